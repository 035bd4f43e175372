"""report.json, report.md, robustness.png and the worst counterexample's replay.html."""

import json
import math
from pathlib import Path

import numpy as np

from safety_systems.cell.braking import PLACEHOLDER_WARNING  # noqa: F401 - named here too
from safety_systems.files.output_files import save_figure, write_json, write_text
from verification.search.runner import FIELDS
from verification.verify import Outcome

PROPERTY_TEXT = {
    "contact": "stopped before contact: robustness = smallest true clearance between a "
               "body and the robot ({geometry}) while the robot moves, minus the contact "
               "distance (>= 0 safe)",
    "separation": "separation invariant: robustness = smallest d_true - S_true over the "
                  "ticks where the controller permits motion, every body and every capsule "
                  "of the robot ({geometry}); S_true is Eqs. 9-11 on the true speeds with "
                  "the simulated robot's own stopping data, without Z_d and Z_r (>= 0 safe)",
    "permitted_contact": "permitted contact (ISO/TS 15066 power and force limiting): every "
                         "contact between a body segment and the robot ({geometry}) while "
                         "the robot moves is with a segment whose body regions permit "
                         "transient contact (never the head, face or neck, never one that "
                         "can be pressed against a declared fixed surface), at a relative "
                         "speed (the robot's towards it) at or below its Annex A limit: "
                         "robustness = the least limit - relative speed over those contacts "
                         "(m/s; -inf for a forbidden or clampable segment), or, with no "
                         "contact while moving, stopped before contact's clearance (m) "
                         "(>= 0 safe)",
}
# Under safety.mode: ssm_pfl the separation invariant covers speed and separation
# monitoring's part only.
SSM_PART = (" (safety.mode ssm_pfl: speed and separation monitoring's part only, each "
            "segment at the ticks the command exceeds its power and force limiting cap in "
            "force; at or below it, contact is the permitted contact property's)")
# What robustness +inf means for each property: the scenario tests nothing.
VACUOUS = {"contact": "the robot never moved while a body was present",
           "separation": "the robot was never let move while a body was present",
           "permitted_contact": "the robot never moved while a body was present"}


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


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


def vacuous_share(robustness) -> dict:
    """How many of the scenarios with these robustness values are vacuous (robustness
    +inf: ``VACUOUS``); ``share`` None when there are none."""
    rho = np.array([math.inf if x is None else x for x in robustness], dtype=float)
    k = int(np.count_nonzero(np.isposinf(rho)))
    return {"share": k / rho.size if rho.size else None, "vacuous": k, "of": int(rho.size)}


def vacuous_warnings(report: dict) -> list[str]:
    """The vacuous shares above one half, in words, property by property."""
    words = {"evaluated": "of the evaluated scenarios",
             "drake_replays": "of the scenarios replayed in the Drake diagram"}
    out = []
    for name, p in report["properties"].items():
        v = p["vacuous"]
        out += [f"{name}: more than half {words[key]} ({v[key]['vacuous']} of {v[key]['of']}, "
                f"{100.0 * v[key]['share']:.0f}%) are vacuous: {v['definition']} "
                f"(robustness +inf), so they test nothing, and a {p['verdict']} verdict over "
                "this box says less than it appears to."
                for key in words if v[key]["share"] is not None and v[key]["share"] > 0.5]
    return out


def _m(x: float | None) -> str:
    """A robustness figure for reading (None: +inf)."""
    return "+inf" if x is None or x == math.inf else f"{x:.4f}"


def disagreement_lines(report: dict) -> list[str]:
    """Each disagreement in one line: the property, both figures, the proof's claim, the
    file."""
    return [f"inconclusive: {d['property']}: search robustness {_m(d['robustness'])} m, "
            f"Drake {_m(d['drake_robustness'])} m, proof {d['proof']} "
            f"({'; '.join(d['conflicts'])}): {d['scenario']}"
            for p in report["properties"].values() for d in p["disagreements"]]


def _proof_dict(proof) -> dict:
    return {"proved": proof.proved, "covers_robot_mode": proof.robot_mode,
            "method": proof.method,
            "premises": [{"statement": x.statement, "holds": bool(x.holds), "basis": x.basis}
                         for x in proof.premises],
            "margin_at_worst_corner": proof.margin_at_worst_corner,
            "needed_allowance": proof.needed_allowance, "terms": proof.terms}


def report_dict(o: Outcome, *, config_path: str, space_path: str,
                origin: dict | None = None) -> dict:
    figures = np.array(o.log.figures) if o.log.figures else np.zeros((0, len(FIELDS)))
    properties = {}
    for name, p in o.properties.items():
        rho = figures[:, p.column]
        properties[name] = {
            "verdict": p.verdict,
            "property": PROPERTY_TEXT[name].format(geometry=o.contact_geometry)
            + (SSM_PART if name == "separation" and o.safety_mode == "ssm_pfl" else ""),
            # null when +inf: never moving (let move) while a body was present
            "min_robustness": _finite(float(rho.min())) if rho.size else None,
            "simulations_violating": int(np.sum(rho < 0.0)),
            "simulations_to_first_counterexample": o.log.first_violation(p.column),
            # the evaluations of each kind and the CPU and wall seconds when the search
            # found the first violation and when Drake first confirmed one
            "first_counterexample": p.first_counterexample,
            "counterexamples": p.counterexamples,
            "unconfirmed_counterexamples": p.unconfirmed,
            "disagreements": p.disagreements,
            "drake_replays": p.replays,
            "vacuous": {"definition": VACUOUS[name], "evaluated": vacuous_share(rho),
                        "drake_replays": vacuous_share([r["drake_robustness"]
                                                        for r in p.replays])},
            "proof": _proof_dict(p.proof),
        }
        if name == "separation":
            properties[name]["max_violation_time"] = (float(figures[:, 3].max())
                                                      if len(figures) else 0.0)
    return _clean({
        "verdict": o.verdict,
        "method": o.method,
        "robot_mode": o.robot_mode,
        "safety_mode": o.safety_mode,
        **({"robot": o.robot} if o.robot else {}),
        "properties": properties,
        "config": config_path,
        "config_sha256": o.config_sha256,
        "space": space_path,
        "assumptions": o.assumptions,
        "box": o.proof.box,
        "free_parameters": o.free_parameters,
        "simulations": len(o.log.points),
        # every evaluation of a model of the loop in this run, by kind and in total
        # (simulations: closed-loop, evaluated here, not read from a resumed run's cache;
        # margins and dangers: candidates scored by the proofs' margins and by the reduced
        # model; drake: Drake replays; search_cost: the search's kinds in
        # simulation-equivalents, which the budget bounds; cost: with the replays), and
        # the run's CPU and wall seconds (verification/search/counts.py)
        "evaluations": o.evaluations.get("evaluations"),
        "cpu_seconds": o.evaluations.get("cpu_seconds"),
        "wall_seconds": o.evaluations.get("wall_seconds"),
        "stopped_at_first": o.stopped_at_first,
        "unchecked_properties": o.unchecked,
        "seed": o.seed,
        "budget": o.budget,
        "braking_data": "placeholder" if o.proof.placeholder_braking else "configured",
        # the placeholder's warning for the space's robot (the resolved cell's)
        **({"braking_data_warning": o.braking_warning} if o.braking_warning else {}),
        "provenance": origin,
    })


def plot_robustness(o: Outcome, path: Path) -> None:
    """Writes :func:`robustness_figure` to ``path`` (PNG)."""
    import matplotlib.pyplot as plt

    fig = robustness_figure(o)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def robustness_figure(o: Outcome):
    """Robustness of every simulation over the two free parameters that vary most with
    it (by rank correlation), and in the order the search ran them. Each panel says what
    it leaves out: vacuous simulations (robustness +inf: the robot never moved near a
    body) are counted, not drawn; violations are marked and counted, or "none" said."""
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
        violating = int(np.sum(rho < 0))
        if violating:
            left.scatter(points[rho < 0, a], points[rho < 0, b], marker="x", c="black",
                         s=40, label=f"violation ({violating})")
            left.legend(loc="best")
        fig.colorbar(sc, ax=left, label=f"{name} robustness [m] (>= 0 safe)")
        left.set_xlabel(f"{names[a]} (0 = its least, 1 = its greatest in the space)")
        left.set_ylabel(f"{names[b]} (0 = its least, 1 = its greatest)")
    vacuous = int(np.sum(np.isposinf(rho)))
    left.set_title(f"{name} robustness over the two parameters it varies most with\n"
                   f"{len(rho) - vacuous} simulations drawn"
                   + (f", {vacuous} vacuous (+inf) not drawn" if vacuous else "")
                   + ("" if np.any(rho < 0) else "; no violation"), fontsize="medium")
    for other, p in o.properties.items():
        values = o.log.column(p.column)
        bad = int(np.sum(values < 0))
        right.plot(np.arange(1, len(values) + 1), np.where(np.isfinite(values), values, np.nan),
                   ".", ms=4, label=f"{other} ({bad} violating)" if bad else
                   f"{other} (none violating)")
    right.axhline(0.0, color="red", label="0: below it, a violation")
    right.legend(loc="upper right")
    right.set_xlabel("simulation, in the order the search ran them")
    right.set_ylabel("robustness [m]")
    right.set_title(f"every simulation of the search (verdict: {o.verdict})",
                    fontsize="medium")
    fig.tight_layout()
    return fig


def metres(x) -> str:
    """A robustness (m) as read: four decimals (0.1 mm), +inf / -inf / none as words."""
    if x is None:
        return "none"
    x = float(x)
    return f"{x:+.4f} m" if math.isfinite(x) else ("+inf (vacuous)" if x > 0 else "-inf")


def first_words(first) -> str:
    """When the first counterexample came, in words."""
    if not first:
        return "no counterexample"
    return f"first counterexample at simulation {first}"


def _share(v: dict) -> str:
    return "-" if v["share"] is None else (f"{100.0 * v['share']:.0f}% ({v['vacuous']} of "
                                           f"{v['of']})")


def _property_markdown(name: str, p: dict, robot_mode: str) -> list:
    v = p["vacuous"]
    # the robustness' unit (permitted contact's: m/s at a contact, m without one)
    unit = "m/s, or m" if name == "permitted_contact" else "m"
    lines = [f"## {name}: {p['verdict'].upper()}", "", f"- property: {p['property']}",
             f"- smallest robustness the search found: {metres(p['min_robustness'])} (the "
             "Drake replays' figures, each beside the search's, are below; a violation's "
             "replay stops a quarter second after it shows); simulations "
             f"violating it: {p['simulations_violating']}; "
             + first_words(p['simulations_to_first_counterexample']),
             *first_counterexample_lines(p.get("first_counterexample")),
             f"- vacuous share ({v['definition']}; robustness +inf): "
             f"{_share(v['evaluated'])} of the evaluated scenarios, "
             f"{_share(v['drake_replays'])} of the Drake replays", ""]
    if p["disagreements"]:
        lines += [f"### Disagreements (why {name} is INCONCLUSIVE)", "",
                  "The evidence contradicts itself: one evaluator, or the proof, is wrong. "
                  "Each scenario file reproduces the disagreement: `safety-systems simulate "
                  "FILE --out DIR` runs it in the Drake diagram.", "",
                  f"| proof | search robustness [{unit}] | Drake robustness [{unit}] | what "
                  "disagrees | scenario |", "|---|---|---|---|---|"]
        lines += [f"| {d['proof']} | {_m(d['robustness'])} | {_m(d['drake_robustness'])} | "
                  f"{'; '.join(d['conflicts'])} | `{d['scenario']}` |"
                  for d in p["disagreements"]]
        lines.append("")
    proof = p["proof"]
    lines += ["### Proof", "", f"Proved: **{proof['proved']}** ({proof['method']}; the "
              f"theorem covers the {proof['covers_robot_mode']} robot, this space's is "
              f"{robot_mode})", "",
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
        lines += [f"{i + 1}. robustness {_m(c['drake_robustness'])} m (search "
                  f"{_m(c['robustness'])}), simulation {c['simulation']}; in Drake: "
                  f"stopped before contact {_m(drake['stopped_before_contact'])} m, "
                  f"separation {_m(drake['separation'])} m"
                  + (f" (the run so far: stopped at {c['drake_stopped_at']:.2f} s, a quarter "
                     "second after the violation showed)" if c.get("drake_stopped_at")
                     else "") + "; replay: "
                  f"`safety-systems simulate {c['scenario']} --out DIR --html`",
                  "   " + ", ".join(f"{k}={v:g}" for k, v in c["parameters"].items())]
    lines += ["", "### Drake replays (the search's figure beside the Drake diagram's)", "",
              "The worst violations (or, with none, the worst scenario) and scenarios drawn "
              "at random from the search's, replayed in the Drake diagram.", "",
              f"| why | simulation | search robustness [{unit}] | Drake robustness "
              f"[{unit}] |",
              "|---|---|---|---|"]
    lines += [f"| {r['why']} | {r['simulation']} | {_m(r['robustness'])} | "
              f"{_m(r['drake_robustness'])} |" for r in p["drake_replays"]]
    if not p["drake_replays"]:
        lines.append("| - | - | - | - |")
    if name == "separation":
        lines += ["", f"Longest time the robot was let move with a body inside S_true: "
                  f"{p['max_violation_time']:.3f} s."]
    return lines + [""]


def _when(x: dict) -> str:
    e = x["evaluations"]
    return (f"{e['total']} evaluations ({counts_in_words(e)}), {x['cpu_seconds']:.2f} s CPU, "
            f"{x['wall_seconds']:.2f} s wall")


def counts_in_words(e: dict) -> str:
    """Evaluations by kind and the search's cost (``counts.Tally.evaluations``)."""
    return (f"{_n(e['simulations'], 'simulation')}, {_n(e['margins'], 'margin scoring')}, "
            f"{_n(e['dangers'], 'reduced-model scoring')}, {_n(e['drake'], 'Drake run')}; "
            f"the search {e['search_cost']:g} simulation-equivalents")


def _n(count: int, noun: str) -> str:
    return f"{count} {noun}" + ("" if count == 1 else "s")


def first_counterexample_lines(first: dict | None) -> list[str]:
    """When the first counterexample was found and confirmed, in words."""
    if not first:
        return []
    out = []
    if first.get("found"):
        out.append(f"- first counterexample found (simulation {first['simulation']}) after "
                   f"{_when(first['found'])}")
    if first.get("confirmed"):
        out.append(f"- first counterexample confirmed in the Drake diagram after "
                   f"{_when(first['confirmed'])}")
    return out


def evaluation_lines(report: dict) -> list[str]:
    """Every evaluation of a model of the loop, by kind and in total, in words."""
    e = report.get("evaluations")
    if not e:
        return []
    lines = [f"- evaluations of models of the loop: {e['total']} in all: "
             f"{counts_in_words(e)} (its budget: {report['budget']}; with the Drake runs "
             f"{e['cost']:g}); {report['cpu_seconds']:.2f} s CPU, "
             f"{report['wall_seconds']:.2f} s wall"]
    if report.get("stopped_at_first"):
        lines.append(f"- stopped at the first confirmed counterexample "
                     f"({report['stopped_at_first']}): no cross-check replays"
                     + (f"; not checked: {', '.join(report['unchecked_properties'])}"
                        if report["unchecked_properties"] else ""))
    return lines


def markdown(report: dict) -> str:
    lines = [f"# Verification: {report['verdict'].upper()}", "",
             f"- config: `{report['config']}` (sha256 {report['config_sha256'][:12]}...)",
             f"- space: `{report['space']}`",
             f"- robot mode: {report['robot_mode']} (the search and the Drake replays run "
             "it; the proofs cover the kinematic robot only)",
             f"- method: {report['method']}",
             "- properties: " + ", ".join(f"{name} {p['verdict']}"
                                          for name, p in report["properties"].items()),
             f"- simulations: {report['simulations']} (budget {report['budget']}, seed "
             f"{report['seed']})", *evaluation_lines(report), ""]
    if report.get("robot"):
        r = report["robot"]
        lines.insert(lines.index(f"- method: {report['method']}"),
                     f"- robot: {r['model']} ({len(r['joints'])} joints, {r['urdf']}, "
                     f"SHA-256 {r['urdf_sha256'][:12]}...)")
    if report["braking_data"] == "placeholder":
        lines += [f"**{placeholder_words(report)}**", ""]
    lines += [f"**{w}**\n" for w in vacuous_warnings(report)]
    lines += ["## Assumptions", ""]
    lines += [f"- {a}" for a in report["assumptions"]]
    lines.append("")
    for name, p in report["properties"].items():
        lines += _property_markdown(name, p, report["robot_mode"])
    lines += ["![robustness](robustness.png)", ""]
    return "\n".join(lines)


def placeholder_words(report: dict) -> str:
    """The built-in stopping data's warning for the report's robot, as the verification's
    resolved cell gave it (``braking_data_warning``; the UR5e's where the report has
    none). Only a shipped robot has a placeholder: a robot from another URDF must
    configure its stopping data, so its report never says placeholder."""
    return report.get("braking_data_warning") or PLACEHOLDER_WARNING


def write_report(o: Outcome, out: Path, *, config_path: str, space_path: str,
                 replay: bool = True, origin: dict | None = None) -> dict:
    """report.json (with ``origin`` as its provenance), report.md, robustness.png and
    the worst counterexample's replay.html, each written atomically."""
    report = report_dict(o, config_path=config_path, space_path=space_path, origin=origin)
    write_json(out / "report.json", report)
    write_text(out / "report.md", markdown(report))
    plot_robustness(o, out / "robustness.png")
    if replay and o.counterexamples:  # the first property's worst, else the next's
        from safety_systems.outputs.replay import write_replay
        from safety_systems.config.scenario import load_scenario
        from safety_systems.diagrams.simulation import simulate

        run = simulate(load_scenario(o.counterexamples[0]["scenario"]))
        write_replay(run, out / "replay.html")
    return report
