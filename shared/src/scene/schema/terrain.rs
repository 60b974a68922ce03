//! `[[terrain]]`: fixed ground read from a file (a surveyed triangle mesh or a DEM grid), the
//! bathymetry and slopes of a real site. The file is read by [`crate::terrain::Terrain::load`];
//! this module holds the table as written (its checks that need no file: `scene::validate`).

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One `[[terrain]]` entry: a fixed, possibly non-convex, body read from a file.
///
/// The file's coordinates are carried into the scene by x_scene = R·(scale ∘ x_file) + offset,
/// with R the rotation of `rotation` (degrees about x, then y, then z); `crop` then keeps the
/// triangles whose centroid is inside the box (a DEM is cropped, and `decimate`d, while it is
/// read). The ground is under the surface: a mesh's
/// triangles are wound counter-clockwise seen from outside (the water side), a DEM's rows run
/// from north (top line of the file) to south.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TerrainSpec {
    /// Name used in outputs and messages.
    #[serde(default = "default_name")]
    pub name: String,
    /// The file, relative to the scene file (absolute once the scene is loaded from a file):
    /// `.stl` (binary or ASCII), `.obj`, `.ply` triangle meshes, or `.asc` (ESRI ASCII grid)
    /// elevation model.
    pub file: PathBuf,
    /// Added after scaling and rotating [m].
    #[serde(default)]
    pub offset: [f64; 3],
    /// Factor per axis applied to the file's coordinates first (e.g. a vertical exaggeration,
    /// or 0.001 for a mesh in millimetres). Positive.
    #[serde(default = "unit_scale")]
    pub scale: [f64; 3],
    /// Rotation [deg] about x, then y, then z (fixed axes), after scaling.
    #[serde(default)]
    pub rotation: [f64; 3],
    /// Keep only the triangles whose centroid lies in this box (scene coordinates, after the
    /// transform).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crop: Option<CropSpec>,
    /// A DEM only: keep every n-th row and column of the file (n ≥ 1), read so, for a survey
    /// grid finer than the water needs. The crop acts while the file is read too: only the
    /// cells near the crop box are held.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decimate: Option<usize>,
    /// What to do with a DEM's no-data (or NaN) cells: `refuse` (default: the load fails and
    /// names the cells) or `fill` (each takes the mean of its valid neighbours, repeated
    /// inwards until none is left).
    #[serde(default)]
    pub nodata: NoData,
    /// Reverse every triangle's winding: for a mesh exported with its normals pointing into
    /// the ground (the load says so when it finds them).
    #[serde(default)]
    pub flip_normals: bool,
    /// Joint friction angle of block contacts on this terrain [deg]; default
    /// `[solid.contact].friction_angle` (a pair uses the smaller of the two).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction_angle: Option<f64>,
    /// Joint cohesion of block contacts on this terrain [Pa]; default `[solid.contact]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cohesion: Option<f64>,
}

fn default_name() -> String {
    "terrain".into()
}

fn unit_scale() -> [f64; 3] {
    [1.0; 3]
}

/// `crop = { min = [...], max = [...] }`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CropSpec {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// `nodata`: how a DEM's missing cells are treated.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum NoData {
    /// The load fails and names the first missing cell and how many there are.
    #[default]
    Refuse,
    /// Missing cells are filled from their neighbours (mean of the valid 4-neighbours,
    /// repeated until every cell has a value).
    Fill,
}

/// The file formats a terrain may be read from, by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TerrainFormat {
    Stl,
    Obj,
    Ply,
    /// ESRI ASCII grid (`.asc`): a digital elevation model.
    EsriAscii,
    /// GeoTIFF (`.tif`, `.tiff`): a digital elevation model, one band, north-up.
    GeoTiff,
}

impl TerrainFormat {
    /// The format of `path`, from its extension (case-insensitive).
    pub fn of(path: &Path) -> Option<TerrainFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "stl" => Some(TerrainFormat::Stl),
            "obj" => Some(TerrainFormat::Obj),
            "ply" => Some(TerrainFormat::Ply),
            "asc" => Some(TerrainFormat::EsriAscii),
            "tif" | "tiff" => Some(TerrainFormat::GeoTiff),
            _ => None,
        }
    }
}

impl TerrainSpec {
    /// Makes a relative `file` relative to `base` (the scene file's directory), absolute.
    pub fn resolve(&mut self, base: &Path) {
        if self.file.is_relative() {
            let joined = base.join(&self.file);
            self.file = std::path::absolute(&joined).unwrap_or(joined);
        }
    }
}
