#include "silpose/io/image_limits.h"

#include <array>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

uint32_t Be16(const unsigned char* p) { return (uint32_t{p[0]} << 8) | p[1]; }
uint32_t Be32(const unsigned char* p) { return (Be16(p) << 16) | Be16(p + 2); }
uint32_t Le32(const unsigned char* p) {
  return uint32_t{p[0]} | (uint32_t{p[1]} << 8) | (uint32_t{p[2]} << 16) | (uint32_t{p[3]} << 24);
}

// Width and height from a JPEG's first SOF marker; false if not found in the first bytes.
bool JpegSize(std::ifstream& file, int64_t* width, int64_t* height) {
  std::vector<unsigned char> data(1 << 20);
  file.seekg(0);
  file.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size()));
  const auto size = static_cast<size_t>(file.gcount());
  size_t i = 2;
  while (i + 9 < size) {
    if (data[i] != 0xFF) return false;
    const unsigned char marker = data[i + 1];
    if (marker == 0xFF) {
      ++i;
      continue;
    }
    const uint32_t length = Be16(&data[i + 2]);
    const bool sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      *height = Be16(&data[i + 5]);
      *width = Be16(&data[i + 7]);
      return true;
    }
    i += 2 + length;
  }
  return false;
}

// A PNG is a signature and chunks (length, type, data, CRC) up to IEND: one that ends before is
// truncated, and libpng would print its own error before silpose's message.
void CheckPngChunks(const std::filesystem::path& path, std::ifstream& file) {
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  if (error) return;
  uint64_t position = 8;
  while (position + 8 <= size) {
    std::array<unsigned char, 8> chunk{};
    file.clear();
    file.seekg(static_cast<std::streamoff>(position));
    file.read(reinterpret_cast<char*>(chunk.data()), chunk.size());
    if (file.gcount() != 8) break;
    if (chunk[4] == 'I' && chunk[5] == 'E' && chunk[6] == 'N' && chunk[7] == 'D') return;
    position += 12 + uint64_t{Be32(chunk.data())};
  }
  ThrowError(path.string(), ": truncated PNG file (", size,
             " bytes; it ends before its last chunk, IEND)");
}

}  // namespace

bool ImageSizeAllowed(int64_t width, int64_t height, std::string* error) {
  if (width <= kMaxImageSide && height <= kMaxImageSide && width * height <= kMaxImagePixels) {
    return true;
  }
  if (error != nullptr) {
    std::ostringstream text;
    text << "the image is " << width << "x" << height << " pixels, beyond silpose's limit of "
         << kMaxImagePixels << " pixels (" << kMaxImageSide << " a side); scale it down first";
    *error = text.str();
  }
  return false;
}

void LimitOpenCvDecoders() {
  static const bool once = [] {
    ::setenv("OPENCV_IO_MAX_IMAGE_PIXELS", std::to_string(kMaxImagePixels).c_str(), 0);
    return true;
  }();
  (void)once;
}

void CheckImageSize(const std::string& name, int64_t width, int64_t height) {
  std::string problem;
  if (!ImageSizeAllowed(width, height, &problem)) ThrowError(name, ": ", problem);
}

void CheckImageFileSize(const std::filesystem::path& path) {
  LimitOpenCvDecoders();
  std::ifstream file(path, std::ios::binary);
  if (!file) return;
  std::array<unsigned char, 32> head{};
  file.read(reinterpret_cast<char*>(head.data()), head.size());
  if (file.gcount() < 26) return;
  int64_t width = 0;
  int64_t height = 0;
  if (head[0] == 0x89 && head[1] == 'P' && head[2] == 'N' && head[3] == 'G') {
    width = Be32(&head[16]);
    height = Be32(&head[20]);
    CheckImageSize(path.string(), width, height);
    CheckPngChunks(path, file);
    return;
  } else if (head[0] == 0xFF && head[1] == 0xD8) {
    file.clear();
    if (!JpegSize(file, &width, &height)) return;
  } else if (head[0] == 'B' && head[1] == 'M') {
    width = static_cast<int32_t>(Le32(&head[18]));
    height = static_cast<int32_t>(Le32(&head[22]));
    if (height < 0) height = -height;
  } else {
    return;
  }
  CheckImageSize(path.string(), width, height);
}

}  // namespace silpose
