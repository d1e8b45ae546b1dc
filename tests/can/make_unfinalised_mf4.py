#!/usr/bin/env python3
"""Makes unfinalised MF4 files from finalised ones, as a stand-alone logger that lost power
would leave them, for the cross-check against asammdf (log_formats_crosscheck.py).

asammdf writes the data blocks first and the metadata after them; a logger writes the
metadata first and appends data until it stops. So the blocks are re-laid (ID, HD and the
metadata, then the data blocks, the largest last, every link rewritten), then:
  - the identification says "UnFinMF " with the unfinalised flags,
  - the cycle counts of the channel groups are 0 (flag 0x01, never written),
  - every DT block's length is 24 (flag 0x04, the last DT of each data group never closed),
  - the file is cut inside the last data block, in the middle of a record.
Compressed (DZ) data blocks are kept whole (a logger cannot leave a deflate block open);
with --dl the largest becomes two DZ blocks under a DL whose second link was never written
(flag 0x10: DZ, DL, DZ in the file). (asammdf 8.8.28 reads the header of a DT block linked
this way 24 bytes too late and drops it, so the DL variant uses DZ blocks.)
    make_unfinalised_mf4.py IN OUT [--cut FRACTION] [--dl]
"""
import argparse
import struct
import zlib

BLOCK = struct.Struct("<4s4xQQ")  # id, length, link count
FLAG_CYCLES, FLAG_LAST_DT, FLAG_LAST_DL = 0x01, 0x04, 0x10
DATA_BLOCKS = (b"##DT", b"##DZ", b"##DL", b"##HL", b"##SD")


def blocks(data):
    """[(offset, id, bytes)] of the blocks after the 64-byte ID block, in file order (asammdf
    leaves gaps between some blocks: the next block is the next 8-byte aligned signature)."""
    out, at = [], 64
    while at + BLOCK.size <= len(data):
        bid, length, count = BLOCK.unpack_from(data, at)
        if not bid.startswith(b"##") or length < BLOCK.size + 8 * count or at + length > len(data):
            at += 8
            continue
        out.append((at, bid, bytearray(data[at:at + length])))
        at = (at + length + 7) // 8 * 8
    return out


def relink(block, moved):
    count = BLOCK.unpack_from(block, 0)[2]
    for i in range(count):
        (link,) = struct.unpack_from("<Q", block, 24 + 8 * i)
        if link in moved:
            struct.pack_into("<Q", block, 24 + 8 * i, moved[link])


def lay_out(ident, parts):
    """The file of `ident` and the blocks in the order given, every link rewritten."""
    moved, at = {}, 64
    for old, _, b in parts:
        moved[old] = at
        at = (at + len(b) + 7) // 8 * 8
    out = bytearray(ident)
    for _, _, b in parts:
        relink(b, moved)
        out += b + bytes((-len(b)) % 8)
    return out, moved


def links(block):
    count = BLOCK.unpack_from(block, 0)[2]
    return [struct.unpack_from("<Q", block, 24 + 8 * i)[0] for i in range(count)]


def dz_payload(dz):
    """The records of a DZ block (zip type 0 deflate, 1 transposed deflate)."""
    zip_type, columns, original, _ = struct.unpack_from("<2xBxIQQ", dz, 24)
    raw = zlib.decompress(bytes(dz[48:]))
    if zip_type == 1:
        rows = original // columns
        body = bytearray(rows * columns)
        for c in range(columns):
            body[c::columns] = raw[c * rows:(c + 1) * rows]
        raw = bytes(body) + raw[rows * columns:]
    return raw


def dz_block(payload):
    packed = zlib.compress(payload)
    return bytearray(BLOCK.pack(b"##DZ", 48 + len(packed), 0) + struct.pack("<2sBxIQQ", b"DT", 0, 0, len(payload),
                                                                            len(packed)) + packed)


def split_under_dl(parts, record_bytes):
    """The last (largest) DZ becomes DZ_a, DL, DZ_b (re-deflated, records split in half); the
    DL's link to DZ_b is not written. Keys: the DL takes the DZ's old offset (the data group
    links to it), the new blocks -1 and -2."""
    old, bid, dz = parts[-1]
    assert bid == b"##DZ", "a logger closes its DZ blocks: the DL variant splits a DZ"
    payload = dz_payload(dz)
    half = len(payload) // record_bytes // 2 * record_bytes
    dl = bytearray(BLOCK.pack(b"##DL", 24 + 3 * 8 + 8 + 2 * 8, 3) + struct.pack("<QQQ", 0, 0, 0) +
                   struct.pack("<B3xI", 0, 2) + struct.pack("<QQ", 0, half))
    return parts[:-1] + [(-1, b"##DZ", dz_block(payload[:half])), (old, b"##DL", dl),
                         (-2, b"##DZ", dz_block(payload[half:]))]


def unfinalise(src, dst, cut=0.6, dl=False):
    data = open(src, "rb").read()
    parts = blocks(data)
    meta = [p for p in parts if p[1] not in DATA_BLOCKS]
    payload = sorted((p for p in parts if p[1] in DATA_BLOCKS), key=lambda p: len(p[2]))
    compressed = any(p[1] == b"##DZ" for p in payload)
    flags = FLAG_CYCLES if compressed else FLAG_CYCLES | FLAG_LAST_DT
    record_bytes = 0
    for _, bid, b in meta:
        if bid == b"##CG":  # cycle count never written
            at = 24 + 8 * BLOCK.unpack_from(b, 0)[2]
            nbytes, inval = struct.unpack_from("<II", b, at + 24)
            record_bytes = max(record_bytes, nbytes + inval)
            struct.pack_into("<Q", b, at + 8, 0)
    if dl:
        payload = split_under_dl(payload, record_bytes)
        flags |= FLAG_LAST_DL
    out, moved = lay_out(data[:64], meta + payload)
    if dl:  # the DL's first data link: DZ_a (laid out before it)
        struct.pack_into("<Q", out, moved[payload[-2][0]] + 24 + 8, moved[-1])
    if not compressed:
        for old, bid, _ in payload:
            if bid == b"##DT":  # the last DT of each data group: length never written
                struct.pack_into("<Q", out, moved[old] + 8, 24)
    out[0:8] = b"UnFinMF "
    struct.pack_into("<H", out, 60, flags)
    end = len(out)
    if not compressed:  # cut inside the last data block, in the middle of a record
        last = moved[payload[-1][0]] + 24
        end = last + int((end - last) * cut) // 8 * 8 + 3
    open(dst, "wb").write(out[:end])
    return flags


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--cut", type=float, default=0.6)
    ap.add_argument("--dl", action="store_true")
    a = ap.parse_args()
    print(f"{a.dst}: unfinalised flags 0x{unfinalise(a.src, a.dst, a.cut, a.dl):02x}")


if __name__ == "__main__":
    main()
