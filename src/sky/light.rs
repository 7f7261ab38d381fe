//! Sunlight and skylight reaching the clouds, from the sun's elevation: a small analytic clear-sky
//! model, so the clouds are lit consistently with Bevy's `Atmosphere` without reading its LUTs.
//!
//! - **Direct sun**: Beer–Lambert through the air mass of Kasten & Young (1989), with the
//!   Rayleigh optical depth of Hansen & Travis (1974, eq. 2.30) at 680, 550 and 440 nm for the
//!   red, green and blue channels, scaled by pressure with a scale height of 8 km, plus a clean
//!   continental aerosol (optical depth 0.1 at 550 nm, Ångström exponent 1.3; Ångström 1929).
//! - **Sky**: the light scattered out of the direct beam, half of it downward (single
//!   scattering, isotropic split), spread over the sky dome: `E_sky = E₀ sin h · ½ (1 − T)`, and
//!   radiance `E_sky / π`. Blue scatters most, so the sky comes out blue by day and the sun
//!   reddens at the horizon.
//!
//! It is an approximation, good to tens of percent; it exists so the clouds have the right
//! colour and brightness relative to the sun, not to replace a sky model.

/// Rayleigh optical depth of a vertical sea-level column at 680, 550 and 440 nm (Hansen &
/// Travis 1974, eq. 2.30: `τ = 0.008569 λ⁻⁴ (1 + 0.0113 λ⁻² + 0.00013 λ⁻⁴)`, λ in µm).
pub const RAYLEIGH_OPTICAL_DEPTH_RGB: [f64; 3] = [0.0411, 0.0973, 0.2428];

/// Aerosol optical depth at 680, 550 and 440 nm: 0.1 at 550 nm with Ångström exponent 1.3.
pub const AEROSOL_OPTICAL_DEPTH_RGB: [f64; 3] = [0.0759, 0.1, 0.1337];

/// Scale height of the air (Rayleigh scattering), metres.
const RAYLEIGH_SCALE_HEIGHT_M: f64 = 8_000.0;
/// Scale height of the aerosol, metres.
const AEROSOL_SCALE_HEIGHT_M: f64 = 1_200.0;

/// Relative optical air mass for an apparent solar elevation in degrees (Kasten & Young 1989);
/// finite down to −0.5°, and capped at the horizon's value below that.
pub fn air_mass(elevation_deg: f64) -> f64 {
    let h = elevation_deg.max(-0.5);
    let zenith = 90.0 - h;
    1.0 / (zenith.to_radians().cos() + 0.50572 * (96.07995 - zenith).powf(-1.6364))
}

/// Fraction of sunlight that reaches `altitude_m` above sea level directly, per RGB channel.
pub fn sun_transmittance_rgb(elevation_deg: f64, altitude_m: f64) -> [f64; 3] {
    let m = air_mass(elevation_deg);
    let rayleigh = (-altitude_m.max(0.0) / RAYLEIGH_SCALE_HEIGHT_M).exp();
    let aerosol = (-altitude_m.max(0.0) / AEROSOL_SCALE_HEIGHT_M).exp();
    std::array::from_fn(|c| {
        let tau = RAYLEIGH_OPTICAL_DEPTH_RGB[c] * rayleigh + AEROSOL_OPTICAL_DEPTH_RGB[c] * aerosol;
        (-tau * m).exp()
    })
}

/// Sky radiance for ambient lighting, per RGB channel, in the units of `sun_illuminance` per
/// steradian (lux/sr with illuminance in lux): the clear-sky diffuse irradiance on a horizontal
/// surface divided by π. Zero when the sun is below the horizon.
pub fn sky_radiance_rgb(
    sun_illuminance: [f64; 3],
    elevation_deg: f64,
    altitude_m: f64,
) -> [f64; 3] {
    let sin_h = elevation_deg.to_radians().sin().max(0.0);
    let transmitted = sun_transmittance_rgb(elevation_deg, altitude_m);
    std::array::from_fn(|c| {
        sun_illuminance[c] * sin_h * 0.5 * (1.0 - transmitted[c]) / std::f64::consts::PI
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn air_mass_matches_kasten_young_table() {
        // Kasten & Young 1989: the formula gives 1.994 at 30° (sec z = 2 less refraction and
        // curvature) and 37.92 at the horizon (their tabulated exact value is 38.09).
        assert!((air_mass(90.0) - 1.0).abs() < 1e-3);
        assert!((air_mass(30.0) - 1.994).abs() < 1e-3);
        assert!((air_mass(0.0) - 38.09).abs() < 0.25);
        assert!(air_mass(-10.0).is_finite());
    }

    #[test]
    fn rayleigh_depths_follow_hansen_travis() {
        for (tau, lambda_um) in RAYLEIGH_OPTICAL_DEPTH_RGB.iter().zip([0.68f64, 0.55, 0.44]) {
            let expected = 0.008569
                * lambda_um.powi(-4)
                * (1.0 + 0.0113 * lambda_um.powi(-2) + 0.00013 * lambda_um.powi(-4));
            assert!(
                (tau - expected).abs() / expected < 2e-3,
                "{tau} vs {expected}"
            );
        }
    }

    #[test]
    fn low_sun_is_red_and_sky_is_blue() {
        let noon = sun_transmittance_rgb(60.0, 500.0);
        let sunset = sun_transmittance_rgb(2.0, 500.0);
        assert!(noon.iter().all(|t| (0.6..1.0).contains(t)));
        assert!(sunset[0] > 2.0 * sunset[2], "reddened: {sunset:?}");
        let sky = sky_radiance_rgb([1.0; 3], 40.0, 500.0);
        assert!(sky[2] > sky[1] && sky[1] > sky[0], "blue sky: {sky:?}");
        assert_eq!(sky_radiance_rgb([1.0; 3], -3.0, 500.0), [0.0; 3]);
    }
}
