// ricci command-line driver: subcommand setup and implementation (see commands.h).
#include "commands.h"

#include <signal.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "flow_setup.h"
#include "ricci/flow.h"
#include "ricci/io.h"
#include "ricci/mesh.h"
#include "ricci/topology.h"
#include "ricci/validate.h"

namespace ricci_cli {

using ricci::FileFormat;
using ricci::Status;

int exit_code(Status status) {
  switch (status) {
    case Status::Ok:
      return kExitOk;
    case Status::InvalidArgument:
      return kExitUsage;
    case Status::FileNotFound:
    case Status::FileUnreadable:
    case Status::UnknownFormat:
    case Status::FileTooLarge:
      return kExitInputUnavailable;
    case Status::ParseError:
    case Status::IndexOutOfRange:
    case Status::NonFiniteCoordinate:
      return kExitMalformedInput;
    case Status::NoFaces:
    case Status::DegenerateFace:
    case Status::DuplicateFace:
    case Status::NonManifoldEdge:
    case Status::NonManifoldVertex:
    case Status::InconsistentOrientation:
    case Status::NonOrientable:
    case Status::MultipleComponents:
      return kExitInvalidMesh;
    case Status::WriteFailed:
    case Status::OutputIsInput:
      return kExitOutputFailure;
    case Status::TriangleInequality:
    case Status::NotConverged:
    case Status::LineSearchFailed:
    case Status::NumericalFailure:
      return kExitFlowFailed;
    case Status::InfeasibleTarget:
      return kExitInfeasibleTarget;
    case Status::NotRun:       // a library driver returned without running
    case Status::OutOfMemory:  // an allocation failed
      break;
  }
  return kExitInternal;
}

// ---- messages -------------------------------------------------------------------------------

void print_note(bool quiet, const std::string& message) {
  if (!quiet) std::cerr << "ricci: " << message << '\n';
}

int usable_threads(int requested, std::string& note) {
  const int available = ricci::available_threads();
  if (requested <= available) return requested;
  note = "--threads " + std::to_string(requested) + ": " + std::to_string(available) +
         " processor" + (available == 1 ? " is" : "s are") + " available to this process; using " +
         std::to_string(available);
  return available;
}

void print_error(const std::string& message) {
  std::cerr << "ricci: error: " << message << '\n';
}

bool same_file(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec) && fs::equivalent(a, b, ec)) return true;
  const fs::path ca = fs::weakly_canonical(a, ec);
  if (ec) return false;
  const fs::path cb = fs::weakly_canonical(b, ec);
  return !ec && ca == cb;
}

void append_number(std::string& out, double x) {
  char buf[40];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

void append_number(std::string& out, std::int64_t x) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}

int finish_stdout(int code) {
  std::cout.flush();
  if (!std::cout) {
    print_error("could not write to standard output");
    return kExitOutputFailure;
  }
  return code;
}

namespace {

using Json = nlohmann::ordered_json;

constexpr const char* kVersion = RICCI_VERSION;  // from CMake's project(VERSION)

constexpr const char* kExitCodeFooter =
    "Exit codes:\n"
    "  0  success\n"
    "  1  unexpected internal error\n"
    "  2  usage error (bad arguments or options)\n"
    "  3  input cannot be opened (not found, unreadable, unknown format, too large)\n"
    "  4  malformed file content (parse error, index out of range, non-finite coordinate)\n"
    "  5  invalid mesh (no faces, degenerate or duplicate face, non-manifold edge or vertex,\n"
    "     inconsistent orientation, non-orientable, several components)\n"
    "  6  output failure (write failed, output is the input)\n"
    "  7  the flow failed (not converged, line search failed, numerical failure, triangle\n"
    "     inequality violated)\n"
    "  8  infeasible target curvature (Gauss-Bonnet or admissibility violated)";

// ---- small formatting helpers ---------------------------------------------------------------

std::optional<std::string> format_option_name(FileFormat f) {
  switch (f) {
    case FileFormat::Obj:
      return "obj";
    case FileFormat::Off:
      return "off";
    case FileFormat::PlyAscii:
      return "ply-ascii";
    case FileFormat::PlyBinary:
      return "ply-binary";
    case FileFormat::StlAscii:
      return "stl-ascii";
    case FileFormat::StlBinary:
      return "stl-binary";
    case FileFormat::Gifti:
      return "gifti";
    case FileFormat::FreeSurfer:
      return "freesurfer";
    case FileFormat::Auto:
      break;
  }
  return std::nullopt;
}

/// The --format choices of `convert`.
std::optional<FileFormat> format_from_option(const std::string& name) {
  if (name.empty()) return FileFormat::Auto;
  if (name == "obj") return FileFormat::Obj;
  if (name == "off") return FileFormat::Off;
  if (name == "ply") return FileFormat::PlyBinary;
  if (name == "ply-ascii") return FileFormat::PlyAscii;
  if (name == "stl") return FileFormat::StlBinary;
  if (name == "stl-ascii") return FileFormat::StlAscii;
  if (name == "gifti") return FileFormat::Gifti;
  if (name == "freesurfer") return FileFormat::FreeSurfer;
  return std::nullopt;
}

std::string printf_string(const char* fmt, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, x);
  return buf;
}

double degrees(double radians) {
  return radians * 180.0 / std::numbers::pi;
}

const char* yes_no(bool b) {
  return b ? "yes" : "no";
}

}  // namespace

namespace {
std::uint64_t g_max_input_bytes = kDefaultMaxFileBytes;  // set once by run() from --max-file-size
}  // namespace

std::uint64_t max_input_bytes() { return g_max_input_bytes; }
void set_max_input_bytes(std::uint64_t bytes) { g_max_input_bytes = bytes; }

double g_weld_tolerance = 0;  // set once by run() from --weld-tolerance

ricci::ReadOptions input_read_options() {
  ricci::ReadOptions ro;
  ro.max_file_bytes = max_input_bytes();
  ro.weld_tolerance = g_weld_tolerance;
  return ro;
}

std::optional<std::uint64_t> parse_byte_size(std::string_view text) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (ec != std::errc() || ptr == text.data()) return std::nullopt;
  const std::string_view suffix(ptr, static_cast<std::size_t>(end - ptr));
  int shift = 0;
  if (suffix == "K" || suffix == "k") {
    shift = 10;
  } else if (suffix == "M") {
    shift = 20;
  } else if (suffix == "G") {
    shift = 30;
  } else if (suffix == "T") {
    shift = 40;
  } else if (!suffix.empty()) {
    return std::nullopt;
  }
  if (shift > 0 && value > (~std::uint64_t{0} >> shift)) return std::nullopt;
  return value << shift;
}

std::string input_too_large(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return {};
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || size <= max_input_bytes()) return {};
  return path + ": the file has " + std::to_string(size) + " bytes, more than the limit of " +
         std::to_string(max_input_bytes()) + " (raise it with --max-file-size)";
}

namespace {
volatile std::sig_atomic_t g_deferred_signal = 0;
extern "C" void record_signal(int sig) { g_deferred_signal = sig; }
constexpr int kDeferredSignals[] = {SIGINT, SIGTERM, SIGHUP};
struct sigaction g_previous_actions[3];
}  // namespace

InterruptsDeferred::InterruptsDeferred() {
  g_deferred_signal = 0;
  struct sigaction sa {};
  sa.sa_handler = record_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  for (int i = 0; i < 3; ++i) ::sigaction(kDeferredSignals[i], &sa, &g_previous_actions[i]);
  if (const char* p = std::getenv("RICCI_WRITE_PAUSE_MS")) {
    const int ms = std::max(0, std::min(std::atoi(p), 10000));
    std::cerr << "ricci: pausing before writing (RICCI_WRITE_PAUSE_MS)" << std::endl;
    std::this_thread::sleep_for(std::chrono::milliseconds(ms));
  }
}

InterruptsDeferred::~InterruptsDeferred() {
  for (int i = 0; i < 3; ++i) ::sigaction(kDeferredSignals[i], &g_previous_actions[i], nullptr);
  if (const int sig = g_deferred_signal; sig != 0) {
    std::cout.flush();
    std::raise(sig);
  }
}

ricci::LoadResult load_input(const std::string& mesh, const ricci::ValidateOptions& options) {
  if (!mesh.empty()) {
    ricci::LoadOptions lo;
    lo.validate = options;
    lo.read = input_read_options();
    ricci::LoadResult r = ricci::load_mesh(mesh, lo);
    if (r.status == Status::FileTooLarge) r.message += "; raise the limit with --max-file-size";
    return r;
  }
  ricci::ReadOptions ro;
  ro.format = FileFormat::Obj;
  const std::string name = embedded_default_name();
  return ricci::validate_read(ricci::read_mesh_from_memory(embedded_default_mesh(), name, ro), name, options);
}

Json repairs_json(const std::vector<ricci::Repair>& repairs) {
  Json out = Json::array();
  for (const ricci::Repair& rep : repairs) {
    Json j{{"kind", std::string(ricci::repair_name(rep.kind))}, {"count", rep.count}, {"message", rep.message}};
    if (rep.kind == ricci::RepairKind::LengthsMollified) j["relative_epsilon"] = rep.value;
    out.push_back(std::move(j));
  }
  return out;
}

std::optional<ricci::Repair> mollification_repair(const ricci::Mollification& m) {
  if (!(m.epsilon > 0)) return std::nullopt;
  ricci::Repair rep;
  rep.kind = ricci::RepairKind::LengthsMollified;
  rep.count = m.faces;
  rep.value = m.mean_edge > 0 ? m.epsilon / m.mean_edge : 0;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "mollified the edge lengths: %lld triangle(s) (the flattest: face %lld) came within %.3g mean "
                "edge lengths of breaking the triangle inequality; %.3g mean edge lengths were added to every "
                "edge (the map is conformal for the mollified lengths)",
                static_cast<long long>(m.faces), static_cast<long long>(m.worst_face), m.delta / m.mean_edge,
                rep.value);
  rep.message = buf;
  return rep;
}

EarSplit split_infeasible_ears(ricci::ValidateResult& validated, ricci::BoundaryMode mode,
                               const TargetSpec& target_spec, const BoundarySpec& boundary_spec,
                               const std::string& target_text, const std::string& boundary_text) {
  EarSplit out;
  if (validated.topology.is_closed() || ricci::find_ears(validated.topology).empty()) return out;
  const TargetBuild tb = build_target(validated.topology, mode, target_spec, boundary_spec, target_text, boundary_text);
  if (tb.status != Status::Ok) return out;
  const std::vector<ricci::Index> ears = ricci::infeasible_ears(validated.topology, tb.target);
  const std::size_t before = validated.repairs.size();
  std::string why;
  out.status = ricci::split_ears(validated, ears, &why);
  if (out.status != Status::Ok) {
    out.message = "splitting ears: " + why;
    return out;
  }
  if (validated.repairs.size() > before) out.repair = validated.repairs.back();
  return out;
}

PreparedTarget prepare_target(ricci::ValidateResult& validated, ricci::Geometry geometry, const TargetSpec& target_spec,
                              const BoundarySpec& boundary_spec, const std::string& target_text,
                              const std::string& boundary_text, bool split_ears, const std::string& file) {
  PreparedTarget out;
  const ricci::Topology& topo = validated.topology;  // split_ears() replaces its content
  auto usage = [&](std::string m) {
    out.status = Status::InvalidArgument;
    out.usage = true;
    out.message = std::move(m);
    return out;
  };
  if (topo.is_closed()) {
    if (!boundary_spec.automatic) out.notes.push_back("the surface is closed; --boundary " + boundary_text + " is ignored");
  } else {
    out.mode = boundary_spec.automatic ? ricci::natural_boundary_mode(topo, geometry) : boundary_spec.mode;
    // A target that cannot be built (e.g. the wrong number of loop totals) splits no ear;
    // build_target() below names the problem.
    if (split_ears) {
      const EarSplit es = split_infeasible_ears(validated, out.mode, target_spec, boundary_spec, target_text, boundary_text);
      if (es.status != Status::Ok) {
        out.status = es.status;
        out.message = file + ": " + es.message;
        return out;
      }
      out.ear_split = es.repair;
    }
  }
  TargetBuild tb = build_target(topo, out.mode, target_spec, boundary_spec, target_text, boundary_text);
  if (tb.usage) return usage(tb.message);
  out.status = tb.status;
  out.message = std::move(tb.message);
  out.target = std::move(tb.target);
  return out;
}

namespace {

// ---- info -----------------------------------------------------------------------------------

/// Everything `info` reports, independent of the output form. Mesh counts describe the validated
/// mesh when status is Ok and the raw triangle soup (diagnose()) otherwise.
struct InfoReport {
  std::string file;
  bool embedded = false;
  std::optional<std::string> format;
  std::string format_details;         ///< what the file says about itself (ReadResult::format_details)
  std::int64_t welded_vertices = -1;  ///< STL: corners welded into earlier vertices; -1 otherwise
  Status status = Status::NotRun;
  std::string message;
  std::int64_t line = -1;
  ricci::Element element = ricci::Element::None;
  std::int64_t element_index = -1;

  bool have_mesh = false;  ///< false when the file could not be read: no counts at all
  bool valid = false;      ///< counts come from the validated mesh and its topology
  std::int64_t vertices = 0;
  std::int64_t vertices_listed = 0;
  std::int64_t vertices_unreferenced = 0;  ///< in the file as read
  std::int64_t edges = 0;
  std::int64_t faces = 0;
  std::int64_t boundary_loops = 0;
  std::vector<std::int64_t> boundary_loop_sizes;  ///< only when valid
  std::int64_t euler_characteristic = 0;
  std::optional<std::int64_t> genus;
  std::string genus_undefined_reason;
  std::int64_t components = 0;
  bool orientable = false;
  bool manifold = false;
  std::int64_t non_manifold_edges = 0;
  std::int64_t non_manifold_vertices = 0;
  std::int64_t inconsistent_edges = 0;
  std::int64_t inconsistent_edges_input = 0;  ///< in the file as read (before any repair)
  bool have_angles = false;                   ///< the mesh has faces, so the angle statistics mean something
  double min_angle_deg = 0;
  double max_angle_deg = 0;
  double obtuse_fraction = 0;
  std::vector<ricci::Repair> repairs;
};

/// Why the genus of a raw soup is undefined, or "" when it is defined.
std::string genus_undefined_reason(const ricci::MeshDiagnostics& d) {
  if (d.faces == 0) return "no faces";
  if (!d.manifold) return "not manifold";
  if (!d.orientable) return "not orientable";
  if (d.components != 1) return "not connected: " + std::to_string(d.components) + " components";
  return {};
}

InfoReport make_info_report(const InfoOptions& options) {
  InfoReport r;
  r.embedded = options.mesh.empty();
  r.file = r.embedded ? std::string(embedded_default_name()) : options.mesh;
  ricci::ValidateOptions vo;
  vo.keep_largest_component = options.largest_component;
  vo.repair_orientation = !options.no_repair_orientation;
  const ricci::LoadResult loaded = load_input(options.mesh, vo);
  const ricci::ReadResult& read = loaded.read;
  r.format = format_option_name(read.format);
  r.status = loaded.status;
  r.message = loaded.status == Status::Ok ? std::string("ok") : loaded.message;
  r.line = loaded.line;
  r.element = loaded.element;
  r.element_index = loaded.element_index;
  if (read.status != Status::Ok) return r;
  r.format_details = read.format_details;
  if (read.format == FileFormat::StlAscii || read.format == FileFormat::StlBinary)
    r.welded_vertices = read.welded_vertices;
  r.repairs = loaded.repairs;
  const ricci::MeshDiagnostics raw = ricci::diagnose(read.mesh);
  const ricci::ValidateResult& validated = loaded.validated;
  r.have_mesh = true;
  r.have_angles = raw.faces > 0;
  r.vertices_listed = raw.vertices_listed;
  r.vertices_unreferenced = raw.vertices_listed - raw.vertices_referenced;
  r.inconsistent_edges_input = raw.inconsistent_edges;
  if (validated.status == Status::Ok) {
    // The clean mesh: connectivity numbers from its topology, quality from diagnose() of it.
    const ricci::Topology& t = validated.topology;
    const ricci::MeshDiagnostics clean = ricci::diagnose(validated.mesh);
    r.valid = true;
    r.vertices = t.num_vertices;
    r.edges = t.num_edges;
    r.faces = t.num_faces;
    r.boundary_loops = t.num_boundary_loops();
    for (ricci::Index i = 0; i < t.num_boundary_loops(); ++i)
      r.boundary_loop_sizes.push_back(t.boundary_offsets[i + 1] - t.boundary_offsets[i]);
    r.euler_characteristic = t.euler_characteristic();
    r.genus = t.genus();
    r.components = t.num_components;
    r.orientable = true;
    r.manifold = true;
    r.non_manifold_edges = clean.non_manifold_edges;
    r.non_manifold_vertices = clean.non_manifold_vertices;
    r.inconsistent_edges = clean.inconsistent_edges;
    r.min_angle_deg = degrees(clean.min_corner_angle);
    r.max_angle_deg = degrees(clean.max_corner_angle);
    r.obtuse_fraction = clean.obtuse_face_fraction;
  } else {
    r.vertices = raw.vertices_referenced;
    r.edges = raw.edges;
    r.faces = raw.faces;
    r.boundary_loops = raw.boundary_loops;
    r.euler_characteristic = raw.euler_characteristic;
    r.genus_undefined_reason = genus_undefined_reason(raw);
    if (r.genus_undefined_reason.empty()) r.genus = raw.genus;
    r.components = raw.components;
    r.orientable = raw.orientable;
    r.manifold = raw.manifold;
    r.non_manifold_edges = raw.non_manifold_edges;
    r.non_manifold_vertices = raw.non_manifold_vertices;
    r.inconsistent_edges = raw.inconsistent_edges;
    r.min_angle_deg = degrees(raw.min_corner_angle);
    r.max_angle_deg = degrees(raw.max_corner_angle);
    r.obtuse_fraction = raw.obtuse_face_fraction;
  }
  return r;
}

Json info_json(const InfoReport& r) {
  Json j;
  j["status"] = std::string(ricci::status_name(r.status));
  j["message"] = r.message;
  j["file"] = r.file;
  j["embedded_default"] = r.embedded;
  j["format"] = r.format ? Json(*r.format) : Json(nullptr);
  j["format_details"] = r.format_details.empty() ? Json(nullptr) : Json(r.format_details);
  j["welded_vertices"] = r.welded_vertices >= 0 ? Json(r.welded_vertices) : Json(nullptr);
  j["line"] = r.line >= 0 ? Json(r.line) : Json(nullptr);
  j["element"] =
      r.element != ricci::Element::None ? Json(std::string(ricci::element_name(r.element))) : Json(nullptr);
  j["element_index"] = r.element_index >= 0 ? Json(r.element_index) : Json(nullptr);
  j["counts_from"] = !r.have_mesh ? Json(nullptr) : Json(r.valid ? "validated_mesh" : "input");

  auto count = [&](const char* key, std::int64_t v) { j[key] = r.have_mesh ? Json(v) : Json(nullptr); };
  auto flag = [&](const char* key, bool v) { j[key] = r.have_mesh ? Json(v) : Json(nullptr); };
  // Angles are undefined without a (non-degenerate) face.
  auto real = [&](const char* key, double v) { j[key] = r.have_angles ? Json(v) : Json(nullptr); };
  count("vertices", r.vertices);
  count("vertices_listed", r.vertices_listed);
  count("vertices_unreferenced", r.vertices_unreferenced);
  count("edges", r.edges);
  count("faces", r.faces);
  count("boundary_loops", r.boundary_loops);
  j["boundary_loop_sizes"] = r.valid ? Json(r.boundary_loop_sizes) : Json(nullptr);
  count("euler_characteristic", r.euler_characteristic);
  j["genus"] = r.genus ? Json(*r.genus) : Json(nullptr);
  j["genus_undefined_reason"] = r.have_mesh && !r.genus ? Json(r.genus_undefined_reason) : Json(nullptr);
  count("components", r.components);
  flag("orientable", r.orientable);
  flag("manifold", r.manifold);
  count("non_manifold_edges", r.non_manifold_edges);
  count("non_manifold_vertices", r.non_manifold_vertices);
  count("inconsistent_edges", r.inconsistent_edges);
  count("inconsistent_edges_input", r.inconsistent_edges_input);
  real("min_angle_deg", r.min_angle_deg);
  real("max_angle_deg", r.max_angle_deg);
  real("obtuse_fraction", r.obtuse_fraction);
  j["repairs"] = repairs_json(r.repairs);
  return j;
}

void print_info_text(const InfoReport& r, std::ostream& os) {
  auto row = [&](const std::string& label, const std::string& value) {
    constexpr std::size_t kWidth = 31;
    os << label << ':' << std::string(label.size() + 1 < kWidth ? kWidth - label.size() - 1 : 1, ' ') << value
       << '\n';
  };
  auto num = [](std::int64_t v) { return std::to_string(v); };

  row("file", r.embedded ? r.file + " (embedded default mesh)" : r.file);
  if (r.format) row("format", *r.format);
  if (!r.format_details.empty()) row("format details", r.format_details);
  if (r.welded_vertices >= 0) row("welded corners", std::to_string(r.welded_vertices));
  if (r.have_mesh) {
    std::string v = num(r.vertices);
    if (r.vertices_listed != r.vertices)
      v += " (file lists " + num(r.vertices_listed) + ", " + num(r.vertices_unreferenced) + " unreferenced)";
    row("vertices", v);
    row("edges", num(r.edges));
    row("faces", num(r.faces));
    std::string b = num(r.boundary_loops);
    if (r.valid && !r.boundary_loop_sizes.empty()) {
      b += " (vertices per loop:";
      for (std::size_t i = 0; i < r.boundary_loop_sizes.size(); ++i)
        b += (i ? ", " : " ") + num(r.boundary_loop_sizes[i]);
      b += ")";
    }
    row("boundary loops", b);
    row("euler characteristic", num(r.euler_characteristic));
    row("genus", r.genus ? num(*r.genus) : "n/a (" + r.genus_undefined_reason + ")");
    row("components", num(r.components));
    row("orientable", yes_no(r.orientable));
    row("manifold", yes_no(r.manifold));
    row("non-manifold edges", num(r.non_manifold_edges));
    row("non-manifold vertices", num(r.non_manifold_vertices));
    std::string inc = num(r.inconsistent_edges);
    if (r.inconsistent_edges_input != r.inconsistent_edges)
      inc += " (" + num(r.inconsistent_edges_input) + " in the input)";
    row("inconsistently oriented edges", inc);
    if (r.have_angles) {
      row("min corner angle", printf_string("%.4g deg", r.min_angle_deg));
      row("max corner angle", printf_string("%.4g deg", r.max_angle_deg));
      row("obtuse triangles", printf_string("%.1f%%", 100.0 * r.obtuse_fraction));
    } else {
      row("corner angles", "n/a (no faces)");
    }
  } else if (r.line >= 0) {
    row(r.element == ricci::Element::Byte ? "byte offset" : "line", num(r.line));
  }
  for (const ricci::Repair& rep : r.repairs) row("repair", rep.message);
  if (r.status == Status::Ok)
    os << "status: ok\n";
  else
    os << "error: " << r.message << '\n';
}

// ---- command-line setup ---------------------------------------------------------------------

CLI::App* add_info_command(CLI::App& app, InfoOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "info",
      "Describe a mesh: counts, topology (χ, genus, boundary loops), defects, angle quality "
      "and the repairs validation would make.");
  cmd->add_option("MESH", o.mesh,
                  "Mesh file (.obj, .off, .ply, .stl, .gii, or a FreeSurfer surface such as lh.white). "
                  "Default: the embedded genus-2 mesh (" +
                      std::string(embedded_default_name()) + ").");
  cmd->add_flag("--json", o.json, "Print one JSON object on stdout instead of text. Default: off.");
  cmd->add_flag("--largest-component", o.largest_component,
                "Keep the largest connected component instead of failing on several. Default: off.");
  cmd->add_flag("--no-repair-orientation", o.no_repair_orientation,
                "Report inconsistently oriented faces as an error instead of flipping them. "
                "Default: off (orientation is repaired).");
  cmd->add_flag("-q,--quiet", o.quiet, "Silence notes on stderr; errors are still printed. Default: off.");
  return cmd;
}

CLI::App* add_convert_command(CLI::App& app, ConvertOptions& o) {
  CLI::App* cmd =
      app.add_subcommand("convert",
                         "Rewrite a mesh in another format (OBJ, OFF, PLY, STL, GIFTI, FreeSurfer). The "
                         "output is written atomically and never replaces the input.");
  cmd->add_option("IN", o.input,
                  "Input mesh file (.obj, .off, .ply, .stl, .gii, or a FreeSurfer surface such as lh.white). "
                  "Required.")
      ->required();
  cmd->add_option("-o,--output", o.output, "Output mesh file. Required.")->required();
  CLI::Option* validate =
      cmd->add_flag("--validate", o.validate,
                    "Validate and repair the mesh before writing (drop unused vertices, fix "
                    "orientation); fail on an invalid mesh. Default: off (written as read).");
  cmd->add_flag("--largest-component", o.largest_component,
                "With --validate: keep the largest connected component. Default: off.")
      ->needs(validate);
  cmd->add_option("--format", o.format,
                  "Output format: obj, off, ply (binary little-endian), ply-ascii, stl (binary), stl-ascii, "
                  "gifti or freesurfer (STL, GIFTI and FreeSurfer store single precision). "
                  "Default: from the extension of OUT (.obj, .off, .ply, .stl, .gii).")
      ->check(CLI::IsMember({"obj", "off", "ply", "ply-ascii", "stl", "stl-ascii", "gifti", "freesurfer"}));
  cmd->add_flag("-q,--quiet", o.quiet, "Silence notes on stderr; errors are still printed. Default: off.");
  return cmd;
}

}  // namespace

int run_info(const InfoOptions& options) {
  if (options.mesh.empty())
    print_note(options.quiet,
               std::string("no MESH given; using the embedded default mesh ") + embedded_default_name());
  const InfoReport report = make_info_report(options);
  if (options.json)
    std::cout << info_json(report).dump(2) << '\n';
  else
    print_info_text(report, std::cout);
  if (report.status != Status::Ok) print_error(report.message);  // names the file

  return finish_stdout(exit_code(report.status));
}

int run_convert(const ConvertOptions& options) {
  const std::optional<FileFormat> format = format_from_option(options.format);
  if (!format) {
    print_error("unknown output format '" + options.format +
                "' (use obj, off, ply, ply-ascii, stl, stl-ascii, gifti or freesurfer)");
    return kExitUsage;
  }
  if (*format == FileFormat::Auto && ricci::format_from_path(options.output) == FileFormat::Auto) {
    print_error("cannot tell the output format from '" + options.output +
                "'; use an .obj, .off, .ply, .stl or .gii extension or --format (freesurfer surfaces have none)");
    return kExitUsage;
  }

  // Validated through the library's load path, or written exactly as read.
  ricci::ValidateOptions vo;
  vo.keep_largest_component = options.largest_component;
  ricci::LoadResult loaded;
  if (options.validate) {
    loaded = load_input(options.input, vo);
  } else {
    loaded.read = ricci::read_mesh(options.input, input_read_options());
    loaded.status = loaded.read.status;
    loaded.message = loaded.read.message;
    if (loaded.status == Status::FileTooLarge) loaded.message += "; raise the limit with --max-file-size";
  }
  if (loaded.status != Status::Ok) {
    print_error(loaded.message);
    return exit_code(loaded.status);
  }
  if (loaded.read.welded_vertices > 0)
    print_note(options.quiet, "welded " + std::to_string(loaded.read.welded_vertices) +
                                  " STL corners into earlier vertices");
  if (!options.validate && loaded.read.polygons_triangulated > 0)
    print_note(options.quiet, "fan-triangulated " + std::to_string(loaded.read.polygons_triangulated) +
                                  " polygons with more than 3 sides");
  for (const ricci::Repair& rep : loaded.repairs) print_note(options.quiet, rep.message);
  const ricci::Mesh* mesh = options.validate ? &loaded.validated.mesh : &loaded.read.mesh;

  ricci::WriteOptions wo;
  wo.format = *format;
  wo.protected_paths = {options.input};
  ricci::WriteResult written;
  {
    const InterruptsDeferred deferred;
    written = ricci::write_mesh(options.output, *mesh, wo);
  }
  if (written.status != Status::Ok) {
    print_error(written.message);
    if (written.status == Status::OutputIsInput)
      print_error("the output must be a different file from the input; nothing was written");
    return exit_code(written.status);
  }
  const FileFormat out_format =
      *format == FileFormat::Auto ? ricci::format_from_path(options.output) : *format;
  print_note(options.quiet, "wrote " + options.output + " (" + format_option_name(out_format).value_or("?") + ", " +
                                std::to_string(mesh->num_vertices()) + " vertices, " +
                                std::to_string(mesh->num_faces()) + " faces, " +
                                std::to_string(written.bytes_written) + " bytes)");
  return kExitOk;
}

int run(int argc, const char* const* argv) {
  CLI::App app("ricci — discrete surface Ricci flow on triangle meshes.", "ricci");
  app.footer(kExitCodeFooter);  // set before the subcommands, which inherit it
  app.set_version_flag("--version", std::string("ricci ") + kVersion, "Print the version and exit.");
  app.require_subcommand(1);
  // Global: accepted before or after the subcommand (fallthrough passes it up to `app`).
  app.fallthrough();
  std::string max_file_size = std::to_string(kDefaultMaxFileBytes);
  app.add_option("--max-file-size", max_file_size,
                 "Refuse input files (mesh, target, metric) larger than SIZE bytes before reading them; "
                 "suffixes K, M, G, T (powers of 1024). Default: 2G.")
      ->check(CLI::Validator(
          [](std::string& v) { return parse_byte_size(v) ? std::string() : "not a size like 2G or 500M: " + v; },
          "SIZE"));
  app.add_option("--weld-tolerance", g_weld_tolerance,
                 "STL input: weld corners closer than this distance (in the file's units) into one vertex. "
                 "Default: 0 (corners with identical coordinates only).")
      ->check(CLI::NonNegativeNumber);

  InfoOptions info;
  ConvertOptions convert;
  FlowCommandOptions flow;
  CLI::App* info_cmd = add_info_command(app, info);
  CLI::App* convert_cmd = add_convert_command(app, convert);
  CLI::App* flow_cmd = add_flow_command(app, flow);
  CutCommandOptions cut;
  CLI::App* cut_cmd = add_cut_command(app, cut);
  UniformizeCommandOptions uniformize, layout;
  CLI::App* uniformize_cmd = add_uniformize_command(app, uniformize);
  CLI::App* layout_cmd = add_layout_command(app, layout);
  CoverCommandOptions cover;
  CLI::App* cover_cmd = add_cover_command(app, cover);
  SignatureCommandOptions signature;
  CLI::App* signature_cmd = add_signature_command(app, signature);
  CompareCommandOptions compare;
  CLI::App* compare_cmd = add_compare_command(app, compare);
  // `batch` and `summarize` are the Python package's (lib/python/ricci/batch.py): everything after
  // the subcommand's name goes to it unparsed, --help included.
  CLI::App* batch_cmd = app.add_subcommand("batch", "Uniformize every mesh of a dataset on Dask (Python; see "
                                                    "`ricci batch --help`).");
  CLI::App* summarize_cmd = app.add_subcommand("summarize", "OUTDIR/summary.csv from the report.json files of a "
                                                            "batch (Python).");
  for (CLI::App* c : {batch_cmd, summarize_cmd}) c->prefix_command()->allow_extras()->fallthrough(false)->set_help_flag();

  // An OpenMP default above the processors available (a mistaken OMP_NUM_THREADS) is lowered to
  // them: every parallel region would otherwise try to start that many threads.
  ricci::cap_default_threads();
  // A file-size limit (ulimit -f) reached while writing is a failed write, not a signal: with
  // SIGXFSZ ignored the write returns EFBIG, and the writers clean up and exit 6 as on a full disk.
  std::signal(SIGXFSZ, SIG_IGN);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) {
      app.exit(e);  // --help or --version: prints to stdout
      return finish_stdout(kExitOk);
    }
    std::cerr << "ricci: error: " << e.what() << "\nRun with --help for more information.\n";
    return kExitUsage;
  }

  set_max_input_bytes(parse_byte_size(max_file_size).value_or(kDefaultMaxFileBytes));
  if (info_cmd->parsed()) return run_info(info);
  if (convert_cmd->parsed()) return run_convert(convert);
  if (flow_cmd->parsed()) return run_flow(flow);
  if (cut_cmd->parsed()) return run_cut(cut);
  if (uniformize_cmd->parsed()) return run_uniformize(uniformize);
  if (layout_cmd->parsed()) return run_uniformize(layout);
  if (cover_cmd->parsed()) return run_cover(cover);
  if (signature_cmd->parsed()) return run_signature(signature);
  if (compare_cmd->parsed()) return run_compare(compare);
  if (batch_cmd->parsed()) return run_python_command("batch", batch_cmd->remaining());
  if (summarize_cmd->parsed()) return run_python_command("summarize", summarize_cmd->remaining());
  print_error("no subcommand given");
  return kExitUsage;
}

}  // namespace ricci_cli
