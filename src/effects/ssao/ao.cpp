// The AO pipeline (include/dofkit/ao.hpp): settings checks, the passes in order, the debug
// views, and AoRenderer's buffers kept between frames.
//   sc2:  geometry → quarter-res depth → raw term (two sample sets) → blur passes
//   gtao: geometry → horizon search + slice integral → blur passes
// With resolution=half the passes run on the grid of every other pixel, then upsample.
// Every pass splits rows over the threads and computes each output pixel from its inputs
// alone, so the result is the same for every thread count.
#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"
#include "core/pass_profile.hpp"
#include "effects/ssao/ssao.hpp"

namespace dofkit {

namespace {

using namespace detail::ao;

std::string list_of(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

// Normals back in the file convention, encoded for viewing: 0.5 + 0.5 (X, Y, Z).
Image normals_view(const Image& n) {
  Image v(n.width(), n.height(), 3);
  const float sign[3] = {1, -1, -1};
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < n.plane_size(); ++i) v.plane(c)[i] = 0.5f + 0.5f * sign[c] * n.plane(c)[i];
  return v;
}

Image plane_copy(const float* p, int w, int h) {
  Image v(w, h, 1);
  std::copy(p, p + static_cast<std::size_t>(w) * h, v.plane(0));
  return v;
}

}  // namespace

struct AoRenderer::Impl {
  AoSettings settings;
  Sc2Params sc2;
  GtaoParams gtao;
  AoResult result;
  Image normals, quarter, small, wide, tmp;
  Image grid_depth, grid_normals, grid_ao;  ///< resolution=half: the sampled grid's buffers

  explicit Impl(AoSettings s) : settings(std::move(s)) {
    if (settings.method != "sc2" && settings.method != "gtao")
      throw_usage("--method " + settings.method + ": unknown AO method (known: sc2, gtao)");
    if (!(settings.hfov_deg > 0 && settings.hfov_deg < 180))
      throw_usage("field of view: must be in (0, 180) degrees, got " + std::to_string(settings.hfov_deg));
    if (!(settings.radius_m > 0) || !std::isfinite(settings.radius_m))
      throw_usage("--radius: must be a finite number of metres > 0, got " + std::to_string(settings.radius_m));
    if (settings.threads < 0) throw_usage("--threads: must be >= 0");
    if (settings.method == "sc2")
      sc2 = parse_sc2(settings.params);
    else
      gtao = parse_gtao(settings.params);
    if (!settings.debug_view.empty()) {
      const std::vector<std::string> names = debug_view_names(settings.method);
      if (std::find(names.begin(), names.end(), settings.debug_view) == names.end())
        throw_usage("--debug-view " + settings.debug_view + ": not a view of AO method " + settings.method +
                    " (views: " + list_of(names) + ")");
      const BlurParams& b = settings.method == "sc2" ? sc2.blur : gtao.blur;
      if (settings.debug_view.rfind("blur", 0) == 0 && std::stoi(settings.debug_view.substr(4)) > b.passes)
        throw_usage("--debug-view " + settings.debug_view + ": the blur runs " + std::to_string(b.passes) +
                    " pass(es) (blur_passes)");
    }
  }

  void run(const Image& full_depth, const Image* given_normals) {
    check_inputs(full_depth, given_normals);
    const int fw = full_depth.width(), fh = full_depth.height();
    const std::string& view = settings.debug_view;
    result.debug = Image();
    result.normals_reconstructed = given_normals == nullptr;
    const bool sc2_method = settings.method == "sc2";
    const bool plain = sc2_method ? sc2.plain : gtao.plain;
    const bool half = sc2_method ? sc2.half : gtao.half;
    // The sampled grid: every pixel, or with resolution=half the pixels (2i, 2j) (halfres.cpp).
    const Camera full_cam = make_camera(fw, fh, settings.hfov_deg);
    const Camera cam = half ? half_camera(full_cam) : full_cam;
    if (half) {
      subsample2(full_depth, grid_depth);
      if (given_normals) subsample2(*given_normals, grid_normals);
    }
    const Image& depth = half ? grid_depth : full_depth;
    const Image* normals_in = half && given_normals ? &grid_normals : given_normals;
    const int w = cam.w, h = cam.h;
    // Debug views of grid-sized buffers are shown at full size.
    const auto show = [&](Image img) { result.debug = half ? upsample_nearest(img, fw, fh) : std::move(img); };
    result.ao.resize(fw, fh, 1);
    if (half) grid_ao.resize(w, h, 1);
    float* ao = half ? grid_ao.plane(0) : result.ao.plane(0);
    {
      core::PassScope scope("ao/normals");
      if (normals_in)
        normals_from_input(*normals_in, depth, normals);
      else
        normals_from_depth(depth, cam, normals);
    }
    if (view == "normals") show(normals_view(normals));
    if (sc2_method) {
      {
        core::PassScope scope("ao/quarter_depth");
        downsample_depth(full_depth, sc2.depth_downsample, quarter);
      }
      if (view == "quarter_depth") result.debug = quarter;
      Sc2Kernel k = make_sc2_kernel(sc2, settings.radius_m, w);
      if (half) {
        k.q_scale = 0.5f;
        k.q_offset = -0.125f;
      }
      Sc2Out out{ao, nullptr, nullptr};
      if (view == "small_set") {
        small.resize(w, h, 1);
        out.small = small.plane(0);
      }
      if (view == "wide_set") {
        wide.resize(w, h, 1);
        out.wide = wide.plane(0);
      }
      {
        core::PassScope scope("ao/sample");
        core::parallel_for(
            h,
            [&](int y0, int y1) {
              if (plain)
                sc2_rows_plain(cam, depth, normals, quarter, k, out, y0, y1);
              else
                sc2_rows_fast(cam, depth, normals, quarter, k, out, y0, y1);
            },
            8);
      }
      if (view == "small_set") show(small);
      if (view == "wide_set") show(wide);
    } else {
      const GtaoKernel k = make_gtao_kernel(gtao, settings.radius_m, w);
      core::PassScope scope("ao/sample");
      core::parallel_for(
          h,
          [&](int y0, int y1) {
            if (plain)
              gtao_rows_plain(cam, depth, normals, k, ao, y0, y1);
            else
              gtao_rows_fast(cam, depth, normals, k, ao, y0, y1);
          },
          4);
    }
    if (view == "raw") show(plane_copy(ao, w, h));
    const BlurParams& bp = sc2_method ? sc2.blur : gtao.blur;
    if (bp.passes > 0) {
      core::PassScope scope("ao/blur");
      tmp.resize(w, h, 1);
      blur(depth, normals, bp, plain, ao, tmp.plane(0), [&](int pass, const float* plane) {
        if (view == "blur" + std::to_string(pass)) show(plane_copy(plane, w, h));
      });
    }
    if (half) {
      core::PassScope scope("ao/upsample");
      upsample_ao(full_depth, depth, ao, static_cast<float>(bp.depth_threshold), result.ao.plane(0));
    }
  }
};

AoRenderer::AoRenderer(AoSettings settings) : impl_(std::make_unique<Impl>(std::move(settings))) {}
AoRenderer::~AoRenderer() = default;
AoRenderer::AoRenderer(AoRenderer&&) noexcept = default;
AoRenderer& AoRenderer::operator=(AoRenderer&&) noexcept = default;

const AoResult& AoRenderer::render(const Image& depth, const Image* normals) {
  core::with_threads(impl_->settings.threads, [&] { impl_->run(depth, normals); });
  return impl_->result;
}

const AoSettings& AoRenderer::settings() const { return impl_->settings; }

AoResult ambient_occlusion(const Image& depth, const Image* normals, const AoSettings& settings) {
  AoRenderer r(settings);
  return r.render(depth, normals);
}

std::vector<MethodInfo> ao_methods() { return method_infos(); }

}  // namespace dofkit
