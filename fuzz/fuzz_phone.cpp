// libFuzzer target for the phone-photo depth readers (phone_depth.hpp): the input is one
// control byte and then the bytes, taken as
//   c % 4 == 0: an XMP packet (io::parse_xmp);
//   c % 4 == 1: base64 text (io::decode_base64; the output is never longer than 3/4 of it);
//   c % 4 == 2: a JPEG file (io::jpeg_xmp, then io::read_embedded_depth on it);
//   c % 4 == 3: a HEIF file (io::read_embedded_depth; libheif when the build has it).
// Bugs besides sanitizer reports: an error that is not a one-line usage / bad-input
// dofkit::Error, a depth map larger than the photo or beyond the pixel budget, a depth that
// is not a positive z (or +inf).
#include <cmath>
#include <string>

#include "fuzz_common.hpp"
#include "io/phone_depth.hpp"

using namespace dofkit;

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::setup();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t c = data[0];
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  std::string why;
  switch (c % 4) {
    case 0: {
      std::vector<io::XmpProperty> props;
      if (!io::parse_xmp(bytes, props, why) && why.empty()) fuzz::bug("parse_xmp refused without a reason");
      std::size_t total = 0;
      for (const auto& p : props) total += p.value.size();
      if (total > bytes.size()) fuzz::bug("parse_xmp returned more value bytes than its input");
      return 0;
    }
    case 1: {
      std::string out;
      if (io::decode_base64(bytes, out, why) && out.size() > bytes.size() / 4 * 3)
        fuzz::bug("decode_base64 returned more than 3/4 of its input");
      return 0;
    }
    default:
      break;
  }
  if (c % 4 == 2) {
    io::JpegXmp xmp;
    if (io::jpeg_xmp(bytes, xmp, why) && xmp.standard.size() + xmp.extended.size() > bytes.size())
      fuzz::bug("jpeg_xmp returned more packet bytes than its input");
  }
  const std::string path = fuzz::temp_path(c % 4 == 2 ? ".jpg" : ".heic");
  if (!fuzz::write_file(path, data + 1, size - 1)) return 0;
  constexpr int kW = 64, kH = 48;
  io::DepthOptions opt;
  opt.invalid_as_far = (c & 4) != 0;
  io::DepthFacts facts;
  std::string missing;
  Image depth;
  if (fuzz::expect_ok_or_refused("read_embedded_depth",
                                 [&] { depth = io::read_embedded_depth(path, kW, kH, opt, &facts, missing); })) {
    if (!depth.empty()) {
      if (depth.width() > kW || depth.height() > kH || depth.channels() != 1)
        fuzz::bug("read_embedded_depth returned a map larger than the photo");
      for (const float z : depth.data())
        if (!(z > 0)) fuzz::bug("read_embedded_depth returned a depth that is not > 0");
    } else if (missing.empty()) {
      fuzz::bug("read_embedded_depth returned no depth without saying what is missing");
    }
  }
  std::remove(path.c_str());
  return 0;
}
