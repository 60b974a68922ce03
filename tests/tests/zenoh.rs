//! The zenoh transport (issue 16): nodes on other hosts.
//!
//! - The coarse wedge runs with its fluid node in a network namespace of its own (a veth pair
//!   on a private /30, created and removed by the test), attached by hand to a coupler that
//!   listens on the host side, and writes byte-identical results to the same scene over
//!   iceoryx2. Where namespaces cannot be made (not root, no `ip`), the fluid node connects
//!   through another loopback address (127.0.0.2) instead, and the test says so.
//! - A node whose host goes silent (its process stopped: no data, no keep-alives) is named
//!   within the link lease, and the run stops cleanly with what was written kept.
//! - Endpoint mistakes on the command line are named with their fix.
//!
//! Every run has its own run id (its zenoh keys) and a port of its own.

mod common;
use common::*;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The determinism test's coarse wedge: a few seconds per run.
const COARSE: [&str; 4] = ["--dx", "0.08", "--end", "0.3"];

/// A TCP port free on `addr` right now.
fn free_port(addr: &str) -> u16 {
    std::net::TcpListener::bind((addr, 0))
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .unwrap_or_else(|e| panic!("no free port on {addr}: {e}"))
}

fn ip(args: &[&str]) -> Result<(), String> {
    let out = Command::new("ip")
        .args(args)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("ip {}: {e}", args.join(" ")))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "ip {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        ))
    }
}

/// A network namespace joined to this one by a veth pair: the host side has `host`, the
/// namespace `inside` (a /30 of the private 10.213.0.0/16). Removed on drop.
struct Netns {
    name: String,
    host: String,
    inside: String,
}

impl Netns {
    fn create(tag: &str) -> Result<Netns, String> {
        // One /30 per test process (the pid picks it), so parallel test binaries never clash.
        let pid = std::process::id();
        let (b, c) = ((pid >> 6) % 250, (pid % 64) * 4);
        let ns = Netns {
            name: format!("rw{tag}{pid}"),
            host: format!("10.213.{b}.{}", c + 1),
            inside: format!("10.213.{b}.{}", c + 2),
        };
        let (vh, vn) = (format!("rwh{pid}"), format!("rwn{pid}"));
        let made = (|| {
            ip(&["netns", "add", &ns.name])?;
            ip(&["link", "add", &vh, "type", "veth", "peer", "name", &vn])?;
            ip(&["link", "set", &vn, "netns", &ns.name])?;
            ip(&["addr", "add", &format!("{}/30", ns.host), "dev", &vh])?;
            ip(&["link", "set", &vh, "up"])?;
            let inside = ["netns", "exec", &ns.name, "ip"];
            let cidr = format!("{}/30", ns.inside);
            ip(&[&inside[..], &["addr", "add", &cidr, "dev", &vn]].concat())?;
            ip(&[&inside[..], &["link", "set", &vn, "up"]].concat())?;
            ip(&[&inside[..], &["link", "set", "lo", "up"]].concat())
        })();
        match made {
            Ok(()) => Ok(ns),
            Err(e) => {
                // Whatever was made goes (the namespace takes its veth end along).
                let _ = ip(&["link", "del", &vh]);
                drop(ns);
                Err(e)
            }
        }
    }
}

impl Drop for Netns {
    fn drop(&mut self) {
        // Deleting the namespace deletes its veth end, and with it the pair.
        let _ = ip(&["netns", "del", &self.name]);
    }
}

/// A node started by hand over zenoh; `wrap` goes before it (e.g. `ip netns exec NS`).
fn node(wrap: &[&str], binary: &str, id: &shared::transport::RunId, endpoint: &str) -> Command {
    let bin = bin(binary);
    let mut words: Vec<String> = wrap.iter().map(|s| s.to_string()).collect();
    words.push(bin.display().to_string());
    let mut c = Command::new(&words[0]);
    c.args(&words[1..])
        .args(["--prefix", id.as_str(), "--transport", "zenoh", "--connect"])
        .arg(endpoint)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

fn assert_identical(a: &Path, b: &Path) {
    let names = result_files(a);
    for n in [
        "gauges.csv",
        "blocks.csv",
        "particles_00000.vtp",
        "blocks_00000.vtp",
    ] {
        assert!(
            names.iter().any(|m| m == n),
            "{n} not written in {}",
            a.display()
        );
    }
    assert_eq!(result_files(b), names, "different sets of result files");
    for n in &names {
        let (x, y) = (
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(b.join(n)).unwrap(),
        );
        assert!(
            x == y,
            "{n} differs: {} ({} bytes) and {} ({} bytes)",
            a.display(),
            x.len(),
            b.display(),
            y.len()
        );
    }
    let rows = std::fs::read_to_string(a.join("blocks.csv"))
        .unwrap()
        .lines()
        .count();
    assert!(
        rows > 3,
        "blocks.csv has {rows} lines: nothing was simulated"
    );
    let (sa, sb) = (summary(a), summary(b));
    for key in ["steps", "frames", "dt_min", "dt_max"] {
        assert_eq!(
            sa["stats"][key], sb["stats"][key],
            "summary.json stats.{key}"
        );
    }
    assert!(sa["stats"]["steps"].as_u64().unwrap() > 10);
}

#[test]
fn wedge_over_zenoh_across_a_network_boundary_matches_iceoryx2() {
    // The reference: the same scene over iceoryx2.
    let (id_ref, out_ref) = fresh("zenoh-ref");
    let reference = coupler(&id_ref, &out_ref, &COARSE)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();

    let (id, out) = fresh("zenoh-net");
    let netns = Netns::create("z");
    let (listen_on, wrap): (String, Vec<String>) = match &netns {
        Ok(ns) => {
            eprintln!(
                "zenoh test: fluid node in network namespace {} ({}), coupler on {}",
                ns.name, ns.inside, ns.host
            );
            (
                ns.host.clone(),
                vec!["ip".into(), "netns".into(), "exec".into(), ns.name.clone()],
            )
        }
        Err(e) => {
            eprintln!(
                "zenoh test: SKIPPING the network namespace ({e}); the fluid node connects \
                 through 127.0.0.2 instead (another loopback address, same network stack)"
            );
            ("127.0.0.2".to_string(), Vec::new())
        }
    };
    let endpoint = format!("tcp/{listen_on}:{}", free_port(&listen_on));
    let coupler_child = coupler(
        &id,
        &out,
        &[
            &COARSE[..],
            &[
                "--transport",
                "zenoh",
                "--attach",
                "--listen",
                &endpoint,
                "--connect-timeout",
                "120",
            ],
        ]
        .concat(),
    )
    .stdout(Stdio::piped())
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    let wrap: Vec<&str> = wrap.iter().map(String::as_str).collect();
    let fluid = node(&wrap, "fluid-node", &id, &endpoint).spawn().unwrap();
    let solid = node(&[], "solid-node", &id, &endpoint).spawn().unwrap();

    let (o, took) = wait_output(coupler_child, Duration::from_secs(300));
    let (f, _) = wait_output(fluid, Duration::from_secs(30));
    let (s, _) = wait_output(solid, Duration::from_secs(30));
    assert!(
        o.status.success(),
        "zenoh run failed after {took:?}: {}\nfluid node: {}\nsolid node: {}",
        stderr(&o),
        stderr(&f),
        stderr(&s)
    );
    assert!(
        f.status.success() && s.status.success(),
        "{}{}",
        stderr(&f),
        stderr(&s)
    );
    let (r, _) = wait_output(reference, Duration::from_secs(300));
    assert!(r.status.success(), "iceoryx2 run failed: {}", stderr(&r));
    assert!(
        leftovers(&id).is_empty(),
        "the zenoh run left shared memory"
    );
    assert_identical(&out_ref, &out);
    drop(netns);
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_dir_all(&out_ref).unwrap();
}

#[test]
fn node_whose_host_goes_silent_is_named_within_the_lease() {
    let (id, out) = fresh("zenoh-silent");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port("127.0.0.1"));
    let scene = scene("toy_hover.toml");
    let mut child = coupler(
        &id,
        &out,
        &[
            scene.to_str().unwrap(),
            "--end",
            "1000",
            "--transport",
            "zenoh",
            "--listen",
            &endpoint,
            "--fluid-cmd",
            &toy_fluid("hover"),
            "--solid-cmd",
            &toy_solid(),
        ],
    );
    let child = child
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let nodes = running_nodes(pid);
    std::thread::sleep(Duration::from_secs(1));
    let fluid = *nodes
        .iter()
        .find(|&&n| cmdline(n).contains("toy-fluid-node"))
        .expect("the fluid node runs");
    // SIGSTOP: the node's host as the network sees a vanished one (no data, no keep-alives;
    // the TCP connection stays open, so only the lease can tell).
    let stopped = Instant::now();
    unsafe_kill(fluid, 19);
    let (o, _) = wait_output(child, Duration::from_secs(60));
    let noticed = stopped.elapsed();
    unsafe_kill(fluid, 9);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("fluid node") && err.contains("no longer reachable"),
        "the silent node is not named: {err}"
    );
    let lease = shared::transport::zenoh::LEASE;
    assert!(
        noticed < lease * 3 + Duration::from_secs(5),
        "noticed after {noticed:?} (lease {lease:?})"
    );
    eprintln!("zenoh test: the silent fluid node was named {noticed:?} after it stopped");
    // The run stopped cleanly: its summary says how far it got and why it ended.
    // (Under load the node may still be setting up when it is stopped: the steps taken may be
    // none, and the summary says so.)
    let s = summary(&out);
    assert!(s["stats"]["steps"].is_u64(), "{s}");
    assert!(
        s["message"]
            .as_str()
            .unwrap_or("")
            .contains("no longer reachable"),
        "{s}"
    );
    assert!(out.join("scene.toml").is_file(), "what was written is kept");
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn endpoint_mistakes_are_named_with_their_fix() {
    let (id, out) = fresh("zenoh-cli");
    let scene = scene("toy_hover.toml");
    let s = scene.to_str().unwrap();
    for (args, expect) in [
        (
            vec![s, "--transport", "zenoh", "--attach"],
            "Fix: add --listen",
        ),
        (
            vec![s, "--listen", "tcp/127.0.0.1:7447"],
            "Fix: add --transport zenoh",
        ),
        (
            vec![s, "--transport", "zenoh", "--listen", "127.0.0.1:7447"],
            "not a zenoh endpoint",
        ),
    ] {
        let o = run(coupler(&id, &out, &args));
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(expect), "{args:?}: {}", stderr(&o));
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
}

#[test]
fn node_without_a_coupler_says_where_it_looked() {
    let (id, _) = fresh("zenoh-alone");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port("127.0.0.1"));
    let mut cmd = node(&[], "fluid-node", &id, &endpoint);
    cmd.args(["--connect-timeout", "1"]);
    let (o, took) = wait_output(cmd.spawn().unwrap(), Duration::from_secs(30));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains(&format!("no coupler reachable at {endpoint}")) && err.contains("Fix:"),
        "{err}"
    );
    assert!(
        took < Duration::from_secs(20),
        "gave up only after {took:?}"
    );
}
