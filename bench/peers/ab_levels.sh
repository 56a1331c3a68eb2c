#!/usr/bin/env bash
# Scenes A and B at errors 1e-3, 1e-6, 1e-9: dirac's cheapest run against the compiled peers',
# measured in one session (issue 15's first target):
#   bench/peers/ab_levels.sh DIRAC COMPILED_PEERS [OUT_DIR]
# runs `dirac bench --scene A|B` and `compiled-peers --scene A|B` alternately over ROUNDS rounds
# (default 3), keeps each run's best wall time (best_of.py) and prints, per scene and level, the
# cheapest run of each side that reaches it (ab_levels.py). COMPILED_PEERS is the binary that
# bench/peers/run.sh builds (bench/compiled/target/release/compiled-peers). Not part of CI.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
DIRAC="$1"; COMPILED="$2"; OUT="${3:-$(mktemp -d)}"
ROUNDS="${ROUNDS:-3}"
mkdir -p "$OUT"
for r in $(seq 1 "$ROUNDS"); do
  for scene in A B; do
    "$DIRAC" bench --scene "$scene" --out "$OUT/dirac_${scene}_$r.csv"
    "$COMPILED" --scene "$scene" --out "$OUT/compiled_${scene}_$r.csv"
  done
  echo "round $r done (load $(cut -d' ' -f1-3 /proc/loadavg))" >&2
done
for tool in dirac compiled; do
  for scene in A B; do
    python3 "$ROOT/bench/peers/best_of.py" "$OUT/${tool}_$scene.csv" "$OUT/${tool}_${scene}"_[0-9]*.csv
  done
done
python3 "$ROOT/bench/peers/ab_levels.py" "$OUT"
