"""Motion capture and tracking: frame faults, the Kalman tracker's rules (gate, hidden
bodies, exits), the protective-stop causes, recordings."""
