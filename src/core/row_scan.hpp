// Whole-row predicates that let a pass skip a block of work, written branch-free so they
// vectorise (each is compiled for AVX-512F / AVX2 / baseline and chosen at run time).
#pragma once

namespace dofkit::core {

/// True if some v[i], i in [0, n), is > 0 (a NaN is not).
bool any_positive(const float* v, int n);

}  // namespace dofkit::core
