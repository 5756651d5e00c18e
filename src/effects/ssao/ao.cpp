// The AO pipeline (include/dofkit/ao.hpp): settings checks, the passes in order, the debug
// views, and AoRenderer's buffers kept between frames.
//   sc2:  geometry → quarter-res depth → raw term (two sample sets) → blur passes
//   gtao: geometry → horizon search + slice integral → blur passes
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

  void run(const Image& depth, const Image* given_normals) {
    check_inputs(depth, given_normals);
    const int w = depth.width(), h = depth.height();
    const std::string& view = settings.debug_view;
    result.debug = Image();
    result.normals_reconstructed = given_normals == nullptr;
    const Camera cam = make_camera(w, h, settings.hfov_deg);
    const bool sc2_method = settings.method == "sc2";
    const bool plain = sc2_method ? sc2.plain : gtao.plain;
    result.ao.resize(w, h, 1);
    float* ao = result.ao.plane(0);
    {
      core::PassScope scope("ao/normals");
      if (given_normals)
        normals_from_input(*given_normals, depth, normals);
      else
        normals_from_depth(depth, cam, normals);
    }
    if (view == "normals") result.debug = normals_view(normals);
    if (sc2_method) {
      {
        core::PassScope scope("ao/quarter_depth");
        downsample_depth(depth, sc2.depth_downsample, quarter);
      }
      if (view == "quarter_depth") result.debug = quarter;
      const Sc2Kernel k = make_sc2_kernel(sc2, settings.radius_m, w);
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
      if (view == "small_set") result.debug = small;
      if (view == "wide_set") result.debug = wide;
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
    if (view == "raw") result.debug = plane_copy(ao, w, h);
    const BlurParams& bp = sc2_method ? sc2.blur : gtao.blur;
    if (bp.passes > 0) {
      core::PassScope scope("ao/blur");
      tmp.resize(w, h, 1);
      blur(depth, normals, bp, plain, ao, tmp.plane(0), [&](int pass, const float* plane) {
        if (view == "blur" + std::to_string(pass)) result.debug = plane_copy(plane, w, h);
      });
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
