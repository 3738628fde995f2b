#include "common/bus/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdlib>
#include <mutex>

namespace fieldline::bus::systemd {
namespace {

// Half of WatchdogSec=, µs; 0: no watchdog.
Utime watchdogPingPeriod() {
  std::uint64_t usec = 0;
  // > 0 only when WATCHDOG_USEC is set and WATCHDOG_PID is this process (or unset).
  return sd_watchdog_enabled(0, &usec) > 0 ? static_cast<Utime>(usec / 2) : 0;
}

// Whether NOTIFY_SOCKET names a socket. Read once, with the watchdog period: the unit's
// environment is the process's from its start, and every loop asked getenv twice (issue 32).
bool notifySocketSet() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  return socket != nullptr && *socket != '\0';
}

struct NotifyState {
  std::mutex mutex;
  const bool under_systemd = notifySocketSet();
  bool ready_sent = false;
  const Utime ping_period_us = watchdogPingPeriod();
  Utime next_ping_us = 0;
  bool started = false;
};

NotifyState& state() {
  static NotifyState s;
  return s;
}

bool underSystemd() {
  return state().under_systemd;
}

}  // namespace

void onLoop(Utime monotonic_now) {
  if (!underSystemd()) return;
  NotifyState& s = state();
  std::lock_guard lock(s.mutex);
  if (!s.ready_sent) {
    sd_notify(0, "READY=1");
    s.ready_sent = true;
  }
  if (s.ping_period_us > 0 && (!s.started || monotonic_now >= s.next_ping_us)) {
    sd_notify(0, "WATCHDOG=1");
    s.next_ping_us = monotonic_now + s.ping_period_us;
    s.started = true;
  }
}

Utime nextPingDue() {
  if (!underSystemd()) return 0;
  NotifyState& s = state();
  std::lock_guard lock(s.mutex);
  return s.ping_period_us > 0 && s.started ? s.next_ping_us : 0;
}

void notifyStopping() {
  if (underSystemd()) sd_notify(0, "STOPPING=1");
}

void notifyStatus(const std::string& text) {
  if (!underSystemd()) return;
  std::string line = "STATUS=";
  // One line: the protocol separates assignments by newlines.
  for (const char c : text)
    line += c == '\n' ? ' ' : c;
  sd_notify(0, line.c_str());
}

}  // namespace fieldline::bus::systemd
