#!/usr/bin/env python3
"""Sorts a perf profile's samples (perf record -g) into what the time went to, for
bench/team/team_profile.sh.

  perf_categories.py PERF_DATA

Kernel samples by the system call (or event) in their call chain: sendmsg (publishing: the
multicast delivery to every socket of the bus runs in the sender's time), recvmmsg (receiving,
the copy to user space), poll (waiting: the sleep and the wake-up, the task switch), read/write
(a serial line), interrupts, page faults, the return to user space. User samples by the leaf
function: the service's algorithm (region_tracking::, feature_recognition::, field::, libm...),
the bus (bus::, msg::, the generated message code, LCM), the motor bridge's serial code, libc.
Prints the shares, largest first.
"""
import collections
import re
import subprocess
import sys

KERNEL = [
    ("sendmsg", r"udp_sendmsg|__sys_sendmsg"),
    ("recvmmsg", r"recvmmsg|udp_recvmsg"),
    ("poll (sleep, wake-up)", r"do_sys_poll|sys_poll"),
    ("epoll_wait", r"epoll_wait"),
    ("write", r"ksys_write|vfs_write"),
    ("read", r"ksys_read|vfs_read"),
    ("clock, timers", r"clock_|hrtimer|timerfd"),
    ("page fault", r"page_fault|handle_mm_fault"),
    ("interrupt", r"asm_sysvec|asm_common_interrupt|irq_exit"),
    ("return to user", r"exit_to_user|syscall_exit"),
]
USER = [
    ("algorithm", r"region_tracking::|feature_recognition::|perception::|geometry::|field::|"
                  r"camera::|fusion::|pilot::|libm|Eigen"),
    ("motor bridge, serial", r"motor_bridge::|serial::|ControllerClock"),
    ("bus, messages", r"bus::|msg::|_t::|lcm|header_t|Status|Seq"),
    ("libc", r"libc|libstdc|\[vdso\]|clock_gettime|malloc|free|operator new|operator delete"),
]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    script = subprocess.run(["perf", "script", "-i", sys.argv[1], "-F", "ip,sym,dso"],
                            capture_output=True, text=True, check=True).stdout
    counts = collections.Counter()
    total = 0
    for sample in script.split("\n\n"):
        lines = [line.strip() for line in sample.strip().splitlines() if line.strip()]
        if not lines:
            continue
        total += 1
        stack = " ".join(lines)
        if "kernel.kallsyms" in lines[0]:
            name = next((n for n, rx in KERNEL if re.search(rx, stack)), "other")
            counts["kernel: " + name] += 1
        else:
            name = next((n for n, rx in USER if re.search(rx, lines[0])), "other")
            counts["user: " + name] += 1
    print(f"{total} samples")
    for name, n in counts.most_common():
        print(f"{100.0 * n / max(total, 1):6.1f} %  {name}")


if __name__ == "__main__":
    main()
