#!/usr/bin/env python3
"""Keeps every file and function of src/ and include/ short enough to read in one sitting.

Catches: a source file over 500 lines, and a function over 150 lines (a lambda counts as part of
the function it is written in), in src/ or include/ (tests may be longer). Function lengths are
lizard's (a pinned requirement of the project venv: requirements.txt), from the line of the
function's name to its closing brace; file lengths are lines as `wc -l` counts them. Each problem
is printed as file:line, the function, its length and the limit.

usage: source_size_test.py SOURCE_DIR
"""
import pathlib
import sys

MAX_FILE_LINES = 500
MAX_FUNCTION_LINES = 150
SOURCE_SUFFIXES = {".h", ".hpp", ".cc", ".cpp", ".c"}

# Exceptions, each with the length it has: none. An entry that no longer exceeds its limit fails
# the test, so the list cannot go stale.
ALLOWED_FILES: set[str] = set()
ALLOWED_FUNCTIONS: set[tuple[str, str]] = set()


def source_files(root: pathlib.Path) -> list[pathlib.Path]:
    files = []
    for top in ("src", "include"):
        files += [p for p in (root / top).rglob("*") if p.is_file() and p.suffix in SOURCE_SUFFIXES]
    return sorted(files)


def main() -> int:
    root = pathlib.Path(sys.argv[1]).resolve()
    try:
        import lizard
    except ImportError:
        print("FAIL: the Python package lizard is missing from the venv (scripts/setup.sh installs requirements.txt)")
        return 1

    errors = []
    used_files, used_functions = set(), set()
    files = source_files(root)
    functions = 0
    for path in files:
        rel = path.relative_to(root).as_posix()
        text = path.read_text(encoding="utf-8", errors="replace")
        lines = text.count("\n") + (0 if text.endswith("\n") or not text else 1)
        if lines > MAX_FILE_LINES:
            if rel in ALLOWED_FILES:
                used_files.add(rel)
            else:
                errors.append(f"{rel}:1: file has {lines} lines (limit {MAX_FILE_LINES})")
        for f in lizard.analyze_file(str(path)).function_list:
            functions += 1
            if f.length <= MAX_FUNCTION_LINES:
                continue
            if (rel, f.name) in ALLOWED_FUNCTIONS:
                used_functions.add((rel, f.name))
                continue
            errors.append(f"{rel}:{f.start_line}: function {f.name} has {f.length} lines (limit {MAX_FUNCTION_LINES})")

    for rel in sorted(ALLOWED_FILES - used_files):
        errors.append(f"{rel}: listed in ALLOWED_FILES but within {MAX_FILE_LINES} lines (or gone): delete the entry")
    for rel, name in sorted(ALLOWED_FUNCTIONS - used_functions):
        errors.append(f"{rel}: {name} listed in ALLOWED_FUNCTIONS but within {MAX_FUNCTION_LINES} lines (or gone): "
                      "delete the entry")

    for e in errors:
        print("FAIL:", e)
    print(f"{len(files)} files, {functions} functions checked, {len(errors)} problems")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
