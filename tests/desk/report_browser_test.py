#!/usr/bin/env python3
"""`ndsid report` in a real browser (docs/model-workflow.md, "One report"): the report of the
bundled steering-offset drives is written, then each page (the combined one and the pages of
replay, compare and diagnose) is loaded in Debian's headless Chromium with the network cut off:
no console message, every figure rendered (plotly's SVG inside each figure's div), every
section and the numbers of the run present (the EG of estimate.json, the ladder's added effect,
the truth). Exit 77 (skipped) without chromium.
    report_browser_test.py <ndsid binary> <source dir>"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile


def skip(why):
    print(f"SKIPPED: {why}")
    sys.exit(77)


def check(cond, msg):
    if not cond:
        print(f"FAIL: {msg}")
        sys.exit(1)


def load(browser, page, tmp):
    """The page's DOM after its scripts ran, and the browser's console messages."""
    r = subprocess.run([browser, "--headless=new", "--no-sandbox", "--disable-gpu", "--enable-logging=stderr", "--v=0",
                        "--host-resolver-rules=MAP * ~NOTFOUND", f"--user-data-dir={tmp}/profile",
                        "--virtual-time-budget=15000", "--dump-dom", "file://" + os.path.abspath(page)],
                       capture_output=True, text=True, timeout=180)
    console = [line for line in r.stderr.splitlines() if ":CONSOLE" in line]
    return r.stdout, console


def main():
    ndsid, src = sys.argv[1], sys.argv[2]
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if not browser:
        skip("no chromium (Debian: apt-get install chromium; scripts/setup.sh installs it)")
    log = os.path.join(src, "replay", "steer_offset", "drive.log.gz")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "report")
        r = subprocess.run([ndsid, "report", "--log", log, "--out", out], capture_output=True, text=True, timeout=900)
        check(r.returncode == 0, f"ndsid report exited {r.returncode}\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
        page = os.path.join(out, "ndsid-report.html")
        check(os.path.exists(page), "no ndsid-report.html")
        text = open(page, encoding="utf-8").read()
        # Our markup outside the embedded plotly.js (whose map modules name tile servers that a
        # page without maps never loads) references nothing on the network; the browser below
        # runs with every host name unresolvable, so a load would show as a console error.
        ours = text[text.index("</head>"):]
        check(not re.search(r'(src|href)="https?://', ours), "the page loads something from the network")
        est_dir = next(os.path.join(out, "replay", d) for d in os.listdir(os.path.join(out, "replay")))
        est = json.load(open(os.path.join(est_dir, "estimate.json")))
        dom, console = load(browser, page, tmp)
        check(not console, "console messages:\n" + "\n".join(console))
        figures = re.findall(r'<div id="(fig\d+)"', dom)
        check(len(figures) >= 6, f"only {len(figures)} figures")
        for fig in figures:  # each figure's div holds plotly's rendered SVG
            start = dom.index(f'<div id="{fig}"')
            nxt = dom.find('<div id="fig', start + 10)
            check('class="main-svg"' in dom[start:nxt if nxt > 0 else len(dom)], f"{fig} not rendered")
        for section in ("Summary", "Model", "Data set", "Adequacy history", "Where it fails", "the error ladder",
                        "Every candidate tried", "The simulator's truth"):
            check(section in dom, f"section {section!r} missing")
        check(f"{est['eg_deg_per_g']:.4f}" in dom, "the replay's EG is not on the page")
        check("steer_offset" in dom and "road_bank" in dom, "the ladder's effects are not on the page")
        check("4.1903 deg/g" in dom, "the truth EG (4.1903 deg/g) is not on the page")
        for sub in (os.path.join(est_dir, "ndsid-report.html"), os.path.join(out, "compare", "ndsid-report.html"),
                    os.path.join(out, "diagnose", "ndsid-report.html")):
            check(os.path.exists(sub), f"{sub} missing")
            dom, console = load(browser, sub, tmp)
            check(not console, f"{sub}: console messages:\n" + "\n".join(console))
            n = len(re.findall(r'<div id="fig\d+"', dom))
            check(n >= 1 and dom.count('class="main-svg"') >= n, f"{sub}: {n} figures, not all rendered")
        print(f"OK: {len(figures)} figures rendered, no console message, 4 pages")


if __name__ == "__main__":
    main()
