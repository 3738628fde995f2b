"""The live children of one fieldline-launch process, read from /proc.

Only the test's own launcher's children are ever looked at: /proc is shared with every other
network namespace on the machine, so a match by name alone could hit another run's process.
"""
import os
import pathlib


def live_children(launcher_pid):
    """(pid, argv as strings) of every child of `launcher_pid` that is not a zombie."""
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            argv = pathlib.Path(f"/proc/{entry}/cmdline").read_bytes().split(b"\0")
            fields = pathlib.Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) != launcher_pid or fields[0] == "Z" or not argv or not argv[0]:
            continue
        yield int(entry), [a.decode() for a in argv if a]


def child_pid(launcher_pid, exe, robot=None):
    """Pid of the launcher's live child running `exe` (for `--robot robot` if given), or None."""
    for pid, words in live_children(launcher_pid):
        if os.path.basename(words[0]) != exe:
            continue
        if robot is None:
            return pid
        at = words.index("--robot") if "--robot" in words else -1
        if 0 <= at < len(words) - 1 and words[at + 1] == str(robot):
            return pid
    return None
