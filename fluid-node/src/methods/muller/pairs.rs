//! Müller SPH's pair sums for one particle (paper Eqs. 12, 14, 18), eight neighbours at a time in
//! f32 ([`crate::core::lanes`]), each lane with its own partial sum added in f64 at the end. Compiled
//! also for AVX2 and NEON and chosen at run time (multiversion).
//!
//! Records ([`Packed`]): a fluid particle's s0 = 1/ρ and s1 = p (so the force loop multiplies
//! and never divides by ρ_j); a boundary particle's the same of its extrapolated pressure and
//! the density it implies. The density loop reads positions only.

use crate::core::lanes::{L, Packed, block, gather, gather_positions, sum};
use crate::kernels::{Poly6, Spiky, ViscosityKernel};
use multiversion::multiversion;
use shared::math::{Real, Vector};

/// The constants of the pair terms, in f32.
#[derive(Debug, Clone, Copy)]
pub struct PairConstants {
    /// h and h².
    pub h: f32,
    pub h2: f32,
    /// The least distance the spiky gradient divides by (10⁻⁶ h): coincident particles push
    /// along r_ij = 0, i.e. not at all, rather than by NaN.
    pub r_min: f32,
    /// Poly6's c (Eq. 13): W = c (h² − r²)³.
    pub poly6: f32,
    /// −3c of the spiky kernel (Eq. 15): ∇W = −3c (h − r)² r_ij / r.
    pub spiky: f32,
    /// The viscosity kernel's ∇²W = lap (h − r) (Eq. 19), times μ.
    pub viscous: f32,
}

impl PairConstants {
    pub fn new(poly6: &Poly6, spiky: &Spiky, visc: &ViscosityKernel, mu: Real, h: Real) -> Self {
        Self {
            h: h as f32,
            h2: (h * h) as f32,
            r_min: (1e-6 * h) as f32,
            poly6: poly6.coefficient() as f32,
            spiky: (-3.0 * spiky.coefficient()) as f32,
            viscous: (mu * visc.laplacian_coefficient()) as f32,
        }
    }
}

/// A record for the force loop: s0 = 1/ρ, s1 = p (fluid or boundary particle).
#[inline]
pub fn record(
    position: &Vector,
    origin: &Vector,
    velocity: &Vector,
    pressure: Real,
    density: Real,
) -> Packed {
    Packed::new(position, origin, velocity, 1.0 / density, pressure)
}

/// Σ_j c (h² − r²)³ over `list` (Eq. 12 without the mass), fluid or boundary records alike.
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn density_sum(me: &Packed, list: &[u32], records: &[Packed], c: &PairConstants) -> Real {
    let [xi, yi, zi] = me.position;
    let mut w = [0.0f32; L];
    let mut k0 = 0;
    while k0 < list.len() {
        let (idx, n) = block(list, k0);
        let [x, y, z, _] = gather_positions(records, &idx);
        for k in 0..L {
            let (rx, ry, rz) = (xi - x[k], yi - y[k], zi - z[k]);
            let d = c.h2 - (rx * rx + ry * ry + rz * rz);
            w[k] += if d > 0.0 && k < n {
                c.poly6 * (d * d * d)
            } else {
                0.0
            };
        }
        k0 += n;
    }
    sum(w)
}

/// Eq. 14's pair factor along r_ij, fluid or boundary neighbour alike:
/// −(p_i + p_j)/(2ρ_j)·(−3c (h − r)²/r), with d = h − r.
#[inline(always)]
fn pressure_term(pi: f32, pj: f32, inv_rho_j: f32, d: f32, r: f32, c: &PairConstants) -> f32 {
    -0.5 * (pi + pj) * inv_rho_j * (c.spiky * d * d / r)
}

/// Σ_j over fluid neighbours `list` of particle `me`, without the factor m: the pressure force
/// of Eq. 14 with Müller's symmetric (p_i + p_j)/2 and the viscous force of Eq. 18 (which
/// damps the velocity difference), −Σ (p_i + p_j)/(2ρ_j) ∇W_spiky + Σ μ (v_j − v_i)/ρ_j ∇²W_visc.
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn fluid_forces(me: &Packed, list: &[u32], records: &[Packed], c: &PairConstants) -> Vector {
    let [xi, yi, zi] = me.position;
    let [vxi, vyi, vzi] = me.velocity;
    let pi = me.s1;
    let mut fx = [0.0f32; L];
    let mut fy = [0.0f32; L];
    let mut fz = [0.0f32; L];
    let mut k0 = 0;
    while k0 < list.len() {
        let (idx, n) = block(list, k0);
        let [x, y, z, inv_rho, vx, vy, vz, pj] = gather(records, &idx);
        for k in 0..L {
            let (rx, ry, rz) = (xi - x[k], yi - y[k], zi - z[k]);
            let r2 = rx * rx + ry * ry + rz * rz;
            let r = r2.sqrt().max(c.r_min);
            let d = c.h - r;
            let inside = r2 < c.h2 && k < n;
            // The pressure factor along r_ij, and μ ∇²W/ρ_j along v_j − v_i.
            let pressure = if inside {
                pressure_term(pi, pj[k], inv_rho[k], d, r, c)
            } else {
                0.0
            };
            let viscous = if inside {
                c.viscous * d * inv_rho[k]
            } else {
                0.0
            };
            fx[k] += rx * pressure + (vx[k] - vxi) * viscous;
            fy[k] += ry * pressure + (vy[k] - vyi) * viscous;
            fz[k] += rz * pressure + (vz[k] - vzi) * viscous;
        }
        k0 += n;
    }
    Vector::new(sum(fx), sum(fy), sum(fz))
}

/// Σ_b over boundary neighbours `list` of particle `me`, without the factor m: Eq. 14's pressure
/// force of the boundary particles (free slip: no viscous term).
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn boundary_forces(me: &Packed, list: &[u32], records: &[Packed], c: &PairConstants) -> Vector {
    let [xi, yi, zi] = me.position;
    let pi = me.s1;
    let mut fx = [0.0f32; L];
    let mut fy = [0.0f32; L];
    let mut fz = [0.0f32; L];
    let mut k0 = 0;
    while k0 < list.len() {
        let (idx, n) = block(list, k0);
        let [x, y, z, inv_rho, _, _, _, pb] = gather(records, &idx);
        for k in 0..L {
            let (rx, ry, rz) = (xi - x[k], yi - y[k], zi - z[k]);
            let r2 = rx * rx + ry * ry + rz * rz;
            let r = r2.sqrt().max(c.r_min);
            let d = c.h - r;
            let pressure = if r2 < c.h2 && k < n {
                pressure_term(pi, pb[k], inv_rho[k], d, r, c)
            } else {
                0.0
            };
            fx[k] += rx * pressure;
            fy[k] += ry * pressure;
            fz[k] += rz * pressure;
        }
        k0 += n;
    }
    Vector::new(sum(fx), sum(fy), sum(fz))
}
