//! The highest contact frequency ω_max of the block system, for the explicit limit
//! dt ≤ 2/ω_max (paper Eq. 8).
//!
//! For each free block, the 6×6 stiffness of its contact springs K (normal k_n along n, shear
//! k_s in the tangent plane, each acting through the generalised direction [e; r × e]) is
//! mass-normalised, M^(-1/2) K M^(-1/2), and its largest eigenvalue taken. A spring to another
//! free block counts (1 + m_i/m_j) times, the Gershgorin share of the partner's motion (exact
//! for two equal masses, 2k/m). The current contacts give one estimate; a floor taken at set-up,
//! the block resting on each of its faces with a spring at every corner, anticipates contacts
//! not made yet (a block falling onto the floor).
//!
//! **Deformable blocks** (12 unknowns) add a 6×6 strain block: their contact springs act on the
//! strains through T_e(X)ᵀ Rᵀ e (mass-normalised by M_e^(−½)), and the block's own elastic
//! stiffness M_e^(−½) V D M_e^(−½) is added to it. The rigid–strain coupling of the springs is
//! not assembled: for a symmetric positive semi-definite block matrix [A B; Bᵀ C],
//! λ_max ≤ λ_max(A) + λ_max(C) (write a unit vector as (cos t·u, sin t·v): the Rayleigh
//! quotient is at most cos²t λ_A + sin²t λ_C + 2|cos t sin t| sqrt(λ_A λ_C) ≤ λ_A + λ_C, since
//! |uᵀBv| ≤ sqrt(uᵀAu · vᵀCv) for a PSD matrix), so ω² ≤ λ_max(rigid) + λ_max(strain) is a
//! conservative bound. It is exact when the coupled springs have rank one (a cube on one face
//! under normal springs only: 4k/m translation + 12k/m strain = 16k/m, the true εz–z mode), and
//! in free flight it is the elastic mode itself, ω² = 36 K/(ρ L²) for a cube (the volumetric
//! mode, ν < 0.3) or 24 μ/(ρ L²) (deviatoric). Rigid blocks get no strain block at all.

use crate::blocks::block::Block;
use crate::blocks::elastic::largest_eigenvalue;
use crate::contact::tangents;
use crate::world::World;
use nalgebra::{Matrix6, Vector6};
use rayon::prelude::*;
use shared::geometry::strain;
use shared::math::{Point, Real, Vector};

/// An ω² estimate and what binds it.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Estimate {
    /// ω_max² [1/s²].
    pub omega2: Real,
    /// The deformable block whose own elastic mode is more than half of the largest bound,
    /// when there is one: the instability report names it.
    pub elastic: Option<usize>,
}

impl Estimate {
    pub fn max(self, other: Estimate) -> Estimate {
        if other.omega2 > self.omega2 {
            other
        } else {
            self
        }
    }
}

/// Per-block matrices reused between calls.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct Scratch {
    rigid: Vec<Matrix6<Real>>,
    strain: Vec<Matrix6<Real>>,
}

/// Generalised direction of a unit force `e` at lever arm `r`, mass-normalised for `b`.
#[inline]
fn normalised_direction(b: &Block, r: &Vector, e: &Vector) -> Vector6<Real> {
    let rot = b.rotation.to_rotation_matrix();
    let inv_sqrt_world = rot.matrix() * b.inv_sqrt_inertia * rot.matrix().transpose();
    let t = inv_sqrt_world * r.cross(e);
    let s = 1.0 / b.mass.sqrt();
    Vector6::new(e.x * s, e.y * s, e.z * s, t.x, t.y, t.z)
}

/// Adds the springs of one contact point (normal `n`, lever arm `r`) to a mass-normalised
/// block stiffness, scaled by `share`.
fn add_contact(
    k: &mut Matrix6<Real>,
    b: &Block,
    r: &Vector,
    n: &Vector,
    kn: Real,
    ks: Real,
    share: Real,
) {
    let (t1, t2) = tangents(n);
    for (e, kk) in [(n, kn), (&t1, ks), (&t2, ks)] {
        let g = normalised_direction(b, r, e);
        *k += g * g.transpose() * (kk * share);
    }
}

/// The same springs on the strain unknowns of a deformable block (at world point `p`):
/// directions M_e^(−½) T_e(X)ᵀ Rᵀ e. Nothing for a rigid block. (Out of line, with its own
/// rank-one update: the rigid blocks' loop above compiles as it did without it.)
#[inline(never)]
fn add_contact_strain(
    k: &mut Matrix6<Real>,
    b: &Block,
    p: &Point,
    n: &Vector,
    kn: Real,
    ks: Real,
    share: Real,
) {
    let Some(el) = &b.elastic else { return };
    let x = b.material_point(p);
    let (t1, t2) = tangents(n);
    for (e, kk) in [(n, kn), (&t1, ks), (&t2, ks)] {
        let local = b.rotation.inverse_transform_vector(e);
        let g = el.inv_sqrt_mass * strain::generalised_force(&x, &local);
        k.ger(kk * share, &g, &g, 1.0);
    }
}

/// The bound λ_max(rigid) + λ_max(strain + elastic) of a deformable block (see the module
/// docs), with the elastic mode named when it is the larger half.
#[inline(never)]
fn deformable_bound(
    b: &Block,
    i: usize,
    rigid: &Matrix6<Real>,
    strain: &Matrix6<Real>,
) -> Estimate {
    let el = b.elastic.as_ref().expect("a deformable block");
    let lr = if rigid.iter().any(|&x| x != 0.0) {
        largest_eigenvalue(rigid)
    } else {
        0.0
    };
    let omega2 = lr + largest_eigenvalue(&(strain + el.normalised_stiffness));
    Estimate {
        omega2,
        elastic: (el.omega2 > 0.5 * omega2).then_some(i),
    }
}

/// ω² of a block resting on its worst face with a spring at each corner, the largest over the
/// free blocks (doubled when free blocks can touch each other).
pub fn resting_floor(world: &World) -> Estimate {
    let (kn, ks) = (world.penalty.normal, world.penalty.shear);
    let neighbours = if world.free.len() > 1 { 2.0 } else { 1.0 };
    let mut best = Estimate::default();
    for &i in &world.free {
        let b = &world.blocks[i];
        for f in 0..b.shape.faces.len() {
            let mut k = Matrix6::zeros();
            let mut ke = Matrix6::zeros();
            let n = -(b.rotation * b.shape.faces[f].normal);
            for &v in &b.shape.faces[f].vertices {
                let p = b.world_vertices[v as usize];
                add_contact(&mut k, b, &(p - b.position), &n, kn, ks, neighbours);
                add_contact_strain(&mut ke, b, &p, &n, kn, ks, neighbours);
            }
            let est = if b.is_deformable() {
                deformable_bound(b, i, &k, &ke)
            } else {
                Estimate {
                    omega2: largest_eigenvalue(&k),
                    elastic: None,
                }
            };
            best = best.max(est);
        }
    }
    best
}

/// ω² from the contacts present now (closed or within the margin), the largest over the free
/// blocks, and for deformable blocks the bound with their elastic mode (present without any
/// contact). `scratch` holds one matrix per block and is reused.
pub fn current(world: &World, scratch: &mut Scratch) -> Estimate {
    let n = world.blocks.len();
    scratch.rigid.clear();
    scratch.rigid.resize(n, Matrix6::zeros());
    let deformable = !world.deformable.is_empty();
    if deformable {
        scratch.strain.clear();
        scratch.strain.resize(n, Matrix6::zeros());
    }
    let (kn, ks) = (world.penalty.normal, world.penalty.shear);
    for c in &world.contacts {
        let (pi, qi) = (c.p as usize, c.q as usize);
        let (p, q) = (&world.blocks[pi], &world.blocks[qi]);
        if p.is_free() {
            let share = if q.is_free() {
                1.0 + p.mass / q.mass
            } else {
                1.0
            };
            add_contact(
                &mut scratch.rigid[pi],
                p,
                &(c.point - p.position),
                &c.normal,
                kn,
                ks,
                share,
            );
            if deformable {
                let ke = &mut scratch.strain[pi];
                add_contact_strain(ke, p, &c.point, &c.normal, kn, ks, share);
            }
        }
        if q.is_free() {
            let share = if p.is_free() {
                1.0 + q.mass / p.mass
            } else {
                1.0
            };
            add_contact(
                &mut scratch.rigid[qi],
                q,
                &(c.point - q.position),
                &c.normal,
                kn,
                ks,
                share,
            );
            if deformable {
                let ke = &mut scratch.strain[qi];
                add_contact_strain(ke, q, &c.point, &c.normal, kn, ks, share);
            }
        }
    }
    let rigid = scratch
        .rigid
        .par_iter()
        .with_min_len(32)
        .filter(|k| k.iter().any(|&x| x != 0.0))
        .map(largest_eigenvalue)
        .reduce(|| 0.0, Real::max);
    let mut best = Estimate {
        omega2: rigid,
        elastic: None,
    };
    for &i in &world.deformable {
        let est = deformable_bound(&world.blocks[i], i, &scratch.rigid[i], &scratch.strain[i]);
        best = best.max(est);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::Scene;

    /// A cube resting on a face with four corner springs: the highest mode is rocking,
    /// ω² = k a² / I = 6 k/m for normal springs only (translation is 4k/m).
    #[test]
    fn cube_on_four_corners_rocks_at_sqrt_6k_over_m() {
        let text = r#"
            name = "t"
            [time]
            end = 1.0
            [domain]
            min = [-5.0, -5.0, -5.0]
            max = [5.0, 5.0, 5.0]
            [solid.contact]
            normal_stiffness = 1e6
            shear_ratio = 0.0
            [[block]]
            name = "cube"
            shape = { type = "box", min = [0.0, 0.0, 0.0], max = [0.5, 0.5, 0.5] }
            density = 2000.0
        "#;
        let scene = Scene::parse(text, "t").unwrap();
        let world = World::new(&scene).unwrap();
        let m = world.blocks[0].mass;
        let w2 = resting_floor(&world).omega2;
        assert!(
            (w2 / (6.0 * 1e6 / m) - 1.0).abs() < 1e-9,
            "ω² = {w2}, 6k/m = {}",
            6e6 / m
        );
    }
}
