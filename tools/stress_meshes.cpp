// stress_meshes — writes the seeded stress meshes of issue 8 (tools/stress_shapes.h) as OBJ files.
//
//   stress_meshes --out DIR [--seed S] [--small] [--large [FACES]] [--run]
//
// Writes every stress kind (medium size, ≤ ~25k faces each; --small: the sizes the test suite
// uses) and, with --large, also the random-order torus of FACES faces (default 1000000). Prints
// one line per mesh: name, #V, #F, smallest corner angle (rad), largest valence, edge-length
// ratio, what it stresses. With --run, also uniformize() on each (validated) mesh, one more table:
// status, iterations, curvature error, layout edge error, flips, seconds. Never commit the output: the tests generate the meshes themselves.
#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "stress_shapes.h"

namespace {

int usage() {
  std::fprintf(stderr, "usage: stress_meshes --out DIR [--seed S] [--small] [--large [FACES]] [--run]\n");
  return 2;
}

struct Figures {
  ricci::Index max_valence = 0;
  double edge_ratio = 0;  ///< longest / shortest edge
};

Figures figures(const ricci::Mesh& m) {
  std::vector<ricci::Index> valence(static_cast<std::size_t>(m.num_vertices()), 0);
  double lo = INFINITY, hi = 0;
  for (ricci::Index f = 0; f < m.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const ricci::Index a = m.faces[3 * f + k], b = m.faces[3 * f + (k + 1) % 3];
      ++valence[static_cast<std::size_t>(a)];
      double s = 0;
      for (int d = 0; d < 3; ++d) {
        const double x = m.positions[3 * a + d] - m.positions[3 * b + d];
        s += x * x;
      }
      lo = std::min(lo, std::sqrt(s));
      hi = std::max(hi, std::sqrt(s));
    }
  }
  Figures r;
  for (ricci::Index v : valence) r.max_valence = std::max(r.max_valence, v);
  r.edge_ratio = hi / lo;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  std::uint64_t seed = 1;
  bool small = false;
  bool run = false;
  std::int64_t large = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (a == "--seed" && i + 1 < argc) {
      seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--run") {
      run = true;
    } else if (a == "--small") {
      small = true;
    } else if (a == "--large") {
      large = 1000000;
      if (i + 1 < argc && argv[i + 1][0] != '-') large = std::strtoll(argv[++i], nullptr, 10);
      if (large < 18) return usage();
    } else {
      return usage();
    }
  }
  if (out.empty()) return usage();
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) {
    std::fprintf(stderr, "stress_meshes: cannot create %s: %s\n", out.c_str(), ec.message().c_str());
    return 1;
  }
  std::vector<ricci_shapes::StressMesh> meshes =
      ricci_shapes::stress_meshes(small ? ricci_shapes::StressSize::Small : ricci_shapes::StressSize::Medium, seed);
  if (large > 0) meshes.push_back(ricci_shapes::large_random_order(large, seed));
  std::printf("| mesh | V | F | min angle (rad) | max valence | longest/shortest edge | stresses |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (const ricci_shapes::StressMesh& s : meshes) {
    const std::string path = (std::filesystem::path(out) / (s.name + ".obj")).string();
    const ricci::WriteResult w = ricci::write_mesh(path, s.mesh);
    if (w.status != ricci::Status::Ok) {
      std::fprintf(stderr, "stress_meshes: %s\n", w.message.c_str());
      return 1;
    }
    const Figures fig = figures(s.mesh);
    std::printf("| %s | %" PRId64 " | %" PRId64 " | %.2g | %" PRId64 " | %.3g | %s |\n", s.name.c_str(),
                static_cast<std::int64_t>(s.mesh.num_vertices()), static_cast<std::int64_t>(s.mesh.num_faces()),
                ricci_shapes::min_angle_radians(s.mesh), static_cast<std::int64_t>(fig.max_valence), fig.edge_ratio,
                s.what.c_str());
  }
  if (!run) return 0;
  std::printf("\n| mesh | status | iterations | max curvature error | layout edge error | rounding floor | flips | "
              "seconds | message |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const ricci_shapes::StressMesh& s : meshes) {
    const ricci::ValidateResult v = ricci::validate_mesh(s.mesh);
    if (v.status != ricci::Status::Ok) {
      std::printf("| %s | %s (validation) | | | | | | | %s |\n", s.name.c_str(),
                  std::string(ricci::status_name(v.status)).c_str(), v.message.c_str());
      std::fflush(stdout);
      continue;
    }
    const ricci::UniformizeResult r = ricci::uniformize(v.mesh, v.topology);
    std::printf("| %s | %s | %d | %.2g | %.2g | %.2g | %" PRId64 " | %.2f | %s |\n", s.name.c_str(),
                std::string(ricci::status_name(r.status)).c_str(), r.flow.iterations, r.flow.max_curvature_error,
                r.layout.max_edge_length_error, r.layout.rounding_floor, static_cast<std::int64_t>(r.layout.flipped_faces),
                r.seconds, r.status == ricci::Status::Ok ? "" : r.message.c_str());
    std::fflush(stdout);
  }
  return 0;
}
