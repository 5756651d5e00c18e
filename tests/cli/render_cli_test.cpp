// `dofkit render`, run in-process through the same CLI11 command the binary registers (the
// binary itself is spawned only by the few end-to-end cases at the bottom).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <sstream>

#include "commands.hpp"
#include "dofkit/coc.hpp"
#include "dofkit/error.hpp"
#include "dofkit/render.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/layers_io.hpp"
#include "render_cli_util.hpp"

using namespace dofkit;
using namespace dofkit::test;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A 160×90 test frame: colour with detail; depth = 10 m background, a 2 m box, an infinitely
// far strip on the left and a 0.5 m corner (beyond the ±40 px clamp of the exact call).
// (160 px wide so the library's absolute cap of a quarter of the width is not below 40 px.)
constexpr int W = 160, H = 90;
constexpr int kBox = 45 * W + 80, kBackground = 10 * W + 130, kInfinite = 10 * W + 2, kCorner = 89 * W + 159;
class RenderCli : public ::testing::Test {
 protected:
  void SetUp() override {
    color_ = test_rgba(W, H, true, true);
    depth_ = Image(W, H, 1, 10.0f);
    for (int y = 25; y < 65; ++y)
      for (int x = 50; x < 110; ++x) depth_.at(x, y) = 2.0f;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < 6; ++x) depth_.at(x, y) = kInf;
    depth_.at(W - 1, H - 1) = 0.5f;
    io::write_image(dir_ / "c.exr", color_);
    io::WriteOptions z;
    z.channel_name = "Z";
    io::write_image(dir_ / "z.exr", depth_, z);
  }

  std::vector<std::string> exact_call(const std::string& out = "out.exr") const {
    return {"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus",   "4",        "--blur-at-infinity",
            "24",      "--max-coc",    "40",      "--method",     "reference", "--output", dir_ / out};
  }

  // Expects a failure with `code` whose message contains every part, and that no file but
  // the inputs (and `keep`) is in the folder afterwards.
  void expect_failure(const std::vector<std::string>& args, int code, std::initializer_list<const char*> parts,
                      std::vector<std::string> keep = {}) {
    const CliResult r = run_render(args);
    EXPECT_EQ(r.code, code) << r.message;
    for (const char* p : parts) EXPECT_TRUE(contains(r.message, p)) << "missing '" << p << "' in: " << r.message;
    EXPECT_FALSE(contains(r.message, "\n")) << r.message;
    keep.insert(keep.end(), {"c.exr", "z.exr"});
    std::sort(keep.begin(), keep.end());
    keep.erase(std::unique(keep.begin(), keep.end()), keep.end());
    EXPECT_EQ(dir_.entries(), keep) << "an output or temporary file was left behind";
  }

  ScratchDir dir_;
  Image color_, depth_;
};

}  // namespace

TEST_F(RenderCli, ExactCallMatchesLibraryRender) {
  const CliResult r = run_render(exact_call());
  ASSERT_EQ(r.code, 0) << r.message;
  const Image out = io::read_color(dir_ / "out.exr");
  Frame f{color_, depth_, {}, {}};
  RenderSettings s;
  s.method = "reference";
  s.camera.model = BlurAtInfinity{4.0, 24.0};
  s.camera.max_coc_px = 40;
  const RenderResult want = render(f, s);
  ASSERT_TRUE(out.same_size(want.image));
  EXPECT_EQ(out.data(), want.image.data());  // float EXR: bit-exact
  EXPECT_EQ(dir_.entries(), (std::vector<std::string>{"c.exr", "out.exr", "z.exr"}));
}

// The CoC map's extension check is case-insensitive, like every other output's: COC.EXR is
// an EXR (it was refused), coc.bmp is refused (a .png is the focus-zone picture:
// render_inputs_test.cpp).
TEST_F(RenderCli, OutputCocExtensionIgnoresCase) {
  auto args = exact_call();
  args.insert(args.end(), {"--output-coc", dir_ / "COC.EXR"});
  const auto ok = run_render(args);
  ASSERT_EQ(ok.code, 0) << ok.message;
  auto in = OIIO::ImageInput::open(dir_ / "COC.EXR");
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().format, OIIO::TypeDesc::FLOAT);
  in.reset();
  std::filesystem::remove(dir_ / "COC.EXR");
  std::filesystem::remove(dir_ / "out.exr");
  auto bad = exact_call();
  bad.insert(bad.end(), {"--output-coc", dir_ / "coc.bmp"});
  expect_failure(bad, 2, {"--output-coc", "coc.bmp", "unsupported"});
}

TEST_F(RenderCli, OutputCocIsSignedFloatPixels) {
  auto args = exact_call();
  args.insert(args.end(), {"--output-coc", dir_ / "coc.exr", "--threads", "2"});
  ASSERT_EQ(run_render(args).code, 0);
  auto in = OIIO::ImageInput::open(dir_ / "coc.exr");
  ASSERT_TRUE(in);
  EXPECT_EQ(in->spec().nchannels, 1);
  EXPECT_EQ(in->spec().format, OIIO::TypeDesc::FLOAT);
  // r(z) = 24 (4/z − 1), clamped to ±40: z = 2 → +24; z = 10 → −14.4; z = ∞ → −24.
  std::vector<float> raw(W * H);
  ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, raw.data()));
  EXPECT_NEAR(raw[kBox], 24.0f, 1e-4);
  EXPECT_NEAR(raw[kBackground], -14.4f, 1e-4);
  EXPECT_NEAR(raw[kInfinite], -24.0f, 1e-4);
  EXPECT_NEAR(raw[kCorner], 40.0f, 1e-4);  // 0.5 m: 168 px clamped to 40
}

TEST_F(RenderCli, ColourExrWithOwnZChannel) {
  std::vector<float> px;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      px.insert(px.end(), {color_.at(x, y, 0), color_.at(x, y, 1), color_.at(x, y, 2), 1.0f, depth_.at(x, y)});
  raw_write(dir_ / "cz.exr", W, H, {"R", "G", "B", "A", "Z"}, px);
  ASSERT_EQ(
      run_render({"--color", dir_ / "cz.exr", "--focus", "4", "--blur-at-infinity", "24", "--output", dir_ / "a.exr"})
          .code,
      0);
  ASSERT_EQ(run_render({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "4", "--blur-at-infinity",
                        "24", "--output", dir_ / "b.exr"})
                .code,
            0);
  EXPECT_EQ(io::read_color(dir_ / "a.exr").data(), io::read_color(dir_ / "b.exr").data());
}

TEST_F(RenderCli, EveryCocModelMatchesTheLibraryModel) {
  struct Case {
    std::vector<std::string> flags;
    CameraModel camera;
  };
  CameraModel thin{ThinLens{35, 2.0, 3.0, 24}};
  CameraModel planes{FourPlane{1.0, 2.0, 4.0, 20.0, 12.0, 6.0, true}};
  CameraModel sc{StarCraft{4.0, 1.0, 6.0, 1.0, 9.0}};
  CameraModel nf{NearFarBlend{1.0, 3.0, 5.0, 12.0, 7.0}};
  CameraModel k{BlurAtInfinity{4.0, 24.0}};
  k.reference_width_px = 320;  // radii given at 320 px → halved on this 160 px image
  const std::vector<Case> cases = {
      {{"--f-number", "2", "--focus", "3", "--focal-length", "35", "--sensor-width", "24"}, thin},
      {{"--planes", "1,2,4,20", "--near-radius", "12", "--far-radius", "6", "--planes-ramp", "inverse-z"}, planes},
      {{"--starcraft", "4,1,6,1", "--max-radius", "9"}, sc},
      {{"--near-far", "1,3,5,12", "--max-radius", "7"}, nf},
      {{"--blur-at-infinity", "24", "--focus", "4", "--reference-width", "320"}, k},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"--color",  dir_ / "c.exr", "--depth",      dir_ / "z.exr",
                                     "--output", dir_ / "o.exr", "--output-coc", dir_ / "coc.exr"};
    args.insert(args.end(), c.flags.begin(), c.flags.end());
    const CliResult r = run_render(args);
    ASSERT_EQ(r.code, 0) << c.flags[0] << ": " << r.message;
    auto in = OIIO::ImageInput::open(dir_ / "coc.exr");
    std::vector<float> raw(W * H);
    ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, raw.data()));
    const CocFunction f(c.camera, W);
    for (int i : {0, kBox, kBackground, kInfinite, kCorner})
      EXPECT_FLOAT_EQ(raw[i], f(depth_.plane(0)[i])) << c.flags[0] << " pixel " << i;
  }
}

TEST_F(RenderCli, FocusAtUsesTheDepthUnderThePixel) {
  auto args = std::vector<std::string>{"--color",      dir_ / "c.exr",  "--depth", dir_ / "z.exr", "--blur-at-infinity",
                                       "24",           "--focus-at",    "80,45",   "--output",     dir_ / "o.exr",
                                       "--output-coc", dir_ / "coc.exr"};
  ASSERT_EQ(run_render(args).code, 0);
  auto in = OIIO::ImageInput::open(dir_ / "coc.exr");
  std::vector<float> raw(W * H);
  ASSERT_TRUE(in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, raw.data()));
  EXPECT_NEAR(raw[kBox], 0.0f, 1e-5);                        // the 2 m box is in focus
  EXPECT_NEAR(raw[kBackground], 24 * (2.0 / 10 - 1), 1e-4);  // background: r = K (2/10 − 1)
}

TEST_F(RenderCli, InvalidDepthFarAccepted) {
  Image z = depth_;
  z.at(3, 1) = std::numeric_limits<float>::quiet_NaN();
  z.at(7, 2) = -1.0f;
  io::write_image(dir_ / "z.exr", z);
  auto args = exact_call();
  args.insert(args.end(), {"--invalid-depth", "far"});
  const CliResult r = run_render(args);
  EXPECT_EQ(r.code, 0) << r.message;
}

TEST_F(RenderCli, DebugViewListPrintsTheMethodsViews) {
  const CliResult r = run_render({"--method", "reference", "--debug-view", "list"});
  EXPECT_EQ(r.code, 0) << r.message;
  for (const auto& m : methods())
    if (m.name == "reference") {
      if (m.debug_views.empty()) EXPECT_TRUE(contains(r.out, "no debug views")) << r.out;
      for (const auto& v : m.debug_views) EXPECT_TRUE(contains(r.out, v.name)) << r.out;
    }
}

TEST_F(RenderCli, DebugViewWritten) {
  // Any method of this build that offers a view (reference has none).
  std::string method, view;
  for (const auto& m : methods())
    if (view.empty() && !m.debug_views.empty()) method = m.name, view = m.debug_views[0].name;
  if (view.empty()) GTEST_SKIP() << "no method in this build has debug views";
  auto a = exact_call();
  a[11] = method;
  a.insert(a.end(), {"--debug-view", view, "--debug-output", dir_ / "dbg.exr"});
  const CliResult r = run_render(a);
  ASSERT_EQ(r.code, 0) << r.message;
  auto in = OIIO::ImageInput::open(dir_ / "dbg.exr");
  ASSERT_TRUE(in) << method << "/" << view;
  EXPECT_GT(in->spec().width, 0);
}

// ---- error paths: message names the flag/file, exit code, and no output file ----

TEST_F(RenderCli, MissingColourFile) {
  auto a = exact_call();
  a[1] = dir_ / "nope.exr";
  expect_failure(a, 3, {"nope.exr", "does not exist"});
}

TEST_F(RenderCli, MissingDepthFile) {
  auto a = exact_call();
  a[3] = dir_ / "nodepth.exr";
  expect_failure(a, 3, {"nodepth.exr", "does not exist"});
}

TEST_F(RenderCli, CorruptColourFile) {
  write_bytes(dir_ / "bad.exr", std::string(500, 'x'));
  auto a = exact_call();
  a[1] = dir_ / "bad.exr";
  expect_failure(a, 3, {"bad.exr"}, {"bad.exr"});
}

TEST_F(RenderCli, TruncatedDepthFile) {
  const std::string bytes = read_bytes(dir_ / "z.exr");
  write_bytes(dir_ / "cut.exr", bytes.substr(0, bytes.size() * 2 / 3));
  auto a = exact_call();
  a[3] = dir_ / "cut.exr";
  expect_failure(a, 3, {"cut.exr"}, {"cut.exr"});
}

TEST_F(RenderCli, SizeMismatch) {
  io::write_image(dir_ / "small.exr", Image(80, 90, 1, 3.0f));
  auto a = exact_call();
  a[3] = dir_ / "small.exr";
  expect_failure(a, 3, {"small.exr", "80x90", "160x90"}, {"small.exr"});
}

TEST_F(RenderCli, NanAndNegativeDepthReportCountAndFirstPixel) {
  Image z = depth_;
  z.at(7, 2) = -1.0f;
  z.at(3, 1) = std::numeric_limits<float>::quiet_NaN();
  z.at(9, 9) = 0.0f;
  io::write_image(dir_ / "z.exr", z);
  expect_failure(exact_call(), 3, {"z.exr", "3 invalid", "first at pixel (3, 1)", "--invalid-depth far"});
}

TEST_F(RenderCli, FNumberNotPositive) {
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "4", "--f-number", "0", "--output",
                  dir_ / "o.exr"},
                 2, {"--f-number 0", "must be 0.1 to 10000"});
}

TEST_F(RenderCli, FocusNotBeyondFocalLength) {
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "0.04", "--f-number", "2.8",
                  "--output", dir_ / "o.exr"},
                 2, {"--focus", "focal length"});
}

TEST_F(RenderCli, PlanesOutOfOrder) {
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--planes", "2,1,4,20", "--near-radius", "8",
                  "--far-radius", "8", "--output", dir_ / "o.exr"},
                 2, {"--planes", "NB < NS"});
}

TEST_F(RenderCli, PlanesMalformed) {
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--planes", "1,2,x", "--near-radius", "8",
                  "--far-radius", "8", "--output", dir_ / "o.exr"},
                 2, {"--planes", "NB,NS,FS,FB", "1,2,x"});
}

TEST_F(RenderCli, UnknownMethod) {
  auto a = exact_call();
  a[11] = "nosuchmethod";
  expect_failure(a, 2, {"--method nosuchmethod", "unknown method", "reference"});
}

TEST_F(RenderCli, OutputEqualToInput) {
  const std::string before = read_bytes(dir_ / "z.exr");
  auto a = exact_call();
  a.back() = dir_ / "z.exr";
  expect_failure(a, 2, {"--output", "--depth", "same file"});
  // A different spelling of the same path is caught too (canonical comparison).
  a.back() = (dir_.path() / "." / "sub" / ".." / "c.exr").string();
  std::filesystem::create_directory(dir_.path() / "sub");
  expect_failure(a, 2, {"--output", "--color"}, {"sub"});
  EXPECT_EQ(read_bytes(dir_ / "z.exr"), before);
}

TEST_F(RenderCli, OutputCocEqualToOutput) {
  auto a = exact_call();
  a.insert(a.end(), {"--output-coc", dir_ / "out.exr"});
  expect_failure(a, 2, {"--output-coc", "same file"});
}

TEST_F(RenderCli, ExistingOutputUntouchedOnError) {
  write_bytes(dir_ / "out.exr", "previous result");
  Image z = depth_;
  z.at(0, 0) = -5.0f;
  io::write_image(dir_ / "z.exr", z);
  expect_failure(exact_call(), 3, {"z.exr", "invalid"}, {"out.exr"});
  EXPECT_EQ(read_bytes(dir_ / "out.exr"), "previous result");
}

TEST_F(RenderCli, NoModelOrTwoModels) {
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "4", "--output", dir_ / "o.exr"}, 2,
                 {"no CoC model"});
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "4", "--blur-at-infinity", "3",
                  "--f-number", "2", "--output", dir_ / "o.exr"},
                 2, {"--f-number", "--blur-at-infinity", "exactly one"});
}

TEST_F(RenderCli, ConflictingFocusFlags) {
  expect_failure(
      {"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--blur-at-infinity", "3", "--output", dir_ / "o.exr"}, 2,
      {"--focus"});
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "4", "--focus-at", "3,3",
                  "--blur-at-infinity", "3", "--output", dir_ / "o.exr"},
                 2, {"--focus-at"});
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "4", "--planes", "1,2,4,20",
                  "--near-radius", "8", "--far-radius", "8", "--output", dir_ / "o.exr"},
                 2, {"--focus", "--planes"});
  expect_failure({"--color", dir_ / "c.exr", "--depth", dir_ / "z.exr", "--focus", "4", "--blur-at-infinity", "3",
                  "--near-radius", "8", "--output", dir_ / "o.exr"},
                 2, {"--near-radius", "--planes"});
}

TEST_F(RenderCli, BadSetParameters) {
  auto a = exact_call();
  a.insert(a.end(), {"--set", "nonsense"});
  expect_failure(a, 2, {"--set nonsense", "KEY=VALUE"});
  a.back() = "no_such_key=1";
  expect_failure(a, 2, {"--set no_such_key=1", "unknown parameter"});
}

TEST_F(RenderCli, DepthKindFlags) {
  auto a = exact_call();
  a.insert(a.end(), {"--depth-kind", "distance"});
  expect_failure(a, 2, {"--fov-deg"});
  a = exact_call();
  a.insert(a.end(), {"--clip", "0.1,100"});
  expect_failure(a, 2, {"--clip", "ndc"});
}

TEST_F(RenderCli, UnsupportedOutputFormatAndMissingFolder) {
  expect_failure(exact_call("out.bmp"), 2, {"--output", "out.bmp", "unsupported"});
  expect_failure(exact_call("nodir/out.exr"), 3, {"--output", "nodir", "does not exist"});
  auto a = exact_call();
  a.insert(a.end(), {"--output-coc", dir_ / "coc.bmp"});
  expect_failure(a, 2, {"--output-coc", "unsupported"});
}

TEST_F(RenderCli, UnknownDebugView) {
  auto a = exact_call();
  a.insert(a.end(), {"--debug-view", "nosuchview", "--debug-output", dir_ / "d.exr"});
  expect_failure(a, 2, {"--debug-view nosuchview"});
}

TEST_F(RenderCli, NegativeThreads) {
  auto a = exact_call();
  a.insert(a.end(), {"--threads", "-1"});
  expect_failure(a, 2, {"--threads"});
}

TEST_F(RenderCli, MaskNeedsMaskDepth) {
  io::write_image(dir_ / "m.exr", Image(W, H, 1, 0.5f));
  auto a = exact_call();
  a.insert(a.end(), {"--mask", dir_ / "m.exr"});
  expect_failure(a, 2, {"--mask-depth"}, {"m.exr"});
}

TEST_F(RenderCli, MaskedRender) {
  Image m(W, H, 1, 0.0f);
  for (int y = 0; y < H; ++y)
    for (int x = 100; x < W; ++x) m.at(x, y) = 1.0f;
  io::write_image(dir_ / "m.exr", m);
  io::WriteOptions zo;
  zo.channel_name = "Z";
  io::write_image(dir_ / "mz.exr", Image(W, H, 1, 4.0f), zo);
  auto a = exact_call();
  a.insert(a.end(), {"--mask", dir_ / "m.exr", "--mask-depth", dir_ / "mz.exr"});
  const CliResult r = run_render(a);
  ASSERT_EQ(r.code, 0) << r.message;
  // The command passes the mask and its depth through to the library unchanged.
  Frame f{color_, depth_, {}, {}};
  RenderSettings st;
  st.method = "reference";  // the call's --method
  st.camera.model = BlurAtInfinity{4.0, 24.0};
  st.camera.max_coc_px = 40;
  const RenderResult want = render_masked(f, m, Image(W, H, 1, 4.0f), st);
  EXPECT_EQ(io::read_color(dir_ / "out.exr").data(), want.image.data());
  // … and the masked region really changed the picture (it is at the focus distance there).
  const RenderResult plain = render(f, st);
  EXPECT_NE(plain.image.data(), want.image.data());
}

// ---- end to end: the built binary ----

namespace {
struct ProcResult {
  int code;
  std::string err;
};
// `env`: NAME=VALUE assignments put before the command (shell syntax), or "".
ProcResult spawn(const std::string& args, const ScratchDir& dir, const std::string& env = "") {
  const std::string err_file = dir / "stderr.txt";
  const std::string cmd =
      env + " " + std::string(DOFKIT_BINARY_DIR) + "/dofkit " + args + " 2>" + err_file + " >/dev/null";
  const int status = std::system(cmd.c_str());
  ProcResult r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_bytes(err_file)};
  std::filesystem::remove(err_file);
  return r;
}
std::string q(const std::string& s) { return "'" + s + "'"; }
}  // namespace

TEST_F(RenderCli, EndToEndExactCall) {
  const ProcResult r =
      spawn("render --color " + q(dir_ / "c.exr") + " --depth " + q(dir_ / "z.exr") +
                " --focus 4 --blur-at-infinity 24 --max-coc 40 --method reference --output " + q(dir_ / "out.exr"),
            dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  const Image out = io::read_color(dir_ / "out.exr");
  EXPECT_EQ(out.width(), W);
  EXPECT_EQ(out.height(), H);
  EXPECT_EQ(dir_.entries(), (std::vector<std::string>{"c.exr", "out.exr", "z.exr"}));
}

TEST_F(RenderCli, EndToEndOpenImageIOIsLoadedOnlyForFilesThatNeedIt) {
  // A "module" that cannot load: any use of OpenImageIO fails, and says so on one line.
  write_bytes(dir_ / "broken.so", "not a shared library");
  const std::string broken = "DOFKIT_OIIO_MODULE=" + q(dir_ / "broken.so");
  const std::string camera = " --focus 4 --blur-at-infinity 24 --max-coc 40 --method sterna";
  // EXR in, EXR / PNG / JPEG / TIFF out (the common kinds, *_direct.hpp): OpenImageIO
  // is never needed.
  for (const char* out : {"out.exr", "out.png", "out.jpg", "out.tif"}) {
    const ProcResult ok = spawn(
        "render --color " + q(dir_ / "c.exr") + " --depth " + q(dir_ / "z.exr") + camera + " --output " + q(dir_ / out),
        dir_, broken);
    EXPECT_EQ(ok.code, 0) << out << ": " << ok.err;
    EXPECT_TRUE(std::filesystem::exists(dir_ / out)) << out;
  }
  // ... nor for those PNG, JPEG and TIFF files as inputs.
  for (const char* in : {"out.png", "out.jpg", "out.tif"}) {
    const ProcResult ok = spawn("render --color " + q(dir_ / in) + " --depth " + q(dir_ / "z.exr") + camera +
                                    " --output " + q(dir_ / (std::string(in) + ".exr")),
                                dir_, broken);
    EXPECT_EQ(ok.code, 0) << in << ": " << ok.err;
  }
  // A PIZ-compressed EXR output needs it (and so does such an input): exit 1 (internal),
  // nothing written.
  const std::string piz = camera + " --compression piz --output " + q(dir_ / "piz.exr");
  ProcResult r = spawn("render --color " + q(dir_ / "c.exr") + " --depth " + q(dir_ / "z.exr") + piz, dir_, broken);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_TRUE(contains(r.err, "OpenImageIO module")) << r.err;
  EXPECT_TRUE(contains(r.err, "broken.so does not load")) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "piz.exr"));
  // The same call finds the real module by itself.
  r = spawn("render --color " + q(dir_ / "c.exr") + " --depth " + q(dir_ / "z.exr") + piz, dir_);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir_ / "piz.exr"));
  r = spawn("render --color " + q(dir_ / "piz.exr") + " --depth " + q(dir_ / "z.exr") + camera + " --output " +
                q(dir_ / "piz_in.exr"),
            dir_, broken);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_TRUE(contains(r.err, "OpenImageIO module")) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "piz_in.exr"));
}

TEST_F(RenderCli, EndToEndErrorsAreOneLineWithExitCodes) {
  ProcResult r = spawn("render --color " + q(dir_ / "missing.exr") + " --depth " + q(dir_ / "z.exr") +
                           " --focus 4 --blur-at-infinity 24 --output " + q(dir_ / "out.exr"),
                       dir_);
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_EQ(r.err.rfind("dofkit: error: ", 0), 0u) << r.err;
  EXPECT_TRUE(contains(r.err, "missing.exr")) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  // A shaped aperture's note (the default method draws circles) waits for the inputs: the
  // input error stays the only line.
  for (const char* extra : {" --blades 6", " --blades 6 --method mcguire"}) {
    r = spawn("render --color " + q(dir_ / "missing.exr") + " --depth " + q(dir_ / "z.exr") +
                  " --focus 4 --blur-at-infinity 24 --output " + q(dir_ / "out.exr") + extra,
              dir_);
    EXPECT_EQ(r.code, 3) << extra << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << extra << ": " << r.err;
  }
  r = spawn("render --color " + q(dir_ / "c.exr") + " --depth " + q(dir_ / "z.exr") +
                " --focus 4 --f-number -2 --output " + q(dir_ / "out.exr"),
            dir_);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_TRUE(contains(r.err, "--f-number")) << r.err;
  r = spawn("render --bogus-flag", dir_);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(dir_.entries(), (std::vector<std::string>{"c.exr", "z.exr"}));
}

TEST_F(RenderCli, EndToEndHelpDocumentsEveryFlag) {
  const std::string out_file = dir_ / "help.txt";
  const int status = std::system((std::string(DOFKIT_BINARY_DIR) + "/dofkit render --help >" + out_file).c_str());
  ASSERT_EQ(WEXITSTATUS(status), 0);
  const std::string help = read_bytes(out_file);
  for (const char* flag : {"--color",
                           "--depth",
                           "--output",
                           "--method",
                           "--focus",
                           "--f-number",
                           "--focal-length",
                           "--sensor-width",
                           "--blur-at-infinity",
                           "--planes",
                           "--near-radius",
                           "--far-radius",
                           "--starcraft",
                           "--max-radius",
                           "--near-far",
                           "--max-coc",
                           "--focus-at",
                           "--depth-kind",
                           "--fov-deg",
                           "--disparity-scale",
                           "--clip",
                           "--invalid-depth",
                           "--output-coc",
                           "--threads",
                           "--set",
                           "--debug-view",
                           "--debug-output",
                           "--layers",
                           "--mask",
                           "--mask-depth",
                           "--frames",
                           "--compression",
                           "--png-level",
                           "Examples:",
                           "Exit codes"})
    EXPECT_TRUE(contains(help, flag)) << flag;
}

TEST_F(RenderCli, EndToEndVersionFlag) {
  // `dofkit --version`: the project version on stdout, exit 0, without a subcommand.
  const std::string out_file = dir_ / "version.txt";
  const int status = std::system((std::string(DOFKIT_BINARY_DIR) + "/dofkit --version >" + out_file).c_str());
  ASSERT_EQ(WEXITSTATUS(status), 0);
  const std::string text = read_bytes(out_file);
  EXPECT_EQ(text.rfind("dofkit ", 0), 0u) << text;
  EXPECT_TRUE(contains(text, ".")) << text;  // MAJOR.MINOR.PATCH
}

TEST_F(RenderCli, LayersFileAloneIsAFrame) {
  // Two fragments per pixel: the visible surface and a hidden one behind it.
  Frame f{color_, depth_, {}, {}};
  f.layer_color = {color_, Image(W, H, 4, 0.25f)};
  Image behind(W, H, 1, 20.0f);
  f.layer_depth = {depth_, behind};
  io::write_layers_exr(dir_ / "layers.exr", f);
  const CliResult r = run_render({"--layers", dir_ / "layers.exr", "--focus", "4", "--blur-at-infinity", "24",
                                  "--max-coc", "40", "--output", dir_ / "out.exr", "--output-coc", dir_ / "coc.exr"});
  ASSERT_EQ(r.code, 0) << r.message;
  // Depth comes from the nearest fragment: the CoC map equals the one of the visible depth.
  std::vector<float> raw(W * H);
  auto in = OIIO::ImageInput::open(dir_ / "coc.exr");
  ASSERT_TRUE(in && in->read_image(0, 0, 0, 1, OIIO::TypeDesc::FLOAT, raw.data()));
  EXPECT_NEAR(raw[kBox], 24.0f, 1e-4);
  EXPECT_NEAR(raw[kBackground], -14.4f, 1e-4);
  EXPECT_EQ(io::read_color(dir_ / "out.exr").width(), W);
}

TEST_F(RenderCli, MissingLayersFile) {
  expect_failure(
      {"--layers", dir_ / "nolayers.exr", "--focus", "4", "--blur-at-infinity", "24", "--output", dir_ / "out.exr"}, 3,
      {"nolayers.exr"});
}

TEST_F(RenderCli, FlagErrorsAreFoundBeforeReadingInputs) {
  // The colour file does not exist, but each flag mistake is reported first (exit 2), so a
  // wrong command line fails fast, before any large file is read.
  const std::string missing = dir_ / "missing.exr";
  auto base = [&] {
    return std::vector<std::string>{"--color", missing, "--depth", dir_ / "z.exr", "--output", dir_ / "o.exr"};
  };
  auto a = base();
  a.insert(a.end(), {"--focus", "4", "--f-number", "0"});
  expect_failure(a, 2, {"--f-number"});
  a = base();
  a.insert(a.end(),
           {"--focus", "4", "--blur-at-infinity", "8", "--debug-view", "nosuchview", "--debug-output", dir_ / "d.exr"});
  expect_failure(a, 2, {"--debug-view nosuchview"});
  a = base();
  a.insert(a.end(), {"--focus", "4", "--blur-at-infinity", "8", "--set", "bogus=1"});
  expect_failure(a, 2, {"--set bogus=1"});
  a = base();
  a.insert(a.end(), {"--focus", "4", "--blur-at-infinity", "8", "--method", "layered", "--set", "layers=99"});
  expect_failure(a, 2, {"layers", "99"});  // out of range: refused before the missing colour is noticed
  a = base();
  a.insert(a.end(), {"--focus", "4", "--blur-at-infinity", "8"});
  a[5] = dir_ / "o.gif";
  expect_failure(a, 2, {"o.gif"});
}

// --frames: a numbered sequence in one process (one Renderer, its buffers reused).
namespace {
// Frames k = 1, 2, 3: the fixture's colour scaled by k and its depth scaled by 1 + k/10
// (so --focus-at pulls a different focus for every frame), as c.000k.exr / z.000k.exr.
void write_sequence(const ScratchDir& dir, const Image& color, const Image& depth) {
  for (int k = 1; k <= 3; ++k) {
    Image c = color, z = depth;
    for (float& v : c.data()) v *= static_cast<float>(k);
    for (float& v : z.data()) v *= 1.0f + 0.1f * static_cast<float>(k);
    const std::string n = "000" + std::to_string(k);
    io::write_image(dir / ("c." + n + ".exr"), c);
    io::WriteOptions zo;
    zo.channel_name = "Z";
    io::write_image(dir / ("z." + n + ".exr"), z, zo);
  }
}
// Runs `seq` (a --frames 1-3 call writing o.####.exr) and, for k = 1 … 3, `single(k)` (the
// same frame alone, writing single.000k.exr); every frame of the sequence must equal its
// single call bit for bit (float EXR).
void expect_frames_match_single_calls(const ScratchDir& dir, const std::vector<std::string>& seq,
                                      const std::function<std::vector<std::string>(const std::string&)>& single) {
  const CliResult r = run_render(seq);
  ASSERT_EQ(r.code, 0) << r.message;
  for (int k = 1; k <= 3; ++k) {
    const std::string n = "000" + std::to_string(k);
    ASSERT_EQ(run_render(single(n)).code, 0) << "frame " << k;
    EXPECT_EQ(io::read_color(dir / ("o." + n + ".exr")).data(), io::read_color(dir / ("single." + n + ".exr")).data())
        << "frame " << k;
  }
}
}  // namespace

TEST_F(RenderCli, FramesRenderLikeOneCallPerFrame) {
  write_sequence(dir_, color_, depth_);
  const std::vector<std::string> common = {"--blur-at-infinity", "24", "--focus-at", "80,45",
                                           "--max-coc",          "40", "--method",   "sterna"};
  auto seq =
      std::vector<std::string>{"--color",  dir_ / "c.####.exr", "--depth",      dir_ / "z.%04d.exr", "--frames", "1-3",
                               "--output", dir_ / "o.####.exr", "--output-coc", dir_ / "coc.%d.exr"};
  seq.insert(seq.end(), common.begin(), common.end());
  expect_frames_match_single_calls(dir_, seq, [&](const std::string& n) {
    auto one =
        std::vector<std::string>{"--color",  dir_ / ("c." + n + ".exr"),     "--depth", dir_ / ("z." + n + ".exr"),
                                 "--output", dir_ / ("single." + n + ".exr")};
    one.insert(one.end(), common.begin(), common.end());
    return one;
  });
  for (int k = 1; k <= 3; ++k) EXPECT_TRUE(std::filesystem::exists(dir_ / "coc." + std::to_string(k) + ".exr")) << k;
  // The frames differ (different inputs and focus), so a stale frame would have been seen.
  EXPECT_NE(io::read_color(dir_ / "o.0001.exr").data(), io::read_color(dir_ / "o.0002.exr").data());
}

TEST_F(RenderCli, FramesStepAndSingleFrame) {
  write_sequence(dir_, color_, depth_);
  auto a = std::vector<std::string>{"--color",  dir_ / "c.####.exr", "--depth",  dir_ / "z.####.exr",  "--frames",
                                    "1-3x2",    "--focus",           "4",        "--blur-at-infinity", "24",
                                    "--method", "starcraft",         "--output", dir_ / "s.##.exr"};
  ASSERT_EQ(run_render(a).code, 0);
  EXPECT_TRUE(std::filesystem::exists(dir_ / "s.01.exr"));
  EXPECT_FALSE(std::filesystem::exists(dir_ / "s.02.exr"));
  EXPECT_TRUE(std::filesystem::exists(dir_ / "s.03.exr"));
  a[5] = "2";
  ASSERT_EQ(run_render(a).code, 0);
  EXPECT_TRUE(std::filesystem::exists(dir_ / "s.02.exr"));
}

TEST_F(RenderCli, FramesUsageErrors) {
  write_sequence(dir_, color_, depth_);
  const std::vector<std::string> keep = {"c.0001.exr", "c.0002.exr", "c.0003.exr",
                                         "z.0001.exr", "z.0002.exr", "z.0003.exr"};
  auto base = [&](const std::string& frames, const std::string& color, const std::string& out) {
    return std::vector<std::string>{"--color",  dir_ / color, "--depth", dir_ / "z.####.exr",  "--frames",
                                    frames,     "--focus",    "4",       "--blur-at-infinity", "24",
                                    "--output", dir_ / out};
  };
  expect_failure(base("1-3", "c.####.exr", "o.exr"), 2, {"--output", "frame pattern"}, keep);
  expect_failure(base("1-3", "c.0001.exr", "o.####.exr"), 2, {"--color", "frame pattern"}, keep);
  expect_failure(base("1-3", "c.####.exr", "o.##.%04d.exr"), 2, {"--output", "more than one frame pattern"}, keep);
  for (const char* bad : {"3-1", "a-b", "1-", "-1", "1-3x0", "1:3", "1-3x2y"})
    expect_failure(base(bad, "c.####.exr", "o.####.exr"), 2, {"--frames", bad}, keep);
  // An output of one frame that is the input of another, or another frame's output.
  expect_failure(base("1-3", "c.####.exr", "c.####.exr"), 2, {"c.0001.exr"}, keep);
  auto two = base("1-12", "c.#.exr", "x%d.exr");
  two.insert(two.end(), {"--output-coc", dir_ / "x%d0.exr"});  // frame 1's CoC is frame 10's output
  expect_failure(two, 2, {"x10.exr", "another frame"}, keep);
}

TEST_F(RenderCli, FramesMissingInputStopsBeforeAnyFrameIsWritten) {
  write_sequence(dir_, color_, depth_);
  std::filesystem::remove(std::string(dir_ / "z.0003.exr"));
  expect_failure({"--color", dir_ / "c.####.exr", "--depth", dir_ / "z.####.exr", "--frames", "1-3", "--focus", "4",
                  "--blur-at-infinity", "24", "--output", dir_ / "o.####.exr"},
                 3, {"z.0003.exr", "does not exist", "frame 3"},
                 {"c.0001.exr", "c.0002.exr", "c.0003.exr", "z.0001.exr", "z.0002.exr"});
}

TEST_F(RenderCli, FramesCorruptFrameKeepsTheFramesBeforeIt) {
  write_sequence(dir_, color_, depth_);
  write_bytes(dir_ / "c.0002.exr", std::string(500, 'x'));
  const CliResult r =
      run_render({"--color", dir_ / "c.####.exr", "--depth", dir_ / "z.####.exr", "--frames", "1-3", "--focus", "4",
                  "--blur-at-infinity", "24", "--method", "mcguire", "--output", dir_ / "o.####.exr"});
  EXPECT_EQ(r.code, 3) << r.message;
  EXPECT_TRUE(contains(r.message, "c.0002.exr")) << r.message;
  EXPECT_EQ(dir_.entries(), (std::vector<std::string>{"c.0001.exr", "c.0002.exr", "c.0003.exr", "c.exr", "o.0001.exr",
                                                      "z.0001.exr", "z.0002.exr", "z.0003.exr", "z.exr"}));
}

TEST_F(RenderCli, CompressionOfExrOutputs) {
  auto a = exact_call("zip.exr");
  ASSERT_EQ(run_render(a).code, 0);
  for (const char* c : {"none", "piz", "rle"}) {
    auto b = exact_call(std::string(c) + ".exr");
    b.insert(b.end(), {"--compression", c, "--output-coc", dir_ / (std::string("coc_") + c + ".exr")});
    const CliResult r = run_render(b);
    ASSERT_EQ(r.code, 0) << r.message;
    for (const std::string f : {std::string(c) + ".exr", std::string("coc_") + c + ".exr"}) {
      auto in = OIIO::ImageInput::open(dir_ / f);
      ASSERT_TRUE(in) << f;
      EXPECT_EQ(in->spec().get_string_attribute("compression"), c) << f;
    }
    // Lossless: the same floats as the default (zip) file.
    EXPECT_EQ(io::read_color(dir_ / (std::string(c) + ".exr")).data(), io::read_color(dir_ / "zip.exr").data()) << c;
  }
  auto png = exact_call("o.png");
  png.insert(png.end(), {"--compression", "none"});
  expect_failure(png, 2, {"--compression", ".exr"},
                 {"zip.exr", "none.exr", "piz.exr", "rle.exr", "coc_none.exr", "coc_piz.exr", "coc_rle.exr"});
  auto unknown = exact_call("o.exr");
  unknown.insert(unknown.end(), {"--compression", "lzw"});
  expect_failure(unknown, 2, {"--compression lzw", "unknown EXR compression", "piz"},
                 {"zip.exr", "none.exr", "piz.exr", "rle.exr", "coc_none.exr", "coc_piz.exr", "coc_rle.exr"});
}

TEST_F(RenderCli, PngLevelOfPngOutputs) {
  // Lossless at every level: the same 8-bit pixels; level 0 stores (largest), 9 is smallest.
  std::vector<std::uintmax_t> sizes;
  for (const char* level : {"0", "1", "6", "9"}) {
    auto a = exact_call(std::string("l") + level + ".png");
    a.insert(a.end(), {"--png-level", level});
    const CliResult r = run_render(a);
    ASSERT_EQ(r.code, 0) << r.message;
    sizes.push_back(std::filesystem::file_size(dir_ / (std::string("l") + level + ".png")));
    EXPECT_EQ(io::read_color(dir_ / (std::string("l") + level + ".png")).data(), io::read_color(dir_ / "l0.png").data())
        << level;
  }
  EXPECT_GT(sizes[0], sizes[1]);
  EXPECT_GE(sizes[1], sizes[3]);
  ASSERT_EQ(run_render(exact_call("default.png")).code, 0);
  EXPECT_EQ(std::filesystem::file_size(dir_ / "default.png"), sizes[2]);  // the default is level 6
  const std::vector<std::string> made = {"default.png", "l0.png", "l1.png", "l6.png", "l9.png"};
  auto exr = exact_call("o.exr");
  exr.insert(exr.end(), {"--png-level", "1"});
  expect_failure(exr, 2, {"--png-level 1", ".png"}, made);
  auto bad = exact_call("o.png");
  bad.insert(bad.end(), {"--png-level", "10"});
  expect_failure(bad, 2, {"--png-level 10", "must be 0 to 9"}, made);
}

TEST_F(RenderCli, FramesWithAMaskAndAFixedMaskDepth) {
  // The masked path (render_masked per frame) in a sequence: the mask changes per frame, its
  // depth is one file for every frame (no pattern); each frame equals its single call.
  write_sequence(dir_, color_, depth_);
  for (int k = 1; k <= 3; ++k) {
    Image m(W, H, 1, 0.0f);
    for (int y = 0; y < H; ++y)
      for (int x = 30 * k; x < W; ++x) m.at(x, y) = 1.0f;
    io::write_image(dir_ / ("m.000" + std::to_string(k) + ".exr"), m);
  }
  io::WriteOptions zo;
  zo.channel_name = "Z";
  io::write_image(dir_ / "mz.exr", Image(W, H, 1, 4.0f), zo);
  const std::vector<std::string> common = {"--focus",  "4",         "--blur-at-infinity", "24",
                                           "--method", "starcraft", "--mask-depth",       dir_ / "mz.exr"};
  auto seq = std::vector<std::string>{"--color",  dir_ / "c.####.exr", "--depth",  dir_ / "z.####.exr",
                                      "--mask",   dir_ / "m.####.exr", "--frames", "1-3",
                                      "--output", dir_ / "o.####.exr"};
  seq.insert(seq.end(), common.begin(), common.end());
  expect_frames_match_single_calls(dir_, seq, [&](const std::string& n) {
    auto one =
        std::vector<std::string>{"--color", dir_ / ("c." + n + ".exr"), "--depth",  dir_ / ("z." + n + ".exr"),
                                 "--mask",  dir_ / ("m." + n + ".exr"), "--output", dir_ / ("single." + n + ".exr")};
    one.insert(one.end(), common.begin(), common.end());
    return one;
  });
}

// --- aperture and highlight recovery flags (issue 29) -----------------------------------------

TEST_F(RenderCli, ApertureFlagsReachTheLibrary) {
  std::vector<std::string> args = exact_call();
  for (const char* a : {"--blades", "6", "--blade-rotation", "15", "--blade-curvature", "0.2", "--anamorphic", "1.33"})
    args.push_back(a);
  const CliResult r = run_render(args);
  ASSERT_EQ(r.code, 0) << r.message;
  Frame f{color_, depth_, {}, {}};
  RenderSettings s;
  s.method = "reference";
  s.camera.model = BlurAtInfinity{4.0, 24.0};
  s.camera.max_coc_px = 40;
  s.aperture.blades = 6;
  s.aperture.rotation_deg = 15;
  s.aperture.curvature = 0.2;
  s.aperture.anamorphic = 1.33;
  EXPECT_EQ(io::read_color(dir_ / "out.exr").data(), render(f, s).image.data());
}

// lens (the default) draws blades, rotation, curvature and anamorphic; the cat's eye (and an
// aperture image) without --method renders with reference; with --method lens it is refused.
TEST_F(RenderCli, ShapedApertureWithoutAMethodRendersWithLensOrReference) {
  std::vector<std::string> args = exact_call();
  const auto m = std::find(args.begin(), args.end(), std::string("--method"));
  ASSERT_NE(m, args.end());
  args.erase(m, m + 2);
  Frame f{color_, depth_, {}, {}};
  RenderSettings s;
  s.camera.model = BlurAtInfinity{4.0, 24.0};
  s.camera.max_coc_px = 40;
  s.aperture.blades = 6;
  std::vector<std::string> blades = args;
  for (const char* a : {"--blades", "6"}) blades.push_back(a);
  CliResult r = run_render(blades);
  ASSERT_EQ(r.code, 0) << r.message;
  s.method = "lens";
  EXPECT_EQ(io::read_color(dir_ / "out.exr").data(), render(f, s).image.data());
  std::vector<std::string> eye = blades;
  for (const char* a : {"--cat-eye", "0.5"}) eye.push_back(a);
  r = run_render(eye);
  ASSERT_EQ(r.code, 0) << r.message;
  s.method = "reference";
  s.aperture.cat_eye = 0.5;
  EXPECT_EQ(io::read_color(dir_ / "out.exr").data(), render(f, s).image.data());
  eye.push_back("--method");
  eye.push_back("lens");
  std::filesystem::remove(dir_ / "out.exr");
  r = run_render(eye);
  EXPECT_EQ(r.code, 2) << r.message;
  EXPECT_TRUE(r.message.find("cat's eye") != std::string::npos) << r.message;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "out.exr"));
}

TEST_F(RenderCli, BadApertureIsAUsageErrorNamingTheFlag) {
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = exact_call();
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  for (const char* b : {"1", "2", "17"}) expect_failure(with({"--blades", b}), 2, {"--blades"});
  expect_failure(with({"--blade-curvature", "1.5"}), 2, {"--blade-curvature"});
  expect_failure(with({"--blade-curvature", "-0.1"}), 2, {"--blade-curvature"});
  expect_failure(with({"--anamorphic", "0"}), 2, {"--anamorphic"});
  expect_failure(with({"--cat-eye", "3"}), 2, {"--cat-eye"});
  expect_failure(with({"--highlight-boost", "nan"}), 2, {"--highlight-boost"});
  expect_failure(with({"--highlight-boost", "inf"}), 2, {"--highlight-boost"});
  expect_failure(with({"--highlight-boost", "-1"}), 2, {"--highlight-boost"});
  expect_failure(with({"--highlight-threshold", "1"}), 2, {"--highlight-threshold"});
}

TEST_F(RenderCli, BadApertureImageIsRefusedWithNoOutput) {
  auto with_image = [&](const std::string& name) {
    std::vector<std::string> a = exact_call();
    a.push_back("--aperture-image");
    a.push_back(dir_ / name);
    return a;
  };
  // Unreadable: missing, empty file, not an image → bad input (3).
  expect_failure(with_image("missing.png"), 3, {"--aperture-image", "missing.png"});
  {
    std::FILE* f = std::fopen((dir_ / "empty.png").c_str(), "wb");
    std::fclose(f);
  }
  expect_failure(with_image("empty.png"), 3, {"--aperture-image", "empty.png"}, {"empty.png"});
  // All black, larger than 1024x1024 → usage (2).
  io::write_image(dir_ / "black.exr", Image(16, 16, 1, 0.0f));
  expect_failure(with_image("black.exr"), 2, {"--aperture-image", "all black"}, {"black.exr", "empty.png"});
  io::write_image(dir_ / "big.exr", Image(1025, 8, 1, 1.0f));
  expect_failure(with_image("big.exr"), 2, {"--aperture-image", "1025x8"}, {"big.exr", "black.exr", "empty.png"});
  // An image of the disc gives the circle's render.
  Image disc(64, 64, 1, 0.0f);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) disc.at(x, y) = std::hypot(x + 0.5 - 32, y + 0.5 - 32) <= 32 ? 1.0f : 0.0f;
  io::write_image(dir_ / "disc.exr", disc);
  const CliResult r = run_render(with_image("disc.exr"));
  ASSERT_EQ(r.code, 0) << r.message;
}

TEST_F(RenderCli, EightBitColourGetsTheDefaultBoostAndEveryViewWorks) {
  // An 8-bit PNG is display-referred: the default boost applies; --highlight-boost 0 turns it off.
  // A small light (3x3 at the clip level) on a dark 9x9 patch: what recovery boosts.
  Image c = color_;
  for (int y = 20; y < 29; ++y)
    for (int x = 40; x < 49; ++x) {
      const float v = (x >= 43 && x < 46 && y >= 23 && y < 26) ? 1.0f : 0.02f;
      for (int ch = 0; ch < 3; ++ch) c.at(x, y, ch) = v * c.at(x, y, 3);
    }
  io::write_image(dir_ / "c8.png", c);
  auto call = [&](std::vector<std::string> extra, const std::string& out) {
    std::vector<std::string> a = {"--color", dir_ / "c8.png",      "--depth", dir_ / "z.exr", "--focus",
                                  "4",       "--blur-at-infinity", "24",      "--output",     dir_ / out};
    a.insert(a.end(), extra.begin(), extra.end());
    return run_render(a);
  };
  ASSERT_EQ(call({}, "def.exr").code, 0);
  ASSERT_EQ(call({"--highlight-boost", "64"}, "b64.exr").code, 0);
  ASSERT_EQ(call({"--highlight-boost", "0"}, "b0.exr").code, 0);
  const Image def = io::read_color(dir_ / "def.exr"), b64 = io::read_color(dir_ / "b64.exr"),
              b0 = io::read_color(dir_ / "b0.exr");
  EXPECT_EQ(def.data(), b64.data());
  EXPECT_NE(def.data(), b0.data());  // the light was boosted
  // The debug views: the boost mask and the aperture kernels.
  const CliResult m = call({"--debug-view", "highlights", "--debug-output", dir_ / "mask.exr"}, "m.exr");
  ASSERT_EQ(m.code, 0) << m.message;
  const Image mask = io::read_color(dir_ / "mask.exr");
  float mx = 0;
  for (float v : mask.data()) mx = std::max(mx, v);
  EXPECT_GT(mx, 0.0f);
  const CliResult a =
      call({"--method", "reference", "--blades", "5", "--debug-view", "aperture", "--debug-output", dir_ / "ap.exr"},
           "a.exr");
  ASSERT_EQ(a.code, 0) << a.message;
  EXPECT_GT(io::read_color(dir_ / "ap.exr").width(), 10);
}
