// Whether a device or file a process needs is there and usable, checked before anything starts
// (every fieldline executable's --check-args, and so fieldline-launch --dry-run). Each check
// returns "" when the path can be used, else one line naming the path, what is wrong and how to
// fix it:
//
//   /dev/video0: no such device; list cameras with v4l2-ctl --list-devices (package v4l-utils)
//
// Nothing is configured or streamed: a camera is opened only to ask what it is (VIDIOC_QUERYCAP),
// a serial device is not opened at all (opening one resets many controllers through DTR).
#pragma once

#include <string>
#include <vector>

namespace fieldline::device {

// A camera for `fieldline-camera --source v4l2`: a V4L2 video capture device (a path, or an index
// N meaning /dev/videoN), or a named pipe (FIFO) standing in for one (YUV4MPEG2 frames, e.g. the
// rehearsal's renderer). Missing, not readable, a regular file, a V4L2 node that captures no video
// (a UVC camera's metadata node) are problems.
std::string checkCamera(const std::string& path_or_index);

// The motor controller's serial device. Under /dev it must exist, be a character device and be
// readable and writable; elsewhere the path is a link that its creator makes when it starts (the
// simulator's pseudo-terminal, `--pty-dir`): a missing one is not a problem, one that exists is
// checked like a device.
std::string checkSerial(const std::string& path);

// An input file or folder (`what`: "video file", "image folder", "log"): exists, is the right kind
// and readable.
std::string checkInputFile(const std::string& path, const std::string& what, bool folder);

// For --check-args: prints every non-empty problem as "process: problem" on stderr and returns
// 2 when there was one (the exit code of arguments that cannot work), else 0.
int reportProblems(const std::string& process, const std::vector<std::string>& problems);

// The V4L2 device path of `path_or_index`: "2" -> "/dev/video2", a path unchanged.
std::string cameraDevicePath(const std::string& path_or_index);

}  // namespace fieldline::device
