#!/usr/bin/env python3
"""Work-precision diagrams and ratio tables from benchmark CSVs (bench/SCENES.md).

Usage:
    python3 bench/peers/plot.py bench/results/*.csv --outdir bench/results

Reads any number of CSV files with the header

    scene,tool,method,setting,wall_s,steps,newton_iterations,error,energy_error

(ours from `dirac bench`, the peers' from peers.py), and writes to --outdir:

- `work_precision_<scene>.png` / `.svg` for A, B, D1, D2 (log-log, x = error, y = wall_s, one line per
  tool + method, dirac drawn prominently) and `scaling_C.png` / `.svg` for the ladder;
- `ratios.md`: the cheapest-run tables and time ratios described in bench/peers/README.md.

Lines starting with `#` are ignored; `<csv>.notes.txt` files beside the CSVs (written by peers.py)
are appended to ratios.md.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

FAST_PERIOD_D1 = 4.443e-3
D1_MIN_H = 10 * FAST_PERIOD_D1
LEVELS_AB = [1e-3, 1e-6, 1e-9]
LEVEL_D2 = 1e-8
# Issue 15: D2-long and E at max energy error ≤ 1e-10 over [0, 1e4].
LEVEL_LONG = 1e-10
# "No secular drift": the running maximum of the energy error at t_end is at most this factor above
# its value at t_end/10 (a bounded oscillating error samples rarer extremes over a longer run and
# creeps up a little; a linear drift gives a factor of 10, a random walk about 3.2).
FLAT_FACTOR = 2.0
C_FIT_RANGE = (1e3, 1e5)
OURS = "dirac"
NOT_REACHED = "not reached"
# Compiled peers (bench/compiled) and Python-callback baselines (bench/peers/peers.py).
COMPILED = {"c", "sundials", "diffsol", "differential-equations"}
PYTHON = {"scipy-py", "sksundae-py"}
# Scene F: the published SciMLBenchmarks figures (AMD EPYC 7502, another machine): Rodas5 at default
# tolerances, n = 1000; JuliaSimCompiler's best whole run (simplify + build + solve) and fastest solve.
F_PUBLISHED_WHOLE_S = 3.88
F_PUBLISHED_SOLVE_S = 0.107
# Scene E: SciMLBenchmarks' published table (another machine), max energy error and time.
E_PUBLISHED = [("DPRKN12", 8.5e-15, 0.05), ("Vern9", 4.6e-14, 0.33), ("KahanLi8", 3.2e-14, 0.83)]
# Issue 15, CLI: `dirac run` (whole child process) at most this factor above the library path.
CLI_FACTOR = 1.5


def num(s) -> float:
    try:
        return float(s)
    except (TypeError, ValueError):
        return math.nan


def finite(x: float) -> bool:
    return x is not None and not math.isnan(x) and not math.isinf(x)


def read_rows(paths: list[str]) -> list[dict]:
    rows = []
    for path in paths:
        try:
            with open(path, newline="") as fh:
                lines = [ln for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
        except OSError as e:
            print(f"plot.py: cannot read {path}: {e}", file=sys.stderr)
            continue
        for r in csv.DictReader(lines):
            if not r.get("scene") or not r.get("tool"):
                continue
            if r["scene"] == "scene":  # a repeated header
                continue
            rows.append(
                {
                    "scene": r["scene"].strip(),
                    "tool": r["tool"].strip(),
                    "method": (r.get("method") or "").strip(),
                    "setting": (r.get("setting") or "").strip(),
                    "wall_s": num(r.get("wall_s")),
                    "steps": num(r.get("steps")),
                    "newton": num(r.get("newton_iterations")),
                    "error": num(r.get("error")),
                    "energy_error": num(r.get("energy_error")),
                    "file": path,
                }
            )
    return rows


def read_drift(paths: list[str]) -> dict[tuple[str, str, str, str], list[float]]:
    """Running maxima per tenth from the `.drift.csv` side files: (scene, tool, method, setting)."""
    out = {}
    for path in paths:
        try:
            with open(path, newline="") as fh:
                for r in csv.DictReader(fh):
                    key = (r["scene"], r["tool"], r["method"], r["setting"])
                    out[key] = [num(r.get(f"tenth{k}")) for k in range(1, 11)]
        except (OSError, KeyError) as e:
            print(f"plot.py: cannot read {path}: {e}", file=sys.stderr)
    return out


def same_setting(a: str, b: str) -> bool:
    x, y = num(a), num(b)
    return a == b or (finite(x) and finite(y) and abs(x - y) <= 1e-9 * max(abs(x), abs(y)))


def drift_of(drift: dict, r: dict) -> list[float] | None:
    for (sc, tool, method, setting), v in drift.items():
        if sc == r["scene"] and tool == r["tool"] and method == r["method"] and same_setting(
            setting, r["setting"]
        ):
            return v
    return None


def scene_key(scene: str) -> str:
    if scene.startswith("C-") or scene == "C":
        return "C"
    if scene.startswith("Cacc-"):
        return "Cacc"
    if scene == "F-whole":
        return "F"
    if scene.startswith("CLI-"):
        return "CLI"
    return scene


def c_sections(r: dict) -> float:
    n = num(r["setting"])
    if not finite(n) and r["scene"].startswith("C-"):
        n = num(r["scene"][2:])
    return n


def c_sections_acc(r: dict) -> float:
    return num(r["scene"][5:]) if r["scene"].startswith("Cacc-") else math.nan


def label(r: dict) -> str:
    return f"{r['tool']} {r['method']}".strip()


def describe(r: dict | None, with_error: str = "error") -> str:
    if r is None:
        return NOT_REACHED
    return (
        f"{r['tool']} {r['method']} @ {r['setting']}: {r['wall_s']:.3g} s, "
        f"{with_error.replace('_', ' ')} {r[with_error]:.2g}"
    )


def cheapest(rows: list[dict], key: str, level: float) -> dict | None:
    ok = [r for r in rows if finite(r[key]) and r[key] <= level and finite(r["wall_s"])]
    return min(ok, key=lambda r: r["wall_s"]) if ok else None


def ratio(peer: dict | None, ours: dict | None) -> str:
    if peer is None or ours is None or not ours["wall_s"] > 0:
        return NOT_REACHED
    return f"{peer['wall_s'] / ours['wall_s']:.3g}"


# ---------------------------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------------------------

PEER_COLOURS = plt.get_cmap("tab10").colors
OUR_COLOURS = [
    "#d62728", "#000000", "#1f4e9c", "#7b3294", "#e66101", "#008837", "#a6611a", "#c51b7d",
    "#4d4d4d", "#b8860b",
]
OUR_MARKERS = ["D", "s", "^", "v", "P", "X", "*", "h"]


def series(rows: list[dict], x: str, y: str) -> dict[tuple[str, str], list[tuple[float, float]]]:
    out: dict[tuple[str, str], list[tuple[float, float, float]]] = defaultdict(list)
    for r in rows:
        xv, yv = r[x], r[y]
        if not (finite(xv) and finite(yv)) or xv <= 0 or yv <= 0:
            continue
        s = num(r["setting"])
        out[(r["tool"], r["method"])].append((s if finite(s) else xv, xv, yv))
    return {k: [(a, b) for _, a, b in sorted(v)] for k, v in out.items()}


def draw(ax, data, xlabel: str, ylabel: str, title: str) -> None:
    peers = sorted(k for k in data if k[0] != OURS)
    ours = sorted(k for k in data if k[0] == OURS)
    for i, k in enumerate(peers):
        xs, ys = zip(*data[k])
        ax.loglog(
            xs, ys, marker="o", ms=3, lw=1.0, ls="--", alpha=0.6,
            color=PEER_COLOURS[i % len(PEER_COLOURS)], label=f"{k[0]} {k[1]}",
        )
    for i, k in enumerate(ours):
        xs, ys = zip(*data[k])
        ax.loglog(
            xs, ys, marker=OUR_MARKERS[i % len(OUR_MARKERS)], ms=6, lw=2.6, zorder=10,
            color=OUR_COLOURS[i % len(OUR_COLOURS)], label=f"{k[0]} {k[1]}",
        )
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.25)
    if data:
        ax.legend(fontsize=7, loc="best")
    else:
        ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)


TITLES = {
    "A": "A: seed RLC loop (max |q_C error| over produced points)",
    "B": "B: damped oscillator (error at t = 5T)",
    "D1": "D1: stiff spring chain",
    "D2": "D2: double pendulum (max |E - E0|)",
    "D2-long": "D2-long: double pendulum on [0, 1e4]",
    "E": "E: Henon-Heiles on [0, 1e4] (q = (0.1, 0), p = (0, 0.5))",
    "F": "F: SciMLBenchmarks RC ladder, n = 1000, error at t = 10",
}


def save(fig, outdir: str, stem: str) -> list[str]:
    paths = []
    for ext in ("png", "svg"):
        p = os.path.join(outdir, f"{stem}.{ext}")
        fig.savefig(p, dpi=130 if ext == "png" else None, bbox_inches="tight")
        paths.append(p)
    plt.close(fig)
    return paths


def drift_figure(by_scene: dict[str, list[dict]], drift: dict, outdir: str) -> list[str]:
    """Running max of the energy error per tenth: each tool's cheapest run at ≤ LEVEL_LONG (or its
    most accurate run when none gets there)."""
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    for ax, sc in zip(axes, ("D2-long", "E")):
        rows = by_scene.get(sc, [])
        for i, tool in enumerate(sorted({r["tool"] for r in rows})):
            mine = [r for r in rows if r["tool"] == tool]
            r = cheapest(mine, "energy_error", LEVEL_LONG) or (
                min(mine, key=lambda x: x["energy_error"] if finite(x["energy_error"]) else math.inf)
                if mine else None
            )
            d = drift_of(drift, r) if r else None
            if not d:
                continue
            ours = tool == OURS
            ax.semilogy(range(1, 11), d, marker="o", lw=2.6 if ours else 1.2,
                        color="#d62728" if ours else PEER_COLOURS[i % len(PEER_COLOURS)],
                        label=f"{tool} {r['method']} @ {r['setting']}")
        ax.set_xlabel("tenth of [0, 1e4]")
        ax.set_ylabel("running max |E - E0|")
        ax.set_title(f"{sc}: energy error growth")
        ax.grid(True, which="both", alpha=0.25)
        if ax.lines:
            ax.legend(fontsize=7)
    return save(fig, outdir, "drift_long")


def figures(by_scene: dict[str, list[dict]], outdir: str) -> list[str]:
    written = []
    for sc in ("A", "B", "D2"):
        rows = by_scene.get(sc, [])
        fig, ax = plt.subplots(figsize=(7.5, 5.5))
        draw(ax, series(rows, "error", "wall_s"), "error", "wall time [s]", TITLES[sc])
        written += save(fig, outdir, f"work_precision_{sc}")
    rows = by_scene.get("D1", [])
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    draw(axes[0], series(rows, "error", "wall_s"), "slow-mode error at t = 10", "wall time [s]",
         "D1: slow-mode error")
    draw(axes[1], series(rows, "energy_error", "wall_s"), "max relative energy error",
         "wall time [s]", "D1: energy error")
    fig.suptitle(TITLES["D1"])
    written += save(fig, outdir, "work_precision_D1")
    for sc in ("D2-long", "E"):
        rows = by_scene.get(sc, [])
        fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
        draw(axes[0], series(rows, "energy_error", "wall_s"), "max |E - E0| over [0, 1e4]",
             "wall time [s]", f"{sc}: energy error")
        if sc == "E":
            for name, err, wall in E_PUBLISHED:
                axes[0].loglog([err], [wall], marker="*", ms=12, ls="none", color="grey")
                axes[0].annotate(f"{name} (SciMLBenchmarks,\nother machine)", (err, wall),
                                 fontsize=6, xytext=(4, 4), textcoords="offset points")
            draw(axes[1], series(rows, "steps", "wall_s"), "steps", "wall time [s]", "E: cost per step")
        else:
            draw(axes[1], series(rows, "error", "wall_s"), "|theta1(1e4) - reference|",
                 "wall time [s]", "D2-long: phase error of theta1 at t = 1e4")
        fig.suptitle(TITLES[sc])
        written += save(fig, outdir, f"work_precision_{sc}")
    rows = by_scene.get("F", [])
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    solve = [r for r in rows if r["scene"] == "F"]
    whole = [dict(r, method=r["method"] + " (whole)") for r in rows if r["scene"] == "F-whole"]
    draw(axes[0], series(solve, "error", "wall_s"), "max |v(10) - exact|", "wall time [s]",
         "F: solve")
    axes[0].axhline(F_PUBLISHED_SOLVE_S, color="grey", ls=":", lw=1)
    draw(axes[1], series(whole, "error", "wall_s"), "max |v(10) - exact|", "wall time [s]",
         "F: dirac's whole run (graph, assembly, solve)")
    axes[1].axhline(F_PUBLISHED_WHOLE_S, color="grey", ls=":", lw=1)
    fig.suptitle(TITLES["F"])
    written += save(fig, outdir, "work_precision_F")
    rows = by_scene.get("Cacc", [])
    sizes = sorted({c_sections_acc(r) for r in rows if finite(c_sections_acc(r))})
    if sizes:
        fig, axes = plt.subplots(1, len(sizes), figsize=(5.5 * len(sizes), 5), squeeze=False)
        for ax, n in zip(axes[0], sizes):
            sub = [r for r in rows if c_sections_acc(r) == n]
            draw(ax, series(sub, "error", "wall_s"), "max |v(10) - reference|", "wall time [s]",
                 f"C, N = {int(n)}: accuracy")
        fig.suptitle("C: RLC ladder accuracy at t = 10 (dirac: midpoint and Gauss 2-4, whole solve; ngspice: its transient time)")
        written += save(fig, outdir, "work_precision_Cacc")
    rows = by_scene.get("C", [])
    for r in rows:
        r["N"] = c_sections(r)
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    draw(axes[0], series(rows, "N", "error"), "sections N", "µs per step per section",
         "C: cost per step per section")
    draw(axes[1], series(rows, "N", "wall_s"), "sections N", "wall time [s]", "C: wall time")
    fig.suptitle("C: RLC ladder scaling (1000 steps of h = 0.01)")
    written += save(fig, outdir, "scaling_C")
    return written


# ---------------------------------------------------------------------------------------------
# ratio tables
# ---------------------------------------------------------------------------------------------


def peer_tools(rows: list[dict]) -> list[str]:
    return sorted({r["tool"] for r in rows if r["tool"] != OURS})


def table_levels(rows: list[dict], levels: list[float], key: str) -> list[str]:
    tools = peer_tools(rows)
    ours = [r for r in rows if r["tool"] == OURS]
    peers = [r for r in rows if r["tool"] != OURS]
    head = ["level", "dirac (cheapest)"] + [f"{t} (cheapest)" for t in tools] + [
        "best peer overall", "peer time / dirac time"
    ]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for lv in levels:
        d = cheapest(ours, key, lv)
        cells = [f"{lv:.0e}", describe(d, key)]
        for t in tools:
            cells.append(describe(cheapest([r for r in peers if r["tool"] == t], key, lv), key))
        p = cheapest(peers, key, lv)
        cells += [describe(p, key), ratio(p, d)]
        out.append("| " + " | ".join(cells) + " |")
    return out


def table_d1(rows: list[dict]) -> list[str]:
    ours = sorted(
        (r for r in rows if r["tool"] == OURS and finite(num(r["setting"]))
         and num(r["setting"]) >= D1_MIN_H * (1 - 1e-9)),
        key=lambda r: (r["method"], num(r["setting"])),
    )
    peers = [r for r in rows if r["tool"] != OURS]
    head = ["dirac method", "h", "wall_s", "slow-mode error", "energy error (rel.)",
            "cheapest peer with slow-mode error ≤ that", "peer energy error", "peer time / dirac time"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    if not ours:
        out.append("| " + " | ".join([NOT_REACHED] + [""] * (len(head) - 1)) + " |")
        return out
    for d in ours:
        p = cheapest(peers, "error", d["error"]) if finite(d["error"]) else None
        out.append(
            "| " + " | ".join([
                d["method"], d["setting"], f"{d['wall_s']:.3g}", f"{d['error']:.3g}",
                f"{d['energy_error']:.3g}", describe(p, "error"),
                f"{p['energy_error']:.3g}" if p else NOT_REACHED, ratio(p, d),
            ]) + " |"
        )
    return out


def fit_exponent(pts: list[tuple[float, float]]) -> str:
    pts = [(n, w) for n, w in pts if C_FIT_RANGE[0] <= n <= C_FIT_RANGE[1] and w > 0]
    if len(pts) < 2:
        return NOT_REACHED
    xs = [math.log(n) for n, _ in pts]
    ys = [math.log(w) for _, w in pts]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    if sxx == 0:
        return NOT_REACHED
    slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx
    ns = ", ".join(f"{int(n)}" for n, _ in sorted(pts))
    return f"{slope:.2f} (N = {ns})"


def table_c(rows: list[dict]) -> list[str]:
    for r in rows:
        r["N"] = c_sections(r)
    rows = [r for r in rows if finite(r["N"])]
    ours_methods = sorted({r["method"] for r in rows if r["tool"] == OURS})
    ng = {r["N"]: r for r in rows if r["tool"] == "ngspice"}
    ns = sorted({r["N"] for r in rows})
    if not ours_methods:
        ours_methods = [None]
    head = ["N"]
    for m in ours_methods:
        head += [f"dirac {m or ''} µs/step/section".replace("  ", " ")]
    head += ["ngspice µs/step/section", "ngspice steps"]
    head += [f"ngspice / dirac {m or ''}".rstrip() for m in ours_methods]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    ours_by = {
        m: {r["N"]: r for r in rows if r["tool"] == OURS and r["method"] == m}
        for m in ours_methods if m is not None
    }
    for n in ns:
        cells = [f"{int(n)}"]
        for m in ours_methods:
            d = ours_by.get(m, {}).get(n)
            cells.append(f"{d['error']:.3g}" if d else NOT_REACHED)
        g = ng.get(n)
        cells.append(f"{g['error']:.3g}" if g else NOT_REACHED)
        cells.append(f"{int(g['steps'])}" if g and finite(g["steps"]) else NOT_REACHED)
        for m in ours_methods:
            d = ours_by.get(m, {}).get(n)
            if d and g and d["error"] > 0:
                cells.append(f"{g['error'] / d['error']:.3g}")
            else:
                cells.append(NOT_REACHED)
        out.append("| " + " | ".join(cells) + " |")
    out.append("")
    out.append("Fitted cost exponent (log-log slope of wall_s against N over N = 1e3 … 1e5):")
    out.append("")
    for m in ours_methods:
        pts = [(r["N"], r["wall_s"]) for r in rows if r["tool"] == OURS and r["method"] == m]
        out.append(f"- dirac {m or ''}: {fit_exponent(pts) if m is not None else NOT_REACHED}")
    pts = [(r["N"], r["wall_s"]) for r in rows if r["tool"] == "ngspice"]
    out.append(f"- ngspice: {fit_exponent(pts)}")
    return out


def compiled(rows: list[dict]) -> list[dict]:
    return [r for r in rows if r["tool"] in COMPILED]


def brief(r: dict | None, key: str = "error") -> str:
    if r is None:
        return NOT_REACHED
    return f"{r['tool']} {r['method']} @ {r['setting']}: {r['wall_s']:.3g} s ({r[key]:.2g})"


def factor(peer: dict | None, ours: dict | None) -> float:
    if peer is None or ours is None or not ours["wall_s"] > 0:
        return math.nan
    return peer["wall_s"] / ours["wall_s"]


def fmt_factor(x: float) -> str:
    return "–" if not finite(x) else f"{x:.3g}"


def verdict(ok: bool | None) -> str:
    return "n/a" if ok is None else ("**met**" if ok else "**missed**")


def targets_ab(sc: str, rows: list[dict], summary: list[str]) -> list[str]:
    """Issue 15, A and B: dirac's cheapest (with and without the affine map) against every compiled
    peer's cheapest at each error level."""
    ours = [r for r in rows if r["tool"] == OURS]
    plain = [r for r in ours if not r["method"].endswith("-affine")]
    comp = compiled(rows)
    py = [r for r in rows if r["tool"] in PYTHON]
    tools = sorted({r["tool"] for r in comp})
    head = ["level", "dirac cheapest", "dirac without affine map"] + [
        f"{t} cheapest" for t in tools
    ] + ["best compiled / dirac", "best compiled / dirac w/o affine", "best Python baseline"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for lv in LEVELS_AB:
        d, dp = cheapest(ours, "error", lv), cheapest(plain, "error", lv)
        best = cheapest(comp, "error", lv)
        cells = [f"{lv:.0e}", brief(d), brief(dp)]
        cells += [brief(cheapest([r for r in comp if r["tool"] == t], "error", lv)) for t in tools]
        f1, f2 = factor(best, d), factor(best, dp)
        cells += [fmt_factor(f1), fmt_factor(f2), brief(cheapest(py, "error", lv))]
        out.append("| " + " | ".join(cells) + " |")
        summary.append(
            f"| {sc} error ≤ {lv:.0e} | dirac cheapest faster than every compiled peer | "
            f"{fmt_factor(f1)} (w/o affine {fmt_factor(f2)}) | "
            f"{verdict(f1 > 1 if finite(f1) else None)} "
            f"(w/o affine: {verdict(f2 > 1 if finite(f2) else None)}) |"
        )
    return out


def flatness(d: list[float] | None) -> float:
    if not d or not finite(d[0]) or d[0] <= 0:
        return math.nan
    return d[-1] / d[0]


def targets_long(sc: str, rows: list[dict], drift: dict, summary: list[str]) -> list[str]:
    """Issue 15, D2-long and E: cheapest run with max energy error ≤ LEVEL_LONG, its drift factor
    (running max at t_end over that at t_end/10) and, for D2-long, its θ₁ phase error."""
    key = "energy_error"
    head = ["tool", "cheapest run with energy error ≤ 1e-10", "wall_s", "energy error",
            "running max t_end / t_end/10"]
    if sc == "D2-long":
        head.append("θ₁ phase error at 1e4")
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    ours = cheapest([r for r in rows if r["tool"] == OURS], key, LEVEL_LONG)
    best = cheapest(compiled(rows), key, LEVEL_LONG)
    for tool in [OURS] + sorted({r["tool"] for r in rows if r["tool"] != OURS}):
        for method in sorted({r["method"] for r in rows if r["tool"] == tool}):
            r = cheapest([x for x in rows if x["tool"] == tool and x["method"] == method], key,
                         LEVEL_LONG)
            if r is None:
                continue
            cells = [tool, f"{method} @ {r['setting']}", f"{r['wall_s']:.3g}", f"{r[key]:.2g}",
                     fmt_factor(flatness(drift_of(drift, r)))]
            if sc == "D2-long":
                cells.append(f"{r['error']:.2g}")
            out.append("| " + " | ".join(cells) + " |")
    f = factor(best, ours)
    flat = flatness(drift_of(drift, ours)) if ours else math.nan
    out += ["", f"Cheapest dirac: {brief(ours, key)}; cheapest compiled peer: {brief(best, key)}; "
            f"ratio {fmt_factor(f)}; dirac's drift factor {fmt_factor(flat)} "
            f"(flat: ≤ {FLAT_FACTOR:g})."]
    if sc == "E":
        out += ["", "SciMLBenchmarks' published table (another machine, Julia): " + "; ".join(
            f"{n} {e:.1e} in {w} s" for n, e, w in E_PUBLISHED) + "."]
    ok = None
    if ours is not None and best is not None:
        ok = f > 1 and flat <= FLAT_FACTOR
    elif ours is None:
        ok = False
    summary.append(
        f"| {sc} energy ≤ 1e-10 | dirac cheaper than every compiled peer, no drift | "
        f"{fmt_factor(f)}, drift factor {fmt_factor(flat)} | {verdict(ok)} |"
    )
    return out


def targets_c(rows_c: list[dict], rows_acc: list[dict], summary: list[str]) -> list[str]:
    """Issue 15, C: ≥ 10× below ngspice, below the best compiled peer at equal accuracy, exponent."""
    out = []
    ours = {c_sections(r): r for r in rows_c if r["tool"] == OURS}
    ng = {c_sections(r): r for r in rows_c if r["tool"] == "ngspice"}
    head = ["N", "dirac µs/step/section", "ngspice / dirac", "midpoint h = 0.01 whole solve (error at t = 10)",
            "cheapest dirac run with error ≤ the midpoint run's",
            "cheapest compiled peer with error ≤ the midpoint run's", "compiled / dirac cheapest",
            "cheapest ngspice run with error ≤ the midpoint run's", "ngspice / dirac cheapest"]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    worst_ng, worst_c, worst_ng_acc = math.inf, math.inf, math.inf
    for n in sorted(set(ours) | {c_sections_acc(r) for r in rows_acc}):
        if not finite(n):
            continue
        d, g = ours.get(n), ng.get(n)
        acc = [r for r in rows_acc if c_sections_acc(r) == n]
        # The level is the scene's own configuration (midpoint, h = 0.01); dirac's cheapest run
        # at or below it may be another method at a longer step.
        da = next((r for r in acc if r["tool"] == OURS and r["method"] == "midpoint"
                   and num(r["setting"]) == 0.01), None)
        db = cheapest([r for r in acc if r["tool"] == OURS], "error", da["error"]) if da else None
        pa = cheapest(compiled(acc), "error", da["error"]) if da else None
        ga = cheapest([r for r in acc if r["tool"] == "ngspice"], "error", da["error"]) if da else None
        f_ng = g["error"] / d["error"] if d and g and d["error"] > 0 else math.nan
        f_c = factor(pa, db)
        f_ng_acc = factor(ga, db)
        if n >= 1e3 and finite(f_ng):
            worst_ng = min(worst_ng, f_ng)
        if n >= 1e3 and finite(f_ng_acc):
            worst_ng_acc = min(worst_ng_acc, f_ng_acc)
        if finite(f_c):
            worst_c = min(worst_c, f_c)
        out.append("| " + " | ".join([
            f"{int(n)}", f"{d['error']:.3g}" if d else NOT_REACHED, fmt_factor(f_ng),
            f"{da['wall_s']:.3g} s ({da['error']:.2g})" if da else NOT_REACHED,
            brief(db), brief(pa), fmt_factor(f_c), brief(ga), fmt_factor(f_ng_acc)]) + " |")
    pts = [(c_sections(r), r["wall_s"]) for r in rows_c if r["tool"] == OURS]
    expo = fit_exponent(pts)
    summary.append(f"| C ladders | ≥ 10× below ngspice (N ≥ 1e3), same steps (h = 0.01, µs per step) | "
                   f"worst {fmt_factor(worst_ng)} | {verdict(worst_ng >= 10 if finite(worst_ng) else None)} |")
    summary.append(f"| C ladders | ≥ 10× below ngspice (N = 1e3, 1e4) at equal accuracy (cheapest runs "
                   f"at the midpoint run's error) | worst {fmt_factor(worst_ng_acc)} | "
                   f"{verdict(worst_ng_acc >= 10 if finite(worst_ng_acc) else None)} |")
    summary.append(f"| C ladders | below the best compiled peer at equal accuracy | worst "
                   f"{fmt_factor(worst_c)} | {verdict(worst_c > 1 if finite(worst_c) else None)} |")
    try:
        e = float(expo.split()[0])
    except (ValueError, IndexError):
        e = math.nan
    summary.append(f"| C ladders | cost exponent ≤ 1.05 | {expo} | "
                   f"{verdict(e <= 1.05 if finite(e) else None)} |")
    return out


def targets_f(rows: list[dict], summary: list[str]) -> list[str]:
    """Issue 15, F: dirac's whole run < 3.88 s and solve < 0.107 s at the accuracy Rodas5's
    defaults give (rtol 1e-3, atol 1e-6), estimated by the compiled L-stable peers there."""
    solve = [r for r in rows if r["scene"] == "F"]
    whole = {(r["method"], r["setting"]): r for r in rows if r["scene"] == "F-whole" and r["tool"] == OURS}
    proxies = [r for r in compiled(solve) if r["setting"] in ("1e-3", "1e-03", "0.001")]
    out = ["Rodas5-default accuracy, estimated by the compiled stiff peers at rtol = 1e-3, "
           "atol = 1e-6 (max |v(10) − exact|):", ""]
    out += [f"- {r['tool']} {r['method']}: {r['error']:.2g} in {r['wall_s']:.3g} s" for r in proxies]
    level = max((r["error"] for r in proxies if finite(r["error"])), default=math.nan)
    out += ["", f"Target accuracy (the least accurate of these): {level:.2g}.", ""]
    head = ["dirac method", "h", "error at t = 10", "solve [s]", "whole run [s]"]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in sorted((r for r in solve if r["tool"] == OURS), key=lambda r: (r["method"], -num(r["setting"]))):
        w = whole.get((r["method"], r["setting"]))
        out.append(f"| {r['method']} | {r['setting']} | {r['error']:.3g} | {r['wall_s']:.3g} | "
                   f"{w['wall_s']:.3g} |" if w else f"| {r['method']} | {r['setting']} | "
                   f"{r['error']:.3g} | {r['wall_s']:.3g} | – |")
    ours = cheapest([r for r in solve if r["tool"] == OURS], "error", level) if finite(level) else None
    best_ours = min((r for r in solve if r["tool"] == OURS and finite(r["error"])),
                    key=lambda r: r["error"], default=None)
    best_peer = cheapest(compiled(solve), "error", level) if finite(level) else None
    out += ["", f"Cheapest compiled peer at that accuracy: {brief(best_peer)}. Published "
            f"(another machine): whole {F_PUBLISHED_WHOLE_S} s, solve {F_PUBLISHED_SOLVE_S} s."]
    if ours is None:
        miss = (f"dirac's most accurate run reaches {best_ours['error']:.2g} "
                f"({best_ours['method']} @ {best_ours['setting']}), "
                f"{best_ours['error'] / level:.3g}× the target error" if best_ours else NOT_REACHED)
        summary.append(f"| F n = 1000 | whole < {F_PUBLISHED_WHOLE_S} s and solve < "
                       f"{F_PUBLISHED_SOLVE_S} s at Rodas5-default accuracy | accuracy not reached: "
                       f"{miss} | **missed** |")
    else:
        w = whole.get((ours["method"], ours["setting"]))
        ok = ours["wall_s"] < F_PUBLISHED_SOLVE_S and w is not None and w["wall_s"] < F_PUBLISHED_WHOLE_S
        summary.append(f"| F n = 1000 | whole < {F_PUBLISHED_WHOLE_S} s and solve < "
                       f"{F_PUBLISHED_SOLVE_S} s at Rodas5-default accuracy | solve "
                       f"{ours['wall_s']:.3g} s, whole {w['wall_s'] if w else math.nan:.3g} s | {verdict(ok)} |")
    return out


def targets_cli(rows: list[dict], rows_c: list[dict], summary: list[str]) -> list[str]:
    """Issue 15, CLI: `dirac run` as a child process against the library doing the same in-process,
    with the bare process start-up (`dirac --version`) beside it; for the ladders also scene C's
    step loop on the section-model graph at the same N (the issue's "through the library")."""
    head = ["netlist", "steps", "library [s]", "dirac run [s]", "process start-up [s]",
            "dirac run / library", "(dirac run − start-up) / library",
            "µs per step (per section): library, dirac run",
            "scene C step loop µs/step/section (dirac run / it)"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for sc in sorted({r["scene"] for r in rows}, key=lambda x: (len(x), x)):
        by = {r["method"]: r for r in rows if r["scene"] == sc and r["tool"] == OURS}
        lib, run, start = by.get("library"), by.get("dirac-run"), by.get("process-start")
        if lib is None or run is None:
            continue
        f = run["wall_s"] / lib["wall_s"]
        net = (run["wall_s"] - start["wall_s"]) / lib["wall_s"] if start else math.nan
        c = next((r for r in rows_c if r["tool"] == OURS and sc.startswith("CLI-ladder-")
                  and c_sections(r) == num(sc[len("CLI-ladder-"):])), None)
        loop = f"{c['error']:.3g} ({run['error'] / c['error']:.3g}×)" if c else "–"
        out.append("| " + " | ".join([
            sc[4:], f"{int(run['steps'])}", f"{lib['wall_s']:.3g}", f"{run['wall_s']:.3g}",
            f"{start['wall_s']:.3g}" if start else "–", fmt_factor(f), fmt_factor(net),
            f"{lib['error']:.3g}, {run['error']:.3g}", loop]) + " |")
        summary.append(f"| CLI {sc[4:]} | `dirac run` within {CLI_FACTOR}× of the library path | "
                       f"{fmt_factor(f)}× (without process start-up {fmt_factor(net)}×) | "
                       f"{verdict(f <= CLI_FACTOR)} |")
    return out


def issue15_md(by_scene: dict[str, list[dict]], drift: dict) -> list[str]:
    summary = ["| scene | target | measured ratio (peer time / dirac time) or figure | verdict |",
               "|---|---|---|---|"]
    body = []
    for sc in ("A", "B"):
        body += [f"### {sc}: cheapest run per tool at each error level (time, error)", ""]
        body += targets_ab(sc, by_scene.get(sc, []), summary) + [""]
    for sc in ("D2-long", "E"):
        body += [f"### {sc}: max energy error ≤ 1e-10 over [0, 1e4]", ""]
        body += targets_long(sc, by_scene.get(sc, []), drift, summary) + [""]
    body += ["### C: ladders against ngspice and the compiled peers", ""]
    body += targets_c(by_scene.get("C", []), by_scene.get("Cacc", []), summary) + [""]
    body += ["### F: the SciMLBenchmarks RC ladder, n = 1000", ""]
    body += targets_f(by_scene.get("F", []), summary) + [""]
    body += ["### CLI: `dirac run` against the library path (same netlist, same signals)", ""]
    body += targets_cli(by_scene.get("CLI", []), by_scene.get("C", []), summary) + [""]
    return ["## Issue 15 targets (one run)", ""] + summary + [""] + body


def ratios_md(by_scene: dict[str, list[dict]], notes: list[str], drift: dict | None = None) -> str:
    md = ["# Benchmark ratios", ""]
    md.append(
        "Times are in-process wall times of the solve (best of 3 repetitions, 1 above 2 s, and best "
        "over run.sh's interleaved rounds for dirac and the compiled peers); ngspice: its own "
        "transient analysis time; CLI: whole child processes. dirac runs through the run layer "
        "(dirac_sim::Simulation). Ratio > 1: the peer is slower than dirac."
    )
    md.append("")
    md += issue15_md(by_scene, drift or {})
    md += ["## Issue 7 tables (all peers, Python baselines included)", ""]
    for sc in ("A", "B"):
        md += [f"## {sc}: cheapest run with error ≤ level", ""]
        md += table_levels(by_scene.get(sc, []), LEVELS_AB, "error")
        md.append("")
    md += [f"## D2: cheapest run with energy error ≤ {LEVEL_D2:.0e}", ""]
    md += table_levels(by_scene.get("D2", []), [LEVEL_D2], "energy_error")
    md.append("")
    md += [
        f"## D1: dirac runs with h ≥ 10 × fast period ({D1_MIN_H:.4g}) and the cheapest peer "
        "reaching the same slow-mode error",
        "",
    ]
    md += table_d1(by_scene.get("D1", []))
    md.append("")
    md.append(
        "The D1 reference takes the normal modes from the SVD of diag(√k)·D (frequencies good to "
        "~1e-12 relative), so slow-mode errors down to ~1e-11 are resolved (SCENES.md)."
    )
    md.append("")
    md += ["## C: RLC ladder, µs per step per section", ""]
    md += table_c(by_scene.get("C", []))
    md.append("")
    if notes:
        md += ["## Notes from the runs", ""]
        md += [f"- {n}" for n in notes]
        md.append("")
    return "\n".join(md)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv", nargs="+", help="benchmark CSV files")
    ap.add_argument("--outdir", default=".", help="where figures and ratios.md go")
    args = ap.parse_args(argv)
    os.makedirs(args.outdir, exist_ok=True)

    paths = [p for p in args.csv if os.path.exists(p) and not p.endswith(".drift.csv")]
    for p in args.csv:
        if p not in paths:
            print(f"plot.py: {p} does not exist, skipped", file=sys.stderr)
    rows = read_rows(paths)
    by_scene: dict[str, list[dict]] = defaultdict(list)
    for r in rows:
        by_scene[scene_key(r["scene"])].append(r)

    notes = []
    for p in paths:
        base = p[:-4] if p.endswith(".csv") else p
        nf = base + ".notes.txt"
        if os.path.exists(nf):
            with open(nf) as fh:
                notes += [f"{os.path.basename(p)}: {ln.strip()}" for ln in fh if ln.strip()]

    drift_paths = [p[:-4] + ".drift.csv" for p in paths if p.endswith(".csv")]
    drift = read_drift([p for p in drift_paths if os.path.exists(p)])
    written = figures(by_scene, args.outdir)
    written += drift_figure(by_scene, drift, args.outdir)
    md = ratios_md(by_scene, notes, drift)
    rp = os.path.join(args.outdir, "ratios.md")
    with open(rp, "w") as fh:
        fh.write(md)
    written.append(rp)
    print(f"plot.py: {len(rows)} rows from {len(paths)} files; wrote {', '.join(written)}",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
