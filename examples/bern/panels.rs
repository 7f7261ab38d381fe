//! The live/play window (Thomann 2021's requirements, §2.4 UI mock-ups), performance numbers,
//! the photo overlay's settings, and an inspector for the layers and the camera's clouds.

use bevy::{
    diagnostic::{DiagnosticsStore, FrameTimeDiagnosticsPlugin},
    ecs::component::Mutable,
    render::diagnostic::RenderDiagnosticsPlugin,
};
use bevy_cloudscape::{
    layers::{DEFAULT_TRANSITION_S, HazeTransition, LayerTransition},
    weather::{Variable, WeatherMapping},
};
use bevy_egui::{
    EguiContext, EguiContexts, EguiPlugin, EguiPrimaryContextPass, PrimaryEguiContext, egui,
};
use bevy_inspector_egui::{DefaultInspectorConfigPlugin, bevy_inspector};

use super::*;

pub struct PanelPlugin;

impl Plugin for PanelPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins((
            EguiPlugin::default(),
            DefaultInspectorConfigPlugin,
            FrameTimeDiagnosticsPlugin::default(),
            RenderDiagnosticsPlugin,
        ))
        .init_resource::<PanelState>()
        .add_systems(
            EguiPrimaryContextPass,
            (control_window, inspector_window).chain(),
        )
        .add_systems(
            Update,
            (apply_panel, drive_play_layers, toggle_growth)
                .chain()
                .before(CloudscapeSystems::Layers),
        );
    }
}

/// Live: the forecasts drive the layers. Play: the sliders do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
enum Mode {
    #[default]
    Live,
    Play,
}

/// The play mode's weather, in forecast units.
#[derive(Clone, Debug, PartialEq)]
struct PlayWeather {
    low_cover: f32,
    mid_cover: f32,
    high_cover: f32,
    precipitation_mm_per_h: f32,
    /// The precipitation falls as showers (convective), which brings cumulonimbus.
    showers: bool,
    wind_speed_m_s: f32,
    /// Where the wind blows from, degrees clockwise from north.
    wind_from_deg: f32,
    /// Meteorological visibility, km.
    visibility_km: f32,
    /// Fog probability, 0–1.
    fog: f32,
    /// 2 m temperature, °C: rain or snow by the lapse rate.
    temperature_c: f32,
}

impl Default for PlayWeather {
    fn default() -> Self {
        Self {
            low_cover: 0.4,
            mid_cover: 0.0,
            high_cover: 0.2,
            precipitation_mm_per_h: 0.0,
            showers: false,
            wind_speed_m_s: 3.0,
            wind_from_deg: 270.0,
            visibility_km: 30.0,
            fog: 0.0,
            temperature_c: 15.0,
        }
    }
}

impl PlayWeather {
    /// Starts from what the forecast says now, so switching to play changes nothing yet.
    fn from_state(state: &WeatherState) -> Self {
        let fallback = Self::default();
        Self {
            low_cover: state.low_cover().unwrap_or(fallback.low_cover),
            mid_cover: state.mid_cover().unwrap_or(fallback.mid_cover),
            high_cover: state.high_cover().unwrap_or(fallback.high_cover),
            precipitation_mm_per_h: state.precipitation_mm_per_h().unwrap_or(0.0),
            showers: state
                .get(Variable::ConvectivePrecipitation)
                .is_some_and(|v| v > 0.0),
            wind_speed_m_s: state.wind_speed_m_s().unwrap_or(fallback.wind_speed_m_s),
            wind_from_deg: state.wind_direction_deg().unwrap_or(fallback.wind_from_deg),
            visibility_km: state
                .get(Variable::Visibility)
                .map_or(fallback.visibility_km, |v| v / 1000.0),
            fog: state.get(Variable::FogProbability).unwrap_or(0.0),
            temperature_c: state
                .get(Variable::Temperature)
                .unwrap_or(fallback.temperature_c),
        }
    }

    /// A forecast state holding these values.
    fn to_state(&self, time: UtcInstant) -> WeatherState {
        let mut state = WeatherState::empty(time);
        let convective = if self.showers {
            self.precipitation_mm_per_h
        } else {
            0.0
        };
        for (variable, value) in [
            (Variable::LowCover, self.low_cover),
            (Variable::MidCover, self.mid_cover),
            (Variable::HighCover, self.high_cover),
            (
                Variable::TotalCover,
                self.low_cover.max(self.mid_cover).max(self.high_cover),
            ),
            (Variable::Precipitation, self.precipitation_mm_per_h),
            (Variable::ConvectivePrecipitation, convective),
            (Variable::WindSpeed, self.wind_speed_m_s),
            (
                Variable::WindDirection,
                self.wind_from_deg.rem_euclid(360.0),
            ),
            (Variable::Visibility, self.visibility_km * 1000.0),
            (Variable::FogProbability, self.fog),
            (Variable::Temperature, self.temperature_c),
        ] {
            state.values[variable as usize] = Some(value);
        }
        state
    }
}

#[derive(Resource)]
struct PanelState {
    mode: Mode,
    play: PlayWeather,
    /// The preset play mode follows (an index into `CloudPreset::ALL`); `None`: the sliders.
    preset: Option<usize>,
    /// Seconds every change of the layers and the haze takes.
    transition_s: f32,
    /// The low clouds grow with the automaton (`CloudGrowth`); `None` until the command line's
    /// `--growth` has been read.
    growth: Option<bool>,
}

impl Default for PanelState {
    fn default() -> Self {
        Self {
            mode: Mode::Live,
            play: PlayWeather::default(),
            preset: None,
            transition_s: DEFAULT_TRANSITION_S,
            growth: None,
        }
    }
}

fn control_window(
    mut contexts: EguiContexts,
    mut panel: ResMut<PanelState>,
    mut clock: ResMut<SceneClock>,
    mut view: ResMut<ViewState>,
    mut overlay: ResMut<PhotoOverlay>,
    mut captured: ResMut<UiCapturesKeyboard>,
    options: Res<BernOptions>,
    source: Res<WeatherSource>,
    forecasts: Res<Assets<Forecast>>,
    current: Res<CurrentWeather>,
    diagnostics: Res<DiagnosticsStore>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    let forecast = near_forecast(&source, &forecasts);
    egui::Window::new("Bern")
        .default_pos([12.0, 12.0])
        .show(ctx, |ui| {
            ui.spacing_mut().slider_width = 220.0;
            let mut next_view = *view;
            ui.horizontal(|ui| {
                ui.label("View:");
                for viewpoint in Viewpoint::ALL {
                    let label = format!("{} -> {}", viewpoint.name(), viewpoint.far_place());
                    if ui
                        .selectable_label(
                            next_view.viewpoint == viewpoint && !next_view.free,
                            label,
                        )
                        .clicked()
                    {
                        next_view = ViewState::on(viewpoint);
                    }
                }
                ui.checkbox(&mut next_view.free, "free camera (F)");
            });
            view.set_if_neq(next_view);
            ui.separator();

            let mut mode = panel.mode;
            ui.horizontal(|ui| {
                ui.selectable_value(&mut mode, Mode::Live, "Live");
                ui.selectable_value(&mut mode, Mode::Play, "Play");
            });
            if mode != panel.mode {
                switch_mode(&mut panel, mode, &current);
            }
            let mut transition_s = panel.transition_s;
            ui.add(egui::Slider::new(&mut transition_s, 0.0..=30.0).text("transition, s (0 cuts)"));
            if transition_s != panel.transition_s {
                panel.transition_s = transition_s;
            }
            let mut growth = panel.growth.unwrap_or(options.growth);
            ui.checkbox(&mut growth, "low clouds form and dissolve (cloud growth)");
            if panel.growth != Some(growth) {
                panel.growth = Some(growth);
            }
            ui.label(time_label(clock.unix_seconds(), forecast));
            match panel.mode {
                Mode::Live => live_controls(ui, &mut clock, forecast, &current),
                Mode::Play => {
                    let mut preset = panel.preset;
                    ui.horizontal_wrapped(|ui| {
                        ui.label("Preset:");
                        for (i, p) in CloudPreset::ALL.iter().enumerate() {
                            ui.selectable_value(&mut preset, Some(i), p.name.as_ref());
                        }
                        ui.selectable_value(&mut preset, None, "sliders");
                    });
                    let mut play = panel.play.clone();
                    play_controls(ui, &mut play, &mut clock, forecast);
                    if play != panel.play {
                        panel.play = play;
                        // A slider moved: the sliders drive the sky again.
                        preset = None;
                    }
                    if preset != panel.preset {
                        panel.preset = preset;
                    }
                }
            }
            ui.separator();

            if options.photos.is_some() {
                let mut settings = overlay.clone();
                ui.horizontal(|ui| {
                    ui.checkbox(&mut settings.visible, "photo overlay");
                    ui.add(egui::Slider::new(&mut settings.opacity, 0.0..=1.0).text("opacity"));
                });
                ui.add(egui::Slider::new(&mut settings.wiper, 0.0..=1.0).text("wiper"));
                ui.label(&settings.status);
                if settings.visible != overlay.visible
                    || settings.opacity != overlay.opacity
                    || settings.wiper != overlay.wiper
                {
                    *overlay = settings;
                }
                ui.separator();
            }

            let fps = diagnostics
                .get(&FrameTimeDiagnosticsPlugin::FPS)
                .and_then(|fps| fps.smoothed());
            ui.label(fps.map_or("FPS: -".into(), |fps| format!("FPS: {fps:.1}")));
            // The cloud passes time themselves ("clouds" and each of its passes, "cloud_noise"); GPU times
            // appear where the device has timestamp queries.
            let mut passes: Vec<_> = diagnostics
                .iter()
                .filter(|d| d.path().as_str().starts_with("render/cloud"))
                .filter_map(|d| Some((d.path().as_str(), d.smoothed()?, &d.suffix)))
                .collect();
            passes.sort_by_key(|(path, _, _)| *path);
            for (path, value, suffix) in passes {
                ui.label(format!("{path}: {value:.2} {suffix}"));
            }
        });
    captured.set_if_neq(UiCapturesKeyboard(ctx.egui_wants_keyboard_input()));
    Ok(())
}

/// Play mode starts from what the forecast says now, so switching changes nothing yet.
fn switch_mode(panel: &mut PanelState, mode: Mode, current: &CurrentWeather) {
    panel.mode = mode;
    if mode == Mode::Play
        && let Some(near) = &current.near
    {
        panel.play = PlayWeather::from_state(&near.state);
    }
}

/// A weather layer the sliders drive in play mode: its `LayerSlot` is taken off (so the forecast
/// leaves it alone) and kept here until live mode or a preset gives it back.
#[derive(Component)]
struct PlaySlot(LayerSlot);

/// Applies the panel's mode, preset and transition time: live mode hands the layers back to the
/// forecast, a preset becomes the `ActivePreset`, the sliders take the layers' slots off, and
/// every transition takes the panel's time.
fn apply_panel(
    panel: Res<PanelState>,
    mut commands: Commands,
    mut transitions: Query<(
        Entity,
        &mut LayerTransition,
        Option<&LayerSlot>,
        Option<&PlaySlot>,
    )>,
    mut haze: ResMut<HazeTransition>,
    mut presets: ResMut<Assets<CloudPreset>>,
    mut handles: Local<Vec<Handle<CloudPreset>>>,
) {
    if !panel.is_changed() {
        return;
    }
    if handles.is_empty() {
        *handles = CloudPreset::ALL.map(|p| presets.add(p)).to_vec();
    }
    let sliders = panel.mode == Mode::Play && panel.preset.is_none();
    for (entity, mut transition, slot, play) in &mut transitions {
        transition.duration_s = panel.transition_s;
        match (sliders, slot, play) {
            (true, Some(&slot), _) => {
                commands
                    .entity(entity)
                    .remove::<LayerSlot>()
                    .insert(PlaySlot(slot));
            }
            (false, _, Some(&PlaySlot(slot))) => {
                commands.entity(entity).remove::<PlaySlot>().insert(slot);
            }
            _ => {}
        }
    }
    haze.duration_s = panel.transition_s;
    if let Some(target) = haze.target.as_mut() {
        // The sliders set the haze by hand; the forecast and the presets set it otherwise.
        target.weather_driven = !sliders;
    }
    match (panel.mode, panel.preset) {
        (Mode::Play, Some(i)) => commands.insert_resource(ActivePreset {
            preset: handles[i].clone(),
            duration_s: panel.transition_s,
        }),
        _ => commands.remove_resource::<ActivePreset>(),
    }
}

fn live_controls(
    ui: &mut egui::Ui,
    clock: &mut SceneClock,
    forecast: Option<&Forecast>,
    current: &CurrentWeather,
) {
    if let Some((start, end)) = forecast.and_then(|f| Some((f.start()?, f.end()?))) {
        let (start, end) = (start.unix_seconds() as f64, end.unix_seconds() as f64);
        let mut t = clock.unix_seconds().clamp(start, end);
        let slider = egui::Slider::new(&mut t, start..=end)
            .show_value(false)
            .step_by(600.0)
            .text("forecast time");
        if ui.add(slider).changed() {
            clock.set_unix_seconds(t);
        }
    } else {
        ui.label("loading the forecast…");
    }
    ui.horizontal(|ui| {
        if ui.button("now").clicked() {
            clock.mode = ClockMode::WallClock;
        }
        let running = clock.mode == ClockMode::WallClock || !clock.paused;
        if ui.button(if running { "pause" } else { "play" }).clicked() {
            let t = clock.unix_seconds();
            clock.set_unix_seconds(t);
            clock.paused = running;
        }
        for speed in CLOCK_SPEEDS {
            if ui
                .selectable_label(clock.speed == speed, format!("{speed}x"))
                .clicked()
            {
                clock.speed = speed;
            }
        }
        if clock.mode == ClockMode::WallClock {
            ui.label("live: the wall clock");
        }
    });
    for place in current.near.iter().chain(current.far.iter().flatten()) {
        ui.label(format!(
            "{}: {}",
            place.place.name,
            weather_label(&place.state)
        ));
    }
}

fn play_controls(
    ui: &mut egui::Ui,
    play: &mut PlayWeather,
    clock: &mut SceneClock,
    forecast: Option<&Forecast>,
) {
    ui.add(egui::Slider::new(&mut play.low_cover, 0.0..=1.0).text("low cover"));
    ui.add(egui::Slider::new(&mut play.mid_cover, 0.0..=1.0).text("mid cover"));
    ui.add(egui::Slider::new(&mut play.high_cover, 0.0..=1.0).text("high cover"));
    ui.add(
        egui::Slider::new(&mut play.precipitation_mm_per_h, 0.0..=20.0).text("precipitation, mm/h"),
    );
    ui.checkbox(&mut play.showers, "as showers (cumulonimbus)");
    ui.add(egui::Slider::new(&mut play.wind_speed_m_s, 0.0..=30.0).text("wind, m/s"));
    ui.add(egui::Slider::new(&mut play.wind_from_deg, 0.0..=360.0).text("wind from, degrees"));
    ui.add(
        egui::Slider::new(&mut play.visibility_km, 0.1..=80.0)
            .logarithmic(true)
            .text("visibility, km"),
    );
    ui.add(egui::Slider::new(&mut play.fog, 0.0..=1.0).text("fog probability"));
    ui.add(
        egui::Slider::new(&mut play.temperature_c, -15.0..=30.0)
            .text("temperature, °C (snow below about 1 °C at the camera)"),
    );
    // Time of day in the forecast's local time, on the scene's current date.
    let offset = forecast.map_or(0.0, |f| f64::from(f.utc_offset_s));
    let local = clock.unix_seconds() + offset;
    let midnight = local - local.rem_euclid(86_400.0);
    let mut hours = (local - midnight) / 3600.0;
    let slider = egui::Slider::new(&mut hours, 0.0..=23.99)
        .step_by(0.25)
        .text("time of day, h");
    if ui.add(slider).changed() {
        clock.set_unix_seconds(midnight + hours * 3600.0 - offset);
    }
    ui.horizontal(|ui| {
        let running = clock.mode == ClockMode::WallClock || !clock.paused;
        if ui.button(if running { "pause" } else { "play" }).clicked() {
            let t = clock.unix_seconds();
            clock.set_unix_seconds(t);
            clock.paused = running;
        }
        ui.label(clock_label(clock));
    });
}

/// In play mode without a preset, writes the sliders' weather onto the layers' transition
/// targets through the same mapping the forecasts go through, so a slider value looks like
/// that forecast value would, and moving a slider is a smooth change.
fn drive_play_layers(
    panel: Res<PanelState>,
    clock: Res<SceneClock>,
    mapping: Option<Res<WeatherMapping>>,
    mut layers: Query<(&PlaySlot, &mut LayerTransition)>,
    mut haze: ResMut<HazeTransition>,
) {
    if panel.mode != Mode::Play || panel.preset.is_some() {
        return;
    }
    let rules = mapping.map_or_else(WeatherMapping::default, |m| *m);
    let mapped = rules.map(&panel.play.to_state(clock.instant()), BERN_GROUND_M);
    for (PlaySlot(slot), mut transition) in &mut layers {
        let mut updated = transition.target.clone();
        mapped.apply(*slot, &mut updated);
        if updated != transition.target {
            transition.target = updated;
        }
    }
    if let Some(visibility_m) = mapped.haze_visibility_m() {
        let target = bevy_cloudscape::layers::Haze {
            visibility_m,
            weather_driven: false,
            ..haze.target.clone().unwrap_or_default()
        };
        if haze.target.as_ref() != Some(&target) {
            haze.target = Some(target);
        }
    }
}

/// Every `CloudLayer` and the camera's `VolumetricClouds`, editable.
fn inspector_window(world: &mut World) {
    let Ok(context) = world
        .query_filtered::<&mut EguiContext, With<PrimaryEguiContext>>()
        .single(world)
    else {
        return;
    };
    let mut context = context.clone();
    let layers: Vec<(Entity, String)> = world
        .query::<(Entity, &CloudLayer, Option<&Name>)>()
        .iter(world)
        .map(|(entity, layer, name)| {
            let name = name.map_or_else(|| format!("{entity}"), |n| n.to_string());
            (
                entity,
                format!("{name} ({}, {:.0}%)", layer.kind, layer.coverage * 100.0),
            )
        })
        .collect();
    let cameras: Vec<Entity> = world
        .query_filtered::<Entity, With<VolumetricClouds>>()
        .iter(world)
        .collect();
    let ctx = context.get_mut();
    let right = ctx.content_rect().right();
    egui::Window::new("Inspector")
        .default_open(false)
        .pivot(egui::Align2::RIGHT_TOP)
        .default_pos([right - 12.0, 12.0])
        .show(ctx, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.label(
                    "The weather slots move to their transition's target: edit the target \
                     (the forecast, a preset or the play sliders write it too).",
                );
                for (entity, name) in &layers {
                    egui::CollapsingHeader::new(name)
                        .id_salt(entity)
                        .show(ui, |ui| {
                            if world.get::<LayerTransition>(*entity).is_some() {
                                edit_component::<LayerTransition>(world, *entity, ui);
                            } else {
                                edit_component::<CloudLayer>(world, *entity, ui);
                            }
                            // `--growth`: the automaton's noise makers and probabilities, live.
                            if world.get::<CloudGrowth>(*entity).is_some() {
                                ui.separator();
                                ui.label("growth (a new grid or seed starts it over)");
                                edit_component::<CloudGrowth>(world, *entity, ui);
                            }
                        });
                }
                for camera in &cameras {
                    egui::CollapsingHeader::new("camera: VolumetricClouds")
                        .id_salt(camera)
                        .show(ui, |ui| {
                            edit_component::<VolumetricClouds>(world, *camera, ui);
                        });
                }
            });
        });
}

/// Edits one component through reflection, writing it back only when changed.
fn edit_component<C: Component<Mutability = Mutable> + Reflect + Clone>(
    world: &mut World,
    entity: Entity,
    ui: &mut egui::Ui,
) {
    let Some(mut value) = world.get::<C>(entity).cloned() else {
        return;
    };
    if bevy_inspector::ui_for_value(&mut value, ui, world)
        && let Some(mut component) = world.get_mut::<C>(entity)
    {
        *component = value;
    }
}

/// The panel's growth checkbox: the low clouds' layer (its `LayerSlot`, or the `PlaySlot` that
/// holds it in play mode) gets or loses its `CloudGrowth`.
fn toggle_growth(
    panel: Res<PanelState>,
    mut commands: Commands,
    layers: Query<(
        Entity,
        Option<&LayerSlot>,
        Option<&PlaySlot>,
        Has<CloudGrowth>,
    )>,
) {
    let Some(growth) = panel.growth.filter(|_| panel.is_changed()) else {
        return;
    };
    for (entity, slot, play, grows) in &layers {
        let low = slot == Some(&LayerSlot::Low) || play.is_some_and(|p| p.0 == LayerSlot::Low);
        if !low || grows == growth {
            continue;
        }
        if growth {
            commands.entity(entity).insert(low_cloud_growth());
        } else {
            commands.entity(entity).remove::<CloudGrowth>();
        }
    }
}
