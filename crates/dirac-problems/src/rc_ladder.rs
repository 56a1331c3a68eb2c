//! The SciMLBenchmarks "RC Circuit" ladder, benchmark scene F: a fully degenerate Lagrangian with
//! time constants from 1 s down to `1/n³` s.

use std::f64::consts::PI;

use dirac_components::{VoltageSource, Waveform};
use dirac_core::{ForceJacobian, LagrangianHessian, Model};
use dirac_graph::{GraphError, Interconnection, Subsystem};
use nalgebra::{DMatrix, DVector};

/// One section of the RC ladder on `q = (q_s, q_c)`: a series resistor carrying the branch charge
/// `q_s` and a shunt capacitor to ground with charge `q_c`. `L = −q_c²/(2C)`, `f = (−R v_s, 0)`:
/// no kinetic term at all. Ports: `series` (`q_s`) and `shunt` (`q_c`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RcSection {
    /// Series resistance.
    pub r: f64,
    /// Shunt capacitance.
    pub c: f64,
}

impl Model for RcSection {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], _v: &[f64]) -> f64 {
        -q[1] * q[1] / (2.0 * self.c)
    }
    fn lagrangian_gradient(&self, q: &[f64], _v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq[0] = 0.0;
        lq[1] = -q[1] / self.c;
        lv[0] = 0.0;
        lv[1] = 0.0;
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        h.qq.add(1, 1, -1.0 / self.c);
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -self.r * v[0];
        f[1] = 0.0;
    }
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, j: &mut ForceJacobian) {
        j.v.add(0, 0, -self.r);
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["qs", "qc"][i].to_string()
    }
}

/// The ladder of SciMLBenchmarks' `RCCircuit.jmd` (ModelingToolkitStandardLibrary parts): a
/// voltage source `V(t) = sin(2π·10·t)` drives `n` series resistors `R_i = 1/i`; node `i` (after
/// `R_i`) has a capacitor `C_i = 1/i²` to ground, charged to `v_i(0) = i`. `t ∈ [0, 10]`.
///
/// Node equations: `C_i v̇_i = (v_{i−1} − v_i)/R_i − (v_i − v_{i+1})/R_{i+1}` with `v_0 = V(t)` and
/// no `R_{n+1}`. The time constants `R_i C_i = 1/i³` reach 1e-9 s at `n = 1000`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RcLadder {
    /// Number of sections.
    pub n: usize,
}

/// Frequency of the source in Hz.
pub const RC_LADDER_FREQUENCY: f64 = 10.0;

impl RcLadder {
    /// `R_i = 1/i` (`i` from 1).
    #[must_use]
    pub fn resistance(i: usize) -> f64 {
        1.0 / i as f64
    }

    /// `C_i = 1/i²` (`i` from 1).
    #[must_use]
    pub fn capacitance(i: usize) -> f64 {
        1.0 / (i as f64 * i as f64)
    }

    /// The source voltage `sin(2π·10·t)`.
    #[must_use]
    pub fn source(t: f64) -> f64 {
        (2.0 * PI * RC_LADDER_FREQUENCY * t).sin()
    }

    /// Initial capacitor voltages `v_i(0) = i`.
    #[must_use]
    pub fn initial_voltages(&self) -> Vec<f64> {
        (1..=self.n).map(|i| i as f64).collect()
    }

    /// The circuit: source `V1` (`SIN(0 1 10)`), sections `S1 … Sn` ([`RcSection`]), KCL at nodes
    /// `n0 … nn` (`n0` the source's + terminal), as [`crate::rlc_ladder`] wires its sections.
    ///
    /// Coordinates in insertion order: the source's charge, then `(q_s, q_c)` of each section.
    ///
    /// # Errors
    /// Only if the graph rejects a port or a name, which would be a bug in this builder.
    pub fn graph(&self) -> Result<Interconnection, GraphError> {
        let n = self.n;
        let mut g = Interconnection::new();
        g.add_subsystem(
            VoltageSource::new(Waveform::sin(0.0, 1.0, RC_LADDER_FREQUENCY))?.subsystem("V1"),
        )?;
        for k in 1..=n {
            let section = RcSection {
                r: Self::resistance(k),
                c: Self::capacitance(k),
            };
            g.add_subsystem(
                Subsystem::new(format!("S{k}"), section)
                    .with_port("series", 0)
                    .with_port("shunt", 1),
            )?;
        }
        let src = g.port("V1", "i")?;
        g.node("n0", vec![(src, -1.0), (g.port("S1", "series")?, -1.0)])?;
        for k in 1..=n {
            let mut ports = vec![
                (g.port(&format!("S{k}"), "series")?, 1.0),
                (g.port(&format!("S{k}"), "shunt")?, -1.0),
            ];
            if k < n {
                ports.push((g.port(&format!("S{}", k + 1), "series")?, -1.0));
            }
            g.node(format!("n{k}"), ports)?;
        }
        Ok(g)
    }

    /// Initial coordinates in the layout of [`RcLadder::graph`]: `q_c,i = C_i v_i(0) = 1/i`, all
    /// other charges 0.
    #[must_use]
    pub fn initial_coordinates(&self) -> Vec<f64> {
        let mut q = vec![0.0; 1 + 2 * self.n];
        for i in 1..=self.n {
            q[2 * i] = Self::capacitance(i) * i as f64;
        }
        q
    }

    /// Capacitor voltages `q_c,i / C_i` from coordinates in the layout of [`RcLadder::graph`].
    #[must_use]
    pub fn voltages(&self, q: &[f64]) -> Vec<f64> {
        (1..=self.n)
            .map(|i| q[2 * i] / Self::capacitance(i))
            .collect()
    }

    /// The exact solution: modes and forcing of the linear system, computed once.
    ///
    /// With `w = C^{1/2} v` the node equations read `ẇ = −BᵀB w + g V(t)`, where
    /// `B = R^{−1/2} D C^{−1/2}` is lower bidiagonal (`D v` = the drops `v_i − v_{i−1}`, `v_0 = 0`)
    /// and `g = e₁/(R₁√C₁)`. The singular value decomposition `B = UΣVᵀ` gives the modes
    /// (`λ = σ²`, columns of `V`); as for [`crate::SpringChain::modes`], the singular values of
    /// `B` are more accurate in the slow modes than the eigenvalues of `BᵀB` (whose absolute
    /// error is `‖BᵀB‖ε ≈ 4e-7` at `n = 1000`).
    #[must_use]
    pub fn exact(&self) -> RcLadderExact {
        let n = self.n;
        let mut b = DMatrix::zeros(n, n);
        for k in 1..=n {
            let rs = Self::resistance(k).sqrt();
            b[(k - 1, k - 1)] = 1.0 / (rs * Self::capacitance(k).sqrt());
            if k > 1 {
                b[(k - 1, k - 2)] = -1.0 / (rs * Self::capacitance(k - 1).sqrt());
            }
        }
        let svd = b.svd(false, true);
        let v = svd.v_t.map(|vt| vt.transpose()).unwrap_or_default();
        let lambda: Vec<f64> = svd.singular_values.iter().map(|s| s * s).collect();
        let sqrt_c: Vec<f64> = (1..=n).map(|i| Self::capacitance(i).sqrt()).collect();
        let w0 = DVector::from_iterator(
            n,
            self.initial_voltages()
                .iter()
                .zip(&sqrt_c)
                .map(|(v, s)| v * s),
        );
        let x0 = v.transpose() * w0;
        let g = 1.0 / (Self::resistance(1) * sqrt_c[0]);
        let beta: Vec<f64> = v.row(0).iter().map(|vk| vk * g).collect();
        RcLadderExact {
            v,
            lambda,
            x0: x0.iter().copied().collect(),
            beta,
            sqrt_c,
        }
    }
}

/// The modal solution of an [`RcLadder`] ([`RcLadder::exact`]).
#[derive(Debug, Clone)]
pub struct RcLadderExact {
    v: DMatrix<f64>,
    lambda: Vec<f64>,
    x0: Vec<f64>,
    beta: Vec<f64>,
    sqrt_c: Vec<f64>,
}

impl RcLadderExact {
    /// Capacitor voltages at time `t`: each mode `ẋ = −λx + β sin ωt` in closed form,
    /// `x(t) = x₀e^{−λt} + β(λ sin ωt − ω cos ωt + ω e^{−λt})/(λ² + ω²)`.
    #[must_use]
    pub fn voltages(&self, t: f64) -> Vec<f64> {
        let w = 2.0 * PI * RC_LADDER_FREQUENCY;
        let (s, c) = (w * t).sin_cos();
        let x = DVector::from_iterator(
            self.lambda.len(),
            self.lambda
                .iter()
                .zip(&self.x0)
                .zip(&self.beta)
                .map(|((&l, &x0), &b)| {
                    let e = (-l * t).exp();
                    x0 * e + b * (l * s - w * c + w * e) / (l * l + w * w)
                }),
        );
        let wv = &self.v * x;
        wv.iter().zip(&self.sqrt_c).map(|(w, s)| w / s).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The modal solution solves the node equations: `v(0) = (1, 2, …, n)` and, at t = 0.3 (all
    /// modes faster than the source long decayed on n = 40), a central difference of `v` matches
    /// `C⁻¹(currents in − currents out)` node by node. Mutations: `l * s` → `1.001 * l * s` in
    /// `voltages` fails the residual at node 1 (4.6e-5 > 1e-6); dropping `+ w * e` fails `v₁(0)` by
    /// 1.6e-2.
    #[test]
    fn modal_solution_solves_the_node_equations() {
        /// `v(0)` is a product with an orthogonal matrix and its transpose: round-off of a
        /// 40-term sum of O(40) values.
        const INITIAL_TOL: f64 = 1e-10;
        /// Central difference with dt = 1e-5: truncation `ω³dt²/6 · |v| ≈ 4e-6·…`, relative to
        /// the node's largest current term; measured ~1e-8.
        const RESIDUAL_TOL: f64 = 1e-6;
        let ladder = RcLadder { n: 40 };
        let exact = ladder.exact();
        let v0 = exact.voltages(0.0);
        for (i, v) in v0.iter().enumerate() {
            assert!(
                (v - (i + 1) as f64).abs() < INITIAL_TOL,
                "v{}(0) = {v}",
                i + 1
            );
        }
        let (t, dt) = (0.3, 1e-5);
        let v = exact.voltages(t);
        let (vp, vm) = (exact.voltages(t + dt), exact.voltages(t - dt));
        for i in 1..=ladder.n {
            let prev = if i == 1 {
                RcLadder::source(t)
            } else {
                v[i - 2]
            };
            let inflow = (prev - v[i - 1]) / RcLadder::resistance(i);
            let outflow = if i < ladder.n {
                (v[i - 1] - v[i]) / RcLadder::resistance(i + 1)
            } else {
                0.0
            };
            let lhs = RcLadder::capacitance(i) * (vp[i - 1] - vm[i - 1]) / (2.0 * dt);
            let scale = inflow.abs().max(outflow.abs()).max(1.0);
            assert!(
                (lhs - (inflow - outflow)).abs() < RESIDUAL_TOL * scale,
                "node {i}: C dv/dt = {lhs}, net inflow {}",
                inflow - outflow
            );
        }
    }
}
