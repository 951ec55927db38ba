// ricci command-line driver — option values shared by the commands that run the flow (`flow`,
// `uniformize`): parsing of --geometry/--scheme/--target/--boundary/--method, CLI11 validators,
// and the target curvature built from them. Definitions in flow_command.cpp (the ear split in
// commands.cpp).
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ricci/flow.h"
#include "ricci/metric.h"
#include "ricci/status.h"
#include "ricci/topology.h"
#include "ricci/validate.h"

namespace ricci_cli {

std::optional<ricci::Geometry> parse_geometry(const std::string& s);
std::optional<ricci::Scheme> parse_scheme(const std::string& s);
std::optional<ricci::Method> parse_method(const std::string& s);
std::string_view method_name(ricci::Method m);
/// A whole-string number; a trailing "pi" multiplies by π ("2pi", "-0.5pi", "pi").
std::optional<double> parse_angle(std::string_view s);

/// --target: auto/uniform, cones=FILE, single-vertex=I.
struct TargetSpec {
  enum class Kind { Uniform, Cones, SingleVertex } kind = Kind::Uniform;
  std::string file;         ///< Cones
  std::int64_t vertex = 0;  ///< SingleVertex
};
std::optional<TargetSpec> parse_target(const std::string& s, std::string* why);

/// --boundary: auto, free, fixed, circle, geodesic, loop-totals=T1,T2,…
struct BoundarySpec {
  bool automatic = true;
  ricci::BoundaryMode mode = ricci::BoundaryMode::Circle;
  std::vector<double> totals;  ///< LoopTotals
};
std::optional<BoundarySpec> parse_boundary(const std::string& s, std::string* why);

/// A CLI11 validator from one of the parse functions above.
template <class Parse>
CLI::Validator spec_validator(Parse parse, const std::string& description) {
  return CLI::Validator(
      [parse](std::string& value) -> std::string {
        std::string why;
        return parse(value, &why) ? std::string() : why;
      },
      description);
}

/// A validator for a number: positive (`strict`) or non-negative; integral when `integer`.
CLI::Validator number_validator(bool strict, bool integer);

/// Whether the path's extension (case-insensitive) is one of `exts` (".obj", …).
bool has_extension(const std::string& path, std::initializer_list<const char*> exts);

/// The target curvature for the parsed --target and --boundary on a validated mesh: `usage` is
/// set for a bad option value (exit 2); otherwise `status` is Ok or the target file's error.
struct TargetBuild {
  ricci::Status status = ricci::Status::Ok;
  bool usage = false;
  std::string message;
  ricci::Target target;
};
TargetBuild build_target(const ricci::Topology& topo, ricci::BoundaryMode mode, const TargetSpec& target_spec,
                         const BoundarySpec& boundary_spec, const std::string& target_text,
                         const std::string& boundary_text);

/// The default of `flow` and `uniformize` (off with --no-split-ears): builds the target for `mode`
/// on the validated mesh and splits (ricci::split_ears) the ears it makes infeasible
/// (ricci::infeasible_ears), updating
/// `validated` in place (mesh, topology, vertex maps, repairs). The target must then be built
/// again on the new topology; the boundary, χ and every vertex index are unchanged. Returns the
/// repair when something was split. A target that cannot be built splits nothing (building it
/// again reports the error); a failing split is returned as `status`/`message`.
struct EarSplit {
  ricci::Status status = ricci::Status::Ok;
  std::string message;
  std::optional<ricci::Repair> repair;
};
EarSplit split_infeasible_ears(ricci::ValidateResult& validated, ricci::BoundaryMode mode,
                               const TargetSpec& target_spec, const BoundarySpec& boundary_spec,
                               const std::string& target_text, const std::string& boundary_text);

/// The step every command that runs a flow shares (`flow`, `uniformize`, `signature`) between
/// loading the mesh and solving: the boundary mode — none on a closed surface (with a note when
/// --boundary was given), else the one given or the natural one for `geometry`; with `split_ears`,
/// the ears that target makes infeasible split (split_infeasible_ears(), `validated` updated in
/// place); then the target on the final topology (build_target()). On failure `status` and
/// `message` say why (`usage` for a bad option value, exit 2; an ear split's message names `file`).
struct PreparedTarget {
  ricci::Status status = ricci::Status::Ok;
  bool usage = false;
  std::string message;
  ricci::BoundaryMode mode = ricci::BoundaryMode::Free;
  std::vector<std::string> notes;          ///< to print and to report
  std::optional<ricci::Repair> ear_split;  ///< the repair, when ears were split
  ricci::Target target;
};
PreparedTarget prepare_target(ricci::ValidateResult& validated, ricci::Geometry geometry, const TargetSpec& target_spec,
                              const BoundarySpec& boundary_spec, const std::string& target_text,
                              const std::string& boundary_text, bool split_ears, const std::string& file);

/// What the metric file says about the run that made it.
struct MetricHeader {
  std::string mesh;      ///< the input's name
  std::string geometry;  ///< geometry_name()
  std::string scheme;    ///< scheme_name()
  std::string boundary;  ///< boundary_mode_name(), or "none" for a closed surface
  std::string target;    ///< "uniform", "cones=FILE", "single-vertex=I"
  std::string method;    ///< "newton" or "gradient"
  /// Vertex scaling with intrinsic flips: the lengths are the input's edges made straight in the
  /// solution's metric; `straight_tiles` says whether those straight triangles tile the surface.
  bool flips = false;
  bool straight_tiles = true;
};

/// The metric file written by `ricci flow -o` and `ricci uniformize` (format at the top of
/// flow_command.cpp): JSON when `json`, else CSV. `vertex_to_input` maps validated vertices to the
/// input file's (−1 for none).
std::string metric_file_text(const MetricHeader& header, const ricci::FlowResult& flow, const ricci::Topology& t,
                             std::span<const ricci::Index> vertex_to_input, bool json);

}  // namespace ricci_cli
