// libFuzzer target: the PLY reader on whole files (header and body). The header picks ascii,
// binary_little_endian or binary_big_endian; the seed corpus has all three, and fuzz_ply_body
// reaches the binary bodies without having to keep a header intact. A successful read must
// satisfy check_read() (fuzz_common.h), round trips included.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  ricci::ReadOptions options;
  options.format = ricci::FileFormat::PlyBinary;  // either encoding is read; the header decides
  const ricci::ReadResult r = ricci::read_mesh_from_memory(bytes, "fuzz.ply", options);
  ricci_fuzz::check_read(r, "fuzz.ply", ricci::FileFormat::PlyBinary);
  return 0;
}
