// libFuzzer target: the STL reader (read_mesh_from_memory with FileFormat::StlBinary, which reads
// either encoding) with exact welding and with a tolerance; a successful read must satisfy
// check_read() (fuzz_common.h) and, when its coordinates are floats, round-trip bit for bit
// through both STL encodings.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string_view>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  ricci::ReadOptions options;
  options.format = ricci::FileFormat::StlBinary;
  const ricci::ReadResult r = ricci::read_mesh_from_memory(bytes, "fuzz.stl", options);
  ricci_fuzz::check_read(r, "fuzz.stl", ricci::FileFormat::StlBinary);
  if (r.status == ricci::Status::Ok) {
    RICCI_FUZZ_CHECK(r.welded_vertices == static_cast<std::int64_t>(r.mesh.faces.size()) - r.mesh.num_vertices());
    // STL holds float32: the round trip is exact when the coordinates are floats (always for a
    // binary file; ascii numbers are read as doubles).
    bool floats = true;
    for (const double x : r.mesh.positions)
      floats = floats && std::abs(x) <= std::numeric_limits<float>::max() && static_cast<double>(static_cast<float>(x)) == x;
    RICCI_FUZZ_CHECK(floats || r.format == ricci::FileFormat::StlAscii);
    if (floats) {
      ricci_fuzz::check_round_trip(r.mesh, ricci::FileFormat::StlBinary);
      ricci_fuzz::check_round_trip(r.mesh, ricci::FileFormat::StlAscii);
    }
  }
  options.weld_tolerance = 1e-3;
  const ricci::ReadResult welded = ricci::read_mesh_from_memory(bytes, "fuzz.stl", options);
  ricci_fuzz::check_read(welded, "fuzz.stl", ricci::FileFormat::StlBinary, /*round_trip=*/false);
  RICCI_FUZZ_CHECK(welded.status == r.status);
  if (welded.status == ricci::Status::Ok) RICCI_FUZZ_CHECK(welded.mesh.num_vertices() <= r.mesh.num_vertices());
  return 0;
}
