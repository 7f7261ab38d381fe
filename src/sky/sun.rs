//! Places the scene's sun where it really is for the scene's place and time, and the moon once
//! the sun has set.

use bevy::{
    light::{SunDisk, light_consts::lux},
    prelude::*,
};

use super::{
    moon::{LunarPosition, lunar_position_unix_seconds},
    solar::{Observer, SolarOptions, SolarPosition, solar_position_unix_seconds},
};
use crate::scene::{GeoOrigin, SceneClock};

/// Put on a `DirectionalLight` to have the crate aim it from the sun's true position for the
/// [`GeoOrigin`] (or [`GeoOrigin::default`], Bern, without one) at the [`SceneClock`] time, and
/// set its illuminance. Once the sun's disc has set, the light is the moon's (with
/// [`Sun::moonlight`]): aimed from the moon, its illuminance the moon's for its phase and
/// distance, so the clouds, their shadows and the ground are moonlit at night.
#[derive(Component, Debug, Clone, Copy, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct Sun {
    /// Illuminance with the sun fully above the horizon, lux. Default
    /// `lux::RAW_SUNLIGHT` (sunlight above the atmosphere), right for Bevy's `Atmosphere`, which
    /// attenuates the light itself. The moonlight is scaled with it: the moon's illuminance
    /// above the atmosphere ([`LunarPosition::illuminance_lux`], about 0.31 lux at full moon)
    /// times `illuminance_lux / lux::RAW_SUNLIGHT`.
    pub illuminance_lux: f32,
    /// Light the scene from the moon while the sun is down (and the moon up): below the
    /// horizon, or under Bevy's `Atmosphere` below [`TWILIGHT_END_DEG`] (twilight keeps the
    /// sun's light until then, [`twilight_share`]). Default true.
    pub moonlight: bool,
    /// Draw the moon's disc with its phase, by day and by night, wherever it is above the
    /// horizon ([`crate::sky::moon::disc`]; the cloud composite draws it behind the clouds, so
    /// only a camera with [`VolumetricClouds`](crate::render::VolumetricClouds) shows it). While
    /// the light is the moon's, the crate sets its `SunDisk` intensity to 0, so Bevy's
    /// atmosphere draws no round disc of its own, and gives the light's own `SunDisk` back when
    /// the sun returns. Default true.
    pub moon_disc: bool,
}

impl Default for Sun {
    fn default() -> Self {
        Self {
            illuminance_lux: lux::RAW_SUNLIGHT,
            moonlight: true,
            moon_disc: true,
        }
    }
}

impl Sun {
    /// The moonlight's lux per lux of the moon's own illuminance above the atmosphere:
    /// `illuminance_lux / lux::RAW_SUNLIGHT` (1 by default).
    pub(crate) fn moon_scale(&self) -> f64 {
        f64::from(self.illuminance_lux) / f64::from(lux::RAW_SUNLIGHT)
    }
}

/// The `SunDisk` a [`Sun`] light had before it became the moon's light (its angular size and
/// intensity), given back when the sun returns (`None`: it had none).
#[derive(Component, Debug, Clone, Copy)]
pub(crate) struct DaySunDisk(Option<(f32, f32)>);

/// Where the sun is now, updated every frame in [`crate::CloudscapeSystems::Sun`].
#[derive(Resource, Debug, Clone, Copy, Default)]
pub struct SunPosition(pub Option<SolarPosition>);

/// Where the moon is now and how much of it is lit, updated every frame in
/// [`crate::CloudscapeSystems::Sun`].
#[derive(Resource, Debug, Clone, Copy, Default)]
pub struct MoonPosition(pub Option<LunarPosition>);

/// Unit vector toward the moon in scene space (+X east, +Y up, −Z north).
pub fn moon_direction_scene(position: &LunarPosition) -> Vec3 {
    scene_direction(position.direction_enu())
}

/// Angular radius of the sun's disc, degrees: the light fades while the disc crosses the horizon.
const SUN_ANGULAR_RADIUS_DEG: f64 = 0.267;

/// Unit vector toward the sun in scene space (+X east, +Y up, −Z north).
pub fn sun_direction_scene(position: &SolarPosition) -> Vec3 {
    scene_direction(position.direction_enu())
}

/// An East-North-Up direction in scene space.
fn scene_direction([east, north, up]: [f64; 3]) -> Vec3 {
    Vec3::new(east as f32, up as f32, -north as f32).normalize()
}

/// Fraction of the sun's disc above the horizon, approximated linearly in elevation: 0 at
/// night, 1 by day. Keeps a light under the ground from lighting the scene from below.
pub fn sun_visibility(elevation_deg: f64) -> f32 {
    (((elevation_deg + SUN_ANGULAR_RADIUS_DEG) / (2.0 * SUN_ANGULAR_RADIUS_DEG)).clamp(0.0, 1.0))
        as f32
}

/// The sun's elevation, degrees, down to which a scene with Bevy's `Atmosphere` keeps its
/// full light: the end of civil twilight.
pub const TWILIGHT_FULL_DEG: f64 = -6.0;

/// The sun's elevation, degrees, from which a scene with Bevy's `Atmosphere` has no light from
/// it: the end of nautical twilight, when the twilight sky is a few thousandths of a lux.
pub const TWILIGHT_END_DEG: f64 = -12.0;

/// The share of the sun's light that a scene with Bevy's `Atmosphere` keeps at
/// `elevation_deg`: 1 down to [`TWILIGHT_FULL_DEG`], 0 from [`TWILIGHT_END_DEG`], linear between.
/// The atmosphere itself takes the light off every surface and sample below the sun's horizon
/// (its transmittance and visible-sun ratio), so a sun under the horizon still lights the air
/// above it: the twilight glow.
pub fn twilight_share(elevation_deg: f64) -> f32 {
    ((elevation_deg - TWILIGHT_END_DEG) / (TWILIGHT_FULL_DEG - TWILIGHT_END_DEG)).clamp(0.0, 1.0)
        as f32
}

/// The light of a [`Sun`] light while the sun is at `solar` and the moon at `lunar`: the unit
/// vector toward the body in scene space and the illuminance, lux. The sun while any of its disc
/// is up, or in a scene with Bevy's `Atmosphere` (`through_atmosphere`) through twilight
/// ([`twilight_share`]); then the moon (with [`Sun::moonlight`]) while any of its disc is up;
/// otherwise the sun's direction and no light.
pub fn sun_or_moon_light(
    sun: &Sun,
    solar: &SolarPosition,
    lunar: &LunarPosition,
    through_atmosphere: bool,
) -> (Vec3, f32) {
    let (toward, illuminance, _) = light_source(sun, solar, lunar, through_atmosphere);
    (toward, illuminance)
}

/// [`sun_or_moon_light`], and whether the light is the moon's.
fn light_source(
    sun: &Sun,
    solar: &SolarPosition,
    lunar: &LunarPosition,
    through_atmosphere: bool,
) -> (Vec3, f32, bool) {
    let sun_light = if through_atmosphere {
        twilight_share(solar.elevation_deg)
    } else {
        sun_visibility(solar.elevation_deg)
    };
    let moon_light = if sun.moonlight && sun_light <= 0.0 {
        sun_visibility(lunar.elevation_deg)
    } else {
        0.0
    };
    if moon_light > 0.0 {
        let illuminance = lunar.illuminance_lux() * sun.moon_scale() * f64::from(moon_light);
        return (moon_direction_scene(lunar), illuminance as f32, true);
    }
    (
        sun_direction_scene(solar),
        sun.illuminance_lux * sun_light,
        false,
    )
}

pub(crate) fn place_sun(
    clock: Res<SceneClock>,
    origin: Option<Res<GeoOrigin>>,
    mut position: ResMut<SunPosition>,
    mut moon: ResMut<MoonPosition>,
    mut suns: Query<(
        Entity,
        &Sun,
        &mut Transform,
        &mut DirectionalLight,
        Option<&SunDisk>,
        Option<&DaySunDisk>,
    )>,
    atmospheres: Query<(), With<bevy::light::Atmosphere>>,
    mut commands: Commands,
) {
    let through_atmosphere = !atmospheres.is_empty();
    let origin = origin.map_or_else(GeoOrigin::default, |origin| *origin);
    let observer = Observer::from(&origin);
    let options = SolarOptions::default();
    let solar = solar_position_unix_seconds(&observer, clock.unix_seconds(), &options);
    let lunar = lunar_position_unix_seconds(&observer, clock.unix_seconds(), &options);
    position.0 = Some(solar);
    moon.0 = Some(lunar);
    for (entity, sun, mut transform, mut light, disk, day_disk) in &mut suns {
        let (toward, illuminance, moonlit) = light_source(sun, &solar, &lunar, through_atmosphere);
        hide_disk_for_the_moon(
            &mut commands,
            entity,
            moonlit && sun.moon_disc,
            disk,
            day_disk,
        );
        let up = if toward.y.abs() > 0.999 {
            Vec3::NEG_Z
        } else {
            Vec3::Y
        };
        // A directional light shines along its forward (-Z) axis, away from the body. Only the
        // rotation is set: translation and scale place the cloud-shadow texture
        // (`render::shadow`) and do not affect the light.
        transform.rotation = Transform::default().looking_to(-toward, up).rotation;
        light.illuminance = illuminance;
    }
}

/// While `hide` (the light is the moon's and the crate draws its disc), sets the light's
/// `SunDisk` intensity to 0, keeping the one it had in [`DaySunDisk`]; otherwise gives that back.
fn hide_disk_for_the_moon(
    commands: &mut Commands,
    entity: Entity,
    hide: bool,
    disk: Option<&SunDisk>,
    day_disk: Option<&DaySunDisk>,
) {
    match (hide, day_disk) {
        (true, None) => {
            let kept = disk.map(|disk| (disk.angular_size, disk.intensity));
            let hidden = SunDisk {
                angular_size: kept.map_or(SunDisk::EARTH.angular_size, |(size, _)| size),
                intensity: 0.0,
            };
            commands.entity(entity).insert((hidden, DaySunDisk(kept)));
        }
        (false, Some(DaySunDisk(kept))) => {
            let mut light = commands.entity(entity);
            light.remove::<DaySunDisk>();
            match *kept {
                Some((angular_size, intensity)) => light.insert(SunDisk {
                    angular_size,
                    intensity,
                }),
                None => light.remove::<SunDisk>(),
            };
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// While the moon lights the scene (and the crate draws its phase), the light's `SunDisk`
    /// draws nothing, and the disc it had comes back by day; a light without one gets none back.
    #[test]
    fn the_moon_light_hides_bevys_round_disc() {
        use bevy::ecs::system::RunSystemOnce;
        let mut world = World::new();
        world.init_resource::<SunPosition>();
        world.init_resource::<MoonPosition>();
        let custom = world
            .spawn((
                DirectionalLight::default(),
                Sun::default(),
                SunDisk {
                    angular_size: 0.02,
                    intensity: 2.0,
                },
            ))
            .id();
        let bare = world
            .spawn((DirectionalLight::default(), Sun::default()))
            .id();
        let mut at = |time: &str| {
            let instant: crate::scene::UtcInstant = time.parse().unwrap();
            world.insert_resource(SceneClock::at(instant));
            world.run_system_once(place_sun).unwrap();
            let disk = |entity| {
                world
                    .get::<SunDisk>(entity)
                    .map(|disk| (disk.angular_size, disk.intensity))
            };
            (disk(custom), disk(bare))
        };
        // The first-quarter moon 40° up at 21:00 UTC on 2021-05-19, the sun 15° down (PyEphem).
        assert_eq!(
            at("2021-05-19T21:00:00Z"),
            (Some((0.02, 0.0)), Some((SunDisk::EARTH.angular_size, 0.0)))
        );
        // The next noon: as before.
        assert_eq!(at("2021-05-20T11:00:00Z"), (Some((0.02, 2.0)), None));
    }

    #[test]
    fn direction_follows_azimuth_and_elevation() {
        let bern = Observer::from(&GeoOrigin::default());
        // Bern, 2021-06-21 11:30 UTC: near the June solstice culmination (local noon ≈ 11:28
        // UTC), so the sun stands due south at 90 − (46.948 − 23.44) ≈ 66.5°.
        let noon = crate::scene::UtcInstant::from_civil(2021, 6, 21, 11, 30, 0).unwrap();
        let p = solar_position_unix_seconds(
            &bern,
            noon.unix_seconds() as f64,
            &SolarOptions::default(),
        );
        let d = sun_direction_scene(&p);
        assert!(d.z > 0.0, "south is +Z: {d}");
        assert!((d.y - (p.elevation_deg.to_radians().sin() as f32)).abs() < 1e-5);
        assert!((p.elevation_deg - 66.5).abs() < 0.3, "{}", p.elevation_deg);
    }

    /// The light of a default [`Sun`] at Bern at `unix_seconds`, and the sun and moon there.
    fn light_at(sun: &Sun, unix_seconds: f64) -> ((Vec3, f32), SolarPosition, LunarPosition) {
        let bern = Observer::from(&GeoOrigin::default());
        let options = SolarOptions::default();
        let solar = solar_position_unix_seconds(&bern, unix_seconds, &options);
        let lunar = lunar_position_unix_seconds(&bern, unix_seconds, &options);
        (sun_or_moon_light(sun, &solar, &lunar, false), solar, lunar)
    }

    #[test]
    fn the_moon_lights_the_night_and_the_sun_the_day() {
        let sun = Sun::default();
        // Full moon over Bern, 2024-04-24 00:00 UTC: the moon 27° up in the south (PyEphem).
        let ((toward, illuminance), solar, lunar) = light_at(&sun, 1_713_916_800.0);
        assert!(solar.elevation_deg < -10.0 && lunar.elevation_deg > 10.0);
        assert!(toward.dot(moon_direction_scene(&lunar)) > 0.999_999);
        // Full moonlight above the atmosphere (Krisciunas & Schaefer 1991): 0.31 lux at the
        // mean distance, 0.28 at apogee to 0.36 at perigee, and up to 12 % less for the few
        // degrees' phase angle the moon's latitude leaves at full moon.
        assert!(
            (0.24..0.37).contains(&illuminance),
            "full moon {illuminance} lux"
        );
        // The same night without moonlight: dark.
        let dark = Sun {
            moonlight: false,
            ..sun
        };
        assert_eq!(light_at(&dark, 1_713_916_800.0).0.1, 0.0);
        // A dimmer sun setting dims the moon in proportion.
        let dim = Sun {
            illuminance_lux: lux::RAW_SUNLIGHT / 2.0,
            ..sun
        };
        assert!((light_at(&dim, 1_713_916_800.0).0.1 / illuminance - 0.5).abs() < 1e-5);
        // The first quarter moon of 2024-04-15, that evening at 21:00 UTC (half lit), gives
        // about a tenth of the full moon's light (the phase law: 0.09 at a phase angle of 90°);
        // a twentieth to a fifth tells that from a light that follows the lit fraction (a half).
        let ((_, quarter), solar, lunar) = light_at(&sun, 1_713_214_800.0);
        assert!(solar.elevation_deg < -10.0 && lunar.elevation_deg > 10.0);
        assert!(
            (0.4..0.7).contains(&lunar.illuminated_fraction),
            "{lunar:?}"
        );
        assert!(
            quarter > 0.05 * illuminance && quarter < 0.2 * illuminance,
            "{quarter}"
        );
        // By day the sun: noon at the June solstice.
        let ((toward, illuminance), solar, _) = light_at(&sun, 1_624_275_000.0);
        assert!(toward.dot(sun_direction_scene(&solar)) > 0.999_999);
        assert_eq!(illuminance, lux::RAW_SUNLIGHT);
    }

    #[test]
    fn light_fades_across_the_horizon() {
        assert_eq!(sun_visibility(-5.0), 0.0);
        assert_eq!(sun_visibility(5.0), 1.0);
        assert!((sun_visibility(0.0) - 0.5).abs() < 1e-6);
        assert!(sun_visibility(-0.1) < sun_visibility(0.1));
    }

    #[test]
    fn under_bevys_atmosphere_the_sun_lights_the_sky_through_twilight() {
        assert_eq!(twilight_share(0.0), 1.0);
        assert_eq!(twilight_share(TWILIGHT_FULL_DEG), 1.0);
        assert!((twilight_share(-9.0) - 0.5).abs() < 1e-6);
        assert_eq!(twilight_share(TWILIGHT_END_DEG), 0.0);
        let sun = Sun::default();
        let bern = Observer::from(&GeoOrigin::default());
        let options = SolarOptions::default();
        // Bern, 2021-05-03 19:05 UTC: the sun about 4° down.
        let t = crate::scene::UtcInstant::from_civil(2021, 5, 3, 19, 5, 0).unwrap();
        let solar = solar_position_unix_seconds(&bern, t.unix_seconds() as f64, &options);
        let lunar = lunar_position_unix_seconds(&bern, t.unix_seconds() as f64, &options);
        assert!(
            (-5.0..-3.0).contains(&solar.elevation_deg),
            "{}",
            solar.elevation_deg
        );
        let (toward, lit) = sun_or_moon_light(&sun, &solar, &lunar, true);
        assert_eq!(
            lit, sun.illuminance_lux,
            "the twilight sky keeps the whole sun"
        );
        assert!(toward.dot(sun_direction_scene(&solar)) > 0.999_999);
        // Without Bevy's atmosphere nothing takes the light off the ground: it goes at sunset.
        let (_, bare) = sun_or_moon_light(&sun, &solar, &lunar, false);
        assert!(bare < 1.0e-3 * sun.illuminance_lux, "{bare}");
    }
}
