#pragma once
// The largest images silpose reads (docs/limits.md, "Image size"): frames, masks and background
// images of at most kMaxImageSide pixels a side and kMaxImagePixels pixels in all. Larger ones are
// refused with one message before their pixels are decoded (PNG, JPEG, BMP and AVI headers are
// read first; other formats are refused by OpenCV's own pixel limit, set to the same bound).

#include <cstdint>
#include <filesystem>
#include <string>

namespace silpose {

inline constexpr int kMaxImageSide = 32768;
inline constexpr int64_t kMaxImagePixels = 100'000'000;  // e.g. 10000 x 10000

/// True if a width x height image is within the limits; otherwise `error` says why.
bool ImageSizeAllowed(int64_t width, int64_t height, std::string* error = nullptr);

/// Throws silpose::Error naming `name` if a width x height image is beyond the limits.
void CheckImageSize(const std::string& name, int64_t width, int64_t height);

/// Reads the size from the header of a PNG, JPEG or BMP file (nothing else is decoded) and checks
/// it (CheckImageSize); a PNG whose chunks end before IEND is refused as truncated. Other formats
/// and unreadable headers pass: the decoder reports those.
/// Also makes OpenCV's decoders refuse images beyond kMaxImagePixels.
void CheckImageFileSize(const std::filesystem::path& path);

/// OpenCV's decoders read OPENCV_IO_MAX_IMAGE_PIXELS the first time they run: sets it to
/// kMaxImagePixels unless the user set it. Called before any image is decoded through OpenCV;
/// setenv is not safe while other threads read the environment, so a multi-threaded program calls
/// it once at its start (the silpose command does).
void LimitOpenCvDecoders();

}  // namespace silpose
