//! Light in f64 (Joseph, Wiscombe & Weinman 1976; Toon et al. 1989; Nakajima & Tanaka 1988;
//! Hillaire 2016). WGSL twin: `src/render/march/light.wgsl`.
//!
//! At each sample the source is [`sample_source`]: the sun's single scattering through the
//! dual-lobe Henyey-Greenstein phase ([`dual_lobe_phase`], Hillaire 2016), with `τ` the optical
//! depth toward the sun from a short light march to the exit of the layer shell
//! ([`sun_optical_depth`]), and the δ-Eddington diffuse field of the sun and the sky in the
//! column that holds the sample. The diffuse part and the light scattered outside the phase's
//! forward peak are seen through the δ-scaled medium ([`EddingtonPhase`]), the peak through the
//! true one. Each step integrates the source against the transmittance across the step
//! analytically (Hillaire 2016, "Physically Based Sky, Atmosphere and Cloud Rendering in
//! Frostbite"): `∫₀^dt e^(−σt x) S dx = S dt (1 − e^(−σt dt)) / (σt dt)`, with the last factor
//! from [`mean_step_transmittance`], which stays exact as `σt → 0` instead of clamping `σt`.
//! Validated against DISORT in `validation/disort/`.

use super::{
    CloudTextures, MarchLayer, MarchSettings, add, altitude_along_ray, dot, ground_distance,
    horizontal_axes, intersect_altitude_sphere, layer_density, layer_is_active, profile_density,
    saturate, scale, total_extinction,
};

/// Most light-march steps; larger [`MarchSettings::light_steps`] are clamped.
pub const MAX_LIGHT_STEPS: u32 = 64;

/// Below this optical thickness [`mean_step_transmittance`] uses its Taylor series. The WGSL twin
/// uses 0.1 with five terms (f32: `1 − e^(−x)` loses digits as `x → 0`); here `expm1` is exact
/// and the series only avoids `0 / 0`.
pub const SERIES_LIMIT: f64 = 1e-5;

/// The WGSL twin's `SERIES_LIMIT`: in f32, without `expm1`, the series takes over at a larger
/// optical thickness (five terms keep it exact to f32 there).
pub const WGSL_SERIES_LIMIT: f64 = 0.1;

/// Largest Henyey-Greenstein asymmetry magnitude used: at |g| = 1 the lobe is a Dirac peak and
/// its denominator vanishes.
pub const MAX_PHASE_G: f64 = 0.999;

/// Henyey-Greenstein phase function, 1/sr: `(1 − g²) / (4π (1 + g² − 2g cos θ)^1.5)`, `g`
/// clamped to `±MAX_PHASE_G` so the peak stays finite. WGSL twin: `henyey_greenstein`.
pub fn henyey_greenstein(cos_theta: f64, g: f64) -> f64 {
    let g = g.clamp(-MAX_PHASE_G, MAX_PHASE_G);
    let denominator = (1.0 + g * g - 2.0 * g * cos_theta).max(1e-12);
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * denominator * denominator.sqrt())
}

/// Dual-lobe phase (Hillaire 2016, after Schneider 2015's silver lining): a forward lobe
/// blended with a backward one, `(1 − blend) HG(g_forward) + blend HG(g_back)`, 1/sr. WGSL twin:
/// `dual_lobe_phase`.
pub fn dual_lobe_phase(cos_theta: f64, g_forward: f64, g_back: f64, blend: f64) -> f64 {
    let blend = saturate(blend);
    (1.0 - blend) * henyey_greenstein(cos_theta, g_forward)
        + blend * henyey_greenstein(cos_theta, g_back)
}

/// Scattering angle of the 22° halo's inner edge, degrees: the least deviation of light through
/// a 60° ice prism, `2 asin(n sin 30°) − 60°` with ice's refractive index `n` = 1.31 (Greenler
/// 1980, "Rainbows, Halos, and Glories", ch. 2). No light of the halo is scattered at smaller
/// angles, so the sky inside the ring is darker than the ring.
pub const HALO_ANGLE_DEG: f64 = 21.84;

/// Width of the halo ring's inner edge, degrees: the sun's angular diameter, over which a sharp
/// ring is smeared.
pub const HALO_EDGE_DEG: f64 = 0.53;

/// How far outward the halo's brightness falls by `e`, degrees: minimum-deviation rays pile up
/// at the inner edge and the deviations of the others spread outward over a few degrees
/// (Greenler 1980), so the ring fades outward.
pub const HALO_FADE_DEG: f64 = 1.5;

/// The 22° halo's ring as a phase function, 1/sr: 0 inside [`HALO_ANGLE_DEG`] −
/// [`HALO_EDGE_DEG`], rising linearly to the inner edge at [`HALO_ANGLE_DEG`], then falling
/// as `e^(−(θ − θ₀)/w)` with `w` = [`HALO_FADE_DEG`]; normalized in closed form so that it
/// integrates to 1 over the sphere. `cos_theta` is the cosine of the scattering angle. WGSL
/// twin: `halo_phase`.
pub fn halo_phase(cos_theta: f64) -> f64 {
    let theta = cos_theta.clamp(-1.0, 1.0).acos();
    let theta0 = HALO_ANGLE_DEG.to_radians();
    let edge = HALO_EDGE_DEG.to_radians();
    let fade = HALO_FADE_DEG.to_radians();
    let ring = if theta >= theta0 {
        (-(theta - theta0) / fade).exp()
    } else {
        ((theta - (theta0 - edge)) / edge).max(0.0)
    };
    // ∫ ring sin θ dθ: the ramp's part in closed form, and the exponential tail's from θ₀ on.
    let ramp = ((theta0).sin() - (theta0 - edge).sin()) / edge - theta0.cos();
    let tail = fade * (theta0.sin() + fade * theta0.cos()) / (1.0 + fade * fade);
    ring / (2.0 * std::f64::consts::PI * (ramp + tail))
}

/// Angle from the forward direction inside which the phase is the forward peak, degrees: the
/// part of the phase above its value at this angle ([`EddingtonPhase::forward_cap`]) is single
/// scattering seen through the true medium, the rest through the scaled one ([`sample_source`]).
pub const FORWARD_PEAK_DEG: f64 = 30.0;

/// Orders of scattering within the forward peak that [`sample_source`] adds after the first:
/// light scattered into the peak and then again within it stays near the sun's direction. WGSL
/// twin: `PEAK_ORDERS`.
pub const PEAK_ORDERS: usize = 2;

/// Smallest sun cosine the diffuse field of [`sample_source`] uses: a grazing sun's beam still
/// lights the layer through its top.
pub const MIN_DIFFUSE_MU_SUN: f64 = 0.02;

/// The quadrature two-stream's cosine `1/√3` (Meador & Weaver 1980, "Two-stream approximations
/// to radiative transfer in planetary atmospheres"): a thick cloud sends out the diffuse light
/// the sun brings in in proportion to `μ₀ + 1/√3` ([`sun_diffuse_constants`],
/// [`peak_injection_depth`]). WGSL twin: `QUADRATURE_MU`.
pub const QUADRATURE_MU: f64 = 0.577_350_269_189_625_8;

/// The δ-Eddington constants of the dual-lobe phase (Joseph, Wiscombe & Weinman 1976, "The
/// Delta-Eddington Approximation for Radiative Flux Transfer"), computed once per march from
/// [`MarchSettings`]' phase. WGSL twin: the uniforms `forward_fraction`, `scaled_asymmetry` and
/// `forward_cap`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EddingtonPhase {
    /// The forward peak's share of the scattered light, `f`: the phase's second moment,
    /// `(1 − blend) g_f² + blend g_b²`. The scaled medium has extinction `(1 − f) σ`.
    pub forward_fraction: f64,
    /// The asymmetry of the phase without its peak, `g* = (g − f) / (1 − f)`.
    pub scaled_asymmetry: f64,
    /// The cosine of [`FORWARD_PEAK_DEG`]: a view closer to the sun than that sees the peak.
    pub forward_peak_cos: f64,
    /// The phase at [`FORWARD_PEAK_DEG`] from the forward direction, 1/sr.
    pub forward_cap: f64,
    /// The same for the phase after `k + 1` more scatterings in the forward lobe (`k` from 0 to
    /// [`PEAK_ORDERS`] − 1): the dual lobe with the forward asymmetry `g_f^(k + 2)`, 1/sr.
    pub peak_caps: [f64; PEAK_ORDERS],
    /// Tangents of the angles the forward peak turns its light by, one per quarter of the peak's
    /// light (the angles at the peak's 1/8, 3/8, 5/8 and 7/8 quantiles of the phase above
    /// [`EddingtonPhase::forward_cap`]): what [`peak_upward_share`] spreads a grazing beam by.
    pub peak_spread: [f64; PEAK_SPREAD_ANGLES],
}

/// Angles [`EddingtonPhase::peak_spread`] represents the forward peak by: [`peak_upward_share`]
/// comes within 0.02 of the share the peak's full angular distribution gives (at most about 0.4)
/// for a sun 75° to 88° from the zenith. WGSL twin: the uniform `peak_spread`.
pub const PEAK_SPREAD_ANGLES: usize = 4;

/// Midpoint steps over the peak's angles that [`eddington_phase`] finds
/// [`EddingtonPhase::peak_spread`] with.
const PEAK_SPREAD_STEPS: usize = 256;

/// [`EddingtonPhase::peak_spread`] of the phase `p` with its value `cap` at [`FORWARD_PEAK_DEG`]:
/// the deflection angles at the quantiles `(k + ½) / 4` of the light the peak (`p − cap` over
/// the solid angle) turns by, as tangents.
fn peak_spread(p: impl Fn(f64) -> f64, cap: f64) -> [f64; PEAK_SPREAD_ANGLES] {
    let width = FORWARD_PEAK_DEG.to_radians() / PEAK_SPREAD_STEPS as f64;
    let weights: Vec<(f64, f64)> = (0..PEAK_SPREAD_STEPS)
        .map(|i| {
            let theta = (i as f64 + 0.5) * width;
            (theta, (p(theta.cos()) - cap).max(0.0) * theta.sin())
        })
        .collect();
    let total: f64 = weights.iter().map(|(_, w)| w).sum();
    let mut spread = [FORWARD_PEAK_DEG.to_radians().tan(); PEAK_SPREAD_ANGLES];
    if total.is_nan() || total <= 0.0 {
        return spread;
    }
    let mut sum = 0.0;
    let mut next = 0;
    for (theta, w) in weights {
        sum += w / total;
        while next < PEAK_SPREAD_ANGLES && sum >= (next as f64 + 0.5) / PEAK_SPREAD_ANGLES as f64 {
            spread[next] = theta.tan();
            next += 1;
        }
    }
    spread
}

/// The share of the light a beam loses to its forward peak that the peak turns upward, for a
/// beam going down with the sine `mu0` of its elevation (the sun's cosine), 0–1. The peak turns
/// light by the angles of [`EddingtonPhase::peak_spread`] in every azimuth; turned by `θ`, the
/// light goes up for the azimuths within `acos(tan α₀ / tan θ)` of straight up (`α₀` the beam's
/// depression below the horizontal), none while `θ ≤ α₀`. 0 for a sun 30° or more up, about
/// 0.28 for a sun 5° up. WGSL twin: `peak_upward_share`.
pub fn peak_upward_share(phase: &EddingtonPhase, mu0: f64) -> f64 {
    let mu0 = mu0.clamp(0.0, 1.0);
    let tan_depression = mu0 / (1.0 - mu0 * mu0).max(1e-12).sqrt();
    let up: f64 = phase
        .peak_spread
        .iter()
        .filter(|&&tan_theta| tan_theta > tan_depression)
        .map(|tan_theta| (tan_depression / tan_theta).acos())
        .sum();
    up / (std::f64::consts::PI * PEAK_SPREAD_ANGLES as f64)
}

/// The azimuth mean of `μ' + 1/√3` over the light the forward peak turns out of a beam going
/// down with the sine `mu0` of its elevation, `μ'` the cosine of the turned light's direction
/// from straight down, and 0 for the light turned upward (it leaves): how deep in the cloud the
/// peak's light starts its diffusion, in the terms of the quadrature two-stream's `μ₀ + 1/√3`
/// ([`sun_diffuse_constants`]). Turned by `θ` at the azimuth `φ` from straight down, `μ' = sin α₀
/// cos θ + cos α₀ sin θ cos φ`; the mean over the angles of
/// [`EddingtonPhase::peak_spread`]. WGSL twin: `peak_injection_depth`.
pub fn peak_injection_depth(phase: &EddingtonPhase, mu0: f64) -> f64 {
    let sin_a = mu0.clamp(0.0, 1.0);
    let cos_a = (1.0 - sin_a * sin_a).max(0.0).sqrt();
    let sum: f64 = phase
        .peak_spread
        .iter()
        .map(|&tan_theta| {
            let cos_theta = 1.0 / (1.0 + tan_theta * tan_theta).sqrt();
            let (along, across) = (sin_a * cos_theta, cos_a * tan_theta * cos_theta);
            if across <= along {
                return along + QUADRATURE_MU;
            }
            // Going down for the azimuths within φc of straight down.
            let cos_c = -along / across;
            ((along + QUADRATURE_MU) * cos_c.acos() + across * (1.0 - cos_c * cos_c).sqrt())
                / std::f64::consts::PI
        })
        .sum();
    sum / PEAK_SPREAD_ANGLES as f64
}

/// Factors on the sun's diffuse source for the light going up and the light going down, for the
/// sun's cosine `mu0`: what the forward peak does to a grazing beam, which the δ-scaling leaves
/// going on at the sun's angle ([`sample_source`]). Going up: `1 − f U` (`f` the peak's share,
/// `U` the share of its light turned up and out, [`peak_upward_share`]). Going down: the
/// light's starting depth, `(1 − f) + f D(μ₀) / (μ₀ + 1/√3)` with `D` [`peak_injection_depth`]
/// (the light turned steeper down goes in deeper and more of it comes out at the base, the light
/// turned up is lost), over its value for a sun overhead. Both are 1 within 0.4 % for a sun 20°
/// or more up; for a sun 5° up about 0.85 and 0.90. WGSL twin: `grazing_peak_factors`.
pub fn grazing_peak_factors(phase: &EddingtonPhase, mu0: f64) -> [f64; 2] {
    let f = phase.forward_fraction;
    let depth = |mu0: f64| (1.0 - f) + f * peak_injection_depth(phase, mu0) / (mu0 + QUADRATURE_MU);
    [
        1.0 - f * peak_upward_share(phase, mu0),
        depth(mu0) / depth(1.0),
    ]
}

/// Azimuths [`peak_spread_phase`] averages over, from 0 to π. WGSL twin:
/// `PEAK_SPREAD_AZIMUTHS`.
pub const PEAK_SPREAD_AZIMUTHS: usize = 8;

/// The settings' dual-lobe phase for light the forward peak has turned before it scatters, at
/// the cosine `cos_theta` from the sun, 1/sr: the phase's mean over the directions the peak turns
/// the sun's light into, by the angles of [`EddingtonPhase::peak_spread`] in
/// [`PEAK_SPREAD_AZIMUTHS`] azimuths. The δ-scaled beam ([`sample_source`]) holds such light as
/// if it still went along the sun; away from the peak the phase falls convexly, so the turned
/// light scatters more to the side than the beam would (for the default phase about a fifth
/// more 40° from the sun, a tenth more at 57°, 3 % more at 90°). WGSL twin: `peak_spread_phase`.
pub fn peak_spread_phase(settings: &MarchSettings, phase: &EddingtonPhase, cos_theta: f64) -> f64 {
    let cos_theta = cos_theta.clamp(-1.0, 1.0);
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let mut sum = 0.0;
    for &tan_turn in &phase.peak_spread {
        let cos_turn = 1.0 / (1.0 + tan_turn * tan_turn).sqrt();
        let sin_turn = tan_turn * cos_turn;
        for j in 0..PEAK_SPREAD_AZIMUTHS {
            let azimuth = std::f64::consts::PI * (j as f64 + 0.5) / PEAK_SPREAD_AZIMUTHS as f64;
            sum += dual_lobe_phase(
                cos_theta * cos_turn + sin_theta * sin_turn * azimuth.cos(),
                settings.phase_g_forward,
                settings.phase_g_back,
                settings.phase_blend,
            );
        }
    }
    sum / (PEAK_SPREAD_ANGLES * PEAK_SPREAD_AZIMUTHS) as f64
}

/// [`EddingtonPhase`] of the settings' dual-lobe phase (asymmetries clamped to
/// ±[`MAX_PHASE_G`], the blend to 0–1, as [`dual_lobe_phase`] does).
pub fn eddington_phase(settings: &MarchSettings) -> EddingtonPhase {
    let blend = saturate(settings.phase_blend);
    let forward = settings.phase_g_forward.clamp(-MAX_PHASE_G, MAX_PHASE_G);
    let back = settings.phase_g_back.clamp(-MAX_PHASE_G, MAX_PHASE_G);
    let asymmetry = (1.0 - blend) * forward + blend * back;
    let forward_fraction = (1.0 - blend) * forward * forward + blend * back * back;
    let cap = FORWARD_PEAK_DEG.to_radians().cos();
    EddingtonPhase {
        forward_fraction,
        scaled_asymmetry: (asymmetry - forward_fraction) / (1.0 - forward_fraction),
        forward_peak_cos: cap,
        forward_cap: dual_lobe_phase(cap, forward, back, blend),
        peak_caps: std::array::from_fn(|k| {
            dual_lobe_phase(cap, forward.powi(k as i32 + 2), back, blend)
        }),
        peak_spread: peak_spread(
            |c| dual_lobe_phase(c, forward, back, blend),
            dual_lobe_phase(cap, forward, back, blend),
        ),
    }
}

/// Where a sample sits in its cloud, for [`sample_source`]: the vertical optical depths of the
/// cloud above and below it, as if the cloud were at full density over the sample (each layer's
/// extinction times its profile's integral up to its top and down to its base,
/// [`profile_column`](super::profile_column): exact in a homogeneous slab, and a cloud's thin
/// edge still sees the thick cloud behind it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CloudColumn {
    /// Optical depth up to the top, dimensionless.
    pub above: f64,
    /// Optical depth down to the base, dimensionless.
    pub below: f64,
}

/// The light a sample sends toward the camera, per metre of the view ray and per unit of the
/// lights: split by the transmittance it is seen through ([`sample_source`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleSource {
    /// Seen through the true medium, `e^(−τ)`: the sun's forward peak scattered once.
    pub direct: [f64; 3],
    /// Seen through the scaled medium, `e^(−(1 − f) τ)`: the sun's light scattered outside the
    /// peak and the diffuse field of the sun and the sky.
    pub scaled: [f64; 3],
}

/// Everything [`sample_source`] needs to know about the lights and the view at one sample.
#[derive(Clone, Copy, Debug)]
pub struct SampleLights {
    /// Optical depth toward the sun ([`sun_optical_depth`]); `None` when the sun does not reach
    /// the sample (below the horizon, or no sun).
    pub sun_optical_depth: Option<f64>,
    /// Cosine of the sun's zenith angle at the sample.
    pub mu_sun: f64,
    /// Cosine between the view ray and the sun.
    pub cos_sun: f64,
    /// The dual-lobe phase at `cos_sun` averaged over the forward peak's spread
    /// ([`peak_spread_phase`]), 1/sr: the phase for the sun's light the peak has already turned.
    pub spread_phase: f64,
    /// Cosine of the view ray's zenith angle (positive looking up).
    pub mu_view: f64,
    /// The part of `sun_optical_depth` in separate layers above the sample's own
    /// ([`higher_layers_optical_depth`]): the sun on the top of the sample's column is dimmed by
    /// it (the δ-scaled `e^(−(1 − f) τ)`); what those layers scatter down is in `sky_light`.
    /// 0 without such layers.
    pub sun_above_depth: f64,
    /// Factors on [`MarchSettings::ambient_top`] and [`MarchSettings::ambient_bottom`] at the
    /// sample ([`MarchLayer::sky_light_top`] and [`MarchLayer::sky_light_bottom`] of its layer;
    /// their scattering-weighted mean where layers overlap).
    pub sky_light: [[f64; 3]; 2],
    /// The share of the sample's scattering in the 22° halo ([`MarchLayer::halo_share`] of its
    /// layer; their scattering-weighted mean where layers overlap), clamped to 0–1.
    pub halo_share: f64,
    /// Optical depth of the view ray from the camera to the sample (the true medium's): the
    /// forward peak's light scattered again within the peak on its way to the camera stays in
    /// the view ([`sample_source`]).
    pub view_optical_depth: f64,
}

/// Source terms of one sample (σs the scattering, 1/m): the δ-Eddington
/// source-function method (Joseph, Wiscombe & Weinman 1976; Toon et al. 1989, "Rapid
/// calculation of radiative heating rates and photodissociation rates in inhomogeneous multiple
/// scattering atmospheres") with its single scattering split as Nakajima & Tanaka 1988
/// ("Algorithms for radiative intensity calculations in moderately thick atmospheres using a
/// truncation approximation") do.
///
/// With `f`, `g*` from [`EddingtonPhase`] and `g = (1 − f) g* + f` the asymmetry, the scaled
/// medium (extinction `(1 − f) σt`) holds a diffuse radiance `I₀ + μ I₁` (μ the cosine of the
/// direction of travel from the downward vertical), whose two-stream equations with Marshak's
/// boundary conditions have a closed form in the column's optical depths above (`τa`) and below
/// (`τb`) the sample; `τa` is at most the optical depth of the sun's path out through the
/// sample's own layers times `μ₀`, since light reaches the sample through the nearest surface
/// of its cloud (on a sunlit side, the side), and where that caps it, `τb` shrinks by the square
/// root of the same ratio (a broken cloud's column below). For the sun (per unit illuminance
/// `E`, `μ₀` the sun's cosine, `τs` the optical depth toward the sun, `e = e^(−(1 − f) τs)`, `k = 1/4π`):
/// `I₁ = C₁ − 3μ₀ k e`, `I₀ = C₀ − (1 − g) C₁ τa − 3μ₀² k e`, with
/// `C₁ = k (q − e_T (3μ₀² − 2μ₀)) / (4/3 + (1 − g)(τa + τb))`, `e_T` the beam's scaled
/// transmittance through the whole column, `C₀ = k q − 2C₁/3`, and `q` Eddington's `3μ₀² + 2μ₀`
/// for the beam still passing and the quadrature two-stream's for the light the column has
/// scattered ([`sun_diffuse_constants`]). For the sky (the
/// isotropic radiances [`MarchSettings::ambient_top`] on the column's top and
/// [`MarchSettings::ambient_bottom`] on its base, times the sample's [`SampleLights::sky_light`]): `I₁ = (A_t − A_b) / (4/3 + (1 − g)(τa + τb))`,
/// `I₀ = A_t − (2/3 + (1 − g) τa) I₁`. The diffuse source is `I₀ + g* μ I₁`.
///
/// Light going up (a view ray looking down, `μ < 0`) takes `k Δ(μ₀) (1 − e_T)` more of the
/// sun's diffuse source, with `Δ(μ₀) = 4μ₀ + 2μ₀ (3μ₀² − 1)(1 − μ₀ ln(1 + 1/μ₀)) − (3μ₀² + 2μ₀)`
/// ([`reflection_deficit`]), in full from `μ ≤ −1/4` and fading to none at `μ = 1/4`.
/// Integrated along the view rays, the two-stream source sends out of a semi-infinite
/// conservative cloud less light than enters it (at `μ₀ = 1`, 94 %), though its fluxes conserve
/// it; `Δ` is the constant that makes the light going out equal the light coming in. With it
/// the reflection of a thick cloud of isotropic scatterers is within 1 % of the exact solution
/// (Chandrasekhar 1960, "Radiative Transfer", its H functions) for the sun 0°, 40° and 70° from
/// the zenith, where it was 7 % too dark. `1 − e_T` scales it down in a column the beam crosses mostly unscattered.
///
/// Under a grazing sun the sun's diffuse source, in the share `1 − e_T` the column has
/// scattered, takes what the forward peak does to the beam ([`grazing_peak_factors`]). The
/// δ-scaling keeps the peak's light in the beam, going on at the sun's angle; a beam a few
/// degrees below the horizontal that the peak turns by 5–20° goes up for a wide range of
/// azimuths and leaves the top at a grazing angle, and goes steeper down for the others, in
/// deeper than the beam. Light going up (in full from `μ ≤ −1/4`, as above) loses the light
/// turned up and out; light going down loses it too and gains the deeper start of the light
/// turned down. Both factors are 1 for a sun 20° or more up (within 0.4 %) and about 0.85 (up)
/// and 0.90 (down) for a sun 5° up; with them every view of decks from optical depth 8 on under
/// a sun 85° from the zenith is within 3.4 % of DISORT, where they were 7–16 % too bright.
///
/// The scaled beam `e^(−(1 − f) τs)` holds the sun's light the peak has already turned on its
/// way in, `1 − e^(−f τs)` of it, as if it still went along the sun; turned by 5–20°, it
/// scatters by the phase averaged over those directions ([`SampleLights::spread_phase`],
/// [`peak_spread_phase`]), which away from the peak, where the phase falls convexly, is larger.
/// The single scattering outside the peak takes `p + (1 − e^(−f τs)) (p̄ − p)` (`p̄` that mean;
/// the dual lobe alone, not the halo's ring). Only the sun's path counts, not the view's: the
/// source stays the same all along a ray through a uniform medium, which keeps Koschmieder's
/// contrast. With it thin decks seen from below are up to 5 points closer to DISORT (2 deep,
/// the sun 40° from the zenith, straight up: −4.4 %, was −9.7 %).
///
/// The sun's single scattering is split at [`EddingtonPhase::forward_cap`]: the peak above it,
/// `E (p − p_cap)⁺ e^(−τs)`, is seen through the true medium; the rest, `E min(p, p_cap)
/// e^(−(1 − f) τs)`, through the scaled one, so light scattered in the peak and then once more
/// is kept. (The light of what lies behind the cloud, scattered in the peak, is added once per
/// ray: [`march_clouds`](super::march_clouds).) Light scattered again within the peak, on the
/// sun's path or on the view's, stays near the sun's direction: of the scaled beam
/// `e^(−(1 − f) τ) = e^(−τ) Σ (f τ)ⁿ / n!` along the whole path `τ = τs + τv`
/// ([`SampleLights::view_optical_depth`] `τv`), the `n`-th term has been scattered `n` times in
/// the peak. The peak of the phase after `n` more scatterings in the forward lobe is the dual
/// lobe with the forward asymmetry `g_f^(n + 1)` (Henyey-Greenstein lobes convolve into one
/// with the product of their asymmetries: their Legendre moments multiply), above its own value
/// at [`FORWARD_PEAK_DEG`] ([`EddingtonPhase::peak_caps`]). So the peak seen through the true
/// medium is `E e^(−τs) Σₙ (f τ)ⁿ / n! (pₙ − pₙ_cap)⁺` for `n` from 0 to [`PEAK_ORDERS`], the
/// orders after the first times `1 − h` (the halo's share, below). Without the later orders the
/// sky around the sun seen through a deck of optical depth 2 was 14 % too dark against DISORT.
///
/// Where the sample's layers make a halo ([`SampleLights::halo_share`] `h` above 0) the phase
/// `p` is `(1 − h)` times the dual lobe plus `h` times the ring of [`halo_phase`], in the single
/// scattering only: the ring's light joins the rest in the diffuse field.
///
/// With [`MarchSettings::multiple_scattering`] off: single scattering `σs E p e^(−τs)` and the
/// ambient `σs (A_b + (A_t − A_b) h)` at the height fraction `h` of the layer (Pérez Martín 2022,
/// "Day / Night Cycle"), given as `ambient`, all seen through the true medium. WGSL twin:
/// `sample_source`.
pub fn sample_source(
    settings: &MarchSettings,
    phase: &EddingtonPhase,
    scattering: f64,
    column: CloudColumn,
    ambient: [f64; 3],
    lights: &SampleLights,
) -> SampleSource {
    let halo = if lights.halo_share > 0.0 {
        lights.halo_share.min(1.0)
    } else {
        0.0
    };
    let dual = dual_lobe_phase(
        lights.cos_sun,
        settings.phase_g_forward,
        settings.phase_g_back,
        settings.phase_blend,
    );
    let mut p = dual;
    if halo > 0.0 {
        p = (1.0 - halo) * p + halo * halo_phase(lights.cos_sun);
    }
    let sun = settings.sun_illuminance;
    if !settings.multiple_scattering {
        let single = lights
            .sun_optical_depth
            .map_or(0.0, |depth| p * (-depth).exp());
        return SampleSource {
            direct: std::array::from_fn(|c| scattering * sun[c] * single + ambient[c]),
            scaled: [0.0; 3],
        };
    }
    let f = phase.forward_fraction;
    let g_star = phase.scaled_asymmetry;
    let one_minus_g = (1.0 - g_star) * (1.0 - f);
    // Light reaches a sample through the nearest surface of its cloud: where the sun's path out
    // through its own layers is shorter than the column above (a cloud's sunlit side), the
    // sample is that deep. The path then crosses less cloud than a full column would, and the
    // cloud below the sample is as broken somewhere between not at all (a cloud's sunlit top
    // over its body) and as much as the path (a wisp at its edge): the column below takes the
    // geometric mean of the two, `τb √(fill)` with `fill` the capped over the full column above.
    // The mean, not either end, is what brings broken cumulus closest to the path-traced
    // truth (`validation/README.md`, "Cumulus against Mitsuba").
    let mut column = column;
    if let Some(depth) = lights.sun_optical_depth {
        let own = (depth - lights.sun_above_depth).max(0.0);
        let capped = own * lights.mu_sun.max(MIN_DIFFUSE_MU_SUN);
        if column.above > capped {
            column.below *= (capped / column.above).sqrt();
            column.above = capped;
        }
    }
    let transport = 4.0 / 3.0 + one_minus_g * (column.above + column.below);
    let mu = lights.mu_view;
    let k = 0.25 / std::f64::consts::PI;
    let (mut peak, mut wide, mut diffuse) = (0.0, 0.0, 0.0);
    if let Some(depth) = lights.sun_optical_depth {
        let mu0 = lights.mu_sun.max(MIN_DIFFUSE_MU_SUN);
        let capped = p.min(phase.forward_cap);
        let beam = (-(1.0 - f) * depth).exp();
        peak = ((p - capped)
            + (1.0 - halo)
                * peak_orders(
                    settings,
                    phase,
                    lights.cos_sun,
                    depth + lights.view_optical_depth.max(0.0),
                ))
            * (-depth).exp();
        // The scaled beam holds light the peak has turned already on the sun's path: it
        // scatters by the phase spread over the peak's angles.
        let turned_before = 1.0 - (-f * depth).exp();
        let spread = p + turned_before * (1.0 - halo) * (lights.spread_phase - dual);
        wide = spread.min(phase.forward_cap) * beam;
        let through = (-(1.0 - f) * (depth + column.below / mu0)).exp();
        let [c0, c1] = sun_diffuse_constants(mu0, through, transport).map(|c| k * c);
        let i1 = c1 - 3.0 * mu0 * k * beam;
        let i0 = c0 - one_minus_g * c1 * column.above - 3.0 * mu0 * mu0 * k * beam;
        // Light going up: the flux the source-function integral leaves out. Both ways, what the
        // forward peak does to a grazing sun's beam, in the column's scattered part.
        let up = saturate(0.5 - 2.0 * mu);
        let reflected = k * reflection_deficit(mu0) * (1.0 - through) * up;
        let [turned_up, turned_down] = grazing_peak_factors(phase, mu0);
        let turned = 1.0 - (1.0 - through) * (1.0 - (up * turned_up + (1.0 - up) * turned_down));
        // The sun on the column's top, through the layers above.
        diffuse = turned
            * (i0 + g_star * mu * i1 + reflected).max(0.0)
            * (-(1.0 - f) * lights.sun_above_depth).exp();
    }
    let sky = |c: usize| {
        let top = settings.ambient_top[c] * lights.sky_light[0][c];
        let bottom = settings.ambient_bottom[c] * lights.sky_light[1][c];
        let i1 = (top - bottom) / transport;
        let i0 = top - (2.0 / 3.0 + one_minus_g * column.above) * i1;
        (i0 + g_star * mu * i1).max(0.0)
    };
    SampleSource {
        direct: sun.map(|e| scattering * e * peak),
        scaled: std::array::from_fn(|c| {
            scattering * (sun[c] * (wide + (1.0 - f) * diffuse) + (1.0 - f) * sky(c))
        }),
    }
}

/// The orders after the first of the light scattered within the forward peak, at the cosine
/// `cos_sun` between the view and the sun, over a path of optical depth `path_depth` (the sun's
/// and the view's): `Σₙ (f τ)ⁿ / n! (pₙ − pₙ_cap)⁺` for `n` from 1 to [`PEAK_ORDERS`], 1/sr
/// ([`sample_source`]). 0 outside [`FORWARD_PEAK_DEG`] of the sun. WGSL twin: `peak_orders`.
pub fn peak_orders(
    settings: &MarchSettings,
    phase: &EddingtonPhase,
    cos_sun: f64,
    path_depth: f64,
) -> f64 {
    if cos_sun <= phase.forward_peak_cos || path_depth.is_nan() || path_depth <= 0.0 {
        return 0.0;
    }
    let forward = settings.phase_g_forward.clamp(-MAX_PHASE_G, MAX_PHASE_G);
    let rate = phase.forward_fraction * path_depth;
    let (mut weight, mut g, mut sum) = (1.0, forward, 0.0);
    for (n, cap) in phase.peak_caps.iter().enumerate() {
        weight *= rate / (n as f64 + 1.0);
        g *= forward;
        let p = dual_lobe_phase(cos_sun, g, settings.phase_g_back, settings.phase_blend);
        sum += weight * (p - cap).max(0.0);
    }
    sum
}

/// The constants `[C₀, C₁]` of the sun's diffuse field in [`sample_source`] and
/// [`deck_irradiance`], in units of `k E` (`k = 1/4π`), for the sun's cosine `mu0`, the scaled
/// beam `through` left after the column (`e_T`, 0–1) and `transport` `= 4/3 + (1 − g)(τa + τb)`:
/// `C₁ = (q − e_T (3μ₀² − 2μ₀)) / transport` and `C₀ = q − 2C₁/3`, with `q` how much of the
/// sun's light the column turns into diffuse light.
///
/// Eddington's `q = 3μ₀ (μ₀ + 2/3)` makes a thick deck transmit and reflect, per unit of the
/// sun's light falling on it, in proportion to `μ₀ + 2/3`, with `2/3` the extrapolation length
/// of Marshak's boundary condition. Against DISORT that falls too slowly as the sun sinks, and
/// thick decks under a low sun come out too bright from below and from above. The quadrature
/// two-stream's `1/√3` in its place (Meador & Weaver 1980, "Two-stream approximations to
/// radiative transfer in planetary atmospheres") follows DISORT's decks far closer, so the part
/// of the light the column has scattered, `1 − e_T`, takes `3μ₀ (μ₀ + 1/√3)`, scaled to
/// Eddington's at `μ₀ = 1` (a sun overhead is unchanged), and the beam still passing keeps
/// Eddington's (a thin column's light is mostly scattered once or twice, and Eddington's fits
/// it better): `q = e_T 3μ₀ (μ₀ + 2/3) + (1 − e_T) 3μ₀ (μ₀ + 1/√3) (5/3) / (1 + 1/√3)`.
/// `validation/README.md` has the decks before and after. WGSL twin: `sun_diffuse_constants`.
pub fn sun_diffuse_constants(mu0: f64, through: f64, transport: f64) -> [f64; 2] {
    let through = through.clamp(0.0, 1.0);
    let eddington = 3.0 * mu0 * (mu0 + 2.0 / 3.0);
    let scattered = 3.0 * mu0 * (mu0 + QUADRATURE_MU) * (5.0 / 3.0) / (1.0 + QUADRATURE_MU);
    let injected = through * eddington + (1.0 - through) * scattered;
    let c1 = (injected - through * (3.0 * mu0 * mu0 - 2.0 * mu0)) / transport;
    [injected - 2.0 / 3.0 * c1, c1]
}

/// `Δ(μ₀)` of [`sample_source`]: how much more of the sun's diffuse source, in units of
/// `E/4π`, light going up takes so that a semi-infinite conservative cloud sends out the light
/// the sun brings in, for the sun's cosine `mu0` (0.02–1 as the diffuse field clamps it):
/// `4μ₀ + 2μ₀ (3μ₀² − 1)(1 − μ₀ ln(1 + 1/μ₀)) − (3μ₀² + 2μ₀)`. It grows from 0.002 at
/// `μ₀ = 0.02` to 0.227 at `μ₀ = 1`. WGSL twin: `reflection_deficit`.
pub fn reflection_deficit(mu0: f64) -> f64 {
    let mu0 = mu0.clamp(MIN_DIFFUSE_MU_SUN, 1.0);
    let out =
        4.0 * mu0 + 2.0 * mu0 * (3.0 * mu0 * mu0 - 1.0) * (1.0 - mu0 * (1.0 + 1.0 / mu0).ln());
    out - (3.0 * mu0 * mu0 + 2.0 * mu0)
}

/// The nearest a sample is taken to be to a lightning flash, metres: the flash is a channel
/// hundreds of metres long, not a point. WGSL twin: `FLASH_MIN_DISTANCE_M`.
pub const FLASH_MIN_DISTANCE_M: f64 = 100.0;

/// The distance over which a flash's light leaks out of its cloud, metres: the diffusion below
/// holds in a cloud without end, and a storm cloud's light escapes through its sides and base
/// within a few kilometres. WGSL twin: `FLASH_LEAK_M`.
pub const FLASH_LEAK_M: f64 = 3_000.0;

/// The light of a lightning flash ([`MarchSettings::flash_intensity_cd`] `I` at
/// [`MarchSettings::flash_position_m`]) at a sample `position_m` (relative to the camera) in a
/// medium of extinction `extinction` (1/m): the mean radiance, per unit scattering, of a point
/// source in a conservatively scattering medium. Far from the source that is the diffusion
/// approximation's fluence over 4π, `3 σ' I / (4π d)` (Ishimaru 1978, "Wave Propagation and
/// Scattering in Random Media", the diffusion approximation); near it, the unscattered
/// `I e^(−σ d) / d²` over 4π. The two are joined as
/// `I / (4π d²) · (e^(−σ d) + 3 σ' d (1 − e^(−σ' d))) · e^(−d / L)`, with `d` the distance (at
/// least [`FLASH_MIN_DISTANCE_M`]), `σ' = (1 − g) σ` the reduced extinction for the phase's
/// asymmetry `g`, and `L` = [`FLASH_LEAK_M`] the leak out of a cloud of finite size. Far from the
/// flash the fluence falls as `1 / d`, not `1 / d²`: the cloud carries the light. Isotropic, so
/// it joins the diffuse light, seen through the scaled medium. 0 without a flash. WGSL twin:
/// `flash_source`.
pub fn flash_source(
    settings: &MarchSettings,
    phase: &EddingtonPhase,
    position_m: [f64; 3],
    extinction: f64,
) -> f64 {
    let intensity = settings.flash_intensity_cd;
    if intensity.is_nan() || intensity <= 0.0 {
        return 0.0;
    }
    let offset: [f64; 3] = std::array::from_fn(|c| position_m[c] - settings.flash_position_m[c]);
    let d = dot(offset, offset).sqrt().max(FLASH_MIN_DISTANCE_M);
    let sigma = extinction.max(0.0);
    let reduced = (1.0 - phase.scaled_asymmetry) * (1.0 - phase.forward_fraction) * sigma;
    let carried = (-sigma * d).exp() + 3.0 * reduced * d * (1.0 - (-reduced * d).exp());
    intensity / (4.0 * std::f64::consts::PI * d * d) * carried * (-d / FLASH_LEAK_M).exp()
}

/// Length of the light march from a point at `altitude_m` toward a sun at `mu_sun = dot(sun,
/// local up)`: the distance to where the ray leaves the shell of every active layer that holds
/// the point (through the top, or through the base when the sun is low), the longest of them.
/// Negative when the ground blocks the sun (the point is in the planet's shadow). 0 outside
/// every layer. WGSL twin: `light_march_distance`.
pub fn light_march_distance(
    layers: &[MarchLayer],
    planet_radius_m: f64,
    altitude_m: f64,
    mu_sun: f64,
) -> f64 {
    if ground_distance(altitude_m, mu_sun, planet_radius_m).is_finite() {
        return -1.0;
    }
    let mut distance: f64 = 0.0;
    for layer in layers.iter().filter(|layer| layer_is_active(layer)) {
        if !(altitude_m >= layer.base_m && altitude_m <= layer.top_m) {
            continue;
        }
        let outer = intersect_altitude_sphere(altitude_m, mu_sun, planet_radius_m, layer.top_m);
        let inner = intersect_altitude_sphere(altitude_m, mu_sun, planet_radius_m, layer.base_m);
        let through_base = if inner[0] >= 0.0 {
            inner[0]
        } else {
            f64::INFINITY
        };
        distance = distance.max(outer[1].max(0.0).min(through_base));
    }
    distance
}

/// The cosine of the sun's zenith angle at `position_m` (relative to a camera at
/// `camera_altitude_m` with local vertical `up`), whose altitude is `altitude_m`: the local up
/// there is `(A·up + p) / (R + alt)`. WGSL twin: `point_mu_sun`.
pub(in crate::reference) fn point_mu_sun(
    settings: &MarchSettings,
    camera_altitude_m: f64,
    up: [f64; 3],
    position_m: [f64; 3],
    altitude_m: f64,
) -> f64 {
    let radius = settings.planet_radius_m;
    let sun = settings.sun_direction;
    (((radius + camera_altitude_m) * dot(sun, up) + dot(sun, position_m)) / (radius + altitude_m))
        .clamp(-1.0, 1.0)
}

/// How far, in shadow-map texels, a far sample's own light march goes before the cloud shadow
/// map takes over ([`MarchSettings::sun_from_shadow_map_m`]): the map's texels blur a cloud's
/// edge, and the sample's light depends most on the cloud right next to it. WGSL twin:
/// `SHADOW_MAP_NEAR_TEXELS`.
pub const SHADOW_MAP_NEAR_TEXELS: f64 = 4.0;

/// Most light-march steps over those first texels (fewer than a full light march: the saving).
/// The fewest that keep `MEDIUM` within its 5 % of the converged march in the bench's views
/// away from the sun. WGSL twin: `SHADOW_MAP_NEAR_STEPS`.
pub const SHADOW_MAP_NEAR_STEPS: u32 = 4;

/// The point `s` metres toward the sun from `position_m` (at `altitude_m`, the sun at `mu_sun`
/// there): its coordinates along the horizontal `axes` and its altitude. The light marches'
/// samples ([`sun_optical_depth`], [`higher_layers_optical_depth`]). WGSL twin:
/// `sun_ray_point`.
fn sun_ray_point(
    settings: &MarchSettings,
    axes: [[f64; 3]; 2],
    position_m: [f64; 3],
    altitude_m: f64,
    mu_sun: f64,
    s: f64,
) -> ([f64; 2], f64) {
    let point = add(position_m, scale(settings.sun_direction, s));
    let altitude = altitude_along_ray(altitude_m, mu_sun, s, settings.planet_radius_m);
    ([dot(point, axes[0]), dot(point, axes[1])], altitude)
}

/// Optical depth toward the sun from the point `position_m` (relative to a camera at
/// `camera_altitude_m` with local vertical `up`) at `altitude_m`, by a light march of
/// `steps` steps (at most [`MAX_LIGHT_STEPS`]; the march uses [`MarchSettings::light_steps`])
/// over [`light_march_distance`], or over the first `max_distance_m` metres of it; negative when
/// the ground blocks the sun.
///
/// Step boundaries lie at `D (k / n)²`: short steps near the point, where the self-shadowing
/// detail is, long ones far away. Each step samples the point `offset` (0–1) of the way through
/// it; the march uses [`LIGHT_SAMPLE_OFFSET`], the midpoints, whatever the view ray's jitter,
/// which only rounds the step count (`jitter`, [`light_step_count`]). A
/// homogeneous layer is integrated exactly whatever the offset. Altitudes along the light ray come from [`altitude_along_ray`] relative to
/// the point. The footprint of a light sample is at least its step length, so long steps read
/// coarse mips. Only the shells that hold the point are marched: the layers wholly above it
/// are [`higher_layers_optical_depth`]'s, which the march adds to a full light march (a far
/// sample's cloud shadow map holds them already). WGSL twin: `sun_optical_depth`.
pub fn sun_optical_depth(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    camera_altitude_m: f64,
    up: [f64; 3],
    position_m: [f64; 3],
    altitude_m: f64,
    footprint_m: f64,
    max_distance_m: f64,
    steps: u32,
    offset: f64,
    jitter: f64,
) -> f64 {
    let radius = settings.planet_radius_m;
    let mu_sun = point_mu_sun(settings, camera_altitude_m, up, position_m, altitude_m);
    let distance = light_march_distance(layers, radius, altitude_m, mu_sun);
    if distance < 0.0 {
        return -1.0;
    }
    let distance = distance.min(max_distance_m);
    let steps = light_step_count(
        steps,
        distance,
        footprint_m,
        settings.light_steps_per_footprint,
        jitter,
    )
    .min(optically_thin_light_steps(
        layers,
        radius,
        altitude_m,
        mu_sun,
        distance,
        settings.light_step_optical_depth,
        jitter,
    ));
    if steps == 0 || distance == 0.0 {
        return 0.0;
    }
    let axes = horizontal_axes(up);
    let n = f64::from(steps);
    let mut optical_depth = 0.0;
    for k in 0..steps {
        let s0 = distance * (f64::from(k) / n).powi(2);
        let s1 = distance * (f64::from(k + 1) / n).powi(2);
        let ds = s1 - s0;
        let s = s0 + offset * ds;
        let (horizontal, altitude) =
            sun_ray_point(settings, axes, position_m, altitude_m, mu_sun, s);
        let extinction = total_extinction(
            textures,
            layers,
            horizontal,
            altitude,
            footprint_m.max(ds),
            true,
        );
        optical_depth += extinction * ds;
    }
    optical_depth
}

/// Light-march steps through each layer above a sample's own: one per this many of the
/// sample's light steps ([`MarchSettings::light_steps`] as the march gives them), rounded up.
/// A layer seen from below casts a shade whose detail the sample's own light march does not
/// need. WGSL twin: `HIGHER_LAYER_STEP_DIVISOR`.
pub const HIGHER_LAYER_STEP_DIVISOR: u32 = 4;

/// Optical depth toward the sun, beyond the sample's own layers, through every active layer
/// whose base lies above `altitude_m`: each crossed from its base to its top in
/// `light_steps /` [`HIGHER_LAYER_STEP_DIVISOR`] (rounded up) equal steps sampled at their
/// midpoints, with the layer's full density ([`layer_density`]) at a footprint of at least the
/// step. 0 without such layers. Without it a low cloud under an overcast deck would take the
/// full sun. The point is at `position_m` relative to a camera with local vertical `up`, and the
/// sun at `mu_sun` there (`point_mu_sun`). WGSL twin: `higher_layers_optical_depth`.
#[allow(clippy::too_many_arguments)]
pub fn higher_layers_optical_depth(
    textures: &CloudTextures,
    settings: &MarchSettings,
    layers: &[MarchLayer],
    up: [f64; 3],
    position_m: [f64; 3],
    altitude_m: f64,
    mu_sun: f64,
    footprint_m: f64,
    light_steps: u32,
) -> f64 {
    let steps = light_steps.div_ceil(HIGHER_LAYER_STEP_DIVISOR);
    if steps == 0 {
        return 0.0;
    }
    let radius = settings.planet_radius_m;
    let axes = horizontal_axes(up);
    let n = f64::from(steps);
    let mut optical_depth = 0.0;
    for layer in layers
        .iter()
        .filter(|layer| layer_is_active(layer) && layer.base_m > altitude_m)
    {
        // From inside both spheres the ray leaves each through its far root.
        let enter = intersect_altitude_sphere(altitude_m, mu_sun, radius, layer.base_m)[1];
        let leave = intersect_altitude_sphere(altitude_m, mu_sun, radius, layer.top_m)[1];
        if !(enter >= 0.0 && leave > enter) {
            continue;
        }
        let ds = (leave - enter) / n;
        for k in 0..steps {
            let s = enter + (f64::from(k) + 0.5) * ds;
            let (horizontal, altitude) =
                sun_ray_point(settings, axes, position_m, altitude_m, mu_sun, s);
            optical_depth += layer_density(
                textures,
                layer,
                horizontal,
                altitude,
                footprint_m.max(ds),
                true,
            ) * ds;
        }
    }
    optical_depth
}

/// Where each light-march step is sampled, as a fraction of the step: its midpoint, every
/// frame. The view samples are jittered ([`ray_start_jitter`]) and the temporal accumulation
/// averages them, but averaging the light march over offsets averages `e^(−τ)`, not `τ`: where
/// the optical depth toward the sun changes with the offset, the mean of the transmittances is
/// brighter than the transmittance of the mean (Jensen's inequality), a bias that shows most
/// under a low sun. WGSL twin: `LIGHT_SAMPLE_OFFSET`.
pub const LIGHT_SAMPLE_OFFSET: f64 = 0.5;

/// Light path over which a light march takes its [`MarchSettings::light_steps`], metres: a
/// longer path (a low sun's, kilometres through the layer) takes proportionally more steps, up
/// to [`MAX_LIGHT_STEPS`], so its far steps stay short against the clouds they cross.
/// Half the default shape-noise period: a 4° sun's path through a 1 km layer (14 km) takes 7
/// times the steps. WGSL twin: `LIGHT_STEP_SPAN_M`.
pub const LIGHT_STEP_SPAN_M: f64 = 2_000.0;

/// Steps of a light march `distance_m` long from a sample whose footprint is `footprint_m`:
/// `steps` over [`LIGHT_STEP_SPAN_M`] or less, and in proportion beyond, but those extra steps
/// no more than `per_footprint` per footprint ([`MarchSettings::light_steps_per_footprint`]; not
/// a positive number, or a footprint of 0: no limit, rounded down); at most
/// [`MAX_LIGHT_STEPS`]. The steps for the length are rounded down after adding `jitter` (0–1,
/// the view ray's; 0.5 rounds to the nearest): a count rounded at fixed lengths changes at
/// fixed altitudes in a layer under a low sun and drew bands there, and with the jitter the
/// accumulated frames take the counts on either side in proportion. (Rounding the footprint
/// limit so too, half a step more on average, made `MEDIUM` at sunset 4.82 % → 5.92 % off the
/// converged march in the bench; it stays rounded down.) WGSL twin: `light_step_count` (which
/// takes `per_footprint` from its uniforms, as f32).
pub fn light_step_count(
    steps: u32,
    distance_m: f64,
    footprint_m: f64,
    per_footprint: f64,
    jitter: f64,
) -> u32 {
    let mut scaled = (f64::from(steps) * distance_m / LIGHT_STEP_SPAN_M + jitter).floor();
    if per_footprint > 0.0 && per_footprint.is_finite() && footprint_m > 0.0 {
        scaled = scaled.min((per_footprint * distance_m / footprint_m).floor());
    }
    // NaN (and negatives) add no steps.
    let scaled = if scaled >= 0.0 {
        scaled.min(f64::from(MAX_LIGHT_STEPS)) as u32
    } else {
        0
    };
    steps.max(scaled).min(MAX_LIGHT_STEPS)
}

/// [`MarchSettings::light_step_optical_depth`] of the presets that limit it: the most optical
/// depth one light-march step may span where the layers are at their peak extinction.
pub const LIGHT_STEP_OPTICAL_DEPTH: f64 = 0.125;

/// The most light-march steps a path needs where it is optically thin: `τ_max /
/// max_step_depth` (the knob [`MarchSettings::light_step_optical_depth`]), rounded down after
/// adding the view ray's `jitter` (0–1) and at least 1, where `τ_max` is the path's length
/// `distance_m` times the summed peak extinction ([`MarchLayer::extinction`]) of every active
/// layer whose shell the path's altitudes reach (from a point at `altitude_m`, the sun at
/// `mu_sun` there). No density exceeds its layer's peak extinction, so `τ_max` bounds the
/// optical depth the light march integrates, and where it is small a few steps give the
/// transmittance `e^(−τ)` within 1 % of a fine quadrature, as the dense cloud's own light march
/// does. At [`LIGHT_STEP_OPTICAL_DEPTH`] a veil of cirrostratus (0.0004/m over 1 km) takes two
/// to six steps instead of [`MarchSettings::light_steps`]; a cumulus (0.07/m) never reaches
/// the limit. Rounding with the jitter lets the accumulated frames take the counts on either
/// side in proportion, so the count draws no bands where `τ_max` crosses a whole step.
/// `u32::MAX` (no limit) where `max_step_depth` is not a positive finite number or the bound
/// is not finite. WGSL twin: `optically_thin_light_steps`.
pub fn optically_thin_light_steps(
    layers: &[MarchLayer],
    planet_radius_m: f64,
    altitude_m: f64,
    mu_sun: f64,
    distance_m: f64,
    max_step_depth: f64,
    jitter: f64,
) -> u32 {
    if !(max_step_depth > 0.0 && max_step_depth.is_finite()) {
        return u32::MAX;
    }
    let end = altitude_along_ray(altitude_m, mu_sun, distance_m, planet_radius_m);
    let mut low = altitude_m.min(end);
    let high = altitude_m.max(end);
    // A sun below the local horizon: the path dips to its lowest point before it climbs.
    let lowest_at = -(planet_radius_m + altitude_m) * mu_sun;
    if lowest_at > 0.0 && lowest_at < distance_m {
        low = low.min(altitude_along_ray(
            altitude_m,
            mu_sun,
            lowest_at,
            planet_radius_m,
        ));
    }
    let peak: f64 = layers
        .iter()
        .filter(|layer| layer_is_active(layer) && layer.top_m >= low && layer.base_m <= high)
        .map(|layer| layer.extinction)
        .sum();
    let steps = (peak * distance_m / max_step_depth + jitter).floor();
    if !steps.is_finite() {
        return u32::MAX;
    }
    steps.clamp(1.0, f64::from(MAX_LIGHT_STEPS)) as u32
}

/// Mean transmittance across a step of optical thickness `x = σt·dt`, `(1 − e^(−x)) / x =
/// −expm1(−x) / x`: the factor of Hillaire 2016's energy-conserving step integral
/// `S·dt·f(x)`. Exact as `x → 0` (series `1 − x/2 + x²/6`, no clamped division, no `0 / 0` at
/// `σt = 0`) and `1 / x` for large `x` (no overflow, finite at `x = ∞`: 0). WGSL twin:
/// `mean_step_transmittance` (series below 0.1 there, since f32 has no `expm1`).
pub fn mean_step_transmittance(x: f64) -> f64 {
    let x = x.max(0.0);
    if x < SERIES_LIMIT {
        1.0 - x * (0.5 - x / 6.0)
    } else {
        -(-x).exp_m1() / x
    }
}

/// Offset of the first sample within each step, 0–1: blue noise at `pixel`, animated per frame
/// ([`blue_noise_jitter`](crate::reference::blue_noise::blue_noise_jitter)), when
/// [`MarchSettings::jitter`] is on (against banding, Pérez Martín 2022 "Banding Reduction"), the step
/// midpoint 0.5 when off. WGSL twin: `ray_start_jitter`.
pub fn ray_start_jitter(settings: &MarchSettings, pixel: [f64; 2]) -> f64 {
    if settings.jitter {
        crate::reference::blue_noise::blue_noise_jitter(pixel, settings.frame_index)
    } else {
        0.5
    }
}

/// The light on a horizontal surface under a cloud deck, per channel, lux: the direct beam
/// through the deck and the diffuse light out of its base ([`deck_irradiance`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeckIrradiance {
    /// The sun's beam through the deck, `μ₀ E e^(−τ/μ₀)` (what a shadow map lets through).
    pub direct: f64,
    /// Everything else: the sun's light scattered in the deck (its forward peak included) and
    /// the sky's light through it.
    pub diffuse: f64,
}

/// The irradiance under a homogeneous deck of vertical optical depth `optical_depth` (the
/// δ-Eddington two-stream fluxes of [`sample_source`]'s field at the base, with Marshak's
/// boundary conditions), lit by a sun of illuminance `sun` (lux, on a surface facing it) at
/// `mu_sun` = cosine of its zenith angle and by an isotropic sky of radiance `sky_top` (cd/m²) on
/// its top, over a ground that sends `sky_bottom` (cd/m²) up into its base. The downward flux
/// of the scaled problem at the base is `π (I₀ + 2I₁/3)`; its scaled direct beam `μ₀ E e^(−(1 −
/// f) τ/μ₀)` holds the light scattered in the phase's forward peak, which is diffuse light
/// beyond the true beam. Validated against DISORT's total downward flux (`validation/disort/`).
/// CPU only: no WGSL twin.
pub fn deck_irradiance(
    phase: &EddingtonPhase,
    optical_depth: f64,
    mu_sun: f64,
    sun: f64,
    sky_top: f64,
    sky_bottom: f64,
) -> DeckIrradiance {
    use std::f64::consts::PI;
    let tau = optical_depth.max(0.0);
    let f = phase.forward_fraction;
    let one_minus_g = (1.0 - phase.scaled_asymmetry) * (1.0 - f);
    let transport = 4.0 / 3.0 + one_minus_g * tau;
    // The sky's field: I₁ = (A_t − A_b) / transport, I₀ = A_t − (2/3 + (1 − g) τ) I₁ at the base.
    let sky_i1 = (sky_top - sky_bottom) / transport;
    let sky_i0 = sky_top - (2.0 / 3.0 + one_minus_g * tau) * sky_i1;
    let mut irradiance = DeckIrradiance {
        direct: 0.0,
        diffuse: PI * (sky_i0 + 2.0 / 3.0 * sky_i1),
    };
    if mu_sun > 0.0 && sun > 0.0 {
        let mu0 = mu_sun.max(MIN_DIFFUSE_MU_SUN);
        let k = 0.25 / PI * sun;
        let beam = (-(1.0 - f) * tau / mu0).exp();
        let [c0, c1] = sun_diffuse_constants(mu0, beam, transport).map(|c| k * c);
        let i1 = c1 - 3.0 * mu0 * k * beam;
        let i0 = c0 - one_minus_g * c1 * tau - 3.0 * mu0 * mu0 * k * beam;
        irradiance.direct = mu_sun * sun * (-tau / mu_sun).exp();
        // What the forward peak does to a grazing beam, as in the light going down of
        // `sample_source`.
        let turned = 1.0 - (1.0 - beam) * (1.0 - grazing_peak_factors(phase, mu0)[1]);
        irradiance.diffuse +=
            turned * PI * (i0 + 2.0 / 3.0 * i1) + mu_sun * sun * beam - irradiance.direct;
    }
    irradiance.diffuse = irradiance.diffuse.max(0.0);
    irradiance
}

/// Sets each layer's [`MarchLayer::sky_light_top`] and [`MarchLayer::sky_light_bottom`] from the
/// active layers wholly above it (their base at or above its top), taken from the highest down,
/// each as a sheet of its coverage `c` and vertical optical thickness `τ = σ h`: the radiance `L`
/// from above becomes `(1 − c) L + c (T_d L + (T_d − b)⁺ E/π)` and the sun's direct
/// irradiance `E` (on a horizontal surface) becomes `E (1 − c (1 − b))`, with the beam
/// `b = e^(−(1 − f) τ/μ₀)` as the δ-scaled medium passes it ([`EddingtonPhase`]), `T_d` the
/// diffuse transmittance ([`cloud_diffuse_transmittance`](crate::reference::haze::cloud_diffuse_transmittance))
/// and `μ₀` the sine of the sun's elevation (at least 0.05). The top factor is `L` over the
/// open sky's [`MarchSettings::ambient_top`], the bottom factor the irradiance left under
/// the layers above, `E + π L`, over the open sky's: the ground lit by less light sends less
/// back. The direct sun through the gaps is the light march's ([`higher_layers_optical_depth`]).
/// A layer with nothing above it keeps factors of 1.
pub fn sky_light_under_layers(settings: &MarchSettings, layers: &mut [MarchLayer]) {
    let mu0 = dot(settings.sun_direction, settings.camera_up).max(0.0);
    let slant = mu0.max(0.05);
    // The beam as the march's δ-scaled medium passes it (what a sample under the layer takes
    // as sun: `SampleLights::sun_above_depth`); the rest of T_d is scattered.
    let scaled = 1.0 - eddington_phase(settings).forward_fraction;
    let sun = settings.sun_illuminance.map(|e| e * mu0);
    let sky = settings.ambient_top;
    let open_flux: [f64; 3] = std::array::from_fn(|c| sun[c] + std::f64::consts::PI * sky[c]);
    // Each active layer as (base, top, coverage, vertical optical depth), the highest top first.
    let mut sheets: Vec<[f64; 4]> = layers
        .iter()
        .filter(|layer| layer_is_active(layer))
        .map(|layer| {
            let tau = layer.extinction * (layer.top_m - layer.base_m);
            [
                layer.base_m,
                layer.top_m,
                layer.coverage.clamp(0.0, 1.0),
                tau,
            ]
        })
        .collect();
    sheets.sort_by(|a, b| b[1].total_cmp(&a[1]));
    for layer in layers.iter_mut() {
        let (mut radiance, mut direct) = (sky, sun);
        for &[_, _, coverage, tau] in sheets.iter().filter(|sheet| sheet[0] >= layer.top_m) {
            let through = crate::reference::haze::cloud_diffuse_transmittance(tau);
            let beam = (-scaled * tau / slant).exp();
            let scattered = (through - beam).max(0.0);
            for c in 0..3 {
                radiance[c] = (1.0 - coverage) * radiance[c]
                    + coverage
                        * (through * radiance[c] + scattered * direct[c] / std::f64::consts::PI);
                direct[c] *= 1.0 - coverage * (1.0 - beam);
            }
        }
        // With nothing above, both ratios are exactly 1.
        let ratio = |value: f64, open: f64| if open > 0.0 { value / open } else { 1.0 };
        layer.sky_light_top = std::array::from_fn(|c| ratio(radiance[c], sky[c]));
        layer.sky_light_bottom = std::array::from_fn(|c| {
            ratio(direct[c] + std::f64::consts::PI * radiance[c], open_flux[c])
        });
    }
}

/// The sky light under the layers above a camera ([`crate::render::sky_light`]'s module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyLightUnderClouds {
    /// Fraction of the sky the layers above the camera cover, 0–1.
    pub cover: f64,
    /// The diffuse irradiance on a horizontal surface over the clear sky's, luminance (1 under a
    /// clear sky).
    pub factor: f64,
    /// The covered part's light as the radiance of a uniform sky that puts the same irradiance
    /// on a horizontal surface, `c E_d / π` with the ground's bounce, per linear RGB channel, in
    /// the units of [`MarchSettings::sun_illuminance`] per steradian (cd/m² for lux); 0 under a
    /// clear sky.
    pub cloud_radiance: [f64; 3],
}

impl SkyLightUnderClouds {
    /// A clear sky: nothing covered, factor 1.
    pub const CLEAR: Self = Self {
        cover: 0.0,
        factor: 1.0,
        cloud_radiance: [0.0; 3],
    };
}

/// The sky light of [`crate::render::sky_light`]'s module docs for a march's settings and
/// layers (the camera at [`MarchSettings::camera_altitude_m`]) over a ground of albedo
/// `ground_albedo` (0–1): the light
/// the ground sends back up is reflected down again by the deck, `1 / (1 − A R)` more, `R` the
/// deck's reflectance for diffuse light from below, `1 − (4/3) / (4/3 + (1 − g) τ)`.
/// [`SkyLightUnderClouds::CLEAR`] when the clear sky sends no light.
pub fn sky_light_under_clouds(
    settings: &MarchSettings,
    layers: &[MarchLayer],
    ground_albedo: f64,
) -> SkyLightUnderClouds {
    const SAMPLES: u32 = 16;
    let luminance = |rgb: [f64; 3]| 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    let altitude = settings.camera_altitude_m;
    let mut clear_fraction = 1.0;
    let mut weighted_depth = 0.0;
    let mut weights = 0.0;
    for layer in layers.iter().filter(|layer| layer_is_active(layer)) {
        let bottom = layer.base_m.max(altitude);
        if layer.top_m.partial_cmp(&bottom) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let mean_profile = (0..SAMPLES)
            .map(|i| {
                let height =
                    bottom + (layer.top_m - bottom) * (f64::from(i) + 0.5) / f64::from(SAMPLES);
                profile_density(
                    layer,
                    (height - layer.base_m) / (layer.top_m - layer.base_m),
                )
            })
            .sum::<f64>()
            / f64::from(SAMPLES);
        let cover = layer.coverage.clamp(0.0, 1.0);
        clear_fraction *= 1.0 - cover;
        weighted_depth += cover * layer.extinction * mean_profile * (layer.top_m - bottom);
        weights += cover;
    }
    let cover = 1.0 - clear_fraction;
    let clear = std::f64::consts::PI * luminance(settings.ambient_top);
    if clear.is_nan() || clear <= 0.0 || cover.is_nan() || cover <= 0.0 {
        return SkyLightUnderClouds::CLEAR;
    }
    let phase = eddington_phase(settings);
    let depth = weighted_depth / weights;
    let mu_sun = settings
        .sun_direction
        .iter()
        .zip(settings.camera_up)
        .map(|(s, u)| s * u)
        .sum();
    let one_minus_g = (1.0 - phase.scaled_asymmetry) * (1.0 - phase.forward_fraction);
    let reflectance = 1.0 - (4.0 / 3.0) / (4.0 / 3.0 + one_minus_g * depth);
    let bounce = 1.0 / (1.0 - ground_albedo.clamp(0.0, 1.0) * reflectance).max(1e-3);
    let under: [f64; 3] = std::array::from_fn(|c| {
        deck_irradiance(
            &phase,
            depth,
            mu_sun,
            settings.sun_illuminance[c],
            settings.ambient_top[c],
            0.0,
        )
        .diffuse
            * bounce
    });
    SkyLightUnderClouds {
        cover,
        factor: ((1.0 - cover) * clear + cover * luminance(under)) / clear,
        cloud_radiance: under.map(|e| cover * e / std::f64::consts::PI),
    }
}
