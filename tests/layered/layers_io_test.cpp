// Round trips of the multi-fragment inputs: dofkit's flat layered EXR and deep EXR.
//
// The deep file is written with OpenImageIO's deep ImageOutput (which drives OpenEXR's
// DeepScanLineOutputFile underneath): the test executables link OpenImageIO but not
// OpenEXR::OpenEXR directly, so calling Imf:: from here would not link.
#include <gtest/gtest.h>

#include <OpenImageIO/deepdata.h>
#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include "dofkit/error.hpp"
#include "io/layers_io.hpp"

namespace {

using dofkit::Frame;
using dofkit::Image;
constexpr float kInf = std::numeric_limits<float>::infinity();

std::string temp_path(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / "dofkit_test_layered";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

Frame make_layers(int w, int h, int n) {
  Frame f;
  for (int l = 0; l < n; ++l) {
    Image c(w, h, 4, 0.0f), z(w, h, 1, kInf);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        if ((x + y + l) % 3 == 0 && l > 0) continue;  // missing fragment
        const float a = l == 0 ? 1.0f : 0.25f + 0.1f * l;
        c.at(x, y, 0) = a * (0.1f + 0.01f * x);
        c.at(x, y, 1) = a * (0.2f + 0.02f * y);
        c.at(x, y, 2) = a * 0.3f * l;
        c.at(x, y, 3) = a;
        z.at(x, y) = 1.0f + l + 0.001f * x;
      }
    f.layer_color.push_back(c);
    f.layer_depth.push_back(z);
  }
  return f;
}

TEST(LayersIo, FlatLayeredExrRoundTrips) {
  const Frame in = make_layers(13, 7, 3);
  const std::string path = temp_path("flat.exr");
  dofkit::io::write_layers_exr(path, in);
  Frame out;
  dofkit::io::read_layers(path, out, 8);
  ASSERT_EQ(out.layer_color.size(), 3u);
  for (int l = 0; l < 3; ++l) {
    EXPECT_EQ(out.layer_color[l].data(), in.layer_color[l].data()) << "layer " << l;
    EXPECT_EQ(out.layer_depth[l].data(), in.layer_depth[l].data()) << "layer " << l;
  }
  // Visible colour / depth were derived: layer 0 is opaque, so they equal layer 0.
  EXPECT_EQ(out.color.data(), in.layer_color[0].data());
  EXPECT_EQ(out.depth.data(), in.layer_depth[0].data());
  // A cap keeps the nearest layers.
  Frame capped;
  dofkit::io::read_layers(path, capped, 2);
  ASSERT_EQ(capped.layer_color.size(), 2u);
  EXPECT_EQ(capped.layer_depth[1].data(), in.layer_depth[1].data());
}

TEST(LayersIo, DeepExrRoundTripsIntoSortedFragments) {
  const int w = 9, h = 5;
  OIIO::ImageSpec spec(w, h, 5, OIIO::TypeDesc::FLOAT);
  spec.channelnames = {"R", "G", "B", "A", "Z"};
  spec.alpha_channel = 3;
  spec.z_channel = 4;
  spec.deep = true;
  OIIO::DeepData dd;
  dd.init(spec);
  // Pixel p gets p % 4 samples written back to front (the reader must sort them).
  auto sample_z = [](int p, int s) { return 2.0f + 0.5f * s + 0.01f * p; };
  for (int p = 0; p < w * h; ++p) dd.set_samples(p, p % 4);
  for (int p = 0; p < w * h; ++p)
    for (int s = 0; s < p % 4; ++s) {
      const int slot = (p % 4) - 1 - s;  // reversed order in the file
      const float a = 0.5f + 0.1f * s;
      dd.set_deep_value(p, 0, slot, a * 0.1f * p / (w * h));
      dd.set_deep_value(p, 1, slot, a * 0.2f * s);
      dd.set_deep_value(p, 2, slot, a * 0.7f);
      dd.set_deep_value(p, 3, slot, a);
      dd.set_deep_value(p, 4, slot, sample_z(p, s));
    }
  const std::string path = temp_path("deep.exr");
  {
    auto out = OIIO::ImageOutput::create(path);
    ASSERT_TRUE(out);
    ASSERT_TRUE(out->supports("deepdata"));
    ASSERT_TRUE(out->open(path, spec)) << out->geterror();
    ASSERT_TRUE(out->write_deep_image(dd)) << out->geterror();
    ASSERT_TRUE(out->close());
  }
  Frame f;
  dofkit::io::read_layers(path, f, 8);
  ASSERT_EQ(f.layer_color.size(), 3u);
  ASSERT_EQ(f.width(), w);
  for (int p = 0; p < w * h; ++p) {
    const int x = p % w, y = p / w;
    for (int s = 0; s < 3; ++s) {
      if (s < p % 4) {
        const float a = 0.5f + 0.1f * s;
        EXPECT_FLOAT_EQ(f.layer_depth[s].at(x, y), sample_z(p, s)) << p << " " << s;
        EXPECT_FLOAT_EQ(f.layer_color[s].at(x, y, 3), a);
        EXPECT_FLOAT_EQ(f.layer_color[s].at(x, y, 0), a * 0.1f * p / (w * h));
        EXPECT_FLOAT_EQ(f.layer_color[s].at(x, y, 1), a * 0.2f * s);
        EXPECT_FLOAT_EQ(f.layer_color[s].at(x, y, 2), a * 0.7f);
      } else {
        EXPECT_EQ(f.layer_color[s].at(x, y, 3), 0.0f);
        EXPECT_EQ(f.layer_depth[s].at(x, y), kInf);
      }
    }
    // Visible colour = front-to-back over of the samples; depth = nearest sample.
    float acc = 0, ab = 0;
    for (int s = 0; s < p % 4; ++s) {
      const float a = 0.5f + 0.1f * s;
      ab += (1 - acc) * a * 0.7f;
      acc += (1 - acc) * a;
    }
    EXPECT_NEAR(f.color.at(x, y, 3), acc, 1e-6);
    EXPECT_NEAR(f.color.at(x, y, 2), ab, 1e-6);
    EXPECT_EQ(f.depth.at(x, y), p % 4 ? sample_z(p, 0) : kInf);
  }
}

TEST(LayersIo, FileWithoutLayersIsBadInput) {
  const std::string path = temp_path("plain.exr");
  OIIO::ImageSpec spec(4, 4, 3, OIIO::TypeDesc::FLOAT);
  std::vector<float> px(48, 0.5f);
  auto out = OIIO::ImageOutput::create(path);
  ASSERT_TRUE(out && out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, px.data()) && out->close());
  Frame f;
  try {
    dofkit::io::read_layers(path, f, 8);
    FAIL() << "expected an error";
  } catch (const dofkit::Error& e) {
    EXPECT_EQ(e.kind(), dofkit::ErrorKind::bad_input);
    EXPECT_NE(std::string(e.what()).find("plain.exr"), std::string::npos);
  }
  EXPECT_THROW(dofkit::io::read_layers(temp_path("missing.exr"), f, 8), dofkit::Error);
}

}  // namespace
