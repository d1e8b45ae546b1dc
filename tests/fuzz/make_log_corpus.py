#!/usr/bin/env python3
"""Writes the seed corpora of the log-format fuzz targets (tests/fuzz/corpus/{asc,blf,mf4}/)
from the first frames of replay/clean/drive.log.gz plus a remote, an error, two CAN FD frames
and a second bus, with python-can's writers (MF4 through asammdf). Run from the repository:
    .venv/bin/python tests/fuzz/make_log_corpus.py
The frame_log gtest reads the MF4 seeds as fixtures (they were written by asammdf, not by us).
"""
import os
import sys
import time

os.environ["TZ"] = "UTC"
time.tzset()
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "can"))
import can  # noqa: E402
from can.io.mf4 import MF4Writer  # noqa: E402
from log_formats_crosscheck import add_special_frames, read_slice, write_with  # noqa: E402

root = os.path.join(os.path.dirname(__file__), "..", "..")
frames = add_special_frames(read_slice(os.path.join(root, "replay/clean/drive.log.gz"), 60))
out = os.path.join(os.path.dirname(__file__), "corpus")
for sub in ("asc", "blf", "mf4"):
    os.makedirs(os.path.join(out, sub), exist_ok=True)
write_with(can.ASCWriter(os.path.join(out, "asc", "python_can.asc")), frames)
write_with(can.BLFWriter(os.path.join(out, "blf", "python_can.blf")), frames)
write_with(can.BLFWriter(os.path.join(out, "blf", "python_can_stored.blf"), compression_level=0), frames[:20])
write_with(MF4Writer(os.path.join(out, "mf4", "asammdf_dt.mf4"), compression_level=0), frames)
write_with(MF4Writer(os.path.join(out, "mf4", "asammdf_dz.mf4"), compression_level=2), frames)
print(f"{len(frames)} frames written to {out}")
