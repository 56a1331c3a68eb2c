#!/usr/bin/env python3
"""Fixed cost and cost per step of dirac's runs, two builds side by side (fixed_cost.sh):

    fixed_cost.py DIR MAX_STEPS

reads DIR/{before,after}_{A,B}.csv (`dirac bench` rows) and, per scene and method, fits
wall_s = fixed + per_step * steps by least squares over the runs of at most MAX_STEPS steps.
Prints a Markdown table (µs) with the ratio before/after of the fixed cost.
"""

import csv
import sys


def fit(points: list[tuple[float, float]]) -> tuple[float, float]:
    n = len(points)
    sx = sum(x for x, _ in points)
    sy = sum(y for _, y in points)
    sxx = sum(x * x for x, _ in points)
    sxy = sum(x * y for x, y in points)
    slope = (n * sxy - sx * sy) / (n * sxx - sx * sx)
    return (sy - slope * sx) / n, slope


def load(path: str, max_steps: int) -> dict[str, list[tuple[float, float]]]:
    out: dict[str, list[tuple[float, float]]] = {}
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            steps = int(row["steps"])
            if steps <= max_steps:
                out.setdefault(row["method"], []).append((steps, float(row["wall_s"])))
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder, max_steps = argv[0], int(argv[1])
    print(f"| scene | method | fixed before, µs | fixed after, µs | ratio | per step before, µs | per step after, µs |")
    print("|---|---|---|---|---|---|---|")
    for scene in ("A", "B"):
        before = load(f"{folder}/before_{scene}.csv", max_steps)
        after = load(f"{folder}/after_{scene}.csv", max_steps)
        for method in before:
            if method not in after or len(before[method]) < 2 or len(after[method]) < 2:
                continue
            fb, sb = fit(before[method])
            fa, sa = fit(after[method])
            print(
                f"| {scene} | {method} | {fb * 1e6:.1f} | {fa * 1e6:.1f} | {fb / fa:.2f} "
                f"| {sb * 1e6:.3f} | {sa * 1e6:.3f} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
