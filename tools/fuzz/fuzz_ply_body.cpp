// libFuzzer target: PLY bodies under fixed headers, so that the fuzzer explores the ascii,
// little-endian and big-endian body readers (list lengths, integer and float types, skipped
// elements and properties, element order) without having to keep a header intact.
//
// Input: byte 0 picks a header (kHeaders), bytes 1 and 2 the vertex and face counts (0–31) put
// into it, the rest is the body. A successful read must satisfy check_read() (fuzz_common.h).
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_common.h"

namespace {

// "@V" and "@F" are replaced by the vertex and face counts.
constexpr std::array<std::string_view, 7> kHeaders = {
    // 0: ascii, the common layout.
    "ply\nformat ascii 1.0\nelement vertex @V\nproperty float x\nproperty float y\nproperty float z\n"
    "element face @F\nproperty list uchar int vertex_indices\nend_header\n",
    // 1: binary little-endian, the common layout.
    "ply\nformat binary_little_endian 1.0\nelement vertex @V\nproperty float x\nproperty float y\n"
    "property float z\nelement face @F\nproperty list uchar int vertex_indices\nend_header\n",
    // 2: binary big-endian, the common layout.
    "ply\nformat binary_big_endian 1.0\nelement vertex @V\nproperty float x\nproperty float y\n"
    "property float z\nelement face @F\nproperty list uchar int vertex_indices\nend_header\n",
    // 3: little-endian doubles, colours, unsigned indices and a skipped edge element.
    "ply\nformat binary_little_endian 1.0\ncomment fuzz\nelement vertex @V\nproperty double x\n"
    "property double y\nproperty double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
    "element face @F\nproperty list int uint vertex_index\nelement edge 2\nproperty int vertex1\n"
    "property int vertex2\nend_header\n",
    // 4: big-endian integer coordinates, a skipped list in the vertex, 16-bit indices.
    "ply\nformat binary_big_endian 1.0\nelement vertex @V\nproperty char flags\nproperty ushort x\n"
    "property short y\nproperty uint z\nproperty list uchar float normal\nelement face @F\n"
    "property uchar tag\nproperty list ushort short vertex_indices\nproperty float quality\nend_header\n",
    // 5: ascii, faces before vertices, an extra list and an extra element.
    "ply\nformat ascii 1.0\nelement face @F\nproperty list uchar uint vertex_indices\n"
    "element vertex @V\nproperty double x\nproperty double y\nproperty double z\n"
    "property list uchar int ids\nelement extra 1\nproperty float w\nend_header\n",
    // 6: little-endian, faces first, coordinates in the order z y x, 32-bit list lengths.
    "ply\nformat binary_little_endian 1.0\nelement face @F\nproperty list uint uint vertex_indices\n"
    "element vertex @V\nproperty float z\nproperty float y\nproperty float x\nend_header\n",
};

void replace(std::string& s, std::string_view key, int value) {
  const std::size_t at = s.find(key);
  if (at != std::string::npos) s.replace(at, key.size(), std::to_string(value));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3) return 0;
  std::string file(kHeaders[data[0] % kHeaders.size()]);
  replace(file, "@V", data[1] % 32);
  replace(file, "@F", data[2] % 32);
  file.append(reinterpret_cast<const char*>(data + 3), size - 3);
  ricci::ReadOptions options;
  options.format = ricci::FileFormat::PlyBinary;
  const ricci::ReadResult r = ricci::read_mesh_from_memory(file, "fuzz.ply", options);
  ricci_fuzz::check_read(r, "fuzz.ply", ricci::FileFormat::PlyBinary);
  if (r.status == ricci::Status::Ok) {
    const bool ascii = data[0] % kHeaders.size() == 0 || data[0] % kHeaders.size() == 5;
    RICCI_FUZZ_CHECK(r.format == (ascii ? ricci::FileFormat::PlyAscii : ricci::FileFormat::PlyBinary));
  }
  return 0;
}
