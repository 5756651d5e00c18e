// EXR passthrough: the channels and header attributes of a colour EXR that a render does not
// replace, carried unchanged into the EXR output (`dofkit render`, unless --rgba-only).
//
// What passes: every channel of the input's first part except the ones read as colour (those
// become the output's R, G, B [, A]), in its own pixel type (half, float, uint) and sampling 1,
// value for value: AOVs are not blurred (a depth or normal pass of the sharp picture stays the
// sharp picture's). Dropped, each with a note: a channel named like an output channel (R, G, B,
// A) that was not the colour read (the output's own channel takes the name), a subsampled
// channel, and the other parts of a multi-part file. A deep input passes nothing (the output
// is flat; the CLI reads deep files only through --layers, never as --color). Attributes: all but the ones that
// describe the stored layout (channels, compression, data / display window, line order, tiles, type, name, version,
// chunk count, deep sample limits); the output's windows are (0, 0)–(W−1, H−1).
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "dofkit/image.hpp"
#include "io/image_io.hpp"

namespace dofkit::io {

class ExrPassthrough {
 public:
  /// What `color_path` (an EXR of `width` × `height`, already read as colour through
  /// `color_channels`, as for read_color) carries beyond its colour. `notes` receives one
  /// line per thing dropped. Throws Error(bad_input) naming the file if it cannot be read.
  static std::shared_ptr<const ExrPassthrough> read(const std::string& color_path,
                                                    const std::vector<std::string>& color_channels, int width,
                                                    int height, std::vector<std::string>& notes);
  ~ExrPassthrough();
  ExrPassthrough(const ExrPassthrough&) = delete;
  ExrPassthrough& operator=(const ExrPassthrough&) = delete;

  /// Nothing to carry (no extra channel and no attribute worth keeping): the output is written
  /// as without passthrough.
  bool empty() const;
  /// The channels carried, in the file's (sorted) order.
  std::vector<std::string> channel_names() const;

  struct Impl;

 private:
  friend void encode_exr_passthrough(const std::string&, const std::string&, const Image&, const WriteOptions&,
                                     const ExrPassthrough&);
  ExrPassthrough();
  std::unique_ptr<Impl> impl_;
};

/// Writes the 3/4-plane colour `rgba` (premultiplied, linear) as R, G, B [, A] per `opt`
/// (bits 16 = half, else float; opt.compression, "" = zip), plus `extra`'s channels and
/// attributes, straight into `file` (the OutputSet temporary). Throws Error(bad_input) naming
/// `format_path` on a write error.
void encode_exr_passthrough(const std::string& file, const std::string& format_path, const Image& rgba,
                            const WriteOptions& opt, const ExrPassthrough& extra);

}  // namespace dofkit::io
