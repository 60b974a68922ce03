//! The solvers a node crate offers, in one list: name, description, constructor and the check of
//! the solver's own parameter table. The node binary (`--solver NAME`), the validation and bench
//! binaries and the coupler's sweeps all read the same list, so adding a solver is one file and
//! one line here.
//!
//! Each solver owns its parameters: a serde type deserialised from its own table of the scene
//! (`[fluid.wcsph]`, `[solid.implicit]`, …), kept by [`crate::scene`] as raw TOML until the
//! solver reads it with [`params`].

use crate::scene::{CouplingScheme, FieldError, Scene, SolverTables};
use crate::solver::{SetupContext, SolverError};
use serde::de::DeserializeOwned;

/// A solver's parameter table: deserialised from `[<role>.<name>]` (every field optional, with
/// the solver's defaults), then checked value by value.
pub trait SolverParams: DeserializeOwned + Default {
    /// Pushes one error per impossible value, through `check.fail(field, value, problem, fix)`.
    fn check(&self, check: &mut ParamCheck);
}

/// Collects the errors of one solver table, naming each field by its full path
/// (`fluid.wcsph.gamma`).
pub struct ParamCheck {
    table: Vec<String>,
    errors: Vec<FieldError>,
}

impl ParamCheck {
    /// Reports `field` of this table as `value`: `problem`; fix: `fix`.
    pub fn fail(&mut self, field: &str, value: impl std::fmt::Debug, problem: &str, fix: &str) {
        let mut path: Vec<&str> = self.table.iter().map(String::as_str).collect();
        path.push(field);
        self.errors
            .push(FieldError::new(&path, format!("{value:?}"), problem, fix));
    }

    /// `value` must be finite and > 0 (`None` means the solver derives it).
    pub fn positive(&mut self, field: &str, value: Option<f64>, fix: &str) {
        if let Some(v) = value
            && !(v.is_finite() && v > 0.0)
        {
            self.fail(field, v, "must be a positive finite number", fix);
        }
    }

    /// `value` must be finite and ≥ 0.
    pub fn non_negative(&mut self, field: &str, value: Option<f64>, fix: &str) {
        if let Some(v) = value
            && !(v.is_finite() && v >= 0.0)
        {
            self.fail(field, v, "must be a finite number >= 0", fix);
        }
    }
}

/// Reads solver `name`'s table `[<role>.<name>]` into `P` (defaults where the table or a field is
/// absent) and checks it. `role` is `fluid` or `solid`.
pub fn params<P: SolverParams>(
    tables: &SolverTables,
    role: &str,
    name: &str,
) -> Result<P, Vec<FieldError>> {
    let p: P = match tables.get(name) {
        None => P::default(),
        Some(value) => value.clone().try_into().map_err(|e: toml::de::Error| {
            vec![FieldError::new(
                &[role, name],
                "{…}".into(),
                e.message().trim(),
                &format!(
                    "see the fields of [{role}.{name}]: the doc comments of its parameter type, in the solver's own file (docs/ARCHITECTURE.md, \"Solvers: registries and their own parameters\")"
                ),
            )]
        })?,
    };
    let mut check = ParamCheck {
        table: vec![role.into(), name.into()],
        errors: Vec::new(),
    };
    p.check(&mut check);
    if check.errors.is_empty() {
        Ok(p)
    } else {
        Err(check.errors)
    }
}

/// [`params`]'s errors alone, for a registry entry's `check`.
pub fn check_params<P: SolverParams>(
    tables: &SolverTables,
    role: &str,
    name: &str,
) -> Vec<FieldError> {
    params::<P>(tables, role, name).err().unwrap_or_default()
}

/// [`params`] for a solver's constructor: the errors as one [`SolverError`].
pub fn solver_params<P: SolverParams>(
    tables: &SolverTables,
    role: &str,
    name: &str,
) -> Result<P, SolverError> {
    params(tables, role, name).map_err(|errors| {
        SolverError::Failed(
            errors
                .iter()
                .map(|e| e.to_string())
                .collect::<Vec<_>>()
                .join("; "),
        )
    })
}

/// One solver of a node crate.
pub struct Entry<S: ?Sized> {
    /// As given to `--solver` and in the scene's `solver = "…"`.
    pub name: &'static str,
    /// One line for `--list` and the docs.
    pub description: &'static str,
    /// Builds the solver for a scene; it reads its own table with [`solver_params`].
    pub build: fn(&SetupContext) -> Result<Box<S>, SolverError>,
    /// Checks the solver's own table of the scene, naming each bad field.
    pub check: fn(&Scene) -> Vec<FieldError>,
    /// What the tools around the solver ask of it without building it ([`Advice::NONE`]: nothing).
    pub advice: Advice,
}

/// What a solver tells the tools around it (the coupler's checks and estimates, the validation)
/// without being built, so that no tool names a solver: each asks the registry's entry.
#[derive(Clone, Copy)]
pub struct Advice {
    /// The solver's step [s] for a scene's water of depth `depth` [m] at spacing `dx` [m]
    /// (`coupler check`'s estimate of a run's steps; `(scene, dx, depth)`), or `None` if it has
    /// no estimate of its own.
    pub estimate_dt: fn(&Scene, f64, f64) -> Option<f64>,
    /// Warnings about the scene's combination of options for this solver under `scheme`, one
    /// sentence each with its fix (the coupler prints them when a run starts).
    pub warnings: fn(&Scene, CouplingScheme) -> Vec<String>,
    /// The solver's own table (TOML of `[<role>.<name>]`) for the validation study named, when
    /// the study runs it with other than its defaults (`"still_water"`: a pressure study).
    pub study_table: fn(&str) -> Option<&'static str>,
    /// The ways a study runs the solver, in the order of the study's rows, for the study named
    /// (one of [`study`]'s names); empty: the solver takes no part in it.
    pub study_variants: fn(&str) -> &'static [Variant],
    /// Why the validation's check named (one of the validation's check names, e.g.
    /// `still_pressure`) at `resolution` (the check's own measure of it, e.g. particles per
    /// water height; 0 where it has none) fails by design of the solver as published, or `None`
    /// where the solver must pass it.
    pub known_limitation: fn(&str, usize) -> Option<&'static str>,
    /// Particle-steps per second of one thread of the solver, measured (`fluid-bench`): what a
    /// run's wall time is estimated with (the default checkpoints); `None` if not measured.
    pub particle_steps_per_second: Option<f64>,
    /// Whether the solver runs on several ranks of the fluid node (MPI): the coupler refuses a
    /// run on more than one rank before it starts when it does not.
    pub splits_over_ranks: bool,
}

impl Advice {
    /// No estimate, no warning, the defaults for every study, in no study's rows, no known
    /// limitation, one rank only.
    pub const NONE: Advice = Advice {
        estimate_dt: |_, _, _| None,
        warnings: |_, _| Vec::new(),
        study_table: |_| None,
        study_variants: |_| &[],
        known_limitation: |_, _| None,
        particle_steps_per_second: None,
        splits_over_ranks: false,
    };
}

/// The studies that ask a solver's entry which rows it takes part in
/// ([`Advice::study_variants`]).
pub mod study {
    /// `coupler stability`, the dt map's coupled floating-block rows.
    pub const STABILITY_DT: &str = "stability_dt";
    /// `coupler stability`, the density map's rows.
    pub const STABILITY_DENSITY: &str = "stability_density";
    /// `fluid-validate`: the solver run once more with Eq. 22 penalty walls only (group
    /// `<name>-penalty`), to show what boundary particles buy.
    pub const PENALTY_WALLS: &str = "penalty_walls";
}

/// One way a study runs a solver: its own table and the couplings of its rows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variant {
    /// Appended to the solver's name in the rows' labels ("" for none).
    pub label: &'static str,
    /// The solver's own table `[<role>.<name>]` for these rows, as TOML ("": its defaults).
    pub table: &'static str,
    /// Whether the rows are run with every solver of the other role (in its registry's order,
    /// each with all of [`Self::couplings`]) or with its registry's first only.
    pub every_partner: bool,
    /// The couplings of the rows, in order (empty for a study without coupling).
    pub couplings: &'static [StudyCoupling],
}

impl Variant {
    /// The solver with its defaults, partnered with the other role's first solver, in no
    /// coupling of its own (a study that only asks whether the solver takes part).
    pub const DEFAULTS: Variant = Variant {
        label: "",
        table: "",
        every_partner: false,
        couplings: &[],
    };
}

/// The coupling of a study's row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StudyCoupling {
    pub scheme: CouplingScheme,
    /// Whether the solid sub-cycles inside the coupling step, at the study's own rate
    /// (`[coupling] solid_substeps`); single-rate otherwise.
    pub subcycled: bool,
    /// `[coupling] added_mass` (0: off).
    pub added_mass: f64,
}

impl StudyCoupling {
    /// Single-rate, no added mass, under `scheme`.
    pub const fn plain(scheme: CouplingScheme) -> StudyCoupling {
        StudyCoupling {
            scheme,
            subcycled: false,
            added_mass: 0.0,
        }
    }

    /// Sub-cycled at the study's rate, no added mass, under `scheme`.
    pub const fn subcycled(scheme: CouplingScheme) -> StudyCoupling {
        StudyCoupling {
            scheme,
            subcycled: true,
            added_mass: 0.0,
        }
    }

    /// This coupling with `[coupling] added_mass = added_mass`.
    pub const fn relaxed(self, added_mass: f64) -> StudyCoupling {
        StudyCoupling { added_mass, ..self }
    }
}

/// The solvers of one role (`fluid` or `solid`), in the order they are listed. The first is the
/// role's default solver: the scene schema's default, and the one the studies and validation
/// cases that run a single solver take.
pub struct Registry<S: ?Sized + 'static> {
    pub role: &'static str,
    pub entries: &'static [Entry<S>],
}

impl<S: ?Sized> Registry<S> {
    /// The role's default solver: the first entry.
    pub fn first(&self) -> &Entry<S> {
        &self.entries[0]
    }

    pub fn names(&self) -> Vec<&'static str> {
        self.entries.iter().map(|e| e.name).collect()
    }

    /// The entry called `name`, or an error listing the names there are.
    pub fn get(&self, name: &str) -> Result<&Entry<S>, SolverError> {
        self.entries.iter().find(|e| e.name == name).ok_or_else(|| {
            SolverError::Failed(format!(
                "unknown {} solver '{name}'; fix: use one of {}",
                self.role,
                self.names().join(", ")
            ))
        })
    }

    pub fn build(&self, name: &str, ctx: &SetupContext) -> Result<Box<S>, SolverError> {
        (self.get(name)?.build)(ctx)
    }

    /// Checks the scene's solver tables of this role: every `[<role>.<name>]` must name a solver
    /// here, and each solver's table must hold valid parameters. Also checks the role's default
    /// `solver = "…"`.
    pub fn check(&self, scene: &Scene, tables: &SolverTables, default: &str) -> Vec<FieldError> {
        let role = self.role;
        let mut errors = Vec::new();
        let known = self
            .names()
            .iter()
            .map(|n| format!("[{role}.{n}]"))
            .collect::<Vec<_>>()
            .join(", ");
        if self.get(default).is_err() {
            errors.push(FieldError::new(
                &[role, "solver"],
                format!("{default:?}"),
                &format!("is not a {role} solver"),
                &format!("use one of {}", self.names().join(", ")),
            ));
        }
        for name in tables.keys() {
            if self.get(name).is_err() {
                errors.push(FieldError::new(
                    &[role, name],
                    "{…}".into(),
                    &format!("is neither a field of [{role}] nor a {role} solver's table"),
                    &format!("solver tables are {known}; check the spelling"),
                ));
            }
        }
        for e in self.entries {
            errors.extend((e.check)(scene));
        }
        errors
    }
}
