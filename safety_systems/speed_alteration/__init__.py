"""Seed 004's speed alteration: ellipsoids and the danger index, ERGA, Hwang's and the
bimodal baselines, Table 1."""
