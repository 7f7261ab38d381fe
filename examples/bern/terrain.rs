//! The Bern scene's ground: the DEM read into a terrain mesh, with its lakes, or flat ground
//! when the DEM cannot be used.

use super::*;

pub(crate) fn terrain_settings() -> TerrainSettings {
    TerrainSettings::default()
}

/// Reads the DEM and builds the terrain mesh; a failure is logged and leaves flat ground.
pub(crate) fn load_terrain(mut commands: Commands, options: Res<BernOptions>) {
    let origin = GeoOrigin::default();
    let plane = TangentPlane::new(
        origin.latitude_deg,
        origin.longitude_deg,
        origin.elevation_m,
    );
    let started = Instant::now();
    let built = Dem::from_path(&options.dem)
        .map_err(|e| e.to_string())
        .and_then(|dem| {
            TerrainMesh::build(&dem, &plane, &terrain_settings())
                .map_err(|e| format!("{}: {e}", options.dem.display()))
        });
    let (mesh, error) = match built {
        Ok(mesh) => {
            info!(
                "terrain: {} triangles, {} water triangles, built in {:.2} s",
                mesh.triangle_count(),
                mesh.stats.water_triangles,
                started.elapsed().as_secs_f64()
            );
            (Some(mesh), None)
        }
        Err(e) => {
            error!("cannot use the terrain: {e}; showing flat ground at {BERN_GROUND_M} m");
            (None, Some(e))
        }
    };
    commands.insert_resource(Terrain { plane, mesh, error });
}

pub(crate) fn spawn_ground(
    commands: &mut Commands,
    terrain: &Terrain,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
) {
    let Some(mesh) = &terrain.mesh else {
        commands.spawn((
            Name::new("flat ground"),
            Mesh3d(meshes.add(Plane3d::default().mesh().size(120_000.0, 120_000.0))),
            MeshMaterial3d(materials.add(StandardMaterial {
                base_color: Color::srgb(0.25, 0.35, 0.18),
                perceptual_roughness: 0.9,
                ..default()
            })),
            Transform::from_xyz(0.0, BERN_GROUND_M, 0.0),
        ));
        return;
    };
    // The crate's mesh arrays are Bevy's attributes as they are; its colours are linear RGBA,
    // which is what Bevy expects of vertex colours.
    let ground = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::RENDER_WORLD,
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, mesh.positions.clone())
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, mesh.normals.clone())
    .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, mesh.colors.clone())
    .with_inserted_indices(Indices::U32(mesh.indices.clone()));
    commands.spawn((
        Name::new("terrain"),
        Mesh3d(meshes.add(ground)),
        MeshMaterial3d(materials.add(StandardMaterial {
            // White, so the vertex colours are the albedo.
            base_color: Color::WHITE,
            perceptual_roughness: 0.9,
            ..default()
        })),
    ));
    let water = &mesh.water;
    if water.indices.is_empty() {
        return;
    }
    let surface = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::RENDER_WORLD,
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, water.positions.clone())
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, water.normals.clone())
    .with_inserted_indices(Indices::U32(water.indices.clone()));
    commands.spawn((
        Name::new("lakes"),
        Mesh3d(meshes.add(surface)),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.03, 0.09, 0.16),
            perceptual_roughness: 0.12,
            ..default()
        })),
    ));
}
