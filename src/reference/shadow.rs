//! Cloud shadows in f64: the CPU twin of `src/render/shadow/shadow.wgsl` (and of
//! `shadow_optical_depth` in `src/render/march/clouds.wgsl`).
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
//! lengths are half the map's extent. Texel `(i, j)` of an `n × n` map (row `j` from the top) is
//! the line through `centre + (1 − 2u)·axis_x + (2v − 1)·axis_y` with `u = (i + ½)/n`,
//! `v = (j + ½)/n`: the mapping Bevy's `DirectionalLightTexture` uses to project a light's
//! texture (`uv = local.xy · (−½, ½) + ½` in the light's scaled frame), so the map can be that
//! texture directly.

use super::render::{
    CloudTextures, MarchLayer, MarchSettings, NO_HIT, add, altitude_along_ray, altitude_of, dot,
    horizontal_axes, intersect_altitude_sphere, next_cloud_interval, scale, total_extinction,
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
}

impl ShadowMapFrame {
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

    /// Side of one texel, m (the footprint the shadow march picks noise mips with).
    pub fn texel_m(&self) -> f64 {
        2.0 * dot(self.axis_x_m, self.axis_x_m).sqrt() / f64::from(self.size.max(1))
    }
}

/// Optical depth of every active layer along the sun line through `position_m` (relative to the
/// camera of `settings`), from where the line meets the ground on the sun's side up to space.
///
/// The march visits only the intervals where the line crosses a layer shell
/// ([`next_cloud_interval`]), with `steps` evenly spaced midpoint samples per interval (at least
/// 1, at most [`MAX_SHADOW_STEPS`]) at full detail, reading noise mips for `footprint_m`. Uses
/// [`MarchSettings::sun_direction`]; the caller decides what a sun below the horizon means (the
/// GPU pass does not run then). WGSL twin: `shadow_optical_depth`.
pub fn shadow_optical_depth(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    position_m: [f64; 3],
    steps: u32,
    footprint_m: f64,
) -> f64 {
    let radius = settings.planet_radius_m;
    let sun = settings.sun_direction;
    let altitude = altitude_of(settings, position_m);
    let mu = ((radius + settings.camera_altitude_m) * dot(sun, settings.camera_up)
        + dot(sun, position_m))
        / (radius + altitude);
    let mu = mu.clamp(-1.0, 1.0);
    // Light travels along −sun, so it reaches the far root (largest distance toward the sun)
    // first. A line that misses the ground starts at its lowest point.
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
    let mut optical_depth = 0.0;
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
            optical_depth += extinction * dt;
        }
        t = b;
    }
    optical_depth
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

/// The whole map: `frame.size²` transmittances, row `j` (from the top) after row `j − 1`, each
/// row `i = 0..size`. What the GPU pass writes (before 8-bit quantisation).
pub fn cloud_shadow_map(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    frame: &ShadowMapFrame,
    steps: u32,
) -> Vec<f64> {
    let footprint = frame.texel_m();
    (0..frame.size)
        .flat_map(|j| (0..frame.size).map(move |i| (i, j)))
        .map(|(i, j)| {
            shadow_transmittance(
                textures,
                settings,
                layers,
                frame.texel_position(i, j),
                steps,
                footprint,
            )
        })
        .collect()
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
        let textures = blob_textures(64, 0.06);
        let settings = settings_with_sun(60.0, 180.0);
        // 10–90 % width of the shadow edge along a north-south line through the shadow.
        let widths: Vec<f64> = [0.05, 0.02, 0.008, 0.003]
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
    fn texel_layout_matches_bevy_light_texture_projection() {
        let frame = ShadowMapFrame {
            centre_m: [10.0, 0.0, 0.0],
            axis_x_m: [100.0, 0.0, 0.0],
            axis_y_m: [0.0, 0.0, 100.0],
            size: 4,
        };
        // Texel (0, 0) is at u = v = 1/8: local x = 0.75, y = −0.75.
        let p = frame.texel_position(0, 0);
        assert_eq!(p, [10.0 + 75.0, 0.0, -75.0]);
        assert!((frame.texel_m() - 50.0).abs() < 1e-12);
    }
}
