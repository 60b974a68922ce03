//! WCSPH's pair sums with a low-dissipation Riemann solver in place of artificial viscosity and
//! δ-SPH (Zhang, Hu & Adams 2017, J. Comput. Phys. 335, 605–620): each pair is a 1D Riemann
//! problem along e_ij = r_ij/r between the left state i (ρ_i, U_L = −v_i·e_ij, p_i) and the
//! right state j, solved by the linearised (acoustic) solver
//!
//!   U* = (U_L + U_R)/2 + (p_L − p_R)/(2 ρ̄ c0),
//!   P* = (p_L + p_R)/2 + β ρ̄ (U_L − U_R)/2,   β = min(η·max(U_L − U_R, 0), c0), η = 3,
//!
//! (their Eqs. 16–18: the limiter β removes the dissipation where particles separate and
//! scales it with the compression, so the pressure is not smeared by a constant viscosity),
//! and enters momentum and continuity as
//!
//!   dv_i/dt = −2 Σ_j m P*/(ρ_i ρ_j) ∇W_ij,
//!   dρ_i/dt = 2 ρ_i Σ_j (m/ρ_j) (U* − U_L) ∂W/∂r_ij     (their Eqs. 11–12).
//!
//! U* − U_L = v_ij·e_ij/2 + (p_i − p_j)/(2 ρ̄ c0): the first half is the continuity equation,
//! the second a pressure diffusion; its hydrostatic part is subtracted as in Fourtakas et al.
//! (2019)'s δ-SPH (p_i − p_j − ρ0 g·r_ij), so a column at rest is not flattened at its free
//! surface, where the kernel is cut. Walls are Adami et al. (2012)'s dummy particles, their
//! pressure extrapolated from the fluid, as for the artificial flux: P* = (p_i + p_w)/2 without
//! dissipation, continuity with the wall's velocity ([`super::pairs::boundary_sums`]). Zhang et
//! al. (§3.3) dissipate at a wall along its normal; along e_ij, with the wall particle's
//! velocity mirrored, the term acted as friction on the flow along the floor (the dam break's
//! front did not reach the far wall), and dummy particles carry no normal.

use crate::core::lanes::{L, Packed, block, gather, sum};
use crate::kernels::WendlandC2;
use multiversion::multiversion;
use shared::math::{Real, Vector};

/// The dissipation limiter's η (Zhang, Hu & Adams 2017, Eq. 18).
pub const ETA: Real = 3.0;

/// A fluid particle's (or a boundary particle's) record for the Riemann loop: s0 = ρ − ρ0,
/// s1 = p.
#[inline]
pub fn record(
    position: &Vector,
    origin: &Vector,
    velocity: &Vector,
    density: Real,
    rest_density: Real,
    pressure: Real,
) -> Packed {
    Packed::new(position, origin, velocity, density - rest_density, pressure)
}

/// The constants of the Riemann pair terms, in the lanes' precision.
#[derive(Debug, Clone, Copy)]
pub struct RiemannConstants {
    pub rest_density: f32,
    pub s2: f32,
    pub half_inv_h: f32,
    pub gradient_scale: f32,
    /// 0.01 h²: keeps 1/r finite for coincident particles.
    pub eta2: f32,
    pub sound_speed: f32,
    pub inv_sound_speed: f32,
    pub limiter: f32,
    /// ρ0 g [Pa/m].
    pub hydro: [f32; 3],
}

impl RiemannConstants {
    pub fn new(kernel: &WendlandC2, rest_density: Real, sound_speed: Real, g: Vector) -> Self {
        let h = kernel.smoothing_length();
        let support = 2.0 * h;
        let hydro = g * rest_density;
        Self {
            rest_density: rest_density as f32,
            s2: (support * support) as f32,
            half_inv_h: (0.5 / h) as f32,
            gradient_scale: kernel.gradient_factor_inside(0.0) as f32,
            eta2: (0.01 * h * h) as f32,
            sound_speed: sound_speed as f32,
            inv_sound_speed: (1.0 / sound_speed) as f32,
            limiter: ETA as f32,
            hydro: [hydro.x as f32, hydro.y as f32, hydro.z as f32],
        }
    }

    /// P* − p̄ = β ρ̄ ΔU/2 for the jump ΔU = U_L − U_R (zero where the pair separates).
    #[inline(always)]
    fn dissipation(&self, rho_bar: f32, du: f32) -> f32 {
        let beta = (self.limiter * du.max(0.0)).min(self.sound_speed);
        0.5 * beta * rho_bar * du
    }
}

/// Σ_j over fluid neighbours `list` of `me`, without the common factor m:
/// (−2 Σ P*/(ρ_i ρ_j) ∇W, 2 ρ_i Σ (U* − U_L) ∂W/∂r / ρ_j).
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn fluid_sums(
    me: &Packed,
    list: &[u32],
    near: &[Packed],
    c: &RiemannConstants,
) -> (Vector, Real) {
    let [xi, yi, zi] = me.position;
    let [vxi, vyi, vzi] = me.velocity;
    let (ri, pi) = (c.rest_density + me.s0, me.s1);
    let mut ax = [0.0f32; L];
    let mut ay = [0.0f32; L];
    let mut az = [0.0f32; L];
    let mut dr = [0.0f32; L];
    let mut k0 = 0;
    while k0 < list.len() {
        let (idx, n) = block(list, k0);
        let [x, y, z, drj, vxj, vyj, vzj, pj] = gather(near, &idx);
        for k in 0..L {
            let (rx, ry, rz) = (xi - x[k], yi - y[k], zi - z[k]);
            let r2 = rx * rx + ry * ry + rz * rz;
            let r = r2.sqrt();
            let t = 1.0 - r * c.half_inv_h;
            // F = ∇W/r (negative), zero outside the support and on padding lanes.
            let f = if r2 < c.s2 && k < n {
                c.gradient_scale * (t * t * t)
            } else {
                0.0
            };
            let rj = c.rest_density + drj[k];
            let rho_bar = 0.5 * (ri + rj);
            let vr = (vxi - vxj[k]) * rx + (vyi - vyj[k]) * ry + (vzi - vzj[k]) * rz;
            let inv_r = 1.0 / (r2 + c.eta2).sqrt();
            // U_L − U_R = −v_ij·e_ij: positive when the pair approaches.
            let du = -vr * inv_r;
            let p_star = 0.5 * (pi + pj[k]) + c.dissipation(rho_bar, du);
            let inv_rj = 1.0 / rj;
            let fc = f * 2.0 * p_star * inv_rj;
            ax[k] -= rx * fc;
            ay[k] -= ry * fc;
            az[k] -= rz * fc;
            let hydro = c.hydro[0] * rx + c.hydro[1] * ry + c.hydro[2] * rz;
            // 2(U* − U_L)·r = v_ij·r_ij + r (p_i − p_j − ρ0 g·r_ij)/(ρ̄ c0): at rest p_i − p_j = ρ0 g·r_ij.
            let jump = vr + r * (pi - pj[k] - hydro) * c.inv_sound_speed / rho_bar;
            dr[k] += f * jump * inv_rj;
        }
        k0 += n;
    }
    // The lanes summed P*/ρ_j: divide by ρ_i once.
    let inv_ri = 1.0 / ri as Real;
    (
        Vector::new(sum(ax), sum(ay), sum(az)) * inv_ri,
        sum(dr) * ri as Real,
    )
}

/// Σ_b over boundary neighbours `list` (records of [`record`] with the wall's extrapolated
/// pressure and its Tait density) of `me`, without the common factor m: (−2 Σ P*/(ρ_i ρ_b) ∇W,
/// Σ (v_i − v_b)·∇W).
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn boundary_sums(
    me: &Packed,
    list: &[u32],
    walls: &[Packed],
    c: &RiemannConstants,
) -> (Vector, Real) {
    let [xi, yi, zi] = me.position;
    let [vxi, vyi, vzi] = me.velocity;
    let (ri, pi) = (c.rest_density + me.s0, me.s1);
    let mut ax = [0.0f32; L];
    let mut ay = [0.0f32; L];
    let mut az = [0.0f32; L];
    let mut dv = [0.0f32; L];
    let mut k0 = 0;
    while k0 < list.len() {
        let (idx, n) = block(list, k0);
        let [x, y, z, drb, vxb, vyb, vzb, pb] = gather(walls, &idx);
        for k in 0..L {
            let (rx, ry, rz) = (xi - x[k], yi - y[k], zi - z[k]);
            let r2 = rx * rx + ry * ry + rz * rz;
            let t = 1.0 - r2.sqrt() * c.half_inv_h;
            let f = if r2 < c.s2 && k < n {
                c.gradient_scale * (t * t * t)
            } else {
                0.0
            };
            let rb = c.rest_density + drb[k];
            let vr = (vxi - vxb[k]) * rx + (vyi - vyb[k]) * ry + (vzi - vzb[k]) * rz;
            let p_star = 0.5 * (pi + pb[k]);
            let fc = f * 2.0 * p_star / rb;
            ax[k] -= rx * fc;
            ay[k] -= ry * fc;
            az[k] -= rz * fc;
            dv[k] += f * vr;
        }
        k0 += n;
    }
    (Vector::new(sum(ax), sum(ay), sum(az)) / ri as Real, sum(dv))
}

/// The pressure factor of a fluid–wall pair, (p_i + p_b)/(ρ_i ρ_b): [`boundary_sums`]' term
/// without m and ∇W, for a moving block's reaction (pair by pair, Newton's third law).
#[inline]
pub fn wall_pair(pi: Real, ri: Real, pb: Real, rb: Real) -> Real {
    (pi + pb) / (ri * rb)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constants() -> RiemannConstants {
        RiemannConstants::new(
            &WendlandC2::new(0.013),
            1000.0,
            20.0,
            Vector::new(0.0, 0.0, -9.81),
        )
    }

    /// Zhang, Hu & Adams (2017) Eq. 18: β = min(η·max(ΔU, 0), c0), P* − p̄ = β ρ̄ ΔU/2.
    #[test]
    fn the_limiter_dissipates_only_where_a_pair_closes_and_at_most_acoustically() {
        let c = constants();
        // Closing at 1 m/s: β = 3 m/s, P* − p̄ = 3 · 1000 · 1 / 2.
        assert_eq!(c.dissipation(1000.0, 1.0), 1500.0);
        // Opening: no dissipation, whatever the speed.
        assert_eq!(c.dissipation(1000.0, -5.0), 0.0);
        // Closing at 10 m/s: η ΔU = 30 m/s is capped at c0 = 20 m/s.
        assert_eq!(c.dissipation(1000.0, 10.0), 0.5 * 20.0 * 1000.0 * 10.0);
    }

    /// Two particles at rest at the hydrostatic pressure difference: no mass flux between them
    /// (the pressure diffusion's hydrostatic part is subtracted, Fourtakas et al. 2019), and
    /// the momentum exchange is the mean pressure's.
    #[test]
    fn a_hydrostatic_pair_at_rest_exchanges_no_mass() {
        let c = constants();
        let dz = 0.01;
        let origin = Vector::zeros();
        let (p_low, p_high) = (1000.0, 1000.0 + 1000.0 * 9.81 * dz);
        let below = record(
            &Vector::zeros(),
            &origin,
            &Vector::zeros(),
            1000.0,
            1000.0,
            p_high,
        );
        let above = record(
            &Vector::new(0.0, 0.0, dz),
            &origin,
            &Vector::zeros(),
            1000.0,
            1000.0,
            p_low,
        );
        let near = [below, above];
        let (a, d) = fluid_sums(&near[1], &[0], &near, &c);
        // Against the flux the same pair would take with equal pressures (the hydrostatic
        // difference not there): zero to the lanes' f32 rounding.
        let level = record(
            &Vector::zeros(),
            &origin,
            &Vector::zeros(),
            1000.0,
            1000.0,
            p_low,
        );
        let (_, d_level) = fluid_sums(&near[1], &[0], &[level, above], &c);
        assert!(
            d.abs() < 1e-3 * d_level.abs(),
            "dρ/dt = {d} against {d_level}"
        );
        // Pushed up by the pair's pressure: −2 P*/(ρ_i ρ_j) ∇W with ∇W along −e_z from above.
        assert!(a.z > 0.0 && a.x == 0.0 && a.y == 0.0, "{a:?}");
    }
}
