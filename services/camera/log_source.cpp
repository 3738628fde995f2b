#include "services/camera/log_source.hpp"

#include <array>
#include <stdexcept>

#include <fmt/core.h>

namespace fieldline::camera {
namespace {

constexpr std::uint32_t kSyncWord = 0xEDA1DA01u;
// Larger events are taken as damage (a 4K BGR frame is 25 MB).
constexpr std::int32_t kMaxEventBytes = 64 * 1024 * 1024;
constexpr std::int32_t kMaxChannelBytes = 256;

std::uint64_t readBigEndian(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i)
    v = (v << 8) | p[i];
  return v;
}

void writeBigEndian(std::ostream& out, std::uint64_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i)
    out.put(static_cast<char>((v >> (8 * i)) & 0xFF));
}

}  // namespace

void appendLogEvent(std::ostream& out, std::int64_t event_number, std::int64_t utime,
                    const std::string& channel, const std::vector<std::uint8_t>& data) {
  writeBigEndian(out, kSyncWord, 4);
  writeBigEndian(out, static_cast<std::uint64_t>(event_number), 8);
  writeBigEndian(out, static_cast<std::uint64_t>(utime), 8);
  writeBigEndian(out, channel.size(), 4);
  writeBigEndian(out, data.size(), 4);
  out.write(channel.data(), static_cast<std::streamsize>(channel.size()));
  out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
}

LogImageSource::LogImageSource(const std::string& path, std::string channel, bool loop)
    : path_(path), channel_(std::move(channel)), loop_(loop), in_(path, std::ios::binary) {
  if (!in_) throw std::runtime_error("cannot open LCM log '" + path + "'");
}

bool LogImageSource::readEvent() {
  std::array<std::uint8_t, 28> head{};
  while (true) {
    // Find the sync word byte by byte (the file may be damaged or start mid-event).
    std::uint32_t window = 0;
    int seen = 0;
    char c = 0;
    do {
      if (!in_.get(c)) return false;
      window = (window << 8) | static_cast<std::uint8_t>(c);
      ++seen;
    } while (seen < 4 || window != kSyncWord);
    if (seen > 4) countError("damaged LCM log: skipped " + std::to_string(seen - 4) + " bytes");
    if (!in_.read(reinterpret_cast<char*>(head.data() + 4), 24)) return false;
    const auto channel_len = static_cast<std::int32_t>(readBigEndian(head.data() + 20, 4));
    const auto data_len = static_cast<std::int32_t>(readBigEndian(head.data() + 24, 4));
    if (channel_len <= 0 || channel_len > kMaxChannelBytes || data_len < 0 ||
        data_len > kMaxEventBytes) {
      countError(fmt::format("damaged LCM log event (channel {} bytes, data {} bytes)", channel_len,
                             data_len));
      continue;
    }
    event_channel_.resize(static_cast<std::size_t>(channel_len));
    data_.resize(static_cast<std::size_t>(data_len));
    if (!in_.read(event_channel_.data(), channel_len) ||
        !in_.read(reinterpret_cast<char*>(data_.data()), data_len)) {
      return false;
    }
    if (event_channel_ == channel_) return true;
  }
}

bool LogImageSource::next(SourceFrame& out) {
  bool rewound = false;
  while (true) {
    if (!readEvent()) {
      // Loop only if the file held at least one frame, and rewind at most once per call.
      if (!loop_ || delivered_ == 0 || rewound) return false;
      in_.clear();
      in_.seekg(0);
      rewound = true;
      continue;
    }
    const int size = static_cast<int>(data_.size());
    if (image_.decode(data_.data(), 0, size) != size) {
      countError("undecodable image in LCM log");
      continue;
    }
    const bool known =
        image_.format == image_t::FORMAT_YUYV || image_.format == image_t::FORMAT_BGR;
    const PixelFormat format =
        image_.format == image_t::FORMAT_YUYV ? PixelFormat::kYuyv : PixelFormat::kBgr;
    const FrameView view{image_.data.data(), image_.width, image_.height, image_.stride, format};
    if (!known || !view.valid() ||
        image_.data.size() != static_cast<std::size_t>(image_.stride) * image_.height) {
      countError(fmt::format("unusable image in LCM log ({}x{}, format {}, {} bytes)", image_.width,
                             image_.height, image_.format, image_.data.size()));
      continue;
    }
    out.width = image_.width;
    out.height = image_.height;
    out.stride = image_.stride;
    out.format = format;
    out.bytes.swap(image_.data);
    out.frame_number = delivered_++;
    return true;
  }
}

std::string LogImageSource::describe() const {
  return fmt::format("LCM log '{}' channel {}{}", path_, channel_, loop_ ? ", looping" : "");
}

}  // namespace fieldline::camera
