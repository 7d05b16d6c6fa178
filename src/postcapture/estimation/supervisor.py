"""The recommended schemes' fault supervision: detect a change, go back to its onset, absorb or isolate it.

Every innovation of the filters (accepted or gated) feeds a :class:`~postcapture.estimation.detect.
ChangeDetector` per sensor; every update's NIS the :class:`~postcapture.estimation.detect.ValidityMonitor`.
On an alarm the supervisor acts on what the sensor can be wrong by:

- the gyro or the accelerometer (a bias the filters carry): the bias's covariance on that axis is
  re-opened by the step the detector estimated (at least the recovery policy's bump for the gyro);
- the star tracker (in the MEKF, a gyro bias step shows as a drifting attitude): the gyro bias on that
  axis is re-opened by the drift rate the detector saw;
- an encoder (no bias to carry): the channel is isolated and its samples are left out from then on;
- a gyro or accelerometer axis that alarms again within ``isolation_window`` of its re-opening: the
  accelerometer is isolated; the gyro, which drives the attitude, is flagged.

The filters then go back to a state saved before the onset, take the action there and re-process the
recorded measurements up to the present: the estimates the fault had already corrupted are recomputed
as if the filters had known of the change from its onset. The histories keep what the filters said in
real time; every detection is an event with its onset, alarm time, sensor, axis, estimated size and action.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from postcapture.core.units import DEG_PER_HOUR
from postcapture.estimation.detect import ChangeDetector, DetectionPolicy, ValidityMonitor

__all__ = ["Detection", "Supervisor"]

_AXES = "xyz"


@dataclass(frozen=True)
class Detection:
    """One handled alarm (times in s, ``size`` in the sensor's unit: rad/s, m/s^2 or rad)."""

    time: float
    onset: float
    sensor: str
    channel: int
    size: float
    action: str

    def describe(self) -> str:
        """One line for logs and tables."""
        where = f"joint {self.channel + 1}" if self.sensor == "encoders" else f"axis {_AXES[self.channel]}"
        return (f"{self.sensor} {where}: change of {self.size:.3g} from {self.onset:.1f} s, detected at "
                f"{self.time:.1f} s, {self.action}")


@dataclass
class Supervisor:
    """Detection and handling of sensor faults for one scheme run (see the module docstring).

    Parameters
    ----------
    policy : DetectionPolicy
    dt : float
        Filter step (s).
    sigmas : dict of str to ndarray
        Each sensor's noise 1-sigma per component (its unit), to size a detected change.
    filters : dict of str to filter
        ``{"attitude": MEKF or None, "plant": AugmentedEKF}``.
    """

    policy: DetectionPolicy
    dt: float
    sigmas: dict
    filters: dict
    detections: list = field(default_factory=list)
    isolated: dict = field(default_factory=dict)  # sensor -> boolean mask of isolated components
    flags: list = field(default_factory=list)  # "gyro inconsistent" and the like, with their times
    bias_floor: dict = field(default_factory=lambda: {"gyro": DEG_PER_HOUR})  # smallest re-opening, by sensor

    def __post_init__(self):
        self.detectors = {name: ChangeDetector(len(sig), self.policy.encoder_drift if name == "encoders"
                                               else self.policy.drift, self.policy.threshold)
                          for name, sig in self.sigmas.items()}
        self.validity = ValidityMonitor(self.policy, self.dt)
        self._snaps: deque = deque(maxlen=max(int(self.policy.lookback / self.dt / 5) + 1, 2))
        self._reopened: dict = {}
        self._mean_square: dict = {}  # sensor -> running mean of z^2 per component (``normalised`` sensors)
        self._pending = None
        for name, sig in self.sigmas.items():
            self.isolated[name] = np.zeros(len(sig), dtype=bool)

    # ------------------------------------------------------------------ what the filters read
    def mask(self, sensor: str, value: np.ndarray) -> np.ndarray:
        """A sample with its isolated components missing (NaN)."""
        iso = self.isolated.get(sensor)
        if iso is None or not any(iso.tolist()):  # (plain Python: numpy's any costs microseconds a call)
            return value
        value = np.array(value, dtype=float)
        value[iso] = np.nan
        return value

    # ------------------------------------------------------------------ snapshots
    def save(self, k: int) -> None:
        """Keep the filters' state after step ``k`` (every fifth step)."""
        if k % 5 == 0:
            self._snaps.append((k, {name: f.snapshot() for name, f in self.filters.items() if f is not None}))

    def _restore_before(self, k_onset: int) -> int:
        """Restore the latest state saved at or before step ``k_onset``; returns its step."""
        for k, snaps in reversed(self._snaps):
            if k <= k_onset:
                for name, snap in snaps.items():
                    self.filters[name].restore(snap)
                while self._snaps and self._snaps[-1][0] > k:
                    self._snaps.pop()
                return k
        k, snaps = self._snaps[0]
        for name, snap in snaps.items():
            self.filters[name].restore(snap)
        return k

    # ------------------------------------------------------------------ detection
    def observe(self, t: float, sensor: str, res, channels) -> list:
        """Feed one update's innovations (``channels``: the components it used); returns the alarms.

        In plain floats (three to seven components, thousands of times a run): ``max(d, 1e-300)`` and
        ``math.sqrt`` are numpy's ``maximum`` and ``sqrt`` to the bit, a NaN included."""
        if res is None:
            return []
        z = [nu / math.sqrt(max(d, 1e-300)) for nu, d in zip(np.asarray(res.innovation, dtype=float).tolist(),
                                                            np.diagonal(res.S).tolist())]
        flag = self.validity.update(sensor, t, res.nis, len(z))
        if sensor in self.policy.normalised:
            z = [x / s for x, s in zip(z, self._spread(sensor, z, channels))]
        if flag is not None:
            self.flags.append((flag.time, f"{sensor} model inconsistent from {flag.since:.1f} s "
                                           f"(windowed NIS {flag.side})"))
        return [(sensor, a) for a in self.detectors[sensor].update(t, z, channels)]

    def _spread(self, sensor: str, z, channels) -> list:
        """The running RMS of a sensor's normalised innovations (exponential, over the normalisation window),
        between the floor and 1, for the components of this update (``x * x`` and ``min(max(.))`` are numpy's
        square and clip to the bit)."""
        p = self.policy
        ms = self._mean_square.setdefault(sensor, [1.0] * len(self.sigmas[sensor]))
        idx = range(len(ms)) if channels is None else [int(i) for i in channels]
        a = min(self.dt / p.normalisation_window, 1.0)
        floor = p.normalisation_floor**2
        out = []
        for i, x in zip(idx, z):
            ms[i] = (1.0 - a) * ms[i] + a * (x * x)
            out.append(math.sqrt(min(max(ms[i], floor), 1.0)))
        return out

    def handle(self, sensor: str, alarm, t_grid) -> int:
        """Act on an alarm (see the module docstring); returns the step to re-process from."""
        p = self.policy
        sig = float(self.sigmas[sensor][alarm.component])
        size = alarm.shift * sig
        key = (sensor, alarm.component)
        repeat = key in self._reopened and alarm.time - self._reopened[key] <= p.isolation_window
        if sensor == "encoders" or (sensor == "accelerometer" and repeat):
            if sensor == "accelerometer":
                self.isolated[sensor][:] = True
            else:
                self.isolated[sensor][alarm.component] = True
            action = "isolated"
        elif sensor == "gyro" and repeat:
            self.flags.append((alarm.time, f"gyro axis {_AXES[alarm.component]} inconsistent after its bias was "
                                           f"re-opened at {self._reopened[key]:.1f} s"))
            action = "flagged"
        else:
            action = "bias re-opened"
        k_onset = max(int(np.searchsorted(t_grid, alarm.onset)) - 1, 0)
        k0 = self._restore_before(k_onset)
        self.validity.rewind(float(t_grid[k0]))
        if action == "bias re-opened":
            self._pending = (k_onset, sensor, alarm, size)  # applied when the re-processing reaches the onset
            self._reopened[key] = alarm.time
        self.detections.append(Detection(alarm.time, alarm.onset, sensor, alarm.component, size, action))
        for det in self.detectors.values():
            det.reset()
        return k0

    def before_step(self, k: int) -> None:
        """Called before re-processing cycle ``k``: a pending bias re-opening happens at its onset."""
        if self._pending is not None and k >= self._pending[0]:
            _, sensor, alarm, size = self._pending
            self._pending = None
            self._reopen(sensor, alarm, size)

    def _reopen(self, sensor: str, alarm, size: float) -> None:
        """Let the bias step at the located onset, by four times the detected size (the filters had absorbed
        part of the step in other states before the alarm) and at least the bias's floor (``bias_floor``)."""
        axis = alarm.component
        if sensor == "star_tracker":  # an attitude drifting from the onset: a gyro bias step of that rate
            size = abs(size) / max(alarm.time - alarm.onset, self.dt)
            sensor = "gyro"
        sigma = max(4.0 * abs(size), self.bias_floor.get(sensor, 0.0))
        for name, f in self.filters.items():
            if f is not None and (name == "plant" or sensor == "gyro"):
                f.reopen_bias(sensor, axis, sigma)
