//! One implicit solve of DFSPH: the divergence solve (2017 Algorithm 2) or the constant-density
//! solve (Algorithm 3), warm-started Jacobi iterations on the stiffness.

use super::{DIVERGED, Dfsph, WARM_START, halo, total};
use crate::system::FluidSystem;
use rayon::prelude::*;
use shared::math::{Real, Vector};

impl Dfsph {
    /// One implicit solve, 2017 Algorithm 2 (divergence, `density` false) or Algorithm 3
    /// (constant density): warm start, then Jacobi iterations on the stiffness until the mean
    /// error is below the tolerance (at least 1 resp. 2 iterations) or the cap. The accumulated
    /// stiffness is left in `k` (per particle, the warm start read from it). A solve whose
    /// error grows past [`DIVERGED`] times the smallest it reached, or that ends at the cap
    /// above it, returns to the iterate of that smallest error (module doc, "Stopping").
    /// Returns (iterations, final mean error, k, the iteration kept if it went back).
    pub(super) fn solve(
        &mut self,
        sys: &mut FluidSystem,
        dt: Real,
        density: bool,
        mut k: Vec<Real>,
    ) -> (usize, Real, Vec<Real>, Option<usize>) {
        let c = self.constants;
        let (tolerance, min_iterations, scale) = if density {
            (c.density_tolerance, 2, 1.0 / (dt * dt))
        } else {
            (c.divergence_tolerance, 1, 1.0 / dt)
        };
        // The constant-density solve also runs until its pressure has settled (module doc,
        // "Stopping"); the divergence solve's stiffness is a velocity correction, not read.
        let pressure_tolerance = if density {
            c.pressure_tolerance
        } else {
            Real::INFINITY
        };
        let mut change = Real::INFINITY;
        // Warm start (both papers): a fraction of the last step's stiffness where compressed.
        let blocks = self.moves_blocks(sys);
        self.predict(sys, dt, density);
        let mut dk = std::mem::take(&mut self.dk);
        let owned = sys.owned();
        dk.par_iter_mut()
            .zip(k.par_iter_mut())
            .zip(self.error.par_iter())
            .enumerate()
            .for_each(|(i, ((d, k), &e))| {
                if owned.is_some_and(|o| !o[i]) {
                    return;
                }
                *k = if e > 0.0 {
                    WARM_START * k.max(0.0)
                } else {
                    0.0
                };
                *d = *k;
            });
        for (i, [d]) in halo(&mut sys.share, |i| [dk[i]]) {
            (dk[i as usize], k[i as usize]) = (d, d);
        }
        let warm = dk.par_iter().any(|&d| d != 0.0);
        // Every rank applies it or none (each applies and shares alike).
        let warm = match &sys.share {
            Some(s) => crate::ranks::any(s.comm(), warm),
            None => warm,
        };
        if warm {
            self.apply(sys, &dk, dt);
            self.share_velocities(sys, blocks && self.mirrored);
            if blocks {
                let kbar = std::mem::take(&mut self.kbar);
                // The walls' k̄_i (zero unless mirrored) is the second half of each pair.
                self.move_blocks(sys, dt, false, |i, _, _, _| dk[i] + kbar[i]);
                self.kbar = kbar;
            }
        }
        let mut err = self.predict(sys, dt, density);
        let mut it = 0;
        // The iterate of the smallest error so far: its iteration, error, stiffness and the
        // free blocks' motion and loads (the velocities follow from the stiffness).
        let (mut best_it, mut best_err) = (0, err);
        self.keep_best(&k, blocks);
        // Plain Jacobi (ω = 1, the papers') until an iteration leaves the mean error above the
        // tolerance and larger than it found it: then the overshooting modes lead (module doc,
        // "Relaxed Jacobi"), and the rest of the solve is relaxed.
        let mut omega = 1.0;
        // How far the free blocks' loads are from converged (module doc, "Blocks in the solve").
        let mut block_left = if blocks { Real::INFINITY } else { 0.0 };
        while (it < min_iterations
            || err > tolerance
            || change > pressure_tolerance
            || block_left > 1.0)
            && it < c.max_iterations
        {
            // κ_i = (ρ*_i − ρ0)·α_i/dt² (Algorithm 3) or (Dρ_i/Dt)·α_i/dt (Algorithm 2), here
            // divided by ρ_i: k_i = error_i·β_i·scale, relaxed by ω once the error grew (module
            // doc, "Relaxed Jacobi"). Damped next to a free block in the solve (`block_damping`).
            let damping = blocks.then_some(&self.damping[..]);
            let owned = sys.owned();
            dk.par_iter_mut()
                .zip(k.par_iter_mut())
                .zip(self.error.par_iter().zip(self.beta.par_iter()))
                .enumerate()
                .for_each(|(i, ((d, k), (&e, &b)))| {
                    if owned.is_some_and(|o| !o[i]) {
                        return;
                    }
                    *d = e * b * scale * omega * damping.map_or(1.0, |w| w[i]);
                    *k += *d;
                });
            // The halo's increments: `apply` reads them of the neighbours, the blocks of
            // the particles next to them.
            for (i, [d]) in halo(&mut sys.share, |i| [dk[i]]) {
                dk[i as usize] = d;
                k[i as usize] += d;
            }
            if pressure_tolerance.is_finite() {
                // Σ|Δk| / Σ|k|: how much this iteration still moved the pressure field.
                let [moved, all] = total(sys, |i| [dk[i].abs(), k[i].abs()]);
                change = if all > 0.0 { moved / all } else { 0.0 };
            }
            self.apply(sys, &dk, dt);
            self.share_velocities(sys, blocks && self.mirrored);
            if blocks {
                let kbar = std::mem::take(&mut self.kbar);
                block_left = self.move_blocks(sys, dt, false, |i, _, _, _| dk[i] + kbar[i]);
                self.kbar = kbar;
            }
            let last = err;
            err = self.predict(sys, dt, density);
            if err > tolerance && err > last {
                omega = c.relaxation;
            }
            it += 1;
            if err < best_err {
                (best_it, best_err) = (it, err);
                self.keep_best(&k, blocks);
            } else if err > tolerance && err > DIVERGED * best_err {
                // Diverging (module doc, "Stopping").
                break;
            }
        }
        let mut kept = None;
        if err > tolerance && err > best_err {
            // Diverging, or stopped at the cap above an earlier iterate: back to the best one.
            // The velocity change is linear in the stiffness, so applying k_best − k undoes the
            // iterations since (to rounding); the blocks take their motion and loads then.
            // The halo's k too: its increments were shared, so k_best − k is its owner's.
            dk.par_iter_mut()
                .zip(k.par_iter_mut())
                .zip(self.k_best.par_iter())
                .for_each(|((d, k), &b)| {
                    *d = b - *k;
                    *k = b;
                });
            self.apply(sys, &dk, dt);
            self.share_velocities(sys, false);
            if blocks && let Some(bodies) = sys.boundary.bodies_mut() {
                self.motion.clone_from(&self.motion_best);
                self.loads.clone_from(&self.loads_best);
                bodies.nudge(&self.motion);
                self.update_flux(sys);
            }
            err = self.predict(sys, dt, density);
            kept = Some(best_it);
        }
        self.dk = dk;
        (it, err, k, kept)
    }

    /// Keeps the current iterate as the best one of the solve: the stiffness `k` and, with
    /// `blocks`, the free blocks' motion and loads so far.
    fn keep_best(&mut self, k: &[Real], blocks: bool) {
        self.k_best.resize(k.len(), 0.0);
        self.k_best.copy_from_slice(k);
        if blocks {
            self.motion_best.clone_from(&self.motion);
            self.loads_best.clone_from(&self.loads);
        }
    }
}

impl Dfsph {
    /// After [`Self::apply`] on several ranks: the halo's velocities (the next pass reads them
    /// of the neighbours) and, with `kbar` (blocks in the solve, mirrored walls), the walls' k̄
    /// (the blocks read it of the particles next to them, [`Self::move_blocks`]; zero
    /// otherwise).
    fn share_velocities(&mut self, sys: &mut FluidSystem, kbar: bool) {
        let Some(s) = &mut sys.share else {
            return;
        };
        let v = &mut sys.particles.velocity;
        if kbar {
            let kbar = &mut self.kbar;
            for (i, [x, y, z, kb]) in s.share(|i| [v[i].x, v[i].y, v[i].z, kbar[i]]) {
                v[i as usize] = Vector::new(x, y, z);
                kbar[i as usize] = kb;
            }
        } else {
            for (i, [x, y, z]) in s.share(|i| [v[i].x, v[i].y, v[i].z]) {
                v[i as usize] = Vector::new(x, y, z);
            }
        }
    }
}
