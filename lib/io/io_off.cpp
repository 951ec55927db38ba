// ricci — OFF reader and writer (see io.h for the accepted subset).
//
//   [comments / blank lines]
//   [ST][C][N]OFF [#V #F [#E]]
//   [#V #F [#E]]                       (when not on the keyword line)
//   x y z [extra columns]              #V lines; normals, colours, texture columns are ignored
//   n i0 … i(n-1) [colour columns]     #F faces, 0-based; the indices may continue on later lines
// `#` starts a comment anywhere. Content after the declared elements is ignored.
#include <string>
#include <string_view>
#include <vector>

#include "io_internal.h"

namespace ricci::io_detail {

namespace {

/// Smallest number of bytes of one vertex line ("0 0 0\n") and one face line ("3 0 1 2\n").
constexpr std::int64_t kMinVertexBytes = 6;
constexpr std::int64_t kMinFaceBytes = 8;

/// Flags of an OFF keyword "[ST][C][N][4][n]OFF".
struct OffKeyword {
  bool valid = false;      ///< the token has the form above
  bool dimension = false;  ///< has the 4 or n prefix (4-D or n-D vertices: unsupported)
};

OffKeyword parse_keyword(std::string_view token) {
  OffKeyword k;
  if (token.size() < 3 || token.substr(token.size() - 3) != "OFF") return k;
  std::string_view prefix = token.substr(0, token.size() - 3);
  for (const std::string_view part : {"ST", "C", "N", "4", "n"}) {
    if (prefix.substr(0, part.size()) == part) {
      prefix.remove_prefix(part.size());
      if (part == "4" || part == "n") k.dimension = true;
    }
  }
  k.valid = prefix.empty();
  return k;
}

class OffReader {
 public:
  OffReader(std::string_view data, ReadContext& ctx)
      : cur_(data, 1, /*comments=*/true, /*continuations=*/false), ctx_(ctx), mesh_(ctx.result().mesh) {}

  bool run() {
    cur_.skip_byte_order_mark();
    if (!read_keyword() || !read_counts()) return false;
    mesh_.positions.reserve(3 * capped_reservation(num_vertices_, kMinVertexBytes, cur_.remaining()));
    mesh_.faces.reserve(3 * capped_reservation(num_faces_, kMinFaceBytes, cur_.remaining()));
    for (std::int64_t v = 0; v < num_vertices_; ++v) {
      if (!read_vertex(v)) return false;
    }
    for (std::int64_t f = 0; f < num_faces_; ++f) {
      if (!read_face(f)) return false;
    }
    return true;
  }

 private:
  /// The first token (after comments and blank lines) must be an OFF keyword.
  bool read_keyword() {
    const std::string_view token = cur_.token();
    if (token.empty()) {
      return ctx_.fail_at_line(Status::ParseError, cur_.line(),
                               "the file has no OFF keyword (it is empty or holds only comments)");
    }
    const OffKeyword keyword = parse_keyword(token);
    if (!keyword.valid) {
      return ctx_.fail_at_line(Status::ParseError, cur_.line(),
                               "expected the keyword OFF (or COFF, NOFF, STOFF, ...), found " + quote(token));
    }
    if (keyword.dimension) {
      return ctx_.fail_at_line(Status::UnknownFormat, cur_.line(),
                               "the keyword " + quote(token) +
                                   " declares 4-D or n-D vertices, which are not supported (only 3-D OFF)");
    }
    const std::string_view next = cur_.token_on_line();
    if (next == "BINARY") {
      return ctx_.fail_at_line(Status::UnknownFormat, cur_.line(),
                               "binary OFF is not supported; convert the file to ascii OFF, OBJ or PLY");
    }
    pending_ = next;
    return true;
  }

  /// "#V #F [#E]" on the keyword line or the next line that is not a comment.
  bool read_counts() {
    std::int64_t counts[2] = {0, 0};
    const char* names[2] = {"vertices", "faces"};
    for (int i = 0; i < 2; ++i) {
      std::string_view token = pending_;
      pending_ = {};
      if (token.empty()) token = cur_.token();
      if (token.empty()) {
        return ctx_.fail_at_line(Status::ParseError, cur_.line(),
                                 std::string("the file ends before the number of ") + names[i]);
      }
      if (!parse_integer(token, counts[i]) || counts[i] < 0) {
        return ctx_.fail_at_line(
            Status::ParseError, cur_.line(),
            std::string("expected the number of ") + names[i] + ", found " + quote(token));
      }
    }
    counts_line_ = cur_.line();
    cur_.token_on_line();  // #E, unused
    cur_.next_line();
    num_vertices_ = counts[0];
    num_faces_ = counts[1];
    return check_counts();
  }

  /// Refuses counts that a Mesh cannot index. Counts larger than the file can hold are not
  /// refused here (nothing is reserved for them): the file then ends early, a ParseError.
  bool check_counts() {
    if (num_vertices_ > kMaxVertices || num_faces_ > kMaxCorners / 3) {
      return ctx_.fail_at_line(Status::FileTooLarge, counts_line_,
                               "the header declares " + count_of(num_vertices_, "vertex", "vertices") +
                                   " and " + count_of(num_faces_, "face", "faces") +
                                   ", more than ricci can index (" + std::to_string(kMaxVertices) +
                                   " vertices, " + std::to_string(kMaxCorners / 3) + " triangles)");
    }
    return true;
  }

  /// The file ended while reading element `index` of kind `element`.
  bool fail_truncated(Element element, std::int64_t index) {
    const std::string read =
        element == Element::Vertex
            ? std::to_string(index) + " of " + count_of(num_vertices_, "vertex", "vertices")
            : count_of(num_vertices_, "vertex", "vertices") + " and " + std::to_string(index) + " of " +
                  count_of(num_faces_, "face", "faces");
    return ctx_.fail_at_line(Status::ParseError, cur_.line(),
                             "the file ends after " + read + " declared in the header", element, index);
  }

  /// One vertex: three coordinates, then the rest of the line is ignored (normals, colours…).
  bool read_vertex(std::int64_t v) {
    double xyz[3];
    for (double& x : xyz) {
      const std::string_view token = cur_.token();
      if (token.empty()) return fail_truncated(Element::Vertex, v);
      const NumberParse parse = parse_real(token, x);
      if (parse != NumberParse::Ok) {
        return fail_coordinate(ctx_, parse, token, false, cur_.line(), "vertex " + std::to_string(v), v);
      }
    }
    mesh_.positions.insert(mesh_.positions.end(), xyz, xyz + 3);
    cur_.next_line();
    return true;
  }

  /// One face "n i0 … i(n-1)"; the rest of the line (colour) is ignored.
  bool read_face(std::int64_t f) {
    std::string_view token = cur_.token();
    if (token.empty()) return fail_truncated(Element::Face, f);
    const std::int64_t line = cur_.line();
    std::int64_t n = 0;
    if (!parse_integer(token, n)) {
      return ctx_.fail_at_line(
          Status::ParseError, line,
          "face " + std::to_string(f) + ": expected its number of vertices, found " + quote(token),
          Element::Face, f);
    }
    if (n < 3) {
      return ctx_.fail_at_line(Status::ParseError, line,
                               "face " + std::to_string(f) + " has " + count_of(n, "vertex", "vertices") +
                                   "; a face needs at least 3",
                               Element::Face, f);
    }
    polygon_.clear();
    for (std::int64_t k = 0; k < n; ++k) {
      token = cur_.token();
      if (token.empty()) return fail_truncated(Element::Face, f);
      std::int64_t index = 0;
      if (!parse_integer(token, index)) {
        return ctx_.fail_at_line(
            Status::ParseError, cur_.line(),
            "face " + std::to_string(f) + " has a vertex index " + quote(token) + " that is not an integer",
            Element::Face, f);
      }
      if (index < 0 || index >= num_vertices_) {
        return ctx_.fail_at_line(Status::IndexOutOfRange, cur_.line(),
                                 "face " + std::to_string(f) + " refers to vertex " + std::to_string(index) +
                                     ", but the file has " + count_of(num_vertices_, "vertex", "vertices") +
                                     " (OFF indices start at 0)",
                                 Element::Face, f);
      }
      polygon_.push_back(static_cast<Index>(index));
    }
    if (!append_polygon(ctx_, polygon_, line, false)) return false;
    cur_.next_line();
    return true;
  }

  TextCursor cur_;
  ReadContext& ctx_;
  Mesh& mesh_;
  std::string_view pending_;  ///< a token already read from the keyword line
  std::int64_t counts_line_ = 0;
  std::int64_t num_vertices_ = 0;
  std::int64_t num_faces_ = 0;
  std::vector<Index> polygon_;
};

}  // namespace

bool read_off(std::string_view data, ReadContext& ctx) {
  return OffReader(data, ctx).run();
}

void append_off(const Mesh& mesh, std::string& out) {
  const std::size_t nv = mesh.positions.size() / 3;
  const std::size_t nf = mesh.faces.size() / 3;
  out.reserve(out.size() + 64 + nv * 62 + nf * 26);
  out += "OFF\n";
  append_integer(out, static_cast<std::int64_t>(nv));
  out += ' ';
  append_integer(out, static_cast<std::int64_t>(nf));
  out += " 0\n";
  append_vertex_lines(mesh, out);
  append_triangle_lines(mesh, out);
}

}  // namespace ricci::io_detail
