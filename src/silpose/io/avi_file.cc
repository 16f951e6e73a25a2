#include "silpose/io/avi_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>

#include "silpose/io/image_codec.h"
#include "silpose/io/image_limits.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

// Four-character codes as the little-endian 32-bit words they are stored as.
constexpr std::uint32_t Fourcc(const char (&text)[5]) {
  return static_cast<std::uint32_t>(static_cast<unsigned char>(text[0])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(text[1])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(text[2])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(text[3])) << 24;
}

constexpr std::uint32_t kRiff = Fourcc("RIFF");
constexpr std::uint32_t kAvi = Fourcc("AVI ");
constexpr std::uint32_t kAvix = Fourcc("AVIX");
constexpr std::uint32_t kList = Fourcc("LIST");
constexpr std::uint32_t kHdrl = Fourcc("hdrl");
constexpr std::uint32_t kMovi = Fourcc("movi");
constexpr std::uint32_t kRec = Fourcc("rec ");
constexpr std::uint32_t kIdx1 = Fourcc("idx1");
constexpr std::uint32_t kAvih = Fourcc("avih");
constexpr std::uint32_t kStrl = Fourcc("strl");
constexpr std::uint32_t kStrh = Fourcc("strh");
constexpr std::uint32_t kStrf = Fourcc("strf");
constexpr std::uint32_t kOdml = Fourcc("odml");
constexpr std::uint32_t kDmlh = Fourcc("dmlh");
constexpr std::uint32_t kVids = Fourcc("vids");

// A header list larger than this is not a real AVI header (ffmpeg's, with its reserved OpenDML
// index space, is a few kB); refusing it bounds the memory a corrupt file can make us allocate.
constexpr std::uint32_t kMaxHeaderBytes = 16u << 20;

std::uint32_t Le32(const std::uint8_t* bytes) {
  return static_cast<std::uint32_t>(bytes[0]) | static_cast<std::uint32_t>(bytes[1]) << 8 |
         static_cast<std::uint32_t>(bytes[2]) << 16 | static_cast<std::uint32_t>(bytes[3]) << 24;
}

std::uint16_t Le16(const std::uint8_t* bytes) {
  return static_cast<std::uint16_t>(bytes[0] | bytes[1] << 8);
}

std::string FourccText(std::uint32_t code) {
  std::string text(4, ' ');
  for (int i = 0; i < 4; ++i) {
    const auto c = static_cast<unsigned char>((code >> (8 * i)) & 0xFF);
    text[static_cast<size_t>(i)] = std::isprint(c) ? static_cast<char>(c) : '?';
  }
  return text;
}

std::string Upper(std::string text) {
  for (char& c : text) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return text;
}

enum class Codec { kUnsupported, kJpeg, kPng, kDib };

Codec CodecOf(const std::string& fourcc, int bits_per_pixel) {
  const std::string upper = Upper(fourcc);
  if (upper == "MJPG" || upper == "JPEG" || upper == "AVRN" || upper == "DMB1") return Codec::kJpeg;
  if (upper == "MPNG" || upper == "PNG1" || upper == "PNG ") return Codec::kPng;
  if (upper == "DIB " && (bits_per_pixel == 8 || bits_per_pixel == 24 || bits_per_pixel == 32)) {
    return Codec::kDib;
  }
  return Codec::kUnsupported;
}

bool ReadAt(std::ifstream& file, std::uint64_t offset, void* destination, size_t count) {
  file.clear();
  file.seekg(static_cast<std::streamoff>(offset));
  file.read(static_cast<char*>(destination), static_cast<std::streamsize>(count));
  return file && static_cast<size_t>(file.gcount()) == count;
}

// The header pass: everything AviReader needs besides the open file.
struct Parsed {
  AviHeader header;
  std::uint64_t movi_begin = 0;  // first chunk of the first 'movi' list
  std::uint64_t movi_end = 0;    // its end (may lie beyond the end of a truncated file)
  std::uint64_t riff_end = 0;    // end of the first RIFF chunk
  std::vector<cv::Vec3b> palette;
  bool bottom_up = true;
};

class HeaderParser {
 public:
  HeaderParser(const std::filesystem::path& path, std::ifstream& file, std::uint64_t file_size)
      : path_(path), file_(file), file_size_(file_size) {}

  Parsed Parse() {
    std::uint8_t head[12];
    if (file_size_ < 12 || !ReadAt(file_, 0, head, 12) || Le32(head) != kRiff ||
        Le32(head + 8) != kAvi) {
      Fail("not an AVI file (no RIFF 'AVI ' header)");
    }
    const std::uint32_t riff_size = Le32(head + 4);
    // A writer that never finished leaves 0: the RIFF chunk then runs to the end of the file.
    parsed_.riff_end = riff_size == 0 ? file_size_ : 8 + std::uint64_t{riff_size};
    bool have_header = false;
    std::uint64_t position = 12;
    while (true) {
      if (position + 12 > std::min(parsed_.riff_end, file_size_)) {
        if (riff_size != 0 && parsed_.riff_end <= file_size_) Fail("no 'movi' list (corrupt file)");
        Fail(have_header ? "truncated: the file ends before its 'movi' list"
                         : "truncated: the file ends before its 'hdrl' header");
      }
      if (!ReadAt(file_, position, head, 12)) Fail("cannot read the file");
      const std::uint32_t id = Le32(head);
      const std::uint32_t size = Le32(head + 4);
      const std::uint64_t end = position + 8 + size;
      if (id == kList && Le32(head + 8) == kHdrl && !have_header) {
        if (size < 4 || size > kMaxHeaderBytes) Fail("corrupt 'hdrl' header (implausible size)");
        if (end > file_size_) Fail("truncated: the file ends inside its 'hdrl' header");
        std::vector<std::uint8_t> bytes(size - 4);
        if (!bytes.empty() && !ReadAt(file_, position + 12, bytes.data(), bytes.size())) {
          Fail("cannot read the file");
        }
        ParseHeaderList(bytes);
        have_header = true;
      } else if (id == kList && Le32(head + 8) == kMovi) {
        if (!have_header) Fail("no 'hdrl' header before the 'movi' list");
        parsed_.movi_begin = position + 12;
        parsed_.movi_end = size == 0 ? file_size_ : end;
        CountIndexedFrames(parsed_.movi_end + (parsed_.movi_end & 1));
        break;
      }
      position = end + (size & 1);
    }
    Finish();
    return parsed_;
  }

 private:
  [[noreturn]] void Fail(const std::string& problem) const {
    ThrowError(path_.string(), ": ", problem);
  }

  // The children of LIST 'hdrl' (without its list type).
  void ParseHeaderList(const std::vector<std::uint8_t>& bytes) {
    int stream = 0;
    ForEachChunk(bytes.data(), bytes.size(),
                 [&](std::uint32_t id, const std::uint8_t* data, std::uint32_t size) {
                   if (id == kAvih && size >= 4) {
                     microseconds_per_frame_ = Le32(data);
                   } else if (id == kList && size >= 4 && Le32(data) == kStrl) {
                     ParseStreamList(data + 4, size - 4, stream++);
                   } else if (id == kList && size >= 4 && Le32(data) == kOdml) {
                     ForEachChunk(data + 4, size - 4,
                                  [&](std::uint32_t child, const std::uint8_t* child_data,
                                      std::uint32_t child_size) {
                                    if (child == kDmlh && child_size >= 4)
                                      total_frames_ = Le32(child_data);
                                  });
                   }
                 });
  }

  void ParseStreamList(const std::uint8_t* data, size_t size, int stream) {
    if (have_video_ || stream > 99) return;
    bool video = false;
    ForEachChunk(data, size,
                 [&](std::uint32_t id, const std::uint8_t* chunk, std::uint32_t chunk_size) {
                   if (id == kStrh) {
                     if (chunk_size < 36) Fail("corrupt stream header ('strh' too short)");
                     video = Le32(chunk) == kVids;
                     if (video) {
                       handler_ = Le32(chunk + 4);
                       scale_ = Le32(chunk + 20);
                       rate_ = Le32(chunk + 24);
                     }
                   } else if (id == kStrf && video) {
                     ParseBitmapInfo(chunk, chunk_size);
                     have_video_ = true;
                     parsed_.header.stream_number = stream;
                   }
                 });
  }

  // strf of a video stream: BITMAPINFOHEADER, then the palette of 8-bit frames.
  void ParseBitmapInfo(const std::uint8_t* data, std::uint32_t size) {
    if (size < 40) Fail("corrupt video format ('strf' too short)");
    const auto width = static_cast<std::int32_t>(Le32(data + 4));
    const auto height = static_cast<std::int32_t>(Le32(data + 8));
    const int bits = Le16(data + 14);
    const std::uint32_t compression = Le32(data + 16);
    if (width < 1 || width > 65535 || height == 0 || height < -65535 || height > 65535) {
      Fail("corrupt video format (frame size " + std::to_string(width) + "x" +
           std::to_string(height) + ")");
    }
    std::string too_large;
    if (!ImageSizeAllowed(width, std::abs(height), &too_large)) Fail(too_large);
    AviHeader& header = parsed_.header;
    header.frame_size = cv::Size(width, std::abs(height));
    header.bits_per_pixel = bits;
    header.fourcc = compression == 0 ? "DIB " : FourccText(compression);
    parsed_.bottom_up = height > 0;
    if (compression == 0 && bits == 8) {
      const std::uint32_t info_size = std::min<std::uint32_t>(Le32(data), size);
      std::uint32_t colours = Le32(data + 32);
      if (colours == 0 || colours > 256) colours = 256;
      const std::uint32_t available = (size - std::max<std::uint32_t>(info_size, 40)) / 4;
      // A missing palette is read as a grey ramp, as players do.
      parsed_.palette.resize(256);
      for (std::uint32_t i = 0; i < 256; ++i) {
        const auto level = static_cast<std::uint8_t>(i);
        parsed_.palette[i] = cv::Vec3b(level, level, level);
      }
      const std::uint8_t* entries = data + std::max<std::uint32_t>(info_size, 40);
      for (std::uint32_t i = 0; i < std::min(colours, available); ++i) {
        parsed_.palette[i] = cv::Vec3b(entries[4 * i], entries[4 * i + 1], entries[4 * i + 2]);
      }
    }
  }

  // Counts the video frames in an 'idx1' chunk at `position`, if there is a complete one.
  void CountIndexedFrames(std::uint64_t position) {
    std::uint8_t head[8];
    if (position + 8 > file_size_ || !ReadAt(file_, position, head, 8) || Le32(head) != kIdx1) {
      return;
    }
    const std::uint32_t size = Le32(head + 4);
    if (position + 8 + size > file_size_) return;
    std::vector<std::uint8_t> entries(size);
    if (size > 0 && !ReadAt(file_, position + 8, entries.data(), size)) return;
    const std::string number = std::to_string(100 + parsed_.header.stream_number).substr(1);
    int count = 0;
    for (size_t i = 0; i + 16 <= entries.size(); i += 16) {
      const std::string id = FourccText(Le32(entries.data() + i));
      if (id.compare(0, 2, number) == 0 &&
          (id.compare(2, 2, "dc") == 0 || id.compare(2, 2, "db") == 0)) {
        ++count;
      }
    }
    indexed_frames_ = count;
  }

  void Finish() {
    if (!have_video_) Fail("no video stream");
    AviHeader& header = parsed_.header;
    if (CodecOf(header.fourcc, header.bits_per_pixel) == Codec::kUnsupported) {
      // Some writers name the codec only in the stream header.
      const std::string handler = FourccText(handler_);
      const Codec codec = CodecOf(handler, header.bits_per_pixel);
      if (codec == Codec::kJpeg || codec == Codec::kPng) header.fourcc = handler;
    }
    header.supported = CodecOf(header.fourcc, header.bits_per_pixel) != Codec::kUnsupported;
    if (scale_ > 0 && rate_ > 0) {
      header.fps = static_cast<double>(rate_) / scale_;
    } else if (microseconds_per_frame_ > 0) {
      header.fps = 1e6 / microseconds_per_frame_;
    }
    // A file continued by OpenDML 'AVIX' chunks has an idx1 for its first part only.
    bool continued = false;
    const std::uint64_t next = parsed_.riff_end + (parsed_.riff_end & 1);
    std::uint8_t head[12];
    if (next + 12 <= file_size_ && ReadAt(file_, next, head, 12)) {
      continued = Le32(head) == kRiff && Le32(head + 8) == kAvix;
    }
    if (total_frames_ > 0 && total_frames_ < (1u << 31)) {
      header.num_frames = static_cast<int>(total_frames_);
    } else if (indexed_frames_ && !continued) {
      header.num_frames = indexed_frames_;
    }
  }

  // Calls visit(id, data, size) for each chunk in [data, data + size); a chunk that overruns the
  // block is a corrupt header.
  template <typename Visit>
  void ForEachChunk(const std::uint8_t* data, size_t size, Visit&& visit) {
    size_t offset = 0;
    while (offset + 8 <= size) {
      const std::uint32_t id = Le32(data + offset);
      const std::uint32_t chunk_size = Le32(data + offset + 4);
      if (chunk_size > size - offset - 8) {
        Fail("corrupt header (chunk '" + FourccText(id) + "' overruns its list)");
      }
      visit(id, data + offset + 8, chunk_size);
      offset += 8 + size_t{chunk_size} + (chunk_size & 1);
    }
  }

  const std::filesystem::path& path_;
  std::ifstream& file_;
  std::uint64_t file_size_;
  Parsed parsed_;
  bool have_video_ = false;
  std::uint32_t handler_ = 0;
  std::uint32_t scale_ = 0;
  std::uint32_t rate_ = 0;
  std::uint32_t microseconds_per_frame_ = 0;
  std::uint32_t total_frames_ = 0;
  std::optional<int> indexed_frames_;
};

Parsed ParseFile(const std::filesystem::path& path, std::ifstream& file, std::uint64_t* file_size) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) ThrowError(path.string(), ": no such file");
  if (std::filesystem::is_directory(path, error)) ThrowError(path.string(), ": is a folder");
  *file_size = std::filesystem::file_size(path, error);
  if (error) ThrowError(path.string(), ": cannot read (", error.message(), ")");
  file.open(path, std::ios::binary);
  if (!file) ThrowError(path.string(), ": cannot open for reading");
  return HeaderParser(path, file, *file_size).Parse();
}

// --- Writing -------------------------------------------------------------------------------

void Put32(std::vector<std::uint8_t>* bytes, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) bytes->push_back(static_cast<std::uint8_t>(value >> (8 * i)));
}

void Put16(std::vector<std::uint8_t>* bytes, std::uint16_t value) {
  bytes->push_back(static_cast<std::uint8_t>(value));
  bytes->push_back(static_cast<std::uint8_t>(value >> 8));
}

// The frame rate as dwRate / dwScale: exact for integer rates and NTSC's 30000/1001.
void RateAndScale(double fps, std::uint32_t* rate, std::uint32_t* scale) {
  for (std::uint32_t candidate : {1u, 1001u, 1000u, 1000000u}) {
    const double scaled = std::round(fps * candidate);
    if (scaled >= 1 && scaled <= 4294967295.0 &&
        (std::abs(scaled / candidate - fps) <= 1e-9 * fps || candidate == 1000000u)) {
      *rate = static_cast<std::uint32_t>(scaled);
      *scale = candidate;
      return;
    }
  }
  *rate = static_cast<std::uint32_t>(std::round(fps));
  *scale = 1;
}

// Byte offsets of the header fields Close() fills in.
constexpr std::uint64_t kRiffSizeAt = 4;
constexpr std::uint64_t kAvihDataAt = 32;
constexpr std::uint64_t kStrhDataAt = 108;
constexpr std::uint64_t kMoviListAt = 212;
constexpr std::uint64_t kHeaderBytes = 224;

std::vector<std::uint8_t> WriterHeader(cv::Size size, double fps) {
  std::uint32_t rate = 0;
  std::uint32_t scale = 0;
  RateAndScale(fps, &rate, &scale);
  const auto width = static_cast<std::uint32_t>(size.width);
  const auto height = static_cast<std::uint32_t>(size.height);
  std::vector<std::uint8_t> bytes;
  Put32(&bytes, kRiff);
  Put32(&bytes, 0);  // RIFF size, by Close()
  Put32(&bytes, kAvi);
  Put32(&bytes, kList);
  Put32(&bytes, 4 + (8 + 56) + (8 + 4 + (8 + 56) + (8 + 40)));
  Put32(&bytes, kHdrl);
  Put32(&bytes, kAvih);
  Put32(&bytes, 56);
  Put32(&bytes, static_cast<std::uint32_t>(std::lround(1e6 / fps)));  // dwMicroSecPerFrame
  Put32(&bytes, 0);                              // dwMaxBytesPerSec, by Close()
  Put32(&bytes, 0);                              // dwPaddingGranularity
  Put32(&bytes, 0x10);                           // dwFlags: AVIF_HASINDEX
  Put32(&bytes, 0);                              // dwTotalFrames, by Close()
  Put32(&bytes, 0);                              // dwInitialFrames
  Put32(&bytes, 1);                              // dwStreams
  Put32(&bytes, 0);                              // dwSuggestedBufferSize, by Close()
  Put32(&bytes, width);                          // dwWidth
  Put32(&bytes, height);                         // dwHeight
  for (int i = 0; i < 4; ++i) Put32(&bytes, 0);  // dwReserved
  Put32(&bytes, kList);
  Put32(&bytes, 4 + (8 + 56) + (8 + 40));
  Put32(&bytes, kStrl);
  Put32(&bytes, kStrh);
  Put32(&bytes, 56);
  Put32(&bytes, kVids);
  Put32(&bytes, 0);  // fccHandler, set by the writer from the codec
  Put32(&bytes, 0);  // dwFlags
  Put16(&bytes, 0);  // wPriority
  Put16(&bytes, 0);  // wLanguage
  Put32(&bytes, 0);  // dwInitialFrames
  Put32(&bytes, scale);
  Put32(&bytes, rate);
  Put32(&bytes, 0);           // dwStart
  Put32(&bytes, 0);           // dwLength, by Close()
  Put32(&bytes, 0);           // dwSuggestedBufferSize, by Close()
  Put32(&bytes, 0xFFFFFFFF);  // dwQuality: default
  Put32(&bytes, 0);           // dwSampleSize: frames vary in size
  Put16(&bytes, 0);           // rcFrame
  Put16(&bytes, 0);
  Put16(&bytes, static_cast<std::uint16_t>(width));
  Put16(&bytes, static_cast<std::uint16_t>(height));
  Put32(&bytes, kStrf);
  Put32(&bytes, 40);
  Put32(&bytes, 40);  // biSize
  Put32(&bytes, width);
  Put32(&bytes, height);
  Put16(&bytes, 1);                   // biPlanes
  Put16(&bytes, 24);                  // biBitCount
  Put32(&bytes, 0);                   // biCompression, set by the writer from the codec
  Put32(&bytes, width * height * 3);  // biSizeImage
  for (int i = 0; i < 4; ++i) Put32(&bytes, 0);
  Put32(&bytes, kList);
  Put32(&bytes, 0);  // movi size, by Close()
  Put32(&bytes, kMovi);
  SILPOSE_ASSERT(bytes.size() == kHeaderBytes);
  return bytes;
}

void Patch32(std::vector<std::uint8_t>* bytes, size_t offset, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) (*bytes)[offset + i] = static_cast<std::uint8_t>(value >> (8 * i));
}

}  // namespace

AviHeader ReadAviHeader(const std::filesystem::path& path) {
  std::ifstream file;
  std::uint64_t file_size = 0;
  return ParseFile(path, file, &file_size).header;
}

// --- AviReader ------------------------------------------------------------------------------

AviReader::AviReader(const std::filesystem::path& path, FrameColor color)
    : FrameSource(color), path_(path) {
  Parsed parsed = ParseFile(path, file_, &file_size_);
  header_ = parsed.header;
  if (!header_.supported) {
    ThrowError(path.string(), ": its frames are coded as '", header_.fourcc, "' (",
               header_.bits_per_pixel,
               " bits), which silpose's AVI reader does not decode (it reads MJPEG, PNG and "
               "uncompressed frames); ",
               HasOpenCvVideoIo() ? "OpenCV videoio may read it"
                                  : "a build with -DSILPOSE_WITH_VIDEOIO=ON reads it through "
                                    "OpenCV videoio",
               ", or convert it, e.g. ffmpeg -i IN -c:v mjpeg -q:v 2 OUT.avi");
  }
  palette_ = std::move(parsed.palette);
  if (header_.bits_per_pixel == 8 && palette_.size() != 256) {
    // 8-bit frames without a palette (e.g. uncompressed by the stream header's handler, with
    // another compression code in the format): a grey ramp, as for a missing palette.
    palette_.resize(256);
    for (int i = 0; i < 256; ++i) {
      const auto level = static_cast<std::uint8_t>(i);
      palette_[static_cast<size_t>(i)] = cv::Vec3b(level, level, level);
    }
  }
  if (!palette_.empty()) {
    gray_palette_ = std::all_of(palette_.begin(), palette_.end(),
                                [](const cv::Vec3b& c) { return c[0] == c[1] && c[1] == c[2]; });
  }
  dib_bottom_up_ = parsed.bottom_up;
  const int bits = header_.bits_per_pixel;
  dib_row_bytes_ = ((header_.frame_size.width * bits + 31) / 32) * 4;
  position_ = parsed.movi_begin;
  list_ends_ = {parsed.movi_end};
  riff_end_ = parsed.riff_end;
}

AviReader::~AviReader() = default;

std::string AviReader::name() const {
  return path_.filename().string() + "#" + std::to_string(frame_index());
}

void AviReader::Fail(const std::string& problem) const {
  ThrowError(path_.string(), ": frame ", frame_index() + 1, ": ", problem);
}

// Walks the movi lists to the next chunk of the video stream; leaves position_ on its payload
// and returns its size through `size`. Returns false at the end of the last movi list.
bool AviReader::NextFrameChunk(std::uint32_t* size) {
  const std::string number = std::to_string(100 + header_.stream_number).substr(1);
  const std::uint32_t compressed = Fourcc("00dc") & 0xFFFF0000u;
  const std::uint32_t uncompressed = Fourcc("00db") & 0xFFFF0000u;
  const std::uint32_t stream_id =
      static_cast<std::uint32_t>(static_cast<unsigned char>(number[0])) |
      static_cast<std::uint32_t>(static_cast<unsigned char>(number[1])) << 8;
  std::uint8_t head[12];
  while (true) {
    if (list_ends_.empty()) {
      // An OpenDML continuation, RIFF 'AVIX', holds another 'movi' list.
      const std::uint64_t next = riff_end_ + (riff_end_ & 1);
      if (next + 12 > file_size_ || !ReadAt(file_, next, head, 12) || Le32(head) != kRiff ||
          Le32(head + 8) != kAvix) {
        return false;
      }
      riff_end_ = next + 8 + Le32(head + 4);
      std::uint64_t position = next + 12;
      while (true) {
        if (position + 12 > std::min(riff_end_, file_size_)) {
          if (riff_end_ > file_size_) Fail("truncated: the file ends inside an 'AVIX' part");
          return false;
        }
        if (!ReadAt(file_, position, head, 12)) Fail("cannot read the file");
        const std::uint32_t chunk_size = Le32(head + 4);
        if (Le32(head) == kList && Le32(head + 8) == kMovi) {
          position_ = position + 12;
          list_ends_.push_back(std::min(position + 8 + chunk_size, riff_end_));
          break;
        }
        position = position + 8 + chunk_size + (chunk_size & 1);
      }
      continue;
    }
    const std::uint64_t end = list_ends_.back();
    if (position_ + 8 > end || position_ + 8 > file_size_) {
      if (end > file_size_ && position_ + 8 > file_size_) {
        Fail("truncated: the file ends before the end of its 'movi' list");
      }
      // This list is done (bytes too few for a chunk header are padding).
      list_ends_.pop_back();
      position_ = std::max(position_, end + (end & 1));
      continue;
    }
    if (!ReadAt(file_, position_, head, 8)) Fail("cannot read the file");
    const std::uint32_t id = Le32(head);
    const std::uint32_t chunk_size = Le32(head + 4);
    const std::uint64_t chunk_end = position_ + 8 + chunk_size;
    if (id == kList) {
      if (chunk_size < 4 || chunk_end > end) {
        if (chunk_end > file_size_) Fail("truncated: the file ends inside a list");
        Fail("corrupt 'movi' list (a list overruns it)");
      }
      if (position_ + 12 > file_size_ || !ReadAt(file_, position_ + 8, head + 8, 4)) {
        Fail("truncated: the file ends inside a list header");
      }
      if (Le32(head + 8) == kRec) {
        list_ends_.push_back(chunk_end);
        position_ += 12;
      } else {
        position_ = chunk_end + (chunk_size & 1);
      }
      continue;
    }
    const bool video = (id & 0xFFFFu) == stream_id &&
                       ((id & 0xFFFF0000u) == compressed || (id & 0xFFFF0000u) == uncompressed);
    if (chunk_end > end || chunk_end > file_size_) {
      if (chunk_end > file_size_) {
        Fail(video ? "truncated: the file ends inside the frame's data"
                   : "truncated: the file ends inside a chunk");
      }
      Fail("corrupt 'movi' list (chunk '" + FourccText(id) + "' overruns it)");
    }
    if (video) {
      position_ += 8;
      *size = chunk_size;
      return true;
    }
    position_ = chunk_end + (chunk_size & 1);
  }
}

bool AviReader::ReadNext(cv::Mat* frame) {
  std::uint32_t size = 0;
  if (!NextFrameChunk(&size)) return false;
  const std::uint64_t payload_at = position_;
  position_ += size + (size & 1);
  if (size == 0) {
    // A dropped frame: players show the previous one again.
    if (previous_.empty()) Fail("the first frame is empty");
    *frame = previous_.clone();
    return true;
  }
  // Bounds the memory a corrupt size can make us allocate; real frames are far smaller.
  const std::uint64_t largest = std::max<std::uint64_t>(
      64u << 20, 8ull * static_cast<std::uint64_t>(header_.frame_size.area()));
  if (size > largest) Fail("corrupt frame chunk (implausible size " + std::to_string(size) + ")");
  payload_.resize(size);
  if (!ReadAt(file_, payload_at, payload_.data(), size)) Fail("cannot read the frame's data");
  const Codec codec = CodecOf(header_.fourcc, header_.bits_per_pixel);
  cv::Mat decoded;
  if (codec == Codec::kDib) {
    DecodeDib(&decoded);
  } else {
    if (codec == Codec::kJpeg) {
      // A JPEG starts with SOI (FF D8) and ends with EOI (FF D9), possibly followed by a little
      // padding; without them the data is not a whole frame (libjpeg would only warn).
      bool end_marker = false;
      for (size_t i = size - 1; i >= 1 && i + 64 >= size; --i) {
        if (payload_[i - 1] == 0xFF && payload_[i] == 0xD9) {
          end_marker = true;
          break;
        }
      }
      if (size < 4 || payload_[0] != 0xFF || payload_[1] != 0xD8 || !end_marker) {
        Fail("corrupt JPEG data (no start or end marker)");
      }
    } else if (size < 8 || std::memcmp(payload_.data(), "\x89PNG\r\n\x1a\n", 8) != 0) {
      Fail("corrupt PNG data (no PNG signature)");
    }
    const int flags = codec == Codec::kJpeg && color() == FrameColor::kGray ? cv::IMREAD_GRAYSCALE
                                                                            : cv::IMREAD_UNCHANGED;
    try {
      decoded = DecodeImage(payload_, flags);
    } catch (const cv::Exception& exception) {
      Fail("cannot decode the frame (" + exception.err + ")");
    }
    if (decoded.empty()) {
      Fail(codec == Codec::kJpeg ? "cannot decode its JPEG data (corrupt)"
                                 : "cannot decode its PNG data (corrupt)");
    }
  }
  if (decoded.size() != header_.frame_size) {
    Fail("decoded frame is " + std::to_string(decoded.cols) + "x" + std::to_string(decoded.rows) +
         " pixels, but the stream's frames are " + std::to_string(header_.frame_size.width) + "x" +
         std::to_string(header_.frame_size.height));
  }
  previous_ = decoded;
  *frame = decoded;
  return true;
}

void AviReader::DecodeDib(cv::Mat* frame) const {
  const int width = header_.frame_size.width;
  const int height = header_.frame_size.height;
  const auto row_bytes = static_cast<size_t>(dib_row_bytes_);
  if (payload_.size() < row_bytes * static_cast<size_t>(height)) {
    Fail("uncompressed frame has " + std::to_string(payload_.size()) + " bytes, expected " +
         std::to_string(row_bytes * static_cast<size_t>(height)));
  }
  const int bits = header_.bits_per_pixel;
  const int type = bits == 24 ? CV_8UC3 : bits == 32 ? CV_8UC4 : gray_palette_ ? CV_8UC1 : CV_8UC3;
  cv::Mat image(height, width, type);
  for (int y = 0; y < height; ++y) {
    const int source_row = dib_bottom_up_ ? height - 1 - y : y;
    const std::uint8_t* source = payload_.data() + row_bytes * static_cast<size_t>(source_row);
    if (bits != 8) {
      std::memcpy(image.ptr(y), source, static_cast<size_t>(width) * image.elemSize());
    } else if (gray_palette_) {
      std::uint8_t* target = image.ptr<std::uint8_t>(y);
      for (int x = 0; x < width; ++x) target[x] = palette_[source[x]][0];
    } else {
      cv::Vec3b* target = image.ptr<cv::Vec3b>(y);
      for (int x = 0; x < width; ++x) target[x] = palette_[source[x]];
    }
  }
  *frame = image;
}

// --- AviWriter ------------------------------------------------------------------------------

AviWriter::AviWriter(const std::filesystem::path& path, cv::Size size, double fps,
                     const VideoWriterOptions& options)
    : VideoWriter(path, size, fps), options_(options) {
  options_.Check();
  if (size.width < 1 || size.width > 65535 || size.height < 1 || size.height > 65535) {
    ThrowError(path.string(), ": invalid frame size ", size.width, "x", size.height,
               " (each side 1..65535 pixels)");
  }
  if (!std::isfinite(fps) || fps <= 0 || fps > 1e5) {
    ThrowError(path.string(), ": invalid frame rate ", fps, " (frames per second, > 0)");
  }
  std::vector<std::uint8_t> header = WriterHeader(size, fps);
  const std::uint32_t code = options_.avi_codec == AviCodec::kPng ? Fourcc("MPNG") : Fourcc("MJPG");
  Patch32(&header, kStrhDataAt + 4, code);              // fccHandler
  Patch32(&header, kHeaderBytes - 12 - 40 + 16, code);  // biCompression
  file_.open(path, std::ios::binary | std::ios::trunc);
  if (!file_) ThrowError(path.string(), ": cannot open for writing");
  file_.write(reinterpret_cast<const char*>(header.data()),
              static_cast<std::streamsize>(header.size()));
  if (!file_) ThrowError(path.string(), ": cannot write");
  position_ = header.size();
  movi_fourcc_offset_ = kMoviListAt + 8;
}

AviWriter::~AviWriter() {
  try {
    Close();
  } catch (...) {
    // A destructor must not throw; Close() explicitly to see the error.
  }
}

void AviWriter::Fail(const std::string& problem) const {
  ThrowError(path().string(), ": ", problem);
}

void AviWriter::Write(const cv::Mat& frame) {
  const std::string label = "frame " + std::to_string(num_frames()) + ": ";
  if (closed_) Fail(label + "write after Close()");
  if (frame.type() != CV_8UC1 && frame.type() != CV_8UC3) {
    Fail(label + "type must be CV_8UC1 or CV_8UC3");
  }
  if (frame.size() != size()) {
    Fail(label + "is " + std::to_string(frame.cols) + "x" + std::to_string(frame.rows) +
         " pixels, but the video's frames are " + std::to_string(size().width) + "x" +
         std::to_string(size().height));
  }
  bool encoded = false;
  try {
    if (options_.avi_codec == AviCodec::kPng) {
      encoded = EncodeImage(".png", frame, &encoded_,
                            {cv::IMWRITE_PNG_COMPRESSION, options_.png_compression});
    } else {
      encoded =
          EncodeImage(".jpg", frame, &encoded_, {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality});
    }
  } catch (const cv::Exception& exception) {
    Fail(label + "cannot encode (" + exception.err + ")");
  }
  if (!encoded || encoded_.empty()) Fail(label + "cannot encode");
  const std::uint64_t size = encoded_.size();
  const std::uint64_t chunk_bytes = 8 + size + (size & 1);
  const std::uint64_t index_bytes = 8 + 16 * (chunk_sizes_.size() + 1);
  if (position_ + chunk_bytes + index_bytes > options_.avi_max_file_bytes) {
    Fail(label + "would make the file larger than " + std::to_string(options_.avi_max_file_bytes) +
         " bytes, the limit of an AVI 1.0 file; the " + std::to_string(num_frames()) +
         " frames before it are kept");
  }
  std::vector<std::uint8_t> chunk_header;
  Put32(&chunk_header, Fourcc("00dc"));
  Put32(&chunk_header, static_cast<std::uint32_t>(size));
  file_.write(reinterpret_cast<const char*>(chunk_header.data()), 8);
  file_.write(reinterpret_cast<const char*>(encoded_.data()), static_cast<std::streamsize>(size));
  if (size & 1) file_.put('\0');
  // Every frame Write() returned from is in the file, even if the process is killed before Close().
  file_.flush();
  if (!file_) Fail(label + "write failed (disk full?)");
  chunk_offsets_.push_back(static_cast<std::uint32_t>(position_ - movi_fourcc_offset_));
  chunk_sizes_.push_back(static_cast<std::uint32_t>(size));
  largest_chunk_ = std::max(largest_chunk_, static_cast<std::uint32_t>(size));
  position_ += chunk_bytes;
}

void AviWriter::Close() {
  if (closed_) return;
  closed_ = true;
  const std::uint64_t movi_end = position_;
  std::vector<std::uint8_t> index;
  Put32(&index, kIdx1);
  Put32(&index, static_cast<std::uint32_t>(16 * chunk_sizes_.size()));
  for (size_t i = 0; i < chunk_sizes_.size(); ++i) {
    Put32(&index, Fourcc("00dc"));
    Put32(&index, 0x10);  // AVIIF_KEYFRAME
    Put32(&index, chunk_offsets_[i]);
    Put32(&index, chunk_sizes_[i]);
  }
  file_.write(reinterpret_cast<const char*>(index.data()),
              static_cast<std::streamsize>(index.size()));
  const std::uint64_t file_bytes = movi_end + index.size();
  const auto frames = static_cast<std::uint32_t>(chunk_sizes_.size());
  double bytes_per_second = 0;
  if (frames > 0) bytes_per_second = static_cast<double>(movi_end - kHeaderBytes) / frames * fps();
  const auto patch = [&](std::uint64_t offset, std::uint64_t value) {
    std::vector<std::uint8_t> bytes;
    Put32(&bytes, static_cast<std::uint32_t>(std::min<std::uint64_t>(value, 0xFFFFFFFFu)));
    file_.seekp(static_cast<std::streamoff>(offset));
    file_.write(reinterpret_cast<const char*>(bytes.data()), 4);
  };
  patch(kRiffSizeAt, file_bytes - 8);
  patch(kAvihDataAt + 4, static_cast<std::uint64_t>(bytes_per_second));
  patch(kAvihDataAt + 16, frames);
  patch(kAvihDataAt + 28, largest_chunk_ + 8u);
  patch(kStrhDataAt + 32, frames);
  patch(kStrhDataAt + 36, largest_chunk_ + 8u);
  patch(kMoviListAt + 4, movi_end - (kMoviListAt + 8));
  file_.flush();
  const bool good = static_cast<bool>(file_);
  file_.close();
  if (!good || file_.fail()) Fail("cannot finish writing the file (disk full?)");
}

}  // namespace silpose
