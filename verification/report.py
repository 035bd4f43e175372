"""report.json, report.md, robustness.png and the worst counterexample's replay.html."""

import json
import math
from pathlib import Path

import numpy as np

from safety_systems.braking import PLACEHOLDER_WARNING  # noqa: F401 - named here too
from safety_systems.output_files import save_figure, write_json, write_text
from verification.verify import Outcome


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def report_dict(o: Outcome, *, config_path: str, space_path: str,
                origin: dict | None = None) -> dict:
    rho = o.log.robustness
    figures = np.array(o.log.figures) if o.log.figures else np.zeros((0, 4))
    return {
        "verdict": o.verdict,
        "method": o.method,
        "property": "stopped before contact: robustness = smallest true clearance between a "
                    "body and the robot (" + o.contact_geometry + ") while the robot moves, "
                    "minus the contact distance (>= 0 safe)",
        "config": config_path,
        "config_sha256": o.config_sha256,
        "space": space_path,
        "assumptions": o.assumptions,
        "box": o.proof.box,
        "free_parameters": o.free_parameters,
        # null when +inf: the tool never moved while a body was present
        "min_robustness": _finite(float(rho.min())) if rho.size else None,
        "simulations": len(o.log.points),
        "simulations_to_first_counterexample": o.log.first_violation(),
        "seed": o.seed,
        "budget": o.budget,
        "counterexamples": o.counterexamples,
        "unconfirmed_counterexamples": o.unconfirmed,
        "protective_distance": {
            "simulations_with_intrusion": int(np.sum(figures[:, 2] > 0.0)) if len(figures) else 0,
            "max_time_moving_inside": float(figures[:, 2].max()) if len(figures) else 0.0,
            "deepest_intrusion": float(figures[:, 3].max()) if len(figures) else 0.0,
        },
        "braking_data": "placeholder" if o.proof.placeholder_braking else "configured",
        "proof": {
            "proved": o.proof.proved,
            "method": o.proof.method,
            "premises": [{"statement": x.statement, "holds": bool(x.holds), "basis": x.basis}
                         for x in o.proof.premises],
            "margin_at_worst_corner": o.proof.margin_at_worst_corner,
            "terms": o.proof.terms,
        },
        "provenance": origin,
    }


def plot_robustness(o: Outcome, path: Path) -> None:
    """Robustness of every simulation over the two free parameters that vary most with
    it (by rank correlation), and in the order the search ran them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rho = o.log.robustness
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
        fig.colorbar(sc, ax=left, label="robustness [m] (>= 0 safe)")
        left.set_xlabel(f"{names[a]} (0 = min, 1 = max)")
        left.set_ylabel(f"{names[b]} (0 = min, 1 = max)")
        left.legend(loc="upper right")
    left.set_title("robustness over the space")
    right.plot(np.arange(1, len(rho) + 1), shown, ".", ms=4)
    right.axhline(0.0, color="red")
    right.set_xlabel("simulation")
    right.set_ylabel("robustness [m]")
    right.set_title(f"verdict: {o.verdict}")
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def markdown(report: dict) -> str:
    lines = [f"# Verification: {report['verdict'].upper()}", "",
             f"- config: `{report['config']}` (sha256 {report['config_sha256'][:12]}...)",
             f"- space: `{report['space']}`",
             f"- method: {report['method']}",
             f"- property: {report['property']}",
             f"- simulations: {report['simulations']} (budget {report['budget']}, seed "
             f"{report['seed']}); first counterexample after "
             f"{report['simulations_to_first_counterexample'] or '-'}",
             f"- smallest robustness found: {report['min_robustness']}", ""]
    if report["braking_data"] == "placeholder":
        lines += [f"**{PLACEHOLDER_WARNING}**", ""]
    lines += ["## Assumptions", ""]
    lines += [f"- {a}" for a in report["assumptions"]]
    lines += ["", "## Proof", "", f"Proved: **{report['proof']['proved']}**", "",
              "Premises *checked* against this model, the configuration and the space:", ""]
    lines += [f"- [{'x' if p['holds'] else ' '}] {p['statement']}"
              for p in report["proof"]["premises"] if p["basis"] == "checked"]
    lines += ["", "Premises *trusted* from the files and the real cell (not checkable here):",
              ""]
    lines += [f"- {p['statement']}" for p in report["proof"]["premises"]
              if p["basis"] == "trusted"]
    if report["proof"]["margin_at_worst_corner"] is not None:
        lines += ["", f"Margin M at the worst corner: {report['proof']['margin_at_worst_corner']:.4f} m",
                  "", "Terms: `" + json.dumps(report["proof"]["terms"]) + "`"]
    lines += ["", "## Counterexamples (confirmed in the Drake diagram)", ""]
    if not report["counterexamples"]:
        lines.append("None.")
    for i, c in enumerate(report["counterexamples"]):
        lines += [f"{i + 1}. robustness {c['drake_robustness']:.4f} m (batch "
                  f"{c['robustness']:.4f}), simulation {c['simulation']}; replay: "
                  f"`safety-systems simulate {c['scenario']} --out DIR --html`",
                  "   " + ", ".join(f"{k}={v:g}" for k, v in c["parameters"].items())]
    p = report["protective_distance"]
    lines += ["", "## Protective distance (reported beside)", "",
              f"{p['simulations_with_intrusion']} simulations had the robot moving inside the "
              f"true-speed protective distance; longest {p['max_time_moving_inside']:.3f} s, "
              f"deepest {p['deepest_intrusion']:.3f} m.", "",
              "![robustness](robustness.png)", ""]
    return "\n".join(lines)


def write_report(o: Outcome, out: Path, *, config_path: str, space_path: str,
                 replay: bool = True, origin: dict | None = None) -> dict:
    """report.json (with ``origin`` as its provenance), report.md, robustness.png and
    the worst counterexample's replay.html, each written atomically."""
    report = report_dict(o, config_path=config_path, space_path=space_path, origin=origin)
    write_json(out / "report.json", report)
    write_text(out / "report.md", markdown(report))
    plot_robustness(o, out / "robustness.png")
    if replay and o.counterexamples:
        from safety_systems.replay import write_replay
        from safety_systems.scenario import load_scenario
        from safety_systems.simulation import simulate

        run = simulate(load_scenario(o.counterexamples[0]["scenario"]))
        write_replay(run, out / "replay.html")
    return report
