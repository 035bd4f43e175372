"""The seed's planner sweeps (seed 001, Section 3, Tables I-VII) as scene variants.

Each sweep turns a scene into labelled variants, applied to whatever scene is given
(the seed's is ``models/scenes/paper.yaml``); every variant is validated like a file.

- ``obstacles`` (Table I): the first 1, 2, ... N obstacles (O1, O1-2, ...).
- ``radius`` (Table II): every sphere's and cylinder's radius 2, 2.5, 3, 3.5 cm.
- ``radii`` (Table III): the four obstacles' radii in the table's four orders.
- ``height`` (Table IV): the four cylinders' heights in the table's four orders.
- ``k_att`` (Table V): K_att 0.03, 0.04, 0.05 with K_rep 0.1.
- ``k_rep`` (Table VI): K_rep 0.1, 0.2, 0.3 with K_att 0.04.
- ``zeta`` (Table VII): zeta 4, 5, 6 cm (the seed's "safety factor", read as the
  threshold of Eq. 3b in cm).
"""

import dataclasses

from safety_systems.files.input_error import InputError
from safety_systems.planning.task_space import Obstacles, TaskScene, validate_scene

CM = 0.01
TABLE_II_RADII = (2.0, 2.5, 3.0, 3.5)
TABLE_III_RADII = ((2.0, 2.5, 3.0, 3.5), (2.5, 2.0, 3.0, 3.5), (3.0, 3.5, 2.0, 2.5),
                   (3.5, 3.0, 2.5, 2.0))
TABLE_IV_HEIGHTS = ((25.0, 20.0, 18.0, 15.0), (20.0, 25.0, 18.0, 15.0),
                    (18.0, 15.0, 20.0, 25.0), (15.0, 18.0, 25.0, 20.0))
TABLE_V_K_ATT = (0.03, 0.04, 0.05)
TABLE_VI_K_REP = (0.1, 0.2, 0.3)
TABLE_VII_ZETA = (4.0, 5.0, 6.0)
SWEEPS = ("obstacles", "radius", "radii", "height", "k_att", "k_rep", "zeta")


def _first(o: Obstacles, k: int) -> Obstacles:
    spheres = o.spheres[:k]
    boxes = o.boxes[:max(0, k - len(o.spheres))]
    cylinders = o.cylinders[:max(0, k - len(o.spheres) - len(o.boxes))]
    return Obstacles(spheres=spheres, boxes=boxes, cylinders=cylinders)


def _radii(o: Obstacles, radii: list[float]) -> Obstacles:
    """Spheres then cylinders take ``radii`` in order (m); boxes are kept."""
    n = len(o.spheres)
    return dataclasses.replace(
        o, spheres=[dataclasses.replace(s, radius=r) for s, r in zip(o.spheres, radii)],
        cylinders=[dataclasses.replace(c, radius=r) for c, r in zip(o.cylinders, radii[n:])])


def _planner(scene: TaskScene, **changes) -> TaskScene:
    return dataclasses.replace(scene, planner=dataclasses.replace(scene.planner, **changes))


def _cm(values) -> str:
    return ", ".join(f"{v:g}" for v in values) + " cm"


def sweep_scenes(scene: TaskScene, name: str) -> list[tuple[str, TaskScene]]:
    """(label, scene) for each setting of sweep ``name``; raises InputError."""
    o = scene.obstacles
    count = len(o.spheres) + len(o.boxes) + len(o.cylinders)
    round_ones = len(o.spheres) + len(o.cylinders)
    if name == "obstacles":
        if count == 0:
            raise InputError("--sweep", name, "a scene with obstacles")
        variants = [(f"{k} (O1-{k})" if k > 1 else "1 (O1)",
                     dataclasses.replace(scene, obstacles=_first(o, k)))
                    for k in range(1, count + 1)]
    elif name == "radius":
        if round_ones == 0:
            raise InputError("--sweep", name, "a scene with spheres or cylinders")
        variants = [(f"{r:g} cm", dataclasses.replace(
            scene, obstacles=_radii(o, [r * CM] * round_ones))) for r in TABLE_II_RADII]
    elif name == "radii":
        if round_ones != 4:
            raise InputError("--sweep", name, "a scene with 4 spheres or cylinders "
                                f"(Table III); this one has {round_ones}")
        variants = [(_cm(row), dataclasses.replace(
            scene, obstacles=_radii(o, [r * CM for r in row]))) for row in TABLE_III_RADII]
    elif name == "height":
        if len(o.cylinders) != 4:
            raise InputError("--sweep", name, "a scene with 4 cylinders (Table IV); "
                                f"this one has {len(o.cylinders)}")
        variants = [(_cm(row), dataclasses.replace(scene, obstacles=dataclasses.replace(
            o, cylinders=[dataclasses.replace(c, height=h * CM)
                          for c, h in zip(o.cylinders, row)]))) for row in TABLE_IV_HEIGHTS]
    elif name == "k_att":
        variants = [(f"K_att {k:g}", _planner(scene, k_att=k, k_rep=0.1))
                    for k in TABLE_V_K_ATT]
    elif name == "k_rep":
        variants = [(f"K_rep {k:g}", _planner(scene, k_att=0.04, k_rep=k))
                    for k in TABLE_VI_K_REP]
    elif name == "zeta":
        variants = [(f"zeta {z:g} cm", _planner(scene, zeta=z * CM)) for z in TABLE_VII_ZETA]
    else:
        raise InputError("--sweep", name, " | ".join(SWEEPS))
    for label, variant in variants:
        try:
            validate_scene(variant)
        except InputError as e:
            raise InputError(f"--sweep {name} ({label}): {e.field}", e.value,
                                e.allowed) from None
    return variants
