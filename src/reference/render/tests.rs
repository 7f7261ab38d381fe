//! Tests of the f64 march: shared helpers, and the tests of the geometry, the parameters, the
//! textures, the light and the queries; the density's and the march's are in `tests/`.

use super::*;
use crate::reference::noise::{NoiseRecipe, downsample_3d, quantize_noise};
use std::sync::OnceLock;

mod density;
mod disort;
mod march;
mod mitsuba;

/// Small textures (the default recipe's channels at 16³, 8³ and 32²), the ones the Mitsuba
/// field was exported from: the march samples them exactly as it would the full-size ones, and a
/// debug build generates them in a blink.
fn textures() -> &'static CloudTextures {
    crate::reference::truth::textures()
}

const UP: [f64; 3] = [0.0, 1.0, 0.0];

/// A homogeneous slab from 1000 to 2000 m: coverage 1, no noise, flat profile.
fn slab(extinction: f64) -> MarchLayer {
    let mut layer = MarchLayer {
        base_m: 1000.0,
        top_m: 2000.0,
        coverage: 1.0,
        extinction,
        shape_strength: 0.0,
        ..MarchLayer::default()
    };
    layer.set_profile(&[[0.0, 1.0], [1.0, 1.0]]);
    layer
}

/// Sun at `elevation_deg` above the horizon toward −z, single scattering, no cut-off, no jitter.
fn slab_settings(steps: u32, elevation_deg: f64) -> MarchSettings {
    let e = elevation_deg.to_radians();
    MarchSettings {
        primary_steps: steps,
        sun_direction: [0.0, e.sin(), -e.cos()],
        multiple_scattering: false,
        transmittance_cutoff: 0.0,
        jitter: false,
        ..MarchSettings::default()
    }
}

fn march_up(settings: &MarchSettings, layers: &[MarchLayer]) -> MarchResult {
    march_toward(settings, layers, UP)
}

/// One ray from the camera at `settings.camera_altitude_m` (up is +y) along `direction` into
/// the sky, sampled at step midpoints, without a shadow map.
fn march_toward(
    settings: &MarchSettings,
    layers: &[MarchLayer],
    direction: [f64; 3],
) -> MarchResult {
    march_clouds(
        textures(),
        settings,
        layers,
        settings.camera_altitude_m,
        UP,
        direction,
        f64::INFINITY,
        0.5,
        None,
    )
}

fn relative_error(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        (a - b).abs() / a.abs().max(b.abs())
    }
}

fn assert_sane(result: &MarchResult, what: &str) {
    assert!(
        result.transmittance.is_finite() && (0.0..=1.0).contains(&result.transmittance),
        "{what}: transmittance {}",
        result.transmittance
    );
    for c in result.radiance {
        assert!(
            c.is_finite() && c >= 0.0,
            "{what}: radiance {:?}",
            result.radiance
        );
    }
}

/// A cumulus-like noisy layer at 1500–3000 m.
fn cumulus(coverage: f64) -> MarchLayer {
    MarchLayer {
        coverage,
        ..MarchLayer::default()
    }
}

#[test]
fn mean_step_transmittance_is_stable_at_both_ends() {
    assert_eq!(mean_step_transmittance(0.0), 1.0);
    assert_eq!(mean_step_transmittance(-1.0), 1.0);
    for x in [1e-300_f64, 1e-12, 1e-6, 9.99e-6, 1e-5, 1e-3, 0.1, 1.0, 10.0] {
        // Reference: the series to many terms for small x, the direct form for large.
        let reference = if x < 0.01 {
            1.0 - x / 2.0 + x * x / 6.0 - x.powi(3) / 24.0 + x.powi(4) / 120.0
        } else {
            (1.0 - (-x).exp()) / x
        };
        let value = mean_step_transmittance(x);
        assert!(
            relative_error(value, reference) < 1e-13,
            "f({x}) = {value}, expected {reference}"
        );
    }
    assert_eq!(mean_step_transmittance(1e4), 1e-4);
    assert_eq!(mean_step_transmittance(1e300), 1e-300);
    assert_eq!(mean_step_transmittance(f64::INFINITY), 0.0);
    for x in [0.05, 0.099_999, 0.1, 0.5] {
        let direct = mean_step_transmittance(x) - (-x).exp();
        assert!(
            relative_error(ambient_gradient_integral(x), direct) < 1e-12,
            "{x}"
        );
    }
    assert!(relative_error(ambient_gradient_integral(1e-9), 0.5e-9) < 1e-9);
}

#[test]
fn sphere_intersections_are_exact_in_simple_cases() {
    let r = EARTH_RADIUS_M;
    // Straight up from the ground to 1000 m: the far root is 1000 m, the near one through
    // the planet.
    assert_eq!(
        intersect_altitude_sphere(0.0, 1.0, r, 1000.0),
        [-(2.0 * r + 1000.0), 1000.0]
    );
    // Straight down from 3000 m to 1000 m.
    let [near, far] = intersect_altitude_sphere(3000.0, -1.0, r, 1000.0);
    assert_eq!(near, 2000.0);
    assert!((far - (2.0 * r + 4000.0)).abs() < 1e-6);
    // Horizontal from the ground: √((R + a)² − R²).
    let [_, far] = intersect_altitude_sphere(0.0, 0.0, r, 1000.0);
    let expected = ((r + 1000.0_f64).powi(2) - r * r).sqrt();
    assert!(relative_error(far, expected) < 1e-14);
    // Camera exactly on the sphere: one root is exactly 0.
    assert_eq!(intersect_altitude_sphere(1000.0, 0.3, r, 1000.0)[1], 0.0);
    assert_eq!(intersect_altitude_sphere(1000.0, -0.3, r, 1000.0)[0], 0.0);
    assert_eq!(
        intersect_altitude_sphere(1000.0, 0.0, r, 1000.0),
        [0.0, 0.0]
    );
    // Above the sphere looking up: both roots behind the camera.
    assert!(intersect_altitude_sphere(5000.0, 0.5, r, 1000.0)[1] < 0.0);
    // A horizontal ray from 5000 m passes over the sphere at 1000 m.
    assert_eq!(
        intersect_altitude_sphere(5000.0, 0.0, r, 1000.0),
        [NO_HIT, NO_HIT]
    );
    // Tangent from above: mu = −√(1 − ((R + a)/(R + h))²), a double root at the tangent
    // point; nudged up, a miss; nudged down, two close roots. No NaN anywhere.
    let (h, a) = (5000.0, 1000.0);
    let mu_tangent = -(1.0 - ((r + a) / (r + h)).powi(2)).sqrt();
    let distance = ((r + h).powi(2) - (r + a).powi(2)).sqrt();
    for mu in [mu_tangent, mu_tangent + 1e-12, mu_tangent - 1e-12] {
        let roots = intersect_altitude_sphere(h, mu, r, a);
        assert!(roots.iter().all(|t| t.is_finite()), "{roots:?}");
        if roots != [NO_HIT, NO_HIT] {
            assert!(
                relative_error(roots[0], distance) < 1e-3,
                "{roots:?} vs {distance}"
            );
        }
    }
}

#[test]
fn altitude_along_ray_matches_the_direct_formula() {
    let r = EARTH_RADIUS_M;
    for (h, mu, t) in [
        (0.0, 1.0, 1234.5),
        (1500.0, 0.0, 50_000.0),
        (400_000.0, -0.8, 300_000.0),
        (10.0, -0.001, 7000.0),
    ] {
        let a = r + h;
        let direct = ((a + t * mu).powi(2) + t * t * (1.0 - mu * mu)).sqrt() - r;
        let stable = altitude_along_ray(h, mu, t, r);
        assert!(
            (stable - direct).abs() < 1e-6,
            "h {h} mu {mu} t {t}: {stable} vs {direct}"
        );
    }
    assert_eq!(altitude_along_ray(1000.0, 1.0, 500.0, r), 1500.0);
    assert_eq!(altitude_along_ray(1000.0, 0.3, 0.0, r), 1000.0);
}

#[test]
fn shells_and_intervals_cover_the_right_distances() {
    let r = EARTH_RADIUS_M;
    // From the ground straight up through [1000, 2000]: one piece.
    let [first, second] = shell_segments(0.0, 1.0, r, 1000.0, 2000.0);
    assert!(first[1] <= first[0]);
    assert_eq!(second, [1000.0, 2000.0]);
    // Inside the layer looking down: the part above the base.
    let [first, _] = shell_segments(1500.0, -1.0, r, 1000.0, 2000.0);
    assert_eq!(first, [0.0, 500.0]);
    // Two disjoint layers and one overlapping the first: two merged intervals.
    let mut low = slab(0.01);
    low.top_m = 1500.0;
    let mut overlap = slab(0.01);
    overlap.base_m = 1400.0;
    overlap.top_m = 2000.0;
    let mut high = slab(0.01);
    high.base_m = 8000.0;
    high.top_m = 9000.0;
    let layers = [high.clone(), low, overlap];
    let first = next_cloud_interval(&layers, r, 0.0, 1.0, 0.0, f64::INFINITY);
    assert_eq!(first, [1000.0, 2000.0]);
    let second = next_cloud_interval(&layers, r, 0.0, 1.0, first[1], f64::INFINITY);
    assert_eq!(second, [8000.0, 9000.0]);
    let none = next_cloud_interval(&layers, r, 0.0, 1.0, second[1], f64::INFINITY);
    assert!(none[1] <= none[0]);
    // The scene ends the ray inside the first interval.
    assert_eq!(
        next_cloud_interval(&layers, r, 0.0, 1.0, 0.0, 1200.0),
        [1000.0, 1200.0]
    );
    // Inactive layers are ignored.
    let mut empty = high.clone();
    empty.coverage = 0.0;
    let none = next_cloud_interval(&[empty], r, 0.0, 1.0, 0.0, f64::INFINITY);
    assert!(none[1] <= none[0]);
    // The ground stops a downward ray from space before the far side of the planet.
    assert!(ground_distance(400_000.0, -1.0, r) == 400_000.0);
    assert!(ground_distance(0.0, -0.5, r) == 0.0);
    assert!(ground_distance(0.0, 0.0, r).is_infinite());
    assert!(ground_distance(0.0, 0.5, r).is_infinite());
}

#[test]
fn wrapped_wind_offsets_keep_the_same_clouds() {
    let settings = MarchSettings::default();
    let mut near = cumulus(0.5);
    near.weather_scale_m = 20_000.0;
    near.shape_scale_m = 8000.0;
    near.detail_scale_m = 1000.0;
    let mut far = near.clone();
    let origin = [1234.5, -678.25];
    near.set_noise_origin(origin);
    // A week of 30 m/s wind later, plus whole common periods (1280 km: the weather's 20 km,
    // the shape's 8 km and the broad warp's 256 km): the same noise.
    let periods = (7.0 * 86_400.0 * 30.0 / 1_280_000.0_f64).round() * 1_280_000.0;
    far.set_noise_origin([origin[0] + periods, origin[1] - periods]);
    for (a, b) in [
        (near.weather_offset_m, far.weather_offset_m),
        (near.shape_offset_m, far.shape_offset_m),
        (near.detail_offset_m, far.detail_offset_m),
        (near.warp_offset_m, far.warp_offset_m),
    ] {
        assert!(
            (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6,
            "{a:?} {b:?}"
        );
    }
    for position in [[0.0, 2000.0, 0.0], [300.0, 2500.0, -1200.0]] {
        let a = density_at(textures(), &settings, std::slice::from_ref(&near), position);
        let b = density_at(textures(), &settings, std::slice::from_ref(&far), position);
        assert!((a - b).abs() <= 1e-9 * a.abs().max(1e-12), "{a} vs {b}");
    }
    assert_eq!(
        wrap_noise_offset([-1.0, 20_000.0], 20_000.0),
        [19_999.0, 0.0]
    );
    assert_eq!(wrap_noise_offset([5.0, 5.0], 0.0), [0.0, 0.0]);
}

#[test]
fn cpu_queries_answer_in_cloud_and_sunlight() {
    let layer = slab(0.002);
    let layers = std::slice::from_ref(&layer);
    let inside = MarchSettings {
        camera_altitude_m: 1500.0,
        sun_direction: UP,
        ..MarchSettings::default()
    };
    assert!(is_in_cloud(textures(), &inside, layers, [0.0; 3]));
    assert_eq!(density_at(textures(), &inside, layers, [0.0; 3]), 0.002);
    // 500 m of cloud above the camera, sun at the zenith: e^(−1).
    let t = transmittance_to_sun(textures(), &inside, layers, [0.0; 3]);
    assert!(relative_error(t, (-1.0_f64).exp()) < 1e-12, "{t}");
    let below = MarchSettings {
        camera_altitude_m: 500.0,
        ..inside.clone()
    };
    assert!(!is_in_cloud(textures(), &below, layers, [0.0; 3]));
    assert!(is_in_cloud(textures(), &below, layers, [0.0, 600.0, 0.0]));
    assert_eq!(
        transmittance_to_sun(textures(), &below, layers, [0.0; 3]),
        1.0
    );
    // Sun below the horizon at ground level: the planet's shadow.
    let night = MarchSettings {
        sun_direction: normalize([1.0, -0.1, 0.0]),
        ..below
    };
    assert_eq!(
        transmittance_to_sun(textures(), &night, layers, [0.0; 3]),
        0.0
    );
}

/// The sky light on a cloud under a separate deck is the light the deck lets through: the
/// irradiance under it (the bottom factor) is the deck's diffuse transmittance, a thicker deck
/// lets through less, a deck with no coverage changes nothing, and the low cloud, marched,
/// dims by about that transmittance.
#[test]
fn a_low_cloud_under_a_deck_takes_the_light_the_deck_lets_through() {
    let low = slab(0.01);
    let deck = |extinction: f64, coverage: f64| MarchLayer {
        base_m: 3000.0,
        top_m: 4000.0,
        coverage,
        ..slab(extinction)
    };
    let settings = MarchSettings {
        multiple_scattering: true,
        ..slab_settings(64, 30.0)
    };
    let lit = |deck: &MarchLayer| {
        let mut layers = vec![low.clone(), deck.clone()];
        sky_light_under_layers(&settings, &mut layers);
        assert_eq!(layers[1].sky_light_top, [1.0; 3], "nothing above the deck");
        layers
    };
    for tau in [2.0, 10.0, 33.0] {
        let thick = deck(tau / 1000.0, 1.0);
        let layers = lit(&thick);
        let expected = crate::reference::haze::mean_diffuse_transmittance(&[thick]);
        for c in 0..3 {
            assert!(
                relative_error(layers[0].sky_light_bottom[c], expected) < 1e-9,
                "tau {tau}: {:?} vs {expected}",
                layers[0].sky_light_bottom
            );
        }
    }
    // (Those values are the two-stream diffuse transmittance; here only its order.)
    let thin = lit(&deck(0.002, 1.0))[0].sky_light_bottom[1];
    let thick = lit(&deck(0.033, 1.0))[0].sky_light_bottom[1];
    assert!(thick < thin, "{thick} vs {thin}");
    assert_eq!(lit(&deck(0.033, 0.0))[0].sky_light_top, [1.0; 3]);
    // Seen from under both, looking up into the low cloud's base.
    let camera = MarchSettings {
        camera_altitude_m: 500.0,
        ..settings.clone()
    };
    let open = march_up(&camera, std::slice::from_ref(&low));
    let mut stack = vec![low.clone(), deck(0.033, 1.0)];
    sky_light_under_layers(&camera, &mut stack);
    let shaded = march_up(&camera, &stack);
    let luminance = |r: &MarchResult| r.radiance.iter().sum::<f64>();
    // All the light on the low cloud came through the deck, so it dims by about the deck's
    // diffuse transmittance: within a factor of two of it either way (the light arrives
    // diffuse instead of as a 30° beam, which the cloud scatters down differently). Without
    // the sky light under the deck it stays near the open sky's; with none it goes black.
    let through = crate::reference::haze::mean_diffuse_transmittance(&stack[1..]);
    let dimmed = luminance(&shaded) / luminance(&open);
    assert!(
        (0.5 * through..=2.0 * through).contains(&dimmed),
        "under the deck {dimmed} of the open sky's light, the deck passes {through}"
    );
}

/// A cloud under a separate deck lies in the deck's shade: the light march of a sample in the
/// low layer adds the deck's optical depth along the sun's path through it (at the zenith its
/// thickness times its extinction, at 30° twice that), not only its own layer's.
#[test]
fn a_low_cloud_under_a_deck_is_in_its_shade() {
    let low = slab(0.002);
    let mut deck = slab(0.001);
    deck.base_m = 3000.0;
    deck.top_m = 4000.0;
    let inside_low = |elevation_deg: f64| MarchSettings {
        camera_altitude_m: 1500.0,
        ..slab_settings(64, elevation_deg)
    };
    for (elevation_deg, slant) in [(90.0_f64, 1.0_f64), (30.0, 2.0)] {
        let settings = inside_low(elevation_deg);
        let alone =
            transmittance_to_sun(textures(), &settings, std::slice::from_ref(&low), [0.0; 3]);
        let shaded = transmittance_to_sun(
            textures(),
            &settings,
            &[low.clone(), deck.clone()],
            [0.0; 3],
        );
        // 500 m of the low layer above the point, then 1000 m of the deck (curvature aside).
        let own = (-0.002 * 500.0 * slant).exp();
        let expected = own * (-0.001 * 1000.0 * slant).exp();
        assert!(
            relative_error(alone, own) < 1e-3,
            "{elevation_deg}°: alone {alone} vs {own}"
        );
        assert!(
            relative_error(shaded, expected) < 1e-2,
            "{elevation_deg}°: under the deck {shaded} vs {expected}"
        );
    }
    // The deck does not shade what lies above it, nor a layer beside it in height.
    let above = MarchSettings {
        camera_altitude_m: 3500.0,
        ..inside_low(90.0)
    };
    let deck_alone =
        transmittance_to_sun(textures(), &above, std::slice::from_ref(&deck), [0.0; 3]);
    let with_low = transmittance_to_sun(textures(), &above, &[low, deck], [0.0; 3]);
    assert_eq!(deck_alone, with_low);
}

#[test]
fn textures_sample_like_a_repeating_trilinear_sampler() {
    let base = &textures().base;
    let n = base.size;
    // At a texel centre level 0 returns the texel itself.
    let texel = base.levels[0][(3 + n * (5 + n * 7)) as usize].map(f64::from);
    let centre = [3.5, 5.5, 7.5].map(|c| c / f64::from(n));
    assert_eq!(base.sample(centre, 0.0), texel);
    // Repeat addressing, negative coordinates included.
    for uvw in [[0.01, 0.5, 0.99], [0.3, 0.7, 0.2]] {
        let a = base.sample(uvw, 0.7);
        let b = base.sample([uvw[0] - 3.0, uvw[1] + 2.0, uvw[2] - 1.0], 0.7);
        for c in 0..4 {
            assert!((a[c] - b[c]).abs() < 1e-12);
        }
    }
    // The last mip is one texel; lod beyond the chain clamps to it.
    let last = base.levels.last().unwrap()[0].map(f64::from);
    let sampled = base.sample([0.123, 0.456, 0.789], 99.0);
    for c in 0..4 {
        assert!(
            (sampled[c] - last[c]).abs() < 1e-12,
            "{sampled:?} against {last:?}"
        );
    }
    assert_eq!(base.levels.len(), 5);
    // Mips are the box filter of the rounded level above, rounded again.
    let level1 = &base.levels[1];
    let above: Vec<[f64; 4]> = base.levels[0].iter().map(|t| t.map(f64::from)).collect();
    let expected: Vec<[f32; 4]> = downsample_3d(&above, n)
        .iter()
        .map(|t| t.map(|v| quantize_noise(v) as f32))
        .collect();
    assert_eq!(level1, &expected);
    // Every texel of every level lies on the grid the GPU stores.
    for v in base
        .levels
        .iter()
        .flatten()
        .flatten()
        .map(|v| f64::from(*v))
    {
        assert_eq!(quantize_noise(v), v, "{v} is off the grid");
    }
    // Halfway between two texel centres of the weather texture: their mean.
    let weather = &textures().weather;
    let m = f64::from(weather.size);
    let a = weather.texels[4].map(unorm8);
    let b = weather.texels[5].map(unorm8);
    let mid = weather.sample([5.0 / m, 0.5 / m]);
    for c in 0..4 {
        assert!((mid[c] - 0.5 * (a[c] + b[c])).abs() < 1e-12);
    }
}

#[test]
fn phase_and_jitter_stay_in_range() {
    for g in [-1.0, -0.3, 0.0, 0.8, 1.0] {
        for cos in [-1.0, 0.0, 1.0] {
            let p = henyey_greenstein(cos, g);
            assert!(p.is_finite() && p > 0.0, "HG({cos}, {g}) = {p}");
        }
    }
    // An isotropic lobe is 1 / 4π.
    assert!((henyey_greenstein(0.3, 0.0) - 1.0 / (4.0 * std::f64::consts::PI)).abs() < 1e-15);
    let on = MarchSettings::default();
    for x in 0..64 {
        for frame in [0, 1, 63, 1000] {
            let pixel = [f64::from(x) * 37.0 + 0.5, f64::from(x) * -11.0 + 0.5];
            let j = ray_start_jitter(
                &MarchSettings {
                    frame_index: frame,
                    ..on.clone()
                },
                pixel,
            );
            assert!((0.0..1.0).contains(&j));
        }
    }
    let off = MarchSettings {
        jitter: false,
        ..MarchSettings::default()
    };
    assert_eq!(ray_start_jitter(&off, [3.0, 4.0]), 0.5);
    assert_eq!(step_warp(0.37, 0.0), 0.37);
    assert!((step_warp(1.0, 5.0) - 1.0).abs() < 1e-15);
    assert!((step_warp(0.5, 3.0) - 1.0 / 3.0).abs() < 1e-15);
}

/// The halo's ring is a phase function: it is finite and never negative, and it integrates to
/// 1 over the sphere (the midpoint rule on 0.001° steps, whose own error is far below the
/// 10⁻⁴ allowed). It is 0 inside its inner edge's ramp and peaks at [`HALO_ANGLE_DEG`], to
/// within a step of the grid.
#[test]
fn the_halo_ring_integrates_to_one_and_peaks_at_22_degrees() {
    let steps = 180_000;
    let dtheta = std::f64::consts::PI / f64::from(steps);
    let mut total = 0.0;
    let mut peak = (0.0, 0.0);
    for k in 0..steps {
        let theta = (f64::from(k) + 0.5) * dtheta;
        let p = halo_phase(theta.cos());
        assert!(p.is_finite() && p >= 0.0, "{theta}: {p}");
        total += 2.0 * std::f64::consts::PI * p * theta.sin() * dtheta;
        if p > peak.1 {
            peak = (theta.to_degrees(), p);
        }
    }
    assert!((total - 1.0).abs() < 1e-4, "integral {total}");
    assert!(
        (peak.0 - HALO_ANGLE_DEG).abs() <= dtheta.to_degrees(),
        "peak at {:.4}°",
        peak.0
    );
    assert_eq!(
        halo_phase((HALO_ANGLE_DEG - HALO_EDGE_DEG - 0.01).to_radians().cos()),
        0.0
    );
    assert_eq!(halo_phase(1.0), 0.0);
}

/// A thin veil (optical depth 0.3) with the default halo share (`CloudWorld::halo_share`)
/// shows a ring: from below, looking 22.5° from the sun is brighter than 20° (inside the ring)
/// and 26° (outside it) by more than the 2 % contrast an eye tells apart (the threshold of
/// Koschmieder's visibility, [`KOSCHMIEDER_CONSTANT`](crate::reference::haze::KOSCHMIEDER_CONSTANT)),
/// where without the halo the forward lobe makes the radiance fall with the angle. Multiple
/// scattering on, the sun 50° up.
#[test]
fn a_veil_with_a_halo_share_shows_a_ring_at_22_degrees() {
    let sun_elevation: f64 = 50.0;
    let settings = MarchSettings {
        multiple_scattering: true,
        ..slab_settings(64, sun_elevation)
    };
    // Radiance (green) looking `angle` degrees from the sun, toward the zenith.
    let radiance = |layer: &MarchLayer, angle: f64| {
        let e = (sun_elevation + angle).to_radians();
        let direction = [0.0, e.sin(), -e.cos()];
        let result = march_clouds(
            textures(),
            &settings,
            std::slice::from_ref(layer),
            settings.camera_altitude_m,
            UP,
            direction,
            f64::INFINITY,
            0.5,
            None,
        );
        assert_sane(&result, "veil");
        result.radiance[1]
    };
    let plain = slab(0.3 / 1000.0);
    let veil = MarchLayer {
        halo_share: f64::from(crate::world::CloudWorld::EARTH.halo_share),
        ..plain.clone()
    };
    let [inside, ring, outside] = [20.0, 22.5, 26.0].map(|a| radiance(&veil, a));
    let [plain_inside, plain_ring, plain_outside] = [20.0, 22.5, 26.0].map(|a| radiance(&plain, a));
    eprintln!(
        "with the halo {inside:.4} {ring:.4} {outside:.4}; without {plain_inside:.4} \
         {plain_ring:.4} {plain_outside:.4}"
    );
    assert!(plain_inside > plain_ring && plain_ring > plain_outside);
    let visible = 1.02;
    assert!(ring > visible * inside, "ring {ring}, inside {inside}");
    assert!(ring > visible * outside, "ring {ring}, outside {outside}");
    // Inside the ring the veil loses the halo's share of its forward lobe.
    assert!(inside < plain_inside);
}

/// A view ray far from the sun takes the share `light_steps_away_from_sun` of the light steps,
/// one near it all of them ([`ray_light_steps`]), and the march follows: toward the sun the
/// image is the same, away from it the ray's samples are lit with fewer steps.
#[test]
fn rays_away_from_the_sun_take_fewer_light_steps() {
    assert_eq!(ray_light_steps(14, 1.0, 0.5, 0.5), 14);
    assert_eq!(ray_light_steps(14, TOWARD_SUN_COS, 0.5, 0.5), 14);
    assert_eq!(ray_light_steps(14, AWAY_FROM_SUN_COS, 0.5, 0.5), 7);
    assert_eq!(ray_light_steps(14, -1.0, 0.5, 0.5), 7);
    // Halfway between: three quarters of 14 (10.5), rounded after adding the jitter.
    let between = 0.5 * (TOWARD_SUN_COS + AWAY_FROM_SUN_COS);
    assert_eq!(ray_light_steps(14, between, 0.5, 0.25), 10);
    assert_eq!(ray_light_steps(14, between, 0.5, 0.75), 11);
    assert_eq!(ray_light_steps(14, -1.0, 0.0, 0.5), 1);
    assert_eq!(ray_light_steps(14, -1.0, 1.0, 0.99), 14);
    assert_eq!(ray_light_steps(14, -1.0, f64::NAN, 0.5), 14);
    assert_eq!(ray_light_steps(14, -1.0, 7.0, 0.5), 14);
    assert_eq!(ray_light_steps(0, -1.0, 0.5, 0.5), 0);
    // Averaged over the jitter the count follows the angle without a jump: from one angle to
    // the next, 1/200 of the way from 60° to 32° from the sun, the mean moves by no more than
    // the share's own change (7/200 of a step, 0.035), where the count alone jumps by a step.
    let mean_steps = |cos_sun: f64| {
        (0..64)
            .map(|k| {
                f64::from(ray_light_steps(
                    14,
                    cos_sun,
                    0.5,
                    (f64::from(k) + 0.5) / 64.0,
                ))
            })
            .sum::<f64>()
            / 64.0
    };
    let angles: Vec<f64> = (0..=200)
        .map(|i| AWAY_FROM_SUN_COS + (TOWARD_SUN_COS - AWAY_FROM_SUN_COS) * f64::from(i) / 200.0)
        .collect();
    for pair in angles.windows(2) {
        let jump = (mean_steps(pair[1]) - mean_steps(pair[0])).abs();
        assert!(
            jump <= 0.05,
            "mean light steps jump by {jump} at cos {}",
            pair[1]
        );
        let (a, b) = (
            ray_light_steps(14, pair[0], 0.5, 0.5),
            ray_light_steps(14, pair[1], 0.5, 0.5),
        );
        assert!(a.abs_diff(b) <= 1);
    }

    let layers = [cumulus(0.6)];
    let march = |direction: [f64; 3], away: f64| {
        let settings = MarchSettings {
            light_steps: 14,
            jitter: false,
            light_steps_away_from_sun: away,
            ..MarchSettings::default()
        };
        march_toward(&settings, &layers, direction)
    };
    let sun = MarchSettings::default().sun_direction;
    assert_eq!(march(sun, 0.5), march(sun, 1.0));
    // Rays 20° to 80° up, all around the horizon; those 60° or more from the sun that cross
    // cloud.
    let away: Vec<[f64; 3]> = (0..7 * 36)
        .map(|k| {
            let e = f64::from(20 + 10 * (k / 36)).to_radians();
            let a = f64::from(10 * (k % 36)).to_radians();
            [e.cos() * a.cos(), e.sin(), e.cos() * a.sin()]
        })
        .filter(|d| dot(*d, sun) <= AWAY_FROM_SUN_COS && march(*d, 1.0).transmittance < 0.9)
        .collect();
    assert!(!away.is_empty(), "no cloudy ray away from the sun");
    for direction in away {
        assert_ne!(
            march(direction, 0.5),
            march(direction, 1.0),
            "{direction:?}"
        );
    }
}

/// A low sun's light march: its path through the layer is many kilometres long, so it takes
/// more steps ([`light_step_count`]), sampled at the steps' midpoints
/// ([`LIGHT_SAMPLE_OFFSET`]), and comes close to a converged light march. A far sample
/// (a footprint of hundreds of metres) takes fewer of those extra steps
/// ([`MarchSettings::light_steps_per_footprint`]) for little more error.
#[test]
fn a_low_suns_light_march_converges_over_its_offsets() {
    let none = f64::INFINITY;
    assert_eq!(light_step_count(8, 1_000.0, 0.0, none, 0.5), 8);
    assert_eq!(light_step_count(8, LIGHT_STEP_SPAN_M, 0.0, none, 0.5), 8);
    assert_eq!(
        light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 0.0, none, 0.5),
        56
    );
    assert_eq!(light_step_count(8, 1e12, 0.0, none, 0.5), MAX_LIGHT_STEPS);
    assert_eq!(light_step_count(0, 1e4, 0.0, none, 0.5), 0);
    assert_eq!(light_step_count(8, f64::NAN, 0.0, none, 0.5), 8);
    assert_eq!(light_step_count(500, 1.0, 0.0, none, 0.5), MAX_LIGHT_STEPS);
    // One extra step per 500 m footprint over 14 km: 28, not 56; never below 8.
    assert_eq!(
        light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 500.0, 1.0, 0.5),
        28
    );
    assert_eq!(
        light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 5_000.0, 1.0, 0.5),
        8
    );
    assert_eq!(
        light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 0.0, 1.0, 0.5),
        56
    );
    for no_limit in [0.0, -1.0, f64::NAN, none] {
        assert_eq!(
            light_step_count(8, 7.0 * LIGHT_STEP_SPAN_M, 500.0, no_limit, 0.5),
            56
        );
    }
    // Averaged over the jitter the count grows with the path without a jump: from one length
    // to the next, 10 m apart, the mean moves by about the path's own share (8 steps per 2 km:
    // 0.04), where the count alone jumps by a step every 250 m. Likewise with the footprint
    // limit at 100 m: a step per 100 m.
    let mean_steps = |distance: f64, per_footprint: f64| {
        (0..64)
            .map(|k| {
                let jitter = (f64::from(k) + 0.5) / 64.0;
                f64::from(light_step_count(8, distance, 100.0, per_footprint, jitter))
            })
            .sum::<f64>()
            / 64.0
    };
    for per_footprint in [none, 1.0] {
        let share = if per_footprint == none {
            8.0 / LIGHT_STEP_SPAN_M
        } else {
            0.01
        };
        for i in 0..600 {
            let d = 2_000.0 + 10.0 * f64::from(i);
            let jump = mean_steps(d + 10.0, per_footprint) - mean_steps(d, per_footprint);
            assert!(
                (0.0..=10.0 * share + 1.0 / 64.0).contains(&jump),
                "mean light steps jump by {jump} from {d} m"
            );
        }
    }

    // Cumulus 1.5–3 km under a sun 4° high: light paths up to 21 km through the layer, from
    // 192 points 1.7–2.9 km up.
    let e = 4f64.to_radians();
    let settings = MarchSettings {
        sun_direction: [0.0, e.sin(), -e.cos()],
        ..MarchSettings::default()
    };
    let layers = [MarchLayer {
        coverage: 0.6,
        ..MarchLayer::default()
    }];
    // Mean |error| against 64 steps of: 8 midpoint steps, 8 steps averaged over 16 offsets,
    // and 24 steps whose extra steps are limited to one per 350 m footprint (with the
    // steps that took, and the steps without the limit).
    let (mut midpoint_error, mut mean_error, mut limited_error) = (0.0, 0.0, 0.0);
    let (mut limited_steps, mut full_steps, mut count) = (0.0, 0.0, 0.0);
    let footprint = 350.0;
    for i in 0..192 {
        let position = [
            173.0 * f64::from(i),
            1_700.0 + 6.25 * f64::from(i),
            311.0 * f64::from(i),
        ];
        let altitude = altitude_of(&settings, position);
        let depth = |steps: u32, offset: f64, footprint: f64, per_footprint: f64| {
            let settings = MarchSettings {
                light_steps_per_footprint: per_footprint,
                ..settings
            };
            sun_optical_depth(
                textures(),
                &settings,
                &layers,
                0.0,
                UP,
                position,
                altitude,
                footprint,
                f64::INFINITY,
                steps,
                offset,
                0.5,
            )
        };
        let converged = (-depth(MAX_LIGHT_STEPS, 0.5, 0.0, none)).exp();
        let jitters = 16;
        let mean = (0..jitters)
            .map(|j| (-depth(8, (f64::from(j) + 0.5) / f64::from(jitters), 0.0, none)).exp())
            .sum::<f64>()
            / f64::from(jitters);
        mean_error += (mean - converged).abs();
        midpoint_error += ((-depth(8, LIGHT_SAMPLE_OFFSET, 0.0, none)).exp() - converged).abs();
        // Far samples: the limited march against 64 steps at the same footprint (the same
        // mips).
        let far = (-depth(MAX_LIGHT_STEPS, 0.5, footprint, none)).exp();
        let limited = (-depth(24, LIGHT_SAMPLE_OFFSET, footprint, 1.0)).exp();
        limited_error += (limited - far).abs();
        let mu = point_mu_sun(&settings, 0.0, UP, position, altitude);
        let distance = light_march_distance(&layers, settings.planet_radius_m, altitude, mu);
        limited_steps += f64::from(light_step_count(24, distance, footprint, 1.0, 0.5));
        full_steps += f64::from(light_step_count(24, distance, footprint, none, 0.5));
        count += converged;
    }
    let (error, mean_error) = (midpoint_error / count, mean_error / count);
    let limited_error = limited_error / count;
    eprintln!(
        "light transmittance: midpoints off by {error:.4}, mean over offsets {mean_error:.4} \
         (of the mean); 24 steps limited to one per {footprint} m footprint: {:.1} steps \
         instead of {:.1}, off by {limited_error:.4}",
        limited_steps / 192.0,
        full_steps / 192.0
    );
    // Measured: midpoints 0.53 %, mean over offsets 0.57 %; limited: 32.0 steps instead of
    // 53.2, off by 1.37 %.
    assert!(
        error < 0.01,
        "light transmittance off by {error} on average"
    );
    assert!(
        limited_steps < 0.7 * full_steps,
        "the limit saved too few steps: {limited_steps} of {full_steps}"
    );
    assert!(
        limited_error < 0.02,
        "the limited light march is off by {limited_error} on average"
    );
}

/// A light path that holds little optical depth takes few steps, and the transmittance they give
/// is as close to a fine quadrature as the dense cloud's own light march is (the 1 % of
/// `a_low_suns_light_march_converges_over_its_offsets`): a veil of cirrostratus (peak 0.0004/m
/// over 1 km, full cover) under suns 15°, 40° and 70° up, from 128 points in the veil.
#[test]
fn an_optically_thin_light_path_takes_few_steps() {
    let mut veil = MarchLayer {
        base_m: 7_500.0,
        top_m: 8_500.0,
        coverage: 0.9,
        extinction: 0.000_4,
        shape_scale_m: 3_000.0,
        detail_scale_m: 600.0,
        ..MarchLayer::default()
    };
    veil.set_profile(&[[0.0, 0.0], [0.2, 0.6], [0.8, 0.6], [1.0, 0.0]]);
    let layers = [veil];
    let light_steps = 24;
    for elevation_deg in [15.0f64, 40.0, 70.0] {
        let e = elevation_deg.to_radians();
        // Without the bound (the default) and with it.
        let every = MarchSettings {
            sun_direction: [0.0, e.sin(), -e.cos()],
            ..MarchSettings::default()
        };
        let bounded = MarchSettings {
            light_step_optical_depth: LIGHT_STEP_OPTICAL_DEPTH,
            ..every
        };
        let radius = every.planet_radius_m;
        let axes = horizontal_axes(UP);
        let (mut error, mut unbounded, mut sum, mut steps, mut full) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let points = 128;
        for i in 0..points {
            let position = [
                97.0 * f64::from(i),
                7_520.0 + 7.6 * f64::from(i),
                -53.0 * f64::from(i),
            ];
            let altitude = altitude_of(&every, position);
            let mu = point_mu_sun(&every, 0.0, UP, position, altitude);
            let distance = light_march_distance(&layers, radius, altitude, mu);
            // The fine quadrature: 2048 equal midpoint steps of the full-detail extinction.
            let n = 2048;
            let ds = distance / f64::from(n);
            let fine: f64 = (0..n)
                .map(|k| {
                    let s = (f64::from(k) + 0.5) * ds;
                    let point = add(position, scale(every.sun_direction, s));
                    let height = altitude_along_ray(altitude, mu, s, radius);
                    let horizontal = [dot(point, axes[0]), dot(point, axes[1])];
                    total_extinction(textures(), &layers, horizontal, height, ds, true) * ds
                })
                .sum();
            let jitter = (f64::from(i) * 0.618_034).fract();
            let transmittance = |settings: &MarchSettings| {
                let depth = sun_optical_depth(
                    textures(),
                    settings,
                    &layers,
                    0.0,
                    UP,
                    position,
                    altitude,
                    0.0,
                    f64::INFINITY,
                    light_steps,
                    LIGHT_SAMPLE_OFFSET,
                    jitter,
                );
                (-depth).exp()
            };
            error += (transmittance(&bounded) - (-fine).exp()).abs();
            unbounded += (transmittance(&every) - (-fine).exp()).abs();
            sum += (-fine).exp();
            let all = light_step_count(light_steps, distance, 0.0, f64::INFINITY, jitter);
            let thin = optically_thin_light_steps(
                &layers,
                radius,
                altitude,
                mu,
                distance,
                LIGHT_STEP_OPTICAL_DEPTH,
                jitter,
            );
            steps += f64::from(thin.min(all));
            full += f64::from(all);
        }
        let (error, unbounded) = (error / sum, unbounded / sum);
        let (steps, full) = (steps / f64::from(points), full / f64::from(points));
        eprintln!(
            "sun {elevation_deg}° up: {steps:.2} light steps instead of {full:.2}, \
             transmittance off by {:.3} % of the mean ({:.3} % with every step)",
            100.0 * error,
            100.0 * unbounded
        );
        assert!(
            error < 0.01,
            "sun {elevation_deg}° up: transmittance off by {error}"
        );
        assert!(
            steps <= 0.25 * full,
            "sun {elevation_deg}° up: {steps} light steps of {full}"
        );
    }
    // A cumulus (0.07/m) keeps every step: its light paths hold tens of optical depths.
    let cumulus = [MarchLayer {
        extinction: 0.07,
        ..MarchLayer::default()
    }];
    let steps = |distance: f64, depth: f64| {
        optically_thin_light_steps(&cumulus, 6_371_000.0, 2_000.0, 0.5, distance, depth, 0.0)
    };
    assert!(steps(2_000.0, LIGHT_STEP_OPTICAL_DEPTH) >= MAX_LIGHT_STEPS);
    // No limit: the knob off (infinity, 0, NaN), or a path of no finite length.
    for depth in [f64::INFINITY, 0.0, f64::NAN] {
        assert_eq!(steps(2_000.0, depth), u32::MAX);
    }
    assert_eq!(steps(f64::INFINITY, LIGHT_STEP_OPTICAL_DEPTH), u32::MAX);
}
