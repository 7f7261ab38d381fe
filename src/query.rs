//! CPU answers about the clouds for game logic: how dense the cloud is at a point, whether a
//! point is in cloud, how much sunlight reaches it. A plane that enters a cloud, a character in
//! the shade of one, a sensor under a deck: ask [`CloudQuery`] from any system.
//!
//! The answers come from the f64 CPU twin of the renderer, the same density model the GPU
//! marches, at full detail: a point is in cloud exactly where a camera would draw cloud. The twin
//! samples CPU copies of the cloud-noise textures, which [`CloudQueryPlugin`] generates on a
//! background thread from [`CloudNoiseSettings`] (at the default 128³ base texture this takes
//! seconds; again whenever the settings change). Until they are ready every query answers
//! `None`.
//!
//! The plugin is not part of [`crate::CloudscapePlugin`]: add it when the game asks questions,
//! so that games which don't pay nothing. (A storm makes the textures too: the
//! [`LightningPlugin`](crate::lightning::LightningPlugin) asks for them once a cumulonimbus
//! flashes, to place its flashes inside the cloud.)

use std::sync::Arc;

use bevy::{
    ecs::system::SystemParam,
    prelude::*,
    tasks::{AsyncComputeTaskPool, Task, block_on, poll_once},
};

use crate::{
    reference::{
        noise::NoiseRecipe,
        render::{CloudTextures, density_at, is_in_cloud, transmittance_to_sun},
        shadow::{MAX_SHADOW_STEPS, optical_depth_above},
    },
    render::{
        VolumetricClouds,
        noise::CloudNoiseSettings,
        view::{CloudSun, LayerInputData, march_inputs},
    },
    sky::Sun,
    world::CloudWorld,
};

/// Generates the CPU copies of the cloud noise that [`CloudQuery`] needs; not part of
/// [`crate::CloudscapePlugin`] (see the [module docs](self)).
#[derive(Debug, Default, Clone, Copy)]
pub struct CloudQueryPlugin;

impl Plugin for CloudQueryPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<CpuCloudTextures>();
        add_cpu_noise(app);
    }
}

/// Makes [`CpuCloudTextures`] while the resource exists; added once by whichever plugin needs
/// the CPU noise first ([`add_cpu_noise`]).
struct CpuNoisePlugin;

impl Plugin for CpuNoisePlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(
            PreUpdate,
            generate_cpu_cloud_textures.run_if(resource_exists::<CpuCloudTextures>),
        );
    }
}

/// Adds the system that makes [`CpuCloudTextures`] once it is asked for (the resource is
/// inserted), unless another plugin added it already.
pub(crate) fn add_cpu_noise(app: &mut App) {
    if !app.is_plugin_added::<CpuNoisePlugin>() {
        app.add_plugins(CpuNoisePlugin);
    }
}

/// The CPU copies of the cloud-noise textures, for the recipe they were made from.
#[derive(Resource, Default)]
pub struct CpuCloudTextures {
    pub(crate) ready: Option<(NoiseRecipe, Arc<CloudTextures>)>,
    pub(crate) pending: Option<(NoiseRecipe, Task<CloudTextures>)>,
}

impl CpuCloudTextures {
    /// Whether the textures of the current [`CloudNoiseSettings`] are ready.
    pub fn is_ready(&self) -> bool {
        self.ready.is_some() && self.pending.is_none()
    }
}

/// Starts a generation when the recipe changes and collects it when done.
fn generate_cpu_cloud_textures(
    settings: Option<Res<CloudNoiseSettings>>,
    mut textures: ResMut<CpuCloudTextures>,
) {
    let recipe = settings.map_or_else(NoiseRecipe::default, |s| s.0.clone());
    let ready = textures.ready.as_ref().is_some_and(|(r, _)| *r == recipe);
    let pending = textures.pending.as_ref().is_some_and(|(r, _)| *r == recipe);
    if !ready && !pending {
        let for_task = recipe.clone();
        let task =
            AsyncComputeTaskPool::get().spawn(async move { CloudTextures::from_recipe(&for_task) });
        textures.pending = Some((recipe, task));
    }
    if let Some((_, task)) = &mut textures.pending
        && let Some(done) = block_on(poll_once(task))
    {
        let (recipe, _) = textures.pending.take().unwrap();
        textures.ready = Some((recipe, Arc::new(done)));
    }
}

/// Asks the clouds about points of the scene, from any system; see the [module docs](self).
///
/// Points are scene positions, metres. The planet and the layers are the ones the cameras
/// draw: with [`PlanetAnchor::UnderCamera`](crate::world::PlanetAnchor::UnderCamera) the
/// ground under the first camera with [`VolumetricClouds`] (or under the point, without one).
/// Every method answers `None` until [`CloudQueryPlugin`] has made the noise textures.
#[derive(SystemParam)]
pub struct CloudQuery<'w, 's> {
    textures: Option<Res<'w, CpuCloudTextures>>,
    world: Option<Res<'w, CloudWorld>>,
    layers: Query<'w, 's, LayerInputData>,
    cameras: Query<'w, 's, &'static GlobalTransform, With<VolumetricClouds>>,
    lights: Query<
        'w,
        's,
        (
            &'static DirectionalLight,
            &'static GlobalTransform,
            Has<Sun>,
        ),
    >,
}

impl CloudQuery<'_, '_> {
    /// Runs `answer` on the twin's inputs for a frame at the reference camera, with `point`
    /// relative to it.
    fn ask<T>(
        &self,
        point: Vec3,
        answer: impl FnOnce(
            &CloudTextures,
            &crate::reference::render::MarchSettings,
            &[crate::reference::render::MarchLayer],
            [f64; 3],
        ) -> T,
    ) -> Option<T> {
        let (_, textures) = self.textures.as_ref()?.ready.as_ref()?;
        if !point.is_finite() {
            return None;
        }
        let camera = self
            .cameras
            .iter()
            .next()
            .copied()
            .unwrap_or_else(|| GlobalTransform::from_translation(point));
        let sun = CloudSun::pick(self.lights.iter(), false);
        let earth = CloudWorld::default();
        let world = self.world.as_deref().unwrap_or(&earth);
        let (settings, layers) = march_inputs(
            world,
            &VolumetricClouds::default(),
            &camera,
            1.0e-3,
            sun.as_ref(),
            self.layers.iter(),
            0,
        );
        let relative = (point.as_dvec3() - camera.translation().as_dvec3()).to_array();
        Some(answer(textures, &settings, &layers, relative))
    }

    /// The cloud's extinction coefficient at `point`, 1/m (0 in clear air).
    pub fn density_at(&self, point: Vec3) -> Option<f32> {
        self.ask(point, |t, s, l, p| density_at(t, s, l, p) as f32)
    }

    /// Whether `point` is inside cloud: where a camera draws cloud.
    pub fn is_in_cloud(&self, point: Vec3) -> Option<bool> {
        self.ask(point, is_in_cloud)
    }

    /// The fraction of the direct sunlight that reaches `point` through the clouds, 0–1 (0 in
    /// the planet's shadow and without a sun): inside a layer from the renderer's light march,
    /// elsewhere from the clouds on the sun line above the point.
    pub fn sun_transmittance(&self, point: Vec3) -> Option<f32> {
        self.ask(point, |t, s, l, p| {
            let local = transmittance_to_sun(t, s, l, p);
            if local == 0.0 || is_in_cloud(t, s, l, p) {
                local as f32
            } else {
                (-optical_depth_above(t, s, l, p, MAX_SHADOW_STEPS, 0.0)).exp() as f32
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use std::time::{Duration, Instant};

    use super::*;
    use crate::layers::{CloudKind, CloudLayer, DensityProfile, ProfileInterpolation};

    /// What a system asks at three heights under a homogeneous slab 1–1.5 km up.
    #[derive(Resource, Default, Debug)]
    struct Answers(Vec<Option<(f32, bool, f32)>>);

    fn ask(query: CloudQuery, mut answers: ResMut<Answers>) {
        answers.0 = [500.0, 1_250.0, 2_000.0]
            .into_iter()
            .map(|y| {
                let p = Vec3::new(3.0e5, y, -2.0e5);
                Some((
                    query.density_at(p)?,
                    query.is_in_cloud(p)?,
                    query.sun_transmittance(p)?,
                ))
            })
            .collect();
    }

    #[test]
    fn a_system_asks_the_cpu_twin_about_points_of_the_scene() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, CloudQueryPlugin))
            .init_resource::<Answers>()
            .insert_resource(CloudNoiseSettings(NoiseRecipe {
                base_size: 16,
                detail_size: 8,
                weather_size: 16,
                ..NoiseRecipe::default()
            }))
            .add_systems(Update, ask);
        app.world_mut().spawn(CloudLayer {
            base_m: 1_000.0,
            top_m: 1_500.0,
            coverage: 1.0,
            density: 0.002,
            shape_noise: 0.0,
            profile: DensityProfile::new([(0.0, 1.0), (1.0, 1.0)], ProfileInterpolation::Linear),
            ..CloudLayer::new(CloudKind::Stratus)
        });
        app.world_mut().spawn((
            DirectionalLight::default(),
            Transform::default().looking_to(Vec3::NEG_Y, Vec3::Z),
            GlobalTransform::from(Transform::default().looking_to(Vec3::NEG_Y, Vec3::Z)),
        ));
        app.update();
        assert!(
            app.world()
                .resource::<Answers>()
                .0
                .iter()
                .all(Option::is_none),
            "no answer before the textures are made"
        );
        let start = Instant::now();
        while !app.world().resource::<CpuCloudTextures>().is_ready() {
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "the textures never came"
            );
            std::thread::sleep(Duration::from_millis(10));
            app.update();
        }
        app.update();
        let answers = &app.world().resource::<Answers>().0;
        let [Some(below), Some(inside), Some(above)] = answers[..] else {
            panic!("{answers:?}");
        };
        assert_eq!((below.0, below.1), (0.0, false));
        assert!(inside.1 && (inside.0 - 0.002).abs() < 1e-6, "{inside:?}");
        assert_eq!((above.0, above.1, above.2), (0.0, false, 1.0));
        // Sun at the zenith: 250 m of the slab above the middle, 500 m above the ground.
        assert!((inside.2 - (-0.5_f32).exp()).abs() < 1e-3, "{inside:?}");
        assert!((below.2 - (-1.0_f32).exp()).abs() < 1e-3, "{below:?}");
    }
}
