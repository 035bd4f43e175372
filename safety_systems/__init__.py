"""safety-systems: simulate, verify and tune the speed and separation monitoring of a
collaborative UR5e cell (docs/architecture.md shows the rooms)."""

from pathlib import Path as _Path

from safety_systems.compiled_cache import drop_all_stale_builds as _drop_all_stale_builds

# Before any compiled function runs: builds that inline changed code are dropped.
_drop_all_stale_builds(_Path(__file__).resolve().parent.parent, ("safety_systems",))
