//! The light of homogeneous slabs against DISORT (`validation/disort/`, whose script says how the
//! table is made): the march of the CPU twin, at many steps and without jitter, through a
//! horizontally infinite layer on a flat planet, seen from below and above.

use super::*;

/// The committed table, relative to the crate root.
const TABLE: &str = "validation/disort/slabs.csv";
/// The columns the table must have, in order.
const HEADER: &str = "optical_depth,sun_zenith_deg,sky_radiance,below_zenith,below_45,\
                      above_nadir,above_45,total_down_base,direct_down_base,up_top";
/// The views, in the table's column order: (name, looking up, zenith angle of the view, degrees).
const VIEWS: [(&str, bool, f64); 4] = [
    ("below_zenith", true, 0.0),
    ("below_45", true, 45.0),
    ("above_nadir", false, 0.0),
    ("above_45", false, 45.0),
];
/// Radiance targets against DISORT: from optical depth 2 on, and below it.
const TOLERANCE_THICK: f64 = 0.05;
const TOLERANCE_THIN: f64 = crate::reference::table::THIN_MEDIUM_TOLERANCE;
/// Target for a ratio of two brightnesses (the validation's base-to-top target for cumulus).
const RATIO_TOLERANCE: f64 = 0.15;

/// One row of the table: the slab, its lights and DISORT's radiances per unit beam irradiance.
#[derive(Clone, Copy, Debug)]
struct Case {
    optical_depth: f64,
    sun_zenith_deg: f64,
    sky_radiance: f64,
    radiance: [f64; 4],
    /// Direct and diffuse flux down at the base per unit beam irradiance, on a horizontal
    /// surface.
    total_down: f64,
}

/// The cases of `text` (the contents of `file`); an error names the file, the row (1 is the
/// header) and what is wrong.
fn parse_table(file: &str, text: &str) -> Result<Vec<Case>, String> {
    crate::reference::table::parse_table(file, text, HEADER, 10, |_, values| {
        let &[tau, zenith, sky, l0, l1, l2, l3, total_down, _, _] = values else {
            unreachable!("the reader checks the field count");
        };
        if values.iter().any(|v| *v < 0.0) {
            return Err("a negative value".to_owned());
        }
        if !(tau > 0.0 && zenith < 90.0) {
            return Err(format!(
                "optical depth {tau} or sun zenith {zenith}° out of range"
            ));
        }
        Ok(Case {
            optical_depth: tau,
            sun_zenith_deg: zenith,
            sky_radiance: sky,
            radiance: [l0, l1, l2, l3],
            total_down,
        })
    })
}

fn table() -> Vec<Case> {
    crate::reference::table::read_committed(TABLE, parse_table)
}

/// The crate's radiance per unit sun illuminance for `case` seen by `view` (an index into
/// [`VIEWS`]), with the sky behind the slab added as the compositor does (`scene · T + L`; the
/// ground under the slab is black).
fn crate_radiance(case: &Case, view: usize) -> f64 {
    crate_radiance_with(case, view, MarchSettings::default())
}

/// [`crate_radiance`] with the knobs of `march` (its phase) other than the scene's.
fn crate_radiance_with(case: &Case, view: usize, march: MarchSettings) -> f64 {
    const BASE_M: f64 = 1000.0;
    const TOP_M: f64 = 2000.0;
    let mut layer = MarchLayer {
        base_m: BASE_M,
        top_m: TOP_M,
        coverage: 1.0,
        extinction: case.optical_depth / (TOP_M - BASE_M),
        shape_strength: 0.0,
        ..MarchLayer::default()
    };
    layer.set_profile(&[[0.0, 1.0], [1.0, 1.0]]);
    let (_, looking_up, view_zenith) = VIEWS[view];
    let camera_altitude_m = if looking_up { 0.0 } else { 3000.0 };
    let zenith = case.sun_zenith_deg.to_radians();
    let settings = MarchSettings {
        // A plane-parallel slab: a planet so large that its curvature changes no light path.
        planet_radius_m: 1e10,
        camera_altitude_m,
        sun_direction: [0.0, zenith.cos(), -zenith.sin()],
        sun_illuminance: [1.0; 3],
        ambient_top: [case.sky_radiance; 3],
        ambient_bottom: [0.0; 3],
        primary_steps: MAX_PRIMARY_STEPS,
        light_steps: 16,
        step_growth: 0.0,
        transmittance_cutoff: 0.0,
        jitter: false,
        ..march
    };
    // The 45° views look across the sun's azimuth (along x; the sun is toward −z).
    let v = view_zenith.to_radians();
    let vertical = if looking_up { v.cos() } else { -v.cos() };
    let direction = [v.sin(), vertical, 0.0];
    let result = march_clouds(
        textures(),
        &settings,
        std::slice::from_ref(&layer),
        camera_altitude_m,
        UP,
        direction,
        f64::INFINITY,
        0.5,
        None,
    );
    let behind = if looking_up { case.sky_radiance } else { 0.0 };
    result.radiance[1] + result.transmittance * behind
}

/// Every case's relative difference from DISORT, as a table; and the largest against each
/// target.
fn compare() -> (String, f64, f64) {
    let mut report = String::from(
        "optical depth, sun zenith, sky: (crate / DISORT − 1) below zenith, below 45°, above \
         nadir, above 45°\n",
    );
    let (mut thick, mut thin) = (0.0_f64, 0.0_f64);
    for case in table() {
        let errors: Vec<f64> = (0..VIEWS.len())
            .map(|view| crate_radiance(&case, view) / case.radiance[view] - 1.0)
            .collect();
        let worst = errors.iter().fold(0.0_f64, |w, e| w.max(e.abs()));
        if case.optical_depth >= 2.0 {
            thick = thick.max(worst);
        } else {
            thin = thin.max(worst);
        }
        report += &format!(
            "{:>5} {:>3}° {:>4}: {}\n",
            case.optical_depth,
            case.sun_zenith_deg,
            case.sky_radiance,
            errors
                .iter()
                .map(|e| format!("{:+7.1} %", 100.0 * e))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    (report, thick, thin)
}

#[test]
fn a_broken_slab_table_names_the_file_and_row() {
    let good = format!("{HEADER}\n2,40,0,1,1,1,1,0.5,0.1,0.4\n");
    assert_eq!(parse_table("t.csv", &good).map(|c| c.len()), Ok(1));
    let cases = [
        ("", "t.csv: empty"),
        ("a,b\n", "t.csv: row 1: header"),
        (&format!("{HEADER}\n"), "t.csv: no cases"),
        (
            &format!("{HEADER}\n2,40,0,1,1,1,1,0.5,0.1,0.4\n2,40,0,x,1,1,1,0.5,0.1,0.4\n"),
            "t.csv: row 3: \"x\" is not a number",
        ),
        (
            &format!("{HEADER}\n2,40,0,NaN,1,1,1,0.5,0.1,0.4\n"),
            "t.csv: row 2: \"NaN\"",
        ),
        (&format!("{HEADER}\n2,40,0,1\n"), "t.csv: row 2: 4 fields"),
        (
            &format!("{HEADER}\n2,40,0,-1,1,1,1,0.5,0.1,0.4\n"),
            "t.csv: row 2: a negative value",
        ),
        (
            &format!("{HEADER}\n2,95,0,1,1,1,1,0.5,0.1,0.4\n"),
            "t.csv: row 2: optical depth 2 or sun zenith 95",
        ),
    ];
    for (text, expected) in cases {
        let error = parse_table("t.csv", text).expect_err(text);
        assert!(error.starts_with(expected), "{error:?} for {text:?}");
    }
}

/// What DISORT says about a deck's reflection with its thickness, which the crate's light must
/// follow within [`RATIO_TOLERANCE`]: seen from above, a thick deck (optical depth 30) reflects
/// three to four times what a thin one (2) does. Light that only fades along the sun's path
/// (scattering octaves) stays nearly as bright from above at every thickness. (From below, the
/// thick deck's share of the thin one's light is not yet within this target everywhere:
/// [`slab_radiances_against_disort`] prints every case.)
#[test]
fn thick_decks_reflect_as_much_more_than_thin_ones_as_disort_says() {
    let cases = table();
    let find = |tau: f64, zenith: f64| {
        *cases
            .iter()
            .find(|c| c.optical_depth == tau && c.sun_zenith_deg == zenith && c.sky_radiance == 0.0)
            .unwrap_or_else(|| panic!("{TABLE}: no case for optical depth {tau}, sun {zenith}°"))
    };
    for zenith in [0.0, 40.0, 70.0] {
        let (thin, thick) = (find(2.0, zenith), find(30.0, zenith));
        for (view, (name, looking_up, _)) in VIEWS.iter().enumerate() {
            if *looking_up {
                continue;
            }
            let disort = thick.radiance[view] / thin.radiance[view];
            let ours = crate_radiance(&thick, view) / crate_radiance(&thin, view);
            // The validation's target for a ratio of brightnesses (a cumulus's base to its top).
            let bound = 1.0 + RATIO_TOLERANCE;
            assert!(
                ours / disort < bound && disort / ours < bound,
                "sun {zenith}°, {name}: thick / thin {ours:.3}, DISORT {disort:.3}"
            );
        }
    }
}

/// Every radiance of the table against DISORT, printed (`cargo test --lib
/// slab_radiances_against_disort -- --nocapture`): the validation's target is 5 % from optical
/// depth 2 on and 10 % at 0.5, which the light does not meet yet (`validation/README.md` has the
/// figures). Asserted: the march gives a finite, positive radiance for every case and view.
#[test]
fn slab_radiances_against_disort() {
    let (report, thick, thin) = compare();
    println!(
        "{report}largest difference {:.1} % from optical depth 2 on (target {:.0} %), {:.1} % \
         below (target {:.0} %)",
        100.0 * thick,
        100.0 * TOLERANCE_THICK,
        100.0 * thin,
        100.0 * TOLERANCE_THIN
    );
    assert!(thick.is_finite() && thin.is_finite(), "{report}");
    for case in table() {
        for view in 0..VIEWS.len() {
            let radiance = crate_radiance(&case, view);
            assert!(
                radiance > 0.0 && radiance.is_finite(),
                "{case:?}, view {view}: {radiance}"
            );
        }
    }
}

/// The validation's 5 % target where the light meets it: every view of every deck from optical
/// depth 8 on, under every sun of the table, sky off and on. Decks this thick are lit by light
/// scattered many times, which the quadrature two-stream's dependence on the sun's cosine carries
/// ([`sun_diffuse_constants`]); under a sun 85° from the zenith, what the forward peak does to
/// the grazing beam ([`grazing_peak_factors`]) too: without it those decks were 7–16 % too
/// bright.
#[test]
fn thick_decks_meet_the_target_under_every_sun() {
    let thick: Vec<Case> = table()
        .into_iter()
        .filter(|case| case.optical_depth >= 8.0)
        .collect();
    let failures = beyond_target(&thick, &[0, 1, 2, 3]);
    assert!(failures.is_empty(), "beyond the target:\n{failures}");
}

/// Each view of `cases` (indices into [`VIEWS`]) beyond the validation's target for its
/// optical depth (10 % below 2, 5 % from 2 on), one line each; empty when all are within.
fn beyond_target(cases: &[Case], views: &[usize]) -> String {
    let mut failures = String::new();
    for case in cases {
        let tolerance = if case.optical_depth >= 2.0 {
            TOLERANCE_THICK
        } else {
            TOLERANCE_THIN
        };
        for &view in views {
            let error = crate_radiance(case, view) / case.radiance[view] - 1.0;
            if error.abs() > tolerance {
                failures += &format!(
                    "optical depth {}, sun {}° from the zenith, sky {}, {}: {:+.1} % (target \
                     {:.0} %)\n",
                    case.optical_depth,
                    case.sun_zenith_deg,
                    case.sky_radiance,
                    VIEWS[view].0,
                    100.0 * error,
                    100.0 * tolerance
                );
            }
        }
    }
    failures
}

/// The ground under a full deck, lit by the sun and the sky as in a scene and by the sun alone:
/// the direct and diffuse light on a horizontal surface within 10 % of DISORT's total downward
/// flux at the base (the validation target). Under a sun 5° high lit by the sun alone it takes
/// what the forward peak does to the grazing beam ([`grazing_peak_factors`]); without that it
/// was up to 13 % too bright.
#[test]
fn the_light_under_a_deck_is_disorts_downward_flux() {
    let phase = eddington_phase(&MarchSettings::default());
    let mut worst = 0.0_f64;
    let mut report = String::new();
    for case in table() {
        let mu = case.sun_zenith_deg.to_radians().cos();
        let under = deck_irradiance(&phase, case.optical_depth, mu, 1.0, case.sky_radiance, 0.0);
        let error = (under.direct + under.diffuse) / case.total_down - 1.0;
        report += &format!(
            "{:>5} {:>3}° {:>4}: {:+.1} %\n",
            case.optical_depth,
            case.sun_zenith_deg,
            case.sky_radiance,
            100.0 * error
        );
        worst = worst.max(error.abs());
    }
    println!("{report}");
    assert!(
        worst <= 0.10,
        "largest difference {:.1} %\n{report}",
        100.0 * worst
    );
}

/// Chandrasekhar's H function of conservative isotropic scattering (Chandrasekhar 1960,
/// "Radiative Transfer", ch. V): `ln H(μ) = −(μ/π) ∫₀^∞ ln(1 − arctan(t)/t) / (1 + μ²t²) dt`,
/// by the midpoint rule over `t = tan x`.
fn chandrasekhar_h(mu: f64) -> f64 {
    const N: u32 = 20_000;
    let dx = std::f64::consts::FRAC_PI_2 / f64::from(N);
    let sum: f64 = (0..N)
        .map(|i| {
            let x = (f64::from(i) + 0.5) * dx;
            let t = x.tan();
            (1.0 - x / t).ln() / (1.0 + mu * mu * t * t) / (x.cos() * x.cos())
        })
        .sum();
    (-mu / std::f64::consts::PI * sum * dx).exp()
}

/// A cloud of isotropic scatterers thick enough to be semi-infinite (optical depth 200) reflects
/// the sun as the exact solution says (Chandrasekhar 1960: `I = E μ₀ H(μ) H(μ₀) / (4π (μ + μ₀))`
/// per unit sun irradiance `E`), within the validation's 5 % for thick decks, for suns 0°, 40°
/// and 70° from the zenith seen from straight above and 45° off. The two-stream source alone,
/// integrated along the view, sent back 7 % too little.
#[test]
fn a_thick_cloud_reflects_as_chandrasekhars_exact_solution_says() {
    // Chandrasekhar's table gives H(1) = 2.9078: the quadrature holds its four decimals.
    assert!((chandrasekhar_h(1.0) - 2.9078).abs() < 5e-5);
    let isotropic = MarchSettings {
        phase_g_forward: 0.0,
        phase_g_back: 0.0,
        phase_blend: 0.0,
        ..MarchSettings::default()
    };
    let mut report = String::new();
    let mut worst = 0.0_f64;
    for zenith in [0.0_f64, 40.0, 70.0] {
        let case = Case {
            optical_depth: 200.0,
            sun_zenith_deg: zenith,
            sky_radiance: 0.0,
            radiance: [0.0; 4],
            total_down: 0.0,
        };
        for view in [2, 3] {
            let (name, _, view_zenith) = VIEWS[view];
            let (mu0, mu) = (zenith.to_radians().cos(), view_zenith.to_radians().cos());
            let exact = mu0 * chandrasekhar_h(mu) * chandrasekhar_h(mu0)
                / (4.0 * std::f64::consts::PI * (mu + mu0));
            let ours = crate_radiance_with(&case, view, isotropic.clone());
            let error = ours / exact - 1.0;
            worst = worst.max(error.abs());
            report += &format!(
                "sun {zenith}°, {name}: {ours:.4} against {exact:.4} ({:+.1} %)\n",
                100.0 * error
            );
        }
    }
    println!("{report}");
    assert!(worst <= TOLERANCE_THICK, "{report}");
}

/// Under a deck with the sun overhead, the sky straight up (the sun's aureole through the deck)
/// is as bright as DISORT says, within the validation's targets (10 % below optical depth 2, 5 %
/// from there), with the sky light off and on: most of that light is scattered more than once
/// within the phase's forward peak, which the later orders of [`sample_source`]'s peak carry.
/// Without them a deck of optical depth 2 was 14 % too dark.
#[test]
fn the_aureole_under_a_deck_is_as_bright_as_disort_says() {
    let mut report = String::new();
    let mut failed = false;
    for case in table().iter().filter(|c| c.sun_zenith_deg == 0.0) {
        let error = crate_radiance(case, 0) / case.radiance[0] - 1.0;
        let tolerance = if case.optical_depth >= 2.0 {
            TOLERANCE_THICK
        } else {
            TOLERANCE_THIN
        };
        failed |= error.abs() > tolerance;
        report += &format!(
            "optical depth {}, sky {}: {:+.1} %\n",
            case.optical_depth,
            case.sky_radiance,
            100.0 * error
        );
    }
    println!("{report}");
    assert!(!failed, "{report}");
}

/// What the forward peak does to a grazing beam: no light turned up and out once the sun stands
/// higher than the peak's largest turning angle (the light going up keeps all of it), and under a
/// sun a few degrees up less light both ways, more taken from the light going up (which loses
/// the light turned out) than from the light going down (which the light turned deeper makes up
/// in part). Printed: both factors from 5° to 90° up. Whether the light going down stays close
/// enough to 1 under a higher sun is for DISORT to say (`thick_decks_meet_the_target_under_every_sun`).
#[test]
fn the_peak_turns_only_a_grazing_beam() {
    let phase = eddington_phase(&MarchSettings::default());
    let widest = phase
        .peak_spread
        .iter()
        .fold(0.0_f64, |w, t| w.max(t.atan()));
    for elevation_deg in [5.0_f64, 10.0, 20.0, 30.0, 50.0, 70.0, 90.0] {
        let elevation = elevation_deg.to_radians();
        let [up, down] = grazing_peak_factors(&phase, elevation.sin());
        println!("sun {elevation_deg}° up: light going up {up:.4}, going down {down:.4}");
        if elevation > widest {
            assert_eq!(up, 1.0, "sun {elevation_deg}° up");
            // The light going down starts no deeper than the overhead sun's by more than the
            // slab target: above the peak's widest angle the factor alone may not move a deck's
            // light beyond it.
            assert!(
                (down - 1.0).abs() < TOLERANCE_THICK,
                "sun {elevation_deg}° up: {down}"
            );
        }
    }
    // The deeper start is measured against the overhead sun's.
    assert_eq!(grazing_peak_factors(&phase, 1.0)[1], 1.0);
    let [up, down] = grazing_peak_factors(&phase, 5f64.to_radians().sin());
    assert!(up < down && down < 1.0, "sun 5° up: {up}, {down}");
}

/// Thin decks (optical depth 0.5 and 2) seen straight up under a sun up to 40° from the zenith,
/// sky off and on: within the validation's targets (10 % at 0.5, 5 % from 2 on). Their light
/// outside the forward peak is mostly the sun's scattered once or twice, and the part the peak
/// has already turned scatters by the phase spread over the peak's angles
/// ([`peak_spread_phase`]); without that, 2 deep under a sun 40° from the zenith was 9.7 % too
/// dark. (Seen at 45°, and under lower suns, they are not yet within the targets:
/// [`slab_radiances_against_disort`] prints them.)
#[test]
fn thin_decks_seen_straight_up_under_a_high_sun_meet_the_target() {
    let thin: Vec<Case> = table()
        .into_iter()
        .filter(|case| case.optical_depth < 8.0 && case.sun_zenith_deg <= 40.0)
        .collect();
    let failures = beyond_target(&thin, &[0]);
    assert!(failures.is_empty(), "beyond the target:\n{failures}");
}
