#!/usr/bin/env bash
# Prints the Debian Depends line of cross-built binaries from the arm64 sysroot's own package
# data (scripts/arm64_sysroot.sh keeps each package's file list and shlibs/symbols files in
# <sysroot>/var/lib/ndsid-packages): what dpkg-shlibdeps does for a native build, which it
# cannot do here because the sysroot has no dpkg database. scripts/package.sh --arch arm64
# passes the result to cpack.
#
#   scripts/deb_depends.sh SYSROOT BINARY...
#
# For each NEEDED entry of each binary: the library in the sysroot (symbolic links followed,
# so liblapack.so.3 -> atlas/liblapack.so.3 names the provider, libatlas3-base, as on the
# amd64 host), the package whose file list holds it, and that package's dependency for the
# library: its shlibs line ("liblcm 1 liblcm1" -> liblcm1), else its symbols file's template
# with #MINVER# the newest version that file names (at least as strict as dpkg-shlibdeps,
# which takes the newest version of the symbols the binary uses). A library that no package
# holds is an error.
set -euo pipefail
sysroot="${1:?usage: deb_depends.sh SYSROOT BINARY...}"
shift
meta="$sysroot/var/lib/ndsid-packages"
[[ -d "$meta" ]] || { echo "deb_depends.sh: $meta missing: remake the sysroot (scripts/arm64_sysroot.sh)" >&2; exit 1; }
libdirs=(/usr/lib/aarch64-linux-gnu /lib/aarch64-linux-gnu /usr/lib /lib)

# shlibs_dep PACKAGE SONAME: the package's dependency line for SONAME, from shlibs or symbols.
shlibs_dep() {
  local pkg="$1" soname="$2" name version
  if [[ "$soname" =~ ^(.*)\.so\.([0-9.]+)$ ]]; then
    name="${BASH_REMATCH[1]}" version="${BASH_REMATCH[2]}"
  elif [[ "$soname" =~ ^(.*)-([0-9.]+)\.so$ ]]; then
    name="${BASH_REMATCH[1]}" version="${BASH_REMATCH[2]}"
  else
    name="$soname" version=""
  fi
  if [[ -f "$meta/$pkg.shlibs" ]]; then
    local line
    line="$(awk -v n="$name" -v v="$version" '$1 == n && $2 == v { $1 = ""; $2 = ""; sub(/^ +/, ""); print; exit }' "$meta/$pkg.shlibs")"
    if [[ -n "$line" ]]; then echo "$line"; return; fi
  fi
  if [[ -f "$meta/$pkg.symbols" ]]; then
    # "libfoo.so.1 libfoo1 #MINVER#", then " symbol@VERSION 1.2.3" lines until the next library.
    awk -v s="$soname" '
      /^[^ #|*]/ { inlib = ($1 == s); if (inlib) { tmpl = $0; sub(/^[^ ]+ /, "", tmpl) } next }
      inlib && /^ / { v = $2; sub(/-[^-]*$/, "", v); if (v != "" && (max == "" || system("dpkg --compare-versions " v " gt " max) == 0)) max = v }
      END { if (tmpl != "") { sub(/#MINVER#/, max == "" ? "" : "(>= " max ")", tmpl); sub(/ +$/, "", tmpl); print tmpl } }' \
      "$meta/$pkg.symbols"
    return
  fi
  echo "$pkg"
}

declare -A deps=()
for exe in "$@"; do
  for soname in $(readelf -d "$exe" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    path=""
    for d in "${libdirs[@]}"; do
      if [[ -e "$sysroot$d/$soname" ]]; then path="$d/$soname"; break; fi
    done
    [[ -n "$path" ]] || { echo "deb_depends.sh: $exe needs $soname: not in $sysroot" >&2; exit 1; }
    real="$(realpath --relative-to="$sysroot" "$sysroot$path")"
    pkg=""
    for candidate in "/$real" "$path"; do
      # The package lists name merged-/usr paths either way (/lib/... or /usr/lib/...).
      for variant in "$candidate" "/usr${candidate#/usr}" "${candidate#/usr}"; do
        [[ -n "$pkg" ]] || pkg="$(grep -lx -- "$variant" "$meta"/*.list 2>/dev/null | head -1 | xargs -r basename -s .list)"
      done
    done
    [[ -n "$pkg" ]] || { echo "deb_depends.sh: $path ($soname) belongs to no package of the sysroot" >&2; exit 1; }
    deps["$(shlibs_dep "$pkg" "$soname")"]=1
  done
done
printf '%s\n' "${!deps[@]}" | sort | paste -sd, | sed 's/,/, /g'
