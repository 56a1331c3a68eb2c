//! A model's and its constraints' first derivatives at one point, stamped once for the set-up
//! analyses that read them (the natural modes, the truncation test's judged components) and
//! restamped by the readout at every state it reads.

use dirac_core::{Constraints, ForceJacobian, LagrangianHessian, Model, Triplets};

/// `∂²L` by blocks, the force Jacobian and the constraint forms at one point `(q, v, t)`.
#[derive(Debug, Default)]
pub(crate) struct Derivatives {
    pub(crate) hessian: LagrangianHessian,
    pub(crate) force: ForceJacobian,
    pub(crate) forms: Triplets,
}

impl Derivatives {
    /// The derivatives of `model` and `constraints` at `(q, v, t)`.
    pub(crate) fn at<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        t: f64,
    ) -> Self {
        let mut derivatives = Self::default();
        derivatives.stamp(model, constraints, q, v, t);
        derivatives
    }

    /// Stamps the derivatives at `(q, v, t)` into this storage, their patterns fixed by the
    /// first stamp (the readout restamps them at every state it reads).
    pub(crate) fn stamp<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        model: &M,
        constraints: &C,
        q: &[f64],
        v: &[f64],
        t: f64,
    ) {
        self.hessian.begin();
        model.lagrangian_hessian(q, v, &mut self.hessian);
        self.hessian.freeze();
        self.force.begin();
        if model.has_force() {
            model.force_jacobian(q, v, t, &mut self.force);
        }
        self.force.freeze();
        self.forms.begin();
        constraints.forms(q, &mut self.forms);
        self.forms.freeze();
    }
}
