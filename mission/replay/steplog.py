"""The input record's core: the records of each backend step, written in batches.

:class:`Recorder` is shared by the recording proxies (:mod:`mission.replay.proxies`,
:class:`RecordingClock`); it notes every read result and command of the step in
progress in a :class:`StepLog`, which writes :data:`~mission.replay.schema.STEPS_PER_MESSAGE`
closed steps per ``/replay/steps`` message.

Cost: this runs several times per 10 ms base step, so a record is kept as plain
Python values (the :mod:`mission.replay.codec` encoders copy arrays into lists,
so a reading changed in place later cannot change its record) and the whole
batch is encoded by one ``orjson.dumps`` when it is written. A batch whose JSON
holds ``null`` outside a text (a non-finite number or a None; not the word in a
text, as the health infos' ``"last_delay_s": null``) is looked at record by record (:func:`mission.replay.codec.has_nonfinite`), and encoded again
with the non-finite values marked (:func:`mission.replay.codec.mark_nonfinite`)
only if it holds one, so NaN and the infinities come back exactly.

A read is recorded only when its result differs from the previous read of the
same name: not the same object (readings are never changed in place) and not the
same values (compared as JSON text when ``==`` finds them equal: ``0.0 == -0.0``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import orjson

from mission.replay import codec
from mission.replay.schema import HEADER_TOPIC, STEP_TOPIC, STEPS_PER_MESSAGE

_OPT = codec.OPTIONS
_default = codec.default


def _dumps(rec: Any) -> bytes:
    return orjson.dumps(rec, default=_default, option=_OPT)


def _marked(step: dict) -> dict:
    """``step`` with the non-finite numbers of its reads and commands marked (a record
    without any is kept as it is: :func:`mission.replay.codec.mark_nonfinite` would
    give a copy that encodes to the same bytes)."""
    out = dict(step)
    needs, mark = codec.has_nonfinite, codec.mark_nonfinite
    out["reads"] = [mark(r) if needs(r) else r for r in step["reads"]]
    out["commands"] = [mark(c) if needs(c) else c for c in step["commands"]]
    return out


def _may_hold_nonfinite(data: bytes) -> bool:
    """Whether the encoded batch ``data`` has a ``null`` that may be a number's: every
    ``null`` written as ``\\":null`` sits in a text (a backslash only occurs inside a
    JSON string), e.g. a health info's ``"last_delay_s":null``; any other one is looked
    at record by record."""
    nulls = data.count(b"null")
    return nulls > 0 and nulls != data.count(b'\\":null')


def _step_has_nonfinite(step: dict) -> bool:
    """Whether :func:`_marked` would mark anything in ``step``."""
    needs = codec.has_nonfinite
    return any(map(needs, step["reads"])) or any(map(needs, step["commands"]))


class StepLog:
    """The records of the step in progress, written to the run log in batches of steps."""

    def __init__(self, log: Any) -> None:
        self.log = log
        self.step = 0
        #: Last clock reading served (s): the time of the step.
        self.t = 0.0
        #: Read records of this step (``{"call", "k", ...fields}``).
        self.reads: list[dict] = []
        #: Commands of this step, as ``{"call", "values"/"text", ...}``.
        self.commands: list[dict] = []
        #: The ``/replay/header`` message, written with the first steps (its time is the
        #: first clock reading: reading the clock for it would be one more call to serve).
        self.header: dict | None = None
        self.t_first: float | None = None
        self.batch: list[dict] = []

    def write_header(self) -> None:
        if self.header is not None and self.log is not None:
            header, self.header = self.header, None
            self.log.write(HEADER_TOPIC, self.t if self.t_first is None else self.t_first, header)

    def end_step(self, dt: float | None) -> None:
        """Close the step (``dt``: the advance that ends it, None for the last one)."""
        if dt is None:
            rec = {"step": self.step, "t": self.t, "reads": self.reads, "commands": self.commands}
        else:
            rec = {"step": self.step, "t": self.t, "dt": dt, "reads": self.reads, "commands": self.commands}
        batch = self.batch
        batch.append(rec)
        self.reads = []
        self.commands = []
        self.step += 1
        if len(batch) >= STEPS_PER_MESSAGE:
            self.write()

    def write(self) -> None:
        """Write the steps closed so far."""
        self.write_header()
        batch = self.batch
        if batch:
            data = _dumps(batch)
            if _may_hold_nonfinite(data) and any(map(_step_has_nonfinite, batch)):
                data = _dumps([_marked(s) for s in batch])
            self.log.write(STEP_TOPIC, self.t, {"steps": orjson.Fragment(data)})
            self.batch = []


class Stream:
    """One call name: its per-step call counter and last recorded result."""

    __slots__ = ("name", "step", "k", "last", "last_obj")

    def __init__(self, name: str) -> None:
        self.name = name
        self.step = -1
        self.k = 0
        self.last: dict | None = None
        self.last_obj: Any = None

    def next_k(self, steps: StepLog) -> int:
        if self.step != steps.step:
            self.step = steps.step
            self.k = 0
        else:
            self.k += 1
        return self.k

    def put(self, steps: StepLog, k: int, fields: dict) -> None:
        """Append the record ``fields`` (whatever the previous one was)."""
        self.last = fields
        steps.reads.append({"call": self.name, "k": k, **fields})

    def error(self, steps: StepLog, k: int, exc: BaseException) -> None:
        self.last = self.last_obj = None  # the next result is written whatever it is
        steps.reads.append({"call": self.name, "k": k, **codec.error_fields(exc)})


class Recorder:
    """Shared by the proxies: reads and commands into one :class:`StepLog`.

    Every recorded call goes through here, many times per step: keep it lean."""

    def __init__(self, steps: StepLog) -> None:
        self.steps = steps
        self._streams: dict[str, Stream] = {}

    def stream(self, name: str) -> Stream:
        s = self._streams.get(name)
        if s is None:
            s = self._streams[name] = Stream(name)
        return s

    def read(self, stream: Stream, fn: Callable[[], Any], encode: Callable[[Any], dict]) -> Any:
        """``fn()``, its result (or exception) recorded as call ``stream.name``."""
        steps = self.steps
        if stream.step != steps.step:
            stream.step = steps.step
            stream.k = k = 0
        else:
            stream.k = k = stream.k + 1
        try:
            value = fn()
        except Exception as exc:
            stream.error(steps, k, exc)
            raise
        if value is not stream.last_obj or value is None:  # a cached reading handed out again costs nothing
            stream.last_obj = value
            fields = encode(value)
            last = stream.last
            if fields != last or _dumps(fields) != _dumps(last):
                stream.last = fields
                steps.reads.append({"call": stream.name, "k": k, **fields})
        return value

    def call(self, stream: Stream, fn: Callable[..., Any], args: tuple, kwargs: dict) -> Any:
        """A driver's own method (beyond :mod:`hal.interfaces`, e.g. ``reset_faults``): its
        arguments and result (JSON text) recorded, every time."""
        steps = self.steps
        k = stream.next_k(steps)
        try:
            value = fn(*args, **kwargs)
        except Exception as exc:
            stream.error(steps, k, exc)
            raise
        rec: dict[str, Any] = {"result": codec.dumps_value(value)}
        if args or kwargs:
            rec["args"] = codec.dumps_value({"args": list(args), "kwargs": kwargs})
        stream.put(steps, k, rec)
        return value

    def command(
        self, call: str, fn: Callable[..., Any], *args: Any, values: Any = None, text: str | None = None
    ) -> Any:
        """``fn(*args)``, recorded as command ``call`` with its ``values`` (numbers) or ``text``."""
        rec: dict[str, Any] = {"call": call}
        if values is not None:
            rec["values"] = (
                values.tolist()
                if type(values) is codec.ND and values.dtype is codec.F64
                else codec.f64(values).tolist()
            )
        elif text is not None:
            rec["text"] = text
        self.steps.commands.append(rec)  # before the call: a command that raises keeps its place in the order
        try:
            return fn(*args)
        except Exception as exc:
            rec.update(codec.error_fields(exc))
            raise


class RecordingClock:
    """The wrapped clock; each reading that differs from the previous one is recorded."""

    def __init__(self, inner: Any, rec: Recorder) -> None:
        self._now = inner.now
        self._steps = rec.steps
        self._stream = rec.stream("clock.now")
        self._last: float | None = None

    def now(self) -> float:
        t = self._now()
        steps = self._steps
        stream = self._stream
        if stream.step != steps.step:
            stream.step = steps.step
            stream.k = k = 0
        else:
            stream.k = k = stream.k + 1
        last = self._last
        if t != last or (t == 0.0 and math.copysign(1.0, t) != math.copysign(1.0, last)):  # type: ignore[arg-type]
            if last is None:
                steps.t_first = t
            self._last = t
            steps.reads.append({"call": "clock.now", "k": k, "t": t})
        steps.t = t
        return t
