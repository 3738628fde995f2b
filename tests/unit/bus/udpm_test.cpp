// The udpm receive path of bus::Node without LCM's receive thread (common/bus/udpm_wire.hpp,
// udpm_receiver.hpp): LCM's wire format read by hand (short, fragmented, truncated, wrong magic,
// fragments out of order or missing), the kernel socket filter (run by the kernel on a socket
// pair), and, in a private network namespace, real udpm buses: what LCM publishes arrives, and a
// process wakes only for the channels it reads.
#include <arpa/inet.h>
#include <fcntl.h>
#include <sched.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <numeric>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/node.hpp"
#include "common/bus/plain_lcm.hpp"
#include "common/bus/udpm_receiver.hpp"
#include "common/bus/udpm_wire.hpp"
#include "tests/support/private_network.hpp"

namespace fieldline::bus {
namespace udpm_test {

using Bytes = std::vector<std::uint8_t>;

void put32(Bytes& b, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    b.push_back(static_cast<std::uint8_t>(v >> shift));
}
void put16(Bytes& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v >> 8));
  b.push_back(static_cast<std::uint8_t>(v));
}

// A datagram as LCM's lcm_udpm_publish builds it.
Bytes shortDatagram(const std::string& channel, const Bytes& payload, std::uint32_t seqno = 7) {
  Bytes b;
  put32(b, udpm::kMagicShort);
  put32(b, seqno);
  b.insert(b.end(), channel.begin(), channel.end());
  b.push_back(0);
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}

// The fragments LCM sends for `payload` on `channel`, `fragment_bytes` of the message per datagram
// (the first one's shortened by the channel name).
std::vector<Bytes> fragments(const std::string& channel, const Bytes& payload,
                             std::uint32_t seqno = 11, std::size_t fragment_bytes = 1000) {
  const std::size_t total = channel.size() + 1 + payload.size();
  const std::size_t count = (total + fragment_bytes - 1) / fragment_bytes;
  std::vector<Bytes> out;
  std::size_t offset = 0;
  for (std::size_t no = 0; no < count; ++no) {
    Bytes b;
    put32(b, udpm::kMagicFragment);
    put32(b, seqno);
    put32(b, static_cast<std::uint32_t>(payload.size()));
    put32(b, static_cast<std::uint32_t>(offset));
    put16(b, static_cast<std::uint16_t>(no));
    put16(b, static_cast<std::uint16_t>(count));
    std::size_t room = fragment_bytes;
    if (no == 0) {
      b.insert(b.end(), channel.begin(), channel.end());
      b.push_back(0);
      room -= channel.size() + 1;
    }
    const std::size_t n = std::min(room, payload.size() - offset);
    b.insert(b.end(), payload.begin() + static_cast<std::ptrdiff_t>(offset),
             payload.begin() + static_cast<std::ptrdiff_t>(offset + n));
    offset += n;
    out.push_back(std::move(b));
  }
  return out;
}

Bytes pattern(std::size_t n) {
  Bytes b(n);
  for (std::size_t i = 0; i < n; ++i)
    b[i] = static_cast<std::uint8_t>((i * 131) ^ (i >> 8));
  return b;
}

// ---- the wire format ----------------------------------------------------------------------

TEST(UdpmWire, ReadsAShortMessage) {
  const Bytes payload = pattern(300);
  const Bytes d = shortDatagram("ODOMETRY", payload, 42);
  udpm::Datagram out;
  ASSERT_EQ(udpm::parseDatagram(d, out), nullptr);
  EXPECT_FALSE(out.fragment);
  EXPECT_EQ(out.seqno, 42u);
  EXPECT_EQ(out.channel, "ODOMETRY");
  EXPECT_EQ(Bytes(out.bytes.begin(), out.bytes.end()), payload);
}

TEST(UdpmWire, RefusesTruncatedAndForeignDatagrams) {
  udpm::Datagram out;
  const Bytes tiny{0x4c, 0x43, 0x30};
  EXPECT_STREQ(udpm::parseDatagram(tiny, out), "shorter than an LCM header");
  Bytes wrong = shortDatagram("ODOMETRY", pattern(10));
  wrong[3] = '9';  // "LC09"
  EXPECT_NE(std::string(udpm::parseDatagram(wrong, out)).find("magic"), std::string::npos);
  // A channel name that never ends (no NUL within 64 bytes).
  Bytes endless;
  put32(endless, udpm::kMagicShort);
  put32(endless, 1);
  endless.insert(endless.end(), 80, 'A');
  EXPECT_NE(udpm::parseDatagram(endless, out), nullptr);
  // A fragment header cut short.
  Bytes cut = fragments("CAMERA_IMAGE", pattern(5000))[1];
  cut.resize(15);
  EXPECT_STREQ(udpm::parseDatagram(cut, out), "shorter than an LCM fragment header");
  // A fragment claiming bytes beyond its message.
  Bytes beyond = fragments("CAMERA_IMAGE", pattern(5000))[1];
  beyond[8] = beyond[9] = beyond[10] = 0;
  beyond[11] = 10;  // message size 10
  EXPECT_STREQ(udpm::parseDatagram(beyond, out), "fragment reaches beyond its message's size");
  // Fragment number not below the count.
  Bytes number = fragments("CAMERA_IMAGE", pattern(5000))[1];
  number[16] = 0x7f;
  EXPECT_STREQ(udpm::parseDatagram(number, out), "fragment number beyond the fragment count");
}

// Feeds datagrams through parse and the assembler as the receiver does; returns the completed
// messages' channel and bytes.
std::vector<std::pair<std::string, Bytes>> assemble(udpm::FragmentAssembler& a,
                                                    const std::vector<Bytes>& datagrams,
                                                    std::uint64_t sender = 1) {
  std::vector<std::pair<std::string, Bytes>> done;
  for (const Bytes& d : datagrams) {
    udpm::Datagram parsed;
    EXPECT_EQ(udpm::parseDatagram(d, parsed), nullptr);
    udpm::FragmentAssembler::Message m;
    if (a.add(sender, parsed, m) == udpm::FragmentAssembler::Outcome::kComplete) {
      done.emplace_back(std::string(m.channel), Bytes(m.bytes.begin(), m.bytes.end()));
    }
  }
  return done;
}

TEST(UdpmWire, ReassemblesAFragmentedMessage) {
  const Bytes image = pattern(153'700);
  const auto parts = fragments("CAMERA_IMAGE", image, 5, 65'487);
  ASSERT_EQ(parts.size(), 3u);
  udpm::FragmentAssembler a;
  const auto done = assemble(a, parts);
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].first, "CAMERA_IMAGE");
  EXPECT_TRUE(done[0].second == image);
  EXPECT_EQ(a.incomplete(), 0);
}

TEST(UdpmWire, FragmentsOutOfOrderAndDuplicatedStillMakeTheMessage) {
  const Bytes payload = pattern(4'500);
  auto parts = fragments("VISION_LINES", payload);
  ASSERT_EQ(parts.size(), 5u);
  udpm::FragmentAssembler a;
  // Last first, the first in the middle, one twice.
  const auto done = assemble(a, {parts[4], parts[2], parts[0], parts[2], parts[3], parts[1]});
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].first, "VISION_LINES");
  EXPECT_TRUE(done[0].second == payload);
}

TEST(UdpmWire, AMissingFragmentLosesThatMessageAndIsCounted) {
  udpm::FragmentAssembler a;
  auto first = fragments("VISION_LINES", pattern(3'000), 1);
  auto second = fragments("VISION_LINES", pattern(3'500), 2);
  first.erase(first.begin() + 1);  // lost on the way
  std::vector<Bytes> all = first;
  all.insert(all.end(), second.begin(), second.end());
  const auto done = assemble(a, all);
  ASSERT_EQ(done.size(), 1u);
  EXPECT_TRUE(done[0].second == pattern(3'500));
  EXPECT_EQ(a.incomplete(), 1);
  EXPECT_EQ(a.lastIncompleteChannel(), "VISION_LINES");
}

TEST(UdpmWire, LaterFragmentsOfAMessageNotReadAreNoLoss) {
  // The socket filter drops the first fragment of a channel the process does not read and passes
  // the later ones: they never complete, and that is not a lost message.
  udpm::FragmentAssembler a;
  auto image = fragments("CAMERA_IMAGE", pattern(4'000), 1);
  image.erase(image.begin());
  const auto lines = fragments("VISION_LINES", pattern(2'000), 2);
  std::vector<Bytes> all = image;
  all.insert(all.end(), lines.begin(), lines.end());
  const auto done = assemble(a, all);
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0].first, "VISION_LINES");
  EXPECT_EQ(a.incomplete(), 0);
}

TEST(UdpmWire, TwoSendersInterleavedAreKeptApart) {
  udpm::FragmentAssembler a;
  const auto one = fragments("CAMERA_IMAGE", pattern(3'000), 9);
  const auto two = fragments("CAMERA_PREVIEW", pattern(2'500), 9);
  std::vector<std::pair<std::string, Bytes>> done;
  for (std::size_t i = 0; i < std::max(one.size(), two.size()); ++i) {
    if (i < one.size()) {
      auto d = assemble(a, {one[i]}, 1);
      done.insert(done.end(), d.begin(), d.end());
    }
    if (i < two.size()) {
      auto d = assemble(a, {two[i]}, 2);
      done.insert(done.end(), d.begin(), d.end());
    }
  }
  ASSERT_EQ(done.size(), 2u);
  EXPECT_EQ(a.incomplete(), 0);
}

// Review of issue 32: a sender's unfinished message is given up (and counted) when it can no
// longer finish: a short message from that sender, or its port no longer passing the filter.
TEST(UdpmWire, AnUnfinishedMessageGivenUpIsCounted) {
  udpm::FragmentAssembler a;
  const auto lines = fragments("VISION_LINES", pattern(3'000), 1);
  auto image = fragments("CAMERA_IMAGE", pattern(3'000), 1);
  EXPECT_TRUE(assemble(a, {lines[0]}, (std::uint64_t{1} << 16) | 6001).empty());
  // Later fragments without their first (a channel not read): no loss when given up.
  EXPECT_TRUE(assemble(a, {image[1]}, (std::uint64_t{1} << 16) | 5000).empty());
  a.giveUp((std::uint64_t{1} << 16) | 5000);
  EXPECT_EQ(a.incomplete(), 0);
  a.giveUp((std::uint64_t{2} << 16) | 6001);  // another address
  EXPECT_EQ(a.incomplete(), 0);
  a.giveUpPort(6001);
  EXPECT_EQ(a.incomplete(), 1);
  EXPECT_EQ(a.lastIncompleteChannel(), "VISION_LINES");
  a.giveUpPort(6001);  // once only
  EXPECT_EQ(a.incomplete(), 1);
}

// Review of issue 32: the least recently seen sender is forgotten first (a publisher that keeps
// publishing stays known however often others restart), and one quiet for 10 s is forgotten.
TEST(UdpmWire, SenderPortsForgetTheLeastRecentlySeen) {
  udpm::SenderPorts ports;
  std::vector<std::uint16_t> forgotten;
  constexpr std::int64_t kSecond = 1'000'000;
  std::int64_t now = 0;
  ports.add(100, now, forgotten);  // the long-lived publisher, learnt first
  for (std::uint16_t p = 1; p < 8; ++p)
    ports.add(static_cast<std::uint16_t>(200 + p), now += 1000, forgotten);
  EXPECT_TRUE(forgotten.empty());
  // Eight restarts of other publishers (a new port each); 100 keeps publishing.
  for (std::uint16_t restart = 0; restart < 8; ++restart) {
    EXPECT_TRUE(ports.refresh(100, now += 1000));
    ports.add(static_cast<std::uint16_t>(300 + restart), now += 1000, forgotten);
  }
  EXPECT_EQ(forgotten.size(), 8u);
  EXPECT_TRUE(std::find(forgotten.begin(), forgotten.end(), 100) == forgotten.end());
  EXPECT_TRUE(ports.refresh(100, now));
  EXPECT_EQ(ports.ports().size(), udpm::SenderPorts::kMax);
  // More than eight senders, of which one keeps publishing: the quiet ones go after 10 s.
  forgotten.clear();
  for (int i = 0; i < 11; ++i)
    EXPECT_TRUE(ports.refresh(100, now += kSecond));
  ports.expire(now, forgotten);
  EXPECT_EQ(forgotten.size(), 7u);
  EXPECT_EQ(ports.ports(), std::vector<std::uint16_t>{100});
  EXPECT_FALSE(ports.refresh(307, now));
}

// ---- the socket filter, run by the kernel --------------------------------------------------

// Sends `datagrams` through a datagram socket pair whose receiving end carries the filter (the
// payload starts at offset 0 there); returns what came through.
std::vector<Bytes> throughProgram(const std::vector<sock_filter>& program,
                                  const std::vector<Bytes>& datagrams) {
  int pair[2];
  EXPECT_EQ(::socketpair(AF_UNIX, SOCK_DGRAM | SOCK_NONBLOCK, 0, pair), 0);
  sock_fprog prog{static_cast<unsigned short>(program.size()),
                  const_cast<sock_filter*>(program.data())};
  EXPECT_EQ(::setsockopt(pair[1], SOL_SOCKET, SO_ATTACH_FILTER, &prog, sizeof prog), 0)
      << std::strerror(errno);
  for (const Bytes& d : datagrams)
    EXPECT_EQ(::send(pair[0], d.data(), d.size(), 0), static_cast<ssize_t>(d.size()));
  std::vector<Bytes> got;
  Bytes buffer(70'000);
  for (;;) {
    const ssize_t n = ::recv(pair[1], buffer.data(), buffer.size(), 0);
    if (n < 0) break;
    got.emplace_back(buffer.begin(), buffer.begin() + n);
  }
  ::close(pair[0]);
  ::close(pair[1]);
  return got;
}

std::vector<Bytes> throughFilter(const std::vector<std::string>& channels, bool later_fragments,
                                 const std::vector<Bytes>& datagrams) {
  return throughProgram(udpm::filterProgram(channels, later_fragments, 0), datagrams);
}

// `d` behind a UDP header from `port`, as a UDP socket's filter sees it.
Bytes fromPort(std::uint16_t port, const Bytes& d) {
  Bytes b;
  put16(b, port);
  put16(b, 7667);
  put16(b, static_cast<std::uint16_t>(d.size() + 8));
  put16(b, 0);
  b.insert(b.end(), d.begin(), d.end());
  return b;
}

TEST(UdpmFilter, PassesOnlyTheChannelsAProcessReads) {
  const Bytes odo = shortDatagram("ODOMETRY", pattern(100));
  const Bytes cmd = shortDatagram("MOTION_COMMAND", pattern(60));
  const Bytes state = shortDatagram("ROBOT_STATE", pattern(200));
  // Names that share a prefix with a subscribed one, or are a prefix of it.
  const Bytes longer = shortDatagram("MOTION_COMMANDS", pattern(60));
  const Bytes shorter = shortDatagram("MOTION_COMMAN", pattern(60));
  const Bytes empty_payload = shortDatagram("MOTION_COMMAND", {});
  const auto got = throughFilter({"MOTION_COMMAND", "ROBOT_STATE"}, false,
                                 {odo, cmd, state, longer, shorter, empty_payload, Bytes{1, 2, 3}});
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0], cmd);
  EXPECT_EQ(got[1], state);
  EXPECT_EQ(got[2], empty_payload);
}

TEST(UdpmFilter, FragmentsOnlyForProcessesThatReadBigChannels) {
  const auto image = fragments("CAMERA_IMAGE", pattern(3'000), 3);
  const auto lines = fragments("VISION_LINES", pattern(2'500), 4);
  std::vector<Bytes> all = image;
  all.insert(all.end(), lines.begin(), lines.end());
  // The motor bridge: no fragment at all.
  EXPECT_TRUE(throughFilter({"MOTION_COMMAND"}, false, all).empty());
  // Fusion (reads VISION_LINES): the first fragment of its own channel, every later fragment.
  const auto fusion = throughFilter({"VISION_LINES", "ODOMETRY"}, true, all);
  EXPECT_EQ(fusion.size(), all.size() - 1);
  EXPECT_EQ(std::count(fusion.begin(), fusion.end(), image[0]), 0);
  // A channel whose name has a length of every residue mod 4.
  for (const std::string name : {"A", "AB", "ABC", "ABCD", "ABCDE"}) {
    const auto got =
        throughFilter({name}, false, {shortDatagram(name, pattern(10)), shortDatagram("X", {})});
    EXPECT_EQ(got.size(), 1u) << name;
  }
}

// Issue 32: a process reading VISION_LINES but no camera image takes later fragments only from
// the senders it has seen publishing what it reads: not the camera's image fragments.
TEST(UdpmFilter, LaterFragmentsOnlyFromTheSendersGiven) {
  std::vector<Bytes> image, lines;
  for (const Bytes& d : fragments("CAMERA_IMAGE", pattern(3'000), 3))
    image.push_back(fromPort(5000, d));
  for (const Bytes& d : fragments("VISION_LINES", pattern(2'500), 4))
    lines.push_back(fromPort(6001, d));
  ASSERT_GT(lines.size(), 2u);
  std::vector<Bytes> all = image;
  all.insert(all.end(), lines.begin(), lines.end());
  const std::vector<std::string> channels{"VISION_LINES", "ODOMETRY"};
  // Senders known: every fragment of the lines, none of the image.
  for (const std::vector<std::uint16_t>& ports :
       {std::vector<std::uint16_t>{6001}, std::vector<std::uint16_t>{4000, 6001, 7000}}) {
    const auto program =
        udpm::filterProgram(channels, udpm::LaterFragments{.all = false, .from_ports = ports}, 8);
    EXPECT_EQ(throughProgram(program, all), lines);
  }
  // None known yet: the lines' first fragment only.
  const auto none = udpm::filterProgram(
      channels, udpm::LaterFragments{.all = false, .from_ports = {5001, 6000}}, 8);
  EXPECT_EQ(throughProgram(none, all), std::vector<Bytes>{lines[0]});
  // Short messages of the channels read pass from any sender.
  const Bytes odo = fromPort(9, shortDatagram("ODOMETRY", pattern(30)));
  EXPECT_EQ(throughProgram(none, {odo, fromPort(9, shortDatagram("ROBOT_STATE", {}))}),
            std::vector<Bytes>{odo});
}

TEST(UdpmFilter, AProcessThatReadsNothingGetsNothing) {
  EXPECT_TRUE(throughFilter({}, false, {shortDatagram("ODOMETRY", pattern(10))}).empty());
}

TEST(UdpmUrl, ReadsGroupPortAndBuffer) {
  const auto a = parseUdpmUrl("udpm://239.255.76.67:7670?ttl=0&recv_buf_size=4194304");
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->port, 7670);
  EXPECT_EQ(a->recv_buf_size, 4194304);
  EXPECT_EQ(std::string(inet_ntoa(a->group)), "239.255.76.67");
  EXPECT_EQ(parseUdpmUrl("udpm://")->port, 7667);
  EXPECT_FALSE(parseUdpmUrl("memq://").has_value());
  EXPECT_THROW(parseUdpmUrl("udpm://239.255.76.67:76x"), std::invalid_argument);
  EXPECT_THROW(parseUdpmUrl("udpm://nowhere:7667"), std::invalid_argument);
}

// ---- real udpm buses, in a private network namespace ---------------------------------------

class UdpmBus : public ::testing::Test {
 protected:
  void SetUp() override {
    // This test's process only (every case runs in a process of its own).
    if (!test::enterPrivateMulticastNetwork()) {
      FAIL() << "needs a private network namespace (root, as scripts/test runs, or user "
                "namespaces): unshare(CLONE_NEWNET) or the loopback multicast route failed";
    }
  }
  static constexpr const char* kUrl = "udpm://239.255.76.67:7801?ttl=0&recv_buf_size=4194304";
  SystemClock clock;

  static image_t image(int frame) {
    image_t m{};
    m.width = 320;
    m.height = 240;
    m.stride = 640;
    m.format = image_t::FORMAT_YUYV;
    m.source = image_t::SOURCE_SIM;
    m.frame_number = frame;
    m.size = 320 * 240 * 2;
    m.data.resize(static_cast<std::size_t>(m.size));
    for (std::size_t i = 0; i < m.data.size(); ++i)
      m.data[i] = static_cast<std::uint8_t>(i * 7 + static_cast<std::size_t>(frame));
    return m;
  }
  // Spins the nodes until `done` or a generous deadline (a busy machine).
  template <typename Done>
  void spinUntil(std::vector<Node*> nodes, Done done) {
    for (int i = 0; i < 400 && !done(); ++i)
      for (Node* n : nodes)
        n->spinOnce(5);
  }
};

TEST_F(UdpmBus, AProcessWakesOnlyForTheChannelsItReads) {
  Node camera{{.process = "camera", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node bridge{{.process = "bridge", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node tracker{{.process = "tracker", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  int commands = 0;
  bridge.subscribe(channels::kMotionCommand, [&](const motion_command_t&) { ++commands; });
  std::vector<image_t> images;
  tracker.subscribe(channels::kCameraImage, [&](const image_t& m) { images.push_back(m); });
  constexpr int kN = 5;
  for (int i = 0; i < kN; ++i) {
    image_t frame = image(i);
    frame.header.utime = clock.now();
    ASSERT_TRUE(camera.publish(channels::kCameraImage, frame));
    odometry_t odo{};
    odo.header.utime = clock.now();
    ASSERT_TRUE(camera.publish(channels::kOdometry, odo));
    motion_command_t cmd{};
    cmd.header.utime = clock.now();
    cmd.deadline_utime = clock.now() + 100'000;
    cmd.source = motion_command_t::SOURCE_PILOT;
    ASSERT_TRUE(camera.publish(channels::kMotionCommand, cmd));
  }
  spinUntil({&bridge, &tracker}, [&] { return commands == kN && images.size() == kN; });
  EXPECT_EQ(commands, kN);
  ASSERT_EQ(images.size(), static_cast<std::size_t>(kN));
  for (int i = 0; i < kN; ++i) {
    const image_t expected = image(i);
    EXPECT_EQ(images[static_cast<std::size_t>(i)].frame_number, i);
    EXPECT_TRUE(images[static_cast<std::size_t>(i)].data == expected.data) << "frame " << i;
  }
  // The bridge's socket saw its commands and nothing else: no odometry, no image fragment.
  EXPECT_EQ(bridge.busDatagrams(), kN);
  // The tracker read three fragments per frame and no small message.
  EXPECT_EQ(tracker.busDatagrams(), 3 * kN);
  // The camera reads nothing: it has no receive socket at all.
  EXPECT_EQ(camera.busDatagrams(), 0);
  EXPECT_EQ(bridge.status().errorCount("bus_incomplete"), 0);
}

TEST_F(UdpmBus, ARecorderTakesEveryChannel) {
  Node sender{{.process = "sender", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node bridge{{.process = "bridge", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node recorder{{.process = "recorder", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  int commands = 0;
  bridge.subscribe(channels::kMotionCommand, [&](const motion_command_t&) { ++commands; });
  std::vector<std::string> seen;
  recorder.subscribeAllRaw(
      [&](const std::string& channel, const void*, int) { seen.push_back(channel); });
  odometry_t odo{};
  odo.header.utime = clock.now();
  ASSERT_TRUE(sender.publish(channels::kOdometry, odo));
  image_t frame = image(1);
  frame.header.utime = clock.now();
  ASSERT_TRUE(sender.publish(channels::kCameraImage, frame));
  motion_command_t cmd{};
  cmd.header.utime = clock.now();
  cmd.deadline_utime = clock.now() + 100'000;
  cmd.source = motion_command_t::SOURCE_PILOT;
  ASSERT_TRUE(sender.publish(channels::kMotionCommand, cmd));
  spinUntil({&bridge, &recorder}, [&] { return seen.size() == 3 && commands == 1; });
  EXPECT_EQ(seen, (std::vector<std::string>{"ODOMETRY", "CAMERA_IMAGE", "MOTION_COMMAND"}));
  EXPECT_EQ(commands, 1);
  EXPECT_EQ(bridge.busDatagrams(), 1);
}

// Issue 32: a deferred subscription (the pilot's pose) wakes no one; its messages are handled, in
// their order, before the next timer and before the next message of another channel on the bus.
TEST_F(UdpmBus, ADeferredChannelWakesNoOneAndIsHandledBeforeTheNextTimer) {
  Node sender{{.process = "sender", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node pilot{{.process = "pilot", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  std::vector<std::int64_t> odometry;
  pilot.subscribeDeferred(channels::kOdometry,
                          [&](const odometry_t& m) { odometry.push_back(m.header.seq); });
  std::size_t odometry_at_command = 0;
  pilot.subscribe(channels::kMotionCommand,
                  [&](const motion_command_t&) { odometry_at_command = odometry.size(); });
  const auto publishOdometry = [&](int n) {
    for (int i = 0; i < n; ++i) {
      odometry_t odo{};
      odo.header.utime = clock.now();
      ASSERT_TRUE(sender.publish(channels::kOdometry, odo));
    }
  };
  publishOdometry(3);
  // Nothing due: the poll sleeps its whole timeout, nothing is handled.
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(pilot.spinOnce(60), 0);
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(50));
  EXPECT_TRUE(odometry.empty());
  // A timer due: the waiting messages first.
  std::size_t odometry_at_timer = 0;
  pilot.after(0, [&] { odometry_at_timer = odometry.size(); });
  pilot.spinOnce(0);
  EXPECT_EQ(odometry_at_timer, 3u);
  EXPECT_EQ(odometry, (std::vector<std::int64_t>{0, 1, 2}));
  // A message of another channel: the deferred ones that came before it first.
  publishOdometry(2);
  motion_command_t cmd{};
  cmd.header.utime = clock.now();
  cmd.deadline_utime = clock.now() + 100'000;
  cmd.source = motion_command_t::SOURCE_PILOT;
  ASSERT_TRUE(sender.publish(channels::kMotionCommand, cmd));
  spinUntil({&pilot}, [&] { return odometry_at_command > 0; });
  EXPECT_EQ(odometry_at_command, 5u);
  // Its waited-on socket read the command alone.
  EXPECT_EQ(pilot.busDatagrams(), 1);
  // handleDeferred(): a callback that acts on the newest (the motor bridge's command written at
  // the controller's sample) has them handled now, without a spin.
  publishOdometry(2);
  for (int i = 0; i < 200 && odometry.size() < 7; ++i) {
    pilot.handleDeferred();
    if (odometry.size() < 7) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(odometry, (std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(pilot.busDatagrams(), 1);
}

// A deferred message that arrived before a message of another channel is handled before it, also
// when that message is read in a later batch of the same wake-up; so a watch callback's
// handleDeferred() (the motor bridge's at the controller's sample) finds none older than what was
// handled. (Read once before the bus, a sample that came while the first batch was handled would
// go after the next batch's newer command.)
TEST_F(UdpmBus, ADeferredMessageGoesBeforeEveryLaterMessageOfTheWakeUp) {
  Node sender{{.process = "sender", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node seer{{.process = "seer", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node bridge{{.process = "bridge", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  std::int64_t seen_by_seer = -1;
  seer.subscribe(channels::kMotionCommand,
                 [&](const motion_command_t& m) { seen_by_seer = m.header.seq; });
  // A datagram is queued on every socket of the bus in one pass: once the seer has a command, the
  // bridge's socket has it (and what the sender sent before it) too.
  const auto arrived = [&](std::int64_t seq) {
    spinUntil({&seer}, [&] { return seen_by_seer >= seq; });
    ASSERT_GE(seen_by_seer, seq);
  };
  const auto command = [&] {
    motion_command_t cmd{};
    cmd.header.utime = clock.now();
    cmd.deadline_utime = clock.now() + 100'000;
    cmd.source = motion_command_t::SOURCE_PILOT;
    ASSERT_TRUE(sender.publish(channels::kMotionCommand, cmd));
  };
  std::vector<std::string> order;
  bridge.subscribeDeferred(channels::kOdometry, [&](const odometry_t& m) {
    order.push_back("odometry " + std::to_string(m.header.seq));
  });
  bool sent_more = false;
  bridge.subscribe(channels::kMotionCommand, [&](const motion_command_t& m) {
    order.push_back("command " + std::to_string(m.header.seq));
    if (sent_more) return;
    sent_more = true;
    // While the first batch is handled: a sample, then a command that the next batch reads.
    odometry_t odo{};
    odo.header.utime = clock.now();
    ASSERT_TRUE(sender.publish(channels::kOdometry, odo));
    command();
    arrived(UdpmReceiver::kBatch);
  });
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  bridge.watchFd(pipe_fds[0], [&] {
    char c = 0;
    EXPECT_EQ(::read(pipe_fds[0], &c, 1), 1);
    bridge.handleDeferred();
    order.push_back("watch");
  });
  // A full first batch waits, and the watched fd is readable: one wake-up for all.
  for (int i = 0; i < UdpmReceiver::kBatch; ++i)
    command();
  arrived(UdpmReceiver::kBatch - 1);
  ASSERT_EQ(::write(pipe_fds[1], "x", 1), 1);
  bridge.spinOnce(1000);
  std::vector<std::string> expected;
  for (int i = 0; i < UdpmReceiver::kBatch; ++i)
    expected.push_back("command " + std::to_string(i));
  expected.insert(expected.end(),
                  {"odometry 0", "command " + std::to_string(UdpmReceiver::kBatch), "watch"});
  EXPECT_EQ(order, expected);
  ::close(pipe_fds[0]);
  ::close(pipe_fds[1]);
}

// Review 13: the deferred socket is read before every batch of the bus; a flood on a deferred
// channel must still stop at one spin's budget, so timers and the status run between spins.
TEST_F(UdpmBus, AFloodOnADeferredChannelIsBoundedPerSpin) {
  Node sender{{.process = "sender", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node seer{{.process = "seer", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node bridge{{.process = "bridge", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  int odometry_seen = 0, commands_seen = 0;
  std::int64_t seen_by_seer = -1;
  seer.subscribe(channels::kMotionCommand,
                 [&](const motion_command_t& m) { seen_by_seer = m.header.seq; });
  bridge.subscribeDeferred(channels::kOdometry, [&](const odometry_t&) { ++odometry_seen; });
  bridge.subscribe(channels::kMotionCommand, [&](const motion_command_t&) { ++commands_seen; });
  constexpr int kFlood = 500;
  for (int i = 0; i < kFlood; ++i) {
    odometry_t odo{};
    odo.header.utime = clock.now();
    ASSERT_TRUE(sender.publish(channels::kOdometry, odo));
  }
  // Several batches of commands after the flood: each batch's read comes with a deferred read.
  constexpr int kCommands = 4 * UdpmReceiver::kBatch;
  for (int i = 0; i < kCommands; ++i) {
    motion_command_t cmd{};
    cmd.header.utime = clock.now();
    cmd.deadline_utime = clock.now() + 100'000;
    cmd.source = motion_command_t::SOURCE_PILOT;
    ASSERT_TRUE(sender.publish(channels::kMotionCommand, cmd));
  }
  spinUntil({&seer}, [&] { return seen_by_seer >= kCommands - 1; });
  ASSERT_EQ(seen_by_seer, kCommands - 1);
  bridge.spinOnce(1000);
  EXPECT_EQ(commands_seen, kCommands);
  EXPECT_GT(odometry_seen, 0);
  EXPECT_LE(odometry_seen, 200);  // the 200 datagrams a spin reads of a bus
  // The rest waits for the next reads, none lost.
  for (int spins = 0; spins < 10 && odometry_seen < kFlood; ++spins)
    bridge.handleDeferred();
  EXPECT_EQ(odometry_seen, kFlood);
}

// Review 13: the guard against a nested read belongs to the receiver, whose buffers hold the batch
// being handled, not to a node: nodes may share a connection (and its deferred socket). A deferred
// handler that has another node on the same connection, or its own node, handle the deferred
// messages again still sees the rest of its batch, each message once, in order. (With the guard a
// node's, the other node's read took the messages after the batch into the batch's buffers: they
// came before the batch's rest, and twice.)
TEST_F(UdpmBus, ANestedDeferredReadOnASharedConnectionLeavesTheBatchWhole) {
  Node sender{{.process = "sender", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node seer{{.process = "seer", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  const std::shared_ptr<Connection> shared = Connection::open(kUrl);
  Node first{
      {.process = "first", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock, shared};
  Node second{
      {.process = "second", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock, shared};
  std::int64_t seen_by_seer = -1;
  seer.subscribe(channels::kOdometry, [&](const odometry_t& m) { seen_by_seer = m.header.seq; });
  std::vector<std::int64_t> seen;
  Node* nested = nullptr;
  first.subscribeDeferred(channels::kOdometry, [&](const odometry_t& m) {
    seen.push_back(m.header.seq);
    nested->handleDeferred();
  });
  // More than a batch: the rest waits on the socket while the first batch is handled.
  constexpr int kCount = UdpmReceiver::kBatch + 2;
  std::int64_t next = 0;
  for (Node* node : {&second, &first}) {
    SCOPED_TRACE(node == &second ? "the other node on the connection" : "the same node");
    nested = node;
    seen.clear();
    for (int i = 0; i < kCount; ++i) {
      odometry_t odo{};
      odo.header.utime = clock.now();
      ASSERT_TRUE(sender.publish(channels::kOdometry, odo));
    }
    // A datagram is queued on every socket of the bus in one pass.
    spinUntil({&seer}, [&] { return seen_by_seer >= next + kCount - 1; });
    ASSERT_EQ(seen_by_seer, next + kCount - 1);
    first.handleDeferred();
    std::vector<std::int64_t> expected(kCount);
    std::iota(expected.begin(), expected.end(), next);
    EXPECT_EQ(seen, expected);
    next += kCount;
  }
}

// Review 14, L10: the guard of the deferred reads is also the node's. A handleDeferred() from
// inside one of the node's deferred handlers reads nothing of any bus: no handler of another bus
// runs inside it. (With the receiver's guard alone, the nested call read the other bus's
// deferred socket and ran its handlers inside the first bus's handler.)
TEST_F(UdpmBus, ANestedDeferredReadRunsNoHandlerOfAnotherBus) {
  static constexpr const char* kOtherUrl = "udpm://239.255.76.67:7802?ttl=0&recv_buf_size=4194304";
  Node sender{{.process = "sender", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node other_sender{
      {.process = "other_sender", .robot_id = 1, .url = kOtherUrl, .status_period_us = 0}, clock};
  Node seer{{.process = "seer", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  const BusId seer_other = seer.addBus(kOtherUrl);
  Node node{{.process = "node", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  const BusId other = node.addBus(kOtherUrl);
  std::int64_t seen_by_seer = -1, seen_by_seer_other = -1;
  seer.subscribe(channels::kOdometry, [&](const odometry_t& m) { seen_by_seer = m.header.seq; });
  seer.subscribe(
      channels::kOdometry, [&](const odometry_t& m) { seen_by_seer_other = m.header.seq; },
      seer_other);
  std::vector<std::string> order;
  bool inside = false;
  node.subscribeDeferred(channels::kOdometry, [&](const odometry_t& m) {
    order.push_back("first " + std::to_string(m.header.seq));
    inside = true;
    node.handleDeferred();
    inside = false;
  });
  int nested_runs = 0;
  node.subscribeDeferred(
      channels::kOdometry,
      [&](const odometry_t& m) {
        if (inside) ++nested_runs;
        order.push_back("other " + std::to_string(m.header.seq));
      },
      other);
  constexpr int kCount = 3;
  for (int i = 0; i < kCount; ++i) {
    odometry_t odo{};
    odo.header.utime = clock.now();
    ASSERT_TRUE(sender.publish(channels::kOdometry, odo));
    ASSERT_TRUE(other_sender.publish(channels::kOdometry, odo));
  }
  // A datagram is queued on every socket of the bus in one pass.
  spinUntil({&seer},
            [&] { return seen_by_seer == kCount - 1 && seen_by_seer_other == kCount - 1; });
  ASSERT_EQ(seen_by_seer_other, kCount - 1);
  node.handleDeferred();
  EXPECT_EQ(nested_runs, 0);
  EXPECT_EQ(order, (std::vector<std::string>{"first 0", "first 1", "first 2", "other 0", "other 1",
                                             "other 2"}));
}

TEST_F(UdpmBus, WhatLcmItselfPublishesArrivesAndWhatTheNodePublishesLcmReads) {
  Node node{{.process = "node", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  std::vector<std::int64_t> frames;
  node.subscribe(channels::kCameraImage,
                 [&](const image_t& m) { frames.push_back(m.frame_number); });
  // A plain LCM program on the same bus, with LCM's own receive thread.
  PlainLcmPeer plain(kUrl);
  plain.count("CAMERA_IMAGE");
  image_t frame = image(3);
  frame.header.utime = clock.now();
  frame.header.utime_published = clock.now();
  frame.header.robot_id = 1;
  frame.header.publisher_id = 99;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(frame.getEncodedSize()));
  ASSERT_EQ(frame.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  ASSERT_TRUE(plain.publish("CAMERA_IMAGE", bytes));
  spinUntil({&node}, [&] { return !frames.empty(); });
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0], 3);
  // And the node's own publication reaches LCM's receive thread (the wire is LCM's).
  image_t again = image(4);
  again.header.utime = clock.now();
  ASSERT_TRUE(node.publish(channels::kCameraImage, again));
  for (int i = 0; i < 200 && plain.received() < 2; ++i)
    plain.handle(10);
  EXPECT_EQ(plain.received(), 2);  // LCM's own and the node's
}

// Issue 32: a process reading VISION_LINES (fusion, feature recognition) does not wake for the
// camera's image fragments. A VISION_LINES message of several datagrams from a sender it knows
// still arrives whole; from a sender not seen before it is refused and counted (never lost
// unseen), and that sender's next one arrives whole.
TEST_F(UdpmBus, LaterFragmentsOnlyFromTheSendersOfWhatAProcessReads) {
  Node camera{{.process = "camera", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node tracker{{.process = "tracker", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node other{{.process = "other", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  Node fusion{{.process = "fusion", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  std::vector<line_contours_t> got;
  fusion.subscribe(channels::kVisionLines, [&](const line_contours_t& m) { got.push_back(m); });
  const auto lines = [&](int n) {
    line_contours_t m{};
    m.header.utime = clock.now();
    m.num_points = n;
    for (int i = 0; i < n; ++i) {
      m.u.push_back(static_cast<float>(i));
      m.v.push_back(static_cast<float>(n - i));
      m.x.push_back(0.001f * static_cast<float>(i));
      m.y.push_back(-0.002f * static_cast<float>(i));
    }
    m.image_width = 320;
    m.image_height = 240;
    return m;
  };
  // 5000 points: 80 KB, two datagrams.
  constexpr int kBig = 5000;
  // The tracker's first lines fit one datagram: fusion learns its port.
  auto small = lines(100);
  ASSERT_TRUE(tracker.publish(channels::kVisionLines, small));
  spinUntil({&fusion}, [&] { return got.size() == 1; });
  ASSERT_EQ(got.size(), 1u);
  for (int i = 0; i < 3; ++i) {
    image_t frame = image(i);
    frame.header.utime = clock.now();
    ASSERT_TRUE(camera.publish(channels::kCameraImage, frame));
  }
  auto big = lines(kBig);
  ASSERT_TRUE(tracker.publish(channels::kVisionLines, big));
  spinUntil({&fusion}, [&] { return got.size() == 2; });
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[1].num_points, kBig);
  EXPECT_TRUE(got[1].u == big.u && got[1].y == big.y);
  // One short message and the big one's two fragments; none of the images' nine.
  EXPECT_EQ(fusion.busDatagrams(), 3);
  EXPECT_EQ(fusion.status().errorCount("bus_incomplete"), 0);
  // A sender not seen before whose first lines take two datagrams: refused and counted.
  auto first = lines(kBig);
  ASSERT_TRUE(other.publish(channels::kVisionLines, first));
  spinUntil({&fusion}, [&] { return fusion.status().errorCount("bus_incomplete") > 0; });
  EXPECT_EQ(fusion.status().errorCount("bus_incomplete"), 1);
  EXPECT_EQ(got.size(), 2u);
  // Its next ones arrive whole.
  auto next = lines(kBig + 1);
  ASSERT_TRUE(other.publish(channels::kVisionLines, next));
  spinUntil({&fusion}, [&] { return got.size() == 3; });
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[2].num_points, kBig + 1);
  EXPECT_TRUE(got[2].x == next.x);
  EXPECT_EQ(fusion.status().errorCount("bus_incomplete"), 1);
}

// A UDP socket that sends to the bus of UdpmBus (an ephemeral port of its own: one sender).
class RawSender {
 public:
  RawSender() : fd_(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0)) {
    sockaddr_in any{};
    any.sin_family = AF_INET;
    EXPECT_EQ(::bind(fd_, reinterpret_cast<const sockaddr*>(&any), sizeof any), 0);
    socklen_t len = sizeof any;
    EXPECT_EQ(::getsockname(fd_, reinterpret_cast<sockaddr*>(&any), &len), 0);
    port_ = ntohs(any.sin_port);
  }
  ~RawSender() { ::close(fd_); }
  RawSender(const RawSender&) = delete;
  RawSender& operator=(const RawSender&) = delete;
  void send(const Bytes& d) const {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(7801);
    inet_aton("239.255.76.67", &to.sin_addr);
    EXPECT_EQ(
        ::sendto(fd_, d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to),
        static_cast<ssize_t>(d.size()));
  }
  std::uint16_t port() const { return port_; }

 private:
  int fd_;
  std::uint16_t port_ = 0;
};

// A receiver reading VISION_LINES, and what it handed on and reported.
struct Reader {
  Reader() : receiver(*parseUdpmUrl("udpm://239.255.76.67:7801?recv_buf_size=4194304")) {
    receiver.setChannels({"VISION_LINES", "ODOMETRY"}, false);
  }
  void receive(std::int64_t now_us) {
    receiver.receive(
        64, now_us,
        [&](std::string_view channel, const void*, int size) {
          messages.emplace_back(channel, size);
          if (on_message) on_message();
        },
        [&](const char* kind, const std::string& text) { problems.emplace_back(kind, text); });
  }
  int count(const std::string& kind) const {
    return static_cast<int>(std::count_if(problems.begin(), problems.end(),
                                          [&](const auto& p) { return p.first == kind; }));
  }
  UdpmReceiver receiver;
  std::vector<std::pair<std::string, int>> messages;
  std::vector<std::pair<std::string, std::string>> problems;
  std::function<void()> on_message;
};

// Review of issue 32 (1a): a sender's short lines, then fragmented ones, before the reader reads:
// the kernel dropped the later fragments (the sender was not known yet) and the first one waits
// in the assembler. The sender's next short message gives it up: counted, not lost unseen.
TEST_F(UdpmBus, AMessageWhoseLaterFragmentsWereDroppedIsCountedAtTheSendersNext) {
  Reader reader;
  RawSender s;
  s.send(shortDatagram("VISION_LINES", pattern(100), 1));
  for (const Bytes& d : fragments("VISION_LINES", pattern(3'000), 2))
    s.send(d);
  reader.receive(0);
  EXPECT_EQ(reader.messages.size(), 1u);
  EXPECT_EQ(reader.count("bus_incomplete"), 0);
  s.send(shortDatagram("VISION_LINES", pattern(100), 3));
  reader.receive(1000);
  EXPECT_EQ(reader.messages.size(), 2u);
  ASSERT_EQ(reader.count("bus_incomplete"), 1);
  EXPECT_NE(reader.problems[0].second.find("VISION_LINES"), std::string::npos);
  // The sender's next fragmented lines arrive whole.
  for (const Bytes& d : fragments("VISION_LINES", pattern(3'000), 4))
    s.send(d);
  reader.receive(2000);
  ASSERT_EQ(reader.messages.size(), 3u);
  EXPECT_EQ(reader.messages[2].second, 3'000);
  EXPECT_EQ(reader.count("bus_incomplete"), 1);
}

// Review of issue 32 (1b): a sender forgotten (to make room for others) while its message is
// half received: that message is given up and counted, not left waiting forever.
TEST_F(UdpmBus, ASenderForgottenWithAHalfMessageHasItCounted) {
  Reader reader;
  RawSender s;
  s.send(shortDatagram("VISION_LINES", pattern(100), 1));
  reader.receive(0);
  const auto half = fragments("VISION_LINES", pattern(3'000), 2);
  s.send(half[0]);
  reader.receive(1000);
  EXPECT_EQ(reader.count("bus_incomplete"), 0);
  std::vector<std::unique_ptr<RawSender>> others;
  for (std::size_t i = 0; i < UdpmReceiver::kMaxFragmentSenders; ++i) {
    others.push_back(std::make_unique<RawSender>());
    others.back()->send(shortDatagram("VISION_LINES", pattern(100), 1));
    reader.receive(2000 + static_cast<std::int64_t>(i));
  }
  const auto& known = reader.receiver.fragmentSenders();
  EXPECT_TRUE(std::find(known.begin(), known.end(), s.port()) == known.end());
  ASSERT_EQ(reader.count("bus_incomplete"), 1);
  EXPECT_NE(reader.problems[0].second.find("VISION_LINES"), std::string::npos);
}

// Review of issue 32 (2): a publisher that keeps publishing stays known while eight others
// restart (a new port each): its fragmented lines still arrive whole.
TEST_F(UdpmBus, ALongLivedSenderStaysKnownWhileOthersRestart) {
  Reader reader;
  RawSender s;
  std::int64_t now = 0;
  s.send(shortDatagram("VISION_LINES", pattern(100), 1));
  reader.receive(now);
  for (std::size_t restart = 0; restart < UdpmReceiver::kMaxFragmentSenders; ++restart) {
    RawSender other;
    other.send(shortDatagram("VISION_LINES", pattern(100), 1));
    s.send(shortDatagram("ODOMETRY", pattern(10), static_cast<std::uint32_t>(2 + restart)));
    reader.receive(now += 1000);
  }
  for (const Bytes& d : fragments("VISION_LINES", pattern(3'000), 20))
    s.send(d);
  reader.receive(now += 1000);
  ASSERT_FALSE(reader.messages.empty());
  EXPECT_EQ(reader.messages.back().second, 3'000);
  EXPECT_EQ(reader.count("bus_incomplete"), 0);
  // Eleven seconds later, only it is still known.
  for (int i = 0; i < 11; ++i) {
    s.send(shortDatagram("ODOMETRY", pattern(10), static_cast<std::uint32_t>(30 + i)));
    reader.receive(now += 1'000'000);
  }
  EXPECT_EQ(reader.receiver.fragmentSenders(), std::vector<std::uint16_t>{s.port()});
}

// Review of issue 32 (3): the kernel refusing the filter for a new sender is reported and the
// receive path keeps going (the rest of the batch is handled); the port stays unknown.
TEST_F(UdpmBus, AFilterTheKernelRefusesIsReportedAndTheBatchGoesOn) {
  Reader reader;
  RawSender one, two, three;
  one.send(shortDatagram("VISION_LINES", pattern(100), 1));
  two.send(shortDatagram("VISION_LINES", pattern(100), 1));
  three.send(shortDatagram("ODOMETRY", pattern(10), 1));
  // After the first message the socket's descriptor is no socket: setsockopt fails (ENOTSOCK).
  const int null = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  ASSERT_GE(null, 0);
  reader.on_message = [&] {
    if (reader.messages.size() == 1) {
      ASSERT_GE(::dup2(null, reader.receiver.fd()), 0);
    }
  };
  EXPECT_NO_THROW(reader.receive(0));
  ::close(null);
  EXPECT_EQ(reader.messages.size(), 3u);
  EXPECT_EQ(reader.count("bus_datagram"), 1);
  EXPECT_EQ(reader.receiver.fragmentSenders(), std::vector<std::uint16_t>{one.port()});
}

TEST_F(UdpmBus, GarbageOnASubscribedChannelIsCountedNotHandled) {
  Node node{{.process = "node", .robot_id = 1, .url = kUrl, .status_period_us = 0}, clock};
  int handled = 0;
  node.subscribe(channels::kOdometry, [&](const odometry_t&) { ++handled; });
  PlainLcmPeer plain(kUrl);
  ASSERT_TRUE(plain.publish("ODOMETRY", {1, 2, 3, 4, 5}));
  spinUntil({&node}, [&] { return node.status().errorCount("decode") > 0; });
  EXPECT_EQ(handled, 0);
  EXPECT_EQ(node.status().errorCount("decode"), 1);
}

}  // namespace udpm_test
}  // namespace fieldline::bus
