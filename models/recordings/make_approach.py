"""Writes approach.csv: a synthesized Motive CSV export of one technician's approach.

There is no motion-capture system here, so the recording is made, not captured: three
rigid bodies (right glove, left glove, helmet) follow keyframes in the cell frame,
blended with minimum-jerk segments, with a walking sway (hands swinging in antiphase,
the head bobbing) while walking, 0.3 mm of Gaussian noise per axis (seed 0), and the
left glove untracked from 6.0 s to 6.4 s (empty cells, as Motive leaves them). The
positions are then put in Motive's Y-up capture frame by the inverse of
approach_mapping.yaml's transform and written at 100 Hz in metres with quaternions.

It also writes approach_banded.csv: the same technician (the same three bodies, sample
for sample) wearing the banded set besides (safety_systems/cell/sensor_sets.py): a belt
(id 4) at the pelvis and two elbow bands (left id 5, right id 6) at the elbows, placed on
a skeleton the premises allow (cell/human_body.py's 95th-percentile lengths): the neck
base 0.18 m below the head, each shoulder 0.18 m beside it towards its own glove, the
pelvis 0.55 m below the neck base, each elbow 0.31 m from its shoulder and from its hand
(bent downwards; straight where the hand is farther), with their own noise (seed 1).

    python models/recordings/make_approach.py     # rewrites approach.csv and approach_banded.csv
"""

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from safety_systems.sensing.motive_csv import motive_csv_text
from safety_systems.sensing.recording_mapping import load_mapping, rotation_matrix

HERE = Path(__file__).parent
RATE = 100.0
DURATION = 12.0
NOISE = 0.0003  # m per axis
WALK = (2.0, 5.5)  # s: walking in
BACK = (8.5, 11.5)  # s: walking out
KEYS = {  # body: [(time, [x, y, z] in the cell frame, m)]
    "RightGlove": [(0.0, [3.0, 0.35, 0.15]), (2.0, [3.0, 0.35, 0.15]), (5.5, [1.15, 0.05, 0.15]),
                   (7.3, [0.55, 0.02, 0.28]), (8.5, [0.57, 0.04, 0.27]),
                   (11.5, [2.7, 0.75, 0.15]), (12.0, [2.7, 0.75, 0.15])],
    "LeftGlove": [(0.0, [3.0, 0.85, 0.15]), (2.0, [3.0, 0.85, 0.15]), (5.5, [1.2, 0.55, 0.15]),
                  (8.5, [1.2, 0.55, 0.2]), (11.5, [2.75, 1.25, 0.15]),
                  (12.0, [2.75, 1.25, 0.15])],
    "Helmet": [(0.0, [3.25, 0.6, 0.8]), (2.0, [3.25, 0.6, 0.8]), (5.5, [1.45, 0.3, 0.8]),
               (7.3, [1.3, 0.28, 0.72]), (8.5, [1.3, 0.28, 0.72]), (11.5, [3.0, 1.0, 0.8]),
               (12.0, [3.0, 1.0, 0.8])],
}
IDS = {"RightGlove": 1, "LeftGlove": 2, "Helmet": 3}
LEFT_GAP = (6.0, 6.4)  # s: the left glove is not tracked


def min_jerk(keys: list, t: np.ndarray) -> np.ndarray:
    """Positions (T, 3) through the keyframes, each segment a minimum-jerk blend."""
    times = np.array([k[0] for k in keys])
    points = np.array([k[1] for k in keys], dtype=float)
    j = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    s = np.clip((t - times[j]) / (times[j + 1] - times[j]), 0.0, 1.0)
    blend = 10 * s**3 - 15 * s**4 + 6 * s**5
    return points[j] + blend[:, None] * (points[j + 1] - points[j])


def sway(t: np.ndarray, phase: float, amplitude: float) -> np.ndarray:
    """A 1 Hz gait sway, on only while walking (faded in and out over 0.3 s)."""
    on = np.zeros_like(t)
    for a, b in (WALK, BACK):
        on = np.maximum(on, np.clip(np.minimum(t - a, b - t) / 0.3, 0.0, 1.0))
    return amplitude * on * np.sin(2 * np.pi * t + phase)


def main() -> None:
    t = np.arange(round(DURATION * RATE) + 1) / RATE
    rng = np.random.default_rng(0)
    names = list(KEYS)
    cell = np.stack([min_jerk(KEYS[n], t) for n in names], axis=1)  # (T, 3, 3)
    heading = np.array([-0.95, -0.3, 0.0]) / np.linalg.norm([-0.95, -0.3, 0.0])
    cell[:, 0] += sway(t, 0.0, 0.06)[:, None] * heading
    cell[:, 1] += sway(t, np.pi, 0.06)[:, None] * heading
    cell[:, 2, 2] += np.abs(sway(t, 0.0, 0.02))
    cell += rng.normal(scale=NOISE, size=cell.shape)
    gap = (t >= LEFT_GAP[0]) & (t < LEFT_GAP[1])
    cell[gap, 1] = np.nan
    c = load_mapping(HERE / "approach_mapping.yaml").capture_to_cell
    capture = (cell - np.asarray(c.translation)) @ rotation_matrix(c)  # R^T (p - t)
    yaw = np.arctan2(np.gradient(cell[:, 2, 1]), np.gradient(cell[:, 2, 0]))
    q = Rotation.from_euler("y", np.nan_to_num(yaw)[:, None]).as_quat()  # about capture's up axis
    rotations = np.repeat(q[:, None], 3, axis=1)
    text = motive_csv_text(t, names, [IDS[n] for n in names], capture, rotations,
                           rate_hz=RATE, take="approach (synthesized)")
    (HERE / "approach.csv").write_text(text)
    worn = banded(cell) + np.random.default_rng(1).normal(scale=NOISE, size=(t.size, 3, 3))
    all_cell = np.concatenate([cell, worn], axis=1)
    all_capture = (all_cell - np.asarray(c.translation)) @ rotation_matrix(c)
    text = motive_csv_text(t, names + list(BANDED_IDS), [IDS[n] for n in names]
                           + list(BANDED_IDS.values()), all_capture,
                           np.repeat(q[:, None], 6, axis=1), rate_hz=RATE,
                           take="approach with the banded set (synthesized)")
    (HERE / "approach_banded.csv").write_text(text)


BANDED_IDS = {"Belt": 4, "LeftBand": 5, "RightBand": 6}
ARM = 0.31  # m, shoulder to elbow and elbow to hand (the premises allow 0.40 and 0.41)


def banded(cell: np.ndarray) -> np.ndarray:
    """(T, 3, 3): the belt (pelvis) and the left and right elbow bands of the skeleton the
    module docstring describes, from the gloves and the helmet of ``cell`` (T, 3, 3; the
    left glove's gap filled by its neighbours: the band is worn throughout)."""
    right, left, head = (_filled(cell[:, i]) for i in range(3))
    down = np.array([0.0, 0.0, 1.0])
    neck = head - 0.18 * down
    side = left - right
    side[:, 2] = 0.0
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    out = [neck - 0.55 * down]
    for hand, shoulder in ((left, neck + 0.18 * side), (right, neck - 0.18 * side)):
        reach = hand - shoulder
        d = np.linalg.norm(reach, axis=1, keepdims=True)
        assert np.all(d <= 0.40 + 0.41), "a hand beyond the arm's reach"
        bend = down - (reach @ down)[:, None] * reach / d**2  # down, across the reach
        bend /= np.linalg.norm(bend, axis=1, keepdims=True)
        h = np.sqrt(np.clip(ARM**2 - (d / 2) ** 2, 0.0, None))
        out.append(shoulder + reach / 2 - h * bend)
    return np.stack(out, axis=1)


def _filled(x: np.ndarray) -> np.ndarray:
    """``x`` (T, 3) with its NaN rows filled linearly from the tracked ones."""
    ok = ~np.isnan(x[:, 0])
    i = np.arange(x.shape[0])
    return np.stack([np.interp(i, i[ok], x[ok, k]) for k in range(3)], axis=1)


if __name__ == "__main__":
    main()
