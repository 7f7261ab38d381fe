//! Lightning: storm clouds flash. Every visible cumulonimbus layer (the weather mapping makes
//! them from thunderstorm weather codes and convective rain) sets a flash rate; flashes come at
//! random, deterministic for [`Lightning::seed`] and the scene time, so a time-lapse or a test
//! shows the same flashes again.
//!
//! A flash is a point of light inside the storm cloud for a third of a second, with three
//! strokes ([`flash_envelope`]). The cloud march lights the cloud volume from within by it
//! ([`flash_source`](crate::reference::render::flash_source): the unscattered light near the
//! flash, the diffusion approximation farther out), so it shows through the cloud as a glow,
//! and a `PointLight` under the cloud (marked [`LightningLight`]) lights the ground while the
//! flash lasts, dimmed by the cloud below it. Without a storm nothing is lit, no light exists and
//! the march's flash term is skipped: lightning costs nothing.

use bevy::prelude::*;

use crate::{
    CloudscapeSystems,
    layers::{CloudKind, CloudLayer},
    render::VolumetricClouds,
    scene::SceneClock,
    world::CloudWorld,
};

/// The scene time one flash may occupy, seconds: each whole second of scene time holds a flash
/// with probability `rate / 60`, starting at the second (so a time-lapse image at a whole
/// second shows a flash at its first stroke).
pub const FLASH_SLOT_S: f64 = 1.0;

/// The strokes of a flash: start after the flash's start, seconds, and relative brightness.
/// A flash holds a few return strokes tens of milliseconds apart (Rakov & Uman 2003,
/// "Lightning: Physics and Effects": three to five strokes per flash, typically 60 ms apart).
pub const FLASH_STROKES: [(f64, f32); 3] = [(0.0, 1.0), (0.07, 0.55), (0.16, 0.8)];

/// How fast a stroke's light fades, seconds (e-folding).
pub const STROKE_FADE_S: f64 = 0.03;

/// How long a flash lasts, seconds: after this its light is taken as gone.
pub const FLASH_DURATION_S: f64 = 0.33;

/// The storm's lightning (a resource; [`LightningPlugin`] inserts the default).
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct Lightning {
    /// Flashes per minute of a cumulonimbus layer at full coverage; a layer with less coverage
    /// flashes in proportion, and the rates of several add up. Default 6 (an active
    /// thunderstorm's rate; a severe one's is several times that).
    pub flashes_per_minute: f32,
    /// A rate in flashes per minute that replaces the layers' (for a scene without a forecast,
    /// or a test). Default `None`: from the layers.
    pub rate_override: Option<f32>,
    /// Picks which flashes come when and where. Default 0.
    pub seed: u64,
    /// A flash's luminous intensity at its brightest stroke, candela. Default 2·10⁹.
    pub peak_intensity_cd: f32,
    /// Flashes strike within this horizontal distance of the camera, metres. Default 12 000.
    pub radius_m: f32,
    /// Where in the storm layer flashes are, as a fraction of its depth above its base, 0–1.
    /// Default 0.35.
    pub height_fraction: f32,
    /// Light the ground with a `PointLight` while a flash lasts. Default true.
    pub light_ground: bool,
}

impl Default for Lightning {
    fn default() -> Self {
        Self {
            flashes_per_minute: 6.0,
            rate_override: None,
            seed: 0,
            peak_intensity_cd: 2.0e9,
            radius_m: 12_000.0,
            height_fraction: 0.35,
            light_ground: true,
        }
    }
}

/// A flash lit now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flash {
    /// Where, scene metres.
    pub position: Vec3,
    /// Its luminous intensity now, candela (its envelope times its strength times
    /// [`Lightning::peak_intensity_cd`]).
    pub intensity_cd: f32,
    /// Luminous power of the `PointLight` that lights the ground, lumens: the flash's `4π I`
    /// times the diffuse transmittance of the cloud under it.
    pub ground_lumens: f32,
}

/// The lightning now (a resource written every frame in [`CloudscapeSystems::Sun`]).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct ActiveFlash {
    /// Flashes per minute from the storm layers (or [`Lightning::rate_override`]).
    pub rate_per_minute: f32,
    /// The flash lit now, if any.
    pub flash: Option<Flash>,
}

/// The `PointLight` entity that lights the ground during a flash.
#[derive(Component, Debug)]
pub struct LightningLight;

/// One flash of the random sequence ([`flash_at`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlashEvent {
    /// Scene time of its start, Unix seconds (a whole multiple of [`FLASH_SLOT_S`]).
    pub start_s: f64,
    /// Where it strikes, in the unit disc (scaled by [`Lightning::radius_m`] around the
    /// camera): x east, y south (scene x and z).
    pub offset: Vec2,
    /// Its strength, 0.5–1 of [`Lightning::peak_intensity_cd`].
    pub strength: f32,
}

/// `SplitMix64` (Steele, Lea & Flood 2014, "Fast splittable pseudorandom number generators"): a
/// well-mixed 64-bit hash of `x`.
fn split_mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A uniform number in [0, 1) from the hash of `seed`, `slot` and `k`.
fn uniform(seed: u64, slot: i64, k: u64) -> f64 {
    let h = split_mix(seed ^ split_mix((slot as u64) ^ split_mix(k)));
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// The flash whose slot holds `unix_seconds` under a storm of `rate_per_minute`, if that slot
/// has one (whether or not it still shines: [`flash_envelope`]). Each slot of
/// [`FLASH_SLOT_S`] has a flash with probability `rate_per_minute / 60` (at most 1), drawn from
/// `seed` and the slot alone, so the sequence is the same at any frame rate and after any jump.
#[must_use]
pub fn flash_at(seed: u64, rate_per_minute: f32, unix_seconds: f64) -> Option<FlashEvent> {
    if rate_per_minute.is_nan() || rate_per_minute <= 0.0 || !unix_seconds.is_finite() {
        return None;
    }
    let slot = (unix_seconds / FLASH_SLOT_S).floor() as i64;
    let chance = f64::from(rate_per_minute) / 60.0 * FLASH_SLOT_S;
    if uniform(seed, slot, 0) >= chance {
        return None;
    }
    // Uniform over the disc.
    let radius = uniform(seed, slot, 1).sqrt();
    let angle = std::f64::consts::TAU * uniform(seed, slot, 2);
    Some(FlashEvent {
        start_s: slot as f64 * FLASH_SLOT_S,
        offset: Vec2::new((radius * angle.cos()) as f32, (radius * angle.sin()) as f32),
        strength: (0.5 + 0.5 * uniform(seed, slot, 3)) as f32,
    })
}

/// A flash's brightness `since_start_s` seconds after it began, 0–1: each of
/// [`FLASH_STROKES`] jumps to its brightness and fades over [`STROKE_FADE_S`]; 0 before the
/// start and from [`FLASH_DURATION_S`] on.
#[must_use]
pub fn flash_envelope(since_start_s: f64) -> f32 {
    if !(0.0..FLASH_DURATION_S).contains(&since_start_s) {
        return 0.0;
    }
    FLASH_STROKES
        .iter()
        .filter(|(at, _)| since_start_s >= *at)
        .map(|(at, brightness)| brightness * (-(since_start_s - at) / STROKE_FADE_S).exp() as f32)
        .fold(0.0, f32::max)
}

/// Flashes per minute of the visible cumulonimbus layers at [`Lightning::flashes_per_minute`]
/// each at full coverage, or the override; 0 for a bad (negative, NaN) rate.
fn storm_rate<'a>(lightning: &Lightning, layers: impl IntoIterator<Item = &'a CloudLayer>) -> f32 {
    let rate = lightning.rate_override.unwrap_or_else(|| {
        layers
            .into_iter()
            .filter(|layer| layer.kind == CloudKind::Cumulonimbus && layer.is_visible())
            .map(|layer| lightning.flashes_per_minute * layer.coverage.clamp(0.0, 1.0))
            .sum()
    });
    if rate.is_finite() { rate.max(0.0) } else { 0.0 }
}

/// Finds the flash lit at the scene time, places it in the storm layer around the first
/// camera with clouds, and keeps the [`LightningLight`] on it (spawned while a flash shines,
/// despawned after).
pub(crate) fn update_lightning(
    mut commands: Commands,
    lightning: Res<Lightning>,
    clock: Res<SceneClock>,
    world: Option<Res<CloudWorld>>,
    layers: Query<&CloudLayer>,
    cameras: Query<&GlobalTransform, With<VolumetricClouds>>,
    mut active: ResMut<ActiveFlash>,
    mut lights: Query<(Entity, &mut Transform, &mut PointLight), With<LightningLight>>,
) {
    let rate = storm_rate(&lightning, layers.iter());
    let t = clock.unix_seconds();
    let storm = layers
        .iter()
        .filter(|layer| layer.kind == CloudKind::Cumulonimbus && layer.is_visible())
        .max_by(|a, b| a.coverage.total_cmp(&b.coverage));
    let flash = flash_at(lightning.seed, rate, t).and_then(|event| {
        let brightness = flash_envelope(t - event.start_s);
        let camera = cameras.iter().next()?.translation();
        let ground = world.as_deref().map_or(0.0, |w| w.ground_height_m);
        // Without a storm layer (a rate override), flashes are at a cumulonimbus's own height.
        let (base, top, density) = storm.map_or_else(
            || {
                let defaults = CloudLayer::new(CloudKind::Cumulonimbus);
                (defaults.base_m, defaults.top_m, defaults.density)
            },
            |layer| (layer.base_m, layer.top_m, layer.density),
        );
        let height = lightning.height_fraction.clamp(0.0, 1.0) * (top - base);
        let offset = event.offset * lightning.radius_m.max(0.0);
        let intensity = lightning.peak_intensity_cd.max(0.0) * event.strength * brightness;
        // Conservative scattering's diffuse transmittance through the cloud below the flash,
        // `1 / (1 + ¾ (1 − g) τ)`: the Eddington approximation's, as in the march's diffuse
        // light (Joseph, Wiscombe & Weinman 1976), with a cloud's g = 0.85.
        let tau = (density * height).max(0.0);
        let below = 1.0 / (1.0 + 0.75 * 0.15 * tau);
        (intensity > 0.0 && intensity.is_finite()).then(|| Flash {
            position: Vec3::new(
                camera.x + offset.x,
                ground + base + height,
                camera.z + offset.y,
            ),
            intensity_cd: intensity,
            ground_lumens: 4.0 * std::f32::consts::PI * intensity * below,
        })
    });
    let next = ActiveFlash {
        rate_per_minute: rate,
        flash,
    };
    if *active != next {
        *active = next;
    }
    match flash.filter(|_| lightning.light_ground) {
        Some(flash) => {
            if let Some((_, mut transform, mut light)) = lights.iter_mut().next() {
                transform.translation = flash.position;
                light.intensity = flash.ground_lumens;
            } else {
                commands.spawn((
                    Name::new("lightning"),
                    LightningLight,
                    Transform::from_translation(flash.position),
                    PointLight {
                        intensity: flash.ground_lumens,
                        range: 2.0 * lightning.radius_m.max(1.0),
                        shadow_maps_enabled: false,
                        color: Color::srgb(0.9, 0.93, 1.0),
                        ..default()
                    },
                ));
            }
        }
        None => {
            for (entity, ..) in &lights {
                commands.entity(entity).despawn();
            }
        }
    }
}

/// Lightning: [`Lightning`], [`ActiveFlash`] and the flash's ground light; part of
/// [`crate::CloudscapePlugin`].
#[derive(Debug, Default, Clone, Copy)]
pub struct LightningPlugin;

impl Plugin for LightningPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<Lightning>()
            .init_resource::<ActiveFlash>()
            .register_type::<Lightning>()
            .add_systems(
                Update,
                update_lightning
                    .in_set(CloudscapeSystems::Sun)
                    .after(CloudscapeSystems::Layers),
            );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flashes_come_at_the_rate_and_the_same_for_a_seed() {
        let count = |seed, rate| {
            (0..60_000)
                .filter(|s| flash_at(seed, rate, f64::from(*s) + 0.5).is_some())
                .count()
        };
        // 6 a minute over 1000 minutes: 6000, within four standard deviations (√6000 ≈ 77).
        let six = count(0, 6.0);
        assert!((6000_i32 - six as i32).abs() < 310, "{six}");
        assert_eq!(count(0, 0.0), 0);
        assert_eq!(count(0, f32::NAN), 0);
        assert_eq!(count(3, -1.0), 0);
        // The same seed and time give the same flash; another seed another sequence.
        let at = |seed| {
            (0..600)
                .map(|s| flash_at(seed, 6.0, f64::from(s)))
                .collect::<Vec<_>>()
        };
        assert_eq!(at(7), at(7));
        assert_ne!(at(7), at(8));
        // Within a slot the flash is the same whenever it is asked for.
        let slot = (0..600)
            .find(|s| flash_at(1, 6.0, f64::from(*s)).is_some())
            .unwrap();
        assert_eq!(
            flash_at(1, 6.0, f64::from(slot)),
            flash_at(1, 6.0, f64::from(slot) + 0.9)
        );
    }

    #[test]
    fn a_flash_flickers_in_strokes_and_goes_out() {
        assert_eq!(flash_envelope(0.0), 1.0);
        assert_eq!(flash_envelope(-0.01), 0.0);
        assert_eq!(flash_envelope(FLASH_DURATION_S), 0.0);
        // Dark between the first and the second stroke, bright again at the second.
        let between = flash_envelope(0.065);
        assert!(between < 0.15, "{between}");
        assert!((flash_envelope(0.07) - 0.55).abs() < 1e-6);
        assert!(flash_envelope(0.16) >= 0.8);
    }

    #[test]
    fn only_cumulonimbus_layers_make_a_storm() {
        let lightning = Lightning::default();
        let cumulus = CloudLayer::new(CloudKind::Cumulus);
        assert_eq!(storm_rate(&lightning, [&cumulus]), 0.0);
        let storm = CloudLayer {
            coverage: 0.5,
            ..CloudLayer::new(CloudKind::Cumulonimbus)
        };
        assert_eq!(storm_rate(&lightning, [&cumulus, &storm]), 3.0);
        let forced = Lightning {
            rate_override: Some(12.0),
            ..default()
        };
        assert_eq!(storm_rate(&forced, [&cumulus]), 12.0);
    }
}
