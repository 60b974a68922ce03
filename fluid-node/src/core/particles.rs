//! Fluid particles as a structure of arrays: each field its own contiguous vector, so the
//! density pass streams positions only and rayon splits every array the same way.

use rayon::prelude::*;
use shared::math::{Real, Vector};

/// All per-particle state. Every particle has the same mass ρ0·dx³, kept once in the solver.
#[derive(Debug, Default, Clone, serde::Serialize, serde::Deserialize)]
pub struct Particles {
    pub position: Vec<Vector>,
    pub velocity: Vec<Vector>,
    /// Density [kg/m³]: summed (Müller, paper Eq. 12) or integrated (WCSPH continuity).
    pub density: Vec<Real>,
    pub pressure: Vec<Real>,
    /// Acceleration of the last force evaluation [m/s²].
    pub acceleration: Vec<Vector>,
    /// dρ/dt of the last evaluation (WCSPH).
    pub density_rate: Vec<Real>,
    /// Eq. 22 force of every block on the particle for the current step [N].
    pub penalty: Vec<Vector>,
    /// State at the start of the step (symplectic) or one step back (Verlet).
    pub position0: Vec<Vector>,
    pub velocity0: Vec<Vector>,
    pub density0: Vec<Real>,
    /// The permutation's buffers ([`Particles::permute`]): scratch, not saved in checkpoints
    /// (a restored run sizes them at its first sort).
    #[serde(skip)]
    scratch_v: Vec<Vector>,
    #[serde(skip)]
    scratch_s: Vec<Real>,
}

impl Particles {
    pub fn new(position: Vec<Vector>, density: Vec<Real>) -> Self {
        let n = position.len();
        assert_eq!(density.len(), n);
        Self {
            velocity: vec![Vector::zeros(); n],
            pressure: vec![0.0; n],
            acceleration: vec![Vector::zeros(); n],
            density_rate: vec![0.0; n],
            penalty: vec![Vector::zeros(); n],
            position0: position.clone(),
            velocity0: vec![Vector::zeros(); n],
            density0: density.clone(),
            scratch_v: vec![Vector::zeros(); n],
            scratch_s: vec![0.0; n],
            position,
            density,
        }
    }

    pub fn len(&self) -> usize {
        self.position.len()
    }

    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Reorders the arrays a scheme `carries` by `order` (new slot k takes old particle
    /// `order[k]`), through two scratch buffers that are swapped in: no allocation. The
    /// positions' new order is also copied into `sorted_at` (the lists are those of these
    /// positions), in the same pass.
    ///
    /// A vector array and a scalar array are gathered in one parallel region, one into each
    /// scratch buffer: with a region per array the second thread woke up for a few dozen µs of
    /// work each time, and the permutation ran no faster on 2 threads than on 1.
    ///
    /// The arrays not carried keep their old order: the scheme rewrites them before it reads
    /// them again. Eq. 22's forces are never carried: they are recomputed after every sort.
    pub fn permute(&mut self, order: &[u32], carried: Carried, sorted_at: &mut Vec<Vector>) {
        let (sv, ss) = (&mut self.scratch_v, &mut self.scratch_s);
        // A no-op once sized (no allocation); a restored run's are empty.
        sv.resize(order.len(), Vector::zeros());
        ss.resize(order.len(), 0.0);
        sorted_at.resize(order.len(), Vector::zeros());
        let (position, density) = (&self.position, &self.density);
        sv.par_iter_mut()
            .zip(ss.par_iter_mut())
            .zip(sorted_at.par_iter_mut())
            .zip(order.par_iter())
            .for_each(|(((x, rho), copy), &o)| {
                *x = position[o as usize];
                *copy = *x;
                *rho = density[o as usize];
            });
        std::mem::swap(&mut self.position, sv);
        std::mem::swap(&mut self.density, ss);
        gather(
            order,
            (&mut self.velocity, sv),
            Some((&mut self.pressure, ss)),
        );
        if carried.rates {
            gather(
                order,
                (&mut self.acceleration, sv),
                Some((&mut self.density_rate, ss)),
            );
        }
        if carried.history {
            gather(
                order,
                (&mut self.position0, sv),
                Some((&mut self.density0, ss)),
            );
            gather(order, (&mut self.velocity0, sv), None);
        }
    }
}

/// `data[order[k]]` into `scratch[k]` for every slot k, and the same for the pair of scalar
/// arrays if given, in one parallel region; each scratch buffer is then swapped in.
fn gather(
    order: &[u32],
    (data, scratch): (&mut Vec<Vector>, &mut Vec<Vector>),
    scalars: Option<(&mut Vec<Real>, &mut Vec<Real>)>,
) {
    let vectors = &*data;
    match scalars {
        Some((values, scratch_s)) => {
            let scalars = &*values;
            scratch
                .par_iter_mut()
                .zip(scratch_s.par_iter_mut())
                .zip(order.par_iter())
                .for_each(|((v, s), &o)| {
                    *v = vectors[o as usize];
                    *s = scalars[o as usize];
                });
            std::mem::swap(values, scratch_s);
        }
        None => scratch
            .par_iter_mut()
            .zip(order.par_iter())
            .for_each(|(v, &o)| *v = vectors[o as usize]),
    }
    std::mem::swap(data, scratch);
}

/// Which per-particle arrays a scheme reads after a sort before it writes them (positions,
/// velocities, densities and pressures always are): only these are reordered at a sort. A
/// scheme that rewrites the rest every step saves their gathers (Müller: five of nine arrays,
/// a sort every step).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Carried {
    /// `acceleration` and `density_rate`: the last evaluation's rates (WCSPH's predictor starts
    /// from them; DFSPH warm-starts from its factors, which it keeps there).
    pub rates: bool,
    /// `position0`, `velocity0`, `density0`: the state one step back (WCSPH's Verlet; DFSPH
    /// keeps a warm start in `density0`).
    pub history: bool,
}

impl Carried {
    /// Every array but Eq. 22's forces.
    pub const ALL: Self = Self {
        rates: true,
        history: true,
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Five particles on the x axis at x = i, each field a multiple of i.
    fn five() -> Particles {
        let pos: Vec<Vector> = (0..5).map(|i| Vector::new(i as f64, 0.0, 0.0)).collect();
        let rho: Vec<f64> = (0..5).map(|i| 1000.0 + i as f64).collect();
        let mut p = Particles::new(pos, rho);
        for i in 0..5 {
            let x = i as f64;
            p.velocity[i].y = x;
            p.pressure[i] = 2.0 * x;
            p.acceleration[i].z = 3.0 * x;
            p.density_rate[i] = 4.0 * x;
            p.velocity0[i].x = 5.0 * x;
            p.density0[i] = 6.0 * x;
        }
        p
    }

    /// The permutation's buffers stay out of a checkpoint (32 bytes a particle), and a restored
    /// set, whose buffers are empty, sorts as the original does.
    #[test]
    fn a_restored_set_permutes_without_its_scratch() {
        let mut p = five();
        let bytes = shared::checkpoint::encode(&p).unwrap();
        let mut q: Particles = shared::checkpoint::decode(&bytes, "particles").unwrap();
        assert!(q.scratch_v.is_empty() && q.scratch_s.is_empty());
        p.scratch_v.clear();
        p.scratch_s.clear();
        assert_eq!(shared::checkpoint::encode(&p).unwrap(), bytes);
        let order = [4, 2, 0, 1, 3];
        let (mut a, mut b) = (Vec::new(), Vec::new());
        five().permute(&order, Carried::ALL, &mut a);
        q.permute(&order, Carried::ALL, &mut b);
        assert_eq!(a, b);
        assert_eq!(q.position, b);
        assert_eq!(q.density0[0], 24.0);
    }

    #[test]
    fn permute_moves_every_field_together() {
        let mut p = five();
        let mut sorted_at = Vec::new();
        p.permute(&[4, 2, 0, 1, 3], Carried::ALL, &mut sorted_at);
        assert_eq!(sorted_at, p.position);
        for k in 0..5 {
            let i = p.position[k].x;
            assert_eq!(p.velocity[k].y, i);
            assert_eq!(p.density[k], 1000.0 + i);
            assert_eq!(p.pressure[k], 2.0 * i);
            assert_eq!(p.acceleration[k].z, 3.0 * i);
            assert_eq!(p.density_rate[k], 4.0 * i);
            assert_eq!(p.position0[k].x, i);
            assert_eq!(p.velocity0[k].x, 5.0 * i);
            assert_eq!(p.density0[k], 6.0 * i);
        }
        assert_eq!(p.position[0].x, 4.0);
        // Without the history, the one-step-back state keeps its old order.
        let carried = Carried {
            rates: true,
            history: false,
        };
        p.permute(&[4, 2, 0, 1, 3], carried, &mut sorted_at);
        assert_eq!(p.position[0].x, 3.0);
        assert_eq!(p.velocity[0].y, 3.0);
        assert_eq!(p.position0[0].x, 4.0);
    }
}
