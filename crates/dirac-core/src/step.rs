//! Residual and Jacobian of one forced discrete Dirac step (MATH §3–§4).

use dirac_solve::Triplets;

use crate::constraints::{ConstraintKind, Constraints};
use crate::discretisation::Discretisation;
use crate::model::{ForceJacobian, LagrangianHessian, Model};
use crate::path::NodeTable;

/// Fills the path value `y = q_k + Σ ℓ_l Z^l` and velocity `w = Σ ℓ_l' Z^l / h` at a node with
/// basis row (`phi`, `dphi`) (the basis sums to one and its derivative to zero).
#[inline]
fn eval_path(
    y: &mut [f64],
    w: &mut [f64],
    q0: &[f64],
    x: &[f64],
    phi: &[f64],
    dphi: &[f64],
    h: f64,
) {
    let n = q0.len();
    let inv_h = 1.0 / h;
    // The first control point initialises (no memcpy/memset calls on tiny slices).
    let (a, b) = (phi[1], dphi[1] * inv_h);
    for (((yk, wk), q), z) in y.iter_mut().zip(w.iter_mut()).zip(q0).zip(&x[..n]) {
        *yk = q + a * z;
        *wk = b * z;
    }
    for l in 2..phi.len() {
        let (a, b) = (phi[l], dphi[l] * inv_h);
        for ((yk, wk), z) in y.iter_mut().zip(w.iter_mut()).zip(&x[(l - 1) * n..l * n]) {
            *yk += a * z;
            *wk += b * z;
        }
    }
}

/// `y += a·x`.
#[inline]
fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    for (yk, xk) in y.iter_mut().zip(x) {
        *yk += a * xk;
    }
}

/// `y += a·x + b·z`.
#[inline]
fn axpy2(y: &mut [f64], a: f64, x: &[f64], b: f64, z: &[f64]) {
    for ((yk, xk), zk) in y.iter_mut().zip(x).zip(z) {
        *yk += a * xk + b * zk;
    }
}

/// Adds a force `f` at a node of weight `hb = h·b` to `E₀` (weight one: the start's share is what
/// the later control points leave) and to `S¹ … S^s` in `later` (weights `ℓ_l`).
fn add_weighted_force(e0: &mut [f64], later: &mut [f64], f: &[f64], phi: &[f64], hb: f64) {
    let n = f.len();
    axpy(e0, hb, f);
    for (l, block) in later.chunks_exact_mut(n).enumerate() {
        let c = hb * phi[l + 1];
        if c != 0.0 {
            axpy(block, c, f);
        }
    }
}

/// One Jacobian block's derivative terms summed over the quadrature nodes: `values` holds each
/// node's derivative values in turn (every node the same pattern), `segments` the `(offset, len)`
/// of each kind of term within a node's values, and `weights(ℓ(cᵢ), ℓ'(cᵢ), bᵢ)` each kind's weight
/// at node `i`. Writes the sums kind after kind into `sums` and returns which kinds have a
/// nonzero weight at some node (the others are not stamped).
fn sum_over_nodes<const K: usize>(
    nodes: &NodeTable,
    values: &[f64],
    segments: [(usize, usize); K],
    weights: impl Fn(&[f64], &[f64], f64) -> [f64; K],
    sums: &mut Vec<f64>,
) -> [bool; K] {
    let per_node = values.len() / nodes.len().max(1);
    sums.clear();
    sums.resize(segments.iter().map(|&(_, len)| len).sum(), 0.0);
    let mut used = [false; K];
    for i in 0..nodes.len() {
        let (phi, dphi) = nodes.row(i);
        let at = &values[i * per_node..(i + 1) * per_node];
        let mut o = 0;
        for (k, (weight, (offset, len))) in weights(phi, dphi, nodes.weights[i])
            .into_iter()
            .zip(segments)
            .enumerate()
        {
            used[k] |= weight != 0.0;
            axpy(&mut sums[o..o + len], weight, &at[offset..offset + len]);
            o += len;
        }
    }
    used
}

/// Which forced discrete Dirac integrator (MATH §4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Flavour {
    /// `ωᵃ(q_k)·(q_{k+1} − q_k) = 0`, constraint impulse on `p_k`.
    Plus,
    /// `ωᵃ(q_{k+1})·(q_k − q_{k+1}) = 0`, in the look-ahead form: the impulse of step `k` is
    /// solved at step `k + 1` together with `q_{k+2}`, so the carried momentum `p̃` excludes it.
    Minus,
}

/// Where a constraint covector is evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Point {
    Start,
    Control(usize),
}

/// The equations of one step from `(q_k, p_k, t_k)` with a Galerkin discretisation of degree `s`.
///
/// Unknowns `x = [Z¹ … Z^s, Λ⁰ … Λ^{s−1}]`: the control-point increments `Z^l = Q^l − q_k`, then
/// one multiplier vector per stationarity equation. Solving for increments keeps round-off
/// relative to `h·v` rather than to `q`: the velocity `Σ ℓ_l'(σ) Z^l / h` involves no cancellation. With `S_j = h Σᵢ bᵢ [ℓⱼ(cᵢ)(∂L/∂q + f) + ℓⱼ'(cᵢ)/h ∂L/∂v]` the equations are
///
/// ```text
/// E₀:  p_k + S₀ − Aᵀ(P₀) Λ⁰ = 0            (p_k = −D₁L_d − f_d⁻ + constraint impulse)
/// Eⱼ:  Sⱼ − Aᵀ(Pⱼ) Λʲ = 0,  j = 1..s−1     (interior stationarity)
/// C_l: Aᵃ(P)·(Q^l − q_k) = 0 or gᵃ(Q^l) = 0,  l = 1..s
/// ```
///
/// and afterwards `p_{k+1} = S_s = D₂L_d + f_d⁺`. Constraints hold at every control point, so
/// degenerate coordinates (massless endpoints, capacitor charges) are determined at interior
/// points too (MATH §5). With `m = 0` this is the forced discrete Hamiltonian map (MATH §3).
#[derive(Debug, Clone)]
pub struct ForcedDiracStep {
    n: usize,
    m: usize,
    s: usize,
    h: f64,
    flavour: Flavour,
    lagrangian_nodes: NodeTable,
    force_nodes: NodeTable,
    /// The force rule is the Lagrangian rule (every equivalence-preserving discretisation): forces
    /// are evaluated at the path points already computed for `∂L`.
    shared_nodes: bool,
    kinds: Vec<ConstraintKind>,
    has_holonomic: bool,
    q0: Vec<f64>,
    p0: Vec<f64>,
    t0: f64,
    y: Vec<f64>,
    w: Vec<f64>,
    lq: Vec<f64>,
    lv: Vec<f64>,
    f: Vec<f64>,
    dq: Vec<f64>,
    point: Vec<f64>,
    mask: Vec<f64>,
    hessian: LagrangianHessian,
    force_jacobian: ForceJacobian,
    forms: Triplets,
    curvature: Triplets,
    contracted: Triplets,
    /// Whether `forms` holds the covectors at `q_k` of the current start (they are reused by every
    /// residual evaluation of the step).
    forms_at_start: bool,
    g: Vec<f64>,
    /// `S¹ … S^s` while `E₀` is assembled from them (degree ≥ 2, see `add_start_stationarity`).
    later: Vec<f64>,
    /// Derivative values at every quadrature node while the Jacobian sums them (node-major).
    node_values: Vec<f64>,
    /// One Jacobian block's derivative terms summed over the nodes.
    node_sums: Vec<f64>,
    /// Where a Jacobian block's Hessian terms land, one merge per set of Hessian kinds a block
    /// uses (built at the first stamp that needs it): a merge depends only on the Hessian's
    /// pattern and on that set, so the blocks share a few (one or two in practice).
    merge_kinds: Vec<([bool; 4], BlockMerge)>,
    /// One block's entries at its distinct positions.
    merged: Vec<f64>,
}

/// How the Hessian terms of one Jacobian block (`H_qq`, `H_qv`, `H_vq = H_qvᵀ`, `H_vv`, each
/// summed over the nodes) land on the block's distinct positions, so the block is stamped with
/// one entry per position instead of one per term (a quarter for a dense Hessian).
#[derive(Debug, Clone)]
struct BlockMerge {
    /// Distinct `(row, col)` in the block, in order of first appearance.
    positions: Vec<(usize, usize)>,
    /// For every term, in the order `H_qq`, `H_qv`, `H_vq`, `H_vv`, its position; `None` where
    /// that kind's weight is zero at every node (the term is not stamped, as before merging).
    slot: Vec<Option<usize>>,
}

impl BlockMerge {
    fn new(hess: &LagrangianHessian, used: [bool; 4]) -> Self {
        let count = hess.qq.len() + 2 * hess.qv.len() + hess.vv.len();
        let mut index = std::collections::HashMap::with_capacity(count);
        let mut positions = Vec::with_capacity(count);
        let mut slot = Vec::with_capacity(count);
        let terms = hess
            .qq
            .iter()
            .map(|(r, c, _)| (0, r, c))
            .chain(hess.qv.iter().map(|(r, c, _)| (1, r, c)))
            .chain(hess.qv.iter().map(|(r, c, _)| (2, c, r)))
            .chain(hess.vv.iter().map(|(r, c, _)| (3, r, c)));
        for (kind, r, c) in terms {
            slot.push(used[kind].then(|| {
                *index.entry((r, c)).or_insert_with(|| {
                    positions.push((r, c));
                    positions.len() - 1
                })
            }));
        }
        Self { positions, slot }
    }
}

impl ForcedDiracStep {
    /// A step for `model` with `constraints`, `discretisation`, `flavour` and step size `h`.
    pub fn new<M: Model + ?Sized, C: Constraints + ?Sized>(
        model: &M,
        constraints: &C,
        discretisation: &Discretisation,
        flavour: Flavour,
        h: f64,
    ) -> Self {
        let n = model.dim();
        let m = constraints.count();
        let s = discretisation.path().degree();
        let kinds: Vec<ConstraintKind> = (0..m).map(|a| constraints.kind(a)).collect();
        let has_holonomic = kinds.contains(&ConstraintKind::Holonomic);
        let (lagrangian_rule, force_rule) = (
            discretisation.lagrangian_rule(),
            discretisation.force_rule(),
        );
        Self {
            n,
            m,
            s,
            h,
            flavour,
            lagrangian_nodes: NodeTable::new(discretisation.path(), lagrangian_rule),
            force_nodes: NodeTable::new(discretisation.path(), force_rule),
            shared_nodes: lagrangian_rule.nodes() == force_rule.nodes()
                && lagrangian_rule.weights() == force_rule.weights(),
            kinds,
            has_holonomic,
            q0: vec![0.0; n],
            p0: vec![0.0; n],
            t0: 0.0,
            y: vec![0.0; n],
            w: vec![0.0; n],
            lq: vec![0.0; n],
            lv: vec![0.0; n],
            f: vec![0.0; n],
            dq: vec![0.0; n],
            point: vec![0.0; n],
            mask: vec![0.0; m],
            hessian: LagrangianHessian::default(),
            force_jacobian: ForceJacobian::default(),
            forms: Triplets::new(),
            curvature: Triplets::new(),
            contracted: Triplets::new(),
            forms_at_start: false,
            g: vec![0.0; m],
            later: vec![0.0; s * n],
            node_values: Vec::new(),
            node_sums: Vec::new(),
            merge_kinds: Vec::new(),
            merged: Vec::new(),
        }
    }

    /// Number of coordinates `n`.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Number of constraint rows `m`.
    #[must_use]
    pub fn constraint_count(&self) -> usize {
        self.m
    }

    /// Path degree `s`.
    #[must_use]
    pub fn degree(&self) -> usize {
        self.s
    }

    /// Step size.
    #[must_use]
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// Changes the step size (the Newton matrix of a linear model changes with it).
    pub fn set_step_size(&mut self, h: f64) {
        self.h = h;
    }

    /// The flavour.
    #[must_use]
    pub fn flavour(&self) -> Flavour {
        self.flavour
    }

    /// Number of unknowns `s(n + m)`.
    #[must_use]
    pub fn unknowns(&self) -> usize {
        self.s * (self.n + self.m)
    }

    /// Offset of the increment `Z^l = Q^l − q_k` (`l = 1..=s`) in the unknown vector.
    #[must_use]
    pub fn control_offset(&self, l: usize) -> usize {
        (l - 1) * self.n
    }

    /// Offset of multiplier vector `Λʲ` (`j = 0..s`) in the unknown vector.
    #[must_use]
    pub fn multiplier_offset(&self, j: usize) -> usize {
        self.s * self.n + j * self.m
    }

    /// Index of the first equation of block `Eⱼ` (`j = 0..s`), or of `C_l` via
    /// [`ForcedDiracStep::constraint_row`].
    #[must_use]
    pub fn stationarity_row(&self, j: usize) -> usize {
        j * self.n
    }

    /// Index of the first equation of constraint block `C_l` (`l = 1..=s`).
    #[must_use]
    pub fn constraint_row(&self, l: usize) -> usize {
        self.s * self.n + (l - 1) * self.m
    }

    /// Sets the start of the step: `q_k`, the carried momentum `p_k` and `t_k`.
    pub fn set_start(&mut self, q: &[f64], p: &[f64], t: f64) {
        self.q0.copy_from_slice(q);
        self.p0.copy_from_slice(p);
        self.t0 = t;
        self.forms_at_start = false;
    }

    /// `q_k`.
    #[must_use]
    pub fn start_position(&self) -> &[f64] {
        &self.q0
    }

    /// Writes the end point `q_{k+1} = q_k + Z^s` of an unknown vector into `q1`.
    pub fn end_position(&self, x: &[f64], q1: &mut [f64]) {
        let o = self.control_offset(self.s);
        for ((out, q), z) in q1.iter_mut().zip(&self.q0).zip(&x[o..o + self.n]) {
            *out = q + z;
        }
    }

    /// Whether the Newton matrix is constant for this model and constraint set at fixed `h`.
    pub fn jacobian_is_constant<M: Model + ?Sized, C: Constraints + ?Sized>(
        &self,
        model: &M,
        constraints: &C,
    ) -> bool {
        model.is_linear() && constraints.is_constant()
    }

    /// Where the covector of a row of `kind` is evaluated in stationarity equation `j`.
    fn multiplier_point(&self, kind: ConstraintKind, j: usize) -> Point {
        match (kind, self.flavour) {
            _ if j == 0 => Point::Start,
            (ConstraintKind::Holonomic, _) => Point::Control(j),
            (ConstraintKind::OneForm, Flavour::Plus) => Point::Start,
            (ConstraintKind::OneForm, Flavour::Minus) => Point::Control(self.s),
        }
    }

    /// Where the covector of a one-form row is evaluated in the kinematic constraint.
    fn kinematic_point(&self) -> Point {
        match self.flavour {
            Flavour::Plus => Point::Start,
            Flavour::Minus => Point::Control(self.s),
        }
    }

    /// Whether the residual needs the covectors at point `p`: as a multiplier covector of some
    /// stationarity block, or in a one-form's kinematic row. With a linear path in the (+) flavour
    /// only `q_k` is (holonomic rows then enter the residual through their values alone).
    fn residual_uses(&self, p: Point) -> bool {
        match p {
            Point::Start => true,
            Point::Control(l) => {
                let one_form = self.kinds.contains(&ConstraintKind::OneForm);
                (self.has_holonomic && l < self.s)
                    || (one_form
                        && (self.kinematic_point() == p
                            || (1..self.s)
                                .any(|j| self.multiplier_point(ConstraintKind::OneForm, j) == p)))
            }
        }
    }

    /// Loads the position of point `p` into `self.point`.
    fn load_point(&mut self, x: &[f64], p: Point) {
        self.point.copy_from_slice(&self.q0);
        if let Point::Control(l) = p {
            let o = (l - 1) * self.n;
            for (out, z) in self.point.iter_mut().zip(&x[o..o + self.n]) {
                *out += z;
            }
        }
    }

    /// Number of points at which constraint covectors are needed: `q_k`, then `Q¹ … Q^s` when a
    /// holonomic row or the (−) flavour evaluates covectors at control points.
    fn constraint_point_count(&self) -> usize {
        if self.m == 0 {
            0
        } else if self.has_holonomic || self.flavour == Flavour::Minus {
            self.s + 1
        } else {
            1
        }
    }

    fn eval_forms<C: Constraints + ?Sized>(&mut self, constraints: &C, x: &[f64], p: Point) {
        if self.forms.is_frozen() && constraints.is_constant() {
            // Constant forms were stamped once; their values do not depend on the point.
            return;
        }
        if p == Point::Start && self.forms_at_start {
            return;
        }
        self.forms_at_start = p == Point::Start;
        self.load_point(x, p);
        let mut forms = std::mem::take(&mut self.forms);
        forms.begin();
        constraints.forms(&self.point, &mut forms);
        if !forms.is_frozen() {
            forms.freeze();
        }
        self.forms = forms;
    }

    /// Evaluates the step equations `r = F(x)`.
    pub fn residual<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        model: &M,
        constraints: &C,
        x: &[f64],
        r: &mut [f64],
    ) {
        let (n, s) = (self.n, self.s);
        r.fill(0.0);
        r[..n].copy_from_slice(&self.p0);
        self.add_stationarity(model, x, 0..s, &mut r[..s * n], None);
        self.add_constraint_terms(constraints, x, r);
    }

    /// The residual at `x` (as [`ForcedDiracStep::residual`]) and, from the same evaluations of
    /// `∂L` and `f`, the end momentum `p_{k+1} = S_s(x)` (as [`ForcedDiracStep::end_momentum`]).
    pub fn residual_and_end_momentum<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        model: &M,
        constraints: &C,
        x: &[f64],
        r: &mut [f64],
        p1: &mut [f64],
    ) {
        let (n, s) = (self.n, self.s);
        r.fill(0.0);
        r[..n].copy_from_slice(&self.p0);
        p1.fill(0.0);
        self.add_stationarity(model, x, 0..s, &mut r[..s * n], Some(p1));
        self.add_constraint_terms(constraints, x, r);
    }

    /// Stamps `∂p_{k+1}/∂x` (rows: momentum components; columns: the increments; the end momentum
    /// does not depend on the multipliers). Constant for linear models at fixed `h`, where
    /// `p_{k+1}(x) = p_{k+1}(x₀) + (∂p_{k+1}/∂x)(x − x₀)` exactly.
    pub fn end_momentum_jacobian<M: Model + ?Sized>(
        &mut self,
        model: &M,
        x: &[f64],
        jac: &mut Triplets,
    ) {
        let s = self.s;
        self.stamp_stationarity(model, x, s..s + 1, jac);
    }

    /// Adds the multiplier terms to the stationarity rows and writes the constraint rows.
    fn add_constraint_terms<C: Constraints + ?Sized>(
        &mut self,
        constraints: &C,
        x: &[f64],
        r: &mut [f64],
    ) {
        let (n, m, s) = (self.n, self.m, self.s);
        if m == 0 {
            return;
        }
        if !self.has_holonomic && self.flavour == Flavour::Plus {
            // Every row a one-form and every covector at q_k (all circuits, for instance): one
            // pass over the form entries without the per-entry placement logic below.
            self.eval_forms(constraints, x, Point::Start);
            let (stationarity, kinematic) = r.split_at_mut(s * n);
            let (increments, multipliers) = x.split_at(s * n);
            let forms = &self.forms;
            let entries = forms.rows().iter().zip(forms.cols()).zip(forms.values());
            if s == 1 {
                // The midpoint rule, unrolled: a plain pass over the entries.
                for ((&a, &col), &val) in entries {
                    stationarity[col] -= val * multipliers[a];
                    kinematic[a] += val * increments[col];
                }
                return;
            }
            for ((&a, &col), &val) in entries {
                for j in 0..s {
                    stationarity[j * n + col] -= val * multipliers[j * m + a];
                    kinematic[j * m + a] += val * increments[j * n + col];
                }
            }
            return;
        }
        for i in 0..self.constraint_point_count() {
            let p = if i == 0 {
                Point::Start
            } else {
                Point::Control(i)
            };
            if !self.residual_uses(p) {
                continue;
            }
            self.eval_forms(constraints, x, p);
            for (a, col, val) in self.forms.iter() {
                let kind = self.kinds[a];
                for j in 0..s {
                    if self.multiplier_point(kind, j) == p {
                        r[j * n + col] -= val * x[s * n + j * m + a];
                    }
                }
                if kind == ConstraintKind::OneForm && self.kinematic_point() == p {
                    for l in 1..=s {
                        r[s * n + (l - 1) * m + a] += val * x[(l - 1) * n + col];
                    }
                }
            }
        }
        if self.has_holonomic {
            for l in 1..=s {
                self.load_point(x, Point::Control(l));
                constraints.values(&self.point, &mut self.g);
                for a in 0..m {
                    if self.kinds[a] == ConstraintKind::Holonomic {
                        r[s * n + (l - 1) * m + a] = self.g[a];
                    }
                }
            }
        }
    }

    /// Stamps `∂S_j/∂Z` for the stationarity blocks `j` in `blocks` (rows `(j − blocks.start)·n`,
    /// columns of the increments): the part of the Jacobian that comes from `L` and `f`.
    fn stamp_stationarity<M: Model + ?Sized>(
        &mut self,
        model: &M,
        x: &[f64],
        blocks: std::ops::Range<usize>,
        jac: &mut Triplets,
    ) {
        let (n, s, h, first) = (self.n, self.s, self.h, blocks.start);
        // The Hessian at every node, its values node-major (one pattern: models stamp the same
        // sequence at every call), then one entry per block and Hessian entry, summed over the
        // nodes: a quarter of the entries per node-by-node stamping at four nodes.
        let nodes = &self.lagrangian_nodes;
        let mut hess = std::mem::take(&mut self.hessian);
        let mut values = std::mem::take(&mut self.node_values);
        values.clear();
        for i in 0..nodes.len() {
            let (phi, dphi) = nodes.row(i);
            eval_path(&mut self.y, &mut self.w, &self.q0, x, phi, dphi, h);
            hess.begin();
            model.lagrangian_hessian(&self.y, &self.w, &mut hess);
            if !hess.qq.is_frozen() {
                hess.freeze();
            }
            values.extend_from_slice(hess.qq.values());
            values.extend_from_slice(hess.qv.values());
            values.extend_from_slice(hess.vv.values());
        }
        let (nqq, nqv, nvv) = (hess.qq.len(), hess.qv.len(), hess.vv.len());
        // Per block: the sums over the nodes of H_qq, H_qv, H_vq (as H_qv, transposed) and H_vv,
        // each with its weight.
        let mut sums = std::mem::take(&mut self.node_sums);
        let mut merged = std::mem::take(&mut self.merged);
        for j in blocks.clone() {
            for l in 1..=s {
                let (er, uc) = ((j - first) * n, (l - 1) * n);
                let used = sum_over_nodes(
                    nodes,
                    &values,
                    [(0, nqq), (nqq, nqv), (nqq, nqv), (nqq + nqv, nvv)],
                    |phi, dphi, b| {
                        let (pj, dj, pl, dl) = (phi[j], dphi[j], phi[l], dphi[l]);
                        [h * b * pj * pl, b * pj * dl, b * dj * pl, b * dj * dl / h]
                    },
                    &mut sums,
                );
                let kind = match self.merge_kinds.iter().position(|(u, _)| *u == used) {
                    Some(kind) => kind,
                    None => {
                        self.merge_kinds.push((used, BlockMerge::new(&hess, used)));
                        self.merge_kinds.len() - 1
                    }
                };
                let merge = &self.merge_kinds[kind].1;
                merged.clear();
                merged.resize(merge.positions.len(), 0.0);
                for (slot, v) in merge.slot.iter().zip(&sums) {
                    if let Some(k) = slot {
                        merged[*k] += v;
                    }
                }
                for (&(r, c), v) in merge.positions.iter().zip(&merged) {
                    jac.add(er + r, uc + c, *v);
                }
            }
        }
        self.hessian = hess;
        if model.has_force() {
            let nodes = &self.force_nodes;
            let mut fj = std::mem::take(&mut self.force_jacobian);
            values.clear();
            for i in 0..nodes.len() {
                let (phi, dphi) = nodes.row(i);
                eval_path(&mut self.y, &mut self.w, &self.q0, x, phi, dphi, h);
                let t = self.t0 + nodes.nodes[i] * h;
                fj.begin();
                model.force_jacobian(&self.y, &self.w, t, &mut fj);
                if !fj.q.is_frozen() {
                    fj.freeze();
                }
                values.extend_from_slice(fj.q.values());
                values.extend_from_slice(fj.v.values());
            }
            let (nq, nv) = (fj.q.len(), fj.v.len());
            for j in blocks.clone() {
                for l in 1..=s {
                    let (er, uc) = ((j - first) * n, (l - 1) * n);
                    let used = sum_over_nodes(
                        nodes,
                        &values,
                        [(0, nq), (nq, nv)],
                        |phi, dphi, b| [h * b * phi[j] * phi[l], b * phi[j] * dphi[l]],
                        &mut sums,
                    );
                    if used[0] {
                        for ((r, c, _), v) in fj.q.iter().zip(&sums[..nq]) {
                            jac.add(er + r, uc + c, *v);
                        }
                    }
                    if used[1] {
                        for ((r, c, _), v) in fj.v.iter().zip(&sums[nq..]) {
                            jac.add(er + r, uc + c, *v);
                        }
                    }
                }
            }
            self.force_jacobian = fj;
        }
        self.node_values = values;
        self.node_sums = sums;
        self.merged = merged;
    }

    /// Stamps the Jacobian `∂F/∂x` (fixed pattern).
    pub fn jacobian<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        model: &M,
        constraints: &C,
        x: &[f64],
        jac: &mut Triplets,
    ) {
        let (n, m, s) = (self.n, self.m, self.s);
        self.stamp_stationarity(model, x, 0..s, jac);
        if m == 0 {
            return;
        }
        let constant = constraints.is_constant();
        for i in 0..self.constraint_point_count() {
            let p = if i == 0 {
                Point::Start
            } else {
                Point::Control(i)
            };
            self.eval_forms(constraints, x, p);
            for (a, col, val) in self.forms.iter() {
                let kind = self.kinds[a];
                for j in 0..s {
                    if self.multiplier_point(kind, j) == p {
                        jac.add(j * n + col, s * n + j * m + a, -val);
                    }
                }
                match kind {
                    ConstraintKind::OneForm if self.kinematic_point() == p => {
                        for l in 1..=s {
                            jac.add(s * n + (l - 1) * m + a, (l - 1) * n + col, val);
                        }
                    }
                    ConstraintKind::Holonomic => {
                        if let Point::Control(l) = p {
                            jac.add(s * n + (l - 1) * m + a, (l - 1) * n + col, val);
                        }
                    }
                    ConstraintKind::OneForm => {}
                }
            }
            let Point::Control(pl) = p else { continue };
            if constant {
                continue;
            }
            // −∂/∂Q^pl of Aᵀ(Q^pl) Λʲ for the rows whose multiplier covector sits at this point.
            for j in 0..s {
                let mut any = false;
                for a in 0..m {
                    let here = self.multiplier_point(self.kinds[a], j) == p;
                    self.mask[a] = if here { x[s * n + j * m + a] } else { 0.0 };
                    any |= here;
                }
                if !any {
                    continue;
                }
                self.load_point(x, p);
                let mut curvature = std::mem::take(&mut self.curvature);
                curvature.begin();
                constraints.multiplier_hessian(&self.point, &self.mask, &mut curvature);
                if !curvature.is_frozen() {
                    curvature.freeze();
                }
                for (r, c, v) in curvature.iter() {
                    jac.add(j * n + r, (pl - 1) * n + c, -v);
                }
                self.curvature = curvature;
            }
            // ∂/∂Q^s of A(Q^s)·(Q^l − q_k) for one-form rows in the (−) flavour.
            if self.kinematic_point() == p && self.kinds.contains(&ConstraintKind::OneForm) {
                self.load_point(x, p);
                for l in 1..=s {
                    let o = (l - 1) * n;
                    self.dq.copy_from_slice(&x[o..o + n]);
                    let mut contracted = std::mem::take(&mut self.contracted);
                    contracted.begin();
                    constraints.contracted_derivative(&self.point, &self.dq, &mut contracted);
                    if !contracted.is_frozen() {
                        contracted.freeze();
                    }
                    for (a, c, v) in contracted.iter() {
                        if self.kinds[a] == ConstraintKind::OneForm {
                            jac.add(s * n + (l - 1) * m + a, (pl - 1) * n + c, v);
                        }
                    }
                    self.contracted = contracted;
                }
            }
        }
    }

    /// `p_{k+1} = S_s = D₂L_d + f_d⁺` at the solution `x`.
    pub fn end_momentum<M: Model + ?Sized>(&mut self, model: &M, x: &[f64], p1: &mut [f64]) {
        let s = self.s;
        p1.fill(0.0);
        self.add_stationarity(model, x, s..s + 1, p1, None);
    }

    /// Adds `S_j = h Σᵢ bᵢ [ℓⱼ(cᵢ)(∂L/∂q + f) + ℓⱼ'(cᵢ)/h ∂L/∂v]` for `j` in `blocks` to
    /// `out[(j − blocks.start)·n ..]`, and `S_s` to `end` when given (from the same evaluations). A
    /// force node none of whose wanted weights is nonzero is not evaluated (the trapezoid's end
    /// nodes, for instance); when the force rule is the Lagrangian rule, forces are evaluated at the
    /// path points already computed.
    fn add_stationarity<M: Model + ?Sized>(
        &mut self,
        model: &M,
        x: &[f64],
        blocks: std::ops::Range<usize>,
        out: &mut [f64],
        mut end: Option<&mut [f64]>,
    ) {
        let (n, h, s, first) = (self.n, self.h, self.s, blocks.start);
        if first == 0 && s >= 2 {
            self.add_start_stationarity(model, x, blocks.end, out, end);
            return;
        }
        // Block j goes to `out` for j in `blocks`, and to `end` (when given) for j = s.
        let with_end = end.is_some();
        // Whether a force node of weight `b` contributes to a wanted block.
        let needs_force = |phi: &[f64], b: f64| {
            (0..=s).any(|j| (blocks.contains(&j) || (with_end && j == s)) && h * b * phi[j] != 0.0)
        };
        // `out` (and `end`) += h·b·ℓⱼ(cᵢ)·f for the wanted blocks.
        let add_force =
            |f: &[f64], phi: &[f64], b: f64, out: &mut [f64], end: Option<&mut [f64]>| {
                for j in blocks.clone() {
                    let cq = h * b * phi[j];
                    if cq != 0.0 {
                        let o = (j - first) * n;
                        axpy(&mut out[o..o + n], cq, f);
                    }
                }
                if let Some(end) = end
                    && h * b * phi[s] != 0.0
                {
                    axpy(end, h * b * phi[s], f);
                }
            };
        let has_force = model.has_force();
        let shared = has_force && self.shared_nodes;
        let nodes = &self.lagrangian_nodes;
        for i in 0..nodes.len() {
            let (phi, dphi) = nodes.row(i);
            eval_path(&mut self.y, &mut self.w, &self.q0, x, phi, dphi, h);
            model.lagrangian_gradient(&self.y, &self.w, &mut self.lq, &mut self.lv);
            let b = nodes.weights[i];
            for j in blocks.clone() {
                let o = (j - first) * n;
                axpy2(
                    &mut out[o..o + n],
                    h * b * phi[j],
                    &self.lq,
                    b * dphi[j],
                    &self.lv,
                );
            }
            if let Some(end) = end.as_deref_mut() {
                axpy2(end, h * b * phi[s], &self.lq, b * dphi[s], &self.lv);
            }
            if shared && needs_force(phi, b) {
                model.force(&self.y, &self.w, self.t0 + nodes.nodes[i] * h, &mut self.f);
                add_force(&self.f, phi, b, out, end.as_deref_mut());
            }
        }
        if !has_force || shared {
            return;
        }
        let nodes = &self.force_nodes;
        for i in 0..nodes.len() {
            let (phi, dphi) = nodes.row(i);
            let b = nodes.weights[i];
            if !needs_force(phi, b) {
                continue;
            }
            eval_path(&mut self.y, &mut self.w, &self.q0, x, phi, dphi, h);
            model.force(&self.y, &self.w, self.t0 + nodes.nodes[i] * h, &mut self.f);
            add_force(&self.f, phi, b, out, end.as_deref_mut());
        }
    }

    /// [`Self::add_stationarity`] for the blocks `0..last` with `E₀`'s `S₀` written as
    /// `h Σᵢ bᵢ (∂L/∂q + f)ᵢ − Σ_{l=1}^{s} S_l`.
    ///
    /// The step evaluates `L_d` on `y = q_k + Σ_{l≥1} ℓ_l Z^l`, `w = Σ_{l≥1} ℓ_l' Z^l / h`, so
    /// its derivative in `q_k` carries the basis weights `1 − Σ_{l≥1} ℓ_l` and `−Σ_{l≥1} ℓ_l'`.
    /// The tabulated `ℓ₀`, `ℓ₀'` equal them only to rounding, by a fixed amount per node, and
    /// that mismatch makes the map slightly non-variational the same way at every step: on the
    /// double pendulum Gauss 4's energy error grew by about 4e-15 per step. Summing the computed
    /// `S_l` instead leaves only rounding of the data, which does not accumulate coherently.
    /// Degree one needs none of this: its basis values at the usual nodes are exact.
    fn add_start_stationarity<M: Model + ?Sized>(
        &mut self,
        model: &M,
        x: &[f64],
        last: usize,
        out: &mut [f64],
        end: Option<&mut [f64]>,
    ) {
        let (n, h, s) = (self.n, self.h, self.s);
        let has_force = model.has_force();
        let shared = has_force && self.shared_nodes;
        let mut later = std::mem::take(&mut self.later);
        later.fill(0.0);
        let nodes = &self.lagrangian_nodes;
        for i in 0..nodes.len() {
            let (phi, dphi) = nodes.row(i);
            eval_path(&mut self.y, &mut self.w, &self.q0, x, phi, dphi, h);
            model.lagrangian_gradient(&self.y, &self.w, &mut self.lq, &mut self.lv);
            let b = nodes.weights[i];
            axpy(&mut out[..n], h * b, &self.lq);
            for l in 1..=s {
                let o = (l - 1) * n;
                axpy2(
                    &mut later[o..o + n],
                    h * b * phi[l],
                    &self.lq,
                    b * dphi[l],
                    &self.lv,
                );
            }
            if shared {
                model.force(&self.y, &self.w, self.t0 + nodes.nodes[i] * h, &mut self.f);
                add_weighted_force(&mut out[..n], &mut later, &self.f, phi, h * b);
            }
        }
        if has_force && !shared {
            let nodes = &self.force_nodes;
            for i in 0..nodes.len() {
                let (phi, dphi) = nodes.row(i);
                let b = nodes.weights[i];
                if b == 0.0 {
                    continue;
                }
                eval_path(&mut self.y, &mut self.w, &self.q0, x, phi, dphi, h);
                model.force(&self.y, &self.w, self.t0 + nodes.nodes[i] * h, &mut self.f);
                add_weighted_force(&mut out[..n], &mut later, &self.f, phi, h * b);
            }
        }
        for l in 1..=s {
            let sl = &later[(l - 1) * n..l * n];
            axpy(&mut out[..n], -1.0, sl);
            if l < last {
                axpy(&mut out[l * n..(l + 1) * n], 1.0, sl);
            }
        }
        if let Some(end) = end {
            axpy(end, 1.0, &later[(s - 1) * n..]);
        }
        self.later = later;
    }

    /// The size of each equation's terms that do not depend on the unknowns: the carried momentum
    /// in `E₀`, and `Σ_j |Aᵃ_j(q_k) q_k,j|` (the positions a holonomic constraint compares) in
    /// its rows `C_l`; zero elsewhere. For Newton's residual test.
    pub fn constant_magnitudes<C: Constraints + ?Sized>(
        &mut self,
        constraints: &C,
        out: &mut [f64],
    ) {
        let (n, m, s) = (self.n, self.m, self.s);
        out.fill(0.0);
        for (o, p) in out[..n].iter_mut().zip(&self.p0) {
            *o = p.abs();
        }
        if !self.has_holonomic {
            return;
        }
        // The covectors at the start point need no unknowns.
        self.eval_forms(constraints, &[], Point::Start);
        for (a, col, val) in self.forms.iter() {
            if self.kinds[a] == ConstraintKind::Holonomic {
                let size = (val * self.q0[col]).abs();
                for l in 1..=s {
                    out[s * n + (l - 1) * m + a] += size;
                }
            }
        }
    }

    /// The largest fraction `α ∈ (0, 1]` of the Newton update from `x` to `x − update` that the
    /// model accepts ([`Model::update_fraction`]) at every quadrature node of the step: the path
    /// and its velocity are linear in the increments, so each node moves by the same fraction of
    /// its own update.
    pub fn update_fraction<M: Model + ?Sized>(
        &mut self,
        model: &M,
        x: &[f64],
        update: &[f64],
    ) -> f64 {
        let (n, h) = (self.n, self.h);
        let mut alpha: f64 = 1.0;
        let tables = if self.shared_nodes || !model.has_force() {
            1
        } else {
            2
        };
        for table in 0..tables {
            let nodes = if table == 0 {
                &self.lagrangian_nodes
            } else {
                &self.force_nodes
            };
            for i in 0..nodes.len() {
                let (phi, dphi) = nodes.row(i);
                eval_path(&mut self.y, &mut self.w, &self.q0, x, phi, dphi, h);
                // `dq` and `lq` serve as scratch for the node's position and velocity updates.
                self.dq.fill(0.0);
                self.lq.fill(0.0);
                for l in 1..phi.len() {
                    let (a, b) = (phi[l], dphi[l] / h);
                    let u = &update[(l - 1) * n..l * n];
                    for ((dy, dw), u) in self.dq.iter_mut().zip(self.lq.iter_mut()).zip(u) {
                        *dy -= a * u;
                        *dw -= b * u;
                    }
                }
                alpha = alpha.min(model.update_fraction(&self.y, &self.w, &self.dq, &self.lq));
            }
        }
        alpha
    }

    /// Max-norm of the constraint equations `C_l` at `x` (uses `scratch`, of length
    /// [`ForcedDiracStep::unknowns`]).
    pub fn constraint_residual<M: Model + ?Sized, C: Constraints + ?Sized>(
        &mut self,
        model: &M,
        constraints: &C,
        x: &[f64],
        scratch: &mut [f64],
    ) -> f64 {
        self.residual(model, constraints, x, scratch);
        scratch[self.constraint_row(1)..]
            .iter()
            .fold(0.0_f64, |m, r| m.max(r.abs()))
    }

    /// The constraint impulse `Aᵀ(q_k) Λ⁰` of the solved step (what `p_k` gained from constraints).
    pub fn start_impulse<C: Constraints + ?Sized>(
        &mut self,
        constraints: &C,
        x: &[f64],
        impulse: &mut [f64],
    ) {
        impulse.fill(0.0);
        if self.m == 0 {
            return;
        }
        self.eval_forms(constraints, x, Point::Start);
        let o = self.multiplier_offset(0);
        for (a, col, val) in self.forms.iter() {
            impulse[col] += val * x[o + a];
        }
    }

    /// An initial guess: control points on the straight line `q_k + dⱼ h v`, multipliers zero.
    pub fn straight_guess(&self, control_nodes: &[f64], velocity: &[f64], x: &mut [f64]) {
        let n = self.n;
        for (l, &d) in control_nodes.iter().enumerate().skip(1).take(self.s) {
            for (xk, vk) in x[(l - 1) * n..l * n].iter_mut().zip(velocity) {
                *xk = d * self.h * vk;
            }
        }
        x[self.s * n..].fill(0.0);
    }
}
