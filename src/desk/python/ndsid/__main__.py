"""python -m ndsid: the interchange exports (ndsid.export) from a shell.

    python -m ndsid decode --dbc car.dbc --log drive.log.gz --out signals.parquet [--wide [--rate-hz 50]]
    python -m ndsid decode --dbc car.dbc --log drive.blf --out signals.mf4
    python -m ndsid compare --config car.yaml [--log F ...] [--effects a,b] [--baseline a] --out DIR
    python -m ndsid encode --csv run1.csv [run2.csv ...] --dbc dbc/timeseries.dbc --map map.yaml --out drive.log.gz

The output's extension chooses the format (.parquet or .mf4). Exit 0 on success, 78 on a
configuration or argument error (as the C++ CLI), 1 on any other error, each with one message.
"""
from __future__ import annotations

import argparse
import os
import sys

EXIT_CONFIG = 78


def _names(text: str | None) -> list[str] | None:
    if text is None:
        return None
    return [] if text in ("", "none") else [n for n in text.split(",") if n]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m ndsid", description="ndsid exports: Parquet and MDF 4")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("decode", help="decoded signals of a CAN log to .parquet or .mf4")
    d.add_argument("--dbc", required=True)
    d.add_argument("--log", required=True, help="candump (plain or gzip), Vector ASC/BLF, ASAM MF4 bus logging")
    d.add_argument("--out", required=True, help="output file: .parquet or .mf4")
    d.add_argument("--bus", default="", help="only frames of this interface (default: all)")
    d.add_argument("--wide", action="store_true", help="Parquet: one column per message.signal")
    d.add_argument("--rate-hz", type=float, help="Parquet, with --wide: resample onto this uniform grid")
    c = sub.add_parser("compare", help="compare's samples and where-it-fails bins as Parquet, and its summary")
    c.add_argument("--config", required=True)
    c.add_argument("--log", nargs="*", default=None)
    c.add_argument("--effects", help="the model's effects, comma-separated (default: the config's; 'none': base)")
    c.add_argument("--baseline", default="", help="the baseline's effects (default: the base model)")
    c.add_argument("--out", required=True, help="output folder")
    e = sub.add_parser("encode", help="decoded time series (CSV) onto a DBC, as a candump log (ndsid.encode)")
    e.add_argument("--csv", nargs="+", required=True, help="CSV files, one drive each, in this order")
    e.add_argument("--dbc", required=True)
    e.add_argument("--map", required=True, help="YAML: time column, and per MESSAGE.SIGNAL its column [scale, offset]")
    e.add_argument("--out", required=True, help="candump log (.log, or .log.gz for gzip)")
    a = p.parse_args(argv)

    import ndsid
    from ndsid import export

    try:
        if a.command == "decode":
            ext = os.path.splitext(a.out)[1].lower()
            if ext not in (".parquet", ".mf4"):
                raise ndsid.ConfigError(f"--out {a.out}: the extension must be .parquet or .mf4")
            if ext == ".mf4" and (a.wide or a.rate_hz is not None):
                raise ndsid.ConfigError("--wide and --rate-hz are for Parquet; MDF 4 keeps each message's own time stamps")
            if a.rate_hz is not None and not a.wide:
                raise ndsid.ConfigError("--rate-hz needs --wide")
            if ext == ".parquet":
                df = export.decode_to_parquet(a.log, a.dbc, a.out, bus=a.bus, wide=a.wide, rate_hz=a.rate_hz)
                print(f"{a.out}: {len(df)} rows, {len(df.columns)} columns ({df.attrs.get('frames')} frames)")
            else:
                n = export.decode_to_mf4(a.log, a.dbc, a.out, bus=a.bus)
                print(f"{a.out}: {n} channels")
        elif a.command == "encode":
            from ndsid import encode
            try:
                n = encode.encode_csv(a.csv, a.dbc, a.map, a.out)
            except (ValueError, KeyError) as err:
                raise ndsid.ConfigError(str(err)) from None
            print(f"{a.out}: {n['frames']} frames from {n['files']} files ({n['seconds']:.1f} s of data, "
                  f"{n['clipped']} values clipped to their signal's range)")
        else:
            out = export.compare_to_parquet(a.config, a.out, a.log, effects=_names(a.effects),
                                            baseline=_names(a.baseline) or [])
            print("\n".join(f"{k}: {v}" for k, v in out.items()))
    except ndsid.ConfigError as e:
        print(f"python -m ndsid {a.command}: {e}", file=sys.stderr)
        return EXIT_CONFIG
    except (ndsid.Error, OSError) as e:
        print(f"python -m ndsid {a.command}: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
