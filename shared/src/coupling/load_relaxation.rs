//! Added-mass stabilisation of the lagged coupling: the water's loads under-relaxed per block.
//!
//! Both coupling schemes hand the solid the loads of the fluid's previous state, so the water
//! answers a block's acceleration one step late. Model the water's response by an added mass
//! M_A (the load is F = −M_A a + the rest): the lagged step m a_{n+1} = −M_A a_n + … multiplies
//! the acceleration by −M_A/m per step, which grows once the water that moves with the block
//! outweighs it (Causin, Gerbeau & Nobile 2005; [`crate::coupling::added_mass`] detects it). With an
//! incompressible solver (DFSPH) M_A does not shrink with the step, so a light block, or a
//! heavy one closing on the floor through a thin film, cannot be saved by a smaller dt.
//!
//! The remedy here is the classical one of partitioned schemes, an artificial added mass
//! m_a on the solid side (cf. Förster, Wall & Ramm 2007, and the added-mass partitioned scheme
//! of Banks, Henshaw, Schwendeman & Tang 2017 for rigid bodies): the load handed to the solid
//! is relaxed, F̃_n = ω F_n + (1 − ω) F̃_{n−1}, with ω = m / (m + m_a). With F_n = −M_A a_n and
//! m a_{n+1} = F̃_n + R (R the other forces, held), a_{n+1} = r a_n + ω R / m with
//!
//!   r = (m_a − M_A) / (m + m_a),
//!
//! and the fixed point is a = R / (m + M_A), the coupled solution: the relaxation changes how
//! the loads are reached, not where they settle. It is stable when |r| < 1, i.e. for
//! M_A < m + 2 m_a (without it, M_A < m), and converges in one step when m_a = M_A. An m_a
//! too large is safe but slow (the load lags by about m_a/m steps); too small leaves the
//! instability where it was. m_a = C ρ_w V with the block's volume V; C ≈ 0.5–1 is the added
//! mass of a compact body in open water (0.5 for a sphere; more near a wall or the floor).
//!
//! Torques and strain loads are relaxed with the same ω (the rotational added inertia of a
//! compact block stands to its inertia about as M_A to m). A block without a fluid load (out
//! of the water) sees its last load fade as (1 − ω)^n: the price of the lag, shown in the
//! validation (floating and sinking blocks, docs/stability.md).

use crate::math::Real;
use crate::protocol::BlockLoad;

/// The relaxed loads of the moving blocks, in loads order.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct LoadRelaxation {
    /// ω = m / (m + m_a) per block (1 for a kinematic block: infinite mass).
    omega: Vec<Real>,
    /// F̃ of the last step; empty until the first loads arrive.
    held: Vec<BlockLoad>,
}

impl LoadRelaxation {
    /// `blocks`: (mass [kg], volume [m³]) of each moving block, in loads order; the artificial
    /// added mass is `coefficient` ρ_w V. None when `coefficient` is zero (no relaxation).
    pub fn new(blocks: &[(Real, Real)], coefficient: Real, water_density: Real) -> Option<Self> {
        (coefficient > 0.0).then(|| Self {
            omega: blocks
                .iter()
                .map(|&(mass, volume)| {
                    if mass.is_finite() {
                        mass / (mass + coefficient * water_density * volume)
                    } else {
                        1.0
                    }
                })
                .collect(),
            held: Vec::with_capacity(blocks.len()),
        })
    }

    /// Relaxes one step's `loads` in place of the last ones and returns them. The first
    /// step's loads pass unchanged (there is no earlier state to relax from: a block at rest in
    /// equilibrium stays so).
    pub fn apply(&mut self, loads: &[BlockLoad]) -> &[BlockLoad] {
        if self.held.len() != loads.len() {
            self.held.clear();
            self.held.extend_from_slice(loads);
            return &self.held;
        }
        for ((held, new), &w) in self.held.iter_mut().zip(loads).zip(&self.omega) {
            held.block = new.block;
            let mix = |old: &mut [Real], new: &[Real]| {
                for (o, n) in old.iter_mut().zip(new) {
                    *o = w * n + (1.0 - w) * *o;
                }
            };
            mix(&mut held.force, &new.force);
            mix(&mut held.torque, &new.torque);
            mix(&mut held.strain_load, &new.strain_load);
        }
        &self.held
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(fz: Real) -> BlockLoad {
        BlockLoad::vertical(fz)
    }

    /// A block of mass m in water of added mass M_A (the load answers −M_A a, one step late),
    /// pulled by a constant R: the accelerations of the lagged scheme, relaxed or not.
    fn lagged(m: Real, added: Real, coefficient: Real, steps: usize) -> Vec<Real> {
        let r = 1.0;
        let mut relax = LoadRelaxation::new(&[(m, 1.0)], coefficient, 1.0);
        let mut a: Real = 0.0;
        let mut out = Vec::new();
        for _ in 0..steps {
            let water = [load(-added * a)];
            let f = match relax.as_mut() {
                Some(x) => x.apply(&water)[0].force[2],
                None => water[0].force[2],
            };
            a = (f + r) / m;
            out.push(a);
        }
        out
    }

    #[test]
    fn a_light_block_grows_unrelaxed_and_settles_relaxed_on_the_coupled_answer() {
        // M_A = 2 m: the lagged scheme's factor is −2 per step.
        let plain = lagged(1.0, 2.0, 0.0, 30);
        assert!(plain[29].abs() > 1e6, "{:?}", &plain[25..]);
        // m_a = M_A: r = 0; any m_a > M_A/2 − m/2 is stable.
        for c in [2.0, 1.0, 5.0] {
            let relaxed = lagged(1.0, 2.0, c, 200);
            let exact = 1.0 / (1.0 + 2.0);
            let last = relaxed[199];
            assert!(
                (last - exact).abs() < 1e-6 * exact,
                "C = {c}: a = {last}, coupled a = {exact}"
            );
        }
        // m_a too small (M_A ≥ m + 2 m_a): still unstable.
        let short = lagged(1.0, 2.0, 0.4, 200);
        assert!(short[199].abs() > 1e3, "{}", short[199]);
    }

    #[test]
    fn a_heavy_block_is_barely_touched_and_kinematic_blocks_not_at_all() {
        let x =
            LoadRelaxation::new(&[(2600.0, 1.0), (Real::INFINITY, 1.0)], 1.0, 1000.0).expect("on");
        assert!((x.omega[0] - 2600.0 / 3600.0).abs() < 1e-12);
        assert_eq!(x.omega[1], 1.0);
        assert!(LoadRelaxation::new(&[(1.0, 1.0)], 0.0, 1000.0).is_none());
    }

    #[test]
    fn the_first_loads_pass_unchanged() {
        let mut x = LoadRelaxation::new(&[(1.0, 1.0)], 1.0, 1.0).unwrap();
        assert_eq!(x.apply(&[load(5.0)])[0].force[2], 5.0);
        // Then half-way (ω = 1/2) towards each new load.
        assert_eq!(x.apply(&[load(1.0)])[0].force[2], 3.0);
    }
}
