//! Writes a SPICE-subset netlist of an RLC ladder of N sections to stdout.
//!
//! `cargo run --release --example gen_ladder -- --sections 1000 > ladder.cir`
//! then `dirac run ladder.cir --signals 'v(n1)'`.
//!
//! Each section: series R = 0.1 and L = 1 from node n(k−1) to n(k), shunt C = 1 from n(k) to ground;
//! a 1 V DC source drives n0; `.tran 0.01 10 uic` (1000 steps), as in the interconnection issue's
//! scale benchmark (`examples/rlc_ladder.rs` builds the same ladder from section subsystems).

use std::error::Error;
use std::io::Write;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sections: usize = match args.iter().position(|a| a == "--sections") {
        Some(i) => args
            .get(i + 1)
            .and_then(|s| s.parse().ok())
            .ok_or("--sections expects a positive integer")?,
        None => 10,
    };
    if sections == 0 {
        return Err("--sections must be at least 1".into());
    }
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    writeln!(
        out,
        "RLC ladder of {sections} sections (R = 0.1, L = 1, C = 1), 1 V DC source"
    )?;
    writeln!(out, "V1 n0 0 DC 1")?;
    for k in 1..=sections {
        writeln!(out, "R{k} n{} m{k} 0.1", k - 1)?;
        writeln!(out, "L{k} m{k} n{k} 1")?;
        writeln!(out, "C{k} n{k} 0 1")?;
    }
    writeln!(out, ".tran 0.01 10 uic")?;
    writeln!(out, ".end")?;
    out.flush()?;
    Ok(())
}
