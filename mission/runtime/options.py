"""What :func:`mission.runtime.api.run_mission` takes: what to run
(:class:`RunTarget`), how (:class:`RunOptions`) and what to call back
(:class:`RunHooks`).

Plain records, light to import (the command line builds them before a run
starts; the types they name are imported for the type checker only).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hal.interfaces import Backend
    from mission.runtime.context import Event
    from mission.runtime.loop import ProgressCallback
    from mission.runtime.operator import Commands
    from mission.runtime.requests import Poller
    from mission.runtime.result import SupervisorOptions
    from mission.runtime.supervisor import Supervisor
    from mission.spec import Mission, RoleSet

#: Scenario used when none is named: the fixed, repeatable pool setting meant for
#: dry runs (pipe and start pose fixed; the seed still drives every noise stream).
#: Randomized settings (``pool_clear``, ``pool_turbid``...) are for campaigns.
DEFAULT_SCENARIO = "pool_fixed"

#: Cut-off (rad/s) standing for "no filter" of the measured velocity. The KCL's
#: first-order filter needs a finite cut-off; its step gain is ``1 - exp(-w dt)``,
#: which is exactly 1.0 in double precision for this w and any dt >= 1 us, so every
#: sample passes through (y + (x - y): equal to x up to one rounding).
NO_FILTER_CUTOFF_RAD_S = 1e9


@dataclass(frozen=True)
class RunTarget:
    """What to run: the mission, and the simulated world or the real devices it runs on.

    Simulator (default): ``scenario`` (name or path, default :data:`DEFAULT_SCENARIO`),
    ``seed``, ``overrides`` (dotted scenario keys, e.g. ``{"dvl.noise_std_mps": 0.02}``).
    Field run: ``backend`` (built from ``hal_config``, a :class:`hal.config.HalConfig`,
    whose file is ``hal_config_path``). ``mission`` is a mission file, or an already
    loaded :class:`mission.spec.Mission` (a replay rebuilds it from a log)."""

    mission: str | Path | Mission
    scenario: str | Path | None = None
    seed: int = 0
    overrides: Mapping[str, Any] | None = None
    backend: Backend | None = None
    #: The devices the mission is checked against: a HAL config (anything with ``roles``).
    hal_config: RoleSet | None = None
    hal_config_path: str | Path | None = None


@dataclass(frozen=True)
class RunOptions:
    """How to run it: the log, the KCL's settings, the supervisor's options, the pace."""

    #: The run log (None: no log).
    log_path: str | Path | None = None
    #: With a log, record every input of the supervisor in it for ``maris log replay``
    #: (:mod:`mission.runtime.inputrecord`); False as ``maris sim --no-input-record``.
    record_inputs: bool = True
    #: The arm compensates the measured vehicle velocity (TPIK 2).
    compensation: bool = True
    #: Cut-off of the measured-velocity filter, rad/s.
    filter_cutoff: float = 50.0
    #: Further :class:`kcl.controller.ControllerConfig` fields (e.g. ``{"lam": 0.01}``).
    controller_options: Mapping[str, Any] | None = None
    #: Pace the simulator to the wall clock (real devices are always real time).
    realtime: bool = False
    #: Refuse a mission with lint warnings (ConfigError) instead of logging them.
    strict: bool = False
    supervisor: SupervisorOptions | None = None


@dataclass(frozen=True)
class RunHooks:
    """What to call back, and who talks to the run while it lasts."""

    #: ``on_progress(elapsed_s, state, action, leaf)`` at each tree tick and state change.
    on_progress: ProgressCallback | None = None
    #: Every event, as it happens.
    on_event: Callable[[Event], None] | None = None
    #: Called once with the built :class:`Supervisor`, before it runs (tests inject
    #: faults through ``supervisor.backend``, campaigns wrap the controller).
    on_supervisor: Callable[[Supervisor], None] | None = None
    #: ``[(t_s, "pause"|"resume"|"abort"|"stop_now"), ...]`` on the backend clock.
    operator_script: Iterable[tuple[float, str]] = ()
    #: The operator's command queue (keys, signals, the live server put into it).
    commands: Commands | None = None
    #: Called at each tree step with the backend time (s).
    pollers: list[Poller] = field(default_factory=list)
    #: A :class:`mission.logs.live.LiveServer` that also gets every log message (needs a log);
    #: it feeds the run's ``foxglove`` operator input.
    live: Any = None
    #: Called once with the backend's operator inputs (role -> device, before the input record
    #: wraps them) so that what feeds them (the key reader) can push into them.
    input_feeds: list[Callable[[Mapping[str, Any]], None]] = field(default_factory=list)
