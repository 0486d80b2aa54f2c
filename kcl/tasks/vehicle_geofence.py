"""Vehicle inside a box of the world (inequality, 3 rows: north, east, down, m).

The box is the mission's geofence, ``Targets.geofence = [[north lo, hi], [east lo,
hi], [down lo, hi]]`` (world NED, m), shrunk by ``margin`` on every face, so that
the KCL turns the vehicle back before the supervisor's envelope monitor ends the
run. x = the vehicle's position ``eta[0:3]``. Per axis: activation = decreasing
bell over ``[lo, lo + width]`` plus increasing bell over ``[hi - width, hi]``
(lo/hi: the shrunk bounds); reference ``gain (xbar - x)`` towards ``lo + width``
or ``hi - width``, saturated to ``max_rate`` (m/s); Jacobian: the world velocity
of the vehicle origin, ``[0, wRv, 0]``. Idle without a fence, or with one too
small for twice the margin and the width (each noted).
"""

from __future__ import annotations

from kcl.activation import band_activation
from kcl.tasks.base import GAIN, Param, Task
from kcl.tasks.jit import (
    ENV_GEOFENCE,
    ENV_HAS_GEOFENCE,
    IDLE_GEOFENCE_TOO_SMALL,
    IDLE_NO_GEOFENCE,
    RowInputs,
    TaskRows,
    njit,
    saturate_into,
)


@njit
def geofence_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, margin, width]."""
    p, q, eta, wRv, env = inp.p, inp.q, inp.eta, inp.wRv, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    if env[ENV_HAS_GEOFENCE] == 0.0:
        return IDLE_NO_GEOFENCE
    l = q.shape[0]
    margin, width = p[2], p[3]
    for i in range(3):
        lo = env[ENV_GEOFENCE + 2 * i] + margin
        hi = env[ENV_GEOFENCE + 2 * i + 1] - margin
        if hi - lo <= 2.0 * width:  # no room for the bands: the task cannot be met
            return IDLE_GEOFENCE_TOO_SMALL
        x[i] = eta[i]
        for c in range(3):
            J[i, l + c] = wRv[i, c]
        a[i], xbar = band_activation(eta[i], lo, hi, width)
        err[i] = xbar - eta[i] if a[i] > 0.0 else 0.0
    saturate_into(xdot, err, p[0], p[1])
    return 0


class VehicleGeofence(Task):
    TYPE = "vehicle_geofence"
    KIND = "inequality"
    USES_ARM = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.2, "positive", "largest reference speed per axis, m/s"),
        "margin": Param(0.5, "nonneg", "distance kept from every face of the geofence, m"),
        "width": Param(0.5, "positive", "transition width of the activation, m"),
    }
    ROW_KERNEL = staticmethod(geofence_rows)

    def dim(self) -> int:
        return 3
