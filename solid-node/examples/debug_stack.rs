use solid_node::verification::*;
use shared::solver::Solver;
fn main() {
    let g = 9.81;
    let mut blocks = vec![block_toml("floor", "fixed", 2500.0, &box_corners([-2.0, -2.0, -0.5], [2.0, 2.0, 0.0]), "")];
    for i in 0..2 {
        let s = if i % 2 == 0 { 0.03 } else { -0.03 };
        let z = 0.3 * i as f64;
        let v = box_corners([-0.2 + s, -0.2 - s, z], [0.2 + s, 0.2 - s, z + 0.3]);
        blocks.push(block_toml(&format!("box{i}"), "free", 2500.0, &v, ""));
    }
    let s = scene("stack", [0.0, 0.0, -g], 10.0, "", "friction_angle = 30.0\ndamping_ratio = 0.1", &blocks);
    let mut h = Harness::new(&s, "explicit").unwrap();
    for c in &h.world().contacts { println!("{:?} p{} q{} pt {:?} n {:?} gap {:e}", c.key.feature, c.p, c.q, c.point.coords.as_slice(), c.normal.as_slice(), c.gap); }
    for _ in 0..3 {
        let dt = h.solver.dt_proposal();
        let r = h.solver.advance(dt);
        println!("dt {dt:e} {:?}", r.err());
        for c in &h.world().contacts { println!("{:?} p{} q{} n {:?} gap {:e} f {:?}", c.key.feature, c.p, c.q, c.normal.as_slice(), c.gap, c.force.as_slice()); }
    }
}
