"""fleet-report.html: one self-contained page for a fleet (docs/fleet.md). Per group, EG ± σ of
every vehicle as an inline SVG chart (the group's mean and spread as a band, outliers and
vehicles contradicting their prior marked), the vehicles' table with validity, adequacy and
gated hours, and the failed vehicles with their errors. No script, no link outside the page."""
from __future__ import annotations

import html
import math

import pandas as pd

_CSS = """body{font-family:system-ui,sans-serif;margin:1.5em;color:#222}table{border-collapse:collapse;margin:.5em 0 1.5em}
td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px;text-align:right}th{background:#f3f3f3}td.l{text-align:left}
tr.bad td{background:#fde8e8}tr.flag td{background:#fff4d6}.bar{display:inline-block;height:9px;background:#4a7;vertical-align:middle}
h2{margin-top:1.4em}.note{color:#666;font-size:13px}"""


def _f(x, fmt="{:.4f}") -> str:
    return "–" if x is None or (isinstance(x, float) and not math.isfinite(x)) else fmt.format(x)


def _chart(g: pd.DataFrame, prior: dict | None) -> str:
    """EG ± σ per vehicle (rows), the group's prior mean ± sd as a band."""
    g = g[g["error"] == ""]
    if g.empty:
        return ""
    lo = (g["eg_deg_per_g"] - 2 * g["eg_se_deg_per_g"]).min()
    hi = (g["eg_deg_per_g"] + 2 * g["eg_se_deg_per_g"]).max()
    band = (prior or {}).get("eg_deg_per_g")
    if band:
        lo, hi = min(lo, band["mean"] - 2 * band["sd"]), max(hi, band["mean"] + 2 * band["sd"])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return ""
    pad = 0.05 * (hi - lo) or 0.1
    lo, hi = lo - pad, hi + pad
    w, left, row_h = 640, 150, 18
    h = 30 + row_h * len(g)

    def x(v: float) -> float:
        return left + (w - left - 20) * (v - lo) / (hi - lo)

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-size="11">']
    if band:
        parts.append(f'<rect x="{x(band["mean"] - band["sd"]):.1f}" y="5" width="{x(band["mean"] + band["sd"]) - x(band["mean"] - band["sd"]):.1f}" '
                     f'height="{h - 25}" fill="#e4eefc"/><line x1="{x(band["mean"]):.1f}" x2="{x(band["mean"]):.1f}" y1="5" '
                     f'y2="{h - 20}" stroke="#7aa0d8"/>')
    for k, (_, r) in enumerate(g.iterrows()):
        y = 15 + row_h * k
        colour = "#c33" if r.get("eg_outlier") or r.get("prior_conflict") else ("#286" if r["valid"] else "#999")
        e, s = r["eg_deg_per_g"], r["eg_se_deg_per_g"]
        parts.append(f'<text x="4" y="{y + 4}">{html.escape(str(r["vehicle"]))}</text>')
        if math.isfinite(e) and math.isfinite(s):
            parts.append(f'<line x1="{x(e - s):.1f}" x2="{x(e + s):.1f}" y1="{y}" y2="{y}" stroke="{colour}" stroke-width="2"/>'
                         f'<circle cx="{x(e):.1f}" cy="{y}" r="3.5" fill="{colour}"/>')
        truth = r.get("truth_eg_deg_per_g")
        if truth is not None and math.isfinite(truth):
            parts.append(f'<path d="M{x(truth):.1f} {y - 6}v12" stroke="#000" stroke-dasharray="2,2"/>')
    for v in (lo + pad, (lo + hi) / 2, hi - pad):
        parts.append(f'<text x="{x(v):.1f}" y="{h - 4}" text-anchor="middle">{v:.2f}</text>')
    parts.append("</svg>")
    return "".join(parts)


def _table(g: pd.DataFrame) -> str:
    cols = ["vehicle", "EG [deg/g]", "σ", "valid", "group z", "prior distance", "adequacy", "gated h", "drives", "RMSE val [m/s²]", "reason"]
    rows = ["<tr>" + "".join(f"<th>{c}</th>" for c in cols) + "</tr>"]
    max_h = max(1.0, float(g["gated_hours"].max() or 1.0)) if g["gated_hours"].notna().any() else 1.0
    for _, r in g.iterrows():
        cls = "bad" if r["error"] else ("flag" if r.get("eg_outlier") or r.get("prior_conflict") else "")
        hours = r["gated_hours"] if math.isfinite(r["gated_hours"]) else 0.0
        bar = f'<span class="bar" style="width:{60 * hours / max_h:.0f}px"></span> {_f(hours, "{:.2f}")}'
        flag = " outlier" if r.get("eg_outlier") else ""
        prior = _f(r.get("prior_distance"), "{:.1f}") + (" contradicts" if r.get("prior_conflict") else "")
        cells = [html.escape(str(r["vehicle"])), _f(r["eg_deg_per_g"]), _f(r["eg_se_deg_per_g"]), "yes" if r["valid"] else "no",
                 _f(r.get("eg_z"), "{:+.1f}") + flag, prior, html.escape(str(r["adequacy_state"])), bar,
                 f'{r["drives_used"]}/{r["drives"]}', _f(r["rmse_validation_mps2"], "{:.4f}"),
                 html.escape(str(r["error"] or r["reason"]))]
        rows.append(f'<tr class="{cls}">' + "".join(
            f'<td class="{"l" if i in (0, 6, 10) else ""}">{c}</td>' for i, c in enumerate(cells)) + "</tr>")
    return "<table>" + "".join(rows) + "</table>"


def render(table: pd.DataFrame, priors: dict) -> str:
    n_fail = int((table["error"] != "").sum())
    body = [f"<h1>ndsid fleet: {len(table)} vehicles</h1>",
            f'<p class="note">{len(table) - n_fail} identified, {n_fail} failed; valid EG: {int(table["valid"].sum())}. '
            "Chart: EG ± σ per vehicle, the group's prior mean ± sd as a band (with at least three usable vehicles), "
            "the simulator's truth dashed where known; red: an outlier of its group (|z| &gt; 3) or a vehicle "
            "contradicting its prior.</p>"]
    for group, g in table.groupby("group", sort=True):
        prior = priors.get(group)
        title = html.escape(str(group) or "(no group)")
        eg = (prior or {}).get("eg_deg_per_g")
        sub = f" — group EG {eg['mean']:.4f} ± {eg['sd']:.4f} deg/g over {len(prior['vehicles'])} vehicles" if eg else ""
        body += [f"<h2>{title}{sub}</h2>", _chart(g, prior), _table(g)]
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>ndsid fleet</title><style>{_CSS}</style></head>"
            f"<body>{''.join(body)}</body></html>\n")


def write_report(table: pd.DataFrame, priors: dict, path: str) -> None:
    with open(path, "w", encoding="utf-8") as f:
        f.write(render(table, priors))
