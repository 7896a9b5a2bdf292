#!/usr/bin/env python3
"""The reference for `axisctl get-param -m 3 ActPos` over an slcan adapter:
the same exchange written with python-can (its slcan interface).

axisctl sends GetExtended ActPos and GetExtended Config (for the unit) to
module 3 pipelined and waits for both acknowledges; so does this script.
Usage: bench_python_can.py TTY [BITRATE]. Prints the position and, on
stderr, the time from open to answer and of the exchange alone.
"""

import struct
import sys
import time

import can

GET_EXTENDED = 0x0A
ACT_POS = 0x3C
CONFIG = 0x39
MODULE = 3


def main():
    tty = sys.argv[1]
    bitrate = int(sys.argv[2]) if len(sys.argv) > 2 else 1_000_000
    t0 = time.perf_counter()
    # sleep_after_open=0: python-can waits 2 s by default for boards that reset when the
    # port opens; a pty (and most USB-CAN adapters) need no such wait.
    bus = can.Bus(interface="slcan", channel=tty, bitrate=bitrate, sleep_after_open=0)
    try:
        t1 = time.perf_counter()
        for param in (ACT_POS, CONFIG):
            bus.send(can.Message(arbitration_id=0x0C0 + MODULE, data=[GET_EXTENDED, param], is_extended_id=False))
        answers = {}
        deadline = time.perf_counter() + 0.1
        while len(answers) < 2 and time.perf_counter() < deadline:
            msg = bus.recv(timeout=max(0.0, deadline - time.perf_counter()))
            if msg is None:
                break
            data = bytes(msg.data)
            if msg.arbitration_id == 0x0A0 + MODULE and len(data) >= 6 and data[0] == GET_EXTENDED:
                answers[data[1]] = data[2:6]
        t2 = time.perf_counter()
    finally:
        bus.shutdown()
    if ACT_POS not in answers:
        print("no answer from module 3", file=sys.stderr)
        return 4
    print(f"ActPos {struct.unpack('<f', answers[ACT_POS])[0]:g}")
    print(f"open {1e3 * (t1 - t0):.2f} ms, exchange {1e3 * (t2 - t1):.2f} ms", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
