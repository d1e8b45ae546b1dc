#!/usr/bin/env python3
"""scripts/ndsid-foxglove end to end: LCM messages of the ndsid types published on a private
udpm group reach a Foxglove WebSocket client (the Foxglove protocol, foxglove.sdk.v1,
spoken by the `websockets` client as the Foxglove app speaks it) field for field, with the
derived `params` object; a damaged message is counted and does not stop the bridge; the MCAP
recording holds the same messages (read with the `mcap` reader). Exit 77 (skipped) when the
generated LCM types, the Python packages or multicast loopback are missing."""
import json
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time

SRC = os.environ.get("NDSID_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
TYPES_PY = os.environ.get("NDSID_LCMTYPES_PYTHONPATH", "")
BRIDGE = os.path.join(SRC, "scripts", "ndsid-foxglove")


def skip(why):
    print(f"SKIPPED: {why}")
    sys.exit(77)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main():
    if not TYPES_PY or not os.path.exists(os.path.join(TYPES_PY, "ndsid", "estimate_t.py")):
        skip(f"generated Python LCM types not found ({TYPES_PY or 'NDSID_LCMTYPES_PYTHONPATH not set'})")
    try:
        import lcm
        from mcap.reader import make_reader
        from websockets.sync.client import connect
    except ImportError as e:
        skip(f"a Python package is missing ({e}); scripts/setup.sh installs it into .venv")
    sys.path.insert(0, TYPES_PY)
    from ndsid import estimate_t, monitor_t, status_t  # the generated LCM types

    url = f"udpm://239.255.76.67:{7700 + os.getpid() % 200}?ttl=0"
    lc = lcm.LCM(url)
    got = []
    lc.subscribe("NDSID_PROBE", lambda c, d: got.append(d))
    lc.publish("NDSID_PROBE", b"probe")
    deadline = time.time() + 2
    while not got and time.time() < deadline:
        if select.select([lc.fileno()], [], [], 0.2)[0]:
            lc.handle()
    if not got:
        skip("UDP multicast does not loop back here (ip link set lo multicast on; ip route add 239.0.0.0/8 dev lo)")

    est = estimate_t()
    est.utime = 1_709_537_400_000_000
    est.publish_utime = int(time.time() * 1e6)
    est.vehicle = "example-cmax"
    est.identifications = 7
    est.valid = True
    est.reason = ""
    est.eg_rad_per_mps2 = 0.0073125
    est.eg_sigma_rad_per_mps2 = 0.00012
    est.eg_deg_per_g = 4.1103
    est.eg_sigma_deg_per_g = 0.0675
    names = ["m", "Jz", "cv", "ch", "lv", "is"]
    est.num_params = len(names)
    est.param_name = names
    est.param_unit = ["kg", "kg m^2", "N/rad", "N/rad", "m", "-"]
    est.param_value = [1520.0, 2510.5, 98765.4, 123456.7, 1.13, 15.9]
    est.param_sigma = [0.0, 40.1, 812.0, 955.5, 0.0, 0.07]
    est.param_fixed = [True, False, False, False, True, False]
    est.param_at_bound = [False] * 6
    for field in estimate_t.__slots__:  # the rest at their defaults, whatever this version holds
        if not hasattr(est, field):
            setattr(est, field, getattr(estimate_t(), field))
    mon = monitor_t()
    mon.utime = est.utime + 20_000
    mon.lat_accel_mps2, mon.lat_accel_model_mps2 = 1.25, 1.21
    mon.yaw_rate_radps, mon.yaw_rate_model_radps = 0.061, 0.060
    mon.speed_mps, mon.steer_rad = 20.5, 0.31
    mon.model_valid, mon.verdict = True, "accepted"
    st = status_t()
    st.utime = est.utime
    st.vehicle, st.source, st.source_state = "example-cmax", "test", "OK"
    st.frames_read = 123456

    def publish_all():
        lc.publish("NDSID_ESTIMATE", est.encode())
        lc.publish("NDSID_MONITOR", mon.encode())
        lc.publish("NDSID_STATUS", st.encode())

    with tempfile.TemporaryDirectory() as tmp:
        rec = os.path.join(tmp, "live.mcap")
        port = free_port()
        bridge = subprocess.Popen([BRIDGE, "--lcm-url", url, "--port", str(port), "--mcap", rec],
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        ws = None
        try:
            line = bridge.stdout.readline()
            assert line.startswith("ndsid-foxglove: ws://"), line
            ws = connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], open_timeout=10)
            topics, received, docs, clock = {}, {}, {}, []  # clock: the server's time messages (op 0x02)
            server = {"capabilities": None}
            by_sub = {}

            def pump(publish, done, seconds):
                """Publish and read the WebSocket until done() or the time is up, recording every
                message: serverInfo, advertisements, the clock, and each subscription's messages."""
                deadline = time.time() + seconds
                while not done() and time.time() < deadline:
                    publish()
                    try:
                        m = ws.recv(timeout=0.3)
                    except TimeoutError:
                        continue
                    if isinstance(m, str):
                        op = json.loads(m)
                        if op.get("op") == "serverInfo":
                            server["capabilities"] = op.get("capabilities", [])
                        if op.get("op") == "advertise":
                            for ch in op["channels"]:
                                topics[ch["topic"]] = ch
                    elif m[0] == 0x01:
                        sub, log_time = struct.unpack_from("<IQ", m, 1)
                        doc = json.loads(m[13:])
                        received[by_sub[sub]] = (log_time, doc)
                        docs.setdefault(by_sub[sub], []).append(doc)
                    elif m[0] == 0x02:
                        clock.append(struct.unpack_from("<Q", m, 1)[0])

            # Channels are advertised when their first message arrives: publish until all three are.
            pump(publish_all, lambda: len(topics) >= 3, 20)
            assert set(topics) == {"/ndsid/estimate", "/ndsid/monitor", "/ndsid/status"}, topics
            assert topics["/ndsid/estimate"]["encoding"] == "json"
            schema = json.loads(topics["/ndsid/estimate"]["schema"])
            assert schema["properties"]["eg_deg_per_g"] == {"type": "number"}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": topics[t]["id"]} for i, t in enumerate(sorted(topics), start=1)]}))
            by_sub.update({i: t for i, t in enumerate(sorted(topics), start=1)})
            lc.publish("NDSID_ESTIMATE", b"\x00garbage")  # damaged: counted, not fatal
            pump(publish_all, lambda: len(received) >= 3, 20)
            assert set(received) == set(topics), received.keys()
            # The app's clock is the data clock: the bridge says it serves time, and its clock
            # is the newest data time it has seen (the monitor's, 20 ms after the estimate).
            assert server["capabilities"] is not None and "time" in server["capabilities"], server
            # The bridge moves the clock when the data time moves (as on a bus): each round here
            # publishes the monitor 20 ms later. A time message broadcast before the server had
            # registered this client is not resent, so the check waits for three of them.
            # (Up to 15 s: on a loaded machine the time messages trail the data; done() ends it early.)
            monitor_times = {mon.utime * 1000}

            def publish_later():
                mon.utime += 20_000
                monitor_times.add(mon.utime * 1000)
                publish_all()
            pump(publish_later, lambda: len(clock) >= 3, 15)
            assert len(clock) >= 3, clock
            assert set(clock) <= monitor_times, (clock[-5:], sorted(monitor_times)[-5:])
            assert all(b > a for a, b in zip(clock, clock[1:])), "the clock went backwards or stood"
            # Estimates do not move the clock (after a restart an estimate carries the learned
            # state's data time, maybe days old): each round published the estimate at the
            # status's time, first, and the clock never showed it.
            assert est.utime * 1000 not in clock, clock[:5]
            log_time, e = received["/ndsid/estimate"]
            assert log_time == est.utime * 1000  # the data time, in ns
            assert e["eg_deg_per_g"] == est.eg_deg_per_g and e["eg_rad_per_mps2"] == est.eg_rad_per_mps2
            assert e["param_value"] == est.param_value and e["vehicle"] == "example-cmax" and e["valid"] is True
            assert e["params"]["cv"] == {"value": 98765.4, "sigma": 812.0, "unit": "N/rad", "fixed": False,
                                         "at_bound": False}
            # The shipped layout (docs/foxglove/ndsid-layout.json) plots fields the bridge sends.
            with open(os.path.join(SRC, "docs", "foxglove", "ndsid-layout.json"), encoding="utf-8") as f:
                layout = json.load(f)
            paths = [p["value"] for c in layout["configById"].values() for p in c.get("paths", [])]
            paths += [c["topicPath"] for c in layout["configById"].values() if "topicPath" in c]
            assert len(paths) >= 5, paths
            for path in paths:
                topic, _, field = path.partition(".")
                assert topic in received, f"layout: {path}: no topic {topic}"
                assert not field or field in received[topic][1], f"layout: {path}: no field {field}"
            _, mo = received["/ndsid/monitor"]
            assert mo["lat_accel_model_mps2"] == 1.21 and mo["verdict"] == "accepted"
            assert json.loads(topics["/ndsid/monitor"]["schema"])["properties"]["lat_accel_model_mps2"] == {
                "type": "number"}
            # A sample the model did not evaluate (not gated): its model values arrive as null, not
            # as the 0 the daemon fills in, so a plot shows a gap rather than a model reading 0.
            ungated = monitor_t.decode(mon.encode())
            ungated.utime += 20_000
            ungated.model_valid, ungated.verdict = False, "below_min_speed"
            ungated.lat_accel_model_mps2 = ungated.yaw_rate_model_radps = 0.0
            def ungated_doc():
                return next((d for d in docs.get("/ndsid/monitor", []) if d["verdict"] == "below_min_speed"), None)
            pump(lambda: lc.publish("NDSID_MONITOR", ungated.encode()), lambda: ungated_doc() is not None, 10)
            got = ungated_doc()
            assert got is not None, "the ungated monitor sample did not arrive"
            assert got["lat_accel_model_mps2"] is None and got["yaw_rate_model_radps"] is None, got
            assert got["lat_accel_mps2"] == 1.25
            assert received["/ndsid/status"][1]["frames_read"] == 123456
        finally:
            # The client goes first, also when an assertion failed (an open connection can hold
            # up the server's shutdown, which would hide the failure behind a timeout).
            if ws is not None:
                ws.close()
            bridge.send_signal(signal.SIGINT)
            out, _ = bridge.communicate(timeout=20)
        assert bridge.returncode == 0, out
        assert "1 undecodable" in out, out
        forwarded = int(out.split("ndsid-foxglove: ")[-1].split(" messages forwarded")[0])
        assert forwarded >= 6, out
        with open(rec, "rb") as f:
            recorded = {}
            for _, channel, message in make_reader(f).iter_messages():
                recorded.setdefault(channel.topic, []).append(json.loads(message.data))
        assert set(recorded) == set(topics), recorded.keys()
        assert sum(len(v) for v in recorded.values()) == forwarded
        assert recorded["/ndsid/estimate"][0]["params"]["is"]["value"] == 15.9
    print(f"OK: 3 topics live and recorded, {forwarded} messages forwarded, 1 damaged message counted")


if __name__ == "__main__":
    main()
