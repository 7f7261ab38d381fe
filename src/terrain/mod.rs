//! Terrain: elevation files to a [`Dem`], and a [`Dem`] to a shaded [`TerrainMesh`] in scene
//! metres, with lakes and pinned summits. Plain Rust with no Bevy types, so the mesh arrays
//! drop straight into a Bevy `Mesh` and everything here is tested on the CPU.
//!
//! # Reading elevation files
//!
//! [`Dem::from_path`] reads either format, chosen by the file's first bytes:
//!
//! - **ESRI ASCII grid** (`.asc`; swisstopo DHM25, GDAL `AAIGrid`, the bundled GLOBE extract):
//!   header lines `ncols`, `nrows`, `xllcorner`/`xllcenter`, `yllcorner`/`yllcenter`,
//!   `cellsize` (or GDAL's `dx`/`dy`) and an optional `NODATA_value`, keys in any order and
//!   any case; then `nrows` lines of `ncols` heights, north row first, one row per line.
//! - **`GeoTIFF`** (through the `tiff` crate): one band of `f32`, `f64`, `i16`, `u16`, `i32` (or
//!   other integer) heights, placed by `ModelTiepointTag` (33922) and `ModelPixelScaleTag`
//!   (33550), `PixelIsArea` or `PixelIsPoint`, with GDAL's NODATA tag honoured. Rotated rasters,
//!   ground control points, several bands and projected coordinate systems are refused with a
//!   clear [`DemErrorKind`].
//!
//! Both need geographic coordinates: longitude and latitude in degrees (WGS 84). swisstopo's
//! LV95 grids (metres) must be reprojected first, e.g. `gdalwarp -t_srs EPSG:4326`.
//!
//! A bad file never panics a reader (a mutation test feeds them thousands of corrupted files):
//! it gives a [`DemError`] naming the file, line and column, such as
//! `assets/terrain/dem.asc: line 9, column 6: height: `1e400` is not a finite number`.
//! NODATA cells are filled from their neighbours (see [`Dem`]).
//!
//! # Building the mesh
//!
//! [`TerrainMesh::build`] takes a [`Dem`], the [`TangentPlane`] of the scene origin (the same
//! projection as `scene::GeoOrigin::to_scene`: +X east, +Y up, −Z north, metres) and
//! [`TerrainSettings`], and runs these steps on a regular grid over the DEM's cell centres:
//!
//! 1. **Upsample** by [`TerrainSettings::upsample`] with separable Catmull-Rom splines (Catmull
//!    & Rom 1974; Keys 1981), which pass through every DEM height and keep slopes continuous.
//! 2. **Detail**: add fractal gradient noise ([`TerrainDetail`]), a few metres on flat ground
//!    up to tens of metres on steep slopes, deterministic for a seed.
//! 3. **Lakes**: flood-fill the flat areas at each [`Lake`]'s level around its location; those
//!    vertices become lake bed under a separate flat [`WaterSurface`].
//! 4. **Summits**: raise a smooth bump (about 1 km across) under each [`Summit`] so the mesh
//!    height at its coordinates is exact: the 1 km GLOBE cells flatten the Gurten (858 m) to
//!    628–828 m and the Bantiger (947 m) to 845 m.
//! 5. **Project** to scene metres, lowering distant ground by the planet's curvature so it meets
//!    the cloud shells ([`TerrainSettings::planet_radius_m`]).
//! 6. **Normals** by central differences, **colours** by height and slope ([`TerrainPalette`]:
//!    meadow, forest, alpine grass, rock, snow above about 2500 m, water).
//!
//! The bundled DEM, `assets/terrain/bern_globe30s.asc`, is a 30″ extract of NOAA's GLOBE
//! (Global Land One-kilometer Base Elevation, 1999; public domain) around Bern; its `README.md`
//! gives the provenance. On it the default settings give a 502 × 322 grid (about 210 m × 310 m
//! per quad) with 321 642 triangles (plus about 9 800 water triangles); reading the file takes
//! about 1 ms and building the mesh about 60 ms in a release build.
//!
//! Place a camera on a summit with [`TerrainMesh::height_at_scene`], which interpolates on the
//! drawn triangles; [`Dem::height_at`] answers for the raw DEM.
//!
//! # Example
//!
//! ```no_run
//! use bevy_cloudscape::terrain::{Dem, Summit, TangentPlane, TerrainMesh, TerrainSettings};
//!
//! let dem = Dem::from_path("assets/terrain/bern_globe30s.asc")?;
//! let plane = TangentPlane::new(46.948, 7.447, 0.0); // Bern, y = altitude
//! let mesh = TerrainMesh::build(&dem, &plane, &TerrainSettings::default())?;
//! let gurten = Summit::GURTEN;
//! let [x, _, z] = plane.to_scene(gurten.latitude_deg, gurten.longitude_deg, 0.0);
//! let eye_y = mesh.height_at_scene(x, z).unwrap() + 1.7;
//! println!("{} triangles, eye at y = {eye_y} m", mesh.triangle_count());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod ascii_grid;
mod dem;
mod error;
mod features;
mod geotiff;
mod mesh;
mod noise;
mod projection;
mod shading;

#[cfg(test)]
mod tests;

pub use dem::{Dem, DemGrid, MAX_DEM_CELLS, MAX_HEIGHT_M, MIN_HEIGHT_M};
pub use error::{DemError, DemErrorKind, MeshError};
pub use features::{Lake, Summit, bern_lakes, bern_summits};
pub use mesh::{
    MAX_MESH_VERTICES, TerrainDetail, TerrainMesh, TerrainSettings, TerrainStats, WaterSurface,
};
pub use projection::TangentPlane;
pub use shading::TerrainPalette;
