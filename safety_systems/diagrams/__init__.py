"""The Drake diagram builders and the simulation of one scenario."""
