//! Deterministic 2D gradient noise for terrain detail and colour variation.

/// Eight unit gradient directions (the axes and diagonals), as in Perlin's "Improving Noise"
/// (SIGGRAPH 2002) reduced to 2D.
const GRADIENTS: [[f64; 2]; 8] = {
    const D: f64 = std::f64::consts::FRAC_1_SQRT_2;
    [
        [1.0, 0.0],
        [-1.0, 0.0],
        [0.0, 1.0],
        [0.0, -1.0],
        [D, D],
        [-D, D],
        [D, -D],
        [-D, -D],
    ]
};

/// Integer hash of a lattice point: Chris Wellons' "lowbias32" finaliser (2018, hash-prospector)
/// applied to the mixed coordinates. Wrapping arithmetic, so any coordinate is fine.
fn hash(ix: i64, iy: i64, seed: u32) -> u32 {
    let mut x = (ix as u32)
        .wrapping_mul(0x8da6_b343)
        .wrapping_add((iy as u32).wrapping_mul(0xd816_3841))
        .wrapping_add(seed.wrapping_mul(0xcb1a_b31f));
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Perlin's quintic fade, 6t⁵ − 15t⁴ + 10t³: zero first and second derivatives at the lattice,
/// so the noise has no creases (Perlin 2002).
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// 2D gradient noise at `(x, y)` (lattice spacing 1), in about [−1, 1]; 0 on the lattice.
pub(crate) fn gradient_noise(x: f64, y: f64, seed: u32) -> f64 {
    let (fx, fy) = (x.floor(), y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let (tx, ty) = (x - fx, y - fy);
    let corner = |dx: i64, dy: i64| {
        let g = GRADIENTS[(hash(ix + dx, iy + dy, seed) >> 29) as usize];
        g[0] * (tx - dx as f64) + g[1] * (ty - dy as f64)
    };
    let (u, v) = (fade(tx), fade(ty));
    let bottom = corner(0, 0) + u * (corner(1, 0) - corner(0, 0));
    let top = corner(0, 1) + u * (corner(1, 1) - corner(0, 1));
    // Unit gradients give at most √½ in 2D; scale to about ±1.
    std::f64::consts::SQRT_2 * (bottom + v * (top - bottom))
}

/// Fractal sum of `octaves` layers of [`gradient_noise`], each at twice the frequency and half
/// the amplitude of the one before, normalised to about [−1, 1]. `(x, y)` is in units of the
/// first octave's wavelength.
pub(crate) fn fbm(x: f64, y: f64, octaves: u32, seed: u32) -> f64 {
    let (mut sum, mut norm, mut amplitude, mut frequency) = (0.0, 0.0, 1.0, 1.0);
    for octave in 0..octaves {
        sum += amplitude * gradient_noise(x * frequency, y * frequency, seed.wrapping_add(octave));
        norm += amplitude;
        amplitude *= 0.5;
        frequency *= 2.0;
    }
    if norm > 0.0 { sum / norm } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_bounded_and_zero_on_the_lattice() {
        let mut min: f64 = 0.0;
        let mut max: f64 = 0.0;
        for i in 0..20_000 {
            let (x, y) = (i as f64 * 0.173 - 1000.0, i as f64 * 0.311 - 2000.0);
            let n = gradient_noise(x, y, 7);
            assert_eq!(n, gradient_noise(x, y, 7));
            min = min.min(n);
            max = max.max(n);
        }
        assert!(min >= -1.0001 && max <= 1.0001, "{min} {max}");
        // Spread over most of the range.
        assert!(min < -0.6 && max > 0.6, "{min} {max}");
        assert_eq!(gradient_noise(3.0, -4.0, 1), 0.0);
        assert_ne!(gradient_noise(3.3, 4.7, 1), gradient_noise(3.3, 4.7, 2));
    }

    #[test]
    fn continuous_across_cells() {
        let eps = 1e-7;
        for i in 0..100 {
            let y = i as f64 * 0.37;
            let a = gradient_noise(5.0 - eps, y, 3);
            let b = gradient_noise(5.0 + eps, y, 3);
            assert!((a - b).abs() < 1e-5);
        }
        let f = fbm(10.3, -4.2, 4, 9);
        assert!((-1.0..=1.0).contains(&f));
        assert_eq!(fbm(1.0, 1.0, 0, 0), 0.0);
    }
}
