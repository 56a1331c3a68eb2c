//! Reference problems with exact solutions and invariants, shared by tests, benches and examples.
//!
//! Every model here writes its derivatives by hand; the generic twins (`*Generic`) write only
//! `L(q, v)` and `f(q, v, t)` and get derivatives from `dirac_core::AutoDiff`, so tests can check
//! one against the other.

mod chain;
mod double_pendulum;
mod henon_heiles;
mod ladder;
mod mechanics;
mod oscillator;
mod pendulum;
mod rc_ladder;
mod rlc;

pub use chain::SpringChain;
pub use double_pendulum::{DoublePendulum, DoublePendulumGeneric};
pub use henon_heiles::{HenonHeiles, HenonHeilesGeneric};
pub use ladder::rlc_ladder;
pub use mechanics::{CircleConstraint, FreeMasses};
pub use oscillator::{ArtificialPotential, DampedOscillator, SplitOscillator};
pub use pendulum::{QuarticPendulums, QuarticPendulumsGeneric};
pub use rc_ladder::{RC_LADDER_FREQUENCY, RcLadder, RcLadderExact, RcSection};
pub use rlc::{LadderSection, LcTank, RlcLoop, rlc_exact};
