#include "dofkit/image.hpp"

#include <limits>
#include <string>

#include "dofkit/error.hpp"

namespace dofkit {

namespace {
std::size_t checked_size(int width, int height, int channels) {
  if (width < 0 || height < 0 || channels < 0)
    throw_usage("image size " + std::to_string(width) + "x" + std::to_string(height) + "x" + std::to_string(channels) +
                " is negative");
  const unsigned long long n = static_cast<unsigned long long>(width) * height * channels;
  if (n > (1ull << 34))
    throw_bad_input("image size " + std::to_string(width) + "x" + std::to_string(height) + "x" +
                    std::to_string(channels) + " is too large");
  return static_cast<std::size_t>(n);
}
}  // namespace

Image::Image(int width, int height, int channels, float fill)
    : width_(width), height_(height), channels_(channels), data_(checked_size(width, height, channels), fill) {}

void Image::resize(int width, int height, int channels) {
  data_.resize(checked_size(width, height, channels));
  width_ = width;
  height_ = height;
  channels_ = channels;
}

}  // namespace dofkit
