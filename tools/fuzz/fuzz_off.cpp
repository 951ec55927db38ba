// libFuzzer target: the OFF reader (read_mesh_from_memory with FileFormat::Off); a successful
// read must satisfy check_read() (fuzz_common.h), round trips included.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  ricci::ReadOptions options;
  options.format = ricci::FileFormat::Off;
  const ricci::ReadResult r = ricci::read_mesh_from_memory(bytes, "fuzz.off", options);
  ricci_fuzz::check_read(r, "fuzz.off", ricci::FileFormat::Off);
  RICCI_FUZZ_CHECK(!r.mesh.has_texcoords());
  return 0;
}
