//! The vertical density profile of a layer: a curve of relative density over the height
//! fraction of the layer, after Aetherius' shape-altering curves.

use bevy::prelude::Reflect;

use super::CloudKind;

/// One control point of a [`DensityProfile`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Reflect)]
pub struct ProfilePoint {
    /// Height in the layer as a fraction: 0 at the base, 1 at the top.
    pub height_fraction: f32,
    /// Relative density at that height, 0–1.
    pub density: f32,
}

impl ProfilePoint {
    /// A point at `height_fraction` (0 base, 1 top) with relative `density` (0–1).
    #[must_use]
    pub const fn new(height_fraction: f32, density: f32) -> Self {
        Self {
            height_fraction,
            density,
        }
    }
}

/// How a [`DensityProfile`] joins its control points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum ProfileInterpolation {
    /// Straight lines between points.
    Linear,
    /// A monotone cubic (a Fritsch–Carlson-style Hermite spline with Fritsch–Butland tangents, as
    /// in PCHIP). It is smooth and never overshoots between points: a profile whose points lie in
    /// 0–1 stays in 0–1, and a plateau stays flat. Default.
    #[default]
    Smooth,
}

/// Relative cloud density against height in a layer: Aetherius' shape-altering curve (Pérez Martín 2022,
/// "Density Model"). The renderer multiplies the base-shape noise by it before the coverage
/// remap. Where the profile is low, only the strongest noise survives the remap, which narrows
/// the clouds there. Where it is high, they fill out. The profile's shape is therefore the shape
/// of the clouds: a rounded base and a tapering top for cumulus, a flat slab for stratus, an
/// anvil for cumulonimbus.
///
/// The curve is editable data: up to a handful of [`ProfilePoint`]s (eight are plenty), sorted by
/// height. Evaluation holds the end values beyond the first and last points. A profile with no
/// points evaluates to 1 everywhere (no shaping). The GPU gets the curve as a table from
/// [`DensityProfile::bake`], so the number of points is not limited by the shader.
///
/// # Example
///
/// ```
/// # use bevy_cloudscape::layers::{DensityProfile, ProfileInterpolation};
/// // A layer that is densest near its base and thins out upward.
/// let profile = DensityProfile::new(
///     [(0.0, 0.0), (0.1, 1.0), (1.0, 0.2)],
///     ProfileInterpolation::Linear,
/// );
/// assert_eq!(profile.evaluate(0.1), 1.0);
/// assert!((profile.evaluate(0.55) - 0.6).abs() < 1e-6);
/// ```
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct DensityProfile {
    /// The control points, sorted by [`ProfilePoint::height_fraction`], each coordinate in 0–1.
    /// [`DensityProfile::new`] and [`DensityProfile::sanitize`] ensure this. Evaluating
    /// unsorted points does not panic, but the result is then unspecified.
    pub points: Vec<ProfilePoint>,
    /// How the points are joined. Default [`ProfileInterpolation::Smooth`].
    pub interpolation: ProfileInterpolation,
}

impl Default for DensityProfile {
    /// [`DensityProfile::uniform`].
    fn default() -> Self {
        Self::uniform()
    }
}

impl DensityProfile {
    /// A profile through `points` given as `(height_fraction, density)` pairs. The points are
    /// cleaned as in [`DensityProfile::sanitize`]: non-finite points are dropped, coordinates
    /// clamped to 0–1, and the points sorted by height.
    #[must_use]
    pub fn new(
        points: impl IntoIterator<Item = (f32, f32)>,
        interpolation: ProfileInterpolation,
    ) -> Self {
        let mut profile = Self {
            points: points
                .into_iter()
                .map(|(height_fraction, density)| ProfilePoint::new(height_fraction, density))
                .collect(),
            interpolation,
        };
        profile.sanitize();
        profile
    }

    /// Density 1 at every height: the layer's clouds keep the noise's own shape.
    #[must_use]
    pub fn uniform() -> Self {
        Self::smooth(&[(0.0, 1.0), (1.0, 1.0)])
    }

    /// The default profile of `kind`.
    #[must_use]
    pub fn for_kind(kind: CloudKind) -> Self {
        match kind {
            CloudKind::Cumulus => Self::cumulus(),
            CloudKind::Stratocumulus => Self::stratocumulus(),
            CloudKind::Stratus => Self::stratus(),
            CloudKind::Altocumulus => Self::altocumulus(),
            CloudKind::Altostratus => Self::altostratus(),
            CloudKind::Cirrus => Self::cirrus(),
            CloudKind::Cirrostratus => Self::cirrostratus(),
            CloudKind::Cirrocumulus => Self::cirrocumulus(),
            CloudKind::Cumulonimbus => Self::cumulonimbus(),
        }
    }

    /// Cumulus: a short ramp at the base (a flat, well-defined base, rounded by the smooth
    /// curve), full density in the lower half, then a long taper. The taper narrows the clouds
    /// into domes, and the renderer's detail erosion makes the domes billow. This is Pérez Martín 2022's
    /// "no density at the bottom, full density somewhere in the middle … fades to zero density
    /// again at the top", with the peak low as in a convective heap.
    #[must_use]
    pub fn cumulus() -> Self {
        Self::smooth(&[
            (0.0, 0.0),
            (0.07, 0.7),
            (0.2, 1.0),
            (0.55, 0.9),
            (0.85, 0.45),
            (1.0, 0.0),
        ])
    }

    /// Stratocumulus: like cumulus, but flatter and spread out. The ramp is quick, the plateau
    /// wide, and the drop-off near the top short: rolls and patches rather than towers.
    #[must_use]
    pub fn stratocumulus() -> Self {
        Self::smooth(&[
            (0.0, 0.0),
            (0.1, 0.8),
            (0.3, 1.0),
            (0.7, 0.9),
            (0.9, 0.4),
            (1.0, 0.0),
        ])
    }

    /// Stratus: a thin, flat slab with full density from a tenth of the way up to a tenth from
    /// the top, and short fades at both edges.
    #[must_use]
    pub fn stratus() -> Self {
        Self::smooth(&[(0.0, 0.0), (0.1, 1.0), (0.9, 1.0), (1.0, 0.0)])
    }

    /// Ground fog: full density from the ground up, fading out over the upper half, so the fog
    /// has a soft top and its density at eye level is the one the visibility gives
    /// (Koschmieder). Used by the weather mapping's fog layer.
    #[must_use]
    pub fn fog() -> Self {
        Self::smooth(&[(0.0, 1.0), (0.5, 1.0), (1.0, 0.0)])
    }

    /// Altocumulus: small heaps like a shallow cumulus, in a thin mid-level layer.
    #[must_use]
    pub fn altocumulus() -> Self {
        Self::smooth(&[(0.0, 0.0), (0.15, 0.8), (0.35, 1.0), (0.7, 0.7), (1.0, 0.0)])
    }

    /// Altostratus: a thick, nearly uniform sheet, slightly denser in the middle.
    #[must_use]
    pub fn altostratus() -> Self {
        Self::smooth(&[
            (0.0, 0.0),
            (0.15, 0.85),
            (0.5, 1.0),
            (0.85, 0.85),
            (1.0, 0.0),
        ])
    }

    /// Cirrus: thin and wispy. The peak density is only half, so the coverage remap leaves thin
    /// filaments rather than solid cloud, and the fade reaches the edges from both sides.
    #[must_use]
    pub fn cirrus() -> Self {
        Self::smooth(&[(0.0, 0.0), (0.3, 0.4), (0.5, 0.5), (0.7, 0.4), (1.0, 0.0)])
    }

    /// Cirrostratus: an even, faint veil across most of the layer.
    #[must_use]
    pub fn cirrostratus() -> Self {
        Self::smooth(&[(0.0, 0.0), (0.2, 0.6), (0.8, 0.6), (1.0, 0.0)])
    }

    /// Cirrocumulus: a thin sheet of tiny cloudlets, a little denser than cirrus.
    #[must_use]
    pub fn cirrocumulus() -> Self {
        Self::smooth(&[(0.0, 0.0), (0.3, 0.7), (0.6, 0.7), (1.0, 0.0)])
    }

    /// Cumulonimbus: a tall tower whose density stays high all the way up. It bulges slightly in
    /// the upper third where the anvil spreads, and drops only in the last few per cent, so the
    /// anvil's top is flat. Because the profile is high near the top, the coverage remap keeps
    /// wide cloud there, and that is the anvil widening (Thomann 2021 §3.3.10: "Their top is often
    /// shaped like an anvil, whereas the base is flat and dark").
    #[must_use]
    pub fn cumulonimbus() -> Self {
        Self::smooth(&[
            (0.0, 0.0),
            (0.03, 0.7),
            (0.1, 0.95),
            (0.5, 0.85),
            (0.75, 0.95),
            (0.92, 1.0),
            (0.97, 0.8),
            (1.0, 0.0),
        ])
    }

    fn smooth(points: &[(f32, f32)]) -> Self {
        Self::new(points.iter().copied(), ProfileInterpolation::Smooth)
    }

    /// Relative density at height fraction `h` (0 base, 1 top), in 0–1.
    ///
    /// `h` outside 0–1 is clamped, and a NaN `h` reads the base. Beyond the first and last points
    /// the end values are held. An empty profile gives 1. A non-finite result (possible only for
    /// hand-made points that are not finite) gives 0. Allocation-free.
    #[must_use]
    pub fn evaluate(&self, h: f32) -> f32 {
        let points = &self.points;
        let (Some(first), Some(last)) = (points.first(), points.last()) else {
            return 1.0;
        };
        let h = if h.is_nan() { 0.0 } else { h.clamp(0.0, 1.0) };
        let value = if h <= first.height_fraction {
            first.density
        } else if h >= last.height_fraction {
            last.density
        } else {
            // The segment [i, i + 1] holding h; it exists because first < h < last.
            let i = points
                .windows(2)
                .position(|pair| h <= pair[1].height_fraction)
                .unwrap_or(points.len() - 2);
            self.interpolate(i, h)
        };
        if value.is_finite() {
            value.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Value in segment `i` (between points `i` and `i + 1`) at height `h`.
    fn interpolate(&self, i: usize, h: f32) -> f32 {
        let points = &self.points;
        let (p0, p1) = (points[i], points[i + 1]);
        let width = p1.height_fraction - p0.height_fraction;
        if width <= 0.0 {
            return p1.density;
        }
        let t = (h - p0.height_fraction) / width;
        match self.interpolation {
            ProfileInterpolation::Linear => p0.density + (p1.density - p0.density) * t,
            ProfileInterpolation::Smooth => {
                // Cubic Hermite with shape-preserving tangents (Fritsch & Carlson 1980,
                // "Monotone piecewise cubic interpolation"), computed locally so evaluation
                // needs no stored tangents.
                let m0 = self.tangent(i);
                let m1 = self.tangent(i + 1);
                let (t2, t3) = (t * t, t * t * t);
                let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
                let h10 = t3 - 2.0 * t2 + t;
                let h01 = -2.0 * t3 + 3.0 * t2;
                let h11 = t3 - t2;
                h00 * p0.density + h10 * width * m0 + h01 * p1.density + h11 * width * m1
            }
        }
    }

    /// Slope at point `i` for the smooth curve.
    fn tangent(&self, i: usize) -> f32 {
        let points = &self.points;
        let secant = |k: usize| {
            let (a, b) = (points[k], points[k + 1]);
            let width = b.height_fraction - a.height_fraction;
            if width > 0.0 {
                (b.density - a.density) / width
            } else {
                0.0
            }
        };
        let last = points.len() - 1;
        if i == 0 {
            return secant(0);
        }
        if i == last {
            return secant(last - 1);
        }
        let (d0, d1) = (secant(i - 1), secant(i));
        // A local extremum or flat neighbour: a zero slope keeps the curve from overshooting.
        if d0 * d1 <= 0.0 {
            return 0.0;
        }
        // Fritsch & Butland (1984) weighted harmonic mean of the neighbouring secants. It stays
        // within 3× the smaller secant, inside Fritsch & Carlson's monotonicity region.
        let w0 = points[i].height_fraction - points[i - 1].height_fraction;
        let w1 = points[i + 1].height_fraction - points[i].height_fraction;
        3.0 * (w0 + w1) / ((2.0 * w1 + w0) / d0 + (w1 + 2.0 * w0) / d1)
    }

    /// Samples the curve into `table` for the GPU: entry `i` of `n` is the density at the
    /// texel centre `(i + 0.5) / n`. That makes the table a 1D texture read with linear
    /// filtering, the array Pérez Martín 2022 passes to its shader ("sampled into an array of values in
    /// the CPU when the curve is modified").
    pub fn bake(&self, table: &mut [f32]) {
        let n = table.len() as f32;
        for (i, value) in table.iter_mut().enumerate() {
            *value = self.evaluate((i as f32 + 0.5) / n);
        }
    }

    /// A cleaned copy; see [`DensityProfile::sanitize`].
    #[must_use]
    pub fn sanitized(&self) -> Self {
        let mut clean = self.clone();
        clean.sanitize();
        clean
    }

    /// Cleans the profile in place: non-finite points are dropped, both coordinates clamped to
    /// 0–1, and the points sorted by height. The sort is stable, so points at the same height
    /// keep their order and make a step. A clean profile is left as it is, without allocating.
    pub fn sanitize(&mut self) {
        self.points
            .retain(|p| p.height_fraction.is_finite() && p.density.is_finite());
        for point in &mut self.points {
            point.height_fraction = point.height_fraction.clamp(0.0, 1.0);
            point.density = point.density.clamp(0.0, 1.0);
        }
        let by_height =
            |a: &ProfilePoint, b: &ProfilePoint| a.height_fraction.total_cmp(&b.height_fraction);
        if !self.points.is_sorted_by(|a, b| by_height(a, b).is_le()) {
            self.points.sort_by(by_height);
        }
    }
}
