//! The sky light on the scene under the clouds: every camera with [`VolumetricClouds`] scales its
//! Bevy environment and ambient light (`AtmosphereEnvironmentMapLight`, `EnvironmentMapLight`,
//! `AmbientLight`) by how much diffuse light the clouds above it let through, so a scene under
//! overcast darkens as a real one does, and not only by losing its direct sun (which the cloud
//! shadow map dims).
//!
//! The factor is the diffuse irradiance on a horizontal surface under the layers above the
//! camera over the clear sky's, `((1 − c) π L + c E_d(τ)) / π L`: `L` the clear sky's radiance
//! ([`MarchSettings::ambient_top`], luminance), `c` the fraction of the sky the layers cover
//! (`1 − Π (1 − coverageᵢ)`), `τ` the mean vertical optical depth of the cloudy part (each layer's
//! extinction times its mean profile density over the part above the camera, weighted by its
//! coverage) and `E_d` the δ-Eddington diffuse irradiance under a deck of that depth
//! ([`deck_irradiance`], validated against DISORT), raised by the light the ground reflects and
//! the deck sends back ([`sky_light_factor`]). Under a thin veil the factor exceeds 1: the
//! sun's light scattered in the cloud outshines the clear sky's.

use bevy::{
    light::{AmbientLight, Atmosphere, AtmosphereEnvironmentMapLight, EnvironmentMapLight},
    prelude::*,
};

use crate::{
    reference::render::{
        MarchLayer, MarchSettings, deck_irradiance, eddington_phase, layer_is_active,
        profile_density,
    },
    render::{
        VolumetricClouds,
        view::{CloudSun, GROUND_ALBEDO, LayerInputData, march_inputs},
    },
    sky::Sun,
    world::CloudWorld,
};

/// How a camera's sky light follows the clouds above it (see the [module docs](self)); every
/// camera with [`VolumetricClouds`] has one.
///
/// The light components' values the game sets are the clear sky's: the crate writes them
/// scaled, and takes a value it did not write as the game's new clear-sky value.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default)]
pub struct CloudSkyLight {
    /// Scale the camera's environment and ambient light by the clouds above it. Default true;
    /// turned off, the clear-sky values are put back.
    pub enabled: bool,
    /// The scale applied this frame (1 without clouds above; read-only, the crate sets it).
    #[reflect(ignore)]
    factor: f32,
    /// Per light component (atmosphere environment, environment map, ambient): the clear-sky
    /// value and the value the crate last wrote.
    #[reflect(ignore)]
    scaled: [Option<Scaled>; 3],
}

impl Default for CloudSkyLight {
    fn default() -> Self {
        Self {
            enabled: true,
            factor: 1.0,
            scaled: [None; 3],
        }
    }
}

impl CloudSkyLight {
    /// The scale applied to the camera's sky light this frame, dimensionless (1 under a clear
    /// sky, less under thick cloud, more under a thin sunlit veil).
    pub fn factor(&self) -> f32 {
        self.factor
    }
}

/// A light value the crate scales: the game's clear-sky value and what the crate wrote.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Scaled {
    clear: f32,
    written: f32,
}

/// The value to write in place of `value` (`None`: leave it): `clear × factor` (`None`:
/// the clear value, put back), where `value` holds what the crate wrote last time (otherwise the
/// game set it: its new clear value). A value that is not finite is left alone.
fn scaled_value(value: f32, slot: &mut Option<Scaled>, factor: Option<f32>) -> Option<f32> {
    if !value.is_finite() {
        *slot = None;
        return None;
    }
    let clear = match *slot {
        Some(scaled) if scaled.written == value => scaled.clear,
        _ => value,
    };
    let Some(factor) = factor else {
        *slot = None;
        return (clear != value).then_some(clear);
    };
    let written = clear * factor;
    *slot = Some(Scaled { clear, written });
    (written != value).then_some(written)
}

/// Applies [`scaled_value`] to the field `field` of a light component, marking it changed only
/// when its value changes.
fn update<T: Component>(
    light: Option<Mut<T>>,
    field: impl Fn(&mut T) -> &mut f32,
    slot: &mut Option<Scaled>,
    factor: Option<f32>,
) {
    let Some(mut light) = light else {
        *slot = None;
        return;
    };
    let value = *field(light.bypass_change_detection());
    if let Some(new) = scaled_value(value, slot, factor) {
        *field(&mut light) = new;
    }
}

/// The factor of the [module docs](self) for a march's settings and layers (the camera at
/// [`MarchSettings::camera_altitude_m`]) over a ground of albedo `ground_albedo` (0–1): the light
/// the ground sends back up is reflected down again by the deck, `1 / (1 − A R)` more, `R` the
/// deck's reflectance for diffuse light from below, `1 − (4/3) / (4/3 + (1 − g) τ)`. 1 when the
/// clear sky sends no light.
pub fn sky_light_factor(
    settings: &MarchSettings,
    layers: &[MarchLayer],
    ground_albedo: f64,
) -> f64 {
    const SAMPLES: u32 = 16;
    let luminance = |rgb: [f64; 3]| 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    let altitude = settings.camera_altitude_m;
    let mut clear_fraction = 1.0;
    let mut weighted_depth = 0.0;
    let mut weights = 0.0;
    for layer in layers.iter().filter(|layer| layer_is_active(layer)) {
        let bottom = layer.base_m.max(altitude);
        if layer.top_m.partial_cmp(&bottom) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let mean_profile = (0..SAMPLES)
            .map(|i| {
                let height =
                    bottom + (layer.top_m - bottom) * (f64::from(i) + 0.5) / f64::from(SAMPLES);
                profile_density(
                    layer,
                    (height - layer.base_m) / (layer.top_m - layer.base_m),
                )
            })
            .sum::<f64>()
            / f64::from(SAMPLES);
        let cover = layer.coverage.clamp(0.0, 1.0);
        clear_fraction *= 1.0 - cover;
        weighted_depth += cover * layer.extinction * mean_profile * (layer.top_m - bottom);
        weights += cover;
    }
    let cover = 1.0 - clear_fraction;
    let sky = luminance(settings.ambient_top);
    let clear = std::f64::consts::PI * sky;
    if clear.is_nan() || clear <= 0.0 || cover.is_nan() || cover <= 0.0 {
        return 1.0;
    }
    let phase = eddington_phase(settings);
    let depth = weighted_depth / weights;
    let under = deck_irradiance(
        &phase,
        depth,
        settings
            .sun_direction
            .iter()
            .zip(settings.camera_up)
            .map(|(s, u)| s * u)
            .sum(),
        luminance(settings.sun_illuminance),
        sky,
        0.0,
    );
    let one_minus_g = (1.0 - phase.scaled_asymmetry) * (1.0 - phase.forward_fraction);
    let reflectance = 1.0 - (4.0 / 3.0) / (4.0 / 3.0 + one_minus_g * depth);
    let bounce = 1.0 / (1.0 - ground_albedo.clamp(0.0, 1.0) * reflectance).max(1e-3);
    ((1.0 - cover) * clear + cover * under.diffuse * bounce) / clear
}

/// The cameras' light components, scaled by [`sky_light_factor`].
type LitCamera<'a> = (
    &'a VolumetricClouds,
    &'a GlobalTransform,
    &'a mut CloudSkyLight,
    Has<Atmosphere>,
    Option<&'a mut AtmosphereEnvironmentMapLight>,
    Option<&'a mut EnvironmentMapLight>,
    Option<&'a mut AmbientLight>,
);

/// Scales each camera's sky light by the clouds above it ([`CloudSkyLight`]).
pub(crate) fn light_the_scene_under_the_clouds(
    world: Option<Res<CloudWorld>>,
    layers: Query<LayerInputData>,
    lights: Query<(&DirectionalLight, &GlobalTransform, Has<Sun>)>,
    mut cameras: Query<LitCamera>,
) {
    let earth = CloudWorld::default();
    let world = world.as_deref().unwrap_or(&earth);
    for (clouds, camera, mut sky_light, atmosphere, environment, map, ambient) in &mut cameras {
        let factor = sky_light.enabled.then(|| {
            let sun = CloudSun::pick(lights.iter(), atmosphere);
            let (settings, march_layers) = march_inputs(
                world,
                clouds,
                camera,
                1.0e-3,
                sun.as_ref(),
                layers.iter(),
                0,
            );
            sky_light_factor(&settings, &march_layers, GROUND_ALBEDO) as f32
        });
        let sky_light = sky_light.bypass_change_detection();
        sky_light.factor = factor.unwrap_or(1.0);
        let [environment_slot, map_slot, ambient_slot] = &mut sky_light.scaled;
        update(environment, |l| &mut l.intensity, environment_slot, factor);
        update(map, |l| &mut l.intensity, map_slot, factor);
        update(ambient, |l| &mut l.brightness, ambient_slot, factor);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layers::{CloudKind, CloudLayer, DensityProfile, ProfileInterpolation};

    /// A full deck from 1 to 2 km of vertical optical depth `tau` (flat profile, no noise).
    fn deck(tau: f32) -> CloudLayer {
        CloudLayer {
            base_m: 1_000.0,
            top_m: 2_000.0,
            coverage: 1.0,
            density: tau / 1_000.0,
            shape_noise: 0.0,
            profile: DensityProfile::new([(0.0, 1.0), (1.0, 1.0)], ProfileInterpolation::Linear),
            ..CloudLayer::new(CloudKind::Stratus)
        }
    }

    /// The march inputs of a camera at `altitude_m` under `layers`, a sun 40° from the zenith
    /// of illuminance 1 and a sky of radiance 0.05 (per unit sun illuminance), black ground:
    /// DISORT's case in `validation/disort/slabs.csv`.
    fn inputs(layers: &[CloudLayer], altitude_m: f32) -> (MarchSettings, Vec<MarchLayer>) {
        let camera = GlobalTransform::from_translation(Vec3::new(0.0, altitude_m, 0.0));
        let (mut settings, layers) = march_inputs(
            &CloudWorld::default(),
            &VolumetricClouds::default(),
            &camera,
            1.0e-3,
            None,
            layers.iter().map(|layer| (layer, None)),
            0,
        );
        let zenith = 40f64.to_radians();
        settings.sun_direction = [0.0, zenith.cos(), -zenith.sin()];
        settings.sun_illuminance = [1.0; 3];
        settings.ambient_top = [0.05; 3];
        settings.ambient_bottom = [0.0; 3];
        (settings, layers)
    }

    #[test]
    fn overcast_dims_the_sky_light_as_disorts_diffuse_flux_says() {
        let (settings, layers) = inputs(&[], 2.0);
        assert_eq!(sky_light_factor(&settings, &layers, 0.0), 1.0, "clear sky");
        // DISORT (slabs.csv, optical depth 30, sun 40°, sky 0.05): 0.0939 down at the base,
        // all of it diffuse; the clear sky sends π · 0.05 onto the ground.
        let disort = 0.093_914 / (std::f64::consts::PI * 0.05);
        let (settings, layers) = inputs(&[deck(30.0)], 2.0);
        let overcast = sky_light_factor(&settings, &layers, 0.0);
        assert!(
            (overcast / disort - 1.0).abs() <= 0.10,
            "factor {overcast}, DISORT {disort}"
        );
        // Above the deck the sky is clear again; half the sky covered lies between.
        let (settings, layers) = inputs(&[deck(30.0)], 2_500.0);
        assert_eq!(
            sky_light_factor(&settings, &layers, 0.0),
            1.0,
            "above the deck"
        );
        let half = CloudLayer {
            coverage: 0.5,
            ..deck(30.0)
        };
        let (settings, layers) = inputs(&[half], 2.0);
        let factor = sky_light_factor(&settings, &layers, 0.0);
        assert!(
            ((factor - (0.5 + 0.5 * overcast)) / factor).abs() < 1e-9,
            "half cover {factor}"
        );
    }

    #[test]
    fn a_camera_under_a_deck_gets_its_sky_light_scaled_and_keeps_the_games_values() {
        let mut app = App::new();
        app.add_systems(Update, light_the_scene_under_the_clouds);
        // Nimbostratus-thick: darker than the clear sky's diffuse light.
        app.world_mut().spawn(deck(100.0));
        let sun = Transform::default().looking_to(Vec3::new(0.0, -1.0, 1.0), Vec3::Y);
        app.world_mut()
            .spawn((DirectionalLight::default(), GlobalTransform::from(sun)));
        let camera = app
            .world_mut()
            .spawn((
                VolumetricClouds::default(),
                GlobalTransform::from_translation(Vec3::new(0.0, 2.0, 0.0)),
                AtmosphereEnvironmentMapLight {
                    intensity: 2.0,
                    ..default()
                },
                AmbientLight {
                    brightness: f32::NAN,
                    ..default()
                },
            ))
            .id();
        let state = |app: &App| {
            let entity = app.world().entity(camera);
            (
                entity.get::<CloudSkyLight>().unwrap().factor(),
                entity
                    .get::<AtmosphereEnvironmentMapLight>()
                    .unwrap()
                    .intensity,
                entity.get::<AmbientLight>().unwrap().brightness,
            )
        };
        app.update();
        let (factor, intensity, ambient) = state(&app);
        assert!(
            factor > 0.0 && factor < 1.0,
            "factor under the deck {factor}"
        );
        assert_eq!(intensity, 2.0 * factor);
        assert!(ambient.is_nan(), "a value that is not finite is left alone");
        // The same frame again: scaled once, not compounded.
        app.update();
        assert_eq!(state(&app).1, 2.0 * factor);
        // The game sets a new clear-sky value: scaled from it.
        app.world_mut()
            .entity_mut(camera)
            .get_mut::<AtmosphereEnvironmentMapLight>()
            .unwrap()
            .intensity = 3.0;
        app.update();
        assert_eq!(state(&app).1, 3.0 * factor);
        // Turned off: the clear-sky value comes back.
        app.world_mut()
            .entity_mut(camera)
            .get_mut::<CloudSkyLight>()
            .unwrap()
            .enabled = false;
        app.update();
        assert_eq!(state(&app).1, 3.0);
    }
}
