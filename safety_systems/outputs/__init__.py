"""What runs write and measure: trace, summary, plots, replay, outcome measures,
comparisons, provenance."""
