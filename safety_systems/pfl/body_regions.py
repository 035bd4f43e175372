"""ISO/TS 15066:2016 Annex A's body regions as data: the permissible force and pressure of
a quasi-static contact, the multiplier for a transient contact, the effective mass and the
effective spring constant of each of the body model's twelve regions.

Sources (figures are facts; the standard's prose is not reproduced):

- **Force** (N) and **pressure** (N/cm^2) of a quasi-static contact: Table A.2. The table
  gives one force per region but a pressure per *body location* (two to nine locations in
  a region). A region here carries the least pressure of its locations, as a contact's
  place within the region is not known: skull/forehead 110 (temple; middle of forehead
  130), face 110 (masticatory muscle), neck 140 (neck muscle; seventh neck muscle 210),
  back/shoulders 160 (shoulder joint; fifth lumbar vertebra 210), chest 120 (sternum;
  pectoral muscle 170), abdomen 140 (abdominal muscle), pelvis 210 (pelvic bone), upper
  arms/elbows 190 (deltoid muscle; humerus 220), lower arms/wrists 180 (forearm muscle and
  arm nerve; radial bone 190), hands/fingers 190 (back of the non-dominant hand; the
  highest of the nine, the dominant forefinger pad, 300), thighs/knees 220 (kneecap; thigh
  muscle 250), lower legs 210 (calf muscle; middle of shin 220).
- **Transient multiplier**: Table A.2 permits a transient contact at up to twice the
  quasi-static force and pressure, and gives no multiplier for the skull/forehead and the
  face, where Annex A permits no transient contact at all. For the neck one transcription
  (below) says the table's multiplier is missing for the skull/forehead and the face only,
  so the neck's is taken as 2 (not confirmed against the standard's own text). Issue 36
  forbids contact with the neck all the same: ``transient_contact`` is False for the
  skull/forehead, the face and the neck (this project's rule, stricter than the table's for
  the neck).
- **Effective mass** (kg) and **effective spring constant** (N/mm): Table A.3 (one figure
  per region).

Checked against two independent transcriptions of Tables A.2 and A.3 found in public code
and notes (one of them read from a licensed copy of the standard) and against a public PFL
calculator's transient forces and its back/shoulders pressure (twice Table A.2's). They
agree on every figure used here, except that one lists no non-dominant hand: the hand's
least pressure, 190 N/cm^2 (back of the non-dominant hand; 200 for the dominant), is the
other's.
Not used: a stricter front-of-neck figure (35 N, spring constant 10 N/mm) that some
summaries list under Table A.2; neither transcription has such a location (it appears to
come from the earlier German BG/BGIA recommendations), and the neck is forbidden anyway.
ISO 10218-2:2025 carries Annex A's method forward; its tables were not compared.

Units: the tables' (N, N/cm^2, kg, N/mm) in the fields, spelled out in their names where
not SI; :attr:`BodyRegion.pressure` and :attr:`BodyRegion.spring_constant` give SI.
"""

import dataclasses
import math

from safety_systems.files.input_error import InputError

TRANSIENT_MULTIPLIER = 2.0  # Table A.2: transient limits at up to twice the quasi-static


@dataclasses.dataclass(frozen=True, kw_only=True)
class BodyRegion:
    """One body region of ISO/TS 15066 Annex A (see the module docstring for sources).

    Args:
        name: snake_case name (``hands_fingers``).
        force: permissible quasi-static force, newtons (Table A.2).
        pressure_n_per_cm2: permissible quasi-static pressure, the region's least over its
            locations, newtons per square centimetre (Table A.2).
        transient_multiplier: the factor on force and pressure for a transient contact
            (Table A.2), or None where the table gives none.
        effective_mass: the region's effective mass, kilograms (Table A.3).
        spring_n_per_mm: the region's effective spring constant, newtons per millimetre
            (Table A.3).
        transient_contact: whether this project permits a transient contact with the region
            (False for the skull/forehead, the face and the neck).
    """

    name: str
    force: float
    pressure_n_per_cm2: float
    transient_multiplier: float | None
    effective_mass: float
    spring_n_per_mm: float
    transient_contact: bool

    def __post_init__(self) -> None:
        for field in ("force", "pressure_n_per_cm2", "effective_mass", "spring_n_per_mm"):
            value = getattr(self, field)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"BodyRegion {self.name!r}: {field} = {value!r}; need a "
                                 "finite number > 0")
        m = self.transient_multiplier
        if m is not None and not (math.isfinite(m) and m >= 1.0):
            raise ValueError(f"BodyRegion {self.name!r}: transient_multiplier = {m!r}; need "
                             "None or a finite number >= 1")
        if self.transient_contact and m is None:
            raise ValueError(f"BodyRegion {self.name!r}: transient_contact needs a "
                             "transient_multiplier")

    @property
    def pressure(self) -> float:
        """Permissible quasi-static pressure, pascals."""
        return self.pressure_n_per_cm2 * 1e4

    @property
    def spring_constant(self) -> float:
        """Effective spring constant, newtons per metre."""
        return self.spring_n_per_mm * 1e3

    @property
    def transient_force(self) -> float:
        """Permissible force of a transient contact, newtons: 0 where none is permitted."""
        return self.transient_multiplier * self.force if self.transient_contact else 0.0

    @property
    def transient_pressure(self) -> float:
        """Permissible pressure of a transient contact, pascals: 0 where none is
        permitted."""
        return self.transient_multiplier * self.pressure if self.transient_contact else 0.0


def _region(name, force, pressure, multiplier, mass, spring, permitted=True):
    return BodyRegion(name=name, force=force, pressure_n_per_cm2=pressure,
                      transient_multiplier=multiplier, effective_mass=mass,
                      spring_n_per_mm=spring, transient_contact=permitted)


_2 = TRANSIENT_MULTIPLIER
# Table A.2 (force N, least pressure N/cm^2, transient multiplier), Table A.3 (kg, N/mm).
REGIONS = (
    _region("skull_forehead", 130.0, 110.0, None, 4.4, 150.0, permitted=False),
    _region("face", 65.0, 110.0, None, 4.4, 75.0, permitted=False),
    _region("neck", 150.0, 140.0, _2, 1.2, 50.0, permitted=False),  # issue 36: forbidden
    _region("back_shoulders", 210.0, 160.0, _2, 40.0, 35.0),
    _region("chest", 140.0, 120.0, _2, 40.0, 25.0),
    _region("abdomen", 110.0, 140.0, _2, 40.0, 10.0),
    _region("pelvis", 180.0, 210.0, _2, 40.0, 25.0),
    _region("upper_arms_elbows", 150.0, 190.0, _2, 3.0, 30.0),
    _region("lower_arms_wrists", 160.0, 180.0, _2, 2.0, 40.0),
    _region("hands_fingers", 140.0, 190.0, _2, 0.6, 75.0),
    _region("thighs_knees", 220.0, 220.0, _2, 75.0, 50.0),
    _region("lower_legs", 130.0, 210.0, _2, 75.0, 60.0),
)
REGION_NAMES = tuple(r.name for r in REGIONS)
_BY_NAME = {r.name: r for r in REGIONS}


def body_region(name: str) -> BodyRegion:
    """The region named ``name`` (one of :data:`REGION_NAMES`); raises ``InputError``
    naming the allowed names otherwise."""
    if name not in _BY_NAME:
        raise InputError("body region", name, f"one of {', '.join(REGION_NAMES)}")
    return _BY_NAME[name]
