//! A tileable blue-noise threshold map for the march's ray-start jitter.
//!
//! Jitter trades the banding of fixed step positions for noise; the kind of noise decides what
//! the eye sees. White noise clumps; interleaved gradient noise has no clumps but repeats along
//! rows every three pixels or so, which reads as fine diagonal hatching on clouds. Blue noise has
//! its energy at the highest frequencies only, so it looks like an even grain and blurs away in
//! any filter or temporal accumulation.
//!
//! The map is made by Ulichney's void-and-cluster method (Ulichney 1993, "The void-and-cluster
//! method for dither array generation"), on a torus so it tiles: a Gaussian filter
//! (`σ` = [`FILTER_SIGMA`] pixels) measures how crowded each pixel's neighbourhood is; the
//! initial pattern's tightest clusters are moved into its largest voids until it is even; its
//! points are ranked by removing the tightest cluster, one by one; the remaining pixels are
//! ranked by filling the largest void, one by one. Pixel value = `(rank + ½) / n`, so every value
//! occurs once: the histogram is exactly uniform.
//!
//! Frames animate it with the golden-ratio sequence, `fract(value + 0.618… · frame)`, which keeps
//! each frame's pattern blue and gives every pixel evenly spread offsets over time.
//!
//! The GPU reads the same values from an `R32Float` texture (`src/render/march/mod.rs` uploads
//! [`blue_noise_map`]). WGSL twin of [`blue_noise_jitter`]: `blue_noise_jitter` in
//! `src/render/march/light.wgsl`.

use std::sync::OnceLock;

/// Side of the map, pixels. 64² = 4096 levels, finer than any step count.
pub const BLUE_NOISE_SIZE: u32 = 64;

/// Standard deviation of the void-and-cluster filter, pixels (Ulichney's 1.5).
pub const FILTER_SIGMA: f64 = 1.5;

/// `(√5 − 1) / 2`: the per-frame offset of the jitter.
pub const GOLDEN_RATIO_CONJUGATE: f64 = 0.618_033_988_749_894_9;

/// Frames after which the per-frame offset repeats (it stays exact in f32).
pub const JITTER_FRAME_PERIOD: u32 = 256;

/// The map: `BLUE_NOISE_SIZE²` values in `(0, 1)`, row after row, each `(rank + ½) / n` for a
/// distinct rank. Made once and cached.
pub fn blue_noise_map() -> &'static [f32] {
    static MAP: OnceLock<Vec<f32>> = OnceLock::new();
    MAP.get_or_init(|| {
        let n = (BLUE_NOISE_SIZE * BLUE_NOISE_SIZE) as f32;
        void_and_cluster(BLUE_NOISE_SIZE as usize, FILTER_SIGMA)
            .into_iter()
            .map(|rank| (rank as f32 + 0.5) / n)
            .collect()
    })
}

/// The jitter at `pixel` (pixel coordinates, any real numbers; the map tiles) in frame `frame`:
/// `fract(map[pixel mod size] + 0.618… · (frame mod 256))`, in `[0, 1)`. Computed in f32 as the
/// GPU does, so both give the same value.
pub fn blue_noise_jitter(pixel: [f64; 2], frame: u32) -> f64 {
    let size = i64::from(BLUE_NOISE_SIZE);
    let wrap = |c: f64| (c.floor() as i64).rem_euclid(size) as usize;
    let value = blue_noise_map()[wrap(pixel[1]) * BLUE_NOISE_SIZE as usize + wrap(pixel[0])];
    let shift = GOLDEN_RATIO_CONJUGATE as f32 * (frame % JITTER_FRAME_PERIOD) as f32;
    let sum = value + shift;
    f64::from(sum - sum.floor())
}

/// Ranks `0..size²` of the pixels of a `size × size` toroidal void-and-cluster map.
fn void_and_cluster(size: usize, sigma: f64) -> Vec<u32> {
    let n = size * size;
    // The Gaussian within ±5σ (beyond, below 10⁻⁶ of its peak), by offset.
    let radius = (5.0 * sigma).ceil() as isize;
    let kernel: Vec<(isize, isize, f64)> = (-radius..=radius)
        .flat_map(|dy| (-radius..=radius).map(move |dx| (dx, dy)))
        .map(|(dx, dy)| {
            let d2 = (dx * dx + dy * dy) as f64;
            (dx, dy, (-d2 / (2.0 * sigma * sigma)).exp())
        })
        .collect();
    let mut pattern = vec![false; n];
    let mut energy = vec![0.0; n];
    let splat = |energy: &mut [f64], at: usize, sign: f64| {
        let (x0, y0) = ((at % size) as isize, (at / size) as isize);
        let s = size as isize;
        for &(dx, dy, weight) in &kernel {
            let x = (x0 + dx).rem_euclid(s) as usize;
            let y = (y0 + dy).rem_euclid(s) as usize;
            energy[y * size + x] += sign * weight;
        }
    };
    // The tightest cluster: the set pixel with the most energy; the largest void: the empty
    // pixel with the least. Ties go to the first pixel, so the map is deterministic.
    let tightest = |pattern: &[bool], energy: &[f64]| {
        (0..n)
            .filter(|&i| pattern[i])
            .fold(None, |best: Option<usize>, i| match best {
                Some(b) if energy[b] >= energy[i] => Some(b),
                _ => Some(i),
            })
            .expect("a set pixel")
    };
    let largest_void = |pattern: &[bool], energy: &[f64]| {
        (0..n)
            .filter(|&i| !pattern[i])
            .fold(None, |best: Option<usize>, i| match best {
                Some(b) if energy[b] <= energy[i] => Some(b),
                _ => Some(i),
            })
            .expect("an empty pixel")
    };

    // An initial pattern of a tenth of the pixels from a fixed hash, made even.
    let ones = (n / 10).max(1);
    let mut hash = 0x9e37_79b9_u32;
    let mut placed = 0;
    while placed < ones {
        hash ^= hash << 13;
        hash ^= hash >> 17;
        hash ^= hash << 5;
        let at = hash as usize % n;
        if !pattern[at] {
            pattern[at] = true;
            splat(&mut energy, at, 1.0);
            placed += 1;
        }
    }
    for _ in 0..n {
        let cluster = tightest(&pattern, &energy);
        pattern[cluster] = false;
        splat(&mut energy, cluster, -1.0);
        let void = largest_void(&pattern, &energy);
        if void == cluster {
            pattern[cluster] = true;
            splat(&mut energy, cluster, 1.0);
            break;
        }
        pattern[void] = true;
        splat(&mut energy, void, 1.0);
    }

    let mut rank = vec![0u32; n];
    // Phase 1: rank the initial points, last first, by removing the tightest cluster.
    let (mut first, mut first_energy) = (pattern.clone(), energy.clone());
    for r in (0..ones).rev() {
        let cluster = tightest(&first, &first_energy);
        first[cluster] = false;
        splat(&mut first_energy, cluster, -1.0);
        rank[cluster] = r as u32;
    }
    // Phase 2: fill the largest void, one rank at a time, until every pixel is set.
    for r in ones..n {
        let void = largest_void(&pattern, &energy);
        pattern[void] = true;
        splat(&mut energy, void, 1.0);
        rank[void] = r as u32;
    }
    rank
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_occurs_once() {
        let map = blue_noise_map();
        let n = map.len();
        assert_eq!(n, (BLUE_NOISE_SIZE * BLUE_NOISE_SIZE) as usize);
        let mut ranks: Vec<u32> = map
            .iter()
            .map(|v| (v * n as f32 - 0.5).round() as u32)
            .collect();
        ranks.sort_unstable();
        assert!(ranks.iter().enumerate().all(|(i, &r)| r as usize == i));
    }

    /// Mean power of the 2D DFT of `values` (mean removed) over the radial frequency band
    /// `(lo, hi]`, cycles per pixel.
    fn band_power(values: &[f64], size: usize, lo: f64, hi: f64) -> f64 {
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let angle = |k: usize, x: usize| -2.0 * std::f64::consts::PI * (k * x) as f64 / size as f64;
        // Rows first, then columns: (re, im) per (row y, frequency k).
        let rows: Vec<(f64, f64)> = (0..size * size)
            .map(|index| {
                let (y, k) = (index / size, index % size);
                (0..size).fold((0.0, 0.0), |(re, im), x| {
                    let v = values[y * size + x] - mean;
                    let a = angle(k, x);
                    (re + v * a.cos(), im + v * a.sin())
                })
            })
            .collect();
        let (mut sum, mut count) = (0.0, 0);
        for l in 0..size {
            for k in 0..size {
                let fold = |f: usize| f.min(size - f) as f64 / size as f64;
                let r = fold(k).hypot(fold(l));
                if r <= lo || r > hi {
                    continue;
                }
                let (re, im) = (0..size).fold((0.0, 0.0), |(re, im), y| {
                    let (a_re, a_im) = rows[y * size + k];
                    let a = angle(l, y);
                    let (c, s) = (a.cos(), a.sin());
                    (re + a_re * c - a_im * s, im + a_re * s + a_im * c)
                });
                sum += re * re + im * im;
                count += 1;
            }
        }
        sum / f64::from(count)
    }

    #[test]
    fn the_noise_is_blue_and_free_of_row_patterns() {
        let size = BLUE_NOISE_SIZE as usize;
        let blue: Vec<f64> = blue_noise_map().iter().map(|&v| f64::from(v)).collect();
        // White noise of the same values (a fixed shuffle) for comparison.
        let mut white = blue.clone();
        let mut hash = 12345u32;
        for i in (1..white.len()).rev() {
            hash = hash.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            white.swap(i, (hash >> 8) as usize % (i + 1));
        }
        // White noise has a flat spectrum, n² · variance = 4096 / 12 per frequency; blue noise
        // has almost nothing below 0.1 cycles per pixel and its energy above 0.35.
        let flat = (size * size) as f64 / 12.0;
        let low = band_power(&blue, size, 0.0, 0.1);
        let high = band_power(&blue, size, 0.35, 0.6);
        let white_low = band_power(&white, size, 0.0, 0.1);
        assert!(
            low < 0.01 * flat,
            "blue noise power below 0.1/px: {low:.2} of {flat:.0}"
        );
        assert!(
            high > 1.2 * flat,
            "blue noise power at 0.35–0.6/px: {high:.0} of {flat:.0}"
        );
        assert!(white_low > 0.5 * flat, "the white control: {white_low:.0}");
        // Neighbours differ more than chance (white: E|a − b| = 1/3) ...
        let neighbour = |values: &[f64], dx: usize, dy: usize| {
            let mut sum = 0.0;
            for y in 0..size {
                for x in 0..size {
                    let (x2, y2) = ((x + dx) % size, (y + dy) % size);
                    sum += (values[y * size + x] - values[y2 * size + x2]).abs();
                }
            }
            sum / (size * size) as f64
        };
        for (dx, dy) in [(1, 0), (0, 1), (1, 1)] {
            let d = neighbour(&blue, dx, dy);
            assert!(d > 0.35, "mean |Δ| to the neighbour ({dx}, {dy}): {d:.3}");
        }
        // ... and no small offset repeats the pattern. Interleaved gradient noise (Jimenez 2014),
        // the control, nearly repeats after a few rows: that is the hatching it drew on clouds.
        let worst = |values: &[f64]| {
            (1..8)
                .flat_map(|dy| (0..8).map(move |dx| (dx, dy)))
                .map(|(dx, dy)| neighbour(values, dx, dy))
                .fold(f64::MAX, f64::min)
        };
        let ign: Vec<f64> = (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f64 + 0.5, (i / size) as f64 + 0.5);
                (52.982_918_9 * (0.067_110_56 * x + 0.005_837_15 * y).fract()).fract()
            })
            .collect();
        let (blue_worst, ign_worst) = (worst(&blue), worst(&ign));
        assert!(ign_worst < 0.15, "the control repeats: {ign_worst:.3}");
        assert!(
            blue_worst > 0.25,
            "an offset nearly repeats: mean |Δ| {blue_worst:.3}"
        );
    }

    #[test]
    fn jitter_tiles_and_animates() {
        let j = blue_noise_jitter([3.5, 7.5], 0);
        assert_eq!(j, blue_noise_jitter([3.5 + 64.0, 7.5 - 128.0], 0));
        assert_eq!(j, f64::from(blue_noise_map()[7 * 64 + 3]));
        let mut frames: Vec<f64> = (0..16).map(|f| blue_noise_jitter([3.5, 7.5], f)).collect();
        assert!(frames.iter().all(|v| (0.0..1.0).contains(v)));
        // The golden-ratio sequence spreads 16 frames over [0, 1): no gap above 0.12.
        frames.sort_by(f64::total_cmp);
        let gap = frames
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(frames[0] + 1.0 - frames[15], f64::max);
        assert!(gap < 0.12, "largest gap {gap}");
        assert_eq!(
            blue_noise_jitter([0.5, 0.5], 5),
            blue_noise_jitter([0.5, 0.5], 5 + JITTER_FRAME_PERIOD)
        );
    }
}
