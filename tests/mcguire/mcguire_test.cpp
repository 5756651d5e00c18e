// Properties of the McGuire method (docs/methods/mcguire.md).
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <map>
#include <vector>
#include <string>

#include "common/test_frames.hpp"
#include "core/parallel.hpp"
#include "dofkit/render.hpp"
#include "methods/mcguire/blur_weights.hpp"
#include "methods/mcguire/gather.hpp"
#include "methods/mcguire/mcguire.hpp"

using namespace dofkit;
namespace mg = dofkit::detail::mcguire;

namespace {

const char* kVariants[] = {"book", "demo", "g3d"};

// Deterministic hash texture in [0.05, 0.95], alpha 1 (shared with the other method tests).
inline Frame textured_frame(int w, int h, float z) { return test::hashed_texture_frame(w, h, z); }

RenderSettings settings(const std::string& variant, double focus_m = 4.0, double k_px = 10.0) {
  RenderSettings s;
  s.method = "mcguire";
  s.camera.model = BlurAtInfinity{focus_m, k_px};
  s.params["variant"] = variant;
  s.threads = 2;
  return s;
}

// Depth whose CoC is r for BlurAtInfinity{focus, k}: z = F K / (K + r).
float depth_for(double focus, double k, double r) { return static_cast<float>(focus * k / (k + r)); }

// A frame mixing every field: far wall, in-focus band, near blobs.
Frame mixed_frame(int w, int h) {
  Frame f = textured_frame(w, h, 12.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x > w / 3 && x < 2 * w / 3) f.depth.at(x, y) = 4.0f;
      if ((x / 17 + y / 13) % 5 == 0) f.depth.at(x, y) = 1.5f;
      if (y > h - 10) f.depth.at(x, y) = 2.5f + 0.02f * x;
    }
  return f;
}

// Near sources of both kinds in the same rows: a wide band at the largest near radius (one
// box half-width: the fast pass sums it per level) next to near pixels whose radius changes
// from pixel to pixel (the fast pass scatters them), over a far background.
Frame near_mix_frame(int w, int h) {
  Frame f = textured_frame(w, h, depth_for(4.0, 10.0, -5.0));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x >= w / 20 && x < 2 * w / 5) f.depth.at(x, y) = depth_for(4.0, 10.0, 9.0);
      if (x >= w / 2 && x < 19 * w / 20 && y < 2 * h / 3)
        f.depth.at(x, y) = depth_for(4.0, 10.0, 0.5 + static_cast<double>((x * 7 + y) % 8));
    }
  return f;
}

// Near sources only in a band of rows (the rest far and in focus): P3's near sums skip
// the columns and chunks whose rows hold no near value (near_span), next to ones that do.
Frame near_band_frame(int w, int h) {
  Frame f = textured_frame(w, h, depth_for(4.0, 10.0, -4.0));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x > w / 2 && x < 3 * w / 4) f.depth.at(x, y) = 4.0f;
      if (y > 2 * h / 3 && x > w / 5 && x < w / 3) f.depth.at(x, y) = depth_for(4.0, 10.0, 6.0 + (x % 3));
    }
  return f;
}

}  // namespace

TEST(Mcguire, InFocusIsIdentity) {
  Frame f = textured_frame(96, 64, 4.0f);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 96; ++x) f.depth.at(x, y) = depth_for(4.0, 10.0, 0.45 * std::sin(0.3 * x + 0.7 * y));
  for (const char* v : kVariants) {
    const RenderResult r = render(f, settings(v));
    ASSERT_EQ(r.image.data(), f.color.data()) << v;
  }
}

TEST(Mcguire, ConstantImageStaysConstant) {
  Frame f = mixed_frame(120, 80);
  const float want[4] = {0.3f, 0.6f, 0.9f, 1.0f};
  for (int c = 0; c < 4; ++c) std::fill_n(f.color.plane(c), f.color.plane_size(), want[c]);
  for (const char* v : kVariants) {
    const RenderResult r = render(f, settings(v));
    for (int c = 0; c < 4; ++c)
      for (std::size_t i = 0; i < f.color.plane_size(); ++i)
        ASSERT_NEAR(r.image.plane(c)[i], want[c], 2e-6f) << v << " plane " << c << " pixel " << i;
  }
}

// A sharp (in-focus) foreground pixel next to a very blurry background keeps its colour:
// far taps never spread over a pixel in front of them in the composite.
TEST(Mcguire, NoBackgroundBleedOverSharpForeground) {
  const int w = 128, h = 64;
  Frame f = textured_frame(w, h, 30.0f);  // far: r ≈ −8.7 px
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w / 2; ++x) f.depth.at(x, y) = 4.0f;  // in focus
  for (const char* v : kVariants) {
    const RenderResult r = render(f, settings(v));
    for (int c = 0; c < 4; ++c)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w / 2; ++x)
          ASSERT_EQ(r.image.at(x, y, c), f.color.at(x, y, c)) << v << " " << x << "," << y;
    // …and the background really is blurred.
    double diff = 0;
    for (int y = 0; y < h; ++y)
      for (int x = w / 2 + 12; x < w; ++x) diff += std::fabs(r.image.at(x, y, 0) - f.color.at(x, y, 0));
    EXPECT_GT(diff / (h * (w / 2 - 12)), 0.05) << v;
  }
}

TEST(Mcguire, SameOutputForAnyThreadCount) {
  const Frame f = mixed_frame(150, 90);
  for (const char* v : kVariants) {
    RenderSettings s = settings(v);
    s.threads = 1;
    const RenderResult a = render(f, s);
    s.threads = 2;
    const RenderResult b = render(f, s);
    s.threads = 3;
    const RenderResult c = render(f, s);
    ASSERT_EQ(a.image.data(), b.image.data()) << v;
    ASSERT_EQ(a.image.data(), c.image.data()) << v;
  }
}

// Worst |a − b| / max(1, |a|) over two buffers of the same size (the FastPathMatchesPlain
// measure); +inf if the sizes differ.
static double worst_relative(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return INFINITY;
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double x = a[i], y = b[i];
    worst = std::max(worst, std::fabs(x - y) / std::max(1.0, std::fabs(x)));
  }
  return worst;
}

// The fast blur passes evaluate the same sums as the plain oracle: bit-identical for
// book/demo (the same arithmetic in the same order); g3d's SIMD kernels (g3d_simd.cpp) use
// a polynomial exp2 and FMA, so within 1e-4 there.
TEST(Mcguire, FastPassesMatchPlainOracle) {
  const Frame f = mixed_frame(97, 61);
  const Image coc = compute_coc(f.depth, CameraModel{BlurAtInfinity{4.0, 10.0}});
  for (int vi = 0; vi < 3; ++vi) {
    mg::Constants k;
    k.variant = static_cast<mg::Variant>(vi);
    k.f = vi == 1 ? 4 : 2;
    k.r_max = 16;
    k.r_near = 12;
    k.inv_near = 1.0f / 12;
    k.far_occlusion = vi != 1;
    Image packed, tb1, tn1, tb2, tn2, b1, n1, b2, n2;
    mg::pack_coc(f.color, coc, {0, 0, 97, 61}, k, packed);
    const int wo = 97 / k.f, ho = 61 / k.f;
    mg::blur_horizontal_plain(packed, k, 0, wo, tb1, tn1);
    mg::blur_horizontal(packed, k, 0, wo, tb2, tn2);
    mg::blur_vertical_plain(tb1, tn1, k, 0, ho, b1, n1);
    mg::blur_vertical(tb1, tn1, k, 0, ho, b2, n2);
    if (k.variant == mg::Variant::g3d) {
      EXPECT_LE(worst_relative(tb1.data(), tb2.data()), 1e-4);
      EXPECT_LE(worst_relative(tn1.data(), tn2.data()), 1e-4);
      EXPECT_LE(worst_relative(b1.data(), b2.data()), 1e-4);
      EXPECT_LE(worst_relative(n1.data(), n2.data()), 1e-4);
      continue;
    }
    for (std::size_t i = 0; i < tb1.data().size(); ++i) ASSERT_EQ(tb1.data()[i], tb2.data()[i]) << vi;
    for (std::size_t i = 0; i < tn1.data().size(); ++i) ASSERT_EQ(tn1.data()[i], tn2.data()[i]) << vi;
    for (std::size_t i = 0; i < b1.data().size(); ++i) ASSERT_EQ(b1.data()[i], b2.data()[i]) << vi;
    for (std::size_t i = 0; i < n1.data().size(); ++i) ASSERT_EQ(n1.data()[i], n2.data()[i]) << vi;
  }
}

// g3d's SIMD passes against the plain passes over the cases their code paths split on:
// reduction 1–4 (phase split), output rows narrower than a vector and with a remainder
// (one-lane tail), centre offsets ox/oy > 0 (guard band), R_max larger than the frame (taps
// clamped far outside), no near field, a near box much narrower than R_max (zero near_box
// taps), far occlusion off, focus_px 0 (fractional nearness: the mixed-centre kernel), and
// rows/columns whose centres are all near (the box kernel) next to all far (tap skipping).
// Each pass is fed the same input (P3 gets the plain P2 output) so the comparison is per
// pass. Both passes must also give identical bits for 1 and 2 threads.
TEST(Mcguire, G3dPassesMatchPlain) {
  struct Case {
    int w, h, f, r_max;
    float r_near;
    bool occlusion = true;
    float focus_px = 0.5f;
    int ox = 0, oy = 0;
    bool near_mix = false;
  };
  const std::vector<Case> cases = {
      {97, 61, 2, 16, 12},
      {150, 90, 2, 24, 20, true, 0.5f, 0, 0, true},
      {101, 59, 3, 16, 12},
      {123, 70, 4, 20, 20, false},
      {65, 41, 1, 12, 12, true, 0.0f},
      {7, 5, 2, 9, 6},      // wo = 3, ho = 2: fewer outputs than lanes
      {3, 2, 4, 5, 4},      // narrower than the reduction: one output, taps all clamped
      {33, 31, 1, 40, 30},  // R_max beyond the frame on every side
      {90, 50, 2, 16, 0},   // no near field
      {90, 50, 2, 30, 2},   // near box much narrower than R_max
      {131, 77, 2, 16, 12, true, 0.0f, 5, 3},
      {140, 48, 4, 24, 20, true, 0.5f, 6, 6, true},
  };
  for (const Case& cs : cases) {
    const Frame fr = cs.near_mix ? near_mix_frame(cs.w, cs.h) : mixed_frame(cs.w, cs.h);
    const Image coc = compute_coc(fr.depth, CameraModel{BlurAtInfinity{4.0, 10.0}});
    mg::Constants k;
    k.variant = mg::Variant::g3d;
    k.f = cs.f;
    k.r_max = cs.r_max;
    k.r_near = cs.r_near;
    k.inv_near = 1.0f / std::max(cs.r_near, 1e-4f);
    k.far_occlusion = cs.occlusion;
    k.focus_px = cs.focus_px;
    k.g3d_fov_rad = 0.7f;
    const std::string name = std::to_string(cs.w) + "x" + std::to_string(cs.h) + " f" + std::to_string(cs.f) + " R" +
                             std::to_string(cs.r_max);
    Image packed;
    mg::pack_coc(fr.color, coc, {0, 0, cs.w, cs.h}, k, packed);
    const int wo = std::max(1, (cs.w - 2 * cs.ox) / cs.f), ho = std::max(1, (cs.h - 2 * cs.oy) / cs.f);
    Image tb1, tn1, b1, n1;
    mg::blur_horizontal_plain(packed, k, cs.ox, wo, tb1, tn1);
    mg::blur_vertical_plain(tb1, tn1, k, cs.oy, ho, b1, n1);
    std::vector<float> first[4];
    for (int threads : {1, 2}) {
      Image tb2, tn2, b2, n2;
      core::with_threads(threads, [&] {
        mg::blur_horizontal(packed, k, cs.ox, wo, tb2, tn2);
        mg::blur_vertical(tb1, tn1, k, cs.oy, ho, b2, n2);
      });
      EXPECT_LE(worst_relative(tb1.data(), tb2.data()), 1e-4) << name;
      EXPECT_LE(worst_relative(tn1.data(), tn2.data()), 1e-4) << name;
      EXPECT_LE(worst_relative(b1.data(), b2.data()), 1e-4) << name;
      EXPECT_LE(worst_relative(n1.data(), n2.data()), 1e-4) << name;
      // The blurred and near results are not trivially zero (the comparison means something).
      EXPECT_GT(*std::max_element(b1.data().begin(), b1.data().end()), 0.05f) << name;
      if (threads == 1) {
        first[0] = tb2.data();
        first[1] = tn2.data();
        first[2] = b2.data();
        first[3] = n2.data();
      } else {
        EXPECT_EQ(first[0], tb2.data()) << name;
        EXPECT_EQ(first[1], tn2.data()) << name;
        EXPECT_EQ(first[2], b2.data()) << name;
        EXPECT_EQ(first[3], n2.data()) << name;
      }
    }
  }
}

// Inside a uniform near field of radius r the near buffer's coverage is the coverage curve
// times the fraction of the near box that r's disc reaches (the horizontal pass counts tap
// B only if |δ| <= r_B, then divides by the box size 2·R_near − 1; the vertical pass and the
// bilinear lookup leave a uniform value unchanged).
TEST(Mcguire, NearBufferAlphaFollowsCoverageCurve) {
  const double focus = 4.0, k = 10.0;
  const int r_near = 16;
  for (const char* curve : {"code", "book"})
    for (double r : {1.5, 2.5, 3.5, 6.5, 12.5}) {
      Frame f = textured_frame(96, 96, depth_for(focus, k, r));
      RenderSettings s = settings("book", focus, k);
      s.params["near_radius_px"] = std::to_string(r_near);
      s.params["near_alpha"] = curve;
      s.debug_view = "near";
      const RenderResult res = render(f, s);
      const double a = std::string(curve) == "code" ? std::min(1.0, 4.0 * r / r_near) : r / r_near;
      const double expect = std::pow(a, 4) * (2 * std::floor(r) + 1) / (2 * r_near - 1);
      const Image& nb = res.debug;
      ASSERT_EQ(nb.channels(), 4);
      const float got = nb.at(nb.width() / 2, nb.height() / 2, 3);
      EXPECT_NEAR(got, expect, 1e-5 + 1e-4 * expect) << curve << " r=" << r;
    }
  // g3d: α = saturate(r / R_near)², no reach test, then the coverage curve of §2.7.
  Frame f = textured_frame(96, 96, depth_for(focus, k, 6.0));
  RenderSettings s = settings("g3d", focus, k);
  s.params["near_radius_px"] = std::to_string(r_near);
  s.debug_view = "near";
  const RenderResult res = render(f, s);
  const double a = std::pow(6.0 / r_near, 2);
  const double t = std::clamp(1.0 - 0.025 / (40.0 * M_PI / 180.0 * a), 0.0, 1.0);
  EXPECT_NEAR(res.debug.at(res.debug.width() / 2, res.debug.height() / 2, 3), t * t * (3 - 2 * t), 1e-5);
}

// Guard band: its output pixels are transparent black; with guard_band_taps=off the result
// inside equals a render of the cropped inner image (whatever the guard band holds); with
// taps on, in-focus guard content (a value found nowhere else) never reaches the output of a
// far/focus frame. (With taps on, guard pixels do feed the inpainting box behind near
// objects at the border — that is the purpose of reading them.)
TEST(Mcguire, GuardBandPixelsNeverReachTheOutput) {
  const int w = 120, h = 80, g = 9;
  for (bool with_near : {false, true}) {
    Frame f = mixed_frame(w, h);
    if (!with_near)
      for (float& z : f.depth.data()) z = std::max(z, 4.0f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (x < g || y < g || x >= w - g || y >= h - g) {
          f.color.at(x, y, 0) = 50.0f;  // a value far outside the inner image's range
          f.depth.at(x, y) = 4.0f;      // in focus
        }
    Frame inner;
    inner.color = Image(w - 2 * g, h - 2 * g, 4);
    inner.depth = Image(w - 2 * g, h - 2 * g, 1);
    for (int y = 0; y < h - 2 * g; ++y)
      for (int x = 0; x < w - 2 * g; ++x) {
        for (int c = 0; c < 4; ++c) inner.color.at(x, y, c) = f.color.at(x + g, y + g, c);
        inner.depth.at(x, y) = f.depth.at(x + g, y + g);
      }
    for (const char* v : kVariants) {
      RenderSettings s = settings(v);
      s.params["guard_band_px"] = std::to_string(g);
      for (const char* taps : {"on", "off"}) {
        if (with_near && std::string(taps) == "on") continue;
        s.params["guard_band_taps"] = taps;
        const RenderResult r = render(f, s);
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) {
            const bool ring = x < g || y < g || x >= w - g || y >= h - g;
            for (int c = 0; c < 4; ++c) {
              if (ring)
                ASSERT_EQ(r.image.at(x, y, c), 0.0f) << v << taps;
              else
                ASSERT_LT(r.image.at(x, y, c), 1.001f) << v << " taps " << taps << " at " << x << "," << y;
            }
          }
        if (std::string(taps) == "off") {
          RenderSettings s0 = settings(v);
          const RenderResult r0 = render(inner, s0);
          for (int y = 0; y < h - 2 * g; ++y)
            for (int x = 0; x < w - 2 * g; ++x)
              for (int c = 0; c < 4; ++c) ASSERT_EQ(r.image.at(x + g, y + g, c), r0.image.at(x, y, c)) << v;
        }
      }
    }
  }
}

TEST(Mcguire, BadParametersNameTheKey) {
  const Frame f = mixed_frame(40, 30);
  RenderSettings s = settings("demo");
  s.params["variant"] = "fast";
  try {
    render(f, s);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("variant"), std::string::npos);
  }
  s = settings("demo");
  s.params["guard_band_px"] = "15";
  try {
    render(f, s);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::usage);
    EXPECT_NE(std::string(e.what()).find("guard_band_px"), std::string::npos);
  }
  s = settings("demo");
  s.params["coverage_boost"] = "0.5";
  EXPECT_THROW(render(f, s), Error);
}

TEST(Mcguire, DebugViewsHaveTheirShapes) {
  const Frame f = mixed_frame(100, 60);
  for (const char* view : {"coc", "near", "far", "weights"}) {
    RenderSettings s = settings("demo");
    s.debug_view = view;
    const RenderResult r = render(f, s);
    const std::string v = view;
    if (v == "coc") EXPECT_EQ(r.debug.channels(), 1);
    if (v == "coc" || v == "weights") EXPECT_TRUE(r.debug.same_size(f.color)) << v;
    if (v == "near" || v == "far") {
      EXPECT_EQ(r.debug.width(), 25);
      EXPECT_EQ(r.debug.height(), 15);
    }
    EXPECT_FALSE(r.debug.empty()) << v;
  }
}

// impl=fast (SIMD gathers, box sums, row-organised composite) computes the plain passes'
// sums within float rounding: every tap weight is evaluated exactly (same division for the
// table index), only FMA and the order of box sums round differently.
TEST(Mcguire, FastPathMatchesPlain) {
  struct Case {
    const char* variant;
    std::map<std::string, std::string> extra;
    int w, h;
    bool near_mix = false;   // near_mix_frame instead of mixed_frame
    bool near_band = false;  // near_band_frame
  };
  const std::vector<Case> cases = {
      {"demo", {}, 150, 90},
      {"book", {}, 150, 90},
      {"g3d", {}, 150, 90},
      {"demo", {{"reduction", "1"}}, 97, 61},
      {"demo", {{"reduction", "3"}, {"guard_band_px", "7"}}, 101, 67},
      {"book", {{"reduction", "4"}, {"far_occlusion_test", "off"}}, 123, 70},
      {"demo", {{"focus_px", "0"}}, 150, 90},  // fractional nearness near r = 0
      {"book", {{"focus_px", "0.1"}, {"guard_band_px", "5"}, {"guard_band_taps", "off"}}, 99, 73},
      {"demo", {{"near_field", "off"}}, 150, 90},
      {"demo", {{"lowres_offset_fix", "off"}, {"near_radius_px", "5"}}, 150, 90},
      {"demo", {}, 37, 29},  // fewer outputs per row than SIMD lanes
      // Each reduction factor takes its own phase split (LoadInterleaved2/3/4, plain loads
      // for 1) and composite interpolation (lane permutes for f = 2, 4; gathers for 1, 3).
      {"demo", {{"reduction", "2"}}, 131, 77},
      {"book", {{"reduction", "1"}}, 65, 41},
      {"book", {{"reduction", "3"}}, 119, 83},
      {"g3d", {{"reduction", "3"}}, 101, 59},
      {"demo", {{"near_radius_px", "3"}}, 150, 90},  // near box narrower than R_max
      // Per-level box sums and the per-source scatter in the same rows (every reduction).
      {"demo", {}, 160, 60, true},
      {"demo", {{"reduction", "1"}}, 97, 40, true},
      {"book", {{"reduction", "3"}}, 131, 50, true},
      {"demo", {{"reduction", "2"}, {"guard_band_px", "6"}}, 140, 48, true},
      // g3d (SIMD kernels of g3d_simd.cpp): odd and tiny frames, guard band with and without
      // taps into it, every reduction, far occlusion off, fractional nearness, near field off.
      {"g3d", {}, 97, 61},
      {"g3d", {}, 13, 9},  // fewer outputs per row than SIMD lanes
      {"g3d", {{"guard_band_px", "7"}}, 101, 67},
      {"g3d", {{"guard_band_px", "5"}, {"guard_band_taps", "off"}}, 99, 73},
      {"g3d", {{"reduction", "1"}}, 65, 41},
      {"g3d", {{"reduction", "4"}, {"far_occlusion_test", "off"}}, 123, 70},
      {"g3d", {{"focus_px", "0"}}, 150, 90},
      {"g3d", {{"near_field", "off"}}, 150, 90},
      {"g3d", {{"near_radius_px", "3"}}, 150, 90},
      {"g3d", {}, 160, 60, true},
      {"g3d", {{"reduction", "3"}, {"guard_band_px", "6"}}, 131, 50, true},
      // Near field in the bottom rows only, in a few columns (book/demo P3's near spans).
      {"demo", {}, 160, 200, false, true},
      {"book", {{"reduction", "3"}}, 131, 150, false, true},
      {"demo", {{"reduction", "1"}, {"guard_band_px", "4"}}, 97, 120, false, true},
  };
  for (const Case& cs : cases) {
    const Frame f = cs.near_band  ? near_band_frame(cs.w, cs.h)
                    : cs.near_mix ? near_mix_frame(cs.w, cs.h)
                                  : mixed_frame(cs.w, cs.h);
    RenderSettings s = settings(cs.variant);
    for (const auto& [key, v] : cs.extra) s.params[key] = v;
    s.params["impl"] = "plain";
    s.threads = 1;
    const RenderResult a = render(f, s);
    s.params["impl"] = "fast";
    std::vector<float> fast_one_thread;
    for (int threads : {1, 2}) {
      s.threads = threads;
      const RenderResult b = render(f, s);
      ASSERT_EQ(a.image.data().size(), b.image.data().size());
      double worst = 0;
      for (std::size_t i = 0; i < a.image.data().size(); ++i) {
        const double x = a.image.data()[i], y = b.image.data()[i];
        worst = std::max(worst, std::fabs(x - y) / std::max(1.0, std::fabs(x)));
      }
      EXPECT_LE(worst, 1e-4) << cs.variant << " " << cs.w << "x" << cs.h << " case " << (&cs - cases.data())
                             << " threads " << threads;
      // The fast path's chunking does not depend on the thread count: identical bits.
      if (threads == 1)
        fast_one_thread = b.image.data();
      else
        EXPECT_EQ(fast_one_thread, b.image.data()) << "case " << (&cs - cases.data());
    }
  }
}

// The far gather's table index is ⌊5|δ| / den⌋ exactly as far_weight() computes it, also
// where the kernel's product 5|δ|·(1/den) rounds to the other side of an integer (the
// kernel must then divide): every source's den is placed within a few ulps of 5|δ_j| / k
// for one tap distance δ_j and one step k of the table, on both sides, and the result is
// compared with a scalar sum over the same indices. Also the pair, single-vector and tail
// paths of the kernel (37 outputs) and den = 0 (near sources, weight 0).
TEST(Mcguire, FarGatherIndexExactAtIntegerQuotients) {
  const int n = 37, L = 9, ntaps = 2 * L + 1, ns = n + 2 * L + 64;
  std::vector<float> col(4 * static_cast<std::size_t>(ns)), aux(3 * static_cast<std::size_t>(ns));
  float* inv = aux.data();
  float* den = inv + ns;
  float* absr = den + ns;
  int product_differs = 0;  // (output, tap) pairs where d5·(1/den) floors differently
  for (int j = 0; j < ns; ++j) {
    for (int c = 0; c < 4; ++c) col[c * ns + j] = 0.1f + 0.8f * static_cast<float>((j * 37 + c * 11) % 23) / 23.0f;
    if (j % 11 == 5) {  // near source
      den[j] = 0.0f;
      inv[j] = std::numeric_limits<float>::infinity();
      continue;
    }
    // Within 4 ulps of 5d / k, for the first tap distance d and step k (from ones that
    // depend on j) that has one, a den whose product floors differently.
    float v = 1.0f + 0.37f * static_cast<float>(j % 13);
    bool found = false;
    for (int e = 0; e < L * 5 && !found; ++e) {
      const int d = 1 + (j + e) % L, k = 2 + (j + e / L) % 5;
      const float d5 = 5.0f * static_cast<float>(d);
      float lo = d5 / static_cast<float>(k), hi = lo;
      for (int u = 0; u < 4 && !found; ++u) {
        for (float x : {lo, hi})
          if (!found && std::floor(d5 * (1.0f / x)) != std::floor(d5 / x)) {
            v = x;
            found = true;
          }
        lo = std::nextafter(lo, 0.0f);
        hi = std::nextafter(hi, 100.0f);
      }
    }
    den[j] = v;
    inv[j] = 1.0f / v;
    absr[j] = (v - 0.001f) / 0.8f;
  }
  std::vector<mg::GatherTap> taps(ntaps);
  for (int t = 0; t < ntaps; ++t) {
    const int d = t - L;
    taps[t] = {col.data() + t, inv + t, d == 0 ? mg::kCentreD5 : 5.0f * static_cast<float>(std::abs(d))};
  }
  std::vector<float> r_a(n, -3.0f), nearness(n, 0.0f), out(4 * n);
  float table[16] = {};
  std::copy_n(mg::kDiscTable, 7, table);
  mg::GatherJob job;
  job.n = n;
  job.ntaps = ntaps;
  job.taps = taps.data();
  job.col_stride = ns;
  job.aux_stride = ns;
  job.r_a = r_a.data();
  job.nearness = nearness.data();
  job.table = table;
  job.frac = false;
  for (int c = 0; c < 4; ++c) job.out[c] = out.data() + c * n;
  mg::far_gather_simd(job);
  for (int o = 0; o < n; ++o) {
    double a[4] = {0, 0, 0, 0}, aw = 0;
    for (int t = 0; t < ntaps; ++t) {
      const int j = o + t;
      const float q = taps[t].d5 / den[j];
      const float w = table[q >= 6.0f ? 6 : static_cast<int>(q)];
      const float p = taps[t].d5 * inv[j];
      product_differs += std::min(6.0f, std::floor(p)) != std::min(6.0f, std::floor(q));
      for (int c = 0; c < 4; ++c) a[c] += static_cast<double>(w) * col[c * ns + j];
      aw += w;
    }
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(out[c * n + o], a[c] / aw, 1e-5) << "output " << o << " channel " << c;
  }
  EXPECT_GT(product_differs, 20);  // the test reaches the divisions it is about
}

// The per-output row kernels of the fast passes (scan_block_simd, box_out_simd,
// window_add_simd, window_scale_simd, scale_row_simd, max_rows_simd) against the scalar loops they replaced, bit
// for bit, on lengths that cover the vector loops, their tails and fewer outputs than lanes.
TEST(Mcguire, RowKernelsMatchScalarLoops) {
  std::uint32_t seed = 12345;
  auto rnd = [&] {
    seed = seed * 1664525u + 1013904223u;
    return static_cast<float>(seed >> 8) / 16777216.0f;
  };
  for (int n : {1, 3, 7, 8, 9, 15, 16, 17, 31, 32, 33, 47, 100}) {
    const int pad = n + 64;
    // Nearness: runs of 0, 1 and fractions (mostly no fraction: the common case).
    for (int pattern = 0; pattern < 4; ++pattern) {
      std::vector<float> nearness(pad, 0.0f);
      std::vector<std::int32_t> reach(pad);
      for (int i = 0; i < pad; ++i) {
        const float u = rnd();
        nearness[i] = pattern == 0   ? 0.0f
                      : pattern == 1 ? 1.0f
                      : u < 0.4f     ? 0.0f
                      : u < 0.8f     ? 1.0f
                      : pattern == 3 ? rnd()
                                     : 1.0f;
        reach[i] = static_cast<std::int32_t>(rnd() * 60);
      }
      mg::ScanBlockJob scan;
      scan.nearness = nearness.data();
      scan.n = n;
      scan.reach = reach.data();
      scan.g0 = n / 3;
      scan.g1 = n / 3 + n - 1;
      mg::scan_block_simd(scan);
      int first = -1, last = -1, m = 0;
      bool far = false, frac = false;
      for (int i = 0; i < n; ++i) {
        if (nearness[i] == 1.0f) {
          if (first < 0) first = i;
          last = i;
        } else {
          far = true;
          frac |= nearness[i] > 0.0f;
        }
      }
      for (int g = scan.g0; g <= scan.g1; ++g) m = std::max(m, reach[g]);
      EXPECT_EQ(scan.first_one, first) << n << " " << pattern;
      EXPECT_EQ(scan.last_one, last) << n << " " << pattern;
      EXPECT_EQ(scan.any_far, far) << n << " " << pattern;
      EXPECT_EQ(scan.any_frac, frac) << n << " " << pattern;
      EXPECT_EQ(scan.max_reach, m) << n << " " << pattern;

      // Box outputs: only the nearness-1 outputs are written.
      std::vector<double> a(4 * pad), b(4 * pad), c(4 * pad);
      for (std::size_t i = 0; i < a.size(); ++i) {
        a[i] = 1000.0 * rnd() + rnd() * 1e-9;
        b[i] = 100.0 * rnd();
        c[i] = rnd();
      }
      for (bool full : {true, false}) {
        std::vector<float> out(4 * pad, -7.0f), ref = out;
        mg::BoxOutJob box;
        box.n = n;
        box.nearness = nearness.data();
        box.w = 117.0f;
        for (int ch = 0; ch < 4; ++ch) {
          box.a[ch] = a.data() + ch * pad;
          box.b[ch] = full ? b.data() + ch * pad : nullptr;
          box.c[ch] = full ? c.data() + ch * pad : nullptr;
          box.out[ch] = out.data() + ch * pad;
        }
        mg::box_out_simd(box);
        for (int i = 0; i < n; ++i)
          if (nearness[i] == 1.0f)
            for (int ch = 0; ch < 4; ++ch) {
              const std::size_t k = ch * pad + i;
              ref[k] = static_cast<float>(full ? a[k] - b[k] + c[k] : a[k]) / 117.0f;
            }
        EXPECT_EQ(out, ref) << n << " " << pattern << " " << full;
      }
      std::vector<double> dst(a.begin(), a.begin() + pad), dref = dst;
      mg::window_add_simd(dst.data(), a.data() + 3, b.data(), c.data() + 3, n);
      for (int i = 0; i < n; ++i) dref[i] += a[i + 3] - b[i] + c[i + 3];
      EXPECT_EQ(dst, dref) << n;
      std::vector<float> ws(pad, -1.0f), wref = ws;
      mg::window_scale_simd(ws.data(), a.data() + 3, b.data(), c.data() + 3, 0.0123f, n);
      for (int i = 0; i < n; ++i) wref[i] = static_cast<float>(a[i + 3] - b[i] + c[i + 3]) * 0.0123f;
      EXPECT_EQ(ws, wref) << n;
      std::vector<float> sc(pad, -1.0f), sref = sc;
      mg::scale_row_simd(sc.data(), a.data(), 0.0123f, n);
      for (int i = 0; i < n; ++i) sref[i] = static_cast<float>(a[i]) * 0.0123f;
      EXPECT_EQ(sc, sref) << n;
    }
    // Column-block reach maxima over rows (rows padded to whole vectors).
    const int stride = (n + 15) & ~15, rows = 9;
    std::vector<float> base(static_cast<std::size_t>(stride) * rows), mx(stride), mref(n, 0.0f);
    for (float& v : base) v = std::floor(rnd() * 60);
    mg::max_rows_simd(mx.data(), base.data(), stride, 2, 7, n);
    for (int y = 2; y <= 7; ++y)
      for (int j = 0; j < n; ++j) mref[j] = std::max(mref[j], base[y * stride + j]);
    EXPECT_EQ(std::vector<float>(mx.begin(), mx.begin() + n), mref) << n;
  }
}
