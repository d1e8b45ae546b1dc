#!/usr/bin/env bash
# README command 1: install what is missing, build, and run the main job on the bundled default:
# replay the recorded drives in replay/ through the estimator and print EG, its uncertainty,
# the adequacy state and where the report was written. Extra arguments go to `ndsid replay`.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$here/scripts/setup.sh"
exec "${NDSID_BUILD_DIR:-$here/build}/bin/ndsid" replay "$@"
