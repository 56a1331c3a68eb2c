//! Polynomial path approximations `q(σh) = Σⱼ ℓⱼ(σ) Qʲ` through control points.

use crate::quadrature::QuadratureRule;

/// A polynomial path of degree `s` on `σ ∈ [0, 1]`, written in the Lagrange basis of `s + 1`
/// control nodes `0 = d₀ < d₁ < … < d_s = 1` (Lobatto points, for conditioning).
///
/// `Q⁰ = q_k` and `Q^s = q_{k+1}`; the interior control points are extra unknowns of the step.
/// Degree one is the linear path `q(σh) = (1 − σ) q_k + σ q_{k+1}`.
#[derive(Debug, Clone, PartialEq)]
pub struct PolynomialPath {
    degree: usize,
    control_nodes: Vec<f64>,
}

impl PolynomialPath {
    /// The path of degree `s ≥ 1`.
    ///
    /// # Panics
    /// If `s == 0`.
    #[must_use]
    pub fn new(degree: usize) -> Self {
        assert!(degree >= 1, "a path needs degree at least one");
        let control_nodes = QuadratureRule::lobatto(degree + 1).nodes().to_vec();
        Self {
            degree,
            control_nodes,
        }
    }

    /// The linear path.
    #[must_use]
    pub fn linear() -> Self {
        Self::new(1)
    }

    /// The degree `s`.
    #[must_use]
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Control nodes `d₀ … d_s`.
    #[must_use]
    pub fn control_nodes(&self) -> &[f64] {
        &self.control_nodes
    }

    /// `ℓⱼ(σ)` for `j = 0..=s`.
    #[must_use]
    pub fn basis(&self, sigma: f64, j: usize) -> f64 {
        let d = &self.control_nodes;
        d.iter()
            .enumerate()
            .filter(|&(m, _)| m != j)
            .map(|(_, dm)| (sigma - dm) / (d[j] - dm))
            .product()
    }

    /// `ℓⱼ'(σ)` (derivative in σ; the velocity is `Σ ℓⱼ'(σ) Qʲ / h`).
    #[must_use]
    pub fn basis_derivative(&self, sigma: f64, j: usize) -> f64 {
        let d = &self.control_nodes;
        let mut total = 0.0;
        for (m, dm) in d.iter().enumerate() {
            if m == j {
                continue;
            }
            let mut term = 1.0 / (d[j] - dm);
            for (r, dr) in d.iter().enumerate() {
                if r != j && r != m {
                    term *= (sigma - dr) / (d[j] - dr);
                }
            }
            total += term;
        }
        total
    }
}

/// Basis values at the nodes of one quadrature rule, flattened row-major with stride `s + 1`:
/// `phi[i(s+1) + j] = ℓⱼ(cᵢ)`, `dphi[i(s+1) + j] = ℓⱼ'(cᵢ)`.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct NodeTable {
    pub nodes: Vec<f64>,
    pub weights: Vec<f64>,
    pub phi: Vec<f64>,
    pub dphi: Vec<f64>,
    pub stride: usize,
}

impl NodeTable {
    pub fn new(path: &PolynomialPath, rule: &QuadratureRule) -> Self {
        let s = path.degree();
        let mut phi = Vec::with_capacity(rule.nodes().len() * (s + 1));
        let mut dphi = Vec::with_capacity(rule.nodes().len() * (s + 1));
        for &c in rule.nodes() {
            for j in 0..=s {
                phi.push(path.basis(c, j));
                dphi.push(path.basis_derivative(c, j));
            }
        }
        Self {
            nodes: rule.nodes().to_vec(),
            weights: rule.weights().to_vec(),
            phi,
            dphi,
            stride: s + 1,
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Basis values and derivatives at node `i`.
    pub fn row(&self, i: usize) -> (&[f64], &[f64]) {
        let o = i * self.stride;
        (
            &self.phi[o..o + self.stride],
            &self.dphi[o..o + self.stride],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The basis reproduces polynomials up to the degree exactly, and its derivative too.
    #[test]
    fn reproduces_polynomials() {
        for s in 1..=5 {
            let path = PolynomialPath::new(s);
            let d = path.control_nodes().to_vec();
            for &sigma in &[0.0, 0.13, 0.5, 0.77, 1.0] {
                for deg in 0..=s as i32 {
                    let p: f64 = (0..=s).map(|j| path.basis(sigma, j) * d[j].powi(deg)).sum();
                    assert!((p - sigma.powi(deg)).abs() < 1e-12);
                    let dp: f64 = (0..=s)
                        .map(|j| path.basis_derivative(sigma, j) * d[j].powi(deg))
                        .sum();
                    let exact = if deg == 0 {
                        0.0
                    } else {
                        f64::from(deg) * sigma.powi(deg - 1)
                    };
                    assert!(
                        (dp - exact).abs() < 1e-10,
                        "s={s} deg={deg}: {dp} vs {exact}"
                    );
                }
            }
        }
    }
}
