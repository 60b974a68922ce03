//! WCSPH's pair sums for one particle, eight neighbours at a time in f32 ([`crate::core::lanes`]):
//! the terms of [`crate::methods::wcsph`] (Monaghan 1992's symmetric pressure gradient and artificial
//! viscosity, the continuity equation, Fourtakas et al. 2019's δ-SPH) over its fluid
//! neighbours, and the pressure and continuity terms over its boundary neighbours, each lane
//! with its own partial sum. Compiled also for AVX2 and NEON and chosen at run time
//! (multiversion). Against the f64 loop with four lanes before: eight lanes per instruction, a
//! neighbour in half a cache line loaded whole, and one division per pair instead of three
//! ((r² + η²)(ρ_i + ρ_j)ρ_j inverted once); docs/VALIDATION.md has the table with it.

use crate::core::lanes::{L, Packed, block, gather, sum};
use crate::kernels::WendlandC2;
use multiversion::multiversion;
use shared::math::{Real, Vector};

/// A fluid particle's record for the WCSPH loop: s0 = ρ − ρ0 (so the δ-SPH difference
/// ρ_j − ρ_i keeps its digits), s1 = p/ρ².
#[inline]
pub fn fluid_record(
    position: &Vector,
    origin: &Vector,
    velocity: &Vector,
    density: Real,
    rest_density: Real,
    pressure: Real,
) -> Packed {
    let inv = 1.0 / density;
    Packed::new(
        position,
        origin,
        velocity,
        density - rest_density,
        pressure * inv * inv,
    )
}

/// A boundary particle's record for the WCSPH loop: s0 unused, s1 = p_w/ρ_w² (its
/// extrapolated pressure and the Tait density of it).
#[inline]
pub fn boundary_record(
    position: &Vector,
    origin: &Vector,
    velocity: &Vector,
    pressure: Real,
    density: Real,
) -> Packed {
    Packed::new(
        position,
        origin,
        velocity,
        0.0,
        pressure / (density * density),
    )
}

/// The constants of the pair terms, in the precision the lanes use.
#[derive(Debug, Clone, Copy)]
pub struct PairConstants {
    /// The origin of the records' positions.
    pub origin: Vector,
    /// ρ0 [kg/m³].
    pub rest_density: f32,
    /// Support squared.
    pub s2: f32,
    /// 1/(2h) and −5α/h² of the Wendland C2 gradient factor F = ∇W/r = −5α/h² (1 − r/2h)³.
    pub half_inv_h: f32,
    pub gradient_scale: f32,
    /// η² = 0.01 h², keeps 1/(r² + η²) finite.
    pub eta2: f32,
    /// −2 α c0 h: Π = visc·min(v·r, 0)/((r² + η²)(ρi + ρj)).
    pub visc: f32,
    /// ρ0 g / c0²: the linearised hydrostatic density difference per metre.
    pub hydro: [f32; 3],
}

impl PairConstants {
    pub fn new(
        kernel: &WendlandC2,
        origin: Vector,
        rest_density: Real,
        eta2: Real,
        visc: Real,
        hydro: Vector,
    ) -> Self {
        let h = kernel.smoothing_length();
        let support = 2.0 * h;
        Self {
            origin,
            rest_density: rest_density as f32,
            s2: (support * support) as f32,
            half_inv_h: (0.5 / h) as f32,
            gradient_scale: (kernel.gradient_factor_inside(0.0)) as f32,
            eta2: eta2 as f32,
            visc: visc as f32,
            hydro: [hydro.x as f32, hydro.y as f32, hydro.z as f32],
        }
    }
}

/// Σ_j over fluid neighbours `list` of particle `me`, without the common factor m:
/// (−Σ (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇W, Σ v_ij·∇W, Σ (ρ_j − ρ_i − ρ0 g·r_ji/c0²) ψ_ij / ρ_j) with
/// ψ_ij = −r²F/(r² + η²), F = ∇W/r (the δ-SPH sum before its factor 2δhc0).
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn fluid_sums(
    me: &Packed,
    list: &[u32],
    near: &[Packed],
    c: &PairConstants,
) -> (Vector, Real, Real) {
    let [xi, yi, zi] = me.position;
    let [vxi, vyi, vzi] = me.velocity;
    let (dri, pi_term) = (me.s0, me.s1);
    let ri = c.rest_density + dri;
    let mut ax = [0.0f32; L];
    let mut ay = [0.0f32; L];
    let mut az = [0.0f32; L];
    let mut dv = [0.0f32; L];
    let mut diff = [0.0f32; L];
    let mut k0 = 0;
    while k0 < list.len() {
        let (idx, n) = block(list, k0);
        let [x, y, z, drj, vxj, vyj, vzj, pj] = gather(near, &idx);
        let mut rx = [0.0f32; L];
        let mut ry = [0.0f32; L];
        let mut rz = [0.0f32; L];
        let mut vx = [0.0f32; L];
        let mut vy = [0.0f32; L];
        let mut vz = [0.0f32; L];
        for k in 0..L {
            rx[k] = xi - x[k];
            ry[k] = yi - y[k];
            rz[k] = zi - z[k];
            vx[k] = vxi - vxj[k];
            vy[k] = vyi - vyj[k];
            vz[k] = vzi - vzj[k];
        }
        for k in 0..L {
            let r2 = rx[k] * rx[k] + ry[k] * ry[k] + rz[k] * rz[k];
            let inside = r2 < c.s2 && k < n;
            // F = ∇W/r, zero outside the support and on padding lanes: every term below
            // carries it.
            let t = 1.0 - r2.sqrt() * c.half_inv_h;
            let f = if inside {
                c.gradient_scale * (t * t * t)
            } else {
                0.0
            };
            let rj = c.rest_density + drj[k];
            // One division for 1/((r² + η²)(ρi + ρj)) and 1/((r² + η²)ρj).
            let inv = 1.0 / ((r2 + c.eta2) * (ri + rj) * rj);
            let vr = vx[k] * rx[k] + vy[k] * ry[k] + vz[k] * rz[k];
            let coef = pi_term + pj[k] + c.visc * vr.min(0.0) * (rj * inv);
            let fc = f * coef;
            ax[k] -= rx[k] * fc;
            ay[k] -= ry[k] * fc;
            az[k] -= rz[k] * fc;
            dv[k] += f * vr;
            let hydro = c.hydro[0] * rx[k] + c.hydro[1] * ry[k] + c.hydro[2] * rz[k];
            // ρ0 g·r_ji/c0² = −(ρ0 g/c0²)·r_ij.
            diff[k] += (drj[k] - dri + hydro) * (-f * r2) * ((ri + rj) * inv);
        }
        k0 += n;
    }
    (Vector::new(sum(ax), sum(ay), sum(az)), sum(dv), sum(diff))
}

/// Σ_b over boundary neighbours `list` (records of [`boundary_record`]) of particle `me`,
/// without the common factor m: (−Σ (p_i/ρ_i² + p_b/ρ_b²) ∇W, Σ (v_i − v_b)·∇W): the pressure
/// term and continuity with the wall's velocity (Adami et al. 2012: free slip, no viscosity).
#[multiversion(targets("x86_64+avx2", "aarch64+neon"))]
pub fn boundary_sums(
    me: &Packed,
    list: &[u32],
    walls: &[Packed],
    c: &PairConstants,
) -> (Vector, Real) {
    let [xi, yi, zi] = me.position;
    let [vxi, vyi, vzi] = me.velocity;
    let pi_term = me.s1;
    let mut ax = [0.0f32; L];
    let mut ay = [0.0f32; L];
    let mut az = [0.0f32; L];
    let mut dv = [0.0f32; L];
    let mut k0 = 0;
    while k0 < list.len() {
        let (idx, n) = block(list, k0);
        let [x, y, z, _, vxb, vyb, vzb, pb] = gather(walls, &idx);
        for k in 0..L {
            let (rx, ry, rz) = (xi - x[k], yi - y[k], zi - z[k]);
            let r2 = rx * rx + ry * ry + rz * rz;
            let t = 1.0 - r2.sqrt() * c.half_inv_h;
            let f = if r2 < c.s2 && k < n {
                c.gradient_scale * (t * t * t)
            } else {
                0.0
            };
            let fc = f * (pi_term + pb[k]);
            ax[k] -= rx * fc;
            ay[k] -= ry * fc;
            az[k] -= rz * fc;
            dv[k] += f * ((vxi - vxb[k]) * rx + (vyi - vyb[k]) * ry + (vzi - vzb[k]) * rz);
        }
        k0 += n;
    }
    (Vector::new(sum(ax), sum(ay), sum(az)), sum(dv))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::Kernel;

    /// A particle's state in f64.
    struct State {
        x: Vector,
        v: Vector,
        rho: Real,
        p: Real,
    }

    /// The pair terms one neighbour at a time in f64 on the f64 state, as written in the papers.
    fn reference(
        me: &State,
        list: &[u32],
        all: &[State],
        kernel: &WendlandC2,
        eta2: Real,
        visc: Real,
        hydro: Vector,
    ) -> ((Vector, Real, Real), [Real; 3]) {
        let s2 = kernel.support().powi(2);
        let (mut a, mut d, mut diff) = (Vector::zeros(), 0.0, 0.0);
        // Σ|term| of each sum: the scale its rounding is relative to.
        let mut scale = [0.0; 3];
        for &j in list {
            let nb = &all[j as usize];
            let rij = me.x - nb.x;
            let r2 = rij.norm_squared();
            if r2 >= s2 {
                continue;
            }
            let f = kernel.gradient_factor(r2.sqrt());
            let vij = me.v - nb.v;
            let vr = vij.dot(&rij);
            let mu = if vr < 0.0 { vr / (r2 + eta2) } else { 0.0 };
            let coef =
                me.p / (me.rho * me.rho) + nb.p / (nb.rho * nb.rho) + visc * mu / (me.rho + nb.rho);
            a -= rij * f * coef;
            d += vij.dot(&rij) * f;
            let hyd = -hydro.dot(&rij);
            let dd = (nb.rho - me.rho - hyd) * (-f * r2) / (r2 + eta2) / nb.rho;
            diff += dd;
            scale[0] += (rij * f * coef).norm();
            scale[1] += (vij.dot(&rij) * f).abs();
            scale[2] += dd.abs();
        }
        ((a, d, diff), scale)
    }

    /// The f32 lanes agree with the f64 sums to f32's precision (relative to the size of the
    /// terms summed: the pressure sum cancels), for list lengths about the lane width and
    /// neighbours outside the support among them; 1 000 h from the origin (Example 1's flume
    /// is 400 h long each side of its centre) too.
    #[test]
    fn lanes_match_the_f64_sums() {
        let mut seed = 11u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let h = 0.013;
        let kernel = WendlandC2::new(h);
        let (rho0, eta2, visc) = (1000.0, 0.01 * h * h, -2.0 * 0.01 * 30.0 * h);
        let hydro = Vector::new(0.0, 0.0, -9.81 * 1000.0 / 900.0);
        for centre in [Vector::repeat(0.3), Vector::new(1000.0 * h, 0.4, 0.5)] {
            let all: Vec<State> = (0..40)
                .map(|_| State {
                    x: centre + Vector::new(rnd(), rnd(), rnd()) * (3.0 * h),
                    v: Vector::new(rnd(), rnd(), rnd()),
                    rho: rho0 + 20.0 * rnd(),
                    p: 900.0 * (1.0 + rnd()),
                })
                .collect();
            let origin = Vector::zeros();
            let c = PairConstants::new(&kernel, origin, rho0, eta2, visc, hydro);
            let near: Vec<Packed> = all
                .iter()
                .map(|s| fluid_record(&s.x, &origin, &s.v, s.rho, rho0, s.p))
                .collect();
            for len in [0, 1, 3, 7, 8, 9, 15, 16, 17, 39] {
                let list: Vec<u32> = (1..=len as u32).collect();
                let (a, d, diff) = fluid_sums(&near[0], &list, &near, &c);
                let ((ea, ed, ediff), scale) =
                    reference(&all[0], &list, &all, &kernel, eta2, visc, hydro);
                // f32 rounds to 6·10⁻⁸; the positions' rounding, relative to h, is 2·10⁻⁶ at
                // 0.3 m and 7·10⁻⁵ at 13 m (ulp(13 m) = 1 µm).
                let tol = if centre.x > 1.0 { 1e-3 } else { 3e-5 };
                assert!(
                    (a - ea).norm() <= tol * scale[0],
                    "len {len}: {a:?} vs {ea:?}"
                );
                assert!((d - ed).abs() <= tol * scale[1], "len {len}: {d} vs {ed}");
                assert!(
                    (diff - ediff).abs() <= tol * scale[2],
                    "len {len}: {diff} vs {ediff}"
                );
            }
            // Some of the 39 are outside the support, some inside: the test covers both.
            let inside = (1..40)
                .filter(|&j| (all[0].x - all[j].x).norm() < kernel.support())
                .count();
            assert!(inside > 3 && inside < 39, "{inside} of 39 inside");
        }
    }
}
