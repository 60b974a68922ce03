//! Digital elevation models in GeoTIFF (`.tif`, `.tiff`), read with georust's `geotiff` crate
//! (pure Rust, on the `tiff` decoder: no GDAL, no system library).
//!
//! Accepted: one band of elevations on a north-up grid of square cells, georeferenced by a tie
//! point and a pixel scale (or an affine transformation without rotation; a rotated grid is
//! refused: the terrain's own `rotation` does that). No-data cells are those equal to GDAL's
//! no-data tag (42113, `GDAL_NODATA`) or NaN. The grid becomes the same [`Grid`] as an ESRI
//! ASCII grid's (cell centres, rows from the north), so both formats triangulate, fill and
//! check alike. Vertical and horizontal units are taken as metres, like every scene length;
//! a geographic (degrees) grid must be projected first (or scaled with the terrain's `scale`).

use super::dem::Grid;
use geotiff::GeoTiff;
use std::io::{BufReader, Seek};
use std::path::Path;
use tiff::decoder::Decoder;
use tiff::tags::Tag;

/// Reads a GeoTIFF elevation model.
pub fn read(path: &Path) -> Result<Grid, String> {
    let file =
        std::fs::File::open(path).map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let mut reader = BufReader::new(file);
    let tags = georeferencing(&mut reader).map_err(|e| format!("'{}': {e}", path.display()))?;
    reader
        .rewind()
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let tif = GeoTiff::read(reader)
        .map_err(|e| format!("'{}': not a readable GeoTIFF: {e}", path.display()))?;
    grid(&tif, &tags).map_err(|e| format!("'{}': {e}", path.display()))
}

/// What the `geotiff` crate does not hand out: whether the file is georeferenced, whether its
/// transformation rotates, and the no-data value.
struct Tags {
    nodata: Option<f64>,
}

fn georeferencing<R: std::io::Read + Seek>(reader: &mut R) -> Result<Tags, String> {
    let mut d = Decoder::new(reader).map_err(|e| format!("not a TIFF file: {e}"))?;
    let mut f64s = |tag: Tag| -> Result<Option<Vec<f64>>, String> {
        d.find_tag(tag)
            .map_err(|e| e.to_string())?
            .map(|v| v.into_f64_vec().map_err(|e| e.to_string()))
            .transpose()
    };
    let scale = f64s(Tag::ModelPixelScaleTag)?;
    let transformation = f64s(Tag::ModelTransformationTag)?;
    if scale.is_none() && transformation.is_none() {
        return Err("has no georeferencing (no ModelPixelScale or ModelTransformation tag): a plain TIFF image, not a DEM".into());
    }
    if let Some(t) = &transformation
        && t.len() >= 6
        && (t[1] != 0.0 || t[4] != 0.0)
    {
        return Err(
            "is a rotated grid (its ModelTransformation has shear terms); give a north-up grid and rotate it with the terrain's `rotation`"
                .into(),
        );
    }
    let nodata = d
        .find_tag(Tag::GdalNodata)
        .map_err(|e| e.to_string())?
        .map(|v| v.into_string().map_err(|e| e.to_string()))
        .transpose()?
        .map(|s| {
            let s = s.trim_matches(|c: char| c == '\0' || c.is_whitespace());
            s.parse::<f64>()
                .map_err(|_| format!("its GDAL no-data tag `{s}` is not a number"))
        })
        .transpose()?;
    Ok(Tags { nodata })
}

fn grid(tif: &GeoTiff, tags: &Tags) -> Result<Grid, String> {
    if tif.num_samples != 1 {
        return Err(format!(
            "has {} bands; give one band of elevations",
            tif.num_samples
        ));
    }
    let (ncols, nrows) = (tif.raster_width, tif.raster_height);
    if ncols < 2 || nrows < 2 {
        return Err(format!(
            "is {ncols} × {nrows} cells; a DEM needs at least 2 × 2"
        ));
    }
    let extent = tif.model_extent();
    let (cx, cy) = (
        extent.width() / ncols as f64,
        extent.height() / nrows as f64,
    );
    if !(cx > 0.0 && (cx - cy).abs() <= 1e-9 * cx.max(cy)) {
        return Err(format!(
            "has cells of {cx} × {cy} (x × y); only square cells are read: resample the grid"
        ));
    }
    let (west, north) = (extent.min().x, extent.max().y);
    let mut z = Vec::with_capacity(ncols * nrows);
    for r in 0..nrows {
        let y = north - (r as f64 + 0.5) * cx;
        for c in 0..ncols {
            let at = geo_types::Coord {
                x: west + (c as f64 + 0.5) * cx,
                y,
            };
            let v: Option<f64> = tif.get_value_at(&at, 0);
            z.push(v.filter(|v| !v.is_nan() && Some(*v) != tags.nodata));
        }
    }
    Ok(Grid {
        ncols,
        nrows,
        x0: west + 0.5 * cx,
        y0: north - (nrows as f64 - 0.5) * cx,
        cell: cx,
        z,
    })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use tiff::encoder::{TiffEncoder, colortype::Gray32Float};

    /// A 4 × 3 GeoTIFF, upper-left corner at (1000, 2030), 10 m cells, rows from the north.
    pub(crate) fn write(path: &Path, z: &[f32], nodata: Option<&str>, rotated: bool) {
        let file = std::fs::File::create(path).unwrap();
        let mut enc = TiffEncoder::new(file).unwrap();
        let mut image = enc.new_image::<Gray32Float>(4, 3).unwrap();
        let dir = image.encoder();
        if rotated {
            let t = [
                10.0, 1.0, 0.0, 1000.0, 1.0, -10.0, 0.0, 2030.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                1.0,
            ];
            dir.write_tag(Tag::ModelTransformationTag, &t[..]).unwrap();
        } else {
            dir.write_tag(Tag::ModelPixelScaleTag, &[10.0f64, 10.0, 0.0][..])
                .unwrap();
            dir.write_tag(
                Tag::ModelTiepointTag,
                &[0.0f64, 0.0, 0.0, 1000.0, 2030.0, 0.0][..],
            )
            .unwrap();
        }
        // GeoKeyDirectory: version 1.1.0, one key, GTRasterTypeGeoKey = RasterPixelIsArea.
        dir.write_tag(Tag::GeoKeyDirectoryTag, &[1u16, 1, 0, 1, 1025, 0, 1, 1][..])
            .unwrap();
        if let Some(n) = nodata {
            dir.write_tag(Tag::GdalNodata, n).unwrap();
        }
        image.write_data(z).unwrap();
    }

    /// The ESRI ASCII grid of the 4 × 3 heights `z` the tests write as GeoTIFF (10 m cells,
    /// corner at (1000, 2000)).
    pub(crate) fn ascii_twin(z: &[f32]) -> String {
        let rows: Vec<String> = z
            .chunks(4)
            .map(|r| {
                r.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(" ")
            })
            .collect();
        format!(
            "ncols 4\nnrows 3\nxllcorner 1000\nyllcorner 2000\ncellsize 10\n{}\n",
            rows.join("\n")
        )
    }

    pub(crate) fn temp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("rw-geotiff-{}-{name}.tif", std::process::id()))
    }

    #[test]
    fn a_geotiff_reads_as_the_same_grid_as_its_ascii_twin() {
        let z: Vec<f32> = (0..12).map(|i| i as f32 * 0.5 - 1.0).collect();
        let path = temp("twin");
        write(&path, &z, None, false);
        let g = read(&path).unwrap();
        let asc = ascii_twin(&z);
        let twin = super::super::dem::parse(&asc).unwrap();
        assert_eq!((g.ncols, g.nrows), (twin.ncols, twin.nrows));
        assert_eq!((g.x0, g.y0, g.cell), (twin.x0, twin.y0, twin.cell));
        assert_eq!((g.x0, g.y0, g.cell), (1005.0, 2005.0, 10.0));
        assert_eq!(g.z, twin.z);
        std::fs::remove_file(&path).unwrap();
    }

    #[test]
    fn no_data_cells_and_bad_grids_are_named() {
        let mut z = vec![1.0f32; 12];
        z[5] = -9999.0;
        z[7] = f32::NAN;
        let path = temp("nodata");
        write(&path, &z, Some("-9999"), false);
        let g = read(&path).unwrap();
        let holes: Vec<usize> = (0..12).filter(|&i| g.z[i].is_none()).collect();

        assert_eq!(holes, [5, 7]);
        write(&path, &z, None, true);
        let e = read(&path).unwrap_err();
        assert!(e.contains("rotated grid") && e.contains("rotation"), "{e}");
        // A plain TIFF image: no georeferencing.
        let file = std::fs::File::create(&path).unwrap();
        TiffEncoder::new(file)
            .unwrap()
            .write_image::<Gray32Float>(4, 3, &z)
            .unwrap();
        let e = read(&path).unwrap_err();
        assert!(e.contains("no georeferencing"), "{e}");
        std::fs::write(&path, "not a tiff").unwrap();
        let e = read(&path).unwrap_err();
        assert!(e.contains("not a TIFF"), "{e}");
        std::fs::remove_file(&path).unwrap();
    }
}
