//! Scenes built in code for the verification cases: boxes, rotations, blocks and the scene text.

use shared::math::Real;
use shared::scene::Scene;

/// Standard gravity [m/s²], the scenes' `[solid] gravity` magnitude.
pub(crate) const G: Real = shared::math::STANDARD_GRAVITY;

/// Corners of an axis-aligned box.
pub fn box_corners(min: [Real; 3], max: [Real; 3]) -> Vec<[Real; 3]> {
    let mut v = Vec::with_capacity(8);
    for &x in &[min[0], max[0]] {
        for &y in &[min[1], max[1]] {
            for &z in &[min[2], max[2]] {
                v.push([x, y, z]);
            }
        }
    }
    v
}

/// Rotation by `alpha` about +y: x̂ goes to (cos α, 0, −sin α), i.e. downhill for a slope of α.
pub fn rotate_y(v: &[[Real; 3]], alpha: Real) -> Vec<[Real; 3]> {
    let (s, c) = alpha.sin_cos();
    v.iter()
        .map(|p| [c * p[0] + s * p[2], p[1], -s * p[0] + c * p[2]])
        .collect()
}

/// The fixed 2 m × 2 m floor slab under the origin (top face at z = 0) that the contact cases
/// rest their blocks on.
pub fn floor_toml() -> String {
    block_toml(
        "floor",
        "fixed",
        2500.0,
        &box_corners([-1.0, -1.0, -0.5], [1.0, 1.0, 0.0]),
        "",
    )
}

/// A `[[block]]` table of convex shape.
pub fn block_toml(
    name: &str,
    kind: &str,
    density: Real,
    vertices: &[[Real; 3]],
    extra: &str,
) -> String {
    let v: Vec<String> = vertices
        .iter()
        .map(|p| format!("[{:.15e}, {:.15e}, {:.15e}]", p[0], p[1], p[2]))
        .collect();
    format!(
        "[[block]]\nname = \"{name}\"\nkind = \"{kind}\"\ndensity = {density:.6}\nshape = {{ type = \"convex\", vertices = [{}] }}\n{extra}\n",
        v.join(", ")
    )
}

/// A whole scene: header, `[solid]` lines (solver tables such as `[solid.implicit]` may follow
/// them), `[solid.contact]` lines, blocks. Checked by [`crate::check_scene`] too.
pub fn scene(
    name: &str,
    gravity: [Real; 3],
    half_extent: Real,
    solid: &str,
    contact: &str,
    blocks: &[String],
) -> Scene {
    let h = half_extent;
    let text = format!(
        "name = \"{name}\"\ngravity = [{:.15e}, {:.15e}, {:.15e}]\n[time]\nend = 10.0\ndt_max = 1e-3\ndt_min = 1e-12\n\
         [domain]\nmin = [{}, {}, {}]\nmax = [{h}, {h}, {h}]\n[output]\ninterval = 0.05\nvtk = false\n\
         [solid]\n{solid}\n[solid.contact]\n{contact}\n{}",
        gravity[0],
        gravity[1],
        gravity[2],
        -h,
        -h,
        -h,
        blocks.join("\n")
    );
    Scene::parse_checked(&text, name, &[&crate::check_scene])
        .unwrap_or_else(|e| panic!("verification scene {name} is invalid: {e}\n{text}"))
}
