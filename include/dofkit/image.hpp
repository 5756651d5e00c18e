// dofkit — planar float images.
#pragma once
#include <cstddef>
#include <vector>

namespace dofkit {

/// A planar float image: `channels` planes of `width × height` floats, each plane stored
/// row-major with no padding (plane c, pixel (x, y) at `data()[(c·height + y)·width + x]`).
/// Pixel (x, y) has its centre at (x + 0.5, y + 0.5); y grows downward.
/// Colour images inside dofkit are linear-light RGBA with premultiplied alpha (4 planes);
/// depth and CoC maps are single planes.
class Image {
 public:
  Image() = default;
  /// Allocates `channels` planes of `width × height`, every sample set to `fill`.
  Image(int width, int height, int channels, float fill = 0.0f);

  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  int channels() const noexcept { return channels_; }
  bool empty() const noexcept { return data_.empty(); }
  /// Number of pixels in one plane (width × height).
  std::size_t plane_size() const noexcept { return static_cast<std::size_t>(width_) * height_; }
  bool same_size(const Image& o) const noexcept { return width_ == o.width_ && height_ == o.height_; }

  float* plane(int c) noexcept { return data_.data() + c * plane_size(); }
  const float* plane(int c) const noexcept { return data_.data() + c * plane_size(); }
  float* row(int c, int y) noexcept { return plane(c) + static_cast<std::size_t>(y) * width_; }
  const float* row(int c, int y) const noexcept { return plane(c) + static_cast<std::size_t>(y) * width_; }
  float& at(int x, int y, int c = 0) noexcept { return row(c, y)[x]; }
  float at(int x, int y, int c = 0) const noexcept { return row(c, y)[x]; }

  std::vector<float>& data() noexcept { return data_; }
  const std::vector<float>& data() const noexcept { return data_; }

  /// Re-shapes the image; keeps the allocation when the total size does not grow.
  /// Sample values are unspecified afterwards.
  void resize(int width, int height, int channels);

 private:
  int width_ = 0;
  int height_ = 0;
  int channels_ = 0;
  std::vector<float> data_;
};

}  // namespace dofkit
