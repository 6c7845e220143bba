"""Random disturbances, drawn in chunks so that memory stays bounded on long runs.

- Force noise: a random vertical line load per element [N/m], an Ornstein-Uhlenbeck process
  with standard deviation ``disturbance.force_noise_N_m`` and correlation time
  ``noise_time_s``, stepped every time step; each strip takes its element's value.
- Measurement noise: Gaussian, standard deviations ``control.height_noise_m``,
  ``velocity_noise_m_s`` and ``volume_noise_m3``, one draw per bag and sample.

Streams: ``numpy.random.default_rng(seed)`` for the force noise and ``seed + 1`` for the
measurements, drawn in time order, so a run is the same whatever its chunking.
"""

from __future__ import annotations

import math

import numpy as np

from flexlift._jit import jit


@jit
def ornstein_uhlenbeck(draws, start, a, b):
    """x_k = a x_(k-1) + b N_k row by row from ``start``, for standard normal ``draws``
    (steps, n); returns the (steps, n) path."""
    out = np.empty_like(draws)
    prev = start.copy()
    for k in range(draws.shape[0]):
        prev = a * prev + b * draws[k]
        out[k] = prev
    return out


class ForceNoise:
    """The force noise of a run: :meth:`rows` gives the strip loads of consecutive steps."""

    def __init__(self, scenario, dt: float, strip_element: np.ndarray, n_elements: int):
        d = scenario.disturbance
        self.on = d.force_noise_N_m > 0
        self.a = math.exp(-dt / d.noise_time_s)
        self.b = d.force_noise_N_m * math.sqrt(1.0 - self.a**2)
        self.rng = np.random.default_rng(d.seed)
        self.state = np.zeros(n_elements)
        self.strip_element = strip_element

    def rows(self, steps: int) -> np.ndarray:
        """(steps, ns) line loads [N/m] of the next ``steps`` steps."""
        draws = self.rng.standard_normal((steps, self.state.size))
        out = ornstein_uhlenbeck(draws, self.state, self.a, self.b)
        self.state = out[-1].copy()
        return np.ascontiguousarray(out[:, self.strip_element])


class MeasurementNoise:
    """The measurement noise of a run: :meth:`rows` gives it for consecutive samples."""

    def __init__(self, scenario, nb: int):
        c = scenario.control
        self.sigma = np.array([c.height_noise_m, c.velocity_noise_m_s, c.volume_noise_m3])
        self.on = bool(np.any(self.sigma > 0))
        self.rng = np.random.default_rng(scenario.disturbance.seed + 1)
        self.nb = nb
        self.first = 0  # sample index of the rows kept
        self.kept = np.zeros((0, 3, nb))

    def rows(self, first: int, last: int) -> np.ndarray:
        """(last - first + 1, 3, nb) noise of samples ``first`` .. ``last`` (consecutive
        calls move forward; a sample drawn once keeps its value)."""
        have = self.first + self.kept.shape[0]
        if last >= have:
            new = self.rng.standard_normal((last - have + 1, 3, self.nb)) * self.sigma[None, :, None]
            self.kept = np.concatenate([self.kept, new])
        out = self.kept[first - self.first:last - self.first + 1]
        self.kept, self.first = self.kept[first - self.first:].copy(), first
        return np.ascontiguousarray(out)
