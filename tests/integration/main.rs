//! Integration tests: whole apps, GPU passes read back on whatever Vulkan driver the machine has
//! (lavapipe on CI), asset hot reload. One test binary with modules, because every binary links
//! Bevy.

mod clouds;
#[path = "../../examples/common/mod.rs"]
mod common;
mod growth;
mod harness;
#[cfg(feature = "live")]
mod live;
mod noise;
mod shadow;
mod sky;
mod weather;
