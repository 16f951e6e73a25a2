// Mesh loading (LoadMesh: OBJ, PLY, OFF, STL, glTF through the project's loader). The first byte
// picks the extension, the rest is the file.

#include <array>
#include <string>

#include "fuzz/fuzz_common.h"
#include "silpose/mesh/triangle_mesh.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const std::array<std::string, 6> kExtensions = {".obj", ".ply",  ".off",
                                                         ".stl", ".gltf", ".glb"};
  const std::string& extension = kExtensions[data[0] % kExtensions.size()];
  const auto path = silpose::fuzz::WriteInput(silpose::fuzz::AsView(data + 1, size - 1), extension);
  silpose::fuzz::ExpectOnlySilposeErrors([&] { (void)silpose::LoadMesh(path); });
  return 0;
}
