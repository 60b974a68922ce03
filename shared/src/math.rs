//! The scalar and vector types of the whole project, fixed in one place (as salva and rapier do).

/// Every physical quantity is computed in double precision: SPH pressure sums and DDA contact
/// springs both lose too much in `f32` over the millions of steps a run takes.
pub type Real = f64;
pub type Vector = nalgebra::Vector3<Real>;
pub type Point = nalgebra::Point3<Real>;
pub type Matrix = nalgebra::Matrix3<Real>;
pub type Rotation = nalgebra::UnitQuaternion<Real>;
pub type Isometry = nalgebra::Isometry3<Real>;
/// A rigid block's six velocities or loads, (linear, angular).
pub type Vector6 = nalgebra::SVector<Real, 6>;
/// A map between them (a block's mobility).
pub type Matrix6 = nalgebra::SMatrix<Real, 6, 6>;

/// Standard gravity [m/s²], the default of every scene.
pub const STANDARD_GRAVITY: Real = 9.81;
