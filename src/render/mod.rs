//! GPU passes, in the order a frame runs them.
//!
//! - [`noise`]: a compute pass that fills the tileable cloud-noise textures once, and again only
//!   when [`noise::CloudNoiseSettings`] change.

pub mod noise;
