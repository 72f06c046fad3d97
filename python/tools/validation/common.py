"""What the validation cases share: the material and section, the analytic constants several
cases use, the spectral peak finder both our model and the peers are measured with, and how a
case builds and relaxes its one-intestine model (the whole stack: plugin, core, MuJoCo's step).

One place for them, so each case (validation/<case>/case.py) and the peers (validation/peers.py)
measure the same thing. Formulas: ../shared/NOTES.md and docs/validation.md.
"""

from __future__ import annotations

import time

import viscera  # first: headless GL backend

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

G = 9.81  # m/s^2
RADIUS = 0.0125  # m, a solid circular section
DENSITY = 1000.0  # kg/m^3
AREA = np.pi * RADIUS**2  # m^2
MU = DENSITY * AREA  # kg/m, mass per length
SECOND_MOMENT = np.pi * RADIUS**4 / 4.0  # m^4

BETA_L = (1.87510, 4.69409)  # clamped-free beam eigenvalues beta_n L (vibration; the peers' beam)
# The weightless beam of the tip-load, elastica and vibration cases: 0.5 m, EI = 1 N m^2, EA from the same E.
TIP_LENGTH, TIP_RIGIDITY = 0.5, 1.0


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


# the intestine compiled last: what a `tolerance` chose is read from it (tolerance_study.py)
LAST_COMPILED: dict = {}


def compile_rod(config: dict, timestep: float, gravity=(0.0, 0.0, -G), worldbody: str = "", after: str = ""):
    """The model, a data and the intestine of one rod; a key whose value is None is left out (the
    plugin's default, or the `tolerance`'s choice). `after`: MJCF after the worldbody (actuators)."""
    config = {key: value for key, value in config.items() if value is not None}
    xml = (f'<mujoco><option timestep="{timestep}" gravity="{gravity[0]} {gravity[1]} {gravity[2]}"/>'
           f'{viscera.extension_xml("rod", **config)}<worldbody>{worldbody}</worldbody>{after}</mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    gut = viscera.intestine(model)
    LAST_COMPILED["intestine"] = gut
    return model, mujoco.MjData(model), gut


def relax(config: dict, duration: float, timestep: float, gravity=(0.0, 0.0, -G), worldbody: str = "",
           setup=None):
    """Compile and step an intestine for `duration` s; return its data, intestine, wall s per sim s.
    `setup(model, data)`, if given, runs before the first step (loads, initial velocities)."""
    model, data, gut = compile_rod(config, timestep, gravity, worldbody)
    if setup:
        setup(model, data)
    steps = int(round(duration / timestep))
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - start
    if gut.divergence_count(data):
        raise RuntimeError(f"diverged: {config}")
    return data, gut, wall / (steps * timestep)


def rk4_substeps(n: int, length: float, rigidity: float, axial: float = 0.0, extra_rate: float = 0.0,
              step: float = 1e-3) -> int:
    """RK4 substeps per `step` (s) under the stability limit of the stiffest mode: curvature
    (EI, N m^2) and axial (EA, N) waves at the sample spacing, and `extra_rate` (rad/s)."""
    spacing = length / (2 * (n - 1))  # sample spacing (m), 2 samples per segment
    bending = 2.0 * np.sqrt(rigidity / (MU * spacing**4))
    stretch = 2.0 * np.sqrt(axial / MU) / spacing
    return int(np.ceil(step * max(bending, stretch, extra_rate) / 1.5))


class quiet_warnings:
    """Silence the plugin's divergence warnings, expected where a run probes a limit."""

    def __enter__(self):
        mujoco.set_mju_user_warning(lambda message: None)

    def __exit__(self, *exc):
        mujoco.set_mju_user_warning(None)
