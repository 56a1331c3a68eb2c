//! Test helpers: running interconnections and checking hand-written derivatives.

use dirac_core::{
    ConstraintKind, Constraints, Discretisation, ForceJacobian, LagrangianHessian, Model, Triplets,
};
use dirac_graph::{
    AssembledConstraints, AssembledModel, AssembledSystem, Interconnection, Representation,
    SubsystemId,
};
use dirac_sim::{Integrator, IntegratorOptions, Simulation};

/// An interconnection run through the run layer ([`Simulation`]), with the assembled system's
/// state at hand for the tests (global `q`, `p`, the step's unknowns).
pub(crate) struct Run {
    pub sim: Simulation,
}

impl Run {
    /// Assembles `graph` (monolithic), builds a midpoint integrator with step `h` and initialises
    /// it at the per-subsystem positions `q0` with zero velocities.
    pub fn midpoint(graph: &Interconnection, h: f64, q0: &[Vec<f64>]) -> Self {
        Self::new(
            graph,
            Representation::Monolithic,
            IntegratorOptions::new(Discretisation::midpoint(), h),
            q0,
        )
    }

    /// As [`Run::midpoint`] with a chosen representation and options. The positions count as
    /// given; the zero velocities do not (the run layer may make them consistent, as the
    /// integrator's own start projects them).
    pub fn new(
        graph: &Interconnection,
        representation: Representation,
        options: IntegratorOptions,
        q0: &[Vec<f64>],
    ) -> Self {
        Self::build(graph, representation, options, q0, false)
    }

    /// As [`Run::new`], evaluating every step's discrete constraint residual
    /// ([`Run::constraint_residual`]).
    pub fn tracking_residual(
        graph: &Interconnection,
        representation: Representation,
        options: IntegratorOptions,
        q0: &[Vec<f64>],
    ) -> Self {
        Self::build(graph, representation, options, q0, true)
    }

    fn build(
        graph: &Interconnection,
        representation: Representation,
        options: IntegratorOptions,
        q0: &[Vec<f64>],
        track_residual: bool,
    ) -> Self {
        let mut sim =
            Simulation::new(graph.clone(), representation, options).track_residual(track_residual);
        let v0: Vec<Vec<f64>> = q0.iter().map(|q| vec![0.0; q.len()]).collect();
        let given_q: Vec<Vec<bool>> = q0.iter().map(|q| vec![true; q.len()]).collect();
        let given_v: Vec<Vec<bool>> = q0.iter().map(|q| vec![false; q.len()]).collect();
        sim.set_initial(q0, &v0, &given_q, &given_v)
            .expect("initial positions");
        sim.prepare().expect("consistent initial state");
        Self { sim }
    }

    /// The assembled system.
    pub fn system(&self) -> &AssembledSystem {
        self.sim.assembled().expect("assembled and prepared").0
    }

    /// The integrator the run layer steps (its global state, counters and last step).
    pub fn integrator(&self) -> &Integrator<AssembledModel, AssembledConstraints> {
        self.sim.assembled().expect("assembled and prepared").1
    }

    /// Global index of local coordinate `local` of subsystem number `s`.
    pub fn index(&self, s: usize, local: usize) -> usize {
        self.system().global_index(SubsystemId(s), local)
    }

    /// `q` of local coordinate `local` of subsystem number `s`.
    pub fn q(&self, s: usize, local: usize) -> f64 {
        self.integrator().q()[self.index(s, local)]
    }

    /// `p` of local coordinate `local` of subsystem number `s`.
    pub fn p(&self, s: usize, local: usize) -> f64 {
        self.integrator().p()[self.index(s, local)]
    }

    /// The largest discrete constraint residual of the last step (built with
    /// [`Run::tracking_residual`]; 0 otherwise).
    pub fn constraint_residual(&mut self) -> f64 {
        self.sim.snapshot().expect("readout").residual
    }

    /// One step.
    pub fn step(&mut self) {
        self.sim.step().expect("step converges");
    }
}

/// Sums a triplet stream into a dense `rows × cols` matrix.
pub(crate) fn dense(t: &Triplets, rows: usize, cols: usize) -> Vec<Vec<f64>> {
    let mut out = vec![vec![0.0; cols]; rows];
    for (r, c, v) in t.iter() {
        out[r][c] += v;
    }
    out
}

fn close(a: f64, b: f64, scale: f64, what: &str) {
    assert!(
        (a - b).abs() <= 1e-6 * (scale + a.abs().max(b.abs())),
        "{what}: hand-written {a:e} vs finite difference {b:e}"
    );
}

/// Central difference of `f` in coordinate `j` of `x` with a relative step.
fn central(x: &[f64], j: usize, mut f: impl FnMut(&[f64]) -> Vec<f64>) -> Vec<f64> {
    let e = 1e-6 * (1.0 + x[j].abs());
    let mut xp = x.to_vec();
    let mut xm = x.to_vec();
    xp[j] += e;
    xm[j] -= e;
    let (fp, fm) = (f(&xp), f(&xm));
    fp.iter()
        .zip(&fm)
        .map(|(a, b)| (a - b) / (2.0 * e))
        .collect()
}

/// Checks every hand-written derivative of `model` at `(q, v, t)` against central differences of
/// the lower-order function (gradient of `L`, Hessian blocks, force Jacobians), and that two
/// passes stamp the same pattern.
pub(crate) fn check_model<M: Model + ?Sized>(model: &M, q: &[f64], v: &[f64], t: f64) {
    let n = model.dim();
    let mut lq = vec![0.0; n];
    let mut lv = vec![0.0; n];
    model.lagrangian_gradient(q, v, &mut lq, &mut lv);
    let scale = 1.0 + lq.iter().chain(&lv).fold(0.0_f64, |m, x| m.max(x.abs()));
    for j in 0..n {
        let dq = central(q, j, |x| vec![model.lagrangian(x, v)]);
        let dv = central(v, j, |x| vec![model.lagrangian(q, x)]);
        close(lq[j], dq[0], scale, &format!("∂L/∂q{j}"));
        close(lv[j], dv[0], scale, &format!("∂L/∂v{j}"));
    }
    let mut h = LagrangianHessian::default();
    for pass in 0..2 {
        h.begin();
        model.lagrangian_hessian(q, v, &mut h);
        if pass == 0 {
            h.freeze();
        } else {
            h.finish().expect("fixed Hessian pattern");
        }
    }
    let (qq, qv, vv) = (dense(&h.qq, n, n), dense(&h.qv, n, n), dense(&h.vv, n, n));
    let grad = |x: &[f64], y: &[f64]| {
        let mut a = vec![0.0; n];
        let mut b = vec![0.0; n];
        model.lagrangian_gradient(x, y, &mut a, &mut b);
        (a, b)
    };
    for j in 0..n {
        let dq_lq = central(q, j, |x| grad(x, v).0);
        let dv_lv = central(v, j, |x| grad(q, x).1);
        let dq_lv = central(q, j, |x| grad(x, v).1);
        for i in 0..n {
            close(qq[i][j], dq_lq[i], scale, &format!("∂²L/∂q{i}∂q{j}"));
            close(vv[i][j], dv_lv[i], scale, &format!("∂²L/∂v{i}∂v{j}"));
            // qv[i][j] = ∂²L/∂qᵢ∂vⱼ = ∂(∂L/∂vⱼ)/∂qᵢ.
            close(qv[j][i], dq_lv[i], scale, &format!("∂²L/∂q{j}∂v{i}"));
        }
    }
    if !model.has_force() {
        return;
    }
    let force = |x: &[f64], y: &[f64]| {
        let mut f = vec![0.0; n];
        model.force(x, y, t, &mut f);
        f
    };
    let f0 = force(q, v);
    let fscale = 1.0 + f0.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let mut jac = ForceJacobian::default();
    for pass in 0..2 {
        jac.begin();
        model.force_jacobian(q, v, t, &mut jac);
        if pass == 0 {
            jac.freeze();
        } else {
            jac.finish().expect("fixed force Jacobian pattern");
        }
    }
    let (jq, jv) = (dense(&jac.q, n, n), dense(&jac.v, n, n));
    for j in 0..n {
        let dq = central(q, j, |x| force(x, v));
        let dv = central(v, j, |x| force(q, x));
        for i in 0..n {
            close(jq[i][j], dq[i], fscale, &format!("∂f{i}/∂q{j}"));
            close(jv[i][j], dv[i], fscale, &format!("∂f{i}/∂v{j}"));
        }
    }
}

/// Checks a constraint set at `q`: holonomic rows' covectors against differences of `g`,
/// `multiplier_hessian` against differences of `Σ λₐ Aᵃ`, `contracted_derivative` against
/// differences of `A·w`.
pub(crate) fn check_constraints<C: Constraints + ?Sized>(
    c: &C,
    q: &[f64],
    lambda: &[f64],
    w: &[f64],
) {
    let (m, n) = (c.count(), q.len());
    let forms = |x: &[f64]| {
        let mut t = Triplets::new();
        t.begin();
        c.forms(x, &mut t);
        dense(&t, m, n)
    };
    let a = forms(q);
    for j in 0..n {
        let dg = central(q, j, |x| {
            let mut g = vec![0.0; m];
            c.values(x, &mut g);
            g
        });
        for (row, (ar, d)) in a.iter().zip(&dg).enumerate() {
            if c.kind(row) == ConstraintKind::Holonomic {
                close(ar[j], *d, 1.0, &format!("∂g{row}/∂q{j}"));
            }
        }
    }
    let mut hess = Triplets::new();
    hess.begin();
    c.multiplier_hessian(q, lambda, &mut hess);
    let hess = dense(&hess, n, n);
    let mut contracted = Triplets::new();
    contracted.begin();
    c.contracted_derivative(q, w, &mut contracted);
    let contracted = dense(&contracted, m, n);
    for l in 0..n {
        let dl = central(q, l, |x| {
            let ax = forms(x);
            (0..n)
                .map(|j| (0..m).map(|r| lambda[r] * ax[r][j]).sum())
                .collect()
        });
        let dw = central(q, l, |x| {
            let ax = forms(x);
            (0..m)
                .map(|r| (0..n).map(|j| w[j] * ax[r][j]).sum())
                .collect()
        });
        for j in 0..n {
            close(hess[j][l], dl[j], 1.0, &format!("Σλ ∂A_{j}/∂q{l}"));
        }
        for r in 0..m {
            close(contracted[r][l], dw[r], 1.0, &format!("Σw ∂A{r}/∂q{l}"));
        }
    }
}

/// Relative difference `|a − b| / max(|b|, floor)`.
pub(crate) fn rel(a: f64, b: f64, floor: f64) -> f64 {
    (a - b).abs() / b.abs().max(floor)
}

/// Adds a node joining `(subsystem, port, sign)` triples (`+1`: the port's flow enters the node).
pub(crate) fn node(g: &mut Interconnection, name: &str, ports: &[(&str, &str, f64)]) {
    let ports = ports
        .iter()
        .map(|&(s, p, sign)| (g.port(s, p).expect("port"), sign))
        .collect();
    g.node(name, ports).expect("node");
}
