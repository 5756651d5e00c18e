// Unreadable inputs: each error is a dofkit::Error(bad_input) whose one-line message names
// the file and the problem.
#include <gtest/gtest.h>

#include <OpenImageIO/deepdata.h>

#include <cstdint>
#include <functional>

#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "io/layers_io.hpp"
#include "io/io_test_util.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::uint32_t crc32(const std::string& data) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (unsigned char b : data) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}

void put_be32(std::string& s, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s[at + i] = static_cast<char>((v >> (24 - 8 * i)) & 0xFF);
}

}  // namespace

TEST(ReadErrors, MissingFile) {
  ScratchDir dir;
  const std::string m = bad_input_message([&] { io::read_color(dir / "nope.exr"); });
  EXPECT_TRUE(contains(m, "nope.exr")) << m;
  EXPECT_TRUE(contains(m, "does not exist")) << m;
  EXPECT_TRUE(contains(bad_input_message([&] { io::read_depth(dir / "z.exr", {}); }), "z.exr"));
}

TEST(ReadErrors, FolderInsteadOfFile) {
  ScratchDir dir;
  const std::string m = bad_input_message([&] { io::read_color(dir.path().string()); });
  EXPECT_TRUE(contains(m, "folder")) << m;
}

TEST(ReadErrors, CorruptFile) {
  ScratchDir dir;
  write_bytes(dir / "junk.exr", std::string(300, '\x5a'));
  const std::string m = bad_input_message([&] { io::read_color(dir / "junk.exr"); });
  EXPECT_TRUE(contains(m, "junk.exr")) << m;
  write_bytes(dir / "junk.png", "\x89PNG\r\n\x1a\nthis is not a png at all");
  EXPECT_TRUE(contains(bad_input_message([&] { io::read_color(dir / "junk.png"); }), "junk.png"));
}

TEST(ReadErrors, TruncatedExr) {
  ScratchDir dir;
  io::write_image(dir / "full.exr", test_rgba(64, 64, false, true));
  const std::string bytes = read_bytes(dir / "full.exr");
  write_bytes(dir / "cut.exr", bytes.substr(0, bytes.size() / 2));
  const std::string m = bad_input_message([&] { io::read_color(dir / "cut.exr"); });
  EXPECT_TRUE(contains(m, "cut.exr")) << m;
}

TEST(ReadErrors, TruncatedPng) {
  ScratchDir dir;
  io::write_image(dir / "full.png", test_rgba(64, 64));
  const std::string bytes = read_bytes(dir / "full.png");
  write_bytes(dir / "cut.png", bytes.substr(0, bytes.size() / 2));
  const std::string m = bad_input_message([&] { io::read_color(dir / "cut.png"); });
  EXPECT_TRUE(contains(m, "cut.png")) << m;
}

TEST(ReadErrors, HugeHeaderRefusedBeforeAllocating) {
  ScratchDir dir;
  io::write_image(dir / "small.png", test_rgba(4, 4));
  std::string bytes = read_bytes(dir / "small.png");
  // IHDR is the first chunk: 8-byte signature, length, "IHDR", width, height, …, CRC over
  // type + data. Claim 40000 × 40000 = 1.6e9 pixels (> 2^28) with a valid CRC, so only our
  // limit can stop it (allocating it as float RGBA would need 25 GB).
  ASSERT_EQ(bytes.substr(12, 4), "IHDR");
  put_be32(bytes, 16, 40000);
  put_be32(bytes, 20, 40000);
  put_be32(bytes, 29, crc32(bytes.substr(12, 17)));
  write_bytes(dir / "huge.png", bytes);
  const std::string m = bad_input_message([&] { io::read_color(dir / "huge.png"); });
  EXPECT_TRUE(contains(m, "huge.png")) << m;
  EXPECT_TRUE(contains(m, "40000x40000")) << m;
  EXPECT_TRUE(contains(bad_input_message([&] { io::read_depth(dir / "huge.png", {}); }), "limit"));
}

TEST(ReadErrors, TooManyChannelsRefused) {
  ScratchDir dir;
  std::vector<std::string> names;
  for (int c = 0; c < 65; ++c) names.push_back("c" + std::to_string(c));
  raw_write(dir / "wide.exr", 1, 1, names, std::vector<float>(65, 1.0f));
  const std::string m = bad_input_message([&] { io::read_color(dir / "wide.exr"); });
  EXPECT_TRUE(contains(m, "65 channels")) << m;
}

TEST(ReadErrors, SizeMismatch) {
  ScratchDir dir;
  io::write_image(dir / "c.exr", test_rgba(8, 6));
  raw_write(dir / "z.exr", 8, 5, {"Z"}, std::vector<float>(40, 2.0f));
  const std::string m = bad_input_message([&] { io::load_frame(dir / "c.exr", dir / "z.exr", {}); });
  EXPECT_TRUE(contains(m, "z.exr")) << m;
  EXPECT_TRUE(contains(m, "8x5")) << m;
  EXPECT_TRUE(contains(m, "8x6")) << m;
}

TEST(ReadErrors, DeepFileIsPointedToLayers) {
  ScratchDir dir;
  OIIO::ImageSpec spec(2, 2, 5, OIIO::TypeDesc::FLOAT);
  spec.channelnames = {"R", "G", "B", "A", "Z"};
  spec.alpha_channel = 3;
  spec.z_channel = 4;
  spec.deep = true;
  OIIO::DeepData dd;
  dd.init(spec);
  auto out = OIIO::ImageOutput::create(dir / "deep.exr");
  ASSERT_TRUE(out && out->open(dir / "deep.exr", spec));
  ASSERT_TRUE(out->write_deep_image(dd)) << out->geterror();
  out->close();
  const std::string m = bad_input_message([&] { io::read_color(dir / "deep.exr"); });
  EXPECT_TRUE(contains(m, "--layers")) << m;
}

TEST(PixelBudget, IsConfigurableAndCheckedFromTheHeader) {
  const std::string dir = ::testing::TempDir();
  const std::string path = dir + "/budget_8x8.exr";
  dofkit::io::write_image(path, dofkit::Image(8, 8, 4, 0.5f));
  dofkit::io::set_pixel_budget(63);
  try {
    (void)dofkit::io::read_color(path);
    ADD_FAILURE() << "an 8x8 image must exceed a budget of 63 pixels";
  } catch (const dofkit::Error& e) {
    EXPECT_EQ(e.kind(), dofkit::ErrorKind::bad_input);
    EXPECT_NE(std::string(e.what()).find("--max-pixels"), std::string::npos) << e.what();
  }
  dofkit::io::set_pixel_budget(64);
  EXPECT_EQ(dofkit::io::read_color(path).width(), 8);
  EXPECT_THROW(dofkit::io::set_pixel_budget(0), dofkit::Error);
  dofkit::io::set_pixel_budget(dofkit::io::kMaxPixels);
}

// Only EXR, PNG, JPEG and TIFF are read (issue 37): a BMP, GIF or Radiance HDR that
// OpenImageIO would decode without dofkit's header checks is refused by its first bytes,
// whatever its name; an empty file too.
TEST(ReadErrors, OtherFormatsAreRefused) {
  ScratchDir dir;
  for (const char* name : {"a.bmp", "a.hdr", "a.tga"}) {
    raw_write(dir / name, 4, 4, {"R", "G", "B"}, std::vector<float>(48, 0.5f), OIIO::TypeDesc::UINT8);
    const std::string renamed = dir / (std::string(name) + ".exr");
    std::filesystem::copy_file(dir / name, renamed);
    for (const std::string& path : {dir / name, renamed}) {
      const std::string m = bad_input_message([&] { io::read_color(path); });
      EXPECT_TRUE(contains(m, path + ": cannot read colour image: not an EXR, PNG, JPEG or TIFF file")) << m;
    }
  }
  write_bytes(dir / "empty.png", "");
  EXPECT_TRUE(contains(bad_input_message([&] { io::read_depth(dir / "empty.png", {}); }), "(it is empty)"));
}

// A channel whose pixel type is not uint / half / float (fuzz_layers, issue 37's fuzzing):
// OpenImageIO 2.4 aborted on an assertion ("Unknown Imf::PixelType 3") when it opened the
// file; the header walk refuses it in one line, for every reader.
TEST(ReadErrors, UnknownExrPixelTypeIsRefused) {
  ScratchDir dir;
  raw_write(dir / "ok.exr", 4, 4, {"R", "G", "B"}, std::vector<float>(48, 0.5f), OIIO::TypeDesc::FLOAT);
  std::string bytes = read_bytes(dir / "ok.exr");
  const std::size_t list = bytes.find(std::string("chlist\0", 7));
  ASSERT_NE(list, std::string::npos);
  // chlist\0, int32 size, then the first channel's name "B\0" and its int32 type.
  const std::size_t type_at = list + 7 + 4 + 2;
  ASSERT_EQ(bytes[type_at], 2);  // FLOAT
  bytes[type_at] = 3;
  write_bytes(dir / "bad.exr", bytes);
  for (const auto& read : std::vector<std::function<void()>>{[&] { io::read_color(dir / "bad.exr"); },
                                                             [&] { io::read_depth(dir / "bad.exr", {}); },
                                                             [&] {
                                                               Frame f;
                                                               io::read_layers(dir / "bad.exr", f);
                                                             }}) {
    const std::string m = bad_input_message(read);
    EXPECT_TRUE(contains(m, "bad.exr")) << m;
    EXPECT_TRUE(contains(m, "malformed channel list")) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}
