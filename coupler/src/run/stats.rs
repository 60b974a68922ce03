//! What a run did, completed or not: written into `summary.json` and the coupler's checkpoints.

/// What a run did, completed or not.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct RunStats {
    pub steps: u64,
    /// Simulated time reached [s].
    pub time: f64,
    pub wall_seconds: f64,
    /// Seconds each node spent computing (solver work plus writing or reading coupling data).
    pub fluid_compute_seconds: f64,
    pub solid_compute_seconds: f64,
    /// Smallest and largest step granted [s].
    pub dt_min: f64,
    pub dt_max: f64,
    pub warnings: u64,
    pub last_warning: Option<String>,
    /// Output frames written (including frame 0).
    pub frames: u32,
    /// CPU seconds each process used over the run; compare with the compute seconds: the
    /// difference is what waiting and talking cost.
    pub fluid_cpu_seconds: f64,
    pub solid_cpu_seconds: f64,
    pub coupler_cpu_seconds: f64,
    /// Peak resident memory of each process [bytes]: the nodes' `VmHWM` read from /proc just
    /// before they are told to stop (None if a node was already gone), the coupler's own from
    /// getrusage at the end.
    pub fluid_peak_rss_bytes: Option<u64>,
    pub solid_peak_rss_bytes: Option<u64>,
    pub coupler_peak_rss_bytes: u64,
    /// Median and 99th percentile of the wall time of one step, command to last status [µs].
    pub step_wall_median_us: f64,
    pub step_wall_p99_us: f64,
    /// Solvers the nodes actually run (a node may be started with its own `--solver`).
    pub fluid_solver: Option<String>,
    pub solid_solver: Option<String>,
    /// Checkpoints written (over the whole run, resumed parts included).
    #[serde(default)]
    pub checkpoints: u64,
    /// Node restarts after a death or hang (`--retries`), in this invocation.
    #[serde(default)]
    pub restarts: u32,
    /// The step this invocation resumed from (`--resume`, or its last restart); null if it ran
    /// from the start.
    #[serde(default)]
    pub resumed_from_step: Option<u64>,
}
