//! Peer cross-check against ngspice on the bundled linear netlists.
//!
//! Seven bundled netlists (DC, SIN, PULSE and PWL sources; R, L, C, mutual inductance, a
//! parameterised subcircuit) run through `dirac run` and through `ngspice -b`. ngspice gets a copy
//! of the netlist, in a temporary directory, with
//!
//! * `.options method=trap` (the trapezoidal rule, which on a linear circuit is the same scheme
//!   as our midpoint discrete Dirac integrator on a fixed grid),
//! * `.tran TSTEP TSTOP 0 TSTEP uic` (maximum step = TSTEP, initial conditions as given),
//! * a `.control` block that runs the analysis and writes ngspice's *raw* time points with
//!   `wrdata`.
//!
//! ngspice does not keep a fixed step even with TMAX = TSTEP: it starts with small steps and cuts
//! the step at every source breakpoint, after which its grid is shifted against ours. Its
//! `.options interp` output is off by about 1.4 steps (docs/audit.md item 8), so it is not used.
//! Instead *our* solution is interpolated onto ngspice's raw time points with a four-point (cubic)
//! Lagrange stencil on our uniform grid. The stencil stays strictly inside one smooth piece between
//! source breakpoints (see [`lagrange4`]), which is possible because every breakpoint of these
//! netlists lies on our grid (checked).
//!
//! # Tolerance
//!
//! Both schemes are second order and coincide on a fixed grid, but ngspice's grid differs near
//! start-up and after breakpoints, so the two solutions differ by O(h²), not by round-off. The
//! tolerance is derived from an error estimate, not tuned:
//!
//! * Per signal, ours runs at h (the netlist's TSTEP) and at h/2. Richardson's estimate of our
//!   global error at h is `E = 4/3 · max_k |y_h(t_k) − y_{h/2}(t_k)|` over the common grid points
//!   that are compared (windows below).
//! * ngspice takes steps ≤ h with the same second-order rule, so its error is at most of the same
//!   size E; the cubic interpolation adds O(h⁴), negligible here.
//! * Hence `max |ours − ngspice| ≤ 2·E + 1e-6 · max |signal|`. The second term is a floor for
//!   round-off and ngspice's 16-digit output (it matters only for source nodes, where E is 0 or
//!   round-off). ngspice's convergence tolerances do not enter: on a linear circuit its Newton
//!   iteration is exact after one solve, so its defaults (`reltol = 1e-3`, `vntol = 1e-6`) only
//!   steer its truncation-error step control, and that is capped by TMAX = TSTEP. We keep the
//!   defaults on purpose: tightening them (`reltol=1e-6 abstol=1e-12 vntol=1e-9`) was measured to
//!   make ngspice refine steps below TSTEP (2602 instead of 2018 points on `coupled_lc.cir`), i.e.
//!   to run a finer integrator than ours. The test still passed then, but the comparison is no
//!   longer "same step".
//!
//! Points within 3·h after t = 0 (ngspice's start-up steps; our node potentials are a second-order
//! readout of the KCL multipliers, docs/audit.md item 7) and within 3·h after each source
//! breakpoint (PULSE corners, PWL corners, SIN delay) are not compared; at least 80 % of ngspice's
//! points must be.
//!
//! Two guards keep the test from passing vacuously with a large E:
//!
//! * a run at h/4 gives the observed order `log2(|y_h − y_{h/2}| / |y_{h/2} − y_{h/4}|)`, which
//!   must be within 2 ± 0.2: E is then an asymptotically valid error estimate;
//! * the tolerance must be smaller than the largest change of the signal over one step, so a time
//!   shift of one step (the size of the `interp` defect above) would fail.
//!
//! Node voltages are compared, and so are capacitor charges: `q(C)/C` (a state of ours, not a
//! readout) against ngspice's voltage of the capacitor's node (all capacitors here are grounded),
//! with the same tolerance rule. The charges agree with ngspice far more closely than E (the two
//! schemes coincide), while our node potentials differ from ngspice by about their own E: that is
//! the readout's O(h²) error.
//!
//! ngspice must be on PATH (CI installs it with `apt-get install ngspice`); without it the test
//! fails rather than skipping.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A bundled netlist, with the grounded capacitors whose charges we check.
struct Case {
    file: &'static str,
    /// `(charge column, node, capacitance)`, from the netlist's C cards.
    caps: &'static [(&'static str, &'static str, f64)],
}

const CASES: &[Case] = &[
    // C1 out 0 {c0} IC=0, c0 = 1u
    Case {
        file: "rc_dc.cir",
        caps: &[("q(c1)", "out", 1e-6)],
    },
    // C1 m 0 1uF IC=0; C2 out 0 0.47u IC=0
    Case {
        file: "rc_pulse.cir",
        caps: &[("q(c1)", "m", 1e-6), ("q(c2)", "out", 0.47e-6)],
    },
    // C1 top 0 2u IC=0
    Case {
        file: "rl_pwl.cir",
        caps: &[("q(c1)", "top", 2e-6)],
    },
    // C1 b 0 {cval} IC=0, cval = 10u
    Case {
        file: "rlc_sin.cir",
        caps: &[("q(c1)", "b", 10e-6)],
    },
    // C1 1 0 3 IC=1
    Case {
        file: "seed_rlc.cir",
        caps: &[("q(c1)", "1", 3.0)],
    },
    // C1 p 0 1u IC=1; C2 s 0 1u IC=0
    Case {
        file: "coupled_lc.cir",
        caps: &[("q(c1)", "p", 1e-6), ("q(c2)", "s", 1e-6)],
    },
    // Section C1 b 0 {c}: X1 and X2 with c = csec = 1u (b = n2, n3), X3 with c = csec/2 (b = n4)
    Case {
        file: "ladder_subckt.cir",
        caps: &[
            ("q(x1.c1)", "n2", 1e-6),
            ("q(x2.c1)", "n3", 1e-6),
            ("q(x3.c1)", "n4", 0.5e-6),
        ],
    },
];

/// Half-width (in steps) of the windows after t = 0 and after each breakpoint.
const WINDOW_STEPS: f64 = 3.0;
/// Share of ngspice's points that must be compared.
const MIN_COMPARED: f64 = 0.8;
/// Relative floor of the tolerance: round-off and ngspice's 16-digit output.
const REL_FLOOR: f64 = 1e-6;
/// Allowed deviation of the observed order of convergence from 2.
const ORDER_SLACK: f64 = 0.2;
/// The options added to ngspice's copy of the netlist (see the module documentation).
const NGSPICE_OPTIONS: &str = ".options method=trap";

fn repo(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path)
}

/// Removes the scratch directory, also when the test panics.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("dirac-ngspice-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        Self(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A SPICE number with an optional scale suffix and unit (`10u`, `1uF`, `5V`, `2meg`).
fn spice_number(s: &str) -> Option<f64> {
    let s = s.trim().to_ascii_lowercase();
    let b = s.as_bytes();
    let mut end = 0;
    while end < b.len()
        && (b[end].is_ascii_digit() || b[end] == b'.' || b[end] == b'+' || b[end] == b'-')
    {
        end += 1;
    }
    // An exponent only if `e` is followed by a (signed) digit, so `1meg` stays a suffix.
    if end < b.len() && b[end] == b'e' {
        let mut k = end + 1;
        if k < b.len() && (b[k] == b'+' || b[k] == b'-') {
            k += 1;
        }
        if k < b.len() && b[k].is_ascii_digit() {
            while k < b.len() && b[k].is_ascii_digit() {
                k += 1;
            }
            end = k;
        }
    }
    let mantissa: f64 = s[..end].parse().ok()?;
    let rest = &s[end..];
    let scale = if rest.starts_with("meg") {
        1e6
    } else if rest.starts_with("mil") {
        25.4e-6
    } else {
        match rest.chars().next() {
            Some('f') => 1e-15,
            Some('p') => 1e-12,
            Some('n') => 1e-9,
            Some('u') => 1e-6,
            Some('m') => 1e-3,
            Some('k') => 1e3,
            Some('g') => 1e9,
            Some('t') => 1e12,
            _ => 1.0,
        }
    };
    Some(mantissa * scale)
}

/// The literal arguments of `name(...)` on a source card, if it has that function.
fn source_args(card: &str, name: &str) -> Option<Vec<f64>> {
    let lower = card.to_ascii_lowercase();
    let start = lower.find(&format!("{name}("))? + name.len() + 1;
    let end = start + lower[start..].find(')')?;
    Some(
        lower[start..end]
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|w| !w.is_empty())
            .map(|w| {
                spice_number(w)
                    .unwrap_or_else(|| panic!("non-literal source argument `{w}` in `{card}`"))
            })
            .collect(),
    )
}

/// The netlist's `.tran` step and stop time, and its source breakpoints in (0, stop).
struct Deck {
    text: String,
    tstep: f64,
    tstop: f64,
    breakpoints: Vec<f64>,
}

fn read_deck(path: &Path) -> Deck {
    let text = std::fs::read_to_string(path).expect("netlist");
    let tran = text
        .lines()
        .find(|l| l.trim_start().to_ascii_lowercase().starts_with(".tran"))
        .expect(".tran card");
    let words: Vec<&str> = tran.split_whitespace().collect();
    let tstep = spice_number(words[1]).expect("TSTEP");
    let tstop = spice_number(words[2]).expect("TSTOP");
    assert!(
        words.iter().any(|w| w.eq_ignore_ascii_case("uic")),
        "{}: the cross-check expects `uic`",
        path.display()
    );

    let mut breakpoints = Vec::new();
    for card in text.lines().skip(1) {
        let first = card
            .trim_start()
            .chars()
            .next()
            .map(|c| c.to_ascii_lowercase());
        if !matches!(first, Some('v' | 'i')) {
            continue;
        }
        if let Some(a) = source_args(card, "pulse") {
            // PULSE(V1 V2 TD TR TF PW PER): corners at TD + n·PER + {0, TR, TR+PW, TR+PW+TF}.
            assert_eq!(
                a.len(),
                7,
                "the test expects all seven PULSE arguments: `{card}`"
            );
            let (td, tr, tf, pw, per) = (a[2], a[3], a[4], a[5], a[6]);
            let mut start = td;
            while start < tstop {
                breakpoints.extend([start, start + tr, start + tr + pw, start + tr + pw + tf]);
                start += per;
            }
        } else if let Some(a) = source_args(card, "pwl") {
            // PWL(T1 V1 T2 V2 ...): a corner at every Ti.
            breakpoints.extend(a.iter().step_by(2));
        } else if let Some(a) = source_args(card, "sin") {
            // SIN(VO VA FREQ TD THETA): the sine starts (with a kink) at TD.
            if let Some(&td) = a.get(3) {
                breakpoints.push(td);
            }
        }
    }
    breakpoints.retain(|&b| b > 0.0 && b < tstop);
    breakpoints.sort_by(f64::total_cmp);
    breakpoints.dedup_by(|a, b| (*a - *b).abs() < 1e-12 * tstop);
    Deck {
        text,
        tstep,
        tstop,
        breakpoints,
    }
}

/// A CSV with a header row, as columns.
struct Table {
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
}

impl Table {
    fn column(&self, name: &str) -> &[f64] {
        let i = self
            .names
            .iter()
            .position(|n| n == name)
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.names));
        &self.columns[i]
    }
}

fn parse_table(text: &str, separator: fn(&str) -> Vec<&str>) -> Table {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let names: Vec<String> = separator(lines.next().expect("header"))
        .into_iter()
        .map(str::to_ascii_lowercase)
        .collect();
    let mut columns = vec![Vec::new(); names.len()];
    for line in lines {
        let cells = separator(line);
        assert_eq!(cells.len(), names.len(), "ragged row `{line}`");
        for (c, cell) in columns.iter_mut().zip(cells) {
            c.push(
                cell.parse()
                    .unwrap_or_else(|_| panic!("bad number `{cell}`")),
            );
        }
    }
    Table { names, columns }
}

fn run_dirac(netlist: &Path, h: Option<f64>, out: &Path) -> Table {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_dirac"));
    cmd.arg("run")
        .arg(netlist)
        .arg("--out")
        .arg(out)
        .arg("--quiet");
    if let Some(h) = h {
        cmd.arg("--h").arg(format!("{h:e}"));
    }
    let output = cmd.output().expect("dirac runs");
    assert!(
        output.status.success(),
        "dirac run {} failed: {}",
        netlist.display(),
        String::from_utf8_lossy(&output.stderr)
    );
    let text = std::fs::read_to_string(out).expect("dirac output");
    parse_table(&text, |l| l.split(',').collect())
}

fn ngspice() -> Command {
    Command::new("ngspice")
}

/// Fails (does not skip) when ngspice is missing.
fn require_ngspice() {
    match ngspice().arg("--version").output() {
        Ok(_) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            panic!("ngspice not found: install it with `apt-get install ngspice`")
        }
        Err(e) => panic!("cannot run ngspice: {e}"),
    }
}

fn run_ngspice(deck: &Deck, nodes: &[String], dir: &Path) -> Table {
    let data = dir.join("ngspice.dat");
    let mut text = String::new();
    for line in deck.text.lines() {
        let lower = line.trim().to_ascii_lowercase();
        if lower == ".end" {
            continue;
        }
        if lower.starts_with(".tran") {
            // TSTART = 0, TMAX = TSTEP.
            writeln!(
                text,
                ".tran {:e} {:e} 0 {:e} uic",
                deck.tstep, deck.tstop, deck.tstep
            )
            .unwrap();
        } else {
            writeln!(text, "{line}").unwrap();
        }
    }
    let vectors: Vec<String> = nodes.iter().map(|n| format!("v({n})")).collect();
    writeln!(
        text,
        "{}\n\
         .control\nset wr_singlescale\nset wr_vecnames\nset numdgt=15\nrun\n\
         wrdata {} {}\nquit\n.endc\n.end",
        NGSPICE_OPTIONS,
        data.display(),
        vectors.join(" ")
    )
    .unwrap();
    let cir = dir.join("ngspice.cir");
    std::fs::write(&cir, text).expect("write ngspice deck");
    let output = ngspice()
        .arg("-b")
        .arg(&cir)
        .current_dir(dir)
        .output()
        .expect("ngspice runs");
    assert!(
        output.status.success() && data.exists(),
        "ngspice failed on {}:\n{}\n{}",
        cir.display(),
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    let text = std::fs::read_to_string(&data).expect("ngspice output");
    parse_table(&text, |l| l.split_whitespace().collect())
}

/// Four-point Lagrange interpolation of `y` (on `t_k = k·h`) at `t`, with a stencil strictly
/// inside the smooth piece `[lo, hi]` (grid indices) that contains `t`.
///
/// The piece's end nodes are left out: our node potential at `t_k` averages the two steps
/// adjacent to `t_k` (on a voltage source's node it is the mean of the source at `t_k ± h/2`),
/// so at a breakpoint it is a mean across the kink, a value of neither piece. Near the ends of a
/// piece the stencil therefore extrapolates by at most one step, still with an O(h⁴) error.
fn lagrange4(y: &[f64], h: f64, t: f64, lo: usize, hi: usize) -> f64 {
    assert!(hi >= lo + 5, "smooth piece too short for the stencil");
    let j = ((t / h).floor() as isize - 1).clamp(lo as isize + 1, hi as isize - 4) as usize;
    let s = t / h;
    (0..4)
        .map(|a| {
            let w: f64 = (0..4)
                .filter(|&b| b != a)
                .map(|b| (s - (j + b) as f64) / (a as f64 - b as f64))
                .product();
            w * y[j + a]
        })
        .sum()
}

/// One compared signal.
struct Row {
    case: &'static str,
    signal: String,
    /// max |ours − ngspice| over the compared points.
    diff: f64,
    /// Richardson estimate of our error at h.
    e: f64,
    /// Observed order of convergence from the runs at h, h/2 and h/4.
    order: f64,
    /// Largest change of the signal over one step (what a one-step time shift would cost).
    step_change: f64,
    scale: f64,
    compared: usize,
    total: usize,
}

impl Row {
    fn tolerance(&self) -> f64 {
        2.0 * self.e + REL_FLOOR * self.scale
    }
}

fn check_case(case: &Case) -> Vec<Row> {
    let netlist = repo("examples/netlists").join(case.file);
    let deck = read_deck(&netlist);
    let scratch = Scratch::new(case.file.trim_end_matches(".cir"));
    let h = deck.tstep;
    let ours = run_dirac(&netlist, None, &scratch.0.join("h.csv"));
    let half = run_dirac(&netlist, Some(h / 2.0), &scratch.0.join("h2.csv"));
    let quarter = run_dirac(&netlist, Some(h / 4.0), &scratch.0.join("h4.csv"));

    // Our grid is t_k = k·h, and every breakpoint must be on it (stencils stop there).
    let t = ours.column("t");
    for (k, &tk) in t.iter().enumerate() {
        assert!(
            (tk - k as f64 * h).abs() <= 1e-9 * h,
            "{}: t[{k}] = {tk}",
            case.file
        );
    }
    let n = t.len() - 1;
    let mut pieces = vec![0usize];
    for &b in &deck.breakpoints {
        let k = (b / h).round();
        assert!(
            (b - k * h).abs() <= 1e-9 * h,
            "{}: breakpoint {b} is not on the grid",
            case.file
        );
        pieces.push(k as usize);
    }
    pieces.push(n);
    pieces.dedup();
    let piece = |tt: f64| -> (usize, usize) {
        let k = ((tt / h).floor() as usize).min(n - 1);
        let i = pieces.partition_point(|&p| p <= k) - 1;
        (pieces[i], pieces[i + 1])
    };
    let window = WINDOW_STEPS * h * (1.0 + 1e-9);
    let starts: Vec<f64> = std::iter::once(0.0)
        .chain(deck.breakpoints.iter().copied())
        .collect();
    let compared = |tt: f64| {
        !starts
            .iter()
            .any(|&b| tt >= b - 1e-9 * h && tt <= b + window)
    };

    let nodes: Vec<String> = ours
        .names
        .iter()
        .filter_map(|n| n.strip_prefix("v(")?.strip_suffix(')').map(str::to_owned))
        .collect();
    let spice = run_ngspice(&deck, &nodes, &scratch.0);
    let ts = spice.column("time");
    let total = ts.len();

    // (our signal, its values at h, h/2 and h/4, ngspice's vector).
    let runs = [&ours, &half, &quarter];
    let mut signals: Vec<(String, [Vec<f64>; 3], String)> = nodes
        .iter()
        .map(|node| {
            let v = format!("v({node})");
            (v.clone(), runs.map(|r| r.column(&v).to_vec()), v)
        })
        .collect();
    for &(q, node, c) in case.caps {
        let scaled = runs.map(|r| r.column(q).iter().map(|x| x / c).collect());
        signals.push((format!("{q}/C"), scaled, format!("v({node})")));
    }

    signals
        .into_iter()
        .map(|(signal, [y, y2, y4], spice_name)| {
            let grid = || (0..=n).filter(|&k| compared(k as f64 * h));
            let d2 = grid().map(|k| (y[k] - y2[2 * k]).abs()).fold(0.0, f64::max);
            let d4 = grid()
                .map(|k| (y2[2 * k] - y4[4 * k]).abs())
                .fold(0.0, f64::max);
            let e = 4.0 / 3.0 * d2;
            let step_change = (0..n)
                .filter(|&k| compared(k as f64 * h) && compared((k + 1) as f64 * h))
                .map(|k| (y[k + 1] - y[k]).abs())
                .fold(0.0, f64::max);
            let reference = spice.column(&spice_name);
            let mut diff = 0.0f64;
            let mut count = 0;
            for (&tt, &v) in ts.iter().zip(reference) {
                if !compared(tt) {
                    continue;
                }
                let (lo, hi) = piece(tt);
                diff = diff.max((lagrange4(&y, h, tt, lo, hi) - v).abs());
                count += 1;
            }
            let scale = y
                .iter()
                .chain(reference)
                .fold(0.0f64, |m, x| m.max(x.abs()));
            Row {
                case: case.file,
                signal,
                diff,
                e,
                order: (d2 / d4).log2(),
                step_change,
                scale,
                compared: count,
                total,
            }
        })
        .collect()
}

#[test]
fn bundled_linear_netlists_agree_with_ngspice() {
    require_ngspice();
    let rows: Vec<Row> = std::thread::scope(|s| {
        let handles: Vec<_> = CASES
            .iter()
            .map(|c| s.spawn(move || check_case(c)))
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    });

    let mut report = format!(
        "{:<18} {:<12} {:>10} {:>10} {:>6} {:>6} {:>10} {:>10} {:>10}\n",
        "netlist", "signal", "max|d|", "E", "d/E", "order", "step", "max|y|", "compared"
    );
    let mut failures = Vec::new();
    for r in &rows {
        // Signals that are exact to the floor (source nodes) have no order and may be constant.
        let inexact = r.e > REL_FLOOR * r.scale;
        writeln!(
            report,
            "{:<18} {:<12} {:>10.3e} {:>10.3e} {:>6} {:>6} {:>10.3e} {:>10.3e} {:>5}/{:<5}",
            r.case,
            r.signal,
            r.diff,
            r.e,
            if inexact {
                format!("{:.3}", r.diff / r.e)
            } else {
                "-".into()
            },
            if inexact {
                format!("{:.2}", r.order)
            } else {
                "-".into()
            },
            r.step_change,
            r.scale,
            r.compared,
            r.total
        )
        .unwrap();
        if r.diff > r.tolerance() {
            failures.push(format!(
                "{} {}: max|ours − ngspice| = {:.3e} > 2·E + {REL_FLOOR:e}·max|y| = {:.3e}",
                r.case,
                r.signal,
                r.diff,
                r.tolerance()
            ));
        }
        if inexact && (r.order - 2.0).abs() > ORDER_SLACK {
            failures.push(format!(
                "{} {}: observed order {:.2} is not 2, so E = {:.3e} is no error estimate",
                r.case, r.signal, r.order, r.e
            ));
        }
        if inexact && r.tolerance() >= r.step_change {
            failures.push(format!(
                "{} {}: tolerance {:.3e} would not detect a one-step time shift ({:.3e})",
                r.case,
                r.signal,
                r.tolerance(),
                r.step_change
            ));
        }
        if (r.compared as f64) < MIN_COMPARED * r.total as f64 {
            failures.push(format!(
                "{} {}: only {} of {} ngspice points compared",
                r.case, r.signal, r.compared, r.total
            ));
        }
    }
    println!("{report}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
