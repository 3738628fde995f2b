"""Waiting for a condition instead of for a time (tests/CMakeLists.txt).

    wait_until(lambda: pty.exists(), 30, "robot 1's pseudo-terminal")

The deadline is only the failure bound: a quick condition returns at once, a loaded machine gets
the time it needs.
"""
import time


class WaitTimeout(AssertionError):
    pass


def wait_until(condition, seconds, what, period=0.1):
    """Calls `condition` every `period` s until it returns something true, and returns that;
    raises WaitTimeout naming `what` after `seconds`."""
    deadline = time.monotonic() + seconds
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() >= deadline:
            raise WaitTimeout(f"timed out after {seconds} s waiting for {what}")
        time.sleep(period)
