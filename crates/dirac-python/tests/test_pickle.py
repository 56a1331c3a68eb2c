"""Pickling: models (with their parameter changes), systems, trajectories, summaries and errors
survive a round trip and give the same numbers, so multiprocessing, Dask and Ray can ship them.
A model pickles as its source text and its changes: the restored model must run to the same
rows bit for bit (a lost change, e.g. R1.r, changes every row after the first)."""

import pickle

import numpy as np
import pytest

import dirac
from conftest import EXAMPLES


@pytest.mark.parametrize("path", [EXAMPLES / "netlists" / "seed_rlc.cir", EXAMPLES / "scenes" / "seed_rlc.toml"])
def test_model_round_trip_keeps_parameter_changes(path):
    model = dirac.load(path)
    model["R1.r"] = 0.3
    model["L1.l"] = 0.5
    copy = pickle.loads(pickle.dumps(model))
    assert copy.overrides == [("R1.r", 0.3), ("L1.l", 0.5)]
    assert copy["R1.r"] == 0.3 and copy.text == model.text and copy.name == model.name
    assert copy.run() == model.run()
    assert copy.run() != dirac.load(path).run()


def test_trajectory_and_summary_round_trip():
    trajectory = dirac.run(EXAMPLES / "scenes" / "two_mass_split.toml", energy=True)
    copy = pickle.loads(pickle.dumps(trajectory))
    assert copy == trajectory
    assert copy.summary == trajectory.summary
    assert copy.signals == trajectory.signals
    assert np.array_equal(copy.t, trajectory.t)
    assert copy.to_csv() == trajectory.to_csv()


def test_system_model_round_trip():
    system = dirac.System(h=0.05, t_end=5.0)
    system.part("C1", "capacitor", c=3.0, q0=1.0)
    system.part("L1", "inductor", l=0.75)
    system.node("n1", "+C1.i", "-L1.i")
    model = system.build()
    assert pickle.loads(pickle.dumps(model)).run() == model.run()
    assert pickle.loads(pickle.dumps(system)).to_toml() == system.to_toml()


def test_errors_round_trip_with_their_fields():
    try:
        dirac.Model.from_netlist("T\nR1 1 0 1k\nC1 1 0 zz\n.end\n", "bad.cir")
    except dirac.InputError as e:
        copy = pickle.loads(pickle.dumps(e))
        assert type(copy) is dirac.InputError
        assert (copy.file, copy.line, copy.column, str(copy)) == (e.file, e.line, e.column, str(e))
    else:
        pytest.fail("the netlist is invalid")
    e = dirac.SimulationError("failed", step=3, time=0.5, residual=1e-3)
    copy = pickle.loads(pickle.dumps(e))
    assert (copy.step, copy.time, copy.residual, str(copy)) == (3, 0.5, 1e-3, "failed")
