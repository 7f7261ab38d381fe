//! The cloud shadow map on the GPU: its texels against the f64 CPU twin, the night rule, and
//! its effect on a lit `StandardMaterial` ground.

use bevy::{
    camera::Exposure,
    light::{DirectionalLightTexture, GlobalAmbientLight},
    prelude::*,
};
use bevy_cloudscape::layers::LayerDrift;
use bevy_cloudscape::{
    prelude::*,
    reference::{render::CloudTextures, shadow::cloud_shadow_map},
    render::{
        VolumetricClouds,
        march::CloudPassStats,
        shadow::{CloudShadowMap, CloudShadowStats, shadow_inputs},
    },
};

use crate::common::scenes::*;
use crate::harness::output_dir;

/// An IEEE half float from its little-endian bytes.
fn f16_to_f64(bytes: [u8; 2]) -> f64 {
    let bits = u16::from_le_bytes(bytes);
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exponent = i32::from((bits >> 10) & 0x1f);
    let mantissa = f64::from(bits & 0x3ff);
    sign * match exponent {
        0 => mantissa * 2f64.powi(-24),
        31 => f64::INFINITY,
        e => (1.0 + mantissa / 1024.0) * 2f64.powi(e - 15),
    }
}

/// The shadow map as read back: `(size, [T, τ(z₁), τ(z₂), τ] per texel)`, rows from the top.
fn read_shadow_texels(rig: &mut CloudRig) -> (u32, Vec<[f64; 4]>) {
    let map = rig.app.world().resource::<CloudShadowMap>().clone();
    let (_, bytes) = rig.app.read_image(&map.image, 0);
    let texels = bytes
        .chunks(8)
        .map(|t| std::array::from_fn(|c| f16_to_f64([t[2 * c], t[2 * c + 1]])))
        .collect();
    (map.resolution, texels)
}

/// The shadow map of the last frame as the CPU twin reads it: the texels read back, and the frame
/// the render world placed it at, relative to the rig's camera.
fn gpu_shadow_image(rig: &mut CloudRig) -> bevy_cloudscape::reference::shadow::ShadowMapImage {
    let (size, texels) = read_shadow_texels(rig);
    let frame = rig
        .app
        .render_world()
        .get_resource::<bevy_cloudscape::render::haze::CloudShadowFrame>()
        .expect("the shadow map was marched this frame")
        .clone();
    assert_eq!(frame.frame.size, size);
    let camera_m = rig
        .app
        .world()
        .get::<GlobalTransform>(rig.camera)
        .unwrap()
        .translation()
        .as_dvec3();
    bevy_cloudscape::reference::shadow::ShadowMapImage {
        frame: frame.relative_to(camera_m),
        texels,
    }
}

/// The shadow map's ground transmittance as read back: `(size, T per texel)`.
fn read_shadow_map(rig: &mut CloudRig) -> (u32, Vec<f64>) {
    let (size, texels) = read_shadow_texels(rig);
    (size, texels.iter().map(|t| t[0]).collect())
}

/// The CPU twin of the map for the rig's current state (the state the last frame extracted).
fn reference_shadow_map(rig: &mut CloudRig, textures: &CloudTextures) -> Vec<f64> {
    let world = rig.app.world();
    let settings = world.resource::<CloudShadows>().clone();
    let camera = *world.get::<GlobalTransform>(rig.camera).unwrap();
    let clouds = world.get::<VolumetricClouds>(rig.camera).unwrap().clone();
    let light = *world.get::<GlobalTransform>(rig.sun).unwrap();
    let directional = *world.get::<DirectionalLight>(rig.sun).unwrap();
    let layers: Vec<(CloudLayer, Option<LayerDrift>)> = world
        .query::<(&CloudLayer, Option<&LayerDrift>)>()
        .iter(world)
        .map(|(l, d)| (l.clone(), d.copied()))
        .collect();
    let sun = bevy_cloudscape::render::march::CloudSun::pick([(&directional, &light, true)], false);
    let (march, march_layers, frame) = shadow_inputs(
        world.resource::<CloudWorld>(),
        &settings,
        &clouds,
        &camera,
        &light,
        sun.as_ref(),
        layers.iter().map(|(l, d)| (l, d.as_ref())),
    )
    .expect("daylight and a visible layer");
    cloud_shadow_map(
        textures,
        &march,
        &march_layers,
        &frame,
        settings.sanitized().steps,
    )
}

fn save_map(path: &std::path::Path, size: u32, maps: &[&[f64]]) {
    let mut image = image::RgbImage::new(size * maps.len() as u32, size);
    for (k, map) in maps.iter().enumerate() {
        for (index, t) in map.iter().enumerate() {
            let v = (t.clamp(0.0, 1.0) * 255.0).round() as u8;
            let (x, y) = (index as u32 % size, index as u32 / size);
            image.put_pixel(k as u32 * size + x, y, image::Rgb([v, v, v]));
        }
    }
    image.save(path).unwrap();
}

fn shadow_scene(sun_deg: (f32, f32)) -> Scene {
    Scene {
        name: "shadow",
        camera: looking(Vec3::new(0.0, 200.0, 0.0), 10.0, 0.0),
        sun_deg,
        layers: vec![layer(CloudKind::Cumulus, 0.5)],
        settings: settings(32),
    }
}

#[test]
fn shadow_map_matches_the_cpu_reference_and_clears_at_night() {
    let textures = CloudTextures::from_recipe(&small_recipe());
    let mut rig = CloudRig::new(UVec2::new(16, 16), Msaa::Off, small_recipe());
    rig.app.world().insert_resource(CloudShadows {
        enabled: true,
        resolution: 48,
        extent_m: 16_000.0,
        steps: 8,
        ..default()
    });
    rig.set_scene(&shadow_scene((30.0, 180.0)));
    rig.app.run_frames(4);
    let passes = rig.app.render_world().resource::<CloudShadowStats>().passes;
    assert!(passes > 0, "the shadow pass ran");
    let (size, gpu) = read_shadow_map(&mut rig);
    let cpu = reference_shadow_map(&mut rig, &textures);
    save_map(
        &output_dir().join("shadow_map_gpu_cpu.png"),
        size,
        &[&gpu, &cpu],
    );
    let errors: Vec<f64> = gpu.iter().zip(&cpu).map(|(g, c)| (g - c).abs()).collect();
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    let max = errors.iter().cloned().fold(0.0, f64::max);
    let (darkest, brightest) = cpu
        .iter()
        .fold((1.0f64, 0.0f64), |(lo, hi), &t| (lo.min(t), hi.max(t)));
    eprintln!(
        "shadow map {size}²: mean |GPU − CPU| {mean:.4}, max {max:.4}, CPU range {darkest:.3}–{brightest:.3}"
    );
    // The map must hold real shadows and real gaps, or the comparison proves nothing.
    assert!(darkest < 0.3 && brightest > 0.95, "{darkest} {brightest}");
    // 8-bit storage (±0.002) plus lavapipe's 8-bit filtering of the 3D noise.
    assert!(mean < 0.01, "mean error {mean}");
    assert!(max < 0.1, "max error {max}");

    // A still view marches a quarter of the rows each frame (`update_frames` 4 by default),
    // and every texel marched again holds what it held: the same map.
    let before = *rig.app.render_world().resource::<CloudShadowStats>();
    rig.app.run_frames(4);
    let after = *rig.app.render_world().resource::<CloudShadowStats>();
    assert_eq!(after.passes - before.passes, 4, "one pass a frame");
    assert_eq!(
        after.rows - before.rows,
        u64::from(size),
        "every row once in 4 frames"
    );
    let (_, amortized) = read_shadow_map(&mut rig);
    assert_eq!(amortized, gpu, "the map after 4 amortized passes");

    // Night: no pass, and the map is reset to 1 once.
    rig.set_scene(&shadow_scene((-10.0, 180.0)));
    rig.app.run_frames(3);
    let stats = *rig.app.render_world().resource::<CloudShadowStats>();
    rig.app.run_frames(2);
    let later = *rig.app.render_world().resource::<CloudShadowStats>();
    assert_eq!(later.passes, stats.passes, "no shadow pass at night");
    assert_eq!(later.clears, 1, "cleared once, not every frame");
    let (_, night) = read_shadow_map(&mut rig);
    assert!(night.iter().all(|&t| t == 1.0), "the night map is all 1");
}

/// A view of the shadowed ground, per pixel ([`ground_shadow_ratios`]).
struct GroundShadows {
    /// The ratio of the pixel's luminance with cloud shadows to without.
    ratios: Vec<f64>,
    /// The map's transmittance where the pixel's ray meets the ground, read bilinearly.
    bilinear: Vec<f64>,
    /// The same, from the nearest texel: what a map read without filtering would show.
    nearest: Vec<f64>,
}

/// The [`GroundShadows`] of a view of the ground (`y = 0`) from the rig's camera, from its
/// frames with and without cloud shadows (`with`, `without`) and the read-back `map`.
fn ground_shadow_ratios(
    rig: &mut CloudRig,
    size: UVec2,
    with: &[[f32; 3]],
    without: &[[f32; 3]],
    map_size: u32,
    map: &[f64],
) -> GroundShadows {
    let world = rig.app.world();
    let camera = world.get::<Camera>(rig.camera).unwrap();
    let camera_transform = *world.get::<GlobalTransform>(rig.camera).unwrap();
    let world_from_clip = camera_transform.to_matrix() * camera.clip_from_view().inverse();
    let light_from_world = world
        .get::<GlobalTransform>(rig.sun)
        .unwrap()
        .affine()
        .inverse();
    let origin = camera_transform.translation();
    let (mut ratios, mut bilinear, mut nearest) = (Vec::new(), Vec::new(), Vec::new());
    for y in 0..size.y {
        for x in 0..size.x {
            let uv = (Vec2::new(x as f32, y as f32) + 0.5) / size.as_vec2();
            let near = world_from_clip * Vec4::new(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 1.0, 1.0);
            let direction = (near.truncate() / near.w - origin).normalize();
            let point = origin + direction * (-origin.y / direction.y);
            let local = light_from_world.transform_point3(point);
            let map_uv = local.truncate() * Vec2::new(-0.5, 0.5) + 0.5;
            let index = (y * size.x + x) as usize;
            let off = luminance(&without[index]);
            assert!(off > 0.0, "the ground is lit");
            ratios.push(luminance(&with[index]) / off);
            bilinear.push(sample_map(map, map_size, map_uv));
            let texel = (map_uv * map_size as f32)
                .floor()
                .clamp(Vec2::ZERO, Vec2::splat(map_size as f32 - 1.0))
                .as_uvec2();
            nearest.push(map[(texel.y * map_size + texel.x) as usize]);
        }
    }
    GroundShadows {
        ratios,
        bilinear,
        nearest,
    }
}

/// Bilinear, clamped sample of a `size²` map at `uv` (texel centres at `(i + ½) / size`).
fn sample_map(map: &[f64], size: u32, uv: Vec2) -> f64 {
    let n = size as f32;
    let p = uv * n - 0.5;
    let base = p.floor();
    let w = p - base;
    let at = |x: f32, y: f32| {
        let xi = x.clamp(0.0, n - 1.0) as u32;
        let yi = y.clamp(0.0, n - 1.0) as u32;
        map[(yi * size + xi) as usize]
    };
    let (wx, wy) = (f64::from(w.x), f64::from(w.y));
    let top = at(base.x, base.y) * (1.0 - wx) + at(base.x + 1.0, base.y) * wx;
    let bottom = at(base.x, base.y + 1.0) * (1.0 - wx) + at(base.x + 1.0, base.y + 1.0) * wx;
    top * (1.0 - wy) + bottom * wy
}

/// A rig over a grey ground plane, with the cloud shadow map set to `shadows` and no ambient
/// light: the ground's radiance is then the direct sun alone, and the ratio of the frames with
/// and without shadows is the shadow map's transmittance.
fn shadowed_ground_rig(size: UVec2, shadows: CloudShadows) -> CloudRig {
    let mut rig = CloudRig::new(size, Msaa::Off, small_recipe());
    rig.app.world().insert_resource(shadows);
    rig.app.world().insert_resource(GlobalAmbientLight::NONE);
    let world = rig.app.world();
    let mesh = world
        .resource_mut::<Assets<Mesh>>()
        .add(Plane3d::default().mesh().size(20_000.0, 20_000.0));
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::srgb(0.5, 0.5, 0.5),
            perceptual_roughness: 1.0,
            reflectance: 0.0,
            ..default()
        });
    world.spawn((Mesh3d(mesh), MeshMaterial3d(material)));
    rig
}

/// The ground under a half-covered cumulus layer seen straight down from 900 m (below the layer:
/// the view rays meet the ground before any cloud) through a `fov_deg` lens, the sun 50° up:
/// its luminance with and without the cloud shadows, and the map as read back.
fn shadowed_ground(
    rig: &mut CloudRig,
    fov_deg: f32,
) -> (Vec<[f32; 3]>, Vec<[f32; 3]>, u32, Vec<f64>) {
    let scene = Scene {
        name: "shadow_ground",
        camera: Transform::from_xyz(0.0, 900.0, 0.0).looking_to(Vec3::NEG_Y, Vec3::NEG_Z),
        sun_deg: (50.0, 160.0),
        layers: vec![layer(CloudKind::Cumulus, 0.5)],
        settings: settings(32),
    };
    rig.app.world().resource_mut::<CloudShadows>().enabled = true;
    rig.set_scene(&scene);
    rig.app.world().entity_mut(rig.camera).insert((
        Projection::Perspective(PerspectiveProjection {
            fov: fov_deg.to_radians(),
            ..default()
        }),
        Exposure { ev100: 15.0 },
    ));
    let (with_shadows, _) = rig.render(4);
    let (map_size, map) = read_shadow_map(rig);
    assert!(
        rig.app
            .world()
            .get::<DirectionalLightTexture>(rig.sun)
            .is_some(),
        "the sun carries the map"
    );
    rig.app.world().resource_mut::<CloudShadows>().enabled = false;
    let (without, _) = rig.render(3);
    (with_shadows, without, map_size, map)
}

/// [`ground_shadow_ratios`] of a 48 × 48 [`shadowed_ground`] view through a `fov_deg` lens, under
/// a map of `resolution` texels over 8 km; also saved side by side as `name`.
fn ground_ratios_and_map(name: &str, resolution: u32, fov_deg: f32) -> GroundShadows {
    let size = UVec2::new(48, 48);
    let mut rig = shadowed_ground_rig(
        size,
        CloudShadows {
            enabled: true,
            resolution,
            extent_m: 8_000.0,
            steps: 8,
            ..default()
        },
    );
    let (with_shadows, without, map_size, map) = shadowed_ground(&mut rig, fov_deg);
    let ground = ground_shadow_ratios(&mut rig, size, &with_shadows, &without, map_size, &map);
    let grey = |image: &[f64]| -> Vec<[f32; 3]> { image.iter().map(|&v| [v as f32; 3]).collect() };
    save_strip(
        &output_dir().join(name),
        size,
        &[&grey(&ground.ratios), &grey(&ground.bilinear)],
    );
    ground
}

#[test]
fn cloud_shadows_darken_only_the_direct_sun_on_lit_ground() {
    let GroundShadows {
        ratios,
        bilinear: expected,
        ..
    } = ground_ratios_and_map("shadow_ground_ratio_vs_map.png", 64, 100.0);
    let n = ratios.len() as f64;
    let mean_error = ratios
        .iter()
        .zip(&expected)
        .map(|(r, e)| (r - e).abs())
        .sum::<f64>()
        / n;
    let (lo, hi) = ratios
        .iter()
        .fold((f64::MAX, 0.0f64), |(lo, hi), &r| (lo.min(r), hi.max(r)));
    eprintln!("ground/shadow: ratio range {lo:.3}–{hi:.3}, mean |ratio − map| {mean_error:.4}");
    // The view holds shadowed and sunlit ground, and the darkening follows the map texel for
    // texel (f16 target and 8-bit map: a few thousandths).
    assert!(lo < 0.5 && hi > 0.95, "{lo} {hi}");
    assert!(mean_error < 0.02, "mean error {mean_error}");
}

/// No texel steps in the ground's cloud shadows: with texels of 500 m (the coarsest map, 16
/// texels over 8 km) seen from 900 m through an 80° lens, a texel spans about 16 pixels, and the
/// darkening across the texels must be their bilinear blend, a ramp, not the nearest texel's
/// value, which steps by the whole difference between two texels at their boundary.
#[test]
fn ground_shadows_show_no_texel_steps() {
    let ground = ground_ratios_and_map("shadow_ground_texel_ramp_vs_bilinear.png", 16, 80.0);
    let w = 48;
    // The largest step between neighbouring pixels, across and down, of an image.
    let largest_step = |image: &[f64]| {
        (0..image.len())
            .flat_map(|i| {
                let right = (i % w + 1 < w).then(|| (image[i + 1] - image[i]).abs());
                let below = (i + w < image.len()).then(|| (image[i + w] - image[i]).abs());
                [right, below]
            })
            .flatten()
            .fold(0.0, f64::max)
    };
    let ground_step = largest_step(&ground.ratios);
    let blend_step = largest_step(&ground.bilinear);
    let texel_step = largest_step(&ground.nearest);
    let worst = ground
        .ratios
        .iter()
        .zip(&ground.bilinear)
        .map(|(r, e)| (r - e).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "ground under 500 m texels: largest step between neighbouring pixels {ground_step:.4} \
         on the ground, {blend_step:.4} in the bilinear blend, {texel_step:.4} from the nearest \
         texels; largest |ground − blend| {worst:.4}"
    );
    // Each pixel is the bilinear blend to within the f16 and 8-bit rounding of the map (0.02).
    let rounding = 0.02;
    assert!(worst < rounding, "largest |ground − bilinear| {worst}");
    // The view spans texels that differ by more than that rounding could hide, several times.
    assert!(
        texel_step > 4.0 * rounding,
        "the map is too flat under the view for a step to show: {texel_step}"
    );
    // A bilinear blend climbs a texel's difference over the texel's width on the ground, about
    // 16 pixels (more along the sun, whose 50° elevation stretches the texels 1.3 times), so
    // no step between two pixels exceeds a twelfth of the nearest texels' step; a quarter
    // leaves room for the rounding. Unfiltered, the ground would step by all of it.
    assert!(
        ground_step < 0.25 * texel_step,
        "a step of {ground_step} between two pixels, against the texels' {texel_step}"
    );
}

/// Light shafts: a pass at a quarter of the resolution marches the haze through the cloud
/// shadow map and the march reads its factors back. The GPU frame matches the CPU twin fed the
/// same (read-back) map at the same shaft resolution, and not the twin that shades the haze with
/// the clouds' mean transmittance, so the map really reaches the haze. The twin reading the map
/// at every haze sample of every pixel measures what the reduced resolution costs.
#[test]
fn light_shafts_follow_the_cloud_shadow_map() {
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    rig.app.world().insert_resource(CloudShadows {
        enabled: true,
        resolution: 128,
        extent_m: 30_000.0,
        steps: 8,
        ..default()
    });
    rig.app
        .world()
        .insert_resource(Haze::with_visibility(8_000.0));
    // Under broken cumulus, looking 30° left of a low sun.
    let scene = Scene {
        name: "shafts",
        camera: looking(Vec3::new(0.0, 100.0, 0.0), 8.0, 210.0),
        sun_deg: (12.0, 240.0),
        layers: vec![layer(CloudKind::Cumulus, 0.45)],
        settings: settings(48),
    };
    assert_eq!(scene.settings.light_shaft_resolution_scale, 0.25);
    rig.set_scene(&scene);
    let shaft_views = |rig: &mut CloudRig| {
        rig.app
            .render_world()
            .resource::<CloudPassStats>()
            .views_with_shafts
    };
    let before = shaft_views(&mut rig);
    let (gpu_l, _) = rig.render(4);
    assert!(shaft_views(&mut rig) > before, "the shaft pass ran");
    let image = gpu_shadow_image(&mut rig);
    let (darkest, brightest) = image
        .texels
        .iter()
        .fold((1.0f64, 0.0f64), |(lo, hi), t| (lo.min(t[0]), hi.max(t[0])));
    assert!(
        darkest < 0.3 && brightest > 0.95,
        "the map holds shadows and gaps"
    );
    let (shafts_l, _) = rig.reference_with_shadow(&textures, Some(&image));
    let (flat_l, _) = rig.reference(&textures);
    let with_map = relative_rmse(&gpu_l, &shafts_l);
    let without_map = relative_rmse(&gpu_l, &flat_l);
    // What the reduced resolution and the two factors cost. The truth reads the map at every
    // one of 128 haze samples of every pixel; the march before the shaft pass read it at its 16
    // samples per pixel. Measured on the haze alone (no clouds in front), in a 640 × 360 frame of
    // the same view: 160 × 90 shaft texels of 0.3° each.
    let (per_sample_l, _) = rig.reference_with_shafts(&textures, Some(&image), true);
    let small_cost = relative_rmse(&shafts_l, &per_sample_l);
    let full = UVec2::new(640, 360);
    let view = rig.rendered_view.clone().unwrap();
    let haze_with = |rig: &mut CloudRig, steps: u32, shafts: bool, per_sample: bool| {
        let mut changed = view.clone();
        changed.haze.steps = steps;
        changed.haze.shafts = shafts;
        rig.rendered_view = Some(changed);
        rig.haze_reference(full, &image, per_sample).0
    };
    let haze_truth = haze_with(&mut rig, 128, true, true);
    let haze_shafts = haze_with(&mut rig, view.haze.steps, true, false);
    let haze_per_sample = haze_with(&mut rig, view.haze.steps, true, true);
    let haze_flat = haze_with(&mut rig, 128, false, true);
    rig.rendered_view = Some(view);
    let shaft_cost = relative_rmse(&haze_shafts, &haze_truth);
    let per_sample_cost = relative_rmse(&haze_per_sample, &haze_truth);
    let shafts_effect = relative_rmse(&haze_truth, &haze_flat);
    save_strip(
        &output_dir().join("shadow_light_shafts_gpu_cpu_per_sample_flat.png"),
        size,
        &[&gpu_l, &shafts_l, &per_sample_l, &flat_l],
    );
    save_strip(
        &output_dir().join("shadow_light_shafts_haze_quarter_per_sample_truth.png"),
        full,
        &[&haze_shafts, &haze_per_sample, &haze_truth],
    );
    eprintln!(
        "light shafts: relative RMSE against the CPU with the map {with_map:.4}, with the mean \
         shade {without_map:.4}; quarter-resolution factors against the map read at every \
         sample {small_cost:.4} at 64x36. Haze alone at 640x360 against 128 samples read per \
         pixel: quarter-resolution factors {shaft_cost:.4}, {} samples read per pixel \
         {per_sample_cost:.4} (the shafts themselves: {shafts_effect:.4})",
        rig.rendered_view.as_ref().unwrap().haze.steps
    );
    assert!(with_map <= 0.03, "relative RMSE {with_map}");
    assert!(
        without_map > 2.0 * with_map,
        "the shafts change the picture: {without_map} vs {with_map}"
    );
    // The quarter-resolution pass keeps the shafts: it moves the haze by much less than the
    // shafts themselves do, and by no more than reading the map at the march's own samples did.
    assert!(
        shaft_cost < 0.2 * shafts_effect,
        "quarter resolution {shaft_cost} vs the shafts {shafts_effect}"
    );
    assert!(
        shaft_cost <= per_sample_cost,
        "quarter resolution {shaft_cost} vs per sample {per_sample_cost}"
    );
}

/// Far cloud samples take the sun's optical depth from the shadow map's levels instead of a
/// light march: the GPU frame matches the CPU twin reading the same map, differs from the
/// light-marched frame by more than that, and stays close to it (the levels' approximation).
#[test]
fn far_cloud_samples_take_the_sun_from_the_shadow_map() {
    let size = UVec2::new(64, 36);
    let (textures, mut rig) = small_rig(size);
    rig.app.world().insert_resource(CloudShadows {
        enabled: true,
        resolution: 256,
        extent_m: 40_000.0,
        steps: 48,
        ..default()
    });
    let scene = Scene {
        name: "sun_from_map",
        camera: looking(Vec3::new(0.0, 2.0, 0.0), 12.0, 0.0),
        sun_deg: (35.0, 200.0),
        layers: vec![layer(CloudKind::Cumulus, 0.5)],
        // Every sample the map covers reads the sun from it.
        settings: VolumetricClouds {
            sun_from_shadow_map_m: 0.0,
            ..settings(48)
        },
    };
    rig.set_scene(&scene);
    let (gpu_l, _) = rig.render(4);
    let image = gpu_shadow_image(&mut rig);
    let (map_l, _) = rig.reference_with_shadow(&textures, Some(&image));
    let mut marched = rig.rendered_view.clone().unwrap();
    marched.settings.sun_from_shadow_map_m = f64::INFINITY;
    rig.rendered_view = Some(marched);
    let (march_l, _) = rig.reference(&textures);
    save_strip(
        &output_dir().join("shadow_sun_from_map_gpu_cpu_marched.png"),
        size,
        &[&gpu_l, &map_l, &march_l],
    );
    let with_map = relative_rmse(&gpu_l, &map_l);
    let against_march = relative_rmse(&gpu_l, &march_l);
    let approximation = relative_rmse(&map_l, &march_l);
    // The cost of the approximation, against a converged light march (48 steps), for every
    // sample (this frame) and for the samples beyond MEDIUM's 5 km (the CPU twin, which the GPU
    // matches).
    let base_view = rig.rendered_view.clone().unwrap();
    let mut truth_view = base_view.clone();
    truth_view.settings.light_steps = 48;
    truth_view.settings.sun_from_shadow_map_m = f64::INFINITY;
    rig.rendered_view = Some(truth_view);
    let (truth_l, _) = rig.reference(&textures);
    let mut medium_view = base_view;
    medium_view.settings.sun_from_shadow_map_m = 5_000.0;
    rig.rendered_view = Some(medium_view);
    let (medium_l, _) = rig.reference_with_shadow(&textures, Some(&image));
    eprintln!(
        "against 48 light steps: the map from 0 m {:.4}, from 5 km {:.4}; the 5-step light march \
         {:.4}",
        relative_rmse(&map_l, &truth_l),
        relative_rmse(&medium_l, &truth_l),
        relative_rmse(&march_l, &truth_l)
    );
    let mean = |image: &[[f32; 3]]| image.iter().map(luminance).sum::<f64>() / image.len() as f64;
    eprintln!(
        "mean luminance: GPU {:.4}, CPU map {:.4}, CPU light march {:.4}",
        mean(&gpu_l),
        mean(&map_l),
        mean(&march_l)
    );
    eprintln!(
        "sun from the map: relative RMSE GPU vs CPU (map) {with_map:.4}, GPU vs CPU (light \
         march) {against_march:.4}; CPU map vs CPU light march {approximation:.4}"
    );
    assert!(with_map <= 0.03, "relative RMSE {with_map}");
    assert!(
        against_march > 1.5 * with_map,
        "the map is read: {against_march} vs {with_map}"
    );
    assert!(
        approximation < 0.25,
        "the levels approximate the light march: {approximation}"
    );
}
