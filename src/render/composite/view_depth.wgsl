#define_import_path bevy_cloudscape::view_depth

// The two bindings every fullscreen pass of the clouds opens with (`march.wgsl`, `upsample.wgsl`,
// `temporal.wgsl`): the view at binding 0 and its depth prepass at binding 1, multisampled under
// the MULTISAMPLED def. Rust side: `depth_binding` and `depth_shader_defs` in
// `src/render/composite/mod.rs`, which every layout of those passes uses.

#import bevy_render::view::View

@group(0) @binding(0) var<uniform> view: View;
#ifdef MULTISAMPLED
@group(0) @binding(1) var depth_prepass: texture_depth_multisampled_2d;
#else
@group(0) @binding(1) var depth_prepass: texture_depth_2d;
#endif
