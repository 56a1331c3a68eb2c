//! A model's and its constraints' first derivatives at one point, stamped once for the set-up
//! analyses that read them (the natural modes, the truncation test's judged components).

use dirac_core::{Constraints, ForceJacobian, LagrangianHessian, Model, Triplets};

/// `∂²L` by blocks, the force Jacobian and the constraint forms at one point `(q, v, t)`.
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
        let mut hessian = LagrangianHessian::default();
        hessian.begin();
        model.lagrangian_hessian(q, v, &mut hessian);
        let mut force = ForceJacobian::default();
        force.begin();
        if model.has_force() {
            model.force_jacobian(q, v, t, &mut force);
        }
        let mut forms = Triplets::new();
        forms.begin();
        constraints.forms(q, &mut forms);
        Self {
            hessian,
            force,
            forms,
        }
    }
}
