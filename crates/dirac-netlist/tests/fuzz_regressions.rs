//! Inputs that once broke the netlist reader (found by fuzzing, kept in
//! `fuzz/regressions/netlist/`): every one must now be read, or refused with a typed error, by
//! `parse_netlist` and `build_circuit` without a panic, a hang or an allocation out of proportion.

use std::path::PathBuf;

use dirac_netlist::{ErrorKind, build_circuit, parse_netlist};

fn regressions() -> Vec<(String, String)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions/netlist");
    let mut files: Vec<(String, String)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| {
            let path = entry.expect("entry").path();
            let bytes = std::fs::read(&path).expect("readable");
            (
                path.file_name()
                    .expect("name")
                    .to_string_lossy()
                    .into_owned(),
                String::from_utf8_lossy(&bytes).into_owned(),
            )
        })
        .collect();
    files.sort();
    files
}

/// Every kept input goes through the reader as the fuzz target drives it (a panic fails the
/// test).
#[test]
fn every_kept_input_is_read_or_refused() {
    let files = regressions();
    assert!(!files.is_empty(), "no regression inputs found");
    for (name, text) in files {
        if let Ok(netlist) = parse_netlist(&text, &name) {
            let _ = build_circuit(&netlist, &name);
        }
    }
}

/// Eight levels of ten nested instances would expand to 10⁸ resistors: before the expansion
/// bound the reader ran out of memory (2.5 GB after a minute, still growing); now it stops after
/// 10⁵ expanded elements with an `Unsupported` error naming the bound. Mutation: the bound check
/// in `flatten.rs` removed makes this test exhaust memory instead of returning.
#[test]
fn exponential_subcircuit_expansion_is_refused() {
    let text = regressions()
        .into_iter()
        .find(|(name, _)| name == "exponential_subckt.cir")
        .expect("kept input")
        .1;
    let e = parse_netlist(&text, "exponential_subckt.cir").expect_err("refused");
    assert_eq!(e.kind, ErrorKind::Unsupported, "{e}");
    assert!(e.to_string().contains("more than 100000 elements"), "{e}");
}
