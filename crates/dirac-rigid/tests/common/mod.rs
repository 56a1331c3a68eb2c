//! Shared helpers of the rigid-body tests: running an interconnection, an independent Lie group
//! variational integrator on `SO(3)`, and small matrix utilities.

#![allow(dead_code)]

use dirac_core::Discretisation;
use dirac_graph::{
    AssembledConstraints, AssembledModel, AssembledSystem, Interconnection, Representation,
    SubsystemId,
};
use dirac_rigid::so3::{self, Mat3};
use dirac_rigid::{Joint, JointFrame, JointKind, RigidBody, Side};
use dirac_sim::{Integrator, IntegratorOptions, Simulation};
use num_dual::{Dual64, DualNum};

/// A graph run through the run layer ([`Simulation`]), with the assembled system's state at hand
/// (global `q` and `p`, the integrator's warnings).
pub struct Run {
    pub sim: Simulation,
}

impl Run {
    /// Builds a simulation of `graph` in `representation` with `options`, starting at the
    /// per-subsystem positions `q0` and rates `v0` (in the graph's subsystem order, all given),
    /// and prepares it.
    pub fn new(
        graph: &Interconnection,
        representation: Representation,
        options: IntegratorOptions,
        q0: &[Vec<f64>],
        v0: &[Vec<f64>],
    ) -> Self {
        Self::build(graph, representation, options, q0, v0, false)
    }

    /// As [`Run::new`], evaluating every step's discrete constraint residual
    /// ([`Run::constraint_residual`]).
    pub fn tracking_residual(
        graph: &Interconnection,
        representation: Representation,
        options: IntegratorOptions,
        q0: &[Vec<f64>],
        v0: &[Vec<f64>],
    ) -> Self {
        Self::build(graph, representation, options, q0, v0, true)
    }

    fn build(
        graph: &Interconnection,
        representation: Representation,
        options: IntegratorOptions,
        q0: &[Vec<f64>],
        v0: &[Vec<f64>],
        track_residual: bool,
    ) -> Self {
        let mut sim =
            Simulation::new(graph.clone(), representation, options).track_residual(track_residual);
        let given: Vec<Vec<bool>> = q0.iter().map(|q| vec![true; q.len()]).collect();
        sim.set_initial(q0, v0, &given, &given)
            .expect("initial state");
        sim.prepare().expect("consistent initial state");
        Self { sim }
    }

    /// The assembled system.
    pub fn system(&self) -> &AssembledSystem {
        self.sim.assembled().expect("assembled and prepared").0
    }

    /// The integrator the run layer steps.
    pub fn integrator(&self) -> &Integrator<AssembledModel, AssembledConstraints> {
        self.sim.assembled().expect("assembled and prepared").1
    }

    /// The twelve coordinates of subsystem `s` (a body) in the global `q`.
    pub fn body_q(&self, s: usize) -> &[f64] {
        let o = self.system().global_index(SubsystemId(s), 0);
        &self.integrator().q()[o..o + 12]
    }

    /// The twelve momenta of subsystem `s` (a body) in the global `p`.
    pub fn body_p(&self, s: usize) -> &[f64] {
        let o = self.system().global_index(SubsystemId(s), 0);
        &self.integrator().p()[o..o + 12]
    }

    /// The largest discrete constraint residual of the last step (built with
    /// [`Run::tracking_residual`]; 0 otherwise).
    pub fn constraint_residual(&mut self) -> f64 {
        self.sim.snapshot().expect("readout").residual
    }

    pub fn step(&mut self) {
        self.sim.step().expect("step converges");
    }
}

/// Trapezoid rule on a linear path: the discretisation that is the LGVI.
pub fn trapezoid(h: f64) -> IntegratorOptions {
    IntegratorOptions::new(Discretisation::trapezoid(), h)
}

/// Max-norm distance of two matrices.
pub fn mat_diff(a: &Mat3, b: &Mat3) -> f64 {
    let mut worst: f64 = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            worst = worst.max((a[i][j] - b[i][j]).abs());
        }
    }
    worst
}

/// Max-norm distance of two vectors.
pub fn vec_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
}

pub fn norm(a: &[f64; 3]) -> f64 {
    so3::dot(a, a).sqrt()
}

/// A heavy top: a body whose point `pivot` (body axes, from the centre of mass) is held at the
/// space origin by a spherical joint, under gravity `−9.81 e_z`. Subsystem 0 is the body.
pub fn heavy_top(body: &RigidBody, pivot: [f64; 3]) -> Interconnection {
    let mut g = Interconnection::new();
    g.add_subsystem(body.subsystem("top")).expect("unique");
    Joint::new(
        JointKind::Spherical,
        Side::body("top", JointFrame::at(pivot)),
        Side::ground(JointFrame::at([0.0; 3])),
    )
    .connect(&mut g, "pivot")
    .expect("joint");
    g
}

/// The state of a body turning about a space-fixed point `pivot` (body axes) held at the origin:
/// rotation `r`, body angular velocity `omega`. Returns `(q, v)`.
pub fn pivoted_state(r: &Mat3, pivot: [f64; 3], omega: [f64; 3]) -> (Vec<f64>, Vec<f64>) {
    let x = so3::apply(r, &pivot).map(|c| -c);
    // ẋ = −Ṙ r_p = −R (Ω × r_p).
    let xdot = so3::apply(r, &so3::cross(&omega, &pivot)).map(|c| -c);
    (
        RigidBody::coordinates(x, r),
        RigidBody::rates(r, xdot, omega),
    )
}

/// The body angular momentum about the pivot point `pivot` (body axes, from the centre of mass)
/// of a body state `(q, p)`: the pairing of `p` with the rotations about the pivot,
/// `Π_R − r_p × (Rᵀ p_x)`.
pub fn pivot_momentum(q: &[f64], p: &[f64], pivot: [f64; 3]) -> [f64; 3] {
    let pi = RigidBody::body_angular_momentum(q, p);
    let r = RigidBody::rotation(q);
    let px = so3::apply(&so3::transpose(&r), &[p[0], p[1], p[2]]);
    let c = so3::cross(&pivot, &px);
    [pi[0] - c[0], pi[1] - c[1], pi[2] - c[2]]
}

/// The Lie group variational integrator of Lee, Leok & McClamroch for a body turning about a fixed
/// point (or about its centre of mass), coded on `SO(3)` without the embedding:
///
/// ```text
/// h Π_k + (h²/2) M_k = vee(F_k J_d − J_d F_kᵀ),   R_{k+1} = R_k F_k,
/// Π_{k+1} = F_kᵀ Π_k + (h/2) F_kᵀ M_k + (h/2) M_{k+1},
/// ```
///
/// with `J_d = ½ tr(J) I − J` and the moment `M = m ρ × (Rᵀ g)` of gravity `g` acting at the
/// centre of mass `ρ` (body axes, from the fixed point). The implicit equation is solved by
/// Newton on the Cayley parameters `F = (I + f̂)(I − f̂)⁻¹`, with its Jacobian from dual numbers.
pub struct Lgvi {
    pub j: Mat3,
    pub jd: Mat3,
    pub mass: f64,
    pub rho: [f64; 3],
    pub gravity: [f64; 3],
    pub h: f64,
}

/// `(I + f̂)(I − f̂)⁻¹` in closed form: `I + 2/(1 + |f|²)(f̂ + f̂²)`.
fn cayley<D: DualNum<Primitive = f64> + Copy>(f: &[D; 3]) -> [[D; 3]; 3] {
    let z = D::from(0.0);
    let hat = [[z, -f[2], f[1]], [f[2], z, -f[0]], [-f[1], f[0], z]];
    let n2 = f[0] * f[0] + f[1] * f[1] + f[2] * f[2];
    let c = D::from(2.0) / (D::from(1.0) + n2);
    [0, 1, 2].map(|i| {
        [0, 1, 2].map(|j| {
            let h2 = hat[i][0] * hat[0][j] + hat[i][1] * hat[1][j] + hat[i][2] * hat[2][j];
            c * (hat[i][j] + h2) + D::from(if i == j { 1.0 } else { 0.0 })
        })
    })
}

impl Lgvi {
    /// For a body of mass `mass`, inertia `j` about its centre of mass, turning about the point at
    /// `rho` from... (`rho`: centre of mass seen from the fixed point, body axes).
    pub fn new(body: &RigidBody, rho: [f64; 3], h: f64) -> Self {
        let m = body.mass();
        let jc = body.inertia();
        let r2 = so3::dot(&rho, &rho);
        let mut j = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                j[a][b] = jc[a][b] + m * (if a == b { r2 } else { 0.0 } - rho[a] * rho[b]);
            }
        }
        let tr = j[0][0] + j[1][1] + j[2][2];
        let mut jd = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                jd[a][b] = 0.5 * tr * if a == b { 1.0 } else { 0.0 } - j[a][b];
            }
        }
        Self {
            j,
            jd,
            mass: m,
            rho,
            gravity: body.gravity(),
            h,
        }
    }

    /// Gravity's moment about the fixed point, body axes.
    pub fn moment(&self, r: &Mat3) -> [f64; 3] {
        let gb = so3::apply(&so3::transpose(r), &self.gravity);
        so3::cross(&self.rho, &gb).map(|c| c * self.mass)
    }

    /// `vee(F J_d − J_d Fᵀ)` at Cayley parameters `f`.
    fn torque_map<D: DualNum<Primitive = f64> + Copy>(&self, f: &[D; 3]) -> [D; 3] {
        let fm = cayley(f);
        // (F J_d − J_d Fᵀ)_ij = Σ_k F_ik J_d,kj − J_d,ik F_jk.
        let entry = |i: usize, j: usize| {
            (0..3)
                .map(|k| fm[i][k] * self.jd[k][j] - fm[j][k] * self.jd[i][k])
                .fold(D::from(0.0), |acc, x| acc + x)
        };
        [entry(2, 1), entry(0, 2), entry(1, 0)]
    }

    /// One step from `(R_k, Π_k)`.
    pub fn step(&self, r: &Mat3, pi: &[f64; 3]) -> (Mat3, [f64; 3]) {
        let h = self.h;
        let m0 = self.moment(r);
        let rhs = [0, 1, 2].map(|i| h * pi[i] + 0.5 * h * h * m0[i]);
        // Guess: the linearisation J f ≈ rhs / 2 (F ≈ I + 2 f̂).
        let mut f = [0, 1, 2].map(|i| 0.5 * rhs[i] / self.j[i][i]);
        for _ in 0..50 {
            let g = self.torque_map(&f);
            let res = [0, 1, 2].map(|i| g[i] - rhs[i]);
            if res.iter().all(|x| x.abs() <= 1e-16 * (1.0 + norm(&rhs))) {
                break;
            }
            // Column c of the Jacobian from a dual number seeded in direction c.
            let columns = [0, 1, 2].map(|c| {
                let fd = [0, 1, 2].map(|i| Dual64::new(f[i], if i == c { 1.0 } else { 0.0 }));
                self.torque_map(&fd).map(|g| g.eps)
            });
            let jac = [0, 1, 2].map(|r| columns.map(|col| col[r]));
            let delta = solve3(&jac, &res);
            f = [0, 1, 2].map(|i| f[i] - delta[i]);
            if delta.iter().all(|d| d.abs() <= 1e-17) {
                break;
            }
        }
        let fm = cayley(&f);
        let r1 = so3::mul(r, &fm);
        let m1 = self.moment(&r1);
        let ft = so3::transpose(&fm);
        let a = so3::apply(&ft, pi);
        let b = so3::apply(&ft, &m0);
        let pi1 = [0, 1, 2].map(|i| a[i] + 0.5 * h * b[i] + 0.5 * h * m1[i]);
        (r1, pi1)
    }
}

/// Solves a 3×3 system by Cramer's rule.
pub fn solve3(a: &Mat3, b: &[f64; 3]) -> [f64; 3] {
    let d = so3::det(a);
    [0, 1, 2].map(|c| {
        let mut m = *a;
        for r in 0..3 {
            m[r][c] = b[r];
        }
        so3::det(&m) / d
    })
}

/// Sums a triplet stream into a dense matrix.
pub fn dense(t: &dirac_core::Triplets, rows: usize, cols: usize) -> Vec<Vec<f64>> {
    let mut out = vec![vec![0.0; cols]; rows];
    for (r, c, v) in t.iter() {
        out[r][c] += v;
    }
    out
}

/// Step of the central differences in the derivative checks, and the relative agreement
/// required (truncation ~1e-12 for these polynomial and trigonometric functions; cancellation in
/// the quotient costs ~1e-10).
pub const FD_STEP: f64 = 1e-6;
pub const FD_AGREE: f64 = 1e-7;

fn central(x: &[f64], j: usize, f: &mut dyn FnMut(&[f64]) -> Vec<f64>) -> Vec<f64> {
    let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
    xp[j] += FD_STEP;
    xm[j] -= FD_STEP;
    let (fp, fm) = (f(&xp), f(&xm));
    fp.iter()
        .zip(&fm)
        .map(|(a, b)| (a - b) / (2.0 * FD_STEP))
        .collect()
}

fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= FD_AGREE * (1.0 + a.abs().max(b.abs())),
        "{what}: hand-written {a:e} vs difference {b:e}"
    );
}

/// Checks a constraint set at `q`: covectors of holonomic rows against differences of `g`,
/// `multiplier_hessian` against differences of `Σ λₐ Aᵃ`, `contracted_derivative` against
/// differences of `A·w`, and that a second pass stamps the same pattern.
pub fn check_constraints<C: dirac_core::Constraints + ?Sized>(
    c: &C,
    q: &[f64],
    lambda: &[f64],
    w: &[f64],
) {
    use dirac_core::{ConstraintKind, Triplets};
    let (m, n) = (c.count(), q.len());
    let forms = |x: &[f64]| {
        let mut t = Triplets::new();
        t.begin();
        c.forms(x, &mut t);
        dense(&t, m, n)
    };
    let a = forms(q);
    for j in 0..n {
        let dg = central(q, j, &mut |x| {
            let mut g = vec![0.0; m];
            c.values(x, &mut g);
            g
        });
        for (row, (ar, d)) in a.iter().zip(&dg).enumerate() {
            assert_eq!(c.kind(row), ConstraintKind::Holonomic);
            close(ar[j], *d, &format!("∂g{row}/∂q{j} ({})", c.name(row)));
        }
    }
    let mut hess = Triplets::new();
    for pass in 0..2 {
        hess.begin();
        c.multiplier_hessian(q, lambda, &mut hess);
        if pass == 0 {
            hess.freeze();
        } else {
            hess.finish().expect("fixed multiplier Hessian pattern");
        }
    }
    let hess = dense(&hess, n, n);
    let mut contracted = Triplets::new();
    contracted.begin();
    c.contracted_derivative(q, w, &mut contracted);
    let contracted = dense(&contracted, m, n);
    for l in 0..n {
        let dl = central(q, l, &mut |x| {
            let ax = forms(x);
            (0..n)
                .map(|j| (0..m).map(|r| lambda[r] * ax[r][j]).sum())
                .collect()
        });
        let dw = central(q, l, &mut |x| {
            let ax = forms(x);
            (0..m)
                .map(|r| (0..n).map(|j| w[j] * ax[r][j]).sum())
                .collect()
        });
        for j in 0..n {
            close(hess[j][l], dl[j], &format!("Σλ ∂A_{j}/∂q{l}"));
        }
        for r in 0..m {
            close(contracted[r][l], dw[r], &format!("Σw ∂A{r}/∂q{l}"));
        }
    }
}

/// A deterministic pseudo-random vector in [−1, 1] (a linear congruential sequence).
pub fn pseudo_random(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        })
        .collect()
}

/// The complete elliptic integral of the first kind `K(k)`, `k² = m < 1`, by the arithmetic-
/// geometric mean: `K = π / (2 AGM(1, √(1 − m)))` (converges quadratically to round-off).
pub fn elliptic_k(m: f64) -> f64 {
    let (mut a, mut b) = (1.0_f64, (1.0 - m).sqrt());
    for _ in 0..40 {
        let (an, bn) = (0.5 * (a + b), (a * b).sqrt());
        if (an - bn).abs() <= 1e-16 * an {
            a = an;
            break;
        }
        (a, b) = (an, bn);
    }
    std::f64::consts::PI / (2.0 * a)
}

/// Times at which `samples` (values at `t₀ + k h`) cross zero upwards, by cubic interpolation
/// through the four samples around each sign change.
pub fn upward_crossings(samples: &[f64], h: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for k in 1..samples.len().saturating_sub(2) {
        if samples[k] < 0.0 && samples[k + 1] >= 0.0 {
            let y = [samples[k - 1], samples[k], samples[k + 1], samples[k + 2]];
            // Lagrange cubic through nodes −1, 0, 1, 2; Newton iterations from the linear guess.
            let p = |s: f64| {
                -y[0] * s * (s - 1.0) * (s - 2.0) / 6.0
                    + y[1] * (s + 1.0) * (s - 1.0) * (s - 2.0) / 2.0
                    - y[2] * (s + 1.0) * s * (s - 2.0) / 2.0
                    + y[3] * (s + 1.0) * s * (s - 1.0) / 6.0
            };
            let mut s = -y[1] / (y[2] - y[1]);
            for _ in 0..20 {
                let d = (p(s + 1e-7) - p(s - 1e-7)) / 2e-7;
                let step = p(s) / d;
                s -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            out.push((k as f64 + s) * h);
        }
    }
    out
}
