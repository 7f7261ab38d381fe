//! The rain a layer drops, as light sees it: Marshall & Palmer 1948, "The distribution of
//! raindrops with size".

/// Marshall–Palmer slope `Λ = 4.1 R^(−0.21)`, 1/mm.
pub(crate) fn marshall_palmer_slope(rate_mm_per_h: f32) -> f32 {
    4.1 * rate_mm_per_h.powf(-0.21)
}

/// Extinction coefficient of rain falling at `rate_mm_per_h`, 1/m: geometric optics (extinction
/// efficiency 2) over the Marshall–Palmer drop sizes,
/// `σ = 2 ∫ (π D² / 4) N₀ e^(−ΛD) dD = π N₀ / Λ³`, which is `0.365 R^0.63` per km (a visibility
/// of about 11 km at 1 mm/h, 2.5 km at 10 mm/h). 0 for no or invalid rain. The march draws it as
/// rain shafts under raining layers (see `render::march`).
#[must_use]
pub fn rain_extinction_per_m(rate_mm_per_h: f32) -> f32 {
    if rate_mm_per_h.is_nan() || rate_mm_per_h <= 0.0 || !rate_mm_per_h.is_finite() {
        return 0.0;
    }
    let slope = marshall_palmer_slope(rate_mm_per_h);
    // N₀ = 8000 m⁻³ mm⁻¹; D in mm, so mm² per m³ → 1e-6 per m.
    std::f32::consts::PI * 8000.0 / slope.powi(3) * 1.0e-6
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rain_extinction_follows_the_marshall_palmer_power_law() {
        assert_eq!(rain_extinction_per_m(0.0), 0.0);
        assert_eq!(rain_extinction_per_m(f32::NAN), 0.0);
        let at_1 = rain_extinction_per_m(1.0);
        assert!((at_1 - 3.65e-4).abs() < 0.05e-4, "{at_1}");
        // σ ∝ Λ⁻³ ∝ R^0.63.
        let ratio = rain_extinction_per_m(10.0) / at_1;
        assert!((ratio - 10f32.powf(0.63)).abs() < 0.01, "{ratio}");
    }
}
