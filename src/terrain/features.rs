//! Known landmarks that a coarse DEM gets wrong: summits to pin and lakes to flood.

use std::borrow::Cow;

/// A summit whose height the mesh is made to match exactly (see
/// [`TerrainSettings::summits`](super::TerrainSettings::summits)).
#[derive(Debug, Clone, PartialEq)]
pub struct Summit {
    /// Name, for messages.
    pub name: Cow<'static, str>,
    /// Latitude of the top, degrees north.
    pub latitude_deg: f64,
    /// Longitude of the top, degrees east.
    pub longitude_deg: f64,
    /// Height of the top above sea level, metres.
    pub altitude_m: f32,
}

impl Summit {
    /// The Gurten, Bern's hill to the south: 858 m at 46.919° N 7.439° E (swisstopo national
    /// map; Wikipedia "Gurten"). GLOBE's 1 km cells read 628–828 m there.
    pub const GURTEN: Summit = Summit {
        name: Cow::Borrowed("Gurten"),
        latitude_deg: 46.919,
        longitude_deg: 7.439,
        altitude_m: 858.0,
    };

    /// The Bantiger, north-east of Bern: 947 m at 46.978° N 7.529° E (swisstopo national map;
    /// Wikipedia "Bantiger"). GLOBE reads 845 m there.
    pub const BANTIGER: Summit = Summit {
        name: Cow::Borrowed("Bantiger"),
        latitude_deg: 46.978,
        longitude_deg: 7.529,
        altitude_m: 947.0,
    };
}

/// A lake: DEM cells near `latitude_deg`/`longitude_deg` that are flat at `level_m` become water
/// (see [`TerrainSettings::lakes`](super::TerrainSettings::lakes) for the method).
#[derive(Debug, Clone, PartialEq)]
pub struct Lake {
    /// Name, for messages.
    pub name: Cow<'static, str>,
    /// Latitude of a point on the water near the lake's middle, degrees north.
    pub latitude_deg: f64,
    /// Longitude of that point, degrees east.
    pub longitude_deg: f64,
    /// Mean water level above sea level, metres.
    pub level_m: f32,
    /// How far from that point the lake may reach, metres: about half its length. Keeps the
    /// flood from running down a river valley at the same height.
    pub radius_m: f64,
}

impl Lake {
    /// Lake Thun (Thunersee), 558 m; 17.5 km long.
    pub const THUN: Lake = Lake {
        name: Cow::Borrowed("Lake Thun"),
        latitude_deg: 46.69,
        longitude_deg: 7.71,
        level_m: 558.0,
        radius_m: 11_000.0,
    };
    /// Lake Brienz (Brienzersee), 564 m; 14 km long.
    pub const BRIENZ: Lake = Lake {
        name: Cow::Borrowed("Lake Brienz"),
        latitude_deg: 46.727,
        longitude_deg: 7.985,
        level_m: 564.0,
        radius_m: 9_000.0,
    };
    /// Lake Biel (Bielersee), 429 m; 15 km long.
    pub const BIEL: Lake = Lake {
        name: Cow::Borrowed("Lake Biel"),
        latitude_deg: 47.085,
        longitude_deg: 7.165,
        level_m: 429.0,
        radius_m: 10_000.0,
    };
    /// Lake Neuchâtel, 429 m; 38 km long (its south-west half lies west of the bundled DEM).
    pub const NEUCHATEL: Lake = Lake {
        name: Cow::Borrowed("Lake Neuchâtel"),
        latitude_deg: 46.90,
        longitude_deg: 6.87,
        level_m: 429.0,
        radius_m: 24_000.0,
    };
    /// Lake Murten (Murtensee), 429 m; 8 km long.
    pub const MURTEN: Lake = Lake {
        name: Cow::Borrowed("Lake Murten"),
        latitude_deg: 46.93,
        longitude_deg: 7.08,
        level_m: 429.0,
        radius_m: 5_500.0,
    };
}

/// The summits pinned by default: the two camera hills of the Bern demo.
pub fn bern_summits() -> Vec<Summit> {
    vec![Summit::GURTEN, Summit::BANTIGER]
}

/// The lakes of the Bernese Oberland and the Three-Lakes region, with mean levels from the
/// swisstopo national map (as quoted by Wikipedia's lake articles): Thun 558 m, Brienz 564 m,
/// Biel, Neuchâtel and Murten 429 m.
pub fn bern_lakes() -> Vec<Lake> {
    vec![
        Lake::THUN,
        Lake::BRIENZ,
        Lake::BIEL,
        Lake::NEUCHATEL,
        Lake::MURTEN,
    ]
}
