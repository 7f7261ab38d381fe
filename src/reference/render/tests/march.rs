//! Tests of the march (`march.rs`), many against the closed form of a homogeneous slab.

use super::*;

#[test]
fn homogeneous_slab_matches_the_closed_form() {
    // τ = 2 through the slab: the regime where a step's source term varies most.
    let layer = slab(0.002);
    let mut worst = [0.0_f64; 4];
    for elevation in [90.0, 60.0, 30.0] {
        for growth in [0.0, 0.001] {
            for (index, steps) in [8, 32, 128, 512].into_iter().enumerate() {
                let settings = MarchSettings {
                    step_growth: growth,
                    ..slab_settings(steps, elevation)
                };
                let marched = march_up(&settings, std::slice::from_ref(&layer));
                let exact = homogeneous_slab(&settings, &layer);
                let t_error = relative_error(marched.transmittance, exact.transmittance);
                assert!(t_error < 1e-12, "T: {marched:?} vs {exact:?}");
                let d_error = relative_error(marched.distance_m, exact.distance_m);
                assert!(d_error < 0.01, "distance: {marched:?} vs {exact:?}");
                for c in 0..3 {
                    let error = relative_error(marched.radiance[c], exact.radiance[c]);
                    worst[index] = worst[index].max(error);
                    assert!(
                        error < 0.005,
                        "sun {elevation}°, growth {growth}, {steps} steps, channel {c}: \
                         {} vs {} ({:.3} %)",
                        marched.radiance[c],
                        exact.radiance[c],
                        error * 100.0
                    );
                }
            }
        }
    }
    let worst = worst.map(|e| format!("{e:.2e}"));
    println!("largest relative error of L at 8, 32, 128, 512 steps: {worst:?}");
}

#[test]
fn tiny_extinction_keeps_full_precision() {
    // σ = 1e-9 /m over 1 km: τ = 1e-6. L is σ times a constant up to the physical
    // self-attenuation of the light on its way in and out, a relative (1 + 1/μs) τ / 2 ≈
    // 1.1e-6 here; at σ = 1e-12 that term is 1e-9. So 1000 L(1e-12) / L(1e-9) − 1 must be
    // exactly that physical term (from the closed form) to 1e-9, and each L must match
    // the closed form to 1e-9: no precision is lost (a clamped σ, or `1 − e^(−x)` in the
    // integrator, would lose it all).
    let settings = slab_settings(64, 60.0);
    let one = march_up(&settings, &[slab(1e-9)]);
    let tiny = march_up(&settings, &[slab(1e-12)]);
    let exact_one = homogeneous_slab(&settings, &slab(1e-9));
    let exact_tiny = homogeneous_slab(&settings, &slab(1e-12));
    for c in 0..3 {
        assert!(one.radiance[c] > 0.0);
        assert!(relative_error(one.radiance[c], exact_one.radiance[c]) < 1e-9);
        assert!(
            relative_error(tiny.radiance[c], exact_tiny.radiance[c]) < 1e-9,
            "{tiny:?} {exact_tiny:?}"
        );
        let nonlinearity = 1000.0 * tiny.radiance[c] / one.radiance[c] - 1.0;
        let expected = 1000.0 * exact_tiny.radiance[c] / exact_one.radiance[c] - 1.0;
        assert!(
            nonlinearity > 0.0 && nonlinearity < 2e-6,
            "L not proportional to σ: {nonlinearity}"
        );
        assert!(
            (nonlinearity - expected).abs() < 1e-9,
            "{nonlinearity} vs {expected}"
        );
    }
    assert!(relative_error(1.0 - one.transmittance, 1e-6) < 1e-6);
    assert!(relative_error(1.0 - tiny.transmittance, 1e-9) < 1e-6);
}

#[test]
fn huge_extinction_is_finite_and_opaque() {
    for steps in [8, 64, 512] {
        let settings = slab_settings(steps, 60.0);
        let result = march_up(&settings, &[slab(1e4)]);
        assert_sane(&result, "σ = 1e4");
        assert_eq!(result.transmittance, 0.0);
        assert!(result.radiance.iter().all(|&c| c > 0.0));
        let exact = homogeneous_slab(&settings, &slab(1e4));
        assert_eq!(exact.transmittance, 0.0);
        assert!(exact.radiance.iter().all(|c| c.is_finite()));
    }
}

#[test]
fn overlapping_layers_add_their_extinction() {
    let settings = slab_settings(64, 60.0);
    let both = march_up(&settings, &[slab(0.001), slab(0.0015)]);
    let single = march_up(&settings, &[slab(0.0025)]);
    assert!(relative_error(both.transmittance, single.transmittance) < 1e-12);
    for c in 0..3 {
        assert!(relative_error(both.radiance[c], single.radiance[c]) < 1e-12);
    }
}

#[test]
fn coverage_zero_gives_exactly_clear_sky() {
    let settings = MarchSettings::default();
    for layers in [vec![cumulus(0.0)], vec![], vec![cumulus(0.0), slab(0.0)]] {
        for direction in [UP, normalize([1.0, 0.1, 0.0]), normalize([0.0, -0.2, 1.0])] {
            for altitude in [0.0, 2000.0, 400_000.0] {
                let result = march_clouds(
                    textures(),
                    &settings,
                    &layers,
                    altitude,
                    UP,
                    direction,
                    f64::INFINITY,
                    0.3,
                    None,
                );
                assert_eq!(result, MarchResult::CLEAR);
            }
        }
    }
    assert_eq!(local_coverage(0.0, 1.0), 0.0);
    assert_eq!(local_coverage(1.0, 0.0), 1.0);
}

#[test]
fn coverage_one_is_overcast() {
    let settings = MarchSettings::default();
    let layer = cumulus(1.0);
    // Every point at the profile peak is cloud, wherever it is.
    for x in [0.0, 1234.0, -5678.0, 40_000.0] {
        for z in [0.0, 777.0, -9_000.0] {
            let position = [x, 1500.0 + 0.1 * 1500.0, z];
            assert!(
                density_at(
                    textures(),
                    &settings,
                    std::slice::from_ref(&layer),
                    position
                ) > 0.0
            );
        }
    }
    let result = march_up(&settings, &[layer]);
    assert_sane(&result, "overcast");
    assert!(result.transmittance < 0.01);
}

/// The hard cases that must stay finite and correct: a camera on the ground, exactly on a
/// layer's base or top, inside it or in space; rays up, down, level and tangent to the layer's
/// spheres; the sun along the view ray and below the horizon; a week of wind far from the origin.
#[test]
fn hard_cases_stay_finite() {
    let r = EARTH_RADIUS_M;
    let week_of_wind = 7.0 * 86_400.0 * 30.0;
    let mut windy = cumulus(0.5);
    windy.set_noise_origin([week_of_wind * 0.6 + 1.3e6, -week_of_wind * 0.8 - 4.2e5]);
    for offset in [
        windy.weather_offset_m,
        windy.shape_offset_m,
        windy.detail_offset_m,
    ] {
        assert!(
            offset.iter().all(|o| (0.0..20_000.0).contains(o)),
            "{offset:?}"
        );
    }
    let mut thin_base = slab(0.01);
    thin_base.base_m = 0.0;
    thin_base.top_m = 300.0;
    let layer_sets: Vec<Vec<MarchLayer>> = vec![
        vec![cumulus(0.5)],
        vec![cumulus(1.0)],
        vec![cumulus(0.0), cumulus(0.3)],
        vec![windy],
        vec![slab(1e4)],
        vec![thin_base, cumulus(0.7)],
    ];
    // Camera altitudes: ground, exactly on the base and the top, inside, in space.
    let altitudes = [0.0, 1500.0, 3000.0, 2200.0, 400_000.0, 1e-9];
    let elevations = [90.0, 30.0, 0.0, -0.5, -30.0, -90.0];
    for layers in &layer_sets {
        for &altitude in &altitudes {
            // Directions: up, down, horizontal, tangent to the base and top spheres.
            let mut mus = vec![1.0, -1.0, 0.0, 0.3, -0.05];
            for shell in [1500.0, 3000.0, 0.0] {
                if altitude > shell {
                    mus.push(-(1.0 - ((r + shell) / (r + altitude)).powi(2)).sqrt());
                }
            }
            for &mu in &mus {
                let direction = [(1.0 - mu * mu).max(0.0).sqrt(), mu, 0.0];
                for &elevation in &elevations {
                    // Sun at the given elevation, and once straight along the view ray.
                    let e: f64 = f64::to_radians(elevation);
                    for sun in [[e.cos(), e.sin(), 0.0], direction] {
                        let settings = MarchSettings {
                            camera_altitude_m: altitude,
                            sun_direction: sun,
                            primary_steps: 16,
                            light_steps: 3,
                            ..MarchSettings::default()
                        };
                        for t_max in [f64::INFINITY, 1e-3, 0.0, 2500.0] {
                            let result = march_clouds(
                                textures(),
                                &settings,
                                layers,
                                altitude,
                                UP,
                                direction,
                                t_max,
                                0.999,
                                None,
                            );
                            let what =
                                format!("alt {altitude} mu {mu} sun {elevation}° t_max {t_max}");
                            assert_sane(&result, &what);
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn sun_below_the_horizon_leaves_only_ambient() {
    let layer = slab(0.002);
    let lit = march_up(&slab_settings(64, 30.0), std::slice::from_ref(&layer));
    let night = MarchSettings {
        sun_illuminance: [0.0; 3],
        ..slab_settings(64, 30.0)
    };
    let ambient_only = march_up(&night, std::slice::from_ref(&layer));
    // At 1-2 km the sun 10° below the horizon is behind the Earth: only the sky lights it.
    let below = march_up(&slab_settings(64, -10.0), std::slice::from_ref(&layer));
    for c in 0..3 {
        assert!(relative_error(below.radiance[c], ambient_only.radiance[c]) < 1e-12);
        assert!(lit.radiance[c] > below.radiance[c]);
    }
}

#[test]
fn a_ray_through_many_layers_shares_one_step_budget() {
    let settings = MarchSettings {
        primary_steps: 48,
        min_step_m: 0.0,
        ..MarchSettings::default()
    };
    // Without step growth the measure is the length. Four intervals of 5 km, 5 km, 5 km and
    // 15 km: 8, 8, 8 and 24 steps, 48 in all.
    let even = MarchSettings {
        step_growth: 0.0,
        ..settings.clone()
    };
    let spans = [5_000.0, 5_000.0, 5_000.0, 15_000.0];
    let mut t = 0.0;
    let intervals: Vec<(f64, f64)> = spans
        .iter()
        .map(|&span| {
            t += span;
            (t - span, t)
        })
        .collect();
    let share = |settings: &MarchSettings| -> Vec<u32> {
        let total: f32 = intervals
            .iter()
            .map(|&(a, b)| interval_measure(settings, a, b))
            .sum();
        intervals
            .iter()
            .map(|&(a, b)| interval_steps(settings, b - a, interval_measure(settings, a, b), total))
            .collect()
    };
    assert_eq!(share(&even), [8, 8, 8, 24]);
    // Sixteen equal intervals: 3 steps each, not 48 each.
    assert_eq!(interval_steps(&even, 1_000.0, 1_000.0, 16_000.0), 3);
    // A sliver still gets a step.
    assert_eq!(interval_steps(&even, 1.0, 1.0, 1e6), 1);
    // Steps grow with distance, so the near interval gets more than its share of the length:
    // a layer the camera is in is not starved by a long one far away.
    let grown = MarchSettings {
        step_growth: 1e-4,
        ..settings.clone()
    };
    let steps = share(&grown);
    assert!(steps[0] > 8 && steps[3] < 24, "{steps:?}");
    assert!(steps.windows(2).take(2).all(|w| w[0] > w[1]), "{steps:?}");
    assert!(steps.iter().sum::<u32>() <= 48 + 4);
}

#[test]
fn short_intervals_get_fewer_steps() {
    let settings = MarchSettings {
        primary_steps: 48,
        min_step_m: 20.0,
        ..MarchSettings::default()
    };
    // 355 m of fog seen 25° up from the ground: 18 steps of 20 m, not 48 of 7 m.
    assert_eq!(interval_steps(&settings, 355.0, 355.0, 355.0), 18);
    assert_eq!(interval_steps(&settings, 5_000.0, 5_000.0, 5_000.0), 48);
    assert_eq!(interval_steps(&settings, 1.0, 1.0, 1.0), 1);
    assert_eq!(interval_steps(&settings, 0.0, 0.0, 0.0), 48);
    assert_eq!(
        interval_steps(&settings, f64::INFINITY, f32::INFINITY, f32::INFINITY),
        48
    );
    let off = MarchSettings {
        min_step_m: 0.0,
        ..settings.clone()
    };
    assert_eq!(interval_steps(&off, 355.0, 355.0, 355.0), 48);
    // A homogeneous slab still matches its closed form with the floor on.
    let layer = slab(0.002);
    let floored = MarchSettings {
        min_step_m: 100.0,
        ..slab_settings(64, 60.0)
    };
    let marched = march_up(&floored, std::slice::from_ref(&layer));
    let exact = homogeneous_slab(&floored, &layer);
    assert!(relative_error(marched.radiance[1], exact.radiance[1]) < 0.005);
}

/// Jitter-mean luminance of a ray looking along +x through a band of cloud whose near wall
/// is `wall_m` away, with a low sun behind the camera lighting the wall's face: the mean
/// over 64 evenly spaced jitters, which the temporal accumulation converges to.
fn wall_radiance(textures: &CloudTextures, wall_m: f64, steps: u32) -> f64 {
    let settings = MarchSettings {
        primary_steps: steps,
        camera_altitude_m: 1500.0,
        sun_direction: [-10f64.to_radians().cos(), 10f64.to_radians().sin(), 0.0],
        ..MarchSettings::default()
    };
    let mut layer = slab(0.05);
    layer.coverage = 0.5;
    layer.weather_scale_m = 32_000.0;
    // The band's near edge is at u = 0.25 of the period: the look-up u = (x + offset) / scale
    // reaches it at x = wall_m.
    layer.weather_offset_m = [0.25 * 32_000.0 - wall_m, 0.0];
    let jitters = 64;
    (0..jitters)
        .map(|i| {
            let jitter = (f64::from(i) + 0.5) / f64::from(jitters);
            let result = march_clouds(
                textures,
                &settings,
                std::slice::from_ref(&layer),
                1500.0,
                UP,
                [1.0, 0.0, 0.0],
                f64::INFINITY,
                jitter,
                None,
            );
            result.radiance.iter().sum::<f64>() / 3.0
        })
        .sum::<f64>()
        / f64::from(jitters)
}

/// A dense cloud wall, opaque within a fraction of a step, looks the same whatever the step
/// grid's phase against it, and as bright as with 1024 steps. Where the cheap stride's sample
/// falls short of the wall, the next one finds cloud and the detail march backs up a stride;
/// the dense step then finds the wall's edge and marches from it in thin parts. Without the
/// back-up the march skipped part of a stride behind the wall with a probability that
/// depends on the phase, which drew horizontal bands on cumulus walls.
#[test]
fn cloud_walls_look_the_same_whatever_the_step_phase() {
    let flat = NoiseTexture3d::from_level0(&[[0.5; 4]], 1);
    let n = 1024u32;
    // A band of full local coverage over texels 256..768 (16 km at 31 m per texel).
    let texels: Vec<[f64; 4]> = (0..n * n)
        .map(|i| {
            let x = i % n;
            let w = if (256..768).contains(&x) { 1.0 } else { 0.0 };
            [w, 0.0, 0.0, 0.0]
        })
        .collect();
    let textures = CloudTextures {
        base: flat.clone(),
        detail: flat,
        weather: NoiseTexture2d::from_texels(&texels, n),
    };
    // The wall swept over 4 km, several strides of the 48-step grid there.
    let radiance: Vec<f64> = (0..=40)
        .map(|i| wall_radiance(&textures, 6_000.0 + 100.0 * f64::from(i), 48))
        .collect();
    let converged = wall_radiance(&textures, 8_000.0, 1024);
    // Departure from the straight line through the sweep (the steps grow with distance, so
    // a slow trend is expected), relative to the mean.
    let count = radiance.len() as f64;
    let mean = radiance.iter().sum::<f64>() / count;
    let mean_x = (count - 1.0) / 2.0;
    let slope = radiance
        .iter()
        .enumerate()
        .map(|(i, r)| (i as f64 - mean_x) * (r - mean))
        .sum::<f64>()
        / radiance
            .iter()
            .enumerate()
            .map(|(i, _)| (i as f64 - mean_x).powi(2))
            .sum::<f64>();
    let worst = radiance
        .iter()
        .enumerate()
        .map(|(i, r)| (r - mean - slope * (i as f64 - mean_x)).abs())
        .fold(0.0, f64::max)
        / mean;
    eprintln!(
        "wall radiance over the sweep: {radiance:.4?}; worst departure {worst:.4}; \
         converged {converged:.4}, mean {mean:.4}"
    );
    assert!(mean > 0.0);
    // With one sample per dense step the sample lies anywhere up to a step deep in the cloud,
    // and the wall's brightness follows the step grid; without the stride back-up the march
    // starts its detail after the wall's edge.
    assert!(
        worst < 0.05,
        "the wall's brightness follows the step grid: {worst}"
    );
    let bias = (mean - converged).abs() / converged;
    assert!(
        bias < 0.05,
        "the wall's mean brightness {mean} against {converged} converged"
    );
}

/// The march is continuous in the density where a step turns dense, even at a cloud's
/// sharp edge: there the one-sample step and the thin parts from the edge see different
/// parts of the step, and they are mixed between optical thickness 1 and 2
/// ([`dense_step_weight`]). So a density that rounds differently on the GPU changes the
/// light a little, not a lot. Dense steps in a homogeneous slab also match its closed form.
#[test]
fn dense_steps_are_continuous_in_the_density() {
    // 16 steps through the 1 km slab, about 62.5 m long (x = 1 at σ = 0.016 /m). The cloud
    // begins sharply at a height inside a step, over a range of heights: wherever a step's
    // sample is clear and the next one's is dense, the next step searches back for the edge.
    let settings = MarchSettings {
        step_growth: 0.0,
        ..slab_settings(16, 20.0)
    };
    let radiance = |extinction: f64, edge: f64| {
        let mut layer = slab(extinction);
        layer.set_profile(&[[0.0, 0.0], [edge, 0.0], [edge + 1e-5, 1.0], [1.0, 1.0]]);
        march_up(&settings, std::slice::from_ref(&layer)).radiance[1]
    };
    let step_m = 1000.0 / 16.0;
    for x in [MAX_STEP_OPTICAL_DEPTH, 2.0 * MAX_STEP_OPTICAL_DEPTH] {
        let sigma = x / step_m;
        let jump = (0..12)
            .map(|i| {
                let edge = 0.25 + 0.01 * f64::from(i);
                let below = radiance(sigma * (1.0 - 1e-9), edge);
                let above = radiance(sigma * (1.0 + 1e-9), edge);
                relative_error(above, below)
            })
            .fold(0.0, f64::max);
        eprintln!("x = {x}: largest jump {jump:.2e}");
        assert!(jump < 1e-6, "the light jumps at x = {x}: {jump}");
    }
    // Dense steps (x = 4: all parts) still integrate the slab as the closed form does.
    // It is opaque (τ = 64), so the light seen from below is the ambient sky's at its base.
    let layer = slab(4.0 / step_m);
    let marched = march_up(&settings, std::slice::from_ref(&layer));
    let exact = homogeneous_slab(&settings, &layer);
    let error = relative_error(marched.radiance[1], exact.radiance[1]);
    eprintln!(
        "x = 4: L {:.6e} against {:.6e} closed form",
        marched.radiance[1], exact.radiance[1]
    );
    assert!(error < 0.005, "{marched:?} vs {exact:?}");
}

#[test]
fn a_part_sampled_at_its_offset_integrates_a_homogeneous_part_exactly_over_jitters() {
    // One sample per part, at `part_offset` of a jitter u, weighted by the part's exact
    // transmittance integral, averaged over u: `∫ S(s) e^(−σs) ds` for any source S. A source
    // that grows along the part (a cloud lit from deeper in) at x = 2, the thickest part a
    // dense step takes: the uniform offset weighs the far half, seen through little
    // transmittance, as much as the near half and overshoots by about 12 %.
    let (sigma, length) = (0.064, MAX_STEP_OPTICAL_DEPTH / 0.064);
    let source = |s: f64| 1.0 + (s / length).powi(2);
    let exact = {
        let n = 100_000;
        let h = length / f64::from(n);
        (0..n)
            .map(|i| {
                let s = (f64::from(i) + 0.5) * h;
                source(s) * (-sigma * s).exp() * h
            })
            .sum::<f64>()
    };
    let weight = -(-sigma * length).exp_m1() / sigma;
    let jitters = 10_000;
    let mean = |offset: &dyn Fn(f64) -> f64| {
        (0..jitters)
            .map(|i| source(offset((f64::from(i) + 0.5) / f64::from(jitters))))
            .sum::<f64>()
            / f64::from(jitters)
            * weight
    };
    let weighted = mean(&|u| part_offset(u, sigma, length));
    let uniform = mean(&|u| u * length);
    eprintln!("exact {exact:.6}, weighted offset {weighted:.6}, uniform {uniform:.6}");
    assert!(
        relative_error(weighted, exact) < 1e-4,
        "{weighted} vs {exact}"
    );
    assert!(
        relative_error(uniform, exact) > 0.05,
        "the source is too flat to tell"
    );
    // Thin parts and the ends of the jitter stay inside the part.
    assert_eq!(part_offset(0.5, 1e-9, 10.0), 5.0);
    assert_eq!(part_offset(0.0, sigma, length), 0.0);
    assert!((part_offset(1.0, sigma, length) - length).abs() < 1e-9);
}

#[test]
fn the_early_exit_keeps_the_light_of_the_scaled_medium() {
    // Backlit decks seen from below, 10° from the sun, with multiple scattering: the
    // forward-peaked light comes through the δ-scaled medium, whose transmittance where the
    // true medium's reaches 1 % (τ = 4.6) is still e^(−(1 − f) 4.6), several times the cut-off.
    // Stopping there would drop it and the sky behind; the march stops on the scaled medium, so
    // a 1 % cut-off may lose about 1 % of the light, not the glow behind the stop.
    for extinction in [0.005, 0.006, 0.008, 0.012] {
        let layer = slab(extinction);
        let full = MarchSettings {
            multiple_scattering: true,
            ..slab_settings(512, 80.0)
        };
        let cut = MarchSettings {
            transmittance_cutoff: 0.01,
            ..full.clone()
        };
        let reference = march_up(&full, std::slice::from_ref(&layer));
        let stopped = march_up(&cut, std::slice::from_ref(&layer));
        assert_sane(&stopped, "stopped");
        for c in 0..3 {
            let error = relative_error(stopped.radiance[c], reference.radiance[c]);
            assert!(
                error < 0.02,
                "τ {}, channel {c}: {} with the cut-off, {} without ({:.2} %)",
                extinction * 1000.0,
                stopped.radiance[c],
                reference.radiance[c],
                100.0 * error
            );
        }
    }
}

#[test]
fn a_black_object_at_the_visibility_distance_keeps_koschmieders_contrast() {
    // Uniform fog from the ground up, visibility V = 800 m, seen level from 2 m: a black object
    // at distance d ends the ray with `L_inf (1 − e^(−σ d))` in front of it, the fog horizon
    // beside it is `L_inf`, so their contrast is `e^(−σ d)` (Koschmieder; 2 % at d = V). It must
    // hold for single and multiple scattering (the δ-scaled medium's forward light behind the
    // object, `add_background`) and with the early exit on the open ray (its tail).
    let sigma = 3.912 / 800.0;
    let distance = 810.0;
    let mut fog = MarchLayer {
        base_m: 0.0,
        top_m: 150.0,
        coverage: 1.0,
        extinction: sigma,
        shape_strength: 0.0,
        ..MarchLayer::default()
    };
    fog.set_profile(&[[0.0, 1.0], [1.0, 1.0]]);
    let (elevation, azimuth) = (30f64.to_radians(), 50f64.to_radians());
    let expected = (-sigma * distance).exp();
    for multiple_scattering in [false, true] {
        for transmittance_cutoff in [0.0, 0.01] {
            let settings = MarchSettings {
                primary_steps: 192,
                sun_direction: [
                    elevation.cos() * azimuth.sin(),
                    elevation.sin(),
                    -elevation.cos() * azimuth.cos(),
                ],
                multiple_scattering,
                transmittance_cutoff,
                jitter: false,
                camera_altitude_m: 2.0,
                ..MarchSettings::default()
            };
            let march = |t_max: f64| {
                march_clouds(
                    textures(),
                    &settings,
                    std::slice::from_ref(&fog),
                    settings.camera_altitude_m,
                    UP,
                    [0.0, 0.0, -1.0],
                    t_max,
                    0.5,
                    None,
                )
            };
            let (target, open) = (march(distance), march(f64::INFINITY));
            assert_sane(&target, "target");
            assert_sane(&open, "open fog");
            for c in 0..3 {
                let contrast = (open.radiance[c] - target.radiance[c]) / open.radiance[c];
                assert!(
                    (contrast - expected).abs() < 0.001,
                    "multiple scattering {multiple_scattering}, cut-off {transmittance_cutoff}, \
                     channel {c}: contrast {contrast:.4}, expected {expected:.4}"
                );
            }
        }
    }
}

#[test]
fn samples_deep_in_the_cloud_march_fewer_light_steps() {
    use super::march::{FULL_LIGHT_STEPS_TRANSMITTANCE, light_steps_at};
    let full = FULL_LIGHT_STEPS_TRANSMITTANCE;
    // Near the cloud's surface every sample takes the preset's light steps.
    for steps in [1, 4, 10, 14, 24] {
        assert_eq!(light_steps_at(steps, 1.0, 1.0, 0.01), steps);
        assert_eq!(light_steps_at(steps, full, full, 0.01), steps);
    }
    // Deeper, in proportion to the cut-off transmittance, rounded up, never fewer than 4 nor
    // more than the preset's.
    assert_eq!(light_steps_at(14, 0.02, 0.5 * full, 0.01), 7);
    assert_eq!(light_steps_at(24, 0.05, 0.2 * full, 0.01), 5);
    assert_eq!(light_steps_at(14, 0.05, 0.2 * full, 0.01), 4);
    assert_eq!(light_steps_at(3, 0.05, 0.2 * full, 0.01), 3);
    // Past the true medium's cut-off a quarter, if that is fewer.
    assert_eq!(light_steps_at(24, 0.01, 0.8 * full, 0.01), 6);
    assert_eq!(light_steps_at(14, 0.005, 0.6 * full, 0.01), 4);
    assert_eq!(light_steps_at(1, 0.005, 0.6 * full, 0.01), 1);
    // Without an early exit (the converged reference) every light step, however deep.
    assert_eq!(light_steps_at(64, 0.001, 0.01 * full, 0.0), 64);
}

#[test]
fn rays_away_from_the_sun_into_the_sky_stop_sooner() {
    use crate::reference::composite::FAR_AWAY;
    let cutoff = 0.01;
    // Within about 32° of the sun every ray keeps the cut-off; from 60° on a sky ray takes
    // AWAY_FROM_SUN_CUTOFF_GAIN times it, linearly between.
    assert_eq!(ray_transmittance_cutoff(cutoff, 1.0, f64::INFINITY), cutoff);
    assert_eq!(
        ray_transmittance_cutoff(cutoff, TOWARD_SUN_COS, FAR_AWAY),
        cutoff
    );
    let away = ray_transmittance_cutoff(cutoff, 0.0, f64::INFINITY);
    assert!(
        (away - AWAY_FROM_SUN_CUTOFF_GAIN * cutoff).abs() < 1e-15,
        "{away}"
    );
    let between =
        ray_transmittance_cutoff(cutoff, 0.5 * (TOWARD_SUN_COS + AWAY_FROM_SUN_COS), FAR_AWAY);
    assert!(
        (between - 0.5 * (1.0 + AWAY_FROM_SUN_CUTOFF_GAIN) * cutoff).abs() < 1e-12,
        "{between}"
    );
    // A ray to a scene object keeps it (the tail does not know where the object is), the
    // converged march's 0 stays 0, and no cut-off passes 1.
    assert_eq!(ray_transmittance_cutoff(cutoff, 0.0, 5_000.0), cutoff);
    assert_eq!(ray_transmittance_cutoff(0.0, 0.0, f64::INFINITY), 0.0);
    assert_eq!(ray_transmittance_cutoff(0.5, 0.0, f64::INFINITY), 1.0);
}

/// The cloud shadow map takes over from the light march between about 32° and 37° from the sun,
/// its share of the optical depth growing linearly with the cosine ([`shadow_map_share`]): a
/// switch at one angle drew a ring around the sun on the clouds. Likewise while the sun climbs
/// from 10° to 12°: a switch at 10° changed the whole sky at once. Under a sun below 10° the
/// light march stays everywhere.
#[test]
fn the_shadow_map_takes_over_gradually_around_the_sun() {
    let high = 0.5;
    assert_eq!(shadow_map_share(TOWARD_SUN_COS + 0.001, high), 0.0);
    assert_eq!(shadow_map_share(1.0, high), 0.0);
    assert_eq!(shadow_map_share(SHADOW_MAP_BLEND_COS - 0.001, high), 1.0);
    assert_eq!(shadow_map_share(-1.0, high), 1.0);
    for fraction in [0.1, 0.25, 0.5, 0.75, 0.9] {
        let cos_sun = TOWARD_SUN_COS - fraction * (TOWARD_SUN_COS - SHADOW_MAP_BLEND_COS);
        let share = shadow_map_share(cos_sun, high);
        assert!((share - fraction).abs() < 1e-12, "{fraction}: {share}");
        let mu_sun =
            SHADOW_MAP_MIN_SUN_MU + fraction * (SHADOW_MAP_FULL_SUN_MU - SHADOW_MAP_MIN_SUN_MU);
        let share = shadow_map_share(-1.0, mu_sun);
        assert!((share - fraction).abs() < 1e-12, "sun {fraction}: {share}");
    }
    assert_eq!(shadow_map_share(-1.0, SHADOW_MAP_FULL_SUN_MU), 1.0);
    assert_eq!(shadow_map_share(0.0, SHADOW_MAP_MIN_SUN_MU - 0.01), 0.0);
    assert_eq!(shadow_map_share(0.0, f64::NAN), 0.0);
}

/// The clear air's transmittance by its 12-step midpoint rule against a fine integral of the same
/// extinction, and its sea-level limit. The fade is a contrast, so its error must stay below the
/// 2 % contrast an eye notices (Koschmieder 1924): 1 % here, from the ground and from a cloud
/// layer's altitude, level, grazing, rising and looking down, out to 300 km.
#[test]
fn the_clear_air_transmittance_matches_a_fine_integral() {
    use crate::reference::haze::{
        CLEAR_AIR_EXTINCTION_PER_M, MIE_SCALE_HEIGHT_M, clear_air_extinction,
    };
    let r = EARTH_RADIUS_M;
    let fine = |h: f64, mu: f64, d: f64| {
        let n = 20_000;
        let ds = d / f64::from(n);
        let tau: f64 = (0..n)
            .map(|k| clear_air_extinction(altitude_along_ray(h, mu, (f64::from(k) + 0.5) * ds, r)))
            .sum::<f64>()
            * ds;
        (-tau).exp()
    };
    for h in [0.0, 500.0, 2000.0] {
        for mu in [-0.02, 0.0, 0.01, 0.05, 0.2, 1.0] {
            for d in [1_000.0_f64, 20_000.0, 80_000.0, 300_000.0] {
                // Rays that would go under the ground stop there.
                let d = d.min(ground_distance(h, mu, r));
                let t = clear_air_transmittance(h, mu, d, r);
                let expected = fine(h, mu, d);
                assert!(
                    (t - expected).abs() < 0.01,
                    "h {h} m, mu {mu}, {d} m: {t} against {expected}"
                );
            }
        }
    }
    // Level at sea level over 1 km: e^(−σ₀ d) with the haze's clear-air extinction, the air
    // the haze leaves out. The ray rises d²/2R (8 cm) over it, which thins the air by at most
    // that over the Mie scale height, so the two agree to τ times that; leaving out the Mie
    // part, say, would miss by 4e-3.
    let d = 1000.0;
    let level = clear_air_transmittance(0.0, 0.0, d, r);
    let tau = CLEAR_AIR_EXTINCTION_PER_M * d;
    let rise = d * d / (2.0 * r);
    assert!((level - (-tau).exp()).abs() <= tau * rise / MIE_SCALE_HEIGHT_M);
    for no_cloud in [f64::INFINITY, 0.0, -1.0, f64::NAN] {
        assert_eq!(clear_air_transmittance(0.0, 0.1, no_cloud, r), 1.0);
    }
}

/// An overcast deck seen at a grazing angle 60 km away fades into what lies behind it by the
/// clear air in front of it, while the same deck overhead keeps its look: the far one's
/// opacity and light fall to the air's transmittance, which Koschmieder's law puts near
/// `e^(−3.912 · 60 / 245) = 0.38` for clean air at sea level (visibility 245 km) and higher
/// aloft, so between 0.3 and 0.8 of the airless values; the one overhead keeps 98 % or more.
#[test]
fn distant_clouds_fade_into_the_air_in_front_of_them() {
    let layer = slab(0.002);
    let airless = MarchSettings {
        primary_steps: 64,
        jitter: false,
        ..MarchSettings::default()
    };
    let with_air = MarchSettings {
        clear_air: true,
        ..airless.clone()
    };
    let r = EARTH_RADIUS_M;
    // The ray that meets the base 1000 m up at 60 km.
    let t_base = 60_000.0;
    let mu = ((r + 1000.0).powi(2) - r * r - t_base * t_base) / (2.0 * r * t_base);
    let direction = [(1.0 - mu * mu).sqrt(), mu, 0.0];
    let march = |settings: &MarchSettings, direction: [f64; 3]| {
        march_toward(settings, std::slice::from_ref(&layer), direction)
    };
    let (far_off, far_on) = (march(&airless, direction), march(&with_air, direction));
    // With the sun right behind the far deck the fade is off: the disc is no air light, and a
    // faded deck would let it through.
    let sun_behind = |settings: &MarchSettings| MarchSettings {
        sun_direction: direction,
        ..settings.clone()
    };
    let (behind_off, behind_on) = (
        march(&sun_behind(&airless), direction),
        march(&sun_behind(&with_air), direction),
    );
    assert!(
        (behind_on.transmittance - behind_off.transmittance).abs() < 1e-12
            && behind_on.radiance == behind_off.radiance,
        "a deck in front of the sun keeps its opacity: {behind_on:?} against {behind_off:?}"
    );
    assert_eq!(sun_disc_share(1.0), 1.0);
    assert_eq!(sun_disc_share(2.5_f64.to_radians().cos()), 0.0);
    let (near_off, near_on) = (march(&airless, UP), march(&with_air, UP));
    for (off, on, low, high) in [
        (&far_off, &far_on, 0.3, 0.8),
        (&near_off, &near_on, 0.98, 1.0),
    ] {
        assert_sane(on, "with air");
        let opacity = (1.0 - on.transmittance) / (1.0 - off.transmittance);
        let light = on.radiance[1] / off.radiance[1];
        assert!(
            (low..=high).contains(&opacity) && (low..=high).contains(&light),
            "opacity kept {opacity}, light kept {light} (cloud at {} m)",
            off.distance_m
        );
        assert_eq!(on.distance_m, off.distance_m);
    }
}

/// A lightning flash inside a deck at night lights it from within: a camera under the deck
/// sees it bright right under the flash and dimmer farther off, in proportion to the diffusion
/// approximation's `1 / d` (times the leak) far from the flash, and the deck without a flash
/// stays dark. Far from the flash the light is the diffusion approximation's
/// (`flash_source`'s far field is `3 σ' I / (4π d)` times the leak).
#[test]
fn a_flash_lights_its_cloud_from_within() {
    let layer = slab(0.02);
    let night = MarchSettings {
        primary_steps: 128,
        jitter: false,
        sun_illuminance: [0.0; 3],
        ambient_top: [0.0; 3],
        ambient_bottom: [0.0; 3],
        ..MarchSettings::default()
    };
    let flash = MarchSettings {
        flash_position_m: [0.0, 1_300.0, 0.0],
        flash_intensity_cd: 1.0e9,
        ..night.clone()
    };
    let dark = march_up(&night, std::slice::from_ref(&layer));
    assert_eq!(dark.radiance, [0.0; 3], "no sun, no sky, no flash");
    // Rays up through the deck at the flash and 1, 2 and 4 km from it (the camera moved).
    let seen: Vec<f64> = [0.0, 1_000.0, 2_000.0, 4_000.0]
        .iter()
        .map(|x| {
            let settings = MarchSettings {
                flash_position_m: [-x, 1_300.0, 0.0],
                ..flash.clone()
            };
            let result = march_up(&settings, std::slice::from_ref(&layer));
            assert_sane(&result, "flash");
            assert_eq!(result.radiance[0], result.radiance[2], "white");
            result.radiance[1]
        })
        .collect();
    assert!(
        seen.windows(2).all(|w| w[0] > w[1]) && seen[3] > 0.0,
        "falls off with distance: {seen:?}"
    );
    // The far field: from 2 to 4 km the seen light falls about as `e^(−d / L) / d` (the deck
    // seen from below shows the light within a few optical depths of its base, 300 m under the
    // flash, so the distances are those of the ray's base to the flash, within 10 %).
    let far = |d: f64| (-d / FLASH_LEAK_M).exp() / d;
    let d = |x: f64| (x * x + 300.0_f64.powi(2)).sqrt();
    let expected = far(d(4_000.0)) / far(d(2_000.0));
    let ratio = seen[3] / seen[2];
    assert!(
        relative_error(ratio, expected) < 0.1,
        "4 km over 2 km: {ratio} against {expected}"
    );
    let phase = eddington_phase(&flash);
    let sigma = 0.02;
    let reduced = (1.0 - phase.scaled_asymmetry) * (1.0 - phase.forward_fraction) * sigma;
    let at = 5_000.0;
    let source = flash_source(&flash, &phase, [at, 1_300.0, 0.0], sigma);
    let diffusion =
        3.0 * reduced * 1.0e9 / (4.0 * std::f64::consts::PI * at) * (-at / FLASH_LEAK_M).exp();
    assert!(
        relative_error(source, diffusion) < 1e-9,
        "{source} against {diffusion}"
    );
}
