//! The march pass in headless renders, against the f64 CPU reference renderer. The scenes and
//! the rig that recovers `L` and `T` from the composite are in `examples/common/scenes.rs`; the
//! noise is generated small here, so the CPU twin is quick.

use bevy::{
    camera::{Exposure, RenderTarget},
    prelude::*,
    render::render_resource::TextureFormat,
};
use bevy_cloudscape::{
    prelude::*,
    reference::render::CloudTextures,
    render::{march::CloudPassStats, shadow::CloudShadowStats},
};

use crate::common::scenes::*;
use crate::harness::{
    Headless, TWIN_RELATIVE_RMSE, TWIN_T_RMSE, output_dir, straight_horizontal_steps,
    twin_difference,
};

#[test]
fn showcase_scenes_match_the_cpu_reference() {
    let size = UVec2::new(96, 54);
    let (textures, mut rig) = small_rig(size);
    // And cumulus under an altostratus deck: the light march's pass through a layer above the
    // sample's own (`higher_layers_optical_depth`).
    let under_a_deck = Scene {
        name: "cumulus_under_altostratus",
        sun_deg: (30.0, 150.0),
        layers: vec![
            layer(CloudKind::Cumulus, 0.5),
            layer(CloudKind::Altostratus, 0.8),
        ],
        ..showcase_scenes().remove(0)
    };
    // And a cirrostratus veil with the sun in the middle of the view: its 22° halo.
    let halo = Scene {
        name: "cirrostratus_halo",
        camera: looking(Vec3::new(0.0, 2.0, 0.0), 40.0, 150.0),
        sun_deg: (40.0, 150.0),
        layers: vec![layer(CloudKind::Cirrostratus, 1.0)],
        ..showcase_scenes().remove(0)
    };
    for scene in showcase_scenes().into_iter().chain([under_a_deck, halo]) {
        rig.set_scene(&scene);
        let (gpu_l, gpu_t) = rig.render(4);
        let (cpu_l, cpu_t) = rig.reference(&textures);
        let strip = output_dir().join(format!("clouds_{}.png", scene.name));
        save_strip(&strip, size, &[&gpu_l, &cpu_l]);
        let (error, t_rmse, mean_t) = twin_difference((&gpu_l, &gpu_t), (&cpu_l, &cpu_t));
        eprintln!(
            "{}: relative RMSE of luminance {:.4}, RMSE of T {t_rmse:.4}, mean T {mean_t:.3}",
            scene.name, error
        );
        assert!(
            error <= TWIN_RELATIVE_RMSE,
            "{}: relative RMSE {error}",
            scene.name
        );
        assert!(
            t_rmse <= TWIN_T_RMSE,
            "{}: transmittance RMSE {t_rmse}",
            scene.name
        );
        assert!(
            mean_t < 0.95,
            "{}: the scene must actually show cloud (mean T {mean_t})",
            scene.name
        );
        if scene.name == "cirrostratus_halo" {
            // Along the middle row, 22.5° from the sun (the ring) against 19° (inside it) on
            // both sides: the camera's 60° vertical field of view at 16:9. Brighter by more
            // than the 2 % contrast an eye tells apart (Koschmieder's threshold); without the
            // halo the forward lobe makes 19° the brighter.
            let half_width = (30f32.to_radians().tan() * size.x as f32 / size.y as f32).atan();
            let at = |degrees: f32| {
                let x = degrees.to_radians().tan() / half_width.tan();
                let column = ((x + 1.0) * 0.5 * size.x as f32) as u32;
                let row = size.y / 2;
                luminance(&gpu_l[(row * size.x + column.min(size.x - 1)) as usize])
            };
            let (ring, inside) = (at(22.5) + at(-22.5), at(19.0) + at(-19.0));
            eprintln!("halo: ring {ring:.4}, inside {inside:.4}");
            assert!(
                ring > 1.02 * inside,
                "no halo: ring {ring}, inside {inside}"
            );
        }
    }
}

/// In a scene with Bevy's `Atmosphere` the clear air in front of the clouds veils them: the
/// GPU's march, fade included, matches its CPU twin, and the far cumulus toward the horizon
/// show less of their opacity than without an atmosphere (the twin's
/// `distant_clouds_fade_into_the_air_in_front_of_them` gives the amount). Without one the fade
/// is off: the background is then no air light.
#[test]
fn far_clouds_fade_into_the_air_under_bevys_atmosphere() {
    use bevy::light::{Atmosphere, atmosphere::ScatteringMedium};
    let size = UVec2::new(96, 54);
    let (textures, mut rig) = small_rig(size);
    let scene = Scene {
        name: "air_fair_cumulus",
        camera: looking(Vec3::new(0.0, 2.0, 0.0), 8.0, 0.0),
        sun_deg: (40.0, 150.0),
        layers: vec![layer(CloudKind::Cumulus, 0.5)],
        settings: settings(64),
    };
    rig.set_scene(&scene);
    let (_, airless_t) = rig.render(4);
    let airless = rig.rendered_view.clone().expect("a rendered view");
    assert!(!airless.settings.clear_air, "no atmosphere, no fade");
    {
        let world = rig.app.world();
        let medium = world
            .resource_mut::<Assets<ScatteringMedium>>()
            .add(ScatteringMedium::earth(64, 64));
        world
            .entity_mut(rig.camera)
            .insert(Atmosphere::earth(medium));
    }
    let (gpu_l, gpu_t) = rig.render(4);
    assert!(
        rig.rendered_view
            .as_ref()
            .expect("a rendered view")
            .settings
            .clear_air,
        "an atmosphere turns the fade on"
    );
    let (cpu_l, cpu_t) = rig.reference(&textures);
    save_strip(
        &output_dir().join(format!("clouds_{}.png", scene.name)),
        size,
        &[&gpu_l, &cpu_l],
    );
    let (error, t_rmse, mean_t) = twin_difference((&gpu_l, &gpu_t), (&cpu_l, &cpu_t));
    eprintln!("air: relative RMSE {error:.4}, RMSE of T {t_rmse:.4}, mean T {mean_t:.3}");
    assert!(error <= TWIN_RELATIVE_RMSE, "relative RMSE {error}");
    assert!(t_rmse <= TWIN_T_RMSE, "transmittance RMSE {t_rmse}");
    // The rows from level up to 4° (the camera looks 8° up with a 60° field of view): clouds
    // 20 km away and more, where clean air (visibility 245 km, Koschmieder) lets through
    // e^(−3.912 · 20 / 245) = 0.73 of their contrast at sea level, and less farther out.
    let row_of = |degrees: f32| {
        let half = 30f32.to_radians().tan();
        let y = (8f32 - degrees).to_radians().tan() / half;
        ((y + 1.0) * 0.5 * size.y as f32) as u32
    };
    let opacity = |t: &[f32]| {
        let rows = row_of(4.0)..row_of(0.0);
        let pixels = rows.len() as u32 * size.x;
        rows.flat_map(|row| (0..size.x).map(move |x| (row * size.x + x) as usize))
            .map(|i| 1.0 - f64::from(t[i]))
            .sum::<f64>()
            / f64::from(pixels)
    };
    let (with_air, without) = (opacity(&gpu_t), opacity(&airless_t));
    eprintln!("opacity within 4° of level: {with_air:.3} with the air, {without:.3} without");
    assert!(
        without > 0.1 && with_air < 0.8 * without,
        "the far clouds keep {with_air} of {without}"
    );
}

/// No frame draws a straight horizontal step in luminance across more than half its width
/// (`straight_horizontal_steps`) anywhere but at the horizon, where the ground and the layers
/// seen edge-on end (within two rows of it). Three weathers looking out over the horizon: fair
/// cumulus, an overcast deck, and a rain deck at evening (stratus 150-450 m at 42 % around a
/// camera 300 m up, an altostratus deck 2.8-5 km at 92 % and cirrostratus, the sun 6° up
/// beside the view). A map's edge, a blend's end or a shade that stops at some distance would
/// each draw such a line above or below the horizon.
#[test]
fn frames_show_no_straight_steps_off_the_horizon() {
    let size = UVec2::new(160, 90);
    let (_textures, mut rig) = small_rig(size);
    let fair = Scene {
        name: "steps_fair_cumulus",
        camera: looking(Vec3::new(0.0, 2.0, 0.0), 8.0, 0.0),
        sun_deg: (40.0, 150.0),
        layers: vec![layer(CloudKind::Cumulus, 0.5)],
        settings: settings(64),
    };
    let overcast = Scene {
        name: "steps_overcast",
        layers: vec![layer(CloudKind::Stratus, 1.0)],
        ..fair.clone()
    };
    let evening = Scene {
        name: "steps_rain_deck_evening",
        camera: looking(Vec3::new(0.0, 300.0, 0.0), 8.0, 0.0),
        sun_deg: (6.0, 60.0),
        layers: vec![
            CloudLayer {
                base_m: 150.0,
                top_m: 450.0,
                ..layer(CloudKind::Stratus, 0.42)
            },
            CloudLayer {
                base_m: 2_800.0,
                top_m: 5_000.0,
                ..layer(CloudKind::Altostratus, 0.92)
            },
            layer(CloudKind::Cirrostratus, 0.7),
        ],
        ..fair.clone()
    };
    for scene in [fair, overcast, evening] {
        rig.set_scene(&scene);
        let (l, t) = rig.render(4);
        save_strip(
            &output_dir().join(format!("clouds_{}.png", scene.name)),
            size,
            &[&l],
        );
        let mean_t = t.iter().map(|t| f64::from(*t)).sum::<f64>() / t.len() as f64;
        assert!(
            mean_t < 0.9,
            "{}: the frame must show cloud (mean T {mean_t})",
            scene.name
        );
        let (camera, transform) = {
            let world = rig.app.world();
            let camera = world.get::<Camera>(rig.camera).unwrap().clone();
            let transform = *world.get::<GlobalTransform>(rig.camera).unwrap();
            (camera, transform)
        };
        let elevation = |y: f32| {
            let ray = camera
                .viewport_to_world(&transform, Vec2::new(0.5 * size.x as f32, y))
                .unwrap();
            ray.direction.y.asin()
        };
        let row_angle = elevation(0.0) - elevation(1.0);
        // The horizon dips below level by acos(R / (R + h)): 0.56° from 300 m up.
        let dip = (6_371_000.0f32 / (6_371_000.0 + scene.camera.translation.y)).acos();
        for row in straight_horizontal_steps(&l, size) {
            let at = elevation(row as f32);
            assert!(
                at <= 2.0 * row_angle && at >= -dip - 2.0 * row_angle,
                "{}: a straight step at row {row}, {:.2}° from level, away from the horizon \
                 (see {})",
                scene.name,
                at.to_degrees(),
                output_dir()
                    .join(format!("clouds_{}.png", scene.name))
                    .display()
            );
        }
    }
}

/// A homogeneous slab 1 km thick: coverage 1, no noise, flat profile.
fn slab(extinction: f32) -> CloudLayer {
    CloudLayer {
        base_m: 1_000.0,
        top_m: 2_000.0,
        coverage: 1.0,
        density: extinction,
        shape_noise: 0.0,
        profile: DensityProfile::uniform(),
        ..CloudLayer::new(CloudKind::Stratus)
    }
}

#[test]
fn homogeneous_slab_matches_the_closed_form_on_the_gpu() {
    use bevy_cloudscape::reference::render::homogeneous_slab;
    // A narrow camera looking straight up: the centre pixels see a vertical ray.
    let size = UVec2::new(8, 8);
    let mut rig = CloudRig::new(size, Msaa::Off, small_recipe());
    rig.app
        .world()
        .entity_mut(rig.camera)
        .insert(Projection::Perspective(PerspectiveProjection {
            fov: 0.5f32.to_radians(),
            ..default()
        }));
    let centre = (size.y / 2 * size.x + size.x / 2) as usize;
    // Exposures that bring each radiance into the f16 range of the HDR target.
    for (extinction, ev100) in [(0.002f32, 13.0f32), (1e-9, -15.0), (1e4, 13.0)] {
        rig.app
            .world()
            .entity_mut(rig.camera)
            .insert(Exposure { ev100 });
        let exposure = f64::from(Exposure { ev100 }.exposure());
        for steps in [8, 32, 128, 512] {
            let scene = Scene {
                name: "slab",
                camera: Transform::from_xyz(0.0, 1.0, 0.0).looking_to(Vec3::Y, Vec3::Z),
                // The sun at the zenith: the closed form is exact on the curved planet.
                sun_deg: (90.0, 0.0),
                layers: vec![slab(extinction)],
                settings: VolumetricClouds {
                    multiple_scattering: false,
                    transmittance_cutoff: 0.0,
                    step_growth: 0.0,
                    ..settings(steps)
                },
            };
            rig.set_scene(&scene);
            let (gpu_l, gpu_t) = rig.render(3);
            let view = rig.extracted();
            let closed = homogeneous_slab(&view.settings, &view.layers[0]);
            let expected = luminance(&closed.radiance.map(|v| (v * exposure) as f32));
            let got = luminance(&gpu_l[centre]);
            let error = (got - expected).abs() / expected;
            eprintln!(
                "σ {extinction:e} /m, {steps} steps: L {got:.6e} vs {expected:.6e} ({error:.2e}), \
                 T {} vs {}",
                gpu_t[centre], closed.transmittance
            );
            assert!(got.is_finite() && gpu_t[centre].is_finite());
            if extinction >= 1e3 {
                // Opaque: T = 0 exactly, L finite. (f16 target: |T| within a half-float step.)
                assert!(gpu_t[centre].abs() < 1e-3, "T {}", gpu_t[centre]);
            } else {
                assert!(
                    error <= 0.005,
                    "σ {extinction}, {steps} steps: {error} > 0.5 %"
                );
                // T comes from `256 · T + L` in f16; with the bright L of the σ = 1e-9 case the
                // half-float step is ~0.03 of T.
                let t_tolerance = if extinction < 1e-6 { 0.05 } else { 2e-3 };
                let t_error = (f64::from(gpu_t[centre]) - closed.transmittance).abs();
                assert!(t_error <= t_tolerance, "T off by {t_error}");
            }
        }
    }
}

#[test]
fn clouds_stop_at_near_geometry_and_cover_far_geometry() {
    near_box_unchanged_far_box_covered(1.0);
}

/// At half resolution the upsample must keep the near box's edges clean: a plain bilinear
/// upsample would blend the cloudy sky texels next to the box into its border pixels.
#[test]
fn reduced_resolution_upsample_respects_depth_edges() {
    near_box_unchanged_far_box_covered(0.5);
}

fn near_box_unchanged_far_box_covered(resolution_scale: f32) {
    let size = UVec2::new(64, 36);
    let mut app = Headless::new(size, TextureFormat::Rgba8UnormSrgb, |app| {
        // The overcast layer rightly shades the near box through the cloud shadow map; this
        // test is about the march stopping at the depth, so the shadows (tested in
        // `shadow.rs`) are off.
        app.add_plugins(CloudscapePlugin)
            .insert_resource(CloudNoiseSettings(small_recipe()))
            .insert_resource(CloudShadows {
                enabled: false,
                ..default()
            });
    });
    let target = app.target.clone();
    app.world().spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.4, 0.6, 0.9)),
            ..default()
        },
        Transform::from_xyz(0.0, 2.0, 0.0).looking_to(Vec3::new(0.0, 0.05, -1.0), Vec3::Y),
        RenderTarget::Image(target.into()),
        VolumetricClouds {
            jitter: false,
            resolution_scale,
            ..VolumetricClouds::MEDIUM
        },
        EXPOSURE,
    ));
    app.world().spawn((
        DirectionalLight {
            illuminance: 100_000.0,
            ..default()
        },
        Transform::default().looking_to(Vec3::new(0.3, -0.8, -0.4), Vec3::Y),
    ));
    let (mesh, material) = {
        let world = app.world();
        let mesh = world
            .resource_mut::<Assets<Mesh>>()
            .add(Cuboid::new(1.0, 1.0, 1.0));
        let material = world
            .resource_mut::<Assets<StandardMaterial>>()
            .add(Color::srgb(0.8, 0.3, 0.2));
        (mesh, material)
    };
    // A 1 m box 5 m ahead on the left; a 4 km box 30 km ahead on the right, behind the layer.
    app.world().spawn((
        Mesh3d(mesh.clone()),
        MeshMaterial3d(material.clone()),
        Transform::from_xyz(-1.5, 2.0, -5.0),
    ));
    app.world().spawn((
        Mesh3d(mesh),
        MeshMaterial3d(material),
        Transform::from_xyz(9_000.0, 2_500.0, -30_000.0).with_scale(Vec3::splat(4_000.0)),
    ));
    let layer = app.world().spawn(layer(CloudKind::Stratus, 0.0)).id();
    app.run_frames(4);
    let clear = app.read_target();
    app.world().get_mut::<CloudLayer>(layer).unwrap().coverage = 1.0;
    app.run_frames(3);
    let cloudy = app.read_target();
    clear.save_png(output_dir().join("depth_clear.png"), 1.0);
    cloudy.save_png(
        output_dir().join(format!("depth_cloudy_scale_{resolution_scale}.png")),
        1.0,
    );
    let stats = *app.render_world().resource::<CloudPassStats>();
    assert!(stats.views_marched > 0);
    assert_eq!(
        stats.views_upsampled > 0,
        resolution_scale < 1.0,
        "the reduced-resolution path runs exactly when asked for"
    );

    let byte = |v: f32| (encode_srgb(v) * 255.0).round() as i32;
    let changed = |x: u32, y: u32| {
        let (a, b) = (clear.at(x, y), cloudy.at(x, y));
        (0..3)
            .map(|c| (byte(a[c]) - byte(b[c])).abs())
            .max()
            .unwrap()
    };
    // Box pixels are the red ones of the clear frame: the near box on the left half, the far
    // box on the right.
    let red = |x: u32, y: u32| {
        let p = clear.at(x, y);
        p[0] > 2.0 * p[2]
    };
    // Interior pixels only: MSAA blends edge pixels with the sky behind, which the clouds
    // rightly change.
    let boxes = |columns: std::ops::Range<u32>| -> Vec<(u32, u32)> {
        (1..size.y - 1)
            .flat_map(|y| columns.clone().map(move |x| (x, y)))
            .filter(|&(x, y)| {
                x > 0
                    && x + 1 < size.x
                    && [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)]
                        .iter()
                        .all(|(dx, dy)| red((x as i32 + dx) as u32, (y as i32 + dy) as u32))
            })
            .collect()
    };
    let (near, far) = (boxes(0..size.x / 2), boxes(size.x / 2..size.x));
    assert!(near.len() >= 12 && far.len() >= 4, "both boxes in view");
    let near_max = near.iter().map(|&(x, y)| changed(x, y)).max().unwrap();
    assert!(
        near_max <= 1,
        "the near box is in front of the clouds and must not change ({near_max} / 255)"
    );
    let far_changed = far.iter().filter(|&&(x, y)| changed(x, y) > 8).count();
    assert_eq!(
        far_changed,
        far.len(),
        "the far box is behind the overcast layer and must be covered"
    );
    // Below the horizon the rays end at the planet's ground, 5 km away, long before the layer:
    // the clouds must not change those pixels. At a reduced resolution the rows just below the
    // horizon read texels whose rays went into the cloudy sky above it; the upsample must weigh
    // them by where the rays end (the ground sphere), not by the depth prepass, which holds no
    // ground here.
    let (camera, camera_transform) = {
        let mut query = app
            .world()
            .query_filtered::<(&Camera, &GlobalTransform), With<VolumetricClouds>>();
        let (camera, transform) = query.single(app.world()).unwrap();
        (camera.clone(), *transform)
    };
    let below_horizon: Vec<(u32, u32)> = (0..size.y)
        .flat_map(|y| (0..size.x).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let ray = camera
                .viewport_to_world(&camera_transform, Vec2::new(x as f32, y as f32) + 0.5)
                .unwrap();
            // The horizon dips 0.05° below level from 2 m up; 0.1° keeps clear of it.
            ray.direction.y < -0.1f32.to_radians().sin()
                && (-1..=1).all(|dy: i32| {
                    (-1..=1).all(|dx: i32| {
                        let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                        nx < 0
                            || ny < 0
                            || nx >= size.x as i32
                            || ny >= size.y as i32
                            || !red(nx as u32, ny as u32)
                    })
                })
        })
        .collect();
    assert!(below_horizon.len() >= 100, "the ground is in view");
    let ground_max = below_horizon
        .iter()
        .map(|&(x, y)| changed(x, y))
        .max()
        .unwrap();
    assert!(
        ground_max <= 1,
        "the ground below the horizon lies in front of the clouds and must not change \
         ({ground_max} / 255)"
    );
}

/// Clouds cost nothing where there are none to draw: with no layer, with a layer of coverage 0,
/// or with cloudy layers but no camera that asks for clouds (no `VolumetricClouds`), the frame
/// is the frame without the plugin, and neither the march nor the shadow pass runs.
#[test]
fn no_coverage_is_the_same_frame_as_no_plugin_and_skips_the_pass() {
    let size = UVec2::new(48, 27);
    let scene = |with_plugin: bool, coverage: Option<f32>, clouds_on: bool| {
        let mut app = Headless::new(size, TextureFormat::Rgba16Float, |app| {
            if with_plugin {
                app.add_plugins(CloudscapePlugin)
                    .insert_resource(CloudNoiseSettings(small_recipe()));
            }
            app.add_systems(Startup, crate::common::spawn_sky_scene);
        });
        let target = app.target.clone();
        let mut camera = app.world().spawn((
            crate::common::sky_scene_camera(),
            RenderTarget::Image(target.into()),
        ));
        if clouds_on {
            camera.insert(VolumetricClouds::MEDIUM);
        }
        if let Some(coverage) = coverage {
            app.world().spawn(layer(CloudKind::Cumulus, coverage));
        }
        app.run_frames(4);
        let marched = app
            .render_world()
            .get_resource::<CloudPassStats>()
            .map_or(0, |s| s.views_marched);
        let shadow_passes = app
            .render_world()
            .get_resource::<CloudShadowStats>()
            .map_or(0, |s| s.passes);
        (app.read_target().rgba, marched + shadow_passes)
    };
    let (off, _) = scene(false, None, true);
    // A camera without `VolumetricClouds` has no depth prepass and HDR either.
    let (plain_off, _) = scene(false, None, false);
    let (no_layers, passes_no_layers) = scene(true, None, true);
    let (zero, passes_zero) = scene(true, Some(0.0), true);
    let (no_camera, passes_no_camera) = scene(true, Some(0.5), false);
    let (cloudy, passes_cloudy) = scene(true, Some(0.5), true);
    assert_eq!(no_layers, off, "no layers: the frame of the plugin off");
    assert_eq!(zero, off, "coverage 0: the frame of the plugin off");
    assert_eq!(
        no_camera, plain_off,
        "no camera with clouds: the frame of the plugin off"
    );
    assert_eq!(
        (passes_no_layers, passes_zero, passes_no_camera),
        (0, 0, 0),
        "neither the march nor the shadow pass ran"
    );
    assert!(
        passes_cloudy > 0 && cloudy != off,
        "with coverage the passes run and change the frame"
    );
}

/// Checks one GPU frame pair for the invariants: finite, T in [0, 1] up to the f16 rounding of
/// its measurement, L ≥ 0.
fn assert_physical(case: &str, radiance: &[[f32; 3]], transmittance: &[f32], tolerance: &[f32]) {
    for ((l, t), tol) in radiance.iter().zip(transmittance).zip(tolerance) {
        assert!(
            l.iter().all(|v| v.is_finite() && *v >= 0.0),
            "{case}: L {l:?}"
        );
        assert!(
            t.is_finite() && *t >= -tol && *t <= 1.0 + tol,
            "{case}: T {t} (measurement tolerance {tol})"
        );
    }
}

#[test]
fn hard_cases_stay_finite_and_physical() {
    let size = UVec2::new(24, 16);
    let mut rig = CloudRig::new(size, Msaa::Sample4, small_recipe());
    // Every path on: haze with light shafts, and the cloud shadow map lighting every sample.
    rig.app
        .world()
        .insert_resource(Haze::with_visibility(8_000.0));
    rig.app.world().insert_resource(CloudShadows {
        enabled: true,
        resolution: 32,
        extent_m: 20_000.0,
        steps: 4,
        ..default()
    });
    let cumulus = layer(CloudKind::Cumulus, 0.6);
    let (base, top) = (f64::from(cumulus.base_m), f64::from(cumulus.top_m));
    // The shadow map's image appears a frame after the settings: let every case see it.
    rig.set_scene(&Scene {
        name: "warm-up",
        camera: looking(Vec3::new(0.0, 2.0, 0.0), 20.0, 0.0),
        sun_deg: (50.0, 30.0),
        layers: vec![cumulus.clone()],
        settings: VolumetricClouds::MEDIUM,
    });
    rig.app.run_frames(4);
    let cases: Vec<(&str, Vec3, f32, (f32, f32), f32)> = vec![
        // (case, camera position, pitch°, sun (elevation°, azimuth°), coverage)
        (
            "at ground level",
            Vec3::new(0.0, 0.0, 0.0),
            20.0,
            (50.0, 30.0),
            0.6,
        ),
        (
            "on the layer base",
            Vec3::new(0.0, base as f32, 0.0),
            0.0,
            (50.0, 30.0),
            0.6,
        ),
        (
            "on the layer top",
            Vec3::new(0.0, top as f32, 0.0),
            -5.0,
            (50.0, 30.0),
            0.6,
        ),
        (
            "in space",
            Vec3::new(0.0, 400_000.0, 0.0),
            -60.0,
            (50.0, 30.0),
            0.6,
        ),
        (
            "grazing",
            Vec3::new(0.0, base as f32 - 0.01, 0.0),
            0.0,
            (30.0, 0.0),
            0.6,
        ),
        (
            "sun at zenith",
            Vec3::new(0.0, 2.0, 0.0),
            30.0,
            (90.0, 0.0),
            0.6,
        ),
        (
            "sun on the horizon",
            Vec3::new(0.0, 2.0, 0.0),
            5.0,
            (0.0, 0.0),
            0.6,
        ),
        (
            "sun below the horizon",
            Vec3::new(0.0, 2.0, 0.0),
            20.0,
            (-12.0, 0.0),
            0.6,
        ),
        (
            "sun straight ahead",
            Vec3::new(0.0, 2.0, 0.0),
            25.0,
            (25.0, 0.0),
            0.6,
        ),
        (
            "coverage 1",
            Vec3::new(0.0, 2.0, 0.0),
            20.0,
            (40.0, 90.0),
            1.0,
        ),
    ];
    for (case, position, pitch, sun, coverage) in cases {
        let scene = Scene {
            name: case,
            camera: looking(position, pitch, 0.0),
            sun_deg: sun,
            layers: vec![CloudLayer {
                coverage,
                wind_m_s: [30.0, 0.0],
                ..cumulus.clone()
            }],
            settings: VolumetricClouds {
                jitter: false,
                sun_from_shadow_map_m: 0.0,
                ..VolumetricClouds::MEDIUM
            },
        };
        rig.set_scene(&scene);
        // A week of 30 m/s wind already behind every layer.
        let week = 7.0 * 86_400.0 * 30.0;
        rig.set_drift([week, -week]);
        // T is recovered from a frame over black and one over grey, which must differ only in
        // the background: the cloud shadow map (the haze's shafts, the samples' sun) catches up
        // with the new scene over the first three frames, so measure from the fourth.
        let (l, t) = rig.render(4);
        assert_physical(case, &l, &t, &rig.t_tolerance);
        // With jitter the two frames of a measurement march different points, so only L is
        // checked exactly; T must still be finite.
        rig.app
            .world()
            .get_mut::<VolumetricClouds>(rig.camera)
            .unwrap()
            .jitter = true;
        let (l, t) = rig.render(2);
        assert!(
            l.iter().flatten().all(|v| v.is_finite() && *v >= 0.0)
                && t.iter().all(|t| t.is_finite()),
            "{case} with jitter: smallest L {:?}, {} non-finite values",
            l.iter().flatten().copied().reduce(f32::min),
            l.iter()
                .flatten()
                .chain(&t)
                .filter(|v| !v.is_finite())
                .count()
        );
    }
    // The moon as the only light (the `Sun` light at night, `sky::sun_or_moon_light`): a full
    // moon's 0.31 lux 30° up. Finite and physical, lit, and darker than the same sky by day:
    // the light is 3·10⁻⁶ of the sun's, the night sky's own faint glow adds a little, and a
    // thousandth fails a frame that does not follow the light's illuminance.
    let lit = |rig: &mut CloudRig, illuminance: f32| {
        rig.app
            .world()
            .get_mut::<DirectionalLight>(rig.sun)
            .unwrap()
            .illuminance = illuminance;
        rig.set_scene(&Scene {
            name: "moonlight",
            camera: looking(Vec3::new(0.0, 2.0, 0.0), 20.0, 0.0),
            sun_deg: (30.0, 150.0),
            layers: vec![cumulus.clone()],
            settings: VolumetricClouds {
                jitter: false,
                ..VolumetricClouds::MEDIUM
            },
        });
        rig.render(4)
    };
    let (day, _) = lit(&mut rig, 100_000.0);
    let (night, t) = lit(&mut rig, 0.31);
    assert_physical("moon as the only light", &night, &t, &rig.t_tolerance);
    let sum = |l: &[[f32; 3]]| l.iter().flatten().map(|v| f64::from(*v)).sum::<f64>();
    assert!(
        sum(&night) > 0.0 && sum(&night) < 1e-3 * sum(&day),
        "moonlit {} against sunlit {}",
        sum(&night),
        sum(&day)
    );
    // Tiny and odd targets (one app at a time: apps take turns on the GPU).
    drop(rig);
    for size in [UVec2::new(1, 1), UVec2::new(7, 5)] {
        let mut rig = CloudRig::new(size, Msaa::Off, small_recipe());
        rig.set_scene(&showcase_scenes().remove(0));
        let (l, t) = rig.render(3);
        assert_physical(
            &format!("{}×{} target", size.x, size.y),
            &l,
            &t,
            &rig.t_tolerance,
        );
        assert!(rig.views_marched() > 0);
    }
}

#[test]
fn far_weather_shows_toward_the_far_place() {
    use bevy_cloudscape::layers::FarCoverage;
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    // Clear over the near place, 80 % cumulus at a far place 30 km north.
    let layer = CloudLayer {
        far_coverage: vec![FarCoverage {
            from_m: [0.0, 0.0],
            to_m: [0.0, 30_000.0],
            coverage: 0.8,
        }],
        ..layer(CloudKind::Cumulus, 0.0)
    };
    let mut mean_t = Vec::new();
    for (yaw, name) in [(0.0, "far_weather_north"), (180.0, "far_weather_south")] {
        let scene = Scene {
            name,
            camera: looking(Vec3::new(0.0, 2.0, 0.0), 8.0, yaw),
            sun_deg: (35.0, 200.0),
            layers: vec![layer.clone()],
            settings: settings(64),
        };
        rig.set_scene(&scene);
        let (gpu_l, gpu_t) = rig.render(3);
        let (cpu_l, cpu_t) = rig.reference(&textures);
        save_strip(
            &output_dir().join(format!("clouds_{name}.png")),
            size,
            &[&gpu_l, &cpu_l],
        );
        let t = cpu_t.iter().map(|t| f64::from(*t)).sum::<f64>() / cpu_t.len() as f64;
        let gpu_mean_t = gpu_t.iter().map(|t| f64::from(*t)).sum::<f64>() / gpu_t.len() as f64;
        eprintln!("{name}: mean T CPU {t:.4}, GPU {gpu_mean_t:.4}");
        if t < 1.0 {
            let error = relative_rmse(&gpu_l, &cpu_l);
            eprintln!("{name}: relative RMSE {error:.4}");
            assert!(error <= 0.03, "{name}: relative RMSE {error}");
        }
        assert!((gpu_mean_t - t).abs() < 0.01, "{name}: {gpu_mean_t} vs {t}");
        mean_t.push(t);
    }
    // Cloud on the horizon toward the far place, none the other way.
    // (A band a few degrees high above the northern horizon: about a tenth of the frame.)
    assert!(mean_t[0] < 0.97, "north: mean T {}", mean_t[0]);
    assert_eq!(mean_t[1], 1.0, "south stays clear");
}

/// Fog from a forecast visibility `V`: a black target `V` away keeps 2 % contrast against the
/// fog behind it, the meteorological definition of visibility (Koschmieder; WMO-No. 8).
#[test]
fn fog_visibility_gives_two_percent_contrast_at_the_visibility_distance() {
    use bevy_cloudscape::scene::UtcInstant;
    use bevy_cloudscape::weather::{Variable, WeatherMapping, WeatherState};
    let visibility = 800.0f32;
    let mut state = WeatherState::empty(UtcInstant::from_unix_seconds(1_620_280_800));
    state.values[Variable::Visibility as usize] = Some(visibility);
    let mut fog = LayerSlot::Fog.initial_layer();
    WeatherMapping::default()
        .map(&state, 0.0)
        .apply(LayerSlot::Fog, &mut fog);
    assert!((fog.density - 3.912 / visibility).abs() < 1e-6 && fog.coverage == 1.0);

    let size = UVec2::new(64, 16);
    // The view looks up by half a row, so the middle row (the one below the centre) looks level:
    // through uniform fog at 2 m, which it leaves past the horizon, 40 km away. The fog behind
    // the target is then the fog's horizon, as the definition has it. Looking level, that row
    // meets the ground 917 m away; looking up by more, the fog behind the target is higher in
    // the layer, lit more by the sky and the sun than the fog in front of it.
    let fov = 4f32.to_radians();
    let pitch = 0.5 * fov / size.y as f32;
    let mut rig = CloudRig::new(size, Msaa::Off, small_recipe());
    // An unlit black box whose near face is `visibility` metres ahead, in the left half.
    // 0.7° to 7.8° left of the view's centre; the view is 16° wide. Its centre on the view's
    // centre line, `pitch` above the horizontal.
    let target = spawn_black_box(
        &mut rig,
        Vec3::new(100.0, 20.0, 20.0),
        Transform::from_xyz(
            -60.0,
            2.0 + (visibility + 10.0) * pitch.tan(),
            -(visibility + 10.0),
        ),
    );
    rig.set_scene(&Scene {
        name: "fog",
        camera: Transform::from_xyz(0.0, 2.0, 0.0)
            .looking_to(Vec3::new(0.0, pitch.tan(), -1.0), Vec3::Y),
        sun_deg: (30.0, 150.0),
        layers: vec![fog],
        // The default preset: the contrast must hold with the early exit the game uses. At full
        // resolution: without jitter the quarter-resolution march has no temporal upsampling,
        // and one of its 4 × 4 blocks would stand for four rows, a degree of the view.
        settings: VolumetricClouds {
            jitter: false,
            // Koschmieder's law holds ray by ray: at a quarter of the resolution the target is
            // two march texels wide and the depth-aware upsample mixes the haze of the horizon
            // beside it into its edges.
            resolution_scale: 1.0,
            ..VolumetricClouds::MEDIUM
        },
    });
    rig.app
        .world()
        .entity_mut(rig.camera)
        .insert(Projection::Perspective(PerspectiveProjection {
            fov,
            ..default()
        }));
    let (radiance, _) = rig.render(3);
    // The same view without the target: the fog behind it, in the same directions (the fog's
    // glow changes with the angle to the sun across the view).
    rig.app.world().despawn(target);
    let (open, _) = rig.render(3);
    save_strip(
        &output_dir().join("clouds_fog_target.png"),
        size,
        &[&radiance, &open],
    );
    // Middle row: the box on the left, at eye level, against the open fog there.
    let row = size.y / 2;
    let mean = |image: &[[f32; 3]]| {
        (4..12)
            .map(|x| luminance(&image[(row * size.x + x) as usize]))
            .sum::<f64>()
            / 8.0
    };
    let (target_l, fog_l) = (mean(&radiance), mean(&open));
    let contrast = (fog_l - target_l) / fog_l;
    eprintln!(
        "fog V = {visibility} m: target {target_l:.5}, fog {fog_l:.5}, contrast {contrast:.4}"
    );
    assert!(fog_l > 0.0, "the fog is lit");
    assert!(
        (contrast - 0.02).abs() <= 0.005,
        "contrast at the visibility distance {contrast:.4}, expected 0.02 ± 0.005"
    );
}

/// Haze from a visibility `V` above the fog range, on the GPU: a black target `V` away keeps
/// Koschmieder's 2 % contrast against the haze horizon beside it (less the clear air's share,
/// which Bevy's atmosphere draws), and the pass runs for haze alone, with no cloud layer.
#[test]
fn haze_visibility_gives_koschmieder_contrast_at_the_visibility_distance() {
    use bevy_cloudscape::reference::haze::CLEAR_AIR_EXTINCTION_PER_M;
    let visibility = 5_000.0f32;
    let size = UVec2::new(64, 16);
    let mut rig = CloudRig::new(size, Msaa::Off, small_recipe());
    // A uniform haze (a scale height far above the view), as the definition assumes.
    rig.app.world().insert_resource(Haze {
        scale_height_m: 1.0e6,
        ..Haze::with_visibility(visibility)
    });
    // 0.7° to 7.6° left of the view's centre (the view is 16° wide), near face at V.
    spawn_black_box(
        &mut rig,
        Vec3::new(600.0, 120.0, 20.0),
        Transform::from_xyz(-360.0, 2.0, -(visibility + 10.0)),
    );
    rig.set_scene(&Scene {
        name: "haze",
        // Half a degree up, so the middle row's rays clear the ground (a level ray from 2 m
        // that dips 0.1° meets it 1 km away) and pass 35 m up the target's face.
        camera: Transform::from_xyz(0.0, 2.0, 0.0)
            .looking_to(Vec3::new(0.0, 0.5f32.to_radians().tan(), -1.0), Vec3::Y),
        // The sun near the zenith lights every level ray at the same phase angle, so the haze
        // beside the target is the haze in front of it (with a low sun, the forward-peaked
        // phase makes the two differ by several per cent across the view).
        sun_deg: (88.0, 0.0),
        layers: vec![],
        settings: VolumetricClouds {
            jitter: false,
            // Koschmieder's law holds ray by ray: at a quarter of the resolution the target is
            // two march texels wide and the depth-aware upsample mixes the haze of the horizon
            // beside it into its edges.
            resolution_scale: 1.0,
            ..VolumetricClouds::MEDIUM
        },
    });
    rig.app
        .world()
        .entity_mut(rig.camera)
        .insert(Projection::Perspective(PerspectiveProjection {
            fov: 4f32.to_radians(),
            // Frustum culling stops at `far`; the target is 5 km away.
            far: 20_000.0,
            ..default()
        }));
    let before = rig.views_marched();
    let (radiance, _) = rig.render(3);
    assert!(rig.views_marched() > before, "haze alone runs the pass");
    save_strip(
        &output_dir().join("clouds_haze_target.png"),
        size,
        &[&radiance],
    );
    let row = size.y / 2;
    let at = |x: u32| luminance(&radiance[(row * size.x + x) as usize]);
    let target_l = (4..12).map(at).sum::<f64>() / 8.0;
    let haze_l = (size.x - 12..size.x - 4).map(at).sum::<f64>() / 8.0;
    let contrast = (haze_l - target_l) / haze_l;
    // The haze's share of 3.912 / V: e^(−(3.912/V − σ_clear) V).
    let expected = (-(3.912 - CLEAR_AIR_EXTINCTION_PER_M * f64::from(visibility))).exp();
    eprintln!(
        "haze V = {visibility} m: target {target_l:.5}, horizon {haze_l:.5}, contrast \
         {contrast:.4} (expected {expected:.4})"
    );
    assert!(haze_l > 0.0, "the haze is lit");
    assert!(
        (contrast - expected).abs() <= 0.005,
        "contrast at the visibility distance {contrast:.4}, expected {expected:.4} ± 0.005"
    );
}

/// Clouds seen through haze: the GPU's clouds-then-haze composite against the CPU twin, and the
/// haze veils the distant clouds (their contrast drops against the clear-air render).
#[test]
fn haze_veils_distant_clouds_like_the_cpu_reference() {
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    let scene = Scene {
        name: "haze_cumulus",
        camera: looking(Vec3::new(0.0, 2.0, 0.0), 6.0, 0.0),
        sun_deg: (35.0, 150.0),
        layers: vec![layer(CloudKind::Cumulus, 0.5)],
        settings: settings(64),
    };
    rig.set_scene(&scene);
    let (clear_l, _) = rig.render(3);
    rig.app
        .world()
        .insert_resource(Haze::with_visibility(8_000.0));
    let (gpu_l, gpu_t) = rig.render(3);
    let (cpu_l, cpu_t) = rig.reference(&textures);
    save_strip(
        &output_dir().join("clouds_haze_cumulus.png"),
        size,
        &[&clear_l, &gpu_l, &cpu_l],
    );
    let error = relative_rmse(&gpu_l, &cpu_l);
    let t_error = gpu_t
        .iter()
        .zip(&cpu_t)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    eprintln!("haze over cumulus: relative RMSE {error:.4}, max |ΔT| {t_error:.4}");
    assert!(error <= 0.03, "relative RMSE {error}");
    assert!(t_error <= 0.02, "max |ΔT| {t_error}");
    // The haze changed the picture: the spread of luminance (cloud against gap) shrinks. Measured
    // over the top half of the view, all sky (the horizon is about 0.6 of the way down), so the
    // dark ground below the horizon does not dominate the spread.
    let sky_pixels = (size.x * size.y / 2) as usize;
    let spread = |image: &[[f32; 3]]| {
        let values: Vec<f64> = image[..sky_pixels].iter().map(luminance).collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64).sqrt() / mean
    };
    let (clear, hazy) = (spread(&clear_l), spread(&gpu_l));
    eprintln!("relative spread of luminance: clear {clear:.3}, hazy {hazy:.3}");
    assert!(
        hazy < 0.8 * clear,
        "haze lowers the contrast: {hazy} vs {clear}"
    );
}

/// An unlit black box `size` metres across (x, y, z) in the rig's world, with `placed` (its
/// transform, its visibility).
fn spawn_black_box(rig: &mut CloudRig, size: Vec3, placed: impl Bundle) -> Entity {
    let world = rig.app.world();
    let mesh = world
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::from_size(size));
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::BLACK,
            unlit: true,
            ..default()
        });
    world
        .spawn((Mesh3d(mesh), MeshMaterial3d(material), placed))
        .id()
}

/// The showcase's noon cumulus marched in 24 jittered steps, each frame on its own (no
/// accumulation): the scene of the jitter and temporal tests.
fn jittered_noon_cumulus() -> Scene {
    let mut scene = showcase_scenes().remove(0);
    scene.settings = VolumetricClouds {
        jitter: true,
        primary_steps: 24,
        temporal_blend: 1.0,
        ..scene.settings
    };
    scene
}

/// With jitter on, the GPU reads the blue-noise map the CPU twin makes: the same jittered image,
/// frame for frame.
#[test]
fn blue_noise_jitter_matches_the_cpu_reference() {
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    // One frame, not the average of several.
    let scene = jittered_noon_cumulus();
    rig.set_scene(&scene);
    let (gpu_l, _) = rig.render(3);
    let (cpu_l, _) = rig.reference(&textures);
    let frame = rig.rendered_view.as_ref().unwrap().settings.frame_index;
    // The same frame without jitter: the jitter must change the picture.
    let mut steady = rig.rendered_view.clone().unwrap();
    steady.settings.jitter = false;
    rig.rendered_view = Some(steady);
    let (still_l, _) = rig.reference(&textures);
    save_strip(
        &output_dir().join("clouds_blue_noise_jitter.png"),
        size,
        &[&gpu_l, &cpu_l, &still_l],
    );
    let error = relative_rmse(&gpu_l, &cpu_l);
    let jitter_effect = relative_rmse(&still_l, &cpu_l);
    eprintln!(
        "jittered frame {frame}: relative RMSE against the CPU {error:.4}; the jitter itself \
         moves the image by {jitter_effect:.4}"
    );
    assert!(error <= 0.03, "relative RMSE {error}");
    assert!(jitter_effect > 2.0 * error, "{jitter_effect} vs {error}");
}

/// Temporal accumulation: a still view converges on the mean of its jittered frames (the CPU
/// twin averaged over 16 frames' jitter) far closer than any one frame is; a turning camera
/// keeps that, because the history is reprojected, not smeared. Also reports both against a
/// converged march (256 primary steps, no jitter): what is left is the 24-step march's bias,
/// which averaging cannot remove.
#[test]
fn temporal_accumulation_converges_and_follows_the_camera() {
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    let mut scene = jittered_noon_cumulus();
    // The CPU twin of the last rendered view: averaged over 16 frames' jitter, and converged.
    let references = |rig: &mut CloudRig| {
        let mean = cpu_jitter_mean(rig, &textures, 16);
        let mut converged = rig.rendered_view.clone().unwrap();
        converged.settings.jitter = false;
        converged.settings.primary_steps = 256;
        converged.settings.min_step_m = 0.0;
        rig.rendered_view = Some(converged);
        (mean, rig.reference(&textures).0)
    };
    rig.set_scene(&scene);
    let (single_l, _) = rig.render(3);
    let (mean_l, truth_l) = references(&mut rig);
    scene.settings.temporal_blend = 0.1;
    rig.set_scene(&scene);
    let accumulated = |rig: &mut CloudRig| {
        rig.app
            .render_world()
            .resource::<CloudPassStats>()
            .views_accumulated
    };
    let before = accumulated(&mut rig);
    let (still_l, _) = rig.render(24);
    assert!(accumulated(&mut rig) > before, "the temporal pass ran");
    // Turn right by half a degree a frame (a pixel is 0.7°), then look at the last pose.
    let from = scene.camera.translation;
    for k in 1..=12 {
        let pose = looking(from, 25.0, 0.5 * k as f32);
        rig.app.world().entity_mut(rig.camera).insert(pose);
        rig.app.run_frames(1);
    }
    let (moving_l, _) = rig.render(1);
    let (moving_mean_l, moving_truth_l) = references(&mut rig);
    save_strip(
        &output_dir().join("clouds_temporal_single_still_mean_moving_mean.png"),
        size,
        &[&single_l, &still_l, &mean_l, &moving_l, &moving_mean_l],
    );
    let single = relative_rmse(&single_l, &mean_l);
    let still = relative_rmse(&still_l, &mean_l);
    let moving = relative_rmse(&moving_l, &moving_mean_l);
    let unregistered = relative_rmse(&moving_l, &mean_l);
    eprintln!(
        "temporal accumulation, against the mean of 16 jittered frames: one frame {single:.4}, \
         24 accumulated {still:.4}, after turning 6° over 12 frames {moving:.4} (against the \
         start pose's mean {unregistered:.4}). Against 256 steps: one frame {:.4}, accumulated \
         {:.4}, turning {:.4}, the mean of 16 frames {:.4}",
        relative_rmse(&single_l, &truth_l),
        relative_rmse(&still_l, &truth_l),
        relative_rmse(&moving_l, &moving_truth_l),
        relative_rmse(&mean_l, &truth_l),
    );
    assert!(still < 0.5 * single, "still {still} vs one frame {single}");
    // Measured: one frame 35.2 %, accumulated 8.6 %, turning 18.9 % (a ratio of 0.54). The
    // turning error is mostly the history's resampling, which loses detail every frame the
    // camera moves, and the newly uncovered strip at the right edge, which has had few frames
    // (there the error is 29 %, against 17 % in the middle columns). So the ratio moves with
    // the scene's detail: with the Catmull-Rom resampling and a constant blend it was 0.57
    // before the broad shape warp (the far heaps lined up in smooth streaks then) and 0.64
    // with it. A history smeared instead of reprojected leaves the turning view as far off as
    // the start pose's mean (81 %, the next assertion).
    assert!(
        moving < 0.6 * single,
        "turning {moving} vs one frame {single}"
    );
    assert!(
        moving < 0.5 * unregistered,
        "turning {moving} vs the start pose {unregistered}"
    );
}

/// No ghost behind a near object while the camera turns: a black pole held in front of the
/// camera (a third-person character) as it turns uncovers, every frame, sky that the pole hid
/// until then, whose history holds the pole's clear, cloudless pixels. With `MEDIUM`'s quarter
/// resolution and accumulation that history must be rejected (the pole was near, the clouds
/// far), not faded in over `1 / temporal_blend` frames: sky uncovered more than 4 frames ago
/// must be as close to the still, converged view as where no pole passed in the same turn.
#[test]
fn a_turning_camera_leaves_no_trail_behind_a_near_object() {
    let size = UVec2::new(64, 36);
    let (_, mut rig) = small_rig(size);
    let mut scene = jittered_noon_cumulus();
    scene.settings = VolumetricClouds {
        resolution_scale: VolumetricClouds::MEDIUM.resolution_scale,
        temporal_blend: VolumetricClouds::MEDIUM.temporal_blend,
        primary_steps: VolumetricClouds::MEDIUM.primary_steps,
        ..scene.settings
    };
    // 60° vertical field of view over 36 rows: 91.6° across 64 columns, 1.43° a column. The
    // camera turns right by a column a frame, so the sky slides left by a column a frame and
    // comes out from behind the pole's left edge.
    let column_deg = 2.0 * (30f32.to_radians().tan() * 64.0 / 36.0).atan().to_degrees() / 64.0;
    let (pitch, turn_frames) = (25.0, 24);
    let from = scene.camera.translation;
    let pose = |k: u32| looking(from, pitch, column_deg * k as f32);
    // 0.4 m wide, 3 m ahead and 1 m right: about five columns from column 45 on, and every
    // row.
    let pole_in_camera = Transform::from_xyz(1.0, 0.0, -3.0);
    let pole = spawn_black_box(&mut rig, Vec3::new(0.4, 60.0, 0.4), Visibility::Hidden);
    rig.set_background(Color::BLACK);
    let frame = |rig: &mut CloudRig, k: u32, with_pole: bool| {
        let world = rig.app.world();
        world.entity_mut(rig.camera).insert(pose(k));
        world.entity_mut(pole).insert((
            pose(k) * pole_in_camera,
            if with_pole {
                Visibility::Visible
            } else {
                Visibility::Hidden
            },
        ));
        rig.app.run_frames(1);
    };
    let read = |rig: &mut CloudRig| -> Vec<[f32; 3]> {
        rig.app
            .read_target()
            .rgba
            .iter()
            .map(|p| [p[0], p[1], p[2]])
            .collect()
    };
    // The turn, with and without the pole, each from a settled still view.
    let mut turn = |rig: &mut CloudRig, with_pole: bool| {
        scene.camera = pose(0);
        rig.set_scene(&scene);
        for _ in 0..48 {
            frame(rig, 0, with_pole);
        }
        for k in 1..=turn_frames {
            frame(rig, k, with_pole);
        }
        read(rig)
    };
    let with_pole = turn(&mut rig, true);
    let without_pole = turn(&mut rig, false);
    // The truth: the last pose, still, settled, no pole.
    scene.camera = pose(turn_frames);
    rig.set_scene(&scene);
    for _ in 0..64 {
        frame(&mut rig, turn_frames, false);
    }
    let still = read(&mut rig);
    save_strip(
        &output_dir().join("clouds_turning_pole_with_without_still.png"),
        size,
        &[&with_pole, &without_pole, &still],
    );
    let w = size.x as usize;
    let mean = still.iter().map(luminance).sum::<f64>() / still.len() as f64;
    let column_error = |image: &[[f32; 3]], x: usize| {
        let squares: f64 = (0..size.y as usize)
            .map(|y| (luminance(&image[y * w + x]) - luminance(&still[y * w + x])).powi(2))
            .sum();
        (squares / f64::from(size.y)).sqrt() / mean
    };
    // The pole's columns in the last frame: black in every row.
    let pole_columns: Vec<usize> = (0..w)
        .filter(|&x| (0..size.y as usize).all(|y| luminance(&with_pole[y * w + x]) < 1e-6 * mean))
        .collect();
    assert!(
        (4..=7).contains(&pole_columns.len()),
        "the pole in view: columns {pole_columns:?}"
    );
    // Sky uncovered 1–4, 5–8 and 9–12 frames ago: the bands of four columns left of it.
    let left = pole_columns[0];
    assert!(
        left >= 12,
        "the pole leaves room for the bands: column {left}"
    );
    let band = |image: &[[f32; 3]], first: usize| {
        let squares: f64 = (first..first + 4)
            .map(|d| column_error(image, left - d).powi(2))
            .sum();
        (squares / 4.0).sqrt()
    };
    let bands: Vec<(f64, f64)> = [1, 5, 9]
        .iter()
        .map(|&first| (band(&with_pole, first), band(&without_pole, first)))
        .collect();
    eprintln!(
        "relative RMSE against the still view of the sky uncovered 1-4, 5-8 and 9-12 frames \
         ago: {bands:.3?} (with the pole, without it)"
    );
    // A trail of the pole's cloudless history fades only as fast as the accumulation takes in
    // new frames (by 1 − blend = 0.9 a frame where the march passes, every 16th frame at a
    // quarter resolution): 5–12 frames on most of the cloud would still be missing, an error
    // about as large as the cloud itself and several times the turn's own. Beyond 4 frames the
    // sky must be as good as where no pole passed, up to the noise of two runs' different
    // jitter (a half).
    for (k, &(with, without)) in bands.iter().enumerate().skip(1) {
        assert!(
            with <= 1.5 * without,
            "band {k}: {with:.3} with the pole, {without:.3} without: a trail"
        );
    }
}

/// A camera cut: with `VolumetricClouds::reset_history` (which `Scene::apply` sets) the first
/// frame after the cut is that frame's march alone, as close to its CPU twin as one jittered
/// frame is (`blue_noise_jitter_matches_the_cpu_reference`); without it the previous scene's
/// history (overcast stratus at the same pose) is reprojected into the new one and outweighs
/// the new frame. The flag lasts one frame.
#[test]
fn a_history_reset_drops_the_previous_scene() {
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    let mut cumulus = jittered_noon_cumulus();
    cumulus.settings.temporal_blend = 0.1;
    let mut overcast = cumulus.clone();
    overcast.layers = showcase_scenes().remove(1).layers;
    let cut = |rig: &mut CloudRig, reset: bool| {
        rig.set_scene(&overcast);
        rig.app.run_frames(16);
        rig.set_scene(&cumulus);
        rig.app
            .world()
            .get_mut::<VolumetricClouds>(rig.camera)
            .unwrap()
            .reset_history = reset;
        let (gpu_l, _) = rig.render(1);
        let (cpu_l, _) = rig.reference(&textures);
        let error = relative_rmse(&gpu_l, &cpu_l);
        (gpu_l, cpu_l, error)
    };
    let (kept_l, _, kept) = cut(&mut rig, false);
    let (reset_l, cpu_l, reset) = cut(&mut rig, true);
    let cleared = !rig
        .app
        .world()
        .get::<VolumetricClouds>(rig.camera)
        .unwrap()
        .reset_history;
    save_strip(
        &output_dir().join("clouds_history_reset_kept_reset_cpu.png"),
        size,
        &[&kept_l, &reset_l, &cpu_l],
    );
    eprintln!(
        "first frame after a cut from overcast to cumulus, against its CPU twin: history kept \
         {kept:.4}, history reset {reset:.4}"
    );
    assert!(reset <= 0.03, "with the reset {reset}");
    assert!(kept > 5.0 * reset, "without the reset {kept} vs {reset}");
    assert!(
        cleared,
        "reset_history is set back to false after the frame"
    );
}

/// At half resolution the temporal accumulation upsamples: each frame's rays go through
/// another full-resolution pixel of their texel, so a still view converges to detail finer than
/// the march's texels. Without it the accumulation converges to the bilinear upsample of the
/// texels, which is at best the full-resolution image averaged over 2 × 2 pixels and
/// interpolated back (the blur floor measured here on the CPU's mean image).
#[test]
fn temporal_upsampling_resolves_detail_finer_than_the_march() {
    use bevy_cloudscape::reference::composite::{
        FAR_AWAY, LowResImage, march_uv, upsample, upsampled_march_size,
    };
    // Odd on both axes: the march's last texels reach a pixel past the view's edge, and every
    // pixel must still be sampled once per cycle.
    let size = UVec2::new(63, 35);
    let (textures, mut rig) = small_rig(size);
    let mut scene = jittered_noon_cumulus();
    scene.settings.resolution_scale = 0.5;
    rig.set_scene(&scene);
    let (single_l, _) = rig.render(3);
    // The CPU's full-resolution image, averaged over 16 frames' jitter.
    let mean_l = cpu_jitter_mean(&mut rig, &textures, 16);
    // The blur floor: that image averaged over each texel's 2 × 2 pixels (those in the view),
    // upsampled back.
    let low = upsampled_march_size(size.to_array(), 2);
    let pixel = |x: u32, y: u32| mean_l[(y.min(size.y - 1) * size.x + x.min(size.x - 1)) as usize];
    let texels = LowResImage {
        size: low,
        values: (0..low[1])
            .flat_map(|ty| {
                (0..low[0]).map(move |tx| {
                    std::array::from_fn(|c| {
                        let at = |dx, dy| f64::from(pixel(2 * tx + dx, 2 * ty + dy)[c]);
                        0.25 * (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1))
                    })
                })
            })
            .collect(),
        distances_m: vec![FAR_AWAY; (low[0] * low[1]) as usize],
    };
    let blurred: Vec<[f32; 3]> = (0..size.x * size.y)
        .map(|p| {
            let uv = [
                (f64::from(p % size.x) + 0.5) / f64::from(size.x),
                (f64::from(p / size.x) + 0.5) / f64::from(size.y),
            ];
            let uv = march_uv(uv, size.to_array(), low, 2);
            upsample(&texels, uv, FAR_AWAY).map(|v| v as f32)
        })
        .collect();
    scene.settings.temporal_blend = 0.1;
    rig.set_scene(&scene);
    let (accumulated_l, _) = rig.render(32);
    save_strip(
        &output_dir().join("clouds_temporal_upsampling_single_accumulated_mean_blurred.png"),
        size,
        &[&single_l, &accumulated_l, &mean_l, &blurred],
    );
    let single = relative_rmse(&single_l, &mean_l);
    let accumulated = relative_rmse(&accumulated_l, &mean_l);
    let floor = relative_rmse(&blurred, &mean_l);
    eprintln!(
        "half resolution against the full-resolution mean of 16 jittered frames: one frame \
         {single:.4}, 32 accumulated {accumulated:.4}; the blur floor of a 2 x 2 upsample {floor:.4}"
    );
    assert!(
        accumulated < 0.7 * floor,
        "accumulated {accumulated} against the blur floor {floor}"
    );
    assert!(
        accumulated < 0.5 * single,
        "accumulated {accumulated} against one frame {single}"
    );
}

/// The CPU twin of the rig's last rendered view, averaged over the jitter of `frames` frames
/// (0 to `frames − 1`); the rig keeps that view.
fn cpu_jitter_mean(rig: &mut CloudRig, textures: &CloudTextures, frames: u32) -> Vec<[f32; 3]> {
    let view = rig.rendered_view.clone().expect("a rendered view");
    let mut mean: Vec<[f32; 3]> = Vec::new();
    for frame in 0..frames {
        let mut jittered = view.clone();
        jittered.settings.frame_index = frame;
        rig.rendered_view = Some(jittered);
        let (radiance, _) = rig.reference(textures);
        mean.resize(radiance.len(), [0.0; 3]);
        for (m, l) in mean.iter_mut().zip(radiance) {
            for c in 0..3 {
                m[c] += l[c] / frames as f32;
            }
        }
    }
    rig.rendered_view = Some(view);
    mean
}

/// View rays keep their direction far from the scene's origin: a camera 80 km out (Bern's
/// views sit 8 km out) sees a uniform slab as the CPU reference does. The rays are built in view
/// space and rotated: a near-plane point minus the camera position in f32 world space is off by
/// up to a few degrees there, in blocks of pixels.
#[test]
fn view_rays_keep_their_direction_far_from_the_origin() {
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    let mut errors = Vec::new();
    for offset in [0.0, 80_000.0] {
        let scene = Scene {
            name: "far_slab",
            // Toward the horizon, where the slab's brightness changes fastest with elevation.
            camera: looking(Vec3::new(offset, 1.0, -offset), 4.0, 30.0),
            sun_deg: (30.0, 200.0),
            layers: vec![slab(0.002)],
            settings: settings(48),
        };
        rig.set_scene(&scene);
        let (gpu_l, _) = rig.render(3);
        let (cpu_l, _) = rig.reference(&textures);
        let error = relative_rmse(&gpu_l, &cpu_l);
        eprintln!("camera {offset} m from the origin: relative RMSE against the CPU {error:.5}");
        errors.push(error);
    }
    for error in errors {
        assert!(error <= 0.01, "relative RMSE {error}");
    }
}

/// The weather map caches each layer's local coverage around the camera. Its texels are the CPU
/// twin's, and the image is the same with the map, without it, and with a map so small that its
/// edge crosses the view (where the march switches to computing the coverage itself); each
/// matches the CPU reference. The layer has a far place (the map carries the coverage blend)
/// and a week of wind drift (the map's origin comes from the wrapped f64 offset).
#[test]
fn weather_map_matches_the_cpu_and_changes_the_cost_not_the_image() {
    use bevy_cloudscape::{
        layers::FarCoverage,
        reference::{
            render::NoiseTexture2d,
            weather_map::{build_weather_map, weather_map_origin},
        },
        render::{noise::CloudNoiseTextures, weather_map::CloudWeatherMap},
    };
    let size = UVec2::new(64, 36);
    let recipe = small_recipe();
    let textures = CloudTextures::from_recipe(&recipe);
    let mut rig = CloudRig::new(size, Msaa::Off, recipe.clone());
    let cloud = CloudLayer {
        far_coverage: vec![FarCoverage {
            from_m: [0.0, 0.0],
            to_m: [0.0, 15_000.0],
            coverage: 0.9,
        }],
        wind_m_s: [12.0, 5.0],
        ..layer(CloudKind::Cumulus, 0.3)
    };
    let week_s = 7.0 * 86_400.0;
    let mut images = Vec::new();
    // Off, a map of 64 texels (±6 km at this noise's 188 m texels: its edge is in view) and the
    // default.
    for (map_size, name) in [(0, "off"), (64, "small"), (512, "default")] {
        let scene = Scene {
            name: "weather_map",
            camera: looking(Vec3::new(0.0, 2.0, 0.0), 14.0, 20.0),
            sun_deg: (40.0, 150.0),
            layers: vec![cloud.clone()],
            settings: VolumetricClouds {
                weather_map_size: map_size,
                ..settings(64)
            },
        };
        rig.set_scene(&scene);
        rig.set_drift([12.0 * week_s, 5.0 * week_s]);
        let before = rig
            .app
            .render_world()
            .resource::<CloudPassStats>()
            .views_with_weather_map;
        let (gpu_l, gpu_t) = rig.render(3);
        let maps = rig
            .app
            .render_world()
            .resource::<CloudPassStats>()
            .views_with_weather_map
            - before;
        let (cpu_l, cpu_t) = rig.reference(&textures);
        let error = relative_rmse(&gpu_l, &cpu_l);
        let t_error = gpu_t
            .iter()
            .zip(&cpu_t)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        let mean_t = cpu_t.iter().map(|t| f64::from(*t)).sum::<f64>() / cpu_t.len() as f64;
        eprintln!(
            "weather map {name}: {maps} maps built in 3 frames; GPU vs CPU relative RMSE \
             {error:.4}, max |ΔT| {t_error:.4}, mean T {mean_t:.3}"
        );
        save_strip(
            &output_dir().join(format!("clouds_weather_map_{name}.png")),
            size,
            &[&gpu_l, &cpu_l],
        );
        assert!(error <= 0.03, "{name}: relative RMSE {error}");
        assert!(
            mean_t < 0.9,
            "{name}: the view must show cloud (mean T {mean_t})"
        );
        if map_size == 0 {
            assert_eq!(maps, 0, "no map when it is off");
        } else {
            assert!(maps >= 3, "{name}: the map is rebuilt every frame ({maps})");
            // The texels the pass wrote, against the CPU twin at the extracted offsets.
            let view = rig.extracted();
            let world = rig.app.render_world();
            let texture = world
                .query::<&CloudWeatherMap>()
                .iter(world)
                .next()
                .expect("the view has a weather map")
                .texture()
                .clone();
            let noise = world
                .resource::<CloudNoiseTextures>()
                .weather
                .texture
                .clone();
            let bytes = rig.app.read_texture(&texture, 0);
            // The warp channels are `texel_shape_warp` of the weather noise the GPU made.
            let noise_bytes = rig.app.read_texture(&noise, 0);
            let n = recipe.weather_size;
            assert_eq!(noise_bytes.len(), (4 * n * n) as usize);
            let gpu_noise = NoiseTexture2d {
                size: n,
                texels: noise_bytes
                    .chunks_exact(4)
                    .map(|t| [t[0], t[1], t[2], t[3]])
                    .collect(),
            };
            let side = map_size as usize;
            assert_eq!(bytes.len(), side * side * view.layers.len() * 16);
            let mut worst = 0.0f64;
            let mut worst_warp = 0.0f64;
            let mut warped = 0;
            let mut partial = 0;
            for (slice, layer) in view.layers.iter().enumerate() {
                let origin = weather_map_origin(layer, recipe.weather_size, map_size);
                let cpu = build_weather_map(&textures.weather, layer, origin, map_size);
                let cpu_warp = build_weather_map(&gpu_noise, layer, origin, map_size);
                for (i, (texel, warp)) in cpu.iter().zip(&cpu_warp).enumerate() {
                    let at = 16 * (slice * side * side + i);
                    let gpu = |c: usize| {
                        let channel = &bytes[at + 4 * c..at + 4 * c + 4];
                        f64::from(f32::from_le_bytes(channel.try_into().unwrap()))
                    };
                    worst = worst.max((gpu(0) - texel[0]).abs());
                    for (c, w) in warp.iter().enumerate().skip(1) {
                        worst_warp = worst_warp.max((gpu(c) - w).abs());
                    }
                    warped += usize::from(warp[1].abs().max(warp[2].abs()) > 0.05);
                    partial += usize::from(texel[0] > 0.0 && texel[0] < 1.0);
                }
            }
            eprintln!(
                "weather map {name}: coverage max |GPU - CPU| {worst:.2e}, warp {worst_warp:.2e} \
                 shape periods, {partial} partial, {warped} warped"
            );
            assert!(worst < 1e-5, "{name}: map coverage off by {worst}");
            // f32 rounding only: 1e-4 of a shape period is under a hundredth of a shape-noise
            // texel, far below anything an image shows.
            assert!(
                worst_warp < 1e-4,
                "{name}: map warp off by {worst_warp} shape periods"
            );
            assert!(warped > side, "{name}: the map must hold a warp ({warped})");
            assert!(
                partial > side,
                "{name}: the map must hold cloud edges ({partial})"
            );
        }
        images.push((gpu_l, gpu_t));
    }
    // With or without the map, the same image: only f32 rounding differs.
    let (off_l, off_t) = &images[0];
    for (name, (l, t)) in ["small", "default"].iter().zip(&images[1..]) {
        let error = relative_rmse(l, off_l);
        let t_error = t
            .iter()
            .zip(off_t)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        eprintln!("weather map {name} vs off: relative RMSE {error:.2e}, max |ΔT| {t_error:.2e}");
        assert!(error < 1e-3, "{name}: the map changed the image by {error}");
        assert!(t_error < 1e-3, "{name}: the map changed T by {t_error}");
    }
}

/// A transition picked anew halfway renders no frame-to-frame jump at the retarget larger than
/// the largest a transition straight to either target makes: value and rate stay continuous.
/// Cutting to the new target instead (the negative control) does jump.
#[test]
fn a_retargeted_transition_renders_no_jump() {
    let size = UVec2::new(64, 36);
    let (_textures, mut rig) = small_rig(size);
    let mut scene = showcase_scenes().remove(0);
    let start = layer(CloudKind::Cumulus, 0.1);
    let middle = layer(CloudKind::Cumulus, 0.25);
    let end = layer(CloudKind::Stratocumulus, 0.45);
    const DURATION_S: f32 = 2.0;
    const DT: f32 = 0.05;
    const FRAMES: usize = 48;
    // Halfway through the transition.
    let retarget = (0.5 * DURATION_S / DT) as usize;
    // The first frames of a new rig wait for the pipelines and the noise.
    scene.layers = vec![start.clone()];
    rig.set_scene(&scene);
    rig.render(4);
    // The frames of a transition from `start` to `first`, retargeted to `then` after
    // `retarget` frames (with a transition, or cut when `cut`).
    let mut play = |first: &CloudLayer, then: Option<&CloudLayer>, cut: bool| {
        let mut layer = start.clone();
        let mut transition = LayerTransition::new(first.clone()).with_duration(DURATION_S);
        let mut frames = Vec::new();
        for frame in 0..FRAMES {
            if let Some(target) = then
                && frame == retarget
            {
                transition.target = target.clone();
                if cut {
                    transition.duration_s = 0.0;
                }
            }
            transition.step(&mut layer, DT);
            scene.layers = vec![layer.clone()];
            rig.set_scene(&scene);
            frames.push(rig.render(1).0);
        }
        frames
    };
    let to_middle = play(&middle, None, false);
    let to_end = play(&end, None, false);
    let retargeted = play(&middle, Some(&end), false);
    let cut = play(&middle, Some(&end), true);
    // Frame-to-frame change: the RMS of the luminance difference over the mean luminance of
    // the end state, one scale for every run.
    let scale = to_end[FRAMES - 1].iter().map(luminance).sum::<f64>() / (size.x * size.y) as f64;
    let change = |a: &[[f32; 3]], b: &[[f32; 3]]| {
        let sum: f64 = a
            .iter()
            .zip(b)
            .map(|(a, b)| (luminance(a) - luminance(b)).powi(2))
            .sum();
        (sum / a.len() as f64).sqrt() / scale
    };
    let changes = |frames: &[Vec<[f32; 3]>]| -> Vec<f64> {
        frames
            .windows(2)
            .map(|pair| change(&pair[1], &pair[0]))
            .collect()
    };
    let largest = |c: &[f64]| c.iter().copied().fold(0.0, f64::max);
    let (middle_changes, end_changes) = (changes(&to_middle), changes(&to_end));
    let straight = largest(&middle_changes).max(largest(&end_changes));
    // Frame `retarget` is the first drawn toward the new target; `changes[i]` is frame i + 1
    // against frame i.
    let around = |c: &[f64]| largest(&c[retarget - 2..retarget + 3]);
    let (retargeted_changes, cut_changes) = (changes(&retargeted), changes(&cut));
    save_strip(
        &output_dir().join("clouds_transition_retargeted.png"),
        size,
        &retargeted
            .iter()
            .step_by(6)
            .map(Vec::as_slice)
            .collect::<Vec<_>>(),
    );
    eprintln!(
        "largest frame-to-frame change (RMS of luminance over the end state's mean): straight \
         to the middle {:.4}, straight to the end {:.4}; around the retarget halfway: with the \
         transition {:.4}, cut {:.4}; retargeted run overall {:.4}",
        largest(&middle_changes),
        largest(&end_changes),
        around(&retargeted_changes),
        around(&cut_changes),
        largest(&retargeted_changes),
    );
    let moved = change(&retargeted[FRAMES - 1], &retargeted[0]);
    // The change is spread over frames: the whole is more than twice the largest frame's.
    assert!(
        moved > 2.0 * straight,
        "start to end {moved}, one frame {straight}"
    );
    assert!(
        around(&retargeted_changes) <= straight,
        "a jump at the retarget: {} > {straight}",
        around(&retargeted_changes)
    );
    assert!(
        around(&cut_changes) > straight,
        "the test sees a cut: {} <= {straight}",
        around(&cut_changes)
    );
}

/// A ray's primary steps are one budget shared by the layers it crosses. From inside a low
/// layer toward the horizon, a mid layer far away spans a hundred kilometres of the ray: shared by
/// length it took most of the steps and left the layer around the camera a step per kilometre,
/// dark blotches at the horizon (the Bern demo in raining stratus). Shared by the steps each
/// interval calls for (they grow with distance), the far layer at most doubles the error of the
/// near one against a converged march. The errors are compared as radiance (RMSE of luminance),
/// not each relative to its own image's mean: the layer above shades the near one (its sun and
/// sky light come through it), which would scale a relative error up with no step going
/// elsewhere.
#[test]
fn a_far_layer_does_not_starve_the_layer_around_the_camera() {
    let size = UVec2::new(96, 54);
    let (_textures, mut rig) = small_rig(size);
    let mut stratus = layer(CloudKind::Stratus, 0.31);
    stratus.base_m = 150.0;
    stratus.top_m = 450.0;
    let mut alto = layer(CloudKind::Altostratus, 0.89);
    alto.base_m = 2_858.0;
    let mut render = |layers: Vec<CloudLayer>, steps: u32| {
        rig.set_scene(&Scene {
            name: "inside stratus",
            camera: looking(Vec3::new(0.0, 320.0, 0.0), -2.0, 20.0),
            sun_deg: (13.8, 279.0),
            layers,
            // Single scattering: the δ-scaled light lets the far layer show through the near
            // one, and its own error (with the steps it gets) with it; the step shares are the
            // same whatever the light.
            // Half the light steps on rays away from the sun, as the test was written with:
            // with 0.3 of them (`MEDIUM` now) the stratus alone is ten times closer to its
            // converged march at 64 steps (RMSE 0.0003 against 0.003), while the two layers'
            // error stays 0.005, so the bound would measure the far layer's own error.
            settings: VolumetricClouds {
                multiple_scattering: false,
                light_steps_away_from_sun: 0.5,
                ..settings(steps)
            },
        });
        rig.render(3).0
    };
    let rmse = |marched: &[[f32; 3]], converged: &[[f32; 3]]| {
        let mean = converged.iter().map(luminance).sum::<f64>() / converged.len() as f64;
        relative_rmse(marched, converged) * mean
    };
    let near = rmse(
        &render(vec![stratus.clone()], 64),
        &render(vec![stratus.clone()], 512),
    );
    let both = vec![stratus, alto];
    let converged = render(both.clone(), 512);
    let marched = render(both, 64);
    let error = rmse(&marched, &converged);
    save_strip(
        &output_dir().join("clouds_inside_stratus_under_altostratus.png"),
        size,
        &[&marched, &converged],
    );
    eprintln!(
        "inside stratus, 64 steps against 512, RMSE of luminance: stratus alone {near:.5}, under altostratus {error:.5}"
    );
    assert!(error <= 2.0 * near, "{error} > 2 × {near}");
}

/// A storm at night: with a flash lit (every second flashes under a rate of 60 a minute, and
/// the paused clock stands at a whole second, the first stroke's peak) the cumulonimbus glows
/// from within, the GPU's march matching its CPU twin, and a `LightningLight` lights the ground;
/// with the same layer at a rate of 0 the march gets no flash and no light exists, so a sky
/// without a storm pays nothing for lightning.
#[test]
fn a_lightning_flash_lights_the_storm_cloud_from_within() {
    use bevy_cloudscape::lightning::{ActiveFlash, Lightning, LightningLight};
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    let scene = Scene {
        name: "storm_flash",
        camera: looking(Vec3::new(0.0, 2.0, 0.0), 25.0, 0.0),
        // Night: the sun far below the horizon.
        sun_deg: (-30.0, 150.0),
        layers: vec![layer(CloudKind::Cumulonimbus, 0.9)],
        settings: settings(64),
    };
    rig.set_scene(&scene);
    let light_count = |rig: &mut CloudRig| {
        let world = rig.app.world();
        world
            .query_filtered::<(), With<LightningLight>>()
            .iter(world)
            .count()
    };
    {
        let world = rig.app.world();
        world.resource_mut::<SceneClock>().paused = true;
        *world.resource_mut::<Lightning>() = Lightning {
            rate_override: Some(0.0),
            ..default()
        };
    }
    let (calm_l, _) = rig.render(4);
    let calm = rig.rendered_view.clone().expect("a rendered view");
    assert_eq!(calm.settings.flash_intensity_cd, 0.0, "no storm, no flash");
    assert_eq!(light_count(&mut rig), 0, "no storm, no light");

    {
        let world = rig.app.world();
        // No ground stroke: its channel is scene geometry, which the rig's recovery of the
        // clouds' light and transmittance from two backgrounds does not allow.
        *world.resource_mut::<Lightning>() = Lightning {
            rate_override: Some(60.0),
            radius_m: 3_000.0,
            ground_strokes: 0.0,
            ..default()
        };
    }
    let (gpu_l, gpu_t) = rig.render(4);
    let view = rig.rendered_view.clone().expect("a rendered view");
    let flash = rig.app.world().resource::<ActiveFlash>().flash;
    assert!(
        view.settings.flash_intensity_cd > 0.0 && flash.is_some(),
        "a flash is lit: {flash:?}"
    );
    assert_eq!(light_count(&mut rig), 1, "the flash lights the ground");
    let (cpu_l, cpu_t) = rig.reference(&textures);
    save_strip(
        &output_dir().join(format!("clouds_{}.png", scene.name)),
        size,
        &[&calm_l, &gpu_l, &cpu_l],
    );
    let (error, t_rmse, _) = twin_difference((&gpu_l, &gpu_t), (&cpu_l, &cpu_t));
    eprintln!("flash: relative RMSE {error:.4}, RMSE of T {t_rmse:.4}");
    assert!(error <= TWIN_RELATIVE_RMSE, "relative RMSE {error}");
    assert!(t_rmse <= TWIN_T_RMSE, "transmittance RMSE {t_rmse}");
    let mean = |l: &[[f32; 3]]| l.iter().map(|p| f64::from(p[1])).sum::<f64>() / l.len() as f64;
    let (lit, dark) = (mean(&gpu_l), mean(&calm_l));
    eprintln!("mean luminance with the flash {lit:.4}, without {dark:.6}");
    // At night the cloud has only the night sky's light: a flash outshines it many times over.
    assert!(lit > 10.0 * dark && lit > 0.0, "{lit} against {dark}");
}
