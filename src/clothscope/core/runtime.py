"""Mitsuba/Dr.Jit runtime set-up: libLLVM discovery, variant choice, thread count.

Import :func:`mitsuba_for` instead of ``import mitsuba`` so that every process
picks a working libLLVM, the configured variant and the job's thread count the
same way, and can record the choice in its outputs.
"""
from __future__ import annotations

import glob
import os
import re
from types import ModuleType

#: Oldest libLLVM major version known to work with drjit 1.5 (15 crashes).
MIN_LLVM_MAJOR = 16
LLVM_SEARCH_DIRS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64", "/usr/lib")
VARIANTS = ("auto", "llvm_ad_rgb", "cuda_ad_rgb", "scalar_rgb")


def find_libllvm() -> str | None:
    """Return the path of the newest system libLLVM with major >= 16, or None."""
    best: tuple[int, str] | None = None
    for folder in LLVM_SEARCH_DIRS:
        for path in glob.glob(os.path.join(folder, "libLLVM*.so*")):
            match = re.search(r"libLLVM[-.]?(?:so\.)?(\d+)", os.path.basename(path))
            if match and int(match.group(1)) >= MIN_LLVM_MAJOR:
                major = int(match.group(1))
                if best is None or major > best[0]:
                    best = (major, path)
    return best[1] if best else None


def ensure_libllvm() -> str | None:
    """Point drjit at a working libLLVM through ``DRJIT_LIBLLVM_PATH`` (unless set)."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    path = find_libllvm()
    if path:
        os.environ["DRJIT_LIBLLVM_PATH"] = path
    return path


def cuda_available() -> bool:
    """True when Dr.Jit can initialise its CUDA backend on this machine."""
    import drjit as dr  # here, not at the top: this module runs before drjit may be imported (clothscope/__init__.py)

    try:
        return bool(dr.has_backend(dr.JitBackend.CUDA))
    except Exception:  # noqa: BLE001 - any driver failure means "no usable GPU"
        return False


def resolve_variant(requested: str = "auto") -> str:
    """Map a configured variant to a concrete Mitsuba variant.

    ``auto`` gives ``cuda_ad_rgb`` when a usable CUDA GPU is present and
    ``llvm_ad_rgb`` otherwise.

    Raises
    ------
    ValueError
        If ``requested`` is not one of :data:`VARIANTS`, or the LLVM variant is
        asked for but no working libLLVM is installed.
    """
    if requested not in VARIANTS:
        raise ValueError(f"unknown Mitsuba variant {requested!r}; choose one of {', '.join(VARIANTS)}")
    ensure_libllvm()
    if requested == "auto":
        requested = "cuda_ad_rgb" if cuda_available() else "llvm_ad_rgb"
    if requested.startswith("llvm") and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        raise ValueError(
            "no libLLVM >= 16 found: install Debian's libllvm19 (apt-get install libllvm19) "
            "or set DRJIT_LIBLLVM_PATH"
        )
    return requested


def mitsuba_for(variant: str = "auto", threads: int | None = None) -> ModuleType:
    """Import Mitsuba with the resolved variant set and the Dr.Jit thread count applied."""
    resolved = resolve_variant(variant)
    import drjit as dr  # see cuda_available
    import mitsuba as mi  # about 1 s to import: only jobs that render pay it

    mi.set_variant(resolved)
    if threads:
        dr.set_thread_count(int(threads))
    return mi


def runtime_metadata(mi: ModuleType) -> dict[str, str]:
    """Versions and variant to record beside every rendered output."""
    import drjit as dr  # see cuda_available

    return {
        "mitsuba_variant": str(mi.variant()),
        "mitsuba_version": str(mi.__version__),
        "drjit_version": str(dr.__version__),
        "libllvm": os.environ.get("DRJIT_LIBLLVM_PATH", ""),
    }
