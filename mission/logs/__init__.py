"""Run logs: one MCAP file per run (JSON messages with JSON schemas).

* :mod:`mission.logs.channels` - the topics, their JSON schemas, time stamps.
* :mod:`mission.logs.writer` - :class:`RunLogWriter`, crash-safe (small chunks,
  flushed on a wall-clock interval) so a killed run leaves a readable file.
* :mod:`mission.logs.reader` - :func:`read_log` (tolerates truncated files).
* :mod:`mission.logs.summary`, :mod:`mission.logs.plots`, :mod:`mission.logs.export`
  - the ``maris log summary|plot|export`` back ends.

* :mod:`mission.logs.wellknown`, :mod:`mission.logs.frames` - the Foxglove
  well-known channels (3D frames, scenes, log, poses, named joints).
* :mod:`mission.logs.live` - the Foxglove WebSocket server of ``--live``.
* :mod:`mission.logs.treeview`, :mod:`mission.logs.recover`,
  :mod:`mission.logs.runmeta` - tree rendering, repair of cut logs, metadata.

Message times are the backend clock (s) converted to integer nanoseconds (plus
the wall-clock offset on field runs), so a simulated run starts near 0.
See docs/foxglove.md.
"""
