//! Finding and starting the node processes, and ending them whatever happens.

use crate::run::rank_report::RankReport;
use shared::protocol::Role;
use shared::transport::RunId;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

/// How long a dead launcher's last words are waited for.
const RANK_REPORT_WAIT: Duration = Duration::from_millis(500);

/// How to start one node.
#[derive(Debug, Clone)]
pub struct NodeCommand {
    pub role: Role,
    pub program: PathBuf,
    /// Extra arguments given before the runtime's own (`--prefix`).
    pub args: Vec<String>,
    /// Variables set in the process's environment besides the coupler's own (an MPI
    /// launcher's, [`crate::run::launcher`]).
    pub env: Vec<(String, String)>,
    /// Whether the program is an MPI launcher starting the node's ranks: its standard error is
    /// read for the rank it names when one dies ([`crate::run::rank_report`]).
    pub launcher: bool,
}

impl NodeCommand {
    /// The node binary installed beside the coupler's own executable (`fluid-node`, `solid-node`).
    pub fn beside_me(role: Role) -> Result<NodeCommand, String> {
        let me = std::env::current_exe()
            .map_err(|e| format!("cannot locate the coupler executable: {e}"))?;
        let dir = me.parent().unwrap_or(Path::new("."));
        let program = dir.join(format!("{}-node", role.name()));
        Ok(NodeCommand {
            role,
            program,
            args: Vec::new(),
            env: Vec::new(),
            launcher: false,
        })
    }

    /// A user-given executable; a bare name is looked up on PATH.
    pub fn given(role: Role, cmd: &str) -> NodeCommand {
        let mut words = cmd.split_whitespace().map(String::from);
        let program = PathBuf::from(words.next().unwrap_or_default());
        NodeCommand {
            role,
            program,
            args: words.collect(),
            env: Vec::new(),
            launcher: false,
        }
    }

    /// Resolves the program to an existing executable, or says what to do.
    pub fn check(&self) -> Result<PathBuf, String> {
        let found = if self.program.components().count() > 1 || self.program.is_absolute() {
            Some(self.program.clone()).filter(|p| p.is_file())
        } else {
            std::env::var_os("PATH").and_then(|paths| {
                std::env::split_paths(&paths)
                    .map(|d| d.join(&self.program))
                    .find(|p| p.is_file())
            })
        };
        let role = self.role.name();
        let Some(path) = found else {
            return Err(format!(
                "the {role} node binary '{}' does not exist. Fix: build it with `cargo build --release` \
                 (the coupler looks for {role}-node beside its own executable), or name another executable \
                 with --{role}-cmd PATH",
                self.program.display()
            ));
        };
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&path)
            .map(|m| m.permissions().mode())
            .unwrap_or(0);
        if mode & 0o111 == 0 {
            return Err(format!(
                "the {role} node binary '{}' is not executable. Fix: chmod +x it",
                path.display()
            ));
        }
        Ok(path)
    }
}

/// A running node process. Dropping it terminates the process (SIGTERM, then SIGKILL), so an
/// error anywhere in the coupler never leaves an orphan behind.
pub struct NodeProcess {
    pub role: Role,
    pub program: PathBuf,
    child: Child,
    status: Option<ExitStatus>,
    /// An MPI launcher's word on a dead rank.
    ranks: Option<RankReport>,
}

impl NodeProcess {
    /// Starts `cmd` joining run `id` (with `transport`, the arguments that say how to reach
    /// the coupler); the node inherits stdout and stderr, so its own messages reach the user
    /// (an MPI launcher's stderr passes through the coupler, which reads it for a dead rank).
    pub fn spawn(
        cmd: &NodeCommand,
        id: &RunId,
        transport: &[String],
    ) -> Result<NodeProcess, String> {
        let program = cmd.check()?;
        let coupler = std::process::id() as libc::pid_t;
        let launcher = cmd.launcher;
        let mut command = Command::new(&program);
        // SAFETY: the closure runs in the child between fork and exec and calls only
        // async-signal-safe functions (signal, prctl, getppid, _exit).
        unsafe {
            use std::os::unix::process::CommandExt;
            command.pre_exec(move || {
                // A launcher writes its stderr into the coupler's pipe: if the coupler dies
                // first, its last lines must not kill it (SIGPIPE) before it has ended its ranks.
                if launcher {
                    libc::signal(libc::SIGPIPE, libc::SIG_IGN);
                }
                // A node whose coupler dies (even by SIGKILL, e.g. during start-up) gets SIGTERM
                // at once instead of waiting out its timeouts; if the coupler is already gone
                // the node is not started at all.
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
                if libc::getppid() != coupler {
                    libc::_exit(3);
                }
                Ok(())
            });
        }
        if cmd.launcher {
            command.stderr(std::process::Stdio::piped());
        }
        let mut child = command
            .args(&cmd.args)
            .arg("--prefix")
            .arg(id.as_str())
            .args(transport)
            .envs(cmd.env.iter().map(|(k, v)| (k, v)))
            .stdin(std::process::Stdio::null())
            .spawn()
            .map_err(|e| {
                format!(
                    "cannot start the {} node '{}': {e}",
                    cmd.role.name(),
                    program.display()
                )
            })?;
        let ranks = child.stderr.take().map(RankReport::follow);
        Ok(NodeProcess {
            role: cmd.role,
            program,
            child,
            status: None,
            ranks,
        })
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// How the process ended, once it has ([`describe_exit`]); for an MPI launcher, with what
    /// it said about the rank that died, if it named one.
    pub fn ended_how(&mut self) -> Option<String> {
        let how = describe_exit(self.exited()?);
        // The launcher's last lines follow its exit by moments.
        let said = self.ranks.as_ref().and_then(|r| r.said(RANK_REPORT_WAIT));
        Some(match said {
            Some(rank) => format!("{how}; its launcher reports: {rank}"),
            None => how,
        })
    }

    /// The exit status if the process has ended (never blocks).
    pub fn exited(&mut self) -> Option<ExitStatus> {
        if self.status.is_none() {
            self.status = self.child.try_wait().ok().flatten();
        }
        self.status
    }

    /// Waits up to `timeout` for the process to end by itself.
    pub fn wait_exit(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let start = Instant::now();
        loop {
            if let Some(s) = self.exited() {
                return Some(s);
            }
            if start.elapsed() >= timeout {
                return None;
            }
            // Process exit has no iceoryx2 event; a short sleep while a child shuts down is
            // the simplest blocking wait std offers.
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// The node's processes (itself and, under an MPI launcher, its ranks) that are stopped
    /// (SIGSTOP, a debugger), each named by its MPI rank where its launcher gave it one: why a
    /// node can be silent while alive.
    pub fn stopped(&self) -> Vec<String> {
        let me = self.child.id() as libc::pid_t;
        std::iter::once(me)
            .chain(descendants(me))
            .filter(|&pid| matches!(state(pid), Some('T' | 't')))
            .map(|pid| match mpi_rank(pid) {
                Some(rank) => format!("rank {rank} (pid {pid})"),
                None => format!("pid {pid}"),
            })
            .collect()
    }

    /// Asks the process to end (SIGTERM), waits `grace`, then kills it and every process it
    /// started. An MPI launcher forwards the SIGTERM to its ranks, but SIGKILL cannot be
    /// forwarded, and Open MPI puts each rank in a process group of its own: the ranks are
    /// found as the launcher's descendants before it is killed, so none is left behind.
    pub fn terminate(&mut self, grace: Duration) -> Option<ExitStatus> {
        if self.exited().is_some() {
            return self.status;
        }
        // SAFETY: kill(2) on the pid of our own child, which has not been reaped yet.
        unsafe {
            libc::kill(self.child.id() as libc::pid_t, libc::SIGTERM);
        }
        if let Some(s) = self.wait_exit(grace) {
            return Some(s);
        }
        let started = descendants(self.child.id() as libc::pid_t);
        let _ = self.child.kill();
        for pid in started {
            // SAFETY: kill(2) on a process our child started, found an instant ago.
            unsafe {
                libc::kill(pid, libc::SIGKILL);
            }
        }
        self.status = self.child.wait().ok();
        self.status
    }
}

/// Every live descendant of `root` (its children, theirs, …), read from /proc: one pass over
/// the processes' parents. Empty where /proc cannot be read.
fn descendants(root: libc::pid_t) -> Vec<libc::pid_t> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    let parent_of: Vec<(libc::pid_t, libc::pid_t)> = entries
        .filter_map(|e| e.ok()?.file_name().to_str()?.parse().ok())
        .filter_map(|pid| Some((pid, parent(pid)?)))
        .collect();
    let mut found = vec![root];
    let mut next = 0;
    while next < found.len() {
        let p = found[next];
        found.extend(parent_of.iter().filter(|(_, pp)| *pp == p).map(|(c, _)| *c));
        next += 1;
    }
    found.remove(0);
    found
}

/// The state letter of `pid` from /proc/PID/stat (`T`: stopped, `t`: stopped by a tracer).
fn state(pid: libc::pid_t) -> Option<char> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    stat.rsplit_once(')')?
        .1
        .split_whitespace()
        .next()?
        .chars()
        .next()
}

/// The MPI rank of `pid`, from the environment its launcher gave it: Open MPI's
/// `OMPI_COMM_WORLD_RANK`, MPICH's `PMI_RANK`, PMIx's `PMIX_RANK`, Slurm's `SLURM_PROCID`.
fn mpi_rank(pid: libc::pid_t) -> Option<u32> {
    let env = std::fs::read(format!("/proc/{pid}/environ")).ok()?;
    env.split(|&b| b == 0).find_map(|var| {
        let var = std::str::from_utf8(var).ok()?;
        let (name, value) = var.split_once('=')?;
        [
            "OMPI_COMM_WORLD_RANK",
            "PMI_RANK",
            "PMIX_RANK",
            "SLURM_PROCID",
        ]
        .contains(&name)
        .then(|| value.parse().ok())?
    })
}

/// The parent of `pid` from /proc/PID/stat (the field after the command, which is in
/// parentheses and may hold spaces).
fn parent(pid: libc::pid_t) -> Option<libc::pid_t> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let (_, rest) = stat.rsplit_once(')')?;
    rest.split_whitespace().nth(1)?.parse().ok()
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        self.terminate(Duration::from_secs(2));
    }
}

/// Describes how a process ended, for messages.
pub fn describe_exit(status: ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(code), _) => format!("exited with code {code}"),
        (None, Some(sig)) => format!("was killed by signal {sig}{}", signal_name(sig)),
        _ => "ended".into(),
    }
}

fn signal_name(sig: i32) -> &'static str {
    match sig {
        libc::SIGKILL => " (SIGKILL)",
        libc::SIGTERM => " (SIGTERM)",
        libc::SIGINT => " (SIGINT)",
        libc::SIGSEGV => " (SIGSEGV)",
        libc::SIGABRT => " (SIGABRT)",
        _ => "",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn alive(pid: libc::pid_t) -> bool {
        std::fs::read_to_string(format!("/proc/{pid}/stat"))
            .ok()
            .and_then(|s| Some(s.rsplit_once(')')?.1.split_whitespace().next()? != "Z"))
            .unwrap_or(false)
    }

    /// The `n` processes `p` started, once they are there (within 5 s).
    fn started_by(p: &NodeProcess, n: usize) -> Vec<libc::pid_t> {
        let started = Instant::now();
        let mut kids = Vec::new();
        while kids.len() < n && started.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(10));
            kids = descendants(p.pid() as libc::pid_t);
        }
        assert_eq!(kids.len(), n, "{kids:?}");
        kids
    }

    /// A process that ignores SIGTERM is killed with everything it started, as an MPI
    /// launcher's ranks (each in a process group of its own) must be.
    #[test]
    fn a_kill_takes_the_processes_a_node_started_with_it() {
        let cmd = NodeCommand {
            role: Role::Fluid,
            program: PathBuf::from("/bin/sh"),
            args: vec![
                "-c".into(),
                "trap '' TERM; sleep 30 & sleep 30 & wait".into(),
            ],
            env: vec![("RW_TREE_TEST".into(), "1".into())],
            launcher: false,
        };
        let id = RunId::parse("treekill").unwrap();
        let mut p = NodeProcess::spawn(&cmd, &id, &[]).unwrap();
        let kids = started_by(&p, 2);
        assert!(p.terminate(Duration::from_millis(100)).is_some());
        let gone = Instant::now();
        while kids.iter().any(|&k| alive(k)) && gone.elapsed() < Duration::from_secs(2) {
            std::thread::sleep(Duration::from_millis(10));
        }
        assert!(kids.iter().all(|&k| !alive(k)), "left: {kids:?}");
    }

    /// A stopped process the node started is named, by its MPI rank when it has one.
    #[test]
    fn the_stopped_processes_of_a_node_are_named_by_rank() {
        let cmd = NodeCommand {
            role: Role::Fluid,
            program: PathBuf::from("/bin/sh"),
            args: vec!["-c".into(), "sleep 30 & wait".into()],
            env: vec![("OMPI_COMM_WORLD_RANK".into(), "3".into())],
            launcher: false,
        };
        let id = RunId::parse("stopped").unwrap();
        let mut p = NodeProcess::spawn(&cmd, &id, &[]).unwrap();
        let kids = started_by(&p, 1);
        let started = Instant::now();
        assert_eq!(p.stopped(), Vec::<String>::new(), "nothing stopped yet");
        // SAFETY: kill(2) on the sleep our child started, found an instant ago.
        unsafe {
            libc::kill(kids[0], libc::SIGSTOP);
        }
        let mut stopped = Vec::new();
        while stopped.is_empty() && started.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(10));
            stopped = p.stopped();
        }
        assert_eq!(stopped, [format!("rank 3 (pid {})", kids[0])]);
        assert!(p.terminate(Duration::from_millis(100)).is_some());
    }
}
