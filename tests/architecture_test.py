#!/usr/bin/env python3
"""Keeps docs/architecture.md and the source tree in agreement, and the stages acyclic.

Catches: a doc linking outside the repository or to a page that does not exist; a stage folder added or removed without the page saying so; the page's order differing
from the build's (NDSID_STAGES); a stage that links or includes a stage below it (a circle in the
making), also through a relative include path; a circle of includes between files, within a stage
too (header a.h includes b.h includes a.h); a third-party library leaking out of the one stage
that owns it.

usage: architecture_test.py SOURCE_DIR
"""
import pathlib
import re
import sys

# Third-party headers and the one stage allowed to include them (style.md, principle 1).
OWNED_HEADERS = {
    "ceres/": "identify",
    "lcm/": "publish",
    "yaml-cpp/": "config",
    "systemd/": "service",
}
# The model is written once, templated on T; the effects are compiled for Ceres' header-only
# autodiff scalar (ceres::Jet), so the model may name that one type.
ALLOWED = {("model", "ceres/jet.h")}


def stage_table(doc: str) -> list[str]:
    # The stage table: from its marker comment to the first line that is not a table row.
    start = doc.find("<!-- stage table")
    table = doc[start:] if start >= 0 else ""
    lines = table.splitlines()[1:]
    end = next((i for i, line in enumerate(lines) if not line.startswith("|")), len(lines))
    rows = re.findall(r"^\| `([a-z_]+)` \|", "\n".join(lines[:end]), flags=re.M)
    if not rows:
        raise SystemExit("docs/architecture.md: no stage table found")
    return rows


def build_order(cmake: str) -> list[str]:
    m = re.search(r"set\(NDSID_STAGES ([^)]*)\)", cmake)
    if not m:
        raise SystemExit("CMakeLists.txt: NDSID_STAGES not found")
    return m.group(1).split()


def stage_of(root: pathlib.Path, path: pathlib.Path) -> str | None:
    """The stage a file of src/<stage>/ or include/ndsid/<stage>/ belongs to."""
    rel = path.relative_to(root).parts
    if len(rel) > 2 and rel[0] == "src":
        return rel[1]
    if len(rel) > 3 and rel[:2] == ("include", "ndsid"):
        return rel[2]
    return None


def include_graph(root: pathlib.Path, files: list[pathlib.Path]) -> dict[pathlib.Path, list[tuple[pathlib.Path, int]]]:
    """Every quoted include resolved to a file of the tree (beside the includer, under include/,
    or in the includer's stage folder or one of its subfolders, as the stages' include paths
    have it), with the line of the #include. Includes of files outside the tree are left out."""
    graph = {}
    for f in files:
        stage = stage_of(root, f)
        stage_dirs = []
        if stage and (root / "src" / stage).is_dir():
            stage_dirs = [root / "src" / stage] + sorted(p for p in (root / "src" / stage).rglob("*") if p.is_dir())
        edges = []
        for number, line in enumerate(f.read_text().splitlines(), 1):
            m = re.match(r'\s*#\s*include\s+"([^"]+)"', line)
            if not m:
                continue
            for base in [f.parent, root / "include", *stage_dirs]:
                target = (base / m.group(1)).resolve()
                if target.is_file() and root in target.parents:
                    edges.append((target, number))
                    break
        graph[f] = edges
    return graph


def circles(graph: dict[pathlib.Path, list[tuple[pathlib.Path, int]]]) -> list[list[pathlib.Path]]:
    """One cycle (as a path a -> b -> ... -> a) per strongly connected set of files."""
    found, state, stack = [], {}, []  # state: 1 on the stack, 2 done

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt, _ in graph.get(node, []):
            if state.get(nxt) == 1:
                cycle = stack[stack.index(nxt):] + [nxt]
                if not any(set(cycle) == set(c) for c in found):
                    found.append(cycle)
            elif nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = 2

    sys.setrecursionlimit(max(1000, 4 * len(graph)))
    for node in sorted(graph):
        if node not in state:
            visit(node)
    return found


def main() -> int:
    root = pathlib.Path(sys.argv[1])
    errors = []
    documented = stage_table((root / "docs/architecture.md").read_text())
    folders = sorted(p.name for p in (root / "src").iterdir() if (p / "CMakeLists.txt").exists())
    order = build_order((root / "CMakeLists.txt").read_text())

    if sorted(documented) != folders:
        errors.append(f"docs/architecture.md lists {sorted(documented)}, src/ has {folders}")
    if documented != order:
        errors.append(f"docs/architecture.md order {documented} != CMakeLists.txt NDSID_STAGES {order}")
    rank = {s: i for i, s in enumerate(order)}

    for stage in folders:
        sdir = root / "src" / stage
        cm = (sdir / "CMakeLists.txt").read_text()
        for dep in sorted(set(re.findall(r"\bndsid_([a-z_]+)\b", cm))):
            if dep in rank and dep != stage and rank[dep] > rank[stage]:
                errors.append(f"src/{stage}/CMakeLists.txt links ndsid_{dep}, a later stage")
        sources = list(sdir.rglob("*.cc")) + list(sdir.rglob("*.h"))
        inc_dir = root / "include" / "ndsid" / stage
        if inc_dir.exists():
            sources += list(inc_dir.rglob("*.h"))
        if not sources:
            errors.append(f"src/{stage}: no sources")
        for f in sources:
            text = f.read_text()
            for dep in re.findall(r'#include "ndsid/([a-z_]+)/', text):
                if dep in rank and rank[dep] > rank[stage]:
                    errors.append(f"{f.relative_to(root)} includes ndsid/{dep}/, a later stage than {stage}")
            for prefix, owner in OWNED_HEADERS.items():
                for inc in re.findall(r"#include <(" + re.escape(prefix) + r"[^>]*)>", text):
                    if stage == owner or (stage, inc) in ALLOWED:
                        continue
                    errors.append(f"{f.relative_to(root)} includes <{inc}>, which only {owner} may use")

    # The include graph over every file of src/ and include/: no include reaches a later stage by
    # any path (a relative one too), and no files include each other in a circle.
    files = sorted(p.resolve() for top in ("src", "include") for p in (root / top).rglob("*")
                   if p.suffix in (".h", ".hpp", ".cc", ".cpp", ".c") and p.is_file())
    root = root.resolve()
    graph = include_graph(root, files)
    for f, edges in graph.items():
        stage = stage_of(root, f)
        for target, number in edges:
            dep = stage_of(root, target)
            if stage in rank and dep in rank and rank[dep] > rank[stage]:
                errors.append(f"{f.relative_to(root)}:{number} includes {target.relative_to(root)}, a later stage than {stage}")
    for cycle in circles(graph):
        errors.append("include circle: " + " -> ".join(str(p.relative_to(root)) for p in cycle))

    # What users need is in the repository: README and docs/ link to no file outside it, and
    # every relative link between them resolves.
    for doc in [root / "README.md", *sorted((root / "docs").glob("*.md"))]:
        text = doc.read_text()
        if re.search(r"\]\([^)]*\.\./shared", text):
            errors.append(f"{doc.relative_to(root)} links outside the repository (../shared)")
        for target in re.findall(r"\]\(([^)#:\s]+\.md)(?:#[^)]*)?\)", text):
            if not (doc.parent / target).resolve().exists():
                errors.append(f"{doc.relative_to(root)} links to {target}, which does not exist")

    for e in errors:
        print("FAIL:", e)
    print(f"{len(folders)} stages and {len(graph)} files' includes checked, {len(errors)} problems")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
