//! Clouds that form, grow and dissolve: [`CloudGrowth`] on a layer runs the cellular automaton
//! of Dobashi et al. 2000 ([`crate::reference::growth`], on the GPU [`crate::render::growth`])
//! fed by two [`NoiseMaker`] fields, after Rosa 2013 ("Large-scale cloudscapes using noise",
//! §3–4): the humidity field says where clouds may grow, the activation field where they start.
//! With [`CloudGrowth::follow_coverage`] the probabilities follow the layer's coverage
//! ([`GrowthSteering::probabilities`]): while the coverage rises, formation outweighs
//! evaporation and new clouds appear and grow; while it falls, clouds evaporate.

use bevy::prelude::*;

use crate::reference::growth::{CLD, GrowthGrid, HUM, probability_threshold};
use crate::reference::noise::perlin_noise_3d;

/// One 2D field of the noise maker (Rosa 2013 §4.1), 0–1 per column of the automaton's grid.
///
/// Each column `(x, y)` reads gradient noise at `offset + (x, y) · increment`, mapped from −1–1
/// to 0–1; then the feather darkens the field toward the grid's edges and the cutoff stretches
/// the range. Rosa 2013 uses 2D simplex noise; this is the crate's tileable gradient noise
/// (Perlin 2002), so the field wraps with the grid: the increment is rounded so that a whole
/// number of noise cells spans the grid.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct NoiseMaker {
    /// Noise cells per grid cell along x and y (Rosa's `XInc`, `YInc`): larger gives more,
    /// smaller features. Default `[0.03, 0.03]` (about eight features across 256 cells).
    pub increment: [f32; 2],
    /// Where the field starts in the noise, noise cells (Rosa's `xMove`, `yMove`): moves the
    /// pattern. Default `[0, 0]`.
    pub offset: [f32; 2],
    /// Cells from each edge, along x and y, where the field is 0 (feather start). Default
    /// `[0, 0]`.
    pub feather_start: [u32; 2],
    /// Cells from each edge, along x and y, where the feather reaches the full field; at or
    /// below `feather_start` there is no feather. Default `[0, 0]`.
    pub feather_depth: [u32; 2],
    /// How quickly the feather fades into black, 0–1: the ramp from start to depth is
    /// `t^(1 + 3 · falloff)`, linear at 0. Default `[0, 0]`.
    pub feather_falloff: [f32; 2],
    /// Floor and ceiling, 0–1: values at or below the floor become 0, at or above the ceiling
    /// 1, linearly between. Default `[0, 1]` (no change).
    pub cutoff: [f32; 2],
    /// Seed of the noise. Default 0.
    pub seed: u32,
}

impl Default for NoiseMaker {
    fn default() -> Self {
        Self {
            increment: [0.03, 0.03],
            offset: [0.0, 0.0],
            feather_start: [0, 0],
            feather_depth: [0, 0],
            feather_falloff: [0.0, 0.0],
            cutoff: [0.0, 1.0],
            seed: 0,
        }
    }
}

impl NoiseMaker {
    /// The field on a `size[0] × size[1]` grid, x fastest, each value 0–1. Non-finite controls
    /// read as their defaults.
    #[must_use]
    pub fn field(&self, size: [u32; 2]) -> Vec<f32> {
        let defaults = Self::default();
        let finite = |v: f32, d: f32| if v.is_finite() { v } else { d };
        // A whole number of noise cells across the grid, so the field wraps with it.
        let period = |axis: usize| -> u32 {
            let inc = finite(self.increment[axis], defaults.increment[axis]).abs();
            ((inc * size[axis] as f32).round() as u32).max(1)
        };
        let periods = [period(0), period(1)];
        // One period on both axes of the 3D noise: the larger, with the other axis stretched.
        let period = periods[0].max(periods[1]);
        let scale = [0, 1].map(|a| f64::from(periods[a]) / f64::from(size[a].max(1)));
        let stretch = [0, 1].map(|a| f64::from(period) / f64::from(periods[a]));
        let offset = [0, 1].map(|a| f64::from(finite(self.offset[a], 0.0)));
        let (low, high) = (
            finite(self.cutoff[0], 0.0).clamp(0.0, 1.0),
            finite(self.cutoff[1], 1.0).clamp(0.0, 1.0),
        );
        let mut out = Vec::with_capacity((size[0] * size[1]) as usize);
        for y in 0..size[1] {
            for x in 0..size[0] {
                let p = [
                    (offset[0] + f64::from(x) * scale[0]) * stretch[0],
                    (offset[1] + f64::from(y) * scale[1]) * stretch[1],
                    0.5,
                ];
                let noise = perlin_noise_3d(p, period, self.seed);
                let mut v = ((noise as f32 + 1.0) * 0.5).clamp(0.0, 1.0);
                v *= self.feather(x, size[0], 0) * self.feather(y, size[1], 1);
                v = if high > low {
                    ((v - low) / (high - low)).clamp(0.0, 1.0)
                } else if v >= high {
                    1.0
                } else {
                    0.0
                };
                out.push(v);
            }
        }
        out
    }

    /// The feather's weight of cell `i` of `n` along `axis`: 0 within `feather_start` of an
    /// edge, rising to 1 at `feather_depth`.
    fn feather(&self, i: u32, n: u32, axis: usize) -> f32 {
        let (start, depth) = (self.feather_start[axis], self.feather_depth[axis]);
        if depth <= start {
            return 1.0;
        }
        let d = i.min(n.saturating_sub(1).saturating_sub(i));
        if d < start {
            return 0.0;
        }
        let t = ((d - start) as f32 / (depth - start) as f32).min(1.0);
        let falloff = self.feather_falloff[axis];
        let falloff = if falloff.is_finite() {
            falloff.clamp(0.0, 1.0)
        } else {
            0.0
        };
        t.powf(1.0 + 3.0 * falloff)
    }
}

/// Grows the clouds of the layer it sits on with the automaton, instead of the weather noise's
/// fixed pattern. Add it to a layer to turn growth on; a layer without it costs nothing extra.
///
/// The automaton runs on the GPU ([`crate::render::growth`]), one step per
/// [`steps_per_hour`](Self::steps_per_hour) of the [`SceneClock`](crate::scene::SceneClock)'s
/// time, each step after the cover of the last one has been read back (so at most one step
/// every frame or two). A run starts at the layer's coverage ([`CloudGrowth::initial_grid`]);
/// a new [`grid`](Self::grid) or [`seed`](Self::seed) starts it over, the other fields apply to
/// the next step. The grid spans one period of the layer's weather pattern
/// (`CloudLayer::weather_map_scale_m`): fewer columns give larger clouds. Without a renderer
/// the layer keeps its first grid.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct CloudGrowth {
    /// Cells along x and y (one period of the layer's weather pattern) and up through the
    /// layer. Default `[256, 256, 16]`.
    pub grid: [u32; 3],
    /// Where clouds may grow: scales the humidity probability per column. Default
    /// [`NoiseMaker::default`].
    pub humidity: NoiseMaker,
    /// Where clouds start: scales the activation probability per column. Default a
    /// [`NoiseMaker`] with seed 1.
    pub activation: NoiseMaker,
    /// Chance per step that humidity returns to a cell, 0–1 (Dobashi 2000's `p_hum`), times the
    /// humidity field. Default 0.1.
    pub humidity_probability: f32,
    /// Chance per step that a cell activates by itself: a new cloud (`p_act`), times the
    /// activation field. Default 0.001.
    pub activation_probability: f32,
    /// Chance per step that a cloud cell evaporates (`p_ext`). Default 0.01.
    pub extinction_probability: f32,
    /// Let the layer's coverage steer formation and evaporation
    /// ([`GrowthSteering::probabilities`]). Default true.
    pub follow_coverage: bool,
    /// Automaton steps per hour of scene time. Default 120.
    pub steps_per_hour: f32,
    /// Seed of the automaton's random numbers. Default 0.
    pub seed: u32,
}

impl Default for CloudGrowth {
    fn default() -> Self {
        Self {
            grid: [256, 256, 16],
            humidity: NoiseMaker::default(),
            activation: NoiseMaker {
                seed: 1,
                ..NoiseMaker::default()
            },
            humidity_probability: 0.1,
            activation_probability: 0.001,
            extinction_probability: 0.01,
            follow_coverage: true,
            steps_per_hour: 120.0,
            seed: 0,
        }
    }
}

impl CloudGrowth {
    /// The settings as the automaton runs them: the grid clamped to 8–1024 columns along x and
    /// y and 1–64 cells up, the probabilities to 0–1 and the steps per hour to 0–36 000 (10 a
    /// second); NaN becomes the default.
    #[must_use]
    pub fn sanitized(&self) -> Self {
        let default = Self::default();
        let clamp = |v: f32, low: f32, high: f32, fallback: f32| {
            if v.is_nan() {
                fallback
            } else {
                v.clamp(low, high)
            }
        };
        Self {
            grid: [
                self.grid[0].clamp(8, 1024),
                self.grid[1].clamp(8, 1024),
                self.grid[2].clamp(1, 64),
            ],
            humidity_probability: clamp(
                self.humidity_probability,
                0.0,
                1.0,
                default.humidity_probability,
            ),
            activation_probability: clamp(
                self.activation_probability,
                0.0,
                1.0,
                default.activation_probability,
            ),
            extinction_probability: clamp(
                self.extinction_probability,
                0.0,
                1.0,
                default.extinction_probability,
            ),
            steps_per_hour: clamp(self.steps_per_hour, 0.0, 36_000.0, default.steps_per_hour),
            ..self.clone()
        }
    }

    /// The grid a run starts from: the columns where the humidity field is highest full of humid
    /// cloud, as many as leave [`covered_fraction`] at `coverage` (0–1) or just under it, the
    /// rest clear; so a layer that starts growing shows about its coverage at once, where clouds
    /// would grow anyway.
    #[must_use]
    pub fn initial_grid(&self, coverage: f32) -> GrowthGrid {
        let size = self.grid;
        let humidity = self.humidity.field([size[0], size[1]]);
        let mut order: Vec<usize> = (0..humidity.len()).collect();
        order.sort_by(|&a, &b| humidity[b].total_cmp(&humidity[a]).then(a.cmp(&b)));
        let coverage = if coverage.is_nan() {
            0.0
        } else {
            coverage.clamp(0.0, 1.0)
        };
        let columns = humidity.len();
        let grid_of = |cloudy: usize| {
            let mut grid = GrowthGrid::new(size);
            for &column in &order[..cloudy] {
                for z in 0..size[2] as usize {
                    grid.cells[column + columns * z] = HUM | CLD;
                }
            }
            grid
        };
        // The covered fraction grows with the cloudy columns: the most that stay at or under
        // the coverage.
        let (mut low, mut high) = (0, columns);
        while low < high {
            let mid = (low + high).div_ceil(2);
            if covered_fraction(&grid_of(mid)) <= coverage {
                low = mid;
            } else {
                high = mid - 1;
            }
        }
        grid_of(low)
    }

    /// The per-column humidity and activation thresholds ([`GrowthGrid::step`]'s `columns`)
    /// for activation and humidity probabilities `p_act` and `p_hum`.
    #[must_use]
    pub fn columns(&self, p_hum: f32, p_act: f32) -> Vec<[u32; 2]> {
        let size = [self.grid[0], self.grid[1]];
        let humidity = self.humidity.field(size);
        let activation = self.activation.field(size);
        humidity
            .iter()
            .zip(&activation)
            .map(|(h, a)| {
                [
                    probability_threshold(p_hum * h),
                    probability_threshold(p_act * a),
                ]
            })
            .collect()
    }
}

/// The fraction of a grid's columns that hold visible cloud: the sky it covers, seen from
/// below ([`covered_share`] of its [`GrowthGrid::smoothed_cover`]).
#[must_use]
pub fn covered_fraction(grid: &GrowthGrid) -> f32 {
    covered_share(&grid.smoothed_cover())
}

/// The smoothed cover from which a column counts as covered: half of what makes a full cloudy
/// patch ([`GROWTH_FULL_COVER`](crate::reference::render::GROWTH_FULL_COVER)), where the
/// shape noise starts to leave cloud.
pub const COVERED_FROM: f32 = (0.5 * crate::reference::render::GROWTH_FULL_COVER) as f32;

/// The share of `cover` (a [`GrowthGrid::smoothed_cover`]) at or above [`COVERED_FROM`], 0–1.
#[must_use]
pub fn covered_share(cover: &[f32]) -> f32 {
    cover.iter().filter(|&&c| c >= COVERED_FROM).count() as f32 / cover.len().max(1) as f32
}

/// Steers formation and evaporation so that the covered fraction follows the layer's coverage:
/// a proportional-integral controller on the error `e = coverage − covered`. With `u = 2e + I`
/// (`I` the error summed over steps, times 0.02, within ±1) and the gain `g = 50^u` (`u` within
/// ±1.5), humidity returns `g` times as often, cells activate `g` times as often and clouds
/// evaporate `1/g` times as often: a sky short of its coverage forms and feeds new clouds, one
/// over it starves and evaporates them, and the sum takes out the offset a fixed gain would leave.
#[derive(Clone, Copy, Debug, Default, PartialEq, Reflect)]
pub struct GrowthSteering {
    integral: f32,
}

/// The probabilities of one automaton step, each 0–1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrowthProbabilities {
    /// Humidity returns to a cell.
    pub humidity: f32,
    /// A cell activates by itself.
    pub activation: f32,
    /// A cloud cell evaporates.
    pub extinction: f32,
}

impl GrowthSteering {
    /// This step's probabilities for `coverage` wanted and `covered` now, from the base
    /// probabilities of `growth`. NaN inputs count as no error.
    pub fn probabilities(
        &mut self,
        coverage: f32,
        covered: f32,
        growth: &CloudGrowth,
    ) -> GrowthProbabilities {
        let error = coverage - covered;
        let error = if error.is_finite() {
            error.clamp(-1.0, 1.0)
        } else {
            0.0
        };
        self.integral = (self.integral + 0.02 * error).clamp(-1.0, 1.0);
        let gain = 50f32.powf((2.0 * error + self.integral).clamp(-1.5, 1.5));
        let unit = |p: f32| {
            if p.is_finite() {
                p.clamp(0.0, 1.0)
            } else {
                0.0
            }
        };
        GrowthProbabilities {
            humidity: unit(growth.humidity_probability * gain),
            activation: unit(growth.activation_probability * gain),
            extinction: unit(growth.extinction_probability / gain),
        }
    }
}

/// The 4-connected regions of covered columns (`cover > 0`) of a `size[0] × size[1]` grid that
/// wraps: each region's columns, x fastest indices.
#[must_use]
pub fn covered_regions(cover: &[f32], size: [u32; 2]) -> Vec<Vec<usize>> {
    let (nx, ny) = (size[0] as usize, size[1] as usize);
    let mut seen = vec![false; cover.len()];
    let mut regions = Vec::new();
    for startat in 0..cover.len() {
        if seen[startat] || cover[startat] <= 0.0 {
            continue;
        }
        seen[startat] = true;
        let mut region = vec![startat];
        let mut next = 0;
        while next < region.len() {
            let i = region[next];
            next += 1;
            let (x, y) = (i % nx, i / nx);
            for (dx, dy) in [(1, 0), (nx - 1, 0), (0, 1), (0, ny - 1)] {
                let j = (x + dx) % nx + nx * ((y + dy) % ny);
                if !seen[j] && cover[j] > 0.0 {
                    seen[j] = true;
                    region.push(j);
                }
            }
        }
        regions.push(region);
    }
    regions
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_noise_maker_wraps_feathers_and_cuts() {
        let maker = NoiseMaker::default();
        let size = [64, 48];
        let field = maker.field(size);
        assert!(field.iter().all(|v| (0.0..=1.0).contains(v)));
        // Gradient noise is 0 on its lattice, so the first column (offset 0) reads one half; a
        // pattern is not a constant.
        assert_eq!(field[0], 0.5);
        assert!(field.iter().any(|&v| v != 0.5), "a pattern, not a constant");
        // It wraps: the last column continues into the first as smoothly as any neighbours.
        let at = |x: u32, y: u32| field[(x + size[0] * y) as usize];
        let step =
            |x0: u32, x1: u32| -> f32 { (0..size[1]).map(|y| (at(x0, y) - at(x1, y)).abs()).sum() };
        let seam = step(size[0] - 1, 0);
        let steepest = (0..size[0] - 1).map(|x| step(x, x + 1)).fold(0.0, f32::max);
        assert!(seam <= steepest, "seam {seam}, steepest inside {steepest}");
        // Feather: 0 within the start, full past the depth.
        let feathered = NoiseMaker {
            feather_start: [4, 4],
            feather_depth: [12, 12],
            ..maker.clone()
        }
        .field(size);
        for y in 0..size[1] {
            assert_eq!(feathered[(2 + size[0] * y) as usize], 0.0);
        }
        assert_eq!(feathered[(30 + size[0] * 20) as usize], at(30, 20));
        // Cutoff: a floor of 0.5 darkens everything below it to 0.
        let cut = NoiseMaker {
            cutoff: [0.5, 1.0],
            ..maker
        }
        .field(size);
        for (c, v) in cut.iter().zip(&field) {
            if *v <= 0.5 {
                assert_eq!(*c, 0.0);
            } else {
                assert!((*c - (v - 0.5) / 0.5).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn the_steering_forms_below_the_coverage_and_evaporates_above() {
        let growth = CloudGrowth::default();
        let short = GrowthSteering::default().probabilities(0.6, 0.2, &growth);
        assert!(short.activation > growth.activation_probability);
        assert!(short.humidity > growth.humidity_probability);
        assert!(short.extinction < growth.extinction_probability);
        let over = GrowthSteering::default().probabilities(0.2, 0.6, &growth);
        assert!(over.activation < growth.activation_probability);
        assert!(over.extinction > growth.extinction_probability);
        let even = GrowthSteering::default().probabilities(0.4, 0.4, &growth);
        assert_eq!(even.extinction, growth.extinction_probability);
        let nan = GrowthSteering::default().probabilities(f32::NAN, 0.4, &growth);
        assert_eq!(nan, even);
    }

    #[test]
    fn out_of_range_growth_settings_are_clamped_and_nan_is_the_default() {
        let default = CloudGrowth::default();
        let bad = CloudGrowth {
            grid: [0, 5000, 0],
            humidity_probability: f32::NAN,
            activation_probability: -1.0,
            extinction_probability: 7.0,
            steps_per_hour: f32::INFINITY,
            ..default.clone()
        };
        let fixed = bad.sanitized();
        assert_eq!(fixed.grid, [8, 1024, 1]);
        assert_eq!(fixed.humidity_probability, default.humidity_probability);
        assert_eq!(fixed.activation_probability, 0.0);
        assert_eq!(fixed.extinction_probability, 1.0);
        assert_eq!(fixed.steps_per_hour, 36_000.0);
        assert_eq!(default.sanitized(), default, "the defaults are in range");
        // A grid the sanitized settings start is as large as they say.
        assert_eq!(fixed.initial_grid(0.5).cells.len(), 8 * 1024);
    }

    #[test]
    fn a_run_starts_at_its_coverage() {
        let growth = CloudGrowth {
            grid: [48, 40, 4],
            ..CloudGrowth::default()
        };
        for coverage in [0.0, 0.2, 0.5, 0.9, 1.0] {
            let covered = covered_fraction(&growth.initial_grid(coverage));
            assert!(
                covered <= coverage && covered > coverage - 0.05, // the 5 points
                "{covered} for {coverage}"
            );
        }
        assert_eq!(covered_fraction(&growth.initial_grid(f32::NAN)), 0.0);
    }

    #[test]
    fn covered_regions_wrap_around_the_grid() {
        // Two covered columns at opposite edges of a row are one region on the torus.
        let mut cover = vec![0.0; 16];
        cover[4] = 1.0;
        cover[7] = 1.0;
        cover[10] = 0.5;
        let regions = covered_regions(&cover, [4, 4]);
        assert_eq!(regions.len(), 2, "{regions:?}");
        assert!(regions.iter().any(|r| r.len() == 2));
    }

    /// Steps `grid` with `growth`, steering toward `coverage(step)`; returns the covered
    /// fraction after each step.
    fn run(
        grid: &mut GrowthGrid,
        growth: &CloudGrowth,
        steering: &mut GrowthSteering,
        steps: std::ops::Range<u32>,
        coverage: impl Fn(u32) -> f32,
    ) -> Vec<f32> {
        let fields = growth.columns(1.0, 1.0);
        let mut covered = covered_fraction(grid);
        let mut out = Vec::new();
        for step in steps {
            let p = steering.probabilities(coverage(step), covered, growth);
            let scale = |one: u32, p: f32| {
                ((u64::from(one) * u64::from(probability_threshold(p))) >> 24) as u32
            };
            let columns: Vec<[u32; 2]> = fields
                .iter()
                .map(|[hum, act]| [scale(*hum, p.humidity), scale(*act, p.activation)])
                .collect();
            let p_ext = p.extinction;
            grid.step(&columns, probability_threshold(p_ext), growth.seed, step);
            covered = covered_fraction(grid);
            out.push(covered);
        }
        out
    }

    #[test]
    fn the_cover_follows_the_coverage_and_a_rise_forms_new_clouds() {
        let size = [64, 64, 8];
        let growth = CloudGrowth {
            grid: size,
            humidity: NoiseMaker {
                increment: [0.06, 0.06],
                ..NoiseMaker::default()
            },
            activation: NoiseMaker {
                increment: [0.06, 0.06],
                seed: 1,
                ..NoiseMaker::default()
            },
            ..CloudGrowth::default()
        };
        let hour = growth.steps_per_hour as u32;
        // The covered fraction's mean over the last hour of `run` is within 5 points of
        // `coverage`.
        let settled = |run: &[f32], coverage: f32| {
            let last = &run[run.len() - hour as usize..];
            let mean = last.iter().sum::<f32>() / last.len() as f32;
            let worst = last
                .iter()
                .map(|c| (c - coverage).abs())
                .fold(0.0, f32::max);
            eprintln!(
                "settled at {coverage}: mean {mean:.3}, farthest {worst:.3} off over the last hour"
            );
            assert!((mean - coverage).abs() <= 0.05, "{mean} vs {coverage}");
        };
        let mut grid = GrowthGrid::new(size);
        let mut steering = GrowthSteering::default();
        // Four hours at 20 %.
        let settle = run(&mut grid, &growth, &mut steering, 0..4 * hour, |_| 0.2);
        settled(&settle, 0.2);

        // An hour rising to 60 %, then three hours there.
        let visible = |grid: &GrowthGrid| -> Vec<f32> {
            let cover = grid.smoothed_cover();
            cover
                .iter()
                .map(|&c| if c >= COVERED_FROM { 1.0 } else { 0.0 })
                .collect()
        };
        let before = visible(&grid);
        let rise = |step: u32| 0.2 + 0.4 * ((step - 4 * hour) as f32 / hour as f32).min(1.0);
        run(&mut grid, &growth, &mut steering, 4 * hour..5 * hour, rise);
        let after_rise = visible(&grid);
        let held = run(
            &mut grid,
            &growth,
            &mut steering,
            5 * hour..8 * hour,
            |_| 0.6,
        );
        settled(&held, 0.6);

        // Over the rise, clouds appeared where there were none (regions touching no column
        // covered before), and the clouds that were there grew.
        let flat = [size[0], size[1]];
        let old = covered_regions(&before, flat);
        let new = covered_regions(&after_rise, flat);
        let born = new
            .iter()
            .filter(|r| r.iter().all(|&i| before[i] <= 0.0))
            .count();
        let mean = |regions: &[Vec<usize>]| {
            regions.iter().map(Vec::len).sum::<usize>() as f32 / regions.len().max(1) as f32
        };
        eprintln!(
            "over the rise: {} regions of {:.1} columns became {} of {:.1}, {born} of them new",
            old.len(),
            mean(&old),
            new.len(),
            mean(&new)
        );
        assert!(born >= 1, "new clouds formed: {born}");
        assert!(mean(&new) > mean(&old), "clouds grew");
    }
}
