//! Building a [`TerrainMesh`] from a [`Dem`]: upsampling, detail, lakes, summits, normals,
//! colours.

use std::collections::VecDeque;

use super::dem::Dem;
use super::error::MeshError;
use super::features::{Lake, Summit, bern_lakes, bern_summits};
use super::noise::fbm;
use super::projection::TangentPlane;
use super::shading::{TerrainPalette, smoothstep};

/// The most vertices a [`TerrainMesh`] may have: 2²⁶ (about 67 million, some 3 GiB of vertex
/// data), so that indices fit `u32` with room to spare.
pub const MAX_MESH_VERTICES: u64 = 1 << 26;

/// Fine procedural relief added to the upsampled DEM.
///
/// Fractal gradient noise (Perlin 2002) in scene metres, so it is isotropic on the ground and
/// the same for the same seed on every run. Its amplitude grows with the local slope of the
/// upsampled DEM: flat valley floors stay nearly flat, hillsides and mountains get gullies and
/// knolls. Octaves shorter than two mesh cells are skipped, since the grid cannot show them.
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainDetail {
    /// Noise seed. Default 0.
    pub seed: u32,
    /// Number of octaves, each half the wavelength and amplitude of the one before. Default 3.
    pub octaves: u32,
    /// Wavelength of the first octave, metres. Default 3000.
    pub wavelength_m: f64,
    /// Amplitude on flat ground, metres. Default 2.
    pub flat_amplitude_m: f32,
    /// Amplitude on steep ground, metres. Default 30.
    pub steep_amplitude_m: f32,
    /// Slope (rise over run) at and above which the steep amplitude applies. Default 0.6.
    pub steep_slope: f32,
}

impl Default for TerrainDetail {
    fn default() -> Self {
        Self {
            seed: 0,
            octaves: 3,
            wavelength_m: 3000.0,
            flat_amplitude_m: 2.0,
            steep_amplitude_m: 30.0,
            steep_slope: 0.6,
        }
    }
}

/// How a [`TerrainMesh`] is built from a [`Dem`].
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainSettings {
    /// Mesh vertices per DEM cell along each axis (at least 1). The DEM is upsampled with
    /// Catmull-Rom splines between cell centres. Default 3: the bundled 168 × 108 DEM gives a
    /// 502 × 322 grid, about 210 m × 310 m per quad and 322 k triangles.
    pub upsample: u32,
    /// Fine procedural relief.
    pub detail: TerrainDetail,
    /// Summits whose height is made exact. Default: [`Summit::GURTEN`], [`Summit::BANTIGER`].
    ///
    /// Method: around each summit the ground is raised (never lowered) towards a paraboloid cap
    /// through the summit height, dropping 15 % of [`summit_radius_m`](Self::summit_radius_m)
    /// at that radius, blended in over the outer half of the radius; then the four vertices of
    /// the mesh quad holding the summit are set to its height. The mesh surface at the summit's
    /// coordinates is therefore exactly the summit height, and the top is a small flat quad.
    /// Summits outside the DEM are skipped.
    pub summits: Vec<Summit>,
    /// Radius over which a pinned summit's bump falls off, metres. Default 1000.
    pub summit_radius_m: f64,
    /// Lakes turned into water. Default: Thun, Brienz, Biel, Neuchâtel and Murten
    /// ([`bern_lakes`]).
    ///
    /// Method: on the DEM's cells, a flood fill (4-connected) starts from the cells within 2 km
    /// of the lake's point that lie within [`lake_tolerance_m`](Self::lake_tolerance_m) of its
    /// level, and spreads over such cells up to [`Lake::radius_m`]: a lake is the flat area at
    /// its level around its location, as GLOBE and swisstopo DEMs store lakes as flat surfaces.
    /// Mesh vertices whose bilinear share of lake cells is at least ½ are water: they sink
    /// [`lake_bed_depth_m`](Self::lake_bed_depth_m) below the level and take the water colour;
    /// land vertices touching lake cells are kept at least 0.5 m above the level so the shore
    /// stays dry. [`TerrainMesh::water`] holds a flat surface at the level over every quad that
    /// touches a water vertex, so it meets the sloping shore triangles at the waterline.
    pub lakes: Vec<Lake>,
    /// How far a cell's height may be from a lake's level and still count as lake, metres.
    /// Default 0.75: exact for integer DEMs such as GLOBE, tolerant of survey noise.
    pub lake_tolerance_m: f32,
    /// How far water vertices sink below the lake level, metres. Default 2.
    pub lake_bed_depth_m: f32,
    /// Radius of the planet the terrain is drawn on, metres; `None` for a flat scene.
    /// Default 6 371 000, matching the cloud shells of `VolumetricClouds::planet_radius_m`.
    ///
    /// Scene x and z are always those of the tangent plane (the same as
    /// `GeoOrigin::to_scene`); with a radius, y is lowered by the sphere's drop below the plane
    /// at that horizontal distance (about 280 m at 60 km), so distant ridges sink behind the
    /// horizon and meet the cloud layers at the right altitude.
    pub planet_radius_m: Option<f64>,
    /// Ground colours.
    pub palette: TerrainPalette,
}

impl Default for TerrainSettings {
    fn default() -> Self {
        Self {
            upsample: 3,
            detail: TerrainDetail::default(),
            summits: bern_summits(),
            summit_radius_m: 1000.0,
            lakes: bern_lakes(),
            lake_tolerance_m: 0.75,
            lake_bed_depth_m: 2.0,
            planet_radius_m: Some(6_371_000.0),
            palette: TerrainPalette::default(),
        }
    }
}

/// A flat water surface over the lakes, as plain arrays for a separate mesh (e.g. with a
/// glossy material). Triangles wind counter-clockwise seen from above.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WaterSurface {
    /// Vertex positions, scene metres.
    pub positions: Vec<[f32; 3]>,
    /// Unit normals: straight up, or away from the planet centre with a planet radius.
    pub normals: Vec<[f32; 3]>,
    /// Triangle list, three indices into `positions` per triangle.
    pub indices: Vec<u32>,
}

/// Numbers about a built [`TerrainMesh`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TerrainStats {
    /// Grid vertices west to east.
    pub columns: usize,
    /// Grid vertices north to south.
    pub rows: usize,
    /// Distance between grid columns, metres.
    pub spacing_east_m: f64,
    /// Distance between grid rows, metres.
    pub spacing_north_m: f64,
    /// Terrain vertices.
    pub vertices: usize,
    /// Terrain triangles.
    pub triangles: usize,
    /// Terrain vertices that are water (lake beds).
    pub water_vertices: usize,
    /// Triangles of the [`WaterSurface`].
    pub water_triangles: usize,
    /// Lakes that were found on the DEM.
    pub lakes_found: usize,
    /// Summits that were pinned (inside the DEM).
    pub pinned_summits: usize,
    /// Lowest terrain altitude, metres above sea level.
    pub min_altitude_m: f32,
    /// Highest terrain altitude, metres above sea level.
    pub max_altitude_m: f32,
}

/// A terrain mesh as plain arrays, ready for `bevy::render::mesh::Mesh` attributes
/// (`ATTRIBUTE_POSITION`, `ATTRIBUTE_NORMAL`, `ATTRIBUTE_COLOR`, `Indices::U32`) with a
/// `TriangleList` topology.
///
/// The mesh is a regular grid over the DEM's cell centres, row by row from the north, columns
/// from the west; each quad is split along its north-east/south-west diagonal into two
/// triangles that wind counter-clockwise seen from above (Bevy's front faces).
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainMesh {
    /// Vertex positions, scene metres (+X east, +Y up, −Z north; see
    /// [`TerrainSettings::planet_radius_m`] for y).
    pub positions: Vec<[f32; 3]>,
    /// Smooth unit vertex normals (central differences over the grid).
    pub normals: Vec<[f32; 3]>,
    /// Linear RGBA vertex colours, each channel in [0, 1].
    pub colors: Vec<[f32; 4]>,
    /// Triangle list, three indices into `positions` per triangle.
    pub indices: Vec<u32>,
    /// Altitude of each vertex above sea level, metres (before the planet's curvature).
    pub altitudes_m: Vec<f32>,
    /// Whether each vertex is a lake bed under the [`WaterSurface`].
    pub is_water: Vec<bool>,
    /// The lakes' surface.
    pub water: WaterSurface,
    /// Counts and extents.
    pub stats: TerrainStats,
    plane: TangentPlane,
    x0: f64,
    z0: f64,
}

/// Slack, in grid cells, for points on the mesh's edge.
const EDGE_SLACK: f64 = 1e-6;
/// Distance within which a lake's flood fill may start, metres.
const LAKE_SEED_RADIUS_M: f64 = 2000.0;
/// How far land next to a lake stays above its level, metres.
const SHORE_MARGIN_M: f32 = 0.5;

impl TerrainMesh {
    /// Builds the mesh of `dem` in the scene frame of `plane` (see the [module docs](super)
    /// for the steps).
    pub fn build(
        dem: &Dem,
        plane: &TangentPlane,
        settings: &TerrainSettings,
    ) -> Result<Self, MeshError> {
        let (ncols, nrows) = (dem.ncols(), dem.nrows());
        if ncols < 2 || nrows < 2 {
            return Err(MeshError::TooSmall { ncols, nrows });
        }
        let factor = settings.upsample.max(1) as usize;
        let (columns, rows) = ((ncols - 1) * factor + 1, (nrows - 1) * factor + 1);
        let vertices = columns as u64 * rows as u64;
        if vertices > MAX_MESH_VERTICES {
            return Err(MeshError::TooManyVertices {
                vertices,
                max: MAX_MESH_VERTICES,
            });
        }

        // The grid in scene metres: the projection is linear in longitude and latitude, so
        // the grid is regular. Row 0 is the DEM's north row of cell centres.
        let grid = dem.grid();
        let north_lat = grid.lower_left_lat_deg + (nrows - 1) as f64 * grid.cell_lat_deg;
        let corner = plane.to_scene(north_lat, grid.lower_left_lon_deg, 0.0);
        let (east_per_deg, north_per_deg) = plane.metres_per_degree();
        let geometry = Grid {
            columns,
            rows,
            factor,
            x0: corner[0],
            z0: corner[2],
            dx: east_per_deg * grid.cell_lon_deg / factor as f64,
            dz: north_per_deg * grid.cell_lat_deg / factor as f64,
        };

        let mut altitudes = upsample_catmull_rom(dem, factor);
        add_detail(&mut altitudes, &geometry, &settings.detail);
        let lakes = flood_lakes(dem, &settings.lakes, settings.lake_tolerance_m);
        let lakes_found = lakes.found;
        let water_levels = apply_lakes(&mut altitudes, &geometry, &lakes, settings);
        let pinned_summits = settings
            .summits
            .iter()
            .filter(|summit| {
                pin_summit(
                    &mut altitudes,
                    &geometry,
                    plane,
                    summit,
                    settings.summit_radius_m,
                )
            })
            .count();

        let curvature = Curvature {
            radius_m: settings.planet_radius_m.filter(|r| *r > 0.0),
            elevation_m: plane.elevation_m,
        };
        let positions: Vec<[f32; 3]> = (0..vertices as usize)
            .map(|index| {
                let (x, z) = geometry.xz(index);
                [
                    x as f32,
                    curvature.scene_y(x, z, f64::from(altitudes[index])) as f32,
                    z as f32,
                ]
            })
            .collect();
        let normals = grid_normals(&positions, columns, rows);
        let slopes = slopes(&altitudes, &geometry);
        let palette = &settings.palette;
        let seed = settings.detail.seed;
        let colors = (0..vertices as usize)
            .map(|index| {
                if water_levels[index].is_some() {
                    return palette.water;
                }
                let (x, z) = geometry.xz(index);
                // Low-frequency noise, independent of the relief's, for forest patches and tint.
                let patch = fbm(x / 2500.0, z / 2500.0, 2, seed.wrapping_add(101)) as f32;
                let tint = fbm(x / 900.0, z / 900.0, 2, seed.wrapping_add(202)) as f32;
                palette.ground(altitudes[index], slopes[index], patch, tint)
            })
            .collect();
        let indices = grid_indices(columns, rows);
        let water = water_surface(&geometry, &water_levels, &curvature);

        let (min_altitude_m, max_altitude_m) = altitudes
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &a| {
                (lo.min(a), hi.max(a))
            });
        let stats = TerrainStats {
            columns,
            rows,
            spacing_east_m: geometry.dx,
            spacing_north_m: geometry.dz,
            vertices: positions.len(),
            triangles: indices.len() / 3,
            water_vertices: water_levels.iter().filter(|l| l.is_some()).count(),
            water_triangles: water.indices.len() / 3,
            lakes_found,
            pinned_summits,
            min_altitude_m,
            max_altitude_m,
        };
        Ok(Self {
            positions,
            normals,
            colors,
            indices,
            altitudes_m: altitudes,
            is_water: water_levels.iter().map(Option::is_some).collect(),
            water,
            stats,
            plane: *plane,
            x0: geometry.x0,
            z0: geometry.z0,
        })
    }

    /// The tangent plane the mesh was built in.
    pub fn plane(&self) -> &TangentPlane {
        &self.plane
    }

    /// Number of terrain triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Scene y (metres) of the terrain surface above scene point `(x, z)`, interpolated on the
    /// mesh's own triangles, so an object placed there sits exactly on the drawn ground. Lake
    /// beds lie [`TerrainSettings::lake_bed_depth_m`] under the water. `None` outside the mesh.
    ///
    /// A camera on a summit: `height_at_scene(x, z)` plus an eye height of about 1.7 m.
    pub fn height_at_scene(&self, x: f64, z: f64) -> Option<f32> {
        self.interpolate(x, z, |index| self.positions[index][1])
    }

    /// Altitude above sea level (metres) of the terrain at scene point `(x, z)`, interpolated
    /// like [`height_at_scene`](Self::height_at_scene) but without the planet's curvature: at
    /// a pinned summit's coordinates it is exactly the summit's height. `None` outside the mesh.
    pub fn altitude_at_scene(&self, x: f64, z: f64) -> Option<f32> {
        self.interpolate(x, z, |index| self.altitudes_m[index])
    }

    /// Interpolates a per-vertex value on the triangle under `(x, z)`.
    fn interpolate(&self, x: f64, z: f64, value: impl Fn(usize) -> f32) -> Option<f32> {
        let stats = &self.stats;
        let u = (x - self.x0) / stats.spacing_east_m;
        let v = (z - self.z0) / stats.spacing_north_m;
        let (max_u, max_v) = ((stats.columns - 1) as f64, (stats.rows - 1) as f64);
        // A hair of slack so that points exactly on the edge survive rounding.
        let inside = |t: f64, max: f64| (-EDGE_SLACK..=max + EDGE_SLACK).contains(&t);
        if !(inside(u, max_u) && inside(v, max_v)) {
            return None;
        }
        let (u, v) = (u.clamp(0.0, max_u), v.clamp(0.0, max_v));
        let i = (u.floor() as usize).min(stats.columns - 2);
        let j = (v.floor() as usize).min(stats.rows - 2);
        let (fu, fv) = (u - i as f64, v - j as f64);
        let at = |di: usize, dj: usize| f64::from(value((j + dj) * stats.columns + i + di));
        // Same split as `grid_indices`: triangle (nw, sw, ne) where fu + fv ≤ 1, else
        // (ne, sw, se).
        let h = if fu + fv <= 1.0 {
            at(0, 0) + fu * (at(1, 0) - at(0, 0)) + fv * (at(0, 1) - at(0, 0))
        } else {
            at(1, 1) + (1.0 - fu) * (at(0, 1) - at(1, 1)) + (1.0 - fv) * (at(1, 0) - at(1, 1))
        };
        Some(h as f32)
    }
}

/// The mesh grid in scene metres.
struct Grid {
    columns: usize,
    rows: usize,
    /// Mesh vertices per DEM cell.
    factor: usize,
    /// Scene x of column 0 (west).
    x0: f64,
    /// Scene z of row 0 (north).
    z0: f64,
    /// Column spacing, metres (x grows east).
    dx: f64,
    /// Row spacing, metres (z grows south, so positive).
    dz: f64,
}

impl Grid {
    fn xz(&self, index: usize) -> (f64, f64) {
        let (i, j) = (index % self.columns, index / self.columns);
        (self.x0 + i as f64 * self.dx, self.z0 + j as f64 * self.dz)
    }

    /// Fractional column and row of a scene point.
    fn uv(&self, x: f64, z: f64) -> (f64, f64) {
        ((x - self.x0) / self.dx, (z - self.z0) / self.dz)
    }
}

/// How scene y follows from altitude.
struct Curvature {
    radius_m: Option<f64>,
    elevation_m: f64,
}

impl Curvature {
    /// Scene y of a point at `altitude_m` above `(x, z)`: on the sphere of radius R + altitude
    /// around the planet centre (0, −R − elevation, 0), i.e. altitude − elevation − drop with
    /// drop = d² / (r + √(r² − d²)), r = R + altitude, d = √(x² + z²) (the sagitta, written so
    /// that it loses no precision for d ≪ r).
    fn scene_y(&self, x: f64, z: f64, altitude_m: f64) -> f64 {
        let y = altitude_m - self.elevation_m;
        let Some(radius) = self.radius_m else {
            return y;
        };
        let r = radius + altitude_m;
        let d2 = x * x + z * z;
        y - d2 / (r + (r * r - d2).max(0.0).sqrt())
    }

    /// Unit normal of a level surface at `(x, y, z)`.
    fn up(&self, x: f64, y: f64, z: f64) -> [f32; 3] {
        let Some(radius) = self.radius_m else {
            return [0.0, 1.0, 0.0];
        };
        let c = [x, y + self.elevation_m + radius, z];
        let len = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        [
            (c[0] / len) as f32,
            (c[1] / len) as f32,
            (c[2] / len) as f32,
        ]
    }
}

/// Catmull-Rom weights for the four samples around fraction `t` (Catmull & Rom 1974; the
/// a = −½ cubic convolution kernel of Keys 1981, which reproduces the samples and linear
/// ramps exactly).
fn catmull_rom_weights(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// Upsamples `n ≥ 2` samples to `(n − 1) · factor + 1` with Catmull-Rom splines. Beyond the
/// ends the samples are extended linearly (2 p₀ − p₁), so ramps stay ramps up to the edge
/// instead of flattening. `get(k)` reads sample k; `put(i, value)` writes output i.
fn upsample_line(
    n: usize,
    factor: usize,
    get: impl Fn(usize) -> f64,
    mut put: impl FnMut(usize, f64),
) {
    let weights: Vec<[f64; 4]> = (0..factor)
        .map(|phase| catmull_rom_weights(phase as f64 / factor as f64))
        .collect();
    let sample = |k: isize| {
        if k < 0 {
            2.0 * get(0) - get(1)
        } else if k as usize >= n {
            2.0 * get(n - 1) - get(n - 2)
        } else {
            get(k as usize)
        }
    };
    for i in 0..(n - 1) * factor + 1 {
        let (k, phase) = ((i / factor) as isize, i % factor);
        if phase == 0 {
            put(i, sample(k));
            continue;
        }
        let w = &weights[phase];
        put(i, (0..4).map(|t| w[t] * sample(k - 1 + t as isize)).sum());
    }
}

/// The DEM upsampled by `factor` on both axes (separable Catmull-Rom), north row first.
fn upsample_catmull_rom(dem: &Dem, factor: usize) -> Vec<f32> {
    let (ncols, nrows) = (dem.ncols(), dem.nrows());
    let columns = (ncols - 1) * factor + 1;
    let rows = (nrows - 1) * factor + 1;
    let heights = dem.heights_m();
    let mut wide = vec![0.0f64; nrows * columns];
    for r in 0..nrows {
        let row = &heights[r * ncols..(r + 1) * ncols];
        let out = &mut wide[r * columns..(r + 1) * columns];
        upsample_line(ncols, factor, |k| f64::from(row[k]), |i, v| out[i] = v);
    }
    let mut result = vec![0.0f32; rows * columns];
    for i in 0..columns {
        upsample_line(
            nrows,
            factor,
            |k| wide[k * columns + i],
            |j, v| result[j * columns + i] = v as f32,
        );
    }
    result
}

/// Slope (rise over run) at each vertex, by central differences (one-sided at the edges).
fn slopes(altitudes: &[f32], grid: &Grid) -> Vec<f32> {
    let (columns, rows) = (grid.columns, grid.rows);
    let at = |i: usize, j: usize| f64::from(altitudes[j * columns + i]);
    (0..columns * rows)
        .map(|index| {
            let (i, j) = (index % columns, index / columns);
            let (i0, i1) = (i.saturating_sub(1), (i + 1).min(columns - 1));
            let (j0, j1) = (j.saturating_sub(1), (j + 1).min(rows - 1));
            let ddx = (at(i1, j) - at(i0, j)) / ((i1 - i0) as f64 * grid.dx);
            let ddz = (at(i, j1) - at(i, j0)) / ((j1 - j0) as f64 * grid.dz);
            ddx.hypot(ddz) as f32
        })
        .collect()
}

/// Adds slope-scaled fractal noise (see [`TerrainDetail`]).
fn add_detail(altitudes: &mut [f32], grid: &Grid, detail: &TerrainDetail) {
    if detail.octaves == 0 || detail.wavelength_m.is_nan() || detail.wavelength_m <= 0.0 {
        return;
    }
    // Keep octaves whose wavelength spans at least two cells of the coarser axis.
    let finest = 2.0 * grid.dx.max(grid.dz);
    let mut octaves = 0;
    while octaves < detail.octaves
        && detail.wavelength_m / f64::from(1u32 << octaves.min(31)) >= finest
    {
        octaves += 1;
    }
    if octaves == 0 {
        return;
    }
    let slopes = slopes(altitudes, grid);
    for (index, altitude) in altitudes.iter_mut().enumerate() {
        let (x, z) = grid.xz(index);
        let steepness = smoothstep(0.0, detail.steep_slope.max(1e-3), slopes[index]);
        let amplitude = detail.flat_amplitude_m
            + (detail.steep_amplitude_m - detail.flat_amplitude_m) * steepness;
        let n = fbm(
            x / detail.wavelength_m,
            z / detail.wavelength_m,
            octaves,
            detail.seed,
        );
        *altitude += amplitude * n as f32;
    }
}

/// DEM cells that are lake: the index into the lake list plus one, 0 for land.
struct LakeCells {
    cells: Vec<u8>,
    found: usize,
}

/// Flood-fills each lake on the DEM's cells (see [`TerrainSettings::lakes`]).
fn flood_lakes(dem: &Dem, lakes: &[Lake], tolerance_m: f32) -> LakeCells {
    let (ncols, nrows) = (dem.ncols(), dem.nrows());
    let grid = dem.grid();
    let heights = dem.heights_m();
    let mut cells = vec![0u8; ncols * nrows];
    let mut found = 0;
    // Lake ids are stored in a byte; lakes past the 255th are ignored.
    for (id, lake) in (1..=u8::MAX).zip(lakes) {
        if !dem.contains(lake.latitude_deg, lake.longitude_deg) {
            continue;
        }
        let (u, v) = dem.cell_coordinates(lake.latitude_deg, lake.longitude_deg);
        // Rows from the north, as stored.
        let v = (nrows - 1) as f64 - v;
        let (east, north) =
            TangentPlane::new(lake.latitude_deg, lake.longitude_deg, 0.0).metres_per_degree();
        let (cell_x, cell_y) = (east * grid.cell_lon_deg, north * grid.cell_lat_deg);
        let distance =
            |c: usize, r: usize| ((c as f64 - u) * cell_x).hypot((r as f64 - v) * cell_y);
        let matches = |c: usize, r: usize| {
            (heights[r * ncols + c] - lake.level_m).abs() <= tolerance_m
                && distance(c, r) <= lake.radius_m
        };
        let (reach_c, reach_r) = (
            (lake.radius_m / cell_x).ceil() as isize + 1,
            (lake.radius_m / cell_y).ceil() as isize + 1,
        );
        let clamp_c = |t: isize| t.clamp(0, ncols as isize - 1) as usize;
        let clamp_r = |t: isize| t.clamp(0, nrows as isize - 1) as usize;
        let (c0, c1) = (clamp_c(u as isize - reach_c), clamp_c(u as isize + reach_c));
        let (r0, r1) = (clamp_r(v as isize - reach_r), clamp_r(v as isize + reach_r));
        let mut queue = VecDeque::new();
        for r in r0..=r1 {
            for c in c0..=c1 {
                if cells[r * ncols + c] == 0
                    && distance(c, r) <= LAKE_SEED_RADIUS_M.min(lake.radius_m)
                    && matches(c, r)
                {
                    cells[r * ncols + c] = id;
                    queue.push_back((c, r));
                }
            }
        }
        if queue.is_empty() {
            continue;
        }
        found += 1;
        while let Some((c, r)) = queue.pop_front() {
            let neighbours = [
                (c.wrapping_sub(1), r),
                (c + 1, r),
                (c, r.wrapping_sub(1)),
                (c, r + 1),
            ];
            for (nc, nr) in neighbours {
                if nc < ncols && nr < nrows && cells[nr * ncols + nc] == 0 && matches(nc, nr) {
                    cells[nr * ncols + nc] = id;
                    queue.push_back((nc, nr));
                }
            }
        }
    }
    LakeCells { cells, found }
}

/// Marks water vertices, sinks them to the lake bed and keeps the shore dry; returns each
/// vertex's water level (`None` for land).
fn apply_lakes(
    altitudes: &mut [f32],
    grid: &Grid,
    lakes: &LakeCells,
    settings: &TerrainSettings,
) -> Vec<Option<f32>> {
    let mut levels = vec![None; altitudes.len()];
    if lakes.found == 0 {
        return levels;
    }
    let factor = grid.factor;
    let ncols = (grid.columns - 1) / factor + 1;
    let nrows = (grid.rows - 1) / factor + 1;
    for (index, altitude) in altitudes.iter_mut().enumerate() {
        let (i, j) = (index % grid.columns, index / grid.columns);
        let (c, fc) = (i / factor, (i % factor) as f32 / factor as f32);
        let (r, fr) = (j / factor, (j % factor) as f32 / factor as f32);
        // Bilinear weights of the (up to) four DEM cells around the vertex.
        let corners = [
            (c, r, (1.0 - fc) * (1.0 - fr)),
            ((c + 1).min(ncols - 1), r, fc * (1.0 - fr)),
            (c, (r + 1).min(nrows - 1), (1.0 - fc) * fr),
            ((c + 1).min(ncols - 1), (r + 1).min(nrows - 1), fc * fr),
        ];
        let mut share = 0.0;
        let mut strongest: Option<(u8, f32)> = None;
        for (cc, cr, w) in corners {
            let id = lakes.cells[cr * ncols + cc];
            if id == 0 || w <= 0.0 {
                continue;
            }
            share += w;
            if strongest.is_none_or(|(_, best)| w > best) {
                strongest = Some((id, w));
            }
        }
        let Some((id, _)) = strongest else {
            continue;
        };
        let level = settings.lakes[usize::from(id) - 1].level_m;
        if share >= 0.5 {
            *altitude = level - settings.lake_bed_depth_m.max(0.0);
            levels[index] = Some(level);
        } else {
            *altitude = altitude.max(level + SHORE_MARGIN_M);
        }
    }
    levels
}

/// Raises a smooth bump so the mesh surface at the summit is exactly its height (see
/// [`TerrainSettings::summits`]). Returns whether the summit lies on the mesh.
fn pin_summit(
    altitudes: &mut [f32],
    grid: &Grid,
    plane: &TangentPlane,
    summit: &Summit,
    radius_m: f64,
) -> bool {
    let [sx, _, sz] = plane.to_scene(summit.latitude_deg, summit.longitude_deg, 0.0);
    let (u, v) = grid.uv(sx, sz);
    let (max_u, max_v) = ((grid.columns - 1) as f64, (grid.rows - 1) as f64);
    let inside = |t: f64, max: f64| (-EDGE_SLACK..=max + EDGE_SLACK).contains(&t);
    if !(inside(u, max_u) && inside(v, max_v)) {
        return false;
    }
    let (u, v) = (u.clamp(0.0, max_u), v.clamp(0.0, max_v));
    let top = f64::from(summit.altitude_m);
    let radius = radius_m.max(1.0);
    let (reach_i, reach_j) = (radius / grid.dx, radius / grid.dz);
    let i0 = (u - reach_i).floor().max(0.0) as usize;
    let i1 = ((u + reach_i).ceil() as usize).min(grid.columns - 1);
    let j0 = (v - reach_j).floor().max(0.0) as usize;
    let j1 = ((v + reach_j).ceil() as usize).min(grid.rows - 1);
    for j in j0..=j1 {
        for i in i0..=i1 {
            let index = j * grid.columns + i;
            let (x, z) = grid.xz(index);
            let r = (x - sx).hypot(z - sz);
            if r >= radius {
                continue;
            }
            let cap = top - 0.15 * r * r / radius;
            let weight = 1.0 - f64::from(smoothstep(0.5, 1.0, (r / radius) as f32));
            let current = f64::from(altitudes[index]);
            altitudes[index] = (current + weight * (cap - current).max(0.0)) as f32;
        }
    }
    // The quad under the summit, flat at its height: the surface there is exact.
    let i = (u.floor() as usize).min(grid.columns - 2);
    let j = (v.floor() as usize).min(grid.rows - 2);
    for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        altitudes[(j + dj) * grid.columns + i + di] = summit.altitude_m;
    }
    true
}

/// Smooth vertex normals: the cross product of the central-difference tangents along the grid
/// (one-sided at the edges), which for a height field weights the surrounding faces by area.
fn grid_normals(positions: &[[f32; 3]], columns: usize, rows: usize) -> Vec<[f32; 3]> {
    let p = |i: usize, j: usize| {
        let [x, y, z] = positions[j * columns + i];
        [f64::from(x), f64::from(y), f64::from(z)]
    };
    (0..columns * rows)
        .map(|index| {
            let (i, j) = (index % columns, index / columns);
            let (east, west) = (p((i + 1).min(columns - 1), j), p(i.saturating_sub(1), j));
            let (south, north) = (p(i, (j + 1).min(rows - 1)), p(i, j.saturating_sub(1)));
            let tx = [east[0] - west[0], east[1] - west[1], east[2] - west[2]];
            let tz = [
                south[0] - north[0],
                south[1] - north[1],
                south[2] - north[2],
            ];
            // tz × tx points up for x east, z south.
            let n = [
                tz[1] * tx[2] - tz[2] * tx[1],
                tz[2] * tx[0] - tz[0] * tx[2],
                tz[0] * tx[1] - tz[1] * tx[0],
            ];
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            [
                (n[0] / len) as f32,
                (n[1] / len) as f32,
                (n[2] / len) as f32,
            ]
        })
        .collect()
}

/// Two counter-clockwise (seen from above) triangles per grid quad, split along the
/// north-east/south-west diagonal.
fn grid_indices(columns: usize, rows: usize) -> Vec<u32> {
    let mut indices = Vec::with_capacity((columns - 1) * (rows - 1) * 6);
    for j in 0..rows - 1 {
        for i in 0..columns - 1 {
            let nw = (j * columns + i) as u32;
            let ne = nw + 1;
            let sw = nw + columns as u32;
            let se = sw + 1;
            indices.extend_from_slice(&[nw, sw, ne, ne, sw, se]);
        }
    }
    indices
}

/// The flat water surface over every quad that touches a water vertex, at that lake's level.
fn water_surface(grid: &Grid, levels: &[Option<f32>], curvature: &Curvature) -> WaterSurface {
    let mut water = WaterSurface::default();
    // Per grid vertex: the water vertex made for it and its level.
    let mut made: Vec<Option<(u32, f32)>> = vec![None; levels.len()];
    for j in 0..grid.rows - 1 {
        for i in 0..grid.columns - 1 {
            let nw = j * grid.columns + i;
            let quad = [nw, nw + 1, nw + grid.columns, nw + grid.columns + 1];
            let Some(level) = quad
                .iter()
                .filter_map(|&v| levels[v])
                .max_by(f32::total_cmp)
            else {
                continue;
            };
            let [a, b, c, d] = quad.map(|v| match made[v] {
                Some((index, at)) if at == level => index,
                _ => {
                    let (x, z) = grid.xz(v);
                    let y = curvature.scene_y(x, z, f64::from(level));
                    let index = water.positions.len() as u32;
                    water.positions.push([x as f32, y as f32, z as f32]);
                    water.normals.push(curvature.up(x, y, z));
                    made[v] = Some((index, level));
                    index
                }
            });
            water.indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    water
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terrain::DemGrid;

    #[test]
    fn catmull_rom_interpolates_and_keeps_ramps() {
        for t in [0.0, 0.25, 0.5, 0.9] {
            let w = catmull_rom_weights(t);
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            // A linear ramp 0, 1, 2, 3 is reproduced: value at 1 + t.
            let ramp: f64 = w.iter().enumerate().map(|(k, w)| w * k as f64).sum();
            assert!((ramp - (1.0 + t)).abs() < 1e-12);
        }
        assert_eq!(catmull_rom_weights(0.0), [0.0, 1.0, 0.0, 0.0]);
        let mut out = [0.0; 7];
        upsample_line(3, 3, |k| [10.0, 20.0, 40.0][k], |i, v| out[i] = v);
        assert_eq!((out[0], out[3], out[6]), (10.0, 20.0, 40.0));
        assert!(out[1] > 10.0 && out[1] < 20.0 && out[4] > 20.0 && out[4] < 40.0);
    }

    fn flat_dem(ncols: usize, nrows: usize, height: f32) -> Dem {
        let grid = DemGrid {
            lower_left_lon_deg: 7.4,
            lower_left_lat_deg: 46.9,
            cell_lon_deg: 0.01,
            cell_lat_deg: 0.01,
        };
        Dem::new(ncols, nrows, vec![height; ncols * nrows], grid).unwrap()
    }

    fn bare() -> TerrainSettings {
        TerrainSettings {
            detail: TerrainDetail {
                octaves: 0,
                ..TerrainDetail::default()
            },
            summits: Vec::new(),
            lakes: Vec::new(),
            planet_radius_m: None,
            ..TerrainSettings::default()
        }
    }

    #[test]
    fn flat_dem_gives_a_flat_upward_mesh() {
        let dem = flat_dem(5, 4, 600.0);
        let plane = TangentPlane::new(46.92, 7.42, 0.0);
        let mesh = TerrainMesh::build(&dem, &plane, &bare()).unwrap();
        assert_eq!((mesh.stats.columns, mesh.stats.rows), (13, 10));
        assert_eq!(mesh.triangle_count(), 12 * 9 * 2);
        assert!(mesh.positions.iter().all(|p| p[1] == 600.0));
        assert!(mesh.normals.iter().all(|n| *n == [0.0, 1.0, 0.0]));
        assert_eq!(mesh.height_at_scene(0.0, 0.0), Some(600.0));
        assert_eq!(mesh.height_at_scene(1e6, 0.0), None);
        // Every triangle faces up (counter-clockwise seen from above).
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.positions[i as usize]);
            let (u, v) = ([b[0] - a[0], b[2] - a[2]], [c[0] - a[0], c[2] - a[2]]);
            // y of (b − a) × (c − a).
            assert!(u[1] * v[0] - u[0] * v[1] > 0.0);
        }
    }

    #[test]
    fn height_at_scene_follows_the_triangles() {
        // A tilted plane: every triangle holds it exactly, so interpolation must too.
        let grid = DemGrid {
            lower_left_lon_deg: 7.4,
            lower_left_lat_deg: 46.9,
            cell_lon_deg: 0.01,
            cell_lat_deg: 0.01,
        };
        let heights = (0..4 * 3)
            .map(|k| 500.0 + 10.0 * (k % 4) as f32 + 3.0 * (k / 4) as f32)
            .collect();
        let dem = Dem::new(4, 3, heights, grid).unwrap();
        let plane = TangentPlane::new(46.91, 7.415, 0.0);
        let mesh = TerrainMesh::build(&dem, &plane, &bare()).unwrap();
        for k in 0..50 {
            let lat = 46.9 + 0.02 * (k as f64 / 49.0);
            let lon = 7.4 + 0.03 * ((k * 7 % 50) as f64 / 49.0);
            let [x, _, z] = plane.to_scene(lat, lon, 0.0);
            let expected = dem.height_at(lat, lon).unwrap();
            let got = mesh.height_at_scene(x, z).unwrap();
            assert!(
                (got - expected).abs() < 1e-3,
                "{lat} {lon}: {got} vs {expected}"
            );
        }
    }

    #[test]
    fn curvature_lowers_distant_ground() {
        let dem = flat_dem(3, 3, 0.0);
        let plane = TangentPlane::new(46.9, 7.4, 0.0);
        let settings = TerrainSettings {
            planet_radius_m: Some(6_371_000.0),
            ..bare()
        };
        let mesh = TerrainMesh::build(&dem, &plane, &settings).unwrap();
        let far = mesh.positions.last().unwrap();
        let d2 = f64::from(far[0]).powi(2) + f64::from(far[2]).powi(2);
        let drop = d2 / (2.0 * 6_371_000.0);
        assert!((f64::from(far[1]) + drop).abs() < 1e-3 * drop.max(1.0));
        assert_eq!(mesh.altitude_at_scene(0.0, 0.0), Some(0.0));
    }

    #[test]
    fn summit_is_exact_and_highest() {
        let dem = flat_dem(20, 20, 550.0);
        let plane = TangentPlane::new(46.95, 7.5, 0.0);
        let summit = Summit {
            latitude_deg: 46.9731,
            longitude_deg: 7.5123,
            ..Summit::BANTIGER
        };
        let settings = TerrainSettings {
            summits: vec![summit.clone()],
            ..bare()
        };
        let mesh = TerrainMesh::build(&dem, &plane, &settings).unwrap();
        assert_eq!(mesh.stats.pinned_summits, 1);
        let [x, _, z] = plane.to_scene(summit.latitude_deg, summit.longitude_deg, 0.0);
        assert_eq!(mesh.altitude_at_scene(x, z), Some(947.0));
        assert_eq!(mesh.stats.max_altitude_m, 947.0);
        // The bump is gone 1 km away.
        assert_eq!(mesh.altitude_at_scene(x + 1600.0, z), Some(550.0));
    }

    #[test]
    fn lake_cells_become_water() {
        // A 9 × 9 DEM at 600 m with a 5 × 5 lake at 558 m in the middle.
        let mut heights = vec![600.0; 81];
        for r in 2..7 {
            for c in 2..7 {
                heights[r * 9 + c] = 558.0;
            }
        }
        // A separate flat patch at the lake level far from the lake's point stays land.
        heights[0] = 558.0;
        let grid = DemGrid {
            lower_left_lon_deg: 7.6,
            lower_left_lat_deg: 46.6,
            cell_lon_deg: 0.01,
            cell_lat_deg: 0.01,
        };
        let dem = Dem::new(9, 9, heights, grid).unwrap();
        let lake = Lake {
            latitude_deg: 46.64,
            longitude_deg: 7.64,
            radius_m: 4000.0,
            ..Lake::THUN
        };
        let settings = TerrainSettings {
            lakes: vec![lake],
            ..bare()
        };
        let plane = TangentPlane::new(46.64, 7.64, 0.0);
        let mesh = TerrainMesh::build(&dem, &plane, &settings).unwrap();
        assert_eq!(mesh.stats.lakes_found, 1);
        assert!(mesh.stats.water_vertices > 0 && mesh.stats.water_triangles > 0);
        // The lake's middle is water, its bed 2 m under the level; the far patch is land.
        assert!(mesh.is_water[mesh.stats.columns * 12 + 12]);
        assert_eq!(mesh.altitude_at_scene(0.0, 0.0), Some(556.0));
        assert!(!mesh.is_water[0]);
        assert!(mesh.water.positions.iter().all(|p| p[1] == 558.0));
        assert!(mesh.water.normals.iter().all(|n| *n == [0.0, 1.0, 0.0]));
        // Land never dips under the water next to the lake.
        for (k, a) in mesh.altitudes_m.iter().enumerate() {
            assert!(mesh.is_water[k] || *a >= 558.5 || k == 0, "{k} {a}");
        }
    }

    #[test]
    fn rejects_tiny_and_huge_grids() {
        let dem = flat_dem(1, 5, 0.0);
        let err = TerrainMesh::build(&dem, &TangentPlane::default(), &bare()).unwrap_err();
        assert_eq!(err, MeshError::TooSmall { ncols: 1, nrows: 5 });
        let dem = flat_dem(100, 100, 0.0);
        let settings = TerrainSettings {
            upsample: 1000,
            ..bare()
        };
        let err = TerrainMesh::build(&dem, &TangentPlane::default(), &settings).unwrap_err();
        assert!(matches!(err, MeshError::TooManyVertices { .. }));
    }
}
