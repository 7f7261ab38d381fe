//! Tests of the weather → layers mapping.

use bevy::prelude::*;

use super::*;
use crate::layers::{CloudKind, CloudLayer, FarCoverage};
use crate::scene::UtcInstant;
use crate::weather::{ForecastFormat, LevelState, Variable, WeatherState};

const BERN_M: f32 = 540.0;

fn state(values: &[(Variable, f32)]) -> WeatherState {
    let mut state = WeatherState::empty(UtcInstant::from_unix_seconds(1_620_000_000));
    for &(variable, value) in values {
        state.values[variable as usize] = Some(value);
    }
    state
}

#[test]
fn far_places_set_far_coverage_on_slotted_layers() {
    use crate::scene::Place;
    use crate::weather::{CurrentWeather, PlaceWeather};
    let place = |name: &str, position: Vec3, state: WeatherState| PlaceWeather {
        place: Place {
            name: name.into(),
            latitude_deg: 47.0,
            longitude_deg: 7.4,
            elevation_m: f64::from(BERN_M),
        },
        scene_position: position,
        state,
        steps: None,
    };
    let mut overcast_far = fair();
    overcast_far.values[Variable::LowCover as usize] = Some(0.95);
    // The far file lacks mid cover: the far coverage keeps the near value, not 0.
    overcast_far.values[Variable::MidCover as usize] = None;
    let mut app = App::new();
    app.insert_resource(CurrentWeather {
        near: Some(place("Bern", Vec3::ZERO, fair())),
        far: vec![
            Some(place(
                "Solothurn",
                Vec3::new(3_000.0, 0.0, -30_000.0),
                overcast_far,
            )),
            None,
        ],
    })
    .insert_resource(WeatherMapping::default())
    .init_resource::<Assets<crate::weather::Forecast>>()
    .add_systems(Update, map_weather_onto_layers);
    let low = app
        .world_mut()
        .spawn((LayerSlot::Low, LayerSlot::Low.initial_layer()))
        .id();
    let mid = app
        .world_mut()
        .spawn((LayerSlot::Mid, LayerSlot::Mid.initial_layer()))
        .id();
    // No slot: the user's layer.
    let manual = app.world_mut().spawn(LayerSlot::High.initial_layer()).id();
    app.update();
    let low = app.world().get::<CloudLayer>(low).unwrap();
    assert!((low.coverage - 0.3).abs() < 1e-6);
    assert_eq!(
        low.far_coverage,
        vec![FarCoverage {
            from_m: [0.0, 0.0],
            to_m: [3_000.0, 30_000.0],
            coverage: 0.95,
        }]
    );
    let mid = app.world().get::<CloudLayer>(mid).unwrap();
    assert_eq!(mid.far_coverage.len(), 1);
    assert!((mid.far_coverage[0].coverage - mid.coverage).abs() < 1e-6);
    let manual = app.world().get::<CloudLayer>(manual).unwrap();
    assert!(
        manual.far_coverage.is_empty(),
        "play-mode layers are left alone"
    );
}

#[test]
fn visibility_sets_the_haze_and_a_gap_keeps_it() {
    use crate::layers::Haze;
    use crate::scene::Place;
    use crate::weather::{CurrentWeather, PlaceWeather};
    let place = |state: WeatherState| PlaceWeather {
        place: Place {
            name: "Bern".into(),
            latitude_deg: 47.0,
            longitude_deg: 7.4,
            elevation_m: f64::from(BERN_M),
        },
        scene_position: Vec3::ZERO,
        state,
        steps: None,
    };
    let mut app = App::new();
    app.insert_resource(CurrentWeather {
        near: Some(place(with(fair(), Variable::Visibility, Some(24_000.0)))),
        far: vec![],
    })
    .init_resource::<Haze>()
    .init_resource::<Assets<crate::weather::Forecast>>()
    .add_systems(Update, map_weather_onto_layers);
    app.update();
    assert_eq!(app.world().resource::<Haze>().visibility_m, 24_000.0);
    // Below the mist limit the fog layer takes over; the haze stops at 5 km.
    app.world_mut().resource_mut::<CurrentWeather>().near =
        Some(place(with(fair(), Variable::Visibility, Some(800.0))));
    app.update();
    assert_eq!(app.world().resource::<Haze>().visibility_m, 5_000.0);
    // A missing value keeps the last good one, never a wall of haze or none.
    app.world_mut().resource_mut::<CurrentWeather>().near =
        Some(place(with(fair(), Variable::Visibility, None)));
    app.update();
    assert_eq!(app.world().resource::<Haze>().visibility_m, 5_000.0);
    // Hand-set haze is left alone.
    app.world_mut().resource_mut::<Haze>().weather_driven = false;
    app.world_mut().resource_mut::<Haze>().visibility_m = 70_000.0;
    app.world_mut().resource_mut::<CurrentWeather>().near =
        Some(place(with(fair(), Variable::Visibility, Some(9_000.0))));
    app.update();
    assert_eq!(app.world().resource::<Haze>().visibility_m, 70_000.0);
}

/// A fair afternoon: every variable the mapping reads, with little weather.
fn fair() -> WeatherState {
    let mut s = state(&[
        (Variable::LowCover, 0.3),
        (Variable::MidCover, 0.1),
        (Variable::HighCover, 0.2),
        (Variable::Precipitation, 0.0),
        (Variable::ConvectivePrecipitation, 0.0),
        (Variable::FogProbability, 0.01),
        (Variable::Visibility, 30_000.0),
        (Variable::WindSpeed, 4.0),
        (Variable::WindDirection, 270.0),
    ]);
    s.pictocode = Some(7);
    s
}

fn with(mut s: WeatherState, variable: Variable, value: Option<f32>) -> WeatherState {
    s.values[variable as usize] = value;
    s
}

fn mapped(s: &WeatherState) -> (WeatherLayers, Vec<MappingWarning>) {
    let mut layers = WeatherLayers::new();
    let warnings = map_weather(s, BERN_M, &mut layers);
    (layers, warnings)
}

fn level(pressure_hpa: f32, speed: f32, from_deg: f32, height_m: Option<f32>) -> LevelState {
    LevelState {
        pressure_hpa,
        wind_speed_m_s: Some(speed),
        wind_direction_deg: Some(from_deg),
        height_m,
        cloud_cover: None,
    }
}

fn set_level(s: &mut WeatherState, level: LevelState) {
    let index = STANDARD_LEVELS_HPA
        .iter()
        .position(|p| *p == level.pressure_hpa)
        .unwrap();
    s.upper_air[index] = Some(level);
}

fn assert_all_finite(layers: &WeatherLayers) {
    for (slot, layer) in layers.iter() {
        let numbers = [
            layer.base_m,
            layer.top_m,
            layer.coverage,
            layer.density,
            layer.weather_map_scale_m,
            layer.wind_m_s[0],
            layer.wind_m_s[1],
            layer.skew,
            layer.precipitation,
            layer.rain_mm_per_h,
        ];
        assert!(numbers.iter().all(|v| v.is_finite()), "{slot}: {layer:?}");
        assert!((0.0..=1.0).contains(&layer.coverage), "{slot}");
        assert!((0.0..=1.0).contains(&layer.precipitation), "{slot}");
        assert!(layer.top_m >= layer.base_m, "{slot}");
        for h in 0..=20 {
            assert!(layer.profile.evaluate(h as f32 / 20.0).is_finite());
        }
    }
}

#[test]
fn covers_set_layer_coverage_in_their_bands() {
    let s = with(fair(), Variable::LowCover, Some(0.6));
    let s = with(s, Variable::MidCover, Some(0.45));
    let s = with(s, Variable::HighCover, Some(0.25));
    let (layers, warnings) = mapped(&s);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(layers[LayerSlot::Low].coverage, 0.6);
    assert_eq!(layers[LayerSlot::Mid].coverage, 0.45);
    assert_eq!(layers[LayerSlot::High].coverage, 0.25);
    // Above ground, within the format notes' bands (meteoblue: low < 2 km, mid 2–7 km,
    // high 5–13 km); the ground elevation does not shift them.
    let band_of = |slot: LayerSlot| {
        let b = CloudBands::METEOBLUE;
        match slot {
            LayerSlot::Low => b.low,
            LayerSlot::Mid => b.mid,
            _ => b.high,
        }
    };
    for slot in [LayerSlot::Low, LayerSlot::Mid, LayerSlot::High] {
        let layer = &layers[slot];
        let band = band_of(slot);
        assert!(
            layer.base_m >= band.bottom_m && layer.base_m <= band.top_m,
            "{slot}: {layer:?}"
        );
        assert!(layer.is_visible(), "{slot}");
    }
    let mut at_sea = WeatherLayers::new();
    map_weather(&s, 0.0, &mut at_sea);
    assert_eq!(at_sea[LayerSlot::Low].base_m, layers[LayerSlot::Low].base_m);
    // Layers are stacked: fog < low < mid < high.
    assert!(layers[LayerSlot::Fog].top_m <= layers[LayerSlot::Low].base_m);
    assert!(layers[LayerSlot::Low].top_m <= layers[LayerSlot::Mid].base_m);
    assert!(layers[LayerSlot::Mid].top_m <= layers[LayerSlot::High].base_m);
}

#[test]
fn open_meteo_bands_place_layers_higher() {
    let s = with(fair(), Variable::HighCover, Some(0.9));
    let mut layers = WeatherLayers::new();
    let mapped = WeatherMapping::for_format(Some(ForecastFormat::OpenMeteo)).map(&s, 0.0);
    mapped.apply_all(&mut layers);
    // Cirrostratus defaults to 7.5 km; Open-Meteo's high band starts at 8 km.
    assert_eq!(layers[LayerSlot::High].kind, CloudKind::Cirrostratus);
    assert_eq!(layers[LayerSlot::High].base_m, 8_000.0);
    assert_eq!(
        WeatherMapping::for_format(Some(ForecastFormat::Meteoblue)),
        WeatherMapping::default()
    );
    assert_eq!(WeatherMapping::for_format(None), WeatherMapping::METEOBLUE);
}

#[test]
fn low_kind_follows_cover_showers_and_codes() {
    let low_kind = |s: &WeatherState| mapped(s).0[LayerSlot::Low].kind;
    let mut s = with(fair(), Variable::LowCover, Some(0.3));
    assert_eq!(low_kind(&s), CloudKind::Cumulus);
    s = with(s, Variable::LowCover, Some(0.75));
    assert_eq!(low_kind(&s), CloudKind::Stratocumulus);
    // Closed deck with rain: stratus (nimbostratus substitute).
    s = with(s, Variable::LowCover, Some(0.95));
    s = with(s, Variable::Precipitation, Some(1.0));
    assert_eq!(low_kind(&s), CloudKind::Stratus);
    // Closed deck, dry: stratocumulus.
    s = with(s, Variable::Precipitation, Some(0.0));
    assert_eq!(low_kind(&s), CloudKind::Stratocumulus);
    // Showers make even a broken deck convective.
    s = with(s, Variable::ConvectivePrecipitation, Some(0.3));
    s = with(s, Variable::Precipitation, Some(0.3));
    assert_eq!(low_kind(&s), CloudKind::Cumulus);
    // Codes: fog 16 → stratus; showers 31 → cumulus; steady rain 23 → stratus.
    let mut coded = with(fair(), Variable::LowCover, Some(0.8));
    coded.pictocode = Some(16);
    assert_eq!(low_kind(&coded), CloudKind::Stratus);
    coded.pictocode = Some(31);
    assert_eq!(low_kind(&coded), CloudKind::Cumulus);
    coded.pictocode = Some(23);
    assert_eq!(low_kind(&coded), CloudKind::Stratus);
    // Open-Meteo WMO codes when there is no pictocode.
    coded.pictocode = None;
    coded.wmo_weather_code = Some(81);
    assert_eq!(low_kind(&coded), CloudKind::Cumulus);
    coded.wmo_weather_code = Some(45);
    assert_eq!(low_kind(&coded), CloudKind::Stratus);
}

#[test]
fn mid_and_high_kinds_follow_cover() {
    let kinds = |s: &WeatherState| {
        let (layers, _) = mapped(s);
        (layers[LayerSlot::Mid].kind, layers[LayerSlot::High].kind)
    };
    let s = with(fair(), Variable::MidCover, Some(0.3));
    let s = with(s, Variable::HighCover, Some(0.3));
    assert_eq!(kinds(&s), (CloudKind::Altocumulus, CloudKind::Cirrus));
    let s = with(s, Variable::MidCover, Some(0.8));
    let s = with(s, Variable::HighCover, Some(0.9));
    assert_eq!(kinds(&s), (CloudKind::Altostratus, CloudKind::Cirrostratus));
    // Half-covered mid level in rain: altostratus (it precedes and brings rain).
    let s = with(s, Variable::MidCover, Some(0.55));
    assert_eq!(kinds(&s).0, CloudKind::Altocumulus);
    let s = with(s, Variable::Precipitation, Some(0.5));
    assert_eq!(kinds(&s).0, CloudKind::Altostratus);
    let high = mapped(&s).0[LayerSlot::High].clone();
    assert!(high.kind.is_cirrus_family());
}

#[test]
fn thunderstorm_codes_add_a_cumulonimbus() {
    for code in [10, 11, 12, 27, 28, 29, 30] {
        let mut s = fair();
        s.pictocode = Some(code);
        let (layers, _) = mapped(&s);
        let cb = &layers[LayerSlot::Convective];
        assert_eq!(cb.kind, CloudKind::Cumulonimbus);
        assert!(cb.is_visible(), "pictocode {code}");
        assert!(cb.coverage >= 0.15, "pictocode {code}");
    }
    let mut wmo = fair();
    wmo.pictocode = None;
    wmo.wmo_weather_code = Some(95);
    assert!(mapped(&wmo).0[LayerSlot::Convective].is_visible());
    // No thunder, no heavy showers: no cumulonimbus.
    for code in [1, 7, 16, 22, 23, 31] {
        let mut s = fair();
        s.pictocode = Some(code);
        assert_eq!(
            mapped(&s).0[LayerSlot::Convective].coverage,
            0.0,
            "pictocode {code}"
        );
    }
    // The pictocode-27 case of the brief, through layers_for_weather.
    let mut s = fair();
    s.pictocode = Some(27);
    let (layers, _) = layers_for_weather(&s, BERN_M);
    assert!(layers.iter().any(|l| l.kind == CloudKind::Cumulonimbus));
}

#[test]
fn convective_precipitation_adds_and_grows_a_cumulonimbus() {
    let coverage = |rate: f32| {
        let s = with(fair(), Variable::ConvectivePrecipitation, Some(rate));
        let s = with(s, Variable::Precipitation, Some(rate));
        mapped(&s).0[LayerSlot::Convective].coverage
    };
    assert_eq!(coverage(0.5), 0.0, "below the 1 mm/h threshold");
    let mut last = 0.0;
    for rate in [1.0, 2.0, 5.0, 10.0, 40.0] {
        let c = coverage(rate);
        assert!(c > last, "{rate}: {c}");
        assert!(c <= 0.6 + 1e-6);
        last = c;
    }
    // More low cover → more storm cover, for the same rain.
    let s = with(fair(), Variable::ConvectivePrecipitation, Some(1.0));
    let s = with(s, Variable::Precipitation, Some(1.5));
    let sparse = mapped(&s).0[LayerSlot::Convective].coverage;
    let s = with(s, Variable::LowCover, Some(0.9));
    let (layers, _) = mapped(&s);
    assert!(layers[LayerSlot::Convective].coverage > sparse);
    // The storm takes the convective rain; the rest falls from the low layer.
    assert_eq!(layers[LayerSlot::Convective].rain_mm_per_h, 1.0);
    assert!((layers[LayerSlot::Low].rain_mm_per_h - 0.5).abs() < 1e-6);
    assert_eq!(layers[LayerSlot::Mid].rain_mm_per_h, 0.0);
}

#[test]
fn a_lightning_potential_adds_a_cumulonimbus() {
    let cb = |lpi: Option<f32>| {
        let s = with(fair(), Variable::LightningPotential, lpi);
        mapped(&s).0[LayerSlot::Convective].coverage
    };
    // Fair weather without showers: no storm below the threshold, one from it on.
    assert_eq!(cb(None), 0.0);
    assert_eq!(cb(Some(0.0)), 0.0);
    assert_eq!(cb(Some(0.5)), 0.0, "below 1 J/kg");
    assert!(
        cb(Some(1.0)) >= 0.15,
        "a storm at 1 J/kg: {}",
        cb(Some(1.0))
    );
    assert_eq!(cb(Some(1.0)), cb(Some(50.0)), "a potential, not a rate");
    // A storm the showers make stays whatever the index says.
    let showers = with(fair(), Variable::ConvectivePrecipitation, Some(3.0));
    let showers = with(showers, Variable::Precipitation, Some(3.0));
    let s = with(showers, Variable::LightningPotential, Some(0.0));
    assert!(mapped(&s).0[LayerSlot::Convective].coverage > 0.15);
}

#[test]
fn convective_cloud_base_and_top_are_placed_above_ground() {
    let s = with(fair(), Variable::ConvectiveCloudBase, Some(1_840.0));
    let s = with(s, Variable::ConvectiveCloudTop, Some(11_540.0));
    let s = with(s, Variable::ConvectivePrecipitation, Some(3.0));
    let s = with(s, Variable::Precipitation, Some(3.0));
    let (layers, _) = mapped(&s);
    let cb = &layers[LayerSlot::Convective];
    assert_eq!((cb.base_m, cb.top_m), (1_300.0, 11_000.0));
    let cu = &layers[LayerSlot::Low];
    assert_eq!(cu.kind, CloudKind::Cumulus);
    assert_eq!(cu.base_m, 1_300.0);
    assert_eq!(cu.top_m, 1_300.0 + 3_000.0, "capped at the deepest cumulus");
}

#[test]
fn fog_probability_adds_fog() {
    let (layers, _) = mapped(&with(fair(), Variable::FogProbability, Some(0.9)));
    let fog = &layers[LayerSlot::Fog];
    assert!(fog.is_visible());
    assert!((fog.coverage - 0.875).abs() < 1e-6, "{}", fog.coverage);
    assert_eq!(fog.kind, CloudKind::Stratus);
    assert_eq!(fog.base_m, 0.0);
    assert_eq!(fog.top_m, 150.0);
    // Low probabilities are no fog.
    let (layers, _) = mapped(&with(fair(), Variable::FogProbability, Some(0.15)));
    assert!(!layers[LayerSlot::Fog].is_visible());
}

#[test]
fn low_visibility_adds_fog_with_koschmieder_density() {
    let s = with(fair(), Variable::FogProbability, None);
    let s = with(s, Variable::Visibility, Some(300.0));
    let (layers, _) = mapped(&s);
    let fog = &layers[LayerSlot::Fog];
    assert_eq!(fog.coverage, 1.0);
    assert!((fog.density - 3.912 / 300.0).abs() < 1e-6);
    // Mist: partial fog, density capped at the fog threshold's.
    let (layers, _) = mapped(&with(s, Variable::Visibility, Some(3_000.0)));
    let mist = &layers[LayerSlot::Fog];
    assert!((mist.coverage - 0.5).abs() < 1e-6, "{}", mist.coverage);
    assert!((mist.density - 3.912 / 1_000.0).abs() < 1e-6);
    // Clear air: none.
    let (layers, _) = mapped(&with(s, Variable::Visibility, Some(20_000.0)));
    assert!(!layers[LayerSlot::Fog].is_visible());
    // The same low visibility in heavy rain is mostly the rain's doing.
    let wet = with(
        with(s, Variable::Visibility, Some(1_000.0)),
        Variable::Precipitation,
        Some(8.0),
    );
    assert!(mapped(&wet).0[LayerSlot::Fog].coverage < 0.1);
}

#[test]
fn fog_pictocodes_add_fog() {
    for code in [16, 17, 18] {
        let mut s = fair();
        s.pictocode = Some(code);
        let (layers, _) = mapped(&s);
        assert!(layers[LayerSlot::Fog].coverage >= 0.8, "pictocode {code}");
        assert_eq!(layers[LayerSlot::Low].kind, CloudKind::Stratus);
    }
    let mut wmo = fair();
    wmo.pictocode = None;
    wmo.wmo_weather_code = Some(48);
    assert!(mapped(&wmo).0[LayerSlot::Fog].coverage >= 0.8);
}

#[test]
fn precipitation_darkens_monotonically_and_sets_rain() {
    let m = WeatherMapping::default();
    assert_eq!(m.precipitation_darkening(0.0), 0.0);
    assert_eq!(m.precipitation_darkening(-1.0), 0.0);
    assert_eq!(m.precipitation_darkening(f32::NAN), 0.0);
    assert!((m.precipitation_darkening(2.5) - (1.0 - (-1.0f32).exp())).abs() < 1e-6);
    let mut last = 0.0;
    for i in 1..=80 {
        let d = m.precipitation_darkening(i as f32 * 0.25);
        assert!(d > last && d <= 1.0, "{i}: {d}");
        last = d;
    }
    assert_eq!(m.precipitation_darkening(f32::INFINITY), 1.0);
    // Tiny rates stay accurate (expm1 form).
    assert!((m.precipitation_darkening(1e-6) - 4e-7).abs() < 1e-12);

    let (dry, _) = mapped(&fair());
    for (slot, layer) in dry.iter() {
        assert_eq!(layer.precipitation, 0.0, "{slot}");
        assert_eq!(layer.rain_mm_per_h, 0.0, "{slot}");
    }
    let wet = with(fair(), Variable::Precipitation, Some(2.0));
    let (layers, _) = mapped(&wet);
    let expected = m.precipitation_darkening(2.0);
    for slot in [
        LayerSlot::Fog,
        LayerSlot::Low,
        LayerSlot::Mid,
        LayerSlot::Convective,
    ] {
        assert_eq!(layers[slot].precipitation, expected, "{slot}");
    }
    assert_eq!(layers[LayerSlot::High].precipitation, 0.0);
    assert_eq!(layers[LayerSlot::Low].rain_mm_per_h, 2.0);
    // No low cloud: the rain falls from the mid layer.
    let (layers, _) = mapped(&with(wet, Variable::LowCover, Some(0.0)));
    assert_eq!(layers[LayerSlot::Low].rain_mm_per_h, 0.0);
    assert_eq!(layers[LayerSlot::Mid].rain_mm_per_h, 2.0);
}

#[test]
fn raining_altostratus_thickens_downward() {
    let s = with(fair(), Variable::MidCover, Some(0.9));
    let dry = mapped(&s).0[LayerSlot::Mid].clone();
    let wet = mapped(&with(s, Variable::Precipitation, Some(6.0))).0[LayerSlot::Mid].clone();
    assert_eq!(dry.kind, CloudKind::Altostratus);
    assert_eq!(wet.top_m, dry.top_m);
    assert!(wet.base_m < dry.base_m - 500.0);
    assert!(wet.base_m >= CloudBands::METEOBLUE.mid.bottom_m);
}

#[test]
fn northerly_winds_either_side_of_north() {
    for from in [350.0, 10.0, 0.0] {
        let s = with(fair(), Variable::WindDirection, Some(from));
        let s = with(s, Variable::WindSpeed, Some(10.0));
        let (layers, _) = mapped(&s);
        for (slot, layer) in layers.iter() {
            let [east, north] = layer.wind_m_s;
            // A north wind blows toward the south.
            assert!(north < -9.0, "{from}° {slot}: {:?}", layer.wind_m_s);
            assert!(east.abs() < 0.2 * north.abs(), "{from}° {slot}");
            if from == 350.0 {
                assert!(east > 0.0, "from NNW toward SSE");
            }
            if from == 10.0 {
                assert!(east < 0.0, "from NNE toward SSW");
            }
        }
    }
}

#[test]
fn surface_wind_grows_with_height_by_the_power_law() {
    let s = with(fair(), Variable::WindDirection, Some(180.0));
    let s = with(s, Variable::WindSpeed, Some(5.0));
    let (layers, _) = mapped(&s);
    let speed = |slot: LayerSlot| layers[slot].wind_m_s[1];
    let expected = |slot: LayerSlot| {
        let l = &layers[slot];
        5.0 * (0.5 * (l.base_m + l.top_m) / 10.0).powf(1.0 / 7.0)
    };
    for slot in [
        LayerSlot::Fog,
        LayerSlot::Low,
        LayerSlot::Mid,
        LayerSlot::High,
    ] {
        assert!((speed(slot) - expected(slot)).abs() < 1e-4, "{slot}");
    }
    assert!(speed(LayerSlot::Fog) < speed(LayerSlot::Low));
    assert!(speed(LayerSlot::Low) < speed(LayerSlot::Mid));
    assert!(speed(LayerSlot::Mid) < speed(LayerSlot::High));
}

#[test]
fn pressure_level_wind_is_used_when_present() {
    let mut s = fair(); // 4 m/s west wind at the surface
    set_level(&mut s, level(850.0, 12.0, 180.0, Some(1_540.0)));
    set_level(&mut s, level(700.0, 20.0, 0.0, Some(3_040.0)));
    set_level(&mut s, level(500.0, 30.0, 0.0, None)); // standard 5 574 m
    set_level(&mut s, level(300.0, 40.0, 90.0, Some(9_540.0)));
    let (layers, warnings) = mapped(&s);
    assert!(warnings.is_empty(), "{warnings:?}");
    let close = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).abs() < 1e-4 && (a[1] - b[1]).abs() < 1e-4;
    // Low: the 850 hPa wind from the south.
    assert!(close(layers[LayerSlot::Low].wind_m_s, [0.0, 12.0]));
    // High: 300 hPa from the east.
    assert!(close(layers[LayerSlot::High].wind_m_s, [-40.0, 0.0]));
    // Mid: between 700 hPa (2 500 m above Bern) and 500 hPa (5 034 m), by height.
    let mid = &layers[LayerSlot::Mid];
    let z = 0.5 * (mid.base_m + mid.top_m);
    let t = (z - 2_500.0) / (5_574.0 - BERN_M - 2_500.0);
    assert!(
        close(mid.wind_m_s, [0.0, -(20.0 + 10.0 * t)]),
        "{:?}",
        mid.wind_m_s
    );
    // Convective: the mean of the four levels.
    let cb = layers[LayerSlot::Convective].wind_m_s;
    assert!(close(cb, [-10.0, (12.0 - 20.0 - 30.0) / 4.0]), "{cb:?}");
    // Fog stays with the surface wind.
    assert!(layers[LayerSlot::Fog].wind_m_s[0] > 4.0);

    // Only 300 hPa present: the others fall back to the surface wind, no warning.
    let mut sparse = fair();
    set_level(&mut sparse, level(300.0, 40.0, 90.0, None));
    let (layers, warnings) = mapped(&sparse);
    assert!(warnings.is_empty());
    assert!(layers[LayerSlot::Low].wind_m_s[0] > 4.0);
    assert!(close(layers[LayerSlot::High].wind_m_s, [-40.0, 0.0]));
}

#[test]
fn levels_below_a_mountain_site_are_ignored() {
    let mut s = fair();
    set_level(&mut s, level(850.0, 30.0, 0.0, Some(1_500.0)));
    let mut layers = WeatherLayers::new();
    WeatherMapping::default()
        .map(&s, 3_000.0)
        .apply_all(&mut layers);
    // The 850 hPa surface is underground at 3 000 m: surface wind (from the west) instead.
    assert!(layers[LayerSlot::Low].wind_m_s[0] > 4.0);
}

#[test]
fn a_layer_is_the_users_without_its_slot_and_the_presets_while_one_is_active() {
    use crate::scene::Place;
    use crate::weather::preset::ActivePreset;
    use crate::weather::{CurrentWeather, PlaceWeather};
    let mut stormy = with(fair(), Variable::LowCover, Some(1.0));
    stormy.pictocode = Some(30);
    let stormy = with(stormy, Variable::Precipitation, Some(20.0));
    let mut app = App::new();
    app.insert_resource(CurrentWeather {
        near: Some(PlaceWeather {
            place: Place {
                name: "Bern".into(),
                latitude_deg: 47.0,
                longitude_deg: 7.4,
                elevation_m: f64::from(BERN_M),
            },
            scene_position: Vec3::ZERO,
            state: stormy,
            steps: None,
        }),
        far: vec![],
    })
    .insert_resource(WeatherMapping::default())
    .init_resource::<Assets<crate::weather::Forecast>>()
    .add_systems(Update, map_weather_onto_layers);
    let low = app
        .world_mut()
        .spawn((LayerSlot::Low, LayerSlot::Low.initial_layer()))
        .id();
    let coverage = |app: &App| app.world().get::<CloudLayer>(low).unwrap().coverage;
    let hand_edit = |app: &mut App, coverage: f32| {
        let mut layer = app.world_mut().get_mut::<CloudLayer>(low).unwrap();
        layer.coverage = coverage;
        layer.base_m = f32::NAN; // even garbage is the user's business
    };
    let weather_changes = |app: &mut App| {
        app.world_mut()
            .resource_mut::<CurrentWeather>()
            .set_changed();
        app.update();
    };
    app.update();
    assert_eq!(coverage(&app), 1.0);

    // Without its slot the layer keeps every hand-set value, whatever the weather does.
    app.world_mut().entity_mut(low).remove::<LayerSlot>();
    hand_edit(&mut app, 0.33);
    weather_changes(&mut app);
    assert_eq!(coverage(&app), 0.33);
    assert!(app.world().get::<CloudLayer>(low).unwrap().base_m.is_nan());

    // The slot back: the forecast takes over at once, without waiting for new weather.
    app.world_mut().entity_mut(low).insert(LayerSlot::Low);
    app.update();
    assert_eq!(coverage(&app), 1.0);
    assert!(
        app.world()
            .get::<CloudLayer>(low)
            .unwrap()
            .base_m
            .is_finite()
    );

    // While a preset is active the forecast writes nothing; when it ends, the forecast is back.
    app.insert_resource(ActivePreset::new(Handle::default()));
    hand_edit(&mut app, 0.2);
    weather_changes(&mut app);
    assert_eq!(coverage(&app), 0.2);
    app.world_mut().remove_resource::<ActivePreset>();
    app.update();
    assert_eq!(coverage(&app), 1.0);
}

#[test]
fn shape_edits_survive_while_the_kind_stays() {
    let s = with(fair(), Variable::LowCover, Some(0.3));
    let mut layers = WeatherLayers::new();
    map_weather(&s, BERN_M, &mut layers);
    layers[LayerSlot::Low].density = 0.02;
    layers[LayerSlot::Low].skew = 0.7;
    map_weather(&with(s, Variable::LowCover, Some(0.4)), BERN_M, &mut layers);
    assert_eq!(layers[LayerSlot::Low].density, 0.02);
    assert_eq!(layers[LayerSlot::Low].skew, 0.7);
    // A new kind brings its own shape.
    map_weather(&with(s, Variable::LowCover, Some(0.8)), BERN_M, &mut layers);
    let low = &layers[LayerSlot::Low];
    assert_eq!(low.kind, CloudKind::Stratocumulus);
    assert_eq!(*low, {
        let mut expected = CloudLayer::new(CloudKind::Stratocumulus);
        expected.coverage = 0.8;
        expected.base_m = low.base_m;
        expected.top_m = low.top_m;
        expected.wind_m_s = low.wind_m_s;
        expected
    });
}

#[test]
fn missing_covers_hold_previous_values_and_are_reported() {
    let mut layers = WeatherLayers::new();
    let s = with(fair(), Variable::LowCover, Some(0.7));
    let s = with(s, Variable::MidCover, Some(0.8));
    map_weather(&s, BERN_M, &mut layers);
    let before = layers.clone();
    let gap = with(with(s, Variable::LowCover, None), Variable::MidCover, None);
    let warnings = map_weather(&gap, BERN_M, &mut layers);
    assert_eq!(layers[LayerSlot::Low].coverage, 0.7);
    assert_eq!(layers[LayerSlot::Low].kind, before[LayerSlot::Low].kind);
    assert_eq!(layers[LayerSlot::Mid].coverage, 0.8);
    assert_eq!(layers[LayerSlot::Mid].kind, CloudKind::Altostratus);
    let inputs: Vec<_> = warnings.iter().map(|w| w.input).collect();
    assert_eq!(inputs, ["low_cover", "mid_cover"]);
    assert!(warnings.iter().all(|w| w.fault == InputFault::NoValue));
    assert!(
        warnings[0]
            .to_string()
            .starts_with("low_cover has no value: the low layer keeps")
    );

    // From scratch, a missing cover gives no layer at all, and says so.
    let (fresh, warnings) = layers_for_weather(&with(fair(), Variable::HighCover, None), BERN_M);
    assert!(fresh.iter().all(|l| !l.kind.is_cirrus_family()));
    assert_eq!(warnings.len(), 1);
    assert_eq!(warnings[0].input, "high_cover");
}

#[test]
fn every_held_input_is_reported_once() {
    let mut layers = WeatherLayers::new();
    map_weather(&fair(), BERN_M, &mut layers);
    let before = layers.clone();
    let empty = WeatherState::empty(UtcInstant::from_unix_seconds(0));
    let warnings = map_weather(&empty, BERN_M, &mut layers);
    let inputs: Vec<_> = warnings.iter().map(|w| w.input).collect();
    assert_eq!(
        inputs,
        [
            "low_cover",
            "mid_cover",
            "high_cover",
            "precipitation",
            "convective_precipitation",
            "fog_probability",
            "wind_speed"
        ]
    );
    // Nothing was zeroed: coverage, darkening, rain and wind are as before.
    for (slot, layer) in layers.iter() {
        let old = &before[slot];
        assert_eq!(layer.coverage, old.coverage, "{slot}");
        assert_eq!(layer.wind_m_s, old.wind_m_s, "{slot}");
        assert_eq!(layer.precipitation, old.precipitation, "{slot}");
        assert_eq!(layer.rain_mm_per_h, old.rain_mm_per_h, "{slot}");
    }
}

#[test]
fn nan_inputs_never_reach_the_layers() {
    let nan = f32::NAN;
    let mut s = state(&Variable::ALL.map(|v| (v, nan)));
    s.pictocode = Some(99);
    let mut bad = level(850.0, nan, 0.0, Some(nan));
    bad.wind_direction_deg = Some(f32::INFINITY);
    set_level(&mut s, bad);
    set_level(&mut s, level(300.0, 20.0, nan, None));
    let mut layers = WeatherLayers::new();
    let digested = WeatherMapping::default().map(&s, nan);
    digested.apply_all(&mut layers);
    assert_all_finite(&layers);
    let warnings = digested.warnings;
    assert!(warnings.iter().any(|w| w.input == "ground_elevation_m"));
    assert!(warnings.iter().any(|w| w.input == "pressure-level wind"));
    let low = warnings.iter().find(|w| w.input == "low_cover").unwrap();
    assert_eq!(low.fault, InputFault::NotFinite);
    assert!(low.to_string().contains("is not a finite number"));
    // Each input at most once.
    let mut inputs: Vec<_> = warnings.iter().map(|w| w.input).collect();
    let count = inputs.len();
    inputs.sort_unstable();
    inputs.dedup();
    assert_eq!(inputs.len(), count, "{warnings:?}");
    // NaN visibility next to a good fog probability: used the probability, reported.
    let s = with(fair(), Variable::Visibility, Some(nan));
    let s = with(s, Variable::FogProbability, Some(0.6));
    let (layers, warnings) = mapped(&s);
    assert!((layers[LayerSlot::Fog].coverage - 0.5).abs() < 1e-6);
    assert_eq!(warnings.len(), 1);
    assert_eq!(warnings[0].input, "visibility");
    assert_eq!(warnings[0].fault, InputFault::NotFinite);
    // Out-of-range values are clamped, not propagated.
    let wild = with(fair(), Variable::LowCover, Some(7.0));
    let wild = with(wild, Variable::Precipitation, Some(-3.0));
    let wild = with(wild, Variable::WindSpeed, Some(f32::MAX));
    let (layers, _) = mapped(&wild);
    assert_eq!(layers[LayerSlot::Low].coverage, 1.0);
    assert_eq!(layers[LayerSlot::Low].precipitation, 0.0);
    assert_all_finite(&layers);
    // Hand-set NaN fields of a weather-driven layer are repaired by the next mapping.
    let mut layers = WeatherLayers::new();
    layers[LayerSlot::Mid].skew = nan;
    layers[LayerSlot::Mid].coverage = nan;
    map_weather(&with(fair(), Variable::MidCover, None), BERN_M, &mut layers);
    assert_all_finite(&layers);
}

#[test]
fn nonsense_mapping_settings_do_not_panic() {
    let mut m = WeatherMapping::default();
    m.bands.low = CloudBand {
        bottom_m: 5_000.0,
        top_m: 100.0,
    };
    m.bands.mid.bottom_m = f32::NAN;
    m.fog_probability_floor = 1.0;
    m.mist_visibility_m = 500.0;
    m.darkening_scale_mm_per_h = 0.0;
    m.thunderstorm_scale_mm_per_h = -1.0;
    m.wind_shear_exponent = f32::INFINITY;
    let mut s = with(fair(), Variable::Precipitation, Some(3.0));
    s = with(s, Variable::ConvectivePrecipitation, Some(3.0));
    s = with(s, Variable::Visibility, Some(400.0));
    let mut layers = WeatherLayers::new();
    m.map(&s, BERN_M).apply_all(&mut layers);
    assert_all_finite(&layers);
    assert_eq!(m.precipitation_darkening(1.0), 1.0);
}

#[test]
fn the_bundled_bern_week_maps_to_plausible_layers() {
    use crate::weather::Forecast;
    let bern =
        Forecast::from_slice(include_bytes!("../../../assets/weather/bern.json"), None).unwrap();
    let ground = bern.place.elevation_m as f32;
    let local = |day: u8, hour: u8| {
        UtcInstant::from_civil(2021, 5, day, hour, 0, 0)
            .unwrap()
            .saturating_add_seconds(-2 * 3600)
    };
    let layers_at = |day, hour| layers_for_weather(&bern.sample(local(day, hour)), ground);
    // Monday afternoon: cumulus.
    let (monday, _) = layers_at(3, 15);
    assert!(monday.iter().any(|l| l.kind == CloudKind::Cumulus));
    // Thursday morning: fog.
    let (thursday, _) = layers_at(6, 7);
    assert!(
        thursday
            .iter()
            .any(|l| l.base_m == 0.0 && l.coverage >= 0.8)
    );
    // Friday afternoon: a thunderstorm.
    let (friday, _) = layers_at(7, 16);
    assert!(friday.iter().any(|l| l.kind == CloudKind::Cumulonimbus));
    // Every hour of the week maps to finite layers.
    let mut all = WeatherLayers::new();
    let mut t = bern.times[0];
    while t <= bern.end().unwrap() {
        map_weather(&bern.sample(t), ground, &mut all);
        assert_all_finite(&all);
        t = t.saturating_add_seconds(1800);
    }
}

#[test]
fn the_table_names_real_inputs_and_every_slot() {
    let extra = [
        "pictocode",
        "weather_code",
        "level_wind",
        "ground_elevation_m",
    ];
    for row in &MAPPING_TABLE {
        assert!(
            extra.contains(&row.input) || Variable::ALL.iter().any(|v| v.name() == row.input),
            "{}",
            row.input
        );
        assert!(!row.slots.is_empty() && !row.rule.is_empty());
    }
    for slot in LayerSlot::ALL {
        assert!(
            MAPPING_TABLE.iter().any(|row| row.slots.contains(&slot)),
            "{slot}"
        );
    }
    // The variables the mapping reads all have a row (wind direction rides with speed and
    // the convective top with the base).
    for variable in [
        Variable::LowCover,
        Variable::MidCover,
        Variable::HighCover,
        Variable::ConvectivePrecipitation,
        Variable::FogProbability,
        Variable::Visibility,
        Variable::Precipitation,
        Variable::WindSpeed,
        Variable::ConvectiveCloudBase,
    ] {
        assert!(
            MAPPING_TABLE.iter().any(|row| row.input == variable.name()),
            "{}",
            variable.name()
        );
    }
}

#[test]
fn slots_and_layers() {
    let layers = WeatherLayers::default();
    assert_eq!(layers.visible().count(), 0, "nothing before a forecast");
    for (slot, layer) in layers.iter() {
        assert_eq!(layer.kind, slot.initial_kind());
        assert_eq!(*layer, slot.initial_layer());
    }
    assert_eq!(LayerSlot::Convective.to_string(), "convective");
    let mut layers = layers;
    for (_, layer) in layers.iter_mut() {
        layer.coverage = 0.5;
    }
    assert_eq!(layers.visible().count(), LayerSlot::COUNT);
    let band = CloudBand {
        bottom_m: 10.0,
        top_m: 0.0,
    };
    assert!(band.clamp_base(5.0).is_finite());
    let mapped = WeatherMapping::default().map(&fair(), BERN_M);
    assert_eq!(mapped.ground_elevation_m(), BERN_M);
    assert_eq!(*mapped.mapping(), WeatherMapping::METEOBLUE);
}
