//! Depth-aware upsampling: how a full-resolution pixel reads an image rendered at a reduced
//! resolution (the cloud march at [`resolution_scale`] below 1, the light-shaft factors) without
//! blending across the edges of near geometry.
//!
//! Each reduced-resolution texel stores its value and the distance its ray was stopped at (the
//! scene's depth, or [`FAR_AWAY`] for the sky). A full-resolution pixel whose own ray stops at
//! `d` blends its four nearest texels with their bilinear weights times
//! `e^(−|d − dᵢ| / (DEPTH_TOLERANCE · min(d, dᵢ)))` ([`depth_weight`]): texels whose rays stopped
//! at other geometry (the sky beside a hill, a hill in front of the sky) barely count. This is a
//! joint bilateral upsample (Kopf et al. 2007) with a range kernel on relative distance, so one
//! tolerance serves a hill at 500 m and one at 20 km. Where no texel saw this pixel's surface
//! (all weights below `1e-4`: a thin object between texels), the texel nearest in distance wins.
//!
//! WGSL twin: `src/render/composite/composite.wgsl`.
//!
//! [`resolution_scale`]: crate::render::VolumetricClouds::resolution_scale

/// The distance a ray that meets no geometry (the sky) is stopped at, metres; the GPU's
/// largest comfortable f32. WGSL twin: `FAR_AWAY`.
pub const FAR_AWAY: f64 = 3.0e38;

/// Distances within this fraction of each other count as the same surface (weight `e^(−1)` at
/// this relative gap). WGSL twin: `DEPTH_TOLERANCE`.
pub const DEPTH_TOLERANCE: f64 = 0.05;

/// Below this total weight no texel saw the pixel's surface. WGSL twin: `MIN_WEIGHT_SUM`.
pub const MIN_WEIGHT_SUM: f64 = 1e-4;

/// `distance_m` as the GPU stores it: infinity and anything beyond [`FAR_AWAY`] become
/// [`FAR_AWAY`]; NaN too (a ray with no defined end is treated as sky).
pub fn stored_distance(distance_m: f64) -> f64 {
    if distance_m.is_nan() {
        FAR_AWAY
    } else {
        distance_m.clamp(0.0, FAR_AWAY)
    }
}

/// How much a texel whose ray stopped at `tap_m` counts for a pixel whose ray stops at
/// `pixel_m` (both as [`stored_distance`]), before the bilinear weight: 1 for the same distance,
/// `e^(−1)` at a relative gap of [`DEPTH_TOLERANCE`]. WGSL twin: `depth_weight`.
pub fn depth_weight(tap_m: f64, pixel_m: f64) -> f64 {
    let gap = (tap_m - pixel_m).abs();
    let scale = DEPTH_TOLERANCE * tap_m.min(pixel_m).max(1e-3);
    (-gap / scale).exp()
}

/// A reduced-resolution image for [`upsample`]: per texel, `N` values and the distance its ray
/// stopped at. Row-major, `size[0]` texels per row, `size[1]` rows, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct LowResImage<const N: usize> {
    /// Texels per side, `[width, height]`.
    pub size: [u32; 2],
    /// The texels' values.
    pub values: Vec<[f64; N]>,
    /// The texels' ray-end distances, metres (as [`stored_distance`]).
    pub distances_m: Vec<f64>,
}

/// The value of `image` at the full-resolution pixel centred on `uv` (0–1, origin top left)
/// whose ray stops at `distance_m` (as [`stored_distance`]): see the module docs. WGSL twin: the
/// loop in `upsample.wgsl`, and `upsampled_shafts` in `march.wgsl`.
pub fn upsample<const N: usize>(image: &LowResImage<N>, uv: [f64; 2], distance_m: f64) -> [f64; N] {
    let [width, height] = image.size.map(|s| s.max(1) as i64);
    let position = [uv[0] * width as f64 - 0.5, uv[1] * height as f64 - 0.5];
    let base = position.map(f64::floor);
    let fraction = [position[0] - base[0], position[1] - base[1]];
    let mut sum = [0.0; N];
    let mut weight_sum = 0.0;
    let mut nearest = [0.0; N];
    let mut nearest_gap = f64::INFINITY;
    for k in 0..4 {
        let offset = [k & 1, k >> 1];
        let x = (base[0] as i64 + offset[0]).clamp(0, width - 1);
        let y = (base[1] as i64 + offset[1]).clamp(0, height - 1);
        let index = (y * width + x) as usize;
        let (value, tap) = (image.values[index], image.distances_m[index]);
        let bilinear = [0, 1]
            .map(|axis| {
                if offset[axis] == 1 {
                    fraction[axis]
                } else {
                    1.0 - fraction[axis]
                }
            })
            .iter()
            .product::<f64>();
        let weight = bilinear * depth_weight(tap, distance_m);
        for (s, v) in sum.iter_mut().zip(value) {
            *s += weight * v;
        }
        weight_sum += weight;
        let gap = (tap - distance_m).abs();
        if gap < nearest_gap {
            nearest_gap = gap;
            nearest = value;
        }
    }
    if weight_sum < MIN_WEIGHT_SUM {
        return nearest;
    }
    sum.map(|s| s / weight_sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: [f64; 4], distances: [f64; 4]) -> LowResImage<1> {
        LowResImage {
            size: [2, 2],
            values: values.iter().map(|&v| [v]).collect(),
            distances_m: distances.to_vec(),
        }
    }

    #[test]
    fn equal_distances_give_the_bilinear_blend() {
        let sky = [FAR_AWAY; 4];
        let img = image([0.0, 1.0, 2.0, 3.0], sky);
        // The texel centres sit at uv 0.25 and 0.75: the middle is the mean.
        let [middle] = upsample(&img, [0.5, 0.5], FAR_AWAY);
        assert!((middle - 1.5).abs() < 1e-12, "{middle}");
        // A quarter of the way from the first to the second column.
        let [v] = upsample(&img, [0.375, 0.25], FAR_AWAY);
        assert!((v - 0.25).abs() < 1e-12, "{v}");
        // Beyond the edge texels: clamped, no extrapolation.
        let [corner] = upsample(&img, [0.0, 0.0], FAR_AWAY);
        assert!((corner - 0.0).abs() < 1e-12, "{corner}");
    }

    #[test]
    fn a_near_surface_ignores_texels_of_the_sky_behind_it() {
        // Left column: a hill 800 m away; right column: the sky.
        let img = image([10.0, 99.0, 10.0, 99.0], [800.0, FAR_AWAY, 800.0, FAR_AWAY]);
        let [hill] = upsample(&img, [0.5, 0.5], 810.0);
        assert!((hill - 10.0).abs() < 1e-6, "{hill}");
        let [sky] = upsample(&img, [0.5, 0.5], FAR_AWAY);
        assert!((sky - 99.0).abs() < 1e-6, "{sky}");
        // A plain bilinear blend would give the middle value to both.
        assert!((depth_weight(800.0, 800.0) - 1.0).abs() < 1e-12);
        assert!((depth_weight(800.0, 840.0) - (-1.0f64).exp()).abs() < 1e-12);
    }

    #[test]
    fn a_surface_no_texel_saw_takes_the_nearest_in_distance() {
        // A pole 50 m away between texels of hills at 2 km and 5 km.
        let img = image([1.0, 2.0, 3.0, 4.0], [2_000.0, 5_000.0, 2_000.0, 5_000.0]);
        let [pole] = upsample(&img, [0.5, 0.5], 50.0);
        assert_eq!(pole, 1.0);
    }

    #[test]
    fn stored_distances_stay_finite() {
        assert_eq!(stored_distance(f64::INFINITY), FAR_AWAY);
        assert_eq!(stored_distance(f64::NAN), FAR_AWAY);
        assert_eq!(stored_distance(-3.0), 0.0);
        assert_eq!(stored_distance(12.5), 12.5);
        for (a, b) in [(0.0, 0.0), (0.0, FAR_AWAY), (FAR_AWAY, FAR_AWAY)] {
            let w = depth_weight(a, b);
            assert!((0.0..=1.0).contains(&w), "{a} {b}: {w}");
        }
    }
}
