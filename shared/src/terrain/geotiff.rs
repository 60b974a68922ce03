//! Digital elevation models in GeoTIFF (`.tif`, `.tiff`), read with the pure-Rust `tiff`
//! decoder (no GDAL, no system library) strip by strip or tile by tile: only the strips and
//! tiles that hold kept cells are decoded, one at a time, each bounded by [`MAX_CHUNK_BYTES`],
//! so a survey grid far larger than memory (or a small file that inflates to gigabytes) costs
//! what its cropped window keeps.
//!
//! Accepted: one band of elevations on a north-up grid of square cells, georeferenced by a tie
//! point and a pixel scale (or an affine transformation without rotation; a rotated grid is
//! refused: the terrain's own `rotation` does that), pixel-is-area or pixel-is-point. No-data
//! cells are those equal to GDAL's no-data tag (42113, `GDAL_NODATA`) or NaN. The grid becomes
//! the same [`Grid`] as an ESRI ASCII grid's (cell centres, rows from the north), so both
//! formats crop, triangulate, fill and check alike. Vertical and horizontal units are taken as
//! metres, like every scene length; a geographic (degrees) grid must be projected first (or
//! scaled with the terrain's `scale`).

use super::dem::{Grid, Header, Window};
use std::io::BufReader;
use std::path::Path;
use tiff::TiffError;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

/// The most bytes one strip or tile may decode to. Survey GeoTIFFs hold strips of a few rows or
/// tiles of 256 × 256 cells (kilobytes to a megabyte); 64 MiB admits a 4 000 × 4 000 grid of
/// f32 saved as a single strip, and refuses a small deflate-compressed file that claims
/// gigabytes in one strip before any of it is decoded.
pub const MAX_CHUNK_BYTES: usize = 64 << 20;

/// The GeoKey of the raster type (GTRasterTypeGeoKey) and its pixel-is-point value.
const RASTER_TYPE_KEY: u16 = 1025;
const PIXEL_IS_POINT: u16 = 2;

/// A GeoTIFF whose georeferencing has been read: [`Self::read`] then decodes the strips or
/// tiles that hold the cells a [`Window`] keeps.
pub struct TifReader {
    decoder: Decoder<BufReader<std::fs::File>>,
    header: Header,
    /// The file's columns run west, its rows run north (a grid flipped about an axis).
    flipped: [bool; 2],
}

/// Opens a GeoTIFF elevation model and reads its georeferencing.
pub fn open(path: &Path) -> Result<TifReader, String> {
    open_with(path, MAX_CHUNK_BYTES)
}

/// Reads a whole GeoTIFF elevation model.
pub fn read(path: &Path) -> Result<Grid, String> {
    let r = open(path)?;
    let w = Window::all(r.header(), 1);
    r.read(&w).map_err(|e| format!("'{}': {e}", path.display()))
}

fn open_with(path: &Path, chunk_bytes: usize) -> Result<TifReader, String> {
    let file =
        std::fs::File::open(path).map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let mut limits = Limits::default();
    limits.decoding_buffer_size = chunk_bytes;
    limits.intermediate_buffer_size = MAX_CHUNK_BYTES;
    let decoder = Decoder::new(BufReader::new(file))
        .map_err(|e| format!("'{}': not a TIFF file: {e}", path.display()))?
        .with_limits(limits);
    TifReader::new(decoder).map_err(|e| format!("'{}': {e}", path.display()))
}

impl TifReader {
    fn new(mut d: Decoder<BufReader<std::fs::File>>) -> Result<TifReader, String> {
        let mut f64s = |tag: Tag| -> Result<Option<Vec<f64>>, String> {
            d.find_tag(tag)
                .map_err(|e| e.to_string())?
                .map(|v| v.into_f64_vec().map_err(|e| e.to_string()))
                .transpose()
        };
        let scale = f64s(Tag::ModelPixelScaleTag)?;
        let tie = f64s(Tag::ModelTiepointTag)?;
        let transformation = f64s(Tag::ModelTransformationTag)?;
        // Raster (column, row) to model (x, y).
        let model: Box<dyn Fn(f64, f64) -> (f64, f64)> = match (&transformation, &scale, &tie) {
            (None, None, _) => {
                return Err("has no georeferencing (no ModelPixelScale or ModelTransformation tag): a plain TIFF image, not a DEM".into());
            }
            (Some(t), _, _) => {
                if t.len() != 16 {
                    return Err(format!(
                        "its ModelTransformation holds {} values, not 16",
                        t.len()
                    ));
                }
                if t[1] != 0.0 || t[4] != 0.0 {
                    return Err(
                        "is a rotated grid (its ModelTransformation has shear terms); give a north-up grid and rotate it with the terrain's `rotation`"
                            .into(),
                    );
                }
                let t = [t[0], t[1], t[3], t[4], t[5], t[7]];
                Box::new(move |i, j| (t[0] * i + t[1] * j + t[2], t[3] * i + t[4] * j + t[5]))
            }
            (None, Some(s), Some(p)) if s.len() >= 2 && p.len() == 6 => {
                let (s, p) = ([s[0], s[1]], [p[0], p[1], p[3], p[4]]);
                Box::new(move |i, j| ((i - p[0]) * s[0] + p[2], (j - p[1]) * -s[1] + p[3]))
            }
            (None, Some(_), _) => {
                return Err("is georeferenced by a pixel scale without exactly one tie point (six values); give one tie point, or a ModelTransformation".into());
            }
        };
        let keys = d
            .find_tag(Tag::GeoKeyDirectoryTag)
            .map_err(|e| e.to_string())?
            .map(|v| v.into_u16_vec().map_err(|e| e.to_string()))
            .transpose()?
            .unwrap_or_default();
        let point = keys
            .chunks_exact(4)
            .skip(1)
            .any(|k| k[0] == RASTER_TYPE_KEY && k[1] == 0 && k[3] == PIXEL_IS_POINT);
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
        let samples = d
            .find_tag_unsigned::<u16>(Tag::SamplesPerPixel)
            .map_err(|e| e.to_string())?
            .unwrap_or(1);
        if samples != 1 {
            return Err(format!("has {samples} bands; give one band of elevations"));
        }
        let (ncols, nrows) = d.dimensions().map_err(|e| e.to_string())?;
        let (ncols, nrows) = (ncols as usize, nrows as usize);
        if ncols < 2 || nrows < 2 {
            return Err(format!(
                "is {ncols} × {nrows} cells; a DEM needs at least 2 × 2"
            ));
        }
        // The corners of the raster in model space: pixel-is-point grids are shifted half a
        // cell (GeoTIFF 1.1, raster space).
        let off = if point { -0.5 } else { 0.0 };
        let lower = model(off, off);
        let upper = model(ncols as f64 + off, nrows as f64 + off);
        let (west, east) = (lower.0.min(upper.0), lower.0.max(upper.0));
        let (south, north) = (lower.1.min(upper.1), lower.1.max(upper.1));
        let (cx, cy) = ((east - west) / ncols as f64, (north - south) / nrows as f64);
        if !(cx > 0.0 && (cx - cy).abs() <= 1e-9 * cx.max(cy)) {
            return Err(format!(
                "has cells of {cx} × {cy} (x × y); only square cells are read: resample the grid"
            ));
        }
        Ok(TifReader {
            decoder: d,
            header: Header {
                ncols,
                nrows,
                x0: west + 0.5 * cx,
                y0: north - (nrows as f64 - 0.5) * cx,
                cell: cx,
                nodata,
            },
            flipped: [upper.0 < lower.0, upper.1 > lower.1],
        })
    }

    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Decodes the strips or tiles that hold the cells `w` keeps, one at a time, and keeps
    /// those cells.
    pub fn read(mut self, w: &Window) -> Result<Grid, String> {
        let h = &self.header;
        let mut g = h.grid_of(w);
        let (cw, ch) = self.decoder.chunk_dimensions();
        let (cw, ch) = (cw as usize, ch as usize);
        if cw == 0 || ch == 0 {
            return Err(format!("has strips or tiles of {cw} × {ch} cells"));
        }
        let across = h.ncols.div_ceil(cw);
        // The window in the file's own rows and columns (the same, or mirrored).
        let file = |range: (usize, usize), n: usize, flip: bool| {
            if flip {
                (n - range.1, n - range.0)
            } else {
                range
            }
        };
        let rows = file(w.rows, h.nrows, self.flipped[1]);
        let cols = file(w.cols, h.ncols, self.flipped[0]);
        if rows.0 >= rows.1 || cols.0 >= cols.1 {
            return Ok(g);
        }
        let unflip = |i: usize, n: usize, flip: bool| if flip { n - 1 - i } else { i };
        for ty in rows.0 / ch..=(rows.1 - 1) / ch {
            for tx in cols.0 / cw..=(cols.1 - 1) / cw {
                let index = ty * across + tx;
                let chunk = self
                    .decoder
                    .read_chunk(u32::try_from(index).map_err(|e| e.to_string())?)
                    .map_err(|e| match e {
                        TiffError::LimitsExceeded => format!(
                            "a strip or tile decodes to more than {MAX_CHUNK_BYTES} bytes (MAX_CHUNK_BYTES); fix: save the grid in strips or tiles (e.g. gdal_translate -co TILED=YES)"
                        ),
                        e => format!("strip or tile {index} cannot be decoded: {e}"),
                    })?;
                let (dw, dh) = (cw.min(h.ncols - tx * cw), ch.min(h.nrows - ty * ch));
                if len(&chunk) < dw * dh {
                    return Err(format!(
                        "strip or tile {index} holds {} values, not {dw} × {dh}",
                        len(&chunk)
                    ));
                }
                for j in 0..dh {
                    let row = unflip(ty * ch + j, h.nrows, self.flipped[1]);
                    for i in 0..dw {
                        let col = unflip(tx * cw + i, h.ncols, self.flipped[0]);
                        if let Some((r, c)) = w.keep(row, col) {
                            let v = value(&chunk, j * dw + i);
                            g.z[r * g.ncols + c] =
                                (!v.is_nan() && Some(v) != h.nodata).then_some(v);
                        }
                    }
                }
            }
        }
        Ok(g)
    }
}

/// Writes a one-band f32 GeoTIFF DEM of `ncols` × `nrows` cells of side `cell`, its north-west
/// corner at `corner`, elevations `z` row-major from the north, in strips of `rows_per_strip`
/// rows (deflate-compressed if asked): what tests and benchmarks generate. (The `tiff`
/// encoder compresses only a whole image written at once, so `z` is whole.)
pub fn write(
    path: &Path,
    (ncols, nrows): (u32, u32),
    corner: [f64; 2],
    cell: f64,
    rows_per_strip: u32,
    deflate: bool,
    z: &[f32],
) -> Result<(), String> {
    use tiff::encoder::TiffEncoder;
    use tiff::encoder::compression::{Compression, Deflate, DeflateLevel, Uncompressed};
    fn write<C: Compression>(
        enc: &mut TiffEncoder<std::io::BufWriter<std::fs::File>>,
        (ncols, nrows): (u32, u32),
        tags: ([f64; 3], [f64; 6]),
        rows_per_strip: u32,
        compression: C,
        z: &[f32],
    ) -> tiff::TiffResult<()> {
        use tiff::encoder::colortype::Gray32Float;
        let mut image =
            enc.new_image_with_compression::<Gray32Float, C>(ncols, nrows, compression)?;
        image.rows_per_strip(rows_per_strip)?;
        let dir = image.encoder();
        dir.write_tag(Tag::ModelPixelScaleTag, &tags.0[..])?;
        dir.write_tag(Tag::ModelTiepointTag, &tags.1[..])?;
        // GeoKeyDirectory: version 1.1.0, one key, GTRasterTypeGeoKey = RasterPixelIsArea.
        dir.write_tag(
            Tag::GeoKeyDirectoryTag,
            &[1u16, 1, 0, 1, RASTER_TYPE_KEY, 0, 1, 1][..],
        )?;
        image.write_data(z)
    }
    let file = std::fs::File::create(path)
        .map_err(|e| format!("cannot create '{}': {e}", path.display()))?;
    let mut enc = TiffEncoder::new(std::io::BufWriter::new(file)).map_err(|e| e.to_string())?;
    let tags = (
        [cell, cell, 0.0],
        [0.0, 0.0, 0.0, corner[0], corner[1], 0.0],
    );
    let size = (ncols, nrows);
    if deflate {
        let d = Deflate::with_level(DeflateLevel::Fast);
        write(&mut enc, size, tags, rows_per_strip, d, z)
    } else {
        write(&mut enc, size, tags, rows_per_strip, Uncompressed, z)
    }
    .map_err(|e| format!("cannot write '{}': {e}", path.display()))
}

fn len(d: &DecodingResult) -> usize {
    match d {
        DecodingResult::U8(v) => v.len(),
        DecodingResult::U16(v) => v.len(),
        DecodingResult::U32(v) => v.len(),
        DecodingResult::U64(v) => v.len(),
        DecodingResult::F32(v) => v.len(),
        DecodingResult::F64(v) => v.len(),
        DecodingResult::I8(v) => v.len(),
        DecodingResult::I16(v) => v.len(),
        DecodingResult::I32(v) => v.len(),
        DecodingResult::I64(v) => v.len(),
    }
}

#[inline]
fn value(d: &DecodingResult, i: usize) -> f64 {
    match d {
        DecodingResult::U8(v) => v[i] as f64,
        DecodingResult::U16(v) => v[i] as f64,
        DecodingResult::U32(v) => v[i] as f64,
        DecodingResult::U64(v) => v[i] as f64,
        DecodingResult::F32(v) => v[i] as f64,
        DecodingResult::F64(v) => v[i],
        DecodingResult::I8(v) => v[i] as f64,
        DecodingResult::I16(v) => v[i] as f64,
        DecodingResult::I32(v) => v[i] as f64,
        DecodingResult::I64(v) => v[i] as f64,
    }
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

    /// A grid stored south-up and east-to-west (a transformation with a positive row step and
    /// a negative column step) reads as the same north-up grid as its plain twin.
    #[test]
    fn a_grid_stored_flipped_reads_as_its_north_up_twin() {
        let z: Vec<f32> = (0..12).map(|i| i as f32 * 0.5 - 1.0).collect();
        let flipped: Vec<f32> = (0..12).map(|i| z[(2 - i / 4) * 4 + (3 - i % 4)]).collect();
        let (plain, other) = (temp("plain"), temp("flipped"));
        write(&plain, &z, None, false);
        let file = std::fs::File::create(&other).unwrap();
        let mut enc = TiffEncoder::new(file).unwrap();
        let mut image = enc.new_image::<Gray32Float>(4, 3).unwrap();
        let t = [
            -10.0, 0.0, 0.0, 1040.0, 0.0, 10.0, 0.0, 2000.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ];
        let dir = image.encoder();
        dir.write_tag(Tag::ModelTransformationTag, &t[..]).unwrap();
        image.write_data(&flipped).unwrap();
        let (a, b) = (read(&plain).unwrap(), read(&other).unwrap());
        assert_eq!((a.x0, a.y0, a.cell), (b.x0, b.y0, b.cell));
        assert_eq!(a.z, b.z);
        std::fs::remove_file(&plain).unwrap();
        std::fs::remove_file(&other).unwrap();
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
        // A strip that decodes past the chunk limit (here 1 KiB) is refused, naming it.
        let one_strip = vec![1.0f32; 40 * 30];
        super::write(&path, (40, 30), [0.0, 30.0], 1.0, 30, true, &one_strip).unwrap();
        let e = open_with(&path, 1024)
            .and_then(|r| {
                let w = Window::all(r.header(), 1);
                r.read(&w)
            })
            .unwrap_err();
        assert!(
            e.contains("MAX_CHUNK_BYTES") && e.contains("fix: save the grid in strips or tiles"),
            "{e}"
        );
        std::fs::write(&path, "not a tiff").unwrap();
        let e = read(&path).unwrap_err();
        assert!(e.contains("not a TIFF"), "{e}");
        std::fs::remove_file(&path).unwrap();
    }
}
