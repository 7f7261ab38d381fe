//! Cloud shadows in f64: the CPU twin of `src/render/march/shadow.wgsl` (the columns of the map and
//! reading it back) and of the shadow-map pass that runs its `shadow_column`,
//! `src/render/shadow/shadow.wgsl`.
//!
//! # What a shadow-map texel holds
//!
//! The map is an orthographic projection along the sun: every texel stands for one straight line
//! parallel to the sun direction, and every point on that line gets the same value. The value is
//! the fraction of direct sunlight that reaches **the ground** on that line through every cloud
//! layer, `e^(−τ)`, where `τ` is the optical depth from the point where the line meets the ground
//! sphere (on the sun's side) up to space ([`shadow_optical_depth`]). So the shadow falls on the
//! ground away from the sun by `h / tan(elevation)` from the cloud at height `h`, moves with the
//! wind and the sun because the layers and the sun do, and is soft where the clouds are thin
//! because `e^(−τ)` is.
//!
//! The march also reads the map, for the sun of far cloud samples: each texel holds, besides the
//! ground's transmittance, a four-knot "deep shadow map" of its line (Lokovic & Veach 2000,
//! "Deep shadow maps"): the altitudes where the cloud starts and where its optical depth from the
//! top reaches 1 and 4 ([`ShadowColumn`]). The optical depth at any altitude is linear between
//! the knots ([`ShadowMapFrame::column_optical_depth`]), decoded per texel and then blended
//! between the four nearest texels ([`ShadowMapImage::sun_optical_depth`]).
//!
//! Two approximations follow from "one value per line":
//! - a surface point *above* or *inside* a layer (a summit poking through stratus) is shadowed as
//!   if it stood on the ground below, which over-darkens it; Bern's hills are far below the cloud
//!   bases the bundled forecasts produce;
//! - a line that never meets the ground (a very low sun far from the camera) is integrated from
//!   its lowest point.
//!
//! # Texel layout
//!
//! [`ShadowMapFrame`] places the map: a centre, and two axes perpendicular to the sun whose
//! lengths are half the map's extent along each (the plugin fits each to the sky it covers, so
//! with a low sun one is far shorter and its texels finer). Texel `(i, j)` of an `n × n` map
//! (row `j` from the top) is the line through `centre + (1 − 2u)·axis_x + (2v − 1)·axis_y` with `u = (i + ½)/n`,
//! `v = (j + ½)/n`: the mapping Bevy's `DirectionalLightTexture` uses to project a light's
//! texture (`uv = local.xy · (−½, ½) + ½` in the light's scaled frame), so the map can be that
//! texture directly.

use super::render::{
    CloudTextures, MarchLayer, MarchSettings, NO_HIT, add, altitude_along_ray, altitude_of, dot,
    horizontal_axes, intersect_altitude_sphere, is_positive, next_cloud_interval, point_mu_sun,
    scale, total_extinction,
};

/// Most steps per layer interval of the shadow march ([`shadow_optical_depth`]). WGSL twin:
/// `MAX_SHADOW_STEPS`.
pub const MAX_SHADOW_STEPS: u32 = 64;

/// Where a shadow map lies, relative to the camera of the [`MarchSettings`] it is computed
/// with (metres, world axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowMapFrame {
    /// Centre of the map, relative to the camera, m.
    pub centre_m: [f64; 3],
    /// From the centre to the middle of the map's left edge (`u = 0`), m: half the extent along
    /// the light's local x axis. Perpendicular to the sun.
    pub axis_x_m: [f64; 3],
    /// From the centre to the middle of the bottom edge (`v = 1`), m: half the extent along the
    /// light's local y axis. Perpendicular to the sun and to `axis_x_m`.
    pub axis_y_m: [f64; 3],
    /// Texels per side.
    pub size: u32,
    /// `[bottom, top]`: the altitudes above the ground, metres, between which the layers lie
    /// (the lowest base and the highest top). A clear sun line reports `bottom` as its knots.
    pub cloud_range_m: [f64; 2],
}

impl ShadowMapFrame {
    /// The optical depth toward the sun from the point at `altitude_m` on a sun line whose texel
    /// holds `texel` (`[e^(−τ), top, knot₁, knot₂]`, see [`cloud_shadow_map_texels`]): linear in
    /// altitude through the knots `(top, 0)`, `(knot₁, min(1, τ))`, `(knot₂, min(4, τ))` and
    /// `(bottom, τ)`, 0 above, `τ` below. `τ = −ln T` (T at least 10⁻⁷: a half float's range).
    /// WGSL twin: `column_optical_depth`.
    pub fn column_optical_depth(&self, texel: [f64; 4], altitude_m: f64) -> f64 {
        let total = -texel[0].clamp(1e-7, 1.0).ln();
        let knots = [
            (texel[1], 0.0),
            (texel[2], SHADOW_KNOT_DEPTHS[0].min(total)),
            (texel[3], SHADOW_KNOT_DEPTHS[1].min(total)),
            (self.cloud_range_m[0], total),
        ];
        if altitude_m.is_nan() || altitude_m >= knots[0].0 {
            return 0.0;
        }
        for pair in knots.windows(2) {
            let ((za, ta), (zb, tb)) = (pair[0], pair[1]);
            if altitude_m >= zb {
                let f = if za > zb {
                    (za - altitude_m) / (za - zb)
                } else {
                    1.0
                };
                return ta + f * (tb - ta);
            }
        }
        total
    }

    /// A point (relative to the camera) on the sun line of texel `(i, j)`.
    pub fn texel_position(&self, i: u32, j: u32) -> [f64; 3] {
        let n = f64::from(self.size.max(1));
        let u = (f64::from(i) + 0.5) / n;
        let v = (f64::from(j) + 0.5) / n;
        add(
            self.centre_m,
            add(
                scale(self.axis_x_m, 1.0 - 2.0 * u),
                scale(self.axis_y_m, 2.0 * v - 1.0),
            ),
        )
    }

    /// Side of one texel along the map's coarser axis, m: how far apart the sun lines the map
    /// blends lie at most (the march reads the map only beyond a few of these).
    pub fn texel_m(&self) -> f64 {
        self.texel_sides_m()[1]
    }

    /// Side of one texel along the map's finer axis, m: the footprint the shadow march picks
    /// noise mips with, so the map keeps the detail its finer axis resolves.
    pub fn fine_texel_m(&self) -> f64 {
        self.texel_sides_m()[0]
    }

    /// The texel's two sides, shorter first, m.
    fn texel_sides_m(&self) -> [f64; 2] {
        let n = f64::from(self.size.max(1));
        let x = 2.0 * dot(self.axis_x_m, self.axis_x_m).sqrt() / n;
        let y = 2.0 * dot(self.axis_y_m, self.axis_y_m).sqrt() / n;
        [x.min(y), x.max(y)]
    }
}

/// Calls `visit(altitude, [altitudes of the sample's lower and upper ends], optical depth)` for
/// every sample of the sun line through `position_m` (relative to the camera of `settings`), from where the line
/// meets the ground on the sun's side up to space, in that order (rising altitude).
///
/// The march visits only the intervals where the line crosses a layer shell
/// ([`next_cloud_interval`]), with `steps` evenly spaced midpoint samples per interval (at least
/// 1, at most [`MAX_SHADOW_STEPS`]) at full detail, reading noise mips for `footprint_m`. Uses
/// [`MarchSettings::sun_direction`]; the caller decides what a sun below the horizon means (the
/// GPU pass does not run then). A line that misses the ground starts at its lowest point.
fn visit_sun_line(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
    steps: u32,
    footprint_m: f64,
    mut visit: impl FnMut(f64, [f64; 2], f64),
) {
    let radius = settings.planet_radius_m;
    let sun = settings.sun_direction;
    let altitude = altitude_of(settings, position_m);
    let mu = point_mu_sun(
        settings,
        settings.camera_altitude_m,
        settings.camera_up,
        position_m,
        altitude,
    );
    // Light travels along −sun, so it reaches the far root (largest distance toward the sun)
    // first.
    let ground = intersect_altitude_sphere(altitude, mu, radius, 0.0);
    let start = if ground == [NO_HIT, NO_HIT] {
        -(radius + altitude) * mu
    } else {
        ground[1]
    };
    let origin = add(position_m, scale(sun, start));
    let origin_altitude = altitude_along_ray(altitude, mu, start, radius);
    let origin_mu =
        (((radius + altitude) * mu + start) / (radius + origin_altitude)).clamp(-1.0, 1.0);

    let axes = horizontal_axes(settings.camera_up);
    let n = steps.clamp(1, MAX_SHADOW_STEPS);
    let mut t = 0.0;
    for _ in 0..=2 * layers.len() {
        let [a, b] =
            next_cloud_interval(layers, radius, origin_altitude, origin_mu, t, f64::INFINITY);
        if a.is_nan() || b <= a || !b.is_finite() {
            break;
        }
        let dt = (b - a) / f64::from(n);
        for k in 0..n {
            let s = a + (f64::from(k) + 0.5) * dt;
            let point = add(origin, scale(sun, s));
            let point_altitude = altitude_along_ray(origin_altitude, origin_mu, s, radius);
            let horizontal = [dot(point, axes[0]), dot(point, axes[1])];
            let extinction = total_extinction(
                textures,
                layers,
                horizontal,
                point_altitude,
                footprint_m,
                true,
            );
            let end = |u: f64| altitude_along_ray(origin_altitude, origin_mu, s + u * dt, radius);
            visit(point_altitude, [end(-0.5), end(0.5)], extinction * dt);
        }
        t = b;
    }
}

/// Optical depth of every active layer along the sun line through `position_m` (relative to the
/// camera of `settings`), from where the line meets the ground on the sun's side up to space
/// (the samples of `visit_sun_line`). WGSL twin: the first pass of `shadow_column`.
pub fn shadow_optical_depth(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
    steps: u32,
    footprint_m: f64,
) -> f64 {
    let mut total = 0.0;
    visit_sun_line(
        textures,
        settings,
        layers,
        position_m,
        steps,
        footprint_m,
        |_, _, x| total += x,
    );
    total
}

/// Optical depth toward the sun from `position_m` (relative to the camera of `settings`) through
/// the layers above it: the part above the point's altitude of the sun line's samples
/// ([`shadow_optical_depth`]), a sample straddling the point counted by the fraction above it.
/// The CPU queries use it for points under or between layers. No WGSL twin.
pub fn optical_depth_above(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
    steps: u32,
    footprint_m: f64,
) -> f64 {
    let altitude = altitude_of(settings, position_m);
    let mut total = 0.0;
    visit_sun_line(
        textures,
        settings,
        layers,
        position_m,
        steps,
        footprint_m,
        |_, [lower, upper], x| {
            if upper > altitude {
                let above = if lower >= altitude || upper <= lower {
                    1.0
                } else {
                    (upper - altitude) / (upper - lower)
                };
                total += x * above;
            }
        },
    );
    total
}

/// Optical depths from the top of the clouds at which a shadow-map texel records the altitude of
/// its sun line ([`shadow_column`]). WGSL twin: `SHADOW_KNOT_DEPTHS`.
pub const SHADOW_KNOT_DEPTHS: [f64; 2] = [1.0, 4.0];

/// How the optical depth toward the sun grows down one sun line: a small "deep shadow map"
/// (Lokovic & Veach 2000) of four knots, what a shadow-map texel stores.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowColumn {
    /// Optical depth of the whole line.
    pub optical_depth: f64,
    /// Altitude of the upper end of the highest cloudy sample, metres (`bottom_m` when the line
    /// is clear).
    pub top_m: f64,
    /// Altitudes, metres, where the optical depth from the top reaches each of
    /// [`SHADOW_KNOT_DEPTHS`], found by linear interpolation between samples; the lower end of
    /// the lowest cloudy sample where the line's whole depth is less.
    pub knots_m: [f64; 2],
}

/// The [`ShadowColumn`] of the sun line through `position_m`: two passes over the samples of
/// [`shadow_optical_depth`], the first for the whole depth and the cloud's top and bottom, the
/// second for where the depth from the top crosses each knot. `bottom_m` is the altitude a clear
/// line reports. WGSL twin: `shadow_column`.
pub fn shadow_column(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
    steps: u32,
    footprint_m: f64,
    bottom_m: f64,
) -> ShadowColumn {
    let (mut total, mut top, mut lowest) = (0.0, f64::NEG_INFINITY, f64::INFINITY);
    let walk = |visit: &mut dyn FnMut(f64, [f64; 2], f64)| {
        visit_sun_line(
            textures,
            settings,
            layers,
            position_m,
            steps,
            footprint_m,
            visit,
        );
    };
    walk(&mut |_, [lower, upper], x| {
        if x > 0.0 {
            total += x;
            top = top.max(upper);
            lowest = lowest.min(lower);
        }
    });
    if !is_positive(total) {
        return ShadowColumn {
            optical_depth: 0.0,
            top_m: bottom_m,
            knots_m: [bottom_m; 2],
        };
    }
    // Depth from the top at each sample's altitude (half the sample counted), rising from
    // (lowest, total) to (top, 0); a knot lies between the last point deeper than its depth and
    // the first shallower one.
    let mut knots = [lowest; 2];
    let mut below = 0.0;
    let mut previous = (lowest, total);
    let mut cross = |previous: (f64, f64), altitude: f64, depth: f64| {
        for (knot, &level) in knots.iter_mut().zip(&SHADOW_KNOT_DEPTHS) {
            if previous.1 >= level && depth < level {
                let f = (previous.1 - level) / (previous.1 - depth);
                *knot = previous.0 + f * (altitude - previous.0);
            }
        }
    };
    walk(&mut |altitude, _, x| {
        if !is_positive(x) {
            return;
        }
        let depth = total - below - 0.5 * x;
        below += x;
        cross(previous, altitude, depth);
        previous = (altitude, depth);
    });
    cross(previous, top, 0.0);
    ShadowColumn {
        optical_depth: total,
        top_m: top,
        knots_m: knots,
    }
}

/// Fraction of direct sunlight that reaches the ground on the sun line through `position_m`,
/// 0–1: `e^(−τ)` of [`shadow_optical_depth`].
pub fn shadow_transmittance(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
    steps: u32,
    footprint_m: f64,
) -> f64 {
    (-shadow_optical_depth(textures, settings, layers, position_m, steps, footprint_m)).exp()
}

/// The whole map as the GPU pass writes it (before rounding to half floats): `frame.size²`
/// texels, row `j` (from the top) after row `j − 1`, each row `i = 0..size`. A texel is its sun
/// line's [`ShadowColumn`] as `[e^(−τ), top, knot₁, knot₂]`: the first channel is the ground's
/// transmittance, which Bevy's light texture reads; the others let the march read the sun's
/// optical depth at any altitude ([`ShadowMapFrame::column_optical_depth`]).
pub fn cloud_shadow_map_texels(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    frame: &ShadowMapFrame,
    steps: u32,
) -> Vec<[f64; 4]> {
    let footprint = frame.fine_texel_m();
    (0..frame.size)
        .flat_map(|j| (0..frame.size).map(move |i| (i, j)))
        .map(|(i, j)| {
            let column = shadow_column(
                textures,
                settings,
                layers,
                frame.texel_position(i, j),
                steps,
                footprint,
                frame.cloud_range_m[0],
            );
            [
                (-column.optical_depth).exp(),
                column.top_m,
                column.knots_m[0],
                column.knots_m[1],
            ]
        })
        .collect()
}

/// The ground transmittance of every texel of [`cloud_shadow_map_texels`]: the map's first
/// channel.
pub fn cloud_shadow_map(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    frame: &ShadowMapFrame,
    steps: u32,
) -> Vec<f64> {
    cloud_shadow_map_texels(textures, settings, layers, frame, steps)
        .into_iter()
        .map(|texel| texel[0])
        .collect()
}

/// A cloud shadow map as the GPU holds it: its frame and texels ([`cloud_shadow_map_texels`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowMapImage {
    /// Where the map lies, relative to the camera of the view that reads it.
    pub frame: ShadowMapFrame,
    /// `frame.size²` texels, `[T, top, knot₁, knot₂]`.
    pub texels: Vec<[f64; 4]>,
}

impl ShadowMapImage {
    /// The map's texture coordinates `(u, v)` of the sun line through `position_m`: the inverse
    /// of [`ShadowMapFrame::texel_position`]. WGSL twin: `shadow_map_uv`.
    pub fn uv(frame: &ShadowMapFrame, position_m: [f64; 3]) -> [f64; 2] {
        let q = add(position_m, scale(frame.centre_m, -1.0));
        let x = dot(q, frame.axis_x_m) / dot(frame.axis_x_m, frame.axis_x_m);
        let y = dot(q, frame.axis_y_m) / dot(frame.axis_y_m, frame.axis_y_m);
        [0.5 * (1.0 - x), 0.5 * (1.0 + y)]
    }

    /// The four texels around `uv` and their bilinear weights (texel centres at `(i + ½)/n`,
    /// wrapping like a repeating sampler).
    fn taps(&self, [u, v]: [f64; 2]) -> [(usize, f64); 4] {
        let n = self.frame.size.max(1);
        let nf = f64::from(n);
        let (x, y) = (u * nf - 0.5, v * nf - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wrap = |i: f64| (i as i64).rem_euclid(i64::from(n)) as usize;
        let index = |i: f64, j: f64| wrap(j) * n as usize + wrap(i);
        [
            (index(x0, y0), (1.0 - fx) * (1.0 - fy)),
            (index(x0 + 1.0, y0), fx * (1.0 - fy)),
            (index(x0, y0 + 1.0), (1.0 - fx) * fy),
            (index(x0 + 1.0, y0 + 1.0), fx * fy),
        ]
    }

    /// The map's coordinates of the sun line through `position_m`, `None` outside the map.
    fn covering_uv(&self, position_m: [f64; 3]) -> Option<[f64; 2]> {
        let uv = Self::uv(&self.frame, position_m);
        uv.iter().all(|c| (0.0..=1.0).contains(c)).then_some(uv)
    }

    /// The texel on the sun line through `position_m` (relative to the camera), filtered
    /// bilinearly between texel centres as a repeating linear sampler does; `None` outside the
    /// map. WGSL twin: `sample_shadow_map`.
    pub fn sample(&self, position_m: [f64; 3]) -> Option<[f64; 4]> {
        let uv = self.covering_uv(position_m)?;
        Some(self.taps(uv).iter().fold([0.0; 4], |sum, &(index, w)| {
            std::array::from_fn(|k| sum[k] + w * self.texels[index][k])
        }))
    }

    /// The sun's transmittance through the clouds to the ground on the sun line through
    /// `position_m` (the light shafts' read); `None` outside the map. WGSL twin: the map read
    /// of `sun_visibility`.
    pub fn ground_transmittance(&self, position_m: [f64; 3]) -> Option<f64> {
        self.sample(position_m).map(|texel| texel[0])
    }

    /// The optical depth toward the sun from `position_m` at `altitude_m`: each of the four
    /// nearest texels decoded ([`ShadowMapFrame::column_optical_depth`]), then blended
    /// bilinearly (blending the knots first would mix a cloud's top with a clear neighbour's);
    /// `None` outside the map. WGSL twin: `map_sun_optical_depth`.
    pub fn sun_optical_depth(&self, position_m: [f64; 3], altitude_m: f64) -> Option<f64> {
        let uv = self.covering_uv(position_m)?;
        Some(self.taps(uv).iter().fold(0.0, |sum, &(index, w)| {
            sum + w * self
                .frame
                .column_optical_depth(self.texels[index], altitude_m)
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::super::render::{NoiseTexture2d, NoiseTexture3d};
    use super::*;

    /// Textures whose weather noise is one Gaussian blob of radius `sigma` (in texture units) at
    /// the texture centre, on a zero background; the 3D noise is a constant (the test layers are
    /// slabs, shape strength 0).
    fn blob_textures(size: u32, sigma: f64) -> CloudTextures {
        let flat = NoiseTexture3d::from_level0(&[[0.5; 4]], 1);
        let texels: Vec<[f64; 4]> = (0..size * size)
            .map(|index| {
                let x = (f64::from(index % size) + 0.5) / f64::from(size) - 0.5;
                let y = (f64::from(index / size) + 0.5) / f64::from(size) - 0.5;
                let w = (-(x * x + y * y) / (2.0 * sigma * sigma)).exp();
                [w, 0.0, 0.0, 0.0]
            })
            .collect();
        CloudTextures {
            base: flat.clone(),
            detail: flat,
            weather: NoiseTexture2d::from_texels(&texels, size),
        }
    }

    /// A thin slab between `base` and `top` over a camera on the ground, whose weather period is
    /// `period` metres with the blob centred straight above the camera.
    fn blob_layer(base: f64, top: f64, extinction: f64, period: f64) -> MarchLayer {
        let mut layer = MarchLayer {
            base_m: base,
            top_m: top,
            coverage: 0.6,
            extinction,
            weather_scale_m: period,
            shape_strength: 0.0,
            ..Default::default()
        };
        layer.set_profile(&[]);
        // The look-up at horizontal 0 reads uv = offset / period = ½: the blob's centre.
        layer.weather_offset_m = [0.5 * period; 2];
        layer
    }

    /// A homogeneous slab 1–2 km up (coverage 1: overcast) of extinction `sigma`, and a map of
    /// `size`² texels centred on the camera, `half_m` metres to each side.
    fn slab_under_map(sigma: f64, half_m: f64, size: u32) -> ([MarchLayer; 1], ShadowMapFrame) {
        let mut layer = blob_layer(1000.0, 2000.0, sigma, 20_000.0);
        layer.coverage = 1.0;
        let frame = ShadowMapFrame {
            centre_m: [0.0, 0.0, 0.0],
            axis_x_m: [-half_m, 0.0, 0.0],
            axis_y_m: [0.0, 0.0, half_m],
            size,
            cloud_range_m: [1000.0, 2000.0],
        };
        ([layer], frame)
    }

    fn settings_with_sun(elevation_deg: f64, azimuth_from_north_deg: f64) -> MarchSettings {
        let (e, a) = (
            elevation_deg.to_radians(),
            azimuth_from_north_deg.to_radians(),
        );
        // Scene axes: +x east, −z north, +y up.
        MarchSettings {
            camera_altitude_m: 0.0,
            camera_up: [0.0, 1.0, 0.0],
            sun_direction: [e.cos() * a.sin(), e.sin(), -e.cos() * a.cos()],
            ..Default::default()
        }
    }

    /// Shadow transmittance on a ground grid of `n × n` points, `spacing` metres apart, centred
    /// on the camera: returns the (x, z) centroid of `1 − T` and the grid.
    fn ground_shadow(
        textures: &CloudTextures,
        settings: &MarchSettings,
        layer: &MarchLayer,
        n: usize,
        spacing: f64,
        centre: [f64; 2],
    ) -> ([f64; 2], Vec<f64>) {
        let mut grid = Vec::with_capacity(n * n);
        let (mut sx, mut sz, mut sw) = (0.0, 0.0, 0.0);
        for row in 0..n {
            for col in 0..n {
                let x = centre[0] + (col as f64 - (n as f64 - 1.0) / 2.0) * spacing;
                let z = centre[1] + (row as f64 - (n as f64 - 1.0) / 2.0) * spacing;
                let t = shadow_transmittance(
                    textures,
                    settings,
                    std::slice::from_ref(layer),
                    [x, 0.0, z],
                    16,
                    0.0,
                );
                let w = 1.0 - t;
                sx += w * x;
                sz += w * z;
                sw += w;
                grid.push(t);
            }
        }
        ([sx / sw, sz / sw], grid)
    }

    #[test]
    fn shadow_falls_away_from_the_sun_by_height_over_tan_elevation() {
        let textures = blob_textures(64, 0.06);
        let layer = blob_layer(1000.0, 1200.0, 0.02, 20_000.0);
        // The point under the cloud: the centroid of the shadow with the sun at the zenith.
        let zenith = settings_with_sun(90.0, 180.0);
        let (under, _) = ground_shadow(&textures, &zenith, &layer, 48, 100.0, [0.0, 0.0]);
        assert!(under[0].abs() < 5.0 && under[1].abs() < 5.0, "{under:?}");

        // Sun at 30° elevation in the south: the shadow lies north (−z) by h / tan 30°, h the
        // middle of the slab (its density is uniform in height).
        let low_sun = settings_with_sun(30.0, 180.0);
        let expected = 1100.0 / 30f64.to_radians().tan();
        let (shadow, _) = ground_shadow(
            &textures,
            &low_sun,
            &layer,
            48,
            100.0,
            [0.0, -expected * 0.8],
        );
        let north = under[1] - shadow[1];
        assert!(
            (north - expected).abs() < 0.05 * expected,
            "shadow {north:.1} m north, expected {expected:.1} m"
        );
        assert!((shadow[0] - under[0]).abs() < 0.05 * expected, "{shadow:?}");
    }

    #[test]
    fn penumbra_widens_as_density_falls() {
        let textures = blob_textures(256, 0.06);
        let settings = settings_with_sun(60.0, 180.0);
        // 10–90 % width of the shadow edge along a north-south line through the shadow. The
        // densities keep the blob's core opaque (optical depth 2 to 10 through the 200 m slab):
        // below that the 10 % level sits inside the coverage ramp's own width (about 280 m
        // here) and the edge is the ramp's, not the penumbra's.
        let widths: Vec<f64> = [0.05, 0.025, 0.015, 0.01]
            .iter()
            .map(|&extinction| {
                let layer = blob_layer(1000.0, 1200.0, extinction, 20_000.0);
                let offset = -1100.0 / 60f64.to_radians().tan();
                let profile: Vec<f64> = (0..400)
                    .map(|k| {
                        let x = f64::from(k) * 10.0;
                        shadow_transmittance(
                            &textures,
                            &settings,
                            std::slice::from_ref(&layer),
                            [x, 0.0, offset],
                            16,
                            0.0,
                        )
                    })
                    .collect();
                let at = |level: f64| {
                    profile
                        .iter()
                        .position(|&t| t >= level)
                        .map_or(f64::NAN, |k| k as f64 * 10.0)
                };
                at(0.9) - at(0.1_f64.max(profile[0] + 0.1 * (1.0 - profile[0])))
            })
            .collect();
        assert!(widths.iter().all(|w| w.is_finite()), "{widths:?}");
        assert!(
            widths.windows(2).all(|w| w[1] >= w[0]),
            "penumbra must widen as density falls: {widths:?}"
        );
        assert!(widths[3] > 1.5 * widths[0], "{widths:?}");
    }

    #[test]
    fn clear_sky_and_inactive_layers_cast_no_shadow() {
        let textures = blob_textures(16, 0.1);
        let settings = settings_with_sun(40.0, 200.0);
        let mut layer = blob_layer(1000.0, 1200.0, 0.05, 20_000.0);
        layer.coverage = 0.0;
        let t = shadow_transmittance(&textures, &settings, &[layer], [0.0, 0.0, 0.0], 16, 0.0);
        assert_eq!(t, 1.0);
        assert_eq!(
            shadow_transmittance(&textures, &settings, &[], [0.0; 3], 16, 0.0),
            1.0
        );
    }

    #[test]
    fn homogeneous_overcast_matches_beer_lambert_along_the_slant_path() {
        let textures = blob_textures(16, 0.1);
        let settings = settings_with_sun(35.0, 150.0);
        let mut layer = blob_layer(800.0, 1400.0, 0.004, 20_000.0);
        layer.coverage = 1.0;
        let layers = [layer];
        let t = shadow_transmittance(&textures, &settings, &layers, [0.0; 3], 8, 0.0);
        // Plane-parallel path 600 m / sin 35°; on the sphere the line climbs faster by
        // t² cos² / 2R (0.3 m at the top), which shortens the path by 0.04 %.
        let expected_depth = 0.004 * 600.0 / 35f64.to_radians().sin();
        let depth = -t.ln();
        assert!(
            (depth - expected_depth).abs() < 1e-3 * expected_depth,
            "{depth} vs {expected_depth}"
        );
        assert!(depth < expected_depth, "curvature shortens the path");
        // Every point on the same sun line reads the same value.
        let along = add([0.0; 3], scale(settings.sun_direction, 5_000.0));
        let t_along = shadow_transmittance(&textures, &settings, &layers, along, 8, 0.0);
        assert!((t_along - t).abs() < 1e-9, "{t_along} vs {t}");
    }

    #[test]
    fn hard_cases_stay_finite_and_in_range() {
        let textures = blob_textures(16, 0.1);
        let layer = blob_layer(1000.0, 1200.0, 0.05, 20_000.0);
        let thick = MarchLayer {
            extinction: 1e4,
            coverage: 1.0,
            ..layer.clone()
        };
        let thin = MarchLayer {
            extinction: 1e-9,
            coverage: 1.0,
            ..layer.clone()
        };
        for elevation in [90.0, 60.0, 5.0, 0.5, 0.01] {
            for camera_altitude in [0.0, 1000.0, 1100.0, 1200.0, 50_000.0] {
                let settings = MarchSettings {
                    camera_altitude_m: camera_altitude,
                    ..settings_with_sun(elevation, 123.0)
                };
                for position in [
                    [0.0; 3],
                    [1e5, -3.0, -2e5],
                    [0.0, 1100.0 - camera_altitude, 0.0],
                    [-4e6, 0.0, 1e6],
                ] {
                    for layers in [[layer.clone()], [thick.clone()], [thin.clone()]] {
                        let t =
                            shadow_transmittance(&textures, &settings, &layers, position, 16, 50.0);
                        assert!(
                            t.is_finite() && (0.0..=1.0).contains(&t),
                            "T {t} at elevation {elevation}, camera {camera_altitude}, {position:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn map_levels_give_the_sun_optical_depth_inside_a_slab() {
        // The slab under a map 2 km across, sun 40° high.
        let textures = blob_textures(16, 0.2);
        let sigma = 0.002;
        let (layers, frame) = slab_under_map(sigma, 1000.0, 8);
        let settings = settings_with_sun(40.0, 180.0);
        let map = ShadowMapImage {
            frame,
            texels: cloud_shadow_map_texels(&textures, &settings, &layers, &frame, 12),
        };
        let mu = 40f64.to_radians().sin();
        for altitude in [1100.0, 1500.0, 1900.0, 2500.0, 500.0] {
            let point = [0.0, altitude, 0.0];
            let from_map = map.sun_optical_depth(point, altitude).unwrap();
            let exact = sigma * (2000.0 - altitude.clamp(1000.0, 2000.0)) / mu;
            assert!(
                (from_map - exact).abs() <= 0.01 * exact + 1e-9,
                "{altitude} m: map {from_map}, exact {exact}"
            );
        }
        // The ground channel is the whole column.
        let ground = map.ground_transmittance([0.0, 0.0, 0.0]).unwrap();
        assert!(
            (ground - (-sigma * 1000.0 / mu).exp()).abs() < 1e-3,
            "{ground}"
        );
        assert!(map.sample([5000.0, 0.0, 0.0]).is_none(), "outside the map");
    }

    /// A sample reads its sun from the map only where the map may light it
    /// ([`shadow_map_share`](crate::reference::render::shadow_map_share)): a map with a wrong
    /// optical depth (50 on every sun line below the slab's top) changes a ray away from a 40°
    /// sun, and leaves a ray toward it, and a ray under a 5° sun, exactly as the light march has
    /// them.
    #[test]
    fn the_map_lights_samples_away_from_a_high_sun_only() {
        let textures = blob_textures(16, 0.2);
        let (layers, frame) = slab_under_map(0.002, 10_000.0, 256);
        // Optical depth 50 from just under the top down.
        let dark = ShadowMapImage {
            frame,
            texels: vec![[(-50.0f64).exp(), 2000.0, 1999.0, 1998.0]; 256 * 256],
        };
        let radiance = |elevation_deg: f64, direction: [f64; 3], map: Option<&ShadowMapImage>| {
            let settings = MarchSettings {
                sun_from_shadow_map_m: 0.0,
                ..settings_with_sun(elevation_deg, 180.0)
            };
            crate::reference::render::march_clouds(
                &textures,
                &settings,
                &layers,
                0.0,
                [0.0, 1.0, 0.0],
                direction,
                f64::INFINITY,
                0.5,
                map,
            )
            .radiance[1]
        };
        // 60° up toward the north, the sun in the south: cos 80° from a 40° sun.
        let north = [0.0, 60f64.to_radians().sin(), -60f64.to_radians().cos()];
        let (marched, from_map) = (
            radiance(40.0, north, None),
            radiance(40.0, north, Some(&dark)),
        );
        assert!(
            (from_map - marched).abs() > 0.1 * marched,
            "away from a 40° sun the map is read: {from_map} vs {marched}"
        );
        // Straight at the sun (south, 40° up).
        let sunward = [0.0, 40f64.to_radians().sin(), 40f64.to_radians().cos()];
        assert_eq!(
            radiance(40.0, sunward, Some(&dark)),
            radiance(40.0, sunward, None)
        );
        assert_eq!(
            radiance(5.0, north, Some(&dark)),
            radiance(5.0, north, None)
        );
    }

    #[test]
    fn texel_layout_matches_bevy_light_texture_projection() {
        let frame = ShadowMapFrame {
            centre_m: [10.0, 0.0, 0.0],
            axis_x_m: [100.0, 0.0, 0.0],
            axis_y_m: [0.0, 0.0, 100.0],
            size: 4,
            cloud_range_m: [1000.0, 4000.0],
        };
        // The knots: τ 0 at the top (4000 m), 1 at 3500 m, 4 at 2000 m, τ = 9 at the bottom.
        let texel = [(-9.0f64).exp(), 4000.0, 3500.0, 2000.0];
        let depth = |altitude: f64| frame.column_optical_depth(texel, altitude);
        assert_eq!(depth(5000.0), 0.0);
        assert_eq!(depth(4000.0), 0.0);
        assert!((depth(3750.0) - 0.5).abs() < 1e-12);
        assert!((depth(2750.0) - 2.5).abs() < 1e-12);
        assert!((depth(1500.0) - 6.5).abs() < 1e-9);
        assert!((depth(10.0) - 9.0).abs() < 1e-9);
        assert_eq!(depth(f64::NAN), 0.0);
        // A thin column (τ 0.5) saturates at its own depth.
        let thin = [(-0.5f64).exp(), 3000.0, 2500.0, 2500.0];
        assert!((frame.column_optical_depth(thin, 2000.0) - 0.5).abs() < 1e-12);
        assert!((frame.column_optical_depth(thin, 2750.0) - 0.25).abs() < 1e-12);
        // Texel (0, 0) is at u = v = 1/8: local x = 0.75, y = −0.75.
        let p = frame.texel_position(0, 0);
        assert_eq!(p, [10.0 + 75.0, 0.0, -75.0]);
        assert!((frame.texel_m() - 50.0).abs() < 1e-12);
    }
}
