"""ndsid-foxglove: the daemon's LCM channels live in Foxglove (docs/monitoring.md, "Foxglove").

Subscribes to ndsidd's LCM channels (estimate, status, monitor), decodes each message with the
ndsid LCM types and serves it as JSON on a Foxglove WebSocket server (foxglove-sdk), so the
Foxglove app (desktop or web, "Open connection" -> Foxglove WebSocket -> ws://HOST:PORT) plots
EG ± σ, every parameter, measured against modelled a_y and yaw rate, and the counters live.
With --mcap FILE the same messages are recorded as MCAP (what Foxglove opens offline).

    scripts/ndsid-foxglove [--lcm-url URL] [--host 127.0.0.1] [--port 8765] [--mcap FILE]

Topics: /ndsid/estimate, /ndsid/status, /ndsid/monitor (the LCM channel names are options).
Each message is the LCM struct's fields as JSON (arrays as lists), log time = its data time
(utime; a message without one, such as the estimate before the first fit, takes the newest data
time seen); estimate adds `params`, an object {name: {value, sigma, unit, fixed, at_bound}}, so a
plot path reads /ndsid/estimate.params.cv.value. A channel is advertised with its JSON schema
(derived from the first message) when its first message arrives. The monitor channel is already
rate-limited in wall-clock time by the daemon (lcm.monitor_rate_hz); --monitor-max-hz limits it
again here.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import select
import signal
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def load_lcm_types(folder: str | None) -> dict:
    """The generated Python LCM types (estimate_t, status_t, monitor_t), loaded by file path:
    their package is also called ndsid, like the Python API's."""
    candidates = [folder] if folder else [
        os.path.join(HERE, "..", "build", "lcmtypes", "python", "ndsid"),  # the source tree
        os.path.join(HERE, "..", "..", "..", "lib", "python3", "dist-packages", "ndsid"),  # installed: <prefix>/share/ndsid/foxglove
        "/usr/lib/python3/dist-packages/ndsid",
    ]
    for d in candidates:
        if d and os.path.exists(os.path.join(d, "estimate_t.py")):
            types = {}
            for name in ("estimate_t", "status_t", "monitor_t"):
                spec = importlib.util.spec_from_file_location(f"ndsid_lcm_{name}", os.path.join(d, f"{name}.py"))
                module = importlib.util.module_from_spec(spec)
                spec.loader.exec_module(module)
                types[name] = getattr(module, name)
            return types
    raise SystemExit("ndsid-foxglove: no generated LCM types (build them: cmake --build build --target "
                     "ndsid_lcmtypes_python; or pass --lcm-types DIR)")


MODEL_FIELDS = ("lat_accel_model_mps2", "yaw_rate_model_radps")


def to_json(msg) -> dict:
    """An LCM message as a JSON object: its fields, arrays as lists, bytes as text."""
    out = {}
    for field in msg.__slots__:
        v = getattr(msg, field)
        if isinstance(v, (list, tuple, map)):  # lcm-gen's decoders return arrays as map objects
            v = list(v)
        elif isinstance(v, bytes):
            v = v.decode("utf-8", "replace")
        out[field] = v
    # The monitor's model values are 0 where the model was not evaluated (model_valid false: no
    # estimate yet, or the sample was not gated, e.g. below the minimum speed). Sent as null, so
    # a plot shows a gap there instead of a model that reads 0.
    if out.get("model_valid") is False:
        for k in MODEL_FIELDS:
            if k in out:
                out[k] = None
    if "param_name" in out and "param_value" in out:
        n = len(out["param_name"])
        keys = [k for k in ("param_value", "param_sigma", "param_unit", "param_fixed", "param_at_bound") if k in out]
        out["params"] = {out["param_name"][i]: {k[len("param_"):]: out[k][i] for k in keys if i < len(out[k])}
                         for i in range(n)}
    return out


def json_schema(value) -> dict:
    """A JSON schema for a decoded message (from its values: LCM types carry no type names in
    Python)."""
    if isinstance(value, bool):
        return {"type": "boolean"}
    if isinstance(value, int):
        return {"type": "integer"}
    if isinstance(value, float):
        return {"type": "number"}
    if isinstance(value, str):
        return {"type": "string"}
    if isinstance(value, list):
        return {"type": "array", "items": json_schema(value[0]) if value else {}}
    if isinstance(value, dict):
        # The model fields are numbers also when the first message has them null (Foxglove's
        # schema parser takes no type lists such as ["number", "null"]).
        return {"type": "object", "properties": {k: {"type": "number"} if k in MODEL_FIELDS else json_schema(v)
                                                 for k, v in value.items()}}
    return {}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="ndsid-foxglove", description=__doc__.split("\n\n")[0])
    p.add_argument("--lcm-url", default=os.environ.get("LCM_DEFAULT_URL", ""),
                   help="LCM provider (default: $LCM_DEFAULT_URL or LCM's default udpm)")
    p.add_argument("--host", default="127.0.0.1", help="WebSocket address (0.0.0.0: every interface)")
    p.add_argument("--port", type=int, default=8765, help="WebSocket port (0: any free one, printed)")
    p.add_argument("--mcap", help="also record the messages to this MCAP file")
    p.add_argument("--estimate-channel", default="NDSID_ESTIMATE")
    p.add_argument("--status-channel", default="NDSID_STATUS")
    p.add_argument("--monitor-channel", default="NDSID_MONITOR")
    p.add_argument("--monitor-max-hz", type=float, default=0, help="forward the monitor at most this often (0: all)")
    p.add_argument("--lcm-types", help="folder of the generated Python LCM types (estimate_t.py, ...)")
    a = p.parse_args(argv)
    if not 0 <= a.port < 65536:
        print(f"ndsid-foxglove: --port {a.port}: out of range 0-65535", file=sys.stderr)
        return 78
    if a.monitor_max_hz < 0:
        print(f"ndsid-foxglove: --monitor-max-hz {a.monitor_max_hz}: must be >= 0", file=sys.stderr)
        return 78

    import foxglove
    import lcm

    types = load_lcm_types(a.lcm_types)
    routes = {a.estimate_channel: ("/ndsid/estimate", types["estimate_t"]),
              a.status_channel: ("/ndsid/status", types["status_t"]),
              a.monitor_channel: ("/ndsid/monitor", types["monitor_t"])}
    from foxglove.websocket import Capability

    # Capability.Time: the app's clock is the data time the bridge broadcasts (below), so a live
    # view's time axis is the car's, also for a replay faster than real time. Without it the app
    # stamps every message with its own wall clock when it arrives.
    server = foxglove.start_server(name="ndsid", host=a.host, port=a.port, capabilities=[Capability.Time])
    mcap = foxglove.open_mcap(a.mcap, allow_overwrite=True) if a.mcap else None
    channels: dict = {}
    counts = {"forwarded": 0, "undecodable": 0, "failed": 0, "rate_limited": 0}
    last_monitor = [0.0]
    last_log_ns = [0]

    def on_message(channel: str, data: bytes) -> None:
        topic, cls = routes[channel]
        if channel == a.monitor_channel and a.monitor_max_hz > 0:
            now = time.monotonic()
            if now - last_monitor[0] < 1.0 / a.monitor_max_hz:
                counts["rate_limited"] += 1
                return
            last_monitor[0] = now
        try:
            msg = to_json(cls.decode(data))
        except Exception:  # a foreign or damaged message on our channel: counted, never fatal
            counts["undecodable"] += 1
            return
        try:
            if topic not in channels:
                schema = json_schema(msg)
                schema["title"] = f"ndsid.{cls.__name__}"
                channels[topic] = foxglove.Channel(topic, schema=schema, message_encoding="json")
            # Log time: the message's data time; one without (utime 0: no data yet) takes the
            # newest data time seen, never the wall clock, which is another time base.
            utime = msg.get("utime", 0)
            if isinstance(utime, int) and utime > 0 and utime * 1000 > last_log_ns[0]:
                last_log_ns[0] = utime * 1000
                # The app's clock: the newest data time of the bus (status, monitor). Not the
                # estimate's, which after a restart is the learned state's, maybe days old: the
                # app's time line would start there.
                if channel != a.estimate_channel:
                    server.broadcast_time(last_log_ns[0])
            channels[topic].log(msg, log_time=utime * 1000 if isinstance(utime, int) and utime > 0 else last_log_ns[0])
        except Exception as e:  # never fatal: counted, the first one said
            counts["failed"] += 1
            if counts["failed"] == 1:
                print(f"ndsid-foxglove: {topic}: could not forward: {e}", file=sys.stderr, flush=True)
            return
        counts["forwarded"] += 1

    lc = lcm.LCM(a.lcm_url) if a.lcm_url else lcm.LCM()
    for channel in routes:
        lc.subscribe(channel, on_message)
    stop = [False]

    def on_signal(*_):
        stop[0] = True

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    print(f"ndsid-foxglove: ws://{a.host}:{server.port} <- LCM {a.lcm_url or '(default)'} "
          f"{', '.join(routes)}" + (f"; recording {a.mcap}" if a.mcap else ""), flush=True)
    while not stop[0]:
        try:
            if select.select([lc.fileno()], [], [], 0.2)[0]:
                lc.handle()
        except InterruptedError:
            continue
    if mcap:
        mcap.close()
    server.stop()
    print(f"ndsid-foxglove: {counts['forwarded']} messages forwarded, {counts['undecodable']} undecodable, "
          f"{counts['failed']} failed, {counts['rate_limited']} monitor messages rate-limited", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
