"""tune.json and tune.md: the chosen configuration beside iso.yaml and the seed's, on the
same task scenarios, and what the search did."""

from pathlib import Path

from safety_systems.files.output_files import write_json, write_text

VACUOUS_WORDS = {"contact": "the robot never moved while a body was present",
                 "separation": "the robot was never let move while a body was present",
                 "permitted_contact": "the robot never moved while a body was present"}


def _s(x: float | None) -> str:
    return "unfinished" if x is None else f"{x:.2f}"


def _row(result: dict, configuration: str) -> dict | None:
    """The comparison's row of ``configuration`` (``chosen``, ``iso.yaml``), None if none."""
    return next((r for r in result["table"] if r["configuration"] == configuration), None)


def _share(v: dict) -> str:
    return "-" if v["share"] is None else f"{100.0 * v['share']:.0f}% ({v['vacuous']} of {v['of']})"


def _comparison(result: dict) -> list[str]:
    lines = ["## The configurations on the task scenarios", "",
             "Each task scenario run in the Drake diagram until the robot finishes its "
             "cycles; *lost* is the task time minus that of the same run with no operator "
             "(time lost to stops and slow-downs); *stopped* is the time the controller "
             "held the robot at rest.", "",
             "| configuration | verdict | task | task time [s] | no operator [s] | lost [s] "
             "| stopped [s] |", "|---|---|---|---|---|---|---|"]
    for row in result["table"]:
        for name, t in row["tasks"].items():
            lines.append(f"| {row['configuration']} | {row['verdict']} | {name} | "
                         f"{_s(t['task_time'])} | {_s(t['no_operator'])} | "
                         f"{_s(t['lost_time'])} | {t['stopped_time']:.2f} |")
        lines.append(f"| {row['configuration']} | {row['verdict']} | **total** | "
                     f"**{_s(row['total_task_time'])}** | | **{_s(row['total_lost_time'])}**"
                     " | |")
    lines.append("")
    reduction = result["lost_time_reduction_vs_iso"]
    if reduction is not None:
        iso = _row(result, "iso.yaml")
        lines += [f"Time lost to the operators: {100.0 * reduction:.1f}% less than "
                  "`iso.yaml` (negative: more)"
                  + ("." if iso["verdict"] == "proved" else
                     f"; `iso.yaml` is {iso['verdict']}, not proved, over this space "
                     "(another robot's stopping data or reach can ask for more than its "
                     "terms give)."), ""]
    return lines


def _vacuous(result: dict) -> list[str]:
    lines = ["## Vacuous share of the verification", "",
             "The share of the evaluated scenarios of the space in which the robot never "
             "moved (contact; permitted contact under safety.mode ssm_pfl) or was never let "
             "move (separation) while a body was present: those scenarios test nothing. A "
             "configuration that is safe because it never moves is not productive, and a "
             "proof over a mostly vacuous box says little.",
             "", "| configuration | contact | separation |", "|---|---|---|"]
    warnings = []
    for row in result["table"]:
        v = row["vacuous"]
        lines.append(f"| {row['configuration']} | " + " | ".join(
            _share(v[name]) if name in v else _share(v[other]) if other in v else "-"
            for name, other in (("contact", "permitted_contact"), ("separation", "")))
            + " |")
        for name, share in v.items():
            if share["share"] is not None and share["share"] > 0.5:
                warnings.append(f"**{row['configuration']}, {name}: "
                                f"{100.0 * share['share']:.0f}% of the evaluated scenarios "
                                f"are vacuous ({VACUOUS_WORDS[name]}): the {row['verdict']} "
                                "verdict over this box says less than it appears to.**")
    return lines + [""] + [w + "\n" for w in warnings]


def _search(result: dict) -> list[str]:
    screen = result["screen"]
    lines = ["## The search", "",
             f"Screened {screen['points']} configurations (the base and Sobol points of the "
             "parameters' box): " + ", ".join(f"{k} {v}" for k, v in
                                              sorted(screen["outcomes"].items())) + ".", "",
             "Simulated (in order of a proxy that only orders them: the mean over the "
             "speed levels of the distance beyond which a still operator lets the robot run "
             "at that level, the full-speed distance when S takes the full-speed stop):", "",
             "| candidate | status | total task time [s] | verdict | why | values |",
             "|---|---|---|---|---|---|"]
    for c in result["candidates"]:
        values = ", ".join(f"{k}={_value(v)}" for k, v in c["values"].items())
        lines.append(f"| {c['index']} | {c['status']} | {_s(c['total_task_time'])} | "
                     f"{c['verdict'] or '-'} | {c['reason']} | {values} |")
    lines += ["", "Counterexamples kept (every later candidate is replayed against them "
              "first):", ""]
    lines += [f"- `{k['file']}`: {k['property']}, {k['robustness']:.4f} m in the Drake "
              f"diagram, found for {k['found_for']}" for k in result["counterexamples"]]
    if not result["counterexamples"]:
        lines.append("- none")
    lines += ["", "Work done: " + ", ".join(f"{k.replace('_', ' ')} {v}"
                                            for k, v in result["counts"].items()) + ".", ""]
    return lines


def markdown(result: dict) -> str:
    chosen = result["chosen"]
    head = (f"# Tuning: {chosen['verdict'].upper()} configuration chosen" if chosen
            else f"# Tuning: no configuration was {result['allow']}")
    lines = [head, "", f"- space: `{result['space']}`; task scenarios: "
             + ", ".join(result["tasks"]),
             f"- constraint: verdict {result['allow']}"
             + (" or proved" if result["allow"] == "passed" else "")
             + f" for both properties (verify budget {result['budget']}, seed "
             f"{result['seed']})", "- tunable parameters: " + "; ".join(
                 f"{p['name']} in " + (str(p['choices']) if p['choices']
                                       else f"[{p['min']:g}, {p['max']:g}]")
                 for p in result["parameters"]), ""]
    if chosen:
        lines += [f"Chosen: `{chosen['config']}` (candidate {chosen['index']}), "
                  f"{chosen['verdict']}; its verification: `{chosen['report']}`.", "",
                  "Changed from the base configuration: " + (", ".join(
                      f"{k} = {v}" for k, v in chosen["changed"].items()) or "nothing") + ".",
                  "", "Export it for deployment:", "",
                  f"    safety-systems export {chosen['config']} --report {chosen['report']} "
                  f"--tune {Path(chosen['config']).parent / 'tune.json'}"
                  " --out OUTDIR", ""]
    return "\n".join(lines + _comparison(result) + _held(result) + _levers(result)
                     + _vacuous(result) + _search(result))


def _held(result: dict) -> list[str]:
    """What held the robot on each task under the chosen configuration."""
    chosen = _row(result, "chosen")
    if not chosen or not chosen.get("held"):
        return []
    lines = ["## What holds the robot under the chosen configuration", "",
             "Each task run once more for its duration: the seconds each protective stop "
             "held the robot, and for the separation stops the segment that held it (the "
             "nearest in the monitor's measure: an untracked segment's envelope is bounded "
             "from the tracked points) and the real body's median clearance then. A "
             "clearance well above the protective distance says the envelope, not the "
             "person, held the robot: tracking that segment's points would release it "
             "(what each sensor set buys: the levers of a tune file).", "",
             "| task | held [s] | by cause | separation stops by segment | true clearance "
             "then (median) [m] | the monitor's measure then [m] | untracked points of the "
             "first |", "|---|---|---|---|---|---|---|"]
    for task, held in chosen["held"].items():
        sep = held.get("separation") or {}
        causes = ", ".join(f"{k} {v:.1f} s" for k, v in held["causes"].items()) or "none"
        segments = ", ".join(f"{k} {v:.1f} s" for k, v in sep.get("by_segment", {}).items())
        true, measured = sep.get("true_clearance_median"), sep.get("measured_clearance_median")
        lines.append(f"| {task} | {sum(held['causes'].values()):.1f} | {causes} | "
                     f"{segments or '-'} | {'-' if true is None else f'{true:.2f}'} | "
                     f"{'-' if measured is None else f'{measured:.2f}'} | "
                     f"{', '.join(sep.get('untracked_points') or []) or '-'} |")
    return lines + [""]


def _levers(result: dict) -> list[str]:
    """What each lever of the tune file buys the chosen configuration (none: nothing)."""
    rows = result.get("levers") or []
    if not rows:
        return []
    tasks = list(rows[0]["lost"])
    lines = ["## What sensing buys", "",
             "The chosen configuration under each lever of the tune file: its frame timeout "
             "and T_r as that sensing allows, its stopping data if it brings any (T_s and B "
             "scaled by its full-speed stop), Z_r the least both proofs then allow, proved "
             "on the space with the lever's tracked points and latency bound; the tasks run "
             "with their operators wearing the lever's sensor set "
             "(`verification/tune/levers.py`). Not re-tuned: the other parameters stay the "
             "chosen's. *vs iso.yaml*: less time lost than iso.yaml's on the tasks as "
             "written.", "",
             "| sensor set, rate, latency | cost | proofs | tau [s] | T_r [s] | Z_r [m] | "
             + " | ".join(f"lost {t} [s]" for t in tasks) + " | lost [s] | held [s] | "
             "vs iso.yaml | won [s] | won per cost [s] |",
             "|---|---|---|---|---|---|" + "---|" * len(tasks) + "---|---|---|---|---|"]
    chosen = _row(result, "chosen")
    base = chosen and chosen["total_lost_time"]
    for r in rows:
        cost = r["lever"]["cost"]
        won = None if base is None or r["total_lost"] is None else base - r["total_lost"]
        per = "-" if won is None or not cost or not r["proved"] else f"{won / cost:.2f}"
        lines.append(
            f"| {r['label']} | {'-' if cost is None else f'{cost:g}'} | "
            f"{'proved' if r['proved'] else 'not proved'} | {r['frame_timeout']:.4f} | "
            f"{r['reaction_time']:.4f} | {r['robot_uncertainty']:.4f} | "
            + " | ".join(_s(r["lost"][t]) for t in tasks)
            + f" | **{_s(r['total_lost'])}** | {r['held']:.1f} | "
            + ("-" if r["reduction"] is None else f"{100.0 * r['reduction']:.1f}%")
            + f" | {'-' if won is None else f'{won:.2f}'} | {per} |")
    return lines + ["", "*won*: the time lost under the chosen configuration as it is "
                    "(its own sensing) less the lever's; *won per cost*: that over the "
                    "lever's cost, for a proved lever with a cost.", ""]


def write_tune(result: dict, out: Path) -> None:
    write_json(out / "tune.json", result)
    write_text(out / "tune.md", markdown(result))


def _value(v) -> str:
    """A tuned value as read: 4 significant digits; None (a field's default rule, as
    frame_timeout's: 1.5 sensor periods + latency + processing) as "default"."""
    if v is None:
        return "default"
    return f"{v:.4g}" if isinstance(v, float) else str(v)
