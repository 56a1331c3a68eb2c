//! The Hénon–Heiles system: a separable two-degree-of-freedom Hamiltonian, benchmark scene E.

use dirac_core::{GenericModel, LagrangianHessian, Model, Triplets};
use num_dual::DualNum;

/// Hénon–Heiles, `L = ½|v|² − V(q)` with
/// `V = ½(q₁² + q₂²) + q₁²q₂ − q₂³/3` (unit mass, so `p = v`).
///
/// Separable (constant mass matrix, position-dependent potential only), so the trapezoid
/// discrete Lagrangian gives Störmer–Verlet; energy `H = ½|p|² + V(q)` is conserved by the flow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HenonHeiles;

/// The same system written only as a generic `L` (derivatives by `AutoDiff`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HenonHeilesGeneric;

impl HenonHeiles {
    /// The initial state of the SciMLBenchmarks "Hénon–Heiles Energy Conservation" notebook:
    /// `q = (0.1, 0)`, `p = (0, 0.5)`, so `H₀ = 0.13` (below the escape energy 1/6).
    pub const Q0: [f64; 2] = [0.1, 0.0];
    /// Initial momenta of [`HenonHeiles::Q0`].
    pub const P0: [f64; 2] = [0.0, 0.5];

    /// Potential `V(q)`.
    #[must_use]
    pub fn potential(q: &[f64]) -> f64 {
        0.5 * (q[0] * q[0] + q[1] * q[1]) + q[0] * q[0] * q[1] - q[1] * q[1] * q[1] / 3.0
    }

    /// Energy `½|p|² + V(q)`.
    #[must_use]
    pub fn hamiltonian(q: &[f64], p: &[f64]) -> f64 {
        0.5 * (p[0] * p[0] + p[1] * p[1]) + Self::potential(q)
    }

    /// Force `−∇V(q)`.
    #[must_use]
    pub fn force(q: &[f64]) -> [f64; 2] {
        [
            -q[0] * (1.0 + 2.0 * q[1]),
            -q[1] - (q[0] * q[0] - q[1] * q[1]),
        ]
    }
}

impl Model for HenonHeiles {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * (v[0] * v[0] + v[1] * v[1]) - Self::potential(q)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let f = Self::force(q);
        lq[0] = f[0];
        lq[1] = f[1];
        lv[0] = v[0];
        lv[1] = v[1];
    }
    fn lagrangian_hessian(&self, q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        // ∂²L/∂q² = −∇²V.
        h.qq.add(0, 0, -(1.0 + 2.0 * q[1]));
        h.qq.add(0, 1, -2.0 * q[0]);
        h.qq.add(1, 0, -2.0 * q[0]);
        h.qq.add(1, 1, -(1.0 - 2.0 * q[1]));
        h.vv.add(0, 0, 1.0);
        h.vv.add(1, 1, 1.0);
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q1", "q2"][i].to_string()
    }
    /// Separable: `M = I`, a position-dependent potential, no force (Störmer–Verlet applies).
    fn separable(&self) -> Option<Triplets> {
        let mut mass = Triplets::new();
        mass.add(0, 0, 1.0);
        mass.add(1, 1, 1.0);
        Some(mass)
    }
}

impl GenericModel<2> for HenonHeilesGeneric {
    fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 2], v: &[D; 2]) -> D {
        (v[0] * v[0] + v[1] * v[1]) * 0.5 - (q[0] * q[0] + q[1] * q[1]) * 0.5 - q[0] * q[0] * q[1]
            + q[1] * q[1] * q[1] * (1.0 / 3.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dirac_core::{AutoDiff, Triplets};

    fn dense(t: &Triplets) -> [[f64; 2]; 2] {
        let mut m = [[0.0; 2]; 2];
        for (r, c, v) in t.iter() {
            m[r][c] += v;
        }
        m
    }

    /// The hand-written gradient and Hessian of `L` equal the dual-number derivatives of the
    /// generic twin at an arbitrary state, and `H₀ = 0.13` at the SciMLBenchmarks initial state
    /// (`½·0.5² + ½·0.1²`). Mutation: `+ 2.0 * q[1]` → `+ 2.01 * q[1]` in `force` fails the
    /// gradient comparison (lq₀ off by 8.4e-4).
    #[test]
    fn hand_written_derivatives_match_automatic_ones() {
        /// Both sides are exact to a few ulps of O(1) values.
        const TOL: f64 = 1e-14;
        let q = [0.31, -0.27];
        let v = [0.4, 0.13];
        let (mut lq, mut lv) = ([0.0; 2], [0.0; 2]);
        HenonHeiles.lagrangian_gradient(&q, &v, &mut lq, &mut lv);
        let auto = AutoDiff::new(HenonHeilesGeneric);
        let (mut aq, mut av) = ([0.0; 2], [0.0; 2]);
        auto.lagrangian_gradient(&q, &v, &mut aq, &mut av);
        for i in 0..2 {
            assert!(
                (lq[i] - aq[i]).abs() < TOL,
                "lq[{i}] {} vs {}",
                lq[i],
                aq[i]
            );
            assert!((lv[i] - av[i]).abs() < TOL, "lv[{i}]");
        }
        let (mut h, mut a) = (LagrangianHessian::default(), LagrangianHessian::default());
        HenonHeiles.lagrangian_hessian(&q, &v, &mut h);
        auto.lagrangian_hessian(&q, &v, &mut a);
        for (x, y) in [(&h.qq, &a.qq), (&h.vv, &a.vv), (&h.qv, &a.qv)] {
            let (x, y) = (dense(x), dense(y));
            for r in 0..2 {
                for c in 0..2 {
                    assert!((x[r][c] - y[r][c]).abs() < TOL, "hessian ({r},{c})");
                }
            }
        }
        let h0 = HenonHeiles::hamiltonian(&HenonHeiles::Q0, &HenonHeiles::P0);
        assert!((h0 - 0.13).abs() < TOL, "H0 = {h0}");
    }
}
