//! Vertex colours by height and slope.

/// Ground colours (linear RGBA, alpha 1) and the heights where the cover changes.
///
/// Forest grows on slopes steeper than about 10–25 % below the tree line (plus noise patches on
/// gentler ground, as on the Swiss Plateau); above the tree line meadow turns alpine and then to
/// rock; rock shows wherever the ground is steeper than about 35°; snow lies above the snow line
/// on all but the steepest faces. Transitions are smooth.
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainPalette {
    /// Meadow and fields. Default sRGB `#6b8e3a`.
    pub meadow: [f32; 4],
    /// Forest. Default sRGB `#2a4522`.
    pub forest: [f32; 4],
    /// Alpine grass above the tree line. Default sRGB `#8a8f5a`.
    pub alpine: [f32; 4],
    /// Bare rock and scree. Default sRGB `#847d73`.
    pub rock: [f32; 4],
    /// Snow. Default sRGB `#f2f4f8`.
    pub snow: [f32; 4],
    /// Water (lake beds under the water surface). Default sRGB `#1c3a4c`.
    pub water: [f32; 4],
    /// Height of the tree line, metres above sea level. Default 1800 (northern Alps).
    pub tree_line_m: f32,
    /// Height where snow is half-way in, metres above sea level. Default 2500.
    pub snow_line_m: f32,
    /// Width of the snow transition around [`snow_line_m`](Self::snow_line_m), metres.
    /// Default 300.
    pub snow_transition_m: f32,
}

impl Default for TerrainPalette {
    fn default() -> Self {
        // Linear values of the sRGB colours in the field docs (IEC 61966-2-1 transfer function).
        Self {
            meadow: [0.147, 0.2705, 0.0423, 1.0],
            forest: [0.0232, 0.0595, 0.016, 1.0],
            alpine: [0.2542, 0.2747, 0.1022, 1.0],
            rock: [0.2307, 0.2051, 0.1714, 1.0],
            snow: [0.8879, 0.9047, 0.9387, 1.0],
            water: [0.0116, 0.0423, 0.0723, 1.0],
            tree_line_m: 1800.0,
            snow_line_m: 2500.0,
            snow_transition_m: 300.0,
        }
    }
}

/// Hermite smoothstep of `x` between `edge0` and `edge1`, clamped to [0, 1].
pub(crate) fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn mix(a: [f32; 4], b: [f32; 4], t: f32) -> [f32; 4] {
    std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
}

impl TerrainPalette {
    /// The colour of ground at `altitude_m` with slope `slope` (rise over run, so 1 is 45°).
    /// `patch` and `tint`, both in about [−1, 1], come from low-frequency noise: `patch` moves
    /// forest edges and the snow line, `tint` varies the brightness by up to 10 %.
    pub(crate) fn ground(&self, altitude_m: f32, slope: f32, patch: f32, tint: f32) -> [f32; 4] {
        let tree = self.tree_line_m;
        // Forest on slopes, and in patches on flatter ground, fading out at the tree line.
        let forest = smoothstep(0.10, 0.25, slope + 0.3 * patch)
            * (1.0 - smoothstep(tree - 150.0, tree + 150.0, altitude_m + 100.0 * patch));
        let lowland = mix(self.meadow, self.forest, forest);
        let alpine = smoothstep(tree - 100.0, tree + 200.0, altitude_m);
        let mut colour = mix(lowland, self.alpine, alpine * (1.0 - forest));
        // Rock on steep faces anywhere, and increasingly with height above the tree line.
        let rock = smoothstep(0.55, 0.85, slope)
            .max(smoothstep(tree + 300.0, tree + 900.0, altitude_m) * smoothstep(0.2, 0.5, slope));
        colour = mix(colour, self.rock, rock);
        // Snow above the snow line, sliding off faces steeper than about 45°.
        let half = 0.5 * self.snow_transition_m.max(1.0);
        let snow = smoothstep(
            self.snow_line_m - half,
            self.snow_line_m + half,
            altitude_m + 120.0 * patch,
        ) * (1.0 - smoothstep(0.9, 1.4, slope));
        colour = mix(colour, self.snow, snow);
        let brightness = 1.0 + 0.1 * tint * (1.0 - snow);
        [
            (colour[0] * brightness).clamp(0.0, 1.0),
            (colour[1] * brightness).clamp(0.0, 1.0),
            (colour[2] * brightness).clamp(0.0, 1.0),
            1.0,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f32; 4], b: [f32; 4]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-3)
    }

    #[test]
    fn cover_follows_height_and_slope() {
        let p = TerrainPalette::default();
        assert!(close(p.ground(550.0, 0.02, 0.0, 0.0), p.meadow));
        assert!(close(p.ground(900.0, 0.4, 0.0, 0.0), p.forest));
        assert!(close(p.ground(1500.0, 1.2, 0.0, 0.0), p.rock));
        assert!(close(p.ground(3500.0, 0.3, 0.0, 0.0), p.snow));
        assert!(close(p.ground(3500.0, 2.0, 0.0, 0.0), p.rock));
        // Soft snow transition: half-way at the snow line.
        let mid = p.ground(2500.0, 0.0, 0.0, 0.0);
        assert!(mid[0] > p.alpine[0] && mid[0] < p.snow[0]);
    }

    #[test]
    fn colours_stay_in_range() {
        let p = TerrainPalette::default();
        for a in (0..5000).step_by(37) {
            for s in 0..40 {
                for n in [-1.0, -0.3, 0.0, 0.7, 1.0] {
                    let c = p.ground(a as f32, s as f32 * 0.07, n, -n);
                    assert!(c.iter().all(|v| (0.0..=1.0).contains(v)), "{c:?}");
                    assert_eq!(c[3], 1.0);
                }
            }
        }
    }
}
