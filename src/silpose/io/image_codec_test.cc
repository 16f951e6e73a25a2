// silpose's PNG and JPEG codecs against OpenCV's (which this test links): the same images from
// the same bytes for every PNG colour type and bit depth, every read mode and every EXIF
// orientation; what they write is read back unchanged (PNG) or close (JPEG); other formats go
// through OpenCV's codecs plugin.

#include "silpose/io/image_codec.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>
// clang-format off
#include <cstdio>  // before jpeglib.h, which needs FILE
#include <jpeglib.h>
// clang-format on
#include <zlib.h>

#include <algorithm>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "silpose/io/image_limits.h"

namespace silpose {
namespace {

using Bytes = std::vector<uint8_t>;

void PutBe32(Bytes* out, uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<uint8_t>(value >> shift));
}

void PutChunk(Bytes* out, const char* type, const Bytes& data) {
  PutBe32(out, static_cast<uint32_t>(data.size()));
  Bytes body(type, type + 4);
  body.insert(body.end(), data.begin(), data.end());
  out->insert(out->end(), body.begin(), body.end());
  PutBe32(out, static_cast<uint32_t>(crc32(0, body.data(), static_cast<uInt>(body.size()))));
}

int SamplesPerPixel(int colour_type) {
  switch (colour_type) {
    case 2:
      return 3;
    case 4:
      return 2;
    case 6:
      return 4;
    default:
      return 1;  // grey, palette
  }
}

// A PNG written here from the format's definition (not by libpng): random pixels, unfiltered
// rows, a palette of 2^depth random colours for colour type 3, optionally a transparency chunk,
// optionally interlaced (Adam7: seven passes over sub-images, each its own rows).
Bytes MakePng(int width, int height, int depth, int colour_type, bool transparency,
              std::mt19937* random, bool interlaced = false) {
  Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  Bytes header;
  PutBe32(&header, static_cast<uint32_t>(width));
  PutBe32(&header, static_cast<uint32_t>(height));
  header.insert(header.end(), {static_cast<uint8_t>(depth), static_cast<uint8_t>(colour_type), 0, 0,
                               static_cast<uint8_t>(interlaced ? 1 : 0)});
  PutChunk(&png, "IHDR", header);
  std::uniform_int_distribution<int> byte(0, 255);
  if (colour_type == 3) {
    Bytes palette;
    for (int i = 0; i < (1 << depth) * 3; ++i)
      palette.push_back(static_cast<uint8_t>(byte(*random)));
    PutChunk(&png, "PLTE", palette);
    if (transparency) {
      Bytes alpha;
      for (int i = 0; i < (1 << depth); ++i) alpha.push_back(static_cast<uint8_t>(byte(*random)));
      PutChunk(&png, "tRNS", alpha);
    }
  } else if (transparency) {
    Bytes key;  // one grey level or one RGB colour is transparent
    const auto level = static_cast<uint8_t>((1 << std::min(depth, 3)) - 1);
    for (int i = 0; i < (colour_type == 0 ? 1 : 3); ++i) key.insert(key.end(), {0, level});
    PutChunk(&png, "tRNS", key);
  }
  struct Pass {
    int x0, y0, dx, dy;
  };
  const std::vector<Pass> passes =
      interlaced ? std::vector<Pass>{{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                                     {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}}
                 : std::vector<Pass>{{0, 0, 1, 1}};
  Bytes raw;
  for (const Pass& pass : passes) {
    const int pass_width = width > pass.x0 ? (width - pass.x0 + pass.dx - 1) / pass.dx : 0;
    const int pass_height = height > pass.y0 ? (height - pass.y0 + pass.dy - 1) / pass.dy : 0;
    if (pass_width == 0 || pass_height == 0) continue;  // an empty pass has no rows
    const size_t row_bytes = (static_cast<size_t>(pass_width) * SamplesPerPixel(colour_type) *
                                  static_cast<size_t>(depth) +
                              7) /
                             8;
    for (int y = 0; y < pass_height; ++y) {
      raw.push_back(0);  // filter: none
      for (size_t i = 0; i < row_bytes; ++i) {
        // Some pixels take the transparent key's value so that the key matters.
        raw.push_back(static_cast<uint8_t>(i % 5 == 0 ? 7 : byte(*random)));
      }
    }
  }
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  Bytes compressed(size);
  EXPECT_EQ(compress(compressed.data(), &size, raw.data(), static_cast<uLong>(raw.size())), Z_OK);
  compressed.resize(size);
  PutChunk(&png, "IDAT", compressed);
  PutChunk(&png, "IEND", {});
  return png;
}

void ExpectSameImage(const cv::Mat& ours, const cv::Mat& opencv, const std::string& what) {
  ASSERT_FALSE(opencv.empty()) << what;
  ASSERT_EQ(ours.type(), opencv.type()) << what;
  ASSERT_EQ(ours.size(), opencv.size()) << what;
  EXPECT_EQ(cv::norm(ours, opencv, cv::NORM_INF), 0.0) << what;
}

constexpr int kModes[] = {cv::IMREAD_UNCHANGED, cv::IMREAD_GRAYSCALE, cv::IMREAD_COLOR};

TEST(ImageCodec, EveryPngColourTypeDepthAndInterlaceDecodesAsOpenCvDecodesIt) {
  struct Format {
    int colour_type;
    std::vector<int> depths;
  };
  const std::vector<Format> formats = {
      {0, {1, 2, 4, 8, 16}}, {2, {8, 16}}, {3, {1, 2, 4, 8}}, {4, {8, 16}}, {6, {8, 16}}};
  std::mt19937 random(5);
  int checked = 0;
  for (const Format& format : formats) {
    for (const int depth : format.depths) {
      for (const bool transparency : {false, true}) {
        if (transparency && (format.colour_type == 4 || format.colour_type == 6)) continue;
        for (const bool interlaced : {false, true}) {
          const Bytes png =
              MakePng(13, 7, depth, format.colour_type, transparency, &random, interlaced);
          for (const int mode : kModes) {
            const std::string what =
                "colour type " + std::to_string(format.colour_type) + ", depth " +
                std::to_string(depth) + (transparency ? ", tRNS" : "") +
                (interlaced ? ", interlaced" : "") + ", mode " + std::to_string(mode);
            ExpectSameImage(DecodeImage(png, mode), cv::imdecode(png, mode), what);
            ++checked;
          }
        }
      }
    }
  }
  EXPECT_EQ(checked, 2 * 3 * (2 * (5 + 2 + 4 + 2 + 2) - 4));
}

TEST(ImageCodec, PngWrittenIsReadBackUnchangedInEveryDepthAndChannelCount) {
  std::mt19937 random(7);
  for (const int depth : {CV_8U, CV_16U}) {
    for (const int channels : {1, 3, 4}) {
      cv::Mat image(11, 17, CV_MAKETYPE(depth, channels));
      cv::randu(image, 0, depth == CV_8U ? 256 : 65536);
      Bytes bytes;
      ASSERT_TRUE(EncodeImage(".png", image, &bytes));
      const std::string what = "depth " + std::to_string(depth) + ", " + std::to_string(channels);
      ExpectSameImage(cv::imdecode(bytes, cv::IMREAD_UNCHANGED), image, what + " (OpenCV reads)");
      ExpectSameImage(DecodeImage(bytes, cv::IMREAD_UNCHANGED), image, what + " (silpose reads)");
    }
  }
  // The compression level is honoured: a smooth image packs smaller at 9 than at 0.
  cv::Mat ramp(64, 64, CV_8UC1);
  for (int y = 0; y < ramp.rows; ++y) ramp.row(y).setTo(y);
  Bytes fast, small;
  ASSERT_TRUE(EncodeImage(".PNG", ramp, &fast, {cv::IMWRITE_PNG_COMPRESSION, 0}));
  ASSERT_TRUE(EncodeImage(".png", ramp, &small, {cv::IMWRITE_PNG_COMPRESSION, 9}));
  EXPECT_LT(small.size() * 4, fast.size());
  ExpectSameImage(DecodeImage(fast, cv::IMREAD_UNCHANGED), ramp, "level 0");
}

cv::Mat SmoothColourImage(int rows, int cols) {
  cv::Mat image(rows, cols, CV_8UC3);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      image.at<cv::Vec3b>(y, x) = {static_cast<uint8_t>(4 * x), static_cast<uint8_t>(3 * y),
                                   static_cast<uint8_t>(2 * (x + y))};
    }
  }
  return image;
}

TEST(ImageCodec, JpegDecodesAsOpenCvDecodesItAndEncodesCloseToTheImage) {
  const cv::Mat colour = SmoothColourImage(40, 56);
  cv::Mat grey;
  cv::cvtColor(colour, grey, cv::COLOR_BGR2GRAY);
  for (const cv::Mat& image : {colour, grey}) {
    for (const int progressive : {0, 1}) {
      Bytes opencv_bytes;
      ASSERT_TRUE(
          cv::imencode(".jpg", image, opencv_bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, progressive}));
      for (const int mode : kModes) {
        ExpectSameImage(DecodeImage(opencv_bytes, mode), cv::imdecode(opencv_bytes, mode),
                        std::to_string(image.channels()) + " channels, progressive " +
                            std::to_string(progressive) + ", mode " + std::to_string(mode));
      }
    }
    Bytes ours;
    ASSERT_TRUE(EncodeImage(".jpeg", image, &ours, {cv::IMWRITE_JPEG_QUALITY, 90}));
    const cv::Mat back = cv::imdecode(ours, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(back.type(), image.type());
    EXPECT_GT(cv::PSNR(back, image), 30.0);
    Bytes coarse;
    ASSERT_TRUE(EncodeImage(".jpg", image, &coarse, {cv::IMWRITE_JPEG_QUALITY, 20}));
    EXPECT_LT(coarse.size(), ours.size());
    EXPECT_LT(cv::PSNR(cv::imdecode(coarse, cv::IMREAD_UNCHANGED), image), cv::PSNR(back, image));
  }
  // BGRA is written as BGR, as OpenCV does.
  cv::Mat bgra;
  cv::cvtColor(colour, bgra, cv::COLOR_BGR2BGRA);
  Bytes bytes;
  ASSERT_TRUE(EncodeImage(".jpg", bgra, &bytes));
  EXPECT_EQ(DecodeImage(bytes, cv::IMREAD_UNCHANGED).type(), CV_8UC3);
}

// EXIF data in TIFF form (as a PNG's eXIf chunk holds it) whose orientation tag says
// `orientation`: one directory with one entry, in either byte order.
Bytes TiffWithOrientation(int orientation, bool little_endian) {
  Bytes tiff;
  auto u16 = [&](uint32_t v) {
    if (little_endian) {
      tiff.insert(tiff.end(), {static_cast<uint8_t>(v), static_cast<uint8_t>(v >> 8)});
    } else {
      tiff.insert(tiff.end(), {static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v)});
    }
  };
  auto u32 = [&](uint32_t v) {
    if (little_endian) {
      u16(v & 0xFFFF);
      u16(v >> 16);
    } else {
      u16(v >> 16);
      u16(v & 0xFFFF);
    }
  };
  tiff.insert(tiff.end(), little_endian ? std::initializer_list<uint8_t>{'I', 'I'}
                                        : std::initializer_list<uint8_t>{'M', 'M'});
  u16(42);
  u32(8);  // first directory right after the header
  u16(1);  // one entry
  u16(0x0112);
  u16(3);  // SHORT
  u32(1);
  u16(static_cast<uint32_t>(orientation));
  u16(0);
  u32(0);  // no next directory
  return tiff;
}

// A JPEG with an EXIF block (APP1) whose orientation tag says `orientation`.
Bytes WithOrientation(const Bytes& jpeg, int orientation, bool little_endian) {
  Bytes exif = {'E', 'x', 'i', 'f', 0, 0};
  const Bytes tiff = TiffWithOrientation(orientation, little_endian);
  exif.insert(exif.end(), tiff.begin(), tiff.end());
  Bytes out(jpeg.begin(), jpeg.begin() + 2);  // SOI
  const auto length = static_cast<uint32_t>(exif.size() + 2);
  out.insert(out.end(),
             {0xFF, 0xE1, static_cast<uint8_t>(length >> 8), static_cast<uint8_t>(length)});
  out.insert(out.end(), exif.begin(), exif.end());
  out.insert(out.end(), jpeg.begin() + 2, jpeg.end());
  return out;
}

// `image` (stored `cols` pixels wide, `rows` high) with the given orientation decodes as OpenCV
// decodes it in every mode: turned a quarter for 5-8, except unchanged, which keeps the stored
// layout.
void ExpectOrientedAsOpenCv(const Bytes& image, int orientation, int rows, int cols) {
  for (const int mode : kModes) {
    const cv::Mat ours = DecodeImage(image, mode);
    ExpectSameImage(
        ours, cv::imdecode(image, mode),
        "orientation " + std::to_string(orientation) + ", mode " + std::to_string(mode));
    const bool turned = orientation >= 5 && mode != cv::IMREAD_UNCHANGED;
    EXPECT_EQ(ours.cols, turned ? rows : cols);
  }
}

TEST(ImageCodec, JpegOrientationIsAppliedAsOpenCvAppliesIt) {
  Bytes plain;
  ASSERT_TRUE(cv::imencode(".jpg", SmoothColourImage(24, 40), plain));
  for (const bool little_endian : {true, false}) {
    for (int orientation = 1; orientation <= 8; ++orientation) {
      ExpectOrientedAsOpenCv(WithOrientation(plain, orientation, little_endian), orientation, 24,
                             40);
    }
  }
}

TEST(ImageCodec, PngOrientationIsAppliedAsOpenCvAppliesIt) {
  std::mt19937 random(8);
  const Bytes png = MakePng(24, 40, 8, 2, false, &random);  // 24 wide, 40 high
  constexpr size_t kHeaderEnd = 8 + 25;                     // signature, IHDR
  for (const bool little_endian : {true, false}) {
    for (int orientation = 1; orientation <= 8; ++orientation) {
      Bytes with(png.begin(), png.begin() + kHeaderEnd);
      PutChunk(&with, "eXIf", TiffWithOrientation(orientation, little_endian));
      with.insert(with.end(), png.begin() + kHeaderEnd, png.end());
      ExpectOrientedAsOpenCv(with, orientation, 40, 24);
    }
  }
}

TEST(ImageCodec, EncodingParametersAreTheOnesOpenCvApplies) {
  const cv::Mat image = SmoothColourImage(48, 64);
  const std::vector<std::vector<int>> cases = {
      {},
      {cv::IMWRITE_PNG_COMPRESSION, 9},
      {cv::IMWRITE_PNG_COMPRESSION, 0},
      {cv::IMWRITE_PNG_COMPRESSION, -4},  // clamped to 0
      {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_FILTERED},
      {cv::IMWRITE_PNG_COMPRESSION, 6, cv::IMWRITE_PNG_STRATEGY,
       cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY}};
  for (const auto& params : cases) {
    Bytes ours;
    Bytes opencv;
    ASSERT_TRUE(EncodeImage(".png", image, &ours, params));
    ASSERT_TRUE(cv::imencode(".png", image, opencv, params));
    EXPECT_EQ(ours, opencv) << "PNG parameters of " << params.size() / 2 << " settings";
  }
  for (const auto& params : std::vector<std::vector<int>>{
           {cv::IMWRITE_JPEG_QUALITY, 70},
           {cv::IMWRITE_JPEG_PROGRESSIVE, 1},
           {cv::IMWRITE_JPEG_QUALITY, 80, cv::IMWRITE_JPEG_OPTIMIZE, 1}}) {
    Bytes ours;
    Bytes opencv;
    ASSERT_TRUE(EncodeImage(".jpg", image, &ours, params));
    ASSERT_TRUE(cv::imencode(".jpg", image, opencv, params));
    EXPECT_EQ(ours.size(), opencv.size()) << "JPEG parameters " << params[0];
    ExpectSameImage(DecodeImage(ours, cv::IMREAD_COLOR), cv::imdecode(opencv, cv::IMREAD_COLOR),
                    "JPEG parameters " + std::to_string(params[0]));
  }
  Bytes bytes;
  EXPECT_THROW((void)EncodeImage(".png", image, &bytes, {cv::IMWRITE_PNG_COMPRESSION}),
               cv::Exception);
}

TEST(ImageCodec, TruncatedJpegIsAnErrorNotAnImageFilledWithGrey) {
  Bytes jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", SmoothColourImage(64, 64), jpeg));
  ASSERT_FALSE(DecodeImage(jpeg, cv::IMREAD_COLOR).empty());
  const Bytes truncated(jpeg.begin(), jpeg.begin() + static_cast<long>(jpeg.size() * 2 / 3));
  // OpenCV's codecs warn and return the image with its lower part grey.
  EXPECT_FALSE(cv::imdecode(truncated, cv::IMREAD_COLOR).empty());
  for (const int mode : kModes) {
    try {
      (void)DecodeImage(truncated, mode);
      ADD_FAILURE() << "a truncated JPEG was decoded, mode " << mode;
    } catch (const cv::Exception& exception) {
      EXPECT_NE(exception.err.find("JPEG: "), std::string::npos) << exception.err;
    }
  }
}

// A progressive greyscale JPEG of 8x8 pixels with 1 + 63 x 10 scans: each AC coefficient in its
// own scans, refined a bit at a time (valid, and slow to decode if the scans were thousands).
Bytes ManyScanJpeg() {
  std::vector<jpeg_scan_info> scans;
  scans.push_back({1, {0, 0, 0, 0}, 0, 0, 0, 0});  // DC
  for (int k = 1; k < 64; ++k) {
    scans.push_back({1, {0, 0, 0, 0}, k, k, 0, 9});
    for (int bit = 9; bit > 0; --bit) scans.push_back({1, {0, 0, 0, 0}, k, k, bit, bit - 1});
  }
  jpeg_compress_struct info{};
  jpeg_error_mgr error{};
  info.err = jpeg_std_error(&error);
  jpeg_create_compress(&info);
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&info, &buffer, &size);
  info.image_width = 8;
  info.image_height = 8;
  info.input_components = 1;
  info.in_color_space = JCS_GRAYSCALE;
  jpeg_set_defaults(&info);
  info.scan_info = scans.data();
  info.num_scans = static_cast<int>(scans.size());
  jpeg_start_compress(&info, TRUE);
  std::array<JSAMPLE, 8> row{};
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) row[static_cast<size_t>(x)] = static_cast<JSAMPLE>(x * 30 + y * 5);
    JSAMPROW pointer = row.data();
    jpeg_write_scanlines(&info, &pointer, 1);
  }
  jpeg_finish_compress(&info);
  jpeg_destroy_compress(&info);
  Bytes out(buffer, buffer + size);
  std::free(buffer);
  return out;
}

TEST(ImageCodec, JpegWithHundredsOfScansIsRefused) {
  const Bytes jpeg = ManyScanJpeg();
  EXPECT_FALSE(cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE).empty());  // a valid file
  try {
    (void)DecodeImage(jpeg, cv::IMREAD_GRAYSCALE);
    ADD_FAILURE() << "a JPEG of 631 scans was decoded";
  } catch (const cv::Exception& exception) {
    EXPECT_NE(exception.err.find("more than 500 scans"), std::string::npos) << exception.err;
  }
}

TEST(ImageCodec, ImageFilesLargerThanAnyAllowedImageAreRefusedBeforeTheyAreRead) {
  // A sparse file of 3 GiB that starts as a PNG: refused from its size, nothing read.
  const auto path = std::filesystem::temp_directory_path() /
                    ("silpose_image_codec_huge_" + std::to_string(::getpid()) + ".png");
  {
    std::ofstream file(path, std::ios::binary);
    const Bytes signature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    file.write(reinterpret_cast<const char*>(signature.data()),
               static_cast<std::streamsize>(signature.size()));
  }
  std::filesystem::resize_file(path, uintmax_t{3} << 30);
  try {
    (void)ReadImage(path, cv::IMREAD_UNCHANGED);
    ADD_FAILURE() << "a 3 GiB image file was read";
  } catch (const cv::Exception& exception) {
    EXPECT_NE(exception.err.find("3072 MiB"), std::string::npos) << exception.err;
  }
  std::filesystem::remove(path);
}

TEST(ImageCodec, AFailedWriteReportsFalseAndLeavesNoPartialFile) {
  cv::Mat noise(256, 256, CV_8UC3);
  cv::randu(noise, 0, 256);  // about 200 kB as PNG
  EXPECT_FALSE(WriteImage("/nonexistent/silpose/frame.png", noise));
  // A file size limit of 16 kB makes the write fail part-way (EFBIG, the signal ignored).
  const auto path = std::filesystem::temp_directory_path() /
                    ("silpose_image_codec_partial_" + std::to_string(::getpid()) + ".png");
  rlimit saved{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &saved), 0);
  auto* const previous = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = saved;
  small.rlim_cur = 16 << 10;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  const bool written = WriteImage(path, noise);
  ::setrlimit(RLIMIT_FSIZE, &saved);
  std::signal(SIGXFSZ, previous);
  EXPECT_FALSE(written);
  EXPECT_FALSE(std::filesystem::exists(path)) << "a partial image was left behind";
  std::filesystem::remove(path);
  EXPECT_TRUE(WriteImage(path, noise));  // without the limit
  EXPECT_EQ(cv::norm(ReadImage(path, cv::IMREAD_UNCHANGED), noise, cv::NORM_INF), 0.0);
  std::filesystem::remove(path);
}

TEST(ImageCodec, BrokenPngAndJpegThrowWithTheDecodersReason) {
  std::mt19937 random(3);
  const Bytes png = MakePng(9, 9, 8, 2, false, &random);
  const Bytes truncated(png.begin(), png.end() - 30);
  try {
    (void)DecodeImage(truncated, cv::IMREAD_UNCHANGED);
    ADD_FAILURE() << "a truncated PNG was decoded";
  } catch (const cv::Exception& exception) {
    EXPECT_NE(exception.err.find("PNG: "), std::string::npos) << exception.err;
  }
  Bytes bad_crc = png;
  bad_crc[8 + 8 + 13] ^= 0xFF;  // the IHDR chunk's CRC
  EXPECT_THROW((void)DecodeImage(bad_crc, cv::IMREAD_UNCHANGED), cv::Exception);

  const Bytes not_jpeg = {0xFF, 0xD8, 0xFF, 0xC0, 0x00, 0x03, 0x01, 0x02, 0x03, 0x04};
  try {
    (void)DecodeImage(not_jpeg, cv::IMREAD_COLOR);
    ADD_FAILURE() << "a broken JPEG was decoded";
  } catch (const cv::Exception& exception) {
    EXPECT_NE(exception.err.find("JPEG: "), std::string::npos) << exception.err;
  }
  EXPECT_TRUE(DecodeImage({}, cv::IMREAD_UNCHANGED).empty());
  EXPECT_TRUE(ReadImage("/nonexistent/silpose.png", cv::IMREAD_UNCHANGED).empty());
}

TEST(ImageCodec, ImagesBeyondTheSizeLimitAreRefusedBeforeTheirPixels) {
  // A PNG header claiming 40000 x 40000 pixels and no pixel data.
  Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  Bytes header;
  PutBe32(&header, 40000);
  PutBe32(&header, 40000);
  header.insert(header.end(), {8, 0, 0, 0, 0});
  PutChunk(&png, "IHDR", header);
  try {
    (void)DecodeImage(png, cv::IMREAD_UNCHANGED);
    ADD_FAILURE() << "a 40000 x 40000 PNG was accepted";
  } catch (const cv::Exception& exception) {
    EXPECT_NE(exception.err.find("40000x40000"), std::string::npos) << exception.err;
  }
  // The same for a JPEG frame header (SOF0) of 40000 x 40000.
  Bytes jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", cv::Mat(8, 8, CV_8UC1, cv::Scalar(90)), jpeg));
  for (size_t i = 2; i + 9 < jpeg.size(); ++i) {
    if (jpeg[i] == 0xFF && jpeg[i + 1] == 0xC0) {
      jpeg[i + 5] = jpeg[i + 7] = 40000 >> 8;
      jpeg[i + 6] = jpeg[i + 8] = 40000 & 0xFF;
      break;
    }
  }
  try {
    (void)DecodeImage(jpeg, cv::IMREAD_UNCHANGED);
    ADD_FAILURE() << "a 40000 x 40000 JPEG was accepted";
  } catch (const cv::Exception& exception) {
    EXPECT_NE(exception.err.find("40000x40000"), std::string::npos) << exception.err;
  }
}

TEST(ImageCodec, OtherFormatsAndModesGoThroughOpenCvsCodecs) {
  const auto folder = std::filesystem::temp_directory_path() / "silpose_image_codec_test";
  std::filesystem::create_directories(folder);
  const cv::Mat image = SmoothColourImage(20, 30);
  for (const char* extension : {".bmp", ".tif", ".ppm", ".png", ".jpg"}) {
    const auto path = folder / (std::string("image") + extension);
    ASSERT_TRUE(WriteImage(path, image)) << extension;
    const cv::Mat ours = ReadImage(path, cv::IMREAD_COLOR);
    ExpectSameImage(ours, cv::imread(path.string(), cv::IMREAD_COLOR), extension);
    if (std::string(extension) != ".jpg") ExpectSameImage(ours, image, extension);
  }
  // A mode silpose does not decode itself (reduced size) is OpenCV's, PNG or not.
  Bytes png;
  ASSERT_TRUE(EncodeImage(".png", image, &png));
  ExpectSameImage(DecodeImage(png, cv::IMREAD_REDUCED_GRAYSCALE_2),
                  cv::imdecode(png, cv::IMREAD_REDUCED_GRAYSCALE_2), "reduced");
  // Bytes in no known format: an empty image, as from OpenCV.
  const Bytes noise = {'n', 'o', 't', ' ', 'a', 'n', ' ', 'i', 'm', 'a', 'g', 'e'};
  EXPECT_TRUE(DecodeImage(noise, cv::IMREAD_UNCHANGED).empty());
  EXPECT_THROW((void)EncodeImage(".unknown", image, &png), cv::Exception);
  EXPECT_FALSE(WriteImage(folder / "missing" / "image.png", image));
  EXPECT_TRUE(OpenCvImageCodecsLoaded());  // this test links them
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace silpose
