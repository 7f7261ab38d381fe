//! The two summits the demo looks from and where their cameras stand.

use super::*;

/// The two summits of Thomann 2021 §4.4, each with the far place whose weather shows on its horizon.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub(crate) enum Viewpoint {
    #[default]
    Gurten,
    Bantiger,
}

impl Viewpoint {
    pub(crate) const ALL: [Self; 2] = [Self::Gurten, Self::Bantiger];

    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Gurten => "Gurten",
            Self::Bantiger => "Bantiger",
        }
    }

    /// The name on the command line and of the photo folder.
    pub(crate) fn key(self) -> &'static str {
        match self {
            Self::Gurten => "gurten",
            Self::Bantiger => "bantiger",
        }
    }

    pub(crate) fn summit(self) -> Summit {
        match self {
            Self::Gurten => Summit::GURTEN,
            Self::Bantiger => Summit::BANTIGER,
        }
    }

    /// View direction, degrees clockwise from north: over Bern toward the far place (Solothurn
    /// lies at 13° from Bern, Fribourg at 234°).
    pub(crate) fn azimuth_deg(self) -> f32 {
        match self {
            Self::Gurten => 20.0,
            Self::Bantiger => 225.0,
        }
    }

    pub(crate) fn far_place(self) -> &'static str {
        match self {
            Self::Gurten => "Solothurn",
            Self::Bantiger => "Fribourg",
        }
    }

    /// The far place's latitude and longitude, degrees (for `--live`).
    #[cfg_attr(not(feature = "live"), allow(dead_code))]
    pub(crate) fn far_place_deg(self) -> (f64, f64) {
        match self {
            Self::Gurten => (47.208, 7.537),
            Self::Bantiger => (46.806, 7.162),
        }
    }

    pub(crate) fn far_forecast(self) -> &'static str {
        match self {
            Self::Gurten => "weather/solothurn.json",
            Self::Bantiger => "weather/fribourg.json",
        }
    }
}

impl std::str::FromStr for Viewpoint {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|v| v.key().eq_ignore_ascii_case(text))
            .ok_or_else(|| format!("{text:?} is neither gurten nor bantiger"))
    }
}

/// Which view the camera shows.
#[derive(Resource, Debug, Clone, Copy, PartialEq)]
pub(crate) struct ViewState {
    pub(crate) viewpoint: Viewpoint,
    /// The free-fly camera is on.
    pub(crate) free: bool,
    /// `--azimuth`: look this way instead of the view's own direction, degrees clockwise from
    /// north (cleared when another view is picked).
    pub(crate) azimuth_deg: Option<f32>,
    /// The camera this far above the eye height on the hill, metres (the look board's view from
    /// above the clouds); 0 on the hill.
    pub(crate) lift_m: f32,
    /// Look this far up (negative: down), degrees, instead of [`PITCH_DEG`].
    pub(crate) pitch_deg: Option<f32>,
}

impl ViewState {
    /// The view from `viewpoint`'s hill in its own direction.
    pub(crate) fn on(viewpoint: Viewpoint) -> Self {
        Self {
            viewpoint,
            free: false,
            azimuth_deg: None,
            lift_m: 0.0,
            pitch_deg: None,
        }
    }
}

/// The terrain, kept on the CPU to put cameras on it.
#[derive(Resource)]
pub(crate) struct Terrain {
    pub(crate) plane: TangentPlane,
    pub(crate) mesh: Option<TerrainMesh>,
    /// Why there is no mesh.
    pub(crate) error: Option<String>,
}

/// How far below the summit the ground must have fallen where the camera stands, metres.
pub(crate) const BROW_DROP_M: f32 = 8.0;
/// The farthest the camera walks from the summit to find the brow, metres.
pub(crate) const MAX_BROW_DISTANCE_M: f64 = 1_000.0;

/// The camera on a summit, looking along the view's azimuth.
///
/// It stands on the brow of the hill in the view direction (the first point where the ground
/// has fallen [`BROW_DROP_M`] below the top), with the eye [`EYE_HEIGHT_M`] above the ground:
/// from the top itself, the rounded summit (the terrain pins it with a flat quad some 250 m
/// across) hides the valley below, just as it would hide Bern from a walker on the Gurten's top.
pub(crate) fn viewpoint_transform(view: &ViewState, terrain: &Terrain) -> Transform {
    let summit = view.viewpoint.summit();
    let [x, _, z] = terrain
        .plane
        .to_scene(summit.latitude_deg, summit.longitude_deg, 0.0);
    let azimuth = view
        .azimuth_deg
        .unwrap_or(view.viewpoint.azimuth_deg())
        .to_radians();
    // +X east, −Z north.
    let ahead = Vec2::new(azimuth.sin(), -azimuth.cos()).as_dvec2();
    let (position, ground) = match &terrain.mesh {
        Some(mesh) => {
            let top = mesh.height_at_scene(x, z).unwrap_or(summit.altitude_m);
            (0..=(MAX_BROW_DISTANCE_M / 25.0) as u32)
                .map(|step| {
                    let p = DVec2::new(x, z) + ahead * f64::from(step) * 25.0;
                    (p, mesh.height_at_scene(p.x, p.y))
                })
                .find_map(|(p, h)| h.filter(|h| *h <= top - BROW_DROP_M).map(|h| (p, h)))
                .unwrap_or((DVec2::new(x, z), top))
        }
        // On flat fallback ground the camera keeps the summit's height, so the view stays
        // alike.
        None => (DVec2::new(x, z), summit.altitude_m),
    };
    let pitch = view.pitch_deg.unwrap_or(PITCH_DEG).to_radians();
    let forward = Vec3::new(
        azimuth.sin() * pitch.cos(),
        pitch.sin(),
        -azimuth.cos() * pitch.cos(),
    );
    Transform::from_xyz(
        position.x as f32,
        ground + EYE_HEIGHT_M + view.lift_m.max(0.0),
        position.y as f32,
    )
    .looking_to(forward, Vec3::Y)
}
