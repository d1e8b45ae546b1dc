#!/usr/bin/env python3
"""Writes MF4 seeds of the logger layouts for the mf4 fuzz target (tests/fuzz/corpus/mf4/),
block by block as tests/can/mf4_test_util.h does: an unfinalised unsorted file with DataBytes
in a VLSD channel group, error and remote frame groups and a record cut at the end (the first
CANedge firmware's layout), and one with virtual channels, a 48-bit microsecond time and a
DataLength table (newer firmware). Run from the repository:
    .venv/bin/python tests/fuzz/make_mf4_logger_seeds.py
"""
import os
import struct

START_NS = 1607975914_000_000_000
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)


class Writer:
    def __init__(self, unfinalised):
        ident = (b"UnFinMF " if unfinalised else b"MDF     ") + b"4.11    ndsid   " + bytes(4) + struct.pack("<H", 411)
        self.b = bytearray(ident.ljust(60, b"\0") + struct.pack("<HH", unfinalised, 0))
        self.add(b"##HD", [0] * 6, struct.pack("<Q", START_NS) + bytes(24))

    def add(self, bid, links, data):
        self.b += bytes((-len(self.b)) % 8)
        at = len(self.b)
        self.b += bid + bytes(4) + struct.pack("<QQ", 24 + 8 * len(links) + len(data), len(links))
        self.b += b"".join(struct.pack("<Q", x) for x in links) + data
        return at

    def link(self, block, index, value):
        struct.pack_into("<Q", self.b, block + 24 + 8 * index, value)

    def text(self, s):
        raw = s.encode() + b"\0"
        return self.add(b"##TX", [], raw + bytes((-len(raw)) % 8))

    def cc(self, kind, values):
        return self.add(b"##CC", [0] * 4, struct.pack("<BBHHH", kind, 0, 0, 0, len(values)) + bytes(16) +
                        b"".join(struct.pack("<d", v) for v in values))

    def channels(self, specs):
        """specs: (name, cn_type, data_type, byte, bit, bits, cc, data link), first to last."""
        nxt = 0
        for name, cn_type, dtype, byte, bit, bits, cc, data in reversed(specs):
            data_block = struct.pack("<BBBBII", cn_type, 1 if cn_type == 2 else 0, dtype, bit, byte, bits) + bytes(64)
            nxt = self.add(b"##CN", [nxt, 0, self.text(name), 0, cc, data, 0, 0], data_block)
        return nxt

    def group(self, nxt, first, record_id, nbytes, flags=0):
        return self.add(b"##CG", [nxt, first, 0, 0, 0, 0], struct.pack("<QQHH4xII", record_id, 0, flags, 0, nbytes, 0))

    def data_group(self, first_group, record_id_bytes):
        at = self.add(b"##DG", [0, first_group, 0, 0], struct.pack("<B7x", record_id_bytes))
        self.link(64, 0, at)
        return at


def put(record, byte, bit, bits, value):
    for i in range(bits):
        if value >> i & 1:
            record[byte + (bit + i) // 8] |= 1 << ((bit + i) % 8)


def first_firmware():
    w = Writer(0x25)
    ns = w.cc(1, [0, 1e-9])
    vlsd = w.group(0, 0, 2, 0, flags=1)
    t = ("Timestamp", 2, 4, 0, 0, 64, ns, 0)
    data = w.channels([t, ("CAN_DataFrame.BusChannel", 0, 0, 13, 2, 2, 0, 0), ("CAN_DataFrame.ID", 0, 0, 8, 3, 29, 0, 0),
                       ("CAN_DataFrame.IDE", 0, 0, 8, 0, 1, 0, 0), ("CAN_DataFrame.DLC", 0, 0, 13, 4, 4, 0, 0),
                       ("CAN_DataFrame.DataLength", 0, 0, 12, 1, 7, 0, 0),
                       ("CAN_DataFrame.DataBytes", 1, 10, 14, 0, 64, 0, vlsd),
                       ("CAN_DataFrame.EDL", 0, 0, 12, 0, 1, 0, 0), ("CAN_DataFrame.BRS", 0, 0, 13, 1, 1, 0, 0)])
    error = w.channels([t, ("CAN_ErrorFrame.BusChannel", 0, 0, 8, 0, 2, 0, 0)])
    remote = w.channels([t, ("CAN_RemoteFrame.ID", 0, 0, 8, 3, 29, 0, 0), ("CAN_RemoteFrame.DLC", 0, 0, 13, 4, 4, 0, 0)])
    cg3 = w.group(w.group(0, remote, 4, 14), error, 3, 9)
    w.link(vlsd, 0, cg3)
    dg = w.data_group(w.group(vlsd, data, 1, 22), 1)
    records, offset = bytearray(), 0
    for i in range(6):
        rec = bytearray(struct.pack("<d", 1e6 * (i + 1)) + bytes(14))
        put(rec, 8, 3, 29, 0x100 + i if i % 2 else 0x18F00E00 + i)
        put(rec, 8, 0, 1, i % 2 == 0)
        put(rec, 13, 4, 4, 9 if i == 4 else 8)
        put(rec, 12, 1, 7, 12 if i == 4 else 8)
        put(rec, 12, 0, 1, i == 4)
        put(rec, 14, 0, 64, offset)
        value = bytes(range(12 if i == 4 else 8))
        records += b"\x01" + rec + b"\x02" + struct.pack("<I", len(value)) + value
        offset += 4 + len(value)
    records += b"\x03" + struct.pack("<d", 7e6) + b"\x01"
    records += b"\x04" + struct.pack("<d", 8e6) + bytes(6)
    w.link(dg, 2, w.add(b"##DT", [], b""))
    return bytes(w.b + records[:-5])  # the last record cut


def newer_firmware():
    w = Writer(0x05)
    us, nine, one = w.cc(1, [0, 1e-6]), w.cc(1, [9, 0]), w.cc(1, [1, 0])
    table = w.cc(5, [v for dlc in range(16) for v in (dlc, FD_LENGTHS[dlc])])
    vlsd = w.group(0, 0, 45, 0, flags=1)
    fd = w.channels([("Timestamp", 2, 0, 0, 0, 48, us, 0), ("CAN_DataFrame.BusChannel", 6, 0, 0, 0, 0, nine, 0),
                     ("CAN_DataFrame.ID", 0, 0, 6, 0, 29, 0, 0), ("CAN_DataFrame.IDE", 6, 0, 0, 0, 0, one, 0),
                     ("CAN_DataFrame.DLC", 0, 0, 10, 0, 4, 0, 0), ("CAN_DataFrame.DataLength", 0, 0, 10, 0, 4, table, 0),
                     ("CAN_DataFrame.DataBytes", 1, 10, 11, 0, 32, 0, vlsd), ("CAN_DataFrame.EDL", 6, 0, 0, 0, 0, one, 0),
                     ("CAN_DataFrame.BRS", 0, 0, 10, 6, 1, 0, 0)])
    dg = w.data_group(w.group(vlsd, fd, 44, 15), 1)
    records = bytearray()
    for i in range(4):
        rec = bytearray(15)
        put(rec, 0, 0, 48, 16_701_700 + i)
        put(rec, 6, 0, 29, 0x18F00E00 + i)
        put(rec, 10, 0, 4, 9 + i)
        put(rec, 11, 0, 32, sum(4 + FD_LENGTHS[9 + k] for k in range(i)))
        records += b"\x2c" + rec + b"\x2d" + struct.pack("<I", FD_LENGTHS[9 + i]) + bytes(range(FD_LENGTHS[9 + i]))
    w.link(dg, 2, w.add(b"##DT", [], b""))
    return bytes(w.b + records)


def main():
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus", "mf4")
    os.makedirs(out, exist_ok=True)
    for name, data in (("logger_unfinalised_vlsd.mf4", first_firmware()), ("logger_virtual_channels.mf4", newer_firmware())):
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)
        print(f"{name}: {len(data)} bytes")


if __name__ == "__main__":
    main()
