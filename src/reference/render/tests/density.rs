//! Tests of the density model (`density.rs`).

use super::*;

/// Height of the highest cloudy point above `horizontal_m`, as a fraction of the layer
/// (0 when the column is clear), found on a 1 000-point grid.
fn cloud_top_fraction(layer: &MarchLayer, horizontal_m: [f64; 2]) -> f64 {
    let thickness = layer.top_m - layer.base_m;
    (0..=1000)
        .rev()
        .map(|i| f64::from(i) / 1000.0)
        .find(|&h| {
            let altitude = layer.base_m + h * thickness;
            layer_density(textures(), layer, horizontal_m, altitude, 0.0, false) > 0.0
        })
        .unwrap_or(0.0)
}

#[test]
fn the_shape_noise_carves_heaps_out_of_the_middle_of_a_patch() {
    // At the densest height of a broken cumulus layer (the profile's peak, a tenth of the way
    // up), in the middle of its cloudy patches (patch fill 1), the shape noise must leave
    // clear air between heaps: a patch filled from edge to edge is a wall of cloud, not
    // cumulus. It must not carve the patch away either.
    let layer = cumulus(0.5);
    let altitude = layer.base_m + 0.1 * (layer.top_m - layer.base_m);
    let (mut full, mut clear) = (0, 0);
    for i in 0..80 {
        for j in 0..80 {
            let x = [f64::from(i) * 173.0, f64::from(j) * 211.0 - 7_000.0];
            let kappa = weather_coverage(&textures().weather, &layer, x, altitude - layer.base_m);
            if patch_fill(kappa) < 1.0 {
                continue;
            }
            full += 1;
            if layer_density(textures(), &layer, x, altitude, 0.0, true) == 0.0 {
                clear += 1;
            }
        }
    }
    let fraction = f64::from(clear) / f64::from(full);
    println!("{clear} of {full} points in full patches are clear ({fraction:.3})");
    assert!(full > 500, "only {full} points in full patches");
    assert!(
        (0.1..0.9).contains(&fraction),
        "{clear} of {full} points in full patches are clear"
    );
}

/// Lateral streak contrast of `periods` consecutive periods of the base shape, starting
/// `first_period` periods from the origin, along lines that run along the noise's x axis:
/// the spread of the differences between neighbouring lines (the fine structure streaks are
/// made of) for the mean over the periods, against the mean spread of single periods. 1
/// means the repeats add up to streaks as strong as one period's structure; `1/√periods`
/// means the periods are independent. `warp` scales both warps (0: none).
///
/// A grazing ray crosses many periods. Unwarped, the optical depth of each period along a
/// line is the same function of the line's lateral position, so the sum over periods keeps
/// the lateral contrast of one period: the line pattern of a single period, drawn toward
/// the vanishing point. The warps displace each period differently, so the fine lateral
/// structure decorrelates and averages out. Coverage 1 and a flat profile leave the shape
/// as the only structure. The base noise has 64 texels (125 m), finer than the shared test
/// textures' 500 m, because a warp of a few hundred metres cannot decorrelate structure
/// that coarse.
fn lateral_streak_ratio(first_period: usize, periods: usize, warp: f64) -> f64 {
    let textures = fine_textures();
    let mut layer = MarchLayer {
        coverage: 1.0,
        ..MarchLayer::default()
    };
    layer.set_profile(&[[0.0, 1.0], [1.0, 1.0]]);
    let altitude = 0.5 * (layer.base_m + layer.top_m);
    let period = layer.shape_scale_m;
    let (lines, samples) = (64, 64);
    // Mean base-only extinction of period k along the line at lateral position z, with the
    // warp scaled by `warp`: the shape looked up as `layer_density` does.
    let depth = |k: usize, z: f64| -> f64 {
        (0..samples)
            .map(|i| {
                let x = (k as f64 + (i as f64 + 0.5) / samples as f64) * period;
                if warp == 1.0 {
                    return layer_density(textures, &layer, [x, z], altitude, 0.0, false);
                }
                let w = shape_warp(&textures.weather, &layer, [x, z], 0.0).map(|d| d * warp);
                let uvw = [(x + w[0]) / period, altitude / period, (z + w[1]) / period];
                base_shape(textures.base.sample(uvw, 0.0))
            })
            .sum::<f64>()
            / samples as f64
    };
    // Differences between neighbouring lines, 125 m apart (periodic across the period).
    let fine_structure = |k: usize| -> Vec<f64> {
        let profile: Vec<f64> = (0..lines)
            .map(|j| depth(k, j as f64 / lines as f64 * period))
            .collect();
        (0..lines)
            .map(|j| profile[(j + 1) % lines] - profile[j])
            .collect()
    };
    let rms = |values: &[f64]| -> f64 {
        (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
    };
    let per_period: Vec<Vec<f64>> = (first_period..first_period + periods)
        .map(fine_structure)
        .collect();
    let summed: Vec<f64> = (0..lines)
        .map(|j| per_period.iter().map(|p| p[j]).sum::<f64>() / periods as f64)
        .collect();
    let single = per_period.iter().map(|p| rms(p)).sum::<f64>() / periods as f64;
    let ratio = rms(&summed) / single;
    println!(
        "warp x{warp}, periods {first_period}..{}: lateral fine structure of one period \
         {single:.2e}, of the mean {:.2e}, ratio {ratio:.3}",
        first_period + periods,
        rms(&summed)
    );
    assert!(single > 0.0, "the shape noise must vary across the lines");
    ratio
}

/// Textures with a 64-texel base noise (125 m texels at an 8 km shape period) and a
/// 128-texel weather noise, fine enough to resolve the warps.
fn fine_textures() -> &'static CloudTextures {
    static FINE: OnceLock<CloudTextures> = OnceLock::new();
    FINE.get_or_init(|| {
        CloudTextures::from_recipe(&NoiseRecipe {
            base_size: 64,
            detail_size: 8,
            weather_size: 128,
            ..NoiseRecipe::default()
        })
    })
}

/// Largest displacement and steepest slope, both in shape periods per shape period, of a
/// curl warp of `amplitude` periods looked up over `look_up_periods` shape periods, from
/// central differences on a grid of an eighth of a period over the look-up's whole period.
/// A slope of 1 folds the shape over itself.
fn curl_warp_extent(amplitude: f64, look_up_periods: f64) -> (f64, f64) {
    let weather = &fine_textures().weather;
    let n = weather.size;
    let warp = |x: f64, z: f64| -> [f64; 2] {
        let taps = [x, z].map(|c| weather_taps(c / look_up_periods, n));
        curl_look_up(weather, taps).map(|c| c * amplitude)
    };
    let (steps_per_period, h) = (8.0, 1e-3 * look_up_periods);
    let cells = (look_up_periods * steps_per_period).round() as usize;
    let (mut largest, mut steepest) = (0.0_f64, 0.0_f64);
    for i in 0..cells {
        for j in 0..cells {
            let (x, z) = (i as f64 / steps_per_period, j as f64 / steps_per_period);
            let w = warp(x, z);
            largest = largest.max(w[0].abs()).max(w[1].abs());
            let (dx0, dx1) = (warp(x + h, z), warp(x - h, z));
            let (dz0, dz1) = (warp(x, z + h), warp(x, z - h));
            for a in 0..2 {
                steepest = steepest
                    .max(((dx0[a] - dx1[a]) / (2.0 * h)).abs())
                    .max(((dz0[a] - dz1[a]) / (2.0 * h)).abs());
            }
        }
    }
    (largest, steepest)
}

#[test]
fn the_broad_warp_displaces_far_without_folding_the_shape() {
    // The broad warp must reach close to half a period somewhere, so that repeats move by a
    // whole feature of the shape, and stay below a slope of 1 everywhere. The fine warp at
    // the same amplitude (the weather look-up of the default 20 km layer, 2.5 shape periods)
    // is printed for comparison: it would fold the shape.
    let (largest, steepest) = curl_warp_extent(SHAPE_WARP_BROAD, BROAD_WARP_PERIODS);
    let (_, fine_steepest) = curl_warp_extent(SHAPE_WARP_BROAD, 2.5);
    println!(
        "broad warp: largest {largest:.3} periods, steepest slope {steepest:.3}; the fine \
         warp's look-up at the same amplitude: steepest slope {fine_steepest:.2}"
    );
    assert!(
        largest > 0.4 && largest <= SHAPE_WARP_BROAD,
        "largest {largest}"
    );
    assert!(
        steepest < 1.0,
        "the broad warp folds the shape: slope {steepest}"
    );
}

#[test]
fn the_shape_warp_keeps_repeats_of_the_shape_from_adding_up_to_streaks() {
    // Ten periods along a line, the path of a ray that grazes a layer for 80 km, in three
    // places: without the warp the mean keeps all of one period's lateral structure (ratio
    // 1); ten independent periods would leave 1/√10 = 0.32.
    let unwarped = lateral_streak_ratio(0, 10, 0.0);
    assert!(unwarped > 0.99, "no warp, no decorrelation: {unwarped:.3}");
    for first in [0, 10, 25] {
        let ratio = lateral_streak_ratio(first, 10, 1.0);
        assert!(
            ratio < 0.5,
            "repeats of the shape from period {first} add up to streaks: ratio {ratio:.3}"
        );
    }
}

#[test]
fn clouds_come_down_toward_the_edge_of_the_coverage() {
    // No shape noise: the cloud is the profile remapped by κ. Along a line across the
    // weather pattern, at full coverage height each column's top comes down by the factor
    // κ (2 − κ) against the same layer at coverage height 0.
    let layer = |coverage_height| MarchLayer {
        coverage: 0.2,
        shape_strength: 0.0,
        coverage_height,
        ..MarchLayer::default()
    };
    let (domed, walled) = (layer(1.0), layer(0.0));
    let (mut partial, mut full) = (0, 0);
    for i in 0..400 {
        let x = [f64::from(i) * 50.0, 1_234.0];
        let kappa = weather_coverage(&textures().weather, &domed, x, 0.0);
        let (domed_top, walled_top) = (
            cloud_top_fraction(&domed, x),
            cloud_top_fraction(&walled, x),
        );
        if !is_positive(kappa) {
            assert_eq!((domed_top, walled_top), (0.0, 0.0), "clear at {x:?}");
            continue;
        }
        // With no noise a point is cloudy where the profile exceeds 1 − κ, and κ is the same
        // at every height (no skew): the domed column is the walled one squeezed by
        // f (2 − f), f the patch fill.
        assert!(walled_top > 0.0, "cloudy at κ = {kappa}");
        let fill = patch_fill(kappa);
        let squeeze = fill * (2.0 - fill);
        // Below κ = 0.1 the cloudy stretch of the column is narrower than the grid.
        let tolerance = if kappa > 0.1 { 2e-3 } else { 0.05 };
        assert!(
            (domed_top - squeeze * walled_top).abs() < tolerance,
            "top {domed_top} against {squeeze} · {walled_top} at κ = {kappa}"
        );
        if fill < 0.9 {
            partial += 1;
        } else {
            full += 1;
        }
    }
    // The line crosses both the middle of cloudy patches and their edges.
    assert!(
        partial > 20 && full > 20,
        "{partial} edge and {full} middle columns"
    );
}

#[test]
fn coverage_height_scale_is_clamped_and_never_below_the_coverage() {
    assert_eq!(coverage_height_scale(0.0, 0.3), 1.0);
    assert!((coverage_height_scale(1.0, 0.3) - 0.51).abs() < 1e-12);
    assert!((coverage_height_scale(0.5, 0.3) - 0.755).abs() < 1e-12);
    assert!((coverage_height_scale(7.0, 0.3) - 0.51).abs() < 1e-12);
    for kappa in [1e-9, 0.01, 0.2, 0.7, 0.999] {
        assert!(coverage_height_scale(1.0, kappa) >= kappa);
    }
    assert_eq!(coverage_height_scale(-1.0, 0.3), 1.0);
    assert_eq!(coverage_height_scale(f64::NAN, 0.3), 1.0);
    assert_eq!(coverage_height_scale(1.0, 1.0), 1.0);
}

/// Fraction of 200 vertical columns through a noisy layer of `coverage` that hold cloud.
fn cloudy_fraction(coverage: f64) -> f64 {
    let settings = MarchSettings {
        primary_steps: 24,
        light_steps: 2,
        ..MarchSettings::default()
    };
    let total = 200;
    let mut cloudy = 0;
    for i in 0..total {
        let mut layer = cumulus(coverage);
        layer.set_noise_origin([f64::from(i) * 997.0, f64::from(i % 13) * 1531.0]);
        let result = march_clouds(
            textures(),
            &settings,
            &[layer],
            0.0,
            UP,
            UP,
            f64::INFINITY,
            0.5,
            None,
        );
        assert_sane(&result, "cumulus");
        if result.transmittance < 0.99 {
            cloudy += 1;
        }
    }
    f64::from(cloudy) / f64::from(total)
}

#[test]
fn coverage_sets_the_cloudy_fraction() {
    let fractions = [0.2, 0.5, 0.8].map(cloudy_fraction);
    println!("cloudy fraction at coverage 0.2, 0.5, 0.8: {fractions:?}");
    assert!(fractions[0] < fractions[1] && fractions[1] < fractions[2]);
    assert!((0.05..0.4).contains(&fractions[0]), "{fractions:?}");
    assert!((0.3..0.7).contains(&fractions[1]), "{fractions:?}");
    assert!((0.6..0.95).contains(&fractions[2]), "{fractions:?}");
}

#[test]
fn profile_column_is_the_integral_of_the_profile() {
    let mut layer = MarchLayer::default();
    for points in [
        &[[0.0, 0.0], [0.1, 1.0], [0.6, 0.8], [1.0, 0.0]][..],
        &[[0.2, 0.5], [0.7, 1.0]][..],
        &[][..],
    ] {
        layer.set_profile(points);
        let n = 100_000;
        let mut sum = 0.0;
        for i in 0..n {
            let h = (f64::from(i) + 0.5) / f64::from(n);
            sum += profile_density(&layer, h) / f64::from(n);
            if (i + 1) % 25_000 == 0 {
                let upto = f64::from(i + 1) / f64::from(n);
                let column = profile_column(&layer, upto);
                assert!(
                    (column - sum).abs() < 1e-6,
                    "{points:?} at {upto}: {column} vs {sum}"
                );
            }
        }
        assert_eq!(profile_column(&layer, 2.0), profile_column(&layer, 1.0));
        assert_eq!(profile_column(&layer, -1.0), 0.0);
    }
}

#[test]
fn the_shape_warp_needs_one_broad_curl_where_the_texel_centres_share_a_broad_cell() {
    // The WGSL `shape_warp` reads the broad curl once, at the look-up itself, where the four
    // weather texel centres around it fall in one broad texel cell, instead of filtering the
    // four texels' broad curls. Both are the same bilinear function there: this checks the
    // identity on the twin, with skew, height and offsets that move the broad look-up off the
    // weather grid, and that the four-curl path is the one taken across cell edges.
    let weather = &textures().weather;
    let n = weather.size;
    let mut layer = cumulus(0.5);
    layer.skew = [0.7, -0.3];
    layer.weather_offset_m = [1_234.5, -987.25];
    layer.warp_offset_m = [40_321.0, 7_777.0];
    let taps_at = |b: [f64; 2]| b.map(|c| weather_taps((c + 0.5) / f64::from(n), n));
    let (mut shared, mut straddling) = (0, 0);
    for i in 0..120 {
        for j in 0..120 {
            let horizontal = [
                f64::from(i) * 397.0 - 20_000.0,
                f64::from(j) * 433.0 - 9_000.0,
            ];
            let height = f64::from((i * 7 + j) % 11) * 150.0;
            let fine_taps = weather_look_up(n, &layer, horizontal, height);
            // The look-up in texel units: the first texel plus the second's weight.
            let x = fine_taps.map(|[(i0, _), (_, w)]| i0 as f64 + w);
            let cell = x.map(f64::floor);
            let (lo, hi) = (
                broad_look_up(n, &layer, cell),
                broad_look_up(n, &layer, cell.map(|c| c + 1.0)),
            );
            let warp = shape_warp(weather, &layer, horizontal, height);
            if (0..2).any(|a| lo[a].floor() != hi[a].floor()) {
                straddling += 1;
                continue;
            }
            shared += 1;
            let fine = curl_look_up(weather, fine_taps);
            let broad = curl_look_up(weather, taps_at(broad_look_up(n, &layer, x)));
            for a in 0..2 {
                let one_look_up =
                    (SHAPE_WARP * fine[a] + SHAPE_WARP_BROAD * broad[a]) * layer.shape_scale_m;
                assert!(
                    (warp[a] - one_look_up).abs() < 1e-9 * layer.shape_scale_m,
                    "axis {a} at {horizontal:?}, {height} m: filter {} against one look-up \
                     {one_look_up}",
                    warp[a]
                );
            }
        }
    }
    println!("{shared} look-ups share a broad cell, {straddling} straddle one");
    // The one-look-up path is the common case, or it would not be worth a branch.
    assert!(
        shared > 2 * straddling,
        "{shared} shared, {straddling} straddling"
    );
    assert!(straddling > 0, "the straddling path must be exercised");
}
