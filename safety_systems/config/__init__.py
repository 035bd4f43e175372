"""Typed YAML of scenarios and configurations, and what a configuration means for the
loop's rules (shared by the builders, the verifier and the proof)."""
