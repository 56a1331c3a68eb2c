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
C_FIT_RANGE = (1e3, 1e5)
OURS = "dirac"
NOT_REACHED = "not reached"


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


def scene_key(scene: str) -> str:
    return "C" if scene.startswith("C-") or scene == "C" else scene


def c_sections(r: dict) -> float:
    n = num(r["setting"])
    if not finite(n) and r["scene"].startswith("C-"):
        n = num(r["scene"][2:])
    return n


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
}


def save(fig, outdir: str, stem: str) -> list[str]:
    paths = []
    for ext in ("png", "svg"):
        p = os.path.join(outdir, f"{stem}.{ext}")
        fig.savefig(p, dpi=130 if ext == "png" else None, bbox_inches="tight")
        paths.append(p)
    plt.close(fig)
    return paths


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


def ratios_md(by_scene: dict[str, list[dict]], notes: list[str]) -> str:
    md = ["# Benchmark ratios", ""]
    md.append(
        "Times are in-process wall times of the solve only (best of 3, best of 1 above 2 s); "
        "ngspice: its own transient analysis time. Ratio > 1: the peer is slower than dirac."
    )
    md.append("")
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

    paths = [p for p in args.csv if os.path.exists(p)]
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

    written = figures(by_scene, args.outdir)
    md = ratios_md(by_scene, notes)
    rp = os.path.join(args.outdir, "ratios.md")
    with open(rp, "w") as fh:
        fh.write(md)
    written.append(rp)
    print(f"plot.py: {len(rows)} rows from {len(paths)} files; wrote {', '.join(written)}",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
