// The AVI reader (ReadAviHeader, AviReader): the input is an .avi file; every frame is read (up to
// 64), as `silpose track` does.

#include <opencv2/core.hpp>

#include "fuzz/fuzz_common.h"
#include "silpose/io/avi_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = silpose::fuzz::WriteInput(silpose::fuzz::AsView(data, size), ".avi");
  silpose::fuzz::ExpectOnlySilposeErrors([&] { (void)silpose::ReadAviHeader(path); });
  silpose::fuzz::ExpectOnlySilposeErrors([&] {
    silpose::AviReader reader(path);
    cv::Mat frame;
    for (int i = 0; i < 64 && reader.Read(&frame); ++i) {
    }
  });
  return 0;
}
