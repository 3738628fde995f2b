// Camera frames travel on a bus of their own.
//
// CAMERA_IMAGE (150 KB at 320x240, 30 Hz) goes out on a sibling of its robot bus: the same udpm
// group and options at port + kFramesPortOffset. LCM's udpm transport has every socket bound to
// a port receive and reassemble every message sent there before it looks at the channel, so
// frames on the robot bus cost each of the robot's processes (pilot, motor bridge, fusion, team
// link...) a copy of 4.6 MB/s that it then drops. On their own port only their readers (region
// tracking, the viewer, recorders) get them. bus::Node routes the channel there by itself
// (publish, publishEncoded, subscribe, and subscribeAllRaw listens on both), so no process names
// this bus; lcm-spy on a robot's bus does not show CAMERA_IMAGE (give it the frames bus's URL).
#pragma once

#include <string>
#include <string_view>

namespace fieldline::bus {

inline constexpr int kFramesPortOffset = 200;

// True for the channels that travel on the frames bus (CAMERA_IMAGE).
bool travelsOnFramesBus(std::string_view channel);

// The frames bus of `url`: a udpm URL with its port + kFramesPortOffset (LCM's default port 7667
// when it names none), the same group and options. Other URLs (memq://) come back unchanged:
// frames share the bus there.
std::string framesBusUrl(const std::string& url);

}  // namespace fieldline::bus
