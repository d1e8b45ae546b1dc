#!/usr/bin/env python3
"""Plots for `ndsid compare` and `ndsid diagnose` (docs/model-workflow.md).

    model_report_plots.py compare DIR   reads compare.csv + summary.json, writes timeseries.png,
                                        residual_bins.png, steady_state.png, coverage.png, and
                                        yaw_residual_bins.png when the bus has a yaw rate
    model_report_plots.py ladder DIR    reads diagnosis.json, writes error_ladder.png
"""
import json
import math
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = {"model": "tab:red", "baseline": "tab:blue"}


def load_compare(folder: Path):
    """summary.json and compare.csv (as a DataFrame: numbers as float64, empty cells NaN; set as
    text). Vectorised: compare.csv holds ~150 000 rows per gated hour."""
    summary = json.loads((folder / "summary.json").read_text())
    df = pd.read_csv(folder / "compare.csv", dtype={"set": str}, keep_default_na=False, na_values=[""])
    return summary, df


def plot_timeseries(folder, summary, df, labels):
    # The held-out chunk with the largest a_y spread (falls back to training when none is held out).
    spread = df.groupby(["set", "chunk"], sort=False)["ay_meas_mps2"].var(ddof=0)
    pool = spread[spread.index.get_level_values(0) == "validation"]
    if pool.empty:
        pool = spread
    key = pool.idxmax()
    rs = df[(df["set"] == key[0]) & (df["chunk"] == key[1])].iloc[:3000]  # at most 60 s
    t = rs["t_s"].to_numpy() - rs["t_s"].iloc[0]
    yaw = has_yaw_rate(df)
    fig, axes = plt.subplots(4 if yaw else 3, 1, figsize=(11, 10.5 if yaw else 8), sharex=True)
    axes[0].plot(t, rs["ay_meas_mps2"], "k", lw=0.8, label="measured")
    for lab in labels:
        m = next(x for x in summary["models"] if x["label"] == lab)
        axes[0].plot(t, rs[f"ay_{lab}_mps2"], color=COLORS.get(lab), lw=1.0, label=f"{lab}: {m['model']}")
        axes[1].plot(t, rs[f"resid_{lab}_mps2"], color=COLORS.get(lab), lw=0.8, label=lab)
    axes[0].set_ylabel("a_y [m/s²]")
    axes[0].legend(fontsize=8)
    axes[1].axhline(0, color="grey", lw=0.5)
    axes[1].set_ylabel("residual [m/s²]")
    axes[1].legend(fontsize=8)
    if yaw:  # the second output: measured and modelled yaw rate
        axes[2].plot(t, np.degrees(rs["yaw_rate_meas_radps"]), "k", lw=0.8, label="measured")
        for lab in labels:
            axes[2].plot(t, np.degrees(rs[f"yaw_rate_{lab}_radps"]), color=COLORS.get(lab), lw=1.0, label=lab)
        axes[2].set_ylabel("yaw rate [deg/s]")
        axes[2].legend(fontsize=8)
        axes[2].grid(True, alpha=0.3)
    axv = axes[-1]
    axv.plot(t, rs["speed_mps"], "g", lw=0.8)
    axv.set_ylabel("v [m/s]", color="g")
    ax2 = axv.twinx()
    ax2.plot(t, np.degrees(rs["steer_rad"]), "m", lw=0.8)
    ax2.set_ylabel("steering wheel [deg]", color="m")
    axv.set_xlabel(f"t [s] (drive {rs['drive'].iloc[0]}, chunk {key[1]}, {key[0]})")
    for ax in axes[:2]:
        ax.grid(True, alpha=0.3)
    fig.suptitle("Measured vs modelled lateral acceleration" + (" and yaw rate" if yaw else "") + " (held-out stretch)")
    fig.tight_layout()
    fig.savefig(folder / "timeseries.png", dpi=100)
    plt.close(fig)


def binned(xs, es, edges):
    """Per bin [lo, hi) with at least 50 samples: its centre, the residuals' mean and (population)
    standard deviation."""
    xs, es = np.asarray(xs, dtype=float), np.asarray(es, dtype=float)
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = es[(xs >= lo) & (xs < hi)]
        if len(sel) < 50:
            continue
        m = sel.mean()
        out.append((0.5 * (lo + hi), m, math.sqrt(((sel - m) ** 2).mean())))
    return out


def has_yaw_rate(df):
    """Every row has a measured yaw rate (compare writes them when the bus has one)."""
    return len(df) > 0 and "yaw_rate_meas_radps" in df and bool(df["yaw_rate_meas_radps"].notna().all())


def plot_residual_bins(folder, summary, df, labels, yaw=False):
    scored = df[df["scored"] == 1]
    specs = [("ay_meas_mps2", "a_y [m/s²]", [x * 0.5 for x in range(-8, 9)]),
             ("speed_mps", "v [m/s]", list(range(5, 45, 2))),
             ("steer_rate_radps", "steering rate [rad/s]", [x * 0.05 for x in range(-12, 13)]),
             ("ax_mps2", "a_x [m/s²]", [x * 0.25 for x in range(-12, 9)])]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    floor = summary["yaw_rate"]["noise_floor_degps"] if yaw else summary["noise_floor_mps2"]

    def resid(lab):
        if yaw:
            return np.degrees(scored["yaw_rate_meas_radps"].to_numpy() - scored[f"yaw_rate_{lab}_radps"].to_numpy())
        return scored[f"resid_{lab}_mps2"].to_numpy()
    for ax, (col, xlabel, edges) in zip(axes.flat, specs):
        xs = scored[col].to_numpy()
        for i, lab in enumerate(labels):
            b = binned(xs, resid(lab), edges)
            if b:
                off = (edges[1] - edges[0]) * 0.12 * (i - 0.5)
                ax.errorbar([c + off for c, _, _ in b], [m for _, m, _ in b], yerr=[s for _, _, s in b], fmt="o-",
                            ms=3, capsize=2, color=COLORS.get(lab), label=lab)
        ax.axhspan(-floor, floor, color="grey", alpha=0.2, label="± noise floor")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("yaw-rate residual [deg/s]" if yaw else "residual [m/s²]")
        ax.grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.suptitle(("Residual e_r = r_meas − r_model" if yaw else "Residual e = a_y,meas − a_y,model") +
                 ": binned mean ± standard deviation")
    fig.tight_layout()
    fig.savefig(folder / ("yaw_residual_bins.png" if yaw else "residual_bins.png"), dpi=100)
    plt.close(fig)


def plot_steady_state(folder, summary, df, labels):
    l = summary["wheelbase_m"]
    model = next(x for x in summary["models"] if x["label"] == labels[0])
    params = {p["name"]: p["value"] for p in model["parameters"]}
    i_s = params["is"]
    # Scored quasi-steady samples (a missing steering rate counts as quasi-steady, as before).
    q = df[(df["scored"] == 1) & ~(df["steer_rate_radps"].abs() >= 0.05)]
    v, ay = q["speed_mps"].to_numpy(), q["ay_meas_mps2"].to_numpy()
    yaw = q["yaw_rate_meas_radps"].to_numpy() if "yaw_rate_meas_radps" in q else np.full(len(q), np.nan)
    kin = np.where(np.isnan(yaw), l * ay / v ** 2, l * yaw / v)
    road = q["steer_rad"].to_numpy() / i_s - kin
    fig, ax = plt.subplots(figsize=(8, 5.5))
    if len(q):
        step = max(1, len(q) // 20000)
        ax.plot(ay[::step], np.degrees(road[::step]), ".", ms=1, color="grey", alpha=0.3, label="quasi-steady samples")
        b = binned(ay, road, [x * 0.25 for x in range(-16, 17)])
        ax.plot([c for c, _, _ in b], [math.degrees(m) for _, m, _ in b], "ko", ms=4, label="binned mean")
    xs = [-4, 4]
    for lab in labels:
        m = next(x for x in summary["models"] if x["label"] == lab)
        p = {q_["name"]: q_["value"] for q_ in m["parameters"]}
        d0 = p.get("steer_offset_rad", 0.0) / p["is"]
        eg = m["eg_rad_per_mps2"]
        ax.plot(xs, [math.degrees(eg * x + d0) for x in xs], color=COLORS.get(lab), lw=1.5,
                label=f"{lab}: EG = {m['eg_deg_per_g']:.2f} deg/g" + (f", d0/is = {math.degrees(d0):.3f} deg" if d0 else ""))
    ax.set_xlabel("a_y [m/s²]")
    first_yaw = df["yaw_rate_meas_radps"].iloc[0] if "yaw_rate_meas_radps" in df and len(df) else np.nan
    ax.set_ylabel("d_sw/is − l·r/v [road-wheel angle, deg]" + ("" if len(q) and not math.isnan(first_yaw) else " (or − l·a_y/v²)"))
    ax.set_ylim(-1.5, 1.5)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Steady-state steering against lateral acceleration (is = {i_s:.3f} of the model)")
    fig.tight_layout()
    fig.savefig(folder / "steady_state.png", dpi=100)
    plt.close(fig)


def plot_coverage(folder, df):
    scored = df[df["scored"] == 1]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    ax_vals = scored["ax_mps2"].to_numpy()
    ay_vals = scored["ay_meas_mps2"].to_numpy()
    ok = ~np.isnan(ax_vals)
    if ok.any():
        h = axes[0].hist2d(ax_vals[ok], ay_vals[ok], bins=[40, 40], range=[[-5, 5], [-5, 5]], cmin=1,
                           cmap="viridis", norm=matplotlib.colors.LogNorm())
        fig.colorbar(h[3], ax=axes[0], label="samples")
    t = [i * 2 * math.pi / 200 for i in range(201)]
    axes[0].plot([4 * math.cos(a) for a in t], [4 * math.sin(a) for a in t], "r--", lw=0.8, label="4 m/s² (linear range)")
    axes[0].set_xlabel("a_x [m/s²]")
    axes[0].set_ylabel("a_y [m/s²]")
    axes[0].set_aspect("equal")
    axes[0].legend(fontsize=8)
    axes[0].set_title("g-g diagram")
    h = axes[1].hist2d(scored["speed_mps"].to_numpy(), ay_vals, bins=[40, 40], range=[[0, 45], [-5, 5]],
                       cmin=1, cmap="viridis", norm=matplotlib.colors.LogNorm())
    fig.colorbar(h[3], ax=axes[1], label="samples")
    axes[1].set_xlabel("v [m/s]")
    axes[1].set_ylabel("a_y [m/s²]")
    axes[1].set_title("speed vs lateral acceleration")
    fig.tight_layout()
    fig.savefig(folder / "coverage.png", dpi=100)
    plt.close(fig)


def plot_ladder(folder: Path):
    d = json.loads((folder / "diagnosis.json").read_text())
    rungs = d.get("ladder", [])
    if not rungs:
        return
    names = ["start" if not r["added"] else "+ " + r["added"] for r in rungs]
    x = list(range(len(rungs)))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    axes[0].plot(x, [r["rmse_train_mps2"] for r in rungs], "o-", label="training")
    axes[0].plot(x, [r["rmse_validation_mps2"] for r in rungs], "s-", label="held-out")
    axes[0].set_ylabel("RMSE [m/s²]")
    axes[0].legend()
    axes[1].errorbar(x, [r["eg_deg_per_g"] for r in rungs], yerr=[r["eg_se_deg_per_g"] for r in rungs], fmt="o-",
                     capsize=3)
    axes[1].set_ylabel("EG ± 1σ [deg/g]")
    for ax in axes:
        ax.set_xticks(x)
        ax.set_xticklabels(names, rotation=20)
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"Error ladder ({d.get('data', '')}): stop — {d.get('stop_reason', '')}")
    fig.tight_layout()
    fig.savefig(folder / "error_ladder.png", dpi=100)
    plt.close(fig)


def main():
    mode, folder = sys.argv[1], Path(sys.argv[2])
    if mode == "compare":
        summary, df = load_compare(folder)
        labels = [m["label"] for m in summary["models"]]
        plot_timeseries(folder, summary, df, labels)
        plot_residual_bins(folder, summary, df, labels)
        if has_yaw_rate(df) and "yaw_rate" in summary:
            plot_residual_bins(folder, summary, df, labels, yaw=True)
        plot_steady_state(folder, summary, df, labels)
        plot_coverage(folder, df)
    elif mode == "ladder":
        plot_ladder(folder)
    else:
        sys.exit(f"unknown mode {mode}")


if __name__ == "__main__":
    main()
