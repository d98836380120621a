"""Find a usable libLLVM for Dr.Jit's LLVM backend and select the Mitsuba variant.

Dr.Jit 1.5 refuses LLVM 14 and crashes on some kernels with LLVM 15 ("LLVM ERROR: Cannot select ...
fminimum", ``RENDERING-NOTES.md``); LLVM >= 16 works (Debian ``libllvm19``). Dr.Jit reads
``DRJIT_LIBLLVM_PATH`` when it is first imported, so :func:`ensure_llvm` must run before ``import drjit``.
Nothing here imports drjit or mitsuba at module level.
"""

from __future__ import annotations

import glob
import os
import re
from collections.abc import Iterable
from pathlib import Path

from psdr_room_core.engine.errors import PsdrRoomError

MIN_LLVM = 16
"""Oldest LLVM major version that runs every kernel we use."""

DEBIAN_PACKAGE = "libllvm19"

SEARCH_GLOBS = (
    "/usr/lib/*/libLLVM*.so*",
    "/usr/lib/libLLVM*.so*",
    "/usr/lib/llvm-*/lib/libLLVM*.so*",
    "/usr/lib64/libLLVM*.so*",
    "/usr/local/lib/libLLVM*.so*",
)
"""Where shared libLLVM builds live on Debian/Ubuntu (multiarch and /usr/lib/llvm-N) and elsewhere."""

VARIANTS = ("auto", "llvm_ad_rgb", "cuda_ad_rgb", "scalar_rgb")

_NAME = re.compile(r"^libLLVM(?:-(?P<a>\d+)[^/]*?\.so(?:\.[\d.]+)?|\.so(?:\.(?P<b>\d+)(?:\.[\d.]*)?)?)$")
_DIR = re.compile(r"llvm-(\d+)")


def llvm_version(path: str | Path) -> int | None:
    """The LLVM major version of a shared library file, from its name (``libLLVM-15.so.1``,
    ``libLLVM.so.19.1``, ``libLLVM-19.so``) or its directory (``/usr/lib/llvm-19/lib/libLLVM.so``);
    None for static archives, component libraries (``libLLVMCore.so``) and names without a version."""
    path = Path(path)
    match = _NAME.match(path.name)
    if match is None:
        return None
    version = match.group("a") or match.group("b")
    if version is None:  # bare libLLVM.so: versioned by its directory, if at all
        for part in reversed(path.parts[:-1]):
            found = _DIR.fullmatch(part)
            if found:
                return int(found.group(1))
        return None
    return int(version)


def find_llvm(patterns: Iterable[str] = SEARCH_GLOBS) -> tuple[str | None, list[tuple[int, str]]]:
    """(best library, every versioned candidate found): the newest LLVM >= :data:`MIN_LLVM`, else None."""
    found: dict[str, int] = {}
    for pattern in patterns:
        for name in glob.glob(pattern):
            version = llvm_version(name)
            if version is not None and os.path.isfile(name):
                found[name] = version
    candidates = sorted(((v, p) for p, v in found.items()), key=lambda vp: (vp[0], -len(vp[1]), vp[1]))
    usable = [(v, p) for v, p in candidates if v >= MIN_LLVM]
    return (usable[-1][1] if usable else None), candidates


def ensure_llvm(patterns: Iterable[str] = SEARCH_GLOBS, environ: dict[str, str] | None = None) -> str:
    """Point ``DRJIT_LIBLLVM_PATH`` at a libLLVM >= 16 (kept if already set to an existing file).

    Returns the path. Raises :class:`PsdrRoomError` naming the Debian package when none is found.
    """
    env = os.environ if environ is None else environ
    current = env.get("DRJIT_LIBLLVM_PATH", "")
    if current and os.path.isfile(current):
        version = llvm_version(current)
        if version is not None and version < MIN_LLVM:
            raise PsdrRoomError(
                f"DRJIT_LIBLLVM_PATH={current} is LLVM {version}, but the mitsuba renderer needs LLVM >= {MIN_LLVM}; "
                f"install it with `apt-get install {DEBIAN_PACKAGE}` and unset DRJIT_LIBLLVM_PATH (or point it at "
                "libLLVM.so.19)"
            )
        return current
    best, candidates = find_llvm(patterns)
    if best is None:
        seen = ", ".join(f"{p} (LLVM {v})" for v, p in candidates) or "none"
        raise PsdrRoomError(
            f"renderer=mitsuba (llvm_ad_rgb) needs a libLLVM >= {MIN_LLVM} for Dr.Jit, found: {seen}; install it "
            f"with `apt-get install {DEBIAN_PACKAGE}` (Debian/Ubuntu) or set DRJIT_LIBLLVM_PATH to a libLLVM.so of "
            f"LLVM >= {MIN_LLVM}"
        )
    env["DRJIT_LIBLLVM_PATH"] = best
    return best


def _cuda_works() -> bool:
    import drjit as dr

    try:
        return bool(dr.has_backend(dr.JitBackend.CUDA))
    except Exception:  # no driver, or a driver that fails to initialise
        return False


def _check_llvm_backend() -> None:
    """Dr.Jit loads libLLVM when it is first imported: if something imported it before
    :func:`ensure_llvm` ran, with an unusable library, say so."""
    import drjit as dr

    if not dr.has_backend(dr.JitBackend.LLVM):
        raise PsdrRoomError(
            "Dr.Jit's LLVM backend did not start (drjit was imported before DRJIT_LIBLLVM_PATH was set, or the "
            f"library is too old); install `{DEBIAN_PACKAGE}` and export DRJIT_LIBLLVM_PATH=/usr/lib/<arch>/"
            "libLLVM.so.19 before starting psdr-room"
        )


def resolve_variant(variant: str = "auto") -> str:
    """The Mitsuba variant to use: ``auto`` is ``cuda_ad_rgb`` when a CUDA device works, else
    ``llvm_ad_rgb``. Sets up LLVM first when the LLVM backend may be used; imports drjit."""
    if variant not in VARIANTS:
        raise PsdrRoomError(f"renderer.mitsuba.variant={variant!r} is not supported; use one of {', '.join(VARIANTS)}")
    if variant in ("auto", "llvm_ad_rgb"):
        llvm_error: PsdrRoomError | None = None
        try:
            ensure_llvm()
        except PsdrRoomError as exc:
            if variant == "llvm_ad_rgb":
                raise
            llvm_error = exc
        if llvm_error is None:
            _check_llvm_backend()
        if variant == "auto":
            if _cuda_works():
                return "cuda_ad_rgb"
            if llvm_error is not None:
                raise llvm_error
            return "llvm_ad_rgb"
        return variant
    if variant == "cuda_ad_rgb" and not _cuda_works():
        raise PsdrRoomError(
            "renderer.mitsuba.variant=cuda_ad_rgb but no CUDA device works here; use variant=auto or llvm_ad_rgb"
        )
    return variant
