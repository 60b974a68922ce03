//! WCSPH's fluid–fluid pair sums for one particle, four neighbours at a time: the terms of
//! [`crate::wcsph`] (Monaghan 1992's symmetric pressure gradient and artificial viscosity, the
//! continuity equation, Fourtakas et al. 2019's δ-SPH) in four lanes, each with its own partial
//! sum, added in a fixed order at the end (so runs stay deterministic). Compiled also for AVX2
//! and NEON and chosen at run time (multiversion); the lanes then map onto one vector register.

use crate::kernels::WendlandC2;
use multiversion::multiversion;
use shared::math::{Real, Vector};

/// A neighbour's state as the pair loop reads it (one 64-byte line).
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(64))]
pub struct NearData {
    pub position: Vector,
    pub density: Real,
    pub velocity: Vector,
    /// p/ρ², computed once per particle.
    pub p_over_rho2: Real,
}

/// The constants of the pair terms.
#[derive(Debug, Clone, Copy)]
pub struct PairConstants {
    pub kernel: WendlandC2,
    /// Support squared.
    pub s2: Real,
    /// η² = 0.01 h², keeps 1/(r² + η²) finite.
    pub eta2: Real,
    /// −2 α c0 h: Π = visc·min(v·r, 0)/((r² + η²)(ρi + ρj)).
    pub visc: Real,
    /// ρ0 g / c0²: the linearised hydrostatic density difference per metre.
    pub hydro: Vector,
}

/// Σ_j over fluid neighbours `list` of particle `me`, without the common factor m:
/// (−Σ (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇W, Σ v_ij·∇W, Σ (ρ_j − ρ_i − ρ0 g·r_ji/c0²) ψ_ij / ρ_j) with
/// ψ_ij = −r²F/(r² + η²), F = ∇W/r (the δ-SPH sum before its factor 2δhc0).
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn fluid_sums(
    me: &NearData,
    list: &[u32],
    near: &[NearData],
    c: &PairConstants,
) -> (Vector, Real, Real) {
    const L: usize = 4;
    let (xi, vi, ri) = (me.position, me.velocity, me.density);
    let mut ax = [0.0; L];
    let mut ay = [0.0; L];
    let mut az = [0.0; L];
    let mut dv = [0.0; L];
    let mut diff = [0.0; L];
    let mut k0 = 0;
    while k0 < list.len() {
        // Gather up to four neighbours; missing lanes repeat the first and are masked.
        let n = L.min(list.len() - k0);
        let mut idx = [list[k0] as usize; L];
        for (k, slot) in idx.iter_mut().enumerate().take(n) {
            *slot = list[k0 + k] as usize;
        }
        let mut rx = [0.0; L];
        let mut ry = [0.0; L];
        let mut rz = [0.0; L];
        let mut vx = [0.0; L];
        let mut vy = [0.0; L];
        let mut vz = [0.0; L];
        let mut rj = [0.0; L];
        let mut pj = [0.0; L];
        let mut ij = [0.0; L];
        for k in 0..L {
            let nb = &near[idx[k]];
            rx[k] = xi.x - nb.position.x;
            ry[k] = xi.y - nb.position.y;
            rz[k] = xi.z - nb.position.z;
            vx[k] = vi.x - nb.velocity.x;
            vy[k] = vi.y - nb.velocity.y;
            vz[k] = vi.z - nb.velocity.z;
            rj[k] = nb.density;
            pj[k] = nb.p_over_rho2;
            // 1/ρ_j from the line already fetched: a separate 1/ρ array cost a second cache
            // line per neighbour, 13 % of the step.
            ij[k] = 1.0 / nb.density;
        }
        for k in 0..L {
            let r2 = rx[k] * rx[k] + ry[k] * ry[k] + rz[k] * rz[k];
            let inside = r2 < c.s2 && k < n;
            // F = ∇W/r, zero outside the support and on padding lanes: every term below
            // carries it.
            let f = if inside {
                c.kernel.gradient_factor_inside(r2.sqrt())
            } else {
                0.0
            };
            let inv_r2 = 1.0 / (r2 + c.eta2);
            let vr = vx[k] * rx[k] + vy[k] * ry[k] + vz[k] * rz[k];
            let coef = me.p_over_rho2 + pj[k] + c.visc * vr.min(0.0) * inv_r2 / (ri + rj[k]);
            let fc = f * coef;
            ax[k] -= rx[k] * fc;
            ay[k] -= ry[k] * fc;
            az[k] -= rz[k] * fc;
            dv[k] += f * vr;
            let hydro = c.hydro.x * rx[k] + c.hydro.y * ry[k] + c.hydro.z * rz[k];
            // ρ0 g·r_ji/c0² = −(ρ0 g/c0²)·r_ij.
            diff[k] += (rj[k] - ri + hydro) * (-f * r2) * inv_r2 * ij[k];
        }
        k0 += n;
    }
    let sum = |a: [Real; L]| (a[0] + a[1]) + (a[2] + a[3]);
    (Vector::new(sum(ax), sum(ay), sum(az)), sum(dv), sum(diff))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::Kernel;

    /// The pair terms one neighbour at a time, as written in the papers.
    fn scalar(
        me: &NearData,
        list: &[u32],
        near: &[NearData],
        c: &PairConstants,
    ) -> (Vector, Real, Real) {
        let (mut a, mut d, mut diff) = (Vector::zeros(), 0.0, 0.0);
        for &j in list {
            let nb = &near[j as usize];
            let rij = me.position - nb.position;
            let r2 = rij.norm_squared();
            if r2 >= c.s2 {
                continue;
            }
            let f = c.kernel.gradient_factor(r2.sqrt());
            let vij = me.velocity - nb.velocity;
            let vr = vij.dot(&rij);
            let mu = if vr < 0.0 { vr / (r2 + c.eta2) } else { 0.0 };
            let coef = me.p_over_rho2 + nb.p_over_rho2 + c.visc * mu / (me.density + nb.density);
            a -= rij * f * coef;
            d += vij.dot(&rij) * f;
            let hydro = -c.hydro.dot(&rij);
            diff += (nb.density - me.density - hydro) * (-f * r2) / (r2 + c.eta2) / nb.density;
        }
        (a, d, diff)
    }

    #[test]
    fn lanes_match_the_scalar_sums() {
        let mut seed = 11u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let h = 0.013;
        let c = PairConstants {
            kernel: WendlandC2::new(h),
            s2: (2.0 * h) * (2.0 * h),
            eta2: 0.01 * h * h,
            visc: -2.0 * 0.01 * 30.0 * h,
            hydro: Vector::new(0.0, 0.0, -9.81 * 1000.0 / 900.0),
        };
        let near: Vec<NearData> = (0..40)
            .map(|_| {
                let density = 1000.0 + 20.0 * rnd();
                let p = 900.0 * (1.0 + rnd());
                NearData {
                    position: Vector::new(rnd(), rnd(), rnd()) * (3.0 * h),
                    density,
                    velocity: Vector::new(rnd(), rnd(), rnd()),
                    p_over_rho2: p / (density * density),
                }
            })
            .collect();
        // List lengths around the lane width, with neighbours outside the support among them.
        for len in [0, 1, 3, 4, 5, 7, 8, 39] {
            let list: Vec<u32> = (1..=len as u32).collect();
            let (a, d, diff) = fluid_sums(&near[0], &list, &near, &c);
            let (ea, ed, ediff) = scalar(&near[0], &list, &near, &c);
            let close = |x: Real, y: Real, scale: Real| (x - y).abs() <= 1e-12 * scale.max(1e-30);
            let sa = ea.norm().max(1.0);
            assert!((a - ea).norm() <= 1e-12 * sa, "len {len}: {a:?} vs {ea:?}");
            assert!(close(d, ed, ed.abs().max(1.0)), "len {len}: {d} vs {ed}");
            assert!(
                close(diff, ediff, ediff.abs().max(1.0)),
                "len {len}: {diff} vs {ediff}"
            );
        }
        // Some of the 39 are outside the support, some inside: the test covers both.
        let inside = (1..40)
            .filter(|&j| (near[0].position - near[j].position).norm_squared() < c.s2)
            .count();
        assert!(inside > 3 && inside < 39, "{inside} of 39 inside");
    }
}
