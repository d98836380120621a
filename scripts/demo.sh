#!/usr/bin/env bash
# Set up (if needed) and run psdr-room end to end on the bundled example photo. Extra arguments are
# passed on as Hydra overrides, e.g. `scripts/demo.sh fov=fixed`.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
cd "$ROOT"
exec psdr-room image=examples/nyu_basement/photo.jpg "$@"
