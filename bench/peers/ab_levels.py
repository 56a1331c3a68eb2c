#!/usr/bin/env python3
"""Cheapest run reaching each error level, dirac against the compiled peers (ab_levels.sh):

    ab_levels.py DIR

reads DIR/{dirac,compiled}_{A,B}.csv and prints a Markdown table: per scene and level (1e-3,
1e-6, 1e-9) dirac's cheapest run (any method), its cheapest without the affine map, the best
compiled peer's cheapest, and the ratio peer / dirac (> 1: dirac faster).
"""

import csv
import sys

LEVELS = (1e-3, 1e-6, 1e-9)


def rows(path: str) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def cheapest(runs: list[dict], level: float, keep=lambda r: True) -> dict | None:
    ok = [r for r in runs if keep(r) and float(r["error"]) <= level]
    return min(ok, key=lambda r: float(r["wall_s"]), default=None)


def show(r: dict | None) -> str:
    if r is None:
        return "none"
    return (f"{r['tool']} {r['method']} {r['setting']}: {float(r['wall_s']) * 1e6:.1f} µs "
            f"({float(r['error']):.1e})")


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    folder = argv[0]
    print("| scene, level | dirac cheapest | dirac without affine map | best compiled peer | ratio (w/o affine) |")
    print("|---|---|---|---|---|")
    for scene in ("A", "B"):
        dirac = rows(f"{folder}/dirac_{scene}.csv")
        peers = rows(f"{folder}/compiled_{scene}.csv")
        for level in LEVELS:
            d = cheapest(dirac, level)
            n = cheapest(dirac, level, lambda r: not r["method"].endswith("-affine"))
            p = cheapest(peers, level)
            ratio = (
                f"**{float(p['wall_s']) / float(d['wall_s']):.2f}** "
                f"({float(p['wall_s']) / float(n['wall_s']):.2f})"
                if d and n and p
                else "-"
            )
            print(f"| {scene}, {level:.0e} | {show(d)} | {show(n)} | {show(p)} | {ratio} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
