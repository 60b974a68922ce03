//! One pass over the particles after a step: everything the stability checks, the next step's
//! proposal and the Verlet lists' validity need, in a single parallel reduction (five separate
//! passes before; each a parallel loop whose fixed cost weighed on two threads at 3·10⁴
//! particles). Violations are reported for the lowest particle index, so the message of an
//! unstable run is the same at every run and thread count.

use crate::core::tasks;
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
    /// The first particle outside the domain (above an open top is not outside).
    pub outside: Option<usize>,
    /// Particles above the domain's top (counted whether it is open or not).
    pub aloft: usize,
    /// The first particle whose density ratio ρ/ρ_ref passes the bound (above it, or below its
    /// inverse when low densities count).
    pub density: Option<usize>,
    /// Whether some particle may move past half the lists' skin before the next evaluation.
    pub moved: bool,
}

/// The rules the pass applies.
pub struct Rules {
    pub domain: (Vector, Vector),
    /// Whether the domain's top is open air (`[domain] open_top`).
    pub open_top: bool,
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
        aloft: 0,
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
            aloft: a.aloft + b.aloft,
            density: first(a.density, b.density),
            moved: a.moved || b.moved,
        }
    }

    /// The pass over particles with `position`, `velocity`, `acceleration`, `density`, and their
    /// positions at the last sort `sorted_at`; on several ranks over the `owned` ones only (a
    /// halo particle is its owner's copy to the bit: its owner surveys it, and the maxima
    /// over the ranks are those of one rank).
    ///
    /// In chunks: a branch-free scan of a chunk takes the maxima and the skin test, and only a
    /// chunk where some particle breaks a rule is scanned again particle by particle to name
    /// the first (the per-particle branches cost a twentieth of a Müller step).
    pub fn of(
        position: &[Vector],
        velocity: &[Vector],
        acceleration: &[Vector],
        density: &[Real],
        sorted_at: &[Vector],
        owned: Option<&[bool]>,
        rules: &Rules,
    ) -> Self {
        const CHUNK: usize = 2048;
        let state = State {
            position,
            velocity,
            acceleration,
            density,
            sorted_at,
            owned,
            rules,
        };
        let n = position.len();
        // v_max and a_max hold squares until the end.
        let squared = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .with_max_len(tasks::CHUNKS)
            .map(|c| {
                let range = c * CHUNK..((c + 1) * CHUNK).min(n);
                state
                    .quick(range.clone())
                    .unwrap_or_else(|| range.fold(Self::EMPTY, |s, i| state.visit(s, i)))
            })
            .reduce(|| Self::EMPTY, Self::join);
        Self {
            v_max: squared.v_max.sqrt(),
            a_max: squared.a_max.sqrt(),
            ..squared
        }
    }
}

/// The arrays and rules of one pass.
struct State<'a> {
    position: &'a [Vector],
    velocity: &'a [Vector],
    acceleration: &'a [Vector],
    density: &'a [Real],
    sorted_at: &'a [Vector],
    owned: Option<&'a [bool]>,
    rules: &'a Rules,
}

impl State<'_> {
    /// Particle `i` into the partial survey `s` (speeds and accelerations squared).
    fn visit(&self, mut s: Survey, i: usize) -> Survey {
        if self.owned.is_some_and(|o| !o[i]) {
            return s;
        }
        let rules = self.rules;
        let (lo, hi) = rules.domain;
        let (x, v, rho) = (&self.position[i], &self.velocity[i], self.density[i]);
        let note = |slot: &mut Option<usize>| {
            if slot.is_none() {
                *slot = Some(i);
            }
        };
        if !(x.iter().all(|c| c.is_finite()) && v.iter().all(|c| c.is_finite()) && rho.is_finite())
        {
            note(&mut s.not_finite);
        }
        let above = x[2] > hi[2];
        if (0..3).any(|k| x[k] < lo[k])
            || x[0] > hi[0]
            || x[1] > hi[1]
            || (above && !rules.open_top)
        {
            note(&mut s.outside);
        }
        s.aloft += above as usize;
        let q = rho / rules.reference_density;
        if q > rules.density_bound || (rules.check_low_density && q < 1.0 / rules.density_bound) {
            note(&mut s.density);
        }
        let speed2 = v.norm_squared();
        s.moved |= self.may_pass_skin(i);
        s.v_max = s.v_max.max(speed2);
        s.a_max = s.a_max.max(self.acceleration[i].norm_squared());
        s
    }

    /// Whether particle `i` may move past half the skin before the next evaluation: its move
    /// since the sort plus twice this step's |v|·dt.
    #[inline]
    fn may_pass_skin(&self, i: usize) -> bool {
        let speed = self.velocity[i].norm_squared().sqrt();
        (self.position[i] - self.sorted_at[i]).norm() + 2.0 * speed * self.rules.dt
            >= self.rules.reach
    }

    /// [`Self::visit`] over `range` without a branch per particle, if no particle there breaks
    /// a rule (None if one may: a sum of its coordinates is not finite, or a comparison fails).
    /// The maxima are the same values `visit` takes; the skin test is skipped when the lists
    /// have no skin (every step rebuilds them).
    fn quick(&self, range: std::ops::Range<usize>) -> Option<Survey> {
        let rules = self.rules;
        let (lo, hi) = rules.domain;
        let (bound, low) = (rules.density_bound, rules.check_low_density);
        let (mut v2max, mut a2max, mut bad) = (0.0 as Real, 0.0 as Real, false);
        let (open, mut aloft) = (rules.open_top, 0usize);
        let owned = |i: usize| self.owned.is_none_or(|o| o[i]);
        for i in range.clone() {
            if !owned(i) {
                continue;
            }
            let (x, v, rho) = (&self.position[i], &self.velocity[i], self.density[i]);
            // Zero times the sum is zero unless some term is infinite or NaN.
            let finite = (x.x + x.y + x.z + v.x + v.y + v.z + rho) * 0.0 == 0.0;
            let above = x.z > hi.z;
            let outside = (x.x < lo.x)
                | (x.x > hi.x)
                | (x.y < lo.y)
                | (x.y > hi.y)
                | (x.z < lo.z)
                | (above & !open);
            aloft += above as usize;
            let q = rho / rules.reference_density;
            let dense = (q > bound) | (low & (q < 1.0 / bound));
            bad |= !finite | outside | dense;
            let v2 = v.norm_squared();
            let a2 = self.acceleration[i].norm_squared();
            v2max = if v2 > v2max { v2 } else { v2max };
            a2max = if a2 > a2max { a2 } else { a2max };
        }
        if bad {
            return None;
        }
        let moved =
            rules.reach <= 0.0 || range.into_iter().any(|i| owned(i) && self.may_pass_skin(i));
        Some(Survey {
            v_max: v2max,
            a_max: a2max,
            aloft,
            moved,
            ..Survey::EMPTY
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chunked pass against the plain per-particle fold, on clean particles and with one
    /// rule broken at a time (in the second chunk, and twice to check the first is named).
    #[test]
    fn chunked_pass_matches_the_per_particle_fold() {
        let n = 5000;
        let mut rnd = crate::uniform(7);
        let position: Vec<Vector> = (0..n).map(|_| Vector::new(rnd(), rnd(), rnd())).collect();
        let velocity: Vec<Vector> = (0..n)
            .map(|_| Vector::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5))
            .collect();
        let acceleration: Vec<Vector> = (0..n)
            .map(|_| Vector::new(rnd(), rnd(), -9.81 * rnd()))
            .collect();
        let density: Vec<Real> = (0..n).map(|_| 1000.0 + 10.0 * rnd()).collect();
        let sorted_at: Vec<Vector> = position
            .iter()
            .map(|x| x - Vector::repeat(1e-4 * rnd()))
            .collect();
        let rules = |reach: Real, low: bool| Rules {
            domain: (Vector::repeat(-0.1), Vector::repeat(1.1)),
            open_top: false,
            density_bound: 1.2,
            reference_density: 1000.0,
            check_low_density: low,
            reach,
            dt: 1e-4,
        };
        let check = |x: &[Vector], v: &[Vector], rho: &[Real], r: &Rules| {
            let state = State {
                position: x,
                velocity: v,
                acceleration: &acceleration,
                density: rho,
                sorted_at: &sorted_at,
                owned: None,
                rules: r,
            };
            let plain = (0..n).fold(Survey::EMPTY, |s, i| state.visit(s, i));
            let plain = Survey {
                v_max: plain.v_max.sqrt(),
                a_max: plain.a_max.sqrt(),
                ..plain
            };
            let fast = Survey::of(x, v, &acceleration, rho, &sorted_at, None, r);
            assert_eq!(fast, plain);
            fast
        };
        for (reach, low) in [(0.0, false), (1e-3, true), (1e-5, false)] {
            let clean = check(&position, &velocity, &density, &rules(reach, low));
            assert_eq!(clean.not_finite.or(clean.outside).or(clean.density), None);
            assert_eq!(clean.moved, reach < 1e-4);
        }
        let r = rules(1e-3, true);
        let mut x = position.clone();
        x[3001].y = Real::NAN;
        x[2500].z = Real::INFINITY;
        assert_eq!(check(&x, &velocity, &density, &r).not_finite, Some(2500));
        let mut x = position.clone();
        x[4999].x = 1.2;
        assert_eq!(check(&x, &velocity, &density, &r).outside, Some(4999));
        // Above the top: outside when it is closed, counted aloft either way; an open top
        // still closes the sides and the floor.
        let mut x = position.clone();
        x[100].z = 1.5;
        x[4000].z = 7.0;
        let closed = check(&x, &velocity, &density, &r);
        assert_eq!((closed.outside, closed.aloft), (Some(100), 2));
        let open = Rules {
            open_top: true,
            ..rules(1e-3, true)
        };
        let aloft = check(&x, &velocity, &density, &open);
        assert_eq!((aloft.outside, aloft.aloft), (None, 2));
        x[4500].x = -0.2;
        assert_eq!(check(&x, &velocity, &density, &open).outside, Some(4500));
        x[4500].x = 0.5;
        x[4600].z = -0.2;
        assert_eq!(check(&x, &velocity, &density, &open).outside, Some(4600));
        let mut rho = density.clone();
        rho[2049] = 700.0;
        rho[2100] = 1300.0;
        assert_eq!(check(&position, &velocity, &rho, &r).density, Some(2049));
        let lenient = rules(1e-3, false);
        assert_eq!(
            check(&position, &velocity, &rho, &lenient).density,
            Some(2100)
        );
    }

    /// On several ranks the halo is left to its owners: a broken or the fastest particle in the
    /// halo is not this rank's to report.
    #[test]
    fn the_halo_is_left_to_its_owners() {
        let n = 3000;
        let position: Vec<Vector> = (0..n)
            .map(|i| Vector::new(0.5, 0.5, i as Real / n as Real))
            .collect();
        let mut velocity = vec![Vector::zeros(); n];
        let (acceleration, density) = (vec![Vector::zeros(); n], vec![1000.0; n]);
        let rules = Rules {
            domain: (Vector::repeat(-0.1), Vector::repeat(1.1)),
            open_top: false,
            density_bound: 1.2,
            reference_density: 1000.0,
            check_low_density: true,
            reach: 1e-3,
            dt: 1e-4,
        };
        // The second half is halo; in it one particle is fast and one is outside.
        let owned: Vec<bool> = (0..n).map(|i| i < n / 2).collect();
        velocity[10].x = 2.0;
        velocity[2500].x = 5.0;
        let mut x = position.clone();
        x[2600].x = 7.0;
        let of = |x: &[Vector], o| {
            Survey::of(x, &velocity, &acceleration, &density, &position, o, &rules)
        };
        let (mine, all) = (of(&x, Some(&owned)), of(&x, None));
        assert_eq!((mine.v_max, mine.outside, mine.moved), (2.0, None, false));
        assert_eq!((all.v_max, all.outside, all.moved), (5.0, Some(2600), true));
        x[20].y = -1.0;
        assert_eq!(of(&x, Some(&owned)).outside, Some(20));
    }
}
