//! The coupled sweeps: the floating block (scenes/validation/floating_block.toml) run as real
//! processes through `coupler run`, with the knobs a sweep turns (solvers, scheme, dx, dt
//! factor, block density, Eq. 22 stiffness) applied as a scene variant or a command-line flag.

use crate::studies::runner::{self, RunOutcome, Scratch};
use shared::scene::{CouplingScheme, Scene, ShapeSpec};
use std::path::Path;

/// The floating-block scene, compiled in so the sweeps run from any directory.
pub const FLOATING_BLOCK: &str = include_str!("../../../scenes/validation/floating_block.toml");

/// Name of the floating block in the scene.
pub const BLOCK: &str = "block";

/// The base scene.
pub fn floating_scene() -> Scene {
    Scene::parse(FLOATING_BLOCK, "scenes/validation/floating_block.toml")
        .expect("the embedded floating-block scene is valid")
}

/// Height of the block and water density of a floating-block scene.
pub fn block_height(scene: &Scene) -> f64 {
    let b = scene
        .blocks
        .iter()
        .find(|b| b.name == BLOCK)
        .expect("scene has the block");
    match &b.shape {
        ShapeSpec::Box { min, max } => max[2] - min[2],
        _ => panic!("the floating block is a box"),
    }
}

/// The knobs of one coupled run.
#[derive(Debug, Clone)]
pub struct Config {
    pub fluid: String,
    pub solid: String,
    pub scheme: CouplingScheme,
    pub dx: f64,
    pub dt_factor: f64,
    /// Block density [kg/m³] (None: the scene's 500).
    pub density: Option<f64>,
    /// Eq. 22 K_S as a multiple of the default (None: the default). Needs the default, so the
    /// caller gives the absolute value instead: [`Config::penalty_stiffness`].
    pub penalty_stiffness: Option<f64>,
    /// Simulated time [s].
    pub end: f64,
    /// Multi-rate coupling: the solid's steps per coupling step at most (1: single-rate).
    pub solid_substeps: u32,
    /// Added-mass stabilisation, `[coupling] added_mass` (0: off).
    pub added_mass: f64,
    /// The fluid solver's own table `[fluid.<name>]` as TOML, merged into the scene's ("": the
    /// scene's), from the solver's registry entry ([`shared::registry::Variant::table`]).
    pub fluid_table: &'static str,
    /// Appended to the fluid solver's name in the label ([`shared::registry::Variant::label`]).
    pub fluid_label: &'static str,
}

impl Config {
    pub fn label(&self) -> String {
        let rate = match self.solid_substeps {
            1 => String::new(),
            n => format!(" ×{n} substeps"),
        };
        let relaxed = if self.added_mass > 0.0 {
            format!(" +{} ρV added mass", self.added_mass)
        } else {
            String::new()
        };
        format!(
            "{}{}+{}/{}{rate}{relaxed}",
            self.fluid, self.fluid_label, self.solid, self.scheme
        )
    }
}

/// A finished coupled run with its draft measurement.
#[derive(Debug, Clone)]
pub struct FloatRun {
    pub config: Config,
    pub outcome: RunOutcome,
    /// Reference draft (ρ_b/ρ_w)·h [m].
    pub reference: f64,
    /// Mean draft over the second half of the run [m], and the block's largest |vz| there.
    pub draft: Result<(f64, f64), String>,
}

impl FloatRun {
    /// |draft − reference| / reference (NaN if the run or the measurement failed).
    pub fn error(&self) -> f64 {
        match (&self.draft, self.outcome.completed()) {
            (Ok((d, _)), true) => (d - self.reference).abs() / self.reference,
            _ => f64::NAN,
        }
    }
}

/// Runs the floating block with `config` through `coupler` (`exe`; None: this executable),
/// in a fresh directory under `scratch`.
pub fn floating(exe: Option<&Path>, scratch: &Scratch, config: &Config) -> FloatRun {
    let mut scene = floating_scene();
    let h = block_height(&scene);
    let rho_w = scene.fluid.as_ref().map(|f| f.density).unwrap_or(1000.0);
    if let Some(rho) = config.density {
        for b in scene.blocks.iter_mut().filter(|b| b.name == BLOCK) {
            b.density = rho;
        }
    }
    if let Some(k) = config.penalty_stiffness {
        scene.coupling.penalty_stiffness = Some(k);
    }
    if let (false, Some(fluid)) = (config.fluid_table.is_empty(), scene.fluid.as_mut()) {
        let own: toml::Table = toml::from_str(config.fluid_table)
            .expect("a registry entry's study table is valid TOML");
        let table = fluid
            .solvers
            .entry(config.fluid.clone())
            .or_insert_with(|| toml::Value::Table(Default::default()));
        if let toml::Value::Table(t) = table {
            t.extend(own);
        }
    }
    let rho_b = scene
        .blocks
        .iter()
        .find(|b| b.name == BLOCK)
        .map(|b| b.density)
        .unwrap_or(500.0);
    let id = shared::transport::RunId::fresh();
    let scene_path = scratch.path.join(format!("scene-{id}.toml"));
    let out = scratch.path.join(format!("run-{id}"));
    let args: Vec<String> = vec![
        "--fluid-solver".into(),
        config.fluid.clone(),
        "--solid-solver".into(),
        config.solid.clone(),
        "--scheme".into(),
        config.scheme.to_string(),
        "--dx".into(),
        config.dx.to_string(),
        "--end".into(),
        config.end.to_string(),
        "--dt-factor".into(),
        config.dt_factor.to_string(),
        "--solid-substeps".into(),
        config.solid_substeps.to_string(),
        "--added-mass".into(),
        config.added_mass.to_string(),
        "--run-id".into(),
        id.to_string(),
    ];
    let outcome = runner::write_scene(&scene, &scene_path).and_then(|_| match exe {
        Some(exe) => runner::coupler_run_with(exe, &scene_path, &args, &out),
        None => runner::coupler_run(&scene_path, &args, &out),
    });
    let outcome = match outcome {
        Ok(o) => o,
        Err(e) => RunOutcome {
            status: "failed".into(),
            message: e,
            exit_code: -1,
            wall_seconds: f64::NAN,
            warnings: 0,
            last_warning: None,
            steps: 0,
            time: 0.0,
            dir: out.clone(),
        },
    };
    // The draft over the second half of the run: the block starts at the exact equilibrium and
    // settles a few mm deeper (the Eq. 22 boundary) within ~0.5 s; averaging [0.5, 1] s spans
    // about one heave period of what is left of that oscillation.
    let draft = runner::mean_draft(&out, BLOCK, h, 0.5 * config.end, config.end);
    FloatRun {
        config: config.clone(),
        outcome,
        reference: rho_b / rho_w * h,
        draft,
    }
}
