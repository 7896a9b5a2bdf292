"""python-can's own slcan interface talking to `axisctl sim`'s slcan pty.

Usage: slcan_client.py TTY
Sends PowerCube requests for module 17 and prints every answer as ID#DATA.
"""
import sys
import time

import can

bus = can.Bus(interface="slcan", channel=sys.argv[1], bitrate=1000000)
try:
    requests = [
        can.Message(arbitration_id=0x0D1, data=[0x0A, 0x1D], is_extended_id=False),  # GetExtended DefCubeVersion
        can.Message(arbitration_id=0x0F1, data=[0x01], is_extended_id=False),  # Home
        can.Message(arbitration_id=0x0D1, data=[0x0A, 0x27], is_extended_id=False),  # GetExtended CubeState
    ]
    for req in requests:
        bus.send(req)
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            msg = bus.recv(timeout=0.5)
            if msg is not None and msg.arbitration_id == 0x0B1:
                print(f"{msg.arbitration_id:03X}#{msg.data.hex().upper()}", flush=True)
                break
        else:
            print("TIMEOUT", flush=True)
finally:
    bus.shutdown()
