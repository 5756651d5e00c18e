// Frames shared by the method test suites (header only: tests/common builds no executable).
#pragma once
#include <cstdint>

#include "dofkit/frame.hpp"

namespace dofkit::test {

/// W × H frame at constant depth z with a deterministic per-pixel hash texture in
/// [0.05, 0.95], RGB distinct, alpha 1: detailed enough that identity tests are not trivial.
inline Frame hashed_texture_frame(int w, int h, float z) {
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1, z);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        std::uint32_t v = static_cast<std::uint32_t>(x * 73856093u ^ y * 19349663u ^ (c + 1) * 83492791u);
        v ^= v >> 13;
        v *= 0x5bd1e995u;
        v ^= v >> 15;
        f.color.at(x, y, c) = 0.05f + 0.9f * static_cast<float>(v % 1000u) / 999.0f;
      }
  return f;
}

}  // namespace dofkit::test
