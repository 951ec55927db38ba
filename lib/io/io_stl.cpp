// ricci — STL reader (binary and ascii) and writer (see io.h).
//
// Takes the bytes of an STL file; gives a Mesh whose vertices are the file's corners welded by
// exact coordinates (or within ReadOptions::weld_tolerance), in order of first appearance.
//
//   binary  80-byte header, uint32 triangle count (little-endian), per triangle 12 float32
//           (normal, three corners) and a uint16 attribute. Chosen when the file does not start
//           with "solid", or when its size is exactly 84 + 50·count (binary files whose header
//           starts with "solid" exist).
//   ascii   solid [name] { facet normal nx ny nz / outer loop / vertex x y z (three or more) /
//           endloop / endfacet } endsolid [name], repeated for several solids. Keywords are
//           matched case-insensitively; normals are not read (they may even be "nan").
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "io_internal.h"

namespace ricci::io_detail {

namespace {

constexpr std::size_t kHeaderBytes = 84;
constexpr std::size_t kTriangleBytes = 50;

bool equal_keyword(std::string_view token, std::string_view keyword) {
  if (token.size() != keyword.size()) return false;
  for (std::size_t i = 0; i < token.size(); ++i) {
    char c = token[i];
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (c != keyword[i]) return false;
  }
  return true;
}

/// Printable part of a header or name for format_details (at most 80 characters).
std::string printable(std::string_view text) {
  std::string out;
  for (const char c : text.substr(0, 80)) {
    if (c == '\0') break;
    out += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

// ---------------------------------------------------------------------------------------------
// Welding: corners (x, y, z) → vertex indices.

/// Key of exact coordinates; -0 and +0 are the same point.
struct PointKey {
  std::uint64_t x, y, z;
  bool operator==(const PointKey&) const = default;
};
struct PointKeyHash {
  std::size_t operator()(const PointKey& k) const {
    std::uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
    h ^= (k.y + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2));
    h ^= (k.z + 0x85EBCA77C2B2AE63ull + (h << 6) + (h >> 2));
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
};

std::uint64_t exact_bits(double x) {
  return x == 0.0 ? 0 : std::bit_cast<std::uint64_t>(x);
}

/// Welds corners into vertices: exactly (tolerance 0) or, for a positive tolerance, a corner
/// joins the earliest vertex within that Euclidean distance (grid of cells of the tolerance's
/// size; coordinates beyond 2^50 tolerances from the origin are welded exactly: their cells'
/// floors no longer resolve the tolerance).
class Welder {
 public:
  explicit Welder(double tolerance) : tol_(tolerance) {}

  Index add(const double p[3], std::vector<double>& positions) {
    if (tol_ > 0) {
      PointKey cell{};
      if (cell_of(p, cell)) return add_near(p, cell, positions);
    }
    const PointKey key{exact_bits(p[0]), exact_bits(p[1]), exact_bits(p[2])};
    const auto [it, inserted] = exact_.try_emplace(key, static_cast<Index>(positions.size() / 3));
    if (inserted) positions.insert(positions.end(), p, p + 3);
    return it->second;
  }

 private:
  /// The grid cell of p; false when a coordinate is too far from the origin for the grid.
  bool cell_of(const double p[3], PointKey& cell) const {
    std::uint64_t k[3];
    for (int i = 0; i < 3; ++i) {
      if (p[i] != 0.0) {
        int ex = 0, et = 0;
        (void)std::frexp(p[i], &ex);
        (void)std::frexp(tol_, &et);
        if (ex - et > 50) return false;
      }
      k[i] = std::bit_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(p[i] / tol_)));
    }
    cell = {k[0], k[1], k[2]};
    return true;
  }

  Index add_near(const double p[3], const PointKey& cell, std::vector<double>& positions) {
    Index best = -1;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const PointKey c{cell.x + static_cast<std::uint64_t>(dx), cell.y + static_cast<std::uint64_t>(dy),
                           cell.z + static_cast<std::uint64_t>(dz)};
          const auto it = grid_.find(c);
          if (it == grid_.end()) continue;
          for (const Index v : it->second) {
            if (best >= 0 && v >= best) break;  // lists are in increasing order
            if (within(p, &positions[3 * static_cast<std::size_t>(v)])) best = v;
          }
        }
      }
    }
    if (best >= 0) return best;
    const auto v = static_cast<Index>(positions.size() / 3);
    positions.insert(positions.end(), p, p + 3);
    grid_[cell].push_back(v);
    return v;
  }

  bool within(const double p[3], const double q[3]) const {
    // Each difference is at most a few tolerances here (neighbouring cells), so no overflow.
    const double d0 = (p[0] - q[0]) / tol_, d1 = (p[1] - q[1]) / tol_, d2 = (p[2] - q[2]) / tol_;
    return d0 * d0 + d1 * d1 + d2 * d2 <= 1.0;
  }

  double tol_;
  std::unordered_map<PointKey, Index, PointKeyHash> exact_;
  std::unordered_map<PointKey, std::vector<Index>, PointKeyHash> grid_;
};

// ---------------------------------------------------------------------------------------------
// Readers.

class StlReader {
 public:
  StlReader(std::string_view data, ReadContext& ctx, double tolerance)
      : data_(data), ctx_(ctx), result_(ctx.result()), welder_(tolerance) {}

  bool run() {
    const bool solid_text = starts_with_solid();
    if (data_.size() >= kHeaderBytes) {
      const auto count = load_endian<std::uint32_t>(data_.data() + 80, false);
      const std::uint64_t expected = kHeaderBytes + kTriangleBytes * static_cast<std::uint64_t>(count);
      if (expected == data_.size() || !solid_text) return read_binary(count, expected);
    } else if (!solid_text) {
      return ctx_.fail_at_byte(Status::ParseError, 0,
                               "the file has " + count_of(static_cast<std::int64_t>(data_.size()), "byte", "bytes") +
                                   ": too short for a binary STL header (84 bytes) and it does not start with "
                                   "\"solid\" as ascii STL does");
    }
    return read_ascii();
  }

 private:
  bool starts_with_solid() const {
    std::size_t i = 0;
    if (data_.substr(0, 3) == "\xEF\xBB\xBF") i = 3;
    while (i < data_.size() && (data_[i] == ' ' || data_[i] == '\t' || data_[i] == '\r' || data_[i] == '\n')) ++i;
    return data_.size() >= i + 5 && equal_keyword(data_.substr(i, 5), "solid");
  }

  bool check_triangles(std::int64_t triangles, std::int64_t where, bool binary) {
    if (triangles > kMaxCorners / 3) {
      return ctx_.fail_at(Status::FileTooLarge, binary, where,
                          "the file has more than " + std::to_string(kMaxCorners / 3) +
                              " triangles, the most ricci can index");
    }
    return true;
  }

  bool read_binary(std::uint32_t count, std::uint64_t expected) {
    result_.format = FileFormat::StlBinary;
    if (expected > data_.size()) {
      const std::uint64_t present = (data_.size() - kHeaderBytes) / kTriangleBytes;
      return ctx_.fail_at_byte(Status::ParseError, static_cast<std::int64_t>(kHeaderBytes + present * kTriangleBytes),
                               "binary STL: the header declares " + count_of(count, "triangle", "triangles") +
                                   " (" + std::to_string(expected) + " bytes) but the file has " +
                                   std::to_string(data_.size()) + " bytes: it ends in triangle " +
                                   std::to_string(present),
                               Element::Face, static_cast<std::int64_t>(present));
    }
    if (!check_triangles(count, 80, true)) return false;
    std::string header = printable(data_.substr(0, 80));
    result_.format_details = "binary STL, " + count_of(count, "triangle", "triangles") + ", header \"" + header + "\"";
    if (expected < data_.size())
      result_.format_details += ", " + std::to_string(data_.size() - expected) + " bytes after the triangles ignored";
    Mesh& mesh = result_.mesh;
    mesh.faces.reserve(3 * static_cast<std::size_t>(count));
    mesh.positions.reserve(3 * (static_cast<std::size_t>(count) / 2 + 3));  // a closed mesh has #F/2 + 2 - 2g vertices
    for (std::uint32_t t = 0; t < count; ++t) {
      const char* base = data_.data() + kHeaderBytes + kTriangleBytes * t;
      Index corners[3];
      for (int k = 0; k < 3; ++k) {
        double p[3];
        for (int i = 0; i < 3; ++i) {
          const auto x = load_endian<float>(base + 12 + 12 * k + 4 * i, false);
          if (!is_finite_bits(x)) {
            return ctx_.fail_at_byte(Status::NonFiniteCoordinate, base + 12 + 12 * k + 4 * i - data_.data(),
                                     "triangle " + std::to_string(t) + ", corner " + std::to_string(k) +
                                         ", has a coordinate that is not finite (NaN or infinite)",
                                     Element::Face, t);
          }
          p[i] = x;
        }
        corners[k] = welder_.add(p, mesh.positions);
      }
      if (!append_polygon(ctx_, corners, base - data_.data(), true)) return false;
    }
    return true;
  }

  bool fail_expected(TextCursor& cur, std::string_view what, std::string_view found) {
    return ctx_.fail_at_line(Status::ParseError, cur.line(),
                             "ascii STL: expected " + std::string(what) + ", found " +
                                 (found.empty() ? std::string("the end of the file") : quote(found)),
                             found.empty() && facet_ >= 0 ? Element::Face : Element::None, facet_);
  }

  bool expect(TextCursor& cur, std::string_view keyword) {
    const std::string_view token = cur.token();
    if (equal_keyword(token, keyword)) return true;
    std::string quoted(1, '"');
    quoted.append(keyword);
    quoted.push_back('"');
    return fail_expected(cur, quoted, token);
  }

  /// After "facet": "normal nx ny nz outer loop (vertex x y z)+ endloop endfacet".
  bool read_facet(TextCursor& cur) {
    const std::int64_t line = cur.line();
    if (!expect(cur, "normal")) return false;
    for (int i = 0; i < 3; ++i) {
      if (cur.token().empty()) return fail_expected(cur, "a normal component", {});
    }
    if (!expect(cur, "outer") || !expect(cur, "loop")) return false;
    polygon_.clear();
    for (;;) {
      const std::string_view token = cur.token();
      if (equal_keyword(token, "endloop")) break;
      if (!equal_keyword(token, "vertex")) return fail_expected(cur, "\"vertex\" or \"endloop\"", token);
      double p[3];
      for (double& x : p) {
        const std::string_view number = cur.token();
        if (number.empty()) return fail_expected(cur, "a vertex coordinate", number);
        const NumberParse parse = parse_real(number, x);
        if (parse != NumberParse::Ok) {
          return fail_coordinate(ctx_, parse, number, false, cur.line(),
                                 "facet " + std::to_string(facet_) + ", corner " + std::to_string(polygon_.size()),
                                 -1);
        }
      }
      polygon_.push_back(welder_.add(p, result_.mesh.positions));
    }
    if (polygon_.size() < 3) {
      return ctx_.fail_at_line(Status::ParseError, cur.line(),
                               "facet " + std::to_string(facet_) + " has " +
                                   count_of(static_cast<std::int64_t>(polygon_.size()), "vertex", "vertices") +
                                   "; a facet needs at least 3",
                               Element::Face, facet_);
    }
    if (!expect(cur, "endfacet")) return false;
    return append_polygon(ctx_, polygon_, line, false);
  }

  bool read_ascii() {
    result_.format = FileFormat::StlAscii;
    TextCursor cur(data_, 1, /*comments=*/false, /*continuations=*/false);
    cur.skip_byte_order_mark();
    int solids = 0;
    std::string first_name;
    for (std::string_view token = cur.token(); !token.empty(); token = cur.token()) {
      if (!equal_keyword(token, "solid")) return fail_expected(cur, "\"solid\"", token);
      ++solids;
      const std::string_view name = cur.token_on_line();
      if (solids == 1) first_name = printable(name);
      cur.next_line();
      for (;;) {
        token = cur.token();
        if (equal_keyword(token, "endsolid")) break;
        if (!equal_keyword(token, "facet")) return fail_expected(cur, "\"facet\" or \"endsolid\"", token);
        facet_ = result_.polygons_read;
        if (!check_triangles(result_.polygons_read + 1, cur.line(), false) || !read_facet(cur)) return false;
        facet_ = -1;
      }
      cur.next_line();  // the solid's name after endsolid
    }
    if (solids == 0) return ctx_.fail_at_line(Status::ParseError, cur.line(), "ascii STL: the file is empty");
    result_.format_details = "ascii STL, " + count_of(solids, "solid", "solids") + ", first named \"" + first_name +
                             "\"";
    return true;
  }

  std::string_view data_;
  ReadContext& ctx_;
  ReadResult& result_;
  Welder welder_;
  std::vector<Index> polygon_;
  std::int64_t facet_ = -1;
};

}  // namespace

bool read_stl(std::string_view data, ReadContext& ctx, const ReadOptions& options) {
  const double tol = options.weld_tolerance;
  if (!is_finite_bits(tol) || tol < 0) {
    return ctx.fail(Status::InvalidArgument, "the weld tolerance must be a finite number >= 0");
  }
  if (!StlReader(data, ctx, tol).run()) return false;
  ReadResult& r = ctx.result();
  r.welded_vertices = static_cast<std::int64_t>(r.mesh.faces.size()) - r.mesh.num_vertices();
  return true;
}

// ---------------------------------------------------------------------------------------------
// Writer.

namespace {

/// The unit normal of a triangle in float coordinates (0 for a degenerate one).
void facet_normal(const float a[3], const float b[3], const float c[3], float n[3]) {
  const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  const double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  // Scaled by the largest component before the cross product, so that nothing overflows.
  double s = 0;
  for (int i = 0; i < 3; ++i) s = std::max({s, std::abs(u[i]), std::abs(v[i])});
  n[0] = n[1] = n[2] = 0.0f;
  if (!(s > 0)) return;
  const double p[3] = {u[0] / s, u[1] / s, u[2] / s}, q[3] = {v[0] / s, v[1] / s, v[2] / s};
  const double w[3] = {p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]};
  const double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  if (!(len > 1e-300)) return;
  for (int i = 0; i < 3; ++i) n[i] = static_cast<float>(w[i] / len);
}

}  // namespace

void append_stl(const Mesh& mesh, bool binary, std::string& out) {
  const std::size_t nf = mesh.faces.size() / 3;
  auto corner = [&](std::size_t f, int k, float p[3]) {
    const auto v = static_cast<std::size_t>(mesh.faces[3 * f + static_cast<std::size_t>(k)]);
    for (int i = 0; i < 3; ++i) p[i] = to_float(mesh.positions[3 * v + static_cast<std::size_t>(i)]);
  };
  if (binary) {
    out.reserve(out.size() + kHeaderBytes + kTriangleBytes * nf);
    std::string header = "binary STL written by ricci";
    header.resize(80, ' ');
    out += header;
    append_endian<std::uint32_t>(out, static_cast<std::uint32_t>(nf), false);
  } else {
    out.reserve(out.size() + 32 + nf * 260);
    out += "solid ricci\n";
  }
  for (std::size_t f = 0; f < nf; ++f) {
    float p[3][3], n[3];
    for (int k = 0; k < 3; ++k) corner(f, k, p[k]);
    facet_normal(p[0], p[1], p[2], n);
    if (binary) {
      for (const float x : n) append_endian<float>(out, x, false);
      for (const auto& q : p)
        for (const float x : q) append_endian<float>(out, x, false);
      append_endian<std::uint16_t>(out, 0, false);
      continue;
    }
    out += "facet normal ";
    for (int i = 0; i < 3; ++i) {
      if (i > 0) out += ' ';
      append_real(out, n[i]);
    }
    out += "\n  outer loop\n";
    for (const auto& q : p) {
      out += "    vertex ";
      for (int i = 0; i < 3; ++i) {
        if (i > 0) out += ' ';
        append_real(out, q[i]);
      }
      out += '\n';
    }
    out += "  endloop\nendfacet\n";
  }
  if (!binary) out += "endsolid ricci\n";
}

}  // namespace ricci::io_detail
