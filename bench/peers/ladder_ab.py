#!/usr/bin/env python3
"""Netlist RLC ladders, two dirac builds side by side (audit item 16):

    nice -n 19 bench/peers/ladder_ab.py BEFORE_DIRAC AFTER_DIRAC RLC_LADDER [SECTIONS ...]

(sections default 1000 100000; RLC_LADDER the binary of `cargo build --release --example
rlc_ladder`, the section-model graph of scene C).

For each ladder size N (the netlist of examples/gen_ladder.rs: series R = 0.1, L = 1, shunt C = 1,
1 V DC source, h = 0.01) and each binary, `dirac run --signals q(cN)` (a charge: no readout at the
rows, so a row costs its step alone) for S1 and S2 steps (1000 and 2000 at N < 10^4, 20 and
220 above). Runs alternate before/after over ROUNDS rounds (environment, default 3); for each binary
and step count the least CPU time of the process (user + system, from wait4) is kept, and the cost
per step and section is (cpu(S2) - cpu(S1)) / ((S2 - S1) N), so parsing, building and set-up
cancel. CPU time rather than wall time: on a shared machine (and under nice) a process's wall time
measures the scheduler as much as the process. Peak RSS (ru_maxrss) of the S2 run. The
section-model graph of the same size (examples/rlc_ladder.rs: one shared section model per
section, driven through the integrator) is measured the same way in the same rounds. Prints a
Markdown table. With SIGNAL='v(n{n})' the netlist runs record the last node's potential
instead (a readout at every row, as `dirac run --signals 'v(nN)'`). Not part of CI (timings).
"""

import json
import os
import subprocess
import sys
import tempfile


# The recorded signal (environment SIGNAL, `{n}` the size): a charge by default; `v(n{n})`, a
# node potential, makes every row solve the readout.
SIGNAL = os.environ.get("SIGNAL", "q(c{n})")


def netlist(n: int) -> str:
    lines = [f"RLC ladder of {n} sections (R = 0.1, L = 1, C = 1), 1 V DC source", "V1 n0 0 DC 1"]
    for k in range(1, n + 1):
        lines += [f"R{k} n{k - 1} m{k} 0.1", f"L{k} m{k} n{k} 1", f"C{k} n{k} 0 1"]
    lines += [".tran 0.01 10 uic", ".end", ""]
    return "\n".join(lines)


def timed(cmd: list[str]) -> tuple[str, float, int]:
    """stderr of `cmd`, its CPU time (user + system, s) and its peak RSS (KiB)."""
    with tempfile.TemporaryFile(mode="w+") as err:
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        text = err.read()
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {text}")
    return text, usage.ru_utime + usage.ru_stime, usage.ru_maxrss


def run(binary: str, cir: str, n: int, steps: int, tmp: str) -> tuple[float, int]:
    err, cpu, rss = timed(
        [binary, "run", cir, "--quiet", "--signals", SIGNAL.format(n=n), "--t-end", repr(steps * 0.01),
         "--json-summary", "--out", os.path.join(tmp, "out.csv")]
    )
    summary = json.loads(err.strip().splitlines()[-1])
    assert summary["steps"] == steps, summary
    return cpu, rss


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    binaries = {"before": argv[0], "after": argv[1]}
    ladder = argv[2]
    sizes = [int(a) for a in argv[3:]] or [1000, 100_000]
    rounds = int(os.environ.get("ROUNDS", "3"))
    print("| sections | build | µs per step per section | peak RSS, MiB |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            cir = os.path.join(tmp, "ladder.cir")
            with open(cir, "w") as fh:
                fh.write(netlist(n))
            s1, s2 = (1000, 2000) if n < 10_000 else (20, 220)
            best: dict[tuple[str, int], float] = {}
            peak: dict[str, int] = {}
            for _ in range(rounds):
                for side, binary in binaries.items():
                    for steps in (s1, s2):
                        cpu, rss = run(binary, cir, n, steps, tmp)
                        key = (side, steps)
                        best[key] = min(best.get(key, float("inf")), cpu)
                        if steps == s2:
                            peak[side] = max(peak.get(side, 0), rss)
                for steps in (s1, s2):
                    _, cpu, rss = timed([ladder, "--sections", str(n), "--steps", str(steps)])
                    key = ("graph", steps)
                    best[key] = min(best.get(key, float("inf")), cpu)
                    if steps == s2:
                        peak["graph"] = max(peak.get("graph", 0), rss)
            labels = {"before": "netlist, before", "after": "netlist, after",
                      "graph": "section-model graph (scene C)"}
            for side, label in labels.items():
                cost = (best[(side, s2)] - best[(side, s1)]) / ((s2 - s1) * n) * 1e6
                print(f"| {n} | {label} | {cost:.3f} | {peak[side] / 1024:.0f} |")
            sys.stdout.flush()
    with open("/proc/loadavg") as fh:
        print(f"(load average {' '.join(fh.read().split()[:3])})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
