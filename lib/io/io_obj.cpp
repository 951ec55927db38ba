// ricci — Wavefront OBJ reader and writer (see io.h for the accepted subset).
//
// Statements used: `v x y z [w | r g b]`, `vt u [v [w]]`, `f` with `v`, `v/vt`, `v//vn` or
// `v/vt/vn` tokens. Everything else (vn, vp, g, o, s, usemtl, mtllib, l, p, unknown statements)
// is skipped. Indices are 1-based; negative indices count back from the last element read so far;
// positive indices may refer forward and are checked once the whole file has been read.
#include <algorithm>
#include <string>
#include <string_view>
#include <vector>

#include "io_internal.h"

namespace ricci::io_detail {

namespace {

/// A positive index that referred beyond the elements read so far.
struct ForwardReference {
  std::int64_t written = 0;  ///< the 1-based index as written
  std::int64_t face = 0;     ///< face (0-based, file order)
  std::int64_t line = 0;
};

/// Forward references, checked when the final element count is known. Only references larger
/// than every earlier one are kept: the first reference (in file order) beyond the final count
/// is larger than all before it, so it is always among them.
class ForwardReferences {
 public:
  void note(const ForwardReference& r) {
    if (r.written <= largest_) return;
    largest_ = r.written;
    kept_.push_back(r);
  }
  /// The first reference beyond `count` elements, or nullptr.
  const ForwardReference* first_beyond(std::int64_t count) const {
    for (const ForwardReference& r : kept_) {
      if (r.written > count) return &r;
    }
    return nullptr;
  }

 private:
  std::int64_t largest_ = 0;
  std::vector<ForwardReference> kept_;
};

/// What an index field refers to; used for resolution and messages.
struct IndexKind {
  const char* singular;  ///< "vertex"
  const char* plural;    ///< "vertices"
};
constexpr IndexKind kVertexIndex{"vertex", "vertices"};
constexpr IndexKind kTexcoordIndex{"texture coordinate", "texture coordinates"};

/// Splits an OBJ face token "v", "v/vt", "v//vn" or "v/vt/vn" into its fields.
/// False when it has more than three fields.
bool split_face_token(std::string_view token, std::string_view& v, std::string_view& vt) {
  const std::size_t a = token.find('/');
  v = token.substr(0, a);
  vt = {};
  if (a == std::string_view::npos) return true;
  const std::string_view rest = token.substr(a + 1);
  const std::size_t b = rest.find('/');
  vt = rest.substr(0, b);
  return b == std::string_view::npos || rest.find('/', b + 1) == std::string_view::npos;
}

class ObjReader {
 public:
  ObjReader(std::string_view data, ReadContext& ctx, const ReadOptions& options)
      : cur_(data, 1, /*comments=*/true, /*continuations=*/true),
        ctx_(ctx),
        mesh_(ctx.result().mesh),
        read_texcoords_(options.read_texcoords),
        collecting_texcoords_(options.read_texcoords) {}

  bool run() {
    cur_.skip_byte_order_mark();
    while (!cur_.at_end()) {
      const std::string_view keyword = cur_.token_on_line();
      bool ok = true;
      if (keyword == "v") {
        ok = read_vertex();
      } else if (keyword == "vt") {
        if (read_texcoords_) ok = read_texcoord();
      } else if (keyword == "f") {
        ok = read_face();
      }
      if (!ok) return false;
      cur_.next_line();
    }
    return finish();
  }

 private:
  /// `v x y z [w | r g b]`: the extra columns are ignored.
  bool read_vertex() {
    const std::int64_t v = mesh_.num_vertices();
    if (v == kMaxVertices) {
      return ctx_.fail_at_line(
          Status::FileTooLarge, cur_.line(),
          "the file has more vertices than ricci can index (" + std::to_string(kMaxVertices) + ")");
    }
    double xyz[3];
    for (double& x : xyz) {
      const std::string_view token = cur_.token_on_line();
      if (token.empty()) {
        return ctx_.fail_at_line(Status::ParseError, cur_.line(),
                                 label(kVertexIndex, v) + " has fewer than 3 coordinates", Element::Vertex,
                                 v);
      }
      const NumberParse parse = parse_real(token, x);
      if (parse != NumberParse::Ok) {
        return fail_coordinate(ctx_, parse, token, false, cur_.line(), label(kVertexIndex, v), v);
      }
    }
    mesh_.positions.insert(mesh_.positions.end(), xyz, xyz + 3);
    return true;
  }

  /// `vt u [v [w]]`: v defaults to 0, w is ignored.
  bool read_texcoord() {
    const std::int64_t t = vt_count_;
    double uv[2] = {0.0, 0.0};
    for (int d = 0; d < 2; ++d) {
      const std::string_view token = cur_.token_on_line();
      if (token.empty()) {
        if (d > 0) break;
        return ctx_.fail_at_line(Status::ParseError, cur_.line(),
                                 label(kTexcoordIndex, t) + " has no coordinates");
      }
      const NumberParse parse = parse_real(token, uv[d]);
      if (parse != NumberParse::Ok) {
        return fail_coordinate(ctx_, parse, token, false, cur_.line(), label(kTexcoordIndex, t), -1);
      }
    }
    ++vt_count_;
    if (collecting_texcoords_) mesh_.texcoords.insert(mesh_.texcoords.end(), uv, uv + 2);
    return true;
  }

  /// `f a b c …` with `v`, `v/vt`, `v//vn` or `v/vt/vn` tokens.
  bool read_face() {
    const std::int64_t face = ctx_.result().polygons_read;
    const std::int64_t line = cur_.line();
    polygon_.clear();
    polygon_texcoords_.clear();
    bool every_corner_has_texcoord = true;
    for (std::string_view token = cur_.token_on_line(); !token.empty(); token = cur_.token_on_line()) {
      std::string_view v_field, vt_field;
      if (!split_face_token(token, v_field, vt_field)) {
        return ctx_.fail_at_line(Status::ParseError, cur_.line(),
                                 "face " + std::to_string(face) + " has a corner " + quote(token) +
                                     " with more than three fields (expected v, v/vt, v//vn or v/vt/vn)",
                                 Element::Face, face);
      }
      Index v = 0;
      if (!resolve(v_field, kVertexIndex, mesh_.num_vertices(), forward_vertices_, face, v)) return false;
      polygon_.push_back(v);
      if (vt_field.empty()) {
        every_corner_has_texcoord = false;
      } else if (collecting_texcoords_) {
        Index t = 0;
        if (!resolve(vt_field, kTexcoordIndex, vt_count_, forward_texcoords_, face, t)) return false;
        polygon_texcoords_.push_back(t);
      } else if (std::int64_t ignored = 0; !parse_integer(vt_field, ignored)) {
        return fail_not_an_index(vt_field, kTexcoordIndex, face);
      }
    }
    if (polygon_.size() < 3) {
      return ctx_.fail_at_line(
          Status::ParseError, line,
          "face " + std::to_string(face) + " has " +
              count_of(static_cast<std::int64_t>(polygon_.size()), "vertex", "vertices") +
              "; a face needs at least 3",
          Element::Face, face);
    }
    if (!every_corner_has_texcoord) stop_collecting_texcoords();
    if (!append_polygon(ctx_, polygon_, line, false)) return false;
    if (collecting_texcoords_) append_fan(polygon_texcoords_, mesh_.corner_texcoords);
    return true;
  }

  /// Resolves an index field against the `count` elements read so far: 1-based, or negative
  /// (relative); positive indices beyond `count` are remembered in `forward`.
  bool resolve(std::string_view field, const IndexKind& kind, std::int64_t count, ForwardReferences& forward,
               std::int64_t face, Index& out) {
    std::int64_t written = 0;
    if (!parse_integer(field, written)) return fail_not_an_index(field, kind, face);
    if (written == 0) {
      return fail_index(face, std::string(kind.singular) + " 0, but OBJ indices start at 1");
    }
    if (written < 0) {
      if (written < -count) {
        return fail_index(face, std::string(kind.singular) + " " + std::to_string(written) + ", but only " +
                                    count_of(count, kind.singular, kind.plural) + " precede it");
      }
      out = static_cast<Index>(count + written);
      return true;
    }
    if (written > count) forward.note({written, face, cur_.line()});
    out = written <= kMaxVertices ? static_cast<Index>(written - 1) : 0;  // 0: reported by finish()
    return true;
  }

  /// "vertex 3 (OBJ index 4)".
  static std::string label(const IndexKind& kind, std::int64_t i) {
    return std::string(kind.singular) + " " + std::to_string(i) + " (OBJ index " + std::to_string(i + 1) +
           ")";
  }

  bool fail_not_an_index(std::string_view field, const IndexKind& kind, std::int64_t face) {
    return ctx_.fail_at_line(Status::ParseError, cur_.line(),
                             "face " + std::to_string(face) + " has a " + kind.singular + " index " +
                                 quote(field) + " that is not an integer",
                             Element::Face, face);
  }

  bool fail_index(std::int64_t face, const std::string& what) {
    return ctx_.fail_at_line(Status::IndexOutOfRange, cur_.line(),
                             "face " + std::to_string(face) + " refers to " + what, Element::Face, face);
  }

  /// A face without texture indices: the mesh will have none.
  void stop_collecting_texcoords() {
    collecting_texcoords_ = false;
    mesh_.texcoords.clear();
    mesh_.texcoords.shrink_to_fit();
    mesh_.corner_texcoords.clear();
    mesh_.corner_texcoords.shrink_to_fit();
  }

  /// Checks forward references against the final counts and settles the texture coordinates.
  bool finish() {
    const ForwardReference* bad_v = forward_vertices_.first_beyond(mesh_.num_vertices());
    const ForwardReference* bad_t =
        collecting_texcoords_ ? forward_texcoords_.first_beyond(vt_count_) : nullptr;
    if (bad_v && (!bad_t || bad_v->face <= bad_t->face))
      return fail_forward(*bad_v, kVertexIndex, mesh_.num_vertices());
    if (bad_t) return fail_forward(*bad_t, kTexcoordIndex, vt_count_);
    if (mesh_.faces.empty()) stop_collecting_texcoords();
    return true;
  }

  bool fail_forward(const ForwardReference& r, const IndexKind& kind, std::int64_t count) {
    return ctx_.fail_at_line(Status::IndexOutOfRange, r.line,
                             "face " + std::to_string(r.face) + " refers to " + kind.singular + " " +
                                 std::to_string(r.written) + ", but the file has " +
                                 count_of(count, kind.singular, kind.plural),
                             Element::Face, r.face);
  }

  TextCursor cur_;
  ReadContext& ctx_;
  Mesh& mesh_;
  bool read_texcoords_;
  /// Reading texture coordinates and every face so far had them.
  bool collecting_texcoords_;
  std::int64_t vt_count_ = 0;
  std::vector<Index> polygon_, polygon_texcoords_;
  ForwardReferences forward_vertices_, forward_texcoords_;
};

}  // namespace

bool read_obj(std::string_view data, ReadContext& ctx, const ReadOptions& options) {
  return ObjReader(data, ctx, options).run();
}

bool append_obj(const Mesh& mesh, bool texcoords, std::string& out, const ByteSink* sink) {
  const std::size_t nv = mesh.positions.size() / 3;
  const std::size_t nf = mesh.faces.size() / 3;
  const bool with_texcoords =
      texcoords && !mesh.corner_texcoords.empty() && mesh.corner_texcoords.size() == mesh.faces.size();
  const std::size_t nt = with_texcoords ? mesh.texcoords.size() / 2 : 0;
  constexpr std::size_t kPiece = std::size_t{1} << 20;
  const std::size_t whole = 64 + nv * 64 + nt * 44 + nf * (with_texcoords ? 48 : 28);
  out.reserve(out.size() + (sink != nullptr ? std::min(whole, kPiece + 256) : whole));
  bool ok = true;
  // Hands a full piece to the sink (after a whole line, so each piece ends with '\n').
  auto flush = [&] {
    if (sink == nullptr || out.size() < kPiece) return;
    ok = ok && (*sink)(out);
    out.clear();
  };
  out += "# written by ricci\n";
  for (std::size_t v = 0; v < nv && ok; ++v) {
    out += "v";
    for (int d = 0; d < 3; ++d) {
      out += ' ';
      append_real(out, mesh.positions[3 * v + d]);
    }
    out += '\n';
    flush();
  }
  for (std::size_t t = 0; t < nt && ok; ++t) {
    out += "vt ";
    append_real(out, mesh.texcoords[2 * t]);
    out += ' ';
    append_real(out, mesh.texcoords[2 * t + 1]);
    out += '\n';
    flush();
  }
  for (std::size_t f = 0; f < nf && ok; ++f) {
    out += 'f';
    for (int k = 0; k < 3; ++k) {
      out += ' ';
      append_integer(out, std::int64_t{mesh.faces[3 * f + k]} + 1);
      if (with_texcoords) {
        out += '/';
        append_integer(out, std::int64_t{mesh.corner_texcoords[3 * f + k]} + 1);
      }
    }
    out += '\n';
    flush();
  }
  return ok;
}

}  // namespace ricci::io_detail
