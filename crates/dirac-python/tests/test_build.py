"""Building models from parts in Python.

A System written part by part with the scene format's names is the scene file: the seed RLC
loop built in Python runs to exactly the rows of examples/scenes/seed_rlc.toml. The three
assembled representations of a circuit give the same discrete trajectory (Parks & Leok's
equivalence; `dirac compare` measures 0 on the seed loop); bad parts, ports and parameters are
named in the InputError."""

import pytest

import dirac
from conftest import EXAMPLES


def seed_loop(**simulation):
    system = dirac.System(h=0.05, t_end=50.0, **simulation)
    system.part("C1", "capacitor", c=3.0, q0=1.0)
    system.part("L1", "inductor", l=0.75, v0=0.0)
    system.part("R1", "resistor", r=0.1)
    system.node("n1", ("L1.i", 1.0), ("R1.i", -1.0))
    system.node("n2", "+R1.i", "-C1.i")
    system.node("n3", "+C1.i", "-L1.i")
    system.record(["C1.q", "L1.i"])
    return system


def test_system_is_the_scene_file():
    built = seed_loop().run()
    from_file = dirac.run(EXAMPLES / "scenes" / "seed_rlc.toml")
    assert built == from_file


def test_representations_agree_and_check_reports_sizes():
    model = seed_loop().build()
    deviations = {c.execution: c.max_abs_deviation for c in model.compare(t_end=5.0)}
    # Equivalent representations: same Newton iterates up to round-off (measured 0.0).
    for representation in ("monolithic", "constraint", "force"):
        assert deviations[representation] <= 1e-13
    report = model.check()
    assert report["parts"] == 3 and report["connections"] == 3
    assert report["signals"] == ["C1.q", "L1.i"]
    constraint = seed_loop(representation="constraint").run(t_end=5.0)
    assert constraint.summary.execution == "constraint"


def test_coupling_parameters_are_swept_by_the_coupling_name():
    system = dirac.System(h=0.01, t_end=1.0)
    system.part("A", "mass", m=1.0, q0=0.1)
    system.part("B", "mass", m=1.0)
    system.coupling("k12", "A.x", "B.x", "spring", k=4.0)
    model = system.build()
    assert model["k12.k"] == 4.0
    stiffer = model.with_parameters({"k12.k": 16.0}).run()
    assert stiffer != model.run()


def test_bad_parts_and_ports_are_named():
    system = seed_loop()
    system.node("n4", "+L1.x", "-R1.i")
    with pytest.raises(dirac.InputError, match="L1") as caught:
        system.build()
    assert caught.value.line is not None
    system = dirac.System(h=0.1, t_end=1.0)
    system.part("C1", "capacitor", c=-1.0)
    with pytest.raises(dirac.InputError, match="c"):
        system.build()
