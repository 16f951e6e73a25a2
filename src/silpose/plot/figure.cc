#include "silpose/plot/figure.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "silpose/io/image_codec.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

// Text widths are estimated, not measured, so that the SVG (whose font the viewer picks) and the
// PNG share one layout: 0.6 em per character is about the average advance of common sans fonts.
constexpr double kCharWidthEm = 0.6;
constexpr double kLabelScale = 1.2;
constexpr double kPadPx = 6.0;
const Rgb kGridColour{221, 221, 221};
const Rgb kAxisColour{0, 0, 0};
const Rgb kTextColour{0, 0, 0};
const Rgb kLegendBorder{170, 170, 170};

double TextWidth(const std::string& text, double font_px) {
  // UTF-8 continuation bytes do not start a character.
  int characters = 0;
  for (unsigned char c : text) characters += (c & 0xC0) != 0x80;
  return characters * kCharWidthEm * font_px;
}

std::string Number(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f", value);
  return buffer;
}

// Colours: explicit ones kept, the others numbered in order (series, then reference lines).
struct PanelColours {
  std::vector<Rgb> series;
  std::vector<Rgb> references;
};

PanelColours ColoursOf(const PlotPanel& panel) {
  PanelColours colours;
  int next = 0;
  for (const PlotSeries& s : panel.series) {
    colours.series.push_back(s.colour ? *s.colour : PaletteColour(next++));
  }
  for (const ReferenceLine& r : panel.reference_lines) {
    colours.references.push_back(r.colour ? *r.colour : PaletteColour(next++));
  }
  return colours;
}

struct LegendEntry {
  std::string label;
  Rgb colour;
  bool line = true;
  bool dashed = false;
  Marker marker = Marker::kNone;
};

std::vector<LegendEntry> LegendOf(const PlotPanel& panel, const PanelColours& colours) {
  std::vector<LegendEntry> entries;
  if (panel.legend == LegendPosition::kNone) return entries;
  for (size_t i = 0; i < panel.series.size(); ++i) {
    const PlotSeries& s = panel.series[i];
    if (!s.label.empty()) entries.push_back({s.label, colours.series[i], s.line, false, s.marker});
  }
  for (size_t i = 0; i < panel.reference_lines.size(); ++i) {
    const ReferenceLine& r = panel.reference_lines[i];
    if (!r.label.empty()) entries.push_back({r.label, colours.references[i], true, true});
  }
  return entries;
}

// The legend's box in figure pixels.
struct LegendBox {
  double left = 0.0, top = 0.0, width = 0.0, height = 0.0, row_height = 0.0;
};

constexpr double kLegendSampleWidthPx = 24.0;

LegendBox LegendAt(const PanelLayout& layout, LegendPosition position,
                   const std::vector<LegendEntry>& entries, double font_px) {
  LegendBox box;
  double text = 0.0;
  for (const LegendEntry& e : entries) text = std::max(text, TextWidth(e.label, font_px));
  box.row_height = 1.5 * font_px;
  box.width = kPadPx + kLegendSampleWidthPx + kPadPx + text + kPadPx;
  box.height = kPadPx + box.row_height * static_cast<double>(entries.size()) + kPadPx / 2;
  const double margin = 8.0;
  const bool right =
      position == LegendPosition::kTopRight || position == LegendPosition::kBottomRight;
  const bool top = position == LegendPosition::kTopRight || position == LegendPosition::kTopLeft;
  box.left =
      right ? layout.left_px + layout.width_px - margin - box.width : layout.left_px + margin;
  box.top = top ? layout.top_px + margin : layout.top_px + layout.height_px - margin - box.height;
  return box;
}

// Pixels of the panel's data: points, samples along lines, error bars and reference lines every
// few pixels.
std::vector<cv::Point2d> DataPixels(const PlotPanel& panel, const PanelLayout& layout) {
  std::vector<cv::Point2d> pixels;
  const double spacing = 4.0;
  auto segment = [&](double x1, double y1, double x2, double y2) {
    const int steps = 1 + static_cast<int>(std::hypot(x2 - x1, y2 - y1) / spacing);
    for (int i = 0; i <= steps; ++i) {
      const double t = static_cast<double>(i) / steps;
      pixels.emplace_back(x1 + t * (x2 - x1), y1 + t * (y2 - y1));
    }
  };
  for (const PlotSeries& s : panel.series) {
    for (size_t i = 0; i < s.x.size(); ++i) {
      const double x = layout.XToPixel(s.x[i]), y = layout.YToPixel(s.y[i]);
      pixels.emplace_back(x, y);
      if (s.line && i > 0) {
        segment(layout.XToPixel(s.x[i - 1]), layout.YToPixel(s.y[i - 1]), x, y);
      }
      if (!s.y_error.empty()) {
        segment(x, layout.YToPixel(s.y[i] - s.y_error[i]), x,
                layout.YToPixel(s.y[i] + s.y_error[i]));
      }
    }
  }
  for (const ReferenceLine& r : panel.reference_lines) {
    const double y = layout.YToPixel(r.y);
    segment(layout.left_px, y, layout.left_px + layout.width_px, y);
  }
  return pixels;
}

LegendBox PlaceLegend(const PlotPanel& panel, const PanelLayout& layout,
                      const std::vector<LegendEntry>& entries, double font_px) {
  if (panel.legend != LegendPosition::kBest) {
    return LegendAt(layout, panel.legend, entries, font_px);
  }
  const std::vector<cv::Point2d> pixels = DataPixels(panel, layout);
  LegendBox best;
  size_t fewest = std::numeric_limits<size_t>::max();
  for (LegendPosition corner : {LegendPosition::kTopRight, LegendPosition::kTopLeft,
                                LegendPosition::kBottomRight, LegendPosition::kBottomLeft}) {
    const LegendBox box = LegendAt(layout, corner, entries, font_px);
    const double pad = 3.0;
    size_t covered = 0;
    for (const cv::Point2d& p : pixels) {
      covered += p.x >= box.left - pad && p.x <= box.left + box.width + pad &&
                 p.y >= box.top - pad && p.y <= box.top + box.height + pad;
    }
    if (covered < fewest) {
      fewest = covered;
      best = box;
    }
  }
  return best;
}

// Range of the data along one axis (y includes error bars and reference lines).
struct DataRange {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    min = std::min(min, v);
    max = std::max(max, v);
  }
  bool empty() const { return min > max; }
};

// The range of an axis before ticks: fixed ends where given, the data elsewhere.
void RangeOf(const PlotAxis& axis, const DataRange& data, double* min, double* max) {
  double lo = 0.0, hi = 1.0;
  if (!data.empty()) {
    lo = data.min;
    hi = data.max;
    if (lo == hi) {
      const double half = lo != 0.0 ? std::abs(lo) / 10.0 : 1.0;
      lo -= half;
      hi += half;
    }
    // Automatic ends get 2 % of room, so that points on a tick are not drawn on the frame.
    const double room = 0.02 * (hi - lo);
    lo -= room;
    hi += room;
  }
  if (axis.min) lo = *axis.min;
  if (axis.max) hi = *axis.max;
  if (!(lo < hi)) {  // one fixed end beyond all the data
    if (axis.min) {
      hi = lo + (data.empty() || data.max == data.min ? 1.0 : data.max - data.min);
    } else {
      lo = hi - (data.empty() || data.max == data.min ? 1.0 : data.max - data.min);
    }
  }
  *min = lo;
  *max = hi;
}

AxisLayout AxisFor(const PlotAxis& axis, double min, double max) {
  AxisLayout layout = NiceAxis(min, max, axis.target_ticks, true);
  // Fixed ends stay where they were asked to be; the ticks are those inside.
  if (axis.min || axis.max) {
    const double lo = axis.min ? *axis.min : layout.min;
    const double hi = axis.max ? *axis.max : layout.max;
    AxisLayout kept = NiceAxis(lo, hi, axis.target_ticks, false);
    return kept;
  }
  return layout;
}

std::string AsciiForHershey(const std::string& text) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      out += static_cast<char>(c);
    } else if (c == 0xC2 && i + 1 < text.size() &&
               static_cast<unsigned char>(text[i + 1]) == 0xB1) {
      out += "+-";
      ++i;
    } else if (c == 0xC2 && i + 1 < text.size() &&
               static_cast<unsigned char>(text[i + 1]) == 0xB0) {
      out += " deg";
      ++i;
    } else if ((c & 0xC0) != 0x80) {
      out += '?';
    }
  }
  return out;
}

// ---- SVG ----

class SvgWriter {
 public:
  explicit SvgWriter(std::ostringstream* out) : out_(*out) {}

  void Line(double x1, double y1, double x2, double y2, const Rgb& colour, double width,
            bool dashed = false) {
    out_ << "<line x1=\"" << Number(x1) << "\" y1=\"" << Number(y1) << "\" x2=\"" << Number(x2)
         << "\" y2=\"" << Number(y2) << "\" stroke=\"" << ToHex(colour) << "\" stroke-width=\""
         << Number(width) << "\"";
    if (dashed) out_ << " stroke-dasharray=\"6,4\"";
    out_ << "/>\n";
  }
  void Text(double x, double y, const std::string& text, double font_px, const char* anchor,
            bool bold = false, double rotate_deg = 0.0) {
    out_ << "<text x=\"" << Number(x) << "\" y=\"" << Number(y) << "\" font-size=\""
         << Number(font_px) << "\" text-anchor=\"" << anchor << "\" fill=\"" << ToHex(kTextColour)
         << "\"";
    if (bold) out_ << " font-weight=\"bold\"";
    if (rotate_deg != 0.0) {
      out_ << " transform=\"rotate(" << Number(rotate_deg) << " " << Number(x) << " " << Number(y)
           << ")\"";
    }
    out_ << ">" << EscapeXml(text) << "</text>\n";
  }
  void Marker(silpose::Marker marker, double x, double y, double radius, const Rgb& colour) {
    switch (marker) {
      case silpose::Marker::kNone:
        break;
      case silpose::Marker::kCircle:
        out_ << "<circle cx=\"" << Number(x) << "\" cy=\"" << Number(y) << "\" r=\""
             << Number(radius) << "\" fill=\"" << ToHex(colour) << "\"/>\n";
        break;
      case silpose::Marker::kCross:
        Line(x - radius, y - radius, x + radius, y + radius, colour, 1.5);
        Line(x - radius, y + radius, x + radius, y - radius, colour, 1.5);
        break;
      case silpose::Marker::kSquare:
        out_ << "<rect x=\"" << Number(x - radius) << "\" y=\"" << Number(y - radius)
             << "\" width=\"" << Number(2 * radius) << "\" height=\"" << Number(2 * radius)
             << "\" fill=\"" << ToHex(colour) << "\"/>\n";
        break;
    }
  }
  std::ostringstream& raw() { return out_; }

 private:
  std::ostringstream& out_;
};

// ---- PNG (OpenCV) ----

constexpr int kShiftBits = 4;
constexpr double kShiftScale = 1 << kShiftBits;

cv::Scalar Bgr(const Rgb& c) { return cv::Scalar(c.b, c.g, c.r); }

cv::Point Fixed(double x, double y) {
  return {static_cast<int>(std::lround(x * kShiftScale)),
          static_cast<int>(std::lround(y * kShiftScale))};
}

int Thickness(double width) { return std::max(1, static_cast<int>(std::lround(width))); }

void DrawLine(cv::Mat& image, double x1, double y1, double x2, double y2, const Rgb& colour,
              double width, bool dashed = false) {
  if (!dashed) {
    cv::line(image, Fixed(x1, y1), Fixed(x2, y2), Bgr(colour), Thickness(width), cv::LINE_AA,
             kShiftBits);
    return;
  }
  const double length = std::hypot(x2 - x1, y2 - y1);
  const double dash = 6.0, gap = 4.0;
  for (double s = 0.0; s < length; s += dash + gap) {
    const double e = std::min(length, s + dash);
    cv::line(image, Fixed(x1 + (x2 - x1) * s / length, y1 + (y2 - y1) * s / length),
             Fixed(x1 + (x2 - x1) * e / length, y1 + (y2 - y1) * e / length), Bgr(colour),
             Thickness(width), cv::LINE_AA, kShiftBits);
  }
}

void DrawMarker(cv::Mat& image, Marker marker, double x, double y, double radius,
                const Rgb& colour) {
  switch (marker) {
    case Marker::kNone:
      break;
    case Marker::kCircle:
      cv::circle(image, Fixed(x, y), static_cast<int>(std::lround(radius * kShiftScale)),
                 Bgr(colour), cv::FILLED, cv::LINE_AA, kShiftBits);
      break;
    case Marker::kCross:
      DrawLine(image, x - radius, y - radius, x + radius, y + radius, colour, 1.5);
      DrawLine(image, x - radius, y + radius, x + radius, y - radius, colour, 1.5);
      break;
    case Marker::kSquare: {
      const std::array<cv::Point, 4> corners = {
          Fixed(x - radius, y - radius), Fixed(x + radius, y - radius),
          Fixed(x + radius, y + radius), Fixed(x - radius, y + radius)};
      cv::fillConvexPoly(image, corners.data(), 4, Bgr(colour), cv::LINE_AA, kShiftBits);
      break;
    }
  }
}

// Hershey simplex: cap height is about 0.72 of the font size, and 21.6 px at scale 1.
double HersheyScale(double font_px) { return 0.72 * font_px / 21.6; }

enum class Anchor { kStart, kMiddle, kEnd };

// Draws `text` with its baseline at y and its anchor at x, as SVG would.
void DrawText(cv::Mat& image, double x, double y, const std::string& utf8, double font_px,
              Anchor anchor, const Rgb& colour, bool bold = false) {
  const std::string text = AsciiForHershey(utf8);
  const double scale = HersheyScale(font_px);
  // Duplex (double strokes) reads as bold; a thicker simplex smudges at small sizes.
  const int font = bold ? cv::FONT_HERSHEY_DUPLEX : cv::FONT_HERSHEY_SIMPLEX;
  const int thickness = 1;
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, font, scale, thickness, &baseline);
  double left = x;
  if (anchor == Anchor::kMiddle) left -= size.width / 2.0;
  if (anchor == Anchor::kEnd) left -= size.width;
  cv::putText(image, text, cv::Point(static_cast<int>(std::lround(left)), static_cast<int>(y)),
              font, scale, Bgr(colour), thickness, cv::LINE_AA);
}

// Text turned 90 degrees counter-clockwise, centred on (x, y) along its length, baseline to the
// right of x (the y axis label).
void DrawVerticalText(cv::Mat& image, double x, double y, const std::string& utf8, double font_px,
                      const Rgb& colour) {
  const std::string text = AsciiForHershey(utf8);
  const double scale = HersheyScale(font_px);
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline);
  cv::Mat strip(size.height + baseline + 2, size.width + 2, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(strip, text, cv::Point(1, size.height + 1), cv::FONT_HERSHEY_SIMPLEX, scale,
              Bgr(colour), 1, cv::LINE_AA);
  cv::Mat turned;
  cv::rotate(strip, turned, cv::ROTATE_90_COUNTERCLOCKWISE);
  // The strip's baseline row becomes a column; put it at x.
  const int left = static_cast<int>(std::lround(x)) - (size.height + 1);
  const int top = static_cast<int>(std::lround(y - turned.rows / 2.0));
  const cv::Rect target =
      cv::Rect(left, top, turned.cols, turned.rows) & cv::Rect(0, 0, image.cols, image.rows);
  if (target.area() <= 0) return;
  const cv::Rect source(target.x - left, target.y - top, target.width, target.height);
  cv::Mat destination = image(target);
  cv::min(destination, turned(source), destination);
}

}  // namespace

Rgb PaletteColour(int index) {
  // A colour-blind-aware qualitative palette (the common ten-colour "category" set).
  static constexpr std::array<Rgb, 10> kPalette = {{{31, 119, 180},
                                                    {214, 39, 40},
                                                    {44, 160, 44},
                                                    {255, 127, 14},
                                                    {148, 103, 189},
                                                    {140, 86, 75},
                                                    {227, 119, 194},
                                                    {127, 127, 127},
                                                    {188, 189, 34},
                                                    {23, 190, 207}}};
  SILPOSE_ASSERT(index >= 0);
  return kPalette[static_cast<size_t>(index) % kPalette.size()];
}

std::string ToHex(const Rgb& colour) {
  char buffer[8];
  std::snprintf(buffer, sizeof buffer, "#%02x%02x%02x", colour.r, colour.g, colour.b);
  return buffer;
}

std::string EscapeXml(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string FormatTick(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", std::max(0, decimals), value);
  std::string text = buffer;
  // "-0", "-0.00": no negative zero.
  if (text.front() == '-' && text.find_first_not_of("-0.") == std::string::npos) text.erase(0, 1);
  return text;
}

AxisLayout NiceAxis(double min, double max, int target, bool extend) {
  SILPOSE_ASSERT(std::isfinite(min) && std::isfinite(max) && min < max && target >= 2);
  const double raw = (max - min) / (target - 1);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10.0 * power;
  for (double factor : {1.0, 2.0, 5.0}) {
    // Take the smallest nice step not below 0.75 of the raw one (about target ticks).
    if (factor * power >= 0.75 * raw) {
      step = factor * power;
      break;
    }
  }
  AxisLayout axis;
  // A small tolerance, so that ends that sit on a tick (up to rounding) keep it.
  const double tolerance = 1e-9 * step;
  double lo, hi;
  if (extend) {
    lo = std::floor((min + tolerance) / step);
    hi = std::ceil((max - tolerance) / step);
    axis.min = lo * step;
    axis.max = hi * step;
  } else {
    lo = std::ceil((min - tolerance) / step);
    hi = std::floor((max + tolerance) / step);
    axis.min = min;
    axis.max = max;
  }
  for (double k = lo; k <= hi + 0.5; k += 1.0) axis.ticks.push_back(k * step);
  axis.decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
  return axis;
}

double PanelLayout::XToPixel(double value) const {
  return left_px + (value - x.min) / (x.max - x.min) * width_px;
}

double PanelLayout::YToPixel(double value) const {
  return top_px + height_px - (value - y.min) / (y.max - y.min) * height_px;
}

bool Figure::Check(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (panels.empty()) return fail("a figure needs at least one panel");
  if (!(font_px >= 6.0 && font_px <= 48.0)) return fail("font size must be in [6, 48] px");
  const int n = static_cast<int>(panels.size());
  if (width_px < kMinPanelWidthPx * n || height_px < kMinPanelHeightPx) {
    return fail("figure of " + std::to_string(width_px) + " x " + std::to_string(height_px) +
                " px is too small for " + std::to_string(n) + " panel(s) (at least " +
                std::to_string(kMinPanelWidthPx) + " x " + std::to_string(kMinPanelHeightPx) +
                " px each)");
  }
  for (size_t p = 0; p < panels.size(); ++p) {
    const PlotPanel& panel = panels[p];
    const std::string where = "panel " + std::to_string(p) + " ('" + panel.title + "')";
    for (const PlotAxis* axis : {&panel.x_axis, &panel.y_axis}) {
      const char* name = axis == &panel.x_axis ? "x" : "y";
      if ((axis->min && !std::isfinite(*axis->min)) || (axis->max && !std::isfinite(*axis->max))) {
        return fail(where + ": " + name + " range is not finite");
      }
      if (axis->min && axis->max && !(*axis->min < *axis->max)) {
        return fail(where + ": " + name + " range is empty or inverted");
      }
      if (axis->target_ticks < 2) return fail(where + ": " + name + " axis needs >= 2 ticks");
    }
    for (const PlotSeries& s : panel.series) {
      const std::string series = where + ", series '" + s.label + "'";
      if (s.x.size() != s.y.size()) return fail(series + ": x and y differ in length");
      if (!s.y_error.empty() && s.y_error.size() != s.y.size()) {
        return fail(series + ": error bars and y differ in length");
      }
      for (size_t i = 0; i < s.x.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
          return fail(series + ": point " + std::to_string(i) + " is not finite");
        }
        if (!s.y_error.empty() && !(std::isfinite(s.y_error[i]) && s.y_error[i] >= 0.0)) {
          return fail(series + ": error bar " + std::to_string(i) + " is not finite and >= 0");
        }
      }
      if (!(s.line_width_px > 0.0 && s.marker_radius_px > 0.0)) {
        return fail(series + ": line width and marker radius must be > 0");
      }
    }
    for (const ReferenceLine& r : panel.reference_lines) {
      if (!std::isfinite(r.y))
        return fail(where + ", reference line '" + r.label + "': not finite");
      if (!(r.line_width_px > 0.0)) {
        return fail(where + ", reference line '" + r.label + "': line width must be > 0");
      }
    }
  }
  return true;
}

std::vector<PanelLayout> Figure::Layout() const {
  std::string error;
  if (!Check(&error)) ThrowError("invalid figure: ", error);
  std::vector<PanelLayout> layouts;
  const double label_px = kLabelScale * font_px;
  const double panel_width = static_cast<double>(width_px) / static_cast<double>(panels.size());
  for (size_t p = 0; p < panels.size(); ++p) {
    const PlotPanel& panel = panels[p];
    DataRange x_data, y_data;
    for (const PlotSeries& s : panel.series) {
      for (size_t i = 0; i < s.x.size(); ++i) {
        x_data.Add(s.x[i]);
        const double e = s.y_error.empty() ? 0.0 : s.y_error[i];
        y_data.Add(s.y[i] - e);
        y_data.Add(s.y[i] + e);
      }
    }
    for (const ReferenceLine& r : panel.reference_lines) y_data.Add(r.y);
    double x_min, x_max, y_min, y_max;
    RangeOf(panel.x_axis, x_data, &x_min, &x_max);
    RangeOf(panel.y_axis, y_data, &y_min, &y_max);

    PanelLayout layout;
    layout.panel_left_px = panel_width * static_cast<double>(p);
    layout.panel_width_px = panel_width;
    layout.x = AxisFor(panel.x_axis, x_min, x_max);
    layout.y = AxisFor(panel.y_axis, y_min, y_max);

    double tick_label_width = 0.0;
    for (double t : layout.y.ticks) {
      tick_label_width =
          std::max(tick_label_width, TextWidth(FormatTick(t, layout.y.decimals), font_px));
    }
    const double top = kPadPx + (panel.title.empty() ? 0.0 : 1.8 * label_px);
    const double bottom =
        kPadPx + font_px + kPadPx + (panel.x_axis.label.empty() ? 0.0 : 1.6 * label_px);
    const double left =
        kPadPx + (panel.y_axis.label.empty() ? 0.0 : 1.6 * label_px) + tick_label_width + kPadPx;
    const double right =
        2.0 * kPadPx +
        0.5 * TextWidth(FormatTick(layout.x.ticks.empty() ? 0.0 : layout.x.ticks.back(),
                                   layout.x.decimals),
                        font_px);
    layout.left_px = layout.panel_left_px + left;
    layout.top_px = top;
    layout.width_px = std::max(1.0, panel_width - left - right);
    layout.height_px = std::max(1.0, static_cast<double>(height_px) - top - bottom);

    if (panel.equal_aspect) {
      // Widen the automatic axis whose scale is finer, about its centre, to the coarser scale.
      const double x_per_px = (layout.x.max - layout.x.min) / layout.width_px;
      const double y_per_px = (layout.y.max - layout.y.min) / layout.height_px;
      const bool widen_x = x_per_px < y_per_px;
      const PlotAxis& axis = widen_x ? panel.x_axis : panel.y_axis;
      AxisLayout& target = widen_x ? layout.x : layout.y;
      if (!axis.min && !axis.max) {
        const double centre = 0.5 * (target.min + target.max);
        const double half =
            0.5 * std::max(x_per_px, y_per_px) * (widen_x ? layout.width_px : layout.height_px);
        target = NiceAxis(centre - half, centre + half, axis.target_ticks, false);
      }
    }
    layouts.push_back(layout);
  }
  return layouts;
}

std::string Figure::ToSvg() const {
  const std::vector<PanelLayout> layouts = Layout();
  const double label_px = kLabelScale * font_px;
  std::ostringstream out;
  SvgWriter svg(&out);
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width_px << "\" height=\""
      << height_px << "\" viewBox=\"0 0 " << width_px << " " << height_px
      << "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n"
      << "<rect x=\"0\" y=\"0\" width=\"" << width_px << "\" height=\"" << height_px
      << "\" fill=\"#ffffff\"/>\n";
  for (size_t p = 0; p < panels.size(); ++p) {
    const PlotPanel& panel = panels[p];
    const PanelLayout& L = layouts[p];
    const PanelColours colours = ColoursOf(panel);
    const double right = L.left_px + L.width_px;
    const double bottom = L.top_px + L.height_px;
    const std::string clip = "plot-area-" + std::to_string(p);
    out << "<g class=\"panel\">\n<defs><clipPath id=\"" << clip << "\"><rect x=\""
        << Number(L.left_px) << "\" y=\"" << Number(L.top_px) << "\" width=\"" << Number(L.width_px)
        << "\" height=\"" << Number(L.height_px) << "\"/></clipPath></defs>\n";
    // Grid, ticks and tick labels.
    for (double t : L.x.ticks) {
      const double px = L.XToPixel(t);
      if (panel.x_axis.grid) svg.Line(px, L.top_px, px, bottom, kGridColour, 1.0);
      svg.Line(px, bottom, px, bottom + 4.0, kAxisColour, 1.0);
      svg.Text(px, bottom + kPadPx + font_px, FormatTick(t, L.x.decimals), font_px, "middle");
    }
    for (double t : L.y.ticks) {
      const double py = L.YToPixel(t);
      if (panel.y_axis.grid) svg.Line(L.left_px, py, right, py, kGridColour, 1.0);
      svg.Line(L.left_px - 4.0, py, L.left_px, py, kAxisColour, 1.0);
      svg.Text(L.left_px - kPadPx, py + 0.35 * font_px, FormatTick(t, L.y.decimals), font_px,
               "end");
    }
    out << "<rect x=\"" << Number(L.left_px) << "\" y=\"" << Number(L.top_px) << "\" width=\""
        << Number(L.width_px) << "\" height=\"" << Number(L.height_px)
        << "\" fill=\"none\" stroke=\"#000000\" stroke-width=\"1\"/>\n";
    // Titles and axis labels.
    const double centre_x = L.left_px + 0.5 * L.width_px;
    if (!panel.title.empty()) {
      svg.Text(centre_x, kPadPx + 1.2 * label_px, panel.title, label_px, "middle", true);
    }
    if (!panel.x_axis.label.empty()) {
      svg.Text(centre_x, bottom + kPadPx + font_px + kPadPx + 1.2 * label_px, panel.x_axis.label,
               label_px, "middle");
    }
    if (!panel.y_axis.label.empty()) {
      const double x = L.panel_left_px + kPadPx + 1.1 * label_px;
      svg.Text(x, L.top_px + 0.5 * L.height_px, panel.y_axis.label, label_px, "middle", false,
               -90.0);
    }
    // Data, clipped to the plot area.
    out << "<g clip-path=\"url(#" << clip << ")\">\n";
    for (size_t r = 0; r < panel.reference_lines.size(); ++r) {
      const ReferenceLine& line = panel.reference_lines[r];
      const double py = L.YToPixel(line.y);
      svg.Line(L.left_px, py, right, py, colours.references[r], line.line_width_px, true);
    }
    for (size_t s = 0; s < panel.series.size(); ++s) {
      const PlotSeries& series = panel.series[s];
      const Rgb& colour = colours.series[s];
      out << "<g class=\"series\">\n";
      if (!series.y_error.empty()) {
        const double cap = std::max(3.0, series.marker_radius_px + 1.0);
        for (size_t i = 0; i < series.x.size(); ++i) {
          const double px = L.XToPixel(series.x[i]);
          const double lo = L.YToPixel(series.y[i] - series.y_error[i]);
          const double hi = L.YToPixel(series.y[i] + series.y_error[i]);
          svg.Line(px, lo, px, hi, colour, 1.0);
          svg.Line(px - cap, lo, px + cap, lo, colour, 1.0);
          svg.Line(px - cap, hi, px + cap, hi, colour, 1.0);
        }
      }
      if (series.line && series.x.size() >= 2) {
        out << "<polyline fill=\"none\" stroke=\"" << ToHex(colour) << "\" stroke-width=\""
            << Number(series.line_width_px) << "\" stroke-linejoin=\"round\" points=\"";
        for (size_t i = 0; i < series.x.size(); ++i) {
          out << (i ? " " : "") << Number(L.XToPixel(series.x[i])) << ","
              << Number(L.YToPixel(series.y[i]));
        }
        out << "\"/>\n";
      }
      for (size_t i = 0; i < series.x.size(); ++i) {
        svg.Marker(series.marker, L.XToPixel(series.x[i]), L.YToPixel(series.y[i]),
                   series.marker_radius_px, colour);
      }
      out << "</g>\n";
    }
    out << "</g>\n";
    // Legend.
    const std::vector<LegendEntry> entries = LegendOf(panel, colours);
    if (!entries.empty()) {
      const LegendBox box = PlaceLegend(panel, L, entries, font_px);
      out << "<rect x=\"" << Number(box.left) << "\" y=\"" << Number(box.top) << "\" width=\""
          << Number(box.width) << "\" height=\"" << Number(box.height)
          << "\" fill=\"#ffffff\" fill-opacity=\"0.9\" stroke=\"" << ToHex(kLegendBorder)
          << "\" stroke-width=\"1\"/>\n";
      for (size_t e = 0; e < entries.size(); ++e) {
        const LegendEntry& entry = entries[e];
        const double y = box.top + kPadPx + (static_cast<double>(e) + 0.5) * box.row_height;
        const double x0 = box.left + kPadPx;
        if (entry.line) {
          svg.Line(x0, y, x0 + kLegendSampleWidthPx, y, entry.colour, 1.5, entry.dashed);
        }
        svg.Marker(entry.marker, x0 + 0.5 * kLegendSampleWidthPx, y, 3.0, entry.colour);
        svg.Text(x0 + kLegendSampleWidthPx + kPadPx, y + 0.35 * font_px, entry.label, font_px,
                 "start");
      }
    }
    out << "</g>\n";
  }
  out << "</svg>\n";
  return out.str();
}

void Figure::WriteSvg(const std::filesystem::path& path) const {
  const std::string text = ToSvg();
  std::ofstream file(path, std::ios::binary);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file << text;
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

cv::Mat Figure::ToImage() const {
  const std::vector<PanelLayout> layouts = Layout();
  const double label_px = kLabelScale * font_px;
  cv::Mat image(height_px, width_px, CV_8UC3, cv::Scalar(255, 255, 255));
  for (size_t p = 0; p < panels.size(); ++p) {
    const PlotPanel& panel = panels[p];
    const PanelLayout& L = layouts[p];
    const PanelColours colours = ColoursOf(panel);
    const double right = L.left_px + L.width_px;
    const double bottom = L.top_px + L.height_px;
    for (double t : L.x.ticks) {
      const double px = L.XToPixel(t);
      if (panel.x_axis.grid) DrawLine(image, px, L.top_px, px, bottom, kGridColour, 1.0);
      DrawLine(image, px, bottom, px, bottom + 4.0, kAxisColour, 1.0);
      DrawText(image, px, bottom + kPadPx + font_px, FormatTick(t, L.x.decimals), font_px,
               Anchor::kMiddle, kTextColour);
    }
    for (double t : L.y.ticks) {
      const double py = L.YToPixel(t);
      if (panel.y_axis.grid) DrawLine(image, L.left_px, py, right, py, kGridColour, 1.0);
      DrawLine(image, L.left_px - 4.0, py, L.left_px, py, kAxisColour, 1.0);
      DrawText(image, L.left_px - kPadPx, py + 0.35 * font_px, FormatTick(t, L.y.decimals), font_px,
               Anchor::kEnd, kTextColour);
    }
    const double centre_x = L.left_px + 0.5 * L.width_px;
    if (!panel.title.empty()) {
      DrawText(image, centre_x, kPadPx + 1.2 * label_px, panel.title, label_px, Anchor::kMiddle,
               kTextColour, true);
    }
    if (!panel.x_axis.label.empty()) {
      DrawText(image, centre_x, bottom + kPadPx + font_px + kPadPx + 1.2 * label_px,
               panel.x_axis.label, label_px, Anchor::kMiddle, kTextColour);
    }
    if (!panel.y_axis.label.empty()) {
      DrawVerticalText(image, L.panel_left_px + kPadPx + 1.1 * label_px,
                       L.top_px + 0.5 * L.height_px, panel.y_axis.label, label_px, kTextColour);
    }
    // Data, clipped to the plot area: drawn into a view of it, in coordinates relative to it.
    const cv::Rect area_rect =
        cv::Rect(static_cast<int>(std::floor(L.left_px)), static_cast<int>(std::floor(L.top_px)),
                 static_cast<int>(std::ceil(L.width_px)) + 1,
                 static_cast<int>(std::ceil(L.height_px)) + 1) &
        cv::Rect(0, 0, image.cols, image.rows);
    cv::Mat area = image(area_rect);
    const double ox = area_rect.x, oy = area_rect.y;
    for (size_t r = 0; r < panel.reference_lines.size(); ++r) {
      const ReferenceLine& line = panel.reference_lines[r];
      const double py = L.YToPixel(line.y) - oy;
      DrawLine(area, L.left_px - ox, py, right - ox, py, colours.references[r], line.line_width_px,
               true);
    }
    for (size_t s = 0; s < panel.series.size(); ++s) {
      const PlotSeries& series = panel.series[s];
      const Rgb& colour = colours.series[s];
      if (!series.y_error.empty()) {
        const double cap = std::max(3.0, series.marker_radius_px + 1.0);
        for (size_t i = 0; i < series.x.size(); ++i) {
          const double px = L.XToPixel(series.x[i]) - ox;
          const double lo = L.YToPixel(series.y[i] - series.y_error[i]) - oy;
          const double hi = L.YToPixel(series.y[i] + series.y_error[i]) - oy;
          DrawLine(area, px, lo, px, hi, colour, 1.0);
          DrawLine(area, px - cap, lo, px + cap, lo, colour, 1.0);
          DrawLine(area, px - cap, hi, px + cap, hi, colour, 1.0);
        }
      }
      if (series.line) {
        for (size_t i = 1; i < series.x.size(); ++i) {
          DrawLine(area, L.XToPixel(series.x[i - 1]) - ox, L.YToPixel(series.y[i - 1]) - oy,
                   L.XToPixel(series.x[i]) - ox, L.YToPixel(series.y[i]) - oy, colour,
                   series.line_width_px);
        }
      }
      for (size_t i = 0; i < series.x.size(); ++i) {
        DrawMarker(area, series.marker, L.XToPixel(series.x[i]) - ox, L.YToPixel(series.y[i]) - oy,
                   series.marker_radius_px, colour);
      }
    }
    // The frame last, over the data's edges.
    cv::rectangle(image, Fixed(L.left_px, L.top_px), Fixed(right, bottom), Bgr(kAxisColour), 1,
                  cv::LINE_AA, kShiftBits);
    const std::vector<LegendEntry> entries = LegendOf(panel, colours);
    if (!entries.empty()) {
      const LegendBox box = PlaceLegend(panel, L, entries, font_px);
      cv::rectangle(image, Fixed(box.left, box.top),
                    Fixed(box.left + box.width, box.top + box.height), cv::Scalar(255, 255, 255),
                    cv::FILLED, cv::LINE_AA, kShiftBits);
      cv::rectangle(image, Fixed(box.left, box.top),
                    Fixed(box.left + box.width, box.top + box.height), Bgr(kLegendBorder), 1,
                    cv::LINE_AA, kShiftBits);
      for (size_t e = 0; e < entries.size(); ++e) {
        const LegendEntry& entry = entries[e];
        const double y = box.top + kPadPx + (static_cast<double>(e) + 0.5) * box.row_height;
        const double x0 = box.left + kPadPx;
        if (entry.line) {
          DrawLine(image, x0, y, x0 + kLegendSampleWidthPx, y, entry.colour, 1.5, entry.dashed);
        }
        DrawMarker(image, entry.marker, x0 + 0.5 * kLegendSampleWidthPx, y, 3.0, entry.colour);
        DrawText(image, x0 + kLegendSampleWidthPx + kPadPx, y + 0.35 * font_px, entry.label,
                 font_px, Anchor::kStart, kTextColour);
      }
    }
  }
  return image;
}

void Figure::WritePng(const std::filesystem::path& path) const {
  const cv::Mat image = ToImage();
  std::vector<uchar> bytes;
  if (!EncodeImage(".png", image, &bytes, {cv::IMWRITE_PNG_COMPRESSION, 6})) {
    ThrowError(path.string(), ": cannot encode the figure as PNG");
  }
  std::ofstream file(path, std::ios::binary);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

}  // namespace silpose
