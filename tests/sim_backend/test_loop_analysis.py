"""The Fig. 17 loop's frequency response (sim_backend.loop_analysis)."""

from __future__ import annotations

import numpy as np

from sim_backend.coupling import compensation_loop_gain
from sim_backend.loop_analysis import loop_response, loop_table


def test_static_gain_and_high_frequency_asymptote():
    f = np.array([0.05, 30.0])
    unf = loop_response("pool_apr2016", filter_cutoff_rad_s=None, freqs_hz=f)
    fil = loop_response("pool_apr2016", filter_cutoff_rad_s=50.0, freqs_hz=f)
    g = compensation_loop_gain("pool_apr2016")
    tau = 0.01  # pool_clear's arm drives
    for axis in ("roll", "pitch", "yaw"):
        assert unf[axis].g == g[axis] and 0 < g[axis] < 1
        # far above the DCL's bandwidth the hull floats freely: |L| = g |D|
        w = 2 * np.pi * 30.0
        assert abs(abs(unf[axis].L[1]) - g[axis] / np.hypot(1, w * tau)) < 0.05 * g[axis]
        # the KCL's filter scales it by its own gain there
        assert abs(abs(fil[axis].L[1]) / abs(unf[axis].L[1]) - 1 / np.hypot(1, w / 50.0)) < 1e-9
        # at very low frequency the DCL holds the hull: no loop
        assert abs(unf[axis].L[0]) < 0.2 * g[axis]


def test_shipped_loop_cannot_oscillate_and_a_lighter_hull_only_approaches_one():
    rows = loop_table("pool_apr2016")
    assert all(r["peak_unfiltered"] < 1.0 for r in rows)
    # the compensating arm's momentum can at most cancel the locked arm's share of the
    # whole inertia: a 20 kg hull raises g a lot, still not to 1
    light = loop_response(
        "pool_apr2016",
        filter_cutoff_rad_s=None,
        overrides={"vehicle.mass_kg": 20.0, "vehicle.added_mass": [10, 10, 10, 0.5, 0.5, 0.5]},
    )
    heavy = loop_response("pool_apr2016", filter_cutoff_rad_s=None)
    for axis in ("roll", "pitch", "yaw"):
        assert heavy[axis].g < light[axis].g < 1.0
