//! Holonomic constraints on port values: `g(x) = 0` with `x` the values of several ports.

/// A holonomic constraint `gᵃ(x) = 0`, `a = 1..rows`, on the values `x = (x₁ … x_P)` of the ports a
/// connection lists (each port a linear combination of its subsystem's coordinates).
///
/// Joints between rigid bodies are of this kind: the ports are the bodies' coordinates, and the rows
/// are affine (a shared point) or bilinear (two body-fixed axes kept parallel) in them. Where a
/// [`crate::Connection::Joint`] only equates two flows (a one-form, which holds positions only as
/// far as they held at the start), these rows are enforced at position level,
/// `g(q_{k+1}) = 0` with the force along `dg(q_k)`, and checked at the initial point.
///
/// Derivatives are emitted as entries through a callback, in the **same sequence on every call**
/// (zeros included), which is how the assembler keeps the Newton matrix's pattern fixed.
pub trait PortConstraint: Send + Sync {
    /// Number of rows.
    fn rows(&self) -> usize;

    /// Writes `gᵃ(x)` into `g` (length [`PortConstraint::rows`]).
    fn values(&self, x: &[f64], g: &mut [f64]);

    /// Emits `∂gᵃ/∂xᵢ` as `(a, i, value)`.
    fn jacobian(&self, x: &[f64], emit: &mut dyn FnMut(usize, usize, f64));

    /// Emits `Σₐ λₐ ∂²gᵃ/∂xᵢ∂xⱼ` as `(i, j, value)` (both triangles), with a pattern that does not
    /// depend on `λ`. Nothing when [`PortConstraint::is_linear`].
    fn hessian(&self, x: &[f64], lambda: &[f64], emit: &mut dyn FnMut(usize, usize, f64));

    /// True when every row is affine in `x`: the covectors are then constant.
    fn is_linear(&self) -> bool;

    /// Name of row `a`, for diagnostics.
    fn row_name(&self, a: usize) -> String {
        format!("row {a}")
    }
}

#[cfg(test)]
mod tests {
    //! A rod `g = ½(|a − b|² − ℓ²)` between two planar points as a holonomic connection: the
    //! assembled covectors, multiplier Hessian and contracted derivative are the derivatives of the
    //! assembled `g` (central differences, step 1e-6, agreement 1e-7 relative), the rows are
    //! holonomic, and a second evaluation stamps the same pattern.
    //!
    //! Mutations seen to fail: the assembled multiplier Hessian scaled by 1.001 (`hessian j,l`),
    //! the contracted derivative scaled by 1.001 (`contracted 0`).

    use super::*;
    use crate::{Assembler, Interconnection, Representation, Subsystem};
    use dirac_core::{ConstraintKind, Constraints, LagrangianHessian, Model, Triplets};

    /// A point of the plane with unit mass; its ports are `x`, `y`, and `2x + y` (to exercise
    /// ports that combine coordinates).
    struct Point;
    impl Model for Point {
        fn dim(&self) -> usize {
            2
        }
        fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
            0.5 * (v[0] * v[0] + v[1] * v[1])
        }
        fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
            lq.fill(0.0);
            lv.copy_from_slice(v);
        }
        fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
            h.vv.add(0, 0, 1.0);
            h.vv.add(1, 1, 1.0);
        }
    }

    /// `½((x₀ − x₂)² + (x₁ − x₃)² − ℓ²)`.
    struct Rod(f64);
    impl PortConstraint for Rod {
        fn rows(&self) -> usize {
            1
        }
        fn values(&self, x: &[f64], g: &mut [f64]) {
            let (dx, dy) = (x[0] - x[2], x[1] - x[3]);
            g[0] = 0.5 * (dx * dx + dy * dy - self.0 * self.0);
        }
        fn jacobian(&self, x: &[f64], emit: &mut dyn FnMut(usize, usize, f64)) {
            let (dx, dy) = (x[0] - x[2], x[1] - x[3]);
            emit(0, 0, dx);
            emit(0, 1, dy);
            emit(0, 2, -dx);
            emit(0, 3, -dy);
        }
        fn hessian(&self, _x: &[f64], lambda: &[f64], emit: &mut dyn FnMut(usize, usize, f64)) {
            for (i, j, s) in [(0, 0, 1.0), (0, 2, -1.0), (2, 0, -1.0), (2, 2, 1.0)] {
                emit(i, j, s * lambda[0]);
                emit(i + 1, j + 1, s * lambda[0]);
            }
        }
        fn is_linear(&self) -> bool {
            false
        }
    }

    /// Difference step and relative agreement of central differences (truncation ~1e-12 here;
    /// the slack covers cancellation in the difference quotient).
    const STEP: f64 = 1e-6;
    const AGREE: f64 = 1e-7;

    fn dense(t: &Triplets, rows: usize, cols: usize) -> Vec<Vec<f64>> {
        let mut out = vec![vec![0.0; cols]; rows];
        for (r, c, v) in t.iter() {
            out[r][c] += v;
        }
        out
    }

    #[test]
    fn holonomic_connection_derivatives_match_differences() {
        let mut g = Interconnection::new();
        for name in ["A", "B"] {
            let s = Subsystem::new(name, Point)
                .with_port("x", 0)
                .with_combination_port("u", vec![(0, 2.0), (1, 1.0)]);
            g.add_subsystem(s).expect("unique");
        }
        let ports = vec![
            g.port("A", "x").expect("port"),
            g.port("A", "u").expect("port"),
            g.port("B", "x").expect("port"),
            g.port("B", "u").expect("port"),
        ];
        g.holonomic("rod", ports, Rod(1.5)).expect("shape");
        let system = Assembler::assemble(&g, Representation::Monolithic).expect("assembles");
        let c = &system.constraints;
        assert_eq!(c.count(), 1);
        assert_eq!(c.kind(0), ConstraintKind::Holonomic);
        assert!(!c.is_constant());
        assert!(c.name(0).contains("rod"), "{}", c.name(0));
        let q = [0.3, -0.7, 1.1, 0.4];
        let w = [0.2, 0.5, -0.3, 0.9];
        let lambda = [1.7];
        let value = |x: &[f64]| {
            let mut out = [0.0];
            c.values(x, &mut out);
            out[0]
        };
        let forms = |x: &[f64]| {
            let mut t = Triplets::new();
            t.begin();
            c.forms(x, &mut t);
            dense(&t, 1, 4)[0].clone()
        };
        let a = forms(&q);
        let mut hess = Triplets::new();
        hess.begin();
        c.multiplier_hessian(&q, &lambda, &mut hess);
        hess.freeze();
        hess.begin();
        c.multiplier_hessian(&q, &lambda, &mut hess);
        hess.finish().expect("fixed pattern");
        let hess = dense(&hess, 4, 4);
        let mut contracted = Triplets::new();
        contracted.begin();
        c.contracted_derivative(&q, &w, &mut contracted);
        let contracted = dense(&contracted, 1, 4);
        for l in 0..4 {
            let (mut qp, mut qm) = (q, q);
            qp[l] += STEP;
            qm[l] -= STEP;
            let dg = (value(&qp) - value(&qm)) / (2.0 * STEP);
            assert!((a[l] - dg).abs() <= AGREE * (1.0 + dg.abs()), "dg/dq{l}");
            let (ap, am) = (forms(&qp), forms(&qm));
            let mut dw = 0.0;
            for j in 0..4 {
                let d = (ap[j] - am[j]) / (2.0 * STEP);
                let expected = lambda[0] * d;
                assert!(
                    (hess[j][l] - expected).abs() <= AGREE * (1.0 + expected.abs()),
                    "hessian {j},{l}: {} vs {expected}",
                    hess[j][l]
                );
                dw += w[j] * d;
            }
            assert!(
                (contracted[0][l] - dw).abs() <= AGREE * (1.0 + dw.abs()),
                "contracted {l}"
            );
        }
        let mut gv = [0.0];
        c.values(&[0.0, 0.0, 1.5 / 5.0_f64.sqrt(), 0.0], &mut gv);
        assert!(
            gv[0].abs() < 1e-15,
            "B at x = ℓ/√5 (u = 2x) is at distance ℓ: {}",
            gv[0]
        );
    }

    /// A connection that reads no port is refused with its name.
    #[test]
    fn empty_constraint_is_refused() {
        let mut g = Interconnection::new();
        let err = g
            .holonomic("nothing", vec![], Rod(1.0))
            .expect_err("no ports");
        assert!(err.to_string().contains("nothing"), "{err}");
    }
}
