//! The instruments: `[[gauge]]`, `[[runup]]` and `[[probe]]` (names, boxes, windows, and that
//! each lies inside the domain, and no probe reads inside a fixed block).

use super::checker::Checker;
use crate::geometry::Polyhedron;
use crate::math::Point;
use crate::scene::error::Seg;
use crate::scene::schema::Scene;
use crate::scene::{BlockKind, FaceReading, Walls};

/// Shortest probe averaging window [s]: a pressure sensor's acquisition samples at 1 MHz at
/// most, so a shorter window averages nothing a sensor could record; and a window below the
/// rounding of the time (t·2⁻⁵²) holds no reading, so every row would be NaN.
const MIN_PROBE_WINDOW: f64 = 1e-6;

/// How deep inside a fixed block a probe's point may lie [m]: a sensor sits on a wall's face,
/// which the rounding of the block's frame moves by ~10⁻¹⁶ m.
const PROBE_IN_WALL: f64 = 1e-9;

/// Every instrument, in this order: the names (and a run-up's box, a probe's window) of the
/// gauges, run-ups and probes; then the gauges.csv columns; then where gauges and probes lie
/// (`polys`: each block's shape, None where it is not one).
pub(super) fn check(c: &mut Checker, s: &Scene, polys: &[Option<Polyhedron>]) {
    gauges(c, s);
    runups(c, s);
    probes(c, s);
    gauge_columns(c, s);
    placement(c, s);
    probes_in_walls(c, s, polys);
    wall_faces(c, s, polys);
}

/// A face that reads the wall (`reading = "wall"`) needs what that reading sums: boundary
/// particles (`[fluid] walls = "particles"`), a face along the water's lattice (the particles'
/// columns behind it are whole only there), and a fixed block behind it.
fn wall_faces(c: &mut Checker, s: &Scene, polys: &[Option<Polyhedron>]) {
    // Without water there is nothing to read (and nothing to check here).
    let Some(fluid) = &s.fluid else {
        return;
    };
    let walls: Vec<&Polyhedron> = s
        .blocks
        .iter()
        .zip(polys)
        .filter(|(b, _)| b.kind == BlockKind::Fixed)
        .filter_map(|(_, p)| p.as_ref())
        .collect();
    let depth = |p: &Polyhedron, x: [f64; 3]| -> f64 {
        -p.plane_distance(&(Point::from(x) - p.centroid.coords)).0
    };
    for (i, probe) in s.probes.iter().enumerate() {
        let Some(f) = probe.face.filter(|f| f.reading == FaceReading::Wall) else {
            continue;
        };
        c.key("probe", |c| {
            c.at(Seg::Index(i), |c| {
                c.key("face", |c| {
                    if fluid.walls != Walls::Particles {
                        c.fail(
                            "reading",
                            "wall",
                            &format!(
                                "reads the force on the wall's boundary particles, and [fluid] walls = \"{}\" has none",
                                fluid.walls
                            ),
                            "set [fluid] walls = \"particles\" (the default), or reading = \"fluid\"",
                        );
                        return;
                    }
                    let axes = f.normal.iter().filter(|&&n| n != 0.0).count();
                    if axes != 1 {
                        c.fail(
                            "normal",
                            f.normal,
                            "is not along x, y or z: a wall reading sums the boundary particles' columns behind the face, which lie on the water's lattice, so only a wall facing along an axis has whole columns behind it",
                            "give the wall's normal as [±1, 0, 0], [0, ±1, 0] or [0, 0, ±1], or reading = \"fluid\" on an inclined wall",
                        );
                        return;
                    }
                    // Half a spacing behind the face, against its normal: inside a fixed block.
                    let len = f.normal.iter().map(|n| n * n).sum::<f64>().sqrt();
                    let behind: [f64; 3] = std::array::from_fn(|k| {
                        probe.position[k] - 0.5 * fluid.dx * f.normal[k] / len
                    });
                    if !walls.iter().any(|p| depth(p, behind) > 0.0) {
                        c.fail(
                            "reading",
                            "wall",
                            &format!(
                                "reads the load on the wall behind the face, and no fixed block lies there (at {behind:?}, half a spacing behind the probe's position against the face's normal)"
                            ),
                            "put the probe's position on a fixed block's face with the normal pointing into the water, or use reading = \"fluid\"",
                        );
                    }
                })
            })
        });
    }
}

/// No point a probe reads (its position, or its face's seven) inside a fixed block: no water
/// ever reaches there, so the point reads dry for ever, and on a face a dry point counts as
/// 0 Pa in the mean (a face turned into its wall reads about half the pressure, with no other
/// sign of it).
fn probes_in_walls(c: &mut Checker, s: &Scene, polys: &[Option<Polyhedron>]) {
    let walls: Vec<(&str, &Polyhedron)> = s
        .blocks
        .iter()
        .zip(polys)
        .filter(|(b, _)| b.kind == BlockKind::Fixed)
        .filter_map(|(b, p)| p.as_ref().map(|p| (b.name.as_str(), p)))
        .collect();
    // Depth of a world point inside a block (negative: outside).
    let depth = |p: &Polyhedron, x: [f64; 3]| -> f64 {
        -p.plane_distance(&(Point::from(x) - p.centroid.coords)).0
    };
    for (i, probe) in s.probes.iter().enumerate() {
        let points: Vec<[f64; 3]> = match probe.face {
            Some(f) if f.diameter > 0.0 && f.normal.iter().any(|&n| n != 0.0) => {
                f.rule(probe.position).iter().map(|(x, _)| *x).collect()
            }
            _ => vec![probe.position],
        };
        let Some((name, inside, deepest, centre_in)) = walls.iter().find_map(|(name, p)| {
            let d: Vec<f64> = points.iter().map(|&x| depth(p, x)).collect();
            let inside = d.iter().filter(|&&d| d > PROBE_IN_WALL).count();
            let centre_in = depth(p, probe.position) > PROBE_IN_WALL;
            (inside > 0).then(|| {
                let deepest = d.iter().cloned().fold(0.0, f64::max);
                (*name, inside, deepest, centre_in)
            })
        }) else {
            continue;
        };
        // A position inside the wall is the position's fault whatever the face; a face that
        // leaves a position on the wall's face for the inside is its normal's, unless its disk
        // at the position is clear and only the span reaches in.
        let disk_clear = |f: &crate::scene::ProbeFace| {
            f.points(probe.position)
                .iter()
                .all(|(x, _)| walls.iter().all(|(_, p)| depth(p, *x) <= PROBE_IN_WALL))
        };
        let total = points.len();
        c.key("probe", |c| {
            c.at(Seg::Index(i), |c| match probe.face {
                Some(f) if f.span.is_some() && !centre_in && disk_clear(&f) => c.key("face", |c| c.fail(
                    "span",
                    f.span.unwrap_or_default(),
                    &format!(
                        "puts {inside} of the strip's {total} points inside fixed block '{name}' (up to {deepest:.2e} m deep), where no water reaches: they read 0 Pa for ever and the strip's mean with them"
                    ),
                    "shorten the span or move it along the wall, so that the strip (the span plus half a diameter at each end) stays on the wall's face",
                )),
                Some(f) if points.len() > 1 && !centre_in => c.key("face", |c| c.fail(
                    "normal",
                    f.normal,
                    &format!(
                        "puts {inside} of the face's {total} points inside fixed block '{name}' (up to {deepest:.2e} m deep), where no water reaches: they read 0 Pa for ever and the face's mean with them"
                    ),
                    "give the face the wall's normal at the sensor (e.g. normal = [-1.0, 0.0, 0.0] on a wall facing −x), with the probe's position on the wall's face",
                )),
                _ => c.fail(
                    "position",
                    probe.position,
                    &format!(
                        "lies inside fixed block '{name}' ({deepest:.2e} m deep), where no water reaches: the probe would read dry for ever"
                    ),
                    "put the probe on the block's face or in the water",
                ),
            })
        });
    }
}

/// `[[gauge]]` names: plain and unique.
fn gauges(c: &mut Checker, s: &Scene) {
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
}

/// `[[runup]]`: unique names and a non-empty box over the domain in plan.
fn runups(c: &mut Checker, s: &Scene) {
    let d = &s.domain;
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
                let reach = far_corner(s, &[r.min, r.max]);
                if let Some((field, v)) = reach {
                    c.fail(
                        field,
                        v,
                        &format!(
                            "reaches beyond ten domain sizes ({:.3e} m) outside [domain] in plan, or is not finite",
                            10.0 * plan_diagonal(s)
                        ),
                        "give the shore's box in plan over the domain, in metres, e.g. min = [150, 190], max = [250, 260]",
                    );
                } else if !(0..2).all(|k| r.min[k] < r.max[k]) {
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
}

/// `[[probe]]`: unique names and a positive averaging window.
fn probes(c: &mut Checker, s: &Scene) {
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
                    let fix = "give the averaging window in seconds (e.g. window = 0.001), or leave it out for the instantaneous reading";
                    if !(w.is_finite() && w > 0.0) {
                        c.fail("window", w, "must be a positive finite number", fix);
                    } else if w < MIN_PROBE_WINDOW {
                        c.fail(
                            "window",
                            w,
                            &format!(
                                "is shorter than {MIN_PROBE_WINDOW:e} s: no sensor samples faster, and a window \
                                 below the time's rounding holds no reading (every row NaN)"
                            ),
                            fix,
                        );
                    } else if s.time.end.is_finite() && w > s.time.end {
                        // A window in milliseconds read as seconds (window = 1 for 1 ms) would
                        // make every row the mean since the start, its peaks smeared unseen.
                        c.fail(
                            "window",
                            w,
                            &format!(
                                "is longer than the run (time.end = {} s): every row would be the mean since the start, not over a window",
                                crate::math::readable(s.time.end)
                            ),
                            fix,
                        );
                    }
                }
                if let Some(f) = p.face {
                    c.key("face", |c| {
                        c.positive(
                            "diameter",
                            f.diameter,
                            "give the sensing face's diameter in metres (e.g. diameter = 0.0042)",
                        );
                        let n2: f64 = f.normal.iter().map(|x| x * x).sum();
                        if !(n2.is_finite() && n2 > 0.0) {
                            c.fail(
                                "normal",
                                f.normal,
                                "must be a finite, non-zero vector",
                                "give the wall's normal at the sensor, e.g. normal = [-1.0, 0.0, 0.0]",
                            );
                        }
                        if let Some(span) = f.span {
                            let s2: f64 = span.iter().map(|x| x * x).sum();
                            let along: f64 = (0..3).map(|k| span[k] * f.normal[k]).sum();
                            let fix = "give the line across the flow in metres, in the face's plane, e.g. span = [0.0, 0.075, 0.0] for a face with normal = [-1.0, 0.0, 0.0]; or leave it out for the disk";
                            if !(s2.is_finite() && s2 > 0.0) {
                                c.fail("span", span, "must be a finite, non-zero vector", fix);
                            } else if n2.is_finite()
                                && n2 > 0.0
                                && along.abs() > 1e-9 * (s2 * n2).sqrt()
                            {
                                c.fail(
                                    "span",
                                    span,
                                    "does not lie in the face's plane (it has a part along `normal`)",
                                    fix,
                                );
                            } else if f.diameter > 0.0
                                && s2.sqrt() / f.diameter > crate::scene::MAX_SPAN_DIAMETERS
                            {
                                c.fail(
                                    "span",
                                    span,
                                    &format!(
                                        "is more than {} diameters long ({} m): the line is read as two disks per diameter, and setting up the wall's reading grows with their square",
                                        crate::math::readable(crate::scene::MAX_SPAN_DIAMETERS),
                                        crate::math::readable(s2.sqrt())
                                    ),
                                    fix,
                                );
                            }
                        }
                    });
                }
            })
        });
    }
}

/// The diagonal of the domain in plan [m].
fn plan_diagonal(s: &Scene) -> f64 {
    let d = &s.domain;
    (0..2)
        .map(|k| (d.max[k] - d.min[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The first of `corners` (a run-up box's `min`, `max`) that is not finite or lies more than
/// ten domain sizes outside the domain in plan (a typo in an exponent, an `inf`), by field.
fn far_corner(s: &Scene, corners: &[[f64; 2]; 2]) -> Option<(&'static str, [f64; 2])> {
    let (d, reach) = (&s.domain, 10.0 * plan_diagonal(s));
    let far =
        |p: &[f64; 2]| (0..2).any(|k| !(p[k] >= d.min[k] - reach && p[k] <= d.max[k] + reach));
    ["min", "max"]
        .into_iter()
        .zip(corners)
        .find(|(_, p)| far(p))
        .map(|(f, p)| (f, *p))
}

/// gauges.csv has a column per gauge and one named `<name>_spray` per gauge: names must not
/// collide, and `time` is the first column.
fn gauge_columns(c: &mut Checker, s: &Scene) {
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
}

/// Gauges inside the domain in plan, probes inside it.
fn placement(c: &mut Checker, s: &Scene) {
    let d = &s.domain;
    let inside_xy =
        |x: f64, y: f64| x >= d.min[0] && x <= d.max[0] && y >= d.min[1] && y <= d.max[1];
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
}
