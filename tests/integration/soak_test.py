#!/usr/bin/env python3
"""Soak test of ndsidd (ctest label `long`): HOURS of simulated driving
(default 24) replayed at 300x recorded speed (as fast as it goes takes ~10 s for 24 h, too
short for restarts; NDSID_SOAK_SPEED sets it), with a SIGHUP every 5 s and a SIGKILL + restart every
15 s of wall time, persisting every 2 s. Samples the daemon's resident memory and open file
descriptors once a second. At the end:

- nothing lost: the final gated hours equal those of a reference run without kills (the same
  log and configuration, identification only at the end), and they never fall across restarts;
- the final EG equals the reference's within 0.1 sigma;
- memory and file descriptors flat once the window (identification.window_h: 4) is full: the
  largest RSS in the last half of the run at most 1.25x the largest in the second quarter,
  descriptors constant within 2.

    soak_test.py [HOURS]      (environment as for daemon_test.py; figures printed, and a CSV of
                               the samples written to $NDSID_SOAK_CSV when set)
"""
import csv
import os
import re
import signal
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import daemon_test as dt  # noqa: E402  (Case, show_state, final_eg, ...)


def rss_kb(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def fds(pid):
    try:
        return len(os.listdir(f"/proc/{pid}/fd"))
    except OSError:
        return None


def config(case, name, state, period_s):
    path = case.config(name, state=state, url="memq://", period_s=period_s)
    window_h = os.environ.get("NDSID_SOAK_WINDOW_H", "4")  # e.g. 20 (the default) to size MemoryMax
    text = open(path).read().replace("identification:\n", f"identification:\n  window_h: {window_h}\n", 1)
    open(path, "w").write(text)
    return path


def main():
    hours = float(sys.argv[1]) if len(sys.argv) > 1 else 24.0
    drive_s = 900
    drives = max(2, int(round(hours * 3600 / drive_s)))
    t_gen = time.time()
    case = dt.Case("soak", drives=drives, drive_s=drive_s)
    print(f"log: {drives} drives of {drive_s} s ({drives * drive_s / 3600:.1f} h of driving), "
          f"{os.path.getsize(case.log) / 1e6:.0f} MB, written in {time.time() - t_gen:.1f} s", flush=True)
    try:
        # Reference: the same data, identification only at the end, no signals.
        ref_cfg = config(case, "ref.yaml", "state_ref", 1e7)
        t = time.time()
        ref = case.run(ref_cfg, timeout=3600)
        dt.check(ref.returncode == 0, ref.stderr[-3000:])
        eg_ref, hours_ref = dt.final_eg(ref.stdout), dt.final_hours(ref.stdout)
        sigma_ref = float(re.search(r"sigma=(\S+)", ref.stdout).group(1))
        print(f"reference: EG {eg_ref:.6e} ± {sigma_ref:.2e}, {hours_ref:.4f} gated h, {time.time() - t:.0f} s", flush=True)

        cfg = config(case, "soak.yaml", "state", 600)
        samples = []  # (wall s, pid, rss kB, fds, event)
        kills = hups = 0
        hours_seen = []
        t0 = time.time()
        last_hup = last_kill = t0
        speed = os.environ.get("NDSID_SOAK_SPEED", "300")
        hup_s = float(os.environ.get("NDSID_SOAK_HUP_S", "5"))     # 0: no SIGHUP
        kill_s = float(os.environ.get("NDSID_SOAK_KILL_S", "15"))  # 0: no SIGKILL
        proc = case.start(cfg, "--persist-interval-s", "2", "--speed", speed)
        while True:
            time.sleep(1.0)
            now = time.time()
            if proc.poll() is not None:
                out, err = proc.communicate()
                if proc.returncode != 0:
                    raise AssertionError(f"ndsidd exited {proc.returncode}:\n{err[-3000:]}")
                break
            samples.append((now - t0, proc.pid, rss_kb(proc.pid), fds(proc.pid), ""))
            if kill_s > 0 and now - last_kill >= kill_s:
                proc.kill()
                proc.communicate()
                kills += 1
                last_kill = now
                st = dt.show_state(case, cfg)
                hours_seen.append(float(st.get("gated_hours", "0") or 0))
                samples.append((time.time() - t0, proc.pid, None, None, "SIGKILL"))
                proc = case.start(cfg, "--persist-interval-s", "2", "--speed", speed)
            elif hup_s > 0 and now - last_hup >= hup_s:
                proc.send_signal(signal.SIGHUP)
                hups += 1
                last_hup = now
                samples.append((now - t0, proc.pid, None, None, "SIGHUP"))
        wall = time.time() - t0
        eg, hrs = dt.final_eg(out), dt.final_hours(out)
        measured = [s for s in samples if s[2] is not None]
        n = len(measured)
        q2 = [s[2] for s in measured[n // 4: n // 2]] or [0]
        late = [s[2] for s in measured[n // 2:]] or [0]
        fd_values = [s[3] for s in measured[n // 4:] if s[3] is not None] or [0]
        print(f"soak: {wall:.0f} s wall, {kills} SIGKILLs, {hups} SIGHUPs; RSS max {max(q2) / 1024:.1f} MB in the "
              f"second quarter, {max(late) / 1024:.1f} MB in the last half (overall {max(s[2] for s in measured) / 1024:.1f} MB); "
              f"fds {min(fd_values)}..{max(fd_values)}; final EG {eg:.6e} ({(eg - eg_ref) / sigma_ref:+.3f} sigma), "
              f"{hrs:.4f} gated h (reference {hours_ref:.4f})", flush=True)
        if os.environ.get("NDSID_SOAK_CSV"):
            with open(os.environ["NDSID_SOAK_CSV"], "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(["wall_s", "pid", "rss_kb", "fds", "event"])
                w.writerows(samples)
        dt.check(all(b >= a - 1e-9 for a, b in zip(hours_seen, hours_seen[1:])), f"gated hours fell across a restart: {hours_seen}")
        dt.check(abs(hrs - hours_ref) * 3600 <= 1.0, "gated time lost or counted twice")
        dt.check(abs(eg - eg_ref) <= 0.1 * sigma_ref, "final EG differs from the reference by more than 0.1 sigma")
        dt.check(max(late) <= 1.25 * max(q2), "memory grew after the window was full")
        dt.check(max(fd_values) - min(fd_values) <= 2, "file descriptors grew")
    finally:
        case.cleanup()


if __name__ == "__main__":
    try:
        main()
        print("PASS soak")
    except dt.Skip as e:
        print(f"SKIP soak: {e}")
        sys.exit(dt.SKIP)
    except AssertionError as e:
        print(f"FAIL soak: {e}")
        sys.exit(1)
