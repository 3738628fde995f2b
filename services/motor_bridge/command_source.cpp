#include "services/motor_bridge/command_source.hpp"

#include <fmt/format.h>

namespace fieldline::motor_bridge {
namespace {
std::string publisherName(std::int64_t id) {
  return fmt::format("{:016x}", static_cast<std::uint64_t>(id));
}
}  // namespace

CommandSource::Result CommandSource::onCommand(int robot_id, std::int64_t publisher_id, Utime now) {
  Result r;
  if (robot_id != robot_id_) {
    r.verdict = Verdict::kOtherRobot;
    ++refused_other_robot_;
    r.reason = fmt::format(
        "MOTION_COMMAND for robot {} from publisher {} on robot {}'s bus: refused ({} so far; "
        "a second driver?)",
        robot_id, publisherName(publisher_id), robot_id_, refused_other_robot_);
  } else if (driver_ && *driver_ != publisher_id && now - driver_seen_ <= kDriverSilenceUs) {
    r.verdict = Verdict::kSecondPublisher;
    ++refused_second_publisher_;
    r.reason = fmt::format("MOTION_COMMAND from two publishers: {} drives, {} refused ({} so far)",
                           publisherName(*driver_), publisherName(publisher_id),
                           refused_second_publisher_);
  } else {
    driver_ = publisher_id;
    driver_seen_ = now;
    return r;
  }
  last_refused_ = now;
  last_reason_ = r.reason;
  return r;
}

std::string CommandSource::warning(Utime now) const {
  if (last_refused_ < 0 || now - last_refused_ > kWarnHoldUs) return {};
  return last_reason_;
}

}  // namespace fieldline::motor_bridge
