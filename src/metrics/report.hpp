// Pictures and tables for quality reports: contact sheets with labels (a built-in 5×7
// bitmap font, so no font file or text-rendering library is needed), error heat maps, a
// depth view, and the Markdown table. No IO here: callers write the images.
#pragma once
#include <string>
#include <vector>

#include "dofkit/image.hpp"

namespace dofkit::metrics {

/// Linear-light RGB colour.
struct Rgb {
  float r = 0, g = 0, b = 0;
};

/// Linear value of an sRGB display value d in [0, 1] (inverse of display_value).
float linear_from_display(float d);

/// Draws `text` with the built-in 5×7 font (letters drawn upper-case; characters without a
/// glyph as a hollow box) at (x, y) = top-left corner, each font pixel `scale` × `scale`
/// image pixels, into planes 0..2 of `img` (plane 3, if any, set to 1 where drawn).
/// Clipped at the image border. Advance per character: 6·scale px.
void draw_text(Image& img, int x, int y, const std::string& text, int scale, Rgb colour);
/// Width in pixels of `text` drawn at `scale`.
int text_width(const std::string& text, int scale);
/// Height in pixels of one line of text at `scale` (7·scale).
int text_height(int scale);

/// RGBA heat map of a 1-plane error map: 0 → black, `max_error` and above → white, through
/// red and yellow (the "hot" ramp), so small errors stay visible as dark red.
Image heat_map(const Image& error, float max_error);

/// RGBA grey view of a depth map: display value proportional to z_min / z (near bright,
/// +inf black); where `band` (1 plane, may be null) is set the pixel is tinted blue.
Image depth_view(const Image& depth, const Image* band);

/// Box-filter down-sampling by an integer factor (>= 1) of every plane; the output is
/// floor(W / f) × floor(H / f) (at least 1 × 1).
Image downsample(const Image& img, int factor);

/// One cell of a contact sheet: a title above `top`, a caption above `bottom` (optional,
/// may be empty). Both images are RGBA linear; they are drawn clipped to [0, 1].
struct SheetCell {
  std::string title;
  Image top;
  std::string caption;
  Image bottom;
};

/// Splits `text` at spaces into lines at most `max_width` px wide at `scale` (a longer word
/// is cut); always at least one line.
std::vector<std::string> wrap_text(const std::string& text, int max_width, int scale);

/// Lays the cells out in a grid of `columns` columns on a dark background with
/// `font_scale`-sized labels (wrapped to the tile width) and a heading. Every cell is sized to the largest images.
/// Returns RGBA linear (alpha 1).
Image contact_sheet(const std::string& heading, const std::vector<SheetCell>& cells, int columns, int font_scale);

/// One row of a quality table.
struct QualityRow {
  std::string scene;   ///< scene name, or "mean" for the per-method means
  std::string method;  ///< method spec as given (e.g. "mcguire:variant=book"), or "input"
  double psnr_db = 0;
  double ssim = 0;
  double edge_psnr_db = 0;
  double time_ms = 0;  ///< render time; NaN for rows without a render (input)
};

/// Appends one "mean" row per method (in first-appearance order): the arithmetic mean over
/// scenes of each column (NaN values are skipped; a mean of nothing is NaN).
std::vector<QualityRow> with_means(const std::vector<QualityRow>& rows);

/// Markdown table: | scene | method | PSNR dB | SSIM | edge PSNR dB | time ms |. Numbers
/// with 2 decimals (SSIM 4), "inf" for +inf and "–" for NaN.
std::string markdown_table(const std::vector<QualityRow>& rows);

}  // namespace dofkit::metrics
