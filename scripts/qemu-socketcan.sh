#!/usr/bin/env bash
# The SocketCAN link against a real Linux kernel: boots Debian's kernel under qemu (software
# emulation, no KVM), creates vcan0 inside, serves the simulated bench on it with
# `axisctl sim --powercube socketcan:vcan0`, runs CLI commands against it while candump
# records the bus, and checks the results and the captured frames here on the host.
#
#   bash scripts/qemu-socketcan.sh
#
# Needs root (or sudo) only to install missing packages. Environment:
#   QEMU_CAN_PROFILE=debug|release   which axisctl build to boot (default debug: CI has it built)
#   AXISCTL_BIN=/path/to/axisctl     boot this binary instead of building one
#   QEMU_CAN_KERNEL=/boot/vmlinuz-V  the kernel (default: the newest one with modules)
#   QEMU_CAN_BOOT=vmlinux|bzimage    boot the extracted uncompressed kernel (default, faster) or the bzImage
#   QEMU_CAN_KEEP=1                  keep the work directory (initramfs, console log, results) on success too
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
T0=$(date +%s.%N)
elapsed() { awk -v a="$T0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }'; }
say() { echo "[$(elapsed) s] $*"; }
die() {
    echo "qemu-socketcan: FAIL: $*" >&2
    exit 1
}

# --- 1. packages -------------------------------------------------------------------------
PACKAGES=(qemu-system-x86 linux-image-amd64 busybox-static can-utils cpio xz-utils jq)
missing=()
for p in "${PACKAGES[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if ((${#missing[@]})); then
    say "installing ${missing[*]}"
    SUDO=()
    if [ "$(id -u)" -ne 0 ]; then
        command -v sudo >/dev/null || die "missing packages (${missing[*]}) and not root"
        SUDO=(sudo)
    fi
    "${SUDO[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" \
        >/tmp/qemu-socketcan-apt.log 2>&1 || {
        tail -30 /tmp/qemu-socketcan-apt.log >&2
        die "apt-get install failed"
    }
    say "packages installed"
fi

work=$(mktemp -d /tmp/qemu-socketcan.XXXXXX)
# Kept on failure (or with QEMU_CAN_KEEP=1) for a look at the console log and the capture.
cleanup() {
    local st=$?
    if [ "$st" -ne 0 ] || [ "${QEMU_CAN_KEEP:-0}" = 1 ]; then
        echo "work directory kept: $work"
    else
        rm -rf "$work"
    fi
}
trap cleanup EXIT
root=$work/root
mkdir -p "$root"/{bin,usr/bin,proc,sys,dev,log,tmp,modules}

# --- 2. axisctl, candump, busybox ---------------------------------------------------------
if [ -n "${AXISCTL_BIN:-}" ]; then
    axisctl=$AXISCTL_BIN
else
    profile=${QEMU_CAN_PROFILE:-debug}
    say "building axisctl ($profile)"
    flags=()
    [ "$profile" = release ] && flags=(--release)
    (cd "$repo" && cargo build --quiet --bin axisctl "${flags[@]}")
    axisctl=${CARGO_TARGET_DIR:-$repo/target}/$profile/axisctl
fi
[ -x "$axisctl" ] || die "no axisctl binary at $axisctl"

# Copies a dynamically linked binary and the shared libraries ldd names, at the same paths.
copy_with_libs() {
    local bin=$1 dest=$2 lib
    cp "$bin" "$root$dest"
    for lib in $(ldd "$bin" | grep -o '/[^ ]*'); do
        mkdir -p "$root$(dirname "$lib")"
        cp -L "$lib" "$root$lib"
    done
}
copy_with_libs "$axisctl" /bin/axisctl
# Debug info is most of a debug build; the guest does not need it and the initramfs stays small.
strip --strip-debug "$root/bin/axisctl" 2>/dev/null || true
copy_with_libs "$(command -v candump)" /usr/bin/candump
copy_with_libs "$(command -v cansend)" /usr/bin/cansend
cp /bin/busybox "$root/bin/busybox"
ln -s busybox "$root/bin/sh"

# --- 3. kernel and modules ----------------------------------------------------------------
if [ -n "${QEMU_CAN_KERNEL:-}" ]; then
    kernel=$QEMU_CAN_KERNEL
else
    kernel=
    for k in $(ls /boot/vmlinuz-* 2>/dev/null | sort -V -r); do
        if [ -f "/lib/modules/${k#/boot/vmlinuz-}/modules.dep" ]; then
            kernel=$k
            break
        fi
    done
    [ -n "$kernel" ] || die "no /boot/vmlinuz-* with modules in /lib/modules (is linux-image-amd64 installed?)"
fi
kver=${kernel#/boot/vmlinuz-}
moddir=/lib/modules/$kver
[ -f "$moddir/modules.dep" ] || die "no $moddir/modules.dep for $kernel"

# Load order from modules.dep: each module after the modules it depends on.
declare -A loaded=()
order=()
resolve() {
    local name=$1 line path deps i
    line=$(grep -E "(^|/)$name\\.ko(\\.xz|\\.zst|\\.gz)?:" "$moddir/modules.dep" | head -1)
    [ -n "$line" ] || die "module $name not in $moddir/modules.dep"
    path=${line%%:*}
    [ -n "${loaded[$path]:-}" ] && return 0
    read -r -a deps <<<"${line#*:}"
    # modules.dep lists the deepest dependency last: load from the end.
    for ((i = ${#deps[@]} - 1; i >= 0; i--)); do
        local dep=${deps[i]##*/}
        resolve "${dep%%.ko*}"
    done
    loaded[$path]=1
    order+=("$path")
}
for m in can can-raw can-dev vcan; do resolve "$m"; done
: >"$root/modules/order"
for path in "${order[@]}"; do
    src=$moddir/$path
    base=$(basename "$path")
    # busybox insmod takes plain .ko files: decompress here.
    case $path in
    *.ko.xz) xz -dc "$src" >"$root/modules/${base%.xz}" ;;
    *.ko.zst) zstd -qdc "$src" >"$root/modules/${base%.zst}" ;;
    *.ko.gz) gzip -dc "$src" >"$root/modules/${base%.gz}" ;;
    *) cp "$src" "$root/modules/$base" ;;
    esac
    echo "${base%.ko*}.ko" >>"$root/modules/order"
done
say "kernel $kver, modules: $(tr '\n' ' ' <"$root/modules/order")"

cp "$repo/scripts/qemu-socketcan-init.sh" "$root/init"
chmod +x "$root/init"
(cd "$root" && find . | cpio -o -H newc --quiet) >"$work/initramfs.cpio"
say "initramfs $(du -h "$work/initramfs.cpio" | cut -f1)"

# The bzImage decompresses itself under emulation, which is slow; qemu boots the
# uncompressed ELF vmlinux directly (PVH entry) when the kernel has one. Extracted as the
# kernel's scripts/extract-vmlinux does: find the compressed payload's magic, decompress
# from there (the trailing bytes make the decompressor complain; the ELF check decides).
boot=$kernel
if [ "${QEMU_CAN_BOOT:-vmlinux}" = vmlinux ]; then
    vmlinux=$work/vmlinux
    for magic in '\xFD7zXZ\x00:xz -dcq' '\x28\xB5\x2F\xFD:zstd -qdc' '\x1F\x8B\x08:gzip -dcq'; do
        pos=$(LC_ALL=C grep -obUaP "${magic%%:*}" "$kernel" | head -1 | cut -d: -f1 || true)
        [ -n "$pos" ] || continue
        tail -c +$((pos + 1)) "$kernel" | ${magic#*:} >"$vmlinux" 2>/dev/null || true
        if [ "$(head -c 4 "$vmlinux" | od -An -tx1 | tr -d ' \n')" = 7f454c46 ] &&
            readelf -n "$vmlinux" 2>/dev/null | grep -q 'Xen.*0x00000012\|Unknown note type: (0x00000012)'; then
            boot=$vmlinux
            break
        fi
    done
    [ "$boot" = "$kernel" ] && say "no PVH vmlinux could be extracted: booting the bzImage"
fi

# --- 4. boot ------------------------------------------------------------------------------
say "booting $(basename "$boot") under qemu (tcg)"
tboot=$(date +%s.%N)
rc=0
# A hung guest ends here rather than in the CI job timeout.
timeout 300 qemu-system-x86_64 -accel tcg -nographic -no-reboot -m 512 -smp 2 -nic none \
    -kernel "$boot" -initrd "$work/initramfs.cpio" \
    -append "console=ttyS0 panic=-1 quiet" \
    -serial mon:stdio -serial "file:$work/results.txt" \
    </dev/null >"$work/console.log" 2>&1 || rc=$?
guest_s=$(awk -v a="$tboot" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
say "qemu exited with $rc after $guest_s s"

out=$work/out
mkdir -p "$out"
awk -v dir="$out" '
    /^=== BEGIN / { f = dir "/" $3; printf "" > f; next }
    /^=== END / { close(f); f = ""; next }
    /^=== DONE$/ { print "" > (dir "/.done"); next }
    f != "" { print > f }
' "$work/results.txt" 2>/dev/null || true

if [ ! -f "$out/.done" ]; then
    echo "--- guest console:" >&2
    tr -d '\r' <"$work/console.log" | tail -40 >&2
    die "the guest did not report its results (qemu exit $rc)"
fi
if [ -f "$out/guest-error.txt" ]; then
    tr -d '\r' <"$work/console.log" | tail -20 >&2
    cat "$out/guest-stderr.txt" >&2 2>/dev/null || true
    die "in the guest: $(cat "$out/guest-error.txt")"
fi

# --- 5. checks ----------------------------------------------------------------------------
failures=0
check() { # check DESCRIPTION COMMAND...
    local what=$1
    shift
    if "$@"; then
        echo "  ok   $what"
    else
        echo "  FAIL $what"
        failures=$((failures + 1))
    fi
}
rc_of() { cat "$out/$1.rc" 2>/dev/null || echo missing; }
# jq_file FILE FILTER: FILE holds exactly one JSON document and the filter holds on it
# (slurped: jq -e alone succeeds on an empty file).
jq_file() { jq -se "length == 1 and (.[0] | $2)" "$out/$1" >/dev/null 2>&1; }
# jq_on NAME FILTER: the same on the command's stdout; jq_err on its stderr.
jq_on() { jq_file "$1.out" "$2"; }
jq_err() { jq_file "$1.err" "$2"; }
is_rc() { [ "$(rc_of "$1")" = "$2" ]; }
is_empty() { [ ! -s "$out/$1" ]; }

# Frames candump saw during a command's run: "ID#DATA" lines in capture order.
frames() {
    local start end
    start=$(cat "$out/$1.start") end=$(cat "$out/$1.end")
    awk -v s="$start" -v e="$end" '{ t = substr($1, 2, length($1) - 2) + 0; if (t >= s && t <= e) print $3 }' \
        "$out/candump.txt"
}
# in_order NAME FRAME...: the frames appear in this order (not necessarily adjacent).
in_order() {
    local name=$1
    shift
    frames "$name" | awk -v want="$*" '
        BEGIN { n = split(want, w, " "); i = 1 }
        i <= n && $0 == w[i] { i++ }
        END { exit !(i > n) }'
}
has_frame() { frames "$1" | grep -Eq "$2"; }
no_frame() { ! has_frame "$1" "$2"; }
some_frames() { [ -n "$(frames "$1")" ]; }

echo "results:"
for n in scan home home-wait state ramp get-param absent out-of-range; do
    printf '  %-13s exit %-3s %s\n' "$n" "$(rc_of "$n")" "$(head -c 300 "$out/$n.out" 2>/dev/null)$(head -c 300 "$out/$n.err" 2>/dev/null)"
done
echo "checks:"
check "sim announced socketcan:vcan0" jq_file sim.jsonl '.family == "powercube" and .link == "socketcan:vcan0"'
check "sim stopped cleanly on SIGINT (exit 0)" is_rc sim 0
check "sim wrote nothing to stderr" is_empty sim.err
check "scan exits 0" is_rc scan 0
check "scan lists modules 3, 5, 17" jq_on scan '[.devices[].module] == [3, 5, 17]'
check "home -m 17 exits 0 and is acknowledged" jq_on home '.acknowledged == true and .module == 17'
check "home -m 17: 0F1#01 then 0B1#01 on the bus" in_order home '0F1#01' '0B1#01'
check "home -m 17 --wait exits 0" is_rc home-wait 0
check "home -m 17 --wait ends with STATE_HOME_OK" jq_on home-wait '.done == true and (.state.flags | index("STATE_HOME_OK") != null)'
check "home -m 17 --wait sent Home" in_order home-wait '0F1#01' '0B1#01'
check "state -m 17 exits 0 and shows STATE_HOME_OK" \
    jq_on state '.module == 17 and (.state.flags | index("STATE_HOME_OK") != null) and .state.errors == []'
check "move-ramp -m 3 0.5 --wait exits 0" is_rc ramp 0
check "move-ramp ends at 0.5 +- 1e-3" jq_on ramp '.done == true and ((.position.value - 0.5) | (. < 1e-3 and . > -1e-3))'
check "move-ramp sent SetMotion to module 3 (0E3#0B...)" has_frame ramp '^0E3#0B'
check "get-param -m 17 ActPos exits 0 at 0 +- 1e-3 after homing" \
    jq_on get-param '.module == 17 and .params.ActPos.id == 60 and (.params.ActPos.value | (. < 1e-3 and . > -1e-3))'
check "state -m 9 (absent) exits 4" is_rc absent 4
check "state -m 9 reports a timeout on stderr, nothing on stdout" jq_err absent '.error.kind == "timeout"'
check "state -m 9 asked module 9 (0C9#...) and got no answer (0A9#...)" \
    eval "has_frame absent '^0C9#' && no_frame absent '^0A9#'"
check "out-of-range move-ramp exits 2" is_rc out-of-range 2
check "out-of-range move-ramp is a usage error naming MaxPos" jq_err out-of-range '.error.kind == "usage" and (.error.message | test("MaxPos"))'
check "out-of-range move-ramp: candump saw its limit query" some_frames out-of-range
check "out-of-range move-ramp: no SetMotion frame (0E?#0B / 0F?#0B)" no_frame out-of-range '^0[EF][0-9A-F]#0B'
check "failed commands print nothing on stdout" eval "is_empty absent.out && is_empty out-of-range.out"
# ID#DATA of each candump -L line, in order.
ids_data() { awk '{ print $3 }' "$out/$1"; }
check "monitor --filter 0C3:7FF ran and ended (exit 0)" is_rc monitor-filtered 0
check "monitor --filter 0C3:7FF saw frames" test -s "$out/monitor-filtered.txt"
check "monitor --filter 0C3:7FF shows what candump vcan0,0C3:7FF,#FFFFFFFF shows (the error frame too), in order" \
    eval 'diff <(ids_data monitor-filtered.txt) <(ids_data candump-filtered.txt) >&2'
check "candump saw the bus-off error frame" eval "ids_data candump-errors.txt | grep -q '^20000040#'"
check "monitor --json shows the error frame as kind error, bus off" \
    eval "jq -se 'any(.[]; .kind == \"error\" and (tostring | test(\"bus off\")))' '$out/monitor-json.txt' >/dev/null"

echo "candump: $(wc -l <"$out/candump.txt") frames captured"
echo "timing: kernel boot to /init $(cat "$out/uptime-init.txt") s, to the report $(cat "$out/uptime-end.txt") s" \
    "(guest clock); qemu $guest_s s; whole script $(elapsed) s"
if ((failures)); then
    echo "--- candump -L vcan0:"
    cat "$out/candump.txt"
    die "$failures check(s) failed"
fi
echo "qemu-socketcan: OK"
