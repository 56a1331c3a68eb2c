//! The planar double pendulum in joint angles: the nonlinear benchmark D2.

use dirac_core::{GenericModel, LagrangianHessian, Model};
use num_dual::DualNum;

/// Double pendulum on the angles from the downward vertical, `q = (θ₁, θ₂)`:
/// `L = ½ a θ̇₁² + ½ b θ̇₂² + c θ̇₁θ̇₂ cos(θ₁ − θ₂) + d cos θ₁ + e cos θ₂` with
/// `a = (m₁+m₂)l₁²`, `b = m₂l₂²`, `c = m₂l₁l₂`, `d = (m₁+m₂)g l₁`, `e = m₂ g l₂`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoublePendulum {
    /// Upper bob mass.
    pub m1: f64,
    /// Lower bob mass.
    pub m2: f64,
    /// Upper rod length.
    pub l1: f64,
    /// Lower rod length.
    pub l2: f64,
    /// Gravity.
    pub g: f64,
}

/// The same pendulum written only as a generic `L` (derivatives by `AutoDiff`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoublePendulumGeneric(pub DoublePendulum);

impl DoublePendulum {
    /// The D2 benchmark: unit masses and lengths, `g = 9.81`.
    #[must_use]
    pub fn unit() -> Self {
        Self {
            m1: 1.0,
            m2: 1.0,
            l1: 1.0,
            l2: 1.0,
            g: 9.81,
        }
    }

    fn coefficients(&self) -> [f64; 5] {
        let m = self.m1 + self.m2;
        [
            m * self.l1 * self.l1,
            self.m2 * self.l2 * self.l2,
            self.m2 * self.l1 * self.l2,
            m * self.g * self.l1,
            self.m2 * self.g * self.l2,
        ]
    }

    /// Energy from angles and angular velocities, `T + V`.
    #[must_use]
    pub fn energy(&self, q: &[f64], w: &[f64]) -> f64 {
        let [a, b, c, d, e] = self.coefficients();
        0.5 * a * w[0] * w[0] + 0.5 * b * w[1] * w[1] + c * w[0] * w[1] * (q[0] - q[1]).cos()
            - d * q[0].cos()
            - e * q[1].cos()
    }

    /// Energy from angles and conjugate momenta `p = M(θ) θ̇`, `½ pᵀM⁻¹p + V`.
    #[must_use]
    pub fn hamiltonian(&self, q: &[f64], p: &[f64]) -> f64 {
        let w = self.velocity(q, p);
        self.energy(q, &w)
    }

    /// Angular velocities `M(θ)⁻¹ p` from momenta.
    #[must_use]
    pub fn velocity(&self, q: &[f64], p: &[f64]) -> [f64; 2] {
        let [a, b, c, _, _] = self.coefficients();
        let m12 = c * (q[0] - q[1]).cos();
        let det = a * b - m12 * m12;
        [(b * p[0] - m12 * p[1]) / det, (a * p[1] - m12 * p[0]) / det]
    }
}

impl Model for DoublePendulum {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        let [a, b, c, d, e] = self.coefficients();
        0.5 * a * v[0] * v[0]
            + 0.5 * b * v[1] * v[1]
            + c * v[0] * v[1] * (q[0] - q[1]).cos()
            + d * q[0].cos()
            + e * q[1].cos()
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let [a, b, c, d, e] = self.coefficients();
        let (s, co) = (q[0] - q[1]).sin_cos();
        let cvv = c * v[0] * v[1] * s;
        lq[0] = -cvv - d * q[0].sin();
        lq[1] = cvv - e * q[1].sin();
        lv[0] = a * v[0] + c * v[1] * co;
        lv[1] = b * v[1] + c * v[0] * co;
    }
    fn lagrangian_hessian(&self, q: &[f64], v: &[f64], h: &mut LagrangianHessian) {
        let [a, b, c, d, e] = self.coefficients();
        let (s, co) = (q[0] - q[1]).sin_cos();
        let cvv = c * v[0] * v[1] * co;
        h.qq.add(0, 0, -cvv - d * q[0].cos());
        h.qq.add(0, 1, cvv);
        h.qq.add(1, 0, cvv);
        h.qq.add(1, 1, -cvv - e * q[1].cos());
        // Row: q index, column: v index; ∂²L/∂qᵢ∂vⱼ.
        h.qv.add(0, 0, -c * v[1] * s);
        h.qv.add(0, 1, -c * v[0] * s);
        h.qv.add(1, 0, c * v[1] * s);
        h.qv.add(1, 1, c * v[0] * s);
        h.vv.add(0, 0, a);
        h.vv.add(0, 1, c * co);
        h.vv.add(1, 0, c * co);
        h.vv.add(1, 1, b);
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["theta1", "theta2"][i].to_string()
    }
}

impl GenericModel<2> for DoublePendulumGeneric {
    fn lagrangian<D: DualNum<Primitive = f64> + Copy>(&self, q: &[D; 2], v: &[D; 2]) -> D {
        let [a, b, c, d, e] = self.0.coefficients();
        v[0] * v[0] * (0.5 * a)
            + v[1] * v[1] * (0.5 * b)
            + v[0] * v[1] * (q[0] - q[1]).cos() * c
            + q[0].cos() * d
            + q[1].cos() * e
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

    /// Hand-written gradient and Hessian blocks equal the dual-number derivatives of `L`.
    #[test]
    fn hand_written_derivatives_match_automatic_ones() {
        let hand = DoublePendulum {
            m1: 1.3,
            m2: 0.7,
            l1: 0.9,
            l2: 1.4,
            g: 9.81,
        };
        let auto = AutoDiff::new(DoublePendulumGeneric(hand));
        for (q, v) in [([1.0, 0.5], [0.3, -2.0]), ([-2.1, 0.4], [1.7, 0.9])] {
            let (mut a, mut b, mut c, mut d) = ([0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2]);
            hand.lagrangian_gradient(&q, &v, &mut a, &mut b);
            auto.lagrangian_gradient(&q, &v, &mut c, &mut d);
            for i in 0..2 {
                assert!((a[i] - c[i]).abs() < 1e-12 && (b[i] - d[i]).abs() < 1e-12);
            }
            let (mut hh, mut ha) = (LagrangianHessian::default(), LagrangianHessian::default());
            hand.lagrangian_hessian(&q, &v, &mut hh);
            auto.lagrangian_hessian(&q, &v, &mut ha);
            for (x, y) in [(&hh.qq, &ha.qq), (&hh.qv, &ha.qv), (&hh.vv, &ha.vv)] {
                let (x, y) = (dense(x), dense(y));
                for i in 0..2 {
                    for j in 0..2 {
                        assert!((x[i][j] - y[i][j]).abs() < 1e-12, "{x:?} vs {y:?}");
                    }
                }
            }
        }
    }

    /// The Hamiltonian from momenta `p = ∂L/∂v` equals the energy from velocities.
    #[test]
    fn hamiltonian_matches_energy() {
        let pend = DoublePendulum::unit();
        let (q, v) = ([1.0, 0.5], [0.8, -1.1]);
        let (mut lq, mut p) = ([0.0; 2], [0.0; 2]);
        pend.lagrangian_gradient(&q, &v, &mut lq, &mut p);
        assert!((pend.hamiltonian(&q, &p) - pend.energy(&q, &v)).abs() < 1e-13);
        let e0 = pend.energy(&[1.0, 0.5], &[0.0, 0.0]);
        assert!((e0 + 19.209_816_173_277_46).abs() < 1e-12);
    }
}
