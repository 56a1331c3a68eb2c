"""Parameter sweeps on any ``concurrent.futures.Executor`` (local processes, Dask, Ray)."""

from __future__ import annotations

import itertools
import math
import os
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _dirac
from ._errors import InputError
from ._model import Model, PathLike

__all__ = ["sweep", "table_csv"]

Reduce = Union[None, Sequence[str], Callable[[Any], Mapping[str, float]]]


def _points(parameters) -> Tuple[List[str], List[List[float]]]:
    """Names and points: a mapping of value lists is a grid (first name slowest, as
    ``itertools.product``); a sequence of mappings or a DataFrame are given points."""
    if hasattr(parameters, "to_dict") and hasattr(parameters, "columns"):
        names = [str(c) for c in parameters.columns]
        return names, [[float(v) for v in row] for row in parameters.itertuples(index=False)]
    if isinstance(parameters, Mapping):
        names = [str(k) for k in parameters]
        axes = []
        for name, values in parameters.items():
            if isinstance(values, str):
                values = _dirac.parse_values(values)
            values = [float(v) for v in np.atleast_1d(np.asarray(values, dtype=np.float64))]
            if not values:
                raise InputError(f"`{name}` has no values", parameter=name)
            axes.append(values)
        return names, [list(p) for p in itertools.product(*axes)]
    points = list(parameters)
    if not points or not all(isinstance(p, Mapping) for p in points):
        raise InputError(
            "parameters must be a mapping of values ({'R1.r': [1, 2]}), a list of points "
            "([{'R1.r': 1}, ...]) or a DataFrame"
        )
    names = [str(k) for k in points[0]]
    for i, p in enumerate(points):
        if list(p) != names:
            raise InputError(f"point {i} has the parameters {list(p)}, point 0 {names}")
    return names, [[float(p[n]) for n in names] for p in points]


def _run_chunk(spec, indices: List[int]) -> List[List[float]]:
    """Runs the points ``indices`` of a sweep in this process (any executor's worker)."""
    state, names, points, settings, outputs, trajectories, keep_going = spec
    model = _dirac.Model.restore(*state)
    chunk = _dirac.Sweep(
        model, names, points, outputs=outputs, trajectories=trajectories, **settings
    )
    return chunk.run_points(indices, keep_going)


def _run_chunk_callable(spec, indices: List[int]) -> List[Tuple[int, Dict[str, float]]]:
    """Runs the points ``indices`` and reduces each trajectory with the caller's function."""
    state, names, points, settings, reduce = spec
    base = Model(_dirac.Model.restore(*state))
    out = []
    for i in indices:
        model = base.with_parameters(dict(zip(names, points[i])))
        result = reduce(model.run(**settings))
        if not isinstance(result, Mapping):
            result = {"value": result}
        out.append((i, {str(k): float(v) for k, v in result.items()}))
    return out


def _workers(executor) -> int:
    for attr in ("_max_workers", "_processes"):
        n = getattr(executor, attr, None)
        if isinstance(n, int) and n > 0:
            return n
    if hasattr(executor, "nthreads"):  # dask.distributed.Client
        try:
            return max(1, sum(executor.nthreads().values()))
        except Exception:  # noqa: BLE001 - a client that cannot answer: assume the machine
            pass
    return os.cpu_count() or 1


def _map(executor, function, spec, chunks: List[List[int]]) -> List[Any]:
    """``[function(spec, c) for c in chunks]`` on the executor, in order."""
    if executor == "serial":
        return [function(spec, c) for c in chunks]
    if hasattr(executor, "submit"):
        futures = [executor.submit(function, spec, c) for c in chunks]
        return [f.result() for f in futures]
    if hasattr(executor, "apply_async"):  # multiprocessing.Pool, ray.util.multiprocessing.Pool
        pending = [executor.apply_async(function, (spec, c)) for c in chunks]
        return [p.get() for p in pending]
    raise TypeError(
        f"executor {executor!r}: expected a concurrent.futures.Executor, a dask Client, a pool "
        "with apply_async, or 'serial'"
    )


def sweep(
    model: Union[PathLike, Model, Any],
    parameters: Union[Mapping[str, Any], Sequence[Mapping[str, float]], Any],
    executor: Union[None, str, Executor, Any] = None,
    *,
    signals: Optional[Sequence[str]] = None,
    reduce: Reduce = None,
    trajectories: bool = False,
    method: Optional[str] = None,
    t_end: Optional[float] = None,
    h: Optional[float] = None,
    representation: Optional[str] = None,
    chunksize: Optional[int] = None,
    keep_going: bool = False,
    frame: Optional[bool] = None,
):
    """Runs ``model`` at every point of ``parameters`` and returns one table.

    Args:
        model: a file path, a :class:`Model` or a :class:`System`.
        parameters: ``{"R1.r": [1, 2, 5], "C1.c": "1e-6:1e-5:10"}`` (the Cartesian product, the
            first parameter varying slowest; values as a list, an array or the command line's
            ``1,2,5`` / ``start:stop:count[:log]``), or given points
            (``[{"R1.r": 1, "C1.c": 1e-6}, ...]`` or a DataFrame).
        executor: any ``concurrent.futures.Executor``, a Dask ``distributed.Client``, a pool
            with ``apply_async`` (``ray.util.multiprocessing.Pool``), or ``"serial"``; ``None``
            runs on a local ``ProcessPoolExecutor`` with one process per core.
        signals: the signals each run records (default: the file's).
        reduce: what each run returns: reductions ``["max(v(2))", "final(q(c1))"]`` (``final``,
            ``min``, ``max``, ``peak``, ``mean``, ``rms``; default: ``final`` of every recorded
            signal), or a function of the :class:`Trajectory` returning ``{column: value}``.
        trajectories: return every row of every run (columns ``t`` and the signals) instead.
        method, t_end, h, representation: run settings over the file's, as :meth:`Model.run`.
        chunksize: points per task (default: about four tasks per worker).
        keep_going: a point that fails numerically gives NaN outputs instead of raising.
        frame: a pandas DataFrame (True), a dict of numpy arrays (False); default: a DataFrame
            when pandas is installed.

    Returns:
        The table: ``point`` (the index in sweep order), the parameters, then the outputs; rows
        in point order whichever executor ran them, with the same numbers.
    """
    if hasattr(model, "build") and not isinstance(model, Model):
        model = model.build()
    if not isinstance(model, Model):
        model = Model.load(model)
    names, points = _points(parameters)
    settings = {"method": method, "t_end": t_end, "h": h, "representation": representation}
    state = (model.kind, model.name, model.text, model.overrides)
    if callable(reduce):
        if trajectories:
            raise InputError("give a reduce function or ask for trajectories, not both")
        run_settings = dict(settings, signals=None if signals is None else list(signals))
        _dirac.Sweep(model._inner, names, points[:1], **settings, signals=run_settings["signals"])
        spec = (state, names, points, run_settings, reduce)
        function = _run_chunk_callable
        columns = None
    else:
        outputs = None if reduce is None else [str(r) for r in reduce]
        run_settings = dict(settings, signals=None if signals is None else list(signals))
        # Built here first: bad names, signals or values fail before anything is shipped.
        planned = _dirac.Sweep(
            model._inner, names, points, outputs=outputs, trajectories=trajectories, **run_settings
        )
        columns = planned.columns()
        spec = (state, names, points, run_settings, outputs, trajectories, keep_going)
        function = _run_chunk
    own = executor is None
    n = len(points)
    if own:
        executor = ProcessPoolExecutor(max_workers=max(1, min(os.cpu_count() or 1, n)))
    try:
        if chunksize is None:
            chunksize = max(1, math.ceil(n / (4 * (1 if executor == "serial" else _workers(executor)))))
        chunks = [list(range(i, min(i + chunksize, n))) for i in range(0, n, chunksize)]
        results = _map(executor, function, spec, chunks)
    finally:
        if own:
            executor.shutdown()
    if columns is None:
        flat = [r for chunk in results for r in chunk]
        keys = list(flat[0][1]) if flat else []
        columns = ["point", *names, *keys]
        rows = [[float(i), *points[i], *(r.get(k, math.nan) for k in keys)] for i, r in flat]
    else:
        rows = [row for chunk in results for row in chunk]
    return _table(columns, rows, frame)


def _table(columns: List[str], rows: List[List[float]], frame: Optional[bool]):
    data = np.asarray(rows, dtype=np.float64).reshape(len(rows), len(columns))
    table: Dict[str, np.ndarray] = {c: data[:, j].copy() for j, c in enumerate(columns)}
    table["point"] = table["point"].astype(np.int64)
    if frame is None:
        try:
            import pandas  # noqa: F401

            frame = True
        except ImportError:
            frame = False
    if frame:
        import pandas as pd

        return pd.DataFrame(table)
    return table


def table_csv(table, path: Optional[PathLike] = None) -> str:
    """The CSV ``dirac sweep`` writes for a sweep table (a DataFrame or a dict of arrays): the
    same bytes as the command line's merged shards. Written to ``path`` if given."""
    columns = [str(c) for c in (table.columns if hasattr(table, "columns") else table.keys())]
    data = np.column_stack([np.asarray(table[c], dtype=np.float64) for c in columns])
    text = _dirac.table_text(columns, data.tolist())
    if path is not None:
        with open(path, "w", newline="") as f:
            f.write(text)
    return text
