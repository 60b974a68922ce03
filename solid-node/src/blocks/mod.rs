//! The blocks themselves, before any contact:
//!
//! - [`block`]: a block's shape, mass properties, pose and world geometry;
//! - [`elastic`]: the strain state and matrices of a deformable block (Shi's constant strain,
//!   co-rotational);
//! - [`rotation`]: exact rotation updates (no growth of rotating blocks).

pub mod block;
pub mod elastic;
pub mod rotation;
