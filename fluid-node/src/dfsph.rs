//! Divergence-free SPH (Bender & Koschier 2015, "Divergence-free smoothed particle
//! hydrodynamics", SCA; Bender & Koschier 2017, "Divergence-free SPH for incompressible and
//! viscous fluids", IEEE TVCG 23(3)): two implicit pressure solves per step, one holding the
//! density at rest (constant-density solver, 2017 Algorithm 3) and one making the velocity field
//! divergence-free (2017 Algorithm 2), so the step is bounded by the flow speed (CFL on the
//! particle diameter), not by a numerical speed of sound.
//!
//! - Density: summed, ρ_i = Σ_j m_j W_ij over fluid and boundary particles; the
//!   boundary particles (Adami-style, filled one support deep on the water's own lattice) carry
//!   the fluid's particle mass m = ρ0·dx³, as in [`crate::muller`]. Rest density is the sum on a
//!   full lattice ([`lattice_density`]), so water at rest is at rest in the discrete sense.
//! - Kernel: Wendland C2 (Wendland 1995), h = 1.3·dx by default (support 2.6·dx).
//! - Factor α_i = ρ_i / (|Σ_j m_j ∇W_ij|² + Σ_j |m_j ∇W_ij|²) (the DFSPH factor) with the
//!   boundary neighbours in the first sum. Here the pressure variable is k_i = κ_i/ρ_i = p_i/ρ_i²,
//!   so the Jacobi diagonal is β_i = α_i/ρ_i = 1/(|G_i|² + Σ_f |m ∇W_ij|²) with
//!   G_i = m(Σ_f ∇W_ij + Σ_b ∇W_ib) (with mirrored walls, G_i·(G_i + B_i) for |G_i|²,
//!   B_i = m Σ_b ∇W_ib: below).
//! - Non-pressure forces: gravity, paper Eq. 22 (`particles.penalty / m`), and XSPH viscosity
//!   (Monaghan 1989; Schechter & Bridson 2012), v_i += ε Σ_j (m/ρ_j)(v_j − v_i) W_ij.
//! - Pressure acceleration (the κ/ρ form of both solvers): a_i = −Σ_f m (k_i + k_j) ∇W_ij
//!   − Σ_b m (k_i + k_b) ∇W_ib, where the wall's k_b is (`[fluid.dfsph] wall_pressure`):
//!   - "mirrored" (the default): k̄_i + H_ib. The wall mirrors the pressure of the water it
//!     faces (Akinci et al. 2012's pressure mirroring), taken as the Shepard mean k̄_i of the
//!     stiffness over particle i and its fluid neighbours ([`Dfsph::apply`]), inside both
//!     solves, plus the hydrostatic difference H_ib = g·(x_b − x_i)/ρ0 between the wall point and
//!     the particle (Adami et al. 2012, Eq. 27, pair by pair), held over the step. Nothing of
//!     the last step's pressure is held, so a block closing on the floor through a film of water
//!     meets that film's whole pressure within the step, from both walls (module doc, "Blocks
//!     in the solve"). The mean, not k_i itself: mirroring each particle's own k_i makes the
//!     wall push a particle by its own stiffness, which the Jacobi solve leaves noisy (a tank at
//!     rest kept particles at 1–3 m/s next to its walls); k̄_i moves with the neighbourhood, so
//!     a stiffness change on one particle leaves it balanced. The Jacobi diagonal counts k̄_i as
//!     k_i, what it is for an increment shared by the neighbourhood (a film between two walls):
//!     exact for that mode, under-relaxed for the others.
//!   - "extrapolated": k_b = p_b/ρ0², Adami's extrapolation of the last step's fluid
//!     pressures with its hydrostatic term ([`crate::boundary::Boundary::update`]), held during
//!     the solves; the implicit part is one-sided, the fluid particle's own k_i (as the 2017
//!     paper's boundary term and SPlisHSPlasH). Water at rest near walls is as quiet, but a
//!     heavy block landing through water meets last step's pressure again in the held p_b
//!     (docs/REFERENCES.md §4.1b) and is thrown back. Mirroring k_i alone, with nothing held
//!     (Akinci et al. 2012), would give a block the pressure of the water ~1 dx below its bottom:
//!     a floating block at dx = 0.02 m rode 2 cm (20 % of its draft) too high.
//!
//!   A moving block takes the reverse pair by pair ([`Dfsph::react`]).
//! - Only compression is corrected: negative density errors (free surface) and negative
//!   divergence are clamped to zero (2017 Algorithm 3 and Algorithm 2, the source terms).
//!   A particle within a support of the free surface has a deficient sum, so nothing resists
//!   gravity packing the top layers until their sums reach ρ0: the surface sinks slowly (0.07
//!   spacings in 4 s of still water with mirrored walls; 0.15 with the walls' pressure
//!   extrapolated, which lost Example 1 a quarter spacing, 2.5 cm, in its first 6 s).
//!   `continued_surface = true` (experimental, off by default) lets a particle with fewer than
//!   [`SURFACE_FRACTION`] of a full lattice's neighbours keep the larger of its sum and the ρ*
//!   the last step predicted for it (the continuity equation's density, which has no deficit):
//!   the surface then holds (−0.016 spacings), Example 1's gauges follow WCSPH's within 3 mm in
//!   deep water, and the floating block's draft error goes from −3.5 % to −2.3 %
//!   (docs/PERFORMANCE.md, docs/VALIDATION.md). Not yet the default: the validation tables
//!   have not been rerun with it.
//! - Warm start: each solve starts from half the stiffness of the last step where the particle is
//!   compressed (the papers' warm start; the ½ and the test on compression as SPlisHSPlasH).
//! - Stopping: mean compression below `density_tolerance` (0.05 %, at least two iterations) and
//!   mean (Dρ/Dt)·dt/ρ0 below `divergence_tolerance` (0.1 %, at least one), SPlisHSPlasH's
//!   defaults; with `pressure_tolerance` set, the constant-density solve also runs until its
//!   last iteration moved the pressure field by less than it, Σ|Δk|/Σ|k| (ours, off by
//!   default: see "Known limits"); at most `max_iterations` (100) each, else the step carries
//!   a warning with the error reached.
//! - Spray: a particle with fewer neighbours (fluid and boundary) than 60 % of a full lattice's
//!   is left out of the divergence solve ([`DEFICIENT_FRACTION`], SPlisHSPlasH's rule). Its
//!   factor β is large, and the solve would throw two converging droplets apart. A mean compression above 10 % after the solve stops the run as unstable
//!   (`dfsph: mean compression limit exceeded`); the densities reported are the predicted ρ*, so
//!   the system's `density_ratio_bound` check (1.3·ρ0 by default) also stops it as soon as one
//!   particle passes that bound.
//! - Step: dt = cfl·dx/v_max (the papers' CFL condition, cfl 0.4 on the particle diameter),
//!   bounded by the non-pressure force limit cfl·sqrt(dx/|a|) and the explicit limit
//!   sqrt(m/K_S) of the Eq. 22 spring. No sound speed: K_S is set from 2·sqrt(2 g H), a fifth
//!   of WCSPH's c0, so that limit stays above the CFL step.
//!
//! The loop of 2017 Algorithm 1 is run rotated by its last two steps: a step here is
//! "neighbours, ρ and α; divergence solve; non-pressure forces; predicted velocities; density
//! solve; positions", so that the state the system checks, re-sorts and samples after a step is
//! the paper's state after its position update. The densities reported are the constant-density
//! solver's prediction ρ* at the new positions; the pressures, p = (k_ρ + k_v)·ρ², what the
//! two solves applied in the step.
//!
//! Known limits:
//! - The pressure of one step is noisy. Many pressure fields meet 0.05 % mean compression; in
//!   still water 0.48 m deep at dx = 0.04 m the particle pressures scatter by 44 % of ρ0 g H
//!   about hydrostatic (2 density iterations a step), the probes at 0.25, 0.5, 0.75 H by
//!   457, 852, 1 251 Pa. `pressure_tolerance = 5` halves the probes' scatter (235, 316,
//!   416 Pa) and brings the particles' to 23 % for about a fifth more time per step; their time
//!   means are hydrostatic either way. It stays off by default because a pressure solved
//!   further also answers a block's motion more fully: in the default scene at 1 ms steps it
//!   brought the wedge's landing at the toe into the added-mass instability below (t = 1.40 s,
//!   before the watch told a heavy block's landing burst from growth), where the same run
//!   without it completes. A block's load inherits the noise:
//!   docs/VALIDATION.md.
//! - With `blocks_in_solve = false`: an incompressible fluid answers a block's motion within
//!   the same step, at any dt. A light block then meets the added-mass instability of
//!   one-step-lagged partitioned coupling (Causin, Gerbeau & Nobile 2005), which no smaller
//!   step cures, and the watch stops the run (`shared::added_mass`); a heavy block closing on
//!   a wall through water (the sinking block landing, the wedge reaching the toe of its slope)
//!   meets it while the squeezed film lasts: a burst of the loads, which the watch names as a
//!   warning (the block's motion over it is unreliable) and stops only past 1 000 weights per
//!   step. The default moves the blocks in the solve instead (below).
//!
//! Blocks in the solve (`blocks_in_solve`, default true; Gissler et al. 2019 couple rigid
//! bodies into the pressure solve the same way, here with the body's dynamics left to the
//! solid node): every stiffness the two solves apply to the water also pushes the free
//! blocks' boundary particles, the reverse pair by pair, and moves each block by
//! Δv = Δt F/m, Δω = Δt I⁻¹τ ([`Dfsph::move_blocks`]); between the solves the block also
//! takes its non-pressure part, the walls' held pressure, Eq. 22 and the rest of its forces
//! (weight, contacts: `BlockState::other_force`, from the solid's last evaluation). The
//! boundary's velocity in the continuity equation follows, so the water near a block sees it
//! give way within the step, and the pressure the solve settles on is that of water and block
//! moving together. The loads sent are the forces the block was moved with over the step
//! (`loads_follow_step`: in the parallel scheme the solid waits for the fluid's step and then
//! moves the block as the fluid predicted). What the prediction misses of the solid's other
//! forces (contacts changing within the step, δR) returns next step as a velocity mismatch
//! Δt δR/m between block and water, which that step's solve shares out by the masses: in open
//! water it does not feed on itself, where the lagged scheme multiplies the block's
//! acceleration by −M_A/m each step (docs/REFERENCES.md §4.1b). Against a layer of water the
//! solve holds as stiffly as a contact it does, and what the layer's pressure is matters: with
//! the walls' pressure extrapolated from the last step, the held part repeats that step's
//! divergence impulse, which the one-sided solve cannot take back, and heavy blocks landing
//! fast were thrown back (with the central difference's half-step velocity, ×1.44 per step);
//! with mirrored walls the film's pressure is all in the solve (§4.1b). Two details keep the
//! solve itself sound: a very light block joins it as a large rank-six term, so the increments
//! next to a block are damped ([`Dfsph::block_damping`]); and a solve runs until the free
//! blocks' loads have settled ([`BLOCK_TOLERANCE`]). Measured: the sinking block
//! (ρ_b/ρ_w = 2.5) lands and rests as under WCSPH, the light block (0.1) floats unrelaxed, the
//! default scene's wedge lands at the toe at 10 ms steps, and with mirrored walls the heavier,
//! faster landings too (ρ_b/ρ_w = 2 and 3 in the floating-block tank, Example 3's block,
//! docs/stability.md). Cost: two passes over the moving boundary per iteration, nothing
//! measurable on the default scene (docs/PERFORMANCE.md).
//!
//! Speed: the kernel gradients and values of a step's fluid pairs are computed once, in f32,
//! and streamed by every later pass (the `pairs` field), which made a step 1.7× faster.
//!
//! State across steps: the per-particle warm-start stiffnesses must follow the system's sort, so
//! they live in two [`crate::particles::Particles`] arrays this scheme does not otherwise use:
//! `density0` holds k of the density solve and `density_rate` k of the divergence solve.

use crate::kernel::Kernel;
use crate::kernels::WendlandC2;
use crate::neighbors::PairValues;
use crate::scheme::{Layout, Scheme};
use crate::system::{FluidSystem, Initial};
use rayon::prelude::*;
use serde::Deserialize;
use shared::math::{Real, Vector};
use shared::protocol::BlockLoad;
use shared::registry::{ParamCheck, SolverParams};
use shared::solver::{SolverError, StepReport};
use shared::strain::Strain;

/// Default Courant number of `[fluid.dfsph] cfl` (Bender & Koschier's 0.4 on the particle
/// diameter); also what `coupler check` estimates a DFSPH run's steps with.
pub const DEFAULT_CFL: Real = 0.4;

/// Default of `[fluid.dfsph] blocks_in_solve`: the free blocks move inside the pressure solves
/// (module doc, "Blocks in the solve").
pub const BLOCKS_IN_SOLVE: bool = true;

/// Whether a scene's `[fluid.dfsph]` table asks for the blocks in the solve (the default when
/// unset), for the coupler's checks of option combinations.
pub fn blocks_in_solve(scene: &shared::scene::Scene) -> bool {
    scene
        .fluid
        .as_ref()
        .and_then(|f| f.solvers.get(<Dfsph as Scheme>::NAME))
        .and_then(|t| t.get("blocks_in_solve"))
        .and_then(|v| v.as_bool())
        .unwrap_or(BLOCKS_IN_SOLVE)
}

/// `[fluid.dfsph]`: parameters of the divergence-free solver. Unset values take the defaults.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DfsphParams {
    /// Courant number on the particle diameter dx: dt = cfl·dx/v_max; default 0.4 (Bender & Koschier).
    pub cfl: Option<f64>,
    /// Constant-density solve: stop when the mean compression is below this [%]; default 0.05.
    pub density_tolerance: Option<f64>,
    /// Divergence solve: stop when the mean of (Dρ/Dt)·dt/ρ0 is below this [% per step];
    /// default 0.1.
    pub divergence_tolerance: Option<f64>,
    /// Constant-density solve: also iterate until an iteration changes the pressure field by
    /// less than this, Σ|Δk|/Σ|k| [%]; default off. 5 halves the step-to-step pressure noise
    /// (for pressure studies against fixed walls; see the module doc before coupling with it).
    pub pressure_tolerance: Option<f64>,
    /// Iteration cap of each solve; default 100.
    pub max_iterations: Option<i64>,
    /// XSPH viscosity coefficient ε (0 disables, ≤ 1); default 0.01.
    pub viscosity: Option<f64>,
    /// Smoothing length h over dx (Wendland C2 support 2h); default 1.3.
    pub smoothing_ratio: Option<f64>,
    /// A particle with fewer neighbours than this fraction of a full lattice's is left out of
    /// the divergence solve (spray; [`DEFICIENT_FRACTION`]); default 0.6, 0 disables.
    pub deficient_fraction: Option<f64>,
    /// Experimental: a particle near the free surface (fewer neighbours than
    /// [`SURFACE_FRACTION`] of a full lattice's) keeps the larger of its summed density and the
    /// density the last step predicted for it (continuity), so gravity cannot pack the surface
    /// layers whose sums are deficient; default false (the summed density, as SPlisHSPlasH).
    pub continued_surface: Option<bool>,
    /// Free blocks move inside the two pressure solves (their inertia in the solve, Gissler et
    /// al. 2019), so the water's answer to a block's motion is not one step late; default
    /// true. False: the blocks keep the velocity the solid node sent over the step (the
    /// explicit partitioned coupling, with its added-mass limit).
    pub blocks_in_solve: Option<bool>,
    /// How the walls and blocks take part in the pressure: "mirrored" (default), each
    /// boundary particle takes the pressure around the fluid particle it faces (the Shepard
    /// mean of its neighbourhood's) inside the two solves, with the hydrostatic difference
    /// between them held over the step; or
    /// "extrapolated", Adami's extrapolation of the last step's pressure held over the step
    /// (module doc, "Pressure acceleration").
    pub wall_pressure: Option<String>,
}

impl SolverParams for DfsphParams {
    fn check(&self, c: &mut ParamCheck) {
        if let Some(v) = self.cfl
            && !(v.is_finite() && v > 0.0 && v <= 1.0)
        {
            c.fail(
                "cfl",
                v,
                "must be a finite number in (0, 1] (a particle may not cross more than its diameter per step)",
                "e.g. cfl = 0.4",
            );
        }
        for (field, value, example, most) in [
            ("density_tolerance", self.density_tolerance, "0.05", 10.0),
            (
                "divergence_tolerance",
                self.divergence_tolerance,
                "0.1",
                10.0,
            ),
            ("pressure_tolerance", self.pressure_tolerance, "5", 100.0),
        ] {
            if let Some(v) = value
                && !(v.is_finite() && v > 0.0 && v <= most)
            {
                c.fail(
                    field,
                    v,
                    &format!("must be a percentage in (0, {most}]"),
                    &format!("e.g. {field} = {example} (per cent)"),
                );
            }
        }
        if let Some(w) = &self.wall_pressure
            && !WALL_PRESSURE.contains(&w.as_str())
        {
            c.fail(
                "wall_pressure",
                w,
                "must be \"mirrored\" or \"extrapolated\"",
                "e.g. wall_pressure = \"mirrored\" (the default)",
            );
        }
        if let Some(n) = self.max_iterations
            && !(1..=10_000).contains(&n)
        {
            c.fail(
                "max_iterations",
                n,
                "must be an integer in [1, 10000]",
                "e.g. max_iterations = 100",
            );
        }
        if let Some(v) = self.viscosity
            && !(v.is_finite() && (0.0..=1.0).contains(&v))
        {
            c.fail(
                "viscosity",
                v,
                "must be an XSPH coefficient in [0, 1]",
                "e.g. viscosity = 0.01; 0 disables it",
            );
        }
        if let Some(f) = self.deficient_fraction
            && !(f.is_finite() && (0.0..=1.0).contains(&f))
        {
            c.fail(
                "deficient_fraction",
                f,
                "must be a fraction of a full neighbourhood in [0, 1]",
                "e.g. deficient_fraction = 0.6; 0 solves every particle",
            );
        }
        if let Some(r) = self.smoothing_ratio
            && !(r.is_finite() && (0.5..=4.0).contains(&r))
        {
            c.fail(
                "smoothing_ratio",
                r,
                "must be a finite number in [0.5, 4] (the support 2h must reach the nearest neighbours)",
                "e.g. smoothing_ratio = 1.3",
            );
        }
    }
}

/// Fraction of the last step's stiffness a solve starts from (the papers' warm start;
/// SPlisHSPlasH's 0.5).
pub const WARM_START: Real = 0.5;
/// A particle with fewer neighbours (fluid and boundary, within the support) than this fraction
/// of a full lattice's is left out of the divergence solve: its Dρ/Dt is set to zero. A spray
/// droplet or a thin sheet has few neighbours, so its factor β is large, and two converging
/// droplets would otherwise be blasted apart by the divergence solve's stiffness (seen: a
/// 143 kPa particle with 4 neighbours, a 49 m/s jet out of the default scene's domain top).
/// The rule and its threshold are SPlisHSPlasH's (`TimeStepDFSPH::computeDensityChange`: fewer
/// than 20 neighbours in 3D with support 2·dx, where a full lattice gives 33): 20/33 ≈ 0.6.
pub const DEFICIENT_FRACTION: Real = 0.6;
/// `continued_surface`: a particle with fewer neighbours than this fraction of a full
/// lattice's is taken to be within a support of the free surface (an interior particle of
/// disordered water keeps ~95–105 %).
pub const SURFACE_FRACTION: Real = 0.9;
/// Blocks in the solve: a solve also runs until its last iteration changed every free block's
/// load by less than this fraction of the block's weight (force, and torque over the block's
/// radius of gyration), so the block's answer is converged where the mean density error alone
/// would stop at two iterations with the block mode still moving. 1 % cost a quarter more
/// time on the default scene for crests within ±3 % of these (docs/PERFORMANCE.md).
pub const BLOCK_TOLERANCE: Real = 0.05;
/// The values of `[fluid.dfsph] wall_pressure`; the first is the default.
pub const WALL_PRESSURE: [&str; 2] = ["mirrored", "extrapolated"];
/// Weight of a fluid particle's stiffness k_i in its pairs with mirrored walls, k_i + k_b with
/// k_b ≈ k_i (Akinci et al. 2012's pressure mirroring, here on a wall filled like the water, so
/// both halves of the symmetric pair term are there): the bound of [`hydrostatic`] and the
/// lagged loads of [`Dfsph::react`], where k̄_i is not at hand.
pub const MIRROR: Real = 2.0;

/// The mirrored wall's held part in the pair (i, b), r = x_i − x_b: the hydrostatic
/// difference p_b − p_i = ρ0 g·(x_b − x_i) (Adami et al. 2012, Eq. 27, pair by pair) as a
/// stiffness, bounded below by −μ k_i of the last step, so that a wall above the water (a
/// block's underside at the surface) never pulls it.
#[inline]
fn hydrostatic(g: &Vector, r: &Vector, rho0: Real, k_last: Real) -> Real {
    (-g.dot(r) / rho0).max(-MIRROR * k_last)
}

/// Mean compression after the density solve beyond which the step is reported as absurd.
pub const ABSURD_DENSITY_ERROR: Real = 0.10;

/// The scheme's constants, resolved from `[fluid.dfsph]` and the scene.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct DfsphConstants {
    pub cfl: Real,
    /// Mean density error tolerance η, as a fraction (0.0005 = 0.05 %).
    pub density_tolerance: Real,
    /// Mean divergence error tolerance η^V per step, as a fraction.
    pub divergence_tolerance: Real,
    /// Largest relative pressure change Σ|Δk|/Σ|k| of the density solve's last iteration
    /// (infinite: off).
    pub pressure_tolerance: Real,
    pub max_iterations: usize,
    /// XSPH ε.
    pub viscosity: Real,
    pub h: Real,
}

/// Iterations and final errors of the last step's two solves.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolveStats {
    pub density_iterations: usize,
    /// Mean compression after the density solve (fraction of ρ0).
    pub density_error: Real,
    pub divergence_iterations: usize,
    /// Mean (Dρ/Dt)·dt/ρ0 after the divergence solve.
    pub divergence_error: Real,
}

#[derive(serde::Serialize, serde::Deserialize)]
pub struct Dfsph {
    kernel: WendlandC2,
    pub constants: DfsphConstants,
    /// ρ0: the summed density of the filled lattice.
    pub rest_density: Real,
    /// Speed that set the Eq. 22 stiffness (Layout); also encodes the initial pressure.
    penalty_speed: Real,
    dx: Real,
    mass: Real,
    penalty_stiffness: Real,
    /// β_i = α_i/ρ_i (the Jacobi diagonal's inverse for k_i).
    beta: Vec<Real>,
    /// G_i = m(Σ_f ∇W_ij + Σ_b ∇W_ib).
    grad: Vec<Vector>,
    /// m Σ_b v_b·∇W_ib: the boundary's (constant) part of Dρ_i/Dt.
    wall_flux: Vec<Real>,
    /// Whether a particle has too few neighbours for the divergence solve ([`DEFICIENT_FRACTION`]).
    deficient: Vec<bool>,
    /// Neighbours (fluid and boundary, within the support) below which a particle is deficient.
    deficient_below: usize,
    /// Neighbours below which a particle keeps its continued density if larger than its sum
    /// (`continued_surface`; 0: off).
    #[serde(default)]
    surface_below: usize,
    /// ρ*_i − ρ0 or Dρ_i/Dt, clamped at zero.
    error: Vec<Real>,
    /// ρ*_i of the last density prediction.
    predicted: Vec<Real>,
    /// Stiffness increment of the current iteration.
    dk: Vec<Real>,
    /// Velocities before the non-pressure forces (XSPH reads the old neighbours).
    v_old: Vec<Vector>,
    /// ∇W_ij (x, y, z) and W_ij of every listed fluid pair at this step's positions (zero past
    /// the support), in list order. The positions do not move during the solves, so the dozen
    /// passes of a step stream these instead of gathering neighbour positions and evaluating
    /// the kernel again; f32 halves the stream, the sums stay f64 (the solves stop at 10⁻⁴
    /// relative errors, f32 is good to 6·10⁻⁸). g_ji = −g_ij holds exactly, so the pressure
    /// forces still conserve momentum. Recomputed at the start of every step: not checkpointed.
    #[serde(skip)]
    pairs: PairValues<[f32; 4]>,
    pub stats: SolveStats,
    /// Whether free blocks move inside the solves (`blocks_in_solve`).
    #[serde(default)]
    blocks_in_solve: bool,
    /// Whether the walls mirror the fluid's stiffness (`wall_pressure = "mirrored"`; a checkpoint
    /// written before the option resumes as it ran, extrapolated).
    #[serde(default)]
    mirrored: bool,
    /// B_i = m Σ_b ∇W_ib, the boundary's part of G_i.
    #[serde(skip)]
    wall_grad: Vec<Vector>,
    /// k̄_i, the Shepard mean of the current stiffness increment over particle i and its fluid
    /// neighbours, for the particles next to a wall ([`Dfsph::apply`]).
    #[serde(skip)]
    kbar: Vec<Real>,
    /// k_ρ + k_v of the last step, per particle (the mirrored walls' bound on their
    /// hydrostatic term).
    #[serde(skip)]
    k_last: Vec<Real>,
    /// Each moving block's velocity change (Δv, Δω) so far in this step (loads order).
    #[serde(skip)]
    motion: Vec<(Vector, Vector)>,
    /// The water's load on each moving block so far in this step (what moved it).
    #[serde(skip)]
    loads: Vec<BlockLoad>,
    /// Jacobi damping of each particle's stiffness increment, 1/(1 + tr K) of the free block it
    /// touches (1 elsewhere): [`Dfsph::block_damping`].
    #[serde(skip)]
    damping: Vec<Real>,
    /// (block, m β_i uᵢᵀM⁻¹uᵢ) of each particle next to a free block (u32::MAX: none).
    #[serde(skip)]
    near: Vec<(u32, Real)>,
    /// tr K of each moving block.
    #[serde(skip)]
    mobility: Vec<Real>,
}

/// The Wendland sum Σ m W at a particle inside a full cubic lattice of spacing dx: ρ0 of the
/// summed density (cf. [`crate::muller::lattice_density`]).
pub fn lattice_density<K: Kernel>(kernel: &K, dx: Real, mass: Real) -> Real {
    let n = (kernel.support() / dx).ceil() as i64;
    let mut sum = 0.0;
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                let r = Vector::new(i as Real, j as Real, k as Real) * dx;
                sum += mass * kernel.value(r.norm());
            }
        }
    }
    sum
}

/// Neighbours within `support` of a particle inside a full cubic lattice of spacing dx (itself
/// not counted).
pub fn lattice_neighbours(support: Real, dx: Real) -> usize {
    let n = (support / dx).ceil() as i64;
    let mut count = 0;
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                let r = Vector::new(i as Real, j as Real, k as Real) * dx;
                if (i, j, k) != (0, 0, 0) && r.norm() < support {
                    count += 1;
                }
            }
        }
    }
    count
}

/// ∇W_ij of a pair value of [`Dfsph::pairs`].
#[inline(always)]
fn gradient(o: &[f32; 4]) -> Vector {
    Vector::new(o[0] as Real, o[1] as Real, o[2] as Real)
}

impl Dfsph {
    /// 2017 Algorithm 1, "compute densities and factors" (also its initialisation): ρ_i, the
    /// factor β_i = α_i/ρ_i, and the boundary's part of Dρ/Dt, at the current positions.
    fn densities_and_factors(&mut self, sys: &mut FluidSystem) {
        let n = sys.len();
        self.beta.resize(n, 0.0);
        self.grad.resize(n, Vector::zeros());
        self.wall_grad.resize(n, Vector::zeros());
        self.kbar.resize(n, 0.0);
        self.wall_flux.resize(n, 0.0);
        self.deficient.resize(n, false);
        self.error.resize(n, 0.0);
        self.predicted.resize(n, 0.0);
        self.dk.resize(n, 0.0);
        self.v_old.resize(n, Vector::zeros());
        let m = sys.mass;
        let kernel = &self.kernel;
        let s2 = kernel.support().powi(2);
        let w0 = kernel.value(0.0);
        let (lists, boundary) = (&sys.fluid_lists, &sys.boundary);
        let (deficient_below, surface_below) = (self.deficient_below, self.surface_below);
        let mirror = self.mirror();
        let p = &mut sys.particles;
        let pos = &p.position;
        lists.fill_pairs(&mut self.pairs, |i, js, out| {
            let xi = pos[i];
            for (&j, o) in js.iter().zip(out.iter_mut()) {
                let rij = xi - pos[j as usize];
                let r2 = rij.norm_squared();
                *o = if r2 < s2 {
                    let r = r2.sqrt();
                    let g = rij * kernel.gradient_factor(r);
                    [g.x as f32, g.y as f32, g.z as f32, kernel.value(r) as f32]
                } else {
                    [0.0; 4]
                };
            }
        });
        let pairs = &self.pairs;
        p.density
            .par_iter_mut()
            .zip(self.beta.par_iter_mut())
            .zip(self.grad.par_iter_mut().zip(self.wall_grad.par_iter_mut()))
            .zip(
                self.wall_flux
                    .par_iter_mut()
                    .zip(self.deficient.par_iter_mut()),
            )
            .enumerate()
            .for_each(
                |(i, (((rho, beta), (grad, wall_grad)), (flux, deficient)))| {
                    let xi = pos[i];
                    let mut sum_w = w0;
                    let mut bs = Vector::zeros();
                    let mut gs = Vector::zeros();
                    let mut sq = 0.0;
                    let mut fl = 0.0;
                    let mut count = 0;
                    for o in lists.with_values(pairs, i).1 {
                        // W > 0 exactly inside the support (Wendland's (1 − q/2)⁴ > 0 for q < 2).
                        if o[3] > 0.0 {
                            count += 1;
                            sum_w += o[3] as Real;
                            let g = gradient(o);
                            gs += g;
                            sq += g.norm_squared();
                        }
                    }
                    boundary.for_each_neighbor(i, |b| {
                        let rib = xi - b.position();
                        let r2 = rib.norm_squared();
                        if r2 < s2 {
                            count += 1;
                            let r = r2.sqrt();
                            sum_w += kernel.value(r);
                            let g = rib * kernel.gradient_factor(r);
                            gs += g;
                            bs += g;
                            fl += b.velocity().dot(&g);
                        }
                    });
                    *deficient = count < deficient_below;
                    // `*rho` still holds the last step's prediction ρ* (the continued density).
                    *rho = if count < surface_below {
                        (m * sum_w).max(*rho)
                    } else {
                        m * sum_w
                    };
                    *grad = gs * m;
                    *wall_grad = bs * m;
                    // The DFSPH factor α_i, divided by ρ_i for this scheme's variable k = κ/ρ
                    // (module doc). With mirrored walls it counts their k̄_i as k_i, what it
                    // is for an increment the neighbourhood shares (module doc, "Pressure
                    // acceleration").
                    let own = *grad + *wall_grad * mirror;
                    let denom = grad.dot(&own).max(0.0) + m * m * sq;
                    *beta = if denom > 1e-9 * (m * m * sq).max(Real::MIN_POSITIVE) {
                        1.0 / denom
                    } else {
                        0.0
                    };
                    *flux = m * fl;
                },
            );
    }

    /// v_i −= dt (dk_i G_i + dk̄_i B_i + m Σ_f dk_j ∇W_ij): the pressure velocity change of
    /// stiffness increments `dk` (the velocity updates of 2017 Algorithms 2 and 3; the
    /// mirrored walls' k̄_i, left in `kbar` for the blocks' loads).
    fn apply(&mut self, sys: &mut FluidSystem, dk: &[Real], dt: Real) {
        let m = sys.mass;
        let (lists, pairs) = (&sys.fluid_lists, &self.pairs);
        let p = &mut sys.particles;
        let (grad, wall_grad) = (&self.grad, &self.wall_grad);
        let mirrored = self.mirrored;
        let w0 = self.kernel.value(0.0);
        p.velocity
            .par_iter_mut()
            .zip(self.kbar.par_iter_mut())
            .enumerate()
            .for_each(|(i, (v, kbar))| {
                let mut acc = grad[i] * dk[i];
                let mut sum = Vector::zeros();
                let (js, gs) = lists.with_values(pairs, i);
                if mirrored && wall_grad[i] != Vector::zeros() {
                    // k̄_i = (W_0 dk_i + Σ_f W_ij dk_j) / (W_0 + Σ_f W_ij), the increment the
                    // mirrored walls give this particle's pairs: the Shepard mean over its
                    // neighbourhood (module doc, "Pressure acceleration"), from the same pairs.
                    let (mut sw, mut sk) = (w0, w0 * dk[i]);
                    for (&j, o) in js.iter().zip(gs) {
                        let (dkj, w) = (dk[j as usize], o[3] as Real);
                        sum += gradient(o) * dkj;
                        sw += w;
                        sk += w * dkj;
                    }
                    *kbar = sk / sw;
                    acc += wall_grad[i] * *kbar;
                } else {
                    for (&j, o) in js.iter().zip(gs) {
                        sum += gradient(o) * dk[j as usize];
                    }
                    *kbar = 0.0;
                }
                acc += sum * m;
                *v -= acc * dt;
            });
    }

    /// 1 with mirrored walls (their pairs' second stiffness is solved for), else 0.
    fn mirror(&self) -> Real {
        if self.mirrored { 1.0 } else { 0.0 }
    }

    /// Whether this step moves blocks inside its solves: asked for, a free block exists, and
    /// the coupling scheme lets the loads follow the step (parallel; in the serial scheme the
    /// blocks keep their velocities, the lagged coupling).
    fn moves_blocks(&self, sys: &FluidSystem) -> bool {
        self.blocks_in_solve
            && sys.loads_may_follow_step
            && sys.boundary.bodies().is_some_and(|b| b.any_free())
    }

    /// The free blocks answer a pressure within the solve (Gissler et al. 2019, rigid bodies
    /// in the pressure solve; here with the block's own inertia and the rest of its forces
    /// from the solid node): the force of stiffness `k(i, p_b, ρ_b)` on each block's boundary
    /// particles, summed as [`Self::react`] sums the loads, moves the block by
    /// Δv = Δt F/m, Δω = Δt I⁻¹τ (with `explicit`, also by the Eq. 22 load and the rest of
    /// its forces R, T: the step's non-pressure part), and the boundary's part of Dρ/Dt,
    /// `wall_flux`, follows the new velocities. The water near a block then sees it give way
    /// within the step, so the pressure the solve converges to is that of the water and the
    /// block moving together: the partitioned scheme's one-step lag no longer multiplies the
    /// added mass (module doc, "Blocks in the solve").
    ///
    /// Returns how far the largest free block's load change was from converged: the change
    /// over [`BLOCK_TOLERANCE`] times the block's weight (force; torque over its radius of
    /// gyration).
    fn move_blocks(
        &mut self,
        sys: &mut FluidSystem,
        dt: Real,
        explicit: bool,
        k: impl Fn(usize, Real, Real, &Vector) -> Real + Sync,
    ) -> Real {
        let (m, kernel) = (sys.mass, &self.kernel);
        sys.boundary.react(
            &sys.particles.position,
            kernel.support(),
            |i, pw, rw, r, len| r * (-m * m * k(i, pw, rw, r) * kernel.gradient_factor(len)),
        );
        let g = sys.gravity.norm().max(Real::MIN_POSITIVE);
        let Some(bodies) = sys.boundary.bodies_mut() else {
            return 0.0;
        };
        let mut left: Real = 0.0;
        let n = bodies.rigid.len();
        self.motion.resize(n, (Vector::zeros(), Vector::zeros()));
        self.loads.resize(n, BlockLoad::default());
        for (kb, ((f, t, e), rigid)) in bodies.loads.iter().zip(&bodies.rigid).enumerate() {
            let (mut f, mut t, mut e) = (*f, *t, *e);
            if explicit && let Some(p) = sys.penalty_loads.get(kb) {
                f += Vector::from(p.force);
                t += Vector::from(p.torque);
                e += Strain::from(p.strain_load);
            }
            let load = &mut self.loads[kb];
            load.force = (Vector::from(load.force) + f).into();
            load.torque = (Vector::from(load.torque) + t).into();
            load.strain_load = (Strain::from(load.strain_load) + e).into();
            if explicit {
                f += rigid.other_force;
                t += rigid.other_torque;
            }
            if rigid.inverse_mass > 0.0 {
                // Weight, and weight times the radius of gyration r² = 3/(m tr I⁻¹).
                let weight = BLOCK_TOLERANCE * g / rigid.inverse_mass;
                let r2 = 3.0 * rigid.inverse_mass
                    / rigid.inverse_inertia.trace().max(Real::MIN_POSITIVE);
                left = left
                    .max(f.norm() / weight)
                    .max(t.norm() / (weight * r2.sqrt()));
            }
            let (dv, dw) = rigid.response(&f, &t, dt);
            self.motion[kb].0 += dv;
            self.motion[kb].1 += dw;
        }
        bodies.nudge(&self.motion);
        self.update_flux(sys);
        left
    }

    /// The Jacobi damping near each free block. Each block joins the solve as a rank-six term
    /// K = m M⁻¹ Σ_i β_i u_i u_iᵀ, u_i = (a_i, c_i), a_i = m Σ_b ∇W_ib and
    /// c_i = m Σ_b (x_b − c) × ∇W_ib over its boundary neighbours b of particle i: a stiffness
    /// increment on the particles next to it moves the block, which relieves all of them at
    /// once, so their Jacobi update overshoots the block's mode by 1 + K (a light block, whose
    /// K is large, made the solve diverge). Their increments are damped by 1/(1 + tr K) (tr K
    /// bounds K's largest eigenvalue); the solution is unchanged, only the path to it. A
    /// particle touching several blocks takes the first one's.
    fn block_damping(&mut self, sys: &FluidSystem) {
        let n = sys.len();
        self.damping.resize(n, 1.0);
        self.near.resize(n, (u32::MAX, 0.0));
        let Some(bodies) = sys.boundary.bodies() else {
            return;
        };
        let (m, kernel, boundary) = (sys.mass, &self.kernel, &sys.boundary);
        let s2 = kernel.support().powi(2);
        let (pos, beta, rigid) = (&sys.particles.position, &self.beta, &bodies.rigid);
        let owner = &bodies.owner_sorted;
        // A coherent increment pushes a block through both halves of a mirrored pair.
        let mu = 1.0 + self.mirror();
        self.near.par_iter_mut().enumerate().for_each(|(i, near)| {
            let xi = pos[i];
            let (mut first, mut a, mut c) = (u32::MAX, Vector::zeros(), Vector::zeros());
            boundary.for_each_moving_neighbor(i, |b| {
                let o = owner[b.index()];
                let rib = xi - b.position();
                let r2 = rib.norm_squared();
                if r2 < s2
                    && rigid[o as usize].inverse_mass > 0.0
                    && (first == u32::MAX || first == o)
                {
                    first = o;
                    let g = rib * kernel.gradient_factor(r2.sqrt());
                    a += g;
                    c += (b.position() - bodies.centroid(o as usize)).cross(&g);
                }
            });
            *near = if first == u32::MAX {
                (u32::MAX, 0.0)
            } else {
                let r = &rigid[first as usize];
                let (a, c) = (a * m, c * m);
                let s = mu
                    * m
                    * beta[i]
                    * (r.inverse_mass * a.norm_squared() + c.dot(&(r.inverse_inertia * c)));
                (first, s)
            };
        });
        self.mobility.clear();
        self.mobility.resize(rigid.len(), 0.0);
        // In particle order: the sums are the same on any number of threads.
        for &(o, s) in &self.near {
            if o != u32::MAX {
                self.mobility[o as usize] += s;
            }
        }
        let mobility = &self.mobility;
        self.damping
            .par_iter_mut()
            .zip(self.near.par_iter())
            .for_each(|(d, &(o, _))| {
                *d = if o == u32::MAX {
                    1.0
                } else {
                    1.0 / (1.0 + mobility[o as usize])
                };
            });
    }

    /// `wall_flux` again at the moving boundary's current velocities (the fixed walls' part
    /// is zero).
    fn update_flux(&mut self, sys: &FluidSystem) {
        let (m, kernel) = (sys.mass, &self.kernel);
        let s2 = kernel.support().powi(2);
        let (boundary, pos) = (&sys.boundary, &sys.particles.position);
        self.wall_flux
            .par_iter_mut()
            .enumerate()
            .for_each(|(i, flux)| {
                let xi = pos[i];
                let mut fl = 0.0;
                boundary.for_each_moving_neighbor(i, |b| {
                    let rib = xi - b.position();
                    let r2 = rib.norm_squared();
                    if r2 < s2 {
                        fl += b.velocity().dot(&(rib * kernel.gradient_factor(r2.sqrt())));
                    }
                });
                *flux = m * fl;
            });
    }

    /// Dρ_i/Dt = Σ_f m (v_i − v_j)·∇W_ij + Σ_b m (v_i − v_b)·∇W_ib (the SPH continuity equation) at
    /// the current velocities. `density`: the constant-density error max(ρ*_i − ρ0, 0) with
    /// ρ*_i = ρ_i + dt·Dρ_i/Dt (Algorithm 3's predicted density; only compression) into `error`,
    /// ρ*_i into `predicted`, and the mean error over ρ0 returned; otherwise the divergence
    /// error max(Dρ_i/Dt, 0) (Algorithm 2's source term) and its mean times dt/ρ0.
    fn predict(&mut self, sys: &FluidSystem, dt: Real, density: bool) -> Real {
        let (m, rho0) = (sys.mass, self.rest_density);
        let (lists, pairs) = (&sys.fluid_lists, &self.pairs);
        let p = &sys.particles;
        let (vel, rho) = (&p.velocity, &p.density);
        let (grad, flux, deficient) = (&self.grad, &self.wall_flux, &self.deficient);
        let sum: Real = self
            .error
            .par_iter_mut()
            .zip(self.predicted.par_iter_mut())
            .enumerate()
            .map(|(i, (e, pred))| {
                let mut d = 0.0;
                let (js, gs) = lists.with_values(pairs, i);
                for (&j, o) in js.iter().zip(gs) {
                    d += vel[j as usize].dot(&gradient(o));
                }
                let div = vel[i].dot(&grad[i]) - m * d - flux[i];
                if density {
                    *pred = rho[i] + dt * div;
                    *e = (*pred - rho0).max(0.0);
                } else if deficient[i] {
                    // Too few neighbours to solve for (DEFICIENT_FRACTION): no divergence source.
                    *e = 0.0;
                } else {
                    *e = div.max(0.0);
                }
                *e
            })
            .sum();
        let mean = sum / p.len().max(1) as Real / rho0;
        if density { mean } else { mean * dt }
    }

    /// One implicit solve, 2017 Algorithm 2 (divergence, `density` false) or Algorithm 3
    /// (constant density): warm start, then Jacobi iterations on the stiffness until the mean
    /// error is below the tolerance (at least 1 resp. 2 iterations) or the cap. The accumulated
    /// stiffness is left in `k` (per particle, the warm start read from it). Returns
    /// (iterations, final mean error).
    fn solve(
        &mut self,
        sys: &mut FluidSystem,
        dt: Real,
        density: bool,
        mut k: Vec<Real>,
    ) -> (usize, Real, Vec<Real>) {
        let c = self.constants;
        let (tolerance, min_iterations, scale) = if density {
            (c.density_tolerance, 2, 1.0 / (dt * dt))
        } else {
            (c.divergence_tolerance, 1, 1.0 / dt)
        };
        // The constant-density solve also runs until its pressure has settled (module doc,
        // "Stopping"); the divergence solve's stiffness is a velocity correction, not read.
        let pressure_tolerance = if density {
            c.pressure_tolerance
        } else {
            Real::INFINITY
        };
        let mut change = Real::INFINITY;
        // Warm start (both papers): a fraction of the last step's stiffness where compressed.
        let blocks = self.moves_blocks(sys);
        self.predict(sys, dt, density);
        let mut dk = std::mem::take(&mut self.dk);
        dk.par_iter_mut()
            .zip(k.par_iter_mut())
            .zip(self.error.par_iter())
            .for_each(|((d, k), &e)| {
                *k = if e > 0.0 {
                    WARM_START * k.max(0.0)
                } else {
                    0.0
                };
                *d = *k;
            });
        if dk.par_iter().any(|&d| d != 0.0) {
            self.apply(sys, &dk, dt);
            if blocks {
                let kbar = std::mem::take(&mut self.kbar);
                // The walls' k̄_i (zero unless mirrored) is the second half of each pair.
                self.move_blocks(sys, dt, false, |i, _, _, _| dk[i] + kbar[i]);
                self.kbar = kbar;
            }
        }
        let mut err = self.predict(sys, dt, density);
        let mut it = 0;
        // How far the free blocks' loads are from converged (module doc, "Blocks in the solve").
        let mut block_left = if blocks { Real::INFINITY } else { 0.0 };
        while (it < min_iterations
            || err > tolerance
            || change > pressure_tolerance
            || block_left > 1.0)
            && it < c.max_iterations
        {
            // κ_i = (ρ*_i − ρ0)·α_i/dt² (Algorithm 3) or (Dρ_i/Dt)·α_i/dt (Algorithm 2), here
            // divided by ρ_i: k_i = error_i·β_i·scale.
            // Damped next to a free block in the solve (`block_damping`).
            let damping = blocks.then_some(&self.damping[..]);
            dk.par_iter_mut()
                .zip(k.par_iter_mut())
                .zip(self.error.par_iter().zip(self.beta.par_iter()))
                .enumerate()
                .for_each(|(i, ((d, k), (&e, &b)))| {
                    *d = e * b * scale * damping.map_or(1.0, |w| w[i]);
                    *k += *d;
                });
            if pressure_tolerance.is_finite() {
                // Σ|Δk| / Σ|k|: how much this iteration still moved the pressure field.
                let (moved, total) = dk
                    .par_iter()
                    .zip(k.par_iter())
                    .map(|(d, k)| (d.abs(), k.abs()))
                    .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
                change = if total > 0.0 { moved / total } else { 0.0 };
            }
            self.apply(sys, &dk, dt);
            if blocks {
                let kbar = std::mem::take(&mut self.kbar);
                block_left = self.move_blocks(sys, dt, false, |i, _, _, _| dk[i] + kbar[i]);
                self.kbar = kbar;
            }
            err = self.predict(sys, dt, density);
            it += 1;
        }
        self.dk = dk;
        (it, err, k)
    }

    /// 2017 Algorithm 1, "non-pressure forces" and "predict velocities": v* = v + dt (g + F_Eq22/m) and XSPH viscosity
    /// v*_i += ε Σ_j (m/ρ_j)(v_j − v_i) W_ij over the fluid neighbours; with them the walls'
    /// held pressure, −dt Σ_b m k_b ∇W_ib with k_b the mirrored walls' H_ib or the extrapolated
    /// walls' p_b/ρ_b² (module doc).
    fn non_pressure(&mut self, sys: &mut FluidSystem, dt: Real) {
        let (m, g, eps) = (sys.mass, sys.gravity, self.constants.viscosity);
        let (mirrored, rho0, k_last) = (self.mirrored, self.rest_density, &self.k_last);
        let kernel = &self.kernel;
        let s2 = kernel.support().powi(2);
        let (lists, boundary, pairs) = (&sys.fluid_lists, &sys.boundary, &self.pairs);
        let p = &mut sys.particles;
        self.v_old.copy_from_slice(&p.velocity);
        let (pos, rho, pen, v_old) = (&p.position, &p.density, &p.penalty, &self.v_old);
        p.velocity
            .par_iter_mut()
            .zip(p.acceleration.par_iter_mut())
            .enumerate()
            .for_each(|(i, (v, a))| {
                let (xi, vi) = (pos[i], v_old[i]);
                let mut xsph = Vector::zeros();
                if eps > 0.0 {
                    let (js, ws) = lists.with_values(pairs, i);
                    for (&j, o) in js.iter().zip(ws) {
                        let j = j as usize;
                        xsph += (v_old[j] - vi) * (m / rho[j] * o[3] as Real);
                    }
                }
                let mut wall = Vector::zeros();
                boundary.for_each_neighbor(i, |b| {
                    let rib = xi - b.position();
                    let r2 = rib.norm_squared();
                    if r2 < s2 {
                        let mk = if mirrored {
                            m * hydrostatic(&g, &rib, rho0, k_last[i])
                        } else {
                            let rb = b.density();
                            m * b.pressure() / (rb * rb)
                        };
                        wall -= rib * (mk * kernel.gradient_factor(r2.sqrt()));
                    }
                });
                // The non-pressure acceleration: what the step's force limit looks at.
                *a = g + pen[i] / m;
                *v = vi + (*a + wall) * dt + xsph * eps;
            });
    }
}

impl Scheme for Dfsph {
    const NAME: &'static str = "dfsph";
    const DESCRIPTION: &'static str = "divergence-free SPH (Bender & Koschier 2015/2017): summed density, implicit constant-density and divergence-free solves, CFL step on the flow speed";
    type Params = DfsphParams;
    type Kernel = WendlandC2;

    fn new(spec: DfsphParams, init: &Initial) -> Result<(Self, Layout), SolverError> {
        let dx = init.fluid.dx;
        let rho0 = init.fluid.density;
        let h = spec.smoothing_ratio.unwrap_or(1.3) * dx;
        let kernel = WendlandC2::new(h);
        let mass = rho0 * dx.powi(3);
        let rest_density = lattice_density(&kernel, dx, mass);
        let deficient_below = (spec.deficient_fraction.unwrap_or(DEFICIENT_FRACTION)
            * lattice_neighbours(kernel.support(), dx) as Real)
            .round() as usize;
        let surface_below = if spec.continued_surface.unwrap_or(false) {
            (SURFACE_FRACTION * lattice_neighbours(kernel.support(), dx) as Real).round() as usize
        } else {
            0
        };
        let constants = DfsphConstants {
            cfl: spec.cfl.unwrap_or(DEFAULT_CFL),
            density_tolerance: 0.01 * spec.density_tolerance.unwrap_or(0.05),
            divergence_tolerance: 0.01 * spec.divergence_tolerance.unwrap_or(0.1),
            // Off unless asked for (module doc, "Known limits").
            pressure_tolerance: spec.pressure_tolerance.map_or(Real::INFINITY, |t| 0.01 * t),
            max_iterations: spec.max_iterations.unwrap_or(100).max(1) as usize,
            viscosity: spec.viscosity.unwrap_or(0.01),
            h,
        };
        // No sound speed limits the step; it only sets the default Eq. 22 spring, the backstop
        // behind the boundary particles. A fifth of WCSPH's (2·sqrt(2 g H), twice the largest
        // free-fall speed) keeps the spring's own limit sqrt(m/K_S) = √2·dx/c above the CFL step.
        let penalty_speed = 0.2 * init.default_sound_speed();
        // Initial hydrostatic pressure, carried to `start` through the density (as Müller does):
        // ρ = ρ0 + ρ_w g d/c².
        let g = init.gravity.norm();
        let density = init
            .fill
            .depth
            .iter()
            .map(|d| rest_density + rho0 * g * d / (penalty_speed * penalty_speed))
            .collect();
        let layout = Layout {
            density,
            support: kernel.support(),
            sound_speed: penalty_speed,
            // particles move ~0.4 dx per step: the lists could not be kept.
            skin_ratio: 0.0,
            poly6_sums: false,
            carried: crate::particles::Carried::ALL,
        };
        let scheme = Self {
            kernel,
            constants,
            rest_density,
            penalty_speed,
            dx,
            mass,
            penalty_stiffness: 0.0,
            beta: Vec::new(),
            grad: Vec::new(),
            wall_flux: Vec::new(),
            deficient: Vec::new(),
            deficient_below,
            surface_below,
            error: Vec::new(),
            predicted: Vec::new(),
            dk: Vec::new(),
            v_old: Vec::new(),
            pairs: PairValues::default(),
            stats: SolveStats::default(),
            blocks_in_solve: spec.blocks_in_solve.unwrap_or(BLOCKS_IN_SOLVE),
            mirrored: spec.wall_pressure.as_deref().unwrap_or(WALL_PRESSURE[0]) == "mirrored",
            wall_grad: Vec::new(),
            kbar: Vec::new(),
            k_last: Vec::new(),
            motion: Vec::new(),
            loads: Vec::new(),
            damping: Vec::new(),
            near: Vec::new(),
            mobility: Vec::new(),
        };
        Ok((scheme, layout))
    }

    fn start(&mut self, sys: &mut FluidSystem) {
        // The particles were sorted: decode the hydrostatic pressure from their own densities,
        // and warm-start the first density solve from it (k = p/ρ0²).
        let (rho0, c2) = (self.rest_density, self.penalty_speed * self.penalty_speed);
        let p = &mut sys.particles;
        p.pressure
            .par_iter_mut()
            .zip(p.density.par_iter_mut())
            .zip(p.density0.par_iter_mut().zip(p.density_rate.par_iter_mut()))
            .for_each(|((pr, r), (kd, kv))| {
                *pr = (*r - rho0) * c2;
                *kd = *pr / (rho0 * rho0);
                *kv = 0.0;
                *r = rho0;
            });
        self.penalty_stiffness = sys.penalty.stiffness;
        self.mass = sys.mass;
    }

    fn step(&mut self, sys: &mut FluidSystem, dt: Real) -> Result<StepReport, SolverError> {
        let c = self.constants;
        // Algorithm 1's "update ρ and α" (rotated to the start): ρ_i and α_i at the current
        // positions; what the walls hold over the step (module doc): mirrored, the last
        // step's stiffness that bounds H_ib; extrapolated, their pressure from the last step's
        // (Adami 2012, Eq. 27 at rest).
        self.densities_and_factors(sys);
        let rho0 = self.rest_density;
        if self.mirrored {
            let p = &sys.particles;
            self.k_last.resize(p.len(), 0.0);
            self.k_last
                .par_iter_mut()
                .zip(p.density0.par_iter().zip(p.density_rate.par_iter()))
                .for_each(|(k, (a, b))| *k = a + b);
        } else {
            sys.boundary
                .update(&self.kernel, &sys.particles, &sys.gravity, rho0, |_| rho0);
        }
        let blocks = self.moves_blocks(sys);
        self.motion.fill((Vector::zeros(), Vector::zeros()));
        self.loads.fill(BlockLoad::default());
        if blocks {
            self.block_damping(sys);
        }
        // Algorithm 1's divergence solve (Algorithm 2), rotated to the start on the current velocities.
        let kv = std::mem::take(&mut sys.particles.density_rate);
        let (div_it, div_err, kv) = self.solve(sys, dt, false, kv);
        sys.particles.density_rate = kv;
        // Non-pressure forces and predicted velocities.
        self.non_pressure(sys, dt);
        if blocks {
            // The blocks' non-pressure part: the walls' held pressure, Eq. 22 and the rest of
            // their forces.
            if self.mirrored {
                let (g, rho0) = (sys.gravity, self.rest_density);
                let k_last = std::mem::take(&mut self.k_last);
                self.move_blocks(sys, dt, true, |i, _, _, r| {
                    hydrostatic(&g, r, rho0, k_last[i])
                });
                self.k_last = k_last;
            } else {
                self.move_blocks(sys, dt, true, |_, pw, rw, _| pw / (rw * rw));
            }
        }
        // The constant-density solve (Algorithm 3) on v*.
        let kd = std::mem::take(&mut sys.particles.density0);
        let (it, err, kd) = self.solve(sys, dt, true, kd);
        sys.particles.density0 = kd;
        // Positions. The pressure the step applied, p = (k_ρ + k_v)ρ², for output and
        // probes; the density the constant-density solve predicts at the new positions.
        if blocks && let Some(bodies) = sys.boundary.bodies_mut() {
            // The solid node moves the blocks; the next pose brings their velocities.
            bodies.settle();
        }
        let p = &mut sys.particles;
        p.position
            .par_iter_mut()
            .zip(p.velocity.par_iter())
            .for_each(|(x, v)| *x += v * dt);
        p.pressure
            .par_iter_mut()
            .zip(p.density.par_iter_mut())
            .zip(p.density0.par_iter().zip(p.density_rate.par_iter()))
            .zip(self.predicted.par_iter())
            .for_each(|(((pr, r), (kd, kv)), pred)| {
                *pr = (kd + kv) * *r * *r;
                *r = *pred;
            });
        self.stats = SolveStats {
            density_iterations: it,
            density_error: err,
            divergence_iterations: div_it,
            divergence_error: div_err,
        };
        let mut warnings = Vec::new();
        if err > c.density_tolerance {
            warnings.push(format!(
                "dfsph: density solve did not converge: mean error {:.3} % after {it} iterations (tolerance {:.3} %)",
                100.0 * err,
                100.0 * c.density_tolerance
            ));
        }
        if err > ABSURD_DENSITY_ERROR {
            return Err(SolverError::Unstable(format!(
                "dfsph: mean compression limit exceeded: {:.1} % after {it} iterations (limit {:.0} %): the constant-density solve cannot hold this step; lower [fluid.dfsph] cfl or [time] dt_max",
                100.0 * err,
                100.0 * ABSURD_DENSITY_ERROR
            )));
        }
        if div_err > c.divergence_tolerance {
            warnings.push(format!(
                "dfsph: divergence solve did not converge: mean error {:.3} % after {div_it} iterations (tolerance {:.3} %)",
                100.0 * div_err,
                100.0 * c.divergence_tolerance
            ));
        }
        Ok(StepReport {
            warning: (!warnings.is_empty()).then(|| warnings.join("; ")),
        })
    }

    fn react(&self, sys: &mut FluidSystem) {
        // The reverse of the pressure force the fluid takes from each moving boundary particle,
        // m·(−m (k_i + k_b) ∇W_ib) with k_i = k_ρ + k_v of the last step and k_b the wall's
        // at the new pose (module doc): mirrored, k_i + H_ib (k_i for k̄_i: summed over a
        // block's pairs the two differ by the noise of single stiffnesses); extrapolated,
        // p_b/ρ_b².
        let rho0 = self.rest_density;
        if !self.mirrored {
            sys.boundary
                .update_moving(&self.kernel, &sys.particles, &sys.gravity, rho0, |_| rho0);
        }
        let (m, kernel, p) = (sys.mass, &self.kernel, &sys.particles);
        sys.boundary
            .react(&p.position, kernel.support(), |i, pw, rw, r, len| {
                let ki = p.density0[i] + p.density_rate[i];
                let k = if self.mirrored {
                    MIRROR * ki + hydrostatic(&sys.gravity, r, rho0, ki)
                } else {
                    ki + pw / (rw * rw)
                };
                r * (-m * m * k * kernel.gradient_factor(len))
            });
    }

    fn loads_follow_step(&self, sys: &FluidSystem) -> bool {
        self.moves_blocks(sys)
    }

    fn step_loads(&self, sys: &FluidSystem, loads: &mut [BlockLoad]) {
        for ((out, load), penalty) in loads.iter_mut().zip(&self.loads).zip(&sys.penalty_loads) {
            *out = BlockLoad {
                block: penalty.block,
                ..*load
            };
        }
    }

    fn kernel(&self) -> &WendlandC2 {
        &self.kernel
    }

    fn density_check(&self) -> (bool, Real) {
        (false, self.rest_density)
    }

    fn dt_proposal(&self, v_max: Real, a_max: Real) -> Real {
        let c = &self.constants;
        let mut dt: Real = 1.0;
        if v_max > 0.0 {
            dt = dt.min(c.cfl * self.dx / v_max);
        }
        if a_max > 0.0 {
            dt = dt.min(c.cfl * (self.dx / a_max).sqrt());
        }
        if self.penalty_stiffness > 0.0 {
            dt = dt.min((self.mass / self.penalty_stiffness).sqrt());
        }
        dt
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `[fluid.dfsph]` from TOML text, as the registry reads it.
    fn params(text: &str) -> Result<DfsphParams, Vec<shared::scene::FieldError>> {
        let mut tables = shared::scene::SolverTables::new();
        tables.insert("dfsph".into(), toml::from_str(text).unwrap());
        shared::registry::params::<DfsphParams>(&tables, "fluid", "dfsph")
    }

    /// `wall_pressure` takes "mirrored" (the default when unset) or "extrapolated"; anything
    /// else is an error naming the field, the value and the fix.
    #[test]
    fn wall_pressure_is_mirrored_or_extrapolated_and_a_bad_value_is_named() {
        assert_eq!(WALL_PRESSURE[0], "mirrored");
        for ok in WALL_PRESSURE {
            let p = params(&format!("wall_pressure = \"{ok}\"")).unwrap();
            assert_eq!(p.wall_pressure.as_deref(), Some(ok));
        }
        assert_eq!(params("").unwrap().wall_pressure, None);
        let errors = params("wall_pressure = \"mirror\"").unwrap_err();
        let text = errors[0].to_string();
        assert!(
            text.contains("fluid.dfsph.wall_pressure")
                && text.contains("\"mirror\"")
                && text.contains("\"mirrored\" or \"extrapolated\""),
            "{text}"
        );
    }
}
