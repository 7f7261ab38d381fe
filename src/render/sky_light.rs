//! The sky light on the scene under the clouds: every camera with [`VolumetricClouds`] turns its
//! Bevy environment and ambient light (`AtmosphereEnvironmentMapLight`, `EnvironmentMapLight`,
//! `AmbientLight`) into the light that reaches the ground under the clouds above it, so a scene
//! under overcast darkens and greys as a real one does, and not only by losing its direct sun
//! (which the cloud shadow map dims).
//!
//! The layers above the camera cover a fraction `c` of the sky (`1 − Π (1 − coverageᵢ)`). The
//! open part still shows the clear sky, so the environment map keeps `1 − c` of its intensity and
//! its colour. The covered part sends the diffuse light out of the cloud base: `E_d(τ)`, the
//! δ-Eddington diffuse irradiance under a deck of the mean vertical optical depth `τ` of the
//! cloudy part ([`deck_irradiance`](crate::reference::render::deck_irradiance), validated against DISORT; each layer's extinction times its
//! mean profile density over the part above the camera, weighted by its coverage), per colour
//! channel from the sun's and the clear sky's colours, and raised by the light the ground reflects
//! and the deck sends back. Clouds scatter all colours alike, so that light is the colour of the
//! sun and sky light falling on the cloud top, not the sky's blue: it goes into the camera's
//! `AmbientLight` as the radiance `c E_d / π` of a uniform sky. A camera without an environment
//! map has its ambient light scaled by the ratio of the two irradiances instead
//! ([`SkyLightUnderClouds::factor`]), `((1 − c) π L + c E_d(τ)) / π L` with `L` the clear sky's radiance
//! ([`MarchSettings::ambient_top`](crate::reference::render::MarchSettings::ambient_top)). Under a thin veil the ratio exceeds 1: the sun's light
//! scattered in the cloud outshines the clear sky's.

use bevy::{
    light::{
        AmbientLight, Atmosphere, AtmosphereEnvironmentMapLight, EnvironmentMapLight,
        GlobalAmbientLight,
    },
    prelude::*,
};

pub use crate::reference::render::{SkyLightUnderClouds, sky_light_under_clouds};
use crate::{
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
/// The light components' values the game sets are the clear sky's: the crate writes them for
/// the clouds, and takes a value it did not write as the game's new clear-sky value. A camera
/// with an environment map but no `AmbientLight` gets one while clouds cover its sky (the
/// [`GlobalAmbientLight`] plus the clouds' light), removed again when they clear.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default)]
pub struct CloudSkyLight {
    /// Turn the camera's environment and ambient light into the light under the clouds above
    /// it. Default true; turned off, the clear-sky values are put back.
    pub enabled: bool,
    /// The ratio applied this frame (1 without clouds above; read-only, the crate sets it).
    #[reflect(ignore)]
    factor: f32,
    /// Per environment component (atmosphere environment, environment map): the clear-sky
    /// intensity and the value the crate last wrote.
    #[reflect(ignore)]
    scaled: [Option<Scaled>; 2],
    /// The ambient light the crate last wrote, and the game's clear-sky value under it.
    #[reflect(ignore)]
    ambient: Option<WrittenAmbient>,
}

impl Default for CloudSkyLight {
    fn default() -> Self {
        Self {
            enabled: true,
            factor: 1.0,
            scaled: [None; 2],
            ambient: None,
        }
    }
}

impl CloudSkyLight {
    /// Off: the camera keeps the clear-sky values its game sets (what `enabled: false` gives).
    #[must_use]
    pub fn disabled() -> Self {
        Self {
            enabled: false,
            ..Self::default()
        }
    }

    /// The diffuse irradiance on a horizontal surface under the clouds above the camera over the
    /// clear sky's this frame, dimensionless (1 under a clear sky, less under thick cloud, more
    /// under a thin sunlit veil): [`SkyLightUnderClouds::factor`].
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

/// An ambient light as colour and brightness (cd/m² once multiplied).
type Ambient = (Color, f32);

/// The ambient light the crate wrote on a camera, and the game's clear-sky value under it
/// (`None`: the camera had no `AmbientLight`, the crate inserted one over the global one).
#[derive(Clone, Copy, Debug, PartialEq)]
struct WrittenAmbient {
    clear: Option<Ambient>,
    written: Ambient,
}

/// The game's clear-sky value of a light field holding `value`, where `slot` holds what the
/// crate wrote last time (a value it did not write is the game's new clear value).
fn clear_value(value: f32, slot: Option<Scaled>) -> f32 {
    match slot {
        Some(scaled) if scaled.written == value => scaled.clear,
        _ => value,
    }
}

/// The value to write in place of `value` (`None`: leave it): `clear × factor` (`None`:
/// the clear value, put back), the clear value from [`clear_value`]. A value that is not
/// finite is left alone.
fn scaled_value(value: f32, slot: &mut Option<Scaled>, factor: Option<f32>) -> Option<f32> {
    if !value.is_finite() {
        *slot = None;
        return None;
    }
    let clear = clear_value(value, *slot);
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

/// The ambient light to write: the game's clear ambient `clear` (colour and brightness) times
/// `factor`, plus `cloud` (linear RGB radiance, cd/m²), as a colour of luminance 1 and a
/// brightness (the game's colour at brightness 0 when the sum is black).
fn ambient_value(clear: Ambient, factor: f32, cloud: Vec3) -> Ambient {
    let (color, brightness) = clear;
    let rgb =
        Vec3::from_array(LinearRgba::from(color).to_f32_array_no_alpha()) * brightness * factor
            + cloud;
    let luminance = rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722));
    if !(luminance > 0.0 && luminance.is_finite()) {
        return (color, 0.0);
    }
    let rgb = rgb / luminance;
    (Color::linear_rgb(rgb.x, rgb.y, rgb.z), luminance)
}

/// Writes a camera's ambient light: the game's clear ambient (the camera's own, or the global one
/// when it has none) times `factor` plus `cloud` (cd/m², linear RGB); `light` `None` puts the
/// clear value back (removes the ambient light the crate inserted). A camera without an
/// `AmbientLight` gets one only where `cloud` is not black. A brightness that is not finite is
/// left alone.
fn update_ambient(
    ambient: Option<Mut<AmbientLight>>,
    global: &GlobalAmbientLight,
    slot: &mut Option<WrittenAmbient>,
    light: Option<(f32, Vec3)>,
    camera: Entity,
    commands: &mut Commands,
) {
    let global_value = (global.color, global.brightness);
    let Some(mut ambient) = ambient else {
        // None yet, or the one the crate inserted is not there yet (or the game removed it).
        *slot = None;
        let Some((factor, cloud)) = light.filter(|(_, cloud)| *cloud != Vec3::ZERO) else {
            return;
        };
        let written = ambient_value(global_value, factor, cloud);
        commands.entity(camera).insert(AmbientLight {
            color: written.0,
            brightness: written.1,
            affects_lightmapped_meshes: global.affects_lightmapped_meshes,
        });
        *slot = Some(WrittenAmbient {
            clear: None,
            written,
        });
        return;
    };
    let value = (ambient.color, ambient.brightness);
    if !value.1.is_finite() {
        *slot = None;
        return;
    }
    let clear = match *slot {
        Some(written) if written.written == value => written.clear,
        _ => Some(value),
    };
    let Some((factor, cloud)) = light.filter(|(_, cloud)| clear.is_some() || *cloud != Vec3::ZERO)
    else {
        *slot = None;
        match clear {
            None => {
                commands.entity(camera).remove::<AmbientLight>();
            }
            Some(clear) if clear != value => (ambient.color, ambient.brightness) = clear,
            Some(_) => {}
        }
        return;
    };
    let written = ambient_value(clear.unwrap_or(global_value), factor, cloud);
    *slot = Some(WrittenAmbient { clear, written });
    if written != value {
        (ambient.color, ambient.brightness) = written;
    }
}

/// The cameras' light components, set by [`sky_light_under_clouds`].
type LitCamera<'a> = (
    Entity,
    &'a VolumetricClouds,
    &'a GlobalTransform,
    &'a mut CloudSkyLight,
    Has<Atmosphere>,
    Option<&'a mut AtmosphereEnvironmentMapLight>,
    Option<&'a mut EnvironmentMapLight>,
    Option<&'a mut AmbientLight>,
);

/// Sets each camera's sky light for the clouds above it ([`CloudSkyLight`]).
pub(crate) fn light_the_scene_under_the_clouds(
    world: Option<Res<CloudWorld>>,
    global_ambient: Option<Res<GlobalAmbientLight>>,
    layers: Query<LayerInputData>,
    lights: Query<(&DirectionalLight, &GlobalTransform, Has<Sun>)>,
    mut cameras: Query<LitCamera>,
    mut commands: Commands,
) {
    let earth = CloudWorld::default();
    let world = world.as_deref().unwrap_or(&earth);
    let no_ambient = GlobalAmbientLight::NONE;
    let global_ambient = global_ambient.as_deref().unwrap_or(&no_ambient);
    for (entity, clouds, camera, mut sky_light, atmosphere, environment, map, ambient) in
        &mut cameras
    {
        let light = sky_light.enabled.then(|| {
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
            sky_light_under_clouds(&settings, &march_layers, GROUND_ALBEDO)
        });
        let sky_light = sky_light.bypass_change_detection();
        sky_light.factor = light.map_or(1.0, |light| light.factor as f32);
        let [environment_slot, map_slot] = &mut sky_light.scaled;
        // The environment map's clear intensity scales the clouds' light as it scales the sky's.
        let environment_intensity = environment
            .as_deref()
            .map(|light| clear_value(light.intensity, *environment_slot))
            .or_else(|| {
                map.as_deref()
                    .map(|light| clear_value(light.intensity, *map_slot))
            })
            .filter(|intensity| intensity.is_finite());
        let (environment_factor, ambient_light) = match (light, environment_intensity) {
            (None, _) => (None, None),
            (Some(light), Some(intensity)) => (
                Some((1.0 - light.cover) as f32),
                Some((
                    light.factor as f32,
                    Vec3::from_array(light.cloud_radiance.map(|l| l as f32)) * intensity,
                )),
            ),
            (Some(light), None) => (None, Some((light.factor as f32, Vec3::ZERO))),
        };
        update(
            environment,
            |l| &mut l.intensity,
            environment_slot,
            environment_factor,
        );
        update(map, |l| &mut l.intensity, map_slot, environment_factor);
        update_ambient(
            ambient,
            global_ambient,
            &mut sky_light.ambient,
            ambient_light,
            entity,
            &mut commands,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layers::{CloudKind, CloudLayer, DensityProfile, ProfileInterpolation};
    use crate::reference::render::{MarchLayer, MarchSettings};

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

    /// The haze under broken clouds sees their sunlit bases: its sky
    /// ([`HazeSettings::sky_radiance`](crate::reference::haze::HazeSettings::sky_radiance))
    /// under half a deck of optical depth 8 is the open half's clear sky plus the deck's diffuse
    /// flux as a uniform sky, within 10 % of DISORT's (slabs.csv: optical depth 8, sun 40°, sky
    /// 0.05: 0.2753 down at the base, all but 2·10⁻⁵ of it diffuse). The clear sky's light
    /// through the clouds alone, which is all the haze saw before, misses that by far more.
    #[test]
    fn the_haze_under_broken_clouds_sees_their_sunlit_bases() {
        let clouds = VolumetricClouds::default();
        let visibility = crate::layers::Haze::with_visibility(20_000.0);
        let (settings, layers) = inputs(&[], 2.0);
        let clear =
            crate::render::haze::haze_settings(&visibility, &clouds, &settings, &layers, 0.0);
        assert_eq!(clear.sky_radiance, Some(settings.ambient_top));
        let half = CloudLayer {
            coverage: 0.5,
            ..deck(8.0)
        };
        let (settings, layers) = inputs(&[half], 2.0);
        let haze =
            crate::render::haze::haze_settings(&visibility, &clouds, &settings, &layers, 0.0);
        let sky = haze
            .sky_radiance
            .expect("the renderer sets the sky above the haze")[1];
        let disort = 0.5 * 0.05 + 0.5 * (0.275_276 - 0.000_022) / std::f64::consts::PI;
        assert!(
            (sky / disort - 1.0).abs() <= 0.10,
            "sky {sky}, DISORT {disort}"
        );
        let through = 0.05 * haze.ambient_transmittance;
        assert!(
            (through / disort - 1.0).abs() > 0.10,
            "the sky's light through the clouds {through} would meet DISORT's {disort} as well"
        );
    }

    #[test]
    fn overcast_dims_the_sky_light_as_disorts_diffuse_flux_says() {
        let (settings, layers) = inputs(&[], 2.0);
        assert_eq!(
            sky_light_under_clouds(&settings, &layers, 0.0).factor,
            1.0,
            "clear sky"
        );
        // DISORT (slabs.csv, optical depth 30, sun 40°, sky 0.05): 0.0939 down at the base,
        // all of it diffuse; the clear sky sends π · 0.05 onto the ground.
        let disort = 0.093_914 / (std::f64::consts::PI * 0.05);
        let (settings, layers) = inputs(&[deck(30.0)], 2.0);
        let overcast = sky_light_under_clouds(&settings, &layers, 0.0).factor;
        assert!(
            (overcast / disort - 1.0).abs() <= 0.10,
            "factor {overcast}, DISORT {disort}"
        );
        // Above the deck the sky is clear again; half the sky covered lies between.
        let (settings, layers) = inputs(&[deck(30.0)], 2_500.0);
        assert_eq!(
            sky_light_under_clouds(&settings, &layers, 0.0).factor,
            1.0,
            "above the deck"
        );
        let half = CloudLayer {
            coverage: 0.5,
            ..deck(30.0)
        };
        let (settings, layers) = inputs(&[half], 2.0);
        let factor = sky_light_under_clouds(&settings, &layers, 0.0).factor;
        assert!(
            ((factor - (0.5 + 0.5 * overcast)) / factor).abs() < 1e-9,
            "half cover {factor}"
        );
    }

    #[test]
    fn the_light_under_a_deck_takes_the_colour_of_the_light_on_its_top() {
        // A blue sky and a white sun: the clear sky's own light is blue, the light out of a
        // full deck is the mix of sun and sky that falls on its top.
        let (mut settings, layers) = inputs(&[deck(30.0)], 2.0);
        settings.ambient_top = [0.03, 0.05, 0.09];
        let light = sky_light_under_clouds(&settings, &layers, 0.0);
        assert_eq!(light.cover, 1.0);
        let blue_over_red = |rgb: [f64; 3]| rgb[2] / rgb[0];
        let sky = blue_over_red(settings.ambient_top);
        let mu0 = 40f64.to_radians().cos();
        let on_top = blue_over_red(std::array::from_fn(|c| {
            settings.sun_illuminance[c] * mu0 + std::f64::consts::PI * settings.ambient_top[c]
        }));
        let under = blue_over_red(light.cloud_radiance);
        // Sun and sky light cross the deck differently, so its light lies between the white
        // sun's (1) and the sky's blue/red, nearer the mix on its top than the sky.
        assert!(
            under > 1.0 && under < sky && (under - on_top).abs() < (under - sky).abs(),
            "blue/red under the deck {under}, of the sky {sky}, on the deck's top {on_top}"
        );
        // All of the light comes from the deck, and it is the irradiance ratio's.
        let luminance = |rgb: [f64; 3]| 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
        assert!(
            (luminance(light.cloud_radiance) / luminance(settings.ambient_top) / light.factor
                - 1.0)
                .abs()
                < 1e-9
        );
        assert_eq!(
            sky_light_under_clouds(&settings, &[], 0.0),
            SkyLightUnderClouds::CLEAR
        );
    }

    /// The sun of [`app_under_a_deck`].
    fn sun() -> (DirectionalLight, GlobalTransform) {
        let sun = Transform::default().looking_to(Vec3::new(0.0, -1.0, 1.0), Vec3::Y);
        (DirectionalLight::default(), GlobalTransform::from(sun))
    }

    /// An app with the sky-light system, [`sun`] and a deck of optical depth 100.
    fn app_under_a_deck() -> (App, Entity) {
        let mut app = App::new();
        app.add_systems(Update, light_the_scene_under_the_clouds);
        let deck = app.world_mut().spawn(deck(100.0)).id();
        app.world_mut().spawn(sun());
        (app, deck)
    }

    /// A camera 2 m up with clouds and `lights`.
    fn spawn_camera(app: &mut App, lights: impl Bundle) -> Entity {
        app.world_mut()
            .spawn((
                VolumetricClouds::default(),
                GlobalTransform::from_translation(Vec3::new(0.0, 2.0, 0.0)),
                lights,
            ))
            .id()
    }

    fn ambient(app: &App, camera: Entity) -> Option<(Vec3, f32)> {
        app.world().entity(camera).get::<AmbientLight>().map(|a| {
            (
                Vec3::from_array(LinearRgba::from(a.color).to_f32_array_no_alpha()),
                a.brightness,
            )
        })
    }

    #[test]
    fn a_camera_with_an_environment_map_takes_the_clouds_light_as_ambient() {
        let (mut app, deck) = app_under_a_deck();
        app.insert_resource(GlobalAmbientLight {
            color: Color::linear_rgb(0.0, 0.0, 1.0),
            brightness: 10.0,
            ..GlobalAmbientLight::NONE
        });
        let camera = spawn_camera(
            &mut app,
            (AtmosphereEnvironmentMapLight {
                intensity: 2.0,
                ..default()
            },),
        );
        let intensity = |app: &App| {
            app.world()
                .get::<AtmosphereEnvironmentMapLight>(camera)
                .unwrap()
                .intensity
        };
        app.update();
        app.update();
        let factor = app.world().get::<CloudSkyLight>(camera).unwrap().factor();
        assert!(
            factor > 0.0 && factor < 1.0,
            "factor under the deck {factor}"
        );
        // The deck covers the whole sky: no clear sky left in the environment map.
        assert_eq!(intensity(&app), 0.0);
        // Its light is in the inserted ambient light: the deck's light (scaled by the map's
        // intensity) over the global ambient scaled by the factor, up to f32 rounding.
        let (color, brightness) = ambient(&app, camera).expect("ambient light inserted");
        let (light, transform) = sun();
        let (settings, layers) = march_inputs(
            &CloudWorld::default(),
            &VolumetricClouds::default(),
            &GlobalTransform::from_translation(Vec3::new(0.0, 2.0, 0.0)),
            1.0e-3,
            CloudSun::pick([(&light, &transform, false)], false).as_ref(),
            [(app.world().get::<CloudLayer>(deck).unwrap(), None)],
            0,
        );
        let under = sky_light_under_clouds(&settings, &layers, GROUND_ALBEDO);
        let expected = Vec3::new(0.0, 0.0, 10.0) * factor
            + Vec3::from_array(under.cloud_radiance.map(|l| l as f32)) * 2.0;
        assert!(
            (color * brightness - expected).length() < 1e-5 * expected.length(),
            "ambient under the deck {} against {expected}",
            color * brightness
        );
        // Written once, not compounded.
        app.update();
        assert_eq!(ambient(&app, camera), Some((color, brightness)));
        assert_eq!(intensity(&app), 0.0);
        // The deck clears: the map's intensity comes back and the inserted light goes.
        app.world_mut()
            .get_mut::<CloudLayer>(deck)
            .unwrap()
            .coverage = 0.0;
        app.update();
        app.update();
        assert_eq!(intensity(&app), 2.0);
        assert_eq!(ambient(&app, camera), None);
    }

    #[test]
    fn a_camera_under_a_deck_keeps_the_games_values() {
        let (mut app, _) = app_under_a_deck();
        let camera = spawn_camera(
            &mut app,
            (
                EnvironmentMapLight {
                    intensity: 2.0,
                    ..default()
                },
                AmbientLight {
                    brightness: f32::NAN,
                    ..default()
                },
            ),
        );
        let intensity = |app: &App| {
            app.world()
                .get::<EnvironmentMapLight>(camera)
                .unwrap()
                .intensity
        };
        app.update();
        assert_eq!(intensity(&app), 0.0);
        let (_, brightness) = ambient(&app, camera).unwrap();
        assert!(
            brightness.is_nan(),
            "a value that is not finite is left alone"
        );
        // The game sets a new clear-sky ambient: it is the base the clouds' light adds to.
        app.world_mut()
            .get_mut::<AmbientLight>(camera)
            .unwrap()
            .brightness = 0.0;
        app.update();
        let (_, with_clouds) = ambient(&app, camera).unwrap();
        assert!(with_clouds > 0.0);
        app.update();
        assert_eq!(
            ambient(&app, camera).unwrap().1,
            with_clouds,
            "not compounded"
        );
        // The game sets a new clear-sky intensity: still none of it under a full deck, and back
        // when turned off, with the game's own ambient light.
        app.world_mut()
            .get_mut::<EnvironmentMapLight>(camera)
            .unwrap()
            .intensity = 3.0;
        app.update();
        assert_eq!(intensity(&app), 0.0);
        app.world_mut()
            .get_mut::<CloudSkyLight>(camera)
            .unwrap()
            .enabled = false;
        app.update();
        assert_eq!(intensity(&app), 3.0);
        assert_eq!(ambient(&app, camera).unwrap().1, 0.0);
    }

    #[test]
    fn a_camera_without_an_environment_map_has_its_ambient_light_scaled() {
        let (mut app, _) = app_under_a_deck();
        let camera = spawn_camera(
            &mut app,
            (AmbientLight {
                color: Color::linear_rgb(0.2, 0.4, 1.0),
                brightness: 50.0,
                ..default()
            },),
        );
        app.update();
        let factor = app.world().get::<CloudSkyLight>(camera).unwrap().factor();
        assert!(factor > 0.0 && factor < 1.0);
        let (color, brightness) = ambient(&app, camera).unwrap();
        let expected = Vec3::new(0.2, 0.4, 1.0) * 50.0 * factor;
        assert!(
            (color * brightness - expected).length() < 1e-5 * expected.length(),
            "{} against {expected}",
            color * brightness
        );
    }
}
