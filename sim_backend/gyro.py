"""Gyro (AHRS angular rate) noise with a realistic spectrum.

Three parts, added to the true body rates [p q r] at each AHRS sample:

* white noise, std ``ahrs.rate_noise_std_rad_s`` per sample (the datasheet's
  rate noise density times the square root of half the output rate);
* an in-run bias: first-order Gauss-Markov process, std ``ahrs.gyro_bias_std_rad_s``,
  correlation time ``ahrs.gyro_bias_time_s`` (the datasheet's bias instability);
* a vibration line: the thrusters shake the frame, the gyro sees a sinusoid at
  ``ahrs.vibration_hz`` whose amplitude is ``ahrs.vibration_rad_s`` times the
  thruster activity (RMS normalized propeller speed, 0..1), each axis with its
  own phase.

The noise stream comes from the AHRS's random stream: same seed, same noise.
"""

from __future__ import annotations

import math

import numpy as np


class GyroNoise:
    """Noise (3,) rad/s for a sample at time ``t`` (s): :meth:`sample`."""

    def __init__(self, params: dict, rng: np.random.Generator):
        self.white = float(params["ahrs.rate_noise_std_rad_s"])
        self.bias_std = float(params["ahrs.gyro_bias_std_rad_s"])
        self.bias_time = float(params["ahrs.gyro_bias_time_s"])
        self.vib_w = 2.0 * math.pi * float(params["ahrs.vibration_hz"])
        self.vib_amp = float(params["ahrs.vibration_rad_s"])
        self.phase = rng.uniform(0.0, 2.0 * math.pi, size=3).tolist()
        self.bias = (self.bias_std * rng.standard_normal(3)).tolist()
        self._t: float | None = None

    def sample(self, t: float, normals6: list[float], level: float) -> tuple[float, float, float]:
        """Noise at time ``t`` given 6 standard normals (3 white, 3 bias increments)
        and the thruster activity ``level`` (0..1)."""
        dt = 0.0 if self._t is None else max(0.0, t - self._t)
        self._t = t
        b = self.bias
        if dt > 0.0 and self.bias_std > 0.0:
            a = math.exp(-dt / self.bias_time)
            s = self.bias_std * math.sqrt(max(0.0, 1.0 - a * a))
            for i in range(3):
                b[i] = a * b[i] + s * normals6[3 + i]
        amp = self.vib_amp * level
        out = []
        for i in range(3):
            v = self.white * normals6[i] + b[i]
            if amp > 0.0:
                v += amp * math.sin(self.vib_w * t + self.phase[i])
            out.append(v)
        return out[0], out[1], out[2]
