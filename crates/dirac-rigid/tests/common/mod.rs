//! Shared helpers of the rigid-body tests: running an interconnection, an independent Lie group
//! variational integrator on `SO(3)`, and small matrix utilities.

#![allow(dead_code)]

use dirac_core::Discretisation;
use dirac_graph::{AssembledSystem, Assembler, Interconnection, Representation, SubsystemId};
use dirac_rigid::so3::{self, Mat3};
use dirac_rigid::{Joint, JointFrame, JointKind, RigidBody, Side};
use dirac_sim::{Integrator, IntegratorOptions};
use num_dual::{Dual64, DualNum};

/// An assembled graph with its integrator.
pub struct Run {
    pub system: AssembledSystem,
    pub sim: Integrator<dirac_graph::AssembledModel, dirac_graph::AssembledConstraints>,
}

impl Run {
    /// Assembles `graph` in `representation`, builds an integrator with `options` and initialises
    /// it at per-subsystem positions `q0` and rates `v0` (in the graph's subsystem order).
    pub fn new(
        graph: &Interconnection,
        representation: Representation,
        options: IntegratorOptions,
        q0: &[Vec<f64>],
        v0: &[Vec<f64>],
    ) -> Self {
        let system = Assembler::assemble(graph, representation).expect("assembles");
        let names: Vec<String> = graph
            .subsystems()
            .iter()
            .map(|s| s.name().to_string())
            .collect();
        let q = system.global_vector(q0, &names).expect("q0");
        let v = system.global_vector(v0, &names).expect("v0");
        let mut sim = Integrator::new(system.model.clone(), system.constraints.clone(), options)
            .expect("options");
        sim.initialise(&q, &v, 0.0)
            .expect("consistent initial state");
        Self { system, sim }
    }

    /// The twelve coordinates of subsystem `s` (a body) in `sim.q()`.
    pub fn body_q(&self, s: usize) -> &[f64] {
        let o = self.system.global_index(SubsystemId(s), 0);
        &self.sim.q()[o..o + 12]
    }

    /// The twelve momenta of subsystem `s` (a body) in `sim.p()`.
    pub fn body_p(&self, s: usize) -> &[f64] {
        let o = self.system.global_index(SubsystemId(s), 0);
        &self.sim.p()[o..o + 12]
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
    let mut out = [[z; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let mut h2 = z;
            for k in 0..3 {
                h2 += hat[i][k] * hat[k][j];
            }
            out[i][j] = c * (hat[i][j] + h2) + D::from(if i == j { 1.0 } else { 0.0 });
        }
    }
    out
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
        let z = D::from(0.0);
        let mut a = [[z; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    a[i][j] += fm[i][k] * self.jd[k][j] - fm[j][k] * self.jd[i][k];
                }
            }
        }
        [a[2][1], a[0][2], a[1][0]]
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
            let mut jac = [[0.0; 3]; 3];
            for c in 0..3 {
                let fd = [0, 1, 2].map(|i| Dual64::new(f[i], if i == c { 1.0 } else { 0.0 }));
                let gd = self.torque_map(&fd);
                for r in 0..3 {
                    jac[r][c] = gd[r].eps;
                }
            }
            let delta = solve3(&jac, &res);
            for i in 0..3 {
                f[i] -= delta[i];
            }
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
