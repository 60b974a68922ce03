use solid_node::verification::*;
fn main() {
    let s = scene("resting", [0.0, 0.0, -9.81], 5.0, "", "normal_stiffness = 1e6\nshear_ratio = 0.0", &[
        block_toml("floor", "fixed", 2500.0, &box_corners([-1.0, -1.0, -0.5], [1.0, 1.0, 0.0]), ""),
        block_toml("block", "free", 2500.0, &box_corners([-0.1, -0.1, 0.0], [0.1, 0.1, 0.4]), ""),
    ]);
    let h = Harness::new(&s, "explicit").unwrap();
    let w = h.world();
    let mut scratch = Vec::new();
    println!("m {} floor {} current {} 4k/m {}", w.blocks[1].mass, solid_node::stability::resting_floor(w).sqrt(), solid_node::stability::current(w, &mut scratch).sqrt(), (4e6f64/40.0).sqrt());
    println!("contacts {}", w.contacts.len());
}
