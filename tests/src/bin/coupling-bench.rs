//! `coupling-bench`: what the coupling itself costs, on this machine.
//!
//! 1. iceoryx2's raw round trip: a u64 sent to an echo process and back, each way a publish
//!    plus an event, the receiver blocked on its listener (the same pattern rockwave uses).
//! 2. One coupling exchange per step: the coupler and the two toy nodes (no physics) stepping
//!    a scene with 3 blocks and with 1000 blocks of geometry; the median wall time of a step
//!    is command + geometry + loads + two statuses.
//! 3. What waiting costs: the toy solid naps 1 ms per step (a stand-in for an expensive solver)
//!    while the fluid node waits for it; the fluid node's CPU time over the run should be
//!    near zero.
//!
//! 4. The same coupled steps over zenoh (`--transport zenoh`, TCP on loopback; with
//!    `--fluid-wrap "ip netns exec NS" --zenoh-listen tcp/ADDR:PORT` the fluid node runs in a
//!    network namespace and the coupler listens on the address the namespace reaches).
//!
//! Run: `cargo run --release -p tests --bin coupling-bench` (after `cargo build --release`).

use iceoryx2::prelude::*;
use shared::transport::{self, Party, Run, RunId};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() == 3 && args[1] == "--echo" {
        echo(&RunId::parse(&args[2]).expect("run id"));
        return;
    }
    let steps: usize = args
        .iter()
        .position(|a| a == "--steps")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000);
    let bin_dir = std::env::current_exe()
        .unwrap()
        .parent()
        .unwrap()
        .to_path_buf();
    println!("machine: {} cores, {}", num_cpus(), cpu_model());
    let (median, p99) = raw_round_trip(steps);
    println!("\n| measurement | median [µs] | p99 [µs] |\n|---|---:|---:|");
    println!("| iceoryx2 raw round trip (publish + event, both ways) | {median:.1} | {p99:.1} |");
    let opt = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let wrap = opt("--fluid-wrap").unwrap_or_default();
    let listen = opt("--zenoh-listen");
    let mut zenoh = vec!["--transport".to_string(), "zenoh".to_string()];
    if let Some(l) = &listen {
        zenoh.extend(["--listen".to_string(), l.clone()]);
    }
    for blocks in [3usize, 1000] {
        let s = coupled_run(&bin_dir, blocks, steps, "ballistic", &[], "");
        println!(
            "| coupled step, {blocks} blocks ({} vertices), toy nodes | {:.1} | {:.1} |",
            blocks * 8,
            s["stats"]["step_wall_median_us"].as_f64().unwrap(),
            s["stats"]["step_wall_p99_us"].as_f64().unwrap()
        );
    }
    for blocks in [3usize, 1000] {
        let s = coupled_run(&bin_dir, blocks, steps, "ballistic", &zenoh, &wrap);
        let where_ = if wrap.is_empty() {
            "loopback".to_string()
        } else {
            format!("fluid node under `{wrap}`")
        };
        println!(
            "| coupled step over zenoh ({where_}), {blocks} blocks ({} vertices), toy nodes | {:.1} | {:.1} |",
            blocks * 8,
            s["stats"]["step_wall_median_us"].as_f64().unwrap(),
            s["stats"]["step_wall_p99_us"].as_f64().unwrap()
        );
    }
    let nap_steps = (steps / 5).max(1000);
    let s = coupled_run(&bin_dir, 3, nap_steps, "ballistic-slow", &[], "");
    let st = &s["stats"];
    let wall = st["wall_seconds"].as_f64().unwrap();
    println!("\nwaiting cost: solid naps 1 ms per step for {nap_steps} steps ({wall:.2} s wall)");
    println!(
        "| process | CPU [s] (incl. start-up) | CPU / wall | CPU per step [µs] |\n|---|---:|---:|---:|"
    );
    for (who, key) in [
        ("fluid node (waits)", "fluid_cpu_seconds"),
        ("solid node (naps)", "solid_cpu_seconds"),
        ("coupler", "coupler_cpu_seconds"),
    ] {
        let cpu = st[key].as_f64().unwrap();
        println!(
            "| {who} | {cpu:.3} | {:.1} % | {:.1} |",
            100.0 * cpu / wall,
            1e6 * cpu / nap_steps as f64
        );
    }
}

fn num_cpus() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// The echo side of the raw round trip: returns every u64 it receives.
fn echo(id: &RunId) {
    let run = Run::join(id, "echo").unwrap();
    let ping = ping_service(&run, "ping");
    let pong = ping_service(&run, "pong");
    let sub = ping.subscriber_builder().create().unwrap();
    let publ = pong.publisher_builder().create().unwrap();
    let listener = run.listener(Party::Fluid).unwrap();
    let bell = run.notifier(Party::Coupler).unwrap();
    publ.send_copy(u64::MAX).unwrap(); // ready
    bell.notify().unwrap();
    loop {
        while let Some(s) = sub.receive().unwrap() {
            let v = *s.payload();
            publ.send_copy(v).unwrap();
            bell.notify().unwrap();
            if v == u64::MAX - 1 {
                return;
            }
        }
        transport::wait(&listener, Duration::from_millis(100)).unwrap();
    }
}

fn ping_service(
    run: &Run,
    leaf: &str,
) -> iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, u64, ()> {
    run.node
        .service_builder(&ServiceName::new(&format!("rockwave/{}/bench/{leaf}", run.id)).unwrap())
        .publish_subscribe::<u64>()
        .subscriber_max_buffer_size(4)
        .open_or_create()
        .unwrap()
}

fn raw_round_trip(n: usize) -> (f64, f64) {
    let id = RunId::fresh();
    let run = Run::join(&id, "pinger").unwrap();
    let ping = ping_service(&run, "ping");
    let pong = ping_service(&run, "pong");
    let publ = ping.publisher_builder().create().unwrap();
    let sub = pong.subscriber_builder().create().unwrap();
    let listener = run.listener(Party::Coupler).unwrap();
    let bell = run.notifier(Party::Fluid).unwrap();
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args(["--echo", id.as_str()])
        .spawn()
        .unwrap();
    let recv = |want: u64| loop {
        if let Some(s) = sub.receive().unwrap()
            && *s.payload() == want
        {
            return;
        }
        transport::wait(&listener, Duration::from_millis(100)).unwrap();
    };
    recv(u64::MAX);
    let mut times = Vec::with_capacity(n);
    for i in 0..n as u64 {
        let t = Instant::now();
        publ.send_copy(i).unwrap();
        bell.notify().unwrap();
        recv(i);
        times.push(t.elapsed().as_secs_f64() * 1e6);
    }
    publ.send_copy(u64::MAX - 1).unwrap();
    bell.notify().unwrap();
    child.wait().unwrap();
    drop((publ, sub, listener, bell, ping, pong, run));
    transport::remove_run_files(&id);
    times.sort_by(f64::total_cmp);
    (times[n / 2], times[(n as f64 * 0.99) as usize])
}

/// A scene of `blocks` free cubes on a grid, run for `steps` steps of 1 ms with the toy nodes.
fn coupled_run(
    bin: &Path,
    blocks: usize,
    steps: usize,
    solid: &str,
    extra: &[String],
    fluid_wrap: &str,
) -> serde_json::Value {
    let dir = std::env::temp_dir().join(format!("rockwave-bench-{}", RunId::fresh()));
    std::fs::create_dir_all(&dir).unwrap();
    let side = (blocks as f64).sqrt().ceil() as usize;
    let mut scene = format!(
        "name = \"bench_{blocks}\"\n[time]\nend = {}\ndt_max = 1e-3\n[domain]\nmin = [-1.0, -1.0, -10.0]\nmax = [{m}, {m}, 10.0]\n\
         [output]\ninterval = 1e6\nvtk = false\n[fluid]\ndx = 0.5\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, -3.0], max = [{m}, {m}, 0.0] }}\n",
        steps as f64 * 1e-3,
        m = 2.0 * side as f64 + 1.0
    );
    for i in 0..blocks {
        let (x, y) = (2.0 * (i % side) as f64, 2.0 * (i / side) as f64);
        scene.push_str(&format!(
            "[[block]]\nname = \"b{i}\"\nshape = {{ type = \"box\", min = [{x}, {y}, 1.0], max = [{}, {}, 2.0] }}\n",
            x + 1.0,
            y + 1.0
        ));
    }
    let scene_path = dir.join("scene.toml");
    std::fs::write(&scene_path, scene).unwrap();
    let out: PathBuf = dir.join("run");
    let status = Command::new(bin.join("coupler"))
        .arg("run")
        .arg(&scene_path)
        .args(["--quiet", "--fluid-cmd"])
        .arg(format!(
            "{fluid_wrap} {} --solver hover",
            bin.join("toy-fluid-node").display()
        ))
        .arg("--solid-cmd")
        .arg(format!(
            "{} --solver {solid}",
            bin.join("toy-solid-node").display()
        ))
        .arg("--out")
        .arg(&out)
        .args(extra)
        .status()
        .unwrap();
    assert!(status.success(), "coupled benchmark run failed");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    s
}
