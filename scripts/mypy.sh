#!/usr/bin/env bash
# mypy over the whole package tree, each module under the name Python imports it by. `plugins/` installs as
# `psdr_room_plugins` (pyproject's package-dir), a mapping mypy cannot make from a folder's name, so this checks a
# temporary tree of links named as the packages are and prints the paths as they are on disk. Arguments go to mypy.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tree="$(mktemp -d)"
trap 'rm -rf "$tree"' EXIT
ln -s "$root/psdr_room_core" "$tree/psdr_room_core"
ln -s "$root/plugins" "$tree/psdr_room_plugins"
cd "$tree"
status=0
mypy --config-file "$root/pyproject.toml" --no-incremental "$@" psdr_room_core psdr_room_plugins >"$tree/report" || status=$?
sed 's#^psdr_room_plugins/#plugins/#' "$tree/report"
exit "$status"
