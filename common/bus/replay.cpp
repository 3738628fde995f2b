#include "common/bus/replay.hpp"

#include <algorithm>

namespace fieldline::bus {

Replay::Replay(SimulatedClock& clock, std::shared_ptr<Connection> bus, ReplayOptions options)
    : clock_(clock),
      options_(std::move(options)),
      publisher_({.process = "replay", .robot_id = 0, .status_period_us = 0}, clock,
                 std::move(bus)) {}

void Replay::add(Node& node) {
  nodes_.push_back(&node);
}

bool Replay::replayed(std::string_view channel) const {
  return options_.channels.empty() || std::find(options_.channels.begin(), options_.channels.end(),
                                                channel) != options_.channels.end();
}

void Replay::settle() {
  // Handling one message may publish others (outputs, their consumers' outputs): spin until a
  // whole round handles nothing. The publisher's spin serves a replay without nodes.
  int handled = 0;
  do {
    handled = publisher_.spinOnce(0);
    for (Node* node : nodes_)
      handled += node->spinOnce(0);
  } while (handled > 0);
}

bool Replay::step(LogReader& log) {
  while (log.nextEvent(event_)) {
    if (!replayed(event_.channel)) {
      ++stats_.skipped;
      continue;
    }
    if (!log.accept(event_)) continue;
    const Utime own = truthToOwn(options_.clock, event_.timestamp);
    if (!started_ || own >= clock_.now()) {
      clock_.set(own);
      started_ = true;
    } else {
      ++stats_.out_of_order;
    }
    publisher_.publishEncoded(event_.channel, event_.data.data(),
                              static_cast<int>(event_.data.size()));
    ++stats_.delivered;
    settle();
    return true;
  }
  return false;
}

const ReplayStats& Replay::run(LogReader& log) {
  while (step(log)) {
  }
  return stats_;
}

// ---------------------------------------------------------------------------------------------
LogRecorder::LogRecorder(Node& node, LogWriter& writer, std::vector<std::string_view> channels,
                         BusId bus)
    : node_(node), writer_(writer), channels_(channels.begin(), channels.end()) {
  node_.subscribeAllRaw(
      [this](const std::string& channel, const void* data, int size) {
        if (std::find(channels_.begin(), channels_.end(), channel) == channels_.end()) return;
        try {
          writer_.write(channel, ownToTruth(log_clock_, node_.now()), data, size);
          ++recorded_;
        } catch (const LogError& e) {
          // Called from LCM's dispatch: an exception must not cross it.
          node_.reportError("log_write", e.what());
        }
      },
      bus);
}

}  // namespace fieldline::bus
