#!/usr/bin/env python3
"""One line about an LCM log that lcm-logger recorded from ndsidd: the events per ndsid channel
and the last status decoded with the project's Python types (PYTHONPATH=<build>/lcmtypes/python).

    lcmlog_summary.py LOG

Used by tests/vm/systemd_unit_test.sh inside the amd64 VM, and on the host for the log the arm64
VM wrote (that VM has no Python LCM module). Exit 1 when no status with frames was recorded.
"""
import sys

import lcm
import ndsid


def main(path):
    n = {"NDSID_STATUS": 0, "NDSID_ESTIMATE": 0, "NDSID_MONITOR": 0}
    last = None
    for e in lcm.EventLog(path, "r"):
        if e.channel in n:
            n[e.channel] += 1
            if e.channel == "NDSID_STATUS":
                last = ndsid.status_t.decode(e.data)
    if last is None:
        print(f"{n} no status")
        return 1
    print(f"{n} last status: source {last.source!r} {last.source_state}, frames_read {last.frames_read}, "
          f"dropped {last.dropped}, drives {last.drives}, gated_hours {last.gated_hours:.5f}")
    return 0 if last.frames_read > 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
