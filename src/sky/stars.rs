//! The night sky's stars: a procedural star field fixed to the celestial sphere, turned with the
//! sidereal time for the [`GeoOrigin`] and the [`SceneClock`], drawn behind the clouds (the cloud
//! composite adds it to the sky's pixels through the clouds' transmittance, so clouds hide it).
//! They are drawn for cameras with [`VolumetricClouds`](crate::render::VolumetricClouds) whose
//! clouds pass through the composite (every preset; not a full-resolution march without
//! accumulation), in a scene whose sky the crate drives (a light with [`Sun`]), while the sun is
//! below the horizon.
//!
//! The field is not a catalogue: each cell of a cube map over the celestial sphere (equatorial
//! coordinates of the date) holds one star at a random place in it, with a magnitude drawn so the
//! whole sky has the counts of the naked-eye sky, `N(< m) = N₀ 10^((m − m₀)/2)` with `N₀` the
//! field's 9 126 stars to [`FAINTEST_MAGNITUDE`] `m₀` (the Bright Star Catalogue lists 9 110 to
//! about magnitude 6.5; Hoffleit & Warren 1991, "The Bright Star Catalogue", 5th ed.); the law
//! then gives about 5 100 stars to magnitude 6 and 160 to 3. A star of
//! visual magnitude `m` gives `10^(−0.4 (m + 14.18))` lux outside the atmosphere, dimmed by
//! [`EXTINCTION_MAG_PER_AIRMASS`] per air mass (Kasten & Young 1989, "Revised optical air mass
//! tables and approximation formula"). Each star is a small Gaussian spot of
//! [`STAR_BLUR_PIXELS`] pixels, which keeps its illuminance whatever the resolution.
//!
//! WGSL twin: `star_light` in `src/render/composite/composite.wgsl`; the uniforms come from
//! [`StarSky`].

use bevy::{
    math::{DMat3, DVec3},
    prelude::*,
    render::extract_resource::ExtractResource,
};

use super::{
    MoonPosition, Sun, SunPosition,
    moon::disc::MoonDisc,
    moon_direction_scene,
    solar::{SolarOptions, earth_frame, julian_day},
    sun_direction_scene,
};
use crate::scene::{GeoOrigin, SceneClock};

/// Cells per cube face edge of the star field: `6 · 39² = 9 126` stars over the whole sky.
pub const STAR_CELLS: u32 = 39;
/// Magnitude of the faintest star of the field, the naked eye's limit under a dark sky.
pub const FAINTEST_MAGNITUDE: f64 = 6.5;
/// Visual magnitude zero point: `m = −14.18 − 2.5 log₁₀(E / 1 lux)`.
pub const MAGNITUDE_ZERO_LUX_EXPONENT: f64 = 14.18;
/// Visual extinction of starlight per air mass, magnitudes (a clear, dry site).
pub const EXTINCTION_MAG_PER_AIRMASS: f64 = 0.2;
/// Standard deviation of a star's spot, in pixels of the full-resolution view.
pub const STAR_BLUR_PIXELS: f64 = 0.6;
/// Share of a cell's width kept clear at each side, so a star's spot stays inside its cell.
pub const STAR_CELL_MARGIN: f64 = 0.15;
/// Above this sun elevation (degrees) no star is drawn: the day sky is hundreds of times brighter
/// than the brightest star's spot, so the field only costs time.
pub const STARS_MAX_SUN_ELEVATION_DEG: f64 = 0.0;

/// The star field's settings (a resource; [`Default`]: on, at the natural brightness).
#[derive(Resource, Reflect, Debug, Clone, Copy, PartialEq)]
#[reflect(Resource, Default)]
pub struct StarField {
    /// Draw the stars. Default `true`.
    pub enabled: bool,
    /// Factor on every star's illuminance, ≥ 0. Default 1 (the real sky's).
    pub brightness: f32,
    /// Which random field. Default 0.
    pub seed: u32,
}

impl StarField {
    /// The settings the renderer draws: a `brightness` that is not a number is the default 1,
    /// a negative or infinite one is clamped to 0–`f32::MAX`. A changed [`StarField`] that
    /// needs this is reported once with `warn!`.
    #[must_use]
    pub fn sanitized(&self) -> Self {
        let brightness = if self.brightness.is_nan() {
            1.0
        } else {
            self.brightness.clamp(0.0, f32::MAX)
        };
        Self {
            brightness,
            ..*self
        }
    }
}

impl Default for StarField {
    fn default() -> Self {
        Self {
            enabled: true,
            brightness: 1.0,
            seed: 0,
        }
    }
}

/// What the renderer needs of the stars and the moon's disc this frame, written from
/// [`StarField`], the [`GeoOrigin`], the [`SceneClock`], the sun and the moon (render world:
/// extracted as it is). The stars are off (`zero_magnitude_lux` 0) without a [`Sun`] light, or
/// while the sun is above [`STARS_MAX_SUN_ELEVATION_DEG`]; the moon's disc is off
/// (`moon` `None`) without a [`Sun`] light with [`Sun::moon_disc`].
#[derive(Resource, ExtractResource, Debug, Clone, Copy, PartialEq, Default)]
pub struct StarSky {
    /// Celestial (equatorial, of the date) coordinates from scene coordinates.
    pub celestial_from_scene: Mat3,
    /// Illuminance of a magnitude-0 star outside the atmosphere, lux, times
    /// [`StarField::brightness`]; 0 when no star is drawn (off, or the sun up).
    pub zero_magnitude_lux: f32,
    /// [`StarField::seed`].
    pub seed: u32,
    /// The moon's disc (`None`: not drawn).
    pub moon: Option<MoonDisc>,
}

/// Celestial coordinates from East-North-Up at latitude `latitude_deg` and local apparent
/// sidereal time `sidereal_deg`: the transpose of `enu = R · c` with the hour angle `θ − α`.
pub(crate) fn celestial_from_enu(latitude_deg: f64, sidereal_deg: f64) -> DMat3 {
    let (sp, cp) = latitude_deg.to_radians().sin_cos();
    let (st, ct) = sidereal_deg.to_radians().sin_cos();
    // Rows of ENU from celestial: east, north, up.
    let enu_from_celestial = DMat3::from_cols(
        DVec3::new(-st, -sp * ct, cp * ct),
        DVec3::new(ct, -sp * st, cp * st),
        DVec3::new(0.0, cp, sp),
    );
    enu_from_celestial.transpose()
}

/// Celestial coordinates from scene coordinates (x east, y up, z south) at `origin` and
/// `unix_seconds`.
pub fn celestial_from_scene(origin: &GeoOrigin, unix_seconds: f64) -> DMat3 {
    let frame = earth_frame(julian_day(unix_seconds), &SolarOptions::default());
    let sidereal = frame.apparent_sidereal_time_deg + origin.longitude_deg;
    let enu_from_scene = DMat3::from_cols(
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.0, -1.0, 0.0),
    );
    celestial_from_enu(origin.latitude_deg, sidereal) * enu_from_scene
}

/// Writes [`StarSky`] for this frame.
pub(crate) fn place_stars(
    clock: Res<SceneClock>,
    origin: Option<Res<GeoOrigin>>,
    field: Option<Res<StarField>>,
    sun: Res<SunPosition>,
    moon: Res<MoonPosition>,
    suns: Query<&Sun>,
    mut sky: ResMut<StarSky>,
) {
    let origin = origin.map_or_else(GeoOrigin::default, |o| *o);
    let field = field.map_or_else(StarField::default, |f| f.sanitized());
    let sun_up = sun
        .0
        .is_some_and(|s| s.elevation_deg > STARS_MAX_SUN_ELEVATION_DEG);
    let brightness = field.brightness;
    // Only a sky the crate drives (a `Sun` light aimed from the same place and instant) has
    // stars: another app's light says nothing of the night.
    let zero = if field.enabled && !sun_up && !suns.is_empty() {
        (zero_magnitude_lux() * f64::from(brightness)) as f32
    } else {
        0.0
    };
    let next = StarSky {
        celestial_from_scene: celestial_from_scene(&origin, clock.unix_seconds()).as_mat3(),
        zero_magnitude_lux: zero,
        seed: field.seed,
        moon: moon_disc(&sun, &moon, &suns),
    };
    if *sky != next {
        *sky = next;
    }
}

/// The moon's disc for the first [`Sun`] light that draws it ([`Sun::moon_disc`]), with that
/// light's scale on the moon's illuminance ([`Sun::illuminance_lux`]).
fn moon_disc(sun: &SunPosition, moon: &MoonPosition, suns: &Query<&Sun>) -> Option<MoonDisc> {
    let light = suns.iter().find(|light| light.moon_disc)?;
    let (solar, lunar) = (sun.0?, moon.0?);
    let disc = MoonDisc::new(
        &lunar,
        &solar,
        moon_direction_scene(&lunar).as_dvec3().normalize(),
        sun_direction_scene(&solar).as_dvec3().normalize(),
        lunar.illuminance_lux() * light.moon_scale(),
    );
    (disc.lux_per_sr > 0.0).then_some(disc)
}

/// Illuminance of a magnitude-0 star outside the atmosphere, lux.
pub fn zero_magnitude_lux() -> f64 {
    10f64.powf(-0.4 * MAGNITUDE_ZERO_LUX_EXPONENT)
}

/// One star of the field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Star {
    /// Unit direction, celestial coordinates.
    pub direction: DVec3,
    /// Visual magnitude.
    pub magnitude: f64,
    /// Colour, linear RGB of luminance 1.
    pub colour: [f64; 3],
}

/// A cell of the field's cube map: face 0–5, then column and row (`0..STAR_CELLS`).
pub(crate) type StarCell = (u32, u32, u32);

/// The axes (major, u, v) of cube face `face`.
fn face_axes(face: u32) -> [DVec3; 3] {
    let s = if face.is_multiple_of(2) { 1.0 } else { -1.0 };
    match face / 2 {
        0 => [DVec3::X * s, DVec3::Y, DVec3::Z],
        1 => [DVec3::Y * s, DVec3::Z, DVec3::X],
        _ => [DVec3::Z * s, DVec3::X, DVec3::Y],
    }
}

/// The cube map's warp: face coordinate (tangent) to cell coordinate in −1..1, so the cells'
/// solid angles differ by at most 40 % (a plain cube map's, by a factor of 5).
fn warp(a: f64) -> f64 {
    a.atan() * (4.0 / std::f64::consts::PI)
}

/// The cell that holds `direction` (unit, celestial). WGSL twin: `star_cell`.
pub(crate) fn star_cell(direction: DVec3) -> StarCell {
    let d = direction.abs();
    let (face, a, b) = if d.x >= d.y && d.x >= d.z {
        (
            u32::from(direction.x < 0.0),
            direction.y / d.x,
            direction.z / d.x,
        )
    } else if d.y >= d.z {
        (
            2 + u32::from(direction.y < 0.0),
            direction.z / d.y,
            direction.x / d.y,
        )
    } else {
        (
            4 + u32::from(direction.z < 0.0),
            direction.x / d.z,
            direction.y / d.z,
        )
    };
    let n = f64::from(STAR_CELLS);
    let cell = |x: f64| ((0.5 * (warp(x) + 1.0) * n).floor() as u32).min(STAR_CELLS - 1);
    (face, cell(a), cell(b))
}

/// A 32-bit integer hash (Wellons' "lowbias32"). WGSL twin: `star_hash`.
fn star_hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The `k`-th random number of a cell's hash `h`, in (0, 1).
fn unit(h: u32, k: u32) -> f64 {
    (f64::from(star_hash(h.wrapping_add(k)) >> 8) + 0.5) / 16_777_216.0
}

/// The star of `cell` in the field of `seed`. WGSL twin: `cell_star`.
pub(crate) fn cell_star(seed: u32, (face, i, j): StarCell) -> Star {
    let index = (face * STAR_CELLS + j) * STAR_CELLS + i;
    let h = star_hash(seed ^ star_hash(index));
    let n = f64::from(STAR_CELLS);
    let inner = 1.0 - 2.0 * STAR_CELL_MARGIN;
    let place = |cell: u32, k: u32| {
        let s = -1.0 + 2.0 * (f64::from(cell) + STAR_CELL_MARGIN + inner * unit(h, k)) / n;
        (s * std::f64::consts::FRAC_PI_4).tan()
    };
    let [major, u, v] = face_axes(face);
    let direction = (major + u * place(i, 0) + v * place(j, 1)).normalize();
    let magnitude = FAINTEST_MAGNITUDE + 2.0 * unit(h, 2).log10();
    Star {
        direction,
        magnitude,
        colour: star_colour(unit(h, 3)),
    }
}

/// A star's colour from a random number: from blue-white to orange, luminance 1.
fn star_colour(t: f64) -> [f64; 3] {
    let blue = [0.80, 0.88, 1.0];
    let orange = [1.0, 0.80, 0.60];
    let c: [f64; 3] = std::array::from_fn(|k| blue[k] + (orange[k] - blue[k]) * t);
    let y = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    c.map(|c| c / y)
}

/// The stars' radiance, cd/m² (linear RGB), seen along `celestial` (unit) `elevation_deg` above
/// the horizon, when a magnitude-0 star gives `zero_lux` lux outside the atmosphere; each star
/// a Gaussian spot of standard deviation `sigma_rad`. WGSL twin: `star_light`.
pub fn star_radiance(
    seed: u32,
    celestial: DVec3,
    elevation_deg: f64,
    sigma_rad: f64,
    zero_lux: f64,
) -> [f64; 3] {
    if elevation_deg.is_nan() || elevation_deg <= 0.0 {
        return [0.0; 3];
    }
    let mass = super::light::air_mass(elevation_deg);
    let star = cell_star(seed, star_cell(celestial));
    let distance2 = (celestial - star.direction).length_squared();
    let spot = (-distance2 / (2.0 * sigma_rad * sigma_rad)).exp()
        / (2.0 * std::f64::consts::PI * sigma_rad * sigma_rad);
    let lux = zero_lux * 10f64.powf(-0.4 * (star.magnitude + EXTINCTION_MAG_PER_AIRMASS * mass));
    star.colour.map(|c| c * lux * spot)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all_stars(seed: u32) -> Vec<Star> {
        let mut stars = Vec::new();
        for face in 0..6 {
            for j in 0..STAR_CELLS {
                for i in 0..STAR_CELLS {
                    stars.push(cell_star(seed, (face, i, j)));
                }
            }
        }
        stars
    }

    #[test]
    fn the_field_has_the_naked_eye_skys_counts() {
        let stars = all_stars(0);
        let total = stars.len() as f64;
        // The law the field draws from, against the usual whole-sky counts (rounded to two
        // figures, hence 10 %): about 170 stars brighter than magnitude 3, 510 than 4, 1 600
        // than 5 and 5 000 than 6.
        let law = |m: f64| total * 10f64.powf((m - FAINTEST_MAGNITUDE) / 2.0);
        for (magnitude, count) in [(3.0, 170.0), (4.0, 510.0), (5.0, 1_600.0), (6.0, 5_000.0)] {
            let expected = law(magnitude);
            assert!(
                (expected / count - 1.0).abs() < 0.1,
                "the law gives {expected} stars brighter than {magnitude}, the sky about {count}"
            );
            // And the drawn field follows the law: a binomial count within four standard
            // deviations.
            let n = stars.iter().filter(|s| s.magnitude < magnitude).count() as f64;
            let sd = (expected * (1.0 - expected / total)).sqrt();
            assert!(
                (n - expected).abs() < 4.0 * sd,
                "{n} stars brighter than {magnitude}, the law {expected} ± {sd}"
            );
        }
        let brightest = stars.iter().map(|s| s.magnitude).fold(f64::MAX, f64::min);
        assert!(
            brightest < 0.0,
            "a few stars as bright as Vega or brighter: {brightest}"
        );
    }

    /// The solid angle of the part of cube face +Z (at distance 1) between the face
    /// coordinates a0..a1 and b0..b1.
    fn face_patch_solid_angle(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
        let corner = |a: f64, b: f64| (a * b).atan2((1.0 + a * a + b * b).sqrt());
        corner(a1, b1) - corner(a0, b1) - corner(a1, b0) + corner(a0, b0)
    }

    #[test]
    fn each_star_lies_in_its_own_cell_and_the_cells_are_even() {
        for (index, star) in all_stars(7).iter().enumerate() {
            let index = index as u32;
            let cell = (
                index / (STAR_CELLS * STAR_CELLS),
                index % STAR_CELLS,
                (index / STAR_CELLS) % STAR_CELLS,
            );
            assert_eq!(star_cell(star.direction), cell);
        }
        // One star per cell: the stars' density over the sky follows the cells' solid angles,
        // which must not vary by half or more, or the cube's corners would show as denser
        // patches (a plain cube map's vary by a factor of 5). They add up to the sphere.
        let n = f64::from(STAR_CELLS);
        let edge = |k: u32| -1.0 + 2.0 * f64::from(k) / n;
        let face = |s: f64| (s * std::f64::consts::FRAC_PI_4).tan();
        let mut angles = Vec::new();
        for j in 0..STAR_CELLS {
            for i in 0..STAR_CELLS {
                angles.push(face_patch_solid_angle(
                    face(edge(i)),
                    face(edge(i + 1)),
                    face(edge(j)),
                    face(edge(j + 1)),
                ));
            }
        }
        let (min, max) = angles
            .iter()
            .fold((f64::MAX, 0.0f64), |(lo, hi), w| (lo.min(*w), hi.max(*w)));
        let sphere = 6.0 * angles.iter().sum::<f64>();
        assert!((sphere / (4.0 * std::f64::consts::PI) - 1.0).abs() < 1e-9);
        assert!(max / min < 1.5, "cells from {min} to {max} sr");
    }

    #[test]
    fn a_spot_keeps_its_stars_illuminance() {
        let star = cell_star(3, (4, 20, 11));
        let sigma = 2e-4;
        // Sum the radiance over a fine patch of the sky around the star, at the zenith-like
        // elevation 90° (air mass 1).
        let (e1, e2) = (
            star.direction.any_orthonormal_pair().0,
            star.direction.any_orthonormal_pair().1,
        );
        let step = sigma / 8.0;
        let mut total = 0.0;
        for y in -64..=64 {
            for x in -64..=64 {
                let d = (star.direction + e1 * (f64::from(x) * step) + e2 * (f64::from(y) * step))
                    .normalize();
                let l = star_radiance(3, d, 90.0, sigma, 1.0);
                total += (0.2126 * l[0] + 0.7152 * l[1] + 0.0722 * l[2]) * step * step;
            }
        }
        let expected = 10f64.powf(-0.4 * (star.magnitude + EXTINCTION_MAG_PER_AIRMASS));
        // Within 0.01 magnitude.
        assert!(
            (total / expected - 1.0).abs() < 0.01,
            "summed illuminance {total} against {expected}"
        );
        // Below the horizon nothing.
        assert_eq!(star_radiance(3, star.direction, -1.0, sigma, 1.0), [0.0; 3]);
    }

    #[test]
    fn the_sky_turns_about_the_celestial_pole() {
        let bern = GeoOrigin::default();
        let t0 = 1_620_000_000.0;
        // Identities, exact but for f64 rounding: the celestial pole stands due north at the
        // latitude's elevation, all night.
        for hours in [0.0, 3.0, 7.5] {
            let m = celestial_from_scene(&bern, t0 + hours * 3600.0);
            let pole_scene = m.transpose() * DVec3::Z;
            let elevation = pole_scene.y.asin().to_degrees();
            assert!((elevation - bern.latitude_deg).abs() < 1e-9, "{elevation}");
            assert!(
                pole_scene.x.abs() < 1e-9 && pole_scene.z < 0.0,
                "{pole_scene}"
            );
        }
        // A star on the celestial equator at the sidereal time's right ascension is on the
        // meridian, due south at 90° − latitude; six sidereal hours later it sets in the west.
        let m = celestial_from_enu(bern.latitude_deg, 100.0);
        let star = DVec3::new(100f64.to_radians().cos(), 100f64.to_radians().sin(), 0.0);
        let enu = m.transpose() * star;
        assert!((enu.z.asin().to_degrees() - (90.0 - bern.latitude_deg)).abs() < 1e-9);
        assert!(enu.y < 0.0 && enu.x.abs() < 1e-12);
        let later = celestial_from_enu(bern.latitude_deg, 190.0).transpose() * star;
        assert!(later.z.abs() < 1e-12 && later.x < -0.99, "{later}");
        // One sidereal day later the sky is where it was, to 10⁻⁵ rad (2″, a thirtieth of a
        // pixel of a 60° view at 2160 lines; nutation moves it by less in a day).
        let a = celestial_from_scene(&bern, t0);
        let b = celestial_from_scene(&bern, t0 + 86_164.090_5);
        assert!((a - b).abs().to_cols_array().iter().all(|d| *d < 1e-5));
    }

    #[test]
    fn stars_need_a_sun_light_below_the_horizon() {
        use crate::scene::UtcInstant;
        use crate::sky::solar::{Observer, solar_position_unix_seconds};
        use bevy::ecs::system::RunSystemOnce;
        let sky_at = |time: &str, with_sun: bool| {
            let instant: UtcInstant = time.parse().unwrap();
            let mut world = World::new();
            world.insert_resource(SceneClock::at(instant));
            world.insert_resource(SunPosition(Some(solar_position_unix_seconds(
                &Observer::from(&GeoOrigin::default()),
                instant.unix_seconds() as f64,
                &SolarOptions::default(),
            ))));
            world.init_resource::<StarSky>();
            world.init_resource::<MoonPosition>();
            if with_sun {
                world.spawn(Sun::default());
            }
            world.run_system_once(place_stars).unwrap();
            *world.resource::<StarSky>()
        };
        // Bern at 01:00 UTC (the sun 26° down) and 11:00 UTC (61° up) on 2021-05-11.
        let night = sky_at("2021-05-11T01:00:00Z", true);
        assert!((f64::from(night.zero_magnitude_lux) / zero_magnitude_lux() - 1.0).abs() < 1e-6);
        assert_eq!(sky_at("2021-05-11T11:00:00Z", true).zero_magnitude_lux, 0.0);
        assert_eq!(
            sky_at("2021-05-11T01:00:00Z", false).zero_magnitude_lux,
            0.0
        );
    }

    #[test]
    fn a_brightness_that_cannot_be_drawn_is_replaced() {
        let field = |brightness| StarField {
            brightness,
            ..default()
        };
        assert_eq!(field(f32::NAN).sanitized().brightness, 1.0);
        assert_eq!(field(-2.0).sanitized().brightness, 0.0);
        assert_eq!(field(f32::INFINITY).sanitized().brightness, f32::MAX);
        assert_eq!(field(3.0).sanitized(), field(3.0));
    }
}
