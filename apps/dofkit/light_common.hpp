// The lights file of `dofkit light` / `dofkit pipeline` (schema: docs/lighting.md) and the
// G-buffer reading the lighting commands share.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dofkit/image.hpp"
#include "dofkit/light.hpp"
#include "ssao_common.hpp"

namespace dofkit::cli {

/// The largest lights file read, bytes.
inline constexpr long long kMaxLightsFileBytes = 16LL << 20;

/// Reads and validates a lights file. World-space lights are turned into camera space by the
/// file's own view_matrix, else `camera`'s (camera.json). Throws Error(bad_input) with one line
/// "--lights PATH: lights[K].FIELD: problem" for anything malformed or out of range.
std::vector<Light> read_lights_file(const std::string& path, const CameraFile* camera);

/// The lights as a lights file (JSON): in world space through `world_to_camera`'s inverse when
/// `world` is set (the view matrix is written into the file as well), else in camera space.
/// A light with shadow maps and a non-empty `shadow_files[k]` gets a "shadow" entry naming
/// that file (relative to the lights file) and its matrices in the light's space.
nlohmann::json lights_json(const std::vector<Light>& lights, bool world, const std::array<double, 16>& world_to_camera,
                           const std::vector<std::string>& shadow_files = {});

/// Writes a light's maps as one float EXR: opaque.Z, translucent.Z, translucent.R/G/B (the
/// channel names a lights file's "maps" entry reads by default).
void write_shadow_maps(const std::string& path, const ShadowMaps& m);

/// A G-buffer read from files: one path for everything (dofkit scene's gbuffer.exr) or one per
/// buffer; channel names per buffer (docs/lighting.md's --channels).
struct GBufferFiles {
  std::string gbuffer;                                            ///< default file for every buffer
  std::string depth, normals, albedo, specular, gloss, emissive;  ///< per-buffer files ("" = gbuffer)
  std::vector<std::string> channel_maps;                          ///< "albedo=diffuse.R,diffuse.G,diffuse.B", …
};
struct GBufferImages {
  Image depth, normals, albedo, specular, gloss, emissive;
  bool has_specular = false, has_gloss = false, has_emissive = false;
  std::vector<std::string> missing;  ///< optional channels absent from the files (treated as 0)
  GBufferRef ref() const;
};
/// Checks the flags (Error(usage)): a file for depth, normals and albedo, valid channel maps.
void check_gbuffer_flags(const GBufferFiles& f);
/// Reads the buffers (Error(bad_input) naming the file and channel; sizes must agree).
GBufferImages read_gbuffer(const GBufferFiles& f);

}  // namespace dofkit::cli
