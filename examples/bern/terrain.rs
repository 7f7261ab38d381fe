//! The Bern scene's ground: the DEM read into a terrain mesh, with its lakes, or flat ground
//! when the DEM cannot be used.

use super::*;
use bevy::{
    pbr::{ExtendedMaterial, MaterialExtension},
    render::render_resource::AsBindGroup,
    shader::ShaderRef,
};

/// The terrain's material: the standard material, whose albedo the mesh's vertex colours set,
/// with the land cover between the vertices drawn per pixel (`assets/shaders/land_cover.wgsl`).
pub(crate) type TerrainMaterial = ExtendedMaterial<StandardMaterial, LandCover>;

/// What the terrain shows between its vertices (about 200 m apart): fields with hedges between
/// them and woods on open ground, and the shading of knolls and hollows. Each fades toward its
/// mean where a pixel covers more ground than it can show.
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone)]
pub(crate) struct LandCover {
    /// Mean width of a field, metres. The Swiss Plateau's fields and meadows are a few hundred
    /// metres across.
    #[uniform(100)]
    field_size_m: f32,
    /// Share of the open ground (the mesh's meadow) under woods, 0.1–0.4. Forest covers about a
    /// quarter of the Plateau, in woods of a few hundred metres to kilometres.
    #[uniform(100)]
    wood_share: f32,
    /// Height of the knolls and hollows, metres.
    #[uniform(100)]
    relief_m: f32,
    /// Width of the hedges and tree lines between fields, metres.
    #[uniform(100)]
    hedge_m: f32,
    /// Linear albedo of the woods: the terrain palette's forest, as the mesh's own woods.
    #[uniform(100)]
    wood: Vec4,
    /// Linear albedo of snow: the terrain palette's.
    #[uniform(100)]
    snow: Vec4,
    /// Height where snow is half-way in on level ground, metres above sea level: the near
    /// forecast's snow line ([`follow_snow_line`]), the terrain palette's until a forecast
    /// gives one.
    #[uniform(100)]
    snow_line_m: f32,
    /// Width of the snow's transition around the snow line, metres: the terrain palette's.
    #[uniform(100)]
    snow_transition_m: f32,
}

impl Default for LandCover {
    fn default() -> Self {
        // The palette's own snow line: `terrain_settings` moves it off the mesh.
        let palette = TerrainPalette::default();
        Self {
            field_size_m: 250.0,
            wood_share: 0.25,
            relief_m: 12.0,
            hedge_m: 8.0,
            wood: Vec4::from_array(terrain_settings().palette.forest),
            snow: Vec4::from_array(palette.snow),
            snow_line_m: palette.snow_line_m,
            snow_transition_m: palette.snow_transition_m,
        }
    }
}

impl MaterialExtension for LandCover {
    fn fragment_shader() -> ShaderRef {
        "shaders/land_cover.wgsl".into()
    }

    fn deferred_fragment_shader() -> ShaderRef {
        "shaders/land_cover.wgsl".into()
    }
}

pub(crate) fn terrain_settings() -> TerrainSettings {
    let mut settings = TerrainSettings::default();
    // No snow in the vertex colours: the land cover draws it per pixel, where the forecast's
    // temperature puts it (`follow_snow_line`).
    settings.palette.snow_line_m = NO_BAKED_SNOW_M;
    settings
}

/// A snow line above every summit: the mesh's colours hold no snow.
const NO_BAKED_SNOW_M: f32 = 100_000.0;

/// The smallest change of the snow line that updates the terrain's material, metres (each
/// update uploads the material again).
const SNOW_LINE_STEP_M: f32 = 5.0;

/// The mean of the forecast's 2 m temperature over the day around `unix_seconds` (hourly
/// samples from 12 hours before to 11 after), °C: snow on the ground follows the day's warmth,
/// not the hour's. `None` without a finite temperature in that day.
fn day_mean_temperature_c(forecast: &Forecast, unix_seconds: f64) -> Option<f32> {
    let now = unix_seconds.floor() as i64;
    let temperatures: Vec<f32> = (-12..12)
        .filter_map(|hour| {
            forecast
                .sample(UtcInstant::from_unix_seconds(now + 3600 * hour))
                .get(bevy_cloudscape::weather::Variable::Temperature)
        })
        .filter(|t| t.is_finite())
        .collect();
    (!temperatures.is_empty()).then(|| temperatures.iter().sum::<f32>() / temperatures.len() as f32)
}

/// Moves the terrain's snow line with the near forecast's temperature, the mean of the day
/// around the scene time ([`day_mean_temperature_c`]). Without a temperature (no forecast yet,
/// or none in it) the line stays where it was.
pub(crate) fn follow_snow_line(
    source: Option<Res<WeatherSource>>,
    forecasts: Res<Assets<Forecast>>,
    clock: Res<SceneClock>,
    grounds: Query<&MeshMaterial3d<TerrainMaterial>>,
    mut materials: ResMut<Assets<TerrainMaterial>>,
) {
    let Some(temperature) = source
        .as_ref()
        .and_then(|source| source.near.as_ref())
        .and_then(|handle| forecasts.get(handle))
        .and_then(|forecast| day_mean_temperature_c(forecast, clock.unix_seconds()))
    else {
        return;
    };
    // Bern's ground is the forecast's station height.
    let Some(line) =
        bevy_cloudscape::precipitation::snow_line_height_m(temperature).map(|h| BERN_GROUND_M + h)
    else {
        return;
    };
    for ground in &grounds {
        let moved = materials
            .get(&ground.0)
            .is_some_and(|m| (m.extension.snow_line_m - line).abs() >= SNOW_LINE_STEP_M);
        if moved && let Some(mut material) = materials.get_mut(&ground.0) {
            debug!("snow line {line:.0} m (the day's mean temperature {temperature:.1} °C)");
            material.extension.snow_line_m = line;
        }
    }
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
    terrain_materials: &mut Assets<TerrainMaterial>,
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
        MeshMaterial3d(terrain_materials.add(ExtendedMaterial {
            base: StandardMaterial {
                // White, so the vertex colours are the albedo.
                base_color: Color::WHITE,
                perceptual_roughness: 0.9,
                ..default()
            },
            extension: LandCover::default(),
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
