//! The assembler: one interconnection graph → a model and constraints on global coordinates.

use std::cell::Cell;
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
    couplings: Vec<GlobalCoupling>,
    dim: usize,
    names: Vec<String>,
    has_force: bool,
    linear: bool,
    autonomous: bool,
}

impl AssembledModel {
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
        for c in self
            .couplings
            .iter()
            .filter(|c| c.potential_in_lagrangian && c.element.has_potential())
        {
            l -= c.element.potential(combine(q, &c.a), combine(q, &c.b));
        }
        l
    }

    fn lagrangian_gradient(&self, q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        let covered: usize = self.parts.last().map_or(0, |p| p.offset + p.dim);
        lq[covered..].fill(0.0);
        lv[covered..].fill(0.0);
        for p in &self.parts {
            let r = p.offset..p.offset + p.dim;
            p.model.lagrangian_gradient(
                &q[r.clone()],
                &v[r.clone()],
                &mut lq[r.clone()],
                &mut lv[r],
            );
        }
        for c in self
            .couplings
            .iter()
            .filter(|c| c.potential_in_lagrangian && c.element.has_potential())
        {
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
        for c in self
            .couplings
            .iter()
            .filter(|c| c.potential_in_lagrangian && c.element.has_potential())
        {
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

    fn force(&self, q: &[f64], v: &[f64], t: f64, f: &mut [f64]) {
        let covered: usize = self.parts.last().map_or(0, |p| p.offset + p.dim);
        f[covered..].fill(0.0);
        for p in &self.parts {
            let r = p.offset..p.offset + p.dim;
            if p.has_force {
                p.model.force(&q[r.clone()], &v[r.clone()], t, &mut f[r]);
            } else {
                f[r].fill(0.0);
            }
        }
        self.stamp_coupling_force(q, v, t, f);
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
        self.autonomous
    }

    fn depends_on_time(&self, i: usize) -> bool {
        let part = self.parts.partition_point(|p| p.offset + p.dim <= i);
        let own = self
            .parts
            .get(part)
            .is_some_and(|p| i >= p.offset && p.model.depends_on_time(i - p.offset));
        own || self.couplings.iter().any(|c| {
            !c.element.is_autonomous() && c.ports().iter().any(|p| p.iter().any(|&(j, _)| j == i))
        })
    }

    fn next_breakpoint(&self, t: f64) -> Option<f64> {
        let parts = self.parts.iter().filter_map(|p| p.model.next_breakpoint(t));
        let couplings = self
            .couplings
            .iter()
            .filter_map(|c| c.element.next_breakpoint(t));
        parts.chain(couplings).reduce(f64::min)
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
    /// coordinate, impulse Λ·c)` for every coordinate the row touches. `multipliers` holds one
    /// value per constraint row (see `Integrator::last_multipliers_full`). Divided by `h` these
    /// are the interaction forces; for a joint they act equal and opposite on its two ports.
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
                out.push((c, i, multipliers[*row] * k));
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
        let mut out = p[..self.subsystem_coordinates()].to_vec();
        for (e, partner) in &self.endpoints {
            for &(i, c) in partner {
                out[i] += c * p[*e];
            }
        }
        out
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
        let autonomous = parts.iter().all(|p| p.model.is_autonomous())
            && couplings.iter().all(|c| c.element.is_autonomous());
        let model = AssembledModel {
            parts: parts
                .iter()
                .map(|p| HotPart {
                    model: p.model.clone(),
                    offset: p.offset,
                    dim: p.dim,
                    has_force: p.model.has_force(),
                })
                .collect(),
            couplings,
            dim,
            names,
            has_force,
            linear,
            autonomous,
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
