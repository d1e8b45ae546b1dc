#!/usr/bin/env python3
"""Keeps the repository's text a manual: the system as it is, not the story of how it got there.

Catches, in every tracked text file (docs, README, code comments, scripts, tests, bench/):
- a reference to a work item: "issue 15", "Issue 11 item 4", "the issue's target", "(issue: ...)";
- a reference to a work session: "eighteenth session", "stopped at the session's end";
- a reference to a merge attempt: "stop 42 refused";
- in README.md, bench/README.md and docs/: the narrative phrase "the build before";
- in README.md: a table row longer than README_ROW_WIDTH characters (one line per row: a
  figure, its command and its anchor; the story behind it belongs in the commit log).
The history lives in the commit messages and CHANGELOG.md.

usage: docs_manual_test.py SOURCE_DIR
"""
import pathlib
import re
import subprocess
import sys

README_ROW_WIDTH = 220

# Narrative references, case-insensitive. Each names what it catches.
PATTERNS = [
    # "issue 15", "Issue 11 item 4", "issues 11 and 12", "issue #3"
    (r"\bissues?\s*#?\d+", "a reference to a work item"),
    # "the target", "the issue", "(issue: compare ...)", 'issue "two outputs ..."'
    (r"\bthe issue\b|\bthe issue['’]s\b|\(issue\b|\bissue\s*[\"“:]", "a reference to a work item"),
    # "eighteenth session", "this session's change", "stopped at the session's end"
    (r"\bsessions?\b", "a reference to a work session"),
    # "stop 42 refused", "stops 41 and 42" (a merge attempt); "a stop 5 s long" is vehicle physics
    (r"\bstops?\s+#?\d+(?:[.,]\d+)?(?![\d.,])(?!\s*(?:(?:s|ms|min|h|m|km|kph|deg|of)\b|%|km/h|m/s))",
     "a reference to a merge attempt"),
]

# Legitimate uses the patterns above would also match. Short, and each says why it is allowed.
ALLOWED = [
    # "issue" as a verb: "ndsidd issues a warning", "to issue the command"
    r"\bissue[sd]?\s+(?:a|an|the|one|its|their)\b",
    # a bug of an upstream project, cited by its own tracker
    r"\b(?:upstream|GitHub|ceres-solver|Ceres|LCM|lcm|spdlog|yaml-cpp|Eigen|CLI11|systemd|Debian|"
    r"asammdf|python-can|cantools|Foxglove|pybind11)\s+issues?\b",
    # a session of a protocol or a tool, not of the work: "the Foxglove WebSocket session"
    r"\b(?:WebSocket|Foxglove|LCM|SSH|ssh|login|logind|user|D-Bus|TLS|HTTP|browser|terminal|tmux|"
    r"screen|Jupyter|notebook|interactive|debug|gdb|desktop)(?:['’]s)?\s+sessions?\b",
    # a session type in code: `ws::Session`, `session(...)`
    r"(?:::|->|\.)sessions?\b|\bsessions?\s*(?:\(|::)",
]

# In the user documentation only: phrases that narrate instead of describe.
DOC_PHRASES = [r"\bthe build before\b"]

# Data, not text: fuzz seeds hold arbitrary bytes on purpose.
SKIP_PREFIXES = ("tests/fuzz/corpus/", "tests/fuzz/regressions/")


def tracked_files(root: pathlib.Path) -> list[str]:
    """Files under version control (and new ones not ignored), or every file without git."""
    try:
        out = subprocess.run(["git", "-C", str(root), "ls-files", "--cached", "--others", "--exclude-standard"],
                             check=True, capture_output=True, text=True).stdout
        return sorted(set(out.split("\n")) - {""})
    except (OSError, subprocess.CalledProcessError):
        skip_dirs = {".git", ".venv", "build", "dist", "out"}
        return sorted(str(p.relative_to(root)) for p in root.rglob("*")
                      if p.is_file() and not skip_dirs.intersection(p.relative_to(root).parts)
                      and not p.relative_to(root).parts[0].startswith("build"))


def text_of(path: pathlib.Path):
    try:
        data = path.read_bytes()
    except OSError:
        return None
    if b"\0" in data:
        return None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return None


def narrative_hits(line: str, doc: bool) -> list[str]:
    masked = line
    for allowed in ALLOWED:
        masked = re.sub(allowed, lambda m: "_" * len(m.group(0)), masked, flags=re.I)
    hits = [f"{why}: '{m.group(0)}'" for pattern, why in PATTERNS for m in re.finditer(pattern, masked, flags=re.I)]
    if doc:
        hits += [f"a narrative phrase: '{m.group(0)}'" for p in DOC_PHRASES for m in re.finditer(p, masked, flags=re.I)]
    return hits


# The patterns' own check: each line on the left must be caught, each on the right must pass.
MUST_CATCH = ["issue 15", "Issue 11 item 4", "(issues 11 and 12)", "the issue's target", "(issue: compare",
              'issue "two outputs"', "the eighteenth session", "stopped at the session's end",
              "stop 42 refused", "stops 41 and 42"]
MUST_PASS = ["standstill stops", "31 stops (363 s) in the window", "a stop 5 s long", "at least 5 stops",
             "ndsidd issues a warning", "a Foxglove WebSocket session", "ws::Session server", "the stop reason",
             "it stops after 20 M frames", "stop at 0.01 sigma"]


def check_patterns() -> list[str]:
    errors = [f"pattern check: '{t}' is not caught" for t in MUST_CATCH if not narrative_hits(t, doc=False)]
    errors += [f"pattern check: '{t}' is caught: {narrative_hits(t, doc=False)}" for t in MUST_PASS
               if narrative_hits(t, doc=False)]
    return errors


def main() -> int:
    root = pathlib.Path(sys.argv[1]).resolve()
    me = pathlib.Path(__file__).resolve()
    errors = check_patterns()
    checked = 0
    for rel in tracked_files(root):
        path = root / rel
        if rel.startswith(SKIP_PREFIXES) or path.resolve() == me or not path.is_file():
            continue
        text = text_of(path)
        if text is None:
            continue
        checked += 1
        doc = rel == "README.md" or rel == "bench/README.md" or (rel.startswith("docs/") and rel.endswith(".md"))
        for n, line in enumerate(text.split("\n"), 1):
            for hit in narrative_hits(line, doc):
                errors.append(f"{rel}:{n}: {hit}")
            if rel == "README.md" and line.startswith("|") and len(line.rstrip()) > README_ROW_WIDTH:
                errors.append(f"{rel}:{n}: a table row of {len(line.rstrip())} characters "
                              f"(at most {README_ROW_WIDTH}: one line per row; the details go to docs/)")
    for e in errors:
        print("FAIL:", e)
    print(f"{checked} files checked, {len(errors)} problems")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
