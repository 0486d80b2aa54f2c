"""Vehicle altitude above the bottom (inequality ``altitude >= min_altitude``).

x = measured altitude (m, from the DVL, ``TaskContext.altitude``); over a flat
bottom its rate is minus the world-down velocity of the vehicle:
``J = -[0_l, e_z^T wRv, 0_3]``. Activation: decreasing bell over
``[min_altitude, min_altitude + width]``. Idle (and noted) without a measurement.
"""

from __future__ import annotations

import numpy as np

from kcl.activation import decreasing_bell
from kcl.tasks.base import GAIN, Param, Task, TaskContext, TaskOutput, saturate


class VehicleAltitude(Task):
    TYPE = "vehicle_altitude"
    KIND = "inequality"
    USES_ARM = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.2, "positive", "largest reference vertical speed, m/s"),
        "min_altitude": Param(1.0, "positive", "minimum altitude, m"),
        "width": Param(0.3, "positive", "transition width, m"),
    }

    def dim(self) -> int:
        return 1

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        if ctx.altitude is None:
            return self.idle("no altitude measurement")
        p = self.params
        x = float(ctx.altitude)
        J = np.zeros((1, self.n))
        np.negative(ctx.kin.wRv[2], out=J[0, self.l : self.l + 3])
        xbar = p["min_altitude"] + p["width"]
        a = decreasing_bell(x, p["min_altitude"], xbar)
        e = xbar - x if a > 0.0 else 0.0
        rate = p["gain"] * e
        rate = min(max(rate, -p["max_rate"]), p["max_rate"])  # saturate() on one value
        return TaskOutput(np.array([x]), J, np.array([a], dtype=float), np.array([rate]), np.array([e]))
