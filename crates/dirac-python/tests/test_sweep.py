"""Parameter sweeps.

Every point of a sweep is its own run of the base model with its parameters set, so the table
must equal, number for number, single runs at those parameters, in point order (the Cartesian
product with the first parameter slowest), whichever executor ran it: serial, local processes,
a Dask LocalCluster and Ray with two workers each. The command line's shards, merged, are the
unsharded table byte for byte, and both are the package's table written by `table_csv`.
"""

import itertools
import math

import numpy as np
import pytest

import dirac
from conftest import EXAMPLES

SEED = EXAMPLES / "netlists" / "seed_rlc.cir"
GRID = {"R1.r": [0.1, 0.2, 0.5], "C1.c": "1:5:3"}
POINTS = list(itertools.product([0.1, 0.2, 0.5], [1.0, 3.0, 5.0]))
REDUCE = ["final(q(c1))", "max(v(2))", "rms(i(l1))"]


@pytest.fixture(scope="module")
def serial():
    return dirac.sweep(SEED, GRID, executor="serial", reduce=REDUCE, t_end=10.0)


def test_serial_sweep_is_single_runs_in_grid_order(serial):
    assert list(serial.columns) == ["point", "R1.r", "C1.c", *REDUCE]
    assert serial["point"].tolist() == list(range(9))
    assert list(zip(serial["R1.r"], serial["C1.c"])) == POINTS
    base = dirac.load(SEED)
    for k, (r, c) in enumerate(POINTS):
        run = base.with_parameters({"R1.r": r, "C1.c": c}).run(t_end=10.0)
        assert serial["final(q(c1))"][k] == run["q(c1)"][-1]
        assert serial["max(v(2))"][k] == run["v(2)"].max()
        # The run layer sums squares in row order, numpy pairwise: equal to round-off.
        assert serial["rms(i(l1))"][k] == pytest.approx(np.sqrt(np.mean(run["i(l1)"] ** 2)), rel=1e-14)


def test_given_points_callable_reduce_and_dict_tables(serial):
    points = [{"R1.r": r, "C1.c": c} for r, c in POINTS]
    table = dirac.sweep(
        SEED, points, executor="serial", t_end=10.0, frame=False,
        reduce=lambda tr: {"last": tr["q(c1)"][-1], "peak": tr["v(2)"].max()},
    )
    assert isinstance(table, dict)
    assert np.array_equal(table["last"], serial["final(q(c1))"].to_numpy())
    assert np.array_equal(table["peak"], serial["max(v(2))"].to_numpy())


def test_trajectory_sweep_rows_are_the_runs():
    table = dirac.sweep(SEED, {"R1.r": [0.1, 0.3]}, executor="serial", trajectories=True, t_end=1.0, signals=["v(1)"])
    for k, r in enumerate([0.1, 0.3]):
        rows = table[table["point"] == k]
        run = dirac.load(SEED).with_parameters({"R1.r": r}).run(t_end=1.0, signals=["v(1)"])
        assert np.array_equal(rows["t"].to_numpy(), run.t)
        assert np.array_equal(rows["v(1)"].to_numpy(), run["v(1)"])


def test_bad_parameters_fail_before_running():
    with pytest.raises(dirac.InputError, match="R9"):
        dirac.sweep(SEED, {"R9.r": [1.0]}, executor="serial")
    with pytest.raises(dirac.InputError, match="median"):
        dirac.sweep(SEED, {"R1.r": [1.0]}, executor="serial", reduce=["median(v(1))"])


def test_local_processes_equal_serial(serial):
    from concurrent.futures import ProcessPoolExecutor

    default = dirac.sweep(SEED, GRID, reduce=REDUCE, t_end=10.0)
    assert default.equals(serial)
    with ProcessPoolExecutor(max_workers=2) as pool:
        assert dirac.sweep(SEED, GRID, pool, reduce=REDUCE, t_end=10.0, chunksize=2).equals(serial)


def test_dask_local_cluster_equals_serial(serial):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            table = dirac.sweep(SEED, GRID, client, reduce=REDUCE, t_end=10.0)
    assert table.equals(serial)


def test_ray_two_workers_equal_serial(serial):
    ray = pytest.importorskip("ray")
    from ray.util.multiprocessing import Pool

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    try:
        with Pool(processes=2) as pool:
            table = dirac.sweep(SEED, GRID, pool, reduce=REDUCE, t_end=10.0)
    finally:
        ray.shutdown()
    assert table.equals(serial)


def test_cli_shards_merge_to_the_unsharded_table(serial, cli, tmp_path):
    args = ["sweep", SEED, "--param", "R1.r=0.1,0.2,0.5", "--param", "C1.c=1:5:3", "--t-end", "10"]
    for output in REDUCE:
        args += ["--reduce", output]
    whole = cli(*args).stdout
    for i in range(4):
        cli(*args, "--shard", f"{i}/4", "--out", tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"shard-{i}-of-4.csv" for i in range(4)]
    merged = cli("sweep", "--merge", tmp_path).stdout
    assert merged == whole
    assert dirac.table_csv(serial) == whole.decode()
    (tmp_path / "shard-2-of-4.csv").unlink()
    missing = cli("sweep", "--merge", tmp_path, check=False)
    assert missing.returncode == 2 and b"shard 2 of 4 is missing" in missing.stderr


def test_failed_points_raise_or_leave_nan_with_keep_going():
    # A 1 V source drives the saturating inductor's flux past L0·I_sat = 1 Wb at t = 1 s (see
    # test_run); at 0.2 V the flux stays at 0.4 Wb over the 2 s. Point 1 fails, point 0 does not.
    from test_run import saturating_inductor

    model = saturating_inductor().build()
    with pytest.raises(dirac.SimulationError) as caught:
        dirac.sweep(model, {"V.waveform": [0.2, 1.0]}, executor="serial", reduce=["final(L.q)"])
    assert caught.value.step == 10
    table = dirac.sweep(model, {"V.waveform": [0.2, 1.0]}, executor="serial", reduce=["final(L.q)"], keep_going=True)
    alone = model.with_parameters({"V.waveform": 0.2}).run(signals=["L.q"])
    assert table["final(L.q)"][0] == alone["L.q"][-1]
    assert np.isnan(table["final(L.q)"][1])


def test_a_sweep_table_holds_each_points_measures(tmp_path):
    # One column per `.meas` card after the reductions: the RC stage's 50 % delay scales with
    # R (tau ln 2 up to the 10 us ramp), NaN where a measure finds no crossing; the CLI's table.
    path = tmp_path / "rc_meas.cir"
    path.write_text(
        "rc\n.param r=1k\nV1 in 0 PULSE(0 1 1m 10u 10u 5m 10m)\nR1 in out {r}\nC1 out 0 1u\n"
        ".tran 10u 10m\n.meas tran tdelay TRIG v(in) VAL=0.5 TARG v(out) VAL=0.5\n"
        ".meas tran never WHEN v(out)=2\n.end\n"
    )
    table = dirac.sweep(path, {"r": [500.0, 2000.0]}, executor="serial", reduce=["max(v(out))"], frame=False)
    assert list(table) == ["point", "r", "max(v(out))", "tdelay", "never"]
    for r, delay in zip(table["r"], table["tdelay"]):
        tau = r * 1e-6
        a = tau / 1e-5 * math.expm1(1e-5 / tau)
        assert delay == pytest.approx(tau * math.log(2 * a) - 5e-6, abs=1e-7)
    assert np.all(np.isnan(table["never"]))
