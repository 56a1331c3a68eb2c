//! The step-size report of `dirac check`: the fastest natural modes of the model linearised at its
//! start, and how many steps of `h` fall on each (docs/math.md §8).

use dirac_sim::{IntegratorOptions, MethodResponse, ModeKind, NaturalModes};

/// Modes of each kind listed by `dirac check`.
const LISTED: usize = 4;

/// Damping ratios below this are rounding of an undamped mode (eigenvalues are good to ~1e-14
/// relative).
const ROUND_OFF: f64 = 1e-12;

/// A step count: plain with one decimal in the usual range, scientific outside it.
fn count(x: f64) -> String {
    if (0.1..1e6).contains(&x) {
        format!("{x:.1}")
    } else {
        format!("{x:.3e}")
    }
}

/// The lines of the report, indented for `dirac check`.
pub fn report(modes: &NaturalModes, options: &IntegratorOptions, start: &str) -> Vec<String> {
    let h = options.h;
    let mut out = vec![format!(
        "  natural modes, linearised at {start} ({} oscillations, {} real modes{}):",
        modes.of_kind(ModeKind::Oscillation).count(),
        modes.modes.len() - modes.of_kind(ModeKind::Oscillation).count(),
        if modes.static_modes > 0 {
            format!(", {} static", modes.static_modes)
        } else {
            String::new()
        }
    )];
    for kind in [ModeKind::Oscillation, ModeKind::Decay, ModeKind::Growth] {
        let total = modes.of_kind(kind).count();
        for mode in modes.of_kind(kind).take(LISTED) {
            let place = mode
                .coordinate
                .as_ref()
                .map_or_else(String::new, |c| format!("  in {c}"));
            out.push(match kind {
                ModeKind::Oscillation => {
                    let phase = match MethodResponse::oscillation(options, mode.im) {
                        MethodResponse::Phase { frequency_error } => {
                            format!(
                                "phase error {:.2e} rad per period",
                                frequency_error.abs() * std::f64::consts::TAU
                            )
                        }
                        MethodResponse::Unstable { growth } => {
                            format!("UNSTABLE: grows by {growth:.3} per step")
                        }
                        MethodResponse::Failed => "method response unknown".into(),
                    };
                    let zeta = mode.damping_ratio();
                    format!(
                        "    oscillation  period {:<11.4e} damping ratio {:<9.3} {:>10} steps per period ({phase}){place}",
                        mode.period().unwrap_or(0.0),
                        if zeta.abs() < ROUND_OFF { 0.0 } else { zeta },
                        count(mode.steps(h))
                    )
                }
                ModeKind::Decay | ModeKind::Growth => {
                    let factor = MethodResponse::decay(options, mode.time_constant().unwrap_or(0.0))
                        .filter(|_| kind == ModeKind::Decay)
                        .map_or_else(String::new, |r| {
                            format!(
                                " (method: {r:.3} per step, exact {:.3e})",
                                (-h / mode.time_constant().unwrap_or(f64::INFINITY)).exp()
                            )
                        });
                    format!(
                        "    {:<12} time constant {:<11.4e} {:>34} steps per τ{factor}{place}",
                        if kind == ModeKind::Decay { "decay" } else { "growth" },
                        mode.time_constant().unwrap_or(0.0),
                        count(mode.steps(h))
                    )
                }
            });
        }
        if total > LISTED {
            out.push(format!(
                "    … {} slower {}",
                total - LISTED,
                match kind {
                    ModeKind::Oscillation => "oscillations",
                    ModeKind::Decay => "decays",
                    ModeKind::Growth => "growing modes",
                }
            ));
        }
    }
    let warnings = modes.warnings(options);
    if warnings.is_empty() {
        out.push(format!(
            "  step size h = {h:e}: no warning (every oscillation gets at least {} steps per period; no mode much faster than h is left undamped by the method)",
            dirac_sim::MIN_STEPS_PER_PERIOD
        ));
    } else {
        out.extend(warnings.into_iter().map(|w| format!("  warning: {w}")));
    }
    out
}
