// ricci — FreeSurfer binary triangle surfaces and "new" curv files (see io.h).
//
// Takes the bytes of a file; gives a Mesh (surfaces) or one array of per-vertex values (curv).
// Everything is big-endian.
//
//   surface  FF FF FE, the created-by line and one more line (each ended by '\n'), int32 #V,
//            int32 #F, #V×3 float32 coordinates, #F×3 int32 vertex indices (0-based); what follows
//            (volume geometry tags) is ignored.
//   curv     FF FF FF, int32 #V, int32 #F, int32 values per vertex (1), #V float32 values.
#include <cstdint>
#include <string>
#include <string_view>

#include "io_internal.h"

namespace ricci::io_detail {

namespace {

constexpr unsigned char kTriangleMagic[3] = {0xFF, 0xFF, 0xFE};
constexpr unsigned char kQuadMagic[3] = {0xFF, 0xFF, 0xFF};
constexpr unsigned char kCurvMagic[3] = {0xFF, 0xFF, 0xFF};

bool has_magic(std::string_view data, const unsigned char (&magic)[3]) {
  return data.size() >= 3 && static_cast<unsigned char>(data[0]) == magic[0] &&
         static_cast<unsigned char>(data[1]) == magic[1] && static_cast<unsigned char>(data[2]) == magic[2];
}

/// A created-by line for format_details: printable characters only, at most 120.
std::string printable_line(std::string_view line) {
  std::string out;
  for (const char c : line.substr(0, 120)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  return out;
}

/// Reads big-endian int32 `what` at `offset`; false (recorded) when the file ends before it or
/// the value is negative.
bool read_count(std::string_view data, std::size_t offset, const char* what, ReadContext& ctx, std::int64_t& value) {
  if (data.size() < offset + 4) {
    return ctx.fail_at_byte(Status::ParseError, static_cast<std::int64_t>(data.size()),
                            std::string("the file ends before the number of ") + what);
  }
  value = load_endian<std::int32_t>(data.data() + offset, true);
  if (value < 0) {
    return ctx.fail_at_byte(Status::ParseError, static_cast<std::int64_t>(offset),
                            std::string("the number of ") + what + " is negative (" + std::to_string(value) + ")");
  }
  return true;
}

/// Checks that `count` items of `item_bytes` fit in the file after `offset`.
bool check_present(std::string_view data, std::size_t offset, std::int64_t count, std::int64_t item_bytes,
                   const std::string& what, Element element, ReadContext& ctx) {
  const std::uint64_t needed = static_cast<std::uint64_t>(count) * static_cast<std::uint64_t>(item_bytes);
  const std::uint64_t present = data.size() - offset;
  if (needed <= present) return true;
  const std::int64_t complete = static_cast<std::int64_t>(present / static_cast<std::uint64_t>(item_bytes));
  return ctx.fail_at_byte(Status::ParseError, static_cast<std::int64_t>(offset + complete * item_bytes),
                          "the file ends after " + std::to_string(complete) + " of the " + std::to_string(count) +
                              " " + what + " declared in the header",
                          element, complete);
}

}  // namespace

bool read_freesurfer(std::string_view data, ReadContext& ctx) {
  if (has_magic(data, kQuadMagic)) {
    return ctx.fail_at_byte(Status::UnknownFormat, 0,
                            "magic number FF FF FF: a FreeSurfer quadrangle surface or a curv file, not a "
                            "triangle surface (only triangle surfaces, magic FF FF FE, are read)");
  }
  if (!has_magic(data, kTriangleMagic)) {
    return ctx.fail_at_byte(Status::ParseError, 0,
                            "no FreeSurfer triangle-surface magic number (FF FF FE) at the start of the file");
  }
  // The created-by line and the (normally empty) line after it.
  std::size_t pos = 3;
  std::string_view created;
  for (int line = 0; line < 2; ++line) {
    const std::size_t end = data.find('\n', pos);
    if (end == std::string_view::npos) {
      return ctx.fail_at_byte(Status::ParseError, static_cast<std::int64_t>(pos),
                              "the created-by line is not ended by two newlines");
    }
    if (line == 0) created = data.substr(pos, end - pos);
    pos = end + 1;
  }
  std::int64_t nv = 0, nf = 0;
  if (!read_count(data, pos, "vertices", ctx, nv) || !read_count(data, pos + 4, "faces", ctx, nf)) return false;
  pos += 8;
  if (nv > kMaxVertices || nf > kMaxCorners / 3) {
    return ctx.fail_at_byte(Status::FileTooLarge, static_cast<std::int64_t>(pos - 8),
                            "the header declares " + count_of(nv, "vertex", "vertices") + " and " +
                                count_of(nf, "face", "faces") + ", more than ricci can index");
  }
  if (!check_present(data, pos, nv, 12, "vertices", Element::Vertex, ctx) ||
      !check_present(data, pos + 12 * static_cast<std::size_t>(nv), nf, 12, "faces", Element::Face, ctx))
    return false;
  ReadResult& r = ctx.result();
  r.format_details = "FreeSurfer triangle surface, \"" + printable_line(created) + "\"";
  r.mesh.positions.resize(3 * static_cast<std::size_t>(nv));
  for (std::size_t i = 0; i < r.mesh.positions.size(); ++i) {
    const auto x = load_endian<float>(data.data() + pos + 4 * i, true);
    if (!is_finite_bits(x)) {
      const auto v = static_cast<std::int64_t>(i / 3);
      return ctx.fail_at_byte(Status::NonFiniteCoordinate, static_cast<std::int64_t>(pos + 4 * i),
                              "vertex " + std::to_string(v) + " has a coordinate that is not finite (NaN or infinite)",
                              Element::Vertex, v);
    }
    r.mesh.positions[i] = x;
  }
  pos += 12 * static_cast<std::size_t>(nv);
  r.mesh.faces.resize(3 * static_cast<std::size_t>(nf));
  for (std::size_t c = 0; c < r.mesh.faces.size(); ++c) {
    const std::int32_t v = load_endian<std::int32_t>(data.data() + pos + 4 * c, true);
    if (v < 0 || v >= nv) {
      const auto f = static_cast<std::int64_t>(c / 3);
      return ctx.fail_at_byte(Status::IndexOutOfRange, static_cast<std::int64_t>(pos + 4 * c),
                              "face " + std::to_string(f) + " refers to vertex " + std::to_string(v) +
                                  ", but the file has " + count_of(nv, "vertex", "vertices") + " (indices start at 0)",
                              Element::Face, f);
    }
    r.mesh.faces[c] = v;
  }
  r.polygons_read = nf;
  return true;
}

void append_freesurfer(const Mesh& mesh, std::string& out) {
  const std::size_t nv = mesh.positions.size() / 3;
  const std::size_t nf = mesh.faces.size() / 3;
  out.reserve(out.size() + 32 + 12 * (nv + nf));
  out.append(reinterpret_cast<const char*>(kTriangleMagic), 3);
  out += "created by ricci\n\n";
  append_endian<std::int32_t>(out, static_cast<std::int32_t>(nv), true);
  append_endian<std::int32_t>(out, static_cast<std::int32_t>(nf), true);
  for (const double x : mesh.positions) append_endian<float>(out, to_float(x), true);
  for (const Index v : mesh.faces) append_endian<std::int32_t>(out, static_cast<std::int32_t>(v), true);
}

bool read_curv(std::string_view data, ReadContext& ctx, OverlayReadResult& out) {
  if (!has_magic(data, kCurvMagic)) {
    return ctx.fail_at_byte(Status::ParseError, 0,
                            "no FreeSurfer curv magic number (FF FF FF) at the start of the file (old-style curv "
                            "files without it are not read)");
  }
  std::int64_t nv = 0, nf = 0, per_vertex = 0;
  if (!read_count(data, 3, "vertices", ctx, nv) || !read_count(data, 7, "faces", ctx, nf) ||
      !read_count(data, 11, "values per vertex", ctx, per_vertex))
    return false;
  if (per_vertex != 1) {
    return ctx.fail_at_byte(Status::ParseError, 11,
                            "the file has " + std::to_string(per_vertex) + " values per vertex; only 1 is read");
  }
  if (nv > kMaxVertices) {
    return ctx.fail_at_byte(Status::FileTooLarge, 3, "the header declares " + count_of(nv, "vertex", "vertices") +
                                                         ", more than ricci can index");
  }
  constexpr std::size_t kBody = 15;
  if (!check_present(data, kBody, nv, 4, "values", Element::Vertex, ctx)) return false;
  std::vector<double> values(static_cast<std::size_t>(nv));
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto x = load_endian<float>(data.data() + kBody + 4 * i, true);
    if (!is_finite_bits(x)) {
      return ctx.fail_at_byte(Status::NonFiniteCoordinate, static_cast<std::int64_t>(kBody + 4 * i),
                              "the value of vertex " + std::to_string(i) + " is not finite (NaN or infinite)",
                              Element::Vertex, static_cast<std::int64_t>(i));
    }
    values[i] = x;
  }
  out.arrays.push_back(std::move(values));
  out.names.emplace_back();
  out.num_faces = nf;
  return true;
}

void append_curv(std::span<const double> values, std::int64_t num_faces, std::string& out) {
  out.reserve(out.size() + 15 + 4 * values.size());
  out.append(reinterpret_cast<const char*>(kCurvMagic), 3);
  append_endian<std::int32_t>(out, static_cast<std::int32_t>(values.size()), true);
  append_endian<std::int32_t>(out, static_cast<std::int32_t>(num_faces < 0 ? 0 : num_faces), true);
  append_endian<std::int32_t>(out, 1, true);
  for (const double x : values) append_endian<float>(out, to_float(x), true);
}

}  // namespace ricci::io_detail
