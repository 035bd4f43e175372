"""Power and force limiting (ISO/TS 15066:2016, Annex A): the body regions' limits, the
robot's effective mass from its description, the permissible relative speed at a transient
contact, and the operator's segments mapped to the regions they may present.

Plain functions and data; nothing of the loop, the verifier or the configuration uses them
yet (issue 36, first stage)."""
