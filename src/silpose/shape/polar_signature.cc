#include "silpose/shape/polar_signature.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "silpose/util/cpu_features.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Unit ray directions at `length` equal angles, made once per length and thread (a frame's
// signature needs the same 1000 directions every time; computing them cost a fifth of it).
const std::vector<Eigen::Vector2d>& RayDirections(int length) {
  thread_local std::vector<Eigen::Vector2d> directions;
  if (directions.size() != static_cast<size_t>(length)) {
    directions.resize(static_cast<size_t>(length));
    for (size_t k = 0; k < directions.size(); ++k) {
      const double angle = kTwoPi * static_cast<double>(k) / static_cast<double>(length);
      directions[k] = {std::cos(angle), std::sin(angle)};
    }
  }
  return directions;
}

// Whether any of the bytes [begin, end) is not zero. A plain loop over the bytes without an early
// exit: the compiler turns it into vector instructions (16 bytes at a time with SSE2), which an
// eight-byte word loop did not get.
SILPOSE_ALWAYS_INLINE bool AnyNonZero(const uint8_t* begin, const uint8_t* end) {
  const auto n = static_cast<size_t>(end - begin);
  uint8_t any = 0;
  for (size_t i = 0; i < n; ++i) any |= begin[i];
  return any != 0;
}

// Bytes checked at once by FirstNonZero and LastNonZero before they look at single bytes.
constexpr ptrdiff_t kBlock = 32;

// The first non-zero byte of [begin, end), or end.
SILPOSE_ALWAYS_INLINE const uint8_t* FirstNonZero(const uint8_t* begin, const uint8_t* end) {
  while (end - begin >= kBlock && !AnyNonZero(begin, begin + kBlock)) begin += kBlock;
  for (; begin < end; ++begin) {
    if (*begin != 0) return begin;
  }
  return end;
}

// The last non-zero byte of [begin, end), or end.
SILPOSE_ALWAYS_INLINE const uint8_t* LastNonZero(const uint8_t* begin, const uint8_t* end) {
  const uint8_t* p = end;
  while (p - begin >= kBlock && !AnyNonZero(p - kBlock, p)) p -= kBlock;
  while (p > begin) {
    --p;
    if (*p != 0) return p;
  }
  return end;
}

SILPOSE_ALWAYS_INLINE cv::Rect NonZeroBoundingBoxBody(const cv::Mat& mask) {
  SILPOSE_ASSERT(mask.type() == CV_8UC1);
  int top = -1;
  int bottom = -1;
  int left = mask.cols;
  int right = -1;
  for (int y = 0; y < mask.rows; ++y) {
    const uint8_t* row = mask.ptr<uint8_t>(y);
    const uint8_t* row_end = row + mask.cols;
    if (!AnyNonZero(row, row_end)) continue;
    if (top < 0) top = y;
    bottom = y;
    // Only the columns outside those already known to hold the object can widen the box.
    const uint8_t* first = FirstNonZero(row, row + left);
    if (first != row + left) left = static_cast<int>(first - row);
    const uint8_t* last = LastNonZero(row + right + 1, row_end);
    if (last != row_end) right = static_cast<int>(last - row);
  }
  if (top < 0) return {};
  return {left, top, right - left + 1, bottom - top + 1};
}

cv::Rect NonZeroBoundingBoxBaseline(const cv::Mat& mask) { return NonZeroBoundingBoxBody(mask); }

SILPOSE_TARGET_AVX2 cv::Rect NonZeroBoundingBoxAvx2(const cv::Mat& mask) {
  return NonZeroBoundingBoxBody(mask);
}

}  // namespace

cv::Rect NonZeroBoundingBox(const cv::Mat& mask) {
  return Avx2Enabled() ? NonZeroBoundingBoxAvx2(mask) : NonZeroBoundingBoxBaseline(mask);
}

namespace {

// The number of non-zero pixels of a mask and the sums of their column and row indices.
struct PixelMoments {
  int64_t count = 0;
  int64_t sum_x = 0;
  int64_t sum_y = 0;
};

// PixelMoments of a mask. RowSum is wide enough for the sum of the column indices of one row.
template <typename RowSum>
SILPOSE_ALWAYS_INLINE PixelMoments PixelSums(const cv::Mat& mask) {
  PixelMoments moments;
  for (int y = 0; y < mask.rows; ++y) {
    const uint8_t* row = mask.ptr<uint8_t>(y);
    RowSum row_count = 0;
    RowSum row_sum_x = 0;
    for (int x = 0; x < mask.cols; ++x) {
      const RowSum inside = row[x] != 0 ? 1 : 0;
      row_count += inside;
      row_sum_x += inside * x;
    }
    moments.count += row_count;
    moments.sum_x += row_sum_x;
    moments.sum_y += static_cast<int64_t>(row_count) * y;
  }
  return moments;
}

SILPOSE_ALWAYS_INLINE PixelMoments PixelMomentsBody(const cv::Mat& mask) {
  // 0 + 1 + ... + 46340 still fits 32 bits.
  return mask.cols <= 46340 ? PixelSums<int32_t>(mask) : PixelSums<int64_t>(mask);
}

PixelMoments PixelMomentsBaseline(const cv::Mat& mask) { return PixelMomentsBody(mask); }

SILPOSE_TARGET_AVX2 PixelMoments PixelMomentsAvx2(const cv::Mat& mask) {
  return PixelMomentsBody(mask);
}

// Integer sums: the two builds give the same moments.
PixelMoments ComputePixelMoments(const cv::Mat& mask) {
  return Avx2Enabled() ? PixelMomentsAvx2(mask) : PixelMomentsBaseline(mask);
}

// The area and centre of gravity (pixel centres at integer coordinates) from the moments.
double AreaCentroid(const PixelMoments& moments, Eigen::Vector2d* centroid) {
  if (moments.count > 0) {
    *centroid = {static_cast<double>(moments.sum_x) / static_cast<double>(moments.count),
                 static_cast<double>(moments.sum_y) / static_cast<double>(moments.count)};
  }
  return static_cast<double>(moments.count);
}

}  // namespace

double PixelAreaCentroid(const cv::Mat& mask, Eigen::Vector2d* centroid) {
  SILPOSE_ASSERT(mask.type() == CV_8UC1 && centroid != nullptr);
  return AreaCentroid(ComputePixelMoments(mask), centroid);
}

double PolygonAreaCentroid(std::span<const Eigen::Vector2d> polygon, Eigen::Vector2d* centroid) {
  double twice_area = 0.0;
  Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  const size_t n = polygon.size();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = polygon[i];
    const Eigen::Vector2d& q = polygon[(i + 1) % n];
    const double cross = Cross(p, q);
    twice_area += cross;
    weighted += cross * (p + q);
  }
  if (std::abs(twice_area) < 1e-12) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : polygon) mean += p;
    *centroid = mean / static_cast<double>(std::max<size_t>(n, 1));
    return 0.0;
  }
  *centroid = weighted / (3.0 * twice_area);
  return 0.5 * twice_area;
}

std::string DescribeSilhouetteFlags(uint32_t flags) {
  static constexpr std::pair<uint32_t, const char*> kNames[] = {
      {kSilhouetteHasHoles, "holes"},
      {kSilhouetteSeveralComponents, "several-components"},
      {kSilhouetteCentroidOutside, "centroid-outside"},
      {kSilhouetteTouchesBorder, "touches-border"},
      {kSilhouetteNearlyCircular, "nearly-circular"},
  };
  std::string text;
  for (const auto& [bit, name] : kNames) {
    if ((flags & bit) == 0) continue;
    if (!text.empty()) text += ", ";
    text += name;
  }
  return text.empty() ? "none" : text;
}

const char* ToString(SignatureStatus status) {
  switch (status) {
    case SignatureStatus::kOk:
      return "ok";
    case SignatureStatus::kEmpty:
      return "empty";
    case SignatureStatus::kTooSmall:
      return "too-small";
  }
  return "unknown";
}

bool SignatureOptions::Check(std::string* error) const {
  std::ostringstream message;
  if (length < 16 || length > 65536 || length % 2 != 0) {
    message << "signature length must be even and in [16, 65536], got " << length;
  } else if (!(min_area_px >= 1.0) || !std::isfinite(min_area_px)) {
    message << "minimum silhouette area must be >= 1 pixel, got " << min_area_px;
  } else if (!(circular_threshold >= 0.0) || !std::isfinite(circular_threshold)) {
    message << "circularity threshold must be >= 0, got " << circular_threshold;
  } else if (!nearest_to_px.allFinite()) {
    message << "reference point for the nearest component must be finite";
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

std::string SignatureResult::Describe() const {
  std::ostringstream text;
  text << "silhouette " << ToString(status);
  if (status != SignatureStatus::kEmpty) {
    text << ", area " << static_cast<long long>(std::lround(signature.area_px)) << " px";
  }
  text << ", flags: " << DescribeSilhouetteFlags(flags);
  return text.str();
}

std::vector<float> StarConvexRadii(std::span<const Eigen::Vector2d> polygon,
                                   const Eigen::Vector2d& centre, int length, int* missed) {
  SILPOSE_ASSERT(length > 0);
  const auto m = static_cast<size_t>(length);
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  std::vector<double> radius(m, kInfinity);
  const std::vector<Eigen::Vector2d>& directions = RayDirections(length);
  const double bins_per_radian = static_cast<double>(length) / kTwoPi;
  const size_t n = polygon.size();
  // Each vertex's angle about the centre, once (an edge needs both of its ends').
  std::vector<double> angles(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = polygon[i] - centre;
    angles[i] = std::atan2(a.y(), a.x());
  }
  for (size_t i = 0; i < n; ++i) {
    const size_t next = i + 1 == n ? 0 : i + 1;
    const Eigen::Vector2d a = polygon[i] - centre;
    const Eigen::Vector2d b = polygon[next] - centre;
    const Eigen::Vector2d edge = b - a;
    if (edge.squaredNorm() == 0.0) continue;
    const double angle_a = angles[i];
    double sweep = angles[next] - angle_a;
    if (sweep > std::numbers::pi) sweep -= kTwoPi;
    if (sweep < -std::numbers::pi) sweep += kTwoPi;
    // An edge through the centre itself sweeps half a turn: it hides nothing behind it.
    if (std::abs(sweep) >= std::numbers::pi - 1e-12) continue;
    const double low = angle_a + std::min(0.0, sweep);
    const double high = angle_a + std::max(0.0, sweep);
    const auto first = static_cast<long>(std::ceil(low * bins_per_radian - 1e-9));
    const auto last = static_cast<long>(std::floor(high * bins_per_radian + 1e-9));
    for (long k = first; k <= last; ++k) {
      const auto bin = static_cast<size_t>(((k % length) + length) % length);
      const Eigen::Vector2d& u = directions[bin];
      const double denominator = Cross(u, edge);
      double t;
      if (std::abs(denominator) > 1e-12) {
        t = Cross(a, edge) / denominator;
      } else {  // ray along the edge: the nearer end point
        t = std::min(a.dot(u), b.dot(u));
      }
      if (t > 0.0 && t < radius[bin]) radius[bin] = t;
    }
  }
  std::vector<float> result(m);
  int num_missed = 0;
  for (size_t k = 0; k < m; ++k) {
    if (radius[k] == kInfinity) {
      ++num_missed;
      result[k] = 0.0f;
    } else {
      result[k] = static_cast<float>(radius[k]);
    }
  }
  if (missed != nullptr) *missed = num_missed;
  return result;
}

SignatureResult ExtractSignature(const cv::Mat& mask, const SignatureOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid signature options: ", error);
  if (mask.empty()) ThrowError("mask is empty (0 x 0 pixels)");
  if (mask.type() != CV_8UC1) {
    ThrowError("mask must be 8-bit single-channel (CV_8UC1), got type ", mask.type(), " with ",
               mask.channels(), " channel(s)");
  }
  SignatureResult result;
  // Contours are traced on the bounding box of the non-zero pixels only (findContours pads its
  // input with zeros, so the contours are those of the whole mask, in the same order).
  const cv::Rect object_box = NonZeroBoundingBox(mask);
  if (object_box.empty()) return result;  // kEmpty
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(mask(object_box), contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE,
                   object_box.tl());

  // Outer contours have no parent in the two-level hierarchy of RETR_CCOMP.
  std::vector<int> outer;
  std::vector<double> outer_area;
  std::vector<double> outer_enclosed;
  std::vector<Eigen::Vector2d> outer_centroid;
  for (int i = 0; i < static_cast<int>(contours.size()); ++i) {
    if (hierarchy[static_cast<size_t>(i)][3] >= 0) continue;
    std::vector<Eigen::Vector2d> polygon;
    polygon.reserve(contours[static_cast<size_t>(i)].size());
    for (const auto& p : contours[static_cast<size_t>(i)]) polygon.emplace_back(p.x, p.y);
    Eigen::Vector2d centroid;
    const double enclosed = std::abs(PolygonAreaCentroid(polygon, &centroid));
    outer.push_back(i);
    outer_enclosed.push_back(enclosed);
    // The contour runs through boundary pixel centres; the pixels' own outline encloses about half
    // a pixel more all around, which makes this close to the component's pixel count.
    outer_area.push_back(enclosed + 0.5 * cv::arcLength(contours[static_cast<size_t>(i)], true) +
                         1.0);
    outer_centroid.push_back(centroid);
  }
  if (outer.empty()) return result;  // kEmpty

  // Choose among the components large enough to describe (a long thin line has a large outline but
  // encloses nothing, and must not hide the object); if none is, report the largest as too small.
  bool any_describable = false;
  for (double enclosed : outer_enclosed) any_describable |= enclosed >= options.min_area_px;
  size_t chosen = outer.size();
  for (size_t j = 0; j < outer.size(); ++j) {
    if (any_describable && outer_enclosed[j] < options.min_area_px) continue;
    if (chosen == outer.size()) {
      chosen = j;
    } else if (options.component == ComponentChoice::kLargest) {
      if (outer_area[j] > outer_area[chosen]) chosen = j;
    } else if ((outer_centroid[j] - options.nearest_to_px).squaredNorm() <
               (outer_centroid[chosen] - options.nearest_to_px).squaredNorm()) {
      chosen = j;
    }
  }
  const int chosen_index = outer[chosen];
  const auto& contour = contours[static_cast<size_t>(chosen_index)];
  PolarSignature& signature = result.signature;

  for (size_t j = 0; j < outer.size(); ++j) {
    if (outer_area[j] >= 0.01 * outer_area[chosen]) ++result.num_components;
  }
  if (result.num_components > 1) result.flags |= kSilhouetteSeveralComponents;
  for (int child = hierarchy[static_cast<size_t>(chosen_index)][2]; child >= 0;
       child = hierarchy[static_cast<size_t>(child)][0]) {
    result.hole_area_px += cv::contourArea(contours[static_cast<size_t>(child)]);
  }
  if (hierarchy[static_cast<size_t>(chosen_index)][2] >= 0) result.flags |= kSilhouetteHasHoles;
  for (const auto& p : contour) {
    if (p.x == 0 || p.y == 0 || p.x == mask.cols - 1 || p.y == mask.rows - 1) {
      result.flags |= kSilhouetteTouchesBorder;
      break;
    }
  }
  // Lines and specks enclose (almost) nothing: their outline says nothing about the object.
  if (outer_enclosed[chosen] < options.min_area_px) {
    result.status = SignatureStatus::kTooSmall;
    return result;
  }
  // The chosen component alone, holes filled, in its bounding box: other components and holes
  // must not move the centre.
  const int margin = 1;
  const cv::Rect box = cv::boundingRect(contour);
  const cv::Rect roi(box.x - margin, box.y - margin, box.width + 2 * margin,
                     box.height + 2 * margin);
  // Centre of gravity and area from the pixels themselves (pixel centres at integer coordinates),
  // not from the contour polygon, which runs half a pixel inside the pixels' outline; the pixel
  // indices counted from the corner of `roi`.
  PixelMoments moments;
  if (contours.size() == 1) {
    // The mask's only component, without holes: its non-zero pixels are exactly those the filled
    // contour covers (the test AreaAndCentreAreThoseOfTheFilledOutline checks it), so the mask's
    // own pixels are summed and no copy is drawn.
    moments = ComputePixelMoments(mask(box));
    moments.sum_x += moments.count * (box.x - roi.x);
    moments.sum_y += moments.count * (box.y - roi.y);
  } else {
    // Constructed with its value (not Mat::zeros, a matrix expression: OpenCV makes the
    // expressions' shared operator object on first use without synchronisation, which
    // ThreadSanitizer reports when the database build's threads describe their first views at
    // once). silpose's library code uses no Mat::zeros, ones or eye for this reason.
    cv::Mat filled(roi.size(), CV_8UC1, cv::Scalar(0));
    cv::drawContours(filled, contours, chosen_index, cv::Scalar(1), cv::FILLED, cv::LINE_8,
                     cv::noArray(), 0, cv::Point(-roi.x, -roi.y));
    moments = ComputePixelMoments(filled);
  }
  Eigen::Vector2d filled_centroid = Eigen::Vector2d::Zero();
  signature.area_px = AreaCentroid(moments, &filled_centroid);
  signature.centroid_px = filled_centroid + Eigen::Vector2d(roi.x, roi.y);
  if (cv::pointPolygonTest(contour,
                           cv::Point2f(static_cast<float>(signature.centroid_px.x()),
                                       static_cast<float>(signature.centroid_px.y())),
                           false) < 0) {
    result.flags |= kSilhouetteCentroidOutside;
  }

  std::vector<Eigen::Vector2d>& polygon = result.outline_px;
  polygon.reserve(contour.size());
  for (const auto& p : contour) polygon.emplace_back(p.x, p.y);
  signature.radii =
      StarConvexRadii(polygon, signature.centroid_px, options.length, &signature.missed_directions);

  // The contour runs through the centres of the boundary pixels; the pixels' own outline lies half
  // a pixel further out, which keeps the shape the same across image sizes. (A sub-pixel outline
  // from a blurred mask was tried and changed no match result: the binary masks' detail below one
  // pixel, not the staircase, limits the precision; see docs/PERFORMANCE.md.)
  double sum = 0.0;
  for (float& r : signature.radii) {
    if (r > 0.0f) r += 0.5f;
    sum += r;
  }
  const double mean = sum / static_cast<double>(options.length);
  if (!(mean > 0.0)) {
    result.status = SignatureStatus::kTooSmall;
    return result;
  }
  signature.mean_radius_px = mean;
  double sum_squares = 0.0;
  for (float& r : signature.radii) {
    r = static_cast<float>(r / mean);
    sum_squares += (r - 1.0) * (r - 1.0);
  }
  signature.relative_std = std::sqrt(sum_squares / static_cast<double>(options.length));
  if (signature.relative_std < options.circular_threshold) {
    result.flags |= kSilhouetteNearlyCircular;
  }
  result.status = SignatureStatus::kOk;
  return result;
}

}  // namespace silpose
