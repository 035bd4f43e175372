"""The safety and efficiency evaluation metric of seed 001 (Tables IX-X).

Dsouza et al. 2025 score a run on seven metrics, combine the safety ones with weights
0.4, 0.3, 0.3 (safe navigation efficiency, obstacle proximity, time to collision) and
the efficiency ones with 0.3, 0.3, 0.1, 0.3 (task completion time, power efficiency,
trajectory smoothness, joint smoothness), and report
Overall = A * Safety + B * Efficiency with A = 0.8, B = 0.2.

Table IX gives the ingredients but not how each becomes a 0-100 score (several of its
formulas are garbled in print). Our reading, every score in [0, 100]:

- Task completion: E = T_ideal / T_total (Table IX) as the path progress made, in
  seconds of nominal time, per second it took (equal to T_ideal / T_total when the task
  finishes); score 100 E.
- Power efficiency: W_i = JE_i JV_i, TW = sum_i |W_i| (joint torque times speed,
  torques by inverse dynamics of the UR5e model); E = mean(TW) / max(TW), score 100 E.
- Trajectory smoothness: S_i = sum_t |a_i(t) - a_i(t - 1)|, the total variation of
  joint i's acceleration (Table IX's S_i before its rescaling); score
  100 * mean_i min(1, S_i,ideal / S_i), against the same path run unhindered.
- Joint smoothness: omega_i = theta_i / t (angle travelled over time), AJS its mean
  over joints; score 100 * min(1, AJS / AJS_ideal).
- Safe navigation efficiency: 100 - (% of time a body is closer than ``unsafe``).
- Obstacle proximity: the mean closest human-robot distance PH while a body is present
  (the workcell has no static obstacles to add, Table IX's sum over O_k is empty);
  score 100 * min(1, mean PH / ``comfortable``).
- Time to collision: CRM = distance / (robot and human speeds of approach) per
  instant (infinite when not closing); score 100 * mean min(1, CRM / ``horizon``).

Our addition, not in seed 001: a contact gate. Table IX has no term for contact, and its
three safety metrics are averages over the run that a brief contact hardly moves (on
seed 004's simulations the run that hits the hand scored 31.3 on safety against 32.9 for
ERGA, which does not). No reading of Table IX fixes that: safe navigation efficiency
counts time inside an "unsafe distance" the seed does not give (we take the red zone,
0.5 m; a smaller distance would count the contact, but only as a fraction of the run),
obstacle proximity and time to collision are means. So a run in which the robot
touches an operator has failed its safety function, and its safety score is 0, below
every run without contact (whose score is positive: time to collision is positive
wherever the tool and the bodies are apart). ``contact_free`` reports the
gate (100 or 0). What counts as contact is the caller's (``compare``: the danger index
of seed 004's ellipsoids reaching 1, or a true separation below the scenario's contact
distance while the robot moves). Table X's scores carry no contact, so its 83.87 % is
unchanged.
"""

import dataclasses

import numpy as np

SAFETY_WEIGHTS = {"safe_navigation_efficiency": 0.4, "obstacle_proximity": 0.3,
                  "time_to_collision": 0.3}
EFFICIENCY_WEIGHTS = {"task_completion": 0.3, "power_efficiency": 0.3,
                      "trajectory_smoothness": 0.1, "joint_smoothness": 0.3}
A, B = 0.8, 0.2


@dataclasses.dataclass(frozen=True)
class Thresholds:
    """Distances (m) and time (s) that turn safety measurements into scores."""

    unsafe: float = 0.5  # seed 001's red zone
    comfortable: float = 1.0  # its green zone
    horizon: float = 2.0


def task_completion(progress: float, elapsed: float) -> float:
    """100 x nominal path seconds achieved per second taken."""
    return 100.0 * min(1.0, progress / elapsed) if elapsed > 0 else 0.0


def power_efficiency(torques: np.ndarray, joint_speeds: np.ndarray) -> float:
    """100 x mean(TW) / max(TW), TW = sum_i |tau_i omega_i| over (T, 6) arrays."""
    tw = np.sum(np.abs(torques * joint_speeds), axis=1)
    return 100.0 * float(tw.mean() / tw.max()) if tw.max() > 0 else 0.0


def acceleration_variation(accelerations: np.ndarray) -> np.ndarray:
    """S_i: total variation of each joint's acceleration over (T, 6)."""
    return np.sum(np.abs(np.diff(accelerations, axis=0)), axis=0)


def trajectory_smoothness(accelerations: np.ndarray, ideal: np.ndarray) -> float:
    s, s_ideal = acceleration_variation(accelerations), acceleration_variation(ideal)
    ratio = np.where(s > 0, np.minimum(1.0, s_ideal / np.where(s > 0, s, 1.0)), 1.0)
    return 100.0 * float(ratio.mean())


def joint_smoothness(positions: np.ndarray, duration: float, ideal_positions: np.ndarray,
                     ideal_duration: float) -> float:
    """100 x min(1, AJS / AJS_ideal), AJS = mean over joints of angle travelled / time."""
    def ajs(q, t):
        return float(np.mean(np.sum(np.abs(np.diff(q, axis=0)), axis=0)) / t)

    ideal = ajs(ideal_positions, ideal_duration)
    return 100.0 * min(1.0, ajs(positions, duration) / ideal) if ideal > 0 else 100.0


def safe_navigation(closest: np.ndarray, unsafe: float) -> float:
    """100 - % of instants with a body closer than ``unsafe`` (absent: inf)."""
    return 100.0 - 100.0 * float(np.mean(closest < unsafe))


def obstacle_proximity(closest: np.ndarray, comfortable: float) -> float:
    present = np.isfinite(closest)
    if not present.any():
        return 100.0
    return 100.0 * min(1.0, float(closest[present].mean()) / comfortable)


def time_to_collision(distance: np.ndarray, closing_speed: np.ndarray, horizon: float) -> float:
    """100 x mean over instants of min(1, CRM / horizon), CRM = d / closing speed."""
    crm = np.where(closing_speed > 0, distance / np.where(closing_speed > 0, closing_speed, 1),
                   np.inf)
    crm = np.where(np.isfinite(distance), crm, np.inf)
    return 100.0 * float(np.mean(np.minimum(1.0, crm / horizon)))


def combine(safety: dict, efficiency: dict, *, contact: bool = False) -> dict:
    """The weighted safety, efficiency and overall scores (Section 5); with ``contact``
    the safety score is 0 (our contact gate, see the module)."""
    s = 0.0 if contact else sum(w * safety[name] for name, w in SAFETY_WEIGHTS.items())
    e = sum(w * efficiency[name] for name, w in EFFICIENCY_WEIGHTS.items())
    return {"safety_score": s, "efficiency_score": e, "overall_score": A * s + B * e}


def evaluate(*, time: np.ndarray, q: np.ndarray, v: np.ndarray, a: np.ndarray,
             torques: np.ndarray, progress: float, elapsed: float, closest: np.ndarray,
             closing_speed: np.ndarray, ideal_q: np.ndarray, ideal_a: np.ndarray,
             ideal_duration: float, contact: bool = False,
             thresholds: Thresholds = Thresholds()) -> dict:
    """Every metric and score of one run, from plain arrays (T rows; see the module);
    ``contact``: whether the robot touched an operator anywhere in the run."""
    efficiency = {
        "task_completion": task_completion(progress, elapsed),
        "power_efficiency": power_efficiency(torques, v),
        "trajectory_smoothness": trajectory_smoothness(a, ideal_a),
        "joint_smoothness": joint_smoothness(q, float(time[-1] - time[0]), ideal_q,
                                             ideal_duration),
    }
    safety = {
        "safe_navigation_efficiency": safe_navigation(closest, thresholds.unsafe),
        "obstacle_proximity": obstacle_proximity(closest, thresholds.comfortable),
        "time_to_collision": time_to_collision(closest, closing_speed, thresholds.horizon),
    }
    return {**efficiency, **safety, "contact_free": 0.0 if contact else 100.0,
            **combine(safety, efficiency, contact=contact)}
