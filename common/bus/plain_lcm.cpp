#include "common/bus/plain_lcm.hpp"

#include <stdexcept>

#include <lcm/lcm-cpp.hpp>

namespace fieldline::bus {

PlainLcmPeer::PlainLcmPeer(const std::string& url) : lcm_(std::make_unique<lcm::LCM>(url)) {
  if (!lcm_->good()) throw std::runtime_error("LCM cannot open " + url);
}

PlainLcmPeer::~PlainLcmPeer() = default;

void PlainLcmPeer::count(const std::string& channel) {
  lcm_->subscribeFunction(
      channel, +[](const lcm::ReceiveBuffer*, const std::string&, int* n) { ++*n; }, &received_);
}

bool PlainLcmPeer::publish(const std::string& channel, const std::vector<std::uint8_t>& bytes) {
  return lcm_->publish(channel, bytes.data(), static_cast<unsigned>(bytes.size())) == 0;
}

void PlainLcmPeer::handle(int timeout_ms) {
  lcm_->handleTimeout(timeout_ms);
}

}  // namespace fieldline::bus
