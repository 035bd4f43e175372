"""The runtime's helper processes (the replay server, the log writer), started in a
process group of their own, so that Ctrl-C does not reach them: a terminal sends it to
its foreground group, and the runtime ends its helpers in its own order once the robot
has its last command (the writer finishes the segment; the replay server is ended, and
asks to be ended too if the runtime dies: ``replay_server --parent-death``)."""

import subprocess
import sys


def start_without_ctrl_c(argv: list[str], **options) -> subprocess.Popen:
    """``subprocess.Popen(argv, **options)`` in a new process group (a new session
    before Python 3.11)."""
    if sys.version_info >= (3, 11):
        return subprocess.Popen(argv, process_group=0, **options)
    return subprocess.Popen(argv, start_new_session=True, **options)
