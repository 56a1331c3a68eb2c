//! Median wall time of [`Model::run`] (set-up, the steps, every row kept) for a netlist or scene:
//! the Rust side of the Python layer's overhead measured by
//! `crates/dirac-python/bench/throughput.py`.
//!
//! `cargo run --release -p dirac-study --example run_cost -- FILE [REPETITIONS]` prints the
//! median in seconds.

use std::time::Instant;

use dirac_study::{Model, RunSettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or_else(|| "examples/netlists/seed_rlc.cir".to_string());
    let repetitions: usize = args.next().map_or(Ok(200), |s| s.parse())?;
    let model = Model::from_file(&path)?;
    let settings = RunSettings::default();
    let mut times = Vec::with_capacity(repetitions);
    for _ in 0..repetitions.max(1) {
        let start = Instant::now();
        let run = model.run(&settings)?;
        std::hint::black_box(run);
        times.push(start.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    println!("{:e}", times[times.len() / 2]);
    Ok(())
}
