// ricci command-line driver: the `flow` subcommand (see commands.h).
//
//   load_mesh → initial_metric → target → check_target → solve_flow → (write OUT) → summary
//
// Output file layouts (-o OUT; written only when the flow converged, atomically):
//
//   OUT ends in ".json": one JSON object
//     { "format": "ricci-flow-metric", "version": 1, "vertex_numbering": "…",
//       "mesh": …, "geometry": …, "scheme": …, "flips": …, "straight_tiles": …, "boundary": …,
//       "target": …, "method": …,
//       "iterations": …, "max_curvature_error": …, "gauss_bonnet_error": …,
//       "num_vertices": V, "num_edges": E, "num_faces": F,
//       "vertices": { "input_vertex": [V], "u": [V], "K": [V], "K_target": [V] },
//       "edges":    { "v0": [E], "v1": [E], "length": [E] } }
//
//   anything else: CSV with `#` comment lines, two sections, each introduced by its header line
//     # vertex,input_vertex,u,K,K_target      then V rows
//     # edge,v0,v1,length                     then E rows
//
// With intrinsic flips (the default: yamabe with flips) the edges are still the input's: their
// lengths are those of the input's edges made straight in the solution's metric, which is carried
// by the intrinsic Delaunay triangulation; "straight_tiles" (CSV: `# flips=yes straight_tiles=…`)
// says whether the input's triangles with those lengths tile the surface (`ricci layout` needs it;
// `ricci uniformize` lays out the common subdivision otherwise). u and K are exact either way.
//
// Vertices are numbered 0-based after validation (vertices used by no face are dropped, and with
// --largest-component the vertices of other components too); `input_vertex` is the 0-based index
// of the same vertex in the input file, −1 for the midpoints added by splitting ears (numbered
// after all others, see --no-split-ears). Edges are numbered as in ricci's topology; v0 → v1 is the
// edge's direction in its first face. Numbers are written as the shortest decimal that reads back
// to the same double.
#include <CLI/CLI.hpp>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "commands.h"
#include "flow_setup.h"
#include "flow_run.h"
#include "ricci/flow.h"
#include "ricci/io.h"
#include "ricci/metric.h"
#include "ricci/topology.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"

namespace ricci_cli {

namespace {

using Json = nlohmann::ordered_json;
using ricci::BoundaryMode;
using ricci::Geometry;
using ricci::Index;
using ricci::Method;
using ricci::Scheme;
using ricci::Status;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

/// Iteration limit of gradient descent when --max-iter is not given (Newton uses FlowOptions').
constexpr int kGradientMaxIterations = 20000;

constexpr const char* kVertexNumberingNote =
    "vertices are numbered 0-based after validation: vertices used by no face are dropped (and, "
    "with --largest-component, those of the other components); input_vertex is the 0-based index "
    "of the same vertex in the input file (-1 for a vertex added by splitting an ear, or by `ricci uniformize`'s "
    "Steiner subdivision, whose edges are listed then; those come last)";

}  // namespace

// ---- option values (shared with other commands through flow_setup.h) -------------------------

std::optional<Geometry> parse_geometry(const std::string& s) {
  if (s == "euclidean") return Geometry::Euclidean;
  if (s == "hyperbolic") return Geometry::Hyperbolic;
  if (s == "spherical") return Geometry::Spherical;
  return std::nullopt;
}

std::optional<Scheme> parse_scheme(const std::string& s) {
  if (s == "circle-packing") return Scheme::CirclePacking;
  if (s == "inversive-distance") return Scheme::InversiveDistance;
  if (s == "yamabe") return Scheme::Yamabe;
  return std::nullopt;
}

std::optional<Method> parse_method(const std::string& s) {
  if (s == "newton") return Method::Newton;
  if (s == "gradient") return Method::GradientDescent;
  return std::nullopt;
}

std::string_view method_name(Method m) { return m == Method::Newton ? "newton" : "gradient"; }

/// A whole-string number; a trailing "pi" multiplies by π ("2pi", "-0.5pi", "pi").
std::optional<double> parse_angle(std::string_view s) {
  double factor = 1;
  if (s.size() >= 2 && s.substr(s.size() - 2) == "pi") {
    factor = std::numbers::pi;
    s.remove_suffix(2);
    if (s.empty() || s == "+") return factor;
    if (s == "-") return -factor;
  }
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double x = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
  if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(x)) return std::nullopt;
  return x * factor;
}

std::optional<TargetSpec> parse_target(const std::string& s, std::string* why) {
  TargetSpec t;
  if (s == "auto" || s == "uniform") return t;
  if (s.rfind("cones=", 0) == 0) {
    t.kind = TargetSpec::Kind::Cones;
    t.file = s.substr(6);
    if (t.file.empty()) {
      *why = "cones=FILE needs a file name";
      return std::nullopt;
    }
    return t;
  }
  if (s.rfind("single-vertex=", 0) == 0) {
    t.kind = TargetSpec::Kind::SingleVertex;
    const std::string_view v = std::string_view(s).substr(14);
    const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), t.vertex);
    if (v.empty() || ec != std::errc() || end != v.data() + v.size() || t.vertex < 0) {
      *why = "single-vertex=I needs a vertex index I >= 0, got '" + std::string(v) + "'";
      return std::nullopt;
    }
    return t;
  }
  *why = "unknown target '" + s + "' (use auto, uniform, cones=FILE or single-vertex=I)";
  return std::nullopt;
}

std::optional<BoundarySpec> parse_boundary(const std::string& s, std::string* why) {
  BoundarySpec b;
  if (s == "auto") return b;
  b.automatic = false;
  if (s == "free") {
    b.mode = BoundaryMode::Free;
    return b;
  }
  if (s == "fixed") {
    b.mode = BoundaryMode::FixedLengths;
    return b;
  }
  if (s == "circle") {
    b.mode = BoundaryMode::Circle;
    return b;
  }
  if (s == "geodesic") {
    b.mode = BoundaryMode::Geodesic;
    return b;
  }
  if (s.rfind("loop-totals=", 0) == 0) {
    b.mode = BoundaryMode::LoopTotals;
    std::string_view rest = std::string_view(s).substr(12);
    while (true) {
      const std::size_t comma = rest.find(',');
      const std::string_view item = rest.substr(0, comma);
      const std::optional<double> x = parse_angle(item);
      if (!x) {
        *why = "loop-totals: '" + std::string(item) + "' is not a number (radians, or a multiple of pi like 2pi)";
        return std::nullopt;
      }
      b.totals.push_back(*x);
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
    return b;
  }
  *why = "unknown boundary mode '" + s + "' (use auto, free, fixed, circle, geodesic or loop-totals=T1,T2,...)";
  return std::nullopt;
}

/// A validator for a number: positive (`strict`) or non-negative; integral when `integer`.
CLI::Validator number_validator(bool strict, bool integer) {
  const std::string what = std::string(strict ? "a positive " : "a non-negative ") + (integer ? "integer" : "number");
  return CLI::Validator(
      [=](std::string& value) -> std::string {
        double x = 0;
        const char* b = value.data();
        const char* e = b + value.size();
        const auto [end, ec] = std::from_chars(b, e, x);
        const bool ok = ec == std::errc() && end == e && std::isfinite(x) && (strict ? x > 0 : x >= 0) &&
                        (!integer || (x == std::floor(x) && x <= 1e9));
        return ok ? std::string() : "must be " + what + ", got '" + value + "'";
      },
      strict ? "POSITIVE" : "NONNEGATIVE");
}

bool has_extension(const std::string& path, std::initializer_list<const char*> exts) {
  std::string e = fs::path(path).extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const char* x : exts)
    if (e == x) return true;
  return false;
}


TargetBuild build_target(const ricci::Topology& topo, BoundaryMode mode, const TargetSpec& target_spec,
                         const BoundarySpec& boundary_spec, const std::string& target_text,
                         const std::string& boundary_text) {
  TargetBuild out;
  auto usage = [&](const std::string& m) {
    out.usage = true;
    out.status = Status::InvalidArgument;
    out.message = m;
    return out;
  };
  ricci::Target& target = out.target;
  switch (target_spec.kind) {
    case TargetSpec::Kind::Uniform:
      target = ricci::uniform_target(topo, mode);
      break;
    case TargetSpec::Kind::SingleVertex:
      if (target_spec.vertex >= topo.num_vertices)
        return usage("--target " + target_text + ": the mesh has " + std::to_string(topo.num_vertices) +
                     " vertices (numbered 0-based after validation)");
      target = ricci::single_vertex_target(topo, static_cast<Index>(target_spec.vertex), mode);
      break;
    case TargetSpec::Kind::Cones: {
      // The target reader holds the whole file in memory: refuse one above the input limit first.
      if (std::string too_large = input_too_large(target_spec.file); !too_large.empty()) {
        out.status = Status::FileTooLarge;
        out.message = std::move(too_large);
        return out;
      }
      ricci::TargetFileResult tf = ricci::read_target_file(target_spec.file, topo, mode);
      if (tf.status != Status::Ok) {
        out.status = tf.status;
        out.message = tf.message;
        return out;
      }
      target = std::move(tf.target);
      break;
    }
  }
  if (mode == BoundaryMode::LoopTotals && !topo.is_closed()) {
    if (boundary_spec.totals.size() != static_cast<std::size_t>(topo.num_boundary_loops()))
      return usage("--boundary " + boundary_text + " gives " + std::to_string(boundary_spec.totals.size()) +
                   " loop totals but the mesh has " + std::to_string(topo.num_boundary_loops()) +
                   " boundary loops (in the order `ricci info` lists them)");
    // A single-vertex target puts the rest of the total curvature at its vertex: keep that true
    // for the totals given here.
    double old_sum = 0, new_sum = 0;
    for (double x : target.loop_total) old_sum += x;
    for (double x : boundary_spec.totals) new_sum += x;
    const Index sv = static_cast<Index>(target_spec.vertex);
    if (target_spec.kind == TargetSpec::Kind::SingleVertex && !topo.is_boundary_vertex(sv) &&
        target.loop_total.size() == boundary_spec.totals.size())
      target.K[sv] += old_sum - new_sum;
    target.loop_total = boundary_spec.totals;
    // Stored boundary values: the equal share of each loop (the flow derives them from lengths).
    for (Index i = 0; i < topo.num_boundary_loops(); ++i) {
      const Index n = topo.boundary_offsets[i + 1] - topo.boundary_offsets[i];
      for (Index k = topo.boundary_offsets[i]; k < topo.boundary_offsets[i + 1]; ++k)
        target.K[topo.boundary_vertices[k]] = target.loop_total[i] / n;
    }
  }
  return out;
}

namespace {

// ---- formatting -----------------------------------------------------------------------------

std::string sci(double x, const char* fmt = "%.3e") {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, x);
  return buf;
}

/// A number for JSON, null when it is not finite (JSON has no NaN or infinity).
Json real(double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); }

}  // namespace

Json flow_json(const FlowReport& r) {
  Json j;
  j["status"] = r.status == Status::Ok ? std::string("converged") : std::string(ricci::status_name(r.status));
  j["message"] = r.message;
  j["file"] = r.file;
  j["embedded_default"] = r.embedded;
  auto count = [&](const char* key, std::int64_t v) { j[key] = r.have_mesh ? Json(v) : Json(nullptr); };
  count("vertices", r.vertices);
  count("edges", r.edges);
  count("faces", r.faces);
  count("boundary_loops", r.boundary_loops);
  count("euler_characteristic", r.euler_characteristic);
  count("genus", r.genus);
  j["geometry"] = r.geometry ? Json(std::string(ricci::geometry_name(*r.geometry))) : Json(nullptr);
  j["scheme"] = std::string(ricci::scheme_name(r.scheme));
  j["flips"] = r.flips;
  j["intrinsic"] = r.flips ? Json{{"delaunay_flips", r.intrinsic.delaunay_flips},
                                  {"flow_flips", r.intrinsic.flow_flips},
                                  {"crossings", r.intrinsic.crossings},
                                  {"straight_tiles", r.intrinsic.straight_tiles},
                                  {"inconsistent_vertices", r.intrinsic.inconsistent_vertices}}
                           : Json(nullptr);
  j["boundary"] = r.boundary.empty() ? Json(nullptr) : Json(r.boundary);
  j["loop_totals"] = r.loop_totals;
  j["target"] = r.target;
  j["method"] = std::string(method_name(r.method));
  j["tolerance"] = r.tolerance;
  j["max_iterations"] = r.max_iterations;
  j["step"] = r.method == Method::GradientDescent ? Json(r.step) : Json(nullptr);
  j["threads"] = r.threads;
  j["length_scale"] = r.have_metric ? real(r.length_scale) : Json(nullptr);
  const bool packing = r.have_metric && r.scheme == Scheme::CirclePacking;
  j["edges_clamped"] = packing ? Json(std::int64_t{r.clamped_high} + r.clamped_low) : Json(nullptr);
  j["edges_clamped_high"] = packing ? Json(r.clamped_high) : Json(nullptr);
  j["edges_clamped_low"] = packing ? Json(r.clamped_low) : Json(nullptr);
  j["edges_relaxed"] = packing ? Json(r.edges_relaxed) : Json(nullptr);
  j["cycles_relaxed"] = packing ? Json(r.cycles_relaxed) : Json(nullptr);
  const ricci::FlowResult& f = r.flow;
  j["iterations"] = r.have_flow ? Json(f.iterations) : Json(nullptr);
  j["chord_steps"] = r.have_flow ? Json(f.chord_steps) : Json(nullptr);
  j["max_curvature_error"] = r.have_flow ? real(f.max_curvature_error) : Json(nullptr);
  j["curvature_resolution"] = r.have_flow ? real(f.curvature_resolution) : Json(nullptr);
  j["resolution_vertices"] = r.have_flow ? Json(f.resolution_vertices) : Json(nullptr);
  j["gauss_bonnet_error"] = r.have_flow ? real(f.gauss_bonnet_error) : Json(nullptr);
  j["seconds"] = r.have_flow ? real(f.seconds) : Json(nullptr);
  j["total_seconds"] = r.total_seconds;
  j["output"] = r.output.empty() ? Json(nullptr) : Json(r.output);
  Json history = Json::array();
  for (const ricci::IterationRecord& h : f.history) {
    history.push_back(Json{{"iteration", h.iteration},
                           {"max_error", real(h.max_error)},
                           {"energy", real(h.energy)},
                           {"step", real(h.step)},
                           {"chord", h.chord},
                           {"seconds", real(h.seconds)}});
  }
  j["history"] = std::move(history);
  j["notes"] = r.notes;
  j["repairs"] = repairs_json(r.repairs);
  return j;
}

namespace {

/// Prints the summary (text or JSON) and returns the exit code for the report's status, or
/// `code` when given (for outcomes that have no status of their own).
int finish(const FlowCommandOptions& options, FlowReport& r, Clock::time_point start,
           std::optional<int> code = std::nullopt) {
  r.total_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (!r.console) return code ? *code : exit_code(r.status);
  if (options.json) {
    std::cout << flow_json(r).dump(2) << '\n';
  } else if (r.have_flow && r.status == r.flow.status) {
    std::cout << r.flow.brief_report() << '\n';
  } else if (r.have_flow) {
    // The flow converged but writing its metric failed: no "ok".
    std::cout << ricci::status_name(r.status) << ": " << r.message << '\n';
  }
  return finish_stdout(code ? *code : exit_code(r.status));
}

/// Records a failure: the status and message in the report and an error line on stderr.
void fail(FlowReport& r, Status status, const std::string& message) {
  r.status = status;
  r.message = message;
  if (r.console) print_error(message);
}

}  // namespace

std::string metric_file_text(const MetricHeader& h, const ricci::FlowResult& f, const ricci::Topology& t,
                             std::span<const Index> vertex_to_input, bool json) {
  const std::string& geometry = h.geometry;
  if (json) {
    Json j;
    j["format"] = "ricci-flow-metric";
    j["version"] = 1;
    j["vertex_numbering"] = kVertexNumberingNote;
    j["mesh"] = h.mesh;
    j["geometry"] = geometry;
    j["scheme"] = h.scheme;
    j["flips"] = h.flips;
    j["straight_tiles"] = h.straight_tiles;
    j["boundary"] = h.boundary;
    j["target"] = h.target;
    j["method"] = h.method;
    j["iterations"] = f.iterations;
    j["max_curvature_error"] = real(f.max_curvature_error);
    j["curvature_resolution"] = real(f.curvature_resolution);
    j["gauss_bonnet_error"] = real(f.gauss_bonnet_error);
    j["num_vertices"] = t.num_vertices;
    j["num_edges"] = t.num_edges;
    j["num_faces"] = t.num_faces;
    Json input = Json::array(), u = Json::array(), K = Json::array(), Kt = Json::array();
    for (Index v = 0; v < t.num_vertices; ++v) {
      input.push_back(vertex_to_input[v]);
      u.push_back(real(f.u[v]));
      K.push_back(real(f.K[v]));
      Kt.push_back(real(f.K_target[v]));
    }
    j["vertices"] = Json{{"input_vertex", std::move(input)}, {"u", std::move(u)}, {"K", std::move(K)},
                         {"K_target", std::move(Kt)}};
    Json v0 = Json::array(), v1 = Json::array(), l = Json::array();
    for (Index e = 0; e < t.num_edges; ++e) {
      v0.push_back(t.edge_vertices[2 * e]);
      v1.push_back(t.edge_vertices[2 * e + 1]);
      l.push_back(real(f.l[e]));
    }
    j["edges"] = Json{{"v0", std::move(v0)}, {"v1", std::move(v1)}, {"length", std::move(l)}};
    return j.dump() + '\n';
  }
  std::string s;
  s.reserve(static_cast<std::size_t>(t.num_vertices) * 80 + static_cast<std::size_t>(t.num_edges) * 48 + 1024);
  s += "# ricci flow metric of " + h.mesh + '\n';
  s += "# geometry=" + geometry + " scheme=" + h.scheme + " boundary=" +
       h.boundary + " target=" + h.target + " method=" + h.method + '\n';
  s += std::string("# flips=") + (h.flips ? "yes" : "no") + " straight_tiles=" + (h.straight_tiles ? "yes" : "no") + '\n';
  if (h.flips)
    s += "# intrinsic flips: u and K are exact; lengths are the input's edges made straight in the solution's "
         "metric" + std::string(h.straight_tiles ? ".\n" : ", whose triangles do not tile the surface (some fold).\n");
  s += "# iterations=" + std::to_string(f.iterations) + " max_curvature_error=";
  append_number(s, f.max_curvature_error);
  s += " gauss_bonnet_error=";
  append_number(s, f.gauss_bonnet_error);
  s += '\n';
  s += std::string("# ") + kVertexNumberingNote + ".\n";
  s += "# u: log-radius / conformal factor; K: curvature of the final metric; K_target: target (radians).\n";
  s += "# vertex,input_vertex,u,K,K_target\n";
  for (Index v = 0; v < t.num_vertices; ++v) {
    append_number(s, std::int64_t{v});
    s += ',';
    append_number(s, std::int64_t{vertex_to_input[v]});
    s += ',';
    append_number(s, f.u[v]);
    s += ',';
    append_number(s, f.K[v]);
    s += ',';
    append_number(s, f.K_target[v]);
    s += '\n';
  }
  s += "# edge lengths of the final metric in the background geometry; v0, v1 numbered as above.\n";
  s += "# edge,v0,v1,length\n";
  for (Index e = 0; e < t.num_edges; ++e) {
    append_number(s, std::int64_t{e});
    s += ',';
    append_number(s, std::int64_t{t.edge_vertices[2 * e]});
    s += ',';
    append_number(s, std::int64_t{t.edge_vertices[2 * e + 1]});
    s += ',';
    append_number(s, f.l[e]);
    s += '\n';
  }
  return s;
}

// Writes the metric to options.output (when given) and finishes the run.
int write_metric(const FlowCommandOptions& options, FlowReport& r, Clock::time_point start, const ricci::Topology& topo,
                 std::span<const Index> vertex_to_input, const std::vector<std::string>& protected_paths) {
  if (!options.output.empty()) {
    const bool json = has_extension(options.output, {".json"});
    const MetricHeader header{r.file, r.geometry ? std::string(ricci::geometry_name(*r.geometry)) : std::string(),
                              std::string(ricci::scheme_name(r.scheme)), r.boundary, r.target,
                              std::string(method_name(r.method)), r.flips,
                              !r.flips || r.intrinsic.straight_tiles};
    const std::string data = metric_file_text(header, r.flow, topo, vertex_to_input, json);
    ricci::WriteResult w;
    {
      const InterruptsDeferred deferred;
      w = ricci::write_file_atomic(options.output, data, protected_paths);
    }
    if (w.status != Status::Ok) {
      print_error(w.message);
      if (w.status == Status::OutputIsInput)
        print_error("the output must be a different file from the input; nothing was written");
      r.status = w.status;
      r.message = w.message;
      return finish(options, r, start);
    }
    r.output = options.output;
    print_note(options.quiet, "wrote " + options.output + " (" + (json ? "JSON" : "CSV") + ", " +
                                  std::to_string(topo.num_vertices) + " vertices, " +
                                  std::to_string(topo.num_edges) + " edges, " + std::to_string(w.bytes_written) +
                                  " bytes)");
  }
  return finish(options, r, start);
}

// Vertex scaling with intrinsic flips (ricci::conformal_metric(): the flow stages of uniformize,
// with its fallback to circle packing), then the output.
int flow_with_flips(const FlowCommandOptions& options, FlowReport& r, Clock::time_point start,
                    const ricci::ValidateResult& validated, BoundaryMode mode, const ricci::Target& target,
                    const ricci::FlowOptions& fo, const std::vector<std::string>& protected_paths) {
  const ricci::Topology& topo = validated.topology;
  ricci::UniformizeOptions uo;
  uo.geometry = *r.geometry;
  if (!topo.is_closed()) uo.boundary = mode;
  uo.metric.scheme = Scheme::Yamabe;
  uo.flow = fo;
  uo.intrinsic_flips = true;
  ricci::UniformizeResult u = ricci::conformal_metric(validated.mesh, topo, uo, &target);
  r.flips = u.intrinsic.used;
  r.intrinsic = u.intrinsic;
  if (const auto rep = mollification_repair(u.metric.mollification)) {
    r.repairs.push_back(*rep);
    print_note(options.quiet, rep->message);
  }
  if (u.metric.status == Status::Ok) {
    r.have_metric = true;
    r.length_scale = u.metric.length_scale;
    r.clamped_high = u.metric.edges_clamped_high;
    r.clamped_low = u.metric.edges_clamped_low;
  }
  if (!u.intrinsic.fallback.empty()) r.scheme = Scheme::CirclePacking;
  r.have_flow = u.flow.status != Status::NotRun;
  r.flow = std::move(u.flow);
  for (const std::string& n : r.flow.notes) {
    r.notes.push_back(n);
    print_note(options.quiet, n);
  }
  if (r.flips && !r.intrinsic.straight_tiles) {
    const std::string note = "the input's edges made straight in the solution's metric fold at " +
                             std::to_string(r.intrinsic.inconsistent_vertices) +
                             " vertices: u and K are exact, but a layout of the input's own triangles with these "
                             "lengths is not (ricci uniformize lays out the common subdivision instead)";
    r.notes.push_back(note);
    print_note(options.quiet, note);
  }
  if (u.status != Status::Ok) {
    fail(r, u.status, r.file + ": " + u.message);
    if (r.console && !options.output.empty() && u.failed_stage == "flow")
      print_error("no output written to " + options.output + " (the flow did not converge)");
    return finish(options, r, start);
  }
  r.status = Status::Ok;
  r.message = r.flow.message;
  return write_metric(options, r, start, topo, validated.vertex_to_input, protected_paths);
}

// The flow on the input's own triangulation (circle packing, inversive distance, or vertex
// scaling with --no-flips): initial metric, target, check, solve_flow(), then the output.
int flow_as_given(const FlowCommandOptions& options, FlowReport& r, Clock::time_point start,
                  const ricci::ValidateResult& validated, const ricci::Target& target, const ricci::FlowOptions& fo,
                  const std::vector<std::string>& protected_paths) {
  const ricci::Topology& topo = validated.topology;
  // ---- initial metric ----
  ricci::InitialMetricOptions mo;
  mo.geometry = *r.geometry;
  mo.scheme = r.scheme;
  mo.relax_angles = !options.no_angle_relax;
  const ricci::InitialMetric metric = ricci::initial_metric(validated.mesh, topo, mo);
  if (metric.status != Status::Ok) {
    fail(r, metric.status, r.file + ": initial metric: " + metric.message);
    return finish(options, r, start);
  }
  if (const auto rep = mollification_repair(metric.mollification)) {
    r.repairs.push_back(*rep);
    print_note(options.quiet, rep->message);
  }
  r.have_metric = true;
  r.length_scale = metric.length_scale;
  r.clamped_high = metric.edges_clamped_high;
  r.clamped_low = metric.edges_clamped_low;
  r.cycles_relaxed = metric.cycles_relaxed;
  r.edges_relaxed = metric.edges_relaxed;
  if (r.scheme == Scheme::CirclePacking && metric.edges_clamped_high + metric.edges_clamped_low > 0) {
    const std::string note = "circle packing: " + std::to_string(metric.edges_clamped_high) +
                             " edge angles clamped to pi/2 and " + std::to_string(metric.edges_clamped_low) +
                             " to 0 (the packing metric only approximates the mesh's lengths there)";
    r.notes.push_back(note);
    print_note(options.quiet, note);
  }

  if (metric.edges_relaxed > 0) {
    const std::string note = "circle packing: lowered the angles of " + std::to_string(metric.edges_relaxed) +
                             " edges on " + std::to_string(metric.cycles_relaxed) +
                             " separating 3- or 4-cycles where Step 2's angles make zero curvature inside them "
                             "infeasible (--no-angle-relax keeps them)";
    r.notes.push_back(note);
    print_note(options.quiet, note);
  }

  const ricci::TargetCheck check = ricci::check_target(topo, metric.structure, target);
  if (check.status != Status::Ok) {
    fail(r, check.status, r.file + ": target: " + check.message);
    return finish(options, r, start);
  }

  // ---- flow ----
  r.flow = ricci::solve_flow(topo, metric.structure, metric.u, target, fo);
  r.have_flow = true;
  r.status = r.flow.status;
  r.message = r.flow.message;
  for (const std::string& n : r.flow.notes) {
    r.notes.push_back(n);
    print_note(options.quiet, n);
  }
  if (r.flow.status != Status::Ok) {
    if (r.console) print_error(r.file + ": " + r.flow.message);
    if (r.console && !options.output.empty()) print_error("no output written to " + options.output + " (the flow did not converge)");
    return finish(options, r, start);
  }

  return write_metric(options, r, start, topo, validated.vertex_to_input, protected_paths);
}

int run_flow(const FlowCommandOptions& options) {
  FlowReport r;
  return flow_run(options, r);
}

int flow_run(const FlowCommandOptions& options, FlowReport& r) {
  const Clock::time_point start = Clock::now();
  r.embedded = options.mesh.empty() && !r.preread;
  if (!r.preread) r.file = r.embedded ? std::string(embedded_default_name()) : options.mesh;
  r.target = options.target;
  r.tolerance = options.tolerance;
  r.step = options.step;
  r.threads = options.threads;

  // ---- settings (all usage errors are found before any file is read) ----
  const auto usage = [&](const std::string& message) {
    fail(r, Status::InvalidArgument, message);
    return finish(options, r, start, kExitUsage);
  };
  std::string why;
  std::optional<Geometry> geometry;
  if (options.geometry != "auto") {
    geometry = parse_geometry(options.geometry);
    if (!geometry) return usage("unknown geometry '" + options.geometry + "'");
  }
  const std::optional<Scheme> scheme = parse_scheme(options.scheme == "auto" ? std::string("yamabe") : options.scheme);
  if (!scheme) return usage("unknown scheme '" + options.scheme + "'");
  r.scheme = *scheme;
  const bool flips = *scheme == Scheme::Yamabe && !options.no_flips;
  const std::optional<Method> method = parse_method(options.method);
  if (!method) return usage("unknown method '" + options.method + "'");
  r.method = *method;
  const std::optional<TargetSpec> target_spec = parse_target(options.target, &why);
  if (!target_spec) return usage(why);
  if (target_spec->kind == TargetSpec::Kind::Uniform) r.target = "uniform";
  const std::optional<BoundarySpec> boundary_spec = parse_boundary(options.boundary, &why);
  if (!boundary_spec) return usage(why);

  ricci::FlowOptions fo;
  fo.method = *method;
  fo.tolerance = options.tolerance;
  fo.max_iterations = options.max_iterations > 0
                          ? options.max_iterations
                          : (*method == Method::Newton ? ricci::FlowOptions{}.max_iterations : kGradientMaxIterations);
  fo.gradient_step = options.step;
  std::string threads_note;
  fo.threads = usable_threads(options.threads, threads_note);
  r.threads = fo.threads;
  if (!threads_note.empty()) {
    r.notes.push_back(threads_note);
    print_note(options.quiet, threads_note);
  }
  fo.normalize_circle_domains = !options.no_circle_normalization;
  r.max_iterations = fo.max_iterations;
  if (options.max_iterations < 0) return usage("--max-iter must be positive");
  if (!fo.is_valid(&why)) return usage(why);

  std::vector<std::string> protected_paths;
  if (!r.embedded && !r.preread) protected_paths.push_back(options.mesh);
  if (target_spec->kind == TargetSpec::Kind::Cones) protected_paths.push_back(target_spec->file);
  if (!options.output.empty()) {
    for (const std::string& p : protected_paths) {
      if (same_file(options.output, p)) {
        fail(r, Status::OutputIsInput,
             "refusing to write " + options.output + ": it is the input file " + p + "; nothing was written");
        return finish(options, r, start);
      }
    }
    if (has_extension(options.output, {".obj", ".off", ".ply"}))
      return usage("-o " + options.output +
                   ": the flow writes its metric as CSV or JSON (.json), not a mesh; choose another name");
    const fs::path parent = fs::path(options.output).parent_path();
    std::error_code ec;
    if (!parent.empty() && !fs::is_directory(parent, ec)) {
      fail(r, Status::WriteFailed, "cannot write " + options.output + ": " + parent.string() + " is not a directory");
      return finish(options, r, start);
    }
  }

  // ---- load ----
  if (r.embedded)
    print_note(options.quiet, std::string("no MESH given; using the embedded default mesh ") + embedded_default_name());
  ricci::ValidateOptions vo;
  vo.keep_largest_component = options.largest_component;
  ricci::LoadResult loaded = r.preread ? ricci::validate_read(*r.preread, r.file, vo)
                                       : load_input(r.embedded ? std::string() : options.mesh, vo);
  if (loaded.status != Status::Ok) {
    fail(r, loaded.status, loaded.message);  // names the file
    return finish(options, r, start);
  }
  r.repairs = loaded.repairs;
  r.input = std::move(loaded.validated);
  ricci::ValidateResult& validated = r.input;
  for (const ricci::Repair& rep : r.repairs) print_note(options.quiet, rep.message);

  const ricci::Topology& topo = validated.topology;  // split_ears below replaces its content
  r.have_mesh = true;
  r.vertices = topo.num_vertices;
  r.edges = topo.num_edges;
  r.faces = topo.num_faces;
  r.boundary_loops = topo.num_boundary_loops();
  r.euler_characteristic = topo.euler_characteristic();
  r.genus = topo.genus();

  // ---- geometry, boundary mode, ears the target cannot realise (split: new vertices come last),
  // the target (both solves take it as built here) ----
  r.geometry = geometry ? *geometry : ricci::natural_geometry(topo);
  PreparedTarget prepared = prepare_target(validated, *r.geometry, *target_spec, *boundary_spec, options.target,
                                           options.boundary, !options.no_split_ears, r.file);
  r.boundary = topo.is_closed() ? std::string("none") : std::string(ricci::boundary_mode_name(prepared.mode));
  for (const std::string& note : prepared.notes) {
    r.notes.push_back(note);
    print_note(options.quiet, note);
  }
  if (prepared.ear_split) {
    r.repairs.push_back(*prepared.ear_split);
    print_note(options.quiet, prepared.ear_split->message);
    r.vertices = topo.num_vertices;
    r.edges = topo.num_edges;
    r.faces = topo.num_faces;
  }
  if (prepared.usage) return usage(prepared.message);
  if (prepared.status != Status::Ok) {
    fail(r, prepared.status, prepared.message);
    return finish(options, r, start);
  }
  if (r.on_iteration) {
    fo.on_iteration = r.on_iteration;
  } else if (!options.quiet && r.console) {
    fo.on_iteration = [](const ricci::IterationRecord& rec) {
      std::cerr << "ricci: iteration " << rec.iteration << ": max error " << sci(rec.max_error) << ", energy "
                << sci(rec.energy, "%.6e") << ", step " << sci(rec.step, "%.3g") << ", " << sci(rec.seconds, "%.3f")
                << " s\n";
    };
  }
  r.loop_totals = prepared.target.loop_total;
  if (flips) return flow_with_flips(options, r, start, validated, prepared.mode, prepared.target, fo, protected_paths);
  return flow_as_given(options, r, start, validated, prepared.target, fo, protected_paths);
}

CLI::App* add_flow_command(CLI::App& app, FlowCommandOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "flow",
      "Run the discrete Ricci flow: find the conformal metric (u per vertex) whose curvature is the "
      "target. Progress per iteration and notes go to stderr, a summary line (or --json) to "
      "stdout; -o writes the metric (u, K, target K per vertex, lengths per edge) only when the "
      "flow converged.");
  cmd->add_option("MESH", o.mesh,
                  "Mesh file (.obj, .off, .ply). Default: the embedded genus-2 mesh (" +
                      std::string(embedded_default_name()) + ").");
  cmd->add_option("--geometry", o.geometry,
                  "Background geometry: auto (by the uniformization theorem: spherical for genus 0, "
                  "euclidean for genus 1, hyperbolic for genus >= 2; with boundary: euclidean for "
                  "genus 0, hyperbolic otherwise), euclidean, hyperbolic or spherical. Default: auto.")
      ->check(CLI::IsMember({"auto", "euclidean", "hyperbolic", "spherical"}));
  cmd->add_option("--scheme", o.scheme,
                  "Discrete conformal scheme: auto (= yamabe), yamabe (vertex scaling, with intrinsic Delaunay "
                  "flips unless --no-flips; circle packing should that solve fail, with a note), circle-packing "
                  "(Thurston, the paper's) or inversive-distance. Default: auto.")
      ->check(CLI::IsMember({"auto", "circle-packing", "inversive-distance", "yamabe"}));
  cmd->add_flag("--no-flips", o.no_flips,
                "Vertex scaling on the input's triangulation as it is, without intrinsic Delaunay flips (stops on "
                "many non-Delaunay meshes; for comparison).");
  cmd->add_option("--target", o.target,
                  "Target curvature: auto (= uniform), uniform (0 at interior vertices: "
                  "uniformization), cones=FILE (lines 'vertex curvature', vertex 0-based after "
                  "validation, radians, '#' comments; unlisted interior vertices get 0) or "
                  "single-vertex=I (all curvature at vertex I). Default: auto.")
      ->check(spec_validator(parse_target, "auto|uniform|cones=FILE|single-vertex=I"));
  cmd->add_option("--boundary", o.boundary,
                  "Boundary condition (ignored for closed surfaces): auto (circle in euclidean, "
                  "geodesic in hyperbolic), free (boundary targets as given, e.g. by cones=FILE), "
                  "fixed (boundary u held: Dirichlet), circle (each loop a circle; the longest "
                  "totals 2pi, the others -2pi), geodesic (0 curvature on the boundary) or "
                  "loop-totals=T1,T2,... (total curvature per loop in radians, '2pi' style allowed, "
                  "loops in the order `ricci info` lists them). Default: auto.")
      ->check(spec_validator(parse_boundary, "auto|free|fixed|circle|geodesic|loop-totals=T1,T2,..."));
  cmd->add_option("--method", o.method,
                  "Solver: newton (sparse Cholesky, line search) or gradient (explicit flow "
                  "u += step (target K - K)). Default: newton.")
      ->check(CLI::IsMember({"newton", "gradient"}));
  cmd->add_option("--tol", o.tolerance,
                  "Stop when max |target K - K| < TOL (radians). Default: 1e-10.")
      ->check(number_validator(true, false));
  cmd->add_option("--max-iter", o.max_iterations,
                  "Iteration limit. Default: " + std::to_string(ricci::FlowOptions{}.max_iterations) +
                      " for newton, " + std::to_string(kGradientMaxIterations) + " for gradient.")
      ->check(number_validator(true, true));
  cmd->add_option("--step", o.step, "Gradient-descent step (the paper's epsilon). Default: 0.05.")
      ->check(number_validator(true, false));
  cmd->add_option("--threads", o.threads, "OpenMP threads; 0 uses the OpenMP default. Default: 0.")
      ->check(number_validator(false, true));
  cmd->add_option("-o,--output", o.output,
                  "Write the metric to OUT: JSON if OUT ends in .json, else CSV with sections "
                  "'# vertex,input_vertex,u,K,K_target' and '# edge,v0,v1,length' (vertices 0-based "
                  "after validation). Written atomically and only when the flow converged; never "
                  "replaces the input. Default: none (no file).")
      ->type_name("OUT");
  cmd->add_flag("--no-angle-relax", o.no_angle_relax,
                "Circle packing: keep Step 2's intersection angles exactly, even on separating 3- and "
                "4-cycles where they make zero curvature infeasible. Default: off (such cycles get "
                "smaller angles; the summary reports how many edges).");
  cmd->add_flag("--no-circle-normalization", o.no_circle_normalization,
                "Circle boundaries of genus-0 surfaces in E: leave the Moebius gauge of the circle domain "
                "free (Newton picks a member of the family) instead of fixing its normalization (which "
                "adds two small zero-sum modes to the outer loop's target). Default: off.");
  cmd->add_flag("--json", o.json,
                "Print one JSON summary object on stdout (status, settings, iterations, errors, "
                "history, notes) instead of the summary line. Default: off.");
  cmd->add_flag("-q,--quiet", o.quiet,
                "Silence progress and notes on stderr; errors are still printed. Default: off.");
  cmd->add_flag("--largest-component", o.largest_component,
                "Keep the largest connected component instead of failing on several. Default: off.");
  cmd->add_flag("--no-split-ears", o.no_split_ears,
                "Keep ears (boundary vertices in a single triangle) whose boundary target is <= 0 (inner circles, "
                "geodesic boundaries) as they are, so the target check fails on them; by default the edge opposite "
                "such an ear is split at its midpoint (a new vertex after the input's; reported in repairs). "
                "Default: off.");
  return cmd;
}

}  // namespace ricci_cli
