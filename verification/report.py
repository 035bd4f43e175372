"""report.json, report.md, robustness.png and the worst counterexample's replay.html."""

import json
import math
from pathlib import Path

import numpy as np

from verification.verify import Outcome

PLACEHOLDER_WARNING = ("The stopping data is the built-in placeholder derived from UR5/CB3 "
                       "figures, not data measured on this cell: enter the measured stopping "
                       "times and distances (controller.braking) before relying on this "
                       "verdict.")


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


PROPERTY_TEXT = {
    "contact": "stopped before contact: robustness = smallest true clearance between a "
               "body and the robot ({geometry}) while the robot moves, minus the contact "
               "distance (>= 0 safe)",
    "separation": "separation invariant: robustness = smallest d_true - S_true over the "
                  "ticks where the controller permits motion, every body and every capsule "
                  "of the robot ({geometry}); S_true is Eqs. 9-11 on the true speeds with "
                  "the simulated robot's own stopping data, without Z_d and Z_r (>= 0 safe)",
}


def _clean(x):
    """JSON-safe: non-finite floats (an infinite robustness: never moving near a body)
    as null, recursively."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    return x


def _proof_dict(proof) -> dict:
    return {"proved": proof.proved, "method": proof.method,
            "premises": [{"statement": x.statement, "holds": bool(x.holds), "basis": x.basis}
                         for x in proof.premises],
            "margin_at_worst_corner": proof.margin_at_worst_corner,
            "needed_allowance": proof.needed_allowance, "terms": proof.terms}


def report_dict(o: Outcome, *, config_path: str, space_path: str) -> dict:
    figures = np.array(o.log.figures) if o.log.figures else np.zeros((0, 4))
    properties = {}
    for name, p in o.properties.items():
        rho = figures[:, p.column]
        properties[name] = {
            "verdict": p.verdict,
            "property": PROPERTY_TEXT[name].format(geometry=o.contact_geometry),
            # null when +inf: never moving (permitted to move) while a body was present
            "min_robustness": _finite(float(rho.min())) if rho.size else None,
            "simulations_violating": int(np.sum(rho < 0.0)),
            "simulations_to_first_counterexample": o.log.first_violation(p.column),
            "counterexamples": p.counterexamples,
            "unconfirmed_counterexamples": p.unconfirmed,
            "proof": _proof_dict(p.proof),
        }
        if name == "separation":
            properties[name]["max_violation_time"] = (float(figures[:, 3].max())
                                                      if len(figures) else 0.0)
    return _clean({
        "verdict": o.verdict,
        "method": o.method,
        "properties": properties,
        "config": config_path,
        "config_sha256": o.config_sha256,
        "space": space_path,
        "assumptions": o.assumptions,
        "box": o.proof.box,
        "free_parameters": o.free_parameters,
        "simulations": len(o.log.points),
        "seed": o.seed,
        "budget": o.budget,
        "braking_data": "placeholder" if o.proof.placeholder_braking else "configured",
    })


def plot_robustness(o: Outcome, path: Path) -> None:
    """Robustness of every simulation over the two free parameters that vary most with
    it (by rank correlation), and in the order the search ran them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name, first = next(iter(o.properties.items()))
    rho = o.log.column(first.column)
    points = np.array(o.log.points)
    finite = np.isfinite(rho)
    shown = np.where(finite, rho, np.nan)
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 5))
    names = o.free_parameters
    if points.ndim == 2 and points.shape[1] >= 2 and finite.sum() > 3:
        ranks = np.argsort(np.argsort(shown[finite]))
        corr = [abs(np.corrcoef(np.argsort(np.argsort(points[finite, j])), ranks)[0, 1])
                if np.ptp(points[finite, j]) > 0 else 0.0 for j in range(points.shape[1])]
        a, b = np.argsort(np.nan_to_num(corr))[::-1][:2]
        sc = left.scatter(points[:, a], points[:, b], c=shown, cmap="RdYlGn", s=18,
                          vmin=min(-0.05, np.nanmin(shown)), vmax=max(0.05, np.nanmax(shown)))
        left.scatter(points[rho < 0, a], points[rho < 0, b], marker="x", c="black", s=40,
                     label="violation")
        fig.colorbar(sc, ax=left, label=f"{name} robustness [m] (>= 0 safe)")
        left.set_xlabel(f"{names[a]} (0 = min, 1 = max)")
        left.set_ylabel(f"{names[b]} (0 = min, 1 = max)")
        left.legend(loc="upper right")
    left.set_title("robustness over the space")
    for other, p in o.properties.items():
        values = o.log.column(p.column)
        right.plot(np.arange(1, len(values) + 1), np.where(np.isfinite(values), values, np.nan),
                   ".", ms=4, label=other)
    right.axhline(0.0, color="red")
    right.legend(loc="upper right")
    right.set_xlabel("simulation")
    right.set_ylabel("robustness [m]")
    right.set_title(f"verdict: {o.verdict}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _property_markdown(name: str, p: dict) -> list:
    lines = [f"## {name}: {p['verdict'].upper()}", "", f"- property: {p['property']}",
             f"- smallest robustness found: {p['min_robustness']}; simulations violating it: "
             f"{p['simulations_violating']}; first counterexample after "
             f"{p['simulations_to_first_counterexample'] or '-'} simulations", ""]
    proof = p["proof"]
    lines += ["### Proof", "", f"Proved: **{proof['proved']}** ({proof['method']})", "",
              "Premises *checked* against this model, the configuration and the space:", ""]
    lines += [f"- [{'x' if x['holds'] else ' '}] {x['statement']}"
              for x in proof["premises"] if x["basis"] == "checked"]
    lines += ["", "Premises *trusted* from the files and the real cell (not checkable here):",
              ""]
    lines += [f"- {x['statement']}" for x in proof["premises"] if x["basis"] == "trusted"]
    if proof["margin_at_worst_corner"] is not None:
        lines += ["", f"Margin at the worst corner: {proof['margin_at_worst_corner']:.4f} m", "",
                  "Terms: `" + json.dumps(proof["terms"]) + "`"]
    if proof.get("needed_allowance"):
        lines += ["", f"**The invariant needs {proof['needed_allowance']:.3f} m more allowance "
                  "in Z_d + Z_r** (the monitor's allowances for the uncertainty of the "
                  "measured positions; the terms above show where the margin goes)."]
    lines += ["", "### Counterexamples (confirmed in the Drake diagram)", ""]
    if not p["counterexamples"]:
        lines.append("None.")
    for i, c in enumerate(p["counterexamples"]):
        drake = c["drake"]
        lines += [f"{i + 1}. robustness {c['drake_robustness']:.4f} m (batch "
                  f"{c['robustness']:.4f}), simulation {c['simulation']}; in Drake: "
                  f"stopped before contact {_fmt(drake['stopped_before_contact'])} m, "
                  f"separation {_fmt(drake['separation'])} m; replay: "
                  f"`safety-systems simulate {c['scenario']} --out DIR --html`",
                  "   " + ", ".join(f"{k}={v:g}" for k, v in c["parameters"].items())]
    if p["unconfirmed_counterexamples"]:
        lines += ["", f"{len(p['unconfirmed_counterexamples'])} batch violations were not "
                  "reproduced in the Drake diagram (see report.json)."]
    return lines + [""]


def _fmt(x) -> str:
    return "inf (never moving near a body)" if x is None else f"{x:.4f}"


def markdown(report: dict) -> str:
    lines = [f"# Verification: {report['verdict'].upper()}", "",
             f"- config: `{report['config']}` (sha256 {report['config_sha256'][:12]}...)",
             f"- space: `{report['space']}`",
             f"- method: {report['method']}",
             "- properties: " + ", ".join(f"{name} {p['verdict']}"
                                          for name, p in report["properties"].items()),
             f"- simulations: {report['simulations']} (budget {report['budget']}, seed "
             f"{report['seed']})", ""]
    if report["braking_data"] == "placeholder":
        lines += [f"**{PLACEHOLDER_WARNING}**", ""]
    lines += ["## Assumptions", ""]
    lines += [f"- {a}" for a in report["assumptions"]]
    lines.append("")
    for name, p in report["properties"].items():
        lines += _property_markdown(name, p)
    lines += ["![robustness](robustness.png)", ""]
    return "\n".join(lines)


def write_report(o: Outcome, out: Path, *, config_path: str, space_path: str,
                 replay: bool = True) -> dict:
    report = report_dict(o, config_path=config_path, space_path=space_path)
    (out / "report.json").write_text(json.dumps(report, indent=2) + "\n")
    (out / "report.md").write_text(markdown(report))
    plot_robustness(o, out / "robustness.png")
    if replay and o.counterexamples:  # the first property's worst, else the next's
        from safety_systems.replay import write_replay
        from safety_systems.scenario import load_scenario
        from safety_systems.simulation import simulate

        run = simulate(load_scenario(o.counterexamples[0]["scenario"]))
        write_replay(run, out / "replay.html")
    return report
