//! ESRI ASCII grid reader (`.asc`), the text format of swisstopo DHM25 and GLOBE extracts.
//!
//! The form (ESRI, "ASCII raster format"; GDAL's `AAIGrid` driver writes the same): header lines
//! `key value` with case-insensitive keys `ncols`, `nrows`, `xllcorner` or `xllcenter`,
//! `yllcorner` or `yllcenter`, `cellsize` (or GDAL's `dx` and `dy` for non-square cells) and an
//! optional `nodata_value`, in any order; then `nrows` lines of `ncols` heights each, north row
//! first. Blank lines are skipped; `\r\n` line ends are fine. A row must sit on one line, so a
//! short or long row is reported on its own line rather than shifting every row after it.

use super::dem::{Dem, DemGrid, check_georeference, check_size, plausible_height};
use super::error::{DemError, DemErrorKind};

/// The header keys, lower case.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Key {
    Ncols,
    Nrows,
    XllCorner,
    XllCenter,
    YllCorner,
    YllCenter,
    Cellsize,
    Dx,
    Dy,
    Nodata,
}

impl Key {
    const ALL: [Key; 10] = [
        Key::Ncols,
        Key::Nrows,
        Key::XllCorner,
        Key::XllCenter,
        Key::YllCorner,
        Key::YllCenter,
        Key::Cellsize,
        Key::Dx,
        Key::Dy,
        Key::Nodata,
    ];

    fn name(self) -> &'static str {
        match self {
            Key::Ncols => "ncols",
            Key::Nrows => "nrows",
            Key::XllCorner => "xllcorner",
            Key::XllCenter => "xllcenter",
            Key::YllCorner => "yllcorner",
            Key::YllCenter => "yllcenter",
            Key::Cellsize => "cellsize",
            Key::Dx => "dx",
            Key::Dy => "dy",
            Key::Nodata => "nodata_value",
        }
    }

    fn parse(token: &str) -> Option<Key> {
        Key::ALL
            .into_iter()
            .find(|key| key.name().eq_ignore_ascii_case(token))
    }

    /// Keys that may not both be given: the corner and centre forms, and `cellsize` with
    /// `dx`/`dy`.
    fn conflicts(self, other: Key) -> bool {
        use Key::*;
        self == other
            || matches!(
                (self, other),
                (XllCorner, XllCenter)
                    | (XllCenter, XllCorner)
                    | (YllCorner, YllCenter)
                    | (YllCenter, YllCorner)
                    | (Cellsize, Dx | Dy)
                    | (Dx | Dy, Cellsize)
            )
    }
}

/// One header value and the line it came from.
#[derive(Debug, Clone, Copy)]
struct Entry {
    key: Key,
    value: f64,
    line: usize,
}

/// The header read so far.
#[derive(Debug, Default)]
struct Header {
    entries: Vec<Entry>,
}

impl Header {
    fn get(&self, key: Key) -> Option<Entry> {
        self.entries.iter().copied().find(|e| e.key == key)
    }

    fn either(&self, a: Key, b: Key) -> Option<Entry> {
        self.get(a).or_else(|| self.get(b))
    }

    fn has_required(&self) -> bool {
        self.get(Key::Ncols).is_some()
            && self.get(Key::Nrows).is_some()
            && self.either(Key::XllCorner, Key::XllCenter).is_some()
            && self.either(Key::YllCorner, Key::YllCenter).is_some()
            && (self.get(Key::Cellsize).is_some()
                || (self.get(Key::Dx).is_some() && self.get(Key::Dy).is_some()))
    }
}

/// Splits a line on whitespace, with each token's byte offset.
fn tokens(line: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut rest = line;
    let mut offset = 0;
    std::iter::from_fn(move || {
        let start = rest.find(|c: char| !c.is_whitespace())?;
        let after = &rest[start..];
        let len = after.find(char::is_whitespace).unwrap_or(after.len());
        let token = &after[..len];
        let token_offset = offset + start;
        offset += start + len;
        rest = &after[len..];
        Some((token_offset, token))
    })
}

/// The 1-based character column of byte offset `offset` in `line`.
fn column(line: &str, offset: usize) -> usize {
    line[..offset].chars().count() + 1
}

/// A token for an error message, cut to 40 characters.
fn shown(token: &str) -> String {
    token.chars().take(40).collect()
}

/// Parses the text of an ESRI ASCII grid.
pub(crate) fn parse(bytes: &[u8]) -> Result<Dem, DemError> {
    let mut header = Header::default();
    let mut data_start = None;
    let mut line_count = 0;
    let mut lines = Vec::new();
    for (index, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let number = index + 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let text = std::str::from_utf8(raw)
            .map_err(|_| DemError::at_line(number, DemErrorKind::NotText))?;
        line_count = number;
        lines.push(text);
        if data_start.is_some() {
            continue;
        }
        let mut words = tokens(text);
        let Some((key_offset, key_token)) = words.next() else {
            continue;
        };
        if !key_token.starts_with(|c: char| c.is_ascii_alphabetic()) {
            data_start = Some(index);
            continue;
        }
        let Some(key) = Key::parse(key_token) else {
            // A row of heights that starts with a word (`nan 1 2`) is a bad number, not a key.
            if header.has_required() && words.nth(1).is_some() {
                data_start = Some(index);
                continue;
            }
            return Err(DemError::at(
                number,
                column(text, key_offset),
                DemErrorKind::UnknownKey {
                    key: shown(key_token),
                },
            ));
        };
        if let Some(first) = header.entries.iter().find(|e| e.key.conflicts(key)) {
            return Err(DemError::at_line(
                number,
                DemErrorKind::DuplicateKey {
                    key: shown(key_token),
                    first_line: first.line,
                },
            ));
        }
        let (Some((value_offset, value_token)), None) = (words.next(), words.next()) else {
            return Err(DemError::at_line(
                number,
                DemErrorKind::HeaderValueCount {
                    key: shown(key_token),
                },
            ));
        };
        let value = parse_header_value(key, value_token).map_err(|expected| {
            DemError::at(
                number,
                column(text, value_offset),
                DemErrorKind::BadNumber {
                    what: format!("`{}`", key.name()),
                    token: shown(value_token),
                    expected,
                },
            )
        })?;
        header.entries.push(Entry {
            key,
            value,
            line: number,
        });
    }
    if header.entries.is_empty() && data_start.is_none() {
        return Err(DemError::at_line(line_count.max(1), DemErrorKind::Empty));
    }
    // Where a missing key is reported: where the heights begin, or the end of the file.
    let header_end = data_start.map_or(line_count, |i| i + 1);
    let required = |key: Key| {
        header.get(key).ok_or_else(|| {
            DemError::at_line(header_end, DemErrorKind::MissingKey { key: key.name() })
        })
    };
    let either = |a: Key, b: Key, both: &'static str| {
        header
            .either(a, b)
            .ok_or_else(|| DemError::at_line(header_end, DemErrorKind::MissingKey { key: both }))
    };
    let ncols_entry = required(Key::Ncols)?;
    let nrows_entry = required(Key::Nrows)?;
    let x = either(Key::XllCorner, Key::XllCenter, "xllcorner/xllcenter")?;
    let y = either(Key::YllCorner, Key::YllCenter, "yllcorner/yllcenter")?;
    let (cell_lon, cell_lat) = match header.get(Key::Cellsize) {
        Some(cellsize) => (cellsize.value, cellsize.value),
        None => (
            either(Key::Dx, Key::Cellsize, "cellsize")?.value,
            either(Key::Dy, Key::Cellsize, "cellsize")?.value,
        ),
    };
    let (ncols, nrows) = (ncols_entry.value as usize, nrows_entry.value as usize);
    check_size(ncols, nrows).map_err(|e| DemError {
        line: Some(ncols_entry.line),
        ..e
    })?;
    // Corner forms name the outer corner; the DEM keeps cell centres.
    let centre = |entry: Entry, corner: Key, cell: f64| {
        entry.value + if entry.key == corner { 0.5 * cell } else { 0.0 }
    };
    let grid = DemGrid {
        lower_left_lon_deg: centre(x, Key::XllCorner, cell_lon),
        lower_left_lat_deg: centre(y, Key::YllCorner, cell_lat),
        cell_lon_deg: cell_lon,
        cell_lat_deg: cell_lat,
    };
    check_georeference(ncols, nrows, &grid).map_err(|e| DemError {
        line: Some(x.line),
        ..e
    })?;
    let nodata = header.get(Key::Nodata).map(|e| e.value);

    // Heights. Capacity is capped so that a header claiming a huge grid cannot allocate more
    // than the file could hold.
    let mut heights = Vec::with_capacity((ncols * nrows).min(bytes.len() / 2 + 1));
    let mut rows = 0;
    for (index, text) in lines
        .iter()
        .enumerate()
        .skip(data_start.unwrap_or(lines.len()))
    {
        let number = index + 1;
        if text.trim().is_empty() {
            continue;
        }
        if rows == nrows {
            return Err(DemError::at_line(
                number,
                DemErrorKind::TooManyRows { expected: nrows },
            ));
        }
        let found = tokens(text).count();
        if found != ncols {
            return Err(DemError::at_line(
                number,
                DemErrorKind::RowLength {
                    row: rows + 1,
                    expected: ncols,
                    found,
                },
            ));
        }
        for (offset, token) in tokens(text) {
            let height = parse_height(token, nodata).map_err(|expected| {
                DemError::at(
                    number,
                    column(text, offset),
                    DemErrorKind::BadNumber {
                        what: "height".into(),
                        token: shown(token),
                        expected,
                    },
                )
            })?;
            heights.push(height);
        }
        rows += 1;
    }
    if rows < nrows {
        return Err(DemError::at_line(
            line_count,
            DemErrorKind::TooFewRows {
                expected: nrows,
                found: rows,
            },
        ));
    }
    Dem::new(ncols, nrows, heights, grid)
}

/// A header value: a whole number for `ncols`/`nrows`, a finite number otherwise.
fn parse_header_value(key: Key, token: &str) -> Result<f64, &'static str> {
    if matches!(key, Key::Ncols | Key::Nrows) {
        return token
            .parse::<u32>()
            .map(f64::from)
            .map_err(|_| "a whole number below 2³²");
    }
    match token.parse::<f64>() {
        Ok(value) if value.is_finite() => Ok(value),
        _ => Err("a finite number"),
    }
}

/// A height in metres; the NODATA value becomes NaN, which [`Dem::new`] fills.
fn parse_height(token: &str, nodata: Option<f64>) -> Result<f32, &'static str> {
    let value = token
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or("a finite number")?;
    if nodata == Some(value) {
        return Ok(f32::NAN);
    }
    let height = value as f32;
    if plausible_height(height) {
        Ok(height)
    } else {
        Err("a height from −12000 to 10000 m (an undeclared NODATA value?)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = "ncols 4\nnrows 3\nxllcorner 7.0\nyllcorner 46.0\ncellsize 0.1\n\
                         NODATA_value -9999\n1 2 3 4\n5 -9999 7 8\n9 10 11 12\n";

    fn parse_str(text: &str) -> Result<Dem, DemError> {
        parse(text.as_bytes())
    }

    #[test]
    fn reads_a_small_grid() {
        let dem = parse_str(SMALL).unwrap();
        assert_eq!((dem.ncols(), dem.nrows()), (4, 3));
        // Corner form: the lower-left centre is half a cell in.
        let grid = dem.grid();
        assert!((grid.lower_left_lon_deg - 7.05).abs() < 1e-12);
        assert!((grid.lower_left_lat_deg - 46.05).abs() < 1e-12);
        assert_eq!(dem.height(0, 0), Some(1.0));
        assert_eq!(dem.height(3, 2), Some(12.0));
        // NODATA filled with the mean of its 8 neighbours.
        assert_eq!(dem.filled_cells(), 1);
        let mean = (1.0 + 2.0 + 3.0 + 5.0 + 7.0 + 9.0 + 10.0 + 11.0) / 8.0;
        assert_eq!(dem.height(1, 1), Some(mean));
        // South-west centre holds the first value of the last row.
        assert_eq!(dem.height_at(46.05, 7.05), Some(9.0));
    }

    #[test]
    fn keys_are_case_insensitive_in_any_order_with_centre_forms_and_crlf() {
        let text = "NROWS 2\r\nXLLCENTER 7.0\r\nnCols 2\r\nYllCenter 46\r\nCELLSIZE 0.5\r\n\
                    \r\n1.5 2.5\r\n3.5 4.5\r\n\r\n";
        let dem = parse_str(text).unwrap();
        assert_eq!(dem.grid().lower_left_lon_deg, 7.0);
        assert_eq!(dem.grid().lower_left_lat_deg, 46.0);
        assert_eq!(dem.height_at(46.0, 7.0), Some(3.5));
    }

    #[test]
    fn gdal_dx_dy_give_rectangular_cells() {
        let text = "ncols 2\nnrows 2\nxllcorner 7\nyllcorner 46\ndx 0.2\ndy 0.1\n1 2\n3 4\n";
        let dem = parse_str(text).unwrap();
        assert_eq!(dem.grid().cell_lon_deg, 0.2);
        assert_eq!(dem.grid().cell_lat_deg, 0.1);
    }

    /// Parses `text`, expecting an error at `line` (and `column`), and returns its kind.
    fn error_at(text: &str, line: usize, column: Option<usize>) -> DemErrorKind {
        let err = parse_str(text).unwrap_err();
        assert_eq!(err.line, Some(line), "{err}");
        assert_eq!(err.column, column, "{err}");
        err.kind
    }

    #[test]
    fn missing_key_is_named_where_the_heights_begin() {
        let text = "ncols 2\nnrows 1\nxllcorner 7\ncellsize 0.1\n1 2\n";
        assert_eq!(
            error_at(text, 5, None),
            DemErrorKind::MissingKey {
                key: "yllcorner/yllcenter"
            }
        );
        let text = "ncols 2\nnrows 1\nxllcorner 7\nyllcorner 46\n1 2\n";
        assert_eq!(
            error_at(text, 5, None),
            DemErrorKind::MissingKey { key: "cellsize" }
        );
    }

    #[test]
    fn bad_numbers_name_line_column_and_key() {
        let text = SMALL.replace("cellsize 0.1", "cellsize 0.1x");
        let kind = error_at(&text, 5, Some(10));
        assert_eq!(
            kind,
            DemErrorKind::BadNumber {
                what: "`cellsize`".into(),
                token: "0.1x".into(),
                expected: "a finite number"
            }
        );
        let text = SMALL.replace("5 -9999 7 8", "5 -9999 seven 8");
        let kind = error_at(&text, 8, Some(9));
        assert!(matches!(kind, DemErrorKind::BadNumber { ref token, .. } if token == "seven"));
        let text = SMALL.replace("ncols 4", "ncols 4.0");
        assert!(matches!(
            error_at(&text, 1, Some(7)),
            DemErrorKind::BadNumber { .. }
        ));
        let text = SMALL.replace("9 10 11 12", "nan 10 11 12");
        assert!(matches!(
            error_at(&text, 9, Some(1)),
            DemErrorKind::BadNumber { ref token, .. } if token == "nan"
        ));
        let text = SMALL.replace("9 10 11 12", "9 10 1e400 12");
        assert!(matches!(
            error_at(&text, 9, Some(6)),
            DemErrorKind::BadNumber { .. }
        ));
    }

    #[test]
    fn wrong_row_length_and_count() {
        let text = SMALL.replace("5 -9999 7 8", "5 -9999 7");
        assert_eq!(
            error_at(&text, 8, None),
            DemErrorKind::RowLength {
                row: 2,
                expected: 4,
                found: 3
            }
        );
        let text = format!("{SMALL}13 14 15 16\n");
        assert_eq!(
            error_at(&text, 10, None),
            DemErrorKind::TooManyRows { expected: 3 }
        );
        let text = SMALL.replace("9 10 11 12\n", "");
        assert_eq!(
            error_at(&text, 9, None),
            DemErrorKind::TooFewRows {
                expected: 3,
                found: 2
            }
        );
    }

    #[test]
    fn header_faults() {
        let text = SMALL.replace("nrows 3", "nrows 3\nxllcenter 7");
        assert_eq!(
            error_at(&text, 4, None),
            DemErrorKind::DuplicateKey {
                key: "xllcorner".into(),
                first_line: 3
            }
        );
        let text = SMALL.replace("nrows 3", "nrows 3\nbyteorder LSBFIRST");
        assert_eq!(
            error_at(&text, 3, Some(1)),
            DemErrorKind::UnknownKey {
                key: "byteorder".into()
            }
        );
        let text = SMALL.replace("nrows 3", "nrows");
        assert_eq!(
            error_at(&text, 2, None),
            DemErrorKind::HeaderValueCount {
                key: "nrows".into()
            }
        );
        let text = SMALL.replace("ncols 4", "ncols 0");
        assert!(matches!(
            error_at(&text, 1, None),
            DemErrorKind::InvalidHeader { key: "ncols", .. }
        ));
        let text = SMALL.replace("cellsize 0.1", "cellsize -0.1");
        assert!(matches!(
            error_at(&text, 3, None),
            DemErrorKind::InvalidHeader {
                key: "cellsize",
                ..
            }
        ));
        // Swiss LV95 metres are not degrees.
        let text = SMALL
            .replace("xllcorner 7.0", "xllcorner 2600000")
            .replace("yllcorner 46.0", "yllcorner 1200000")
            .replace("cellsize 0.1", "cellsize 25");
        assert!(matches!(
            error_at(&text, 3, None),
            DemErrorKind::NotGeographic { .. }
        ));
        assert_eq!(error_at("", 1, None), DemErrorKind::Empty);
        assert_eq!(error_at("\n\n  \n", 4, None), DemErrorKind::Empty);
        assert_eq!(
            error_at("ncols 1\n\u{ff}\n", 2, None),
            DemErrorKind::MissingKey { key: "nrows" }
        );
        let err = parse(b"ncols 1\n\xff\n").unwrap_err();
        assert_eq!((err.line, err.kind), (Some(2), DemErrorKind::NotText));
    }

    #[test]
    fn huge_header_does_not_allocate() {
        let text =
            "ncols 4000000000\nnrows 4000000000\nxllcorner 7\nyllcorner 46\ncellsize 0.1\n1\n";
        assert!(matches!(
            error_at(text, 1, None),
            DemErrorKind::TooLarge { .. }
        ));
        let text = "ncols 16000\nnrows 16000\nxllcorner 7\nyllcorner 46\ncellsize 1e-5\n1\n";
        assert!(matches!(
            error_at(text, 6, None),
            DemErrorKind::RowLength { found: 1, .. }
        ));
    }

    /// A small deterministic generator (xorshift64*, Vigna 2016) so the mutations repeat.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
        }

        fn below(&mut self, n: usize) -> usize {
            (self.next() % n.max(1) as u64) as usize
        }
    }

    #[test]
    fn random_mutations_never_panic() {
        // Bytes a mutation likes to insert: digits, signs, exponents, separators, key letters.
        const INTERESTING: &[u8] = b"0123456789-+.eE \t\r\n\x00\xffnNaAiIfF_xX";
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let base = SMALL.as_bytes();
        let mut ok = 0;
        for _ in 0..20_000 {
            let mut bytes = base.to_vec();
            for _ in 0..1 + rng.below(4) {
                let at = rng.below(bytes.len() + 1);
                match rng.below(5) {
                    0 if at < bytes.len() => bytes[at] = rng.next() as u8,
                    1 if at < bytes.len() => {
                        bytes[at] = INTERESTING[rng.below(INTERESTING.len())];
                    }
                    2 => bytes.insert(at, INTERESTING[rng.below(INTERESTING.len())]),
                    3 if at < bytes.len() => {
                        bytes.remove(at);
                    }
                    _ => {
                        // Duplicate a run, e.g. a whole line or a run of digits.
                        let len = rng.below(12).min(bytes.len() - at.min(bytes.len()));
                        let run: Vec<u8> = bytes[at..at + len].to_vec();
                        let to = rng.below(bytes.len() + 1);
                        bytes.splice(to..to, run);
                    }
                }
            }
            if let Ok(dem) = parse(&bytes) {
                ok += 1;
                assert!(dem.heights_m().iter().all(|h| h.is_finite()));
                assert_eq!(dem.heights_m().len(), dem.ncols() * dem.nrows());
            }
        }
        // Some mutations (e.g. a changed digit in a height) leave a valid file.
        assert!(ok > 100, "{ok}");
    }
}
