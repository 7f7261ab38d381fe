//! Compositing the clouds over the scene, and reading images rendered at a reduced resolution
//! back at full resolution.
//!
//! The march's output `(L, T)` (in-scattered radiance and view transmittance) is blended onto
//! the view's HDR main texture as `scene · T + L` (a fixed blend state), before tonemapping.
//!
//! Two images may be rendered at a reduced resolution, each with the distance its rays were
//! stopped at:
//!
//! - the march itself, at [`VolumetricClouds::resolution_scale`] below 1
//!   ([`CloudLowResTargets`]); the upsample pass (`upsample.wgsl`) composites it;
//! - the light-shaft factors, at [`VolumetricClouds::light_shaft_resolution_scale`]
//!   ([`CloudShaftTarget`], see [`crate::render::haze`]); the march reads them.
//!
//! Both are read with the same depth-aware weights (the shader library `composite.wgsl`), so
//! values from rays that stopped at other geometry (the sky beside a hill) do not bleed over the
//! edges of near geometry. The weights and their CPU twin are documented in
//! [`crate::reference::composite`].
//!
//! [`VolumetricClouds::resolution_scale`]: super::VolumetricClouds::resolution_scale
//! [`VolumetricClouds::light_shaft_resolution_scale`]: super::VolumetricClouds::light_shaft_resolution_scale

use std::borrow::Cow;

use bevy::{
    asset::{embedded_asset, load_embedded_asset},
    core_pipeline::FullscreenShader,
    prelude::*,
    render::{
        render_resource::{
            binding_types::{
                texture_2d, texture_depth_2d, texture_depth_2d_multisampled, uniform_buffer,
            },
            *,
        },
        renderer::RenderDevice,
        texture::{CachedTexture, TextureCache},
        view::{ViewTarget, ViewUniform},
    },
    shader::load_shader_library,
};

use super::march::{CloudMarchPipelineKey, ExtractedCloudView};

/// Loads `composite.wgsl` (the shader library of the upsample weights) and `upsample.wgsl`.
pub(crate) fn load_composite_shaders(app: &mut App) {
    load_shader_library!(app, "composite.wgsl");
    embedded_asset!(app, "upsample.wgsl");
}

/// Format of the reduced-resolution `(L, T)` target.
pub const LOW_RES_COLOUR_FORMAT: TextureFormat = TextureFormat::Rgba16Float;
/// Format of the reduced-resolution target of ray-end distances (metres).
pub const LOW_RES_DISTANCE_FORMAT: TextureFormat = TextureFormat::R32Float;
/// Format of the light-shaft factors: the factor below the lowest cloud base, the factor above
/// it, and the distance the ray was stopped at (metres, so 32-bit).
pub const SHAFT_FORMAT: TextureFormat = TextureFormat::Rgba32Float;

/// The depth prepass binding, multisampled or not.
pub(crate) fn depth_binding(multisampled: bool) -> BindGroupLayoutEntryBuilder {
    if multisampled {
        texture_depth_2d_multisampled()
    } else {
        texture_depth_2d()
    }
}

/// `scene · T + L`: the fragment returns `(L, T)`.
pub(crate) const COMPOSITE_BLEND: BlendState = BlendState {
    color: BlendComponent {
        src_factor: BlendFactor::One,
        dst_factor: BlendFactor::SrcAlpha,
        operation: BlendOperation::Add,
    },
    alpha: BlendComponent {
        src_factor: BlendFactor::Zero,
        dst_factor: BlendFactor::One,
        operation: BlendOperation::Add,
    },
};

fn upsample_layout(label: &'static str, multisampled: bool) -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new(
        label,
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                uniform_buffer::<ViewUniform>(true),
                depth_binding(multisampled),
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_2d(TextureSampleType::Float { filterable: false }),
            ),
        ),
    )
}

/// Creates [`CloudUpsamplePipeline`] (render world, at start-up).
pub(crate) fn init_cloud_upsample_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    fullscreen: Res<FullscreenShader>,
) {
    commands.insert_resource(CloudUpsamplePipeline {
        layout: upsample_layout("cloud_upsample_layout", false),
        layout_multisampled: upsample_layout("cloud_upsample_layout_multisampled", true),
        fullscreen: fullscreen.clone(),
        shader: load_embedded_asset!(asset_server.as_ref(), "upsample.wgsl"),
    });
}

/// Layouts and shader of the depth-aware upsample that composites a reduced-resolution march.
#[derive(Resource)]
pub struct CloudUpsamplePipeline {
    pub(crate) layout: BindGroupLayoutDescriptor,
    pub(crate) layout_multisampled: BindGroupLayoutDescriptor,
    fullscreen: FullscreenShader,
    shader: Handle<Shader>,
}

impl SpecializedRenderPipeline for CloudUpsamplePipeline {
    /// The view's main-texture format and sample count (`low_res` unused).
    type Key = CloudMarchPipelineKey;

    fn specialize(&self, key: Self::Key) -> RenderPipelineDescriptor {
        let multisampled = key.samples > 1;
        let shader_defs = if multisampled {
            vec!["MULTISAMPLED".into()]
        } else {
            Vec::new()
        };
        RenderPipelineDescriptor {
            label: Some(Cow::Borrowed("cloud_upsample_pipeline")),
            layout: vec![if multisampled {
                self.layout_multisampled.clone()
            } else {
                self.layout.clone()
            }],
            vertex: self.fullscreen.to_vertex_state(),
            fragment: Some(FragmentState {
                shader: self.shader.clone(),
                shader_defs,
                entry_point: Some(Cow::Borrowed("fragment")),
                targets: vec![Some(ColorTargetState {
                    format: key.format,
                    blend: Some(COMPOSITE_BLEND),
                    write_mask: ColorWrites::ALL,
                })],
            }),
            multisample: MultisampleState {
                count: key.samples,
                ..default()
            },
            ..default()
        }
    }
}

/// The reduced-resolution targets of a view that marches below full resolution.
#[derive(Component)]
pub struct CloudLowResTargets {
    /// `(L, T)`, [`LOW_RES_COLOUR_FORMAT`].
    pub colour: CachedTexture,
    /// Where each ray was stopped, metres ([`LOW_RES_DISTANCE_FORMAT`]).
    pub distance: CachedTexture,
}

/// The light-shaft factors of a view with light shafts ([`SHAFT_FORMAT`]), at
/// [`VolumetricClouds::light_shaft_resolution_scale`](super::VolumetricClouds::light_shaft_resolution_scale).
#[derive(Component)]
pub struct CloudShaftTarget {
    /// Per texel: the factor below the lowest cloud base, the factor above it, the distance the
    /// ray was stopped at (metres), 0.
    pub factors: CachedTexture,
}

/// Size of a reduced-resolution image for a view of `size` pixels at `scale`: each side
/// rounded up, at least 1.
pub fn low_res_size(size: UVec2, scale: f32) -> UVec2 {
    (size.as_vec2() * scale).ceil().as_uvec2().max(UVec2::ONE)
}

/// Creates or drops each view's reduced-resolution targets (render world, every frame).
pub(crate) fn prepare_low_res_targets(
    mut commands: Commands,
    mut cache: ResMut<TextureCache>,
    device: Res<RenderDevice>,
    views: Query<(Entity, &ViewTarget, &ExtractedCloudView)>,
) {
    for (entity, target, view) in &views {
        let full = target.main_texture().size();
        let full = UVec2::new(full.width, full.height);
        let mut texture = |label: &'static str, format: TextureFormat, size: UVec2| {
            cache.get(
                &device,
                TextureDescriptor {
                    label: Some(label),
                    size: Extent3d {
                        width: size.x,
                        height: size.y,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: TextureDimension::D2,
                    format,
                    usage: TextureUsages::RENDER_ATTACHMENT | TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                },
            )
        };
        let mut entity_commands = commands.entity(entity);
        if view.resolution_scale < 1.0 {
            let size = low_res_size(full, view.resolution_scale);
            let colour = texture("cloud_low_res_colour", LOW_RES_COLOUR_FORMAT, size);
            let distance = texture("cloud_low_res_distance", LOW_RES_DISTANCE_FORMAT, size);
            entity_commands.insert(CloudLowResTargets { colour, distance });
        } else {
            entity_commands.remove::<CloudLowResTargets>();
        }
        match view.shaft_resolution_scale {
            Some(scale) => {
                let factors = texture(
                    "cloud_shaft_factors",
                    SHAFT_FORMAT,
                    low_res_size(full, scale),
                );
                entity_commands.insert(CloudShaftTarget { factors });
            }
            None => {
                entity_commands.remove::<CloudShaftTarget>();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reduced_sizes_round_up_and_never_vanish() {
        assert_eq!(
            low_res_size(UVec2::new(1280, 720), 0.5),
            UVec2::new(640, 360)
        );
        assert_eq!(
            low_res_size(UVec2::new(1281, 721), 0.25),
            UVec2::new(321, 181)
        );
        assert_eq!(low_res_size(UVec2::new(1, 1), 0.25), UVec2::ONE);
        assert_eq!(low_res_size(UVec2::new(0, 3), 0.5), UVec2::new(1, 2));
    }
}
