//! Reading triangle meshes: STL (binary and ASCII, `stl_io`), OBJ (`tobj`) and PLY (ASCII and
//! binary, `ply-rs-bw`). Each gives vertices and triangles (indices), in the file's frame.

use std::io::BufReader;
use std::path::Path;

/// Vertices and index triangles as read from a file.
#[derive(Debug, Clone, Default)]
pub struct RawMesh {
    pub vertices: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

/// Refuses a path that is not a regular file (a FIFO, a device, a directory), whose reading
/// could block for ever or never end.
pub fn regular(path: &Path) -> Result<(), String> {
    let meta =
        std::fs::metadata(path).map_err(|e| format!("cannot open '{}': {e}", path.display()))?;
    if meta.is_file() {
        Ok(())
    } else {
        Err(format!(
            "'{}' is not a regular file (a pipe, device or directory)",
            path.display()
        ))
    }
}

fn open(path: &Path) -> Result<BufReader<std::fs::File>, String> {
    std::fs::File::open(path)
        .map(BufReader::new)
        .map_err(|e| format!("cannot open '{}': {e}", path.display()))
}

/// An STL file, binary or ASCII (`stl_io` tells them apart and merges equal corners).
pub fn read_stl(path: &Path) -> Result<RawMesh, String> {
    let mut r = open(path)?;
    let mesh = stl_io::read_stl(&mut r)
        .map_err(|e| format!("'{}' is not a readable STL file: {e}", path.display()))?;
    Ok(RawMesh {
        vertices: mesh
            .vertices
            .iter()
            .map(|v| [v[0] as f64, v[1] as f64, v[2] as f64])
            .collect(),
        triangles: mesh
            .faces
            .iter()
            .map(|f| f.vertices.map(|i| i as u32))
            .collect(),
    })
}

/// An OBJ file: every object's faces (polygons fan-triangulated by `tobj`), one mesh.
pub fn read_obj(path: &Path) -> Result<RawMesh, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _materials) = tobj::load_obj(path, &options)
        .map_err(|e| format!("'{}' is not a readable OBJ file: {e}", path.display()))?;
    let mut out = RawMesh::default();
    for m in &models {
        let first = out.vertices.len() as u32;
        out.vertices
            .extend(m.mesh.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
        out.triangles.extend(
            m.mesh
                .indices
                .chunks_exact(3)
                .map(|t| [first + t[0], first + t[1], first + t[2]]),
        );
    }
    Ok(out)
}

/// A PLY file's `vertex` (x, y, z) and `face` (`vertex_indices` or `vertex_index`) elements;
/// polygons are fan-triangulated.
pub fn read_ply(path: &Path) -> Result<RawMesh, String> {
    use ply_rs_bw::ply::Property;
    let mut r = open(path)?;
    let parser = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new();
    let ply = parser
        .read_ply(&mut r)
        .map_err(|e| format!("'{}' is not a readable PLY file: {e}", path.display()))?;
    let scalar = |p: &Property| -> Option<f64> {
        Some(match *p {
            Property::Char(v) => v as f64,
            Property::UChar(v) => v as f64,
            Property::Short(v) => v as f64,
            Property::UShort(v) => v as f64,
            Property::Int(v) => v as f64,
            Property::UInt(v) => v as f64,
            Property::Float(v) => v as f64,
            Property::Double(v) => v,
            _ => return None,
        })
    };
    let list = |p: &Property| -> Option<Vec<i64>> {
        Some(match p {
            Property::ListChar(v) => v.iter().map(|&x| x as i64).collect(),
            Property::ListUChar(v) => v.iter().map(|&x| x as i64).collect(),
            Property::ListShort(v) => v.iter().map(|&x| x as i64).collect(),
            Property::ListUShort(v) => v.iter().map(|&x| x as i64).collect(),
            Property::ListInt(v) => v.iter().map(|&x| x as i64).collect(),
            Property::ListUInt(v) => v.iter().map(|&x| x as i64).collect(),
            _ => return None,
        })
    };
    let no = |what: &str| format!("'{}': PLY file has no {what}", path.display());
    let verts = ply
        .payload
        .get("vertex")
        .ok_or_else(|| no("`vertex` element"))?;
    let mut out = RawMesh::default();
    for v in verts {
        let mut xyz = [0.0; 3];
        for (k, name) in ["x", "y", "z"].iter().enumerate() {
            xyz[k] = v
                .get(*name)
                .and_then(scalar)
                .ok_or_else(|| no(&format!("numeric vertex property `{name}`")))?;
        }
        out.vertices.push(xyz);
    }
    let faces = ply
        .payload
        .get("face")
        .ok_or_else(|| no("`face` element"))?;
    let n = out.vertices.len() as i64;
    for (fi, f) in faces.iter().enumerate() {
        let idx = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .and_then(list)
            .ok_or_else(|| no("face list `vertex_indices`"))?;
        if let Some(bad) = idx.iter().find(|&&i| i < 0 || i >= n) {
            return Err(format!(
                "'{}': face {fi} names vertex {bad}, but the file has {n} vertices",
                path.display()
            ));
        }
        for k in 1..idx.len().saturating_sub(1) {
            out.triangles
                .push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
        }
    }
    Ok(out)
}
