//! The march pass in headless renders, against the f64 CPU reference renderer.
//!
//! The cloud pass composites `scene · T + L`. Rendering a view over a black and over a white
//! background (no sky, no geometry) therefore recovers both: `L` from the black frame and `T`
//! from the difference. The CPU reference marches the same rays with the settings and layers
//! the render world extracted, over the same noise (generated small here, so the CPU twin is
//! quick), and the two are compared pixel by pixel.

use bevy::{
    camera::{Exposure, RenderTarget},
    core_pipeline::tonemapping::Tonemapping,
    prelude::*,
    render::render_resource::TextureFormat,
};
use bevy_cloudscape::{
    prelude::*,
    reference::{
        noise::NoiseRecipe,
        render::{CloudTextures, march_clouds, ray_start_jitter},
    },
    render::march::{CloudPassStats, ExtractedCloudView},
};

use crate::harness::{Headless, output_dir};

/// A fixed scene: camera, sun, layers, march settings.
struct Scene {
    name: &'static str,
    camera: Transform,
    /// Sun elevation and azimuth (clockwise from −Z, the view's north), degrees.
    sun_deg: (f32, f32),
    layers: Vec<CloudLayer>,
    settings: VolumetricClouds,
}

fn layer(kind: CloudKind, coverage: f32) -> CloudLayer {
    CloudLayer {
        coverage,
        weather_driven: false,
        ..CloudLayer::new(kind)
    }
}

fn looking(from: Vec3, pitch_deg: f32, yaw_deg: f32) -> Transform {
    let (pitch, yaw) = (pitch_deg.to_radians(), yaw_deg.to_radians());
    let forward = Vec3::new(
        yaw.sin() * pitch.cos(),
        pitch.sin(),
        -yaw.cos() * pitch.cos(),
    );
    Transform::from_translation(from).looking_to(forward, Vec3::Y)
}

fn sun_direction((elevation, azimuth): (f32, f32)) -> Vec3 {
    let (el, az) = (elevation.to_radians(), azimuth.to_radians());
    Vec3::new(az.sin() * el.cos(), el.sin(), -az.cos() * el.cos())
}

/// Deterministic settings: no jitter, so GPU and CPU sample the same points.
fn settings(primary_steps: u32) -> VolumetricClouds {
    VolumetricClouds {
        primary_steps,
        jitter: false,
        ..VolumetricClouds::MEDIUM
    }
}

fn showcase_scenes() -> Vec<Scene> {
    vec![
        Scene {
            name: "cumulus_noon",
            camera: looking(Vec3::new(0.0, 2.0, 0.0), 25.0, 0.0),
            sun_deg: (60.0, 150.0),
            layers: vec![layer(CloudKind::Cumulus, 0.5)],
            settings: settings(64),
        },
        Scene {
            name: "overcast_stratus",
            camera: looking(Vec3::new(0.0, 2.0, 0.0), 20.0, 40.0),
            sun_deg: (40.0, 200.0),
            layers: vec![layer(CloudKind::Stratus, 1.0)],
            settings: settings(64),
        },
        Scene {
            name: "sunset_behind_clouds",
            camera: looking(Vec3::new(0.0, 2.0, 0.0), 6.0, 0.0),
            sun_deg: (4.0, 5.0),
            layers: vec![layer(CloudKind::Altocumulus, 0.6)],
            settings: settings(64),
        },
        Scene {
            name: "inside_cumulus",
            camera: looking(Vec3::new(0.0, 1_600.0, 0.0), 5.0, 30.0),
            sun_deg: (45.0, 100.0),
            layers: vec![layer(CloudKind::Cumulus, 0.6)],
            settings: settings(64),
        },
    ]
}

/// The noise at test size: the CPU twin of 128³ is too slow for an unoptimised test build.
fn small_recipe() -> NoiseRecipe {
    NoiseRecipe {
        base_size: 32,
        detail_size: 16,
        weather_size: 64,
        ..default()
    }
}

#[derive(Component)]
struct TestCamera;

/// One app for many scenes: the pipelines compile once.
struct CloudRig {
    app: Headless,
    camera: Entity,
    sun: Entity,
    /// Per pixel, how far f16 rounding can move the `T` of the last [`CloudRig::render`].
    t_tolerance: Vec<f32>,
}

/// Spacing of half-floats around `v`.
fn f16_step(v: f32) -> f32 {
    let v = v.abs().max(6.1e-5);
    2f32.powi(v.log2().floor() as i32 - 10)
}

const EXPOSURE: Exposure = Exposure { ev100: 13.0 };

impl CloudRig {
    fn new(size: UVec2, msaa: Msaa) -> Self {
        let mut app = Headless::new(size, TextureFormat::Rgba16Float, |app| {
            app.add_plugins(CloudscapePlugin)
                .insert_resource(CloudNoiseSettings(small_recipe()))
                .insert_resource(SceneClock::at("2021-05-03T12:00:00Z".parse().unwrap()));
        });
        let target = app.target.clone();
        let camera = app
            .world()
            .spawn((
                Camera3d::default(),
                Camera {
                    clear_color: ClearColorConfig::Custom(Color::BLACK),
                    ..default()
                },
                Projection::Perspective(PerspectiveProjection {
                    fov: 60f32.to_radians(),
                    ..default()
                }),
                RenderTarget::Image(target.into()),
                VolumetricClouds::MEDIUM,
                EXPOSURE,
                Tonemapping::None,
                msaa,
                TestCamera,
            ))
            .id();
        let sun = app
            .world()
            .spawn(DirectionalLight {
                illuminance: 100_000.0,
                ..default()
            })
            .id();
        Self {
            app,
            camera,
            sun,
            t_tolerance: Vec::new(),
        }
    }

    fn set_scene(&mut self, scene: &Scene) {
        let world = self.app.world();
        world
            .entity_mut(self.camera)
            .insert((scene.camera, scene.settings.clone()));
        world
            .entity_mut(self.sun)
            .insert(Transform::default().looking_to(-sun_direction(scene.sun_deg), Vec3::Y));
        let old: Vec<Entity> = world
            .query_filtered::<Entity, With<CloudLayer>>()
            .iter(world)
            .collect();
        for entity in old {
            world.despawn(entity);
        }
        for layer in &scene.layers {
            world.spawn(layer.clone());
        }
    }

    fn set_background(&mut self, color: Color) {
        self.app
            .world()
            .get_mut::<Camera>(self.camera)
            .unwrap()
            .clear_color = ClearColorConfig::Custom(color);
    }

    /// Renders over black and over a bright grey; returns per pixel (L · exposure, T) from the
    /// GPU. The grey is bright so that `T` survives the f16 rounding of `grey · T + L`.
    fn render(&mut self, frames: u32) -> (Vec<[f32; 3]>, Vec<f32>) {
        const GREY: f32 = 256.0;
        self.set_background(Color::BLACK);
        self.app.run_frames(frames);
        let black = self.app.read_target();
        self.set_background(Color::linear_rgb(GREY, GREY, GREY));
        self.app.run_frames(2);
        let grey = self.app.read_target();
        let radiance = black.rgba.iter().map(|p| [p[0], p[1], p[2]]).collect();
        let transmittance = grey
            .rgba
            .iter()
            .zip(&black.rgba)
            .map(|(w, b)| (w[0] - b[0] + w[1] - b[1] + w[2] - b[2]) / (3.0 * GREY))
            .collect();
        // How far rounding to f16 (twice: the blend and the resolve or copy) can move the
        // recovered T: two half-float steps of each frame's value, over the grey.
        self.t_tolerance = grey
            .rgba
            .iter()
            .zip(&black.rgba)
            .map(|(w, b)| 2.0 * (f16_step(w[1]) + f16_step(b[1])) / GREY)
            .collect();
        (radiance, transmittance)
    }

    fn extracted(&mut self) -> ExtractedCloudView {
        let world = self.app.render_world();
        world
            .query::<&ExtractedCloudView>()
            .iter(world)
            .next()
            .expect("the view has visible layers")
            .clone()
    }

    fn views_marched(&mut self) -> u64 {
        self.app
            .render_world()
            .resource::<CloudPassStats>()
            .views_marched
    }

    /// The CPU reference image for the current scene: (L·exposure, T) per pixel.
    fn reference(&mut self, textures: &CloudTextures) -> (Vec<[f32; 3]>, Vec<f32>) {
        let view = self.extracted();
        let size = self.app.size;
        let world = self.app.world();
        let camera = world.get::<Camera>(self.camera).unwrap();
        let world_from_clip = world
            .get::<GlobalTransform>(self.camera)
            .unwrap()
            .to_matrix()
            * camera.clip_from_view().inverse();
        let position = world
            .get::<GlobalTransform>(self.camera)
            .unwrap()
            .translation();
        let exposure = f64::from(EXPOSURE.exposure());
        let mut radiance = Vec::new();
        let mut transmittance = Vec::new();
        for y in 0..size.y {
            for x in 0..size.x {
                // The same ray as march.wgsl: through the pixel centre on the near plane.
                let uv = (Vec2::new(x as f32, y as f32) + 0.5) / size.as_vec2();
                let ndc = Vec2::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
                let near = world_from_clip * Vec4::new(ndc.x, ndc.y, 1.0, 1.0);
                let direction = (near.truncate() / near.w - position).normalize();
                let pixel = [f64::from(x) + 0.5, f64::from(y) + 0.5];
                let result = march_clouds(
                    textures,
                    &view.settings,
                    &view.layers,
                    view.settings.camera_altitude_m,
                    view.settings.camera_up,
                    direction.as_dvec3().to_array(),
                    f64::INFINITY,
                    ray_start_jitter(&view.settings, pixel),
                );
                radiance.push(result.radiance.map(|v| (v * exposure) as f32));
                transmittance.push(result.transmittance as f32);
            }
        }
        (radiance, transmittance)
    }
}

fn luminance(rgb: &[f32; 3]) -> f64 {
    f64::from(0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2])
}

/// Relative RMSE of linear luminance: `sqrt(mean((a − b)²)) / mean(b)`.
fn relative_rmse(gpu: &[[f32; 3]], reference: &[[f32; 3]]) -> f64 {
    let n = reference.len() as f64;
    let mean = reference.iter().map(luminance).sum::<f64>() / n;
    let mse = gpu
        .iter()
        .zip(reference)
        .map(|(a, b)| (luminance(a) - luminance(b)).powi(2))
        .sum::<f64>()
        / n;
    mse.sqrt() / mean
}

fn save_strip(name: &str, size: UVec2, images: &[&[[f32; 3]]]) {
    let scale = 1.0;
    let width = size.x * images.len() as u32;
    let mut bytes = Vec::new();
    for y in 0..size.y {
        for image in images {
            for x in 0..size.x {
                let p = image[(y * size.x + x) as usize];
                bytes.extend(p.map(|v| (encode_srgb(v * scale) * 255.0 + 0.5) as u8));
            }
        }
    }
    let path = output_dir().join(format!("{name}.png"));
    std::fs::create_dir_all(output_dir()).unwrap();
    image::RgbImage::from_raw(width, size.y, bytes)
        .unwrap()
        .save(path)
        .unwrap();
}

fn encode_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

#[test]
fn showcase_scenes_match_the_cpu_reference() {
    let size = UVec2::new(96, 54);
    let textures = CloudTextures::from_recipe(&small_recipe());
    let mut rig = CloudRig::new(size, Msaa::Off);
    for scene in showcase_scenes() {
        rig.set_scene(&scene);
        let (gpu_l, gpu_t) = rig.render(4);
        let (cpu_l, cpu_t) = rig.reference(&textures);
        save_strip(&format!("clouds_{}", scene.name), size, &[&gpu_l, &cpu_l]);
        let error = relative_rmse(&gpu_l, &cpu_l);
        let t_rmse = (gpu_t
            .iter()
            .zip(&cpu_t)
            .map(|(a, b)| f64::from(a - b).powi(2))
            .sum::<f64>()
            / cpu_t.len() as f64)
            .sqrt();
        let mean_t = cpu_t.iter().map(|t| f64::from(*t)).sum::<f64>() / cpu_t.len() as f64;
        eprintln!(
            "{}: relative RMSE of luminance {:.4}, RMSE of T {t_rmse:.4}, mean T {mean_t:.3}",
            scene.name, error
        );
        assert!(error <= 0.03, "{}: relative RMSE {error} > 3 %", scene.name);
        assert!(
            t_rmse <= 0.02,
            "{}: transmittance RMSE {t_rmse}",
            scene.name
        );
        assert!(
            mean_t < 0.95,
            "{}: the scene must actually show cloud (mean T {mean_t})",
            scene.name
        );
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
        weather_driven: false,
        ..CloudLayer::new(CloudKind::Stratus)
    }
}

#[test]
fn homogeneous_slab_matches_the_closed_form_on_the_gpu() {
    use bevy_cloudscape::reference::render::homogeneous_slab;
    // A narrow camera looking straight up: the centre pixels see a vertical ray.
    let size = UVec2::new(8, 8);
    let mut rig = CloudRig::new(size, Msaa::Off);
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
                    multiple_scattering_octaves: 1,
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
    let size = UVec2::new(64, 36);
    let mut app = Headless::new(size, TextureFormat::Rgba8UnormSrgb, |app| {
        app.add_plugins(CloudscapePlugin)
            .insert_resource(CloudNoiseSettings(small_recipe()));
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
    cloudy.save_png(output_dir().join("depth_cloudy.png"), 1.0);

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
}

#[test]
fn no_coverage_is_the_same_frame_as_no_plugin_and_skips_the_pass() {
    let size = UVec2::new(48, 27);
    let scene = |with_plugin: bool, coverage: Option<f32>| {
        let mut app = Headless::new(size, TextureFormat::Rgba16Float, |app| {
            if with_plugin {
                app.add_plugins(CloudscapePlugin)
                    .insert_resource(CloudNoiseSettings(small_recipe()));
            }
            app.add_systems(Startup, crate::common::spawn_sky_scene);
        });
        let target = app.target.clone();
        app.world().spawn((
            crate::common::sky_scene_camera(),
            RenderTarget::Image(target.into()),
            VolumetricClouds::MEDIUM,
        ));
        if let Some(coverage) = coverage {
            app.world().spawn(layer(CloudKind::Cumulus, coverage));
        }
        app.run_frames(4);
        let marched = app
            .render_world()
            .get_resource::<CloudPassStats>()
            .map_or(0, |s| s.views_marched);
        (app.read_target().rgba, marched)
    };
    let (off, _) = scene(false, None);
    let (no_layers, marched_no_layers) = scene(true, None);
    let (zero, marched_zero) = scene(true, Some(0.0));
    let (cloudy, marched_cloudy) = scene(true, Some(0.5));
    assert_eq!(no_layers, off, "no layers: the frame of the plugin off");
    assert_eq!(zero, off, "coverage 0: the frame of the plugin off");
    assert_eq!(
        (marched_no_layers, marched_zero),
        (0, 0),
        "the pass did not run"
    );
    assert!(
        marched_cloudy > 0 && cloudy != off,
        "with coverage the pass runs and changes the frame"
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
    let mut rig = CloudRig::new(size, Msaa::Sample4);
    let cumulus = layer(CloudKind::Cumulus, 0.6);
    let (base, top) = (f64::from(cumulus.base_m), f64::from(cumulus.top_m));
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
                ..VolumetricClouds::MEDIUM
            },
        };
        rig.set_scene(&scene);
        // A week of 30 m/s wind already behind every layer.
        let week = 7.0 * 86_400.0 * 30.0;
        let world = rig.app.world();
        let layers: Vec<Entity> = world
            .query_filtered::<Entity, With<CloudLayer>>()
            .iter(world)
            .collect();
        for entity in layers {
            world
                .entity_mut(entity)
                .insert(bevy_cloudscape::render::march::LayerDrift {
                    offset_m: [week, -week],
                });
        }
        let (l, t) = rig.render(2);
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
            "{case} with jitter"
        );
    }
    // Tiny and odd targets (one app at a time: apps take turns on the GPU).
    drop(rig);
    for size in [UVec2::new(1, 1), UVec2::new(7, 5)] {
        let mut rig = CloudRig::new(size, Msaa::Off);
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
