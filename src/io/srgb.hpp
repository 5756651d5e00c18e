// The sRGB transfer curve (IEC 61966-2-1) as dofkit's integer files use it.
#pragma once
#include <cstdint>

namespace dofkit::io {

/// Linear → sRGB-encoded, clamped to [0, 1] (NaN → 0), computed in double.
float encode_srgb(float v);

/// sRGB-encoded → linear for a value k / 65535 (every 8- and 16-bit code is one), clamped to
/// [0, 1] (NaN → 0); a table lookup.
float decode_srgb(float v);

/// The 8-bit code an 8-bit file stores for linear v: quantise(encode_srgb(v), 255)
/// (quantise.hpp), bit for bit, without pow: v is compared with the 255 linear values where
/// the code steps up, found once by bisection on encode_srgb itself, starting from a table
/// indexed by v's exponent and top mantissa bits. ~4× faster than encode_srgb; tested
/// against it around every step and on a sweep of all floats in [0, 1].
std::uint8_t srgb8_code(float v);

}  // namespace dofkit::io
