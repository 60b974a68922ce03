//! The free blocks inside DFSPH's pressure solves (module doc of [`super`], "Blocks in the
//! solve"; Gissler et al. 2019): whether a step moves them, moving them by the solve's
//! forces, and the damping of the Jacobi increments next to them.

use super::{BLOCK_TOLERANCE, Dfsph};
use crate::core::exact_sum::{ExactSum, combine};
use crate::kernels::Kernel;
use crate::ranks::comm::wire;
use crate::ranks::share::Share;
use crate::system::FluidSystem;
use rayon::prelude::*;
use shared::geometry::strain::Strain;
use shared::math::{Real, Vector};
use shared::protocol::BlockLoad;

impl Dfsph {
    /// Whether this step moves blocks inside its solves: asked for, a free block exists, and
    /// the coupling scheme lets the loads follow the step (parallel; in the serial scheme the
    /// blocks keep their velocities, the lagged coupling).
    pub(super) fn moves_blocks(&self, sys: &FluidSystem) -> bool {
        self.blocks_in_solve
            && sys.loads_may_follow_step
            && sys.boundary.bodies().is_some_and(|b| b.any_free())
    }

    /// The free blocks answer a pressure within the solve (Gissler et al. 2019, rigid bodies
    /// in the pressure solve; here with the block's response over the step from the solid
    /// node, its contacts' answer included, [`crate::boundary::bodies::Rigid`]): the force of stiffness
    /// `k(i, p_b, ρ_b)` on each block's boundary particles, summed as [`Self::react`] sums the
    /// loads, moves the block by (Δv, Δω) = Δt M (F, τ) (Δt F/m, Δt I⁻¹τ for a block on its
    /// own; with `explicit`, also by the Eq. 22 load and Δt a0, the rest of its motion: the
    /// step's non-pressure part), and the boundary's part of Dρ/Dt,
    /// `wall_flux`, follows the new velocities. The water near a block then sees it give way
    /// within the step, so the pressure the solve converges to is that of the water and the
    /// block moving together: the partitioned scheme's one-step lag no longer multiplies the
    /// added mass (module doc, "Blocks in the solve").
    ///
    /// Returns how far the largest free block's load change was from converged: the change
    /// over [`BLOCK_TOLERANCE`] times the block's weight (force; torque over its radius of
    /// gyration).
    pub(super) fn move_blocks(
        &mut self,
        sys: &mut FluidSystem,
        dt: Real,
        explicit: bool,
        k: impl Fn(usize, Real, Real, &Vector) -> Real + Sync,
    ) -> Real {
        let (m, kernel) = (sys.mass, &self.kernel);
        // On several ranks rank 0 sums the loads in one-rank order (`BodyParticles::react`).
        let split = sys.share.as_ref().map(|s| (s, &sys.grid));
        sys.boundary.react(
            &sys.particles.position,
            kernel.support(),
            |i, pw, rw, r, len| r * (-m * m * k(i, pw, rw, r) * kernel.gradient_factor(len)),
            split,
        );
        let g = sys.gravity.norm().max(Real::MIN_POSITIVE);
        let Some(bodies) = sys.boundary.bodies_mut() else {
            return 0.0;
        };
        self.block_loads.clear();
        for (kb, (f, t, e)) in bodies.loads.iter().enumerate() {
            let (mut f, mut t, mut e) = (*f, *t, *e);
            if explicit && let Some(p) = sys.penalty_loads.get(kb) {
                f += Vector::from(p.force);
                t += Vector::from(p.torque);
                e += Strain::from(p.strain_load);
            }
            self.block_loads.push((f, t, e));
        }
        if let Some(s) = &sys.share {
            // Rank 0's sums (the others' are partial) move the blocks on every rank alike.
            broadcast_loads(s, &mut self.block_loads);
        }
        let mut left: Real = 0.0;
        let n = bodies.rigid.len();
        self.motion.resize(n, (Vector::zeros(), Vector::zeros()));
        self.loads.resize(n, BlockLoad::default());
        for (kb, (&(f, t, e), rigid)) in self.block_loads.iter().zip(&bodies.rigid).enumerate() {
            let load = &mut self.loads[kb];
            load.force = (Vector::from(load.force) + f).into();
            load.torque = (Vector::from(load.torque) + t).into();
            load.strain_load = (Strain::from(load.strain_load) + e).into();
            if rigid.inverse_mass > 0.0 {
                // Weight, and weight times the radius of gyration r² = 3/(m tr I⁻¹).
                let weight = BLOCK_TOLERANCE * g / rigid.inverse_mass;
                let r2 = 3.0 * rigid.inverse_mass
                    / rigid.inverse_inertia.trace().max(Real::MIN_POSITIVE);
                left = left
                    .max(f.norm() / weight)
                    .max(t.norm() / (weight * r2.sqrt()));
            }
            // With `explicit`, the rest of the block's motion over the step too: its weight,
            // its contacts.
            let (dv, dw) = rigid.response(&f, &t, dt, explicit);
            self.motion[kb].0 += dv;
            self.motion[kb].1 += dw;
        }
        bodies.nudge(&self.motion);
        self.update_flux(sys);
        left
    }

    /// The Jacobi damping near each free block. Each block joins the solve as a rank-six term
    /// K = m M Σ_i β_i u_i u_iᵀ (M the block's mobility over the step, diag(1/m, I⁻¹) for a
    /// block on its own), u_i = (a_i, c_i), a_i = m Σ_b ∇W_ib and
    /// c_i = m Σ_b (x_b − c) × ∇W_ib over its boundary neighbours b of particle i: a stiffness
    /// increment on the particles next to it moves the block, which relieves all of them at
    /// once, so their Jacobi update overshoots the block's mode by 1 + K (a light block, whose
    /// K is large, made the solve diverge). Their increments are damped by 1/(1 + tr K) (tr K
    /// bounds K's largest eigenvalue); the solution is unchanged, only the path to it. A
    /// particle touching several blocks takes the first one's.
    pub(super) fn block_damping(&mut self, sys: &FluidSystem) {
        let n = sys.len();
        self.damping.resize(n, 1.0);
        self.near.resize(n, (u32::MAX, 0.0));
        let Some(bodies) = sys.boundary.bodies() else {
            return;
        };
        let (m, kernel, boundary) = (sys.mass, &self.kernel, &sys.boundary);
        let s2 = kernel.support().powi(2);
        let (pos, beta, rigid) = (&sys.particles.position, &self.beta, &bodies.rigid);
        let owner = &bodies.owner_sorted;
        // A coherent increment pushes a block through both halves of a mirrored pair.
        let mu = 1.0 + self.mirror();
        // On several ranks the owned particles only (the halo's damping is not read).
        let owned = sys.owned();
        self.near.par_iter_mut().enumerate().for_each(|(i, near)| {
            if owned.is_some_and(|o| !o[i]) {
                *near = (u32::MAX, 0.0);
                return;
            }
            let xi = pos[i];
            let (mut first, mut a, mut c) = (u32::MAX, Vector::zeros(), Vector::zeros());
            boundary.for_each_moving_neighbor(i, |b| {
                let o = owner[b.index()];
                let rib = xi - b.position();
                let r2 = rib.norm_squared();
                if r2 < s2
                    && rigid[o as usize].inverse_mass > 0.0
                    && (first == u32::MAX || first == o)
                {
                    first = o;
                    let g = rib * kernel.gradient_factor(r2.sqrt());
                    a += g;
                    c += (b.position() - bodies.centroid(o as usize)).cross(&g);
                }
            });
            *near = if first == u32::MAX {
                (u32::MAX, 0.0)
            } else {
                let r = &rigid[first as usize];
                let (a, c) = (a * m, c * m);
                let s = mu * m * beta[i] * r.mobility_along(&a, &c);
                (first, s)
            };
        });
        // Exact sums: the same on any number of threads and ranks.
        let mut sums = vec![ExactSum::default(); rigid.len()];
        for &(o, s) in &self.near {
            if o != u32::MAX {
                sums[o as usize].add(s);
            }
        }
        if let Some(s) = &sys.share {
            combine(&mut sums, |w| s.comm().sum(w));
        }
        self.mobility.clear();
        self.mobility.extend(sums.iter().map(ExactSum::value));
        let mobility = &self.mobility;
        self.damping
            .par_iter_mut()
            .zip(self.near.par_iter())
            .for_each(|(d, &(o, _))| {
                *d = if o == u32::MAX {
                    1.0
                } else {
                    1.0 / (1.0 + mobility[o as usize])
                };
            });
    }
}

/// Rank 0's `loads` (force, torque, strain load per block) on every rank.
fn broadcast_loads(share: &Share, loads: &mut [(Vector, Vector, Strain)]) {
    let mut bytes = Vec::new();
    if share.rank() == 0 {
        for (f, t, e) in loads.iter() {
            wire::put_f64(
                &mut bytes,
                f.iter().chain(t.iter()).chain(e.iter()).copied(),
            );
        }
    }
    share.comm().broadcast(&mut bytes);
    let mut w = wire::f64s(&bytes);
    for (f, t, e) in loads.iter_mut() {
        for c in f.iter_mut().chain(t.iter_mut()).chain(e.iter_mut()) {
            *c = w.next().expect("rank 0 sent every block's load");
        }
    }
}
