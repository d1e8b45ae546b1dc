#!/usr/bin/env python3
"""Rewrites a BLF file (as python-can's BLFWriter writes it: object header version 1, times in
ns, CAN_MESSAGE / CAN_FD_MESSAGE_64 / CAN_ERROR_EXT in zlib containers of 128 KiB) into the
other layouts Vector's tools write, for the cross-check against python-can
(log_formats_crosscheck.py):
  - object header version 2 (40 bytes, with the original time stamp),
  - times in 10 us units (TIME_TEN_MICS) instead of ns,
  - CAN_MESSAGE2 instead of CAN_MESSAGE,
  - all objects in one zlib container (any size; Vector writes 128 KiB ones), or in stored
    (uncompressed) containers of 1000 bytes, objects cut at every container boundary.
    make_blf_variants.py IN OUT [--stored]
"""
import argparse
import struct
import zlib

OBJ = struct.Struct("<4sHHLL")  # signature, header size, header version, object size, type
V1 = struct.Struct("<LHHQ")      # flags, client index, object version, time
CAN_MESSAGE, LOG_CONTAINER, CAN_MESSAGE2 = 1, 10, 86
TEN_MICS = 1


def objects(data):
    """The object stream of a BLF file's containers (after its 144-byte header)."""
    stream, at = bytearray(), struct.unpack_from("<L", data, 4)[0]
    while at + OBJ.size <= len(data):
        _, _, _, size, kind = OBJ.unpack_from(data, at)
        body = data[at + OBJ.size + 16:at + size]
        method = struct.unpack_from("<H", data, at + OBJ.size)[0]
        if kind == LOG_CONTAINER:
            stream += zlib.decompress(body) if method == 2 else body
        at += size + size % 4
    out, at = [], 0
    while at + OBJ.size <= len(stream):
        at = stream.index(b"LOBJ", at)
        _, header_size, _, size, kind = OBJ.unpack_from(stream, at)
        out.append((kind, bytes(stream[at + OBJ.size:at + header_size]), bytes(stream[at + header_size:at + size])))
        at += size
    return out


def rewrite(kind, header, body):
    """The object with a version 2 header, its time in 10 us, CAN_MESSAGE as CAN_MESSAGE2."""
    _, _, version, stamp = V1.unpack(header)
    if kind == CAN_MESSAGE:
        kind, body = CAN_MESSAGE2, body + struct.pack("<LBBH", 0, 0, 0, 0)
    tens = stamp // 10_000
    head = struct.pack("<LBxHQQ", TEN_MICS, 0, version, tens, stamp)
    size = OBJ.size + len(head) + len(body)
    return OBJ.pack(b"LOBJ", OBJ.size + len(head), 2, size, kind) + head + body + bytes(size % 4)


def container(stream, compress):
    data = zlib.compress(stream) if compress else stream
    size = OBJ.size + 16 + len(data)
    return (OBJ.pack(b"LOBJ", 16, 1, size, LOG_CONTAINER) + struct.pack("<H6xL4x", 2 if compress else 0, len(stream)) +
            data + bytes(size % 4))


def write_variant(src, dst, stored=False):
    data = open(src, "rb").read()
    stream = b"".join(rewrite(*o) for o in objects(data))
    chunks = [stream[i:i + 1000] for i in range(0, len(stream), 1000)] if stored else [stream]
    body = b"".join(container(c, not stored) for c in chunks)
    header = bytearray(data[:144])
    struct.pack_into("<QQ", header, 16, 144 + len(body), 144 + len(stream))
    open(dst, "wb").write(bytes(header) + body)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--stored", action="store_true")
    a = ap.parse_args()
    write_variant(a.src, a.dst, a.stored)


if __name__ == "__main__":
    main()
