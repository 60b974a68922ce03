//! `[domain] open_top`: a jet thrown up from the middle of a tank whose walls, and the domain,
//! end 10 cm above the water. Closed, the top stops the run, named; open, the jet flies on above
//! it, is said once, and falls back into the tank when a ballistic column would.

use fluid_node::methods::SphMethod;
use fluid_node::methods::dfsph::Dfsph;
use fluid_node::methods::wcsph::Wcsph;
use fluid_node::sph::{Sph, SphSolver};
use fluid_node::validation::*;
use shared::coupling::step::StepRule;
use shared::scene::{CouplingScheme as Coupling, Scene};
use shared::solver::{SetupContext, Solver, SolverError};

/// Water 0.1 m deep in a 0.6 m square tank whose walls and domain end at z = 0.2 m
/// (dx = 0.02 m).
fn tank_scene(solver: &str, open_top: bool) -> Scene {
    let (l, dx, top, end) = (0.6, 0.02, 0.2, 0.7);
    let text = format!(
        "name = \"jet\"\n[time]\nend = {end}\ndt_max = 1e-3\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [{l}, {l}, {top}]\nopen_top = {open_top}\n\
         [output]\ninterval = {end}\n{fluid}\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [{l}, {l}, 0.1] }}\n\n{tank}",
        fluid = fluid_table(solver, dx, None),
        tank = tank(l, l, top, 0.02),
    );
    Scene::parse(&text, "jet").expect("valid scene")
}

/// A solver alone (parallel scheme, no solid node) for `scene`, writing into `dir`.
fn ctx<'a>(scene: &'a Scene, dir: &'a TempRunDir) -> SetupContext<'a> {
    SetupContext {
        scene,
        run_dir: dir.path(),
        scheme: Coupling::Parallel,
        peer_present: false,
    }
}

/// What a run of the tank with a jet did: the most particles above the top at once, the
/// highest one, when the first flight ended (none above the top again), and the steps'
/// warnings.
struct Flight {
    most: usize,
    highest: f64,
    landed: Option<f64>,
    warnings: Vec<String>,
}

/// The tank's water within 6 cm of the middle thrown up at 2.5 m/s (a column rising 0.32 m, to
/// 0.22 m above the top), run to the scene's end.
fn jet<S: SphMethod>(open_top: bool) -> Result<Flight, SolverError> {
    let scene = tank_scene(S::NAME, open_top);
    let top = scene.domain.max[2];
    let dir = TempRunDir::new("open-top").unwrap();
    let mut s = Sph::<S>::new(&ctx(&scene, &dir))?;
    throw_jet(&mut s);
    let rule = StepRule::new(scene.time.dt_max, scene.time.dt_min);
    let (mut t, mut most, mut highest, mut warnings) = (0.0, 0, 0.0f64, Vec::new());
    let mut landed = None;
    while t < scene.time.end {
        let (reached, report) = step(&mut s, &rule, t, scene.time.end, &mut [])?;
        t = reached;
        warnings.extend(report.warning);
        let z = s.system().particles.position.iter().map(|x| x.z);
        let aloft = z.clone().filter(|&z| z > top).count();
        if aloft == 0 && most > 0 && landed.is_none() {
            landed = Some(t);
        }
        most = most.max(aloft);
        highest = z.fold(highest, f64::max);
    }
    Ok(Flight {
        most,
        highest,
        landed,
        warnings,
    })
}

/// The tank's water within 6 cm of the middle given 2.5 m/s upwards.
fn throw_jet<S: SphMethod>(s: &mut Sph<S>) {
    let p = &mut s.sys.particles;
    for ((x, v), v0) in p.position.iter().zip(&mut p.velocity).zip(&mut p.velocity0) {
        if (x.x - 0.3).hypot(x.y - 0.3) < 0.06 {
            v.z = 2.5;
            *v0 = *v;
        }
    }
}

fn check<S: SphMethod>() {
    let solver = S::NAME;
    let err = jet::<S>(false)
        .err()
        .expect("the jet leaves a closed top")
        .to_string();
    assert!(
        err.contains("domain limit exceeded") && err.contains("left the domain"),
        "{solver}: {err}"
    );
    let f = jet::<S>(true).unwrap();
    eprintln!(
        "{solver}: at most {} particles above the top, the highest at z = {:.3} m; all back under it at t = {:?} s; warnings {:?}",
        f.most, f.highest, f.landed, f.warnings
    );
    // The jet rose well above the top (ballistically to 0.22 m above it).
    assert!(
        f.most > 50 && f.highest > 0.3,
        "{solver}: the jet stayed low"
    );
    // Said once for each flight above the top (a drop that falls back and is thrown up again
    // is a second flight), naming the top.
    assert!(
        !f.warnings.is_empty()
            && f.warnings.len() <= 3
            && f.warnings
                .iter()
                .all(|w| w.contains("above the open domain top z = 0.2 m")),
        "{solver}: {:?}",
        f.warnings
    );
    // Back in the tank about when a ballistic column would be (up and down from the top at
    // 2.06 m/s: 0.42 s, plus its rise to the top, 0.04 s).
    assert!(
        f.landed.is_some_and(|t| (0.38..0.6).contains(&t)),
        "{solver}: first flight ended at {:?} s",
        f.landed
    );
}

#[test]
fn a_jet_above_an_open_top_falls_back_and_a_closed_top_stops_the_run() {
    check::<Wcsph>();
    check::<Dfsph>();
}

/// A checkpoint taken while the jet is above the top resumes as the run goes on: the same
/// particles to the bit, and no second warning for the flight under way (the count above the
/// top is taken again from the restored positions).
#[test]
fn a_resume_mid_flight_continues_exactly_and_warns_no_more() {
    let scene = tank_scene("dfsph", true);
    let top = scene.domain.max[2];
    let (da, db, scratch) = (
        TempRunDir::new("open-top-a").unwrap(),
        TempRunDir::new("open-top-b").unwrap(),
        TempRunDir::new("open-top-scratch").unwrap(),
    );
    let mut a = Sph::<Dfsph>::new(&ctx(&scene, &da)).unwrap();
    throw_jet(&mut a);
    let rule = StepRule::new(scene.time.dt_max, scene.time.dt_min);
    let steps = |s: &mut Sph<Dfsph>, t: &mut f64, n: usize| -> Vec<String> {
        let mut warnings = Vec::new();
        for _ in 0..n {
            let (reached, report) = step(s, &rule, *t, scene.time.end, &mut []).unwrap();
            *t = reached;
            warnings.extend(report.warning);
        }
        warnings
    };
    let mut t = 0.0;
    while a.system().particles.position.iter().all(|x| x.z <= top) {
        assert!(steps(&mut a, &mut t, 1).len() <= 1);
    }
    steps(&mut a, &mut t, 5);
    let aloft = |s: &Sph<Dfsph>| {
        s.system()
            .particles
            .position
            .iter()
            .filter(|x| x.z > top)
            .count()
    };
    assert!(aloft(&a) > 0, "the jet is not above the top at t = {t} s");
    let state = a.save_state().unwrap();
    let mut b = Sph::<Dfsph>::new(&ctx(&scene, &scratch)).unwrap();
    b.restore_state(&state, db.path()).unwrap();
    let (mut ta, mut tb) = (t, t);
    let (wa, wb) = (steps(&mut a, &mut ta, 20), steps(&mut b, &mut tb, 20));
    assert!(
        aloft(&a) > 0,
        "the jet landed within the 20 steps: take fewer"
    );
    assert_eq!((wa.len(), wb.len()), (0, 0), "{wa:?} {wb:?}");
    assert_eq!(ta.to_bits(), tb.to_bits());
    let bits = |s: &Sph<Dfsph>| {
        let p = &s.system().particles;
        let v: Vec<u64> = p
            .position
            .iter()
            .chain(&p.velocity)
            .flat_map(|v| v.iter().map(|x| x.to_bits()))
            .collect();
        v
    };
    assert!(bits(&a) == bits(&b), "the resumed run's particles differ");
}
