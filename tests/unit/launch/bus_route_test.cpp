// Which interface a bus leaves through (tools/launch/bus_route.hpp). The route of the loopback
// address stands in for a multicast route (the mechanism is the kernel's route lookup either
// way); the laptop namespace test checks a real multicast route to a network card.
#include <gtest/gtest.h>

#include "tools/launch/bus_route.hpp"
#include "tools/launch/launch_file.hpp"

namespace fieldline::launch {
namespace bus_route_test {

TEST(BusRoute, TheKernelsRouteNamesTheInterface) {
  const RouteLookup lo = multicastRoute("127.0.0.1", 7667);
  EXPECT_EQ(lo.interface, "lo") << lo.error;
  EXPECT_NE(multicastRoute("not.an.address", 7667).error.find("not an IPv4 address"),
            std::string::npos);
}

TEST(BusRoute, ARouteElsewhereOrNoSuchInterfaceIsAProblemWithItsFix) {
  bus::BusAddress loopback;
  loopback.group = "127.0.0.1";
  EXPECT_EQ(checkBusRoute(loopback, "lo"), "");
  EXPECT_EQ(checkBusRoute(loopback, ""), "");
  EXPECT_EQ(checkBusRoute(loopback, "nosuch0"),
            "bus.interface nosuch0: no such network interface; list them with ip link");
}

TEST(BusRoute, TheLaunchFileAndTheCommandLineSetTtlAndInterface) {
  const std::string text = R"(defaults:
  bus: {group: 239.255.76.67, base_port: 7667, ttl: 0, interface: wlan0}
processes:
  - {name: a, executable: b, robots: 1}
)";
  const LaunchFile f = parseLaunchFile(config::Node::loadString(text, "robot.yaml"));
  EXPECT_EQ(f.defaults.bus.ttl, 0);
  EXPECT_EQ(f.defaults.bus_interface, "wlan0");
  const LaunchFile watched = parseLaunchFile(config::Node::loadString(text, "robot.yaml"),
                                             {.bus_ttl = 1, .bus_interface = "eth0"});
  EXPECT_EQ(watched.defaults.bus.ttl, 1);
  EXPECT_EQ(watched.defaults.bus_interface, "eth0");
  try {
    parseLaunchFile(config::Node::loadString(text, "robot.yaml"), {.bus_ttl = 300});
    FAIL();
  } catch (const config::Error& e) {
    EXPECT_NE(std::string(e.what()).find("--bus-ttl 300: 0..255"), std::string::npos);
  }
}

}  // namespace bus_route_test
}  // namespace fieldline::launch
