//! The terrain, the sky, the sun, the camera and the clouds of the Bern scene.

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

/// Handles of both far forecasts, so switching views swaps them without reloading.
#[derive(Resource)]
pub(crate) struct FarForecasts(pub(crate) [Handle<Forecast>; 2]);

pub(crate) fn spawn_scene(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    terrain: Res<Terrain>,
    view: Res<ViewState>,
    options: Res<BernOptions>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut media: ResMut<Assets<ScatteringMedium>>,
) {
    // The planet's centre defaults to one radius below the origin: scene y is height above sea
    // level, as for the terrain.
    commands.spawn((
        Name::new("atmosphere"),
        Atmosphere::earth(media.add(ScatteringMedium::earth(256, 256))),
    ));
    // Sunlight above the air; the crate aims it and the atmosphere attenuates it.
    commands.spawn((
        Name::new("sun"),
        DirectionalLight {
            illuminance: lux::RAW_SUNLIGHT,
            ..default()
        },
        Sun::default(),
    ));
    spawn_ground(&mut commands, &terrain, &mut meshes, &mut materials);

    // The layers' altitudes count from Bern's ground, on the terrain's planet, which curves
    // around the scene origin.
    commands.insert_resource(CloudWorld {
        ground_height_m: BERN_GROUND_M,
        planet_radius_m: terrain_settings()
            .planet_radius_m
            .unwrap_or(CloudWorld::EARTH.planet_radius_m as f64) as f32,
        anchor: PlanetAnchor::Geocentric,
        ..default()
    });
    let camera = commands
        .spawn((
            Name::new("camera"),
            Camera3d::default(),
            Projection::Perspective(PerspectiveProjection {
                fov: FOV_DEG.to_radians(),
                ..default()
            }),
            viewpoint_transform(&view, &terrain),
            AtmosphereSettings {
                // The terrain reaches 60 km (the Alps); haze it all the way, not only the
                // default 32 km.
                aerial_view_lut_max_distance: 60_000.0,
                ..default()
            },
            AtmosphereEnvironmentMapLight::default(),
            Exposure {
                ev100: options.ev100,
            },
            Tonemapping::AcesFitted,
            Bloom::NATURAL,
            VolumetricClouds::MEDIUM,
            MainCamera,
            // Headless, the camera renders to an image: UI goes there too.
            IsDefaultUiCamera,
        ))
        .id();
    if !options.clouds {
        // The depth prepass and HDR that `VolumetricClouds` brought stay: only the clouds go.
        commands.entity(camera).remove::<VolumetricClouds>();
    }
    if let Some(error) = &terrain.error {
        commands.spawn((
            Node {
                position_type: PositionType::Absolute,
                top: px(8),
                left: px(8),
                right: px(8),
                padding: UiRect::all(px(6)),
                ..default()
            },
            BackgroundColor(Color::srgba(0.3, 0.0, 0.0, 0.7)),
            Text::new(format!(
                "Terrain unavailable: {error}\nShowing flat ground at {BERN_GROUND_M} m."
            )),
            TextFont {
                font_size: FontSize::Px(14.0),
                ..default()
            },
            TextColor(Color::WHITE),
            UiTargetCamera(camera),
        ));
    }

    let far: [Handle<Forecast>; 2] =
        Viewpoint::ALL.map(|viewpoint| asset_server.load(viewpoint.far_forecast()));
    commands.insert_resource(WeatherSource::load(
        &asset_server,
        NEAR_FORECAST,
        [view.viewpoint.far_forecast().into()],
    ));
    commands.insert_resource(FarForecasts(far));
    spawn_weather_layers(&mut commands);
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
