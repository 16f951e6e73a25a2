#pragma once
// Sources of video frames for tracking (docs/tracking.md, "Input"): a folder of images taken
// in name order, a single image, an AVI file read by silpose itself (MJPEG, PNG or uncompressed
// frames, see avi_file.h), and, only in a build with -DSILPOSE_WITH_VIDEOIO=ON, other video
// containers (mp4, mkv, ...) and live cameras through OpenCV videoio.
//
// Frames are CV_8UC1 (grey) or CV_8UC3 (BGR). FrameColor chooses: kAsStored gives what the source
// holds (grey PNG/JPEG/8-bit grey-palette frames as CV_8UC1, everything else as BGR; 16-bit images
// are scaled to 8 bits, alpha is dropped), and later frames are converted to the first frame's
// kind, so one source never mixes the two. Videos decoded by OpenCV and cameras are always BGR at
// the source.

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace silpose {

/// Pixel format of the frames a FrameSource delivers.
enum class FrameColor {
  kAsStored,  ///< CV_8UC1 if the first frame is grey, else CV_8UC3; later frames follow the first.
  kGray,      ///< Always CV_8UC1 (BGR is converted by luminance; MJPEG decodes straight to grey).
  kBgr,       ///< Always CV_8UC3 BGR (grey is replicated).
  /// Always CV_8UC1 masks, 255 = object: each frame as stored (any depth, alpha kept) decoded by
  /// the one mask rule of mask_file.h (DecodeMask, FrameSourceOptions::mask_threshold).
  kMask,
};

/// Which subfolder of a sequence folder to read (a folder with masks/ and/or frames/ subfolders
/// holding images, as `silpose synth` writes; images in the folder itself are then ignored).
enum class SequenceFolder {
  kMasks,   ///< masks/ (silhouettes); frames/ if there is no masks/ with images.
  kFrames,  ///< frames/ (colour video, e.g. for background subtraction); masks/ if no frames/.
};

struct FrameSourceOptions {
  /// Pixel format of the delivered frames.
  FrameColor color = FrameColor::kAsStored;
  /// Subfolder taken when INPUT is a sequence folder (see SequenceFolder).
  SequenceFolder sequence_folder = SequenceFolder::kMasks;
  /// FrameColor::kMask: a pixel is object above this value (8-bit scale, [0, 254]; see DecodeMask).
  int mask_threshold = 0;
};

/// A sequence of frames read one at a time. Not thread-safe; one reader per source.
class FrameSource {
 public:
  virtual ~FrameSource();
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  /// Reads the next frame into `frame` (CV_8UC1 or CV_8UC3, see FrameColor). Returns false at the
  /// end of the sequence. Frames beyond the image size limit (image_limits.h) are refused. Throws
  /// silpose::Error naming the file and the frame for a corrupt, truncated or unreadable frame, or
  /// for a frame whose size differs from the first frame's; all good frames before it have been
  /// delivered. After an Error, Read() returns false.
  bool Read(cv::Mat* frame);

  /// FrameColor::kMask: the threshold DecodeMask applies (set by OpenFrameSource from the options).
  void set_mask_threshold(int threshold) { mask_threshold_ = threshold; }

  /// 0-based index of the last frame Read() delivered (-1 before the first).
  int frame_index() const { return frame_index_; }
  /// Number of frames when known without reading them all (image folders, AVI files with an index
  /// or OpenDML header, videos whose container states it); std::nullopt otherwise (cameras,
  /// unindexed AVIs).
  virtual std::optional<int> num_frames() const = 0;
  /// Frames per second stated by the source; 0 if unknown (image folders).
  virtual double fps() const = 0;
  /// Frame size in pixels (cv::Size(0, 0) if not known before the first frame is read).
  virtual cv::Size size() const = 0;
  /// Name of the last frame read, for messages and outputs: the file name for image folders
  /// ("000012.png"), "<video file name>#<frame_index>" for videos ("video.avi#12") and
  /// "camera<index>#<frame_index>" for cameras. Before the first frame: the folder for image
  /// folders, frame index -1 for videos.
  virtual std::string name() const = 0;

 protected:
  explicit FrameSource(FrameColor color);
  FrameColor color() const { return color_; }
  /// Reads the next frame as stored (CV_8U with 1, 3 or 4 channels, or CV_16U). Returns false at
  /// the end; throws silpose::Error for a bad frame. The frame about to be read has index
  /// frame_index() + 1.
  virtual bool ReadNext(cv::Mat* frame) = 0;

 private:
  FrameColor color_;
  int mask_threshold_ = 0;
  int frame_index_ = -1;
  bool finished_ = false;
  int first_channels_ = 0;
  cv::Size first_size_;
  cv::Mat raw_;
};

/// Images read one per frame from a list of files (a folder's ImageFilesIn, or one image).
class ImageFolderSource final : public FrameSource {
 public:
  /// `files` in reading order, at least one. Decodes the first image to know size(); throws
  /// silpose::Error naming it if it does not decode.
  explicit ImageFolderSource(std::vector<std::filesystem::path> files,
                             FrameColor color = FrameColor::kAsStored);

  std::optional<int> num_frames() const override { return static_cast<int>(files_.size()); }
  double fps() const override { return 0.0; }
  cv::Size size() const override { return size_; }
  std::string name() const override;

 protected:
  bool ReadNext(cv::Mat* frame) override;

 private:
  std::vector<std::filesystem::path> files_;
  cv::Size size_;
  cv::Mat first_;  // the first image, decoded once by the constructor
  size_t next_ = 0;
};

/// Opens INPUT as docs/tracking.md ("Input") describes:
///  - an existing folder: with masks/ or frames/ subfolders holding images, one of them (by
///    options.sequence_folder); otherwise its own images in name order (extensions as
///    ImageFilesIn);
///  - an existing file ending in .avi: silpose's own AVI reader (AviReader); with videoio, an AVI
///    whose codec that reader does not decode goes to OpenCV instead;
///  - an existing image file: a one-frame source;
///  - another existing file: OpenCV videoio (mp4, mkv, mov, ...) if built with it;
///  - a path starting with /dev/video or /dev/v4l/ (Linux): a Video4Linux2 camera
///    (V4l2CameraSource, v4l2_camera.h), in every build;
///  - a string of digits that is not an existing path: camera number N, through OpenCV videoio in
///    a build with it, else (Linux) /dev/videoN through Video4Linux2.
/// Throws silpose::Error: "no such file or folder", a folder without images, a file that is not a
/// readable video, a camera that cannot be opened, and for videos other than AVI in a build
/// without SILPOSE_WITH_VIDEOIO, a message naming that CMake option.
std::unique_ptr<FrameSource> OpenFrameSource(const std::string& input,
                                             const FrameSourceOptions& options = {});

/// Image files directly in `folder` (.png .pgm .pbm .ppm .bmp .tif .tiff .jpg .jpeg .webp, any
/// case), sorted by name. Throws silpose::Error if the folder cannot be listed.
std::vector<std::filesystem::path> ImageFilesIn(const std::filesystem::path& folder);

/// True if this build reads and writes videos other than AVI and cameras through OpenCV videoio
/// (CMake option SILPOSE_WITH_VIDEOIO).
bool HasOpenCvVideoIo();

}  // namespace silpose
