//! The cloud genera and their default geometry and optics; the sources are in the
//! [`layers`](super) module docs.

use std::fmt;

use bevy::prelude::Reflect;

#[cfg(doc)]
use super::{CloudLayer, DensityProfile};

/// The cloud genera the crate draws (WMO International Cloud Atlas, WMO-No. 407). Nimbostratus is
/// left out: as Thomann 2021 §4.2.6 proposes, it is drawn as darkened, thickened altostratus over
/// stratus (see [`weather::mapping`](crate::weather::mapping)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum CloudKind {
    /// Detached heaps with flat bases and rounded, billowing tops. Low étage, formed by
    /// convection; fair weather.
    #[default]
    Cumulus,
    /// Grey or whitish patches, rolls or sheets of rounded masses. Low étage; the most common
    /// cloud on Earth.
    Stratocumulus,
    /// A grey, featureless, uniform sheet with a low base; in contact with the ground it is fog.
    Stratus,
    /// Mid-level sheets or patches of small rounded cloudlets, often shaded on one side.
    Altocumulus,
    /// A grey, fibrous or uniform mid-level sheet through which the sun shows dimly; often
    /// precedes rain.
    Altostratus,
    /// High, detached, hair-like white filaments of ice crystals.
    Cirrus,
    /// A thin, whitish, high veil of ice crystals that may make a halo.
    Cirrostratus,
    /// High sheets or patches of very small white cloudlets (ripples, grains).
    Cirrocumulus,
    /// Thundercloud: a tall tower from a low, dark base to a flat, spreading anvil near the
    /// tropopause.
    Cumulonimbus,
}

impl CloudKind {
    /// Every kind, from low to high and then cumulonimbus.
    pub const ALL: [Self; 9] = [
        Self::Cumulus,
        Self::Stratocumulus,
        Self::Stratus,
        Self::Altocumulus,
        Self::Altostratus,
        Self::Cirrus,
        Self::Cirrostratus,
        Self::Cirrocumulus,
        Self::Cumulonimbus,
    ];

    /// A lowercase name for messages and JSON output, e.g. `"stratocumulus"`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Cumulus => "cumulus",
            Self::Stratocumulus => "stratocumulus",
            Self::Stratus => "stratus",
            Self::Altocumulus => "altocumulus",
            Self::Altostratus => "altostratus",
            Self::Cirrus => "cirrus",
            Self::Cirrostratus => "cirrostratus",
            Self::Cirrocumulus => "cirrocumulus",
            Self::Cumulonimbus => "cumulonimbus",
        }
    }

    /// True for the cirrus family (cirrus, cirrostratus, cirrocumulus): high ice clouds.
    #[must_use]
    pub const fn is_cirrus_family(self) -> bool {
        matches!(self, Self::Cirrus | Self::Cirrostratus | Self::Cirrocumulus)
    }

    /// The kind's default altitudes, coverage, density, weather-map period, skew and coverage
    /// height (the table in the [`layers`](crate::layers) module docs, with its sources).
    #[must_use]
    pub const fn defaults(self) -> KindDefaults {
        let (base_m, top_m, coverage, density, weather_map_scale_m, skew) = match self {
            Self::Cumulus => (1_000.0, 2_200.0, 0.4, 0.07, 12_000.0, 0.1),
            Self::Stratocumulus => (800.0, 1_400.0, 0.7, 0.05, 20_000.0, 0.05),
            Self::Stratus => (150.0, 450.0, 0.9, 0.04, 40_000.0, 0.0),
            Self::Altocumulus => (3_000.0, 3_500.0, 0.5, 0.03, 15_000.0, 0.05),
            Self::Altostratus => (3_000.0, 5_000.0, 0.9, 0.015, 40_000.0, 0.0),
            Self::Cirrus => (8_000.0, 9_000.0, 0.4, 0.000_8, 50_000.0, 0.5),
            Self::Cirrostratus => (7_500.0, 8_500.0, 0.9, 0.000_4, 80_000.0, 0.1),
            Self::Cirrocumulus => (7_000.0, 7_400.0, 0.4, 0.001_6, 15_000.0, 0.1),
            Self::Cumulonimbus => (1_000.0, 10_000.0, 0.3, 0.1, 30_000.0, 0.2),
        };
        // Heaps grow tallest where the weather is most cloudy and round off toward their edges;
        // sheets keep a level top.
        let coverage_height = match self {
            Self::Cumulus => 1.0,
            Self::Stratocumulus | Self::Altocumulus | Self::Cirrocumulus | Self::Cumulonimbus => {
                0.5
            }
            Self::Stratus | Self::Altostratus | Self::Cirrus | Self::Cirrostratus => 0.0,
        };
        KindDefaults {
            base_m,
            top_m,
            coverage,
            density,
            weather_map_scale_m,
            skew,
            coverage_height,
        }
    }
}

impl fmt::Display for CloudKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Default geometry and optics of a [`CloudKind`], from [`CloudKind::defaults`]. The sources are
/// in the [`layers`](crate::layers) module docs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KindDefaults {
    /// Cloud base, metres above ground.
    pub base_m: f32,
    /// Cloud top, metres above ground.
    pub top_m: f32,
    /// Fraction of the sky covered, 0–1.
    pub coverage: f32,
    /// Extinction coefficient of the densest cloud, 1/m.
    pub density: f32,
    /// Period of the weather noise, metres.
    pub weather_map_scale_m: f32,
    /// Horizontal shift per metre of height, downwind (dimensionless).
    pub skew: f32,
    /// How much the local coverage sets the clouds' height, 0–1
    /// ([`CloudLayer::coverage_height`]).
    pub coverage_height: f32,
}
