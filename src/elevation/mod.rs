//! Terrain heights from GeoTIFF digital elevation models (`[map] elevation`):
//! SRTM or Copernicus GLO-30 style tiles in WGS-84 latitude/longitude,
//! one band of Int16, UInt16, Int32 or Float32/64 heights, georeferenced by
//! ModelTiepoint + ModelPixelScale or ModelTransformation, no data marked
//! by the GDAL_NODATA tag (42113).
//!
//! * Heights are interpolated bilinearly between the four pixel centres
//!   around a point. Within half a pixel of a tile's border (outside its
//!   pixel centres but inside the area its pixels cover) the neighbourhood
//!   is clamped to the border pixels.
//! * Several tiles: the first tile (in the order given) whose pixel centres
//!   surround the point is used; failing that, the first whose area covers
//!   it.
//! * A point outside every tile, or next to a no-data pixel, is an error
//!   naming the file(s) and the point: there is no silent fallback height;
//!   so is a height outside [`TERRAIN_HEIGHT_RANGE_M`].
//! * Heights are the file's values: for SRTM and GLO-30, metres above the
//!   EGM96 / EGM2008 geoid, not the WGS-84 ellipsoid (a constant offset over
//!   a map's extent to within a few decimetres: the barometer and the
//!   navigator see height changes, which it does not alter).
//!
//! [`HeightProfile`] turns heights sampled along a route into the smoothed
//! profile a vehicle drives.

mod geotiff;
mod profile;

pub use profile::{HeightProfile, PROFILE_HALF_WINDOW_M, PROFILE_STEP_M};

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Most pixels of all `[map] elevation` files together: 2^27 (a 512 MiB
/// raster as f32; ten Copernicus GLO-30 1° tiles of 3600 × 3600 fit).
/// Checked from each file's header before its raster is decoded.
pub const MAX_DEM_PIXELS: u64 = 1 << 27;

/// Terrain heights a route may take from an elevation model (m): as a
/// scenario's heights (`route[0].height_m`, a tag's `height_m`), from
/// below the Dead Sea's shore to above Everest. A height beyond is a
/// damaged pixel or another unit, and it made the navigator diverge (at
/// 3e38 m) or run 1000 km above the ground (at 1e6 m) without a word about
/// the file.
pub const TERRAIN_HEIGHT_RANGE_M: (f64, f64) = (-1000.0, 10_000.0);

/// A digital elevation model: one or more GeoTIFF tiles.
#[derive(Debug, Clone)]
pub struct Dem {
    files: Vec<PathBuf>,
    tiles: Vec<geotiff::Tile>,
}

impl Dem {
    /// Reads the tiles (at least one); errors name the file.
    pub fn open(files: &[PathBuf]) -> Result<Dem> {
        if files.is_empty() {
            return Err(Error::InvalidParameter(
                "an elevation model needs at least one file".into(),
            ));
        }
        let mut budget = MAX_DEM_PIXELS;
        let mut tiles = Vec::with_capacity(files.len());
        for f in files {
            let t = geotiff::read_tile(f, budget)?;
            budget -= (t.width * t.height) as u64;
            tiles.push(t);
        }
        Ok(Dem {
            files: files.to_vec(),
            tiles,
        })
    }

    /// The files, as given.
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// The files' names, comma-separated (for messages and metadata).
    pub fn describe(&self) -> String {
        self.files
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Bounds of each tile: south, north, west, east (degrees).
    pub fn bounds(&self) -> Vec<[f64; 4]> {
        self.tiles.iter().map(|t| t.bounds()).collect()
    }

    /// The terrain height (m) at a latitude and longitude (degrees).
    pub fn height(&self, lat_deg: f64, lon_deg: f64) -> Result<f64> {
        let mut fallback = None;
        for (i, t) in self.tiles.iter().enumerate() {
            let (fx, fy) = t.raster(lat_deg, lon_deg);
            let (w, h) = ((t.width - 1) as f64, (t.height - 1) as f64);
            if (0.0..=w).contains(&fx) && (0.0..=h).contains(&fy) {
                return self.value(i, t.bilinear(fx, fy), lat_deg, lon_deg);
            }
            if fallback.is_none()
                && (-0.5..=w + 0.5).contains(&fx)
                && (-0.5..=h + 0.5).contains(&fy)
            {
                fallback = Some((i, fx, fy));
            }
        }
        if let Some((i, fx, fy)) = fallback {
            return self.value(i, self.tiles[i].bilinear(fx, fy), lat_deg, lon_deg);
        }
        let cover = self
            .bounds()
            .iter()
            .map(|[s, n, w, e]| format!("latitude {s:.4}..{n:.4}, longitude {w:.4}..{e:.4}"))
            .collect::<Vec<_>>()
            .join("; ");
        Err(self.error(
            0,
            format!(
                "the elevation model does not cover {lat_deg:.6}, {lon_deg:.6} \
                 (it covers {cover}): give a DEM covering the map"
            ),
        ))
    }

    fn value(&self, tile: usize, v: Option<f64>, lat: f64, lon: f64) -> Result<f64> {
        let h = v.ok_or_else(|| {
            self.error(
                tile,
                format!("no height at {lat:.6}, {lon:.6}: a pixel next to it is no data (GDAL_NODATA or NaN)"),
            )
        })?;
        let (lo, hi) = TERRAIN_HEIGHT_RANGE_M;
        if !(lo..=hi).contains(&h) {
            return Err(self.error(
                tile,
                format!(
                    "the height at {lat:.6}, {lon:.6} is {} m, outside {lo} to {hi} m: not a \
                     terrain height (a damaged pixel, heights not in metres, or no data \
                     without a GDAL_NODATA tag)",
                    crate::decimal::short_number(h.round())
                ),
            ));
        }
        Ok(h)
    }

    fn error(&self, tile: usize, message: String) -> Error {
        let path = if self.files.len() == 1 || message.contains("does not cover") {
            PathBuf::from(self.describe())
        } else {
            self.files[tile].clone()
        };
        Error::format(Path::new(&path), message)
    }
}
