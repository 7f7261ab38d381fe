//! Tileable cloud noise: the f64 CPU twin of `src/render/noise/noise.wgsl`.
//!
//! Every public function here has a WGSL function of the same name in the shader, and each
//! points at the other. The GPU compute pass is tested against this module, so a change to a
//! formula must be made in both places.
//!
//! # The noises
//!
//! - **Hash**: `pcg4d` of Jarzynski & Olano 2020 ("Hash Functions for GPU Rendering", JCGT 9(3))
//!   on `u32` with wrapping arithmetic: the lattice cell goes into `x, y, z` and the seed into
//!   `w`. Integer arithmetic gives the same bits on every GPU and on the CPU, unlike
//!   `fract(sin(x) * 43758.5453)`, whose result depends on each GPU's `sin` precision.
//! - **Perlin**: improved Perlin noise (Perlin 2002, "Improving Noise"): quintic fade and the
//!   12 cube-edge gradients, signed, roughly in `[-1, 1]`.
//! - **Worley**: cellular noise F1 (Worley 1996, "A Cellular Texture Basis Function") with one
//!   feature point per cell, searched over the 27 neighbouring cells and **inverted** to
//!   `1 - min(F1, 1)`, so cells are bright in the middle and dark at their edges: the "billowy"
//!   look of Pérez Martín 2022 ("Worley Noise", Figure 24.b).
//! - **fBm**: octave `k` has `frequency * 2^k` cells per texture period and amplitude
//!   `persistence^k`; the sum is divided by the sum of amplitudes (Pérez Martín 2022, Figure 28).
//! - **Perlin-Worley**: Perlin fBm dilated by Worley fBm through [`remap`] (Pérez Martín 2022, "Cloud
//!   textures"; Schneider 2015).
//! - **Curl**: the 2D curl of a Perlin fBm potential, for distorting the detail look-ups.
//!
//! # Tiling
//!
//! A noise with a period of `n` cells hashes the lattice cell *wrapped* into `[0, n)` with a true
//! modulo ([`wrap_cell`]), so `f(p + n·k) = f(p)` for every integer `k`, negative ones included
//! (Thomann 2021 §5.3: HLSL's and WGSL's `%` keep the dividend's sign and leave seams at negative
//! coordinates). The fBm functions take positions in *texture units*, where one texture period
//! is `1.0`; a frequency is a whole number of cells per period, so every octave tiles.
//!
//! # Textures and channels
//!
//! Texel `i` of a texture `size` texels wide samples the noise at its centre,
//! `p = (i + 0.5) / size`, in `[0, 1)` ([`texel_centre`]). Storage is x fastest, then y, then z.
//!
//! | texture | R | G | B | A |
//! |---|---|---|---|---|
//! | base (3D, 128³) | Perlin-Worley | Worley fBm | Worley fBm, higher | Worley fBm, highest |
//! | detail (3D, 32³) | Worley fBm | Worley fBm, higher | Worley fBm, highest | 1 (unused) |
//! | weather (2D, 256²) | coverage Perlin-Worley | Perlin fBm | curl x | curl y |
//!
//! The weather noise is a slice of the 3D noises at `z =` [`WEATHER_SLICE_Z`]; curl is stored
//! as `0.5 + 0.5 * clamp(curl / CURL_RANGE, -1, 1)`. All values lie in `[0, 1]`.
//!
//! The GPU stores the base and detail noise as `Rgba16Float`, each value rounded to a multiple of
//! `2^-11` ([`quantize_noise`]), and the weather noise as `Rgba8Unorm`, which stores
//! `round(v * 255)` ([`quantize_unorm8`]). Graphics APIs allow a conversion tolerance, so a value
//! within rounding of a half step may land either way. Mips are a 2×2×2 box average
//! ([`downsample_3d`]); the GPU averages the *quantized* level above, so compare a GPU mip with
//! `downsample_3d` of the GPU's own previous level, or allow the rounding of each level.
//!
//! # Precision against the f32 twin
//!
//! Texel centres `(i + 0.5) / size` are dyadic for power-of-two sizes and frequencies are whole
//! numbers, so the positions `p * frequency * 2^k` are exact in f32 as in f64. Lattice cells are
//! integers wrapped on integers, and a noise is evaluated from the fractional part within its
//! cell, never from large absolute coordinates; the f32 result then differs from f64 by about
//! `1e-6` (about `1e-5` for the curl, a difference quotient), far below the `1/255` step of the
//! weather texture and the `2^-11` step of a half float just under 1. On lavapipe the stored
//! values match [`quantize_unorm8`] and [`quantize_noise`] of this module exactly on almost every
//! texel and never differ by more than one step.

use bevy::reflect::Reflect;

/// Most fBm octaves evaluated; larger counts are clamped. Beyond about five octaves the
/// difference is negligible (Pérez Martín 2022, Figure 29) and `frequency * 2^k` would soon outrun the
/// texel grid.
pub const MAX_OCTAVES: u32 = 8;

/// Largest base frequency (cells per texture period) of an fBm; larger values are clamped, and
/// 0 counts as 1. Keeps `frequency * 2^(MAX_OCTAVES - 1)` far inside `i32` and f32's exact
/// integers.
pub const MAX_FREQUENCY: u32 = 4096;

/// The `z` coordinate, in texture units, of the slice through the 3D noises that makes the 2D
/// weather noise.
///
/// Irrational (the golden-ratio conjugate, `(√5 - 1) / 2`) so that no octave's slice lies on a
/// lattice plane, where Perlin noise is zero at every lattice point and would print the grid.
pub const WEATHER_SLICE_Z: f64 = 0.618_033_988_749_894_9;

/// Step of the central differences in [`curl_noise_2d`], in cells of the octave being
/// differentiated (1/256 cell).
///
/// Small enough that the truncation error of the difference is below `1e-3` of the derivative,
/// large enough that the difference of two f32 noise values keeps about five significant
/// digits. A power of two, so `p ± step` is exact in f32.
pub const CURL_STEP_CELLS: f64 = 1.0 / 256.0;

/// Gain applied to the Perlin fBm around 0.5 before it is dilated by Worley in
/// [`perlin_worley`]: `signed_to_unit(perlin, PERLIN_WORLEY_CONTRAST)`.
///
/// The Perlin fBm of the default recipe has a standard deviation of about 0.16, so a plain
/// `0.5 + 0.5 * perlin` stays near 0.5 and lifts every texel by half the gap to 1, leaving
/// Perlin-Worley a flat 0.73 ± 0.06. With a gain of 4 the Perlin saturates to 1 where it
/// exceeds 1.5 standard deviations, about 6 % of the volume (solid cloud cores: Pérez Martín 2022's "no
/// gaps in the denser parts"), and to 0 in as much again (pure Worley cells there), and
/// Perlin-Worley spreads to 0.74 ± 0.17: the classic look of Schneider 2015's Perlin-Worley.
pub const PERLIN_WORLEY_CONTRAST: f64 = 4.0;

/// Gain applied around 0.5 to the Perlin fBm of the weather texture's G channel:
/// `signed_to_unit(perlin, VARIATION_CONTRAST)`. A gain of 2 doubles the spread (standard
/// deviation about 0.16 instead of 0.08, so more of the 8-bit range is used) while clamping
/// under 1 % of texels.
pub const VARIATION_CONTRAST: f64 = 2.0;

/// Curl magnitude (in potential units per base-octave cell) that maps to the ends of the stored
/// `[0, 1]` range of the weather texture's B and A channels.
///
/// Measured over the default curl recipe (seeds 0-23, 128² texels each): the components have
/// a root-mean-square of 0.71 and never exceeded 2.66 in magnitude, so `±3` keeps the whole
/// distribution (rarer larger values are clamped) while one 8-bit step is 0.024, about 3 % of
/// the typical value.
pub const CURL_RANGE: f64 = 3.0;

/// Index of an fBm recipe in [`NoiseRecipe::fbm_slots`] and in the shader's `NoiseParams`.
///
/// The slot is also the channel number mixed into the seed by [`noise_seed`], so every channel
/// of every texture gets independent noise from one user seed.
pub type FbmSlot = u32;

/// Base texture R: the Perlin fBm of Perlin-Worley.
pub const SLOT_BASE_PERLIN: FbmSlot = 0;
/// Base texture R: the Worley fBm of Perlin-Worley.
pub const SLOT_BASE_WORLEY: FbmSlot = 1;
/// Base texture G: Worley fBm.
pub const SLOT_BASE_G: FbmSlot = 2;
/// Base texture B: Worley fBm.
pub const SLOT_BASE_B: FbmSlot = 3;
/// Base texture A: Worley fBm.
pub const SLOT_BASE_A: FbmSlot = 4;
/// Detail texture R: Worley fBm.
pub const SLOT_DETAIL_R: FbmSlot = 5;
/// Detail texture G: Worley fBm.
pub const SLOT_DETAIL_G: FbmSlot = 6;
/// Detail texture B: Worley fBm.
pub const SLOT_DETAIL_B: FbmSlot = 7;
/// Weather texture R: the Perlin fBm of the coverage Perlin-Worley.
pub const SLOT_WEATHER_PERLIN: FbmSlot = 8;
/// Weather texture R: the Worley fBm of the coverage Perlin-Worley.
pub const SLOT_WEATHER_WORLEY: FbmSlot = 9;
/// Weather texture G: Perlin fBm.
pub const SLOT_WEATHER_VARIATION: FbmSlot = 10;
/// Weather texture B and A: the Perlin fBm potential of the curl noise.
pub const SLOT_WEATHER_CURL: FbmSlot = 11;
/// Number of fBm slots.
pub const FBM_SLOT_COUNT: usize = 12;

/// One fBm: its base frequency, octave count and persistence.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct FbmRecipe {
    /// Cells per texture period of the first octave; a whole number so the texture tiles.
    /// Octave `k` has `frequency * 2^k`. Clamped to `1..=MAX_FREQUENCY`.
    pub frequency: u32,
    /// Number of octaves, clamped to `1..=MAX_OCTAVES`.
    pub octaves: u32,
    /// Amplitude ratio between successive octaves, clamped to `[0, 1]`; 0.5 halves the
    /// amplitude as the frequency doubles.
    pub persistence: f64,
}

impl FbmRecipe {
    /// An fBm of `octaves` octaves starting at `frequency` cells per period.
    pub const fn new(frequency: u32, octaves: u32, persistence: f64) -> Self {
        Self {
            frequency,
            octaves,
            persistence,
        }
    }
}

/// Recipe of the base-shape texture (Pérez Martín 2022, "Cloud textures", first texture).
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct BaseRecipe {
    /// Perlin fBm of the R channel (Perlin-Worley). Default: 4 cells, 4 octaves, 0.5.
    pub perlin: FbmRecipe,
    /// Worley fBm that dilates the Perlin fBm in the R channel. Default: 4 cells, 3 octaves,
    /// 0.5.
    pub worley: FbmRecipe,
    /// Worley fBm of the G, B and A channels at rising frequencies. Default: 4, 8 and 16 cells,
    /// 3 octaves each, 0.5; the finest octave (64 cells in 128 texels) keeps 2 texels per cell.
    pub channels: [FbmRecipe; 3],
}

impl Default for BaseRecipe {
    fn default() -> Self {
        Self {
            perlin: FbmRecipe::new(4, 4, 0.5),
            worley: FbmRecipe::new(4, 3, 0.5),
            channels: [
                FbmRecipe::new(4, 3, 0.5),
                FbmRecipe::new(8, 3, 0.5),
                FbmRecipe::new(16, 3, 0.5),
            ],
        }
    }
}

/// Recipe of the detail texture (Pérez Martín 2022, "Cloud textures", second texture). Its A channel is
/// always 1: Pérez Martín 2022 leaves it unused.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct DetailRecipe {
    /// Worley fBm of the R, G and B channels at rising frequencies. Default: 2, 4 and 8 cells
    /// with 3, 3 and 2 octaves, persistence 0.5, so that the finest octave (16 cells in 32
    /// texels) keeps 2 texels per cell.
    pub channels: [FbmRecipe; 3],
}

impl Default for DetailRecipe {
    fn default() -> Self {
        Self {
            channels: [
                FbmRecipe::new(2, 3, 0.5),
                FbmRecipe::new(4, 3, 0.5),
                FbmRecipe::new(8, 2, 0.5),
            ],
        }
    }
}

/// Recipe of the 2D weather noise, from which the weather-map pass builds per-layer coverage.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct WeatherNoiseRecipe {
    /// Perlin fBm of the R channel (coverage Perlin-Worley, as Pérez Martín 2022's first weather-map
    /// prototype). Default: 4 cells, 5 octaves, 0.5.
    pub coverage_perlin: FbmRecipe,
    /// Worley fBm that dilates the coverage Perlin fBm. Default: 8 cells, 3 octaves, 0.5.
    pub coverage_worley: FbmRecipe,
    /// Perlin fBm of the G channel, a second, independent field (cloud-type or density
    /// variation). Default: 8 cells, 4 octaves, 0.5.
    pub variation: FbmRecipe,
    /// Perlin fBm potential whose curl fills B and A. Default: 4 cells, 3 octaves, 0.5.
    pub curl: FbmRecipe,
}

impl Default for WeatherNoiseRecipe {
    fn default() -> Self {
        Self {
            coverage_perlin: FbmRecipe::new(4, 5, 0.5),
            coverage_worley: FbmRecipe::new(8, 3, 0.5),
            variation: FbmRecipe::new(8, 4, 0.5),
            curl: FbmRecipe::new(4, 3, 0.5),
        }
    }
}

/// Everything that determines the cloud-noise textures. Equal recipes give identical textures.
///
/// The default follows Pérez Martín 2022 ("Cloud textures"): a 128³ base texture (Perlin-Worley plus three
/// Worley fBm), a 32³ detail texture (three Worley fBm) and a 2D weather noise.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct NoiseRecipe {
    /// Seed of every noise; each channel mixes in its own slot ([`noise_seed`]). Default 0.
    pub seed: u32,
    /// Texels per side of the 3D base texture. Default 128.
    pub base_size: u32,
    /// Texels per side of the 3D detail texture. Default 32.
    pub detail_size: u32,
    /// Texels per side of the 2D weather noise texture. Default 256.
    pub weather_size: u32,
    /// Base-shape channels.
    pub base: BaseRecipe,
    /// Detail channels.
    pub detail: DetailRecipe,
    /// Weather-noise channels.
    pub weather: WeatherNoiseRecipe,
}

impl Default for NoiseRecipe {
    fn default() -> Self {
        Self {
            seed: 0,
            base_size: 128,
            detail_size: 32,
            weather_size: 256,
            base: BaseRecipe::default(),
            detail: DetailRecipe::default(),
            weather: WeatherNoiseRecipe::default(),
        }
    }
}

impl NoiseRecipe {
    /// The fBm recipes in slot order (`SLOT_*`), as the shader's `NoiseParams` holds them: slot
    /// `s` is lane `s % 4` of `frequencies_{s / 4}`, `octaves_{s / 4}` and `persistences_{s / 4}`.
    pub fn fbm_slots(&self) -> [FbmRecipe; FBM_SLOT_COUNT] {
        [
            self.base.perlin,
            self.base.worley,
            self.base.channels[0],
            self.base.channels[1],
            self.base.channels[2],
            self.detail.channels[0],
            self.detail.channels[1],
            self.detail.channels[2],
            self.weather.coverage_perlin,
            self.weather.coverage_worley,
            self.weather.variation,
            self.weather.curl,
        ]
    }
}

/// Hash `pcg4d` (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering", §2): an LCG step
/// on each lane, then two rounds of cross-lane multiply-adds around an xorshift.
///
/// All arithmetic wraps modulo 2³², exactly as WGSL `u32` does. WGSL twin: `pcg4d`.
pub fn pcg4d(v: [u32; 4]) -> [u32; 4] {
    let [mut x, mut y, mut z, mut w] =
        v.map(|a| a.wrapping_mul(1_664_525).wrapping_add(1_013_904_223));
    // Each lane takes in two others, using the lanes already updated (sequential, as published).
    x = x.wrapping_add(y.wrapping_mul(w));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    w = w.wrapping_add(y.wrapping_mul(z));
    x ^= x >> 16;
    y ^= y >> 16;
    z ^= z >> 16;
    w ^= w >> 16;
    x = x.wrapping_add(y.wrapping_mul(w));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    w = w.wrapping_add(y.wrapping_mul(z));
    [x, y, z, w]
}

/// Maps a hash to `[0, 1)` from its top 24 bits, which f32 represents exactly, so CPU and GPU
/// get the same number. WGSL twin: `hash_to_unit`.
pub fn hash_to_unit(hash: u32) -> f64 {
    f64::from(hash >> 8) * (1.0 / 16_777_216.0)
}

/// The seed of one channel (`slot`, see `SLOT_*`) derived from the user's seed.
///
/// Slots are spread by the golden-ratio constant `0x9E37_79B9`; fBm octave `k` then adds `k`, so
/// neither channels nor octaves share lattices. WGSL twin: `noise_seed`.
pub fn noise_seed(seed: u32, slot: FbmSlot) -> u32 {
    seed.wrapping_add(slot.wrapping_mul(0x9E37_79B9))
}

/// True modulo of a lattice cell index: `cell - period * floor(cell / period)`, in
/// `[0, period)` for negative cells too (Thomann 2021 §5.3: `%` keeps the sign of the dividend, so
/// `-5 % 3 = -2` where tiling needs 1). `period` must be at least 1. WGSL twin: `wrap_cell`.
pub fn wrap_cell(cell: i64, period: u32) -> u32 {
    let period = i64::from(period);
    let remainder = cell % period;
    // The remainder has the dividend's sign; shift negative ones into [0, period).
    let wrapped = if remainder < 0 {
        remainder + period
    } else {
        remainder
    };
    wrapped as u32
}

/// Hash of a wrapped lattice cell under `seed`. WGSL twin: `lattice_hash`.
pub fn lattice_hash(cell: [u32; 3], seed: u32) -> [u32; 4] {
    pcg4d([cell[0], cell[1], cell[2], seed])
}

/// Quintic fade `6t⁵ - 15t⁴ + 10t³` (Perlin 2002): zero first and second derivatives at the
/// cell faces, so the noise has no visible lattice creases. WGSL twin: `fade`.
pub fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The 12 cube-edge gradients of improved Perlin noise (Perlin 2002), padded to 16 with four
/// of them repeated so a 4-bit hash picks one without a modulo (the padding Perlin 2002 uses).
/// WGSL twin: `PERLIN_GRADIENTS`.
pub(crate) const PERLIN_GRADIENTS: [[f64; 3]; 16] = [
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [1.0, -1.0, 0.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, 1.0, 1.0],
    [0.0, -1.0, 1.0],
    [0.0, 1.0, -1.0],
    [0.0, -1.0, -1.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [0.0, -1.0, 1.0],
    [0.0, -1.0, -1.0],
];

/// Perlin gradient of a lattice corner chosen by the top 4 bits of its hash. WGSL twin:
/// `perlin_gradient`.
pub fn perlin_gradient(hash: u32) -> [f64; 3] {
    PERLIN_GRADIENTS[(hash >> 28) as usize]
}

/// Splits a position in cells into its lattice cell and the offset within it, in `[0, 1)`.
/// Inlined as `floor` and `p - floor(p)` in the WGSL twins.
fn split_cell(p: [f64; 3]) -> ([i64; 3], [f64; 3]) {
    let cell = p.map(f64::floor);
    (
        cell.map(|c| c as i64),
        [p[0] - cell[0], p[1] - cell[1], p[2] - cell[2]],
    )
}

/// Linear interpolation `a + (b - a) t`. WGSL twin: `lerp` (not `mix`, which rounds differently).
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Dot of one corner's gradient with the vector from that corner to `p`: `corner` is 0 or 1 per
/// axis, `lo`/`hi` the wrapped lattice indices of the cell's two faces, `f` the offset of `p`
/// in its cell. WGSL twin: `perlin_corner`.
fn perlin_corner(lo: [u32; 3], hi: [u32; 3], f: [f64; 3], corner: [u32; 3], seed: u32) -> f64 {
    let index: [u32; 3] = std::array::from_fn(|a| if corner[a] == 1 { hi[a] } else { lo[a] });
    let g = perlin_gradient(lattice_hash(index, seed)[0]);
    let d: [f64; 3] = std::array::from_fn(|a| f[a] - f64::from(corner[a]));
    g[0] * d[0] + g[1] * d[1] + g[2] * d[2]
}

/// Periodic improved Perlin noise (Perlin 2002) at `p`, in cells, repeating every `period`
/// cells on each axis; signed, about `[-1, 1]` (values outside are clamped by the channel
/// recipes). WGSL twin: `perlin_noise_3d`.
pub fn perlin_noise_3d(p: [f64; 3], period: u32, seed: u32) -> f64 {
    let (cell, f) = split_cell(p);
    // Corner 0 and corner 1 of each axis, wrapped so the lattice repeats (Thomann 2021 §5.3).
    let lo = cell.map(|c| wrap_cell(c, period));
    let hi = cell.map(|c| wrap_cell(c + 1, period));
    let u = f.map(fade);
    let corner = |c: [u32; 3]| perlin_corner(lo, hi, f, c, seed);
    let x00 = lerp(corner([0, 0, 0]), corner([1, 0, 0]), u[0]);
    let x10 = lerp(corner([0, 1, 0]), corner([1, 1, 0]), u[0]);
    let x01 = lerp(corner([0, 0, 1]), corner([1, 0, 1]), u[0]);
    let x11 = lerp(corner([0, 1, 1]), corner([1, 1, 1]), u[0]);
    lerp(lerp(x00, x10, u[1]), lerp(x01, x11, u[1]), u[2])
}

/// Periodic inverted Worley noise `1 - min(F1, 1)` (Worley 1996) at `p`, in cells, repeating
/// every `period` cells; in `[0, 1]`, 1 at a feature point.
///
/// One feature point per cell, placed by the cell's hash. Searching the 27 cells around `p` is
/// exact for the clamped F1: a point two or more cells away along any axis is at least one cell
/// from `p`, so it could only matter where F1 ≥ 1, which the clamp maps to 0 anyway. The
/// inversion makes bright, round cells with dark edges, the "billowy" shapes of Pérez Martín 2022
/// (Figure 24.b). WGSL twin: `worley_noise_3d`.
pub fn worley_noise_3d(p: [f64; 3], period: u32, seed: u32) -> f64 {
    let (cell, f) = split_cell(p);
    // Squared distance, starting at the clamp: F1 is never taken above one cell.
    let mut nearest_squared: f64 = 1.0;
    for dz in -1..=1_i64 {
        for dy in -1..=1_i64 {
            for dx in -1..=1_i64 {
                let index = [
                    wrap_cell(cell[0] + dx, period),
                    wrap_cell(cell[1] + dy, period),
                    wrap_cell(cell[2] + dz, period),
                ];
                let h = lattice_hash(index, seed);
                // Feature point relative to p's cell origin, minus p's offset in that cell:
                // small numbers, no cancellation in f32.
                let d = [
                    dx as f64 + hash_to_unit(h[0]) - f[0],
                    dy as f64 + hash_to_unit(h[1]) - f[1],
                    dz as f64 + hash_to_unit(h[2]) - f[2],
                ];
                nearest_squared = nearest_squared.min(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            }
        }
    }
    1.0 - nearest_squared.sqrt()
}

/// Which noise an fBm sums. WGSL twin: the `OCTAVE_*` constants.
#[derive(Clone, Copy)]
enum Octave {
    Perlin,
    Worley,
}

/// The fBm sum (Pérez Martín 2022, Figure 28) shared by [`perlin_fbm_3d`] and [`worley_fbm_3d`].
/// WGSL twin: `fbm_3d`.
fn fbm_3d(p: [f64; 3], fbm: &FbmRecipe, seed: u32, octave: Octave) -> f64 {
    let octaves = fbm.octaves.clamp(1, MAX_OCTAVES);
    let persistence = fbm.persistence.clamp(0.0, 1.0);
    let mut period = fbm.frequency.clamp(1, MAX_FREQUENCY);
    let mut sum = 0.0;
    let mut amplitude = 1.0;
    let mut total_amplitude = 0.0;
    for k in 0..octaves {
        // A whole number of cells per texture period, so the octave tiles with the texture.
        let q = p.map(|c| c * f64::from(period));
        let octave_seed = seed.wrapping_add(k);
        let value = match octave {
            Octave::Perlin => perlin_noise_3d(q, period, octave_seed),
            Octave::Worley => worley_noise_3d(q, period, octave_seed),
        };
        sum += amplitude * value;
        total_amplitude += amplitude;
        amplitude *= persistence;
        period *= 2;
    }
    sum / total_amplitude
}

/// Perlin fBm at `p` in texture units (period 1 on each axis); signed, about `[-1, 1]`.
/// WGSL twin: `perlin_fbm_3d`.
pub fn perlin_fbm_3d(p: [f64; 3], fbm: &FbmRecipe, seed: u32) -> f64 {
    fbm_3d(p, fbm, seed, Octave::Perlin)
}

/// Inverted-Worley fBm at `p` in texture units (period 1 on each axis); in `[0, 1]`.
/// WGSL twin: `worley_fbm_3d`.
pub fn worley_fbm_3d(p: [f64; 3], fbm: &FbmRecipe, seed: u32) -> f64 {
    fbm_3d(p, fbm, seed, Octave::Worley)
}

/// Linear remap of `value` from `[old_min, old_max]` to `[new_min, new_max]` (Pérez Martín 2022,
/// Figure 30). WGSL twin: `remap`.
pub fn remap(value: f64, old_min: f64, old_max: f64, new_min: f64, new_max: f64) -> f64 {
    new_min + (value - old_min) / (old_max - old_min) * (new_max - new_min)
}

/// Maps a signed noise in about `[-1, 1]` to `[0, 1]` as `clamp(0.5 + 0.5 * contrast * value, 0,
/// 1)`: a `contrast` of 1 maps `[-1, 1]` onto `[0, 1]`, larger ones stretch the narrow
/// distribution of an fBm and saturate its tails. WGSL twin: `signed_to_unit`.
pub fn signed_to_unit(value: f64, contrast: f64) -> f64 {
    (0.5 + 0.5 * contrast * value).clamp(0.0, 1.0)
}

/// Perlin-Worley noise at `p` in texture units; in `[0, 1]`.
///
/// The Perlin fBm, mapped to `[0, 1]` with gain [`PERLIN_WORLEY_CONTRAST`], is remapped into
/// `[worley, 1]`: `remap(perlin, 0, 1, worley, 1) = worley + perlin * (1 - worley)`. The Worley cells dilate
/// the Perlin blobs, so dense Perlin regions stay solid while their edges take the billowy
/// Worley shapes (Pérez Martín 2022, "Cloud textures", R channel, after Schneider 2015). WGSL twin:
/// `perlin_worley`.
pub fn perlin_worley(
    p: [f64; 3],
    perlin: &FbmRecipe,
    worley: &FbmRecipe,
    perlin_seed: u32,
    worley_seed: u32,
) -> f64 {
    let perlin = signed_to_unit(
        perlin_fbm_3d(p, perlin, perlin_seed),
        PERLIN_WORLEY_CONTRAST,
    );
    let worley = worley_fbm_3d(p, worley, worley_seed);
    remap(perlin, 0.0, 1.0, worley, 1.0).clamp(0.0, 1.0)
}

/// 2D curl `(∂ψ/∂y, -∂ψ/∂x)` of the Perlin fBm potential `ψ` on the weather slice
/// (`z =` [`WEATHER_SLICE_Z`]), at `p` in texture units (period 1); a divergence-free flow field.
///
/// Derivatives are central differences, step [`CURL_STEP_CELLS`], taken per octave in that
/// octave's cells (so the step scales with the detail and the f32 difference stays accurate),
/// then scaled by `2^k` to base-octave cells and summed with the fBm weights. The result is in
/// potential units per base-octave cell; [`CURL_RANGE`] bounds it in practice. WGSL twin:
/// `curl_noise_2d`.
pub fn curl_noise_2d(p: [f64; 2], fbm: &FbmRecipe, seed: u32) -> [f64; 2] {
    let octaves = fbm.octaves.clamp(1, MAX_OCTAVES);
    let persistence = fbm.persistence.clamp(0.0, 1.0);
    let mut period = fbm.frequency.clamp(1, MAX_FREQUENCY);
    let h = CURL_STEP_CELLS;
    let mut gradient = [0.0, 0.0];
    let mut amplitude = 1.0;
    let mut total_amplitude = 0.0;
    // 2^k: the chain-rule factor from octave-k cells to base-octave cells.
    let mut cell_ratio = 1.0;
    for k in 0..octaves {
        let cells = f64::from(period);
        let q = [p[0] * cells, p[1] * cells, WEATHER_SLICE_Z * cells];
        let octave_seed = seed.wrapping_add(k);
        let psi =
            |dx: f64, dy: f64| perlin_noise_3d([q[0] + dx, q[1] + dy, q[2]], period, octave_seed);
        let d_dx = (psi(h, 0.0) - psi(-h, 0.0)) / (2.0 * h);
        let d_dy = (psi(0.0, h) - psi(0.0, -h)) / (2.0 * h);
        gradient[0] += amplitude * cell_ratio * d_dx;
        gradient[1] += amplitude * cell_ratio * d_dy;
        total_amplitude += amplitude;
        amplitude *= persistence;
        cell_ratio *= 2.0;
        period *= 2;
    }
    [
        gradient[1] / total_amplitude,
        -gradient[0] / total_amplitude,
    ]
}

/// Centre of texel `index` of a texture `size` texels wide, in texture units: `(index + 0.5) /
/// size`, in `[0, 1)`. WGSL twin: `texel_centre`.
pub fn texel_centre(index: u32, size: u32) -> f64 {
    (f64::from(index) + 0.5) / f64::from(size)
}

/// The four channels of base-texture texel `texel = [x, y, z]` of a `size`³ texture (R
/// Perlin-Worley, G/B/A Worley fBm); in `[0, 1]`. WGSL twin: `base_texel`.
pub fn base_texel(recipe: &NoiseRecipe, size: u32, texel: [u32; 3]) -> [f64; 4] {
    let p = texel.map(|i| texel_centre(i, size));
    let seed = |slot| noise_seed(recipe.seed, slot);
    let base = &recipe.base;
    [
        perlin_worley(
            p,
            &base.perlin,
            &base.worley,
            seed(SLOT_BASE_PERLIN),
            seed(SLOT_BASE_WORLEY),
        ),
        worley_fbm_3d(p, &base.channels[0], seed(SLOT_BASE_G)),
        worley_fbm_3d(p, &base.channels[1], seed(SLOT_BASE_B)),
        worley_fbm_3d(p, &base.channels[2], seed(SLOT_BASE_A)),
    ]
}

/// The four channels of detail-texture texel `texel = [x, y, z]` of a `size`³ texture (R/G/B
/// Worley fBm, A = 1); in `[0, 1]`. WGSL twin: `detail_texel`.
pub fn detail_texel(recipe: &NoiseRecipe, size: u32, texel: [u32; 3]) -> [f64; 4] {
    let p = texel.map(|i| texel_centre(i, size));
    let seed = |slot| noise_seed(recipe.seed, slot);
    let detail = &recipe.detail;
    [
        worley_fbm_3d(p, &detail.channels[0], seed(SLOT_DETAIL_R)),
        worley_fbm_3d(p, &detail.channels[1], seed(SLOT_DETAIL_G)),
        worley_fbm_3d(p, &detail.channels[2], seed(SLOT_DETAIL_B)),
        1.0,
    ]
}

/// Encodes a curl component into `[0, 1]`: `0.5 + 0.5 * clamp(c / CURL_RANGE, -1, 1)`.
/// WGSL twin: `encode_curl`.
pub fn encode_curl(component: f64) -> f64 {
    0.5 + 0.5 * (component / CURL_RANGE).clamp(-1.0, 1.0)
}

/// The four channels of weather-noise texel `texel = [x, y]` of a `size`² texture (R coverage
/// Perlin-Worley, G Perlin fBm, B/A encoded curl x/y); in `[0, 1]`. WGSL twin: `weather_texel`.
pub fn weather_texel(recipe: &NoiseRecipe, size: u32, texel: [u32; 2]) -> [f64; 4] {
    let uv = texel.map(|i| texel_centre(i, size));
    let p = [uv[0], uv[1], WEATHER_SLICE_Z];
    let seed = |slot| noise_seed(recipe.seed, slot);
    let weather = &recipe.weather;
    let curl = curl_noise_2d(uv, &weather.curl, seed(SLOT_WEATHER_CURL));
    [
        perlin_worley(
            p,
            &weather.coverage_perlin,
            &weather.coverage_worley,
            seed(SLOT_WEATHER_PERLIN),
            seed(SLOT_WEATHER_WORLEY),
        ),
        signed_to_unit(
            perlin_fbm_3d(p, &weather.variation, seed(SLOT_WEATHER_VARIATION)),
            VARIATION_CONTRAST,
        ),
        encode_curl(curl[0]),
        encode_curl(curl[1]),
    ]
}

/// Every texel of a `size`³ texture from `texel`, x fastest, then y, then z.
fn generate_3d(size: u32, texel: impl Fn([u32; 3]) -> [f64; 4]) -> Vec<[f64; 4]> {
    let mut texels = Vec::with_capacity((size as usize).pow(3));
    for z in 0..size {
        for y in 0..size {
            for x in 0..size {
                texels.push(texel([x, y, z]));
            }
        }
    }
    texels
}

/// Level 0 of the base texture, `size`³ texels, x fastest, then y, then z. GPU twin: the
/// `generate_base` entry point.
pub fn generate_base(recipe: &NoiseRecipe, size: u32) -> Vec<[f64; 4]> {
    generate_3d(size, |texel| base_texel(recipe, size, texel))
}

/// Level 0 of the detail texture, `size`³ texels, x fastest, then y, then z. GPU twin: the
/// `generate_detail` entry point.
pub fn generate_detail(recipe: &NoiseRecipe, size: u32) -> Vec<[f64; 4]> {
    generate_3d(size, |texel| detail_texel(recipe, size, texel))
}

/// The weather noise texture, `size`² texels, x fastest, then y. GPU twin: the
/// `generate_weather` entry point.
pub fn generate_weather(recipe: &NoiseRecipe, size: u32) -> Vec<[f64; 4]> {
    let mut texels = Vec::with_capacity((size as usize).pow(2));
    for y in 0..size {
        for x in 0..size {
            texels.push(weather_texel(recipe, size, [x, y]));
        }
    }
    texels
}

/// Side of the mip level below one of side `size`: half, rounded down, at least 1.
pub fn mip_size(size: u32) -> u32 {
    (size / 2).max(1)
}

/// Number of mip levels of a texture of side `size`, level 0 included, down to 1 texel:
/// `floor(log2(size)) + 1`.
pub fn mip_level_count(size: u32) -> u32 {
    size.max(1).ilog2() + 1
}

/// One 3D mip step: a 2×2×2 box average of `source` (`source_size`³ texels, x fastest),
/// giving [`mip_size`]`(source_size)`³ texels.
///
/// Source coordinates are clamped to the last texel, so an odd size averages its last texel
/// twice and a side of 1 stays 1. For power-of-two sizes the mean is preserved exactly. WGSL
/// twin: the `downsample_3d` entry point.
pub fn downsample_3d(source: &[[f64; 4]], source_size: u32) -> Vec<[f64; 4]> {
    let n = source_size as usize;
    assert_eq!(source.len(), n * n * n, "source is not {n}³ texels");
    let size = mip_size(source_size) as usize;
    let mut level = Vec::with_capacity(size * size * size);
    for z in 0..size {
        for y in 0..size {
            for x in 0..size {
                let mut sum = [0.0; 4];
                for (dx, dy, dz) in (0..8).map(|c| (c & 1, (c >> 1) & 1, c >> 2)) {
                    let sx = (2 * x + dx).min(n - 1);
                    let sy = (2 * y + dy).min(n - 1);
                    let sz = (2 * z + dz).min(n - 1);
                    let texel = source[sx + n * (sy + n * sz)];
                    for (s, t) in sum.iter_mut().zip(texel) {
                        *s += t;
                    }
                }
                level.push(sum.map(|s| s / 8.0));
            }
        }
    }
    level
}

/// The full mip chain of a 3D texture: `level0` (`size`³ texels) and every [`downsample_3d`]
/// of it down to 1³, [`mip_level_count`]`(size)` levels in all.
pub fn mip_chain_3d(level0: Vec<[f64; 4]>, size: u32) -> Vec<Vec<[f64; 4]>> {
    let mut chain = vec![level0];
    let mut level_size = size;
    for _ in 1..mip_level_count(size) {
        let next = downsample_3d(chain.last().expect("chain starts with level 0"), level_size);
        chain.push(next);
        level_size = mip_size(level_size);
    }
    chain
}

/// The byte an `Rgba8Unorm` texture stores for `value`: `round(clamp(value, 0, 1) * 255)`.
pub fn quantize_unorm8(value: f64) -> u8 {
    (value.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Steps per unit of the grid the base and detail noise are stored on: values are multiples of
/// `1 / NOISE_LEVELS` (`2^-11`), each exactly a half float.
pub const NOISE_LEVELS: f64 = 2048.0;

/// The value the GPU stores in the `Rgba16Float` base and detail noise for `value`:
/// `floor(clamp(value, 0, 1) · 2048 + 0.5) / 2048` ([`NOISE_LEVELS`]). The shader rounds to this
/// grid itself before it writes, because every multiple of `2^-11` in `[0, 1]` is a half float
/// and so is stored exactly, whatever rounding the GPU applies when it converts f32 to f16 (the
/// Vulkan specification allows round-to-nearest-even or round-toward-zero; lavapipe truncates,
/// which on its own leaves the texels half a step low on average). WGSL twin: `quantize_noise`.
pub fn quantize_noise(value: f64) -> f64 {
    let v = if value.is_nan() {
        0.0
    } else {
        value.clamp(0.0, 1.0)
    };
    (v * NOISE_LEVELS + 0.5).floor() / NOISE_LEVELS
}

#[cfg(test)]
mod tests;
