// systemd's service notifications (sd_notify(3)) for a process started by a unit with
// Type=notify and WatchdogSec= (fieldline-systemd-units writes such units). Every bus::Node loop
// calls onLoop(): READY=1 the first time (buses open, subscriptions made), WATCHDOG=1 at half the
// unit's watchdog period, from the loop itself, so a loop stuck in a handler stops the pings and
// systemd restarts the process. The node's SERVICE_STATUS state goes out as STATUS= (shown by
// `systemctl status`). Outside systemd (no NOTIFY_SOCKET, no WATCHDOG_USEC) all of it is a no-op.
// The variables are read once, at the first call: a loop costs no getenv.
// Process-wide: the watchdog belongs to the process, whatever number of nodes it runs.
#pragma once

#include <string>

#include "common/time/clock.hpp"

namespace fieldline::bus::systemd {

// From an event loop, with the loop's monotonic time: READY=1 once, WATCHDOG=1 when due.
void onLoop(Utime monotonic_now);
// Monotonic time the next WATCHDOG=1 is due (the loop must wake by then); 0 without a watchdog.
Utime nextPingDue();
void notifyStopping();
// One line for `systemctl status` ("ok", "WARN CAMERA_IMAGE silent 2.1 s").
void notifyStatus(const std::string& text);

}  // namespace fieldline::bus::systemd
