//! The RLC ladder of the scaling benchmarks, assembled from section subsystems.

use dirac_components::VoltageSource;
use dirac_graph::{GraphError, Interconnection, Subsystem};

use crate::LadderSection;

/// An interconnection of a 1 V DC source `V1` driving `sections` copies `S1 … SN` of `section`,
/// with KCL at every node `n0 … nN` (`n0` is the source's + terminal).
///
/// Section `k` carries its series current from `n(k−1)` to `nk` and its shunt current from `nk` to
/// ground; ground's KCL row is omitted (it is the sum of the others).
///
/// # Errors
/// Only if the graph rejects a port or a name, which would be a bug in this builder.
pub fn rlc_ladder(sections: usize, section: LadderSection) -> Result<Interconnection, GraphError> {
    let mut g = Interconnection::new();
    g.add_subsystem(VoltageSource::dc(1.0)?.subsystem("V1"))?;
    let prototype = Subsystem::new("S", section)
        .with_port("series", 0)
        .with_port("shunt", 1);
    for k in 1..=sections {
        g.add_subsystem(prototype.renamed(format!("S{k}")))?;
    }
    // The source's branch current (SPICE orientation, + to − through the source) leaves n0.
    let src = g.port("V1", "i")?;
    g.node("n0", vec![(src, -1.0), (g.port("S1", "series")?, -1.0)])?;
    for k in 1..=sections {
        let mut ports = vec![
            (g.port(&format!("S{k}"), "series")?, 1.0),
            (g.port(&format!("S{k}"), "shunt")?, -1.0),
        ];
        if k < sections {
            ports.push((g.port(&format!("S{}", k + 1), "series")?, -1.0));
        }
        g.node(format!("n{k}"), ports)?;
    }
    Ok(g)
}
