//! Tests of the reference noise generators.

use super::*;

/// A small deterministic generator of test positions (xorshift), independent of the hash
/// under test.
struct Positions(u64);

impl Positions {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    fn point(&mut self, scale: f64) -> [f64; 3] {
        [
            self.unit() * scale,
            self.unit() * scale,
            self.unit() * scale,
        ]
    }
}

/// Integer shifts, in periods, applied in the tiling tests: negative, positive and mixed.
const SHIFTS: [[i32; 3]; 6] = [
    [-1, 0, 0],
    [0, -3, 0],
    [0, 0, 2],
    [1, 1, 1],
    [-2, 5, -7],
    [-11, -4, 3],
];

fn shifted(p: [f64; 3], shift: [i32; 3], period: f64) -> [f64; 3] {
    [
        p[0] + f64::from(shift[0]) * period,
        p[1] + f64::from(shift[1]) * period,
        p[2] + f64::from(shift[2]) * period,
    ]
}

fn assert_tiles(name: &str, period: f64, f: impl Fn([f64; 3]) -> f64) {
    let mut positions = Positions(0x2545_F491_4F6C_DD1D);
    for _ in 0..200 {
        let p = positions.point(period);
        let reference = f(p);
        for shift in SHIFTS {
            let q = shifted(p, shift, period);
            let value = f(q);
            assert!(
                (value - reference).abs() <= 1e-12,
                "{name} does not tile: f({p:?}) = {reference}, f({q:?}) = {value}"
            );
        }
    }
}

#[test]
fn hash_matches_independent_implementation() {
    // Expected values from an independent Python implementation of pcg4d (Jarzynski &
    // Olano 2020) with explicit `& 0xffffffff` masking; the GPU parity relies on them.
    let cases: [([u32; 4], [u32; 4]); 5] = [
        (
            [0, 0, 0, 0],
            [0x0f02_f829, 0x2d56_8769, 0x32b0_c43b, 0xd325_48ea],
        ),
        (
            [1, 2, 3, 4],
            [0x3622_cd16, 0xf114_71d8, 0xe110_9b3f, 0x02b9_4c2f],
        ),
        (
            [127, 0, 31, 0x9E37_79B9],
            [0xf866_2705, 0x58df_a743, 0x9c21_dac9, 0xfbd8_cb1f],
        ),
        (
            [u32::MAX; 4],
            [0x974e_d892, 0xc015_dc67, 0x9f95_5760, 0xa1bb_a208],
        ),
        (
            [5, 17, 64, 12345],
            [0x9733_e9e0, 0x0ba7_575d, 0x293b_bcfb, 0x8d3d_26ba],
        ),
    ];
    for (input, expected) in cases {
        assert_eq!(pcg4d(input), expected, "pcg4d({input:x?})");
    }
    assert_eq!(hash_to_unit(0), 0.0);
    assert_eq!(hash_to_unit(u32::MAX), 1.0 - 1.0 / 16_777_216.0);
}

#[test]
fn wrap_cell_is_a_true_modulo() {
    assert_eq!(wrap_cell(-5, 3), 1, "Thomann 2021 §5.3: -5 mod 3 = 1");
    assert_eq!(wrap_cell(-3, 3), 0);
    assert_eq!(wrap_cell(-1, 4), 3);
    assert_eq!(wrap_cell(7, 4), 3);
    assert_eq!(wrap_cell(0, 1), 0);
    for cell in -100..100_i64 {
        assert_eq!(i64::from(wrap_cell(cell, 7)), cell.rem_euclid(7));
    }
}

#[test]
fn noises_tile_for_negative_and_positive_periods() {
    let fbm = FbmRecipe::new(3, 3, 0.5);
    for period in [1_u32, 3, 8] {
        let cells = f64::from(period);
        assert_tiles("perlin_noise_3d", cells, |p| perlin_noise_3d(p, period, 7));
        assert_tiles("worley_noise_3d", cells, |p| worley_noise_3d(p, period, 7));
    }
    assert_tiles("perlin_fbm_3d", 1.0, |p| perlin_fbm_3d(p, &fbm, 11));
    assert_tiles("worley_fbm_3d", 1.0, |p| worley_fbm_3d(p, &fbm, 11));
    assert_tiles("perlin_worley", 1.0, |p| perlin_worley(p, &fbm, &fbm, 1, 2));
    for axis in 0..2 {
        assert_tiles("curl_noise_2d", 1.0, |p| {
            curl_noise_2d([p[0], p[1]], &fbm, 5)[axis]
        });
    }
}

#[test]
fn noises_are_continuous_across_cells() {
    // Worley's 27-cell search and Perlin's fade must leave no jumps at cell faces.
    let mut positions = Positions(99);
    for _ in 0..500 {
        let p = positions.point(4.0);
        let mut q = p;
        q[0] += 1e-7;
        assert!((perlin_noise_3d(p, 4, 3) - perlin_noise_3d(q, 4, 3)).abs() < 1e-5);
        assert!((worley_noise_3d(p, 4, 3) - worley_noise_3d(q, 4, 3)).abs() < 1e-5);
    }
    let face = [2.0, 0.37, 1.61];
    let below = [2.0 - 1e-12, 0.37, 1.61];
    assert!((worley_noise_3d(face, 4, 3) - worley_noise_3d(below, 4, 3)).abs() < 1e-9);
    assert!((perlin_noise_3d(face, 4, 3) - perlin_noise_3d(below, 4, 3)).abs() < 1e-9);
}

#[test]
fn worley_cells_are_bright_at_feature_points() {
    // The inverted F1 is 1 on a feature point and falls away from it (Pérez Martín 2022, Fig. 24.b).
    let seed = 4;
    let h = lattice_hash([1, 2, 3], seed);
    let point = [
        1.0 + hash_to_unit(h[0]),
        2.0 + hash_to_unit(h[1]),
        3.0 + hash_to_unit(h[2]),
    ];
    assert!((worley_noise_3d(point, 8, seed) - 1.0).abs() < 1e-12);
    let nearby = [point[0] + 0.05, point[1], point[2]];
    assert!(worley_noise_3d(nearby, 8, seed) < 1.0);
}

/// Mean and standard deviation of each channel.
fn channel_stats(texels: &[[f64; 4]]) -> [(f64, f64); 4] {
    let n = texels.len() as f64;
    std::array::from_fn(|c| {
        let mean = texels.iter().map(|t| t[c]).sum::<f64>() / n;
        let variance = texels.iter().map(|t| (t[c] - mean).powi(2)).sum::<f64>() / n;
        (mean, variance.sqrt())
    })
}

#[test]
fn channels_lie_in_unit_range_and_vary() {
    let recipe = NoiseRecipe::default();
    // Smaller textures sample the same tileable functions more coarsely; the statistics
    // hold at any size. Why these floors:
    // - Worley fBm: one octave of inverted F1 on a jittered grid has a standard deviation
    //   of about 0.17 (0.20 for Poisson-distributed points: P(F1 > r) = exp(-4πr³/3)).
    //   Three independent octaves weighted 4:2:1 scale it by √21 / 7 ≈ 0.65, giving ≈ 0.11;
    //   measured over seeds 0-23 at these sizes: 0.101-0.126.
    // - Perlin-Worley (base R 0.162-0.183, weather R 0.144-0.185), weather G (0.146-0.170)
    //   and curl (0.100-0.128) were measured the same way.
    // Each floor is about half the smallest measured value: room for any seed, yet a
    // constant or collapsed channel (broken hash, wrong wrap, lost octave weights) fails.
    let textures: [(&str, Vec<[f64; 4]>, [f64; 4]); 3] = [
        ("base", generate_base(&recipe, 32), [0.08, 0.05, 0.05, 0.05]),
        (
            "detail",
            generate_detail(&recipe, 16),
            [0.05, 0.05, 0.05, 0.0],
        ),
        (
            "weather",
            generate_weather(&recipe, 64),
            [0.07, 0.07, 0.05, 0.05],
        ),
    ];
    for (name, texels, floors) in &textures {
        for texel in texels {
            assert!(
                texel.iter().all(|v| (0.0..=1.0).contains(v)),
                "{name} texel out of [0, 1]: {texel:?}"
            );
        }
        let stats = channel_stats(texels);
        for (channel, ((mean, deviation), floor)) in stats.iter().zip(floors).enumerate() {
            println!("{name}[{channel}]: mean {mean:.4}, standard deviation {deviation:.4}");
            assert!(
                *deviation >= *floor,
                "{name} channel {channel}: standard deviation {deviation} below {floor}"
            );
        }
    }
    let detail_alpha = &textures[1].1;
    assert!(detail_alpha.iter().all(|t| t[3] == 1.0));
}

#[test]
fn default_finest_octaves_keep_two_texels_per_cell() {
    let recipe = NoiseRecipe::default();
    let finest = |fbm: &FbmRecipe| fbm.frequency << (fbm.octaves - 1);
    for fbm in [&recipe.base.perlin, &recipe.base.worley]
        .into_iter()
        .chain(&recipe.base.channels)
    {
        assert!(2 * finest(fbm) <= recipe.base_size, "{fbm:?}");
    }
    for fbm in &recipe.detail.channels {
        assert!(2 * finest(fbm) <= recipe.detail_size, "{fbm:?}");
    }
}

#[test]
fn a_different_seed_changes_every_channel() {
    let recipe = NoiseRecipe::default();
    let other = NoiseRecipe {
        seed: 1,
        ..recipe.clone()
    };
    let pairs = [
        (generate_base(&recipe, 8), generate_base(&other, 8)),
        (generate_detail(&recipe, 8), generate_detail(&other, 8)),
        (generate_weather(&recipe, 16), generate_weather(&other, 16)),
    ];
    for (a, b) in &pairs {
        // Detail A is the constant 1.
        let channels = if a.len() == 512 && a[0][3] == 1.0 {
            3
        } else {
            4
        };
        for c in 0..channels {
            let differing = a
                .iter()
                .zip(b)
                .filter(|(s, t)| (s[c] - t[c]).abs() > 1e-3)
                .count();
            assert!(
                differing > a.len() / 2,
                "channel {c}: only {differing} texels changed"
            );
        }
    }
}

#[test]
fn channels_are_independent_of_each_other() {
    // Each slot has its own seed, so G, B and A are not copies of each other at another
    // scale; a shared lattice would show as a correlation close to 1.
    let texels = generate_base(&NoiseRecipe::default(), 16);
    let stats = channel_stats(&texels);
    let n = texels.len() as f64;
    for a in 1..4 {
        for b in (a + 1)..4 {
            let covariance = texels
                .iter()
                .map(|t| (t[a] - stats[a].0) * (t[b] - stats[b].0))
                .sum::<f64>()
                / n;
            let correlation = covariance / (stats[a].1 * stats[b].1);
            assert!(
                correlation.abs() < 0.5,
                "channels {a}, {b}: correlation {correlation}"
            );
        }
    }
}

#[test]
fn mips_preserve_the_mean() {
    let recipe = NoiseRecipe::default();
    let size = 16;
    let chain = mip_chain_3d(generate_detail(&recipe, size), size);
    assert_eq!(chain.len(), 5);
    assert_eq!(chain.last().map(Vec::len), Some(1));
    let level0 = channel_stats(&chain[0]);
    for (level, texels) in chain.iter().enumerate() {
        assert_eq!(texels.len(), (mip_size_at(size, level) as usize).pow(3));
        for (c, (mean, _)) in channel_stats(texels).iter().enumerate() {
            assert!(
                (mean - level0[c].0).abs() < 1e-12,
                "level {level} channel {c}"
            );
        }
    }
}

fn mip_size_at(size: u32, level: usize) -> u32 {
    (0..level).fold(size, |s, _| mip_size(s))
}

#[test]
fn downsample_clamps_odd_sizes() {
    // 3³ texels whose value is their x index: the 1³ mip averages x = 0 and 1 only.
    let source: Vec<[f64; 4]> = (0..27).map(|i| [f64::from(i % 3); 4]).collect();
    let level = downsample_3d(&source, 3);
    assert_eq!(level, vec![[0.5; 4]]);
    assert_eq!(downsample_3d(&[[0.25; 4]], 1), vec![[0.25; 4]]);
    assert_eq!(mip_level_count(128), 8);
    assert_eq!(mip_level_count(1), 1);
    assert_eq!(mip_level_count(96), 7);
}

#[test]
fn quantization_rounds_to_nearest() {
    assert_eq!(quantize_unorm8(0.0), 0);
    assert_eq!(quantize_unorm8(1.0), 255);
    assert_eq!(quantize_unorm8(0.5), 128);
    assert_eq!(quantize_unorm8(1.5 / 255.0 - 1e-9), 1);
    assert_eq!(quantize_unorm8(-0.2), 0);
}

#[test]
fn noise_quantization_rounds_to_half_floats_on_an_even_grid() {
    let step = 1.0 / NOISE_LEVELS;
    assert_eq!(quantize_noise(0.0), 0.0);
    assert_eq!(quantize_noise(1.0), 1.0);
    assert_eq!(quantize_noise(2.0), 1.0, "clamped to [0, 1]");
    assert_eq!(quantize_noise(-0.5), 0.0, "clamped to [0, 1]");
    assert_eq!(quantize_noise(f64::NAN), 0.0);
    assert_eq!(quantize_noise(0.5 + 0.4 * step), 0.5);
    assert_eq!(quantize_noise(0.5 + 0.6 * step), 0.5 + step);
    // Every grid value is a half float: it survives f32 → f16 → f32 under any rounding, since
    // a multiple of 2^-11 in [0, 1] needs at most 11 significant bits.
    for k in 0..=2048_u32 {
        let v = f64::from(k) / NOISE_LEVELS;
        assert_eq!(quantize_noise(v), v);
        let significant = if k == 0 {
            0
        } else {
            32 - k.leading_zeros() - k.trailing_zeros()
        };
        assert!(significant <= 11, "{k}");
    }
    for k in 0..=1000 {
        let v = f64::from(k) / 1000.0;
        assert!((quantize_noise(v) - v).abs() <= 0.5 * step);
    }
}
