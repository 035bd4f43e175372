"""Power and force limiting (ISO/TS 15066:2016, Annex A): the body regions' limits, the
robot's effective mass from its description, the permissible relative speed at a transient
contact, the operator's segments mapped to the regions they may present, and what
``safety.mode: ssm_pfl`` makes of them: each segment's speed cap in the override, the
clamping rule and the permitted contact property's figure (speed_caps.py)."""
