#include "silpose/plot/figure.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

// Checks that every tag of an XML document is closed in order, that every '&' starts one of the
// five predefined entities and that no '<' or '>' stands in text. Returns "" or the first problem.
std::string XmlProblem(const std::string& xml) {
  std::vector<std::string> open;
  size_t i = 0;
  int roots = 0;
  while (i < xml.size()) {
    const char c = xml[i];
    if (c == '>') return "stray '>' at " + std::to_string(i);
    if (c == '&') {
      bool entity = false;
      for (const char* e : {"&amp;", "&lt;", "&gt;", "&quot;", "&apos;"}) {
        entity = entity || xml.compare(i, std::string(e).size(), e) == 0;
      }
      if (!entity) return "bare '&' at " + std::to_string(i);
      ++i;
      continue;
    }
    if (c != '<') {
      ++i;
      continue;
    }
    const size_t end = xml.find('>', i);
    if (end == std::string::npos) return "unterminated tag at " + std::to_string(i);
    const std::string tag = xml.substr(i + 1, end - i - 1);
    // Attribute values must not contain '<' (escaped) and quotes must pair.
    if (tag.find('<') != std::string::npos) return "'<' inside tag at " + std::to_string(i);
    size_t quotes = 0;
    for (char t : tag) quotes += t == '"';
    if (quotes % 2 != 0) return "unpaired quote in tag at " + std::to_string(i);
    i = end + 1;
    if (tag.front() == '?') continue;  // declaration
    if (tag.front() == '/') {
      const std::string name = tag.substr(1);
      if (open.empty() || open.back() != name) return "closing </" + name + "> does not match";
      open.pop_back();
      continue;
    }
    const std::string name = tag.substr(0, tag.find_first_of(" \n/"));
    if (tag.back() == '/') {
      if (open.empty()) ++roots;
      continue;
    }
    if (open.empty()) ++roots;
    open.push_back(name);
  }
  if (!open.empty()) return "unclosed <" + open.back() + ">";
  if (roots != 1) return "expected one root element, found " + std::to_string(roots);
  return "";
}

std::string Coordinate(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f", value);
  return buffer;
}

// Two panels like the paper's Fig. 4: mean +- std against a count, with a reference level.
Figure TwoPanels() {
  Figure figure;
  figure.width_px = 900;
  figure.height_px = 360;
  PlotPanel error;
  error.title = "Pose error";
  error.x_axis.label = "particles per object";
  error.y_axis.label = "pose error";
  PlotSeries filter;
  filter.label = "particle filter";
  filter.x = {10, 20, 30, 40};
  filter.y = {0.30, 0.12, 0.08, 0.07};
  filter.y_error = {0.4, 0.2, 0.1, 0.05};
  filter.marker = Marker::kCross;
  error.series.push_back(filter);
  error.reference_lines.push_back({.y = 0.149, .label = "brute force"});
  PlotPanel right;
  right.title = "Right object";
  right.x_axis.label = "particles per object";
  right.y_axis.label = "% frames";
  PlotSeries percent;
  percent.label = "particle filter";
  percent.x = {10, 20, 30, 40};
  percent.y = {95.0, 99.0, 99.5, 100.0};
  right.series.push_back(percent);
  right.reference_lines.push_back({.y = 96.3, .label = "brute force"});
  right.legend = LegendPosition::kBottomRight;
  figure.panels = {error, right};
  return figure;
}

TEST(NiceAxis, ExtendsAutomaticRangesToTicksAtOneTwoFiveTimesAPowerOfTen) {
  const AxisLayout a = NiceAxis(0.0, 0.93, 6, true);
  EXPECT_DOUBLE_EQ(a.min, 0.0);
  EXPECT_DOUBLE_EQ(a.max, 1.0);
  ASSERT_EQ(a.ticks.size(), 6u);
  EXPECT_NEAR(a.ticks[1], 0.2, 1e-12);
  EXPECT_EQ(a.decimals, 1);

  const AxisLayout b = NiceAxis(3.0, 97.0, 6, true);
  EXPECT_DOUBLE_EQ(b.min, 0.0);
  EXPECT_DOUBLE_EQ(b.max, 100.0);
  EXPECT_EQ(b.ticks.size(), 6u);
  EXPECT_EQ(b.decimals, 0);

  const AxisLayout c = NiceAxis(-0.013, 0.021, 5, true);
  EXPECT_LE(c.min, -0.013);
  EXPECT_GE(c.max, 0.021);
  EXPECT_EQ(c.decimals, 2);
  for (double t : c.ticks) EXPECT_NEAR(std::remainder(t, 0.01), 0.0, 1e-12) << t;

  // A fixed range is kept; its ticks are the step's multiples inside it.
  const AxisLayout d = NiceAxis(0.05, 0.95, 6, false);
  EXPECT_DOUBLE_EQ(d.min, 0.05);
  EXPECT_DOUBLE_EQ(d.max, 0.95);
  ASSERT_EQ(d.ticks.size(), 4u);
  EXPECT_NEAR(d.ticks.front(), 0.2, 1e-12);
  EXPECT_NEAR(d.ticks.back(), 0.8, 1e-12);
}

TEST(FormatTick, HasNoNegativeZero) {
  EXPECT_EQ(FormatTick(-1e-17, 1), "0.0");
  EXPECT_EQ(FormatTick(-0.25, 2), "-0.25");
  EXPECT_EQ(FormatTick(40.0, 0), "40");
}

TEST(Figure, MapsDataLinearlyOntoThePlotAreaWithYUp) {
  Figure figure;
  figure.width_px = 800;
  figure.height_px = 400;
  PlotPanel panel;
  panel.x_axis.min = 0.0;
  panel.x_axis.max = 10.0;
  panel.y_axis.min = 0.0;
  panel.y_axis.max = 1.0;
  PlotSeries s;
  s.x = {0.0, 5.0, 10.0, 2.5};
  s.y = {0.0, 0.5, 1.0, 0.25};
  s.line = false;
  panel.series.push_back(s);
  figure.panels = {panel};

  const std::vector<PanelLayout> layouts = figure.Layout();
  ASSERT_EQ(layouts.size(), 1u);
  const PanelLayout& L = layouts[0];
  // The plot area lies inside the figure, with room for labels.
  EXPECT_GT(L.left_px, 0.0);
  EXPECT_GT(L.top_px, 0.0);
  EXPECT_LT(L.left_px + L.width_px, 800.0);
  EXPECT_LT(L.top_px + L.height_px, 400.0);
  EXPECT_GT(L.width_px, 600.0);
  EXPECT_GT(L.height_px, 300.0);
  // Corners and centre.
  EXPECT_DOUBLE_EQ(L.XToPixel(0.0), L.left_px);
  EXPECT_DOUBLE_EQ(L.XToPixel(10.0), L.left_px + L.width_px);
  EXPECT_DOUBLE_EQ(L.YToPixel(0.0), L.top_px + L.height_px);
  EXPECT_DOUBLE_EQ(L.YToPixel(1.0), L.top_px);
  EXPECT_DOUBLE_EQ(L.XToPixel(5.0), L.left_px + 0.5 * L.width_px);
  EXPECT_DOUBLE_EQ(L.YToPixel(0.25), L.top_px + 0.75 * L.height_px);

  // Every point is drawn as a circle at its mapped position.
  const std::string svg = figure.ToSvg();
  for (size_t i = 0; i < s.x.size(); ++i) {
    const std::string circle = "<circle cx=\"" + Coordinate(L.XToPixel(s.x[i])) + "\" cy=\"" +
                               Coordinate(L.YToPixel(s.y[i])) + "\"";
    EXPECT_NE(svg.find(circle), std::string::npos) << circle;
  }
  EXPECT_EQ(svg.find("<polyline"), std::string::npos);  // line off
}

TEST(Figure, PanelsSitSideBySideAndLinesPassThroughThePoints) {
  const Figure figure = TwoPanels();
  const std::vector<PanelLayout> layouts = figure.Layout();
  ASSERT_EQ(layouts.size(), 2u);
  EXPECT_DOUBLE_EQ(layouts[0].panel_left_px, 0.0);
  EXPECT_DOUBLE_EQ(layouts[1].panel_left_px, 450.0);
  EXPECT_LT(layouts[0].left_px + layouts[0].width_px, layouts[1].left_px);
  EXPECT_LE(layouts[1].left_px + layouts[1].width_px, 900.0);

  const std::string svg = figure.ToSvg();
  // The polyline of the right panel lists its mapped points in order.
  const PlotSeries& s = figure.panels[1].series[0];
  std::string points;
  for (size_t i = 0; i < s.x.size(); ++i) {
    points += (i ? " " : "") + Coordinate(layouts[1].XToPixel(s.x[i])) + "," +
              Coordinate(layouts[1].YToPixel(s.y[i]));
  }
  EXPECT_NE(svg.find("points=\"" + points + "\""), std::string::npos) << points;
  // The reference line spans the plot area at its level, dashed.
  const double y = layouts[0].YToPixel(0.149);
  const std::string reference =
      "<line x1=\"" + Coordinate(layouts[0].left_px) + "\" y1=\"" + Coordinate(y) + "\" x2=\"" +
      Coordinate(layouts[0].left_px + layouts[0].width_px) + "\" y2=\"" + Coordinate(y) + "\"";
  const size_t at = svg.find(reference);
  ASSERT_NE(at, std::string::npos) << reference;
  EXPECT_NE(svg.substr(at, 200).find("stroke-dasharray"), std::string::npos);
  // Error bars: a vertical line from y - e to y + e at each x.
  const PlotSeries& e = figure.panels[0].series[0];
  const std::string bar = "<line x1=\"" + Coordinate(layouts[0].XToPixel(e.x[1])) + "\" y1=\"" +
                          Coordinate(layouts[0].YToPixel(e.y[1] - e.y_error[1])) + "\" x2=\"" +
                          Coordinate(layouts[0].XToPixel(e.x[1])) + "\" y2=\"" +
                          Coordinate(layouts[0].YToPixel(e.y[1] + e.y_error[1])) + "\"";
  EXPECT_NE(svg.find(bar), std::string::npos) << bar;
  // Series and reference line in different palette colours; legends name both.
  EXPECT_NE(svg.find(ToHex(PaletteColour(0))), std::string::npos);
  EXPECT_NE(svg.find(ToHex(PaletteColour(1))), std::string::npos);
  EXPECT_NE(PaletteColour(0), PaletteColour(1));
  EXPECT_NE(svg.find(">brute force</text>"), std::string::npos);
  EXPECT_NE(svg.find(">particle filter</text>"), std::string::npos);
}

TEST(Figure, AutomaticRangesCoverDataErrorBarsAndReferenceLines) {
  const Figure figure = TwoPanels();
  const std::vector<PanelLayout> layouts = figure.Layout();
  // Left: y from 0.30 - 0.4 = -0.1 to 0.30 + 0.4 = 0.7.
  EXPECT_LE(layouts[0].y.min, -0.1);
  EXPECT_GE(layouts[0].y.max, 0.7);
  EXPECT_LE(layouts[0].x.min, 10.0);
  EXPECT_GE(layouts[0].x.max, 40.0);
  // Right: y from 95 to 100, reference inside.
  EXPECT_LE(layouts[1].y.min, 95.0);
  EXPECT_GE(layouts[1].y.max, 100.0);
  // Not absurdly wide: the nice range is within two steps of the data.
  EXPECT_GE(layouts[1].y.min, 90.0);
  EXPECT_LE(layouts[1].y.max, 105.0);
  for (const PanelLayout& L : layouts) {
    EXPECT_GE(L.y.ticks.size(), 3u);
    EXPECT_LE(L.y.ticks.size(), 12u);
    EXPECT_DOUBLE_EQ(L.y.ticks.front(), L.y.min);
    EXPECT_DOUBLE_EQ(L.y.ticks.back(), L.y.max);
  }
}

// The x of the legend box in an SVG (the only rect drawn with fill-opacity).
double LegendLeft(const std::string& svg) {
  const size_t opacity = svg.find("fill-opacity=\"0.9\"");
  const size_t rect = svg.rfind("<rect x=\"", opacity);
  return std::stod(svg.substr(rect + 9));
}

TEST(Figure, BestLegendCornerAvoidsTheData) {
  Figure figure;
  PlotPanel panel;
  PlotSeries s;
  s.label = "rising";
  s.x = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10};
  s.y = {0, 0, 0, 0, 0, 0, 7, 8, 9.5, 9.5, 9.5};  // the bottom left and the top right
  panel.series.push_back(s);
  panel.x_axis.min = panel.y_axis.min = 0.0;
  panel.x_axis.max = panel.y_axis.max = 10.0;
  figure.panels = {panel};
  const PanelLayout L = figure.Layout()[0];
  const double centre = L.left_px + 0.5 * L.width_px;
  EXPECT_LT(LegendLeft(figure.ToSvg()), centre);  // top left is free
  figure.panels[0].series[0].y = {0, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5, 9.5};
  // The top is taken by the line; bottom right is free.
  EXPECT_GT(LegendLeft(figure.ToSvg()), centre);
  figure.panels[0].legend = LegendPosition::kTopLeft;
  EXPECT_LT(LegendLeft(figure.ToSvg()), centre);
  figure.panels[0].legend = LegendPosition::kNone;
  EXPECT_EQ(figure.ToSvg().find("fill-opacity"), std::string::npos);
}

TEST(Figure, EqualAspectGivesBothAxesOneScale) {
  Figure figure;
  figure.width_px = 700;
  figure.height_px = 400;
  PlotPanel panel;
  panel.equal_aspect = true;
  PlotSeries s;
  s.x = {-1.0, 1.0};
  s.y = {-1.0, 1.0};
  panel.series.push_back(s);
  figure.panels = {panel};
  const PanelLayout L = figure.Layout()[0];
  const double x_scale = L.width_px / (L.x.max - L.x.min);
  const double y_scale = L.height_px / (L.y.max - L.y.min);
  EXPECT_NEAR(x_scale, y_scale, 1e-9 * x_scale);
  EXPECT_LE(L.x.min, -1.0);
  EXPECT_GE(L.x.max, 1.0);
}

TEST(Figure, SvgIsWellFormedAndEscapesLabels) {
  Figure figure = TwoPanels();
  figure.panels[0].title = "a < b & \"c\" > 'd'";
  figure.panels[0].series[0].label = "<script>";
  figure.panels[1].x_axis.label = "mean \xC2\xB1 std";
  const std::string svg = figure.ToSvg();
  EXPECT_EQ(XmlProblem(svg), "") << svg;
  EXPECT_NE(svg.find("a &lt; b &amp; &quot;c&quot; &gt; &apos;d&apos;"), std::string::npos);
  EXPECT_NE(svg.find("&lt;script&gt;"), std::string::npos);
  EXPECT_EQ(svg.find("<script>"), std::string::npos);
  EXPECT_NE(svg.find("mean \xC2\xB1 std"), std::string::npos);
  EXPECT_EQ(svg.rfind("</svg>\n"), svg.size() - 7);
  // The checker itself catches the problems it is meant to.
  EXPECT_NE(XmlProblem("<svg><g></svg>"), "");
  EXPECT_NE(XmlProblem("<svg>a & b</svg>"), "");
  EXPECT_NE(XmlProblem("<svg>a > b</svg>"), "");
  EXPECT_EQ(XmlProblem("<?xml version=\"1.0\"?>\n<svg><g/><text>x &amp; y</text></svg>"), "");
}

TEST(Figure, RejectsNonFiniteOrInconsistentData) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto expect_error = [](const Figure& figure, const std::string& part) {
    try {
      (void)figure.ToSvg();
      ADD_FAILURE() << "no error for " << part;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
    EXPECT_THROW((void)figure.ToImage(), Error);
  };
  Figure figure = TwoPanels();
  figure.panels[1].series[0].y[2] = nan;
  expect_error(figure, "point 2 is not finite");
  figure = TwoPanels();
  figure.panels[0].series[0].x[0] = inf;
  expect_error(figure, "particle filter");
  figure = TwoPanels();
  figure.panels[0].series[0].y_error[1] = nan;
  expect_error(figure, "error bar 1");
  figure = TwoPanels();
  figure.panels[0].series[0].y_error[1] = -0.1;
  expect_error(figure, "error bar 1");
  figure = TwoPanels();
  figure.panels[0].reference_lines[0].y = inf;
  expect_error(figure, "brute force");
  figure = TwoPanels();
  figure.panels[0].series[0].y.pop_back();
  expect_error(figure, "differ in length");
  figure = TwoPanels();
  figure.panels[0].y_axis.min = 1.0;
  figure.panels[0].y_axis.max = 0.0;
  expect_error(figure, "inverted");
  figure = TwoPanels();
  figure.width_px = 200;
  expect_error(figure, "too small");
  figure.panels.clear();
  expect_error(figure, "at least one panel");
}

TEST(Figure, WritesSvgAndPngOfTheRequestedSize) {
  const std::filesystem::path folder =
      std::filesystem::temp_directory_path() / ("silpose_plot_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  Figure figure = TwoPanels();
  figure.width_px = 1000;
  figure.height_px = 380;
  figure.WriteSvg(folder / "figure.svg");
  std::ifstream file(folder / "figure.svg");
  std::stringstream text;
  text << file.rdbuf();
  EXPECT_EQ(text.str(), figure.ToSvg());

  figure.WritePng(folder / "figure.png");
  const cv::Mat image = cv::imread((folder / "figure.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 1000);
  EXPECT_EQ(image.rows, 380);
  EXPECT_EQ(image.type(), CV_8UC3);
  // Not blank: the background is white, the data is drawn in the series' colour at its place.
  const PanelLayout L = figure.Layout()[1];
  const Rgb blue = PaletteColour(0);
  const cv::Vec3b at = image.at<cv::Vec3b>(static_cast<int>(std::lround(L.YToPixel(99.0))),
                                           static_cast<int>(std::lround(L.XToPixel(20.0))));
  EXPECT_NEAR(at[0], blue.b, 40);
  EXPECT_NEAR(at[1], blue.g, 40);
  EXPECT_NEAR(at[2], blue.r, 40);
  EXPECT_EQ(image.at<cv::Vec3b>(1, 1), cv::Vec3b(255, 255, 255));
  // Text was drawn (the title's row has dark pixels).
  int dark = 0;
  for (int y = 0; y < static_cast<int>(L.top_px); ++y) {
    for (int x = 450; x < 1000; ++x) dark += image.at<cv::Vec3b>(y, x)[0] < 100;
  }
  EXPECT_GT(dark, 20);

  const std::filesystem::path bad = folder / "missing" / "figure.png";
  for (const auto& write :
       {+[](const Figure&f, const std::filesystem::path&p) { f.WriteSvg(p); },
        +[](const Figure&f, const std::filesystem::path&p) { f.WritePng(p); }}) {
    try {
      write(figure, bad);
      ADD_FAILURE() << "no error writing into a missing folder";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(bad.string()), std::string::npos) << e.what();
    }
  }
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace silpose
