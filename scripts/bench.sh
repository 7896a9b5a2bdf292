#!/usr/bin/env bash
# The benchmark suite in one run (a few minutes): builds release, runs the criterion
# micro benchmarks with short measurement times, then the whole-process figures
# (scripts/bench.py) against `axisctl sim --wire-speed`, and prints one table.
#   scripts/bench.sh [--markdown FILE] [bench.py options]
# docs/performance.md holds the table of a run: scripts/bench.sh --markdown /tmp/perf.md
# Needs python3 with python-can (pip install python-can) and tmux for the dashboard figure.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TERM_COLOR=never
python3 -c 'import can' 2>/dev/null || python3 -m pip install --quiet python-can
cargo build --release --quiet
cargo bench --quiet --bench poll --no-run 2>/dev/null
# Short criterion runs: ~3 s per benchmark; medians are stable to a few percent.
cargo bench --quiet --bench codecs --bench session -- --warm-up-time 1 --measurement-time 2 2>&1 |
    grep -E '^[a-z_]+/[a-z0-9_]+|time:' || true
python3 scripts/bench.py "$@"
