// libFuzzer target: the FreeSurfer readers — the same bytes as a triangle surface
// (read_mesh_from_memory with FileFormat::FreeSurfer, checked by check_read() and a bit-exact
// round trip through FreeSurfer) and as a curv overlay (read_overlay_from_memory, whose values
// must round-trip through serialize_overlay()).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  ricci::ReadOptions options;
  options.format = ricci::FileFormat::FreeSurfer;
  const ricci::ReadResult r = ricci::read_mesh_from_memory(bytes, "lh.fuzz", options);
  ricci_fuzz::check_read(r, "lh.fuzz", ricci::FileFormat::FreeSurfer);
  if (r.status == ricci::Status::Ok) ricci_fuzz::check_round_trip(r.mesh, ricci::FileFormat::FreeSurfer);

  const ricci::OverlayReadResult o = ricci::read_overlay_from_memory(bytes, "lh.curv", ricci::OverlayFormat::FreeSurferCurv);
  if (o.status != ricci::Status::Ok) {
    ricci_fuzz::check_failure(o.status, o.message, "lh.curv");
    RICCI_FUZZ_CHECK(o.arrays.empty());
    return 0;
  }
  RICCI_FUZZ_CHECK(o.arrays.size() == 1 && o.names.size() == 1);
  const std::string again = ricci::serialize_overlay(o.arrays[0], ricci::OverlayFormat::FreeSurferCurv, "", o.num_faces);
  const ricci::OverlayReadResult back = ricci::read_overlay_from_memory(again, "back.curv", ricci::OverlayFormat::FreeSurferCurv);
  RICCI_FUZZ_CHECK(back.status == ricci::Status::Ok);
  RICCI_FUZZ_CHECK(ricci_fuzz::same_bits(back.arrays.at(0), o.arrays[0]));
  RICCI_FUZZ_CHECK(back.num_faces == o.num_faces);
  return 0;
}
