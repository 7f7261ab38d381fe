//! CPU twin of the cloud-growth automaton: the cellular automaton of Dobashi et al. 2000 ("A
//! simple, efficient method for realistic animation of clouds"), as Rosa 2013 ("Large-scale
//! cloudscapes using noise", §3.1–3.2) describes it, on a grid of cells that each hold three
//! bits: humid ([`HUM`]), activated ([`ACT`]) and cloud ([`CLD`]). The GPU pass
//! (`src/render/growth/growth.wgsl`) gives the same bits for the same seed and steps.
//!
//! One step, for every cell at once (Dobashi 2000 eqs. 1–4 with its three probabilities):
//!
//! - `hum' = (hum ∧ ¬act) ∨ (rnd < p_hum)`: activation uses the vapour up; humidity comes back
//!   at random.
//! - `act' = (¬act ∧ hum ∧ f_act) ∨ (rnd < p_act)`: a humid cell next to an activated one
//!   activates (clouds grow where clouds are), and some cells activate at random (new clouds).
//! - `cld' = (cld ∨ act) ∧ ¬(rnd < p_ext)`: an activated cell becomes cloud, and cloud
//!   vanishes at random (evaporation).
//!
//! `f_act` is the activation of the neighbours one cell away along each axis, two cells away
//! horizontally, and two cells below (`k` is up): clouds grow sideways and upward. Rosa 2013
//! prints one of the eleven offsets as `(0, −1, −1)`; the stencil here is the axis-aligned one
//! its prose describes. The grid wraps horizontally, so the field tiles like the weather noise;
//! vertically a neighbour outside the grid is not activated.
//!
//! The random numbers are an integer hash (PCG, Jarzynski & Olano 2020, "Hash Functions for GPU
//! Rendering") of the seed, the step, the cell and the bit, compared with probabilities given as
//! 24-bit thresholds ([`probability_threshold`]), so the GPU and the CPU agree bit for bit.

/// The humid bit of a cell.
pub const HUM: u32 = 1;
/// The activated bit of a cell.
pub const ACT: u32 = 2;
/// The cloud bit of a cell.
pub const CLD: u32 = 4;

/// The probabilities of one step as 24-bit thresholds: a random 24-bit number below the
/// threshold fires.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct GrowthThresholds {
    /// Humidity returns to a cell ([`probability_threshold`] of `p_hum`).
    pub humidity: u32,
    /// A cell activates at random: a new cloud forms (`p_act`).
    pub activation: u32,
    /// A cloud cell evaporates (`p_ext`).
    pub extinction: u32,
}

/// `p` (0–1, clamped; NaN is 0) as a 24-bit threshold: `round(p · 2²⁴)`.
#[must_use]
pub fn probability_threshold(p: f32) -> u32 {
    let p = if p.is_nan() { 0.0 } else { p.clamp(0.0, 1.0) };
    (f64::from(p) * f64::from(1u32 << 24)).round() as u32
}

/// PCG hash of one 32-bit word (Jarzynski & Olano 2020). WGSL: `pcg` in `growth.wgsl`.
#[must_use]
pub const fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The hash key of `bit` at `step` with `seed`, the same for every cell (the GPU gets it as a
/// uniform).
#[must_use]
pub const fn step_key(seed: u32, step: u32, bit: u32) -> u32 {
    pcg(pcg(seed ^ bit.wrapping_mul(0x9E37_79B9)).wrapping_add(step))
}

/// The 24-bit random number of `cell` for `bit` at `step` with `seed`. WGSL: `cell_random`.
#[must_use]
pub const fn cell_random(seed: u32, step: u32, cell: u32, bit: u32) -> u32 {
    pcg(step_key(seed, step, bit).wrapping_add(cell)) >> 8
}

/// The neighbours whose activation spreads to a cell: `(di, dj, dk)`, `k` up.
pub const NEIGHBOURS: [[i32; 3]; 11] = [
    [1, 0, 0],
    [-1, 0, 0],
    [0, 1, 0],
    [0, -1, 0],
    [0, 0, 1],
    [0, 0, -1],
    [2, 0, 0],
    [-2, 0, 0],
    [0, 2, 0],
    [0, -2, 0],
    [0, 0, -2],
];

/// Columns on each side of a column whose cloud [`GrowthGrid::smoothed_cover`] averages.
/// WGSL: `COVER_RADIUS` in `growth.wgsl`.
pub const COVER_RADIUS: u32 = 2;

/// A grid of cells, `size[0] × size[1]` columns of `size[2]` cells, stored x fastest, then y,
/// then z (index `x + size[0]·(y + size[1]·z)`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GrowthGrid {
    /// Cells along x, y (horizontal) and z (up).
    pub size: [u32; 3],
    /// The bits of each cell ([`HUM`], [`ACT`], [`CLD`]).
    pub cells: Vec<u32>,
}

impl GrowthGrid {
    /// An empty grid (every bit 0).
    #[must_use]
    pub fn new(size: [u32; 3]) -> Self {
        let count = size.iter().map(|&s| s as usize).product();
        Self {
            size,
            cells: vec![0; count],
        }
    }

    /// Index of cell `(x, y, z)`.
    #[must_use]
    pub const fn index(&self, x: u32, y: u32, z: u32) -> usize {
        (x + self.size[0] * (y + self.size[1] * z)) as usize
    }

    /// Whether the cell at `(x, y, z)` offset by `d` is activated: wrapping horizontally, false
    /// outside the grid vertically.
    fn activated(&self, x: u32, y: u32, z: u32, d: [i32; 3]) -> bool {
        let wrap = |v: u32, d: i32, n: u32| (v as i32 + d).rem_euclid(n as i32) as u32;
        let zz = z as i32 + d[2];
        if zz < 0 || zz >= self.size[2] as i32 {
            return false;
        }
        let cell = self.cells[self.index(
            wrap(x, d[0], self.size[0]),
            wrap(y, d[1], self.size[1]),
            zz as u32,
        )];
        cell & ACT != 0
    }

    /// One step of the automaton (the [module docs](self)): `columns` holds each column's
    /// humidity and activation thresholds (`size[0] · size[1]` entries, x fastest, or one entry
    /// for every column), `extinction` the evaporation threshold, `step` the step's number.
    pub fn step(&mut self, columns: &[[u32; 2]], extinction: u32, seed: u32, step: u32) {
        let [nx, ny, nz] = self.size;
        let mut next = vec![0; self.cells.len()];
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let i = self.index(x, y, z);
                    let column = if columns.len() == 1 {
                        columns[0]
                    } else {
                        columns[(x + nx * y) as usize]
                    };
                    let thresholds = GrowthThresholds {
                        humidity: column[0],
                        activation: column[1],
                        extinction,
                    };
                    let f_act = NEIGHBOURS.iter().any(|&d| self.activated(x, y, z, d));
                    next[i] = next_cell(self.cells[i], f_act, thresholds, seed, step, i as u32);
                }
            }
        }
        self.cells = next;
    }

    /// The cloud the weather reads, per column, x fastest: the fraction of cloud cells among
    /// the `(2 COVER_RADIUS + 1)²` columns around it (wrapping), so the automaton's cell-sized
    /// speckle becomes a cloud with soft edges (Dobashi et al. 2000 smooth their binary field
    /// the same way). The sum is counted in integers and divided once, so the GPU
    /// (`column_cover` in `growth.wgsl`) gives the same bits.
    #[must_use]
    pub fn smoothed_cover(&self) -> Vec<f32> {
        let [nx, ny, nz] = self.size;
        let counts = self.column_counts();
        let r = COVER_RADIUS as i64;
        let cells = ((2 * r + 1) * (2 * r + 1)) as u32 * nz;
        let wrap = |v: u32, d: i64, n: u32| (i64::from(v) + d).rem_euclid(i64::from(n)) as u32;
        let mut cover = Vec::with_capacity((nx * ny) as usize);
        for y in 0..ny {
            for x in 0..nx {
                let mut sum = 0u32;
                for dy in -r..=r {
                    for dx in -r..=r {
                        sum += counts[(wrap(x, dx, nx) + nx * wrap(y, dy, ny)) as usize];
                    }
                }
                cover.push(sum as f32 / cells as f32);
            }
        }
        cover
    }

    /// The number of cloud cells in each column, x fastest.
    #[must_use]
    pub fn column_counts(&self) -> Vec<u32> {
        let [nx, ny, nz] = self.size;
        let mut counts = vec![0; (nx * ny) as usize];
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    if self.cells[self.index(x, y, z)] & CLD != 0 {
                        counts[(x + nx * y) as usize] += 1;
                    }
                }
            }
        }
        counts
    }

    /// The fraction of each column's cells that are cloud, x fastest.
    #[must_use]
    pub fn column_cover(&self) -> Vec<f32> {
        let cells = self.size[2] as f32;
        self.column_counts()
            .into_iter()
            .map(|count| count as f32 / cells)
            .collect()
    }
}

/// The bits of a cell after one step, from its bits, its neighbours' activation and the
/// thresholds. WGSL: `next_cell`.
#[must_use]
pub fn next_cell(
    cell: u32,
    f_act: bool,
    thresholds: GrowthThresholds,
    seed: u32,
    step: u32,
    index: u32,
) -> u32 {
    let hum = cell & HUM != 0;
    let act = cell & ACT != 0;
    let cld = cell & CLD != 0;
    let fires = |bit: u32, threshold: u32| cell_random(seed, step, index, bit) < threshold;
    let hum_next = (hum && !act) || fires(HUM, thresholds.humidity);
    let act_next = (!act && hum && f_act) || fires(ACT, thresholds.activation);
    let cld_next = (cld || act) && !fires(CLD, thresholds.extinction);
    let bit = |set: bool, bit: u32| if set { bit } else { 0 };
    bit(hum_next, HUM) | bit(act_next, ACT) | bit(cld_next, CLD)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hash_is_pcg_and_the_thresholds_are_24_bit() {
        // Known answers of the published algorithm (Jarzynski & Olano 2020's `pcg`).
        assert_eq!(pcg(0), 129_708_002);
        assert_eq!(pcg(1), 2_831_084_092);
        assert_eq!(pcg(12_345), 4_099_845_390);
        assert_eq!(probability_threshold(0.0), 0);
        assert_eq!(probability_threshold(1.0), 1 << 24);
        assert_eq!(probability_threshold(f32::NAN), 0);
        // Every random number is below 2²⁴, so p = 1 always fires and p = 0 never does.
        for i in 0..1000 {
            assert!(cell_random(7, 3, i, CLD) < 1 << 24);
        }
        // The random numbers are uniform: about p of them fire.
        let fired = (0..100_000)
            .filter(|&i| cell_random(1, 0, i, ACT) < probability_threshold(0.3))
            .count();
        assert!((29_000..31_000).contains(&fired), "{fired}");
    }

    #[test]
    fn clouds_form_grow_and_vanish_by_the_rules() {
        let mut grid = GrowthGrid::new([32, 32, 8]);
        // Only humidity everywhere: nothing activates without a seed.
        let humid = [[probability_threshold(1.0), 0]];
        grid.step(&humid, 0, 1, 0);
        assert!(grid.cells.iter().all(|&c| c == HUM));
        grid.step(&humid, 0, 1, 1);
        assert_eq!(grid.column_cover().iter().sum::<f32>(), 0.0);
        // One activated cell spreads through humid neighbours, and what activated is cloud.
        let centre = grid.index(16, 16, 2);
        grid.cells[centre] |= ACT;
        let dry = [[0, 0]];
        grid.step(&dry, 0, 1, 2);
        assert_eq!(
            grid.cells[centre] & CLD,
            CLD,
            "an activated cell turns to cloud"
        );
        // A cell activates when its neighbour at `d` is activated, so the seed spreads to the
        // cells at `−d` from it: sideways, one below, and one and two above.
        for d in NEIGHBOURS {
            let i = grid.index((16 - d[0]) as u32, (16 - d[1]) as u32, (2 - d[2]) as u32);
            assert_eq!(grid.cells[i] & ACT, ACT, "{d:?} activated");
        }
        assert_eq!(grid.cells[grid.index(16, 16, 0)] & ACT, 0, "not two below");
        // Activation used the humidity up.
        assert_eq!(grid.cells[centre] & (HUM | ACT), 0);
        // With extinction 1 every cloud vanishes in one step.
        grid.step(&dry, probability_threshold(1.0), 1, 3);
        assert!(grid.cells.iter().all(|&c| c & CLD == 0));
    }

    #[test]
    fn the_same_seed_gives_the_same_field_and_another_seed_another() {
        let columns = [[probability_threshold(0.2), probability_threshold(0.002)]];
        let run = |seed: u32| {
            let mut grid = GrowthGrid::new([24, 24, 6]);
            for step in 0..20 {
                grid.step(&columns, probability_threshold(0.05), seed, step);
            }
            grid
        };
        assert_eq!(run(5), run(5));
        assert_ne!(run(5), run(6));
        let cover: f32 = run(5).column_cover().iter().sum::<f32>() / (24.0 * 24.0);
        assert!(cover > 0.0 && cover < 1.0, "{cover}");
    }
}
