//! Scene validation: every impossible value is reported with its field, the value, the problem
//! and the fix. All problems are collected, not just the first.

use super::error::{FieldError, Seg, render_path};
use super::schema::*;
use crate::geometry::Polyhedron;

/// Largest domain coordinate [m]: a 10 000 km box holds any landslide tsunami.
const MAX_DOMAIN: f64 = 1e7;
/// Most output frames a run may ask for (time.end / output.interval), unless the scene raises
/// it with `output.max_frames`.
const MAX_FRAMES: f64 = 1e4;
/// Smallest block, as a fraction of the domain diagonal (cube root of the volume).
const MIN_BLOCK_OF_DOMAIN: f64 = 1e-6;
/// Overlap of two moving blocks at the start, as a fraction of the smaller one's radius, above
/// which their interiors are taken to overlap (rounding in the corner coordinates stays below).
const MAX_START_OVERLAP: f64 = 1e-6;
/// Fastest prescribed block motion [m/s]; a landslide is tens of m/s.
const MAX_SPEED: f64 = 1e3;

/// Collects errors while walking the scene.
struct Checker {
    path: Vec<Seg>,
    errors: Vec<FieldError>,
}

impl Checker {
    fn at<R>(&mut self, seg: Seg, f: impl FnOnce(&mut Self) -> R) -> R {
        self.path.push(seg);
        let r = f(self);
        self.path.pop();
        r
    }

    fn key<R>(&mut self, k: &str, f: impl FnOnce(&mut Self) -> R) -> R {
        self.at(Seg::Key(k.into()), f)
    }

    fn fail(&mut self, field: &str, value: impl std::fmt::Debug, problem: &str, fix: &str) {
        let mut segments = self.path.clone();
        if !field.is_empty() {
            segments.push(Seg::Key(field.into()));
        }
        let path = render_path(&segments);
        self.errors.push(FieldError {
            path,
            segments,
            value: format!("{value:?}"),
            problem: problem.into(),
            fix: fix.into(),
            line: None,
        });
    }

    fn positive(&mut self, field: &str, v: f64, fix: &str) {
        if !(v.is_finite() && v > 0.0) {
            self.fail(field, v, "must be a positive finite number", fix);
        }
    }

    fn finite3(&mut self, field: &str, v: [f64; 3]) {
        if v.iter().any(|x| !x.is_finite()) {
            self.fail(field, v, "must be finite", "give three finite numbers");
        }
    }

    /// A name written into CSV headers and cells, JSON keys and messages: not empty, no
    /// separator, quote or control character, no spaces at either end (CSV readers trim them).
    fn label(&mut self, field: &str, name: &str, what: &str) {
        let bad = name
            .chars()
            .find(|ch| matches!(ch, ',' | '"' | '\'' | ';') || ch.is_control());
        if name.trim().is_empty() {
            self.fail(
                field,
                name,
                "is empty",
                &format!("give the {what} a short name"),
            );
        } else if let Some(ch) = bad {
            self.fail(
                field,
                name,
                &format!("holds {ch:?}, which breaks the CSV and JSON outputs"),
                "use letters, digits, spaces, '_', '-' or '.'",
            );
        } else if name.trim() != name {
            self.fail(
                field,
                name,
                "starts or ends with white space",
                "remove the spaces around the name",
            );
        }
    }

    fn shape(&mut self, shape: &ShapeSpec, domain: &DomainSpec, must_be_inside: bool) {
        // Coordinates far outside the domain are typos (a fixed block may reach past the
        // domain, not by more than ten times its size): say so before the geometry does.
        let diag = (0..3)
            .map(|k| (domain.max[k] - domain.min[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        if let Ok(points) = crate::geometry::shape_points(shape)
            && diag.is_finite()
            && let Some(p) = points.iter().find(|p| {
                (0..3).any(|k| {
                    !(p[k] >= domain.min[k] - 10.0 * diag && p[k] <= domain.max[k] + 10.0 * diag)
                })
            })
        {
            self.key("shape", |c| {
                c.fail(
                    "",
                    shape_summary(shape),
                    &format!(
                        "has a corner at [{:e}, {:e}, {:e}], more than ten domain sizes ({:.3} m) outside [domain]",
                        p[0], p[1], p[2], 10.0 * diag
                    ),
                    "give coordinates in metres near the domain (a typo in an exponent?)",
                )
            });
            return;
        }
        self.key("shape", |c| match Polyhedron::from_shape(shape) {
            Err(e) => c.fail("", shape_summary(shape), &e.problem, &e.fix),
            Ok(p) if must_be_inside => {
                let (lo, hi) = p.world_aabb();
                let inside = (0..3).all(|k| lo[k] >= domain.min[k] && hi[k] <= domain.max[k]);
                if !inside {
                    c.fail(
                        "",
                        shape_summary(shape),
                        &format!("reaches outside the domain (spans {lo:?} to {hi:?})"),
                        "move the shape inside [domain] or enlarge [domain]",
                    );
                }
            }
            Ok(p) if domain.open_top => {
                // Above an open top the water meets no wall (boundary particles end there): a
                // fixed block reaching higher would let the spray pass through it.
                let top = p.world_aabb().1[2];
                if top > domain.max[2] {
                    c.fail(
                        "",
                        shape_summary(shape),
                        &format!(
                            "reaches z = {top} m, above the open domain top (max[2] = {} m), where the spray would pass through it",
                            domain.max[2]
                        ),
                        "raise [domain] max[2] to the block's top, or cut the block at the top",
                    );
                }
            }
            Ok(_) => {}
        });
    }
}

fn shape_summary(shape: &ShapeSpec) -> String {
    match shape {
        ShapeSpec::Box { min, max } => format!("box {min:?}..{max:?}"),
        ShapeSpec::Prism {
            axis,
            profile,
            extent,
        } => {
            format!(
                "prism along {axis:?}, {} profile points, extent {extent:?}",
                profile.len()
            )
        }
        ShapeSpec::Convex { vertices } => format!("convex set of {} vertices", vertices.len()),
    }
}

pub(super) fn validate(s: &Scene) -> Vec<FieldError> {
    let mut c = Checker {
        path: Vec::new(),
        errors: Vec::new(),
    };
    if s.name.trim().is_empty() {
        c.fail(
            "name",
            &s.name,
            "is empty",
            "give the scene a short name, e.g. name = \"wedge\"",
        );
    } else if s.name.starts_with('.')
        || s.name.len() > 100
        || !s
            .name
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || matches!(ch, '_' | '-' | '.'))
    {
        c.fail(
            "name",
            &s.name,
            "names the run directory (runs/<name>-<run id>) and must be one plain file name: \
             no '/', '..', spaces or other characters, not starting with '.', at most 100 characters",
            "use letters, digits, '_', '-' and '.', e.g. name = \"sliding_wedge\"",
        );
    }
    c.finite3("gravity", s.gravity);
    if s.gravity.iter().any(|g| g.abs() > 1e3) {
        c.fail(
            "gravity",
            s.gravity,
            "is more than 100 g",
            "give gravity in m/s², e.g. gravity = [0, 0, -9.81]",
        );
    }

    c.key("time", |c| {
        c.positive(
            "end",
            s.time.end,
            "give the simulated end time in seconds, e.g. end = 3.0",
        );
        c.positive(
            "dt_max",
            s.time.dt_max,
            "give the largest step in seconds, e.g. dt_max = 1e-3",
        );
        c.positive(
            "dt_min",
            s.time.dt_min,
            "give the smallest acceptable step, e.g. dt_min = 1e-9",
        );
        if s.time.dt_min >= s.time.dt_max {
            c.fail(
                "dt_min",
                s.time.dt_min,
                "is not below dt_max",
                "make dt_min much smaller than dt_max",
            );
        }
    });

    let d = &s.domain;
    c.key("domain", |c| {
        c.finite3("min", d.min);
        c.finite3("max", d.max);
        for (field, v) in [("min", d.min), ("max", d.max)] {
            if v.iter().any(|x| x.abs() > MAX_DOMAIN) {
                c.fail(
                    field,
                    v,
                    &format!("lies beyond ±{MAX_DOMAIN:e} m"),
                    "give the domain corners in metres",
                );
            }
        }
        if (0..3).any(|k| d.max[k] <= d.min[k]) {
            c.fail(
                "max",
                d.max,
                "is not above domain.min on every axis",
                "make max[k] > min[k] for x, y and z",
            );
        }
    });

    c.key("output", |c| {
        c.positive(
            "interval",
            s.output.interval,
            "give the time between frames, e.g. interval = 0.05",
        );
        if let Some(m) = s.output.max_frames {
            c.positive(
                "max_frames",
                m,
                "give the most frames the run may write, e.g. max_frames = 20000, or leave it out for 10000",
            );
        }
        let max_frames = s
            .output
            .max_frames
            .filter(|m| m.is_finite() && *m > 0.0)
            .unwrap_or(MAX_FRAMES);
        let frames = s.time.end / s.output.interval;
        if s.output.interval > 0.0 && frames > max_frames {
            c.fail(
                "interval",
                s.output.interval,
                &format!(
                    "asks for {frames:.3e} frames over time.end = {} s (at most {max_frames:.0}, \
                     output.max_frames); each frame is a step landed exactly and a VTK file per node",
                    s.time.end
                ),
                &format!(
                    "use interval >= {:.3e}, or raise output.max_frames to {:.0} if you mean it",
                    s.time.end / max_frames,
                    frames.ceil()
                ),
            );
        }
        if let Some(v) = s.output.checkpoint_interval {
            c.positive(
                "checkpoint_interval",
                v,
                "give the simulated seconds between checkpoints, e.g. checkpoint_interval = 1.0, or leave it out",
            );
        }
        if let Some(v) = s.output.checkpoint_wall_minutes {
            c.positive(
                "checkpoint_wall_minutes",
                v,
                "give the wall-clock minutes between checkpoints, e.g. checkpoint_wall_minutes = 30, or leave it out",
            );
        }
    });

    if let Some(f) = &s.fluid {
        c.key("fluid", |c| {
            c.positive("density", f.density, "water is density = 1000.0");
            c.positive(
                "dx",
                f.dx,
                "give the particle spacing in metres, e.g. dx = 0.02",
            );
            let smallest = (0..3)
                .map(|k| d.max[k] - d.min[k])
                .fold(f64::INFINITY, f64::min);
            if f.dx.is_finite() && f.dx > 0.0 && f.dx * 4.0 > smallest {
                c.fail(
                    "dx",
                    f.dx,
                    "is too coarse for the domain (fewer than 4 particles across)",
                    "use a smaller dx",
                );
            }
            if !(f.kinematic_viscosity.is_finite() && f.kinematic_viscosity >= 0.0) {
                c.fail(
                    "kinematic_viscosity",
                    f.kinematic_viscosity,
                    "must be >= 0",
                    "water is 1e-6 m²/s",
                );
            }
            if !(f.density_ratio_bound.is_finite() && f.density_ratio_bound > 1.0) {
                c.fail(
                    "density_ratio_bound",
                    f.density_ratio_bound,
                    "must be > 1",
                    "e.g. density_ratio_bound = 1.3",
                );
            }
            for (i, w) in f.water.iter().enumerate() {
                c.key("water", |c| {
                    c.at(Seg::Index(i), |c| c.shape(&w.shape, d, true))
                });
            }
            // Keys that are not [fluid] fields are solver tables; a stray value is a typo.
            for (key, value) in &f.solvers {
                if !value.is_table() {
                    c.fail(
                        key,
                        value,
                        "is not a field of [fluid]",
                        "fields are solver, density, dx, kinematic_viscosity, density_ratio_bound, walls, water; solver parameters go in their own table, e.g. [fluid.wcsph]",
                    );
                }
            }
        });
    }

    c.key("solid", |c| {
        // Keys that are not [solid] fields are solver tables; a stray value is a typo.
        for (key, value) in &s.solid.solvers {
            if !value.is_table() {
                c.fail(
                    key,
                    value,
                    "is not a field of [solid]",
                    "fields are solver, contact; solver parameters go in their own table, e.g. [solid.implicit]",
                );
            }
        }
        c.key("contact", |c| {
            let k = &s.solid.contact;
            if let Some(kn) = k.normal_stiffness {
                c.positive(
                    "normal_stiffness",
                    kn,
                    "give a spring in N/m, or leave it out to derive one",
                );
            }
            if !(k.shear_ratio >= 0.0 && k.shear_ratio.is_finite()) {
                c.fail(
                    "shear_ratio",
                    k.shear_ratio,
                    "must be >= 0",
                    "e.g. shear_ratio = 0.4",
                );
            }
            if !(0.0..90.0).contains(&k.friction_angle) {
                c.fail(
                    "friction_angle",
                    k.friction_angle,
                    "must be in [0, 90) degrees",
                    "e.g. friction_angle = 30.0",
                );
            }
            if !(k.cohesion >= 0.0 && k.cohesion.is_finite()) {
                c.fail(
                    "cohesion",
                    k.cohesion,
                    "must be >= 0",
                    "give cohesion in Pa, 0 for a clean joint",
                );
            }
            if !(k.allowed_penetration > 0.0 && k.allowed_penetration < 0.1) {
                c.fail(
                    "allowed_penetration",
                    k.allowed_penetration,
                    "must be in (0, 0.1)",
                    "e.g. allowed_penetration = 1e-4",
                );
            }
            if !(0.0..=1.0).contains(&k.damping_ratio) {
                c.fail(
                    "damping_ratio",
                    k.damping_ratio,
                    "must be in [0, 1]",
                    "0 keeps bounces elastic",
                );
            }
        });
    });

    c.key("coupling", |c| {
        let k = &s.coupling;
        if let Some(v) = k.penalty_stiffness {
            c.positive(
                "penalty_stiffness",
                v,
                "give K_S in N/m, or leave it out to derive one",
            );
        }
        if let Some(v) = k.penalty_damping
            && !(v >= 0.0 && v.is_finite())
        {
            c.fail(
                "penalty_damping",
                v,
                "must be >= 0",
                "give K_D in N·s/m, or leave it out",
            );
        }
        if let Some(v) = k.margin {
            c.positive(
                "margin",
                v,
                "give the Eq. 22 contact margin in metres, e.g. dx/2",
            );
        }
        if !(1..=10_000).contains(&k.solid_substeps) {
            c.fail(
                "solid_substeps",
                k.solid_substeps,
                "must be in 1..=10000",
                "1 is single-rate; 4 to 20 let an explicit solid sub-cycle inside a long fluid step",
            );
        }
        if !(0.0..=100.0).contains(&k.added_mass) {
            c.fail(
                "added_mass",
                k.added_mass,
                "must be in 0..=100 (times ρ_water × the block's volume)",
                "0 is off; 0.5 to 2 stabilise light blocks under an incompressible fluid",
            );
        }
    });

    let diag = (0..3)
        .map(|k| (d.max[k] - d.min[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let polys: Vec<Option<Polyhedron>> = s
        .blocks
        .iter()
        .map(|b| Polyhedron::from_shape(&b.shape).ok())
        .collect();
    let mut names = std::collections::HashSet::new();
    for (i, b) in s.blocks.iter().enumerate() {
        c.key("block", |c| {
            c.at(Seg::Index(i), |c| {
                c.label("name", &b.name, "block");
                if !names.insert(b.name.as_str()) {
                    c.fail(
                        "name",
                        &b.name,
                        "is used by an earlier block (blocks.csv and summary.json key blocks by name)",
                        "give every block a unique name",
                    );
                }
                c.shape(&b.shape, d, b.kind != BlockKind::Fixed);
                if let Some(p) = polys[i].as_ref() {
                    let size = p.volume.cbrt();
                    let dx = s.fluid.as_ref().map_or(0.0, |f| f.dx);
                    let floor = if b.kind == BlockKind::Fixed {
                        MIN_BLOCK_OF_DOMAIN * diag
                    } else {
                        (MIN_BLOCK_OF_DOMAIN * diag).max(dx / 4.0)
                    };
                    if size < floor {
                        c.key("shape", |c| {
                            c.fail(
                                "",
                                shape_summary(&b.shape),
                                &format!(
                                    "block '{}' is {size:.3e} m across (the cube root of its volume), \
                                     below {floor:.3e} m ({}): too small to simulate",
                                    b.name,
                                    if floor > MIN_BLOCK_OF_DOMAIN * diag {
                                        "a quarter of fluid.dx: no particle would see it"
                                    } else {
                                        "1e-6 of the domain diagonal"
                                    }
                                ),
                                "make the block larger, or remove it",
                            )
                        });
                    }
                }
                if b.kind == BlockKind::Free {
                    c.positive(
                        "density",
                        b.density,
                        "give the rock density in kg/m³, e.g. density = 2500.0",
                    );
                }
                c.finite3("velocity", b.velocity);
                c.finite3("angular_velocity", b.angular_velocity);
                match (&b.kind, &b.motion) {
                    (BlockKind::Kinematic, None) => c.fail(
                        "motion",
                        "nothing",
                        "a kinematic block needs a prescribed motion",
                        "add motion = { type = \"sine\", amplitude = [0.1, 0, 0], period = 2.0 }",
                    ),
                    (BlockKind::Kinematic, Some(MotionSpec::Linear { velocity })) => {
                        c.key("motion", |c| {
                            c.finite3("velocity", *velocity);
                            if velocity.iter().any(|v| v.abs() > MAX_SPEED) {
                                c.fail(
                                    "velocity",
                                    velocity,
                                    &format!("is faster than {MAX_SPEED} m/s"),
                                    "give the velocity in m/s",
                                );
                            }
                        })
                    }
                    (
                        BlockKind::Kinematic,
                        Some(MotionSpec::Sine {
                            amplitude,
                            period,
                            phase,
                            ramp,
                        }),
                    ) => {
                        c.key("motion", |c| {
                            c.finite3("amplitude", *amplitude);
                            if !phase.is_finite() {
                                c.fail("phase", *phase, "must be finite", "give the phase in radians, or 0");
                            }
                            if ramp.is_infinite() {
                                c.fail("ramp", *ramp, "must be finite", "give the ramp-in time in seconds, or 0");
                            }
                            c.positive("period", *period, "give the period in seconds");
                            // The peak speed of A·sin(2πt/T) is 2π|A|/T.
                            let a = amplitude.iter().map(|x| x * x).sum::<f64>().sqrt();
                            let peak = 2.0 * std::f64::consts::PI * a / period;
                            if a.is_finite() && *period > 0.0 && peak > MAX_SPEED {
                                c.fail(
                                    "period",
                                    *period,
                                    &format!(
                                        "gives a peak speed 2π·|amplitude|/period = {peak:.3e} m/s, faster than {MAX_SPEED} m/s"
                                    ),
                                    &format!(
                                        "lengthen the period to at least {:.3e} s or shrink the amplitude",
                                        2.0 * std::f64::consts::PI * a / MAX_SPEED
                                    ),
                                );
                            }
                            if ramp.is_nan() || *ramp < 0.0 {
                                c.fail(
                                    "ramp",
                                    *ramp,
                                    "must be >= 0",
                                    "give the ramp-in time in seconds, or 0",
                                );
                            }
                        })
                    }
                    (BlockKind::Fixed | BlockKind::Free, Some(_)) => c.fail(
                        "motion",
                        format!("{:?}", b.kind).to_lowercase(),
                        "only kinematic blocks follow a prescribed motion",
                        "set kind = \"kinematic\" or remove motion",
                    ),
                    _ => {}
                }
                if let Some(phi) = b.friction_angle
                    && !(0.0..90.0).contains(&phi)
                {
                    c.fail(
                        "friction_angle",
                        phi,
                        "must be in [0, 90) degrees",
                        "e.g. friction_angle = 30.0",
                    );
                }
                if let Some(coh) = b.cohesion
                    && (coh.is_nan() || coh < 0.0)
                {
                    c.fail("cohesion", coh, "must be >= 0", "give cohesion in Pa");
                }
                if let Some(el) = &b.elastic {
                    if b.kind != BlockKind::Free {
                        c.fail(
                            "elastic",
                            format!("{:?}", b.kind).to_lowercase(),
                            "only free blocks deform (fixed and kinematic blocks have no unknowns)",
                            "remove elastic, or set kind = \"free\"",
                        );
                    }
                    c.key("elastic", |c| {
                        c.positive(
                            "young_modulus",
                            el.young_modulus,
                            "give Young's modulus in Pa, e.g. young_modulus = 1e10 for rock",
                        );
                        if !(0.0..0.5).contains(&el.poisson_ratio) {
                            c.fail(
                                "poisson_ratio",
                                el.poisson_ratio,
                                "must be in [0, 0.5) (0.5 is incompressible: no finite bulk modulus)",
                                "e.g. poisson_ratio = 0.25",
                            );
                        }
                    });
                }
            })
        });
    }

    // Moving blocks must not start inside each other: the contact springs act on penetrations
    // of the order of allowed_penetration, and two blocks sharing their interiors move as one.
    // Nor may a kinematic block start inside a fixed one: the solid node computes no contact
    // between two blocks that are not free (their motions are given), so the prescribed motion
    // would carry it through the fixed block, and the water between them, unopposed.
    for i in 0..s.blocks.len() {
        for j in 0..i {
            let (bi, bj) = (&s.blocks[i], &s.blocks[j]);
            let fixed = [bi.kind, bj.kind]
                .iter()
                .filter(|k| **k == BlockKind::Fixed)
                .count();
            let kinematic = [bi.kind, bj.kind].contains(&BlockKind::Kinematic);
            if fixed == 2 || (fixed == 1 && !kinematic) {
                continue;
            }
            let (Some(pi), Some(pj)) = (&polys[i], &polys[j]) else {
                continue;
            };
            let ((li, hi), (lj, hj)) = (pi.world_aabb(), pj.world_aabb());
            if (0..3).any(|k| li[k] >= hj[k] || lj[k] >= hi[k]) {
                continue; // apart or touching: the bounding boxes already tell
            }
            let depth = crate::geometry::overlap_depth(pi, pj);
            let size = pi.radius.min(pj.radius);
            if depth > MAX_START_OVERLAP * size {
                c.key("block", |c| {
                    c.at(Seg::Index(i), |c| {
                        c.fail(
                            "shape",
                            shape_summary(&bi.shape),
                            &if fixed == 1 {
                                format!(
                                    "the interior of block '{}' ({}) overlaps that of block '{}' ({}, block[{j}]) by {depth:.3e} m: \
                                     a kinematic block feels no contact with a fixed one and its prescribed motion would run through it",
                                    bi.name,
                                    kind_name(bi.kind),
                                    bj.name,
                                    kind_name(bj.kind)
                                )
                            } else {
                                format!(
                                    "the interior of block '{}' overlaps that of block '{}' (block[{j}]) by {depth:.3e} m: \
                                     moving blocks that start inside each other feel no contact and move as one",
                                    bi.name, bj.name
                                )
                            },
                            "move the blocks apart (touching faces are fine)",
                        )
                    })
                });
            }
        }
    }

    let block_names: Vec<&str> = s.blocks.iter().map(|b| b.name.as_str()).collect();
    c.errors
        .extend(validate_terrain(&s.terrain, &s.domain, &block_names));

    let mut gauge_names = std::collections::HashSet::new();
    for (i, g) in s.gauges.iter().enumerate() {
        c.key("gauge", |c| {
            c.at(Seg::Index(i), |c| {
                c.label("name", &g.name, "gauge");
                if !gauge_names.insert(g.name.as_str()) {
                    c.fail(
                        "name",
                        &g.name,
                        "is used by an earlier gauge (gauges.csv columns and summary.json key gauges by name)",
                        "give every gauge a unique name",
                    );
                }
            })
        });
    }
    let mut runup_names = std::collections::HashSet::new();
    for (i, r) in s.runups.iter().enumerate() {
        c.key("runup", |c| {
            c.at(Seg::Index(i), |c| {
                c.label("name", &r.name, "runup");
                if !runup_names.insert(r.name.as_str()) {
                    c.fail(
                        "name",
                        &r.name,
                        "is used by an earlier runup (summary.json keys run-ups by name)",
                        "give every [[runup]] a unique name",
                    );
                }
                if !(0..2).all(|k| r.min[k] < r.max[k]) {
                    c.fail(
                        "max",
                        r.max,
                        &format!("is not above min = {:?} in both x and y: the box is empty", r.min),
                        "give the shore's box in plan with min < max, e.g. min = [150, 190], max = [250, 260]",
                    );
                } else if !(0..2).all(|k| r.min[k] < d.max[k] && r.max[k] > d.min[k]) {
                    c.fail(
                        "min",
                        r.min,
                        "gives a box outside the domain in plan: no water can reach it",
                        "put the box over a shore inside [domain]",
                    );
                }
            })
        });
    }
    let mut probe_names = std::collections::HashSet::new();
    for (i, p) in s.probes.iter().enumerate() {
        c.key("probe", |c| {
            c.at(Seg::Index(i), |c| {
                c.label("name", &p.name, "probe");
                if !probe_names.insert(p.name.as_str()) {
                    c.fail(
                        "name",
                        &p.name,
                        "is used by an earlier probe (probes.csv columns are named by probe)",
                        "give every probe a unique name",
                    );
                }
                if let Some(w) = p.window {
                    c.positive(
                        "window",
                        w,
                        "give the averaging window in seconds (e.g. window = 0.001), or leave it out for the instantaneous reading",
                    );
                }
            })
        });
    }

    let inside_xy =
        |x: f64, y: f64| x >= d.min[0] && x <= d.max[0] && y >= d.min[1] && y <= d.max[1];
    // gauges.csv has a column per gauge and one named `<name>_spray` per gauge: names must not
    // collide, and `time` is the first column.
    let mut columns = std::collections::HashSet::from(["time".to_string()]);
    for (i, g) in s.gauges.iter().enumerate() {
        if !columns.insert(g.name.clone()) || !columns.insert(format!("{}_spray", g.name)) {
            c.key("gauge", |c| {
                c.at(Seg::Index(i), |c| {
                    c.fail(
                        "name",
                        &g.name,
                        "collides with another gauges.csv column (time, an earlier gauge or its <name>_spray column)",
                        "give every gauge a unique name that is not another gauge's name + \"_spray\"",
                    )
                })
            });
        }
    }
    for (i, g) in s.gauges.iter().enumerate() {
        if !inside_xy(g.x, g.y) {
            c.key("gauge", |c| {
                c.at(Seg::Index(i), |c| {
                    c.fail(
                        "x",
                        (g.x, g.y),
                        "lies outside the domain",
                        "put the gauge inside [domain] in x and y",
                    )
                })
            });
        }
    }
    for (i, p) in s.probes.iter().enumerate() {
        let q = p.position;
        if (0..3).any(|k| q[k] < d.min[k] || q[k] > d.max[k]) {
            c.key("probe", |c| {
                c.at(Seg::Index(i), |c| {
                    c.fail(
                        "position",
                        q,
                        "lies outside the domain",
                        "put the probe inside [domain]",
                    )
                })
            });
        }
    }
    c.errors
}

/// A block kind as the scene writes it.
fn kind_name(k: BlockKind) -> &'static str {
    match k {
        BlockKind::Fixed => "fixed",
        BlockKind::Kinematic => "kinematic",
        BlockKind::Free => "free",
    }
}

/// An error at `terrain[index].field`.
pub(crate) fn terrain_field_error(
    index: usize,
    field: &str,
    value: String,
    problem: &str,
    fix: &str,
) -> FieldError {
    let mut segments = vec![Seg::Key("terrain".into()), Seg::Index(index)];
    if !field.is_empty() {
        segments.push(Seg::Key(field.into()));
    }
    FieldError {
        path: render_path(&segments),
        segments,
        value,
        problem: problem.into(),
        fix: fix.into(),
        line: None,
    }
}

/// The checks of the `[[terrain]]` tables that need no file.
/// `blocks` are the scene's block names: a terrain is a block to the solid node (its
/// contacts, its messages), so the names must differ.
fn validate_terrain(
    terrains: &[TerrainSpec],
    domain: &DomainSpec,
    blocks: &[&str],
) -> Vec<FieldError> {
    let mut out = Vec::new();
    let mut fail = |i: usize, field: &str, value: String, problem: &str, fix: &str| {
        out.push(terrain_field_error(i, field, value, problem, fix))
    };
    for (i, t) in terrains.iter().enumerate() {
        if blocks.contains(&t.name.as_str()) || terrains[..i].iter().any(|o| o.name == t.name) {
            fail(
                i,
                "name",
                format!("{:?}", t.name),
                "is used by a block or an earlier terrain",
                "give every terrain a name of its own, e.g. name = \"valley\"",
            );
        }
        if t.name.trim().is_empty()
            || t.name
                .chars()
                .any(|c| matches!(c, ',' | '"' | '\'' | ';') || c.is_control())
        {
            fail(
                i,
                "name",
                format!("{:?}", t.name),
                "must be a short name without separators or quotes",
                "use letters, digits, '_', '-' or '.', e.g. name = \"fjord\"",
            );
        }
        if TerrainFormat::of(&t.file).is_none() {
            fail(
                i,
                "file",
                format!("{:?}", t.file.display().to_string()),
                "has no known terrain extension",
                "give a .stl, .obj or .ply triangle mesh or an .asc (ESRI ASCII grid) or .tif (GeoTIFF) elevation model",
            );
        }
        for (field, v) in [("offset", t.offset), ("rotation", t.rotation)] {
            if v.iter().any(|x| !x.is_finite()) {
                fail(
                    i,
                    field,
                    format!("{v:?}"),
                    "must be finite",
                    "give three finite numbers",
                );
            }
        }
        if t.scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            fail(
                i,
                "scale",
                format!("{:?}", t.scale),
                "must be three positive finite factors",
                "give e.g. scale = [1.0, 1.0, 1.0]; mirror a mesh in its own tool, not here",
            );
        }
        if let Some(c) = &t.crop {
            if (0..3).any(|k| {
                c.max[k].partial_cmp(&c.min[k]) != Some(std::cmp::Ordering::Greater)
                    || !c.min[k].is_finite()
            }) {
                fail(
                    i,
                    "crop",
                    format!("{c:?}"),
                    "is empty or not finite (max must be above min on every axis)",
                    "give crop = { min = [x, y, z], max = [x, y, z] } with max > min",
                );
            } else if (0..3).any(|k| c.max[k] < domain.min[k] || c.min[k] > domain.max[k]) {
                fail(
                    i,
                    "crop",
                    format!("{c:?}"),
                    "lies wholly outside [domain]: no triangle could be kept",
                    "give a crop box that overlaps [domain]",
                );
            }
        }
        for (field, v, fix) in [
            (
                "friction_angle",
                t.friction_angle,
                "give an angle in degrees in [0, 90), e.g. 30",
            ),
            ("cohesion", t.cohesion, "give a cohesion ≥ 0 in Pa"),
        ] {
            if let Some(v) = v {
                let ok = v.is_finite() && v >= 0.0 && (field != "friction_angle" || v < 90.0);
                if !ok {
                    fail(i, field, format!("{v}"), "is out of range", fix);
                }
            }
        }
    }
    out
}
