"""Reads a candump log with python-can's LogReader and passes each frame
through python-can's own CAN filters (can_id / can_mask, the SocketCAN
semantics), on its virtual bus; prints ID#DATA of each frame that passes.
Usage: filter_log.py LOG ID:MASK..."""
import sys

import can

filters = []
for text in sys.argv[2:]:
    can_id, can_mask = (int(x, 16) for x in text.split(":"))
    filters.append({"can_id": can_id, "can_mask": can_mask})

channel = "axisctl-filter-test"
with can.Bus(interface="virtual", channel=channel) as tx, can.Bus(
    interface="virtual", channel=channel, can_filters=filters
) as rx:
    for msg in can.LogReader(sys.argv[1]):
        tx.send(msg)
        # The virtual bus hands a frame over within send(): a frame the
        # filters pass is already waiting.
        got = rx.recv(timeout=0.0)
        if got is not None:
            width = 8 if got.is_extended_id else 3
            print(f"{got.arbitration_id:0{width}X}#{got.data.hex().upper()}")
