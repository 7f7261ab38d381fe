//! [`Sampler`]: samples forecasts at instants, caching its position and the warnings given.

use std::fmt;

use super::interpolate::{
    Position, locate, sample_direction, sample_level_at, sample_nearest, sample_rate,
    sample_scalar, seconds,
};
use super::{
    DEFAULT_MAX_BRIDGE_S, DataEdge, LevelState, STANDARD_LEVELS_HPA, VariableSet, WeatherState,
};
use crate::scene::UtcInstant;
use crate::weather::forecast::{Forecast, Variable};

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
