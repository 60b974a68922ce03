//! The solid's look-ahead for a fluid that moves the blocks inside its step
//! (`SolidSolver::look_ahead`): the response it sends, (Δv, Δω) = Δt (a0 + M (F, τ)) over the
//! coming step, predicts what the next step then does under a load it has not seen, the trial
//! steps leave no trace, a contact shows in M, and the trials split over two threads give the
//! response of one.

use shared::math::{Real, Vector6};
use shared::protocol::{BlockLoad, BlockState};
use shared::scene::Scene;
use shared::solver::SolidSolver;
use solid_node::verification::Incline;

mod common;
use common::{Dir, build};

/// A block sliding down a 30° incline (friction 20°): its contact holds it against the plane.
fn incline() -> Scene {
    Incline::SLIDING.scene()
}

fn load(force: [f64; 3], torque: [f64; 3]) -> BlockLoad {
    BlockLoad {
        force,
        torque,
        ..BlockLoad::default()
    }
}

fn state(s: &dyn SolidSolver) -> (BlockState, Vec<[f64; 3]>) {
    let mut blocks = vec![BlockState::default(); 1];
    let mut vertices = vec![[0.0; 3]; s.vertex_count()];
    s.write_geometry(&mut blocks, &mut vertices);
    (blocks[0], vertices)
}

/// Steps of `dt` taken as the runtime takes a coupling step of `n` substeps.
fn coupling_step(s: &mut dyn SolidSolver, l: BlockLoad, dt: Real, n: u32) {
    s.read_loads(&[l]);
    for _ in 0..n {
        s.advance(dt / n as Real).unwrap();
    }
}

/// The block's mean (Δv, Δω) over a step, from its poses before and after (as the look-ahead
/// defines it).
fn mean_change(before: &BlockState, after: &BlockState, dt: Real) -> Vector6 {
    let v = (after.centroid() - before.centroid()) / dt - before.velocity();
    let w = (after.rotation() * before.rotation().inverse()).scaled_axis() / dt
        - before.angular_velocity();
    Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z)
}

/// With the water's load changed by a tenth of the block's weight (and a torque) between the
/// look-ahead and the step, the response predicts the step's mean velocities to 1 % of the
/// load's effect with the explicit scheme and 10 % with the implicit one (its open–close
/// iterations are not linear in the load); the block taken on its own (its mass, its last
/// forces: what a fluid assumed before) misses by more than ten times that. On the incline the
/// contact holds the block against the plane: M along the normal is under half of M along the
/// slope (a free block's M is the same along both).
#[test]
fn the_response_predicts_the_next_step_under_a_new_load() {
    for solver in solid_node::REGISTRY.names() {
        let scene = incline();
        let dir = Dir::new(&format!("ahead-{solver}"));
        let mut s = build(solver, &scene, &dir);
        let l0 = load([1.0, 0.0, 0.5], [0.0, 0.0, 0.0]);
        let n = 4;
        let dt = n as Real * s.dt_proposal().min(1e-3);
        for _ in 0..30 {
            coupling_step(s.as_mut(), l0, dt, n);
        }
        let (free, _) = state(s.as_ref());
        s.look_ahead(Some((dt, n))).unwrap();
        let (before, _) = state(s.as_ref());
        let (a0, m) = (before.free_acceleration(), before.mobility());
        let weight = 9.81 / before.inverse_mass;
        // A new load: a tenth of the weight up and along, and a torque about y.
        let l1 = load(
            [0.1 * weight, 0.0, 1.5 + 0.1 * weight],
            [0.0, 0.05 * weight, 0.0],
        );
        let f1 = Vector6::new(l1.force[0], 0.0, l1.force[2], 0.0, l1.torque[1], 0.0);
        coupling_step(s.as_mut(), l1, dt, n);
        let (after, _) = state(s.as_ref());
        let actual = mean_change(&before, &after, dt);
        let predicted = (a0 + m * f1) * dt;
        let effect = (m * (f1 - Vector6::new(1.0, 0.0, 0.5, 0.0, 0.0, 0.0)) * dt).norm();
        let err = (predicted - actual).norm();
        // What a fluid assumed before: m Δv = Δt (F + R), I Δω = Δt (τ + T).
        assert!(free.response().is_none());
        let (r, t) = (free.other_force, free.other_torque);
        let v = (f1.fixed_rows::<3>(0) + nalgebra::Vector3::from(r)) * free.inverse_mass;
        let w = free.inverse_inertia() * (f1.fixed_rows::<3>(3) + nalgebra::Vector3::from(t));
        let on_its_own = Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z) * dt;
        let err_alone = (on_its_own - actual).norm();
        // The incline's normal (x, z) = (sin α, cos α) of a 30° plane rising towards −x.
        let (sa, ca) = (0.5, 0.75f64.sqrt());
        let normal = Vector6::new(sa, 0.0, ca, 0.0, 0.0, 0.0);
        let slope = Vector6::new(ca, 0.0, -sa, 0.0, 0.0, 0.0);
        let (mn, ms) = (normal.dot(&(m * normal)), slope.dot(&(m * slope)));
        eprintln!(
            "{solver}: prediction off by {err:.3e} m/s (load's effect {effect:.3e}, the block on its own off by {err_alone:.3e}); M along the normal {mn:.4} 1/kg, along the slope {ms:.4}"
        );
        // The implicit scheme's open–close iterations are not linear in the load.
        let tolerance = if solver == "explicit" { 0.01 } else { 0.1 };
        assert!(effect > 0.0 && err < tolerance * effect, "{solver}");
        assert!(err_alone > 10.0 * err, "{solver}");
        assert!(mn < 0.5 * ms, "{solver}: M normal {mn}, slope {ms}");
    }
}

/// The trial steps leave no trace: a solver that looked ahead and one that did not take the
/// next steps to the bit, and write the same blocks.csv.
#[test]
fn looking_ahead_changes_nothing_of_the_run() {
    for solver in solid_node::REGISTRY.names() {
        let scene = incline();
        let (da, db) = (
            Dir::new(&format!("ahead-{solver}-a")),
            Dir::new(&format!("ahead-{solver}-b")),
        );
        let (mut a, mut b) = (build(solver, &scene, &da), build(solver, &scene, &db));
        let l = load([1.0, 0.0, 0.5], [0.0, 0.2, 0.0]);
        let n = 3;
        let dt = n as Real * a.dt_proposal().min(1e-3);
        for step in 0..40 {
            coupling_step(a.as_mut(), l, dt, n);
            coupling_step(b.as_mut(), l, dt, n);
            a.look_ahead(Some((dt, n))).unwrap();
            if step % 2 == 0 {
                b.look_ahead(None).unwrap();
            }
            let ((sa, va), (sb, vb)) = (state(a.as_ref()), state(b.as_ref()));
            let bits = |s: &BlockState, v: &[[f64; 3]]| -> Vec<u64> {
                s.centroid
                    .iter()
                    .chain(&s.orientation)
                    .chain(&s.velocity)
                    .chain(&s.angular_velocity)
                    .chain(v.iter().flatten())
                    .map(|x| x.to_bits())
                    .collect()
            };
            assert_eq!(bits(&sa, &va), bits(&sb, &vb), "{solver}: step {step}");
        }
        a.finish().unwrap();
        b.finish().unwrap();
        let csv = |d: &Dir| std::fs::read_to_string(d.0.join("blocks.csv")).unwrap();
        assert_eq!(csv(&da), csv(&db), "{solver}: blocks.csv");
    }
}

/// The trials run half on a copy of the block system, on the second thread: the response is
/// the same to the bit on one thread and on two, and again when looked ahead twice.
#[test]
fn the_response_is_the_same_on_one_thread_and_on_two() {
    for solver in solid_node::REGISTRY.names() {
        let response = |threads: usize, twice: bool| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let dir = Dir::new(&format!("ahead-threads-{solver}-{threads}-{twice}"));
                let mut s = build(solver, &incline(), &dir);
                let l = load([1.0, 0.0, 0.5], [0.0, 0.2, 0.0]);
                let n = 4;
                let dt = n as Real * s.dt_proposal().min(1e-3);
                for _ in 0..20 {
                    coupling_step(s.as_mut(), l, dt, n);
                }
                s.look_ahead(Some((dt, n))).unwrap();
                if twice {
                    s.look_ahead(Some((dt, n))).unwrap();
                }
                let (b, _) = state(s.as_ref());
                s.finish().unwrap();
                b.free_acceleration()
                    .iter()
                    .chain(b.mobility().iter())
                    .map(|x| x.to_bits())
                    .collect::<Vec<u64>>()
            })
        };
        let one = response(1, false);
        assert!(
            one.iter().any(|&x| x != 0),
            "{solver}: a response was measured"
        );
        assert_eq!(one, response(2, false), "{solver}: 1 against 2 threads");
        assert_eq!(one, response(2, true), "{solver}: looked ahead twice");
    }
}
