#!/usr/bin/env python3
"""Writes the seed corpora of the log-format fuzz targets (tests/fuzz/corpus/{asc,blf,mf4}/)
from the first frames of replay/clean/drive.log.gz plus a remote, an error, two CAN FD frames
and a second bus, with python-can's writers (MF4 through asammdf); then the layouts those
writers do not produce, made from these seeds: BLF with object header version 2 and 10 us
times (one container; stored containers of 1000 bytes), unfinalised MF4 (cut DT; DZ under a
DL with an unwritten link), an ASC classic frame of 64 bytes ("d 40"), and the logger layouts
of make_mf4_logger_seeds.py. Run from the repository:
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

import make_blf_variants  # noqa: E402
import make_unfinalised_mf4  # noqa: E402
sys.path.insert(0, os.path.dirname(__file__))
import make_mf4_logger_seeds  # noqa: E402


def write_layout_seeds():
    make_blf_variants.write_variant(os.path.join(out, "blf", "python_can.blf"), os.path.join(out, "blf", "v2_10us.blf"))
    make_blf_variants.write_variant(os.path.join(out, "blf", "python_can_stored.blf"),
                                    os.path.join(out, "blf", "v2_10us_stored.blf"), stored=True)
    make_unfinalised_mf4.unfinalise(os.path.join(out, "mf4", "asammdf_dt.mf4"), os.path.join(out, "mf4", "unfinalised_dt_cut.mf4"))
    make_unfinalised_mf4.unfinalise(os.path.join(out, "mf4", "asammdf_dz.mf4"), os.path.join(out, "mf4", "unfinalised_dz_dl.mf4"),
                                    dl=True)
    # (a start time of whole 100 ms: python-can writes "07:30:00.4" for 4 ms and reads it as 400 ms)
    write_with(can.ASCWriter(os.path.join(out, "asc", "classic_64_bytes.asc")),
               [dict(ns=frames[0]["ns"] + 123_000_000, bus="can0", id=0x123, ext=True, data=bytes(range(64)), remote=False, error=False,
                     fd=False, brs=False)])
    make_mf4_logger_seeds.main()


write_layout_seeds()
print(f"{len(frames)} frames written to {out}")
