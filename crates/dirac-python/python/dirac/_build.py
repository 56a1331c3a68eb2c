"""Building a model from stock parts in Python, with the names scene files use."""

from __future__ import annotations

from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

from ._model import Model
from ._toml import dumps
from ._trajectory import Trajectory

__all__ = ["System"]

Port = Union[str, Tuple[str, float]]


class System:
    """An interconnection of stock parts, written as a scene and read by the scene reader.

    Parts, parameters, ports and connections have the names of scene files (docs/guide.md,
    "Scene files"): ``part("C1", "capacitor", c=3.0, q0=1.0)``, ``node("n1", "+L1.i", "-R1.i")``,
    ``joint("shaft", "M.theta", "G.theta1")``, ``coupling("k12", "A.x", "B.x", "spring", k=1.0)``.
    :meth:`build` returns a :class:`Model` (so every error names the part, port or parameter at
    fault as a scene file's would), :meth:`run`, :meth:`compare` and :meth:`check` build and use
    it. :meth:`to_toml` shows the scene; ``dirac run`` runs the same file to the same rows.

    Args:
        h: step size.
        t_end: end time.
        representation: ``monolithic``, ``constraint``, ``force`` or ``staggered``.
        discretisation: ``midpoint``, ``trapezoid``, ``simpson``, ``gauss``, ``lobatto``.
        order: the discretisation's order (even; ``2s`` for ``s`` Gauss or Lobatto nodes).
        scheme: ``plus``, ``minus``, ``symmetric``.
        **simulation: other keys of the scene's ``[simulation]`` table (``splitting``,
            ``initial``).
    """

    def __init__(
        self,
        h: float,
        t_end: float,
        representation: str = "monolithic",
        discretisation: str = "midpoint",
        order: Optional[int] = None,
        scheme: str = "plus",
        **simulation: Any,
    ) -> None:
        self.simulation: Dict[str, Any] = {
            "representation": representation,
            "scheme": scheme,
            "discretisation": discretisation,
            "h": float(h),
            "t_end": float(t_end),
        }
        if order is not None:
            self.simulation["order"] = int(order)
        self.simulation.update(simulation)
        self.parts: List[Dict[str, Any]] = []
        self.connections: List[Dict[str, Any]] = []
        self.recorded: Dict[str, Any] = {}

    def part(self, name: str, type: str, *, q0: Any = None, v0: Any = None, **parameters: Any) -> str:
        """Adds the stock part ``type`` named ``name`` with its ``parameters`` (``r=``, ``c=``,
        ``waveform=``, ...) and initial positions ``q0`` / rates ``v0`` (a number, a list in
        coordinate order or a dict by coordinate name). Returns ``name``."""
        entry: Dict[str, Any] = {"name": name, "type": type}
        entry.update(parameters)
        if q0 is not None:
            entry["q0"] = q0
        if v0 is not None:
            entry["v0"] = v0
        self.parts.append(entry)
        return name

    def node(self, name: str, *ports: Port) -> str:
        """A node (KCL / force balance): ``Σ sign·flow = 0`` over the ports, each written
        ``"+L1.i"`` / ``"-R1.i"`` or ``("L1.i", 1.0)``. Returns ``name``."""
        written = [list(p) if isinstance(p, tuple) else p for p in ports]
        self.connections.append({"type": "node", "name": name, "ports": written})
        return name

    def joint(self, name: str, a: str, b: str) -> str:
        """A rigid joint between ports ``a`` and ``b`` (equal flows). Returns ``name``."""
        self.connections.append({"type": "joint", "name": name, "a": a, "b": b})
        return name

    def coupling(self, name: str, a: str, b: str, type: str, **parameters: Any) -> str:
        """A coupling element of ``type`` (``spring``: ``k``, ``k3``, ``rest``; ``damper``:
        ``c``; ``force_source``: ``waveform``) between ports ``a`` and ``b``. Its parameters are
        swept as ``<name>.<parameter>``. Returns ``name``."""
        element = {"type": type}
        element.update(parameters)
        self.connections.append(
            {"type": "coupling", "name": name, "a": a, "b": b, "element": element}
        )
        return name

    def record(
        self,
        signals: Optional[Iterable[str]] = None,
        *,
        energy: bool = False,
        power: Sequence[str] = (),
        residuals: bool = False,
        forces: Sequence[str] = (),
    ) -> None:
        """What runs record (the scene's ``[record]``): signals ``part.coordinate``,
        ``part.coordinate'``, ``part.port``; the total ``energy``; ``power(P)`` of parts; the
        ``constraint_residual``; ``force(c)`` of connections."""
        self.recorded = {}
        if signals is not None:
            self.recorded["signals"] = list(signals)
        if energy:
            self.recorded["energy"] = True
        if power:
            self.recorded["power"] = list(power)
        if residuals:
            self.recorded["residuals"] = True
        if forces:
            self.recorded["forces"] = list(forces)

    def to_dict(self) -> Dict[str, Any]:
        """The scene as a dict of the TOML file's shape."""
        doc: Dict[str, Any] = {"simulation": dict(self.simulation)}
        if self.recorded:
            doc["record"] = dict(self.recorded)
        if self.parts:
            doc["part"] = [dict(p) for p in self.parts]
        if self.connections:
            doc["connection"] = [dict(c) for c in self.connections]
        return doc

    def to_toml(self) -> str:
        """The scene file text."""
        return dumps(self.to_dict())

    def build(self, name: str = "<system>") -> Model:
        """The :class:`Model` of this system (raises :class:`dirac.InputError` naming the part,
        port or parameter at fault)."""
        return Model.from_scene(self.to_toml(), name)

    def run(self, **options: Any) -> Trajectory:
        """``build().run(**options)``."""
        return self.build().run(**options)

    def compare(self, **options: Any):
        """``build().compare(**options)``: every representation against monolithic."""
        return self.build().compare(**options)

    def check(self) -> dict:
        """``build().check()``."""
        return self.build().check()
