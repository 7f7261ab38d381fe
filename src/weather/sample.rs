//! Sampling a [`Forecast`] at an instant into a [`WeatherState`]; [`Sampler`] documents the
//! interpolation rules.

use std::fmt;

use super::forecast::{Forecast, PressureLevel, Series, Variable};
use crate::scene::UtcInstant;

/// Default longest gap between valid values that sampling bridges: 3 hours, in seconds.
pub const DEFAULT_MAX_BRIDGE_S: f64 = 3.0 * 3600.0;

/// Pressure levels sampled into [`WeatherState::upper_air`], hPa: the levels that the format notes
/// map to cloud altitudes (850 hPa ≈ 1.5 km, 700 ≈ 3.0 km, 500 ≈ 5.6 km, 300 ≈ 9.2 km).
pub const STANDARD_LEVELS_HPA: [f32; 4] = [850.0, 700.0, 500.0, 300.0];

/// Which end of the data an instant was clamped to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DataEdge {
    /// Before the first time step: the first values are used.
    Start,
    /// After the last time step: the last values are used.
    End,
}

/// A small set of [`Variable`]s (a bit set; `Copy`, no allocation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct VariableSet(u32);

impl VariableSet {
    /// The empty set.
    pub const EMPTY: Self = Self(0);

    /// Adds `variable`.
    pub fn insert(&mut self, variable: Variable) {
        self.0 |= 1 << variable as u32;
    }

    /// Whether `variable` is in the set.
    #[must_use]
    pub const fn contains(self, variable: Variable) -> bool {
        self.0 & (1 << variable as u32) != 0
    }

    /// Whether the set is empty.
    #[must_use]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Number of variables in the set.
    #[must_use]
    pub const fn len(self) -> usize {
        self.0.count_ones() as usize
    }

    /// The variables in the set, in [`Variable::ALL`] order.
    pub fn iter(self) -> impl Iterator<Item = Variable> {
        Variable::ALL.into_iter().filter(move |&v| self.contains(v))
    }
}

impl fmt::Display for VariableSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, variable) in self.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            f.write_str(variable.name())?;
        }
        Ok(())
    }
}

/// Variables at one pressure level, sampled at an instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelState {
    /// The level's pressure, hPa.
    pub pressure_hpa: f32,
    /// Wind speed, m/s.
    pub wind_speed_m_s: Option<f32>,
    /// Direction the wind blows from, degrees clockwise from north.
    pub wind_direction_deg: Option<f32>,
    /// Geopotential height above sea level, m.
    pub height_m: Option<f32>,
    /// Cloud cover, fraction 0–1.
    pub cloud_cover: Option<f32>,
}

/// A [`Forecast`] sampled at one instant. `Copy`, so sampling never allocates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeatherState {
    /// The instant asked for (not clamped).
    pub time: UtcInstant,
    /// `Some` when [`WeatherState::time`] lies outside the data and the values are those of that
    /// end.
    pub clamped: Option<DataEdge>,
    /// Each [`Variable`] at this instant (index with `variable as usize`, or use [`Self::get`]),
    /// in [`Variable::sampled_unit`]: precipitation as mm/h, sunshine as a fraction of the time.
    /// `None` when the forecast lacks the variable or the value is in a long gap.
    pub values: [Option<f32>; Variable::COUNT],
    /// Variables whose value here was interpolated across `null` entries.
    pub bridged: VariableSet,
    /// Variables the forecast has but which have no value here (a gap longer than
    /// [`Sampler::max_bridge_s`], or `null` at the clamped end).
    pub missing: VariableSet,
    /// meteoblue pictocode of the nearest time step.
    pub pictocode: Option<u8>,
    /// WMO weather code of the nearest time step (Open-Meteo).
    pub wmo_weather_code: Option<u8>,
    /// Daylight flag of the nearest time step.
    pub is_daylight: Option<bool>,
    /// Wind, height and cover at [`STANDARD_LEVELS_HPA`], where the forecast has those levels.
    pub upper_air: [Option<LevelState>; STANDARD_LEVELS_HPA.len()],
}

impl WeatherState {
    /// A state with no values at `time`.
    #[must_use]
    pub const fn empty(time: UtcInstant) -> Self {
        Self {
            time,
            clamped: None,
            values: [None; Variable::COUNT],
            bridged: VariableSet::EMPTY,
            missing: VariableSet::EMPTY,
            pictocode: None,
            wmo_weather_code: None,
            is_daylight: None,
            upper_air: [None; STANDARD_LEVELS_HPA.len()],
        }
    }

    /// The value of `variable`, in [`Variable::sampled_unit`].
    #[must_use]
    pub const fn get(&self, variable: Variable) -> Option<f32> {
        self.values[variable as usize]
    }

    /// Total cloud cover, fraction 0–1.
    #[must_use]
    pub const fn total_cover(&self) -> Option<f32> {
        self.get(Variable::TotalCover)
    }

    /// Low cloud cover, fraction 0–1.
    #[must_use]
    pub const fn low_cover(&self) -> Option<f32> {
        self.get(Variable::LowCover)
    }

    /// Mid-level cloud cover, fraction 0–1.
    #[must_use]
    pub const fn mid_cover(&self) -> Option<f32> {
        self.get(Variable::MidCover)
    }

    /// High cloud cover, fraction 0–1.
    #[must_use]
    pub const fn high_cover(&self) -> Option<f32> {
        self.get(Variable::HighCover)
    }

    /// Precipitation rate, mm/h.
    #[must_use]
    pub const fn precipitation_mm_per_h(&self) -> Option<f32> {
        self.get(Variable::Precipitation)
    }

    /// Convective (shower) precipitation rate, mm/h.
    #[must_use]
    pub const fn convective_precipitation_mm_per_h(&self) -> Option<f32> {
        self.get(Variable::ConvectivePrecipitation)
    }

    /// Wind speed at 10 m, m/s.
    #[must_use]
    pub const fn wind_speed_m_s(&self) -> Option<f32> {
        self.get(Variable::WindSpeed)
    }

    /// Direction the 10 m wind blows from, degrees clockwise from north, [0, 360).
    #[must_use]
    pub const fn wind_direction_deg(&self) -> Option<f32> {
        self.get(Variable::WindDirection)
    }

    /// The 10 m wind as a velocity `[east, north]` in m/s: where the air moves TO (opposite to the
    /// meteorological "from" direction).
    #[must_use]
    pub fn wind_velocity_m_s(&self) -> Option<[f32; 2]> {
        let speed = self.wind_speed_m_s()?;
        let from = self.wind_direction_deg()?.to_radians();
        Some([-speed * from.sin(), -speed * from.cos()])
    }

    /// Air temperature at 2 m, °C.
    #[must_use]
    pub const fn temperature_c(&self) -> Option<f32> {
        self.get(Variable::Temperature)
    }

    /// Visibility, m.
    #[must_use]
    pub const fn visibility_m(&self) -> Option<f32> {
        self.get(Variable::Visibility)
    }

    /// Fog probability, fraction 0–1.
    #[must_use]
    pub const fn fog_probability(&self) -> Option<f32> {
        self.get(Variable::FogProbability)
    }

    /// The sampled pressure level at `pressure_hpa` (one of [`STANDARD_LEVELS_HPA`]).
    #[must_use]
    pub fn level(&self, pressure_hpa: f32) -> Option<&LevelState> {
        self.upper_air
            .iter()
            .flatten()
            .find(|level| (level.pressure_hpa - pressure_hpa).abs() < 0.5)
    }
}

/// Something a caller should tell the user once, from [`Sampler::take_warning`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SampleWarning {
    /// The instant lies outside the forecast; the values of the nearest end are held.
    OutsideData {
        /// The end that is held.
        edge: DataEdge,
        /// The instant asked for.
        requested: UtcInstant,
        /// First instant with data.
        start: UtcInstant,
        /// Last instant with data.
        end: UtcInstant,
    },
    /// Variables with no value because of a gap longer than [`Sampler::max_bridge_s`].
    Gap {
        /// The instant asked for.
        at: UtcInstant,
        /// The variables without a value.
        missing: VariableSet,
    },
}

impl fmt::Display for SampleWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::OutsideData {
                edge: DataEdge::Start,
                requested,
                start,
                ..
            } => write!(
                f,
                "{requested} is before the forecast starts ({start}); using its first values"
            ),
            Self::OutsideData {
                edge: DataEdge::End,
                requested,
                end,
                ..
            } => write!(
                f,
                "{requested} is after the forecast ends ({end}); using its last values"
            ),
            Self::Gap { at, missing } => {
                write!(f, "no data for {missing} at {at} (gap too long to bridge)")
            }
        }
    }
}

/// Samples [`Forecast`]s at instants, remembering where it last looked (so successive frames cost
/// O(1)) and which warnings it already gave.
///
/// - Linear in time between the two surrounding steps (Thomann 2021 §6.5, Listing 9: "the weather
///   data is interpolated from hour to hour").
/// - Wind direction is interpolated as a vector, so 350° → 10° passes through 0°, not 180°. The
///   vectors are weighted by wind speed, so a calm step does not drag the direction; the speed
///   itself is interpolated as a scalar, so a turning wind keeps its strength.
/// - Amounts over the preceding step (precipitation, sunshine; format notes: "a value stamped
///   14:00 covers 13:00–14:00") become a mean rate per step, placed at the middle of its step, and
///   rates are interpolated linearly between step middles. At 13:30 the rate is exactly the
///   13:00–14:00 amount per hour; the rate is continuous, so rain does not jump on the hour.
/// - `null` values are gaps: when the valid values on either side are at most
///   [`Sampler::max_bridge_s`] apart (default 3 h) the gap is bridged linearly and reported in
///   [`WeatherState::bridged`]; otherwise the value is `None` and reported in
///   [`WeatherState::missing`]. Nothing becomes a silent zero.
/// - Instants outside the data are clamped to the nearest end and flagged in
///   [`WeatherState::clamped`]; [`Sampler::take_warning`] yields a warning once per excursion, not
///   once per frame.
/// - [`Sampler`] caches the last step index, so sampling successive frames is O(1) and any jump is
///   a binary search, O(log n). No sample allocates: [`WeatherState`] is `Copy`.
///
/// Use one sampler per forecast you sample every frame. The cached position is only a hint: a
/// sampler stays correct when handed a different or reloaded forecast.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampler {
    /// Longest span between valid values, in seconds, that a `null` gap is bridged across.
    /// Default [`DEFAULT_MAX_BRIDGE_S`] (3 h).
    pub max_bridge_s: f64,
    cursor: usize,
    warned_edge: Option<DataEdge>,
    warned_missing: VariableSet,
    pending_edge: Option<SampleWarning>,
    pending_gap: Option<SampleWarning>,
}

impl Default for Sampler {
    fn default() -> Self {
        Self::new()
    }
}

impl Forecast {
    /// Samples at `at` without a [`Sampler`] (a binary search per call, no warnings kept).
    #[must_use]
    pub fn sample(&self, at: UtcInstant) -> WeatherState {
        Sampler::new().sample(self, at)
    }
}

impl Sampler {
    /// A sampler bridging gaps of up to [`DEFAULT_MAX_BRIDGE_S`].
    #[must_use]
    pub const fn new() -> Self {
        Self {
            max_bridge_s: DEFAULT_MAX_BRIDGE_S,
            cursor: 0,
            warned_edge: None,
            warned_missing: VariableSet::EMPTY,
            pending_edge: None,
            pending_gap: None,
        }
    }

    /// A sampler bridging gaps of up to `max_bridge_s` seconds (0 disables bridging).
    #[must_use]
    pub const fn with_max_bridge_s(max_bridge_s: f64) -> Self {
        let mut sampler = Self::new();
        sampler.max_bridge_s = max_bridge_s;
        sampler
    }

    /// Forgets the cached position and the warnings already given.
    pub fn reset(&mut self) {
        *self = Self::with_max_bridge_s(self.max_bridge_s);
    }

    /// The next warning to show the user, if any; each is returned once. Call after sampling.
    ///
    /// An [`SampleWarning::OutsideData`] is raised when sampling leaves the data (and again only
    /// after it has come back inside); a [`SampleWarning::Gap`] when the set of missing variables
    /// changes to a new non-empty set.
    pub fn take_warning(&mut self) -> Option<SampleWarning> {
        self.pending_edge.take().or_else(|| self.pending_gap.take())
    }

    /// The forecast at `at`, by the rules in the [`Sampler`] docs.
    pub fn sample(&mut self, forecast: &Forecast, at: UtcInstant) -> WeatherState {
        self.sample_impl(forecast, at.unix_seconds() as f64, at)
    }

    /// The forecast at a fractional Unix time in seconds (for smooth animation between whole
    /// seconds). A NaN time samples the first step.
    pub fn sample_unix_seconds(&mut self, forecast: &Forecast, unix_seconds: f64) -> WeatherState {
        let whole = if unix_seconds.is_finite() {
            unix_seconds.floor() as i64
        } else {
            0
        };
        self.sample_impl(forecast, unix_seconds, UtcInstant::from_unix_seconds(whole))
    }

    /// Samples `forecast.pressure_levels[level_index]` at `at` (any level, not only
    /// [`STANDARD_LEVELS_HPA`]); `None` for an index out of range or an empty forecast.
    pub fn sample_level(
        &mut self,
        forecast: &Forecast,
        level_index: usize,
        at: UtcInstant,
    ) -> Option<LevelState> {
        let level = forecast.pressure_levels.get(level_index)?;
        let (position, _) = self.position(&forecast.times, at.unix_seconds() as f64)?;
        Some(sample_level_at(level, &position, self.max_bridge_s))
    }

    /// Clamps `t` into the data and finds its step; `None` for an empty forecast.
    fn position<'a>(
        &mut self,
        times: &'a [UtcInstant],
        t: f64,
    ) -> Option<(Position<'a>, Option<DataEdge>)> {
        let first = seconds(*times.first()?);
        let last = seconds(*times.last()?);
        let (t, edge) = if t.is_nan() {
            (first, None)
        } else if t < first {
            (first, Some(DataEdge::Start))
        } else if t > last {
            (last, Some(DataEdge::End))
        } else {
            (t, None)
        };
        let index = locate(times, t, self.cursor);
        self.cursor = index;
        Some((Position { times, t, index }, edge))
    }

    fn sample_impl(&mut self, forecast: &Forecast, t: f64, at: UtcInstant) -> WeatherState {
        let mut state = WeatherState::empty(at);
        let Some((position, edge)) = self.position(&forecast.times, t) else {
            return state;
        };
        state.clamped = edge;
        let max_bridge = self.max_bridge_s;
        let speed = forecast.series(Variable::WindSpeed);

        for variable in Variable::ALL {
            let Some(series) = forecast.series(variable) else {
                continue;
            };
            let sampled = if variable == Variable::WindDirection {
                sample_direction(series, speed, &position, max_bridge)
            } else if variable.is_preceding_step_amount() {
                // Mean rate over each step: mm per hour, or the sunny fraction of the step.
                let per = if variable == Variable::SunshineDuration {
                    1.0
                } else {
                    3600.0
                };
                sample_rate(series, per, &position, max_bridge)
            } else {
                sample_scalar(series, &position, max_bridge)
            };
            match sampled {
                Some((value, bridged)) => {
                    state.values[variable as usize] = Some(value);
                    if bridged {
                        state.bridged.insert(variable);
                    }
                }
                None => state.missing.insert(variable),
            }
        }

        state.pictocode = sample_nearest(forecast.pictocode.as_deref(), &position, max_bridge);
        state.wmo_weather_code =
            sample_nearest(forecast.wmo_weather_code.as_deref(), &position, max_bridge);
        state.is_daylight = sample_nearest(forecast.is_daylight.as_deref(), &position, max_bridge);
        for (slot, pressure) in state.upper_air.iter_mut().zip(STANDARD_LEVELS_HPA) {
            *slot = forecast
                .pressure_level(pressure)
                .map(|level| sample_level_at(level, &position, max_bridge));
        }

        self.note_warnings(forecast, &state);
        state
    }

    fn note_warnings(&mut self, forecast: &Forecast, state: &WeatherState) {
        if state.clamped != self.warned_edge {
            self.warned_edge = state.clamped;
            self.pending_edge = match (state.clamped, forecast.start(), forecast.end()) {
                (Some(edge), Some(start), Some(end)) => Some(SampleWarning::OutsideData {
                    edge,
                    requested: state.time,
                    start,
                    end,
                }),
                _ => None,
            };
        }
        if state.missing != self.warned_missing {
            self.warned_missing = state.missing;
            self.pending_gap = (!state.missing.is_empty()).then_some(SampleWarning::Gap {
                at: state.time,
                missing: state.missing,
            });
        }
    }
}

fn seconds(instant: UtcInstant) -> f64 {
    instant.unix_seconds() as f64
}

/// The step index `i` with `times[i] <= t < times[i + 1]` (the last index when `t` is at the end),
/// trying the cached `hint` and its successor before a binary search.
fn locate(times: &[UtcInstant], t: f64, hint: usize) -> usize {
    let n = times.len();
    let fits = |i: usize| seconds(times[i]) <= t && (i + 1 == n || t < seconds(times[i + 1]));
    if hint < n && fits(hint) {
        return hint;
    }
    if hint + 1 < n && fits(hint + 1) {
        return hint + 1;
    }
    times
        .partition_point(|&time| seconds(time) <= t)
        .saturating_sub(1)
}

/// A clamped instant and its step in a forecast's time axis.
struct Position<'a> {
    times: &'a [UtcInstant],
    /// Clamped time, Unix seconds.
    t: f64,
    /// `times[index] <= t < times[index + 1]`.
    index: usize,
}

impl Position<'_> {
    fn len(&self) -> usize {
        self.times.len()
    }

    /// Length of the step that ends at `i`, seconds; the first step is taken to be as long as
    /// the second (its start is not in the file), a lone step as one hour.
    fn step_s(&self, i: usize) -> f64 {
        let n = self.len();
        if n < 2 {
            3600.0
        } else if i == 0 {
            seconds(self.times[1]) - seconds(self.times[0])
        } else {
            seconds(self.times[i]) - seconds(self.times[i - 1])
        }
    }
}

/// The axis a series is interpolated along.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Axis {
    /// Values stand at the time stamps.
    Instants,
    /// Values are means over the step ending at the stamp and stand at the step's middle.
    StepMiddles,
}

impl Axis {
    fn at(self, position: &Position, i: usize) -> f64 {
        let stamp = seconds(position.times[i]);
        match self {
            Self::Instants => stamp,
            Self::StepMiddles => stamp - 0.5 * position.step_s(i),
        }
    }

    /// The two neighbouring indices around `position.t` on this axis and the weight of the upper.
    fn bracket(self, position: &Position) -> (usize, usize, f64) {
        let n = position.len();
        let t = position.t;
        let lower = match self {
            Self::Instants => position.index,
            // The step middle after stamp `index` may already lie behind `t`.
            Self::StepMiddles => {
                let next = position.index + 1;
                if next < n && t >= self.at(position, next) {
                    next
                } else {
                    position.index
                }
            }
        };
        let upper = (lower + 1).min(n - 1);
        (lower, upper, self.weight(position, lower, upper))
    }

    fn weight(self, position: &Position, lower: usize, upper: usize) -> f64 {
        let (a, b) = (self.at(position, lower), self.at(position, upper));
        if b > a {
            ((position.t - a) / (b - a)).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// Which samples a value is made from.
enum Support {
    /// Exactly one sample.
    At(usize),
    /// `lower` and `upper` with the upper's `weight`; `bridged` when a gap lies between.
    Between {
        lower: usize,
        upper: usize,
        weight: f64,
        bridged: bool,
    },
}

/// Finds the samples to interpolate from, stepping over invalid (`null`) samples as long as the
/// valid ones on either side are at most `max_bridge` seconds apart. `None`: a gap too long.
fn support(
    axis: Axis,
    position: &Position,
    valid: impl Fn(usize) -> bool,
    max_bridge: f64,
) -> Option<Support> {
    let (lower, upper, weight) = axis.bracket(position);
    let (lower_valid, upper_valid) = (valid(lower), valid(upper));
    if lower_valid && (weight == 0.0 || lower == upper) {
        return Some(Support::At(lower));
    }
    if upper_valid && weight == 1.0 {
        return Some(Support::At(upper));
    }
    if lower_valid && upper_valid {
        return Some(Support::Between {
            lower,
            upper,
            weight,
            bridged: false,
        });
    }

    // A gap: search outwards, but never further than the bridge allows (bounded work).
    let t = position.t;
    let n = position.len();
    let mut before = lower;
    while !valid(before) {
        before = before.checked_sub(1)?;
        if t - axis.at(position, before) > max_bridge {
            return None;
        }
    }
    let mut after = if upper == lower { upper + 1 } else { upper };
    loop {
        if after >= n || axis.at(position, after) - t > max_bridge {
            return None;
        }
        if valid(after) {
            break;
        }
        after += 1;
    }
    let (a, b) = (axis.at(position, before), axis.at(position, after));
    if b - a > max_bridge || b <= a {
        return None;
    }
    Some(Support::Between {
        lower: before,
        upper: after,
        weight: ((t - a) / (b - a)).clamp(0.0, 1.0),
        bridged: true,
    })
}

fn value(series: &[Option<f32>], i: usize) -> Option<f32> {
    series.get(i).copied().flatten()
}

fn lerp(a: f64, b: f64, weight: f64) -> f64 {
    a + (b - a) * weight
}

/// Linear interpolation of a plain series; `(value, bridged)`.
fn sample_scalar(
    series: &[Option<f32>],
    position: &Position,
    max_bridge: f64,
) -> Option<(f32, bool)> {
    let valid = |i| value(series, i).is_some();
    let get = |i| f64::from(value(series, i).unwrap_or_default());
    match support(Axis::Instants, position, valid, max_bridge)? {
        Support::At(i) => Some((get(i) as f32, false)),
        Support::Between {
            lower,
            upper,
            weight,
            bridged,
        } => Some((lerp(get(lower), get(upper), weight) as f32, bridged)),
    }
}

/// Rates from amounts over the preceding step: `amount / step * per` (per = 3600 gives mm/h),
/// interpolated between step middles.
fn sample_rate(
    series: &[Option<f32>],
    per: f64,
    position: &Position,
    max_bridge: f64,
) -> Option<(f32, bool)> {
    let valid = |i| value(series, i).is_some() && position.step_s(i) > 0.0;
    let rate = |i| f64::from(value(series, i).unwrap_or_default()) / position.step_s(i) * per;
    match support(Axis::StepMiddles, position, valid, max_bridge)? {
        Support::At(i) => Some((rate(i) as f32, false)),
        Support::Between {
            lower,
            upper,
            weight,
            bridged,
        } => Some((lerp(rate(lower), rate(upper), weight) as f32, bridged)),
    }
}

/// Direction (degrees, "from") interpolated as a vector weighted by `speed` where known, so that
/// 350° → 10° passes through 0°.
fn sample_direction(
    directions: &[Option<f32>],
    speed: Option<&[Option<f32>]>,
    position: &Position,
    max_bridge: f64,
) -> Option<(f32, bool)> {
    let valid = |i| value(directions, i).is_some();
    let (lower, upper, weight, bridged) =
        match support(Axis::Instants, position, valid, max_bridge)? {
            Support::At(i) => return Some((value(directions, i)?, false)),
            Support::Between {
                lower,
                upper,
                weight,
                bridged,
            } => (lower, upper, weight, bridged),
        };
    let unit = |i: usize| {
        let radians = f64::from(value(directions, i).unwrap_or_default()).to_radians();
        (radians.sin(), radians.cos())
    };
    let speed_at = |i| {
        speed
            .and_then(|speed| value(speed, i))
            .map_or(1.0, |s| f64::from(s).max(0.0))
    };
    let blend = |wa: f64, wb: f64| {
        let ((ax, ay), (bx, by)) = (unit(lower), unit(upper));
        let x = lerp(ax * wa, bx * wb, weight);
        let y = lerp(ay * wa, by * wb, weight);
        (x, y, x.hypot(y))
    };
    // Speed-weighted first; if that cancels (calm, or exactly opposite winds), plain unit vectors;
    // if those cancel too (exactly opposite), the nearer sample's direction.
    let (mut x, mut y, mut length) = blend(speed_at(lower), speed_at(upper));
    if length < 1e-6 {
        (x, y, length) = blend(1.0, 1.0);
    }
    if length < 1e-6 {
        let nearest = if weight < 0.5 { lower } else { upper };
        return Some((value(directions, nearest)?, bridged));
    }
    let degrees = x.atan2(y).to_degrees().rem_euclid(360.0) as f32;
    // Rounding can give exactly 360.0 in f32.
    Some((if degrees >= 360.0 { 0.0 } else { degrees }, bridged))
}

/// The value of the nearest valid sample (codes and flags do not interpolate).
fn sample_nearest<T: Copy>(
    series: Option<&[Option<T>]>,
    position: &Position,
    max_bridge: f64,
) -> Option<T> {
    let series = series?;
    let get = |i: usize| series.get(i).copied().flatten();
    match support(Axis::Instants, position, |i| get(i).is_some(), max_bridge)? {
        Support::At(i) => get(i),
        Support::Between {
            lower,
            upper,
            weight,
            ..
        } => get(if weight < 0.5 { lower } else { upper }),
    }
}

fn sample_level_at(level: &PressureLevel, position: &Position, max_bridge: f64) -> LevelState {
    let scalar = |series: &Option<Series>| {
        series
            .as_deref()
            .and_then(|series| sample_scalar(series, position, max_bridge))
            .map(|(value, _)| value)
    };
    LevelState {
        pressure_hpa: level.pressure_hpa,
        wind_speed_m_s: scalar(&level.wind_speed_m_s),
        wind_direction_deg: level.wind_direction_deg.as_deref().and_then(|directions| {
            sample_direction(
                directions,
                level.wind_speed_m_s.as_deref(),
                position,
                max_bridge,
            )
            .map(|(value, _)| value)
        }),
        height_m: scalar(&level.height_m),
        cloud_cover: scalar(&level.cloud_cover),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Place;

    const HOUR: i64 = 3600;
    const T0: i64 = 1_620_000_000; // 2021-05-03T00:00:00Z

    fn at(seconds_after_t0: i64) -> UtcInstant {
        UtcInstant::from_unix_seconds(T0 + seconds_after_t0)
    }

    /// An hourly forecast built in code with the given series.
    fn hourly(steps: usize, series: &[(Variable, Vec<Option<f32>>)]) -> Forecast {
        let times = (0..steps as i64).map(|i| at(i * HOUR)).collect();
        let mut forecast = Forecast::new(Place::default(), times);
        for (variable, values) in series {
            forecast.series[*variable as usize] = Some(values.clone());
        }
        forecast
    }

    fn some(values: &[f32]) -> Vec<Option<f32>> {
        values.iter().copied().map(Some).collect()
    }

    /// The midpoint of two stored `f32` values, as sampling computes it (in `f64`).
    fn midpoint(a: f32, b: f32) -> f32 {
        f64::midpoint(f64::from(a), f64::from(b)) as f32
    }

    #[test]
    fn half_hour_values_are_exact_midpoints() {
        let forecast = hourly(
            3,
            &[
                (Variable::LowCover, some(&[0.2, 0.6, 0.1])),
                (Variable::Temperature, some(&[10.0, 13.0, 12.0])),
            ],
        );
        let mut sampler = Sampler::new();
        let state = sampler.sample(&forecast, at(HOUR / 2));
        assert_eq!(state.low_cover(), Some(midpoint(0.2, 0.6)));
        assert_eq!(state.temperature_c(), Some(11.5));
        let state = sampler.sample(&forecast, at(HOUR + HOUR / 2));
        assert_eq!(state.low_cover(), Some(midpoint(0.6, 0.1)));
        assert_eq!(state.temperature_c(), Some(12.5));
        // On a stamp the value is the stamp's.
        assert_eq!(sampler.sample(&forecast, at(HOUR)).low_cover(), Some(0.6));
        assert!(state.bridged.is_empty() && state.missing.is_empty() && state.clamped.is_none());
    }

    #[test]
    fn half_hours_of_the_bundled_forecast_are_midpoints() {
        let forecast =
            Forecast::from_slice(include_bytes!("../../assets/weather/bern.json"), None).unwrap();
        let mut sampler = Sampler::new();
        for i in 0..forecast.len() - 1 {
            let middle = forecast.times[i].saturating_add_seconds(HOUR / 2);
            let state = sampler.sample(&forecast, middle);
            for variable in [
                Variable::LowCover,
                Variable::MidCover,
                Variable::HighCover,
                Variable::Temperature,
            ] {
                let series = forecast.series(variable).unwrap();
                let expected = f64::midpoint(
                    f64::from(series[i].unwrap()),
                    f64::from(series[i + 1].unwrap()),
                );
                assert!(
                    (f64::from(state.get(variable).unwrap()) - expected).abs() < 1e-5,
                    "{variable:?} at {middle}"
                );
            }
        }
    }

    #[test]
    fn wind_turns_through_north_not_south() {
        let forecast = hourly(
            2,
            &[
                (Variable::WindSpeed, some(&[5.0, 5.0])),
                (Variable::WindDirection, some(&[350.0, 10.0])),
            ],
        );
        let direction = |seconds| forecast.sample(at(seconds)).wind_direction_deg().unwrap();
        let angular_error = |a: f32, b: f32| ((a - b + 180.0).rem_euclid(360.0) - 180.0).abs();
        assert!(
            angular_error(direction(HOUR / 2), 0.0) < 1e-3,
            "{}",
            direction(HOUR / 2)
        );
        // A quarter of the way is close to (not exactly) a quarter of the angle: vectors, not angles,
        // are interpolated.
        assert!(
            angular_error(direction(HOUR / 4), 355.0) < 0.1,
            "{}",
            direction(HOUR / 4)
        );
        assert!(
            angular_error(direction(3 * HOUR / 4), 5.0) < 0.1,
            "{}",
            direction(3 * HOUR / 4)
        );
        // The speed is interpolated as a scalar: the turn does not weaken the wind.
        assert_eq!(forecast.sample(at(HOUR / 2)).wind_speed_m_s(), Some(5.0));
        for step in 0..=60 {
            let d = direction(step * 60);
            assert!(
                (0.0..360.0).contains(&d) && (d >= 349.9 || d <= 10.1),
                "{d}"
            );
        }

        // The other way round, 10° → 350°, also passes through north.
        let back = hourly(
            2,
            &[
                (Variable::WindSpeed, some(&[5.0, 5.0])),
                (Variable::WindDirection, some(&[10.0, 350.0])),
            ],
        );
        let d = back.sample(at(HOUR / 2)).wind_direction_deg().unwrap();
        assert!(angular_error(d, 0.0) < 1e-3, "{d}");
    }

    #[test]
    fn calm_and_opposite_winds_keep_a_sensible_direction() {
        // A calm step does not drag the direction: it is the other step's.
        let calm = hourly(
            2,
            &[
                (Variable::WindSpeed, some(&[0.0, 4.0])),
                (Variable::WindDirection, some(&[90.0, 270.0])),
            ],
        );
        let state = calm.sample(at(HOUR / 2));
        assert!((state.wind_direction_deg().unwrap() - 270.0).abs() < 1e-3);
        assert_eq!(state.wind_speed_m_s(), Some(2.0));
        // Exactly opposite equal winds cancel: the nearer step's direction is held.
        let opposite = hourly(
            2,
            &[
                (Variable::WindSpeed, some(&[3.0, 3.0])),
                (Variable::WindDirection, some(&[90.0, 270.0])),
            ],
        );
        assert_eq!(
            opposite.sample(at(HOUR / 2 - 1)).wind_direction_deg(),
            Some(90.0)
        );
        assert_eq!(
            opposite.sample(at(HOUR / 2)).wind_direction_deg(),
            Some(270.0)
        );
        // Direction without speed: unit vectors.
        let no_speed = hourly(2, &[(Variable::WindDirection, some(&[300.0, 20.0]))]);
        let d = no_speed.sample(at(HOUR / 2)).wind_direction_deg().unwrap();
        assert!((d - 340.0).abs() < 1e-3, "{d}");
    }

    #[test]
    fn wind_velocity_points_downwind() {
        let west_wind = hourly(
            1,
            &[
                (Variable::WindSpeed, some(&[5.0])),
                (Variable::WindDirection, some(&[270.0])),
            ],
        );
        let [east, north] = west_wind.sample(at(0)).wind_velocity_m_s().unwrap();
        assert!((east - 5.0).abs() < 1e-5 && north.abs() < 1e-5);
    }

    #[test]
    fn precipitation_is_an_amount_over_the_preceding_step() {
        // Stamped amounts: 01:00 holds 00:00–01:00, 02:00 holds 01:00–02:00, …
        let forecast = hourly(
            4,
            &[
                (
                    Variable::Precipitation,
                    vec![None, Some(2.0), Some(4.0), Some(0.0)],
                ),
                (
                    Variable::SunshineDuration,
                    vec![None, Some(1800.0), Some(0.0), Some(3600.0)],
                ),
            ],
        );
        let rate = |seconds| forecast.sample(at(seconds)).precipitation_mm_per_h();
        // In the middle of a step the rate is that step's amount per hour, exactly.
        assert_eq!(rate(HOUR / 2), Some(2.0));
        assert_eq!(rate(HOUR + HOUR / 2), Some(4.0));
        assert_eq!(rate(2 * HOUR + HOUR / 2), Some(0.0));
        // On a stamp it is halfway between the two steps it separates: continuous, no jump.
        assert_eq!(rate(HOUR), Some(3.0));
        assert_eq!(rate(2 * HOUR), Some(2.0));
        // Sunshine: the fraction of the step that was sunny.
        assert_eq!(
            forecast
                .sample(at(HOUR / 2))
                .get(Variable::SunshineDuration),
            Some(0.5)
        );
        // The first stamp's backward-looking value is null, so the rate before 00:30 has no data
        // on one side: missing, never a silent zero.
        let first = forecast.sample(at(0));
        assert_eq!(first.precipitation_mm_per_h(), None);
        assert!(first.missing.contains(Variable::Precipitation));
        assert_eq!(rate(HOUR / 2 - 1), None);

        // Amounts are kept up to the smoothing at step edges: integrating the rate over
        // 01:00–03:00 gives 3.75 mm against the stamped 4 + 0 mm (the 3 mm/h at 01:00 borrows from
        // the wetter step before).
        let mut total = 0.0;
        let samples: i32 = 3600;
        for i in 0..samples {
            let t = HOUR + (2 * HOUR * i64::from(i)) / i64::from(samples);
            total += f64::from(rate(t).unwrap()) * 2.0 / f64::from(samples);
        }
        assert!((total - 4.0).abs() < 0.3, "{total}");

        // Three-hourly steps: 3 mm over 3 h is 1 mm/h, 6 mm over 3 h is 2 mm/h.
        let times = vec![at(0), at(3 * HOUR), at(6 * HOUR)];
        let mut three_hourly = Forecast::new(Place::default(), times);
        three_hourly.series[Variable::Precipitation as usize] = Some(some(&[3.0, 3.0, 6.0]));
        assert_eq!(
            three_hourly
                .sample(at(HOUR + 1800))
                .precipitation_mm_per_h(),
            Some(1.0)
        );
        assert_eq!(
            three_hourly
                .sample(at(4 * HOUR + 1800))
                .precipitation_mm_per_h(),
            Some(2.0)
        );
        assert_eq!(
            three_hourly.sample(at(6 * HOUR)).precipitation_mm_per_h(),
            Some(2.0)
        );
    }

    #[test]
    fn short_gaps_are_bridged_and_long_gaps_reported() {
        let mut values = some(&[0.0; 12]);
        values[1] = Some(0.1);
        values[2] = None; // one null: bridged from 01:00 to 03:00 (2 h)
        values[3] = Some(0.3);
        values[5] = None; // two nulls: 04:00 to 07:00 is 3 h, bridged
        values[6] = None;
        values[4] = Some(0.4);
        values[7] = Some(0.7);
        values[8] = None; // three nulls: 07:00 to 11:00 is 4 h, too long
        values[9] = None;
        values[10] = None;
        values[11] = Some(1.0);
        let forecast = hourly(12, &[(Variable::LowCover, values)]);
        let mut sampler = Sampler::new();

        let state = sampler.sample(&forecast, at(2 * HOUR));
        assert!((state.low_cover().unwrap() - 0.2).abs() < 1e-6);
        assert!(state.bridged.contains(Variable::LowCover));
        assert_eq!(sampler.take_warning(), None);

        let state = sampler.sample(&forecast, at(5 * HOUR + 1800));
        assert!((state.low_cover().unwrap() - 0.55).abs() < 1e-6);
        assert!(state.bridged.contains(Variable::LowCover));

        let state = sampler.sample(&forecast, at(9 * HOUR));
        assert_eq!(state.low_cover(), None);
        assert!(state.missing.contains(Variable::LowCover));
        assert!(
            matches!(sampler.take_warning(), Some(SampleWarning::Gap { missing, .. }) if missing.contains(Variable::LowCover))
        );
        // Once per gap, not per frame.
        let _ = sampler.sample(&forecast, at(9 * HOUR + 60));
        assert_eq!(sampler.take_warning(), None);

        // A sampler that does not bridge at all.
        let mut strict = Sampler::with_max_bridge_s(0.0);
        assert_eq!(strict.sample(&forecast, at(2 * HOUR)).low_cover(), None);
        assert_eq!(
            strict.sample(&forecast, at(3 * HOUR)).low_cover(),
            Some(0.3)
        );
    }

    #[test]
    fn instants_outside_the_data_are_clamped_with_one_warning() {
        let forecast = hourly(3, &[(Variable::TotalCover, some(&[0.1, 0.5, 0.9]))]);
        let mut sampler = Sampler::new();
        let before = sampler.sample(&forecast, at(-10 * HOUR));
        assert_eq!(before.clamped, Some(DataEdge::Start));
        assert_eq!(before.total_cover(), Some(0.1));
        assert_eq!(before.time, at(-10 * HOUR));
        let warning = sampler.take_warning().unwrap();
        assert!(matches!(
            warning,
            SampleWarning::OutsideData {
                edge: DataEdge::Start,
                ..
            }
        ));
        assert!(
            warning.to_string().contains("before the forecast starts"),
            "{warning}"
        );
        // Many frames later, still outside: no new warning.
        for frame in 0..100 {
            let state = sampler.sample(&forecast, at(-10 * HOUR + frame));
            assert_eq!(state.clamped, Some(DataEdge::Start));
            assert_eq!(sampler.take_warning(), None);
        }
        // Inside again, then past the end: one warning for the new excursion.
        assert_eq!(sampler.sample(&forecast, at(HOUR)).clamped, None);
        assert_eq!(sampler.take_warning(), None);
        let after = sampler.sample(&forecast, at(30 * HOUR));
        assert_eq!(
            (after.clamped, after.total_cover()),
            (Some(DataEdge::End), Some(0.9))
        );
        let warning = sampler.take_warning().unwrap();
        assert!(
            warning.to_string().contains("after the forecast ends"),
            "{warning}"
        );
        assert_eq!(sampler.take_warning(), None);
        let _ = sampler.sample(&forecast, at(31 * HOUR));
        assert_eq!(sampler.take_warning(), None);
        // reset() forgets what was said.
        sampler.reset();
        let _ = sampler.sample(&forecast, at(31 * HOUR));
        assert!(sampler.take_warning().is_some());
    }

    #[test]
    fn cursor_and_binary_search_agree() {
        let forecast =
            Forecast::from_slice(include_bytes!("../../assets/weather/fribourg.json"), None)
                .unwrap();
        let (start, end) = (
            forecast.times[0].unix_seconds(),
            forecast.end().unwrap().unix_seconds(),
        );
        let mut sampler = Sampler::new();
        // Sequential frames (the cursor path), then random jumps.
        let mut t = start - 600;
        while t < end + 600 {
            let instant = UtcInstant::from_unix_seconds(t);
            assert_eq!(
                sampler.sample(&forecast, instant),
                forecast.sample(instant),
                "{instant}"
            );
            t += 97;
        }
        let mut state = 0x2545_F491_4F6C_DD1D_u64;
        for _ in 0..2000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let span = (end - start + 7200) as u64;
            let instant = UtcInstant::from_unix_seconds(start - 3600 + (state % span) as i64);
            assert_eq!(
                sampler.sample(&forecast, instant),
                forecast.sample(instant),
                "{instant}"
            );
        }
        // Fractional seconds interpolate smoothly between whole ones.
        let a = sampler.sample_unix_seconds(&forecast, (start + 1800) as f64);
        let b = sampler.sample_unix_seconds(&forecast, (start + 1800) as f64 + 0.5);
        assert!((a.low_cover().unwrap() - b.low_cover().unwrap()).abs() < 1e-3);
    }

    #[test]
    fn codes_flags_and_upper_air() {
        let forecast = Forecast::from_slice(
            include_bytes!("../../assets/weather/bern_open_meteo.json"),
            None,
        )
        .unwrap();
        let start = forecast.times[0];
        let mut sampler = Sampler::new();
        let state = sampler.sample(&forecast, start.saturating_add_seconds(20 * 60));
        assert_eq!(
            state.wmo_weather_code,
            forecast.wmo_weather_code.as_ref().unwrap()[0]
        );
        let later = sampler.sample(&forecast, start.saturating_add_seconds(40 * 60));
        assert_eq!(
            later.wmo_weather_code,
            forecast.wmo_weather_code.as_ref().unwrap()[1]
        );
        assert!(state.is_daylight.is_some());
        for pressure in STANDARD_LEVELS_HPA {
            let level = state.level(pressure).unwrap();
            assert!(
                level.wind_speed_m_s.is_some() && level.height_m.is_some(),
                "{level:?}"
            );
        }
        // The 300 hPa series ends in nulls (past the model horizon): missing at the end.
        let end = sampler.sample(&forecast, forecast.end().unwrap());
        assert_eq!(end.level(300.0).unwrap().wind_speed_m_s, None);
        assert!(end.level(850.0).unwrap().wind_speed_m_s.is_some());
        let index = forecast
            .pressure_levels
            .iter()
            .position(|level| level.pressure_hpa == 500.0)
            .unwrap();
        assert_eq!(
            sampler.sample_level(&forecast, index, start),
            Some(*state_at(&forecast, start).level(500.0).unwrap())
        );
        assert_eq!(sampler.sample_level(&forecast, 99, start), None);
    }

    fn state_at(forecast: &Forecast, instant: UtcInstant) -> WeatherState {
        forecast.sample(instant)
    }

    #[test]
    fn the_bundled_week_reads_as_described() {
        let bern =
            Forecast::from_slice(include_bytes!("../../assets/weather/bern.json"), None).unwrap();
        let local = |day: u8, hour: u8| {
            // CEST = UTC+2.
            UtcInstant::from_civil(2021, 5, day, hour, 0, 0)
                .unwrap()
                .saturating_add_seconds(-2 * HOUR)
        };
        let state = |day, hour| bern.sample(local(day, hour));
        // Monday: clear morning, afternoon cumulus.
        assert!(state(3, 8).low_cover().unwrap() < 0.05);
        assert!(state(3, 15).low_cover().unwrap() > 0.3);
        // Tuesday: cirrus first, then altostratus, then rain.
        assert!(
            state(4, 11).high_cover().unwrap() > 0.4 && state(4, 11).mid_cover().unwrap() < 0.2
        );
        assert!(state(4, 18).mid_cover().unwrap() > 0.7);
        assert!(state(4, 23).precipitation_mm_per_h().unwrap() > 0.5);
        // Wednesday: overcast.
        assert!(state(5, 12).total_cover().unwrap() > 0.9);
        // Thursday: foggy morning.
        let fog = state(6, 7);
        assert_eq!(fog.pictocode, Some(16));
        assert!(fog.fog_probability().unwrap() > 0.6 && fog.visibility_m().unwrap() < 1000.0);
        // Friday: afternoon thunderstorm.
        let storm = state(7, 16);
        assert!(matches!(storm.pictocode, Some(10..=12 | 27..=30)));
        assert!(storm.convective_precipitation_mm_per_h().unwrap() > 1.0);
    }

    #[test]
    fn degenerate_forecasts_do_not_panic() {
        let empty = Forecast::new(Place::default(), Vec::new());
        let state = Sampler::new().sample(&empty, at(0));
        assert_eq!(state, WeatherState::empty(at(0)));

        // Series shorter than the times, unsorted times, a lone step, NaN instants.
        let mut odd = hourly(3, &[(Variable::LowCover, some(&[0.5]))]);
        odd.series[Variable::Precipitation as usize] = Some(some(&[1.0, 2.0, 3.0, 4.0, 5.0]));
        let mut sampler = Sampler::new();
        for t in [-HOUR, 0, HOUR / 2, HOUR, 5 * HOUR] {
            let _ = sampler.sample(&odd, at(t));
        }
        odd.times.reverse();
        for t in [-HOUR, 0, HOUR / 2, HOUR, 5 * HOUR] {
            let _ = sampler.sample(&odd, at(t));
        }
        let _ = sampler.sample_unix_seconds(&odd, f64::NAN);
        let _ = sampler.sample_unix_seconds(&odd, f64::INFINITY);
        let lone = hourly(1, &[(Variable::Precipitation, some(&[2.0]))]);
        assert_eq!(lone.sample(at(0)).precipitation_mm_per_h(), Some(2.0));
    }

    #[test]
    fn variable_sets() {
        let mut set = VariableSet::EMPTY;
        assert!(set.is_empty());
        set.insert(Variable::WindSpeed);
        set.insert(Variable::LowCover);
        set.insert(Variable::LowCover);
        assert_eq!(set.len(), 2);
        assert!(set.contains(Variable::WindSpeed) && !set.contains(Variable::MidCover));
        assert_eq!(set.to_string(), "low_cover, wind_speed");
        assert_eq!(Variable::ALL.len(), Variable::COUNT);
        for (i, variable) in Variable::ALL.iter().enumerate() {
            assert_eq!(*variable as usize, i);
        }
    }
}
