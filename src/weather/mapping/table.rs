//! [`MAPPING_TABLE`]: the mapping table as data.

use super::LayerSlot;

/// One row of the mapping table, as data (the [module docs](super) render it with reasons).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MappingRow {
    /// The forecast input: a [`Variable::name`], `"pictocode"`, `"weather_code"`,
    /// `"level_wind"`, `"level_height"` or `"ground_elevation_m"`.
    ///
    /// [`Variable::name`]: crate::weather::Variable::name
    pub input: &'static str,
    /// The slots it drives.
    pub slots: &'static [LayerSlot],
    /// What it drives, and how.
    pub rule: &'static str,
}

/// The mapping table as data, in the order of the [module docs](super)' table.
pub const MAPPING_TABLE: [MappingRow; 14] = {
    use LayerSlot::{Convective, Fog, High, Low, Mid};
    [
        MappingRow {
            input: "low_cover",
            slots: &[Low, Convective],
            rule: "low coverage; kind cumulus < 0.6 ≤ stratocumulus, stratus at ≥ 0.9 with precipitation; raises cumulonimbus coverage",
        },
        MappingRow {
            input: "mid_cover",
            slots: &[Mid],
            rule: "mid coverage; altocumulus < 0.7 ≤ altostratus (≥ 0.5 when raining)",
        },
        MappingRow {
            input: "high_cover",
            slots: &[High],
            rule: "high coverage; cirrus < 0.7 ≤ cirrostratus",
        },
        MappingRow {
            input: "convective_precipitation",
            slots: &[Convective, Low],
            rule: "cumulonimbus at ≥ 1 mm/h, coverage 0.15 + 0.45·max(1 − e^(−rate/5), low cover), its rain; cumulus low layer at ≥ 0.1 mm/h",
        },
        MappingRow {
            input: "lightning_potential",
            slots: &[Convective],
            rule: "cumulonimbus at ≥ 1 J/kg, coverage as for convective precipitation",
        },
        MappingRow {
            input: "pictocode",
            slots: &[Convective, Fog, Low],
            rule: "10–12, 27–30 cumulonimbus; 16–18 fog ≥ 0.8 and stratus; 31–32 cumulus; 23–26, 33–35 stratus",
        },
        MappingRow {
            input: "weather_code",
            slots: &[Convective, Fog, Low],
            rule: "WMO 95–99 cumulonimbus; 45, 48 fog ≥ 0.8 and stratus; 80–86 cumulus; 51–77 stratus",
        },
        MappingRow {
            input: "fog_probability",
            slots: &[Fog],
            rule: "fog coverage (p − 0.2) / 0.8",
        },
        MappingRow {
            input: "visibility",
            slots: &[Fog],
            rule: "fog coverage 0 at 5 km to 1 at 1 km, less in rain; density 3.912 / min(visibility, 1 km) (Koschmieder)",
        },
        MappingRow {
            input: "precipitation",
            slots: &[Fog, Low, Mid, Convective],
            rule: "darkening 1 − e^(−rate/2.5 mm/h); rain to the lowest covered layer; altostratus thickens downward",
        },
        MappingRow {
            input: "wind_speed",
            slots: &[Fog, Low, Mid, High, Convective],
            rule: "with wind_direction: layer wind where no level wind, v₁₀·(z/10 m)^(1/7)",
        },
        MappingRow {
            input: "level_wind",
            slots: &[Low, Mid, High, Convective],
            rule: "850 hPa low, 700–500 hPa mid (interpolated by height), 300 hPa high, mean of all for cumulonimbus",
        },
        MappingRow {
            input: "convective_cloud_base",
            slots: &[Convective, Low],
            rule: "with convective_cloud_top: cumulonimbus and cumulus base and top, above sea level − ground",
        },
        MappingRow {
            input: "ground_elevation_m",
            slots: &[Low, Mid, High, Convective],
            rule: "subtracted from heights above sea level (level heights, convective cloud base and top)",
        },
    ]
};
