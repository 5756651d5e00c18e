// `dofkit compare REF TEST [--depth Z] [--crop X0,Y0,X1,Y1] [--json]`: scores TEST against
// the reference REF by the protocol in src/metrics/metrics.hpp (docs/quality.md).
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "budget.hpp"
#include "cli_common.hpp"
#include "commands.hpp"
#include "dofkit/error.hpp"
#include "io/image_io.hpp"
#include "metrics/metrics.hpp"

namespace dofkit::cli {

namespace {

nlohmann::json json_number(double v) {
  if (std::isnan(v)) return nullptr;
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

std::string text_number(double v, const char* fmt_spec) {
  if (std::isnan(v)) return "n/a";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format(fmt::runtime(fmt_spec), v);
}

}  // namespace

void add_compare_command(CLI::App& app) {
  struct Opts {
    std::string ref, test, depth, crop;
    bool json = false;
    BudgetFlags budget;
  };
  auto opts = std::make_shared<Opts>();
  auto* cmd =
      app.add_subcommand("compare",
                         "score TEST against the reference REF: PSNR and SSIM of clipped sRGB, edge PSNR (with "
                         "--depth), linear RMSE\nexample: dofkit compare ground_truth.exr out.exr --depth depth.exr");
  cmd->add_option("REF", opts->ref, "reference image (e.g. the ground truth)")->required();
  cmd->add_option("TEST", opts->test, "image to score")->required();
  cmd->add_option(
      "--depth", opts->depth,
      "pinhole depth (planar z) of the reference: enables edge PSNR (pixels within 12 px of a depth jump > 5 %)");
  cmd->add_option(
      "--crop", opts->crop,
      "score only the region X0,Y0,X1,Y1 (pixels; X1, Y1 exclusive); the edge band is found on the whole depth map");
  cmd->add_flag("--json", opts->json,
                "print one JSON object (PSNR inf as the string \"inf\", undefined values as null)");
  opts->budget.add(cmd);
  cmd->callback([opts] {
    opts->budget.apply();
    // Sizes before pixels: the headers first, compared, and the memory of the scores.
    const io::ImageInfo ri = io::probe_image(opts->ref, "colour"), ti = io::probe_image(opts->test, "colour");
    if (ri.width != ti.width || ri.height != ti.height)
      throw_bad_input(fmt::format("compare: {} is {}x{} but {} is {}x{}", opts->ref, ri.width, ri.height, opts->test,
                                  ti.width, ti.height));
    if (!opts->depth.empty()) {
      const io::ImageInfo di = io::probe_image(opts->depth, "depth");
      if (di.width != ri.width || di.height != ri.height)
        throw_bad_input(fmt::format("compare: depth {} is {}x{} but {} is {}x{}", opts->depth, di.width, di.height,
                                    opts->ref, ri.width, ri.height));
    }
    // Two RGBA float images, the depth, the edge band, and the metrics' planes (~96 B/px).
    check_memory(96u * 1024 * 1024 + static_cast<std::uint64_t>(ri.width) * ri.height * 160,
                 fmt::format("comparing {}x{} images", ri.width, ri.height),
                 "compare smaller images (--crop does not "
                 "lower it: the whole images are read)");
    Image ref = io::read_color(opts->ref);
    Image test = io::read_color(opts->test);
    if (!ref.same_size(test))
      throw_bad_input(fmt::format("compare: {} is {}x{} but {} is {}x{}", opts->ref, ref.width(), ref.height(),
                                  opts->test, test.width(), test.height()));
    Image band;
    const bool have_depth = !opts->depth.empty();
    if (have_depth) {
      const Image depth = io::read_depth(opts->depth, io::DepthOptions{});
      if (!depth.same_size(ref))
        throw_bad_input(fmt::format("compare: depth {} is {}x{} but {} is {}x{}", opts->depth, depth.width(),
                                    depth.height(), opts->ref, ref.width(), ref.height()));
      band = metrics::edge_band(depth, metrics::kEdgeBandPx, metrics::kEdgeJump);
    }
    int x0 = 0, y0 = 0, x1 = ref.width(), y1 = ref.height();
    if (!opts->crop.empty()) {
      char extra = 0;
      if (std::sscanf(opts->crop.c_str(), "%d,%d,%d,%d%c", &x0, &y0, &x1, &y1, &extra) != 4)
        throw_usage("--crop " + opts->crop + ": expected X0,Y0,X1,Y1 (integers)");
      ref = metrics::crop(ref, x0, y0, x1, y1);
      test = metrics::crop(test, x0, y0, x1, y1);
      if (have_depth) band = metrics::crop(band, x0, y0, x1, y1);
    }
    if (ref.width() < 11 || ref.height() < 11)
      throw_usage(fmt::format("compare: the compared region is {}x{}; SSIM's 11x11 window needs at least 11x11",
                              ref.width(), ref.height()));
    const metrics::Scores s = metrics::compare_with_mask(ref, test, have_depth ? &band : nullptr);
    if (opts->json) {
      nlohmann::json j{{"reference", opts->ref},
                       {"test", opts->test},
                       {"width", ref.width()},
                       {"height", ref.height()},
                       {"crop", {x0, y0, x1, y1}},
                       {"psnr_db", json_number(s.psnr_db)},
                       {"ssim", json_number(s.ssim)},
                       {"edge_psnr_db", json_number(s.edge_psnr_db)},
                       {"edge_fraction", json_number(s.edge_fraction)},
                       {"rmse_linear", json_number(s.rmse_linear)}};
      if (have_depth) j["depth"] = opts->depth;
      std::cout << j.dump(2) << "\n";
      return;
    }
    std::cout << "PSNR        " << text_number(s.psnr_db, "{:.3f}") << " dB\n"
              << "SSIM        " << text_number(s.ssim, "{:.5f}") << "\n"
              << "edge PSNR   "
              << (have_depth ? text_number(s.edge_psnr_db, "{:.3f}") + " dB (" +
                                   text_number(100 * s.edge_fraction, "{:.1f}") + " % of pixels)"
                             : std::string("n/a (give --depth)"))
              << "\n"
              << "RMSE linear " << text_number(s.rmse_linear, "{:.6f}") << "\n";
  });
}

}  // namespace dofkit::cli
