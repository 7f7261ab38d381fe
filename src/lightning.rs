//! Lightning: storm clouds flash. Every visible cumulonimbus layer (the weather mapping makes
//! them from thunderstorm weather codes, heavy convective rain and Open-Meteo's lightning
//! potential) sets a flash rate; flashes come at random, deterministic for [`Lightning::seed`]
//! and the scene time, so a time-lapse or a test shows the same flashes again.
//!
//! A flash is a point of light inside the storm cloud for a third of a second, with three
//! strokes ([`flash_envelope`]). It takes the first of [`FLASH_PLACES`] random places within
//! [`Lightning::radius_m`] of the camera where the CPU twin finds cloud ([`flash_offset`]);
//! once a storm is on, the plugin makes the CPU copies of the cloud noise that needs in the
//! background (as [`CloudQueryPlugin`](crate::query::CloudQueryPlugin) does; seconds), and
//! until they are ready a flash takes the first place whether it is in cloud or not. The cloud
//! march lights the cloud volume from within by it
//! ([`flash_source`](crate::reference::render::flash_source): the unscattered light near the
//! flash, the diffusion approximation farther out), so it shows through the cloud as a glow,
//! and a `PointLight` under the cloud (marked [`LightningLight`]) lights the ground while the
//! flash lasts, dimmed by the cloud below it. A ground stroke ([`Lightning::ground_strokes`])
//! also shows its channel as a jagged emissive ribbon ([`LightningBolt`]). Without a storm
//! nothing is lit, no light or channel exists and the march's flash term is skipped: lightning
//! costs nothing.

use bevy::{
    asset::RenderAssetUsages,
    camera::visibility::NoFrustumCulling,
    light::NotShadowCaster,
    mesh::{Indices, PrimitiveTopology},
    prelude::*,
};

use crate::{
    CloudscapeSystems,
    layers::{CloudKind, CloudLayer},
    query::{CloudQuery, CpuCloudTextures, add_cpu_noise},
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
    /// Share of flashes that strike the ground, 0–1: their channel shows below the cloud as a
    /// bright, jagged line ([`LightningBolt`]). Default 0.25 (about a quarter of flashes are
    /// cloud-to-ground; Rakov & Uman 2003).
    pub ground_strokes: f32,
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
            ground_strokes: 0.25,
        }
    }
}

impl Lightning {
    /// A copy with every number in its range: a NaN or infinite field takes its default, the
    /// rest are clamped (rates, intensity and radius at least 0, shares to 0–1). Returns the
    /// copy and the names of the fields that were not finite.
    #[must_use]
    pub fn sanitized(&self) -> (Self, Vec<&'static str>) {
        let defaults = Self::default();
        let mut bad = Vec::new();
        let mut finite = |name, value: f32, default: f32| {
            if value.is_finite() {
                value
            } else {
                bad.push(name);
                default
            }
        };
        let clean = Self {
            flashes_per_minute: finite(
                "flashes_per_minute",
                self.flashes_per_minute,
                defaults.flashes_per_minute,
            )
            .max(0.0),
            rate_override: self
                .rate_override
                .map(|rate| finite("rate_override", rate, 0.0).max(0.0)),
            peak_intensity_cd: finite(
                "peak_intensity_cd",
                self.peak_intensity_cd,
                defaults.peak_intensity_cd,
            )
            .max(0.0),
            radius_m: finite("radius_m", self.radius_m, defaults.radius_m).max(0.0),
            height_fraction: finite(
                "height_fraction",
                self.height_fraction,
                defaults.height_fraction,
            )
            .clamp(0.0, 1.0),
            ground_strokes: finite(
                "ground_strokes",
                self.ground_strokes,
                defaults.ground_strokes,
            )
            .clamp(0.0, 1.0),
            ..self.clone()
        };
        (clean, bad)
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
    /// Scene time the flash began, Unix seconds: it picks the channel's path.
    pub start_s: f64,
    /// Whether it strikes the ground ([`Lightning::ground_strokes`]), its channel then drawn
    /// from [`Flash::position`] down to [`Flash::ground_y`].
    pub strikes_ground: bool,
    /// Scene height of the ground under the flash, metres.
    pub ground_y: f32,
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

/// The visible channel of a ground stroke: a camera-facing ribbon along [`bolt_path`] with an
/// emissive material, present while the stroke shines. It is scene geometry, so the clouds in
/// front of it hide it.
#[derive(Component, Debug)]
pub struct LightningBolt;

/// Drawn width of a ground stroke's channel, metres. The channel itself is centimetres wide;
/// its glow and the eye's blur make it look metres wide from kilometres away. Its luminance is
/// the flash's intensity spread over the drawn ribbon.
pub const BOLT_WIDTH_M: f32 = 6.0;

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
    /// A uniform number in [0, 1) of the flash's own: it strikes the ground when this is below
    /// [`Lightning::ground_strokes`].
    pub ground_draw: f32,
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
    let start_s = slot as f64 * FLASH_SLOT_S;
    Some(FlashEvent {
        start_s,
        // Uniform over the disc.
        offset: flash_offset(seed, start_s, 0),
        strength: (0.5 + 0.5 * uniform(seed, slot, 3)) as f32,
        ground_draw: uniform(seed, slot, 4) as f32,
    })
}

/// How many places in the storm's disc a flash tries, the event's own first, for one inside
/// the cloud ([`flash_offset`]).
pub const FLASH_PLACES: u64 = 12;

/// The `k`-th place a flash starting at `start_s` may take, as an offset on the unit disc
/// (times [`Lightning::radius_m`] around the camera): `k = 0` is its event's own
/// ([`FlashEvent::offset`]), the others drawn from `seed` and the flash's slot alone.
#[must_use]
pub fn flash_offset(seed: u64, start_s: f64, k: u64) -> Vec2 {
    let slot = (start_s / FLASH_SLOT_S).floor() as i64;
    let (a, b) = if k == 0 {
        (1, 2)
    } else {
        (100 + 2 * k, 101 + 2 * k)
    };
    let radius = uniform(seed, slot, a).sqrt();
    let angle = std::f64::consts::TAU * uniform(seed, slot, b);
    Vec2::new((radius * angle.cos()) as f32, (radius * angle.sin()) as f32)
}

/// Segments of a ground stroke's channel ([`bolt_path`]).
pub const BOLT_SEGMENTS: usize = 40;

/// Most sideways step of a ground stroke's channel per segment ([`bolt_path`]), as a share of
/// the segment's height.
pub const BOLT_WANDER: f64 = 0.6;

/// The channel of a ground stroke from `top` down to the ground at `ground_y`: a random walk
/// sideways ([`BOLT_SEGMENTS`] segments, each stepping up to [`BOLT_WANDER`] of its height
/// aside, pulled a fifth of the way back toward the vertical each step), drawn from `seed`
/// and the flash's start alone. `BOLT_SEGMENTS + 1` points, from `top` to the ground.
#[must_use]
pub fn bolt_path(seed: u64, start_s: f64, top: Vec3, ground_y: f32) -> Vec<Vec3> {
    let slot = (start_s / FLASH_SLOT_S).floor() as i64;
    let height = f64::from(top.y - ground_y).max(0.0);
    let step = height / BOLT_SEGMENTS as f64;
    let (mut x, mut z) = (0.0_f64, 0.0_f64);
    let mut points = vec![top];
    for k in 1..=BOLT_SEGMENTS {
        let n = 16 + 2 * k as u64;
        x = 0.8 * x + (2.0 * uniform(seed, slot, n) - 1.0) * BOLT_WANDER * step;
        z = 0.8 * z + (2.0 * uniform(seed, slot, n + 1) - 1.0) * BOLT_WANDER * step;
        let y = f64::from(top.y) - step * k as f64;
        points.push(Vec3::new(top.x + x as f32, y as f32, top.z + z as f32));
    }
    points
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
    mut warned: Local<Vec<&'static str>>,
    clouds: CloudQuery,
    mut placed: Local<Option<(f64, Vec2)>>,
) {
    // A field that is not a number takes its default, with one warning while it stays bad.
    let (lightning, bad) = lightning.sanitized();
    for field in &bad {
        if !warned.contains(field) {
            warn!("bevy_cloudscape: Lightning::{field} is not a finite number; using its default");
        }
    }
    *warned = bad;
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
        // `sanitized` keeps the fraction in 0–1 and the radius and intensity at least 0.
        let height = lightning.height_fraction * (top - base);
        let radius = lightning.radius_m;
        let at = |offset: Vec2| {
            Vec3::new(
                camera.x + offset.x * radius,
                ground + base + height,
                camera.z + offset.y * radius,
            )
        };
        // Inside the cloud: the first of the flash's places where the CPU twin finds cloud
        // (once its noise is ready), kept for the flash's length.
        let unit = match *placed {
            Some((start, unit)) if start == event.start_s => unit,
            _ => {
                let unit =
                    place_in_cloud(&lightning, event, |offset| clouds.density_at(at(offset)));
                *placed = Some((event.start_s, unit));
                unit
            }
        };
        let intensity = lightning.peak_intensity_cd * event.strength * brightness;
        // Conservative scattering's diffuse transmittance through the cloud below the flash,
        // `1 / (1 + ¾ (1 − g) τ)`: the Eddington approximation's, as in the march's diffuse
        // light (Joseph, Wiscombe & Weinman 1976), with a cloud's g = 0.85.
        let tau = (density * height).max(0.0);
        let below = 1.0 / (1.0 + 0.75 * 0.15 * tau);
        (intensity > 0.0 && intensity.is_finite()).then(|| Flash {
            position: at(unit),
            intensity_cd: intensity,
            ground_lumens: 4.0 * std::f32::consts::PI * intensity * below,
            start_s: event.start_s,
            strikes_ground: event.ground_draw < lightning.ground_strokes,
            ground_y: ground,
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

/// The place of `event` in the storm's disc: the first of its [`FLASH_PLACES`] places
/// ([`flash_offset`]) where `density` (1/m, `None`: not known) finds cloud; the event's own
/// when none does or the density is not known.
fn place_in_cloud(
    lightning: &Lightning,
    event: FlashEvent,
    density: impl Fn(Vec2) -> Option<f32>,
) -> Vec2 {
    for k in 0..FLASH_PLACES {
        let offset = flash_offset(lightning.seed, event.start_s, k);
        match density(offset) {
            None => break,
            Some(sigma) if sigma > 0.0 => return offset,
            Some(_) => {}
        }
    }
    event.offset
}

/// Asks for the CPU copies of the cloud noise ([`CpuCloudTextures`]) once a storm is on, so
/// [`update_lightning`] can place its flashes inside the cloud; a scene without storms never
/// makes them.
fn want_cloud_textures(
    mut commands: Commands,
    active: Res<ActiveFlash>,
    textures: Option<Res<CpuCloudTextures>>,
) {
    if active.rate_per_minute > 0.0 && textures.is_none() {
        commands.init_resource::<CpuCloudTextures>();
    }
}

/// A ribbon `width` wide along `path`, each segment turned to face `camera`.
fn ribbon_mesh(path: &[Vec3], camera: Vec3, width: f32) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    for segment in path.windows(2) {
        let (a, b) = (segment[0], segment[1]);
        let middle = 0.5 * (a + b);
        let toward = (camera - middle).normalize_or(Vec3::Z);
        let side = (b - a).cross(toward).normalize_or(Vec3::X) * (0.5 * width);
        let first = positions.len() as u32;
        positions.extend([a - side, a + side, b - side, b + side].map(|p| p.to_array()));
        normals.extend([toward.to_array(); 4]);
        indices.extend([first, first + 2, first + 1, first + 1, first + 2, first + 3]);
    }
    let mut mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    );
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
    mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
    mesh.insert_indices(Indices::U32(indices));
    mesh
}

/// Keeps the [`LightningBolt`] on the ground stroke that shines now, facing the first camera
/// with clouds, as bright as the stroke; despawns it when none does.
pub(crate) fn update_bolt(
    mut commands: Commands,
    lightning: Res<Lightning>,
    active: Res<ActiveFlash>,
    cameras: Query<&GlobalTransform, With<VolumetricClouds>>,
    meshes: Option<ResMut<Assets<Mesh>>>,
    materials: Option<ResMut<Assets<StandardMaterial>>>,
    bolts: Query<(Entity, &Mesh3d, &MeshMaterial3d<StandardMaterial>), With<LightningBolt>>,
) {
    let strike = active.flash.filter(|flash| flash.strikes_ground);
    let camera = cameras.iter().next().map(GlobalTransform::translation);
    let (Some(flash), Some(camera), Some(mut meshes), Some(mut materials)) =
        (strike, camera, meshes, materials)
    else {
        for (entity, ..) in &bolts {
            commands.entity(entity).despawn();
        }
        return;
    };
    let path = bolt_path(
        lightning.seed,
        flash.start_s,
        flash.position,
        flash.ground_y,
    );
    let length: f32 = path.windows(2).map(|w| w[0].distance(w[1])).sum();
    let luminance = flash.intensity_cd / (BOLT_WIDTH_M * length.max(1.0));
    let emissive = LinearRgba::rgb(0.9, 0.93, 1.0) * luminance;
    let mesh = ribbon_mesh(&path, camera, BOLT_WIDTH_M);
    if let Some((_, mesh_handle, material_handle)) = bolts.iter().next() {
        if let Some(mut old) = meshes.get_mut(&mesh_handle.0) {
            *old = mesh;
        }
        if let Some(mut material) = materials.get_mut(&material_handle.0) {
            material.emissive = emissive;
        }
    } else {
        commands.spawn((
            Name::new("lightning bolt"),
            LightningBolt,
            Mesh3d(meshes.add(mesh)),
            MeshMaterial3d(materials.add(StandardMaterial {
                base_color: Color::BLACK,
                emissive,
                perceptual_roughness: 1.0,
                // Seen from either side.
                double_sided: true,
                cull_mode: None,
                ..default()
            })),
            Transform::IDENTITY,
            NotShadowCaster,
            NoFrustumCulling,
        ));
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
                (update_lightning, update_bolt, want_cloud_textures)
                    .chain()
                    .in_set(CloudscapeSystems::Sun)
                    .after(CloudscapeSystems::Layers),
            );
        // The CPU noise, made once `want_cloud_textures` asks for it.
        add_cpu_noise(app);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An app with the lightning plugin and a camera with clouds 2 m up, its storm asking for a
    /// small CPU noise (16³ base) so the task pool the tests share is not held for long.
    fn lightning_app() -> App {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Mesh>()
            .init_asset::<StandardMaterial>()
            .init_resource::<SceneClock>()
            .insert_resource(crate::render::noise::CloudNoiseSettings(
                crate::reference::noise::NoiseRecipe {
                    base_size: 16,
                    detail_size: 8,
                    weather_size: 32,
                    ..default()
                },
            ))
            .add_plugins(LightningPlugin);
        app.world_mut().spawn((
            Camera::default(),
            VolumetricClouds::default(),
            GlobalTransform::from_xyz(0.0, 2.0, 0.0),
        ));
        app
    }

    /// Sets the paused scene clock to `seconds` and runs `frames` frames.
    fn run_at(app: &mut App, seconds: f64, frames: u32) {
        let mut clock = SceneClock::at(crate::scene::UtcInstant::from_unix_seconds(0));
        clock.set_unix_seconds(seconds);
        clock.paused = true;
        app.insert_resource(clock);
        for _ in 0..frames {
            app.update();
        }
    }

    #[test]
    fn flashes_come_at_the_rate_and_the_same_for_a_seed() {
        let count = |seed, rate| {
            (0..60_000)
                .filter(|s| flash_at(seed, rate, f64::from(*s) + 0.5).is_some())
                .count()
        };
        // 6 a minute over 1000 minutes: the count is binomial over 60 000 seconds with a
        // chance of 0.1 each, mean 6000, standard deviation √(60 000 · 0.1 · 0.9) ≈ 73.5; a
        // fair draw is within four of them.
        let six = count(0, 6.0) as f64;
        let sigma = (60_000.0_f64 * 0.1 * 0.9).sqrt();
        assert!((six - 6000.0).abs() < 4.0 * sigma, "{six}");
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
        // It flickers: just before the second stroke the light is under half of what that
        // stroke brings, and each stroke jumps to its own brightness.
        let [_, (second, second_brightness), (third, third_brightness)] = FLASH_STROKES;
        let before = flash_envelope(second - 0.005);
        assert!(before < 0.5 * second_brightness, "{before}");
        // And dark between the strokes: under 15 % of the flash's peak.
        assert!(before < 0.15 * FLASH_STROKES[0].1, "{before}");
        assert_eq!(flash_envelope(second), second_brightness);
        assert_eq!(flash_envelope(third), third_brightness);
    }

    #[test]
    fn a_ground_stroke_wanders_down_to_the_ground_the_same_each_time() {
        let top = Vec3::new(100.0, 4_000.0, -50.0);
        let path = bolt_path(5, 120.0, top, 500.0);
        assert_eq!(path.len(), BOLT_SEGMENTS + 1);
        assert_eq!(path[0], top);
        assert!((path[BOLT_SEGMENTS].y - 500.0).abs() < 1e-2);
        assert!(path.windows(2).all(|w| w[1].y < w[0].y), "always downward");
        // Sideways within the walk's bound: each step at most 0.6 of a segment's 87.5 m, and
        // the pull back keeps it within five steps (0.6 · 87.5 / 0.2 ≈ 263 m) of the vertical.
        let aside = path
            .iter()
            .map(|p| Vec2::new(p.x - top.x, p.z - top.z).length())
            .fold(0.0, f32::max);
        assert!(aside > 1.0 && aside < 263.0 * 2f32.sqrt(), "{aside}");
        assert_eq!(path, bolt_path(5, 120.0, top, 500.0));
        assert_ne!(path, bolt_path(5, 121.0, top, 500.0));
    }

    #[test]
    fn a_flash_takes_its_first_place_in_cloud() {
        let lightning = Lightning::default();
        let event = flash_at(lightning.seed, 60.0, 1_000.0).unwrap();
        let place = |k| flash_offset(lightning.seed, event.start_s, k);
        assert_eq!(place(0), event.offset);
        // Cloud at the fourth place only.
        let cloud_at =
            |k: u64| move |offset: Vec2| Some(if offset == place(k) { 0.01 } else { 0.0 });
        assert_eq!(place_in_cloud(&lightning, event, cloud_at(3)), place(3));
        // Clear air everywhere, or no density known: the event's own place.
        assert_eq!(
            place_in_cloud(&lightning, event, |_| Some(0.0)),
            event.offset
        );
        assert_eq!(place_in_cloud(&lightning, event, |_| None), event.offset);
        // The places differ from each other and from flash to flash.
        assert_ne!(place(1), place(2));
        assert_ne!(
            place(1),
            flash_offset(lightning.seed, event.start_s + 1.0, 1)
        );
    }

    /// In an app, a storm makes the CPU noise on its own and its flashes go into the cloud:
    /// every flash with a place in cloud among its tries takes one.
    #[test]
    fn flashes_are_placed_inside_the_storm_cloud() {
        use crate::{reference::render::CloudTextures, render::noise::CloudNoiseSettings};
        use bevy::ecs::system::RunSystemOnce;
        let mut app = lightning_app();
        app.world_mut().spawn(CloudLayer {
            coverage: 0.3,
            ..CloudLayer::new(CloudKind::Cumulonimbus)
        });
        *app.world_mut().resource_mut::<Lightning>() = Lightning {
            rate_override: Some(60.0),
            ..default()
        };
        let at = |app: &mut App, seconds: f64| run_at(app, seconds, 1);
        // No storm, no CPU noise; a storm asks for it.
        let storm = app.world().resource::<Lightning>().clone();
        *app.world_mut().resource_mut::<Lightning>() = Lightning {
            rate_override: Some(0.0),
            ..default()
        };
        at(&mut app, 999.5);
        at(&mut app, 999.6);
        assert!(!app.world().contains_resource::<CpuCloudTextures>());
        *app.world_mut().resource_mut::<Lightning>() = storm;
        at(&mut app, 999.7);
        assert!(app.world().contains_resource::<CpuCloudTextures>());
        // Made here rather than on the task pool the test harness's threads share.
        let recipe = app.world().resource::<CloudNoiseSettings>().0.clone();
        let textures = CloudTextures::from_recipe(&recipe);
        app.insert_resource(CpuCloudTextures {
            ready: Some((recipe, std::sync::Arc::new(textures))),
            pending: None,
        });
        let density = |app: &mut App, point: Vec3| {
            app.world_mut()
                .run_system_once(move |clouds: CloudQuery| clouds.density_at(point))
                .unwrap()
                .unwrap()
        };
        let (mut inside, mut could) = (0, 0);
        let lightning = app.world().resource::<Lightning>().clone();
        for second in 1_000..1_040 {
            at(&mut app, f64::from(second));
            let flash = app.world().resource::<ActiveFlash>().flash.unwrap();
            let in_cloud = density(&mut app, flash.position) > 0.0;
            inside += usize::from(in_cloud);
            let any = (0..FLASH_PLACES).any(|k| {
                let offset =
                    flash_offset(lightning.seed, f64::from(second), k) * lightning.radius_m;
                let point = Vec3::new(offset.x, flash.position.y, offset.y);
                density(&mut app, point) > 0.0
            });
            could += usize::from(any);
            assert!(
                in_cloud || !any,
                "second {second}: a place in cloud was passed over"
            );
        }
        println!("{inside} of 40 flashes in cloud ({could} could be)");
        assert!(
            inside >= 20,
            "most flashes are in the cloud: {inside} of 40"
        );
    }

    #[test]
    fn a_ground_stroke_draws_its_channel_and_only_while_it_shines() {
        let mut app = lightning_app();
        // Every second flashes, and every flash strikes the ground.
        *app.world_mut().resource_mut::<Lightning>() = Lightning {
            rate_override: Some(60.0),
            ground_strokes: 1.0,
            ..default()
        };
        let bolts = |app: &mut App| {
            let world = app.world_mut();
            world
                .query_filtered::<(), With<LightningBolt>>()
                .iter(world)
                .count()
        };
        let at = |app: &mut App, seconds: f64| run_at(app, seconds, 2);
        at(&mut app, 1_000.0);
        assert_eq!(bolts(&mut app), 1, "a stroke at its first peak");
        let flash = app.world().resource::<ActiveFlash>().flash.unwrap();
        assert!(flash.strikes_ground && flash.ground_y == 0.0);
        // Past the flash's last stroke it is gone.
        at(&mut app, 1_000.0 + FLASH_DURATION_S + 0.01);
        assert_eq!(bolts(&mut app), 0, "dark between flashes");
        // Cloud-to-cloud flashes draw none.
        app.world_mut().resource_mut::<Lightning>().ground_strokes = 0.0;
        at(&mut app, 1_000.0);
        assert_eq!(bolts(&mut app), 0, "no ground stroke");
    }

    #[test]
    fn bad_numbers_take_their_defaults_and_are_named() {
        let bad = Lightning {
            flashes_per_minute: f32::NAN,
            rate_override: Some(f32::INFINITY),
            peak_intensity_cd: -5.0,
            height_fraction: f32::NAN,
            ground_strokes: 3.0,
            ..default()
        };
        let (clean, named) = bad.sanitized();
        assert_eq!(
            named,
            ["flashes_per_minute", "rate_override", "height_fraction"]
        );
        let defaults = Lightning::default();
        assert_eq!(clean.flashes_per_minute, defaults.flashes_per_minute);
        assert_eq!(clean.rate_override, Some(0.0));
        assert_eq!(clean.peak_intensity_cd, 0.0);
        assert_eq!(clean.height_fraction, defaults.height_fraction);
        assert_eq!(clean.ground_strokes, 1.0);
        assert_eq!(defaults.sanitized(), (defaults.clone(), Vec::new()));
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
