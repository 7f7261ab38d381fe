//! The look board (`--look`): a fixed set of Bern views, one weather each, rendered headless and
//! tiled into one contact sheet, to hold against what photographs of the same weather show
//! (`docs/look.md` has the checklist).

use super::*;

/// One view of the board.
pub(crate) struct Shot {
    /// What the view shows, for the log and `docs/look.md`.
    pub(crate) label: &'static str,
    pub(crate) viewpoint: Viewpoint,
    /// Scene time, UTC (RFC 3339), in the bundled week of forecasts.
    pub(crate) time: &'static str,
    /// View direction, degrees clockwise from north; `None`: the viewpoint's own.
    pub(crate) azimuth_deg: Option<f32>,
    /// Camera exposure, EV100.
    pub(crate) ev100: f32,
    /// Metres above the eye height on the hill (0: on the hill).
    pub(crate) lift_m: f32,
    /// Pitch, degrees; `None`: the demo's.
    pub(crate) pitch_deg: Option<f32>,
}

/// The board, left to right and top to bottom, three views per row. The times are the bundled
/// forecast's hours with that weather (`assets/weather/bern.json`).
pub(crate) const BOARD: [Shot; 9] = [
    Shot {
        label: "clear morning",
        viewpoint: Viewpoint::Gurten,
        time: "2021-05-03T07:00:00Z",
        azimuth_deg: None,
        ev100: 14.0,
        lift_m: 0.0,
        pitch_deg: None,
    },
    Shot {
        label: "fair cumulus",
        viewpoint: Viewpoint::Gurten,
        time: "2021-05-03T14:00:00Z",
        azimuth_deg: None,
        ev100: 14.0,
        lift_m: 0.0,
        pitch_deg: None,
    },
    Shot {
        label: "overcast",
        viewpoint: Viewpoint::Gurten,
        time: "2021-05-05T15:00:00Z",
        azimuth_deg: None,
        ev100: 12.5,
        lift_m: 0.0,
        pitch_deg: None,
    },
    Shot {
        label: "rain",
        viewpoint: Viewpoint::Gurten,
        time: "2021-05-07T15:00:00Z",
        azimuth_deg: None,
        ev100: 12.0,
        lift_m: 0.0,
        pitch_deg: None,
    },
    Shot {
        label: "fog",
        viewpoint: Viewpoint::Gurten,
        time: "2021-05-06T08:00:00Z",
        azimuth_deg: None,
        ev100: 12.5,
        lift_m: 0.0,
        pitch_deg: None,
    },
    Shot {
        label: "sunset with shafts",
        viewpoint: Viewpoint::Bantiger,
        time: "2021-05-08T18:15:00Z",
        azimuth_deg: Some(285.0),
        ev100: 13.0,
        lift_m: 0.0,
        pitch_deg: None,
    },
    Shot {
        label: "above the clouds",
        viewpoint: Viewpoint::Gurten,
        time: "2021-05-03T14:00:00Z",
        azimuth_deg: None,
        ev100: 14.5,
        lift_m: 3_500.0,
        pitch_deg: Some(-12.0),
    },
    Shot {
        label: "rainy evening",
        viewpoint: Viewpoint::Bantiger,
        time: "2021-05-04T18:00:00Z",
        azimuth_deg: None,
        ev100: 11.0,
        lift_m: 0.0,
        pitch_deg: None,
    },
    Shot {
        label: "moonlit night",
        viewpoint: Viewpoint::Gurten,
        time: "2021-05-04T02:30:00Z",
        azimuth_deg: Some(135.0),
        ev100: -5.0,
        lift_m: 0.0,
        pitch_deg: None,
    },
];

/// Views per row of the contact sheet.
pub(crate) const BOARD_COLUMNS: u32 = 3;

/// Puts the current shot of the board on screen: its time, its view and its exposure. Each
/// shot is a camera cut (another day, another weather): the clouds' temporal accumulation starts
/// over, or the last view's clouds would linger in the new one's history.
pub(crate) fn follow_look_shots(
    progress: Res<HeadlessProgress>,
    mut shown: Local<Option<u32>>,
    mut clock: ResMut<SceneClock>,
    mut view: ResMut<ViewState>,
    mut cameras: Query<(&mut Exposure, Option<&mut VolumetricClouds>), With<MainCamera>>,
) {
    let Some(shot) = BOARD.get(progress.shot as usize) else {
        return;
    };
    let cut = *shown != Some(progress.shot);
    if cut {
        *shown = Some(progress.shot);
        info!("look board {}: {}", progress.shot, shot.label);
        let time: UtcInstant = shot.time.parse().expect("the board's times are RFC 3339");
        clock.set_unix_seconds(time.unix_seconds() as f64);
    }
    view.set_if_neq(ViewState {
        azimuth_deg: shot.azimuth_deg,
        lift_m: shot.lift_m,
        pitch_deg: shot.pitch_deg,
        ..ViewState::on(shot.viewpoint)
    });
    for (mut exposure, clouds) in &mut cameras {
        if exposure.ev100 != shot.ev100 {
            exposure.ev100 = shot.ev100;
        }
        if let Some(mut clouds) = clouds.filter(|_| cut) {
            clouds.reset_history = true;
        }
    }
}

/// Tiles the board's images (`frame_000.png`, … in `folder`) into `folder/board.png`, three per
/// row in [`BOARD`]'s order.
pub(crate) fn write_board(folder: &Path) -> Result<PathBuf, String> {
    let tiles = (0..BOARD.len())
        .map(|i| {
            let path = folder.join(format!("frame_{i:03}.png"));
            image::open(&path)
                .map(|image| image.to_rgb8())
                .map_err(|e| format!("cannot read {}: {e}", path.display()))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (w, h) = tiles[0].dimensions();
    let rows = (BOARD.len() as u32).div_ceil(BOARD_COLUMNS);
    let gap = 4;
    let mut sheet = image::RgbImage::from_pixel(
        BOARD_COLUMNS * (w + gap) - gap,
        rows * (h + gap) - gap,
        image::Rgb([255, 255, 255]),
    );
    for (i, tile) in tiles.iter().enumerate() {
        let (column, row) = (i as u32 % BOARD_COLUMNS, i as u32 / BOARD_COLUMNS);
        image::imageops::replace(
            &mut sheet,
            tile,
            i64::from(column * (w + gap)),
            i64::from(row * (h + gap)),
        );
    }
    let path = folder.join("board.png");
    sheet
        .save(&path)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(path)
}
