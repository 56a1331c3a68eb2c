//! A spatial pendulum chain: rods joined end to end by spherical joints, hanging from a spherical
//! joint at the origin under gravity along `−z`, released from a non-planar (helical) pose while
//! turning about the vertical ([`SphericalChain`]).
//!
//! Rotations of space about the `z` axis leave the discrete Lagrangian (kinetic terms, gravity
//! along `z`) and every joint row (the suspension point lies on the axis) invariant, so the
//! discrete Noether theorem keeps the vertical angular momentum about the suspension point,
//! `L_z = Σ e_z·(xᵢ × p_{x,i} + Rᵢ Πᵢ)`, to round-off; constraint impulses carried in `p` pair to
//! zero with that rotation. The joints are held at position level every step (to the Newton
//! tolerance), and the energy of the variational step stays in a band without drift.
//!
//! One link is a symmetric heavy top pivoted on its axis (Lagrange's top): with `u = cos θ` (the
//! angle of the rod from the downward vertical), energy, `L_z` and the spin momentum `b = C ω₃`
//! give `u̇² = f(u) = (1 − u²)(e + c u) − (l + β u)²` (`e = 2E′/A`, `c = 2 m g ℓ/A`, `l = L_z/A`,
//! `β = b/A`, `E′` the energy without the spin term, `A` and `C` the moments about the pivot across
//! and along the rod, `ℓ` the pivot's distance from the centre of mass). The cubic's roots
//! `u₀ < −1 ≤ u_a ≤ u_b ≤ 1` are the turning points, and the nutation period is
//! `T = 4 K(k) / √(c (u_b − u₀))`, `k² = (u_b − u_a)/(u_b − u₀)` (the integral of `du/√f` between
//! the turning points, Byrd & Friedman 233.00; Goldstein §5.7). The run's turning points and
//! period converge to these at order 2.

mod common;

use common::{Run, elliptic_k, trapezoid, upward_crossings};
use dirac_core::{Constraints, LagrangianHessian, Model, Triplets};
use dirac_graph::Representation;
use dirac_rigid::mechanisms::SphericalChain;
use dirac_rigid::{RigidBody, so3};
use nalgebra::{DMatrix, DVector};

/// The chain's run at step `h`.
fn chain_run(chain: &SphericalChain, h: f64) -> Run {
    let m = chain.build().expect("chain");
    Run::new(
        &m.graph,
        Representation::Monolithic,
        trapezoid(h),
        &m.q0,
        &m.v0,
    )
}

/// `L_z` about the origin: the sum of the links' spatial angular momenta.
fn vertical_momentum(run: &Run, links: usize) -> f64 {
    (0..links)
        .map(|i| RigidBody::spatial_angular_momentum(run.body_q(i), run.body_p(i))[2])
        .sum()
}

/// The largest joint gap `|O_A − O_B|` and the largest `|RᵀR − I|` over the links.
fn joint_gaps(run: &Run, chain: &SphericalChain) -> (f64, f64) {
    let end = |i: usize, sign: f64| {
        let q = run.body_q(i);
        let d = so3::apply(
            &RigidBody::rotation(q),
            &[sign * 0.5 * chain.length, 0.0, 0.0],
        );
        [q[0] + d[0], q[1] + d[1], q[2] + d[2]]
    };
    let (mut gap, mut orth) = (0.0_f64, 0.0_f64);
    for i in 0..chain.links {
        let b = end(i, -1.0);
        let a = if i == 0 { [0.0; 3] } else { end(i - 1, 1.0) };
        gap = gap.max(common::norm(&[a[0] - b[0], a[1] - b[1], a[2] - b[2]]));
        orth = orth.max(so3::orthonormality_error(&RigidBody::rotation(
            run.body_q(i),
        )));
    }
    (gap, orth)
}

/// `E = v·∂L/∂v − L` at `(q_k, p_k)`, with `v` the `M`-orthogonal projection of `M⁻¹p_k` onto the
/// constraints' tangent space: `[M Aᵀ; A 0][v; μ] = [p; 0]` (as the chain bench does).
fn energy(run: &Run) -> f64 {
    let (q, p) = (run.integrator().q(), run.integrator().p());
    let n = q.len();
    let model = run.integrator().model();
    let mut hessian = LagrangianHessian::default();
    hessian.begin();
    model.lagrangian_hessian(q, &vec![0.0; n], &mut hessian);
    let c = run.integrator().active_constraints();
    let m = c.count();
    let mut kkt = DMatrix::zeros(n + m, n + m);
    for (r, col, val) in hessian.vv.iter() {
        kkt[(r, col)] += val;
    }
    let mut forms = Triplets::new();
    forms.begin();
    c.forms(q, &mut forms);
    for (a, j, val) in forms.iter() {
        kkt[(n + a, j)] += val;
        kkt[(j, n + a)] += val;
    }
    let mut rhs = DVector::zeros(n + m);
    for i in 0..n {
        rhs[i] = p[i];
    }
    let v = kkt.lu().solve(&rhs).expect("KKT matrix is regular");
    let v: Vec<f64> = v.iter().take(n).copied().collect();
    let (mut lq, mut lv) = (vec![0.0; n], vec![0.0; n]);
    model.lagrangian_gradient(q, &v, &mut lq, &mut lv);
    v.iter().zip(&lv).map(|(a, b)| a * b).sum::<f64>() - model.lagrangian(q, &v)
}

/// Links of the long run, its step and number of steps (30 s of motion).
const LINKS: usize = 5;
const H: f64 = 1e-3;
const STEPS: usize = 30_000;

/// `L_z` allowed to change, relative to its initial value (0.343 kg·m²/s), over the run: round-off
/// accumulating over 3·10⁴ steps (measured 6.6e-15).
const MOMENTUM_ROUNDOFF: f64 = 1e-12;
/// Joint gaps and `|RᵀR − I|` at every step: the Newton tolerance on the rows (measured 6.7e-16 m
/// and 2.0e-14).
const JOINT_HELD: f64 = 1e-14;
const ORTHONORMAL: f64 = 1e-13;
/// Energy band `max |E − E₀| / |E₀|` at h = 1e-3, sampled every 10 steps as the chain bench does
/// (`E₀ = −14.84 J`; measured 4.6e-5: the O(h²) band of the variational step), and the allowed
/// change of the mean of `(E − E₀)/|E₀|` between the first and the last tenth of the run
/// (measured 5.5e-7: no drift).
const ENERGY_BAND: f64 = 5e-4;
const ENERGY_DRIFT: f64 = 1e-5;

/// A five-link spatial chain released from a helical pose while turning at 2 rad/s about the
/// vertical, h = 1e-3, 3·10⁴ steps: `L_z` constant to round-off, every joint and `RᵀR = I` held to
/// round-off, the energy in an O(h²) band without drift.
///
/// Mutations seen to fail (tests/mutations.md RB1–RB5): gravity tilted by 1e-3 rad (`L_z` changes
/// by 5.8e-3: no symmetry about `z`); Newton stopped at `residual_tol = 1e-6` (`L_z` 5.0e-8,
/// `RᵀR − I` 7.5e-7); the gap measured to 1.001 × the joint's offset (3.0e-4 m); h = 4e-3 (band
/// 9.3e-4); a 1e-3 N·s/m damper on the last link's `x` (band 1.3e-3, drift −1.2e-3).
#[test]
fn spatial_chain_keeps_its_vertical_momentum() {
    let f = measure(LINKS, STEPS);
    let (dlz, gap, orth, band, drift) = (f.dlz, f.gap, f.orth, f.band, f.drift);
    assert!(dlz <= MOMENTUM_ROUNDOFF, "L_z changed by {dlz:e}");
    assert!(gap <= JOINT_HELD, "joint gap {gap:e}");
    assert!(orth <= ORTHONORMAL, "RᵀR − I = {orth:e}");
    assert!(band <= ENERGY_BAND, "energy band {band:e}");
    assert!(drift.abs() <= ENERGY_DRIFT, "energy drifts by {drift:e}");
}

/// The figures of one chain run.
struct Figures {
    dlz: f64,
    gap: f64,
    orth: f64,
    band: f64,
    drift: f64,
}

/// Runs the bundled chain with `links` links for `steps` steps at h = [`H`]: the largest relative
/// change of `L_z`, joint gap and `|RᵀR − I|`, the energy band (every 10th step) and the drift of
/// its mean from the first to the last tenth.
fn measure(links: usize, steps: usize) -> Figures {
    let chain = SphericalChain::bundled(links);
    let mut run = chain_run(&chain, H);
    let lz0 = vertical_momentum(&run, links);
    let e0 = energy(&run);
    let (mut dlz, mut gap, mut orth) = (0.0_f64, 0.0_f64, 0.0_f64);
    let mut band = 0.0_f64;
    let mut tenths = [(0.0_f64, 0_usize); 10];
    for k in 0..steps {
        run.step();
        dlz = dlz.max((vertical_momentum(&run, links) - lz0).abs() / lz0.abs());
        let (g, o) = joint_gaps(&run, &chain);
        (gap, orth) = (gap.max(g), orth.max(o));
        if k % 10 == 9 {
            let de = (energy(&run) - e0) / e0.abs();
            band = band.max(de.abs());
            let t = &mut tenths[k * 10 / steps];
            (t.0, t.1) = (t.0 + de, t.1 + 1);
        }
    }
    let mean = |t: (f64, usize)| t.0 / t.1 as f64;
    let drift = mean(tenths[9]) - mean(tenths[0]);
    println!(
        "{links} links, {steps} steps: L_z0 = {lz0:.6}, ΔL_z {dlz:.2e}; joint gap {gap:.1e} m, RᵀR − I {orth:.1e}; E0 = {e0:.6} J, band {band:.2e}, drift of the mean {drift:.1e}"
    );
    Figures {
        dlz,
        gap,
        orth,
        band,
        drift,
    }
}

/// Chains of 3 and 10 links, 5000 steps each: `L_z`, the joints and `RᵀR = I` to round-off, as
/// for five links (the same allowances; measured 8.9e-15 and 7.9e-15, 2.3e-16 m and 1.3e-15 m,
/// 4.4e-16 and 2.8e-14), and the energy in the band (measured 1.1e-5 and 7.6e-5 of `|E₀|`).
///
/// Mutation seen to fail (tests/mutations.md RB17): gravity tilted by 1e-3 rad, as in RB1 (3 links:
/// `L_z` changes by 5.6e-3).
#[test]
fn spatial_chains_of_three_and_ten_links() {
    for links in [3, 10] {
        let f = measure(links, 5000);
        assert!(f.dlz <= MOMENTUM_ROUNDOFF, "{links} links: L_z {:e}", f.dlz);
        assert!(f.gap <= JOINT_HELD, "{links} links: gap {:e}", f.gap);
        assert!(f.orth <= ORTHONORMAL, "{links} links: RᵀR − I {:e}", f.orth);
        assert!(f.band <= ENERGY_BAND, "{links} links: band {:e}", f.band);
    }
}

/// The real roots of `−c u³ + a₂ u² + a₁ u + a₀` (three, ascending), by bisection to round-off
/// in the brackets the cubic's critical points give.
fn cubic_roots(coefficients: [f64; 4]) -> [f64; 3] {
    let [c3, c2, c1, c0] = coefficients;
    let f = |u: f64| ((c3 * u + c2) * u + c1) * u + c0;
    // Critical points of the cubic: roots of 3c₃u² + 2c₂u + c₁.
    let disc = (c2 * c2 - 3.0 * c3 * c1).sqrt();
    let (s1, s2) = ((-c2 + disc) / (3.0 * c3), (-c2 - disc) / (3.0 * c3));
    let (lo, hi) = (s1.min(s2), s1.max(s2));
    let bisect = |mut a: f64, mut b: f64| {
        for _ in 0..200 {
            let mid = 0.5 * (a + b);
            if (f(mid) > 0.0) == (f(a) > 0.0) {
                a = mid;
            } else {
                b = mid;
            }
        }
        0.5 * (a + b)
    };
    [
        bisect(lo - 100.0, lo),
        bisect(lo, hi),
        bisect(hi, hi + 100.0),
    ]
}

/// `cos θ` of the rod (its axis against the downward vertical) at every step of a one-link run.
fn nutation(chain: &SphericalChain, h: f64, t_end: f64) -> Vec<f64> {
    let mut run = chain_run(chain, h);
    let steps = (t_end / h).round() as usize;
    let mut u = vec![-RigidBody::rotation(run.body_q(0))[2][0]];
    for _ in 0..steps {
        run.step();
        u.push(-RigidBody::rotation(run.body_q(0))[2][0]);
    }
    u
}

/// Errors of the one-link run against the closed form allowed at h = 1e-3: turning points
/// (measured 9.5e-9 and 2.8e-7 in `cos θ`) and period (measured 3.1e-6 relative); and the range of
/// the error ratio when h halves (order 2: 4; measured 4.02).
const TURNING: f64 = 1e-5;
const PERIOD: f64 = 1e-4;
const RATIO: std::ops::RangeInclusive<f64> = 3.5..=4.5;

/// One link (N = 1) of the chain is Lagrange's top: the run's turning points of `cos θ` and its
/// nutation period converge at order 2 to the roots of the cubic `f(u)` and to
/// `4 K(k)/√(c (u_b − u₀))`, with `E′`, `L_z` and the spin `b` of the stated initial state. The run
/// starts at a turning point (`θ̇ = 0`), so `u_a` is the initial `cos θ`.
///
/// Mutations seen to fail (tests/mutations.md RB6–RB8): `ℓ` written as the full rod length in `m g ℓ`
/// (turning point off by 5.9e-3, period by 0.42); the spin term `β` left out of `f` (turning
/// points off by 1.5e-4, error ratio 2.3); the run at 1.001 g (turning point 1.2e-5, period
/// 5.0e-4).
#[test]
fn one_link_is_lagranges_top() {
    let chain = SphericalChain::bundled(1);
    let link = chain.link().expect("link");
    let m = chain.build().expect("chain");
    let (q0, v0) = (&m.q0[0], &m.v0[0]);
    // Moments about the pivot: across the rod (parallel axes) and along it.
    let ell = 0.5 * chain.length;
    let (a, c_axis) = (
        link.inertia()[1][1] + chain.mass * ell * ell,
        link.inertia()[0][0],
    );
    let r = RigidBody::rotation(q0);
    let omega = RigidBody::body_angular_velocity(q0, v0);
    // Axis e (space), its rate ė = R (Ω × e_x); spin momentum b = C Ω₁.
    let e = [r[0][0], r[1][0], r[2][0]];
    let edot = so3::apply(&r, &so3::cross(&omega, &[1.0, 0.0, 0.0]));
    let b = c_axis * omega[0];
    let u0 = -e[2];
    let lz = a * (e[0] * edot[1] - e[1] * edot[0]) + b * e[2];
    let mgl = chain.mass * chain.g * ell;
    let energy = 0.5 * a * so3::dot(&edot, &edot) - mgl * u0;
    let (ce, cc, cl, cb) = (2.0 * energy / a, 2.0 * mgl / a, lz / a, b / a);
    // f(u) = (1 − u²)(e + c u) − (l + β u)² = −c u³ − (e + β²) u² + (c − 2 l β) u + e − l².
    let [root0, ua, ub] = cubic_roots([-cc, -(ce + cb * cb), cc - 2.0 * cl * cb, ce - cl * cl]);
    let k2 = (ub - ua) / (ub - root0);
    let period = 4.0 * elliptic_k(k2) / (cc * (ub - root0)).sqrt();
    println!(
        "Lagrange's top: roots {root0:.9}, {ua:.9}, {ub:.9} (start u = {u0:.9}), period {period:.9} s"
    );
    let t_end = 6.0 * period;
    let mut errors = Vec::new();
    for h in [2e-3, 1e-3] {
        let u = nutation(&chain, h, t_end);
        // Extremes after the first half period (the run starts at the lower turning point).
        let later = &u[(0.5 * period / h) as usize..];
        let lo = later.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = later.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mid: Vec<f64> = u.iter().map(|x| x - 0.5 * (ua + ub)).collect();
        let crossings = upward_crossings(&mid, h);
        let measured =
            (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
        let (eu, ep) = (
            (lo - ua).abs().max((hi - ub).abs()),
            (measured / period - 1.0).abs(),
        );
        println!(
            "h = {h:e}: turning points {lo:.9}, {hi:.9} (errors {:.1e}, {:.1e}), period {measured:.9} s over {} crossings (error {ep:.2e})",
            lo - ua,
            hi - ub,
            crossings.len()
        );
        errors.push((eu, ep));
    }
    let (eu, ep) = errors[1];
    assert!(eu <= TURNING, "turning points off by {eu:e}");
    assert!(ep <= PERIOD, "period off by {ep:e}");
    let ratio = errors[0].1 / errors[1].1;
    assert!(RATIO.contains(&ratio), "period not order 2: {errors:?}");
}
