//! The wire protocol: `#[repr(C)]` types sent through iceoryx2 shared memory without copying.
//!
//! The same types cross the network as their bytes (the zenoh transport): each is
//! [`bytemuck::Pod`], which the derive checks at compile time (no padding, no pointers, every
//! bit pattern valid), so a message is its header's bytes followed by its payload's, in the
//! hosts' byte order (little-endian on every platform rockwave builds for).
//!
//! Hot-path messages (geometry, loads, commands, status) are fixed-layout types and slices of
//! them; the scene itself travels once, at start-up, as bincode bytes. Any change to a layout
//! here must bump [`PROTOCOL_VERSION`]: the handshake refuses a node that speaks another one.

use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::ZeroCopySend;

/// Version of every layout in this module. Checked at the handshake. 3: the checkpoint command
/// and its answer, and a setup that may resume from a checkpoint. 4: a block's inertia and the
/// rest of its forces in [`BlockState`], for a fluid that moves the blocks in its pressure solve.
/// 5: the block's measured response over the coming step ([`BlockState::free_acceleration`],
/// [`BlockState::mobility`]), and [`LoadsHeader::FOLLOWED`]. 6: [`Status::message`] holds
/// 2 048 bytes (512 cut the solid's energy watch before its conclusion).
pub const PROTOCOL_VERSION: u32 = 6;

/// Which side of the coupling a node plays.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Role {
    Fluid = 1,
    Solid = 2,
}

impl Role {
    pub fn name(self) -> &'static str {
        match self {
            Role::Fluid => "fluid",
            Role::Solid => "solid",
        }
    }
    pub fn from_u32(v: u32) -> Option<Role> {
        match v {
            1 => Some(Role::Fluid),
            2 => Some(Role::Solid),
            _ => None,
        }
    }
}

/// Fixed-capacity UTF-8 text for names and messages inside `#[repr(C)]` messages.
#[repr(C)]
#[derive(Clone, Copy, ZeroCopySend)]
pub struct Text<const N: usize> {
    len: u32,
    bytes: [u8; N],
}

// SAFETY: `Text<N>` is `#[repr(C)]` of a u32 and N bytes: no padding when N is a multiple of
// 4 (asserted at compile time for the sizes used), no pointers, every bit pattern valid
// (`as_str` checks the length and the UTF-8).
unsafe impl<const N: usize> Zeroable for Text<N> {}
unsafe impl Pod for Text<64> {}
unsafe impl Pod for Text<MESSAGE_BYTES> {}
const _: () = assert!(
    size_of::<Text<64>>() == 4 + 64 && size_of::<Text<MESSAGE_BYTES>>() == 4 + MESSAGE_BYTES
);

/// Capacity of a node's status message: the longest the nodes write (the solid's energy watch
/// naming the contact that holds the energy and what that means, ~700 bytes) with room to spare.
pub const MESSAGE_BYTES: usize = 2048;

impl<const N: usize> Text<N> {
    /// Stores `s`; if it does not fit, cut at a character boundary and ended with "…", so a
    /// reader sees that something is missing.
    pub fn new(s: &str) -> Self {
        const MORE: &str = "…";
        let mut bytes = [0u8; N];
        let end = if s.len() <= N {
            s.len()
        } else {
            let mut end = N.saturating_sub(MORE.len());
            while !s.is_char_boundary(end) {
                end -= 1;
            }
            end
        };
        bytes[..end].copy_from_slice(&s.as_bytes()[..end]);
        let mut len = end;
        if end < s.len() && N >= MORE.len() {
            bytes[end..end + MORE.len()].copy_from_slice(MORE.as_bytes());
            len += MORE.len();
        }
        Self {
            len: len as u32,
            bytes,
        }
    }
    pub fn as_str(&self) -> &str {
        let n = (self.len as usize).min(N);
        std::str::from_utf8(&self.bytes[..n]).unwrap_or("<invalid utf-8>")
    }
}

impl<const N: usize> Default for Text<N> {
    fn default() -> Self {
        Self::new("")
    }
}

impl<const N: usize> std::fmt::Debug for Text<N> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

/// Node → coupler, once: who I am and which protocol I speak.
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend, Pod, Zeroable)]
pub struct Hello {
    pub protocol_version: u32,
    /// [`Role`] as u32.
    pub role: u32,
    pub pid: u32,
    pub solver: Text<64>,
}

/// Header of the coupler → node start message; the payload is the bincode-encoded [`Setup`].
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, ZeroCopySend, Pod, Zeroable)]
pub struct SetupHeader {
    pub protocol_version: u32,
    pub payload_len: u32,
}

/// What a node needs to start, sent once after the handshake (bincode, variable size).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Setup {
    /// The scene as run, as TOML text: the scene's tagged enums need a self-describing format,
    /// which bincode is not. Parsed (and validated again) by [`Setup::scene`].
    pub scene_toml: String,
    /// Directory the node writes its output files into.
    pub run_dir: std::path::PathBuf,
    pub scheme: crate::scene::CouplingScheme,
    /// Whether the other solver runs (a dry scene has no fluid node, a scene without moving
    /// blocks no solid node).
    pub fluid_present: bool,
    pub solid_present: bool,
    /// Solver each node must build (the coupler resolved command line and scene).
    pub fluid_solver: String,
    pub solid_solver: String,
    /// Process id of the coupler: a node whose coupler died stops at once.
    pub coupler_pid: u32,
    /// Continue from a checkpoint instead of the scene's initial state.
    pub resume: Option<Resume>,
}

/// Where a resumed node starts: the checkpoint it wrote after `step` steps (at `time`), which
/// is its [`crate::checkpoint::node_file`] in the run directory.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Resume {
    pub step: u64,
    pub time: f64,
}

impl Setup {
    /// The scene of this run.
    pub fn scene(&self) -> Result<crate::scene::Scene, String> {
        crate::scene::Scene::parse(&self.scene_toml, "setup message").map_err(|e| e.to_string())
    }
    /// Encodes for the setup message (bincode, standard configuration).
    pub fn encode(&self) -> Vec<u8> {
        bincode::serde::encode_to_vec(self, bincode::config::standard())
            .expect("a setup always encodes")
    }
    /// Decodes a setup message.
    pub fn decode(bytes: &[u8]) -> Result<Setup, String> {
        bincode::serde::decode_from_slice(bytes, bincode::config::standard())
            .map(|(s, _)| s)
            .map_err(|e| format!("undecodable setup message: {e}"))
    }
}

/// What the coupler asks of a node.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandKind {
    /// Advance by `dt` from `time`.
    Advance = 1,
    /// Finish (flush outputs) and exit.
    Stop = 2,
    /// Write a checkpoint of the state after `step` steps (at `time`) into the run directory's
    /// `checkpoints/` and answer [`StatusCode::Checkpointed`].
    Checkpoint = 3,
}

/// Coupler → node, every step.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, ZeroCopySend, Pod, Zeroable)]
pub struct Command {
    /// [`CommandKind`] as u32.
    pub kind: u32,
    /// Write an output frame after this step: the frame number, or -1 for none.
    pub output_frame: i32,
    pub step: u64,
    /// Time at the start of the step.
    pub time: f64,
    /// The one step both nodes take.
    pub dt: f64,
}

/// How a node's step ended.
#[repr(u32)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StatusCode {
    /// Initialised (answer to the setup), or a step done.
    Ok = 0,
    /// Step done, with a warning in `message` (e.g. too much compression).
    Warning = 1,
    /// The method went unstable; `message` names the limit exceeded. The run must stop.
    Unstable = 2,
    /// Any other failure (bad setup, I/O). The run must stop.
    Failed = 3,
    /// Answer to [`CommandKind::Stop`]: outputs flushed, exiting.
    Stopped = 4,
    /// Answer to [`CommandKind::Checkpoint`]: the node's checkpoint file is on disk.
    Checkpointed = 5,
}

impl StatusCode {
    pub fn from_u32(v: u32) -> StatusCode {
        match v {
            0 => StatusCode::Ok,
            1 => StatusCode::Warning,
            2 => StatusCode::Unstable,
            4 => StatusCode::Stopped,
            5 => StatusCode::Checkpointed,
            _ => StatusCode::Failed,
        }
    }
}

/// Node → coupler after each command.
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend, Pod, Zeroable)]
pub struct Status {
    pub role: u32,
    /// [`StatusCode`] as u32.
    pub code: u32,
    pub step: u64,
    /// Time reached.
    pub time: f64,
    /// Stable step proposed for the next advance.
    pub dt_proposal: f64,
    /// Seconds of wall time this node spent computing (not waiting) in the step.
    pub compute_seconds: f64,
    /// CPU seconds this node's process has used so far (user + system): with
    /// `compute_seconds` it shows what waiting costs (nothing, when nobody spins).
    pub cpu_seconds: f64,
    pub message: Text<MESSAGE_BYTES>,
    /// Explicit padding to the 8-byte alignment (the layout is what it always was; named so
    /// that the message has no uninitialised bytes to send).
    pub _reserved: u32,
}

/// Header of a geometry message (solid → fluid): when it is valid.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, ZeroCopySend, Pod, Zeroable)]
pub struct GeometryHeader {
    pub step: u64,
    pub time: f64,
    pub vertex_count: u32,
    pub _reserved: u32,
}

/// Pose and velocity of one moving block (payload of a geometry message, one per block in
/// [`crate::scene::Scene::moving_blocks`] order).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
pub struct BlockState {
    /// Index of the block in the scene's `[[block]]` list.
    pub block: u32,
    /// Range of this block's corners in the vertex message.
    pub first_vertex: u32,
    pub vertex_count: u32,
    /// [`BlockState::DEFORMABLE`] when the block is a 12-DOF deformable DDA block.
    pub flags: u32,
    /// Centroid position [m].
    pub centroid: [f64; 3],
    /// Unit quaternion, in nalgebra's coordinate order [i, j, k, w].
    pub orientation: [f64; 4],
    /// Centroid velocity [m/s].
    pub velocity: [f64; 3],
    /// Angular velocity [rad/s].
    pub angular_velocity: [f64; 3],
    /// Constant strain (εx, εy, εz, γyz, γzx, γxy) in the block frame (see [`crate::geometry::strain`]);
    /// zero for rigid blocks.
    pub strain: [f64; 6],
    /// Its rate [1/s].
    pub strain_rate: [f64; 6],
    /// 1/m [1/kg]; zero for a kinematic block (its motion is prescribed: infinite mass).
    pub inverse_mass: f64,
    /// World-frame inverse inertia tensor about the centroid, (xx, yy, zz, yz, zx, xy)
    /// [1/(kg m²)]; zero for a kinematic block.
    pub inverse_inertia: [f64; 6],
    /// The force on the block from everything but the water (its weight, contacts, joints)
    /// at this state [N], as the solid's last force evaluation has it. With `inverse_mass`,
    /// what a fluid needs to predict the block's motion within its own step (a solver that
    /// moves the block in its pressure solve, Gissler et al. 2019); the others ignore it.
    pub other_force: [f64; 3],
    /// The same for the torque about the centroid [N m].
    pub other_torque: [f64; 3],
    /// With [`BlockState::RESPONSE`] set (a solid that looked ahead, `LoadsHeader::FOLLOWED`),
    /// how the block answers the water over the coming coupling step, everything else
    /// included (its weight, contacts, joints, and how they change within the step), in place
    /// of `other_force` and the inverse mass: the change of its mean velocity and angular
    /// velocity over the step, (Δv, Δω) = Δt (a0 + M (F, τ)), for a water force F and torque τ
    /// (about the centroid) held over the step; the mean velocity is the displacement over the
    /// step divided by Δt. This is a0 [m/s², rad/s²].
    pub free_acceleration: [f64; 6],
    /// M of [`Self::free_acceleration`], row by row [1/kg, 1/(kg m), 1/(kg m²)].
    pub mobility: [[f64; 6]; 6],
}

impl BlockState {
    pub fn centroid(&self) -> crate::math::Point {
        crate::math::Point::from(self.centroid)
    }
    pub fn rotation(&self) -> crate::math::Rotation {
        let [i, j, k, w] = self.orientation;
        crate::math::Rotation::new_normalize(nalgebra::Quaternion::new(w, i, j, k))
    }
    pub fn velocity(&self) -> crate::math::Vector {
        crate::math::Vector::from(self.velocity)
    }
    pub fn angular_velocity(&self) -> crate::math::Vector {
        crate::math::Vector::from(self.angular_velocity)
    }
    /// [`Self::free_acceleration`] as a vector.
    pub fn free_acceleration(&self) -> crate::math::Vector6 {
        crate::math::Vector6::from_row_slice(&self.free_acceleration)
    }
    /// [`Self::mobility`] as a matrix.
    pub fn mobility(&self) -> crate::math::Matrix6 {
        crate::math::Matrix6::from_fn(|r, c| self.mobility[r][c])
    }
    /// The block's measured response over the coming step, if the solid sent one
    /// ([`Self::free_acceleration`], [`Self::mobility`]).
    pub fn response(&self) -> Option<(crate::math::Vector6, crate::math::Matrix6)> {
        (self.flags & Self::RESPONSE != 0).then(|| (self.free_acceleration(), self.mobility()))
    }
    /// Stores a measured response over the coming step ([`Self::free_acceleration`]).
    pub fn set_response(&mut self, a0: &crate::math::Vector6, m: &crate::math::Matrix6) {
        self.flags |= Self::RESPONSE;
        self.free_acceleration = (*a0).into();
        for (r, row) in self.mobility.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                *x = m[(r, c)];
            }
        }
    }
    /// Flag bit of a deformable block.
    pub const DEFORMABLE: u32 = 1;
    /// Flag bit of a block sent with its measured response ([`Self::free_acceleration`]).
    pub const RESPONSE: u32 = 2;

    pub fn is_deformable(&self) -> bool {
        self.flags & Self::DEFORMABLE != 0
    }
    pub fn strain(&self) -> crate::geometry::strain::Strain {
        crate::geometry::strain::Strain::from(self.strain)
    }
    /// The world-frame inverse inertia tensor ([`Self::inverse_inertia`]) as a matrix.
    pub fn inverse_inertia(&self) -> crate::math::Matrix {
        symmetric(&self.inverse_inertia)
    }
    /// Stores a symmetric matrix as (xx, yy, zz, yz, zx, xy).
    pub fn pack_symmetric(m: &crate::math::Matrix) -> [f64; 6] {
        [
            m[(0, 0)],
            m[(1, 1)],
            m[(2, 2)],
            m[(1, 2)],
            m[(2, 0)],
            m[(0, 1)],
        ]
    }
    /// The linear map of the block frame to the world, F = R (I + E) (R for a rigid block).
    pub fn deformation(&self) -> crate::math::Matrix {
        self.material_map().map
    }
    /// Positions and velocities of the block's material points at this state.
    pub fn material_map(&self) -> crate::geometry::strain::MaterialMap {
        let (e, e_dot) = (
            self.strain(),
            crate::geometry::strain::Strain::from(self.strain_rate),
        );
        crate::geometry::strain::MaterialMap::new(
            self.centroid().coords,
            self.rotation().to_rotation_matrix().into_inner(),
            self.velocity(),
            self.angular_velocity(),
            self.is_deformable().then_some((&e, &e_dot)),
        )
    }
    /// Velocity of the material point of the block at world position `p`: v + ω × r, plus
    /// R Ė X for a deformable block. (Builds the map: hot loops should keep a
    /// [`Self::material_map`] instead.)
    pub fn point_velocity(&self, p: &crate::math::Point) -> crate::math::Vector {
        let m = self.material_map();
        m.velocity(&m.material(&p.coords))
    }
}

/// The symmetric matrix stored as (xx, yy, zz, yz, zx, xy).
fn symmetric(s: &[f64; 6]) -> crate::math::Matrix {
    let [xx, yy, zz, yz, zx, xy] = *s;
    crate::math::Matrix::new(xx, xy, zx, xy, yy, yz, zx, yz, zz)
}

/// Header of a loads message (fluid → solid).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, ZeroCopySend, Pod, Zeroable)]
pub struct LoadsHeader {
    pub step: u64,
    pub time: f64,
    /// [`LoadsHeader::FOLLOWED`] or 0.
    pub flags: u32,
    pub _reserved: u32,
}

impl LoadsHeader {
    /// The loads are those the fluid moved the blocks with over the step it has just taken
    /// (`FluidSolver::loads_follow_step` in the parallel scheme): it moves them inside its own
    /// step and reads their response over the next one ([`BlockState::free_acceleration`]),
    /// so the solid looks ahead for it.
    pub const FOLLOWED: u32 = 1;

    pub fn followed(&self) -> bool {
        self.flags & Self::FOLLOWED != 0
    }
}

/// Force and torque (about the centroid) the water exerts on one moving block: the opposite of
/// the paper's Eq. 22 forces on the particles, summed.
#[repr(C)]
#[derive(
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    ZeroCopySend,
    Pod,
    Zeroable,
    serde::Serialize,
    serde::Deserialize,
)]
pub struct BlockLoad {
    pub block: u32,
    pub _reserved: u32,
    pub force: [f64; 3],
    pub torque: [f64; 3],
    /// Generalised force on the strain unknowns, Σ T_e(X)ᵀ Rᵀ f over the forces f at material
    /// points X ([`crate::geometry::strain::generalised_force`]); zero for rigid blocks.
    pub strain_load: [f64; 6],
}

#[cfg(test)]
impl BlockLoad {
    /// A load of `fz` newtons straight up (unit tests of what reads loads).
    pub(crate) fn vertical(fz: f64) -> Self {
        BlockLoad {
            force: [0.0, 0.0, fz],
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_text_that_does_not_fit_is_cut_at_a_character_and_says_so() {
        assert_eq!(Text::<64>::new("G1").as_str(), "G1");
        let exact = "x".repeat(64);
        assert_eq!(Text::<64>::new(&exact).as_str(), exact);
        // 'é' is two bytes: the cut falls inside one of them and moves back to its start.
        let long = "é".repeat(40);
        let cut = Text::<64>::new(&long);
        assert_eq!(cut.as_str(), format!("{}…", "é".repeat(30)));
        assert!(cut.as_str().len() <= 64);
    }
}
