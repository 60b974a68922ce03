//! Start-up: the nodes started (or awaited), their hello and protocol version, the setup sent
//! and every node ready; or, on a resume, the coupler's own state taken from its checkpoint.

use super::{Peer, SLICE, Session, scene_text};
use crate::run::error::RunError;
use crate::run::launch::{NodeProcess, describe_exit};
use crate::run::output::RunDir;
use crate::run::stats::RunStats;
use shared::protocol::*;
use shared::transport::Kind;
use std::time::Instant;

impl Session {
    /// Starts (or awaits) the nodes, checks their protocol, sends the setup and waits for every
    /// node to report ready.
    pub fn start(&mut self, dir: &mut RunDir) -> Result<(), RunError> {
        let roles = Session::roles(&self.opts.scene);
        if roles.is_empty() {
            return Err(RunError::Input(
                "the scene has neither water nor moving blocks: nothing to simulate".into(),
            ));
        }
        let mut processes = Vec::new();
        if !self.opts.attach {
            for &role in &roles {
                let cmd = if role == Role::Fluid {
                    &self.opts.fluid_cmd
                } else {
                    &self.opts.solid_cmd
                };
                processes.push(
                    NodeProcess::spawn(cmd, &self.opts.run_id, &self.node_transport_args())
                        .map_err(RunError::Input)?,
                );
            }
        } else {
            eprintln!(
                "coupler: waiting up to {:.0} s for the nodes of run {id}; start them with:",
                self.opts.connect_timeout.as_secs_f64(),
                id = self.opts.run_id
            );
            let extra = self.node_transport_args().join(" ");
            for &role in &roles {
                let node = format!(
                    "{}-node --prefix {}{}{extra}",
                    role.name(),
                    self.opts.run_id,
                    if extra.is_empty() { "" } else { " " }
                );
                let ranks = if role == Role::Fluid {
                    self.opts.fluid_ranks
                } else {
                    1
                };
                eprintln!("  {}", self.opts.launcher.attach_line(ranks, &node));
            }
        }
        self.handshake(&roles, processes)?;

        let setup = Setup {
            scene_toml: scene_text(&self.opts.scene)?,
            run_dir: dir.path().to_path_buf(),
            scheme: self.scheme(),
            fluid_present: roles.contains(&Role::Fluid),
            solid_present: roles.contains(&Role::Solid),
            fluid_solver: self.fluid_solver(),
            solid_solver: self.solid_solver(),
            coupler_pid: std::process::id(),
            resume: self.opts.resume.as_ref().map(|c| Resume {
                step: c.step,
                time: c.time,
            }),
        };
        let bytes = setup.encode();
        self.setup_out
            .publish(bytes.len(), &mut |header, payload| {
                *header = SetupHeader {
                    protocol_version: PROTOCOL_VERSION,
                    payload_len: bytes.len() as u32,
                };
                payload.copy_from_slice(&bytes);
            })?;
        self.ring();
        let interval = self.opts.scene.output.interval;
        self.next_output = interval.min(self.opts.scene.time.end);
        self.next_checkpoint = self.opts.checkpoint_interval;
        if let Some(ck) = self.opts.resume.clone() {
            // The nodes restore theirs; the coupler continues from its own.
            let stats = std::mem::take(&mut self.stats);
            self.stats = RunStats {
                fluid_solver: stats.fluid_solver,
                solid_solver: stats.solid_solver,
                ..ck.stats.clone()
            };
            self.step = ck.step;
            self.time = ck.time;
            self.frame = ck.frame;
            self.next_output = ck.next_output;
            self.next_checkpoint = ck.next_checkpoint;
            self.collect_statuses(ck.step, self.opts.setup_timeout, false)?;
            return Ok(());
        }
        self.collect_statuses(0, self.opts.setup_timeout, false)?;
        if self.opts.scene.output.vtk {
            dir.add_frame(
                0,
                0.0,
                &self.peers.iter().map(|p| p.role).collect::<Vec<_>>(),
            )
            .map_err(|e| RunError::Input(format!("cannot write to the run directory: {e}")))?;
            self.stats.frames = 1;
        }
        Ok(())
    }

    /// What the nodes need besides the run id to reach this coupler.
    fn node_transport_args(&self) -> Vec<String> {
        match self.opts.transport {
            Kind::Iceoryx2 => Vec::new(),
            Kind::Zenoh => {
                let mut args = vec!["--transport".to_string(), "zenoh".to_string()];
                for e in &self.opts.node_connect {
                    args.push("--connect".into());
                    args.push(e.clone());
                }
                args
            }
        }
    }

    /// Waits for a hello from each role; checks protocol versions.
    fn handshake(
        &mut self,
        roles: &[Role],
        mut processes: Vec<NodeProcess>,
    ) -> Result<(), RunError> {
        let started = Instant::now();
        while self.peers.len() < roles.len() {
            while let Some(hello) = self.hello_in.receive()? {
                let Some(role) = Role::from_u32(hello.role).filter(|r| roles.contains(r)) else {
                    return Err(RunError::Handshake(format!(
                        "a node with unknown role {} said hello",
                        hello.role
                    )));
                };
                if self.peers.iter().any(|p| p.role == role) {
                    continue; // a repeated hello
                }
                let process = processes
                    .iter()
                    .position(|p| p.role == role)
                    .map(|i| processes.swap_remove(i));
                let program = process
                    .as_ref()
                    .map(|p| p.program.display().to_string())
                    .unwrap_or_else(|| format!("pid {}", hello.pid));
                if hello.protocol_version != PROTOCOL_VERSION {
                    return Err(RunError::Handshake(format!(
                        "the {} node '{program}' speaks protocol version {}, this coupler version {PROTOCOL_VERSION}. \
                         Fix: rebuild both from the same source (`cargo build --release`)",
                        role.name(),
                        hello.protocol_version
                    )));
                }
                // A node started with its own --solver runs that one.
                let solver = match hello.solver.as_str() {
                    "" if role == Role::Fluid => self.fluid_solver(),
                    "" => self.solid_solver(),
                    own => own.to_string(),
                };
                match role {
                    Role::Fluid => self.stats.fluid_solver = Some(solver.clone()),
                    Role::Solid => self.stats.solid_solver = Some(solver.clone()),
                }
                self.peers.push(Peer {
                    role,
                    solver,
                    pid: hello.pid,
                    process,
                    proposal: f64::INFINITY,
                    answered: false,
                });
            }
            if self.peers.len() == roles.len() {
                break;
            }
            for p in processes.iter_mut() {
                if let Some(status) = p.exited() {
                    return Err(RunError::Handshake(format!(
                        "the {} node '{}' {} before saying hello",
                        p.role.name(),
                        p.program.display(),
                        describe_exit(status)
                    )));
                }
            }
            if self.run.termination_requested() {
                return Err(RunError::Interrupted { step: 0, time: 0.0 });
            }
            if started.elapsed() > self.opts.connect_timeout {
                let missing: Vec<&str> = roles
                    .iter()
                    .filter(|r| !self.peers.iter().any(|p| p.role == **r))
                    .map(|r| r.name())
                    .collect();
                return Err(RunError::Handshake(format!(
                    "no hello from the {} node(s) within {:.0} s",
                    missing.join(" and "),
                    self.opts.connect_timeout.as_secs_f64()
                )));
            }
            self.listener.wait(SLICE)?;
        }
        Ok(())
    }
}
