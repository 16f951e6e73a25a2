// Camera files (ReadCameraFile: OpenCV YAML, XML or JSON). The first byte picks the extension,
// the rest is the file.

#include <array>
#include <string>

#include "fuzz/fuzz_common.h"
#include "silpose/io/camera_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const std::array<std::string, 4> kExtensions = {".yml", ".yaml", ".xml", ".json"};
  const std::string& extension = kExtensions[data[0] % kExtensions.size()];
  const auto path = silpose::fuzz::WriteInput(silpose::fuzz::AsView(data + 1, size - 1), extension);
  silpose::fuzz::ExpectOnlySilposeErrors([&] { (void)silpose::ReadCameraFile(path); });
  return 0;
}
