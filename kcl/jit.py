"""How the KCL compiles its kernels (Numba), and keeps their on-disk caches honest.

Every compiled function of the KCL goes through :func:`njit`: cached on disk
(``__pycache__``, so only the first process on a machine compiles, for seconds),
holding the interpreter lock while it runs (the control step is the only caller,
and a kernel that released the lock would let the field drivers' reader threads
into the step and then wait for them to hand the lock back).

Numba keys a cached function on its OWN source file only, while the machine code
it stores embeds every compiled function it calls, possibly from other files: an
edit of such a callee would go unnoticed. :func:`drop_stale`, called by a module
at import before any of its kernels runs, deletes that module's cache entries
older than the files it depends on, so Numba compiles them again.

:func:`lock_types` stops a loaded kernel from compiling again for new argument
types: a call with an array of another kind (read-only, strided, another dtype)
then raises ``TypeError`` at once instead of compiling inside a control cycle.
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numba
from numba.core.errors import NumbaExperimentalFeatureWarning

# The task batch dispatches to the tasks' row kernels through a tuple of kernels
# (kcl.tasks.batch): Numba types such a tuple with its first-class function types,
# which it still labels experimental. The calls it makes are direct ones.
warnings.filterwarnings("ignore", category=NumbaExperimentalFeatureWarning)

F = TypeVar("F", bound=Callable[..., Any])


def drop_stale(module_file: str, dependencies: list[str]) -> int:
    """Delete ``module_file``'s Numba cache entries older than any of
    ``dependencies`` (source files). Returns how many were deleted. Caches kept
    elsewhere (``NUMBA_CACHE_DIR``, read-only installs) are left alone."""
    src = Path(module_file)
    cache_dir = src.parent / "__pycache__"
    try:
        newest = max(os.stat(d).st_mtime for d in dependencies)
        entries = list(cache_dir.glob(f"{src.stem}.*.nb[ic]"))
    except (OSError, ValueError):
        return 0
    dropped = 0
    for entry in entries:
        try:
            if entry.stat().st_mtime < newest:
                entry.unlink()
                dropped += 1
        except OSError:  # another process got there first, or no permission
            continue
    return dropped


_KCL = Path(__file__).resolve().parent
#: modules of compiled helpers that kernels anywhere in the KCL call
SHARED_SOURCES = [
    str(_KCL / name)
    for name in ("jit.py", "small_linalg.py", "buffers.py", "activation.py", "manipulability.py", "tasks/jit.py")
]


def njit(fn: F) -> F:
    """Compile ``fn`` (cached on disk, the interpreter lock held), after dropping the
    cache of its module when that is older than one of :data:`SHARED_SOURCES`."""
    module_file = sys.modules[fn.__module__].__file__
    if module_file is not None:
        drop_stale(module_file, SHARED_SOURCES)
    compiled: Any = numba.njit(cache=True, nogil=False)(fn)
    return compiled  # a Dispatcher, called like fn


def lock_types(kernel: Any) -> None:
    """Forbid further compilations of the loaded ``kernel`` (see the module docstring)."""
    kernel.disable_compile()
