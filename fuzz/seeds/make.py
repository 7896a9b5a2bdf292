#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets from the manuals' vectors.

Each target reads its input in its own layout (see fuzz/fuzz_targets/*.rs):
a leading byte that picks the read chunking or a sub-area, then the bytes
or text. The vectors are the ones the unit tests assert byte for byte
(manual sections cited there); the Cdios and PA-CONTROL frames are read out
of those tests so that the seeds follow them. Run from the repository root:
`python3 fuzz/seeds/make.py`.
"""
import hashlib
import os
import re
import shutil
import struct

ROOT = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(ROOT))


def hexbytes(s):
    return bytes(int(b, 16) for b in s.split())


def write(target, items):
    d = os.path.join(ROOT, target)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    for data in items:
        if isinstance(data, str):
            data = data.encode()
        name = hashlib.sha1(data).hexdigest()[:16]
        with open(os.path.join(d, name), "wb") as f:
            f.write(data)


def read(path):
    with open(os.path.join(REPO, path)) as f:
        return f.read()


def can_seed(frame):
    """`ID#HEX` -> u16 LE id (bit 15 = extended) + data, for the CAN targets."""
    ident, data = frame.split("#")
    ext = 0x8000 if len(ident) > 3 else 0
    return struct.pack("<H", (int(ident, 16) & 0x7FF) | ext) + bytes.fromhex(data)


def monitor_seed(frames):
    """Frames as the monitor target reads them: u16 LE head (id, len << 11) + data."""
    out = b""
    for frame in frames:
        ident, data = frame.split("#")
        data = bytes.fromhex(data)
        out += struct.pack("<H", (int(ident, 16) & 0x7FF) | len(data) << 11) + data
    return out


# PowerCube, manual sections 8 (CAN, module 17) and 9 (RS232, module 17).
PC_CAN = [
    "0F1#01", "0B1#01", "0F1#00", "0B1#00", "0F1#08500000003F", "0B1#085064", "0F1#084F0AD7A33D",
    "0B1#084F64", "0F1#0B040000403F", "0B1#0B0464", "0D1#0A27", "0D1#0A3C", "0B1#0A2702000000",
    "0B1#0B0E0000403F2011", "100#0700", "100#0F00", "100#0903", "100#0E00",
]
PC_RS232 = [
    "02 06 21 01 28 03", "02 0a 21 01 2c 03", "02 06 21 00 27 03", "02 0a 21 00 2b 03",
    "02 06 26 08 50 00 00 00 3f c3 03", "02 0a 26 08 50 64 ec 03",
    "02 06 26 08 4f 0a d7 a3 3d 46 03", "02 0a 26 08 4f 64 eb 03",
    "02 06 26 0b 04 00 00 40 3f ba 03", "02 0a 26 0b 04 64 a3 03",
    "02 06 21 10 82 29 03", "02 04 10 82 0e 00 14 03", "02 06 21 db 10 83 03",
]

# PA-CONTROL, manual 3.4: every frame printed in the unit tests.
pac = read("src/proto/pac/frame.rs")
PAC = sorted(set(re.findall(r'hex\("(01 02 [0-9A-F ]+ 04)"\)', pac)) | set(re.findall(r'"(01 02 [0-9A-F ]+ 04)"', pac)))

# Cdios: the goto of the module docs and every command vector of the tests.
cdios = read("src/proto/cdios/tests.rs")
CDIOS = sorted(set(re.findall(r'"((?:[0-9A-F]{2} ){7}[0-9A-F]{2})"', cdios)))

SLCAN = [
    b"t0F1101\r", b"S8\rO\rt0F1101\rC\r", b"T123456782DEAD\r", b"t0B1101\r\n", b"z\rZ\r\r\x07",
    b"F00\rV1013\rNAX01\r", b"r0F12\r", b"t0F11011234\r", b"L\rF\r", b"S6\rO\rt0D1020A27\rt0D1020A3C\r",
    # Regression: an overlong line cut by BEL (proto::slcan unit test).
    b"x" * 100 + b"\x07t0F1101\r",
]
# What socketcand and python-can's client put on the wire (proto::socketcand unit tests).
SOCKETCAND = [
    b"< hi >< ok >< ok >< echo >", b"< frame 0B1 23.424242 0A1D1835 >", b"< frame 123 1.000005  >",
    b"< frame 1AAAAAAA 0.5 01F1 >", b"< frame 123 23.424242 11 22 33 44 >", b"< open can0 >< rawmode >",
    b"< send 0E3 2 a 3c >", b"< send 1AAAAAAA 2 1 F1 >", b"< error could not open bus >",
    b"< error 004 3.000001 >< stat 1 2 3 4 >", b"HTTP/1.1 400 Bad Request\r\n< hi >", b"< frame 0A3 < ok >",
    b"< frame " + b"1" * 600 + b" >< ok >",
]
URIS = [
    "sim", "socketcan:can0", "socketcan:vcan0", "slcan:/dev/ttyACM0", "slcan:/dev/ttyACM0?bitrate=500000",
    "serial:/dev/ttyUSB0", "serial:/dev/pts/8?baud=9600&format=7N1", "serial:COM3?format=8N1&baud=38400",
    "socketcand:10.0.0.7:29536/can0", "socketcand:[::1]/vcan0?rtt=40",
    # Regression: a bracket inside a host printed back as another spec (link::spec::tests::rejects_bad_uris).
    "socketcand:[[\x1d\x001]//dev40",
]
CANDUMP = [
    "(1700000000.123456) can0 0F1#01", "(5.000007) slcan0 0F1#01", "(0.000001) vcan0 12345678#DEADBEEF R\n",
    "(1.5) can1 100#", "(1700000000.500000) can0 0B1#0A2702000000 T", "0F1#08500000003F",
]
USER_TEXT = [
    "0x1f", "-500", "256", "0.5", "1e-3", "inf", "0b101", "-0x80", "ActPos", "actpos", "0x3c", "60",
    "STATE_HOME_OK|STATE_ERROR", "HOME_OK,ERROR", "0x00000002", "FRampMode", "TargetVel", "MOTION + RAMP_END",
    # Regressions: crashes the fuzzer found (see the unit tests named in docs/fuzzing.md).
    "--9223372036854775808", "-0x-8000000000000000",
]

write("powercube_can", [can_seed(f) for f in PC_CAN])
write("monitor_describe", [monitor_seed(PC_CAN), monitor_seed(["201#2301008813000000", "000#0101", "181#2301000000000000", "7FF#00"])]
      + [monitor_seed([f]) for f in PC_CAN[:6]])
write("powercube_rs232_stream", [bytes([i]) + hexbytes(f) for i, f in enumerate(PC_RS232)]
      + [b"\x07" + b"".join(hexbytes(f) for f in PC_RS232), b"\x00\xff\x03\x10\x55" + hexbytes(PC_RS232[1])])
write("pac_ack_stream", [bytes([i]) + hexbytes(f) for i, f in enumerate(PAC)]
      + [b"\x05" + b"".join(hexbytes(f) for f in PAC) + b"\x04\x04",
         # Regression: a frame reaching MAX_FRAME bytes (proto::pac::frame unit test).
         b"\x03\x01\x02" + b"1" * 1021 + b"\x04\x04"])
write("cdios_messages", [can_seed("201#" + v.replace(" ", "")) for v in CDIOS]
      + [can_seed(f) for f in ["201#2301008813000000", "181#2301000000000000", "181#A301000200000000",
                               "181#6601000000000000", "000#0101", "185#2601000000000000"]])
write("slcan_stream", [bytes([i]) + s for i, s in enumerate(SLCAN)])
write("socketcand_stream", [bytes([i]) + s for i, s in enumerate(SOCKETCAND)])
write("link_uri", URIS)
write("candump_line", CANDUMP)
write("user_values", [b"\x00" + t.encode() for t in USER_TEXT]
      + [b"\x01" + bytes([i]) + b"\x05\x00\x01\x00\x00\x00\x00\x00\x00\x00\x01\x10" for i in range(0, 60, 7)]
      + [b"\x02" + bytes([i]) + b"\x01\x00" + b"\x04" * 16 for i in range(0, 40, 3)])
for d in sorted(os.listdir(ROOT)):
    if os.path.isdir(os.path.join(ROOT, d)):
        print(d, len(os.listdir(os.path.join(ROOT, d))))
