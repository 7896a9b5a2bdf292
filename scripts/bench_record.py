#!/usr/bin/env python3
"""`axisctl record`'s sample rate as a share of the wire limit.

Against `axisctl sim --wire-speed` on pseudo-terminals: PowerCube modules over
an slcan pty at 1 Mbit/s CAN (every value of every module pipelined in one
burst per sample, the next sample's burst sent before the current one's
answers are read) and a PA-CONTROL axis over a serial pty at 9600 baud (one
request at a time: the line is half duplex).

The wire limit of a sample is the wire time of its frames, taken from the
traffic `--log` writes: the log of `--count 2` less the log of `--count 1`
is exactly one sample's requests and answers (without the setup reads; the
burst sent ahead of the end, never read, is in both). The
measured rate is (samples - 1) / (last t - first t) of a `--for` recording.

`figures(add, links)` adds the rows to scripts/bench.py's table (`links`:
family -> link as `axisctl sim --wire-speed` prints them); run alone it starts
its own simulator and prints the rows.
"""

import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from benchlib import AXISCTL, Sim, wire_bits

GOAL = 0.9
SECONDS = 3.0


def serial_bits_per_char(link):
    """Start bit, data bits, parity, stop bit of the link's format (8N1 unless it says)."""
    m = re.search(r"format=(\d)([NEO])(\d)", link)
    data, parity, stop = (int(m.group(1)), m.group(2), int(m.group(3))) if m else (8, "N", 1)
    return 1 + data + (0 if parity == "N" else 1) + stop


def baud(link, default=9600):
    m = re.search(r"baud=(\d+)", link)
    return int(m.group(1)) if m else default


def bitrate(link, default=1_000_000):
    m = re.search(r"bitrate=(\d+)", link)
    return int(m.group(1)) if m else default


def wire_seconds(log, link):
    """Wire time of everything in a `--log` file of this link."""
    text = log.read_text() if log.exists() else ""
    if link.startswith("serial:"):
        chars = 0
        for line in text.splitlines():
            _, _direction, *hexes = line.split()
            chars += len(hexes)
        return chars * serial_bits_per_char(link) / baud(link)
    bits = 0
    for line in text.splitlines():
        parts = line.split()
        if len(parts) >= 3 and "#" in parts[2]:
            can_id, data = parts[2].split("#", 1)
            bits += wire_bits(int(can_id, 16), bytes.fromhex(data))
    return bits / bitrate(link)


def record(link, args, extra, log=None):
    argv = [str(AXISCTL), "--link", link, "--json"]
    if log:
        argv += ["--log", str(log)]
    argv += ["record", *args, *extra]
    r = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(argv)} failed ({r.returncode}): {r.stderr}")
    return [json.loads(line) for line in r.stdout.splitlines()]


def wire_per_sample(link, args):
    with tempfile.TemporaryDirectory() as d:
        one, two = Path(d) / "one.log", Path(d) / "two.log"
        record(link, args, ["--count", "1"], one)
        record(link, args, ["--count", "2"], two)
        return wire_seconds(two, link) - wire_seconds(one, link)


def measure(link, args, seconds):
    """(samples per second over the whole run, samples, samples per second
    at the median interval between two samples: what the recorder sustains
    when no other process takes the CPU away)."""
    lines = record(link, args, ["--for", f"{seconds}s"])
    t = [line["t"] for line in lines]
    gaps = sorted(b - a for a, b in zip(t, t[1:]))
    return (len(lines) - 1) / (t[-1] - t[0]), len(lines), 1 / gaps[len(gaps) // 2]


def figure(add, what, link, args, why, seconds=SECONDS, repeats=3):
    per_sample = wire_per_sample(link, args)
    limit = 1 / per_sample
    runs = sorted(measure(link, args, seconds) for _ in range(repeats))
    rate, n, steady = runs[len(runs) // 2]
    share = rate / limit
    command = f"axisctl --link '{link}' --json record {' '.join(args)} --for {seconds:g}s"
    add(
        f"record sample rate, {what}",
        f"{100 * share:.1f} % of the wire limit ({rate:.1f} samples/s against {limit:.1f}; {n} samples in "
        f"{seconds:g} s); median of {repeats} runs ("
        + ", ".join(f"{100 * r / limit:.1f} %" for r, _, _ in runs)
        + f"); at the median interval between samples {100 * steady / limit:.1f} %",
        f"goal >= {100 * GOAL:.0f} % of the wire limit",
        share >= GOAL,
        command + "  # against axisctl sim --wire-speed",
        f"{why}: {per_sample * 1e3:.3f} ms of wire time per sample (from --log)",
    )
    return share


def figures(add, links):
    can = links["powercube"].split("?")[0] + "?bitrate=1000000"
    figure(
        add,
        "PowerCube modules 3, 5, 17 x ActPos ActVel Cur on CAN 1 Mbit/s via an slcan pty",
        can,
        ["-m", "3,5,17", "ActPos", "ActVel", "Cur"],
        "9 reads pipelined in one burst = 9 x (2-byte request + 6-byte answer); the next sample's burst goes out "
        "before this one's answers are read, so the bus carries it during the pty turnaround (what is lost: the "
        "host falling behind the wire)",
    )
    figure(
        add,
        "PA-CONTROL axis 2 position and speed over RS232 9600 baud 7N1 (pty)",
        links["pac"].split("?")[0] + "?baud=9600&format=7N1",
        ["--axis", "2", "position", "speed"],
        "half duplex: 2 reads one after the other, each command + acknowledge",
        seconds=5.0,
    )


def main():
    if not AXISCTL.exists():
        sys.exit(f"{AXISCTL} missing: cargo build --release first")
    rows = []

    def add(figure, measured, reference, ok, command, limit):
        rows.append((figure, measured, reference, {True: "pass", False: "FAIL", None: "pending"}[ok], command, limit))

    sim = Sim("--wire-speed")
    try:
        figures(add, sim.links)
    finally:
        sim.stop()
    for r in rows:
        print(" | ".join(map(str, r)))
    load = os.getloadavg()
    print(f"load average: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs")
    return 0 if all(r[3] == "pass" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
