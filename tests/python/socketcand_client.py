"""python-can's own socketcand interface talking to `axisctl sim --socketcand`.

Usage: socketcand_client.py HOST PORT CHANNEL
Reads PowerCube module 3's DefCubeVersion, starts Cdios node 1 and reads
module 0's status; prints each answer as ID#DATA (TIMEOUT when none came).
"""
import sys
import time

import can

host, port, channel = sys.argv[1], int(sys.argv[2]), sys.argv[3]
bus = can.Bus(interface="socketcand", host=host, port=port, channel=channel)


def ask(request, answer_id):
    bus.send(request)
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline:
        msg = bus.recv(timeout=0.5)
        if msg is not None and msg.arbitration_id == answer_id:
            print(f"{msg.arbitration_id:03X}#{msg.data.hex().upper()}", flush=True)
            return
    print("TIMEOUT", flush=True)


try:
    # PowerCube GetExtended DefCubeVersion to module 3.
    ask(can.Message(arbitration_id=0x0C3, data=[0x0A, 0x1D], is_extended_id=False), 0x0A3)
    # Cdios: NMT start node 1 (no answer), then read_status of module 0.
    bus.send(can.Message(arbitration_id=0x000, data=[0x01, 0x01], is_extended_id=False))
    ask(can.Message(arbitration_id=0x201, data=[0x26, 0, 0, 0, 0, 0, 0, 0], is_extended_id=False), 0x181)
finally:
    bus.shutdown()
