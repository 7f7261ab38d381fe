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
