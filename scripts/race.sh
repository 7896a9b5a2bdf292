#!/usr/bin/env bash
# The motion supervisor's race harness (tests/supervisor_race.rs) at full
# length: signals and output failures at random instants against a served
# simulator, RUNS per family (default 200). Prints per family: runs, devices
# left moving, wrong exits, and the time from the signal to the halt frame
# (median and worst, from the wall-clock stamps of --log) and to the exit.
# It runs a copy of the binaries, so a rebuild meanwhile changes nothing.
# Then the PA-CONTROL late-answer race: LATE_RUNS (default 120) signalled
# runs each of pac-move --wait, pac-ref --wait and record -- pac-move on a
# simulator that answers 30 % of the requests 200 ms late.
# Usage: scripts/race.sh [RUNS] [SEED]; PROFILE=release for a release build,
# AXISCTL_RACE_ONLY=pac (or powercube, cdios) for one family, RACE_TEST=late
# (or signals_and_output) for one of the two races. A failure prints each
# wrong run.
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-200}"
seed="${2:-$RANDOM}"
profile="${PROFILE:-debug}"
flags=()
[ "$profile" = release ] && flags=(--release)
cargo build -q "${flags[@]}" --bin axisctl
exe=$(cargo test "${flags[@]}" --test supervisor_race --no-run 2>&1 | sed -n 's/.*Executable .*(\(.*\))$/\1/p' | tail -1)
snap=$(mktemp -d)
trap 'rm -rf "$snap"' EXIT
cp "target/$profile/axisctl" "$snap/axisctl"
cp "$exe" "$snap/race"
late="${LATE_RUNS:-120}"
export AXISCTL_BIN="$snap/axisctl" AXISCTL_RACE_RUNS="$runs" AXISCTL_RACE_SEED="$seed" AXISCTL_RACE_LATE_RUNS="$late"
echo "race: $runs runs per family, $late late-answer runs per PA-CONTROL command, seed $seed, $profile build, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
"$snap/race" ${RACE_TEST:-} --nocapture 2>&1 | grep -E '^race |^  wrong: |^    |test result|FAILED'
