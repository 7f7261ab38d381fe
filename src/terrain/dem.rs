//! The [`Dem`]: a grid of heights on longitude/latitude cells.

use std::path::Path;

use super::error::{DemError, DemErrorKind};
use super::{ascii_grid, geotiff};

/// The most cells a [`Dem`] holds: 2²⁸ (1 GiB of heights), far above any terrain a scene
/// needs, so that a corrupt header cannot ask for an absurd allocation.
pub const MAX_DEM_CELLS: usize = 1 << 28;

/// The lowest height a [`Dem`] accepts, metres: a little below the deepest ocean floor.
/// Lower values are almost always an undeclared NODATA value such as SRTM's −32 768.
pub const MIN_HEIGHT_M: f32 = -12_000.0;
/// The highest height a [`Dem`] accepts, metres: a little above Mount Everest.
pub const MAX_HEIGHT_M: f32 = 10_000.0;

/// Whether `height_m` is a plausible elevation ([`MIN_HEIGHT_M`] to [`MAX_HEIGHT_M`]).
pub(crate) fn plausible_height(height_m: f32) -> bool {
    (MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&height_m)
}

/// Where a [`Dem`]'s cells lie on the globe.
///
/// Cell-centre convention: a height is the value at the centre of its cell, and
/// `lower_left_*` is the centre of the lower-left (south-west) cell, not the grid's outer corner.
/// ESRI ASCII `xllcorner`/`yllcorner` and `GeoTIFF` `PixelIsArea` tie points name the outer
/// corner, so the readers add half a cell; `xllcenter`/`yllcenter` and `PixelIsPoint` are used
/// as they are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DemGrid {
    /// Longitude of the centre of the lower-left cell, degrees east.
    pub lower_left_lon_deg: f64,
    /// Latitude of the centre of the lower-left cell, degrees north.
    pub lower_left_lat_deg: f64,
    /// Width of a cell, degrees of longitude (positive).
    pub cell_lon_deg: f64,
    /// Height of a cell, degrees of latitude (positive).
    pub cell_lat_deg: f64,
}

/// A digital elevation model: heights in metres above sea level on a regular longitude/latitude
/// grid (see [`DemGrid`] for the cell-centre convention), stored row by row with the **north row
/// first**, as in ESRI ASCII grids and `GeoTIFFs`.
///
/// Missing values (NODATA, non-finite) are filled when the DEM is made, from the neighbours
/// outward: each round, every missing cell next to known cells takes the mean of its known
/// neighbours (8-connected), until none are left. Small holes get a smooth patch; large ones
/// a plausible but invented surface, so [`Dem::filled_cells`] tells how many were invented.
#[derive(Debug, Clone, PartialEq)]
pub struct Dem {
    ncols: usize,
    nrows: usize,
    heights_m: Vec<f32>,
    grid: DemGrid,
    filled_cells: usize,
}

impl Dem {
    /// A DEM of `ncols` × `nrows` cells from `heights_m` (metres above sea level, north row
    /// first, west to east in each row). Non-finite heights mark NODATA cells and are filled
    /// from their neighbours (see [`Dem`]).
    ///
    /// Fails when the sizes disagree, the grid is empty or larger than [`MAX_DEM_CELLS`], the
    /// cell size is not positive, the grid is not within longitude ±360° and latitude ±90° (a
    /// projected grid such as Swiss LV95 in metres), a height lies outside [`MIN_HEIGHT_M`] to
    /// [`MAX_HEIGHT_M`], or no cell has data.
    pub fn new(
        ncols: usize,
        nrows: usize,
        mut heights_m: Vec<f32>,
        grid: DemGrid,
    ) -> Result<Self, DemError> {
        check_size(ncols, nrows)?;
        if heights_m.len() != ncols * nrows {
            return Err(DemError::new(DemErrorKind::SizeMismatch {
                ncols,
                nrows,
                found: heights_m.len(),
            }));
        }
        check_georeference(ncols, nrows, &grid)?;
        if let Some(index) = heights_m
            .iter()
            .position(|h| h.is_finite() && !plausible_height(*h))
        {
            return Err(DemError::new(DemErrorKind::HeightOutOfRange {
                column: index % ncols + 1,
                row: index / ncols + 1,
                value: heights_m[index],
            }));
        }
        let filled_cells = fill_nodata(ncols, nrows, &mut heights_m)?;
        Ok(Self {
            ncols,
            nrows,
            heights_m,
            grid,
            filled_cells,
        })
    }

    /// Reads an ESRI ASCII grid or a `GeoTIFF`, chosen by the file's first bytes (TIFF magic
    /// number or not). Errors name the file.
    pub fn from_path(path: impl AsRef<Path>) -> Result<Self, DemError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| {
            DemError::new(DemErrorKind::Io {
                message: e.to_string(),
            })
            .with_file(path)
        })?;
        Self::from_bytes(&bytes).map_err(|e| e.with_file(path))
    }

    /// Reads an ESRI ASCII grid or a `GeoTIFF` from memory, chosen by the first bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, DemError> {
        if geotiff::is_tiff(bytes) {
            Self::from_geotiff(bytes)
        } else {
            Self::from_ascii_grid(bytes)
        }
    }

    /// Reads an ESRI ASCII grid (`.asc`); see the [module docs](super) for the accepted form.
    pub fn from_ascii_grid(bytes: &[u8]) -> Result<Self, DemError> {
        ascii_grid::parse(bytes)
    }

    /// Reads a single-band `GeoTIFF` in geographic degrees; see the [module docs](super).
    pub fn from_geotiff(bytes: &[u8]) -> Result<Self, DemError> {
        geotiff::parse(bytes)
    }

    /// Columns (west to east).
    pub fn ncols(&self) -> usize {
        self.ncols
    }

    /// Rows (north to south).
    pub fn nrows(&self) -> usize {
        self.nrows
    }

    /// Where the cells lie.
    pub fn grid(&self) -> &DemGrid {
        &self.grid
    }

    /// All heights in metres, north row first.
    pub fn heights_m(&self) -> &[f32] {
        &self.heights_m
    }

    /// The height in metres of the cell in column `col` (from the west) and row `row` (from
    /// the north), or `None` outside the grid.
    pub fn height(&self, col: usize, row: usize) -> Option<f32> {
        (col < self.ncols && row < self.nrows).then(|| self.heights_m[row * self.ncols + col])
    }

    /// How many NODATA cells were filled from their neighbours.
    pub fn filled_cells(&self) -> usize {
        self.filled_cells
    }

    /// Lowest and highest height, metres.
    pub fn min_max_m(&self) -> (f32, f32) {
        self.heights_m
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &h| {
                (lo.min(h), hi.max(h))
            })
    }

    /// The fractional column (from the west cell's centre) and row (from the **south** cell's
    /// centre) of a point.
    pub(crate) fn cell_coordinates(&self, latitude_deg: f64, longitude_deg: f64) -> (f64, f64) {
        (
            (longitude_deg - self.grid.lower_left_lon_deg) / self.grid.cell_lon_deg,
            (latitude_deg - self.grid.lower_left_lat_deg) / self.grid.cell_lat_deg,
        )
    }

    /// Whether the point lies on the DEM's cells (their outer edges included).
    pub fn contains(&self, latitude_deg: f64, longitude_deg: f64) -> bool {
        let (u, v) = self.cell_coordinates(latitude_deg, longitude_deg);
        // A hair of slack (in cells) so that points exactly on the edge survive rounding.
        let inside = |t: f64, n: usize| (-0.5 - 1e-6..=n as f64 - 0.5 + 1e-6).contains(&t);
        inside(u, self.ncols) && inside(v, self.nrows)
    }

    /// The height in metres at a point, interpolated bilinearly between the four nearest cell
    /// centres; in the outer half cell the edge values are held. `None` outside the cells.
    pub fn height_at(&self, latitude_deg: f64, longitude_deg: f64) -> Option<f32> {
        if !self.contains(latitude_deg, longitude_deg) {
            return None;
        }
        let (u, v) = self.cell_coordinates(latitude_deg, longitude_deg);
        let (c0, c1, fu) = bracket(u, self.ncols);
        let (s0, s1, fv) = bracket(v, self.nrows);
        // Rows are stored north first.
        let row = |s: usize| self.nrows - 1 - s;
        let at = |c: usize, s: usize| f64::from(self.heights_m[row(s) * self.ncols + c]);
        let south = at(c0, s0) * (1.0 - fu) + at(c1, s0) * fu;
        let north = at(c0, s1) * (1.0 - fu) + at(c1, s1) * fu;
        Some((south * (1.0 - fv) + north * fv) as f32)
    }
}

/// The two cell indices around fractional index `t` of an axis of `n` cells, and the weight of
/// the second, holding the edge values beyond the outer centres.
fn bracket(t: f64, n: usize) -> (usize, usize, f64) {
    if n < 2 {
        return (0, 0, 0.0);
    }
    let t = t.clamp(0.0, (n - 1) as f64);
    let i0 = (t.floor() as usize).min(n - 2);
    (i0, i0 + 1, t - i0 as f64)
}

/// Rejects empty grids and grids over [`MAX_DEM_CELLS`].
pub(crate) fn check_size(ncols: usize, nrows: usize) -> Result<(), DemError> {
    if ncols == 0 || nrows == 0 {
        let key = if ncols == 0 { "ncols" } else { "nrows" };
        return Err(DemError::new(DemErrorKind::InvalidHeader {
            key,
            reason: "must be at least 1".into(),
        }));
    }
    match ncols.checked_mul(nrows) {
        Some(cells) if cells <= MAX_DEM_CELLS => Ok(()),
        _ => Err(DemError::new(DemErrorKind::TooLarge {
            ncols,
            nrows,
            max: MAX_DEM_CELLS,
        })),
    }
}

/// Rejects non-positive cell sizes and grids that cannot be in geographic degrees.
pub(crate) fn check_georeference(
    ncols: usize,
    nrows: usize,
    grid: &DemGrid,
) -> Result<(), DemError> {
    for (value, key) in [
        (grid.cell_lon_deg, "cellsize"),
        (grid.cell_lat_deg, "cellsize"),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(DemError::new(DemErrorKind::InvalidHeader {
                key,
                reason: format!("must be a positive number of degrees, not {value}"),
            }));
        }
    }
    let west = grid.lower_left_lon_deg - 0.5 * grid.cell_lon_deg;
    let east = west + ncols as f64 * grid.cell_lon_deg;
    let south = grid.lower_left_lat_deg - 0.5 * grid.cell_lat_deg;
    let north = south + nrows as f64 * grid.cell_lat_deg;
    // A hair of slack for grids that end exactly on a pole or the antimeridian.
    let slack = 1e-6;
    if !(west >= -360.0 - slack && east <= 360.0 + slack) {
        return Err(DemError::new(DemErrorKind::NotGeographic {
            detail: format!("spans longitude {west} to {east}"),
        }));
    }
    if !(south >= -90.0 - slack && north <= 90.0 + slack) {
        return Err(DemError::new(DemErrorKind::NotGeographic {
            detail: format!("spans latitude {south} to {north}"),
        }));
    }
    Ok(())
}

/// Fills non-finite heights from their known neighbours, ring by ring (see [`Dem`]), and
/// returns how many were filled.
fn fill_nodata(ncols: usize, nrows: usize, heights: &mut [f32]) -> Result<usize, DemError> {
    let mut known: Vec<bool> = heights.iter().map(|h| h.is_finite()).collect();
    let missing = known.iter().filter(|k| !**k).count();
    if missing == 0 {
        return Ok(0);
    }
    if missing == heights.len() {
        return Err(DemError::new(DemErrorKind::NoValidData));
    }
    let neighbours = |index: usize| {
        let (col, row) = ((index % ncols) as isize, (index / ncols) as isize);
        (-1..=1isize)
            .flat_map(move |dr| (-1..=1isize).map(move |dc| (col + dc, row + dr)))
            .filter(move |&(c, r)| {
                (c, r) != (col, row)
                    && (0..ncols as isize).contains(&c)
                    && (0..nrows as isize).contains(&r)
            })
            .map(move |(c, r)| r as usize * ncols + c as usize)
    };
    let mut queued = known.clone();
    let mut ring: Vec<usize> = Vec::new();
    for index in 0..heights.len() {
        if !known[index] && neighbours(index).any(|n| known[n]) {
            queued[index] = true;
            ring.push(index);
        }
    }
    let mut values = Vec::new();
    while !ring.is_empty() {
        // Compute the whole ring from the cells known before it, so the result does not
        // depend on the order within a ring.
        values.clear();
        values.extend(ring.iter().map(|&index| {
            let (sum, count) = neighbours(index)
                .filter(|&n| known[n])
                .fold((0.0f64, 0u32), |(s, c), n| {
                    (s + f64::from(heights[n]), c + 1)
                });
            (sum / f64::from(count)) as f32
        }));
        for (&index, &value) in ring.iter().zip(&values) {
            heights[index] = value;
            known[index] = true;
        }
        let mut next = Vec::new();
        for &index in &ring {
            for n in neighbours(index) {
                if !queued[n] {
                    queued[n] = true;
                    next.push(n);
                }
            }
        }
        ring = next;
    }
    Ok(missing)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> DemGrid {
        DemGrid {
            lower_left_lon_deg: 7.0,
            lower_left_lat_deg: 46.0,
            cell_lon_deg: 0.1,
            cell_lat_deg: 0.05,
        }
    }

    #[test]
    fn bilinear_between_cell_centres() {
        // North row first: north row 10 20, south row 30 40.
        let dem = Dem::new(2, 2, vec![10.0, 20.0, 30.0, 40.0], grid()).unwrap();
        assert_eq!(dem.height_at(46.0, 7.0), Some(30.0));
        assert_eq!(dem.height_at(46.05, 7.1), Some(20.0));
        assert_eq!(dem.height_at(46.025, 7.05), Some(25.0));
        // The outer half cell holds the edge value; beyond it there is no data.
        assert_eq!(dem.height_at(45.98, 6.96), Some(30.0));
        assert_eq!(dem.height_at(45.97, 7.0), None);
        assert_eq!(dem.height_at(46.0, 7.16), None);
        assert_eq!(dem.height(1, 0), Some(20.0));
        assert_eq!(dem.height(2, 0), None);
        assert_eq!(dem.min_max_m(), (10.0, 40.0));
    }

    #[test]
    fn single_cell_dem_is_flat() {
        let dem = Dem::new(1, 1, vec![5.0], grid()).unwrap();
        assert_eq!(dem.height_at(46.01, 7.02), Some(5.0));
    }

    #[test]
    fn nodata_is_filled_from_neighbours() {
        let nan = f32::NAN;
        #[rustfmt::skip]
        let heights = vec![
            nan, nan, nan, nan,
            nan, 10.0, 20.0, nan,
            nan, 30.0, nan, nan,
        ];
        let dem = Dem::new(4, 3, heights, grid()).unwrap();
        assert_eq!(dem.filled_cells(), 9);
        assert!(dem.heights_m().iter().all(|h| h.is_finite()));
        // The hole at (2, 2) touches 10, 20 and 30 only.
        assert_eq!(dem.height(2, 2), Some(20.0));
        // The corner (0, 0) touches only 10.
        assert_eq!(dem.height(0, 0), Some(10.0));
        let (lo, hi) = dem.min_max_m();
        assert!((10.0..=30.0).contains(&lo) && (10.0..=30.0).contains(&hi));
    }

    #[test]
    fn rejects_bad_construction() {
        let kind = |r: Result<Dem, DemError>| r.unwrap_err().kind;
        assert!(matches!(
            kind(Dem::new(2, 2, vec![1.0; 3], grid())),
            DemErrorKind::SizeMismatch { found: 3, .. }
        ));
        assert_eq!(
            kind(Dem::new(2, 1, vec![f32::NAN; 2], grid())),
            DemErrorKind::NoValidData
        );
        assert!(matches!(
            kind(Dem::new(0, 1, vec![], grid())),
            DemErrorKind::InvalidHeader { key: "ncols", .. }
        ));
        assert!(matches!(
            kind(Dem::new(usize::MAX, 2, vec![], grid())),
            DemErrorKind::TooLarge { .. }
        ));
        let lv95 = DemGrid {
            lower_left_lon_deg: 2_600_000.0,
            lower_left_lat_deg: 1_200_000.0,
            cell_lon_deg: 25.0,
            cell_lat_deg: 25.0,
        };
        assert!(matches!(
            kind(Dem::new(1, 1, vec![1.0], lv95)),
            DemErrorKind::NotGeographic { .. }
        ));
        let flat = DemGrid {
            cell_lat_deg: 0.0,
            ..grid()
        };
        assert!(matches!(
            kind(Dem::new(1, 1, vec![1.0], flat)),
            DemErrorKind::InvalidHeader {
                key: "cellsize",
                ..
            }
        ));
        // SRTM's void value, undeclared.
        assert_eq!(
            kind(Dem::new(2, 2, vec![500.0, 510.0, -32768.0, 520.0], grid())),
            DemErrorKind::HeightOutOfRange {
                column: 1,
                row: 2,
                value: -32768.0
            }
        );
    }

    #[test]
    fn missing_file_names_the_file() {
        let err = Dem::from_path("/nonexistent/dem.asc").unwrap_err();
        assert_eq!(err.file.as_deref(), Some(Path::new("/nonexistent/dem.asc")));
        assert!(matches!(err.kind, DemErrorKind::Io { .. }));
        assert!(
            err.to_string()
                .starts_with("/nonexistent/dem.asc: cannot read the file")
        );
    }
}
