//! Typed errors for forecast files.
//!
//! Every variant names the file (once [`Forecast::from_path`](super::Forecast::from_path) or
//! [`ForecastError::with_file`] has set it), the JSON key as a dotted path (`data_1h.lowclouds`,
//! `[1].hourly.time` inside a multi-location array) and the array index where one applies, so that
//! one line on stderr is enough to find the fault in the file.

use std::fmt;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::scene::UtcInstant;

/// Why a forecast file could not be turned into a [`Forecast`](super::Forecast).
///
/// `Display` gives one line: `FILE: key `KEY` index N: what is wrong`. Bad files never panic the
/// parser; the caller keeps its last good forecast and shows this message.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum ForecastError {
    /// The file could not be read.
    #[error("{}cannot read the file: {message}", FilePrefix(file))]
    Io {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The operating system's message.
        message: String,
    },
    /// The text is not valid JSON, or a value has the wrong JSON type for its key.
    #[error(
        "{}broken JSON at line {line}, column {column}{}: {message}",
        FilePrefix(file),
        JsonPathSuffix(path)
    )]
    Json {
        /// The file, when known.
        file: Option<PathBuf>,
        /// Line of the fault, counted from 1.
        line: usize,
        /// Column of the fault, counted from 1.
        column: usize,
        /// Where in the document the fault lies, e.g. `data_1h.lowclouds[3]`, when it could be
        /// worked out.
        path: Option<String>,
        /// The JSON parser's description.
        message: String,
    },
    /// A `NaN` or `Infinity` literal, which JSON does not allow (Python's `json.dump` writes them).
    #[error(
        "{}{}: NaN or Infinity at line {line}, column {column} is not JSON; write null for a missing value",
        FilePrefix(file),
        KeyIndex(key, *index)
    )]
    NonFiniteLiteral {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The key holding the literal.
        key: String,
        /// The array index of the literal.
        index: Option<usize>,
        /// Line of the literal, counted from 1.
        line: usize,
        /// Column of the literal, counted from 1.
        column: usize,
    },
    /// The file is an API error response (Open-Meteo `{"error": true, "reason": …}` or
    /// meteoblue's `error_message`) rather than data.
    #[error(
        "{}the weather service answered with an error: {reason}",
        FilePrefix(file)
    )]
    ApiError {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The service's `reason` text.
        reason: String,
    },
    /// Neither meteoblue (`metadata`, `data_1h`) nor Open-Meteo (`hourly`) keys were found, or
    /// the format asked for does not match the file.
    #[error("{}not a meteoblue or Open-Meteo forecast: {detail}", FilePrefix(file))]
    UnknownFormat {
        /// The file, when known.
        file: Option<PathBuf>,
        /// What was looked for.
        detail: String,
    },
    /// A multi-location file (JSON array) with no locations in it.
    #[error("{}the file holds an empty array of locations", FilePrefix(file))]
    EmptyDocument {
        /// The file, when known.
        file: Option<PathBuf>,
    },
    /// A key the format requires is absent (or `null`).
    #[error("{}key `{key}` is missing", FilePrefix(file))]
    MissingKey {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The missing key.
        key: String,
    },
    /// A variable's array is not as long as its block's `time` array.
    #[error(
        "{}key `{key}`: {found} values but `time` has {expected}",
        FilePrefix(file)
    )]
    LengthMismatch {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The variable whose length is wrong.
        key: String,
        /// Length of the block's `time` array.
        expected: usize,
        /// Length of this variable's array.
        found: usize,
    },
    /// A unit string this crate cannot convert to SI.
    #[error("{}key `{key}`: unknown unit \"{unit}\"", FilePrefix(file))]
    UnknownUnit {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The unit's key, e.g. `units.windspeed` or `hourly_units.wind_speed_10m`.
        key: String,
        /// The unit as written in the file.
        unit: String,
    },
    /// The `time` array is empty, so there is nothing to sample.
    #[error("{}key `{key}`: the time array is empty", FilePrefix(file))]
    EmptyTime {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The `time` key.
        key: String,
    },
    /// A time stamp is earlier than the one before it.
    #[error(
        "{}{}: time {found} is earlier than the previous {previous}; times must increase",
        FilePrefix(file),
        KeyIndex(key, Some(*index))
    )]
    TimesNotIncreasing {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The `time` key.
        key: String,
        /// Index of the offending stamp.
        index: usize,
        /// The stamp before it, in UTC.
        previous: UtcInstant,
        /// The offending stamp, in UTC.
        found: UtcInstant,
    },
    /// A time stamp equals the one before it.
    #[error("{}{}: time {time} appears twice", FilePrefix(file), KeyIndex(key, Some(*index)))]
    DuplicateTime {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The `time` key.
        key: String,
        /// Index of the second occurrence.
        index: usize,
        /// The repeated stamp, in UTC.
        time: UtcInstant,
    },
    /// A time stamp that cannot be read.
    #[error(
        "{}{}: cannot read time \"{value}\": {reason}",
        FilePrefix(file),
        KeyIndex(key, Some(*index))
    )]
    BadTime {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The `time` key.
        key: String,
        /// Index of the stamp.
        index: usize,
        /// The stamp as written (`null` for a null).
        value: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A cloud cover that is negative or not a number.
    #[error(
        "{}{}: cloud cover {value} % is negative or not a number",
        FilePrefix(file),
        KeyIndex(key, Some(*index))
    )]
    InvalidCover {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The cover variable.
        key: String,
        /// Index of the value.
        index: usize,
        /// The value as written, in percent.
        value: f64,
    },
    /// A cloud cover above 100 %.
    #[error(
        "{}{}: cloud cover {value} % is above 100 %",
        FilePrefix(file),
        KeyIndex(key, Some(*index))
    )]
    CoverAbove100 {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The cover variable.
        key: String,
        /// Index of the value.
        index: usize,
        /// The value as written, in percent.
        value: f64,
    },
    /// Any other value outside its physical range (negative precipitation, humidity above 100 %,
    /// latitude beyond ±90°, …).
    #[error(
        "{}{}: value {value} is out of range (expected {expected})",
        FilePrefix(file),
        KeyIndex(key, *index)
    )]
    OutOfRange {
        /// The file, when known.
        file: Option<PathBuf>,
        /// The variable or metadata key.
        key: String,
        /// Index of the value in its array, `None` for a scalar.
        index: Option<usize>,
        /// The value as written in the file's units.
        value: f64,
        /// The allowed range, in the file's units.
        expected: &'static str,
    },
}

impl ForecastError {
    /// The file this error is about, once known.
    #[must_use]
    pub fn file(&self) -> Option<&Path> {
        self.file_slot_ref().map(PathBuf::as_path)
    }

    /// The same error, naming `file`. [`Forecast::from_path`](super::Forecast::from_path) calls
    /// this; call it yourself when reading through [`Forecast::from_reader`](super::Forecast::from_reader).
    #[must_use]
    pub fn with_file(mut self, file: impl Into<PathBuf>) -> Self {
        *self.file_slot() = Some(file.into());
        self
    }

    /// The JSON key (dotted path, e.g. `data_1h.lowclouds` or `[1].hourly.time`) the error is
    /// about, if it is about one; the array index is [`ForecastError::index`].
    #[must_use]
    pub fn key(&self) -> Option<&str> {
        match self {
            // The path without its trailing `[i]`, which `index()` reports.
            Self::Json { path, .. } => path.as_deref().map(|path| {
                last_index(path)
                    .and_then(|_| path.rfind('['))
                    .map_or(path, |open| &path[..open])
            }),
            Self::NonFiniteLiteral { key, .. }
            | Self::MissingKey { key, .. }
            | Self::LengthMismatch { key, .. }
            | Self::UnknownUnit { key, .. }
            | Self::EmptyTime { key, .. }
            | Self::TimesNotIncreasing { key, .. }
            | Self::DuplicateTime { key, .. }
            | Self::BadTime { key, .. }
            | Self::InvalidCover { key, .. }
            | Self::CoverAbove100 { key, .. }
            | Self::OutOfRange { key, .. } => Some(key),
            Self::Io { .. }
            | Self::ApiError { .. }
            | Self::UnknownFormat { .. }
            | Self::EmptyDocument { .. } => None,
        }
    }

    /// The array index the error is about, if it is about one.
    #[must_use]
    pub fn index(&self) -> Option<usize> {
        match self {
            Self::Json { path, .. } => path.as_deref().and_then(last_index),
            Self::NonFiniteLiteral { index, .. } | Self::OutOfRange { index, .. } => *index,
            Self::TimesNotIncreasing { index, .. }
            | Self::DuplicateTime { index, .. }
            | Self::BadTime { index, .. }
            | Self::InvalidCover { index, .. }
            | Self::CoverAbove100 { index, .. } => Some(*index),
            _ => None,
        }
    }

    fn file_slot(&mut self) -> &mut Option<PathBuf> {
        match self {
            Self::Io { file, .. }
            | Self::Json { file, .. }
            | Self::NonFiniteLiteral { file, .. }
            | Self::ApiError { file, .. }
            | Self::UnknownFormat { file, .. }
            | Self::EmptyDocument { file }
            | Self::MissingKey { file, .. }
            | Self::LengthMismatch { file, .. }
            | Self::UnknownUnit { file, .. }
            | Self::EmptyTime { file, .. }
            | Self::TimesNotIncreasing { file, .. }
            | Self::DuplicateTime { file, .. }
            | Self::BadTime { file, .. }
            | Self::InvalidCover { file, .. }
            | Self::CoverAbove100 { file, .. }
            | Self::OutOfRange { file, .. } => file,
        }
    }

    fn file_slot_ref(&self) -> Option<&PathBuf> {
        match self {
            Self::Io { file, .. }
            | Self::Json { file, .. }
            | Self::NonFiniteLiteral { file, .. }
            | Self::ApiError { file, .. }
            | Self::UnknownFormat { file, .. }
            | Self::EmptyDocument { file }
            | Self::MissingKey { file, .. }
            | Self::LengthMismatch { file, .. }
            | Self::UnknownUnit { file, .. }
            | Self::EmptyTime { file, .. }
            | Self::TimesNotIncreasing { file, .. }
            | Self::DuplicateTime { file, .. }
            | Self::BadTime { file, .. }
            | Self::InvalidCover { file, .. }
            | Self::CoverAbove100 { file, .. }
            | Self::OutOfRange { file, .. } => file.as_ref(),
        }
    }

    /// Converts a `serde_json` error on `bytes` into [`ForecastError::Json`], or
    /// [`ForecastError::NonFiniteLiteral`] when the fault is a `NaN`/`Infinity` literal.
    pub(crate) fn from_json(error: &serde_json::Error, bytes: &[u8]) -> Self {
        let (line, column) = (error.line(), error.column());
        let offset = byte_offset(bytes, line, column);
        let located = offset.map(|offset| (offset, locate(bytes, offset)));
        if let Some((offset, location)) = &located
            && starts_non_finite_literal(bytes, *offset)
        {
            return Self::NonFiniteLiteral {
                file: None,
                key: location.key.clone(),
                index: location.index,
                line,
                column,
            };
        }
        // serde_json appends " at line L column C"; the variant carries those separately.
        let text = error.to_string();
        let suffix = format!(" at line {line} column {column}");
        let message = text.strip_suffix(&suffix).unwrap_or(&text).to_owned();
        Self::Json {
            file: None,
            line,
            column,
            path: located.and_then(|(_, location)| location.render()),
            message,
        }
    }
}

/// Formats the `FILE: ` prefix, or nothing when the file is unknown.
struct FilePrefix<'a>(&'a Option<PathBuf>);

impl fmt::Display for FilePrefix<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(path) => write!(f, "{}: ", path.display()),
            None => Ok(()),
        }
    }
}

/// Formats `key `K` index I`.
struct KeyIndex<'a>(&'a str, Option<usize>);

impl fmt::Display for KeyIndex<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "key `{}`", self.0)?;
        match self.1 {
            Some(index) => write!(f, " index {index}"),
            None => Ok(()),
        }
    }
}

/// Formats ` (at `path`)` when a path is known.
struct JsonPathSuffix<'a>(&'a Option<String>);

impl fmt::Display for JsonPathSuffix<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(path) => write!(f, " (at `{path}`)"),
            None => Ok(()),
        }
    }
}

/// The index in a rendered path's last `[i]`, if the path ends with one.
fn last_index(path: &str) -> Option<usize> {
    let inner = path.strip_suffix(']')?;
    let open = inner.rfind('[')?;
    inner[open + 1..].parse().ok()
}

/// Byte offset of `serde_json`'s (line, column), both counted from 1; the column counts bytes.
fn byte_offset(bytes: &[u8], line: usize, column: usize) -> Option<usize> {
    if line == 0 {
        return None;
    }
    let mut line_start = 0;
    if line > 1 {
        let mut newlines = 0;
        let position = bytes.iter().position(|&b| {
            newlines += usize::from(b == b'\n');
            newlines == line - 1
        })?;
        line_start = position + 1;
    }
    Some((line_start + column.saturating_sub(1)).min(bytes.len()))
}

/// Does a `NaN`, `Infinity` or `-Infinity` literal start at, or up to two bytes before, `offset`?
///
/// `serde_json` reports the byte it stopped at, which is the literal's first or second byte.
fn starts_non_finite_literal(bytes: &[u8], offset: usize) -> bool {
    const LITERALS: [&[u8]; 3] = [b"NaN", b"Infinity", b"-Infinity"];
    (offset.saturating_sub(2)..=offset).any(|start| {
        let rest = &bytes[start.min(bytes.len())..];
        LITERALS.iter().any(|literal| rest.starts_with(literal))
    })
}

/// A key as it may be shown in a one-line message: control characters escaped, at most 64
/// characters (a broken file can make a "key" of anything).
fn printable_key(raw: &[u8]) -> String {
    let text = String::from_utf8_lossy(raw);
    let mut key = String::new();
    for (count, character) in text.chars().enumerate() {
        if count == 64 {
            key.push('…');
            break;
        }
        if character.is_control() {
            key.extend(character.escape_default());
        } else {
            key.push(character);
        }
    }
    key
}

/// Where a byte offset lies in a JSON document.
#[derive(Debug, Default, PartialEq)]
struct Location {
    /// Rendered frames, outermost first: `Key("data_1h")`, `Index(3)`.
    frames: Vec<Frame>,
    /// Dotted key path without a trailing index, e.g. `data_1h.lowclouds`.
    key: String,
    /// The innermost array index, if the offset is inside an array.
    index: Option<usize>,
}

#[derive(Debug, PartialEq)]
enum Frame {
    Key(String),
    Index(usize),
}

impl Location {
    fn render(&self) -> Option<String> {
        if self.frames.is_empty() {
            return None;
        }
        let mut text = String::new();
        for frame in &self.frames {
            match frame {
                Frame::Key(key) => {
                    if !text.is_empty() {
                        text.push('.');
                    }
                    text.push_str(key);
                }
                Frame::Index(index) => {
                    text.push('[');
                    text.push_str(&index.to_string());
                    text.push(']');
                }
            }
        }
        Some(text)
    }
}

/// Works out the key path at `offset` by scanning the document from the start.
///
/// `serde_json` stops at the first fault, so everything before `offset` is valid JSON and a simple
/// forward scan that tracks open objects (with their current key) and arrays (with the count of
/// commas seen) is exact.
fn locate(bytes: &[u8], offset: usize) -> Location {
    enum Open {
        Object { key: Option<String> },
        Array { index: usize },
    }
    let mut stack: Vec<Open> = Vec::new();
    let mut position = 0;
    let end = offset.min(bytes.len());
    while position < end {
        match bytes[position] {
            b'{' => stack.push(Open::Object { key: None }),
            b'[' => stack.push(Open::Array { index: 0 }),
            b'}' | b']' => {
                stack.pop();
            }
            b',' => match stack.last_mut() {
                Some(Open::Array { index }) => *index += 1,
                Some(Open::Object { key }) => *key = None,
                None => {}
            },
            b'"' => {
                let start = position + 1;
                position = start;
                while position < end && bytes[position] != b'"' {
                    position += if bytes[position] == b'\\' { 2 } else { 1 };
                }
                if let Some(Open::Object { key }) = stack.last_mut()
                    && key.is_none()
                {
                    let raw = &bytes[start..position.min(end)];
                    *key = Some(printable_key(raw));
                }
            }
            _ => {}
        }
        position += 1;
    }

    let mut location = Location::default();
    let mut keys: Vec<&str> = Vec::new();
    for open in &stack {
        match open {
            Open::Object { key: Some(key) } => {
                location.frames.push(Frame::Key(key.clone()));
                keys.push(key);
                location.index = None;
            }
            Open::Object { key: None } => {}
            Open::Array { index } => {
                location.frames.push(Frame::Index(*index));
                location.index = Some(*index);
            }
        }
    }
    // The key path keeps array indices that sit between keys (`[1].hourly.time`) but not the
    // innermost one, which is reported as the index.
    let mut key = String::new();
    let last_key_frame = location
        .frames
        .iter()
        .rposition(|frame| matches!(frame, Frame::Key(_)));
    for (i, frame) in location.frames.iter().enumerate() {
        if last_key_frame.is_none_or(|last| i > last) {
            break;
        }
        match frame {
            Frame::Key(name) => {
                if !key.is_empty() {
                    key.push('.');
                }
                key.push_str(name);
            }
            Frame::Index(index) => {
                key.push('[');
                key.push_str(&index.to_string());
                key.push(']');
            }
        }
    }
    if last_key_frame.is_some_and(|last| last + 1 == location.frames.len()) {
        location.index = None;
    }
    location.key = key;
    location
}

#[cfg(test)]
mod tests {
    use super::*;

    fn json_error(text: &str) -> ForecastError {
        let error = serde_json::from_str::<serde_json::Value>(text).unwrap_err();
        ForecastError::from_json(&error, text.as_bytes())
    }

    #[test]
    fn locates_keys_and_indices() {
        let text = r#"{"data_1h": {"time": ["a", "b"], "lowclouds": [30, 40, "#;
        let location = locate(text.as_bytes(), text.len());
        assert_eq!(location.key, "data_1h.lowclouds");
        assert_eq!(location.index, Some(2));
        assert_eq!(location.render().as_deref(), Some("data_1h.lowclouds[2]"));

        let text = r#"[{"hourly": {}}, {"hourly": {"time": ["#;
        let location = locate(text.as_bytes(), text.len());
        assert_eq!(location.key, "[1].hourly.time");
        assert_eq!(location.index, Some(0));

        let text = r#"{"metadata": {"name": "a,b\"c", "latitude": "#;
        let location = locate(text.as_bytes(), text.len());
        assert_eq!(location.key, "metadata.latitude");
        assert_eq!(location.index, None);
    }

    #[test]
    fn bare_nan_names_key_and_index() {
        let error = json_error("{\n \"data_1h\": {\"lowclouds\": [30, NaN, 20]}\n}");
        assert!(
            matches!(
                &error,
                ForecastError::NonFiniteLiteral { key, index: Some(1), line: 2, .. }
                    if key == "data_1h.lowclouds"
            ),
            "{error:?}"
        );
        assert_eq!(error.key(), Some("data_1h.lowclouds"));
        assert_eq!(error.index(), Some(1));
        let error = json_error(r#"{"x": [-Infinity]}"#);
        assert!(matches!(
            error,
            ForecastError::NonFiniteLiteral { index: Some(0), .. }
        ));
    }

    #[test]
    fn broken_json_reports_line_column_and_path() {
        let error =
            json_error("{\n  \"data_1h\": {\n    \"time\": [\"2021-05-03 00:00\" \"x\"]\n  }\n}");
        let ForecastError::Json {
            line,
            path,
            message,
            ..
        } = &error
        else {
            panic!("{error:?}");
        };
        assert_eq!(*line, 3);
        assert_eq!(path.as_deref(), Some("data_1h.time[0]"));
        assert!(!message.contains("at line"), "{message}");
        let text = error.with_file("bern.json").to_string();
        assert!(
            text.starts_with("bern.json: broken JSON at line 3"),
            "{text}"
        );
        assert!(text.contains("`data_1h.time[0]`"), "{text}");
    }

    #[test]
    fn display_names_file_key_and_index() {
        let error = ForecastError::CoverAbove100 {
            file: None,
            key: "data_1h.lowclouds".into(),
            index: 7,
            value: 101.0,
        }
        .with_file("assets/weather/bern.json");
        assert_eq!(
            error.to_string(),
            "assets/weather/bern.json: key `data_1h.lowclouds` index 7: cloud cover 101 % is above 100 %"
        );
        assert_eq!(error.file(), Some(Path::new("assets/weather/bern.json")));
        assert_eq!(error.index(), Some(7));
        let error = ForecastError::MissingKey {
            file: None,
            key: "metadata.latitude".into(),
        };
        assert_eq!(error.to_string(), "key `metadata.latitude` is missing");
    }

    #[test]
    fn keys_in_messages_stay_on_one_line() {
        assert_eq!(printable_key(b"data\n_1h"), "data\\n_1h");
        assert_eq!(printable_key(&[b'k'; 100]).chars().count(), 65);
    }

    #[test]
    fn last_index_parses_paths() {
        assert_eq!(last_index("a.b[12]"), Some(12));
        assert_eq!(last_index("a.b"), None);
        assert_eq!(last_index("[3]"), Some(3));
    }
}
