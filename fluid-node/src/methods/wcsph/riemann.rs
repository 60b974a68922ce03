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
//! pressure extrapolated from the fluid, as for the artificial flux, continuity with the wall's
//! velocity ([`super::pairs::boundary_sums`]), and P* = (p_i + p_w)/2 along e_ib plus Zhang et
//! al.'s (§3.3) wall dissipation along the wall normal: the Riemann problem between the
//! particle and its mirror image, whose normal velocities jump by u = 2 (v_i − v_b)·n_i
//! (positive approaching the wall), gives P* − p̄ = β ρ̄ u/2 with β = min(η_w·max(u, 0), c0),
//! applied through |∇W_ib| along n_i:
//!
//!   dv_i/dt ∋ −2 m Σ_b (P* − p̄)/(ρ_i ρ_b) |∇W_ib| n_i.
//!
//! Dummy particles carry no normal, so each fluid particle takes its own from the wall
//! particles it sees: n_i = Σ_b ∇W_ib / |Σ_b ∇W_ib| (pointing into the wall), a first pass
//! over its list of each set (fixed, moving). Along n_i only the normal approach is damped; the
//! flow along the floor is not (along e_ij, with the wall particle's velocity mirrored, the
//! term acted as friction there: the dam break's front did not reach the far wall). η_w is
//! `[fluid.riemann] wall_limiter`, by default [`WALL_ETA`], the fluid pairs' η = 3 (why not
//! another: [`WALL_ETA`]); a moving block takes the exact reverse ([`wall_pair`],
//! [`wall_pair_dissipation`], `Wcsph::react`).

use crate::core::lanes::{L, Packed, block, gather, sum};
use crate::kernels::WendlandC2;
use multiversion::multiversion;
use shared::math::{Real, Vector};

/// The dissipation limiter's η (Zhang, Hu & Adams 2017, Eq. 18).
pub const ETA: Real = 3.0;

/// The default η of the fluid–wall pairs' limiter (`[fluid.riemann] wall_limiter`): the fluid
/// pairs' [`ETA`], Zhang et al.'s one limiter for both. With it the Lobovský impact peak, in
/// a slab 4 layers wide, is 86 → 128 → 158 mbar at H/dx = 15, 30, 60 (without the walls'
/// dissipation 138 → 210 → 183): lower, inside the experiment's band at 15 and 30, still
/// growing; in the tank's 150 mm width 126 → 191 → 202 (docs/VALIDATION.md). A scan of η_w
/// (3, 5, 7, 10, 14, 20, ∞) in the 4-layer slab found one value, 10, inside the band at all
/// three (112 → 117 → 127), but its neighbours 7 and 14 leave it (142 mbar at H/dx = 30, 154
/// at 60): a tuned pass on a crest that moves ±20 % with η_w, not a converged peak, so it is
/// not the default (docs/journal/2026-11-29-impact-pressures.md).
pub const WALL_ETA: Real = ETA;

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
    /// η of the wall pairs' limiter (Zhang, Hu & Adams 2017, §3.3, the dissipation along the
    /// wall normal); 0: no dissipation at walls.
    pub wall_limiter: f32,
    /// ρ0 g [Pa/m].
    pub hydro: [f32; 3],
}

impl RiemannConstants {
    pub fn new(
        kernel: &WendlandC2,
        rest_density: Real,
        sound_speed: Real,
        wall_limiter: Real,
        g: Vector,
    ) -> Self {
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
            wall_limiter: wall_limiter as f32,
            hydro: [hydro.x as f32, hydro.y as f32, hydro.z as f32],
        }
    }

    /// F = ∇W/r of Wendland C2 (negative) at distance r (r2 = r²), zero outside the support
    /// and on padding lanes (`live` false).
    #[inline(always)]
    fn gradient(&self, r: f32, r2: f32, live: bool) -> f32 {
        let t = 1.0 - r * self.half_inv_h;
        if r2 < self.s2 && live {
            self.gradient_scale * (t * t * t)
        } else {
            0.0
        }
    }

    /// P* − p̄ = β ρ̄ ΔU/2 for the jump ΔU = U_L − U_R (zero where the pair separates).
    #[inline(always)]
    fn dissipation(&self, rho_bar: f32, du: f32) -> f32 {
        let beta = (self.limiter * du.max(0.0)).min(self.sound_speed);
        0.5 * beta * rho_bar * du
    }

    /// The same for a fluid–wall pair with the wall's η.
    #[inline(always)]
    fn wall_dissipation(&self, rho_bar: f32, du: f32) -> f32 {
        let beta = (self.wall_limiter * du.max(0.0)).min(self.sound_speed);
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
            let f = c.gradient(r, r2, k < n);
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
    // The wall normal n_i = Σ_b ∇W_ib / |Σ_b ∇W_ib| (pointing from the particle into the
    // wall): a first pass over the list, only with dissipation at walls.
    let mut normal = [0.0f32; 3];
    if c.wall_limiter > 0.0 {
        let mut nx = [0.0f32; L];
        let mut ny = [0.0f32; L];
        let mut nz = [0.0f32; L];
        let mut k0 = 0;
        while k0 < list.len() {
            let (idx, n) = block(list, k0);
            let [x, y, z, ..] = gather(walls, &idx);
            for k in 0..L {
                let (rx, ry, rz) = (xi - x[k], yi - y[k], zi - z[k]);
                let r2 = rx * rx + ry * ry + rz * rz;
                let f = c.gradient(r2.sqrt(), r2, k < n);
                nx[k] += f * rx;
                ny[k] += f * ry;
                nz[k] += f * rz;
            }
            k0 += n;
        }
        let s = [sum(nx), sum(ny), sum(nz)];
        let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        if len > 0.0 {
            normal = s.map(|v| (v / len) as f32);
        }
    }
    let [nxi, nyi, nzi] = normal;
    let mut dn = [0.0f32; L];
    let mut k0 = 0;
    while k0 < list.len() {
        let (idx, n) = block(list, k0);
        let [x, y, z, drb, vxb, vyb, vzb, pb] = gather(walls, &idx);
        for k in 0..L {
            let (rx, ry, rz) = (xi - x[k], yi - y[k], zi - z[k]);
            let r2 = rx * rx + ry * ry + rz * rz;
            let r = r2.sqrt();
            let f = c.gradient(r, r2, k < n);
            let rb = c.rest_density + drb[k];
            let (wx, wy, wz) = (vxi - vxb[k], vyi - vyb[k], vzi - vzb[k]);
            let vr = wx * rx + wy * ry + wz * rz;
            let p_star = 0.5 * (pi + pb[k]);
            let inv_rb = 1.0 / rb;
            let fc = f * 2.0 * p_star * inv_rb;
            ax[k] -= rx * fc;
            ay[k] -= ry * fc;
            az[k] -= rz * fc;
            dv[k] += f * vr;
            // Zhang, Hu & Adams (2017) §3.3: the wall's dissipation along n_i, the jump of the
            // mirrored normal velocity u = 2 (v_i − v_b)·n_i (positive approaching), acting
            // through |∇W_ib| along n_i: −2 (P* − p̄)/(ρ_i ρ_b) |∇W_ib| n_i.
            let u = 2.0 * (wx * nxi + wy * nyi + wz * nzi);
            let d = c.wall_dissipation(0.5 * (ri + rb), u);
            dn[k] += 2.0 * f * r * d * inv_rb;
        }
        k0 += n;
    }
    let dn = sum(dn);
    let a = Vector::new(
        sum(ax) + dn * nxi as Real,
        sum(ay) + dn * nyi as Real,
        sum(az) + dn * nzi as Real,
    );
    (a / ri as Real, sum(dv))
}

/// The pressure factor of a fluid–wall pair, (p_i + p_b)/(ρ_i ρ_b): [`boundary_sums`]' term
/// without m and ∇W, for a moving block's reaction (pair by pair, Newton's third law).
#[inline]
pub fn wall_pair(pi: Real, ri: Real, pb: Real, rb: Real) -> Real {
    (pi + pb) / (ri * rb)
}

/// The dissipative factor of a fluid–wall pair, 2 (P* − p̄)/(ρ_i ρ_b) for the jump
/// u = 2 (v_i − v_b)·n_i: [`boundary_sums`]' wall term without m, |∇W| and n_i, in f64 for a
/// moving block's reaction.
#[inline]
pub fn wall_pair_dissipation(c: &RiemannConstants, ri: Real, rb: Real, u: Real) -> Real {
    let beta = (c.wall_limiter as Real * u.max(0.0)).min(c.sound_speed as Real);
    beta * 0.5 * (ri + rb) * u / (ri * rb)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn constants() -> RiemannConstants {
        RiemannConstants::new(
            &WendlandC2::new(0.013),
            1000.0,
            20.0,
            WALL_ETA,
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

    /// Zhang, Hu & Adams (2017) §3.3 at a wall: a particle sliding along a flat wall takes no
    /// dissipation (its normal velocity is zero: no friction along the floor), one approaching
    /// it is pushed back along the wall normal alone, by 2 (P* − p̄)/(ρ_i ρ_b) |∇W| summed.
    #[test]
    fn the_wall_dissipates_the_normal_approach_only() {
        let h = 0.013;
        let dx = h / 1.3;
        let origin = Vector::zeros();
        // Two layers of wall particles under the plane z = 0, symmetric about x = y = 0.
        let mut walls = Vec::new();
        for layer in 0..2 {
            for ix in -4..=4 {
                for iy in -4..=4 {
                    let x = Vector::new(
                        ix as Real * dx,
                        iy as Real * dx,
                        -(layer as Real + 0.5) * dx,
                    );
                    walls.push(record(&x, &origin, &Vector::zeros(), 1000.0, 1000.0, 500.0));
                }
            }
        }
        let list: Vec<u32> = (0..walls.len() as u32).collect();
        let at = Vector::new(0.0, 0.0, 0.5 * dx);
        let with =
            RiemannConstants::new(&WendlandC2::new(h), 1000.0, 20.0, WALL_ETA, Vector::zeros());
        let without =
            RiemannConstants::new(&WendlandC2::new(h), 1000.0, 20.0, 0.0, Vector::zeros());
        let run = |v: Vector, c: &RiemannConstants| {
            let me = record(&at, &origin, &v, 1000.0, 1000.0, 500.0);
            boundary_sums(&me, &list, &walls, c)
        };
        // Sliding: the same sums with and without the wall's dissipation.
        let slide = Vector::new(2.0, 0.0, 0.0);
        let ((a, d), (a0, d0)) = (run(slide, &with), run(slide, &without));
        assert!((a - a0).norm() <= 1e-6 * a0.norm(), "{a:?} vs {a0:?}");
        assert_eq!(d, d0);
        // Approaching at 1 m/s: pushed up, not sideways; continuity unchanged.
        let fall = Vector::new(2.0, 0.0, -1.0);
        let ((a, d), (a0, d0)) = (run(fall, &with), run(fall, &without));
        let extra = a - a0;
        assert!(extra.z > 0.0, "{extra:?}");
        assert!(
            extra.x.abs() < 1e-6 * extra.z && extra.y.abs() < 1e-6 * extra.z,
            "{extra:?}"
        );
        assert_eq!(d, d0);
        // Receding: no dissipation.
        let rise = Vector::new(2.0, 0.0, 1.0);
        assert_eq!(run(rise, &with), run(rise, &without));
    }
}
