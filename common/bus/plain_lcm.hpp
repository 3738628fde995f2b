#pragma once
// A plain LCM program on a bus: LCM's own receive thread and none of bus::Node's checks, as any LCM
// tool (lcm-spy, lcm-logger, another team's code) sees the bus. Used to show that what a Node
// publishes and reads stays LCM's wire.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace lcm {
class LCM;
}

namespace fieldline::bus {

class PlainLcmPeer {
 public:
  // Throws std::runtime_error when LCM cannot open `url`.
  explicit PlainLcmPeer(const std::string& url);
  ~PlainLcmPeer();
  PlainLcmPeer(const PlainLcmPeer&) = delete;
  PlainLcmPeer& operator=(const PlainLcmPeer&) = delete;

  // Counts every message LCM delivers on `channel` (see received()).
  void count(const std::string& channel);
  // Publishes raw bytes with lcm_publish; false when LCM refuses.
  bool publish(const std::string& channel, const std::vector<std::uint8_t>& bytes);
  // Lets LCM deliver what arrived, waiting at most `timeout_ms`.
  void handle(int timeout_ms);
  int received() const { return received_; }

 private:
  std::unique_ptr<lcm::LCM> lcm_;
  int received_ = 0;
};

}  // namespace fieldline::bus
