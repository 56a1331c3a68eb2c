//! A chain of unit masses between two walls joined by springs: the stiff benchmark D1.

use dirac_core::{LagrangianHessian, Model};
use nalgebra::{DMatrix, DVector};

/// `n` unit masses on a line between two walls, `L = ½|v|² − ½ Σᵢ kᵢ (x_{i+1} − x_i)²` with
/// `x_0 = x_{n+1} = 0` (the walls) and `n + 1` spring constants.
///
/// With alternating soft and stiff springs this is the classic test of integrators on highly
/// oscillatory problems: the fast modes have periods far below any step one would like to take.
#[derive(Debug, Clone, PartialEq)]
pub struct SpringChain {
    /// Spring constants `k_0 … k_n`; `k_0` ties the first mass to the left wall.
    pub k: Vec<f64>,
}

impl SpringChain {
    /// The D1 benchmark chain: ten masses, springs alternating 1 (walls and between pairs) and
    /// `stiff` (inside each of the five pairs).
    #[must_use]
    pub fn alternating(masses: usize, stiff: f64) -> Self {
        Self {
            k: (0..=masses)
                .map(|i| if i % 2 == 0 { 1.0 } else { stiff })
                .collect(),
        }
    }

    /// Number of masses.
    #[must_use]
    pub fn masses(&self) -> usize {
        self.k.len() - 1
    }

    /// The stiffness matrix `K` with `V = ½ xᵀ K x`.
    #[must_use]
    pub fn stiffness(&self) -> DMatrix<f64> {
        let n = self.masses();
        let mut k = DMatrix::zeros(n, n);
        for (i, &ki) in self.k.iter().enumerate() {
            // Spring i joins mass i−1 (left, if any) and mass i (right, if any).
            if i >= 1 {
                k[(i - 1, i - 1)] += ki;
            }
            if i < n {
                k[(i, i)] += ki;
            }
            if i >= 1 && i < n {
                k[(i - 1, i)] -= ki;
                k[(i, i - 1)] -= ki;
            }
        }
        k
    }

    /// Total energy `½|p|² + ½ Σ kᵢ (x_{i+1} − x_i)²`.
    #[must_use]
    pub fn energy(&self, q: &[f64], p: &[f64]) -> f64 {
        0.5 * p.iter().map(|x| x * x).sum::<f64>() + self.potential(q)
    }

    fn potential(&self, q: &[f64]) -> f64 {
        let n = self.masses();
        let at = |i: usize| if i == 0 || i > n { 0.0 } else { q[i - 1] };
        self.k
            .iter()
            .enumerate()
            .map(|(i, ki)| {
                let d = at(i + 1) - at(i);
                0.5 * ki * d * d
            })
            .sum()
    }

    /// The spring-difference matrix `G = diag(√k) D` (one row per spring) with `K = GᵀG`.
    fn spring_matrix(&self) -> DMatrix<f64> {
        let n = self.masses();
        let mut g = DMatrix::zeros(n + 1, n);
        for (i, &ki) in self.k.iter().enumerate() {
            let s = ki.sqrt();
            if i >= 1 {
                g[(i, i - 1)] = -s;
            }
            if i < n {
                g[(i, i)] = s;
            }
        }
        g
    }

    /// Normal modes, slowest first: angular frequencies `ω` and the orthonormal mode shapes as
    /// the columns of a matrix.
    ///
    /// They come from the singular value decomposition of `G` (`ωᵢ = σᵢ(G)`), not from the
    /// eigen-decomposition of `K = GᵀG`: with springs of 1 and 10⁶ the latter carries an absolute
    /// error of `‖K‖ε ≈ 2e-10` in every eigenvalue, 3e-9 relative in the slowest one, while the
    /// singular values of `G` are good to ~1e-12 relative (checked against a 40-digit
    /// eigen-decomposition).
    #[must_use]
    pub fn modes(&self) -> (Vec<f64>, DMatrix<f64>) {
        let svd = self.spring_matrix().svd(false, true);
        let Some(v_t) = svd.v_t else {
            return (Vec::new(), DMatrix::zeros(0, 0));
        };
        let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
        order.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
        let omegas = order.iter().map(|&i| svd.singular_values[i]).collect();
        let columns: Vec<_> = order.iter().map(|&i| v_t.row(i).transpose()).collect();
        (omegas, DMatrix::from_columns(&columns))
    }

    /// The largest angular frequency `√λ_max(K)`.
    #[must_use]
    pub fn fastest_frequency(&self) -> f64 {
        self.modes().0.last().copied().unwrap_or(0.0)
    }

    /// The `count` slowest normal modes as the columns of an orthonormal matrix.
    #[must_use]
    pub fn slow_modes(&self, count: usize) -> DMatrix<f64> {
        let (_, shapes) = self.modes();
        shapes.columns(0, count.min(shapes.ncols())).into_owned()
    }

    /// Exact `(x(t), p(t))` from `(x0, p0)` at `t = 0` in normal modes ([`SpringChain::modes`]):
    /// `x(t) = V (cos Ωt Vᵀx₀ + Ω⁻¹ sin Ωt Vᵀp₀)`, `p(t) = V (−Ω sin Ωt Vᵀx₀ + cos Ωt Vᵀp₀)`.
    ///
    /// # Panics
    /// If `x0` or `p0` does not have one entry per mass, or `K` is singular (a chain with a
    /// free end and no wall).
    #[must_use]
    pub fn exact(&self, x0: &[f64], p0: &[f64], t: f64) -> (Vec<f64>, Vec<f64>) {
        let (omegas, v) = self.modes();
        let a = v.transpose() * DVector::from_column_slice(x0);
        let b = v.transpose() * DVector::from_column_slice(p0);
        let (mut ax, mut ap) = (a.clone(), b.clone());
        for (i, &w) in omegas.iter().enumerate() {
            assert!(w > 0.0, "singular stiffness matrix");
            let (s, c) = (w * t).sin_cos();
            ax[i] = c * a[i] + s / w * b[i];
            ap[i] = -w * s * a[i] + c * b[i];
        }
        ((&v * ax).as_slice().to_vec(), (&v * ap).as_slice().to_vec())
    }
}

impl Model for SpringChain {
    fn dim(&self) -> usize {
        self.masses()
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        0.5 * v.iter().map(|x| x * x).sum::<f64>() - self.potential(q)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let n = self.masses();
        lv.copy_from_slice(v);
        let at = |i: usize| if i == 0 || i > n { 0.0 } else { q[i - 1] };
        lq.fill(0.0);
        for (i, ki) in self.k.iter().enumerate() {
            // Spring i stretches by x_{i+1} − x_i (1-based positions, walls at 0 and n+1).
            let force = ki * (at(i + 1) - at(i));
            if i >= 1 {
                lq[i - 1] += force;
            }
            if i < n {
                lq[i] -= force;
            }
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
        let n = self.masses();
        for (i, &ki) in self.k.iter().enumerate() {
            if i >= 1 {
                h.qq.add(i - 1, i - 1, -ki);
            }
            if i < n {
                h.qq.add(i, i, -ki);
            }
            if i >= 1 && i < n {
                h.qq.add(i - 1, i, ki);
                h.qq.add(i, i - 1, ki);
            }
        }
        for i in 0..n {
            h.vv.add(i, i, 1.0);
        }
    }
    fn is_linear(&self) -> bool {
        true
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn coordinate_name(&self, i: usize) -> String {
        format!("x{}", i + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact solution conserves energy, starts at the initial state, and satisfies ẍ = −Kx
    /// (checked by central differences).
    #[test]
    fn exact_solution_solves_the_equations() {
        let chain = SpringChain::alternating(10, 1e6);
        let mut x0 = vec![0.0; 10];
        x0[0] = 1.0;
        x0[1] = 1.001;
        let p0 = vec![0.0; 10];
        let e0 = chain.energy(&x0, &p0);
        let (x, p) = chain.exact(&x0, &p0, 0.0);
        let start_dev = x
            .iter()
            .zip(&x0)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(start_dev < 1e-13, "{start_dev}");
        assert!(p.iter().all(|v| v.abs() < 1e-10));
        let k = chain.stiffness();
        let (t, d) = (3.7, 1e-5);
        let (x, p) = chain.exact(&x0, &p0, t);
        let drift = ((chain.energy(&x, &p) - e0) / e0).abs();
        assert!(drift < 1e-12, "{drift}");
        let (xa, _) = chain.exact(&x0, &p0, t + d);
        let (xb, _) = chain.exact(&x0, &p0, t - d);
        let kx = &k * DVector::from_column_slice(&x);
        for i in 0..10 {
            let acc = (xa[i] - 2.0 * x[i] + xb[i]) / (d * d);
            assert!(
                (acc + kx[i]).abs() < 1e-3 * kx.amax().max(1.0),
                "{i}: {acc} vs {}",
                -kx[i]
            );
        }
    }

    /// The slow frequencies match a 40-digit eigen-decomposition of `K` (mpmath `eigsy`) to
    /// 1e-11 relative.
    #[test]
    fn slow_frequencies_are_accurate() {
        let reference = [
            0.133_974_512_882_273_13,
            0.499_999_750_000_078_1,
            0.999_999_666_666_666_6,
            1.499_999_749_999_921_8,
            1.866_025_320_451_060_2,
        ];
        let (omegas, _) = SpringChain::alternating(10, 1e6).modes();
        for (w, l) in omegas.iter().zip(reference) {
            assert!(((w * w - l) / l).abs() < 1e-11, "{} vs {l}", w * w);
        }
    }

    /// `∂L/∂q = −Kx` for the hand-written gradient.
    #[test]
    fn gradient_is_minus_stiffness_times_x() {
        let chain = SpringChain::alternating(4, 50.0);
        let x = [0.3, -0.2, 0.9, 0.1];
        let (mut lq, mut lv) = ([0.0; 4], [0.0; 4]);
        chain.lagrangian_gradient(&x, &[0.0; 4], &mut lq, &mut lv);
        let kx = chain.stiffness() * DVector::from_column_slice(&x);
        for i in 0..4 {
            assert!((lq[i] + kx[i]).abs() < 1e-12);
        }
    }
}
