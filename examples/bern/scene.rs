//! The sky, the sun, the camera and the clouds of the Bern scene (the ground: `terrain.rs`).

use super::*;

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
    mut terrain_materials: ResMut<Assets<TerrainMaterial>>,
    mut media: ResMut<Assets<ScatteringMedium>>,
    #[cfg(feature = "live")] mut live: ResMut<bevy_cloudscape::weather::LiveForecasts>,
    #[cfg(feature = "live")] forecasts: Res<Assets<Forecast>>,
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
    spawn_ground(
        &mut commands,
        &terrain,
        &mut meshes,
        &mut materials,
        &mut terrain_materials,
    );

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
                fov: options.fov_deg.to_radians(),
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
    if !options.sky_light {
        commands
            .entity(camera)
            .insert(bevy_cloudscape::render::sky_light::CloudSkyLight::disabled());
    }
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

    let (near, far): (Handle<Forecast>, [Handle<Forecast>; 2]) = {
        #[cfg(feature = "live")]
        if options.live {
            use bevy_cloudscape::weather::LiveForecast;
            let origin = GeoOrigin::default();
            let url = &options.open_meteo_url;
            let near = live.add(
                &forecasts,
                LiveForecast::open_meteo_at(url, origin.latitude_deg, origin.longitude_deg)
                    .named("Bern"),
            );
            let far = Viewpoint::ALL.map(|viewpoint| {
                let (latitude, longitude) = viewpoint.far_place_deg();
                live.add(
                    &forecasts,
                    LiveForecast::open_meteo_at(url, latitude, longitude)
                        .named(viewpoint.far_place()),
                )
            });
            (near, far)
        } else {
            (
                asset_server.load(NEAR_FORECAST),
                Viewpoint::ALL.map(|viewpoint| asset_server.load(viewpoint.far_forecast())),
            )
        }
        #[cfg(not(feature = "live"))]
        (
            asset_server.load(NEAR_FORECAST),
            Viewpoint::ALL.map(|viewpoint| asset_server.load(viewpoint.far_forecast())),
        )
    };
    let index = Viewpoint::ALL
        .iter()
        .position(|v| *v == view.viewpoint)
        .unwrap_or(0);
    commands.insert_resource(WeatherSource {
        near: Some(near),
        far: vec![FarForecast {
            forecast: far[index].clone(),
        }],
    });
    commands.insert_resource(FarForecasts(far));
    let layers = spawn_weather_layers(&mut commands);
    if options.growth {
        // The low slot's layer: cumulus and stratocumulus form and dissolve with its cover.
        let low = LayerSlot::ALL.iter().position(|s| *s == LayerSlot::Low);
        if let Some(&entity) = low.and_then(|i| layers.get(i)) {
            commands.entity(entity).insert(low_cloud_growth());
        }
    }
}

/// The automaton the low clouds grow with (`--growth`, or the panel's checkbox): 96 × 96
/// columns over the cumulus weather period (about 125 m each) and eight noise features across
/// it, so the clouds grow to cumulus size.
pub(crate) fn low_cloud_growth() -> CloudGrowth {
    let maker = bevy_cloudscape::layers::NoiseMaker {
        increment: [0.08, 0.08],
        ..default()
    };
    CloudGrowth {
        grid: [96, 96, 16],
        humidity: maker.clone(),
        activation: bevy_cloudscape::layers::NoiseMaker { seed: 1, ..maker },
        ..default()
    }
}
