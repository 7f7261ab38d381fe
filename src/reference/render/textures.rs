//! The noise textures a march samples, in f64. WGSL twin: `src/render/march/textures.wgsl`
//! (their bindings, and `sample_base_noise` and `sample_detail_noise`, the twins of
//! [`NoiseTexture3d::sample`]).
//!
//! [`CloudTextures`] holds exactly the texels the GPU samples: the base and detail noise of
//! [`noise`] rounded to multiples of `2^-11` and stored as half floats (`Rgba16Float`,
//! [`quantize_noise`]), with mip levels box-filtered from the rounded level above
//! and rounded again, and the weather noise quantised to `Rgba8Unorm` bytes. Sampling is
//! trilinear with repeat addressing and linear mip interpolation, texel centres at
//! `(i + 0.5) / n`, as a `linear`/`linear`/`linear`, `repeat` sampler does. The only differences
//! from the GPU are then f32 against f64 and the GPU's filtering precision.
//!
//! That precision is why the 3D noise is stored as half floats. The coverage and erosion remaps
//! amplify small differences in the filtered noise (the coverage ramp about sevenfold, the
//! carving of heaps inside cloudy patches fourfold more), and lavapipe (llvmpipe, the software
//! Vulkan of the test machines) filters `Rgba8Unorm` in 8-bit fixed point and rounds the result to
//! 1/255 (measured: up to 1.5/255 from the exact trilinear value, 0.35/255 on average). Half
//! floats are filtered in float. The weather noise stays in bytes: the shader filters the local
//! coverage itself from four texel loads, exactly as [`weather_coverage`] does. Single rays can
//! still differ by a few per cent where a cheap sample flips between zero and non-zero, so
//! compare images, not single rays.

#[cfg(doc)]
use super::weather_coverage;
#[cfg(doc)]
use crate::reference::noise;
use crate::reference::noise::{
    NoiseRecipe, downsample_3d, generate_base, generate_detail, generate_weather, mip_level_count,
    mip_size, quantize_noise, quantize_unorm8,
};

/// A 3D `Rgba16Float` texture with its full mip chain, as the GPU holds the base and detail
/// noise: values on the grid of [`quantize_noise`].
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseTexture3d {
    /// Texels per side of level 0.
    pub size: u32,
    /// The mip levels, level 0 first, each `side³` texels, x fastest, then y, then z; level `n`
    /// has side [`mip_size`] applied `n` times. Every value is a multiple of `2^-11`
    /// ([`quantize_noise`]), held exactly as `f32`.
    pub levels: Vec<Vec<[f32; 4]>>,
}

impl NoiseTexture3d {
    /// Rounds `level0` (`size³` texels in `[0, 1]`) with [`quantize_noise`] and builds the mips
    /// as the GPU does: each level is [`downsample_3d`] of the *rounded* level above, rounded
    /// again.
    pub fn from_level0(level0: &[[f64; 4]], size: u32) -> Self {
        let quantise = |texels: &[[f64; 4]]| -> Vec<[f32; 4]> {
            texels
                .iter()
                .map(|t| t.map(|v| quantize_noise(v) as f32))
                .collect()
        };
        let mut levels = vec![quantise(level0)];
        let mut side = size;
        for _ in 1..mip_level_count(size) {
            let above: Vec<[f64; 4]> = levels
                .last()
                .expect("level 0 exists")
                .iter()
                .map(|t| t.map(f64::from))
                .collect();
            levels.push(quantise(&downsample_3d(&above, side)));
            side = mip_size(side);
        }
        Self { size, levels }
    }

    /// Side of mip `level`.
    pub fn level_size(&self, level: usize) -> u32 {
        (0..level).fold(self.size, |s, _| mip_size(s))
    }

    /// Trilinear sample of one level at `uvw` (texture units, period 1, repeat addressing).
    fn sample_level(&self, level: usize, uvw: [f64; 3]) -> [f64; 4] {
        let n = self.level_size(level);
        let texels = &self.levels[level];
        let axes = uvw.map(|c| filter_taps(c, n));
        let mut sum = [0.0; 4];
        for corner in 0..8_usize {
            let pick = |axis: usize| axes[axis][(corner >> axis) & 1];
            let (x, y, z) = (pick(0), pick(1), pick(2));
            let weight = x.1 * y.1 * z.1;
            let index = x.0 as usize + n as usize * (y.0 as usize + n as usize * z.0 as usize);
            let texel = texels[index];
            for (s, t) in sum.iter_mut().zip(texel) {
                *s += weight * f64::from(t);
            }
        }
        sum
    }

    /// Trilinear sample with linear interpolation between mip levels, like `textureSampleLevel`
    /// on a `linear`/`linear`/`linear`, `repeat` sampler: `lod` is clamped to the chain.
    pub fn sample(&self, uvw: [f64; 3], lod: f64) -> [f64; 4] {
        let last = (self.levels.len() - 1) as f64;
        let lod = if lod.is_nan() {
            0.0
        } else {
            lod.clamp(0.0, last)
        };
        let lower = lod.floor();
        let fraction = lod - lower;
        let a = self.sample_level(lower as usize, uvw);
        if fraction == 0.0 {
            return a;
        }
        let b = self.sample_level(lower as usize + 1, uvw);
        std::array::from_fn(|c| a[c] + (b[c] - a[c]) * fraction)
    }
}

/// A 2D `Rgba8Unorm` texture with one level, as the GPU holds the weather noise.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseTexture2d {
    /// Texels per side.
    pub size: u32,
    /// `size²` texels, x fastest.
    pub texels: Vec<[u8; 4]>,
}

impl NoiseTexture2d {
    /// Quantises `texels` (`size²` values in `[0, 1]`) to bytes.
    pub fn from_texels(texels: &[[f64; 4]], size: u32) -> Self {
        Self {
            size,
            texels: texels.iter().map(|t| t.map(quantize_unorm8)).collect(),
        }
    }

    /// Bilinear sample at `uv` (texture units, repeat addressing), level 0. The density model
    /// does not filter the noise itself: it filters the local coverage of each texel
    /// ([`weather_coverage`]).
    pub fn sample(&self, uv: [f64; 2]) -> [f64; 4] {
        let n = self.size;
        let axes = uv.map(|c| filter_taps(c, n));
        let mut sum = [0.0; 4];
        for corner in 0..4_usize {
            let x = axes[0][corner & 1];
            let y = axes[1][corner >> 1];
            let texel = self.texels[x.0 as usize + n as usize * y.0 as usize];
            for (s, t) in sum.iter_mut().zip(texel) {
                *s += x.1 * y.1 * unorm8(t);
            }
        }
        sum
    }
}

/// The value an `Rgba8Unorm` byte reads as.
pub(crate) fn unorm8(byte: u8) -> f64 {
    f64::from(byte) / 255.0
}

/// The two texels (wrapped index, weight) a linear filter reads along one axis for coordinate
/// `c` (texture units) on `n` texels: texel centres at `(i + 0.5) / n`, repeat addressing.
fn filter_taps(c: f64, n: u32) -> [(u32, f64); 2] {
    let x = c * f64::from(n) - 0.5;
    let floor = x.floor();
    let weight = x - floor;
    let n = i64::from(n);
    let i0 = (floor as i64).rem_euclid(n);
    let i1 = (i0 + 1).rem_euclid(n);
    [(i0 as u32, 1.0 - weight), (i1 as u32, weight)]
}

/// The noise textures a march samples, byte for byte what the GPU holds (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct CloudTextures {
    /// Base shape (R Perlin-Worley, G/B/A Worley fBm), with mips.
    pub base: NoiseTexture3d,
    /// Detail (R/G/B Worley fBm), with mips.
    pub detail: NoiseTexture3d,
    /// Weather noise (R coverage Perlin-Worley; G variation; B/A curl), one level.
    pub weather: NoiseTexture2d,
}

impl CloudTextures {
    /// Generates the textures of `recipe` at its sizes with [`noise`]. Costly at the
    /// default 128³ (seconds in a release build); tests use small sizes.
    pub fn from_recipe(recipe: &NoiseRecipe) -> Self {
        Self {
            base: NoiseTexture3d::from_level0(
                &generate_base(recipe, recipe.base_size),
                recipe.base_size,
            ),
            detail: NoiseTexture3d::from_level0(
                &generate_detail(recipe, recipe.detail_size),
                recipe.detail_size,
            ),
            weather: NoiseTexture2d::from_texels(
                &generate_weather(recipe, recipe.weather_size),
                recipe.weather_size,
            ),
        }
    }
}
