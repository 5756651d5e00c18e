// The shared aperture model (src/core/aperture.hpp): conventions, exactness of its spans and
// normaliser against brute force, and the validation messages.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "core/aperture.hpp"
#include "dofkit/error.hpp"

namespace dofkit::core {
namespace {

constexpr double kPi = std::numbers::pi;

ApertureShape poly(int blades, double rot = 0, double curv = 0, double ana = 1, double eye = 0) {
  ApertureShape a;
  a.blades = blades;
  a.rotation_deg = rot;
  a.curvature = curv;
  a.anamorphic = ana;
  a.cat_eye = eye;
  return a;
}

std::shared_ptr<const Image> disc_image(int n, int blades = 0) {
  auto img = std::make_shared<Image>(n, n, 1, 0.0f);
  const ApertureModel shape(poly(blades), 0, 0);
  // 4×4 supersampled coverage of the unit footprint (far field).
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double acc = 0;
      for (int sj = 0; sj < 4; ++sj)
        for (int si = 0; si < 4; ++si)
          acc += shape.unit_transmission(-1 + 2.0 * (i + (si + 0.5) / 4) / n, -1 + 2.0 * (j + (sj + 0.5) / 4) / n,
                                         Field::far);
      img->at(i, j) = static_cast<float>(acc / 16);
    }
  return img;
}

struct Case {
  std::string name;
  ApertureShape shape;
};

std::vector<Case> cases() {
  std::vector<Case> v{{"circle", poly(0)},
                      {"pentagon rot 10", poly(5, 10)},
                      {"hexagon curved 0.4", poly(6, -25, 0.4)},
                      {"triangle", poly(3, 7)},
                      {"octagon anamorphic 2", poly(8, 10, 0, 2.0)},
                      {"oval 0.5", poly(0, 0, 0, 0.5)},
                      {"heptagon cat-eye", poly(7, 33, 0.2, 1.3, 0.8)}};
  ApertureShape img;
  img.image = disc_image(48, 6);
  img.rotation_deg = 20;
  v.push_back({"image hexagon rot 20", img});
  return v;
}

// Brute-force checks of (a)–(d) for one footprint.
void check_footprint(const ApertureModel& m, float rho, Field f, float sx, float sy, const std::string& what) {
  const int r = m.reach(rho);
  const int box = r + 3;
  double sum = 0;
  for (int dy = -box; dy <= box; ++dy) {
    const Span o = m.row_span(dy, rho, f, sx, sy);
    const Span in = m.row_interior(dy, rho, f, sx, sy);
    for (int dx = -box; dx <= box; ++dx) {
      for (int c = 0; c < m.channels(); ++c) {
        const float cov = m.coverage(dx, dy, rho, f, sx, sy, c);
        ASSERT_GE(cov, 0.0f);
        ASSERT_LE(cov, 1.0f);
        if (cov > 0) {
          ASSERT_LE(std::abs(dx), r) << what;
          ASSERT_LE(std::abs(dy), r) << what;
          ASSERT_TRUE(!o.empty() && dx >= o.x0 && dx <= o.x1) << what << " dx " << dx << " dy " << dy;
        }
        if (!in.empty() && dx >= in.x0 && dx <= in.x1) ASSERT_EQ(cov, 1.0f) << what << " dx " << dx << " dy " << dy;
        if (c == 0) sum += cov;
      }
      // Near field = the far footprint point-reflected (with the cat's eye turned too).
      if (f == Field::near)
        ASSERT_EQ(m.coverage(dx, dy, rho, Field::near, sx, sy), m.coverage(-dx, -dy, rho, Field::far, sx, sy)) << what;
    }
  }
  EXPECT_NEAR(m.weight_sum(rho, f, sx, sy), sum, 1e-9 * sum) << what;
  const ApertureModel::Kernel k = m.kernel(rho, f, sx, sy);
  EXPECT_NEAR(k.sum, sum, 1e-9 * sum) << what;
  EXPECT_EQ(k.reach, r);
}

TEST(Aperture, SpansInteriorAndNormaliserMatchBruteForce) {
  for (const Case& c : cases()) {
    const ApertureModel m(c.shape, 320, 180);
    for (float rho : {0.5f, 0.8f, 2.3f, 7.5f, 16.2f})
      for (Field f : {Field::far, Field::near})
        for (auto [sx, sy] : {std::pair{160.5f, 90.5f}, std::pair{3.5f, 2.5f}, std::pair{300.5f, 170.5f}})
          check_footprint(m, rho, f, sx, sy, c.name + " rho " + std::to_string(rho));
  }
}

TEST(Aperture, InFocusFootprintIsTheCentrePixel) {
  for (const Case& c : cases()) {
    const ApertureModel m(c.shape, 320, 180);
    for (Field f : {Field::far, Field::near})
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          const float cov = m.coverage(dx, dy, 0.5f, f, 1.5f, 1.5f);
          if (dx == 0 && dy == 0)
            EXPECT_GT(cov, 0.4f) << c.name;
          else
            EXPECT_EQ(cov, 0.0f) << c.name << " " << dx << "," << dy;
        }
  }
}

TEST(Aperture, CircleIsTheReferencesDisc) {
  const ApertureModel m;
  EXPECT_TRUE(m.is_circle());
  for (float rho : {0.5f, 3.7f, 11.0f})
    for (int dy = -13; dy <= 13; ++dy)
      for (int dx = -13; dx <= 13; ++dx) {
        const float d = std::sqrt(float(dx) * dx + float(dy) * dy);
        EXPECT_EQ(m.coverage(dx, dy, rho, Field::far), std::min(std::max(rho + 0.5f - d, 0.0f), 1.0f));
      }
}

// Blender's conventions (external-gt README): rotation 0, far field: a flat edge faces +x;
// rotation turns counter-clockwise on screen (y down in pixels); near field turned by 180°.
TEST(Aperture, PolygonConventionIsBlenders) {
  const float rho = 100;
  const ApertureModel p5(poly(5), 0, 0);
  // Edge midpoint at +x (apothem cos 36° = 0.809): just outside / inside.
  EXPECT_EQ(p5.coverage(85, 0, rho, Field::far), 0.0f);
  EXPECT_EQ(p5.coverage(78, 0, rho, Field::far), 1.0f);
  // A vertex at 180°: −x reaches almost the full radius.
  EXPECT_EQ(p5.coverage(-97, 0, rho, Field::far), 1.0f);
  // Vertex at 36° counter-clockwise = up and right on screen (y negative).
  EXPECT_EQ(
      p5.coverage(static_cast<int>(97 * std::cos(kPi / 5)), -static_cast<int>(97 * std::sin(kPi / 5)), rho, Field::far),
      1.0f);
  // Near field: point-reflected (flat edge faces −x).
  EXPECT_EQ(p5.coverage(-85, 0, rho, Field::near), 0.0f);
  EXPECT_EQ(p5.coverage(97, 0, rho, Field::near), 1.0f);
  // Rotation +90° (counter-clockwise): the flat edge faces up (−y on screen), a vertex points down.
  const ApertureModel r90(poly(5, 90), 0, 0);
  EXPECT_EQ(r90.coverage(0, -85, rho, Field::far), 0.0f);
  EXPECT_EQ(r90.coverage(0, 97, rho, Field::far), 1.0f);
  // Vertices on the circle of radius rho: area n/(2π)·sin(2π/n) of the disc's.
  for (int n : {3, 5, 6, 8, 16}) {
    const ApertureModel m(poly(n, 13), 0, 0);
    const double want = n / (2 * kPi) * std::sin(2 * kPi / n);
    EXPECT_NEAR(m.weight_sum(40, Field::far) / ApertureModel().weight_sum(40, Field::far), want, 0.01) << n;
  }
  // Curvature 1 is the circle; 0.5 lies between.
  const double circle = ApertureModel().weight_sum(30, Field::far);
  EXPECT_NEAR(ApertureModel(poly(6, 0, 1.0), 0, 0).weight_sum(30, Field::far), circle, 1e-9);
  const double half = ApertureModel(poly(6, 0, 0.5), 0, 0).weight_sum(30, Field::far);
  EXPECT_GT(half, ApertureModel(poly(6), 0, 0).weight_sum(30, Field::far) + 10);
  EXPECT_LT(half, circle - 10);
}

TEST(Aperture, AnamorphicSqueezesHorizontally) {
  const ApertureModel m(poly(0, 0, 0, 2.0), 0, 0);  // Blender's aperture ratio 2: half as wide
  EXPECT_EQ(m.coverage(0, 38, 40, Field::far), 1.0f);
  EXPECT_EQ(m.coverage(19, 0, 40, Field::far), 1.0f);
  EXPECT_EQ(m.coverage(22, 0, 40, Field::far), 0.0f);
  EXPECT_NEAR(m.weight_sum(40, Field::far) / ApertureModel().weight_sum(40, Field::far), 0.5, 0.01);
}

TEST(Aperture, CatEyeClipsTowardTheCentre) {
  const ApertureModel m(poly(0, 0, 0, 1, 1.0), 400, 300);
  const float rho = 20;
  // At the centre: the plain disc.
  EXPECT_NEAR(m.weight_sum(rho, Field::far, 200, 150), ApertureModel().weight_sum(rho, Field::far), 1e-6);
  // At the top-left corner: smaller, and its centroid lies toward the centre (+x, +y) in the
  // far field, away from it in the near field.
  for (Field f : {Field::far, Field::near}) {
    const ApertureModel::Kernel k = m.kernel(rho, f, 0.5f, 0.5f);
    double cx = 0, cy = 0;
    for (int dy = -k.reach; dy <= k.reach; ++dy)
      for (int dx = -k.reach; dx <= k.reach; ++dx) cx += dx * k.at(dx, dy), cy += dy * k.at(dx, dy);
    cx /= k.sum;
    cy /= k.sum;
    EXPECT_LT(k.sum, 0.5 * ApertureModel().weight_sum(rho, Field::far));
    const double sign = f == Field::far ? 1 : -1;
    EXPECT_GT(sign * cx, 3.0);
    EXPECT_GT(sign * cy, 2.0);
  }
}

TEST(Aperture, ImageOfADiscMatchesTheCircle) {
  ApertureShape a;
  a.image = disc_image(256);
  const ApertureModel m(a, 0, 0);
  EXPECT_TRUE(m.has_image());
  EXPECT_EQ(m.channels(), 1);
  const ApertureModel c;
  for (float rho : {3.0f, 9.5f, 25.0f}) {
    EXPECT_NEAR(m.weight_sum(rho, Field::far), c.weight_sum(rho, Field::far), 0.01 * c.weight_sum(rho, Field::far));
    double worst = 0;
    for (int dy = -30; dy <= 30; ++dy)
      for (int dx = -30; dx <= 30; ++dx)
        worst = std::max(worst,
                         double(std::abs(m.coverage(dx, dy, rho, Field::far) - c.coverage(dx, dy, rho, Field::far))));
    EXPECT_LT(worst, 0.35) << rho;  // rim pixels only: box filter against the linear ramp
  }
}

TEST(Aperture, RgbImageKeepsOneKernelPerChannel) {
  auto img = std::make_shared<Image>(16, 16, 3, 0.0f);
  for (int y = 4; y < 12; ++y)
    for (int x = 4; x < 12; ++x) img->at(x, y, 0) = img->at(x, y, 1) = 1.0f;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) img->at(x, y, 2) = 1.0f;  // blue: the whole square
  ApertureShape a;
  a.image = img;
  const ApertureModel m(a, 0, 0);
  EXPECT_EQ(m.channels(), 3);
  EXPECT_NEAR(m.weight_sum(16, Field::far, 0, 0, 2), 4 * m.weight_sum(16, Field::far, 0, 0, 0), 0.05 * 4 * 256);
}

TEST(Aperture, KernelBankHoldsTheModelsRasters) {
  ApertureShape a;
  a.image = disc_image(40, 5);
  a.rotation_deg = 15;
  a.anamorphic = 1.5;
  const ApertureModel m(a, 0, 0);
  const KernelBank bank(m, 9.0f, 0, 16);
  for (float rho : {0.5f, 2.2f, 8.9f}) {
    const int b = bank.bucket(rho);
    EXPECT_LE(std::abs(bank.bucket_rho(b) - rho), bank.step() / 2 + 1e-6f);
    const ApertureModel::Kernel k = m.kernel(bank.bucket_rho(b), Field::far);
    ASSERT_EQ(bank.reach(b), k.reach);
    EXPECT_DOUBLE_EQ(bank.sum(b), k.sum);
    const int r = k.reach;
    for (int dy = -r; dy <= r; ++dy) {
      const Span sf = bank.row_span(b, Field::far, dy), sn = bank.row_span(b, Field::near, dy);
      for (int pad : {-r - 16, r + 16}) {
        ASSERT_EQ(bank.raster(b, Field::far)[(dy + r) * bank.pitch(b) + pad + r], 0.0f);
        ASSERT_EQ(bank.raster(b, Field::near)[(dy + r) * bank.pitch(b) + pad + r], 0.0f);
      }
      for (int dx = -r; dx <= r; ++dx) {
        const float far = bank.raster(b, Field::far)[(dy + r) * bank.pitch(b) + dx + r];
        const float near = bank.raster(b, Field::near)[(dy + r) * bank.pitch(b) + dx + r];
        ASSERT_EQ(far, k.at(dx, dy));
        ASSERT_EQ(near, k.at(-dx, -dy));
        if (far > 0) ASSERT_TRUE(dx >= sf.x0 && dx <= sf.x1);
        if (near > 0) ASSERT_TRUE(dx >= sn.x0 && dx <= sn.x1);
      }
    }
  }
}

TEST(Aperture, BoundaryMapPutsTheUnitCircleOnTheShape) {
  for (const Case& c : cases()) {
    if (c.shape.image) continue;
    const ApertureModel m(c.shape, 0, 0);
    for (int k = 0; k < 64; ++k) {
      const double a = 2 * kPi * k / 64;
      double x, y;
      m.unit_boundary_map(std::cos(a), std::sin(a), x, y);
      EXPECT_EQ(m.unit_transmission(0.999 * x, 0.999 * y, Field::far), 1.0) << c.name;
      EXPECT_EQ(m.unit_transmission(1.001 * x, 1.001 * y, Field::far), 0.0) << c.name;
    }
  }
}

void expect_usage(const ApertureShape& a, const std::string& flag) {
  try {
    validate(a);
    FAIL() << "no error for " << flag;
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::usage);
    EXPECT_EQ(std::string(e.what()).rfind(flag + ":", 0), 0u) << e.what();
  }
}

TEST(Aperture, BadSettingsNameTheirFlag) {
  for (int b : {1, 2, 17, -3}) expect_usage(poly(b), "--blades");
  expect_usage(poly(6, NAN), "--blade-rotation");
  expect_usage(poly(6, 0, -0.1), "--blade-curvature");
  expect_usage(poly(6, 0, 1.5), "--blade-curvature");
  expect_usage(poly(6, 0, 0, 0), "--anamorphic");
  expect_usage(poly(6, 0, 0, INFINITY), "--anamorphic");
  expect_usage(poly(6, 0, 0, 1, 2), "--cat-eye");
  ApertureShape a;
  a.image = std::make_shared<Image>();
  expect_usage(a, "--aperture-image");
  a.image = std::make_shared<Image>(8, 8, 1, 0.0f);
  expect_usage(a, "--aperture-image");
  a.image = std::make_shared<Image>(1025, 4, 1, 1.0f);
  expect_usage(a, "--aperture-image");
  auto nan_img = std::make_shared<Image>(4, 4, 1, 1.0f);
  nan_img->at(1, 1) = NAN;
  a.image = nan_img;
  expect_usage(a, "--aperture-image");
  HighlightRecovery h;
  h.boost = INFINITY;
  EXPECT_THROW(validate(h), Error);
  h.boost = 1;
  h.threshold = 1;
  EXPECT_THROW(validate(h), Error);
  for (int b : {0, 3, 16}) EXPECT_NO_THROW(validate(poly(b)));
}

}  // namespace
}  // namespace dofkit::core
