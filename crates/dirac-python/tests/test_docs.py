"""The Python code blocks of docs/python.md run as written.

Each block is executed in order in one namespace (later blocks use `dirac` and the names earlier
ones define), from a scratch directory that holds `examples/` (a link to the repository's) and
`circuit.cir` (a copy of the seed netlist, the file the error-handling block names), so a block
that stops running, or that uses an API the package no longer has, fails here. The cluster block
(Dask at tcp://scheduler:8786, Ray at address "auto") needs running clusters and is not executed;
test_sweep.py runs the same two executors on local clusters. The seed netlist runs without
failure, so the block that catches `dirac.SimulationError` runs its `try` branch only;
test_run.py checks the exception itself.
"""

import re
import shutil

import pytest

from conftest import EXAMPLES, REPO

PAGE = REPO / "docs" / "python.md"

# Blocks that need something a test machine does not have, by a phrase they contain.
NEEDS_A_CLUSTER = 'Client("tcp://scheduler:8786")'


def python_blocks():
    return re.findall(r"^```python\n(.*?)^```$", PAGE.read_text(encoding="utf-8"), re.S | re.M)


def test_the_page_has_its_blocks():
    # A change of the fence syntax would otherwise leave nothing to run and this file green.
    blocks = python_blocks()
    assert len(blocks) == 5, [b.splitlines()[0] for b in blocks]
    assert sum(NEEDS_A_CLUSTER in b for b in blocks) == 1


def test_python_blocks_of_the_docs_run(tmp_path, monkeypatch):
    (tmp_path / "examples").symlink_to(EXAMPLES, target_is_directory=True)
    shutil.copy(EXAMPLES / "netlists" / "seed_rlc.cir", tmp_path / "circuit.cir")
    monkeypatch.chdir(tmp_path)
    namespace = {}
    ran = 0
    for block in python_blocks():
        if NEEDS_A_CLUSTER in block:
            continue
        exec(compile(block, f"{PAGE}:block{ran}", "exec"), namespace)
        ran += 1
    assert ran == 4
    # What the blocks promise: the first run's CSV is the command line's format, the sweep's table
    # has one row per point of the 3 × 3 product.
    assert (tmp_path / "run.csv").read_text().startswith("t,")
    table = namespace["table"]
    assert len(table["point"]) == 9
