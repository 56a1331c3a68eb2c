//! Source waveforms against hand-computed values (ngspice's definitions).

use std::f64::consts::PI;

use dirac_netlist::SourceSpec;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + b.abs())
}

fn check(spec: &SourceSpec, cases: &[(f64, f64, f64)]) {
    for &(t, value, slope) in cases {
        let (v, d) = (spec.value(t), spec.derivative(t));
        assert!(
            close(v, value),
            "value at t={t}: {v} != {value} for {spec:?}"
        );
        assert!(
            close(d, slope),
            "slope at t={t}: {d} != {slope} for {spec:?}"
        );
    }
}

/// Central differences agree with `derivative` away from corners.
fn check_derivative(spec: &SourceSpec, times: &[f64]) {
    let h = 1e-7;
    for &t in times {
        let fd = (spec.value(t + h) - spec.value(t - h)) / (2.0 * h);
        let d = spec.derivative(t);
        assert!(
            (fd - d).abs() <= 1e-5 * (1.0 + d.abs()),
            "t={t}: fd {fd} vs {d}"
        );
    }
}

#[test]
fn sin_with_delay_and_damping() {
    let s = SourceSpec::Sin {
        vo: 1.0,
        va: 2.0,
        freq: 50.0,
        td: 0.01,
        theta: 10.0,
        phase: 0.0,
    };
    check(
        &s,
        &[
            (0.0, 1.0, 0.0),
            (0.005, 1.0, 0.0),
            (0.01, 1.0, 0.0),
            // tau = 5 ms: a quarter period, the crest.
            (
                0.015,
                1.0 + 2.0 * (-0.05f64).exp(),
                -20.0 * (-0.05f64).exp(),
            ),
            // tau = 15 ms: three quarters, the trough.
            (0.025, 1.0 - 2.0 * (-0.15f64).exp(), 20.0 * (-0.15f64).exp()),
        ],
    );
    // tau = 10 ms: half a period, crossing the offset with slope -2*omega*e^{-0.1}.
    assert!((s.value(0.02) - 1.0).abs() < 1e-14);
    let omega = 2.0 * PI * 50.0;
    assert!(close(s.derivative(0.02), -2.0 * omega * (-0.1f64).exp()));
    check_derivative(&s, &[0.0123, 0.0171, 0.0333]);
}

#[test]
fn sin_phase_holds_before_delay() {
    let s = SourceSpec::Sin {
        vo: 0.5,
        va: 1.0,
        freq: 1.0,
        td: 1.0,
        theta: 0.0,
        phase: 90.0,
    };
    check(
        &s,
        &[
            (0.0, 1.5, 0.0),
            (1.0, 1.5, 0.0),
            (1.25, 0.5, -2.0 * PI),
            (1.5, -0.5, 0.0),
        ],
    );
    check_derivative(&s, &[1.1, 1.7, 2.3]);
}

#[test]
fn pulse_rise_fall_and_period() {
    let p = SourceSpec::Pulse {
        v1: 1.0,
        v2: 5.0,
        td: 1.0,
        tr: 0.5,
        tf: 0.25,
        pw: 2.0,
        per: 4.0,
        np: 0.0,
    };
    check(
        &p,
        &[
            (0.0, 1.0, 0.0),
            (1.0, 1.0, 0.0),
            (1.25, 3.0, 8.0),
            (1.5, 5.0, 0.0),
            (2.5, 5.0, 0.0),
            (3.5, 5.0, 0.0),
            (3.625, 3.0, -16.0),
            (3.75, 1.0, 0.0),
            (4.5, 1.0, 0.0),
            (5.0, 1.0, 0.0),
            // Next periods.
            (5.25, 3.0, 8.0),
            (7.625, 3.0, -16.0),
            (9.25, 3.0, 8.0),
            (11.0, 5.0, 0.0),
            (12.0, 1.0, 0.0),
        ],
    );
    check_derivative(&p, &[1.1, 1.4, 3.6, 5.3, 7.7]);
}

#[test]
fn pulse_defaults_from_tran() {
    let p = SourceSpec::Pulse {
        v1: 0.0,
        v2: 1.0,
        td: 0.0,
        tr: 0.0,
        tf: 0.0,
        pw: 0.0,
        per: 0.0,
        np: 0.0,
    };
    let r = p.resolved(0.1, 10.0);
    assert_eq!(
        r,
        SourceSpec::Pulse {
            v1: 0.0,
            v2: 1.0,
            td: 0.0,
            tr: 0.1,
            tf: 0.1,
            pw: 10.0,
            per: 10.0,
            np: 0.0
        }
    );
    assert!(close(p.value_with_defaults(0.05, 0.1, 10.0), 0.5));
    assert!(close(p.derivative_with_defaults(0.05, 0.1, 10.0), 10.0));
    assert_eq!(p.value_with_defaults(5.0, 0.1, 10.0), 1.0);
    // Unresolved: ideal step, no repetition.
    assert_eq!(
        (p.value(0.0), p.value(1e-9), p.value(100.0)),
        (0.0, 0.0, 0.0)
    );
    let s = SourceSpec::Sin {
        vo: 0.0,
        va: 1.0,
        freq: 0.0,
        td: 0.0,
        theta: 0.0,
        phase: 0.0,
    };
    assert!(close(s.value_with_defaults(2.5, 0.1, 10.0), 1.0));
    assert!(matches!(s.resolved(0.1, 10.0), SourceSpec::Sin { freq, .. } if freq == 0.1));
}

#[test]
fn pwl_interpolates_and_holds() {
    let w = SourceSpec::pwl(vec![(0.0, 0.0), (1.0, 2.0), (3.0, -2.0)]);
    check(
        &w,
        &[
            (-1.0, 0.0, 0.0),
            (0.0, 0.0, 2.0),
            (0.5, 1.0, 2.0),
            (1.0, 2.0, 2.0),
            (2.0, 0.0, -2.0),
            (2.5, -1.0, -2.0),
            (3.0, -2.0, -2.0),
            (3.5, -2.0, 0.0),
            (1e6, -2.0, 0.0),
        ],
    );
    let late = SourceSpec::pwl(vec![(1.0, 5.0), (2.0, 7.0)]);
    check(&late, &[(0.0, 5.0, 0.0), (1.5, 6.0, 2.0), (9.0, 7.0, 0.0)]);
    // A repeated time is a jump: the old value up to it, the new one after.
    let step = SourceSpec::pwl(vec![(0.0, 0.0), (1.0, 0.0), (1.0, 3.0), (2.0, 3.0)]);
    check(&step, &[(1.0, 0.0, 0.0), (1.0 + 1e-9, 3.0, 0.0)]);
    assert_eq!(SourceSpec::pwl(vec![(1.0, 4.0)]).value(1.0), 4.0);
    assert_eq!(SourceSpec::Dc(3.0).value(7.0), 3.0);
    assert_eq!(SourceSpec::Dc(3.0).derivative(7.0), 0.0);
}
