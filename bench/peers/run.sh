#!/usr/bin/env bash
# One command for the whole speed-vs-error benchmark (bench/SCENES.md, issues 7 and 15):
#   bench/peers/run.sh [--quick] [--results DIR]
# installs what it needs (Debian's libsundials-dev, the pinned Python requirements), builds dirac
# and the compiled peers (bench/compiled), runs `dirac bench`, the compiled peers and the Python
# peers on every scene, then draws the work-precision diagrams and writes ratios.md (printed).
# Environment: PYTHON (default python3), SECTIONS (scene C ladder sizes),
# SCENES (default "A B D1 D2 D2-long E F C"), SKIP_INSTALL=1 (no apt/pip), PY_PEERS=0 (skip the
# Python baselines and ngspice).
set -uo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT"

QUICK=""
RESULTS="bench/results"
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) QUICK="--quick" ;;
    --results) RESULTS="$2"; shift ;;
    -h|--help) sed -n '2,8p' "$0"; exit 0 ;;
    *) echo "run.sh: unknown argument '$1' (use --quick, --results DIR)" >&2; exit 2 ;;
  esac
  shift
done

PY="${PYTHON:-python3}"
SCENES="${SCENES:-A B D1 D2 D2-long E F C}"
if [ -n "$QUICK" ]; then
  SECTIONS="${SECTIONS:-10,100,1000}"
else
  SECTIONS="${SECTIONS:-10,100,1000,10000,100000}"
fi
mkdir -p "$RESULTS"
T0=$(date +%s)

if [ "${SKIP_INSTALL:-0}" != 1 ]; then
  # SUNDIALS 6 for the C peers, from Debian (headers, CVODE/ARKODE/IDA, dense/band/KLU solvers).
  if [ ! -f /usr/include/cvode/cvode.h ]; then
    echo "== installing libsundials-dev (apt)"
    SUDO=""
    [ "$(id -u)" != 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq && $SUDO apt-get install -y -qq --no-install-recommends libsundials-dev \
      || { echo "run.sh: apt-get install libsundials-dev failed" >&2; exit 1; }
  fi
  echo "== installing Python requirements (bench/peers/requirements.txt)"
  "$PY" -m pip install -q --disable-pip-version-check -r bench/peers/requirements.txt \
    || { echo "run.sh: pip install failed" >&2; exit 1; }
fi

echo "== building dirac (cargo build --release -p dirac-cli)"
cargo build --release -p dirac-cli || { echo "run.sh: cargo build failed" >&2; exit 1; }
DIRAC="$ROOT/target/release/dirac"
echo "== building the compiled peers (bench/compiled, its own workspace and lock file)"
cargo build --release --locked --manifest-path bench/compiled/Cargo.toml \
  || { echo "run.sh: building bench/compiled failed" >&2; exit 1; }
COMPILED="$ROOT/bench/compiled/target/release/compiled-peers"

for S in $SCENES; do
  echo "== scene $S"
  extra=()
  [ "$S" = "C" ] && extra=(--sections "$SECTIONS")
  t=$(date +%s)
  "$DIRAC" bench --scene "$S" --out "$RESULTS/dirac_$S.csv" $QUICK "${extra[@]}" \
    || { echo "run.sh: 'dirac bench --scene $S' failed" >&2; exit 1; }
  echo "   dirac: $(( $(date +%s) - t )) s"
  t=$(date +%s)
  "$COMPILED" --scene "$S" --out "$RESULTS/compiled_$S.csv" $QUICK "${extra[@]}" \
    || echo "run.sh: WARNING: compiled peers failed on scene $S" >&2
  echo "   compiled peers: $(( $(date +%s) - t )) s"
  if [ "${PY_PEERS:-1}" != 0 ]; then
    t=$(date +%s)
    "$PY" bench/peers/peers.py --scene "$S" --out "$RESULTS/peers_$S.csv" $QUICK "${extra[@]}" \
      || echo "run.sh: WARNING: Python peers failed on scene $S" >&2
    echo "   Python peers and ngspice: $(( $(date +%s) - t )) s"
  fi
done

echo "== plots and ratio tables"
CSVS=()
for S in $SCENES; do
  for f in "$RESULTS/dirac_$S.csv" "$RESULTS/compiled_$S.csv" "$RESULTS/peers_$S.csv"; do
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
