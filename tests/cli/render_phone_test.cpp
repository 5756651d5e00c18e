// `dofkit render --color portrait.jpg` with no --depth: the depth map a Google Camera JPEG
// carries in its XMP (GDepth), and a HEIC's auxiliary depth image. The tests build their own
// photos: a JPEG written by dofkit, GDepth XMP segments spliced in after its SOI marker, the
// depth image a PNG encoded per Google's depthmap formulas from a known depth. Tiny frames
// (64x48 photo, 16x12 depth).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>

#include "dofkit/coc.hpp"
#include "io/image_io.hpp"
#include "io/io_test_util.hpp"
#include "io/phone_depth.hpp"
#include "render_cli_util.hpp"
#ifdef DOFKIT_HAVE_HEIF
#include "heic_test_util.hpp"
#endif

using namespace dofkit;
using namespace dofkit::test;

namespace {

constexpr int W = 64, H = 48, DW = 16, DH = 12;
const char* kGuid = "0123456789ABCDEF0123456789ABCDEF";

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::string base64(const std::string& bytes) { return io::encode_base64(bytes); }

std::string be16(std::size_t v) { return {static_cast<char>(v >> 8), static_cast<char>(v & 255)}; }
std::string be32(std::size_t v) {
  return {static_cast<char>(v >> 24), static_cast<char>((v >> 16) & 255), static_cast<char>((v >> 8) & 255),
          static_cast<char>(v & 255)};
}

std::string app1(const std::string& payload) { return std::string("\xFF\xE1", 2) + be16(payload.size() + 2) + payload; }

std::string standard_segment(const std::string& xmp) {
  return app1(std::string("http://ns.adobe.com/xap/1.0/\0", 29) + xmp);
}

// The extended XMP `xmp` as segments of at most `chunk` bytes, each declaring `declared`.
std::string extended_segments(const std::string& xmp, std::size_t chunk, std::size_t declared) {
  std::string out;
  for (std::size_t off = 0; off < xmp.size(); off += chunk)
    out += app1(std::string("http://ns.adobe.com/xmp/extension/\0", 35) + kGuid + be32(declared) + be32(off) +
                xmp.substr(off, chunk));
  return out;
}

std::string packet(const std::string& description_attrs, const std::string& body = "") {
  return "<?xpacket begin=\"\" id=\"W5M0MpCehiHzreSzNTczkc9d\"?>\n"
         "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">"
         "<rdf:Description rdf:about=\"\" xmlns:GDepth=\"http://ns.google.com/photos/1.0/depthmap/\" "
         "xmlns:GFocus=\"http://ns.google.com/photos/1.0/focus/\" xmlns:xmpNote=\"http://ns.adobe.com/xmp/note/\" " +
         description_attrs + (body.empty() ? "/>" : ">" + body + "</rdf:Description>") +
         "</rdf:RDF></x:xmpmeta>\n<?xpacket end=\"w\"?>";
}

class RenderPhone : public ::testing::Test {
 protected:
  void SetUp() override {
    color_ = test_rgba(W, H, true, false);
    io::write_image(dir_ / "photo.jpg", color_);
    photo_ = read_bytes(dir_ / "photo.jpg");
    // The scene's depth at the map's resolution: 6 m background, a 1.25 m box, a 0.7 m corner.
    depth_ = Image(DW, DH, 1, 6.0f);
    for (int y = 3; y < 9; ++y)
      for (int x = 5; x < 11; ++x) depth_.at(x, y) = 1.25f;
    for (int y = 9; y < DH; ++y)
      for (int x = 13; x < DW; ++x) depth_.at(x, y) = 0.7f;
    io::WriteOptions z;
    z.channel_name = "Z";
    io::write_image(dir_ / "true_z.exr", depth_, z);
  }

  // The depth encoded as a grey PNG per Google's depthmap encoding (`inverse`: RangeInverse,
  // else RangeLinear) with `bits` 8 or 16, near `n` and far `f` in file units of `unit`
  // metres. Writes the values the map decodes to (a code normalised as dofkit's PNG reader
  // does, code · (1 / (2^bits − 1)) in float, then the formula in double, times the unit) to
  // `decoded` (an EXR Z file), and returns the PNG's bytes.
  std::string encode_depth(bool inverse, int bits, double unit, double n, double f, const std::string& decoded) {
    const float top = bits == 16 ? 65535.0f : 255.0f;
    Image codes(DW, DH, 1), z(DW, DH, 1);
    for (std::size_t i = 0; i < codes.plane_size(); ++i) {
      const double d = depth_.plane(0)[i] / unit;
      const double dn = inverse ? f * (d - n) / (d * (f - n)) : (d - n) / (f - n);
      const float v = static_cast<float>(std::round(dn * top)) * (1.0f / top);
      codes.plane(0)[i] = v;
      const double vd = v;
      const double zz = inverse ? n * f / (f - vd * (f - n)) : n + vd * (f - n);
      z.plane(0)[i] = static_cast<float>(zz * unit);
    }
    io::WriteOptions png;
    png.bits = bits;
    io::write_image(dir_ / "depth.png", codes, png);
    io::WriteOptions zo;
    zo.channel_name = "Z";
    io::write_image(dir_ / decoded, z, zo);
    return read_bytes(dir_ / "depth.png");
  }

  // The photo with these segments spliced in after its SOI marker.
  void write_photo(const std::string& file, const std::string& segments) {
    write_bytes(dir_ / file, photo_.substr(0, 2) + segments + photo_.substr(2));
  }

  std::vector<std::string> call(std::vector<std::string> args, const std::string& out, const std::string& coc) const {
    for (const char* a : {"--focus", "1.5", "--blur-at-infinity", "6", "--method", "reference"}) args.push_back(a);
    args.insert(args.end(), {"--output", dir_ / out, "--output-coc", dir_ / coc});
    return args;
  }

  // Renders the photo with no depth flag and with --depth `reference` (same upsampling):
  // the CoC maps (and images) must be the same bit for bit.
  CliResult expect_same_as(const std::string& photo, const std::string& reference) {
    const CliResult r = run_render(call({"--color", dir_ / photo}, "e.exr", "e_coc.exr"));
    EXPECT_EQ(r.code, 0) << r.message;
    const CliResult s = run_render(call({"--color", dir_ / photo, "--depth", dir_ / reference}, "s.exr", "s_coc.exr"));
    EXPECT_EQ(s.code, 0) << s.message;
    if (r.code == 0 && s.code == 0) {
      EXPECT_EQ(io::read_color(dir_ / "e_coc.exr").data(), io::read_color(dir_ / "s_coc.exr").data());
      EXPECT_EQ(io::read_color(dir_ / "e.exr").data(), io::read_color(dir_ / "s.exr").data());
    }
    return r;
  }

  // The largest |CoC| difference between the last expect_same_as render (the embedded depth)
  // and the photo rendered with the scene's own depth at the map's size (upsampled alike).
  double coc_error_against_true_depth(const std::string& photo) {
    const CliResult t =
        run_render(call({"--color", dir_ / photo, "--depth", dir_ / "true_z.exr"}, "t.exr", "t_coc.exr"));
    EXPECT_EQ(t.code, 0) << t.message;
    if (t.code != 0) return HUGE_VAL;
    const Image a = io::read_color(dir_ / "e_coc.exr"), b = io::read_color(dir_ / "t_coc.exr");
    EXPECT_GT(std::fabs(b.plane(0)[0]), 1.0);  // the CoC map is not trivially zero
    double worst = 0;
    for (std::size_t i = 0; i < a.plane_size(); ++i)
      worst = std::max(worst, static_cast<double>(std::fabs(a.plane(0)[i] - b.plane(0)[i])));
    return worst;
  }

  void expect_failure(const std::string& photo, int code, std::initializer_list<const char*> parts) {
    const CliResult r = run_render(call({"--color", dir_ / photo}, "fail.exr", "fail_coc.exr"));
    EXPECT_EQ(r.code, code) << r.message;
    for (const char* p : parts) EXPECT_TRUE(contains(r.message, p)) << "missing '" << p << "' in: " << r.message;
    EXPECT_FALSE(contains(r.message, "\n") || contains(r.message, "\\n")) << r.message;
    EXPECT_FALSE(std::filesystem::exists(dir_ / "fail.exr"));
    EXPECT_FALSE(std::filesystem::exists(dir_ / "fail_coc.exr"));
  }

  ScratchDir dir_;
  Image color_, depth_;
  std::string photo_;
};

}  // namespace

TEST_F(RenderPhone, GDepthRangeInverseInExtendedXmpGivesTheDecodedDepthsCocMap) {
  const std::string png = encode_depth(/*inverse=*/true, 16, 1.0, 0.5, 8.0, "decoded.exr");
  const std::string ext = packet("GDepth:Data=\"" + base64(png) + "\"");
  // Chunks of 300 bytes (several segments), the last one first: order in the file is free.
  std::string segs = extended_segments(ext, 300, ext.size());
  const std::size_t last = segs.rfind(std::string("\xFF\xE1", 2));
  segs = segs.substr(last) + segs.substr(0, last);
  write_photo("portrait.jpg",
              standard_segment(packet("GDepth:Format=\"RangeInverse\" GDepth:Near=\"0.5\" GDepth:Far=\"8\" "
                                      "GDepth:Mime=\"image/png\" GDepth:Units=\"m\" GDepth:ImageWidth=\"64\" "
                                      "GDepth:ImageHeight=\"48\" GFocus:FocalDistance=\"1.5\" "
                                      "xmpNote:HasExtendedXMP=\"" +
                                      std::string(kGuid) + "\"")) +
                  segs);
  const CliResult r = expect_same_as("portrait.jpg", "decoded.exr");
  EXPECT_TRUE(contains(r.err, "note: depth from " + (dir_ / "portrait.jpg") + "'s GDepth XMP (RangeInverse")) << r.err;
  EXPECT_TRUE(contains(r.err, "upsampled to 64x48 (--depth-upsample guided)")) << r.err;
  EXPECT_TRUE(contains(r.err, "GFocus:FocalDistance 1.5")) << r.err;

  // Within the map's quantisation of the scene's own depth: the CoC maps of the true depth and
  // the embedded one (both upsampled alike) differ by far less than a pixel.
  EXPECT_LT(coc_error_against_true_depth("portrait.jpg"), 0.01) << "px";

  // The recorded focus distance is the focus when no focus flag is given: the same CoC map as
  // --focus 1.5 (expect_same_as's renders).
  const CliResult f = run_render({"--color", dir_ / "portrait.jpg", "--blur-at-infinity", "6", "--method", "reference",
                                  "--output-coc", dir_ / "f_coc.exr"});
  ASSERT_EQ(f.code, 0) << f.message;
  EXPECT_EQ(io::read_color(dir_ / "f_coc.exr").data(), io::read_color(dir_ / "e_coc.exr").data());
}

TEST_F(RenderPhone, GDepthRangeLinearInMillimetresAsAnElementInTheStandardXmp) {
  const std::string png = encode_depth(/*inverse=*/false, 8, 0.001, 500.0, 8000.0, "decoded.exr");
  write_photo("linear.jpg", standard_segment(packet("GDepth:Format=\"RangeLinear\" GDepth:Near=\"500\" "
                                                    "GDepth:Far=\"8000\" GDepth:Mime=\"image/png\" GDepth:Units=\"mm\"",
                                                    "<GDepth:Data>\n" + base64(png) + "\n</GDepth:Data>")));
  const CliResult r = expect_same_as("linear.jpg", "decoded.exr");
  EXPECT_TRUE(contains(r.err, "RangeLinear, near 500 mm, far 8000 mm, PNG 16x12")) << r.err;
  // It records no focus distance: a thin lens without a focus flag is a usage error.
  const CliResult f =
      run_render({"--color", dir_ / "linear.jpg", "--blur-at-infinity", "6", "--output-coc", dir_ / "nofocus_coc.exr"});
  EXPECT_EQ(f.code, 2) << f.message;
  EXPECT_TRUE(contains(f.message, "--blur-at-infinity: needs --focus")) << f.message;
  EXPECT_TRUE(contains(f.message, "records no focus distance")) << f.message;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "nofocus_coc.exr"));
}

TEST_F(RenderPhone, BadGDepthIsAOneLineErrorWithoutOutput) {
  const std::string png = encode_depth(true, 16, 1.0, 0.5, 8.0, "decoded.exr");
  const std::string head =
      "GDepth:Format=\"RangeInverse\" GDepth:Near=\"0.5\" GDepth:Far=\"8\" GDepth:Mime=\"image/png\" ";
  std::string b64 = base64(png);
  std::string broken = b64;
  broken[40] = '*';
  write_photo("b64.jpg", standard_segment(packet(head + "GDepth:Data=\"" + broken + "\"")));
  expect_failure("b64.jpg", 3, {"b64.jpg", "GDepth:Data is not valid base64", "character 40"});
  write_photo("cut.jpg", standard_segment(packet(head + "GDepth:Data=\"" + b64.substr(0, 41) + "\"")));
  expect_failure("cut.jpg", 3, {"cut.jpg", "base64"});
  // A depth image cut short (valid base64 of a truncated PNG).
  write_photo("trunc.jpg",
              standard_segment(packet(head + "GDepth:Data=\"" + base64(png.substr(0, png.size() - 30)) + "\"")));
  expect_failure("trunc.jpg", 3, {"trunc.jpg (its GDepth:Data depth image)"});
  write_photo("size.jpg", standard_segment(packet(head +
                                                  "GDepth:ImageWidth=\"640\" GDepth:ImageHeight=\"480\" "
                                                  "GDepth:Data=\"" +
                                                  b64 + "\"")));
  expect_failure("size.jpg", 3, {"size.jpg", "declare 640x480 but the photo is 64x48"});
  const std::string ext = packet("GDepth:Data=\"" + b64 + "\"");
  write_photo("ext.jpg", standard_segment(packet(head + "xmpNote:HasExtendedXMP=\"" + std::string(kGuid) + "\"")) +
                             extended_segments(ext, 300, ext.size() + 1000));
  expect_failure("ext.jpg", 3, {"ext.jpg", "extended XMP declares"});
  write_photo("xml.jpg", standard_segment(packet(head).substr(0, 200) + "<rdf:li>"));
  expect_failure("xml.jpg", 3, {"xml.jpg", "XMP is not well-formed"});
  write_photo("near.jpg", standard_segment(packet("GDepth:Near=\"8\" GDepth:Far=\"0.5\" GDepth:Data=\"" + b64 + "\"")));
  expect_failure("near.jpg", 3, {"near.jpg", "GDepth:Near 8 and Far 0.5"});
  write_photo("mime.jpg", standard_segment(packet("GDepth:Near=\"1\" GDepth:Far=\"2\" GDepth:Data=\"" + b64 + "\"")));
  expect_failure("mime.jpg", 3, {"mime.jpg", "not the image/jpeg image GDepth:Mime declares"});
  // A segment whose length runs past the end of the file.
  write_bytes(dir_ / "seg.jpg", photo_.substr(0, 2) + std::string("\xFF\xE1\xFF\xF0", 4) + "http://ns.adobe.com");
  expect_failure("seg.jpg", 3, {"seg.jpg"});
}

// A newer Pixel portrait: GDepth's fields in the XMP, the depth image appended after the photo
// as the container directory's "Depth" item (here followed by padding and another item).
static std::string container_xmp(const std::string& head, const std::string& depth_item) {
  return packet(head +
                    "xmlns:Container=\"http://ns.google.com/photos/1.0/container/\" "
                    "xmlns:Item=\"http://ns.google.com/photos/1.0/container/item/\"",
                "<Container:Directory><rdf:Seq>"
                "<rdf:li rdf:parseType=\"Resource\"><Container:Item Item:Semantic=\"Primary\" "
                "Item:Mime=\"image/jpeg\"/></rdf:li>"
                "<rdf:li rdf:parseType=\"Resource\"><Container:Item " +
                    depth_item +
                    "/></rdf:li>"
                    "<rdf:li rdf:parseType=\"Resource\"><Container:Item Item:Semantic=\"Confidence\" "
                    "Item:Mime=\"image/png\" Item:Length=\"5\"/></rdf:li>"
                    "</rdf:Seq></Container:Directory>");
}

TEST_F(RenderPhone, ContainerDepthItemAppendedAfterThePhotoGivesTheDecodedDepthsCocMap) {
  const std::string png = encode_depth(/*inverse=*/true, 16, 1.0, 0.5, 8.0, "decoded.exr");
  const std::string head =
      "GDepth:Format=\"RangeInverse\" GDepth:Near=\"0.5\" GDepth:Far=\"8\" GDepth:Mime=\"image/png\" ";
  const std::string item = "Item:Semantic=\"Depth\" Item:Mime=\"image/png\" Item:Length=\"" +
                           std::to_string(png.size()) + "\" Item:Padding=\"3\"";
  const std::string tail = png + "PAD" + "CONF!";
  write_photo("pixel.jpg", standard_segment(container_xmp(head, item)));
  write_bytes(dir_ / "pixel.jpg", read_bytes(dir_ / "pixel.jpg") + tail);
  const CliResult r = expect_same_as("pixel.jpg", "decoded.exr");
  EXPECT_TRUE(contains(r.err, "GDepth XMP and container (RangeInverse")) << r.err;
  EXPECT_LT(coc_error_against_true_depth("pixel.jpg"), 0.01) << "px";

  // A directory that does not fit the file, a Depth item without a length, none at all.
  write_photo("long.jpg", standard_segment(container_xmp(head, "Item:Semantic=\"Depth\" Item:Length=\"99999\"")));
  write_bytes(dir_ / "long.jpg", read_bytes(dir_ / "long.jpg") + tail);
  expect_failure("long.jpg", 3, {"long.jpg", "container Item 2's Item:Length '99999'"});
  write_photo("nolen.jpg", standard_segment(container_xmp(head, "Item:Semantic=\"Depth\" Item:Mime=\"image/png\"")));
  expect_failure("nolen.jpg", 3, {"nolen.jpg", "container Item 2 has no Item:Length"});
  write_photo("none.jpg", standard_segment(container_xmp(head, "Item:Semantic=\"GainMap\" Item:Length=\"4\"")));
  expect_failure("none.jpg", 3, {"none.jpg", "GDepth:Data (the depth image) is missing", "no Depth item"});
}

TEST_F(RenderPhone, APhotoWithoutDepthSaysWhatIsMissing) {
  expect_failure("photo.jpg", 2, {"photo.jpg", "holds no embedded depth map (no XMP)", "--depth"});
  write_photo("other.jpg", standard_segment(packet("xmpNote:Other=\"1\"")));
  expect_failure("other.jpg", 2, {"other.jpg", "no GDepth depth map in its XMP"});
}

TEST(PhoneDepthParsers, XmpAndBase64RefuseWhatIsNotWellFormed) {
  std::vector<io::XmpProperty> p;
  std::string why;
  ASSERT_TRUE(io::parse_xmp("<a:x xmlns:a='u:a' a:k='1 &amp; &#x41;'><a:t>v&lt;</a:t><!-- c --></a:x>", p, why)) << why;
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0].ns, "u:a");
  EXPECT_EQ(p[0].name, "k");
  EXPECT_EQ(p[0].value, "1 & A");
  EXPECT_EQ(p[1].name, "t");
  EXPECT_EQ(p[1].value, "v<");
  for (const char* bad :
       {"<a:x xmlns:a='u'>", "<a:x xmlns:a='u'></a:y>", "<b:x/>", "<!DOCTYPE x [<!ENTITY e 'x'>]><x/>",
        "<a:x xmlns:a='u' a:k='&bomb;'/>", "<x/><y/>", "<x k=1/>", "text"}) {
    p.clear();
    EXPECT_FALSE(io::parse_xmp(bad, p, why)) << bad;
  }
  std::string deep;
  for (int i = 0; i < 300; ++i) deep += "<e>";
  EXPECT_FALSE(io::parse_xmp(deep, p, why));
  EXPECT_TRUE(contains(why, "nested more than 256")) << why;

  std::string out;
  ASSERT_TRUE(io::decode_base64("aGVs bG8=", out, why)) << why;
  EXPECT_EQ(out, "hello");
  for (const char* bad : {"", "a", "aGVsbG8=x", "aGV*", "a===", "aGVsbG8=="})
    EXPECT_FALSE(io::decode_base64(bad, out, why)) << bad;
}

#ifdef DOFKIT_HAVE_HEIF
// A HEIC made here with libheif's (lossless) encoder: the photo, and a 16x12 8-bit disparity
// map as its auxiliary depth image with Apple's depth XMP (disparity 0..2 1/m over codes
// 0..255). The file's boxes are edited by heic_test_util.hpp, since libheif 1.15 cannot add
// a depth image.
TEST_F(RenderPhone, HeicAuxiliaryDepthImageWithAppleDepthDataGivesTheDecodedDepthsCocMap) {
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(W) * H * 3), codes(static_cast<std::size_t>(DW) * DH);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<std::uint8_t>((i * 37 + i / 192 * 11) & 255);
  Image decoded(DW, DH, 1);
  for (std::size_t i = 0; i < codes.size(); ++i) {
    const double disparity = 1.0 / depth_.plane(0)[i];
    codes[i] = static_cast<std::uint8_t>(std::lround(disparity / 2.0 * 255.0));
    const float v = codes[i];
    const double native = 0.0 + (v - 0.0) / (255.0 - 0.0) * (2.0 - 0.0);  // as the reader maps a code
    decoded.plane(0)[i] = static_cast<float>(1.0 / native);
  }
  io::WriteOptions zo;
  zo.channel_name = "Z";
  io::write_image(dir_ / "decoded.exr", decoded, zo);
  const std::string xmp =
      "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">"
      "<rdf:Description rdf:about=\"\" xmlns:apdi=\"http://ns.apple.com/pixeldatainfo/1.0/\">"
      "<apdi:AuxiliaryImageType>disparity</apdi:AuxiliaryImageType><apdi:IntMinValue>0</apdi:IntMinValue>"
      "<apdi:IntMaxValue>255</apdi:IntMaxValue><apdi:FloatMinValue>0</apdi:FloatMinValue>"
      "<apdi:FloatMaxValue>2</apdi:FloatMaxValue></rdf:Description></rdf:RDF></x:xmpmeta>";
  std::string why;
  const std::string heic = heic_test::make_heic(W, H, rgb, DW, DH, codes, xmp, why);
  if (heic.empty()) GTEST_SKIP() << "cannot make a HEIC here: " << why;
  write_bytes(dir_ / "portrait.heic", heic);
  const CliResult r = expect_same_as("portrait.heic", "decoded.exr");
  EXPECT_TRUE(contains(r.err, "auxiliary depth image (Apple disparity 0..2 1/m, 8-bit 16x12), upsampled to 64x48"))
      << r.err;

  // The same map within its quantisation of the scene's depth: CoC maps within 0.05 px
  // (8-bit disparity steps of 1/127.5 1/m).
  EXPECT_LT(coc_error_against_true_depth("portrait.heic"), 0.05) << "px";

  // Without the metadata the map cannot be put in metres; without a depth image it is missing;
  // a file cut inside its image data is damaged.
  write_bytes(dir_ / "nometa.heic", heic_test::make_heic(W, H, rgb, DW, DH, codes, "", why));
  expect_failure("nometa.heic", 3, {"nometa.heic", "records neither a depth representation"});
  write_bytes(dir_ / "plain.heic", heic_test::make_heic(W, H, rgb, 0, 0, {}, "", why));
  expect_failure("plain.heic", 2, {"plain.heic", "holds no embedded depth map (no auxiliary depth image)"});
  // (libheif refuses the whole file: an item's extent runs past its end.)
  write_bytes(dir_ / "cut.heic", heic.substr(0, heic.size() - 40));
  expect_failure("cut.heic", 3, {"cut.heic", "cannot read colour image"});
}
#endif
