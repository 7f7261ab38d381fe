//! Typed errors for elevation files and terrain meshes.

use std::fmt;
use std::path::{Path, PathBuf};

use thiserror::Error;

/// Why an elevation file could not be read into a [`Dem`](super::Dem).
///
/// `Display` gives one line, `FILE: line L, column C: what is wrong`, with the parts that are
/// known: the file once [`Dem::from_path`](super::Dem::from_path) or [`DemError::with_file`] has
/// set it, the line and column (counted from 1) for text formats. Bad files never panic the
/// readers.
#[derive(Clone, Debug, Error, PartialEq)]
#[error("{}{}{kind}", FilePrefix(file), LinePrefix(*line, *column))]
pub struct DemError {
    /// The file, when known.
    pub file: Option<PathBuf>,
    /// Line of the fault, counted from 1 (text formats only).
    pub line: Option<usize>,
    /// Column of the fault, counted from 1 in characters, where one applies.
    pub column: Option<usize>,
    /// What is wrong.
    pub kind: DemErrorKind,
}

impl DemError {
    /// An error with no file, line or column yet.
    pub fn new(kind: DemErrorKind) -> Self {
        Self {
            file: None,
            line: None,
            column: None,
            kind,
        }
    }

    /// An error at `line` (counted from 1).
    pub(crate) fn at_line(line: usize, kind: DemErrorKind) -> Self {
        Self {
            line: Some(line),
            ..Self::new(kind)
        }
    }

    /// An error at `line` and `column` (both counted from 1).
    pub(crate) fn at(line: usize, column: usize, kind: DemErrorKind) -> Self {
        Self {
            line: Some(line),
            column: Some(column),
            ..Self::new(kind)
        }
    }

    /// Names the file the error came from.
    pub fn with_file(mut self, file: impl AsRef<Path>) -> Self {
        self.file = Some(file.as_ref().to_path_buf());
        self
    }
}

/// The ways an elevation file can be wrong; see [`DemError`] for where.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum DemErrorKind {
    /// The file could not be read.
    #[error("cannot read the file: {message}")]
    Io {
        /// The operating system's message.
        message: String,
    },
    /// The bytes of a text format are not UTF-8 text.
    #[error("not text (invalid UTF-8)")]
    NotText,
    /// The file has no header at all.
    #[error("empty file: expected an ESRI ASCII grid header (`ncols`, `nrows`, …)")]
    Empty,
    /// A required header key is missing; the line is where the heights begin.
    #[error("header has no `{key}`")]
    MissingKey {
        /// The key, lower case; alternatives joined with `/`, e.g. `xllcorner/xllcenter`.
        key: &'static str,
    },
    /// A header key appears twice (or both the corner and the centre form are given).
    #[error("header key `{key}` given again (first at line {first_line})")]
    DuplicateKey {
        /// The key as written.
        key: String,
        /// Where it was first given.
        first_line: usize,
    },
    /// A header line whose key is not an ESRI ASCII grid key.
    #[error(
        "unknown header key `{key}` (expected ncols, nrows, xllcorner/xllcenter, \
         yllcorner/yllcenter, cellsize, nodata_value)"
    )]
    UnknownKey {
        /// The key as written.
        key: String,
    },
    /// A header key without a value, or with more than one.
    #[error("header key `{key}` needs exactly one value")]
    HeaderValueCount {
        /// The key as written.
        key: String,
    },
    /// A value that is not a (finite) number of the expected kind.
    #[error("{what}: `{token}` is not {expected}")]
    BadNumber {
        /// What the value is: a header key, or `height`.
        what: String,
        /// The text as written (cut to 40 characters).
        token: String,
        /// What was expected, e.g. `a finite number`.
        expected: &'static str,
    },
    /// A header value out of its range, e.g. `cellsize 0`.
    #[error("`{key}` {reason}")]
    InvalidHeader {
        /// The key.
        key: &'static str,
        /// Why the value is not usable.
        reason: String,
    },
    /// Coordinates that are not longitude/latitude in degrees (e.g. Swiss LV95 metres).
    #[error(
        "georeference {detail}: only geographic longitude/latitude in degrees (e.g. WGS 84) is \
         supported; reproject projected grids such as Swiss LV95 first (e.g. `gdalwarp -t_srs \
         EPSG:4326`)"
    )]
    NotGeographic {
        /// What gave it away.
        detail: String,
    },
    /// A row of heights with the wrong number of values.
    #[error("row {row} has {found} values, expected {expected} (ncols)")]
    RowLength {
        /// The row, counted from 1 at the north edge.
        row: usize,
        /// `ncols`.
        expected: usize,
        /// Values on the line.
        found: usize,
    },
    /// More rows of heights than `nrows`; the line is the first extra one.
    #[error("more than {expected} rows of heights (nrows)")]
    TooManyRows {
        /// `nrows`.
        expected: usize,
    },
    /// Fewer rows of heights than `nrows`; the line is the file's last.
    #[error("only {found} rows of heights, expected {expected} (nrows)")]
    TooFewRows {
        /// `nrows`.
        expected: usize,
        /// Rows found.
        found: usize,
    },
    /// A height that cannot be an elevation in metres, most likely an undeclared NODATA value.
    #[error(
        "height {value} m at column {column}, row {row} is outside {min}…{max} m; \
         an undeclared NODATA value?",
        min = super::MIN_HEIGHT_M,
        max = super::MAX_HEIGHT_M
    )]
    HeightOutOfRange {
        /// Column, counted from 1 at the west edge.
        column: usize,
        /// Row, counted from 1 at the north edge.
        row: usize,
        /// The height, metres.
        value: f32,
    },
    /// Every cell is NODATA, so there is nothing to fill the gaps from.
    #[error("every cell is NODATA")]
    NoValidData,
    /// The grid is larger than a DEM this crate will hold.
    #[error("{ncols} × {nrows} cells is more than the {max} cells supported")]
    TooLarge {
        /// Columns.
        ncols: usize,
        /// Rows.
        nrows: usize,
        /// The limit, [`MAX_DEM_CELLS`](super::MAX_DEM_CELLS).
        max: usize,
    },
    /// The heights given to [`Dem::new`](super::Dem::new) do not match its size.
    #[error("{found} heights for a {ncols} × {nrows} grid")]
    SizeMismatch {
        /// Columns.
        ncols: usize,
        /// Rows.
        nrows: usize,
        /// Heights given.
        found: usize,
    },
    /// The TIFF decoder failed (broken or truncated file, unsupported compression).
    #[error("TIFF: {message}")]
    Tiff {
        /// The decoder's message.
        message: String,
    },
    /// A valid TIFF whose layout is not a single-band elevation raster.
    #[error("unsupported GeoTIFF layout: {detail}")]
    UnsupportedLayout {
        /// What is unsupported.
        detail: String,
    },
    /// A `GeoTIFF` without the tags that place it on the globe.
    #[error("GeoTIFF has no {tag}: cannot georeference it")]
    MissingGeoreference {
        /// The tag, e.g. `ModelTiepointTag (33922)`.
        tag: &'static str,
    },
}

/// Why a [`TerrainMesh`](super::TerrainMesh) could not be built.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum MeshError {
    /// A mesh needs at least 2 × 2 cells.
    #[error("a {ncols} × {nrows} DEM is too small for a mesh (at least 2 × 2 cells)")]
    TooSmall {
        /// Columns of the DEM.
        ncols: usize,
        /// Rows of the DEM.
        nrows: usize,
    },
    /// The upsampled grid has more vertices than the limit.
    #[error(
        "{vertices} vertices is more than the {max} allowed; lower `TerrainSettings::upsample`"
    )]
    TooManyVertices {
        /// Vertices the grid would have.
        vertices: u64,
        /// The limit, [`MAX_MESH_VERTICES`](super::MAX_MESH_VERTICES).
        max: u64,
    },
}

/// `FILE: ` when the file is known.
struct FilePrefix<'a>(&'a Option<PathBuf>);

impl fmt::Display for FilePrefix<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(file) => write!(f, "{}: ", file.display()),
            None => Ok(()),
        }
    }
}

/// `line L, column C: ` with the parts that are known.
struct LinePrefix(Option<usize>, Option<usize>);

impl fmt::Display for LinePrefix {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.0, self.1) {
            (Some(line), Some(column)) => write!(f, "line {line}, column {column}: "),
            (Some(line), None) => write!(f, "line {line}: "),
            (None, _) => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_file_line_and_column() {
        let e = DemError::at(
            3,
            10,
            DemErrorKind::BadNumber {
                what: "`cellsize`".into(),
                token: "0.0x8".into(),
                expected: "a finite number",
            },
        )
        .with_file("assets/terrain/dem.asc");
        assert_eq!(
            e.to_string(),
            "assets/terrain/dem.asc: line 3, column 10: `cellsize`: `0.0x8` is not a finite number"
        );
        let e = DemError::new(DemErrorKind::NoValidData);
        assert_eq!(e.to_string(), "every cell is NODATA");
    }
}
