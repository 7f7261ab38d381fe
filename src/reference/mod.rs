//! CPU reference models, in f64: the truth the GPU passes are tested against.
//!
//! Every function here has a WGSL twin with the same name (and a comment pointing back), so a
//! GPU readback can be compared value for value. The module is plain Rust — no Bevy render
//! types — so it also serves CPU queries at run time.
//!
//! - [`noise`]: tileable Perlin, Worley, Perlin-Worley and curl noise, the channel recipes of
//!   the base, detail and weather textures, and the mip box filter. GPU twin:
//!   `src/render/noise/noise.wgsl`.
//! - [`render`]: the cloud ray-march — shell geometry on a curved planet, the density model,
//!   the light march and the energy-conserving integrator — for one ray at a time, sampling the
//!   same texel data as the GPU; also the CPU queries [`render::density_at`] and
//!   [`render::transmittance_to_sun`]. One file per concern (parameters, textures, geometry,
//!   density, light, the march), each the twin of one shader library in `src/render/march/`.
//! - [`shadow`]: the cloud shadow map — the transmittance of every layer along the sun line
//!   through a ground point, and the texel layout of the map. GPU twin:
//!   `src/render/march/shadow.wgsl` (whose `shadow_column` the pass
//!   `src/render/shadow/shadow.wgsl` runs); and how the march reads the map back
//!   (`ShadowMapImage`).
//! - [`blue_noise`]: the tileable blue-noise map of the ray-start jitter. GPU twin:
//!   `blue_noise_jitter` in `src/render/march/light.wgsl`, reading the same values from a texture.
//! - [`haze`]: haze from the visibility, marched along the view ray with light shafts from the
//!   shadow map, and stacked with the clouds. GPU twin: `src/render/haze/haze.wgsl`.
//! - [`composite`]: the depth-aware upsample of images rendered at a reduced resolution (the
//!   march, the light-shaft factors). GPU twin: `src/render/composite/composite.wgsl`.
//! - [`weather_map`]: each layer's local coverage per weather texel around the camera, which the
//!   GPU caches once per frame for the march. GPU twin: `src/render/weather_map/weather_map.wgsl`.

pub mod blue_noise;
pub mod composite;
pub mod growth;
pub mod haze;
pub mod noise;
pub mod render;
pub mod shadow;
#[cfg(test)]
pub(crate) mod table;
pub mod truth;
pub mod weather_map;
