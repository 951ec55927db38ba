// Tests of the ear repair (find_ears, split_ears, ValidateOptions::split_ears) and of its default
// in `ricci flow`: an ear on an inner circle loop makes the target infeasible naming the vertex;
// the split keeps χ, the loops, the orientation and every input vertex, puts each new vertex at
// the midpoint of the split edge, and lets the flow converge; ear-free meshes stay as they were.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "ricci/flow.h"
#include "ricci/io.h"
#include "ricci/metric.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;

namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

/// annulus(2, 24) with an ear triangle in the hole on the inner loop's first edge. Returns the
/// ear's vertex index (the last vertex) through *ear.
Mesh annulus_with_ear(Index* ear) {
  Mesh m = ricci_shapes::annulus(2, 24);
  const ValidateResult v = validate_mesh(m);
  REQUIRE(v.status == Status::Ok);
  const Topology& t = v.topology;
  // The inner loop: the one whose first vertex is nearest the centre.
  Index inner = 0;
  auto radius = [&](Index x) { return std::hypot(m.positions[3 * x], m.positions[3 * x + 1]); };
  for (Index i = 1; i < t.num_boundary_loops(); ++i)
    if (radius(t.boundary_vertices[t.boundary_offsets[i]]) <
        radius(t.boundary_vertices[t.boundary_offsets[inner]]))
      inner = i;
  const Index j = t.boundary_offsets[inner];
  const Index p = t.boundary_vertices[j], q = t.boundary_vertices[j + 1];  // the loop runs p → q
  const Index e = m.num_vertices();
  for (int d = 0; d < 3; ++d) {
    const double mid = 0.5 * (m.positions[3 * p + d] + m.positions[3 * q + d]);
    m.positions.push_back(d < 2 ? 0.85 * mid : mid);  // into the hole
  }
  m.faces.insert(m.faces.end(), {q, p, e});  // traverses the boundary edge the other way
  *ear = e;
  return m;
}

/// The Circle target with the loop holding `outer_vertex` at +2π and the other loops at −2π.
Target circle_target(const Topology& t, Index outer_vertex) {
  Target target = uniform_target(t, BoundaryMode::Circle);
  for (Index i = 0; i < t.num_boundary_loops(); ++i) {
    bool outer = false;
    for (Index j = t.boundary_offsets[i]; j < t.boundary_offsets[i + 1]; ++j)
      outer = outer || t.boundary_vertices[j] == outer_vertex;
    target.loop_total[i] = outer ? kTwoPi : -kTwoPi;
  }
  return target;
}

/// A vertex on the outer loop of annulus() (radius 1).
Index outer_vertex(const Mesh& m) {
  for (Index v = 0; v < m.num_vertices(); ++v)
    if (std::hypot(m.positions[3 * v], m.positions[3 * v + 1]) > 0.99) return v;
  return kInvalid;
}

/// Checks what split_ears() promises for the split of `in` into `out` (`split` ears).
void check_split(const Mesh& in, const Topology& tin, const Mesh& out, const Topology& tout,
                 std::size_t split) {
  CHECK(ricci_test::check_topology(tout, out.faces).empty());
  CHECK(tout.euler_characteristic() == tin.euler_characteristic());
  CHECK(tout.num_boundary_loops() == tin.num_boundary_loops());
  CHECK(tout.num_boundary_edges() == tin.num_boundary_edges());
  CHECK(tout.num_components == tin.num_components);
  CHECK(out.num_vertices() == in.num_vertices() + static_cast<Index>(split));
  CHECK(out.num_faces() == in.num_faces() + 2 * static_cast<Index>(split));
  // Input vertices: same positions, same indices.
  CHECK(std::equal(in.positions.begin(), in.positions.end(), out.positions.begin()));
  // The boundary loops are the input's (the same vertices in the same order).
  CHECK(tout.boundary_vertices == tin.boundary_vertices);
  // Consistent orientation: every interior edge is traversed both ways (build_topology checks it
  // too), and every face keeps a positive normal component along the input's average normal.
  std::set<std::pair<Index, Index>> directed;
  for (Index f = 0; f < out.num_faces(); ++f)
    for (Index k = 0; k < 3; ++k) {
      const bool fresh = directed.insert({out.faces[3 * f + k], out.faces[3 * f + (k + 1) % 3]}).second;
      CHECK(fresh);
    }
  // Each new vertex is interior, of valence 4 (or more when a later round split an edge of one
  // of its faces), and the exact midpoint of two of its neighbours from the input.
  for (Index v = in.num_vertices(); v < out.num_vertices(); ++v) {
    CAPTURE(v);
    CHECK_FALSE(tout.is_boundary_vertex(v));
    CHECK(tout.valence(v) >= 4);
    std::vector<Index> ring;  // the far vertex of each corner's next edge
    for (Index k = tout.vertex_corner_offsets[v]; k < tout.vertex_corner_offsets[v + 1]; ++k)
      ring.push_back(tout.corner_vertex[next_corner(tout.vertex_corners[k])]);
    bool midpoint = false;
    for (Index a : ring)
      for (Index c : ring) {
        bool all = a < c && c < in.num_vertices();
        for (int d = 0; d < 3 && all; ++d)
          all = out.positions[3 * v + d] == 0.5 * (out.positions[3 * a + d] + out.positions[3 * c + d]);
        midpoint = midpoint || all;
      }
    CHECK(midpoint);
  }
  // No ears remain that could have been split (isolated triangles aside).
  for (Index b : find_ears(tout)) {
    const Index c = tout.vertex_corners[tout.vertex_corner_offsets[b]];
    CHECK(tout.opposite[c] == kInvalid);
  }
}

/// The target passes its check and Newton reaches it to 1e-10 from the initial metric.
void converges(const ValidateResult& v, const Target& target) {
  const InitialMetric im = initial_metric(v.mesh, v.topology);
  REQUIRE(im.status == Status::Ok);
  const TargetCheck check = check_target(v.topology, im.structure, target);
  REQUIRE_MESSAGE(check.status == Status::Ok, check.message);
  FlowOptions fo;
  fo.tolerance = 1e-10;
  const FlowResult r = solve_flow(v.topology, im.structure, im.u, target, fo);
  INFO(r.message);
  CHECK(r.status == Status::Ok);
  CHECK(r.max_curvature_error < 1e-10);
}

}  // namespace

TEST_CASE("repair ears: without the split an inner-loop ear makes the circle target infeasible, naming it") {
  Index ear = kInvalid;
  const Mesh m = annulus_with_ear(&ear);
  const ValidateResult v = validate_mesh(m);
  REQUIRE(v.status == Status::Ok);
  CHECK(v.repairs.empty());
  CHECK(find_ears(v.topology) == std::vector<Index>{ear});
  const InitialMetric im = initial_metric(v.mesh, v.topology);
  REQUIRE(im.status == Status::Ok);
  const TargetCheck check =
      check_target(v.topology, im.structure, circle_target(v.topology, outer_vertex(m)));
  CHECK(check.status == Status::InfeasibleTarget);
  CHECK(check.element == Element::Vertex);
  CHECK(check.element_index == ear);
  CHECK(check.message.find("vertex " + std::to_string(ear)) != std::string::npos);
  CHECK(check.message.find("single triangle") != std::string::npos);
}

TEST_CASE("repair ears: infeasible_ears lists exactly the ears a target's check rejects") {
  Index ear = kInvalid;
  const Mesh m = annulus_with_ear(&ear);
  const ValidateResult v = validate_mesh(m);
  REQUIRE(v.status == Status::Ok);
  const Topology& t = v.topology;
  const Target circle = circle_target(t, outer_vertex(m));
  // Circle: the ear lies on the inner loop (total −2π); on the outer loop (+2π) it would be feasible.
  CHECK(infeasible_ears(t, circle) == std::vector<Index>{ear});
  Target swapped = circle;
  for (double& total : swapped.loop_total) total = -total;
  CHECK(infeasible_ears(t, swapped).empty());
  // Free boundary: K̄ per vertex, the ear's own value decides.
  Target free = uniform_target(t, BoundaryMode::Free);
  free.K[ear] = 0.5;
  CHECK(infeasible_ears(t, free).empty());
  free.K[ear] = 0;
  CHECK(infeasible_ears(t, free) == std::vector<Index>{ear});
  // A held u asks no curvature; targets of the wrong size list nothing.
  free.fixed_u.assign(static_cast<std::size_t>(t.num_vertices), 0);
  free.fixed_u[ear] = 1;
  CHECK(infeasible_ears(t, free).empty());
  Target short_target = circle;
  short_target.K.pop_back();
  CHECK(infeasible_ears(t, short_target).empty());
  // What the check says agrees: infeasible with the ear, feasible once it is split.
  const InitialMetric im = initial_metric(v.mesh, t);
  REQUIRE(im.status == Status::Ok);
  CHECK(check_target(t, im.structure, circle).status == Status::InfeasibleTarget);
  ValidateResult split = v;
  REQUIRE(split_ears(split, infeasible_ears(t, circle)) == Status::Ok);
  CHECK(infeasible_ears(split.topology, circle_target(split.topology, outer_vertex(split.mesh))).empty());
}

TEST_CASE("repair ears: the split keeps χ, loops, orientation and input vertices, and the flow then converges") {
  Index ear = kInvalid;
  const Mesh m = annulus_with_ear(&ear);
  const ValidateResult plain = validate_mesh(m);
  REQUIRE(plain.status == Status::Ok);
  ValidateOptions vo;
  vo.split_ears = true;
  const ValidateResult v = validate_mesh(m, vo);
  REQUIRE(v.status == Status::Ok);
  check_split(plain.mesh, plain.topology, v.mesh, v.topology, 1);
  CHECK(v.topology.valence(ear) == 2);
  REQUIRE(v.repairs.size() == 1);
  CHECK(v.repairs[0].kind == RepairKind::EarsSplit);
  CHECK(repair_name(v.repairs[0].kind) == "ears_split");
  CHECK(v.repairs[0].count == 1);
  CHECK(v.repairs[0].message.find(std::to_string(ear)) != std::string::npos);
  // Maps: input vertices map to themselves, the new one to none; every face to an input face.
  REQUIRE(v.vertex_to_input.size() == static_cast<std::size_t>(m.num_vertices() + 1));
  for (Index x = 0; x < m.num_vertices(); ++x) CHECK(v.vertex_to_input[x] == x);
  CHECK(v.vertex_to_input.back() == kInvalid);
  REQUIRE(v.face_to_input.size() == static_cast<std::size_t>(v.mesh.num_faces()));
  for (Index f = 0; f < v.mesh.num_faces(); ++f) {
    const Index g = v.face_to_input[f];
    REQUIRE(g >= 0);
    REQUIRE(g < m.num_faces());
    // The output face shares at least two vertices with the input face it is part of.
    int shared = 0;
    for (Index k = 0; k < 3; ++k)
      for (Index j = 0; j < 3; ++j) shared += v.mesh.faces[3 * f + k] == m.faces[3 * g + j];
    CHECK(shared >= 2);
  }

  converges(v, circle_target(v.topology, outer_vertex(m)));
}

TEST_CASE("repair ears: split_ears on chosen ears, in rounds, and on isolated triangles") {
  SUBCASE("two ears on one face are split in two rounds") {
    // Face g = (0, 1, 2) with ear faces across two of its edges: (1, 0, 3) and (2, 1, 4).
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -0.6, 0.1, 1.2, 0.8, 0.1};
    m.faces = {0, 1, 2, 1, 0, 3, 2, 1, 4};
    m.texcoords = {0, 0, 1, 0, 0.5, 1, 0.5, -0.6, 1.2, 0.8};
    m.corner_texcoords = m.faces;
    const TopologyResult t = build_topology(m.faces, m.num_vertices());
    REQUIRE(t.status == Status::Ok);
    CHECK(find_ears(t.topology) == std::vector<Index>{3, 4});
    const SplitEarsResult r = split_ears(m, t.topology);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.split == std::vector<Index>{3, 4});
    CHECK(r.unsplittable.empty());
    CHECK(r.repair.count == 2);
    check_split(m, t.topology, r.mesh, r.topology, 2);
    // Texture coordinates follow: each new corner's coordinate is the new vertex's midpoint here.
    REQUIRE(r.mesh.corner_texcoords.size() == r.mesh.faces.size());
    for (std::size_t c = 0; c < r.mesh.faces.size(); ++c) {
      const Index v = r.mesh.faces[c], tc = r.mesh.corner_texcoords[c];
      CHECK(r.mesh.texcoords[2 * tc] == r.mesh.positions[3 * v]);
      CHECK(r.mesh.texcoords[2 * tc + 1] == r.mesh.positions[3 * v + 1]);
    }
    // Only the chosen ear.
    const SplitEarsResult one = split_ears(m, t.topology, std::vector<Index>{4, 0});
    REQUIRE(one.status == Status::Ok);
    CHECK(one.split == std::vector<Index>{4});
    CHECK(one.mesh.num_vertices() == 6);
    CHECK(find_ears(one.topology) == std::vector<Index>{3});
  }
  SUBCASE("two triangles on one edge: one split removes both ears") {
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    m.faces = {0, 1, 2, 0, 2, 3};
    const TopologyResult t = build_topology(m.faces, 4);
    REQUIRE(t.status == Status::Ok);
    CHECK(find_ears(t.topology) == std::vector<Index>{1, 3});
    const SplitEarsResult r = split_ears(m, t.topology);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.split == std::vector<Index>{1});
    check_split(m, t.topology, r.mesh, r.topology, 1);
  }
  SUBCASE("an isolated triangle is left alone and reported") {
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    m.faces = {0, 1, 2};
    const TopologyResult t = build_topology(m.faces, 3);
    REQUIRE(t.status == Status::Ok);
    const SplitEarsResult r = split_ears(m, t.topology);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.split.empty());
    CHECK(r.unsplittable == std::vector<Index>{0, 1, 2});
    CHECK(r.repair.count == 0);
    CHECK(r.mesh.positions == m.positions);
    CHECK(r.mesh.faces == m.faces);
    ValidateOptions vo;
    vo.split_ears = true;
    const ValidateResult v = validate_mesh(m, vo);
    REQUIRE(v.status == Status::Ok);
    CHECK(v.repairs.empty());
  }
  SUBCASE("bad arguments") {
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    m.faces = {0, 1, 2};
    const TopologyResult t = build_topology(m.faces, 3);
    CHECK(split_ears(m, t.topology, std::vector<Index>{7}).status == Status::InvalidArgument);
    Mesh bigger = m;
    bigger.positions.insert(bigger.positions.end(), {1, 1, 0});
    CHECK(split_ears(bigger, t.topology).status == Status::InvalidArgument);
  }
}

TEST_CASE("repair ears: ear-free meshes are left byte-identical") {
  std::vector<std::pair<std::string, Mesh>> meshes = {{"annulus", ricci_shapes::annulus(3, 12)},
                                                      {"disk", ricci_shapes::disk(4)},
                                                      {"torus", ricci_shapes::torus(12, 8, 1.0, 0.4)}};
  ricci_test::for_each_fixture([&](const ricci_test::fs::path& file) {
    const ReadResult rr = read_mesh(file.string());
    if (rr.status == Status::Ok) meshes.emplace_back(file.filename().string(), rr.mesh);
  });
  REQUIRE(meshes.size() >= 5);
  for (const auto& [name, m] : meshes) {
    INFO(name);
    const ValidateResult plain = validate_mesh(m);
    REQUIRE(plain.status == Status::Ok);
    if (!find_ears(plain.topology).empty()) continue;  // (none of these has one)
    ValidateOptions vo;
    vo.split_ears = true;
    const ValidateResult v = validate_mesh(m, vo);
    REQUIRE(v.status == Status::Ok);
    CHECK(v.mesh.positions == plain.mesh.positions);
    CHECK(v.mesh.faces == plain.mesh.faces);
    CHECK(v.mesh.texcoords == plain.mesh.texcoords);
    CHECK(v.mesh.corner_texcoords == plain.mesh.corner_texcoords);
    CHECK(v.topology.opposite == plain.topology.opposite);
    CHECK(v.vertex_to_input == plain.vertex_to_input);
    CHECK(v.face_to_input == plain.face_to_input);
    CHECK(v.repairs.size() == plain.repairs.size());
    const SplitEarsResult r = split_ears(plain.mesh, plain.topology);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.split.empty());
    CHECK(r.mesh.positions == plain.mesh.positions);
    CHECK(r.mesh.faces == plain.mesh.faces);
  }
}

TEST_CASE("repair ears: ricci flow splits an infeasible ear by default and refuses it with --no-split-ears") {
  const std::string cli = RICCI_CLI_PATH;
  if (cli.empty()) {
    MESSAGE("skipped: the CLI is not built");
    return;
  }
  Index ear2 = kInvalid;
  const Mesh with_ear = annulus_with_ear(&ear2);
  ricci_test::TempDir dir;
  const std::string in = (dir / "ear.obj").string();
  REQUIRE(write_mesh(in, with_ear).status == Status::Ok);
  // The inner loop (with the ear) is loop 0 or 1; find it to give the totals in that order.
  const ValidateResult v = validate_mesh(with_ear);
  REQUIRE(v.status == Status::Ok);
  std::string totals;
  for (Index i = 0; i < v.topology.num_boundary_loops(); ++i) {
    bool has_ear = false;
    for (Index j = v.topology.boundary_offsets[i]; j < v.topology.boundary_offsets[i + 1]; ++j)
      has_ear = has_ear || v.topology.boundary_vertices[j] == ear2;
    totals += std::string(i ? "," : "") + (has_ear ? "-2pi" : "2pi");
  }
  const std::string metric = (dir / "metric.csv").string();
  const auto off = ricci_test::run_cli(
      {"flow", in, "--boundary", "loop-totals=" + totals, "--json", "-q", "--no-split-ears"});
  CHECK(off.exit_code == 8);
  CHECK(off.err.find("vertex " + std::to_string(ear2)) != std::string::npos);
  const auto on =
      ricci_test::run_cli({"flow", in, "--boundary", "loop-totals=" + totals, "--json", "-q", "-o", metric});
  INFO(on.err);
  REQUIRE(on.exit_code == 0);
  const nlohmann::json j = nlohmann::json::parse(on.out, nullptr, false);
  REQUIRE(j.is_object());
  REQUIRE(j.contains("repairs"));
  bool reported = false;
  for (const auto& rep : j["repairs"])
    reported = reported || (rep["kind"] == "ears_split" && rep["count"] == 1);
  CHECK(reported);
  CHECK(j["vertices"] == with_ear.num_vertices() + 1);
  // The metric file lists the new vertex last, with input_vertex −1.
  const std::string text = ricci_test::read_bytes(metric);
  std::string row = "\n";  // (built step by step: GCC 12 warns on "\n" + std::string&&)
  row += std::to_string(with_ear.num_vertices());
  row += ",-1,";
  CHECK(text.find(row) != std::string::npos);
}

TEST_CASE("repair ears: the Stanford bunny's inner-loop ears are split and its circle domain converges") {
  const auto root = ricci_test::shared_meshes_dir();
  const auto file = root / "boundary" / "stanford-bunny.obj";
  if (root.empty() || !ricci_test::fs::exists(file)) {
    MESSAGE("skipped: ../shared/meshes/boundary/stanford-bunny.obj is absent");
    return;
  }
  LoadOptions lo;
  lo.validate.split_ears = true;
  const LoadResult loaded = load_mesh(file.string(), lo);
  REQUIRE(loaded.status == Status::Ok);
  const ValidateResult& v = loaded.validated;
  const auto it = std::find_if(loaded.repairs.begin(), loaded.repairs.end(),
                               [](const Repair& r) { return r.kind == RepairKind::EarsSplit; });
  REQUIRE(it != loaded.repairs.end());
  CHECK(it->count >= 1);
  CHECK(it->message.find("1791") != std::string::npos);
  CHECK(find_ears(v.topology).empty());
  converges(v, uniform_target(v.topology, BoundaryMode::Circle));
}
