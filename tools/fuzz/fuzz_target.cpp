// libFuzzer target: the target-curvature reader (parse_target_text, the in-memory half of
// read_target_file) on three small fixed meshes: a closed tetrahedron, a disk (hexagon fan) and
// an annulus (two boundary loops). Input: byte 0 picks the mesh (byte % 3) and the boundary mode
// ((byte / 3) % 5); the rest is the file's text. A parsed target is then put through
// effective_target() and check_target().
#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "fuzz_common.h"
#include "ricci/flow.h"
#include "ricci/metric.h"

namespace {

struct Fixture {
  ricci::Mesh mesh;
  ricci::Topology topology;
  ricci::InitialMetric metric;
};

Fixture make_fixture(std::vector<double> positions, std::vector<ricci::Index> faces) {
  Fixture f;
  f.mesh.positions = std::move(positions);
  f.mesh.faces = std::move(faces);
  ricci::TopologyResult t = ricci::build_topology(f.mesh.faces, f.mesh.num_vertices());
  RICCI_FUZZ_CHECK(t.status == ricci::Status::Ok);
  f.topology = std::move(t.topology);
  f.metric = ricci::initial_metric(f.mesh, f.topology);
  RICCI_FUZZ_CHECK(f.metric.status == ricci::Status::Ok);
  return f;
}

std::array<Fixture, 3> make_fixtures() {
  // Tetrahedron, outward normals.
  Fixture tetrahedron =
      make_fixture({0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3});
  // Disk: vertex 0 in the middle of a regular hexagon 1..6.
  std::vector<double> p = {0, 0, 0};
  std::vector<ricci::Index> f;
  const double c[6][2] = {{1, 0}, {0.5, 0.866}, {-0.5, 0.866}, {-1, 0}, {-0.5, -0.866}, {0.5, -0.866}};
  for (int i = 0; i < 6; ++i) {
    p.insert(p.end(), {c[i][0], c[i][1], 0});
    f.insert(f.end(), {0, 1 + i, 1 + (i + 1) % 6});
  }
  Fixture disk = make_fixture(p, f);
  // Annulus: inner square 0..3 (radius 1), outer square 4..7 (radius 2).
  p.clear();
  f.clear();
  const double s[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
  for (const double r : {1.0, 2.0})
    for (const auto& d : s) p.insert(p.end(), {r * d[0], r * d[1], 0});
  for (int i = 0; i < 4; ++i) {
    const int j = (i + 1) % 4;
    f.insert(f.end(), {i, 4 + i, 4 + j, i, 4 + j, j});
  }
  Fixture annulus = make_fixture(p, f);
  return {std::move(tetrahedron), std::move(disk), std::move(annulus)};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::array<Fixture, 3> fixtures = make_fixtures();
  if (size < 1) return 0;
  const Fixture& fx = fixtures[data[0] % 3];
  const auto mode = static_cast<ricci::BoundaryMode>((data[0] / 3) % 5);
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  const ricci::Topology& t = fx.topology;

  const ricci::TargetFileResult r = ricci::parse_target_text(text, t, mode, "fuzz.target");
  if (r.status != ricci::Status::Ok) {
    ricci_fuzz::check_failure(r.status, r.message, "fuzz.target");
    RICCI_FUZZ_CHECK(r.status == ricci::Status::ParseError || r.status == ricci::Status::IndexOutOfRange);
    RICCI_FUZZ_CHECK(r.line >= 1);
    return 0;
  }
  RICCI_FUZZ_CHECK(r.line == -1);
  RICCI_FUZZ_CHECK(ricci_fuzz::starts_with(r.message, "fuzz.target: "));
  const ricci::Target& target = r.target;
  const auto nv = static_cast<std::size_t>(t.num_vertices);
  RICCI_FUZZ_CHECK(target.boundary == mode);
  RICCI_FUZZ_CHECK(target.K.size() == nv);
  RICCI_FUZZ_CHECK(ricci_fuzz::all_finite(target.K));
  RICCI_FUZZ_CHECK(target.fixed_u.empty() || target.fixed_u.size() == nv);
  if (mode == ricci::BoundaryMode::FixedLengths) RICCI_FUZZ_CHECK(target.fixed_u.size() == nv);
  if (mode == ricci::BoundaryMode::Circle || mode == ricci::BoundaryMode::LoopTotals)
    RICCI_FUZZ_CHECK(target.loop_total.size() == static_cast<std::size_t>(t.num_boundary_loops()));

  std::vector<double> K_target(nv, 0.0);
  ricci::effective_target(t, target, fx.metric.l0, K_target, ricci::Geometry::Euclidean);
  RICCI_FUZZ_CHECK(ricci_fuzz::all_finite(K_target));
  const ricci::TargetCheck check = ricci::check_target(t, fx.metric.structure, target);
  RICCI_FUZZ_CHECK(check.status == ricci::Status::Ok || check.status == ricci::Status::InfeasibleTarget);
  RICCI_FUZZ_CHECK(!check.message.empty());
  return 0;
}
