//! The test side of the headless harness (`examples/common/headless.rs`, shared with the tool
//! examples): where images go, and checks of the harness itself.

pub use crate::common::headless::{Headless, f16_to_f32};

/// How far a GPU frame may be from its CPU twin: relative RMSE of luminance, and RMSE of the
/// transmittance (f32 against f64, and the GPU's texture filtering).
pub const TWIN_RELATIVE_RMSE: f64 = 0.03;
pub const TWIN_T_RMSE: f64 = 0.02;

/// A GPU frame (luminance, transmittance per pixel) against its CPU twin's: the relative RMSE
/// of luminance, the RMSE of the transmittance and the twin's mean transmittance.
pub fn twin_difference(
    (gpu_l, gpu_t): (&[[f32; 3]], &[f32]),
    (cpu_l, cpu_t): (&[[f32; 3]], &[f32]),
) -> (f64, f64, f64) {
    let t_rmse = (gpu_t
        .iter()
        .zip(cpu_t)
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum::<f64>()
        / cpu_t.len() as f64)
        .sqrt();
    let mean_t = cpu_t.iter().map(|t| f64::from(*t)).sum::<f64>() / cpu_t.len() as f64;
    (
        crate::common::scenes::relative_rmse(gpu_l, cpu_l),
        t_rmse,
        mean_t,
    )
}

/// Where tests write images for people to look at: `target/test-images/`.
pub fn output_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/test-images")
}

#[test]
fn f16_decoding_matches_known_values() {
    assert_eq!(f16_to_f32(0x3c00), 1.0);
    assert_eq!(f16_to_f32(0xc000), -2.0);
    assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
    assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
    assert!(f16_to_f32(0x7e00).is_nan());
}

#[test]
fn buffers_read_back_as_written() {
    use bevy::render::{
        render_resource::{BufferInitDescriptor, BufferUsages},
        renderer::RenderDevice,
    };
    let mut app = Headless::new(
        bevy::math::UVec2::splat(2),
        bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb,
        |_| {},
    );
    let data: Vec<u8> = (0..=255u8).cycle().take(1000).collect();
    let buffer = app
        .render_world()
        .resource::<RenderDevice>()
        .create_buffer_with_data(&BufferInitDescriptor {
            label: Some("readback test"),
            contents: &data,
            usage: BufferUsages::COPY_SRC,
        });
    assert_eq!(app.read_buffer(&buffer, 0, 1000), data);
    assert_eq!(app.read_buffer(&buffer, 256, 8), data[256..264]);
}

/// Smallest change of luminance between two neighbouring rows, as a ratio, that counts toward a
/// straight step: a quarter brighter or darker.
pub const STEP_RATIO: f64 = 1.25;

/// The rows `y` (1..height) where the image steps along a straight horizontal line: more than
/// half of the columns change from row `y − 1` to row `y` by more than [`STEP_RATIO`], all the
/// same way (brighter, or darker). No photograph of a sky shows one except at the horizon or
/// the edge of a layer seen edge-on; a fault in a renderer (a map's edge, a blend's end, a
/// shadow beyond its map) often draws one. `l` is linear RGB per pixel, rows from the top.
pub fn straight_horizontal_steps(l: &[[f32; 3]], size: bevy::math::UVec2) -> Vec<u32> {
    let (w, h) = (size.x as usize, size.y as usize);
    assert_eq!(l.len(), w * h, "an image of {w} x {h}");
    let luminance = |p: &[f32; 3]| {
        0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])
    };
    // Black (below the horizon of an empty scene) is as dark as the dimmest light a frame
    // shows: a step into it counts like any other.
    let floor = l.iter().map(luminance).fold(0.0, f64::max) * 1e-4 + 1e-12;
    let threshold = STEP_RATIO.ln();
    (1..h)
        .filter(|&y| {
            let (mut up, mut down) = (0, 0);
            for x in 0..w {
                let a = luminance(&l[(y - 1) * w + x]).max(floor);
                let b = luminance(&l[y * w + x]).max(floor);
                let change = (b / a).ln();
                if change > threshold {
                    up += 1;
                } else if change < -threshold {
                    down += 1;
                }
            }
            2 * up.max(down) > w
        })
        .map(|y| y as u32)
        .collect()
}

#[test]
fn straight_steps_are_found_and_nothing_else() {
    use bevy::math::UVec2;
    let size = UVec2::new(64, 32);
    let image = |f: &dyn Fn(usize, usize) -> f32| -> Vec<[f32; 3]> {
        (0..32 * 64)
            .map(|i| {
                let v = f(i % 64, i / 64);
                [v, v, v]
            })
            .collect()
    };
    // A smooth sky, brighter toward the horizon.
    let sky = |_x: usize, y: usize| 1.0 + 0.02 * y as f32;
    assert!(straight_horizontal_steps(&image(&sky), size).is_empty());
    // A band twice as bright from row 12 down: its top edge.
    let band = |x: usize, y: usize| sky(x, y) * if y >= 12 { 2.0 } else { 1.0 };
    assert_eq!(straight_horizontal_steps(&image(&band), size), vec![12]);
    // A band darker over two thirds of the width, from row 20: found.
    let wide = |x: usize, y: usize| sky(x, y) * if y >= 20 && x < 43 { 0.5 } else { 1.0 };
    assert_eq!(straight_horizontal_steps(&image(&wide), size), vec![20]);
    // Over less than half the width, a cloud's flat base: not a straight step.
    let base = |x: usize, y: usize| sky(x, y) * if y >= 20 && x < 30 { 0.5 } else { 1.0 };
    assert!(straight_horizontal_steps(&image(&base), size).is_empty());
    // Round clouds all over: edges in every row, none straight.
    let heaps = |x: usize, y: usize| {
        let (dx, dy) = ((x % 16) as f32 - 8.0, (y % 16) as f32 - 8.0);
        sky(x, y) * if dx * dx + dy * dy < 30.0 { 3.0 } else { 1.0 }
    };
    assert!(straight_horizontal_steps(&image(&heaps), size).is_empty());
    // The black below an empty scene's horizon counts.
    let horizon = |x: usize, y: usize| if y >= 25 { 0.0 } else { sky(x, y) };
    assert_eq!(straight_horizontal_steps(&image(&horizon), size), vec![25]);
}
