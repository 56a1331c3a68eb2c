//! Where recorded rows go: a [`Sink`] streams them (to a file, a socket, a reduction), a
//! [`Trajectory`] keeps them in memory.

/// Receiver of a run's rows: the column names once, then one row per output time `t_k`.
pub trait Sink {
    /// Called once before the first row with the signal names (the time column excluded).
    ///
    /// # Errors
    /// A message when the destination cannot take the rows (the run stops with it).
    fn begin(&mut self, names: &[String]) -> Result<(), String>;

    /// Row `k` at time `t_k = t_0 + k·h` with one value per signal.
    ///
    /// # Errors
    /// A message when the destination cannot take the row (the run stops with it).
    fn row(&mut self, k: usize, t: f64, values: &[f64]) -> Result<(), String>;

    /// From what time on the sink takes [`Sink::sample`]s (`None`, the default: none, and a
    /// run then reads nothing between the rows). States before it are not read.
    fn samples_from(&self) -> Option<f64> {
        None
    }

    /// The signals at the end of a substep inside a step (a time `t` between two rows, not
    /// before [`Sink::samples_from`]: a source breakpoint, a piece of a refined step, a ramp's
    /// substep; see [`crate::Integrator::record_inner_states`]), in time order among themselves
    /// but in no order relative to the rows; `NaN` where the state there does not determine a
    /// value (one the rows read from the steps around them).
    ///
    /// # Errors
    /// A message when the destination cannot take the sample (the run stops with it).
    fn sample(&mut self, t: f64, values: &[f64]) -> Result<(), String> {
        let _ = (t, values);
        Ok(())
    }
}

/// Every row of a run in memory: times and named columns.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    names: Vec<String>,
    t: Vec<f64>,
    values: Vec<f64>,
}

impl Trajectory {
    /// An empty trajectory (filled by a run).
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The output times `t_0, t_0 + h, …`.
    #[must_use]
    pub fn t(&self) -> &[f64] {
        &self.t
    }

    /// The signal names, in column order.
    #[must_use]
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Number of rows.
    #[must_use]
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether there are no rows.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Row `k`: one value per signal.
    #[must_use]
    pub fn row(&self, k: usize) -> &[f64] {
        let w = self.names.len();
        &self.values[k * w..(k + 1) * w]
    }

    /// The largest `|x − y|` between this trajectory and `other`, row by row and signal by signal
    /// over the rows both have (how far two representations of one model apart ran). A NaN on
    /// either side makes the result NaN instead of being skipped.
    #[must_use]
    pub fn max_deviation(&self, other: &Trajectory) -> f64 {
        (0..self.len().min(other.len()))
            .flat_map(|k| self.row(k).iter().zip(other.row(k)))
            .map(|(x, y)| (x - y).abs())
            .fold(0.0_f64, |m, d| if d.is_nan() { f64::NAN } else { m.max(d) })
    }

    /// The column of signal `name`, if recorded.
    #[must_use]
    pub fn signal(&self, name: &str) -> Option<Vec<f64>> {
        let c = self.names.iter().position(|n| n == name)?;
        Some(self.column(c))
    }

    /// Column `c`.
    #[must_use]
    pub fn column(&self, c: usize) -> Vec<f64> {
        let w = self.names.len();
        self.values
            .iter()
            .skip(c)
            .step_by(w.max(1))
            .copied()
            .collect()
    }
}

impl Sink for Trajectory {
    fn begin(&mut self, names: &[String]) -> Result<(), String> {
        self.names = names.to_vec();
        self.t.clear();
        self.values.clear();
        Ok(())
    }

    fn row(&mut self, _k: usize, t: f64, values: &[f64]) -> Result<(), String> {
        self.t.push(t);
        self.values.extend_from_slice(values);
        Ok(())
    }
}

impl<F: FnMut(usize, f64, &[f64]) -> Result<(), String>> Sink for F {
    fn begin(&mut self, _names: &[String]) -> Result<(), String> {
        Ok(())
    }

    fn row(&mut self, k: usize, t: f64, values: &[f64]) -> Result<(), String> {
        self(k, t, values)
    }
}

#[cfg(test)]
mod tests {
    use super::{Sink, Trajectory};

    fn trajectory(rows: &[[f64; 2]]) -> Trajectory {
        let mut t = Trajectory::new();
        t.begin(&["a".into(), "b".into()]).unwrap();
        for (k, r) in rows.iter().enumerate() {
            Sink::row(&mut t, k, k as f64, r).unwrap();
        }
        t
    }

    /// The deviation is the largest entry-wise difference over the common rows, and a NaN is
    /// reported, not skipped (a fold with `f64::max` alone returns 0 for an all-NaN run).
    #[test]
    fn max_deviation_is_entrywise_and_sees_nan() {
        let x = trajectory(&[[1.0, 2.0], [3.0, 4.0], [9.0, 9.0]]);
        let y = trajectory(&[[1.0, 2.5], [2.0, 4.0]]);
        assert_eq!(x.max_deviation(&y), 1.0);
        assert_eq!(y.max_deviation(&x), 1.0);
        let nan = trajectory(&[[f64::NAN, f64::NAN], [f64::NAN, f64::NAN]]);
        assert!(x.max_deviation(&nan).is_nan());
    }
}
