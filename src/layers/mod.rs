//! Cloud layers: the data a game edits and the renderer draws.
//!
//! Third stage of the crate's data flow (forecast → [`weather`](crate::weather) → layers →
//! render). A [`CloudLayer`] is one shell of cloud between two altitudes above the ground. The
//! renderer fills it with noise and shapes that noise with the layer's numbers:
//!
//! - **Where**: [`CloudLayer::base_m`] and [`CloudLayer::top_m`], metres above ground. The renderer
//!   draws the layer as a spherical shell around the planet centre.
//! - **How much**: [`CloudLayer::coverage`] is the fraction of the sky the layer covers (0–1). It
//!   drives the coverage remap of the density model (Pérez Martín 2022, "Density Model":
//!   `Remap(base, 1 − coverage · weather, 1, 0, 1)`).
//! - **How dense**: [`CloudLayer::density`] is the extinction coefficient, 1/m, of the densest
//!   cloud in the layer. The noise density (0–1) scales it.
//! - **What shape**: [`CloudLayer::profile`] is a [`DensityProfile`]: density against the height
//!   fraction in the layer (0 at the base, 1 at the top). It plays the part of Aetherius'
//!   shape-altering curve. In Pérez Martín 2022 ("Density Model") the shape-altering gradient starts as
//!   two remaps multiplied together, "no density at the bottom, full density somewhere in the
//!   middle … fades to zero density again at the top". It then becomes a user-drawn curve, sampled
//!   into an array on the CPU "when the curve is modified" and passed to the shader
//!   ([`DensityProfile::bake`] does that here). The curve is data, not a formula, so it can be
//!   edited. [`CloudLayer::coverage_height`] lets the weather's local coverage set how far up
//!   the layer each cloud reaches, so heaps come down toward the edge of their cloudy patch
//!   instead of standing as walls there. Inside the patches of a broken layer the base shape
//!   noise carves separate heaps ([`crate::reference::render::local_coverage`]).
//! - **How it moves**: [`CloudLayer::wind_m_s`] scrolls the layer's noise and weather map.
//!   [`CloudLayer::skew`] leans the clouds downwind with height. This is Pérez Martín 2022's "Wind and
//!   Skew": skew "only displaces the weather map texture and the amount displaced increases with
//!   height".
//! - **Weather**: [`CloudLayer::precipitation`] darkens the cloud (0–1) and
//!   [`CloudLayer::rain_mm_per_h`] is the rain falling from it.
//! - **Who drives it**: a layer with a [`LayerSlot`](crate::weather::LayerSlot) component is
//!   rewritten from the forecast by the weather mapping
//!   ([`weather::mapping`](crate::weather::mapping)), or from the
//!   [`ActivePreset`](crate::weather::preset::ActivePreset) while there is one. Any other layer is
//!   left alone, and every value is the user's: remove a layer's slot to take it over by hand
//!   ("play" mode), insert it again to give it back to the forecast.
//! - **How it changes**: a layer with a [`LayerTransition`] moves smoothly to the transition's
//!   target over its duration; the mapping and the presets write that target. Picking a new
//!   target halfway keeps every value and its rate continuous.
//!
//! Any number of layers may exist. A layer that [`CloudLayer::is_visible`] says is invisible
//! (coverage 0, density 0, or no thickness) is not sent to the GPU and costs nothing.
//!
//! # Kinds and their defaults
//!
//! [`CloudLayer::new`] starts a layer from its [`CloudKind`]'s [`KindDefaults`]:
//!
//! | kind | base – top, m above ground | coverage | density, 1/m | weather-map period, m | skew | coverage height |
//! |---|---|---|---|---|---|---|
//! | Cumulus | 1 000 – 2 200 | 0.4 | 0.07 | 12 000 | 0.1 | 1 |
//! | Stratocumulus | 800 – 1 400 | 0.7 | 0.05 | 20 000 | 0.05 | 0.5 |
//! | Stratus | 150 – 450 | 0.9 | 0.04 | 40 000 | 0 | 0 |
//! | Altocumulus | 3 000 – 3 500 | 0.5 | 0.03 | 15 000 | 0.05 | 0.5 |
//! | Altostratus | 3 000 – 5 000 | 0.9 | 0.015 | 40 000 | 0 | 0 |
//! | Cirrus | 8 000 – 9 000 | 0.4 | 0.000 8 | 50 000 | 0.5 | 0 |
//! | Cirrostratus | 7 500 – 8 500 | 0.9 | 0.000 4 | 80 000 | 0.1 | 0 |
//! | Cirrocumulus | 7 000 – 7 400 | 0.4 | 0.001 6 | 15 000 | 0.1 | 0.5 |
//! | Cumulonimbus | 1 000 – 10 000 | 0.3 | 0.1 | 30 000 | 0.2 | 0.5 |
//!
//! - **Altitudes** are typical mid-latitude heights inside the WMO étages (International Cloud
//!   Atlas, WMO-No. 407: low étage from the surface to 2 km, middle 2–7 km, high 5–13 km in
//!   temperate regions; the same bands as meteoblue's Packages API documentation,
//!   docs.meteoblue.com). Cumulonimbus spans all three étages, from a low base to an anvil near
//!   the tropopause (Thomann 2021 §3.3.10: "spanning over the whole troposphere").
//! - **Densities** are extinction coefficients from the geometric-optics relation
//!   `σ ≈ 3·LWC / (2·ρ·r_e)` (Stephens 1978, extinction efficiency ≈ 2). LWC is the liquid (or
//!   ice) water content, ρ the density of water (or ice) and `r_e` the effective droplet (or
//!   crystal) radius. The typical values used are: cumulus 0.5 g/m³ at 10 µm, stratocumulus
//!   0.3 g/m³ at 9 µm, stratus 0.25 g/m³ at 9 µm, altocumulus 0.2 g/m³ at 10 µm, altostratus
//!   0.1 g/m³ at 10 µm, cumulonimbus 1 g/m³ at 15 µm. The cirrus family uses ice water contents
//!   of 0.01–0.03 g/m³ with crystals of 30–40 µm. A 1 km cumulus is therefore opaque (optical depth
//!   ≈ 70) and a 1 km cirrus translucent (≈ 0.8).
//! - **Coverage, weather-map period, skew and coverage height** are starting points chosen for
//!   the look, not measurements. The period is set so that the weather noise holds several
//!   clouds of the kind's typical size (cumulus cells about 1 km, stratiform sheets tens of km).
//!   The skew makes cirrus fall streaks and cumulonimbus anvils trail downwind. Heaps take a
//!   coverage height, so they come down toward the edges of their cloudy patches; sheets keep a
//!   level top.
//!
//! Each kind's vertical profile is in [`DensityProfile::for_kind`].

mod drift;
mod growth;
mod haze;
mod kind;
mod profile;
pub mod rain;
mod transition;

use bevy::prelude::{Component, Reflect, ReflectComponent, ReflectDefault};

pub use drift::LayerDrift;
pub(crate) use drift::drift_cloud_layers;
#[doc(hidden)]
pub use growth::{
    COVERED_FROM, GrowthProbabilities, GrowthSteering, covered_fraction, covered_regions,
    covered_share,
};
pub use growth::{CloudGrowth, NoiseMaker};
pub use haze::{Haze, KOSCHMIEDER_CONSTANT};
pub use kind::{CloudKind, KindDefaults};
pub use profile::{DensityProfile, ProfileInterpolation, ProfilePoint};
pub(crate) use transition::run_transitions;
pub use transition::{DEFAULT_TRANSITION_S, HazeTransition, LayerTransition};

/// One layer of cloud between two altitudes above the ground. The [module docs](self) explain
/// the model.
///
/// Start from [`CloudLayer::new`] for a kind's defaults, then change fields. The weather mapping
/// ([`weather::mapping`](crate::weather::mapping)) rewrites only layers with a
/// [`LayerSlot`](crate::weather::LayerSlot); a layer you spawn without a slot keeps your
/// values.
///
/// `Default` is [`CloudLayer::new`]`(`[`CloudKind::Cumulus`]`)`.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct CloudLayer {
    /// The genus. It picks the defaults in [`CloudLayer::new`]; the renderer uses only the
    /// numbers below. Default [`CloudKind::Cumulus`].
    pub kind: CloudKind,
    /// Cloud base, metres above the ground (the scene's ground level). Default: the kind's (see
    /// [`CloudKind::defaults`]).
    pub base_m: f32,
    /// Cloud top, metres above the ground; above [`CloudLayer::base_m`] for a visible layer.
    /// Default: the kind's.
    pub top_m: f32,
    /// Fraction of the sky covered, 0–1 (forecast `lowclouds`/`midclouds`/`highclouds`). Default:
    /// the kind's.
    pub coverage: f32,
    /// Extinction coefficient of the densest cloud in the layer, 1/m (≥ 0). Default: the kind's,
    /// e.g. 0.07 /m for cumulus.
    pub density: f32,
    /// Vertical density profile: Aetherius' shape-altering curve. Default:
    /// [`DensityProfile::for_kind`].
    pub profile: DensityProfile,
    /// How much the weather's local coverage sets the clouds' height, 0–1 (dimensionless).
    /// Where the weather pattern fills a cloudy patch to `f` (1 in the middle of the patch,
    /// falling to 0 at its edge; [`crate::reference::render::patch_fill`]), the profile is
    /// stretched over `1 − s · (1 − f)²` of the layer's thickness. At 1 a cloud's top comes down
    /// toward its edges, so heaps round into domes; at 0 every cloud reaches the layer's top and
    /// stands as a wall where the patch ends. Default: the kind's (cumulus 1; stratocumulus,
    /// altocumulus, cirrocumulus and cumulonimbus 0.5; sheets and cirrus 0).
    pub coverage_height: f32,
    /// Period of the layer's 2D weather noise, metres: the horizontal size of the pattern of
    /// clouds and gaps (> 0). Default: the kind's, e.g. 12 000 m for cumulus.
    pub weather_map_scale_m: f32,
    /// Velocity of the air carrying the layer, `[east, north]` in m/s: where the clouds move TO.
    /// Default `[0, 0]`.
    pub wind_m_s: [f32; 2],
    /// Horizontal shift of the weather map per metre of height, in the wind's direction
    /// (dimensionless; 0.5 moves the top of a 1 km layer 500 m downwind of its base). Default:
    /// the kind's.
    pub skew: f32,
    /// How much the 3D shape and detail noise carve the layer, 0–1: 0 is a homogeneous slab
    /// (density = profile × coverage), 1 the full billowy shapes. Default 1.
    pub shape_noise: f32,
    /// Darkening of the cloud by precipitation, 0 (none) to 1 (darkest). Default 0.
    pub precipitation: f32,
    /// Rain (or snow, as water) falling from the layer's base, mm/h (≥ 0). Default 0.
    pub rain_mm_per_h: f32,
    /// The layer's coverage toward distant places, so the weather can change across the view
    /// (Thomann 2021 §4.4–4.5: Bern's forecast in the foreground, Solothurn's toward Solothurn).
    /// [`CloudLayer::coverage`] holds near the first place of each entry and each entry's
    /// coverage from 30 % of the way to its place onward (see [`FarCoverage`]). The renderer
    /// uses the first [`MAX_FAR_COVERAGES`]. The weather mapping fills it from
    /// [`WeatherSource::far`](crate::weather::WeatherSource::far). Default: empty (one coverage
    /// everywhere).
    pub far_coverage: Vec<FarCoverage>,
}

pub use crate::reference::render::{FAR_BLEND_START, MAX_FAR_COVERAGES};

/// A layer's coverage at a distant place ([`CloudLayer::far_coverage`]).
///
/// With `s` the fraction of the way from `from_m` to `to_m` of a point's projection onto that
/// line, the coverage there is `near + b(s) · (coverage − near)` with `b` a smoothstep from 0 at
/// [`FAR_BLEND_START`] to 1 at `s = 1`. The blend is a band across the line, so the far weather
/// fills that whole side of the sky near the horizon, as distant weather is seen.
#[derive(Clone, Copy, Debug, PartialEq, Default, Reflect)]
pub struct FarCoverage {
    /// The near place, scene metres `[east, north]` (the weather origin is `[0, 0]`).
    pub from_m: [f32; 2],
    /// The far place, scene metres `[east, north]`.
    pub to_m: [f32; 2],
    /// Fraction of the sky covered at the far place, 0–1.
    pub coverage: f32,
}

impl FarCoverage {
    /// Whether the entry can blend: finite places at least a metre apart, finite coverage.
    #[must_use]
    pub fn is_usable(&self) -> bool {
        let d = [self.to_m[0] - self.from_m[0], self.to_m[1] - self.from_m[1]];
        self.from_m.iter().chain(&self.to_m).all(|v| v.is_finite())
            && self.coverage.is_finite()
            && (d[0] * d[0] + d[1] * d[1]) >= 1.0
    }
}

impl Default for CloudLayer {
    fn default() -> Self {
        Self::new(CloudKind::Cumulus)
    }
}

impl CloudLayer {
    /// A layer of `kind` with the kind's defaults ([`CloudKind::defaults`],
    /// [`DensityProfile::for_kind`]), no wind and no precipitation.
    #[must_use]
    pub fn new(kind: CloudKind) -> Self {
        let defaults = kind.defaults();
        Self {
            kind,
            base_m: defaults.base_m,
            top_m: defaults.top_m,
            coverage: defaults.coverage,
            density: defaults.density,
            profile: DensityProfile::for_kind(kind),
            coverage_height: defaults.coverage_height,
            weather_map_scale_m: defaults.weather_map_scale_m,
            wind_m_s: [0.0, 0.0],
            skew: defaults.skew,
            shape_noise: 1.0,
            precipitation: 0.0,
            rain_mm_per_h: 0.0,
            far_coverage: Vec::new(),
        }
    }

    /// Thickness `top_m − base_m`, metres (negative for an inverted layer).
    #[must_use]
    pub fn thickness_m(&self) -> f32 {
        self.top_m - self.base_m
    }

    /// The largest coverage anywhere: [`CloudLayer::coverage`] or a usable
    /// [`CloudLayer::far_coverage`] among the first [`MAX_FAR_COVERAGES`].
    #[must_use]
    pub fn max_coverage(&self) -> f32 {
        self.far_coverage
            .iter()
            .take(MAX_FAR_COVERAGES)
            .filter(|far| far.is_usable())
            .map(|far| far.coverage)
            .fold(self.coverage, f32::max)
    }

    /// Whether the layer can show anything: coverage somewhere ([`CloudLayer::max_coverage`])
    /// and density both finite and above 0, and base and top finite with the top above the
    /// base. An invisible layer is not sent to the GPU.
    #[must_use]
    pub fn is_visible(&self) -> bool {
        let positive = |x: f32| x.is_finite() && x > 0.0;
        positive(self.max_coverage())
            && positive(self.density)
            && self.base_m.is_finite()
            && self.top_m.is_finite()
            && self.top_m > self.base_m
    }

    /// A cleaned copy that the renderer can trust; see [`CloudLayer::sanitize`] for the rules.
    #[must_use]
    pub fn sanitized(&self) -> Self {
        let mut clean = self.clone();
        clean.sanitize();
        clean
    }

    /// Cleans the layer in place so that the renderer can trust it. Each field is fixed as
    /// follows, and anything not listed is kept:
    ///
    /// - `coverage`: clamped to 0–1; NaN becomes the kind's default.
    /// - `density`: a non-finite value becomes the kind's default; a negative value becomes 0.
    /// - `base_m`, `top_m`: a non-finite value becomes the kind's default; if the base is then
    ///   above the top, the two are swapped. Negative altitudes are kept (a fog bank may reach
    ///   below the scene's ground level).
    /// - `weather_map_scale_m`: a non-finite or non-positive value becomes the kind's default (the
    ///   renderer divides by it).
    /// - `skew`: a non-finite value becomes the kind's default.
    /// - `wind_m_s`: a non-finite component becomes 0.
    /// - `shape_noise`: clamped to 0–1; NaN becomes 1 (the full shapes, the default).
    /// - `precipitation`: clamped to 0–1; NaN becomes 0.
    /// - `coverage_height`: clamped to 0–1; NaN becomes the kind's default.
    /// - `rain_mm_per_h`: a negative or NaN value becomes 0; +∞ is kept as `f32::MAX`.
    /// - `profile`: [`DensityProfile::sanitize`].
    /// - `far_coverage`: unusable entries ([`FarCoverage::is_usable`]) removed, coverages
    ///   clamped to 0–1.
    ///
    /// It does not allocate, so it can run on every layer every frame.
    pub fn sanitize(&mut self) {
        let defaults = self.kind.defaults();
        use crate::clean::{clamp_or, finite_or};
        let unit = |value: f32, nan: f32| clamp_or(value, 0.0, 1.0, nan);
        self.base_m = finite_or(self.base_m, defaults.base_m);
        self.top_m = finite_or(self.top_m, defaults.top_m);
        if self.base_m > self.top_m {
            std::mem::swap(&mut self.base_m, &mut self.top_m);
        }
        self.coverage = unit(self.coverage, defaults.coverage);
        self.density = if self.density.is_finite() {
            self.density.max(0.0)
        } else {
            defaults.density
        };
        if !(self.weather_map_scale_m.is_finite() && self.weather_map_scale_m > 0.0) {
            self.weather_map_scale_m = defaults.weather_map_scale_m;
        }
        self.wind_m_s = self.wind_m_s.map(|v| finite_or(v, 0.0));
        self.skew = finite_or(self.skew, defaults.skew);
        self.shape_noise = unit(self.shape_noise, 1.0);
        self.precipitation = unit(self.precipitation, 0.0);
        self.coverage_height = unit(self.coverage_height, defaults.coverage_height);
        self.rain_mm_per_h = if self.rain_mm_per_h > 0.0 {
            self.rain_mm_per_h.min(f32::MAX)
        } else {
            0.0
        };
        self.profile.sanitize();
        self.far_coverage.retain(FarCoverage::is_usable);
        for far in &mut self.far_coverage {
            far.coverage = far.coverage.clamp(0.0, 1.0);
        }
    }

    /// The relative density at `height_m` above the ground: the profile at the height's fraction
    /// of the way from base to top. Below the base, above the top, for a non-finite height or an
    /// invisible layer, it is 0.
    #[must_use]
    pub fn profile_at(&self, height_m: f32) -> f32 {
        if !self.is_visible() || !(self.base_m..=self.top_m).contains(&height_m) {
            return 0.0;
        }
        self.profile
            .evaluate((height_m - self.base_m) / self.thickness_m())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(profile: &DensityProfile, n: usize) -> Vec<f32> {
        (0..=n)
            .map(|i| profile.evaluate(i as f32 / n as f32))
            .collect()
    }

    #[test]
    fn every_kind_has_consistent_defaults() {
        for kind in CloudKind::ALL {
            let layer = CloudLayer::new(kind);
            let d = kind.defaults();
            assert_eq!(layer.kind, kind);
            assert!(layer.is_visible(), "{kind}");
            assert!(d.top_m > d.base_m && d.base_m >= 0.0, "{kind}");
            assert!((0.0..=1.0).contains(&d.coverage), "{kind}");
            assert!(d.density > 0.0 && d.weather_map_scale_m > 0.0, "{kind}");
            assert_eq!(layer.profile, DensityProfile::for_kind(kind));
            assert_eq!(
                layer.sanitized(),
                layer,
                "{kind}: defaults are already clean"
            );
            assert_eq!(
                (layer.precipitation, layer.rain_mm_per_h, layer.wind_m_s),
                (0.0, 0.0, [0.0, 0.0])
            );
            // Every profile fades to nothing at both ends of the layer and peaks high enough to
            // show: soft layer boundaries (Pérez Martín 2022's DensityAltering intent).
            let values = grid(&layer.profile, 100);
            assert_eq!(values[0], 0.0, "{kind}");
            assert_eq!(values[100], 0.0, "{kind}");
            assert!(values.iter().all(|v| (0.0..=1.0).contains(v)), "{kind}");
            assert!(values.iter().copied().fold(0.0, f32::max) >= 0.5, "{kind}");
        }
        assert_eq!(CloudLayer::default(), CloudLayer::new(CloudKind::Cumulus));
        assert_eq!(CloudKind::default(), CloudKind::Cumulus);
    }

    #[test]
    fn altitudes_follow_the_wmo_etages() {
        // Low étage: base below 2 km; middle: 2–7 km; high: 5–13 km (WMO-No. 407).
        for kind in CloudKind::ALL {
            let d = kind.defaults();
            match kind {
                CloudKind::Cumulus | CloudKind::Stratocumulus | CloudKind::Stratus => {
                    assert!(d.base_m < 2_000.0, "{kind}");
                }
                CloudKind::Altocumulus | CloudKind::Altostratus => {
                    assert!(d.base_m >= 2_000.0 && d.top_m <= 7_000.0, "{kind}");
                }
                CloudKind::Cirrus | CloudKind::Cirrostratus | CloudKind::Cirrocumulus => {
                    assert!(kind.is_cirrus_family());
                    assert!(d.base_m >= 5_000.0 && d.top_m <= 13_000.0, "{kind}");
                }
                CloudKind::Cumulonimbus => {
                    assert!(d.base_m < 2_000.0 && d.top_m >= 9_000.0, "{kind}");
                }
            }
        }
        let cirrus_family: Vec<_> = CloudKind::ALL
            .into_iter()
            .filter(|k| k.is_cirrus_family())
            .collect();
        assert_eq!(cirrus_family.len(), 3);
    }

    #[test]
    fn densities_follow_the_liquid_water_relation() {
        // σ = 3·LWC / (2·ρ·r_e) with the module docs' values, within 10 %.
        let sigma = |lwc_g_m3: f32, rho_kg_m3: f32, r_e_um: f32| {
            3.0 * lwc_g_m3 * 1e-3 / (2.0 * rho_kg_m3 * r_e_um * 1e-6)
        };
        let cases = [
            (CloudKind::Cumulus, sigma(0.5, 1000.0, 10.0)),
            (CloudKind::Stratocumulus, sigma(0.3, 1000.0, 9.0)),
            (CloudKind::Stratus, sigma(0.25, 1000.0, 9.0)),
            (CloudKind::Altocumulus, sigma(0.2, 1000.0, 10.0)),
            (CloudKind::Altostratus, sigma(0.1, 1000.0, 10.0)),
            (CloudKind::Cirrus, sigma(0.02, 917.0, 40.0)),
            (CloudKind::Cirrostratus, sigma(0.01, 917.0, 40.0)),
            (CloudKind::Cirrocumulus, sigma(0.03, 917.0, 30.0)),
            (CloudKind::Cumulonimbus, sigma(1.0, 1000.0, 15.0)),
        ];
        for (kind, expected) in cases {
            let density = kind.defaults().density;
            assert!(
                (density / expected - 1.0).abs() < 0.1,
                "{kind}: {density} vs {expected}"
            );
        }
    }

    #[test]
    fn cumulus_profile_has_a_rounded_base_and_a_tapering_top() {
        let cumulus = DensityProfile::cumulus();
        // Rises quickly from the base, with no kink at the points (smooth curve).
        assert_eq!(cumulus.evaluate(0.0), 0.0);
        assert!(cumulus.evaluate(0.07) > 0.6);
        assert!(cumulus.evaluate(0.035) > 0.0 && cumulus.evaluate(0.035) < 0.7);
        // Full density low in the layer, then monotonically thinner toward the top.
        let peak = cumulus.evaluate(0.2);
        assert_eq!(peak, 1.0);
        let upper = grid(&cumulus, 100);
        for pair in upper[55..].windows(2) {
            assert!(pair[1] <= pair[0] + 1e-6, "{pair:?}");
        }
        assert!(cumulus.evaluate(0.9) < 0.5 * peak);
    }

    #[test]
    fn stratus_is_a_flat_slab() {
        let stratus = DensityProfile::stratus();
        for i in 10..=90 {
            let value = stratus.evaluate(i as f32 / 100.0);
            assert!((value - 1.0).abs() < 1e-6, "{i}: {value}");
        }
        assert!(stratus.evaluate(0.05) > 0.0 && stratus.evaluate(0.05) < 1.0);
        // Thin: the kind's default is a few hundred metres.
        let d = CloudKind::Stratus.defaults();
        assert!(d.top_m - d.base_m <= 500.0);
    }

    #[test]
    fn cumulonimbus_stays_dense_to_an_anvil_top() {
        let cb = DensityProfile::cumulonimbus();
        let middle = cb.evaluate(0.5);
        // Density near the top is at least as high as in the middle: the anvil widens.
        for h in [0.8, 0.85, 0.9, 0.93, 0.95] {
            let value = cb.evaluate(h);
            assert!(value >= middle && value >= 0.85, "{h}: {value}");
        }
        // Dense from low down, too: a tall tower, not a heap.
        assert!(cb.evaluate(0.1) >= 0.9);
        // And its default layer is the tallest of all kinds.
        let depth = |k: CloudKind| k.defaults().top_m - k.defaults().base_m;
        assert!(
            CloudKind::ALL
                .into_iter()
                .all(|k| depth(k) <= depth(CloudKind::Cumulonimbus))
        );
    }

    #[test]
    fn cirrus_is_thin_and_wispy() {
        let cirrus = DensityProfile::cirrus();
        let peak = grid(&cirrus, 200).into_iter().fold(0.0, f32::max);
        assert!(peak <= 0.5 + 1e-6 && peak > 0.3, "{peak}");
        let d = CloudKind::Cirrus.defaults();
        assert!(d.density < 0.01 * CloudKind::Cumulus.defaults().density * 2.0);
        assert!(d.top_m - d.base_m <= 1_500.0);
    }

    #[test]
    fn smooth_profiles_never_overshoot_and_pass_through_their_points() {
        let profiles = CloudKind::ALL.map(DensityProfile::for_kind);
        for profile in &profiles {
            for point in &profile.points {
                assert!((profile.evaluate(point.height_fraction) - point.density).abs() < 1e-6);
            }
            // Between two points the smooth curve stays within their range (monotone cubic).
            for pair in profile.points.windows(2) {
                let (lo, hi) = (
                    pair[0].density.min(pair[1].density),
                    pair[0].density.max(pair[1].density),
                );
                for i in 1..50 {
                    let h = pair[0].height_fraction
                        + (pair[1].height_fraction - pair[0].height_fraction) * i as f32 / 50.0;
                    let value = profile.evaluate(h);
                    assert!(value >= lo - 1e-5 && value <= hi + 1e-5, "{h}: {value}");
                }
            }
        }
        // A steep step next to a gentle slope: a plain Catmull-Rom would overshoot here.
        let step = DensityProfile::new(
            [(0.0, 0.0), (0.45, 0.0), (0.55, 1.0), (1.0, 1.0)],
            ProfileInterpolation::Smooth,
        );
        for value in grid(&step, 400) {
            assert!((0.0..=1.0).contains(&value), "{value}");
        }
        for pair in grid(&step, 400).windows(2) {
            assert!(pair[1] >= pair[0] - 1e-6);
        }
    }

    #[test]
    fn linear_profiles_and_edge_cases() {
        let ramp = DensityProfile::new([(0.2, 0.0), (0.8, 1.0)], ProfileInterpolation::Linear);
        assert_eq!(ramp.evaluate(0.5), 0.5);
        // End values held beyond the points; out-of-range and NaN heights are clamped.
        assert_eq!(ramp.evaluate(0.1), 0.0);
        assert_eq!(ramp.evaluate(0.9), 1.0);
        assert_eq!(ramp.evaluate(-3.0), 0.0);
        assert_eq!(ramp.evaluate(7.0), 1.0);
        assert_eq!(ramp.evaluate(f32::NAN), 0.0);
        // No points: no shaping. One point: a constant.
        let empty = DensityProfile {
            points: Vec::new(),
            interpolation: ProfileInterpolation::Smooth,
        };
        assert_eq!(empty.evaluate(0.3), 1.0);
        let single = DensityProfile::new([(0.5, 0.25)], ProfileInterpolation::Smooth);
        assert_eq!(single.evaluate(0.0), 0.25);
        assert_eq!(single.evaluate(1.0), 0.25);
        // Two points at the same height make a step, without dividing by zero.
        let step = DensityProfile::new(
            [(0.0, 0.0), (0.5, 0.0), (0.5, 1.0), (1.0, 1.0)],
            ProfileInterpolation::Smooth,
        );
        assert_eq!(step.evaluate(0.25), 0.0);
        assert_eq!(step.evaluate(0.75), 1.0);
        assert!(step.evaluate(0.5).is_finite());
        assert_eq!(DensityProfile::default().evaluate(0.37), 1.0);
        assert_eq!(DensityProfile::uniform().evaluate(0.0), 1.0);
    }

    #[test]
    fn profiles_are_cleaned_and_hand_made_garbage_does_not_panic() {
        let messy = DensityProfile::new(
            [
                (0.9, 0.2),
                (f32::NAN, 1.0),
                (-1.0, 0.5),
                (0.4, 3.0),
                (0.5, f32::INFINITY),
            ],
            ProfileInterpolation::Linear,
        );
        assert_eq!(
            messy.points,
            vec![
                ProfilePoint::new(0.0, 0.5),
                ProfilePoint::new(0.4, 1.0),
                ProfilePoint::new(0.9, 0.2),
            ]
        );
        // Edited in place (as the inspector does) into something unsorted and non-finite.
        let mut raw = DensityProfile::cumulus();
        raw.points.push(ProfilePoint::new(0.3, f32::NAN));
        raw.points.push(ProfilePoint::new(f32::NAN, 0.3));
        raw.points.swap(0, 3);
        for interpolation in [ProfileInterpolation::Linear, ProfileInterpolation::Smooth] {
            raw.interpolation = interpolation;
            for value in grid(&raw, 100) {
                assert!((0.0..=1.0).contains(&value), "{value}");
            }
        }
        let clean = raw.sanitized();
        let mut in_place = raw.clone();
        in_place.sanitize();
        assert_eq!(in_place, clean);
        assert!(
            clean
                .points
                .windows(2)
                .all(|p| p[0].height_fraction <= p[1].height_fraction)
        );
        assert_eq!(clean.points.len(), DensityProfile::cumulus().points.len());
    }

    #[test]
    fn baking_samples_texel_centres() {
        let ramp = DensityProfile::new([(0.0, 0.0), (1.0, 1.0)], ProfileInterpolation::Linear);
        let mut table = [0.0; 4];
        ramp.bake(&mut table);
        assert_eq!(table, [0.125, 0.375, 0.625, 0.875]);
        let mut empty: [f32; 0] = [];
        ramp.bake(&mut empty);
        let mut cb = [0.0; 64];
        DensityProfile::cumulonimbus().bake(&mut cb);
        assert!(cb.iter().all(|v| (0.0..=1.0).contains(v)));
    }

    #[test]
    fn visibility_rules() {
        let visible = CloudLayer::new(CloudKind::Stratus);
        assert!(visible.is_visible());
        let with = |edit: fn(&mut CloudLayer)| {
            let mut layer = visible.clone();
            edit(&mut layer);
            layer.is_visible()
        };
        assert!(!with(|l| l.coverage = 0.0));
        assert!(!with(|l| l.density = 0.0));
        assert!(!with(|l| l.coverage = f32::NAN));
        assert!(!with(|l| l.density = f32::INFINITY));
        assert!(!with(|l| l.density = -1.0));
        assert!(!with(|l| l.top_m = l.base_m));
        assert!(!with(|l| l.top_m = l.base_m - 1.0));
        assert!(!with(|l| l.base_m = f32::NAN));
        assert!(!with(|l| l.top_m = f32::INFINITY));
        // Hand-set values that still make sense stay visible.
        assert!(with(|l| l.base_m = -50.0));
        assert!(with(|l| l.coverage = 1e-6));
    }

    /// A usable far place: 20 km east, half covered.
    fn far_place() -> FarCoverage {
        FarCoverage {
            from_m: [0.0, 0.0],
            to_m: [20_000.0, 0.0],
            coverage: 0.5,
        }
    }

    #[test]
    fn sanitizing_repairs_every_field() {
        let kind = CloudKind::Altocumulus;
        let d = kind.defaults();
        let mut layer = CloudLayer::new(kind);
        layer.coverage = 1.7;
        layer.precipitation = -0.5;
        layer.base_m = 4_000.0;
        layer.top_m = 3_200.0;
        layer.density = -0.2;
        layer.wind_m_s = [f32::NAN, 3.0];
        layer.rain_mm_per_h = -1.0;
        layer.weather_map_scale_m = 0.0;
        layer.coverage_height = 3.0;
        layer.shape_noise = -2.0;
        layer.far_coverage = vec![
            FarCoverage {
                coverage: 1.5,
                ..far_place()
            },
            FarCoverage {
                to_m: [f32::NAN, 0.0],
                ..far_place()
            },
        ];
        let clean = layer.sanitized();
        assert_eq!(clean.coverage, 1.0);
        assert_eq!(clean.shape_noise, 0.0);
        assert_eq!(
            clean.far_coverage,
            vec![FarCoverage {
                coverage: 1.0,
                ..far_place()
            }],
            "the unusable place dropped, the other's coverage clamped"
        );
        assert_eq!(clean.precipitation, 0.0);
        assert_eq!(clean.coverage_height, 1.0);
        assert_eq!((clean.base_m, clean.top_m), (3_200.0, 4_000.0));
        assert_eq!(clean.density, 0.0);
        assert_eq!(clean.wind_m_s, [0.0, 3.0]);
        assert_eq!(clean.rain_mm_per_h, 0.0);
        assert_eq!(clean.weather_map_scale_m, d.weather_map_scale_m);
        assert_eq!(clean.kind, kind);

        let mut nan = CloudLayer::new(kind);
        nan.coverage = f32::NAN;
        nan.density = f32::NAN;
        nan.base_m = f32::NAN;
        nan.top_m = f32::NEG_INFINITY;
        nan.skew = f32::NAN;
        nan.precipitation = f32::NAN;
        nan.coverage_height = f32::NAN;
        nan.rain_mm_per_h = f32::NAN;
        nan.weather_map_scale_m = f32::INFINITY;
        nan.shape_noise = f32::NAN;
        let clean = nan.sanitized();
        assert_eq!(clean, CloudLayer::new(kind));
        // The inverted default case: a NaN base replaced by a default above the given top.
        let mut low_top = CloudLayer::new(kind);
        low_top.base_m = f32::NAN;
        low_top.top_m = 100.0;
        let clean = low_top.sanitized();
        assert_eq!((clean.base_m, clean.top_m), (100.0, d.base_m));
        assert!(clean.is_visible());
        let mut infinite_rain = CloudLayer::new(kind);
        infinite_rain.rain_mm_per_h = f32::INFINITY;
        assert_eq!(infinite_rain.sanitized().rain_mm_per_h, f32::MAX);
    }

    #[test]
    fn profile_at_maps_heights_into_the_layer() {
        let mut layer = CloudLayer::new(CloudKind::Stratus);
        layer.base_m = 100.0;
        layer.top_m = 300.0;
        assert_eq!(layer.profile_at(200.0), 1.0);
        assert_eq!(layer.profile_at(50.0), 0.0);
        assert_eq!(layer.profile_at(350.0), 0.0);
        assert_eq!(layer.profile_at(f32::NAN), 0.0);
        assert_eq!(layer.thickness_m(), 200.0);
        layer.coverage = 0.0;
        assert_eq!(layer.profile_at(200.0), 0.0);
    }

    #[test]
    fn names() {
        assert_eq!(CloudKind::Cumulonimbus.to_string(), "cumulonimbus");
        let names: std::collections::HashSet<_> = CloudKind::ALL.iter().map(|k| k.name()).collect();
        assert_eq!(names.len(), CloudKind::ALL.len());
    }
}
