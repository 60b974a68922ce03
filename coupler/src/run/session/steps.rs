//! The step loop: the shared timestep granted and sent until the end time, frames recorded,
//! checkpoints taken when due, and the orderly stop.

use super::{Session, scene_text};
use crate::run::checkpoint::CouplerCheckpoint;
use crate::run::error::RunError;
use crate::run::output::RunDir;
use shared::coupling::step::{self, StepRule};
use shared::protocol::*;
use shared::transport::Kind;
use std::time::{Duration, Instant};

impl Session {
    /// Steps until the scene's end time.
    pub(super) fn advance_to_end(&mut self, dir: &mut RunDir) -> Result<(), RunError> {
        let scene = &self.opts.scene;
        let end = scene.time.end;
        let interval = scene.output.interval;
        let dt_max = scene.time.dt_max;
        let rule = StepRule::new(dt_max, scene.time.dt_min).with_factor(self.opts.dt_factor);
        let roles: Vec<Role> = self.peers.iter().map(|p| p.role).collect();
        let progress = crate::run::progress::Progress::new(self.opts.progress, end);
        // Step wall times, for the median and tail the benchmark reports.
        let expected_steps = (end / dt_max.max(1e-12)).min(1e7) as usize;
        let mut step_walls: Vec<f32> = Vec::with_capacity(expected_steps);
        if self.opts.resume.is_none() {
            self.stats.dt_min = f64::INFINITY;
        }
        self.last_checkpoint = Instant::now();
        let tol = 1e-12 * end.max(1.0);

        while self.time < end - tol {
            // The shared step: the most restrictive proposal, never past dt_max, landing
            // exactly on the next output time.
            let target = self.next_output.min(end);
            let proposals = self.peers.iter().map(|p| (p.label(), p.proposal));
            let granted = step::grant(proposals, &rule, self.time, target).map_err(|c| {
                RunError::Collapsed {
                    node: c.limiting.to_string(),
                    step: self.step,
                    time: self.time,
                    dt: c.proposal,
                    dt_min: c.dt_min,
                }
            })?;
            let (dt, lands) = (granted.dt, granted.lands);
            let output_frame =
                if lands && self.opts.scene.output.vtk && (self.next_output <= end + tol) {
                    self.frame as i32
                } else {
                    -1
                };
            let cmd = Command {
                kind: CommandKind::Advance as u32,
                output_frame,
                step: self.step,
                time: self.time,
                dt,
            };
            let sent = Instant::now();
            self.command_out.send(cmd)?;
            self.ring();
            self.collect_statuses(self.step, self.opts.step_timeout, false)?;
            step_walls.push(sent.elapsed().as_secs_f32());

            self.stats.dt_min = self.stats.dt_min.min(dt);
            self.stats.dt_max = self.stats.dt_max.max(dt);
            self.step += 1;
            self.time = granted.end_time(self.time, target);
            self.stats.steps = self.step;
            self.stats.time = self.time;
            if lands {
                if output_frame >= 0 {
                    dir.add_frame(self.frame, self.time, &roles).map_err(|e| {
                        RunError::Input(format!("cannot write to the run directory: {e}"))
                    })?;
                    self.stats.frames = self.frame + 1;
                    self.frame += 1;
                }
                self.next_output += interval;
            }
            if self.time < end - tol && self.checkpoint_due() {
                self.checkpoint(dir)?;
            }
            progress.update(self.time, self.step);
        }
        progress.finish();
        if !step_walls.is_empty() {
            step_walls.sort_by(f32::total_cmp);
            let at = |q: f64| {
                step_walls[((step_walls.len() - 1) as f64 * q).round() as usize] as f64 * 1e6
            };
            self.stats.step_wall_median_us = at(0.5);
            self.stats.step_wall_p99_us = at(0.99);
        }
        Ok(())
    }

    /// Whether a checkpoint is due after this step: the simulated interval was crossed, or the
    /// wall interval passed. Checkpoints never cut a step: the grants stay those of a run
    /// without them.
    fn checkpoint_due(&mut self) -> bool {
        let mut due = false;
        if let (Some(next), Some(every)) = (self.next_checkpoint, self.opts.checkpoint_interval)
            && self.time >= next * (1.0 - 1e-12)
        {
            due = true;
            self.next_checkpoint = Some(next_after(next, every, self.time));
        }
        if self
            .opts
            .checkpoint_wall
            .is_some_and(|w| self.last_checkpoint.elapsed() >= w)
        {
            due = true;
        }
        due
    }

    /// A checkpoint of the state after `self.step` steps: each node writes its own file and
    /// answers, then the coupler records the series' lengths and its state (last, so that a
    /// coupler file means a complete checkpoint).
    fn checkpoint(&mut self, dir: &RunDir) -> Result<(), RunError> {
        let cmd = Command {
            kind: CommandKind::Checkpoint as u32,
            output_frame: -1,
            step: self.step,
            time: self.time,
            dt: 0.0,
        };
        self.command_out.send(cmd)?;
        self.ring();
        self.collect_statuses(self.step, self.opts.step_timeout, true)?;
        let fail = |e: String| RunError::Failed {
            node: "coupler".into(),
            step: self.step,
            time: self.time,
            cause: format!("checkpoint: {e}"),
        };
        let series = crate::run::checkpoint::series_lengths(dir.path()).map_err(fail)?;
        let (particles, blocks) = dir.series();
        self.stats.checkpoints += 1;
        let ck = CouplerCheckpoint {
            scene_hash: shared::checkpoint::run_hash(
                &self.opts.scene,
                &scene_text(&self.opts.scene)?,
            ),
            fluid_solver: self.stats.fluid_solver.clone(),
            solid_solver: self.stats.solid_solver.clone(),
            scheme: self.scheme(),
            dt_factor: self.opts.dt_factor,
            step: self.step,
            time: self.time,
            frame: self.frame,
            next_output: self.next_output,
            next_checkpoint: self.next_checkpoint,
            stats: self.stats.clone(),
            particles,
            blocks,
            series,
        };
        ck.write(dir.path()).map_err(fail)?;
        self.last_checkpoint = Instant::now();
        Ok(())
    }

    /// Ends the run: asks the nodes to stop (they flush their files), then makes sure every
    /// process is gone. Returns the run's outcome.
    pub(super) fn stop(&mut self, outcome: Result<(), RunError>) -> Result<(), RunError> {
        // The nodes' peak memory, while they are still alive to be asked (on this host: a
        // node attached over zenoh may run elsewhere, where its pid means nothing here).
        let local = self.run.kind() == Kind::Iceoryx2;
        for p in &self.peers {
            let rss = if local || p.process.is_some() {
                shared::runtime::peak_rss_bytes_of(p.pid)
            } else {
                None
            };
            match p.role {
                Role::Fluid => self.stats.fluid_peak_rss_bytes = rss,
                Role::Solid => self.stats.solid_peak_rss_bytes = rss,
            }
        }
        let cmd = Command {
            kind: CommandKind::Stop as u32,
            output_frame: -1,
            step: self.step,
            time: self.time,
            dt: 0.0,
        };
        let _ = self.command_out.send(cmd);
        self.ring();
        let stopped = if outcome.is_ok() {
            // A clean end: wait for the nodes to confirm they flushed their outputs.
            self.collect_statuses(self.step, Duration::from_secs(30), false)
        } else {
            Ok(())
        };
        for p in self.peers.iter_mut() {
            if let Some(proc_) = p.process.as_mut()
                && proc_.wait_exit(Duration::from_secs(1)).is_none()
            {
                proc_.terminate(Duration::from_secs(1));
            }
        }
        outcome.and(stopped)
    }
}

/// The first time of the checkpoint grid `next + k·every` past `time`. A step that crosses
/// many intervals skips them at once: one addition each took a step of 1e-3 s over an interval
/// of 1e-9 s a million of them, and an interval below the resolution of `time` never got past
/// it (the coupler hung). The usual step, shorter than the interval, adds it once, as before.
fn next_after(next: f64, every: f64, time: f64) -> f64 {
    let past = time * (1.0 + 1e-12);
    let mut n = next;
    let whole = ((past - n) / every).floor() - 1.0;
    if whole > 0.0 {
        n += whole * every;
    }
    while n <= past {
        let added = n + every;
        if added == n {
            return past.next_up(); // the interval is lost in `time`: one checkpoint a step
        }
        n = added;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::next_after;

    #[test]
    fn the_next_checkpoint_is_found_past_the_step_in_a_few_additions() {
        assert_eq!(next_after(0.1, 0.1, 0.05), 0.1);
        assert_eq!(next_after(0.1, 0.1, 0.1), 0.2);
        let n = next_after(1e-9, 1e-9, 1.0);
        assert!(n > 1.0 && n < 1.0 + 3e-9, "{n}");
        let n = next_after(1e-300, 1e-300, 1.0);
        assert!(n > 1.0 && n < 1.0 + 1e-9, "{n}");
    }
}
