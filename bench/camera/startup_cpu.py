#!/usr/bin/env python3
"""Start-up cost of a process: starts COMMAND..., waits for a line of its output containing
--ready (default: the simulated camera's "rendering"), prints the wall time and the CPU time the
process used until then, and kills it. Run it in a network namespace with a multicast route:

  unshare -n sh -c 'ip link set lo up; ip link set lo multicast on; \\
    ip route add 224.0.0.0/4 dev lo; python3 bench/camera/startup_cpu.py -- \\
    build/bin/fieldline-camera --robot 1 --field msl'
"""
import argparse
import os
import subprocess
import time

parser = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--ready", default="rendering", help="text of the line that means started")
parser.add_argument("command", nargs="+")
args = parser.parse_args()
start = time.monotonic()
process = subprocess.Popen(args.command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True)
for line in process.stdout:
    if args.ready in line:
        break
wall = time.monotonic() - start
fields = open(f"/proc/{process.pid}/stat").read().rsplit(")", 1)[1].split()
cpu = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
process.kill()
process.wait()
print(f"wall {wall:.2f} s, cpu {cpu:.2f} s")
