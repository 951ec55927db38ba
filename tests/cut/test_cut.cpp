// cut_surface(): the cut mesh is one disk whose sides pair up and glue back to the (refined)
// surface; 2g loops (+ arcs) are reported; the canonical word agrees with intersection numbers
// counted independently on the surface; results are deterministic and valid for random base
// vertices; refinement records reproduce the added vertices. On every fixture and on the shared
// meshes in ../shared/meshes/{genus1,genus2,genus3plus,boundary} (skipped when absent).
#include <doctest/doctest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <span>
#include <string>

#include "ricci/cut.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "support.h"

using namespace ricci;
namespace fs = std::filesystem;

namespace {

std::string nm(const char* prefix, Index k, bool inverse = false) {
  std::string s = prefix;
  s += std::to_string(k);
  if (inverse) s += "^-1";
  return s;
}

std::string expected_word(Index g, Index b, const CutResult& r) {
  std::string w;
  auto add = [&](const std::string& s) {
    if (!w.empty()) w += ' ';
    w += s;
  };
  if (g == 0 && b == 0) return "s1 s1^-1";
  for (Index k = 1; k <= g; ++k) {
    add(nm("a", k));
    add(nm("b", k));
    add(nm("a", k, true));
    add(nm("b", k, true));
  }
  const Index o = (g == 0 && !r.side_boundary_loop.empty()) ? r.side_boundary_loop[0] : -1;
  if (g == 0) add(nm("∂", o + 1));
  for (Index L = 0; L < b; ++L) {
    if (L == o) continue;
    add(nm("t", L + 1));
    add(nm("∂", L + 1));
    add(nm("t", L + 1, true));
  }
  return w;
}

std::span<const Index> generator(const CutResult& r, Index i) {
  return {r.generator_vertices.data() + r.generator_offsets[i],
          static_cast<std::size_t>(r.generator_offsets[i + 1] - r.generator_offsets[i])};
}

/// Every property of a cut; `expect_canonical` for meshes where canonical form must be reached.
void check_cut(const Mesh& mesh, const Topology& topo, const CutResult& r, bool expect_canonical = true) {
  REQUIRE(r.status == Status::Ok);
  const Index g = static_cast<Index>(topo.genus()), b = topo.num_boundary_loops();
  CHECK(r.genus == g);
  CHECK(r.boundary_loops == b);
  // The refined surface: same topology type, records reproduce the added vertices.
  const Index Vs = r.num_input_vertices + r.num_refined_vertices();
  CHECK(r.num_input_vertices == topo.num_vertices);
  REQUIRE(r.surface_positions.size() == static_cast<std::size_t>(Vs) * 3);
  REQUIRE(r.surface_faces.size() == r.surface_face_to_input.size() * 3);
  for (Index v = 0; v < topo.num_vertices; ++v)
    for (int d = 0; d < 3; ++d) CHECK(r.surface_positions[3 * v + d] == mesh.positions[3 * v + d]);
  for (Index k = 0; k < r.num_refined_vertices(); ++k) {
    const Index f = r.refined_vertex_face[k];
    double sum = 0;
    for (int j = 0; j < 3; ++j) {
      CHECK(r.refined_vertex_corners[3 * k + j] == mesh.faces[3 * f + j]);
      CHECK(r.refined_vertex_bary[3 * k + j] >= 0);
      sum += r.refined_vertex_bary[3 * k + j];
    }
    CHECK(std::abs(sum - 1) < 1e-12);
    for (int d = 0; d < 3; ++d) {
      double x = 0;
      for (int j = 0; j < 3; ++j)
        x += r.refined_vertex_bary[3 * k + j] * mesh.positions[3 * mesh.faces[3 * f + j] + d];
      CHECK(std::abs(x - r.surface_positions[3 * (r.num_input_vertices + k) + d]) < 1e-12);
    }
  }
  const TopologyResult st = build_topology(r.surface_faces, Vs);
  REQUIRE(st.status == Status::Ok);
  // The connectivities the cut hands on are the ones build_topology() gives.
  CHECK(ricci_test::same_topology(r.surface_topology, st.topology));
  const TopologyResult dt = build_topology(r.cut_faces, r.num_cut_vertices());
  REQUIRE(dt.status == Status::Ok);
  CHECK(ricci_test::same_topology(r.disk_topology, dt.topology));
  CHECK(st.topology.genus() == g);
  CHECK(st.topology.num_boundary_loops() == b);
  CHECK(st.topology.num_boundary_edges() == topo.num_boundary_edges());
  // Every refined face lies in its input face: its input vertices are corners of that face.
  for (Index f = 0; f < st.topology.num_faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const Index v = r.surface_faces[3 * f + k];
      if (v >= r.num_input_vertices) continue;
      const Index O = r.surface_face_to_input[f];
      CHECK((mesh.faces[3 * O] == v || mesh.faces[3 * O + 1] == v || mesh.faces[3 * O + 2] == v));
    }
  // The refined faces of each input face tile it: their area vectors add up to the input face's
  // and each points the same way (so the refinement is a subdivision, not a re-triangulation).
  if (!mesh.positions.empty()) {
    auto area_vector = [](const std::vector<double>& x, Index p, Index q, Index s) {
      const double u[3] = {x[3 * q] - x[3 * p], x[3 * q + 1] - x[3 * p + 1], x[3 * q + 2] - x[3 * p + 2]};
      const double w[3] = {x[3 * s] - x[3 * p], x[3 * s + 1] - x[3 * p + 1], x[3 * s + 2] - x[3 * p + 2]};
      return std::array<double, 3>{0.5 * (u[1] * w[2] - u[2] * w[1]), 0.5 * (u[2] * w[0] - u[0] * w[2]),
                                   0.5 * (u[0] * w[1] - u[1] * w[0])};
    };
    std::vector<std::array<double, 3>> covered(static_cast<std::size_t>(topo.num_faces), {0.0, 0.0, 0.0});
    std::vector<Index> pieces(static_cast<std::size_t>(topo.num_faces), 0);
    for (Index f = 0; f < st.topology.num_faces; ++f) {
      const Index O = r.surface_face_to_input[f];
      const auto piece = area_vector(r.surface_positions, r.surface_faces[3 * f], r.surface_faces[3 * f + 1],
                                     r.surface_faces[3 * f + 2]);
      const auto whole = area_vector(mesh.positions, mesh.faces[3 * O], mesh.faces[3 * O + 1], mesh.faces[3 * O + 2]);
      CHECK(piece[0] * whole[0] + piece[1] * whole[1] + piece[2] * whole[2] > 0);
      for (int d = 0; d < 3; ++d) covered[O][d] += piece[d];
      ++pieces[O];
    }
    for (Index O = 0; O < topo.num_faces; ++O) {
      const auto whole = area_vector(mesh.positions, mesh.faces[3 * O], mesh.faces[3 * O + 1], mesh.faces[3 * O + 2]);
      const double size = std::sqrt(whole[0] * whole[0] + whole[1] * whole[1] + whole[2] * whole[2]);
      CHECK(pieces[O] >= 1);
      for (int d = 0; d < 3; ++d) CHECK(std::abs(covered[O][d] - whole[d]) <= 1e-9 * size);
    }
  }
  // The cut mesh is one disk.
  const TopologyResult ct = build_topology(r.cut_faces, r.num_cut_vertices());
  REQUIRE(ct.status == Status::Ok);
  CHECK(ricci_test::check_topology(ct.topology, r.cut_faces) == "");
  CHECK(ct.topology.euler_characteristic() == 1);
  CHECK(ct.topology.num_boundary_loops() == 1);
  CHECK(ct.topology.num_components == 1);
  // Gluing back: merging cut vertices reproduces the refined surface exactly.
  std::vector<Index> merged(r.cut_faces.size());
  for (std::size_t c = 0; c < merged.size(); ++c) merged[c] = r.cut_to_surface[r.cut_faces[c]];
  CHECK(merged == r.surface_faces);
  const TopologyResult mt = build_topology(merged, Vs);
  REQUIRE(mt.status == Status::Ok);
  CHECK(mt.topology.num_vertices == st.topology.num_vertices);
  CHECK(mt.topology.num_edges == st.topology.num_edges);
  CHECK(mt.topology.num_faces == st.topology.num_faces);
  CHECK(mt.topology.corner_vertex == st.topology.corner_vertex);
  // Sides: cover the disk boundary in order, partners reversed, boundary sides cover ∂S.
  const Index ns = r.num_sides();
  REQUIRE(ns > 0);
  REQUIRE(r.side_offsets.size() == static_cast<std::size_t>(ns) + 1);
  Index boundary_edges = 0, total_edges = 0;
  for (Index s = 0; s < ns; ++s) {
    const Index b0 = r.side_offsets[s], b1 = r.side_offsets[s + 1];
    REQUIRE(b1 - b0 >= 2);
    total_edges += b1 - b0 - 1;
    const Index next = (s + 1) % ns;
    CHECK(r.side_vertices[b1 - 1] == r.side_vertices[r.side_offsets[next]]);
    if (r.side_kind[s] == SideKind::Boundary) {
      CHECK(r.side_partner[s] == kInvalid);
      boundary_edges += b1 - b0 - 1;
      continue;
    }
    const Index p = r.side_partner[s];
    REQUIRE(p >= 0);
    CHECK(p != s);
    CHECK(r.side_partner[p] == s);
    CHECK(r.side_generator[p] == r.side_generator[s]);
    CHECK(r.side_orientation[p] == -r.side_orientation[s]);
    REQUIRE(r.side_offsets[p + 1] - r.side_offsets[p] == b1 - b0);
    for (Index i = 0; i < b1 - b0; ++i)
      CHECK(r.cut_to_surface[r.side_vertices[b0 + i]] ==
            r.cut_to_surface[r.side_vertices[r.side_offsets[p + 1] - 1 - i]]);
  }
  CHECK(boundary_edges == topo.num_boundary_edges());
  CHECK(total_edges == ct.topology.num_boundary_edges());
  // Generators: 2g loops, b arcs (b−1 for genus 0), a slit for the sphere.
  Index loops = 0, arcs = 0, slits = 0;
  for (Index i = 0; i < r.num_generators(); ++i) {
    if (r.generator_kind[i] == SideKind::Loop) ++loops;
    if (r.generator_kind[i] == SideKind::Arc) ++arcs;
    if (r.generator_kind[i] == SideKind::Slit) ++slits;
  }
  // Not canonical: the loops are the branches of the reduced cut graph (at least 2g).
  if (r.canonical)
    CHECK(loops == 2 * g);
  else
    CHECK(loops >= 2 * g);
  CHECK(arcs == (b == 0 ? 0 : (g == 0 ? b - 1 : b)));
  CHECK(slits == (g == 0 && b == 0 ? 1 : 0));
  if (!expect_canonical) return;
  INFO(r.reason);
  CHECK(r.canonical);
  if (!r.canonical) return;
  CHECK(r.word == expected_word(g, b, r));
  CHECK(ns == (g == 0 && b == 0 ? 2 : 4 * g + (g == 0 ? 1 + 3 * (b - 1) : 3 * b)));
  // Loops pass through the base vertex only once each, and their intersection numbers —
  // counted here on the refined surface, not read from the word — are canonical.
  for (Index i = 0; i < 2 * g; ++i) {
    const auto gi = generator(r, i);
    CHECK(gi.front() == r.base_vertex);
    CHECK(gi.back() == r.base_vertex);
    for (std::size_t k = 1; k + 1 < gi.size(); ++k) CHECK(gi[k] != r.base_vertex);
    for (Index j = 0; j < 2 * g; ++j) {
      if (i == j) continue;
      const int x = intersection_number(st.topology, gi, generator(r, j));
      const int expect = (i / 2 == j / 2) ? (i % 2 == 0 ? 1 : -1) : 0;
      CHECK(x == expect);
    }
  }
}

struct Loaded {
  Mesh mesh;
  Topology topo;
};

Loaded load(const fs::path& p) {
  const LoadResult lr = load_mesh(p.string());
  REQUIRE(lr.status == Status::Ok);
  return {lr.validated.mesh, lr.validated.topology};
}

}  // namespace

TEST_CASE("cut: every fixture becomes one canonical disk, deterministically, for random base vertices") {
  ricci_test::for_each_fixture([&](const ricci_test::fs::path& p) {
    const Loaded m = load(p);
    const CutResult r = cut_surface(m.mesh, m.topo);
    check_cut(m.mesh, m.topo, r);
    const CutResult again = cut_surface(m.mesh, m.topo);
    CHECK(again.cut_faces == r.cut_faces);
    CHECK(again.cut_to_surface == r.cut_to_surface);
    CHECK(again.side_vertices == r.side_vertices);
    CHECK(again.word == r.word);
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      CAPTURE(seed);
      CutOptions o;
      o.seed = seed;
      const CutResult rs = cut_surface(m.mesh, m.topo, o);
      check_cut(m.mesh, m.topo, rs);
      CutOptions ob;
      ob.base_vertex = rs.requested_base_vertex;
      CHECK(cut_surface(m.mesh, m.topo, ob).side_vertices == rs.side_vertices);
    }
  });
}

TEST_CASE("cut: coarse surfaces need refinement and stay exact") {
  using namespace ricci_shapes;
  // A coarse torus: too few free edges at the base vertex for a bouquet of 2 loops.
  for (const Mesh& m :
       {torus(3, 3, 2.0, 0.8), torus(4, 3, 2.0, 0.7), pretzel(2, 2), pretzel(4, 2), pretzel(6, 2)}) {
    const TopologyResult t = build_topology(m.faces, m.num_vertices());
    REQUIRE(t.status == Status::Ok);
    // The sanitizer build tries fewer base vertices (the same paths, less time).
    for (Index v = 0; v < std::min<Index>(m.num_vertices(), ricci_test::kSanitized ? 3 : 6); ++v) {
      CAPTURE(v);
      CutOptions o;
      o.base_vertex = v;
      check_cut(m, t.topology, cut_surface(m, t.topology, o));
    }
  }
}

TEST_CASE("cut: without positions the lengths are uniform and the result is still a canonical disk") {
  const Loaded m = load(ricci_test::fixtures_dir() / "genus2-1hole.obj");
  Mesh bare;
  bare.faces = m.mesh.faces;
  const CutResult r = cut_surface(bare, m.topo);
  REQUIRE(r.status == Status::Ok);
  CHECK(r.surface_positions.empty());
  CHECK(r.canonical);
  const TopologyResult ct = build_topology(r.cut_faces, r.num_cut_vertices());
  REQUIRE(ct.status == Status::Ok);
  CHECK(ct.topology.euler_characteristic() == 1);
  CHECK(ct.topology.num_boundary_loops() == 1);
  CHECK(cut_disk_mesh(r).positions.empty());
}

TEST_CASE("cut: a base vertex on the boundary is replaced by an interior one (genus > 0) or kept (genus 0)") {
  for (const char* name : {"genus2-1hole.obj", "annulus.obj", "sphere-3holes.obj", "disk.obj"}) {
    INFO(name);
    const Loaded m = load(ricci_test::fixtures_dir() / name);
    for (Index k = 0; k < 3; ++k) {
      CutOptions o;
      o.base_vertex =
          m.topo.boundary_vertices[static_cast<std::size_t>(k * 7) % m.topo.boundary_vertices.size()];
      const CutResult r = cut_surface(m.mesh, m.topo, o);
      check_cut(m.mesh, m.topo, r);
      CHECK(r.requested_base_vertex == o.base_vertex);
      const TopologyResult st =
          build_topology(r.surface_faces, r.num_input_vertices + r.num_refined_vertices());
      REQUIRE(st.status == Status::Ok);
      CHECK(st.topology.is_boundary_vertex(r.base_vertex) == (m.topo.genus() == 0));
    }
  }
}

TEST_CASE("cut: renumbered surfaces give valid cuts") {
  using namespace ricci_shapes;
  const Mesh base = remove_vertex_stars(pretzel(2, 2), {3, 40});
  ricci_test::for_each_seed(1, 3, [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const Mesh m = rotate_face_corners(permute_faces(permute_vertices(base, rng), rng), rng);
    const TopologyResult t = build_topology(m.faces, m.num_vertices());
    REQUIRE(t.status == Status::Ok);
    check_cut(m, t.topology, cut_surface(m, t.topology));
  });
}

TEST_CASE("cut: options are checked and data is carried across the cut") {
  const Loaded m = load(ricci_test::fixtures_dir() / "torus.obj");
  CutOptions o;
  o.base_vertex = m.topo.num_vertices;
  CHECK(cut_surface(m.mesh, m.topo, o).status == Status::InvalidArgument);
  o = {};
  o.edge_weights = {1.0, 2.0};
  CHECK(cut_surface(m.mesh, m.topo, o).status == Status::InvalidArgument);
  o.edge_weights.assign(static_cast<std::size_t>(m.topo.num_edges), 1.0);
  const CutResult uniform = cut_surface(m.mesh, m.topo, o);
  check_cut(m.mesh, m.topo, uniform);
  o = {};
  o.canonicalize = false;
  const CutResult raw = cut_surface(m.mesh, m.topo, o);
  check_cut(m.mesh, m.topo, raw, false);
  CHECK(!raw.canonical);
  CHECK(!raw.reason.empty());

  const CutResult r = cut_surface(m.mesh, m.topo);
  REQUIRE(r.status == Status::Ok);
  // Per-vertex data: positions carried to the cut vertices equal the disk mesh's positions.
  const std::vector<double> moved = cut_vertex_data(r, m.mesh.positions, 3);
  const Mesh disk = cut_disk_mesh(r);
  CHECK(moved == disk.positions);
  CHECK(cut_vertex_data(r, std::vector<double>{1.0}, 3).empty());
  // UVs per cut vertex become per-corner texture coordinates with seams along the cut.
  std::vector<double> uv(static_cast<std::size_t>(r.num_cut_vertices()) * 2);
  for (Index v = 0; v < r.num_cut_vertices(); ++v) {
    uv[2 * v] = v;
    uv[2 * v + 1] = -v;
  }
  const Mesh tex = surface_with_cut_uvs(r, uv);
  CHECK(tex.has_texcoords());
  CHECK(tex.faces == r.surface_faces);
  CHECK(tex.num_texcoords() == r.num_cut_vertices());
  CHECK(tex.texcoords.size() == uv.size());
}

// CutOptions::max_refined_per_face bounds what the loops' refinements add: a genus-12 grid's
// canonicalisation adds 329857 vertices on its 5824 faces under the default bound of 64; with a
// bound of 1 (and the 65536 every bound allows) it stops uncanonical, saying so, far sooner.
TEST_CASE("cut: the refinement bound stops a cut whose loops keep crossing refined faces") {
  CutOptions o;
  for (const double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    o.max_refined_per_face = bad;
    std::string why;
    CHECK(!o.is_valid(&why));
    CHECK(why.find("max_refined_per_face") != std::string::npos);
  }
  const ValidateResult v = validate_mesh(ricci_shapes::pretzel_grid(4, 3, 4));
  REQUIRE(v.status == Status::Ok);
  o.max_refined_per_face = 1;
  const CutResult bounded = cut_surface(v.mesh, v.topology, o);
  REQUIRE(bounded.status == Status::Ok);
  CHECK(!bounded.canonical);
  CHECK(bounded.refinement_bound);
  CHECK(bounded.reason.find("more than 1 vertices per input face (and 65536") != std::string::npos);
  CHECK(bounded.num_refined_vertices() <= v.topology.num_faces + 65536);
  check_cut(v.mesh, v.topology, bounded, false);
  const CutResult wide = cut_surface(v.mesh, v.topology);
  REQUIRE(wide.status == Status::Ok);
  CHECK(wide.num_refined_vertices() > 4 * bounded.num_refined_vertices());
}

TEST_CASE("cut: the shared real meshes become disks with canonical polygons") {
  const fs::path root = ricci_test::shared_meshes_dir();
  if (root.empty()) {
    MESSAGE("skipped: ../shared/meshes is absent");
    return;
  }
  ricci_test::for_each_shared_mesh({"genus1", "genus2", "genus3plus", "boundary"}, [&](const fs::path& p) {
    const LoadResult lr = load_mesh(p.string());
    REQUIRE(lr.status == Status::Ok);
    const Mesh& mesh = lr.validated.mesh;
    const Topology& topo = lr.validated.topology;
#ifndef NDEBUG
    if (topo.num_faces > 30000) {
      MESSAGE("skipped in this (debug) build: " << p.filename().string() << " has " << topo.num_faces
                                                << " faces");
      return;
    }
#endif
    const auto t0 = std::chrono::steady_clock::now();
    const CutResult r = cut_surface(mesh, topo);
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    MESSAGE(p.filename().string() << ": " << r.brief_report() << " (" << sec << " s)");
    check_cut(mesh, topo, r);
    if (topo.num_faces <= 12000) {
      CutOptions o;
      o.seed = 7;
      check_cut(mesh, topo, cut_surface(mesh, topo, o));
    }
  });
}
