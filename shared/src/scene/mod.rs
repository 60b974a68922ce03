//! Scenes: the TOML schema ([`schema`], the tables as written), the slides cut into blocks
//! ([`slide`]), validation that names the field, the bad value and the fix ([`validate`], its
//! [`FieldError`] in `error`), and the line a field sits on ([`span`]).

mod error;
mod motion;
mod read;
pub mod schema;
pub mod slide;
mod span;
mod validate;

pub use error::FieldError;
pub use read::MAX_SCENE_BYTES;
pub use schema::*;
pub use validate::fluid_ranks_problem;
pub(crate) use validate::{indexed_field_error, terrain_field_error, terrain_reach_problem};

use std::path::Path;

/// The paper's Example 2 (a rigid wedge sliding down a 25° plane into water): the scene that runs
/// when none is given.
pub const DEFAULT_SCENE: &str = include_str!("../../../scenes/sliding_wedge.toml");
/// Where [`DEFAULT_SCENE`] lives in the repository, for messages.
pub const DEFAULT_SCENE_ORIGIN: &str = "scenes/sliding_wedge.toml (embedded default)";

/// A check a scene must also pass, beyond its own validation (e.g. a solver registry's check of
/// the solver tables); returns every problem it finds.
pub type SceneCheck = dyn Fn(&Scene) -> Vec<FieldError>;

/// Why a scene could not be used.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("cannot read scene file '{path}': {source}")]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The path names no scene file: not a regular file (a device, a pipe, a directory), or
    /// longer than [`MAX_SCENE_BYTES`]. Refused before anything is read from it.
    #[error("scene file '{path}' {problem}; fix: {fix}")]
    NotAScene {
        path: String,
        problem: String,
        fix: String,
    },
    /// The TOML parser or the schema rejected the text; the message carries line and column.
    #[error("scene '{origin}' is not a valid scene file:\n{message}")]
    Syntax { origin: String, message: String },
    /// The text parsed but some values are impossible.
    #[error("scene '{origin}' has {} invalid field(s):\n{}", errors.len(), render(errors))]
    Invalid {
        origin: String,
        errors: Vec<FieldError>,
    },
}

/// The parser's message (line, column, the offending text), led by the field it belongs to when
/// the parser does not name it (serde reports a bad enum value without its key), and followed
/// by the type the field takes with an example when the value has the wrong type
/// ([`read::type_fix`]).
fn syntax_message(text: &str, e: &toml::de::Error) -> String {
    let field = e.span().and_then(|s| span::field_at(text, s.start));
    let mut message = match &field {
        Some(f) if !e.message().contains(f.as_str()) => format!("in field `{f}`: {e}"),
        _ => e.to_string(),
    };
    if let Some(fix) = field.and_then(|f| read::type_fix(&f, e.message())) {
        message.push_str(&fix);
    }
    message
}

fn render(errors: &[FieldError]) -> String {
    errors
        .iter()
        .map(|e| format!("  {e}"))
        .collect::<Vec<_>>()
        .join("\n")
}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Scene::load_checked(path, &[])
    }

    /// [`Self::load`] with [`Self::parse_checked`]'s extra checks.
    pub fn load_checked(path: &Path, checks: &[&SceneCheck]) -> Result<Scene, SceneError> {
        let text = read::scene_text(path)?;
        let base = path.parent().unwrap_or(Path::new("."));
        Scene::parse_in(&text, &path.display().to_string(), Some(base), checks)
    }

    /// The embedded default scene.
    pub fn default_scene() -> Scene {
        Scene::parse(DEFAULT_SCENE, DEFAULT_SCENE_ORIGIN)
            .expect("the embedded default scene is valid")
    }

    /// Parses and validates scene text; `origin` names it in messages.
    pub fn parse(text: &str, origin: &str) -> Result<Scene, SceneError> {
        Scene::parse_checked(text, origin, &[])
    }

    /// [`Self::parse`], plus `checks` that know more than this crate, e.g. the solver registries'
    /// checks of each solver's own parameter table (`shared::registry::Registry::check`).
    pub fn parse_checked(
        text: &str,
        origin: &str,
        checks: &[&SceneCheck],
    ) -> Result<Scene, SceneError> {
        Scene::parse_in(text, origin, None, checks)
    }

    /// [`Self::parse_checked`] of a scene file in directory `base`: the files it names
    /// (`terrain[i].file`) are relative to it, and made absolute so that the scene as run
    /// (the nodes' copy, the run directory's `scene.toml`) still finds them.
    pub fn parse_in(
        text: &str,
        origin: &str,
        base: Option<&Path>,
        checks: &[&SceneCheck],
    ) -> Result<Scene, SceneError> {
        let mut scene: Scene = toml::from_str(text).map_err(|e| SceneError::Syntax {
            origin: origin.into(),
            message: syntax_message(text, &e),
        })?;
        if let Some(base) = base {
            scene.terrain.iter_mut().for_each(|t| t.resolve(base));
        }
        let mut errors = span::array_lengths(text);
        // Slides become blocks first, so that every check below sees the blocks that will run.
        errors.extend(slide::expand(&mut scene));
        errors.extend(scene.validate());
        for check in checks {
            errors.extend(check(&scene));
        }
        if errors.is_empty() {
            return Ok(scene);
        }
        span::locate(text, &mut errors);
        Err(SceneError::Invalid {
            origin: origin.into(),
            errors,
        })
    }

    /// Checks every value; returns all problems found (empty when the scene is usable).
    pub fn validate(&self) -> Vec<FieldError> {
        let mut errors = validate::validate(self);
        slide::attribute(self, &mut errors);
        errors.extend(slide::spacing_errors(self));
        errors
    }

    /// True when the scene has water, i.e. a fluid node must run.
    pub fn has_fluid(&self) -> bool {
        self.fluid.as_ref().is_some_and(|f| !f.water.is_empty())
    }

    /// The lowest bottom and highest top [m] of the scene's water volumes (`fluid.water`) as
    /// given, before they are filled: their depth bounds the water's. `None` without water or
    /// when no volume is a valid shape (the scene check names those).
    pub fn water_span(&self) -> Option<(f64, f64)> {
        let water = &self.fluid.as_ref()?.water;
        water
            .iter()
            .filter_map(|w| crate::geometry::Polyhedron::from_shape(&w.shape).ok())
            .map(|p| {
                let (lo, hi) = p.world_aabb();
                (lo.z, hi.z)
            })
            .reduce(|(b, t), (lo, hi)| (b.min(lo), t.max(hi)))
    }

    /// The bed under a wave gauge at (x, y): the highest top of a fixed block on the vertical
    /// line through it, or the domain floor where no fixed block is under it. Moving blocks are
    /// not bed (they move over it). A dry gauge reads this elevation.
    pub fn bed_elevation(&self, x: f64, y: f64) -> f64 {
        self.blocks
            .iter()
            .filter(|b| b.kind == BlockKind::Fixed)
            .filter_map(|b| crate::geometry::Polyhedron::from_shape(&b.shape).ok())
            .filter_map(|p| p.top_at(x, y))
            .fold(self.domain.min[2], f64::max)
    }

    /// True when some block moves (kinematic or free), i.e. a solid node must run.
    pub fn has_moving_blocks(&self) -> bool {
        self.blocks.iter().any(|b| b.kind != BlockKind::Fixed)
    }

    /// Indices (into `blocks`) of the blocks whose geometry changes: the ones exchanged each step.
    pub fn moving_blocks(&self) -> Vec<usize> {
        (0..self.blocks.len())
            .filter(|&i| self.blocks[i].kind != BlockKind::Fixed)
            .collect()
    }

    /// Overrides the particle spacing (the `--dx` of quick runs).
    pub fn set_dx(&mut self, dx: f64) {
        if let Some(f) = self.fluid.as_mut() {
            f.dx = dx;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_scene_is_valid() {
        let s = Scene::default_scene();
        assert!(s.has_fluid());
        assert!(s.has_moving_blocks());
    }

    #[test]
    fn gauge_names_must_not_collide_with_spray_columns() {
        let text = format!("{DEFAULT_SCENE}\n[[gauge]]\nname = \"G1_spray\"\nx = 1.0\ny = 0.4\n");
        let msg = Scene::parse(&text, "t.toml").unwrap_err().to_string();
        assert!(
            msg.contains("G1_spray") && msg.contains("collides"),
            "{msg}"
        );
    }

    #[test]
    fn the_bed_under_the_default_scene_gauges_is_the_tank_floor() {
        let s = Scene::default_scene();
        for g in &s.gauges {
            let bed = s.bed_elevation(g.x, g.y);
            assert!(
                bed >= s.domain.min[2] && bed < 0.48,
                "{}: bed {bed}",
                g.name
            );
        }
        // Outside every block: the domain floor.
        assert_eq!(s.bed_elevation(-1e3, -1e3), s.domain.min[2]);
    }

    #[test]
    fn syntax_error_names_line() {
        let err = Scene::parse("name = \"x\"\n[time]\nend = \n", "t.toml").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("line 3"), "{msg}");
    }

    #[test]
    fn unknown_field_is_named() {
        let text = DEFAULT_SCENE.replace("[time]", "[time]\nendd = 3.0");
        let msg = Scene::parse(&text, "t.toml").unwrap_err().to_string();
        assert!(msg.contains("endd"), "{msg}");
    }

    #[test]
    fn stray_fluid_value_is_named_with_its_line() {
        let text = DEFAULT_SCENE.replace("\ndx = 0.04\n", "\ndx = 0.04\ndxx = 0.1\n");
        let msg = Scene::parse(&text, "t.toml").unwrap_err().to_string();
        assert!(
            msg.contains("fluid.dxx") && msg.contains("line ") && msg.contains("[fluid.wcsph]"),
            "{msg}"
        );
    }

    #[test]
    fn stray_solid_value_is_named_with_its_line() {
        let text = DEFAULT_SCENE.replace(
            "solver = \"explicit\"\n",
            "solver = \"explicit\"\nsafety_factor = 0.5\n",
        );
        assert_ne!(text, DEFAULT_SCENE);
        let msg = Scene::parse(&text, "t.toml").unwrap_err().to_string();
        assert!(
            msg.contains("solid.safety_factor")
                && msg.contains("line ")
                && msg.contains("[solid.implicit]"),
            "{msg}"
        );
    }

    #[test]
    fn zero_solid_substeps_are_refused() {
        let text = format!("{DEFAULT_SCENE}\n")
            .replace("[coupling]\n", "[coupling]\nsolid_substeps = 0\n");
        let msg = Scene::parse(&text, "t.toml").unwrap_err().to_string();
        assert!(
            msg.contains("coupling.solid_substeps") && msg.contains("fix"),
            "{msg}"
        );
    }

    #[test]
    fn unknown_wall_treatment_is_named() {
        let text = DEFAULT_SCENE.replace("\ndx = 0.04\n", "\ndx = 0.04\nwalls = \"sponge\"\n");
        let msg = Scene::parse(&text, "t.toml").unwrap_err().to_string();
        assert!(
            msg.contains("fluid.walls") && msg.contains("sponge") && msg.contains("penalty"),
            "{msg}"
        );
    }

    #[test]
    fn bad_value_names_field_line_and_fix() {
        let text = DEFAULT_SCENE.replacen("density = 2500.0", "density = -3.0", 1);
        let err = Scene::parse(&text, "t.toml").unwrap_err();
        let SceneError::Invalid { errors, .. } = &err else {
            panic!("{err}")
        };
        let e = &errors[0];
        assert!(e.path.ends_with(".density"), "{e}");
        let line = e.line.expect("line located");
        assert!(text.lines().nth(line - 1).unwrap().contains("-3.0"), "{e}");
        assert!(!e.fix.is_empty());
    }
}
