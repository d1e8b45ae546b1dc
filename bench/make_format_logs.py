#!/usr/bin/env python3
"""Converts a candump log into Vector ASC and BLF (python-can's writers) and ASAM MF4 bus
logging (asammdf, one bulk append: python-can's MF4Writer appends frame by frame and takes
minutes for a million frames), for bench/run_frame_log_bench.sh.
    make_format_logs.py LOG OUT_DIR
"""
import gzip
import os
import sys
import time

os.environ["TZ"] = "UTC"
time.tzset()
import can  # noqa: E402
import numpy as np  # noqa: E402
from asammdf import MDF, Signal, Source  # noqa: E402
from asammdf.blocks.v4_constants import BUS_TYPE_CAN, SOURCE_BUS  # noqa: E402


def main():
    log, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    opener = gzip.open if log.endswith(".gz") else open
    msgs = []
    with opener(log, "rt") as f:
        for line in f:
            ts, bus, token = line.split()
            cid, data = token.split("#")
            msgs.append(can.Message(timestamp=float(ts[1:-1]), arbitration_id=int(cid, 16), is_extended_id=len(cid) == 8,
                                    data=bytes.fromhex(data), channel=int(bus[3:])))
    for name, writer in (("drive.asc", can.ASCWriter), ("drive.blf", can.BLFWriter)):
        t = time.time()
        w = writer(os.path.join(out, name))
        for m in msgs:
            w.on_message_received(m)
        w.stop()
        print(f"{name}: {len(msgs)} frames in {time.time() - t:.1f} s")
    t = time.time()
    dtype = np.dtype([("CAN_DataFrame.BusChannel", "<u1"), ("CAN_DataFrame.ID", "<u4"), ("CAN_DataFrame.IDE", "<u1"),
                      ("CAN_DataFrame.DLC", "<u1"), ("CAN_DataFrame.DataLength", "<u1"),
                      ("CAN_DataFrame.DataBytes", "(8,)u1"), ("CAN_DataFrame.Dir", "<u1")])
    rec = np.zeros(len(msgs), dtype=dtype)
    rec["CAN_DataFrame.BusChannel"] = [m.channel for m in msgs]
    rec["CAN_DataFrame.ID"] = [m.arbitration_id for m in msgs]
    rec["CAN_DataFrame.IDE"] = [m.is_extended_id for m in msgs]
    rec["CAN_DataFrame.DLC"] = [m.dlc for m in msgs]
    rec["CAN_DataFrame.DataLength"] = [len(m.data) for m in msgs]
    rec["CAN_DataFrame.DataBytes"] = [list(bytes(m.data).ljust(8, b"\0")) for m in msgs]
    t0 = msgs[0].timestamp
    mdf = MDF(version="4.10")
    from datetime import datetime, timezone
    mdf.header.start_time = datetime.fromtimestamp(t0, tz=timezone.utc)
    times = np.array([m.timestamp - t0 for m in msgs])
    mdf.append(Signal(name="CAN_DataFrame", samples=rec, timestamps=times,
                      source=Source(name="CAN", path="CAN", comment="", source_type=SOURCE_BUS, bus_type=BUS_TYPE_CAN)))
    mdf.save(os.path.join(out, "drive.mf4"), compression=2, overwrite=True)
    print(f"drive.mf4: {len(msgs)} frames in {time.time() - t:.1f} s")


if __name__ == "__main__":
    main()
