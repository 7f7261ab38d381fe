//! What the clouds are and where the planet is: the settings every camera shares.
//!
//! [`CloudWorld`] is a resource, apart from the per-camera quality knobs of
//! [`VolumetricClouds`](crate::render::VolumetricClouds), in the way Bevy keeps `Atmosphere`
//! apart from `AtmosphereSettings`: two cameras with different presets see the same clouds and
//! the same cloud shadows, only drawn with more or fewer samples.

use bevy::prelude::*;

/// Where the planet the cloud layers are shells around sits in the scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Reflect)]
pub enum PlanetAnchor {
    /// The planet touches the ground plane `y = ground_height_m` right under each camera: every
    /// camera is `y − ground_height_m` above the ground and sees the layers at the same heights
    /// above it, wherever it is in a flat game world. The horizon curves away from each camera
    /// as it does from an observer on Earth. This is what Bevy's `Atmosphere` assumes.
    #[default]
    UnderCamera,
    /// The planet's centre is fixed at `(0, ground_height_m − planet_radius_m, 0)`: a camera far
    /// from the scene origin is high above a curved ground, as on a globe. For scenes whose own
    /// ground curves around the origin (a terrain mesh on a sphere) or that span more than a
    /// few hundred kilometres.
    Geocentric,
}

/// The clouds' world: the planet, the ground, the cloud noise and the cloud medium's phase
/// function. A resource shared by every camera with
/// [`VolumetricClouds`](crate::render::VolumetricClouds) and by the cloud shadow map.
///
/// Values the renderer cannot use (NaN, out of range) are replaced as
/// [`CloudWorld::sanitize`] documents, with a `warn!` naming the field.
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Default)]
pub struct CloudWorld {
    /// Radius of the planet the layers are shells around, metres. Default 6 371 000 (Earth's
    /// mean radius).
    pub planet_radius_m: f32,
    /// Scene y of the ground the layer altitudes are measured from, metres. Default 0.
    pub ground_height_m: f32,
    /// Where the planet sits. Default [`PlanetAnchor::UnderCamera`].
    pub anchor: PlanetAnchor,
    /// Period of the base (shape) noise, metres. Default 4 000 m.
    pub shape_scale_m: f32,
    /// Period of the detail (erosion) noise, metres. Default 700 m.
    pub detail_scale_m: f32,
    /// How much the detail noise erodes cloud edges (0–0.9). Default 0.35.
    pub detail_erosion: f32,
    /// Forward lobe of the dual-lobe Henyey-Greenstein phase function (−0.999–0.999). Default
    /// 0.8.
    pub phase_g_forward: f32,
    /// Backward lobe (−0.999–0.999). Default −0.3.
    pub phase_g_back: f32,
    /// Weight of the backward lobe (0–1). Default 0.2.
    pub phase_blend: f32,
    /// Share of the light that a cirrostratus veil's ice crystals scatter into the 22° halo
    /// around the sun (and the moon, whose light is the `Sun` light at night), 0–1: the ring of
    /// [`halo_phase`](crate::reference::render::halo_phase) takes this share of the layer's
    /// phase function, the dual lobe the rest. 0 turns halos off. Other cloud kinds make none.
    /// Default 0.05, a visual choice (a ring clearly brighter than the veil beside it, as in
    /// photographs of a halo), not a measured crystal habit.
    pub halo_share: f32,
}

impl CloudWorld {
    /// Earth, with the crate's default cloud noise and phase function.
    pub const EARTH: Self = Self {
        planet_radius_m: 6_371_000.0,
        ground_height_m: 0.0,
        anchor: PlanetAnchor::UnderCamera,
        shape_scale_m: 4_000.0,
        detail_scale_m: 700.0,
        detail_erosion: 0.35,
        phase_g_forward: 0.8,
        phase_g_back: -0.3,
        phase_blend: 0.2,
        halo_share: 0.05,
    };

    /// A cleaned copy that the renderer can trust; see [`CloudWorld::sanitize`].
    #[must_use]
    pub fn sanitized(&self) -> Self {
        let mut clean = self.clone();
        clean.sanitize();
        clean
    }

    /// Cleans the settings in place so that the renderer can trust them. The renderer draws
    /// with the cleaned copy, and a `warn!` names each field it changes. Each field is fixed as
    /// follows:
    ///
    /// - `planet_radius_m`: a non-finite value or one below 1 m becomes Earth's 6 371 000 m.
    /// - `ground_height_m`: a non-finite value becomes 0.
    /// - `shape_scale_m`, `detail_scale_m`: a non-finite or non-positive value becomes the
    ///   default (4 000 m, 700 m).
    /// - `detail_erosion`: clamped to 0–0.9; NaN becomes 0.35.
    /// - `phase_g_forward`, `phase_g_back`: clamped to −0.999–0.999 (±1 is a delta, which the
    ///   phase function cannot evaluate); NaN becomes the default (0.8, −0.3).
    /// - `phase_blend`: clamped to 0–1; NaN becomes 0.2.
    /// - `halo_share`: clamped to 0–1; NaN becomes 0.05.
    pub fn sanitize(&mut self) {
        use crate::{
            clean::{clamp_or, positive_or},
            reference::render::{MAX_DETAIL_EROSION, MAX_PHASE_G},
        };
        let defaults = Self::EARTH;
        let max_g = MAX_PHASE_G as f32;
        if !(self.planet_radius_m.is_finite() && self.planet_radius_m >= 1.0) {
            self.planet_radius_m = defaults.planet_radius_m;
        }
        if !self.ground_height_m.is_finite() {
            self.ground_height_m = 0.0;
        }
        self.shape_scale_m = positive_or(self.shape_scale_m, defaults.shape_scale_m);
        self.detail_scale_m = positive_or(self.detail_scale_m, defaults.detail_scale_m);
        self.detail_erosion = clamp_or(
            self.detail_erosion,
            0.0,
            MAX_DETAIL_EROSION as f32,
            defaults.detail_erosion,
        );
        self.phase_g_forward = clamp_or(
            self.phase_g_forward,
            -max_g,
            max_g,
            defaults.phase_g_forward,
        );
        self.phase_g_back = clamp_or(self.phase_g_back, -max_g, max_g, defaults.phase_g_back);
        self.phase_blend = clamp_or(self.phase_blend, 0.0, 1.0, defaults.phase_blend);
        self.halo_share = clamp_or(self.halo_share, 0.0, 1.0, defaults.halo_share);
    }

    /// The planet's centre for a camera at `camera_m` (scene metres), as [`CloudWorld::anchor`]
    /// places it. Call on a [sanitized](CloudWorld::sanitized) world.
    #[must_use]
    pub fn planet_centre_m(&self, camera_m: bevy::math::DVec3) -> bevy::math::DVec3 {
        let y = f64::from(self.ground_height_m) - f64::from(self.planet_radius_m);
        match self.anchor {
            PlanetAnchor::UnderCamera => bevy::math::DVec3::new(camera_m.x, y, camera_m.z),
            PlanetAnchor::Geocentric => bevy::math::DVec3::new(0.0, y, 0.0),
        }
    }

    /// The local vertical (unit, world axes; +Y at the planet's centre) and the altitude above
    /// the ground (metres) of a camera at `camera_m` (scene metres). Call on a
    /// [sanitized](CloudWorld::sanitized) world.
    #[must_use]
    pub fn camera_up_and_altitude(&self, camera_m: bevy::math::DVec3) -> (bevy::math::DVec3, f64) {
        let from_centre = camera_m - self.planet_centre_m(camera_m);
        let distance = from_centre.length();
        let up = if distance > 0.0 {
            from_centre / distance
        } else {
            bevy::math::DVec3::Y
        };
        (up, distance - f64::from(self.planet_radius_m))
    }
}

impl Default for CloudWorld {
    fn default() -> Self {
        Self::EARTH
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::DVec3;

    /// `field` set to each of `given` is cleaned to the matching `used`.
    fn check(field: impl Fn(&mut CloudWorld) -> &mut f32, cases: &[(f32, f32)]) {
        for &(given, used) in cases {
            let mut world = CloudWorld::default();
            *field(&mut world) = given;
            let mut clean = world.sanitized();
            assert_eq!(*field(&mut clean), used, "{given:?}");
        }
    }

    #[test]
    fn sanitizing_repairs_every_field() {
        let (nan, inf) = (f32::NAN, f32::INFINITY);
        check(
            |w| &mut w.planet_radius_m,
            &[
                (nan, 6_371_000.0),
                (0.5, 6_371_000.0),
                (inf, 6_371_000.0),
                (1e5, 1e5),
            ],
        );
        check(
            |w| &mut w.ground_height_m,
            &[(nan, 0.0), (-inf, 0.0), (-30.0, -30.0)],
        );
        check(
            |w| &mut w.shape_scale_m,
            &[(0.0, 4000.0), (nan, 4000.0), (-1.0, 4000.0)],
        );
        check(|w| &mut w.detail_scale_m, &[(0.0, 700.0), (inf, 700.0)]);
        check(
            |w| &mut w.detail_erosion,
            &[(nan, 0.35), (1.0, 0.9), (-1.0, 0.0)],
        );
        check(
            |w| &mut w.phase_g_forward,
            &[(nan, 0.8), (1.0, 0.999), (-2.0, -0.999)],
        );
        check(|w| &mut w.phase_g_back, &[(nan, -0.3), (0.5, 0.5)]);
        check(
            |w| &mut w.halo_share,
            &[(nan, 0.05), (2.0, 1.0), (-1.0, 0.0), (0.3, 0.3)],
        );
        check(
            |w| &mut w.phase_blend,
            &[(nan, 0.2), (1.5, 1.0), (-0.5, 0.0)],
        );
        assert_eq!(CloudWorld::EARTH.sanitized(), CloudWorld::EARTH);
    }

    #[test]
    fn the_planet_sits_under_the_camera_or_at_the_origin() {
        let camera = DVec3::new(1.0e6, 2.0, -1.0e6);
        let world = CloudWorld {
            ground_height_m: 10.0,
            ..default()
        };
        let r = f64::from(world.planet_radius_m);
        assert_eq!(
            world.planet_centre_m(camera),
            DVec3::new(1.0e6, 10.0 - r, -1.0e6)
        );
        let globe = CloudWorld {
            anchor: PlanetAnchor::Geocentric,
            ..world
        };
        assert_eq!(
            globe.planet_centre_m(camera),
            DVec3::new(0.0, 10.0 - r, 0.0)
        );
        // Under the camera: straight up, 2 m − 10 m of ground below it, wherever it stands.
        let (up, altitude) = world.camera_up_and_altitude(camera);
        assert_eq!(up, DVec3::Y);
        assert!((altitude + 8.0).abs() < 1e-6, "{altitude}");
        // On the globe, 1414 km from the origin: the vertical tilts toward the camera, and the
        // ground curves away below it.
        let (up, altitude) = globe.camera_up_and_altitude(camera);
        let from_centre = camera - globe.planet_centre_m(camera);
        assert!((up - from_centre.normalize()).length() < 1e-12 && up.z < 0.0 && up.x > 0.0);
        assert!((altitude - (from_centre.length() - r)).abs() < 1e-6 && altitude > 1.0e5);
    }
}
