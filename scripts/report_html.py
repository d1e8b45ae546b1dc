#!/usr/bin/env python3
"""One self-contained HTML report (docs/model-workflow.md, "One report"): what `ndsid replay`,
`ndsid compare` and `ndsid diagnose` wrote into their folders, on one page with interactive
plots (plotly, its JavaScript embedded: the file opens offline, nothing is fetched).

    report_html.py --out report.html [--replay DIR] [--compare DIR] [--diagnose DIR]
                   [--truth truth.yaml] [--title TEXT]

Sections, each from the folders that hold it: summary (EG ± σ, adequacy, truth), the model
(effects, every parameter ± σ, bounds hit, identifiability notes, plausibility), the data set
(drives, gated hours, gate counters, coverage), the adequacy history, where it fails (binned
residual tables for a_y and the yaw rate, a held-out stretch measured against modelled), the
error ladder (rungs, every candidate tried with why it was added or rejected, the ranking, the
verdicts), and the simulator's truth where a truth.yaml is given. Called by the ndsid commands
(src/desk/html_report.cc); exit 0, or 1 with a message when an input cannot be read.
"""
from __future__ import annotations

import argparse
import csv
import datetime
import html
import json
import math
import os
import sys

DEG_PER_G = 180.0 / math.pi * 9.81  # as ndsid's EG in deg/g (model::EgToDegPerG)


def esc(x) -> str:
    return html.escape(str(x))


def num(x, fmt="{:.4g}") -> str:
    if x is None:
        return ""
    try:
        if isinstance(x, float) and not math.isfinite(x):
            return "–"
        return fmt.format(x)
    except (ValueError, TypeError):
        return esc(x)


def read_csv(path: str) -> list[dict]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def read_json(path: str) -> dict:
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def table(header: list[str], rows: list[list], classes: list[str] | None = None) -> str:
    h = "<table><tr>" + "".join(f"<th>{esc(c)}</th>" for c in header) + "</tr>\n"
    for i, r in enumerate(rows):
        cls = f' class="{classes[i]}"' if classes and classes[i] else ""
        h += f"<tr{cls}>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>\n"
    return h + "</table>\n"


class Page:
    def __init__(self, title: str):
        import plotly.offline

        self.title = title
        self.parts: list[str] = []
        self.toc: list[tuple[str, str]] = []
        self.figures = 0
        self.plotlyjs = plotly.offline.get_plotlyjs()

    def section(self, anchor: str, title: str) -> None:
        self.toc.append((anchor, title))
        self.parts.append(f'<h2 id="{anchor}">{esc(title)}</h2>\n')

    def add(self, text: str) -> None:
        self.parts.append(text)

    def figure(self, fig, caption: str) -> None:
        self.figures += 1
        div = fig.to_html(full_html=False, include_plotlyjs=False, div_id=f"fig{self.figures}",
                          config={"displaylogo": False, "responsive": True})
        self.parts.append(f'<figure class="plot">{div}<figcaption>{caption}</figcaption></figure>\n')

    def html(self) -> str:
        style = ("body{font-family:sans-serif;max-width:1250px;margin:auto;padding:0 1em}"
                 "table{border-collapse:collapse;font-size:13px;margin:.5em 0}"
                 "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}td:first-child,th:first-child{text-align:left}"
                 "tr.fail td{background:#f6c0c0}tr.few td{color:#999}tr.added td{background:#d8f0d0}"
                 "figure{margin:1em 0}figcaption{font-size:13px;color:#444}.note{color:#555;font-size:13px}"
                 "nav a{margin-right:1em}")
        toc = "".join(f'<a href="#{a}">{esc(t)}</a>' for a, t in self.toc)
        made = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
                f"<title>{esc(self.title)}</title><style>{style}</style>\n"
                f"<script type=\"text/javascript\">{self.plotlyjs}</script></head><body>\n"
                f"<h1>{esc(self.title)}</h1><p class=note>written {made} by ndsid; self-contained (plots "
                f"embedded, zoom and pan with the mouse)</p><nav>{toc}</nav>\n" + "".join(self.parts) +
                "</body></html>\n")


def estimate_of(replay: str | None) -> dict | None:
    if replay and os.path.exists(os.path.join(replay, "estimate.json")):
        return read_json(os.path.join(replay, "estimate.json"))
    return None


TRUTH_KEYS = {"m": ("mass_kg", 1), "Jz": ("yaw_inertia_kgm2", 1), "cv": ("cornering_stiffness_front_npr", 1),
              "ch": ("cornering_stiffness_rear_npr", 1), "lv": ("cg_to_front_m", 1), "is": ("steering_ratio", 1)}


def truth_value(truth: dict | None, name: str):
    if not truth:
        return None
    if name in TRUTH_KEYS:
        return truth.get("vehicle", {}).get(TRUTH_KEYS[name][0])
    return None


def summary_section(page: Page, est: dict | None, cmp: dict | None, dia: dict | None, truth: dict | None) -> None:
    page.section("summary", "Summary")
    rows = []
    if est:
        rows.append(["EG (replay, final fit)", f"{num(est.get('eg_deg_per_g'), '{:.4f}')} ± {num(est.get('eg_se_deg_per_g'), '{:.4f}')} deg/g",
                     esc(est.get("model", ""))])
        ad = est.get("adequacy", {})
        rows.append(["adequacy", f"<b>{esc(ad.get('state', ''))}</b>", esc(ad.get("explanation", ""))])
        rows.append(["RMSE a_y train / held-out", f"{num(est.get('rmse_train_mps2'), '{:.4f}')} / "
                     f"{num(est.get('rmse_validation_mps2'), '{:.4f}')} m/s²", ""])
        rows.append(["gated hours", num(est.get("gated_hours"), "{:.3f}"), f"window {num(est.get('window_hours'), '{:.3f}')} h"])
        rows.append(["estimate valid", "yes" if est.get("valid") else "<b>no</b>", esc(est.get("reason", ""))])
    if cmp:
        for m in cmp.get("models", []):
            rows.append([f"EG (compare, {esc(m.get('label'))})", f"{num(m.get('eg_deg_per_g'), '{:.4f}')} ± {num(m.get('eg_se_deg_per_g'), '{:.4f}')} deg/g",
                         esc(m.get("model", ""))])
    if dia and dia.get("ladder"):
        top = dia["ladder"][-1]
        rows.append(["EG (diagnose, the ladder's last rung)", f"{num(top.get('eg_deg_per_g'), '{:.4f}')} ± "
                     f"{num(top.get('eg_se_deg_per_g'), '{:.4f}')} deg/g", esc(top.get("model", ""))])
    if truth:
        eg_t = truth.get("vehicle", {}).get("self_steer_gradient_rad_per_mps2")
        if eg_t is not None:
            extra = ""
            if est and est.get("eg_rad_per_mps2"):
                err = est["eg_rad_per_mps2"] - eg_t
                sd = est.get("eg_se_rad_per_mps2") or float("nan")
                extra = f"estimate off by {100 * err / eg_t:+.2f} % = {err / sd:+.1f} σ"
            rows.append(["EG truth (simulator)", f"{eg_t * DEG_PER_G:.4f} deg/g", extra])
    page.add(table(["", "value", "note"], rows) if rows else "<p>No estimate in the inputs.</p>\n")


def model_section(page: Page, est: dict, truth: dict | None) -> None:
    page.section("model", "Model")
    page.add(f"<p>Model: <b>{esc(est.get('model', ''))}</b>; effects: {esc(', '.join(est.get('effects', [])) or 'none')}; "
             f"outputs: {'a_y and yaw rate' if est.get('yaw_rate_output') else 'a_y'}; standard errors: {esc(est.get('se_method', ''))}.</p>\n")
    rows, classes = [], []
    for p in est.get("parameters", []):
        t = truth_value(truth, p["name"])
        note = "fixed" if p.get("fixed") else ("<b>at its bound</b>" if p.get("at_bound") else "")
        rows.append([esc(p["name"]), num(p["value"], "{:.6g}"), num(p["se"], "{:.3g}"), esc(p.get("unit", "")), note,
                     num(t, "{:.6g}") if t is not None else ""])
        classes.append("fail" if p.get("at_bound") else "")
    page.add(table(["parameter", "value", "σ", "unit", "note", "truth"], rows, classes))
    ident = est.get("identifiability", {})
    notes = ident.get("notes", [])
    page.add(f"<p>Identifiability: condition number {num(ident.get('condition_number'), '{:.3g}')}; singular values "
             f"{esc(', '.join(num(s, '{:.3g}') for s in ident.get('singular_values', [])))}.</p>\n")
    if ident.get("weak"):
        page.add("<p>Weak directions: " + esc("; ".join(map(str, ident["weak"]))) + "</p>\n")
    if notes:
        page.add("<ul>" + "".join(f"<li>{esc(n)}</li>" for n in notes) + "</ul>\n")
    pl = est.get("plausibility", {})
    checks = pl.get("checks", []) if isinstance(pl, dict) else []
    if checks:
        rows = [[esc(c.get("name", "")), esc(c.get("verdict", "")), num(c.get("value")), esc(c.get("message", ""))]
                for c in checks]
        page.add("<h3>Plausibility</h3>\n" + table(["check", "verdict", "value", "detail"], rows,
                                                   ["fail" if c.get("verdict") == "failed" else "" for c in checks]))


def data_section(page: Page, replay: str, est: dict | None) -> None:
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    page.section("data", "Data set")
    drives_csv = os.path.join(replay, "drives.csv")
    if os.path.exists(drives_csv):
        drives = read_csv(drives_csv)
        rows = [[esc(d["drive"]), datetime.datetime.fromtimestamp(float(d["start_s"]), datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S"),
                 num(float(d["duration_s"]), "{:.0f}"), num(float(d["distance_km"]), "{:.2f}"), num(float(d["gated_s"]), "{:.0f}"),
                 "yes" if d["used"] == "1" else "no"] for d in drives]
        used = sum(d["used"] == "1" for d in drives)
        page.add(f"<p>{len(drives)} drives, {used} used; gated hours {num(est.get('gated_hours') if est else None, '{:.3f}')}.</p>\n")
        page.add(table(["drive", "start (UTC)", "duration [s]", "distance [km]", "gated [s]", "used"], rows))
    gate_csv = os.path.join(replay, "gate.csv")
    if os.path.exists(gate_csv):
        gate = read_csv(gate_csv)
        fig = go.Figure(go.Bar(x=[g["reason"] for g in gate], y=[int(g["samples"]) for g in gate]))
        fig.update_layout(height=320, margin=dict(t=30, b=40), yaxis_title="samples", title="Gate: samples per verdict")
        page.figure(fig, "The gate's verdict for every synchronised sample (accepted ones enter the statistics).")
    cov_csv = os.path.join(replay, "coverage.csv")
    if os.path.exists(cov_csv):
        cov = read_csv(cov_csv)
        kinds = sorted({c["histogram"] for c in cov})
        fig = make_subplots(rows=1, cols=len(kinds), subplot_titles=kinds)
        for i, k in enumerate(kinds, start=1):
            cells = [c for c in cov if c["histogram"] == k]
            fig.add_trace(go.Scatter(x=[float(c["x_lo"]) for c in cells], y=[float(c["y_lo"]) for c in cells], mode="markers",
                                     marker=dict(size=9, symbol="square", color=[math.log10(1 + float(c["count"])) for c in cells],
                                                 colorscale="Viridis", showscale=(i == 1), colorbar=dict(title="log10 n")),
                                     text=[c["count"] for c in cells], hovertemplate="x %{x}, y %{y}: %{text} samples", name=k),
                          row=1, col=i)
        fig.update_layout(height=380, margin=dict(t=40, b=40), showlegend=False, title="Coverage of the operating range")
        page.figure(fig, "Coverage histograms of the accepted samples (cell lower corners; colour: log10 of the count).")


def adequacy_section(page: Page, replay: str) -> None:
    import plotly.graph_objects as go

    path = os.path.join(replay, "eg_history.csv")
    if not os.path.exists(path):
        return
    hist = read_csv(path)
    page.section("adequacy", "Adequacy history")
    h = [float(r["gated_hours"]) for r in hist]
    eg = [float(r["eg_deg_per_g"]) for r in hist]
    sd = [float(r["eg_se_deg_per_g"]) for r in hist]
    fig = go.Figure([
        go.Scatter(x=h + h[::-1], y=[e + s for e, s in zip(eg, sd)] + [e - s for e, s in zip(eg[::-1], sd[::-1])],
                   fill="toself", line=dict(width=0), fillcolor="rgba(31,119,180,0.2)", name="± σ", hoverinfo="skip"),
        go.Scatter(x=h, y=eg, mode="lines+markers", name="EG", text=[r["state"] for r in hist],
                   hovertemplate="%{x:.2f} h: %{y:.4f} deg/g (%{text})")])
    fig.update_layout(height=380, margin=dict(t=30, b=40), xaxis_title="gated hours", yaxis_title="EG [deg/g]",
                      title="EG ± σ at every identification")
    page.figure(fig, "EG's convergence: the signal that the data are adequate (docs/physics.md).")
    rows = [[num(float(r["gated_hours"]), "{:.3f}"), num(float(r["eg_deg_per_g"]), "{:.4f}"), num(float(r["eg_se_deg_per_g"]), "{:.4f}"),
             esc(r["state"])] for r in hist[-10:]]
    page.add("<p>The last identifications:</p>\n" + table(["gated h", "EG [deg/g]", "σ", "state"], rows))


def bins_table(page: Page, rows: list[dict], unit: str) -> None:
    value_key = next((k for k in rows[0] if k.startswith("bias_")), "bias") if rows else "bias"
    se_key = value_key.replace("bias_", "se_")
    rmse_key = value_key.replace("bias_", "rmse_")
    out, classes = [], []
    for r in rows:
        out.append([esc(r["group"]), esc(r["label"]), esc(r["model"]), esc(r["n"]), num(float(r[value_key]), "{:+.4f}"),
                    num(float(r[se_key]), "{:.4f}"), num(float(r[rmse_key]), "{:.4f}"), esc(r["verdict"])])
        classes.append("fail" if r["verdict"].startswith("FAIL") else ("few" if "few" in r["verdict"] else ""))
    page.add(table(["group", "bin", "model", "n", f"bias [{unit}]", "σ", f"RMSE [{unit}]", "verdict"], out, classes))


def compare_section(page: Page, cmp_dir: str) -> None:
    import plotly.graph_objects as go

    page.section("fails", "Where it fails")
    summary = read_json(os.path.join(cmp_dir, "summary.json"))
    rows = [[esc(m.get("label")), esc(m.get("model")), num(m.get("eg_deg_per_g"), "{:.4f}"), num(m.get("eg_se_deg_per_g"), "{:.4f}"),
             num(m.get("rmse_train_mps2"), "{:.4f}"), num(m.get("rmse_validation_mps2"), "{:.4f}")] for m in summary.get("models", [])]
    page.add(f"<p>compare: the model against its baseline on the same window; noise floor "
             f"{num(summary.get('noise_floor_mps2'), '{:.4f}')} m/s² ({esc(summary.get('noise_floor_source', ''))}).</p>\n")
    page.add(table(["label", "model", "EG [deg/g]", "σ", "RMSE train [m/s²]", "RMSE held-out [m/s²]"], rows))
    bins = os.path.join(cmp_dir, "bins.csv")
    if os.path.exists(bins):
        page.add("<h3>a<sub>y</sub> residual by operating condition</h3>\n")
        bins_table(page, read_csv(bins), "m/s²")
    ybins = os.path.join(cmp_dir, "yaw_bins.csv")
    if os.path.exists(ybins):
        page.add("<h3>Yaw-rate residual by operating condition</h3>\n")
        bins_table(page, read_csv(ybins), "deg/s")
    samples = os.path.join(cmp_dir, "compare.csv")
    if os.path.exists(samples):
        rows = [r for r in read_csv(samples) if r["set"] != "train" and r["scored"] == "1"] or read_csv(samples)
        # The held-out chunk with the largest a_y spread (as compare's own time-series plot).
        chunks: dict = {}
        for r in rows:
            chunks.setdefault((r["drive"], r["segment"], r["chunk"]), []).append(r)
        best = max(chunks.values(), key=lambda c: max(float(x["ay_meas_mps2"]) for x in c) - min(float(x["ay_meas_mps2"]) for x in c))
        t0 = float(best[0]["t_s"])
        t = [float(x["t_s"]) - t0 for x in best]
        fig = go.Figure()
        fig.add_trace(go.Scatter(x=t, y=[float(x["ay_meas_mps2"]) for x in best], name="measured", line=dict(color="black")))
        fig.add_trace(go.Scatter(x=t, y=[float(x["ay_model_mps2"]) for x in best], name="model"))
        if "ay_baseline_mps2" in best[0]:
            fig.add_trace(go.Scatter(x=t, y=[float(x["ay_baseline_mps2"]) for x in best], name="baseline", line=dict(dash="dot")))
        fig.update_layout(height=380, margin=dict(t=30, b=40), xaxis_title="time in the chunk [s]", yaxis_title="a_y [m/s²]",
                          title="Measured against modelled a_y on a held-out stretch")
        page.figure(fig, "The held-out chunk with the largest a<sub>y</sub> spread (the study's Fig. 7); zoom with the mouse.")
        if best[0].get("yaw_rate_meas_radps") not in (None, ""):
            fig = go.Figure()
            fig.add_trace(go.Scatter(x=t, y=[math.degrees(float(x["yaw_rate_meas_radps"])) for x in best], name="measured",
                                     line=dict(color="black")))
            fig.add_trace(go.Scatter(x=t, y=[math.degrees(float(x["yaw_rate_model_radps"])) for x in best], name="model"))
            fig.update_layout(height=340, margin=dict(t=30, b=40), xaxis_title="time in the chunk [s]",
                              yaxis_title="yaw rate [deg/s]", title="Measured against modelled yaw rate, same stretch")
            page.figure(fig, "The yaw rate on the same stretch (gyro effects included in the model's).")


def diagnose_section(page: Page, dia_dir: str) -> None:
    import plotly.graph_objects as go

    d = read_json(os.path.join(dia_dir, "diagnosis.json"))
    page.section("ladder", "Which effect is missing: the error ladder")
    ladder = d.get("ladder", [])
    rows = [[str(i), esc(r.get("model")), esc(r.get("added") or "–"), esc(r.get("added_parameters", "")),
             num(r.get("rmse_train_mps2"), "{:.4f}"), num(r.get("rmse_validation_mps2"), "{:.4f}"),
             f"{num(r.get('eg_deg_per_g'), '{:.4f}')} ± {num(r.get('eg_se_deg_per_g'), '{:.4f}')}", num(r.get("delta_bic"), "{:.1f}")]
            for i, r in enumerate(ladder)]
    page.add(table(["rung", "model", "added", "parameters", "RMSE train", "RMSE held-out", "EG [deg/g]", "ΔBIC"], rows))
    if ladder:
        fig = go.Figure(go.Scatter(x=[r.get("added") or "base" for r in ladder], y=[r.get("rmse_validation_mps2") for r in ladder],
                                   mode="lines+markers", name="held-out RMSE"))
        floor = next((v.get("noise_floor") for v in d.get("verdicts", []) if v.get("output") == "a_y"), None)
        if floor:
            fig.add_hline(y=floor, line_dash="dash", annotation_text="noise floor")
        fig.update_layout(height=340, margin=dict(t=30, b=40), yaxis_title="held-out RMSE a_y [m/s²]", title="The error falls")
        page.figure(fig, "Held-out RMSE at each rung of the ladder against the noise floor.")
    trials = d.get("trials", [])
    if trials:
        page.add("<h3>Every candidate tried</h3>\n")
        page.add(table(["step", "effect", "added", "held-out before", "after", "ΔBIC", "EG moves", "why"],
                       [[esc("0 (contest)" if (t.get("step") or 0) < 0 else t.get("step")), esc(t.get("effect")), "yes" if t.get("accepted") else "no",
                         num(t.get("held_out_before_mps2"), "{:.4f}"), num(t.get("held_out_after_mps2"), "{:.4f}"),
                         num(t.get("delta_bic"), "{:.1f}"),
                         (num(100 * t["eg_shift_rel"], "{:+.2f}") + " %") if t.get("eg_shift_rel") is not None else "–",
                         esc(t.get("why", ""))] for t in trials],
                       ["added" if t.get("accepted") else "" for t in trials]))
    look_alike = d.get("look_alike")
    if look_alike:
        page.add(f"<p>Step 0: <b>{esc(look_alike.get('effect'))}</b> was added first (rung 1): it explains more of the "
                 f"held-out error than the time shifts ({esc(look_alike.get('why'))}); the latencies were estimated again "
                 "with it in the model.</p>\n")
    page.add(f"<p>The ladder stopped: {esc(d.get('stop_reason', ''))}. Final effects: "
             f"<b>{esc(', '.join(d.get('final_effects', [])) or 'none')}</b>.</p>\n")
    ranking = d.get("ranking", [])
    if ranking:
        page.add("<h3>Candidates ranked by their score test</h3>\n")
        page.add(table(["effect", "robust z", "share of RSS", "predicted RMSE", "confounded with", "significant"],
                       [[esc(r.get("effect")), num(r.get("z_robust"), "{:+.2f}"), num(r.get("drss_share"), "{:.3f}"),
                         num(r.get("rmse_predicted_mps2"), "{:.4f}"), esc(", ".join(r.get("confounded_with", []))),
                         "yes" if r.get("significant") else "no"] for r in ranking[:15]]))
    verdicts = d.get("verdicts", [])
    unsettled = d.get("eg_unsettled", "")
    if verdicts or unsettled:
        red = ' style="color:#b00"'
        page.add("<h3>Verdicts</h3>\n<ul>" + "".join(
            f"<li{red if v.get('unexplained') else ''}>{esc(v.get('text', ''))}</li>" for v in verdicts) +
            (f"<li{red}>{esc(unsettled)}</li>" if unsettled else "") + "</ul>\n")
    outside = d.get("outside_library", [])
    if outside:
        page.add("<h3>Outside the library</h3>\n<ul>" + "".join(
            f"<li>{esc(o.get('text', ''))}" +
            (f"<pre>{esc(o['formula_template'])}</pre>" if o.get("formula_template") else "") + "</li>"
            for o in outside) + "</ul>\n")


def truth_section(page: Page, truth: dict, est: dict | None) -> None:
    page.section("truth", "The simulator's truth")
    v = truth.get("vehicle", {})
    rows = [[esc(k), esc(v[k])] for k in ("mass_kg", "yaw_inertia_kgm2", "cornering_stiffness_front_npr",
                                          "cornering_stiffness_rear_npr", "cg_to_front_m", "steering_ratio",
                                          "self_steer_gradient_deg_per_g") if k in v]
    eff = [(k, e) for k, e in truth.get("effects", {}).items() if isinstance(e, dict) and e.get("enabled")]
    rows += [[f"effect {esc(k)}", f"{esc(e.get('value'))} {esc(e.get('unit', ''))}"] for k, e in eff]
    page.add(f"<p>seed {esc(truth.get('seed', ''))}; {esc(truth.get('command_line', ''))}</p>\n" + table(["quantity", "truth"], rows))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True)
    p.add_argument("--replay")
    p.add_argument("--compare")
    p.add_argument("--diagnose")
    p.add_argument("--truth")
    p.add_argument("--title", default="ndsid report")
    a = p.parse_args(argv)
    try:
        truth = None
        if a.truth and os.path.exists(a.truth):
            import yaml
            with open(a.truth, encoding="utf-8") as f:
                truth = yaml.safe_load(f)
        est = estimate_of(a.replay)
        cmp = read_json(os.path.join(a.compare, "summary.json")) if a.compare and os.path.exists(os.path.join(a.compare, "summary.json")) else None
        dia = read_json(os.path.join(a.diagnose, "diagnosis.json")) if a.diagnose and os.path.exists(os.path.join(a.diagnose, "diagnosis.json")) else None
        page = Page(a.title)
        summary_section(page, est, cmp, dia, truth)
        if est:
            model_section(page, est, truth)
        if a.replay:
            data_section(page, a.replay, est)
            adequacy_section(page, a.replay)
        if cmp:
            compare_section(page, a.compare)
        if a.diagnose and os.path.exists(os.path.join(a.diagnose, "diagnosis.json")):
            diagnose_section(page, a.diagnose)
        if truth:
            truth_section(page, truth, est)
        tmp = a.out + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(page.html())
        os.replace(tmp, a.out)
        print(f"{a.out}: {len(page.toc)} sections, {page.figures} figures")
    except (OSError, ValueError, KeyError) as e:
        print(f"report_html.py: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
