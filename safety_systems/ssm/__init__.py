"""Seed 000's speed and separation monitoring: distances, directed speeds, S (Eqs. 1,
6-11), the override k (Eq. 12), separation over the robot's capsules."""
