#include "services/camera/sources.hpp"
#include "services/camera/sources_y4m.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "common/camera/image_header.hpp"

namespace fieldline::camera {
namespace {

// Copies a BGR or raw YUYV cv::Mat into `out` row by row (no colour conversion).
bool copyFrame(const cv::Mat& mat, PixelFormat format, int width, int height, SourceFrame& out) {
  const int row_bytes = FrameView::minStride(width, format);
  if (static_cast<std::size_t>(row_bytes) * height != mat.total() * mat.elemSize()) return false;
  out.width = width;
  out.height = height;
  out.stride = row_bytes;
  out.format = format;
  out.bytes.resize(static_cast<std::size_t>(row_bytes) * height);
  if (mat.isContinuous()) {
    std::memcpy(out.bytes.data(), mat.data, out.bytes.size());
  } else {
    // Non-continuous mats have one image row per mat row.
    for (int v = 0; v < height; ++v) {
      std::memcpy(out.bytes.data() + static_cast<std::size_t>(v) * row_bytes, mat.ptr(v),
                  static_cast<std::size_t>(row_bytes));
    }
  }
  return true;
}

class VideoCaptureSource final : public FrameSource {
 public:
  VideoCaptureSource(SourceKind kind, const VideoCaptureOptions& options)
      : kind_(kind), options_(options) {
    bool opened = false;
    if (kind == SourceKind::kV4l2) {
      const bool is_index = !options.spec.empty() &&
                            std::all_of(options.spec.begin(), options.spec.end(),
                                        [](unsigned char c) { return std::isdigit(c) != 0; });
      opened = is_index ? capture_.open(std::stoi(options.spec), cv::CAP_V4L2)
                        : capture_.open(options.spec, cv::CAP_V4L2);
      if (opened) {
        if (options.raw_yuyv) {
          capture_.set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc('Y', 'U', 'Y', 'V'));
        }
        if (options.width > 0) capture_.set(cv::CAP_PROP_FRAME_WIDTH, options.width);
        if (options.height > 0) capture_.set(cv::CAP_PROP_FRAME_HEIGHT, options.height);
        if (options.fps > 0.0) capture_.set(cv::CAP_PROP_FPS, options.fps);
        if (options.raw_yuyv) raw_ = capture_.set(cv::CAP_PROP_CONVERT_RGB, 0.0);
      }
    } else if (kind == SourceKind::kGstreamer) {
      opened = capture_.open(options.spec, cv::CAP_GSTREAMER);
    } else if (kind == SourceKind::kVideo) {
      opened = capture_.open(options.spec, cv::CAP_ANY);
    } else {
      throw std::invalid_argument("openVideoCapture: not a VideoCapture source kind");
    }
    if (!opened || !capture_.isOpened()) {
      throw std::runtime_error(
          fmt::format("cannot open {} source '{}'", sourceKindName(kind), options.spec));
    }
    // A video's frame size is known from its container before a frame is decoded.
    const auto width = static_cast<std::int64_t>(capture_.get(cv::CAP_PROP_FRAME_WIDTH));
    const auto height = static_cast<std::int64_t>(capture_.get(cv::CAP_PROP_FRAME_HEIGHT));
    if (width > kMaxImageSide || height > kMaxImageSide || width * height > kMaxImagePixels) {
      throw std::runtime_error(fmt::format(
          "{} source '{}' has frames of {} x {} pixels, more than any camera frame (at most {} a "
          "side and {} pixels)",
          sourceKindName(kind), options.spec, width, height, kMaxImageSide, kMaxImagePixels));
    }
  }

  bool next(SourceFrame& out) override {
    for (int attempt = 0; attempt < 100; ++attempt) {
      if (!capture_.read(mat_) || mat_.empty()) {
        if (kind_ == SourceKind::kVideo && options_.loop && delivered_ > 0 && attempt == 0) {
          capture_.set(cv::CAP_PROP_POS_FRAMES, 0);
          continue;
        }
        return false;
      }
      const int width = static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_WIDTH));
      const int height = static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_HEIGHT));
      bool ok = false;
      if (mat_.type() == CV_8UC3) {
        ok = copyFrame(mat_, PixelFormat::kBgr, mat_.cols, mat_.rows, out);
      } else if (raw_ && mat_.depth() == CV_8U && width > 0 && width % 2 == 0 && height > 0) {
        // Raw driver buffer: YUYV bytes in a 1-row or 2-channel mat.
        ok = copyFrame(mat_, PixelFormat::kYuyv, width, height, out);
      }
      if (!ok) {
        countError(fmt::format("frame of unexpected layout (type {}, {}x{})", mat_.type(),
                               mat_.cols, mat_.rows));
        continue;
      }
      out.frame_number = delivered_++;
      return true;
    }
    return false;
  }

  SourceKind kind() const override { return kind_; }
  std::string describe() const override {
    return fmt::format("{} '{}' {}x{}{}", sourceKindName(kind_), options_.spec,
                       capture_.get(cv::CAP_PROP_FRAME_WIDTH),
                       capture_.get(cv::CAP_PROP_FRAME_HEIGHT), raw_ ? " raw YUYV" : "");
  }

 private:
  SourceKind kind_;
  VideoCaptureOptions options_;
  cv::VideoCapture capture_;
  cv::Mat mat_;
  bool raw_ = false;
  std::int64_t delivered_ = 0;
};

bool isImageFile(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp";
}

}  // namespace

const char* sourceKindName(SourceKind kind) {
  switch (kind) {
    case SourceKind::kSim:
      return "sim";
    case SourceKind::kV4l2:
      return "v4l2";
    case SourceKind::kVideo:
      return "video";
    case SourceKind::kGstreamer:
      return "gstreamer";
    case SourceKind::kFolder:
      return "folder";
    case SourceKind::kLog:
      return "log";
  }
  return "unknown";
}

bool isNamedPipe(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_fifo(path, ec);
}

std::unique_ptr<FrameSource> openVideoCapture(SourceKind kind, const VideoCaptureOptions& options) {
  // A named pipe where a camera or a video is expected: YUV4MPEG2 frames (sources_y4m.hpp).
  if ((kind == SourceKind::kV4l2 || kind == SourceKind::kVideo) && isNamedPipe(options.spec)) {
    return std::make_unique<Y4mPipeSource>(options.spec);
  }
  return std::make_unique<VideoCaptureSource>(kind, options);
}

ImageFolderSource::ImageFolderSource(const std::string& folder, bool loop)
    : folder_(folder), loop_(loop) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw std::runtime_error("image folder '" + folder + "' does not exist");
  }
  for (const fs::directory_entry& e : fs::directory_iterator(folder, ec)) {
    if (e.is_regular_file() && isImageFile(e.path())) files_.push_back(e.path().string());
  }
  std::sort(files_.begin(), files_.end());
  if (files_.empty()) {
    throw std::runtime_error("image folder '" + folder + "' holds no PNG, JPEG or BMP file");
  }
}

bool ImageFolderSource::next(SourceFrame& out) {
  // At most one pass over the folder per call: a folder of broken files ends the stream.
  for (std::size_t tried = 0; tried < files_.size(); ++tried) {
    if (position_ == files_.size()) {
      if (!loop_) return false;
      position_ = 0;
    }
    const std::string& path = files_[position_++];
    try {
      checkImageSize(path);  // before decoding: a decompression bomb is refused unread
    } catch (const std::runtime_error& e) {
      countError(e.what());
      continue;
    }
    const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
    if (image.empty() || !copyFrame(image, PixelFormat::kBgr, image.cols, image.rows, out)) {
      countError("cannot read image " + path);
      continue;
    }
    out.frame_number = delivered_++;
    return true;
  }
  return false;
}

std::string ImageFolderSource::describe() const {
  return fmt::format("folder '{}' ({} images{})", folder_, files_.size(), loop_ ? ", looping" : "");
}

}  // namespace fieldline::camera
