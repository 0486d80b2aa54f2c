"""Exact replay of a run from its log, and open-loop what-if runs.

A run log written by ``maris sim`` or ``maris run`` holds every input the
supervisor consumed, step by step (``/replay/steps``; see
:mod:`mission.replay.record`): each device reading a step used, device health,
detections, operator commands with the step they were consumed at, the clock
readings, exceptions raised by devices, and every command sent to the devices.
The supervisor has no random seeds of its own (the simulator's seed drives the
world, not the software), so a step is a pure function of these records and of
the configuration sources in ``/run/source``.

* :mod:`mission.replay.record`: the recording proxy at the device boundary
  (:class:`~mission.replay.record.RecordingBackend`), installed by
  :func:`mission.runtime.api.run_mission` whenever a log is written.
* :mod:`mission.replay.serve`: :class:`~mission.replay.serve.ReplayBackend`,
  a :class:`hal.interfaces.Backend` serving the logged readings back.
* :mod:`mission.replay.rebuild`: mission, actions, model and options from the log.
* :mod:`mission.replay.compare`: first divergence between two logs.
* :mod:`mission.replay.run`: :func:`~mission.replay.run.replay_log`, the whole job
  behind ``maris log replay``.

The supervisor code is the same in a live run and in a replay: only the backend
(and the operator command queue) differ.
"""
