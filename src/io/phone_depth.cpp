// Over 800 lines: XMP / base64 decoding, the JPEG and optional HEIC readers share the property and temp-file helpers.
// Depth maps embedded in phone photos (see phone_depth.hpp).
#include "io/phone_depth.hpp"

#include <stdlib.h>  // mkstemps
#include <unistd.h>  // close

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>

#include "dofkit/error.hpp"
#include "io/srgb.hpp"

#ifdef DOFKIT_HAVE_HEIF
#include <libheif/heif.h>
#endif

namespace dofkit::io {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kNsGDepth = "http://ns.google.com/photos/1.0/depthmap/";
constexpr std::string_view kNsGFocus = "http://ns.google.com/photos/1.0/focus/";
// Google's container (newer Pixel portraits): secondary files appended after the photo,
// listed in the XMP's Container:Directory, each with Item:Semantic, Item:Mime, Item:Length.
constexpr std::string_view kNsItem = "http://ns.google.com/photos/1.0/container/item/";
constexpr std::string_view kNsXmpNote = "http://ns.adobe.com/xmp/note/";
constexpr std::string_view kNsAppleDepth = "http://ns.apple.com/pixeldatainfo/1.0/";
constexpr std::size_t kMaxNamespaces = 1024;  // declarations in scope at once
// The part of a JPEG read for its metadata: the segments before the image data are a few
// hundred kilobytes at most in a phone photo.
constexpr std::uintmax_t kMaxJpegHead = 64u << 20;
// An XMP packet from a HEIF file's metadata item.
constexpr std::uint64_t kMaxHeifXmp = 16u << 20;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

void append_utf8(std::string& out, std::uint32_t cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xC0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xE0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

// Appends `text` with its entity and character references decoded.
bool decode_entities(std::string_view text, std::string& out, std::string& why) {
  std::size_t i = 0;
  while (i < text.size()) {
    const std::size_t amp = text.find('&', i);
    if (amp == std::string_view::npos) {
      out.append(text.substr(i));
      return true;
    }
    out.append(text.substr(i, amp - i));
    const std::size_t semi = text.find(';', amp);
    if (semi == std::string_view::npos || semi - amp > 12) {
      why = "an '&' that starts no entity";
      return false;
    }
    const std::string_view name = text.substr(amp + 1, semi - amp - 1);
    if (name == "lt") {
      out += '<';
    } else if (name == "gt") {
      out += '>';
    } else if (name == "amp") {
      out += '&';
    } else if (name == "quot") {
      out += '"';
    } else if (name == "apos") {
      out += '\'';
    } else if (name.size() >= 2 && name[0] == '#') {
      const bool hex = name[1] == 'x';
      const std::string_view digits = name.substr(hex ? 2 : 1);
      std::uint32_t cp = 0;
      const auto r = std::from_chars(digits.data(), digits.data() + digits.size(), cp, hex ? 16 : 10);
      if (digits.empty() || r.ec != std::errc() || r.ptr != digits.data() + digits.size() || cp == 0 || cp > 0x10FFFF ||
          (cp >= 0xD800 && cp <= 0xDFFF)) {
        why = "a bad character reference &" + std::string(name) + ";";
        return false;
      }
      append_utf8(out, cp);
    } else {
      why = "an unknown entity &" + std::string(name) + ";";
      return false;
    }
    i = semi + 1;
  }
  return true;
}

bool name_char(char c) { return !is_space(c) && c != '/' && c != '>' && c != '=' && c != '<' && c != '"' && c != '\''; }

bool starts_with(std::string_view s, std::size_t at, std::string_view p) {
  return s.size() >= at + p.size() && s.compare(at, p.size(), p) == 0;
}

std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

}  // namespace

bool parse_xmp(std::string_view x, std::vector<XmpProperty>& out, std::string& why) {
  struct Element {
    std::string qname;
    std::size_t ns_mark = 0;
    std::string text;
    bool children = false;
  };
  std::vector<std::pair<std::string, std::string>> ns;  // prefix → URI, innermost last
  std::vector<Element> stack;
  bool root_done = false;
  std::size_t i = 0;
  const auto fail = [&](const std::string& what) {
    why = what + " at byte " + std::to_string(i);
    return false;
  };
  const auto resolve = [&](std::string_view qname, std::string& uri, std::string& local) {
    const std::size_t colon = qname.find(':');
    if (colon == std::string_view::npos) return false;  // no namespace: not an XMP property
    const std::string_view prefix = qname.substr(0, colon);
    local = std::string(qname.substr(colon + 1));
    if (prefix == "xml") {
      uri = "http://www.w3.org/XML/1998/namespace";
      return true;
    }
    for (auto it = ns.rbegin(); it != ns.rend(); ++it)
      if (it->first == prefix) {
        uri = it->second;
        return true;
      }
    uri.clear();
    return true;  // prefixed but undeclared: uri empty, the caller refuses it
  };
  while (i < x.size()) {
    if (x[i] != '<') {
      const std::size_t end = std::min(x.find('<', i), x.size());
      const std::string_view raw = x.substr(i, end - i);
      if (stack.empty()) {
        if (!trim(raw).empty()) return fail("text outside the root element");
      } else {
        std::string entity_why;
        if (!decode_entities(raw, stack.back().text, entity_why)) return fail(entity_why);
      }
      i = end;
      continue;
    }
    if (starts_with(x, i, "<?")) {
      const std::size_t end = x.find("?>", i + 2);
      if (end == std::string_view::npos) return fail("an unterminated processing instruction");
      i = end + 2;
      continue;
    }
    if (starts_with(x, i, "<!--")) {
      const std::size_t end = x.find("-->", i + 4);
      if (end == std::string_view::npos) return fail("an unterminated comment");
      i = end + 3;
      continue;
    }
    if (starts_with(x, i, "<![CDATA[")) {
      const std::size_t end = x.find("]]>", i + 9);
      if (end == std::string_view::npos) return fail("an unterminated CDATA section");
      if (stack.empty()) return fail("CDATA outside the root element");
      stack.back().text.append(x.substr(i + 9, end - i - 9));
      i = end + 3;
      continue;
    }
    if (starts_with(x, i, "<!")) return fail("a DTD or declaration (not allowed in XMP)");
    if (starts_with(x, i, "</")) {
      std::size_t j = i + 2;
      while (j < x.size() && name_char(x[j])) ++j;
      const std::string_view name = x.substr(i + 2, j - i - 2);
      while (j < x.size() && is_space(x[j])) ++j;
      if (j >= x.size() || x[j] != '>') return fail("an unterminated end tag");
      if (stack.empty() || stack.back().qname != name)
        return fail("end tag </" + std::string(name) + "> does not match " +
                    (stack.empty() ? std::string("any open element") : "<" + stack.back().qname + ">"));
      Element top = std::move(stack.back());
      stack.pop_back();
      if (!top.children) {
        std::string uri, local;
        if (resolve(top.qname, uri, local) && !uri.empty() && !trim(top.text).empty())
          out.push_back({uri, local, std::move(top.text)});
      }
      ns.resize(top.ns_mark);
      i = j + 1;
      if (stack.empty()) root_done = true;
      continue;
    }
    // A start tag.
    std::size_t j = i + 1;
    while (j < x.size() && name_char(x[j])) ++j;
    const std::string qname(x.substr(i + 1, j - i - 1));
    if (qname.empty()) return fail("a '<' that starts no tag");
    if (root_done && stack.empty()) return fail("a second root element <" + qname + ">");
    if (static_cast<int>(stack.size()) >= kMaxXmlDepth)
      return fail("elements nested more than " + std::to_string(kMaxXmlDepth) + " deep");
    std::vector<std::pair<std::string, std::string>> attrs;
    bool self_closing = false;
    while (true) {
      while (j < x.size() && is_space(x[j])) ++j;
      if (j >= x.size()) return fail("an unterminated start tag <" + qname + ">");
      if (x[j] == '>') {
        ++j;
        break;
      }
      if (x[j] == '/') {
        if (j + 1 >= x.size() || x[j + 1] != '>') return fail("a '/' inside start tag <" + qname + ">");
        self_closing = true;
        j += 2;
        break;
      }
      const std::size_t a0 = j;
      while (j < x.size() && name_char(x[j])) ++j;
      const std::string aname(x.substr(a0, j - a0));
      while (j < x.size() && is_space(x[j])) ++j;
      if (aname.empty() || j >= x.size() || x[j] != '=') return fail("an attribute without a value in <" + qname + ">");
      ++j;
      while (j < x.size() && is_space(x[j])) ++j;
      if (j >= x.size() || (x[j] != '"' && x[j] != '\'')) return fail("an unquoted attribute value in <" + qname + ">");
      const char quote = x[j];
      const std::size_t end = x.find(quote, j + 1);
      if (end == std::string_view::npos) return fail("an unterminated attribute value in <" + qname + ">");
      const std::string_view raw = x.substr(j + 1, end - j - 1);
      if (raw.find('<') != std::string_view::npos) return fail("a '<' inside an attribute value");
      std::string value, entity_why;
      if (!decode_entities(raw, value, entity_why)) return fail(entity_why);
      attrs.emplace_back(aname, std::move(value));
      j = end + 1;
    }
    if (!stack.empty()) stack.back().children = true;
    const std::size_t mark = ns.size();
    for (const auto& [aname, value] : attrs) {
      if (aname == "xmlns") {
        ns.emplace_back("", value);
      } else if (aname.rfind("xmlns:", 0) == 0) {
        ns.emplace_back(aname.substr(6), value);
      }
      if (ns.size() > kMaxNamespaces)
        return fail("more than " + std::to_string(kMaxNamespaces) + " namespace declarations in scope");
    }
    std::string uri, local;
    if (resolve(qname, uri, local) && uri.empty()) return fail("undeclared namespace prefix in <" + qname + ">");
    for (auto& [aname, value] : attrs) {
      if (aname == "xmlns" || aname.rfind("xmlns:", 0) == 0) continue;
      if (!resolve(aname, uri, local)) continue;  // an unprefixed attribute has no namespace
      if (uri.empty()) return fail("undeclared namespace prefix in attribute " + aname);
      out.push_back({uri, local, std::move(value)});
    }
    i = j;
    if (self_closing) {
      ns.resize(mark);
      if (stack.empty()) root_done = true;
    } else {
      stack.push_back({qname, mark, {}, false});
    }
  }
  if (!stack.empty()) return fail("element <" + stack.back().qname + "> is not closed");
  if (!root_done) return fail("no element");
  return true;
}

bool decode_base64(std::string_view text, std::string& out, std::string& why) {
  static const auto kTable = [] {
    std::array<std::int8_t, 256> t{};
    t.fill(-1);
    const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int k = 0; k < 64; ++k) t[static_cast<unsigned char>(a[k])] = static_cast<std::int8_t>(k);
    return t;
  }();
  out.clear();
  out.reserve(text.size() / 4 * 3 + 3);  // never more than the text itself
  std::uint32_t acc = 0;
  int bits = 0;
  std::size_t count = 0, pad = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (is_space(static_cast<char>(c))) continue;
    if (c == '=') {
      ++pad;
      continue;
    }
    const int v = kTable[c];
    if (v < 0 || pad) {
      why = (pad ? std::string("data after its '=' padding") : "a character that is not base64") + " at character " +
            std::to_string(i);
      return false;
    }
    acc = (acc << 6) | static_cast<std::uint32_t>(v);
    bits += 6;
    ++count;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xFF);
    }
  }
  if (count == 0 || count % 4 == 1 || pad > 2 || (pad && (count + pad) % 4 != 0)) {
    why = "it ends in the middle of a group (" + std::to_string(count) + " characters, " + std::to_string(pad) +
          " padding)";
    return false;
  }
  return true;
}

std::string encode_base64(std::string_view bytes) {
  static const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
    std::uint32_t v = 0;
    for (std::size_t k = 0; k < 3; ++k) v = (v << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
    for (std::size_t k = 0; k < 4; ++k) out += k <= n ? a[(v >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

bool jpeg_xmp(std::string_view b, JpegXmp& out, std::string& why) {
  out = {};
  const auto* u = reinterpret_cast<const unsigned char*>(b.data());
  if (b.size() < 4 || u[0] != 0xFF || u[1] != 0xD8) {
    why = "not a JPEG";
    return false;
  }
  constexpr std::string_view kStd("http://ns.adobe.com/xap/1.0/\0", 29);
  constexpr std::string_view kExt("http://ns.adobe.com/xmp/extension/\0", 35);
  struct Chunk {
    std::string_view guid;
    std::uint32_t full = 0, offset = 0;
    std::string_view data;
  };
  std::vector<Chunk> chunks;
  std::size_t i = 2;
  while (true) {
    if (i >= b.size()) {
      why = "it ends before its image data (truncated)";
      return false;
    }
    if (u[i] != 0xFF) {
      why = "no marker at byte " + std::to_string(i);
      return false;
    }
    while (i < b.size() && u[i] == 0xFF) ++i;
    if (i >= b.size()) {
      why = "it ends inside a marker (truncated)";
      return false;
    }
    const unsigned m = u[i++];
    if (m == 0xD9 || m == 0xDA) break;  // end of image, start of scan: no metadata after
    if ((m >= 0xD0 && m <= 0xD7) || m == 0x01) continue;
    if (i + 2 > b.size()) {
      why = "it ends inside a segment header (truncated)";
      return false;
    }
    const std::size_t len = (std::size_t{u[i]} << 8) | u[i + 1];
    if (len < 2 || i + len > b.size()) {
      why = "segment 0x" + std::string(1, "0123456789ABCDEF"[m >> 4]) + "0123456789ABCDEF"[m & 15] + " at byte " +
            std::to_string(i) + " declares " + std::to_string(len) + " bytes, " +
            (len < 2 ? "fewer than its length field" : "past the end of the file");
      return false;
    }
    const std::string_view payload = b.substr(i + 2, len - 2);
    i += len;
    if (m != 0xE1) continue;
    if (payload.substr(0, kStd.size()) == kStd) {
      if (out.standard.empty()) out.standard = std::string(payload.substr(kStd.size()));
    } else if (payload.substr(0, kExt.size()) == kExt) {
      const std::string_view rest = payload.substr(kExt.size());
      if (rest.size() < 40) {
        why = "an extended XMP segment shorter than its 40-byte header";
        return false;
      }
      const auto* r = reinterpret_cast<const unsigned char*>(rest.data());
      chunks.push_back({rest.substr(0, 32), be32(r + 32), be32(r + 36), rest.substr(40)});
    }
  }
  if (out.standard.empty()) return true;
  std::vector<XmpProperty> props;
  std::string xml_why;
  if (!parse_xmp(out.standard, props, xml_why)) {
    why = "its XMP is not well-formed: " + xml_why;
    return false;
  }
  std::string guid;
  for (const XmpProperty& p : props)
    if (p.ns == kNsXmpNote && p.name == "HasExtendedXMP") guid = std::string(trim(p.value));
  if (guid.empty()) return true;
  std::vector<Chunk> mine;
  for (const Chunk& c : chunks)
    if (c.guid == guid) mine.push_back(c);
  if (mine.empty()) {
    why = "its XMP names extended XMP " + guid + " but no segment of it is present";
    return false;
  }
  std::stable_sort(mine.begin(), mine.end(), [](const Chunk& a, const Chunk& c) { return a.offset < c.offset; });
  // The declared length is believed only once the chunks present tile it exactly.
  std::uint64_t covered = 0;
  for (const Chunk& c : mine) {
    if (c.full != mine.front().full || c.offset != covered) {
      why = "its extended XMP segments do not tile their declared " + std::to_string(mine.front().full) +
            " bytes (a segment at offset " + std::to_string(c.offset) + ", " + std::to_string(covered) +
            " bytes covered before it)";
      return false;
    }
    covered += c.data.size();
  }
  if (covered != mine.front().full) {
    why = "its extended XMP declares " + std::to_string(mine.front().full) + " bytes but its segments hold " +
          std::to_string(covered);
    return false;
  }
  out.extended.reserve(covered);
  for (const Chunk& c : mine) out.extended.append(c.data);
  return true;
}

namespace {

// The first `limit` bytes of a regular file ("" for anything else: a fifo or device is never
// opened here, the input checks refuse it with its own message).
std::string read_head(const std::string& path, std::uintmax_t limit) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return {};
  std::ifstream f(path, std::ios::binary);
  if (!f) return {};
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) return {};
  std::string bytes(static_cast<std::size_t>(std::min(size, limit)), '\0');
  f.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  bytes.resize(static_cast<std::size_t>(f.gcount()));
  return bytes;
}

// The value of property `name` of namespace `ns`, the first found.
const std::string* find_prop(const std::vector<XmpProperty>& props, std::string_view ns, std::string_view name) {
  for (const XmpProperty& p : props)
    if (p.ns == ns && p.name == name) return &p.value;
  return nullptr;
}

std::optional<double> number(const std::string* s) {
  if (!s) return std::nullopt;
  const std::string_view t = trim(*s);
  double v = 0;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// A temporary file holding `bytes`, removed when this goes.
class TempFile {
 public:
  TempFile(const std::string& bytes, const char* suffix) {
    std::error_code ec;
    std::string pattern = (fs::temp_directory_path(ec) / "dofkit-depth-XXXXXX").string() + suffix;
    if (ec) pattern = std::string("/tmp/dofkit-depth-XXXXXX") + suffix;
    std::vector<char> name(pattern.begin(), pattern.end());
    name.push_back('\0');
    const int fd = ::mkstemps(name.data(), static_cast<int>(std::strlen(suffix)));
    if (fd < 0) throw_internal("cannot create a temporary file for an embedded depth image in " + pattern);
    ::close(fd);
    path_ = name.data();
    std::ofstream f(path_, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!f) throw_internal("cannot write the temporary file " + path_);
  }
  ~TempFile() {
    std::error_code ec;
    fs::remove(path_, ec);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// Runs `fn`; an Error that names `temp` is rethrown naming `label` instead.
template <typename F>
auto naming(const std::string& temp, const std::string& label, F&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const Error& e) {
    std::string m = e.what();
    for (std::size_t at = m.find(temp); at != std::string::npos; at = m.find(temp, at + label.size()))
      m.replace(at, temp.size(), label);
    throw Error(e.kind(), m);
  }
}

// The Item:* properties of a container directory, one map per item, in directory order (a
// new item starts where a name repeats: each Container:Item element holds one of each).
std::vector<std::map<std::string, std::string>> container_items(const std::vector<XmpProperty>& props) {
  std::vector<std::map<std::string, std::string>> items;
  for (const XmpProperty& p : props) {
    if (p.ns != kNsItem) continue;
    if (items.empty() || items.back().count(p.name)) items.emplace_back();
    items.back()[p.name] = std::string(trim(p.value));
  }
  return items;
}

// The depth image of a container photo: the item whose Item:Semantic is "Depth". The items
// after the primary one are the file's tail, in directory order, each Item:Length bytes
// followed by Item:Padding bytes. "" with `missing` set when there is no such item;
// Error(bad_input) naming the field when the directory does not fit the file.
std::string container_depth(const std::string& path, const std::vector<XmpProperty>& props, std::string& missing) {
  const auto items = container_items(props);
  std::size_t depth = items.size();
  for (std::size_t i = 0; i < items.size(); ++i)
    if (items[i].count("Semantic") && items[i].at("Semantic") == "Depth") depth = i;
  if (depth == items.size()) {
    missing = items.empty() ? "no GDepth:Data and no container directory" : "no Depth item in its container directory";
    return {};
  }
  if (depth == 0) throw_bad_input(path + ": container Item 1 (Depth) is the primary image, not an appended one");
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw_bad_input(path + ": cannot read its size: " + ec.message());
  // Offsets from the end of the file: every item after the primary one has a length.
  std::uintmax_t tail = 0, before = 0, length = 0;
  for (std::size_t i = 1; i < items.size(); ++i) {
    const auto field = [&](const char* name, bool required) -> std::uintmax_t {
      const auto it = items[i].find(name);
      if (it == items[i].end()) {
        if (required) throw_bad_input(path + ": container Item " + std::to_string(i + 1) + " has no Item:" + name);
        return 0;
      }
      const std::optional<double> v = number(&it->second);
      if (!v || *v < 0 || *v != std::floor(*v) || *v > static_cast<double>(size))
        throw_bad_input(path + ": container Item " + std::to_string(i + 1) + "'s Item:" + name + " '" + it->second +
                        "' is not a byte count within the file's " + std::to_string(size) + " bytes");
      return static_cast<std::uintmax_t>(*v);
    };
    const std::uintmax_t item_length = field("Length", true);
    if (i == depth) length = item_length;
    const std::uintmax_t len = item_length + field("Padding", false);
    if (i < depth) before += len;
    tail += len;
    if (tail > size)
      throw_bad_input(path + ": its container directory lists " + std::to_string(tail) +
                      " bytes of appended items, more than the file's " + std::to_string(size));
  }
  if (length == 0) throw_bad_input(path + ": container Item " + std::to_string(depth + 1) + " (Depth) is empty");
  if (length > kMaxJpegHead)
    throw_bad_input(path + ": container Item " + std::to_string(depth + 1) + " (Depth) declares " +
                    std::to_string(length) + " bytes, more than the " + std::to_string(kMaxJpegHead >> 20) +
                    " MiB a depth image may have");
  std::ifstream f(path, std::ios::binary);
  f.seekg(static_cast<std::streamoff>(size - tail + before));
  std::string bytes(static_cast<std::size_t>(length), '\0');
  f.read(bytes.data(), static_cast<std::streamsize>(length));
  if (!f || static_cast<std::uintmax_t>(f.gcount()) != length)
    throw_bad_input(path + ": cannot read container Item " + std::to_string(depth + 1) + " (Depth)");
  return bytes;
}

Image gdepth(const std::string& path, int width, int height, const DepthOptions& user, DepthFacts* facts,
             std::string& missing) {
  const std::string head = read_head(path, kMaxJpegHead);
  JpegXmp xmp;
  std::string why;
  if (!jpeg_xmp(head, xmp, why)) throw_bad_input(path + ": " + why);
  std::vector<XmpProperty> props;
  if (!xmp.standard.empty() && !parse_xmp(xmp.standard, props, why))
    throw_bad_input(path + ": its XMP is not well-formed: " + why);
  if (!xmp.extended.empty() && !parse_xmp(xmp.extended, props, why))
    throw_bad_input(path + ": its extended XMP is not well-formed: " + why);
  const bool any = std::any_of(props.begin(), props.end(), [](const XmpProperty& p) { return p.ns == kNsGDepth; });
  if (!any) {
    missing = xmp.standard.empty() ? "no XMP" : "no GDepth depth map in its XMP";
    return {};
  }
  const auto get = [&](const char* name) { return find_prop(props, kNsGDepth, name); };
  const auto bad = [&](const std::string& what) { throw_bad_input(path + ": GDepth:" + what); };
  const std::string format = get("Format") ? std::string(trim(*get("Format"))) : "RangeInverse";
  if (format != "RangeInverse" && format != "RangeLinear")
    bad("Format '" + format + "' is neither RangeInverse nor RangeLinear");
  const std::optional<double> near = number(get("Near")), far = number(get("Far"));
  if (!near || !far) bad(std::string(!near ? "Near" : "Far") + " is missing or not a number");
  if (!(*near > 0 && *far > *near)) bad("Near " + fmt(*near) + " and Far " + fmt(*far) + " are not 0 < Near < Far");
  const std::string units = get("Units") ? std::string(trim(*get("Units"))) : "m";
  const double scale = units == "m" ? 1.0 : units == "cm" ? 0.01 : units == "mm" ? 0.001 : 0.0;
  if (scale == 0) bad("Units '" + units + "' is not m, cm or mm");
  const std::string mime = get("Mime") ? std::string(trim(*get("Mime"))) : "image/jpeg";
  if (mime != "image/png" && mime != "image/jpeg") bad("Mime '" + mime + "' is neither image/png nor image/jpeg");
  const std::optional<double> iw = number(get("ImageWidth")), ih = number(get("ImageHeight"));
  if (iw && ih && (*iw != width || *ih != height))
    bad("ImageWidth/ImageHeight declare " + fmt(*iw) + "x" + fmt(*ih) + " but the photo is " + std::to_string(width) +
        "x" + std::to_string(height));
  const std::string* data = get("Data");
  std::string image;
  bool from_container = false;
  if (data) {
    if (!decode_base64(*data, image, why)) bad("Data is not valid base64: " + why);
  } else {
    std::string none;
    image = container_depth(path, props, none);
    if (image.empty())
      bad("Data (the depth image) is missing" + std::string(xmp.extended.empty() ? " (no extended XMP)" : "") +
          ", and " + none);
    from_container = true;
  }
  const bool png = image.size() >= 8 && image.compare(0, 8, "\x89PNG\r\n\x1a\n", 8) == 0;
  const bool jpeg = image.size() >= 3 && image.compare(0, 3, "\xFF\xD8\xFF", 3) == 0;
  if (png != (mime == "image/png") || (!png && !jpeg))
    bad(std::string(from_container ? "Mime: the container's Depth item" : "Data") + " is not the " + mime +
        " image GDepth:Mime declares");

  // The normalised map d ∈ [0, 1] → z (Google's depthmap encoding): RangeLinear
  // z = near + d (far − near); RangeInverse z = far·near / (far − d (far − near)), which is
  // the ndc kind's formula with the clip planes at near and far.
  DepthOptions opt;
  opt.kind = format == "RangeLinear" ? DepthKind::linear : DepthKind::ndc;
  opt.clip_near = *near;
  opt.clip_far = *far;
  opt.scale = scale;
  opt.invalid_as_far = user.invalid_as_far;
  const TempFile temp(image, png ? ".png" : ".jpg");
  const std::string label =
      path + (from_container ? " (its container's Depth item)" : " (its GDepth:Data depth image)");
  Image depth = naming(temp.path(), label, [&] {
    const ImageInfo info = probe_image(temp.path(), "depth");
    if (info.width > width || info.height > height)
      throw_bad_input(temp.path() + ": is " + std::to_string(info.width) + "x" + std::to_string(info.height) +
                      ", larger than the photo (" + std::to_string(width) + "x" + std::to_string(height) + ")");
    return read_depth(temp.path(), opt);
  });
  if (facts) {
    facts->integer = false;  // converted per the metadata, not read as z
    facts->channel = from_container ? "Container Depth item" : "GDepth:Data";
    std::string s = path + "'s GDepth XMP" + (from_container ? " and container" : "") + " (" + format + ", near " +
                    fmt(*near) + " " + units + ", far " + fmt(*far) + " " + units + ", " + (png ? "PNG " : "JPEG ") +
                    std::to_string(depth.width()) + "x" + std::to_string(depth.height()) + ")";
    const std::string* ray = get("MeasureType");
    if (ray && trim(*ray) == "OpticalRay") s += "; it is measured along each ray and is read as planar z";
    if (const std::optional<double> focus = number(find_prop(props, kNsGFocus, "FocalDistance")))
      if (std::isfinite(*focus) && *focus > 0) {
        facts->focus_m = *focus * scale;
        s += "; it records GFocus:FocalDistance " + fmt(*focus) + " " + units +
             " (the focus unless a focus flag is given)";
      }
    facts->embedded = s;
  }
  return depth;
}

#ifdef DOFKIT_HAVE_HEIF
// libheif's message for an error, on one line without its trailing newline.
std::string heif_text(const heif_error& e) {
  std::string m = e.message && *e.message ? e.message : "libheif error";
  while (!m.empty() && is_space(m.back())) m.pop_back();
  return m;
}

struct HeifContext {
  heif_context* ctx = heif_context_alloc();
  ~HeifContext() {
    if (ctx) heif_context_free(ctx);
  }
};
struct HeifHandle {
  heif_image_handle* h = nullptr;
  ~HeifHandle() {
    if (h) heif_image_handle_release(h);
  }
};
struct HeifImage {
  heif_image* img = nullptr;
  ~HeifImage() {
    if (img) heif_image_release(img);
  }
};

// Apple's depth metadata (the depth item's XMP): the stored integer range maps linearly to
// the float range of the native format, disparity (1/m) or depth (m).
struct AppleDepth {
  bool disparity = true;
  double float_min = 0, float_max = 0, int_min = 0, int_max = 0;
};
std::optional<AppleDepth> apple_depth(heif_image_handle* depth, const std::string& path) {
  const int n = heif_image_handle_get_number_of_metadata_blocks(depth, "mime");
  if (n <= 0) return std::nullopt;
  std::vector<heif_item_id> ids(static_cast<std::size_t>(std::min(n, 16)));
  heif_image_handle_get_list_of_metadata_block_IDs(depth, "mime", ids.data(), static_cast<int>(ids.size()));
  for (const heif_item_id id : ids) {
    const std::size_t size = heif_image_handle_get_metadata_size(depth, id);
    if (size == 0 || size > kMaxHeifXmp) continue;
    std::string xml(size, '\0');
    if (heif_image_handle_get_metadata(depth, id, xml.data()).code != heif_error_Ok) continue;
    std::vector<XmpProperty> props;
    std::string why;
    if (!parse_xmp(xml, props, why)) throw_bad_input(path + ": the depth image's XMP is not well-formed: " + why);
    const auto num = [&](const char* name) { return number(find_prop(props, kNsAppleDepth, name)); };
    const auto fmin = num("FloatMinValue"), fmax = num("FloatMaxValue"), imin = num("IntMinValue"),
               imax = num("IntMaxValue");
    if (!fmin || !fmax || !imin || !imax) continue;
    AppleDepth a{true, *fmin, *fmax, *imin, *imax};
    const std::string* type = find_prop(props, kNsAppleDepth, "AuxiliaryImageType");
    if (type && trim(*type) == "depth") a.disparity = false;
    if (!(a.int_max > a.int_min) || !(a.float_max > a.float_min))
      throw_bad_input(path + ": the depth image's Apple depth data has an empty value range");
    return a;
  }
  return std::nullopt;
}

Image heif_depth(const std::string& path, int width, int height, const DepthOptions& user, DepthFacts* facts,
                 std::string& missing) {
  HeifContext c;
  if (!c.ctx) throw_internal("libheif: cannot allocate a context");
  heif_context_set_maximum_image_size_limit(c.ctx, std::max(width, height));
  const auto check = [&](heif_error e, const char* what) {
    if (e.code != heif_error_Ok) throw_bad_input(path + ": " + what + ": " + heif_text(e));
  };
  check(heif_context_read_from_file(c.ctx, path.c_str(), nullptr), "cannot read it as HEIF");
  HeifHandle primary;
  check(heif_context_get_primary_image_handle(c.ctx, &primary.h), "no primary image");
  if (!heif_image_handle_has_depth_image(primary.h)) {
    missing = "no auxiliary depth image";
    return {};
  }
  heif_item_id id = 0;
  if (heif_image_handle_get_list_of_depth_image_IDs(primary.h, &id, 1) != 1) {
    missing = "no auxiliary depth image";
    return {};
  }
  HeifHandle depth;
  check(heif_image_handle_get_depth_image_handle(primary.h, id, &depth.h), "its depth image");
  const int w = heif_image_handle_get_width(depth.h), h = heif_image_handle_get_height(depth.h);
  if (w <= 0 || h <= 0 || w > width || h > height)
    throw_bad_input(path + ": its depth image is " + std::to_string(w) + "x" + std::to_string(h) +
                    ", empty or larger than the photo (" + std::to_string(width) + "x" + std::to_string(height) + ")");
  if (static_cast<long long>(w) * h > pixel_budget())
    throw_bad_input(path + ": its depth image exceeds the pixel budget (--max-pixels)");

  // How the samples map to metres: the depth representation info (ISO/IEC 23008-2), else
  // Apple's depth XMP.
  const heif_depth_representation_info* info = nullptr;
  DepthOptions opt;
  opt.invalid_as_far = user.invalid_as_far;
  std::optional<AppleDepth> apple;
  std::string how;
  if (heif_image_handle_get_depth_image_representation_info(primary.h, id, &info) && info) {
    const bool near_far = info->has_z_near && info->has_z_far;
    const auto type = info->depth_representation_type;
    opt.clip_near = info->z_near;
    opt.clip_far = info->z_far;
    heif_depth_representation_info_free(info);
    if (type == heif_depth_representation_type_uniform_inverse_Z && near_far) {
      // Uniform in 1/z, the largest sample at z_near: reversed-Z between the two planes.
      opt.kind = DepthKind::ndc_reversed;
      how = "uniform inverse z";
    } else if (type == heif_depth_representation_type_uniform_Z && near_far) {
      opt.kind = DepthKind::linear;
      how = "uniform z";
    } else {
      throw_bad_input(
          path + ": its depth image is " +
          (near_far ? std::string("disparity (needs the camera's baseline)") : std::string("missing z_near / z_far")) +
          "; dofkit cannot convert it to metres");
    }
    how += ", z_near " + fmt(opt.clip_near) + " m, z_far " + fmt(opt.clip_far) + " m";
  } else if ((apple = apple_depth(depth.h, path))) {
    how = std::string("Apple ") + (apple->disparity ? "disparity" : "depth") + " " + fmt(apple->float_min) + ".." +
          fmt(apple->float_max) + (apple->disparity ? " 1/m" : " m");
  } else {
    throw_bad_input(path +
                    ": its depth image records neither a depth representation (z_near, z_far) nor Apple "
                    "depth data; dofkit cannot convert it to metres");
  }

  // Decoded as coded: a grey depth image comes back as Y (4:0:0 or YCbCr) or, coded
  // losslessly as RGB, as three equal planes.
  HeifImage img;
  check(heif_decode_image(depth.h, &img.img, heif_colorspace_undefined, heif_chroma_undefined, nullptr),
        "cannot decode its depth image");
  const bool rgb = !heif_image_has_channel(img.img, heif_channel_Y);
  const heif_channel channels[3] = {rgb ? heif_channel_R : heif_channel_Y, heif_channel_G, heif_channel_B};
  const std::uint8_t* planes[3] = {nullptr, nullptr, nullptr};
  int strides[3] = {0, 0, 0};
  const int bits = heif_image_get_bits_per_pixel_range(img.img, channels[0]);
  for (int k = 0; k < (rgb ? 3 : 1); ++k) {
    planes[k] = heif_image_get_plane_readonly(img.img, channels[k], &strides[k]);
    if (!planes[k] || bits < 1 || bits > 16 || heif_image_get_width(img.img, channels[k]) != w ||
        heif_image_get_height(img.img, channels[k]) != h || strides[k] < w * (bits > 8 ? 2 : 1) ||
        heif_image_get_bits_per_pixel_range(img.img, channels[k]) != bits)
      throw_bad_input(path + ": its depth image does not decode to " + std::to_string(w) + "x" + std::to_string(h) +
                      " grey samples");
  }
  const auto sample = [&](int k, int x, int y) -> std::uint32_t {
    const std::uint8_t* row = planes[k] + static_cast<std::size_t>(y) * static_cast<std::size_t>(strides[k]);
    if (bits <= 8) return row[x];
    std::uint16_t v;
    std::memcpy(&v, row + 2 * static_cast<std::size_t>(x), 2);
    return v;
  };
  const double top = std::ldexp(1.0, bits) - 1;
  Image out(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::uint32_t v = sample(0, x, y);
      if (rgb && (sample(1, x, y) != v || sample(2, x, y) != v))
        throw_bad_input(path + ": its depth image is not grey (R, G, B differ at pixel (" + std::to_string(x) + ", " +
                        std::to_string(y) + "))");
      out.at(x, y) = apple ? static_cast<float>(v) : static_cast<float>(v / top);  // Apple: the code itself
    }
  if (apple) {
    // The stored code → the native value (linear map of [IntMin, IntMax] onto [FloatMin,
    // FloatMax]) → z: 1 / disparity, or the depth itself; then the z kind's checks.
    const AppleDepth& a = *apple;
    for (float& v : out.data()) {
      const double native = a.float_min + (v - a.int_min) / (a.int_max - a.int_min) * (a.float_max - a.float_min);
      v = static_cast<float>(a.disparity ? (native > 0 ? 1.0 / native : (native == 0 ? HUGE_VAL : -1.0)) : native);
    }
    opt.kind = DepthKind::z;
  }
  convert_depth(out, opt, path + " (its depth image)");
  if (facts) {
    facts->integer = false;
    facts->channel = "HEIF depth";
    facts->embedded = path + "'s auxiliary depth image (" + how + ", " + std::to_string(bits) + "-bit " +
                      std::to_string(w) + "x" + std::to_string(h) + ")";
  }
  return out;
}
#endif

}  // namespace

#ifdef DOFKIT_HAVE_HEIF
namespace {
// The primary image handle of a HEIF file, its size held to the pixel budget.
struct HeifPrimary {
  HeifContext c;
  HeifHandle h;
  int width = 0, height = 0;
  bool alpha = false;
  HeifPrimary(const std::string& path, const char* role) {
    if (!c.ctx) throw_internal("libheif: cannot allocate a context");
    const auto check = [&](heif_error e) {
      if (e.code != heif_error_Ok) throw_bad_input(path + ": cannot read " + role + " image: " + heif_text(e));
    };
    const long long budget = pixel_budget();
    heif_context_set_maximum_image_size_limit(c.ctx, static_cast<int>(std::min<long long>(budget, 1 << 30)));
    check(heif_context_read_from_file(c.ctx, path.c_str(), nullptr));
    check(heif_context_get_primary_image_handle(c.ctx, &h.h));
    width = heif_image_handle_get_width(h.h);
    height = heif_image_handle_get_height(h.h);
    alpha = heif_image_handle_has_alpha_channel(h.h) != 0;
    if (width <= 0 || height <= 0) throw_bad_input(path + ": cannot read " + role + " image: its size is 0");
    if (static_cast<long long>(width) * height > budget)
      throw_bad_input(path + ": " + role + " image is " + std::to_string(width) + "x" + std::to_string(height) +
                      ", beyond the pixel budget of " + std::to_string(budget) + " (--max-pixels)");
  }
};
}  // namespace
#endif

HeifInfo probe_heif(const std::string& path, const char* role) {
#ifdef DOFKIT_HAVE_HEIF
  const HeifPrimary p(path, role);
  return {p.width, p.height, p.alpha ? 4 : 3};
#else
  throw_bad_input(path + ": cannot read " + role +
                  " image: a HEIF/HEIC photo, but this dofkit was built without HEIC support (libheif)");
#endif
}

Image read_heif_color(const std::string& path) {
#ifdef DOFKIT_HAVE_HEIF
  HeifPrimary p(path, "colour");
  const int bits = std::clamp(heif_image_handle_get_luma_bits_per_pixel(p.h.h), 8, 16);
  const bool wide = bits > 8;
  const heif_chroma chroma = p.alpha ? (wide ? heif_chroma_interleaved_RRGGBBAA_LE : heif_chroma_interleaved_RGBA)
                                     : (wide ? heif_chroma_interleaved_RRGGBB_LE : heif_chroma_interleaved_RGB);
  HeifImage img;
  const heif_error e = heif_decode_image(p.h.h, &img.img, heif_colorspace_RGB, chroma, nullptr);
  if (e.code != heif_error_Ok) throw_bad_input(path + ": cannot decode its image: " + heif_text(e));
  const int C = p.alpha ? 4 : 3;
  int stride = 0;
  const std::uint8_t* plane = heif_image_get_plane_readonly(img.img, heif_channel_interleaved, &stride);
  const int got_bits = heif_image_get_bits_per_pixel_range(img.img, heif_channel_interleaved);
  if (!plane || heif_image_get_width(img.img, heif_channel_interleaved) != p.width ||
      heif_image_get_height(img.img, heif_channel_interleaved) != p.height || stride < p.width * C * (wide ? 2 : 1) ||
      got_bits < 1 || got_bits > 16 || (got_bits > 8) != wide)
    throw_bad_input(path + ": its image does not decode to " + std::to_string(p.width) + "x" +
                    std::to_string(p.height) + " RGB samples");
  const float top = static_cast<float>(std::ldexp(1.0, got_bits) - 1);
  Image out(p.width, p.height, 4);
  for (int y = 0; y < p.height; ++y) {
    const std::uint8_t* row = plane + static_cast<std::size_t>(y) * static_cast<std::size_t>(stride);
    for (int x = 0; x < p.width; ++x) {
      float v[4] = {0, 0, 0, 1};
      for (int c = 0; c < C; ++c) {
        std::uint32_t code = 0;
        if (wide) {
          std::uint16_t s16;
          std::memcpy(&s16, row + 2 * (static_cast<std::size_t>(x) * C + c), 2);
          code = s16;
        } else {
          code = row[static_cast<std::size_t>(x) * C + c];
        }
        v[c] = static_cast<float>(code) / top;
      }
      // Straight alpha (HEIF's): the colour is sRGB-decoded, then multiplied by it.
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = decode_srgb(v[c]) * v[3];
      out.at(x, y, 3) = v[3];
    }
  }
  return out;
#else
  throw_bad_input(path + ": a HEIF/HEIC photo, but this dofkit was built without HEIC support (libheif)");
#endif
}

bool looks_like_jpeg(const std::string& path) {
  const std::string head = read_head(path, 3);
  return head.size() == 3 && head == std::string("\xFF\xD8\xFF", 3);
}

bool looks_like_heif(const std::string& path) {
  const std::string head = read_head(path, 12);
  if (head.size() < 12 || head.compare(4, 4, "ftyp") != 0) return false;
  const std::string brand = head.substr(8, 4);
  for (const char* b : {"heic", "heix", "heim", "heis", "hevc", "hevx", "mif1", "msf1"})
    if (brand == b) return true;
  return false;
}

bool reads_embedded_depth(const std::string& color_path, const std::string& depth_path,
                          const std::string& depth_channel) {
  return depth_path.empty() && depth_channel.empty() && (looks_like_jpeg(color_path) || looks_like_heif(color_path));
}

Image read_embedded_depth(const std::string& path, int width, int height, const DepthOptions& opt, DepthFacts* facts,
                          std::string& missing) {
  missing.clear();
  if (looks_like_jpeg(path)) return gdepth(path, width, height, opt, facts, missing);
  if (looks_like_heif(path)) {
#ifdef DOFKIT_HAVE_HEIF
    return heif_depth(path, width, height, opt, facts, missing);
#else
    throw_bad_input(path + ": a HEIF/HEIC photo, but this dofkit was built without HEIC support (libheif)");
#endif
  }
  missing = "not a JPEG or HEIF photo";
  return {};
}

}  // namespace dofkit::io
