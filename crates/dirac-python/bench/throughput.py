"""Throughput of the Python package (issue 17's benchmark).

1. Sweep throughput: a 1000-point sweep of the seed RLC loop (examples/netlists/seed_rlc.cir,
   1000 steps each, R1.r from 0.05 to 0.5) in this process ("serial") and on a local
   ProcessPoolExecutor with 2 workers; runs per second.
2. Overhead of the Python layer per run: the median wall time of ``Model.run()`` from Python
   (arguments, the run with the GIL released, numpy arrays and the summary) against the median
   of ``dirac_study::Model::run`` in Rust on the same file (the example ``run_cost``), for the
   1000-step seed loop. Target: at most 20 %.

Run from the repository root with the package installed:

    cargo build --release -p dirac-study --example run_cost
    python crates/dirac-python/bench/throughput.py
"""

import pathlib
import statistics
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import dirac

REPO = pathlib.Path(__file__).resolve().parents[3]
SEED = REPO / "examples" / "netlists" / "seed_rlc.cir"
RUST = REPO / "target" / "release" / "examples" / "run_cost"
REPETITIONS = 400


def sweep_rate(executor, label):
    values = np.linspace(0.05, 0.5, 1000)
    start = time.perf_counter()
    table = dirac.sweep(SEED, {"R1.r": values}, executor, reduce=["final(q(c1))"])
    wall = time.perf_counter() - start
    assert len(table) == 1000
    print(f"sweep of 1000 runs, {label:<22}: {wall:6.2f} s, {1000 / wall:7.1f} runs/s")
    return table


def python_run_median(model):
    times = []
    for _ in range(REPETITIONS):
        start = time.perf_counter()
        model.run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main():
    serial = sweep_rate("serial", "serial (this process)")
    with ProcessPoolExecutor(max_workers=2) as pool:
        parallel = sweep_rate(pool, "2 local processes")
    assert parallel.equals(serial), "the executors disagree"

    if not RUST.exists():
        sys.exit(f"{RUST} missing: cargo build --release -p dirac-study --example run_cost")
    model = dirac.load(SEED)
    model.run()
    python = python_run_median(model)
    rust = float(subprocess.check_output([str(RUST), str(SEED), str(REPETITIONS)], text=True))
    print(f"1000-step run, Rust run layer (median of {REPETITIONS}): {rust * 1e3:8.3f} ms")
    print(f"1000-step run, from Python    (median of {REPETITIONS}): {python * 1e3:8.3f} ms")
    print(f"Python-layer overhead: {100 * (python / rust - 1):+.1f} % (target <= 20 %)")


if __name__ == "__main__":
    main()
