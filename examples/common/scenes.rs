//! Fixed cloud scenes and a rig that renders them headless, shared by the GPU tests and the
//! `bench` example.
//!
//! The cloud pass composites `scene · T + L`. Rendering a view over a black and over a bright
//! grey background (no sky, no geometry) recovers both: `L` from the black frame and `T` from the
//! difference. [`CloudRig::reference`] marches the same rays on the CPU with the settings and
//! layers the render world extracted.

use bevy::{
    camera::{Exposure, RenderTarget},
    core_pipeline::tonemapping::Tonemapping,
    prelude::*,
    render::render_resource::TextureFormat,
};
use bevy_cloudscape::layers::LayerDrift;
use bevy_cloudscape::{
    prelude::*,
    reference::{
        composite::{LowResImage, ray_end_m, upsample},
        haze::{HazeSun, ShaftFactors, composite, march_haze, shaft_factors},
        noise::NoiseRecipe,
        render::{CloudTextures, MarchResult, march_clouds, ray_start_jitter},
        shadow::ShadowMapImage,
    },
    render::{
        composite::low_res_size,
        march::{CloudPassStats, ExtractedCloudView},
    },
};

use super::headless::Headless;

impl Scene {
    /// Puts the scene into `world`: moves `camera` and gives it the settings, aims the `sun`
    /// light, and replaces every `CloudLayer` entity with the scene's layers.
    pub fn apply(&self, world: &mut World, camera: Entity, sun: Entity) {
        // A new scene is a camera cut: the temporal accumulation starts over, so no earlier
        // scene's clouds linger in this one's first frames.
        let settings = VolumetricClouds {
            reset_history: true,
            ..self.settings.clone()
        };
        world.entity_mut(camera).insert((self.camera, settings));
        world
            .entity_mut(sun)
            .insert(Transform::default().looking_to(-sun_direction(self.sun_deg), Vec3::Y));
        let old: Vec<Entity> = world
            .query_filtered::<Entity, With<CloudLayer>>()
            .iter(world)
            .collect();
        for entity in old {
            world.despawn(entity);
        }
        for layer in &self.layers {
            world.spawn(layer.clone());
        }
    }
}

/// A fixed scene: camera, sun, layers, march settings.
#[derive(Clone)]
pub struct Scene {
    /// Name, for files and tables.
    pub name: &'static str,
    /// Camera transform.
    pub camera: Transform,
    /// Sun elevation and azimuth (clockwise from −Z, the view's north), degrees.
    pub sun_deg: (f32, f32),
    /// The cloud layers.
    pub layers: Vec<CloudLayer>,
    /// March settings.
    pub settings: VolumetricClouds,
}

pub fn layer(kind: CloudKind, coverage: f32) -> CloudLayer {
    CloudLayer {
        coverage,
        ..CloudLayer::new(kind)
    }
}

pub fn looking(from: Vec3, pitch_deg: f32, yaw_deg: f32) -> Transform {
    let (pitch, yaw) = (pitch_deg.to_radians(), yaw_deg.to_radians());
    let forward = Vec3::new(
        yaw.sin() * pitch.cos(),
        pitch.sin(),
        -yaw.cos() * pitch.cos(),
    );
    Transform::from_translation(from).looking_to(forward, Vec3::Y)
}

pub fn sun_direction((elevation, azimuth): (f32, f32)) -> Vec3 {
    let (el, az) = (elevation.to_radians(), azimuth.to_radians());
    Vec3::new(az.sin() * el.cos(), el.sin(), -az.cos() * el.cos())
}

/// Deterministic settings: no jitter, so GPU and CPU sample the same points, at full
/// resolution (the CPU reference renders one ray per pixel), with 5 light steps (cheap for the
/// CPU twin; the GPU and CPU march the same steps either way), and every sample's sun from
/// the light march, as the CPU reference marches it without a shadow map.
pub fn settings(primary_steps: u32) -> VolumetricClouds {
    VolumetricClouds {
        primary_steps,
        light_steps: 5,
        resolution_scale: 1.0,
        jitter: false,
        sun_from_shadow_map_m: f32::INFINITY,
        ..VolumetricClouds::MEDIUM
    }
}

pub fn showcase_scenes() -> Vec<Scene> {
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
pub fn small_recipe() -> NoiseRecipe {
    NoiseRecipe {
        base_size: 32,
        detail_size: 16,
        weather_size: 64,
        ..default()
    }
}

/// A rig on [`small_recipe`]'s noise at `size` without MSAA, and the CPU twin's textures of
/// the same noise.
pub fn small_rig(size: UVec2) -> (CloudTextures, CloudRig) {
    (
        CloudTextures::from_recipe(&small_recipe()),
        CloudRig::new(size, Msaa::Off, small_recipe()),
    )
}

/// Marks the rig's camera.
#[derive(Component)]
pub struct TestCamera;

/// One app for many scenes: the pipelines compile once.
pub struct CloudRig {
    /// The app.
    pub app: Headless,
    /// The camera entity.
    pub camera: Entity,
    /// The sun entity.
    pub sun: Entity,
    /// Per pixel, how far f16 rounding can move the `T` of the last [`CloudRig::render`].
    pub t_tolerance: Vec<f32>,
    /// The march inputs of the frame [`CloudRig::render`] took its radiance from (its frame
    /// index sets the jitter), for [`CloudRig::reference`].
    pub rendered_view: Option<ExtractedCloudView>,
}

/// Spacing of half-floats around `v`.
pub fn f16_step(v: f32) -> f32 {
    let v = v.abs().max(6.1e-5);
    2f32.powi(v.log2().floor() as i32 - 10)
}

pub const EXPOSURE: Exposure = Exposure { ev100: 13.0 };

impl CloudRig {
    /// A rig rendering `size` pixels with `msaa`, over noise made from `noise`.
    pub fn new(size: UVec2, msaa: Msaa, noise: NoiseRecipe) -> Self {
        Self::build(size, msaa, noise, false)
    }

    /// [`CloudRig::new`] with Bevy's render diagnostics on: each cloud pass's GPU time is in
    /// the `DiagnosticsStore` as `render/clouds/PASS/elapsed_gpu` (where the device has
    /// timestamp queries).
    pub fn with_gpu_spans(size: UVec2, msaa: Msaa, noise: NoiseRecipe) -> Self {
        Self::build(size, msaa, noise, true)
    }

    fn build(size: UVec2, msaa: Msaa, noise: NoiseRecipe, gpu_spans: bool) -> Self {
        let mut app = Headless::new(size, TextureFormat::Rgba16Float, |app| {
            if gpu_spans {
                app.add_plugins(bevy::render::diagnostic::RenderDiagnosticsPlugin);
            }
            // The rig measures the march: the cloud shadow map (its own pass, tested and timed
            // on its own) is off unless a test turns it on.
            app.add_plugins(CloudscapePlugin)
                .insert_resource(CloudShadows {
                    enabled: false,
                    ..default()
                })
                .insert_resource(CloudNoiseSettings(noise))
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
            rendered_view: None,
        }
    }

    pub fn set_scene(&mut self, scene: &Scene) {
        scene.apply(self.app.world(), self.camera, self.sun);
    }

    /// Puts `offset_m` (`[east, north]`, metres) of wind drift behind every cloud layer.
    pub fn set_drift(&mut self, offset_m: [f64; 2]) {
        let world = self.app.world();
        let layers: Vec<Entity> = world
            .query_filtered::<Entity, With<CloudLayer>>()
            .iter(world)
            .collect();
        for entity in layers {
            world.entity_mut(entity).insert(LayerDrift { offset_m });
        }
    }

    pub fn set_background(&mut self, color: Color) {
        self.app
            .world()
            .get_mut::<Camera>(self.camera)
            .unwrap()
            .clear_color = ClearColorConfig::Custom(color);
    }

    /// Renders over black and over a bright grey; returns per pixel (L · exposure, T) from the
    /// GPU. The grey is bright so that `T` survives the f16 rounding of `grey · T + L`.
    pub fn render(&mut self, frames: u32) -> (Vec<[f32; 3]>, Vec<f32>) {
        const GREY: f32 = 256.0;
        self.set_background(Color::BLACK);
        self.app.run_frames(frames);
        let black = self.app.read_target();
        let world = self.app.render_world();
        self.rendered_view = world
            .query::<&ExtractedCloudView>()
            .iter(world)
            .next()
            .cloned();
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

    pub fn extracted(&mut self) -> ExtractedCloudView {
        let world = self.app.render_world();
        world
            .query::<&ExtractedCloudView>()
            .iter(world)
            .next()
            .expect("the view has visible layers")
            .clone()
    }

    pub fn views_marched(&mut self) -> u64 {
        self.app
            .render_world()
            .resource::<CloudPassStats>()
            .views_marched
    }

    /// The CPU reference image for the current scene: (L·exposure, T) per pixel.
    pub fn reference(&mut self, textures: &CloudTextures) -> (Vec<[f32; 3]>, Vec<f32>) {
        self.reference_with_shadow(textures, None)
    }

    /// [`CloudRig::reference`] with the clouds and the haze reading `shadow`; the light shafts
    /// as the GPU draws them (factors at the view's shaft resolution, upsampled).
    pub fn reference_with_shadow(
        &mut self,
        textures: &CloudTextures,
        shadow: Option<&ShadowMapImage>,
    ) -> (Vec<[f32; 3]>, Vec<f32>) {
        self.reference_with_shafts(textures, shadow, false)
    }

    /// [`CloudRig::reference_with_shadow`]; with `per_sample`, the haze reads the map at every
    /// sample instead of through the reduced-resolution factors (what the factors approximate).
    pub fn reference_with_shafts(
        &mut self,
        textures: &CloudTextures,
        shadow: Option<&ShadowMapImage>,
        per_sample: bool,
    ) -> (Vec<[f32; 3]>, Vec<f32>) {
        let size = self.app.size;
        self.reference_pixels(Some(textures), size, shadow, per_sample)
    }

    /// The haze alone (no clouds in front of it) of the current view at `size` pixels, lit
    /// through `shadow` as [`CloudRig::reference_with_shafts`] lights it: (L·exposure, T).
    pub fn haze_reference(
        &mut self,
        size: UVec2,
        shadow: &ShadowMapImage,
        per_sample: bool,
    ) -> (Vec<[f32; 3]>, Vec<f32>) {
        self.reference_pixels(None, size, Some(shadow), per_sample)
    }

    /// The CPU twin of the view at `size` pixels; without `textures`, the haze alone.
    fn reference_pixels(
        &mut self,
        textures: Option<&CloudTextures>,
        size: UVec2,
        shadow: Option<&ShadowMapImage>,
        per_sample: bool,
    ) -> (Vec<[f32; 3]>, Vec<f32>) {
        let view = self
            .rendered_view
            .clone()
            .unwrap_or_else(|| self.extracted());
        let world = self.app.world();
        let camera = world.get::<Camera>(self.camera).unwrap();
        let view_from_clip = camera.clip_from_view().inverse();
        let world_from_view = world
            .get::<GlobalTransform>(self.camera)
            .unwrap()
            .to_matrix();
        let exposure = f64::from(EXPOSURE.exposure());
        // The same ray as `view_direction` in composite.wgsl: through the pixel centre `uv` on the
        // near plane, in view space, rotated into the world.
        let ray = |uv: Vec2| {
            let ndc = Vec2::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
            let near = view_from_clip * Vec4::new(ndc.x, ndc.y, 1.0, 1.0);
            let direction = world_from_view.transform_vector3(near.truncate() / near.w);
            direction.normalize().as_dvec3().to_array()
        };
        // Where a sky ray ends for the shaft factors' upsample (the ground, or the sky).
        let ray_end = |direction: [f64; 3]| {
            ray_end_m(
                &view.settings,
                view.settings.camera_altitude_m,
                view.settings.camera_up,
                direction,
                f64::INFINITY,
            )
        };
        // The shaft pass: factors at the reduced resolution (the rig has no geometry: every ray
        // ends in the sky).
        let shafts = shadow
            .filter(|_| !per_sample)
            .zip(view.shaft_resolution_scale)
            .map(|(map, scale)| {
                let low = low_res_size(size, scale);
                let mut values = Vec::new();
                let mut distances_m = Vec::new();
                for y in 0..low.y {
                    for x in 0..low.x {
                        let pixel = Vec2::new(x as f32, y as f32) + 0.5;
                        let jitter = ray_start_jitter(
                            &view.settings,
                            [f64::from(pixel.x), f64::from(pixel.y)],
                        );
                        let direction = ray(pixel / low.as_vec2());
                        let f = shaft_factors(
                            &view.settings,
                            &view.haze,
                            view.settings.camera_altitude_m,
                            view.settings.camera_up,
                            direction,
                            f64::INFINITY,
                            jitter,
                            map,
                        );
                        values.push([f.below, f.above]);
                        distances_m.push(ray_end(direction));
                    }
                }
                let image = LowResImage {
                    size: low.to_array(),
                    distances_m,
                    values,
                };
                (image, map.frame.cloud_range_m[0])
            });
        let mut radiance = Vec::new();
        let mut transmittance = Vec::new();
        for y in 0..size.y {
            for x in 0..size.x {
                let uv = (Vec2::new(x as f32, y as f32) + 0.5) / size.as_vec2();
                let pixel = [f64::from(x) + 0.5, f64::from(y) + 0.5];
                let jitter = ray_start_jitter(&view.settings, pixel);
                let direction = ray(uv);
                let clouds = textures.map_or(MarchResult::CLEAR, |textures| {
                    march_clouds(
                        textures,
                        &view.settings,
                        &view.layers,
                        view.settings.camera_altitude_m,
                        view.settings.camera_up,
                        direction,
                        f64::INFINITY,
                        jitter,
                        shadow,
                    )
                });
                let haze = march_haze(
                    &view.settings,
                    &view.haze,
                    view.settings.camera_altitude_m,
                    view.settings.camera_up,
                    direction,
                    f64::INFINITY,
                    clouds.distance_m,
                    jitter,
                    match (&shafts, shadow) {
                        (Some((image, split)), _) => {
                            let [below, above] = upsample(
                                image,
                                [f64::from(uv.x), f64::from(uv.y)],
                                ray_end(direction),
                            );
                            HazeSun::Shafts(ShaftFactors {
                                below,
                                above,
                                split_altitude_m: *split,
                            })
                        }
                        (None, Some(map)) if per_sample => HazeSun::PerSample(map),
                        _ => HazeSun::Mean,
                    },
                );
                let result = composite(&haze, &clouds);
                radiance.push(result.radiance.map(|v| (v * exposure) as f32));
                transmittance.push(result.transmittance as f32);
            }
        }
        (radiance, transmittance)
    }
}

pub fn luminance(rgb: &[f32; 3]) -> f64 {
    f64::from(0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2])
}

/// Relative RMSE of linear luminance: `sqrt(mean((a − b)²)) / mean(b)`.
pub fn relative_rmse(gpu: &[[f32; 3]], reference: &[[f32; 3]]) -> f64 {
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

/// Writes linear RGB images side by side as one sRGB PNG.
pub fn save_strip(path: &std::path::Path, size: UVec2, images: &[&[[f32; 3]]]) {
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
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).unwrap();
    }
    image::RgbImage::from_raw(width, size.y, bytes)
        .unwrap()
        .save(path)
        .unwrap();
}

pub fn encode_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}
