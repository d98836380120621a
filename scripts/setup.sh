#!/usr/bin/env bash
# Prepare a machine for psdr-room: Debian libraries (as root), a virtualenv in .venv with pinned packages.
# Idempotent and quick when nothing changed; run (not sourced) by scripts/demo.sh and scripts/test.sh.
# --test also installs what only the tests use: Debian chromium and chromium-driver (the report and studio browser
# tests), Debian blender, python3-numpy and Mesa's EGL (the Blender export tests, EEVEE headless: about 90 MB
# installed, a minute or two),
# and, where npm exists, the Khronos glTF validator (into .venv/node_modules).
# `source scripts/env.sh` then puts the tools on your shell's PATH.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
PYTHON="${PYTHON:-python3}"
# libllvm19: Dr.Jit's LLVM backend (1.5 crashes on Debian's default LLVM 14/15); libusb-1.0-0: open3d.
DEB_PACKAGES=(libllvm19 libusb-1.0-0 libgl1 libgomp1)
TESTING=0
TEST_ONLY=(chromium chromium-driver blender python3-numpy libegl-mesa0 libgl1-mesa-dri)
[[ "${1:-}" == "--test" ]] && TESTING=1 && DEB_PACKAGES+=("${TEST_ONLY[@]}")
GLTF_VALIDATOR="gltf-validator@2.0.0-dev.3.10"

say() { printf 'psdr-room setup: %s\n' "$*" >&2; }
only_test_packages() {  # every argument is one of TEST_ONLY
    local pkg
    for pkg in "$@"; do [[ " ${TEST_ONLY[*]} " == *" $pkg "* ]] || return 1; done
}

missing=()
for pkg in "${DEB_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ((${#missing[@]})); then
    if [[ $(id -u) -eq 0 ]]; then
        say "installing Debian packages: ${missing[*]}"
        DEBIAN_FRONTEND=noninteractive apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
    elif only_test_packages "${missing[@]}"; then
        say "${missing[*]} missing: the tests that need them (browser, Blender) will be skipped (sudo apt-get install -y ${missing[*]} runs them)"
    else
        say "missing Debian packages: ${missing[*]}"
        say "install them with: sudo apt-get install -y ${missing[*]}   (then rerun this command)"
        exit 1
    fi
fi

if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' 2>/dev/null; then
    say "needs Python 3.11 (the pinned CPU torch wheel is built for it); set PYTHON=/path/to/python3.11"
    exit 1
fi

if [[ ! -x "$VENV/bin/python" ]]; then
    say "creating $VENV"
    "$PYTHON" -m venv "$VENV"
fi

stamp="$VENV/.psdr-room-installed"
want="$(cat "$ROOT/requirements.lock" "$ROOT/pyproject.toml" | sha256sum | cut -d' ' -f1)"
if [[ "$(cat "$stamp" 2>/dev/null)" != "$want" ]]; then
    say "installing pinned packages into $VENV (first time: a few minutes; log in $VENV/pip.log)"
    pip_quiet() {  # pip's own output goes to the log; shown only when it fails
        if ! "$VENV/bin/python" -m pip "$@" >>"$VENV/pip.log" 2>&1; then
            tail -n 30 "$VENV/pip.log" >&2
            say "pip $* failed (full log: $VENV/pip.log)"
            exit 1
        fi
    }
    : > "$VENV/pip.log"
    pip_quiet install --upgrade pip setuptools
    pip_quiet install -r "$ROOT/requirements.lock"
    pip_quiet install --no-deps --no-build-isolation -e "$ROOT"
    echo "$want" > "$stamp"
fi

if ((TESTING)) && [[ ! -d "$VENV/node_modules/gltf-validator" ]]; then
    if command -v npm >/dev/null; then
        say "installing the Khronos glTF validator ($GLTF_VALIDATOR) into $VENV/node_modules"
        npm install --silent --no-audit --no-fund --prefix "$VENV" "$GLTF_VALIDATOR" >>"$VENV/npm.log" 2>&1 \
            || say "npm install $GLTF_VALIDATOR failed (log: $VENV/npm.log); the .glb test will skip the validator"
    else
        say "npm not found: the .glb test will check the file without the Khronos validator"
    fi
fi
