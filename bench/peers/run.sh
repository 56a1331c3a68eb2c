#!/usr/bin/env bash
# One command for the whole speed-vs-error benchmark (bench/SCENES.md):
#   bench/peers/run.sh [--quick] [--results DIR]
# installs the pinned Python requirements, builds dirac, runs `dirac bench` and the peers on every
# scene, then draws the work-precision diagrams and writes ratios.md (printed at the end).
# Environment: PYTHON (default python3), SECTIONS (scene C ladder sizes), SCENES (default "A B D1 D2 C").
set -uo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT"

QUICK=""
RESULTS="bench/results"
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) QUICK="--quick" ;;
    --results) RESULTS="$2"; shift ;;
    -h|--help) sed -n '2,6p' "$0"; exit 0 ;;
    *) echo "run.sh: unknown argument '$1' (use --quick, --results DIR)" >&2; exit 2 ;;
  esac
  shift
done

PY="${PYTHON:-python3}"
SCENES="${SCENES:-A B D1 D2 C}"
if [ -n "$QUICK" ]; then
  SECTIONS="${SECTIONS:-10,100,1000}"
else
  SECTIONS="${SECTIONS:-10,100,1000,10000,100000}"
fi
mkdir -p "$RESULTS"
T0=$(date +%s)

echo "== installing Python requirements (bench/peers/requirements.txt)"
if ! "$PY" -m pip install -q --disable-pip-version-check -r bench/peers/requirements.txt; then
  echo "run.sh: pip install failed" >&2
  exit 1
fi

echo "== building dirac (cargo build --release -p dirac-cli)"
cargo build --release -p dirac-cli || { echo "run.sh: cargo build failed" >&2; exit 1; }
DIRAC="$ROOT/target/release/dirac"

# dirac bench for one scene, written atomically by `dirac bench --out`.
dirac_scene() {
  local s="$1" extra=()
  [ "$s" = "C" ] && extra=(--sections "$SECTIONS")
  "$DIRAC" bench --scene "$s" --out "$RESULTS/dirac_$s.csv" $QUICK "${extra[@]}" \
    || { echo "run.sh: 'dirac bench --scene $s' failed" >&2; exit 1; }
}

for S in $SCENES; do
  echo "== scene $S"
  t=$(date +%s)
  dirac_scene "$S"
  echo "   dirac: $(( $(date +%s) - t )) s"
  t=$(date +%s)
  if [ "$S" = "C" ]; then
    "$PY" bench/peers/peers.py --scene C --sections "$SECTIONS" --out "$RESULTS/peers_C.csv" $QUICK \
      || echo "run.sh: WARNING: peers failed on scene C" >&2
  else
    "$PY" bench/peers/peers.py --scene "$S" --out "$RESULTS/peers_$S.csv" $QUICK \
      || echo "run.sh: WARNING: peers failed on scene $S" >&2
  fi
  echo "   peers: $(( $(date +%s) - t )) s"
done

echo "== plots and ratio tables"
CSVS=()
for S in $SCENES; do
  for f in "$RESULTS/dirac_$S.csv" "$RESULTS/peers_$S.csv"; do
    [ -f "$f" ] && CSVS+=("$f")
  done
done
if [ ${#CSVS[@]} -eq 0 ]; then
  echo "run.sh: no results to plot" >&2
  exit 1
fi
"$PY" bench/peers/plot.py "${CSVS[@]}" --outdir "$RESULTS" || { echo "run.sh: plot.py failed" >&2; exit 1; }

echo
cat "$RESULTS/ratios.md"
echo
echo "== done in $(( $(date +%s) - T0 )) s; results in $RESULTS/"
