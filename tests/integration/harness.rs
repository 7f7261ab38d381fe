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
