//! One rank's share of the water: the particles of its slab and their halo, kept in the order
//! they have on one rank, and the messages that keep the halo the owners' exact copy.
//!
//! # Same bits on any number of ranks
//!
//! On one rank the particles are counting-sorted by cell, stably: after sort k they are in the
//! order (cell at sort k, place after sort k − 1). A particle's place after a sort is named by
//! a key, (cell, index within the cell), which any rank holding the whole cell computes alike.
//! Every rank holds whole cells (grid columns along the cut axis, whole but for the outer
//! halo column, of which it holds the cells next to a wall: [`Share::holds`]), so a rank that puts
//! its particles in key order and then counting-sorts them by cell gets the one-rank order
//! restricted to its particles. Its neighbour lists are then the one-rank lists, entry by entry
//! (the eight-lane pair loops see every neighbour in the same lane), and every sum over a
//! particle's neighbours rounds as on one rank.
//!
//! A rank computes the rates (acceleration, dρ/dt) of the particles it owns only; the halo's
//! rates come from their owners after every evaluation ([`Share::share_rates`]). Everything
//! else is per particle (integration, equation of state, Eq. 22), so a halo particle, integrated
//! by every rank holding it from the same bits, stays the owner's copy to the last bit. At a
//! sort ([`Share::redistribute`]) each owner sends each of its particles to every rank whose
//! held columns contain it: the new owners and the new halos at once.

use super::clocked::Clocked;
use super::comm::{Comm, wire};
use super::slabs::{BINS, REBALANCE, Slabs};
use crate::boundary::Boundary;
use crate::core::grid::CellGrid;
use crate::core::neighbors::NeighborLists;
use crate::core::particles::Particles;
use rayon::prelude::*;
use shared::math::{Real, Vector};
use std::sync::Arc;
use std::time::{Duration, Instant};

// The halo's values go on the wire as the machine's words ([`Share::share`]): the wire's
// little-endian ones.
const _: () = assert!(cfg!(target_endian = "little"));

/// Words of a particle's hand-over state ([`state`]).
const STATE: usize = 3 + 3 + 1 + 1 + 3 + 1 + 3 + 3 + 1;

/// Words per particle in a hand-over: its state and its key.
const WORDS: usize = STATE + 1;

/// The cuts' measure of work is in listed fluid pairs. WCSPH's phases on this machine's core
/// (`fluid-bench --threads 1 --phases` at 10⁵ particles) give ~2.4 ns a listed pair in the
/// force pass, ~7 ns a listed wall pair in the wall particles' Adami extrapolation, and ~45 ns
/// a particle in the per-particle passes (equation of state, records, integration, survey):
/// a particle weighs as 20 pairs. A wall pair's force term costs more than a fluid pair's too:
/// on 2 ranks (`fluid-bench --ranks 2 --phases`), a weight of 4 left the rank with the tank's
/// end wall ~1 ms a step (6 %) busier, 8 the other rank; 6 is between.
const WALL_PAIR_WORK: usize = 6;

/// See [`WALL_PAIR_WORK`].
const PARTICLE_WORK: usize = 20;

/// What the halo costs, for `fluid-bench --ranks`.
#[derive(Debug, Clone, Copy, Default)]
pub struct HaloStats {
    /// Halo particles held now.
    pub halo: usize,
    /// Bytes sent since the counters were reset.
    pub bytes_sent: u64,
    /// Time spent in messages (waiting included) since the counters were reset.
    pub waiting: Duration,
    /// The work of the busiest rank over the mean, at the last sort.
    pub imbalance: f64,
    /// The compute time of the busiest rank over the mean, at the last time the cuts were
    /// judged by time (0 before).
    pub time_imbalance: f64,
    /// Times the cuts moved.
    pub rebalances: u64,
}

/// One other rank this one trades halo rates with: the owned particles it holds (`send`, local
/// indices in order) and the halo particles it owns (`receive`).
#[derive(Debug, Default)]
struct Link {
    rank: usize,
    send: Vec<u32>,
    receive: Vec<u32>,
}

/// This rank's share of the particles.
pub struct Share {
    /// The ranks, with the time spent in messages counted.
    comm: Clocked,
    /// The cut axis: the domain's longest horizontal one.
    axis: usize,
    /// The cuts: from [`Self::first_cut`] on.
    slabs: Option<Slabs>,
    /// Per grid cell: whether a fixed wall particle is in it or in a cell next to it (the 26
    /// about it), the cells of an outer halo column a rank holds ([`Self::holds`]); None with
    /// moving blocks, whose particles move between sorts: then it holds the column whole.
    near_wall: Option<Vec<bool>>,
    /// Per local particle (sorted order): whether this rank owns it.
    pub owned: Vec<bool>,
    /// Per local particle: its key (module doc).
    key: Vec<u64>,
    links: Vec<Link>,
    /// Each part's work (listed pairs plus particles; [`BINS`] parts a column) at the last
    /// sort, over all ranks.
    work: Vec<u64>,
    /// Particles on all ranks.
    pub global_len: usize,
    pub stats: HaloStats,
    /// Whether the first sort is done ([`Self::recut_at_start`]).
    started: bool,
    /// The cuts the next sort moves to, if they move.
    next: Option<Slabs>,
    /// This rank's own work at the last measure.
    my_work: u64,
    /// This rank's compute since the cuts were last judged by time.
    window: Window,
    /// The start of the step this rank is computing: the clock, and the time in messages then.
    busy_from: Option<(Instant, Duration)>,
}

/// Steps after which the cuts are judged by the ranks' compute times (at the next sort).
const WINDOW: u32 = 20;

/// A rank's compute since the cuts were last judged by time.
#[derive(Debug, Default, Clone, Copy)]
struct Window {
    /// Time in its steps outside messages.
    busy: Duration,
    /// Its work ([`Share::measure_work`]) summed over the steps.
    work: u64,
    steps: u32,
}

impl Share {
    /// The share of rank `comm.rank()` of `global_len` particles on `grid`, with the fixed
    /// wall particles at `walls` (None when blocks move: [`Self::holds`]); fails when the
    /// grid has fewer columns along the cut axis than there are ranks (the coupler refuses
    /// such a run before it starts; ranks started by hand hear it here).
    pub fn new(
        comm: Arc<dyn Comm>,
        grid: &CellGrid,
        global_len: usize,
        walls: Option<&[Vector]>,
    ) -> Result<Self, String> {
        let dims = grid.dims();
        let axis = if dims[1] > dims[0] { 1 } else { 0 };
        Slabs::balanced(axis, &vec![0; BINS * dims[axis]], comm.size())?;
        Ok(Self {
            comm: Clocked::new(comm),
            axis,
            slabs: None,
            near_wall: walls.map(|w| near_walls(grid, w)),
            owned: Vec::new(),
            key: Vec::new(),
            links: Vec::new(),
            work: Vec::new(),
            global_len,
            stats: HaloStats::default(),
            started: false,
            next: None,
            my_work: 0,
            window: Window::default(),
            busy_from: None,
        })
    }

    pub fn comm(&self) -> &dyn Comm {
        &self.comm
    }

    /// The start of this rank's part of a step (every rank's solver calls it as it starts a
    /// step's work); false if a step is started already (a nested call).
    pub fn begin_busy(&mut self) -> bool {
        if self.busy_from.is_some() {
            return false;
        }
        self.busy_from = Some((Instant::now(), self.comm.waited()));
        true
    }

    /// The end of the work [`Self::begin_busy`] began: its time outside messages counts.
    pub fn end_busy(&mut self) {
        if let Some((t, waited)) = self.busy_from.take() {
            let messages = self.comm.waited().saturating_sub(waited);
            self.window.busy += t.elapsed().saturating_sub(messages);
        }
    }

    /// After each step: the step's work counts in the window the cuts are judged by.
    pub fn step_done(&mut self) {
        self.window.work += self.my_work;
        self.window.steps += 1;
    }

    pub fn rank(&self) -> usize {
        self.comm.rank()
    }

    /// The column along the cut axis of a point.
    #[inline]
    fn column(&self, grid: &CellGrid, x: &Vector) -> usize {
        grid.coords(x)[self.axis]
    }

    /// The part of a column ([`BINS`] a column) along the cut axis of a point: the cuts fall
    /// between parts.
    #[inline]
    fn part(&self, grid: &CellGrid, x: &Vector) -> usize {
        grid.part(x, self.axis, BINS * grid.dims()[self.axis])
    }

    /// Whether rank q holds the cell of `x` under `slabs`: a cell of its inner columns
    /// ([`Slabs::inner`]), or of the outer halo columns next to a wall. The outer column is
    /// there for the wall particles of the inner one, whose Adami extrapolation reads the water
    /// within a cell of them; the rest of it no sum of q's reads (a third of the halo in the
    /// bench's tank, `fluid-bench --ranks`). Every rank answers alike for every q.
    #[inline]
    fn holds(&self, slabs: &Slabs, q: usize, grid: &CellGrid, x: &Vector) -> bool {
        let c = self.column(grid, x);
        slabs.inner(q).contains(&c)
            || (slabs.held(q).contains(&c)
                && self
                    .near_wall
                    .as_ref()
                    .is_none_or(|m| m[grid.cell_index(x)]))
    }

    /// The rank owning the point `x` (instruments read where they stand).
    pub fn owner_at(&self, grid: &CellGrid, x: &Vector) -> usize {
        let slabs = self.slabs.as_ref().expect("the first cut made the slabs");
        slabs.owner(self.part(grid, x))
    }

    /// After the first sort, once: whether the cuts should move at once (the particle counts
    /// the first cuts followed were far from the work), for the system to sort again.
    pub fn recut_at_start(&mut self) -> bool {
        !std::mem::replace(&mut self.started, true) && self.next.is_some()
    }

    /// Particles this rank owns.
    pub fn owned_count(&self) -> usize {
        self.owned.iter().filter(|&&o| o).count()
    }

    /// Before a sort: hands each particle to the ranks that hold its column now and did not
    /// hold it at the last sort (its position then: `sorted_at`, or its position now before the
    /// first sort), drops the particles whose column this rank no longer holds, and leaves the
    /// rest in key order; moves the cuts first if the last measure said so. A
    /// particle a rank kept is its owner's copy to the last bit (module doc): only what enters
    /// a rank's columns travels.
    pub fn redistribute(
        &mut self,
        p: &mut Particles,
        grid: &CellGrid,
        sorted_at: &[Vector],
    ) -> Result<(), String> {
        let t = Instant::now();
        let me = self.rank();
        let before = self.slabs.clone().expect("the first cut made the slabs");
        if let Some(next) = self.next.take() {
            self.slabs = Some(next);
            self.stats.rebalances += 1;
        }
        let after = self.slabs.as_ref().unwrap();
        let size = self.comm.size();
        let mut bundles: Vec<Vec<u8>> = vec![Vec::new(); size];
        let mut kept: Vec<u32> = Vec::with_capacity(p.len());
        for i in 0..p.len() {
            let now = &p.position[i];
            if self.holds(after, me, grid, now) {
                kept.push(i as u32);
            }
            if !self.owned[i] {
                continue;
            }
            // The rank that owned the particle at the last sort sends it where it is new.
            let then = sorted_at.get(i).unwrap_or(now);
            for (q, bundle) in bundles.iter_mut().enumerate() {
                if q != me && self.holds(after, q, grid, now) && !self.holds(&before, q, grid, then)
                {
                    encode(p, i, self.key[i], bundle);
                }
            }
        }
        let out: Vec<(usize, Vec<u8>)> = bundles
            .into_iter()
            .enumerate()
            .filter(|(q, _)| *q != me)
            .collect();
        self.stats.bytes_sent += out.iter().map(|(_, b)| b.len() as u64).sum::<u64>();
        let received = self.comm.exchange(out);
        let arrived: Vec<&[u8]> = received
            .iter()
            .flat_map(|b| b.chunks_exact(8 * WORDS))
            .collect();
        if arrived.is_empty() && kept.len() == p.len() {
            // Nothing came or went: the particles are in key order already.
        } else {
            // This rank's particles, kept and arrived, in key order: `Ok` a kept particle's
            // index, `Err` an arrived one's words.
            let mut items: Vec<(u64, Result<u32, &[u8]>)> = kept
                .iter()
                .map(|&i| (self.key[i as usize], Ok(i)))
                .chain(arrived.iter().map(|c| {
                    let key = u64::from_le_bytes(c[8 * (WORDS - 1)..].try_into().unwrap());
                    (key, Err(*c))
                }))
                .collect();
            items.par_sort_unstable_by_key(|(k, _)| *k);
            let mut q = Particles::new(vec![Vector::zeros(); items.len()], vec![0.0; items.len()]);
            let mut w = [0.0; STATE];
            for (k, (_, from)) in items.iter().enumerate() {
                match from {
                    Ok(i) => set_state(&mut q, k, &state(p, *i as usize)),
                    Err(c) => {
                        for (v, f) in w.iter_mut().zip(wire::f64s(c)) {
                            *v = f;
                        }
                        set_state(&mut q, k, &w);
                    }
                }
            }
            *p = q;
            self.key = items.iter().map(|(k, _)| *k).collect();
        }
        let own = after.owned(me);
        self.owned = p
            .position
            .iter()
            .map(|x| own.contains(&self.part(grid, x)))
            .collect();
        self.stats.waiting += t.elapsed();
        Ok(())
    }

    /// After the sort: the keys and ownership follow the permutation `order` (slot k took
    /// particle `order[k]`); the new keys are (cell, index in cell) at the sorted positions;
    /// the links of the halo are listed anew.
    pub fn after_sort(&mut self, order: &[u32], grid: &CellGrid, sorted_at: &[Vector]) {
        let me = self.rank();
        let owned: Vec<bool> = order.iter().map(|&o| self.owned[o as usize]).collect();
        self.owned = owned;
        self.key = sorted_at
            .par_iter()
            .enumerate()
            .map(|(k, x)| {
                let c = grid.cell_index(x);
                ((c as u64) << 32) | (k - grid.cell_range(c).start) as u64
            })
            .collect();
        let slabs = self.slabs.as_ref().unwrap();
        self.links.clear();
        for q in (0..self.comm.size()).filter(|&q| q != me) {
            let own = slabs.owned(q);
            let mut link = Link {
                rank: q,
                ..Link::default()
            };
            for (k, x) in sorted_at.iter().enumerate() {
                if self.owned[k] && self.holds(slabs, q, grid, x) {
                    link.send.push(k as u32);
                } else if !self.owned[k] && own.contains(&self.part(grid, x)) {
                    link.receive.push(k as u32);
                }
            }
            if !link.send.is_empty() || !link.receive.is_empty() {
                self.links.push(link);
            }
        }
        self.stats.halo = self.owned.iter().filter(|&&o| !o).count();
    }

    /// Measures each part's work from the lists just built (a particle's listed fluid and
    /// wall pairs, weighed, plus [`PARTICLE_WORK`]) and sums it over the ranks, and decides
    /// whether the next sort moves the cuts: at the first sort when the work is unbalanced
    /// past [`REBALANCE`] (the first cuts followed the particle counts); later, every
    /// [`WINDOW`] steps, by the ranks' compute times ([`Slabs::retimed`]). The
    /// measure's weights are one machine's and one method's, and a rank's cost also depends on
    /// its walls, its cache and what else runs on its core: the new cuts weigh each rank's
    /// parts by the time a unit of its work took. The outputs are the same bits on any cuts.
    pub fn measure_work(
        &mut self,
        lists: &NeighborLists,
        walls: &Boundary,
        grid: &CellGrid,
        sorted_at: &[Vector],
    ) -> Result<(), String> {
        let t = Instant::now();
        let parts = BINS * grid.dims()[self.axis];
        self.work.clear();
        self.work.resize(parts, 0);
        for (k, x) in sorted_at.iter().enumerate() {
            if self.owned[k] {
                let b = self.part(grid, x);
                self.work[b] += (lists.of(k).len()
                    + WALL_PAIR_WORK * walls.fixed_listed(k)
                    + PARTICLE_WORK) as u64;
            }
        }
        self.my_work = self.work.iter().sum();
        // Every rank counts the same steps: they judge together. The ranks' times and work
        // ride in the same sum, each in its own slot.
        let (size, me) = (self.comm.size(), self.rank());
        let judge = self.started && self.window.steps >= WINDOW;
        if judge {
            self.work.resize(parts + 2 * size, 0);
            self.work[parts + me] = self.window.busy.as_nanos() as u64;
            self.work[parts + size + me] = self.window.work;
        }
        self.comm.sum(&mut self.work);
        let timing = self.work.split_off(parts);
        let slabs = self.slabs.as_ref().unwrap();
        self.stats.imbalance = slabs.imbalance(&self.work);
        self.next = None;
        if !self.started && self.stats.imbalance > REBALANCE {
            self.next = Some(Slabs::balanced(self.axis, &self.work, size)?);
        } else if judge {
            self.window = Window::default();
            let (busy, done) = timing.split_at(size);
            if let Some((imbalance, cut)) = slabs.retimed(&self.work, busy, done)? {
                self.stats.time_imbalance = imbalance;
                self.next = cut;
            }
        }
        self.stats.waiting += t.elapsed();
        Ok(())
    }

    /// Sends N values of each owned particle other ranks hold (`get(i)` of local particle i)
    /// and returns those of the halo from their owners, as (local index, values): after every
    /// pass that computed per-particle values for the owned particles only.
    pub fn share<const N: usize>(
        &mut self,
        get: impl Fn(usize) -> [Real; N],
    ) -> Vec<(u32, [Real; N])> {
        self.post(get);
        let mut halo = Vec::with_capacity(self.stats.halo);
        self.take(|k, v| halo.push((k as u32, v)));
        halo
    }

    /// The first half of [`Self::share`]: sends each link's values and returns at once.
    fn post<const N: usize>(&mut self, get: impl Fn(usize) -> [Real; N]) {
        let t = Instant::now();
        for l in &self.links {
            let mut b = Vec::with_capacity(8 * N * l.send.len());
            for &k in &l.send {
                // The wire's little-endian words are the machine's (`wire`).
                b.extend_from_slice(bytemuck::cast_slice(&get(k as usize)));
            }
            self.stats.bytes_sent += b.len() as u64;
            self.comm.send(l.rank, b);
        }
        self.stats.waiting += t.elapsed();
    }

    /// The second half of [`Self::share`]: the halo's values from their owners, each handed
    /// to `set(local index, values)`.
    fn take<const N: usize>(&mut self, mut set: impl FnMut(usize, [Real; N])) {
        let t = Instant::now();
        for l in &self.links {
            let bytes = self.comm.receive(l.rank);
            assert_eq!(
                bytes.len(),
                8 * N * l.receive.len(),
                "rank {} sent the values of another halo: the ranks disagree on the cuts",
                l.rank
            );
            // A particle's record read whole: the machine's words are the wire's (`wire`).
            for (c, &k) in bytes.chunks_exact(8 * N).zip(&l.receive) {
                set(k as usize, bytemuck::pod_read_unaligned(c));
            }
        }
        self.stats.waiting += t.elapsed();
    }

    /// [`Self::share`] of the rates (acceleration, dρ/dt): after every evaluation of them.
    pub fn share_rates(&mut self, acceleration: &mut [Vector], density_rate: &mut [Real]) {
        self.post(|k| {
            let a = acceleration[k];
            [a.x, a.y, a.z, density_rate[k]]
        });
        self.take(|k, [x, y, z, d]| {
            acceleration[k] = Vector::new(x, y, z);
            density_rate[k] = d;
        });
    }

    /// The owned particles of every rank on rank 0, in one-rank order: `fields(i)` are particle
    /// i's values (the same number for every particle). None on the other ranks.
    ///
    /// Each rank's owned particles are in key order (a rank's particles are the one-rank order
    /// restricted to it), so rank 0 merges the pieces by key as they came, without a sort and
    /// without a keyed copy of the whole water; the other ranks encode theirs straight into
    /// the message.
    pub fn gather<const N: usize>(
        &self,
        fields: impl Fn(usize) -> [Real; N],
    ) -> Option<Vec<[Real; N]>> {
        let item = 8 * (N + 1);
        let mut bytes = Vec::with_capacity(item * self.owned_count());
        for i in (0..self.owned.len()).filter(|&i| self.owned[i]) {
            wire::put_u64(&mut bytes, [self.key[i]]);
            wire::put_f64(&mut bytes, fields(i));
        }
        let all = self.comm.gather(bytes);
        if self.rank() != 0 {
            return None;
        }
        let key = |piece: &[u8], k: usize| {
            u64::from_le_bytes(piece[k * item..k * item + 8].try_into().unwrap())
        };
        let mut heads: std::collections::BinaryHeap<std::cmp::Reverse<(u64, usize)>> = all
            .iter()
            .enumerate()
            .filter(|(_, b)| !b.is_empty())
            .map(|(r, b)| std::cmp::Reverse((key(b, 0), r)))
            .collect();
        let mut next = vec![0usize; all.len()];
        let mut out = Vec::with_capacity(all.iter().map(|b| b.len() / item).sum());
        while let Some(std::cmp::Reverse((k, r))) = heads.pop() {
            let (piece, at) = (&all[r], next[r]);
            // The record read whole, as the halo's (`take`).
            out.push(bytemuck::pod_read_unaligned(
                &piece[at * item + 8..(at + 1) * item],
            ));
            next[r] += 1;
            if next[r] * item < piece.len() {
                let following = key(piece, next[r]);
                assert!(
                    following > k,
                    "rank {r}'s particles are not in key order: the ranks' order is broken"
                );
                heads.push(std::cmp::Reverse((following, r)));
            }
        }
        Some(out)
    }

    /// Items from every rank on rank 0, sorted by their keys (each key given by one rank): the
    /// terms of a sum rank 0 then adds in one-rank order. None on the other ranks.
    pub fn gather_items<const N: usize>(
        &self,
        items: &[(u64, [Real; N])],
    ) -> Option<Vec<(u64, [Real; N])>> {
        let mut bytes = Vec::with_capacity(8 * (N + 1) * items.len());
        for (k, v) in items {
            wire::put_u64(&mut bytes, [*k]);
            wire::put_f64(&mut bytes, v.iter().copied());
        }
        let all = self.comm.gather(bytes);
        if self.rank() != 0 {
            return None;
        }
        let mut got: Vec<(u64, [Real; N])> = all
            .iter()
            .flat_map(|b| b.chunks_exact(8 * (N + 1)))
            .map(|c| {
                let mut w = wire::words(c);
                let key = u64::from_le_bytes(w.next().unwrap());
                let mut v = [0.0; N];
                for (v, b) in v.iter_mut().zip(w) {
                    *v = f64::from_le_bytes(b);
                }
                (key, v)
            })
            .collect();
        got.par_sort_unstable_by_key(|(k, _)| *k);
        Some(got)
    }

    /// The key of local particle i (its place in one-rank order at the last sort).
    pub fn key(&self, i: usize) -> u64 {
        self.key[i]
    }

    /// Whether this rank owns the point `x` (a moving block's boundary particle: its
    /// neighbourhood is whole here).
    pub fn owns(&self, grid: &CellGrid, x: &Vector) -> bool {
        self.owner_at(grid, x) == self.rank()
    }

    /// Every particle on rank 0, in one-rank order, with the positions at the last sort (for a
    /// checkpoint); None on the other ranks.
    pub fn gather_particles(
        &self,
        p: &Particles,
        sorted_at: &[Vector],
    ) -> Option<(Particles, Vec<Vector>)> {
        // The hand-over state, then the Eq. 22 force and the position at the last sort.
        let all = self.gather(|i| {
            let mut w = [0.0; STATE + 6];
            w[..STATE].copy_from_slice(&state(p, i));
            w[STATE..STATE + 3].copy_from_slice(p.penalty[i].as_slice());
            w[STATE + 3..].copy_from_slice(sorted_at[i].as_slice());
            w
        })?;
        let n = all.len();
        let mut q = Particles::new(vec![Vector::zeros(); n], vec![0.0; n]);
        let mut at = vec![Vector::zeros(); n];
        for (i, w) in all.iter().enumerate() {
            set_state(&mut q, i, &w[..STATE]);
            q.penalty[i] = Vector::from_column_slice(&w[STATE..STATE + 3]);
            at[i] = Vector::from_column_slice(&w[STATE + 3..]);
        }
        Some((q, at))
    }

    /// `items` on rank 0 with each entry k taken from rank `owners[k]` (items that serde
    /// encodes: the probes' running averages); None on the other ranks.
    pub fn merge_encoded<T: serde::Serialize + serde::de::DeserializeOwned>(
        &self,
        items: &[T],
        owners: &[usize],
    ) -> Option<Vec<T>> {
        let config = bincode::config::standard();
        let bytes = bincode::serde::encode_to_vec(items, config).expect("items encode");
        let all = self.comm.gather(bytes);
        if self.rank() != 0 {
            return None;
        }
        let decoded: Vec<Vec<T>> = all
            .iter()
            .map(|b| {
                bincode::serde::decode_from_slice(b, config)
                    .expect("a rank's items decode")
                    .0
            })
            .collect();
        let mut per_rank: Vec<_> = decoded.into_iter().map(|v| v.into_iter()).collect();
        let mut out = Vec::with_capacity(items.len());
        for &owner in owners {
            for (r, it) in per_rank.iter_mut().enumerate() {
                let item = it.next().expect("every rank has every item");
                if r == owner {
                    out.push(item);
                }
            }
        }
        Some(out)
    }

    /// Before the particles exist here (every rank has the whole water, `positions` in
    /// one-rank order: the fill's, or a checkpoint's): cuts the slabs from the particle counts
    /// and returns the indices of the particles this rank holds (its slab and halo), in order.
    /// Only those become particles on this rank; their indices are their keys until the first
    /// sort (module doc), which is then the one-rank sort restricted to them.
    pub fn first_cut(
        &mut self,
        grid: &CellGrid,
        positions: &[Vector],
    ) -> Result<Vec<usize>, String> {
        let mut counts = vec![0u64; BINS * grid.dims()[self.axis]];
        for x in positions {
            counts[self.part(grid, x)] += 1;
        }
        let slabs = Slabs::balanced(self.axis, &counts, self.comm.size())?;
        let me = self.rank();
        let own = slabs.owned(me);
        let keep: Vec<usize> = (0..positions.len())
            .filter(|&i| self.holds(&slabs, me, grid, &positions[i]))
            .collect();
        self.key = keep.iter().map(|&i| i as u64).collect();
        self.owned = keep
            .iter()
            .map(|&i| own.contains(&self.part(grid, &positions[i])))
            .collect();
        self.slabs = Some(slabs);
        Ok(keep)
    }

    /// After a restore (every rank holds the whole state, in the order of the last sort):
    /// keeps this rank's slab and halo by the positions at that sort, as the first cut does,
    /// to be listed anew (the sort of a sorted set is the identity).
    pub fn restore(&mut self, p: &mut Particles, sorted_at: &mut Vec<Vector>, grid: &CellGrid) {
        let keep = self
            .first_cut(grid, sorted_at)
            .expect("the slabs fit the grid (checked at set-up)");
        let mut q = Particles::new(vec![Vector::zeros(); keep.len()], vec![0.0; keep.len()]);
        for (k, &i) in keep.iter().enumerate() {
            set_state(&mut q, k, &state(p, i));
            q.penalty[k] = p.penalty[i];
        }
        *p = q;
        *sorted_at = keep.iter().map(|&i| sorted_at[i]).collect();
        self.started = true;
        self.window = Window::default();
    }

    /// Fills each entry of `row` (on rank 0) with the value its owner computed: `owners[k]` is
    /// the rank owning entry k. Every rank passes its own row.
    pub fn merge(&self, row: &mut [Real], owners: &[usize]) {
        let mut bytes = Vec::with_capacity(8 * row.len());
        wire::put_f64(&mut bytes, row.iter().copied());
        let all = self.comm.gather(bytes);
        if self.rank() == 0 {
            for (k, v) in row.iter_mut().enumerate() {
                *v = wire::f64s(&all[owners[k]]).nth(k).unwrap();
            }
        }
    }

    /// Once the ranks know that some rank failed (every rank calls it): rank 0 gets the lowest
    /// failing rank's message, named by rank; the others a message saying rank 0 reports it.
    pub fn name_failure(&self, failure: Option<String>) -> String {
        let all = self.comm.gather(failure.unwrap_or_default().into_bytes());
        if self.rank() != 0 {
            return "another rank failed; rank 0 reports why".into();
        }
        all.iter()
            .enumerate()
            .find(|(_, m)| !m.is_empty())
            .map_or("a rank failed".into(), |(r, m)| {
                format!("rank {r}: {}", String::from_utf8_lossy(m))
            })
    }
}

/// Per cell of `grid`: whether one of the wall particles at `walls` lies in it or in one of
/// the 26 cells about it (a wall particle off the grid counts in the cell it is clamped to,
/// whose neighbours still hold all the water within a cell of it).
fn near_walls(grid: &CellGrid, walls: &[Vector]) -> Vec<bool> {
    let mut walled = vec![false; grid.cell_count()];
    for x in walls {
        walled[grid.cell_index(x)] = true;
    }
    let d = grid.dims();
    let mut near = vec![false; walled.len()];
    for k in 0..d[2] {
        for j in 0..d[1] {
            for i in 0..d[0] {
                if !walled[grid.index([i, j, k])] {
                    continue;
                }
                let span = |c: usize, n: usize| c.saturating_sub(1)..(c + 2).min(n);
                for kk in span(k, d[2]) {
                    for jj in span(j, d[1]) {
                        for ii in span(i, d[0]) {
                            near[grid.index([ii, jj, kk])] = true;
                        }
                    }
                }
            }
        }
    }
    near
}

/// Particle i's hand-over state: position, velocity, density, pressure, acceleration, dρ/dt,
/// and the three one-step-back arrays ([`STATE`] words).
fn state(p: &Particles, i: usize) -> [Real; STATE] {
    let mut w = [0.0; STATE];
    let vectors = [
        (0, &p.position[i]),
        (3, &p.velocity[i]),
        (8, &p.acceleration[i]),
        (12, &p.position0[i]),
        (15, &p.velocity0[i]),
    ];
    for (k, v) in vectors {
        w[k..k + 3].copy_from_slice(v.as_slice());
    }
    (w[6], w[7], w[11], w[18]) = (
        p.density[i],
        p.pressure[i],
        p.density_rate[i],
        p.density0[i],
    );
    w
}

/// Sets particle i of `q` from its hand-over state ([`state`]).
fn set_state(q: &mut Particles, i: usize, w: &[Real]) {
    let v3 = |k: usize| Vector::from_column_slice(&w[k..k + 3]);
    (q.position[i], q.velocity[i], q.acceleration[i]) = (v3(0), v3(3), v3(8));
    (q.position0[i], q.velocity0[i]) = (v3(12), v3(15));
    (
        q.density[i],
        q.pressure[i],
        q.density_rate[i],
        q.density0[i],
    ) = (w[6], w[7], w[11], w[18]);
}

/// Appends particle i's hand-over state and its key to `out`.
fn encode(p: &Particles, i: usize, key: u64, out: &mut Vec<u8>) {
    wire::put_f64(out, state(p, i));
    wire::put_u64(out, [key]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cells an outer halo column keeps: a wall particle's cell and the 26 about it; a
    /// wall particle off the grid counts in the cell it is clamped to.
    #[test]
    fn the_cells_near_a_wall_are_its_own_and_the_26_about_it() {
        // A unit box in cells of 0.25 m, one cell of padding on each side: 6 a side.
        let grid = CellGrid::new(Vector::zeros(), Vector::repeat(1.0), 0.25).unwrap();
        assert_eq!(grid.dims(), [6, 6, 6]);
        let marked = |walls: &[Vector]| -> Vec<[usize; 3]> {
            let near = near_walls(&grid, walls);
            let mut cells = Vec::new();
            for k in 0..6 {
                for j in 0..6 {
                    for i in 0..6 {
                        if near[grid.index([i, j, k])] {
                            cells.push([i, j, k]);
                        }
                    }
                }
            }
            cells
        };
        // In cell (2, 3, 1): 27 cells, all within one of it.
        let at = Vector::new(0.4, 0.6, 0.1);
        assert_eq!(grid.coords(&at), [2, 3, 1]);
        let cells = marked(&[at]);
        assert_eq!(cells.len(), 27);
        assert!(cells.iter().all(|c| {
            (c[0] as i64 - 2).abs() <= 1 && (c[1] as i64 - 3).abs() <= 1 && c[2] <= 2
        }));
        // Far below the grid: clamped to the bottom layer, whose cells and the layer above
        // are marked (3 × 3 × 2).
        let cells = marked(&[Vector::new(0.4, 0.6, -2.0)]);
        assert_eq!(cells.len(), 18);
        assert!(cells.iter().all(|c| c[2] <= 1));
        assert!(marked(&[]).is_empty());
    }
}
