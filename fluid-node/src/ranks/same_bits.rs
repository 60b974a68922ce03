//! The decomposition's promise, checked on ranks that are threads of the test: a dam break
//! against walls with gauges and a probe gives the same bits on 1, 2, 3 and 4 ranks with every
//! SPH method, particle by particle, in the gauges' file and in the frame; a checkpoint of 2
//! ranks is the one-rank file and resumes on 3.

use super::comm::{Comm, ThreadRanks};
use super::share::HaloStats;
use crate::methods::SphMethod;
use crate::methods::dfsph::Dfsph;
use crate::methods::muller::Muller;
use crate::methods::riemann::Riemann;
use crate::methods::wcsph::Wcsph;
use crate::sph::Sph;
use shared::scene::{CouplingScheme, Scene};
use shared::solver::{SetupContext, Solver};
use std::path::Path;
use std::sync::Arc;

/// A column of water a third of a 0.6 m tank long, collapsing: within 800 steps (0.1 s) the
/// front runs a tenth of the tank, the work drifts and the cuts move, and particles change
/// owner.
fn scene() -> Scene {
    scene_with(WALL_PROBES)
}

/// Two faces that read the wall (`instruments::wall_load`): one on the left wall under the
/// column, one on the floor 3 cm across where the column's foot spreads, which the cuts pass
/// as they move (each rank sums its own particles' pairs, rank 0 adds them in one order).
const WALL_PROBES: &str = "\n[[probe]]\nname = \"left\"\nposition = [0.0, 0.03, 0.02]\nwindow = 0.002\nface = { diameter = 0.02, normal = [1.0, 0.0, 0.0], reading = \"wall\" }\n\n[[probe]]\nname = \"foot\"\nposition = [0.2, 0.03, 0.0]\nface = { diameter = 0.03, normal = [0.0, 0.0, 1.0], reading = \"wall\" }\n";

/// [`scene`] with `extra` TOML appended (a method's table).
fn scene_with(extra: &str) -> Scene {
    let text = crate::validation::narrow_dam_break(1.0, 1.0) + extra;
    Scene::parse(&text, "ranks test").unwrap()
}

/// Runs `steps` steps on the ranks `comm` (one rank when None) writing into `dir`; returns
/// rank 0's particles (position, velocity, density, pressure) in one-rank order.
fn run<S: SphMethod>(
    scene: &Scene,
    dir: &Path,
    comm: Option<Arc<dyn Comm>>,
    steps: usize,
) -> (Option<Vec<[u64; 8]>>, u64, Option<HaloStats>) {
    let ctx = SetupContext {
        scene,
        run_dir: dir,
        scheme: CouplingScheme::Parallel,
        peer_present: false,
    };
    let mut s = Sph::<S>::on_ranks(&ctx, comm).unwrap();
    for _ in 0..steps {
        let dt = s.dt_proposal().min(1e-3);
        s.advance(dt).unwrap();
    }
    s.write_frame(1, s.sys.time).unwrap();
    s.finish().unwrap();
    (
        s.sys.gathered_bits(),
        s.sys.sorts,
        s.sys.share.as_ref().map(|s| s.stats),
    )
}

/// `steps` steps of the dam break with the method `S` on 1, 2, 3 and 4 ranks: the same bits in
/// every particle and every file.
fn same_bits_on_one_to_four_ranks<S: SphMethod>(steps: usize) {
    same_bits_in::<S>(&scene(), steps);
}

/// [`same_bits_on_one_to_four_ranks`] in `scene`.
fn same_bits_in<S: SphMethod>(scene: &Scene, steps: usize) {
    let one = tempfile::tempdir().unwrap();
    let (reference, sorts, _) = run::<S>(scene, one.path(), None, steps);
    let reference = reference.unwrap();
    assert!(sorts > 20, "the lists were rebuilt {sorts} times only");
    for n in [2, 3, 4] {
        let dirs: Vec<_> = (0..n).map(|_| tempfile::tempdir().unwrap()).collect();
        let ranks = ThreadRanks::handles(n);
        let results: Vec<_> = std::thread::scope(|s| {
            let handles: Vec<_> = ranks
                .into_iter()
                .zip(&dirs)
                .map(|(c, d)| {
                    // Not on rayon's pool (`on_pool`): a rank waiting for another would hold
                    // one of its two workers, and the other rank might never get one.
                    s.spawn(move || run::<S>(scene, d.path(), Some(c), steps))
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        // Every rank held a halo, sent particles and rates, and the cuts moved.
        for (r, (_, _, stats)) in results.iter().enumerate() {
            let stats = stats.unwrap();
            assert!(
                stats.halo > 0 && stats.bytes_sent > 0,
                "{n} ranks, rank {r}: {stats:?}"
            );
            assert!(
                stats.rebalances > 0,
                "{n} ranks, rank {r}: the cuts never moved"
            );
            // Judged by the ranks' compute times too (which move them or not by the
            // machine's timing: the bits must not care).
            assert!(
                stats.time_imbalance > 0.0,
                "{n} ranks, rank {r}: the cuts were never judged by time"
            );
        }
        let got = results[0].0.as_ref().expect("rank 0 gathers");
        assert_eq!(got.len(), reference.len(), "{n} ranks: particle count");
        let first = got.iter().zip(&reference).position(|(a, b)| a != b);
        assert_eq!(first, None, "{n} ranks: the first particle that differs");
        for file in [
            "gauges.csv",
            "probes.csv",
            "particles_00001.vtp",
            "fluid.json",
        ] {
            let a = std::fs::read(one.path().join(file)).unwrap();
            let b = std::fs::read(dirs[0].path().join(file)).unwrap();
            assert!(a == b, "{n} ranks: {file} differs");
            assert!(
                !dirs[1].path().join(file).exists(),
                "{n} ranks: rank 1 wrote {file}"
            );
        }
    }
}

#[test]
fn wcsph_gives_the_same_bits_on_one_to_four_ranks() {
    same_bits_on_one_to_four_ranks::<Wcsph>(800);
}

#[test]
fn muller_gives_the_same_bits_on_one_to_four_ranks() {
    same_bits_on_one_to_four_ranks::<Muller>(400);
}

/// The Riemann flux, and a sensor's face on the floor 3 cm across where the column's foot is
/// (its seven points fall on either side of a cut as the cuts move): each point read by its
/// owner, the face's mean the one rank's.
#[test]
fn riemann_and_a_probe_face_give_the_same_bits_on_one_to_four_ranks() {
    let face = "\n[[probe]]\nname = \"face\"\nposition = [0.2, 0.03, 0.0]\nwindow = 0.002\nface = { diameter = 0.03, normal = [0.0, 0.0, 1.0] }\n";
    same_bits_in::<Riemann>(&scene_with(&format!("{face}{WALL_PROBES}")), 800);
}

/// DFSPH's steps are capped at the scene's 1 ms (its CFL step is longer): 150 steps run the
/// front as far as WCSPH's 800.
#[test]
fn dfsph_gives_the_same_bits_on_one_to_four_ranks() {
    same_bits_on_one_to_four_ranks::<Dfsph>(150);
}

/// DFSPH's other options on ranks: the pressure-change stop (its second exact sum), the walls'
/// pressure extrapolated from the water's (which reads the halo's densities) and the continued
/// surface density.
#[test]
fn dfsph_options_give_the_same_bits_on_one_to_four_ranks() {
    let scene = scene_with(&format!(
        "{WALL_PROBES}\n[fluid.dfsph]\npressure_tolerance = 5.0\nwall_pressure = \"extrapolated\"\ncontinued_surface = true\n"
    ));
    same_bits_in::<Dfsph>(&scene, 150);
}

/// Steps `steps` steps, then returns the checkpoint (rank 0's; empty on the others).
fn steps_then_save<S: SphMethod>(s: &mut Sph<S>, steps: usize) -> Vec<u8> {
    for _ in 0..steps {
        let dt = s.dt_proposal().min(1e-3);
        s.advance(dt).unwrap();
    }
    s.save_state().unwrap()
}

/// Runs `f` on `n` thread ranks, each with its own run directory; returns rank 0's result.
fn on_threads<T: Send>(
    n: usize,
    dirs: &[tempfile::TempDir],
    f: impl Fn(Arc<dyn Comm>, &Path) -> T + Sync,
) -> T {
    let ranks = ThreadRanks::handles(n);
    std::thread::scope(|s| {
        let handles: Vec<_> = ranks
            .into_iter()
            .zip(dirs)
            .map(|(c, d)| {
                let f = &f;
                s.spawn(move || f(c, d.path()))
            })
            .collect();
        let mut results: Vec<T> = handles.into_iter().map(|h| h.join().unwrap()).collect();
        results.swap_remove(0)
    })
}

/// `before` steps of the dam break with the method `S` on 2 ranks save the checkpoint one rank
/// saves, and 3 ranks resume from it to the bits of the one-rank run `after` steps on.
fn checkpoint_on_two_ranks_resumes_on_three<S: SphMethod>(before: usize, after: usize) {
    let scene = scene();
    fn ctx<'a>(scene: &'a Scene, dir: &'a Path) -> SetupContext<'a> {
        SetupContext {
            scene,
            run_dir: dir,
            scheme: CouplingScheme::Parallel,
            peer_present: false,
        }
    }
    // One rank, straight through, saving halfway.
    let one = tempfile::tempdir().unwrap();
    let mut s = Sph::<S>::on_ranks(&ctx(&scene, one.path()), None).unwrap();
    let saved = steps_then_save(&mut s, before);
    steps_then_save(&mut s, after);
    let reference = s.sys.gathered_bits().unwrap();
    // Two ranks save the same bytes.
    let dirs: Vec<_> = (0..3).map(|_| tempfile::tempdir().unwrap()).collect();
    let on_two = on_threads(2, &dirs[..2], |c, d| {
        let mut s = Sph::<S>::on_ranks(&ctx(&scene, d), Some(c)).unwrap();
        steps_then_save(&mut s, before)
    });
    assert!(
        on_two == saved,
        "the checkpoint of 2 ranks differs from one rank's"
    );
    // Three ranks resume from it (rank 0 continues the files of the one-rank run's copy).
    for f in ["gauges.csv", "probes.csv"] {
        std::fs::copy(one.path().join(f), dirs[0].path().join(f)).unwrap();
    }
    let resumed = on_threads(3, &dirs, |c, d| {
        let mut s = Sph::<S>::on_ranks(&ctx(&scene, d), Some(c)).unwrap();
        s.restore_state(&saved, d).unwrap();
        steps_then_save(&mut s, after);
        s.sys.gathered_bits()
    });
    let resumed = resumed.expect("rank 0 gathers");
    let first = resumed.iter().zip(&reference).position(|(a, b)| a != b);
    assert_eq!(
        first, None,
        "resumed on 3 ranks: the first particle that differs"
    );
    assert_eq!(resumed.len(), reference.len());
}

#[test]
fn a_checkpoint_on_two_ranks_is_the_one_rank_file_and_resumes_on_three() {
    checkpoint_on_two_ranks_resumes_on_three::<Wcsph>(300, 200);
}

#[test]
fn a_dfsph_checkpoint_on_two_ranks_is_the_one_rank_file_and_resumes_on_three() {
    checkpoint_on_two_ranks_resumes_on_three::<Dfsph>(60, 40);
}
