// image_t (CAMERA_IMAGE) <-> camera::FrameView: the pixels of a message as the vision reads them,
// and a frame's layout and pixels into a message. Header and the source fields (source,
// frame_number, exposure_us) are the node's business and left untouched.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include <fieldline/image_t.hpp>

#include "common/camera/frame.hpp"

namespace fieldline::msg {

// The layout of an image_t FORMAT_ code; nullopt for layouts the vision does not read (grey,
// unknown codes).
std::optional<camera::PixelFormat> pixelFormatOf(std::int8_t format);
// The image_t FORMAT_ code of a layout.
std::int8_t formatCode(camera::PixelFormat format);

// A view of the message's pixels (valid while `m` is unchanged); nullopt if the format is not
// YUYV or BGR or the sizes do not describe the data.
std::optional<camera::FrameView> fromMessage(const image_t& m);
// The same for a message's fields with its pixels elsewhere (bus::ImageView: in the receive
// buffer); `m.data` is not looked at.
std::optional<camera::FrameView> fromMessage(const image_t& m, std::span<const std::uint8_t> data);

// Writes `frame`'s size, stride, format and pixels into `m`. A frame that views m.data itself (a
// buffer swapped into the message) is not copied; any other is copied row by row with the
// smallest stride.
void toMessage(const camera::FrameView& frame, image_t& m);

}  // namespace fieldline::msg
