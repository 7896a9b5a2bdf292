"""What the benchmark scripts share: where the release binary is, the
simulator served in the background, and a CAN frame's length on the wire as
the simulator at wire speed meters it."""

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
AXISCTL = TARGET / "release" / "axisctl"


class Sim:
    """`axisctl sim ARGS` in the background; links as announced (family -> link)."""

    def __init__(self, *args):
        self.proc = subprocess.Popen([str(AXISCTL), "sim", *args], stdout=subprocess.PIPE, text=True)
        self.links = {}
        if "--socketcand" in args:
            expect = 2  # the one bus, announced for PowerCube and Cdios
        elif any(a.startswith("--powercube") or a.startswith("--pac") for a in args):
            expect = 1
        else:
            expect = 3
        while len(self.links) < expect:
            line = self.proc.stdout.readline()
            if not line:
                sys.exit("axisctl sim ended early")
            d = json.loads(line)
            self.links[d["family"]] = d["link"]

    def stop(self):
        self.proc.send_signal(signal.SIGINT)
        self.proc.wait(timeout=5)


def wire_bits(can_id, data):
    """A classic frame's bits on the wire (ISO 11898-1): stuffed SOF..CRC,
    then the 13 unstuffed bits of delimiters, EOF and intermission. The same
    count as `CanFrame::wire_bits`, which the simulator's wire speed uses."""
    bits = []

    def push(v, n):
        bits.extend((v >> i) & 1 for i in range(n - 1, -1, -1))

    push(0, 1)
    if can_id > 0x7FF:
        push(can_id >> 18, 11)
        push(0b11, 2)
        push(can_id & 0x3FFFF, 18)
        push(0, 3)
    else:
        push(can_id, 11)
        push(0, 3)
    push(len(data), 4)
    for b in data:
        push(b, 8)
    crc = 0
    for bit in bits:
        top = (crc >> 14) & 1
        crc = (crc << 1) & 0x7FFF
        if top != bit:
            crc ^= 0x4599
    push(crc, 15)
    stuffed, run, last = 0, 0, None
    for b in bits:
        if b == last:
            run += 1
        else:
            run, last = 1, b
        if run == 5:
            stuffed += 1
            last, run = 1 - b, 1
    return len(bits) + stuffed + 13
