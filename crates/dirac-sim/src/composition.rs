//! Symmetric compositions of a step: `Φ_{γ_m h} ∘ … ∘ Φ_{γ_1 h}` with `Σ γᵢ = 1`.

/// The step sizes of a composition method as fractions `γᵢ` of `h`.
///
/// A composition of variational steps is variational (each factor is the discrete flow of a discrete
/// Lagrangian), and a symmetric composition (`γᵢ = γ_{m+1−i}`) of a symmetric step of order 2 has
/// order 4, 6 or 8 with the coefficients below: Yoshida 1990, *Construction of higher order
/// symplectic integrators*, Phys. Lett. A 150 (the triple jump and the solutions "A" of its
/// tables 1 and 2), and Kahan & Li 1997, *Composition constants for raising the orders of
/// unconventional schemes for ordinary differential equations*, Math. Comp. 66 (`s9odr6a`,
/// `s17odr8a`, as printed in Hairer, Lubich & Wanner, *Geometric Numerical Integration*, §V.3.2),
/// whose error constants are much smaller for two more stages. Negative `γᵢ` step backwards in
/// time.
#[derive(Debug, Clone, PartialEq)]
pub struct Composition {
    gammas: Vec<f64>,
    /// Order of the composition of a symmetric order-2 step.
    order: usize,
}

impl Default for Composition {
    fn default() -> Self {
        Self::single()
    }
}

impl Composition {
    /// The stock compositions by name, as the command line, scene files and Python take them
    /// (`none`: the single step).
    pub const NAMES: [&'static str; 6] = [
        "none",
        "yoshida4",
        "yoshida6",
        "yoshida8",
        "kahan-li6",
        "kahan-li8",
    ];

    /// The stock composition named `name` (one of [`Composition::NAMES`], case-insensitive).
    #[must_use]
    pub fn named(name: &str) -> Option<Self> {
        Some(match name.trim().to_ascii_lowercase().as_str() {
            "none" => Self::single(),
            "yoshida4" => Self::yoshida4(),
            "yoshida6" => Self::yoshida6(),
            "yoshida8" => Self::yoshida8(),
            "kahan-li6" => Self::kahan_li6(),
            "kahan-li8" => Self::kahan_li8(),
            _ => return None,
        })
    }

    /// No composition: one step of size `h`.
    #[must_use]
    pub fn single() -> Self {
        Self {
            gammas: vec![1.0],
            order: 2,
        }
    }

    /// Yoshida's triple jump: order 4 from a symmetric step of order 2 (3 stages).
    #[must_use]
    pub fn yoshida4() -> Self {
        let c = 2f64.cbrt();
        let g1 = 1.0 / (2.0 - c);
        Self {
            gammas: vec![g1, -c * g1, g1],
            order: 4,
        }
    }

    /// Yoshida's order-6 composition, solution A (7 stages).
    #[must_use]
    pub fn yoshida6() -> Self {
        Self::symmetric(
            6,
            &[
                -1.177_679_984_178_87,
                0.235_573_213_359_357,
                0.784_513_610_477_560,
            ],
        )
    }

    /// Yoshida's order-8 composition, solution A (15 stages).
    #[must_use]
    pub fn yoshida8() -> Self {
        Self::symmetric(
            8,
            &[
                -1.615_823_741_500_97,
                -2.446_991_823_705_24,
                -0.007_169_894_197_081_20,
                2.440_027_326_167_35,
                0.157_739_928_123_617,
                1.820_206_309_707_14,
                1.042_426_208_699_91,
            ],
        )
    }

    /// Kahan and Li's order-6 composition `s9odr6a` (9 stages).
    #[must_use]
    #[allow(clippy::excessive_precision)] // the published 26 digits, rounded by the compiler
    pub fn kahan_li6() -> Self {
        Self::symmetric(
            6,
            &[
                0.082_213_596_293_550_800_231_490_45,
                -0.706_246_172_557_639_359_809_964_82,
                0.332_599_136_789_359_438_599_748_64,
                0.392_161_444_007_314_139_279_250_56,
            ],
        )
    }

    /// Kahan and Li's order-8 composition `s17odr8a` (17 stages).
    #[must_use]
    #[allow(clippy::excessive_precision)] // the published 26 digits, rounded by the compiler
    pub fn kahan_li8() -> Self {
        Self::symmetric(
            8,
            &[
                0.295_011_723_609_310_298_870_966_24,
                0.258_374_387_686_322_047_293_979_11,
                0.184_539_640_978_315_707_091_832_54,
                -0.395_903_894_133_237_577_336_231_54,
                0.158_841_906_555_155_600_896_210_75,
                -0.389_474_962_644_847_286_408_078_60,
                0.561_162_981_775_108_384_561_964_41,
                0.130_202_483_088_890_080_878_817_63,
            ],
        )
    }

    /// The symmetric composition `w_k … w_1 w_0 w_1 … w_k` of the given `order` from `w_1 … w_k`
    /// (`w_1` next to the centre). The centre is computed as `w_0 = 1 − 2 Σ wᵢ`, not taken from
    /// the printed tables, so the fractions sum to 1 up to rounding (it agrees with the printed
    /// Kahan–Li centres to 1e-16).
    fn symmetric(order: usize, w: &[f64]) -> Self {
        let w0 = 1.0 - 2.0 * w.iter().sum::<f64>();
        let mut gammas: Vec<f64> = w.iter().rev().copied().collect();
        gammas.push(w0);
        gammas.extend(w.iter().copied());
        Self { gammas, order }
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
        Ok(Self { gammas, order: 2 })
    }

    /// The fractions `γᵢ` of `h`, in the order they are applied.
    #[must_use]
    pub fn gammas(&self) -> &[f64] {
        &self.gammas
    }

    /// Order of the composition of a symmetric order-2 step: 2 for a single step and for a
    /// [`Composition::custom`] one (whose order is not known), else the stock method's.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
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
            Composition::kahan_li6(),
            Composition::kahan_li8(),
        ] {
            let g = c.gammas();
            let sum: f64 = g.iter().sum();
            assert!((sum - 1.0).abs() < 1e-14, "{g:?} sums to {sum}");
            for (a, b) in g.iter().zip(g.iter().rev()) {
                assert_eq!(a, b);
            }
        }
        for name in Composition::NAMES {
            assert!(Composition::named(name).is_some(), "{name}");
        }
        assert_eq!(
            Composition::named(" Kahan-Li8 "),
            Some(Composition::kahan_li8())
        );
        assert_eq!(Composition::named("ruth3"), None);
        assert!(Composition::custom(vec![0.5, 0.4]).is_err());
        assert!(Composition::custom(vec![]).is_err());
    }
}
