// ricci — reading and writing OBJ, OFF, PLY, STL, GIFTI and FreeSurfer surfaces, and per-vertex
// overlays (GIFTI functional files, FreeSurfer curv files).
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
//   STL  binary (80-byte header, triangle count, 50 bytes per triangle; chosen when the size is
//        84 + 50·count, whatever the header says) and ascii (`solid` … `facet` / `outer loop` /
//        three `vertex x y z` / `endloop` / `endfacet` … `endsolid`, several solids appended).
//        STL stores every triangle's corners separately: corners are welded into vertices by
//        exact coordinates, or within ReadOptions::weld_tolerance; ReadResult::welded_vertices
//        says how many corners were merged away. Normals and attribute bytes are ignored.
//   GIFTI (.gii, e.g. .surf.gii) the data arrays of intent NIFTI_INTENT_POINTSET (#V×3) and
//        NIFTI_INTENT_TRIANGLE (#F×3); ASCII, Base64Binary and GZipBase64Binary encodings, both
//        endiannesses, row- and column-major order, FLOAT32/FLOAT64 coordinates and INT32/UINT8/
//        other integer indices; the XML is parsed by expat, the compressed data inflated by zlib.
//   FreeSurfer binary triangle surfaces (lh.white, lh.pial, lh.sphere, …: no extension, known by
//        their magic number FF FF FE): the created-by line, big-endian vertex and face counts,
//        float32 coordinates and int32 indices; trailing tags are ignored.
//
// STL, GIFTI and FreeSurfer surfaces are single precision on write (float32 coordinates: what the
// formats and their tools hold); a mesh whose coordinates are floats round-trips exactly.
// Numbers are parsed locale-independently. Memory reserved for declared counts is capped by what
// the remaining bytes can hold, so a hostile header cannot exhaust memory: a file shorter than
// its header says is a ParseError naming what was expected and where the file ended. Only regular
// files are read (a pipe or device is FileUnreadable). Errors name the file, the line (text) or
// byte offset (binary), and the element.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <functional>
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
  StlAscii,   ///< STL, ascii
  StlBinary,  ///< STL, binary (the writers' default for .stl); either encoding on read
  Gifti,      ///< GIFTI surface (.gii): GZipBase64Binary little-endian on write
  FreeSurfer, ///< FreeSurfer binary triangle surface (no extension; recognised by its magic number)
};

/// Name of a format for messages and reports ("OBJ", "binary STL", "GIFTI", …).
const char* format_name(FileFormat format);

/// Format named by a path's extension, or FileFormat::Auto when it names none.
/// For ".ply" returns FileFormat::PlyBinary (writers' default for PLY), for ".stl" StlBinary, for
/// ".gii" Gifti. FreeSurfer surfaces have no extension: see format_from_content().
FileFormat format_from_path(std::string_view path);

/// Format recognised from the first bytes of a file: FreeSurfer (magic FF FF FE), PLY ("ply"),
/// GIFTI (an XML declaration followed by <GIFTI), OFF (an OFF keyword); Auto otherwise (OBJ and
/// STL have no reliable signature). read_mesh() uses it when the name has no known extension.
FileFormat format_from_content(std::string_view head);

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
  /// STL only: corners closer than this (Euclidean distance, in the file's units) become one
  /// vertex; 0 welds only corners with identical coordinates. Clusters are formed greedily in
  /// file order: a corner joins the first earlier vertex within the tolerance. Negative or
  /// non-finite values are refused (InvalidArgument).
  double weld_tolerance = 0;
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
  /// STL: corners merged into an earlier vertex by welding (3·#F − #V). 0 for other formats.
  std::int64_t welded_vertices = 0;
  /// What the file said about itself, for `ricci info`: the STL header or solid name, the GIFTI
  /// data arrays' encodings, data types, endianness and order, the FreeSurfer created-by line.
  std::string format_details;
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
/// output) for FileFormat::Auto or when memory runs out.
std::string serialize_mesh(const Mesh& mesh, FileFormat format, bool write_texcoords = true);

/// Receives a serialisation piece by piece, in order; returns false to stop it (a failed write).
using ByteSink = std::function<bool(std::string_view)>;

/// The bytes of serialize_mesh(), handed to `sink` as they are made: OBJ in pieces of about 1 MB,
/// so that a large mesh is never one string in memory; the other formats in one piece. Returns
/// false for FileFormat::Auto, when memory runs out or when `sink` returns false (the bytes handed
/// over until then are a prefix of serialize_mesh()'s). Used by write_mesh().
bool serialize_mesh_to(const Mesh& mesh, FileFormat format, const ByteSink& sink, bool write_texcoords = true);

// ---------------------------------------------------------------------------------------------
// Per-vertex overlays: one value per vertex of a surface, as neuroimaging viewers (Connectome
// Workbench, freeview) display them on it.

enum class OverlayFormat : int {
  Auto = 0,        ///< from the name (.gii) or the content (FreeSurfer's magic FF FF FF)
  GiftiFunc,       ///< GIFTI functional file (.func.gii / .shape.gii): FLOAT32 arrays
  FreeSurferCurv,  ///< FreeSurfer "new" curv file: magic FF FF FF, #V, #F, 1, big-endian float32
};

/// What read_overlay() and read_overlay_from_memory() return.
struct OverlayReadResult {
  /// Ok, or a failure as for read_mesh() (FileNotFound, FileUnreadable, UnknownFormat,
  /// FileTooLarge, ParseError, NonFiniteCoordinate for a value that is NaN or infinite).
  Status status = Status::NotRun;
  std::string message = "not run";  ///< "<name>: …" as for read_mesh()
  std::int64_t line = -1;           ///< byte offset (binary) or XML line of an error; -1 when unknown
  OverlayFormat format = OverlayFormat::Auto;  ///< format actually read
  /// One array per GIFTI data array (one for a curv file), each with one value per vertex.
  std::vector<std::vector<double>> arrays;
  /// The arrays' names: GIFTI's `Name` metadata ("" when absent); "" for a curv file.
  std::vector<std::string> names;
  /// Curv files: the face count stored in the header (-1 for GIFTI).
  std::int64_t num_faces = -1;
};

/// Reads a per-vertex overlay file. Never throws.
OverlayReadResult read_overlay(const std::string& path, const ReadOptions& options = {},
                               OverlayFormat format = OverlayFormat::Auto);
OverlayReadResult read_overlay_from_memory(std::string_view data, const std::string& name,
                                           OverlayFormat format = OverlayFormat::Auto);

/// Serialises per-vertex values (finite; stored as float32) as an overlay. GIFTI: one FLOAT32
/// data array of intent NIFTI_INTENT_SHAPE, GZipBase64Binary, with `name` as its Name metadata.
/// Curv: the header records `num_faces` (the surface's face count, as FreeSurfer expects).
/// Empty string for Auto, a non-finite value or when memory runs out.
std::string serialize_overlay(std::span<const double> values, OverlayFormat format, std::string_view name,
                              std::int64_t num_faces);

}  // namespace ricci
