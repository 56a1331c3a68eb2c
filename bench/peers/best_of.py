#!/usr/bin/env python3
"""Merges the rounds of one tool on one scene (bench/peers/run.sh runs dirac and the compiled peers
ROUNDS times, interleaved) into one results CSV:

    best_of.py OUT.csv ROUND1.csv ROUND2.csv ...

A run is identified by (scene, tool, method, setting); the merged row is the round with the least
wall time (best of N over the rounds, on top of each tool's own best of repetitions). The other
columns are the same in every round up to that choice (fixed steps or deterministic adaptive
runs). Runs that only some rounds reached (a sweep cut short by its time limit) are kept. The
`.drift.csv` side files are merged by the same key (first round that has the run); the
`.notes.txt` files are concatenated with their round named.
"""

import csv
import os
import sys

KEY = ("scene", "tool", "method", "setting")


def side(path: str, suffix: str) -> str:
    return (path[:-4] if path.endswith(".csv") else path) + suffix


def read(path: str) -> tuple[list[str], list[dict]]:
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        return list(reader.fieldnames or []), list(reader)


def wall(row: dict) -> float:
    try:
        return float(row["wall_s"])
    except (KeyError, ValueError):
        return float("inf")


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    out, rounds = argv[0], argv[1:]
    header: list[str] = []
    best: dict[tuple, dict] = {}
    order: list[tuple] = []
    for path in rounds:
        fields, rows = read(path)
        header = header or fields
        for row in rows:
            key = tuple(row[k] for k in KEY)
            if key not in best:
                order.append(key)
                best[key] = row
            elif wall(row) < wall(best[key]):
                best[key] = row
    with open(out, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=header, lineterminator="\n")
        writer.writeheader()
        for key in order:
            writer.writerow(best[key])

    drift_header: list[str] = []
    drift: dict[tuple, dict] = {}
    drift_order: list[tuple] = []
    notes: list[str] = []
    for r, path in enumerate(rounds, start=1):
        d = side(path, ".drift.csv")
        if os.path.exists(d):
            fields, rows = read(d)
            drift_header = drift_header or fields
            for row in rows:
                key = tuple(row[k] for k in KEY)
                if key not in drift:
                    drift[key] = row
                    drift_order.append(key)
        n = side(path, ".notes.txt")
        if os.path.exists(n):
            with open(n) as fh:
                notes += [f"round {r}: {line.rstrip()}" for line in fh if line.strip()]
    if drift_order:
        with open(side(out, ".drift.csv"), "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=drift_header, lineterminator="\n")
            writer.writeheader()
            for key in drift_order:
                writer.writerow(drift[key])
    if notes:
        with open(side(out, ".notes.txt"), "w") as fh:
            fh.write("\n".join(notes) + "\n")
    print(f"best_of.py: {len(order)} runs from {len(rounds)} round(s) -> {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
