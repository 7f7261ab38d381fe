//! Tests on the bundled Bern DEM (`assets/terrain/bern_globe30s.asc`).

use std::path::PathBuf;

use super::*;

fn bundled_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/terrain/bern_globe30s.asc")
}

fn bundled() -> Dem {
    Dem::from_path(bundled_path()).unwrap()
}

/// The scene origin of the Bern demo: Bern old town, y = altitude.
fn bern() -> TangentPlane {
    TangentPlane::new(46.948, 7.447, 0.0)
}

#[test]
fn bundled_dem_matches_its_readme() {
    let dem = bundled();
    assert_eq!((dem.ncols(), dem.nrows()), (168, 108));
    assert_eq!(dem.filled_cells(), 0);
    let grid = dem.grid();
    let cell = 1.0 / 120.0;
    assert!((grid.cell_lon_deg - cell).abs() < 1e-12);
    assert!((grid.cell_lat_deg - cell).abs() < 1e-12);
    // xllcorner 6.8, yllcorner 46.4: the first centre is half a cell in.
    assert!((grid.lower_left_lon_deg - (6.8 + cell / 2.0)).abs() < 1e-12);
    assert!((grid.lower_left_lat_deg - (46.4 + cell / 2.0)).abs() < 1e-12);
    assert_eq!(dem.min_max_m(), (370.0, 4130.0));
    // Bern old town, 538 m at 46.948 N 7.447 E: the cell there holds 538, and the bilinear
    // height is within the spread of the neighbouring cells.
    let (u, v) = dem.cell_coordinates(46.948, 7.447);
    let (col, row) = (u.round() as usize, dem.nrows() - 1 - v.round() as usize);
    assert_eq!(dem.height(col, row), Some(538.0));
    let bern = dem.height_at(46.948, 7.447).unwrap();
    assert!((500.0..=560.0).contains(&bern), "{bern}");
    // The lakes are flat at their levels.
    assert_eq!(dem.height_at(46.69, 7.71), Some(558.0));
    assert_eq!(dem.height_at(47.085, 7.165), Some(429.0));
    // Corners of the covered area.
    assert!(dem.contains(46.4, 6.8) && dem.contains(47.3, 8.2));
    assert!(!dem.contains(47.31, 7.5) && dem.height_at(46.39, 7.5).is_none());
}

#[test]
fn bundled_mesh_at_default_settings() {
    let dem = bundled();
    let plane = bern();
    let mesh = TerrainMesh::build(&dem, &plane, &TerrainSettings::default()).unwrap();
    let stats = &mesh.stats;
    assert_eq!((stats.columns, stats.rows), (502, 322));
    assert_eq!(stats.triangles, 501 * 321 * 2);
    assert!(
        stats.triangles + stats.water_triangles < 500_000,
        "{stats:?}"
    );
    assert_eq!(stats.pinned_summits, 2);
    assert_eq!(stats.lakes_found, 5, "{stats:?}");
    assert!(stats.water_triangles > 1000, "{stats:?}");
    let vertices = stats.vertices;
    assert_eq!(mesh.positions.len(), vertices);
    assert_eq!(mesh.normals.len(), vertices);
    assert_eq!(mesh.colors.len(), vertices);
    assert_eq!(mesh.altitudes_m.len(), vertices);
    assert_eq!(mesh.is_water.len(), vertices);
    assert!(mesh.indices.iter().all(|&i| (i as usize) < vertices));
    assert!(
        mesh.water
            .indices
            .iter()
            .all(|&i| (i as usize) < mesh.water.positions.len())
    );
    assert!(mesh.positions.iter().flatten().all(|c| c.is_finite()));
    assert!(mesh.water.positions.iter().flatten().all(|c| c.is_finite()));
    for n in mesh.normals.iter().chain(&mesh.water.normals) {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((len - 1.0).abs() < 1e-5 && n[1] > 0.0, "{n:?}");
    }
    for c in &mesh.colors {
        assert!(c.iter().all(|v| (0.0..=1.0).contains(v)), "{c:?}");
    }
    // Detail stays within tens of metres of the data: the range barely moves.
    assert!(
        stats.min_altitude_m > 340.0 && stats.max_altitude_m < 4200.0,
        "{stats:?}"
    );
    // The Alps are snowy, the Plateau is green.
    let snowy = mesh.colors.iter().filter(|c| c[0] > 0.6).count();
    assert!(snowy > 100, "{snowy}");
}

#[test]
fn summits_are_exact_and_cameras_can_stand_on_them() {
    let dem = bundled();
    let plane = bern();
    let mesh = TerrainMesh::build(&dem, &plane, &TerrainSettings::default()).unwrap();
    for summit in bern_summits() {
        let [x, _, z] = plane.to_scene(summit.latitude_deg, summit.longitude_deg, 0.0);
        assert_eq!(
            mesh.altitude_at_scene(x, z),
            Some(summit.altitude_m),
            "{}",
            summit.name
        );
        // Scene y is a little lower: the planet curves away from the tangent plane at Bern
        // (under 5 m this close).
        let y = mesh.height_at_scene(x, z).unwrap();
        let drop = summit.altitude_m - y;
        assert!((0.0..5.0).contains(&drop), "{}: {drop}", summit.name);
        // The top is the highest ground within a kilometre.
        for k in 0..64 {
            let angle = k as f64 * std::f64::consts::TAU / 64.0;
            for r in [150.0, 400.0, 800.0] {
                let a = mesh
                    .altitude_at_scene(x + r * angle.cos(), z + r * angle.sin())
                    .unwrap();
                assert!(a <= summit.altitude_m, "{} at {r} m: {a}", summit.name);
            }
        }
        // The raw DEM is lower: pinning did something.
        let raw = dem
            .height_at(summit.latitude_deg, summit.longitude_deg)
            .unwrap();
        assert!(raw < summit.altitude_m - 20.0, "{}: {raw}", summit.name);
    }
}

#[test]
fn height_at_scene_lies_on_the_drawn_triangles() {
    let dem = bundled();
    let mesh = TerrainMesh::build(&dem, &bern(), &TerrainSettings::default()).unwrap();
    let columns = mesh.stats.columns;
    // Points inside a few quads, checked against the triangles in the index buffer.
    for (quad_i, quad_j) in [(10, 10), (228, 135), (400, 300), (123, 45)] {
        let quad = quad_j * (columns - 1) + quad_i;
        let corner = mesh.positions[quad_j * columns + quad_i];
        for (fu, fv) in [(0.5, 0.5), (0.2, 0.3), (0.8, 0.6), (0.1, 0.85)] {
            let x = f64::from(corner[0]) + fu * mesh.stats.spacing_east_m;
            let z = f64::from(corner[2]) + fv * mesh.stats.spacing_north_m;
            let got = mesh.height_at_scene(x, z).unwrap();
            let expected = mesh.indices[quad * 6..quad * 6 + 6]
                .chunks_exact(3)
                .find_map(|t| {
                    let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.positions[i as usize]);
                    barycentric_height(a, b, c, x as f32, z as f32)
                })
                .unwrap();
            assert!((got - expected).abs() < 1e-2, "{got} vs {expected}");
        }
    }
}

/// The height of triangle `abc` above `(x, z)`, if the point lies inside it (seen from above).
fn barycentric_height(a: [f32; 3], b: [f32; 3], c: [f32; 3], x: f32, z: f32) -> Option<f32> {
    let det = (b[2] - c[2]) * (a[0] - c[0]) + (c[0] - b[0]) * (a[2] - c[2]);
    let wa = ((b[2] - c[2]) * (x - c[0]) + (c[0] - b[0]) * (z - c[2])) / det;
    let wb = ((c[2] - a[2]) * (x - c[0]) + (a[0] - c[0]) * (z - c[2])) / det;
    let wc = 1.0 - wa - wb;
    let eps = -1e-4;
    (wa >= eps && wb >= eps && wc >= eps).then(|| wa * a[1] + wb * b[1] + wc * c[1])
}

#[test]
fn lakes_on_the_bundled_dem_are_water() {
    let dem = bundled();
    let plane = bern();
    let mesh = TerrainMesh::build(&dem, &plane, &TerrainSettings::default()).unwrap();
    for lake in bern_lakes() {
        let [x, _, z] = plane.to_scene(lake.latitude_deg, lake.longitude_deg, 0.0);
        let bed = mesh.altitude_at_scene(x, z).unwrap();
        assert_eq!(bed, lake.level_m - 2.0, "{}", lake.name);
    }
    // Bern itself is dry, and the Aare valley below Lake Thun did not flood.
    let [x, _, z] = plane.to_scene(46.948, 7.447, 0.0);
    assert!(mesh.altitude_at_scene(x, z).unwrap() > 500.0);
    let water_near_bern = mesh
        .positions
        .iter()
        .zip(&mesh.is_water)
        .filter(|(p, w)| **w && p[0].hypot(p[2]) < 15_000.0)
        .count();
    assert_eq!(water_near_bern, 0);
}

#[test]
fn dem_errors_name_the_file() {
    let dir = std::env::temp_dir().join(format!("cloudscape_terrain_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("broken.asc");
    let text = std::fs::read_to_string(bundled_path()).unwrap();
    // Cut the file after the 7th row of heights (line 13).
    let broken: String = text.lines().take(13).map(|l| format!("{l}\n")).collect();
    std::fs::write(&path, broken).unwrap();
    let err = Dem::from_path(&path).unwrap_err();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(err.file.as_deref(), Some(path.as_path()));
    assert_eq!(
        err.kind,
        DemErrorKind::TooFewRows {
            expected: 108,
            found: 7
        }
    );
    assert_eq!(
        err.to_string(),
        format!(
            "{}: line 14: only 7 rows of heights, expected 108 (nrows)",
            path.display()
        )
    );
}
