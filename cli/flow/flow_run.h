// ricci command-line driver — `ricci flow` for drivers other than the command line (the Python
// module, lib/python): the whole command on a mesh read from a file or already in memory, with
// nothing printed when `console` is off and every result kept in FlowReport. run_flow() is
// flow_run() with a fresh FlowReport.
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "ricci/flow.h"
#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"

namespace ricci_cli {

/// Everything the summary reports, filled in as the pipeline advances.
struct FlowReport {
  /// Off: nothing on stdout or stderr (the outcome stays in status/message, notes in `notes`).
  bool console = true;
  /// A mesh read elsewhere (e.g. from arrays): validated under the name `file` instead of reading
  /// the options' mesh. Null: read it (or the embedded default).
  const ricci::ReadResult* preread = nullptr;
  /// Called after every iteration instead of the progress printed on stderr.
  std::function<void(const ricci::IterationRecord&)> on_iteration;

  ricci::Status status = ricci::Status::NotRun;
  std::string message = "not run";
  std::string file;
  bool embedded = false;
  // Mesh (when loaded).
  bool have_mesh = false;
  std::int64_t vertices = 0, edges = 0, faces = 0, boundary_loops = 0, euler_characteristic = 0, genus = 0;
  ricci::ValidateResult input;  ///< the validated input (ears split as the target needs)
  // Settings as resolved.
  std::optional<ricci::Geometry> geometry;
  ricci::Scheme scheme = ricci::Scheme::CirclePacking;
  std::string boundary;  ///< boundary_mode_name, or "none" for a closed surface; "" before known
  std::string target;
  ricci::Method method = ricci::Method::Newton;
  double tolerance = 0;
  int max_iterations = 0;
  double step = 0;
  int threads = 0;
  std::vector<double> loop_totals;
  // Initial metric.
  bool have_metric = false;
  double length_scale = 1;
  ricci::Index clamped_high = 0, clamped_low = 0;
  ricci::Index cycles_relaxed = 0, edges_relaxed = 0;
  // Flow.
  bool have_flow = false;
  ricci::FlowResult flow;
  bool flips = false;               ///< solved with intrinsic flips
  ricci::IntrinsicSummary intrinsic;  ///< what the flips did (when `flips`)
  double total_seconds = 0;
  std::string output;  ///< the file written, "" if none
  std::vector<std::string> notes;
  std::vector<ricci::Repair> repairs;
};

/// `ricci flow` into `r` (see run_flow()); returns the exit code.
int flow_run(const FlowCommandOptions& options, FlowReport& r);
/// The summary `ricci flow --json` prints.
nlohmann::ordered_json flow_json(const FlowReport& r);

}  // namespace ricci_cli
