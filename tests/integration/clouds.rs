//! The march pass in headless renders.

use bevy::{
    camera::RenderTarget, core_pipeline::tonemapping::Tonemapping, prelude::*,
    render::render_resource::TextureFormat,
};
use bevy_cloudscape::prelude::*;

use crate::common;
use crate::harness::{Headless, output_dir};

fn cumulus(coverage: f32) -> CloudLayer {
    CloudLayer {
        coverage,
        weather_driven: false,
        ..CloudLayer::new(CloudKind::Cumulus)
    }
}

#[test]
fn cumulus_layer_renders() {
    let size = UVec2::new(192, 108);
    let mut app = Headless::new(size, TextureFormat::Rgba16Float, |app| {
        app.add_plugins(CloudscapePlugin)
            .insert_resource(SceneClock::at("2021-05-03T12:00:00Z".parse().unwrap()))
            .add_systems(Startup, common::spawn_sky_scene);
    });
    let target = app.target.clone();
    app.world()
        .spawn((
            common::sky_scene_camera(),
            RenderTarget::Image(target.into()),
        ))
        .insert((
            Tonemapping::None,
            VolumetricClouds {
                jitter: false,
                ..VolumetricClouds::MEDIUM
            },
            Msaa::Off,
        ));
    app.world().spawn(cumulus(0.5));
    app.run_frames(8);
    let stats = *app
        .render_world()
        .resource::<bevy_cloudscape::render::march::CloudPassStats>();
    eprintln!("stats {stats:?}");
    let has_noise = app
        .render_world()
        .get_resource::<bevy_cloudscape::render::noise::CloudNoiseTextures>()
        .is_some();
    eprintln!("noise {has_noise}");
    let mut q = app
        .render_world()
        .query::<&bevy_cloudscape::render::march::ExtractedCloudView>();
    for v in q.iter(app.render_world()) {
        eprintln!(
            "view {:?} layers {}",
            v.settings.sun_illuminance,
            v.layers.len()
        );
    }
    {
        use bevy::core_pipeline::prepass::ViewPrepassTextures;
        use bevy::render::view::ViewTarget;
        let mut q = app.render_world().query_filtered::<(
            Option<&ViewTarget>,
            Option<&ViewPrepassTextures>,
            Option<&Msaa>,
        ), With<bevy_cloudscape::render::march::ExtractedCloudView>>(
        );
        for (a, b, c) in q.iter(app.render_world()) {
            eprintln!(
                "target {} prepass {} msaa {}",
                a.is_some(),
                b.map(|p| p.depth.is_some()).unwrap_or(false),
                c.is_some()
            );
        }
    }
    {
        let mut q = app
            .render_world()
            .query::<&bevy_cloudscape::render::march::CloudMarchPipelineId>();
        let ids: Vec<_> = q.iter(app.render_world()).map(|i| i.0).collect();
        let cache = app
            .render_world()
            .resource::<bevy::render::render_resource::PipelineCache>();
        for id in ids {
            eprintln!("pipeline state {:?}", cache.get_render_pipeline_state(id));
        }
    }
    let pixels = app.read_target();
    pixels.save_png(output_dir().join("cumulus.png"), 1.0);
    assert!(pixels.rgba.iter().all(|p| p.iter().all(|c| c.is_finite())));
}
