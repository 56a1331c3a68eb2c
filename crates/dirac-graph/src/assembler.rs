//! The assembler: one interconnection graph → a model and constraints on global coordinates.

use std::cell::Cell;
use std::collections::HashMap;
use std::fmt;
use std::sync::Arc;

use dirac_core::{ConstraintKind, Constraints, ForceJacobian, LagrangianHessian, Model, Triplets};

use crate::coupling::CouplingElement;
use crate::error::GraphError;
use crate::interconnection::{
    Connection, Interconnection, MAX_CONSTRAINT_PORTS, PortRef, SubsystemId,
};
use crate::port_constraint::PortConstraint;

/// How couplings and connections become equations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Representation {
    /// One system on `Q = ΠQᵢ`; coupling potentials inside the one Lagrangian; nodes and joints as
    /// constraint one-forms.
    Monolithic,
    /// Each coupling acts on a massless endpoint coordinate of its first subsystem, tied to the
    /// partner port by a joint whose multiplier is the interaction force.
    Constraint,
    /// Coupling potentials applied as equal-and-opposite forces `−∂V/∂x_a`, `−∂V/∂x_b`.
    InteractionForce,
}

impl fmt::Display for Representation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Monolithic => "monolithic",
            Self::Constraint => "constraint",
            Self::InteractionForce => "force",
        })
    }
}

type Coefficients = Vec<(usize, f64)>;

fn port_coefficients(graph: &Interconnection, offsets: &[usize], p: PortRef) -> Coefficients {
    let o = offsets[p.subsystem.0];
    graph.subsystems()[p.subsystem.0].ports()[p.port]
        .coefficients
        .iter()
        .map(|&(i, c)| (o + i, c))
        .collect()
}

fn combine(q: &[f64], coefficients: &[(usize, f64)]) -> f64 {
    coefficients.iter().map(|&(i, c)| c * q[i]).sum()
}

/// A coupling placed on global coordinates.
#[derive(Clone)]
struct GlobalCoupling {
    connection: usize,
    element: Arc<dyn CouplingElement>,
    a: Coefficients,
    b: Coefficients,
    potential_in_lagrangian: bool,
}

impl GlobalCoupling {
    fn ports(&self) -> [&Coefficients; 2] {
        [&self.a, &self.b]
    }
}

/// The hot data of a part in the model's evaluation loops: its model and where it sits.
#[derive(Clone)]
struct HotPart {
    model: Arc<dyn Model + Send + Sync>,
    offset: usize,
    dim: usize,
    has_force: bool,
    has_update_limit: bool,
    has_step_check: bool,
}

/// The parts that share one model object (instances of one definition, a netlist's elements of
/// equal kind and value), evaluated by one call ([`Model::lagrangian_gradient_at`],
/// [`Model::force_at`]) instead of one dynamic call per part.
#[derive(Clone)]
struct PartGroup {
    model: Arc<dyn Model + Send + Sync>,
    offsets: Vec<usize>,
    has_force: bool,
}

/// The parts of `parts` grouped by model object, in order of first appearance.
fn group_parts(parts: &[HotPart]) -> Vec<PartGroup> {
    let mut index: HashMap<*const (), usize> = HashMap::new();
    let mut groups: Vec<PartGroup> = Vec::new();
    for p in parts {
        let key = Arc::as_ptr(&p.model).cast::<()>();
        let g = *index.entry(key).or_insert_with(|| {
            groups.push(PartGroup {
                model: Arc::clone(&p.model),
                offsets: Vec::new(),
                has_force: p.has_force,
            });
            groups.len() - 1
        });
        groups[g].offsets.push(p.offset);
    }
    groups
}

/// A part placed at an offset of the global coordinates.
#[derive(Clone)]
struct Placed {
    model: Arc<dyn Model + Send + Sync>,
    constraints: Arc<dyn Constraints + Send + Sync>,
    offset: usize,
    dim: usize,
    row_offset: usize,
    rows: usize,
    name: String,
}

/// The Lagrangian `Σ Lᵢ − Σ V_c` (monolithic, constraint) or `Σ Lᵢ` (force) and the forces of an
/// assembled interconnection, on the global coordinates.
#[derive(Clone)]
pub struct AssembledModel {
    parts: Vec<HotPart>,
    groups: Vec<PartGroup>,
    couplings: Vec<GlobalCoupling>,
    dim: usize,
    names: Vec<String>,
    has_force: bool,
    linear: bool,
    has_update_limit: bool,
    has_step_check: bool,
    /// Parts and couplings that depend on time, the only ones with source breakpoints (the
    /// query runs every step, and a ladder of 10⁵ sections has one source); none: autonomous.
    timed_parts: Vec<usize>,
    timed_couplings: Vec<usize>,
    /// The one part's model when it is the whole system (it covers every coordinate and there
    /// are no couplings): its gradient and force are the system's, called directly (an explicit
    /// composition of a one-part scene evaluates them once per substep, a few nanoseconds each).
    sole: Option<Arc<dyn Model + Send + Sync>>,
}

impl AssembledModel {
    /// The couplings whose potential is part of `L` (monolithic representation): the ones the
    /// Lagrangian, its gradient and its Hessian include.
    fn couplings_in_lagrangian(&self) -> impl Iterator<Item = &GlobalCoupling> {
        self.couplings
            .iter()
            .filter(|c| c.potential_in_lagrangian && c.element.has_potential())
    }

    /// [`Model::lagrangian_gradient`] part by part, then the coupling potentials in `L`.
    fn gradient_of_parts(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let covered: usize = self.parts.last().map_or(0, |p| p.offset + p.dim);
        lq[covered..].fill(0.0);
        lv[covered..].fill(0.0);
        for g in &self.groups {
            g.model.lagrangian_gradient_at(&g.offsets, q, v, lq, lv);
        }
        for c in self.couplings_in_lagrangian() {
            let g = c
                .element
                .potential_gradient(combine(q, &c.a), combine(q, &c.b));
            for (side, coefficients) in c.ports().into_iter().enumerate() {
                for &(i, k) in coefficients {
                    lq[i] -= k * g[side];
                }
            }
        }
    }

    /// [`Model::force`] part by part, then the couplings' forces.
    fn force_of_parts(&self, q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        // One pass zeroes the coordinates of the parts without a force (a fill per instance was
        // a library call per one-coordinate capacitor); the parts with a force set theirs.
        f.fill(0.0);
        for g in self.groups.iter().filter(|g| g.has_force) {
            g.model.force_at(&g.offsets, q, v, t, f);
        }
        self.stamp_coupling_force(q, v, t, f);
    }

    fn stamp_coupling_force(&self, q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        for c in &self.couplings {
            let x = [combine(q, &c.a), combine(q, &c.b)];
            let mut fa = [0.0; 2];
            if c.element.has_potential() && !c.potential_in_lagrangian {
                let g = c.element.potential_gradient(x[0], x[1]);
                fa = [-g[0], -g[1]];
            }
            if c.element.has_force() {
                let w = [combine(v, &c.a), combine(v, &c.b)];
                let g = c.element.force(x, w, t);
                fa = [fa[0] + g[0], fa[1] + g[1]];
            }
            for (side, coefficients) in c.ports().into_iter().enumerate() {
                for &(i, k) in coefficients {
                    f[i] += k * fa[side];
                }
            }
        }
    }
}

impl Model for AssembledModel {
    fn dim(&self) -> usize {
        self.dim
    }

    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        let mut l = 0.0;
        for p in &self.parts {
            let r = p.offset..p.offset + p.dim;
            l += p.model.lagrangian(&q[r.clone()], &v[r]);
        }
        for c in self.couplings_in_lagrangian() {
            l -= c.element.potential(combine(q, &c.a), combine(q, &c.b));
        }
        l
    }

    // Inlined into the integrator (another crate), so that a one-part system costs one dynamic
    // call per evaluation, the part's.
    #[inline]
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        match &self.sole {
            Some(model) => model.lagrangian_gradient(q, v, lq, lv),
            None => self.gradient_of_parts(q, v, lq, lv),
        }
    }

    fn lagrangian_hessian(&self, q: &[f64], v: &[f64], h: &mut LagrangianHessian) {
        for p in &self.parts {
            let r = p.offset..p.offset + p.dim;
            h.qq.set_offset(p.offset, p.offset);
            h.qv.set_offset(p.offset, p.offset);
            h.vv.set_offset(p.offset, p.offset);
            p.model.lagrangian_hessian(&q[r.clone()], &v[r], h);
        }
        h.qq.set_offset(0, 0);
        h.qv.set_offset(0, 0);
        h.vv.set_offset(0, 0);
        for c in self.couplings_in_lagrangian() {
            let hess = c
                .element
                .potential_hessian(combine(q, &c.a), combine(q, &c.b));
            let ports = c.ports();
            for (sa, ca) in ports.iter().enumerate() {
                for (sb, cb) in ports.iter().enumerate() {
                    for &(i, ki) in ca.iter() {
                        for &(j, kj) in cb.iter() {
                            h.qq.add(i, j, -ki * kj * hess[sa][sb]);
                        }
                    }
                }
            }
        }
    }

    fn has_force(&self) -> bool {
        self.has_force
    }

    #[inline]
    fn force(&self, q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        match &self.sole {
            Some(model) if self.has_force => model.force(q, v, t, f),
            Some(_) => f.fill(0.0),
            None => self.force_of_parts(q, v, t, f),
        }
    }

    fn force_jacobian(&self, q: &[f64], v: &[f64], t: f64, jac: &mut ForceJacobian) {
        for p in self.parts.iter().filter(|p| p.has_force) {
            let r = p.offset..p.offset + p.dim;
            jac.q.set_offset(p.offset, p.offset);
            jac.v.set_offset(p.offset, p.offset);
            p.model.force_jacobian(&q[r.clone()], &v[r], t, jac);
        }
        jac.q.set_offset(0, 0);
        jac.v.set_offset(0, 0);
        for c in &self.couplings {
            let x = [combine(q, &c.a), combine(q, &c.b)];
            let w = [combine(v, &c.a), combine(v, &c.b)];
            let mut dq = [[0.0; 2]; 2];
            let mut dv = [[0.0; 2]; 2];
            let potential_as_force = c.element.has_potential() && !c.potential_in_lagrangian;
            if potential_as_force {
                let hess = c.element.potential_hessian(x[0], x[1]);
                for a in 0..2 {
                    for b in 0..2 {
                        dq[a][b] = -hess[a][b];
                    }
                }
            }
            if c.element.has_force() {
                let [jq, jv] = c.element.force_jacobian(x, w, t);
                for a in 0..2 {
                    for b in 0..2 {
                        dq[a][b] += jq[a][b];
                        dv[a][b] += jv[a][b];
                    }
                }
            }
            let ports = c.ports();
            for (sa, ca) in ports.iter().enumerate() {
                for (sb, cb) in ports.iter().enumerate() {
                    for &(i, ki) in ca.iter() {
                        for &(j, kj) in cb.iter() {
                            if potential_as_force || c.element.has_force() {
                                jac.q.add(i, j, ki * kj * dq[sa][sb]);
                            }
                            if c.element.has_force() {
                                jac.v.add(i, j, ki * kj * dv[sa][sb]);
                            }
                        }
                    }
                }
            }
        }
    }

    fn is_linear(&self) -> bool {
        self.linear
    }

    fn is_autonomous(&self) -> bool {
        self.timed_parts.is_empty() && self.timed_couplings.is_empty()
    }

    /// Separable when every part is and no coupling force depends on the flows: the mass
    /// matrix is then block diagonal over the parts (coupling potentials depend on positions
    /// only, in whichever representation they sit).
    fn separable(&self) -> Option<Triplets> {
        if self
            .couplings
            .iter()
            .any(|c| c.element.has_force() && c.element.force_depends_on_velocity())
        {
            return None;
        }
        let mut mass = Triplets::new();
        for p in &self.parts {
            let part = p.model.separable()?;
            for (r, c, m) in part.iter() {
                mass.add(p.offset + r, p.offset + c, m);
            }
        }
        Some(mass)
    }

    fn depends_on_time(&self, i: usize) -> bool {
        let part = self.parts.partition_point(|p| p.offset + p.dim <= i);
        let own = self
            .parts
            .get(part)
            .is_some_and(|p| i >= p.offset && p.model.depends_on_time(i - p.offset));
        own || self.timed_couplings.iter().any(|&c| {
            self.couplings[c]
                .ports()
                .iter()
                .any(|p| p.iter().any(|&(j, _)| j == i))
        })
    }

    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        let parts = self
            .timed_parts
            .iter()
            .filter_map(|&i| self.parts[i].model.next_breakpoint(t));
        let couplings = self
            .timed_couplings
            .iter()
            .filter_map(|&i| self.couplings[i].element.next_breakpoint(t));
        parts.chain(couplings).reduce(f64::min)
    }

    fn has_update_limit(&self) -> bool {
        self.has_update_limit
    }

    fn update_fraction(&self, q: &[f64], v: &[f64], dq: &[f64], dv: &[f64]) -> f64 {
        let mut alpha: f64 = 1.0;
        for p in self.parts.iter().filter(|p| p.has_update_limit) {
            let r = p.offset..p.offset + p.dim;
            alpha = alpha.min(p.model.update_fraction(
                &q[r.clone()],
                &v[r.clone()],
                &dq[r.clone()],
                &dv[r],
            ));
        }
        alpha
    }

    fn has_step_check(&self) -> bool {
        self.has_step_check
    }

    /// Each part's check on its own coordinates; a rejection names the part.
    fn check_step(&self, q0: &[f64], q1: &[f64]) -> Result<(), String> {
        for p in self.parts.iter().filter(|p| p.has_step_check) {
            let r = p.offset..p.offset + p.dim;
            p.model.check_step(&q0[r.clone()], &q1[r]).map_err(|why| {
                let name = &self.names[p.offset];
                let part = name
                    .rsplit_once('.')
                    .map_or(name.as_str(), |(part, _)| part);
                format!("part `{part}`: {why}")
            })?;
        }
        Ok(())
    }

    /// Each part's bodies' turns, part by part.
    fn step_turns(&self, q0: &[f64], q1: &[f64], turns: &mut Vec<f64>) {
        for p in self.parts.iter().filter(|p| p.has_step_check) {
            let r = p.offset..p.offset + p.dim;
            p.model.step_turns(&q0[r.clone()], &q1[r], turns);
        }
    }

    fn coordinate_name(&self, i: usize) -> String {
        self.names[i].clone()
    }
}

/// One constraint row contributed by a connection.
#[derive(Clone)]
struct ConnectionRow {
    name: String,
    entries: Coefficients,
}

/// A holonomic connection placed on global coordinates: its rows start at `first_row`.
#[derive(Clone)]
struct PlacedHolonomic {
    name: String,
    constraint: Arc<dyn PortConstraint>,
    /// The coefficients of each port it reads, in the constraint's port order.
    ports: Vec<Coefficients>,
    first_row: usize,
}

impl PlacedHolonomic {
    /// Gathers the port values of `q` into `x` (the first `ports.len()` entries).
    fn gather(&self, q: &[f64], x: &mut [f64; MAX_CONSTRAINT_PORTS]) {
        for (xi, port) in x.iter_mut().zip(&self.ports) {
            *xi = combine(q, port);
        }
    }
}

/// Internal constraints of every subsystem (at their offsets), the one-form connection rows, then
/// the rows of holonomic connections.
#[derive(Clone)]
pub struct AssembledConstraints {
    parts: Vec<Placed>,
    internal_rows: usize,
    rows: Vec<ConnectionRow>,
    holonomic: Vec<PlacedHolonomic>,
    holonomic_rows: usize,
    constant: bool,
}

impl AssembledConstraints {
    /// The part owning internal row `a` (parts are stored in increasing row offset).
    fn part_of_row(&self, a: usize) -> Option<&Placed> {
        if a >= self.internal_rows {
            return None;
        }
        let i = self.parts.partition_point(|p| p.row_offset + p.rows <= a);
        self.parts
            .get(i)
            .filter(|p| a >= p.row_offset && a < p.row_offset + p.rows)
    }

    /// First row of the holonomic connections.
    fn holonomic_start(&self) -> usize {
        self.internal_rows + self.rows.len()
    }

    /// The holonomic connection owning row `a`, if any.
    fn holonomic_of_row(&self, a: usize) -> Option<&PlacedHolonomic> {
        if a < self.holonomic_start() {
            return None;
        }
        let i = self
            .holonomic
            .partition_point(|h| h.first_row + h.constraint.rows() <= a);
        self.holonomic.get(i)
    }
}

impl Constraints for AssembledConstraints {
    fn count(&self) -> usize {
        self.internal_rows + self.rows.len() + self.holonomic_rows
    }

    fn kind(&self, a: usize) -> ConstraintKind {
        match self.part_of_row(a) {
            Some(p) => p.constraints.kind(a - p.row_offset),
            None if a >= self.holonomic_start() => ConstraintKind::Holonomic,
            None => ConstraintKind::OneForm,
        }
    }

    fn forms(&self, q: &[f64], out: &mut Triplets) {
        for p in self.parts.iter().filter(|p| p.rows > 0) {
            out.set_offset(p.row_offset, p.offset);
            p.constraints.forms(&q[p.offset..p.offset + p.dim], out);
        }
        out.set_offset(0, 0);
        for (r, row) in self.rows.iter().enumerate() {
            for &(j, c) in &row.entries {
                out.add(self.internal_rows + r, j, c);
            }
        }
        let mut x = [0.0; MAX_CONSTRAINT_PORTS];
        for h in &self.holonomic {
            h.gather(q, &mut x);
            // ∂gᵃ/∂q_j = Σᵢ ∂gᵃ/∂xᵢ · cᵢⱼ.
            h.constraint.jacobian(&x[..h.ports.len()], &mut |a, i, v| {
                for &(j, c) in &h.ports[i] {
                    out.add(h.first_row + a, j, c * v);
                }
            });
        }
    }

    fn values(&self, q: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        for p in self.parts.iter().filter(|p| p.rows > 0) {
            p.constraints.values(
                &q[p.offset..p.offset + p.dim],
                &mut out[p.row_offset..p.row_offset + p.rows],
            );
        }
        let mut x = [0.0; MAX_CONSTRAINT_PORTS];
        for h in &self.holonomic {
            h.gather(q, &mut x);
            let rows = h.first_row..h.first_row + h.constraint.rows();
            h.constraint.values(&x[..h.ports.len()], &mut out[rows]);
        }
    }

    fn is_constant(&self) -> bool {
        self.constant
    }

    fn multiplier_hessian(&self, q: &[f64], lambda: &[f64], out: &mut Triplets) {
        for p in self
            .parts
            .iter()
            .filter(|p| p.rows > 0 && !p.constraints.is_constant())
        {
            out.set_offset(p.offset, p.offset);
            p.constraints.multiplier_hessian(
                &q[p.offset..p.offset + p.dim],
                &lambda[p.row_offset..p.row_offset + p.rows],
                out,
            );
        }
        out.set_offset(0, 0);
        let mut x = [0.0; MAX_CONSTRAINT_PORTS];
        for h in self.holonomic.iter().filter(|h| !h.constraint.is_linear()) {
            h.gather(q, &mut x);
            let rows = h.first_row..h.first_row + h.constraint.rows();
            // Σₐ λₐ ∂²gᵃ/∂q_j∂q_l = Σᵢₖ Hᵢₖ cᵢⱼ cₖₗ.
            h.constraint
                .hessian(&x[..h.ports.len()], &lambda[rows], &mut |i, k, v| {
                    for &(j, ci) in &h.ports[i] {
                        for &(l, ck) in &h.ports[k] {
                            out.add(j, l, ci * ck * v);
                        }
                    }
                });
        }
    }

    fn contracted_derivative(&self, q: &[f64], w: &[f64], out: &mut Triplets) {
        for p in self
            .parts
            .iter()
            .filter(|p| p.rows > 0 && !p.constraints.is_constant())
        {
            out.set_offset(p.row_offset, p.offset);
            p.constraints.contracted_derivative(
                &q[p.offset..p.offset + p.dim],
                &w[p.offset..p.offset + p.dim],
                out,
            );
        }
        out.set_offset(0, 0);
        let mut x = [0.0; MAX_CONSTRAINT_PORTS];
        let mut wx = [0.0; MAX_CONSTRAINT_PORTS];
        let mut unit = Vec::new();
        for h in self.holonomic.iter().filter(|h| !h.constraint.is_linear()) {
            h.gather(q, &mut x);
            h.gather(w, &mut wx);
            let rows = h.constraint.rows();
            unit.clear();
            unit.resize(rows, 0.0);
            // Σⱼ wⱼ ∂Aᵃⱼ/∂q_l = Σᵢₖ Hᵃᵢₖ (cᵢ·w) cₖₗ, one row at a time (λ = eₐ).
            for a in 0..rows {
                unit[a] = 1.0;
                h.constraint
                    .hessian(&x[..h.ports.len()], &unit, &mut |i, k, v| {
                        for &(l, ck) in &h.ports[k] {
                            out.add(h.first_row + a, l, wx[i] * ck * v);
                        }
                    });
                unit[a] = 0.0;
            }
        }
    }

    fn name(&self, a: usize) -> String {
        if let Some(p) = self.part_of_row(a) {
            return format!("{}/{}", p.name, p.constraints.name(a - p.row_offset));
        }
        match self.holonomic_of_row(a) {
            Some(h) => format!("{} ({})", h.name, h.constraint.row_name(a - h.first_row)),
            None => self.rows[a - self.internal_rows].name.clone(),
        }
    }
}

/// An assembled interconnection: model, constraints and the global index map.
#[derive(Clone)]
pub struct AssembledSystem {
    /// The representation it was built in.
    pub representation: Representation,
    /// `Σ Lᵢ` (± coupling potentials) and forces on the global coordinates.
    pub model: AssembledModel,
    /// Internal and connection constraint rows.
    pub constraints: AssembledConstraints,
    offsets: Vec<usize>,
    dims: Vec<usize>,
    /// `(endpoint global index, partner port coefficients)` per endpoint (constraint form).
    endpoints: Vec<(usize, Coefficients)>,
    /// Constraint rows of each connection, in order (`None`: the connection has no row).
    connection_rows: Vec<Option<usize>>,
}

impl fmt::Debug for AssembledSystem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("AssembledSystem")
            .field("representation", &self.representation)
            .field("coordinates", &self.model.dim())
            .field("constraints", &self.constraints.count())
            .finish()
    }
}

impl AssembledSystem {
    /// Global index of `(subsystem, local coordinate)`.
    #[must_use]
    pub fn global_index(&self, subsystem: SubsystemId, local: usize) -> usize {
        self.offsets[subsystem.0] + local
    }

    /// Number of subsystem coordinates (endpoints excluded).
    #[must_use]
    pub fn subsystem_coordinates(&self) -> usize {
        self.offsets
            .last()
            .map_or(0, |o| o + self.dims[self.dims.len() - 1])
    }

    /// Number of global coordinates (endpoints included).
    #[must_use]
    pub fn coordinates(&self) -> usize {
        self.model.dim()
    }

    /// Number of constraint rows.
    #[must_use]
    pub fn constraint_rows(&self) -> usize {
        self.constraints.count()
    }

    /// The constraint row of connection `c` (joints, nodes, and couplings in constraint form; the
    /// first of its rows for a holonomic constraint).
    #[must_use]
    pub fn connection_row(&self, c: usize) -> Option<usize> {
        self.connection_rows.get(c).copied().flatten()
    }

    /// The coefficients `(global coordinate, coefficient)` of connection `c`'s constraint row, if
    /// it has one.
    #[must_use]
    pub fn connection_entries(&self, c: usize) -> Option<&[(usize, f64)]> {
        let row = self.connection_row(c)?;
        self.constraints
            .rows
            .get(row - self.constraints.internal_rows)
            .map(|r| r.entries.as_slice())
    }

    /// Number of connections of the graph this system was assembled from.
    #[must_use]
    pub fn connection_count(&self) -> usize {
        self.connection_rows.len()
    }

    /// Global vector from per-subsystem vectors; endpoint entries take the partner port's value
    /// (positions for `q`, flows for `v`), which makes the initial state consistent.
    pub fn global_vector(
        &self,
        per_subsystem: &[Vec<f64>],
        names: &[String],
    ) -> Result<Vec<f64>, GraphError> {
        let mut out = vec![0.0; self.coordinates()];
        for (s, values) in per_subsystem.iter().enumerate() {
            if values.len() != self.dims[s] {
                return Err(GraphError::InitialDimension {
                    subsystem: names.get(s).cloned().unwrap_or_default(),
                    got: values.len(),
                    expected: self.dims[s],
                });
            }
            out[self.offsets[s]..self.offsets[s] + self.dims[s]].copy_from_slice(values);
        }
        for (e, partner) in &self.endpoints {
            out[*e] = combine(&out, partner);
        }
        Ok(out)
    }

    /// Interaction impulses of the one-form connection rows: for each connection with such a row
    /// (node, joint, or coupling endpoint in the constraint form), `(connection index, global
    /// coordinate, impulse)` for every coordinate the row touches, where the impulse is what the
    /// connection adds to that coordinate's momentum over the step: `−Λ·c` for the row's
    /// multiplier `Λ` and coefficient `c` (the step equations read
    /// `p_k + D₁L_d + f_d⁻ − Σ Λ·A = 0`, MATH §4). `multipliers` holds one value per constraint
    /// row (see `Integrator::last_multipliers_full`). Divided by `h` these are the interaction
    /// forces; for a joint they act equal and opposite on its two ports. A coupling's endpoint row
    /// (constraint form) delivers the coupling's impulse to the partner less the change of the
    /// endpoint's own momentum, which [`AssembledSystem::subsystem_momenta`] pulls back onto the
    /// partner.
    #[must_use]
    pub fn interaction_impulses(&self, multipliers: &[f64]) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        for (c, row) in self.connection_rows.iter().enumerate() {
            let Some(row) = row else { continue };
            if *row >= self.constraints.holonomic_start() {
                continue;
            }
            let entries = &self.constraints.rows[row - self.constraints.internal_rows].entries;
            for &(i, k) in entries {
                out.push((c, i, -multipliers[*row] * k));
            }
        }
        out
    }

    /// Interaction forces of the couplings that act as forces at the state `(q, v, t)` (every
    /// coupling in the force representation; dampers in all representations):
    /// `(connection index, [f_a, f_b])` on the two port coordinates.
    #[must_use]
    pub fn coupling_forces(&self, q: &[f64], v: &[f64], t: f64) -> Vec<(usize, [f64; 2])> {
        let mut out = Vec::new();
        let force_carrying = self.model.couplings.iter().filter(|c| {
            c.element.has_force() || (c.element.has_potential() && !c.potential_in_lagrangian)
        });
        for coupling in force_carrying {
            let x = [combine(q, &coupling.a), combine(q, &coupling.b)];
            let w = [combine(v, &coupling.a), combine(v, &coupling.b)];
            let mut f = [0.0; 2];
            if coupling.element.has_potential() && !coupling.potential_in_lagrangian {
                let g = coupling.element.potential_gradient(x[0], x[1]);
                f = [-g[0], -g[1]];
            }
            if coupling.element.has_force() {
                let g = coupling.element.force(x, w, t);
                f = [f[0] + g[0], f[1] + g[1]];
            }
            out.push((coupling.connection, f));
        }
        out
    }

    /// Subsystem positions (endpoints dropped).
    #[must_use]
    pub fn subsystem_positions<'a>(&self, q: &'a [f64]) -> &'a [f64] {
        &q[..self.subsystem_coordinates()]
    }

    /// Subsystem momenta with endpoint momenta pulled back to the partner ports (`p_b += c·p_e`):
    /// the momenta of the constraint form that equal the monolithic ones (MATH §6).
    #[must_use]
    pub fn subsystem_momenta(&self, p: &[f64]) -> Vec<f64> {
        let mut out = Vec::new();
        self.subsystem_momenta_into(p, &mut out);
        out
    }

    /// [`AssembledSystem::subsystem_momenta`] into `out` (reusing its buffer, so a caller
    /// reading every step allocates nothing).
    pub fn subsystem_momenta_into(&self, p: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend_from_slice(&p[..self.subsystem_coordinates()]);
        for (e, partner) in &self.endpoints {
            for &(i, c) in partner {
                out[i] += c * p[*e];
            }
        }
    }
}

/// Builds [`AssembledSystem`]s from an [`Interconnection`].
#[derive(Debug, Clone, Copy)]
pub struct Assembler;

impl Assembler {
    /// Assembles `graph` in `representation`.
    pub fn assemble(
        graph: &Interconnection,
        representation: Representation,
    ) -> Result<AssembledSystem, GraphError> {
        let subsystems = graph.subsystems();
        let mut offsets = Vec::with_capacity(subsystems.len());
        let mut dims = Vec::with_capacity(subsystems.len());
        let mut parts = Vec::with_capacity(subsystems.len());
        let mut names = Vec::new();
        let (mut offset, mut row_offset) = (0, 0);
        for s in subsystems {
            let dim = s.model.dim();
            let rows = s.constraints.count();
            offsets.push(offset);
            dims.push(dim);
            for i in 0..dim {
                names.push(format!("{}.{}", s.name, s.model.coordinate_name(i)));
            }
            parts.push(Placed {
                model: s.model.clone(),
                constraints: s.constraints.clone(),
                offset,
                dim,
                row_offset,
                rows,
                name: s.name.clone(),
            });
            offset += dim;
            row_offset += rows;
        }
        let internal_rows = row_offset;
        let mut couplings = Vec::new();
        let mut rows = Vec::new();
        let mut endpoints = Vec::new();
        let mut connection_rows = Vec::with_capacity(graph.connections().len());
        let mut holonomic = Vec::new();
        let mut holonomic_rows = 0;
        for (index, connection) in graph.connections().iter().enumerate() {
            match connection {
                Connection::Holonomic {
                    name,
                    ports,
                    constraint,
                } => {
                    // Placed after every one-form row; the row index is fixed below.
                    connection_rows.push(Some(holonomic_rows));
                    holonomic.push(PlacedHolonomic {
                        name: name.clone(),
                        constraint: constraint.clone(),
                        ports: ports
                            .iter()
                            .map(|&p| port_coefficients(graph, &offsets, p))
                            .collect(),
                        first_row: holonomic_rows,
                    });
                    holonomic_rows += constraint.rows();
                }
                Connection::Node { name, ports } => {
                    let mut entries = Vec::new();
                    for &(p, sign) in ports {
                        for (i, c) in port_coefficients(graph, &offsets, p) {
                            entries.push((i, sign * c));
                        }
                    }
                    connection_rows.push(Some(internal_rows + rows.len()));
                    rows.push(ConnectionRow {
                        name: format!("node `{name}` (KCL)"),
                        entries,
                    });
                }
                Connection::Joint { name, a, b } => {
                    let mut entries = port_coefficients(graph, &offsets, *a);
                    entries.extend(
                        port_coefficients(graph, &offsets, *b)
                            .into_iter()
                            .map(|(i, c)| (i, -c)),
                    );
                    connection_rows.push(Some(internal_rows + rows.len()));
                    rows.push(ConnectionRow {
                        name: format!("joint `{name}`"),
                        entries,
                    });
                }
                Connection::Coupling {
                    name,
                    a,
                    b,
                    element,
                } => {
                    let ca = port_coefficients(graph, &offsets, *a);
                    let cb = port_coefficients(graph, &offsets, *b);
                    match representation {
                        Representation::Monolithic | Representation::InteractionForce => {
                            connection_rows.push(None);
                            couplings.push(GlobalCoupling {
                                connection: index,
                                element: element.clone(),
                                a: ca,
                                b: cb,
                                potential_in_lagrangian: representation
                                    == Representation::Monolithic,
                            });
                        }
                        Representation::Constraint => {
                            let e = offset + endpoints.len();
                            names.push(format!(
                                "{}.endpoint({name})",
                                subsystems[a.subsystem.0].name
                            ));
                            let mut entries = vec![(e, 1.0)];
                            entries.extend(cb.iter().map(|&(i, c)| (i, -c)));
                            connection_rows.push(Some(internal_rows + rows.len()));
                            rows.push(ConnectionRow {
                                name: format!("joint `{name}` (endpoint)"),
                                entries,
                            });
                            endpoints.push((e, cb));
                            couplings.push(GlobalCoupling {
                                connection: index,
                                element: element.clone(),
                                a: ca,
                                b: vec![(e, 1.0)],
                                potential_in_lagrangian: true,
                            });
                        }
                    }
                }
            }
        }
        let holonomic_start = internal_rows + rows.len();
        for h in &mut holonomic {
            h.first_row += holonomic_start;
        }
        for (row, connection) in connection_rows.iter_mut().zip(graph.connections()) {
            if let (Some(r), Connection::Holonomic { .. }) = (row.as_mut(), connection) {
                *r += holonomic_start;
            }
        }
        let dim = offset + endpoints.len();
        let has_force = parts.iter().any(|p| p.model.has_force())
            || couplings.iter().any(|c| {
                c.element.has_force() || (c.element.has_potential() && !c.potential_in_lagrangian)
            });
        let linear = parts.iter().all(|p| p.model.is_linear())
            && couplings.iter().all(|c| c.element.is_linear());
        let constant = parts
            .iter()
            .all(|p| p.rows == 0 || p.constraints.is_constant())
            && holonomic.iter().all(|h| h.constraint.is_linear());
        let hot: Vec<HotPart> = parts
            .iter()
            .map(|p| HotPart {
                model: p.model.clone(),
                offset: p.offset,
                dim: p.dim,
                has_force: p.model.has_force(),
                has_update_limit: p.model.has_update_limit(),
                has_step_check: p.model.has_step_check(),
            })
            .collect();
        let timed_parts = (0..parts.len())
            .filter(|&i| !parts[i].model.is_autonomous())
            .collect();
        let timed_couplings = (0..couplings.len())
            .filter(|&i| !couplings[i].element.is_autonomous())
            .collect();
        let sole = match hot.as_slice() {
            [part] if part.dim == dim && couplings.is_empty() => Some(Arc::clone(&part.model)),
            _ => None,
        };
        let model = AssembledModel {
            groups: group_parts(&hot),
            parts: hot,
            couplings,
            dim,
            names,
            has_force,
            linear,
            has_update_limit: parts.iter().any(|p| p.model.has_update_limit()),
            has_step_check: parts.iter().any(|p| p.model.has_step_check()),
            timed_parts,
            timed_couplings,
            sole,
        };
        let constraints = AssembledConstraints {
            parts,
            internal_rows,
            rows,
            holonomic,
            holonomic_rows,
            constant,
        };
        Ok(AssembledSystem {
            representation,
            model,
            constraints,
            offsets,
            dims,
            endpoints,
            connection_rows,
        })
    }

    /// The per-subsystem models of a staggered co-simulation: each subsystem with its couplings
    /// as forces against frozen partner values. Fails if a node or joint joins subsystems.
    pub fn staggered(graph: &Interconnection) -> Result<StaggeredPlan, GraphError> {
        let subsystems = graph.subsystems();
        let mut links: Vec<Vec<StaggeredLink>> = vec![Vec::new(); subsystems.len()];
        for connection in graph.connections() {
            let Connection::Coupling { a, b, element, .. } = connection else {
                return Err(GraphError::StaggeredNeedsCouplings(
                    connection.name().to_string(),
                ));
            };
            for (side, (me, partner)) in [(*a, *b), (*b, *a)].into_iter().enumerate() {
                links[me.subsystem.0].push(StaggeredLink {
                    element: element.clone(),
                    side,
                    mine: subsystems[me.subsystem.0].ports()[me.port]
                        .coefficients
                        .clone(),
                    partner: partner.subsystem,
                    partner_port: subsystems[partner.subsystem.0].ports()[partner.port]
                        .coefficients
                        .clone(),
                    frozen: Cell::new((0.0, 0.0)),
                });
            }
        }
        let models = subsystems
            .iter()
            .zip(links)
            .map(|(s, links)| FrozenCouplingModel {
                inner: s.model.clone(),
                constraints: s.constraints.clone(),
                links,
            })
            .collect();
        Ok(StaggeredPlan { models })
    }
}

/// One coupling seen from one side in a staggered co-simulation.
#[derive(Clone)]
pub struct StaggeredLink {
    element: Arc<dyn CouplingElement>,
    side: usize,
    mine: Coefficients,
    /// The partner subsystem.
    pub partner: SubsystemId,
    /// The partner port's coefficients in the partner's own coordinates.
    pub partner_port: Coefficients,
    frozen: Cell<(f64, f64)>,
}

/// A subsystem's model plus its couplings as forces against frozen partner port values.
#[derive(Clone)]
pub struct FrozenCouplingModel {
    inner: Arc<dyn Model + Send + Sync>,
    constraints: Arc<dyn Constraints + Send + Sync>,
    links: Vec<StaggeredLink>,
}

impl FrozenCouplingModel {
    /// The couplings of this subsystem.
    #[must_use]
    pub fn links(&self) -> &[StaggeredLink] {
        &self.links
    }

    /// Freezes the partner of link `i` at port position `x` and flow `v`.
    pub fn freeze(&self, i: usize, x: f64, v: f64) {
        self.links[i].frozen.set((x, v));
    }

    /// The subsystem's internal constraints.
    #[must_use]
    pub fn constraints(&self) -> SharedConstraints {
        SharedConstraints(self.constraints.clone())
    }

    fn pair(&self, link: &StaggeredLink, q: &[f64], v: &[f64]) -> ([f64; 2], [f64; 2]) {
        let (xp, vp) = link.frozen.get();
        let (xm, vm) = (combine(q, &link.mine), combine(v, &link.mine));
        if link.side == 0 {
            ([xm, xp], [vm, vp])
        } else {
            ([xp, xm], [vp, vm])
        }
    }
}

impl Model for FrozenCouplingModel {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
        self.inner.lagrangian(q, v)
    }
    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        self.inner.lagrangian_gradient(q, v, lq, lv);
    }
    fn lagrangian_hessian(&self, q: &[f64], v: &[f64], h: &mut LagrangianHessian) {
        self.inner.lagrangian_hessian(q, v, h);
    }
    fn has_force(&self) -> bool {
        self.inner.has_force() || !self.links.is_empty()
    }
    fn force(&self, q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        if self.inner.has_force() {
            self.inner.force(q, v, t, f);
        } else {
            f.fill(0.0);
        }
        for link in &self.links {
            let (x, w) = self.pair(link, q, v);
            let mut mine = 0.0;
            if link.element.has_potential() {
                mine -= link.element.potential_gradient(x[0], x[1])[link.side];
            }
            if link.element.has_force() {
                mine += link.element.force(x, w, t)[link.side];
            }
            for &(i, c) in &link.mine {
                f[i] += c * mine;
            }
        }
    }
    fn force_jacobian(&self, q: &[f64], v: &[f64], t: f64, jac: &mut ForceJacobian) {
        if self.inner.has_force() {
            self.inner.force_jacobian(q, v, t, jac);
        }
        for link in &self.links {
            let (x, w) = self.pair(link, q, v);
            let s = link.side;
            let dq = -link.element.potential_hessian(x[0], x[1])[s][s]
                + if link.element.has_force() {
                    link.element.force_jacobian(x, w, t)[0][s][s]
                } else {
                    0.0
                };
            let dv = if link.element.has_force() {
                link.element.force_jacobian(x, w, t)[1][s][s]
            } else {
                0.0
            };
            for &(i, ci) in &link.mine {
                for &(j, cj) in &link.mine {
                    jac.q.add(i, j, ci * cj * dq);
                    jac.v.add(i, j, ci * cj * dv);
                }
            }
        }
    }
    fn is_linear(&self) -> bool {
        self.inner.is_linear() && self.links.iter().all(|l| l.element.is_linear())
    }
    fn depends_on_time(&self, i: usize) -> bool {
        self.inner.depends_on_time(i)
            || self
                .links
                .iter()
                .any(|l| !l.element.is_autonomous() && l.mine.iter().any(|&(j, _)| j == i))
    }
    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        let links = self
            .links
            .iter()
            .filter_map(|l| l.element.next_breakpoint(t));
        self.inner
            .next_breakpoint(t)
            .into_iter()
            .chain(links)
            .reduce(f64::min)
    }
    fn has_update_limit(&self) -> bool {
        self.inner.has_update_limit()
    }
    fn update_fraction(&self, q: &[f64], v: &[f64], dq: &[f64], dv: &[f64]) -> f64 {
        self.inner.update_fraction(q, v, dq, dv)
    }
    fn has_step_check(&self) -> bool {
        self.inner.has_step_check()
    }
    fn check_step(&self, q0: &[f64], q1: &[f64]) -> Result<(), String> {
        self.inner.check_step(q0, q1)
    }
    fn step_turns(&self, q0: &[f64], q1: &[f64], turns: &mut Vec<f64>) {
        self.inner.step_turns(q0, q1, turns);
    }
    fn coordinate_name(&self, i: usize) -> String {
        self.inner.coordinate_name(i)
    }
}

/// Constraints shared through an `Arc` (a subsystem's internal constraints).
#[derive(Clone)]
pub struct SharedConstraints(Arc<dyn Constraints + Send + Sync>);

impl Constraints for SharedConstraints {
    fn count(&self) -> usize {
        self.0.count()
    }
    fn kind(&self, a: usize) -> ConstraintKind {
        self.0.kind(a)
    }
    fn forms(&self, q: &[f64], out: &mut Triplets) {
        self.0.forms(q, out);
    }
    fn values(&self, q: &[f64], out: &mut [f64]) {
        self.0.values(q, out);
    }
    fn is_constant(&self) -> bool {
        self.0.is_constant()
    }
    fn multiplier_hessian(&self, q: &[f64], lambda: &[f64], out: &mut Triplets) {
        self.0.multiplier_hessian(q, lambda, out);
    }
    fn contracted_derivative(&self, q: &[f64], w: &[f64], out: &mut Triplets) {
        self.0.contracted_derivative(q, w, out);
    }
    fn name(&self, a: usize) -> String {
        self.0.name(a)
    }
}

/// Per-subsystem models for staggered co-simulation, built by [`Assembler::staggered`].
pub struct StaggeredPlan {
    /// One model per subsystem, in graph order.
    pub models: Vec<FrozenCouplingModel>,
}

#[cfg(test)]
mod tests {
    //! The assembler against hand-written sums and finite differences: the assembled Lagrangian is
    //! `Σ Lᵢ − Σ V_c` (monolithic, constraint) or `Σ Lᵢ` (force), evaluated here from the parts'
    //! formulas; its gradient, Hessian and force Jacobian are checked against central differences
    //! of the assembled Lagrangian and force, on ports that are combinations of coordinates with
    //! coefficients other than one (so a dropped or squared coefficient shows).

    use super::*;
    use crate::coupling::{LinearDamper, LinearSpring};
    use crate::subsystem::Subsystem;
    use dirac_core::LinearForms;

    /// `L = ½ m v² − ½ k x² − ¼ a x⁴`, `f = −c v (1 + x²)`.
    #[derive(Clone, Copy)]
    struct Bead {
        m: f64,
        k: f64,
        a: f64,
        c: f64,
    }

    impl Bead {
        fn l(&self, x: f64, v: f64) -> f64 {
            0.5 * self.m * v * v - 0.5 * self.k * x * x - 0.25 * self.a * x.powi(4)
        }
        fn f(&self, x: f64, v: f64) -> f64 {
            -self.c * v * (1.0 + x * x)
        }
    }

    impl Model for Bead {
        fn dim(&self) -> usize {
            1
        }
        fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
            self.l(q[0], v[0])
        }
        fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
            lq[0] = -self.k * q[0] - self.a * q[0].powi(3);
            lv[0] = self.m * v[0];
        }
        fn lagrangian_hessian(&self, q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
            h.qq.add(0, 0, -self.k - 3.0 * self.a * q[0] * q[0]);
            h.vv.add(0, 0, self.m);
        }
        fn has_force(&self) -> bool {
            true
        }
        fn force(&self, q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
            f[0] = self.f(q[0], v[0]);
        }
        fn force_jacobian(&self, q: &[f64], v: &[f64], _t: f64, j: &mut ForceJacobian) {
            j.q.add(0, 0, -2.0 * self.c * v[0] * q[0]);
            j.v.add(0, 0, -self.c * (1.0 + q[0] * q[0]));
        }
        fn coordinate_name(&self, _i: usize) -> String {
            "x".into()
        }
    }

    /// `L = ½(v₀² + 2v₁²) + 0.3 v₀ q₁ − ½(q₀ − q₁)²`, no force.
    #[derive(Clone, Copy)]
    struct Pair;

    impl Pair {
        fn l(q: &[f64], v: &[f64]) -> f64 {
            0.5 * (v[0] * v[0] + 2.0 * v[1] * v[1]) + 0.3 * v[0] * q[1]
                - 0.5 * (q[0] - q[1]).powi(2)
        }
    }

    impl Model for Pair {
        fn dim(&self) -> usize {
            2
        }
        fn lagrangian(&self, q: &[f64], v: &[f64]) -> f64 {
            Self::l(q, v)
        }
        fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
            lq[0] = -(q[0] - q[1]);
            lq[1] = (q[0] - q[1]) + 0.3 * v[0];
            lv[0] = v[0] + 0.3 * q[1];
            lv[1] = 2.0 * v[1];
        }
        fn lagrangian_hessian(&self, _q: &[f64], _v: &[f64], h: &mut LagrangianHessian) {
            h.qq.add(0, 0, -1.0);
            h.qq.add(0, 1, 1.0);
            h.qq.add(1, 0, 1.0);
            h.qq.add(1, 1, -1.0);
            h.qv.add(1, 0, 0.3);
            h.vv.add(0, 0, 1.0);
            h.vv.add(1, 1, 2.0);
        }
    }

    /// `V = ⅓κ(x_a − x_b)³`, `f_a = −c(v_a − v_b)(1 + x_a²) = −f_b`: a nonlinear potential and a
    /// position-dependent force, so every block of the coupling's derivatives is exercised.
    struct Cubic {
        kappa: f64,
        c: f64,
    }

    impl CouplingElement for Cubic {
        fn has_potential(&self) -> bool {
            true
        }
        fn potential(&self, xa: f64, xb: f64) -> f64 {
            self.kappa * (xa - xb).powi(3) / 3.0
        }
        fn potential_gradient(&self, xa: f64, xb: f64) -> [f64; 2] {
            let g = self.kappa * (xa - xb).powi(2);
            [g, -g]
        }
        fn potential_hessian(&self, xa: f64, xb: f64) -> [[f64; 2]; 2] {
            let h = 2.0 * self.kappa * (xa - xb);
            [[h, -h], [-h, h]]
        }
        fn has_force(&self) -> bool {
            true
        }
        fn force(&self, x: [f64; 2], v: [f64; 2], _t: f64) -> [f64; 2] {
            let f = -self.c * (v[0] - v[1]) * (1.0 + x[0] * x[0]);
            [f, -f]
        }
        fn force_jacobian(&self, x: [f64; 2], v: [f64; 2], _t: f64) -> [[[f64; 2]; 2]; 2] {
            let dx = -self.c * (v[0] - v[1]) * 2.0 * x[0];
            let dv = -self.c * (1.0 + x[0] * x[0]);
            [[[dx, 0.0], [-dx, 0.0]], [[dv, -dv], [-dv, dv]]]
        }
        fn is_linear(&self) -> bool {
            false
        }
        fn describe(&self) -> String {
            "cubic".into()
        }
    }

    const A: Bead = Bead {
        m: 1.5,
        k: 2.0,
        a: 0.7,
        c: 0.2,
    };
    const B: Bead = Bead {
        m: 0.5,
        k: 1.0,
        a: 0.0,
        c: 0.0,
    };

    /// Pair P (internal row `q₀' − 2q₁' = 0`, port `y = 0.5 q₀ + 2 q₁`), beads A and B (port `x`),
    /// bead C (port `x` = −1.5 x): a spring A–P, the cubic element P–B, a damper B–C, a joint A–C
    /// and a node joining P.y, A.x and B.x.
    fn graph() -> Interconnection {
        let mut g = Interconnection::new();
        let mut internal = LinearForms::new(2);
        internal.push("slide", &[(0, 1.0), (1, -2.0)]);
        g.add_subsystem(
            Subsystem::new("P", Pair)
                .with_constraints(internal)
                .with_combination_port("y", vec![(0, 0.5), (1, 2.0)]),
        )
        .unwrap();
        g.add_subsystem(Subsystem::new("A", A).with_port("x", 0))
            .unwrap();
        g.add_subsystem(Subsystem::new("B", B).with_port("x", 0))
            .unwrap();
        g.add_subsystem(Subsystem::new("C", B).with_combination_port("x", vec![(0, -1.5)]))
            .unwrap();
        let port = |g: &Interconnection, s: &str, p: &str| g.port(s, p).unwrap();
        let (py, ax, bx, cx) = (
            port(&g, "P", "y"),
            port(&g, "A", "x"),
            port(&g, "B", "x"),
            port(&g, "C", "x"),
        );
        g.coupling("s", ax, py, LinearSpring { k: 3.0, rest: 0.2 });
        g.coupling("cubic", py, bx, Cubic { kappa: 0.8, c: 0.3 });
        g.coupling("d", bx, cx, LinearDamper { c: 0.4 });
        g.joint("j", ax, cx);
        g.node("n", vec![(py, 1.0), (ax, -1.0), (bx, 1.0)]).unwrap();
        g
    }

    /// A state of the global coordinates (subsystems, then endpoints).
    fn state(n: usize, seed: f64) -> Vec<f64> {
        (0..n)
            .map(|i| (seed + 0.37 * i as f64).sin() * 0.9)
            .collect()
    }

    /// The assembled Lagrangian and force, written out from the parts' formulas.
    fn by_hand(rep: Representation, q: &[f64], v: &[f64]) -> (f64, Vec<f64>) {
        let (y, vy) = (0.5 * q[0] + 2.0 * q[1], 0.5 * v[0] + 2.0 * v[1]);
        let (xa, xb) = (q[2], q[3]);
        let (vb, vc) = (v[3], -1.5 * v[4]);
        let mut l = Pair::l(&q[..2], &v[..2]) + A.l(q[2], v[2]) + B.l(q[3], v[3]) + B.l(q[4], v[4]);
        let spring = |x1: f64, x2: f64| 0.5 * 3.0 * (x1 - x2 - 0.2).powi(2);
        let cubic = |x1: f64, x2: f64| 0.8 * (x1 - x2).powi(3) / 3.0;
        let mut f = vec![0.0; q.len()];
        f[2] = A.f(q[2], v[2]);
        // Cubic's force on its ports: f_a = −0.3(v_a − v_b)(1 + x_a²) on y, −f_a on B.x.
        let fc = |x1: f64, v1: f64, v2: f64| -0.3 * (v1 - v2) * (1.0 + x1 * x1);
        // Damper on B.x (first port) and C.x (second, coefficient −1.5): [fd, −fd].
        let fd = -0.4 * (vb - vc);
        match rep {
            Representation::Monolithic => {
                l -= spring(xa, y) + cubic(y, xb);
                let g = fc(y, vy, vb);
                f[0] += 0.5 * g;
                f[1] += 2.0 * g;
                f[3] += -g + fd;
                f[4] += -1.5 * -fd;
            }
            Representation::InteractionForce => {
                // Potentials become forces −∂V/∂x on the ports.
                let gs = 3.0 * (xa - y - 0.2);
                let gc = 0.8 * (y - xb).powi(2);
                let g = fc(y, vy, vb);
                f[2] += -gs;
                f[0] += 0.5 * (gs - gc + g);
                f[1] += 2.0 * (gs - gc + g);
                f[3] += gc - g + fd;
                f[4] += -1.5 * -fd;
            }
            Representation::Constraint => {
                // Endpoints e_s (of A, for s, partner P.y), e_c (of P, for cubic, partner B.x),
                // e_d (of B, for d, partner C.x) at 5, 6, 7; potentials act on the endpoint.
                let (es, ec) = (q[5], q[6]);
                let (vec_, ved) = (v[6], v[7]);
                l -= spring(xa, es) + cubic(y, ec);
                let g = fc(y, vy, vec_);
                f[0] += 0.5 * g;
                f[1] += 2.0 * g;
                f[6] += -g;
                let fd = -0.4 * (vb - ved);
                f[3] += fd;
                f[7] += -fd;
            }
        }
        (l, f)
    }

    fn dense(t: &Triplets, n: usize) -> Vec<Vec<f64>> {
        let mut m = vec![vec![0.0; n]; n];
        for (r, c, v) in t.iter() {
            m[r][c] += v;
        }
        m
    }

    /// Largest `|a − b|` relative to `1 + |b|` over two matrices or vectors.
    fn close(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs() / (1.0 + y.abs())))
    }

    /// Central differences with δ = 1e-6 of a function of order one: truncation ≈ δ², round-off
    /// ≈ ε/δ, so agreement to about 1e-9; the figures below measured at most 2e-10.
    const DIFFERENCES: f64 = 1e-8;

    #[test]
    fn assembled_model_is_the_sum_of_its_parts() {
        let g = graph();
        for rep in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            let system = Assembler::assemble(&g, rep).unwrap();
            let model = &system.model;
            let n = model.dim();
            assert_eq!(
                n,
                if rep == Representation::Constraint {
                    8
                } else {
                    5
                }
            );
            let (q, v) = (state(n, 0.3), state(n, 1.1));
            let (l, f) = by_hand(rep, &q, &v);
            assert!(
                (model.lagrangian(&q, &v) - l).abs() <= 1e-14 * (1.0 + l.abs()),
                "{rep}: L = {} by hand {l}",
                model.lagrangian(&q, &v)
            );
            let mut force = vec![f64::NAN; n];
            model.force(&q, &v, 0.0, &mut force);
            assert!(
                close(&force, &f) <= 1e-14,
                "{rep}: f = {force:?}, by hand {f:?}"
            );

            // Gradient and Hessian against central differences of L; force Jacobian of f.
            let d = 1e-6;
            let (mut lq, mut lv) = (vec![f64::NAN; n], vec![f64::NAN; n]);
            model.lagrangian_gradient(&q, &v, &mut lq, &mut lv);
            let mut hess = LagrangianHessian::default();
            hess.begin();
            model.lagrangian_hessian(&q, &v, &mut hess);
            let mut jac = ForceJacobian::default();
            jac.begin();
            model.force_jacobian(&q, &v, 0.0, &mut jac);
            let (hqq, hqv, hvv) = (dense(&hess.qq, n), dense(&hess.qv, n), dense(&hess.vv, n));
            let (jq, jv) = (dense(&jac.q, n), dense(&jac.v, n));
            let mut worst = 0.0_f64;
            for j in 0..n {
                let shifted = |dq: f64, dv: f64| {
                    let (mut q1, mut v1) = (q.clone(), v.clone());
                    q1[j] += dq;
                    v1[j] += dv;
                    let (mut gq, mut gv, mut f1) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                    model.lagrangian_gradient(&q1, &v1, &mut gq, &mut gv);
                    model.force(&q1, &v1, 0.0, &mut f1);
                    (model.lagrangian(&q1, &v1), gq, gv, f1)
                };
                let (lp, gqp, _, fp) = shifted(d, 0.0);
                let (lm, gqm, _, fm) = shifted(-d, 0.0);
                let (lvp, gq_vp, gv_vp, fvp) = shifted(0.0, d);
                let (lvm, gq_vm, gv_vm, fvm) = shifted(0.0, -d);
                let diff = |a: &[f64], b: &[f64]| -> Vec<f64> {
                    a.iter().zip(b).map(|(x, y)| (x - y) / (2.0 * d)).collect()
                };
                worst = worst.max(close(&[lq[j]], &[(lp - lm) / (2.0 * d)]));
                worst = worst.max(close(&[lv[j]], &[(lvp - lvm) / (2.0 * d)]));
                // Column j of each block: ∂(∂L/∂q_i)/∂q_j = hqq[i][j], ∂(∂L/∂q_i)/∂v_j = hqv[i][j],
                // ∂(∂L/∂v_i)/∂v_j = hvv[i][j]; ∂f_i/∂q_j = jq[i][j], ∂f_i/∂v_j = jv[i][j].
                let column = |m: &[Vec<f64>]| -> Vec<f64> { m.iter().map(|r| r[j]).collect() };
                worst = worst.max(close(&column(&hqq), &diff(&gqp, &gqm)));
                worst = worst.max(close(&column(&hqv), &diff(&gq_vp, &gq_vm)));
                worst = worst.max(close(&column(&hvv), &diff(&gv_vp, &gv_vm)));
                worst = worst.max(close(&column(&jq), &diff(&fp, &fm)));
                worst = worst.max(close(&column(&jv), &diff(&fvp, &fvm)));
            }
            println!("{rep}: derivatives against central differences {worst:.1e}");
            assert!(worst <= DIFFERENCES, "{rep}: derivatives off by {worst:e}");
        }
    }

    /// A one-part system is the part: its gradient and force are the part's, bit for bit, in
    /// every representation; a coupling between two of the part's own ports adds its spring and
    /// damper to them (so the part alone is no longer the whole system).
    #[test]
    fn a_one_part_system_is_the_part_unless_coupled_to_itself() {
        let bead = Bead {
            m: 1.3,
            k: 0.7,
            a: 0.2,
            c: 0.05,
        };
        let (q, v) = ([0.4, -0.9], [1.1, 0.3]);
        let mut alone = Interconnection::new();
        alone
            .add_subsystem(
                Subsystem::new("P", Pair)
                    .with_port("a", 0)
                    .with_port("b", 1),
            )
            .unwrap();
        let mut single = Interconnection::new();
        single.add_subsystem(Subsystem::new("B", bead)).unwrap();
        for rep in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            for (graph, part) in [
                (&alone, &Pair as &dyn Model),
                (&single, &bead as &dyn Model),
            ] {
                let model = Assembler::assemble(graph, rep).unwrap().model;
                let n = part.dim();
                let (mut lq, mut lv) = (vec![f64::NAN; n], vec![f64::NAN; n]);
                let (mut pq, mut pv) = (vec![0.0; n], vec![0.0; n]);
                model.lagrangian_gradient(&q[..n], &v[..n], &mut lq, &mut lv);
                part.lagrangian_gradient(&q[..n], &v[..n], &mut pq, &mut pv);
                assert_eq!((&lq, &lv), (&pq, &pv), "{rep}: gradient");
                let (mut f, mut pf) = (vec![f64::NAN; n], vec![f64::NAN; n]);
                model.force(&q[..n], &v[..n], 0.0, &mut f);
                part.force(&q[..n], &v[..n], 0.0, &mut pf);
                assert_eq!(f, pf, "{rep}: force");
            }
        }
        // P's ports a = q₀ and b = q₁ joined by a spring (k = 3, rest 0.2) and a damper (c = 0.4).
        let mut coupled = alone.clone();
        let (a, b) = (
            coupled.port("P", "a").unwrap(),
            coupled.port("P", "b").unwrap(),
        );
        coupled.coupling("s", a, b, LinearSpring { k: 3.0, rest: 0.2 });
        coupled.coupling("d", a, b, LinearDamper { c: 0.4 });
        let model = Assembler::assemble(&coupled, Representation::Monolithic)
            .unwrap()
            .model;
        let (mut lq, mut lv) = ([0.0; 2], [0.0; 2]);
        model.lagrangian_gradient(&q, &v, &mut lq, &mut lv);
        let stretch = 3.0 * (q[0] - q[1] - 0.2);
        assert!((lq[0] - (-(q[0] - q[1]) - stretch)).abs() <= 1e-15);
        assert!((lq[1] - ((q[0] - q[1]) + 0.3 * v[0] + stretch)).abs() <= 1e-15);
        let mut f = [f64::NAN; 2];
        model.force(&q, &v, 0.0, &mut f);
        let damping = -0.4 * (v[0] - v[1]);
        assert_eq!(f, [damping, -damping]);
    }

    /// The constraint rows, written out: P's internal row at P's offset, then one row per node,
    /// joint and (constraint form) coupling endpoint, with the ports' coefficients and signs.
    #[test]
    fn constraint_rows_are_the_internal_rows_and_the_connections() {
        let g = graph();
        // (name, entries) per row; coordinates: P = 0, 1; A = 2; B = 3; C = 4; endpoints 5, 6, 7.
        let internal = ("P/slide", vec![(0, 1.0), (1, -2.0)]);
        let joint = ("joint `j`", vec![(2, 1.0), (4, 1.5)]);
        let node = (
            "node `n` (KCL)",
            vec![(0, 0.5), (1, 2.0), (2, -1.0), (3, 1.0)],
        );
        for rep in [
            Representation::Monolithic,
            Representation::Constraint,
            Representation::InteractionForce,
        ] {
            let system = Assembler::assemble(&g, rep).unwrap();
            let mut want = vec![internal.clone()];
            // Connections in order: s, cubic, d, j, n.
            let mut rows_of = vec![None, None, None, Some(1), Some(2)];
            if rep == Representation::Constraint {
                want.push(("joint `s` (endpoint)", vec![(5, 1.0), (0, -0.5), (1, -2.0)]));
                want.push(("joint `cubic` (endpoint)", vec![(6, 1.0), (3, -1.0)]));
                want.push(("joint `d` (endpoint)", vec![(7, 1.0), (4, 1.5)]));
                rows_of = vec![Some(1), Some(2), Some(3), Some(4), Some(5)];
            }
            want.push(joint.clone());
            want.push(node.clone());
            let c = &system.constraints;
            assert_eq!(c.count(), want.len(), "{rep}");
            let n = system.coordinates();
            let mut forms = Triplets::new();
            forms.begin();
            c.forms(&vec![0.3; n], &mut forms);
            for (a, (name, entries)) in want.iter().enumerate() {
                assert_eq!(&c.name(a), name, "{rep}: row {a}");
                assert_eq!(c.kind(a), ConstraintKind::OneForm);
                let mut got: Vec<(usize, f64)> = forms
                    .iter()
                    .filter(|(r, _, _)| *r == a)
                    .map(|(_, j, v)| (j, v))
                    .collect();
                got.sort_by_key(|x| x.0);
                let mut entries = entries.clone();
                entries.sort_by_key(|x| x.0);
                assert_eq!(got, entries, "{rep}: row {a} ({name})");
            }
            for (connection, row) in rows_of.iter().enumerate() {
                assert_eq!(
                    system.connection_row(connection),
                    *row,
                    "{rep}: {connection}"
                );
            }
            assert!(c.is_constant());
        }
    }

    /// Initial data: endpoint entries take the partner port's value; a wrong length is a typed
    /// error naming the subsystem. Momenta: each endpoint's momentum is added to its partner
    /// port's coordinates with the port's coefficients.
    #[test]
    fn endpoints_take_and_return_their_partners_values() {
        let g = graph();
        let system = Assembler::assemble(&g, Representation::Constraint).unwrap();
        let names: Vec<String> = ["P", "A", "B", "C"].map(String::from).to_vec();
        let per = vec![vec![0.2, -0.4], vec![1.0], vec![-0.5], vec![0.6]];
        let q = system.global_vector(&per, &names).unwrap();
        // Partners: s → P.y = 0.5·0.2 + 2·(−0.4); cubic → B.x; d → C.x = −1.5·0.6.
        assert_eq!(
            q,
            vec![
                0.2,
                -0.4,
                1.0,
                -0.5,
                0.6,
                0.5 * 0.2 + 2.0 * -0.4,
                -0.5,
                -1.5 * 0.6
            ]
        );
        let bad = vec![vec![0.2], vec![1.0], vec![-0.5], vec![0.6]];
        assert_eq!(
            system.global_vector(&bad, &names),
            Err(GraphError::InitialDimension {
                subsystem: "P".into(),
                got: 1,
                expected: 2
            })
        );
        let p = [1.0, 2.0, 3.0, 4.0, 5.0, 10.0, 20.0, 30.0];
        assert_eq!(
            system.subsystem_momenta(&p),
            vec![
                1.0 + 0.5 * 10.0,
                2.0 + 2.0 * 10.0,
                3.0,
                4.0 + 20.0,
                5.0 - 1.5 * 30.0
            ]
        );
        assert_eq!(system.subsystem_positions(&p), &p[..5]);
        assert_eq!(system.subsystem_coordinates(), 5);
        assert_eq!(system.global_index(crate::SubsystemId(2), 0), 3);
    }

    /// Staggered co-simulation needs couplings only; a subsystem's frozen-coupling model applies
    /// the coupling's force with the partner held at the frozen value, on its own side.
    #[test]
    fn staggered_plan_freezes_the_partner() {
        assert_eq!(
            Assembler::staggered(&graph()).err(),
            Some(GraphError::StaggeredNeedsCouplings("j".into()))
        );
        let mut g = Interconnection::new();
        g.add_subsystem(Subsystem::new("A", A).with_port("x", 0))
            .unwrap();
        g.add_subsystem(Subsystem::new("B", B).with_combination_port("x", vec![(0, 2.0)]))
            .unwrap();
        let (a, b) = (g.port("A", "x").unwrap(), g.port("B", "x").unwrap());
        g.coupling("s", a, b, LinearSpring { k: 3.0, rest: 0.2 });
        let plan = Assembler::staggered(&g).unwrap();
        let (ma, mb) = (&plan.models[0], &plan.models[1]);
        ma.freeze(0, 0.7, 0.0);
        mb.freeze(0, -0.4, 0.0);
        let mut f = [f64::NAN];
        // A at x = 0.1 against B.x frozen at 0.7: own force plus −k(x_a − x_b − ℓ).
        ma.force(&[0.1], &[0.5], 0.0, &mut f);
        let want = A.f(0.1, 0.5) - 3.0 * (0.1 - 0.7 - 0.2);
        assert!((f[0] - want).abs() <= 1e-15, "{} vs {want}", f[0]);
        // B (port 2·x) at x = 0.3 against A.x frozen at −0.4: 2·k(x_a − x_b − ℓ).
        mb.force(&[0.3], &[0.0], 0.0, &mut f);
        let want = 2.0 * 3.0 * (-0.4 - 0.6 - 0.2);
        assert!((f[0] - want).abs() <= 1e-15, "{} vs {want}", f[0]);
        assert_eq!(ma.links()[0].partner, crate::SubsystemId(1));
    }
}
