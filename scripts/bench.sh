#!/usr/bin/env bash
# The benchmark suite in one run (a few minutes): builds release, runs the criterion
# micro benchmarks with short measurement times, then the whole-process figures
# (scripts/bench.py) against `axisctl sim --wire-speed`, and prints one table.
#   scripts/bench.sh [--markdown FILE] [bench.py options]
# docs/performance.md is the page of a run: scripts/bench.sh --markdown docs/performance.md
# (written only when every figure of this run is there; a failed criterion run stops here).
# Needs python3 with python-can (pip install python-can) and tmux for the dashboard figure.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never
target=${CARGO_TARGET_DIR:-target}
python3 -c 'import can' 2>/dev/null || python3 -m pip install --quiet python-can
cargo build --release --quiet
cargo bench --quiet --bench poll --no-run
# Estimates of earlier runs must not stand in for this one's: remove them, and let bench.py
# refuse any estimate older than this run's start.
since=$(date +%s)
rm -rf "$target/criterion"
# Short criterion runs: ~3 s per benchmark; medians are stable to a few percent.
out=$(mktemp)
trap 'rm -f "$out"' EXIT
if ! cargo bench --quiet --bench codecs --bench session -- --warm-up-time 1 --measurement-time 2 >"$out" 2>&1; then
    cat "$out" >&2
    echo "bench: the criterion benchmarks failed; no page written" >&2
    exit 1
fi
grep -E '^[a-z_]+/[a-z0-9_]+|time:' "$out"
python3 scripts/bench.py --criterion-since "$since" "$@"
