use solid_node::verification::*;
use shared::solver::Solver;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let damping: f64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(0.2);
    let inc = Incline { alpha: 20.0, phi: 30.0, cohesion: 0.0, b: 0.4, h: 0.2 };
    let mut s = inc.scene();
    s.solid.contact.damping_ratio = damping;
    let mut h = Harness::new(&s, "explicit").unwrap();
    let rock = h.solver.block_index("rock").unwrap();
    let start = h.world().blocks[rock].position;
    let mut n = 0;
    while h.time() < 1.0 {
        let dt = h.solver.dt_proposal().min(1e-3);
        h.solver.advance(dt).unwrap();
        n += 1;
        if n % 200 == 0 || n < 12 {
            let w = h.world();
            let b = &w.blocks[rock];
            let d = (b.position - start).dot(&inc.downhill());
            let states: Vec<String> = w.contacts.iter().map(|c| format!("{:?}{:?}{}:{:.2e}/{:.1}", c.key.feature, c.state, c.key.i, c.gap, c.normal_force)).collect();
            println!("t {:.4} dt {dt:.2e} d {d:.3e} v {:.3e} w {:.2e} {}", w.time, b.velocity.norm(), b.angular_velocity.norm(), states.join(" "));
        }
    }
}
