#include "services/camera/realism.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fieldline::camera {
namespace {

std::uint8_t toByte(float x) {
  return static_cast<std::uint8_t>(std::clamp(x + 0.5f, 0.0f, 255.0f));
}

std::uint64_t mix(std::uint32_t seed, std::uint64_t frame) {
  std::uint64_t h = (frame + 0x51ED27ull) * 0x9E3779B97F4A7C15ull ^ (std::uint64_t{seed} << 21);
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 29;
  return h == 0 ? 0x2545F4914F6CDD1Dull : h;
}

void check(const RealismParams& p) {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("realism: ") + what);
  };
  require(p.light_factor > 0.0 && p.light_factor <= 10.0, "light_factor must be in (0, 10]");
  require(p.light_gradient >= 0.0 && p.light_gradient < 1.0, "light_gradient must be in [0, 1)");
  require(std::isfinite(p.light_gradient_angle), "light_gradient_angle must be finite");
  require(p.vignetting >= 0.0 && p.vignetting < 1.0, "vignetting must be in [0, 1)");
  require(p.saturation >= 0.0 && p.saturation <= 3.0, "saturation must be in [0, 3]");
  require(std::abs(p.chroma_shift[0]) <= 128.0 && std::abs(p.chroma_shift[1]) <= 128.0,
          "chroma_shift must be within +-128");
  require(p.blur_sigma >= 0.0 && p.blur_sigma <= 10.0, "blur_sigma must be in [0, 10] px");
  require(p.shot_noise >= 0.0 && p.shot_noise <= 100.0, "shot_noise must be in [0, 100]");
}

// Separable Gaussian blur of one plane (edges clamped).
void blurPlane(std::vector<float>& plane, std::vector<float>& tmp, int w, int h,
               const std::vector<float>& kernel) {
  const int r = static_cast<int>(kernel.size()) / 2;
  tmp.resize(plane.size());
  for (int v = 0; v < h; ++v) {
    const float* src = plane.data() + static_cast<std::size_t>(v) * w;
    float* dst = tmp.data() + static_cast<std::size_t>(v) * w;
    for (int u = 0; u < w; ++u) {
      float s = 0.0f;
      for (int k = -r; k <= r; ++k)
        s += kernel[k + r] * src[std::clamp(u + k, 0, w - 1)];
      dst[u] = s;
    }
  }
  for (int v = 0; v < h; ++v) {
    float* dst = plane.data() + static_cast<std::size_t>(v) * w;
    for (int u = 0; u < w; ++u) {
      float s = 0.0f;
      for (int k = -r; k <= r; ++k) {
        s += kernel[k + r] * tmp[static_cast<std::size_t>(std::clamp(v + k, 0, h - 1)) * w + u];
      }
      dst[u] = s;
    }
  }
}

}  // namespace

RealismParams loadRealismParams(const config::Node& n) {
  RealismParams p;
  p.light_factor = n.getOr<double>("light_factor", 1.0, 0.01, 10.0);
  p.light_gradient = n.getOr<double>("light_gradient", 0.0, 0.0, 0.99);
  p.light_gradient_angle = n.getOr<double>("light_gradient_angle", 0.0, -10.0, 10.0);
  p.vignetting = n.getOr<double>("vignetting", 0.0, 0.0, 0.99);
  p.saturation = n.getOr<double>("saturation", 1.0, 0.0, 3.0);
  if (n.has("chroma_shift")) {
    const std::vector<double> s = n.getList<double>("chroma_shift", 2);
    if (std::abs(s[0]) > 128.0 || std::abs(s[1]) > 128.0) {
      n.fail("chroma_shift", "components must be within +-128");
    }
    p.chroma_shift = {s[0], s[1]};
  }
  p.blur_sigma = n.getOr<double>("blur_sigma", 0.0, 0.0, 10.0);
  p.shot_noise = n.getOr<double>("shot_noise", 0.0, 0.0, 100.0);
  p.seed = static_cast<std::uint32_t>(n.getOr<int>("seed", 1, 0, 1 << 30));
  n.rejectUnknownKeys();
  return p;
}

RealismFilter::RealismFilter(const RealismParams& params, const MirrorModel& mirror)
    : width_(mirror.width()),
      height_(mirror.height()),
      centre_(mirror.params().centre),
      radius_(mirror.params().outer_radius) {
  setParams(params);
}

void RealismFilter::setParams(const RealismParams& params) {
  check(params);
  params_ = params;
  buildGain();
  kernel_.clear();
  if (params_.blur_sigma > 0.0) {
    const int r = std::max(1, static_cast<int>(std::ceil(3.0 * params_.blur_sigma)));
    double sum = 0.0;
    for (int k = -r; k <= r; ++k) {
      const double g = std::exp(-0.5 * k * k / (params_.blur_sigma * params_.blur_sigma));
      kernel_.push_back(static_cast<float>(g));
      sum += g;
    }
    for (float& k : kernel_)
      k = static_cast<float>(k / sum);
  }
}

void RealismFilter::buildGain() {
  gain_.assign(static_cast<std::size_t>(width_) * height_, 1.0f);
  const Vec2 dir{std::cos(params_.light_gradient_angle), std::sin(params_.light_gradient_angle)};
  for (int v = 0; v < height_; ++v) {
    for (int u = 0; u < width_; ++u) {
      const Vec2 d = Vec2(u, v) - centre_;
      const double rel = d.norm() / radius_;
      const double g = params_.light_factor *
                       (1.0 + params_.light_gradient * d.dot(dir) / radius_) *
                       (1.0 - params_.vignetting * rel * rel);
      gain_[static_cast<std::size_t>(v) * width_ + u] = static_cast<float>(std::max(0.0, g));
    }
  }
}

void RealismFilter::apply(std::vector<Yuv>& frame, std::uint64_t frame_number) {
  if (!enabled()) return;
  const std::size_t n = static_cast<std::size_t>(width_) * height_;
  if (frame.size() != n) throw std::invalid_argument("realism: frame of another size");
  for (auto& p : planes_)
    p.resize(n);
  const auto sat = static_cast<float>(params_.saturation);
  const auto su = static_cast<float>(params_.chroma_shift[0]);
  const auto sv = static_cast<float>(params_.chroma_shift[1]);
  for (std::size_t i = 0; i < n; ++i) {
    const float g = gain_[i];
    planes_[0][i] = frame[i].y * g;
    planes_[1][i] = 128.0f + (frame[i].u - 128.0f) * g * sat + su;
    planes_[2][i] = 128.0f + (frame[i].v - 128.0f) * g * sat + sv;
  }
  if (!kernel_.empty()) {
    for (auto& p : planes_)
      blurPlane(p, scratch_, width_, height_, kernel_);
  }
  if (params_.shot_noise > 0.0) {
    std::uint64_t state = mix(params_.seed, frame_number);
    auto next = [&state] {
      state ^= state << 13;
      state ^= state >> 7;
      state ^= state << 17;
      return state;
    };
    // Sum of four uniforms (16 bits each): mean 2, variance 4/12; scaled to unit variance.
    auto gauss = [&next] {
      const std::uint64_t r = next();
      const float s = static_cast<float>((r & 0xFFFF) + ((r >> 16) & 0xFFFF) +
                                         ((r >> 32) & 0xFFFF) + (r >> 48)) /
                      65536.0f;
      return (s - 2.0f) * 1.7320508f;
    };
    const auto scale = static_cast<float>(params_.shot_noise);
    for (std::size_t i = 0; i < n; ++i) {
      const float sigma = scale * std::sqrt(std::max(planes_[0][i], 0.0f) / 255.0f);
      planes_[0][i] += sigma * gauss();
      planes_[1][i] += 0.5f * sigma * gauss();
      planes_[2][i] += 0.5f * sigma * gauss();
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    frame[i] = {toByte(planes_[0][i]), toByte(planes_[1][i]), toByte(planes_[2][i])};
  }
}

}  // namespace fieldline::camera
