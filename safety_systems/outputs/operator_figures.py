"""What a run's figures are per operator: its segments' true and monitored distances, the
nearest segment of each, the S the override used, and its bodies; shared by what
``simulate`` writes (``outputs.run_files``) and its replay (``outputs.replay``)."""

import numpy as np

from safety_systems.cell.human_body import SEGMENT_NAMES, Recipe
from safety_systems.config.configuration import truth_recipe
from safety_systems.diagrams.simulation import Run
from safety_systems.outputs.metrics import tool_state, true_separations
from safety_systems.ssm.formulas import held_level, separation_distances


def commanded_speed(run: Run) -> np.ndarray:
    """(T,) the controller's commanded path speed (k for the SSM override)."""
    key = next(k for k in ("override", "speed", "zones")
               if f"{k}.path_speed_commanded" in run.signals)
    return run[f"{key}.path_speed_commanded"][:, 0]


def run_monitor_recipe(run: Run) -> Recipe:
    """The SSM monitor's envelope recipe of the run's operators, as the run's resolved
    cell gives it (the recipe its OperatorEnvelopes took)."""
    return run.cell.scenario_recipe(run.scenario)


def body_measured_distances(run: Run) -> np.ndarray:
    """(T, N) the tool's distance to each tracked estimate (the distance the seed-004
    controllers and the zones see; NaN without a track)."""
    return separation_distances(tool_state(run)[0], run.bodies("tracker.positions_estimated"))


def operator_bodies(run: Run) -> list[tuple[str, list[int]]]:
    """(operator name, its body slots' indices into ``run.body_names``), operator by
    operator (``scenario.body_names``' order)."""
    out, first = [], 0
    for o in run.scenario.operators:
        out.append((o.name, list(range(first, first + len(o.bodies)))))
        first += len(o.bodies)
    if first != len(run.body_names):
        raise ValueError(f"body slots: the scenario's operators have {first}, the run "
                         f"{len(run.body_names)}")
    return out


def operator_segments(operator: np.ndarray, count: int) -> list[np.ndarray]:
    """Per operator (0 .. ``count`` - 1): the columns of its segments, of a recipe whose
    segments belong to ``operator`` (M,) (``human_body.Recipe.operator``)."""
    return [np.flatnonzero(np.asarray(operator) == k) for k in range(count)]


def segment_words(column: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """(T,) the index into ``human_body.SEGMENT_NAMES`` of the segments at ``column``
    (T,) of a recipe named ``names`` ("operator/segment"); NaN where the column is -1."""
    which = np.array([SEGMENT_NAMES.index(n.rsplit("/", 1)[1]) for n in names] + [-1],
                     dtype=float)
    return np.where(column >= 0, which[column], np.nan)


def nearest_segment(d: np.ndarray, columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(least d (T,), its column (T,)) over ``columns`` of ``d`` (T, M), NaN ignored; NaN
    and -1 where every one is NaN."""
    if columns.size == 0:
        return np.full(d.shape[0], np.nan), np.full(d.shape[0], -1)
    part = d[:, columns]
    none = np.all(np.isnan(part), axis=1)
    j = np.argmin(np.where(np.isnan(part), np.inf, part), axis=1)
    least = part[np.arange(d.shape[0]), j]
    return np.where(none, np.nan, least), np.where(none, -1, columns[j])


def override_levels(run: Run) -> np.ndarray:
    """(T,) under ``safety.stopping: by_speed``, the speed level g (of G + 1, S at
    g / G: ``monitor.level_protective_distances``) whose S the override held the
    distances to at each tick (``ssm.formulas.held_level``, of the logged
    ``follower.path_state``'s rate, the override's input, and the k it commanded).
    Where a fault of the sensing chain held the robot (stop reasons after
    ``separation``) k is 0 whatever level the distances allowed: the rate's level then."""
    m = run["monitor.distances"].shape[1]
    levels = run["monitor.level_protective_distances"].shape[1] // max(m, 1) - 1
    rate = run["follower.path_state"][:, 1]
    return np.array([held_level(float(r), float(k), levels)
                     for r, k in zip(rate, commanded_speed(run))], dtype=int)


def monitor_protective_distances(run: Run) -> np.ndarray:
    """(T, M) the monitor's S of every segment as the override used it: its
    ``protective_distances``, or under ``by_speed`` the S at :func:`override_levels`."""
    if "monitor.level_protective_distances" not in run.signals:
        return run["monitor.protective_distances"]
    t, m = run["monitor.distances"].shape
    s = run["monitor.level_protective_distances"].reshape(t, -1, m)
    return s[np.arange(t), override_levels(run)]


def operator_figures(run: Run) -> list[dict]:
    """Per operator (the scenario's order): ``name``, ``bodies`` (its body slots),
    ``d_true`` (T,) its least true clearance over its segments (NaN while absent) and
    ``nearest_true`` that segment (its index into ``SEGMENT_NAMES``, NaN while absent);
    with the SSM monitor ``d_measured`` (the least monitored d over its segments, NaN
    with none monitored), ``nearest_measured`` and ``S`` (the S the override used of that
    segment, :func:`monitor_protective_distances`); else ``d_measured_bodies`` (T, its
    bodies) the tool's distance to each body's estimate."""
    scenario = run.scenario
    bodies = operator_bodies(run)
    truth = truth_recipe(scenario)
    d_true = true_separations(run)
    true_parts = operator_segments(truth.operator, len(bodies))
    ssm = "monitor.distances" in run.signals
    if ssm:
        recipe = run_monitor_recipe(run)
        parts = operator_segments(recipe.operator, len(bodies))
        d = run["monitor.distances"]
        s = monitor_protective_distances(run)
    else:
        measured = body_measured_distances(run)
    out = []
    for k, (name, slots) in enumerate(bodies):
        least, column = nearest_segment(d_true, true_parts[k])
        figures = {"name": name, "bodies": slots, "d_true": least,
                   "nearest_true": segment_words(column, truth.names)}
        if ssm:
            least, column = nearest_segment(d, parts[k])
            figures |= {"d_measured": least,
                        "nearest_measured": segment_words(column, recipe.names),
                        "S": np.where(column >= 0, s[np.arange(len(column)),
                                                     np.maximum(column, 0)], np.nan)}
        else:
            figures["d_measured_bodies"] = measured[:, slots]
        out.append(figures)
    return out
