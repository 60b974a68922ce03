//! One boundary-particle set for every block, fixed and moving (Adami, Hu & Adams 2012), seen by
//! the schemes through one neighbour iterator ([`Boundary::for_each_neighbor`]): a scheme's pass over a fluid particle's boundary
//! neighbours is one loop, whatever block each neighbour belongs to.
//!
//! Inside, the set has two parts because they move differently: the fixed blocks' particles
//! ([`WallParticles`]) are sorted into the grid once, the moving blocks' ([`BodyParticles`]) are
//! carried and re-sorted at every pose, and only they load a block. The iterator visits the fixed
//! part first, then the moving part, so sums keep one fixed order (runs are deterministic).
//!
//! The folder: this file is the set and its iterator; [`walls`] the fixed blocks' particles,
//! [`bodies`] the moving blocks', [`terrain`] the `[[terrain]]` ground (boundary particles under
//! its surface and Eq. 22 against its triangles), [`penalty`] paper Eq. 22 between water and
//! blocks, both ways.

pub mod bodies;
pub mod penalty;
pub mod terrain;
pub mod walls;

use crate::boundary::bodies::BodyParticles;
use crate::boundary::walls::WallParticles;
use crate::core::grid::CellGrid;
use crate::core::lanes::Packed;
use crate::core::neighbors::NeighborLists;
use crate::core::particles::Particles;
use crate::core::scatter::scatter;
use crate::kernels::Kernel;
use shared::math::{Real, Vector};
use shared::protocol::{BlockLoad, BlockState};

/// The boundary particles of all blocks, and each fluid particle's neighbours among them.
#[derive(Debug, Clone, Default)]
pub struct Boundary {
    fixed: Option<WallParticles>,
    moving: Option<BodyParticles>,
    /// Boundary neighbours of each fluid particle in the fixed and in the moving part.
    fixed_lists: NeighborLists,
    moving_lists: NeighborLists,
    /// f32 records of the fixed and moving parts' active particles for the vectorised pair
    /// loops ([`Self::pack`]; what the two scalars mean is the scheme's).
    fixed_packed: Vec<Packed>,
    moving_packed: Vec<Packed>,
}

/// One boundary neighbour of a fluid particle: a wall point with its extrapolated pressure, the
/// density that pressure implies, and its velocity (zero on a fixed block).
#[derive(Debug, Clone, Copy)]
pub struct Near<'a> {
    set: &'a WallParticles,
    index: usize,
    velocity: Option<&'a [Vector]>,
}

impl Near<'_> {
    /// Index of the particle in its set (sorted order).
    #[inline]
    pub fn index(&self) -> usize {
        self.index
    }
    #[inline]
    pub fn position(&self) -> Vector {
        self.set.position[self.index]
    }
    #[inline]
    pub fn pressure(&self) -> Real {
        self.set.pressure[self.index]
    }
    #[inline]
    pub fn density(&self) -> Real {
        self.set.density[self.index]
    }
    /// The wall's material velocity (free slip: it enters the continuity equation only).
    #[inline]
    pub fn velocity(&self) -> Vector {
        self.velocity.map_or(Vector::zeros(), |v| v[self.index])
    }
}

impl Boundary {
    /// `fixed`: the fixed blocks' particles (none for Eq. 22-only walls); `moving`: the moving
    /// blocks' (none when no block moves or walls are Eq. 22 only).
    pub fn new(fixed: Option<WallParticles>, moving: Option<BodyParticles>) -> Self {
        Self {
            fixed,
            moving,
            ..Self::default()
        }
    }

    /// Number of (fluid, boundary) pairs listed, fixed and moving parts together.
    pub fn listed_pairs(&self) -> usize {
        self.fixed_lists.pairs() + self.moving_lists.pairs()
    }

    /// The fixed boundary neighbours listed for fluid particle `i` (a rank's work measure).
    pub fn fixed_listed(&self, i: usize) -> usize {
        if self.fixed.is_some() {
            self.fixed_lists.of(i).len()
        } else {
            0
        }
    }

    /// Number of fixed and of moving boundary particles.
    pub fn counts(&self) -> (usize, usize) {
        (
            self.fixed.as_ref().map_or(0, WallParticles::len),
            self.moving.as_ref().map_or(0, BodyParticles::len),
        )
    }

    /// Calls `f` on each boundary neighbour of fluid particle `i`, fixed first, then moving.
    /// An internal iterator, inlined into the scheme's pair loop: the two parts compile to two
    /// plain loops (an external `flat_map`/`chain` iterator left a call per pair and cost 6 %
    /// of a Müller step).
    #[inline(always)]
    pub fn for_each_neighbor(&self, i: usize, mut f: impl FnMut(Near<'_>)) {
        self.for_each_fixed_neighbor(i, &mut f);
        self.for_each_moving_neighbor(i, f);
    }

    /// Calls `f` on each boundary neighbour of fluid particle `i` on a fixed block.
    #[inline(always)]
    pub fn for_each_fixed_neighbor(&self, i: usize, mut f: impl FnMut(Near<'_>)) {
        if let Some(set) = &self.fixed {
            for &j in self.fixed_lists.of(i) {
                f(Near {
                    set,
                    index: j as usize,
                    velocity: None,
                });
            }
        }
    }

    /// Calls `f(b, r, |r|)` on each fixed boundary neighbour b of fluid particle `i` (at `x`)
    /// closer than `support`, r = x − x_b: a method's wall term pair by pair.
    pub fn for_each_fixed_within(
        &self,
        i: usize,
        x: &Vector,
        support: Real,
        mut f: impl FnMut(Near<'_>, &Vector, Real),
    ) {
        self.for_each_fixed_neighbor(i, |b| {
            let r = x - b.position();
            let len = r.norm();
            if len < support {
                f(b, &r, len);
            }
        });
    }

    /// The fixed blocks' boundary particles, if any.
    pub fn fixed(&self) -> Option<&WallParticles> {
        self.fixed.as_ref()
    }

    /// Calls `f` on each boundary neighbour of fluid particle `i` on a moving block.
    #[inline(always)]
    pub fn for_each_moving_neighbor(&self, i: usize, mut f: impl FnMut(Near<'_>)) {
        if let Some(b) = &self.moving {
            for &j in self.moving_lists.of(i) {
                f(Near {
                    set: &b.set,
                    index: j as usize,
                    velocity: Some(&b.velocity),
                });
            }
        }
    }

    /// The moving blocks' particles, if any.
    pub fn bodies(&self) -> Option<&BodyParticles> {
        self.moving.as_ref()
    }

    pub fn bodies_mut(&mut self) -> Option<&mut BodyParticles> {
        self.moving.as_mut()
    }

    /// Fills the f32 records of every active boundary particle, fixed and moving:
    /// `record(position, velocity, pressure, density)` (the velocity zero on a fixed block),
    /// after their pressures were extrapolated ([`Self::update`]).
    pub fn pack(&mut self, record: impl Fn(&Vector, &Vector, Real, Real) -> Packed + Sync) {
        fn fill(
            set: &WallParticles,
            velocity: Option<&[Vector]>,
            out: &mut Vec<Packed>,
            record: &(impl Fn(&Vector, &Vector, Real, Real) -> Packed + Sync),
        ) {
            out.resize(set.len(), Packed::default());
            let zero = Vector::zeros();
            // Only the active particles (in increasing order) are read by a pair loop.
            scatter(&mut out[..], &set.active, &|_, w| {
                let v = velocity.map_or(&zero, |v| &v[w]);
                record(&set.position[w], v, set.pressure[w], set.density[w])
            });
        }
        if let Some(w) = &self.fixed {
            fill(w, None, &mut self.fixed_packed, &record);
        }
        if let Some(b) = &self.moving {
            fill(&b.set, Some(&b.velocity), &mut self.moving_packed, &record);
        }
    }

    /// Calls `f` with fluid particle `i`'s boundary neighbours and the records they index
    /// ([`Self::pack`]), fixed part first, then moving (the order of
    /// [`Self::for_each_neighbor`]).
    #[inline(always)]
    pub fn for_each_list(&self, i: usize, mut f: impl FnMut(&[u32], &[Packed])) {
        if self.fixed.is_some() {
            f(self.fixed_lists.of(i), &self.fixed_packed);
        }
        if self.moving.is_some() {
            f(self.moving_lists.of(i), &self.moving_packed);
        }
    }

    /// Lists the fixed neighbours of the (just sorted) fluid and finds the wall particles near
    /// water; only of the particles `listed` marks, if given (a rank's own: `crate::ranks`).
    pub fn list_fixed(
        &mut self,
        fluid: &[Vector],
        grid: &CellGrid,
        radius: Real,
        listed: Option<&[bool]>,
    ) {
        if let Some(w) = &mut self.fixed {
            self.fixed_lists
                .build_for(fluid, &w.position, &w.grid, radius, false, listed);
            w.activate(&self.fixed_lists, fluid, grid, radius);
        }
    }

    /// Lists the moving neighbours of the fluid (after the fluid or the blocks moved).
    pub fn list_moving(&mut self, fluid: &[Vector], grid: &CellGrid, radius: Real) {
        if let Some(b) = &mut self.moving {
            self.moving_lists
                .build(fluid, &b.set.position, &b.set.grid, radius, false);
            b.set.activate(&self.moving_lists, fluid, grid, radius);
        }
    }

    /// Carries the moving blocks' particles to the poses the solid node sent.
    pub fn place(&mut self, blocks: &[BlockState]) {
        if let Some(b) = &mut self.moving {
            b.place(blocks);
        }
    }

    /// Adami's pressure extrapolation on every active boundary particle, fixed then moving;
    /// `density_of` is the scheme's inverse equation of state.
    pub fn update<K: Kernel>(
        &mut self,
        kernel: &K,
        fluid: &Particles,
        gravity: &Vector,
        rest_density: Real,
        density_of: impl Fn(Real) -> Real + Sync,
    ) {
        if let Some(w) = &mut self.fixed {
            w.update(kernel, fluid, gravity, rest_density, &density_of);
        }
        self.update_moving(kernel, fluid, gravity, rest_density, density_of);
    }

    /// [`Self::update`] on the moving part alone (after a new pose). The wall acceleration term
    /// of Adami's Eq. 27 (g − a_w) is left out: the solid node sends poses and velocities, not
    /// accelerations, and for a block near equilibrium a_w ≪ g.
    pub fn update_moving<K: Kernel>(
        &mut self,
        kernel: &K,
        fluid: &Particles,
        gravity: &Vector,
        rest_density: Real,
        density_of: impl Fn(Real) -> Real + Sync,
    ) {
        if let Some(b) = &mut self.moving {
            b.set
                .update(kernel, fluid, gravity, rest_density, density_of);
        }
    }

    /// The water's force on each moving block through its boundary particles:
    /// see [`BodyParticles::react`].
    pub fn react(
        &mut self,
        fluid: &[Vector],
        support: Real,
        pair: impl Fn(usize, Real, Real, &Vector, Real) -> Vector + Sync,
        split: Option<(&crate::ranks::share::Share, &CellGrid)>,
    ) {
        if let Some(b) = &mut self.moving {
            b.react(fluid, support, pair, split);
        }
    }

    /// [`Self::react`] with the wall particle's velocity: see [`BodyParticles::react_moving`].
    pub fn react_moving(
        &mut self,
        fluid: &[Vector],
        support: Real,
        pair: impl Fn(usize, &Vector, Real, Real, &Vector, Real) -> Vector + Sync,
        split: Option<(&crate::ranks::share::Share, &CellGrid)>,
    ) {
        if let Some(b) = &mut self.moving {
            b.react_moving(fluid, support, pair, split);
        }
    }

    /// Adds the last [`Self::react`] to the moving blocks' loads.
    pub fn add_loads(&self, loads: &mut [BlockLoad]) {
        if let Some(b) = &self.moving {
            b.add_loads(loads);
        }
    }
}
