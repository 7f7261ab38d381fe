//! Depth-aware upsampling: how a full-resolution pixel reads an image rendered at a reduced
//! resolution (the cloud march at [`resolution_scale`] below 1, the light-shaft factors) without
//! blending across the edges of near geometry.
//!
//! Each reduced-resolution texel stores its value and the distance its ray ends at
//! ([`ray_end_m`]: the scene's depth or the planet's ground sphere, whichever is nearer, or
//! [`FAR_AWAY`] for the sky). A full-resolution pixel whose own ray ends at `d` blends its four
//! nearest texels with their bilinear weights times `e^(−|d − dᵢ| / (DEPTH_TOLERANCE · min(d,
//! dᵢ)))` ([`depth_weight`]): texels whose rays stopped at other geometry (the sky beside a
//! hill, a hill in front of the sky, the sky above a horizon with no ground geometry) barely
//! count. This is a joint bilateral upsample (Kopf et al. 2007) with a range kernel on relative
//! distance, so one tolerance serves a hill at 500 m and one at 20 km. Where no texel saw this
//! pixel's surface (all weights below `1e-4`: a thin object between texels), the texel nearest
//! in distance wins.
//!
//! # Temporal accumulation
//!
//! With jitter on, each frame samples every ray at other points, so a still view converges by
//! averaging frames. The accumulation keeps a full-resolution history of `(L, T)` and blends each
//! new frame in with weight `α` ([`temporal_resolve`]): an exponential moving average over about
//! `1/α` frames. Before blending, the history is found where this pixel's content was last frame
//! ([`reproject`]: the point at the clouds' distance, or the direction alone for the sky, through
//! last frame's camera), and clamped to the range of the new frame's 3 × 3 neighbourhood, so what
//! moved or was uncovered does not leave a trail (the neighbourhood clamp of temporal
//! anti-aliasing; Karis 2014, "High Quality Temporal Supersampling"). A pixel whose history falls
//! outside last frame's view takes the new frame alone, and so does one whose history saw
//! another surface ([`history_matches`]: the history keeps where each pixel's ray ended), such
//! as the sky coming out from behind a near object: the clamp alone cannot tell, since the pixels
//! the march does not visit are not clamped (below).
//!
//! Every frame the camera moves, the history is read between its texels again, and what each
//! read loses compounds over the `1/α` frames a value lives. So the history is read with a
//! Lanczos-3 filter ([`lanczos3_weights`]), which keeps detail a few pixels across far better
//! than a 4-tap cubic, and a pixel whose content moved takes more of the new frame
//! ([`moving_blend`]), trading a little noise for less blur.
//!
//! # Temporal upsampling
//!
//! A march at a reduced resolution (each texel standing for `k × k` full-resolution pixels,
//! [`upsampling_factor`]) that accumulates frames would converge to the bilinear upsample of its
//! texels, which blurs everything finer than a texel. Instead each frame's rays go through the
//! centre of another of the `k × k` pixels of their texel ([`sample_offset`]), and the new
//! frame is blended only into the pixel its ray went through ([`hit_proximity`]), with the
//! weight [`hit_blend`], which lets each pixel average several of its own samples while it
//! forgets its history within `k` times the frames a full-resolution march takes. The pixels no
//! ray went through keep their history, unclamped ([`temporal_upsample_resolve`]). A still view
//! then converges to the full-resolution image: the unit test
//! `temporal_upsampling_converges_to_the_full_resolution_image` checks that the error on
//! structure finer than a texel falls under a fifth of the error with rays through the texels'
//! centres.
//! Schneider 2015 reconstructs the clouds of Horizon Zero Dawn the same way, marching one pixel
//! of each 4 × 4 block per frame.
//!
//! WGSL twin: `src/render/composite/composite.wgsl` and `temporal.wgsl`.
//!
//! [`resolution_scale`]: crate::render::VolumetricClouds::resolution_scale

use super::render::{MarchSettings, dot, ground_distance};

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

/// Where a view ray ends for the depth-aware upsample and the temporal accumulation, metres:
/// the scene at `t_max` (infinity: none) or the ground sphere, whichever is nearer, as
/// [`stored_distance`]. The camera is at `camera_altitude_m` with local vertical `up`;
/// `direction` is the unit view ray. Rays below the horizon of a scene with no ground geometry
/// end at the planet, not in the sky, so the sky's texels do not bleed below the horizon. The
/// march stores it for each reduced-resolution texel, and each full-resolution pixel computes
/// its own. WGSL twin: `ray_end`.
pub fn ray_end_m(
    settings: &MarchSettings,
    camera_altitude_m: f64,
    up: [f64; 3],
    direction: [f64; 3],
    t_max: f64,
) -> f64 {
    let mu = dot(direction, up).clamp(-1.0, 1.0);
    let ground = ground_distance(camera_altitude_m, mu, settings.planet_radius_m);
    stored_distance(t_max.min(ground))
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

/// The normalised weights of the four texels around a pixel, whose rays stopped at `taps_m`,
/// for a pixel whose ray stops at `pixel_m` (all as [`stored_distance`]): `bilinear` times
/// [`depth_weight`], or, where no texel saw this pixel's surface (total below
/// [`MIN_WEIGHT_SUM`]), the texel nearest in distance alone (the first of equals). WGSL twin:
/// `upsample_weights`.
pub fn upsample_weights(bilinear: [f64; 4], taps_m: [f64; 4], pixel_m: f64) -> [f64; 4] {
    let weights: [f64; 4] = std::array::from_fn(|k| bilinear[k] * depth_weight(taps_m[k], pixel_m));
    let sum: f64 = weights.iter().sum();
    if sum < MIN_WEIGHT_SUM {
        let gap = |k: usize| (taps_m[k] - pixel_m).abs();
        let nearest = (1..4).fold(0, |best, k| if gap(k) < gap(best) { k } else { best });
        return std::array::from_fn(|k| f64::from(u8::from(k == nearest)));
    }
    weights.map(|w| w / sum)
}

/// The value of `image` at the full-resolution pixel centred on `uv` (0–1, origin top left)
/// whose ray stops at `distance_m` (as [`stored_distance`]): the four nearest texels (clamped to
/// the image) blended with [`upsample_weights`]. WGSL twin: the callers of `upsample_weights`
/// (`upsample.wgsl`, `temporal.wgsl`, `upsampled_shafts` in `march.wgsl`).
pub fn upsample<const N: usize>(image: &LowResImage<N>, uv: [f64; 2], distance_m: f64) -> [f64; N] {
    upsample_offset(image, uv, distance_m, [0.0; 2])
}

/// [`upsample`] of an image whose texels were sampled `offset` texels from their centres
/// ([`sample_offset`]): the bilinear weights are those of the points actually sampled. WGSL
/// twin: `footprint_offset` and its callers in `temporal.wgsl`.
pub fn upsample_offset<const N: usize>(
    image: &LowResImage<N>,
    uv: [f64; 2],
    distance_m: f64,
    offset: [f64; 2],
) -> [f64; N] {
    let [width, height] = image.size.map(|s| s.max(1) as i64);
    let position = [
        uv[0] * width as f64 - 0.5 - offset[0],
        uv[1] * height as f64 - 0.5 - offset[1],
    ];
    let base = position.map(f64::floor);
    let fraction = [position[0] - base[0], position[1] - base[1]];
    // Texel k is base + (k & 1, k >> 1), as the WGSL `footprint_texel`.
    let texels: [usize; 4] = std::array::from_fn(|k| {
        let x = (base[0] as i64 + (k & 1) as i64).clamp(0, width - 1);
        let y = (base[1] as i64 + (k >> 1) as i64).clamp(0, height - 1);
        (y * width + x) as usize
    });
    let bilinear = std::array::from_fn(|k| {
        let along = |axis: usize, offset: usize| {
            if offset == 1 {
                fraction[axis]
            } else {
                1.0 - fraction[axis]
            }
        };
        along(0, k & 1) * along(1, k >> 1)
    });
    let weights = upsample_weights(bilinear, texels.map(|t| image.distances_m[t]), distance_m);
    std::array::from_fn(|c| {
        (0..4)
            .map(|k| weights[k] * image.values[texels[k]][c])
            .sum()
    })
}

/// Largest [`upsampling_factor`]: a march at an eighth of the resolution per axis.
pub const MAX_UPSAMPLING_FACTOR: u32 = 8;

/// Full-resolution pixels per reduced-resolution texel along an axis, rounded, 1 to
/// [`MAX_UPSAMPLING_FACTOR`]: the side `k` of the `k × k` pixels one texel stands for, for an
/// image of `full` pixels marched at `low` texels (`[width, height]`; the larger ratio of the
/// two axes). 1 at full resolution. WGSL: computed on the CPU into the uniforms.
pub fn upsampling_factor(full: [u32; 2], low: [u32; 2]) -> u32 {
    let ratio = (0..2)
        .map(|a| f64::from(full[a].max(1)) / f64::from(low[a].max(1)))
        .fold(1.0, f64::max);
    (ratio.round() as u32).clamp(1, MAX_UPSAMPLING_FACTOR)
}

/// The march's image with the temporal upsampling at factor `k` (> 1) for a view of `full`
/// pixels: `⌈full / k⌉` texels per axis, each standing for exactly `k × k` pixels from the view's
/// top left corner, so that every pixel is some texel's sample point once per cycle whatever the
/// view's size; the last texels may reach past the view's edge. WGSL: computed on the CPU
/// (`TemporalUpsampling::size`).
pub fn upsampled_march_size(full: [u32; 2], factor: u32) -> [u32; 2] {
    let k = factor.clamp(1, MAX_UPSAMPLING_FACTOR);
    full.map(|n| n.max(1).div_ceil(k))
}

/// The march image's uv of the view's `uv` with the temporal upsampling at factor `k` (> 1) on a
/// march image of `low` texels ([`upsampled_march_size`]) for a view of `full` pixels:
/// `uv · full / (k · low)`, texel `t` spanning pixels `k t` to `k (t + 1)`. `uv` itself at
/// factor 1. WGSL twin: `uv / temporal.uv_scale` in `temporal.wgsl`.
pub fn march_uv(uv: [f64; 2], full: [u32; 2], low: [u32; 2], factor: u32) -> [f64; 2] {
    if factor <= 1 {
        return uv;
    }
    std::array::from_fn(|a| {
        uv[a] * f64::from(full[a].max(1)) / (f64::from(factor) * f64::from(low[a].max(1)))
    })
}

/// Where this frame's reduced-resolution rays pass through their texels with the temporal
/// upsampling, in texels from the texel's centre (each component in `(−0.5, 0.5)`): the centre
/// of one of the `k × k` full-resolution pixels the texel stands for (`k` =
/// [`upsampling_factor`]), cell `c = frame mod k²`, column `c mod k`, row `(⌊c / k⌋ + c) mod k`.
/// Every cell comes once in `k²` frames, the first `k` along a diagonal, so consecutive frames
/// sample far apart. `[0, 0]` for `k = 1`. WGSL: computed on the CPU into the uniforms.
pub fn sample_offset(frame: u32, factor: u32) -> [f64; 2] {
    let k = factor.clamp(1, MAX_UPSAMPLING_FACTOR);
    let cell = frame % (k * k);
    let (column, row) = (cell % k, (cell / k + cell) % k);
    [column, row].map(|i| (f64::from(i) + 0.5) / f64::from(k) - 0.5)
}

/// `x` clamped to 0–1, NaN read as 1 (a blend weight that keeps the new frame).
fn unit_weight(x: f64) -> f64 {
    if x.is_nan() { 1.0 } else { x.clamp(0.0, 1.0) }
}

/// The weight of the new frame for a pixel whose ray this frame's march passed through, with
/// the march at `1 / k` of the resolution (each pixel visited once in `k²` frames):
/// `1 − (1 − α)^k`, as if it took `alpha` on `k` frames of the `k²`. A still pixel then
/// averages about `(2 − w) / w` of its own samples (4.8 for the default `α = 0.1` at `k = 4`,
/// where the weight is 0.34), which smooths the jitter's noise, and forgets its history in `k`
/// times the frames a full-resolution march with `alpha` takes (moving content faster:
/// [`moving_blend`]). `alpha` itself for `k = 1` (NaN: 1). WGSL: computed on the CPU into
/// `TemporalUniforms::blend`.
pub fn hit_blend(alpha: f64, factor: u32) -> f64 {
    let alpha = unit_weight(alpha);
    match factor.clamp(1, MAX_UPSAMPLING_FACTOR) {
        1 => alpha,
        k => 1.0 - (1.0 - alpha).powi(k as i32),
    }
}

/// Frames a still view's accumulation takes until the first frame weighs under `first_weight`
/// (0–1) in each pixel's running average, with the march at `1 / k` of the resolution: each
/// pixel takes a sample once in `k²` frames with the weight [`hit_blend`], so `k²` times the
/// visits `(1 − w)^n < first_weight` needs. 1 for a weight of 1 or a `first_weight` not in
/// (0, 1).
pub fn settle_frames(alpha: f64, k: u32, first_weight: f64) -> u32 {
    let k = k.clamp(1, MAX_UPSAMPLING_FACTOR);
    let kept = 1.0 - hit_blend(alpha, k);
    if !(kept > 0.0 && first_weight > 0.0 && first_weight < 1.0) {
        return 1;
    }
    let visits = (first_weight.ln() / kept.ln()).ceil().max(1.0) as u32;
    k * k * visits
}

/// The new frame's weight for a pixel whose content moved `motion_px` full-resolution pixels on
/// screen since last frame (the distance between the pixel and its [`reproject`]ed position):
/// `α · (1 + motion_px)`, clamped to 0–1 (NaN `alpha`: 1). A still pixel keeps `alpha`. A moving
/// one forgets its history faster, because the history is resampled again every frame it
/// moves and each resampling loses some detail ([`lanczos3_weights`]); at 0.7 pixel a frame
/// the weight 0.1 becomes 0.17. WGSL twin: `moving_blend` in `temporal.wgsl`.
pub fn moving_blend(alpha: f64, motion_px: f64) -> f64 {
    let motion_px = if motion_px.is_nan() {
        0.0
    } else {
        motion_px.abs()
    };
    unit_weight(unit_weight(alpha) * (1.0 + motion_px))
}

/// How many times farther one of two ray ends may lie than the other and still be the same
/// surface for the history ([`history_matches`]): 2. A pixel's ray end and that of the history
/// texel it reprojects to differ by less between frames wherever they see the same thing (a
/// camera closing in at 10 m/s on a wall 3 m away changes its distance by 6 % a frame at
/// 60 Hz); a near object against the sky or distant land differs by orders of magnitude. WGSL
/// twin: the constant of the same name in `temporal.wgsl`.
pub const HISTORY_DEPTH_RATIO: f64 = 2.0;

/// Whether a history texel whose ray ended at `history_end_m` (as [`stored_distance`]) may be
/// kept by a pixel whose ray ends at `end_m`: the two lie within [`HISTORY_DEPTH_RATIO`] of each
/// other. Where they do not, the pixel shows what last frame's pixel did not (the sky coming out
/// from behind a near object, or an object moving in front of the sky), and the history there
/// is another surface's clouds: kept, it would fade out over `1 / temporal_blend` frames as a
/// trail behind the object. WGSL twin: `history_matches` in `temporal.wgsl`.
pub fn history_matches(history_end_m: f64, end_m: f64) -> bool {
    let (near, far) = if history_end_m < end_m {
        (history_end_m, end_m)
    } else {
        (end_m, history_end_m)
    };
    far <= HISTORY_DEPTH_RATIO * near
}

/// How far from a texel centre, in texels along each axis, a history read may land and still be
/// read as that one texel ([`history_read_snaps`]): 0.001. There the weights the snap drops
/// add up to less than 1 % ([`lanczos3_weights`]), a fifth of the 5 % image error `MEDIUM` is
/// allowed, while a still camera's reprojection lands on the centres up to f32 rounding. WGSL
/// twin: the constant of the same name in `temporal.wgsl`.
pub const HISTORY_SNAP_TEXELS: f64 = 1e-3;

/// Whether the history read at `position` (texel units, texel centres at integers) is the
/// nearest texel itself rather than the Lanczos-3 filter around it: within
/// [`HISTORY_SNAP_TEXELS`] of its centre on both axes. A still camera reads every pixel's
/// history this way, one texel read instead of the filter's 25, and the history's ray end is
/// checked at that texel alone. WGSL twin: `history_read_snaps` in `temporal.wgsl`, which
/// `sample_history` and `history_surface` call.
pub fn history_read_snaps(position: [f64; 2]) -> bool {
    position
        .iter()
        .all(|p| (p - p.round()).abs() <= HISTORY_SNAP_TEXELS)
}

/// The weights with which the history is read at a point `fraction` (0–1) of a texel past the
/// centre of texel `base`, for the texels `base − 2 ..= base + 3` of each axis: a Lanczos-3
/// filter (a sinc windowed by a sinc three texels wide, Duchon 1979), normalised to sum to 1.
/// At `fraction` 0 it is the texel itself. Reprojection resamples the history every frame the
/// camera moves, and the losses compound, so the filter has to keep detail a few pixels across
/// better than a 4-tap cubic does (the test `lanczos3_keeps_detail_through_a_turning_camera`).
/// WGSL twin: `lanczos3_weights` in `temporal.wgsl`.
pub fn lanczos3_weights(fraction: f64) -> [f64; 6] {
    let sinc = |x: f64| {
        if x.abs() < 1e-9 {
            1.0
        } else {
            (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x)
        }
    };
    let weights: [f64; 6] = std::array::from_fn(|i| {
        let x = i as f64 - 2.0 - fraction;
        if x.abs() < 3.0 {
            sinc(x) * sinc(x / 3.0)
        } else {
            0.0
        }
    });
    let sum: f64 = weights.iter().sum();
    weights.map(|w| w / sum)
}

/// How closely this frame's ray passed through the full-resolution pixel centred on `uv`:
/// `Π max(0, 1 − |d|)` over the axes, with `d` the distance in full-resolution pixels from the
/// pixel's centre to the sample of the texel holding it (its centre plus `offset` texels,
/// [`sample_offset`]), on the march image of `low` texels ([`upsampled_march_size`]) whose texels
/// stand for `k × k` pixels each. 1 for the pixel the ray went through, 0 for its neighbours.
/// `full` and `low` are the two images' sizes. 1 everywhere at
/// [`upsampling_factor`] 1 (`factor`): every pixel then takes every frame, as without the
/// upsampling. WGSL twin: the end of `temporal.wgsl`.
pub fn hit_proximity(
    uv: [f64; 2],
    full: [u32; 2],
    low: [u32; 2],
    factor: u32,
    offset: [f64; 2],
) -> f64 {
    if factor <= 1 {
        return 1.0;
    }
    (0..2)
        .map(|a| {
            let n = f64::from(full[a].max(1)) / f64::from(factor);
            let last = f64::from(low[a].max(1)) - 1.0;
            let texel = (uv[a] * n).floor().clamp(0.0, last);
            let sample = (texel + 0.5 + offset[a]) / n;
            let distance = (uv[a] - sample) * f64::from(full[a].max(1));
            (1.0 - distance.abs()).max(0.0)
        })
        .product()
}

/// Where the content of a pixel was in last frame's image, as `uv` (0–1, origin top left), or
/// `None` outside last frame's view (or behind its camera). `previous_clip_from_relative` maps a
/// point relative to this frame's camera to last frame's clip space; the content lies along the
/// unit `direction` at `distance_m` (as [`stored_distance`]; [`FAR_AWAY`] for the sky: a
/// direction, which the camera's motion does not move). WGSL twin: `reproject`.
pub fn reproject(
    previous_clip_from_relative: &[[f64; 4]; 4],
    direction: [f64; 3],
    distance_m: f64,
) -> Option<[f64; 2]> {
    let point = if distance_m >= FAR_AWAY {
        [direction[0], direction[1], direction[2], 0.0]
    } else {
        [
            direction[0] * distance_m,
            direction[1] * distance_m,
            direction[2] * distance_m,
            1.0,
        ]
    };
    // Column-major: column c is previous_clip_from_relative[c].
    let clip: [f64; 4] = std::array::from_fn(|r| {
        (0..4)
            .map(|c| previous_clip_from_relative[c][r] * point[c])
            .sum()
    });
    if clip[3] <= 0.0 {
        return None;
    }
    let ndc = [clip[0] / clip[3], clip[1] / clip[3]];
    let uv = [0.5 * ndc[0] + 0.5, 0.5 - 0.5 * ndc[1]];
    uv.iter().all(|v| (0.0..=1.0).contains(v)).then_some(uv)
}

/// One pixel of the temporal accumulation: `history` (reprojected; `None` where there is none)
/// clamped to `[lo, hi]`, the new frame's neighbourhood range, then blended toward `current` with
/// weight `alpha` (0–1; 1 keeps the new frame alone). WGSL twin: the end of `temporal.wgsl`.
pub fn temporal_resolve<const N: usize>(
    current: [f64; N],
    lo: [f64; N],
    hi: [f64; N],
    history: Option<[f64; N]>,
    alpha: f64,
) -> [f64; N] {
    temporal_upsample_resolve(current, lo, hi, history, alpha, 1.0)
}

/// [`temporal_resolve`] for the temporal upsampling, where this frame's march passed through
/// the pixel with [`hit_proximity`] `proximity` (0–1): the clamp and the blend weight `alpha`
/// (the [`hit_blend`]) both apply in proportion to it. A pixel the march did not sample this
/// frame keeps its history: the new frame holds only an interpolation between other pixels
/// there, and fine structure finer than a texel lies outside its neighbourhood's range, so
/// clamping to it would blur what earlier frames resolved. WGSL twin: the end of
/// `temporal.wgsl`.
pub fn temporal_upsample_resolve<const N: usize>(
    current: [f64; N],
    lo: [f64; N],
    hi: [f64; N],
    history: Option<[f64; N]>,
    alpha: f64,
    proximity: f64,
) -> [f64; N] {
    let Some(history) = history else {
        return current;
    };
    let (alpha, proximity) = (unit_weight(alpha), unit_weight(proximity));
    std::array::from_fn(|c| {
        let clamped = history[c].max(lo[c]).min(hi[c]);
        let kept = history[c] + (clamped - history[c]) * proximity;
        let weight = alpha * proximity;
        kept * (1.0 - weight) + current[c] * weight
    })
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
    fn the_history_of_another_surface_is_not_kept() {
        // The same surface, a frame later: the sky, a wall approached, the ground.
        for (history, now) in [
            (FAR_AWAY, FAR_AWAY),
            (3.0, 2.8),
            (800.0, 1_000.0),
            (0.0, 0.0),
        ] {
            assert!(history_matches(history, now), "{history} -> {now}");
            assert!(history_matches(now, history), "{now} -> {history}");
        }
        // A pole 3 m away against the sky or the clouds' land, either way round.
        for (history, now) in [(3.0, FAR_AWAY), (3.0, 5_000.0), (1_000.0, 2_001.0)] {
            assert!(!history_matches(history, now), "{history} -> {now}");
            assert!(!history_matches(now, history), "{now} -> {history}");
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

    /// Bevy's infinite reverse-Z perspective (near 0.1 m) for a vertical field of view `fov`
    /// and `aspect`, times a camera turned `yaw` radians to the left and moved by `shift`
    /// (world), as seen from the origin: column-major.
    fn clip_from_relative(fov: f64, aspect: f64, yaw: f64, shift: [f64; 3]) -> [[f64; 4]; 4] {
        let f = 1.0 / (fov / 2.0).tan();
        let projection = [
            [f / aspect, 0.0, 0.0, 0.0],
            [0.0, f, 0.0, 0.0],
            [0.0, 0.0, 0.0, -1.0],
            [0.0, 0.0, 0.1, 0.0],
        ];
        // view_from_relative = R(yaw)ᵀ · (x − shift): rotation about +y.
        let (s, c) = yaw.sin_cos();
        let rotation_t = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]; // columns of Rᵀ
        let translation: [f64; 3] =
            std::array::from_fn(|r| -(0..3).map(|k| rotation_t[k][r] * shift[k]).sum::<f64>());
        let view = [
            [rotation_t[0][0], rotation_t[0][1], rotation_t[0][2], 0.0],
            [rotation_t[1][0], rotation_t[1][1], rotation_t[1][2], 0.0],
            [rotation_t[2][0], rotation_t[2][1], rotation_t[2][2], 0.0],
            [translation[0], translation[1], translation[2], 1.0],
        ];
        std::array::from_fn(|c| {
            std::array::from_fn(|r| (0..4).map(|k| projection[k][r] * view[c][k]).sum())
        })
    }

    #[test]
    fn reprojection_follows_the_camera() {
        let fov = 60f64.to_radians();
        let ahead = [0.0, 0.0, -1.0];
        // Same camera: the centre stays the centre.
        let still = clip_from_relative(fov, 16.0 / 9.0, 0.0, [0.0; 3]);
        let [u, v] = reproject(&still, ahead, FAR_AWAY).unwrap();
        assert!((u - 0.5).abs() < 1e-12 && (v - 0.5).abs() < 1e-12);
        // Last frame the camera looked 10° further left: what is ahead now was right of centre,
        // at tan(10°) / (aspect · tan(30°)) of the half-width.
        let turned = clip_from_relative(fov, 16.0 / 9.0, 10f64.to_radians(), [0.0; 3]);
        let [u, _] = reproject(&turned, ahead, FAR_AWAY).unwrap();
        let expected =
            0.5 + 0.5 * 10f64.to_radians().tan() / (16.0 / 9.0 * 30f64.to_radians().tan());
        assert!((u - expected).abs() < 1e-12, "{u} vs {expected}");
        // A camera that moved sideways leaves the sky where it was, and shifts a cloud 1 km
        // ahead by the parallax of the move.
        let moved = clip_from_relative(fov, 1.0, 0.0, [10.0, 0.0, 0.0]);
        let [u, _] = reproject(&moved, ahead, FAR_AWAY).unwrap();
        assert!((u - 0.5).abs() < 1e-12);
        let [u, _] = reproject(&moved, ahead, 1000.0).unwrap();
        let expected = 0.5 - 0.5 * (10.0 / 1000.0) / 30f64.to_radians().tan();
        assert!((u - expected).abs() < 1e-9, "{u} vs {expected}");
        // Behind last frame's camera, or outside its view: no history.
        let behind = clip_from_relative(fov, 1.0, std::f64::consts::PI, [0.0; 3]);
        assert_eq!(reproject(&behind, ahead, FAR_AWAY), None);
        assert_eq!(reproject(&turned, [0.0, 0.0, 1.0], 500.0), None);
    }

    #[test]
    fn the_resolve_blends_a_clamped_history() {
        // Converges on a still input as 1 − (1 − α)ⁿ.
        let mut value = [0.0];
        for _ in 0..10 {
            value = temporal_resolve([1.0], [0.0], [1.0], Some(value), 0.2);
        }
        assert!((value[0] - (1.0 - 0.8f64.powi(10))).abs() < 1e-12);
        // A history outside the new neighbourhood is clamped to it first (no trail).
        let [v] = temporal_resolve([0.5], [0.4], [0.6], Some([5.0]), 0.1);
        assert!((v - (0.6 * 0.9 + 0.5 * 0.1)).abs() < 1e-12);
        // No history, or α = 1: the new frame alone; a NaN α is treated as 1.
        assert_eq!(temporal_resolve([0.3], [0.0], [1.0], None, 0.1), [0.3]);
        assert_eq!(
            temporal_resolve([0.3], [0.0], [1.0], Some([0.9]), 1.0),
            [0.3]
        );
        assert_eq!(
            temporal_resolve([0.3], [0.0], [1.0], Some([0.9]), f64::NAN),
            [0.3]
        );
    }

    /// A camera turning 0.7 pixel a frame: each frame the accumulation reads its history 0.7
    /// pixel along and blends in 10 % of the exact new frame. A cosine a few pixels long must
    /// survive 60 such frames. Lanczos-3 keeps it far better than the 4-tap Catmull-Rom cubic it
    /// replaced; the motion-dependent blend keeps it better still.
    #[test]
    fn lanczos3_keeps_detail_through_a_turning_camera() {
        let catmull_rom = |f: f64| {
            [
                f * (-0.5 + f * (1.0 - 0.5 * f)),
                1.0 + f * f * (-2.5 + 1.5 * f),
                f * (0.5 + f * (2.0 - 1.5 * f)),
                f * f * (-0.5 + 0.5 * f),
            ]
        };
        // Relative RMS error after 60 frames of a cosine of `period` pixels on a ring of 60.
        let turn = |period: f64, first_tap: i64, weights: &dyn Fn(f64) -> Vec<f64>, alpha: f64| {
            let n = 60usize;
            let step = 0.7;
            let exact = |i: usize, frame: usize| {
                (std::f64::consts::TAU * (i as f64 + step * frame as f64) / period).cos()
            };
            let mut history: Vec<f64> = (0..n).map(|i| exact(i, 0)).collect();
            for frame in 1..=60 {
                history = (0..n)
                    .map(|i| {
                        let position = i as f64 + step;
                        let base = position.floor();
                        let taps = weights(position - base);
                        let resampled: f64 = taps
                            .iter()
                            .enumerate()
                            .map(|(k, w)| {
                                let texel =
                                    (base as i64 + first_tap + k as i64).rem_euclid(n as i64);
                                w * history[texel as usize]
                            })
                            .sum();
                        resampled * (1.0 - alpha) + exact(i, frame) * alpha
                    })
                    .collect();
            }
            let error: f64 = (0..n).map(|i| (history[i] - exact(i, 60)).powi(2)).sum();
            let signal: f64 = (0..n).map(|i| exact(i, 60).powi(2)).sum();
            (error / signal).sqrt()
        };
        // Where the read snaps to a texel, the filter it skips is that texel to within 1 %: a
        // fifth of the 5 % relative RMSE `MEDIUM` may differ from the converged image by.
        for fraction in [HISTORY_SNAP_TEXELS, 1.0 - HISTORY_SNAP_TEXELS] {
            let weights = lanczos3_weights(fraction);
            let centre = if fraction < 0.5 { 2 } else { 3 };
            let off: f64 = (0..6)
                .map(|i| (weights[i] - f64::from(u8::from(i == centre))).abs())
                .sum();
            assert!(off < 0.01, "{fraction}: {weights:?}");
        }
        assert!(history_read_snaps([3.0, 7.0005]));
        assert!(history_read_snaps([-2.9995, 0.0]));
        assert!(!history_read_snaps([3.0, 7.01]));
        assert!(!history_read_snaps([3.5, 7.0]));
        let at_centre = lanczos3_weights(0.0);
        for (i, w) in at_centre.into_iter().enumerate() {
            let expected = if i == 2 { 1.0 } else { 0.0 };
            assert!((w - expected).abs() < 1e-12, "{at_centre:?}");
        }
        let lanczos = |f: f64| lanczos3_weights(f).to_vec();
        let cubic = |f: f64| catmull_rom(f).to_vec();
        let moving = moving_blend(0.1, 0.7);
        assert!((moving - 0.17).abs() < 1e-12, "{moving}");
        for period in [3.0, 4.0, 5.0] {
            let new = turn(period, -2, &lanczos, 0.1);
            let old = turn(period, -1, &cubic, 0.1);
            let faster = turn(period, -2, &lanczos, moving);
            eprintln!(
                "a {period}-pixel cosine after 60 frames turning 0.7 pixel a frame: relative \
                 RMS error Catmull-Rom {old:.3}, Lanczos-3 {new:.3}, Lanczos-3 with the moving \
                 blend {faster:.3}"
            );
            // Measured: 3 pixels 0.43 against 0.73, 4 pixels 0.19 against 0.50, 5 pixels 0.20
            // against 0.31.
            assert!(new < 0.67 * old, "{new} vs {old}");
            assert!(faster < new, "{faster} vs {new}");
        }
        // Still, a NaN motion counts as none; the weight never exceeds 1.
        assert_eq!(moving_blend(0.1, 0.0), 0.1);
        assert_eq!(moving_blend(0.1, f64::NAN), 0.1);
        assert_eq!(moving_blend(0.5, 3.0), 1.0);
        assert_eq!(moving_blend(f64::NAN, 1.0), 1.0);
    }

    #[test]
    fn every_pixel_of_a_texel_is_sampled_once_per_cycle() {
        assert_eq!(upsampling_factor([160, 90], [80, 45]), 2);
        assert_eq!(upsampling_factor([161, 91], [81, 46]), 2);
        assert_eq!(upsampling_factor([160, 90], [160, 90]), 1);
        assert_eq!(upsampling_factor([160, 90], [40, 23]), 4);
        assert_eq!(upsampling_factor([0, 0], [0, 0]), 1);
        assert_eq!(
            upsampling_factor([100_000, 1], [1, 1]),
            MAX_UPSAMPLING_FACTOR
        );
        assert_eq!(sample_offset(7, 1), [0.0, 0.0]);
        // At half resolution the rays go through the four pixel centres of their texel, a
        // quarter texel from its centre, diagonal first.
        let cycle: Vec<[f64; 2]> = (0..4).map(|f| sample_offset(f, 2)).collect();
        assert_eq!(
            cycle,
            [[-0.25, -0.25], [0.25, 0.25], [-0.25, 0.25], [0.25, -0.25]]
        );
        assert_eq!(sample_offset(4, 2), sample_offset(0, 2));
        // For each factor, each of a texel's k² pixels is hit (proximity 1) in exactly one frame
        // of the k² of a cycle, and no frame leaves a weight on another pixel.
        // Also where the view's size is not a multiple of k: the march then has ⌈full / k⌉
        // texels, the last ones reaching past the view's edge.
        let sizes = |k: u32| [[5 * k, 3 * k], [5 * k - k / 2, 3 * k - (k - 1)]];
        for (k, full) in (1..=4_u32).flat_map(|k| sizes(k).map(|full| (k, full))) {
            let low = upsampled_march_size(full, k);
            for py in 0..full[1] {
                for px in 0..full[0] {
                    let uv = [
                        (f64::from(px) + 0.5) / f64::from(full[0]),
                        (f64::from(py) + 0.5) / f64::from(full[1]),
                    ];
                    let weights: Vec<f64> = (0..k * k)
                        .map(|f| hit_proximity(uv, full, low, k, sample_offset(f, k)))
                        .collect();
                    let hits = weights.iter().filter(|&&w| (w - 1.0).abs() < 1e-9).count();
                    let others = weights.iter().filter(|&&w| w.abs() > 1e-9).count();
                    assert_eq!(
                        (hits, others),
                        (1, 1),
                        "k {k}, pixel ({px}, {py}): {weights:?}"
                    );
                }
            }
        }
        // At factor 1 every pixel takes every frame, also where the sizes do not divide evenly.
        assert_eq!(
            hit_proximity([0.3, 0.7], [160, 90], [128, 72], 1, [0.0; 2]),
            1.0
        );
        // A pixel visited every k² frames forgets its history over k times the frames a
        // full-resolution march does: after n visits, (1 − w)^n = (1 − α)^(k n).
        let alpha = 0.1;
        for k in [2u32, 4] {
            let w = hit_blend(alpha, k);
            assert!(((1.0 - w).powi(3) - 0.9f64.powi(3 * k as i32)).abs() < 1e-12);
            // And it averages several of its own samples, (2 − w) / w of them: at least 4 at
            // quarter resolution, against 1.5 if it forgot as fast as a pixel blended every
            // frame (1 − (1 − α)^(k²)).
            if k == 4 {
                assert!((2.0 - w) / w > 4.0, "{w}");
            }
        }
        assert_eq!(hit_blend(alpha, 1), alpha);
        assert_eq!(hit_blend(f64::NAN, 2), 1.0);
    }

    #[test]
    fn temporal_upsampling_converges_to_the_full_resolution_image() {
        // A still view of fine structure (periods of 3 and 3.7 pixels), marched at half
        // resolution and accumulated with a blend of 0.1 until the first frame weighs under 1 %
        // (k² times the visits that takes at the hit weight). With the rays always
        // through their texels' centres, the accumulation converges to the bilinear upsample,
        // which blurs the structure away; with the rays visiting each pixel's centre in turn it
        // converges to the full-resolution image, up to the neighbourhood clamp.
        let (full, low) = ([32_u32, 32], [16_u32, 16]);
        let k = upsampling_factor(full, low);
        // The image at a point in full-resolution pixels.
        let scene = |x: f64, y: f64| 0.5 + 0.4 * (x * 2.1).sin() * (y * 1.7).cos();
        let alpha = 0.1;
        let frames = settle_frames(alpha, k, 0.01);
        let run = |upsampling: bool| -> f64 {
            let pixels = (full[0] * full[1]) as usize;
            let mut history: Vec<Option<[f64; 1]>> = vec![None; pixels];
            for frame in 0..frames {
                let offset = if upsampling {
                    sample_offset(frame, k)
                } else {
                    [0.0; 2]
                };
                let texel_value = |tx: u32, ty: u32| {
                    let at = |t: u32, o: f64| (f64::from(t) + 0.5 + o) * f64::from(k);
                    scene(at(tx, offset[0]), at(ty, offset[1]))
                };
                let image = LowResImage {
                    size: low,
                    values: (0..low[1])
                        .flat_map(|ty| (0..low[0]).map(move |tx| [texel_value(tx, ty)]))
                        .collect(),
                    distances_m: vec![FAR_AWAY; (low[0] * low[1]) as usize],
                };
                history = (0..pixels)
                    .map(|p| {
                        let (px, py) = (p as u32 % full[0], p as u32 / full[0]);
                        let uv = [
                            (f64::from(px) + 0.5) / f64::from(full[0]),
                            (f64::from(py) + 0.5) / f64::from(full[1]),
                        ];
                        let current =
                            upsample_offset(&image, march_uv(uv, full, low, k), FAR_AWAY, offset);
                        let (cx, cy) = (px / k, py / k);
                        let (mut lo, mut hi) = (current, current);
                        for ty in cy.saturating_sub(1)..=(cy + 1).min(low[1] - 1) {
                            for tx in cx.saturating_sub(1)..=(cx + 1).min(low[0] - 1) {
                                let [v] = image.values[(ty * low[0] + tx) as usize];
                                lo[0] = lo[0].min(v);
                                hi[0] = hi[0].max(v);
                            }
                        }
                        Some(if upsampling {
                            let proximity = hit_proximity(uv, full, low, k, offset);
                            temporal_upsample_resolve(
                                current,
                                lo,
                                hi,
                                history[p],
                                hit_blend(alpha, k),
                                proximity,
                            )
                        } else {
                            temporal_resolve(current, lo, hi, history[p], alpha)
                        })
                    })
                    .collect();
            }
            let squared: f64 = (0..pixels)
                .map(|p| {
                    let (px, py) = (p as u32 % full[0], p as u32 / full[0]);
                    let truth = scene(f64::from(px) + 0.5, f64::from(py) + 0.5);
                    (history[p].unwrap()[0] - truth).powi(2)
                })
                .sum();
            (squared / pixels as f64).sqrt()
        };
        let (plain, upsampled) = (run(false), run(true));
        println!(
            "RMS error after {frames} frames: texel centres {plain:.4}, pixel centres {upsampled:.4}"
        );
        assert!(
            plain > 0.1,
            "the test image must have structure finer than a texel"
        );
        assert!(upsampled < 0.2 * plain, "{upsampled} against {plain}");
    }

    #[test]
    fn rays_end_at_the_scene_or_the_ground_whichever_is_nearer() {
        let settings = MarchSettings::default();
        let radius = settings.planet_radius_m;
        let up = [0.0, 1.0, 0.0];
        let h = 2.0;
        // Level and up: the sky (no ground ahead), or the scene where there is one.
        assert_eq!(
            ray_end_m(&settings, h, up, [0.0, 0.0, -1.0], f64::INFINITY),
            FAR_AWAY
        );
        assert_eq!(ray_end_m(&settings, h, up, [0.0, 0.6, -0.8], 300.0), 300.0);
        // 1° down from 2 m: the ground sphere at about h / sin(1°) = 115 m (the curvature adds
        // well under a metre).
        let angle = 1f64.to_radians();
        let down = [0.0, -angle.sin(), -angle.cos()];
        let ground = ray_end_m(&settings, h, up, down, f64::INFINITY);
        assert!((ground - h / angle.sin()).abs() < 0.5, "{ground}");
        // A scene in front of the ground ends the ray there; one behind it does not.
        assert_eq!(ray_end_m(&settings, h, up, down, 50.0), 50.0);
        assert_eq!(ray_end_m(&settings, h, up, down, 1_000.0), ground);
        // Just below the horizon, which dips θh = sqrt(2h / R) = 0.045° from 2 m: at θ below
        // level the ground is R (θ − sqrt(θ² − θh²)) away (small angles), 1.9 km at θ = 1.5 θh.
        let horizon = (2.0 * h / radius).sqrt();
        let dip = 1.5 * horizon;
        let grazing = ray_end_m(
            &settings,
            h,
            up,
            [0.0, -dip.sin(), -dip.cos()],
            f64::INFINITY,
        );
        let expected = radius * (dip - (dip * dip - horizon * horizon).sqrt());
        assert!(
            (grazing / expected - 1.0).abs() < 1e-3,
            "{grazing} {expected}"
        );
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
