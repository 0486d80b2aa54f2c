"""Named, independent random streams derived from one seed.

Every subsystem draws from its own generator ``child_rng(seed, "dvl")``; the
stream of one subsystem depends only on the seed and its name, so adding a new
sensor (or a new random scenario parameter) never changes what the others draw.
"""

from __future__ import annotations

import zlib

import numpy as np


def stable_id(name: str) -> int:
    """A process-independent 32-bit id of ``name`` (``hash()`` is salted per process)."""
    return zlib.crc32(name.encode("utf-8"))


def child_rng(seed: int, *names: str) -> np.random.Generator:
    """Generator for the stream ``names`` of run ``seed``."""
    ss = np.random.SeedSequence(entropy=int(seed), spawn_key=tuple(stable_id(n) for n in names))
    return np.random.Generator(np.random.PCG64(ss))


class NormalBlock:
    """Standard normal samples drawn from ``rng`` in blocks (far cheaper than many
    tiny draws). The sequence is the same however it is consumed."""

    def __init__(self, rng: np.random.Generator, block: int = 4096):
        self._rng = rng
        self._block = block
        self._buf = rng.standard_normal(block)
        self._i = 0

    def take(self, n: int) -> np.ndarray:
        """Next ``n`` samples (a fresh array)."""
        if self._i + n > self._block:
            self._buf = np.concatenate([self._buf[self._i :], self._rng.standard_normal(self._block)])
            self._i = 0
        out = self._buf[self._i : self._i + n].copy()
        self._i += n
        return out

    def reserve(self, n: int) -> tuple[np.ndarray, int]:
        """The next ``n`` samples as ``(buffer, start)``: they are ``buffer[start:start + n]``
        (no copy; valid until the next call). Same sequence and same refills as :meth:`take`."""
        if self._i + n > self._block:
            self._buf = np.concatenate([self._buf[self._i :], self._rng.standard_normal(self._block)])
            self._i = 0
        i = self._i
        self._i = i + n
        return self._buf, i

    def take_list(self, n: int) -> list[float]:
        """Next ``n`` samples as Python floats (same sequence as :meth:`take`)."""
        return self.take(n).tolist()
