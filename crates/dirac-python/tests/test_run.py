"""Running netlists and scenes from Python.

The package runs a file exactly as the `dirac` command line does: for every bundled example the
trajectory written as CSV is byte-for-byte the CLI's output (the same run layer, settings and
formatting; any difference in a setting, a signal or a digit shows). The seed RLC loop is held
against its exact solution q(t) = e^{-γt}(cos ω_d t + γ/ω_d sin ω_d t), γ = R/2L,
ω_d = sqrt(1/LC - γ²): the (+) midpoint step stays within 3.41e-4 of it (README). Bad input
raises InputError with file:line:column; a saturating inductor driven past L0·I_sat raises
SimulationError at the step that starts at t = 1 s (flux V·t = 1 Wb = L0·I_sat there).
"""

import json
import math
import threading

import numpy as np
import pytest

import dirac
from conftest import EXAMPLES

NETLISTS = sorted((EXAMPLES / "netlists").glob("*.cir"))
SCENES = sorted((EXAMPLES / "scenes").glob("*.toml"))

# The seed loop's largest error against the exact charge: README states 3.41e-4 for the (+)
# midpoint step at h = 0.05 over 1000 steps; 3.5e-4 leaves the last digit's rounding.
SEED_EXACT_ERROR = 3.5e-4

# Loop turns that show the GIL was free during a run: 5.7 times the count with the GIL held
# (5.3e4), a sixth of the count measured with it released (1.8e6).
GIL_FREE_TURNS = 300_000


def _op_only(model):
    return model.kind == "netlist" and model.check()["tran"] is None


@pytest.mark.parametrize("path", NETLISTS + SCENES, ids=lambda p: p.name)
def test_package_writes_the_cli_csv(path, cli):
    model = dirac.load(path)
    if _op_only(model):
        # `.op` alone: the CLI prints the operating point; the package returns it.
        out = cli("run", path, "--quiet").stdout.decode().splitlines()
        assert out[0] == "signal,value"
        expected = {line.rsplit(",", 1)[0].strip('"'): float(line.rsplit(",", 1)[1]) for line in out[1:]}
        assert model.operating_point() == expected
        return
    expected = cli("run", path, "--quiet").stdout.decode()
    assert model.run().to_csv() == expected


def test_an_operating_point_that_is_not_isolated_warns():
    """The heavy top may be turned about the vertical at its equilibrium: ``dirac op`` warns that
    the steady state is not isolated, the package issues that warning as a RuntimeWarning, and
    the point is an equilibrium (centre of mass on the vertical through the pivot, 0.15 m from
    it)."""
    model = dirac.load(EXAMPLES / "scenes" / "heavy_top.toml")
    with pytest.warns(RuntimeWarning, match="not isolated"):
        point = model.operating_point()
    assert abs(point["top.x"]) < 1e-12 and abs(point["top.y"]) < 1e-12
    assert abs(abs(point["top.z"]) - 0.15) < 1e-12


def test_a_mechanism_without_a_static_equilibrium_raises_input_error():
    """The motor arm's motor, at a constant voltage, turns a column that nothing holds: there is
    no static equilibrium (the motion tends to a steady rotation). ``dirac op`` exits 2 naming the
    gear's angle; the package raises InputError with the same message."""
    model = dirac.load(EXAMPLES / "scenes" / "motor_arm.toml")
    with pytest.raises(dirac.InputError, match=r"no static equilibrium.*`G\.theta1`"):
        model.operating_point()


def test_options_reach_the_run_as_on_the_command_line(cli):
    path = EXAMPLES / "netlists" / "seed_rlc.cir"
    expected = cli(
        "run", path, "--quiet", "--method", "gauss2", "--t-end", "5", "--signals", "v(1),i(l1)"
    ).stdout.decode()
    trajectory = dirac.run(path, method="gauss2", t_end=5, signals=["v(1)", "i(l1)"])
    assert trajectory.to_csv() == expected
    assert trajectory.signals == ("v(1)", "i(l1)")
    assert trajectory.t[-1] == 5.0 and len(trajectory) == 101


def test_start_ramp_reaches_the_run_as_on_the_command_line(cli, tmp_path):
    # A stiff two-section RC ladder started off its slow manifold (fast time constant ~1e-6 s,
    # h = 0.01): the ramp's rows are the CLI's with --start-ramp, its substeps are counted, and
    # at the end the nodes sit at the quasi-static gap (~1e-6 V) where the plain run
    # (start_ramp=False) rings. Left at None, a netlist with such a mode takes a ramp itself,
    # as the CLI does without a flag; asked for or not, the ramp is sized to reach that mode
    # (51 substeps, not the default 32 levels' 99).
    path = tmp_path / "stiff_rc.cir"
    path.write_text(
        "stiff RC ladder\nR1 0 n1 1\nC1 n1 0 1 IC=1\nR2 n1 n2 1e-3\nC2 n2 0 1e-3 IC=3\n"
        ".tran 0.01 0.5 uic\n.end\n"
    )
    expected = cli("run", path, "--quiet", "--start-ramp").stdout.decode()
    ramped = dirac.run(path, start_ramp=True)
    assert ramped.to_csv() == expected
    assert ramped.summary.ramp_substeps == 51
    plain = dirac.run(path, start_ramp=False)
    assert plain.to_csv() == cli("run", path, "--quiet", "--no-start-ramp").stdout.decode()
    assert plain.summary.ramp_substeps == 0
    default = dirac.run(path)
    assert default.to_csv() == cli("run", path, "--quiet").stdout.decode()
    assert default.summary.ramp_substeps == 51
    gap = lambda tr: abs(tr["v(n2)"][-1] - tr["v(n1)"][-1])
    assert max(gap(ramped), gap(default)) <= 1.1e-6 < 1e-2 <= gap(plain), (
        gap(ramped),
        gap(default),
        gap(plain),
    )


def test_a_method_that_would_blow_up_is_refused():
    # The variational trapezoid rule multiplies a decay of time constant tau by 1 - h/tau per
    # step: an RC divider of tau = 0.5 us at h = 50 us grows by 99 per step. The run layer
    # refuses it before a step is taken (InputError naming the mode, as `dirac run` exits 2);
    # force=True takes it and it blows up as the refusal said; the midpoint rule is accepted.
    path = EXAMPLES / "netlists" / "rc_fast_coarse_tstep.cir"
    with pytest.raises(dirac.InputError, match=r"amplifies the damped mode \(in c1.q\)"):
        dirac.run(path, method="trapezoid")
    forced = dirac.run(path, method="trapezoid", force=True, signals=["v(out)"])
    assert abs(forced["v(out)"][-1]) > 1e100
    damped = dirac.run(path, method="midpoint", signals=["v(out)"])
    assert np.all(np.abs(damped["v(out)"]) <= 0.5 + 1e-9)


def test_refine_reaches_the_run_as_on_the_command_line(cli):
    # rectifier.cir has a diode, so the truncation-error control is on by default: its rows are
    # the CLI's, and refine=False gives the CLI's --fixed-step rows, with no substep added.
    path = EXAMPLES / "netlists" / "rectifier.cir"
    refined = dirac.run(path)
    assert refined.to_csv() == cli("run", path, "--quiet").stdout.decode()
    assert refined.summary.refinements > 0
    assert refined.summary.substeps > refined.summary.steps
    fixed = dirac.run(path, refine=False)
    assert fixed.to_csv() == cli("run", path, "--quiet", "--fixed-step").stdout.decode()
    assert fixed.summary.refinements == 0
    assert fixed.summary.substeps == fixed.summary.steps
    assert fixed.to_csv() != refined.to_csv()


def test_tmax_sets_the_step_and_the_rows_stay_every_tstep(cli, tmp_path):
    # ngspice steps at most TMAX = 10 us and prints every TSTEP = 1 ms; the package's rows are
    # the CLI's: 11 rows on the TSTEP grid from 1000 steps, the run at h = TMAX every 100th row.
    path = tmp_path / "rc_tmax.cir"
    path.write_text("rc\nV1 in 0 SIN(0 1 100)\nR1 in out 1k\nC1 out 0 1u\n.tran 1m 10m 0 10u\n.end\n")
    run = dirac.run(path, signals=["v(out)"])
    assert run.to_csv() == cli("run", path, "--quiet", "--signals", "v(out)").stdout.decode()
    assert run.summary.steps == 1000
    assert np.array_equal(run.t, np.arange(11) * 1e-3)
    fine = dirac.run(path, signals=["v(out)"], h=1e-5)
    assert np.array_equal(run["v(out)"], fine["v(out)"][::100])


def test_measures_reach_the_summary_as_on_the_command_line(cli, tmp_path):
    # An RC low-pass (tau = 1 ms) behind a 10 us ramp at 1 ms: v(in) crosses 0.5 V at 1.005 ms
    # and falls through it at 6.015 ms (corners on the grid, so exact); a measure with no
    # crossing is None, and the run succeeds as on the command line.
    path = tmp_path / "rc_meas.cir"
    path.write_text(
        "rc\nV1 in 0 PULSE(0 1 1m 10u 10u 5m 10m)\nR1 in out 1k\nC1 out 0 1u\n.tran 10u 10m\n"
        ".meas tran trig WHEN v(in)=0.5\n.meas tran fall WHEN v(in)=0.5 FALL=1\n"
        ".meas tran tdelay TRIG v(in) VAL=0.5 TARG v(out) VAL=0.5\n"
        ".meas tran never WHEN v(out)=2\n.end\n"
    )
    run = dirac.run(path, signals=["v(out)"])
    assert run.signals == ("v(out)",)
    measures = run.summary.measures
    assert list(measures) == ["trig", "fall", "tdelay", "never"]
    assert measures["trig"] == pytest.approx(1.005e-3, abs=1e-15)
    assert measures["fall"] == pytest.approx(6.015e-3, abs=1e-15)
    assert measures["never"] is None
    a = 100 * math.expm1(0.01)
    assert measures["tdelay"] == pytest.approx(1e-3 * math.log(2 * a) - 5e-6, abs=5e-8)
    out = cli("run", path, "--quiet", "--signals", "v(out)", "--json-summary")
    summary = json.loads(out.stderr.decode().strip().splitlines()[-1])
    assert summary["measures"] == measures
    assert not any("reads across a source corner" in w for w in run.summary.warnings)
    # A 1 us edge inside a 10 us step: the state at its corner (1.001 ms) is a sample, so the
    # crossing is at 1.0005 ms as on the source, without a warning.
    off = tmp_path / "rc_meas_off.cir"
    off.write_text(path.read_text().replace("PULSE(0 1 1m 10u 10u 5m 10m)", "PULSE(0 1 1m 1u 1u 5m 10m)"))
    sampled = dirac.run(off, signals=["v(out)"])
    assert sampled.summary.measures["trig"] == pytest.approx(1.0005e-3, abs=1e-15)
    assert not any("reads across a source corner" in w for w in sampled.summary.warnings)
    # The current of a capacitor straight across the source is not determined by the state at
    # the corner (index 2): a measure of it reads across the corner and the summary says so.
    index_two = tmp_path / "rc_meas_index_two.cir"
    index_two.write_text(
        off.read_text()
        .replace("R1 in out 1k", "C2 in 0 1u\nR1 in out 1k")
        .replace(".end\n", ".meas tran qin INTEG i(v1) FROM=0.5m TO=3m\n.end\n")
    )
    warned = dirac.run(index_two, signals=["v(out)"])
    assert any("`.meas qin` reads across a source corner" in w for w in warned.summary.warnings)


def test_composition_reaches_the_run_as_on_the_command_line(cli):
    # The two-mass scene with the trapezoid rule (explicit Störmer–Verlet): composition= gives the
    # CLI's --composition rows, and Kahan and Li's order-8 composition at h = 0.4 stays within
    # 1e-5 of the normal-mode solution x_A = (cos t + cos √3 t)/2 where the single step is 1e-2 off.
    path = EXAMPLES / "scenes" / "two_mass_split.toml"
    options = dict(method="trapezoid", h=0.4, t_end=20, signals=["A.x"])
    composed = dirac.run(path, composition="kahan-li8", **options)
    expected = cli(
        "run", path, "--quiet", "--method", "trapezoid", "--h", "0.4", "--t-end", "20",
        "--signals", "A.x", "--composition", "kahan-li8",
    ).stdout.decode()
    assert composed.to_csv() == expected
    exact = 0.5 * (np.cos(composed.t) + np.cos(math.sqrt(3) * composed.t))
    single = dirac.run(path, **options)
    assert np.max(np.abs(composed["A.x"] - exact)) < 1e-5
    assert np.max(np.abs(single["A.x"] - exact)) > 1e-2
    with pytest.raises(dirac.InputError, match="unknown composition `ruth3`"):
        dirac.run(path, composition="ruth3")
    # compare() composes too: the force representation keeps the monolithic trajectory to
    # round-off (the composition is equivalence-preserving, substep by substep).
    model = dirac.load(path)
    deviations = {
        c.execution: c.max_abs_deviation
        for c in model.compare(method="trapezoid", h=0.4, t_end=20, composition="kahan-li8")
    }
    assert deviations["force"] < 1e-12, deviations
    with pytest.raises(dirac.InputError, match="unknown composition"):
        model.compare(composition="ruth3")


def test_seed_loop_against_the_exact_solution():
    trajectory = dirac.run(EXAMPLES / "scenes" / "seed_rlc.toml")
    L, C, R = 0.75, 3.0, 0.1
    gamma = R / (2 * L)
    omega = math.sqrt(1 / (L * C) - gamma**2)
    t = trajectory.t
    exact = np.exp(-gamma * t) * (np.cos(omega * t) + gamma / omega * np.sin(omega * t))
    error = np.max(np.abs(trajectory["C1.q"] - exact))
    assert error < SEED_EXACT_ERROR
    assert error > SEED_EXACT_ERROR / 10  # the O(h²) error is there: a run that did not step fails
    summary = trajectory.summary
    assert summary.steps == 1000 and summary.newton_iterations >= 1000
    assert summary.execution == "monolithic" and summary.h == 0.05 and summary.t_end == 50.0


def test_energy_drift_of_a_conservative_loop():
    # With R = 0 the loop is an LC tank; the midpoint rule keeps its energy exactly constant
    # (docs/guide.md), so the drift is round-off (measured 3.6e-16 on E = 1/6; 1e-14 is 28 times
    # that, for other platforms' libm).
    model = dirac.load(EXAMPLES / "scenes" / "seed_rlc.toml")
    model["R1.r"] = 0.0
    summary = model.run(energy=True).summary
    assert summary.energy_start == pytest.approx(1 / 6, rel=1e-12)  # q²/2C = 1/6
    assert summary.energy_drift < 1e-14
    model["R1.r"] = 0.1
    damped = model.run(energy=True).summary
    assert damped.energy_drift > 0.1  # the resistor takes most of it over 50 s


def test_pandas_and_dict():
    trajectory = dirac.run(EXAMPLES / "netlists" / "seed_rlc.cir")
    frame = trajectory.to_pandas()
    assert list(frame.columns) == ["t", *trajectory.signals]
    assert np.array_equal(frame["v(2)"].to_numpy(), trajectory["v(2)"])
    with pytest.raises(KeyError, match="v\\(1\\), v\\(2\\)"):
        trajectory["v(9)"]


def test_input_errors_carry_their_place():
    with pytest.raises(dirac.InputError) as caught:
        dirac.Model.from_netlist("T\nR1 1 0 1k\nC1 1 0 zz\n.tran 1 2\n.end\n", "bad.cir")
    e = caught.value
    assert isinstance(e, ValueError)
    assert (e.file, e.line, e.column) == ("bad.cir", 3, 8)
    assert e.location == "bad.cir:3:8"
    with pytest.raises(dirac.InputError, match="no node `9`"):
        dirac.run(EXAMPLES / "netlists" / "seed_rlc.cir", signals=["v(9)"])
    with pytest.raises(dirac.InputError, match="R1, L1|C1, L1, R1") as caught:
        dirac.load(EXAMPLES / "netlists" / "seed_rlc.cir")["R9.r"] = 1.0
    assert caught.value.parameter == "R9.r"
    with pytest.raises(dirac.InputError, match="must be positive"):
        dirac.load(EXAMPLES / "netlists" / "seed_rlc.cir")["C1.c"] = -1.0
    with pytest.raises(dirac.InputError, match="unknown method"):
        dirac.run(EXAMPLES / "netlists" / "seed_rlc.cir", method="rk4")


def saturating_inductor():
    system = dirac.System(h=0.1, t_end=2.0)
    system.part("V", "voltage_source", waveform=1.0)
    system.part("L", "saturating_inductor", l0=1.0, l_inf=0.0, i_sat=1.0)
    system.node("a", "-V.i", "-L.i")
    return system


def test_numerical_failure_is_a_simulation_error():
    with pytest.raises(dirac.SimulationError) as caught:
        saturating_inductor().run()
    e = caught.value
    assert e.step == 10 and e.time == pytest.approx(1.0, abs=1e-12)
    assert e.residual is not None and (math.isnan(e.residual) or e.residual > 0)
    assert "`L.q`" in str(e)


def test_the_gil_is_released_while_stepping():
    # A run of 2.5·10^5 steps in another thread; this thread counts loop turns while it steps.
    # With the GIL held for the run this thread turns only while the other runs Python code
    # before and after it (measured 5.3e4 with `py.detach` removed); released, it turns all
    # through the run (measured 1.8e6 to 2.0e6).
    model = dirac.load(EXAMPLES / "netlists" / "seed_rlc.cir")
    started, done = threading.Event(), threading.Event()

    def work():
        started.set()
        model.run(h=2e-4, signals=["q(c1)"])
        done.set()

    import sys

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-4)
    try:
        thread = threading.Thread(target=work)
        thread.start()
        started.wait()
        turns = 0
        while not done.is_set():
            turns += 1
        thread.join()
    finally:
        sys.setswitchinterval(interval)
    assert turns > GIL_FREE_TURNS
