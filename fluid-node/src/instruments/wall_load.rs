//! What a probe's face reads with `reading = "wall"` ([`shared::scene::FaceReading::Wall`]): the
//! load the water puts on the wall behind the face, per unit area, averaged over the face's
//! disk. A transducer's diaphragm is pushed by the water's force on the wall there, and the
//! force on the wall is what stops the water: its time integral is the momentum the wall takes
//! out of the flow (the probe's impulse is the wall's, not an interpolation's).
//!
//! # What is summed
//!
//! The wall's boundary particles (Adami, Hu & Adams 2012) take from each fluid neighbour the
//! reverse of the method's wall term, the force the method's step puts on the water
//! ([`crate::methods::SphMethod::fixed_wall_forces`]), as a moving block does
//! ([`crate::boundary::Boundary::react`]). The boundary particles lie on the water's lattice,
//! in columns behind the face; a column's force over its cell of the face (dx × dx) is the
//! wall's mean normal stress there, and the reading is the mean of that piecewise-constant
//! stress over the disk: each boundary particle behind the face, within one kernel support of
//! it, weighs the fraction of the disk its column's cell covers, over dx². A particle whose
//! column is buried in another fixed block (under the floor, where the wall meets it) is the
//! wall's too, and belongs to the first column outside that block: in a corner the fluid's
//! kernel reaches the particles below the floor, and their push on the water is the wall's
//! (in the Lobovský tank, sensor 1 sits 3 mm above the floor).
//!
//! The wall also holds the water by paper Eq. 22's backstop, a spring on any particle that
//! comes within its margin of the face (a quarter spacing by default, `system::setup`). At rest
//! it does nothing; where the face is off the lattice the water presses into it, the boundary
//! particles standing up to a spacing behind the face (the Lobovský tank 80.5 spacings long:
//! twice the boundary particles' impulse at sensor 1 over the impact; docs/VALIDATION.md,
//! "What a sensor reads"). Its force on a particle within one
//! spacing of the face counts in the column whose cell the particle's foot on the face lies in,
//! with that column's weight: the reading is the wall's whole force on the water.
//!
//! At rest the reading is ρ0 g times the depth of the cell's centre within 3 % (the deficit of
//! the boundary force at the free surface and in the corner, `wall_load`'s hydrostatic test).
//! What it leaves out: for DFSPH, the position corrections that keep particles off the faces
//! (they move particles, they exert no force).
//!
//! # Same bits on any rank count
//!
//! Each rank sums its own particles' pairs; the terms are keyed by the fluid particle's place
//! in one-rank order and the boundary particle's position, and rank 0 adds them in that order.

use crate::boundary::walls::WallParticles;
use crate::core::grid::CellGrid;
use crate::ranks::share::Share;
use shared::geometry::Polyhedron;
use shared::math::{Point, Real, Vector};
use shared::scene::{FaceReading, ProbeSpec};

/// Samples across the disk's diameter for the cells' shares of it (setup only): the shares
/// are exact to about 1/SAMPLES of the disk.
const SAMPLES: usize = 96;

/// A column of the wall behind a face: its cell's centre on the face and its weight [1/m²].
type Column = (Vector, Real);

/// One wall-reading face: its boundary particles and their weights.
#[derive(Debug, Clone)]
struct Face {
    /// Unit normal out of the wall, into the water.
    normal: Vector,
    /// (fixed boundary particle, weight [1/m²]): the share of the disk its column's cell
    /// covers, over dx². Sorted by particle.
    members: Vec<(u32, Real)>,
    /// The columns that meet the disk, for the backstop's force on the particles in front of
    /// them.
    columns: Vec<Column>,
    /// Two unit vectors along the face (the cells' edges) and the spacing.
    u: Vector,
    v: Vector,
    dx: Real,
    /// The box the members' fluid neighbours lie in (the members' box grown by the support).
    lo: Vector,
    hi: Vector,
}

/// The wall-reading faces of a scene's probes, and their last readings.
#[derive(Debug, Clone, Default)]
pub struct WallLoads {
    /// (probe index in the scene, its face).
    faces: Vec<(usize, Face)>,
    /// Each probe's last reading [Pa] (0 for a probe that does not read the wall).
    pub loads: Vec<Real>,
    /// Scratch: (fluid particle's key, [face slot, x_b, y_b, z_b, term]).
    terms: Vec<(u64, [Real; 5])>,
}

impl WallLoads {
    /// The faces of the `probes` that read the wall, from the fixed boundary particles `walls`
    /// and the fixed blocks `fixed` (to find the columns buried under another block). With
    /// every wall at hand (`whole`: one process), an error names a probe with no boundary
    /// particle behind its face.
    pub fn new(
        probes: &[ProbeSpec],
        walls: Option<&WallParticles>,
        fixed: &[Polyhedron],
        dx: Real,
        support: Real,
        whole: bool,
    ) -> Result<Self, String> {
        let mut faces = Vec::new();
        for (k, p) in probes.iter().enumerate() {
            let Some(f) = p.face.filter(|f| f.reading == FaceReading::Wall) else {
                continue;
            };
            let normal = Vector::from(f.normal).normalize();
            let centre = Vector::from(p.position);
            let (members, columns) = match walls {
                Some(w) => {
                    // [`members`]' own reach along the face, and a support of depth behind it.
                    let reach = 0.5 * f.diameter + 2.0 * support + 2.0 * dx;
                    swept(&w.position, &f.centres(p.position), reach, dx, |near, c| {
                        members(near, fixed, c, &normal, f.diameter, dx, support)
                    })
                }
                None => (Vec::new(), Vec::new()),
            };
            if members.is_empty() && whole {
                return Err(format!(
                    "probe '{}' (face reading = \"wall\"): no boundary particle lies behind its face at {:?}: put the probe's position on a fixed block's face, its normal into the water, or use reading = \"fluid\"",
                    p.name, p.position
                ));
            }
            // (A face with no member here, on a rank that holds none of its wall, reads
            // nothing: its empty box holds no fluid.)
            let (mut lo, mut hi) = (centre, centre);
            if let Some(w) = walls {
                for &(b, _) in &members {
                    lo = lo.inf(&w.position[b as usize]);
                    hi = hi.sup(&w.position[b as usize]);
                }
            }
            let reach = Vector::repeat(support);
            let (u, v) = in_plane(&normal);
            faces.push((
                k,
                Face {
                    normal,
                    members,
                    columns,
                    u,
                    v,
                    dx,
                    lo: lo - reach,
                    hi: hi + reach,
                },
            ));
        }
        Ok(Self {
            faces,
            loads: vec![0.0; probes.len()],
            terms: Vec::new(),
        })
    }

    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// Reads every face: `pairs(i, visit)` calls `visit(b, F)` with the force F of each fixed
    /// boundary particle b near fluid particle i on it (the method's wall term), and
    /// `backstop[i]` is the Eq. 22 force on particle i at `position[i]`. The fluid is
    /// found in the cells of the last sort (`grid`), grown by how far particles may have moved
    /// since; on several ranks only `share`'s own particles are summed here and rank 0 holds
    /// the readings ([`Self::loads`]; the other ranks' are not meaningful).
    pub fn read(
        &mut self,
        walls: &WallParticles,
        grid: &CellGrid,
        share: Option<&Share>,
        position: &[Vector],
        backstop: &[Vector],
        mut pairs: impl FnMut(usize, &mut dyn FnMut(usize, Vector)),
    ) {
        if self.faces.is_empty() {
            return;
        }
        let mut terms = std::mem::take(&mut self.terms);
        terms.clear();
        let stale = Vector::repeat(grid.stale_reach());
        for (slot, (_, face)) in self.faces.iter().enumerate() {
            let (lo, hi) = (face.lo - stale, face.hi + stale);
            grid.box_cells(&lo, &hi, |_, range| {
                for i in range {
                    if share.is_some_and(|s| !s.owned[i]) {
                        continue;
                    }
                    let key = share.map_or(i as u64, |s| s.key(i));
                    pairs(i, &mut |b, force| {
                        if let Ok(m) = face.members.binary_search_by_key(&(b as u32), |m| m.0) {
                            let x = walls.position[b];
                            // The wall takes −F; its normal load is −F·(−n) = F·n.
                            let term = face.members[m].1 * force.dot(&face.normal);
                            terms.push((key, [slot as Real, x.x, x.y, x.z, term]));
                        }
                    });
                    // The backstop, keyed by its column's centre (on the face, where no
                    // boundary particle is).
                    if let Some((q, w)) = face.column_of(&position[i]) {
                        let term = w * backstop[i].dot(&face.normal);
                        if term != 0.0 {
                            terms.push((key, [slot as Real, q.x, q.y, q.z, term]));
                        }
                    }
                }
            });
        }
        let all = match share {
            None => Some(std::mem::take(&mut terms)),
            Some(s) => s.gather_items(&terms),
        };
        self.loads.iter_mut().for_each(|l| *l = 0.0);
        if let Some(mut all) = all {
            // One order on any rank count: by face, fluid particle (one-rank order: its index
            // on one rank, its (cell, place in cell) key on several), then the boundary
            // particle's position.
            all.sort_unstable_by(|a, b| {
                a.1[0].total_cmp(&b.1[0]).then(a.0.cmp(&b.0)).then_with(|| {
                    (1..4)
                        .map(|q| a.1[q].total_cmp(&b.1[q]))
                        .find(|o| o.is_ne())
                        .unwrap_or(std::cmp::Ordering::Equal)
                })
            });
            for (_, v) in &all {
                let (probe, _) = self.faces[v[0] as usize];
                self.loads[probe] += v[4];
            }
            if share.is_none() {
                terms = all;
            }
        }
        self.terms = terms;
    }
}

impl Face {
    /// The column (its cell's centre on the face, its weight) in front of which a fluid
    /// particle at `x` lies, when the particle is within one spacing of the face's plane (on
    /// either side: one pushed through is still the wall's); None elsewhere.
    fn column_of(&self, x: &Vector) -> Option<Column> {
        let (&(q0, _), half) = (self.columns.first()?, 0.5 * self.dx);
        if (x - q0).dot(&self.normal).abs() > self.dx {
            return None;
        }
        let cell = |t: Real| (-half..half).contains(&t);
        self.columns
            .iter()
            .find(|(q, _)| {
                let r = x - q;
                cell(r.dot(&self.u)) && cell(r.dot(&self.v))
            })
            .copied()
    }
}

/// The boundary particles behind a face (centre `c`, unit normal `n` into the water, diameter
/// `d`) within `support` of it, each with the share of the disk its column's cell covers over
/// dx², sorted by particle; and the columns (cell centre on the face, the same weight).
fn members(
    walls: &[Vector],
    fixed: &[Polyhedron],
    c: &Vector,
    n: &Vector,
    d: Real,
    dx: Real,
    support: Real,
) -> (Vec<(u32, Real)>, Vec<Column>) {
    let radius = 0.5 * d;
    // The disk's samples, equal areas on a square lattice (the disk's points of it).
    let step = d / SAMPLES as Real;
    let (u, v) = in_plane(n);
    let disk: Vec<Vector> = (0..SAMPLES * SAMPLES)
        .map(|s| {
            let a = ((s % SAMPLES) as Real + 0.5) * step - radius;
            let b = ((s / SAMPLES) as Real + 0.5) * step - radius;
            (a, b)
        })
        .filter(|(a, b)| a * a + b * b <= radius * radius)
        .map(|(a, b)| c + u * a + v * b)
        .collect();
    let mut out = Vec::new();
    let mut columns: Vec<Column> = Vec::new();
    for (b, x) in walls.iter().enumerate() {
        let depth = (c - x).dot(n);
        let on_face = x + n * depth;
        // Behind the face, within a support; and near enough along it that its column, or the
        // one a burying block moves it to (by up to a support), can meet the disk.
        if depth <= 0.0 || depth > support || (on_face - c).norm() > radius + support + 2.0 * dx {
            continue;
        }
        // The column's cell centre on the face, out of any block that buries it.
        let Some(q) = column(&on_face, n, fixed, dx) else {
            continue;
        };
        if (q - c).norm() > radius + dx {
            continue;
        }
        let inside = disk
            .iter()
            .filter(|s| {
                let r = *s - q;
                // Half-open cells: a sample on a shared edge is in one of them.
                let half = |t: Real| (-0.5 * dx..0.5 * dx).contains(&t);
                half(r.dot(&u)) && half(r.dot(&v))
            })
            .count();
        if inside > 0 {
            let weight = inside as Real / disk.len() as Real / (dx * dx);
            out.push((b as u32, weight));
            // One entry per column: its particles' cells coincide (to rounding).
            if !columns.iter().any(|(p, _)| (p - q).norm() < 1e-6 * dx) {
                columns.push((q, weight));
            }
        }
    }
    (out, columns)
}

/// The members and columns of a face that is the mean of disks at `centres` (a face with a
/// `span`; one disk without): each disk's (`disk`, [`members`] over the boundary particles
/// within `reach` of the line through the centres, found once) with its weights shared among
/// the disks, a particle's or column's shares summed. Members stay sorted by particle,
/// columns in the order first met (one disk: its own lists, weights × 1).
fn swept(
    walls: &[Vector],
    centres: &[[Real; 3]],
    reach: Real,
    dx: Real,
    disk: impl Fn(&[Vector], &Vector) -> (Vec<(u32, Real)>, Vec<Column>),
) -> (Vec<(u32, Real)>, Vec<Column>) {
    let (Some(first), Some(last)) = (centres.first(), centres.last()) else {
        return (Vec::new(), Vec::new());
    };
    let (a, b) = (Vector::from(*first), Vector::from(*last));
    let along = b - a;
    let near_line = |x: &Vector| {
        let t = if along.norm_squared() > 0.0 {
            ((x - a).dot(&along) / along.norm_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (x - (a + along * t)).norm() <= reach
    };
    let index: Vec<u32> = (0..walls.len() as u32)
        .filter(|&k| near_line(&walls[k as usize]))
        .collect();
    let near: Vec<Vector> = index.iter().map(|&k| walls[k as usize]).collect();
    let share = 1.0 / centres.len() as Real;
    let mut members = std::collections::BTreeMap::<u32, Real>::new();
    let mut columns: Vec<Column> = Vec::new();
    for c in centres {
        let (m, cols) = disk(&near, &Vector::from(*c));
        for (k, w) in m {
            *members.entry(index[k as usize]).or_insert(0.0) += w * share;
        }
        for (q, w) in cols {
            match columns.iter_mut().find(|(p, _)| (p - q).norm() < 1e-6 * dx) {
                Some(col) => col.1 += w * share,
                None => columns.push((q, w * share)),
            }
        }
    }
    (members.into_iter().collect(), columns)
}

/// Where on the face the column through face point `q` counts: `q` itself, or, when the
/// water side of `q` is inside a fixed block (the column is under the floor), the first
/// lattice row out of that block (half a spacing past the block's nearest face), projected
/// back onto the face's plane. None when that is buried too.
fn column(q: &Vector, n: &Vector, fixed: &[Polyhedron], dx: Real) -> Option<Vector> {
    let probe = q + n * (0.25 * dx);
    let buried = |x: &Vector| {
        fixed.iter().find_map(|p| {
            let local = Point::from(*x - p.centroid.coords);
            let (d, f) = p.plane_distance(&local);
            (d < 0.0).then(|| (-d, p.faces[f].normal))
        })
    };
    match buried(&probe) {
        None => Some(*q),
        Some((depth, out)) => {
            let moved = probe + out * (depth + 0.5 * dx);
            if buried(&moved).is_some() {
                return None;
            }
            // Back onto the face's plane through q.
            Some(moved - n * (moved - q).dot(n))
        }
    }
}

/// How the faces of the wall-reading probes among `probes` miss the water's lattice
/// (`anchor + k·dx`, which the boundary particles share): one sentence per plane, naming its
/// probes, none for a face on it. On the lattice a face lies half a spacing from the nearest
/// row of boundary particles behind it and from the water's first row in front. Off it by more
/// than a quarter spacing the wall that holds the water is not where the face is: a row behind
/// the face by nearly a spacing leaves the water's first row within Eq. 22's margin of the
/// face, on the backstop's spring, and the peak is the spring's (the Lobovský tank 1.61 m long
/// at dx = 20 mm, 80.5 spacings: docs/VALIDATION.md, "What a sensor reads"); a row just behind
/// it holds the water off the face. A probe's normal is an axis (the scene check refuses
/// others).
pub fn off_lattice(probes: &[ProbeSpec], anchor: &Vector, dx: Real) -> Vec<String> {
    // The axis, the face's coordinate along it, whether the wall lies up the axis from the
    // face (its normal points down it).
    type Plane = (usize, Real, bool);
    let mut planes: Vec<(Plane, Vec<&str>)> = Vec::new();
    for p in probes {
        let Some(face) = p.face.filter(|f| f.reading == FaceReading::Wall) else {
            continue;
        };
        let Some(k) = (0..3).max_by(|&a, &b| face.normal[a].abs().total_cmp(&face.normal[b].abs()))
        else {
            continue;
        };
        let key = (k, p.position[k], face.normal[k] < 0.0);
        match planes.iter_mut().find(|(q, _)| *q == key) {
            Some((_, names)) => names.push(&p.name),
            None => planes.push((key, vec![&p.name])),
        }
    }
    planes
        .into_iter()
        .filter_map(|((k, s, wall_up), names)| {
            let a = anchor[k];
            // Rows a + j·dx; the wall lies behind the face, against its normal.
            let t = (s - a) / dx;
            let frac = t - t.floor();
            let on_row = frac.min(1.0 - frac) < 1e-6;
            let behind = if wall_up { 1.0 - frac } else { frac };
            if !on_row && (behind - 0.5).abs() <= 0.25 {
                return None;
            }
            // A row on the face is the wall's or the water's by the last bit of a sum.
            let stands = if on_row {
                "stands on the face or a whole spacing behind it (a row lies on the face)".to_string()
            } else {
                format!("stands {behind:.2} spacings behind the face")
            };
            let axis = ["x", "y", "z"][k];
            let below = a + ((t - 0.5).floor() + 0.5) * dx;
            // To a nanometre: a + (j + ½)·dx carries the float sums' last bits.
            let on = |v: Real| shared::math::readable((v * 1e9).round() / 1e9);
            let probes = if names.len() == 1 { "probe" } else { "probes" };
            let names: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
            Some(format!(
                "{probes} {} (face reading = \"wall\") at {axis} = {} m: the wall's first row of boundary particles {stands} (on the water's lattice, rows every dx = {} m from {axis} = {} m, it stands half a spacing behind): the wall that holds the water is not at the face, and from 0.75 spacings on the water's first row lies within Eq. 22's margin of the face, on its spring, whose load a peak then reads; fix: put the face (its block and the probes) at {axis} = {} or {} m, half a spacing from a row",
                names.join(", "),
                on(s),
                on(dx),
                on(a),
                on(below),
                on(below + dx),
            ))
        })
        .collect()
}

/// Two unit vectors spanning the plane normal to `n` (an axis: validation refuses others).
fn in_plane(n: &Vector) -> (Vector, Vector) {
    let k = (0..3)
        .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
        .unwrap_or(0);
    let mut e = Vector::zeros();
    e[k] = 1.0;
    let u = (e - n * e.dot(n)).normalize();
    (u, n.cross(&u))
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::ShapeSpec;

    /// The Lobovský tank's right wall at dx = 20 mm with the water's corner at x = 0 (rows at
    /// 0.01 + 0.02 j): 1.61 m lies on a row (the first row behind it a whole spacing back),
    /// 1.62 m half a spacing past one; within a quarter spacing of that the face is on. The
    /// probes on one plane are one warning.
    #[test]
    fn a_wall_face_off_the_lattice_is_named_with_the_faces_on_it() {
        let probe = |name: &str, x: Real, reading: &str| -> ProbeSpec {
            let text = format!(
                "name = \"{name}\"\nposition = [{x}, 0.08, 0.003]\nface = {{ diameter = 0.0042, normal = [-1.0, 0.0, 0.0], reading = \"{reading}\" }}"
            );
            toml::from_str(&text).unwrap()
        };
        let anchor = Vector::new(0.01, 0.01, 0.01);
        let dx = 0.02;
        let check = |x: Real| off_lattice(&[probe("s1", x, "wall")], &anchor, dx);
        let w = off_lattice(
            &[probe("s1", 1.61, "wall"), probe("s2", 1.61, "wall")],
            &anchor,
            dx,
        );
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("probes 's1', 's2'")
                && w[0].contains("at x = 1.61 m: the wall's first row of boundary particles stands on the face or a whole spacing behind it")
                && w[0].contains("at x = 1.6 or 1.62 m"),
            "{w:?}"
        );
        assert!(check(1.62).is_empty());
        // The first row behind at 1.63 m: 0.8 and 0.1 spacings are off, 0.7 is not.
        let w = check(1.614);
        assert!(
            w.len() == 1 && w[0].contains("probe 's1' ") && w[0].contains("0.80 spacings behind"),
            "{w:?}"
        );
        assert_eq!(check(1.628).len(), 1);
        assert!(check(1.616).is_empty());
        // Facing +x (a left wall), the row behind lies below the face.
        let mut left = probe("s1", 0.0, "wall");
        left.face.as_mut().unwrap().normal = [1.0, 0.0, 0.0];
        assert!(off_lattice(std::slice::from_ref(&left), &anchor, dx).is_empty());
        left.position[0] = 0.01;
        assert_eq!(off_lattice(&[left], &anchor, dx).len(), 1);
        // A face that reads the water's pressure has no wall to be off.
        assert!(off_lattice(&[probe("s1", 1.61, "fluid")], &anchor, dx).is_empty());
    }

    fn boxed(min: [Real; 3], max: [Real; 3]) -> Polyhedron {
        Polyhedron::from_shape(&ShapeSpec::Box { min, max }).unwrap()
    }

    /// Boundary particles on the lattice (k + ½) dx inside [lo, hi].
    fn lattice(lo: [Real; 3], hi: [Real; 3], dx: Real) -> Vec<Vector> {
        let n = |a: usize| ((hi[a] - lo[a]) / dx).round() as usize;
        let mut out = Vec::new();
        for i in 0..n(0) {
            for j in 0..n(1) {
                for k in 0..n(2) {
                    out.push(Vector::new(
                        lo[0] + (i as Real + 0.5) * dx,
                        lo[1] + (j as Real + 0.5) * dx,
                        lo[2] + (k as Real + 0.5) * dx,
                    ));
                }
            }
        }
        out
    }

    /// A right wall x ∈ [1, 1.1] over a floor z ∈ [−0.1, 0] that runs under it, the lattice
    /// of both (each point once).
    fn corner(dx: Real) -> (Vec<Vector>, Vec<Polyhedron>) {
        let mut pts = lattice([1.0, 0.0, 0.0], [1.1, 0.2, 0.3], dx);
        pts.extend(lattice([0.5, 0.0, -0.1], [1.1, 0.2, 0.0], dx));
        let blocks = vec![
            boxed([1.0, 0.0, 0.0], [1.1, 0.2, 0.3]),
            boxed([0.5, 0.0, -0.1], [1.1, 0.2, 0.0]),
        ];
        (pts, blocks)
    }

    /// The weights of each column (the members' shares summed over a column's depth, times
    /// dx², by the column's (y, z) cell after the corner's move) add up to the whole disk,
    /// however the disk sits on the cells.
    #[test]
    fn the_columns_shares_cover_the_disk_once() {
        let dx = 0.02;
        let (pts, blocks) = corner(dx);
        let n = Vector::new(-1.0, 0.0, 0.0);
        for (z, d) in [(0.15, 0.0042), (0.1, 0.0042), (0.15, 0.05), (0.06, 0.03)] {
            let c = Vector::new(1.0, 0.1, z);
            let (m, _) = members(&pts, &blocks, &c, &n, d, dx, 2.6 * dx);
            // One row of particles per column counts each column once.
            let front: Real = m
                .iter()
                .filter(|(b, _)| (pts[*b as usize].x - (1.0 + 0.5 * dx)).abs() < 1e-9)
                .map(|(_, w)| w * dx * dx)
                .sum();
            assert!((front - 1.0).abs() < 0.01, "z {z}, d {d}: {front}");
        }
    }

    /// A face swept along a span: its columns' shares add up to the whole face once, each
    /// column along the span takes its length's share (a strip 0.1 m long over columns 20 mm
    /// wide: a fifth each, a tenth at its two half-covered ends), and one disk (no span) is
    /// the disk's own lists, bit for bit.
    #[test]
    fn a_strip_shares_its_length_among_the_columns_along_it() {
        let dx = 0.02;
        let (pts, blocks) = corner(dx);
        let n = Vector::new(-1.0, 0.0, 0.0);
        let face = |span: Option<[Real; 3]>| shared::scene::ProbeFace {
            diameter: 0.0042,
            normal: [-1.0, 0.0, 0.0],
            reading: FaceReading::Wall,
            span,
        };
        let centre = [1.0, 0.1, 0.15];
        let reach = 0.5 * 0.0042 + 2.0 * 2.6 * dx + 2.0 * dx;
        let read = |f: &shared::scene::ProbeFace| {
            swept(&pts, &f.centres(centre), reach, dx, |near, c| {
                members(near, &blocks, c, &n, f.diameter, dx, 2.6 * dx)
            })
        };
        let (m, columns) = read(&face(Some([0.0, 0.1, 0.0])));
        let total: Real = columns.iter().map(|(_, w)| w * dx * dx).sum();
        assert!((total - 1.0).abs() < 1e-9, "{total}");
        // The strip runs from y = 0.05 to 0.15 over cells whose edges are at 0.04, 0.06, …:
        // four whole cells (0.06–0.14) and two halves.
        let mut shares: Vec<(Real, Real)> =
            columns.iter().map(|(q, w)| (q.y, w * dx * dx)).collect();
        shares.sort_by(|a, b| a.0.total_cmp(&b.0));
        let expected = [0.1, 0.2, 0.2, 0.2, 0.2, 0.1];
        assert_eq!(shares.len(), expected.len(), "{shares:?}");
        for ((_, got), want) in shares.iter().zip(expected) {
            assert!((got - want).abs() < 0.01, "{shares:?}");
        }
        assert!(m.windows(2).all(|w| w[0].0 < w[1].0), "members sorted");
        // Without a span: the disk's lists, bit for bit.
        let disk = face(None);
        let c = Vector::from(centre);
        let alone = members(&pts, &blocks, &c, &n, disk.diameter, dx, 2.6 * dx);
        assert_eq!(read(&disk), alone);
    }

    /// A sensor 3 mm above the floor at dx = 20 mm: its column is the lowest row of the wall
    /// (z = 10 mm) and the particles below the floor behind the wall join it, each with the
    /// whole disk's weight 1/dx² (the disk lies in one cell across y when centred on a
    /// column); nothing of the floor in front of the wall, nor beyond one support, is in.
    #[test]
    fn a_sensor_by_the_floor_takes_the_particles_under_it() {
        let dx = 0.02;
        let support = 2.6 * dx;
        let (pts, blocks) = corner(dx);
        let c = Vector::new(1.0, 0.09, 0.003);
        let (m, columns) = members(
            &pts,
            &blocks,
            &c,
            &Vector::new(-1.0, 0.0, 0.0),
            0.0042,
            dx,
            support,
        );
        assert!(!m.is_empty());
        for (b, w) in &m {
            let x = pts[*b as usize];
            assert!(x.x > 1.0 && x.x - 1.0 <= support, "{x}");
            assert!((x.y - 0.09).abs() < 1e-9, "{x}");
            assert!(x.z < dx, "{x}");
            assert!((w * dx * dx - 1.0).abs() < 1e-9, "{w}");
        }
        // Two rows deep in the wall (1.01, 1.03; 1.05 is past the support of 52 mm? no: in)
        // and the wall's lowest row plus the floor's rows under the wall within the support.
        let under = m.iter().filter(|(b, _)| pts[*b as usize].z < 0.0).count();
        let lowest = m.iter().filter(|(b, _)| pts[*b as usize].z > 0.0).count();
        assert_eq!(lowest, 3);
        assert!(under >= 3, "{under}");
        // One column, the lowest row's cell (z in [0, dx)) on the face, with the whole weight.
        assert_eq!(columns.len(), 1);
        let (q, w) = columns[0];
        assert!((q - Vector::new(1.0, 0.09, 0.01)).norm() < 1e-9, "{q}");
        assert!((w * dx * dx - 1.0).abs() < 1e-9, "{w}");
    }

    /// The backstop of a particle counts in the column its foot on the face lies in, within one
    /// spacing of the face (in front of it or pushed through it), and nowhere else.
    #[test]
    fn a_particle_at_the_face_counts_in_the_column_in_front_of_it() {
        let dx = 0.02;
        let (pts, blocks) = corner(dx);
        let c = Vector::new(1.0, 0.09, 0.003);
        let n = Vector::new(-1.0, 0.0, 0.0);
        let (members, columns) = members(&pts, &blocks, &c, &n, 0.0042, dx, 2.6 * dx);
        let (u, v) = in_plane(&n);
        let face = Face {
            normal: n,
            members,
            columns,
            u,
            v,
            dx,
            lo: Vector::zeros(),
            hi: Vector::zeros(),
        };
        let w = 1.0 / (dx * dx);
        for (x, expected) in [
            (Vector::new(0.995, 0.085, 0.004), Some(w)),
            (Vector::new(1.003, 0.099, 0.019), Some(w)),
            (Vector::new(0.981, 0.081, 0.001), Some(w)),
            // Above the lowest row, beside its cell, or farther than a spacing off the face.
            (Vector::new(0.995, 0.09, 0.021), None),
            (Vector::new(0.995, 0.101, 0.01), None),
            (Vector::new(0.979, 0.09, 0.01), None),
        ] {
            assert_eq!(face.column_of(&x).map(|c| c.1), expected, "{x}");
        }
    }
}
