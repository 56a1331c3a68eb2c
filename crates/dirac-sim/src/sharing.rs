//! Charge sharing along loops of junction and capacitor charges (docs/math.md §7): the
//! directions of the state that the steps do not see, which the readout removes before reading
//! and the truncation-error test leaves out of its estimate.

use dirac_solve::Triplets;

/// Marks a coordinate or constraint row without a shift.
const OUT: usize = usize::MAX;

/// Charge sharing: shifts `δ` of degenerate positions that the readout may make to reach a
/// state its relations can all hold at, and that the truncation-error test must not judge
/// (docs/math.md §7).
///
/// A junction's charge is a momentum (`p_φ = Q_j(φ̇)`) and a capacitor's a position; when both sit
/// on one loop of charges the exact motion keeps `Q_j⁻¹(p_φ) = q_C/C`, which a step keeps only
/// inside the step, not at its ends: the split of the node's charge between them is a mode the
/// steps do not see (midpoint alternates it, Gauss methods keep it) and the state carries it. The
/// readout undoes it as the circuit would, by an impulsive flow `δ` through the loop: it moves
/// the degenerate positions it passes (the capacitor's charge, the junction branch's charge) and,
/// through forces linear in those rates (`f_φ = q̇ − i_D`), the momenta (`δp = ∂f/∂v · δ`).
/// Only coordinates whose rate no degenerate force resists take part (no resistor, no current
/// source, no series resistance), the flow keeps every constraint (`A δ = 0`), and only the
/// loops reached from a constrained coordinate whose rate pushes a momentum are included (a part
/// read alone, its ports open, has none), so a model without such a coupling reads exactly as
/// before.
#[derive(Debug, Default)]
pub(crate) struct Sharing {
    /// Coordinate of each shift unknown.
    pub(crate) coords: Vec<usize>,
    /// Shift unknown of each coordinate (`OUT` when the coordinate is not shifted).
    slot: Vec<usize>,
    /// Constraint row of each sharing equation (`A δ = 0`).
    pub(crate) rows: Vec<usize>,
    /// Sharing equation of each constraint row (`OUT` when no shift enters it).
    pub(crate) row_slot: Vec<usize>,
    /// Whether a coordinate has a kinetic term (its momentum takes a shift's impulse).
    kinetic: Vec<bool>,
}

impl Sharing {
    /// The shifts of a model of `n` coordinates and `m` constraint rows, from the patterns of
    /// `∂²L/∂v²` (`vv`), `∂f/∂v` (`fv`) and the constraint forms.
    pub(crate) fn find(n: usize, m: usize, vv: &Triplets, fv: &Triplets, forms: &Triplets) -> Self {
        let mut kinetic = vec![false; n];
        for (i, _, _) in vv.iter() {
            kinetic[i] = true;
        }
        let mut free = kinetic.iter().map(|k| !k).collect::<Vec<bool>>();
        for (i, j, _) in fv.iter() {
            if !kinetic[i] {
                free[j] = false;
            }
        }
        let mut row_cols: Vec<Vec<usize>> = vec![Vec::new(); m];
        let mut col_rows: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (a, j, _) in forms.iter() {
            if free[j] {
                row_cols[a].push(j);
                col_rows[j].push(a);
            }
        }
        let mut slot = vec![OUT; n];
        let mut row_slot = vec![OUT; m];
        let mut coords = Vec::new();
        let mut rows = Vec::new();
        let mut stack: Vec<usize> = fv
            .iter()
            .filter(|&(i, j, _)| kinetic[i] && free[j] && !col_rows[j].is_empty())
            .map(|(_, j, _)| j)
            .collect();
        while let Some(j) = stack.pop() {
            if slot[j] != OUT {
                continue;
            }
            slot[j] = coords.len();
            coords.push(j);
            for &a in &col_rows[j] {
                if row_slot[a] == OUT {
                    row_slot[a] = rows.len();
                    rows.push(a);
                    stack.extend(row_cols[a].iter().copied().filter(|&k| slot[k] == OUT));
                }
            }
        }
        Self {
            coords,
            slot,
            rows,
            row_slot,
            kinetic,
        }
    }

    /// The shift unknown of coordinate `j`, if it is shifted.
    pub(crate) fn shift(&self, j: usize) -> Option<usize> {
        let k = self.slot[j];
        (k != OUT).then_some(k)
    }

    /// The entries `(i, k, ∂f_i/∂v_j)` of a force Jacobian's rate block `fv` through which
    /// shift `k` (of coordinate `j`) pushes the momentum of a kinetic coordinate `i`.
    pub(crate) fn impulses<'a>(
        &'a self,
        fv: &'a Triplets,
    ) -> impl Iterator<Item = (usize, usize, f64)> + 'a {
        fv.iter()
            .filter_map(|(i, j, value)| Some((i, self.shift(j)?, value)))
            .filter(|&(i, _, _)| self.kinetic[i])
    }

    /// The entries `(l, k, A_aj)` of the constraint forms through which shift `k` (of
    /// coordinate `j`) enters sharing equation `l` (of constraint row `a`).
    pub(crate) fn flows<'a>(
        &'a self,
        forms: &'a Triplets,
    ) -> impl Iterator<Item = (usize, usize, f64)> + 'a {
        forms.iter().filter_map(|(a, j, value)| {
            let l = self.row_slot[a];
            if l == OUT {
                return None;
            }
            Some((l, self.shift(j)?, value))
        })
    }
}
