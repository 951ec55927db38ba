// libFuzzer target: the GIFTI readers — the same bytes as a surface (read_mesh_from_memory with
// FileFormat::Gifti, checked by check_read(); a success must also round-trip through
// serialize_mesh(…, FileFormat::Gifti) to the same arrays rounded to float32) and as a functional
// file (read_overlay_from_memory with OverlayFormat::GiftiFunc; every array must round-trip
// through serialize_overlay() to its float32-rounded values and its name).
#include <cfloat>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_common.h"

namespace {

/// What a float32 GIFTI array holds for `x`: rounded to nearest, saturated at ±FLT_MAX as the
/// writer does (a conversion beyond the float range would be undefined).
double as_float32(double x) {
  if (x > FLT_MAX) return FLT_MAX;
  if (x < -FLT_MAX) return -FLT_MAX;
  return static_cast<double>(static_cast<float>(x));
}

std::vector<double> as_float32(const std::vector<double>& xs) {
  std::vector<double> out(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) out[i] = as_float32(xs[i]);
  return out;
}

void check_surface(std::string_view bytes) {
  ricci::ReadOptions options;
  options.format = ricci::FileFormat::Gifti;
  const ricci::ReadResult r = ricci::read_mesh_from_memory(bytes, "fuzz.surf.gii", options);
  ricci_fuzz::check_read(r, "fuzz.surf.gii", ricci::FileFormat::Gifti);
  if (r.status != ricci::Status::Ok) return;
  RICCI_FUZZ_CHECK(ricci_fuzz::starts_with(r.format_details, "GIFTI"));
  const std::string again = ricci::serialize_mesh(r.mesh, ricci::FileFormat::Gifti);
  RICCI_FUZZ_CHECK(!again.empty());
  RICCI_FUZZ_CHECK(ricci::format_from_content(again) == ricci::FileFormat::Gifti);
  const ricci::ReadResult back = ricci::read_mesh_from_memory(again, "back.surf.gii", options);
  RICCI_FUZZ_CHECK(back.status == ricci::Status::Ok);
  RICCI_FUZZ_CHECK(ricci_fuzz::same_bits(back.mesh.positions, as_float32(r.mesh.positions)));
  RICCI_FUZZ_CHECK(back.mesh.faces == r.mesh.faces);
  RICCI_FUZZ_CHECK(back.polygons_read == r.mesh.num_faces());
}

void check_overlay(std::string_view bytes) {
  const ricci::OverlayReadResult o =
      ricci::read_overlay_from_memory(bytes, "fuzz.func.gii", ricci::OverlayFormat::GiftiFunc);
  if (o.status != ricci::Status::Ok) {
    ricci_fuzz::check_failure(o.status, o.message, "fuzz.func.gii");
    RICCI_FUZZ_CHECK(o.arrays.empty() && o.names.empty());
    return;
  }
  RICCI_FUZZ_CHECK(ricci_fuzz::starts_with(o.message, "fuzz.func.gii"));
  RICCI_FUZZ_CHECK(o.format == ricci::OverlayFormat::GiftiFunc);
  RICCI_FUZZ_CHECK(!o.arrays.empty() && o.arrays.size() == o.names.size());
  RICCI_FUZZ_CHECK(o.num_faces == -1);
  for (std::size_t k = 0; k < o.arrays.size(); ++k) {
    RICCI_FUZZ_CHECK(o.arrays[k].size() == o.arrays[0].size());  // one value per vertex in each
    RICCI_FUZZ_CHECK(ricci_fuzz::all_finite(o.arrays[k]));
    const std::string again =
        ricci::serialize_overlay(o.arrays[k], ricci::OverlayFormat::GiftiFunc, o.names[k], -1);
    RICCI_FUZZ_CHECK(!again.empty());
    const ricci::OverlayReadResult back =
        ricci::read_overlay_from_memory(again, "back.func.gii", ricci::OverlayFormat::GiftiFunc);
    RICCI_FUZZ_CHECK(back.status == ricci::Status::Ok);
    RICCI_FUZZ_CHECK(back.arrays.size() == 1 && back.names.size() == 1);
    RICCI_FUZZ_CHECK(ricci_fuzz::same_bits(back.arrays[0], as_float32(o.arrays[k])));
    // A name came out of an XML parser, so it is text the writer can hold unchanged.
    RICCI_FUZZ_CHECK(back.names[0] == o.names[k]);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  check_surface(bytes);
  check_overlay(bytes);
  return 0;
}
