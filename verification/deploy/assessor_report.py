"""report.html: one self-contained page for the safety assessor to read, sign and file.

It holds the cell and the configuration (each parameter with the ISO/TS 15066 or ISO
13855 term it stands for, ``verification.deploy.standard_terms``), the verdict and every
premise in words (checked or trusted), the scenario space, the counterexamples found on
the way with their plots, the robustness figure, the safety checksum and empty sign-off
fields. Self-contained: styles inline, figures as ``data:`` PNGs, no script, and a
Content-Security-Policy that lets the browser fetch nothing
(``tests/verification/deploy/test_report_html.py`` opens it in a headless Chromium and
watches for requests).
"""

import base64
import html
import io
import math
from pathlib import Path

from safety_systems.files.output_files import write_text
from safety_systems.config.params_file import Params
from safety_systems.files.ranges import field_limits, type_hints
from safety_systems.config.params_file import robot_config
from safety_systems.config.resolved_cell import resolve
from safety_systems.config.scenario import ControllerConfig
from safety_systems.outputs.explanation import (
    explanation,
    explanation_heading,
    explanation_tables,
)
from verification.spaces.box import ScenarioSpace
from verification.spaces.space import explained_operators, free_parameters, parameter_ranges
from verification.deploy.standard_terms import term

MAX_PLOTS = 6  # counterexamples simulated for a plot; the rest are listed
CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"
STYLE = """
body { font-family: sans-serif; max-width: 60em; margin: 2em auto; color: #111;
       line-height: 1.4; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #888; margin-top: 2em; }
table { border-collapse: collapse; width: 100%; margin: 0.5em 0; font-size: 0.92em; }
th, td { border: 1px solid #999; padding: 0.25em 0.5em; text-align: left;
         vertical-align: top; }
th { background: #eee; }
.verdict { font-size: 1.4em; font-weight: bold; padding: 0.4em 0.8em; display: inline-block; }
.proved { background: #cfc; } .passed { background: #ffc; }
.falsified, .inconclusive { background: #fcc; }
.warning { background: #fdd; border: 2px solid #c00; padding: 0.5em; font-weight: bold; }
.checksum { font-family: monospace; font-size: 1.1em; }
.sign td { height: 3em; }
img { max-width: 100%; }
code { font-size: 0.95em; }
@media print { h2 { page-break-after: avoid; } .sign { page-break-inside: avoid; } }
"""


def _bodies(bodies: dict) -> str:
    """The certificate's operators in words: the body model's dimensions, the tracking
    allowance, and the points tracked (a recording's, from its mapping)."""
    d = bodies["dimensions"]
    tracked = bodies["tracked"]
    points = ", ".join(f"{k} ({v})" for k, v in tracked.items()) \
        if isinstance(tracked, dict) else ", ".join(tracked)
    return (f"whole bodies as capsules (upper arm {d['upper_arm']:g} m, forearm "
            f"{d['forearm']:g} m, hand radius {d['hand_radius']:g} m, trunk radius "
            f"{d['trunk_radius']:g} m, head radius {d['head_radius']:g} m, trunk lean up to "
            f"{d['trunk_lean_deg']:g} deg), tracked at: {points}; tracking allowance "
            f"{bodies['tracking_allowance']:g} m")


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _m(x) -> str:
    """A robustness for reading (None: +inf, never moving near a body)."""
    return "+inf (never moving near a body)" if x is None or x == math.inf else f"{x:.4f} m"


def _g(values: list[float]) -> str:
    return "[" + ", ".join(f"{x:.4g}" for x in values) + "]"


def png_uri(data: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _table(head: list[str] | None, rows: list[list[str]], cls: str = "") -> str:
    """A table whose cells are already HTML (``head`` None: no header row)."""
    out = [f'<table class="{cls}">' if cls else "<table>"]
    if head is not None:
        out.append("<tr>" + "".join(f"<th>{_e(h)}</th>" for h in head) + "</tr>")
    out += ["<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows]
    return "\n".join(out + ["</table>"])


def _unit(name: str) -> str:
    """The declared unit of a controller configuration field (dotted name)."""
    schema, parts = ControllerConfig, name.split(".")
    for part in parts[:-1]:
        hint = type_hints(schema).get(part)
        if hint is None or not isinstance(hint, type):
            return ""
        schema = hint
    try:
        limits = field_limits(schema, parts[-1])
    except (KeyError, TypeError):
        return ""
    return limits.unit if limits is not None else ""


def exits_words(tracker, occlusion_speed: float) -> str:
    """The cell's exits (``tracker.exits``), or what having none means for a live cell."""
    if tracker.exits:
        return ", ".join(f"[{b.min} .. {b.max}]" for b in tracker.exits)
    if tracker.hidden_bodies != "hazard":
        return "none declared (the expire rule ends a hidden body's track by time instead)"
    walls = ", unless last seen beyond the cell's walls" if tracker.cell is not None else ""
    kept = (f"a ball growing at {occlusion_speed:g} m/s from where they were last "
            f"seen{walls}, so the robot slows and then stands still as that ball reaches it"
            if occlusion_speed > 0.0 else f"where they were last seen{walls}")
    return ("none declared: in the live cell a person who walks out of the cameras' view "
            f"stays a hazard, {kept}, until they are seen again. Declare the ways out of the "
            "cell as exits (tracker.exits) for people to leave by")


def _cell(params: Params, space: ScenarioSpace, certificate: dict) -> str:
    c, r = params.controller, params.robot
    path = r.path
    if path.waypoints_deg:
        shape = (f"{len(path.waypoints_deg)} joint waypoints, a cycle of "
                 f"{sum(path.segment_durations):g} s at nominal speed")
    elif path.line is not None:
        shape = f"a straight tool line at {path.line.speed:g} m/s"
    elif path.log is not None:
        log = (certificate.get("robot") or {}).get("log") or {}
        shape = (f"the robot's own log {path.log.file} (SHA-256 "
                 f"{str(log.get('sha256'))[:12]}...), "
                 + ("repeated" if path.log.repeat else "run once") + " at its own pace")
    else:
        shape = f"a task-space path of {len(path.task_path.points)} points"
    b = certificate["braking_data"]
    robot = certificate.get("robot") or {"model": "ur5e", "joints": [None] * 6}
    name = "UR5e" if robot["model"] == "ur5e" else robot["model"]
    rows = [["robot", _e(f"{name} ({len(robot['joints'])} joints"
                         + (f", {robot['urdf']} SHA-256 {robot['urdf_sha256'][:12]}..."
                            if "urdf_sha256" in robot else "")
                         + "), kinematic model (the proofs cover the kinematic robot: the "
                         "real robot is trusted to follow its braked reference)")],
            ["control rate", f"{r.control_rate_hz:g} Hz"],
            ["path", _e(shape)],
            ["tool (real)", f"payload radius {r.payload_radius:g} m, length {r.tool_length:g} m"],
            ["sensor", f"{c.sensor.rate_hz:g} Hz, latency {c.sensor.latency:g} s, noise "
                       f"{c.sensor.noise_std:g} m per axis"],
            ["exits", _e(exits_words(c.tracker, c.safety.occlusion_speed))],
            ["contact", _e(f"{space.contact_geometry}, contact distance "
                           f"{space.contact_distance:g} m")],
            *_whole_cell(certificate["cell"]),
            ["stopping data", _e(f"{b['origin']}: speed fractions {_g(b['speed_fraction'])}, "
                                 f"times {_g(b['stopping_time'])} s, distances "
                                 f"{_g(b['stopping_distance'])} m")]]
    out = _table(None, rows)
    if b["origin"] == "placeholder":
        source = ("UR5/CB3 figures" if robot["model"] == "ur5e" else
                  f"published figures for the {name} (models/README.md)")
        out = ('<p class="warning">The stopping data is the built-in PLACEHOLDER derived '
               f"from {_e(source)}, not data measured on this cell. Enter the measured "
               "stopping times and distances before relying on this report.</p>\n" + out)
    return out


def _whole_cell(cell: dict) -> list[list[str]]:
    """Rows of the cell table for the certificate's ``cell`` (the whole-cell settings)."""
    m, c = cell["monitor"], cell["contact"]
    speed = {"directed": "the directed speed of the nearest capsule point towards the body "
                         "(ISO/TS 15066, seed 000 Eq. 7)",
             "fastest_point": "the speed of the capsule's fastest point, whatever its "
                              "direction"}.get(m["robot_speed"], m["robot_speed"])
    h, g = cell["hidden_bodies"], cell["frames"]
    return [
        ["robot as the monitor measures it", _e(
            f"{m['robot_geometry']}: {', '.join(m['capsules'])}, radii {_g(m['radii'])} m, "
            f"tool length {m['tool_length']:g} m")],
        ["robot as contact is measured", _e(
            f"{c['geometry']}: radii {_g(c['radii'])} m, tool length {c['tool_length']:g} m")],
        ["robot's speed in S", _e(speed)],
        ["operators", _e(_bodies(cell["bodies"]))],
        ["hidden bodies", _e(
            f"{h['rule']}: " + ("a hidden body stays a hazard, a ball growing at "
                                f"{h['occlusion_speed']:g} m/s, until seen leaving through "
                                f"an exit ({h['exits'] or 'none'} declared)"
                                if h["rule"] == "hazard" else
                                "a hidden body's track ends after a time"))],
        ["frames", _e(("gated: a frame farther from its track than "
                       f"{g['gate_speed']:g} m/s times the time elapsed plus "
                       f"{g['gate_width']:g} m is rejected" if g["gate"] else "not gated")
                      + f"; a stop when no good frame came for {g['timeout']:.3g} s")],
    ]


def _configuration(certificate: dict, params: Params) -> str:
    kind = params.controller.type
    rows = []
    for key, value in certificate["parameters"].items():
        if not key.startswith("controller."):
            continue
        name = key[len("controller."):]
        if kind == "ssm_override" and name.split(".")[0] in ("alteration", "zones"):
            continue
        symbol, source, meaning = term(name)
        rows.append([f"<code>{_e(name)}</code>", _e(value), _e(_unit(name)), _e(symbol),
                     _e(source), _e(meaning)])
    note = ("<p>The settings of the other controllers (<code>alteration</code>, "
            "<code>zones</code>) are in params.yaml but not used by ssm_override.</p>"
            if kind == "ssm_override" else "")
    return _table(["parameter", "value", "unit", "term", "standard", "meaning"], rows) + note


def explained(params: Params, space: ScenarioSpace, folder: Path | None = None) -> dict:
    """``safety-systems explain``'s figures of the deployed configuration on its robot
    (files relative to ``folder``, params.yaml's) with the space's operators
    (``outputs.explanation.explanation``)."""
    points, names, peak, noise = explained_operators(space)
    cell = resolve(params.controller, robot_config(params.robot, space.robot, folder),
                   points=points, names=names)
    return explanation(cell, peak_speed=peak, noise_bound=noise)


def _explained(data: dict | None) -> str:
    """What the configuration makes the robot do: ``explain``'s tables."""
    if data is None:
        return ""
    out = ["<h3>What it makes the robot do</h3>",
           (f"<p>{_e(explanation_heading(data))} (as <code>safety-systems explain "
            "params.yaml --space</code> prints it).</p>")]
    for caption, head, rows in explanation_tables(data):
        out += [f"<p>{_e(caption)}</p>", _table(head, [[_e(x) for x in r] for r in rows])]
    return "\n".join(out)


def _mode(params) -> str:
    """The deployed configuration's ``safety.mode``."""
    return params.controller.safety.mode


def _properties(certificate: dict) -> str:
    out = []
    for name, p in certificate["properties"].items():
        out.append(f"<h3>{_e(name)}: <span class=\"{_e(p['verdict'])}\">"
                   f"{_e(p['verdict'])}</span></h3>")
        out.append(f"<p>Smallest robustness found: {_e(_m(p['min_robustness']))}. Proof: "
                   f"{'proved' if p['proved'] else 'not proved'} ({_e(p['method'])}).")
        if p.get("margin_at_worst_corner") is not None:
            out.append(f" Margin at the worst corner of the box: "
                       f"{p['margin_at_worst_corner']:.4f} m.")
        if p.get("needed_allowance"):
            out.append(f" The invariant needs {p['needed_allowance']:.3f} m more Z_d + Z_r.")
        out.append("</p>")
        out.append(_table(["premise", "basis", "holds"], [
            [_e(x["statement"]), _e(x["basis"]),
             ("yes" if x["holds"] else "<b>NO</b>") if x["basis"] == "checked"
             else "taken from the files"] for x in p["premises"]]))
    return "\n".join(out)


def _space(certificate: dict, space: ScenarioSpace) -> str:
    a = certificate["assumptions"]
    free = set(free_parameters(space))
    rows = [[f"<code>{_e(n)}</code>", f"{r.min:g}", f"{r.max:g}",
             "varied" if n in free else "fixed"] for n, r in parameter_ranges(space).items()]
    return (f"<p>Space <code>{_e(a['space_file'])}</code> (SHA-256 "
            f"<code>{_e(a['space_sha256'])}</code>), robot mode {_e(a['robot_mode'])}.</p>"
            "<p>The verdict holds under these assumptions:</p><ul>"
            + "".join(f"<li>{_e(x)}</li>" for x in a["assumptions"]) + "</ul>"
            + _table(["parameter", "min", "max", ""], rows))


def counterexample_plots(certificate: dict) -> list[bytes | None]:
    """A plot (PNG) of each of the first ``MAX_PLOTS`` counterexamples, replayed in the
    Drake diagram (None where its scenario file is gone)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from safety_systems.files.input_error import InputError
    from safety_systems.outputs.metrics import summarize
    from safety_systems.outputs.run_files import run_figure
    from safety_systems.config.scenario import load_scenario
    from safety_systems.diagrams.simulation import simulate

    out = []
    for c in certificate["counterexamples"][:MAX_PLOTS]:
        try:
            run = simulate(load_scenario(c["scenario"]))
        except InputError:
            out.append(None)
            continue
        fig = run_figure(run, summarize(run))
        data = io.BytesIO()
        fig.savefig(data, format="png", dpi=80)
        plt.close(fig)
        out.append(data.getvalue())
    return out


def _counterexamples(certificate: dict, plots: list[bytes | None]) -> str:
    found = certificate["counterexamples"]
    if not found:
        return "<p>None were found: no scenario of the search violated either property.</p>"
    out = [f"<p>{len(found)} counterexample(s), each confirmed in the Drake diagram; "
           "each scenario file replays with <code>safety-systems simulate FILE --out DIR"
           "</code>.</p>"]
    for i, c in enumerate(found):
        out.append(f"<h3>{i + 1}. {_e(c['property'])}, robustness "
                   f"{_e(_m(c['drake_robustness']))}, found for {_e(c['found_for'])}</h3>")
        out.append(f"<p><code>{_e(c['scenario'])}</code>"
                   + ("; " + _e(", ".join(f"{k}={v:g}" for k, v in c["parameters"].items()))
                      if c["parameters"] else "") + "</p>")
        if i < len(plots) and plots[i] is not None:
            out.append(f'<img alt="counterexample {i + 1}" src="{png_uri(plots[i])}">')
        elif i >= MAX_PLOTS:
            out.append("<p>(no plot: only the first few are replayed for a plot)</p>")
    return "\n".join(out)


def _sign_off() -> str:
    rows = [[_e(role), "", "", "", ""] for role in
            ("Integrator", "Safety assessor", "Operator's representative")]
    return _table(["role", "name", "organisation", "signature", "date"], rows, "sign")


def assessor_html(certificate: dict, params: Params, space: ScenarioSpace,
                  robustness_png: bytes | None, plots: list[bytes | None],
                  explain: dict | None = None) -> str:
    """The page; ``explain``: :func:`explained`'s figures (None: left out)."""
    verdict = certificate["verdict"]
    robustness = (f'<img alt="robustness of every simulation" src="{png_uri(robustness_png)}">'
                  if robustness_png else "<p>(robustness.png was not found beside the "
                                         "report.json)</p>")
    versions = ", ".join(f"{k} {v}" for k, v in certificate["versions"].items()
                         if isinstance(v, str))
    body = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        f'<meta http-equiv="Content-Security-Policy" content="{CSP}">',
        "<title>Safety parameters: assessment report</title>",
        f"<style>{STYLE}</style></head><body>",
        "<h1>Speed and separation monitoring"
        + (" with power and force limiting" if _mode(params) == "ssm_pfl" else "")
        + ": parameters for deployment</h1>",
        f'<p><span class="verdict {_e(verdict)}">{_e(verdict.upper())}</span> '
        f"{_e(certificate['verdict_meaning'])}.</p>",
        f"<p>Safety checksum: <span class=\"checksum\">{_e(certificate['checksum_short'])}"
        f"</span> (SHA-256 <code>{_e(certificate['checksum'])}</code>), exported "
        f"{_e(certificate['exported'])} with {_e(versions)}.</p>",
        "<h2>1. The cell</h2>", _cell(params, space, certificate),
        "<h2>2. The configuration</h2>", _configuration(certificate, params),
        _explained(explain),
        "<h2>3. The verdict and its premises</h2>",
        f"<p>Method: {_e(certificate['method'])}. Each premise is <i>checked</i> (against "
        "the simulated model, the configuration and the space) or <i>trusted</i> (taken "
        "from the files and the real cell: the assessor must confirm these).</p>",
        _properties(certificate),
        f"<p>Evidence: {certificate['simulations']} closed-loop simulations of the search "
        f"and {certificate['evaluations'].get('drake', 0)} runs of the full Drake model; "
        "every evaluation by kind: "
        + _e(", ".join(f"{k} {v:g}" for k, v in certificate["evaluations"].items()))
        + f" ({_e(certificate['counts_meaning'])})</p>",
        "<h2>4. The scenario space</h2>", _space(certificate, space),
        "<h2>5. Counterexamples found on the way</h2>",
        _counterexamples(certificate, plots),
        "<h2>6. Robustness</h2>",
        "<p>Robustness of every simulation (&ge; 0 means safe): over the two parameters of "
        "the space that vary most with it, and in the order the search ran them.</p>",
        robustness,
        "<h2>7. Checksum</h2>",
        f"<p class=\"checksum\">{_e(certificate['checksum'])}</p>",
        f"<p>{_e(certificate['checksum_covers'])}. <code>safety-systems check "
        "params.yaml</code> recomputes it and refuses any edited file.</p>",
        "<h2>8. Sign-off</h2>", _sign_off(),
        "</body></html>"]
    return "\n".join(body) + "\n"


def write_assessor_report(path: Path, certificate: dict, params: Params,
                          space: ScenarioSpace, report: dict, report_dir: Path, *,
                          plots: bool = True) -> None:
    del report
    robustness = report_dir / "robustness.png"
    png = robustness.read_bytes() if robustness.is_file() else None
    write_text(path, assessor_html(certificate, params, space, png,
                                   counterexample_plots(certificate) if plots else [],
                                   explained(params, space, path.parent)))
