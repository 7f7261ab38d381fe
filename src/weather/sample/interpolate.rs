//! Interpolation in time: finding the step, bridging gaps, sampling each kind of series.

use super::LevelState;
use crate::scene::UtcInstant;
use crate::weather::forecast::{PressureLevel, Series};

pub(super) fn seconds(instant: UtcInstant) -> f64 {
    instant.unix_seconds() as f64
}

/// The step index `i` with `times[i] <= t < times[i + 1]` (the last index when `t` is at the end),
/// trying the cached `hint` and its successor before a binary search.
pub(super) fn locate(times: &[UtcInstant], t: f64, hint: usize) -> usize {
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
pub(super) struct Position<'a> {
    pub(super) times: &'a [UtcInstant],
    /// Clamped time, Unix seconds.
    pub(super) t: f64,
    /// `times[index] <= t < times[index + 1]`.
    pub(super) index: usize,
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
pub(super) fn sample_scalar(
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
pub(super) fn sample_rate(
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
pub(super) fn sample_direction(
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
pub(super) fn sample_nearest<T: Copy>(
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

pub(super) fn sample_level_at(
    level: &PressureLevel,
    position: &Position,
    max_bridge: f64,
) -> LevelState {
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
