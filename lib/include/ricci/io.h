// ricci — reading and writing OBJ, OFF and PLY.
//
// Readers turn a file into a Mesh (a triangle soup: nothing is validated beyond what the format
// itself requires). Polygons with more than three sides are fan-triangulated
// (v0 v1 v2, v0 v2 v3, …) and counted. Use load_mesh() in validate.h to read *and* validate.
//
//   OBJ  `v x y z [w]` (extra colour columns ignored), `vt u v [w]`, `f` with `v`, `v/vt`,
//        `v//vn`, `v/vt/vn` tokens, 1-based and negative (relative) indices; `vn`, `g`, `o`, `s`,
//        `usemtl`, `mtllib`, `l`, `p`, comments and unknown statements are skipped; CRLF and
//        backslash line continuations are accepted.
//   OFF  optional comment / blank lines before the keyword; OFF, COFF, NOFF, CNOFF, STOFF (extra
//        vertex columns ignored); counts on the keyword line or the next; `#` comments anywhere;
//        face lines `n i0 … i(n-1) [colour]`, 0-based.
//   PLY  ascii, binary_little_endian and binary_big_endian; element `vertex` with properties x, y,
//        z of any scalar type; element `face` with a list property `vertex_indices` (or
//        `vertex_index`); all other elements and properties are skipped.
//
// Numbers are parsed locale-independently. Memory reserved for declared counts is capped by what
// the remaining bytes can hold, so a hostile header cannot exhaust memory: a file shorter than
// its header says is a ParseError naming what was expected and where the file ended. Only regular
// files are read (a pipe or device is FileUnreadable). Errors name the file, the line (text) or
// byte offset (binary), and the element.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "ricci/mesh.h"
#include "ricci/status.h"

namespace ricci {

/// Mesh file format, for reading and writing.
enum class FileFormat : int {
  Auto = 0,   ///< from the file extension (.obj, .off, .ply; case-insensitive)
  Obj,        ///< Wavefront OBJ (text)
  Off,        ///< OFF (text)
  PlyAscii,   ///< PLY, ascii encoding
  PlyBinary,  ///< binary little-endian on write; either endianness on read
};

/// Format named by a path's extension, or FileFormat::Auto when it names none.
/// For ".ply" returns FileFormat::PlyBinary (writers' default for PLY).
FileFormat format_from_path(std::string_view path);

/// Options of read_mesh() and read_mesh_from_memory().
struct ReadOptions {
  /// Format of the file; Auto picks it from the extension (and, for PLY, from the header).
  FileFormat format = FileFormat::Auto;
  /// Refuse files larger than this many bytes (Status::FileTooLarge, the message states the size
  /// and the limit) after one stat() and before reading any byte. A file is read whole into
  /// memory and parsed from there, so reading needs about its size plus the mesh (reservations
  /// for declared counts are capped by the bytes present, see above). The default, 2 GiB, holds
  /// some 30M triangles as OBJ text, far beyond what the flow handles in memory here.
  std::uint64_t max_file_bytes = std::uint64_t{2} << 30;
  /// Read texture coordinates (OBJ `vt`) into Mesh::texcoords / corner_texcoords.
  bool read_texcoords = true;
};

/// What read_mesh() and read_mesh_from_memory() return.
struct ReadResult {
  /// Ok, FileNotFound, FileUnreadable, UnknownFormat, FileTooLarge (also when memory runs out),
  /// ParseError, IndexOutOfRange (a face names a vertex the file does not have) or
  /// NonFiniteCoordinate.
  Status status = Status::NotRun;
  /// "<name>: …" naming the problem, with "line N: " or "byte N: " after the name when the place
  /// is known; on success "<name>: read V vertices and F triangles" (and the polygons triangulated).
  std::string message = "not run";
  /// 1-based line of a text file, or byte offset of a binary file, where an error was found;
  /// -1 when not applicable.
  std::int64_t line = -1;
  /// Element an error refers to (e.g. Element::Face and its 0-based index in file order).
  Element element = Element::None;
  std::int64_t element_index = -1;  ///< index of that element; -1 when element is None

  /// The triangle soup as read (valid only when status is Ok).
  Mesh mesh;
  /// Number of input polygons with more than three sides (each was fan-triangulated).
  std::int64_t polygons_triangulated = 0;
  /// Number of input polygons read (before triangulation).
  std::int64_t polygons_read = 0;
  /// #F when any polygon was triangulated: triangle → index of its polygon in the file (0-based,
  /// file order). Empty when every polygon was a triangle (triangle f is polygon f).
  std::vector<Index> triangle_polygon;
  /// Format that was actually read.
  FileFormat format = FileFormat::Auto;
};

/// Reads a mesh file. Never throws; every failure is a status with a message naming `path`.
ReadResult read_mesh(const std::string& path, const ReadOptions& options = {});

/// Reads a mesh from bytes already in memory. `name` is used in messages in place of a path.
/// `options.format` must not be Auto unless `name` has a known extension.
ReadResult read_mesh_from_memory(std::string_view data, const std::string& name,
                                 const ReadOptions& options = {});

/// Options of write_mesh().
struct WriteOptions {
  /// Format to write; Auto picks it from the extension (.ply → binary little-endian).
  FileFormat format = FileFormat::Auto;
  /// OBJ only: write `vt` lines and `f v/vt` when the mesh has per-corner texture coordinates.
  bool write_texcoords = true;
  /// Files that must never be replaced (typically the input). Writing to a path that is the
  /// same file as any of these fails with Status::OutputIsInput and touches nothing.
  std::vector<std::string> protected_paths;
};

/// What write_mesh() and write_file_atomic() return.
struct WriteResult {
  Status status = Status::NotRun;   ///< Ok, or a failure as listed at write_mesh()
  std::string message = "not run";  ///< "<path>: …" naming the problem; "<path>: wrote N bytes" on success
  std::uint64_t bytes_written = 0;  ///< size of the file written (0 unless status is Ok)
};

/// Writes a mesh atomically: the data goes to a temporary file in the same directory, which is
/// renamed over `path` only when complete. On failure nothing is left behind and an existing
/// file at `path` is unchanged. Numbers are written so that reading them back gives the same
/// bits (shortest round-trip decimal for text formats, IEEE doubles for binary PLY).
/// Statuses: InvalidArgument for a mesh that could not be read back (buffer sizes, indices out of
/// range, non-finite values), UnknownFormat for an unknown extension with FileFormat::Auto,
/// OutputIsInput, WriteFailed.
WriteResult write_mesh(const std::string& path, const Mesh& mesh, const WriteOptions& options = {});

/// Writes `data` to `path` atomically (temporary file in the same directory + rename), refusing
/// `protected_paths` as write_mesh() does. For reports and other non-mesh outputs.
WriteResult write_file_atomic(const std::string& path, std::string_view data,
                              const std::vector<std::string>& protected_paths = {});

/// Serialises a mesh to bytes in the given format. Returns an empty string (never a valid
/// output) for FileFormat::Auto or when memory runs out. Used by write_mesh().
std::string serialize_mesh(const Mesh& mesh, FileFormat format, bool write_texcoords = true);

}  // namespace ricci
