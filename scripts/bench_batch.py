#!/usr/bin/env python3
"""`axisctl batch` against the wire: N get-param lines in one process next to
N one-shot processes, at 1 Mbit/s CAN (an slcan pty served by
`axisctl sim --wire-speed`).

The wire limit is what the frames themselves take: every frame the lines
exchange (counted with --log on a calibration batch) at its length on the
wire, stuff bits and intermission included, as the simulator meters it.
The figure is that busy time over the wall time of the whole batch process.
Consecutive get-param (and state) lines go out pipelined, in bursts of up to 32
requests; the log tells the bursts apart (a request after an answer starts
one).

`figures(add, links)` adds the rows to scripts/bench.py's table; run alone
(`python3 scripts/bench_batch.py [--lines N]`) it serves its own simulator
and prints them.
"""

import argparse
import itertools
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchlib import AXISCTL, Sim, wire_bits

BITRATE = 1_000_000
LINE = "get-param -m 3 ActPos"
GOAL = 0.90


CANDUMP = re.compile(r"^\((\d+\.\d+)\) \S+ ([0-9A-Fa-f]+)#([0-9A-Fa-f]*)$")


def logged(path):
    """(time, CAN id, wire bits) of every frame in a candump -l log."""
    out = []
    for line in Path(path).read_text().splitlines():
        m = CANDUMP.match(line.strip())
        if m:
            can_id = int(m.group(2), 16)
            out.append((float(m.group(1)), can_id, wire_bits(can_id, bytes.fromhex(m.group(3)))))
    return out


def is_answer(can_id):
    """A PowerCube acknowledge (0x0A0 + module), not a request."""
    return can_id & ~0x1F == 0x0A0


def run_batch(link, n, extra=()):
    """Wall time of one `axisctl --link LINK batch` process running n lines."""
    script = "".join(f"{LINE}\n" for _ in range(n))
    t0 = time.perf_counter()
    r = subprocess.run(
        [str(AXISCTL), "--link", link, *extra, "batch", "-"],
        input=script,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    elapsed = time.perf_counter() - t0
    if r.returncode != 0:
        sys.exit(f"axisctl batch failed ({r.returncode}): {r.stderr}")
    return elapsed


def calibrate(link, n):
    """The wire bits and frames of one line, and the lines of the median
    burst (a run of requests in the log), from the traffic log of an n-line
    batch."""
    with tempfile.TemporaryDirectory() as d:
        log = Path(d) / "traffic.log"
        run_batch(link, n, ["--log", str(log)])
        frames = logged(log)
    per_line = len(frames) / n
    requests = [sum(1 for _ in run) for is_req, run in itertools.groupby(frames, lambda f: not is_answer(f[1])) if is_req]
    # The first run holds the first burst and the one sent ahead of its answers.
    lines = statistics.median(requests[1:] or requests) / (per_line / 2)
    return sum(b for _, _, b in frames) / n, per_line, lines


def figures(add, links, n=1000):
    """Adds the batch rows: `links` maps family -> link as `axisctl sim
    --wire-speed` prints them; the PowerCube's slcan link is used."""
    link = links["powercube"]
    per_line, frames, burst_lines = calibrate(link, n)
    wire = n * per_line / BITRATE
    elapsed = min(run_batch(link, n) for _ in range(3))
    share = wire / elapsed
    t0 = time.perf_counter()
    for _ in range(n):
        r = subprocess.run([str(AXISCTL), "--link", link, *LINE.split()], stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            sys.exit(f"axisctl {LINE} failed ({r.returncode}): {r.stderr}")
    one_shot = time.perf_counter() - t0
    load = os.getloadavg()[0]
    limit = (f"{frames:.0f} frames per line ({per_line:.0f} bits with stuffing and intermission: "
             f"{per_line:.0f} µs at 1 Mbit/s); consecutive get-param and state lines are pipelined, their requests "
             f"in bursts of up to 32 ({burst_lines:.0f} lines here), and the next burst leaves before this "
             "one's answers are read, so the bus waits neither for a line nor for a burst; what is left of the gap to the "
             "wire limit is the process start, the parse of every line before the first runs and the "
             "first burst's trip across the pty "
             f"(load average {load:.1f} during the run)")
    add(
        f"batch: {n} x `{LINE}` in one process, CAN 1 Mbit/s via an slcan pty",
        f"{100 * share:.1f} % of the wire limit ({elapsed:.3f} s for {wire:.3f} s of frames, "
        f"{1e3 * elapsed / n:.2f} ms per line; best of 3)",
        f"goal >= {100 * GOAL:.0f} % of the wire limit",
        share >= GOAL,
        f"printf '{LINE}\\n%.0s' $(seq {n}) | axisctl --link {link} batch -  # against axisctl sim --wire-speed",
        limit,
    )
    add(
        f"the same {n} lines as {n} one-shot processes",
        f"{100 * wire / one_shot:.1f} % of the wire limit ({one_shot:.2f} s, {1e3 * one_shot / n:.2f} ms per "
        f"process); batch is {one_shot / elapsed:.1f} x faster",
        "reference for the batch row (no goal)",
        None,
        f"for i in $(seq {n}); do axisctl --link {link} {LINE}; done",
        "a process start, the adapter's setup (C, S8, O with replies) and the port lock per command",
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=1000)
    args = ap.parse_args()
    if not AXISCTL.exists():
        sys.exit(f"{AXISCTL} is missing: cargo build --release")
    rows = []

    def add(figure, measured, reference, ok, command, limit):
        verdict = {True: "pass", False: "FAIL", None: "-"}[ok]
        rows.append((figure, measured, reference, verdict, command, limit))

    sim = Sim("--wire-speed")
    try:
        figures(add, sim.links, args.lines)
    finally:
        sim.stop()
    for r in rows:
        print(" | ".join(r))
    return 0 if all(r[3] != "FAIL" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
