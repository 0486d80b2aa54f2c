"""Operating-system means for a steady real-time loop (``maris run`` options).

* :class:`ProcessSettings` / :func:`apply_process_settings`: scheduling policy
  and priority (``--rt-priority``: SCHED_FIFO, so ordinary processes such as a
  campaign cannot take the CPU from the loop or the drivers' reader
  threads), niceness (``--nice``) and CPU affinity (``--rt-affinity``), applied
  to every thread of this process and inherited by the threads started later
  (the drivers'); when the loop starts, :func:`put_loop_first` moves the other
  threads one priority below the loop's. Linux; raising priority needs root or CAP_SYS_NICE. And
  Python's GIL switch interval (``--gil-interval``): the drivers' reader
  threads share the interpreter with the loop, and a thread that wants the GIL
  waits up to this long (default 5 ms) for the holder to let go.
* :class:`GcControl`: the garbage collector around the supervisor loop
  (``--gc``): ``auto`` (Python's own), ``freeze`` (collect once and move every
  object built while loading to the permanent generation before the loop, so
  the automatic collections during the loop only walk young objects),
  ``manual`` (freeze, disable the automatic collector, collect the young
  generation at every tree tick inside the step, generation 1 every 5 s of
  tree ticks, everything after the loop). With ``manual``, cyclic garbage that
  survives into generation 2 during the run is only freed after the loop
  (the supervisor's steady state makes almost none). Every collection during
  the loop is timed (``gc.callbacks``) and reported as ``wall_gc``.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import os
import sys
import threading
import time
from array import array
from dataclasses import dataclass
from typing import Any

#: ``--gc`` choices.
GC_MODES = ("auto", "freeze", "manual")


class ProcessSettingError(RuntimeError):
    """A process setting could not be applied (message says why and what to do)."""


def parse_cpus(text: str) -> frozenset[int]:
    """``"1"``, ``"0,2"``, ``"0-3"`` -> CPU numbers; ValueError with the reason."""
    cpus: set[int] = set()
    for part in text.replace(" ", "").split(","):
        if not part:
            continue
        lo, sep, hi = part.partition("-")
        if not lo.isdigit() or (sep and not hi.isdigit()):
            raise ValueError(f"expected CPU numbers such as 1, 0,1 or 0-1, got {text!r}")
        first, last = int(lo), int(hi) if sep else int(lo)
        if last < first:
            raise ValueError(f"empty CPU range {part!r} in {text!r}")
        cpus.update(range(first, last + 1))
    if not cpus:
        raise ValueError(f"no CPU given in {text!r}")
    return frozenset(cpus)


@dataclass(frozen=True)
class ProcessSettings:
    """What to ask of the OS for this process. ``None`` leaves a setting as it is."""

    #: SCHED_FIFO priority 1..99 (higher preempts lower; every SCHED_OTHER process yields to it).
    rt_priority: int | None = None
    #: Niceness -20..19 of SCHED_OTHER threads (negative needs privileges); ignored under SCHED_FIFO.
    nice: int | None = None
    #: CPUs the process may run on.
    cpus: frozenset[int] | None = None
    #: Python's thread switch interval (s; ``sys.setswitchinterval``, default 0.005): how long
    #: the loop may wait for the GIL while a driver thread holds it.
    gil_interval_s: float | None = None
    #: Lock every page of the process in memory, now and later (``mlockall``): no page of the
    #: loop's code or data is paged out (and faulted back in during a step) while it runs.
    lock_memory: bool = False

    @property
    def empty(self) -> bool:
        return (
            self.rt_priority is None
            and self.nice is None
            and self.cpus is None
            and self.gil_interval_s is None
            and not self.lock_memory
        )


def _threads() -> list[int]:
    """Native ids of this process's threads (Linux), or ``[0]`` (the calling thread)."""
    try:
        return [int(t) for t in os.listdir("/proc/self/task")]
    except OSError:
        return [0]


def _memory_locked() -> bool:
    """Whether this process's pages are locked (``VmLck`` of /proc/self/status above 0)."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.startswith("VmLck:"):
                    return int(line.split()[1]) > 0
    except (OSError, ValueError, IndexError):
        pass
    return False


def current_settings() -> dict[str, Any]:
    """What this thread runs with now: ``policy``, ``rt_priority``, ``nice``, ``cpus``."""
    out: dict[str, Any] = {
        "policy": "other",
        "rt_priority": None,
        "nice": os.getpriority(os.PRIO_PROCESS, 0),
        "gil_interval_s": sys.getswitchinterval(),
        "memory_locked": _memory_locked(),
    }
    if hasattr(os, "sched_getscheduler"):
        policy = os.sched_getscheduler(0)
        names = {os.SCHED_OTHER: "other", os.SCHED_FIFO: "fifo", os.SCHED_RR: "rr"}
        out["policy"] = names.get(policy, str(policy))
        if policy in (os.SCHED_FIFO, os.SCHED_RR):
            out["rt_priority"] = os.sched_getparam(0).sched_priority
    if hasattr(os, "sched_getaffinity"):
        out["cpus"] = sorted(os.sched_getaffinity(0))
    return out


def apply_process_settings(settings: ProcessSettings) -> dict[str, Any]:
    """Apply ``settings`` to every thread of this process; returns :func:`current_settings`.

    Raises :class:`ProcessSettingError` naming the setting, the OS's reason and the fix."""
    if settings.gil_interval_s is not None:
        if not 1e-5 <= settings.gil_interval_s <= 0.1:
            raise ProcessSettingError(f"--gil-interval must be 0.01..100 ms, got {1e3 * settings.gil_interval_s:g} ms")
        sys.setswitchinterval(settings.gil_interval_s)
    if settings.cpus is not None:
        if not hasattr(os, "sched_setaffinity"):
            raise ProcessSettingError("--rt-affinity: CPU affinity is not supported on this OS")
        available = set(range(os.cpu_count() or 1))
        if not settings.cpus <= available:
            raise ProcessSettingError(
                f"--rt-affinity: no CPU {sorted(settings.cpus - available)} here "
                f"(this machine has CPUs {min(available)}-{max(available)})"
            )
        for tid in _threads():
            _os_call(os.sched_setaffinity, "--rt-affinity", tid, settings.cpus)
    if settings.nice is not None:
        if not -20 <= settings.nice <= 19:
            raise ProcessSettingError(f"--nice must be in -20..19, got {settings.nice}")
        for tid in _threads():
            _os_call(os.setpriority, "--nice", os.PRIO_PROCESS, tid, settings.nice)
    if settings.lock_memory:
        lock_memory()
    if settings.rt_priority is not None:
        if not hasattr(os, "sched_setscheduler"):
            raise ProcessSettingError("--rt-priority: real-time scheduling is not supported on this OS")
        if not 1 <= settings.rt_priority <= os.sched_get_priority_max(os.SCHED_FIFO):
            raise ProcessSettingError(
                f"--rt-priority must be in 1..{os.sched_get_priority_max(os.SCHED_FIFO)}, got {settings.rt_priority}"
            )
        param = os.sched_param(settings.rt_priority)
        for tid in _threads():
            _os_call(os.sched_setscheduler, "--rt-priority", tid, os.SCHED_FIFO, param)
    return current_settings()


#: ``mlockall`` flags: the pages mapped now and those mapped later (Linux values).
_MCL_CURRENT, _MCL_FUTURE = 1, 2


def lock_memory() -> None:
    """``mlockall(MCL_CURRENT | MCL_FUTURE)``: keep every page of this process in RAM
    (the kernel may otherwise page out file-backed pages such as the interpreter's and
    the libraries' code when they look cold, and fault them back in during a step).
    Raises :class:`ProcessSettingError` with the OS's reason and the fix."""

    name = ctypes.util.find_library("c")
    if sys.platform != "linux" or name is None:
        raise ProcessSettingError("--lock-memory: mlockall is only supported on Linux here")
    libc = ctypes.CDLL(name, use_errno=True)
    if libc.mlockall(_MCL_CURRENT | _MCL_FUTURE) != 0:
        err = ctypes.get_errno()
        raise ProcessSettingError(
            f"--lock-memory: mlockall refused ({os.strerror(err)}); run as root, give the "
            "interpreter CAP_IPC_LOCK, or raise the memlock limit (ulimit -l unlimited)"
        )


def put_loop_first() -> dict[str, Any] | None:
    """Under SCHED_FIFO priority P (``--rt-priority``), move every other thread of this
    process (the drivers' readers and service threads, started by then) to P - 1 and
    keep the calling thread, the loop, at P: when the interpreter lock is released
    the kernel wakes the highest-priority waiter first, so the loop no longer races
    the drivers' threads for it at its tick. Returns ``{"loop": P, "others": P - 1,
    "threads": n}``, or None when not under SCHED_FIFO (or P is 1: nothing below)."""
    if not hasattr(os, "sched_getscheduler") or os.sched_getscheduler(0) != os.SCHED_FIFO:
        return None
    prio = os.sched_getparam(0).sched_priority
    if prio <= 1:
        return None
    me = threading.get_native_id()
    lower = os.sched_param(prio - 1)
    others = [tid for tid in _threads() if tid != me]
    for tid in others:
        _os_call(os.sched_setscheduler, "--rt-priority", tid, os.SCHED_FIFO, lower)
    return {"loop": prio, "others": prio - 1, "threads": len(others)}


def _os_call(fn: Any, option: str, *args: Any) -> None:
    try:
        fn(*args)
    except ProcessLookupError:
        pass  # that thread ended meanwhile
    except PermissionError as exc:
        raise ProcessSettingError(
            f"{option}: not permitted ({exc.strerror}); run as root or give the Python "
            "binary CAP_SYS_NICE (sudo setcap cap_sys_nice+ep <python>)"
        ) from None
    except OSError as exc:
        raise ProcessSettingError(f"{option}: {exc.strerror or exc}") from None


class GcControl:
    """The garbage-collector policy around one supervisor loop (see the module docstring)."""

    def __init__(self, mode: str = "auto") -> None:
        if mode not in GC_MODES:
            raise ValueError(f"gc mode must be one of {', '.join(GC_MODES)}, got {mode!r}")
        self.mode = mode
        self.manual = mode == "manual"
        #: Duration (s) of every collection during the loop, and its generation.
        self.pauses = array("d")
        self.generations = array("b")
        self._t = 0.0
        self._ticks = 0
        self._was_enabled = True
        self._active = False

    def _callback(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._t = time.perf_counter()
        else:
            self.pauses.append(time.perf_counter() - self._t)
            self.generations.append(int(info.get("generation", -1)))

    def start(self) -> None:
        """Before the loop's first step."""
        self._was_enabled = gc.isenabled()
        if self.mode != "auto":
            gc.collect()
            gc.freeze()
        if self.manual:
            gc.disable()
        gc.callbacks.append(self._callback)
        self._active = True

    def tick(self) -> None:
        """``manual``: one collection, at a tree tick (10 Hz for the shipped missions)."""
        self._ticks += 1
        gc.collect(1 if self._ticks % 50 == 0 else 0)

    def stop(self) -> None:
        """After the loop (also after an error): the collector as it was before :meth:`start`."""
        if not self._active:
            return
        self._active = False
        if self._callback in gc.callbacks:
            gc.callbacks.remove(self._callback)
        if self.mode != "auto":
            gc.unfreeze()
        if self._was_enabled:
            gc.enable()

    def summary(self) -> dict[str, Any]:
        """``{mode, collections, max_s, total_s, by_generation}`` of the collections during the loop."""
        p = list(self.pauses)
        by_gen = {str(g): sum(1 for x in self.generations if x == g) for g in (0, 1, 2)}
        return {
            "mode": self.mode,
            "collections": len(p),
            "max_s": max(p) if p else 0.0,
            "total_s": sum(p),
            "by_generation": by_gen,
        }
