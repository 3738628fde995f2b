// Writes seed inputs for the fuzz targets from the real encoders:
//   fuzz_make_seeds CORPUS_DIR   (writes CORPUS_DIR/fuzz_serial_decoder/, fuzz_lcm_decode/,
//                                 fuzz_team_packet/)
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/bus/channels.hpp"
#include "common/serial/protocol.hpp"
#include "teamcomm/packet.hpp"

namespace bus = fieldline::bus;
namespace serial = fieldline::serial;
namespace fs = std::filesystem;
namespace team = fieldline::teamcomm;

namespace {

void write(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// The channel's index byte followed by a default message of its type, stamped plausibly.
template <typename Msg>
void writeLcmSeed(const fs::path& dir, std::uint8_t index, Msg msg) {
  std::vector<std::uint8_t> bytes(1 + msg.getEncodedSize());
  bytes[0] = index;
  msg.encode(bytes.data() + 1, 0, static_cast<int>(bytes.size() - 1));
  write(dir / ("seed_" + std::string(bus::kAllChannelNames[index])), bytes);
}

template <typename Msg>
Msg stamped() {
  Msg msg{};
  msg.header.utime = 1'700'000'000'000'000;
  msg.header.utime_published = msg.header.utime;
  msg.header.seq = 1;
  msg.header.robot_id = 1;
  return msg;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  const fs::path root = argv[1];
  const fs::path serial_dir = root / "fuzz_serial_decoder";
  const fs::path lcm_dir = root / "fuzz_lcm_decode";
  fs::create_directories(serial_dir);
  fs::create_directories(lcm_dir);

  // Serial: a piece-size byte, then valid frames (one per message type, and all in a row).
  const std::vector<serial::Message> messages{
      serial::Hello{serial::Role::kController, 3, 768, 20000},
      serial::VelocityCommand{7, 1000, -2000, 300},
      serial::OdometrySample{42, 123456789, {1, -2, 3}, serial::kStatusReset, 7},
      serial::ErrorReport{serial::ErrorCode::kUnknownType, 0x99},
      // Four wheels (type 0x21) with both tails.
      serial::OdometrySample{
          43, 123476789, {1, -2, 3, -4}, 0, 8, {{100, -200, 300, -400}}, 123456}};
  std::vector<std::uint8_t> all{5};
  for (std::size_t i = 0; i < messages.size(); ++i) {
    std::vector<std::uint8_t> one{static_cast<std::uint8_t>(63)};
    serial::encode(messages[i], one);
    serial::encode(messages[i], all);
    write(serial_dir / ("seed_message_" + std::to_string(i)), one);
  }
  write(serial_dir / "seed_stream", all);

  std::uint8_t i = 0;
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::image_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::line_contours_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::ball_observation_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::obstacle_observations_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::field_features_t>());
  {
    auto odometry = stamped<fieldline::odometry_t>();
    odometry.wheel_count = 3;
    odometry.ticks = {1, -2, 3};
    odometry.wheel_current = {0.5f, -0.25f, 0.0f};
    writeLcmSeed(lcm_dir, i++, odometry);
  }
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::motion_command_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::robot_state_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::ball_state_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::team_state_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::service_status_t>());
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::world_state_t>());
  fieldline::recording_info_t info = stamped<fieldline::recording_info_t>();
  info.format_version = fieldline::recording_info_t::FORMAT_VERSION;
  writeLcmSeed(lcm_dir, i++, info);
  writeLcmSeed(lcm_dir, i++, stamped<fieldline::image_t>());  // CAMERA_PREVIEW

  // Team packets as fuzz_team_packet reads them: a flag byte (bit 0: the target puts magic,
  // version and a valid MAC around the rest), then the packet's body without those.
  const fs::path team_dir = root / "fuzz_team_packet";
  fs::create_directories(team_dir);
  team::TeamKey key;
  for (std::size_t k = 0; k < key.bytes.size(); ++k)
    key.bytes[k] = static_cast<std::uint8_t>(k);
  team::TeamPacket minimal{.team_id = 7, .robot_id = 2, .sequence = 1000, .send_utime = 5'000'000};
  team::TeamPacket full = minimal;
  full.links = {{1, 4'000'000, 4'100'000}, {3, 4'500'000, 4'600'000}};
  full.pose = team::PacketPose{4'900'000, 1.5f, -2.0f,  0.3f,
                               0.1f,      0.0f, 0.2f,   {0.01f, 0.0f, 0.0f, 0.01f, 0.0f, 0.002f},
                               2,         true, 100'000};
  full.ball = team::PacketBall{4'950'000, 4'950'000, 3.0f, 1.0f, -0.5f, 0.0f, {0.02f, 0.0f, 0.02f}};
  full.obstacles = {{2.0f, 2.0f, 0.25f}, {-3.0f, 1.0f, 0.25f}};
  int n = 0;
  for (const team::TeamPacket& p : {minimal, full}) {
    const std::vector<std::uint8_t> packet = team::encodePacket(p, key);
    std::vector<std::uint8_t> signed_body{1};
    signed_body.insert(signed_body.end(), packet.begin() + 5, packet.end() - team::kMacBytes);
    write(team_dir / ("seed_body_" + std::to_string(n)), signed_body);
    std::vector<std::uint8_t> raw{0};
    raw.insert(raw.end(), packet.begin(), packet.end());
    write(team_dir / ("seed_raw_" + std::to_string(n)), raw);
    ++n;
  }
  return 0;
}
