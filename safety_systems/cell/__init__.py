"""The cell: the UR5e model and its capsules, joint and Cartesian paths, braking data and
true stopping, scripted operators."""
