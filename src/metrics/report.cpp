// Contact sheets, heat maps and tables for quality reports (see report.hpp).
#include "metrics/report.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/parallel.hpp"
#include "dofkit/error.hpp"
#include "metrics/metrics.hpp"

namespace dofkit::metrics {

namespace {

// 5×7 glyphs, 7 rows of 5 columns per character ('#' = ink). Only what report labels
// need: A–Z, 0–9 and some punctuation; lower case is drawn as upper case.
struct Glyph {
  char ch;
  const char* rows[7];
};

constexpr Glyph kGlyphs[] = {
    {'A', {".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"}},
    {'B', {"####.", "#...#", "#...#", "####.", "#...#", "#...#", "####."}},
    {'C', {".###.", "#...#", "#....", "#....", "#....", "#...#", ".###."}},
    {'D', {"####.", "#...#", "#...#", "#...#", "#...#", "#...#", "####."}},
    {'E', {"#####", "#....", "#....", "####.", "#....", "#....", "#####"}},
    {'F', {"#####", "#....", "#....", "####.", "#....", "#....", "#...."}},
    {'G', {".###.", "#...#", "#....", "#.###", "#...#", "#...#", ".####"}},
    {'H', {"#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"}},
    {'I', {".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."}},
    {'J', {"..###", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##.."}},
    {'K', {"#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#"}},
    {'L', {"#....", "#....", "#....", "#....", "#....", "#....", "#####"}},
    {'M', {"#...#", "##.##", "#.#.#", "#.#.#", "#...#", "#...#", "#...#"}},
    {'N', {"#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#"}},
    {'O', {".###.", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."}},
    {'P', {"####.", "#...#", "#...#", "####.", "#....", "#....", "#...."}},
    {'Q', {".###.", "#...#", "#...#", "#...#", "#.#.#", "#..#.", ".##.#"}},
    {'R', {"####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"}},
    {'S', {".####", "#....", "#....", ".###.", "....#", "....#", "####."}},
    {'T', {"#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."}},
    {'U', {"#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."}},
    {'V', {"#...#", "#...#", "#...#", "#...#", "#...#", ".#.#.", "..#.."}},
    {'W', {"#...#", "#...#", "#...#", "#.#.#", "#.#.#", "#.#.#", ".#.#."}},
    {'X', {"#...#", "#...#", ".#.#.", "..#..", ".#.#.", "#...#", "#...#"}},
    {'Y', {"#...#", "#...#", ".#.#.", "..#..", "..#..", "..#..", "..#.."}},
    {'Z', {"#####", "....#", "...#.", "..#..", ".#...", "#....", "#####"}},
    {'0', {".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."}},
    {'1', {"..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."}},
    {'2', {".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"}},
    {'3', {"####.", "....#", "....#", ".###.", "....#", "....#", "####."}},
    {'4', {"...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."}},
    {'5', {"#####", "#....", "####.", "....#", "....#", "#...#", ".###."}},
    {'6', {"..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."}},
    {'7', {"#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."}},
    {'8', {".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."}},
    {'9', {".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."}},
    {'.', {".....", ".....", ".....", ".....", ".....", ".##..", ".##.."}},
    {',', {".....", ".....", ".....", ".....", ".##..", "..#..", ".#..."}},
    {':', {".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."}},
    {';', {".....", ".##..", ".##..", ".....", ".##..", "..#..", ".#..."}},
    {'-', {".....", ".....", ".....", "#####", ".....", ".....", "....."}},
    {'_', {".....", ".....", ".....", ".....", ".....", ".....", "#####"}},
    {'=', {".....", ".....", "#####", ".....", "#####", ".....", "....."}},
    {'+', {".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."}},
    {'(', {"...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."}},
    {')', {".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."}},
    {'/', {".....", "....#", "...#.", "..#..", ".#...", "#....", "....."}},
    {'%', {"##..#", "##..#", "...#.", "..#..", ".#...", "#..##", "#..##"}},
    {'|', {"..#..", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."}},
    {'[', {".###.", ".#...", ".#...", ".#...", ".#...", ".#...", ".###."}},
    {']', {".###.", "...#.", "...#.", "...#.", "...#.", "...#.", ".###."}},
    {'<', {"...#.", "..#..", ".#...", "#....", ".#...", "..#..", "...#."}},
    {'>', {".#...", "..#..", "...#.", "....#", "...#.", "..#..", ".#..."}},
    {'*', {".....", "..#..", "#.#.#", ".###.", "#.#.#", "..#..", "....."}},
    {'?', {".###.", "#...#", "....#", "...#.", "..#..", ".....", "..#.."}},
    {'\'', {"..#..", "..#..", ".#...", ".....", ".....", ".....", "....."}},
    {'!', {"..#..", "..#..", "..#..", "..#..", "..#..", ".....", "..#.."}},
    {'#', {".#.#.", ".#.#.", "#####", ".#.#.", "#####", ".#.#.", ".#.#."}},
    {' ', {".....", ".....", ".....", ".....", ".....", ".....", "....."}},
};
constexpr Glyph kMissing = {'?', {"#####", "#...#", "#...#", "#...#", "#...#", "#...#", "#####"}};

const Glyph& glyph(char c) {
  const char u = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  for (const Glyph& g : kGlyphs)
    if (g.ch == u) return g;
  return kMissing;
}

Rgb hot_ramp(float t) {
  // Black → red → yellow → white in display space, evenly over t in [0, 1].
  t = std::clamp(t, 0.0f, 1.0f);
  const float r = std::clamp(3.0f * t, 0.0f, 1.0f);
  const float g = std::clamp(3.0f * t - 1.0f, 0.0f, 1.0f);
  const float b = std::clamp(3.0f * t - 2.0f, 0.0f, 1.0f);
  return {linear_from_display(r), linear_from_display(g), linear_from_display(b)};
}

void fill(Image& img, int x0, int y0, int w, int h, Rgb c) {
  for (int y = std::max(0, y0); y < std::min(img.height(), y0 + h); ++y)
    for (int x = std::max(0, x0); x < std::min(img.width(), x0 + w); ++x) {
      img.at(x, y, 0) = c.r;
      img.at(x, y, 1) = c.g;
      img.at(x, y, 2) = c.b;
    }
}

void blit(Image& dst, const Image& src, int x0, int y0) {
  for (int y = 0; y < src.height(); ++y) {
    const int dy = y0 + y;
    if (dy < 0 || dy >= dst.height()) continue;
    for (int x = 0; x < src.width(); ++x) {
      const int dx = x0 + x;
      if (dx < 0 || dx >= dst.width()) continue;
      for (int c = 0; c < 3; ++c) dst.at(dx, dy, c) = std::clamp(src.at(x, y, c), 0.0f, 1.0f);
    }
  }
}

std::string number(double v, int decimals) {
  if (std::isnan(v)) return "–";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

float linear_from_display(float d) {
  d = std::clamp(d, 0.0f, 1.0f);
  return d <= 0.04045f ? d / 12.92f : std::pow((d + 0.055f) / 1.055f, 2.4f);
}

int text_width(const std::string& text, int scale) {
  return text.empty() ? 0 : static_cast<int>(text.size()) * 6 * scale - scale;
}

int text_height(int scale) { return 7 * scale; }

void draw_text(Image& img, int x, int y, const std::string& text, int scale, Rgb colour) {
  if (scale < 1) scale = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const Glyph& g = glyph(text[i]);
    const int gx = x + static_cast<int>(i) * 6 * scale;
    for (int r = 0; r < 7; ++r)
      for (int c = 0; c < 5; ++c) {
        if (g.rows[r][c] != '#') continue;
        for (int sy = 0; sy < scale; ++sy)
          for (int sx = 0; sx < scale; ++sx) {
            const int px = gx + c * scale + sx, py = y + r * scale + sy;
            if (px < 0 || py < 0 || px >= img.width() || py >= img.height()) continue;
            img.at(px, py, 0) = colour.r;
            img.at(px, py, 1) = colour.g;
            img.at(px, py, 2) = colour.b;
            if (img.channels() > 3) img.at(px, py, 3) = 1.0f;
          }
      }
  }
}

Image heat_map(const Image& error, float max_error) {
  if (!(max_error > 0)) throw_usage("heat_map: max_error must be > 0");
  Image out(error.width(), error.height(), 4, 1.0f);
  core::parallel_for(error.height(), [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < error.width(); ++x) {
        const Rgb c = hot_ramp(error.at(x, y) / max_error);
        out.at(x, y, 0) = c.r;
        out.at(x, y, 1) = c.g;
        out.at(x, y, 2) = c.b;
      }
  });
  return out;
}

Image depth_view(const Image& depth, const Image* band) {
  float zmin = std::numeric_limits<float>::infinity();
  for (float z : depth.data())
    if (z > 0 && z < zmin) zmin = z;
  Image out(depth.width(), depth.height(), 4, 1.0f);
  for (int y = 0; y < depth.height(); ++y)
    for (int x = 0; x < depth.width(); ++x) {
      const float z = depth.at(x, y);
      const float d = (z > 0 && std::isfinite(zmin)) ? std::clamp(zmin / z, 0.0f, 1.0f) : 0.0f;
      Rgb c{d, d, d};
      if (band && band->at(x, y) > 0.5f) c = {0.6f * d, 0.6f * d + 0.05f, 0.4f + 0.6f * d};
      out.at(x, y, 0) = linear_from_display(c.r);
      out.at(x, y, 1) = linear_from_display(c.g);
      out.at(x, y, 2) = linear_from_display(std::min(c.b, 1.0f));
    }
  return out;
}

Image downsample(const Image& img, int factor) {
  if (factor <= 1) return img;
  const int w = std::max(1, img.width() / factor), h = std::max(1, img.height() / factor);
  Image out(w, h, img.channels());
  for (int c = 0; c < img.channels(); ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        double s = 0;
        int n = 0;
        for (int sy = y * factor; sy < std::min(img.height(), (y + 1) * factor); ++sy)
          for (int sx = x * factor; sx < std::min(img.width(), (x + 1) * factor); ++sx, ++n) s += img.at(sx, sy, c);
        out.at(x, y, c) = n ? static_cast<float>(s / n) : 0.0f;
      }
  return out;
}

std::vector<std::string> wrap_text(const std::string& text, int max_width, int scale) {
  // Greedy word wrap; a word longer than a line is cut.
  const int max_chars = std::max(1, (max_width + scale) / (6 * scale));
  std::vector<std::string> lines;
  std::string line, word;
  auto flush_word = [&] {
    while (!word.empty()) {
      const std::string sep = line.empty() ? "" : " ";
      if (static_cast<int>(line.size() + sep.size() + word.size()) <= max_chars) {
        line += sep + word;
        word.clear();
      } else if (line.empty()) {
        lines.push_back(word.substr(0, max_chars));
        word.erase(0, max_chars);
      } else {
        lines.push_back(line);
        line.clear();
      }
    }
  };
  for (char ch : text) {
    if (ch == ' ')
      flush_word();
    else
      word += ch;
  }
  flush_word();
  if (!line.empty() || lines.empty()) lines.push_back(line);
  return lines;
}

Image contact_sheet(const std::string& heading, const std::vector<SheetCell>& cells, int columns, int font_scale) {
  if (cells.empty()) throw_usage("contact_sheet: no cells");
  font_scale = std::max(1, font_scale);
  columns = std::clamp(columns, 1, static_cast<int>(cells.size()));
  int tw = 0, th_top = 0, th_bottom = 0;
  for (const SheetCell& c : cells) {
    tw = std::max({tw, c.top.width(), c.bottom.width()});
    th_top = std::max(th_top, c.top.height());
    th_bottom = std::max(th_bottom, c.bottom.height());
  }
  // Labels wrap to the tile width; every cell reserves as many lines as the longest one.
  std::size_t title_lines = 1, caption_lines = 1;
  for (const SheetCell& c : cells) {
    title_lines = std::max(title_lines, wrap_text(c.title, tw, font_scale).size());
    caption_lines = std::max(caption_lines, wrap_text(c.caption, tw, font_scale).size());
  }
  const int pad = 4 * font_scale, line = text_height(font_scale) + 3 * font_scale;
  const int cell_w = tw + pad;
  const int cell_h = static_cast<int>(title_lines) * line + th_top +
                     (th_bottom > 0 ? static_cast<int>(caption_lines) * line + th_bottom : 0) + pad;
  const int rows = (static_cast<int>(cells.size()) + columns - 1) / columns;
  const int sheet_w = pad + columns * cell_w;
  const std::vector<std::string> head = wrap_text(heading, sheet_w - 2 * pad, font_scale);
  const int head_h = static_cast<int>(head.size()) * line + pad;
  Image sheet(sheet_w, head_h + rows * cell_h + pad, 4, 1.0f);
  const Rgb bg{0.012f, 0.012f, 0.015f}, white{1, 1, 1}, grey{0.5f, 0.5f, 0.5f};
  fill(sheet, 0, 0, sheet.width(), sheet.height(), bg);
  for (std::size_t i = 0; i < head.size(); ++i)
    draw_text(sheet, pad, pad + static_cast<int>(i) * line, head[i], font_scale, white);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const SheetCell& c = cells[i];
    const int x0 = pad + static_cast<int>(i % columns) * cell_w;
    int y = head_h + static_cast<int>(i / columns) * cell_h;
    const auto title = wrap_text(c.title, tw, font_scale);
    for (std::size_t k = 0; k < title.size(); ++k)
      draw_text(sheet, x0, y + font_scale + static_cast<int>(k) * line, title[k], font_scale, white);
    y += static_cast<int>(title_lines) * line;
    blit(sheet, c.top, x0, y);
    y += th_top;
    if (th_bottom > 0) {
      const auto caption = wrap_text(c.caption, tw, font_scale);
      for (std::size_t k = 0; k < caption.size(); ++k)
        draw_text(sheet, x0, y + font_scale + static_cast<int>(k) * line, caption[k], font_scale, grey);
      y += static_cast<int>(caption_lines) * line;
      blit(sheet, c.bottom, x0, y);
    }
  }
  return sheet;
}

std::vector<QualityRow> with_means(const std::vector<QualityRow>& rows) {
  std::vector<QualityRow> out = rows;
  std::vector<std::string> order;
  for (const QualityRow& r : rows)
    if (r.scene != "mean" && std::find(order.begin(), order.end(), r.method) == order.end()) order.push_back(r.method);
  auto mean = [&](const std::string& m, double QualityRow::*f) {
    double s = 0;
    int n = 0;
    for (const QualityRow& r : rows)
      if (r.method == m && r.scene != "mean" && !std::isnan(r.*f)) s += r.*f, ++n;
    return n ? s / n : std::numeric_limits<double>::quiet_NaN();
  };
  for (const std::string& m : order)
    out.push_back({"mean", m, mean(m, &QualityRow::psnr_db), mean(m, &QualityRow::ssim),
                   mean(m, &QualityRow::edge_psnr_db), mean(m, &QualityRow::time_ms)});
  return out;
}

std::string markdown_table(const std::vector<QualityRow>& rows) {
  std::string s =
      "| scene | method | PSNR dB | SSIM | edge PSNR dB | time ms |\n"
      "|---|---|---:|---:|---:|---:|\n";
  for (const QualityRow& r : rows) {
    const bool mean = r.scene == "mean";
    const std::string b = mean ? "**" : "";
    s += "| " + b + r.scene + b + " | " + b + r.method + b + " | " + number(r.psnr_db, 2) + " | " + number(r.ssim, 4) +
         " | " + number(r.edge_psnr_db, 2) + " | " + number(r.time_ms, 1) + " |\n";
  }
  return s;
}

}  // namespace dofkit::metrics
