// OpenImageIO, loaded when a file needs it.
//
// Why: OpenImageIO's Debian build links ~260 shared libraries (OpenCV, ffmpeg, GStreamer,
// DCMTK, OpenVDB, …); a program linked to it spends ~0.23 s in the dynamic loader before
// main(), a third of a whole 1080p `dofkit render` call once EXR coding went direct
// (exr_direct.hpp). So the few OpenImageIO calls dofkit makes live in a separate shared
// module, libdofkit_oiio.so (src/io/oiio/), opened with dlopen the first time a file is not
// one of the common EXRs. The interface is plain data and error strings: no exception and
// no OpenImageIO type crosses it.
#pragma once
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace dofkit::io::oiio {

/// What dofkit reads from an image's header.
struct Spec {
  int width = 0, height = 0, depth = 1, nchannels = 0;
  std::vector<std::string> channelnames;
  int alpha_channel = -1, z_channel = -1;
  int full_x = 0, full_y = 0, full_width = 0, full_height = 0;  ///< display window
  int x = 0, y = 0;                                             ///< data window origin
  bool deep = false;
  bool integer = false;       ///< integer samples (normalised to [0, 1] when read as float)
  bool unassociated = false;  ///< the file declares straight (unassociated) alpha
};

/// Deep samples as flat arrays: pixel p (row-major over the data window) has counts[p]
/// samples, starting at sample index first[p]; sample s holds channels values[s·nc …].
struct DeepSamples {
  std::vector<std::string> channelnames;
  std::vector<int> counts;
  std::vector<std::size_t> first;
  std::vector<float> values;
};

class Input {
 public:
  virtual ~Input() = default;
  const Spec& spec() const { return spec_; }
  /// Channels [cb, ce) of the first subimage as float, pixel-interleaved. False on error.
  virtual bool read(int cb, int ce, float* out) = 0;
  /// The first subimage's deep samples (a deep file). False on error.
  virtual bool read_deep(DeepSamples& out) = 0;
  /// The last error, on one line ("unknown error" if none was given).
  virtual std::string error() = 0;

 protected:
  Spec spec_;
};

enum class PixelType { uint8, uint16, half, float32 };

/// An image to write: interleaved float samples, converted to `type` by OpenImageIO.
struct OutSpec {
  int width = 0, height = 0, nchannels = 0;
  std::vector<std::string> channelnames;
  int alpha_channel = -1;
  PixelType type = PixelType::float32;
  std::vector<std::pair<std::string, std::string>> string_attributes;  ///< e.g. Compression
  std::vector<std::pair<std::string, int>> int_attributes;             ///< e.g. oiio:UnassociatedAlpha
};

enum class WriteResult { ok, no_writer, failed };

class Module {
 public:
  virtual ~Module() = default;
  /// Opens an image for reading (nullptr and `error` set on failure). `straight_alpha`: ask
  /// for the file's own values of unassociated-alpha files ("oiio:UnassociatedAlpha").
  virtual std::unique_ptr<Input> open(const std::string& path, bool straight_alpha, std::string& error) = 0;
  /// Writes `pixels` to `file` in the format of `format_path`'s extension.
  virtual WriteResult write(const std::string& file, const std::string& format_path, const OutSpec& spec,
                            const float* pixels, std::string& error) = 0;
};

/// The module, loaded on first use (thread-safe). Throws Error(internal) naming the places it
/// looked if it cannot be loaded. $DOFKIT_OIIO_MODULE, if set, is tried first.
Module& module();

}  // namespace dofkit::io::oiio

/// The module's entry point (extern "C" so dlsym finds it by this name).
extern "C" dofkit::io::oiio::Module* dofkit_oiio_module_v1();
