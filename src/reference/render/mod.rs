//! The cloud ray-march in f64: the CPU twin of the cloud shader libraries in
//! `src/render/march/`.
//!
//! Every public function here has a WGSL function of the same name in the shaders, and each points
//! at the other. The GPU march is tested against this module, so a change to a formula must be
//! made in both places. It is also the engine of the CPU queries a game asks ("is the camera in a
//! cloud?"): [`density_at`], [`transmittance_to_sun`] and [`is_in_cloud`].
//!
//! One file per concern, each the twin of one WGSL library in `src/render/march/` (and each
//! naming the other); their module docs explain the model, with its sources:
//!
//! - `parameters.rs`: [`MarchSettings`] and [`MarchLayer`], the f64 source of the shaders'
//!   uniforms. WGSL twin: `parameters.wgsl` (`CloudUniforms`, `CloudLayerGpu`).
//! - `textures.rs`: [`CloudTextures`], the texels the GPU samples, and how it samples them. WGSL
//!   twin: `textures.wgsl`.
//! - `geometry.rs`: shell geometry on a curved planet, and the small vector helpers. WGSL twin:
//!   `geometry.wgsl`.
//! - `density.rs`: the density model. WGSL twin: `density.wgsl`.
//! - `light.rs`: the light march toward the sun, the phase and multiple scattering. WGSL twin:
//!   `light.wgsl`.
//! - `march.rs`: the march of one view ray ([`march_clouds`]). WGSL twin: `clouds.wgsl`, the
//!   library the entry shader `march.wgsl` calls.
//! - `queries.rs`: the CPU queries and the closed form of a homogeneous slab; CPU only.
//!
//! The cloud shadow map is the pair [`super::shadow`] and `src/render/march/shadow.wgsl`.

mod density;
mod geometry;
mod light;
mod march;
mod parameters;
mod queries;
mod textures;

#[cfg(test)]
mod tests;

pub use self::{
    density::*, geometry::*, light::*, march::*, parameters::*, queries::*, textures::*,
};
