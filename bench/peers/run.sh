#!/usr/bin/env bash
# One command for the whole speed-vs-error benchmark (bench/SCENES.md, issues 7 and 15):
#   bench/peers/run.sh [--quick] [--results DIR]
# installs what it needs on Debian/Ubuntu (apt: SUNDIALS 6 headers and libraries, ngspice, a C
# compiler, python3-venv; rustup when cargo is missing; the pinned Python requirements in a venv
# bench/.venv unless the interpreter already has them), builds dirac and the compiled peers
# (bench/compiled), runs `dirac bench`, the compiled peers and the Python peers on every scene,
# then draws the work-precision diagrams and writes ratios.md (printed).
# dirac and the compiled peers run ROUNDS times, interleaved (dirac, peers, dirac, peers, ...);
# best_of.py keeps each run's best wall time over the rounds, so a load burst on a shared
# machine hits both sides alike. The load average before and after each tool goes to its
# <tool>_<scene>.notes.txt.
# Environment: PYTHON (default: python3 if it has the pinned packages, else bench/.venv),
# SECTIONS (scene C ladder sizes), SCENES (default "A B D1 D2 D2-long E F C CLI"),
# ROUNDS (default 2; --quick 1), SKIP_INSTALL=1 (no apt/pip), PY_PEERS=0 (skip the Python
# baselines and ngspice). Not part of CI: the CSV contract test (cargo test -p dirac-cli --test
# bench_csv) checks the committed results instead.
set -uo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT"

QUICK=""
RESULTS="bench/results"
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) QUICK="--quick" ;;
    --results) RESULTS="$2"; shift ;;
    -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
    *) echo "run.sh: unknown argument '$1' (use --quick, --results DIR)" >&2; exit 2 ;;
  esac
  shift
done

SCENES="${SCENES:-A B D1 D2 D2-long E F C CLI}"
if [ -n "$QUICK" ]; then
  SECTIONS="${SECTIONS:-10,100,1000}"
  ROUNDS="${ROUNDS:-1}"
else
  SECTIONS="${SECTIONS:-10,100,1000,10000,100000}"
  ROUNDS="${ROUNDS:-2}"
fi
mkdir -p "$RESULTS"
T0=$(date +%s)

# The pinned requirements, checked against what an interpreter has.
has_pinned() {
  "$1" - <<'PYEOF' 2>/dev/null
import importlib.metadata as m, re, sys
for line in open("bench/peers/requirements.txt"):
    line = line.split("#")[0].strip()
    if line:
        name, version = re.split(r"==", line)
        try:
            if m.version(name) != version:
                sys.exit(1)
        except m.PackageNotFoundError:
            sys.exit(1)
PYEOF
}

if [ "${SKIP_INSTALL:-0}" != 1 ]; then
  SUDO=""
  [ "$(id -u)" != 0 ] && SUDO="sudo"
  # SUNDIALS 6 for the C peers (headers, CVODE/ARKODE/IDA, dense/band/KLU solvers), ngspice for
  # scenes C and F, a C compiler for bench/compiled's build.rs, venv for the Python peers.
  missing=()
  for pkg in libsundials-dev ngspice build-essential pkg-config python3 python3-venv curl ca-certificates; do
    dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "== installing ${missing[*]} (apt)"
    $SUDO apt-get update -qq && $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" \
      || { echo "run.sh: apt-get install ${missing[*]} failed" >&2; exit 1; }
  fi
  if ! command -v cargo >/dev/null 2>&1; then
    echo "== installing Rust (rustup, stable toolchain)"
    curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal \
      || { echo "run.sh: rustup failed" >&2; exit 1; }
    # shellcheck disable=SC1091
    . "$HOME/.cargo/env"
  fi
  if [ -z "${PYTHON:-}" ] && ! has_pinned python3; then
    echo "== Python requirements into bench/.venv (bench/peers/requirements.txt)"
    [ -x bench/.venv/bin/python ] || python3 -m venv bench/.venv \
      || { echo "run.sh: python3 -m venv failed" >&2; exit 1; }
    bench/.venv/bin/python -m pip install -q --disable-pip-version-check -r bench/peers/requirements.txt \
      || { echo "run.sh: pip install failed" >&2; exit 1; }
    PYTHON="$ROOT/bench/.venv/bin/python"
  elif [ -n "${PYTHON:-}" ] && ! has_pinned "$PYTHON"; then
    echo "== installing Python requirements into $PYTHON"
    "$PYTHON" -m pip install -q --disable-pip-version-check -r bench/peers/requirements.txt \
      || { echo "run.sh: pip install failed" >&2; exit 1; }
  fi
fi
if [ -z "${PYTHON:-}" ] && [ -x bench/.venv/bin/python ] && ! has_pinned python3; then
  PYTHON="$ROOT/bench/.venv/bin/python"
fi
PY="${PYTHON:-python3}"

load() { cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo "unknown"; }

# Runs one tool ("$1": dirac or compiled) on scene "$2" into "$3", appending the load average
# before and after to the CSV's notes file.
run_tool() {
  local tool="$1" scene="$2" out="$3" notes before status t
  shift 3
  notes="${out%.csv}.notes.txt"
  before="$(load)"
  t=$(date +%s)
  if [ "$tool" = dirac ]; then
    rm -f "$notes"
    "$DIRAC" bench --scene "$scene" --out "$out" $QUICK "$@"
  else
    "$COMPILED" --scene "$scene" --out "$out" $QUICK "$@"
  fi
  status=$?
  echo "load average (1, 5, 15 min) before: $before; after: $(load); $(( $(date +%s) - t )) s; $(date -u +%FT%TZ)" >> "$notes"
  echo "   $tool: $(( $(date +%s) - t )) s (load before $before, after $(load))"
  return $status
}

echo "== building dirac (cargo build --release -p dirac-cli)"
cargo build --release -p dirac-cli || { echo "run.sh: cargo build failed" >&2; exit 1; }
DIRAC="$ROOT/target/release/dirac"
echo "== building the compiled peers (bench/compiled, its own workspace and lock file)"
cargo build --release --locked --manifest-path bench/compiled/Cargo.toml \
  || { echo "run.sh: building bench/compiled failed" >&2; exit 1; }
COMPILED="$ROOT/bench/compiled/target/release/compiled-peers"

ROUND_DIR="$RESULTS/rounds"
for S in $SCENES; do
  echo "== scene $S"
  extra=()
  [ "$S" = "C" ] && extra=(--sections "$SECTIONS")
  # dirac's CLI scene has no peers; every other scene has compiled peers.
  peers=1
  [ "$S" = "CLI" ] && peers=0
  # The Python baselines call Python per evaluation over t ∈ [0, 1e4]: minutes per run, so the
  # quick mode leaves them out on the long runs.
  py=1
  [ -n "$QUICK" ] && { [ "$S" = "D2-long" ] || [ "$S" = "E" ]; } && py=0
  rm -rf "$ROUND_DIR" && mkdir -p "$ROUND_DIR"
  for r in $(seq 1 "$ROUNDS"); do
    [ "$ROUNDS" -gt 1 ] && echo "  round $r of $ROUNDS"
    run_tool dirac "$S" "$ROUND_DIR/dirac_$S.r$r.csv" "${extra[@]}" \
      || { echo "run.sh: 'dirac bench --scene $S' failed" >&2; exit 1; }
    if [ $peers = 1 ]; then
      cextra=("${extra[@]}")
      # The compiled peers on C compare with dirac's accuracy rows, which stop at N = 1e4.
      [ "$S" = "C" ] && cextra=(--sections "$(echo "$SECTIONS" | tr , '\n' | awk '$1 <= 10000' | paste -sd,)")
      run_tool compiled "$S" "$ROUND_DIR/compiled_$S.r$r.csv" "${cextra[@]}" \
        || echo "run.sh: WARNING: compiled peers failed on scene $S" >&2
    fi
  done
  for tool in dirac compiled; do
    files=()
    for r in $(seq 1 "$ROUNDS"); do
      [ -f "$ROUND_DIR/${tool}_$S.r$r.csv" ] && files+=("$ROUND_DIR/${tool}_$S.r$r.csv")
    done
    [ ${#files[@]} -gt 0 ] || continue
    "$PY" bench/peers/best_of.py "$RESULTS/${tool}_$S.csv" "${files[@]}" \
      || { echo "run.sh: best_of.py failed" >&2; exit 1; }
  done
  if [ "${PY_PEERS:-1}" != 0 ] && [ $peers = 1 ] && [ $py = 1 ]; then
    t=$(date +%s)
    before="$(load)"
    "$PY" bench/peers/peers.py --scene "$S" --out "$RESULTS/peers_$S.csv" $QUICK "${extra[@]}" \
      || echo "run.sh: WARNING: Python peers failed on scene $S" >&2
    echo "load average (1, 5, 15 min) before: $before; after: $(load); $(( $(date +%s) - t )) s" \
      >> "$RESULTS/peers_$S.notes.txt"
    echo "   Python peers and ngspice: $(( $(date +%s) - t )) s"
  fi
done
rm -rf "$ROUND_DIR"

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
