//! The nodes' answers: the statuses of one command collected (proposals, compute times,
//! warnings, failures), and nodes that died or hung turned into errors.

use super::{Peer, SLICE, Session};
use crate::run::error::RunError;
use shared::protocol::*;
use shared::scene::CouplingScheme;
use shared::transport::{Kind, Party};
use std::time::{Duration, Instant};

impl Session {
    /// Waits until every node answered `step` (the checkpoint command of `step` when
    /// `checkpoint`); records proposals; turns failures into errors.
    pub(super) fn collect_statuses(
        &mut self,
        step: u64,
        timeout: Duration,
        checkpoint: bool,
    ) -> Result<(), RunError> {
        for p in self.peers.iter_mut() {
            p.answered = false;
        }
        let sent = Instant::now();
        loop {
            while let Some(s) = self.status_in.receive()? {
                let Some(peer) = self.peers.iter_mut().find(|p| p.role as u32 == s.role) else {
                    continue;
                };
                let node = peer.label();
                match StatusCode::from_u32(s.code) {
                    code @ (StatusCode::Ok
                    | StatusCode::Warning
                    | StatusCode::Stopped
                    | StatusCode::Checkpointed) => {
                        if s.step != step || (code == StatusCode::Checkpointed) != checkpoint {
                            continue; // stale answer to an earlier command
                        }
                        peer.answered = true;
                        peer.proposal = s.dt_proposal;
                        match peer.role {
                            Role::Fluid => {
                                self.stats.fluid_compute_seconds += s.compute_seconds;
                                self.stats.fluid_cpu_seconds = s.cpu_seconds;
                            }
                            Role::Solid => {
                                self.stats.solid_compute_seconds += s.compute_seconds;
                                self.stats.solid_cpu_seconds = s.cpu_seconds;
                            }
                        }
                        if StatusCode::from_u32(s.code) == StatusCode::Warning {
                            self.stats.warnings += 1;
                            let msg = format!(
                                "{node}: warning at step {step}, t = {:.6} s: {}",
                                s.time,
                                s.message.as_str()
                            );
                            // Repeats of a kind thin out (#1, 2, 4, 8, …); a new kind, such
                            // as a block's landing burst among a solver's repeated warnings,
                            // is always printed.
                            let kind = warning_kind(&node, s.message.as_str());
                            if self.warned.insert(kind) || self.stats.warnings.is_power_of_two() {
                                eprintln!("coupler: {msg} (warning #{})", self.stats.warnings);
                            }
                            self.stats.last_warning = Some(msg);
                        }
                    }
                    StatusCode::Unstable => {
                        return Err(RunError::Unstable {
                            node,
                            step: s.step,
                            time: s.time,
                            cause: s.message.as_str().into(),
                        });
                    }
                    StatusCode::Failed => {
                        return Err(RunError::Failed {
                            node,
                            step: s.step,
                            time: s.time,
                            cause: s.message.as_str().into(),
                        });
                    }
                }
            }
            if self.peers.iter().all(|p| p.answered) {
                return Ok(());
            }
            self.check_peers(step)?;
            if self.run.termination_requested() {
                return Err(RunError::Interrupted {
                    step,
                    time: self.time,
                });
            }
            if sent.elapsed() > timeout {
                // When neither node answered, one is waiting for the other's data within the
                // step (the step contract): the parallel scheme's solid for the fluid's loads,
                // the serial scheme's fluid for the solid's new geometry. The one waited for
                // is the hung one (a restart must know which node failed).
                let waited_for = match self.scheme() {
                    CouplingScheme::Parallel => Role::Fluid,
                    CouplingScheme::Serial => Role::Solid,
                };
                let silent: Vec<&Peer> = self.peers.iter().filter(|p| !p.answered).collect();
                let p = silent
                    .iter()
                    .find(|p| silent.len() > 1 && !checkpoint && p.role == waited_for)
                    .or(silent.first())
                    .expect("someone has not answered");
                let stopped = p.process.as_ref().map_or(Vec::new(), |n| n.stopped());
                let why = if stopped.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; stopped: {} (SIGSTOP, or held by a debugger)",
                        stopped.join(", ")
                    )
                };
                return Err(RunError::Hung {
                    node: p.label(),
                    step,
                    time: self.time,
                    waited: sent.elapsed().as_secs_f64(),
                    why,
                });
            }
            self.listener.wait(SLICE)?;
        }
    }

    /// A node whose process ended (or, for attached nodes, whose pid vanished; over zenoh,
    /// whose liveliness token was withdrawn) ends the run. Only nodes that have not answered
    /// the current command count: a node that answered a stop exits at once, and must not be
    /// taken for dead while the other one still flushes.
    fn check_peers(&mut self, step: u64) -> Result<(), RunError> {
        let run = &self.run;
        let remote = run.kind() != Kind::Iceoryx2;
        for p in self.peers.iter_mut().filter(|p| !p.answered) {
            let gone = |p: &Peer| {
                (!run.alive(Party::from(p.role), p.pid)).then(|| run.gone_how().to_string())
            };
            let how = match p.process.as_mut() {
                Some(proc_) => match proc_.ended_how() {
                    None if remote => gone(p),
                    how => how,
                },
                None => gone(p),
            };
            if let Some(how) = how {
                return Err(RunError::Died {
                    node: p.label(),
                    step,
                    time: self.time,
                    how,
                });
            }
        }
        Ok(())
    }
}

/// What makes two warnings the same kind: the node and the message without its numbers.
fn warning_kind(node: &str, message: &str) -> String {
    let text: String = message.chars().filter(|c| !c.is_ascii_digit()).collect();
    format!("{node}: {text}")
}

#[cfg(test)]
mod tests {
    use super::warning_kind;

    #[test]
    fn warnings_differing_only_in_their_numbers_are_one_kind() {
        let solid = "solid node (explicit, pid 7)";
        let burst = |w: u32| {
            format!(
                "the water's load on block 'rock' (ρ_b/ρ_w = 2.5000) bursts to {w} weights per step"
            )
        };
        assert_eq!(
            warning_kind(solid, &burst(47)),
            warning_kind(solid, &burst(13))
        );
        let other =
            "the water's load on block 'wedge' (ρ_b/ρ_w = 2.5000) bursts to 47 weights per step";
        assert_ne!(warning_kind(solid, &burst(47)), warning_kind(solid, other));
        let fluid = "fluid node (dfsph, pid 8)";
        let solve = "dfsph: density solve did not converge: mean error 0.07 % after 100 iterations";
        assert_ne!(warning_kind(fluid, solve), warning_kind(solid, &burst(47)));
        assert_ne!(warning_kind(fluid, solve), warning_kind(solid, solve));
    }
}
