// libFuzzer target: the OBJ reader (read_mesh_from_memory with FileFormat::Obj). Each input is
// read with and without texture coordinates; both must agree on positions and faces, and a
// successful read must satisfy check_read() (fuzz_common.h), round trips included.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  ricci::ReadOptions options;
  options.format = ricci::FileFormat::Obj;
  const ricci::ReadResult with = ricci::read_mesh_from_memory(bytes, "fuzz.obj", options);
  ricci_fuzz::check_read(with, "fuzz.obj", ricci::FileFormat::Obj);

  options.read_texcoords = false;
  const ricci::ReadResult without = ricci::read_mesh_from_memory(bytes, "fuzz.obj", options);
  ricci_fuzz::check_read(without, "fuzz.obj", ricci::FileFormat::Obj, /*round_trip=*/false);
  RICCI_FUZZ_CHECK(!without.mesh.has_texcoords() && without.mesh.texcoords.empty());
  // Texture coordinates are optional data: skipping them may turn a texture-index error into
  // success, but never the reverse, and never changes the geometry.
  if (with.status == ricci::Status::Ok) {
    RICCI_FUZZ_CHECK(without.status == ricci::Status::Ok);
    RICCI_FUZZ_CHECK(ricci_fuzz::same_bits(with.mesh.positions, without.mesh.positions));
    RICCI_FUZZ_CHECK(with.mesh.faces == without.mesh.faces);
  }
  return 0;
}
