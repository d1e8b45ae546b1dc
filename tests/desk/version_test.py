#!/usr/bin/env python3
"""The version a user sees is one version: CHANGELOG.md's newest entry, the first line of
`ndsid version`, and the Debian package's version (CPack's configuration and the package's
changelog.Debian, both written when the build tree is configured).

Catches: a release entry added to CHANGELOG.md without bumping `project(ndsid VERSION ...)`
(or the reverse), `ndsid version` printing something other than the project version, the
package built with another version, and a CHANGELOG whose entries are not newest first.
usage: version_test.py NDSID_EXE SOURCE_DIR BINARY_DIR
"""
import re
import subprocess
import sys
from pathlib import Path

exe, src, build = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])
errors = []


def as_tuple(v: str) -> tuple[int, ...]:
    return tuple(int(x) for x in v.split("."))


changelog = (src / "CHANGELOG.md").read_text(encoding="utf-8")
versions = re.findall(r"^## \[?(\d+\.\d+\.\d+)\]?", changelog, flags=re.M)
if not versions:
    sys.exit("CHANGELOG.md has no '## X.Y.Z' entry")
newest = versions[0]
if [as_tuple(v) for v in versions] != sorted((as_tuple(v) for v in versions), reverse=True) or len(set(versions)) != len(versions):
    errors.append(f"CHANGELOG.md entries are not newest first without repeats: {versions}")

first_line = subprocess.run([exe, "version"], check=True, capture_output=True, text=True).stdout.split("\n")[0]
m = re.fullmatch(r"ndsid (\S+) \(commit (?:[0-9a-f]+|unknown)\)", first_line)
printed = m.group(1) if m else None
if printed != newest:
    errors.append(f"`ndsid version` prints '{first_line}', CHANGELOG.md's newest entry is {newest}")

cmake = (src / "CMakeLists.txt").read_text()
project = re.search(r"project\(ndsid VERSION (\S+)", cmake)
if not project or project.group(1) != newest:
    errors.append(f"CMakeLists.txt project(ndsid VERSION {project.group(1) if project else '?'}) "
                  f"!= CHANGELOG.md's newest entry {newest}")

cpack = build / "CPackConfig.cmake"
if cpack.exists():
    package = re.search(r'set\(CPACK_PACKAGE_VERSION "([^"]+)"\)', cpack.read_text())
    if not package or package.group(1) != newest:
        errors.append(f"{cpack}: CPACK_PACKAGE_VERSION {package.group(1) if package else '?'} != {newest}")
    debian = build / "debian-control" / "changelog.Debian"
    head = debian.read_text().split("\n")[0] if debian.exists() else ""
    if not re.match(rf"ndsid \({re.escape(newest)}-\d+\) ", head):
        errors.append(f"{debian}: first line '{head}' does not name version {newest}")
else:
    errors.append(f"{cpack} missing: the build tree has no package configuration (cmake/install.cmake)")

if errors:
    print("\n".join(errors))
    sys.exit(1)
print(f"version {newest}: CHANGELOG.md, `ndsid version`, CMakeLists.txt and the Debian package agree")
