// flip_sweep — the flow stage on mesh files, scheme by scheme: the paper's circle packing and
// vertex scaling (Yamabe) on the mesh's own triangulation (solve_flow()), and vertex scaling with
// intrinsic Delaunay flips (solve_flow_with_flips()). Prints a Markdown table of Newton
// iterations, flips, max |K̄ − K| and seconds per mesh and scheme, and for the flipped solution
// how the input's edges run on it (trace_input_edges(), input_edge_crossings()): crossings in
// all, the most on one input edge, seconds, and whether every crossing lies inside its edge in
// slot order. A benchmark, not a test.
//
//   build/tools/flip_sweep [--threads N] [--flips-only] MESH...   (e.g. ../shared/meshes/genus*/*.off)
//
// Geometry and target as `ricci uniformize` chooses them: S/E/H by χ for closed surfaces, E with
// circle boundaries for genus 0 with boundary, H with geodesic boundaries otherwise. Meshes that
// do not validate are listed with their status.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "ricci/flow.h"
#include "ricci/intrinsic.h"
#include "ricci/intrinsic_trace.h"
#include "ricci/io.h"
#include "ricci/validate.h"

using namespace ricci;

namespace {

std::string cell(const FlowResult& r, bool flips) {
  char buffer[160];
  if (r.status != Status::Ok) {
    std::snprintf(buffer, sizeof buffer, "%s (%d it.)", std::string(status_name(r.status)).c_str(), r.iterations);
    return buffer;
  }
  if (flips)
    std::snprintf(buffer, sizeof buffer, "%d it., %lld flips, %.1e, %.2f s", r.iterations,
                  static_cast<long long>(r.flips), r.max_curvature_error, r.seconds);
  else
    std::snprintf(buffer, sizeof buffer, "%d it., %.1e, %.2f s", r.iterations, r.max_curvature_error, r.seconds);
  return buffer;
}

// Whether the straight input triangles carry the solution: "tiles (angle sums to 1e-15)" or the
// vertices and faces where they do not.
std::string straight_cell(const StraightInputMetric& s) {
  if (s.status != Status::Ok) return s.message;
  char buffer[160];
  if (s.tiles())
    std::snprintf(buffer, sizeof buffer, "tiles (angle sums to %.0e)", s.max_angle_sum_error);
  else
    std::snprintf(buffer, sizeof buffer, "%lld vertices off (max %.1e), %lld degenerate faces",
                  static_cast<long long>(s.inconsistent_vertices), s.max_angle_sum_error,
                  static_cast<long long>(s.degenerate_faces));
  return buffer;
}

// The input's edges on the final triangulation: "N crossings (max M on one edge), S s", or why not.
std::string trace_cell(const IntrinsicTriangulation& tri, const Topology& input, std::span<const double> u) {
  const auto start = std::chrono::steady_clock::now();
  const InputEdgePaths paths = trace_input_edges(tri, input);
  if (paths.status != Status::Ok) return "trace: " + paths.message;
  const std::vector<double> t = input_edge_crossings(tri, u, paths);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // Inside the edges and in slot order along each.
  std::vector<std::vector<double>> along(static_cast<std::size_t>(tri.topology.num_edges));
  for (Index e = 0; e < tri.topology.num_edges; ++e)
    along[e].assign(static_cast<std::size_t>(std::max<std::int64_t>(0, tri.normal[e])), 0.0);
  bool ordered = true;
  for (std::size_t k = 0; k < t.size(); ++k) {
    ordered = ordered && t[k] > 0 && t[k] < 1;
    along[paths.crossed_edge[k]][paths.crossed_slot[k]] = t[k];
  }
  for (const auto& list : along)
    for (std::size_t k = 1; k < list.size(); ++k) ordered = ordered && list[k - 1] < list[k];
  Index most = 0;
  for (std::size_t a = 0; a + 1 < paths.offsets.size(); ++a) most = std::max(most, paths.offsets[a + 1] - paths.offsets[a]);
  const StraightInputMetric straight = straight_input_metric(tri, u, input, paths);
  char buffer[320];
  std::snprintf(buffer, sizeof buffer, "%lld crossings (max %lld on one edge), %.2f s%s; straight: %s",
                static_cast<long long>(t.size()), static_cast<long long>(most), seconds,
                ordered ? "" : ", OUT OF ORDER", straight_cell(straight).c_str());
  return buffer;
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 0;
  bool flips_only = false;
  std::vector<std::string> paths;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--threads" && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    } else if (a == "--flips-only") {
      flips_only = true;
    } else {
      paths.push_back(a);
    }
  }
  if (paths.empty()) {
    std::fprintf(stderr, "usage: flip_sweep [--threads N] [--flips-only] MESH...\n");
    return 2;
  }
  std::printf("| mesh | faces | geometry | circle packing | yamabe, no flips | yamabe with flips | input edges on it |\n");
  std::printf("|---|---:|---|---|---|---|---|\n");
  for (const std::string& path : paths) {
    const ReadResult read = read_mesh(path);
    const std::string name = path.substr(path.find_last_of('/') + 1);
    if (read.status != Status::Ok) {
      std::printf("| %s | – | – | %s | | | |\n", name.c_str(), std::string(status_name(read.status)).c_str());
      continue;
    }
    const ValidateResult v = validate_mesh(read.mesh);
    if (v.status != Status::Ok) {
      std::printf("| %s | – | – | %s | | | |\n", name.c_str(), std::string(status_name(v.status)).c_str());
      continue;
    }
    const Topology& t = v.topology;
    const Geometry g = natural_geometry(t);
    const Target target = uniform_target(t, natural_boundary_mode(t, g));
    FlowOptions options;
    options.threads = threads;
    std::string cells[4];
    for (int k = 0; k < (flips_only ? 0 : 2); ++k) {
      InitialMetricOptions o;
      o.geometry = g;
      o.scheme = k == 0 ? Scheme::CirclePacking : Scheme::Yamabe;
      const InitialMetric m = initial_metric(v.mesh, t, o);
      cells[k] = m.status != Status::Ok ? std::string(status_name(m.status))
                                        : cell(solve_flow(t, m.structure, m.u, target, options), false);
    }
    const auto start = std::chrono::steady_clock::now();
    IntrinsicResult tri = mesh_intrinsic_triangulation(v.mesh, t, g);
    if (tri.status != Status::Ok) {
      cells[2] = std::string(status_name(tri.status));
    } else {
      const std::vector<double> u0(static_cast<std::size_t>(t.num_vertices), 0.0);
      FlowResult r = solve_flow_with_flips(tri.triangulation, u0, target, options);
      r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      r.flips += tri.delaunay_flips;
      cells[2] = cell(r, true);
      if (r.status == Status::Ok) cells[3] = trace_cell(tri.triangulation, t, r.u);
    }
    std::printf("| %s | %d | %s | %s | %s | %s | %s |\n", name.c_str(), t.num_faces,
                std::string(geometry_name(g)).c_str(), cells[0].c_str(), cells[1].c_str(), cells[2].c_str(),
                cells[3].c_str());
    std::fflush(stdout);
  }
  return 0;
}
