//! The photo overlay (Thomann 2021 §7.3): photos found under `--photos`, drawn over the view with a wiper.

use super::*;

/// Photos found under `--photos`, per viewpoint, sorted by time.
#[derive(Resource, Default)]
pub(crate) struct Photos {
    pub(crate) by_view: [Vec<(UtcInstant, PathBuf)>; 2],
    /// Where each view's photos are looked for.
    pub(crate) folders: [PathBuf; 2],
    /// What was found, for the panel.
    pub(crate) summary: String,
}

/// How the photo overlay is drawn.
#[derive(Resource, Debug, Clone)]
pub(crate) struct PhotoOverlay {
    pub(crate) visible: bool,
    /// 0 (transparent) to 1.
    pub(crate) opacity: f32,
    /// Fraction of the view's width, from the left, that shows the photo.
    pub(crate) wiper: f32,
    /// The photo loaded now.
    pub(crate) shown: Option<PathBuf>,
    pub(crate) shown_size: Vec2,
    /// What the overlay shows, or why it shows nothing.
    pub(crate) status: String,
}

impl Default for PhotoOverlay {
    fn default() -> Self {
        Self {
            visible: false,
            opacity: 0.5,
            wiper: 1.0,
            shown: None,
            shown_size: Vec2::ONE,
            status: String::new(),
        }
    }
}

#[derive(Component)]
pub(crate) struct PhotoNode;

/// Reads `DIR/<view>/YYYY-MM-DDTHH-MM.jpg` names; anything else in the folders is ignored.
pub(crate) fn scan_photos(dir: &Path) -> Photos {
    let mut photos = Photos::default();
    if !dir.is_dir() {
        photos.summary = format!("no photo folder {}", dir.display());
        return photos;
    }
    let mut summary = Vec::new();
    for (index, viewpoint) in Viewpoint::ALL.into_iter().enumerate() {
        let folder = dir.join(viewpoint.key());
        photos.folders[index].clone_from(&folder);
        let Ok(entries) = std::fs::read_dir(&folder) else {
            summary.push(format!("no folder {}", folder.display()));
            continue;
        };
        let list = &mut photos.by_view[index];
        list.extend(entries.flatten().filter_map(|entry| {
            let path = entry.path();
            let extension = path.extension()?.to_str()?.to_ascii_lowercase();
            if !matches!(extension.as_str(), "jpg" | "jpeg" | "png") {
                return None;
            }
            Some((photo_time(path.file_stem()?.to_str()?)?, path))
        }));
        list.sort();
        summary.push(format!("{}: {} photos", viewpoint.key(), list.len()));
    }
    photos.summary = summary.join(", ");
    photos
}

/// `2021-05-03T14-00` (UTC; colons are not allowed in file names everywhere).
pub(crate) fn photo_time(stem: &str) -> Option<UtcInstant> {
    let (date, time) = stem.split_once(['T', 't'])?;
    let mut date = date.split('-').map(str::parse::<u32>);
    let mut time = time.split('-').map(str::parse::<u8>);
    let (year, month, day) = (date.next()?.ok()?, date.next()?.ok()?, date.next()?.ok()?);
    let (hour, minute) = (time.next()?.ok()?, time.next()?.ok()?);
    let second = time.next().and_then(Result::ok).unwrap_or(0);
    UtcInstant::from_civil(
        i32::try_from(year).ok()?,
        u8::try_from(month).ok()?,
        u8::try_from(day).ok()?,
        hour,
        minute,
        second,
    )
}

pub(crate) fn spawn_photo_overlay(
    mut commands: Commands,
    options: Res<BernOptions>,
    mut overlay: ResMut<PhotoOverlay>,
) {
    let Some(dir) = &options.photos else {
        return;
    };
    let photos = scan_photos(dir);
    info!("photos: {}", photos.summary);
    overlay.status.clone_from(&photos.summary);
    commands.insert_resource(photos);
    commands.spawn((
        Node {
            position_type: PositionType::Absolute,
            left: px(0),
            top: px(0),
            width: percent(100),
            height: percent(100),
            ..default()
        },
        ImageNode::default(),
        Visibility::Hidden,
        PhotoNode,
    ));
}

pub(crate) fn photo_keys(
    keys: Res<ButtonInput<KeyCode>>,
    captured: Res<UiCapturesKeyboard>,
    mut overlay: ResMut<PhotoOverlay>,
) {
    if captured.0 {
        return;
    }
    if keys.just_pressed(KeyCode::KeyP) {
        overlay.visible = !overlay.visible;
    }
    for (key, step) in [(KeyCode::BracketLeft, -0.1), (KeyCode::BracketRight, 0.1)] {
        if keys.just_pressed(key) {
            overlay.wiper = (overlay.wiper + step).clamp(0.0, 1.0);
        }
    }
}

pub(crate) fn load_photo(path: &Path) -> Result<Image, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or_default();
    Image::from_buffer(
        &bytes,
        ImageType::Extension(extension),
        CompressedImageFormats::NONE,
        true,
        ImageSampler::Default,
        RenderAssetUsages::RENDER_WORLD,
    )
    .map_err(|e| format!("{}: {e}", path.display()))
}

/// Shows the photo of the current view nearest to the scene time.
pub(crate) fn update_photo_overlay(
    clock: Res<SceneClock>,
    view: Res<ViewState>,
    photos: Option<Res<Photos>>,
    mut overlay: ResMut<PhotoOverlay>,
    mut images: ResMut<Assets<Image>>,
    node: Option<Single<(&mut ImageNode, &mut Node, &mut Visibility), With<PhotoNode>>>,
) {
    let (Some(photos), Some(node)) = (photos, node) else {
        return;
    };
    let (mut image_node, mut layout, mut visibility) = node.into_inner();
    let index = Viewpoint::ALL
        .iter()
        .position(|v| *v == view.viewpoint)
        .unwrap_or(0);
    let now = clock.unix_seconds() as i64;
    let nearest = photos.by_view[index]
        .iter()
        .min_by_key(|(time, _)| (time.unix_seconds() - now).abs());
    let mut status = String::new();
    let mut show = false;
    match nearest {
        None if photos.by_view.iter().all(Vec::is_empty) => status.clone_from(&photos.summary),
        None => {
            status = format!(
                "no photos named like 2021-05-03T14-00.jpg in {}",
                photos.folders[index].display()
            );
        }
        Some((time, path)) => {
            if overlay.shown.as_ref() != Some(path) {
                overlay.shown = Some(path.clone());
                match load_photo(path) {
                    Ok(image) => {
                        overlay.shown_size = image.size_f32();
                        image_node.image = images.add(image);
                    }
                    Err(e) => {
                        warn!("photo overlay: {e}");
                        image_node.image = Handle::default();
                        overlay.shown_size = Vec2::ZERO;
                    }
                }
            }
            if overlay.shown_size == Vec2::ZERO {
                status = format!("cannot read {}", path.display());
            } else {
                show = overlay.visible;
                let minutes = (time.unix_seconds() - now) as f64 / 60.0;
                status = format!(
                    "{} ({minutes:+.0} min from the scene time)",
                    path.file_name().unwrap_or_default().to_string_lossy()
                );
            }
        }
    }
    if overlay.status != status {
        overlay.status = status;
    }
    // The wiper crops the photo and its node together, so the photo stays registered with the
    // view underneath.
    let wiper = overlay.wiper.clamp(0.0, 1.0);
    let rect = Rect::new(0.0, 0.0, overlay.shown_size.x * wiper, overlay.shown_size.y);
    let color = Color::srgba(1.0, 1.0, 1.0, overlay.opacity.clamp(0.0, 1.0));
    if image_node.rect != Some(rect) || image_node.color != color {
        image_node.rect = Some(rect);
        image_node.color = color;
    }
    layout.width = percent(wiper * 100.0);
    visibility.set_if_neq(if show && wiper > 0.0 {
        Visibility::Inherited
    } else {
        Visibility::Hidden
    });
}
