// Multi-fragment (layered) input for the layered method.
//
// Two file kinds are read:
//  * deep EXR (OpenEXR deep scanline or tiled images, as renderers write for deep
//    compositing): each pixel's samples (R, G, B, A premultiplied, Z [, ZBack]) are sorted
//    front to back and stored as fixed layers; pixels with fewer samples get alpha 0, z = +inf;
//  * the layered EXR that `dofkit scene --layers N` writes: one flat EXR with channels
//    `L0.R L0.G L0.B L0.A L0.Z  L1.R …` (layer 0 = visible surface, front to back).
#pragma once
#include <string>

#include "dofkit/frame.hpp"

namespace dofkit::io {

/// Fills frame.layer_color / layer_depth from `path` (deep or layered EXR), keeping at most
/// `max_layers` fragments per pixel (the nearest). If frame.color / frame.depth are empty they
/// are set from the layers: colour = front-to-back "over" composite, depth = the nearest
/// fragment with alpha > 0 (+inf if none). Throws Error(bad_input) naming the file.
void read_layers(const std::string& path, Frame& frame, int max_layers = 8);

/// Writes frame.layer_* as the layered EXR described above (float channels).
void write_layers_exr(const std::string& path, const Frame& frame);

}  // namespace dofkit::io
