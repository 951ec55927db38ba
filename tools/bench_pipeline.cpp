// bench_pipeline — the whole uniformization per input, stage by stage, against the least work a
// linear conformal method does: one sparse Cholesky analysis + factorization + solve of the
// cotangent Laplacian of the same mesh with the same solver (lib/core/sparse_solver.h, CHOLMOD).
// A driver, not a test: it never fails on a slow or non-converging input, it reports it.
//
// How to run (Release build; the one command the README documents):
//   cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DRICCI_PEERS=ON && cmake --build build -j --target bench_pipeline
//   OMP_WAIT_POLICY=active build/tools/bench_pipeline --sphere --out tools/BENCHMARK-pipeline.md
// Options:
//   MESHES_DIR         the shared meshes (default ../shared/meshes beside the repository)
//   --out FILE.md      also write the tables to FILE.md (atomically)
//   --only TEXT        only inputs whose name contains TEXT (repeatable)
//   --max-faces N      skip generated inputs above N faces (default: all, up to 2M)
//   --sphere           also generated icospheres (S, 20k … 1.3M faces)
//   --threads N        OpenMP threads (default 0: the OpenMP default, all cores)
//   --gd-seconds S     cap of the gradient-descent comparison per input (default 20; 0 skips it)
//   --flow-only        skip the stages after the flow (cut, layout, deck, angles, writing)
//   --all-shared       every shared mesh of genus*/, boundary/ and derived/ instead of five large ones
//                      (with --max-faces 0 --gd-seconds 0: the table of the default against circle
//                      packing, tools/BENCHMARK-flips.md)
//   --cli PATH         the ricci CLI whose whole `uniformize --no-pictures` process is timed per input
//                      (default: the one built beside this benchmark; none when it is not built)
//   --cli-max-faces N  time the CLI only on inputs up to N faces (default 900000: face.obj subdivided
//                      twice is the largest; 0: never)
//   --peer PATH        tools/peer_cgal (CGAL's LSCM and discrete conformal map), timed on every disk
//                      input in the same run: face.obj, its midpoint subdivisions and a generated
//                      2M-face disk (default: the one built beside this benchmark with
//                      -DRICCI_PEERS=ON; none otherwise, and the peer table is left out)
//   --peer-max-faces N run the peer only on disks up to N faces (default 2100000; 0: never)
//
// Every input runs in a child process (fork), so that its peak resident memory is its own: the
// peak of each stage is read from /proc/self/status (VmHWM), reset between stages by writing 5 to
// /proc/self/clear_refs. Timings are wall-clock; ratios are measured in the same process, minutes
// apart at most, so they are less sensitive to other load than absolute seconds.
#include <fcntl.h>
#include <omp.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#ifndef RICCI_PEER_PATH
#define RICCI_PEER_PATH ""
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_common.h"
#include "hessian.h"
#include "huge_pages.h"
#include "ricci/flow.h"
#include "ricci/io.h"
#include "ricci/metric.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "sparse_solver.h"

namespace {

/// Flows shorter than this (flips and circle packing together, seconds) are timed kShortRepeats
/// times each for the comparison table, the best kept.
constexpr double kShortFlow = 4.0;
constexpr int kShortRepeats = 5;


namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using ricci::Index;

struct Settings {
  fs::path meshes;
  std::string out;
  std::vector<std::string> only;
  std::int64_t max_faces = -1;
  bool sphere = false;
  int threads = 0;
  double gd_seconds = 20;
  bool flow_only = false;
  bool all_shared = false;
  std::string cli = RICCI_CLI_PATH;
  std::int64_t cli_max_faces = 900000;
  std::string peer = RICCI_PEER_PATH;
  std::int64_t peer_max_faces = 2100000;
};

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

using bench_common::fmt;

using bench_common::compiler_name;
using bench_common::cpu_model;

/// Peak resident set since the last reset_peak(), in bytes (VmHWM).
double peak_bytes() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return 1024.0 * std::strtod(line.c_str() + 6, nullptr);
  return 0;
}
void reset_peak() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
}

// ---------------------------------------------------------------------------------------------
// Inputs.

struct Input {
  std::string name;
  std::int64_t approx_faces = 0;  ///< generated only (for --max-faces)
  std::function<ricci::Mesh()> generate;  ///< generated inputs
  std::string path;                       ///< file inputs
  /// A file the peer reads for this input (OBJ or OFF) and how often it subdivides it; empty:
  /// the generated mesh written to an OFF file.
  std::string peer_path;
  int peer_subdivide = 0;
};

std::vector<Input> inputs(const Settings& s) {
  using namespace ricci_shapes;
  std::vector<Input> in;
  const fs::path m = s.meshes;
  std::vector<std::string> files = {"boundary/face.obj", "genus1/kitten-106k.obj", "genus0/brain-conte69-32k-lh.off",
                                    "genus3plus/botijo.obj", "derived/kitten-425k-midpoint-subdiv.off"};
  if (s.all_shared) {
    // Every mesh of genus*/, boundary/ and derived/, in name order.
    files.clear();
    std::error_code ec;
    for (const char* dir : {"genus0", "genus1", "genus2", "genus3plus", "boundary", "derived"})
      for (const auto& e : fs::directory_iterator(m / dir, ec)) {
        const std::string ext = e.path().extension().string();
        if (ext == ".obj" || ext == ".off" || ext == ".ply") files.push_back(std::string(dir) + "/" + e.path().filename().string());
      }
    std::sort(files.begin(), files.end());
  }
  for (const std::string& f : files)
    if (fs::exists(m / f)) in.push_back({f, 0, {}, (m / f).string(), (m / f).string(), 0});
  // The shared disk subdivided (the peers' sizes between 50k and 2M faces), unless --all-shared.
  if (!s.all_shared && fs::exists(m / "boundary/face.obj"))
    for (const int k : {1, 2}) {
      const std::string path = (m / "boundary/face.obj").string();
      in.push_back({"boundary/face.obj, " + std::to_string(k) + " midpoint subdivision" + (k > 1 ? "s" : ""),
                    51712 * (k == 1 ? 4 : 16),
                    [path, k] {
                      ricci::Mesh mesh = ricci::read_mesh(path).mesh;
                      for (int i = 0; i < k; ++i) mesh = subdivide_midpoint(mesh);
                      return mesh;
                    },
                    {}, path, k});
    }
  // Torus: 2·(2m)·m faces. Genus 2: pretzel(2, c) has 100·c² faces, ×4 per midpoint subdivision.
  struct Size {
    const char* label;
    int torus_m, cells, subdiv;
    std::int64_t faces;
  };
  const Size sizes[] = {{"10k", 50, 10, 0, 10000},
                        {"100k", 158, 32, 0, 100000},
                        {"400k", 316, 32, 1, 400000},
                        {"1M", 500, 25, 2, 1000000},
                        {"2M", 707, 18, 3, 2000000}};
  for (const Size& z : sizes) {
    const int tm = z.torus_m, c = z.cells, k = z.subdiv;
    in.push_back({std::string("generated/torus-") + z.label, z.faces, [tm] { return torus(2 * tm, tm, 1.0, 0.5); }, {}, {}, 0});
    in.push_back({std::string("generated/genus2-") + z.label, z.faces, [c, k] {
                    ricci::Mesh mesh = pretzel(2, c);
                    for (int i = 0; i < k; ++i) mesh = subdivide_midpoint(mesh);
                    return mesh;
                  },
                  {}, {}, 0});
  }
  in.push_back({"generated/disk-2M", 1997574, [] { return disk(577); }, {}, {}, 0});
  if (s.sphere)
    for (const auto& [label, sub, faces] : {std::tuple{"20k", 5, 20480}, std::tuple{"328k", 7, 327680},
                                           std::tuple{"1.3M", 8, 1310720}}) {
      const int subdivisions = sub;
      in.push_back({std::string("generated/icosphere-") + label, faces,
                    [subdivisions] { return icosphere(subdivisions); }, {}, {}, 0});
    }
  std::vector<Input> kept;
  for (Input& i : in) {
    if (s.max_faces >= 0 && i.approx_faces > s.max_faces) continue;
    bool match = s.only.empty();
    for (const std::string& o : s.only) match = match || i.name.find(o) != std::string::npos;
    if (match) kept.push_back(std::move(i));
  }
  return kept;
}

// ---------------------------------------------------------------------------------------------
// The reference: analysis + factorization + solve of the cotangent Laplacian (one vertex pinned,
// as the flow pins one per gauge component), with the solver and pattern the flow uses.

struct Reference {
  double analysis = 0, factor = 0, solve = 0;
  double total() const { return analysis + factor + solve; }
  bool ok = false;
};

Reference laplacian_reference(const ricci::Mesh& mesh, const ricci::Topology& t) {
  Reference r;
  const Index nv = t.num_vertices, nf = t.num_faces, ne = t.num_edges;
  std::vector<std::uint8_t> unknown(static_cast<std::size_t>(nv), 1);
  for (Index v = 0; v < nv; ++v) unknown[v] = t.valence(v) > 0;
  for (Index v = 0; v < nv; ++v)
    if (unknown[v]) {
      unknown[v] = 0;  // the pinned vertex
      break;
    }
  // Cotangent weights w_e = ½ Σ cot(opposite corners), from the 3D positions.
  std::vector<double> w(static_cast<std::size_t>(ne), 0.0);
  const double* x = mesh.positions.data();
  for (Index f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const Index c = 3 * f + k;
      const Index a = t.corner_vertex[c], b = t.corner_vertex[ricci::next_corner(c)],
                  d = t.corner_vertex[ricci::prev_corner(c)];
      double u[3], v[3];
      for (int i = 0; i < 3; ++i) {
        u[i] = x[3 * b + i] - x[3 * a + i];
        v[i] = x[3 * d + i] - x[3 * a + i];
      }
      const double dot = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
      const double cx = u[1] * v[2] - u[2] * v[1], cy = u[2] * v[0] - u[0] * v[2], cz = u[0] * v[1] - u[1] * v[0];
      w[t.corner_edge[c]] += 0.5 * dot / std::max(std::sqrt(cx * cx + cy * cy + cz * cz), 1e-300);
    }
  const ricci::detail::HessianPattern p = ricci::detail::build_hessian_pattern(t, unknown);
  const Index n = p.num_unknowns;
  ricci::detail::SymmetricSolver solver;
  Clock::time_point t0 = Clock::now();
  if (solver.analyze(n, p.col_ptr, p.row, ricci::detail::FactorKind::PositiveDefinite) !=
      ricci::detail::FactorOutcome::Ok)
    return r;
  r.analysis = since(t0);
  const std::span<double> values = solver.values();
  std::vector<double> diag(static_cast<std::size_t>(nv), 0.0);
  for (Index e = 0; e < ne; ++e) {
    diag[t.edge_vertices[2 * e]] += w[e];
    diag[t.edge_vertices[2 * e + 1]] += w[e];
  }
  for (Index j = 0; j < n; ++j) {
    const std::int64_t end = p.col_ptr[j + 1] - 1;
    for (std::int64_t k = p.col_ptr[j]; k < end; ++k) values[k] = -w[p.entry_edge[k]];
    values[end] = diag[p.unknown_vertex[j]];
  }
  std::vector<double> b(static_cast<std::size_t>(n), 1.0), sol(static_cast<std::size_t>(n), 0.0);
  t0 = Clock::now();
  if (solver.factorize() != ricci::detail::FactorOutcome::Ok) return r;
  r.factor = since(t0);
  t0 = Clock::now();
  if (!solver.solve(b, sol)) return r;
  r.solve = since(t0);
  r.ok = true;
  return r;
}

// ---------------------------------------------------------------------------------------------
// Kernel scaling at the solution.

// The per-face kernels of one Newton iteration (lengths, angles, curvature, derivative blocks),
// best of several repetitions with 1 thread and with `threads`, alternated so that both see the
// same machine (other load, clock changes): {seconds with 1 thread, seconds with `threads`}.
std::pair<double, double> kernel_seconds(const ricci::Topology& t, const ricci::ConformalStructure& s,
                                         const std::vector<double>& u, int threads) {
  const auto ne = static_cast<std::size_t>(t.num_edges), nc = 3 * static_cast<std::size_t>(t.num_faces);
  std::vector<double> l(ne), theta(nc), K(static_cast<std::size_t>(t.num_vertices)), blocks(3 * nc);
  const int saved = omp_get_max_threads();
  double best[2] = {1e300, 1e300};
  const int reps = t.num_faces > 500000 ? 5 : (t.num_faces > 50000 ? 11 : 31);
  for (int r = 0; r < 2 * reps; ++r) {
    omp_set_num_threads(r % 2 == 0 ? 1 : threads);
    const Clock::time_point t0 = Clock::now();
    ricci::edge_lengths(t, s, u, l);
    ricci::corner_angles(t, s.geometry, l, theta);
    ricci::vertex_curvature(t, theta, K);
    ricci::angle_derivative_blocks(t, s, u, l, theta, blocks);
    best[r % 2] = std::min(best[r % 2], since(t0));
  }
  omp_set_num_threads(saved);
  return {best[0], best[1]};
}

// ---------------------------------------------------------------------------------------------
// One input (in a child process): key → value pairs.

using Row = std::map<std::string, std::string>;

double time_to(const ricci::FlowResult& r, double tol) {
  for (const ricci::IterationRecord& h : r.history)
    if (h.max_error < tol) return h.seconds;
  return -1;
}

Row run_input(const Input& input, const Settings& s) {
  Row row;
  reset_peak();
  Clock::time_point t0 = Clock::now();
  ricci::Mesh raw;
  if (input.generate) {
    raw = input.generate();
  } else {
    ricci::ReadResult read = ricci::read_mesh(input.path);
    if (read.status != ricci::Status::Ok) {
      row["error"] = read.message;
      return row;
    }
    raw = std::move(read.mesh);
  }
  row["load"] = fmt("%.3f", since(t0));
  t0 = Clock::now();
  ricci::ValidateResult v = ricci::validate_mesh(raw);
  row["validate"] = fmt("%.3f", since(t0));
  if (v.status != ricci::Status::Ok) {
    row["error"] = v.message;
    return row;
  }
  raw = ricci::Mesh{};
  // validate_mesh() builds the topology; build it again on its own to time that stage.
  t0 = Clock::now();
  {
    const ricci::TopologyResult again = ricci::build_topology(v.mesh.faces, v.mesh.num_vertices());
    (void)again;
  }
  row["topology"] = fmt("%.3f", since(t0));
  const ricci::Topology& topo = v.topology;
  const double F = static_cast<double>(topo.num_faces);
  row["faces"] = std::to_string(topo.num_faces);
  row["genus"] = std::to_string(topo.genus());
  row["loops"] = std::to_string(topo.num_boundary_loops());
  row["peak_load"] = fmt("%.0f", peak_bytes());

  const Reference ref = laplacian_reference(v.mesh, topo);
  if (ref.ok) {
    row["ref_analysis"] = fmt("%.3f", ref.analysis);
    row["ref_factor"] = fmt("%.3f", ref.factor);
    row["ref_solve"] = fmt("%.3f", ref.solve);
    row["ref"] = fmt("%.4f", ref.total());
  }

  ricci::UniformizeOptions o;
  o.flow.tolerance = 1e-10;
  o.flow.threads = s.threads;
  std::map<std::string, double> stage_peak;
  std::map<std::string, double> stage_seconds;
  bool stop_after_flow = s.flow_only;
  o.on_stage = [&](const ricci::StageRecord& r) {
    stage_peak[std::string(r.stage)] = peak_bytes();
    stage_seconds[std::string(r.stage)] += r.seconds;  // a stage reported twice counts twice
    reset_peak();
  };
  if (stop_after_flow) {
    o.seed_checks = 0;
    o.base_candidates = 1;
  }
  reset_peak();
  ricci::UniformizeResult u;
  if (stop_after_flow) {
    // Only initial metric, target and flow (the same calls uniformize() makes).
    const ricci::Geometry g = ricci::natural_geometry(topo);
    ricci::InitialMetricOptions mo;
    mo.geometry = g;
    t0 = Clock::now();
    u.metric = ricci::initial_metric(v.mesh, topo, mo);
    stage_seconds["initial_metric"] = since(t0);
    u.target = ricci::uniform_target(topo, ricci::natural_boundary_mode(topo, g));
    u.geometry = g;
    reset_peak();
    if (u.metric.status == ricci::Status::Ok) {
      t0 = Clock::now();
      u.flow = ricci::solve_flow(topo, u.metric.structure, u.metric.u, u.target, o.flow);
      stage_seconds["flow"] = since(t0);
      stage_peak["flow"] = peak_bytes();
      u.status = u.flow.status;
      u.message = u.flow.message;
    } else {
      u.status = u.metric.status;
      u.message = u.metric.message;
    }
  } else {
    u = ricci::uniformize(v.mesh, topo, o);
  }
  row["geometry"] = std::string(ricci::geometry_name(u.geometry));
  row["status"] = std::string(ricci::status_name(u.status));
  if (u.status == ricci::Status::Ok && std::isfinite(u.angles.mean_abs_log))
    row["distortion"] = fmt("%.3g", u.angles.mean_abs_log);
  if (u.status != ricci::Status::Ok) row["message"] = u.message;
  for (const auto& [name, sec] : stage_seconds) row["stage_" + name] = fmt("%.3f", sec);
  for (const auto& [name, peak] : stage_peak) row["peak_" + name] = fmt("%.0f", peak);
  const ricci::FlowResult& f = u.flow;
  if (f.status != ricci::Status::NotRun) {
    row["flow_status"] = std::string(ricci::status_name(f.status));
    row["error"] = fmt("%.1e", f.max_curvature_error);
    // The Newton solve proper ends at the first iterate below the tolerance; uniformize()'s
    // polishing steps after it (FlowOptions::polish_steps) are reported apart.
    int to_tolerance = f.iterations;
    double solve_seconds = f.seconds;
    for (std::size_t i = 0; i < f.history.size(); ++i)
      if (f.history[i].max_error < o.flow.tolerance) {
        to_tolerance = static_cast<int>(i) + 1;
        solve_seconds = f.history[i].seconds;
        break;
      }
    row["iterations"] = std::to_string(to_tolerance);
    row["polish_iterations"] = std::to_string(f.iterations - to_tolerance);
    row["polish"] = fmt("%.4f", f.seconds - solve_seconds);
    row["flow"] = fmt("%.4f", solve_seconds);
    // Chord steps (the last factor reused) among all steps.
    row["chords"] = std::to_string(f.chord_steps);
    // Per iteration: the full Newton iterations of the solve proper (their records' shares; chord
    // steps, which factorize nothing, left out of the mean).
    ricci::FlowTimings ft;
    int full = 0;
    for (int i = 0; i < to_tolerance && i < static_cast<int>(f.history.size()); ++i) {
      if (f.history[i].chord) continue;
      ++full;
      const ricci::FlowTimings& h = f.history[i].timings;
      ft.derivatives += h.derivatives;
      ft.assembly += h.assembly;
      ft.factorization += h.factorization;
      ft.solve += h.solve;
      ft.line_search += h.line_search;
    }
    // Every iteration on its own (the polishing steps included, marked), for the table of iterations.
    for (std::size_t i = 0; i < f.history.size(); ++i) {
      const ricci::IterationRecord& h = f.history[i];
      const ricci::FlowTimings& t = h.timings;
      std::string index = std::to_string(i);
      index.insert(0, index.size() < 4 ? 4 - index.size() : 0, '0');  // keys sort in iteration order
      row["iter_" + index] =
          fmt("%.1e", h.max_error) + " " + fmt("%.3g", h.step) + " " + fmt("%.4f", t.derivatives) + " " +
          fmt("%.4f", t.assembly) + " " + fmt("%.4f", t.factorization) + " " + fmt("%.4f", t.solve) + " " +
          fmt("%.4f", t.line_search) + " " + (static_cast<int>(i) < to_tolerance ? "newton" : "polish") +
          (h.chord ? "-chord" : "");
    }
    ft.setup = f.timings.setup;
    ft.analysis = f.timings.analysis;
    const double per_iter =
        full > 0 ? (ft.derivatives + ft.assembly + ft.factorization + ft.solve + ft.line_search) / full : 0;
    row["per_iter"] = fmt("%.4f", per_iter);
    for (const auto& [k, x] : {std::pair{"setup", ft.setup}, std::pair{"analysis", ft.analysis},
                               std::pair{"derivatives", ft.derivatives}, std::pair{"assembly", ft.assembly},
                               std::pair{"factorization", ft.factorization}, std::pair{"solve", ft.solve},
                               std::pair{"line_search", ft.line_search}})
      row[std::string("t_") + k] = fmt("%.4f", full > 0 && std::string(k) != "setup" && std::string(k) != "analysis"
                                                    ? x / full
                                                    : x);
    row["lnz"] = fmt("%.0f", f.factor_nonzeros);
    if (ref.ok && ref.total() > 0) {
      row["ratio_flow"] = fmt("%.2f", solve_seconds / ref.total());
      row["ratio_iter"] = fmt("%.2f", per_iter / ref.total());
    }
    const double n6 = time_to(f, 1e-6);
    if (n6 >= 0) row["newton_1e6"] = fmt("%.3f", n6);
    if (stage_peak.count("flow")) row["bytes_per_face"] = fmt("%.0f", stage_peak["flow"] / F);
    // Kernel scaling at the solution.
    if (!f.u.empty()) {
      const int many = s.threads > 0 ? s.threads : std::max(2, omp_get_num_procs());
      const auto [one, more] = kernel_seconds(topo, u.metric.structure, f.u, many);
      row["kernel_1"] = fmt("%.4f", one);
      row["kernel_n"] = fmt("%.4f", more);
      row["kernel_speedup"] = fmt("%.2f", one / more);
    }
  }
  // Writing: the layout as a mesh (positions of the laid-out disk, or of the sphere).
  if (!stop_after_flow && u.layout.status == ricci::Status::Ok && !u.layout.positions.empty()) {
    ricci::Mesh out;
    const int dims = u.layout.dims;
    const std::size_t count = u.layout.positions.size() / static_cast<std::size_t>(dims);
    out.positions.assign(3 * count, 0.0);
    for (std::size_t i = 0; i < count; ++i)
      for (int d = 0; d < dims; ++d) out.positions[3 * i + d] = u.layout.positions[dims * i + d];
    out.faces = u.has_cut ? u.cut.cut_faces : v.mesh.faces;
    const std::string path = "/tmp/bench_pipeline_" + std::to_string(getpid()) + ".ply";
    t0 = Clock::now();
    const ricci::WriteResult w = ricci::write_mesh(path, out);
    row["stage_write"] = fmt("%.3f", since(t0));
    std::error_code ec;
    fs::remove(path, ec);
    if (w.status != ricci::Status::Ok) row["write_error"] = w.message;
  }
  // The default's flow (vertex scaling with intrinsic flips) against the paper's circle packing on
  // the same input: the CP flow stage as uniformize() runs it with scheme = CirclePacking (the same
  // tolerance and polishing steps; the initial metric is its own stage in both).
  if (!stop_after_flow && u.intrinsic.used && stage_seconds.count("flow")) {
    row["flips"] = std::to_string(u.intrinsic.flow_flips);
    ricci::InitialMetricOptions mo;
    mo.geometry = u.geometry;
    mo.scheme = ricci::Scheme::CirclePacking;
    const ricci::InitialMetric cm = ricci::initial_metric(v.mesh, topo, mo);
    if (cm.status == ricci::Status::Ok) {
      ricci::FlowOptions cf = o.flow;
      cf.polish_steps = std::max(cf.polish_steps, 2);
      const ricci::FlowResult c = ricci::solve_flow(topo, cm.structure, cm.u, u.target, cf);
      // Short flows are timed again (the best of kShortRepeats runs of each, alternating), so that
      // the ratio of two tenths of a second is not one scheduler hiccup.
      double flips_best = stage_seconds["flow"], cp_best = c.seconds;
      ricci::UniformizeOptions repeat = o;
      repeat.on_stage = nullptr;  // the stage table keeps the first run's figures
      if (flips_best + cp_best < kShortFlow)
        for (int k = 1; k < kShortRepeats; ++k) {
          const ricci::UniformizeResult again = ricci::conformal_metric(v.mesh, topo, repeat, &u.target);
          for (const auto& [stage, seconds] : again.timings)
            if (stage == "flow") flips_best = std::min(flips_best, seconds);
          cp_best = std::min(cp_best, ricci::solve_flow(topo, cm.structure, cm.u, u.target, cf).seconds);
        }
      row["flips_stage"] = fmt("%.4f", flips_best);
      row["cp_status"] = std::string(ricci::status_name(c.status));
      row["cp_flow"] = fmt("%.4f", cp_best);
      row["cp_iterations"] = std::to_string(c.iterations) + (c.chord_steps > 0 ? ", " + std::to_string(c.chord_steps) + " chord" : "");
      if (cp_best > 0) row["flips_over_cp"] = fmt("%.2f", flips_best / cp_best);
      row["cp_distortion"] = fmt("%.4f", ricci::angle_distortion(v.mesh, topo, u.geometry, c.l).mean_abs_log);
    }
  }
  // Time to 1e-6: the paper's gradient descent (step 0.05), capped.
  if (s.gd_seconds > 0 && u.metric.status == ricci::Status::Ok) {
    ricci::FlowOptions gd;
    gd.method = ricci::Method::GradientDescent;
    gd.tolerance = 1e-6;
    gd.threads = s.threads;
    std::vector<double> uu = u.metric.u;
    double seconds = 0;
    int iterations = 0, chunk = 16;
    ricci::Status status = ricci::Status::NotRun;
    double err = 0;
    // Error at the end of each chunk, for the extrapolation of a capped descent.
    std::vector<std::pair<int, double>> marks;
    while (true) {
      gd.max_iterations = chunk;
      const ricci::FlowResult g = ricci::solve_flow(topo, u.metric.structure, uu, u.target, gd);
      seconds += g.seconds;
      iterations += g.iterations;
      status = g.status;
      err = g.max_curvature_error;
      marks.emplace_back(iterations, err);
      if (g.status != ricci::Status::NotConverged || seconds >= s.gd_seconds) break;
      uu = g.u;
      const double per = g.seconds / std::max(1, g.iterations);
      chunk = static_cast<int>(std::max(1.0, std::min(2.0 * chunk, 0.25 * (s.gd_seconds - seconds) / std::max(per, 1e-9))));
    }
    row["gd_seconds"] = fmt("%.2f", seconds);
    row["gd_iterations"] = std::to_string(iterations);
    row["gd_status"] = status == ricci::Status::Ok ? "ok" : (status == ricci::Status::NotConverged ? "capped" : std::string(ricci::status_name(status)));
    row["gd_error"] = fmt("%.1e", err);
    // A capped descent in E or H: the Ricci energy is convex there, and gradient descent converges
    // linearly near the solution, so the rate of the last chunk (log error per iteration, over
    // about half of all iterations as chunks double) extrapolates the iterations still needed, at
    // the mean seconds per iteration. Only in a steady linear phase: the error fell over each of the
    // last two chunks at rates within a factor 2 of each other. Not in S, whose energy is not
    // convex (the descent there can stall far from the solution).
    if (status == ricci::Status::NotConverged && u.geometry != ricci::Geometry::Spherical && marks.size() >= 3 &&
        iterations > 0) {
      const auto [k0, e0] = marks[marks.size() - 3];
      const auto [k1, e1] = marks[marks.size() - 2];
      const auto [k2, e2] = marks.back();
      const double rate = std::log(e2 / e1) / (k2 - k1), previous = std::log(e1 / e0) / (k1 - k0);
      if (e2 > 0 && rate < 0 && previous < 0 && rate <= 0.5 * previous && rate >= 2 * previous) {
        const double remaining = std::log(gd.tolerance / e2) / rate;
        row["gd_extrapolated_iterations"] = fmt("%.0f", iterations + remaining);
        row["gd_extrapolated_seconds"] = fmt("%.1f", seconds * (iterations + remaining) / iterations);
      }
    }
  }
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  row["maxrss"] = fmt("%.0f", 1024.0 * static_cast<double>(usage.ru_maxrss));
  return row;
}

std::string serialize(const Row& r) {
  std::string s;
  for (const auto& [k, v] : r) {
    std::string clean = v;
    std::replace(clean.begin(), clean.end(), '\n', ' ');
    s += k + "\t" + clean + "\n";
  }
  return s;
}

Row deserialize(const std::string& s) {
  Row r;
  std::istringstream in(s);
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t tab = line.find('\t');
    if (tab != std::string::npos) r[line.substr(0, tab)] = line.substr(tab + 1);
  }
  return r;
}

/// Everything the descriptor gives until end of file; closes it.
std::string read_all(int fd) {
  std::string text;
  char buf[4096];
  ssize_t k;
  while ((k = read(fd, buf, sizeof buf)) > 0) text.append(buf, static_cast<std::size_t>(k));
  close(fd);
  return text;
}

/// Runs run_input() in a child process; its rows come back through a pipe.
Row run_isolated(const Input& input, const Settings& s) {
  int fd[2];
  if (pipe(fd) != 0) return run_input(input, s);
  std::cout << std::flush;
  std::cerr << std::flush;
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    const std::string text = serialize(run_input(input, s));
    std::size_t done = 0;
    while (done < text.size()) {
      const ssize_t k = write(fd[1], text.data() + done, text.size() - done);
      if (k <= 0) break;
      done += static_cast<std::size_t>(k);
    }
    close(fd[1]);
    _exit(0);
  }
  close(fd[1]);
  const std::string text = read_all(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  Row r = deserialize(text);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    r["error"] = WIFSIGNALED(status) ? "child killed by signal " + std::to_string(WTERMSIG(status)) : "child failed";
  return r;
}

/// A program run in a child process: its standard output, exit status, resources (wait4) and wall
/// time; its standard error goes to /dev/null. started is false when no pipe could be made.
struct ChildRun {
  bool started = false;
  std::string text;
  int status = 0;
  struct rusage use {};
  double wall = 0;
};
ChildRun run_child(std::vector<std::string> args) {
  ChildRun r;
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int fd[2];
  if (pipe(fd) != 0) return r;
  std::cout << std::flush;
  std::cerr << std::flush;
  const Clock::time_point t0 = Clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    dup2(fd[1], 1);
    const int null = open("/dev/null", O_WRONLY);
    if (null >= 0) dup2(null, 2);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(fd[1]);
  r.started = true;
  r.text = read_all(fd[0]);
  wait4(pid, &r.status, 0, &r.use);
  r.wall = since(t0);
  return r;
}

/// The CLI's whole job on the input: `ricci uniformize --no-pictures --json` in a child process
/// (generated inputs written to a PLY file first), its wall time, peak RSS (wait4), the flow stage
/// it reports and the bytes it wrote. Skipped above s.cli_max_faces faces or when the file inputs'
/// row has no face count.
void run_cli(const Input& input, const Settings& s, Row& r) {
  const auto it = r.find("faces");
  if (it == r.end() || s.cli.empty() || s.cli_max_faces <= 0 || std::atoll(it->second.c_str()) > s.cli_max_faces)
    return;
  std::error_code ec;
  const fs::path scratch = fs::temp_directory_path() / ("bench_pipeline_cli_" + std::to_string(getpid()));
  fs::remove_all(scratch, ec);
  fs::create_directories(scratch, ec);
  std::string mesh = input.path;
  if (mesh.empty()) {
    mesh = (scratch / "input.ply").string();
    if (ricci::write_mesh(mesh, input.generate()).status != ricci::Status::Ok) {
      r["cli_status"] = "could not write the generated mesh";
      return;
    }
  }
  const std::string out = (scratch / "out").string();
  std::vector<std::string> args = {s.cli, "uniformize", mesh, "-o", out, "--no-pictures", "--json", "-q"};
  if (s.threads > 0) args.insert(args.end(), {"--threads", std::to_string(s.threads)});
  const ChildRun run = run_child(args);
  if (!run.started) return;
  const std::string& text = run.text;
  const int status = run.status;
  const struct rusage& use = run.use;
  const double wall = run.wall;
  std::uintmax_t bytes = 0;
  for (const auto& e : fs::directory_iterator(out, ec))
    if (e.is_regular_file(ec)) bytes += e.file_size(ec);
  fs::remove_all(scratch, ec);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || j.is_discarded() || !j.contains("timings")) {
    r["cli_status"] = "exit " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    return;
  }
  const double flow = j["timings"].value("flow", 0.0);
  r["cli_seconds"] = fmt("%.3f", wall);
  r["cli_flow"] = fmt("%.3f", flow);
  r["cli_ratio"] = flow > 0 ? fmt("%.2f", wall / flow) : "—";
  r["cli_peak"] = fmt("%.0f", 1024.0 * static_cast<double>(use.ru_maxrss));
  r["cli_bytes"] = fmt("%.0f", static_cast<double>(bytes));
  r["cli_status"] = j.value("status", std::string("?"));
}

std::string get(const Row& r, const std::string& k, const std::string& fallback = "—") {
  const auto it = r.find(k);
  return it == r.end() ? fallback : it->second;
}

double num(const Row& r, const std::string& k) {
  const auto it = r.find(k);
  return it == r.end() ? std::nan("") : std::strtod(it->second.c_str(), nullptr);
}

std::string mb(const Row& r, const std::string& k) {
  const double x = num(r, k);
  return std::isnan(x) ? "—" : fmt("%.0f", x / 1048576.0);
}

/// The peers on a disk input (genus 0, one boundary loop): `peer_cgal --peers NAME --json` in a
/// child process per peer, on the input's file (subdivided by the peer as the input is) or on the
/// generated mesh written to an OFF file: its parameterize() seconds, the process's wall time and
/// the angle distortion it reports. Skipped above s.peer_max_faces faces.
void run_peer(const Input& input, const Settings& s, Row& r) {
  if (s.peer.empty() || s.peer_max_faces <= 0 || get(r, "genus") != "0" || get(r, "loops") != "1" ||
      std::atoll(get(r, "faces", "0").c_str()) > s.peer_max_faces)
    return;
  std::error_code ec;
  const fs::path scratch = fs::temp_directory_path() / ("bench_pipeline_peer_" + std::to_string(getpid()));
  fs::remove_all(scratch, ec);
  fs::create_directories(scratch, ec);
  std::string mesh = input.peer_path;
  int subdivide = input.peer_subdivide;
  if (mesh.empty()) {
    mesh = (scratch / "input.off").string();
    subdivide = 0;
    if (ricci::write_mesh(mesh, input.generate()).status != ricci::Status::Ok) {
      r["lscm_status"] = r["dcm_status"] = "could not write the generated mesh";
      return;
    }
  }
  for (const std::string name : {"lscm", "dcm"}) {
    std::vector<std::string> args = {s.peer, "--peers", name, "--subdivide", std::to_string(subdivide), "--json", mesh};
    const ChildRun run = run_child(args);
    if (!run.started) return;
    const int status = run.status;
    const struct rusage& use = run.use;
    const double wall = run.wall;
    const nlohmann::json j = nlohmann::json::parse(run.text, nullptr, false);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || j.is_discarded() || !j.contains("peers") || j["peers"].empty()) {
      r[name + "_status"] = "exit " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1);
      continue;
    }
    const nlohmann::json& p = j["peers"][0];
    r[name + "_status"] = p.value("status", std::string("?"));
    r[name + "_wall"] = fmt("%.3f", wall);
    r[name + "_peak"] = fmt("%.0f", 1024.0 * static_cast<double>(use.ru_maxrss));
    if (p["seconds"].is_number()) r[name + "_seconds"] = fmt("%.3f", p["seconds"].get<double>());
    if (p["angle_distortion"].is_object() && p["angle_distortion"]["mean"].is_number())
      r[name + "_distortion"] = fmt("%.3g", p["angle_distortion"]["mean"].get<double>());
  }
  fs::remove_all(scratch, ec);
}

/// The library's whole job on a row: every stage uniformize() reported (whether or not it has a
/// column) and writing, with loading and validation, but not the topology column
/// (validate_mesh() builds the topology; that column times it again).
double job_seconds(const Row& r) {
  double job = 0;
  for (const char* k : {"load", "validate"})
    if (!std::isnan(num(r, k))) job += num(r, k);
  for (const auto& [key, value] : r)
    if (key.rfind("stage_", 0) == 0 && !std::isnan(num(r, key))) job += num(r, key);
  return job;
}

int usage(const char* argv0) {
  std::cerr << "usage: " << argv0
            << " [MESHES_DIR] [--out FILE.md] [--only TEXT]… [--max-faces N] [--sphere] [--threads N] "
               "[--gd-seconds S] [--flow-only] [--all-shared] [--cli PATH] [--cli-max-faces N] [--peer PATH] "
               "[--peer-max-faces N]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  ricci_cli::prepare_malloc(argv);
  Settings s;
  s.meshes = fs::path(RICCI_SOURCE_DIR).parent_path() / "shared" / "meshes";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    if (a == "--sphere") {
      s.sphere = true;
    } else if (a == "--all-shared") {
      s.all_shared = true;
    } else if (a == "--flow-only") {
      s.flow_only = true;
    } else if (a == "--out" || a == "--only" || a == "--cli" || a == "--peer") {
      const char* v = value();
      if (!v) return usage(argv[0]);
      if (a == "--out") s.out = v;
      else if (a == "--cli") s.cli = v;
      else if (a == "--peer") s.peer = v;
      else s.only.emplace_back(v);
    } else if (a == "--threads" || a == "--gd-seconds" || a == "--max-faces" || a == "--cli-max-faces" ||
               a == "--peer-max-faces") {
      const char* v = value();
      if (!v) return usage(argv[0]);
      char* end = nullptr;
      const double x = std::strtod(v, &end);
      if (*end != '\0' || !(x >= 0)) return usage(argv[0]);
      if (a == "--threads") s.threads = static_cast<int>(x);
      if (a == "--gd-seconds") s.gd_seconds = x;
      if (a == "--max-faces") s.max_faces = static_cast<std::int64_t>(x);
      if (a == "--cli-max-faces") s.cli_max_faces = static_cast<std::int64_t>(x);
      if (a == "--peer-max-faces") s.peer_max_faces = static_cast<std::int64_t>(x);
    } else if (a == "-h" || a == "--help") {
      usage(argv[0]);
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      return usage(argv[0]);
    } else {
      s.meshes = a;
    }
  }
  const std::vector<Input> list = inputs(s);
  std::vector<std::pair<std::string, Row>> rows;
  for (const Input& in : list) {
    std::cerr << "bench_pipeline: " << in.name << " …" << std::endl;
    const Clock::time_point t0 = Clock::now();
    rows.emplace_back(in.name, run_isolated(in, s));
    if (!s.flow_only) run_cli(in, s, rows.back().second);
    if (!s.flow_only) run_peer(in, s, rows.back().second);
    std::cerr << "bench_pipeline: " << in.name << " done in " << fmt("%.1f", since(t0)) << " s: flow "
              << get(rows.back().second, "flow") << " s, ref " << get(rows.back().second, "ref") << " s, "
              << get(rows.back().second, "iterations") << " it, ratio " << get(rows.back().second, "ratio_flow")
              << std::endl;
  }

  std::string doc = "# ricci pipeline benchmark\n\n";
  doc += "Machine: " + cpu_model() + ", " + std::to_string(std::thread::hardware_concurrency()) +
         " hardware threads; compiler: " + compiler_name() + "; OpenMP threads: " +
         (s.threads > 0 ? std::to_string(s.threads) : std::string("default")) + "; OMP_WAIT_POLICY " +
         (std::getenv("OMP_WAIT_POLICY") ? std::string(std::getenv("OMP_WAIT_POLICY")) : std::string("unset")) +
         (s.flow_only ? "; --flow-only" : "") + "; malloc " +
         (ricci_cli::malloc_huge_pages() ? "on huge pages (glibc.malloc.hugetlb=1, as the CLI)" : "on 4 kB pages") +
         ".\n\n";
  doc += "Uniformization with `uniformize()` defaults (geometry by topology, vertex scaling with intrinsic "
         "flips, circle boundary in E, geodesic in H) except the flow tolerance max |K̄ − K| < 1e-10. *ref* = analysis + factorization + solve of "
         "the cotangent Laplacian (one vertex pinned) with the flow's own solver and pattern (CHOLMOD supernodal "
         "LLᵀ; AMD, or METIS where AMD's factor costs more than 6000 flops per unknown and METIS's fewer); *flow s* is the whole Newton solve to the tolerance (setup and symbolic "
         "analysis included, from the call to the first iterate below 1e-10), *+ polish* the steps `uniformize()` "
         "adds after it (polishing steps kept only when they lower the error, then chord steps for the residual's "
         "smooth part while they still move u by more than 1e-13; the stage table's *flow* has both); *flow/ref* and "
         "*it/ref* are the solve and one mean Newton iteration (kernels + assembly + factorization + solve + line "
         "search; the full steps, chord steps — the last factor reused, counted as *k chord* — left out) over ref. "
         "Each input runs in its own process; peaks are VmHWM per stage.\n\n";
  doc += "## Flow against the reference\n\n";
  doc += "| input | geometry | #F | Newton it. + polish | max error | flow s + polish s | ref s | flow/ref | it/ref | "
         "kernels 1→N thr | flow peak MB | bytes/face |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& [name, r] : rows) {
    std::string it = get(r, "iterations") + " + " + get(r, "polish_iterations");
    if (get(r, "chords") != "0" && !get(r, "chords").empty()) it += ", " + get(r, "chords") + " chord";
    if (get(r, "flow_status", "ok") != "ok") it += " (" + get(r, "flow_status") + ")";
    doc += "| " + name + " | " + get(r, "geometry") + " | " + get(r, "faces") + " | " + it + " | " + get(r, "error") +
           " | " + get(r, "flow") + " + " + get(r, "polish") + " | " + get(r, "ref") + " | " + get(r, "ratio_flow") +
           " | " + get(r, "ratio_iter") +
           " | " + get(r, "kernel_speedup") + "× | " + mb(r, "peak_flow") + " | " + get(r, "bytes_per_face") + " |\n";
  }
  doc += "\n## Newton iteration, mean seconds per full iteration (chord steps left out)\n\n";
  doc += "| input | setup s | analysis s | kernels | assembly | factorization | solve | line search | L nnz | ref "
         "analysis | ref factor | ref solve |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& [name, r] : rows)
    doc += "| " + name + " | " + get(r, "t_setup") + " | " + get(r, "t_analysis") + " | " + get(r, "t_derivatives") +
           " | " + get(r, "t_assembly") + " | " + get(r, "t_factorization") + " | " + get(r, "t_solve") + " | " +
           get(r, "t_line_search") + " | " + fmt("%.3gM", num(r, "lnz") / 1e6) + " | " + get(r, "ref_analysis") + " | " +
           get(r, "ref_factor") + " | " + get(r, "ref_solve") + " |\n";
  doc += "\n## Newton iterations one by one, seconds\n\n";
  doc += "Max |K̄ − K| after the step, the accepted step length (fraction of the Newton step) and the iteration's "
         "parts; *polish* marks the steps after the tolerance.\n\n";
  doc += "| input | it. | max error | step | kernels | assembly | factorization | solve | line search |\n"
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& [name, r] : rows)
    for (const auto& [key, value] : r) {
      if (key.rfind("iter_", 0) != 0) continue;
      std::istringstream in(value);
      std::string error, step, kernels, assembly, factorization, solve, search, kind;
      in >> error >> step >> kernels >> assembly >> factorization >> solve >> search >> kind;
      const int index = std::atoi(key.c_str() + 5) + 1;
      const std::string mark = kind == "polish"         ? " (polish)"
                               : kind == "polish-chord" ? " (polish, chord)"
                               : kind == "newton-chord" ? " (chord)"
                                                        : "";
      doc += "| " + name + " | " + std::to_string(index) + mark + " | " + error +
             " | " + step + " | " + kernels + " | " + assembly + " | " + factorization + " | " + solve + " | " +
             search + " |\n";
    }
  doc += "\n## Stages, seconds (peak MB of the process during the stage)\n\n";
  const std::vector<std::string> stages = {"initial_metric", "target", "flow",       "straighten", "cut",  "layout",
                                           "atlas",          "seed_check", "polygon", "deck",       "angles"};
  doc += "| input | load | validate | topology |";
  for (const std::string& st : stages) doc += " " + st + " |";
  doc += " write | job | job/flow | cut/ref | layout/ref | status |\n|---|---:|---:|---:|";
  for (std::size_t i = 0; i < stages.size(); ++i) doc += "---:|";
  doc += "---:|---:|---:|---:|---:|---|\n";
  for (const auto& [name, r] : rows) {
    doc += "| " + name + " | " + get(r, "load") + " | " + get(r, "validate") + " | " + get(r, "topology") + " |";
    for (const std::string& st : stages) {
      const std::string sec = get(r, "stage_" + st);
      doc += " " + sec + (sec != "—" && r.count("peak_" + st) ? " (" + mb(r, "peak_" + st) + ")" : "") + " |";
    }
    std::string status = get(r, "status");
    if (r.count("message")) status += ": " + get(r, "message");
    if (r.count("error") && !r.count("faces")) status = get(r, "error");
    // The job: job_seconds().
    const double job = job_seconds(r);
    const double flow = num(r, "stage_flow"), ref = num(r, "ref");
    auto ratio = [](double a, double b) { return std::isnan(a) || !(b > 0) ? std::string("—") : fmt("%.2f", a / b); };
    doc += " " + get(r, "stage_write") + " | " + fmt("%.3f", job) + " | " + ratio(job, flow) + " | " +
           ratio(num(r, "stage_cut"), ref) + " | " + ratio(num(r, "stage_layout"), ref) + " | " + status + " |\n";
  }
  if (!s.flow_only && !s.cli.empty()) {
    doc += "\n## The CLI's whole job\n\n";
    doc += "`ricci uniformize MESH -o OUTDIR --no-pictures --json -q` in its own process after the input's row above "
           "(generated inputs written to a PLY file first), up to " + std::to_string(s.cli_max_faces) +
           " faces: wall time from start to exit (reading, every stage, the outputs and writing them), the flow "
           "stage it reports, its peak RSS and the bytes it wrote. The CLI runs the flow to its own default "
           "tolerance (1e-12).\n\n";
    doc += "| input | #F | process s | flow s | process/flow | peak MB | bytes/face | outputs MB | status |\n"
           "|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (const auto& [name, r] : rows) {
      if (!r.count("cli_status")) continue;
      const double F = num(r, "faces");
      doc += "| " + name + " | " + get(r, "faces") + " | " + get(r, "cli_seconds") + " | " + get(r, "cli_flow") + " | " +
             get(r, "cli_ratio") + " | " + mb(r, "cli_peak") + " | " +
             (r.count("cli_peak") ? fmt("%.0f", num(r, "cli_peak") / F) : std::string("—")) + " | " +
             mb(r, "cli_bytes") + " | " + get(r, "cli_status") + " |\n";
    }
  }
  bool any_peer = false;
  for (const auto& [name, r] : rows) any_peer = any_peer || r.count("lscm_status") || r.count("dcm_status");
  if (any_peer) {
    doc += "\n## Against the peers: CGAL's LSCM and discrete conformal map on the disks\n\n";
    doc += "tools/peer_cgal (CGAL " + std::string("from Debian's libcgal-dev") +
           ", benchmark only) in its own process per peer, in this run, right after the input's rows above, on the "
           "same mesh (the shared file, subdivided by the peer as here, or the generated disk written to OFF): "
           "*LSCM s*, *DCM s* its parameterize() call alone (the mesh read and built before it), *process s* the "
           "whole peer process. *job s* is ricci's library job of the stage table (from the mesh in memory to "
           "the meshes written), *CLI s* the whole `ricci uniformize --no-pictures` process where it ran; the "
           "ratios are ricci over the peer (above 1: ricci slower). Distortion: mean |log θ_map/θ_3D| over the "
           "input's corners, as each reports it. LSCM fixes two boundary vertices (free boundary), DCM maps the "
           "boundary onto a circle by arc length, ricci onto a circle by its conformal flow (the default).\n\n";
    doc += "| input | #F | job s | flow s | job/flow | LSCM s | DCM s | job/LSCM | job/DCM | CLI s | LSCM process s | "
           "DCM process s | CLI/LSCM process | distortion | LSCM distortion | DCM distortion | LSCM, DCM status |\n";
    doc += "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (const auto& [name, r] : rows) {
      if (!r.count("lscm_status") && !r.count("dcm_status")) continue;
      const double job = job_seconds(r);
      auto ratio = [](double a, double b) { return std::isnan(a) || !(b > 0) ? std::string("—") : fmt("%.2f", a / b); };
      doc += "| " + name + " | " + get(r, "faces") + " | " + fmt("%.3f", job) + " | " + get(r, "stage_flow") + " | " +
             ratio(job, num(r, "stage_flow")) + " | " + get(r, "lscm_seconds") + " | " + get(r, "dcm_seconds") + " | " +
             ratio(job, num(r, "lscm_seconds")) + " | " + ratio(job, num(r, "dcm_seconds")) + " | " +
             get(r, "cli_seconds") + " | " + get(r, "lscm_wall") + " | " + get(r, "dcm_wall") + " | " +
             ratio(num(r, "cli_seconds"), num(r, "lscm_wall")) + " | " + get(r, "distortion") + " | " +
             get(r, "lscm_distortion") + " | " + get(r, "dcm_distortion") + " | " + get(r, "lscm_status") + ", " +
             get(r, "dcm_status") + " |\n";
    }
  }
  doc += "\n## The default (vertex scaling with intrinsic flips) against the paper's circle packing\n\n";
  doc += "*flow s*: the default's flow stage (the intrinsic Delaunay triangulation of the input's metric and "
         "the Newton solve with flips, polishing included); *CP flow s*: `solve_flow()` with circle packing on "
         "the same input, target, tolerance and polishing; where the two take under " + fmt("%g", kShortFlow) +
         " s together, each is the best of " + std::to_string(kShortRepeats) + " runs; iterations include the "
         "polishing steps; angle distortion is the mean |log θ_input/θ_output| over the input's corners, of the "
         "flow on the input's own triangulation (`uniformize()` adds Steiner points where its faces cannot carry "
         "the map: brain.obj and pig-7holes, tools/SWEEP-schemes.md).\n\n";
  doc += "| input | #F | Newton it. | flips | flow s | CP it. | CP flow s | flow/CP | distortion | CP distortion |\n"
         "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& [name, r] : rows) {
    if (!r.count("flips")) continue;
    const std::string chords = get(r, "chords") != "0" && !get(r, "chords").empty() ? ", " + get(r, "chords") + " chord" : "";
    doc += "| " + name + " | " + get(r, "faces") + " | " + get(r, "iterations") + " + " + get(r, "polish_iterations") + chords +
           " | " + get(r, "flips") + " | " + get(r, "flips_stage") + " | " + get(r, "cp_iterations") + " | " +
           get(r, "cp_flow") + " | " + get(r, "flips_over_cp") + " | " + get(r, "distortion") + " | " +
           get(r, "cp_distortion") + " |\n";
  }
  doc += "\n## Time to max |K̄ − K| < 1e-6: Newton against the paper's gradient descent (step 0.05)\n\n";
  doc += "A descent that reaches its time cap is extrapolated at the rate of its last chunk (log error per "
         "iteration over roughly the last half of its iterations, when the error fell steadily): the "
         "*extrapolated* columns are estimates, the others measurements.\n\n";
  doc += "| input | Newton s | gradient descent | GD/Newton | extrapolated GD it. | extrapolated GD/Newton |\n"
         "|---|---:|---|---:|---:|---:|\n";
  for (const auto& [name, r] : rows) {
    const std::string gs = get(r, "gd_status");
    std::string g = gs == "—" ? "—"
                              : get(r, "gd_seconds") + " s, " + get(r, "gd_iterations") + " it" +
                                    (gs == "ok" ? "" : " (" + gs + " at error " + get(r, "gd_error") + ")");
    const double ratio = num(r, "gd_seconds") / num(r, "newton_1e6");
    std::string rs = std::isfinite(ratio) ? (gs == "ok" ? "" : "> ") + fmt("%.0f", ratio) : "—";
    const double extrapolated = num(r, "gd_extrapolated_seconds") / num(r, "newton_1e6");
    doc += "| " + name + " | " + get(r, "newton_1e6") + " | " + g + " | " + rs + " | " +
           get(r, "gd_extrapolated_iterations") + " | " +
           (std::isfinite(extrapolated) ? "≈ " + fmt("%.0f", extrapolated) : "—") + " |\n";
  }
  // Growth: log–log slope of flow seconds against #F over the generated inputs of each family.
  doc += "\n## Growth with size (least-squares log–log slope of flow seconds and flow peak against #F)\n\n";
  doc += "| family | sizes | time slope | peak-memory slope |\n|---|---|---:|---:|\n";
  for (const std::string family : {"generated/torus-", "generated/genus2-", "generated/icosphere-"}) {
    std::vector<double> lx, lt, lm;
    std::string sizes;
    for (const auto& [name, r] : rows)
      if (name.rfind(family, 0) == 0 && !std::isnan(num(r, "flow"))) {
        lx.push_back(std::log(num(r, "faces")));
        lt.push_back(std::log(num(r, "flow")));
        lm.push_back(std::log(num(r, "peak_flow")));
        sizes += (sizes.empty() ? "" : ", ") + name.substr(family.size());
      }
    if (lx.size() < 2) continue;
    auto slope = [&](const std::vector<double>& y) {
      double mx = 0, my = 0;
      for (std::size_t i = 0; i < lx.size(); ++i) {
        mx += lx[i];
        my += y[i];
      }
      mx /= lx.size();
      my /= lx.size();
      double sxy = 0, sxx = 0;
      for (std::size_t i = 0; i < lx.size(); ++i) {
        sxy += (lx[i] - mx) * (y[i] - my);
        sxx += (lx[i] - mx) * (lx[i] - mx);
      }
      return sxy / sxx;
    };
    doc += "| " + family.substr(10, family.size() - 11) + " | " + sizes + " | " + fmt("%.2f", slope(lt)) + " | " +
           fmt("%.2f", slope(lm)) + " |\n";
  }
  std::cout << doc << std::flush;
  if (!s.out.empty()) {
    const ricci::WriteResult w = ricci::write_file_atomic(s.out, doc);
    if (w.status != ricci::Status::Ok) {
      std::cerr << "bench_pipeline: " << w.message << '\n';
      return 1;
    }
  }
  return 0;
}
