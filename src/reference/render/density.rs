//! The density model in f64 (Pérez Martín 2022, "Density Model"; Schneider 2015). WGSL twin:
//! `src/render/march/density.wgsl`.
//!
//! [`layer_density`]: the height fraction in the layer picks a density from the layer's
//! profile (Aetherius' shape-altering curve, piecewise linear here); the weather noise sets a
//! local coverage ([`local_coverage`] per weather texel, filtered by [`weather_coverage`]); the
//! base noise (Perlin-Worley carved by Worley fBm,
//! [`base_shape`]) times the profile is remapped by that coverage; the detail noise erodes the
//! edges, wispy at the bottom and billowy at the top ([`detail_erosion`]). The result, 0–1, scales
//! the layer's extinction. [`MarchLayer::shape_strength`] blends the noise in: at 0 a layer is a
//! homogeneous slab whose density is the profile shaped by coverage only, which has a closed form
//! ([`homogeneous_slab`]).

use super::{
    CloudTextures, MAX_PROFILE_POINTS, MarchLayer, NoiseTexture2d, is_positive, layer_coverage,
    layer_is_active, lerp, saturate, unorm8,
};
#[cfg(doc)]
use super::{homogeneous_slab, horizontal_axes};

/// Fraction of the scattering albedo that full precipitation removes: a raining layer
/// ([`MarchLayer::precipitation`] = 1) scatters half of what it extinguishes. An artistic
/// darkening (rain clouds look dark mostly because they are thick), kept in one place.
pub const PRECIPITATION_ABSORPTION: f64 = 0.5;

/// Most detail erosion applied, so the erosion remap `(d − e) / (1 − e)` never divides by zero.
pub const MAX_DETAIL_EROSION: f64 = 0.9;

/// Height fraction over which the detail erosion turns from wispy (at the base) to billowy: seed
/// 002 blends with `saturate(height_fraction * 5)`, i.e. over the bottom fifth.
pub const DETAIL_TRANSITION_HEIGHT: f64 = 0.2;

/// Weights of the three Worley fBm channels (G, B, A) of the base texture in the low-frequency
/// fBm that carves the Perlin-Worley channel (Pérez Martín 2022, Figure 36: 0.625, 0.25, 0.125). The
/// detail fBm weighs its R, G, B channels the same way.
pub const FBM_WEIGHTS: [f64; 3] = [0.625, 0.25, 0.125];

/// The layer's profile at `height_fraction` (0 base, 1 top): piecewise linear between its
/// points, the end values held beyond them, 1 with no points. Aetherius' shape-altering curve
/// (Pérez Martín 2022, "Density Model"), baked to at most [`MAX_PROFILE_POINTS`] points. WGSL twin:
/// `profile_density`.
pub fn profile_density(layer: &MarchLayer, height_fraction: f64) -> f64 {
    let count = (layer.profile_points as usize).min(MAX_PROFILE_POINTS);
    if count == 0 {
        return 1.0;
    }
    let points = &layer.profile[..count];
    let h = height_fraction;
    if h <= points[0][0] {
        return points[0][1];
    }
    for pair in points.windows(2) {
        let ([h0, d0], [h1, d1]) = (pair[0], pair[1]);
        if h <= h1 {
            let span = h1 - h0;
            return if span > 0.0 {
                lerp(d0, d1, (h - h0) / span)
            } else {
                d1
            };
        }
    }
    points[count - 1][1]
}

/// The integral of the layer's profile ([`profile_density`]) from the base up to
/// `height_fraction` (clamped to 0–1), in height fractions: the column of a cloud at full density
/// below that height, over the layer's extinction and thickness. Exact for the piecewise-linear
/// profile. WGSL twin: `profile_column`.
pub fn profile_column(layer: &MarchLayer, height_fraction: f64) -> f64 {
    let h = saturate(height_fraction);
    let count = (layer.profile_points as usize).min(MAX_PROFILE_POINTS);
    if count == 0 {
        return h;
    }
    let points = &layer.profile[..count];
    // Before the first point the first value holds.
    let mut total = points[0][1] * h.min(points[0][0]).max(0.0);
    for pair in points.windows(2) {
        let ([h0, d0], [h1, d1]) = (pair[0], pair[1]);
        if h <= h0 {
            return total;
        }
        let top = h.min(h1);
        if top > h0 {
            let end = if h1 > h0 {
                lerp(d0, d1, (top - h0) / (h1 - h0))
            } else {
                d1
            };
            total += 0.5 * (d0 + end) * (top - h0);
        }
    }
    let last = points[count - 1];
    total + last[1] * (h - last[0]).max(0.0)
}

/// Range of the weather noise's coverage channel that [`local_coverage`] stretches to 0–1: about
/// its 3rd and 98th percentiles for the default noise recipe (measured on 128² texels: median
/// 0.72), so coverage reads as a fraction of the sky.
pub const WEATHER_COVERAGE_RANGE: [f64; 2] = [0.4, 0.95];

/// Width, in stretched weather units, of the ramp from clear to full local coverage at the edge
/// of a cloud field in [`local_coverage`]: narrow gives sharp-edged fields, wide gives soft ones.
pub const COVERAGE_EDGE_WIDTH: f64 = 0.25;

/// Layer coverage from which [`local_coverage`] blends toward overcast, reaching 1 everywhere at
/// coverage 1 (the weather pattern alone would leave its lowest values clear).
pub const OVERCAST_COVERAGE: f64 = 0.9;

/// Local coverage in the middle of a cloudy patch while the layer is broken: the base shape must
/// exceed `1 − PATCH_COVERAGE` (times the profile) to hold cloud, so the shape noise carves
/// separate heaps out of each patch instead of filling it from edge to edge.
///
/// For the default noise recipe the base shape spans 0.63–0.98 between its 5th and 90th
/// percentiles (median 0.84, measured on the 128³ texels), so a threshold of 0.75 leaves about
/// two thirds of a patch cloudy at the profile's peak and less toward its ends.
pub const PATCH_COVERAGE: f64 = 0.25;

/// How much more of the map the cloudy patches cover than the layer's coverage, up to
/// [`BROKEN_PATCH_AREA`]. The carving inside the patches takes the cloudy fraction of the sky back
/// down, so that it follows the coverage.
pub const PATCH_AREA_GAIN: f64 = 2.5;

/// Most of the map the cloudy patches cover while the layer is broken (below
/// [`CLOSING_COVERAGE`]). The clear quarter keeps the weather pattern in view at every coverage:
/// without it the patches merge from coverage 0.4 on and only the shape noise, which repeats
/// every [`MarchLayer::shape_scale_m`], structures the sky, so its repeats line up along grazing
/// rays into streaks toward the horizon.
pub const BROKEN_PATCH_AREA: f64 = 0.75;

/// Layer coverage from which the peak of the local coverage rises from [`PATCH_COVERAGE`] to 1
/// and the patches spread from [`BROKEN_PATCH_AREA`] to the whole map (both reached at coverage
/// 1), so that the heaps merge and the layer closes to overcast.
pub const CLOSING_COVERAGE: f64 = 0.75;

/// Local coverage `κ`, 0–1, from the layer's `coverage` (0–1) and the weather noise's coverage
/// channel `weather` (0–1): where the weather map makes clouds form and how much of the shape
/// noise becomes cloud there (Pérez Martín 2022, "Density Model").
///
/// The weather value is stretched over [`WEATHER_COVERAGE_RANGE`] to `w`. Cloudy patches cover
/// about `area = min(PATCH_AREA_GAIN · coverage, BROKEN_PATCH_AREA)` of the map: the patch field
/// ramps from 0 at `w = 1 − area` to 1 over [`COVERAGE_EDGE_WIDTH`]. Inside a patch `κ` reaches
/// the peak [`PATCH_COVERAGE`]. From [`CLOSING_COVERAGE`] to coverage 1 the peak rises to 1 and
/// the area to the whole map; above [`OVERCAST_COVERAGE`] `κ` blends to 1 everywhere. Coverage
/// 0 gives exactly 0 everywhere and coverage 1 exactly 1 (overcast). WGSL twin:
/// `local_coverage`.
pub fn local_coverage(coverage: f64, weather: f64) -> f64 {
    if !is_positive(coverage) {
        return 0.0;
    }
    let [low, high] = WEATHER_COVERAGE_RANGE;
    let w = saturate((weather - low) / (high - low));
    let closing = saturate((coverage - CLOSING_COVERAGE) / (1.0 - CLOSING_COVERAGE));
    let area = lerp(
        (PATCH_AREA_GAIN * coverage).min(BROKEN_PATCH_AREA),
        1.0,
        closing,
    );
    let field = saturate((w - (1.0 - area)) / COVERAGE_EDGE_WIDTH);
    let peak = lerp(PATCH_COVERAGE, 1.0, closing);
    let overcast = saturate((coverage - OVERCAST_COVERAGE) / (1.0 - OVERCAST_COVERAGE));
    (field * peak).max(overcast)
}

/// How full a patch is where the local coverage is `κ`: `saturate(κ / PATCH_COVERAGE)`, 1 from
/// the middle of a broken layer's patch up. It scales the density, so the carved heaps are as
/// dense as a full layer's clouds, and it sets how high the profile reaches
/// ([`coverage_height_scale`]), so the heaps stand tallest in the middle of their patch.
/// WGSL twin: `patch_fill`.
pub fn patch_fill(kappa: f64) -> f64 {
    saturate(kappa / PATCH_COVERAGE)
}

/// Local coverage `κ` of weather texel `texel` (an index along the noise axes, not wrapped: the
/// texel at the camera is near `weather_offset_m / weather_scale_m · n`): [`local_coverage`] of
/// the texel's coverage channel and of the layer's coverage ([`layer_coverage`]) at the texel's
/// centre, `(texel + 0.5) · weather_scale_m / n − weather_offset_m` from the camera. A coverage
/// of 1 there is overcast without reading the texel. The weather-map pass stores exactly these
/// values (see [`crate::reference::weather_map`]). WGSL twin: `weather_texel_coverage`.
pub fn weather_texel_coverage(
    weather: &NoiseTexture2d,
    layer: &MarchLayer,
    texel: [i64; 2],
) -> f64 {
    let n = weather.size.max(1);
    let texel_m = layer.weather_scale_m / f64::from(n);
    let centre = [0, 1].map(|a| (texel[a] as f64 + 0.5) * texel_m - layer.weather_offset_m[a]);
    let coverage = layer_coverage(layer, centre);
    if coverage >= 1.0 {
        return 1.0;
    }
    let size = n;
    let n = i64::from(n);
    let [x, y] = texel.map(|i| i.rem_euclid(n) as usize);
    if let Some(growth) = &layer.growth {
        return growth_coverage(coverage, growth.cover_at([x, y], size));
    }
    local_coverage(coverage, unorm8(weather.texels[x + n as usize * y][0]))
}

/// Local coverage `κ`, 0–1, of a layer whose clouds grow ([`MarchLayer::growth`]), from the
/// layer's `coverage` (0–1) and the cloud fraction `cover` (0–1) of the automaton's column
/// there: the patch peak of [`local_coverage`] ([`PATCH_COVERAGE`], rising to 1 from
/// [`CLOSING_COVERAGE`]) times `cover` over [`GROWTH_FULL_COVER`] (at most 1), so a column with
/// that share of its cells in cloud is a full patch the shape noise carves and one with a single
/// cloud cell a thinner one; above [`OVERCAST_COVERAGE`] it blends to 1 like
/// [`local_coverage`]. Coverage 0 gives 0. WGSL twin: `growth_coverage`.
pub fn growth_coverage(coverage: f64, cover: f64) -> f64 {
    if !is_positive(coverage) {
        return 0.0;
    }
    let closing = saturate((coverage - CLOSING_COVERAGE) / (1.0 - CLOSING_COVERAGE));
    let peak = lerp(PATCH_COVERAGE, 1.0, closing);
    let overcast = saturate((coverage - OVERCAST_COVERAGE) / (1.0 - OVERCAST_COVERAGE));
    (saturate(cover / GROWTH_FULL_COVER) * peak).max(overcast)
}

/// The share of a column's cells in cloud from which [`growth_coverage`] makes it a full patch:
/// the automaton's clouds fill a few of a column's cells, rarely all.
pub const GROWTH_FULL_COVER: f64 = 0.25;

/// The weather texel `(index, weight)` pairs a bilinear look-up of coordinate `c` (texture
/// units) on `n` texels reads along one axis: texel centres at `(i + 0.5) / n`, indices not
/// wrapped. WGSL twin: the first lines of `weather_coverage`.
pub fn weather_taps(c: f64, n: u32) -> [(i64, f64); 2] {
    let x = c * f64::from(n) - 0.5;
    let floor = x.floor();
    let weight = x - floor;
    let i0 = floor as i64;
    [(i0, 1.0 - weight), (i0 + 1, weight)]
}

/// The weather texels and weights, per axis ([`weather_taps`]), of a layer's weather look-up at
/// `horizontal_m` (relative to the camera, along the noise axes) and `height_above_base_m` on
/// `n` texels: `(horizontal + weather_offset + skew · height) / weather_scale`. WGSL twin: the
/// first lines of `weather_coverage` and `shape_warp`.
pub(super) fn weather_look_up(
    n: u32,
    layer: &MarchLayer,
    horizontal_m: [f64; 2],
    height_above_base_m: f64,
) -> [[(i64, f64); 2]; 2] {
    [0, 1].map(|a| {
        let uv =
            (horizontal_m[a] + layer.weather_offset_m[a] + layer.skew[a] * height_above_base_m)
                / layer.weather_scale_m;
        weather_taps(uv, n)
    })
}

/// Local coverage `κ`, 0–1, of a layer at `horizontal_m` (relative to the camera, along the noise
/// axes) and `height_above_base_m`: the bilinear filter of [`weather_texel_coverage`] over the
/// four weather texels around the look-up `(horizontal + weather_offset + skew · height) /
/// weather_scale`.
///
/// The coverage remap is applied per texel and then filtered (rather than filtering the noise
/// and then remapping), so the GPU can cache the texel values in its weather map and read them
/// with the same four taps: inside the map and outside it the result is the same function. The
/// weather noise varies slowly against the remap (κ changes by 0.06 per texel at the median
/// edge texel of the default noise), so the two orders differ little. WGSL twin:
/// `weather_coverage`.
pub fn weather_coverage(
    weather: &NoiseTexture2d,
    layer: &MarchLayer,
    horizontal_m: [f64; 2],
    height_above_base_m: f64,
) -> f64 {
    let n = weather.size.max(1);
    let taps = weather_look_up(n, layer, horizontal_m, height_above_base_m);
    let mut kappa = 0.0;
    for corner in 0..4_usize {
        let (x, wx) = taps[0][corner & 1];
        let (y, wy) = taps[1][corner >> 1];
        if wx * wy > 0.0 {
            kappa += wx * wy * weather_texel_coverage(weather, layer, [x, y]);
        }
    }
    kappa
}

/// Largest displacement of the base-shape look-up by the fine warp, as a fraction of
/// [`MarchLayer::shape_scale_m`] (500 m at the default 4 km period): see [`shape_warp`].
///
/// The base shape repeats every period, and a ray that grazes a layer crosses tens of periods. Its
/// optical depth then depends on its lateral position alone, the same in every period, and the
/// repeats add up to streaks that run toward the vanishing point. Displacing each period by a
/// different amount breaks that sum. An eighth of a period removed the streaks in the `showcase`
/// renders while the heaps kept round shapes; a quarter swirled and sheared them visibly.
pub const SHAPE_WARP: f64 = 0.125;

/// Largest displacement of the base-shape look-up by the broad warp, as a fraction of
/// [`MarchLayer::shape_scale_m`] (2 km at the default 4 km period): see [`shape_warp`].
///
/// The fine warp follows the weather noise's curl, which varies over a few hundred metres; an
/// eighth of a period is as far as it can displace the shape before it tears the heaps apart,
/// and that left a fan of streaks toward the vanishing point where a view looks along a noise
/// axis over tens of kilometres of cloud (the fine look-up's slope reaches 1.8 at an eighth of
/// a period and 7 at half a period, folding the shape over itself). The broad warp varies over
/// [`BROAD_WARP_PERIODS`] shape periods: it reaches 0.42 of a period with a slope of 0.63 at
/// its steepest (unit test `the_broad_warp_displaces_far_without_folding_the_shape`), so
/// consecutive periods along a ray are displaced by different amounts while no heap folds.
pub const SHAPE_WARP_BROAD: f64 = 0.5;

/// Period of the broad warp ([`SHAPE_WARP_BROAD`]), in shape periods (128 km at the default
/// 4 km): the weather noise's curl looked up over this period, so its finest octave (a sixteenth
/// of the weather noise) spans two shape periods.
pub const BROAD_WARP_PERIODS: f64 = 32.0;

/// The weather noise's curl (channels B and A, each `0.5 + 0.5 · curl / range`) as `2c − 1`
/// per axis, −1 to 1, filtered bilinearly from the four weather texels of `taps`
/// ([`weather_taps`] per axis). WGSL twin: `curl_look_up`.
pub(crate) fn curl_look_up(weather: &NoiseTexture2d, taps: [[(i64, f64); 2]; 2]) -> [f64; 2] {
    let size = i64::from(weather.size.max(1));
    let mut curl = [0.0; 2];
    for corner in 0..4_usize {
        let (x, wx) = taps[0][corner & 1];
        let (y, wy) = taps[1][corner >> 1];
        let texel = weather.texels[(x.rem_euclid(size) + size * y.rem_euclid(size)) as usize];
        for (c, channel) in curl.iter_mut().zip([texel[2], texel[3]]) {
            *c += wx * wy * (2.0 * unorm8(channel) - 1.0);
        }
    }
    curl
}

/// The broad curl's look-up per axis, in weather-noise texel units (texel centres at integers)
/// on `n` texels, for the weather look-up `x` in the same units ([`weather_look_up`]): the
/// skewed horizontal point of `x` plus the warp offset, over [`BROAD_WARP_PERIODS`] shape
/// periods. Affine in `x`, axis by axis. WGSL twin: `broad_look_up`.
pub(super) fn broad_look_up(n: u32, layer: &MarchLayer, x: [f64; 2]) -> [f64; 2] {
    let n = f64::from(n);
    let texel_m = layer.weather_scale_m / n;
    let broad_period = BROAD_WARP_PERIODS * layer.shape_scale_m;
    [0, 1].map(|a| {
        let skewed_m = (x[a] + 0.5) * texel_m - layer.weather_offset_m[a];
        (skewed_m + layer.warp_offset_m[a]) / broad_period * n - 0.5
    })
}

/// The shape warp at weather texel `texel` (not wrapped), in shape periods per axis: the sum of
/// two warps, both from the weather noise's curl (`curl_look_up`).
///
/// - The fine warp, `±`[`SHAPE_WARP`] of the shape period: the curl of the texel itself. It
///   varies over the weather period, which is not a multiple of the shape period, so
///   consecutive repeats of the shape are displaced differently.
/// - The broad warp, `±`[`SHAPE_WARP_BROAD`] of the shape period: the curl looked up over
///   [`BROAD_WARP_PERIODS`] shape periods at the texel's centre (where
///   [`weather_texel_coverage`] takes the layer's coverage) plus the warp offset. It varies
///   slowly, so it displaces far apart repeats by up to a period without shearing any one heap.
///
/// The GPU's weather map stores exactly this per texel. WGSL twin: `texel_shape_warp`.
pub fn texel_shape_warp(weather: &NoiseTexture2d, layer: &MarchLayer, texel: [i64; 2]) -> [f64; 2] {
    let n = weather.size.max(1);
    let broad = curl_look_up(
        weather,
        broad_look_up(n, layer, texel.map(|i| i as f64))
            .map(|b| weather_taps((b + 0.5) / f64::from(n), n)),
    );
    let fine = curl_look_up(weather, texel.map(|i| [(i, 1.0), (i + 1, 0.0)]));
    [0, 1].map(|a| SHAPE_WARP * fine[a] + SHAPE_WARP_BROAD * broad[a])
}

/// Displacement of the base-shape look-up at a point, metres along the noise axes: the bilinear
/// filter of [`texel_shape_warp`] over the four weather texels [`weather_coverage`] reads, so
/// the weather map caches it with the coverage and a sample inside the map reads four texels
/// for both.
///
/// The broad warp follows the weather's skew, as the coverage does. Both warps are periodic in
/// their look-up's period, and the wrapped offsets keep them continuous. Neither depends on the
/// camera, so the view ray, the light march and the shadow map see the same shapes. WGSL twin:
/// `shape_warp` (which reads one broad curl instead of four where the four texel centres share
/// a broad texel cell: the same value, as the broad curl is bilinear in each cell).
pub fn shape_warp(
    weather: &NoiseTexture2d,
    layer: &MarchLayer,
    horizontal_m: [f64; 2],
    height_above_base_m: f64,
) -> [f64; 2] {
    let n = weather.size.max(1);
    let taps = weather_look_up(n, layer, horizontal_m, height_above_base_m);
    let mut warp = [0.0; 2];
    for corner in 0..4_usize {
        let (x, wx) = taps[0][corner & 1];
        let (y, wy) = taps[1][corner >> 1];
        if wx * wy > 0.0 {
            let texel = texel_shape_warp(weather, layer, [x, y]);
            for (w, t) in warp.iter_mut().zip(texel) {
                *w += wx * wy * t;
            }
        }
    }
    warp.map(|w| w * layer.shape_scale_m)
}

/// The fraction of the layer's thickness the profile is stretched over where a cloudy patch is
/// filled to `f` (0–1, the [`patch_fill`] of the local coverage), for
/// [`MarchLayer::coverage_height`] `s`: `1 − s · (1 − f)²`. 1 in a full patch or at `s = 0`. At
/// `s = 1` it is `f (2 − f)`: a cloud's top falls steeply at the edge of its patch and levels
/// off toward the middle, a rounded dome rather than the cone a linear `f` would give (a half
/// full patch reaches three quarters of the way up). Never below `f`, so positive wherever `f`
/// is. WGSL twin: `coverage_height_scale`.
pub fn coverage_height_scale(coverage_height: f64, fill: f64) -> f64 {
    let s = if coverage_height.is_nan() {
        0.0
    } else {
        coverage_height.clamp(0.0, 1.0)
    };
    let gap = 1.0 - fill;
    1.0 - s * gap * gap
}

/// Linear remap of `value` from `[old_min, old_max]` to `[new_min, new_max]` (Pérez Martín 2022, Figure
/// 30). WGSL twin: `remap`.
pub fn remap(value: f64, old_min: f64, old_max: f64, new_min: f64, new_max: f64) -> f64 {
    new_min + (value - old_min) / (old_max - old_min) * (new_max - new_min)
}

/// The billowy base shape from a base-texture sample: the Perlin-Worley channel R carved by the
/// low-frequency Worley fBm of G, B, A (weights [`FBM_WEIGHTS`]),
/// `saturate(remap(R, fbm − 1, 1, 0, 1))` (Pérez Martín 2022, Figure 36; Schneider 2015). WGSL twin:
/// `base_shape`.
pub fn base_shape(sample: [f64; 4]) -> f64 {
    let fbm = sample[1] * FBM_WEIGHTS[0] + sample[2] * FBM_WEIGHTS[1] + sample[3] * FBM_WEIGHTS[2];
    saturate(remap(sample[0], fbm - 1.0, 1.0, 0.0, 1.0))
}

/// Detail erosion amount, 0–1, from a detail-texture sample at `height_fraction`: the detail
/// fBm (R, G, B weighted by [`FBM_WEIGHTS`]) near the base and its inverse above
/// [`DETAIL_TRANSITION_HEIGHT`], so the bottoms erode into wisps and the tops into billows
/// (Pérez Martín 2022, Figure 36: `lerp(fbm, 1 − fbm, saturate(h · 5))`; Schneider 2015). WGSL twin:
/// `detail_erosion`.
pub fn detail_erosion(sample: [f64; 4], height_fraction: f64) -> f64 {
    let fbm = sample[0] * FBM_WEIGHTS[0] + sample[1] * FBM_WEIGHTS[1] + sample[2] * FBM_WEIGHTS[2];
    lerp(
        fbm,
        1.0 - fbm,
        saturate(height_fraction / DETAIL_TRANSITION_HEIGHT),
    )
}

/// Mip level for a sample whose footprint is `footprint_m` on a texture whose texels are
/// `texel_m` apart: `log2(footprint / texel)`, at least 0 (Pérez Martín 2022, "LODs Over Distance").
/// WGSL twin: `texture_lod`.
pub fn texture_lod(footprint_m: f64, texel_m: f64) -> f64 {
    (footprint_m / texel_m).max(1.0).log2()
}

/// Extinction coefficient, 1/m, of one layer at a point: `horizontal_m` are its coordinates
/// along [`horizontal_axes`] relative to the camera, metres, `altitude_m` its altitude above the
/// ground; `footprint_m` picks the mip levels ([`texture_lod`]). `with_detail = false` is the
/// cheap base-only density of the two-level march: never smaller than the full one, so it finds
/// every cloud the full density would.
///
/// Pérez Martín 2022's model ("Density Model"; Schneider 2015): the profile at the height fraction times
/// the base shape (looked up displaced by [`shape_warp`]), remapped by the local coverage `κ`
/// as `saturate(remap(shape · profile, 1 − κ, 1, 0, 1)) · fill`, with `fill` the
/// [`patch_fill`] of `κ`, then eroded by the detail, `saturate(remap(d, erosion, 1, 0, 1))`. The shape and the erosion are blended in by
/// [`MarchLayer::shape_strength`]; at 0 there is no noise and a layer of coverage 1 is exactly
/// its profile. Coverage 0 returns exactly 0. WGSL twin: `layer_density`.
pub fn layer_density(
    textures: &CloudTextures,
    layer: &MarchLayer,
    horizontal_m: [f64; 2],
    altitude_m: f64,
    footprint_m: f64,
    with_detail: bool,
) -> f64 {
    let inside = altitude_m >= layer.base_m && altitude_m <= layer.top_m;
    if !layer_is_active(layer) || !inside {
        return 0.0;
    }
    let height_above_base = altitude_m - layer.base_m;
    let height_fraction = height_above_base / (layer.top_m - layer.base_m);
    let kappa = weather_coverage(&textures.weather, layer, horizontal_m, height_above_base);
    if !is_positive(kappa) {
        return 0.0;
    }
    let fill = patch_fill(kappa);
    let profile = profile_density(
        layer,
        height_fraction / coverage_height_scale(layer.coverage_height, fill),
    );
    if !is_positive(profile) {
        return 0.0;
    }
    let strength = saturate(layer.shape_strength);
    let mut shape = 1.0;
    if strength > 0.0 {
        let warp = shape_warp(&textures.weather, layer, horizontal_m, height_above_base);
        let uvw = [
            (horizontal_m[0] + layer.shape_offset_m[0] + warp[0]) / layer.shape_scale_m,
            altitude_m / layer.shape_scale_m,
            (horizontal_m[1] + layer.shape_offset_m[1] + warp[1]) / layer.shape_scale_m,
        ];
        let texel_m = layer.shape_scale_m / f64::from(textures.base.size);
        let sample = textures.base.sample(uvw, texture_lod(footprint_m, texel_m));
        shape = lerp(1.0, base_shape(sample), strength);
    }
    let covered = saturate(remap(shape * profile, 1.0 - kappa, 1.0, 0.0, 1.0)) * fill;
    let erosion_strength = layer.detail_erosion.clamp(0.0, MAX_DETAIL_EROSION) * strength;
    if !with_detail || !is_positive(erosion_strength) || !is_positive(covered) {
        return covered * layer.extinction;
    }
    let uvw = [
        (horizontal_m[0] + layer.detail_offset_m[0]) / layer.detail_scale_m,
        altitude_m / layer.detail_scale_m,
        (horizontal_m[1] + layer.detail_offset_m[1]) / layer.detail_scale_m,
    ];
    let texel_m = layer.detail_scale_m / f64::from(textures.detail.size);
    let sample = textures
        .detail
        .sample(uvw, texture_lod(footprint_m, texel_m));
    let erosion = erosion_strength * detail_erosion(sample, height_fraction);
    saturate(remap(covered, erosion, 1.0, 0.0, 1.0)) * layer.extinction
}

/// Sum of [`layer_density`] over `layers` at one point: the extinction every sample of the march,
/// the light march and the shadow map sees. WGSL twin: `total_extinction`.
pub fn total_extinction(
    textures: &CloudTextures,
    layers: &[MarchLayer],
    horizontal_m: [f64; 2],
    altitude_m: f64,
    footprint_m: f64,
    with_detail: bool,
) -> f64 {
    layers
        .iter()
        .map(|layer| {
            layer_density(
                textures,
                layer,
                horizontal_m,
                altitude_m,
                footprint_m,
                with_detail,
            )
        })
        .sum()
}

/// Scattering albedo of a layer: 1 (cloud droplets barely absorb) lowered by precipitation
/// ([`PRECIPITATION_ABSORPTION`]). WGSL twin: `scattering_albedo`.
pub fn scattering_albedo(layer: &MarchLayer) -> f64 {
    1.0 - PRECIPITATION_ABSORPTION * saturate(layer.precipitation)
}
