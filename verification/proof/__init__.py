"""Proving: the two theorems (``theorems``: "stopped before contact" and the
separation invariant), their premises (``premises``), their margins per speed level
checked by z3 (``margins``), and the sound bounds they rest on: the robot's speed
and stops (``robot_bounds``) and the tracker's position error (``tracking_error``)."""
