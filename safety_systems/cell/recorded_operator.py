"""An operator played from a recording (``sensing.recording``, mapped to the cell by
``sensing.recording_mapping``): the recorded counterpart of ``operator_paths``'
scripted operator, shared by the RecordedMotion system and the diagram builder."""

import dataclasses
import functools
import math

import numpy as np
from scipy.spatial.transform import Rotation

from safety_systems.sensing.recording import recorded_state_one
from safety_systems.sensing.recording_mapping import RecordedBodies


@dataclasses.dataclass(frozen=True, eq=False)
class RecordedOperator:
    """One operator played from a recording: its ``bodies`` (cell frame), played from
    recording time ``start`` at t = 0 at ``time_scale`` recording seconds per second
    (every velocity scaled by it), every body turned by ``yaw_deg`` about the cell's z
    axis (through the robot base) and then moved by ``shift`` (m), present for
    enter_time <= t < leave_time (and while each body's recording tracks it)."""

    bodies: RecordedBodies
    start: float = 0.0
    time_scale: float = 1.0
    shift: tuple = (0.0, 0.0, 0.0)
    enter_time: float = 0.0
    leave_time: float = math.inf
    yaw_deg: float = 0.0

    @functools.cached_property
    def _turn(self) -> np.ndarray:
        """The transpose of the yaw's rotation matrix (rows of points turn by it)."""
        return Rotation.from_euler("z", self.yaw_deg, degrees=True).as_matrix().T

    @property
    def num_bodies(self) -> int:
        return len(self.bodies.names)

    def recording_time(self, t: float | np.ndarray) -> float | np.ndarray:
        """The recording time played at time t."""
        return self.start + self.time_scale * np.asarray(t, dtype=float)

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(positions (n, 3), velocities (n, 3), present (n,)) at time t (m, m/s)."""
        n = self.num_bodies
        p, v, present = np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
        b = self.bodies
        recorded_state_one(b.times, b.points, b.tracked_times, float(self.recording_time(t)),
                           p, v, present)
        if not self.enter_time <= t < self.leave_time:
            present[:] = 0.0
        v *= self.time_scale
        if self.yaw_deg != 0.0:
            p, v = p @ self._turn, v @ self._turn
        return p + np.asarray(self.shift), v, present

    def hidden_intervals(self) -> list[tuple[int, float, float]]:
        """(body index, start, end) intervals of time over which the recording did not
        track a body between its first and last tracked samples (the sensor does not see
        it then): each gap's open interval in recording time, mapped to time."""
        out = []
        for i, body_gaps in enumerate(self.bodies.gaps):
            for a, b in body_gaps:
                t0, t1 = ((x - self.start) / self.time_scale for x in (a, b))
                out.append((i, t0 + 1e-9, t1))
        return out
