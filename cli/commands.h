// ricci command-line driver: the subcommands and the mapping of library statuses to exit codes.
//
// The CLI holds no geometry logic: it calls the library (io.h, validate.h) and turns its results
// into text, JSON and exit codes. Messages go to stderr prefixed "ricci: "; reports go to stdout.
//
// Exit codes (also listed in the --help footer):
//   0  success
//   1  unexpected internal error (an exception reached main, out_of_memory, or a status the CLI
//      does not expect: not_run, and the metric/flow statuses, which no subcommand produces yet)
//   2  usage error: bad arguments or options (every CLI11 parse error)
//   3  the input cannot be opened: file_not_found, file_unreadable, unknown_format, file_too_large
//   4  malformed file content: parse_error, index_out_of_range, non_finite_coordinate
//   5  invalid mesh: no_faces, degenerate_face, duplicate_face, non_manifold_edge,
//      non_manifold_vertex, inconsistent_orientation, non_orientable, multiple_components
//   6  output failure: write_failed, output_is_input (also: standard output cannot be written)
#pragma once

#include <string>
#include <string_view>

#include "ricci/status.h"

namespace ricci_cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitInternal = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitInputUnavailable = 3;
inline constexpr int kExitMalformedInput = 4;
inline constexpr int kExitInvalidMesh = 5;
inline constexpr int kExitOutputFailure = 6;

/// The exit code for a library status (the table above). The one place this mapping lives.
int exit_code(ricci::Status status);

/// `ricci info [MESH]`: describes a mesh file (or the embedded default mesh when `mesh` is empty).
struct InfoOptions {
  std::string mesh;                    ///< input path; empty: the embedded default mesh
  bool json = false;                   ///< one JSON object on stdout instead of text
  bool largest_component = false;      ///< keep the largest component instead of failing
  bool no_repair_orientation = false;  ///< inconsistent orientation is an error, not repaired
  bool quiet = false;                  ///< no notes on stderr (errors are still printed)
};
int run_info(const InfoOptions& options);

/// `ricci convert IN -o OUT`: rewrites a mesh in another format (optionally validated first).
struct ConvertOptions {
  std::string input;
  std::string output;
  bool validate = false;           ///< validate and repair before writing
  bool largest_component = false;  ///< with validate: keep the largest component
  std::string format;              ///< "obj", "off", "ply", "ply-ascii"; empty: from OUT's extension
  bool quiet = false;
};
int run_convert(const ConvertOptions& options);

/// Parses the command line and runs the chosen subcommand; returns the process exit code.
/// May throw std::exception on an internal error (main() maps that to kExitInternal).
int run(int argc, const char* const* argv);

/// The embedded default mesh (bytes of fixtures/genus2.obj) and its name; generated at build time
/// by cli/embed.cmake into embedded_default.cpp.
std::string_view embedded_default_mesh();
const char* embedded_default_name();

}  // namespace ricci_cli
