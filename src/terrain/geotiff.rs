//! `GeoTIFF` reader for single-band elevation rasters in geographic degrees, on the `tiff` crate.
//!
//! Georeferencing follows the `GeoTIFF` 1.1 standard (OGC 19-008r4): `ModelTiepointTag` (33922)
//! ties raster point (i, j) to model point (x = longitude, y = latitude), `ModelPixelScaleTag`
//! (33550) gives the cell size (x, y; y positive for north-up rows), and the
//! `GTRasterTypeGeoKey` in `GeoKeyDirectoryTag` (34735) says whether the tie point names a
//! cell's corner (`PixelIsArea`, the default) or its centre (`PixelIsPoint`). A
//! `GTModelTypeGeoKey` of projected or geocentric is refused, as are rotated rasters
//! (`ModelTransformationTag`) and several tie points (ground control points). GDAL's NODATA
//! tag (42113) marks missing cells; float NaN does too.

use std::io::Cursor;

use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

use super::dem::{Dem, DemGrid, check_size};
use super::error::{DemError, DemErrorKind};

/// `GeoKey` ID of `GTModelTypeGeoKey`: 1 projected, 2 geographic, 3 geocentric.
const GT_MODEL_TYPE: u16 = 1024;
/// `GeoKey` ID of `GTRasterTypeGeoKey`: 1 `PixelIsArea`, 2 `PixelIsPoint`.
const GT_RASTER_TYPE: u16 = 1025;
/// `GTRasterTypeGeoKey` value for `PixelIsPoint`.
const RASTER_PIXEL_IS_POINT: u16 = 2;
/// `GTModelTypeGeoKey` value for geographic latitude/longitude.
const MODEL_GEOGRAPHIC: u16 = 2;

/// Whether the bytes start with a TIFF or `BigTIFF` header.
pub(crate) fn is_tiff(bytes: &[u8]) -> bool {
    [b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"]
        .iter()
        .any(|magic| bytes.starts_with(*magic))
}

fn tiff_error(e: tiff::TiffError) -> DemError {
    DemError::new(DemErrorKind::Tiff {
        message: e.to_string(),
    })
}

fn unsupported(detail: impl Into<String>) -> DemError {
    DemError::new(DemErrorKind::UnsupportedLayout {
        detail: detail.into(),
    })
}

/// The two `GeoKeys` this reader uses, when present.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct GeoKeys {
    model_type: Option<u16>,
    raster_type: Option<u16>,
}

/// Reads the keys stored inline in a `GeoKeyDirectoryTag`: a 4-short header whose last value
/// is the key count, then 4 shorts per key (ID, tag location, count, value); location 0 means
/// the value is the fourth short itself.
fn geo_keys(directory: &[u16]) -> GeoKeys {
    let mut keys = GeoKeys::default();
    let Some(&count) = directory.get(3) else {
        return keys;
    };
    for entry in directory[4..].chunks_exact(4).take(usize::from(count)) {
        if entry[1] != 0 {
            continue;
        }
        match entry[0] {
            GT_MODEL_TYPE => keys.model_type = Some(entry[3]),
            GT_RASTER_TYPE => keys.raster_type = Some(entry[3]),
            _ => {}
        }
    }
    keys
}

/// Parses a `GeoTIFF` held in memory.
pub(crate) fn parse(bytes: &[u8]) -> Result<Dem, DemError> {
    let mut decoder = Decoder::new(Cursor::new(bytes)).map_err(tiff_error)?;
    let (width, height) = decoder.dimensions().map_err(tiff_error)?;
    let (ncols, nrows) = (width as usize, height as usize);
    check_size(ncols, nrows)?;
    match decoder.colortype().map_err(tiff_error)? {
        ColorType::Gray(_) => {}
        other => {
            return Err(unsupported(format!(
                "{other:?} pixels; expected one band of heights"
            )));
        }
    }

    let tag_f64s = |decoder: &mut Decoder<Cursor<&[u8]>>, tag: Tag, name: &'static str| {
        decoder
            .find_tag(tag)
            .map_err(tiff_error)?
            .ok_or(DemError::new(DemErrorKind::MissingGeoreference {
                tag: name,
            }))?
            .into_f64_vec()
            .map_err(tiff_error)
    };
    if decoder
        .find_tag(Tag::ModelTransformationTag)
        .map_err(tiff_error)?
        .is_some()
    {
        return Err(unsupported(
            "ModelTransformationTag (34264): rotated or sheared rasters are not supported",
        ));
    }
    let scale = tag_f64s(
        &mut decoder,
        Tag::ModelPixelScaleTag,
        "ModelPixelScaleTag (33550)",
    )?;
    let tie = tag_f64s(
        &mut decoder,
        Tag::ModelTiepointTag,
        "ModelTiepointTag (33922)",
    )?;
    let [scale_x, scale_y, ..] = scale[..] else {
        return Err(unsupported(format!(
            "ModelPixelScaleTag has {} values, expected 3",
            scale.len()
        )));
    };
    let [i, j, _, x, y, _] = tie[..] else {
        return Err(unsupported(format!(
            "ModelTiepointTag has {} values: one tie point (6 values) expected, not ground \
             control points",
            tie.len()
        )));
    };
    if !(scale_x > 0.0 && scale_y > 0.0) {
        return Err(unsupported(format!(
            "ModelPixelScaleTag ({scale_x}, {scale_y}): north-up rows with positive cell sizes \
             expected"
        )));
    }
    let keys = match decoder
        .find_tag(Tag::GeoKeyDirectoryTag)
        .map_err(tiff_error)?
    {
        Some(value) => geo_keys(&value.into_u16_vec().map_err(tiff_error)?),
        None => GeoKeys::default(),
    };
    if let Some(model) = keys.model_type
        && model != MODEL_GEOGRAPHIC
    {
        return Err(DemError::new(DemErrorKind::NotGeographic {
            detail: format!("GTModelTypeGeoKey is {model} (2 = geographic)"),
        }));
    }
    let nodata = match decoder.find_tag(Tag::GdalNodata).map_err(tiff_error)? {
        Some(value) => {
            let text = value.into_string().map_err(tiff_error)?;
            let text = text.trim_matches(|c: char| c == '\0' || c.is_whitespace());
            Some(text.parse::<f64>().map_err(|_| {
                DemError::new(DemErrorKind::BadNumber {
                    what: "GDAL_NODATA tag (42113)".into(),
                    token: text.chars().take(40).collect(),
                    expected: "a number",
                })
            })?)
        }
        None => None,
    };

    let mut buffer = DecodingResult::F32(Vec::new());
    let layout = decoder
        .read_image_to_buffer(&mut buffer)
        .map_err(tiff_error)?;
    if layout.planes != 1 {
        return Err(unsupported("several planes; expected one band of heights"));
    }
    let heights = to_heights(buffer, nodata);
    if heights.len() != ncols * nrows {
        return Err(unsupported(format!(
            "{} samples for {ncols} × {nrows} pixels; expected one band of heights",
            heights.len()
        )));
    }

    // The cell centre is raster point (c + ½, r + ½) for PixelIsArea, (c, r) for PixelIsPoint.
    let centre = if keys.raster_type == Some(RASTER_PIXEL_IS_POINT) {
        0.0
    } else {
        0.5
    };
    let grid = DemGrid {
        lower_left_lon_deg: x + (centre - i) * scale_x,
        lower_left_lat_deg: y - ((nrows - 1) as f64 + centre - j) * scale_y,
        cell_lon_deg: scale_x,
        cell_lat_deg: scale_y,
    };
    Dem::new(ncols, nrows, heights, grid)
}

/// Converts any integer or float samples to heights in metres, NODATA to NaN.
fn to_heights(buffer: DecodingResult, nodata: Option<f64>) -> Vec<f32> {
    fn map<T: Copy>(values: Vec<T>, nodata: Option<f64>, f: impl Fn(T) -> f64) -> Vec<f32> {
        values
            .into_iter()
            .map(|v| {
                let value = f(v);
                if nodata == Some(value) {
                    f32::NAN
                } else {
                    value as f32
                }
            })
            .collect()
    }
    match buffer {
        DecodingResult::U8(v) => map(v, nodata, f64::from),
        DecodingResult::U16(v) => map(v, nodata, f64::from),
        DecodingResult::U32(v) => map(v, nodata, f64::from),
        DecodingResult::U64(v) => map(v, nodata, |x| x as f64),
        DecodingResult::I8(v) => map(v, nodata, f64::from),
        DecodingResult::I16(v) => map(v, nodata, f64::from),
        DecodingResult::I32(v) => map(v, nodata, f64::from),
        DecodingResult::I64(v) => map(v, nodata, |x| x as f64),
        DecodingResult::F16(v) => map(v, nodata, |x| f64::from(x.to_f32())),
        DecodingResult::F32(v) => map(v, nodata, f64::from),
        DecodingResult::F64(v) => map(v, nodata, |x| x),
    }
}

#[cfg(test)]
mod tests {
    use tiff::encoder::{TiffEncoder, colortype};

    use super::*;

    /// `GeoKey` directory: version 1.1.0, then model type and raster type.
    fn geokeys(model: u16, raster: u16) -> [u16; 12] {
        [
            1,
            1,
            0,
            2,
            GT_MODEL_TYPE,
            0,
            1,
            model,
            GT_RASTER_TYPE,
            0,
            1,
            raster,
        ]
    }

    /// Writes a 3 × 2 raster with the given sample type and tags.
    fn write<C: colortype::ColorType>(
        data: &[C::Inner],
        scale: Option<&[f64]>,
        tie: Option<&[f64]>,
        keys: Option<&[u16]>,
        nodata: Option<&str>,
    ) -> Vec<u8>
    where
        [C::Inner]: tiff::encoder::TiffValue,
    {
        let mut bytes = Cursor::new(Vec::new());
        let mut encoder = TiffEncoder::new(&mut bytes).unwrap();
        let mut image = encoder.new_image::<C>(3, 2).unwrap();
        let dir = image.encoder();
        if let Some(scale) = scale {
            dir.write_tag(Tag::ModelPixelScaleTag, scale).unwrap();
        }
        if let Some(tie) = tie {
            dir.write_tag(Tag::ModelTiepointTag, tie).unwrap();
        }
        if let Some(keys) = keys {
            dir.write_tag(Tag::GeoKeyDirectoryTag, keys).unwrap();
        }
        if let Some(nodata) = nodata {
            dir.write_tag(Tag::GdalNodata, nodata).unwrap();
        }
        image.write_data(data).unwrap();
        bytes.into_inner()
    }

    const SCALE: &[f64] = &[0.25, 0.125, 0.0];
    /// Raster (0, 0) at 7° E, 47° N: the outer north-west corner for `PixelIsArea`.
    const TIE: &[f64] = &[0.0, 0.0, 0.0, 7.0, 47.0, 0.0];

    #[test]
    fn f32_round_trip_with_tags() {
        let heights = [500.0f32, 510.5, 520.0, 600.0, -9999.0, 620.25];
        let keys = geokeys(MODEL_GEOGRAPHIC, 1);
        let bytes = write::<colortype::Gray32Float>(
            &heights,
            Some(SCALE),
            Some(TIE),
            Some(&keys),
            Some("-9999"),
        );
        assert!(is_tiff(&bytes));
        let dem = Dem::from_bytes(&bytes).unwrap();
        assert_eq!((dem.ncols(), dem.nrows()), (3, 2));
        let grid = dem.grid();
        // Lower-left centre: half a cell east of 7°, one and a half cells south of 47°.
        assert!((grid.lower_left_lon_deg - 7.125).abs() < 1e-12);
        assert!((grid.lower_left_lat_deg - (47.0 - 1.5 * 0.125)).abs() < 1e-12);
        assert_eq!((grid.cell_lon_deg, grid.cell_lat_deg), (0.25, 0.125));
        assert_eq!(dem.height(1, 0), Some(510.5));
        assert_eq!(dem.height(2, 1), Some(620.25));
        assert_eq!(dem.filled_cells(), 1);
        assert!(dem.height(1, 1).unwrap() > 500.0);
        // North-west cell centre.
        assert_eq!(dem.height_at(47.0 - 0.0625, 7.125), Some(500.0));
    }

    #[test]
    fn integer_samples_and_pixel_is_point() {
        let keys = geokeys(MODEL_GEOGRAPHIC, RASTER_PIXEL_IS_POINT);
        let i16s = write::<colortype::GrayI16>(
            &[-5, 10, 20, 30, 40, 50],
            Some(SCALE),
            Some(TIE),
            Some(&keys),
            None,
        );
        let dem = Dem::from_geotiff(&i16s).unwrap();
        // PixelIsPoint: the tie point is the north-west centre itself.
        assert!((dem.grid().lower_left_lon_deg - 7.0).abs() < 1e-12);
        assert!((dem.grid().lower_left_lat_deg - 46.875).abs() < 1e-12);
        assert_eq!(dem.height(0, 0), Some(-5.0));
        let u16s =
            write::<colortype::Gray16>(&[1, 2, 3, 4, 5, 6], Some(SCALE), Some(TIE), None, None);
        assert_eq!(Dem::from_geotiff(&u16s).unwrap().height(2, 1), Some(6.0));
        let i32s =
            write::<colortype::GrayI32>(&[1, 2, 3, 4, 5, 4000], Some(SCALE), Some(TIE), None, None);
        assert_eq!(Dem::from_geotiff(&i32s).unwrap().height(2, 1), Some(4000.0));
    }

    #[test]
    fn clear_errors_for_unsupported_files() {
        let kind = |bytes: &[u8]| Dem::from_geotiff(bytes).unwrap_err().kind;
        let data = [1.0f32; 6];
        let no_tie = write::<colortype::Gray32Float>(&data, Some(SCALE), None, None, None);
        assert_eq!(
            kind(&no_tie),
            DemErrorKind::MissingGeoreference {
                tag: "ModelTiepointTag (33922)"
            }
        );
        let no_scale = write::<colortype::Gray32Float>(&data, None, Some(TIE), None, None);
        assert_eq!(
            kind(&no_scale),
            DemErrorKind::MissingGeoreference {
                tag: "ModelPixelScaleTag (33550)"
            }
        );
        let projected = geokeys(1, 1);
        let lv95 =
            write::<colortype::Gray32Float>(&data, Some(SCALE), Some(TIE), Some(&projected), None);
        assert!(matches!(kind(&lv95), DemErrorKind::NotGeographic { .. }));
        let two_ties: Vec<f64> = TIE.iter().chain(TIE).copied().collect();
        let gcps = write::<colortype::Gray32Float>(&data, Some(SCALE), Some(&two_ties), None, None);
        assert!(matches!(
            kind(&gcps),
            DemErrorKind::UnsupportedLayout { .. }
        ));
        let rgb = {
            let mut bytes = Cursor::new(Vec::new());
            TiffEncoder::new(&mut bytes)
                .unwrap()
                .write_image::<colortype::RGB8>(1, 1, &[1, 2, 3])
                .unwrap();
            bytes.into_inner()
        };
        assert!(matches!(kind(&rgb), DemErrorKind::UnsupportedLayout { .. }));
        assert!(matches!(kind(b"II*\0garbage"), DemErrorKind::Tiff { .. }));
        let bad_nodata =
            write::<colortype::Gray32Float>(&data, Some(SCALE), Some(TIE), None, Some("none"));
        assert!(matches!(kind(&bad_nodata), DemErrorKind::BadNumber { .. }));
    }

    #[test]
    fn truncated_and_mutated_files_never_panic() {
        let bytes = write::<colortype::Gray32Float>(
            &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
            Some(SCALE),
            Some(TIE),
            Some(&geokeys(MODEL_GEOGRAPHIC, 1)),
            Some("-9999"),
        );
        for len in 0..bytes.len() {
            let _ = Dem::from_bytes(&bytes[..len]);
        }
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for _ in 0..5_000 {
            let mut mutated = bytes.clone();
            for _ in 0..1 + next() % 3 {
                let at = (next() % mutated.len() as u64) as usize;
                mutated[at] = next() as u8;
            }
            if let Ok(dem) = Dem::from_bytes(&mutated) {
                assert!(dem.heights_m().iter().all(|h| h.is_finite()));
            }
        }
    }
}
