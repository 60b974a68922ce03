//! Digital elevation models in the ESRI ASCII grid format (`.asc`): a header (`ncols`, `nrows`,
//! `xllcorner`/`xllcenter`, `yllcorner`/`yllcenter`, `cellsize`, optional `NODATA_value`), then
//! `nrows` lines of `ncols` elevations, the first line the northern (largest y) row.
//!
//! Each cell's value is the elevation at its centre; neighbouring centres are joined into two
//! triangles per grid square, wound counter-clockwise seen from above (normals up).

use super::files::RawMesh;
use crate::scene::NoData;
use std::path::Path;

/// A grid read from a file, before its no-data cells are dealt with.
#[derive(Debug, Clone)]
pub struct Grid {
    pub ncols: usize,
    pub nrows: usize,
    /// Centre of the south-west cell [file units].
    pub x0: f64,
    pub y0: f64,
    pub cell: f64,
    /// Row-major from the north row; `None` for no-data (or NaN) cells.
    pub z: Vec<Option<f64>>,
}

/// Reads an ESRI ASCII grid.
pub fn read(path: &Path) -> Result<Grid, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    parse(&text).map_err(|e| format!("'{}': {e}", path.display()))
}

/// Parses the text of an ESRI ASCII grid.
pub fn parse(text: &str) -> Result<Grid, String> {
    let mut tokens = text.split_ascii_whitespace().peekable();
    let mut header = std::collections::BTreeMap::new();
    while let Some(t) = tokens.peek() {
        if t.parse::<f64>().is_ok() {
            break;
        }
        let key = tokens.next().expect("peeked").to_ascii_lowercase();
        let value = tokens
            .next()
            .ok_or_else(|| format!("header key `{key}` has no value"))?;
        let v: f64 = value
            .parse()
            .map_err(|_| format!("header `{key}` = `{value}` is not a number"))?;
        header.insert(key, v);
    }
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
    // The header's claim is bounded by what the text holds (each elevation takes a character
    // and a separator at least) before anything is reserved for it.
    let room = text.len() / 2 + 1;
    if ncols * nrows > room as f64 {
        let n = |v: f64| {
            if v < 1e15 {
                format!("{v}")
            } else {
                format!("{v:e}")
            }
        };
        return Err(format!(
            "the header claims ncols × nrows = {} × {} = {} cells, but the file's {} bytes hold at most {room} elevations; fix: correct ncols and nrows, or give the whole grid",
            n(ncols),
            n(nrows),
            n(ncols * nrows),
            text.len()
        ));
    }
    let (ncols, nrows) = (ncols as usize, nrows as usize);
    let cell = need("cellsize")?;
    if !(cell.is_finite() && cell > 0.0) {
        return Err(format!("cellsize = {cell}: must be a positive length"));
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
    let nodata = get("nodata_value");
    let mut z = Vec::with_capacity(ncols * nrows);
    for t in tokens {
        let v: f64 = t
            .parse()
            .map_err(|_| format!("elevation `{t}` (value {}) is not a number", z.len() + 1))?;
        z.push((v.is_finite() && Some(v) != nodata).then_some(v));
    }
    if z.len() != ncols * nrows {
        return Err(format!(
            "holds {} elevations, but ncols × nrows = {ncols} × {nrows} = {}; fix: give nrows lines of ncols elevations after the header",
            z.len(),
            ncols * nrows
        ));
    }
    Ok(Grid {
        ncols,
        nrows,
        x0,
        y0,
        cell,
        z,
    })
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
        let mut s = format!(
            "ncols {}\nnrows {}\nxllcenter {}\nyllcenter {}\ncellsize {}\nNODATA_value -9999\n",
            self.ncols, self.nrows, self.x0, self.y0, self.cell
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
        };
        for r in 0..nrows {
            for c in 0..ncols {
                let (x, y) = g.centre(r, c);
                g.z.push(Some(z(x, y)));
            }
        }
        g
    }

    /// Centre of cell (row from the north, column from the west).
    pub fn centre(&self, row: usize, col: usize) -> (f64, f64) {
        (
            self.x0 + col as f64 * self.cell,
            self.y0 + (self.nrows - 1 - row) as f64 * self.cell,
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
