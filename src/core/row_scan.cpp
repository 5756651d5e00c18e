#include "core/row_scan.hpp"
#include "core/clones.hpp"

namespace dofkit::core {

DOFKIT_CLONES
bool any_positive(const float* __restrict v, int n) {
  int on = 0;
  for (int i = 0; i < n; ++i) on |= v[i] > 0.0f;
  return on != 0;
}

}  // namespace dofkit::core
