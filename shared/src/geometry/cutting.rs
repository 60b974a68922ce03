//! Shi's block cutting for a convex region: the region is split by every plane of every joint
//! set in turn (a half-space split of a convex polyhedron gives two convex polyhedra), and each
//! block is the convex hull of its corners (Shi 1988, *Discontinuous Deformation Analysis*, ch. 3,
//! "block cutting"; for convex regions the cutting reduces to successive half-space splits).
//!
//! parry3d-f64 builds each cell's hull (merged polygonal faces) so the split only needs the
//! cell's corners and edges: the corners on each side of the plane, plus the points where the
//! edges cross it. Everything is in the scene's frame, in a fixed order (set by set, plane by
//! plane, cell by cell): the same input gives the same blocks, bit for bit, in every process.

use crate::math::{Point, Real, Vector};
use parry3d_f64::shape::ConvexPolyhedron;

/// A plane n·x = offset (n unit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub normal: Vector,
    pub offset: Real,
}

/// A convex cell: its corners and the edges between them.
#[derive(Debug, Clone)]
pub struct Cell {
    pub corners: Vec<Point>,
    pub edges: Vec<[u32; 2]>,
}

impl Cell {
    /// The convex hull of `points` reduced to its corners (points where at least three faces
    /// meet: points inside a face or an edge are dropped), or `None` when the points enclose no
    /// volume. `tol` [m] merges points closer than it.
    pub fn hull(points: &[Point], tol: Real) -> Option<Cell> {
        let mut unique: Vec<Point> = Vec::with_capacity(points.len());
        for p in points {
            if !unique.iter().any(|q| (p - q).norm() <= tol) {
                unique.push(*p);
            }
        }
        if unique.len() < 4 {
            return None;
        }
        let hull = ConvexPolyhedron::from_convex_hull(&unique)?;
        let adj = hull.vertices_adj_to_face();
        let mut face_count = vec![0u32; hull.points().len()];
        let faces: Vec<&[u32]> = hull
            .faces()
            .iter()
            .map(|f| {
                let first = f.first_vertex_or_edge as usize;
                &adj[first..first + f.num_vertices_or_edges as usize]
            })
            .collect();
        for f in &faces {
            for &v in *f {
                face_count[v as usize] += 1;
            }
        }
        // Corners only, renumbered; a face's polygon then runs corner to corner and its sides
        // (between consecutive corners) are the cell's edges.
        let mut index = vec![u32::MAX; face_count.len()];
        let mut corners = Vec::new();
        for (i, &n) in face_count.iter().enumerate() {
            if n >= 3 {
                index[i] = corners.len() as u32;
                corners.push(hull.points()[i]);
            }
        }
        if corners.len() < 4 {
            return None;
        }
        let mut edges: Vec<[u32; 2]> = Vec::new();
        for f in &faces {
            let ring: Vec<u32> = f
                .iter()
                .map(|&v| index[v as usize])
                .filter(|&v| v != u32::MAX)
                .collect();
            for k in 0..ring.len() {
                let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
                let e = [a.min(b), a.max(b)];
                if a != b && !edges.contains(&e) {
                    edges.push(e);
                }
            }
        }
        Some(Cell { corners, edges })
    }

    /// Range of n·x over the corners.
    pub fn extent(&self, n: &Vector) -> (Real, Real) {
        self.corners
            .iter()
            .map(|p| n.dot(&p.coords))
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), s| {
                (lo.min(s), hi.max(s))
            })
    }
}

/// What a plane does to a cell.
#[derive(Debug)]
pub enum Split {
    /// The plane misses the cell (or only touches it within the tolerance).
    Whole,
    /// The two sides: below (n·x < offset) and above. A side that encloses no volume (a sliver
    /// flatter than the tolerance) is `None`.
    Cut(Option<Cell>, Option<Cell>),
}

/// Splits `cell` by `plane`; corners within `tol` [m] of the plane belong to both sides.
pub fn split(cell: &Cell, plane: &Plane, tol: Real) -> Split {
    let s: Vec<Real> = cell
        .corners
        .iter()
        .map(|p| plane.normal.dot(&p.coords) - plane.offset)
        .collect();
    if !s.iter().any(|&x| x > tol) || !s.iter().any(|&x| x < -tol) {
        return Split::Whole;
    }
    let mut below = Vec::new();
    let mut above = Vec::new();
    for (p, &x) in cell.corners.iter().zip(&s) {
        if x <= tol {
            below.push(*p);
        }
        if x >= -tol {
            above.push(*p);
        }
    }
    for &[i, j] in &cell.edges {
        let (si, sj) = (s[i as usize], s[j as usize]);
        if (si > tol && sj < -tol) || (si < -tol && sj > tol) {
            let (pi, pj) = (cell.corners[i as usize], cell.corners[j as usize]);
            let x = pi + (pj - pi) * (si / (si - sj));
            below.push(x);
            above.push(x);
        }
    }
    Split::Cut(Cell::hull(&below, tol), Cell::hull(&above, tol))
}

/// A family of parallel planes n·x = base + k·spacing (k integer).
#[derive(Debug, Clone, Copy)]
pub struct PlaneFamily {
    pub normal: Vector,
    pub base: Real,
    pub spacing: Real,
}

impl PlaneFamily {
    /// The planes of the family strictly inside (lo, hi) (by more than `tol`), in increasing
    /// order of offset.
    /// The plane indices are counted in floating point ([`Self::count_within`]), so a base
    /// far from the cell (an offset of 1e300) yields no plane instead of an index range that
    /// saturates (and wraps) in integers.
    pub fn planes_within(&self, lo: Real, hi: Real, tol: Real) -> impl Iterator<Item = Plane> {
        let k0 = ((lo + tol - self.base) / self.spacing).floor() + 1.0;
        let fam = *self;
        (0..self.count_within(lo, hi, tol)).filter_map(move |i| {
            let offset = fam.base + (k0 + i as Real) * fam.spacing;
            (offset > lo + tol && offset < hi - tol).then_some(Plane {
                normal: fam.normal,
                offset,
            })
        })
    }

    /// How many planes of the family cross (lo, hi).
    pub fn count_within(&self, lo: Real, hi: Real, tol: Real) -> u64 {
        let k0 = ((lo + tol - self.base) / self.spacing).floor() + 1.0;
        let k1 = ((hi - tol - self.base) / self.spacing).ceil() - 1.0;
        if k1 >= k0 { (k1 - k0 + 1.0) as u64 } else { 0 }
    }
}

/// Cutting failed: more cells than allowed.
#[derive(Debug, Clone, PartialEq)]
pub struct TooMany {
    /// Cells when the cutting stopped (just above the limit).
    pub reached: usize,
}

/// The result of cutting: the cells, and the pieces too flat to be a cell (their count).
#[derive(Debug, Clone)]
pub struct Cut {
    pub cells: Vec<Cell>,
    /// Pieces with no volume within the tolerance, dropped while cutting.
    pub degenerate: usize,
    /// Per family: how many planes cut at least one cell.
    pub planes_used: Vec<usize>,
}

/// Cuts `region` by every plane of every family, in order. Stops (without allocating more) as
/// soon as the cell count exceeds `max_cells`: the count only grows as the cutting proceeds.
/// `progress(k, n)` is told after each cell is cut by family `k` that the pass holds `n` cells.
pub fn cut(
    region: Cell,
    families: &[PlaneFamily],
    tol: Real,
    max_cells: usize,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Cut, TooMany> {
    let mut cells = vec![region];
    let mut degenerate = 0;
    let mut planes_used = Vec::with_capacity(families.len());
    for (k, fam) in families.iter().enumerate() {
        let mut used = std::collections::BTreeSet::new();
        let mut next = Vec::with_capacity(cells.len());
        for cell in cells {
            let (lo, hi) = cell.extent(&fam.normal);
            let mut rest = Some(cell);
            // Planes in increasing offset: each cut peels the part below and keeps cutting the
            // part above.
            for plane in fam.planes_within(lo, hi, tol) {
                let Some(c) = rest.take() else { break };
                match split(&c, &plane, tol) {
                    Split::Whole => rest = Some(c),
                    Split::Cut(below, above) => {
                        used.insert(plane.offset.to_bits());
                        match below {
                            Some(b) => next.push(b),
                            None => degenerate += 1,
                        }
                        if above.is_none() {
                            degenerate += 1;
                        }
                        rest = above;
                    }
                }
                if next.len() > max_cells {
                    return Err(TooMany {
                        reached: next.len(),
                    });
                }
            }
            if let Some(c) = rest {
                next.push(c);
            }
            progress(k, next.len());
            if next.len() > max_cells {
                return Err(TooMany {
                    reached: next.len(),
                });
            }
        }
        planes_used.push(used.len());
        cells = next;
    }
    Ok(Cut {
        cells,
        degenerate,
        planes_used,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(a: Real) -> Cell {
        let mut pts = Vec::new();
        for i in 0..8 {
            pts.push(Point::new(
                a * (i & 1) as Real,
                a * ((i >> 1) & 1) as Real,
                a * ((i >> 2) & 1) as Real,
            ));
        }
        Cell::hull(&pts, 1e-12).unwrap()
    }

    #[test]
    fn hull_keeps_corners_only() {
        let mut pts: Vec<Point> = cube(1.0).corners;
        pts.push(Point::new(0.5, 0.5, 0.0)); // on a face
        pts.push(Point::new(0.5, 0.0, 0.0)); // on an edge
        pts.push(Point::new(0.5, 0.5, 0.5)); // inside
        let c = Cell::hull(&pts, 1e-12).unwrap();
        assert_eq!(c.corners.len(), 8);
        assert_eq!(c.edges.len(), 12);
    }

    #[test]
    fn a_diagonal_plane_halves_a_cube_into_two_prisms() {
        let n = Vector::new(1.0, 1.0, 0.0).normalize();
        let plane = Plane {
            normal: n,
            offset: n.dot(&Vector::new(0.5, 0.5, 0.0)),
        };
        let Split::Cut(Some(b), Some(a)) = split(&cube(1.0), &plane, 1e-12) else {
            panic!("no cut")
        };
        assert_eq!(b.corners.len(), 6);
        assert_eq!(a.corners.len(), 6);
        assert_eq!(b.edges.len(), 9);
    }

    #[test]
    fn a_plane_through_a_face_does_not_cut() {
        let plane = Plane {
            normal: Vector::z(),
            offset: 1.0,
        };
        assert!(matches!(split(&cube(1.0), &plane, 1e-12), Split::Whole));
    }

    #[test]
    fn planes_within_excludes_the_ends() {
        let fam = PlaneFamily {
            normal: Vector::x(),
            base: 0.0,
            spacing: 0.25,
        };
        let offs: Vec<Real> = fam
            .planes_within(0.0, 1.0, 1e-9)
            .map(|p| p.offset)
            .collect();
        assert_eq!(offs, vec![0.25, 0.5, 0.75]);
        assert_eq!(fam.count_within(0.0, 1.0, 1e-9), 3);
        assert_eq!(fam.count_within(0.1, 0.2, 1e-9), 0);
        // A base far away gives no plane, at once (the index range used to wrap).
        let far = PlaneFamily { base: 1e300, ..fam };
        assert_eq!(far.planes_within(0.0, 1.0, 1e-9).count(), 0);
        let far = PlaneFamily {
            base: -1e300,
            ..fam
        };
        assert_eq!(far.planes_within(0.0, 1.0, 1e-9).count(), 0);
    }

    #[test]
    fn cutting_stops_at_the_limit() {
        let fam = |n: Vector| PlaneFamily {
            normal: n,
            base: 0.0,
            spacing: 0.1,
        };
        let r = cut(
            cube(1.0),
            &[fam(Vector::x()), fam(Vector::y()), fam(Vector::z())],
            1e-12,
            50,
            &mut |_, _| {},
        );
        assert_eq!(r.unwrap_err().reached, 51);
    }

    #[test]
    fn progress_is_told_each_pass_up_to_the_cells_made() {
        let fam = |n: Vector| PlaneFamily {
            normal: n,
            base: 0.0,
            spacing: 0.5,
        };
        let mut seen = Vec::new();
        let c = cut(
            cube(1.0),
            &[fam(Vector::x()), fam(Vector::y())],
            1e-12,
            100,
            &mut |k, n| seen.push((k, n)),
        )
        .unwrap();
        assert_eq!(seen, vec![(0, 2), (1, 2), (1, 4)]);
        assert_eq!(c.cells.len(), 4);
    }
}
