// Test helper: a HEIC whose primary image has an auxiliary depth image, made with libheif's
// encoder (libheif 1.15 cannot add a depth image itself): the depth is encoded as the
// primary's thumbnail, then the file's boxes are edited — the 'thmb' reference becomes
// 'auxl', and an 'auxC' property "urn:mpeg:hevc:2015:auxid:2" is added to the depth item (the
// boxes that contain it grow, the item locations after them move).
#pragma once
#include <libheif/heif.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace heic_test {

inline std::uint32_t rd(const std::string& s, std::size_t at, int bytes) {
  std::uint32_t v = 0;
  for (int k = 0; k < bytes; ++k) v = (v << 8) | static_cast<unsigned char>(s[at + k]);
  return v;
}
inline void wr(std::string& s, std::size_t at, int bytes, std::uint32_t v) {
  for (int k = bytes - 1; k >= 0; --k, v >>= 8) s[at + k] = static_cast<char>(v & 255);
}

struct Box {
  std::size_t at = 0, size = 0, body = 0;  // start, size, first byte after the header
  std::string type;
};
// The boxes in [begin, end) of `s` (32-bit sizes only: what libheif writes for small files).
inline std::vector<Box> boxes(const std::string& s, std::size_t begin, std::size_t end) {
  std::vector<Box> out;
  for (std::size_t at = begin; at + 8 <= end;) {
    Box b{at, rd(s, at, 4), at + 8, s.substr(at + 4, 4)};
    if (b.size < 8 || at + b.size > end) break;
    out.push_back(b);
    at += b.size;
  }
  return out;
}
inline const Box* find(const std::vector<Box>& v, const char* type) {
  for (const Box& b : v)
    if (b.type == type) return &b;
  return nullptr;
}

// Encodes `rgb` (interleaved 8-bit, w x h) as the primary and `depth` (8-bit grey, dw x dh;
// none if empty) as its depth image, with `depth_xmp` (if not empty) as the depth item's XMP.
// Lossless, so the depth codes come back exactly. Returns the file's bytes, or "" with `why`.
inline std::string make_heic(int w, int h, const std::vector<std::uint8_t>& rgb, int dw, int dh,
                             const std::vector<std::uint8_t>& depth, const std::string& depth_xmp, std::string& why) {
  if (!heif_have_encoder_for_format(heif_compression_HEVC)) {
    why = "libheif has no HEVC encoder";
    return {};
  }
  heif_context* ctx = heif_context_alloc();
  heif_encoder* enc = nullptr;
  heif_context_get_encoder_for_format(ctx, heif_compression_HEVC, &enc);
  heif_encoder_set_lossless(enc, 1);
  heif_image *prim = nullptr, *dimg = nullptr;
  heif_image_create(w, h, heif_colorspace_RGB, heif_chroma_interleaved_RGB, &prim);
  heif_image_add_plane(prim, heif_channel_interleaved, w, h, 8);
  int stride = 0;
  std::uint8_t* p = heif_image_get_plane(prim, heif_channel_interleaved, &stride);
  for (int y = 0; y < h; ++y) std::memcpy(p + y * stride, rgb.data() + 3 * w * y, 3 * w);
  const bool with_depth = !depth.empty();
  if (!with_depth) dw = dh = 1;
  heif_image_create(dw, dh, heif_colorspace_monochrome, heif_chroma_monochrome, &dimg);
  heif_image_add_plane(dimg, heif_channel_Y, dw, dh, 8);
  p = heif_image_get_plane(dimg, heif_channel_Y, &stride);
  for (int y = 0; y < dh && with_depth; ++y) std::memcpy(p + y * stride, depth.data() + dw * y, dw);
  heif_image_handle *ph = nullptr, *dh_ = nullptr;
  heif_error e = heif_context_encode_image(ctx, prim, enc, nullptr, &ph);
  if (e.code == heif_error_Ok && with_depth) e = heif_context_encode_image(ctx, dimg, enc, nullptr, &dh_);
  if (e.code == heif_error_Ok) e = heif_context_set_primary_image(ctx, ph);
  if (e.code == heif_error_Ok && with_depth) e = heif_context_assign_thumbnail(ctx, ph, dh_);
  if (e.code == heif_error_Ok && with_depth && !depth_xmp.empty())
    e = heif_context_add_XMP_metadata(ctx, dh_, depth_xmp.data(), static_cast<int>(depth_xmp.size()));
  const std::string tmp = std::string(std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp") + "/dofkit-heic-" +
                          std::to_string(reinterpret_cast<std::uintptr_t>(ctx)) + ".heic";
  if (e.code == heif_error_Ok) e = heif_context_write_to_file(ctx, tmp.c_str());
  if (ph) heif_image_handle_release(ph);
  if (dh_) heif_image_handle_release(dh_);
  heif_image_release(prim);
  heif_image_release(dimg);
  heif_encoder_release(enc);
  heif_context_free(ctx);
  if (e.code != heif_error_Ok) {
    why = e.message ? e.message : "libheif error";
    return {};
  }
  std::ifstream in(tmp, std::ios::binary);
  std::string s((std::istreambuf_iterator<char>(in)), {});
  std::remove(tmp.c_str());
  if (!with_depth) return s;

  const std::vector<Box> top = boxes(s, 0, s.size());
  const Box* meta = find(top, "meta");
  if (!meta) {
    why = "no meta box";
    return {};
  }
  std::vector<Box> in_meta = boxes(s, meta->body + 4, meta->at + meta->size);
  const Box *iref = find(in_meta, "iref"), *iprp = find(in_meta, "iprp"), *iloc = find(in_meta, "iloc");
  if (!iref || !iprp || !iloc) {
    why = "no iref / iprp / iloc";
    return {};
  }
  // The 'thmb' reference (libheif writes it from the primary to the thumbnail) becomes
  // 'auxl' from the depth item to the primary.
  const Box* pitm = find(in_meta, "pitm");
  if (!pitm) {
    why = "no pitm";
    return {};
  }
  const std::uint32_t primary_id = rd(s, pitm->body + 4, s[pitm->body] == 0 ? 2 : 4);
  bool renamed = false;
  std::uint32_t depth_id = 0;
  const int id_bytes = s[iref->body] == 0 ? 2 : 4;
  for (const Box& r : boxes(s, iref->body + 4, iref->at + iref->size))
    if (r.type == "thmb" && rd(s, r.body + id_bytes, 2) == 1) {
      const std::uint32_t from = rd(s, r.body, id_bytes), to = rd(s, r.body + id_bytes + 2, id_bytes);
      depth_id = from == primary_id ? to : from;
      s.replace(r.at + 4, 4, "auxl");
      wr(s, r.body, id_bytes, depth_id);
      wr(s, r.body + id_bytes + 2, id_bytes, primary_id);
      renamed = true;
    }
  std::vector<Box> in_iprp = boxes(s, iprp->body, iprp->at + iprp->size);
  const Box *ipco = find(in_iprp, "ipco"), *ipma = find(in_iprp, "ipma");
  if (!renamed || !ipco || !ipma || ipma->at < ipco->at) {
    why = "unexpected box layout";
    return {};
  }
  const std::size_t nprops = boxes(s, ipco->body, ipco->at + ipco->size).size();
  std::string auxc = std::string(4, '\0') + "auxC" + std::string(4, '\0') + "urn:mpeg:hevc:2015:auxid:2" + '\0';
  wr(auxc, 0, 4, static_cast<std::uint32_t>(auxc.size()));
  // The depth item's ipma entry gets one more association: the new property, not essential.
  const int version = static_cast<unsigned char>(s[ipma->body]);
  const bool wide = (rd(s, ipma->body, 4) & 1) != 0;
  std::size_t at = ipma->body + 4;
  const std::uint32_t entries = rd(s, at, 4);
  at += 4;
  std::size_t insert_at = 0;
  for (std::uint32_t k = 0; k < entries; ++k) {
    const std::uint32_t item = rd(s, at, version < 1 ? 2 : 4);
    at += version < 1 ? 2 : 4;
    const std::size_t count_at = at;
    const unsigned count = static_cast<unsigned char>(s[at]);
    at += 1 + count * (wide ? 2 : 1);
    if (item == depth_id) {
      s[count_at] = static_cast<char>(count + 1);
      insert_at = at;
    }
  }
  if (!insert_at) {
    why = "the depth item has no ipma entry";
    return {};
  }
  std::string assoc(wide ? 2 : 1, '\0');
  wr(assoc, 0, wide ? 2 : 1, static_cast<std::uint32_t>(nprops + 1));
  // Insert the association, then the property (it is before ipma), growing the boxes.
  const std::size_t grow = assoc.size() + auxc.size();
  s.insert(insert_at, assoc);
  wr(s, ipma->at, 4, static_cast<std::uint32_t>(ipma->size + assoc.size()));
  s.insert(ipco->at + ipco->size, auxc);
  wr(s, ipco->at, 4, static_cast<std::uint32_t>(ipco->size + auxc.size()));
  wr(s, iprp->at, 4, static_cast<std::uint32_t>(iprp->size + grow));
  wr(s, meta->at, 4, static_cast<std::uint32_t>(meta->size + grow));
  // Item locations after the meta box (the mdat) moved by `grow`.
  if (iloc->at > iprp->at) {
    why = "iloc after iprp";
    return {};
  }
  const int iv = static_cast<unsigned char>(s[iloc->body]);
  std::size_t q = iloc->body + 4;
  const int offset_size = static_cast<unsigned char>(s[q]) >> 4, length_size = s[q] & 15;
  const int base_size = static_cast<unsigned char>(s[q + 1]) >> 4, index_size = iv >= 1 ? (s[q + 1] & 15) : 0;
  q += 2;
  const std::uint32_t items = rd(s, q, iv < 2 ? 2 : 4);
  q += iv < 2 ? 2 : 4;
  for (std::uint32_t k = 0; k < items; ++k) {
    q += iv < 2 ? 2 : 4;  // item_ID
    int method = 0;
    if (iv >= 1) {
      method = rd(s, q, 2) & 15;
      q += 2;
    }
    q += 2;  // data_reference_index
    const std::size_t base_at = q;
    q += base_size;
    const std::uint32_t extents = rd(s, q, 2);
    q += 2;
    if (method == 0 && base_size > 0 && rd(s, base_at, base_size) > meta->at)
      wr(s, base_at, base_size, static_cast<std::uint32_t>(rd(s, base_at, base_size) + grow));
    for (std::uint32_t x = 0; x < extents; ++x) {
      q += index_size;
      if (method == 0 && offset_size > 0 && base_size == 0 && rd(s, q, offset_size) > meta->at)
        wr(s, q, offset_size, static_cast<std::uint32_t>(rd(s, q, offset_size) + grow));
      q += offset_size + length_size;
    }
  }
  return s;
}

}  // namespace heic_test
