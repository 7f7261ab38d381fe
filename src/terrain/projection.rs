//! Geographic coordinates to scene metres, in f64, without Bevy types.

/// WGS 84 semi-major axis, metres.
const WGS84_A_M: f64 = 6_378_137.0;
/// WGS 84 first eccentricity squared.
const WGS84_E2: f64 = 6.694_379_990_14e-3;

/// The local tangent plane at a geographic origin: the crate's scene frame, +X east, +Y up,
/// −Z north, in metres.
///
/// [`TangentPlane::to_scene`] is the same formula as `scene::GeoOrigin::to_scene` (WGS 84 radii
/// of curvature at the origin: meridional `M` for north, prime vertical `N cos φ` for east), in
/// f64 and with plain arrays so that this module needs no Bevy types. Build one from a
/// `GeoOrigin` with its three fields. Because the mapping is linear in longitude and in latitude
/// separately, a longitude/latitude grid maps to an axis-aligned rectangular grid in scene X/Z,
/// and [`TangentPlane::to_geographic`] inverts it exactly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TangentPlane {
    /// Latitude of the origin, degrees north. Default 46.948 (Bern).
    pub latitude_deg: f64,
    /// Longitude of the origin, degrees east. Default 7.447 (Bern).
    pub longitude_deg: f64,
    /// Altitude of scene y = 0 above sea level, metres. Default 0: scene y is altitude.
    pub elevation_m: f64,
}

impl Default for TangentPlane {
    fn default() -> Self {
        Self {
            latitude_deg: 46.948,
            longitude_deg: 7.447,
            elevation_m: 0.0,
        }
    }
}

impl TangentPlane {
    /// A plane at `latitude_deg` north, `longitude_deg` east, whose y = 0 lies `elevation_m`
    /// above sea level.
    pub fn new(latitude_deg: f64, longitude_deg: f64, elevation_m: f64) -> Self {
        Self {
            latitude_deg,
            longitude_deg,
            elevation_m,
        }
    }

    /// Metres per degree of longitude (east) and of latitude (north) at the origin.
    pub fn metres_per_degree(&self) -> (f64, f64) {
        let phi = self.latitude_deg.to_radians();
        let w = 1.0 - WGS84_E2 * phi.sin().powi(2);
        let prime_vertical = WGS84_A_M / w.sqrt();
        let meridional = WGS84_A_M * (1.0 - WGS84_E2) / w.powf(1.5);
        (
            prime_vertical * phi.cos() * 1f64.to_radians(),
            meridional * 1f64.to_radians(),
        )
    }

    /// Scene position `[x, y, z]` in metres (+X east, +Y up, −Z north) of a point at
    /// `latitude_deg`, `longitude_deg` and `elevation_m` above sea level. Matches
    /// `GeoOrigin::to_scene`.
    pub fn to_scene(&self, latitude_deg: f64, longitude_deg: f64, elevation_m: f64) -> [f64; 3] {
        let (east_per_deg, north_per_deg) = self.metres_per_degree();
        [
            east_per_deg * (longitude_deg - self.longitude_deg),
            elevation_m - self.elevation_m,
            -north_per_deg * (latitude_deg - self.latitude_deg),
        ]
    }

    /// Latitude and longitude in degrees of the scene point `(x, z)` (metres): the inverse of
    /// [`TangentPlane::to_scene`] on the horizontal axes.
    pub fn to_geographic(&self, x: f64, z: f64) -> (f64, f64) {
        let (east_per_deg, north_per_deg) = self.metres_per_degree();
        (
            self.latitude_deg - z / north_per_deg,
            self.longitude_deg + x / east_per_deg,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn origin_maps_to_zero_and_axes_point_the_right_way() {
        let plane = TangentPlane::default();
        let o = plane.to_scene(46.948, 7.447, 0.0);
        assert!(o.iter().all(|c| c.abs() < 1e-9));
        let north = plane.to_scene(46.958, 7.447, 0.0);
        assert!(north[2] < -1000.0 && north[0].abs() < 1e-9);
        let east = plane.to_scene(46.948, 7.457, 540.0);
        assert!(east[0] > 700.0 && east[2].abs() < 1e-9);
        assert!((east[1] - 540.0).abs() < 1e-9);
    }

    #[test]
    fn scale_matches_wgs84_at_bern() {
        // At 46.948° N one degree of latitude is about 111.17 km and one of longitude about
        // 76.1 km (WGS 84).
        let (east, north) = TangentPlane::default().metres_per_degree();
        assert!((north - 111_170.0).abs() < 100.0, "{north}");
        assert!((east - 76_100.0).abs() < 200.0, "{east}");
    }

    #[test]
    fn to_geographic_inverts_to_scene() {
        let plane = TangentPlane::new(46.9, 7.4, 500.0);
        let p = plane.to_scene(47.2, 7.9, 1200.0);
        let (lat, lon) = plane.to_geographic(p[0], p[2]);
        assert!((lat - 47.2).abs() < 1e-12 && (lon - 7.9).abs() < 1e-12);
        assert!((p[1] - 700.0).abs() < 1e-9);
    }
}
