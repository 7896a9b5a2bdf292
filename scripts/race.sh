#!/usr/bin/env bash
# The motion supervisor's race harness (tests/supervisor_race.rs) at full
# length: signals at random instants against a served simulator, RUNS per
# family (default 200). Prints per family: runs, devices left moving, worst
# time from signal to exit. Usage: scripts/race.sh [RUNS] [SEED]
set -euo pipefail
cd "$(dirname "$0")/.."
export AXISCTL_RACE_RUNS="${1:-200}"
export AXISCTL_RACE_SEED="${2:-$RANDOM}"
echo "race: $AXISCTL_RACE_RUNS runs per family, seed $AXISCTL_RACE_SEED"
cargo test --test supervisor_race -- --nocapture 2>&1 | grep -E '^race |test result|panicked|FAILED'
