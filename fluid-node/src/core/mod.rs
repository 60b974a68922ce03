//! The SPH machinery every method shares: the particles ([`particles`]), the cell grid and its
//! counting sort ([`grid`]), the neighbour lists ([`neighbors`], their branch-free test in
//! [`candidates`]), the eight-lane pair records ([`lanes`]), how finely a parallel pass is cut
//! ([`tasks`]) and its deterministic writes and sums ([`scatter`], [`exact_sum`]), the stable
//! step ([`dt`]), the water volumes filled on a lattice ([`fill`]) and the phase clock
//! ([`phases`]).

pub mod candidates;
pub mod dt;
pub mod exact_sum;
pub mod fill;
pub mod grid;
pub mod lanes;
pub mod neighbors;
pub mod particles;
pub mod phases;
pub mod scatter;
pub mod tasks;
