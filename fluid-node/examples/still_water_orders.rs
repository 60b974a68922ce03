//! Still water (the validation case, `fluid_node::validation::still_water_scene`) with the
//! neighbour grid's cells shifted, which changes the order the particles are sorted in and so
//! the order of every neighbour sum, and nothing of the physics: how far the still-water row
//! moves with the summation order alone (issue 44).
//!
//! `cargo run --release -p fluid-node --example still_water_orders -- SOLVER PER_DEPTH END
//! [--shift S]... [--param 'key = value']... [--defaults]`
//!
//! `--shift S` moves the domain's lower corner by S support radii (default: 0, 0.31, 0.62);
//! `--defaults` drops the case's own solver table (DFSPH's `pressure_tolerance`).

use fluid_node::validation::{TempRunDir, build, hydrostatics, run, still_water_scene};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let solver = args.first().cloned().expect("SOLVER PER_DEPTH END");
    let per: f64 = args[1].parse().expect("PER_DEPTH");
    let end: f64 = args[2].parse().expect("END");
    let (mut shifts, mut params, mut defaults) = (Vec::new(), Vec::new(), false);
    let mut i = 3;
    while i < args.len() {
        match args[i].as_str() {
            "--shift" => {
                shifts.push(args[i + 1].parse::<f64>().expect("shift"));
                i += 2;
            }
            "--param" => {
                params.push(args[i + 1].clone());
                i += 2;
            }
            "--defaults" => {
                defaults = true;
                i += 1;
            }
            o => panic!("unknown option {o}"),
        }
    }
    if shifts.is_empty() {
        shifts = vec![0.0, 0.31, 0.62];
    }
    let depth = 0.1;
    let dx = depth / per;
    for shift in shifts {
        let mut scene = still_water_scene(&solver, depth, dx, end, None);
        let fluid = scene.fluid.as_mut().expect("fluid");
        if defaults {
            fluid.solvers.remove(&solver);
        }
        if !params.is_empty() {
            let mut table = match fluid.solvers.get(&solver) {
                Some(toml::Value::Table(t)) => t.clone(),
                _ => toml::Table::new(),
            };
            let extra: toml::Table = toml::from_str(&params.join("\n")).expect("params");
            table.extend(extra);
            fluid
                .solvers
                .insert(solver.clone(), toml::Value::Table(table));
        }
        let support = 2.6 * dx;
        for k in 0..3 {
            scene.domain.min[k] -= shift * support;
        }
        let t0 = std::time::Instant::now();
        let dir = TempRunDir::new("orders").expect("run directory");
        let mut s = build(&solver, &scene, dir.path()).expect("build");
        let particles = s.system().len();
        let steps = run(s.as_mut(), &scene, end, |_, _| {}).expect("run");
        drop(s);
        let r = hydrostatics(dir.path(), &scene, depth, end, particles, steps).expect("files");
        // The deepest probe's scatter over the second half: step-to-step noise.
        let rows = std::fs::read_to_string(dir.path().join("probes.csv")).expect("probes");
        let deep: Vec<f64> = rows
            .lines()
            .skip(1)
            .filter_map(|l| {
                let v: Vec<f64> = l.split(',').filter_map(|x| x.parse().ok()).collect();
                (v.len() > 3 && v[0] >= 0.5 * end).then(|| v[3])
            })
            .collect();
        let mean = deep.iter().sum::<f64>() / deep.len().max(1) as f64;
        let sd = (deep.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / deep.len().max(1) as f64)
            .sqrt();
        let probes: Vec<String> = r
            .probes
            .iter()
            .map(|(d, p, p_ref)| format!("{d:.2}H {p:.1}/{p_ref:.1}"))
            .collect();
        println!(
            "{solver} H/dx = {per} shift {shift:.2}: error {:.2} % of ρ0gH, surface {:+.3} dx, {} steps, {:.1} s; {}; deepest probe scatter {sd:.0} Pa ({} rows)",
            100.0 * r.max_error,
            (r.surface - depth) / dx,
            r.steps,
            t0.elapsed().as_secs_f64(),
            probes.join(", "),
            deep.len()
        );
    }
}
