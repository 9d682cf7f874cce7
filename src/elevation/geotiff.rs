//! One GeoTIFF elevation tile: decoded with the `tiff` crate, georeferenced
//! from its GeoTIFF tags read here.
//!
//! Why the GeoTIFF keys are read by hand: the maintained crates that read
//! them (`geotiff` 0.1, georust) depend on an older `tiff` (0.9), decode the
//! raster without a size check the caller controls, and ignore
//! `GDAL_NODATA`; what an elevation model needs of GeoTIFF is small (the
//! model type, the geographic CRS code, the raster type, a tie point and a
//! pixel scale or an affine transformation, and the no-data value), so it
//! is read here from the tags the `tiff` crate decodes.

use crate::error::{Error, Result};
use std::path::Path;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;
use tiff::ColorType;

/// GeoKey ids (GeoTIFF 1.1, OGC 19-008r4, table 3).
const GT_MODEL_TYPE: u16 = 1024;
const GT_RASTER_TYPE: u16 = 1025;
const GEOGRAPHIC_TYPE: u16 = 2048;
const GEOG_GEODETIC_DATUM: u16 = 2050;
const PROJECTED_CS_TYPE: u16 = 3072;
/// `GTModelTypeGeoKey` values.
const MODEL_PROJECTED: u16 = 1;
const MODEL_GEOGRAPHIC: u16 = 2;
/// `GTRasterTypeGeoKey`: the tie point names a pixel's centre, not its corner.
const RASTER_PIXEL_IS_POINT: u16 = 2;
/// EPSG:4326 (WGS 84 geographic) and its datum EPSG:6326.
const EPSG_WGS84: u16 = 4326;
const EPSG_WGS84_DATUM: u16 = 6326;
/// GeoTIFF's "user-defined" code.
const USER_DEFINED: u16 = 32767;

/// One elevation raster on WGS-84 latitude and longitude.
#[derive(Debug, Clone)]
pub(super) struct Tile {
    /// Longitude of pixel (0, 0)'s centre (degrees).
    pub lon0: f64,
    /// Latitude of pixel (0, 0)'s centre (degrees).
    pub lat0: f64,
    /// Longitude step per column (degrees, signed).
    pub dlon: f64,
    /// Latitude step per row (degrees, signed; negative for north-up).
    pub dlat: f64,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Heights (m), row-major; NaN where the file has no data.
    pub data: Vec<f32>,
}

impl Tile {
    /// Fractional column and row of a point.
    pub fn raster(&self, lat: f64, lon: f64) -> (f64, f64) {
        ((lon - self.lon0) / self.dlon, (lat - self.lat0) / self.dlat)
    }

    /// Latitude and longitude bounds of the area the pixels cover
    /// (south, north, west, east; degrees).
    pub fn bounds(&self) -> [f64; 4] {
        let lat_a = self.lat0 - 0.5 * self.dlat;
        let lat_b = self.lat0 + (self.height as f64 - 0.5) * self.dlat;
        let lon_a = self.lon0 - 0.5 * self.dlon;
        let lon_b = self.lon0 + (self.width as f64 - 0.5) * self.dlon;
        [
            lat_a.min(lat_b),
            lat_a.max(lat_b),
            lon_a.min(lon_b),
            lon_a.max(lon_b),
        ]
    }

    fn at(&self, col: usize, row: usize) -> f32 {
        self.data[row * self.width + col]
    }

    /// Bilinear height at fractional raster position (fx, fy), clamped to
    /// the pixel centres' extent; `None` where a pixel used has no data.
    pub fn bilinear(&self, fx: f64, fy: f64) -> Option<f64> {
        let fx = fx.clamp(0.0, (self.width - 1) as f64);
        let fy = fy.clamp(0.0, (self.height - 1) as f64);
        let c0 = (fx.floor() as usize).min(self.width.saturating_sub(2));
        let r0 = (fy.floor() as usize).min(self.height.saturating_sub(2));
        let c1 = (c0 + 1).min(self.width - 1);
        let r1 = (r0 + 1).min(self.height - 1);
        let (tx, ty) = (fx - c0 as f64, fy - r0 as f64);
        let mut sum = 0.0;
        for (c, r, w) in [
            (c0, r0, (1.0 - tx) * (1.0 - ty)),
            (c1, r0, tx * (1.0 - ty)),
            (c0, r1, (1.0 - tx) * ty),
            (c1, r1, tx * ty),
        ] {
            if w == 0.0 {
                continue;
            }
            let v = self.at(c, r);
            if v.is_nan() {
                return None;
            }
            sum += w * f64::from(v);
        }
        Some(sum)
    }
}

/// Reads one tile; `budget` is the number of pixels still allowed (checked
/// from the header, before the raster is decoded).
pub(super) fn read_tile(path: &Path, budget: u64) -> Result<Tile> {
    let bad = |m: String| Error::format(path, m);
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut limits = Limits::default();
    // The header check below bounds the raster; the decoder's own limits
    // must let a raster within it through (8 bytes per sample at most).
    limits.decoding_buffer_size = usize::try_from(budget.saturating_mul(8)).unwrap_or(usize::MAX);
    let mut dec = Decoder::new(std::io::BufReader::new(file))
        .map_err(|e| bad(format!("not a readable TIFF file ({e})")))?
        .with_limits(limits);
    let tiff_err = |e: tiff::TiffError| bad(format!("TIFF decoding failed ({e})"));
    let (w, h) = dec.dimensions().map_err(tiff_err)?;
    let pixels = u64::from(w) * u64::from(h);
    if pixels > budget {
        return Err(bad(format!(
            "the elevation model declares {w} × {h} pixels, above the limit of {} pixels \
             (all [map] elevation files together; crop it to the map with gdal_translate -projwin)",
            super::MAX_DEM_PIXELS
        )));
    }
    if w < 2 || h < 2 {
        return Err(bad(format!(
            "the elevation model is {w} × {h} pixels; bilinear interpolation needs at least 2 × 2"
        )));
    }
    match dec.colortype().map_err(tiff_err)? {
        ColorType::Gray(_) => {}
        ColorType::Multiband { num_samples, .. } => {
            return Err(bad(format!(
                "the raster has {num_samples} bands; an elevation model has one"
            )))
        }
        other => {
            return Err(bad(format!(
                "the raster is {other:?}; an elevation model has one band of heights"
            )))
        }
    }
    let georef = georeference(&mut dec, path)?;
    let nodata = match dec.find_tag(Tag::GdalNodata).map_err(tiff_err)? {
        Some(v) => {
            let s = v.into_string().map_err(tiff_err)?;
            let s = s.trim_matches(|c: char| c == '\0' || c.is_whitespace());
            Some(
                s.parse::<f64>()
                    .map_err(|_| bad(format!("GDAL_NODATA (tag 42113) is {s:?}, not a number")))?,
            )
        }
        None => None,
    };
    let raw = dec.read_image().map_err(tiff_err)?;
    let data = samples(raw, nodata);
    if data.len() != (w as usize) * (h as usize) {
        return Err(bad(format!(
            "the raster holds {} samples for {w} × {h} pixels",
            data.len()
        )));
    }
    let (lon0, lat0, dlon, dlat) = georef;
    let tile = Tile {
        lon0,
        lat0,
        dlon,
        dlat,
        width: w as usize,
        height: h as usize,
        data,
    };
    let [s, n, west, east] = tile.bounds();
    if !(s >= -90.5 && n <= 90.5 && west >= -180.5 && east <= 360.5) {
        return Err(bad(format!(
            "the raster spans latitude {s:.3}..{n:.3}, longitude {west:.3}..{east:.3}: \
             not WGS-84 degrees"
        )));
    }
    Ok(tile)
}

/// Heights as `f32`, NaN for no data (the `GDAL_NODATA` value, and NaN).
fn samples(raw: DecodingResult, nodata: Option<f64>) -> Vec<f32> {
    fn conv<T: Copy + Into<f64>>(v: Vec<T>, nodata: Option<f64>) -> Vec<f32> {
        v.into_iter()
            .map(|x| {
                let x: f64 = x.into();
                if nodata.is_some_and(|n| x == n) {
                    f32::NAN
                } else {
                    x as f32
                }
            })
            .collect()
    }
    match raw {
        DecodingResult::U8(v) => conv(v, nodata),
        DecodingResult::I8(v) => conv(v, nodata),
        DecodingResult::U16(v) => conv(v, nodata),
        DecodingResult::I16(v) => conv(v, nodata),
        DecodingResult::U32(v) => conv(v, nodata),
        DecodingResult::I32(v) => conv(v, nodata),
        DecodingResult::F32(v) => conv(v, nodata),
        DecodingResult::F64(v) => conv(v, nodata),
        DecodingResult::F16(v) => conv(v.into_iter().map(f32::from).collect(), nodata),
        // 64-bit integers: heights far inside ±2^53.
        DecodingResult::U64(v) => conv(v.into_iter().map(|x| x as f64).collect(), nodata),
        DecodingResult::I64(v) => conv(v.into_iter().map(|x| x as f64).collect(), nodata),
    }
}

/// The GeoKeys as (id, inline SHORT value) pairs; keys stored in the
/// double or ASCII parameter tags are not needed here and are left out.
fn geokeys(dir: &[u16]) -> Vec<(u16, u16)> {
    let n = dir.get(3).copied().unwrap_or(0) as usize;
    dir.get(4..)
        .unwrap_or(&[])
        .chunks_exact(4)
        .take(n)
        .filter(|k| k[1] == 0 && k[2] == 1)
        .map(|k| (k[0], k[3]))
        .collect()
}

/// Checks the CRS (WGS-84 geographic) and returns the centre of pixel
/// (0, 0) and the steps per column and row: (lon0, lat0, dlon, dlat).
fn georeference<R: std::io::Read + std::io::Seek>(
    dec: &mut Decoder<R>,
    path: &Path,
) -> Result<(f64, f64, f64, f64)> {
    let bad = |m: String| Error::format(path, m);
    let tiff_err = |e: tiff::TiffError| bad(format!("TIFF decoding failed ({e})"));
    let Some(dir) = dec.find_tag(Tag::GeoKeyDirectoryTag).map_err(tiff_err)? else {
        return Err(bad(
            "no GeoTIFF georeferencing (GeoKeyDirectory tag 34735 missing): a [map] elevation \
             file must be a GeoTIFF in WGS-84 latitude/longitude (EPSG:4326)"
                .into(),
        ));
    };
    let keys = geokeys(&dir.into_u16_vec().map_err(tiff_err)?);
    let key = |id: u16| keys.iter().find(|k| k.0 == id).map(|k| k.1);
    let reproject = "reproject it with gdalwarp -t_srs EPSG:4326";
    match key(GT_MODEL_TYPE) {
        Some(MODEL_GEOGRAPHIC) => {}
        Some(MODEL_PROJECTED) => {
            let code = key(PROJECTED_CS_TYPE)
                .map(|c| format!(" (EPSG:{c})"))
                .unwrap_or_default();
            return Err(bad(format!(
                "the elevation model is in a projected CRS{code}; waymark reads WGS-84 \
                 latitude/longitude (EPSG:4326): {reproject}"
            )));
        }
        other => {
            return Err(bad(format!(
                "GTModelTypeGeoKey is {}; waymark reads geographic WGS-84 (EPSG:4326) \
                 elevation models: {reproject}",
                other.map_or("missing".to_string(), |v| v.to_string())
            )))
        }
    }
    match (key(GEOGRAPHIC_TYPE), key(GEOG_GEODETIC_DATUM)) {
        (Some(EPSG_WGS84), _) | (None | Some(USER_DEFINED), Some(EPSG_WGS84_DATUM)) => {}
        (g, d) => {
            return Err(bad(format!(
                "the geographic CRS is {} (datum {}), not WGS 84 (EPSG:4326): {reproject}",
                g.map_or("missing".into(), |c| format!("EPSG:{c}")),
                d.map_or("missing".into(), |c| format!("EPSG:{c}")),
            )))
        }
    }
    // Raster space: pixel (c, r) covers [c, c+1) × [r, r+1) (PixelIsArea,
    // the default), or sits at (c, r) (PixelIsPoint).
    let centre = if key(GT_RASTER_TYPE) == Some(RASTER_PIXEL_IS_POINT) {
        0.0
    } else {
        0.5
    };
    let tie = dec.find_tag(Tag::ModelTiepointTag).map_err(tiff_err)?;
    let scale = dec.find_tag(Tag::ModelPixelScaleTag).map_err(tiff_err)?;
    let transform = dec
        .find_tag(Tag::ModelTransformationTag)
        .map_err(tiff_err)?;
    // Longitude = a·i + c, latitude = e·j + f at raster position (i, j).
    let (a, c, e, f) = match (tie, scale, transform) {
        (Some(t), Some(s), _) => {
            let t = t.into_f64_vec().map_err(tiff_err)?;
            let s = s.into_f64_vec().map_err(tiff_err)?;
            if t.len() < 6 || s.len() < 2 {
                return Err(bad(format!(
                    "ModelTiepoint has {} values and ModelPixelScale {}; need 6 and 2",
                    t.len(),
                    s.len()
                )));
            }
            if t.len() > 6 {
                return Err(bad(
                    "several ModelTiepoints (a warped raster): waymark reads a regular grid; \
                     regrid it with gdalwarp -t_srs EPSG:4326"
                        .into(),
                ));
            }
            (s[0], t[3] - t[0] * s[0], -s[1], t[4] + t[1] * s[1])
        }
        (_, _, Some(m)) => {
            let m = m.into_f64_vec().map_err(tiff_err)?;
            if m.len() < 16 {
                return Err(bad(format!(
                    "ModelTransformation has {} values; need 16",
                    m.len()
                )));
            }
            if m[1] != 0.0 || m[4] != 0.0 {
                return Err(bad(
                    "the raster is rotated (ModelTransformation has shear terms); \
                     regrid it north-up with gdalwarp -t_srs EPSG:4326"
                        .into(),
                ));
            }
            (m[0], m[3], m[5], m[7])
        }
        _ => {
            return Err(bad(
                "no ModelTiepoint with ModelPixelScale and no ModelTransformation: \
                 the raster is not georeferenced"
                    .into(),
            ))
        }
    };
    if !(a.is_finite() && e.is_finite() && c.is_finite() && f.is_finite()) || a == 0.0 || e == 0.0 {
        return Err(bad(format!(
            "the pixel size is {a} × {e} degrees: not a usable grid"
        )));
    }
    Ok((c + centre * a, f + centre * e, a, e))
}
