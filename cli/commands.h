// ricci command-line driver: the subcommands and the mapping of library statuses to exit codes.
//
// The CLI holds no geometry logic: it calls the library (io.h, validate.h, metric.h, flow.h) and
// turns its results into text, JSON and exit codes. Messages go to stderr prefixed "ricci: ";
// reports go to stdout. `info` and `convert` live in commands.cpp, each other subcommand in its folder (README.md).
//
// Exit codes (also listed in the --help footer):
//   0  success
//   1  unexpected internal error (an exception reached main, out_of_memory, or not_run)
//   2  usage error: bad arguments or options (every CLI11 parse error)
//   3  the input cannot be opened: file_not_found, file_unreadable, unknown_format, file_too_large
//   4  malformed file content: parse_error, index_out_of_range, non_finite_coordinate
//   5  invalid mesh: no_faces, degenerate_face, duplicate_face, non_manifold_edge,
//      non_manifold_vertex, inconsistent_orientation, non_orientable, multiple_components
//   6  output failure: write_failed, output_is_input (also: standard output cannot be written)
//   7  the flow failed: not_converged, line_search_failed, numerical_failure, triangle_inequality
//   8  infeasible target curvature: infeasible_target (Gauss–Bonnet or admissibility violated)
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ricci/metric.h"
#include "ricci/signature.h"
#include "ricci/status.h"
#include "ricci/validate.h"

namespace CLI {
class App;
}  // namespace CLI

namespace ricci_cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitInternal = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitInputUnavailable = 3;
inline constexpr int kExitMalformedInput = 4;
inline constexpr int kExitInvalidMesh = 5;
inline constexpr int kExitOutputFailure = 6;
inline constexpr int kExitFlowFailed = 7;
inline constexpr int kExitInfeasibleTarget = 8;

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

/// `ricci flow [MESH]`: load → initial metric → target → check → solve_flow, with progress on
/// stderr, a summary (text or --json) on stdout and optionally the metric written to a file.
/// Option values are the strings of the command line (checked again here, so callers other than
/// the parser get a usage error, not an exception, for a bad value).
struct FlowCommandOptions {
  std::string mesh;                        ///< input path; empty: the embedded default mesh
  std::string geometry = "auto";           ///< auto, euclidean, hyperbolic, spherical
  std::string scheme = "auto";             ///< auto (= yamabe), circle-packing, inversive-distance, yamabe
  std::string target = "auto";             ///< auto, uniform, cones=FILE, single-vertex=I
  std::string boundary = "auto";           ///< auto, free, fixed, circle, geodesic, loop-totals=T1,…
  std::string method = "newton";           ///< newton, gradient
  double tolerance = 1e-10;                ///< max |K̄ − K| at convergence
  int max_iterations = 0;                  ///< 0: 200 for newton, 20000 for gradient
  double step = 0.05;                      ///< gradient-descent step
  int threads = 0;                         ///< OpenMP threads; 0: the OpenMP default
  std::string output;                      ///< -o OUT; empty: write no file
  bool json = false;                       ///< summary as one JSON object on stdout
  bool quiet = false;                      ///< no progress or notes on stderr
  bool largest_component = false;          ///< keep the largest component instead of failing
  bool no_angle_relax = false;             ///< circle packing: Step 2's angles exactly
  bool no_circle_normalization = false;    ///< circle domains: K̄ ∝ length exactly
  bool no_split_ears = false;              ///< keep ears the boundary target cannot realise (no split)
  bool no_flips = false;                   ///< yamabe on the input's triangulation, without intrinsic flips
};
int run_flow(const FlowCommandOptions& options);

/// Registers the `flow` subcommand (its options bound to `o`) on `app`.
CLI::App* add_flow_command(CLI::App& app, FlowCommandOptions& o);

/// `ricci cut [MESH] -o CUT`: cuts the surface into a disk with a canonical polygon (cut_command.cpp).
struct CutCommandOptions {
  std::string mesh;                ///< input path; empty: the embedded default mesh
  std::string output;              ///< -o CUT (the disk; sides/loops go to CUT.loops.obj); empty: none
  std::int64_t base_vertex = -1;   ///< --base-vertex; -1: from the seed
  std::uint64_t seed = 0;          ///< --seed
  bool json = false;               ///< summary as one JSON object on stdout
  bool quiet = false;              ///< no notes on stderr
  bool largest_component = false;  ///< keep the largest component instead of failing
};
int run_cut(const CutCommandOptions& options);
CLI::App* add_cut_command(CLI::App& app, CutCommandOptions& o);

/// `ricci uniformize [MESH] -o OUTDIR` (the main job) and `ricci layout MESH --metric METRIC -o
/// OUTDIR` (from a stored metric): uniformize_command.cpp.
struct UniformizeCommandOptions {
  std::string mesh;                       ///< input path; empty: the embedded default mesh
  std::string output;                     ///< -o OUTDIR
  std::string metric;                     ///< layout: the metric file (then no flow runs)
  std::string geometry = "auto";          ///< auto, euclidean, hyperbolic, spherical
  std::string scheme = "auto";            ///< auto (= yamabe), circle-packing, inversive-distance, yamabe
  bool no_flips = false;                  ///< yamabe without intrinsic Delaunay flips
  int steiner_levels = 3;                 ///< at most this many Steiner subdivisions (0: none)
  int boundary_split_rounds = 4;          ///< at most this many rounds of boundary splits (0: none)
  bool no_split_chords = false;           ///< no chord splits for the double (UniformizeOptions::split_chords)
  std::string target = "auto";            ///< auto, uniform, cones=FILE, single-vertex=I
  std::string boundary = "auto";          ///< auto, free, fixed, circle, geodesic, loop-totals=…
  double tolerance = 1e-12;               ///< flow: max |K̄ − K| at convergence
  int max_iterations = 0;                 ///< flow: 0 for the library default
  int threads = 0;                        ///< OpenMP threads; 0: the OpenMP default
  bool mesh_polygon = false;              ///< H: the mesh-path canonical polygon (polygon.obj)
  bool no_atlas = false;                  ///< E, H: one chart only (a layout it cannot hold fails)
  bool cut_after_flow = false;            ///< not beside the flow (UniformizeOptions::cut_beside_flow)
  int base_candidates = 8;                ///< H: base vertices tried for the mesh-path canonical polygon
  int seed_checks = 1;                    ///< extra seed faces for seed_independence_error
  int cover_depth = 0;                    ///< cover word length; 0: 3 (torus) or 2
  int cover_faces = 250000;               ///< cover.obj only up to this many faces (tiles × domain faces)
  bool unit_box = false;                  ///< E: layout scaled into [0,1]²
  int patches = -1;                       ///< layout: divide-and-conquer patches (-1 automatic)
  double layout_refine_above = 1e-10;     ///< layout: refine only above the rounding floor by more than this
  bool no_pictures = false;               ///< no PNG/SVG pictures, no report.html
  bool no_angle_relax = false;
  bool no_circle_normalization = false;
  bool json = false;
  bool quiet = false;
  bool largest_component = false;
  bool no_split_ears = false;  ///< keep ears the boundary target cannot realise (no split)
};
int run_uniformize(const UniformizeCommandOptions& options);
CLI::App* add_uniformize_command(CLI::App& app, UniformizeCommandOptions& o);
CLI::App* add_layout_command(CLI::App& app, UniformizeCommandOptions& o);

/// `ricci cover [MESH] -o OUT --depth k`: the universal cover tiling as SVG or a mesh.
struct CoverCommandOptions {
  std::string mesh;
  std::string output;
  std::int64_t depth = 2;  ///< H: word length in the domain's side pairings; torus: block size
  double radius = 0;  ///< H: keep copies with centre inside |z| <= radius (0: all)
  bool json = false;
  bool quiet = false;
  bool largest_component = false;
};
int run_cover(const CoverCommandOptions& options);
CLI::App* add_cover_command(CLI::App& app, CoverCommandOptions& o);

/// `ricci signature [MESH] [--json] [-o FILE]`: the conformal signature (signature.h).
struct SignatureCommandOptions {
  std::string mesh;
  std::string output;  ///< signature.json to write (atomically); empty: none
  bool json = false;
  bool quiet = false;
  bool largest_component = false;
};
int run_signature(const SignatureCommandOptions& options);
CLI::App* add_signature_command(CLI::App& app, SignatureCommandOptions& o);
/// The signature as JSON (keys in README): status, genus, boundary_loops, torus {tau,
/// tau_computed, b_reversed, reduction, uncertainty}, words [{word, length, uncertainty}],
/// systole, fenchel_nielsen [{curve, word, length, twist, …}], circle_domain {circles,
/// separation, …}, boundary_geodesics [{vertex, length_3d, length, uncertainty}].
nlohmann::ordered_json signature_json(const ricci::ConformalSignature& s);
/// Renames the loops' vertices (validated numbering) to the file's (ValidateResult::vertex_to_input).
void signature_vertices_to_file(ricci::ConformalSignature& s, const std::vector<ricci::Index>& vertex_to_input);
/// The parts of signature_json()'s output signature_distance() needs, read back; throws
/// std::runtime_error (or nlohmann's exceptions) naming what is missing or malformed.
ricci::ConformalSignature signature_from_json(const nlohmann::ordered_json& j);

/// `ricci compare A B [B2 …] [--json]`: signature_distance() of A to each B (meshes or
/// signature.json files); several B are ranked, nearest first.
struct CompareCommandOptions {
  std::string first;
  std::vector<std::string> others;
  bool json = false;
  bool largest_component = false;
  bool quiet = false;
};
int run_compare(const CompareCommandOptions& options);
CLI::App* add_compare_command(CLI::App& app, CompareCommandOptions& o);

/// `ricci batch …` and `ricci summarize …`: runs `PYTHON -m ricci COMMAND ARGS…` in place of this
/// process (python_command.cpp). PYTHON is $RICCI_PYTHON, else the interpreter the module was built
/// for, else python3; the package beside this executable (<dir>/python/ricci, the build tree) is put
/// first on PYTHONPATH. Returns only on failure (exit 1, with a message on how to install it).
int run_python_command(const std::string& command, const std::vector<std::string>& args);

// Shared by the subcommands.
/// "ricci: MESSAGE" on stderr unless quiet.
void print_note(bool quiet, const std::string& message);

/// --threads N as the library will use it: N, or ricci::available_threads() when N is above that
/// (then `note` says so, for the caller to print and report).
int usable_threads(int requested, std::string& note);
/// "ricci: error: MESSAGE" on stderr.
void print_error(const std::string& message);

/// Largest input file (mesh, target or metric file) the commands read, in bytes: the global
/// option --max-file-size (default kDefaultMaxFileBytes). Larger files are refused before any of
/// their bytes are read (exit 3, file_too_large), so a file of many GB cannot exhaust memory.
inline constexpr std::uint64_t kDefaultMaxFileBytes = std::uint64_t{2} << 30;
std::uint64_t max_input_bytes();
void set_max_input_bytes(std::uint64_t bytes);
/// "SIZE" as bytes: a whole number with an optional suffix K, M, G or T (powers of 1024).
std::optional<std::uint64_t> parse_byte_size(std::string_view text);
/// "" when `path` is not a regular file above max_input_bytes(); otherwise the message
/// "<path>: the file has N bytes, more than the limit of M (--max-file-size)".
std::string input_too_large(const std::string& path);

/// While alive, SIGINT, SIGTERM and SIGHUP are held back: one that arrives is only recorded, and
/// the destructor restores the previous handlers and raises it again. Wrapped around the writes of
/// `convert`, `flow -o`, `cut -o` and `cover -o`, so an interruption leaves each output complete
/// or absent (never an atomic write's temporary file) and the process still ends by the signal.
/// RICCI_WRITE_PAUSE_MS (a test aid, as for uniformize) sleeps that long in the constructor.
class InterruptsDeferred {
 public:
  InterruptsDeferred();
  ~InterruptsDeferred();
  InterruptsDeferred(const InterruptsDeferred&) = delete;
  InterruptsDeferred& operator=(const InterruptsDeferred&) = delete;
};

/// Reads MESH — or the embedded default mesh when MESH is empty — and validates it through the
/// library's load path (ricci::validate_read): messages name the file, repairs include the
/// reader's triangulation, and faces named by errors are the file's polygons.
ricci::LoadResult load_input(const std::string& mesh, const ricci::ValidateOptions& options);

/// The `repairs` array of the JSON reports.
nlohmann::ordered_json repairs_json(const std::vector<ricci::Repair>& repairs);
/// The repair to list when the metric's lengths were mollified (epsilon > 0), else nothing.
std::optional<ricci::Repair> mollification_repair(const ricci::Mollification& m);
/// Best-effort early test that `a` and `b` name the same file (atomic writes check again).
bool same_file(const std::string& a, const std::string& b);
/// Appends the shortest round-trip decimal of x.
void append_number(std::string& out, double x);
void append_number(std::string& out, std::int64_t x);

/// Flushes stdout and returns `code`, or kExitOutputFailure if stdout could not be written.
int finish_stdout(int code);

/// Parses the command line and runs the chosen subcommand; returns the process exit code.
/// May throw std::exception on an internal error (main() maps that to kExitInternal).
int run(int argc, const char* const* argv);

/// The embedded default mesh (bytes of fixtures/genus2.obj) and its name; generated at build time
/// by cli/embed.cmake into embedded_default.cpp.
std::string_view embedded_default_mesh();
const char* embedded_default_name();

}  // namespace ricci_cli
