#!/usr/bin/env bash
# The run layer's fixed cost (set-up) against its per-step cost, two dirac builds side by side:
#   bench/peers/fixed_cost.sh BEFORE_DIRAC AFTER_DIRAC [OUT_DIR]
# runs `dirac bench --scene A` and `--scene B` (the benchmark behind bench/results/dirac_A.csv and
# dirac_B.csv) with both binaries, interleaved over ROUNDS rounds (default 3: before, after,
# before, ...), keeps each run's best wall time over the rounds (best_of.py) and fits
# wall = fixed + per_step·steps per method over the runs of at most MAX_STEPS steps (default 3200;
# fixed_cost.py), printing one table. A "before" binary is built from an older commit with
#   git worktree add /tmp/before <commit> && (cd /tmp/before && cargo build --release -p dirac-cli)
# Not part of CI (wall times).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
BEFORE="$1"; AFTER="$2"; OUT="${3:-$(mktemp -d)}"
ROUNDS="${ROUNDS:-3}"
mkdir -p "$OUT"
for r in $(seq 1 "$ROUNDS"); do
  for scene in A B; do
    for side in before after; do
      bin="$BEFORE"; [ "$side" = after ] && bin="$AFTER"
      "$bin" bench --scene "$scene" --out "$OUT/${side}_${scene}_$r.csv"
    done
  done
  echo "round $r done (load $(cut -d' ' -f1-3 /proc/loadavg))" >&2
done
for side in before after; do
  for scene in A B; do
    python3 "$ROOT/bench/peers/best_of.py" "$OUT/${side}_$scene.csv" "$OUT/${side}_${scene}"_[0-9]*.csv
  done
done
python3 "$ROOT/bench/peers/fixed_cost.py" "$OUT" "${MAX_STEPS:-3200}"
