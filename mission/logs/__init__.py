"""Run logs: one MCAP file per run (JSON messages with JSON schemas).

* :mod:`mission.logs.channels` - the topics, their JSON schemas, time stamps.
* :mod:`mission.logs.writer` - :class:`RunLogWriter`, crash-safe (small chunks,
  flushed on a wall-clock interval) so a killed run leaves a readable file.
* :mod:`mission.logs.reader` - :func:`read_log` (tolerates truncated files).
* :mod:`mission.logs.summary`, :mod:`mission.logs.plots`, :mod:`mission.logs.export`
  - the ``maris log summary|plot|export`` back ends.

Message times are the backend clock (s) converted to integer nanoseconds, so a
simulated run starts near 0 in Foxglove.
"""
