// core::coc_range / coc_row_range against a plain scalar loop.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/coc_range.hpp"
#include "core/parallel.hpp"

namespace dofkit {
namespace {

TEST(CocRange, RowMatchesScalarLoopWithAndWithoutMask) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> val(-40.0f, 40.0f), u(0.0f, 1.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int n = 0; n <= 37; ++n) {
    std::vector<float> r(n), a(n);
    for (int x = 0; x < n; ++x) {
      r[x] = val(rng);
      const float t = u(rng);
      a[x] = t < 0.2f ? 0.0f : (t < 0.25f ? nan : (t < 0.3f ? -0.5f : t));  // transparent, NaN, negative, opaque-ish
    }
    // Plain loop, starting from non-zero maxima as a caller folding several rows would.
    float n_want = 1.5f, f_want = 2.5f, nm_want = 1.5f, fm_want = 2.5f;
    for (int x = 0; x < n; ++x) {
      n_want = std::max(n_want, r[x]);
      f_want = std::max(f_want, -r[x]);
      if (a[x] > 0) {
        nm_want = std::max(nm_want, r[x]);
        fm_want = std::max(fm_want, -r[x]);
      }
    }
    float n_got = 1.5f, f_got = 2.5f, nm_got = 1.5f, fm_got = 2.5f;
    core::coc_row_range(r.data(), nullptr, n, n_got, f_got);
    core::coc_row_range(r.data(), a.data(), n, nm_got, fm_got);
    EXPECT_EQ(n_got, n_want) << n;
    EXPECT_EQ(f_got, f_want) << n;
    EXPECT_EQ(nm_got, nm_want) << n;
    EXPECT_EQ(fm_got, fm_want) << n;
  }
}

TEST(CocRange, RectangleMatchesScalarLoopForAnyThreadCount) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> val(-30.0f, 20.0f);
  Image coc(53, 41, 1);
  for (float& v : coc.data()) v = val(rng);
  coc.at(50, 38) = 35.0f;  // outside the rectangle below: must not count
  coc.at(2, 1) = -45.0f;
  const int x0 = 1, y0 = 1, w = 45, h = 33;
  float near_want = 0, far_want = 0;
  for (int y = y0; y < y0 + h; ++y)
    for (int x = x0; x < x0 + w; ++x) {
      near_want = std::max(near_want, coc.at(x, y));
      far_want = std::max(far_want, -coc.at(x, y));
    }
  EXPECT_EQ(far_want, 45.0f);
  for (int threads : {1, 2, 3}) {
    core::CocRange got;
    core::with_threads(threads, [&] { got = core::coc_range(coc, x0, y0, w, h); });
    EXPECT_EQ(got.near_max, near_want) << threads;
    EXPECT_EQ(got.far_max, far_want) << threads;
  }
  const core::CocRange all = core::coc_range(coc);
  EXPECT_EQ(all.near_max, 35.0f);
}

}  // namespace
}  // namespace dofkit
