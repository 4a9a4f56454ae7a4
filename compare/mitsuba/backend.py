"""Choose and load a Mitsuba variant, making Dr.Jit's LLVM backend work.

Dr.Jit 1.5 crashes with libLLVM 14 and 15 ("Cannot select: fminimum"), which
are Debian 12's defaults; Debian's ``libllvm19`` works when
``DRJIT_LIBLLVM_PATH`` points at it. The variable must be set before Dr.Jit is
first imported, so every module that needs Mitsuba goes through
:func:`load_mitsuba`.

Order of preference: ``cuda_ad_rgb`` (a GPU), ``llvm_ad_rgb``, ``scalar_rgb``
(with one warning saying how to get the fast backend).
"""

from __future__ import annotations

import glob
import os
import sys
import re
import warnings

from compare.util.errors import MissingComponentError

#: Oldest libLLVM major version known to work with Dr.Jit 1.5.
MIN_LLVM_MAJOR = 16

_INSTALL_HINT = (
    "install a newer libLLVM (on Debian 12: `apt-get install libllvm19`) and, if it is not "
    "found automatically, set DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
)

_SEARCH_GLOBS = (
    "/usr/lib/x86_64-linux-gnu/libLLVM*.so*",
    "/usr/lib/aarch64-linux-gnu/libLLVM*.so*",
    "/usr/lib/llvm-*/lib/libLLVM*.so*",
    "/usr/lib64/libLLVM*.so*",
    "/usr/local/lib/libLLVM*.so*",
)

_state: dict[str, object] = {}


def llvm_major(path: str) -> int | None:
    """The LLVM major version encoded in a libLLVM file name, or None."""
    name = os.path.basename(path)
    m = re.search(r"libLLVM[-.]?(\d+)", name) or re.search(r"\.so\.(\d+)", name)
    return int(m.group(1)) if m else None


def find_libllvm() -> str | None:
    """Path of the newest usable libLLVM (major >= MIN_LLVM_MAJOR) on this machine, or None."""
    best: tuple[int, str] | None = None
    for pattern in _SEARCH_GLOBS:
        for path in glob.glob(pattern):
            major = llvm_major(path)
            if major is None or major < MIN_LLVM_MAJOR or not os.path.isfile(path):
                continue
            if best is None or major > best[0]:
                best = (major, path)
    return best[1] if best else None


def configure_llvm() -> str | None:
    """Point DRJIT_LIBLLVM_PATH at a usable libLLVM unless the user already chose one.

    Returns the path in use, or None when no usable libLLVM was found.
    """
    current = os.environ.get("DRJIT_LIBLLVM_PATH")
    if current:
        major = llvm_major(current)
        if not os.path.isfile(current):
            raise MissingComponentError(
                f"DRJIT_LIBLLVM_PATH={current!r} does not exist; unset it or {_INSTALL_HINT}"
            )
        if major is not None and major < MIN_LLVM_MAJOR:
            raise MissingComponentError(
                f"DRJIT_LIBLLVM_PATH={current!r} is LLVM {major}, which crashes Dr.Jit 1.5; {_INSTALL_HINT}"
            )
        return current
    found = find_libllvm()
    if found:
        os.environ["DRJIT_LIBLLVM_PATH"] = found
    return found


#: The variants the suite renders with, in the order of preference of :func:`load_mitsuba`.
MITSUBA_VARIANTS = ("cuda_ad_rgb", "llvm_ad_rgb", "scalar_rgb")


#: Fewest worker threads Dr.Jit may have. With one, Mitsuba's loader deadlocks on the first EXR or texture:
#: it reads the file inside a task of Dr.Jit's pool and OpenEXR's line reads go back to the same pool, whose
#: only thread is the one waiting (a machine or container with one CPU, or one job per core).
MIN_THREADS = 2


def set_thread_count(n: int) -> int:
    """Give Dr.Jit ``n`` worker threads, at least :data:`MIN_THREADS`; returns the count set."""
    import drjit as dr

    n = max(MIN_THREADS, int(n))
    dr.set_thread_count(n)
    return n


def load_mitsuba(variant: str | None = None):
    """Import Mitsuba, select a variant and return the ``mitsuba`` module.

    ``variant`` None picks the best available (cuda_ad_rgb > llvm_ad_rgb >
    scalar_rgb); the environment variable ``COMPARE_MITSUBA_VARIANT`` overrides
    that choice. An explicitly requested variant that cannot be loaded raises
    :class:`MissingComponentError`.
    """
    requested = variant or os.environ.get("COMPARE_MITSUBA_VARIANT") or None
    llvm_path = configure_llvm()
    import drjit as dr  # noqa: PLC0415  (must follow configure_llvm)
    import mitsuba as mi  # noqa: PLC0415

    if dr.thread_count() < MIN_THREADS:  # a one-CPU machine: see MIN_THREADS
        set_thread_count(MIN_THREADS)

    if requested:
        if "llvm" in requested and llvm_path is None:
            raise MissingComponentError(f"Mitsuba variant {requested!r} needs libLLVM >= {MIN_LLVM_MAJOR}: {_INSTALL_HINT}")
        try:
            mi.set_variant(requested)
        except Exception as exc:  # Mitsuba raises ImportError/RuntimeError here
            raise MissingComponentError(f"cannot load Mitsuba variant {requested!r}: {exc}") from exc
        return mi

    if "variant" in _state:
        mi.set_variant(_state["variant"])
        return mi
    candidates = ["cuda_ad_rgb"] if _has_cuda() else []
    if llvm_path is not None:
        candidates.append("llvm_ad_rgb")
    for name in candidates:
        try:
            mi.set_variant(name)
            _state["variant"] = name
            return mi
        except Exception:  # noqa: BLE001 - try the next backend
            continue
    warnings.warn(
        "Mitsuba falls back to the slow scalar_rgb variant because no libLLVM >= "
        f"{MIN_LLVM_MAJOR} was found; to get the fast LLVM backend, {_INSTALL_HINT}",
        RuntimeWarning,
        stacklevel=2,
    )
    mi.set_variant("scalar_rgb")
    _state["variant"] = "scalar_rgb"
    return mi


def load_active_mitsuba(variant: str | None = None):
    """:func:`load_mitsuba` keeping the variant that is active now (none yet: the best one), or ``variant``."""
    if variant is None:
        loaded = sys.modules.get("mitsuba")
        variant = (loaded.variant() if loaded is not None else None) or None
    return load_mitsuba(variant)


def _has_cuda() -> bool:
    """True when an NVIDIA driver library is present (cheap check before trying CUDA)."""
    return bool(glob.glob("/usr/lib/x86_64-linux-gnu/libcuda.so*") or glob.glob("/usr/lib64/libcuda.so*"))


_INTEGRATORS: set[tuple[str, str]] = set()


def register_integrator_once(name: str, make_class):
    """Register the Python integrator ``make_class(mi)`` as ``name`` for the active Mitsuba variant, once
    per variant (Mitsuba's registry is per variant); returns ``mitsuba``."""
    import mitsuba as mi

    key = (name, mi.variant())
    if key not in _INTEGRATORS:
        cls = make_class(mi)
        mi.register_integrator(name, lambda props, _cls=cls: _cls(props))
        _INTEGRATORS.add(key)
    return mi
