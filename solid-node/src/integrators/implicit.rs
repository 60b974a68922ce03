//! `--solver implicit`: Shi's original DDA time integration (Shi 1993; paper Eqs. 2–4): Newmark
//! with β = ½, γ = 1, so the acceleration of the step's end is held over the whole step:
//!
//! ```text
//! (2/Δt² M + 2/Δt C + K) D = F + (2/Δt M + C) V_n        (Eq. 4)
//! V_{n+1} = 2 D/Δt − V_n
//! ```
//!
//! D holds each free block's translation and small rotation over the step (6 unknowns per
//! rigid block); K the contact springs, linearised about the start of the step as in DDA
//! (the gap of a contact changes by n·(d_P + θ_P × r_P − d_Q − θ_Q × r_Q)). The orientation is
//! then turned by the exact rotation exp(θ) ([`crate::blocks::rotation`]), not by DDA's linear
//! displacement field, so blocks keep their size.
//!
//! Open–close iterations (Shi 1993): each contact starts the step in its last state (open,
//! locked, sliding); after each solve the states are re-derived from the new gaps and the
//! Mohr–Coulomb limit, and the solve repeats until no state changes. If that takes more than
//! `[solid.implicit] max_open_close` solves, or a block moves more than `displacement_limit` of
//! its size, the step is cut by 3 and retried (Shi's rule). Cuts happen inside one
//! `advance(dt)`: it takes as many sub-steps as needed and still ends exactly at t + dt.
//!
//! **Bonded joints** of a `[[slide]]` ([`crate::contact::joints`]): a bonded contact's normal spring acts
//! in tension too, and its shear spring holds up to c·A + N tan φ. An iteration whose trial
//! tension passes T·A or whose shear passes that envelope breaks the bond for the rest of the
//! attempt (a state change, so the step is solved again without it), and the committed step
//! breaks it for good: the residual friction alone from then on, as in the explicit scheme.
//!
//! The scheme is unconditionally stable but damps contact oscillations: a penalty bounce
//! keeps e ≈ exp(−πΩ/4) of its speed (Ω = ω·Δt), the price DDA pays for its large steps.
//!
//! **Deformable blocks** (Shi's 12 unknowns: D = [d; θ; Δe]) add, per block, the strain mass
//! M_e and the block stiffness V·D to the diagonal block, the strain loads (fluid strain load,
//! −V D e_n) to the right-hand side, and to each contact spring the strain part of its
//! direction, T_e(X)ᵀ Rᵀ e ([`crate::blocks::elastic`]): (2/Δt² M_e + V D) Δe = g − V D e_n +
//! (2/Δt) M_e ė_n + springs, the constant-strain rows of Eq. 4. The integrator is generic over
//! the block size: `Newmark<6>` for a scene of rigid blocks (the system of before, no strain
//! work anywhere), `Newmark<12>` when a scene has a deformable block, with identity strain rows
//! (solving to zero) for its rigid blocks.

use crate::blocks::block::Block;
use crate::contact::friction::{ContactState, Joint};
use crate::contact::springs::PenaltyModel;
use crate::contact::{Contact, tangents};
use crate::integrators::energy::EnergyMonitor;
use crate::integrators::linear_system::{BlockMat, BlockSystem, BlockVec, SolveError};
use crate::integrators::stability;
use crate::integrators::{DdaMethod, Integrator};
use crate::world::World;
use serde::Deserialize;
use shared::geometry::strain::{self, Strain};
use shared::math::{Matrix, Point, Real, Rotation, Vector};
use shared::registry::{ParamCheck, SolverParams};
use shared::scene::Scene;
use shared::solver::{SolverError, StepReport};

/// `[solid.implicit]`: parameters of Shi's scheme.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ImplicitParams {
    /// Largest displacement per step over the block size before the step is cut; default 0.01.
    pub displacement_limit: f64,
    /// Open–close iterations before the step is cut (Shi 1993: 6).
    pub max_open_close: u32,
}

impl Default for ImplicitParams {
    fn default() -> Self {
        Self {
            displacement_limit: 0.01,
            max_open_close: 6,
        }
    }
}

impl SolverParams for ImplicitParams {
    fn check(&self, c: &mut ParamCheck) {
        c.positive(
            "displacement_limit",
            Some(self.displacement_limit),
            "e.g. displacement_limit = 0.01",
        );
        if self.max_open_close == 0 {
            c.fail(
                "max_open_close",
                self.max_open_close,
                "must be at least 1 (every step needs one solve)",
                "Shi's value is max_open_close = 6",
            );
        }
    }
}

/// The registry's `implicit` scheme: [`Newmark<6>`] for a scene of rigid blocks, [`Newmark<12>`]
/// when the scene has a deformable block.
pub struct Implicit;

impl DdaMethod for Implicit {
    const NAME: &'static str = "implicit";
    const DESCRIPTION: &'static str = "Shi's DDA Newmark (β = ½, γ = 1, paper Eq. 4) with open–close iterations: unconditionally stable, damps contact bounces";
    type Params = ImplicitParams;

    fn integrator(params: &ImplicitParams, scene: &Scene) -> Box<dyn Integrator> {
        // 12 unknowns per block only when the scene asks for a deformable one.
        if scene.blocks.iter().any(|b| b.elastic.is_some()) {
            Box::new(Newmark::<12>::new(params))
        } else {
            Box::new(Newmark::<6>::new(params))
        }
    }
}

/// Relative residual of the conjugate gradient solve.
const SOLVE_TOLERANCE: Real = 1e-11;

/// Relative band about the Mohr–Coulomb limit inside which a contact keeps its locked or
/// sliding state between open–close iterations (the four corners of a deformable block
/// spreading under load sit exactly on the limit: without the band they flip on round-off).
const STATE_TOLERANCE: Real = 1e-6;

/// Band about zero gap, as a fraction of the contact margin, inside which a contact keeps its
/// open or closed state between open–close iterations. Blocks cut from one rock mass touch at
/// exactly zero gap where no bond holds them (corners, pairs across two joint sets): a
/// contact there closes when open (the load presses it by round-off) and opens when closed
/// (its shear spring lifts it by as much), and the iterations never settle, however short the
/// step. Inside the band a closed contact may pull by at most k_n · 10⁻⁶ margin.
const GAP_TOLERANCE: Real = 1e-6;

/// The per-iteration state of one contact.
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
struct Trial {
    state: ContactState,
    /// Normal force of the last solve [N] (the sliding friction of the next solve uses it).
    normal_force: Real,
    /// Shear spring elongation after the last solve.
    shear: Vector,
    gap: Real,
    /// Still bonded across a slide's joint ([`crate::contact::joints`]): the normal spring then pulls
    /// too. A bond broken in an iteration stays broken for the rest of the attempt.
    bonded: bool,
}

/// The cohesion contact `c` has in a trial where it is `still_bonded` or not: none once the
/// trial has broken its bond.
#[inline]
fn trial_cohesion(c: &Contact, still_bonded: bool) -> Real {
    if c.bonded && !still_bonded {
        0.0
    } else {
        c.cohesion
    }
}

/// Why a sub-step must be cut.
#[derive(Debug)]
enum Cut {
    OpenClose { changing: usize },
    Displacement { block: usize, ratio: Real },
    Solve(SolveError),
}

/// Shi's implicit scheme over blocks of `N` unknowns: 6 (rigid blocks only) or 12 (a scene
/// with deformable blocks).
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct Newmark<const N: usize> {
    max_open_close: u32,
    displacement_limit: Real,
    system: BlockSystem<N>,
    /// Row of each block in the system, usize::MAX for fixed and kinematic blocks.
    row: Vec<usize>,
    /// Prescribed step displacement of fixed and kinematic blocks.
    known: Vec<BlockVec<N>>,
    solution: Vec<BlockVec<N>>,
    trials: Vec<Trial>,
    /// Sub-step that last succeeded when the step had to be cut.
    substep_hint: Option<Real>,
    /// Statistics of the last advance.
    pub last_substeps: usize,
    pub last_iterations: usize,
    scratch: stability::Scratch,
}

/// Where a contact point sits on one block: the world lever arm r, and for a deformable block
/// (N = 12 only) the point's undeformed block-frame position X and the block's rotation R.
#[derive(Clone, Copy)]
struct Arm {
    r: Vector,
    strain: Option<(Vector, Rotation)>,
}

#[inline]
fn arm<const N: usize>(b: &Block, p: &Point) -> Arm {
    Arm {
        r: p - b.position,
        strain: (N == 12 && b.is_deformable()).then(|| (b.material_point(p), b.rotation)),
    }
}

/// Generalised direction [e; r × e] of a unit force e at the arm, with [T_e(X)ᵀ Rᵀ e] on the
/// strain rows of a deformable block.
#[inline]
fn direction<const N: usize>(a: &Arm, e: &Vector) -> BlockVec<N> {
    let t = a.r.cross(e);
    let mut g = BlockVec::<N>::zeros();
    g[0] = e.x;
    g[1] = e.y;
    g[2] = e.z;
    g[3] = t.x;
    g[4] = t.y;
    g[5] = t.z;
    if let Some((x, rot)) = &a.strain {
        let s = strain::generalised_force(x, &rot.inverse_transform_vector(e));
        for k in 0..6 {
            g[6 + k] = s[k];
        }
    }
    g
}

/// The strain rows of a generalised vector (zero when N = 6).
#[inline]
fn strain_part<const N: usize>(d: &BlockVec<N>) -> Strain {
    if N == 12 {
        Strain::from_fn(|k, _| d[6 + k])
    } else {
        Strain::zeros()
    }
}

/// A generalised vector from its rigid part [d; θ] and strain part.
#[inline]
fn generalised<const N: usize>(d: &Vector, theta: &Vector, e: &Strain) -> BlockVec<N> {
    let mut g = BlockVec::<N>::zeros();
    for k in 0..3 {
        g[k] = d[k];
        g[3 + k] = theta[k];
    }
    if N == 12 {
        for k in 0..6 {
            g[6 + k] = e[k];
        }
    }
    g
}

/// Displacement of the material point at the arm under D = [d; θ; Δe]: d + θ × r (+ R ΔE X).
#[inline]
fn point_displacement<const N: usize>(d: &BlockVec<N>, a: &Arm) -> Vector {
    let u = Vector::new(d[0], d[1], d[2]) + Vector::new(d[3], d[4], d[5]).cross(&a.r);
    match &a.strain {
        None => u,
        Some((x, rot)) => u + rot * (strain::tensor(&strain_part(d)) * x),
    }
}

/// Largest distance [m] a point of block `b` moves under the strain change `de`:
/// |ΔE X| ≤ ‖ΔE‖_F |X| (the Frobenius norm bounds the spectral one).
#[inline]
fn strain_travel(b: &Block, de: &Strain) -> Real {
    strain::tensor(de).norm() * b.shape.radius
}

/// The block's mass matrix: m 1, the world inertia, and (N = 12) M_e on the strain rows of a
/// deformable block, the identity on those of a rigid one (rows that solve to Δe = 0).
/// Block-diagonal: the rotation–strain inertia coupling is neglected ([`crate::blocks::elastic`]).
fn mass_matrix<const N: usize>(b: &Block) -> BlockMat<N> {
    let mut m = BlockMat::<N>::zeros();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(Matrix::identity() * b.mass));
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&b.world_inertia());
    if N == 12 {
        match &b.elastic {
            Some(el) => m.fixed_view_mut::<6, 6>(6, 6).copy_from(&el.mass),
            None => m.fixed_view_mut::<6, 6>(6, 6).fill_with_identity(),
        }
    }
    m
}

impl<const N: usize> Newmark<N> {
    pub fn new(spec: &ImplicitParams) -> Newmark<N> {
        assert!(N == 6 || N == 12, "blocks have 6 or 12 unknowns");
        Newmark {
            max_open_close: spec.max_open_close.max(1),
            displacement_limit: spec.displacement_limit,
            system: BlockSystem::default(),
            row: Vec::new(),
            known: Vec::new(),
            solution: Vec::new(),
            trials: Vec::new(),
            substep_hint: None,
            last_substeps: 0,
            last_iterations: 0,
            scratch: stability::Scratch::default(),
        }
    }

    /// Adds a spring of stiffness `k` along `e` between the contact's blocks to the system,
    /// with the generalised force `f0` (acting on P along e, the opposite on Q) that does not
    /// depend on the unknowns. Known displacements of fixed/kinematic sides go into `f0`.
    #[allow(clippy::too_many_arguments)]
    fn add_spring(
        &mut self,
        c: &Contact,
        rp: &Arm,
        rq: &Arm,
        e: &Vector,
        k: Real,
        f0: Real,
        world: &World,
    ) {
        let (p, q) = (c.p as usize, c.q as usize);
        let (gp, gq) = (direction::<N>(rp, e), direction::<N>(rq, e));
        let (ip, iq) = (self.row[p], self.row[q]);
        // Relative displacement along e already fixed by the prescribed sides.
        let mut u_known = 0.0;
        if ip == usize::MAX {
            u_known += gp.dot(&self.known[p]);
        }
        if iq == usize::MAX {
            u_known -= gq.dot(&self.known[q]);
        }
        let f = f0 - k * u_known;
        if ip != usize::MAX {
            self.system.diag[ip] += gp * gp.transpose() * k;
            self.system.rhs[ip] += gp * f;
        }
        if iq != usize::MAX {
            self.system.diag[iq] += gq * gq.transpose() * k;
            self.system.rhs[iq] -= gq * f;
        }
        if ip != usize::MAX && iq != usize::MAX {
            self.system.add_off(ip, iq, &(gp * gq.transpose() * -k));
        }
        let _ = world;
    }

    /// Assembles Eq. 4 for a step `h` with the contacts in the states of `self.trials`.
    fn assemble(&mut self, world: &World, h: Real) {
        let n = world.free.len();
        self.system.reset(n);
        for (r, &i) in world.free.iter().enumerate() {
            let b = &world.blocks[i];
            let m = mass_matrix::<N>(b);
            self.system.diag[r] = m * (2.0 / (h * h));
            let f = b.mass * world.gravity + world.load_force[i];
            let t = world.load_torque[i];
            // Strain rows: the fluid's strain load and the elastic force at the start, −V D e_n;
            // V D Δe goes into the matrix (the elastic force at the end of the step).
            let (g, rate) = match &b.elastic {
                Some(el) if N == 12 => {
                    let mut kb = self.system.diag[r].fixed_view_mut::<6, 6>(6, 6);
                    kb += el.stiffness;
                    (world.load_strain[i] + el.elastic_force(), el.rate)
                }
                _ => (Strain::zeros(), Strain::zeros()),
            };
            let v = generalised::<N>(&b.velocity, &b.angular_velocity, &rate);
            self.system.rhs[r] = generalised::<N>(&f, &t, &g) + m * v * (2.0 / h);
        }
        let pen = &world.penalty;
        for (ci, c) in world.contacts.iter().enumerate() {
            let tr = self.trials[ci];
            if tr.state == ContactState::Open {
                continue;
            }
            let (bp, bq) = (&world.blocks[c.p as usize], &world.blocks[c.q as usize]);
            let (rp, rq) = (arm::<N>(bp, &c.point), arm::<N>(bq, &c.point));
            let mred = PenaltyModel::reduced_mass(bp, bq);
            let dv = bp.point_velocity(&c.point) - bq.point_velocity(&c.point);
            let n = c.normal;
            // Normal spring with its dashpot: F = −k (g0 + u) − c (2u/h − v_n,old).
            let cn = pen.dashpot(pen.normal, mred);
            self.add_spring(
                c,
                &rp,
                &rq,
                &n,
                pen.normal + 2.0 * cn / h,
                -pen.normal * c.gap + cn * n.dot(&dv),
                world,
            );
            let (t1, t2) = tangents(&n);
            match tr.state {
                ContactState::Locked => {
                    let cs = pen.dashpot(pen.shear, mred);
                    for t in [t1, t2] {
                        self.add_spring(
                            c,
                            &rp,
                            &rq,
                            &t,
                            pen.shear + 2.0 * cs / h,
                            -pen.shear * c.shear.dot(&t) + cs * t.dot(&dv),
                            world,
                        );
                    }
                }
                ContactState::Sliding => {
                    // Friction as a load along the slip of the last iteration (Shi 1993).
                    let limit = Joint::shear_limit(
                        c.tan_phi,
                        trial_cohesion(c, tr.bonded),
                        c.area,
                        tr.normal_force,
                    );
                    let s = tr.shear;
                    let dir = if s.norm() > 0.0 {
                        s.normalize()
                    } else {
                        Vector::zeros()
                    };
                    for (t, sign) in [(t1, 1.0), (t2, 1.0)] {
                        let f = -limit * dir.dot(&t) * sign;
                        self.add_spring(c, &rp, &rq, &t, 0.0, f, world);
                    }
                }
                ContactState::Open => {}
            }
        }
    }

    /// Re-derives each contact's state from the solution; returns how many changed between
    /// open/closed or locked/sliding, and whether sliding friction used a stale normal force.
    fn classify(&mut self, world: &World) -> (usize, bool) {
        let pen = &world.penalty;
        let gap_band = GAP_TOLERANCE * pen.margin;
        let mut changed = 0;
        let mut stale = false;
        for (ci, c) in world.contacts.iter().enumerate() {
            let (p, q) = (c.p as usize, c.q as usize);
            let dp = self.step_of(p);
            let dq = self.step_of(q);
            let delta = point_displacement(&dp, &arm::<N>(&world.blocks[p], &c.point))
                - point_displacement(&dq, &arm::<N>(&world.blocks[q], &c.point));
            let n = c.normal;
            let gap = c.gap + n.dot(&delta);
            let tr = &mut self.trials[ci];
            let shear = c.shear + (delta - n * n.dot(&delta));
            // Compression positive; a bonded joint pulls back when opened.
            let signed_force = -pen.normal * gap;
            let mut bonded = tr.bonded;
            if bonded && !pen.bonds_hold {
                // A bond breaks for good when the tension passes T·A or the shear the
                // Mohr–Coulomb envelope with cohesion; the contact is then a plain one (residual
                // friction, open if it has opened) from this iteration on.
                let limit = Joint::shear_limit(c.tan_phi, c.cohesion, c.area, signed_force);
                if signed_force < -c.tensile * c.area
                    || pen.shear * shear.norm() > limit * (1.0 + STATE_TOLERANCE)
                {
                    bonded = false;
                }
            }
            let closes = match tr.state {
                ContactState::Open => gap < -gap_band,
                _ => gap < gap_band,
            };
            let (state, normal_force, shear) = if bonded {
                (ContactState::Locked, signed_force, shear)
            } else if !closes {
                (ContactState::Open, 0.0, Vector::zeros())
            } else {
                let nf = signed_force;
                let limit = if pen.bonds_hold {
                    Real::INFINITY
                } else {
                    Joint::shear_limit(c.tan_phi, trial_cohesion(c, bonded), c.area, nf)
                };
                // A contact whose shear sits on the Mohr–Coulomb limit (within
                // STATE_TOLERANCE) keeps its trial state: locked and sliding then give the same
                // solution, and flipping between them on round-off would never converge.
                let force = pen.shear * shear.norm();
                let slides = match tr.state {
                    ContactState::Sliding => force >= limit * (1.0 - STATE_TOLERANCE),
                    _ => force > limit * (1.0 + STATE_TOLERANCE),
                };
                let state = if slides {
                    ContactState::Sliding
                } else {
                    ContactState::Locked
                };
                (state, nf, shear)
            };
            if bonded != tr.bonded {
                changed += 1;
            }
            if state != tr.state {
                changed += 1;
            } else if state == ContactState::Sliding
                && (normal_force - tr.normal_force).abs() > 1e-3 * normal_force.max(tr.normal_force)
            {
                stale = true;
            }
            *tr = Trial {
                state,
                normal_force,
                shear,
                gap,
                bonded,
            };
        }
        (changed, stale)
    }

    fn step_of(&self, block: usize) -> BlockVec<N> {
        match self.row[block] {
            usize::MAX => self.known[block],
            r => self.solution[r],
        }
    }

    /// One sub-step of length h from the world's current state, without changing it.
    fn attempt(&mut self, world: &World, h: Real) -> Result<usize, Cut> {
        for (i, b) in world.blocks.iter().enumerate() {
            self.known[i] = match (&b.motion, b.kind) {
                (Some(m), shared::scene::BlockKind::Kinematic) => {
                    let d = m.displacement(world.time + h) - m.displacement(world.time);
                    generalised::<N>(&d, &Vector::zeros(), &Strain::zeros())
                }
                _ => BlockVec::<N>::zeros(),
            };
        }
        self.trials.clear();
        self.trials.extend(world.contacts.iter().map(|c| Trial {
            // A contact already interpenetrating at the start is closed, a bonded one is held
            // (it pulls when opened); others keep their state.
            state: if c.bonded || (c.state == ContactState::Open && c.gap < 0.0) {
                ContactState::Locked
            } else {
                c.state
            },
            normal_force: c.normal_force,
            shear: c.shear,
            gap: c.gap,
            bonded: c.bonded,
        }));
        self.solution.clear();
        for &i in &world.free {
            let b = &world.blocks[i];
            let (d, w) = (b.velocity * h, b.angular_velocity * h);
            self.solution
                .push(generalised::<N>(&d, &w, &(b.strain_rate() * h)));
        }
        let max_cg = 50 + 20 * world.free.len();
        let mut iterations = 0;
        let mut converged = false;
        let mut changing = 0;
        for _ in 0..self.max_open_close {
            self.assemble(world, h);
            let mut x = std::mem::take(&mut self.solution);
            let r = self.system.solve(&mut x, SOLVE_TOLERANCE, max_cg);
            self.solution = x;
            r.map_err(Cut::Solve)?;
            iterations += 1;
            let (changed, stale) = self.classify(world);
            changing = changed;
            if changed == 0 {
                converged = true;
                if !stale {
                    break;
                }
            } else {
                converged = false;
            }
        }
        if !converged {
            return Err(Cut::OpenClose { changing });
        }
        for (r, &i) in world.free.iter().enumerate() {
            let b = &world.blocks[i];
            let d = &self.solution[r];
            let moved = Vector::new(d[0], d[1], d[2]).norm()
                + Vector::new(d[3], d[4], d[5]).norm() * b.shape.radius
                + strain_travel(b, &strain_part(d));
            let ratio = moved / b.size();
            if ratio > self.displacement_limit {
                return Err(Cut::Displacement { block: i, ratio });
            }
        }
        Ok(iterations)
    }

    /// Applies the converged sub-step: poses, velocities (V = 2D/h − V_n) and contact states.
    fn commit(&mut self, world: &mut World, h: Real) -> Real {
        let mut work = 0.0;
        for (r, &i) in world.free.iter().enumerate() {
            let d = self.solution[r];
            let (dx, th) = (Vector::new(d[0], d[1], d[2]), Vector::new(d[3], d[4], d[5]));
            work += world.load_force[i].dot(&dx) + world.load_torque[i].dot(&th);
            let b = &mut world.blocks[i];
            b.remember_pose();
            b.velocity = dx * (2.0 / h) - b.velocity;
            b.angular_velocity = th * (2.0 / h) - b.angular_velocity;
            b.displace(&dx, &th);
            if let Some(el) = b.elastic.as_mut() {
                let de = strain_part(&d);
                work += world.load_strain[i].dot(&de);
                el.rate = de * (2.0 / h) - el.rate;
                b.strain_by(&de);
            }
            b.update_world_geometry();
        }
        let pen = world.penalty.clone();
        for (c, tr) in world.contacts.iter_mut().zip(&self.trials) {
            if c.bonded && !tr.bonded {
                c.break_bond();
            }
            c.state = tr.state;
            c.gap = tr.gap;
            // The signed force of a bonded joint in tension acts; the normal force reported is
            // the compression.
            c.normal_force = tr.normal_force.max(0.0);
            match tr.state {
                ContactState::Open => {
                    c.shear = Vector::zeros();
                    c.force = Vector::zeros();
                }
                ContactState::Locked => {
                    c.shear = tr.shear;
                    c.force = c.normal * tr.normal_force - tr.shear * pen.shear;
                }
                ContactState::Sliding => {
                    let limit = Joint::shear_limit(c.tan_phi, c.cohesion, c.area, tr.normal_force);
                    let len = tr.shear.norm();
                    c.shear = if len > 0.0 {
                        tr.shear * (limit / (pen.shear * len))
                    } else {
                        Vector::zeros()
                    };
                    c.force = c.normal * tr.normal_force - c.shear * pen.shear;
                }
            }
        }
        world.sum_contact_forces();
        let t1 = world.time + h;
        for &i in &world.moving {
            let b = &mut world.blocks[i];
            if b.is_free() {
                continue;
            }
            b.remember_pose();
            b.set_kinematic_pose(t1);
            work -= world.contact_force[i].dot(&(b.position - b.prev_position));
            b.update_world_geometry();
        }
        world.time = t1;
        work
    }

    /// Contact search distance for a sub-step h: the margin plus twice the largest distance a
    /// block point can travel in h, so every contact that may close within the step is found.
    fn search_margin(world: &World, h: Real) -> Real {
        let mut travel: Real = 0.0;
        for &i in &world.free {
            let b = &world.blocks[i];
            let a = world.gravity.norm() + world.load_force[i].norm() / b.mass;
            travel = travel.max(
                (b.velocity.norm()
                    + b.angular_velocity.norm() * b.shape.radius
                    + strain_travel(b, &b.strain_rate()))
                    * h
                    + a * h * h,
            );
        }
        world.penalty.margin + 2.0 * travel
    }
}

impl<const N: usize> Integrator for Newmark<N> {
    fn name(&self) -> &'static str {
        Implicit::NAME
    }

    fn save(&self) -> Result<Vec<u8>, String> {
        shared::checkpoint::encode(self)
    }

    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        *self = shared::checkpoint::decode(state, "implicit integrator")?;
        Ok(())
    }

    fn duplicate(&self) -> Box<dyn Integrator> {
        Box::new(self.clone())
    }

    fn init(&mut self, world: &mut World) {
        let mut r = 0;
        self.row = world
            .blocks
            .iter()
            .map(|b| {
                if b.is_free() {
                    r += 1;
                    r - 1
                } else {
                    usize::MAX
                }
            })
            .collect();
        self.known = vec![BlockVec::<N>::zeros(); world.blocks.len()];
    }

    fn advance(
        &mut self,
        world: &mut World,
        dt: Real,
        energy: &mut EnergyMonitor,
    ) -> Result<StepReport, SolverError> {
        let t_end = world.time + dt;
        let mut remaining = dt;
        let mut h = self.substep_hint.map_or(dt, |s| (3.0 * s).min(dt));
        let mut cuts = 0usize;
        self.last_substeps = 0;
        self.last_iterations = 0;
        let mut work = 0.0;
        while remaining > 0.0 {
            h = h.min(remaining);
            if remaining - h <= 1e-9 * dt {
                h = remaining;
            }
            world.detect(Self::search_margin(world, h));
            loop {
                match self.attempt(world, h) {
                    Ok(iterations) => {
                        self.last_iterations += iterations;
                        break;
                    }
                    Err(cut) => {
                        cuts += 1;
                        h /= 3.0;
                        if h < world.dt_min {
                            let why = match cut {
                                Cut::OpenClose { changing } => format!(
                                    "open–close iterations did not converge ({changing} contact(s) still changing state after {} solves)",
                                    self.max_open_close
                                ),
                                Cut::Displacement { block, ratio } => format!(
                                    "block '{}' moves {ratio:.3e} of its size per step, above displacement_limit {}",
                                    world.blocks[block].name,
                                    shared::math::readable(self.displacement_limit)
                                ),
                                Cut::Solve(e) => {
                                    format!("the global equations could not be solved ({e:?})")
                                }
                            };
                            return Err(SolverError::Unstable(format!(
                                "implicit solver: {why}, even with the step cut {cuts} times to {h:.3e} s (below dt_min) at t = {:.6} s",
                                world.time
                            )));
                        }
                    }
                }
            }
            work += self.commit(world, h);
            self.last_substeps += 1;
            remaining = t_end - world.time;
            if remaining <= 1e-9 * dt {
                world.time = t_end;
                remaining = 0.0;
            }
            if cuts > 0 {
                h *= 3.0;
            }
        }
        self.substep_hint = (cuts > 0).then_some(h / 3.0);
        energy.add_work(work);
        world.check_state(self.name())?;
        let scratch = &mut self.scratch;
        energy.check(
            world,
            "implicit",
            || stability::current(world, scratch).omega2.sqrt() * dt,
            || "Shi's β = ½, γ = 1 Newmark is unconditionally stable: growth means a wrong contact state".to_string(),
        )?;
        // Cutting is routine for Shi's scheme; only heavy cutting is worth telling the user.
        let warning = (self.last_substeps >= 9).then(|| {
            format!(
                "implicit: step cut {cuts} time(s), {} sub-steps",
                self.last_substeps
            )
        });
        Ok(StepReport { warning })
    }

    fn dt_proposal(&self, world: &World) -> Real {
        let mut dt = world.dt_max;
        for &i in &world.free {
            let b = &world.blocks[i];
            let speed = b.velocity.norm()
                + b.angular_velocity.norm() * b.shape.radius
                + strain_travel(b, &b.strain_rate());
            if speed > 0.0 {
                dt = dt.min(self.displacement_limit * b.size() / speed);
            }
        }
        match self.substep_hint {
            Some(h) => dt.min(h),
            None => dt,
        }
    }
}
