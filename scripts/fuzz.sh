#!/usr/bin/env bash
# Runs every cargo-fuzz target of fuzz/ one after another and prints, per
# target, the executions done, the time, exec/s and the crashes found.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]      each target for SECONDS (default 60)
#   scripts/fuzz.sh --runs N [TARGET...]       each target for N executions
#   scripts/fuzz.sh --build-only               install cargo-fuzz if missing, build, run nothing
#
# The seed corpora in fuzz/seeds/<target>/ (manual vectors, committed) are
# copied into the working corpus fuzz/corpus/<target>/ (not committed), which
# keeps what the fuzzer learns between runs. Crashing inputs land in
# fuzz/artifacts/<target>/; reproduce one with
#   RUSTC_BOOTSTRAP=1 cargo fuzz run -s none TARGET fuzz/artifacts/TARGET/crash-...
#
# Only stable Rust exists here: cargo fuzz needs nightly flags, which
# RUSTC_BOOTSTRAP=1 unlocks on the stable compiler. The targets are built
# without a sanitizer (FUZZ_SANITIZER=none): the fuzzed code is safe Rust, so
# AddressSanitizer finds nothing there and costs 3x the speed; panics,
# overflow checks and debug assertions stay on. FUZZ_SANITIZER=address
# builds with it anyway.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
export RUSTC_BOOTSTRAP=1
sanitizer=${FUZZ_SANITIZER:-none}

limit=(-max_total_time=60)
build_only=
if [[ ${1:-} == --build-only ]]; then
    build_only=1
    shift
elif [[ ${1:-} == --runs ]]; then
    [[ ${2:-} =~ ^[0-9]+$ ]] || { echo "usage: $0 --runs N [TARGET...]" >&2; exit 2; }
    limit=(-runs="$2")
    shift 2
elif [[ ${1:-} =~ ^[0-9]+$ ]]; then
    limit=(-max_total_time="$1")
    shift
fi

if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo install --locked cargo-fuzz
fi

targets=("$@")
if [[ ${#targets[@]} -eq 0 ]]; then
    mapfile -t targets < <(cargo fuzz list)
fi

# One build for all targets (the same flags as `cargo fuzz run` below, so it
# does not rebuild).
cargo fuzz build -s "$sanitizer"
[[ -n $build_only ]] && exit 0

mkdir -p logs
status=0
failed=0
printf '%-24s %12s %8s %10s %8s\n' target executions seconds exec/s crashes
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t" "artifacts/$t"
    if [[ -d "seeds/$t" ]]; then
        cp -n "seeds/$t"/* "corpus/$t/" 2>/dev/null || true
    fi
    before=$(find "artifacts/$t" -type f | wc -l)
    # Inputs up to 4096 bytes reach past the PA-CONTROL MAX_FRAME (1024). slcan
    # lines end at MAX_LINE (96): 1024 bytes hold ten overlong ones, and longer
    # inputs only make the stream decoders' per-line buffer shifts dominate.
    max_len=4096
    [[ $t == slcan_stream ]] && max_len=1024
    start=$(date +%s%N)
    rc=0
    cargo fuzz run -s "$sanitizer" "$t" "corpus/$t" -- \
        "${limit[@]}" -max_len="$max_len" -timeout=10 -rss_limit_mb=1024 -print_final_stats=1 \
        >"logs/$t.log" 2>&1 || rc=$?
    end=$(date +%s%N)
    after=$(find "artifacts/$t" -type f | wc -l)
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "logs/$t.log" | tail -1)
    secs=$(((end - start + 500000000) / 1000000000))
    # Over the wall time of the run (startup included): libFuzzer's own
    # average divides by whole seconds and reads 0 for short runs.
    ms=$(((end - start) / 1000000))
    rate=$([[ -n $runs ]] && echo $((runs * 1000 / (ms > 0 ? ms : 1))))
    crashes=$((after - before))
    if [[ $rc -ne 0 && $crashes -eq 0 ]]; then
        crashes=1
    fi
    printf '%-24s %12s %8s %10s %8s\n' "$t" "${runs:-?}" "$secs" "${rate:-?}" "$crashes"
    if [[ $crashes -ne 0 ]]; then
        status=1
        failed=$((failed + 1))
        grep -m1 -A6 -E 'panicked|ERROR: libFuzzer' "logs/$t.log" | sed 's/^/    /' || true
        grep -m1 'Test unit written' "logs/$t.log" | sed 's/^/    /' || true
    fi
done
echo "fuzz: $((${#targets[@]} - failed)) passed, $failed failed"
exit $status
