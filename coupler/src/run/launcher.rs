//! The fluid node as N MPI ranks: the launcher's command line (`mpirun -n N fluid-node …`, or
//! the words of `--mpirun`), what Open MPI needs on this machine, and the error when no launcher
//! is installed. The same fluid-node binary runs on every rank with the same arguments; rank 0
//! is the node the coupler talks to (fluid-node's `mpi` feature). One rank starts the node
//! itself, exactly as without MPI.

use crate::run::launch::NodeCommand;
use shared::protocol::Role;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The launcher `coupler run --fluid-ranks N` starts the ranks with when `--mpirun` names none:
/// Open MPI's and MPICH's both, on every Debian machine with either installed.
pub const DEFAULT_LAUNCHER: &str = "mpirun";

/// How long `<launcher> --version` may take to say which MPI it belongs to: Open MPI and
/// MPICH answer in milliseconds; a launcher that hangs on it is taken for neither.
const PROBE_TIMEOUT: Duration = Duration::from_secs(5);

/// Open MPI refuses to start as root unless told twice (CI runs as root); MPICH needs nothing.
const OPEN_MPI_ENV: [(&str, &str); 2] = [
    ("OMPI_ALLOW_RUN_AS_ROOT", "1"),
    ("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1"),
];

/// Which MPI a launcher belongs to, as far as starting the ranks differs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flavour {
    /// Open MPI's `mpirun`: refuses more ranks than cores without `--oversubscribe`, and root
    /// without [`OPEN_MPI_ENV`].
    OpenMpi,
    /// MPICH's `mpirun` (Hydra), Slurm's `srun`, or anything else: started as given.
    Other,
}

/// An MPI launcher as words: the program, then its own arguments (`mpirun --hostfile hosts`,
/// `srun --mpi=pmix`). `-n N` and the fluid node's command follow them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Launcher {
    pub words: Vec<String>,
}

impl Default for Launcher {
    fn default() -> Self {
        Launcher {
            words: vec![DEFAULT_LAUNCHER.to_string()],
        }
    }
}

impl Launcher {
    /// `--mpirun`'s command split into words as a POSIX shell splits them (quotes and
    /// backslashes keep a word together, e.g. `--mpirun "mpirun --mca btl tcp,self"`), or
    /// [`DEFAULT_LAUNCHER`] without one.
    pub fn parse(given: Option<&str>) -> Result<Launcher, String> {
        let Some(text) = given else {
            return Ok(Launcher::default());
        };
        match shlex::split(text) {
            Some(words) if !words.is_empty() => Ok(Launcher { words }),
            Some(_) => Err(format!(
                "--mpirun '{text}' names no program. Fix: e.g. --mpirun mpirun, or --mpirun \"srun --mpi=pmix\""
            )),
            None => Err(format!(
                "--mpirun '{text}': an unclosed quote or a trailing backslash. Fix: quote the command as a shell would, e.g. --mpirun \"mpirun --hostfile 'my hosts'\""
            )),
        }
    }

    /// The launcher's program, as written.
    pub fn program(&self) -> &str {
        &self.words[0]
    }

    /// Resolves the launcher's program (a bare name on PATH, as the fluid node's own is), or
    /// says that MPI is missing and what to install.
    pub fn check(&self) -> Result<PathBuf, String> {
        let probe = NodeCommand {
            role: Role::Fluid,
            program: PathBuf::from(self.program()),
            args: Vec::new(),
            env: Vec::new(),
            launcher: false,
        };
        probe.check().map_err(|_| {
            format!(
                "the MPI launcher '{}' is not installed (not an executable file{}), and more than one fluid rank needs it. \
                 Fix: install MPI (Debian: `apt-get install openmpi-bin libopenmpi-dev`, or MPICH's `mpich libmpich-dev`) \
                 and build the fluid node for it with `cargo build --release --features fluid-node/mpi`; \
                 or name the launcher with --mpirun (e.g. --mpirun srun); or run one fluid rank (--fluid-ranks 1)",
                self.program(),
                if self.program().contains('/') {
                    ""
                } else {
                    " on PATH"
                }
            )
        })
    }

    /// Which MPI the launcher at `program` belongs to: Open MPI's `--version` names it
    /// ("mpirun (Open MPI) 4.1.4"); anything else, or no answer within [`PROBE_TIMEOUT`], is
    /// [`Flavour::Other`].
    pub fn flavour(program: &Path) -> Flavour {
        let env = OPEN_MPI_ENV.map(|(k, v)| (k.to_string(), v.to_string()));
        let said = crate::run::node_ranks::answer_within(program, "--version", &env, PROBE_TIMEOUT)
            .unwrap_or_default();
        if said.contains("Open MPI") || said.contains("OpenRTE") {
            Flavour::OpenMpi
        } else {
            Flavour::Other
        }
    }

    /// The words before the fluid node's command: the launcher's, Open MPI's
    /// `--oversubscribe` (unless given), and `-n ranks`.
    pub fn prefix(&self, ranks: u32, flavour: Flavour) -> Vec<String> {
        let mut words = self.words.clone();
        if flavour == Flavour::OpenMpi && !words.iter().any(|w| w == "--oversubscribe") {
            // More ranks than cores is how the tests run (3 ranks on 2 cores) and how a user
            // tries a decomposition on a laptop; on a cluster the launcher's hostfile or
            // allocation places the ranks anyway.
            words.push("--oversubscribe".into());
        }
        words.push("-n".into());
        words.push(ranks.to_string());
        words
    }

    /// The fluid node's command as `ranks` MPI ranks: the launcher with [`Launcher::prefix`],
    /// then the node's program and arguments, with the environment `flavour` needs. One rank
    /// is the node's own command, unchanged.
    pub fn wrap(&self, node: &NodeCommand, ranks: u32, flavour: Flavour) -> NodeCommand {
        if ranks <= 1 {
            return node.clone();
        }
        let mut words = self.prefix(ranks, flavour).into_iter();
        let program = PathBuf::from(words.next().unwrap_or_default());
        let mut args: Vec<String> = words.collect();
        args.push(node.program.display().to_string());
        args.extend(node.args.iter().cloned());
        let mut env = node.env.clone();
        if flavour == Flavour::OpenMpi {
            env.extend(OPEN_MPI_ENV.map(|(k, v)| (k.to_string(), v.to_string())));
        }
        NodeCommand {
            role: node.role,
            program,
            args,
            env,
            launcher: true,
        }
    }

    /// The command a user starts the fluid ranks with under `--attach`: the launcher's words,
    /// `-n ranks`, then `node` (the fluid node's command line); `node` alone for one rank.
    pub fn attach_line(&self, ranks: u32, node: &str) -> String {
        if ranks <= 1 {
            return node.to_string();
        }
        let words = self.prefix(ranks, Flavour::Other);
        let quoted =
            shlex::try_join(words.iter().map(String::as_str)).unwrap_or_else(|_| words.join(" "));
        format!("{quoted} {node}")
    }
}

/// The fluid node's command for `ranks` ranks (asked by `asked`, e.g. `--fluid-ranks 2`):
/// unchanged for one; for more, wrapped in `launcher` after checking that the node's binary
/// exists and can run as ranks, and that the launcher exists (unless `attach`: the user starts
/// the ranks, maybe on other hosts).
pub fn fluid_command(
    node: NodeCommand,
    ranks: u32,
    asked: &str,
    launcher: &Launcher,
    attach: bool,
) -> Result<NodeCommand, String> {
    if ranks <= 1 || attach {
        return Ok(node);
    }
    let binary = node.check()?;
    // Before the launcher: a node without MPI needs rebuilding whether MPI is installed or not.
    crate::run::node_ranks::refuse_without_mpi(&node, &binary, ranks, asked)?;
    let program = launcher.check()?;
    Ok(launcher.wrap(&node, ranks, Launcher::flavour(&program)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node() -> NodeCommand {
        NodeCommand {
            role: Role::Fluid,
            program: PathBuf::from("/opt/rw/fluid-node"),
            args: vec!["--threads".into(), "1".into()],
            env: Vec::new(),
            launcher: false,
        }
    }

    #[test]
    fn one_rank_is_the_nodes_own_command() {
        let n = node();
        for flavour in [Flavour::OpenMpi, Flavour::Other] {
            let w = Launcher::default().wrap(&n, 1, flavour);
            assert_eq!(
                (w.program, w.args, w.env),
                (n.program.clone(), n.args.clone(), vec![])
            );
        }
        let given =
            fluid_command(n.clone(), 1, "--fluid-ranks 1", &Launcher::default(), false).unwrap();
        assert_eq!((given.program, given.args), (n.program, n.args));
        assert_eq!(
            Launcher::default().attach_line(1, "fluid-node --prefix r"),
            "fluid-node --prefix r"
        );
    }

    #[test]
    fn open_mpi_gets_oversubscribe_and_root_leave() {
        let w = Launcher::default().wrap(&node(), 3, Flavour::OpenMpi);
        assert_eq!(w.program, PathBuf::from("mpirun"));
        assert_eq!(
            w.args,
            [
                "--oversubscribe",
                "-n",
                "3",
                "/opt/rw/fluid-node",
                "--threads",
                "1"
            ]
        );
        assert!(
            w.env
                .contains(&("OMPI_ALLOW_RUN_AS_ROOT".into(), "1".into()))
        );
        assert!(
            w.env
                .contains(&("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM".into(), "1".into()))
        );
        // MPICH and the rest: as given, nothing added.
        let w = Launcher::default().wrap(&node(), 3, Flavour::Other);
        assert_eq!(w.args, ["-n", "3", "/opt/rw/fluid-node", "--threads", "1"]);
        assert!(w.env.is_empty());
    }

    #[test]
    fn mpirun_words_are_split_like_a_shell_and_replace_the_launcher() {
        let l = Launcher::parse(Some("srun --mpi=pmix")).unwrap();
        let w = l.wrap(&node(), 4, Flavour::Other);
        assert_eq!(w.program, PathBuf::from("srun"));
        assert_eq!(w.args[..3], ["--mpi=pmix", "-n", "4"]);
        let l = Launcher::parse(Some(
            "mpirun --mca btl tcp,self --hostfile 'my hosts' --oversubscribe",
        ))
        .unwrap();
        assert_eq!(
            l.prefix(2, Flavour::OpenMpi),
            [
                "mpirun",
                "--mca",
                "btl",
                "tcp,self",
                "--hostfile",
                "my hosts",
                "--oversubscribe",
                "-n",
                "2"
            ],
            "quotes keep a word; --oversubscribe is not given twice"
        );
        assert_eq!(
            l.attach_line(2, "fluid-node --prefix r"),
            "mpirun --mca btl 'tcp,self' --hostfile 'my hosts' --oversubscribe -n 2 fluid-node --prefix r",
            "quoted so that a shell gives the launcher the same words"
        );
        assert_eq!(Launcher::parse(None).unwrap().words, ["mpirun"]);
        let msg = Launcher::parse(Some("  ")).unwrap_err();
        assert!(
            msg.contains("names no program") && msg.contains("Fix:"),
            "{msg}"
        );
        let msg = Launcher::parse(Some("mpirun 'open")).unwrap_err();
        assert!(
            msg.contains("unclosed quote") && msg.contains("Fix:"),
            "{msg}"
        );
    }

    #[test]
    fn a_missing_launcher_says_what_to_install() {
        let l = Launcher::parse(Some("/nonexistent/mpirun -x A")).unwrap();
        let msg = l.check().unwrap_err();
        for says in [
            "'/nonexistent/mpirun'",
            "openmpi-bin libopenmpi-dev",
            "MPICH",
            "cargo build --release --features fluid-node/mpi",
            "--mpirun",
        ] {
            assert!(msg.contains(says), "{says}: {msg}");
        }
        // Before anything of the run exists: the node's own binary is there.
        let me = std::env::current_exe().unwrap();
        let n = NodeCommand {
            program: me,
            ..node()
        };
        let err = fluid_command(n.clone(), 2, "--fluid-ranks 2", &l, false).unwrap_err();
        assert_eq!(err, msg);
        // Under --attach the user starts the ranks: nothing is checked, nothing wrapped.
        let attached = fluid_command(n.clone(), 2, "--fluid-ranks 2", &l, true).unwrap();
        assert_eq!(attached.program, n.program);
    }

    /// Which MPI `--version` names: Open MPI's says so; MPICH's (Hydra) and a launcher that
    /// cannot run are started as given.
    #[test]
    fn the_launchers_version_tells_open_mpi() {
        let dir = tempfile::tempdir().unwrap();
        let script = |name: &str, says: &str| {
            use std::os::unix::fs::PermissionsExt;
            let path = dir.path().join(name);
            std::fs::write(&path, format!("#!/bin/sh\necho '{says}'\n")).unwrap();
            std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
            path
        };
        let ompi = script("ompi", "mpirun (Open MPI) 4.1.4");
        let mpich = script("mpich", "HYDRA build details:\n    Version: 4.0.2");
        assert_eq!(Launcher::flavour(&ompi), Flavour::OpenMpi);
        assert_eq!(Launcher::flavour(&mpich), Flavour::Other);
        assert_eq!(
            Launcher::flavour(Path::new("/nonexistent/mpirun")),
            Flavour::Other
        );
    }
}
