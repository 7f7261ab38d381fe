//! The scene time: live (the wall clock, or a chosen instant) or play (scrubbed, paused, sped up).

use bevy::prelude::*;

use super::UtcInstant;

/// How [`SceneClock`] advances.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Reflect)]
pub enum ClockMode {
    /// Live: the scene time is the system clock's UTC time, every frame.
    #[default]
    WallClock,
    /// The scene time is what was set last ([`SceneClock::set_unix_seconds`]), advancing at
    /// [`SceneClock::speed`] unless [`SceneClock::paused`]. Covers both "live at a chosen
    /// instant" (speed 1) and "play" (scrub, pause, 60×, 3600×).
    Manual,
}

/// The instant the scene shows, which the weather and the sun follow.
///
/// Default: [`ClockMode::WallClock`].
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Default)]
pub struct SceneClock {
    /// How the clock advances.
    pub mode: ClockMode,
    /// Scene seconds per real second in [`ClockMode::Manual`]. Default 1; the demo offers 60
    /// and 3600. Negative runs time backwards.
    pub speed: f64,
    /// Stops a [`ClockMode::Manual`] clock. Default false.
    pub paused: bool,
    /// Seconds since 1970-01-01T00:00:00Z (UTC), with fractions so slow motion stays smooth.
    unix_seconds: f64,
}

impl Default for SceneClock {
    fn default() -> Self {
        Self {
            mode: ClockMode::WallClock,
            speed: 1.0,
            paused: false,
            unix_seconds: wall_clock_unix_seconds(),
        }
    }
}

impl SceneClock {
    /// A manual clock stopped at `instant` (set `paused = false` to let it run).
    pub fn at(instant: UtcInstant) -> Self {
        Self {
            mode: ClockMode::Manual,
            speed: 1.0,
            paused: true,
            unix_seconds: instant.unix_seconds() as f64,
        }
    }

    /// The scene time, seconds since the Unix epoch (UTC).
    pub fn unix_seconds(&self) -> f64 {
        self.unix_seconds
    }

    /// The scene time, rounded down to whole seconds.
    pub fn instant(&self) -> UtcInstant {
        UtcInstant::from_unix_seconds(self.unix_seconds.floor() as i64)
    }

    /// Jumps to a time (seconds since the Unix epoch, UTC) and switches to [`ClockMode::Manual`].
    /// A non-finite value is ignored with a warning, keeping the current time.
    pub fn set_unix_seconds(&mut self, unix_seconds: f64) {
        if unix_seconds.is_finite() {
            self.mode = ClockMode::Manual;
            self.unix_seconds = unix_seconds;
        } else {
            warn!("bevy_cloudscape: SceneClock ignores the non-finite time {unix_seconds}");
        }
    }

    /// Advances the clock by `real_seconds` of real time, by the rules of its mode.
    pub fn advance(&mut self, real_seconds: f64) {
        match self.mode {
            ClockMode::WallClock => self.unix_seconds = wall_clock_unix_seconds(),
            ClockMode::Manual if !self.paused && self.speed.is_finite() => {
                self.unix_seconds += real_seconds * self.speed;
            }
            ClockMode::Manual => {}
        }
    }
}

fn wall_clock_unix_seconds() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// Advances the [`SceneClock`] by the frame's real time.
pub(crate) fn advance_scene_clock(time: Res<Time<Real>>, mut clock: ResMut<SceneClock>) {
    clock.advance(time.delta_secs_f64());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manual_clock_scrubs_pauses_and_speeds_up() {
        let noon: UtcInstant = "2021-05-03T12:00:00Z".parse().unwrap();
        let mut clock = SceneClock::at(noon);
        clock.advance(10.0);
        assert_eq!(clock.instant(), noon, "paused");
        clock.paused = false;
        clock.speed = 3600.0;
        clock.advance(0.5);
        assert_eq!(clock.unix_seconds(), noon.unix_seconds() as f64 + 1800.0);
        clock.set_unix_seconds(f64::NAN);
        assert_eq!(clock.unix_seconds(), noon.unix_seconds() as f64 + 1800.0);
    }

    #[test]
    fn wall_clock_follows_system_time() {
        let mut clock = SceneClock::at(UtcInstant::from_unix_seconds(0));
        clock.mode = ClockMode::WallClock;
        clock.advance(0.0);
        assert!((clock.unix_seconds() - wall_clock_unix_seconds()).abs() < 5.0);
    }
}
