//! Rain and snow near the camera: streaks (rain) or flakes (snow) falling through a box that
//! follows the camera, as many as the rain rate calls for.
//!
//! # Where the numbers come from
//!
//! [`precipitation_look`] turns a rain rate (mm/h of water) and the snow fraction into what
//! falls:
//!
//! - **How many.** Raindrops follow the Marshall–Palmer size distribution (Marshall & Palmer
//!   1948): `N(D) = N₀ e^(−ΛD)` with `N₀ = 8000 m⁻³ mm⁻¹` and `Λ = 4.1 R^(−0.21) mm⁻¹` for a rate
//!   `R` in mm/h. Drops of 1 mm and more, the ones the eye catches as streaks, number
//!   `N(>1 mm) = (N₀ / Λ) e^(−Λ)` per m³: about 32 at 1 mm/h, 260 at 10 mm/h and 720 at
//!   50 mm/h. The particle count is that concentration relative to a 50 mm/h downpour
//!   ([`HEAVY_RAIN_MM_PER_H`]) times [`PrecipitationSettings::max_particles`]: zero without rain,
//!   rising monotonically with the rate. Snow uses the same count for its water-equivalent rate.
//! - **How fast.** Rain falls at the terminal speed of the median-volume drop,
//!   `D₀ = 3.67 / Λ` (Marshall–Palmer), from Atlas et al. 1973:
//!   `v = 9.65 − 10.3 e^(−0.6 D₀)` m/s (about 3.6 m/s at 1 mm/h, 6.1 m/s at 25 mm/h). Snowflakes
//!   fall at about 1 m/s (Locatelli & Hobbs 1974: 0.5–1.5 m/s for aggregates).
//! - **Rain or snow.** Snow when the snow fraction is above one half. Without a forecast snow
//!   fraction it comes from the forecast's 2 m temperature carried up to the camera by the
//!   standard lapse rate, 6.5 K/km (ICAO standard atmosphere), and split around 1 °C, the mean
//!   rain–snow threshold over land (Jennings et al. 2018, "Spatial variation of the rain–snow
//!   temperature threshold across the Northern Hemisphere"): all snow at 0 °C and below, all
//!   rain at 2 °C and above ([`snow_fraction_at`]). A camera on a hill sees the snow line.
//!
//! The rate is the largest [`CloudLayer::rain_mm_per_h`] of the visible layers (the weather
//! mapping puts the forecast's precipitation there, and play mode's sliders too); the snow fraction
//! is the near forecast's (or its temperature's), unless [`PrecipitationSettings::snow_fraction`]
//! overrides it. The wind
//! of the lowest raining layer carries the particles sideways.
//!
//! # Rendering
//!
//! One mesh of camera-facing quads with an unlit, alpha-blended `StandardMaterial`, rewritten on
//! the CPU each frame (a few thousand quads): each particle falls and drifts, wraps around the
//! box centred on the camera, and its quad is stretched along its motion for rain (a streak as
//! long as the drop moves in [`STREAK_EXPOSURE_S`]) or square for snow. Particles beyond the count
//! the rate calls for collapse to nothing. Animation runs on real time, not the scene clock: a
//! time-lapse at 3600× does not turn rain into lines.

use bevy::{
    asset::RenderAssetUsages,
    camera::visibility::NoFrustumCulling,
    light::NotShadowCaster,
    mesh::{Indices, PrimitiveTopology},
    prelude::*,
};

use crate::{
    CloudscapeSystems,
    layers::{CloudLayer, rain::marshall_palmer_slope},
    render::VolumetricClouds,
    weather::{CurrentWeather, Variable},
};

/// The rain rate at which the particle count reaches [`PrecipitationSettings::max_particles`],
/// mm/h: a heavy shower.
pub const HEAVY_RAIN_MM_PER_H: f32 = 50.0;

/// How long a raindrop's streak lasts on screen, seconds: the streak is the distance it falls
/// in this time, as a camera at a 1/25 s shutter records it.
pub const STREAK_EXPOSURE_S: f32 = 0.04;

/// Fall speed of snowflakes, m/s (Locatelli & Hobbs 1974).
pub const SNOW_FALL_SPEED_M_S: f32 = 1.0;

/// Settings of the rain and snow near the camera.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default)]
pub struct PrecipitationSettings {
    /// Draw rain and snow. Default true.
    pub enabled: bool,
    /// Particles at [`HEAVY_RAIN_MM_PER_H`] and above. Default 6000.
    pub max_particles: u32,
    /// Half the side of the box of particles around the camera, metres. Default 20.
    pub radius_m: f32,
    /// Snow fraction to use instead of the forecast's, 0–1. Default `None` (the forecast's; 0
    /// without one).
    pub snow_fraction: Option<f32>,
}

impl Default for PrecipitationSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            max_particles: 6000,
            radius_m: 20.0,
            snow_fraction: None,
        }
    }
}

/// What falls.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Reflect)]
pub enum PrecipitationKind {
    /// Nothing.
    #[default]
    None,
    /// Raindrops, drawn as streaks.
    Rain,
    /// Snowflakes.
    Snow,
}

/// The precipitation this frame, from [`precipitation_look`] (read it, do not write it).
#[derive(Resource, Clone, Copy, Debug, PartialEq, Default, Reflect)]
#[reflect(Resource, Default)]
pub struct PrecipitationState {
    /// Rain, snow or nothing.
    pub kind: PrecipitationKind,
    /// Water-equivalent rate, mm/h.
    pub rate_mm_per_h: f32,
    /// Concentration of drops of 1 mm and more relative to a [`HEAVY_RAIN_MM_PER_H`] downpour,
    /// 0–1: the share of the particles drawn.
    pub intensity: f32,
    /// Fall speed, m/s.
    pub fall_speed_m_s: f32,
}

/// Concentration of raindrops of 1 mm diameter and more, per m³, at `rate_mm_per_h` (Marshall &
/// Palmer 1948): `(N₀ / Λ) e^(−Λ)`. 0 for no or invalid rain.
#[must_use]
pub fn large_drop_concentration(rate_mm_per_h: f32) -> f32 {
    if rate_mm_per_h.is_nan() || rate_mm_per_h <= 0.0 || !rate_mm_per_h.is_finite() {
        return 0.0;
    }
    let slope = marshall_palmer_slope(rate_mm_per_h);
    8000.0 / slope * (-slope).exp()
}

/// Standard temperature lapse rate of the troposphere, K per metre (ICAO standard atmosphere).
pub const LAPSE_RATE_K_PER_M: f32 = 0.0065;

/// The fraction of precipitation that falls as snow `height_m` metres above a station that
/// measures `temperature_c` °C at 2 m: the temperature there by [`LAPSE_RATE_K_PER_M`], then 1
/// at 0 °C and below, 0 at 2 °C and above, linear between (the [module docs](self) give the
/// source). A NaN input gives 0 (rain).
#[must_use]
pub fn snow_fraction_at(temperature_c: f32, height_m: f32) -> f32 {
    let temperature = temperature_c - LAPSE_RATE_K_PER_M * height_m;
    if temperature.is_nan() {
        return 0.0;
    }
    ((ALL_RAIN_C - temperature) / (ALL_RAIN_C - ALL_SNOW_C)).clamp(0.0, 1.0)
}

/// Air temperature at and below which all precipitation is snow, °C ([`snow_fraction_at`]).
const ALL_SNOW_C: f32 = 0.0;
/// Air temperature at and above which all precipitation is rain, °C ([`snow_fraction_at`]).
const ALL_RAIN_C: f32 = 2.0;

/// The snow line: how far above a station that measures `temperature_c` °C at 2 m half of the
/// precipitation falls as snow ([`snow_fraction_at`] is one half there), metres (negative when
/// the station itself is colder). `None` for a temperature that is not finite.
#[must_use]
pub fn snow_line_height_m(temperature_c: f32) -> Option<f32> {
    temperature_c
        .is_finite()
        .then(|| (temperature_c - 0.5 * (ALL_SNOW_C + ALL_RAIN_C)) / LAPSE_RATE_K_PER_M)
}

/// What falls at `rate_mm_per_h` (water equivalent) with `snow_fraction` (0–1) of it snow. See
/// the [module docs](self) for the formulas. NaN, infinite or negative inputs count as none.
#[must_use]
pub fn precipitation_look(rate_mm_per_h: f32, snow_fraction: f32) -> PrecipitationState {
    let rate = if rate_mm_per_h.is_finite() && rate_mm_per_h > 0.0 {
        rate_mm_per_h
    } else {
        return PrecipitationState::default();
    };
    let intensity =
        (large_drop_concentration(rate) / large_drop_concentration(HEAVY_RAIN_MM_PER_H)).min(1.0);
    let snow = snow_fraction.is_finite() && snow_fraction > 0.5;
    let fall_speed_m_s = if snow {
        SNOW_FALL_SPEED_M_S
    } else {
        let median_volume_diameter_mm = 3.67 / marshall_palmer_slope(rate);
        9.65 - 10.3 * (-0.6 * median_volume_diameter_mm).exp()
    };
    PrecipitationState {
        kind: if snow {
            PrecipitationKind::Snow
        } else {
            PrecipitationKind::Rain
        },
        rate_mm_per_h: rate,
        intensity,
        fall_speed_m_s,
    }
}

/// Draws rain and snow near the camera; part of [`crate::CloudscapePlugin`].
#[derive(Debug, Default, Clone, Copy)]
pub struct PrecipitationPlugin;

impl Plugin for PrecipitationPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<PrecipitationSettings>()
            .init_resource::<PrecipitationState>()
            .register_type::<PrecipitationSettings>()
            .register_type::<PrecipitationState>()
            .add_systems(
                Update,
                (update_precipitation_state, animate_precipitation)
                    .chain()
                    .after(CloudscapeSystems::Layers),
            );
    }
}

fn update_precipitation_state(
    settings: Res<PrecipitationSettings>,
    current: Option<Res<CurrentWeather>>,
    layers: Query<&CloudLayer>,
    cameras: Query<&GlobalTransform, With<VolumetricClouds>>,
    mut state: ResMut<PrecipitationState>,
) {
    let rate = layers
        .iter()
        .filter(|layer| layer.is_visible())
        .map(|layer| layer.rain_mm_per_h)
        .filter(|r| r.is_finite())
        .fold(0.0, f32::max);
    let camera_height = cameras.iter().next().map_or(0.0, |t| t.translation().y);
    let snow_fraction = settings.snow_fraction.unwrap_or_else(|| {
        let near = current.as_ref().and_then(|c| c.near.as_ref());
        near.and_then(|near| {
            near.state.get(Variable::SnowFraction).or_else(|| {
                let temperature = near.state.get(Variable::Temperature)?;
                Some(snow_fraction_at(temperature, camera_height))
            })
        })
        .unwrap_or(0.0)
    });
    let look = if settings.enabled {
        precipitation_look(rate, snow_fraction)
    } else {
        PrecipitationState::default()
    };
    if *state != look {
        *state = look;
    }
}

/// The particle cloud: positions in world space, kept inside the box around the camera.
#[derive(Component, Debug, Default)]
pub struct PrecipitationParticles {
    positions: Vec<Vec3>,
    /// The mesh whose quads are rewritten each frame.
    mesh: Handle<Mesh>,
    /// How many quads are drawn now (the rest are collapsed).
    pub active: u32,
}

/// A small deterministic scatter (a 32-bit integer hash), so the particles start the same every
/// run.
fn scatter(index: u32, axis: u32) -> f32 {
    let mut x = index
        .wrapping_mul(0x9E37_79B9)
        .wrapping_add(axis.wrapping_mul(0x85EB_CA6B));
    x ^= x >> 16;
    x = x.wrapping_mul(0x7FEB_352D);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846C_A68B);
    x ^= x >> 16;
    x as f32 / u32::MAX as f32
}

fn animate_precipitation(
    mut commands: Commands,
    time: Res<Time>,
    settings: Res<PrecipitationSettings>,
    state: Res<PrecipitationState>,
    layers: Query<&CloudLayer>,
    cameras: Query<(&Camera, &GlobalTransform), With<VolumetricClouds>>,
    meshes: Option<ResMut<Assets<Mesh>>>,
    materials: Option<ResMut<Assets<StandardMaterial>>>,
    mut particles: Query<(
        &mut PrecipitationParticles,
        &mut Visibility,
        &MeshMaterial3d<StandardMaterial>,
    )>,
) {
    let (Some(mut meshes), Some(mut materials)) = (meshes, materials) else {
        return;
    };
    let count = settings.max_particles.min(200_000) as usize;
    let Ok((mut cloud, mut visibility, material)) = particles.single_mut() else {
        if state.kind != PrecipitationKind::None && count > 0 {
            spawn_particles(&mut commands, &mut meshes, &mut materials, count);
        }
        return;
    };
    let Some((_, camera)) = cameras
        .iter()
        .filter(|(camera, _)| camera.is_active)
        .min_by_key(|(camera, _)| camera.order)
    else {
        return;
    };
    if state.kind == PrecipitationKind::None || count == 0 {
        *visibility = Visibility::Hidden;
        cloud.active = 0;
        return;
    }
    *visibility = Visibility::Inherited;
    if cloud.positions.len() != count {
        spawn_positions(&mut cloud.positions, count, settings.radius_m);
    }
    if let Some(mut material) = materials.get_mut(&material.0) {
        let colour = match state.kind {
            PrecipitationKind::Snow => Color::srgba(1.0, 1.0, 1.0, 0.85),
            _ => Color::srgba(0.75, 0.8, 0.85, 0.35),
        };
        if material.base_color != colour {
            material.base_color = colour;
        }
    }
    // The lowest raining layer's wind carries the particles ([east, north] → world x, −z).
    let wind = layers
        .iter()
        .filter(|layer| layer.is_visible() && layer.rain_mm_per_h > 0.0)
        .min_by(|a, b| a.base_m.total_cmp(&b.base_m))
        .map_or(Vec3::ZERO, |layer| {
            Vec3::new(layer.wind_m_s[0], 0.0, -layer.wind_m_s[1])
        });
    let velocity = wind - Vec3::Y * state.fall_speed_m_s;
    let dt = time.delta_secs().min(0.1);
    let centre = camera.translation();
    let radius = settings.radius_m.max(1.0);
    let side = 2.0 * radius;
    for p in &mut cloud.positions {
        *p += velocity * dt;
        let offset = *p - centre + Vec3::splat(radius);
        *p = centre - Vec3::splat(radius) + offset.rem_euclid(Vec3::splat(side));
    }
    cloud.active = (state.intensity * count as f32).round() as u32;

    // Camera-facing quads: rain streaks along the motion, snow squares.
    let view = camera.forward().as_vec3();
    let (half_width, along) = match state.kind {
        PrecipitationKind::Snow => (0.012, Vec3::Y * 0.012),
        // Streaks a little wider than a drop (2–5 mm), so they stay visible a few metres away.
        _ => (0.006, -velocity * STREAK_EXPOSURE_S * 0.5),
    };
    let side_dir = view.cross(along).normalize_or_zero() * half_width;
    let Some(mut mesh) = meshes.get_mut(&cloud.mesh) else {
        return;
    };
    let mut vertices = Vec::with_capacity(count * 4);
    for (i, p) in cloud.positions.iter().enumerate() {
        if i < cloud.active as usize {
            vertices.extend([
                (*p - along - side_dir).to_array(),
                (*p - along + side_dir).to_array(),
                (*p + along + side_dir).to_array(),
                (*p + along - side_dir).to_array(),
            ]);
        } else {
            vertices.extend([p.to_array(); 4]);
        }
    }
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, vertices);
}

fn spawn_positions(positions: &mut Vec<Vec3>, count: usize, radius: f32) {
    positions.clear();
    positions.extend((0..count as u32).map(|i| {
        Vec3::new(scatter(i, 0), scatter(i, 1), scatter(i, 2)) * 2.0 * radius - Vec3::splat(radius)
    }));
}

fn spawn_particles(
    commands: &mut Commands,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
    count: usize,
) {
    let mut mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::RENDER_WORLD | RenderAssetUsages::MAIN_WORLD,
    );
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; count * 4]);
    mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0f32, 1.0, 0.0]; count * 4]);
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, vec![[0.0f32, 0.0]; count * 4]);
    let indices: Vec<u32> = (0..count as u32)
        .flat_map(|q| {
            let v = q * 4;
            [v, v + 1, v + 2, v, v + 2, v + 3]
        })
        .collect();
    mesh.insert_indices(Indices::U32(indices));
    let mesh = meshes.add(mesh);
    let material = materials.add(StandardMaterial {
        base_color: Color::srgba(0.75, 0.8, 0.85, 0.35),
        unlit: true,
        alpha_mode: AlphaMode::Blend,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    commands.spawn((
        Name::new("precipitation"),
        Mesh3d(mesh.clone()),
        MeshMaterial3d(material),
        Transform::IDENTITY,
        Visibility::Hidden,
        NotShadowCaster,
        NoFrustumCulling,
        PrecipitationParticles {
            positions: Vec::new(),
            mesh,
            active: 0,
        },
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_rain_means_nothing_falls() {
        for rate in [0.0, -1.0, f32::NAN, f32::NEG_INFINITY] {
            let look = precipitation_look(rate, 0.0);
            assert_eq!(look.kind, PrecipitationKind::None);
            assert_eq!(look.intensity, 0.0);
        }
        assert_eq!(large_drop_concentration(0.0), 0.0);
    }

    #[test]
    fn intensity_rises_monotonically_with_the_rate() {
        let mut last = 0.0;
        for k in 1..=400 {
            let rate = k as f32 * 0.25;
            let look = precipitation_look(rate, 0.0);
            assert_eq!(look.kind, PrecipitationKind::Rain);
            assert!(look.intensity > 0.0 && look.intensity <= 1.0);
            assert!(
                look.intensity >= last,
                "{rate} mm/h: {} < {last}",
                look.intensity
            );
            last = look.intensity;
        }
        assert_eq!(precipitation_look(HEAVY_RAIN_MM_PER_H, 0.0).intensity, 1.0);
        // Marshall–Palmer counts of drops ≥ 1 mm: about 32 /m³ at 1 mm/h, 260 at 10 mm/h.
        assert!((large_drop_concentration(1.0) - 32.3).abs() < 1.0);
        assert!((large_drop_concentration(10.0) - 261.0).abs() < 10.0);
    }

    #[test]
    fn drops_fall_faster_in_heavier_rain_and_snow_falls_slowly() {
        let light = precipitation_look(1.0, 0.0).fall_speed_m_s;
        let heavy = precipitation_look(25.0, 0.0).fall_speed_m_s;
        assert!((3.4..3.9).contains(&light), "{light}");
        assert!((5.8..6.4).contains(&heavy), "{heavy}");
        assert_eq!(
            precipitation_look(5.0, 0.9).fall_speed_m_s,
            SNOW_FALL_SPEED_M_S
        );
    }

    #[test]
    fn the_snow_line_follows_the_temperature_and_the_lapse_rate() {
        assert_eq!(snow_fraction_at(5.0, 0.0), 0.0);
        assert_eq!(snow_fraction_at(-3.0, 0.0), 1.0);
        assert!((snow_fraction_at(1.0, 0.0) - 0.5).abs() < 1e-6);
        // 4 °C in the valley is rain; 600 m up it is 0.1 °C: nearly all snow.
        assert!((snow_fraction_at(4.0, 600.0) - 0.95).abs() < 1e-3);
        assert_eq!(snow_fraction_at(f32::NAN, 0.0), 0.0);
        // The snow line is where the fraction is one half: 4 °C puts it about 460 m up.
        for temperature in [-5.0_f32, 1.0, 4.0, 15.0] {
            let line = snow_line_height_m(temperature).unwrap();
            assert!((snow_fraction_at(temperature, line) - 0.5).abs() < 1e-4);
        }
        assert!((snow_line_height_m(4.0).unwrap() - 461.5).abs() < 0.1);
        assert_eq!(snow_line_height_m(f32::NAN), None);
        assert_eq!(snow_line_height_m(f32::INFINITY), None);
        // Monotone: colder or higher never melts the snow.
        let mut last = 0.0;
        for i in 0..100 {
            let f = snow_fraction_at(3.0 - 0.05 * i as f32, 0.0);
            assert!(f >= last);
            last = f;
        }
    }

    #[test]
    fn snow_replaces_rain_above_half_snow_fraction() {
        assert_eq!(precipitation_look(2.0, 0.5).kind, PrecipitationKind::Rain);
        assert_eq!(precipitation_look(2.0, 0.51).kind, PrecipitationKind::Snow);
        assert_eq!(precipitation_look(2.0, 1.0).kind, PrecipitationKind::Snow);
        assert_eq!(
            precipitation_look(2.0, f32::NAN).kind,
            PrecipitationKind::Rain
        );
        // The same water falls: snow keeps the count of its water-equivalent rate.
        assert_eq!(
            precipitation_look(2.0, 1.0).intensity,
            precipitation_look(2.0, 0.0).intensity
        );
    }

    #[test]
    fn particles_follow_the_layers_rain() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Mesh>()
            .init_asset::<StandardMaterial>()
            .add_plugins(PrecipitationPlugin);
        app.world_mut().spawn((
            Camera::default(),
            VolumetricClouds::default(),
            GlobalTransform::from_xyz(100.0, 2.0, -50.0),
        ));
        let layer = app
            .world_mut()
            .spawn(CloudLayer {
                rain_mm_per_h: 10.0,
                ..CloudLayer::new(crate::layers::CloudKind::Stratus)
            })
            .id();
        for _ in 0..3 {
            app.update();
        }
        let state = *app.world().resource::<PrecipitationState>();
        assert_eq!(state.kind, PrecipitationKind::Rain);
        let active = |app: &mut App| {
            let world = app.world_mut();
            world
                .query::<&PrecipitationParticles>()
                .single(world)
                .map(|p| p.active)
                .unwrap()
        };
        let expected = (state.intensity * 6000.0).round() as u32;
        assert_eq!(active(&mut app), expected);
        assert!(expected > 0);
        // Every particle stays inside the box around the camera.
        {
            let world = app.world_mut();
            let particles = world
                .query::<&PrecipitationParticles>()
                .single(world)
                .unwrap();
            let centre = Vec3::new(100.0, 2.0, -50.0);
            assert!(
                particles
                    .positions
                    .iter()
                    .all(|p| (*p - centre).abs().max_element() <= 20.0 + 1e-3)
            );
        }
        app.world_mut()
            .get_mut::<CloudLayer>(layer)
            .unwrap()
            .rain_mm_per_h = 0.0;
        app.update();
        assert_eq!(active(&mut app), 0);
        assert_eq!(
            app.world().resource::<PrecipitationState>().kind,
            PrecipitationKind::None
        );
    }
}
