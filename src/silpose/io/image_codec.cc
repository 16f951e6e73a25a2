#include "silpose/io/image_codec.h"

#include <dlfcn.h>
#include <jpeglib.h>
// After jpeglib.h: the message codes (JWRN_...).
#include <jerror.h>
#include <link.h>
#include <png.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "silpose/io/image_codec_plugin.h"
#include "silpose/io/image_limits.h"

namespace silpose {
namespace {

// cv::ImreadModes and cv::ImwriteFlags values (opencv2/imgcodecs.hpp), which this file does not
// include so that nothing here can call OpenCV's codecs by accident.
constexpr int kImreadUnchanged = -1;
constexpr int kImreadGrayscale = 0;
constexpr int kImreadColor = 1;
constexpr int kImwriteJpegQuality = 1;
constexpr int kImwritePngCompression = 16;
// Image files larger than this are refused before they are read whole: the largest image the size
// limits allow (image_limits.h), stored uncompressed with 16-bit samples, is smaller.
constexpr uintmax_t kMaxImageFileBytes = uintmax_t{2} << 30;
// Progressive JPEGs with more scans than this are refused: a small file with thousands of tiny
// scans would take minutes to decode. Encoders write about ten.
constexpr int kMaxJpegScans = 500;

[[noreturn]] void Fail(const std::string& reason) {
  cv::error(cv::Error::StsError, reason, "silpose image codec", __FILE__, __LINE__);
  std::abort();  // cv::error throws
}

bool IsPng(std::span<const uint8_t> bytes) {
  static constexpr std::array<uint8_t, 8> kSignature = {0x89, 'P',  'N',  'G',
                                                        '\r', '\n', 0x1A, '\n'};
  return bytes.size() >= kSignature.size() &&
         std::equal(kSignature.begin(), kSignature.end(), bytes.begin());
}

bool IsJpeg(std::span<const uint8_t> bytes) {
  return bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF;
}

bool Handled(int flags) {
  return flags == kImreadUnchanged || flags == kImreadGrayscale || flags == kImreadColor;
}

std::string SizeError(int64_t width, int64_t height) {
  std::string error;
  if (ImageSizeAllowed(width, height, &error)) return {};
  return error;
}

// ---------------------------------------------------------------------------------------------
// OpenCV's codecs, loaded on first use.

std::string PluginCandidates(std::vector<std::string>* paths) {
  std::string list;
  auto add = [&](const std::string& path) {
    if (path.empty() || std::find(paths->begin(), paths->end(), path) != paths->end()) return;
    paths->push_back(path);
    list += (list.empty() ? "" : ", ") + path;
  };
  if (const char* path = std::getenv("SILPOSE_OPENCV_CODECS")) {  // this one and no other
    add(path);
    return list;
  }
  // Beside the code that is running (an installed program or library, relocated as a whole).
  // For code linked into the program dladdr names the program as it was started (argv[0], perhaps
  // a bare name found on PATH): the kernel's link to the executable is used instead. Only absolute
  // paths are tried, never one relative to the working directory.
  std::filesystem::path here;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&PluginCandidates), &info) != 0 && info.dli_fname != nullptr) {
    here = std::filesystem::path(info.dli_fname);
  }
  if (!here.is_absolute()) {
    std::error_code error;
    here = std::filesystem::read_symlink("/proc/self/exe", error);
    if (error) here.clear();
  }
  auto add_absolute = [&](const std::filesystem::path& path) {
    if (path.is_absolute()) add(path.lexically_normal().string());
  };
  if (here.is_absolute()) {
    add_absolute(here.parent_path() / SILPOSE_CODECS_PLUGIN_FROM_BIN);
    add_absolute(here.parent_path() / SILPOSE_CODECS_PLUGIN_FROM_LIB);
  }
  add_absolute(SILPOSE_CODECS_PLUGIN_INSTALLED);
  add_absolute(SILPOSE_CODECS_PLUGIN_BUILT);
  return list;
}

const OpenCvCodecs& Plugin() {
  static const OpenCvCodecs* codecs = nullptr;
  static std::string failure;
  static std::once_flag once;
  std::call_once(once, [] {
    LimitOpenCvDecoders();
    std::vector<std::string> paths;
    const std::string list = PluginCandidates(&paths);
    std::string reasons;
    for (const std::string& path : paths) {
      std::error_code error;
      if (!std::filesystem::exists(path, error)) continue;
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (handle == nullptr) {
        const char* why = dlerror();
        reasons += "; " + path + ": " + (why != nullptr ? why : "cannot be loaded");
        continue;
      }
      using Entry = const OpenCvCodecs* (*)();
      const auto entry = reinterpret_cast<Entry>(dlsym(handle, "silpose_opencv_codecs"));
      const OpenCvCodecs* found = entry != nullptr ? entry() : nullptr;
      if (found == nullptr || found->version != kOpenCvCodecsVersion ||
          found->opencv_version != kOpenCvVersion || found->size != sizeof(OpenCvCodecs)) {
        reasons += "; " + path + ": not this version of silpose's codecs plugin";
        dlclose(handle);
        continue;
      }
      codecs = found;
      return;
    }
    failure =
        "formats other than PNG and JPEG need silpose's OpenCV codecs plugin "
        "(libsilpose_opencv_codecs.so), not found in " +
        list + reasons + " (set SILPOSE_OPENCV_CODECS to its path, or convert the image to PNG)";
  });
  if (codecs == nullptr) Fail(failure);
  return *codecs;
}

cv::Mat PluginRead(const std::filesystem::path& path, int flags) {
  cv::Mat image;
  std::string error;
  if (!Plugin().read(path.c_str(), flags, &image, &error)) Fail(error);
  return image;
}

cv::Mat PluginDecode(std::span<const uint8_t> bytes, int flags) {
  cv::Mat image;
  std::string error;
  if (!Plugin().decode(bytes.data(), bytes.size(), flags, &image, &error)) Fail(error);
  return image;
}

bool PluginEncode(const std::string& extension, const cv::Mat& image, std::vector<uint8_t>* bytes,
                  const std::vector<int>& params) {
  std::string error;
  bool encoded = false;
  if (!Plugin().encode(extension.c_str(), &image, params.data(), params.size(), bytes, &encoded,
                       &error)) {
    Fail(error);
  }
  return encoded;
}

// The orientation (1-8) in TIFF-structured EXIF data (a PNG's eXIf chunk, a JPEG's APP1 after
// its "Exif\0\0" header), or 1. Every read is bounds-checked against the data.
int TiffOrientation(std::span<const uint8_t> tiff) {
  const size_t size = tiff.size();
  if (size < 8) return 1;
  const bool little = tiff[0] == 'I' && tiff[1] == 'I';
  if (!little && !(tiff[0] == 'M' && tiff[1] == 'M')) return 1;
  auto u16 = [&](size_t at) -> uint32_t {
    return little ? uint32_t{tiff[at]} | (uint32_t{tiff[at + 1]} << 8)
                  : (uint32_t{tiff[at]} << 8) | tiff[at + 1];
  };
  auto u32 = [&](size_t at) -> uint32_t {
    return little ? u16(at) | (u16(at + 2) << 16) : (u16(at) << 16) | u16(at + 2);
  };
  const size_t ifd = u32(4);
  if (ifd > size || size - ifd < 2) return 1;
  const size_t entries = u16(ifd);
  const size_t room = (size - ifd - 2) / 12;  // whole entries the data holds
  for (size_t i = 0; i < std::min(entries, room); ++i) {
    const size_t at = ifd + 2 + 12 * i;
    if (u16(at) == 0x0112) {  // Orientation, a SHORT held in the entry itself
      const uint32_t value = u16(at + 8);
      return value >= 1 && value <= 8 ? static_cast<int>(value) : 1;
    }
  }
  return 1;
}

// Turns a decoded image upright as the EXIF orientation says (as cv::imread does).
void ApplyOrientation(int orientation, cv::Mat* image) {
  switch (orientation) {
    case 2:  // mirrored left-right
      cv::flip(*image, *image, 1);
      break;
    case 3:  // upside down
      cv::flip(*image, *image, -1);
      break;
    case 4:  // mirrored top-bottom
      cv::flip(*image, *image, 0);
      break;
    case 5:  // mirrored about the main diagonal
      cv::transpose(*image, *image);
      break;
    case 6:  // turned a quarter anticlockwise: turn it clockwise
      cv::transpose(*image, *image);
      cv::flip(*image, *image, 1);
      break;
    case 7:  // mirrored about the other diagonal
      cv::transpose(*image, *image);
      cv::flip(*image, *image, -1);
      break;
    case 8:  // turned a quarter clockwise: turn it anticlockwise
      cv::transpose(*image, *image);
      cv::flip(*image, *image, 0);
      break;
    default:
      break;
  }
}

// ---------------------------------------------------------------------------------------------
// PNG. libpng reports errors by longjmp: the functions holding setjmp keep only trivially
// destructible locals, and everything with a destructor lives in the caller's frame.

struct PngJob {
  std::span<const uint8_t> bytes;
  size_t offset = 0;
  std::vector<uint8_t>* out = nullptr;
  char error[200] = {};
  int64_t width = 0, height = 0;  // of an image beyond the size limits
  int orientation = 1;            // from an eXIf chunk
};

void PngError(png_structp png, png_const_charp message) {
  auto* job = static_cast<PngJob*>(png_get_error_ptr(png));
  std::snprintf(job->error, sizeof(job->error), "%s", message);
  png_longjmp(png, 1);
}

void PngWarning(png_structp, png_const_charp) {}  // not printed: silpose reports what matters

void PngRead(png_structp png, png_bytep data, png_size_t length) {
  auto* job = static_cast<PngJob*>(png_get_io_ptr(png));
  if (length > job->bytes.size() - job->offset) png_error(png, "the data ends early (truncated)");
  std::memcpy(data, job->bytes.data() + job->offset, length);
  job->offset += length;
}

// Fills *image; false with job->error set if libpng fails.
bool DecodePngInto(PngJob* job, int flags, cv::Mat* image, std::vector<png_bytep>* rows) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, job, PngError, PngWarning);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_set_read_fn(png, job, PngRead);
#ifdef PNG_IGNORE_ADLER32
  // Each chunk's CRC already guards the compressed data; zlib's second checksum over the
  // decompressed rows costs a tenth of the decoding.
  png_set_option(png, PNG_IGNORE_ADLER32, PNG_OPTION_ON);
#endif
  png_read_info(png, info);
  const png_uint_32 width = png_get_image_width(png, info);
  const png_uint_32 height = png_get_image_height(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  const int color_type = png_get_color_type(png, info);
  if (!ImageSizeAllowed(width, height)) {
    job->width = width;
    job->height = height;
    png_error(png, "too large");
  }

  // The channels cv::imread gives: colour with alpha or a transparency chunk and grey with alpha
  // are BGRA; colour is BGR; grey is grey.
  const bool colour = (color_type & PNG_COLOR_MASK_COLOR) != 0;
  const bool transparency = png_get_valid(png, info, PNG_INFO_tRNS) != 0;
  int channels = 1;
  if (flags == kImreadColor) {
    channels = 3;
  } else if (flags == kImreadUnchanged) {
    if (color_type == PNG_COLOR_TYPE_GRAY_ALPHA || color_type == PNG_COLOR_TYPE_RGB_ALPHA ||
        (colour && transparency)) {
      channels = 4;
    } else if (colour) {
      channels = 3;
    }
  }
  const bool sixteen = bit_depth == 16 && flags == kImreadUnchanged;
  if (bit_depth == 16) {
    if (sixteen) {
      if constexpr (std::endian::native == std::endian::little) png_set_swap(png);
    } else {
      png_set_strip_16(png);
    }
  }
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (!colour && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (channels == 4) {
    if (transparency) png_set_tRNS_to_alpha(png);
  } else {
    png_set_strip_alpha(png);
  }
  if (colour && channels >= 3) {
    png_set_bgr(png);
  } else if (channels >= 3) {
    png_set_gray_to_rgb(png);
  } else if (colour) {
    png_set_rgb_to_gray_fixed(png, 1, 29900, 58700);  // 0.299 R + 0.587 G + 0.114 B
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const int type = CV_MAKETYPE(sixteen ? CV_16U : CV_8U, channels);
  const size_t row_bytes = static_cast<size_t>(width) * channels * (sixteen ? 2 : 1);
  if (png_get_rowbytes(png, info) != row_bytes) png_error(png, "unexpected row layout");
  try {  // out of memory: release libpng's state before the exception leaves
    image->create(static_cast<int>(height), static_cast<int>(width), type);
    rows->resize(height);
  } catch (...) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw;
  }
  for (png_uint_32 y = 0; y < height; ++y) (*rows)[y] = image->ptr<uint8_t>(static_cast<int>(y));
  png_read_image(png, rows->data());
  png_read_end(png, info);  // an eXIf chunk may follow the image data
  job->orientation = 1;
#ifdef PNG_eXIf_SUPPORTED
  png_uint_32 exif_size = 0;
  png_bytep exif = nullptr;
  if (flags != kImreadUnchanged && png_get_valid(png, info, PNG_INFO_eXIf) != 0 &&
      png_get_eXIf_1(png, info, &exif_size, &exif) != 0 && exif != nullptr) {
    job->orientation = TiffOrientation(std::span<const uint8_t>(exif, exif_size));
  }
#endif
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

cv::Mat DecodePng(std::span<const uint8_t> bytes, int flags) {
  if (bytes.size() >= 24 && std::memcmp(bytes.data() + 12, "IHDR", 4) == 0) {
    // Refused before libpng reads further: the first chunk is the header, with the size.
    auto be32 = [&](size_t at) {
      return (int64_t{bytes[at]} << 24) | (int64_t{bytes[at + 1]} << 16) |
             (int64_t{bytes[at + 2]} << 8) | int64_t{bytes[at + 3]};
    };
    const std::string size_error = SizeError(be32(16), be32(20));
    if (!size_error.empty()) Fail(size_error);
  }
  PngJob job;
  job.bytes = bytes;
  cv::Mat image;
  std::vector<png_bytep> rows;
  if (!DecodePngInto(&job, flags, &image, &rows)) {
    if (job.width > 0) Fail(SizeError(job.width, job.height));
    Fail(std::string("PNG: ") + (job.error[0] != '\0' ? job.error : "cannot decode"));
  }
  ApplyOrientation(job.orientation, &image);
  return image;
}

void PngWrite(png_structp png, png_bytep data, png_size_t length) {
  auto* job = static_cast<PngJob*>(png_get_io_ptr(png));
  bool out_of_memory = false;
  try {  // no exception may cross libpng's frames
    job->out->insert(job->out->end(), data, data + length);
  } catch (...) {
    out_of_memory = true;
  }
  if (out_of_memory) png_error(png, "out of memory");
}

void PngFlush(png_structp) {}

bool EncodePngInto(PngJob* job, const cv::Mat* image, int level, int strategy,
                   const std::vector<png_bytep>* rows) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, job, PngError, PngWarning);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, job, PngWrite, PngFlush);
  const int channels = image->channels();
  const int colour_type = channels == 1   ? PNG_COLOR_TYPE_GRAY
                          : channels == 3 ? PNG_COLOR_TYPE_RGB
                                          : PNG_COLOR_TYPE_RGB_ALPHA;
  const int bit_depth = image->depth() == CV_16U ? 16 : 8;
  if (level >= 0) {
    png_set_compression_level(png, level);
  } else {
    // The default favours speed, as cv::imwrite's does: one cheap filter, fastest deflate.
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_compression_level(png, 1);
  }
  png_set_compression_strategy(png, strategy);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image->cols),
               static_cast<png_uint_32>(image->rows), bit_depth, colour_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bit_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
  if (channels >= 3) png_set_bgr(png);
  png_write_image(png, const_cast<png_bytepp>(rows->data()));
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

// level -1: cv::imwrite's default (fastest, run-length strategy); 0-9: zlib's level with its
// default strategy, as cv::imwrite does when IMWRITE_PNG_COMPRESSION is given.
void EncodePng(const cv::Mat& image, std::vector<uint8_t>* bytes, int level) {
  PngJob job;
  job.out = bytes;
  bytes->clear();
  std::vector<png_bytep> rows(static_cast<size_t>(image.rows));
  for (int y = 0; y < image.rows; ++y)
    rows[static_cast<size_t>(y)] = const_cast<uint8_t*>(image.ptr<uint8_t>(y));
  constexpr int kZlibDefaultStrategy = 0;
  constexpr int kZlibRle = 3;  // runs, as in masks and flat frames
  if (!EncodePngInto(&job, &image, level, level >= 0 ? kZlibDefaultStrategy : kZlibRle, &rows)) {
    bytes->clear();
    Fail(std::string("PNG: ") + (job.error[0] != '\0' ? job.error : "cannot encode"));
  }
}

// ---------------------------------------------------------------------------------------------
// JPEG. libjpeg reports errors through error_exit, which longjmps back as libpng's does.

struct JpegError {
  jpeg_error_mgr manager;
  std::jmp_buf jump;
  char error[JMSG_LENGTH_MAX + 8] = {};
  int64_t width = 0, height = 0;  // of an image beyond the size limits
  jpeg_progress_mgr progress;     // counts a progressive file's scans
};

void JpegExit(j_common_ptr info) {
  auto* error = reinterpret_cast<JpegError*>(info->err);
  char message[JMSG_LENGTH_MAX] = {};
  (*info->err->format_message)(info, message);
  std::snprintf(error->error, sizeof(error->error), "%s", message);
  std::longjmp(error->jump, 1);
}

// Warnings are not printed. Those that mean the image data ended before the image did (libjpeg
// fills the rest with grey) are errors: a truncated file or camera frame is not a good image.
void JpegMessage(j_common_ptr info, int level) {
  if (level >= 0) return;  // trace messages
  const int code = info->err->msg_code;
  if (code == JWRN_JPEG_EOF || code == JWRN_HIT_MARKER) (*info->err->error_exit)(info);
}

void JpegProgress(j_common_ptr info) {
  if (info->is_decompressor == 0) return;
  const auto* decompress = reinterpret_cast<j_decompress_ptr>(info);
  if (decompress->input_scan_number > kMaxJpegScans) {
    auto* error = reinterpret_cast<JpegError*>(info->err);
    std::snprintf(error->error, sizeof(error->error),
                  "more than %d scans (a progressive file built to decode slowly)", kMaxJpegScans);
    std::longjmp(error->jump, 1);
  }
}

// The EXIF orientation (1-8) from the first APP1 marker, as cv::imread reads it, or 1.
int ExifOrientation(const jpeg_decompress_struct& info) {
  for (jpeg_saved_marker_ptr marker = info.marker_list; marker != nullptr; marker = marker->next) {
    if (marker->marker != JPEG_APP0 + 1) continue;
    const std::span<const uint8_t> data(marker->data, marker->data_length);
    if (data.size() < 6 || std::memcmp(data.data(), "Exif\0\0", 6) != 0) return 1;
    return TiffOrientation(data.subspan(6));
  }
  return 1;
}

enum class JpegOutcome { kDecoded, kError, kNotHandled };

JpegOutcome DecodeJpegInto(std::span<const uint8_t> bytes, int flags, JpegError* error,
                           cv::Mat* image, int* orientation) {
  jpeg_decompress_struct info{};
  info.err = jpeg_std_error(&error->manager);
  error->manager.error_exit = JpegExit;
  error->manager.emit_message = JpegMessage;
  if (setjmp(error->jump)) {
    jpeg_destroy_decompress(&info);
    return JpegOutcome::kError;
  }
  jpeg_create_decompress(&info);
  error->progress.progress_monitor = JpegProgress;
  info.progress = &error->progress;
  jpeg_mem_src(&info, bytes.data(), static_cast<unsigned long>(bytes.size()));
  if (flags != kImreadUnchanged) jpeg_save_markers(&info, JPEG_APP0 + 1, 0xFFFF);
  jpeg_read_header(&info, TRUE);
  if (!ImageSizeAllowed(info.image_width, info.image_height)) {
    error->width = info.image_width;
    error->height = info.image_height;
    jpeg_destroy_decompress(&info);
    return JpegOutcome::kError;
  }
  if (info.num_components != 1 && info.num_components != 3) {  // CMYK, YCCK: OpenCV's codecs
    jpeg_destroy_decompress(&info);
    return JpegOutcome::kNotHandled;
  }
  const bool grey =
      flags == kImreadGrayscale || (flags == kImreadUnchanged && info.num_components == 1);
  info.out_color_space = grey ? JCS_GRAYSCALE : JCS_EXT_BGR;
  *orientation = flags == kImreadUnchanged ? 1 : ExifOrientation(info);
  jpeg_calc_output_dimensions(&info);
  try {  // allocated before libjpeg's own buffers; out of memory: nothing of libjpeg's to leak
    image->create(static_cast<int>(info.output_height), static_cast<int>(info.output_width),
                  grey ? CV_8UC1 : CV_8UC3);
  } catch (...) {
    jpeg_destroy_decompress(&info);
    throw;
  }
  jpeg_start_decompress(&info);
  while (info.output_scanline < info.output_height) {
    JSAMPROW row = image->ptr<uint8_t>(static_cast<int>(info.output_scanline));
    jpeg_read_scanlines(&info, &row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return JpegOutcome::kDecoded;
}

cv::Mat DecodeJpeg(std::span<const uint8_t> bytes, int flags) {
  if (bytes.size() > std::numeric_limits<unsigned long>::max()) Fail("JPEG: too large");
  JpegError error;
  cv::Mat image;
  int orientation = 1;
  switch (DecodeJpegInto(bytes, flags, &error, &image, &orientation)) {
    case JpegOutcome::kNotHandled:
      return PluginDecode(bytes, flags);
    case JpegOutcome::kError:
      if (error.width > 0) Fail(SizeError(error.width, error.height));
      Fail(std::string("JPEG: ") + (error.error[0] != '\0' ? error.error : "cannot decode"));
    case JpegOutcome::kDecoded:
      break;
  }
  ApplyOrientation(orientation, &image);
  return image;
}

// libjpeg's output, collected in a vector. (jpeg_mem_dest reallocates its buffer itself and
// reports the new one only when the compression finishes, so an error in between loses track of
// it.) Out of memory becomes libjpeg's error.
struct JpegDestination {
  jpeg_destination_mgr manager;
  std::vector<uint8_t>* out = nullptr;
  std::array<JOCTET, 1 << 16> buffer;
};

bool Append(JpegDestination* destination, size_t count) {
  try {  // no exception may cross libjpeg's frames
    destination->out->insert(destination->out->end(), destination->buffer.begin(),
                             destination->buffer.begin() + static_cast<std::ptrdiff_t>(count));
    return true;
  } catch (...) {
    return false;
  }
}

void JpegOutOfMemory(j_common_ptr info) {
  auto* error = reinterpret_cast<JpegError*>(info->err);
  std::snprintf(error->error, sizeof(error->error), "out of memory");
  std::longjmp(error->jump, 1);
}

void JpegDestinationStart(j_compress_ptr info) {
  auto* destination = reinterpret_cast<JpegDestination*>(info->dest);
  destination->manager.next_output_byte = destination->buffer.data();
  destination->manager.free_in_buffer = destination->buffer.size();
}

boolean JpegDestinationFull(j_compress_ptr info) {
  auto* destination = reinterpret_cast<JpegDestination*>(info->dest);
  if (!Append(destination, destination->buffer.size())) {
    JpegOutOfMemory(reinterpret_cast<j_common_ptr>(info));
  }
  JpegDestinationStart(info);
  return TRUE;
}

void JpegDestinationEnd(j_compress_ptr info) {
  auto* destination = reinterpret_cast<JpegDestination*>(info->dest);
  if (!Append(destination, destination->buffer.size() - destination->manager.free_in_buffer)) {
    JpegOutOfMemory(reinterpret_cast<j_common_ptr>(info));
  }
}

bool EncodeJpegInto(const cv::Mat* image, int quality, JpegError* error,
                    JpegDestination* destination) {
  jpeg_compress_struct info{};
  info.err = jpeg_std_error(&error->manager);
  error->manager.error_exit = JpegExit;
  error->manager.emit_message = JpegMessage;
  if (setjmp(error->jump)) {
    jpeg_destroy_compress(&info);
    return false;
  }
  jpeg_create_compress(&info);
  destination->manager.init_destination = JpegDestinationStart;
  destination->manager.empty_output_buffer = JpegDestinationFull;
  destination->manager.term_destination = JpegDestinationEnd;
  info.dest = &destination->manager;
  info.image_width = static_cast<JDIMENSION>(image->cols);
  info.image_height = static_cast<JDIMENSION>(image->rows);
  const bool grey = image->channels() == 1;
  info.input_components = grey ? 1 : 3;
  info.in_color_space = grey ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, quality, TRUE);
  jpeg_start_compress(&info, TRUE);
  while (info.next_scanline < info.image_height) {
    auto row = const_cast<JSAMPROW>(image->ptr<uint8_t>(static_cast<int>(info.next_scanline)));
    jpeg_write_scanlines(&info, &row, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  return true;
}

void EncodeJpeg(const cv::Mat& image, std::vector<uint8_t>* bytes, int quality) {
  JpegError error;
  auto destination = std::make_unique<JpegDestination>();
  destination->out = bytes;
  bytes->clear();
  if (!EncodeJpegInto(&image, quality, &error, destination.get())) {
    bytes->clear();
    Fail(std::string("JPEG: ") + (error.error[0] != '\0' ? error.error : "cannot encode"));
  }
}

// The value of the last `key` in OpenCV's (key, value) list, or `fallback`.
int Param(const std::vector<int>& params, int key, int fallback) {
  int value = fallback;
  for (size_t i = 0; i + 1 < params.size(); i += 2) {
    if (params[i] == key) value = params[i + 1];
  }
  return value;
}

// True if every key of the list is `allowed`: other settings are OpenCV's codecs' to apply.
bool OnlyKey(const std::vector<int>& params, int allowed) {
  for (size_t i = 0; i < params.size(); i += 2) {
    if (params[i] != allowed) return false;
  }
  return true;
}

std::string Lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

}  // namespace

cv::Mat DecodeImage(std::span<const uint8_t> bytes, int flags) {
  if (bytes.empty()) return {};
  if (Handled(flags)) {
    if (IsPng(bytes)) return DecodePng(bytes, flags);
    if (IsJpeg(bytes)) return DecodeJpeg(bytes, flags);
  }
  return PluginDecode(bytes, flags);
}

cv::Mat ReadImage(const std::filesystem::path& path, int flags) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return {};
  std::array<uint8_t, 8> head{};
  file.read(reinterpret_cast<char*>(head.data()), head.size());
  const std::span<const uint8_t> start(head.data(), static_cast<size_t>(file.gcount()));
  if (start.empty()) return {};
  if (!Handled(flags) || !(IsPng(start) || IsJpeg(start))) return PluginRead(path, flags);
  std::error_code error;
  const auto size = std::filesystem::file_size(path, error);
  if (error) return {};
  if (size > kMaxImageFileBytes) {
    Fail("image file of " + std::to_string(size >> 20) + " MiB: more than an image within the " +
         "size limits can need (" + std::to_string(kMaxImageFileBytes >> 20) + " MiB)");
  }
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  file.seekg(0);
  file.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  bytes.resize(static_cast<size_t>(file.gcount()));
  return DecodeImage(bytes, flags);
}

bool EncodeImage(const std::string& extension, const cv::Mat& image, std::vector<uint8_t>* bytes,
                 const std::vector<int>& params) {
  const std::string format = Lower(extension);
  if (params.size() % 2 != 0) {
    Fail("image encoding parameters must be (key, value) pairs: " + std::to_string(params.size()) +
         " values given");
  }
  if (image.empty() || image.dims != 2) return PluginEncode(extension, image, bytes, params);
  const int depth = image.depth();
  const int channels = image.channels();
  if (format == ".png" && (depth == CV_8U || depth == CV_16U) &&
      (channels == 1 || channels == 3 || channels == 4) &&
      OnlyKey(params, kImwritePngCompression)) {
    // A level given: clamped to zlib's 0-9, as cv::imwrite does; none: the fast default.
    const int level = Param(params, kImwritePngCompression, -1);
    EncodePng(image, bytes, params.empty() ? -1 : std::clamp(level, 0, 9));
    return true;
  }
  if ((format == ".jpg" || format == ".jpeg" || format == ".jpe") && depth == CV_8U &&
      (channels == 1 || channels == 3 || channels == 4) && OnlyKey(params, kImwriteJpegQuality)) {
    const int quality = std::clamp(Param(params, kImwriteJpegQuality, 95), 0, 100);
    if (channels == 4) {
      cv::Mat bgr;
      cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
      EncodeJpeg(bgr, bytes, quality);
    } else {
      EncodeJpeg(image, bytes, quality);
    }
    return true;
  }
  return PluginEncode(extension, image, bytes, params);
}

bool WriteImage(const std::filesystem::path& path, const cv::Mat& image,
                const std::vector<int>& params) {
  std::vector<uint8_t> bytes;
  if (!EncodeImage(path.extension().string(), image, &bytes, params)) return false;
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) return false;
  file.write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  file.close();
  if (!file) {
    // Disk full or a write error: no truncated image is left behind to be read as a good one.
    std::error_code error;
    if (std::filesystem::is_regular_file(path, error)) std::filesystem::remove(path, error);
    return false;
  }
  return true;
}

bool OpenCvImageCodecsLoaded() {
  bool loaded = false;
  dl_iterate_phdr(
      [](dl_phdr_info* info, size_t, void* found) {
        if (info->dlpi_name != nullptr &&
            std::strstr(info->dlpi_name, "libopencv_imgcodecs") != nullptr) {
          *static_cast<bool*>(found) = true;
        }
        return 0;
      },
      &loaded);
  return loaded;
}

}  // namespace silpose
