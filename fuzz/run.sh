#!/usr/bin/env bash
# Coverage-guided fuzzing of the netlist and scene readers with libFuzzer, on the stable toolchain
# (the sanitizer-coverage instrumentation is set by -C flags; no nightly needed, no sanitizer).
#
#   fuzz/run.sh [--time SECONDS | --runs N] [netlist] [scene]
#
# Defaults: both targets, 30 s each (the short run CI does through scripts/test). The long run of
# docs/hardening.md is `nice -n 19 fuzz/run.sh --runs 1000000`. Every input is limited to 1 s of
# CPU time (the targets time themselves: dirac_fuzz::CPU_LIMIT) and 256 MiB live (the targets'
# allocator aborts beyond that); libFuzzer's wall-clock -timeout is only a backstop for an input
# that never returns, set high because a niced run on a busy machine waits for a core. A crash,
# a hang or an allocation past the limit stops the run with a non-zero exit and leaves the input in
# fuzz/artifacts/<target>/. Keep such an input in fuzz/regressions/<target>/ once fixed: the test
# suite replays them (crates/dirac-netlist/tests/fuzz_regressions.rs and its scene twin).
set -euo pipefail
cd "$(dirname "$0")"

limit=(-max_total_time=30)
targets=()
while [ $# -gt 0 ]; do
    case "$1" in
        --time) limit=(-max_total_time="$2"); shift 2 ;;
        --runs) limit=(-runs="$2"); shift 2 ;;
        netlist|scene) targets+=("$1"); shift ;;
        *) echo "usage: fuzz/run.sh [--time SECONDS | --runs N] [netlist] [scene]" >&2; exit 2 ;;
    esac
done
[ ${#targets[@]} -gt 0 ] || targets=(netlist scene)

host=$(rustc -vV | sed -n 's/^host: //p')
coverage="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing"
# --target keeps the instrumentation off build scripts and proc macros (they run on the host).
RUSTFLAGS="$coverage" cargo build --release --locked --target "$host" --bins
build=${CARGO_TARGET_DIR:-target}

python3 extract_seeds.py "$build/seeds"
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t" "artifacts/$t"
    echo "fuzzing $t: ${limit[*]}" >&2
    "$build/$host/release/$t" "corpus/$t" "$build/seeds/$t" \
        -dict="dict/$t.dict" -timeout=60 -rss_limit_mb=2048 -max_len=8192 \
        -artifact_prefix="artifacts/$t/" -print_final_stats=1 "${limit[@]}"
done
