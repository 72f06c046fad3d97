"""The validation cases' shared material, geometry and analytic references (../shared/NOTES.md),
and the spectral peak finder both our model and the peers are measured with.

One place for them, so viscera.validate and viscera.peers measure the same thing.
"""

from __future__ import annotations

import numpy as np

G = 9.81  # m/s^2
RADIUS = 0.0125  # m, a solid circular section
DENSITY = 1000.0  # kg/m^3
AREA = np.pi * RADIUS**2  # m^2
MU = DENSITY * AREA  # kg/m, mass per length
SECOND_MOMENT = np.pi * RADIUS**4 / 4.0  # m^4

CATENARY_SAG = 1.177335  # m: L = 4 m, ends 3 m apart, a = 1.110084 m
BETA_L = (1.87510, 4.69409)  # clamped-free beam eigenvalues beta_n L
# Elastica, inextensible, dead vertical tip load: vertical tip deflection / L against alpha = P L^2 / EI.
ELASTICA = {1.0: 0.30172, 2.0: 0.49346, 5.0: 0.71379, 10.0: 0.81061}


def peak_frequency(signal: np.ndarray, step: float, low: float, high: float) -> float:
    """Frequency (Hz) of the largest spectral peak of `signal` (sampled every `step` s) in
    [low, high] Hz: Hann window, 16x zero-padded FFT, then golden section on the exact |DTFT|."""
    x = (signal - signal.mean()) * np.hanning(signal.size)
    t = np.arange(signal.size) * step
    padded = 16 * signal.size
    freqs = np.fft.rfftfreq(padded, step)
    spectrum = np.abs(np.fft.rfft(x, padded))
    band = (freqs >= low) & (freqs <= high)
    guess = freqs[band][np.argmax(spectrum[band])]
    bin_hz = 1.0 / (padded * step)
    a, b = guess - bin_hz, guess + bin_hz

    def minus_power(f: float) -> float:
        return -abs(np.dot(x, np.exp(-2j * np.pi * f * t)))

    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    for _ in range(60):
        c, d = b - ratio * (b - a), a + ratio * (b - a)
        if minus_power(c) < minus_power(d):
            b = d
        else:
            a = c
    return 0.5 * (a + b)
