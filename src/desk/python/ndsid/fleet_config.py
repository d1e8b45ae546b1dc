"""A vehicle configuration with a fleet prior as its `model.priors` (docs/fleet.md): the YAML text
edited in place (comments and layout kept), relative paths rebased when the new file lives
elsewhere, and the result read back by ndsid to check it says what was meant."""
from __future__ import annotations

import math
import os
import re

_TOP = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*):(.*)$")
_PATH_KEYS = ("dbc", "state_dir", "report_dir")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def _blank(line: str) -> bool:
    s = line.strip()
    return not s or s.startswith("#")


def _block(lines: list[str], key: str) -> tuple[int, int]:
    """[start, end) of a top-level block `key:` (end: the next top-level line), or (-1, -1)."""
    for i, line in enumerate(lines):
        m = _TOP.match(line)
        if m and m.group(1) == key:
            j = i + 1
            while j < len(lines) and (_blank(lines[j]) or _indent(lines[j]) > 0):
                j += 1
            while j > i + 1 and _blank(lines[j - 1]):  # trailing blank lines belong to the next block
                j -= 1
            return i, j
    return -1, -1


def _number(x: float) -> str:
    return repr(float(f"{x:.9g}"))


def _priors_block(priors: dict[str, dict], indent: str, note: str) -> list[str]:
    out = [f"{indent}priors:{'  # ' + note if note else ''}"]
    for name, p in priors.items():
        out.append(f"{indent}  {name}: {{value: {_number(p['value'])}, sd: {_number(p['sd'])}}}")
    return out


def set_priors(text: str, priors: dict[str, dict], note: str = "") -> str:
    """`text` with model.priors replaced by (or extended with) `priors`: a prior already there
    on another parameter is kept."""
    lines = text.splitlines()
    start, end = _block(lines, "model")
    if start < 0:
        body = lines + ["", "model:"] + _priors_block(priors, "  ", note)
        return "\n".join(body) + "\n"
    if _TOP.match(lines[start]).group(2).split("#")[0].strip():
        raise ValueError("model: is written in flow style ({...}); write it as a block to add priors")
    children = [i for i in range(start + 1, end) if not _blank(lines[i])]
    child = min((_indent(lines[i]) for i in children), default=2)
    indent = " " * child
    kept: dict[str, str] = {}
    p_start = next((i for i in children if _indent(lines[i]) == child and lines[i].strip().startswith("priors:")), -1)
    if p_start >= 0:
        p_end = p_start + 1
        while p_end < end and (_blank(lines[p_end]) or _indent(lines[p_end]) > child):
            m = re.match(r"^\s+([A-Za-z_][A-Za-z0-9_]*):\s*(\{.*\})", lines[p_end])
            if m and _indent(lines[p_end]) > child and m.group(1) not in priors:
                kept[m.group(1)] = lines[p_end]
            p_end += 1
        if lines[p_start].split("#")[0].strip() != "priors:":
            raise ValueError("model.priors is written in flow style; write it as a block to add priors")
        block = _priors_block(priors, indent, note) + list(kept.values())
        lines[p_start:p_end] = block
    else:
        last = max(children) if children else start
        lines[last + 1:last + 1] = _priors_block(priors, indent, note)
    return "\n".join(lines) + "\n"


def rebase_paths(text: str, src_dir: str, dst_dir: str) -> str:
    """Relative paths of the configuration (dbc, state_dir, report_dir, source.logs) rewritten
    for a file in dst_dir instead of src_dir."""
    if os.path.abspath(src_dir) == os.path.abspath(dst_dir):
        return text

    def fix(p: str) -> str:
        q = p.strip().strip("'\"")
        if not q or os.path.isabs(q):
            return p
        return os.path.relpath(os.path.normpath(os.path.join(src_dir, q)), dst_dir)

    lines = text.splitlines()
    for i, line in enumerate(lines):
        m = _TOP.match(line)
        if m and m.group(1) in _PATH_KEYS:
            value, _, comment = m.group(2).partition(" #")
            lines[i] = f"{m.group(1)}: {fix(value)}" + (f"  #{comment}" if comment else "")
    start, end = _block(lines, "source")
    in_logs = False
    for i in range(max(start, 0) + 1, end if start >= 0 else 0):
        s = lines[i].strip()
        if s.startswith("logs:"):
            rest = s[len("logs:"):].split("#")[0].strip()
            if rest.startswith("["):
                items = [fix(x) for x in rest.strip("[]").split(",") if x.strip()]
                lines[i] = lines[i][:_indent(lines[i])] + "logs: [" + ", ".join(items) + "]"
            in_logs = not rest
            continue
        if in_logs and s.startswith("- "):
            value, _, comment = s[2:].partition(" #")
            lines[i] = lines[i][:_indent(lines[i])] + "- " + fix(value) + (f"  #{comment}" if comment else "")
        elif not _blank(lines[i]):
            in_logs = False
    return "\n".join(lines) + "\n"


def write_config_with_priors(config: str, priors: dict[str, dict], out: str, note: str = "") -> dict:
    """Writes `config` with `priors` as model.priors to `out`; returns the new configuration as
    ndsid reads it. Raises ndsid.ConfigError when the result does not read back as meant."""
    import ndsid
    with open(config, encoding="utf-8") as f:
        text = f.read()
    try:
        new = rebase_paths(set_priors(text, priors, note), os.path.dirname(os.path.abspath(config)),
                           os.path.dirname(os.path.abspath(out)))
    except ValueError as e:
        raise ndsid.ConfigError(f"{config}: {e}") from None
    before = ndsid.load_config(config)
    tmp = out + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(new)
    try:
        after = ndsid.load_config(tmp)
    except ndsid.ConfigError:
        os.remove(tmp)
        raise
    problems = [k for k in ("dbc", "logs", "state_dir", "report_dir", "vehicle", "effects", "parameters")
                if before.get(k) != after.get(k)]
    for name, p in priors.items():
        got = after["priors"].get(name)
        if got is None or not math.isclose(got["value"], p["value"], rel_tol=1e-8, abs_tol=1e-12) \
                or not math.isclose(got["sd"], p["sd"], rel_tol=1e-8):
            problems.append(f"model.priors.{name}")
    if problems:
        os.remove(tmp)
        raise ndsid.ConfigError(f"{out}: the edited configuration does not read back as meant ({', '.join(problems)}); "
                                f"write it next to {config}")
    os.replace(tmp, out)
    return after
