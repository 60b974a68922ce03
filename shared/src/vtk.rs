//! VTK XML PolyData writers (.vtp) for ParaView: particles as points, blocks as polygons.
//! The coupler lists the frames in a .pvd series so ParaView opens a whole run at once.
//!
//! Files are written to a temporary name and renamed, so a run killed mid-write never leaves
//! a truncated frame behind.

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

fn scalars<W: Write>(w: &mut W, name: &str, values: &[f64]) -> io::Result<()> {
    writeln!(
        w,
        r#"<DataArray type="Float64" Name="{name}" format="ascii">"#
    )?;
    for v in values {
        write!(w, "{v} ")?;
    }
    writeln!(w, "\n</DataArray>")
}

fn vectors<W: Write>(w: &mut W, name: &str, values: &[[f64; 3]]) -> io::Result<()> {
    writeln!(
        w,
        r#"<DataArray type="Float64" Name="{name}" NumberOfComponents="3" format="ascii">"#
    )?;
    for v in values {
        write!(w, "{} {} {} ", v[0], v[1], v[2])?;
    }
    writeln!(w, "\n</DataArray>")
}

fn ints<W: Write>(w: &mut W, name: &str, values: impl Iterator<Item = usize>) -> io::Result<()> {
    writeln!(
        w,
        r#"<DataArray type="Int64" Name="{name}" format="ascii">"#
    )?;
    for v in values {
        write!(w, "{v} ")?;
    }
    writeln!(w, "\n</DataArray>")
}

/// Writes particles as vertices with point data (scalars such as density and pressure, vectors
/// such as velocity).
pub fn write_particles(
    path: &Path,
    positions: &[[f64; 3]],
    point_scalars: &[(&str, &[f64])],
    point_vectors: &[(&str, &[[f64; 3]])],
) -> io::Result<()> {
    let n = positions.len();
    atomically(path, |w| {
        writeln!(w, r#"<?xml version="1.0"?>"#)?;
        writeln!(
            w,
            r#"<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">"#
        )?;
        writeln!(w, "<PolyData>")?;
        writeln!(
            w,
            r#"<Piece NumberOfPoints="{n}" NumberOfVerts="{n}" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0">"#
        )?;
        writeln!(w, "<Points>")?;
        vectors(w, "Points", positions)?;
        writeln!(w, "</Points>")?;
        writeln!(w, "<Verts>")?;
        ints(w, "connectivity", 0..n)?;
        ints(w, "offsets", 1..=n)?;
        writeln!(w, "</Verts>")?;
        writeln!(w, "<PointData>")?;
        for (name, v) in point_scalars {
            scalars(w, name, v)?;
        }
        for (name, v) in point_vectors {
            vectors(w, name, v)?;
        }
        writeln!(w, "</PointData>")?;
        writeln!(w, "</Piece>\n</PolyData>\n</VTKFile>")
    })
}

/// One block for [`write_polyhedra`]: world-frame corners and faces as corner index lists.
pub type PolyhedronRef<'a> = (&'a [[f64; 3]], &'a [Vec<u32>]);

/// Writes blocks as closed polygon surfaces: per block its world-frame corners and its faces
/// (vertex index lists into those corners); `cell_scalars` hold one value per block.
pub fn write_polyhedra(
    path: &Path,
    blocks: &[PolyhedronRef<'_>],
    cell_scalars: &[(&str, &[f64])],
) -> io::Result<()> {
    let n_points: usize = blocks.iter().map(|b| b.0.len()).sum();
    let n_polys: usize = blocks.iter().map(|b| b.1.len()).sum();
    atomically(path, |w| {
        writeln!(w, r#"<?xml version="1.0"?>"#)?;
        writeln!(
            w,
            r#"<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian">"#
        )?;
        writeln!(w, "<PolyData>")?;
        writeln!(
            w,
            r#"<Piece NumberOfPoints="{n_points}" NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="{n_polys}">"#
        )?;
        writeln!(w, "<Points>")?;
        let all: Vec<[f64; 3]> = blocks.iter().flat_map(|b| b.0.iter().copied()).collect();
        vectors(w, "Points", &all)?;
        writeln!(w, "</Points>")?;
        writeln!(w, "<Polys>")?;
        let mut base = 0usize;
        let mut connectivity = Vec::new();
        let mut offsets = Vec::new();
        for (verts, faces) in blocks {
            for f in faces.iter() {
                connectivity.extend(f.iter().map(|&i| base + i as usize));
                offsets.push(connectivity.len());
            }
            base += verts.len();
        }
        ints(w, "connectivity", connectivity.into_iter())?;
        ints(w, "offsets", offsets.into_iter())?;
        writeln!(w, "</Polys>")?;
        writeln!(w, "<CellData>")?;
        for (name, per_block) in cell_scalars {
            // One value per face, repeated from the block's value.
            let per_face: Vec<f64> = blocks
                .iter()
                .zip(per_block.iter())
                .flat_map(|(b, &v)| std::iter::repeat_n(v, b.1.len()))
                .collect();
            scalars(w, name, &per_face)?;
        }
        writeln!(w, "</CellData>")?;
        writeln!(w, "</Piece>\n</PolyData>\n</VTKFile>")
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

    #[test]
    fn writes_particles_and_blocks() {
        let dir = std::env::temp_dir().join(format!("rockwave-vtk-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("p.vtp");
        write_particles(
            &p,
            &[[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]],
            &[("rho", &[1000.0, 1001.0])],
            &[],
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
        )
        .unwrap();
        let text = std::fs::read_to_string(&b).unwrap();
        assert!(
            text.contains(r#"NumberOfPolys="8""#) && text.contains("4 5 7"),
            "{text}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
