fn main() {
    for w in [1.5, 1.8, 1.9, 1.95, 1.99, 2.05, 2.5] {
        let e: Vec<String> = (0..8).map(|k| match solid_node::verification::bounce("explicit", w, (k as f64 + 0.5) / 8.0) { Ok(e) => format!("{e:.3}"), Err(e) => format!("ERR {}", &e.to_string()[..60]) }).collect();
        println!("Ω {w}: {}", e.join(" "));
    }
}
