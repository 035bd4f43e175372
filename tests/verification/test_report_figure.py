"""robustness.png says what it draws and what it leaves out: vacuous simulations counted,
violations marked and counted, "none" where there is none."""

import types

import numpy as np

from verification.report import robustness_figure


class _Log:
    def __init__(self, points, columns):
        self.points, self._columns = points, columns

    def column(self, j):
        return self._columns[j]


def _outcome(contact, separation):
    rng = np.random.default_rng(0)
    points = rng.uniform(size=(len(contact), 3)).tolist()
    log = _Log(points, [np.array(contact, dtype=float), np.array(separation, dtype=float)])
    properties = {"contact": types.SimpleNamespace(column=0),
                  "separation": types.SimpleNamespace(column=1)}
    return types.SimpleNamespace(properties=properties, log=log, verdict="falsified",
                                 free_parameters=["peak_speed", "latency", "noise_std"])


def test_violations_are_counted_and_vacuous_ones_said_not_drawn():
    contact = [0.5, 0.4, -0.2, np.inf, 0.3, 0.25, np.inf, 0.1]
    separation = [0.2, 0.1, 0.05, np.inf, 0.3, 0.2, np.inf, 0.15]
    left, right = robustness_figure(_outcome(contact, separation)).axes[:2]
    assert "6 simulations drawn, 2 vacuous (+inf) not drawn" in left.get_title()
    assert "no violation" not in left.get_title()
    assert [t.get_text() for t in left.get_legend().get_texts()] == ["violation (1)"]
    labels = [t.get_text() for t in right.get_legend().get_texts()]
    assert labels == ["contact (1 violating)", "separation (none violating)",
                      "0: below it, a violation"]


def test_no_violation_marker_where_there_is_none():
    contact = [0.5, 0.4, 0.2, 0.3, 0.25, 0.1]
    left = robustness_figure(_outcome(contact, contact)).axes[0]
    assert left.get_legend() is None
    assert left.get_title().endswith("6 simulations drawn; no violation")
