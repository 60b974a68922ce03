//! How a run ended when it did not complete, and the exit code that tells it.

use shared::transport;

/// How a run ended, when it did not complete.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    Input(String),
    #[error("{node} went unstable at step {step}, t = {time:.6} s: {cause}")]
    Unstable {
        node: String,
        step: u64,
        time: f64,
        cause: String,
    },
    #[error("{node} failed at step {step}, t = {time:.6} s: {cause}")]
    Failed {
        node: String,
        step: u64,
        time: f64,
        cause: String,
    },
    #[error("{node} died at step {step}, t = {time:.6} s: the process {how}")]
    Died {
        node: String,
        step: u64,
        time: f64,
        how: String,
    },
    #[error("{node} hung at step {step}, t = {time:.6} s: no answer within {waited:.1} s{why}")]
    Hung {
        node: String,
        step: u64,
        time: f64,
        waited: f64,
        /// What the coupler found about the silence ("; stopped: rank 2 (pid …) …"), or empty.
        why: String,
    },
    #[error("start-up failed: {0}")]
    Handshake(String),
    #[error(
        "step collapsed at step {step}, t = {time:.6} s: {node} proposed dt = {dt:e} s, below dt_min = {dt_min:e} s"
    )]
    Collapsed {
        node: String,
        step: u64,
        time: f64,
        dt: f64,
        dt_min: f64,
    },
    #[error("interrupted at step {step}, t = {time:.6} s")]
    Interrupted { step: u64, time: f64 },
    #[error("transport: {0}")]
    Transport(String),
    #[error("{cause} (again, after a restart from step {from_step}: the run stops)")]
    Again {
        cause: Box<RunError>,
        from_step: u64,
    },
}

impl RunError {
    /// The process exit code for this outcome.
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Input(_) => 1,
            RunError::Unstable { .. } | RunError::Failed { .. } | RunError::Collapsed { .. } => 2,
            RunError::Died { .. }
            | RunError::Hung { .. }
            | RunError::Handshake(_)
            | RunError::Transport(_) => 3,
            RunError::Interrupted { .. } => 130,
            RunError::Again { cause, .. } => cause.exit_code(),
        }
    }

    /// The node ("fluid node (...)") and step of a death or hang, which a restart may cure.
    pub(crate) fn restartable(&self) -> Option<(String, u64)> {
        match self {
            RunError::Died { node, step, .. } | RunError::Hung { node, step, .. } => {
                let role = node.split(" node").next().unwrap_or(node).to_string();
                Some((role, *step))
            }
            _ => None,
        }
    }
}

impl From<transport::TransportError> for RunError {
    fn from(e: transport::TransportError) -> Self {
        RunError::Transport(e.to_string())
    }
}
