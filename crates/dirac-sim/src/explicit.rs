//! The explicit trapezoid step of a separable model: Störmer–Verlet (velocity Verlet).
//!
//! For `L = ½vᵀMv − V(q)` with a constant `M` and a force `f(q, t)`, write the total force
//! `F(q, t) = ∂L/∂q + f = −∇V(q) + f(q, t)`. The trapezoid rule on the linear path gives
//! `L_d = h/2 [L(q_k, v̄) + L(q_{k+1}, v̄)]` with `v̄ = (q_{k+1} − q_k)/h` and
//! `f_d^± = h/2 f(q_{k+1 | k}, t_{k+1 | k})`, so the forced discrete Hamiltonian map
//! `p_k = −D₁L_d − f_d⁻`, `p_{k+1} = D₂L_d + f_d⁺` reads
//!
//! ```text
//! M v̄     = p_k + h/2 F(q_k, t_k)
//! q_{k+1} = q_k + h v̄
//! p_{k+1} = M v̄ + h/2 F(q_{k+1}, t_k + h)
//! ```
//!
//! which is explicit: the step equation is linear in `q_{k+1}` with the constant matrix `M/h`.
//! The end force is the next step's start force, so a step costs one force evaluation and one
//! solve with `M` (factorised once). It is the same map as the Newton path's trapezoid step, so
//! equivalence preservation (potentials in `L` or as forces give the same `F`) carries over.
//! A composition (substeps `h_1 … h_s`) runs as one pass: the end kick `h_i/2 F` of one substep
//! and the start kick `h_{i+1}/2 F` of the next act at the same point and are applied as one,
//! which changes only round-off.

use dirac_core::{Model, Triplets};
use dirac_solve::{LinearSolveError, LinearSolver};

use crate::linear::{AutoLu, SolverChoice};

/// How `M v̄ = r` is solved.
#[derive(Debug)]
enum MassSolve {
    /// `M` diagonal: multiply by the stored inverse.
    Diagonal(Vec<f64>),
    /// General `M`: its LU factors (dense for small `n`).
    Lu(AutoLu),
}

/// The explicit trapezoid step of a separable model (see the module documentation).
#[derive(Debug)]
pub(crate) struct ExplicitStep {
    mass: MassSolve,
    /// Zero velocities (the model's `∂L/∂q` and `f` do not depend on `v`).
    zero: Vec<f64>,
    /// `∂L/∂v` output of gradient calls (unused).
    lv: Vec<f64>,
    /// Work space for the force part `f`.
    f: Vec<f64>,
    /// `F(q, t)` at the start of the next step, when known.
    start_force: Vec<f64>,
    /// The point where `start_force` was evaluated (`t` matters only for non-autonomous models).
    start_q: Vec<f64>,
    start_t: f64,
    start_valid: bool,
    autonomous: bool,
    /// `q_{k+1} − q_*` of the last substep.
    increment: Vec<f64>,
}

impl ExplicitStep {
    /// The explicit step for `model` if it is separable with a nonsingular mass matrix.
    pub(crate) fn new<M: Model + ?Sized>(model: &M, solver: SolverChoice) -> Option<Self> {
        let n = model.dim();
        let mass = model.separable()?;
        let diagonal = mass.iter().all(|(r, c, m)| r == c || m == 0.0);
        let mass = if diagonal {
            let mut d = vec![0.0; n];
            for (r, _, m) in mass.iter() {
                d[r] += m;
            }
            if d.iter().any(|m| !(m.is_finite() && *m != 0.0)) {
                return None;
            }
            MassSolve::Diagonal(d.iter().map(|m| 1.0 / m).collect())
        } else {
            MassSolve::Lu(factor(&mass, n, solver).ok()?)
        };
        Some(Self {
            mass,
            zero: vec![0.0; n],
            lv: vec![0.0; n],
            f: vec![0.0; n],
            start_force: vec![0.0; n],
            start_q: vec![0.0; n],
            start_t: f64::NAN,
            start_valid: false,
            autonomous: model.is_autonomous(),
            increment: vec![0.0; n],
        })
    }

    /// `F(q, t) = ∂L/∂q + f` into `out` (inlined: it runs once per substep, and a call of its
    /// own costs as much as a small model's gradient).
    #[inline(always)]
    fn total_force<M: Model + ?Sized>(
        model: &M,
        q: &[f64],
        t: f64,
        zero: &[f64],
        lv: &mut [f64],
        f: &mut [f64],
        out: &mut [f64],
    ) {
        model.lagrangian_gradient(q, zero, out, lv);
        if model.has_force() {
            model.force(q, zero, t, f);
            for (o, fi) in out.iter_mut().zip(f.iter()) {
                *o += fi;
            }
        }
    }

    /// One step from `(q, p, t)` made of explicit substeps of the given sizes (one size: a
    /// Störmer–Verlet step; several: a composition), in place. Adjacent half kicks at the same
    /// point are merged (`p += (hᵢ + hᵢ₊₁)/2 · F`), so a step costs one force evaluation per
    /// substep and one pass over the state each. Returns the index of a non-finite entry of the new
    /// state, if any.
    pub(crate) fn compose<M: Model + ?Sized>(
        &mut self,
        model: &M,
        q: &mut [f64],
        p: &mut [f64],
        t: f64,
        sizes: impl Iterator<Item = f64>,
    ) -> Result<(), usize> {
        let increment = &mut self.increment[..];
        let reuse = self.start_valid
            && (self.autonomous || self.start_t == t)
            && self.start_q.as_slice() == &*q;
        // The stored start no longer describes `start_force` until this step succeeds.
        self.start_valid = false;
        if !reuse {
            Self::total_force(
                model,
                q,
                t,
                &self.zero,
                &mut self.lv,
                &mut self.f,
                &mut self.start_force,
            );
        }
        let n = q.len();
        let mut sizes = sizes.peekable();
        let mut kick = 0.5 * sizes.peek().copied().unwrap_or(0.0);
        let mut time = t;
        while let Some(h) = sizes.next() {
            // p += kick F, z = h M⁻¹ p, q += z (one pass when M is diagonal: the vectors are
            // short and a substep is a few operations per entry). `inv·h` does not depend on
            // `p`: grouped so, it stays off the chain force → p → q → force that bounds a
            // substep, which then holds one multiplication fewer.
            let force = &self.start_force[..n];
            match &mut self.mass {
                MassSolve::Diagonal(inv) => {
                    let (z, inv) = (&mut increment[..n], &inv[..n]);
                    for i in 0..n {
                        p[i] += kick * force[i];
                        z[i] = p[i] * (inv[i] * h);
                        q[i] += z[i];
                    }
                }
                MassSolve::Lu(lu) => {
                    for ((pk, f), z) in p.iter_mut().zip(force).zip(increment.iter_mut()) {
                        *pk += kick * f;
                        *z = *pk;
                    }
                    if let Err(e) = lu.solve_in_place(increment) {
                        return Err(match e {
                            LinearSolveError::NonFinite { index } => index,
                            _ => 0,
                        });
                    }
                    for (z, qk) in increment.iter_mut().zip(q.iter_mut()) {
                        *z *= h;
                        *qk += *z;
                    }
                }
            }
            time += h;
            Self::total_force(
                model,
                q,
                time,
                &self.zero,
                &mut self.lv,
                &mut self.f,
                &mut self.start_force,
            );
            kick = 0.5 * (h + sizes.peek().copied().unwrap_or(0.0));
        }
        for (pk, f) in p.iter_mut().zip(&self.start_force) {
            *pk += kick * f;
        }
        if let Some(bad) = p
            .iter()
            .zip(q.iter())
            .position(|(a, b)| !(a.is_finite() && b.is_finite()))
        {
            return Err(bad);
        }
        self.start_q.copy_from_slice(q);
        self.start_t = time;
        self.start_valid = true;
        Ok(())
    }

    /// The increment `q_{k+1} − q_*` of the last substep of the last step.
    pub(crate) fn last_increment(&self) -> &[f64] {
        &self.increment
    }
}

/// Factorises `M` given as triplets.
fn factor(mass: &Triplets, n: usize, solver: SolverChoice) -> Result<AutoLu, LinearSolveError> {
    let mut lu = AutoLu::for_size(solver, n);
    lu.analyse(n, mass.rows(), mass.cols())?;
    lu.factor(mass.values())?;
    Ok(lu)
}
