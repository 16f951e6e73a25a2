#pragma once
// Plots for the evaluation's figures: a small, dependency-free writer of line and scatter plots,
// as SVG (the figure as text: vector, diffable, embeddable in Markdown) and as PNG (the same
// layout drawn with OpenCV, for places that cannot show SVG).
//
// A Figure holds one or more panels side by side, each with equal width. A panel has a title, x and
// y axes (label, automatic or fixed range, "nice" ticks at 1, 2 or 5 times a power of ten, grid
// lines), data series (a line, markers or both, optionally with symmetric error bars y +- e),
// horizontal reference lines (a baseline level, dashed) and a legend.
//
// Coordinates. Pixels, origin at the top-left corner of the figure, x to the right, y down; a data
// point (x, y) of a panel is drawn at PanelLayout::XToPixel(x), YToPixel(y): linear maps of the
// panel's axis range onto its plot area, y growing upwards. Data outside a fixed range is clipped
// at the plot area.
//
// Colours come from a fixed palette (PaletteColour): series without an explicit colour take the
// palette's colours in order within their panel, reference lines continue after the series.
//
// Errors: drawing a figure (ToSvg, WriteSvg, ToImage, WritePng, Layout) checks it first and throws
// silpose::Error for non-finite data, x / y / error vectors of different lengths, negative error
// bars, an empty or inverted fixed range, or a size too small for the panels; writing throws
// silpose::Error naming the file if it cannot be written.

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace silpose {

/// An 8-bit sRGB colour.
struct Rgb {
  uint8_t r = 0;
  uint8_t g = 0;
  uint8_t b = 0;
  bool operator==(const Rgb& other) const = default;
};

/// Colour `index` of the fixed palette (10 colours, repeating: blue, red, green, orange, purple,
/// brown, pink, grey, olive, cyan). Any index >= 0.
Rgb PaletteColour(int index);
/// "#rrggbb".
std::string ToHex(const Rgb& colour);

enum class Marker : uint8_t { kNone = 0, kCircle, kCross, kSquare };

/// One data series of a panel.
struct PlotSeries {
  /// Legend entry; empty: not in the legend.
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
  /// Symmetric error bars: y[i] +- y_error[i] (>= 0). Empty: none; otherwise as long as y.
  std::vector<double> y_error;
  /// Connect the points in order.
  bool line = true;
  Marker marker = Marker::kCircle;
  /// Empty: the panel's next palette colour.
  std::optional<Rgb> colour;
  /// Line width and marker radius, pixels.
  double line_width_px = 1.5;
  double marker_radius_px = 3.0;
};

/// A horizontal line across the plot area at y = `y` (e.g. a baseline's level), dashed.
struct ReferenceLine {
  double y = 0.0;
  /// Legend entry; empty: not in the legend.
  std::string label;
  std::optional<Rgb> colour;
  double line_width_px = 1.5;
};

struct PlotAxis {
  std::string label;
  /// Fixed ends of the range; unset: automatic. An automatic range covers the data (with error
  /// bars) and, for y, the reference lines, widened by 2 % of its span on each side (so that no
  /// point sits on the frame) and extended outwards to the enclosing ticks; a single
  /// value v is first widened to v +- |v| / 10 (+- 1 for 0); no data at all gives [0, 1]. Fixed
  /// ends are kept exactly (min < max when both are set).
  std::optional<double> min;
  std::optional<double> max;
  /// Grid lines at the ticks.
  bool grid = true;
  /// About this many ticks (the nice step chosen gives between about half and twice as many).
  int target_ticks = 6;
};

enum class LegendPosition : uint8_t {
  kNone = 0,
  /// The corner (top right, top left, bottom right, bottom left, in this order of preference)
  /// where the legend covers the fewest data: points, line samples, error bars, reference lines.
  kBest,
  kTopRight,
  kTopLeft,
  kBottomRight,
  kBottomLeft,
};

struct PlotPanel {
  std::string title;
  PlotAxis x_axis;
  PlotAxis y_axis;
  std::vector<PlotSeries> series;
  std::vector<ReferenceLine> reference_lines;
  /// Where the legend box sits inside the plot area (it lists labelled series, then labelled
  /// reference lines).
  LegendPosition legend = LegendPosition::kBest;
  /// One data unit is as many pixels along x as along y (for trajectories on the view sphere): the
  /// automatic ranges are widened about their centres until both scales agree.
  bool equal_aspect = false;
};

/// One axis as drawn: its range and its ticks (within the range, ascending).
struct AxisLayout {
  double min = 0.0;
  double max = 1.0;
  std::vector<double> ticks;
  /// Decimals used for the tick labels.
  int decimals = 0;
};

/// Where one panel is drawn: its plot area (the rectangle inside the axes) in figure pixels, and
/// its axes. Maps data to pixels (see the file comment).
struct PanelLayout {
  /// The panel's whole rectangle (title, axes labels and plot area).
  double panel_left_px = 0.0;
  double panel_width_px = 0.0;
  /// The plot area.
  double left_px = 0.0;
  double top_px = 0.0;
  double width_px = 0.0;
  double height_px = 0.0;
  AxisLayout x;
  AxisLayout y;

  double XToPixel(double value) const;
  double YToPixel(double value) const;
};

/// Nice ticks for a range: the step is 1, 2 or 5 times a power of ten giving about `target` ticks.
/// `extend`: the range grows outwards to the enclosing multiples of the step (automatic ranges);
/// otherwise the range is kept and the ticks are the step's multiples inside it. Requires
/// finite min < max and target >= 2.
AxisLayout NiceAxis(double min, double max, int target, bool extend);

/// Formats a number with `decimals` decimals, without a negative zero ("-0.0" -> "0.0").
std::string FormatTick(double value, int decimals);

/// Escapes &, <, >, " and ' for XML text and attribute values.
std::string EscapeXml(const std::string& text);

class Figure {
 public:
  static constexpr int kMinPanelWidthPx = 160;
  static constexpr int kMinPanelHeightPx = 120;

  /// Size of the whole figure, pixels: at least kMinPanelWidthPx per panel wide and
  /// kMinPanelHeightPx high.
  int width_px = 960;
  int height_px = 400;
  /// Font size of tick labels and legend, pixels, in [6, 48]; titles and axis labels are 1.2 times
  /// larger.
  double font_px = 12.0;
  std::vector<PlotPanel> panels;

  /// Checks the figure (see the file comment); on failure writes the reason to `error`.
  bool Check(std::string* error = nullptr) const;
  /// Where each panel is drawn. Throws silpose::Error if Check fails.
  std::vector<PanelLayout> Layout() const;

  /// The figure as a standalone SVG document. Throws silpose::Error if Check fails.
  std::string ToSvg() const;
  /// Writes ToSvg() to `path`. Throws silpose::Error naming the file if it cannot be written.
  void WriteSvg(const std::filesystem::path& path) const;

  /// The figure drawn with OpenCV (anti-aliased lines, Hershey fonts): CV_8UC3 (BGR), height_px x
  /// width_px, same layout as the SVG. Hershey fonts are ASCII only: the PNG writes "+-" for
  /// U+00B1 and " deg" for U+00B0, "?" for other non-ASCII characters. Throws silpose::Error if
  /// Check fails.
  cv::Mat ToImage() const;
  /// Writes ToImage() as PNG. Throws silpose::Error naming the file if it cannot be written.
  void WritePng(const std::filesystem::path& path) const;
};

}  // namespace silpose
