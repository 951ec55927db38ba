// Uses the installed ricci library: uniformizes a mesh (by default a torus built here, or
// the mesh file given as the first argument) and checks that the flow converged.
#include <ricci/flow.h>
#include <ricci/metric.h>
#include <ricci/validate.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

namespace {

// An n_major × n_minor grid on a torus of radii R > r, each quad split into two triangles,
// oriented counter-clockwise seen from outside.
ricci::Mesh torus(int n_major, int n_minor, double R, double r) {
  ricci::Mesh mesh;
  for (int i = 0; i < n_major; ++i) {
    const double a = 2 * std::numbers::pi * i / n_major;
    for (int j = 0; j < n_minor; ++j) {
      const double b = 2 * std::numbers::pi * j / n_minor;
      mesh.positions.insert(mesh.positions.end(), {(R + r * std::cos(b)) * std::cos(a),
                                                   (R + r * std::cos(b)) * std::sin(a), r * std::sin(b)});
    }
  }
  const auto vertex = [&](int i, int j) {
    return static_cast<ricci::Index>((i % n_major) * n_minor + j % n_minor);
  };
  for (int i = 0; i < n_major; ++i) {
    for (int j = 0; j < n_minor; ++j) {
      const ricci::Index v00 = vertex(i, j), v10 = vertex(i + 1, j), v11 = vertex(i + 1, j + 1),
                         v01 = vertex(i, j + 1);
      mesh.faces.insert(mesh.faces.end(), {v00, v10, v11, v00, v11, v01});
    }
  }
  return mesh;
}

}  // namespace

int main(int argc, char** argv) {
  ricci::ValidateResult valid;
  if (argc > 1) {
    ricci::LoadResult loaded = ricci::load_mesh(argv[1]);
    if (loaded.status != ricci::Status::Ok) {
      std::fprintf(stderr, "consumer: %s\n", loaded.message.c_str());
      return 1;
    }
    valid = std::move(loaded.validated);
  } else {
    valid = ricci::validate_mesh(torus(16, 8, 3.0, 1.0));
    if (valid.status != ricci::Status::Ok) {
      std::fprintf(stderr, "consumer: %s\n", valid.message.c_str());
      return 1;
    }
  }
  const ricci::Topology& topology = valid.topology;

  ricci::InitialMetricOptions metric_options;
  metric_options.geometry = ricci::natural_geometry(topology);
  const ricci::InitialMetric metric = ricci::initial_metric(valid.mesh, topology, metric_options);
  if (metric.status != ricci::Status::Ok) {
    std::fprintf(stderr, "consumer: %s\n", metric.message.c_str());
    return 1;
  }
  const ricci::Target target =
      ricci::uniform_target(topology, ricci::natural_boundary_mode(topology, metric_options.geometry));
  const ricci::FlowResult flow = ricci::solve_flow(topology, metric.structure, metric.u, target);

  std::printf(
      "consumer: V=%d F=%d chi=%lld %s: %s after %d iterations, max curvature error %.3g\n",
      topology.num_vertices, topology.num_faces, static_cast<long long>(topology.euler_characteristic()),
      std::string(ricci::geometry_name(flow.geometry)).c_str(),
      std::string(ricci::status_name(flow.status)).c_str(), flow.iterations, flow.max_curvature_error);
  if (flow.status != ricci::Status::Ok || !(flow.max_curvature_error <= 1e-9)) {
    std::fprintf(stderr, "consumer: the flow failed: %s\n", flow.message.c_str());
    return 1;
  }
  return 0;
}
