#include "silpose/synth/colour_frames.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>

#include "silpose/io/image_codec.h"
#include "silpose/synth/synth_random.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

using synth_internal::FrameSeed;
using synth_internal::Mix64;
using synth_internal::Uniform;
using synth_internal::Uniform01;

// Random streams of the colour frames; the mask degradations use 1..5 (degradation.cc), so the
// same user seed drives both without correlating them.
enum Stream : uint64_t {
  kStreamFlicker = 101,
  kStreamNoise = 102,
  kStreamTexture = 103,
};

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Smooth noise in about [0, 1]: a grid of uniform values, `cells_x` cells across the width
// (square cells), interpolated bicubically to width x height.
cv::Mat SmoothNoise(int width, int height, int cells_x, std::mt19937_64& engine) {
  const int cells_y = std::max(1, static_cast<int>(std::lround(cells_x * double(height) / width)));
  cv::Mat grid(cells_y + 1, cells_x + 1, CV_32FC1);
  for (int v = 0; v < grid.rows; ++v) {
    for (int u = 0; u < grid.cols; ++u) grid.at<float>(v, u) = float(Uniform01(engine));
  }
  cv::Mat field;
  cv::resize(grid, field, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
  return field;
}

// A value in [low, high) for an integer key of the texture (a plank), from the seed.
double KeyUniform(uint64_t seed, int64_t key, uint64_t salt, double low, double high) {
  const uint64_t bits = Mix64(seed ^ Mix64(static_cast<uint64_t>(key) ^ Mix64(salt)));
  return low + (high - low) * static_cast<double>(bits >> 11) * 0x1.0p-53;
}

bool InByteRange(const Eigen::Vector3d& colour) {
  for (int k = 0; k < 3; ++k) {
    if (!(colour[k] >= 0.0 && colour[k] <= 255.0)) return false;
  }
  return true;
}

}  // namespace

bool ColourOptions::Check(std::string* error) const {
  std::ostringstream message;
  std::string problem;
  if (!background_image.empty() && background_image.type() != CV_8UC3) {
    message << "the background image must be 8-bit BGR (3 channels)";
  } else if (!(noise_sigma >= 0.0 && noise_sigma <= 100.0)) {
    message << "camera noise sigma must be in [0, 100] grey levels, got " << noise_sigma;
  } else if (!(flicker >= 0.0 && flicker <= 0.5)) {
    message << "flicker must be in [0, 0.5], got " << flicker;
  } else if (!shading.Check(&problem)) {
    message << "shading: " << problem;
  } else {
    for (size_t i = 0; i < object_colours_bgr.size(); ++i) {
      if (!InByteRange(object_colours_bgr[i])) {
        message << "object colour " << i + 1 << " must have B, G, R in [0, 255], got ("
                << object_colours_bgr[i].transpose() << ")";
        break;
      }
    }
    if (message.tellp() == 0) return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

Eigen::Vector3d DefaultObjectColour(int index) {
  SILPOSE_ASSERT(index >= 0);
  static const std::array<Eigen::Vector3d, 8> kPalette = {Eigen::Vector3d(220, 110, 20),  // blue
                                                          Eigen::Vector3d(30, 120, 240),  // orange
                                                          Eigen::Vector3d(50, 190, 40),   // green
                                                          Eigen::Vector3d(180, 40, 200),  // magenta
                                                          Eigen::Vector3d(20, 210, 230),  // yellow
                                                          Eigen::Vector3d(210, 200, 30),  // cyan
                                                          Eigen::Vector3d(40, 30, 200),   // red
                                                          Eigen::Vector3d(140, 50, 100)};  // purple
  return kPalette[static_cast<size_t>(index) % kPalette.size()];
}

cv::Mat GenerateBackgroundTexture(int width_px, int height_px, uint64_t seed) {
  if (width_px < 1 || width_px > 16384 || height_px < 1 || height_px > 16384) {
    ThrowError("background texture size must be in [1, 16384] pixels, got ", width_px, "x",
               height_px);
  }
  // Drawn at twice the resolution and averaged down, which tames the aliasing of the planks
  // towards the horizon.
  const int width = 2 * width_px;
  const int height = 2 * height_px;
  std::mt19937_64 engine(FrameSeed(seed, 0, kStreamTexture));
  cv::Mat coarse = SmoothNoise(width, height, 4, engine);
  cv::Mat medium = SmoothNoise(width, height, 9, engine);
  cv::Mat fine = SmoothNoise(width, height, 23, engine);
  cv::Mat tint_blue = SmoothNoise(width, height, 3, engine);
  cv::Mat tint_red = SmoothNoise(width, height, 3, engine);
  const Eigen::Vector3d wall(150.0, 160.0, 170.0);
  const Eigen::Vector3d wood(92.0, 115.0, 140.0);  // greyish, so objects stand out
  const double horizon = 0.45 * height;
  const double plank_width = 0.3;  // table units; the camera is 1 unit above the table
  const double board_length = 2.5;

  cv::Mat texture(height, width, CV_8UC3);
  for (int v = 0; v < height; ++v) {
    cv::Vec3b* row = texture.ptr<cv::Vec3b>(v);
    for (int u = 0; u < width; ++u) {
      Eigen::Vector3d colour;
      const double below = v + 0.5 - horizon;  // rows below the horizon
      if (below < 1.0) {
        const double shade = 0.5 * coarse.at<float>(v, u) + 0.3 * medium.at<float>(v, u) +
                             0.2 * fine.at<float>(v, u);
        colour = wall * (0.72 + 0.45 * shade);
        colour[0] += 30.0 * (tint_blue.at<float>(v, u) - 0.5);
        colour[2] += 30.0 * (tint_red.at<float>(v, u) - 0.5);
      } else {
        // Table point seen at (u, v): depth z = f / (v - horizon) with f = width, lateral
        // position x = (u - width / 2) / (v - horizon).
        const double depth = width / below;
        const double across = (u + 0.5 - 0.5 * width) / below;
        const double plank_position = across / plank_width;
        const double plank = std::floor(plank_position);
        const auto key = static_cast<int64_t>(plank);
        const double in_plank = plank_position - plank;
        const double along = depth / board_length + KeyUniform(seed, key, 1, 0.0, 1.0);
        const double in_board = along - std::floor(along);
        const auto board = static_cast<int64_t>(std::floor(along));
        const double tone = KeyUniform(seed, key * 7919 + board, 2, 0.78, 1.12);
        const double grain =
            0.93 +
            0.07 * std::sin(kTwoPi * (6.0 * in_plank + 0.6 * std::sin(0.9 * depth + 1.7 * plank)));
        double brightness = tone * grain * (0.85 + 0.3 * fine.at<float>(v, u));
        if (in_plank < 0.04 || in_board < 0.015) brightness *= 0.6;  // gaps between boards
        // Far away the planks blur into their mean colour.
        const double haze = std::min(1.0, depth / (12.0 * width / height));
        colour = wood * (brightness * (1.0 - haze) + 0.95 * haze);
      }
      for (int k = 0; k < 3; ++k) row[u][k] = cv::saturate_cast<uint8_t>(colour[k]);
    }
  }
  cv::Mat result;
  cv::resize(texture, result, cv::Size(width_px, height_px), 0, 0, cv::INTER_AREA);
  return result;
}

cv::Mat FitBackground(const cv::Mat& image, int width_px, int height_px) {
  if (image.empty() || image.type() != CV_8UC3) {
    ThrowError("background image must be a non-empty 8-bit BGR image");
  }
  if (width_px < 1 || height_px < 1) {
    ThrowError("background size must be positive, got ", width_px, "x", height_px);
  }
  const double scale = std::max(double(width_px) / image.cols, double(height_px) / image.rows);
  const int scaled_width = std::max(width_px, static_cast<int>(std::ceil(image.cols * scale)));
  const int scaled_height = std::max(height_px, static_cast<int>(std::ceil(image.rows * scale)));
  cv::Mat scaled;
  if (scaled_width == image.cols && scaled_height == image.rows) {
    scaled = image;
  } else {
    cv::resize(image, scaled, cv::Size(scaled_width, scaled_height), 0, 0,
               scale < 1.0 ? cv::INTER_AREA : cv::INTER_LINEAR);
  }
  const cv::Rect crop((scaled_width - width_px) / 2, (scaled_height - height_px) / 2, width_px,
                      height_px);
  return scaled(crop).clone();
}

cv::Mat ReadBackgroundImage(const std::filesystem::path& path) {
  if (!std::filesystem::is_regular_file(path)) {
    ThrowError(path.string(), ": background image not found");
  }
  cv::Mat image = ReadImage(path.string(), cv::IMREAD_COLOR);
  if (image.empty()) {
    ThrowError(path.string(),
               ": cannot decode the background image (not an image format OpenCV "
               "reads?)");
  }
  return image;
}

void ApplyCameraEffects(const ColourOptions& options, int frame, cv::Mat* image) {
  SILPOSE_ASSERT(image != nullptr && image->type() == CV_8UC3);
  if (options.noise_sigma <= 0.0 && options.flicker <= 0.0) return;
  const auto frame_key = static_cast<uint64_t>(frame);
  double gain = 1.0;
  if (options.flicker > 0.0) {
    std::mt19937_64 engine(FrameSeed(options.seed, frame_key, kStreamFlicker));
    gain = 1.0 + options.flicker * Uniform(engine, -1.0, 1.0);
  }
  cv::Mat value;
  image->convertTo(value, CV_32FC3, gain);
  if (options.noise_sigma > 0.0) {
    // OpenCV's generator (multiply-with-carry, Ziggurat normals) is fixed by OpenCV and fast;
    // seeded per frame, like every random choice of the generator.
    cv::RNG random(FrameSeed(options.seed, frame_key, kStreamNoise));
    cv::Mat noise(image->size(), CV_32FC3);
    random.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0.0), cv::Scalar::all(options.noise_sigma));
    value += noise;
  }
  value.convertTo(*image, CV_8UC3);  // rounds and clips to [0, 255]
}

}  // namespace silpose
