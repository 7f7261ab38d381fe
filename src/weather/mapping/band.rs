//! [`CloudBand`] and [`CloudBands`]: the altitude bands that slot bases are clamped into.

/// An altitude band above ground, metres: where a slot's layer base may lie.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudBand {
    /// Lowest base, metres above ground.
    pub bottom_m: f32,
    /// Highest base, metres above ground.
    pub top_m: f32,
}

impl CloudBand {
    /// Clamps a base altitude into the band. It never panics, even for an inverted or NaN band.
    #[must_use]
    pub fn clamp_base(self, base_m: f32) -> f32 {
        base_m.max(self.bottom_m).min(self.top_m)
    }
}

/// The low, mid and high bands that a forecast's `lowclouds`, `midclouds` and `highclouds`
/// describe (meteoblue's Packages API documentation (docs.meteoblue.com), cloud layer altitudes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudBands {
    /// Low-cloud band.
    pub low: CloudBand,
    /// Mid-cloud band.
    pub mid: CloudBand,
    /// High-cloud band.
    pub high: CloudBand,
}

impl CloudBands {
    /// meteoblue (WMO étages for mid latitudes): low surface–2 km, mid 2–7 km, high 5–13 km
    /// above ground.
    pub const METEOBLUE: Self = Self {
        low: CloudBand {
            bottom_m: 0.0,
            top_m: 2_000.0,
        },
        mid: CloudBand {
            bottom_m: 2_000.0,
            top_m: 7_000.0,
        },
        high: CloudBand {
            bottom_m: 5_000.0,
            top_m: 13_000.0,
        },
    };

    /// Open-Meteo: low up to 3 km, mid 3–8 km, high above 8 km (capped at 13 km, the top of the
    /// WMO high étage).
    pub const OPEN_METEO: Self = Self {
        low: CloudBand {
            bottom_m: 0.0,
            top_m: 3_000.0,
        },
        mid: CloudBand {
            bottom_m: 3_000.0,
            top_m: 8_000.0,
        },
        high: CloudBand {
            bottom_m: 8_000.0,
            top_m: 13_000.0,
        },
    };
}
