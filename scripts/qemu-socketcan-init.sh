#!/bin/sh
# PID 1 of the qemu guest built by scripts/qemu-socketcan.sh: loads the CAN modules,
# creates vcan0, serves the simulated bench on it with `axisctl sim`, runs CLI commands
# against it while candump records the bus, then writes everything to the second serial
# port (ttyS1, a file on the host) and powers off. The host side does all the judging:
# this script only records, so a wrong answer cannot be hidden by the guest.

/bin/busybox --install -s /bin
export PATH=/bin:/usr/bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
mkdir -p /log /tmp
cut -d' ' -f1 /proc/uptime >/log/uptime-init.txt

# Wall-clock time in microseconds, the clock candump stamps frames with (busybox date has no %N).
now() {
    adjtimex | awk '/tv_sec/ { s = $2 } /tv_usec/ { u = $2 } END { printf "%d.%06d\n", s, u }'
}

LINK=socketcan:vcan0

# Everything in /log goes to ttyS1 between markers; the host splits it back into files.
# `raw` so the tty does not turn \n into \r\n.
report() {
    cut -d' ' -f1 /proc/uptime >/log/uptime-end.txt
    stty -F /dev/ttyS1 raw -echo 2>/dev/null
    {
        for f in /log/*; do
            echo "=== BEGIN ${f#/log/}"
            cat "$f"
            # Keep the end marker on a line of its own.
            [ -n "$(tail -c 1 "$f")" ] && echo
            echo "=== END ${f#/log/}"
        done
        echo "=== DONE"
    } >/dev/ttyS1
    sync
    poweroff -f
}

fail() {
    echo "$*" >>/log/guest-error.txt
    echo "guest: $*" >&2
    report
}

# The module list is written by the host in load order (dependencies first).
for m in $(cat /modules/order); do
    insmod "/modules/$m" 2>>/log/guest-stderr.txt || fail "insmod $m failed"
done

ip link add dev vcan0 type vcan 2>>/log/guest-stderr.txt || fail "cannot create vcan0"
ip link set vcan0 up || fail "cannot bring vcan0 up"
ip -d link show vcan0 >/log/vcan0.txt 2>&1

# One capture of the whole run; each command's window is recorded below, so the host
# can tell which frames a command put on the bus from the kernel's own timestamps.
candump -L vcan0 >/log/candump.txt 2>/log/candump.err &
CANDUMP=$!

axisctl sim --powercube "$LINK" >/log/sim.jsonl 2>/log/sim.err &
SIM=$!

# The sim prints its link once its socket is bound; candump binds before that in practice,
# and the wait also covers it.
i=0
until grep -q '"link"' /log/sim.jsonl 2>/dev/null; do
    i=$((i + 1))
    [ "$i" -gt 300 ] && fail "axisctl sim did not announce its link within 30 s"
    kill -0 "$SIM" 2>/dev/null || fail "axisctl sim exited early"
    sleep 0.1
done
sleep 0.5

# run NAME ARGS...: one CLI invocation; stdout, stderr, exit code and its time window.
run() {
    name=$1
    shift
    echo "$*" >"/log/$name.cmd"
    now >"/log/$name.start"
    # The 100 ms default answer timeout is a real-bus figure; this emulated guest runs many
    # times slower and shares the host with other jobs, so a late answer would be a timeout.
    axisctl --link "$LINK" --json --timeout 1000 "$@" >"/log/$name.out" 2>"/log/$name.err"
    echo $? >"/log/$name.rc"
    now >"/log/$name.end"
    # Keep windows apart: frames in flight at the end stay inside this window.
    sleep 0.2
}

# The host checks these by name (scripts/qemu-socketcan.sh); keep the two in step.
run scan scan
run home home -m 17
run home-wait home -m 17 --wait
run state state -m 17
run ramp move-ramp -m 3 0.5 --vel 1 --acc 2 --wait
run get-param get-param -m 17 ActPos
run absent state -m 9
run out-of-range move-ramp -m 3 1000

# The monitor beside candump on the same traffic: one id/mask filter in both (the monitor
# shows error frames whatever its id filters, as candump with the error mask #FFFFFFFF), and a bus
# error frame (cansend of an id with CAN_ERR_FLAG; vcan hands it to error-filtered sockets).
candump -L vcan0,0C3:7FF,#FFFFFFFF >/log/candump-filtered.txt 2>/log/candump-filtered.err &
CDF=$!
candump -L vcan0,#FFFFFFFF >/log/candump-errors.txt 2>/log/candump-errors.err &
CDE=$!
# Each monitor is ended by Ctrl-C once it showed the last frame sent (below); --for is a
# backstop only.
axisctl --link "$LINK" monitor --candump --filter 0C3:7FF --for 60 >/log/monitor-filtered.txt 2>/log/monitor-filtered.err &
MONF=$!
axisctl --link "$LINK" --json monitor --for 60 >/log/monitor-json.txt 2>/log/monitor-json.err &
MONJ=$!
sleep 2
for args in "state -m 3" "state -m 17" "get-param -m 3 ActPos" "state -m 5"; do
    axisctl --link "$LINK" --timeout 1000 $args >/dev/null 2>&1
done
cansend vcan0 20000040#0000000000000000 2>>/log/guest-stderr.txt
# The error frame is the last frame on the bus: once both monitors printed it they have seen
# every frame, and Ctrl-C ends a monitor with exit 0. Waited for 30 s at most (the host's
# checks then say what is missing).
i=0
until grep -q ' 20000040#' /log/monitor-filtered.txt 2>/dev/null &&
    grep '"kind":"error"' /log/monitor-json.txt 2>/dev/null | grep -q 'bus off'; do
    i=$((i + 1))
    [ "$i" -gt 300 ] && break
    sleep 0.1
done
kill -INT "$MONF" "$MONJ"
wait "$MONF"
echo $? >/log/monitor-filtered.rc
wait "$MONJ"
echo $? >/log/monitor-json.rc
kill -TERM "$CDF" "$CDE"
wait "$CDF"
wait "$CDE"

kill -INT "$SIM"
wait "$SIM"
echo $? >/log/sim.rc
kill -TERM "$CANDUMP"
wait "$CANDUMP"
report
