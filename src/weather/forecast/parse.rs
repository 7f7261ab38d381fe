//! Reading a document: a cheap probe of each location for its format, then its typed structs.

use serde::Deserialize;
use serde::de::{DeserializeSeed, IgnoredAny, SeqAccess, Visitor};

use super::{Forecast, ForecastError, ForecastFormat};
use crate::weather::meteoblue::MeteoblueFile;
use crate::weather::open_meteo::OpenMeteoFile;

/// What the first, cheap pass finds at the top of each location object.
#[derive(Deserialize)]
struct Probe {
    metadata: Option<IgnoredAny>,
    data_1h: Option<IgnoredAny>,
    data_3h: Option<IgnoredAny>,
    hourly: Option<IgnoredAny>,
    error: Option<serde_json::Value>,
    reason: Option<serde_json::Value>,
    error_message: Option<serde_json::Value>,
}

impl Probe {
    /// The reason text if this object is an API error response.
    fn api_error(&self) -> Option<String> {
        let flagged = match &self.error {
            Some(serde_json::Value::Bool(flag)) => *flag,
            Some(serde_json::Value::Null) | None => false,
            Some(_) => true,
        } || self.error_message.is_some();
        if !flagged {
            return None;
        }
        let text = |value: &serde_json::Value| match value {
            serde_json::Value::String(text) => text.clone(),
            other => other.to_string(),
        };
        Some(
            self.reason
                .as_ref()
                .or(self.error_message.as_ref())
                .or(self.error.as_ref().filter(|e| !e.is_boolean()))
                .map_or_else(|| "no reason given".to_owned(), text),
        )
    }

    fn looks_like_meteoblue(&self) -> bool {
        self.metadata.is_some() || self.data_1h.is_some() || self.data_3h.is_some()
    }

    fn format(&self, hint: Option<ForecastFormat>) -> Result<ForecastFormat, String> {
        let meteoblue = self.looks_like_meteoblue();
        let open_meteo = self.hourly.is_some();
        match hint {
            Some(ForecastFormat::Meteoblue) if open_meteo && !meteoblue => {
                Err("meteoblue was asked for, but the file has Open-Meteo's `hourly`".to_owned())
            }
            Some(ForecastFormat::OpenMeteo) if meteoblue && !open_meteo => Err(
                "Open-Meteo was asked for, but the file has meteoblue's `metadata`/`data_1h`"
                    .to_owned(),
            ),
            Some(format) => Ok(format),
            None if meteoblue => Ok(ForecastFormat::Meteoblue),
            None if open_meteo => Ok(ForecastFormat::OpenMeteo),
            None => Err(
                "expected `metadata` and `data_1h` (meteoblue) or `hourly` (Open-Meteo)".to_owned(),
            ),
        }
    }
}

/// A location parsed with its format's typed structs.
enum TypedLocation {
    Meteoblue(MeteoblueFile),
    OpenMeteo(OpenMeteoFile),
}

impl TypedLocation {
    fn into_forecast(self, prefix: &str) -> Result<Forecast, ForecastError> {
        match self {
            Self::Meteoblue(file) => file.into_forecast(prefix),
            Self::OpenMeteo(file) => file.into_forecast(prefix),
        }
    }
}

/// Deserializes one location with the struct of the format the probe found.
struct LocationSeed(ForecastFormat);

impl<'de> DeserializeSeed<'de> for LocationSeed {
    type Value = TypedLocation;

    fn deserialize<D: serde::Deserializer<'de>>(
        self,
        deserializer: D,
    ) -> Result<Self::Value, D::Error> {
        Ok(match self.0 {
            ForecastFormat::Meteoblue => {
                TypedLocation::Meteoblue(MeteoblueFile::deserialize(deserializer)?)
            }
            ForecastFormat::OpenMeteo => {
                TypedLocation::OpenMeteo(OpenMeteoFile::deserialize(deserializer)?)
            }
        })
    }
}

/// Deserializes a JSON array of locations, each with its own format.
struct ArraySeed<'a>(&'a [ForecastFormat]);

impl<'de> DeserializeSeed<'de> for ArraySeed<'_> {
    type Value = Vec<TypedLocation>;

    fn deserialize<D: serde::Deserializer<'de>>(
        self,
        deserializer: D,
    ) -> Result<Self::Value, D::Error> {
        deserializer.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for ArraySeed<'_> {
    type Value = Vec<TypedLocation>;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("an array of forecast locations")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut locations = Vec::with_capacity(self.0.len());
        for &format in self.0 {
            match seq.next_element_seed(LocationSeed(format))? {
                Some(location) => locations.push(location),
                None => break,
            }
        }
        Ok(locations)
    }
}

/// Two passes: a cheap probe of every location's top-level keys (finds syntax errors, API error
/// objects and the format), then typed deserialization with the right structs.
pub(super) fn parse_document(
    bytes: &[u8],
    hint: Option<ForecastFormat>,
) -> Result<Vec<Forecast>, ForecastError> {
    // Editors on Windows may prepend a UTF-8 byte-order mark, which JSON parsers reject.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let json_error = |error: serde_json::Error| ForecastError::from_json(&error, bytes);
    let is_array = bytes
        .iter()
        .find(|b| !b.is_ascii_whitespace())
        .is_some_and(|&b| b == b'[');

    let probes: Vec<Probe> = if is_array {
        serde_json::from_slice(bytes).map_err(json_error)?
    } else {
        vec![serde_json::from_slice(bytes).map_err(json_error)?]
    };
    if probes.is_empty() {
        return Err(ForecastError::EmptyDocument { file: None });
    }
    let prefix = |index: usize| {
        if is_array {
            format!("[{index}].")
        } else {
            String::new()
        }
    };
    let mut formats = Vec::with_capacity(probes.len());
    for (index, probe) in probes.iter().enumerate() {
        if let Some(reason) = probe.api_error() {
            let reason = if is_array {
                format!("location {index}: {reason}")
            } else {
                reason
            };
            return Err(ForecastError::ApiError { file: None, reason });
        }
        let format = probe
            .format(hint)
            .map_err(|detail| ForecastError::UnknownFormat {
                file: None,
                detail: format!("{}{detail}", prefix(index)),
            })?;
        formats.push(format);
    }

    let mut deserializer = serde_json::Deserializer::from_slice(bytes);
    let typed = if is_array {
        ArraySeed(&formats).deserialize(&mut deserializer)
    } else {
        LocationSeed(formats[0])
            .deserialize(&mut deserializer)
            .map(|location| vec![location])
    }
    .map_err(json_error)?;

    typed
        .into_iter()
        .enumerate()
        .map(|(index, location)| location.into_forecast(&prefix(index)))
        .collect()
}
