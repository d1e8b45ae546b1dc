#!/usr/bin/env python3
"""EG per data-set size (the study's Fig. 6) from study.csv; optional truth line."""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

folder = Path(sys.argv[1])
truth = float(sys.argv[2]) if len(sys.argv) > 2 else None
rows = [r for r in csv.DictReader(open(folder / "study.csv")) if r["valid"] == "1"]
kinds = []
for r in rows:
    if r["set"] not in kinds:
        kinds.append(r["set"])
data = [[float(r["eg_deg_per_g"]) for r in rows if r["set"] == k] for k in kinds]
fig, ax = plt.subplots(figsize=(7, 4))
ax.boxplot(data, labels=kinds, whis=(0, 100))
for i, d in enumerate(data, start=1):
    ax.plot([i] * len(d), d, "o", alpha=0.5, color="tab:blue")
if truth is not None:
    ax.axhline(truth, color="tab:red", linestyle="--", label="truth (simulator)")
    ax.legend()
ax.set_xlabel("data set (SD = single drive, H<n> = n gated hours, AD = all)")
ax.set_ylabel("EG [deg/g]")
ax.set_title("Self-steering gradient per data-set size")
ax.grid(True, alpha=0.3)
fig.tight_layout()
fig.savefig(folder / "study.png", dpi=110)
