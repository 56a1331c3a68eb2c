"""Shared fixtures: the repository's examples and the `dirac` command line built from the same
sources (scripts/test builds it before pytest runs; DIRAC_CLI overrides its path)."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]
EXAMPLES = REPO / "examples"


def cli_path() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("DIRAC_CLI", REPO / "target" / "release" / "dirac"))
    if not path.exists():
        raise RuntimeError(
            f"{path}: the dirac command line is needed (cargo build --release -p dirac-cli)"
        )
    return path


@pytest.fixture(scope="session")
def cli():
    """Runs `dirac ARGS...` and returns its completed process (stdout as bytes)."""
    path = cli_path()

    def run(*args, check=True):
        return subprocess.run([str(path), *map(str, args)], capture_output=True, check=check)

    return run
