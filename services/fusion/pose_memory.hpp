// Fusion's memory of its pose across a restart of the process. A restarted fusion knows nothing of
// where it was, and the field is point-symmetric: in the opponent's half the start-up prior (own
// half) put it on its twin (docs/faults.md, clock-step fault). The node saves its tracked pose to a
// small text file every few tenths of a second and when it stops; a fusion started again by the
// same supervisor soon after takes that pose as the twin's continuity reference
// (Localizer::resumeFrom). Written atomically (temporary file + rename), like world_sim's snapshot.
//
//   fieldline-fusion-pose 1
//   robot 2
//   field msl
//   supervisor boot <boot id> pid 123 started 456     # who started the process ("-": unknown)
//   saved_steady_us 123456789                         # CLOCK_BOOTTIME when written, us
//   pose x y phi                                      # field frame, m, rad
//   covariance c00 c01 c02 c11 c12 c22                # of (x, y, phi)
//   twin_ambiguous 0                                  # 1: the twin was undecided
//
// The age is measured on the machine's boot-time clock, not the robot clock the bus stamps with:
// a restart after a clock step (NTP, the eval's clockstep fault) must not make a saved pose look
// seconds older or newer than it is. Plain library: no LCM, the clock comes in as an argument.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "common/geometry/geometry.hpp"
#include "common/time/clock.hpp"

namespace fieldline::fusion {

struct SavedPose {
  int robot_id = 0;
  std::string field;
  // The supervisor's identity (supervisorIdentity()); empty when unknown.
  std::string supervisor;
  Utime saved_steady_us = 0;
  geometry::Pose2 pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  bool twin_ambiguous = false;
};

// Text form; decode(encode(x)) keeps every double bit for bit.
std::string encodeSavedPose(const SavedPose& saved);
// Throws std::runtime_error naming the line for text that is not a saved pose, and for a pose or
// covariance that is not finite or a covariance that is not positive definite.
SavedPose decodeSavedPose(const std::string& text);
// Writes `path` atomically; throws std::runtime_error when it cannot.
void writeSavedPoseFile(const std::string& path, const SavedPose& saved);
// The saved pose in `path`; nothing when the file does not exist. Throws std::runtime_error (with
// the path) for a file that cannot be read or parsed.
std::optional<SavedPose> readSavedPoseFile(const std::string& path);

// Why a saved pose must not be resumed, as a counter name, or empty when it may be: another robot
// ("resume_other_robot") or field ("resume_other_field"), another supervisor (a new run or a
// reboot: "resume_new_run"), saved more than `max_age_s` before `steady_now_us`
// ("resume_stale"), or after it ("resume_from_future": a clock that went back, not a restart).
// `age_s` gets the age when it is known.
std::string resumeRefusal(const SavedPose& saved, int robot_id, const std::string& field,
                          const std::string& supervisor, Utime steady_now_us, double max_age_s,
                          double& age_s);

}  // namespace fieldline::fusion
