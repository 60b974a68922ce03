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

use crate::block::Block;
use crate::world::World;
use nalgebra::{Matrix6, SymmetricEigen, Vector6};
use rayon::prelude::*;
use shared::math::{Real, Vector};

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
    let t1 = n
        .cross(&if n.x.abs() < 0.9 {
            Vector::x()
        } else {
            Vector::y()
        })
        .normalize();
    let t2 = n.cross(&t1);
    for (e, kk) in [(n, kn), (&t1, ks), (&t2, ks)] {
        let g = normalised_direction(b, r, e);
        *k += g * g.transpose() * (kk * share);
    }
}

fn largest_eigenvalue(k: Matrix6<Real>) -> Real {
    SymmetricEigen::new(k).eigenvalues.max()
}

/// ω² of a block resting on its worst face with a spring at each corner, the largest over the
/// free blocks (doubled when free blocks can touch each other).
pub fn resting_floor(world: &World) -> Real {
    let (kn, ks) = (world.penalty.normal, world.penalty.shear);
    let neighbours = if world.free.len() > 1 { 2.0 } else { 1.0 };
    world
        .free
        .iter()
        .map(|&i| {
            let b = &world.blocks[i];
            (0..b.shape.faces.len())
                .map(|f| {
                    let mut k = Matrix6::zeros();
                    let n = -(b.rotation * b.shape.faces[f].normal);
                    for &v in &b.shape.faces[f].vertices {
                        let r = b.world_vertices[v as usize] - b.position;
                        add_contact(&mut k, b, &r, &n, kn, ks, 1.0);
                    }
                    largest_eigenvalue(k)
                })
                .fold(0.0, Real::max)
                * neighbours
        })
        .fold(0.0, Real::max)
}

/// ω² from the contacts present now (closed or within the margin), the largest over the free
/// blocks. `scratch` holds one matrix per block and is reused.
pub fn current(world: &World, scratch: &mut Vec<Matrix6<Real>>) -> Real {
    let n = world.blocks.len();
    scratch.clear();
    scratch.resize(n, Matrix6::zeros());
    let (kn, ks) = (world.penalty.normal, world.penalty.shear);
    for c in &world.contacts {
        let (p, q) = (&world.blocks[c.p as usize], &world.blocks[c.q as usize]);
        if p.is_free() {
            let share = if q.is_free() {
                1.0 + p.mass / q.mass
            } else {
                1.0
            };
            add_contact(
                &mut scratch[c.p as usize],
                p,
                &(c.point - p.position),
                &c.normal,
                kn,
                ks,
                share,
            );
        }
        if q.is_free() {
            let share = if p.is_free() {
                1.0 + q.mass / p.mass
            } else {
                1.0
            };
            add_contact(
                &mut scratch[c.q as usize],
                q,
                &(c.point - q.position),
                &c.normal,
                kn,
                ks,
                share,
            );
        }
    }
    scratch
        .par_iter()
        .with_min_len(32)
        .filter(|k| k.iter().any(|&x| x != 0.0))
        .map(|k| largest_eigenvalue(*k))
        .reduce(|| 0.0, Real::max)
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
        let w2 = resting_floor(&world);
        assert!(
            (w2 / (6.0 * 1e6 / m) - 1.0).abs() < 1e-9,
            "ω² = {w2}, 6k/m = {}",
            6e6 / m
        );
    }
}
