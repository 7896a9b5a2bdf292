#!/usr/bin/env bash
# The PowerCube watchdog keep-alive measured under CPU load on every core.
#
# Serves the simulated bench on two slcan ptys sharing one bus, keeps the
# watchdog alive on one (`axisctl watchdog keepalive`), switches module 5's
# watchdog online over the other, and loads every core with busy loops. It
# reports the refresh gaps the keep-alive measured (min / mean / p99 / max),
# and checks on the module side that the watchdog never tripped while the
# refreshes ran and did trip once they stopped. Exit 1 if a gap reached 50 ms
# or the module tripped early.
#
#   scripts/watchdog-jitter.sh [SECONDS]      (default 30)
#   AXISCTL=target/release/axisctl LOAD=0 scripts/watchdog-jitter.sh 10
set -euo pipefail

SECONDS_TO_RUN=${1:-30}
AXISCTL=${AXISCTL:-target/release/axisctl}
LOAD=${LOAD:-$(nproc)}
INTERVAL=${INTERVAL:-20}
[ -x "$AXISCTL" ] || { echo "no $AXISCTL: cargo build --release (or set AXISCTL)" >&2; exit 2; }

work=$(mktemp -d)
pids=()
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    wait 2>/dev/null || true
    rm -rf "$work"
}
trap cleanup EXIT

# The simulator stands in for the modules' own microcontrollers, which no load
# on this machine slows down: it runs at real-time priority where permitted, so
# that what is measured is the tool, not the simulator starving.
rt=()
if command -v chrt >/dev/null && chrt -f 30 true 2>/dev/null; then rt=(chrt -f 30); fi
"${rt[@]}" "$AXISCTL" sim --powercube pty-slcan --cdios pty-slcan >"$work/sim.out" &
pids+=($!)
for _ in $(seq 100); do [ "$(wc -l <"$work/sim.out")" -ge 2 ] && break; sleep 0.05; done
link_a=$(sed -n 1p "$work/sim.out" | sed 's/.*"link":"\([^"]*\)".*/\1/')
link_b=$(sed -n 2p "$work/sim.out" | sed 's/.*"link":"\([^"]*\)".*/\1/')

for _ in $(seq "$LOAD"); do
    (while :; do :; done) &
    pids+=($!)
done

"$AXISCTL" --link "$link_a" --json watchdog keepalive --interval "$INTERVAL" --for "$SECONDS_TO_RUN" >"$work/keepalive.json" &
keepalive=$!
sleep 0.5
"$AXISCTL" --link "$link_b" --timeout 1000 watchdog on -m 5 >/dev/null
# Just before the keep-alive ends: the module must not have tripped.
sleep "$(echo "$SECONDS_TO_RUN - 2" | bc)"
during=$("$AXISCTL" --link "$link_b" --timeout 1000 --json state -m 5)
wait "$keepalive"
sleep 0.2
after=$("$AXISCTL" --link "$link_b" --timeout 1000 --json state -m 5)

echo "command: $AXISCTL --link slcan:PTY --json watchdog keepalive --interval $INTERVAL --for $SECONDS_TO_RUN"
echo "load:    $LOAD busy loop(s) on $(nproc) core(s); simulator ${rt[*]:-at normal priority}"
echo "gaps:    $(cat "$work/keepalive.json")"
echo "module 5 while refreshed: $during"
echo "module 5 after the end:   $after"

status=0
max=$(sed 's/.*"max_gap_ms":\([0-9.]*\).*/\1/' "$work/keepalive.json")
if [ "$(echo "$max >= 50" | bc)" = 1 ]; then
    echo "FAIL: a refresh gap of $max ms (the module trips at 50 ms)"; status=1
fi
case $during in *STATE_COMM_ERROR*) echo "FAIL: the watchdog tripped while refreshed"; status=1 ;; esac
case $after in *STATE_COMM_ERROR*) ;; *) echo "FAIL: the watchdog did not trip after the refreshes stopped"; status=1 ;; esac
[ $status = 0 ] && echo "ok: max gap $max ms < 50 ms, the watchdog held and then tripped"
exit $status
