//! UTC instants as whole Unix seconds, with hand-written RFC 3339 / ISO 8601 parsing.
//!
//! Forecast files stamp their values in three ways (the APIs' documentation: docs.meteoblue.com, open-meteo.com/en/docs): local wall-clock time
//! plus one offset for the whole file (`"2021-05-03 14:00"` + `utc_timeoffset: 2.0`), ISO 8601
//! strings with or without an offset (`"2021-05-03T14:00+02:00"`), and integer Unix seconds. All of
//! them end up as a [`UtcInstant`], so the rest of the crate never sees a time zone.
//!
//! The calendar arithmetic is the proleptic Gregorian "days from civil" construction (count days in
//! 400-year eras of 146 097 days, with the year starting on 1 March so the leap day is the last day
//! of the year); no time-zone database is needed because every input carries its offset explicitly.

use std::fmt;
use std::str::FromStr;

use thiserror::Error;

/// Seconds in one civil day (leap seconds are ignored, as in POSIX time).
const SECONDS_PER_DAY: i64 = 86_400;

/// An instant in UTC, stored as whole seconds since 1970-01-01T00:00:00Z (Unix time, no leap
/// seconds).
///
/// Formats with [`fmt::Display`] as RFC 3339 (`2021-05-03T12:00:00Z`) and parses with
/// [`UtcInstant::parse_rfc3339`] or [`str::parse`]. The default is the Unix epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct UtcInstant(i64);

/// A calendar date and time of day (proleptic Gregorian calendar), without a time zone.
///
/// Returned by [`UtcInstant::to_civil`]; fields are plain numbers so callers can format them as
/// they like.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct CivilDateTime {
    /// Year, e.g. 2021 (may be zero or negative for astronomical dates).
    pub year: i32,
    /// Month of the year, 1–12.
    pub month: u8,
    /// Day of the month, 1–31.
    pub day: u8,
    /// Hour of the day, 0–23.
    pub hour: u8,
    /// Minute of the hour, 0–59.
    pub minute: u8,
    /// Second of the minute, 0–59.
    pub second: u8,
}

/// Why a time stamp could not be read; carried inside
/// [`ForecastError::BadTime`](crate::weather::ForecastError::BadTime).
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
#[error("{reason}")]
pub struct TimeParseError {
    reason: &'static str,
}

impl TimeParseError {
    const fn new(reason: &'static str) -> Self {
        Self { reason }
    }

    /// A short English description of what was wrong, e.g. `"month out of range"`.
    #[must_use]
    pub const fn reason(&self) -> &'static str {
        self.reason
    }
}

impl UtcInstant {
    /// The Unix epoch, 1970-01-01T00:00:00Z.
    pub const UNIX_EPOCH: Self = Self(0);

    /// The instant `seconds` after the Unix epoch (negative: before it).
    #[must_use]
    pub const fn from_unix_seconds(seconds: i64) -> Self {
        Self(seconds)
    }

    /// Whole seconds since the Unix epoch.
    #[must_use]
    pub const fn unix_seconds(self) -> i64 {
        self.0
    }

    /// This instant shifted by `seconds` (saturating at the ends of the `i64` range).
    #[must_use]
    pub const fn saturating_add_seconds(self, seconds: i64) -> Self {
        Self(self.0.saturating_add(seconds))
    }

    /// The instant of a UTC calendar date and time; `None` if a field is out of range
    /// (month 1–12, day within the month, hour 0–23, minute 0–59, second 0–60 where 60 is a leap
    /// second folded into the next minute).
    #[must_use]
    pub fn from_civil(
        year: i32,
        month: u8,
        day: u8,
        hour: u8,
        minute: u8,
        second: u8,
    ) -> Option<Self> {
        if !(1..=12).contains(&month)
            || day == 0
            || day > days_in_month(year, month)
            || hour > 23
            || minute > 59
            || second > 60
        {
            return None;
        }
        let days = days_from_civil(i64::from(year), i64::from(month), i64::from(day));
        let seconds_of_day = i64::from(hour) * 3600 + i64::from(minute) * 60 + i64::from(second);
        Some(Self(days * SECONDS_PER_DAY + seconds_of_day))
    }

    /// The UTC calendar date and time of this instant.
    #[must_use]
    pub fn to_civil(self) -> CivilDateTime {
        let days = self.0.div_euclid(SECONDS_PER_DAY);
        let seconds_of_day = self.0.rem_euclid(SECONDS_PER_DAY);
        let (year, month, day) = civil_from_days(days);
        // The casts are exact: the remainders are bounded by 24, 60 and 60.
        CivilDateTime {
            year: i32::try_from(year).unwrap_or(if year < 0 { i32::MIN } else { i32::MAX }),
            month: month as u8,
            day: day as u8,
            hour: (seconds_of_day / 3600) as u8,
            minute: (seconds_of_day / 60 % 60) as u8,
            second: (seconds_of_day % 60) as u8,
        }
    }

    /// RFC 3339 in UTC with whole seconds, e.g. `2021-05-03T12:00:00Z`.
    #[must_use]
    pub fn to_rfc3339(self) -> String {
        self.to_string()
    }

    /// Parses an RFC 3339 time stamp such as `2021-05-03T14:00:00+02:00` or `2021-05-03T12:00Z`.
    ///
    /// Lenient where files in the wild are: the date/time separator may be `T`, `t` or a space,
    /// seconds and fractional seconds are optional (fractions are rounded to the nearest second),
    /// and the offset may be `Z`, `±HH:MM`, `±HHMM` or `±HH`. An offset is required: a time
    /// without one is local time of an unknown zone, which only a forecast file's metadata can
    /// resolve (see [`UtcInstant::parse_with_default_offset`]).
    ///
    /// # Errors
    /// [`TimeParseError`] naming the first thing that is wrong.
    pub fn parse_rfc3339(text: &str) -> Result<Self, TimeParseError> {
        Self::parse_with_default_offset(text, None)
    }

    /// Parses an ISO 8601 date-time like [`UtcInstant::parse_rfc3339`], but a stamp without an
    /// explicit offset is read as local time `default_offset_s` seconds east of UTC (the file-wide
    /// `utc_timeoffset` of meteoblue or `utc_offset_seconds` of Open-Meteo). A date alone
    /// (`2021-05-03`) means local midnight.
    ///
    /// # Errors
    /// [`TimeParseError`] naming the first thing that is wrong, including a missing offset when
    /// `default_offset_s` is `None`.
    pub fn parse_with_default_offset(
        text: &str,
        default_offset_s: Option<i64>,
    ) -> Result<Self, TimeParseError> {
        let mut cursor = Cursor::new(text.trim());
        let year = cursor.digits(4, "expected a four-digit year")?;
        cursor.expect(b'-', "expected '-' after the year")?;
        let month = cursor.digits(2, "expected a two-digit month")?;
        cursor.expect(b'-', "expected '-' after the month")?;
        let day = cursor.digits(2, "expected a two-digit day")?;

        let (mut hour, mut minute, mut second, mut fraction) = (0, 0, 0, 0.0_f64);
        if cursor
            .peek()
            .is_some_and(|b| matches!(b, b'T' | b't' | b' '))
        {
            cursor.advance();
            hour = cursor.digits(2, "expected a two-digit hour")?;
            cursor.expect(b':', "expected ':' after the hour")?;
            minute = cursor.digits(2, "expected a two-digit minute")?;
            if cursor.peek() == Some(b':') {
                cursor.advance();
                second = cursor.digits(2, "expected two-digit seconds")?;
                if cursor.peek().is_some_and(|b| b == b'.' || b == b',') {
                    cursor.advance();
                    fraction = cursor.fraction()?;
                }
            }
        }

        let offset_s = match cursor.peek() {
            None => default_offset_s.ok_or(TimeParseError::new(
                "no UTC offset (add 'Z' or '+hh:mm', or give the file's offset)",
            ))?,
            Some(b'Z' | b'z') => {
                cursor.advance();
                0
            }
            Some(sign @ (b'+' | b'-')) => {
                cursor.advance();
                let hours = cursor.digits(2, "expected a two-digit offset hour")?;
                let minutes = match cursor.peek() {
                    Some(b':') => {
                        cursor.advance();
                        cursor.digits(2, "expected two-digit offset minutes")?
                    }
                    Some(b'0'..=b'9') => cursor.digits(2, "expected two-digit offset minutes")?,
                    _ => 0,
                };
                if hours > 23 || minutes > 59 {
                    return Err(TimeParseError::new("UTC offset out of range"));
                }
                let magnitude = hours * 3600 + minutes * 60;
                if sign == b'-' { -magnitude } else { magnitude }
            }
            Some(_) => return Err(TimeParseError::new("unexpected text after the time")),
        };
        if !cursor.at_end() {
            return Err(TimeParseError::new("unexpected text after the UTC offset"));
        }

        let local = Self::from_civil(
            narrow(year)?,
            narrow(month)?,
            narrow(day)?,
            narrow(hour)?,
            narrow(minute)?,
            narrow(second)?,
        )
        .ok_or_else(|| TimeParseError::new(civil_range_reason(month, day, hour, minute, second)))?;
        // Round fractional seconds half up; sub-second precision is irrelevant for weather.
        let rounded = i64::from(fraction >= 0.5);
        Ok(Self(local.0 - offset_s + rounded))
    }

    /// Parses meteoblue's local wall-clock format `"YYYY-MM-DD hh:mm"` (also accepts the other
    /// forms of [`UtcInstant::parse_with_default_offset`]) at `offset_s` seconds east of UTC.
    ///
    /// # Errors
    /// [`TimeParseError`] naming the first thing that is wrong.
    pub fn parse_local(text: &str, offset_s: i64) -> Result<Self, TimeParseError> {
        Self::parse_with_default_offset(text, Some(offset_s))
    }
}

impl fmt::Display for UtcInstant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.to_civil();
        write!(
            f,
            "{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z",
            c.year, c.month, c.day, c.hour, c.minute, c.second
        )
    }
}

impl FromStr for UtcInstant {
    type Err = TimeParseError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        Self::parse_rfc3339(text)
    }
}

/// Picks the most specific reason once `from_civil` has refused the fields.
fn civil_range_reason(month: i64, day: i64, hour: i64, minute: i64, second: i64) -> &'static str {
    if !(1..=12).contains(&month) {
        "month out of range"
    } else if day == 0 || day > 31 {
        "day out of range"
    } else if hour > 23 {
        "hour out of range"
    } else if minute > 59 {
        "minute out of range"
    } else if second > 60 {
        "second out of range"
    } else {
        "day does not exist in that month"
    }
}

fn narrow<T: TryFrom<i64>>(value: i64) -> Result<T, TimeParseError> {
    T::try_from(value).map_err(|_| TimeParseError::new("number out of range"))
}

/// A byte cursor over an ASCII time stamp.
struct Cursor<'a> {
    bytes: &'a [u8],
    position: usize,
}

impl<'a> Cursor<'a> {
    fn new(text: &'a str) -> Self {
        Self {
            bytes: text.as_bytes(),
            position: 0,
        }
    }

    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.position).copied()
    }

    fn advance(&mut self) {
        self.position += 1;
    }

    fn at_end(&self) -> bool {
        self.position >= self.bytes.len()
    }

    fn expect(&mut self, byte: u8, reason: &'static str) -> Result<(), TimeParseError> {
        if self.peek() == Some(byte) {
            self.advance();
            Ok(())
        } else {
            Err(TimeParseError::new(reason))
        }
    }

    /// Exactly `count` ASCII digits as a number.
    fn digits(&mut self, count: usize, reason: &'static str) -> Result<i64, TimeParseError> {
        let mut value = 0_i64;
        for _ in 0..count {
            match self.peek() {
                Some(digit @ b'0'..=b'9') => {
                    value = value * 10 + i64::from(digit - b'0');
                    self.advance();
                }
                _ => return Err(TimeParseError::new(reason)),
            }
        }
        Ok(value)
    }

    /// One or more digits after a decimal point, as a fraction in [0, 1).
    fn fraction(&mut self) -> Result<f64, TimeParseError> {
        let mut value = 0.0;
        let mut scale = 0.1;
        let start = self.position;
        while let Some(digit @ b'0'..=b'9') = self.peek() {
            value += f64::from(digit - b'0') * scale;
            scale *= 0.1;
            self.advance();
        }
        if self.position == start {
            return Err(TimeParseError::new(
                "expected digits after the decimal point",
            ));
        }
        Ok(value)
    }
}

fn is_leap_year(year: i32) -> bool {
    (year % 4 == 0 && year % 100 != 0) || year % 400 == 0
}

fn days_in_month(year: i32, month: u8) -> u8 {
    match month {
        2 if is_leap_year(year) => 29,
        2 => 28,
        4 | 6 | 9 | 11 => 30,
        _ => 31,
    }
}

/// Days since 1970-01-01 of a proleptic Gregorian date.
///
/// Years are counted from 1 March, so February (with the leap day) ends the year and the
/// day-of-year of each month start follows the linear rule `(153 * m + 2) / 5` for months counted
/// from March; whole 400-year eras hold 146 097 days. 719 468 is the day number of 1970-01-01 in
/// this count (which starts at 0000-03-01).
fn days_from_civil(year: i64, month: i64, day: i64) -> i64 {
    let year = if month <= 2 { year - 1 } else { year };
    let era = year.div_euclid(400);
    let year_of_era = year.rem_euclid(400);
    let month_from_march = (month + 9) % 12;
    let day_of_year = (153 * month_from_march + 2) / 5 + day - 1;
    let day_of_era = year_of_era * 365 + year_of_era / 4 - year_of_era / 100 + day_of_year;
    era * 146_097 + day_of_era - 719_468
}

/// Inverse of [`days_from_civil`]: (year, month 1–12, day 1–31).
fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let days = days + 719_468;
    let era = days.div_euclid(146_097);
    let day_of_era = days.rem_euclid(146_097);
    // Remove the leap days of the 4-, 100- and 400-year cycles to count whole 365-day years.
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let month_from_march = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * month_from_march + 2) / 5 + 1;
    let month = if month_from_march < 10 {
        month_from_march + 3
    } else {
        month_from_march - 9
    };
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    (year, month, day)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epoch_and_known_instants() {
        assert_eq!(
            UtcInstant::from_civil(1970, 1, 1, 0, 0, 0),
            Some(UtcInstant::UNIX_EPOCH)
        );
        // 2021-05-03T00:00:00Z, checked with `date -u -d 2021-05-03 +%s`.
        assert_eq!(
            UtcInstant::from_civil(2021, 5, 3, 0, 0, 0)
                .unwrap()
                .unix_seconds(),
            1_620_000_000
        );
        assert_eq!(
            UtcInstant::from_civil(2000, 2, 29, 12, 0, 0)
                .unwrap()
                .unix_seconds(),
            951_825_600
        );
        assert_eq!(
            UtcInstant::from_civil(1969, 12, 31, 23, 59, 59)
                .unwrap()
                .unix_seconds(),
            -1
        );
    }

    #[test]
    fn civil_round_trip_over_many_days() {
        // Every day from 1600 to 2400 (both leap-century rules) survives the round trip.
        let start = UtcInstant::from_civil(1600, 1, 1, 0, 0, 0)
            .unwrap()
            .unix_seconds();
        let end = UtcInstant::from_civil(2400, 12, 31, 0, 0, 0)
            .unwrap()
            .unix_seconds();
        let mut t = start;
        while t <= end {
            let civil = UtcInstant::from_unix_seconds(t + 3723).to_civil();
            let back = UtcInstant::from_civil(
                civil.year,
                civil.month,
                civil.day,
                civil.hour,
                civil.minute,
                civil.second,
            )
            .unwrap();
            assert_eq!(back.unix_seconds(), t + 3723, "{civil:?}");
            t += SECONDS_PER_DAY;
        }
    }

    #[test]
    fn rejects_impossible_dates() {
        assert_eq!(UtcInstant::from_civil(2021, 2, 29, 0, 0, 0), None);
        assert_eq!(UtcInstant::from_civil(1900, 2, 29, 0, 0, 0), None);
        assert!(UtcInstant::from_civil(2000, 2, 29, 0, 0, 0).is_some());
        assert_eq!(UtcInstant::from_civil(2021, 13, 1, 0, 0, 0), None);
        assert_eq!(UtcInstant::from_civil(2021, 4, 31, 0, 0, 0), None);
        assert_eq!(UtcInstant::from_civil(2021, 4, 1, 24, 0, 0), None);
    }

    #[test]
    fn formats_rfc3339() {
        let t = UtcInstant::from_civil(2003, 10, 17, 19, 30, 30).unwrap();
        assert_eq!(t.to_string(), "2003-10-17T19:30:30Z");
        assert_eq!(t.to_rfc3339(), "2003-10-17T19:30:30Z");
        assert_eq!(
            UtcInstant::from_unix_seconds(-1).to_string(),
            "1969-12-31T23:59:59Z"
        );
    }

    #[test]
    fn parses_rfc3339_variants() {
        let expected = UtcInstant::from_civil(2021, 5, 3, 12, 0, 0).unwrap();
        for text in [
            "2021-05-03T12:00:00Z",
            "2021-05-03T12:00Z",
            "2021-05-03t12:00:00z",
            "2021-05-03 12:00:00Z",
            "2021-05-03T14:00+02:00",
            "2021-05-03T14:00:00+0200",
            "2021-05-03T14:00:00+02",
            "2021-05-03T07:30-04:30",
            "2021-05-03T11:59:59.5Z",
            " 2021-05-03T12:00:00.000Z ",
        ] {
            assert_eq!(text.parse::<UtcInstant>(), Ok(expected), "{text}");
        }
    }

    #[test]
    fn local_times_use_the_file_offset() {
        let expected = UtcInstant::from_civil(2021, 5, 3, 12, 0, 0).unwrap();
        assert_eq!(
            UtcInstant::parse_local("2021-05-03 14:00", 7200),
            Ok(expected)
        );
        assert_eq!(
            UtcInstant::parse_local("2021-05-03T14:00", 7200),
            Ok(expected)
        );
        // An explicit offset wins over the file's.
        assert_eq!(
            UtcInstant::parse_local("2021-05-03T12:00Z", 7200),
            Ok(expected)
        );
        // India, +5:30 (meteoblue writes utc_timeoffset 5.5).
        assert_eq!(
            UtcInstant::parse_local("2021-05-03 17:30", 19_800),
            Ok(expected)
        );
        // A date alone is local midnight.
        assert_eq!(
            UtcInstant::parse_local("2021-05-03", 0),
            Ok(UtcInstant::from_civil(2021, 5, 3, 0, 0, 0).unwrap())
        );
    }

    #[test]
    fn parse_errors_say_why() {
        let reason = |text: &str| UtcInstant::parse_rfc3339(text).unwrap_err().reason();
        assert!(reason("2021-05-03T12:00").contains("offset"));
        assert_eq!(reason("2021-13-03T12:00Z"), "month out of range");
        assert_eq!(
            reason("2021-02-30T12:00Z"),
            "day does not exist in that month"
        );
        assert_eq!(reason("2021-05-03T25:00Z"), "hour out of range");
        assert_eq!(reason("21-05-03T12:00Z"), "expected a four-digit year");
        assert_eq!(
            reason("2021-05-03T12:00Zjunk"),
            "unexpected text after the UTC offset"
        );
        assert_eq!(reason("2021-05-03T12:00+25:00"), "UTC offset out of range");
        assert_eq!(reason(""), "expected a four-digit year");
        assert_eq!(
            reason("2021-05-03T12:00:00.Z"),
            "expected digits after the decimal point"
        );
        assert_eq!(
            reason("2021-05-03X12:00Z"),
            "unexpected text after the time"
        );
    }
}
