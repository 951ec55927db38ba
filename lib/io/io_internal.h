// ricci — internals shared by the OBJ, OFF and PLY readers and writers (not a public header).
//
// The readers work on the whole file in memory. Text is scanned with a TextCursor (pointers, no
// per-line allocation); numbers are parsed with std::from_chars (locale independent); polygons go
// through append_polygon(), which fan-triangulates and counts them; every failure is recorded by a
// ReadContext, which writes the message "NAME: line N: what" (or "NAME: byte N: what") into the
// ReadResult. Reader functions return false once a failure has been recorded.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ricci/io.h"
#include "ricci/mesh.h"
#include "ricci/status.h"

namespace ricci::io_detail {

/// Largest number of vertices a Mesh can index.
inline constexpr std::int64_t kMaxVertices = std::numeric_limits<Index>::max();
/// Largest number of corners (3 × triangles) a Mesh can hold, a multiple of 3.
inline constexpr std::int64_t kMaxCorners = std::numeric_limits<Index>::max() / 3 * 3;

// ---------------------------------------------------------------------------------------------
// Numbers.

/// True when `x` is neither NaN nor infinite. Looks at the bits only, so it performs no
/// floating-point operation (safe with signalling NaNs and floating-point traps enabled).
inline bool is_finite_bits(double x) {
  return (std::bit_cast<std::uint64_t>(x) & 0x7ff0000000000000ull) != 0x7ff0000000000000ull;
}
inline bool is_finite_bits(float x) {
  return (std::bit_cast<std::uint32_t>(x) & 0x7f800000u) != 0x7f800000u;
}

enum class NumberParse {
  Ok,         ///< the whole token is a finite number
  Malformed,  ///< the token is not a number (or has trailing characters)
  NonFinite,  ///< nan, inf, or a magnitude beyond the range of a double
};

/// Parses a whole token as a decimal floating-point number (optional leading '+'). Values that
/// underflow become a signed zero; values that overflow, and nan/inf, give NonFinite (and leave
/// `value` at 0). Locale independent.
NumberParse parse_real(std::string_view token, double& value);

/// Parses a whole token as a decimal integer (optional sign). False when malformed or beyond
/// the range of int64.
bool parse_integer(std::string_view token, std::int64_t& value);

/// Appends the shortest decimal form of `x` that reads back to the same bits.
void append_real(std::string& out, double x);
/// Appends a decimal integer.
void append_integer(std::string& out, std::int64_t x);
/// Appends one line "x y z" per vertex (the body of OFF and ascii PLY).
void append_vertex_lines(const Mesh& mesh, std::string& out);
/// Appends one line "3 a b c" per triangle, 0-based (the body of OFF and ascii PLY).
void append_triangle_lines(const Mesh& mesh, std::string& out);

// ---------------------------------------------------------------------------------------------
// Messages.

/// A token as shown in a message: quoted, at most 40 characters, non-printable bytes as \xNN.
std::string quote(std::string_view token);
/// "1 vertex", "3 vertices".
std::string count_of(std::int64_t n, std::string_view singular, std::string_view plural);

/// Records failures into a ReadResult on behalf of one reader.
class ReadContext {
 public:
  ReadContext(std::string_view name, ReadResult& result) : name_(name), result_(result) {}

  std::string_view name() const { return name_; }
  ReadResult& result() { return result_; }

  /// Records a failure at a 1-based text line ("NAME: line N: what"). Always returns false.
  bool fail_at_line(Status status, std::int64_t line, const std::string& what,
                    Element element = Element::None, std::int64_t element_index = -1);
  /// Records a failure at a byte offset of a binary file ("NAME: byte N: what"). Returns false.
  bool fail_at_byte(Status status, std::int64_t offset, const std::string& what,
                    Element element = Element::None, std::int64_t element_index = -1);
  /// fail_at_byte() when `binary`, else fail_at_line().
  bool fail_at(Status status, bool binary, std::int64_t where, const std::string& what,
               Element element = Element::None, std::int64_t element_index = -1) {
    return binary ? fail_at_byte(status, where, what, element, element_index)
                  : fail_at_line(status, where, what, element, element_index);
  }
  /// Records a failure that has no location ("NAME: what"). Always returns false.
  bool fail(Status status, const std::string& what);

 private:
  bool record(Status status, std::string where, std::int64_t line, const std::string& what, Element element,
              std::int64_t element_index);

  std::string_view name_;
  ReadResult& result_;
};

/// Records the failure of a vertex coordinate: ParseError when `parse` is Malformed,
/// NonFiniteCoordinate when NonFinite. `label` names the vertex ("vertex 3"); `token` is the text
/// read (empty for binary files); `vertex` < 0 for texture coordinates. Always returns false.
bool fail_coordinate(ReadContext& ctx, NumberParse parse, std::string_view token, bool binary,
                     std::int64_t where, const std::string& label, std::int64_t vertex);

// ---------------------------------------------------------------------------------------------
// Text scanning.

/// A forward cursor over text with 1-based line numbers. Newlines are "\n", "\r\n" or a lone
/// "\r"; blanks are space, tab, \v and \f. Tokens are maximal runs of other characters, ended
/// also by '#' when comments are on (a comment runs to the end of the line). With continuations
/// on, a backslash directly before a newline joins the two lines (OBJ), except in a comment.
class TextCursor {
 public:
  TextCursor(std::string_view text, std::int64_t first_line, bool comments, bool continuations)
      : begin_(text.data()),
        p_(text.data()),
        end_(text.data() + text.size()),
        line_(first_line),
        comments_(comments),
        continuations_(continuations) {}

  bool at_end() const { return p_ == end_; }
  /// Line of the character under the cursor.
  std::int64_t line() const { return line_; }
  /// Offset of the cursor from the start of the text.
  std::size_t offset() const { return static_cast<std::size_t>(p_ - begin_); }
  /// Bytes from the cursor to the end.
  std::size_t remaining() const { return static_cast<std::size_t>(end_ - p_); }

  /// Skips blanks (and line continuations) on the current line.
  void skip_blanks() {
    while (p_ != end_) {
      const char c = *p_;
      if (c == ' ' || c == '\t' || c == '\v' || c == '\f') {
        ++p_;
      } else if (c == '\\' && continuations_ && newline_after_backslash()) {
        ++p_;
        consume_newline();
      } else {
        return;
      }
    }
  }

  /// Skips blanks, then says whether the current line has no more tokens.
  bool at_line_end() {
    skip_blanks();
    return p_ == end_ || is_newline(*p_) || (comments_ && *p_ == '#');
  }

  /// Next token on the current line; empty when the line has no more.
  std::string_view token_on_line() {
    if (at_line_end()) return {};
    return scan_token();
  }

  /// Next token, crossing newlines and comments; empty at the end of the text.
  std::string_view token() {
    for (;;) {
      if (!at_line_end()) return scan_token();
      if (p_ == end_) return {};
      next_line();
    }
  }

  /// Moves to the start of the next line (skipping the rest of this one, comments included).
  /// A continuation joins the next line unless it ends a comment.
  void next_line() {
    bool in_comment = false;
    while (p_ != end_) {
      if (is_newline(*p_)) {
        const bool continued = continuations_ && !in_comment && p_ != begin_ && p_[-1] == '\\';
        consume_newline();
        if (!continued) return;
      } else {
        in_comment = in_comment || (comments_ && *p_ == '#');
        ++p_;
      }
    }
  }

  /// Skips a UTF-8 byte order mark at the cursor.
  void skip_byte_order_mark() {
    if (remaining() >= 3 && std::memcmp(p_, "\xEF\xBB\xBF", 3) == 0) p_ += 3;
  }

 private:
  static bool is_newline(char c) { return c == '\n' || c == '\r'; }
  static bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f'; }

  bool newline_after_backslash() const {
    const char* q = p_ + 1;
    return q != end_ && is_newline(*q);
  }
  void consume_newline() {
    if (*p_ == '\r' && p_ + 1 != end_ && p_[1] == '\n') ++p_;
    ++p_;
    ++line_;
  }
  std::string_view scan_token() {
    const char* start = p_;
    while (p_ != end_) {
      const char c = *p_;
      if (is_blank(c) || is_newline(c) || (comments_ && c == '#')) break;
      if (c == '\\' && continuations_ && newline_after_backslash()) break;
      ++p_;
    }
    return {start, static_cast<std::size_t>(p_ - start)};
  }

  const char* begin_;
  const char* p_;
  const char* end_;
  std::int64_t line_;
  bool comments_;
  bool continuations_;
};

// ---------------------------------------------------------------------------------------------
// Declared counts.

/// How many of `declared` elements to reserve room for: at most as many as `available_bytes` can
/// hold at `min_bytes` (> 0) each. A hostile count therefore allocates nothing; a truncated file
/// is then reported by the parser when the data runs out.
inline std::size_t capped_reservation(std::int64_t declared, std::int64_t min_bytes,
                                      std::size_t available_bytes) {
  const auto fit = static_cast<std::int64_t>(available_bytes / static_cast<std::size_t>(min_bytes)) + 1;
  return static_cast<std::size_t>(declared < fit ? declared : fit);
}

// ---------------------------------------------------------------------------------------------
// Polygons.

/// Appends the fan triangulation of `polygon` (v0 v1 v2, v0 v2 v3, …) to `triangles`.
/// Precondition: polygon.size() >= 3.
void append_fan(std::span<const Index> polygon, std::vector<Index>& triangles);

/// Fan-triangulates `polygon` into result.mesh.faces and updates polygons_read and
/// polygons_triangulated. Fails (FileTooLarge) when the mesh would exceed kMaxCorners.
/// `line` is the line (or byte offset when `binary`) reported on failure.
bool append_polygon(ReadContext& ctx, std::span<const Index> polygon, std::int64_t line, bool binary);

// ---------------------------------------------------------------------------------------------
// Format readers and writers. Each reader fills ctx.result().mesh and the polygon counters and
// returns false after recording a failure; the caller sets the status on success.

bool read_obj(std::string_view data, ReadContext& ctx, const ReadOptions& options);
bool read_off(std::string_view data, ReadContext& ctx);
/// Reads ascii and both binary PLY encodings; sets ctx.result().format from the header.
bool read_ply(std::string_view data, ReadContext& ctx);

/// Appends the mesh as OBJ; texture coordinates when `texcoords` and the mesh has consistent
/// ones (corner_texcoords.size() == faces.size()). With a `sink`, `out` is handed to it and
/// emptied whenever it holds about 1 MB (what is left at the end stays in `out`); false when the
/// sink stops.
bool append_obj(const Mesh& mesh, bool texcoords, std::string& out, const ByteSink* sink = nullptr);
void append_off(const Mesh& mesh, std::string& out);
/// Appends the mesh as PLY, ascii or binary little-endian.
void append_ply(const Mesh& mesh, bool binary, std::string& out);

/// Reads ascii and binary STL (sets ctx.result().format) and welds the corners into vertices
/// (options.weld_tolerance; ctx.result().welded_vertices).
bool read_stl(std::string_view data, ReadContext& ctx, const ReadOptions& options);
/// Appends the mesh as STL, ascii or binary (float32 coordinates, facet normals computed).
void append_stl(const Mesh& mesh, bool binary, std::string& out);

/// Reads a GIFTI surface: the NIFTI_INTENT_POINTSET and NIFTI_INTENT_TRIANGLE data arrays.
bool read_gifti(std::string_view data, ReadContext& ctx);
/// Appends the mesh as a GIFTI surface (float32 pointset, int32 triangles, GZipBase64Binary).
void append_gifti(const Mesh& mesh, std::string& out);
/// Reads every data array of a GIFTI functional file as per-vertex values (#V or #V×1 arrays;
/// any numeric data type). Failures are recorded in ctx.
bool read_gifti_overlay(std::string_view data, ReadContext& ctx, OverlayReadResult& out);
/// Appends a GIFTI functional file with one FLOAT32 array (intent NIFTI_INTENT_SHAPE).
void append_gifti_overlay(std::span<const double> values, std::string_view name, std::string& out);

/// Reads a FreeSurfer binary triangle surface.
bool read_freesurfer(std::string_view data, ReadContext& ctx);
/// Appends the mesh as a FreeSurfer triangle surface (created-by line "created by ricci").
void append_freesurfer(const Mesh& mesh, std::string& out);
/// Reads a FreeSurfer "new" curv file.
bool read_curv(std::string_view data, ReadContext& ctx, OverlayReadResult& out);
/// Appends values as a FreeSurfer "new" curv file.
void append_curv(std::span<const double> values, std::int64_t num_faces, std::string& out);

// ---------------------------------------------------------------------------------------------
// Binary helpers.

/// `x` as a float for the single-precision formats (STL, GIFTI, FreeSurfer), rounded to nearest
/// and saturated at ±FLT_MAX (a double beyond the float range would make the conversion
/// undefined; write_mesh() refuses such meshes before they get here).
inline float to_float(double x) {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (!is_finite_bits(x)) return 0.0f;
  if (x > kMax) return std::numeric_limits<float>::max();
  if (x < -kMax) return -std::numeric_limits<float>::max();
  return static_cast<float>(x);
}

/// True when the format stores coordinates in single precision.
inline bool single_precision(FileFormat f) {
  return f == FileFormat::StlAscii || f == FileFormat::StlBinary || f == FileFormat::Gifti ||
         f == FileFormat::FreeSurfer;
}

/// Reads a big- or little-endian value of type T (an integer or float type of 1, 2, 4 or 8 bytes)
/// from `p` (no alignment needed).
template <class T>
T load_endian(const char* p, bool big_endian) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) {
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  }
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

/// Appends a value of type T in the given byte order.
template <class T>
void append_endian(std::string& out, T v, bool big_endian) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) {
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  }
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

}  // namespace ricci::io_detail
