//! The foundation scene: Bevy's atmosphere and a sunlit ground plane, rendered headless.

use bevy::{
    camera::RenderTarget, core_pipeline::tonemapping::Tonemapping, prelude::*,
    render::render_resource::TextureFormat,
};

use crate::common;
use crate::harness::{Headless, output_dir};

/// Pixel position of a world direction seen from the sky-scene camera.
fn project(direction: Vec3, camera: &Transform, size: UVec2) -> Vec2 {
    let view = camera.rotation.inverse() * direction;
    let tan_half = (common::SKY_SCENE_FOV_DEG.to_radians() * 0.5).tan();
    let aspect = size.x as f32 / size.y as f32;
    let ndc = Vec2::new(
        view.x / -view.z / (tan_half * aspect),
        view.y / -view.z / tan_half,
    );
    Vec2::new(
        (ndc.x + 1.0) * 0.5 * size.x as f32,
        (1.0 - ndc.y) * 0.5 * size.y as f32,
    )
}

#[test]
fn atmosphere_sky_and_sunlit_ground() {
    let size = UVec2::new(160, 90);
    let mut app = Headless::new(size, TextureFormat::Rgba16Float, |app| {
        app.add_systems(Startup, common::spawn_sky_scene);
    });
    let target = app.target.clone();
    let camera = app
        .world()
        .spawn((
            common::sky_scene_camera(),
            RenderTarget::Image(target.into()),
        ))
        // Linear exposed radiance, no tonemapping curve.
        .insert(Tonemapping::None)
        .id();
    app.run_frames(6);
    let pixels = app.read_target();
    pixels.save_png(output_dir().join("sky.png"), 1.0);

    assert!(
        pixels
            .rgba
            .iter()
            .all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0)),
        "every pixel finite and non-negative"
    );

    let camera_transform = *app.world().get::<Transform>(camera).unwrap();
    let sun = project(common::sky_scene_sun_direction(), &camera_transform, size);
    assert!(
        sun.x > 8.0 && sun.x < size.x as f32 - 8.0 && sun.y > 8.0,
        "sun at {sun} must be inside the frame for this test"
    );
    // A window beside the sun and the same window mirrored to the far side of the view, at the
    // same elevation: forward (Mie) scattering makes the sky much brighter toward the sun.
    let (sx, sy) = (sun.x as u32, sun.y as u32);
    let mirrored = size.x - sx;
    let near_sun = pixels.mean_luminance(sx - 6, sx + 6, sy - 6, sy + 6);
    let away = pixels.mean_luminance(mirrored - 6, mirrored + 6, sy - 6, sy + 6);
    assert!(
        near_sun > 1.5 * away && away > 0.0,
        "sky near the sun ({near_sun}) must be brighter than away from it ({away})"
    );

    // Below the horizon is ground lit by the sun: neither black nor clipped.
    let horizon = project(Vec3::NEG_Z, &camera_transform, size).y as u32;
    let ground_rows = horizon + 4..size.y;
    assert!(ground_rows.len() >= 8, "enough ground in view");
    let ground = pixels.mean_luminance(0, size.x, ground_rows.start, ground_rows.end);
    assert!(
        (0.02..1.0).contains(&ground),
        "lit ground luminance {ground} must be neither black nor saturated"
    );
    let mut ground_values: Vec<f32> = ground_rows
        .flat_map(|y| (0..size.x).map(move |x| (x, y)))
        .map(|(x, y)| pixels.luminance(x, y))
        .collect();
    ground_values.sort_by(f32::total_cmp);
    assert!(
        ground_values[ground_values.len() - 1] < 1.0,
        "no ground pixel clips"
    );
}

/// The world direction through the centre of pixel (`x`, `y`) of a `size` image seen by a
/// camera turned by `rotation` with a `fov_deg` vertical field of view.
fn pixel_direction(
    rotation: bevy::math::DQuat,
    size: UVec2,
    fov_deg: f64,
    x: u32,
    y: u32,
) -> bevy::math::DVec3 {
    let tan_half = (0.5 * fov_deg).to_radians().tan();
    let aspect = f64::from(size.x) / f64::from(size.y);
    let ndc_x = (2.0 * (f64::from(x) + 0.5) / f64::from(size.x) - 1.0) * tan_half * aspect;
    let ndc_y = (1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(size.y)) * tan_half;
    (rotation * bevy::math::DVec3::new(ndc_x, ndc_y, -1.0)).normalize()
}

/// A `MEDIUM` cloud camera at `transform` with a `fov_deg` vertical field of view, exposed at
/// `ev100` without tone mapping, rendering into the app's target.
fn spawn_night_camera(app: &mut Headless, transform: Transform, fov_deg: f32, ev100: f32) {
    use bevy::camera::Exposure;
    use bevy_cloudscape::prelude::VolumetricClouds;
    let target = app.target.clone();
    app.world().spawn((
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection {
            fov: fov_deg.to_radians(),
            ..default()
        }),
        transform,
        Exposure { ev100 },
        Tonemapping::None,
        VolumetricClouds::MEDIUM,
        RenderTarget::Image(target.into()),
    ));
}

/// The stars at night: a clear sky shows the star field where its CPU twin puts it and as bright
/// as the twin says; an overcast deck hides it. (That there are none by day, or without a `Sun`
/// light, is `stars_need_a_sun_light_below_the_horizon` in `src/sky/stars.rs`: the frame without
/// stars here is the same shader path.)
#[test]
fn stars_shine_at_night_where_the_twin_puts_them_and_clouds_hide_them() {
    use bevy::camera::Exposure;
    use bevy_cloudscape::{
        prelude::*,
        scene::{SceneClock, UtcInstant},
        sky::{
            Sun,
            stars::{StarField, star_radiance},
        },
    };
    let size = UVec2::new(160, 90);
    let ev100 = -4.0;
    // Looking south-east, 50° up, from Bern: the moon is down at 01:00 UTC on 2021-05-11 (new
    // moon) and the sun 26° below the horizon.
    let camera_transform = crate::common::scenes::looking(Vec3::new(0.0, 2.0, 0.0), 50.0, 135.0);
    let render = |time: &str, stars: bool, deck: bool| {
        let instant: UtcInstant = time.parse().unwrap();
        let mut app = Headless::new(size, TextureFormat::Rgba16Float, |app| {
            app.add_plugins(CloudscapePlugin)
                .insert_resource(CloudNoiseSettings(crate::common::scenes::small_recipe()))
                .insert_resource(SceneClock::at(instant))
                .insert_resource(StarField {
                    enabled: stars,
                    ..default()
                });
        });
        app.world()
            .spawn((DirectionalLight::default(), Sun::default()));
        if deck {
            app.world().spawn(crate::common::scenes::layer(
                bevy_cloudscape::layers::CloudKind::Stratus,
                1.0,
            ));
        }
        spawn_night_camera(&mut app, camera_transform, 60.0, ev100);
        app.run_frames(20);
        app.read_target()
    };
    let night = "2021-05-11T01:00:00Z";
    let with = render(night, true, false);
    let without = render(night, false, false);
    with.save_png(output_dir().join("stars.png"), 1.0);

    // The twin at every pixel's centre: the same view, exposure and sky.
    let origin = bevy_cloudscape::scene::GeoOrigin::default();
    let instant: UtcInstant = night.parse().unwrap();
    let celestial =
        bevy_cloudscape::sky::stars::celestial_from_scene(&origin, instant.unix_seconds() as f64);
    let exposure = f64::from(Exposure { ev100 }.exposure());
    let fov_deg = 60.0;
    // The crate's pixel angle: the field of view over the image height.
    let sigma =
        bevy_cloudscape::sky::stars::STAR_BLUR_PIXELS * 60f64.to_radians() / f64::from(size.y);
    let zero_lux = bevy_cloudscape::sky::stars::zero_magnitude_lux();
    let rotation = camera_transform.rotation.as_dquat();
    let (mut peak_gpu, mut peak_twin, mut spots, mut diff2, mut twin2) =
        (0.0f64, 0.0f64, 0, 0.0, 0.0);
    for y in 0..size.y {
        for x in 0..size.x {
            let direction = pixel_direction(rotation, size, fov_deg, x, y);
            let elevation = direction.y.asin().to_degrees();
            let twin = star_radiance(0, celestial * direction, elevation, sigma, zero_lux);
            let twin = exposure * (0.2126 * twin[0] + 0.7152 * twin[1] + 0.0722 * twin[2]);
            let gpu = f64::from(with.luminance(x, y) - without.luminance(x, y));
            peak_gpu = peak_gpu.max(gpu);
            peak_twin = peak_twin.max(twin);
            spots += usize::from(twin > 0.01);
            diff2 += (gpu - twin).powi(2);
            twin2 += twin * twin;
        }
    }
    let relative = (diff2 / twin2).sqrt();
    println!(
        "stars: twin peak {peak_twin:.4}, GPU peak {peak_gpu:.4}, relative RMSE {relative:.3}, {spots} pixels above 0.01"
    );
    assert!(spots >= 5, "the view holds stars: {spots} pixels");
    assert!(
        relative < 0.1,
        "the GPU's stars are the twin's: relative RMSE {relative:.3} (peaks {peak_gpu} and {peak_twin})"
    );

    // An overcast deck hides them.
    let overcast = render(night, true, true);
    let overcast_plain = render(night, false, true);
    let hidden = (0..size.y)
        .flat_map(|y| (0..size.x).map(move |x| (x, y)))
        .map(|(x, y)| f64::from(overcast.luminance(x, y) - overcast_plain.luminance(x, y)))
        .fold(0.0, f64::max);
    assert!(
        hidden < 0.01 * peak_twin,
        "the deck hides the stars: {hidden} against {peak_twin}"
    );
}

/// The moon's disc: the first-quarter moon over Bern shows as its CPU twin draws it (lit on the
/// sun's side, dark on the other, as bright as the moon's illuminance makes it), and nothing is
/// drawn with `Sun::moon_disc` off. (That Bevy's own round disc is hidden meanwhile is
/// `the_moon_light_hides_bevys_round_disc` in `src/sky/sun.rs`.)
#[test]
fn the_moon_shows_its_phase_where_the_twin_draws_it() {
    use bevy::camera::Exposure;
    use bevy_cloudscape::{
        prelude::*,
        scene::{GeoOrigin, SceneClock, UtcInstant},
        sky::{
            Observer, SolarOptions, Sun, lunar_position_unix_seconds, moon::disc::MoonDisc,
            moon_direction_scene, solar_position_unix_seconds, sun_direction_scene,
        },
    };
    let size = UVec2::new(160, 90);
    let fov_deg = 3.0f64;
    let ev100 = 10.0;
    // 2021-05-19 21:00 UTC: the first-quarter moon 40° up in the south-west of Bern, the sun
    // 15° below the horizon (PyEphem).
    let instant: UtcInstant = "2021-05-19T21:00:00Z".parse().unwrap();
    let t = instant.unix_seconds() as f64;
    let observer = Observer::from(&GeoOrigin::default());
    let lunar = lunar_position_unix_seconds(&observer, t, &SolarOptions::default());
    let solar = solar_position_unix_seconds(&observer, t, &SolarOptions::default());
    let toward_moon = moon_direction_scene(&lunar);
    assert!(lunar.elevation_deg > 20.0 && solar.elevation_deg < -12.0);
    let camera_transform = Transform::from_xyz(0.0, 2.0, 0.0).looking_to(toward_moon, Vec3::Y);
    let render = |moon_disc: bool| {
        let mut app = Headless::new(size, TextureFormat::Rgba16Float, |app| {
            app.add_plugins(CloudscapePlugin)
                .insert_resource(CloudNoiseSettings(crate::common::scenes::small_recipe()))
                .insert_resource(SceneClock::at(instant));
        });
        app.world().spawn((
            DirectionalLight::default(),
            Sun {
                moon_disc,
                ..default()
            },
        ));
        spawn_night_camera(&mut app, camera_transform, fov_deg as f32, ev100);
        app.run_frames(6);
        app.read_target()
    };
    let with = render(true);
    let without = render(false);
    with.save_png(output_dir().join("moon.png"), 1.0);

    let disc = MoonDisc::new(
        &lunar,
        &solar,
        toward_moon.as_dvec3().normalize(),
        sun_direction_scene(&solar).as_dvec3().normalize(),
        lunar.illuminance_lux(),
    );
    let exposure = f64::from(Exposure { ev100 }.exposure());
    let pixel = fov_deg.to_radians() / f64::from(size.y);
    let rotation = camera_transform.rotation.as_dquat();
    let (mut diff2, mut twin2, mut lit_pixels) = (0.0, 0.0, 0);
    // The disc's lit and dark halves, by the side of the sun each pixel is on.
    let across =
        (disc.toward_sun - disc.direction * disc.toward_sun.dot(disc.direction)).normalize();
    let (mut sunward, mut away) = (0.0, 0.0);
    for y in 0..size.y {
        for x in 0..size.x {
            let direction = pixel_direction(rotation, size, fov_deg, x, y);
            let elevation = direction.y.asin().to_degrees();
            let twin = exposure * disc.radiance(direction, elevation, pixel);
            let gpu = f64::from(with.luminance(x, y) - without.luminance(x, y));
            diff2 += (gpu - twin).powi(2);
            twin2 += twin * twin;
            lit_pixels += usize::from(twin > 0.05);
            if direction.dot(disc.direction) > disc.radius_rad.cos() {
                if direction.dot(across) > 0.0 {
                    sunward += gpu;
                } else {
                    away += gpu;
                }
            }
        }
    }
    let relative = (diff2 / twin2).sqrt();
    println!(
        "moon: {lit_pixels} lit pixels, relative RMSE {relative:.4}, sunward half {sunward:.2}, other half {away:.2}"
    );
    assert!(
        lit_pixels >= 40,
        "the disc is drawn: {lit_pixels} lit pixels"
    );
    assert!(
        relative < 0.05,
        "the GPU's disc is the twin's: relative RMSE {relative:.4}"
    );
    assert!(
        away < 0.05 * sunward,
        "a quarter moon is lit on the sun's side only: {sunward} against {away}"
    );
}
