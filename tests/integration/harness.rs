//! The test side of the headless harness (`examples/common/headless.rs`, shared with the tool
//! examples): where images go, and checks of the harness itself.

pub use crate::common::headless::{Headless, f16_to_f32};

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
