// Separable filters shared by the methods. All use clamp-to-edge borders and cost O(1) per
// pixel whatever the radius, so a large blur is as cheap as a small one.
#pragma once
#include "dofkit/image.hpp"

namespace dofkit::core {

/// Box mean of (2·rx+1) × (2·ry+1) taps on one plane (src and dst may alias).
void box_blur_plane(const float* src, float* dst, int w, int h, int rx, int ry);

/// Gaussian blur of standard deviation `sigma` px (both axes) approximated by `passes`
/// extended-box passes per axis (Gwosdek et al. 2011): the variance is exact for any real
/// sigma, the shape converges to a Gaussian (3 passes: within ~1 % of peak). O(1) per pixel.
/// In place on every plane of `img`. sigma <= 0 leaves the image unchanged.
void gaussian_blur(Image& img, float sigma, int passes = 3);
/// Same on one plane of w × h floats.
void gaussian_blur_plane(float* data, int w, int h, float sigma_x, float sigma_y, int passes = 3);

/// One extended-box pass along x (rows) or y (columns): weights 1 for |i| <= r and alpha for
/// |i| = r+1, normalised. In place.
void extended_box_x(float* data, int w, int h, int r, float alpha);
void extended_box_y(float* data, int w, int h, int r, float alpha);
/// Radius and end weight of one of `passes` extended boxes giving total variance sigma².
void extended_box_params(float sigma, int passes, int& r, float& alpha);

/// Bilinear sample of one plane at continuous position (x, y) in pixel units, where pixel
/// (i, j) has its centre at (i + 0.5, j + 0.5); clamp-to-edge.
float sample_bilinear(const float* plane, int w, int h, float x, float y);

}  // namespace dofkit::core
