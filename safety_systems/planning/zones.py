"""Safety zones and performance recovery (seed 001, Sections 2.5-2.6, Eq. 6).

Dsouza et al. 2025 classify the closest human-robot distance (Eq. 6b) into green,
yellow and red zones (Eq. 6c) and give each zone a speed; when the operator leaves,
the robot recovers its speed. Eq. 6c as printed makes red "d >= d_yellow", which
would overlap green; we read red as d <= d_yellow (``yellow_distance``), yellow
strictly between the thresholds and green at or beyond ``green_distance``.
"""

import numpy as np

GREEN, YELLOW, RED = 0, 1, 2
ZONE_NAMES = ("green", "yellow", "red")  # by code
# Gesture codes: the latest gesture at a time (0: none yet).
NO_GESTURE, START, STOP, RESUME = 0, 1, 2, 3
GESTURE_CODES = {"start": START, "stop": STOP, "resume": RESUME}


def closest_distance(p_robot: np.ndarray, bodies: np.ndarray, usable: np.ndarray) -> float:
    """Eq. 6b: the smallest distance from the robot point to a usable body, m (inf when
    none)."""
    d = np.linalg.norm(np.asarray(bodies, dtype=float) - np.asarray(p_robot, dtype=float),
                       axis=-1)
    return float(np.min(np.where(usable, d, np.inf), initial=np.inf))


def zone_of(distance: np.ndarray, *, green_distance: float,
            yellow_distance: float) -> np.ndarray:
    """Eq. 6c (as read in the module docstring): 0 green, 1 yellow, 2 red."""
    d = np.asarray(distance, dtype=float)
    return np.where(d >= green_distance, GREEN, np.where(d > yellow_distance, YELLOW, RED))


def zone_speed(zone: np.ndarray, speeds: tuple[float, float, float]) -> np.ndarray:
    """The speed of each zone (green, yellow, red), fraction of nominal."""
    return np.asarray(speeds, dtype=float)[np.asarray(zone, dtype=int)]


def recovery_step(k: float, rate: float, target: float, dt: float, *,
                  max_acceleration: float, max_jerk: float) -> tuple[float, float]:
    """One step of the commanded speed k towards ``target`` (performance recovery).

    Down: at once (the PathFollower's brakes bound the actual slow-down). Up: a
    bounded-jerk profile: the rate of k (path acceleration) moves towards the largest
    value from which, lowering it by max_jerk * dt a step, k still stops by the target
    (r dt / 2 + r^2 / (2 max_jerk) <= target - k), capped at max_acceleration, and
    changes by at most max_jerk * dt per step. Returns (k, rate).
    """
    if target <= k:
        return target, 0.0
    half = 0.5 * max_jerk * dt
    wanted = min(max_acceleration,
                 float(-half + np.sqrt(half * half + 2.0 * max_jerk * (target - k))))
    rate = min(max(rate + np.clip(wanted - rate, -max_jerk * dt, max_jerk * dt), 0.0),
               max_acceleration)
    return min(k + rate * dt, target), rate
