//! Solar position: NREL's Solar Position Algorithm (SPA), Reda & Andreas, "Solar position
//! algorithm for solar radiation applications", Solar Energy 76 (2004) 577–589, revised as NREL
//! TP-560-34302 (2008). Equation numbers below refer to that paper.
//!
//! From a place (latitude, longitude, elevation) and a UTC instant it gives the topocentric solar
//! zenith, elevation and azimuth (degrees, azimuth clockwise from north) with an uncertainty of
//! ±0.0003° for the years −2000 to 6000, plus the sun's unit direction in a local East-North-Up
//! frame for driving a directional light. The Earth's heliocentric position comes from the
//! truncated VSOP87 periodic terms of the paper's Table A4.2 (with NREL's 2006 corrections), the
//! nutation from Table A4.3.
//!
//! Cost: a few hundred trigonometric evaluations, about 10 µs; compute it once per frame at most.

use crate::scene::{GeoOrigin, Place, UtcInstant};

/// A point on Earth for solar position (WGS 84).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Observer {
    /// Geodetic latitude in degrees, north positive, −90 to 90.
    pub latitude_deg: f64,
    /// Longitude in degrees, east positive (west negative), −180 to 180.
    pub longitude_deg: f64,
    /// Elevation above mean sea level in metres (enters the parallax correction).
    pub elevation_m: f64,
}

impl From<&Place> for Observer {
    fn from(place: &Place) -> Self {
        Self {
            latitude_deg: place.latitude_deg,
            longitude_deg: place.longitude_deg,
            elevation_m: place.elevation_m,
        }
    }
}

/// Atmosphere and time-scale settings of [`solar_position`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolarOptions {
    /// Mean annual local air pressure in hPa (= mbar) for the refraction correction. Default
    /// 1013.25 (sea level).
    pub pressure_hpa: f64,
    /// Mean annual local air temperature in °C for the refraction correction. Default 15.
    pub temperature_c: f64,
    /// ΔT = TT − UT in seconds. Default `None`: estimated from the date with
    /// [`estimate_delta_t_s`] (an error of a few seconds moves the sun by about 0.00003°).
    pub delta_t_s: Option<f64>,
    /// Whether to add atmospheric refraction to the elevation (what an observer sees; eq. 42).
    /// Default `true`. Never applied when the sun is below the horizon by more than its radius
    /// plus the refraction at the horizon (0.26667° + 0.5667°).
    pub refraction: bool,
}

impl Default for SolarOptions {
    fn default() -> Self {
        Self {
            pressure_hpa: 1013.25,
            temperature_c: 15.0,
            delta_t_s: None,
            refraction: true,
        }
    }
}

/// Where the sun is, seen from an [`Observer`] at an instant. Angles in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolarPosition {
    /// Topocentric zenith angle, 0 overhead, 90 on the horizon (refracted when
    /// [`SolarOptions::refraction`] is on).
    pub zenith_deg: f64,
    /// Topocentric elevation above the horizon, `90 − zenith_deg`; negative below the horizon.
    pub elevation_deg: f64,
    /// Topocentric elevation without refraction (the geometric direction).
    pub geometric_elevation_deg: f64,
    /// Topocentric azimuth, clockwise from north: 90 east, 180 south, 270 west; [0, 360).
    pub azimuth_deg: f64,
    /// Geocentric apparent declination, north positive.
    pub declination_deg: f64,
    /// Geocentric apparent right ascension, [0, 360).
    pub right_ascension_deg: f64,
    /// Apparent Greenwich hour angle (apparent sidereal time minus right ascension), [0, 360);
    /// what nautical almanacs tabulate as the sun's GHA.
    pub greenwich_hour_angle_deg: f64,
    /// Topocentric local hour angle, [0, 360), 0 at the meridian, growing westward.
    pub hour_angle_deg: f64,
    /// Earth–Sun distance in astronomical units.
    pub earth_sun_distance_au: f64,
}

impl SolarPosition {
    /// Unit vector towards the sun in the observer's East-North-Up frame, from the (refracted)
    /// elevation and azimuth: `[east, north, up]`.
    #[must_use]
    pub fn direction_enu(&self) -> [f64; 3] {
        direction_enu(self.elevation_deg, self.azimuth_deg)
    }

    /// Whether the sun's centre is above the horizon (refracted elevation > 0).
    #[must_use]
    pub fn is_above_horizon(&self) -> bool {
        self.elevation_deg > 0.0
    }
}

/// Unit vector `[east, north, up]` of a direction at `elevation_deg` above the horizon and
/// `azimuth_deg` clockwise from north.
#[must_use]
pub fn direction_enu(elevation_deg: f64, azimuth_deg: f64) -> [f64; 3] {
    let (sin_e, cos_e) = elevation_deg.to_radians().sin_cos();
    let (sin_a, cos_a) = azimuth_deg.to_radians().sin_cos();
    [cos_e * sin_a, cos_e * cos_a, sin_e]
}

/// The sun's position seen from `observer` at `at` (UTC; treated as UT1, which differs by less
/// than 0.9 s, i.e. under 0.004° of hour angle).
#[must_use]
pub fn solar_position(
    observer: &Observer,
    at: UtcInstant,
    options: &SolarOptions,
) -> SolarPosition {
    solar_position_unix_seconds(observer, at.unix_seconds() as f64, options)
}

/// [`solar_position`] at a fractional Unix time in seconds.
#[must_use]
pub fn solar_position_unix_seconds(
    observer: &Observer,
    unix_seconds: f64,
    options: &SolarOptions,
) -> SolarPosition {
    spa(observer, julian_day(unix_seconds), options).position
}

/// The Julian day (UT) of a Unix time in seconds: the epoch 1970-01-01T00:00Z is JD 2440587.5.
#[must_use]
pub fn julian_day(unix_seconds: f64) -> f64 {
    unix_seconds / 86_400.0 + 2_440_587.5
}

/// An estimate of ΔT = TT − UT in seconds for a decimal year (e.g. 2021.5), from the polynomials of
/// Espenak & Meeus, "Five Millennium Canon of Solar Eclipses" (NASA TP-2006-214141), as published
/// on NASA's eclipse web site. Within a few seconds of the measured value for 1941–2025.
#[must_use]
pub fn estimate_delta_t_s(year: f64) -> f64 {
    let long_term = |y: f64| {
        let u = (y - 1820.0) / 100.0;
        -20.0 + 32.0 * u * u
    };
    if (1941.0..1961.0).contains(&year) {
        let t = year - 1950.0;
        29.07 + 0.407 * t - t * t / 233.0 + t.powi(3) / 2547.0
    } else if (1961.0..1986.0).contains(&year) {
        let t = year - 1975.0;
        45.45 + 1.067 * t - t * t / 260.0 - t.powi(3) / 718.0
    } else if (1986.0..2005.0).contains(&year) {
        let t = year - 2000.0;
        63.86 + 0.3345 * t - 0.060_374 * t * t
            + 0.001_727_5 * t.powi(3)
            + 0.000_651_814 * t.powi(4)
            + 0.000_023_735_99 * t.powi(5)
    } else if (2005.0..2050.0).contains(&year) {
        let t = year - 2000.0;
        62.92 + 0.32217 * t + 0.005_589 * t * t
    } else if (2050.0..2150.0).contains(&year) {
        long_term(year) - 0.5628 * (2150.0 - year)
    } else {
        long_term(year)
    }
}

/// Decimal year of a Julian day, for [`estimate_delta_t_s`] (J2000.0 = 2000.0, Julian years).
fn decimal_year(jd: f64) -> f64 {
    2000.0 + (jd - 2_451_545.0) / 365.25
}

/// Brings an angle in degrees into [0, 360).
pub(crate) fn wrap_degrees(degrees: f64) -> f64 {
    let wrapped = degrees.rem_euclid(360.0);
    // rem_euclid can round up to exactly 360 for tiny negative inputs.
    if wrapped >= 360.0 { 0.0 } else { wrapped }
}

/// Apparent solar radius, degrees (SPA's refraction cut-off, eq. 43).
const SUN_RADIUS_DEG: f64 = 0.266_67;
/// Atmospheric refraction at the horizon, degrees (SPA's refraction cut-off, eq. 43).
const HORIZON_REFRACTION_DEG: f64 = 0.5667;

/// `(amplitude A, phase B, frequency C)`: one term `A cos(B + C·JME)` (eq. 9).
type PeriodicTerm = (f64, f64, f64);

/// `(multipliers of X0..X4, a, b, c, d)`: one nutation term (eqs. 15–16).
type NutationTerm = ([i8; 5], f64, f64, f64, f64);

/// Sum over the series of eq. 9–11: `Σ_i (Σ_j A cos(B + C·JME)) · JME^i / 10⁸` (radians or AU).
fn earth_periodic_sum(series: &[&[PeriodicTerm]], jme: f64) -> f64 {
    let mut total = 0.0;
    let mut power = 1.0;
    for terms in series {
        let sum: f64 = terms.iter().map(|&(a, b, c)| a * (b + c * jme).cos()).sum();
        total += sum * power;
        power *= jme;
    }
    total / 1.0e8
}

/// `a + b·x + c·x² + x³/d` (the nutation arguments of eqs. 15–19 are all of this form).
fn cubic(a: f64, b: f64, c: f64, d: f64, x: f64) -> f64 {
    a + x * (b + x * (c + x / d))
}

/// The intermediates of the algorithm that the paper's worked example lists, and the result.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(
    not(test),
    allow(
        dead_code,
        reason = "intermediates are checked against the paper's worked example"
    )
)]
struct Spa {
    heliocentric_longitude_deg: f64,
    heliocentric_latitude_deg: f64,
    nutation_longitude_deg: f64,
    nutation_obliquity_deg: f64,
    true_obliquity_deg: f64,
    apparent_longitude_deg: f64,
    observer_hour_angle_deg: f64,
    topocentric_declination_deg: f64,
    topocentric_right_ascension_deg: f64,
    /// JCE, Julian centuries of Terrestrial Time from J2000.0 (eq. 7).
    julian_ephemeris_century: f64,
    /// Apparent sidereal time at Greenwich ν, [0, 360) (eq. 29).
    apparent_sidereal_time_deg: f64,
    position: SolarPosition,
}

/// What the Earth's frame and the sun are at a Julian day (UT), for the moon
/// ([`super::moon`]): SPA's time scale, nutation, obliquity, sidereal time and the sun's
/// apparent geocentric longitude, latitude and distance.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EarthFrame {
    /// Julian centuries of Terrestrial Time from J2000.0.
    pub julian_ephemeris_century: f64,
    /// Nutation in longitude Δψ, degrees.
    pub nutation_longitude_deg: f64,
    /// True obliquity of the ecliptic ε, degrees.
    pub true_obliquity_deg: f64,
    /// Apparent sidereal time at Greenwich, degrees, [0, 360).
    pub apparent_sidereal_time_deg: f64,
    /// The sun's apparent geocentric longitude, degrees.
    pub sun_longitude_deg: f64,
    /// Earth–Sun distance, astronomical units.
    pub sun_distance_au: f64,
}

/// [`EarthFrame`] at Julian day `jd` (UT), ΔT from `options` as in [`solar_position`].
pub(crate) fn earth_frame(jd: f64, options: &SolarOptions) -> EarthFrame {
    let spa = spa(&Observer::default(), jd, options);
    EarthFrame {
        julian_ephemeris_century: spa.julian_ephemeris_century,
        nutation_longitude_deg: spa.nutation_longitude_deg,
        true_obliquity_deg: spa.true_obliquity_deg,
        apparent_sidereal_time_deg: spa.apparent_sidereal_time_deg,
        sun_longitude_deg: spa.apparent_longitude_deg,
        sun_distance_au: spa.position.earth_sun_distance_au,
    }
}

/// A body's direction seen from the observer's place on the ellipsoid ([`topocentric`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Topocentric {
    /// Elevation above the horizon, refracted when the options ask for it, degrees.
    pub elevation_deg: f64,
    /// Elevation without refraction, degrees.
    pub geometric_elevation_deg: f64,
    /// Azimuth clockwise from north, [0, 360).
    pub azimuth_deg: f64,
    /// Topocentric local hour angle, [0, 360).
    pub hour_angle_deg: f64,
    /// Topocentric declination, degrees.
    pub declination_deg: f64,
    /// Topocentric right ascension, degrees.
    pub right_ascension_deg: f64,
}

/// Steps 3.12–3.15 of SPA (eqs. 33–46), which are Meeus's (1998, ch. 40) parallax for any body:
/// the geocentric right ascension `alpha_deg` and declination `delta_deg` of a body at local hour
/// angle `hour_angle_deg` and equatorial horizontal parallax `parallax_rad`, seen from `observer`
/// (ellipsoid: 1 − flattening 0.99664719, equatorial radius 6 378 140 m), with refraction for a
/// standard atmosphere scaled to the options' pressure and temperature (Bennett's formula as SPA
/// uses it) when on and the body, of apparent radius `radius_deg`, is not wholly below the
/// horizon's refraction.
pub(crate) fn topocentric(
    observer: &Observer,
    alpha_deg: f64,
    delta_deg: f64,
    hour_angle_deg: f64,
    parallax_rad: f64,
    radius_deg: f64,
    options: &SolarOptions,
) -> Topocentric {
    // 3.12 Topocentric right ascension (eqs. 33–38).
    let xi = parallax_rad;
    let phi = observer.latitude_deg.to_radians();
    let u_angle = (0.996_647_19 * phi.tan()).atan();
    let height_ratio = observer.elevation_m / 6_378_140.0;
    let x_term = u_angle.cos() + height_ratio * phi.cos();
    let y_term = 0.996_647_19 * u_angle.sin() + height_ratio * phi.sin();
    let h_rad = hour_angle_deg.to_radians();
    let delta_rad = delta_deg.to_radians();
    let denominator = delta_rad.cos() - x_term * xi.sin() * h_rad.cos();
    let delta_alpha = (-x_term * xi.sin() * h_rad.sin()).atan2(denominator);
    let delta_prime =
        ((delta_rad.sin() - y_term * xi.sin()) * delta_alpha.cos()).atan2(denominator);

    // 3.13 Topocentric local hour angle (eq. 39).
    let h_prime = h_rad - delta_alpha;

    // 3.14 Topocentric elevation (eqs. 40–44).
    let e0 = (phi.sin() * delta_prime.sin() + phi.cos() * delta_prime.cos() * h_prime.cos())
        .asin()
        .to_degrees();
    let delta_e = if options.refraction && e0 >= -(radius_deg + HORIZON_REFRACTION_DEG) {
        (options.pressure_hpa / 1010.0) * (283.0 / (273.0 + options.temperature_c)) * 1.02
            / (60.0 * (e0 + 10.3 / (e0 + 5.11)).to_radians().tan())
    } else {
        0.0
    };

    // 3.15 Topocentric azimuth (eqs. 45–46), converted from astronomers' (westward from south)
    // to navigators' (clockwise from north).
    let gamma = h_prime
        .sin()
        .atan2(h_prime.cos() * phi.sin() - delta_prime.tan() * phi.cos())
        .to_degrees();
    Topocentric {
        elevation_deg: e0 + delta_e,
        geometric_elevation_deg: e0,
        azimuth_deg: wrap_degrees(gamma + 180.0),
        hour_angle_deg: wrap_degrees(h_prime.to_degrees()),
        declination_deg: delta_prime.to_degrees(),
        right_ascension_deg: alpha_deg + delta_alpha.to_degrees(),
    }
}

/// The algorithm, steps 3.1–3.15 of the paper, at Julian day `jd` (UT).
fn spa(observer: &Observer, jd: f64, options: &SolarOptions) -> Spa {
    // 3.1 Time scales (eqs. 5–8).
    let delta_t = options
        .delta_t_s
        .unwrap_or_else(|| estimate_delta_t_s(decimal_year(jd)));
    let jde = jd + delta_t / 86_400.0;
    let jc = (jd - 2_451_545.0) / 36_525.0;
    let jce = (jde - 2_451_545.0) / 36_525.0;
    let jme = jce / 10.0;

    // 3.2 Earth heliocentric longitude, latitude and radius vector (eqs. 9–12).
    let l = wrap_degrees(earth_periodic_sum(&L_TERMS, jme).to_degrees());
    let b = earth_periodic_sum(&B_TERMS, jme).to_degrees();
    let r = earth_periodic_sum(&R_TERMS, jme);

    // 3.3 Geocentric longitude and latitude (eqs. 13–14): the sun seen from the Earth.
    let theta = wrap_degrees(l + 180.0);
    let beta = -b;

    // 3.4 Nutation in longitude and obliquity (eqs. 15–23). X0..X4: mean elongation of the moon,
    // mean anomalies of sun and moon, moon's argument of latitude, longitude of its node.
    let x = [
        cubic(297.850_36, 445_267.111_480, -0.001_914_2, 189_474.0, jce),
        cubic(357.527_72, 35_999.050_340, -0.000_160_3, -300_000.0, jce),
        cubic(134.962_98, 477_198.867_398, 0.008_697_2, 56_250.0, jce),
        cubic(93.271_91, 483_202.017_538, -0.003_682_5, 327_270.0, jce),
        cubic(125.044_52, -1_934.136_261, 0.002_070_8, 450_000.0, jce),
    ];
    let (mut delta_psi, mut delta_epsilon) = (0.0, 0.0);
    for &(multipliers, a, b_coefficient, c, d) in &NUTATION {
        let argument: f64 = multipliers
            .iter()
            .zip(x)
            .map(|(&m, x)| f64::from(m) * x)
            .sum::<f64>()
            .to_radians();
        delta_psi += (a + b_coefficient * jce) * argument.sin();
        delta_epsilon += (c + d * jce) * argument.cos();
    }
    // Table units are 0.0001 arc seconds.
    let delta_psi = delta_psi / 36_000_000.0;
    let delta_epsilon = delta_epsilon / 36_000_000.0;

    // 3.5 True obliquity of the ecliptic (eqs. 24–25), U in units of 10 000 Julian years.
    let u = jme / 10.0;
    let epsilon0_arcsec = [
        84_381.448, -4680.93, -1.55, 1999.25, -51.38, -249.67, -39.05, 7.12, 27.87, 5.79, 2.45,
    ]
    .iter()
    .rev()
    .fold(0.0, |acc, &coefficient| acc * u + coefficient);
    let epsilon = epsilon0_arcsec / 3600.0 + delta_epsilon;

    // 3.6–3.7 Aberration correction and apparent sun longitude (eqs. 26–27).
    let delta_tau = -20.4898 / (3600.0 * r);
    let lambda = theta + delta_psi + delta_tau;

    // 3.8 Apparent sidereal time at Greenwich (eqs. 28–29).
    let nu0 = wrap_degrees(
        280.460_618_37 + 360.985_647_366_29 * (jd - 2_451_545.0) + 0.000_387_933 * jc * jc
            - jc.powi(3) / 38_710_000.0,
    );
    let nu = nu0 + delta_psi * epsilon.to_radians().cos();

    // 3.9–3.10 Geocentric right ascension and declination (eqs. 30–31).
    let (sin_lambda, cos_lambda) = lambda.to_radians().sin_cos();
    let (sin_epsilon, cos_epsilon) = epsilon.to_radians().sin_cos();
    let beta_rad = beta.to_radians();
    let alpha = wrap_degrees(
        (sin_lambda * cos_epsilon - beta_rad.tan() * sin_epsilon)
            .atan2(cos_lambda)
            .to_degrees(),
    );
    let delta = (beta_rad.sin() * cos_epsilon + beta_rad.cos() * sin_epsilon * sin_lambda)
        .asin()
        .to_degrees();

    // 3.11 Observer local hour angle (eq. 32), longitude east positive.
    let hour_angle = wrap_degrees(nu + observer.longitude_deg - alpha);

    let seen = topocentric(
        observer,
        alpha,
        delta,
        hour_angle,
        (8.794 / (3600.0 * r)).to_radians(),
        SUN_RADIUS_DEG,
        options,
    );
    let (elevation, e0, azimuth) = (
        seen.elevation_deg,
        seen.geometric_elevation_deg,
        seen.azimuth_deg,
    );

    Spa {
        heliocentric_longitude_deg: l,
        heliocentric_latitude_deg: b,
        nutation_longitude_deg: delta_psi,
        nutation_obliquity_deg: delta_epsilon,
        true_obliquity_deg: epsilon,
        apparent_longitude_deg: lambda,
        observer_hour_angle_deg: hour_angle,
        topocentric_declination_deg: seen.declination_deg,
        topocentric_right_ascension_deg: seen.right_ascension_deg,
        julian_ephemeris_century: jce,
        apparent_sidereal_time_deg: wrap_degrees(nu),
        position: SolarPosition {
            zenith_deg: 90.0 - elevation,
            elevation_deg: elevation,
            geometric_elevation_deg: e0,
            azimuth_deg: azimuth,
            declination_deg: delta,
            right_ascension_deg: alpha,
            greenwich_hour_angle_deg: wrap_degrees(nu - alpha),
            hour_angle_deg: seen.hour_angle_deg,
            earth_sun_distance_au: r,
        },
    }
}

// Periodic terms of Reda & Andreas (2004), Appendix A4, as numbers (generated from the tables).

/// Earth heliocentric longitude terms L0–L5 (Table A4.2).
const L0: [PeriodicTerm; 64] = [
    (175_347_046.0, 0.0, 0.0),
    (3_341_656.0, 4.6692568, 6283.07585),
    (34_894.0, 4.6261, 12566.1517),
    (3497.0, 2.7441, 5753.3849),
    (3418.0, 2.8289, 3.5231),
    (3136.0, 3.6277, 77713.7715),
    (2676.0, 4.4181, 7860.4194),
    (2343.0, 6.1352, 3930.2097),
    (1324.0, 0.7425, 11506.7698),
    (1273.0, 2.0371, 529.691),
    (1199.0, 1.1096, 1577.3435),
    (990.0, 5.233, 5884.927),
    (902.0, 2.045, 26.298),
    (857.0, 3.508, 398.149),
    (780.0, 1.179, 5223.694),
    (753.0, 2.533, 5507.553),
    (505.0, 4.583, 18849.228),
    (492.0, 4.205, 775.523),
    (357.0, 2.92, 0.067),
    (317.0, 5.849, 11790.629),
    (284.0, 1.899, 796.298),
    (271.0, 0.315, 10977.079),
    (243.0, 0.345, 5486.778),
    (206.0, 4.806, 2544.314),
    (205.0, 1.869, 5573.143),
    (202.0, 2.458, 6069.777),
    (156.0, 0.833, 213.299),
    (132.0, 3.411, 2942.463),
    (126.0, 1.083, 20.775),
    (115.0, 0.645, 0.98),
    (103.0, 0.636, 4694.003),
    (102.0, 0.976, 15720.839),
    (102.0, 4.267, 7.114),
    (99.0, 6.21, 2146.17),
    (98.0, 0.68, 155.42),
    (86.0, 5.98, 161000.69),
    (85.0, 1.3, 6275.96),
    (85.0, 3.67, 71430.7),
    (80.0, 1.81, 17260.15),
    (79.0, 3.04, 12036.46),
    (75.0, 1.76, 5088.63),
    (74.0, 3.5, 3154.69),
    (74.0, 4.68, 801.82),
    (70.0, 0.83, 9437.76),
    (62.0, 3.98, 8827.39),
    (61.0, 1.82, 7084.9),
    (57.0, 2.78, 6286.6),
    (56.0, 4.39, 14143.5),
    (56.0, 3.47, 6279.55),
    (52.0, 0.19, 12139.55),
    (52.0, 1.33, 1748.02),
    (51.0, 0.28, 5856.48),
    (49.0, 0.49, 1194.45),
    (41.0, 5.37, 8429.24),
    (41.0, 2.4, 19651.05),
    (39.0, 6.17, 10447.39),
    (37.0, 6.04, 10213.29),
    (37.0, 2.57, 1059.38),
    (36.0, 1.71, 2352.87),
    (36.0, 1.78, 6812.77),
    (33.0, 0.59, 17789.85),
    (30.0, 0.44, 83996.85),
    (30.0, 2.74, 1349.87),
    (25.0, 3.16, 4690.48),
];
const L1: [PeriodicTerm; 34] = [
    (628_331_966_747.0, 0.0, 0.0),
    (206_059.0, 2.678235, 6283.07585),
    (4303.0, 2.6351, 12566.1517),
    (425.0, 1.59, 3.523),
    (119.0, 5.796, 26.298),
    (109.0, 2.966, 1577.344),
    (93.0, 2.59, 18849.23),
    (72.0, 1.14, 529.69),
    (68.0, 1.87, 398.15),
    (67.0, 4.41, 5507.55),
    (59.0, 2.89, 5223.69),
    (56.0, 2.17, 155.42),
    (45.0, 0.4, 796.3),
    (36.0, 0.47, 775.52),
    (29.0, 2.65, 7.11),
    (21.0, 5.34, 0.98),
    (19.0, 1.85, 5486.78),
    (19.0, 4.97, 213.3),
    (17.0, 2.99, 6275.96),
    (16.0, 0.03, 2544.31),
    (16.0, 1.43, 2146.17),
    (15.0, 1.21, 10977.08),
    (12.0, 2.83, 1748.02),
    (12.0, 3.26, 5088.63),
    (12.0, 5.27, 1194.45),
    (12.0, 2.08, 4694.0),
    (11.0, 0.77, 553.57),
    (10.0, 1.3, 6286.6),
    (10.0, 4.24, 1349.87),
    (9.0, 2.7, 242.73),
    (9.0, 5.64, 951.72),
    (8.0, 5.3, 2352.87),
    (6.0, 2.65, 9437.76),
    (6.0, 4.67, 4690.48),
];
const L2: [PeriodicTerm; 20] = [
    (52_919.0, 0.0, 0.0),
    (8720.0, 1.0721, 6283.0758),
    (309.0, 0.867, 12566.152),
    (27.0, 0.05, 3.52),
    (16.0, 5.19, 26.3),
    (16.0, 3.68, 155.42),
    (10.0, 0.76, 18849.23),
    (9.0, 2.06, 77713.77),
    (7.0, 0.83, 775.52),
    (5.0, 4.66, 1577.34),
    (4.0, 1.03, 7.11),
    (4.0, 3.44, 5573.14),
    (3.0, 5.14, 796.3),
    (3.0, 6.05, 5507.55),
    (3.0, 1.19, 242.73),
    (3.0, 6.12, 529.69),
    (3.0, 0.31, 398.15),
    (3.0, 2.28, 553.57),
    (2.0, 4.38, 5223.69),
    (2.0, 3.75, 0.98),
];
const L3: [PeriodicTerm; 7] = [
    (289.0, 5.844, 6283.076),
    (35.0, 0.0, 0.0),
    (17.0, 5.49, 12566.15),
    (3.0, 5.2, 155.42),
    (1.0, 4.72, 3.52),
    (1.0, 5.3, 18849.23),
    (1.0, 5.97, 242.73),
];
#[allow(
    clippy::approx_constant,
    reason = "a published phase of 3.14 rad, not an approximation of π"
)]
const L4: [PeriodicTerm; 3] = [
    (114.0, 3.142, 0.0),
    (8.0, 4.13, 6283.08),
    (1.0, 3.84, 12566.15),
];
#[allow(
    clippy::approx_constant,
    reason = "a published phase of 3.14 rad, not an approximation of π"
)]
const L5: [PeriodicTerm; 1] = [(1.0, 3.14, 0.0)];
const L_TERMS: [&[PeriodicTerm]; 6] = [&L0, &L1, &L2, &L3, &L4, &L5];

/// Earth heliocentric latitude terms B0–B1 (Table A4.2).
const B0: [PeriodicTerm; 5] = [
    (280.0, 3.199, 84334.662),
    (102.0, 5.422, 5507.553),
    (80.0, 3.88, 5223.69),
    (44.0, 3.7, 2352.87),
    (32.0, 4.0, 1577.34),
];
const B1: [PeriodicTerm; 2] = [(9.0, 3.9, 5507.55), (6.0, 1.73, 5223.69)];
const B_TERMS: [&[PeriodicTerm]; 2] = [&B0, &B1];

/// Earth radius vector terms R0–R4 (Table A4.2).
const R0: [PeriodicTerm; 40] = [
    (100_013_989.0, 0.0, 0.0),
    (1_670_700.0, 3.0984635, 6283.07585),
    (13_956.0, 3.05525, 12566.1517),
    (3084.0, 5.1985, 77713.7715),
    (1628.0, 1.1739, 5753.3849),
    (1576.0, 2.8469, 7860.4194),
    (925.0, 5.453, 11506.77),
    (542.0, 4.564, 3930.21),
    (472.0, 3.661, 5884.927),
    (346.0, 0.964, 5507.553),
    (329.0, 5.9, 5223.694),
    (307.0, 0.299, 5573.143),
    (243.0, 4.273, 11790.629),
    (212.0, 5.847, 1577.344),
    (186.0, 5.022, 10977.079),
    (175.0, 3.012, 18849.228),
    (110.0, 5.055, 5486.778),
    (98.0, 0.89, 6069.78),
    (86.0, 5.69, 15720.84),
    (86.0, 1.27, 161000.69),
    (65.0, 0.27, 17260.15),
    (63.0, 0.92, 529.69),
    (57.0, 2.01, 83996.85),
    (56.0, 5.24, 71430.7),
    (49.0, 3.25, 2544.31),
    (47.0, 2.58, 775.52),
    (45.0, 5.54, 9437.76),
    (43.0, 6.01, 6275.96),
    (39.0, 5.36, 4694.0),
    (38.0, 2.39, 8827.39),
    (37.0, 0.83, 19651.05),
    (37.0, 4.9, 12139.55),
    (36.0, 1.67, 12036.46),
    (35.0, 1.84, 2942.46),
    (33.0, 0.24, 7084.9),
    (32.0, 0.18, 5088.63),
    (32.0, 1.78, 398.15),
    (28.0, 1.21, 6286.6),
    (28.0, 1.9, 6279.55),
    (26.0, 4.59, 10447.39),
];
#[allow(
    clippy::approx_constant,
    reason = "a published phase of 3.14 rad, not an approximation of π"
)]
const R1: [PeriodicTerm; 10] = [
    (103_019.0, 1.10749, 6283.07585),
    (1721.0, 1.0644, 12566.1517),
    (702.0, 3.142, 0.0),
    (32.0, 1.02, 18849.23),
    (31.0, 2.84, 5507.55),
    (25.0, 1.32, 5223.69),
    (18.0, 1.42, 1577.34),
    (10.0, 5.91, 10977.08),
    (9.0, 1.42, 6275.96),
    (9.0, 0.27, 5486.78),
];
#[allow(
    clippy::approx_constant,
    reason = "a published phase of 3.14 rad, not an approximation of π"
)]
const R2: [PeriodicTerm; 6] = [
    (4359.0, 5.7846, 6283.0758),
    (124.0, 5.579, 12566.152),
    (12.0, 3.14, 0.0),
    (9.0, 3.63, 77713.77),
    (6.0, 1.87, 5573.14),
    (3.0, 5.47, 18849.23),
];
const R3: [PeriodicTerm; 2] = [(145.0, 4.273, 6283.076), (7.0, 3.92, 12566.15)];
const R4: [PeriodicTerm; 1] = [(4.0, 2.56, 6283.08)];
const R_TERMS: [&[PeriodicTerm]; 5] = [&R0, &R1, &R2, &R3, &R4];

/// Nutation terms (Table A4.3): multipliers of X0–X4, then a, b (longitude) and c, d (obliquity)
/// in units of 0.0001″.
const NUTATION: [NutationTerm; 63] = [
    ([0, 0, 0, 0, 1], -171_996.0, -174.2, 92_025.0, 8.9),
    ([-2, 0, 0, 2, 2], -13_187.0, -1.6, 5736.0, -3.1),
    ([0, 0, 0, 2, 2], -2274.0, -0.2, 977.0, -0.5),
    ([0, 0, 0, 0, 2], 2062.0, 0.2, -895.0, 0.5),
    ([0, 1, 0, 0, 0], 1426.0, -3.4, 54.0, -0.1),
    ([0, 0, 1, 0, 0], 712.0, 0.1, -7.0, 0.0),
    ([-2, 1, 0, 2, 2], -517.0, 1.2, 224.0, -0.6),
    ([0, 0, 0, 2, 1], -386.0, -0.4, 200.0, 0.0),
    ([0, 0, 1, 2, 2], -301.0, 0.0, 129.0, -0.1),
    ([-2, -1, 0, 2, 2], 217.0, -0.5, -95.0, 0.3),
    ([-2, 0, 1, 0, 0], -158.0, 0.0, 0.0, 0.0),
    ([-2, 0, 0, 2, 1], 129.0, 0.1, -70.0, 0.0),
    ([0, 0, -1, 2, 2], 123.0, 0.0, -53.0, 0.0),
    ([2, 0, 0, 0, 0], 63.0, 0.0, 0.0, 0.0),
    ([0, 0, 1, 0, 1], 63.0, 0.1, -33.0, 0.0),
    ([2, 0, -1, 2, 2], -59.0, 0.0, 26.0, 0.0),
    ([0, 0, -1, 0, 1], -58.0, -0.1, 32.0, 0.0),
    ([0, 0, 1, 2, 1], -51.0, 0.0, 27.0, 0.0),
    ([-2, 0, 2, 0, 0], 48.0, 0.0, 0.0, 0.0),
    ([0, 0, -2, 2, 1], 46.0, 0.0, -24.0, 0.0),
    ([2, 0, 0, 2, 2], -38.0, 0.0, 16.0, 0.0),
    ([0, 0, 2, 2, 2], -31.0, 0.0, 13.0, 0.0),
    ([0, 0, 2, 0, 0], 29.0, 0.0, 0.0, 0.0),
    ([-2, 0, 1, 2, 2], 29.0, 0.0, -12.0, 0.0),
    ([0, 0, 0, 2, 0], 26.0, 0.0, 0.0, 0.0),
    ([-2, 0, 0, 2, 0], -22.0, 0.0, 0.0, 0.0),
    ([0, 0, -1, 2, 1], 21.0, 0.0, -10.0, 0.0),
    ([0, 2, 0, 0, 0], 17.0, -0.1, 0.0, 0.0),
    ([2, 0, -1, 0, 1], 16.0, 0.0, -8.0, 0.0),
    ([-2, 2, 0, 2, 2], -16.0, 0.1, 7.0, 0.0),
    ([0, 1, 0, 0, 1], -15.0, 0.0, 9.0, 0.0),
    ([-2, 0, 1, 0, 1], -13.0, 0.0, 7.0, 0.0),
    ([0, -1, 0, 0, 1], -12.0, 0.0, 6.0, 0.0),
    ([0, 0, 2, -2, 0], 11.0, 0.0, 0.0, 0.0),
    ([2, 0, -1, 2, 1], -10.0, 0.0, 5.0, 0.0),
    ([2, 0, 1, 2, 2], -8.0, 0.0, 3.0, 0.0),
    ([0, 1, 0, 2, 2], 7.0, 0.0, -3.0, 0.0),
    ([-2, 1, 1, 0, 0], -7.0, 0.0, 0.0, 0.0),
    ([0, -1, 0, 2, 2], -7.0, 0.0, 3.0, 0.0),
    ([2, 0, 0, 2, 1], -7.0, 0.0, 3.0, 0.0),
    ([2, 0, 1, 0, 0], 6.0, 0.0, 0.0, 0.0),
    ([-2, 0, 2, 2, 2], 6.0, 0.0, -3.0, 0.0),
    ([-2, 0, 1, 2, 1], 6.0, 0.0, -3.0, 0.0),
    ([2, 0, -2, 0, 1], -6.0, 0.0, 3.0, 0.0),
    ([2, 0, 0, 0, 1], -6.0, 0.0, 3.0, 0.0),
    ([0, -1, 1, 0, 0], 5.0, 0.0, 0.0, 0.0),
    ([-2, -1, 0, 2, 1], -5.0, 0.0, 3.0, 0.0),
    ([-2, 0, 0, 0, 1], -5.0, 0.0, 3.0, 0.0),
    ([0, 0, 2, 2, 1], -5.0, 0.0, 3.0, 0.0),
    ([-2, 0, 2, 0, 1], 4.0, 0.0, 0.0, 0.0),
    ([-2, 1, 0, 2, 1], 4.0, 0.0, 0.0, 0.0),
    ([0, 0, 1, -2, 0], 4.0, 0.0, 0.0, 0.0),
    ([-1, 0, 1, 0, 0], -4.0, 0.0, 0.0, 0.0),
    ([-2, 1, 0, 0, 0], -4.0, 0.0, 0.0, 0.0),
    ([1, 0, 0, 0, 0], -4.0, 0.0, 0.0, 0.0),
    ([0, 0, 1, 2, 0], 3.0, 0.0, 0.0, 0.0),
    ([0, 0, -2, 2, 2], -3.0, 0.0, 0.0, 0.0),
    ([-1, -1, 1, 0, 0], -3.0, 0.0, 0.0, 0.0),
    ([0, 1, 1, 0, 0], -3.0, 0.0, 0.0, 0.0),
    ([0, -1, 1, 2, 2], -3.0, 0.0, 0.0, 0.0),
    ([2, -1, -1, 2, 2], -3.0, 0.0, 0.0, 0.0),
    ([0, 0, 3, 2, 2], -3.0, 0.0, 0.0, 0.0),
    ([2, -1, 0, 2, 2], -3.0, 0.0, 0.0, 0.0),
];

impl From<&GeoOrigin> for Observer {
    /// The scene origin as an observer for the solar position.
    fn from(origin: &GeoOrigin) -> Self {
        Self {
            latitude_deg: origin.latitude_deg,
            longitude_deg: origin.longitude_deg,
            elevation_m: origin.elevation_m,
        }
    }
}

#[cfg(test)]
mod tests;
