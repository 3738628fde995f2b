#!/usr/bin/env python3
"""A sim_team launch file with one build's robot executables on half of the team and another's on
the other half, for bench/team/team_cpu_pairs.sh.

  team_cpu_mix.py ROOT HALF EXE...    (printed to stdout)

EXE: short names of robot executables (camera, region-tracking, feature-recognition, fusion,
pilot, motor-bridge, teamcomm). HALF a: fieldline-EXE on robots 1-3 and fieldline-EXE-new on
4-6; b: swapped. Everything else is config/launch/sim_team.yaml as it is.
"""
import sys

import yaml


class _NoAliases(yaml.SafeDumper):
    def ignore_aliases(self, data):
        return True


def main():
    if len(sys.argv) < 4 or sys.argv[2] not in ("a", "b"):
        sys.exit(__doc__)
    root, half, exes = sys.argv[1], sys.argv[2], sys.argv[3:]
    team = yaml.safe_load(open(f"{root}/config/launch/sim_team.yaml"))
    base = yaml.safe_load(open(f"{root}/config/launch/robot_processes.yaml"))["processes"]
    old_robots, new_robots = ([1, 2, 3], [4, 5, 6]) if half == "a" else ([4, 5, 6], [1, 2, 3])
    procs = team["processes"]
    for exe in exes:
        full = "fieldline-" + exe
        entry = next((p for p in base if p.get("executable") == full), None)
        if entry is None:
            sys.exit(f"team_cpu_mix: no process runs {full} in robot_processes.yaml")
        merged = dict(entry)
        own = next((p for p in procs if p.get("name") == entry["name"]), None)
        if own is None:
            own = {"name": entry["name"]}
            procs.append(own)
        merged.update({k: v for k, v in own.items() if k != "robots"})
        own["robots"] = old_robots
        new = {k: v for k, v in merged.items() if k in ("args", "main_channel", "env")}
        new.update({"name": entry["name"] + "_new", "executable": full + "-new",
                    "robots": new_robots})
        procs.append(new)
    print(yaml.dump(team, Dumper=_NoAliases, sort_keys=False))


if __name__ == "__main__":
    main()
