"""Vehicle horizontal attitude (inequality ``|roll|, |pitch| <= max_angle``).

x = [roll, pitch] of the vehicle (rad, Z-Y-X). Activation per row: increasing
bell of ``|x|`` over ``[max_angle - width, max_angle]``; reference pushes back to
``+-(max_angle - width)``. Jacobian: the first two rows of the Euler-rate map
applied to the body angular velocity (no arm columns).
"""

from __future__ import annotations

import math

from kcl.activation import increasing_bell
from kcl.tasks.base import GAIN, MAX_RATE, Param, Task
from kcl.tasks.jit import RowInputs, TaskRows, njit, saturate_into


@njit
def horizontal_attitude_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, max_angle, width]."""
    p, q, eta = inp.p, inp.q, inp.eta
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    roll, pitch = eta[3], eta[4]
    # rows 0-1 of kcl.rotations.euler_rate_matrix
    sr, cr, tp = math.sin(roll), math.cos(roll), math.tan(pitch)
    c = q.shape[0] + 3
    J[0, c] = 1.0
    J[0, c + 1] = sr * tp
    J[0, c + 2] = cr * tp
    J[1, c + 1] = cr
    J[1, c + 2] = -sr
    top = p[2]
    lim = top - p[3]
    x[0], x[1] = roll, pitch
    a[0] = increasing_bell(abs(roll), lim, top)
    a[1] = increasing_bell(abs(pitch), lim, top)
    err[0] = math.copysign(lim, roll) - roll if a[0] > 0.0 else 0.0
    err[1] = math.copysign(lim, pitch) - pitch if a[1] > 0.0 else 0.0
    saturate_into(xdot, err, p[0], p[1])
    return 0


class VehicleHorizontalAttitude(Task):
    TYPE = "vehicle_horizontal_attitude"
    KIND = "inequality"
    USES_ARM = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "max_angle": Param(0.1, "positive", "largest roll and pitch, rad"),
        "width": Param(0.05, "positive", "transition width, rad"),
    }
    ROW_KERNEL = staticmethod(horizontal_attitude_rows)

    def dim(self) -> int:
        return 2
