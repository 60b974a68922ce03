//! DFSPH's passes over the pairs of a step: densities and factors, the pressure velocity
//! change of a stiffness increment, the predicted density change, the moving boundary's flux,
//! and the non-pressure forces (2017 Algorithm 1).

use super::{Dfsph, gradient, halo, hydrostatic, total};
use crate::core::tasks;
use crate::kernels::Kernel;
use crate::system::FluidSystem;
use rayon::prelude::*;
use shared::math::{Real, Vector};

impl Dfsph {
    /// 2017 Algorithm 1, "compute densities and factors" (also its initialisation): ρ_i, the
    /// factor β_i = α_i/ρ_i, and the boundary's part of Dρ/Dt, at the current positions.
    pub(super) fn densities_and_factors(&mut self, sys: &mut FluidSystem) {
        let n = sys.len();
        self.beta.resize(n, 0.0);
        self.grad.resize(n, Vector::zeros());
        self.wall_grad.resize(n, Vector::zeros());
        self.kbar.resize(n, 0.0);
        self.wall_flux.resize(n, 0.0);
        self.deficient.resize(n, false);
        self.error.resize(n, 0.0);
        self.predicted.resize(n, 0.0);
        self.dk.resize(n, 0.0);
        self.v_old.resize(n, Vector::zeros());
        let m = sys.mass;
        let kernel = &self.kernel;
        let s2 = kernel.support().powi(2);
        let w0 = kernel.value(0.0);
        let (lists, boundary) = (&sys.fluid_lists, &sys.boundary);
        let (deficient_below, surface_below) = (self.deficient_below, self.surface_below);
        let mirror = self.mirror();
        let owned = sys.share.as_ref().map(|s| &s.owned[..]);
        let p = &mut sys.particles;
        let pos = &p.position;
        lists.fill_pairs(&mut self.pairs, |i, js, out| {
            let xi = pos[i];
            for (&j, o) in js.iter().zip(out.iter_mut()) {
                let rij = xi - pos[j as usize];
                let r2 = rij.norm_squared();
                *o = if r2 < s2 {
                    let r = r2.sqrt();
                    let g = rij * kernel.gradient_factor(r);
                    [g.x as f32, g.y as f32, g.z as f32, kernel.value(r) as f32]
                } else {
                    [0.0; 4]
                };
            }
        });
        let pairs = &self.pairs;
        p.density
            .par_iter_mut()
            .zip(self.beta.par_iter_mut())
            .zip(self.grad.par_iter_mut().zip(self.wall_grad.par_iter_mut()))
            .zip(
                self.wall_flux
                    .par_iter_mut()
                    .zip(self.deficient.par_iter_mut()),
            )
            .enumerate()
            .with_max_len(tasks::PARTICLES)
            .for_each(
                |(i, (((rho, beta), (grad, wall_grad)), (flux, deficient)))| {
                    // On several ranks, a rank's own particles only (module doc, "On
                    // several ranks").
                    if owned.is_some_and(|o| !o[i]) {
                        return;
                    }
                    let xi = pos[i];
                    let mut sum_w = w0;
                    let mut bs = Vector::zeros();
                    let mut gs = Vector::zeros();
                    let mut sq = 0.0;
                    let mut fl = 0.0;
                    let mut count = 0;
                    for o in lists.with_values(pairs, i).1 {
                        // W > 0 exactly inside the support (Wendland's (1 − q/2)⁴ > 0 for q < 2).
                        if o[3] > 0.0 {
                            count += 1;
                            sum_w += o[3] as Real;
                            let g = gradient(o);
                            gs += g;
                            sq += g.norm_squared();
                        }
                    }
                    boundary.for_each_neighbor(i, |b| {
                        let rib = xi - b.position();
                        let r2 = rib.norm_squared();
                        if r2 < s2 {
                            count += 1;
                            let r = r2.sqrt();
                            sum_w += kernel.value(r);
                            let g = rib * kernel.gradient_factor(r);
                            gs += g;
                            bs += g;
                            fl += b.velocity().dot(&g);
                        }
                    });
                    *deficient = count < deficient_below;
                    // `*rho` still holds the last step's prediction ρ* (the continued density).
                    *rho = if count < surface_below {
                        (m * sum_w).max(*rho)
                    } else {
                        m * sum_w
                    };
                    *grad = gs * m;
                    *wall_grad = bs * m;
                    // The DFSPH factor α_i, divided by ρ_i for this scheme's variable k = κ/ρ
                    // (module doc). With mirrored walls it counts their k̄_i as k_i, what it
                    // is for an increment the neighbourhood shares (module doc, "Pressure
                    // acceleration").
                    let own = *grad + *wall_grad * mirror;
                    let denom = grad.dot(&own).max(0.0) + m * m * sq;
                    *beta = if denom > 1e-9 * (m * m * sq).max(Real::MIN_POSITIVE) {
                        1.0 / denom
                    } else {
                        0.0
                    };
                    *flux = m * fl;
                },
            );
        // What a neighbour's pass reads of the halo: its density (XSPH; the walls'
        // extrapolated pressure).
        let density = &mut sys.particles.density;
        for (k, [r]) in halo(&mut sys.share, |i| [density[i]]) {
            density[k as usize] = r;
        }
    }

    /// v_i −= dt (dk_i G_i + dk̄_i B_i + m Σ_f dk_j ∇W_ij): the pressure velocity change of
    /// stiffness increments `dk` (the velocity updates of 2017 Algorithms 2 and 3; the
    /// mirrored walls' k̄_i, left in `kbar` for the blocks' loads).
    pub(super) fn apply(&mut self, sys: &mut FluidSystem, dk: &[Real], dt: Real) {
        let m = sys.mass;
        let (lists, pairs) = (&sys.fluid_lists, &self.pairs);
        let owned = sys.share.as_ref().map(|s| &s.owned[..]);
        let p = &mut sys.particles;
        let (grad, wall_grad) = (&self.grad, &self.wall_grad);
        let mirrored = self.mirrored;
        let w0 = self.kernel.value(0.0);
        p.velocity
            .par_iter_mut()
            .zip(self.kbar.par_iter_mut())
            .enumerate()
            .with_max_len(tasks::PARTICLES)
            .for_each(|(i, (v, kbar))| {
                if owned.is_some_and(|o| !o[i]) {
                    return;
                }
                let mut acc = grad[i] * dk[i];
                let mut sum = Vector::zeros();
                let (js, gs) = lists.with_values(pairs, i);
                if mirrored && wall_grad[i] != Vector::zeros() {
                    // k̄_i = (W_0 dk_i + Σ_f W_ij dk_j) / (W_0 + Σ_f W_ij), the increment the
                    // mirrored walls give this particle's pairs: the Shepard mean over its
                    // neighbourhood (module doc, "Pressure acceleration"), from the same pairs.
                    let (mut sw, mut sk) = (w0, w0 * dk[i]);
                    for (&j, o) in js.iter().zip(gs) {
                        let (dkj, w) = (dk[j as usize], o[3] as Real);
                        sum += gradient(o) * dkj;
                        sw += w;
                        sk += w * dkj;
                    }
                    *kbar = sk / sw;
                    acc += wall_grad[i] * *kbar;
                } else {
                    for (&j, o) in js.iter().zip(gs) {
                        sum += gradient(o) * dk[j as usize];
                    }
                    *kbar = 0.0;
                }
                acc += sum * m;
                *v -= acc * dt;
            });
    }

    /// `wall_flux` again at the moving boundary's current velocities (the fixed walls' part
    /// is zero).
    pub(super) fn update_flux(&mut self, sys: &FluidSystem) {
        let (m, kernel) = (sys.mass, &self.kernel);
        let s2 = kernel.support().powi(2);
        let (boundary, pos) = (&sys.boundary, &sys.particles.position);
        let owned = sys.owned();
        self.wall_flux
            .par_iter_mut()
            .enumerate()
            .with_max_len(tasks::PARTICLES)
            .for_each(|(i, flux)| {
                if owned.is_some_and(|o| !o[i]) {
                    return;
                }
                let xi = pos[i];
                let mut fl = 0.0;
                boundary.for_each_moving_neighbor(i, |b| {
                    let rib = xi - b.position();
                    let r2 = rib.norm_squared();
                    if r2 < s2 {
                        fl += b.velocity().dot(&(rib * kernel.gradient_factor(r2.sqrt())));
                    }
                });
                *flux = m * fl;
            });
    }

    /// Dρ_i/Dt = Σ_f m (v_i − v_j)·∇W_ij + Σ_b m (v_i − v_b)·∇W_ib (the SPH continuity equation) at
    /// the current velocities. `density`: the constant-density error max(ρ*_i − ρ0, 0) with
    /// ρ*_i = ρ_i + dt·Dρ_i/Dt (Algorithm 3's predicted density; only compression) into `error`,
    /// ρ*_i into `predicted`, and the mean error over ρ0 returned; otherwise the divergence
    /// error max(Dρ_i/Dt, 0) (Algorithm 2's source term) and its mean times dt/ρ0.
    pub(super) fn predict(&mut self, sys: &FluidSystem, dt: Real, density: bool) -> Real {
        let (m, rho0) = (sys.mass, self.rest_density);
        let (lists, pairs) = (&sys.fluid_lists, &self.pairs);
        let p = &sys.particles;
        let (vel, rho) = (&p.velocity, &p.density);
        let (grad, flux, deficient) = (&self.grad, &self.wall_flux, &self.deficient);
        let owned = sys.owned();
        self.error
            .par_iter_mut()
            .zip(self.predicted.par_iter_mut())
            .enumerate()
            .with_max_len(tasks::PARTICLES)
            .for_each(|(i, (e, pred))| {
                if owned.is_some_and(|o| !o[i]) {
                    return;
                }
                let mut d = 0.0;
                let (js, gs) = lists.with_values(pairs, i);
                for (&j, o) in js.iter().zip(gs) {
                    d += vel[j as usize].dot(&gradient(o));
                }
                let div = vel[i].dot(&grad[i]) - m * d - flux[i];
                if density {
                    *pred = rho[i] + dt * div;
                    *e = (*pred - rho0).max(0.0);
                } else if deficient[i] {
                    // Too few neighbours to solve for (DEFICIENT_FRACTION): no divergence source.
                    *e = 0.0;
                } else {
                    *e = div.max(0.0);
                }
            });
        // The solves stop on this mean: summed exactly over the owned particles of every
        // rank, so that where they stop depends neither on the threads nor on the ranks.
        let error = &self.error;
        let [sum] = total(sys, |i| [error[i]]);
        let mean = sum / sys.global_len().max(1) as Real / rho0;
        if density { mean } else { mean * dt }
    }

    /// 2017 Algorithm 1, "non-pressure forces" and "predict velocities": v* = v + dt (g + F_Eq22/m) and XSPH viscosity
    /// v*_i += ε Σ_j (m/ρ_j)(v_j − v_i) W_ij over the fluid neighbours; with them the walls'
    /// held pressure, −dt Σ_b m k_b ∇W_ib with k_b the mirrored walls' H_ib or the extrapolated
    /// walls' p_b/ρ_b² (module doc).
    pub(super) fn non_pressure(&mut self, sys: &mut FluidSystem, dt: Real) {
        let (m, g, eps) = (sys.mass, sys.gravity, self.constants.viscosity);
        let (mirrored, rho0, k_last) = (self.mirrored, self.rest_density, &self.k_last);
        let kernel = &self.kernel;
        let s2 = kernel.support().powi(2);
        let (lists, boundary, pairs) = (&sys.fluid_lists, &sys.boundary, &self.pairs);
        let owned = sys.share.as_ref().map(|s| &s.owned[..]);
        let p = &mut sys.particles;
        // In parallel: a serial copy left the second thread idle long enough to fall asleep
        // (tasks.rs).
        self.v_old
            .par_iter_mut()
            .zip(p.velocity.par_iter())
            .for_each(|(old, v)| *old = *v);
        let (pos, rho, pen, v_old) = (&p.position, &p.density, &p.penalty, &self.v_old);
        p.velocity
            .par_iter_mut()
            .zip(p.acceleration.par_iter_mut())
            .enumerate()
            .with_max_len(tasks::PARTICLES)
            .for_each(|(i, (v, a))| {
                if owned.is_some_and(|o| !o[i]) {
                    return;
                }
                let (xi, vi) = (pos[i], v_old[i]);
                let mut xsph = Vector::zeros();
                if eps > 0.0 {
                    let (js, ws) = lists.with_values(pairs, i);
                    for (&j, o) in js.iter().zip(ws) {
                        let j = j as usize;
                        xsph += (v_old[j] - vi) * (m / rho[j] * o[3] as Real);
                    }
                }
                let mut wall = Vector::zeros();
                boundary.for_each_neighbor(i, |b| {
                    let rib = xi - b.position();
                    let r2 = rib.norm_squared();
                    if r2 < s2 {
                        let mk = if mirrored {
                            m * hydrostatic(&g, &rib, rho0, k_last[i])
                        } else {
                            let rb = b.density();
                            m * b.pressure() / (rb * rb)
                        };
                        wall -= rib * (mk * kernel.gradient_factor(r2.sqrt()));
                    }
                });
                // The non-pressure acceleration: what the step's force limit looks at.
                *a = g + pen[i] / m;
                *v = vi + (*a + wall) * dt + xsph * eps;
            });
        // The halo's v* (its owned neighbours' passes read it) and acceleration (the step's
        // survey reads every particle held; a halo particle's Eq. 22 force is its owner's).
        let (vel, acc) = (&mut p.velocity, &mut p.acceleration);
        for (k, [vx, vy, vz, ax, ay, az]) in halo(&mut sys.share, |i| {
            let (v, a) = (vel[i], acc[i]);
            [v.x, v.y, v.z, a.x, a.y, a.z]
        }) {
            vel[k as usize] = Vector::new(vx, vy, vz);
            acc[k as usize] = Vector::new(ax, ay, az);
        }
    }
}
