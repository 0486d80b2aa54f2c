"""The supervisor runtime: dry runs on the simulator and field runs.

Entry point for other packages: :func:`mission.runtime.api.run_mission`, with
its records in :mod:`.options` (what to run, how, what to call back) and its
result :class:`mission.runtime.result.RunResult`. The parts, one job each:

* :mod:`.lifecycle` - idle/preflight/running/paused/aborting/ends (``transitions``)
* :mod:`.schedule` - multi-rate dividers on the base (arm KCL) step
* :mod:`.safety` - watchdogs, envelope, drive faults, non-finite values (pure checks)
* :mod:`.context` - the concrete MissionContext and event sink for the leaves
* :mod:`.telemetry` - readings and tree state as log messages (pure)
* :mod:`.recorder` - what goes to the run log, topic by topic, written on change where it can
* :mod:`.operator` - keys, signals, scripted commands
* :mod:`.progress` - the live terminal line; :mod:`.report` - the final summary
* :mod:`.trees` - the main tree and the abort path, ticked
* :mod:`.endings` - breaches, the trees' ends and stops turned into the run's end
* :mod:`.requests` - what an operator's request does to the run
* :mod:`.loop` - the multi-rate loop and its wall-clock figures
* :mod:`.supervisor` - one run: the parts built and run in order
* :mod:`.api` - building everything for one run
* :mod:`.inputrecord` - the hook the replay's input record fills (a log's inputs)
"""
