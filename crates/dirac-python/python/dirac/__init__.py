"""dirac: forced discrete Dirac variational integrators for circuits and mechanisms.

Run a netlist or scene file and read its signals as numpy arrays::

    import dirac
    trajectory = dirac.run("examples/netlists/seed_rlc.cir", method="gauss2")
    trajectory.t, trajectory["v(1)"], trajectory.summary.newton_iterations

Build a model from stock parts (:class:`System`), change parameters by name
(``model["R1.r"] = 0.2``), sweep them on local processes or a cluster (:func:`sweep`).
Bad input raises :class:`InputError` (a ``ValueError``), a numerical failure
:class:`SimulationError`. Models and trajectories pickle. See docs/python.md.
"""

from ._build import System
from ._errors import DiracError, InputError, SimulationError
from ._model import Comparison, Model, load, run
from ._sweep import sweep, table_csv
from ._trajectory import RunSummary, Trajectory

__all__ = [
    "Comparison",
    "DiracError",
    "InputError",
    "Model",
    "RunSummary",
    "SimulationError",
    "System",
    "Trajectory",
    "load",
    "run",
    "sweep",
    "table_csv",
]
