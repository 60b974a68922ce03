//! Reading triangle meshes: STL (binary and ASCII, `stl_io`), OBJ (`tobj`) and PLY (ASCII and
//! binary, `ply-rs-bw`). Each gives vertices and triangles (indices), in the file's frame.
//!
//! A file's own claims (a binary STL's triangle count, a PLY header's element counts) are
//! checked against its length before it is parsed, and every file against
//! [`MAX_MESH_FILE_BYTES`]; what is read is then bounded by [`MAX_MESH_TRIANGLES`].

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// The most triangles a terrain mesh may hold. A triangle costs about 400 bytes once placed,
/// checked and held with its bounding-volume tree (vertices, indices, the edge sort of the
/// topology check, parry's BVH and pseudo-normals), so 8 M triangles take some 3 GB: the most a
/// workstation should spend on fixed ground, and far more than the resolution the water sees
/// (a few triangles per particle spacing).
pub const MAX_MESH_TRIANGLES: usize = 8_000_000;

/// The longest terrain mesh file read [bytes]: an ASCII STL of [`MAX_MESH_TRIANGLES`] takes
/// about 250 bytes a triangle, 2 GB; a longer file (a sparse or runaway file of zeros or
/// garbage) is refused before its first byte is parsed.
pub const MAX_MESH_FILE_BYTES: u64 = 2 << 30;

/// The longest line of a text mesh file (ASCII STL, OBJ, ASCII PLY) [bytes]: their lines are a
/// few dozen bytes (a long polygon a few kilobytes); a longer run without a newline (zeros,
/// binary garbage under a text format's name) is refused instead of being gathered into one
/// string.
pub const MAX_LINE_BYTES: usize = 1 << 20;

fn long_line() -> String {
    format!(
        "a line longer than {MAX_LINE_BYTES} bytes (MAX_LINE_BYTES): not a text mesh file; fix: give the mesh as text lines, or as a binary STL or PLY"
    )
}

/// A reader that fails when a line grows past [`MAX_LINE_BYTES`], so the text parsers, which
/// gather a line at a time, hold at most that.
struct Lines<R> {
    inner: R,
    since_newline: usize,
}

impl<R> Lines<R> {
    fn new(inner: R) -> Self {
        Lines {
            inner,
            since_newline: 0,
        }
    }
}

impl<R: Read> Read for Lines<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            self.since_newline = if b == b'\n' {
                0
            } else {
                self.since_newline + 1
            };
            if self.since_newline > MAX_LINE_BYTES {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    long_line(),
                ));
            }
        }
        Ok(n)
    }
}

impl<R: std::io::Seek> std::io::Seek for Lines<R> {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        self.since_newline = 0;
        self.inner.seek(pos)
    }
}

/// Size of a binary STL's header (80 bytes) and triangle count (4), and of each triangle
/// record (normal, three corners as f32, a 2-byte attribute).
const STL_HEADER: u64 = 84;
const STL_TRIANGLE: u64 = 50;

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

/// The file's length, refused past [`MAX_MESH_FILE_BYTES`].
fn bounded_length(path: &Path) -> Result<u64, String> {
    let len = std::fs::metadata(path)
        .map_err(|e| format!("cannot open '{}': {e}", path.display()))?
        .len();
    if len > MAX_MESH_FILE_BYTES {
        return Err(format!(
            "'{}' is {len} bytes, past the {MAX_MESH_FILE_BYTES}-byte limit of a terrain mesh (MAX_MESH_FILE_BYTES, room for {MAX_MESH_TRIANGLES} triangles); fix: simplify or cut the mesh in its own tool (e.g. a quadric decimation), or give the surface as a DEM and crop it",
            path.display()
        ));
    }
    Ok(len)
}

/// Refuses a mesh of more than [`MAX_MESH_TRIANGLES`].
fn bounded_triangles(path: &Path, n: u64) -> Result<(), String> {
    if n > MAX_MESH_TRIANGLES as u64 {
        return Err(format!(
            "'{}' holds {n} triangles, past the limit of {MAX_MESH_TRIANGLES} (MAX_MESH_TRIANGLES); fix: simplify the mesh in its own tool (e.g. a quadric decimation) or cut it to the part the water reaches",
            path.display()
        ));
    }
    Ok(())
}

/// A binary STL (one that does not start with `solid`, or whose count fits its length exactly)
/// must be as long as its triangle count says: 84 + 50·n bytes. True for an ASCII STL.
fn check_stl_length(path: &Path, len: u64) -> Result<bool, String> {
    let mut head = [0u8; STL_HEADER as usize];
    let mut f =
        std::fs::File::open(path).map_err(|e| format!("cannot open '{}': {e}", path.display()))?;
    let got = f
        .read(&mut head)
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    if got < head.len() && len >= STL_HEADER {
        // A short read of a regular file: read the rest (rare; keeps the check exact).
        f.read_exact(&mut head[got..])
            .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    }
    let ascii = head.starts_with(b"solid");
    if len < STL_HEADER {
        return if ascii {
            Ok(true)
        } else {
            Err(format!(
                "'{}' is {len} bytes: too short for a binary STL (84 bytes of header and count) and does not start with `solid` (ASCII); fix: give a complete STL file",
                path.display()
            ))
        };
    }
    let n = u32::from_le_bytes([head[80], head[81], head[82], head[83]]) as u64;
    let expected = STL_HEADER + STL_TRIANGLE * n;
    if ascii && expected != len {
        return Ok(true);
    }
    if expected != len {
        return Err(format!(
            "'{}' is a binary STL whose header claims {n} triangles ({expected} bytes), but the file is {len} bytes; fix: re-export the mesh (the file is truncated, padded or not an STL)",
            path.display()
        ));
    }
    bounded_triangles(path, n).map(|()| false)
}

/// An STL file, binary or ASCII (`stl_io` tells them apart and merges equal corners).
pub fn read_stl(path: &Path) -> Result<RawMesh, String> {
    let len = bounded_length(path)?;
    let ascii = check_stl_length(path, len)?;
    let r = open(path)?;
    let mesh = if ascii {
        stl_io::read_stl(&mut Lines::new(r))
    } else {
        stl_io::read_stl(&mut { r })
    }
    .map_err(|e| format!("'{}' is not a readable STL file: {e}", path.display()))?;
    bounded_triangles(path, mesh.faces.len() as u64)?;
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
    bounded_length(path)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let file =
        std::fs::File::open(path).map_err(|e| format!("cannot open '{}': {e}", path.display()))?;
    let mut r = BufReader::new(Lines::new(file));
    // Materials are not read: a terrain is a surface, whatever its colours.
    let (models, _materials) =
        tobj::load_obj_buf(&mut r, &options, |_| Err(tobj::LoadError::OpenFileFailed)).map_err(
            |e| {
                let e = if r.get_ref().since_newline > MAX_LINE_BYTES {
                    long_line()
                } else {
                    e.to_string()
                };
                format!("'{}' is not a readable OBJ file: {e}", path.display())
            },
        )?;
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
        bounded_triangles(path, out.triangles.len() as u64)?;
    }
    Ok(out)
}

/// The longest PLY header read [bytes]: real headers are a few hundred bytes.
const MAX_PLY_HEADER: u64 = 64 << 10;

/// A PLY header's element counts are bounded by the bytes after it: an ASCII element takes
/// at least two bytes per property (a digit and a separator), a binary one at least one; so a
/// header that claims 10¹² vertices in a small file is refused before anything is parsed.
/// True for an ASCII PLY.
fn check_ply_counts(path: &Path, len: u64) -> Result<bool, String> {
    let mut r = open(path)?;
    let (mut header, mut claimed, mut ascii) = (0u64, 0u64, false);
    let mut line = Vec::new();
    let (mut props, mut count) = (0u64, 0u64);
    loop {
        line.clear();
        let n = r
            .by_ref()
            .take(MAX_PLY_HEADER.saturating_sub(header))
            .read_until(b'\n', &mut line)
            .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
        header += n as u64;
        if n == 0 || header >= MAX_PLY_HEADER {
            return Err(format!(
                "'{}': no `end_header` in its first {header} bytes (MAX_PLY_HEADER = {MAX_PLY_HEADER}): not a PLY file; fix: give a PLY mesh",
                path.display()
            ));
        }
        let text = String::from_utf8_lossy(&line);
        let words: Vec<&str> = text.split_ascii_whitespace().collect();
        match words.as_slice() {
            ["format", f, ..] => ascii = *f == "ascii",
            ["element", _, c] => {
                claimed = claimed.saturating_add(count.saturating_mul(props.max(1)));
                count = c.parse().unwrap_or(0);
                props = 0;
            }
            ["property", ..] => props += 1,
            ["end_header"] => break,
            _ => {}
        }
    }
    claimed = claimed.saturating_add(count.saturating_mul(props.max(1)));
    let room = (len - header) / if ascii { 2 } else { 1 };
    if claimed > room {
        return Err(format!(
            "'{}': its header claims elements of {claimed} values in all, but the {} bytes after the header hold at most {room}; fix: correct the element counts, or give the whole file",
            path.display(),
            len - header
        ));
    }
    Ok(ascii)
}

/// A PLY file's `vertex` (x, y, z) and `face` (`vertex_indices` or `vertex_index`) elements;
/// polygons are fan-triangulated.
pub fn read_ply(path: &Path) -> Result<RawMesh, String> {
    use ply_rs_bw::ply::Property;
    let len = bounded_length(path)?;
    let ascii = check_ply_counts(path, len)?;
    let file =
        std::fs::File::open(path).map_err(|e| format!("cannot open '{}': {e}", path.display()))?;
    let parser = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new();
    let ply = if ascii {
        parser.read_ply(&mut BufReader::new(Lines::new(file)))
    } else {
        parser.read_ply(&mut BufReader::new(file))
    }
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
    bounded_triangles(path, out.triangles.len() as u64)?;
    Ok(out)
}
