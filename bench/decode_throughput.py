#!/usr/bin/env python3
"""Reference rate: python-can's CanutilsLogReader + cantools decode of the same candump log.

    decode_throughput.py DBC LOG [FRAMES]

Reads only the first FRAMES frames (python-can parses lazily, line by line), decodes every
signal with cantools (numeric values, no choice names), and prints key=value lines matching
ndsid_bench_decode_throughput: the rate and a checksum of the decoded physical values.
"""
import sys
import time

import can
import cantools


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    dbc_path, log_path = sys.argv[1], sys.argv[2]
    limit = int(sys.argv[3]) if len(sys.argv) > 3 else 200000
    db = cantools.database.load_file(dbc_path)

    # Parse only.
    start = time.perf_counter()
    n = 0
    for _ in can.CanutilsLogReader(log_path):
        n += 1
        if n >= limit:
            break
    parse_s = time.perf_counter() - start

    # Parse + decode.
    start = time.perf_counter()
    frames = values = not_decoded = 0
    check_sum = 0.0
    for msg in can.CanutilsLogReader(log_path):
        try:
            decoded = db.decode_message(msg.arbitration_id, msg.data, decode_choices=False)
        except (KeyError, cantools.database.DecodeError):
            not_decoded += 1
        else:
            values += len(decoded)
            check_sum += sum(decoded.values())
        frames += 1
        if frames >= limit:
            break
    decode_s = time.perf_counter() - start

    print(f"py_frames={frames}")
    print(f"py_signal_values={values}")
    print(f"py_frames_not_decoded={not_decoded}")
    print(f"py_parse_only_s={parse_s:.3f}")
    print(f"py_parse_only_fps={n / parse_s:.0f}")
    print(f"py_parse_decode_s={decode_s:.3f}")
    print(f"py_parse_decode_fps={frames / decode_s:.0f}")
    print(f"py_check_sum={check_sum:.6f}")
    print(f"py_versions=python-can {can.__version__}, cantools {cantools.__version__}, "
          f"Python {sys.version.split()[0]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
