#include "services/camera/log_source.hpp"

#include <algorithm>

#include <fmt/core.h>

#include "common/bus/log_file.hpp"
#include "common/msg/image.hpp"

namespace fieldline::camera {

struct LogImageSource::Impl {
  bus::LogReader reader;
  image_t image;
  explicit Impl(const std::string& path) : reader(path) {}
};

LogImageSource::LogImageSource(const std::string& path, bool loop)
    : path_(path), loop_(loop), impl_(std::make_unique<Impl>(path)) {}

LogImageSource::~LogImageSource() = default;

void LogImageSource::countRejections() {
  const auto& recent = impl_->reader.recentRejections();
  const std::int64_t total = impl_->reader.rejectedTotal();
  for (; rejections_counted_ < total; ++rejections_counted_) {
    // Name the newest rejection: the reader keeps the last hundred.
    const auto& r = recent.back();
    countError(fmt::format("LCM log '{}': {} ({}) at offset {}", path_, r.reason.text,
                           r.reason.kind, r.offset));
  }
}

bool LogImageSource::next(SourceFrame& out) {
  bool rewound = false;
  while (true) {
    const bool got = impl_->reader.next(bus::channels::kCameraImage, impl_->image);
    countRejections();
    if (!got) {
      // Loop only if the file held at least one frame, and rewind at most once per call.
      if (!loop_ || delivered_ == 0 || rewound) return false;
      impl_->reader.rewind();
      rewound = true;
      if (first_utime_) {
        // The next pass follows this one by a frame period, so stamps never go back.
        const std::int64_t span = last_utime_ - *first_utime_;
        const std::int64_t period =
            delivered_in_pass_ > 1 ? span / (delivered_in_pass_ - 1) : 33'333;
        loop_shift_ += span + std::max<std::int64_t>(1, period);
      }
      first_utime_.reset();
      delivered_in_pass_ = 0;
      continue;
    }
    const image_t& image = impl_->image;
    const std::optional<FrameView> view = msg::fromMessage(image);
    if (!view) {
      // Valid on the bus (e.g. grey) but not a layout the vision reads.
      countError(fmt::format("unusable image in LCM log ({}x{}, format {})", image.width,
                             image.height, image.format));
      continue;
    }
    out.width = view->width;
    out.height = view->height;
    out.stride = view->stride;
    out.format = view->format;
    out.bytes.swap(impl_->image.data);
    out.frame_number = delivered_++;
    if (!first_utime_) first_utime_ = image.header.utime;
    last_utime_ = image.header.utime;
    ++delivered_in_pass_;
    out.recorded_utime = image.header.utime + loop_shift_;
    return true;
  }
}

std::optional<std::int64_t> LogImageSource::firstUtime(const std::string& path) {
  bus::LogReader reader(path);
  image_t image;
  while (reader.next(bus::channels::kCameraImage, image)) {
    if (msg::fromMessage(image)) return image.header.utime;
  }
  return std::nullopt;
}

std::string LogImageSource::describe() const {
  return fmt::format("LCM log '{}' channel {}{}", path_, bus::channels::kCameraImage.name,
                     loop_ ? ", looping" : "");
}

}  // namespace fieldline::camera
