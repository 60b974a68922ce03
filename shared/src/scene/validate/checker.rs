//! The walk of a scene: the field path it is at, the errors found so far, and the checks
//! every part of the scene uses (positive, finite, a name, a shape inside the domain).

use crate::geometry::Polyhedron;
use crate::math::readable;
use crate::scene::error::{FieldError, Seg, render_path};
use crate::scene::schema::{DomainSpec, ShapeSpec};

/// Collects errors while walking the scene.
pub(super) struct Checker {
    path: Vec<Seg>,
    pub(super) errors: Vec<FieldError>,
}

impl Checker {
    pub(super) fn new() -> Self {
        Checker {
            path: Vec::new(),
            errors: Vec::new(),
        }
    }

    pub(super) fn at<R>(&mut self, seg: Seg, f: impl FnOnce(&mut Self) -> R) -> R {
        self.path.push(seg);
        let r = f(self);
        self.path.pop();
        r
    }

    pub(super) fn key<R>(&mut self, k: &str, f: impl FnOnce(&mut Self) -> R) -> R {
        self.at(Seg::Key(k.into()), f)
    }

    pub(super) fn fail(
        &mut self,
        field: &str,
        value: impl std::fmt::Debug,
        problem: &str,
        fix: &str,
    ) {
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

    pub(super) fn positive(&mut self, field: &str, v: f64, fix: &str) {
        if !(v.is_finite() && v > 0.0) {
            self.fail(field, v, "must be a positive finite number", fix);
        }
    }

    pub(super) fn finite3(&mut self, field: &str, v: [f64; 3]) {
        if v.iter().any(|x| !x.is_finite()) {
            self.fail(field, v, "must be finite", "give three finite numbers");
        }
    }

    /// A name written into CSV headers and cells, JSON keys and messages: not empty, no
    /// separator, quote or control character, no spaces at either end (CSV readers trim them).
    pub(super) fn label(&mut self, field: &str, name: &str, what: &str) {
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

    pub(super) fn shape(&mut self, shape: &ShapeSpec, domain: &DomainSpec, reach: Reach) {
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
            Ok(p) if reach == Reach::Inside => {
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
            Ok(p) if reach == Reach::Fixed && domain.open_top => {
                // Above an open top the water meets no wall (boundary particles end there): a
                // fixed block reaching higher would let the spray pass through it.
                let top = p.world_aabb().1[2];
                if top > domain.max[2] {
                    c.fail(
                        "",
                        shape_summary(shape),
                        &format!(
                            "reaches z = {} m, above the open domain top (max[2] = {} m), where the spray would pass through it",
                            readable(top),
                            readable(domain.max[2])
                        ),
                        "raise [domain] max[2] to the block's top, or cut the block at the top",
                    );
                }
            }
            Ok(_) => {}
        });
    }
}

/// How far a shape may reach past `[domain]` ([`Checker::shape`]).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Reach {
    /// Inside it (water, moving blocks).
    Inside,
    /// Past its faces (a fixed block: the walls), but not above an open top.
    Fixed,
    /// Not checked here (a block cut from a slide: its region is, once).
    Unchecked,
}

/// A shape in a few words, as the value of its error.
pub(super) fn shape_summary(shape: &ShapeSpec) -> String {
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
