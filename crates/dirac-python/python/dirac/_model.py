"""Models read from netlists and scenes (or built in Python), and running them."""

from __future__ import annotations

import os
import warnings
from typing import Dict, Iterable, List, Mapping, NamedTuple, Optional, Union

from . import _dirac
from ._trajectory import Trajectory

__all__ = ["Comparison", "Model", "load", "run"]

PathLike = Union[str, "os.PathLike[str]"]


class Comparison(NamedTuple):
    """One representation's largest deviation from the monolithic run (``dirac compare``)."""

    execution: str
    max_abs_deviation: Optional[float]
    note: Optional[str]


def _restore(kind: str, name: str, text: str, overrides) -> "Model":
    return Model(_dirac.Model.restore(kind, name, text, list(overrides)))


class Model:
    """A netlist or scene with parameters set by name.

    Parameters have the names scene files use, ``<part>.<parameter>``: ``R1.r``, ``C1.c``,
    ``L1.ic``, ``V1.waveform.amplitude``; a coupling's element parameters go by the coupling's
    name (``k12.k``). Netlist elements take the names of the scene parts they become
    (``dirac convert``). ``model["R1.r"]`` reads a parameter, ``model["R1.r"] = 2.0`` sets it
    (checked as the reader checks a file), ``model.with_parameters({...})`` returns a changed
    copy. A model pickles as its source text and its parameter changes.
    """

    __slots__ = ("_inner",)

    def __init__(self, inner: "_dirac.Model") -> None:
        self._inner = inner

    @classmethod
    def load(cls, path: PathLike) -> "Model":
        """Reads the netlist (``.cir``, ``.sp``, ``.net``, ``.spice``) or scene (``.toml``) at
        ``path``. Raises :class:`dirac.InputError` with ``file:line:column`` for bad input."""
        return cls(_dirac.Model.load(os.fspath(path)))

    @classmethod
    def from_netlist(cls, text: str, name: str = "<netlist>") -> "Model":
        """A netlist from its text; ``name`` stands for the file in messages."""
        return cls(_dirac.Model.restore("netlist", name, text, []))

    @classmethod
    def from_scene(cls, scene: Union[str, Mapping], name: str = "<scene>") -> "Model":
        """A scene from its TOML text or from a dict of the same shape (see
        :class:`dirac.System` to build one part by part)."""
        if not isinstance(scene, str):
            from ._toml import dumps

            scene = dumps(scene)
        return cls(_dirac.Model.restore("scene", name, scene, []))

    def __reduce__(self):
        return (_restore, (self.kind, self.name, self.text, self.overrides))

    def __repr__(self) -> str:
        changed = f", {len(self.overrides)} parameters changed" if self.overrides else ""
        return f"<dirac.Model {self.kind} {self.name!r}{changed}>"

    @property
    def kind(self) -> str:
        """``"netlist"`` or ``"scene"``."""
        return self._inner.kind

    @property
    def name(self) -> str:
        """The file's path, or the name given to a model built from text."""
        return self._inner.name

    @property
    def text(self) -> str:
        """The source text as read (before any parameter change)."""
        return self._inner.text

    @property
    def overrides(self) -> List[tuple]:
        """The parameter changes since reading: ``[(name, value), ...]`` in order."""
        return self._inner.overrides

    @property
    def parameters(self) -> Dict[str, float]:
        """Every numeric parameter the model states, with its current value."""
        return dict(self._inner.parameters())

    @property
    def signals(self) -> List[str]:
        """The signals the file records by default."""
        return self._inner.default_signals()

    @property
    def warnings(self) -> List[str]:
        """What the reader noticed (ignored netlist cards, options dirac does differently)."""
        return self._inner.warnings()

    def __getitem__(self, parameter: str) -> float:
        return self._inner.parameter(parameter)

    def __setitem__(self, parameter: str, value: float) -> None:
        self._inner.set_parameter(parameter, float(value))

    def copy(self) -> "Model":
        """An independent copy."""
        return _restore(self.kind, self.name, self.text, self.overrides)

    def with_parameters(self, values: Mapping[str, float]) -> "Model":
        """A copy with the parameters ``values`` set (``{"R1.r": 2.0}``)."""
        model = self.copy()
        for name, value in values.items():
            model[name] = value
        return model

    def to_toml(self) -> Optional[str]:
        """The scene as TOML with the parameter changes applied (None for a netlist)."""
        return self._inner.scene_toml()

    def run(
        self,
        method: Optional[str] = None,
        t_end: Optional[float] = None,
        signals: Optional[Iterable[str]] = None,
        *,
        h: Optional[float] = None,
        representation: Optional[str] = None,
        scheme: Optional[str] = None,
        energy: bool = False,
        start_ramp: Optional[bool] = None,
        refine: Optional[bool] = None,
        composition: Optional[str] = None,
        force: bool = False,
    ) -> Trajectory:
        """Runs the model and returns its :class:`Trajectory`.

        Every argument left ``None`` keeps the file's setting (a scene's ``[simulation]``, a
        netlist's ``.tran``, ``.options method=`` and ``.print``), as ``dirac run`` does.

        Args:
            method: ``midpoint``, ``trapezoid``, ``gauss2``, ``gauss3``, ``gauss4``.
            t_end: end time.
            signals: signal names (``"v(2)"``, ``"i(l1)"``, ``"v(a,b)"`` in a netlist;
                ``"C1.q"``, ``"L1.i"``, ``"A.x'"``, ``"energy"`` in a scene).
            h: step size.
            representation: ``monolithic``, ``constraint``, ``force``, ``staggered``,
                ``staggered-gs``, ``staggered-jacobi``.
            scheme: ``plus``, ``minus``, ``symmetric``.
            energy: also record the total energy for ``summary.energy_drift`` (costs a readout
                of the velocities at every row).
            start_ramp: take the first step as geometrically growing substeps, which damp the
                fast modes of a stiff start off its slow manifold, down to a substep that reaches
                the fastest damped mode (``dirac run --start-ramp``;
                ``None`` keeps the scene's ``start_ramp``; a netlist takes it, and ramps the
                stretch after every source breakpoint, when its modal check finds a damped mode
                the method would leave ringing; ``False`` turns both off).
            refine: control the truncation error as SPICE does, taking a step whose estimated
                local error is too large again as 2^m substeps on the same grid (``dirac run
                --refine``/``--fixed-step``; ``None``: on for a netlist with diodes, else off).
            composition: take each step as a symmetric composition of substeps, ``yoshida4``,
                ``yoshida6``, ``yoshida8``, ``kahan-li6``, ``kahan-li8`` or ``none`` (``dirac run
                --composition``; ``None`` keeps the scene's ``composition``, none for a netlist).
                It raises a second-order method to the composition's order when the run has no
                constraints; with ``method="trapezoid"`` on a separable scene every substep is an
                explicit Störmer–Verlet step.
            force: run even when the method would amplify a mode of the model by more than
                1e6 over the run (the trapezoid rule on a decay much faster than ``h``), which
                is otherwise refused with an :class:`InputError` before a step is taken
                (``dirac run --force``).

        Raises:
            InputError: bad settings or signal names, an inconsistent start, a method that
                would blow up on a mode of the model (see ``force``).
            SimulationError: Newton failed (with ``step``, ``time``, ``residual``).

        The GIL is released while the run steps.
        """
        names, t, data, summary = self._inner.run(
            method=method,
            representation=representation,
            scheme=scheme,
            h=h,
            t_end=t_end,
            signals=None if signals is None else list(signals),
            energy=energy,
            start_ramp=start_ramp,
            refine=refine,
            composition=composition,
            force=force,
        )
        return Trajectory._from_run(names, t, data, summary)

    def compare(
        self,
        method: Optional[str] = None,
        t_end: Optional[float] = None,
        signals: Optional[Iterable[str]] = None,
        *,
        h: Optional[float] = None,
        composition: Optional[str] = None,
    ) -> List[Comparison]:
        """Runs every representation (for a scene also both staggered splittings) and returns
        each one's largest deviation from the monolithic run (``dirac compare``; ``composition``
        as in :meth:`run`)."""
        rows = self._inner.compare(
            method=method,
            h=h,
            t_end=t_end,
            signals=None if signals is None else list(signals),
            composition=composition,
        )
        return [Comparison(*r) for r in rows]

    def check(self) -> dict:
        """``dirac check``'s report: parts, connections, the size of each representation,
        degenerate directions, signals, start."""
        return self._inner.check()

    def operating_point(self) -> Dict[str, float]:
        """The steady state with the sources at t = 0 (``dirac op``). The set-up's warnings
        (a steady state that is not isolated, redundant rows dropped) are issued as
        ``RuntimeWarning``."""
        values, notes = self._inner.operating_point()
        for note in notes:
            warnings.warn(note, RuntimeWarning, stacklevel=2)
        return dict(values)


def load(path: PathLike) -> Model:
    """Reads a netlist or scene file: ``dirac.load("circuit.cir")``."""
    return Model.load(path)


def run(
    model: Union[PathLike, Model],
    method: Optional[str] = None,
    t_end: Optional[float] = None,
    signals: Optional[Iterable[str]] = None,
    **options,
) -> Trajectory:
    """Runs a netlist or scene file (or a :class:`Model`) and returns its :class:`Trajectory`:
    ``dirac.run("circuit.cir", method="gauss2")``. See :meth:`Model.run` for the options."""
    if not isinstance(model, Model):
        model = Model.load(model)
    return model.run(method=method, t_end=t_end, signals=signals, **options)
