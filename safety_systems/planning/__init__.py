"""Seed 001's planning, zones and metric: task space, potential field, planners, RRT*,
path optimisation and metrics, sweeps, zones, evaluation."""
