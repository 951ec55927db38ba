// ricci — the public I/O entry points (io.h) and the helpers shared by the three formats
// (io_internal.h): number parsing and printing, messages, triangulation, loading files and
// atomic writes.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <new>
#include <string>
#include <system_error>

#include "io_internal.h"
#include "ricci/io.h"

namespace ricci {
namespace io_detail {

// ---------------------------------------------------------------------------------------------
// Numbers.

namespace {

/// For a token std::from_chars accepted as out of range: true when its magnitude is at least 1
/// (an overflow), false when below 1 (an underflow). Looks at the decimal exponent of the
/// leading significant digit only, which is far beyond ±300 in either case.
bool magnitude_at_least_one(std::string_view t) {
  std::size_t i = 0;
  if (i < t.size() && (t[i] == '-' || t[i] == '+')) ++i;
  bool found = false;
  bool after_point = false;
  std::int64_t digits_before_point = 0;
  std::int64_t zeros_after_point = 0;
  for (; i < t.size(); ++i) {
    const char c = t[i];
    if (c == '.') {
      after_point = true;
    } else if (c >= '0' && c <= '9') {
      if (!after_point) {
        if (found || c != '0') {
          found = true;
          ++digits_before_point;
        }
      } else if (!found) {
        if (c == '0') {
          ++zeros_after_point;
        } else {
          found = true;
        }
      }
    } else {
      break;  // exponent marker
    }
  }
  if (!found) return false;
  // Decimal exponent of the first significant digit, before the explicit exponent.
  const std::int64_t leading = digits_before_point > 0 ? digits_before_point - 1 : -(zeros_after_point + 1);
  std::int64_t exponent = 0;
  if (i < t.size() && (t[i] == 'e' || t[i] == 'E')) {
    ++i;
    bool negative = false;
    if (i < t.size() && (t[i] == '-' || t[i] == '+')) negative = t[i++] == '-';
    for (; i < t.size() && t[i] >= '0' && t[i] <= '9'; ++i) {
      exponent = std::min<std::int64_t>(exponent * 10 + (t[i] - '0'), std::int64_t{1} << 40);
    }
    if (negative) exponent = -exponent;
  }
  return leading + exponent >= 0;
}

/// Removes one leading '+' that is followed by a digit or a point.
std::string_view strip_plus(std::string_view t) {
  if (t.size() >= 2 && t[0] == '+' && t[1] != '-' && t[1] != '+') t.remove_prefix(1);
  return t;
}

}  // namespace

NumberParse parse_real(std::string_view token, double& value) {
  const std::string_view t = strip_plus(token);
  if (t.empty()) return NumberParse::Malformed;
  double v = 0;
  const char* end = t.data() + t.size();
  const auto [ptr, ec] = std::from_chars(t.data(), end, v, std::chars_format::general);
  if (ptr != end) return NumberParse::Malformed;
  if (ec == std::errc::result_out_of_range) {
    if (magnitude_at_least_one(t)) return NumberParse::NonFinite;
    value = t[0] == '-' ? -0.0 : 0.0;
    return NumberParse::Ok;
  }
  if (ec != std::errc()) return NumberParse::Malformed;
  if (!is_finite_bits(v)) return NumberParse::NonFinite;
  value = v;
  return NumberParse::Ok;
}

bool parse_integer(std::string_view token, std::int64_t& value) {
  const std::string_view t = strip_plus(token);
  if (t.empty()) return false;
  const char* end = t.data() + t.size();
  const auto [ptr, ec] = std::from_chars(t.data(), end, value);
  return ec == std::errc() && ptr == end;
}

void append_real(std::string& out, double x) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

void append_integer(std::string& out, std::int64_t x) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

void append_vertex_lines(const Mesh& mesh, std::string& out) {
  for (std::size_t v = 0; v < mesh.positions.size() / 3; ++v) {
    for (std::size_t d = 0; d < 3; ++d) {
      if (d > 0) out += ' ';
      append_real(out, mesh.positions[3 * v + d]);
    }
    out += '\n';
  }
}

void append_triangle_lines(const Mesh& mesh, std::string& out) {
  for (std::size_t f = 0; f < mesh.faces.size() / 3; ++f) {
    out += '3';
    for (std::size_t k = 0; k < 3; ++k) {
      out += ' ';
      append_integer(out, mesh.faces[3 * f + k]);
    }
    out += '\n';
  }
}

// ---------------------------------------------------------------------------------------------
// Messages.

std::string quote(std::string_view token) {
  constexpr std::size_t kShown = 40;
  static constexpr char kHex[] = "0123456789abcdef";
  std::string s = "'";
  for (std::size_t i = 0; i < std::min(token.size(), kShown); ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f) {
      s += static_cast<char>(c);
    } else {
      s += "\\x";
      s += kHex[c >> 4];
      s += kHex[c & 15];
    }
  }
  if (token.size() > kShown) s += "...";
  s += "'";
  return s;
}

std::string count_of(std::int64_t n, std::string_view singular, std::string_view plural) {
  std::string s = std::to_string(n);
  s += ' ';
  s += n == 1 ? singular : plural;
  return s;
}

bool ReadContext::fail_at_line(Status status, std::int64_t line, const std::string& what, Element element,
                               std::int64_t element_index) {
  return record(status, "line " + std::to_string(line) + ": ", line, what, element, element_index);
}

bool ReadContext::fail_at_byte(Status status, std::int64_t offset, const std::string& what, Element element,
                               std::int64_t element_index) {
  return record(status, "byte " + std::to_string(offset) + ": ", offset, what, element, element_index);
}

bool ReadContext::fail(Status status, const std::string& what) {
  return record(status, "", -1, what, Element::None, -1);
}

bool ReadContext::record(Status status, std::string where, std::int64_t line, const std::string& what,
                         Element element, std::int64_t element_index) {
  result_.status = status;
  result_.message = std::string(name_) + ": " + where + what;
  result_.line = line;
  result_.element = element;
  result_.element_index = element_index;
  result_.mesh = Mesh{};  // outputs are unspecified on failure; free the memory now
  result_.polygons_read = 0;
  result_.polygons_triangulated = 0;
  return false;
}

bool fail_coordinate(ReadContext& ctx, NumberParse parse, std::string_view token, bool binary,
                     std::int64_t where, const std::string& label, std::int64_t vertex) {
  std::string shown;
  if (!token.empty()) shown.append(" ").append(quote(token));
  const Element element = vertex >= 0 ? Element::Vertex : Element::None;
  if (parse == NumberParse::NonFinite) {
    return ctx.fail_at(Status::NonFiniteCoordinate, binary, where,
                       label + " has a coordinate" + shown +
                           " that is not finite (NaN, infinite or beyond the range of a double)",
                       element, vertex);
  }
  return ctx.fail_at(Status::ParseError, binary, where,
                     label + " has a coordinate" + shown + " that is not a number", element, vertex);
}

// ---------------------------------------------------------------------------------------------
// Polygons.

void append_fan(std::span<const Index> polygon, std::vector<Index>& triangles) {
  for (std::size_t k = 1; k + 1 < polygon.size(); ++k) {
    triangles.push_back(polygon[0]);
    triangles.push_back(polygon[k]);
    triangles.push_back(polygon[k + 1]);
  }
}

bool append_polygon(ReadContext& ctx, std::span<const Index> polygon, std::int64_t line, bool binary) {
  ReadResult& r = ctx.result();
  std::vector<Index>& faces = r.mesh.faces;
  const auto corners = 3 * (static_cast<std::int64_t>(polygon.size()) - 2);
  if (static_cast<std::int64_t>(faces.size()) + corners > kMaxCorners) {
    const std::string what = "face " + std::to_string(r.polygons_read) + " makes the mesh larger than " +
                             std::to_string(kMaxCorners / 3) + " triangles, the most ricci can index";
    return ctx.fail_at(Status::FileTooLarge, binary, line, what, Element::Face, r.polygons_read);
  }
  const std::size_t first_triangle = faces.size() / 3;
  append_fan(polygon, faces);
  if (polygon.size() > 3 && r.polygons_triangulated == 0) {
    // The first polygon that is not a triangle: every earlier triangle was its own polygon.
    r.triangle_polygon.resize(first_triangle);
    for (std::size_t f = 0; f < first_triangle; ++f) r.triangle_polygon[f] = static_cast<Index>(f);
  }
  if (polygon.size() > 3 || r.polygons_triangulated > 0)
    r.triangle_polygon.resize(faces.size() / 3, static_cast<Index>(r.polygons_read));
  ++r.polygons_read;
  if (polygon.size() > 3) ++r.polygons_triangulated;
  return true;
}

}  // namespace io_detail

// =============================================================================================
// Public API.

namespace fs = std::filesystem;
using io_detail::ReadContext;

const char* format_name(FileFormat format) {
  switch (format) {
    case FileFormat::Auto: return "automatic";
    case FileFormat::Obj: return "OBJ";
    case FileFormat::Off: return "OFF";
    case FileFormat::PlyAscii: return "ascii PLY";
    case FileFormat::PlyBinary: return "binary PLY";
    case FileFormat::StlAscii: return "ascii STL";
    case FileFormat::StlBinary: return "binary STL";
    case FileFormat::Gifti: return "GIFTI";
    case FileFormat::FreeSurfer: return "FreeSurfer surface";
  }
  return "unknown";
}

namespace {

/// The lower-case extension after the last dot of the file name ("" when none).
std::string lower_extension(std::string_view path) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  if (dot == std::string_view::npos || (slash != std::string_view::npos && dot < slash)) return {};
  std::string ext(path.substr(dot + 1));
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; });
  return ext;
}

}  // namespace

FileFormat format_from_path(std::string_view path) {
  const std::string ext = lower_extension(path);
  if (ext == "obj") return FileFormat::Obj;
  if (ext == "off") return FileFormat::Off;
  if (ext == "ply") return FileFormat::PlyBinary;
  if (ext == "stl") return FileFormat::StlBinary;
  if (ext == "gii") return FileFormat::Gifti;
  return FileFormat::Auto;
}

FileFormat format_from_content(std::string_view head) {
  auto byte = [&](std::size_t i) { return static_cast<unsigned char>(head[i]); };
  if (head.size() >= 3 && byte(0) == 0xFF && byte(1) == 0xFF && byte(2) == 0xFE) return FileFormat::FreeSurfer;
  if (head.substr(0, 3) == "ply" && head.size() > 3 && (head[3] == '\n' || head[3] == '\r'))
    return FileFormat::PlyBinary;
  std::string_view text = head.substr(0, 4096);
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return FileFormat::Auto;
  text.remove_prefix(first);
  if (text.substr(0, 5) == "<?xml" && text.find("<GIFTI") != std::string_view::npos) return FileFormat::Gifti;
  const std::size_t end = text.find_first_of(" \t\r\n");
  const std::string_view word = text.substr(0, end);
  for (const std::string_view keyword : {"OFF", "COFF", "NOFF", "CNOFF", "STOFF", "STCOFF"}) {
    if (word == keyword) return FileFormat::Off;
  }
  return FileFormat::Auto;
}

namespace {

std::string errno_text(int err) {
  return std::generic_category().message(err);
}

/// Closes a file descriptor when it goes out of scope.
class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const { return fd_; }
  /// Closes now and reports close()'s result (0 or an errno value).
  int close_now() {
    const int rc = ::close(fd_);
    fd_ = -1;
    return rc == 0 ? 0 : errno;
  }

 private:
  int fd_;
};

/// Records why a file with status `st` cannot be read as a mesh (a directory, not a regular
/// file, or larger than `max_bytes`); true when it can.
bool check_file_status(const struct stat& st, std::uint64_t max_bytes, ReadContext& ctx) {
  if (S_ISDIR(st.st_mode))
    return ctx.fail(Status::FileUnreadable, "the path is a directory, not a mesh file");
  // Pipes and devices may block or never end; only regular files are read.
  if (!S_ISREG(st.st_mode))
    return ctx.fail(Status::FileUnreadable, "the path is not a regular file (a pipe or a device)");
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size > max_bytes) {
    return ctx.fail(Status::FileTooLarge, "the file has " + std::to_string(size) +
                                              " bytes, more than the limit of " + std::to_string(max_bytes) +
                                              " (ReadOptions::max_file_bytes)");
  }
  return true;
}

/// Checks, without opening it, that `path` is an existing regular file of at most `max_bytes`.
/// Records FileNotFound, FileUnreadable or FileTooLarge otherwise.
bool check_file(const std::string& path, std::uint64_t max_bytes, ReadContext& ctx) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    if (err == ENOENT || err == ENOTDIR) return ctx.fail(Status::FileNotFound, "the file does not exist");
    return ctx.fail(Status::FileUnreadable, "the file cannot be read: " + errno_text(err));
  }
  return check_file_status(st, max_bytes, ctx);
}

/// Reads a whole regular file of at most `max_bytes` into `data` (the checks of check_file()
/// are repeated on the open file). Records FileUnreadable or FileTooLarge on failure.
bool load_file(const std::string& path, std::uint64_t max_bytes, std::string& data, ReadContext& ctx) {
  FileDescriptor fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK));
  if (fd.get() < 0)
    return ctx.fail(Status::FileUnreadable, "the file cannot be opened: " + errno_text(errno));
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0)
    return ctx.fail(Status::FileUnreadable, "the file cannot be read: " + errno_text(errno));
  if (!check_file_status(st, max_bytes, ctx)) return false;
  data.resize(static_cast<std::size_t>(st.st_size));
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::read(fd.get(), data.data() + done, data.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return ctx.fail(Status::FileUnreadable, "the file cannot be read: " + errno_text(errno));
    if (n == 0) break;  // the file shrank since fstat(); read what is there
    done += static_cast<std::size_t>(n);
  }
  data.resize(done);
  return true;
}

/// Records that no format was given and the name has no known extension.
void fail_unknown_format(ReadContext& ctx) {
  ctx.fail(Status::UnknownFormat,
           "the name has no .obj, .off, .ply, .stl or .gii extension and the content is not recognised "
           "(FreeSurfer, PLY, GIFTI or OFF); give the format explicitly");
}

std::string summary(const ReadResult& r) {
  std::string s = "read " + io_detail::count_of(r.mesh.num_vertices(), "vertex", "vertices") + " and " +
                  io_detail::count_of(r.mesh.num_faces(), "triangle", "triangles");
  if (r.polygons_triangulated > 0) {
    s += " (" + io_detail::count_of(r.polygons_triangulated, "polygon", "polygons") + " triangulated)";
  }
  if (r.format == FileFormat::StlAscii || r.format == FileFormat::StlBinary) {
    s += " (" + io_detail::count_of(r.welded_vertices, "corner", "corners") + " welded into earlier vertices)";
  }
  return s;
}

/// Parses bytes in a known format into ctx.result().
// OBJ and OFF are text: a file in another encoding (UTF-16, UTF-32) or with binary content is
// named as such instead of being read as lines that say nothing ("no faces"). The first 64 KiB
// decide: a byte-order mark of UTF-16/32, any NUL byte, or more than kMaxControlBytes control
// bytes other than whitespace and the DOS end-of-file mark (0x1A) that old files carry.
bool check_text(std::string_view data, ReadContext& ctx) {
  constexpr std::size_t kWindow = 64 * 1024;
  constexpr int kMaxControlBytes = 8;
  auto byte = [&](std::size_t i) { return static_cast<unsigned char>(data[i]); };
  const char* reread = ": re-save it as UTF-8 or ASCII text";
  if (data.size() >= 4 && ((byte(0) == 0xFF && byte(1) == 0xFE && byte(2) == 0 && byte(3) == 0) ||
                           (byte(0) == 0 && byte(1) == 0 && byte(2) == 0xFE && byte(3) == 0xFF)))
    return ctx.fail_at_byte(Status::ParseError, 0, std::string("the file is UTF-32 text (byte-order mark)") + reread);
  if (data.size() >= 2 && ((byte(0) == 0xFF && byte(1) == 0xFE) || (byte(0) == 0xFE && byte(1) == 0xFF)))
    return ctx.fail_at_byte(Status::ParseError, 0, std::string("the file is UTF-16 text (byte-order mark)") + reread);
  const std::size_t n = std::min(data.size(), kWindow);
  int control = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = byte(i);
    if (c == 0) {
      // UTF-16 without a mark has a NUL beside every ASCII character.
      const std::size_t partner = i ^ 1;  // the other byte of a UTF-16 code unit
      const bool utf16 = partner < n && byte(partner) != 0 &&
                         ((i + 2 < n && byte(i + 2) == 0) || (i >= 2 && byte(i - 2) == 0));
      return ctx.fail_at_byte(Status::ParseError, static_cast<std::int64_t>(i),
                              utf16 ? std::string("NUL bytes between the characters: UTF-16 text without a "
                                                  "byte-order mark") + reread
                                    : std::string("a NUL byte: binary content, not a text mesh file"));
    }
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\v' && c != '\f' && c != '\r' && c != 0x1A && ++control > kMaxControlBytes) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02X", c);
      return ctx.fail_at_byte(Status::ParseError, static_cast<std::int64_t>(i),
                              std::string("control byte ") + hex + " (the " + std::to_string(control) +
                                  "th in the first 64 KiB): binary content, not a text mesh file");
    }
  }
  return true;
}

void parse_bytes(std::string_view data, FileFormat format, const ReadOptions& options, ReadContext& ctx) {
  ReadResult& r = ctx.result();
  if (format == FileFormat::Auto) return fail_unknown_format(ctx);
  r.format = format;
  if ((format == FileFormat::Obj || format == FileFormat::Off) && !check_text(data, ctx)) return;
  bool ok = false;
  switch (format) {
    case FileFormat::Obj:
      ok = io_detail::read_obj(data, ctx, options);
      break;
    case FileFormat::Off:
      ok = io_detail::read_off(data, ctx);
      break;
    case FileFormat::PlyAscii:
    case FileFormat::PlyBinary:
      ok = io_detail::read_ply(data, ctx);
      break;
    case FileFormat::StlAscii:
    case FileFormat::StlBinary:
      ok = io_detail::read_stl(data, ctx, options);
      break;
    case FileFormat::Gifti:
      ok = io_detail::read_gifti(data, ctx);
      break;
    case FileFormat::FreeSurfer:
      ok = io_detail::read_freesurfer(data, ctx);
      break;
    case FileFormat::Auto:
      break;
  }
  if (!ok) return;
  r.status = Status::Ok;
  r.message = std::string(ctx.name()) + ": " + summary(r);
  r.line = -1;
  r.element = Element::None;
  r.element_index = -1;
}

/// Runs `body` and turns exceptions (only allocation failures are expected) into a status.
template <class Body>
void guarded_read(ReadContext& ctx, Body&& body) {
  try {
    body();
  } catch (const std::bad_alloc&) {
    ctx.fail(Status::FileTooLarge, "not enough memory to read the mesh");
  } catch (const std::length_error&) {
    ctx.fail(Status::FileTooLarge, "the mesh is too large to hold in memory");
  } catch (const std::exception& e) {
    ctx.fail(Status::ParseError, std::string("unexpected error while reading: ") + e.what());
  } catch (...) {
    ctx.fail(Status::ParseError, "unexpected error while reading");
  }
}

}  // namespace

ReadResult read_mesh(const std::string& path, const ReadOptions& options) {
  ReadResult r;
  ReadContext ctx(path, r);
  guarded_read(ctx, [&] {
    if (!check_file(path, options.max_file_bytes, ctx)) return;
    FileFormat format = options.format == FileFormat::Auto ? format_from_path(path) : options.format;
    std::string data;
    if (!load_file(path, options.max_file_bytes, data, ctx)) return;
    if (format == FileFormat::Auto) format = format_from_content(data);
    parse_bytes(data, format, options, ctx);
  });
  return r;
}

ReadResult read_mesh_from_memory(std::string_view data, const std::string& name, const ReadOptions& options) {
  ReadResult r;
  ReadContext ctx(name, r);
  guarded_read(ctx, [&] {
    if (data.size() > options.max_file_bytes) {
      ctx.fail(Status::FileTooLarge,
               "the data has " + std::to_string(data.size()) + " bytes, more than the limit of " +
                   std::to_string(options.max_file_bytes) + " (ReadOptions::max_file_bytes)");
      return;
    }
    FileFormat format = options.format == FileFormat::Auto ? format_from_path(name) : options.format;
    if (format == FileFormat::Auto) format = format_from_content(data);
    parse_bytes(data, format, options, ctx);
  });
  return r;
}

// ---------------------------------------------------------------------------------------------
// Writing.

namespace {

/// Appends the mesh in `format` (nothing for Auto). May throw std::bad_alloc.
void append_mesh(const Mesh& mesh, FileFormat format, bool write_texcoords, std::string& out) {
  switch (format) {
    case FileFormat::Obj:
      io_detail::append_obj(mesh, write_texcoords, out);
      break;
    case FileFormat::Off:
      io_detail::append_off(mesh, out);
      break;
    case FileFormat::PlyAscii:
      io_detail::append_ply(mesh, false, out);
      break;
    case FileFormat::PlyBinary:
      io_detail::append_ply(mesh, true, out);
      break;
    case FileFormat::StlAscii:
      io_detail::append_stl(mesh, false, out);
      break;
    case FileFormat::StlBinary:
      io_detail::append_stl(mesh, true, out);
      break;
    case FileFormat::Gifti:
      io_detail::append_gifti(mesh, out);
      break;
    case FileFormat::FreeSurfer:
      io_detail::append_freesurfer(mesh, out);
      break;
    case FileFormat::Auto:
      break;
  }
}

}  // namespace

bool serialize_mesh_to(const Mesh& mesh, FileFormat format, const ByteSink& sink, bool write_texcoords) {
  if (format == FileFormat::Auto) return false;
  try {
    std::string out;
    if (format == FileFormat::Obj) {
      if (!io_detail::append_obj(mesh, write_texcoords, out, &sink)) return false;
    } else {
      append_mesh(mesh, format, write_texcoords, out);
    }
    return out.empty() || sink(out);
  } catch (const std::exception&) {
    return false;  // out of memory
  }
}

std::string serialize_mesh(const Mesh& mesh, FileFormat format, bool write_texcoords) {
  std::string out;
  try {
    append_mesh(mesh, format, write_texcoords, out);
  } catch (const std::exception&) {
    out.clear();  // out of memory: an empty string is never a valid serialisation
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Overlays.

namespace {

OverlayFormat overlay_format(std::string_view name, std::string_view data) {
  if (lower_extension(name) == "gii") return OverlayFormat::GiftiFunc;
  if (data.size() >= 3 && static_cast<unsigned char>(data[0]) == 0xFF && static_cast<unsigned char>(data[1]) == 0xFF &&
      static_cast<unsigned char>(data[2]) == 0xFF)
    return OverlayFormat::FreeSurferCurv;
  if (format_from_content(data) == FileFormat::Gifti) return OverlayFormat::GiftiFunc;
  return OverlayFormat::Auto;
}

/// Parses overlay bytes; failures go through ctx (a scratch ReadResult) and are copied to out.
void parse_overlay(std::string_view data, OverlayFormat format, ReadContext& ctx, OverlayReadResult& out) {
  if (format == OverlayFormat::Auto) format = overlay_format(ctx.name(), data);
  out.format = format;
  bool ok = false;
  if (format == OverlayFormat::GiftiFunc) {
    ok = io_detail::read_gifti_overlay(data, ctx, out);
  } else if (format == OverlayFormat::FreeSurferCurv) {
    ok = io_detail::read_curv(data, ctx, out);
  } else {
    ctx.fail(Status::UnknownFormat,
             "not a GIFTI functional file (.gii) nor a FreeSurfer curv file (magic FF FF FF); give the format");
  }
  if (!ok) return;
  ctx.result().status = Status::Ok;
  std::size_t values = out.arrays.empty() ? 0 : out.arrays.front().size();
  ctx.result().message = std::string(ctx.name()) + ": read " + io_detail::count_of(static_cast<std::int64_t>(out.arrays.size()), "array", "arrays") +
                         " of " + io_detail::count_of(static_cast<std::int64_t>(values), "value", "values");
}

OverlayReadResult overlay_read(std::string_view name, const std::function<void(ReadContext&, OverlayReadResult&)>& body) {
  OverlayReadResult out;
  ReadResult scratch;
  ReadContext ctx(name, scratch);
  guarded_read(ctx, [&] { body(ctx, out); });
  out.status = scratch.status;
  out.message = scratch.message;
  out.line = scratch.line;
  if (out.status != Status::Ok) {
    out.arrays.clear();
    out.names.clear();
  }
  return out;
}

}  // namespace

OverlayReadResult read_overlay(const std::string& path, const ReadOptions& options, OverlayFormat format) {
  return overlay_read(path, [&](ReadContext& ctx, OverlayReadResult& out) {
    if (!check_file(path, options.max_file_bytes, ctx)) return;
    std::string data;
    if (!load_file(path, options.max_file_bytes, data, ctx)) return;
    parse_overlay(data, format, ctx, out);
  });
}

OverlayReadResult read_overlay_from_memory(std::string_view data, const std::string& name, OverlayFormat format) {
  return overlay_read(name, [&](ReadContext& ctx, OverlayReadResult& out) { parse_overlay(data, format, ctx, out); });
}

std::string serialize_overlay(std::span<const double> values, OverlayFormat format, std::string_view name,
                              std::int64_t num_faces) {
  std::string out;
  for (const double v : values) {
    if (!io_detail::is_finite_bits(v)) return out;
  }
  try {
    if (format == OverlayFormat::GiftiFunc) io_detail::append_gifti_overlay(values, name, out);
    if (format == OverlayFormat::FreeSurferCurv) io_detail::append_curv(values, num_faces, out);
  } catch (const std::exception&) {
    out.clear();
  }
  return out;
}

namespace {

/// "file.obj: what".
WriteResult write_failure(Status status, const std::string& path, const std::string& what) {
  WriteResult r;
  r.status = status;
  r.message = path + ": " + what;
  return r;
}

/// `a` and `b` name the same file: equivalent existing files, or the same lexically normalised
/// absolute path (also when neither exists yet).
bool same_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::equivalent(a, b, ec) && !ec) return true;
  const fs::path na = fs::absolute(a, ec).lexically_normal();
  if (ec) return false;
  const fs::path nb = fs::absolute(b, ec).lexically_normal();
  if (ec) return false;
  return na == nb;
}

/// Checks that `path` may be written: not protected, not a directory. Fills `r` when not.
bool check_target(const std::string& path, const std::vector<std::string>& protected_paths, WriteResult& r) {
  if (path.empty()) {
    r = write_failure(Status::WriteFailed, path, "the output path is empty");
    return false;
  }
  for (const std::string& p : protected_paths) {
    if (!p.empty() && same_file(path, p)) {
      r = write_failure(Status::OutputIsInput, path,
                        "refusing to write: this is the protected file " + p + " (typically the input)");
      return false;
    }
  }
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    r = write_failure(Status::WriteFailed, path, "the output path is a directory");
    return false;
  }
  if (fs::path(path).filename().empty()) {
    r = write_failure(Status::WriteFailed, path, "the output path names no file");
    return false;
  }
  return true;
}

/// Opens a new, uniquely named temporary file beside `target` with O_EXCL (the permissions then
/// follow the umask like any new file). Returns the descriptor or -1 with errno set.
int create_temporary(const fs::path& target, std::string& temp_path) {
  static std::atomic<std::uint64_t> counter{0};
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string stem = target.filename().string().substr(0, 100);  // stay below NAME_MAX
  for (int attempt = 0; attempt < 100; ++attempt) {
    const auto tick = static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
    const std::uint64_t unique = tick ^ (counter.fetch_add(1) * 0x9e3779b97f4a7c15ull);
    temp_path = (dir / ("." + stem + ".ricci-tmp-" + std::to_string(::getpid()) + "-" +
                        std::to_string(unique % 1000000007ull)))
                    .string();
    const int fd = ::open(temp_path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0 || errno != EEXIST) return fd;
  }
  errno = EEXIST;
  return -1;
}

/// Explains why a temporary file could not be created in `dir`.
std::string create_error_text(int err, const fs::path& dir) {
  const std::string d = dir.empty() ? std::string(".") : dir.string();
  if (err == ENOENT) return "cannot write: the directory " + d + " does not exist";
  if (err == ENOTDIR) return "cannot write: " + d + " is not a directory";
  if (err == EACCES || err == EPERM) return "cannot write: permission denied in the directory " + d;
  return "cannot create a temporary file in " + d + ": " + errno_text(err);
}

/// Writes all of `data` to `fd`, retrying partial writes. Returns 0 or an errno value.
int write_all(int fd, std::string_view data) {
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno;
    done += static_cast<std::size_t>(n);
  }
  return 0;
}

/// Flushes the directory entry of a rename to disk (best effort).
void sync_directory(const fs::path& dir) {
  const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

/// Writes the bytes `produce` hands its sink to a temporary file beside `path`, then renames it
/// over `path`. On failure (of a write, or `produce` returning false) the temporary is removed
/// and `path` is untouched.
WriteResult write_atomically(const std::string& path, const std::function<bool(const ByteSink&)>& produce) {
  const fs::path target(path);
  std::string temp;
  FileDescriptor fd(create_temporary(target, temp));
  if (fd.get() < 0)
    return write_failure(Status::WriteFailed, path, create_error_text(errno, target.parent_path()));
  auto abandon = [&](const std::string& what, int err) {
    if (fd.get() >= 0) fd.close_now();
    ::unlink(temp.c_str());
    return write_failure(Status::WriteFailed, path, what + ": " + errno_text(err));
  };
  int write_error = 0;
  std::uint64_t written = 0;
  const bool produced = produce([&](std::string_view piece) {
    write_error = write_all(fd.get(), piece);
    written += piece.size();
    return write_error == 0;
  });
  if (write_error != 0) return abandon("cannot write", write_error);
  if (!produced) return abandon("cannot serialise the data", ENOMEM);
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) ::fchmod(fd.get(), st.st_mode & 07777);
  if (::fsync(fd.get()) != 0 && errno != EINVAL && errno != ENOTSUP) {  // those: fsync unsupported here
    return abandon("cannot flush to disk", errno);
  }
  if (const int err = fd.close_now()) return abandon("cannot close", err);
  if (::rename(temp.c_str(), path.c_str()) != 0) return abandon("cannot replace the file", errno);
  sync_directory(target.parent_path());
  WriteResult r;
  r.status = Status::Ok;
  r.bytes_written = written;
  r.message = path + ": wrote " + io_detail::count_of(static_cast<std::int64_t>(written), "byte", "bytes");
  return r;
}

/// Checks that a mesh's buffers can be written and read back: sizes, index ranges, finite
/// coordinates. Texture coordinates are checked only when they will be written.
bool check_mesh(const std::string& path, const Mesh& mesh, bool texcoords, WriteResult& r) {
  auto refuse = [&](const std::string& what) {
    r = write_failure(Status::InvalidArgument, path, "cannot write the mesh: " + what);
    return false;
  };
  if (mesh.positions.size() % 3 != 0) return refuse("positions.size() is not a multiple of 3");
  if (mesh.faces.size() % 3 != 0) return refuse("faces.size() is not a multiple of 3");
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    if (!io_detail::is_finite_bits(mesh.positions[i]))
      return refuse("vertex " + std::to_string(i / 3) + " has a non-finite coordinate");
  }
  const Index nv = mesh.num_vertices();
  for (std::size_t c = 0; c < mesh.faces.size(); ++c) {
    if (mesh.faces[c] < 0 || mesh.faces[c] >= nv)
      return refuse("face " + std::to_string(c / 3) + " refers to vertex " + std::to_string(mesh.faces[c]) +
                    ", but the mesh has " + io_detail::count_of(nv, "vertex", "vertices"));
  }
  if (!texcoords || !mesh.has_texcoords()) return true;
  if (mesh.corner_texcoords.size() != mesh.faces.size())
    return refuse("corner_texcoords.size() differs from faces.size()");
  if (mesh.texcoords.size() % 2 != 0) return refuse("texcoords.size() is not a multiple of 2");
  for (std::size_t i = 0; i < mesh.texcoords.size(); ++i) {
    if (!io_detail::is_finite_bits(mesh.texcoords[i]))
      return refuse("texture coordinate " + std::to_string(i / 2) + " is not finite");
  }
  const Index nt = mesh.num_texcoords();
  for (std::size_t c = 0; c < mesh.corner_texcoords.size(); ++c) {
    if (mesh.corner_texcoords[c] < 0 || mesh.corner_texcoords[c] >= nt)
      return refuse("corner " + std::to_string(c) + " refers to texture coordinate " +
                    std::to_string(mesh.corner_texcoords[c]) + ", but the mesh has " + std::to_string(nt));
  }
  return true;
}

}  // namespace

WriteResult write_file_atomic(const std::string& path, std::string_view data,
                              const std::vector<std::string>& protected_paths) {
  try {
    WriteResult r;
    if (!check_target(path, protected_paths, r)) return r;
    return write_atomically(path, [&](const ByteSink& sink) { return sink(data); });
  } catch (const std::exception& e) {
    return write_failure(Status::WriteFailed, path, std::string("cannot write: ") + e.what());
  }
}

WriteResult write_mesh(const std::string& path, const Mesh& mesh, const WriteOptions& options) {
  try {
    WriteResult r;
    const FileFormat format = options.format == FileFormat::Auto ? format_from_path(path) : options.format;
    if (format == FileFormat::Auto) {
      return write_failure(Status::UnknownFormat, path,
                           "the name has no .obj, .off, .ply, .stl or .gii extension; give the format explicitly");
    }
    const bool texcoords = format == FileFormat::Obj && options.write_texcoords;
    if (!check_target(path, options.protected_paths, r)) return r;
    if (!check_mesh(path, mesh, texcoords, r)) return r;
    if (io_detail::single_precision(format)) {
      constexpr double kMax = std::numeric_limits<float>::max();
      for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        if (std::abs(mesh.positions[i]) > kMax) {
          return write_failure(Status::InvalidArgument, path,
                               "cannot write the mesh: vertex " + std::to_string(i / 3) +
                                   " has a coordinate beyond the range of single precision, which " +
                                   format_name(format) + " stores");
        }
      }
    }
    return write_atomically(path,
                            [&](const ByteSink& sink) { return serialize_mesh_to(mesh, format, sink, texcoords); });
  } catch (const std::exception& e) {
    return write_failure(Status::WriteFailed, path, std::string("cannot write: ") + e.what());
  }
}

}  // namespace ricci
