// Consumer smoke test: only the installed public headers and dofkit::dofkit. Renders a tiny
// frame whose far half is one bright pixel on black and checks that the blur spread it while
// keeping its energy, then that a bad setting raises dofkit::Error. Exit 0 = pass.
#include <dofkit/dofkit.hpp>

#include <cmath>
#include <cstdio>
#include <limits>

int main() {
  const int w = 48, h = 32;
  dofkit::Frame frame;
  frame.color = dofkit::Image(w, h, 4, 0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) frame.color.at(x, y, 3) = 1.0f;
  frame.color.at(24, 16, 0) = 1.0f;  // one red point light
  frame.depth = dofkit::Image(w, h, 1, std::numeric_limits<float>::infinity());

  dofkit::RenderSettings settings;
  settings.method = "reference";
  settings.camera.model = dofkit::BlurAtInfinity{2.0, 4.0};  // r(inf) = -4 px
  settings.threads = 2;
  const dofkit::RenderResult out = dofkit::render(frame, settings);

  double energy = 0;
  int lit = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = out.image.at(x, y, 0);
      energy += v;
      lit += v > 1e-4f;
    }
  std::printf("consumer: methods=%zu energy=%.4f lit=%d coc=%.2f\n", dofkit::methods().size(), energy, lit,
              out.coc.at(0, 0));
  if (std::abs(energy - 1.0) > 0.02 || lit < 30 || std::abs(out.coc.at(0, 0) + 4.0f) > 1e-4f) return 1;

  settings.camera.model = dofkit::ThinLens{50, -1.0, 5.0, 36};  // f-number <= 0
  try {
    dofkit::render(frame, settings);
    return 1;
  } catch (const dofkit::Error& e) {
    if (e.kind() != dofkit::ErrorKind::usage) return 1;
  }
  return 0;
}
