//! Symmetric compositions of a step: `Φ_{γ_m h} ∘ … ∘ Φ_{γ_1 h}` with `Σ γᵢ = 1`.

/// The step sizes of a composition method as fractions `γᵢ` of `h`.
///
/// A composition of variational steps is variational (each factor is the discrete flow of a discrete
/// Lagrangian), and a symmetric composition (`γᵢ = γ_{m+1−i}`) of a symmetric step of order 2 has
/// order 4, 6 or 8 with the coefficients below (Yoshida 1990, *Construction of higher order
/// symplectic integrators*, Phys. Lett. A 150: the triple jump and the solutions "A" of its
/// tables 1 and 2). Negative `γᵢ` step backwards in time.
#[derive(Debug, Clone, PartialEq)]
pub struct Composition {
    gammas: Vec<f64>,
}

impl Default for Composition {
    fn default() -> Self {
        Self::single()
    }
}

impl Composition {
    /// No composition: one step of size `h`.
    #[must_use]
    pub fn single() -> Self {
        Self { gammas: vec![1.0] }
    }

    /// Yoshida's triple jump: order 4 from a symmetric step of order 2 (3 stages).
    #[must_use]
    pub fn yoshida4() -> Self {
        let c = 2f64.cbrt();
        let g1 = 1.0 / (2.0 - c);
        Self {
            gammas: vec![g1, -c * g1, g1],
        }
    }

    /// Yoshida's order-6 composition, solution A (7 stages).
    #[must_use]
    pub fn yoshida6() -> Self {
        Self::symmetric(&[
            -1.177_679_984_178_87,
            0.235_573_213_359_357,
            0.784_513_610_477_560,
        ])
    }

    /// Yoshida's order-8 composition, solution A (15 stages).
    #[must_use]
    pub fn yoshida8() -> Self {
        Self::symmetric(&[
            -1.615_823_741_500_97,
            -2.446_991_823_705_24,
            -0.007_169_894_197_081_20,
            2.440_027_326_167_35,
            0.157_739_928_123_617,
            1.820_206_309_707_14,
            1.042_426_208_699_91,
        ])
    }

    /// The symmetric composition `w_k … w_1 w_0 w_1 … w_k` from Yoshida's `w_1 … w_k`
    /// (`w_0 = 1 − 2 Σ wᵢ`), in his table order (`w_1` first).
    fn symmetric(w: &[f64]) -> Self {
        let w0 = 1.0 - 2.0 * w.iter().sum::<f64>();
        let mut gammas: Vec<f64> = w.iter().rev().copied().collect();
        gammas.push(w0);
        gammas.extend(w.iter().copied());
        Self { gammas }
    }

    /// A composition with the given fractions of `h`.
    ///
    /// # Errors
    /// When the list is empty, a fraction is not finite or zero, or they do not sum to 1 (within
    /// 1e-12): the composed step would not advance by `h`.
    pub fn custom(gammas: Vec<f64>) -> Result<Self, CompositionError> {
        let sum: f64 = gammas.iter().sum();
        if gammas.is_empty() || gammas.iter().any(|g| !g.is_finite() || *g == 0.0) {
            return Err(CompositionError::BadFraction);
        }
        if (sum - 1.0).abs() > 1e-12 {
            return Err(CompositionError::Sum(sum));
        }
        Ok(Self { gammas })
    }

    /// The fractions `γᵢ` of `h`, in the order they are applied.
    #[must_use]
    pub fn gammas(&self) -> &[f64] {
        &self.gammas
    }

    /// Order of the composition of a symmetric order-2 step (2 for a single step).
    #[must_use]
    pub fn order(&self) -> usize {
        match self.gammas.len() {
            1 => 2,
            3 => 4,
            7 => 6,
            15 => 8,
            _ => 2,
        }
    }
}

/// A composition that does not advance by one step `h`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompositionError {
    /// A fraction is zero, not finite, or the list is empty.
    #[error("composition fractions must be finite and non-zero, and there must be at least one")]
    BadFraction,
    /// The fractions do not sum to one.
    #[error("composition fractions sum to {0}, not 1")]
    Sum(f64),
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every stock composition advances by exactly `h` and is symmetric.
    #[test]
    fn stock_compositions_sum_to_one_and_are_symmetric() {
        for c in [
            Composition::single(),
            Composition::yoshida4(),
            Composition::yoshida6(),
            Composition::yoshida8(),
        ] {
            let g = c.gammas();
            let sum: f64 = g.iter().sum();
            assert!((sum - 1.0).abs() < 1e-14, "{g:?} sums to {sum}");
            for (a, b) in g.iter().zip(g.iter().rev()) {
                assert_eq!(a, b);
            }
        }
        assert!(Composition::custom(vec![0.5, 0.4]).is_err());
        assert!(Composition::custom(vec![]).is_err());
    }
}
