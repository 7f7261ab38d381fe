//! The contract between the WGSL shaders and their Rust twins: every constant the shaders
//! declare has the value of its Rust twin, and every uniform and storage struct the shaders read
//! has the size and the fields, in order, of the Rust struct that writes it. A constant or a
//! layout changed on one side only fails here.

use bevy::render::render_resource::ShaderType;

use super::{
    composite::{GpuTemporalUniforms, GpuViewGround},
    growth::GpuGrowthUniforms,
    haze::GpuHazeUniforms,
    noise::GpuNoiseParams,
    shadow::GpuShadowUniforms,
    view::{GpuCloudLayer, GpuCloudUniforms},
    weather_map::GpuWeatherMapUniforms,
};
use crate::reference::{
    blue_noise, composite, growth, haze,
    noise::{self as noise_ref},
    render as march_ref, shadow,
};
use crate::sky::stars;

/// Every shader of the crate, by path under `src/render/`, with its source.
const SHADERS: &[(&str, &str)] = &[
    (
        "march/parameters.wgsl",
        include_str!("march/parameters.wgsl"),
    ),
    ("march/textures.wgsl", include_str!("march/textures.wgsl")),
    ("march/geometry.wgsl", include_str!("march/geometry.wgsl")),
    ("march/density.wgsl", include_str!("march/density.wgsl")),
    ("march/light.wgsl", include_str!("march/light.wgsl")),
    ("march/shadow.wgsl", include_str!("march/shadow.wgsl")),
    ("march/clouds.wgsl", include_str!("march/clouds.wgsl")),
    ("march/march.wgsl", include_str!("march/march.wgsl")),
    ("noise/noise.wgsl", include_str!("noise/noise.wgsl")),
    ("haze/haze.wgsl", include_str!("haze/haze.wgsl")),
    ("shadow/shadow.wgsl", include_str!("shadow/shadow.wgsl")),
    (
        "composite/composite.wgsl",
        include_str!("composite/composite.wgsl"),
    ),
    (
        "composite/temporal.wgsl",
        include_str!("composite/temporal.wgsl"),
    ),
    (
        "composite/upsample.wgsl",
        include_str!("composite/upsample.wgsl"),
    ),
    (
        "composite/view_depth.wgsl",
        include_str!("composite/view_depth.wgsl"),
    ),
    (
        "weather_map/weather_map.wgsl",
        include_str!("weather_map/weather_map.wgsl"),
    ),
    ("growth/growth.wgsl", include_str!("growth/growth.wgsl")),
];

/// WGSL constants of the GPU's own schedule, which the CPU twin has no use for: the deferred
/// light march's queue (`march/clouds.wgsl`). Each is checked to be declared, so a stale name
/// fails too.
const GPU_ONLY: &[&str] = &["LIGHT_QUEUE_STEPS", "LIGHT_QUEUE_SIZE", "NO_SAMPLE"];

/// The Rust value of every WGSL constant, by name (flattened for vectors and arrays).
fn rust_constants() -> Vec<(&'static str, Vec<f64>)> {
    use march_ref::*;
    let scalar = |v: f64| vec![v];
    let slot = |s: noise_ref::FbmSlot| vec![s as f64];
    vec![
        ("FAR_AWAY", scalar(composite::FAR_AWAY)),
        ("STAR_CELLS", scalar(stars::STAR_CELLS.into())),
        ("FAINTEST_MAGNITUDE", scalar(stars::FAINTEST_MAGNITUDE)),
        (
            "EXTINCTION_MAG_PER_AIRMASS",
            scalar(stars::EXTINCTION_MAG_PER_AIRMASS),
        ),
        ("STAR_CELL_MARGIN", scalar(stars::STAR_CELL_MARGIN)),
        ("DEPTH_TOLERANCE", scalar(composite::DEPTH_TOLERANCE)),
        ("MIN_WEIGHT_SUM", scalar(composite::MIN_WEIGHT_SUM)),
        (
            "HISTORY_SNAP_TEXELS",
            scalar(composite::HISTORY_SNAP_TEXELS),
        ),
        (
            "HISTORY_DEPTH_RATIO",
            scalar(composite::HISTORY_DEPTH_RATIO),
        ),
        ("NO_HIT", scalar(NO_HIT)),
        ("PI", scalar(std::f64::consts::PI)),
        ("MAX_HAZE_STEPS", scalar(haze::MAX_HAZE_STEPS.into())),
        (
            "LIGHT_SHARE_ANGLES",
            scalar(haze::LIGHT_SHARE_ANGLES.into()),
        ),
        (
            "LIGHT_SHARE_AZIMUTHS",
            scalar(haze::LIGHT_SHARE_AZIMUTHS.into()),
        ),
        (
            "HAZE_TOP_SCALE_HEIGHTS",
            scalar(haze::HAZE_TOP_SCALE_HEIGHTS),
        ),
        ("MAX_PROFILE_POINTS", scalar(MAX_PROFILE_POINTS as f64)),
        ("MAX_FAR_COVERAGES", scalar(MAX_FAR_COVERAGES as f64)),
        ("FAR_BLEND_START", scalar(FAR_BLEND_START)),
        ("MIN_DIFFUSE_MU_SUN", scalar(MIN_DIFFUSE_MU_SUN)),
        ("PEAK_ORDERS", scalar(PEAK_ORDERS as f64)),
        ("PEAK_SPREAD_ANGLES", scalar(PEAK_SPREAD_ANGLES as f64)),
        ("PEAK_SPREAD_AZIMUTHS", scalar(PEAK_SPREAD_AZIMUTHS as f64)),
        ("QUADRATURE_MU", scalar(QUADRATURE_MU)),
        ("HALO_ANGLE_DEG", scalar(HALO_ANGLE_DEG)),
        ("HALO_EDGE_DEG", scalar(HALO_EDGE_DEG)),
        ("HALO_FADE_DEG", scalar(HALO_FADE_DEG)),
        ("MAX_PRIMARY_STEPS", scalar(MAX_PRIMARY_STEPS.into())),
        ("MAX_LIGHT_STEPS", scalar(MAX_LIGHT_STEPS.into())),
        ("LIGHT_SAMPLE_OFFSET", scalar(LIGHT_SAMPLE_OFFSET)),
        ("LIGHT_STEP_SPAN_M", scalar(LIGHT_STEP_SPAN_M)),
        ("CHEAP_STRIDE", scalar(CHEAP_STRIDE.into())),
        ("EMPTY_STEPS_TO_CHEAP", scalar(EMPTY_STEPS_TO_CHEAP.into())),
        ("MAX_STEP_OPTICAL_DEPTH", scalar(MAX_STEP_OPTICAL_DEPTH)),
        ("PART_OFFSET_THIN", scalar(PART_OFFSET_THIN)),
        ("MAX_SUBSTEPS", scalar(MAX_SUBSTEPS.into())),
        ("MAX_PARTS", scalar(MAX_PARTS.into())),
        (
            "PAST_CUTOFF_LIGHT_STEP_DIVISOR",
            scalar(PAST_CUTOFF_LIGHT_STEP_DIVISOR.into()),
        ),
        (
            "PAST_CUTOFF_MIN_LIGHT_STEPS",
            scalar(PAST_CUTOFF_MIN_LIGHT_STEPS.into()),
        ),
        (
            "FULL_LIGHT_STEPS_TRANSMITTANCE",
            scalar(FULL_LIGHT_STEPS_TRANSMITTANCE),
        ),
        ("TOWARD_SUN_COS", scalar(TOWARD_SUN_COS)),
        (
            "CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M",
            scalar(haze::CLEAR_AIR_RAYLEIGH_EXTINCTION_PER_M),
        ),
        (
            "CLEAR_AIR_MIE_EXTINCTION_PER_M",
            scalar(haze::CLEAR_AIR_MIE_EXTINCTION_PER_M),
        ),
        (
            "RAYLEIGH_SCALE_HEIGHT_M",
            scalar(haze::RAYLEIGH_SCALE_HEIGHT_M),
        ),
        ("MIE_SCALE_HEIGHT_M", scalar(haze::MIE_SCALE_HEIGHT_M)),
        ("CLEAR_AIR_STEPS", scalar(CLEAR_AIR_STEPS.into())),
        ("SUN_DISC_NO_FADE_DEG", scalar(SUN_DISC_NO_FADE_DEG)),
        ("SUN_DISC_FULL_FADE_DEG", scalar(SUN_DISC_FULL_FADE_DEG)),
        ("FLASH_MIN_DISTANCE_M", scalar(FLASH_MIN_DISTANCE_M)),
        ("FLASH_LEAK_M", scalar(FLASH_LEAK_M)),
        ("SHADOW_MAP_MIN_SUN_MU", scalar(SHADOW_MAP_MIN_SUN_MU)),
        ("SHADOW_MAP_BLEND_COS", scalar(SHADOW_MAP_BLEND_COS)),
        ("SHADOW_MAP_FULL_SUN_MU", scalar(SHADOW_MAP_FULL_SUN_MU)),
        (
            "AWAY_FROM_SUN_CUTOFF_GAIN",
            scalar(AWAY_FROM_SUN_CUTOFF_GAIN),
        ),
        ("AWAY_FROM_SUN_COS", scalar(AWAY_FROM_SUN_COS)),
        ("CLEAR_STEP_OPTICAL_DEPTH", scalar(CLEAR_STEP_OPTICAL_DEPTH)),
        ("EDGE_SEARCH_STEPS", scalar(EDGE_SEARCH_STEPS.into())),
        ("PRECIPITATION_ABSORPTION", scalar(PRECIPITATION_ABSORPTION)),
        ("MAX_DETAIL_EROSION", scalar(MAX_DETAIL_EROSION)),
        ("DETAIL_TRANSITION_HEIGHT", scalar(DETAIL_TRANSITION_HEIGHT)),
        ("MAX_PHASE_G", scalar(MAX_PHASE_G)),
        ("FBM_WEIGHTS", FBM_WEIGHTS.to_vec()),
        ("WEATHER_COVERAGE_RANGE", WEATHER_COVERAGE_RANGE.to_vec()),
        ("COVERAGE_EDGE_WIDTH", scalar(COVERAGE_EDGE_WIDTH)),
        ("OVERCAST_COVERAGE", scalar(OVERCAST_COVERAGE)),
        ("PATCH_COVERAGE", scalar(PATCH_COVERAGE)),
        ("PATCH_AREA_GAIN", scalar(PATCH_AREA_GAIN)),
        ("BROKEN_PATCH_AREA", scalar(BROKEN_PATCH_AREA)),
        ("CLOSING_COVERAGE", scalar(CLOSING_COVERAGE)),
        ("GROWTH_FULL_COVER", scalar(GROWTH_FULL_COVER)),
        ("SHAPE_WARP", scalar(SHAPE_WARP)),
        ("SHAPE_WARP_BROAD", scalar(SHAPE_WARP_BROAD)),
        ("BROAD_WARP_PERIODS", scalar(BROAD_WARP_PERIODS)),
        // f32 has no `expm1`: the shader switches to the series at a larger optical thickness
        // (`SERIES_LIMIT` documents both).
        ("SERIES_LIMIT", scalar(WGSL_SERIES_LIMIT)),
        (
            "GOLDEN_RATIO_CONJUGATE",
            scalar(blue_noise::GOLDEN_RATIO_CONJUGATE),
        ),
        (
            "JITTER_FRAME_PERIOD",
            scalar(blue_noise::JITTER_FRAME_PERIOD.into()),
        ),
        ("MAX_SHADOW_STEPS", scalar(shadow::MAX_SHADOW_STEPS.into())),
        ("SHADOW_KNOT_DEPTHS", shadow::SHADOW_KNOT_DEPTHS.to_vec()),
        ("SHADOW_MAP_NEAR_TEXELS", scalar(SHADOW_MAP_NEAR_TEXELS)),
        (
            "SHADOW_MAP_NEAR_STEPS",
            scalar(SHADOW_MAP_NEAR_STEPS.into()),
        ),
        (
            "HIGHER_LAYER_STEP_DIVISOR",
            scalar(HIGHER_LAYER_STEP_DIVISOR.into()),
        ),
        ("MAX_OCTAVES", scalar(noise_ref::MAX_OCTAVES.into())),
        ("MAX_FREQUENCY", scalar(noise_ref::MAX_FREQUENCY.into())),
        ("WEATHER_SLICE_Z", scalar(noise_ref::WEATHER_SLICE_Z)),
        ("CURL_STEP_CELLS", scalar(noise_ref::CURL_STEP_CELLS)),
        ("CURL_RANGE", scalar(noise_ref::CURL_RANGE)),
        (
            "PERLIN_WORLEY_CONTRAST",
            scalar(noise_ref::PERLIN_WORLEY_CONTRAST),
        ),
        ("VARIATION_CONTRAST", scalar(noise_ref::VARIATION_CONTRAST)),
        ("NOISE_LEVELS", scalar(noise_ref::NOISE_LEVELS)),
        (
            "PERLIN_GRADIENTS",
            noise_ref::PERLIN_GRADIENTS
                .iter()
                .flatten()
                .copied()
                .collect(),
        ),
        ("SLOT_BASE_PERLIN", slot(noise_ref::SLOT_BASE_PERLIN)),
        ("SLOT_BASE_WORLEY", slot(noise_ref::SLOT_BASE_WORLEY)),
        ("SLOT_BASE_G", slot(noise_ref::SLOT_BASE_G)),
        ("SLOT_BASE_B", slot(noise_ref::SLOT_BASE_B)),
        ("SLOT_BASE_A", slot(noise_ref::SLOT_BASE_A)),
        ("SLOT_DETAIL_R", slot(noise_ref::SLOT_DETAIL_R)),
        ("SLOT_DETAIL_G", slot(noise_ref::SLOT_DETAIL_G)),
        ("SLOT_DETAIL_B", slot(noise_ref::SLOT_DETAIL_B)),
        ("SLOT_WEATHER_PERLIN", slot(noise_ref::SLOT_WEATHER_PERLIN)),
        ("SLOT_WEATHER_WORLEY", slot(noise_ref::SLOT_WEATHER_WORLEY)),
        (
            "SLOT_WEATHER_VARIATION",
            slot(noise_ref::SLOT_WEATHER_VARIATION),
        ),
        ("SLOT_WEATHER_CURL", slot(noise_ref::SLOT_WEATHER_CURL)),
        ("HUM", scalar(growth::HUM.into())),
        ("ACT", scalar(growth::ACT.into())),
        ("CLD", scalar(growth::CLD.into())),
        ("COVER_RADIUS", scalar(growth::COVER_RADIUS.into())),
        // Which fBm a noise octave sums; the CPU twin passes the function itself.
        ("OCTAVE_PERLIN", scalar(0.0)),
        ("OCTAVE_WORLEY", scalar(1.0)),
    ]
}

/// `(name, body)` of every module-level `const` in `source`: the text between `=` and `;`.
fn wgsl_constants(source: &str) -> Vec<(String, String)> {
    let code: String = source
        .lines()
        .map(|line| line.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n");
    let mut found = Vec::new();
    let mut rest = code.as_str();
    while let Some(start) = rest.find("\nconst ") {
        let decl = &rest[start + "\nconst ".len()..];
        let end = decl.find(';').expect("a const ends with ;");
        let (name, body) = decl[..end].split_once('=').expect("a const has a value");
        let name = name.split(':').next().unwrap().trim().to_owned();
        found.push((name, body.trim().to_owned()));
        rest = &decl[end..];
    }
    found
}

/// The numbers of a constant's WGSL value: its literals in order (a type's `vec3<f32>` or
/// `array<f32, 2>` aside), with `a / b` evaluated.
fn wgsl_numbers(body: &str) -> Vec<f64> {
    // Drop the type constructors, keep what is inside the outermost parentheses.
    let inner = match body.find('(') {
        Some(open) => &body[open + 1..body.rfind(')').unwrap()],
        None => body,
    };
    inner
        .split(',')
        // An inner constructor's name (`vec3<f32>(`) and closing parentheses are not numbers.
        .map(|part| {
            part.rsplit('(')
                .next()
                .unwrap_or(part)
                .trim_end_matches([')', ' ', '\n'])
                .trim()
        })
        .filter(|part| !part.is_empty())
        .map(|part| {
            let literal = |s: &str| -> f64 {
                s.trim()
                    .trim_end_matches(['u', 'i', 'f'])
                    .parse()
                    .unwrap_or_else(|_| panic!("not a number: {s:?} in {body:?}"))
            };
            match part.split_once('/') {
                Some((a, b)) => literal(a) / literal(b),
                None => literal(part),
            }
        })
        .collect()
}

#[test]
fn every_wgsl_constant_has_the_value_of_its_rust_twin() {
    let rust = rust_constants();
    let mut seen = Vec::new();
    for (file, source) in SHADERS {
        for (name, body) in wgsl_constants(source) {
            if GPU_ONLY.contains(&name.as_str()) {
                seen.push(name);
                continue;
            }
            let expected = rust
                .iter()
                .find(|(n, _)| *n == name)
                .unwrap_or_else(|| panic!("{file}: `{name}` has no Rust twin in rust_constants"));
            let got = wgsl_numbers(&body);
            assert_eq!(got.len(), expected.1.len(), "{file}: {name} = {body}");
            for (g, e) in got.iter().zip(&expected.1) {
                // The shader holds f32: equal to the Rust value rounded to f32.
                assert_eq!(*g as f32, *e as f32, "{file}: {name} = {body}, Rust {e}");
            }
            seen.push(name);
        }
    }
    for name in rust.iter().map(|(n, _)| *n).chain(GPU_ONLY.iter().copied()) {
        assert!(seen.iter().any(|s| s == name), "{name} is in no shader");
    }
}

/// The WGSL struct `name` of `source` with naga's layout: its size in bytes and its fields'
/// names in order.
fn wgsl_layout(source: &str, name: &str) -> (u32, Vec<String>) {
    let start = source
        .find(&format!("struct {name} {{"))
        .unwrap_or_else(|| panic!("no struct {name}"));
    let end = start + source[start..].find("\n}").unwrap() + 2;
    let module =
        naga::front::wgsl::parse_str(&source[start..end]).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, ty)| ty.name.as_deref() == Some(name))
        .unwrap();
    let naga::TypeInner::Struct { members, .. } = &ty.inner else {
        panic!("{name} is not a struct");
    };
    let fields = members.iter().filter_map(|m| m.name.clone()).collect();
    (layouter[handle].size, fields)
}

/// The field names of the Rust struct `name` in `source`, in order.
fn rust_fields(source: &str, name: &str) -> Vec<String> {
    let start = source
        .find(&format!("struct {name} {{"))
        .unwrap_or_else(|| panic!("no struct {name}"));
    let end = start + source[start..].find("\n}").unwrap();
    source[start..end]
        .lines()
        .skip(1)
        .map(str::trim)
        .filter(|line| !line.starts_with("//") && !line.starts_with('#'))
        .filter_map(|line| line.split_once(':'))
        .map(|(field, _)| {
            field
                .trim_start_matches("pub(crate) ")
                .trim_start_matches("pub ")
        })
        .map(str::to_owned)
        .collect()
}

/// Padding has no meaning, and another name on each side.
fn is_padding(field: &str) -> bool {
    field.starts_with('_') || field.starts_with("pad")
}

#[test]
fn every_uniform_layout_matches_its_rust_struct() {
    let layouts: [(&str, &str, &str, &str, u64); 9] = [
        (
            include_str!("march/parameters.wgsl"),
            "CloudUniforms",
            include_str!("view.rs"),
            "GpuCloudUniforms",
            GpuCloudUniforms::min_size().get(),
        ),
        (
            include_str!("march/parameters.wgsl"),
            "CloudLayerGpu",
            include_str!("view.rs"),
            "GpuCloudLayer",
            GpuCloudLayer::min_size().get(),
        ),
        (
            include_str!("noise/noise.wgsl"),
            "NoiseParams",
            include_str!("noise/mod.rs"),
            "GpuNoiseParams",
            GpuNoiseParams::min_size().get(),
        ),
        (
            include_str!("haze/haze.wgsl"),
            "HazeUniforms",
            include_str!("haze/mod.rs"),
            "GpuHazeUniforms",
            GpuHazeUniforms::min_size().get(),
        ),
        (
            include_str!("shadow/shadow.wgsl"),
            "ShadowUniforms",
            include_str!("shadow/mod.rs"),
            "GpuShadowUniforms",
            GpuShadowUniforms::min_size().get(),
        ),
        (
            include_str!("composite/temporal.wgsl"),
            "TemporalUniforms",
            include_str!("composite/mod.rs"),
            "GpuTemporalUniforms",
            GpuTemporalUniforms::min_size().get(),
        ),
        (
            include_str!("composite/composite.wgsl"),
            "ViewGround",
            include_str!("composite/mod.rs"),
            "GpuViewGround",
            GpuViewGround::min_size().get(),
        ),
        (
            include_str!("weather_map/weather_map.wgsl"),
            "WeatherMapUniforms",
            include_str!("weather_map/mod.rs"),
            "GpuWeatherMapUniforms",
            GpuWeatherMapUniforms::min_size().get(),
        ),
        (
            include_str!("growth/growth.wgsl"),
            "GrowthUniforms",
            include_str!("growth/mod.rs"),
            "GpuGrowthUniforms",
            GpuGrowthUniforms::min_size().get(),
        ),
    ];
    for (wgsl, wgsl_name, rust, rust_name, rust_size) in layouts {
        let (size, wgsl_fields) = wgsl_layout(wgsl, wgsl_name);
        // A uniform struct's size rounds up to 16 bytes under WGSL's uniform rules.
        assert_eq!(
            u64::from(size.next_multiple_of(16)),
            rust_size.next_multiple_of(16),
            "{wgsl_name} ({size} bytes) against {rust_name} ({rust_size} bytes)"
        );
        let named = |fields: Vec<String>| -> Vec<String> {
            fields.into_iter().filter(|f| !is_padding(f)).collect()
        };
        assert_eq!(
            named(wgsl_fields),
            named(rust_fields(rust, rust_name)),
            "{wgsl_name} against {rust_name}"
        );
    }
}
