"""The exceptions of dirac: bad input and numerical failure.

Both pickle with their fields, so an error raised in a worker process (``multiprocessing``,
Dask, Ray) arrives in the caller intact.
"""

from __future__ import annotations

from typing import Any, Optional

__all__ = ["DiracError", "InputError", "SimulationError"]


class DiracError(Exception):
    """Base class of dirac's errors."""

    _fields: tuple = ()

    def __init__(self, message: str, **fields: Any) -> None:
        super().__init__(message)
        self.message = message
        for name in self._fields:
            setattr(self, name, fields.get(name))

    def __reduce__(self):
        return (_rebuild, (type(self), self.message, {f: getattr(self, f) for f in self._fields}))


def _rebuild(cls, message, fields):
    return cls(message, **fields)


class InputError(DiracError, ValueError):
    """Bad input: a file, a part, a port, a parameter, a signal or a setting.

    Attributes:
        file: the file at fault (or the name given to a model built from text), if known.
        line: 1-based line in that file, if known.
        column: 1-based column, if known.
        parameter: the parameter name (``"R1.r"``) when a parameter was at fault.

    The message names the part, port, connection or signal at fault and what exists.
    """

    _fields = ("file", "line", "column", "parameter")
    file: Optional[str]
    line: Optional[int]
    column: Optional[int]
    parameter: Optional[str]

    @property
    def location(self) -> Optional[str]:
        """``file:line:column`` when the error has a position, else None."""
        if self.file is None or self.line is None:
            return None
        return f"{self.file}:{self.line}:{self.column}"


class SimulationError(DiracError, RuntimeError):
    """A run failed numerically (Newton did not converge, a value left the model's domain).

    Attributes:
        step: index of the step (or output row) that failed, if known.
        time: time at the start of that step, if known.
        residual: max-norm of the Newton residual when it failed (NaN if it was not finite).

    The message says what usually causes the failure.
    """

    _fields = ("step", "time", "residual")
    step: Optional[int]
    time: Optional[float]
    residual: Optional[float]
