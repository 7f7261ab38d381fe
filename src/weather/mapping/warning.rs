//! [`MappingWarning`] and [`InputFault`]: a forecast input the mapping could not use.

use std::fmt;

/// What went wrong with a forecast input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InputFault {
    /// No value: the forecast lacks the variable, or the instant is in a long gap.
    NoValue,
    /// NaN or infinite; treated as no value.
    NotFinite,
}

/// A forecast input the mapping could not use, and what it did instead. Each input is reported
/// at most once per [`WeatherMapping::map`] call.
///
/// [`WeatherMapping::map`]: super::WeatherMapping::map
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MappingWarning {
    /// The input: a [`Variable::name`] such as `"low_cover"`, `"pressure-level wind"` or
    /// `"ground_elevation_m"`.
    ///
    /// [`Variable::name`]: crate::weather::Variable::name
    pub input: &'static str,
    /// What is wrong with it.
    pub fault: InputFault,
    /// What the mapping did instead, e.g. which layer keeps which previous value.
    pub consequence: &'static str,
}

impl fmt::Display for MappingWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let fault = match self.fault {
            InputFault::NoValue => "has no value",
            InputFault::NotFinite => "is not a finite number",
        };
        write!(f, "{} {fault}: {}", self.input, self.consequence)
    }
}
