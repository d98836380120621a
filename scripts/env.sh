# Source me (`source scripts/env.sh`): psdr-room's virtualenv on PATH and Dr.Jit pointed at LLVM >= 16.
# Sets no shell options, so it is safe in an interactive shell. Run scripts/setup.sh first.
PSDR_ROOM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="$PSDR_ROOM_ROOT/.venv/bin:$PATH"
if [[ -z "${DRJIT_LIBLLVM_PATH:-}" ]]; then  # Dr.Jit finds libLLVM by name: name LLVM 19 explicitly
    for lib in /usr/lib/*/libLLVM.so.19* /usr/lib/*/libLLVM-19.so /usr/lib/llvm-19/lib/libLLVM*.so*; do
        if [[ -f "$lib" ]]; then export DRJIT_LIBLLVM_PATH="$lib"; break; fi
    done
fi
