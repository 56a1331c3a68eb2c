//! The scenes of bench/SCENES.md as first-order systems `y' = f(t, y)` in Rust (for diffsol and
//! the Gauss–Legendre peer; the C peers have the same right-hand sides in c/scenes.c), with the
//! error measures and references.

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector};

/// A benchmark scene; the discriminant is the C `enum scene_id` (c/peers.h).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    A = 0,
    B = 1,
    D1 = 2,
    D2 = 3,
    E = 4,
    F = 5,
    C = 6,
}

/// θ₁(10⁴) of the double pendulum (D2-long), see bench/SCENES.md for how it was obtained.
pub const D2_LONG_THETA1: f64 = -0.147_651_889_63;

/// One scene instance: label, kind, size, interval and initial state.
#[derive(Debug, Clone)]
pub struct Scene {
    pub label: String,
    pub kind: Kind,
    pub n: usize,
    pub t_end: f64,
    pub y0: Vec<f64>,
    d1_springs: Vec<f64>,
    d1_modes: Option<(Vec<f64>, DMatrix<f64>)>,
    reference: Option<Vec<f64>>,
}

/// What a scene reports for one trajectory: `(error, energy_error)`.
pub type Score = (f64, f64);

/// Double pendulum: energy from `(θ, ω)` and the accelerations.
fn d2_energy(y: &[f64]) -> f64 {
    let (th1, th2, w1, w2) = (y[0], y[1], y[2], y[3]);
    0.5 * 2.0 * w1 * w1 + 0.5 * w2 * w2 + w1 * w2 * (th1 - th2).cos()
        - 2.0 * 9.81 * th1.cos()
        - 9.81 * th2.cos()
}

fn hh_energy(y: &[f64]) -> f64 {
    let (q1, q2, p1, p2) = (y[0], y[1], y[2], y[3]);
    0.5 * (p1 * p1 + p2 * p2) + 0.5 * (q1 * q1 + q2 * q2) + q1 * q1 * q2 - q2 * q2 * q2 / 3.0
}

const RLC: (f64, f64, f64) = (0.75, 3.0, 0.1); // L, C, R of scene A
const OSC_C: f64 = 0.01;

fn oscillator_period() -> f64 {
    let g = OSC_C / 2.0;
    2.0 * PI / (1.0 - g * g).sqrt()
}

impl Scene {
    /// The scene named `label` (`A`, `B`, `D1`, `D2`, `D2-long`, `E`, `F`, `C-<N>`); `n` is
    /// the size of F (sections).
    pub fn new(label: &str, n_f: usize) -> Option<Self> {
        let mut s = Scene {
            label: label.to_string(),
            kind: Kind::A,
            n: 0,
            t_end: 0.0,
            y0: Vec::new(),
            d1_springs: Vec::new(),
            d1_modes: None,
            reference: None,
        };
        match label {
            "A" => {
                s.t_end = 50.0;
                s.y0 = vec![1.0, 0.0];
            }
            "B" => {
                s.kind = Kind::B;
                s.t_end = 5.0 * oscillator_period();
                s.y0 = vec![1.0, 0.0];
            }
            "D1" => {
                s.kind = Kind::D1;
                s.t_end = 10.0;
                let mut y0 = vec![0.0; 20];
                y0[0] = 1.0;
                y0[1] = 1.001;
                s.y0 = y0;
                s.d1_springs = (0..=10)
                    .map(|i| if i % 2 == 0 { 1.0 } else { 1e6 })
                    .collect();
                s.d1_modes = Some(d1_modes(&s.d1_springs));
            }
            "D2" | "D2-long" => {
                s.kind = Kind::D2;
                s.t_end = if label == "D2" { 100.0 } else { 1e4 };
                s.y0 = vec![1.0, 0.5, 0.0, 0.0];
            }
            "E" => {
                s.kind = Kind::E;
                s.t_end = 1e4;
                s.y0 = vec![0.1, 0.0, 0.0, 0.5];
            }
            "F" => {
                s.kind = Kind::F;
                s.n = n_f;
                s.t_end = 10.0;
                s.y0 = (1..=n_f).map(|i| i as f64).collect();
                s.reference = Some(rc_ladder_exact(n_f, 10.0));
            }
            _ => {
                let n: usize = label.strip_prefix("Cacc-")?.parse().ok()?;
                s.kind = Kind::C;
                s.n = n;
                s.t_end = 10.0;
                s.y0 = vec![0.0; 2 * n];
            }
        }
        Some(s)
    }

    pub fn dim(&self) -> usize {
        self.y0.len()
    }

    /// Whether the scene is separable (`y = (q, p)`, unit masses, position-dependent force).
    pub fn separable(&self) -> bool {
        matches!(self.kind, Kind::D1 | Kind::E)
    }

    /// Whether every recorded point is needed to score a run (max over produced points).
    pub fn needs_every_point(&self) -> bool {
        matches!(self.kind, Kind::A | Kind::D1 | Kind::D2 | Kind::E)
    }

    /// Whether the energy's running maximum per tenth of the interval is reported (D2-long, E).
    pub fn long_run(&self) -> bool {
        self.t_end >= 1e4
    }

    /// Sets the reference final state (scene C at size N: from a tight run of a peer).
    pub fn set_reference(&mut self, y: Vec<f64>) {
        self.reference = Some(y);
    }

    /// `f(t, y)`.
    pub fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        match self.kind {
            Kind::A => {
                let (l, c, r) = RLC;
                dy[0] = y[1];
                dy[1] = (-r * y[1] - y[0] / c) / l;
            }
            Kind::B => {
                dy[0] = y[1];
                dy[1] = -y[0] - OSC_C * y[1];
            }
            Kind::D1 => {
                let k = &self.d1_springs;
                dy[..10].copy_from_slice(&y[10..]);
                for i in 0..10 {
                    let left = if i > 0 { y[i] - y[i - 1] } else { y[i] };
                    let right = if i < 9 { y[i + 1] - y[i] } else { -y[i] };
                    dy[10 + i] = -k[i] * left + k[i + 1] * right;
                }
            }
            Kind::D2 => {
                let (a1, a2) = d2_accel(y);
                dy[0] = y[2];
                dy[1] = y[3];
                dy[2] = a1;
                dy[3] = a2;
            }
            Kind::E => {
                let (q1, q2) = (y[0], y[1]);
                dy[0] = y[2];
                dy[1] = y[3];
                dy[2] = -q1 * (1.0 + 2.0 * q2);
                dy[3] = -q2 - (q1 * q1 - q2 * q2);
            }
            Kind::F => {
                let n = self.n;
                let mut prev = (2.0 * PI * 10.0 * t).sin();
                for i in 0..n {
                    let r = 1.0 / (i + 1) as f64;
                    let c = r * r;
                    let inflow = (prev - y[i]) / r;
                    let outflow = if i + 1 < n {
                        (y[i] - y[i + 1]) * (i + 2) as f64
                    } else {
                        0.0
                    };
                    dy[i] = (inflow - outflow) / c;
                    prev = y[i];
                }
            }
            Kind::C => {
                let n = self.n;
                let mut prev = 1.0;
                for k in 0..n {
                    let (i, v) = (y[2 * k], y[2 * k + 1]);
                    let inext = if k + 1 < n { y[2 * k + 2] } else { 0.0 };
                    dy[2 * k] = prev - v - 0.1 * i;
                    dy[2 * k + 1] = i - inext;
                    prev = v;
                }
            }
        }
    }

    /// `J(t, y) v` with the analytic Jacobian.
    pub fn jac_mul(&self, t: f64, y: &[f64], v: &[f64], out: &mut [f64]) {
        match self.kind {
            Kind::A | Kind::B | Kind::D1 => {
                // Linear and homogeneous: J v = f(v).
                self.rhs(t, v, out);
            }
            Kind::D2 => {
                let j = d2_jacobian(y);
                for (r, o) in out.iter_mut().enumerate() {
                    *o = (0..4).map(|c| j[r][c] * v[c]).sum();
                }
            }
            Kind::E => {
                let (q1, q2) = (y[0], y[1]);
                out[0] = v[2];
                out[1] = v[3];
                out[2] = -(1.0 + 2.0 * q2) * v[0] - 2.0 * q1 * v[1];
                out[3] = -2.0 * q1 * v[0] - (1.0 - 2.0 * q2) * v[1];
            }
            Kind::F => {
                let n = self.n;
                for i in 0..n {
                    let g_in = (i + 1) as f64;
                    let c = 1.0 / (g_in * g_in);
                    let mut s = -g_in * v[i];
                    if i > 0 {
                        s += g_in * v[i - 1];
                    }
                    if i + 1 < n {
                        let g_out = (i + 2) as f64;
                        s -= g_out * (v[i] - v[i + 1]);
                    }
                    out[i] = s / c;
                }
            }
            Kind::C => {
                let n = self.n;
                let mut prev = 0.0;
                for k in 0..n {
                    let (i, vv) = (v[2 * k], v[2 * k + 1]);
                    let inext = if k + 1 < n { v[2 * k + 2] } else { 0.0 };
                    out[2 * k] = prev - vv - 0.1 * i;
                    out[2 * k + 1] = i - inext;
                    prev = vv;
                }
            }
        }
    }

    /// Scores a trajectory: times `t` and states `y` (row by row), as SCENES.md defines.
    pub fn score(&self, t: &[f64], y: &[f64]) -> Score {
        let d = self.dim();
        let last = &y[y.len() - d..];
        match self.kind {
            Kind::A => {
                let (l, c, r) = RLC;
                let g = r / (2.0 * l);
                let wd = (1.0 / (l * c) - g * g).sqrt();
                let e = t
                    .iter()
                    .zip(y.chunks_exact(d))
                    .map(|(&t, x)| {
                        let q = (-g * t).exp() * ((wd * t).cos() + g / wd * (wd * t).sin());
                        (x[0] - q).abs()
                    })
                    .fold(0.0, f64::max);
                (e, f64::NAN)
            }
            Kind::B => {
                let g = OSC_C / 2.0;
                let wd = (1.0 - g * g).sqrt();
                let te = *t.last().unwrap_or(&0.0);
                let e = (-g * te).exp();
                let q = e * ((wd * te).cos() + g / wd * (wd * te).sin());
                let p = -e * (wd * wd + g * g) / wd * (wd * te).sin();
                ((last[0] - q).abs().max((last[1] - p).abs()), f64::NAN)
            }
            Kind::D1 => {
                let (omega, v) = self.d1_modes.as_ref().expect("D1 modes");
                let h0 = self.d1_energy(&self.y0);
                let energy = y
                    .chunks_exact(d)
                    .map(|x| ((self.d1_energy(x) - h0) / h0).abs())
                    .fold(0.0, f64::max);
                let te = *t.last().unwrap_or(&0.0);
                let x0 = DVector::from_column_slice(&self.y0[..10]);
                let a = v.transpose() * x0;
                let xe =
                    v * DVector::from_iterator(10, (0..10).map(|i| (omega[i] * te).cos() * a[i]));
                let pe = v * DVector::from_iterator(
                    10,
                    (0..10).map(|i| -omega[i] * (omega[i] * te).sin() * a[i]),
                );
                let vs = v.columns(0, 5);
                let dx = DVector::from_column_slice(&last[..10]) - xe;
                let dp = DVector::from_column_slice(&last[10..]) - pe;
                let slow = (vs.transpose() * dx)
                    .amax()
                    .max((vs.transpose() * dp).amax());
                (slow, energy)
            }
            Kind::D2 => {
                let e0 = d2_energy(&self.y0);
                let energy = y
                    .chunks_exact(d)
                    .map(|x| (d2_energy(x) - e0).abs())
                    .fold(0.0, f64::max);
                if self.long_run() {
                    ((last[0] - D2_LONG_THETA1).abs(), energy)
                } else {
                    (energy, energy)
                }
            }
            Kind::E => {
                let e0 = hh_energy(&self.y0);
                let energy = y
                    .chunks_exact(d)
                    .map(|x| (hh_energy(x) - e0).abs())
                    .fold(0.0, f64::max);
                (energy, energy)
            }
            Kind::F | Kind::C => {
                let reference = self.reference.as_ref().expect("reference");
                let voltages: Vec<f64> = if self.kind == Kind::F {
                    last.to_vec()
                } else {
                    last.iter().skip(1).step_by(2).copied().collect()
                };
                let e = voltages
                    .iter()
                    .zip(reference)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                (e, f64::NAN)
            }
        }
    }

    /// Running maximum of the energy error at the end of each tenth of the interval (long runs).
    pub fn tenths(&self, t: &[f64], y: &[f64]) -> Vec<f64> {
        let d = self.dim();
        let energy: fn(&[f64]) -> f64 = if self.kind == Kind::E {
            hh_energy
        } else {
            d2_energy
        };
        let e0 = energy(&self.y0);
        let mut out = vec![0.0; 10];
        let mut running: f64 = 0.0;
        let mut tenth = 0;
        for (&tk, x) in t.iter().zip(y.chunks_exact(d)) {
            while tenth < 9 && tk > self.t_end * (tenth + 1) as f64 / 10.0 * (1.0 + 1e-12) {
                out[tenth] = running;
                tenth += 1;
            }
            running = running.max((energy(x) - e0).abs());
        }
        for o in out.iter_mut().skip(tenth) {
            *o = running;
        }
        out
    }

    fn d1_energy(&self, y: &[f64]) -> f64 {
        let k = &self.d1_springs;
        let mut e = 0.5 * y[10..].iter().map(|p| p * p).sum::<f64>();
        for i in 0..=10 {
            let left = if i > 0 { y[i - 1] } else { 0.0 };
            let right = if i < 10 { y[i] } else { 0.0 };
            e += 0.5 * k[i] * (right - left) * (right - left);
        }
        e
    }
}

fn d2_accel(y: &[f64]) -> (f64, f64) {
    let (th1, th2, w1, w2) = (y[0], y[1], y[2], y[3]);
    let (sd, cd) = (th1 - th2).sin_cos();
    let (m11, m12, m22) = (2.0, cd, 1.0);
    let f1 = -w2 * w2 * sd - 2.0 * 9.81 * th1.sin();
    let f2 = w1 * w1 * sd - 9.81 * th2.sin();
    let det = m11 * m22 - m12 * m12;
    ((m22 * f1 - m12 * f2) / det, (m11 * f2 - m12 * f1) / det)
}

/// `∂f/∂y` of the double pendulum (as bench/peers/peers.py `SceneD2.jac_fn`).
fn d2_jacobian(y: &[f64]) -> [[f64; 4]; 4] {
    let (th1, th2, w1, w2) = (y[0], y[1], y[2], y[3]);
    let g = 9.81;
    let (sd, cd) = (th1 - th2).sin_cos();
    let (m11, m12, m22) = (2.0, cd, 1.0);
    let (a1, a2) = d2_accel(y);
    let df = [
        [
            -w2 * w2 * cd - 2.0 * g * th1.cos(),
            w2 * w2 * cd,
            0.0,
            -2.0 * w2 * sd,
        ],
        [
            w1 * w1 * cd,
            -w1 * w1 * cd - g * th2.cos(),
            2.0 * w1 * sd,
            0.0,
        ],
    ];
    let s = -sd;
    let mut rhs = df;
    rhs[0][0] -= s * a2;
    rhs[1][0] -= s * a1;
    rhs[0][1] += s * a2;
    rhs[1][1] += s * a1;
    let det = m11 * m22 - m12 * m12;
    let inv = [[m22 / det, -m12 / det], [-m12 / det, m11 / det]];
    let mut j = [[0.0; 4]; 4];
    j[0][2] = 1.0;
    j[1][3] = 1.0;
    for r in 0..2 {
        for c in 0..4 {
            j[2 + r][c] = inv[r][0] * rhs[0][c] + inv[r][1] * rhs[1][c];
        }
    }
    j
}

/// D1 normal modes from the SVD of `G = diag(√k)·D` (slowest first), as peers.py.
fn d1_modes(k: &[f64]) -> (Vec<f64>, DMatrix<f64>) {
    let mut g = DMatrix::zeros(11, 10);
    for (i, ki) in k.iter().enumerate() {
        let s = ki.sqrt();
        if i >= 1 {
            g[(i, i - 1)] = -s;
        }
        if i < 10 {
            g[(i, i)] = s;
        }
    }
    let svd = g.svd(false, true);
    let vt = svd.v_t.expect("v_t requested");
    let mut order: Vec<usize> = (0..10).collect();
    order.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
    let omega = order.iter().map(|&i| svd.singular_values[i]).collect();
    let cols: Vec<_> = order.iter().map(|&i| vt.row(i).transpose()).collect();
    (omega, DMatrix::from_columns(&cols))
}

/// The RC ladder's capacitor voltages at `t` from its modes (the same construction as
/// `dirac_problems::RcLadder::exact`, written again here so the peers do not depend on dirac):
/// `w = C^{1/2} v`, `ẇ = −BᵀB w + g sin ωt`, `B = R^{−1/2} D C^{−1/2}`, modes from the SVD of `B`.
pub fn rc_ladder_exact(n: usize, t: f64) -> Vec<f64> {
    let mut b = DMatrix::zeros(n, n);
    for k in 1..=n {
        let rs = (1.0 / k as f64).sqrt();
        b[(k - 1, k - 1)] = k as f64 / rs;
        if k > 1 {
            b[(k - 1, k - 2)] = -((k - 1) as f64) / rs;
        }
    }
    let svd = b.svd(false, true);
    let v = svd.v_t.expect("v_t requested").transpose();
    let sqrt_c: Vec<f64> = (1..=n).map(|i| 1.0 / i as f64).collect();
    let w0 = DVector::from_iterator(n, (1..=n).map(|i| i as f64 * sqrt_c[i - 1]));
    let x0 = v.transpose() * w0;
    let w = 2.0 * PI * 10.0;
    let (s, c) = (w * t).sin_cos();
    let x = DVector::from_iterator(
        n,
        (0..n).map(|k| {
            let l = svd.singular_values[k] * svd.singular_values[k];
            let beta = v[(0, k)]; // g = 1/(R₁√C₁) = 1
            let e = (-l * t).exp();
            x0[k] * e + beta * (l * s - w * c + w * e) / (l * l + w * w)
        }),
    );
    let wv = &v * x;
    wv.iter().zip(&sqrt_c).map(|(w, s)| w / s).collect()
}
