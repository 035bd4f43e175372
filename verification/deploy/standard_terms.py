"""What each parameter stands for in the standards an assessor reads: ISO/TS 15066:2016
(speed and separation monitoring, its Eq. 1, the protective separation distance
S = S_h + S_r + S_s + C + Z_d + Z_r), ISO 13855:2010 (the human approach speed K and
the intrusion distance C) and ISO 10218 (the robot's stopping data), and where the
project departs from them (seed 000's Eqs. 9-12, and our own additions).

``TERMS`` maps a configuration field (its dotted name, or a prefix of names) to
(symbol, source, meaning in words); :func:`term` finds the entry of a field.
"""

ISO_SSM = "ISO/TS 15066:2016, 5.5.4.2.3, Eq. (1); seed 000 Eqs. 9-11"
TERMS = {
    "type": ("-", "project", "the safety controller: ssm_override is speed and separation "
             "monitoring with seed 000's speed override"),
    "sensor.rate_hz": ("part of T_r", "measured", "the motion-capture rate: a frame every "
                       "1/rate s (its period, latency and processing make up the detection "
                       "part of the reaction time)"),
    "sensor.latency": ("part of T_r", "measured", "delay from a capture to its delivery"),
    "sensor.noise_std": ("part of Z_d", "measured", "the sensor's position noise per axis"),
    "sensor": ("-", "scenario", "scripted sensor conditions (simulation only; empty for a "
               "deployment)"),
    "tracker.measurement_std": ("part of Z_d", "project (seed 000 Eq. 3, R)",
                                "the Kalman filter's measurement noise"),
    "tracker.velocity_process_noise": ("part of Z_d", "project (seed 000 Eq. 4, Q)",
                                       "the Kalman filter's velocity process noise"),
    "tracker.initial_velocity_std": ("part of Z_d", "project", "a new track's velocity "
                                     "uncertainty"),
    "tracker.hidden_bodies": ("-", "project (our addition)", "a body no longer seen stays a "
                              "hazard (hazard) or its track ends after a time (expire)"),
    "tracker.exits": ("-", "cell", "where bodies leave the cell (their tracks end there)"),
    "tracker.cell": ("-", "cell", "the cell's walls"),
    "tracker.gate": ("-", "project (our addition)", "frames farther from a track than a "
                     "body could move are rejected and stop the robot"),
    "tracker.gate_speed": ("K", "ISO 13855:2010 (approach speed, 2000 mm/s)", "the speed "
                           "the outlier gate allows a body"),
    "tracker.gate_width": ("-", "project", "the gate's allowance for noise and estimate "
                           "error"),
    "tracker.processing_time": ("part of T_r", "measured", "the tracker's processing time"),
    "tracker.frame_timeout": ("part of T_r", "project", "a frame older than this stops "
                              "the robot (unset: 1.5 periods + latency + processing)"),
    "tracker.max_coast_time": ("-", "project", "expire rule only: how long a hidden track "
                               "coasts"),
    "tracker.exit_radius": ("-", "project", "expire rule only: distance from the base "
                            "beyond which a hidden track ends"),
    "safety.robot_geometry": ("-", "ISO/TS 15066 (the robot's hazardous parts)",
                              "what the distance is measured to: every link as a capsule, "
                              "or the tool flange as a point (seed 000 Eq. 8)"),
    "safety.payload_radius": ("-", "ISO/TS 15066 (the robot's hazardous parts)",
                              "the tool and payload as a sphere at the flange, m"),
    "safety.tool_length": ("-", "ISO/TS 15066 (the robot's hazardous parts)",
                           "the tool's length along the flange's z axis, m"),
    "safety.link_radii": ("-", "project", "the links' capsule radii (empty: the UR5e "
                          "model's)"),
    "safety.robot_speed": ("v_R (S_R = v_R T_r)", f"{ISO_SSM}; seed 000 Eqs. 5, 7",
                           "the robot's speed in S: the directed speed of the capsule "
                           "point nearest the body towards it (directed, the standard's "
                           "and the seed's) or the speed of the capsule's fastest point, "
                           "whatever its direction (fastest_point: never credits a robot "
                           "moving away)"),
    "safety.human_speed": ("v_H", f"{ISO_SSM}; seed 000 Eq. 10", "how the operator's speed "
                           "enters S: a constant (iso), the estimate (estimated, the seed's) "
                           "or the larger of the two (estimated_with_floor)"),
    "safety.iso_human_speed": ("v_H = K", "ISO 13855:2010, K = 2000 mm/s; ISO/TS 15066 "
                               "Eq. (1)", "the operator's speed in S (and the floor of "
                               "estimated_with_floor)"),
    "safety.iso_reduced_human_speed": ("v_H = K where S > 500 mm", "ISO 13855:2010 (K = "
                                       "1600 mm/s where S > 500 mm)", "the operator's "
                                       "speed where S exceeds 0.5 m (the value configured; "
                                       "the standard allows 1600 mm/s there)"),
    "safety.stopping": ("T_s, S_s in S", f"{ISO_SSM}; seed 000 Eqs. 9-11",
                        "which stop S takes: the full-speed stopping time and distance "
                        "(full_speed), or the stop from the speed the robot runs at "
                        "(by_speed, from the braking data)"),
    "safety.reaction_time": ("T_r", ISO_SSM, "the robot system's reaction time"),
    "safety.stopping_time": ("T_s", ISO_SSM + "; ISO 10218-1 (stopping data)",
                             "the robot's stopping time (unset: the braking table's at full "
                             "speed)"),
    "safety.stopping_distance": ("S_s (B)", ISO_SSM + "; ISO 10218-1 (stopping data)",
                                 "the robot's stopping distance (unset: the table's)"),
    "safety.intrusion_distance": ("C", ISO_SSM + "; ISO 13855:2010 (intrusion distance)",
                                  "how far a body part may reach into the sensing field "
                                  "before it is detected"),
    "safety.human_uncertainty": ("Z_d", ISO_SSM, "the uncertainty of the operator's measured "
                                 "position"),
    "safety.robot_uncertainty": ("Z_r", ISO_SSM, "the uncertainty of the robot's position"),
    "safety.human_uncertainty_sigmas": ("part of Z_d", "project", "standard deviations of "
                                        "each track's estimate added to Z_d"),
    "safety.occlusion_speed": ("K (hidden)", "project (our addition; ISO 13855's K applied "
                               "to an unseen body)", "how fast a hidden body's ball grows"),
    "safety.delta_s": ("ΔS", "seed 000 Eq. 12 (not an ISO term)", "the slow-down band: full "
                       "speed beyond ΔS·S, a stop below S"),
    "safety.d_min": ("d_min", "seed 000 Eq. 12 (not an ISO term)", "a stop whenever a body "
                     "is nearer than this"),
    "safety.mode": ("SSM / SSM + PFL", "ISO/TS 15066:2016, 5.5.4 (SSM) and 5.5.5 (PFL)",
                    "ssm: no contact while the robot moves; ssm_pfl: near the arms, hands and "
                    "trunk the robot may run at a speed whose contact stays within Annex A's "
                    "limits (head, face and neck: SSM)"),
    "safety.pfl_speed": ("v_PFL", "project (ISO/TS 15066 Annex A's permissible relative "
                         "speed caps it per body region)", "the robot's speed cap near an "
                         "operator under ssm_pfl (none: each region's own limit)"),
    "safety.payload_mass": ("m_L", "ISO/TS 15066 Annex A, Eq. A.4", "the effective payload "
                            "(tool and workpiece) in the robot's effective mass"),
    "safety.fixed_surfaces": ("-", "ISO/TS 15066, 5.5.5 (clamping, quasi-static contact)",
                              "the cell's objects a body region could be pressed against: "
                              "near them the region keeps pure SSM"),
    "safety.clamp_margin": ("-", "project", "how far beyond the 0.05 m clamping gap a "
                            "segment's envelope loses its PFL cap (near the robot's mounting "
                            "surface, a fixed surface or two of its links)"),
    "safety.contact_stop_force": ("F_det", "the robot's force limit (manufacturer; UR: its "
                                  "configured limit plus a 25 N tolerance); ISO/TS 15066 "
                                  "5.5.5", "the contact force at which the robot's own "
                                  "detection is certain to stop it: configure the robot so"),
    "safety.contact_detection_time": ("t_det", "the robot's manufacturer (UR CB3 manual: "
                                      "250 ms worst case for the TCP force limit)", "how long "
                                      "the contact force is held before the robot stops"),
    "safety.transient_window": ("-", "ISO/TS 15066 5.5.5 and Annex A (transient contact, "
                                "as applied)", "after an impact, how long the transient "
                                "limits apply before the quasi-static ones"),
    "braking": ("T_s, S_s by speed", "ISO 10218-1 (stopping time and distance data)",
                "the robot's stopping data by speed fraction, as measured on the cell"),
    "alteration": ("-", "seed 004 (not used by ssm_override)", "speed alteration settings"),
    "zones": ("-", "seed 001 (not used by ssm_override)", "safety zone settings"),
}


def term(name: str) -> tuple[str, str, str]:
    """(symbol, source, meaning) of a configuration field by its dotted name (without
    ``controller.``): its own entry, else its nearest enclosing one."""
    parts = name.split(".")
    for n in range(len(parts), 0, -1):
        key = ".".join(parts[:n])
        if key in TERMS:
            return TERMS[key]
    return ("-", "-", "-")
