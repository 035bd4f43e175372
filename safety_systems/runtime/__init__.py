"""The live runtime: ``safety-systems run`` runs the certified controller on a real cell.

Motion capture comes in as NatNet frames (``mocap``: the ``natnet`` client library, or a
recording streamed over loopback by ``replay_server``), the robot is a UR over RTDE
(``robot_link``: ``ur-rtde``) or, with ``--robot none``, a model that follows the
verified path at the commanded speed. ``safety_loop`` runs the simulator's own compiled
tracker, monitor and override functions on them; ``live_run`` holds the control loop,
its watchdog and its log.
"""
