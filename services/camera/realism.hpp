// What real omni-directional frames have and the clean renderer lacks (issue 12, part 7), as a
// post-process on a rendered frame: the light level of the hall, uneven light across the image,
// vignetting, washed-out and shifted colours, blur and signal-dependent sensor noise. Each is a
// knob of the camera preset's `render.realism` section; all off by default (the identity).
//
// Order (as light reaches the sensor): brightness gain per pixel (light factor x gradient x
// vignetting, scaling luma and chroma together as a gain on R, G and B does), then the colour
// (saturation toward grey, then a shift of U and V), then the optics' Gaussian blur, then shot
// noise (standard deviation growing with the square root of the signal). The renderer's own
// Gaussian noise (`noise.luma/chroma`) and the YUYV chroma subsampling come after it.
//
// Deterministic: the noise is seeded by `seed` and the frame number; the same frame twice gives
// the same bytes. No allocation per frame after the first.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "common/camera/frame.hpp"
#include "common/camera/mirror_model.hpp"
#include "common/config/config.hpp"

namespace fieldline::camera {

struct RealismParams {
  // Brightness factor of the whole frame (the hall's light level), 1 = as rendered.
  double light_factor = 1.0;
  // Uneven light: the brightness factor changes linearly across the image, by +-light_gradient
  // at the mirror's outer radius in the direction light_gradient_angle (rad, image angle from +u
  // toward +v) and its opposite.
  double light_gradient = 0.0;
  double light_gradient_angle = 0.0;
  // Vignetting: brightness falls by this fraction at the mirror's outer radius, quadratically in
  // the radius.
  double vignetting = 0.0;
  // Chroma scaled toward grey: 1 = as rendered, 0 = grey (washed-out carpets).
  double saturation = 1.0;
  // Added to U and V after the saturation (a colour cast, white balance off), levels.
  std::array<double, 2> chroma_shift{0.0, 0.0};
  // Gaussian blur of the optics, standard deviation in px; 0 = off.
  double blur_sigma = 0.0;
  // Shot noise: standard deviation in levels at Y = 255, scaled by sqrt(Y / 255) (luma), and
  // half of it on chroma.
  double shot_noise = 0.0;
  std::uint32_t seed = 1;

  bool identity() const {
    return light_factor == 1.0 && light_gradient == 0.0 && vignetting == 0.0 && saturation == 1.0 &&
           chroma_shift[0] == 0.0 && chroma_shift[1] == 0.0 && blur_sigma == 0.0 &&
           shot_noise == 0.0;
  }
};

// Reads a `realism` section (every key optional, defaults as above; unknown keys are errors with
// file:line): light_factor, light_gradient, light_gradient_angle, vignetting, saturation,
// chroma_shift [u, v], blur_sigma, shot_noise, seed.
RealismParams loadRealismParams(const config::Node& node);

class RealismFilter {
 public:
  // Throws std::invalid_argument for values out of range (light_factor in (0, 10], gradient and
  // vignetting in [0, 1), saturation in [0, 3], shift within +-128, blur_sigma in [0, 10],
  // shot_noise in [0, 100]).
  RealismFilter(const RealismParams& params, const MirrorModel& mirror);

  const RealismParams& params() const { return params_; }
  // Changes the knobs (e.g. the light factor along a drive); the same checks as the
  // constructor.
  void setParams(const RealismParams& params);
  bool enabled() const { return !params_.identity(); }

  // Applies the knobs to a frame of width x height pixels (row-major, one Yuv per pixel).
  // Nothing happens when every knob is at its identity value.
  void apply(std::vector<Yuv>& frame, std::uint64_t frame_number);

 private:
  void buildGain();

  RealismParams params_;
  int width_;
  int height_;
  Vec2 centre_;
  double radius_;
  std::vector<float> gain_;  // per pixel brightness factor
  std::vector<float> kernel_;
  std::array<std::vector<float>, 3> planes_;
  std::vector<float> scratch_;
};

}  // namespace fieldline::camera
