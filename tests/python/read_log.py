"""Reads a candump log with python-can's LogReader; prints ID#DATA per frame."""
import sys

import can

for msg in can.LogReader(sys.argv[1]):
    width = 8 if msg.is_extended_id else 3
    print(f"{msg.arbitration_id:0{width}X}#{msg.data.hex().upper()}")
