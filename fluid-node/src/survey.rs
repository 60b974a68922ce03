//! One pass over the particles after a step: everything the stability checks, the next step's
//! proposal and the Verlet lists' validity need, in a single parallel reduction (five separate
//! passes before; each a parallel loop whose fixed cost weighed on two threads at 3·10⁴
//! particles). Violations are reported for the lowest particle index, so the message of an
//! unstable run is the same at every run and thread count.

use rayon::prelude::*;
use shared::math::{Real, Vector};

/// What one pass found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Survey {
    /// Largest speed and acceleration magnitude [m/s, m/s²].
    pub v_max: Real,
    pub a_max: Real,
    /// The first particle with a non-finite position, velocity or density.
    pub not_finite: Option<usize>,
    /// The first particle outside the domain.
    pub outside: Option<usize>,
    /// The first particle whose density ratio ρ/ρ_ref passes the bound (above it, or below its
    /// inverse when low densities count).
    pub density: Option<usize>,
    /// Whether some particle may move past half the lists' skin before the next evaluation.
    pub moved: bool,
}

/// The rules the pass applies.
pub struct Rules {
    pub domain: (Vector, Vector),
    /// Density ratio bound, the reference density, and whether a low density is a violation.
    pub density_bound: Real,
    pub reference_density: Real,
    pub check_low_density: bool,
    /// Half the skin, and the step just taken (a particle may move twice this step's |v|·dt
    /// in the next).
    pub reach: Real,
    pub dt: Real,
}

impl Survey {
    const EMPTY: Self = Self {
        v_max: 0.0,
        a_max: 0.0,
        not_finite: None,
        outside: None,
        density: None,
        moved: false,
    };

    /// Joins two partial surveys (of disjoint particle ranges).
    fn join(a: Self, b: Self) -> Self {
        let first = |x: Option<usize>, y: Option<usize>| match (x, y) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, y) => x.or(y),
        };
        Self {
            v_max: a.v_max.max(b.v_max),
            a_max: a.a_max.max(b.a_max),
            not_finite: first(a.not_finite, b.not_finite),
            outside: first(a.outside, b.outside),
            density: first(a.density, b.density),
            moved: a.moved || b.moved,
        }
    }

    /// The pass over particles with `position`, `velocity`, `acceleration`, `density`, and their
    /// positions at the last sort `sorted_at`.
    pub fn of(
        position: &[Vector],
        velocity: &[Vector],
        acceleration: &[Vector],
        density: &[Real],
        sorted_at: &[Vector],
        rules: &Rules,
    ) -> Self {
        let (lo, hi) = rules.domain;
        let (bound, rho_ref) = (rules.density_bound, rules.reference_density);
        // v_max and a_max hold squares until the end.
        let squared = (0..position.len())
            .into_par_iter()
            .fold(
                || Self::EMPTY,
                |mut s, i| {
                    let (x, v, rho) = (&position[i], &velocity[i], density[i]);
                    let note = |slot: &mut Option<usize>| {
                        if slot.is_none() {
                            *slot = Some(i);
                        }
                    };
                    if !(x.iter().all(|c| c.is_finite())
                        && v.iter().all(|c| c.is_finite())
                        && rho.is_finite())
                    {
                        note(&mut s.not_finite);
                    }
                    if (0..3).any(|k| x[k] < lo[k] || x[k] > hi[k]) {
                        note(&mut s.outside);
                    }
                    let q = rho / rho_ref;
                    if q > bound || (rules.check_low_density && q < 1.0 / bound) {
                        note(&mut s.density);
                    }
                    let speed2 = v.norm_squared();
                    s.moved |=
                        (x - sorted_at[i]).norm() + 2.0 * speed2.sqrt() * rules.dt >= rules.reach;
                    s.v_max = s.v_max.max(speed2);
                    s.a_max = s.a_max.max(acceleration[i].norm_squared());
                    s
                },
            )
            .reduce(|| Self::EMPTY, Self::join);
        Self {
            v_max: squared.v_max.sqrt(),
            a_max: squared.a_max.sqrt(),
            ..squared
        }
    }
}
