//! Digital elevation models in the ESRI ASCII grid format (`.asc`): a header (`ncols`, `nrows`,
//! `xllcorner`/`xllcenter`, `yllcorner`/`yllcenter`, `cellsize`, optional `NODATA_value`), then
//! `nrows` lines of `ncols` elevations, the first line the northern (largest y) row.
//!
//! Each cell's value is the elevation at its centre; neighbouring centres are joined into two
//! triangles per grid square, wound counter-clockwise seen from above (normals up).

use super::files::RawMesh;
use crate::math::readable;
use crate::scene::NoData;
use std::io::BufRead;
use std::path::Path;

/// The most cells a DEM keeps (after `crop` and `decimate`, which act while it is read). A
/// kept cell becomes a vertex and two triangles, about 800 bytes once placed, checked and held
/// with its bounding-volume tree, so 4 M cells (2 000 × 2 000, 8 M triangles: the mesh limit
/// [`super::files::MAX_MESH_TRIANGLES`]) take some 3 GB; survey grids larger than that are
/// cropped to the part the water reaches or decimated.
pub const MAX_DEM_CELLS: u64 = 4_000_000;

/// The longest token of an ESRI grid [bytes]: a number or a header key. A longer run of
/// non-blank bytes (a binary or runaway file) is refused instead of being gathered.
const MAX_TOKEN: usize = 256;

/// What a grid's header says: its size, where it lies and its no-data value.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    pub ncols: usize,
    pub nrows: usize,
    /// Centre of the south-west cell [file units].
    pub x0: f64,
    pub y0: f64,
    pub cell: f64,
    pub nodata: Option<f64>,
}

/// The part of a grid kept while it is read: rows `rows.0..rows.1` (from the north) and columns
/// `cols.0..cols.1` (from the west), every `step`-th of each from the first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    pub rows: (usize, usize),
    pub cols: (usize, usize),
    pub step: usize,
}

impl Window {
    /// The whole grid, every `step`-th row and column.
    pub fn all(header: &Header, step: usize) -> Window {
        Window {
            rows: (0, header.nrows),
            cols: (0, header.ncols),
            step,
        }
    }

    fn count(range: (usize, usize), step: usize) -> usize {
        range.1.saturating_sub(range.0).div_ceil(step)
    }

    /// Kept rows and columns.
    pub fn size(&self) -> (usize, usize) {
        (
            Self::count(self.rows, self.step),
            Self::count(self.cols, self.step),
        )
    }

    /// Kept cells.
    pub fn cells(&self) -> u64 {
        let (r, c) = self.size();
        r as u64 * c as u64
    }

    /// The kept index (row, column) of the grid's cell (row, col), if kept.
    #[inline]
    pub fn keep(&self, row: usize, col: usize) -> Option<(usize, usize)> {
        let inside = |i: usize, (a, b): (usize, usize)| {
            (i >= a && i < b && (i - a).is_multiple_of(self.step)).then(|| (i - a) / self.step)
        };
        Some((inside(row, self.rows)?, inside(col, self.cols)?))
    }
}

impl Header {
    /// Refuses a window of more than [`MAX_DEM_CELLS`]; the caller names the field to change.
    pub fn check_kept(&self, w: &Window) -> Result<(), String> {
        if w.cells() > MAX_DEM_CELLS {
            let (r, c) = w.size();
            return Err(format!(
                "the grid of {} × {} cells keeps {c} × {r} = {} cells, past the limit of {MAX_DEM_CELLS} (MAX_DEM_CELLS)",
                self.ncols,
                self.nrows,
                w.cells()
            ));
        }
        Ok(())
    }

    /// An empty grid of `w`'s cells, placed where they lie in the whole grid.
    pub(super) fn grid_of(&self, w: &Window) -> Grid {
        let (nrows, ncols) = w.size();
        let last_row = w.rows.0 + (nrows.max(1) - 1) * w.step;
        Grid {
            ncols,
            nrows,
            x0: self.x0,
            y0: self.y0,
            cell: self.cell,
            z: vec![None; nrows * ncols],
            origin: [w.cols.0, self.nrows - 1 - last_row],
            step: w.step,
        }
    }
}

/// A grid read from a file, before its no-data cells are dealt with.
#[derive(Debug, Clone)]
pub struct Grid {
    pub ncols: usize,
    pub nrows: usize,
    /// Centre of the south-west cell of the whole grid in the file [file units].
    pub x0: f64,
    pub y0: f64,
    pub cell: f64,
    /// Row-major from the north row; `None` for no-data (or NaN) cells.
    pub z: Vec<Option<f64>>,
    /// Where the kept cells lie in the file's grid: the column of the first and the row (from
    /// the south) of the southmost, every `step`-th cell of the file kept. A cell's position is
    /// computed from the file's own origin, so a cropped grid's vertices are the very numbers
    /// of the whole grid's.
    pub origin: [usize; 2],
    pub step: usize,
}

/// Splits a byte stream at ASCII whitespace, one token at a time, without gathering more than
/// [`MAX_TOKEN`] bytes.
struct Tokens<R> {
    r: R,
    buf: Vec<u8>,
    /// Tokens read so far.
    count: u64,
}

impl<R: BufRead> Tokens<R> {
    fn next(&mut self) -> Result<Option<&str>, String> {
        self.buf.clear();
        loop {
            let chunk = self.r.fill_buf().map_err(|e| format!("cannot read: {e}"))?;
            if chunk.is_empty() {
                break;
            }
            let mut i = 0;
            if self.buf.is_empty() {
                while i < chunk.len() && chunk[i].is_ascii_whitespace() {
                    i += 1;
                }
            }
            let start = i;
            while i < chunk.len() && !chunk[i].is_ascii_whitespace() {
                i += 1;
            }
            self.buf.extend_from_slice(&chunk[start..i]);
            let ended = i < chunk.len() && !self.buf.is_empty();
            self.r.consume(i);
            if self.buf.len() > MAX_TOKEN {
                return Err(format!(
                    "after {} values, a run of more than {MAX_TOKEN} bytes without a blank (MAX_TOKEN): not an ESRI ASCII grid; fix: give the grid as text",
                    self.count
                ));
            }
            if ended {
                break;
            }
        }
        if self.buf.is_empty() {
            return Ok(None);
        }
        self.count += 1;
        std::str::from_utf8(&self.buf)
            .map(Some)
            .map_err(|_| format!("value {} is not text: not an ESRI ASCII grid", self.count))
    }
}

/// An ESRI ASCII grid whose header has been read: [`Self::read`] then reads the cells a
/// [`Window`] keeps, row by row, holding nothing else.
pub struct AscReader<R> {
    tokens: Tokens<R>,
    header: Header,
    /// The first elevation, read while looking for the header's end.
    first: String,
}

/// Opens an ESRI ASCII grid and reads its header.
pub fn open(path: &Path) -> Result<AscReader<std::io::BufReader<std::fs::File>>, String> {
    let file =
        std::fs::File::open(path).map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let len = file
        .metadata()
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?
        .len();
    AscReader::new(std::io::BufReader::new(file), len)
        .map_err(|e| format!("'{}': {e}", path.display()))
}

/// Reads a whole ESRI ASCII grid.
pub fn read(path: &Path) -> Result<Grid, String> {
    let r = open(path)?;
    let w = Window::all(r.header(), 1);
    r.read(&w).map_err(|e| format!("'{}': {e}", path.display()))
}

/// Parses the text of a whole ESRI ASCII grid.
pub fn parse(text: &str) -> Result<Grid, String> {
    let r = AscReader::new(text.as_bytes(), text.len() as u64)?;
    let w = Window::all(r.header(), 1);
    r.read(&w)
}

impl<R: BufRead> AscReader<R> {
    /// Reads the header of a grid of `len` bytes; the claim of its size is bounded by them.
    pub fn new(r: R, len: u64) -> Result<Self, String> {
        let mut tokens = Tokens {
            r,
            buf: Vec::new(),
            count: 0,
        };
        let mut header = std::collections::BTreeMap::new();
        let first = loop {
            let Some(t) = tokens.next()? else {
                break String::new();
            };
            if t.parse::<f64>().is_ok() {
                break t.to_string();
            }
            let key = t.to_ascii_lowercase();
            let value = tokens
                .next()?
                .ok_or_else(|| format!("header key `{key}` has no value"))?;
            let v: f64 = value
                .parse()
                .map_err(|_| format!("header `{key}` = `{value}` is not a number"))?;
            header.insert(key, v);
        };
        tokens.count = 0;
        let get = |k: &str| header.get(k).copied();
        let need = |k: &str| {
            get(k).ok_or_else(|| {
                format!("not an ESRI ASCII grid: the header has no `{k}` (expected ncols, nrows, xllcorner, yllcorner, cellsize)")
            })
        };
        let (ncols, nrows) = (need("ncols")?, need("nrows")?);
        if !(ncols >= 2.0 && nrows >= 2.0 && ncols.fract() == 0.0 && nrows.fract() == 0.0) {
            return Err(format!(
                "ncols = {ncols}, nrows = {nrows}: a grid needs at least 2 × 2 cells"
            ));
        }
        // The header's claim is bounded by what the file holds (each elevation takes a
        // character and a separator at least) before anything is reserved for it.
        let room = len / 2 + 1;
        if ncols * nrows > room as f64 {
            let n = |v: f64| {
                if v < 1e15 {
                    format!("{v}")
                } else {
                    format!("{v:e}")
                }
            };
            return Err(format!(
                "the header claims ncols × nrows = {} × {} = {} cells, but the file's {len} bytes hold at most {room} elevations; fix: correct ncols and nrows, or give the whole grid",
                n(ncols),
                n(nrows),
                n(ncols * nrows),
            ));
        }
        let cell = need("cellsize")?;
        if !(cell.is_finite() && cell > 0.0) {
            return Err(format!(
                "cellsize = {}: must be a positive length",
                readable(cell)
            ));
        }
        let centre = |corner: &str, center: &str| match (get(corner), get(center)) {
            (Some(c), _) => Ok(c + 0.5 * cell),
            (None, Some(c)) => Ok(c),
            (None, None) => Err(format!("the header has neither `{corner}` nor `{center}`")),
        };
        let (x0, y0) = (
            centre("xllcorner", "xllcenter")?,
            centre("yllcorner", "yllcenter")?,
        );
        Ok(AscReader {
            tokens,
            header: Header {
                ncols: ncols as usize,
                nrows: nrows as usize,
                x0,
                y0,
                cell,
                nodata: get("nodata_value"),
            },
            first,
        })
    }

    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Reads the cells `w` keeps, row by row; the values of other cells are passed over
    /// unparsed, and the reading stops after the last kept row unless it is the grid's last
    /// (then the count of the whole grid is checked).
    pub fn read(mut self, w: &Window) -> Result<Grid, String> {
        let h = self.header.clone();
        let mut g = h.grid_of(w);
        let total = h.ncols * h.nrows;
        let end = if w.rows.1 >= h.nrows {
            usize::MAX
        } else {
            w.rows.1 * h.ncols
        };
        let mut n = 0;
        let mut parse = |t: &str, n: usize| -> Result<(), String> {
            let (row, col) = (n / h.ncols, n % h.ncols);
            if let Some((r, c)) = w.keep(row, col) {
                let v: f64 = t
                    .parse()
                    .map_err(|_| format!("elevation `{t}` (value {}) is not a number", n + 1))?;
                // NaN is a hole (GDAL writes `nan` for one); an infinity is no elevation and
                // no hole either: `nodata = "fill"` would have filled it silently.
                if v.is_infinite() {
                    return Err(format!(
                        "elevation `{t}` (value {}, row {row}, column {col} from the north-west \
                         corner) is infinite; fix: give the cell's elevation, or the file's \
                         NODATA_value to mark it a hole",
                        n + 1
                    ));
                }
                g.z[r * g.ncols + c] = (!v.is_nan() && Some(v) != h.nodata).then_some(v);
            }
            Ok(())
        };
        if !self.first.is_empty() {
            if n < total {
                parse(&self.first, n)?;
            }
            n += 1;
        }
        while n < end {
            let Some(t) = self.tokens.next()? else {
                break;
            };
            if n < total {
                parse(t, n)?;
            }
            n += 1;
        }
        if n < end.min(total) || (end == usize::MAX && n != total) {
            return Err(format!(
                "holds {n} elevations, but ncols × nrows = {} × {} = {total}; fix: give nrows lines of ncols elevations after the header",
                h.ncols, h.nrows
            ));
        }
        Ok(g)
    }
}

/// How a grid's missing cells were dealt with.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Filled {
    pub cells: usize,
}

impl Grid {
    /// Deals with the no-data cells as `policy` says: refused (the error names how many and
    /// the first, by row and column from the north-west corner, and its position), or filled,
    /// each from the mean of its valid 4-neighbours, in passes inwards from the valid cells (a
    /// pass reads only the values of earlier passes, so the result does not depend on order).
    pub fn resolve(&mut self, policy: NoData) -> Result<Filled, String> {
        let missing = self.z.iter().filter(|v| v.is_none()).count();
        if missing == 0 {
            return Ok(Filled::default());
        }
        if missing == self.z.len() {
            return Err("every cell is no-data (or NaN): the grid holds no elevation".into());
        }
        if policy == NoData::Refuse {
            let first = self
                .z
                .iter()
                .position(Option::is_none)
                .expect("some missing");
            let (row, col) = (first / self.ncols, first % self.ncols);
            let (x, y) = self.centre(row, col);
            let (x, y) = (readable(x), readable(y));
            return Err(format!(
                "{missing} cell(s) are no-data or NaN, the first at row {row}, column {col} \
                 (from the north-west corner; x = {x}, y = {y} in the file's units); \
                 refused, not filled"
            ));
        }
        let (nc, nr) = (self.ncols, self.nrows);
        let mut left = missing;
        while left > 0 {
            let before = self.z.clone();
            for r in 0..nr {
                for c in 0..nc {
                    if before[r * nc + c].is_some() {
                        continue;
                    }
                    let mut sum = 0.0;
                    let mut n = 0;
                    let nbrs = [
                        (r.wrapping_sub(1), c),
                        (r + 1, c),
                        (r, c.wrapping_sub(1)),
                        (r, c + 1),
                    ];
                    for (rr, cc) in nbrs {
                        if rr < nr
                            && cc < nc
                            && let Some(v) = before[rr * nc + cc]
                        {
                            sum += v;
                            n += 1;
                        }
                    }
                    if n > 0 {
                        self.z[r * nc + c] = Some(sum / n as f64);
                        left -= 1;
                    }
                }
            }
        }
        Ok(Filled { cells: missing })
    }

    /// The grid as ESRI ASCII grid text (`xllcenter`/`yllcenter`, no-data as -9999): what
    /// scripts that make synthetic sites write.
    pub fn to_asc(&self) -> String {
        let (x0, y0) = self.centre(self.nrows - 1, 0);
        let mut s = format!(
            "ncols {}\nnrows {}\nxllcenter {x0}\nyllcenter {y0}\ncellsize {}\nNODATA_value -9999\n",
            self.ncols,
            self.nrows,
            self.cell * self.step as f64
        );
        for row in self.z.chunks(self.ncols) {
            let line: Vec<String> = row
                .iter()
                .map(|v| v.map_or("-9999".to_string(), |z| format!("{z}")))
                .collect();
            s += &line.join(" ");
            s.push('\n');
        }
        s
    }

    /// A grid of `ncols` × `nrows` centres from (x0, y0) (south-west) with elevation `z(x, y)`.
    pub fn from_fn(
        ncols: usize,
        nrows: usize,
        x0: f64,
        y0: f64,
        cell: f64,
        z: impl Fn(f64, f64) -> f64,
    ) -> Grid {
        let mut g = Grid {
            ncols,
            nrows,
            x0,
            y0,
            cell,
            z: Vec::with_capacity(ncols * nrows),
            origin: [0, 0],
            step: 1,
        };
        for r in 0..nrows {
            for c in 0..ncols {
                let (x, y) = g.centre(r, c);
                g.z.push(Some(z(x, y)));
            }
        }
        g
    }

    /// Centre of kept cell (row from the north, column from the west).
    pub fn centre(&self, row: usize, col: usize) -> (f64, f64) {
        let file_col = self.origin[0] + col * self.step;
        let file_row_from_south = self.origin[1] + (self.nrows - 1 - row) * self.step;
        (
            self.x0 + file_col as f64 * self.cell,
            self.y0 + file_row_from_south as f64 * self.cell,
        )
    }

    /// The surface through the cell centres: two triangles per square of four centres,
    /// counter-clockwise seen from above. Call after [`Self::resolve`].
    pub fn triangulate(&self) -> RawMesh {
        let (nc, nr) = (self.ncols, self.nrows);
        let mut vertices = Vec::with_capacity(nc * nr);
        for r in 0..nr {
            for c in 0..nc {
                let (x, y) = self.centre(r, c);
                vertices.push([x, y, self.z[r * nc + c].unwrap_or(f64::NAN)]);
            }
        }
        let id = |r: usize, c: usize| (r * nc + c) as u32;
        let mut triangles = Vec::with_capacity(2 * (nc - 1) * (nr - 1));
        for r in 0..nr - 1 {
            for c in 0..nc - 1 {
                // Row r is north of row r + 1: (r+1, c) is the south-west corner of the square.
                let (sw, se, nw, ne) = (id(r + 1, c), id(r + 1, c + 1), id(r, c), id(r, c + 1));
                triangles.push([sw, se, ne]);
                triangles.push([sw, ne, nw]);
            }
        }
        RawMesh {
            vertices,
            triangles,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GRID: &str = "ncols 3\nnrows 2\nxllcorner 10\nyllcorner 20\ncellsize 2\nNODATA_value -9999\n\
                        1 2 3\n4 -9999 6\n";

    #[test]
    fn header_positions_and_winding() {
        let mut g = parse(GRID).unwrap();
        assert_eq!((g.ncols, g.nrows), (3, 2));
        // The south-west centre is the corner plus half a cell.
        assert_eq!(g.centre(1, 0), (11.0, 21.0));
        assert_eq!(g.centre(0, 2), (15.0, 23.0));
        assert_eq!(g.z[4], None);
        let e = g.clone().resolve(NoData::Refuse).unwrap_err();
        assert!(
            e.contains("1 cell(s)") && e.contains("row 1, column 1") && e.contains("refused"),
            "{e}"
        );
        assert_eq!(g.resolve(NoData::Fill).unwrap().cells, 1);
        // Mean of 2 (north), 4 (west) and 6 (east).
        assert_eq!(g.z[4], Some(4.0));
        let m = g.triangulate();
        assert_eq!(m.triangles.len(), 4);
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.vertices[i as usize]);
            let cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            assert!(cross > 0.0, "counter-clockwise seen from above");
        }
    }

    #[test]
    fn bad_grids_say_what_is_wrong() {
        let short = GRID.replace("4 -9999 6\n", "4 5\n");
        assert!(parse(&short).unwrap_err().contains("holds 5 elevations"));
        let no_size = GRID.replace("cellsize 2\n", "");
        assert!(parse(&no_size).unwrap_err().contains("cellsize"));
        let nan = GRID.replace("-9999 6", "nan 6");
        assert_eq!(parse(&nan).unwrap().z[4], None);
        // An infinity is not a hole to fill: refused, naming the cell.
        for inf in ["inf", "-inf", "1e999"] {
            let e = parse(&GRID.replace("-9999 6", &format!("{inf} 6"))).unwrap_err();
            assert!(
                e.contains(&format!("`{inf}`"))
                    && e.contains("row 1, column 1")
                    && e.contains("infinite; fix: give the cell's elevation"),
                "{e}"
            );
        }
    }

    /// A header is not trusted past what the file holds: a claim of 10⁹ cells (or 10³⁰⁰ columns)
    /// in a few bytes is refused before anything is reserved for it, and so is a header with no
    /// elevations at all.
    #[test]
    fn a_header_that_claims_more_than_the_file_holds_is_refused() {
        for (header, claim) in [
            ("ncols 31623\nnrows 31623\n", "31623 × 31623"),
            ("ncols 1e300\nnrows 3\n", "1e300 × 3"),
            (
                "ncols 3\nnrows 3\n",
                "holds 0 elevations, but ncols × nrows = 3 × 3",
            ),
        ] {
            let text = format!("{header}xllcorner 10\nyllcorner 20\ncellsize 2\n");
            let e = parse(&text).unwrap_err();
            assert!(e.contains(claim) && e.contains("fix:"), "{e}");
        }
        // The same header with its values passes.
        let full =
            "ncols 3\nnrows 3\nxllcorner 10\nyllcorner 20\ncellsize 2\n1 2 3\n4 5 6\n7 8 9\n";
        assert_eq!(parse(full).unwrap().z.len(), 9);
    }
}
