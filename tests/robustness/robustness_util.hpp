// Shared helpers for the robustness suite: frames with hostile content, the list of every
// registered method, and one checker that says whether a render ended acceptably.
#pragma once
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "dofkit/render.hpp"

namespace dofkit::robust {

inline constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
inline constexpr float kInf = std::numeric_limits<float>::infinity();
inline constexpr float kFltMax = std::numeric_limits<float>::max();
inline constexpr float kDenorm = std::numeric_limits<float>::denorm_min() * 7;

/// Every registered technique (iterating the registry, so new methods are covered).
inline std::vector<std::string> method_names() {
  std::vector<std::string> v;
  for (const auto& m : methods()) v.push_back(m.name);
  return v;
}

/// A textured opaque frame; depth spans near (in front of focus 2 m), focus, far and +inf,
/// so both CoC signs and the clamp occur.
inline Frame textured_frame(int w, int h) {
  Frame f;
  f.color = Image(w, h, 4, 1.0f);
  f.depth = Image(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c)
        f.color.at(x, y, c) = 0.1f + 0.8f * std::fabs(std::sin(0.37f * x * (c + 1) + 0.23f * y));
      const int k = (x * 7 + y * 3) % 5;
      f.depth.at(x, y) = k == 0 ? 0.3f : k == 1 ? 2.0f : k == 2 ? 6.0f : k == 3 ? 40.0f : kInf;
    }
  return f;
}

inline RenderSettings default_settings(const std::string& method) {
  RenderSettings s;
  s.method = method;
  s.camera.model = BlurAtInfinity{2.0, 6.0};
  s.camera.max_coc_px = 12;
  s.threads = 2;
  return s;
}

inline std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

/// How a render ended.
struct Outcome {
  bool rendered = false;
  bool error = false;
  ErrorKind kind = ErrorKind::internal;
  std::string message;
  RenderResult result;
};

inline Outcome try_render(const Frame& f, const RenderSettings& s) {
  Outcome o;
  try {
    o.result = render(f, s);
    o.rendered = true;
  } catch (const Error& e) {
    o.error = true;
    o.kind = e.kind();
    o.message = e.what();
  }
  // Any other exception type escapes and fails the test: dofkit throws only dofkit::Error.
  return o;
}

/// Index of the first non-finite sample, or -1.
inline long long first_non_finite(const Image& img) {
  const auto& d = img.data();
  for (std::size_t i = 0; i < d.size(); ++i)
    if (!std::isfinite(d[i])) return static_cast<long long>(i);
  return -1;
}

/// Known, reported bugs (method, case label) → bug id + one-line description. Such a case is
/// still run and checked, but its failures are printed as "[ TODO ]" instead of failing the
/// suite, so one open bug in one method does not block everything else. Remove the entry when
/// the method is fixed (the test prints when a listed case passes).
inline const char* known_bug(const std::string& method, const std::string& label) {
  (void)method;
  (void)label;
  return nullptr;  // none open (BUG-R2, sterna near/far planes equal in float, is fixed)
}

/// Problems with one render's outcome under the contract of issue 9: finite output of the
/// input's size, or a clear usage/bad-input Error (an internal error is a bug). `must_render`
/// forbids even a clear error (used where the input is valid and ordinary, e.g. hostile colour
/// that render() sanitises).
inline std::vector<std::string> contract_problems(const Frame& f, const Outcome& o, bool must_render) {
  std::vector<std::string> p;
  if (o.error) {
    if (o.kind == ErrorKind::internal) p.push_back("internal error: " + o.message);
    if (o.message.empty() || o.message.find('\n') != std::string::npos) p.push_back("unclear message: " + o.message);
    if (must_render) p.push_back("refused an ordinary input: " + o.message);
    return p;
  }
  const Image& img = o.result.image;
  if (img.width() != f.width() || img.height() != f.height() || img.channels() != 4 ||
      img.data().size() != f.color.data().size()) {
    p.push_back("output is " + size_text(img.width(), img.height()) + "x" + std::to_string(img.channels()));
    return p;
  }
  const long long bad = first_non_finite(img);
  if (bad >= 0) {
    const long long plane = static_cast<long long>(img.plane_size()), i = bad % plane;
    std::ostringstream s;
    s << "non-finite output " << img.data()[bad] << " at pixel (" << i % img.width() << ", " << i / img.width()
      << ") channel " << bad / plane;
    p.push_back(s.str());
  }
  if (!o.result.coc.same_size(img) || first_non_finite(o.result.coc) >= 0)
    p.push_back("CoC map wrong size or non-finite");
  return p;
}

inline void expect_finite_or_clear_error(const Frame& f, const RenderSettings& s, const std::string& label,
                                         bool must_render = false) {
  const std::string where = s.method + ", " + size_text(f.width(), f.height()) + ", " + label;
  const Outcome o = try_render(f, s);
  const auto problems = contract_problems(f, o, must_render);
  if (const char* bug = known_bug(s.method, label)) {
    std::cout << "[ TODO ] " << where << ": " << bug << " -- "
              << (problems.empty() ? "passes in this case (remove the entry once every case passes)"
                                   : "still " + problems[0])
              << "\n";
    return;
  }
  for (const auto& p : problems) ADD_FAILURE() << where << ": " << p;
  if (o.error && problems.empty()) std::cout << "[ note ] " << where << ": refused: " << o.message << "\n";
}

}  // namespace dofkit::robust
