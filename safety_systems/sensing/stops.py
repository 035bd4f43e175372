"""Why the robot is held: the protective-stop causes, written once.

The SpeedOverride's ``stop_reason`` output and the KalmanTracker's ``fault`` output use
these codes (a tracker fault is a stop reason of its own, so the override passes it on
unchanged). Every cause but ``separation`` is a fault of the sensing chain; each stops
the robot until it clears (fail safe).
"""

STOP_NONE = 0
STOP_SEPARATION = 1  # Eq. 12: a body too close for the robot's speed
STOP_STALE_FRAME = 2  # no fresh frame: missing frames, or none yet
STOP_LOST_TRACK = 3  # a track vanished near the robot (the previous rule, ``expire``)
STOP_BAD_TIME = 4  # a new frame whose capture time repeats or goes back
STOP_NON_FINITE = 5  # a body flagged seen without a finite position
STOP_UNKNOWN_ID = 6  # an entry whose body id is not registered (or claimed twice)
STOP_GATE = 7  # a position farther from the track than a body can move
# The live runtime's watchdog (``safety_systems.runtime``; never raised in simulation):
STOP_BAD_PACKET = 8  # a motion-capture packet that could not be read
STOP_ROBOT_LOST = 9  # the robot's connection lost, or its joint positions stale
STOP_OVERRUN = 10  # the control loop ran late beyond its stated bound
STOP_EXCEPTION = 11  # an error in the runtime itself (the run ends at speed 0)
# The robot's own contact detection (power and force limiting: its force limit tripped,
# ``safety_systems.pfl.contact_limits``; simulated under ``safety.mode: ssm_pfl``, a
# premise of the real robot's, which stops itself):
STOP_CONTACT = 12

STOP_REASONS = ("none", "separation", "stale_frame", "lost_track", "bad_time", "non_finite",
                "unknown_id", "gate", "bad_packet", "robot_lost", "overrun", "exception",
                "contact")
SIMULATED = STOP_BAD_PACKET  # the sensing causes a simulation can raise: codes below this
# Every cause a simulation can raise, in the summary's order.
SIMULATED_CAUSES = STOP_REASONS[1:SIMULATED] + (STOP_REASONS[STOP_CONTACT],)

# Rejected measurements by cause (the tracker's ``rejected_frames`` counts, in this order).
REJECT_NON_FINITE, REJECT_TIME, REJECT_UNKNOWN_ID, REJECT_GATE = 0, 1, 2, 3
REJECT_CAUSES = ("non_finite", "time", "unknown_id", "gate")
