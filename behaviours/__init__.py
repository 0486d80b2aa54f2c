"""Behaviour-tree leaves and decorators of MARIS missions (py_trees 2.x).

:mod:`mission.compiler` builds them from a checked mission; each gets the
run's :class:`behaviours.context.MissionContext`. Module map:

* :mod:`.context`: what leaves may touch; :class:`~.context.MissionBlackboard`
  (typed keys), :class:`~.context.EventList`.
* leaves: :mod:`.action` (KCL action until a condition), :mod:`.condition`,
  :mod:`.gripper`, :mod:`.wait`, :mod:`.blackboard_set`, :mod:`.log_event`;
* decorators: :mod:`.timeout` (backend clock), :mod:`.guard`, :mod:`.retry`;
* pure helpers: :mod:`.predicates` (condition evaluators), :mod:`.geometry`,
  :mod:`.nav_history` (vehicle pose at a detection's image time), :mod:`.base`.

Rules: never block a tick; a leaf halted while it commands motion calls
``ctx.stop_motion()`` before returning (the halt contract).
"""
