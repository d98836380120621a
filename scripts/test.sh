#!/usr/bin/env bash
# Set up (if needed) and run the test suite. Extra arguments go to pytest (e.g. `-m slow` for the long runs).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
bash "$HERE/setup.sh" --test
source "$HERE/env.sh"
cd "$PSDR_ROOM_ROOT"
exec python -m pytest "$@"
