//! Subsystems: a model, its internal constraints and its ports.

use std::sync::Arc;

use dirac_core::{Constraints, Model, NoConstraints};

/// A port: a linear combination `Σ cᵢ qᵢ` of a subsystem's coordinates whose velocity is a flow
/// (a branch current, a point's velocity, a shaft's angular velocity). Its conjugate effort is
/// what an interaction force acts through.
#[derive(Debug, Clone, PartialEq)]
pub struct Port {
    /// Port name, unique within the subsystem.
    pub name: String,
    /// `(local coordinate, coefficient)` pairs.
    pub coefficients: Vec<(usize, f64)>,
}

/// A model on its own coordinates with internal constraints and named ports.
///
/// It knows nothing of the graph it is placed in.
#[derive(Clone)]
pub struct Subsystem {
    pub(crate) name: String,
    pub(crate) model: Arc<dyn Model + Send + Sync>,
    pub(crate) constraints: Arc<dyn Constraints + Send + Sync>,
    pub(crate) ports: Vec<Port>,
}

impl std::fmt::Debug for Subsystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Subsystem")
            .field("name", &self.name)
            .field("dim", &self.model.dim())
            .field("constraints", &self.constraints.count())
            .field("ports", &self.ports)
            .finish()
    }
}

impl Subsystem {
    /// A subsystem named `name` with model `model`, no internal constraints and no ports.
    pub fn new(name: impl Into<String>, model: impl Model + Send + Sync + 'static) -> Self {
        Self {
            name: name.into(),
            model: Arc::new(model),
            constraints: Arc::new(NoConstraints),
            ports: Vec::new(),
        }
    }

    /// Sets the internal constraints (their rows act on the subsystem's own coordinates).
    #[must_use]
    pub fn with_constraints(
        mut self,
        constraints: impl Constraints + Send + Sync + 'static,
    ) -> Self {
        self.constraints = Arc::new(constraints);
        self
    }

    /// Adds a port that is the single coordinate `coordinate`.
    #[must_use]
    pub fn with_port(self, name: impl Into<String>, coordinate: usize) -> Self {
        self.with_combination_port(name, vec![(coordinate, 1.0)])
    }

    /// Adds a port that is a linear combination of coordinates.
    #[must_use]
    pub fn with_combination_port(
        mut self,
        name: impl Into<String>,
        coefficients: Vec<(usize, f64)>,
    ) -> Self {
        self.ports.push(Port {
            name: name.into(),
            coefficients,
        });
        self
    }

    /// Another instance of the same part definition under a new name. The model and constraints
    /// are shared (not copied), so a ladder of 10⁵ identical sections holds one model in memory.
    #[must_use]
    pub fn renamed(&self, name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            ..self.clone()
        }
    }

    /// The subsystem's name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The model.
    #[must_use]
    pub fn model(&self) -> &(dyn Model + Send + Sync) {
        self.model.as_ref()
    }

    /// The internal constraints.
    #[must_use]
    pub fn constraints(&self) -> &(dyn Constraints + Send + Sync) {
        self.constraints.as_ref()
    }

    /// The ports.
    #[must_use]
    pub fn ports(&self) -> &[Port] {
        &self.ports
    }

    /// Index of the port named `name`.
    #[must_use]
    pub fn port_index(&self, name: &str) -> Option<usize> {
        self.ports.iter().position(|p| p.name == name)
    }
}
