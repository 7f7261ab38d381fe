//! Smooth, retargetable changes of a layer and of the haze: [`LayerTransition`] and
//! [`HazeTransition`].
//!
//! Every value moves toward its target as a critically damped spring, `x'' = ω²(target − x) −
//! 2ωx'`, integrated exactly over each frame with the target held. The state of each value is its
//! position and its rate, so a new target picked mid-transition changes neither: value and first
//! derivative stay continuous (no kink), whatever the target does. With `D` the duration,
//! `ω = 6.64 / D`, so a step comes within 1 % of its target after `D` seconds.
//!
//! **Rate bound.** The spring's impulse response `ω²·t·e^(−ωt)` is positive and integrates to
//! 1, so a value never moves faster than its target: over a frame it changes by at most the
//! largest change of the target over one frame. For a step of size Δ (a preset picked, a time
//! jump) the fastest rate is `Δ·ω/e ≈ 2.44·Δ/D`.

use bevy::prelude::*;

use super::{CloudLayer, DensityProfile, Haze, KOSCHMIEDER_CONSTANT, ProfileInterpolation};
use crate::reference::render::MAX_PROFILE_POINTS;

/// `ω·D` for a step to come within 1 % of its target after the duration `D`: the root of
/// `(1 + x)·e^(−x) = 0.01`.
const OMEGA_DURATION: f32 = 6.638_352;

/// Default [`LayerTransition::duration_s`] and [`HazeTransition::duration_s`], seconds.
pub const DEFAULT_TRANSITION_S: f32 = 5.0;

/// Scalars of a layer that move, then the profile sampled where the renderer samples it.
const SCALARS: usize = 12;
const VALUES: usize = SCALARS + MAX_PROFILE_POINTS;

/// Moves a [`CloudLayer`] smoothly to [`LayerTransition::target`].
///
/// Put it beside a `CloudLayer` (the layers of [`spawn_weather_layers`] have one) and write the
/// target instead of the layer: the weather mapping, the presets and a game's own code all do.
/// Each update moves coverage, density, altitudes, coverage height, the weather-map period (as
/// its inverse), wind, skew, shape noise, precipitation, rain, the far coverages and the density
/// profile toward the target as a critically damped spring, `x'' = ω²(target − x) − 2ωx'` with
/// `ω = 6.64 / duration_s`, so a new target picked midway keeps each value and its rate
/// continuous. A change of kind morphs the profile and the kind's numbers, sampled at the
/// heights the renderer samples, so it never jumps; the layer takes the target's
/// [`CloudLayer::kind`] at once (the renderer reads only the numbers). When every value has
/// arrived, the layer becomes an exact copy of the target.
///
/// While a transition is present it owns the layer: edits to the `CloudLayer` itself are
/// overwritten on the next update. The first weather a slotted layer receives is a cut, so a
/// scene starts with its forecast's clouds instead of fading them in.
///
/// [`spawn_weather_layers`]: crate::weather::spawn_weather_layers
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component)]
pub struct LayerTransition {
    /// Where the layer is going. Cleaned with [`CloudLayer::sanitize`] before use.
    pub target: CloudLayer,
    /// Seconds of [`Time`] (Bevy's virtual time, not scene time) a change takes to come within
    /// 1 % of its target; 0 or less cuts straight to the target. Default
    /// [`DEFAULT_TRANSITION_S`].
    pub duration_s: f32,
    #[reflect(ignore)]
    velocity: [f32; VALUES],
    #[reflect(ignore)]
    far_velocity: Vec<f32>,
    /// Whether the weather mapping has written a target yet (its first is a cut).
    #[reflect(ignore)]
    pub(crate) has_weather: bool,
}

impl LayerTransition {
    /// A transition whose target is `layer` (nothing moves until the target changes), with the
    /// default duration.
    #[must_use]
    pub fn new(layer: CloudLayer) -> Self {
        Self {
            target: layer,
            duration_s: DEFAULT_TRANSITION_S,
            velocity: [0.0; VALUES],
            far_velocity: Vec::new(),
            has_weather: false,
        }
    }

    /// The same transition with `duration_s` seconds ([`LayerTransition::duration_s`]).
    #[must_use]
    pub fn with_duration(mut self, duration_s: f32) -> Self {
        self.duration_s = duration_s;
        self
    }

    /// Whether the layer is still moving: some value's rate is not 0.
    #[must_use]
    pub fn is_moving(&self) -> bool {
        self.velocity
            .iter()
            .chain(&self.far_velocity)
            .any(|v| *v != 0.0)
    }

    /// The rate of each moving value, per second, in the order of the scalars then the profile
    /// samples (for tests of continuity).
    #[cfg(test)]
    pub(crate) fn rates(&self) -> &[f32] {
        &self.velocity
    }

    /// Sets `layer` to the target at once, with every rate 0.
    pub fn cut(&mut self, layer: &mut CloudLayer) {
        *layer = self.target.sanitized();
        self.velocity = [0.0; VALUES];
        self.far_velocity.clear();
    }

    /// Moves `layer` toward the target over `dt_s` seconds.
    pub fn step(&mut self, layer: &mut CloudLayer, dt_s: f32) {
        let target = self.target.sanitized();
        if !(self.duration_s > 0.0 && self.duration_s.is_finite() && dt_s.is_finite()) {
            self.cut(layer);
            return;
        }
        if *layer == target && !self.is_moving() {
            return;
        }
        let omega = OMEGA_DURATION / self.duration_s;
        let goal = values(&target);
        let mut now = values(layer);
        let mut settled = springs(&mut now, &mut self.velocity, &goal, omega, dt_s);

        // Far coverages move when they describe the same places; anything else is a cut.
        let mut far = target.far_coverage.clone();
        if same_far_places(layer, &target) {
            self.far_velocity.resize(far.len(), 0.0);
            let mut x: Vec<f32> = layer.far_coverage.iter().map(|f| f.coverage).collect();
            let goal: Vec<f32> = far.iter().map(|f| f.coverage).collect();
            settled &= springs(&mut x, &mut self.far_velocity, &goal, omega, dt_s);
            for (entry, coverage) in far.iter_mut().zip(x) {
                entry.coverage = coverage.clamp(0.0, 1.0);
            }
        } else {
            self.far_velocity.clear();
        }

        if settled || now.iter().any(|v| !v.is_finite()) {
            self.cut(layer);
            return;
        }
        let profile_arrived = now[SCALARS..] == goal[SCALARS..];
        set_values(layer, &now, &target, profile_arrived);
        layer.far_coverage = far;
    }
}

impl Default for LayerTransition {
    fn default() -> Self {
        Self::new(CloudLayer::default())
    }
}

/// Moves the [`Haze`] smoothly to [`HazeTransition::target`], as [`LayerTransition`] moves a
/// layer: the extinction (`3.912 / visibility`, so clear air is 0), scale height, albedo and
/// asymmetry move; the target's `weather_driven` is taken at once.
///
/// The crate inserts it with no target, which leaves the haze alone. The weather mapping and the
/// presets set a target (the mapping's first is a cut); a game may too.
#[derive(Resource, Clone, Debug, Reflect)]
#[reflect(Resource)]
pub struct HazeTransition {
    /// Where the haze is going; `None` leaves it alone. Default `None`.
    pub target: Option<Haze>,
    /// Seconds of [`Time`] a change takes to come within 1 % of its target; 0 or less cuts.
    /// Default [`DEFAULT_TRANSITION_S`].
    pub duration_s: f32,
    #[reflect(ignore)]
    velocity: [f32; 4],
}

impl Default for HazeTransition {
    fn default() -> Self {
        Self {
            target: None,
            duration_s: DEFAULT_TRANSITION_S,
            velocity: [0.0; 4],
        }
    }
}

impl HazeTransition {
    /// Moves `haze` toward the target over `dt_s` seconds (nothing without a target).
    pub fn step(&mut self, haze: &mut Haze, dt_s: f32) {
        let Some(target) = self.target.clone() else {
            return;
        };
        let cut = |haze: &mut Haze, velocity: &mut [f32; 4]| {
            *haze = target.clone();
            *velocity = [0.0; 4];
        };
        if !(self.duration_s > 0.0 && self.duration_s.is_finite() && dt_s.is_finite()) {
            cut(haze, &mut self.velocity);
            return;
        }
        if *haze == target && self.velocity == [0.0; 4] {
            return;
        }
        let omega = OMEGA_DURATION / self.duration_s;
        let as_values = |h: &Haze| {
            let extinction = KOSCHMIEDER_CONSTANT / h.visibility_m;
            [
                if extinction.is_finite() {
                    extinction
                } else {
                    0.0
                },
                h.scale_height_m,
                h.albedo,
                h.asymmetry,
            ]
        };
        let goal = as_values(&target);
        let mut now = as_values(haze);
        if springs(&mut now, &mut self.velocity, &goal, omega, dt_s)
            || now.iter().any(|v| !v.is_finite())
        {
            cut(haze, &mut self.velocity);
            return;
        }
        *haze = Haze {
            visibility_m: KOSCHMIEDER_CONSTANT / now[0].max(0.0),
            scale_height_m: now[1],
            albedo: now[2],
            asymmetry: now[3],
            weather_driven: target.weather_driven,
        };
    }
}

/// One exact step of critically damped springs toward `goal` over `dt` with the goal held.
/// Returns whether every value has arrived (then the caller snaps to the goal).
fn springs(x: &mut [f32], v: &mut [f32], goal: &[f32], omega: f32, dt: f32) -> bool {
    let decay = (-omega * dt).exp();
    let mut settled = true;
    for ((x, v), goal) in x.iter_mut().zip(v.iter_mut()).zip(goal) {
        let e0 = *x - goal;
        let j = *v + omega * e0;
        *x = goal + (e0 + j * dt) * decay;
        *v = (*v - omega * j * dt) * decay;
        // Arrived: within a part in 10⁵ of the value and no longer moving by as much over a
        // duration.
        let tolerance = 1e-5 * goal.abs().max(x.abs()) + 1e-7;
        if (*x - goal).abs() > tolerance || v.abs() * (OMEGA_DURATION / omega) > tolerance {
            settled = false;
        }
    }
    settled
}

/// The moving values of `layer`: its scalars, then its profile at the renderer's sample heights.
fn values(layer: &CloudLayer) -> [f32; VALUES] {
    let mut out = [0.0; VALUES];
    out[..SCALARS].copy_from_slice(&[
        layer.coverage,
        layer.density,
        layer.base_m,
        layer.top_m,
        layer.coverage_height,
        1.0 / layer.weather_map_scale_m,
        layer.wind_m_s[0],
        layer.wind_m_s[1],
        layer.skew,
        layer.shape_noise,
        layer.precipitation,
        layer.rain_mm_per_h,
    ]);
    for (i, value) in out[SCALARS..].iter_mut().enumerate() {
        *value = layer.profile.evaluate(profile_height(i));
    }
    out
}

/// Whether the far coverages of `a` and `b` describe the same places, in the same order.
fn same_far_places(a: &CloudLayer, b: &CloudLayer) -> bool {
    a.far_coverage.len() == b.far_coverage.len()
        && a.far_coverage
            .iter()
            .zip(&b.far_coverage)
            .all(|(a, b)| a.from_m == b.from_m && a.to_m == b.to_m)
}

/// Height fraction of profile sample `i`: evenly spaced with both ends, as the renderer samples.
fn profile_height(i: usize) -> f32 {
    i as f32 / (MAX_PROFILE_POINTS - 1) as f32
}

/// Writes moving values into `layer`; the rest comes from `target`.
fn set_values(
    layer: &mut CloudLayer,
    v: &[f32; VALUES],
    target: &CloudLayer,
    profile_arrived: bool,
) {
    let unit = |x: f32| x.clamp(0.0, 1.0);
    layer.kind = target.kind;
    layer.coverage = unit(v[0]);
    layer.density = v[1].max(0.0);
    layer.base_m = v[2];
    layer.top_m = v[3].max(v[2]);
    layer.coverage_height = unit(v[4]);
    layer.weather_map_scale_m = if v[5] > 0.0 {
        1.0 / v[5]
    } else {
        target.weather_map_scale_m
    };
    layer.wind_m_s = [v[6], v[7]];
    layer.skew = v[8];
    layer.shape_noise = unit(v[9]);
    layer.precipitation = unit(v[10]);
    layer.rain_mm_per_h = v[11].max(0.0);
    layer.profile = if profile_arrived {
        target.profile.clone()
    } else {
        DensityProfile::new(
            v[SCALARS..]
                .iter()
                .enumerate()
                .map(|(i, d)| (profile_height(i), *d)),
            ProfileInterpolation::Linear,
        )
    };
}

impl CloudLayer {
    /// The layer a fraction `t` (0–1, clamped) of the way from `self` to `other`: every value
    /// [`LayerTransition`] moves is interpolated linearly (the weather-map period through its
    /// inverse, the profile at the renderer's sample heights), far coverages too when both
    /// describe the same places (else `other`'s); the kind is `self`'s below one half and
    /// `other`'s from there. `t = 0` gives `self` and `t = 1` gives `other` exactly, so a
    /// sequence of blends between consecutive states is continuous.
    #[must_use]
    pub fn lerp(&self, other: &Self, t: f32) -> Self {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        if t == 0.0 {
            return self.clone();
        }
        if t == 1.0 {
            return other.clone();
        }
        let (a, b) = (values(self), values(other));
        let mixed: [f32; VALUES] = std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t);
        let labels = if t < 0.5 { self } else { other };
        let mut out = other.clone();
        set_values(&mut out, &mixed, labels, self.profile == other.profile);
        if self.profile == other.profile {
            out.profile = other.profile.clone();
        }
        if same_far_places(self, other) {
            for (entry, from) in out.far_coverage.iter_mut().zip(&self.far_coverage) {
                entry.coverage = from.coverage + (entry.coverage - from.coverage) * t;
            }
        }
        out
    }
}

/// Steps every [`LayerTransition`] and the [`HazeTransition`] by the frame's [`Time`].
pub(crate) fn run_transitions(
    time: Res<Time>,
    mut layers: Query<(&mut CloudLayer, &mut LayerTransition)>,
    haze: Option<ResMut<Haze>>,
    haze_transition: Option<ResMut<HazeTransition>>,
) {
    let dt = time.delta_secs();
    for (mut layer, mut transition) in &mut layers {
        let transition = transition.bypass_change_detection();
        let mut next = layer.clone();
        transition.step(&mut next, dt);
        if next != *layer {
            *layer = next;
        }
    }
    if let (Some(mut haze), Some(mut transition)) = (haze, haze_transition) {
        let transition = transition.bypass_change_detection();
        let mut next = haze.clone();
        transition.step(&mut next, dt);
        if next != *haze {
            *haze = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layers::CloudKind;

    const DT: f32 = 1.0 / 60.0;

    #[test]
    fn a_step_arrives_within_one_percent_after_the_duration_and_never_overshoots() {
        let mut layer = CloudLayer::new(CloudKind::Cumulus);
        layer.coverage = 0.0;
        let mut transition = LayerTransition::new(layer.clone()).with_duration(2.0);
        transition.target.coverage = 1.0;
        let mut t = 0.0;
        let mut previous = 0.0;
        let mut fastest: f32 = 0.0;
        while t < 2.0 - 0.5 * DT {
            transition.step(&mut layer, DT);
            t += DT;
            assert!(layer.coverage >= previous, "monotone: {t}");
            fastest = fastest.max((layer.coverage - previous) / DT);
            previous = layer.coverage;
        }
        assert!((0.99..=1.0).contains(&layer.coverage), "{}", layer.coverage);
        // The fastest rate of a step is Δ·ω/e.
        let bound = OMEGA_DURATION / 2.0 / std::f32::consts::E;
        assert!(fastest <= bound * 1.001, "{fastest} > {bound}");
        // Sampled once a frame, the fastest frame's mean rate falls short of the peak by at
        // most |v''|·dt²/2 = (ω·dt)²/2 of it (v'' = −Δω³/e at the peak).
        let omega_dt = OMEGA_DURATION / 2.0 * DT;
        assert!(
            fastest >= bound * (1.0 - 0.5 * omega_dt * omega_dt),
            "{fastest} ≪ {bound}"
        );
        // Long after, it is exactly the target.
        for _ in 0..600 {
            transition.step(&mut layer, DT);
        }
        assert_eq!(layer, transition.target);
        assert!(!transition.is_moving());
    }

    #[test]
    fn retargeting_halfway_keeps_value_and_rate_continuous() {
        let start = CloudLayer::new(CloudKind::Cumulus);
        let first = CloudLayer::new(CloudKind::Altostratus);
        let second = CloudLayer::new(CloudKind::Stratus);
        let h = 1e-3;
        let mut layer = start.clone();
        let mut transition = LayerTransition::new(first).with_duration(1.0);
        // To halfway (in time) toward the first target.
        for _ in 0..500 {
            transition.step(&mut layer, h);
        }
        let before = values(&layer);
        let rate_before = transition.rates().to_vec();
        // Retarget and take one tiny step: the rate continues from where it was.
        transition.target = second.clone();
        let mut next = layer.clone();
        transition.step(&mut next, h);
        let after = values(&next);
        for i in 0..VALUES {
            let scale = before[i].abs().max(1e-3);
            let secant = (after[i] - before[i]) / h;
            // One step of h changes the rate by at most the acceleration · h; the acceleration is
            // bounded by ω²·|target − x| + 2ω·|v|.
            let gap = (values(&second)[i] - before[i]).abs();
            let accel = OMEGA_DURATION.powi(2) * gap + 2.0 * OMEGA_DURATION * rate_before[i].abs();
            assert!(
                (secant - rate_before[i]).abs() <= accel * h + 1e-3 * scale,
                "value {i}: rate {} before, {secant} after",
                rate_before[i]
            );
        }
        // The kind is a label the renderer does not read: it switches with the target.
        assert_eq!(next.kind, CloudKind::Stratus);
        // A jump in the rate would show up as a kink: the second difference around the retarget
        // is as small as the ones before it.
        let mut a = start.clone();
        let mut t =
            LayerTransition::new(CloudLayer::new(CloudKind::Altostratus)).with_duration(1.0);
        let mut history = Vec::new();
        for i in 0..1000 {
            if i == 500 {
                t.target = second.clone();
            }
            t.step(&mut a, h);
            history.push(a.base_m);
        }
        let second_difference = |i: usize| history[i + 1] - 2.0 * history[i] + history[i - 1];
        let kink = second_difference(499)
            .abs()
            .max(second_difference(500).abs());
        let accel_bound = OMEGA_DURATION.powi(2) * 5_000.0 * h * h;
        assert!(kink <= accel_bound, "kink {kink} > {accel_bound}");
    }

    #[test]
    fn a_kind_change_morphs_the_profile_without_a_jump() {
        let mut layer = CloudLayer::new(CloudKind::Cumulus);
        let mut transition = LayerTransition::new(CloudLayer::new(CloudKind::Stratus));
        let mut previous = values(&layer);
        let mut largest: f32 = 0.0;
        for _ in 0..2_000 {
            transition.step(&mut layer, DT);
            let now = values(&layer);
            for i in SCALARS..VALUES {
                largest = largest.max((now[i] - previous[i]).abs());
            }
            previous = now;
        }
        // Profile values are 0–1; a step of Δ ≤ 1 moves at most 2.44·Δ/D per second.
        let bound = OMEGA_DURATION / DEFAULT_TRANSITION_S / std::f32::consts::E * DT;
        assert!(
            largest > 0.0 && largest <= bound * 1.001,
            "{largest} vs {bound}"
        );
        assert_eq!(layer, CloudLayer::new(CloudKind::Stratus));
    }

    #[test]
    fn zero_duration_cuts_and_bad_targets_are_cleaned() {
        let mut layer = CloudLayer::new(CloudKind::Cumulus);
        let mut target = CloudLayer::new(CloudKind::Cirrus);
        target.coverage = f32::NAN;
        let mut transition = LayerTransition::new(target).with_duration(0.0);
        transition.step(&mut layer, DT);
        assert_eq!(layer, transition.target.sanitized());
        assert!(layer.coverage.is_finite());
        // A NaN duration is a cut too, never a NaN layer.
        transition.duration_s = f32::NAN;
        transition.target = CloudLayer::new(CloudKind::Stratus);
        transition.step(&mut layer, DT);
        assert_eq!(layer, CloudLayer::new(CloudKind::Stratus));
    }

    #[test]
    fn the_haze_moves_in_extinction_and_clears_to_infinity() {
        let mut haze = Haze::with_visibility(2_000.0);
        let mut transition = HazeTransition {
            target: Some(Haze::default()),
            ..default()
        };
        transition.step(&mut haze, 0.5);
        let extinction = KOSCHMIEDER_CONSTANT / haze.visibility_m;
        assert!(extinction > 0.0 && extinction < KOSCHMIEDER_CONSTANT / 2_000.0);
        for _ in 0..1_000 {
            transition.step(&mut haze, DT);
        }
        assert_eq!(haze, Haze::default());
        assert!(haze.visibility_m.is_infinite());
        // Without a target nothing moves.
        let mut idle = HazeTransition::default();
        let mut fixed = Haze::with_visibility(8_000.0);
        idle.step(&mut fixed, 1.0);
        assert_eq!(fixed, Haze::with_visibility(8_000.0));
    }
}
