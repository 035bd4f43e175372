"""What ``safety-systems run`` says while it starts: each step and how long it took."""

import contextlib
import os
import sys
import time


def process_age() -> float | None:
    """Seconds since this process started (Linux; None elsewhere): what the command
    line's own imports took before ``run`` began."""
    try:
        fields = open("/proc/self/stat").read().rsplit(")", 1)[1].split()
        uptime = float(open("/proc/uptime").read().split()[0])
        return uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


class Phases:
    """What ``run`` is doing while it starts, said on stderr with how long each step
    took (nothing with --quiet), and kept for summary.json's ``startup``."""

    def __init__(self, quiet: bool):
        self.quiet, self.now, self.took = quiet, "starting", {}
        age = process_age()
        if age is not None:
            self.took["imports"] = round(age, 3)

    @contextlib.contextmanager
    def step(self, key: str, words: str):
        """A step of the start: "run: WORDS..." then, once it is done, its seconds
        (kept under ``key``); a step that fails ends its line (the error's follows)."""
        self.now = words
        if not self.quiet:
            print(f"run: {words}...", end="", file=sys.stderr, flush=True)
        began = time.monotonic()
        try:
            yield
        except BaseException:
            if not self.quiet:
                print(file=sys.stderr, flush=True)  # (the line of a refusal follows)
            raise
        self.took[key] = round(time.monotonic() - began, 3)
        if not self.quiet:
            print(f" {self.took[key]:.1f} s", file=sys.stderr, flush=True)

    def say(self, line: str) -> None:
        if not self.quiet:
            print(f"run: {line}", file=sys.stderr, flush=True)
