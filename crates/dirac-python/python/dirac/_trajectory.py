"""Trajectories and run summaries."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from . import _dirac

__all__ = ["RunSummary", "Trajectory"]


@dataclass(frozen=True)
class RunSummary:
    """What a run cost and what it found.

    Attributes:
        steps: steps taken.
        newton_iterations: Newton updates of the steps.
        factorisations: numeric factorisations of the steps.
        readout_iterations: Newton updates of the readouts at the output times.
        breakpoint_substeps: substeps that ended on a source breakpoint.
        step_cuts: substeps retried as two halves after a Newton failure.
        ramp_substeps: substeps of the start ramp (0 without one).
        refinements: substeps the truncation-error control rejected and took again in pieces.
        substeps: substeps accepted, of every kind (the run's time points after the start).
        turn_checks: substeps that turned a rigid body by more than 0.25 rad and were checked
            against two half steps.
        spurious_roots: substeps rejected (and cut) as roots of a rigid body's step equations
            that the motion does not take.
        max_constraint_residual: largest discrete constraint residual (when tracked).
        wall_s: wall time of set-up and stepping in the Rust run layer, in seconds.
        warnings: warnings of the set-up.
        execution: representation or splitting that ran.
        h: step size.
        t_end: end time.
        energy_start, energy_end: the total energy in the first and last rows (``energy=True``).
        energy_drift: ``max_k |E_k - E_0|`` over the rows (``energy=True``); for a conservative
            model a measure of the integrator's energy error, for a dissipative or driven one the
            energy exchanged.
        measures: a netlist's ``.meas`` results by name, in card order; ``None`` for a measure
            that could not be taken (no such crossing), as ngspice reports it failed.
    """

    steps: int
    newton_iterations: int
    factorisations: int
    readout_iterations: int
    breakpoint_substeps: int
    step_cuts: int
    ramp_substeps: int
    refinements: int
    substeps: int
    turn_checks: int
    spurious_roots: int
    max_constraint_residual: Optional[float]
    wall_s: float
    warnings: Tuple[str, ...]
    execution: str
    h: float
    t_end: float
    energy_start: Optional[float] = None
    energy_end: Optional[float] = None
    energy_drift: Optional[float] = None
    measures: Dict[str, Optional[float]] = field(default_factory=dict)

    @property
    def newton_iterations_per_step(self) -> float:
        """Mean Newton updates per step."""
        return self.newton_iterations / max(self.steps, 1)

    @classmethod
    def _from_dict(cls, d: dict) -> "RunSummary":
        d = dict(d)
        d["warnings"] = tuple(d["warnings"])
        return cls(**d)


class Trajectory:
    """The rows of a run: times ``t`` and one numpy array per signal.

    ``trajectory["v(2)"]`` is a signal's column, ``trajectory.signals`` the names in order,
    ``trajectory.summary`` the run's :class:`RunSummary`. ``to_pandas()`` gives a DataFrame with a
    ``t`` column, ``to_csv()`` exactly the CSV ``dirac run`` writes. Trajectories pickle.
    """

    __slots__ = ("_t", "_names", "_columns", "summary")

    def __init__(
        self,
        t: np.ndarray,
        signals: Sequence[str],
        columns: Sequence[np.ndarray],
        summary: Optional[RunSummary] = None,
    ) -> None:
        if len(signals) != len(columns):
            raise ValueError(f"{len(signals)} signal names but {len(columns)} columns")
        self._t = np.asarray(t, dtype=np.float64)
        self._names = tuple(signals)
        self._columns = {n: np.asarray(c, dtype=np.float64) for n, c in zip(signals, columns)}
        self.summary = summary

    @classmethod
    def _from_run(cls, names, t, data, summary) -> "Trajectory":
        return cls(
            np.frombuffer(t, dtype=np.float64),
            names,
            [np.frombuffer(c, dtype=np.float64) for c in data],
            RunSummary._from_dict(summary),
        )

    @property
    def t(self) -> np.ndarray:
        """Output times t_k (row 0 is the start)."""
        return self._t

    @property
    def signals(self) -> Tuple[str, ...]:
        """The signal names, in column order."""
        return self._names

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._columns[name]
        except KeyError:
            raise KeyError(f"no signal {name!r}; the signals are {', '.join(self._names)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self._columns

    def __len__(self) -> int:
        return len(self._t)

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __repr__(self) -> str:
        span = f"t = {self._t[0]:g}..{self._t[-1]:g}" if len(self._t) else "empty"
        return f"<Trajectory {len(self)} rows, {span}, signals {list(self._names)}>"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Trajectory):
            return NotImplemented
        return (
            self._names == other._names
            and np.array_equal(self._t, other._t)
            and all(np.array_equal(self[n], other[n], equal_nan=True) for n in self._names)
        )

    def __getstate__(self):
        return (self._t, self._names, [self._columns[n] for n in self._names], self.summary)

    def __setstate__(self, state) -> None:
        t, names, columns, summary = state
        self._t = t
        self._names = tuple(names)
        self._columns = dict(zip(names, columns))
        self.summary = summary

    def to_dict(self) -> Dict[str, np.ndarray]:
        """``{"t": times, signal: column, ...}``."""
        out = {"t": self._t}
        out.update(self._columns)
        return out

    def to_pandas(self):
        """A pandas DataFrame with the columns ``t`` and the signals (needs pandas)."""
        import pandas as pd

        return pd.DataFrame(self.to_dict())

    def to_csv(self, path: Optional[os.PathLike] = None) -> str:
        """The CSV ``dirac run`` writes for these rows (the same bytes); written to ``path`` if
        given. Returns the text."""
        text = _dirac.csv_text(
            list(self._names),
            self._t.tolist(),
            [self._columns[n].tolist() for n in self._names],
        )
        if path is not None:
            with open(path, "w", newline="") as f:
                f.write(text)
        return text
