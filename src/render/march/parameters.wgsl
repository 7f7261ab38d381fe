#define_import_path bevy_cloudscape::cloud_parameters

// The parameters of the cloud march: the per-view uniforms and the cloud layers, and their
// bindings. A shader library of the cloud march (see `clouds.wgsl`), imported by the others.
//
// CPU twin: `src/reference/render/parameters.rs` (`MarchSettings` and `MarchLayer`, the f64
// source of these values). Rust side: `GpuCloudUniforms` and `GpuCloudLayer` in
// `src/render/view.rs`, which write them.

// Per-view uniforms, written by `GpuCloudUniforms` (render/view.rs) from `MarchSettings`
// (reference/render/parameters.rs, the f64 source of the same values). Every scalar group fills
// 16 bytes before the first vec4, so the layout is the same under WGSL's uniform rules and
// encase; `render::contract` checks size and field order.
struct CloudUniforms {
    // Radius of the ground sphere, m.
    planet_radius_m: f32,
    // Camera altitude above the ground sphere, m (computed on the CPU in f64).
    camera_altitude_m: f32,
    // Angle a pixel subtends, rad: a sample at distance t stands for t * pixel_angle_rad metres.
    pixel_angle_rad: f32,
    // A primary step at distance t is (1 + step_growth * t) times one at the camera; 1/m.
    step_growth: f32,
    // Primary steps across each interval of layers the ray crosses.
    primary_steps: u32,
    // Light-march steps toward the sun (0: no self-shadowing).
    light_steps: u32,
    // 1: the delta-Eddington multiple scattering; 0: single scattering and a height-graded sky.
    multiple_scattering: u32,
    // Number of layers in `cloud_layers` (inactive ones may be left out by the CPU or not).
    layer_count: u32,
    // The march stops once the view transmittance is at or below this.
    transmittance_cutoff: f32,
    // The phase's forward-peak fraction f, its asymmetry without the peak g* and its value at
    // FORWARD_PEAK_DEG from the forward direction, 1/sr (Rust: `EddingtonPhase`).
    forward_fraction: f32,
    scaled_asymmetry: f32,
    forward_cap: f32,
    // Dual-lobe Henyey-Greenstein: forward and backward asymmetry, weight of the back lobe.
    phase_g_forward: f32,
    phase_g_back: f32,
    phase_blend: f32,
    // Blue-noise jitter of the ray start: 0 off (step midpoints), 1 on.
    jitter: u32,
    // Frame counter that animates the jitter.
    frame_index: u32,
    // From this distance on, m, cloud samples read the sun's optical depth from the shadow map
    // where it covers them (Rust: `MarchSettings::sun_from_shadow_map_m`; FAR_AWAY: never).
    sun_from_shadow_map_m: f32,
    // 1 when `cloud_shadow_map` and the shadow_map_* fields hold a map, 0 otherwise.
    shadow_map: u32,
    // Shortest primary step, m (Rust: `MarchSettings::min_step_m`; 0: always primary_steps).
    min_step_m: f32,
    // Temporal upsampling: where this frame's reduced-resolution rays pass through their
    // texels, in uv from the texels' centres (Rust: `reference::composite::sample_offset`
    // over the march's size). 0 at full resolution and without the accumulation.
    sample_offset_uv: vec2<f32>,
    // The view's uv per march uv: the march's image covers the view and, with the temporal
    // upsampling, the pixels past its edge up to a whole texel (Rust:
    // `TemporalUpsampling::uv_scale`); 1 otherwise.
    march_uv_scale: vec2<f32>,
    // Most extra light steps per view-sample footprint (Rust:
    // `MarchSettings::light_steps_per_footprint`; 0: no limit).
    light_steps_per_footprint: f32,
    // Share of light_steps a view ray 60 degrees or more from the sun takes (Rust:
    // `MarchSettings::light_steps_away_from_sun`; `ray_light_steps`).
    light_steps_away_from_sun: f32,
    // 1: the clouds fade into what lies behind them by the clear air's transmittance to them
    // (Rust: `MarchSettings::clear_air`).
    clear_air: u32,
    // Most optical depth one light-march step spans at the layers' peak extinction (Rust:
    // `MarchSettings::light_step_optical_depth`; 0: no limit).
    light_step_optical_depth: f32,
    // xyz: unit vector from the planet centre through the camera.
    camera_up: vec4<f32>,
    // xyz: unit vector toward the sun, world space.
    sun_direction: vec4<f32>,
    // rgb: sun illuminance at the clouds, lux, already attenuated by the atmosphere.
    sun_illuminance: vec4<f32>,
    // rgb: ambient sky radiance at the top and at the bottom of a layer, cd/m^2.
    ambient_top: vec4<f32>,
    ambient_bottom: vec4<f32>,
    // The shadow map's centre relative to the camera, m, and its half-extent axes divided by
    // their squared length, 1/m (Rust: `ShadowMapImage::uv`).
    shadow_map_centre_m: vec4<f32>,
    shadow_map_axis_x: vec4<f32>,
    shadow_map_axis_y: vec4<f32>,
    // xy: (bottom, top) of the layers the map holds, m (Rust: `ShadowMapFrame::cloud_range_m`);
    // z: the side of a texel, m (`ShadowMapFrame::texel_m`).
    shadow_map_range_m: vec4<f32>,
    // xyz: a lightning flash's position relative to the camera, m; w: its luminous intensity, cd
    // (0: no flash). Rust: `MarchSettings::flash_position_m`, `flash_intensity_cd`.
    flash: vec4<f32>,
    // xy: the phase's value at FORWARD_PEAK_DEG after one and two more scatterings in the
    // forward lobe, 1/sr; w: the cosine of FORWARD_PEAK_DEG (Rust: `EddingtonPhase::peak_caps`,
    // `FORWARD_PEAK_DEG`).
    peak_caps: vec4<f32>,
    // Tangents of the angles the forward peak turns its light by, one per quarter of the peak's
    // light (Rust: `EddingtonPhase::peak_spread`).
    peak_spread: vec4<f32>,
}

// One cloud layer of the storage buffer, written by `GpuCloudLayer` (render/view.rs) from
// `MarchLayer` (reference/render/parameters.rs); `render::contract` checks size and field order.
//
// Offsets are wrapped by their own period on the CPU in f64 (`MarchLayer::set_noise_origin`), so
// they stay below one period. Horizontal coordinates are along `horizontal_axes(up)`.
struct CloudLayerGpu {
    base_m: f32,
    top_m: f32,
    coverage: f32,
    extinction: f32,
    weather_scale_m: f32,
    shape_scale_m: f32,
    detail_scale_m: f32,
    detail_erosion: f32,
    shape_strength: f32,
    precipitation: f32,
    profile_count: u32,
    far_count: u32,
    // Rust: `MarchLayer::coverage_height`.
    coverage_height: f32,
    // Rust: `MarchLayer::halo_share`.
    halo_share: f32,
    // Rust: `MarchLayer::warp_offset_m`.
    warp_offset_m: vec2<f32>,
    weather_offset_m: vec4<f32>,
    noise_offset_m: vec4<f32>,
    profile: array<vec4<f32>, 4>,
    // Coverage toward far places: dot(horizontal, xy) + z is the fraction of the way from the
    // near place to the far one, w the far coverage (Rust: `MarchLayer::far`).
    far: array<vec4<f32>, 2>,
    // The layer's slice of the weather map (Rust: `reference::weather_map`): xy the weather
    // texel at map texel (0, 0), z the array slice, w the side in texels (< 2: no map).
    weather_map: vec4<f32>,
    // The growth automaton's clouds (Rust: `MarchLayer::growth`): x 1 when the layer grows, y its
    // slice of `growth_cover`, zw the grid's columns along x and y.
    growth: vec4<f32>,
    // Factors on clouds.ambient_top and ambient_bottom for this layer (xyz), 1 under an open
    // sky (Rust: `MarchLayer::sky_light_top`, `sky_light_bottom`).
    sky_light_top: vec4<f32>,
    sky_light_bottom: vec4<f32>,
}

@group(0) @binding(2) var<uniform> clouds: CloudUniforms;
@group(0) @binding(3) var<storage, read> cloud_layers: array<CloudLayerGpu>;

// Rust: the constants of the same names in reference/render/parameters.rs; see their docs there.
const MAX_PROFILE_POINTS: u32 = 8u;
const MAX_FAR_COVERAGES: u32 = 2u;
