// The viewer's picture of the team: the latest ROBOT_STATE, BALL_STATE, TEAM_STATE, VISION_LINES
// and every process's SERVICE_STATUS per robot bus, and SIM_WORLD with the simulator's statuses,
// written out as one JSON document for the page (docs/viewer.md lists its fields).
//
// Messages are kept as received (already decoded and validated by bus::Node), so the page shows
// exactly what was published. Not thread-safe: the bus thread owns it and hands the JSON text on.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fieldline/ball_state_t.hpp>
#include <fieldline/line_contours_t.hpp>
#include <fieldline/robot_state_t.hpp>
#include <fieldline/service_status_t.hpp>
#include <fieldline/team_state_t.hpp>
#include <fieldline/world_state_t.hpp>

#include "common/field/field_model.hpp"
#include "common/time/clock.hpp"
#include "tools/json/json_text.hpp"

namespace fieldline::viewer {

// SERVICE_STATUS comes every second: three missed ones mean the process is gone or hung (the
// live view and a recording's view both draw a status older than this as stale).
inline constexpr Utime kStatusStaleUs = 3 * kMicrosPerSecond;

// A message and the viewer's clock time when it arrived (for its age on the page).
template <typename Msg>
struct Received {
  Msg msg;
  Utime received = 0;
};

// One bus: a robot's (robot_id 1..6) or the simulator's (robot_id 0).
struct BusView {
  int robot_id = 0;
  std::string url;
  std::optional<Received<robot_state_t>> robot_state;
  std::optional<Received<ball_state_t>> ball_state;
  std::optional<Received<team_state_t>> team_state;
  std::optional<Received<line_contours_t>> vision_lines;
  // By process name, then by sender robot_id (a bus normally carries one robot's processes).
  std::map<std::pair<std::string, int>, Received<service_status_t>> statuses;
};

class TeamView {
 public:
  // robot_ids: the robots listened to (1..6, each once).
  explicit TeamView(const std::vector<int>& robot_ids);

  // The view of robot `robot_id`'s bus, 0 for the simulator's; throws std::out_of_range otherwise.
  BusView& bus(int robot_id);
  const std::vector<BusView>& robots() const { return robots_; }
  const BusView& sim() const { return sim_; }

  void setSimWorld(const world_state_t& m, Utime received) { sim_world_ = {m, received}; }
  const std::optional<Received<world_state_t>>& simWorld() const { return sim_world_; }

  // The whole picture at viewer time `now`. A status older than stale_after_us is marked stale
  // (its process is probably gone: SERVICE_STATUS comes every second).
  std::string toJson(Utime now, Utime stale_after_us) const;

 private:
  std::vector<BusView> robots_;
  BusView sim_;
  std::optional<Received<world_state_t>> sim_world_;
};

// The field's painted lines, goals, penalty marks and carpet as JSON (sent once to the page).
std::string fieldJson(const field::FieldModel& model);

}  // namespace fieldline::viewer
