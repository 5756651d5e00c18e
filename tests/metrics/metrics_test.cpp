// Metrics: exact identities, edge-band geometry, and a cross-check against scikit-image.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"
#include "metrics/metrics.hpp"

using namespace dofkit;
namespace fs = std::filesystem;

namespace {

/// A deterministic test image with detail at several scales, values partly outside [0, 1]
/// so clipping is exercised.
Image pattern(int w, int h, unsigned seed, float noise) {
  Image img(w, h, 4, 1.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-noise, noise);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        float v = 0.45f + 0.4f * std::sin(0.31f * x + 1.7f * c) * std::cos(0.17f * y - c) +
                  (((x / 7 + y / 5) % 2) ? 0.15f : -0.1f) + u(rng);
        img.at(x, y, c) = v * (1.0f + 0.2f * c);
      }
  return img;
}

Image perturb(const Image& a, unsigned seed, float amount) {
  Image b = a;
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, amount);
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < a.plane_size(); ++i) b.plane(c)[i] += n(rng);
  // A blurred patch as well: structure changes, not just noise.
  for (int c = 0; c < 3; ++c)
    for (int y = 10; y < 30; ++y)
      for (int x = 12; x < 40; ++x)
        b.at(x, y, c) = 0.25f * (a.at(x - 1, y, c) + a.at(x + 1, y, c) + a.at(x, y - 1, c) + a.at(x, y + 1, c));
  return b;
}

}  // namespace

TEST(Metrics, IdenticalImagesArePerfect) {
  const Image a = pattern(64, 48, 1, 0.05f);
  EXPECT_TRUE(std::isinf(metrics::psnr(a, a)));
  EXPECT_GT(metrics::psnr(a, a), 0);
  EXPECT_DOUBLE_EQ(metrics::ssim(a, a), 1.0);
  EXPECT_DOUBLE_EQ(metrics::rmse_linear(a, a), 0.0);
  const metrics::Scores s = metrics::compare(a, a, nullptr);
  EXPECT_TRUE(std::isinf(s.psnr_db));
  EXPECT_DOUBLE_EQ(s.ssim, 1.0);
  EXPECT_TRUE(std::isnan(s.edge_psnr_db));
}

TEST(Metrics, KnownPsnrAndRmse) {
  // Mid-grey display value 0.5 everywhere vs 0.5 + 0.1 in R only: MSE = 0.01 / 3.
  Image a(32, 32, 4, 1.0f), b(32, 32, 4, 1.0f);
  auto lin = [](double d) { return static_cast<float>(std::pow((d + 0.055) / 1.055, 2.4)); };
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < a.plane_size(); ++i) {
      a.plane(c)[i] = lin(0.5);
      b.plane(c)[i] = lin(c == 0 ? 0.6 : 0.5);
    }
  EXPECT_NEAR(metrics::psnr(a, b), 10 * std::log10(3.0 / 0.01), 1e-4);
  const double d = lin(0.6) - lin(0.5);
  EXPECT_NEAR(metrics::rmse_linear(a, b), std::sqrt(d * d / 3), 1e-7);
}

TEST(Metrics, ClipsBeforeComparing) {
  // HDR values above 1 all display as white: no difference after the protocol's clip.
  Image a(16, 16, 4, 2.0f), b(16, 16, 4, 7.0f);
  EXPECT_TRUE(std::isinf(metrics::psnr(a, b)));
  EXPECT_DOUBLE_EQ(metrics::ssim(a, b), 1.0);
  EXPECT_NEAR(metrics::rmse_linear(a, b), 5.0, 1e-6);  // RMSE is linear and unclipped
}

TEST(Metrics, SizeMismatchIsBadInput) {
  Image a(16, 16, 4), b(17, 16, 4);
  try {
    metrics::psnr(a, b);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::bad_input);
    EXPECT_NE(std::string(e.what()).find("16x16x4"), std::string::npos) << e.what();
  }
  Image tiny(8, 8, 4);
  EXPECT_THROW(metrics::ssim(tiny, tiny), Error);
}

TEST(Metrics, ResultsDoNotDependOnThreadCount) {
  const Image a = pattern(150, 97, 3, 0.1f), b = perturb(a, 4, 0.05f);
  double s1 = 0, s2 = 0, p1 = 0, p2 = 0;
  core::with_threads(1, [&] {
    s1 = metrics::ssim(a, b);
    p1 = metrics::psnr(a, b);
  });
  core::with_threads(2, [&] {
    s2 = metrics::ssim(a, b);
    p2 = metrics::psnr(a, b);
  });
  EXPECT_EQ(s1, s2);
  EXPECT_EQ(p1, p2);
}

TEST(EdgeBand, SingleVerticalStepGivesBandOfHalfWidth12) {
  // Depth 2 left of x = 40, 3 right of it (50 % jump): edge pixels are x = 39 and x = 40,
  // so the band is x in [39 − 12, 40 + 12] on every row.
  const int w = 100, h = 30;
  Image z(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) z.at(x, y) = x < 40 ? 2.0f : 3.0f;
  const Image m = metrics::edge_band(z);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) EXPECT_EQ(m.at(x, y), (x >= 27 && x <= 52) ? 1.0f : 0.0f) << x << "," << y;
}

TEST(EdgeBand, SmallJumpsAndInfinityPairsAreNoEdges) {
  const int w = 60, h = 40;
  Image z(w, h, 1);
  // A smooth ramp with 1 % steps (below the 5 % threshold) and a region of +inf next to +inf.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      z.at(x, y) = y < 20 ? 1.0f * std::pow(1.01f, x) : std::numeric_limits<float>::infinity();
  // The border between finite (row 19) and +inf (row 20) is a jump; nothing else is.
  const Image m = metrics::edge_band(z, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) EXPECT_EQ(m.at(x, y), (y >= 16 && y <= 23) ? 1.0f : 0.0f) << x << "," << y;
}

TEST(EdgeBand, IsotropicDiscAroundAnIsolatedPixel) {
  // One pixel much nearer than its surroundings: it and its 4 neighbours are edge pixels;
  // the band is the union of discs of radius 12 around those five.
  const int w = 61, h = 61, cx = 30, cy = 30;
  Image z(w, h, 1, 10.0f);
  z.at(cx, cy) = 1.0f;
  const Image m = metrics::edge_band(z);
  const int ex[5] = {0, 1, -1, 0, 0}, ey[5] = {0, 0, 0, 1, -1};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      bool in = false;
      for (int k = 0; k < 5; ++k) {
        const int dx = x - cx - ex[k], dy = y - cy - ey[k];
        in = in || dx * dx + dy * dy <= 144;
      }
      EXPECT_EQ(m.at(x, y), in ? 1.0f : 0.0f) << x << "," << y;
    }
}

TEST(EdgeBand, EdgePsnrOnlySeesTheBand) {
  const int w = 80, h = 40;
  Image z(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) z.at(x, y) = x < 20 ? 1.0f : 5.0f;
  Image a(w, h, 4, 0.2f), b = a;
  // Differences only far from the edge (x >= 60): whole-image PSNR is finite, edge PSNR inf.
  for (int y = 0; y < h; ++y) b.at(70, y, 1) = 0.9f;
  const metrics::Scores s = metrics::compare(a, b, &z);
  EXPECT_TRUE(std::isfinite(s.psnr_db));
  EXPECT_TRUE(std::isinf(s.edge_psnr_db));
  EXPECT_NEAR(s.edge_fraction, 26.0 / 80.0, 1e-12);
}

// ---------------------------------------------------------------------------
// Cross-check against scikit-image (the protocol's reference implementation).

namespace {

/// A python3 that can import skimage, or "" (with the reason in `why`).
std::string find_python_with_skimage(std::string& why) {
  for (const char* py : {"python3", "/usr/bin/python3"}) {
    const std::string cmd = std::string(py) + " -c \"import skimage.metrics, numpy\" >/dev/null 2>&1";
    if (std::system(cmd.c_str()) == 0) return py;
  }
  why =
      "neither python3 nor /usr/bin/python3 can import skimage.metrics and numpy "
      "(install python3-skimage: scripts/deps)";
  return "";
}

void write_raw(const fs::path& p, const Image& img) {
  // Linear R, G, B as float32, interleaved H × W × 3 (numpy's layout for channel_axis=-1).
  std::ofstream f(p, std::ios::binary);
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = img.at(x, y, c);
        f.write(reinterpret_cast<const char*>(&v), sizeof v);
      }
}

}  // namespace

TEST(Metrics, MatchesScikitImage) {
  std::string why;
  const std::string py = find_python_with_skimage(why);
  if (py.empty()) GTEST_SKIP() << why;

  const fs::path dir = fs::path(DOFKIT_BINARY_DIR) / "test_metrics_skimage";
  fs::create_directories(dir);
  const fs::path script = dir / "ref.py";
  {
    // The protocol written with numpy + skimage only: clip, sRGB-encode (float64), then
    // skimage's PSNR and SSIM with the Wang et al. Gaussian settings.
    std::ofstream f(script);
    f << "import sys, numpy as np\n"
         "from skimage.metrics import structural_similarity, peak_signal_noise_ratio\n"
         "w, h = int(sys.argv[3]), int(sys.argv[4])\n"
         "def load(p):\n"
         "    v = np.fromfile(p, dtype=np.float32).astype(np.float64).reshape(h, w, 3)\n"
         "    v = np.clip(v, 0.0, 1.0)\n"
         "    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)\n"
         "a, b = load(sys.argv[1]), load(sys.argv[2])\n"
         "s = structural_similarity(a, b, channel_axis=-1, gaussian_weights=True, sigma=1.5,\n"
         "                          use_sample_covariance=False, data_range=1.0)\n"
         "p = peak_signal_noise_ratio(a, b, data_range=1.0)\n"
         "print('%.12f %.12f' % (s, p))\n";
  }
  struct Case {
    int w, h;
    float noise;
    unsigned seed;
  };
  // Odd sizes and a size barely above the window exercise the reflected border and crop.
  for (const Case& k : {Case{64, 48, 0.05f, 7}, Case{37, 23, 0.2f, 8}, Case{12, 11, 0.1f, 9}}) {
    const Image a = pattern(k.w, k.h, k.seed, k.noise);
    Image b = k.w >= 40 ? perturb(a, k.seed + 100, 0.08f) : pattern(k.w, k.h, k.seed + 1, k.noise);
    write_raw(dir / "a.raw", a);
    write_raw(dir / "b.raw", b);
    const std::string cmd = py + " " + script.string() + " " + (dir / "a.raw").string() + " " +
                            (dir / "b.raw").string() + " " + std::to_string(k.w) + " " + std::to_string(k.h) + " > " +
                            (dir / "out.txt").string();
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    std::ifstream out(dir / "out.txt");
    double s_ref = 0, p_ref = 0;
    ASSERT_TRUE(out >> s_ref >> p_ref);
    const double s = metrics::ssim(a, b), p = metrics::psnr(a, b);
    EXPECT_NEAR(s, s_ref, 1e-4) << k.w << "x" << k.h;
    EXPECT_NEAR(p, p_ref, 1e-4) << k.w << "x" << k.h;
    EXPECT_LT(s, 0.999);  // the pair really differs
    std::printf("%dx%d: SSIM %.9f (skimage %.9f), PSNR %.6f dB (skimage %.6f)\n", k.w, k.h, s, s_ref, p, p_ref);
  }
}
