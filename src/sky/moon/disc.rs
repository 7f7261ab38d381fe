//! The moon's disc in the sky, lit for its phase: the sunlit part of a sphere seen from the
//! observer, shaded with the Lommel–Seeliger law (the moon's regolith scatters so that the full
//! moon looks evenly bright to its limb, with no darkening toward it; Hapke 1963, "A theoretical
//! photometric function for the lunar surface"), and scaled so the disc gives the moon's
//! illuminance for its phase and distance ([`LunarPosition::illuminance_lux`]). The cloud
//! composite draws it behind the clouds, dimmed by the air mass like the stars, by day as well
//! as by night; the earthshine on the dark part is not drawn.
//!
//! WGSL twin: `moon_light` in `src/render/composite/composite.wgsl`; the uniforms come from
//! [`crate::sky::stars::StarSky`].

use bevy::math::DVec3;

use super::{AU_KM, LunarPosition};
use crate::sky::{SolarPosition, light::air_mass, stars::EXTINCTION_MAG_PER_AIRMASS};

/// The moon's disc as the renderer draws it, in scene coordinates (x east, y up, z south).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoonDisc {
    /// Unit vector toward the moon's centre.
    pub direction: DVec3,
    /// The disc's apparent radius, radians (about 0.0045).
    pub radius_rad: f64,
    /// Unit vector from the moon toward the sun: it points the lit limb and sets the terminator.
    pub toward_sun: DVec3,
    /// The disc's radiance per unit of the shading ([`MoonDisc::shading`]) above the
    /// atmosphere, cd/m² (lux per steradian): the illuminance over the shading's integral over
    /// the disc's solid angle, so the disc gives `illuminance_lux`. 0: no disc.
    pub lux_per_sr: f64,
}

impl MoonDisc {
    /// The disc of the moon at `lunar` with the sun at `solar`, giving `illuminance_lux` above
    /// the atmosphere (the moon's, [`LunarPosition::illuminance_lux`], times any scale).
    /// `direction` and `sun_direction` are the unit vectors toward the moon and the sun in scene
    /// coordinates.
    #[must_use]
    pub fn new(
        lunar: &LunarPosition,
        solar: &SolarPosition,
        direction: DVec3,
        sun_direction: DVec3,
        illuminance_lux: f64,
    ) -> Self {
        let radius_rad = lunar.radius_deg().to_radians();
        // The sun seen from the moon: the sun's direction moved by the moon's offset, a few
        // tenths of a degree at most (the sun is about 390 times farther).
        let toward_sun = (sun_direction * solar.earth_sun_distance_au * AU_KM
            - direction * lunar.distance_km)
            .normalize_or_zero();
        let mut disc = Self {
            direction,
            radius_rad,
            toward_sun,
            lux_per_sr: 0.0,
        };
        let integral = disc.shading_integral_sr();
        if illuminance_lux.is_finite() && illuminance_lux > 0.0 && integral > 0.0 {
            disc.lux_per_sr = illuminance_lux / integral;
        }
        disc
    }

    /// The shading at the point of the disc seen along the unit `view` direction: Lommel–Seeliger,
    /// `μ₀ / (μ₀ + μ)` with `μ₀` the cosine of the sun's angle to the moon's surface there and `μ`
    /// of the observer's; 0 on the night side. Off the disc, the shading of the rim point nearest
    /// to `view`.
    #[must_use]
    pub fn shading(&self, view: DVec3) -> f64 {
        let m = self.direction;
        // The point on the disc in units of its radius, in the plane across the line of sight.
        let p = (view - m * view.dot(m)) / self.radius_rad.sin();
        let rho = p.length();
        let p = if rho > 1.0 { p / rho } else { p };
        let mu = (1.0 - p.length_squared()).max(0.0).sqrt();
        // The surface normal, toward the observer at the disc's centre.
        let normal = p - m * mu;
        let mu0 = normal.dot(self.toward_sun);
        if mu0.is_nan() || mu0 <= 0.0 {
            return 0.0;
        }
        mu0 / (mu0 + mu)
    }

    /// How much of a pixel `pixel_rad` wide around `view` the disc covers, 0–1: 1 inside, 0 a
    /// pixel beyond the rim, linear across the rim's pixel.
    #[must_use]
    pub fn coverage(&self, view: DVec3, pixel_rad: f64) -> f64 {
        let angle = view.dot(self.direction).clamp(-1.0, 1.0).acos();
        if pixel_rad.is_nan() || pixel_rad <= 0.0 {
            return f64::from(u8::from(angle <= self.radius_rad));
        }
        ((self.radius_rad - angle) / pixel_rad + 0.5).clamp(0.0, 1.0)
    }

    /// The disc's radiance along the unit `view` direction `elevation_deg` above the horizon,
    /// cd/m² (luminance; the disc is white), with pixels `pixel_rad` wide: the shading times
    /// [`MoonDisc::lux_per_sr`] times the coverage, dimmed by
    /// [`EXTINCTION_MAG_PER_AIRMASS`] per air mass; 0 below the horizon. WGSL twin: `moon_light`.
    #[must_use]
    pub fn radiance(&self, view: DVec3, elevation_deg: f64, pixel_rad: f64) -> f64 {
        if self.lux_per_sr.is_nan()
            || self.lux_per_sr <= 0.0
            || elevation_deg.is_nan()
            || elevation_deg <= 0.0
        {
            return 0.0;
        }
        let coverage = self.coverage(view, pixel_rad);
        if coverage.is_nan() || coverage <= 0.0 {
            return 0.0;
        }
        let extinction = 10f64.powf(-0.4 * EXTINCTION_MAG_PER_AIRMASS * air_mass(elevation_deg));
        self.lux_per_sr * self.shading(view) * coverage * extinction
    }

    /// The shading integrated over the disc's solid angle, steradians: `π r² Φ(α) / 2`, with
    /// `Φ(α) = 1 − sin(α/2) tan(α/2) ln cot(α/4)` the disc-integrated Lommel–Seeliger law at the
    /// phase angle `α` (1 at full moon, when the shading is ½ all over the disc).
    fn shading_integral_sr(&self) -> f64 {
        let alpha = (-self.toward_sun.dot(self.direction))
            .clamp(-1.0, 1.0)
            .acos();
        let half = 0.5 * alpha;
        let phase = if alpha < 1e-9 {
            1.0
        } else if std::f64::consts::PI - alpha < 1e-9 {
            0.0
        } else {
            1.0 - half.sin() * half.tan() * (1.0 / (0.25 * alpha).tan()).ln()
        };
        let r = self.radius_rad.sin();
        0.5 * std::f64::consts::PI * r * r * phase.max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{
        scene::{GeoOrigin, UtcInstant},
        sky::{
            Observer, SolarOptions, lunar_position_unix_seconds, moon_direction_scene,
            solar_position_unix_seconds, sun_direction_scene,
        },
    };

    fn disc_at(time: &str) -> (MoonDisc, LunarPosition) {
        let instant: UtcInstant = time.parse().unwrap();
        let observer = Observer::from(&GeoOrigin::default());
        let options = SolarOptions::default();
        let t = instant.unix_seconds() as f64;
        let lunar = lunar_position_unix_seconds(&observer, t, &options);
        let solar = solar_position_unix_seconds(&observer, t, &options);
        let disc = MoonDisc::new(
            &lunar,
            &solar,
            moon_direction_scene(&lunar).as_dvec3().normalize(),
            sun_direction_scene(&solar).as_dvec3().normalize(),
            lunar.illuminance_lux(),
        );
        (disc, lunar)
    }

    /// A direction on the disc, `x` and `y` in units of its radius along two axes across it.
    fn on_disc(disc: &MoonDisc, x: f64, y: f64) -> DVec3 {
        let m = disc.direction;
        let e1 = m.cross(DVec3::Y).normalize();
        let e2 = m.cross(e1);
        let (s, c) = disc.radius_rad.sin_cos();
        (m * c + (e1 * x + e2 * y) * s).normalize()
    }

    /// The midpoints `(x, y)` of an `n` × `n` grid over the disc's square that fall on the disc,
    /// in units of its radius; each cell is `2 / n` wide.
    fn disc_grid(n: u32) -> impl Iterator<Item = (f64, f64)> {
        let cell = 2.0 / f64::from(n);
        (0..n)
            .flat_map(move |j| (0..n).map(move |i| (i, j)))
            .map(move |(i, j)| {
                (
                    -1.0 + (f64::from(i) + 0.5) * cell,
                    -1.0 + (f64::from(j) + 0.5) * cell,
                )
            })
            .filter(|(x, y)| x * x + y * y <= 1.0)
    }

    /// The share of the disc's area that is lit, on a fine grid.
    fn lit_share(disc: &MoonDisc) -> f64 {
        let (mut inside, mut lit) = (0u32, 0u32);
        for (x, y) in disc_grid(400) {
            inside += 1;
            lit += u32::from(disc.shading(on_disc(disc, x, y)) > 0.0);
        }
        f64::from(lit) / f64::from(inside)
    }

    /// The disc's lit share is the moon's illuminated fraction (Meeus ch. 48, checked against
    /// `PyEphem`) at every phase: new, crescent, quarters, gibbous and full moons of 2021.
    #[test]
    fn the_lit_part_of_the_disc_is_the_illuminated_fraction() {
        for time in [
            "2021-05-11T19:00:00Z", // new moon
            "2021-05-14T19:00:00Z", // waxing crescent
            "2021-05-19T19:00:00Z", // first quarter
            "2021-05-23T19:00:00Z", // waxing gibbous
            "2021-05-26T11:14:00Z", // full moon (the total eclipse)
            "2021-06-02T07:00:00Z", // last quarter
        ] {
            let (disc, lunar) = disc_at(time);
            let share = lit_share(&disc);
            assert!(
                (share - lunar.illuminated_fraction).abs() < 0.02,
                "{time}: lit share {share:.4}, illuminated fraction {:.4}",
                lunar.illuminated_fraction
            );
        }
    }

    /// The disc gives the moon's illuminance: its radiance summed over its solid angle on a fine
    /// grid (which checks the closed form it is normalised with) is `illuminance_lux`, above
    /// the atmosphere.
    #[test]
    fn the_disc_gives_the_moons_illuminance() {
        for time in [
            "2021-05-19T19:00:00Z",
            "2021-05-26T11:14:00Z",
            "2021-05-14T19:00:00Z",
        ] {
            let (disc, lunar) = disc_at(time);
            let n = 300;
            let cell = 2.0 / f64::from(n);
            let sum: f64 = disc_grid(n)
                .map(|(x, y)| disc.lux_per_sr * disc.shading(on_disc(&disc, x, y)))
                .sum();
            let lux = sum * cell * cell * disc.radius_rad.sin().powi(2);
            let expected = lunar.illuminance_lux();
            assert!(
                (lux / expected - 1.0).abs() < 0.01,
                "{time}: the disc gives {lux:.5} lux, the moon {expected:.5}"
            );
        }
    }

    /// The lit limb faces the sun: at the first quarter, the disc's point toward the sun is lit
    /// and the opposite point dark; the full moon is evenly bright from its centre to near its
    /// rim (Lommel–Seeliger: no limb darkening).
    #[test]
    fn the_lit_limb_faces_the_sun_and_the_full_moon_is_flat() {
        let (quarter, _) = disc_at("2021-05-19T19:00:00Z");
        let m = quarter.direction;
        let across = (quarter.toward_sun - m * quarter.toward_sun.dot(m)).normalize();
        let point = |k: f64| (m + across * (k * quarter.radius_rad)).normalize();
        assert!(quarter.shading(point(0.8)) > 0.3);
        assert!(quarter.shading(point(-0.8)) == 0.0);

        let (full, _) = disc_at("2021-05-26T11:14:00Z");
        let centre = full.shading(full.direction);
        let near_rim = full.shading(on_disc(&full, 0.0, 0.95));
        assert!(
            (near_rim / centre - 1.0).abs() < 0.05,
            "centre {centre}, near the rim {near_rim}"
        );
    }

    /// Below the horizon, off the disc, and for a disc with no light: nothing; the rim is
    /// blended over one pixel; a direction that is not a number gives nothing rather than NaN.
    #[test]
    fn the_disc_shows_only_where_it_is() {
        let (disc, _) = disc_at("2021-05-23T19:00:00Z");
        let r = disc.radius_rad;
        assert!(disc.radiance(disc.direction, 20.0, r / 10.0) > 0.0);
        assert_eq!(disc.radiance(disc.direction, -1.0, r / 10.0), 0.0);
        assert_eq!(disc.radiance(on_disc(&disc, 1.5, 0.0), 20.0, r / 10.0), 0.0);
        let rim = disc.coverage(on_disc(&disc, 1.0, 0.0), r / 10.0);
        assert!((rim - 0.5).abs() < 0.05, "{rim}");
        let dark = MoonDisc {
            lux_per_sr: 0.0,
            ..disc
        };
        assert_eq!(dark.radiance(disc.direction, 20.0, r / 10.0), 0.0);
        let nan = disc.radiance(DVec3::NAN, f64::NAN, r / 10.0);
        assert_eq!(nan, 0.0);
    }
}
