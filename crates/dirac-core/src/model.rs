//! The continuous model: a Lagrangian `L(q, v)` and an external force `f(q, v, t)`.

use dirac_solve::Triplets;

/// Second derivatives of a Lagrangian, stamped as three fixed-pattern triplet streams.
///
/// `qq` holds `∂²L/∂qᵢ∂qⱼ`, `qv` holds `∂²L/∂qᵢ∂vⱼ` (row = q index, column = v index) and `vv`
/// holds `∂²L/∂vᵢ∂vⱼ`. Symmetric blocks are stamped in full (both `(i, j)` and `(j, i)`).
/// A model must emit the same `(i, j)` sequence on every call, zeros included.
#[derive(Debug, Clone, Default)]
pub struct LagrangianHessian {
    /// `∂²L/∂q∂q`.
    pub qq: Triplets,
    /// `∂²L/∂q∂v` (row: q index, column: v index).
    pub qv: Triplets,
    /// `∂²L/∂v∂v`.
    pub vv: Triplets,
}

impl LagrangianHessian {
    /// Starts a pass over all three blocks.
    pub fn begin(&mut self) {
        self.qq.begin();
        self.qv.begin();
        self.vv.begin();
    }

    /// Fixes the patterns after the first pass.
    pub fn freeze(&mut self) {
        self.qq.freeze();
        self.qv.freeze();
        self.vv.freeze();
    }

    /// Checks that a pass emitted the recorded patterns.
    pub fn finish(&self) -> Result<(), dirac_solve::PatternMismatch> {
        self.qq.finish()?;
        self.qv.finish()?;
        self.vv.finish()
    }
}

/// Jacobians of an external force, stamped as fixed-pattern triplet streams.
///
/// `q` holds `∂fᵢ/∂qⱼ` and `v` holds `∂fᵢ/∂vⱼ`.
#[derive(Debug, Clone, Default)]
pub struct ForceJacobian {
    /// `∂f/∂q`.
    pub q: Triplets,
    /// `∂f/∂v`.
    pub v: Triplets,
}

impl ForceJacobian {
    /// Starts a pass over both blocks.
    pub fn begin(&mut self) {
        self.q.begin();
        self.v.begin();
    }

    /// Fixes the patterns after the first pass.
    pub fn freeze(&mut self) {
        self.q.freeze();
        self.v.freeze();
    }

    /// Checks that a pass emitted the recorded patterns.
    pub fn finish(&self) -> Result<(), dirac_solve::PatternMismatch> {
        self.q.finish()?;
        self.v.finish()
    }
}

/// A mechanical or electrical model on `Qⁿ`: Lagrangian, external force and their derivatives.
///
/// The Lagrangian may be degenerate (`∂²L/∂v²` singular), as for a capacitor charge with no kinetic
/// term; the discrete step then relies on constraints or potentials to determine every coordinate.
/// Derivatives are exact: stock models write them by hand, [`crate::AutoDiff`] derives them from a
/// generic `L(q, v)` and `f(q, v, t)` with dual numbers.
pub trait Model {
    /// Number of coordinates `n`.
    fn dim(&self) -> usize;

    /// `L(q, v)`.
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64;

    /// Writes `∂L/∂q` into `lq` and `∂L/∂v` into `lv` (overwriting them).
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]);

    /// Stamps the second derivatives of `L` at `(q, v)`.
    fn lagrangian_hessian(&self, q: &[f64], v: &[f64], hessian: &mut LagrangianHessian);

    /// [`Model::lagrangian_gradient`] of several instances of this model at once: instance `k`
    /// owns entries `offsets[k] .. offsets[k] + dim()` of the longer vectors `q`, `v`, `lq`, `lv`.
    /// An assembled model calls it once for all the parts that share this model object (a
    /// netlist's resistors of equal value), so a part may override it with one tight loop; the
    /// values must be those of one call per instance.
    fn lagrangian_gradient_at(
        &self,
        offsets: &[usize],
        q: &[f64],
        v: &[f64],
        lq: &mut [f64],
        lv: &mut [f64],
    ) {
        let n = self.dim();
        for &o in offsets {
            let r = o..o + n;
            self.lagrangian_gradient(&q[r.clone()], &v[r.clone()], &mut lq[r.clone()], &mut lv[r]);
        }
    }

    /// Whether the model has an external force. Models without one skip force evaluation.
    fn has_force(&self) -> bool {
        false
    }

    /// Writes the external force `f(q, v, t)` into `f` (overwriting it).
    fn force(&self, _q: &[f64], _v: &[f64], _t: f64, f: &mut [f64]) {
        f.fill(0.0);
    }

    /// Stamps `∂f/∂q` and `∂f/∂v` at `(q, v, t)`.
    fn force_jacobian(&self, _q: &[f64], _v: &[f64], _t: f64, _jacobian: &mut ForceJacobian) {}

    /// [`Model::force`] of several instances at once, laid out as in
    /// [`Model::lagrangian_gradient_at`].
    fn force_at(&self, offsets: &[usize], q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        let n = self.dim();
        for &o in offsets {
            let r = o..o + n;
            self.force(&q[r.clone()], &v[r.clone()], t, &mut f[r]);
        }
    }

    /// True when `L` is quadratic and `f` is affine in `(q, v)` with `t` entering only additively:
    /// every Hessian and force Jacobian is then constant, and so is the Newton matrix at fixed `h`.
    fn is_linear(&self) -> bool {
        false
    }

    /// True when the force does not depend on `t` (no sources). A linear autonomous model with
    /// constant constraint forms has a step that is a fixed linear map of `(q_k, p_k)`.
    fn is_autonomous(&self) -> bool {
        false
    }

    /// Whether the force on coordinate `i` depends on `t` explicitly (a source). By default every
    /// coordinate of a non-autonomous model does. Used to prefer a source's own equation when two
    /// equations fix the same value (a capacitor across a voltage source).
    fn depends_on_time(&self, _i: usize) -> bool {
        !self.is_autonomous()
    }

    /// The first time after `t` at which the force stops being smooth in time (a corner of a
    /// piecewise-linear or pulse source, the delayed start of a sine), if any. The integrator lands
    /// a step on every such time, so a corner costs no more accuracy than a smooth stretch.
    fn next_breakpoint(&self, _t: f64) -> Option<f64> {
        None
    }

    /// Whether [`Model::update_fraction`] may return less than 1 (solvers skip the call when not).
    fn has_update_limit(&self) -> bool {
        false
    }

    /// The largest fraction `α ∈ (0, 1]` of a Newton update from `(q, v)` to `(q + dq, v + dv)`
    /// that the model accepts. Exponential devices use it to keep an iterate from jumping into
    /// overflow or far past the solution (SPICE's junction limiting `pnjlim`, as a fraction);
    /// Newton moves every unknown by `α` times its update, so the direction stays Newton's.
    /// Only consulted when [`Model::has_update_limit`] is true.
    fn update_fraction(&self, _q: &[f64], _v: &[f64], _dq: &[f64], _dv: &[f64]) -> f64 {
        1.0
    }

    /// Whether [`Model::check_step`] may reject a step (the integrator skips the call when not).
    fn has_step_check(&self) -> bool {
        false
    }

    /// Whether a solved step from `q0` to `q1` lies on the branch of the step equations that
    /// the motion follows. A nonlinear step can have roots that no motion takes (the discrete
    /// rigid body's equations have one near a half turn per step besides the small rotation the
    /// body makes); Newton may land on one from a good guess, and the step equations alone cannot
    /// tell. `Err(reason)` rejects the step; the integrator takes it again as smaller pieces.
    /// Only consulted when [`Model::has_step_check`] is true.
    fn check_step(&self, _q0: &[f64], _q1: &[f64]) -> Result<(), String> {
        Ok(())
    }

    /// Appends to `turns` the angle (radians) by which a step from `q0` to `q1` turns each body
    /// of the model, one entry per body in a fixed order (none for a model without rotations).
    /// A step that turns a body far enough to have passed a spurious root nearby is checked
    /// against two half steps by the integrator, and the angle between their ends, body by
    /// body, measures how far apart the two landed. Only consulted when
    /// [`Model::has_step_check`] is true.
    fn step_turns(&self, _q0: &[f64], _q1: &[f64], _turns: &mut Vec<f64>) {}

    /// Name of coordinate `i`, for diagnostics and output headers.
    fn coordinate_name(&self, i: usize) -> String {
        format!("q{i}")
    }

    /// The constant mass matrix `M` (full symmetric triplets, duplicates summed) when the model is
    /// *separable*: `L = ½vᵀMv − V(q)` with `M` constant, `∂L/∂q` independent of `v`, and a
    /// force `f(q, t)` independent of `v`. `None` unless proven (the default).
    ///
    /// A separable model without constraints steps explicitly with the trapezoid rule
    /// (Störmer–Verlet): the step equations are then linear in the unknowns with the matrix `M/h`
    /// (MATH §3), so no Newton iteration is needed. `M` may be singular (a massless coordinate);
    /// the integrator then keeps the Newton path.
    fn separable(&self) -> Option<Triplets> {
        None
    }
}

impl<M: Model + ?Sized> Model for &M {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        (**self).lagrangian(q, v)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        (**self).lagrangian_gradient(q, v, lq, lv);
    }
    fn lagrangian_hessian(&self, q: &[f64], v: &[f64], hessian: &mut LagrangianHessian) {
        (**self).lagrangian_hessian(q, v, hessian);
    }
    fn lagrangian_gradient_at(
        &self,
        offsets: &[usize],
        q: &[f64],
        v: &[f64],
        lq: &mut [f64],
        lv: &mut [f64],
    ) {
        (**self).lagrangian_gradient_at(offsets, q, v, lq, lv);
    }
    fn has_force(&self) -> bool {
        (**self).has_force()
    }
    fn force(&self, q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        (**self).force(q, v, t, f);
    }
    fn force_at(&self, offsets: &[usize], q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        (**self).force_at(offsets, q, v, t, f);
    }
    fn force_jacobian(&self, q: &[f64], v: &[f64], t: f64, jacobian: &mut ForceJacobian) {
        (**self).force_jacobian(q, v, t, jacobian);
    }
    fn is_linear(&self) -> bool {
        (**self).is_linear()
    }
    fn is_autonomous(&self) -> bool {
        (**self).is_autonomous()
    }
    fn depends_on_time(&self, i: usize) -> bool {
        (**self).depends_on_time(i)
    }
    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        (**self).next_breakpoint(t)
    }
    fn has_update_limit(&self) -> bool {
        (**self).has_update_limit()
    }
    fn update_fraction(&self, q: &[f64], v: &[f64], dq: &[f64], dv: &[f64]) -> f64 {
        (**self).update_fraction(q, v, dq, dv)
    }
    fn has_step_check(&self) -> bool {
        (**self).has_step_check()
    }
    fn check_step(&self, q0: &[f64], q1: &[f64]) -> Result<(), String> {
        (**self).check_step(q0, q1)
    }
    fn step_turns(&self, q0: &[f64], q1: &[f64], turns: &mut Vec<f64>) {
        (**self).step_turns(q0, q1, turns);
    }
    fn coordinate_name(&self, i: usize) -> String {
        (**self).coordinate_name(i)
    }
    fn separable(&self) -> Option<Triplets> {
        (**self).separable()
    }
}
