//! VTK XML PolyData writers (.vtp) for ParaView: particles as points, blocks as polygons.
//! The coupler lists the frames in a .pvd series so ParaView opens a whole run at once.
//!
//! Frames are binary by default (`output.vtk_format = "binary"`): the XML header lists each
//! DataArray with `format="appended"` and an offset into one raw `<AppendedData>` block of
//! little-endian bytes, every array prefixed by its UInt64 byte count. `"ascii"` writes the
//! numbers as text inside the XML. [`read_vtp`] reads both back.
//!
//! Files are written to a temporary name and renamed, so a run killed mid-write never leaves
//! a truncated frame behind.

use crate::scene::VtkFormat;
use std::borrow::Cow;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

fn atomically(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = path.with_extension("vtp.partial");
    let mut w = BufWriter::new(File::create(&tmp)?);
    body(&mut w)?;
    w.flush()?;
    drop(w);
    std::fs::rename(tmp, path)
}

/// The numbers of one DataArray as the writers hold them. Positions and point data are the
/// simulation's f64 values, written as Float64 (no rounding to f32); indices are Int64.
enum Values<'a> {
    Scalars(Cow<'a, [f64]>),
    Vectors(Cow<'a, [[f64; 3]]>),
    Ints(Vec<i64>),
}

impl Values<'_> {
    fn header(&self) -> (&'static str, &'static str) {
        match self {
            Values::Scalars(_) => ("Float64", ""),
            Values::Vectors(_) => ("Float64", r#" NumberOfComponents="3""#),
            Values::Ints(_) => ("Int64", ""),
        }
    }

    fn byte_len(&self) -> usize {
        match self {
            Values::Scalars(v) => 8 * v.len(),
            Values::Vectors(v) => 24 * v.len(),
            Values::Ints(v) => 8 * v.len(),
        }
    }

    /// The values as text, each followed by a space (the ASCII layout of earlier versions).
    fn write_ascii<W: Write>(&self, w: &mut W) -> io::Result<()> {
        match self {
            Values::Scalars(v) => v.iter().try_for_each(|v| write!(w, "{v} ")),
            Values::Vectors(v) => v
                .iter()
                .try_for_each(|v| write!(w, "{} {} {} ", v[0], v[1], v[2])),
            Values::Ints(v) => v.iter().try_for_each(|v| write!(w, "{v} ")),
        }
    }

    /// The values' little-endian bytes.
    fn write_raw<W: Write>(&self, w: &mut W) -> io::Result<()> {
        let mut buf = Vec::with_capacity(self.byte_len());
        match self {
            Values::Scalars(v) => v.iter().for_each(|v| buf.extend(v.to_le_bytes())),
            Values::Vectors(v) => v.iter().flatten().for_each(|v| buf.extend(v.to_le_bytes())),
            Values::Ints(v) => v.iter().for_each(|v| buf.extend(v.to_le_bytes())),
        }
        w.write_all(&buf)
    }
}

/// One `<Points>`, `<Verts>`, `<Polys>`, `<PointData>` or `<CellData>` element and its arrays.
struct Section<'a> {
    tag: &'static str,
    arrays: Vec<(&'a str, Values<'a>)>,
}

/// Writes one PolyData piece. ASCII puts every number inside its DataArray; binary writes each
/// DataArray as `format="appended"` with an `offset` into one `<AppendedData encoding="raw">`
/// block after the XML, where each array is a UInt64 byte count followed by its bytes.
fn write_polydata<W: Write>(
    w: &mut W,
    format: VtkFormat,
    piece: &str,
    sections: &[Section<'_>],
) -> io::Result<()> {
    writeln!(w, r#"<?xml version="1.0"?>"#)?;
    let header = match format {
        VtkFormat::Ascii => "",
        VtkFormat::Binary => r#" header_type="UInt64""#,
    };
    writeln!(
        w,
        r#"<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian"{header}>"#
    )?;
    writeln!(w, "<PolyData>")?;
    writeln!(w, "<Piece {piece}>")?;
    let mut offset = 0usize;
    for section in sections {
        writeln!(w, "<{}>", section.tag)?;
        for (name, values) in &section.arrays {
            let (ty, components) = values.header();
            match format {
                VtkFormat::Ascii => {
                    writeln!(
                        w,
                        r#"<DataArray type="{ty}" Name="{name}"{components} format="ascii">"#
                    )?;
                    values.write_ascii(w)?;
                    writeln!(w, "\n</DataArray>")?;
                }
                VtkFormat::Binary => {
                    writeln!(
                        w,
                        r#"<DataArray type="{ty}" Name="{name}"{components} format="appended" offset="{offset}"/>"#
                    )?;
                    offset += 8 + values.byte_len();
                }
            }
        }
        writeln!(w, "</{}>", section.tag)?;
    }
    writeln!(w, "</Piece>\n</PolyData>")?;
    if format == VtkFormat::Binary {
        write!(w, "<AppendedData encoding=\"raw\">\n_")?;
        for values in sections.iter().flat_map(|s| s.arrays.iter().map(|a| &a.1)) {
            w.write_all(&(values.byte_len() as u64).to_le_bytes())?;
            values.write_raw(w)?;
        }
        writeln!(w, "\n</AppendedData>")?;
    }
    writeln!(w, "</VTKFile>")
}

/// Writes particles as vertices with point data (scalars such as density and pressure, vectors
/// such as velocity), in `format`.
pub fn write_particles(
    path: &Path,
    positions: &[[f64; 3]],
    point_scalars: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 3]])],
    format: VtkFormat,
) -> io::Result<()> {
    let n = positions.len();
    let piece = format!(
        r#"NumberOfPoints="{n}" NumberOfVerts="{n}" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0""#
    );
    let mut data: Vec<(&str, Values)> = point_scalars
        .iter()
        .map(|(name, v)| (*name, Values::Scalars(Cow::Borrowed(*v))))
        .collect();
    data.extend(
        point_vectors
            .iter()
            .map(|(name, v)| (*name, Values::Vectors(Cow::Borrowed(*v)))),
    );
    let sections = [
        Section {
            tag: "Points",
            arrays: vec![("Points", Values::Vectors(Cow::Borrowed(positions)))],
        },
        Section {
            tag: "Verts",
            arrays: vec![
                ("connectivity", Values::Ints((0..n as i64).collect())),
                ("offsets", Values::Ints((1..=n as i64).collect())),
            ],
        },
        Section {
            tag: "PointData",
            arrays: data,
        },
    ];
    atomically(path, |w| write_polydata(w, format, &piece, &sections))
}

/// One block for [`write_polyhedra`]: world-frame corners and faces as corner index lists.
pub type PolyhedronRef<'a> = (&'a [[f64; 3]], &'a [Vec<u32>]);

/// Writes blocks as closed polygon surfaces: per block its world-frame corners and its faces
/// (vertex index lists into those corners); `cell_scalars` hold one value per block.
pub fn write_polyhedra(
    path: &Path,
    blocks: &[PolyhedronRef<'_>],
    cell_scalars: &[(&str, &[f64])],
    format: VtkFormat,
) -> io::Result<()> {
    let n_points: usize = blocks.iter().map(|b| b.0.len()).sum();
    let n_polys: usize = blocks.iter().map(|b| b.1.len()).sum();
    let piece = format!(
        r#"NumberOfPoints="{n_points}" NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="{n_polys}""#
    );
    let all: Vec<[f64; 3]> = blocks.iter().flat_map(|b| b.0.iter().copied()).collect();
    let mut base = 0i64;
    let mut connectivity = Vec::new();
    let mut offsets = Vec::new();
    for (verts, faces) in blocks {
        for f in faces.iter() {
            connectivity.extend(f.iter().map(|&i| base + i64::from(i)));
            offsets.push(connectivity.len() as i64);
        }
        base += verts.len() as i64;
    }
    let cells = cell_scalars
        .iter()
        .map(|(name, per_block)| {
            // One value per face, repeated from the block's value.
            let per_face: Vec<f64> = blocks
                .iter()
                .zip(per_block.iter())
                .flat_map(|(b, &v)| std::iter::repeat_n(v, b.1.len()))
                .collect();
            (*name, Values::Scalars(Cow::Owned(per_face)))
        })
        .collect();
    let sections = [
        Section {
            tag: "Points",
            arrays: vec![("Points", Values::Vectors(Cow::Owned(all)))],
        },
        Section {
            tag: "Polys",
            arrays: vec![
                ("connectivity", Values::Ints(connectivity)),
                ("offsets", Values::Ints(offsets)),
            ],
        },
        Section {
            tag: "CellData",
            arrays: cells,
        },
    ];
    atomically(path, |w| write_polydata(w, format, &piece, &sections))
}

/// The numbers of a DataArray read back: floating-point types as f64, integer types as i64.
#[derive(Debug, Clone, PartialEq)]
pub enum ArrayValues {
    Float64(Vec<f64>),
    Int64(Vec<i64>),
}

impl ArrayValues {
    pub fn len(&self) -> usize {
        match self {
            ArrayValues::Float64(v) => v.len(),
            ArrayValues::Int64(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every value as f64 (integers convert exactly below 2^53).
    pub fn to_f64(&self) -> Vec<f64> {
        match self {
            ArrayValues::Float64(v) => v.clone(),
            ArrayValues::Int64(v) => v.iter().map(|&i| i as f64).collect(),
        }
    }
}

/// One DataArray of a .vtp file: the element it sits in (`Points`, `Verts`, `Polys`,
/// `PointData`, `CellData`, …), its name, components per tuple and values.
#[derive(Debug, Clone, PartialEq)]
pub struct DataArray {
    pub section: String,
    pub name: String,
    pub components: usize,
    pub values: ArrayValues,
}

/// A PolyData file read back by [`read_vtp`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VtpFile {
    pub points: usize,
    pub polys: usize,
    pub arrays: Vec<DataArray>,
}

impl VtpFile {
    /// The array `name` inside element `section`.
    pub fn array(&self, section: &str, name: &str) -> Option<&DataArray> {
        self.arrays
            .iter()
            .find(|a| a.section == section && a.name == name)
    }
}

fn invalid(path: &Path, what: impl std::fmt::Display) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("{}: {what}", path.display()),
    )
}

/// The value of attribute `key` in the text of one XML start tag.
fn attribute<'t>(tag: &'t str, key: &str) -> Option<&'t str> {
    let pattern = format!(" {key}=\"");
    let start = tag.find(&pattern)? + pattern.len();
    let len = tag[start..].find('"')?;
    Some(&tag[start..start + len])
}

/// Reads a single-piece PolyData file as [`write_particles`] and [`write_polyhedra`] write it,
/// in either encoding: ASCII DataArrays, or appended raw data with a UInt32 or UInt64 header
/// (little-endian). Base64 (`format="binary"`) and compressed files are refused.
pub fn read_vtp(path: &Path) -> io::Result<VtpFile> {
    let bytes = std::fs::read(path)?;
    let marker = b"<AppendedData";
    let xml_end = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .unwrap_or(bytes.len());
    let appended = if xml_end < bytes.len() {
        let underscore = bytes[xml_end..]
            .iter()
            .position(|&b| b == b'_')
            .ok_or_else(|| invalid(path, "AppendedData without '_'"))?;
        Some(&bytes[xml_end + underscore + 1..])
    } else {
        None
    };
    let xml = std::str::from_utf8(&bytes[..xml_end]).map_err(|e| invalid(path, e))?;
    let mut file = VtpFile::default();
    let mut wide_header = false;
    let mut section = String::new();
    let mut rest = xml;
    while let Some(open) = rest.find('<') {
        let close = rest[open..]
            .find('>')
            .ok_or_else(|| invalid(path, "unterminated tag"))?
            + open;
        let tag = &rest[open + 1..close];
        let after = &rest[close + 1..];
        rest = after;
        let name = tag.split_whitespace().next().unwrap_or("");
        match name {
            "VTKFile" => {
                if attribute(tag, "compressor").is_some() {
                    return Err(invalid(path, "compressed files are not supported"));
                }
                wide_header = attribute(tag, "header_type") == Some("UInt64");
            }
            "Piece" => {
                let count = |key| attribute(tag, key).and_then(|v| v.parse().ok());
                file.points = count("NumberOfPoints").unwrap_or(0);
                file.polys = count("NumberOfPolys").unwrap_or(0);
            }
            "Points" | "Verts" | "Lines" | "Strips" | "Polys" | "PointData" | "CellData" => {
                section = name.to_string();
            }
            "DataArray" => {
                let array_name = attribute(tag, "Name").unwrap_or("").to_string();
                let ty = attribute(tag, "type").unwrap_or("");
                let components = attribute(tag, "NumberOfComponents")
                    .map(|c| c.parse().map_err(|e| invalid(path, e)))
                    .transpose()?
                    .unwrap_or(1);
                let float = match ty {
                    "Float64" | "Float32" => true,
                    "Int64" | "Int32" | "UInt64" | "UInt32" => false,
                    other => return Err(invalid(path, format!("unsupported type '{other}'"))),
                };
                let values = match attribute(tag, "format") {
                    Some("ascii") => {
                        let end = after
                            .find("</DataArray>")
                            .ok_or_else(|| invalid(path, "DataArray not closed"))?;
                        let words = after[..end].split_whitespace();
                        if float {
                            ArrayValues::Float64(
                                words
                                    .map(|w| w.parse().map_err(|e| invalid(path, e)))
                                    .collect::<io::Result<_>>()?,
                            )
                        } else {
                            ArrayValues::Int64(
                                words
                                    .map(|w| w.parse().map_err(|e| invalid(path, e)))
                                    .collect::<io::Result<_>>()?,
                            )
                        }
                    }
                    Some("appended") => {
                        let data =
                            appended.ok_or_else(|| invalid(path, "no AppendedData section"))?;
                        let offset: usize = attribute(tag, "offset")
                            .ok_or_else(|| invalid(path, "appended DataArray without offset"))?
                            .parse()
                            .map_err(|e| invalid(path, e))?;
                        let head = if wide_header { 8 } else { 4 };
                        let take = |from: usize, len: usize| {
                            data.get(from..from + len)
                                .ok_or_else(|| invalid(path, "AppendedData is truncated"))
                        };
                        let h = take(offset, head)?;
                        let len = if wide_header {
                            u64::from_le_bytes(h.try_into().unwrap()) as usize
                        } else {
                            u32::from_le_bytes(h.try_into().unwrap()) as usize
                        };
                        decode(take(offset + head, len)?, ty).ok_or_else(|| {
                            invalid(path, format!("{len} bytes are not whole {ty} values"))
                        })?
                    }
                    other => {
                        return Err(invalid(
                            path,
                            format!("unsupported DataArray format {other:?}"),
                        ));
                    }
                };
                file.arrays.push(DataArray {
                    section: section.clone(),
                    name: array_name,
                    components,
                    values,
                });
            }
            _ => {}
        }
    }
    Ok(file)
}

/// Little-endian raw bytes as values of VTK type `ty`.
fn decode(raw: &[u8], ty: &str) -> Option<ArrayValues> {
    fn chunks<const N: usize, T>(raw: &[u8], f: impl Fn([u8; N]) -> T) -> Option<Vec<T>> {
        raw.len().is_multiple_of(N).then(|| {
            raw.chunks_exact(N)
                .map(|c| f(c.try_into().unwrap()))
                .collect()
        })
    }
    Some(match ty {
        "Float64" => ArrayValues::Float64(chunks(raw, f64::from_le_bytes)?),
        "Float32" => ArrayValues::Float64(chunks(raw, |b| f32::from_le_bytes(b) as f64)?),
        "Int64" => ArrayValues::Int64(chunks(raw, i64::from_le_bytes)?),
        "UInt64" => ArrayValues::Int64(chunks(raw, |b| u64::from_le_bytes(b) as i64)?),
        "Int32" => ArrayValues::Int64(chunks(raw, |b| i32::from_le_bytes(b) as i64)?),
        "UInt32" => ArrayValues::Int64(chunks(raw, |b| u32::from_le_bytes(b) as i64)?),
        _ => return None,
    })
}

/// Writes a ParaView collection (.pvd) listing `(time, file name)` pairs relative to its folder.
pub fn write_pvd(path: &Path, frames: &[(f64, String)]) -> io::Result<()> {
    let tmp = path.with_extension("pvd.partial");
    let mut w = BufWriter::new(File::create(&tmp)?);
    writeln!(w, r#"<?xml version="1.0"?>"#)?;
    writeln!(
        w,
        r#"<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">"#
    )?;
    writeln!(w, "<Collection>")?;
    for (t, file) in frames {
        writeln!(
            w,
            r#"<DataSet timestep="{t}" group="" part="0" file="{file}"/>"#
        )?;
    }
    writeln!(w, "</Collection>\n</VTKFile>")?;
    w.flush()?;
    drop(w);
    std::fs::rename(tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("rockwave-vtk-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn writes_particles_and_blocks() {
        let dir = scratch("ascii");
        let p = dir.join("p.vtp");
        write_particles(
            &p,
            &[[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]],
            &[("rho", &[1000.0, 1001.0])],
            &[],
            VtkFormat::Ascii,
        )
        .unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.contains(r#"NumberOfPoints="2""#) && text.contains("1001"));
        let verts = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let faces = vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]];
        let b = dir.join("b.vtp");
        write_polyhedra(
            &b,
            &[(&verts, &faces), (&verts, &faces)],
            &[("id", &[0.0, 1.0])],
            VtkFormat::Ascii,
        )
        .unwrap();
        let text = std::fs::read_to_string(&b).unwrap();
        assert!(
            text.contains(r#"NumberOfPolys="8""#) && text.contains("4 5 7"),
            "{text}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The ASCII layout is pinned: earlier versions wrote exactly these bytes.
    #[test]
    fn ascii_layout_is_unchanged() {
        let dir = scratch("layout");
        let p = dir.join("p.vtp");
        write_particles(
            &p,
            &[[0.5, 1.0, -2.25]],
            &[("density", &[1000.125])],
            &[("velocity", &[[0.1, 0.0, -3.0]])],
            VtkFormat::Ascii,
        )
        .unwrap();
        let expected = r#"<?xml version="1.0"?>
<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">
<PolyData>
<Piece NumberOfPoints="1" NumberOfVerts="1" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0">
<Points>
<DataArray type="Float64" Name="Points" NumberOfComponents="3" format="ascii">
0.5 1 -2.25 
</DataArray>
</Points>
<Verts>
<DataArray type="Int64" Name="connectivity" format="ascii">
0 
</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">
1 
</DataArray>
</Verts>
<PointData>
<DataArray type="Float64" Name="density" format="ascii">
1000.125 
</DataArray>
<DataArray type="Float64" Name="velocity" NumberOfComponents="3" format="ascii">
0.1 0 -3 
</DataArray>
</PointData>
</Piece>
</PolyData>
</VTKFile>
"#;
        assert_eq!(std::fs::read_to_string(&p).unwrap(), expected);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Both encodings read back to the very same bits, and the binary file's appended block is
    /// laid out as the header promises.
    #[test]
    fn both_encodings_round_trip_bit_for_bit() {
        let dir = scratch("roundtrip");
        let awkward = [
            0.1 + 0.2,
            -0.0,
            1e-300,
            f64::MIN_POSITIVE / 3.0,
            f64::MAX,
            -123456.789e10,
            std::f64::consts::PI,
        ];
        let positions: Vec<[f64; 3]> = (0..awkward.len())
            .map(|i| [awkward[i], awkward[(i + 1) % 7], awkward[(i + 3) % 7] * 0.7])
            .collect();
        let pressure: Vec<f64> = awkward.iter().map(|v| v * 1.1).collect();
        let verts = [
            [0.0; 3],
            [1.0, 1e-17, 0.0],
            [0.0, 1.0, 0.3],
            [0.1, 0.2, 1.0],
        ];
        let faces = vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]];
        let mut read = Vec::new();
        for format in [VtkFormat::Binary, VtkFormat::Ascii] {
            let p = dir.join(format!("p-{format:?}.vtp"));
            write_particles(
                &p,
                &positions,
                &[("density", &awkward), ("pressure", &pressure)],
                &[("velocity", &positions)],
                format,
            )
            .unwrap();
            let b = dir.join(format!("b-{format:?}.vtp"));
            write_polyhedra(
                &b,
                &[(&verts, &faces), (&verts[..], &faces[..3])],
                &[("kind", &[2.0, 0.0])],
                format,
            )
            .unwrap();
            let (p, b) = (read_vtp(&p).unwrap(), read_vtp(&b).unwrap());
            assert_eq!(p.points, 7);
            let bits = |a: &DataArray| match &a.values {
                ArrayValues::Float64(v) => v.iter().map(|x| x.to_bits() as i64).collect(),
                ArrayValues::Int64(v) => v.clone(),
            };
            let pts = p.array("Points", "Points").unwrap();
            assert_eq!(pts.components, 3);
            let flat: Vec<i64> = positions
                .iter()
                .flatten()
                .map(|x| x.to_bits() as i64)
                .collect();
            assert_eq!(bits(pts), flat);
            assert_eq!(
                bits(p.array("PointData", "density").unwrap()),
                awkward
                    .iter()
                    .map(|x| x.to_bits() as i64)
                    .collect::<Vec<_>>()
            );
            assert_eq!(
                p.array("Verts", "offsets").unwrap().values,
                ArrayValues::Int64((1..=7).collect())
            );
            assert_eq!((b.points, b.polys), (8, 7));
            assert_eq!(b.array("Polys", "connectivity").unwrap().values.len(), 21);
            assert_eq!(
                b.array("CellData", "kind").unwrap().values.to_f64(),
                [2.0, 2.0, 2.0, 2.0, 0.0, 0.0, 0.0]
            );
            let arrays = |f: &VtpFile| {
                f.arrays
                    .iter()
                    .map(|a| (a.section.clone(), a.name.clone(), a.components, bits(a)))
                    .collect::<Vec<_>>()
            };
            read.push((arrays(&p), arrays(&b)));
        }
        assert_eq!(read[0], read[1], "binary and ASCII differ");
        // Binary: header_type UInt64, appended raw block, each array 8 + bytes.
        let raw = std::fs::read(dir.join("p-Binary.vtp")).unwrap();
        let text = String::from_utf8_lossy(&raw);
        assert!(text.contains(r#"header_type="UInt64""#));
        assert!(
            text.contains(r#"format="appended" offset="176"/>"#),
            "{text}"
        );
        let start = raw.windows(2).position(|w| w == b"\n_").unwrap() + 2;
        assert_eq!(
            u64::from_le_bytes(raw[start..start + 8].try_into().unwrap()),
            168
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn refuses_what_it_cannot_read() {
        let dir = scratch("refuse");
        let p = dir.join("c.vtp");
        std::fs::write(
            &p,
            r#"<VTKFile type="PolyData" compressor="vtkZLibDataCompressor"><PolyData></PolyData></VTKFile>"#,
        )
        .unwrap();
        assert!(read_vtp(&p).unwrap_err().to_string().contains("compressed"));
        std::fs::write(
            &p,
            "<VTKFile type=\"PolyData\" header_type=\"UInt64\"><PolyData><Piece NumberOfPoints=\"1\"><Points>\n<DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" offset=\"0\"/></Points></Piece></PolyData><AppendedData encoding=\"raw\">\n_\x18\0\0\0\0\0\0\0abc",
        )
        .unwrap();
        assert!(read_vtp(&p).unwrap_err().to_string().contains("truncated"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Size and write time of a 25 000-particle frame both ways (docs/PERFORMANCE.md, "VTK
    /// frames: binary versus ASCII"):
    /// `cargo test --release -p shared vtk::tests::measure -- --ignored --nocapture`.
    /// The values have full 17-digit mantissas, as particles have once they move.
    #[test]
    #[ignore]
    fn measure_frame_size_and_write_time() {
        let dir = scratch("measure");
        let n = 25_000;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let pos: Vec<[f64; 3]> = (0..n)
            .map(|_| [next() * 4.0, next(), next() * 0.6])
            .collect();
        let vel: Vec<[f64; 3]> = (0..n)
            .map(|_| [next() - 0.5, next() - 0.5, next() - 0.5])
            .collect();
        let rho: Vec<f64> = (0..n).map(|_| 1000.0 + next() * 20.0).collect();
        let p: Vec<f64> = (0..n).map(|_| next() * 6000.0).collect();
        println!("| format | bytes | bytes/particle | write [ms], best of 5 | read back [ms] |");
        for format in [VtkFormat::Binary, VtkFormat::Ascii] {
            let path = dir.join(format!("{format:?}.vtp"));
            let mut best = f64::INFINITY;
            for _ in 0..5 {
                let t = std::time::Instant::now();
                write_particles(
                    &path,
                    &pos,
                    &[("density", &rho), ("pressure", &p)],
                    &[("velocity", &vel)],
                    format,
                )
                .unwrap();
                best = best.min(t.elapsed().as_secs_f64() * 1e3);
            }
            let t = std::time::Instant::now();
            read_vtp(&path).unwrap();
            let read = t.elapsed().as_secs_f64() * 1e3;
            let bytes = std::fs::metadata(&path).unwrap().len();
            println!(
                "| {format:?} | {bytes} | {:.1} | {best:.1} | {read:.1} |",
                bytes as f64 / n as f64
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
