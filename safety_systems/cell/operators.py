"""How many operators a cell holds, how many tracked bodies each has, and how they are
named: one statement for the scenario files, the mapping of recordings and the
operators' Drake systems."""

import re

MAX_OPERATORS = 5
MAX_BODIES_PER_OPERATOR = 10  # one per body point (cell.human_body.POINTS)
NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")  # operator and body names (they name files,
#                                             Meshcat paths and trace columns)
