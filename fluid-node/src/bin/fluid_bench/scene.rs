//! The bench's scene: a dam break of about `particles` particles in a 4 m × 1 m tank (the
//! water a 1 m × 1 m × 2 m column), with `[fluid.<solver>]` parameters as given.

use shared::scene::Scene;

/// The scene's end [s]: the bench steps towards it and never reaches it.
pub const END: f64 = 1.0;

/// The latest `--from` [s]: near t = 0.9 s the surge that met the far wall throws water over
/// the tank's 3 m top, out of the domain, and WCSPH stops there at 10⁵ particles.
pub const LAST_FROM: f64 = 0.8;

pub fn scene(solver: &str, particles: usize, params: &[String]) -> Scene {
    // N = 2·(a/dx)³ with a = 1 m.
    let dx = (2.0 / particles as f64).cbrt();
    let blk = |name: &str, min: [f64; 3], max: [f64; 3]| {
        format!(
            "[[block]]\nname = \"{name}\"\nkind = \"fixed\"\nshape = {{ type = \"box\", min = {min:?}, max = {max:?} }}\n\n"
        )
    };
    let t = 0.2;
    let walls = [
        blk("floor", [-t, -t, -t], [4.0 + t, 1.0 + t, 0.0]),
        blk("left", [-t, -t, -t], [0.0, 1.0 + t, 3.0]),
        blk("right", [4.0, -t, -t], [4.0 + t, 1.0 + t, 3.0]),
        blk("south", [-t, -t, -t], [4.0 + t, 0.0, 3.0]),
        blk("north", [-t, 1.0, -t], [4.0 + t, 1.0 + t, 3.0]),
    ]
    .concat();
    let text = format!(
        "name = \"bench\"\n[time]\nend = {END:?}\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [4.0, 1.0, 3.0]\n\
         [fluid]\nsolver = \"{solver}\"\ndx = {dx}\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 2.0] }}\n\n{walls}\
         [fluid.{solver}]\n{}\n",
        params.join("\n")
    );
    Scene::parse(&text, "bench (generated)").expect("bench scene is valid")
}
