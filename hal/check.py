"""What ``maris hal check`` finds: every configured device, its state and why,
never stopping at the first failure.

:func:`check_hal` builds the backend tolerantly (a device that cannot be built
or connected is a row with its reason, the others are still checked), lets the
devices come up for ``wait`` s, optionally resets drive faults (the documented
preflight reset), checks the arm's joints against the model, and returns a
:class:`HalReport`. The rows come from each device's :meth:`health`: its state
and detail, plus **parts** (sub-rows) taken generically from ``Health.info``:

* ``info["parts"]``: a list of dicts with ``name``, ``state``, ``detail`` and
  any diagnostics (the CANopen drives of the arm and gripper);
* any ``info`` value that is a dict with a ``state`` key (e.g. the vehicle's
  ``ardusub``, ``dvl``, ``ahrs`` entries) becomes a part named by its key;
* ``notes`` (a list of strings) anywhere: remarks shown under the device
  (e.g. the optional objects a drive's EDS lacks).

Devices and parts that are configured but were not heard since the start
(health MISSING: :func:`unheard`) are listed with their config entry
(``file:line:column``, :func:`config_entries`): ``maris run`` refuses to start
without them unless the operator allows it (``--allow-missing NAME``).

The wait ends early once every device is usable and none says it is still
``info["starting"]`` (usable, but not yet seen working: the stereo detector
before its first processed pair).

A new device type plugs in by filling its ``Health`` this way; the command
needs no change.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from hal.config import HalConfig, site_of
from hal.factory import DeviceUnavailable, build_backend
from hal.interfaces import Health, HealthState
from hal.joints import joint_mismatch

#: Row states, best first; ``failed``: the device could not be built or connected.
STATES = ("ok", "degraded", "fault", "missing", "failed")


@dataclass
class DeviceRow:
    role: str
    driver: str
    state: str
    detail: str = ""
    parts: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    info: dict = field(default_factory=dict)
    reset: list[str] = field(default_factory=list)  # faults reset by --reset-faults
    #: Devices or parts not heard since the start: ``name (config entry): why``.
    unheard: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.state in ("ok", "degraded")


@dataclass
class HalReport:
    config: str
    rows: list[DeviceRow]

    @property
    def ok(self) -> bool:
        return all(r.ok for r in self.rows)

    def to_dict(self) -> dict:
        return {"config": self.config, "ok": self.ok, "devices": [asdict(r) for r in self.rows]}


def parts_of(info: dict) -> tuple[list[dict], list[str]]:
    """Sub-rows and notes from a ``Health.info`` (see the module docstring)."""
    parts: list[dict] = []
    notes: list[str] = []
    for key, value in info.items():
        if key == "parts" and isinstance(value, list):
            for p in value:
                if isinstance(p, dict):
                    parts.append({k: v for k, v in p.items() if k != "notes"})
                    notes += [n for n in p.get("notes") or [] if n not in notes]
        elif isinstance(value, dict) and "state" in value:
            parts.append({"name": key, **{k: v for k, v in value.items() if k != "notes"}})
            notes += [n for n in value.get("notes") or [] if n not in notes]
        elif key == "notes" and isinstance(value, list):
            notes += [str(n) for n in value if n not in notes]
    return parts, notes


#: The vehicle's optional sensors, by their key in the vehicle's config entry (and part name).
VEHICLE_SENSOR_KEYS = ("dvl", "ahrs", "ping")
#: Roles a run can go on without (the fault table only warns when they are lost); with the
#: vehicle's sensors, the names a run may be started without (``--allow-missing``).
OPTIONAL_ROLES = ("detector", "wrench_sensor")


@dataclass(frozen=True)
class Unheard:
    """A configured device (``name`` = its role) or vehicle part (``name`` = the part,
    e.g. ``dvl``) not heard since the start; ``detail``: its health's why."""

    name: str
    role: str
    detail: str


def unheard(role: str, h: Health) -> list[Unheard]:
    """The vehicle's sensors (by part name) or the device (by role) whose state is
    MISSING in ``h`` (configured, never heard)."""
    if role == "vehicle":
        parts, _ = parts_of(h.info or {})
        return [
            Unheard(str(p.get("name")), role, str(p.get("detail") or ""))
            for p in parts
            if p.get("state") == HealthState.MISSING.value and p.get("name") in VEHICLE_SENSOR_KEYS
        ]
    return [Unheard(role, role, h.detail)] if h.state == HealthState.MISSING else []


def may_be_missing(name: str) -> bool:
    """True for the names a run may be started without (``--allow-missing``)."""
    return name in VEHICLE_SENSOR_KEYS or name in OPTIONAL_ROLES


def config_entries(config: HalConfig) -> dict[str, str]:
    """Name -> ``file:line:column: devices.<path>`` of every configured device (by role)
    and of the vehicle's sensors (``dvl``, ``ahrs``, ``ping``): the names
    ``--allow-missing`` accepts and where each is configured."""
    out: dict[str, str] = {}
    for role, dc in config.devices.items():
        out[role] = f"{dc.mark}: devices.{role}"
        if role == "vehicle":
            for key in VEHICLE_SENSOR_KEYS:
                if dc.params.get(key):
                    out[key] = site_of(dc.params, key)
    return out


def _row(role: str, driver: str, h: Health) -> DeviceRow:
    parts, notes = parts_of(h.info or {})
    rest = {
        k: v
        for k, v in (h.info or {}).items()  # ("starting": its why is the device's detail already)
        if k not in ("parts", "notes", "starting") and not (isinstance(v, dict) and "state" in v)
    }
    return DeviceRow(role, driver, h.state.value, h.detail, parts, notes, rest)


def check_hal(
    config: Any, *, wait: float = 6.0, reset_faults: bool = False, model_joints: list[str] | None = None
) -> HalReport:
    """Connect to every device of ``config`` (a HalConfig) and report; never raises for device problems."""

    failed: dict[str, str] = {}
    drivers = {role: dc.driver for role, dc in config.devices.items()}
    entries = config_entries(config)
    try:
        backend = build_backend(config, failed=failed)
    except DeviceUnavailable as exc:  # the simulator cannot model a role
        return HalReport(config.path, [DeviceRow(role, drivers[role], "failed", str(exc)) for role in config.devices])
    rows: dict[str, DeviceRow] = {}
    try:
        errors = backend.open_each() if hasattr(backend, "open_each") else _open_all(backend)
        devices = backend.devices.by_role()
        deadline = time.monotonic() + max(0.0, wait)
        while True:
            backend.advance(0.05)
            healths = {role: dev.health() for role, dev in devices.items() if role not in errors}
            if (
                all(h.state.usable and not h.info.get("starting") for h in healths.values())
                or time.monotonic() >= deadline
            ):
                break
        resets: dict[str, list[str]] = {}
        if reset_faults:
            for role, dev in devices.items():
                if role not in errors and hasattr(dev, "reset_faults"):
                    resets[role] = dev.reset_faults()
            if any(resets.values()):
                settle = time.monotonic() + 1.0
                while time.monotonic() < settle and not all(
                    d.health().state.usable for r, d in devices.items() if r not in errors
                ):
                    backend.advance(0.05)
                healths = {role: dev.health() for role, dev in devices.items() if role not in errors}
        for role in config.devices:
            if role in errors:
                rows[role] = DeviceRow(role, drivers[role], "failed", errors[role])
                continue
            rows[role] = _row(role, drivers[role], healths[role])
            rows[role].reset = resets.get(role, [])
            rows[role].unheard = [
                f"{u.name} ({entries.get(u.name, entries.get(role, 'devices.' + role))}): {u.detail}"
                for u in unheard(role, healths[role])
                if may_be_missing(u.name)
            ]
        arm = devices.get("arm")
        # an arm driver, or the stand-in of one that could not be built (no joints)
        joint_names: Sequence[str] | None = getattr(arm, "joint_names", None)
        if model_joints is not None and joint_names is not None and "arm" not in errors:
            why = joint_mismatch(list(joint_names), model_joints)
            if why:
                r = rows["arm"]
                r.state = "fault" if r.ok else r.state
                r.detail = "; ".join(x for x in (r.detail, why) if x)
    finally:
        backend.close()
    return HalReport(config.path, [rows[r] for r in config.devices])


def _open_all(backend: Any) -> dict[str, str]:
    try:
        backend.open()
    except Exception as exc:  # noqa: BLE001 - the simulator opens as one
        return {role: str(exc) for role in backend.devices.by_role()}
    return {}


def usable(state: str) -> bool:
    return state in (HealthState.OK.value, HealthState.DEGRADED.value)
