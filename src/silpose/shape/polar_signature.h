#pragma once
// The silhouette descriptor of the paper (section 4.2).
//
// From a binary mask: the outer contour of the chosen connected component (holes ignored) ->
// its area centre of gravity -> for each of M equally spaced directions, the distance from the
// centre to the FIRST crossing of the outline (so only the part of the outline visible from the
// centre, a star-convex polygon, is kept; concavities hidden behind it do not produce the large
// error peaks of a plain polar resampling, paper Fig. 3) -> radii divided by their mean, which
// makes the descriptor scale invariant. The correlation (match/circular_correlator.h) then removes
// mean and variance, as in the paper's normalised cross-correlation (3).
//
// Angles: bin k lies at 360 * k / M degrees from image +x towards image +y (clockwise on screen, as
// image y points down). Rolling the camera by r degrees shifts the signature by r * M / 360 bins,
// see geometry/view_frame.h.

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <span>
#include <string>
#include <vector>

namespace silpose {

/// What was found in the mask, as bits. None of these stops the descriptor from being computed;
/// they tell the caller how far to trust it.
enum SilhouetteFlag : uint32_t {
  kSilhouetteHasHoles = 1u << 0,           ///< the chosen component has holes (ignored)
  kSilhouetteSeveralComponents = 1u << 1,  ///< other components of >= 1% of its area were dropped
  kSilhouetteCentroidOutside = 1u << 2,    ///< the centre of gravity lies outside the shape
  kSilhouetteTouchesBorder = 1u << 3,      ///< the outline touches the image border (cut off?)
  kSilhouetteNearlyCircular = 1u << 4,     ///< radii almost constant: roll not observable
};

/// Comma-separated names of the flags set in `flags` ("holes, touches-border"), or "none".
std::string DescribeSilhouetteFlags(uint32_t flags);

enum class SignatureStatus : uint8_t {
  kOk = 0,        ///< descriptor computed
  kEmpty = 1,     ///< no object pixel in the mask
  kTooSmall = 2,  ///< the chosen component is smaller than SignatureOptions::min_area_px
};
const char* ToString(SignatureStatus status);

/// Which connected component describes the object.
enum class ComponentChoice : uint8_t {
  kLargest = 0,    ///< largest area (default)
  kNearestTo = 1,  ///< centre of gravity nearest to SignatureOptions::nearest_to_px
};

struct SignatureOptions {
  /// M, the number of directions (even, 16..65536). Paper: 1000.
  int length = 1000;
  /// A component whose outline (through its boundary pixels' centres) encloses fewer pixels is
  /// "too small to describe"; one-pixel lines and specks enclose none.
  double min_area_px = 64.0;
  /// Relative standard deviation of the radii below which the silhouette is "nearly circular".
  double circular_threshold = 0.01;
  ComponentChoice component = ComponentChoice::kLargest;
  /// Reference point for ComponentChoice::kNearestTo, in pixels.
  Eigen::Vector2d nearest_to_px = Eigen::Vector2d::Zero();

  bool Check(std::string* error = nullptr) const;
};

/// The descriptor and the silhouette measurements the pose needs.
struct PolarSignature {
  /// M radii divided by their mean (so their mean is 1); bin k at angle 360 k / M degrees.
  std::vector<float> radii;
  /// Mean of the radii before normalisation, pixels (the silhouette's scale).
  double mean_radius_px = 0.0;
  /// Area centre of gravity of the outer contour, pixels.
  Eigen::Vector2d centroid_px = Eigen::Vector2d::Zero();
  /// Area of the component with its holes filled, pixels (from the outer contour).
  double area_px = 0.0;
  /// Standard deviation of `radii` (relative to their mean of 1).
  double relative_std = 0.0;
  /// Directions in which the outline was not crossed (only with the centroid outside); radius 0.
  int missed_directions = 0;
};

struct SignatureResult {
  SignatureStatus status = SignatureStatus::kEmpty;
  /// SilhouetteFlag bits.
  uint32_t flags = 0;
  /// Number of outer components of >= 1% of the chosen one's area (including it).
  int num_components = 0;
  /// Total area of the chosen component's holes, pixels.
  double hole_area_px = 0.0;
  /// Valid when status == kOk.
  PolarSignature signature;
  /// The chosen component's outer contour through its boundary pixels' centres (pixels, in
  /// order), when ok(): what the on-axis description (pose/on_axis.h) and contour
  /// refinement work from.
  std::vector<Eigen::Vector2d> outline_px;

  bool ok() const { return status == SignatureStatus::kOk; }
  /// One line for people: status, flags, area.
  std::string Describe() const;
};

/// Computes the descriptor of a CV_8UC1 mask (non-zero = object). Throws silpose::Error for a mask
/// of another type or invalid options; an empty or too small silhouette is a status, not an error.
SignatureResult ExtractSignature(const cv::Mat& mask, const SignatureOptions& options = {});

/// The smallest rectangle holding every non-zero pixel of a CV_8UC1 mask; empty when there is none.
/// Scans the rows with vector instructions (about 10 µs for 640×480).
cv::Rect NonZeroBoundingBox(const cv::Mat& mask);

/// The number of non-zero pixels of a CV_8UC1 mask and their centre of gravity (pixel centres at
/// integer coordinates; `centroid` is left as it is when there is none): what cv::moments(mask,
/// true) gives as m00 and (m10, m01) / m00, without starting OpenCV's thread pool, which costs more
/// than the sums over a silhouette's bounding box.
double PixelAreaCentroid(const cv::Mat& mask, Eigen::Vector2d* centroid);

/// Area centre of gravity of a closed polygon (shoelace formula); the vertex mean for a polygon
/// without area. Returns the signed area (positive when counter-clockwise in a y-up frame).
double PolygonAreaCentroid(std::span<const Eigen::Vector2d> polygon, Eigen::Vector2d* centroid);

/// The star-convex radii of a closed polygon seen from `centre`: for each of `length` directions,
/// the distance to the first crossing of the polygon's edges, 0 if the ray crosses none (counted in
/// `missed`, may be null). O(vertices + length).
std::vector<float> StarConvexRadii(std::span<const Eigen::Vector2d> polygon,
                                   const Eigen::Vector2d& centre, int length,
                                   int* missed = nullptr);

}  // namespace silpose
