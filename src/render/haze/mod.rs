//! Haze from the forecast's visibility, and light shafts through the gaps in the clouds.
//!
//! The march pass marches the haze along every view ray after the clouds (`haze.wgsl`, a shader
//! library imported by `march.wgsl`) and stacks it in front of and behind them, so distant
//! clouds and hills fade into the haze and the clouds hide the haze beyond. The model, its
//! sources and the integrator are documented in [`crate::reference::haze`], the f64 CPU twin.
//!
//! # Light shafts
//!
//! With [`VolumetricClouds::light_shafts`] on (every preset but `LOW`), the haze is lit
//! through the cloud shadow map ([`crate::render::shadow`]): air in a cloud's shadow scatters no
//! sunlight and air under a gap does, which draws crepuscular rays.
//!
//! The map is not read at full resolution. A shaft pass (the `shafts` entry of `march.wgsl`)
//! runs first at [`VolumetricClouds::light_shaft_resolution_scale`] (a quarter per axis by
//! default: a sixteenth of the rays). It marches the haze along each of its rays with the
//! march's step spacing but more samples (below), reads the map at each, and writes two
//! [`ShaftFactors`](crate::reference::haze::ShaftFactors): the mean sunlit fraction of the haze
//! below the lowest cloud base and above it, each weighted by how much that haze shows in the
//! pixel. The full-resolution march upsamples them with depth awareness
//! ([`crate::render::composite`]) and lights its haze samples with them.
//!
//! Below the cloud base nothing lies between the haze and a camera under the clouds, so there
//! the factor gives what reading the map at the shaft pass's samples would; above it the
//! clouds' distance splits the haze, and the factor spreads the sunlit fraction over both parts.
//! The pass runs on few pixels, so it takes [`SHAFT_STEPS_PER_HAZE_STEP`] (4) times the march's
//! haze samples, which keeps the noise of its jittered samples from showing as blocks.
//!
//! The GPU test `light_shafts_follow_the_cloud_shadow_map` checks the quarter-resolution
//! factors against the map read at 128 haze samples of every pixel.
//!
//! The map covers [`CloudShadows::extent_m`](crate::render::shadow::CloudShadows::extent_m)
//! around the camera. Beyond it, with the shafts off, or with no map (shadows disabled, night),
//! the haze uses one number, the clouds' mean transmittance toward the sun
//! ([`crate::reference::haze::mean_sun_transmittance`]), so overcast skies still dim it.
//!
//! # What it costs
//!
//! Nothing when [`Haze::visibility_m`] is infinite (the default) or 245 km or more: the march
//! skips it, and with no visible cloud layer either the pass does not run. Otherwise
//! [`VolumetricClouds::haze_steps`] samples per pixel, each one exponential, plus, with shafts,
//! the shaft pass: four times the samples with one filtered read of the shadow map each, on a
//! sixteenth of the pixels, and four texel reads per pixel to upsample them.

use bevy::{
    math::DVec3, prelude::*, render::render_resource::ShaderType, shader::load_shader_library,
};

use super::VolumetricClouds;
pub use crate::layers::Haze;
use crate::reference::{
    haze::{
        HazeSettings, MAX_HAZE_STEPS, SHAFT_STEPS_PER_HAZE_STEP, haze_extinction_for_visibility,
        mean_diffuse_transmittance, mean_sun_transmittance, sky_above_clouds,
    },
    render::{MarchLayer, MarchSettings},
    shadow::ShadowMapFrame,
};

/// Loads `haze.wgsl`, the shader library the march imports.
pub(crate) fn load_haze_shader(app: &mut App) {
    load_shader_library!(app, "haze.wgsl");
}

/// The haze settings of one view: [`Haze`] with the view's quality knobs, and the clouds' mean
/// transmittance toward the sun for haze without a shadow map. Bad values (NaN, negative)
/// give no haze rather than NaN.
pub(crate) fn haze_settings(
    haze: &Haze,
    clouds: &VolumetricClouds,
    march: &MarchSettings,
    layers: &[MarchLayer],
    ground_albedo: f64,
) -> HazeSettings {
    let finite_or = |v: f32, default: f64| {
        if v.is_finite() { f64::from(v) } else { default }
    };
    let defaults = HazeSettings::default();
    let mu_sun = DVec3::from_array(march.sun_direction).dot(DVec3::from_array(march.camera_up));
    // The haze lies low, in the Earth's shadow once the sun's disc has set. Under Bevy's
    // atmosphere (`clear_air`) the march's sun shines on through twilight for the clouds above
    // the shadow, so the haze takes the disc's visibility here; without one the march's sun
    // has it already.
    let set_sun = if march.clear_air {
        f64::from(crate::sky::sun_visibility(
            mu_sun.clamp(-1.0, 1.0).asin().to_degrees(),
        ))
    } else {
        1.0
    };
    let scale_height = finite_or(haze.scale_height_m, defaults.scale_height_m);
    HazeSettings {
        extinction_per_m: if scale_height > 0.0 {
            haze_extinction_for_visibility(f64::from(haze.visibility_m))
        } else {
            0.0
        },
        scale_height_m: scale_height,
        albedo: finite_or(haze.albedo, defaults.albedo).clamp(0.0, 1.0),
        asymmetry: finite_or(haze.asymmetry, defaults.asymmetry).clamp(-0.99, 0.99),
        steps: clouds.haze_steps.clamp(1, MAX_HAZE_STEPS),
        shafts: clouds.light_shafts,
        shaft_steps: clouds
            .haze_steps
            .saturating_mul(SHAFT_STEPS_PER_HAZE_STEP)
            .clamp(1, MAX_HAZE_STEPS),
        sun_transmittance: mean_sun_transmittance(layers, mu_sun) * set_sun,
        ambient_transmittance: mean_diffuse_transmittance(layers),
        sky_radiance: Some(sky_above_clouds(march, layers, ground_albedo)),
    }
}

#[doc(hidden)]
/// Where the cloud shadow map lies this frame, for the light shafts and the sun of far cloud
/// samples (render world): the map's frame relative to the camera it follows, and that camera's
/// position. Absent while no map holds shadows (disabled, night, no clouds).
#[derive(Resource, Clone, Debug)]
pub struct CloudShadowFrame {
    /// The shadow map image.
    pub image: AssetId<Image>,
    /// The map's frame, relative to `camera_m`.
    pub frame: ShadowMapFrame,
    /// World position of the camera the map follows, m.
    pub camera_m: DVec3,
}

impl CloudShadowFrame {
    /// The frame relative to a view camera at `camera_m`.
    pub fn relative_to(&self, camera_m: DVec3) -> ShadowMapFrame {
        let shift = self.camera_m - camera_m;
        ShadowMapFrame {
            centre_m: (DVec3::from_array(self.frame.centre_m) + shift).to_array(),
            ..self.frame
        }
    }
}

/// The haze uniform, laid out as `HazeUniforms` in `haze.wgsl` (64 bytes).
#[derive(ShaderType, Clone, Debug, Default)]
pub(crate) struct GpuHazeUniforms {
    extinction_per_m: f32,
    scale_height_m: f32,
    albedo: f32,
    asymmetry: f32,
    steps: u32,
    shafts: u32,
    sun_transmittance: f32,
    ambient_transmittance: f32,
    shaft_steps: u32,
    sky_radiance: Vec4,
}

impl GpuHazeUniforms {
    /// The uniform for `settings` under a clear sky of radiance `ambient_top`
    /// ([`HazeSettings::sky_radiance_or`]); `shafts_ran` says whether the shaft pass ran for
    /// this view (the march reads its factors when the settings ask for shafts).
    pub fn new(settings: &HazeSettings, ambient_top: [f64; 3], shafts_ran: bool) -> Self {
        let active = settings.is_active();
        let sky = settings.sky_radiance_or(ambient_top);
        Self {
            extinction_per_m: if active {
                settings.extinction_per_m as f32
            } else {
                0.0
            },
            scale_height_m: settings.scale_height_m as f32,
            albedo: settings.albedo as f32,
            asymmetry: settings.asymmetry as f32,
            steps: settings.steps,
            shafts: u32::from(settings.shafts && shafts_ran),
            sun_transmittance: settings.sun_transmittance as f32,
            ambient_transmittance: settings.ambient_transmittance as f32,
            shaft_steps: settings.shaft_steps,
            sky_radiance: Vec4::new(sky[0] as f32, sky[1] as f32, sky[2] as f32, 0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_layout_matches_the_shader() {
        assert_eq!(GpuHazeUniforms::min_size().get(), 64);
    }

    #[test]
    fn bad_haze_values_give_no_haze_or_defaults() {
        let clouds = VolumetricClouds::default();
        let march = MarchSettings::default();
        for visibility in [f32::NAN, -1.0, 0.0, f32::INFINITY, 1.0e6] {
            let settings = haze_settings(
                &Haze::with_visibility(visibility),
                &clouds,
                &march,
                &[],
                0.2,
            );
            assert!(!settings.is_active(), "{visibility}");
        }
        let wild = Haze {
            visibility_m: 10_000.0,
            scale_height_m: f32::NAN,
            albedo: 7.0,
            asymmetry: f32::NEG_INFINITY,
            weather_driven: true,
        };
        let settings = haze_settings(&wild, &clouds, &march, &[], 0.2);
        assert!(settings.is_active());
        assert_eq!(settings.scale_height_m, 1200.0);
        assert_eq!(settings.albedo, 1.0);
        assert_eq!(settings.asymmetry, 0.7);
        let flat = Haze {
            scale_height_m: 0.0,
            ..wild
        };
        assert!(!haze_settings(&flat, &clouds, &march, &[], 0.2).is_active());
    }

    #[test]
    fn shafts_need_a_map_and_the_setting() {
        let frame = ShadowMapFrame {
            centre_m: [1.0, 2.0, 3.0],
            axis_x_m: [2.0e4, 0.0, 0.0],
            axis_y_m: [0.0, 0.0, 2.0e4],
            size: 256,
            cloud_range_m: [1000.0, 3000.0],
        };
        let on = HazeSettings {
            extinction_per_m: 1e-4,
            ..HazeSettings::default()
        };
        assert_eq!(GpuHazeUniforms::new(&on, [1.0; 3], true).shafts, 1);
        assert_eq!(GpuHazeUniforms::new(&on, [1.0; 3], false).shafts, 0);
        let off = HazeSettings {
            shafts: false,
            ..on
        };
        assert_eq!(GpuHazeUniforms::new(&off, [1.0; 3], true).shafts, 0);
        // A map that follows another camera is shifted into this view's frame.
        let shared = CloudShadowFrame {
            image: AssetId::default(),
            frame,
            camera_m: DVec3::new(100.0, 0.0, 0.0),
        };
        assert_eq!(
            shared.relative_to(DVec3::new(0.0, 10.0, 0.0)).centre_m,
            [101.0, -8.0, 3.0]
        );
    }
}
