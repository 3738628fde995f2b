#include "tools/recording/bus_recording.hpp"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "common/bus/channels.hpp"
#include "common/bus/checked_decode.hpp"

namespace fieldline::recording {

namespace {
// LCM's event framing around the data: sync word, event number, time, two lengths.
constexpr std::int64_t kEventOverhead = 28;
// Messages kept for the clock check (about 20 s of a robot's bus without images).
constexpr std::size_t kObservedSamples = 4000;
}  // namespace

std::string partFileName(const std::string& name, int index) {
  return index == 0 ? name + ".lcm" : fmt::format("{}_part{:03d}.lcm", name, index + 1);
}

BusRecording::BusRecording(std::string dir, std::string name, recording_info_t info,
                           BusRecordingOptions options)
    : dir_(std::move(dir)),
      name_(std::move(name)),
      info_(std::move(info)),
      options_(std::move(options)),
      clock_{info_.clock_offset_us, info_.clock_drift_ppm, info_.clock_reference_us} {
  info_.format_version = recording_info_t::FORMAT_VERSION;
  info_.channels = options_.channels;
  info_.num_channels = static_cast<std::int32_t>(info_.channels.size());
  info_.image_every = options_.image_every;
  info_.max_file_bytes = options_.max_file_bytes;
  info_.header.robot_id = info_.bus_robot_id;
  std::filesystem::create_directories(dir_);
  startFile(0);
}

bool BusRecording::recorded(std::string_view channel) const {
  if (channel == bus::channels::kCameraImage.name && options_.image_every <= 0) return false;
  return options_.channels.empty() || std::find(options_.channels.begin(), options_.channels.end(),
                                                channel) != options_.channels.end();
}

void BusRecording::startFile(Utime log_time) {
  if (writer_) writer_->flush();
  ++file_index_;
  path_ = dir_ + "/" + partFileName(name_, file_index_);
  writer_ = std::make_unique<bus::LogWriter>(path_);
  files_.push_back(path_);
  while (options_.max_files > 0 && static_cast<int>(files_.size()) > options_.max_files) {
    std::error_code ec;
    std::filesystem::remove(files_.front(), ec);
    files_.pop_front();
  }
  file_bytes_ = 0;
  info_.file_index = file_index_;
  if (log_time > 0) writeInfo(log_time);
}

void BusRecording::writeInfo(Utime log_time) {
  // Stamped on the robot's clock, as the model reads the log time: every reader's stamp checks
  // pass it.
  info_.header.utime = truthToOwn(clock_, log_time);
  info_.header.utime_published = info_.header.utime;
  if (observed_) {
    info_.clock_observed_offset_us = observed_->ownAt(observed_at_) - observed_at_;
    info_.clock_observed_messages = static_cast<std::int32_t>(observed_->samples);
  }
  writer_->write(bus::channels::kRecordingInfo, log_time, info_);
  ++info_.header.seq;
  file_bytes_ += infoBytes();
  next_info_ = log_time + static_cast<Utime>(options_.info_period_s * 1e6);
}

std::int64_t BusRecording::infoBytes() const {
  return kEventOverhead + static_cast<std::int64_t>(bus::channels::kRecordingInfo.name.size()) +
         info_.getEncodedSize();
}

void BusRecording::observe(Utime log_time, const void* data, int size) {
  const auto header = peekHeader(data, size);
  if (!header || header->robot_id != info_.bus_robot_id) return;
  recent_.push_back({log_time, header->utime_published});
  if (recent_.size() >= kObservedSamples) {
    observed_ = fitClock(recent_);
    observed_at_ = log_time;
    recent_.erase(recent_.begin(), recent_.begin() + kObservedSamples / 2);
  } else if (recent_.size() % (observed_ ? 500 : 200) == 0) {
    observed_ = fitClock(recent_);
    observed_at_ = log_time;
  }
}

void BusRecording::write(std::string_view channel, Utime log_time, const void* data, int size) {
  // LCM's own probe of a new connection: not traffic.
  if (channel == "LCM_SELF_TEST" || !recorded(channel)) return;
  if (channel == bus::channels::kCameraImage.name) {
    const auto header = peekHeader(data, size);
    const std::int64_t n = images_seen_[header ? header->publisher_id : 0]++;
    if (n % options_.image_every != 0) {
      ++images_skipped_;
      return;
    }
  }
  if (auto rejection = bus::checkEncoded(channel, data, size, truthToOwn(clock_, log_time),
                                         500 * kMicrosPerMilli)) {
    ++refused_[rejection->kind];
    last_refusal_ = fmt::format("{}: {}", channel, rejection->text);
    return;
  }
  const std::int64_t bytes = kEventOverhead + static_cast<std::int64_t>(channel.size()) + size;
  const bool info_due = file_bytes_ == 0 || log_time >= next_info_;
  const std::int64_t info_bytes = info_due ? infoBytes() : 0;
  if (options_.max_file_bytes > 0 && file_bytes_ > 0 &&
      file_bytes_ + info_bytes + bytes > options_.max_file_bytes) {
    startFile(log_time);  // which starts with the description
  } else if (info_due) {
    writeInfo(log_time);
  }
  writer_->write(channel, log_time, data, size);
  file_bytes_ += bytes;
  bytes_total_ += bytes;
  ++events_written_;
  observe(log_time, data, size);
}

void BusRecording::flush() {
  if (writer_) writer_->flush();
}

}  // namespace fieldline::recording
