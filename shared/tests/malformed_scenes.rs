//! Malformed scenes, one table row each: the scene (the default scene with one change) must be
//! refused with an error that names the field, on the line where the field is written.
//!
//! The solver parameter tables (`[fluid.<name>]`, `[solid.<name>]`) and the size limits are
//! checked by the coupler (it knows the solver registries and the machine): see
//! `coupler/tests/cli.rs`.

use shared::math::long_number;
use shared::scene::{DEFAULT_SCENE, Scene, SceneError};

/// The default scene with `from` replaced by `to` (once; `from` must be there).
fn edit(from: &str, to: &str) -> String {
    assert!(
        DEFAULT_SCENE.contains(from),
        "the default scene has no {from:?}"
    );
    DEFAULT_SCENE.replacen(from, to, 1)
}

/// The default scene with `extra` appended.
fn plus(extra: &str) -> String {
    format!("{DEFAULT_SCENE}\n{extra}\n")
}

const WEDGE_PROFILE: &str = "profile = [[-0.179479, 0.783154], [0.320521, 0.55], [0.320521, 0.783154]], extent = [0.25, 0.55] }";
const KINEMATIC: &str = "[[block]]\nname = \"paddle\"\nkind = \"kinematic\"\nshape = { type = \"box\", min = [4.0, 0.3, 0.6], max = [4.2, 0.5, 0.8] }";

/// A slide whose region reaches 0.1 m above the domain: cut into 2 × 2 × 3 blocks, of which
/// the top four reach outside.
const SLIDE_PAST_THE_TOP: &str = "[[slide]]\nname = \"rock\"\ndensity = 2600.0\nregion = { type = \"box\", min = [2.0, 0.3, 1.4], max = [2.2, 0.5, 1.7] }\n[[slide.joint_set]]\ndip = 0.0\ndip_direction = 0.0\nspacing = 0.1\noffset = [2.0, 0.3, 1.4]\n[[slide.joint_set]]\ndip = 90.0\ndip_direction = 90.0\nspacing = 0.1\noffset = [2.0, 0.3, 1.4]\n[[slide.joint_set]]\ndip = 90.0\ndip_direction = 0.0\nspacing = 0.1\noffset = [2.0, 0.3, 1.4]";

struct Case {
    what: &'static str,
    text: String,
    /// The field the error must name (its dotted path).
    field: &'static str,
    /// Text of the line the field sits on; the error must give that line.
    line_has: &'static str,
}

fn case(what: &'static str, text: String, field: &'static str, line_has: &'static str) -> Case {
    Case {
        what,
        text,
        field,
        line_has,
    }
}

fn cases() -> Vec<Case> {
    let kin = |motion: &str| plus(&format!("{KINEMATIC}\n{motion}"));
    let extra_block = |name: &str, kind: &str, shape: &str| {
        plus(&format!(
            "[[block]]\nname = \"{name}\"\nkind = \"{kind}\"\nshape = {shape}"
        ))
    };
    vec![
        case(
            "empty name",
            edit("name = \"sliding_wedge\"", "name = \"\""),
            "name",
            "name = \"\"",
        ),
        case(
            "name climbs out of runs/",
            edit("name = \"sliding_wedge\"", "name = \"../../evil\""),
            "name",
            "evil",
        ),
        case(
            "name with a slash",
            edit("name = \"sliding_wedge\"", "name = \"a/b\""),
            "name",
            "a/b",
        ),
        case(
            "gravity NaN",
            edit("[time]", "gravity = [0.0, 0.0, nan]\n[time]"),
            "gravity",
            "gravity",
        ),
        case(
            "gravity absurd",
            edit("[time]", "gravity = [0.0, 0.0, -1e5]\n[time]"),
            "gravity",
            "gravity",
        ),
        case(
            "end zero",
            edit("end = 2.5", "end = 0.0"),
            "time.end",
            "end = 0.0",
        ),
        case(
            "end infinite",
            edit("end = 2.5", "end = inf"),
            "time.end",
            "end = inf",
        ),
        case(
            "dt_max negative",
            edit("dt_max = 1e-3", "dt_max = -1e-3"),
            "time.dt_max",
            "dt_max",
        ),
        case(
            "dt_min above dt_max",
            edit("dt_max = 1e-3", "dt_max = 1e-3\ndt_min = 1.0"),
            "time.dt_min",
            "dt_min",
        ),
        case(
            "domain.min with 4 numbers",
            edit(
                "min = [-0.6, -0.05, -0.05]",
                "min = [-0.6, -0.05, -0.05, 7.0]",
            ),
            "domain.min",
            "7.0",
        ),
        case(
            "domain.max below min",
            edit("max = [5.05, 0.85, 1.6]", "max = [5.05, -0.85, 1.6]"),
            "domain.max",
            "-0.85",
        ),
        case(
            "domain.max absurd",
            edit("max = [5.05, 0.85, 1.6]", "max = [5.05, 0.85, 1e300]"),
            "domain.max",
            "1e300",
        ),
        case(
            "output.interval zero",
            edit("interval = 0.05", "interval = 0.0"),
            "output.interval",
            "interval",
        ),
        case(
            "output.interval far below dt",
            edit("interval = 0.05", "interval = 1e-9"),
            "output.interval",
            "interval",
        ),
        case(
            "water density negative",
            edit("density = 1000.0", "density = -1000.0"),
            "fluid.density",
            "-1000.0",
        ),
        case(
            "dx zero",
            edit("\ndx = 0.04", "\ndx = 0.0"),
            "fluid.dx",
            "dx = 0.0",
        ),
        case(
            "dx NaN",
            edit("\ndx = 0.04", "\ndx = nan"),
            "fluid.dx",
            "dx = nan",
        ),
        case(
            "dx coarser than the domain",
            edit("\ndx = 0.04", "\ndx = 10.0"),
            "fluid.dx",
            "dx = 10.0",
        ),
        case(
            "viscosity negative",
            edit("\ndx = 0.04", "\ndx = 0.04\nkinematic_viscosity = -1e-6"),
            "fluid.kinematic_viscosity",
            "kinematic_viscosity",
        ),
        case(
            "density ratio bound below 1",
            edit("\ndx = 0.04", "\ndx = 0.04\ndensity_ratio_bound = 0.9"),
            "fluid.density_ratio_bound",
            "density_ratio_bound = 0.9",
        ),
        case(
            "stray fluid value",
            edit("\ndx = 0.04", "\ndx = 0.04\ndxx = 0.1"),
            "fluid.dxx",
            "dxx",
        ),
        case(
            "water outside the domain",
            edit("max = [5.0, 0.8, 0.48]", "max = [9.0, 0.8, 0.48]"),
            "fluid.water[0].shape",
            "9.0",
        ),
        case(
            "water box empty",
            edit("max = [5.0, 0.8, 0.48]", "max = [5.0, 0.8, 0.0]"),
            "fluid.water[0].shape",
            "0.8, 0.0]",
        ),
        case(
            "stray solid value",
            edit(
                "solver = \"explicit\"",
                "solver = \"explicit\"\nsafety_factor = 0.5",
            ),
            "solid.safety_factor",
            "safety_factor",
        ),
        case(
            "friction angle 95°",
            edit("friction_angle = 5.0", "friction_angle = 95.0"),
            "solid.contact.friction_angle",
            "95.0",
        ),
        case(
            "shear ratio negative",
            edit(
                "friction_angle = 5.0",
                "friction_angle = 5.0\nshear_ratio = -0.4",
            ),
            "solid.contact.shear_ratio",
            "shear_ratio",
        ),
        case(
            "cohesion NaN",
            edit(
                "friction_angle = 5.0",
                "friction_angle = 5.0\ncohesion = nan",
            ),
            "solid.contact.cohesion",
            "cohesion",
        ),
        case(
            "allowed penetration zero",
            edit(
                "friction_angle = 5.0",
                "friction_angle = 5.0\nallowed_penetration = 0.0",
            ),
            "solid.contact.allowed_penetration",
            "allowed_penetration",
        ),
        case(
            "damping ratio 2",
            edit(
                "friction_angle = 5.0",
                "friction_angle = 5.0\ndamping_ratio = 2.0",
            ),
            "solid.contact.damping_ratio",
            "damping_ratio",
        ),
        case(
            "normal stiffness zero",
            edit(
                "friction_angle = 5.0",
                "friction_angle = 5.0\nnormal_stiffness = 0.0",
            ),
            "solid.contact.normal_stiffness",
            "normal_stiffness",
        ),
        case(
            "penalty stiffness negative",
            edit(
                "scheme = \"parallel\"",
                "scheme = \"parallel\"\npenalty_stiffness = -1.0",
            ),
            "coupling.penalty_stiffness",
            "penalty_stiffness",
        ),
        case(
            "penalty damping NaN",
            edit(
                "scheme = \"parallel\"",
                "scheme = \"parallel\"\npenalty_damping = nan",
            ),
            "coupling.penalty_damping",
            "penalty_damping",
        ),
        case(
            "margin zero",
            edit(
                "scheme = \"parallel\"",
                "scheme = \"parallel\"\nmargin = 0.0",
            ),
            "coupling.margin",
            "margin",
        ),
        case(
            "duplicate block name",
            edit("name = \"far_wall\"", "name = \"floor\""),
            "block[1].name",
            "name = \"floor\"",
        ),
        case(
            "block name with a comma",
            edit("name = \"floor\"", "name = \"floor,1\""),
            "block[0].name",
            "floor,1",
        ),
        case(
            "block name with a newline",
            edit("name = \"floor\"", "name = \"floor\\nx\""),
            "block[0].name",
            "floor\\nx",
        ),
        case(
            "block name with a quote",
            edit("name = \"floor\"", "name = 'fl\"oor'"),
            "block[0].name",
            "fl\"oor",
        ),
        case(
            "free block density zero",
            edit("density = 2500.0", "density = 0.0"),
            "block[5].density",
            "density = 0.0",
        ),
        case(
            "free block velocity infinite",
            edit(
                "density = 2500.0",
                "density = 2500.0\nvelocity = [inf, 0.0, 0.0]",
            ),
            "block[5].velocity",
            "velocity",
        ),
        case(
            "free block spin NaN",
            edit(
                "density = 2500.0",
                "density = 2500.0\nangular_velocity = [0.0, nan, 0.0]",
            ),
            "block[5].angular_velocity",
            "angular_velocity",
        ),
        case(
            "motion on a free block",
            edit(
                "density = 2500.0",
                "density = 2500.0\nmotion = { type = \"linear\", velocity = [1.0, 0.0, 0.0] }",
            ),
            "block[5].motion",
            "motion",
        ),
        case(
            "kinematic block without motion",
            plus(KINEMATIC),
            "block[6].motion",
            "[[block]]",
        ),
        case(
            "kinematic velocity NaN",
            kin("motion = { type = \"linear\", velocity = [nan, 0.0, 0.0] }"),
            "block[6].motion.velocity",
            "nan",
        ),
        case(
            "kinematic velocity infinite",
            kin("motion = { type = \"linear\", velocity = [0.0, inf, 0.0] }"),
            "block[6].motion.velocity",
            "inf",
        ),
        case(
            "kinematic velocity absurd",
            kin("motion = { type = \"linear\", velocity = [0.0, 0.0, 1e9] }"),
            "block[6].motion.velocity",
            "1e9",
        ),
        case(
            "sine period zero",
            kin("motion = { type = \"sine\", amplitude = [0.1, 0.0, 0.0], period = 0.0 }"),
            "block[6].motion.period",
            "period",
        ),
        case(
            "sine amplitude infinite",
            kin("motion = { type = \"sine\", amplitude = [inf, 0.0, 0.0], period = 1.0 }"),
            "block[6].motion.amplitude",
            "amplitude",
        ),
        case(
            "sine phase NaN",
            kin(
                "motion = { type = \"sine\", amplitude = [0.1, 0.0, 0.0], period = 1.0, phase = nan }",
            ),
            "block[6].motion.phase",
            "phase",
        ),
        case(
            "sine ramp negative",
            kin(
                "motion = { type = \"sine\", amplitude = [0.1, 0.0, 0.0], period = 1.0, ramp = -1.0 }",
            ),
            "block[6].motion.ramp",
            "ramp",
        ),
        case(
            "sine peak speed beyond any landslide",
            kin("motion = { type = \"sine\", amplitude = [1.0, 0.0, 0.0], period = 0.001 }"),
            "block[6].motion.period",
            "period = 0.001",
        ),
        case(
            "kinematic block starting inside a fixed one",
            plus(
                "[[block]]\nname = \"paddle\"\nkind = \"kinematic\"\nshape = { type = \"box\", min = [4.9, 0.3, 0.6], max = [5.1, 0.5, 0.8] }\nmotion = { type = \"sine\", amplitude = [0.1, 0.0, 0.0], period = 2.0 }",
            ),
            "block[6].shape",
            "min = [4.9",
        ),
        case(
            "slide region reaching into the far wall",
            plus(
                "[[slide]]\nname = \"rock\"\ndensity = 2600.0\nregion = { type = \"box\", min = [4.7, 0.3, 0.6], max = [5.04, 0.5, 0.8] }\n[[slide.joint_set]]\ndip = 0.0\ndip_direction = 0.0\nspacing = 0.1",
            ),
            "slide[0].region",
            "region = {",
        ),
        case(
            "slide region reaching past the domain's top",
            plus(SLIDE_PAST_THE_TOP),
            "slide[0].region",
            "region = {",
        ),
        case(
            "an end before the smallest step",
            edit("end = 2.5", "end = 1e-300"),
            "time.end",
            "end = 1e-300",
        ),
        // Numbers far from 1 in fields whose messages print them or numbers made from them
        // (each printed hundreds of digits: `numbers_in_errors_are_readable`).
        case(
            "output.interval of 1e-300",
            edit("interval = 0.05", "interval = 1e-300"),
            "output.interval",
            "interval = 1e-300",
        ),
        case(
            "time.end of 1e300",
            edit("end = 2.5", "end = 1e300"),
            "output.interval",
            "interval = 0.05",
        ),
        case(
            "Eq. 22 margin of 1e300",
            edit(
                "scheme = \"parallel\"",
                "scheme = \"parallel\"\nmargin = 1e300",
            ),
            "coupling.margin",
            "margin = 1e300",
        ),
        case(
            "Eq. 22 margin of 2.5 particle spacings",
            edit(
                "scheme = \"parallel\"",
                "scheme = \"parallel\"\nmargin = 0.1",
            ),
            "coupling.margin",
            "margin = 0.1",
        ),
        case(
            "penalty stiffness past any step",
            edit(
                "scheme = \"parallel\"",
                "scheme = \"parallel\"\npenalty_stiffness = 1e300",
            ),
            "coupling.penalty_stiffness",
            "penalty_stiffness = 1e300",
        ),
        case(
            "free block starting 4 cm inside a fixed one",
            plus(
                "[[block]]\nname = \"boulder\"\nkind = \"free\"\ndensity = 2600.0\nshape = { type = \"box\", min = [4.76, 0.3, 0.6], max = [5.04, 0.5, 0.8] }",
            ),
            "block[6].shape",
            "min = [4.76",
        ),
        case(
            "output.max_frames negative",
            edit("interval = 0.05", "interval = 0.05\nmax_frames = -1.0"),
            "output.max_frames",
            "max_frames",
        ),
        case(
            "block friction angle negative",
            edit(
                "density = 2500.0",
                "density = 2500.0\nfriction_angle = -5.0",
            ),
            "block[5].friction_angle",
            "-5.0",
        ),
        case(
            "block cohesion negative",
            edit("density = 2500.0", "density = 2500.0\ncohesion = -1.0"),
            "block[5].cohesion",
            "cohesion",
        ),
        case(
            "elastic fixed block",
            edit(
                "kind = \"fixed\"",
                "kind = \"fixed\"\nelastic = { young_modulus = 1e10 }",
            ),
            "block[0].elastic",
            "elastic",
        ),
        case(
            "Poisson ratio 0.5",
            edit(
                "density = 2500.0",
                "density = 2500.0\nelastic = { young_modulus = 1e10, poisson_ratio = 0.5 }",
            ),
            "block[5].elastic.poisson_ratio",
            "poisson_ratio",
        ),
        case(
            "Young's modulus zero",
            edit(
                "density = 2500.0",
                "density = 2500.0\nelastic = { young_modulus = 0.0 }",
            ),
            "block[5].elastic.young_modulus",
            "young_modulus",
        ),
        case(
            "self-intersecting prism profile",
            extra_block(
                "bow",
                "fixed",
                "{ type = \"prism\", axis = \"y\", profile = [[2.0, 1.0], [3.0, 1.5], [3.0, 1.0], [2.0, 1.5]], extent = [0.0, 0.5] }",
            ),
            "block[6].shape",
            "[2.0, 1.5]",
        ),
        case(
            "flat tetrahedron",
            extra_block(
                "flat",
                "fixed",
                "{ type = \"convex\", vertices = [[2.0, 0.1, 1.0], [3.0, 0.1, 1.0], [2.0, 0.6, 1.0], [2.3, 0.3, 1.0000000000001]] }",
            ),
            "block[6].shape",
            "1.0000000000001",
        ),
        case(
            "vertices at 1e200",
            extra_block(
                "far",
                "fixed",
                "{ type = \"convex\", vertices = [[0.0, 0.0, 0.0], [1e200, 0.0, 0.0], [0.0, 1e200, 0.0], [0.0, 0.0, 1e200]] }",
            ),
            "block[6].shape",
            "1e200",
        ),
        case(
            "a 1 nm free block",
            extra_block(
                "grain",
                "free",
                "{ type = \"box\", min = [2.0, 0.4, 1.0], max = [2.000000001, 0.400000001, 1.000000001] }",
            ),
            "block[6].shape",
            "2.000000001",
        ),
        case(
            "two free blocks in one place",
            extra_block(
                "twin",
                "free",
                &format!("{{ type = \"prism\", axis = \"y\", {WEDGE_PROFILE}"),
            ),
            "block[6].shape",
            "0.320521",
        ),
        case(
            "non-convex convex block",
            extra_block(
                "dent",
                "fixed",
                "{ type = \"convex\", vertices = [[2,0,0],[3,0,0],[2,1,0],[2,0,1],[2.1,0.1,0.1]] }",
            ),
            "block[6].shape",
            "2.1,0.1,0.1",
        ),
        case(
            "convex vertex with 4 numbers",
            extra_block(
                "v4",
                "fixed",
                "{ type = \"convex\", vertices = [[2,0,0],[3,0,0,9],[2,1,0],[2,0,1]] }",
            ),
            "block[6].shape",
            "[3,0,0,9]",
        ),
        case(
            "profile point with 3 numbers",
            extra_block(
                "p3",
                "fixed",
                "{ type = \"prism\", axis = \"y\", profile = [[2.0, 1.0, 5.0], [3.0, 1.0], [3.0, 1.5]], extent = [0.0, 0.5] }",
            ),
            "block[6].shape",
            "[2.0, 1.0, 5.0]",
        ),
        case(
            "box min with 4 numbers",
            edit("min = [5.0, -0.2, -0.2]", "min = [5.0, -0.2, -0.2, 1.0]"),
            "block[1].shape",
            "-0.2, -0.2, 1.0]",
        ),
        case(
            "free block outside the domain",
            edit("extent = [0.25, 0.55]", "extent = [0.25, 1.55]"),
            "block[5].shape",
            "1.55",
        ),
        case(
            "fixed block above an open top",
            edit("max = [5.2, 1.0, 1.6] }", "max = [5.2, 1.0, 1.8] }"),
            "block[1].shape",
            "max = [5.2, 1.0, 1.8]",
        ),
        case(
            "gauge outside the domain",
            edit("\nx = 1.5\n", "\nx = 15.0\n"),
            "gauge[0].x",
            "x = 15.0",
        ),
        case(
            "duplicate gauge name",
            edit("name = \"G2\"", "name = \"G1\""),
            "gauge[1].name",
            "name = \"G1\"",
        ),
        case(
            "gauge name with a comma",
            edit("name = \"G3\"", "name = \"G,3\""),
            "gauge[2].name",
            "G,3",
        ),
        case(
            "gauge name padded",
            edit("name = \"G4\"", "name = \" G4\""),
            "gauge[3].name",
            "\" G4\"",
        ),
        case(
            "runup box empty",
            plus("[[runup]]\nname = \"beach\"\nmin = [3.0, 0.0]\nmax = [2.0, 0.8]"),
            "runup[0].max",
            "max = [2.0, 0.8]",
        ),
        case(
            "runup box with 3 numbers",
            plus("[[runup]]\nname = \"beach\"\nmin = [0.0, 0.0, 0.0]\nmax = [2.0, 0.8]"),
            "runup[0].min",
            "min = [0.0, 0.0, 0.0]",
        ),
        case(
            "runup box outside the domain",
            plus("[[runup]]\nname = \"beach\"\nmin = [30.0, 0.0]\nmax = [32.0, 0.8]"),
            "runup[0].min",
            "min = [30.0, 0.0]",
        ),
        case(
            "duplicate runup name",
            plus(
                "[[runup]]\nname = \"beach\"\nmin = [0.0, 0.0]\nmax = [2.0, 0.8]\n[[runup]]\nname = \"beach\"\nmin = [3.0, 0.0]\nmax = [4.0, 0.8]",
            ),
            "runup[1].name",
            "name = \"beach\"",
        ),
        case(
            "probe outside the domain",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, -5.0]",
            ),
            "probe[0].position",
            "-5.0",
        ),
        case(
            "duplicate probe name",
            plus("[[probe]]\nname = \"far_wall_bottom\"\nposition = [4.0, 0.4, 0.05]"),
            "probe[1].name",
            "name = \"far_wall_bottom\"",
        ),
        case(
            "probe name with a quote",
            edit("name = \"far_wall_bottom\"", "name = 'far\"bottom'"),
            "probe[0].name",
            "far\"bottom",
        ),
        case(
            "probe position with 2 numbers",
            edit("position = [4.95, 0.4, 0.05]", "position = [4.95, 0.4]"),
            "probe[0].position",
            "[4.95, 0.4]",
        ),
        case(
            "probe window of 1e-300 s",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nwindow = 1e-300",
            ),
            "probe[0].window",
            "window = 1e-300",
        ),
        case(
            "runup box reaching infinity",
            plus("[[runup]]\nname = \"beach\"\nmin = [0.0, 0.0]\nmax = [inf, 0.8]"),
            "runup[0].max",
            "max = [inf, 0.8]",
        ),
        case(
            "runup box reaching 1e300",
            plus("[[runup]]\nname = \"beach\"\nmin = [-1e300, 0.0]\nmax = [2.0, 0.8]"),
            "runup[0].min",
            "min = [-1e300, 0.0]",
        ),
        case(
            "probe window zero",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nwindow = 0.0",
            ),
            "probe[0].window",
            "window = 0.0",
        ),
        case(
            "probe window negative",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nwindow = -0.001",
            ),
            "probe[0].window",
            "window = -0.001",
        ),
        case(
            "probe window longer than the run",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nwindow = 1000",
            ),
            "probe[0].window",
            "window = 1000",
        ),
        case(
            "probe window not finite",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nwindow = inf",
            ),
            "probe[0].window",
            "window = inf",
        ),
        case(
            "probe face of diameter zero",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0, normal = [-1.0, 0.0, 0.0] }",
            ),
            "probe[0].face.diameter",
            "diameter = 0.0",
        ),
        case(
            "probe face with a zero normal",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [0.0, 0.0, 0.0] }",
            ),
            "probe[0].face.normal",
            "normal = [0.0, 0.0, 0.0]",
        ),
        case(
            "fluid rows shifted along two axes",
            edit("\ndx = 0.04", "\ndx = 0.04\nrow_shift = [0.25, 0.25, 0.0]"),
            "fluid.row_shift",
            "row_shift = [0.25, 0.25, 0.0]",
        ),
        case(
            "fluid rows shifted by more than half a spacing",
            edit("\ndx = 0.04", "\ndx = 0.04\nrow_shift = [0.0, 0.75, 0.0]"),
            "fluid.row_shift",
            "row_shift = [0.0, 0.75, 0.0]",
        ),
        case(
            "fluid rows shifted by nan",
            edit("\ndx = 0.04", "\ndx = 0.04\nrow_shift = [nan, 0.0, 0.0]"),
            "fluid.row_shift",
            "row_shift = [nan, 0.0, 0.0]",
        ),
        case(
            "fluid row draw without shifted rows",
            edit("\ndx = 0.04", "\ndx = 0.04\nrow_draw = 3"),
            "fluid.row_draw",
            "row_draw = 3",
        ),
        case(
            "fluid row draw past the largest",
            edit(
                "\ndx = 0.04",
                "\ndx = 0.04\nrow_shift = [0.25, 0.0, 0.0]\nrow_draw = 4000000000",
            ),
            "fluid.row_draw",
            "row_draw = 4000000000",
        ),
        case(
            "fluid row draw negative",
            edit(
                "\ndx = 0.04",
                "\ndx = 0.04\nrow_shift = [0.25, 0.0, 0.0]\nrow_draw = -1",
            ),
            "row_draw",
            "-1",
        ),
        case(
            "probe face's span along its normal",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], span = [0.1, 0.0, 0.0] }",
            ),
            "probe[0].face.span",
            "span = [0.1, 0.0, 0.0]",
        ),
        case(
            "probe face's span zero",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], span = [0.0, 0.0, 0.0] }",
            ),
            "probe[0].face.span",
            "span = [0.0, 0.0, 0.0]",
        ),
        case(
            "probe face's span a million diameters long",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], span = [0.0, 4200.0, 0.0] }",
            ),
            "probe[0].face.span",
            "span = [0.0, 4200.0, 0.0]",
        ),
        case(
            "probe face's span infinite",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], span = [0.0, inf, 0.0] }",
            ),
            "probe[0].face.span",
            "span = [0.0, inf, 0.0]",
        ),
        case(
            "probe face's span of 1e300 m",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], span = [0.0, 1e300, 0.0] }",
            ),
            "probe[0].face.span",
            "span = [0.0, 1e300, 0.0]",
        ),
        case(
            "probe face's span reaching into a wall",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], span = [0.0, 0.0, 0.2] }",
            ),
            "probe[0].face.span",
            "span = [0.0, 0.0, 0.2]",
        ),
        case(
            "probe inside a fixed block",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [5.03, 0.4, 0.05]",
            ),
            "probe[0].position",
            "5.03",
        ),
        case(
            "probe with a face, inside a fixed block",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [5.03, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0] }",
            ),
            "probe[0].position",
            "5.03",
        ),
        case(
            "probe face turned into its wall",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [5.0, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [0.0, 0.0, 1.0] }",
            ),
            "probe[0].face.normal",
            "normal = [0.0, 0.0, 1.0]",
        ),
        case(
            "probe face with a misspelt field",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diametre = 0.0042, normal = [-1.0, 0.0, 0.0] }",
            ),
            "diametre",
            "diametre",
        ),
        case(
            "probe face reading the wall off the lattice's axes",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.5], reading = \"wall\" }",
            ),
            "probe[0].face.normal",
            "normal = [-1.0, 0.0, 0.5]",
        ),
        case(
            "probe face reading the wall with no wall behind it",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], reading = \"wall\" }",
            ),
            "probe[0].face.reading",
            "reading = \"wall\"",
        ),
        case(
            "probe face reading the wall of penalty walls",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [5.0, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], reading = \"wall\" }",
            )
            .replacen("\ndx = 0.04", "\ndx = 0.04\nwalls = \"penalty\"", 1),
            "probe[0].face.reading",
            "reading = \"wall\"",
        ),
        case(
            "probe face reading misspelt",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [5.0, 0.4, 0.05]\nface = { diameter = 0.0042, normal = [-1.0, 0.0, 0.0], reading = \"walls\" }",
            ),
            "probe[0].face.reading",
            "walls",
        ),
        case(
            "probe window not a number",
            edit(
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nwindow = \"5 ms\"",
            ),
            "probe[0].window",
            "5 ms",
        ),
        case(
            "dx not a number",
            edit("\ndx = 0.04", "\ndx = \"fine\""),
            "fluid.dx",
            "\"fine\"",
        ),
        case(
            "unknown wall treatment",
            edit("\ndx = 0.04", "\ndx = 0.04\nwalls = \"sponge\""),
            "fluid.walls",
            "sponge",
        ),
        case(
            "misspelt time field",
            edit("end = 2.5", "end = 2.5\nendd = 3.0"),
            "endd",
            "endd",
        ),
        case(
            "unknown coupling scheme",
            edit("scheme = \"parallel\"", "scheme = \"sideways\""),
            "scheme",
            "sideways",
        ),
        case(
            "free block launched at 1e9 m/s",
            edit(
                "density = 2500.0",
                "density = 2500.0\nvelocity = [1e9, 0.0, 0.0]",
            ),
            "block[5].velocity",
            "velocity = [1e9",
        ),
        case(
            "free block spun at 1e9 rad/s",
            edit(
                "density = 2500.0",
                "density = 2500.0\nangular_velocity = [0.0, 1e9, 0.0]",
            ),
            "block[5].angular_velocity",
            "angular_velocity = [0.0, 1e9",
        ),
        case(
            "velocity on a fixed block (ignored)",
            edit(
                "kind = \"fixed\"",
                "kind = \"fixed\"\nvelocity = [1.0, 0.0, 0.0]",
            ),
            "block[0].velocity",
            "velocity = [1.0",
        ),
        case(
            "angular velocity on a kinematic block (ignored)",
            kin(
                "motion = { type = \"linear\", velocity = [0.1, 0.0, 0.0] }\nangular_velocity = [0.0, 0.0, 1.0]",
            ),
            "block[6].angular_velocity",
            "angular_velocity",
        ),
        case(
            "free block density 1e300",
            edit("density = 2500.0", "density = 1e300"),
            "block[5].density",
            "density = 1e300",
        ),
        case(
            "slide density 1e300",
            plus(
                "[[slide]]\nname = \"rock\"\ndensity = 1e300\nregion = { type = \"box\", min = [2.0, 0.3, 0.1], max = [2.4, 0.5, 0.3] }\n[[slide.joint_set]]\ndip = 0.0\ndip_direction = 0.0\nspacing = 0.1",
            ),
            "slide[0].density",
            "density = 1e300",
        ),
        case(
            "kinematic block driven through the far wall",
            kin("motion = { type = \"linear\", velocity = [1.0, 0.0, 0.0] }"),
            "block[6].motion.velocity",
            "velocity = [1.0",
        ),
        case(
            "kinematic block driven into the floor",
            kin("motion = { type = \"linear\", velocity = [0.0, 0.0, -0.25] }"),
            "block[6].motion.velocity",
            "velocity = [0.0, 0.0, -0.25]",
        ),
        case(
            "piston stroke into the far wall",
            plus(
                "[[block]]\nname = \"paddle\"\nkind = \"kinematic\"\nshape = { type = \"box\", min = [4.7, 0.3, 0.6], max = [4.9, 0.5, 0.8] }\nmotion = { type = \"sine\", amplitude = [0.12, 0.0, 0.0], period = 2.0, ramp = 1.0 }",
            ),
            "block[6].motion.amplitude",
            "amplitude = [0.12",
        ),
        case(
            "unknown block kind",
            edit("kind = \"free\"", "kind = \"loose\""),
            "kind",
            "loose",
        ),
    ]
}

/// Every refusal of the table prints its numbers readably (see [`long_number`]).
#[test]
fn every_malformed_scene_is_refused_naming_its_field_and_line() {
    let cases = cases();
    assert!(cases.len() >= 40, "{} cases", cases.len());
    let mut failures = Vec::new();
    for c in &cases {
        let lines: Vec<usize> = c
            .text
            .lines()
            .enumerate()
            .filter(|(_, l)| l.contains(c.line_has))
            .map(|(i, _)| i + 1)
            .collect();
        assert!(
            !lines.is_empty(),
            "{}: no line holds {:?}",
            c.what,
            c.line_has
        );
        let line = *lines.last().unwrap();
        match Scene::parse(&c.text, "case.toml") {
            Ok(_) => failures.push(format!("{}: accepted", c.what)),
            Err(SceneError::Invalid { errors, .. }) => {
                if let Some(e) = errors
                    .iter()
                    .find(|e| long_number(&e.to_string()).is_some())
                {
                    failures.push(format!("{}: a number of many digits in: {e}", c.what));
                }
                let named = errors.iter().find(|e| e.path == c.field);
                match named {
                    None => failures.push(format!(
                        "{}: no error names {}: {errors:?}",
                        c.what, c.field
                    )),
                    Some(e) if e.line != Some(line) || e.fix.is_empty() => failures.push(format!(
                        "{}: {} on line {:?}, expected line {line} (fix {:?})",
                        c.what, c.field, e.line, e.fix
                    )),
                    Some(_) => {}
                }
            }
            Err(e @ SceneError::Syntax { .. }) => {
                let msg = e.to_string();
                if !(msg.contains(c.field) && msg.contains(&format!("line {line}"))) {
                    failures.push(format!(
                        "{}: syntax error names neither {} nor line {line}: {msg}",
                        c.what, c.field
                    ));
                }
            }
            Err(e) => failures.push(format!("{}: {e}", c.what)),
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// The limits leave every scene of the repository alone.
#[test]
fn repository_scenes_stay_valid() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    for dir in [root.clone(), root.join("validation")] {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            if e.path().extension().is_some_and(|x| x == "toml") {
                Scene::load(&e.path()).unwrap_or_else(|err| panic!("{err}"));
            }
        }
    }
}

#[test]
fn the_frame_cap_names_its_override_and_the_overlap_names_both_blocks() {
    let many = edit("interval = 0.05", "interval = 1e-4");
    let Err(SceneError::Invalid { errors, .. }) = Scene::parse(&many, "many.toml") else {
        panic!("25 000 frames accepted");
    };
    let e = errors
        .iter()
        .find(|e| e.path == "output.interval")
        .expect("output.interval named");
    assert!(e.to_string().contains("output.max_frames"), "{e}");
    let raised = edit("interval = 0.05", "interval = 1e-4\nmax_frames = 30000");
    Scene::parse(&raised, "raised.toml").unwrap_or_else(|e| panic!("{e}"));

    let paddle = plus(
        "[[block]]\nname = \"paddle\"\nkind = \"kinematic\"\nshape = { type = \"box\", min = [4.9, 0.3, 0.6], max = [5.1, 0.5, 0.8] }\nmotion = { type = \"sine\", amplitude = [0.1, 0.0, 0.0], period = 2.0 }",
    );
    let Err(SceneError::Invalid { errors, .. }) = Scene::parse(&paddle, "paddle.toml") else {
        panic!("overlap accepted");
    };
    let msg = errors
        .iter()
        .map(|e| e.to_string())
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        msg.contains("'paddle' (kinematic)") && msg.contains("'far_wall' (fixed"),
        "{msg}"
    );
    // Touching is fine: the paddle's face on the wall's, sliding along it (a stroke towards
    // the wall would drive it in: `motion_path`).
    let touching = plus(
        "[[block]]\nname = \"paddle\"\nkind = \"kinematic\"\nshape = { type = \"box\", min = [4.8, 0.3, 0.6], max = [5.0, 0.5, 0.8] }\nmotion = { type = \"sine\", amplitude = [0.0, 0.0, 0.1], period = 2.0 }",
    );
    Scene::parse(&touching, "touching.toml").unwrap_or_else(|e| panic!("{e}"));
}

/// A probe's face on a wall is fine with the wall's normal; turned into the wall, the error
/// says how many of its points are inside which block, and the fix.
#[test]
fn a_face_turned_into_its_wall_names_the_block_and_the_normal_to_give() {
    let on_wall = |normal: &str| {
        edit(
            "position = [4.95, 0.4, 0.05]",
            &format!(
                "position = [5.0, 0.4, 0.05]\nface = {{ diameter = 0.0042, normal = {normal} }}"
            ),
        )
    };
    Scene::parse(&on_wall("[-1.0, 0.0, 0.0]"), "facing.toml").unwrap_or_else(|e| panic!("{e}"));
    // A face's normal may point either way along the wall's.
    Scene::parse(&on_wall("[2.0, 0.0, 0.0]"), "facing.toml").unwrap_or_else(|e| panic!("{e}"));
    let Err(SceneError::Invalid { errors, .. }) =
        Scene::parse(&on_wall("[0.0, 1.0, 0.0]"), "turned.toml")
    else {
        panic!("a face half inside the far wall accepted");
    };
    let e = errors
        .iter()
        .find(|e| e.path == "probe[0].face.normal")
        .expect("probe[0].face.normal named")
        .to_string();
    // With the normal along y the disk lies in x–z: the points at x > 5.0 are in the wall.
    assert!(
        e.contains("puts 3 of the face's 7 points inside fixed block 'far_wall'")
            && e.contains("normal = [-1.0, 0.0, 0.0]"),
        "{e}"
    );
}

/// A DEM with one cell far past any scene (a spike, a cell in other units) is refused by the
/// terrain check, named at `terrain[0].file` with the fix; before, `coupler check` passed it
/// and the solid node failed at step 0 on a vertex of −inf. The same DEM without the spike
/// passes.
#[test]
fn a_dem_cell_past_any_scene_is_refused_at_check() {
    let dir = tempfile::tempdir().unwrap();
    let dem = |spike: &str| {
        let mut text = String::from(
            "ncols 11\nnrows 11\nxllcenter 0\nyllcenter 0\ncellsize 0.1\nNODATA_value -9999\n",
        );
        for row in 0..11 {
            let cells: Vec<&str> = (0..11)
                .map(|col| if (row, col) == (5, 5) { spike } else { "0.3" })
                .collect();
            text.push_str(&cells.join(" "));
            text.push('\n');
        }
        text
    };
    let scene = |spike: &str| {
        std::fs::write(dir.path().join("ground.asc"), dem(spike)).unwrap();
        let text = "name = \"t\"\n[time]\nend = 0.1\n[domain]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n\
                    [[terrain]]\nfile = \"ground.asc\"\n";
        std::fs::write(dir.path().join("scene.toml"), text).unwrap();
        Scene::load(&dir.path().join("scene.toml")).unwrap_or_else(|e| panic!("{e}"))
    };
    assert!(shared::terrain::check_scene(&scene("0.4")).is_empty());
    let errors = shared::terrain::check_scene(&scene("1e300"));
    let e = errors
        .iter()
        .find(|e| e.path == "terrain[0].file")
        .unwrap_or_else(|| panic!("terrain[0].file not named: {errors:?}"));
    assert!(
        e.problem.contains("beyond ±1e9 m") && e.fix.contains("crop"),
        "{e}"
    );
}

/// A terrain file that is not there is named with a fix about its path (it was told "not a
/// pipe, device or directory", the fix for a file that exists but is not a regular one).
#[test]
fn a_missing_terrain_file_is_named_with_where_it_is_looked_for() {
    let dir = tempfile::tempdir().unwrap();
    let text = "name = \"t\"\n[time]\nend = 0.1\n[domain]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n\
                [[terrain]]\nfile = \"valley.asc\"\n";
    std::fs::write(dir.path().join("scene.toml"), text).unwrap();
    let scene = Scene::load(&dir.path().join("scene.toml")).unwrap_or_else(|e| panic!("{e}"));
    let errors = shared::terrain::check_scene(&scene);
    let e = errors
        .iter()
        .find(|e| e.path == "terrain[0].file")
        .unwrap_or_else(|| panic!("terrain[0].file not named: {errors:?}"));
    assert!(
        e.problem.contains("cannot open") && e.fix.contains("the scene file's folder"),
        "{e}"
    );
}

/// A slide region past a domain face is one error on the region, counting the cut blocks
/// outside, not one per cut block telling the user to raise `min_block_volume`.
#[test]
fn a_slide_past_the_domain_is_one_error_on_its_region() {
    let Err(SceneError::Invalid { errors, .. }) = Scene::parse(&plus(SLIDE_PAST_THE_TOP), "s.toml")
    else {
        panic!("a slide past the domain's top accepted");
    };
    assert_eq!(errors.len(), 1, "{errors:?}");
    let e = errors[0].to_string();
    assert!(
        errors[0].path == "slide[0].region"
            && e.contains("4 of the blocks cut from it")
            && e.contains("enlarge [domain]")
            && !e.contains("min_block_volume"),
        "{e}"
    );
}
