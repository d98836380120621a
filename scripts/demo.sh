#!/usr/bin/env bash
# Set up (if needed) and run psdr-room end to end on the bundled example photo. Extra arguments are
# passed on as Hydra overrides, e.g. `scripts/demo.sh fov=fixed`.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
bash "$HERE/setup.sh"
source "$HERE/env.sh"
cd "$PSDR_ROOM_ROOT"
exec psdr-room image=examples/nyu_basement/photo.jpg "$@"
