#include "common/bus/log_file.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <numeric>

#include <fmt/format.h>
#include <sys/stat.h>
#include <lcm/lcm-cpp.hpp>

namespace fieldline::bus {
namespace {

// LCM's event framing: sync word, event number (8), log time (8), channel length (4), data
// length (4), all big-endian, then the channel name and the data.
constexpr std::uint32_t kSyncWord = 0xEDA1DA01u;
constexpr int kHeaderBytes = 28;
// LCM itself allows names up to 1000 bytes; ours are short, and a long name is damage.
constexpr std::int32_t kMaxChannelBytes = 256;
constexpr std::size_t kRecentRejections = 100;

std::uint64_t bigEndian(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i)
    v = (v << 8) | p[i];
  return v;
}

bool printable(std::string_view name) {
  for (const char c : name) {
    if (c < 0x21 || c > 0x7e) return false;
  }
  return !name.empty();
}

LogUpgrade& installedUpgrade() {
  static LogUpgrade upgrade;
  return upgrade;
}

}  // namespace

void setLogUpgrade(LogUpgrade upgrade) {
  installedUpgrade() = std::move(upgrade);
}

// ---------------------------------------------------------------------------------------------
namespace {

// A damaged stretch of the file, counted under `kind` ("damaged", "truncated").
struct Damage {
  std::int64_t offset = 0;
  std::string kind;
  std::string text;
};

// What an event's header says about it.
struct EventHeader {
  // Offset of its sync word.
  std::int64_t start = 0;
  std::int64_t number = 0;
  Utime timestamp = 0;
  std::int32_t channel_bytes = 0;
  std::int32_t data_bytes = 0;
  // The offset just past the event, if its lengths are right.
  std::int64_t end() const { return start + kHeaderBytes + channel_bytes + data_bytes; }
};

}  // namespace

struct LogReader::Impl {
  lcm::LogFile file;
  explicit Impl(const std::string& path) : file(path, "r") {}
  FILE* stream() { return file.getFilePtr(); }
  std::int64_t size() {
    struct stat st {};
    return ::fstat(::fileno(stream()), &st) == 0 ? static_cast<std::int64_t>(st.st_size) : 0;
  }

  // Reads on to the next sync word (in an intact log, the next four bytes) and returns the
  // offset of its event; nothing at the end of the file. Bytes passed over on the way go to
  // `skipped`.
  std::optional<std::int64_t> findSyncWord(std::optional<Damage>& skipped) {
    FILE* f = stream();
    const std::int64_t scan_start = ::ftello(f);
    std::uint32_t window = 0;
    std::int64_t scanned = 0;
    int c = 0;
    while ((c = std::fgetc(f)) != EOF) {
      window = (window << 8) | static_cast<std::uint32_t>(c);
      if (++scanned >= 4 && window == kSyncWord) break;
    }
    if (c == EOF) {
      if (scanned > 0) {
        skipped =
            Damage{scan_start, "damaged", fmt::format("{} bytes after the last event", scanned)};
      }
      return std::nullopt;
    }
    const std::int64_t start = scan_start + scanned - 4;
    if (start > scan_start) {
      skipped = Damage{scan_start, "damaged",
                       fmt::format("{} bytes between events skipped at offset {}",
                                   start - scan_start, scan_start)};
    }
    return start;
  }

  // The rest of the header of the event whose sync word is at `start` (just read); nothing
  // when the log ends inside it.
  std::optional<EventHeader> readHeader(std::int64_t start) {
    std::uint8_t head[kHeaderBytes - 4];
    if (std::fread(head, 1, sizeof head, stream()) != sizeof head) return std::nullopt;
    return EventHeader{.start = start,
                       .number = static_cast<std::int64_t>(bigEndian(head, 8)),
                       .timestamp = static_cast<std::int64_t>(bigEndian(head + 8, 8)),
                       .channel_bytes = static_cast<std::int32_t>(bigEndian(head + 16, 4)),
                       .data_bytes = static_cast<std::int32_t>(bigEndian(head + 20, 4))};
  }

  // Why the event's framing cannot be trusted, or nothing. Lengths are checked here, before
  // LCM allocates and reads what they say; LCM refuses an event that is not followed by the
  // next sync word or the end of the file (its length cannot be trusted then), checked here
  // first so that it is counted with a reason.
  std::optional<Damage> framingDamage(const EventHeader& h, std::int32_t max_event_bytes) {
    if (h.channel_bytes <= 0 || h.channel_bytes > kMaxChannelBytes || h.data_bytes < 0 ||
        h.data_bytes > max_event_bytes) {
      return Damage{h.start, "damaged",
                    fmt::format("event at offset {} claims a {}-byte channel name and {} bytes "
                                "of data",
                                h.start, h.channel_bytes, h.data_bytes)};
    }
    if (h.end() > size()) {
      return Damage{h.start, "truncated",
                    fmt::format("event {} at offset {} ends {} bytes beyond the end of the log",
                                h.number, h.start, h.end() - size())};
    }
    if (h.end() < size()) {
      std::uint8_t next_sync[4];
      ::fseeko(stream(), static_cast<off_t>(h.end()), SEEK_SET);
      if (std::fread(next_sync, 1, sizeof next_sync, stream()) != sizeof next_sync ||
          bigEndian(next_sync, 4) != kSyncWord) {
        return Damage{h.start, "damaged",
                      fmt::format("event {} at offset {} is not followed by another event",
                                  h.number, h.start)};
      }
    }
    return std::nullopt;
  }

  // The event at `h.start` as LCM reads it, or null when its channel or data do not match the
  // header.
  const lcm::LogEvent* readEvent(const EventHeader& h) {
    ::fseeko(stream(), static_cast<off_t>(h.start), SEEK_SET);
    const lcm::LogEvent* e = file.readNextEvent();
    if (e == nullptr || !printable(e->channel) || e->datalen != h.data_bytes) return nullptr;
    return e;
  }

  // Goes on searching one byte after the start of a damaged event.
  void resyncAfter(std::int64_t start) {
    ::fseeko(stream(), static_cast<off_t>(start + 1), SEEK_SET);
  }
};

LogReader::LogReader(const std::string& path, LogReaderOptions options)
    : path_(path),
      options_(options),
      impl_(std::make_unique<Impl>(path)),
      upgrade_(installedUpgrade()) {
  if (!impl_->file.good()) {
    throw LogError("cannot open LCM log '" + path + "': " + std::strerror(errno));
  }
}

LogReader::~LogReader() = default;

void LogReader::rewind() {
  std::fseek(impl_->stream(), 0, SEEK_SET);
}

void LogReader::seek(std::int64_t offset) {
  ::fseeko(impl_->stream(), static_cast<off_t>(offset), SEEK_SET);
}

std::int64_t LogReader::rejectedTotal() const {
  return std::accumulate(rejected_by_kind_.begin(), rejected_by_kind_.end(), std::int64_t{0},
                         [](std::int64_t sum, const auto& kv) { return sum + kv.second; });
}

void LogReader::reject(const LogEvent& event, Rejection reason) {
  ++rejected_by_kind_[reason.kind];
  recent_.push_back(LogRejection{event.number, event.offset, event.channel, std::move(reason)});
  if (recent_.size() > kRecentRejections) recent_.pop_front();
}

void LogReader::damage(std::int64_t offset, std::string kind, std::string text) {
  ++rejected_by_kind_[kind];
  recent_.push_back(LogRejection{-1, offset, {}, Rejection{std::move(kind), std::move(text)}});
  if (recent_.size() > kRecentRejections) recent_.pop_front();
}

bool LogReader::nextEvent(LogEvent& event) {
  while (true) {
    std::optional<Damage> skipped;
    const std::optional<std::int64_t> start = impl_->findSyncWord(skipped);
    if (skipped) damage(skipped->offset, std::move(skipped->kind), std::move(skipped->text));
    if (!start) return false;
    const std::optional<EventHeader> header = impl_->readHeader(*start);
    if (!header) {
      damage(*start, "truncated", fmt::format("the log ends inside an event at offset {}", *start));
      return false;
    }
    if (auto bad = impl_->framingDamage(*header, options_.max_event_bytes)) {
      damage(bad->offset, std::move(bad->kind), std::move(bad->text));
      impl_->resyncAfter(header->start);
      continue;
    }
    const lcm::LogEvent* e = impl_->readEvent(*header);
    if (e == nullptr) {
      damage(header->start, "damaged",
             fmt::format("unreadable event {} at offset {}", header->number, header->start));
      impl_->resyncAfter(header->start);
      continue;
    }
    event.number = header->number;
    event.timestamp = header->timestamp;
    event.channel = e->channel;
    const auto* bytes = static_cast<const std::uint8_t*>(e->data);
    event.data.assign(bytes, bytes + e->datalen);
    event.offset = header->start;
    ++events_read_;
    if (upgrade_) {
      if (const auto name = upgrade_(event)) ++upgraded_[*name];
    }
    return true;
  }
}

std::optional<Rejection> LogReader::checkLogStamp(const LogEvent& event) {
  // A log stamp is the recorder's clock when the event arrived: one that is no time at all
  // (before 1970, after 2100) is damage, and would overflow the clock conversions.
  constexpr Utime kLatestPlausibleStamp = 4'102'444'800'000'000;  // 2100-01-01
  if (event.timestamp >= 0 && event.timestamp <= kLatestPlausibleStamp) return std::nullopt;
  return Rejection{"bad_log_stamp",
                   fmt::format("event {} is stamped {} µs, not a time between 1970 and 2100",
                               event.number, event.timestamp)};
}

bool LogReader::accept(const LogEvent& event) {
  if (auto bad = checkLogStamp(event)) {
    reject(event, std::move(*bad));
    return false;
  }
  auto rejection =
      checkEncoded(event.channel, event.data.data(), static_cast<int>(event.data.size()),
                   truthToOwn(options_.clock, event.timestamp), options_.future_tolerance_us);
  if (!rejection) return true;
  reject(event, std::move(*rejection));
  return false;
}

bool LogReader::nextChecked(LogEvent& event) {
  while (nextEvent(event)) {
    if (accept(event)) return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
struct LogWriter::Impl {
  lcm::LogFile file;
  explicit Impl(const std::string& path) : file(path, "w") {}
};

LogWriter::LogWriter(const std::string& path) : path_(path), impl_(std::make_unique<Impl>(path)) {
  if (!impl_->file.good()) {
    throw LogError("cannot create LCM log '" + path + "': " + std::strerror(errno));
  }
}

LogWriter::~LogWriter() = default;

void LogWriter::write(std::string_view channel, Utime timestamp, const void* data, int size) {
  if (channel.empty() || channel.size() > static_cast<std::size_t>(kMaxChannelBytes) || size < 0) {
    throw LogError(fmt::format("{}: refusing an event on '{}' of {} bytes", path_, channel, size));
  }
  lcm::LogEvent event;
  event.eventnum = events_written_;
  event.timestamp = timestamp;
  event.channel = std::string(channel);
  event.datalen = size;
  // LCM's API takes a non-const pointer but only reads from it.
  event.data = const_cast<void*>(data);
  if (impl_->file.writeEvent(&event) != 0) {
    throw LogError(fmt::format("{}: write failed: {}", path_, std::strerror(errno)));
  }
  ++events_written_;
}

void LogWriter::flush() {
  if (std::fflush(impl_->file.getFilePtr()) != 0) {
    throw LogError(fmt::format("{}: flush failed: {}", path_, std::strerror(errno)));
  }
}

}  // namespace fieldline::bus
