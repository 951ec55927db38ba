// Steiner points for conformality (steiner.h): the subdivision is the input surface itself, the
// target carries over, and uniformize() runs on it where the input's faces cannot carry the map
// (E, S and bordered H) — with every guarantee of the layout, the outputs on the user's faces, and
// a more conformal map.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <string>

#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"

using namespace ricci;

namespace {

const double* at(const Mesh& m, Index v) { return &m.positions[3 * static_cast<std::size_t>(v)]; }

double dist(const double* a, const double* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

double area(const double* a, const double* b, const double* c) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2], z = u[0] * w[1] - u[1] * w[0];
  return 0.5 * std::sqrt(x * x + y * y + z * z);
}

double face_area(const Mesh& m, Index f) {
  return area(at(m, m.faces[3 * f]), at(m, m.faces[3 * f + 1]), at(m, m.faces[3 * f + 2]));
}

// Angle sums per vertex (#V) of the mesh's own 3D metric.
std::vector<double> angle_sums(const Mesh& m, const Topology& t) {
  std::vector<double> s(static_cast<std::size_t>(t.num_vertices), 0.0);
  for (Index c = 0; c < t.num_corners(); ++c) {
    const Index f = corner_face(c), k = c % 3;
    const double* p = at(m, m.faces[3 * f + k]);
    const double* q = at(m, m.faces[3 * f + (k + 1) % 3]);
    const double* r = at(m, m.faces[3 * f + (k + 2) % 3]);
    const double a = dist(q, r), b = dist(p, r), d = dist(p, q);
    s[m.faces[3 * f + k]] += std::acos(std::clamp((b * b + d * d - a * a) / (2 * b * d), -1.0, 1.0));
  }
  return s;
}

// Coarse, non-Delaunay surfaces whose straight input triangles fold under the map with flips.
std::vector<std::pair<std::string, Mesh>> hard_cases() {
  using namespace ricci_shapes;
  std::vector<std::pair<std::string, Mesh>> out;
  std::mt19937_64 rng(3);
  out.emplace_back("needles torus (E)", insert_needles_and_caps(torus(12, 6, 2.0, 0.7), rng, 0.3, 0.02));
  out.emplace_back("needles annulus (E, circles)", insert_needles_and_caps(annulus(6, 24), rng, 0.3, 0.02));
  std::mt19937_64 rng2(2);
  out.emplace_back("needles pancake (S)", insert_needles_and_caps(pancake(2, 0.2), rng2, 0.4, 0.03));
  out.emplace_back("random surface 13 (H, genus 5, 2 geodesic loops)", random_surface(13, 1500).mesh);
  return out;
}

// `s` is a subdivision of the input (v.mesh, t) on its own faces (angle sums `sums`): the input's
// vertices first, where they were; every new vertex, face and edge on the input element it names;
// the same piecewise-flat surface.
void check_on_input(const Mesh& in, const Topology& t, const std::vector<double>& sums, const SteinerMesh& s) {
  const Topology& st = s.topology;
  CHECK(st.euler_characteristic() == t.euler_characteristic());
  CHECK(st.genus() == t.genus());
  CHECK(st.num_boundary_loops() == t.num_boundary_loops());
  CHECK(st.num_components == 1);
  // The input's vertices first, where they were.
  for (Index k = 0; k < 3 * t.num_vertices; ++k) CHECK(s.mesh.positions[k] == in.positions[k]);
  // Every vertex lies on the input element it names: an edge's segment or a face's triangle.
  for (Index w = 0; w < st.num_vertices; ++w) {
    const SteinerPlace p = s.place[w];
    if (w < t.num_vertices) {
      CHECK(p.kind == SteinerPlace::Kind::Vertex);
      CHECK(p.index == w);
    } else if (p.kind == SteinerPlace::Kind::Edge) {
      const double* a = at(in, t.edge_vertices[2 * p.index]);
      const double* b = at(in, t.edge_vertices[2 * p.index + 1]);
      CHECK(std::abs(dist(a, at(s.mesh, w)) + dist(at(s.mesh, w), b) - dist(a, b)) < 1e-12 * dist(a, b));
    } else {
      REQUIRE(p.kind == SteinerPlace::Kind::Face);
      const Index* f = &in.faces[3 * p.index];
      const double whole = face_area(in, p.index);
      const double parts = area(at(s.mesh, w), at(in, f[1]), at(in, f[2])) +
                           area(at(in, f[0]), at(s.mesh, w), at(in, f[2])) +
                           area(at(in, f[0]), at(in, f[1]), at(s.mesh, w));
      CHECK(std::abs(parts - whole) < 1e-12 * whole);
    }
  }
  // The faces of each input face cover exactly its area, with its orientation (no fold).
  std::vector<double> covered(static_cast<std::size_t>(t.num_faces), 0.0);
  for (Index f = 0; f < st.num_faces; ++f) covered[s.face_input[f]] += face_area(s.mesh, f);
  for (Index f = 0; f < t.num_faces; ++f) CHECK(std::abs(covered[f] - face_area(in, f)) < 1e-12 * face_area(in, f));
  // Edges said to lie on an input edge have both ends on it; the boundary is made of them.
  for (Index e = 0; e < st.num_edges; ++e) {
    const Index ie = s.edge_input[e];
    if (st.edge_corners[2 * e + 1] == kInvalid) CHECK(ie != kInvalid);
    if (ie == kInvalid) continue;
    for (int end = 0; end < 2; ++end) {
      const SteinerPlace p = s.place[st.edge_vertices[2 * e + end]];
      const bool on = (p.kind == SteinerPlace::Kind::Edge && p.index == ie) ||
                      (p.kind == SteinerPlace::Kind::Vertex &&
                       (p.index == t.edge_vertices[2 * ie] || p.index == t.edge_vertices[2 * ie + 1]));
      CHECK(on);
    }
  }
  // The same piecewise-flat surface: cone angles unchanged at the input's vertices, 2π (π on
  // the boundary) at the new ones.
  const std::vector<double> refined = angle_sums(s.mesh, st);
  for (Index w = 0; w < st.num_vertices; ++w) {
    const double expected = w < t.num_vertices ? sums[w] : (st.is_boundary_vertex(w) ? std::numbers::pi : 2 * std::numbers::pi);
    CHECK(std::abs(refined[w] - expected) < 1e-11);
  }
}

}  // namespace

TEST_CASE("steiner: the subdivision is the input surface, each new vertex, edge and face where it says") {
  using namespace ricci_shapes;
  std::mt19937_64 rng(7);
  const Mesh inputs[] = {insert_needles_and_caps(annulus(4, 12), rng, 0.3, 0.05), pretzel(2, 2), icosphere(1)};
  for (const Mesh& in : inputs) {
    const ValidateResult v = validate_mesh(in);
    REQUIRE(v.status == Status::Ok);
    const Topology& t = v.topology;
    const std::vector<double> sums = angle_sums(v.mesh, t);
    for (int levels = 0; levels <= 2; ++levels) {
      INFO("levels " << levels);
      const SteinerMesh s = subdivide_on_faces(v.mesh, t, levels);
      REQUIRE_MESSAGE(s.status == Status::Ok, s.message);
      const Topology& st = s.topology;
      CHECK(st.num_faces == t.num_faces << (2 * levels));
      check_on_input(v.mesh, t, sums, s);
    }
  }
  const ValidateResult v = validate_mesh(ricci_shapes::icosphere(0));
  CHECK(subdivide_on_faces(v.mesh, v.topology, 9).status == Status::InvalidArgument);
  CHECK(subdivide_on_faces(v.mesh, v.topology, -1).status == Status::InvalidArgument);
}

TEST_CASE("steiner: boundary splits keep the input surface, one split per face and round, interior edges left alone") {
  using namespace ricci_shapes;
  std::mt19937_64 rng(5);
  const Mesh inputs[] = {insert_needles_and_caps(annulus(4, 12), rng, 0.3, 0.05),
                         remove_vertex_stars(icosphere(2), {0, 5, 40})};
  for (const Mesh& in : inputs) {
    const ValidateResult v = validate_mesh(in);
    REQUIRE(v.status == Status::Ok);
    const Topology& t = v.topology;
    const std::vector<double> sums = angle_sums(v.mesh, t);
    const Target target = uniform_target(t, BoundaryMode::Circle);
    SteinerMesh s = subdivide_on_faces(v.mesh, t, 0);
    REQUIRE(s.status == Status::Ok);
    for (int round = 0; round < 3; ++round) {
      CAPTURE(round);
      // Every boundary edge in loop order, the first of them again, and one interior edge.
      const Topology& st = s.topology;
      std::vector<Index> edges;
      std::set<Index> faces;
      for (const Index c : st.boundary_corners) {
        edges.push_back(st.corner_edge[c]);
        faces.insert(corner_face(c));
      }
      edges.push_back(edges.front());
      for (Index e = 0; e < st.num_edges; ++e)
        if (st.edge_corners[2 * e + 1] != kInvalid) {
          edges.push_back(e);
          break;
        }
      Index n = -1;
      SteinerMesh next = split_boundary_edges(s, edges, &n);
      REQUIRE_MESSAGE(next.status == Status::Ok, next.message);
      // One split per face (a face with two boundary edges waits for the next round).
      CHECK(n == static_cast<Index>(faces.size()));
      CHECK(next.topology.num_vertices == st.num_vertices + n);
      CHECK(next.topology.num_faces == st.num_faces + n);
      CHECK(next.topology.num_boundary_edges() == st.num_boundary_edges() + n);
      for (Index w = 0; w < st.num_vertices; ++w) {
        CHECK(next.place[w].kind == s.place[w].kind);
        CHECK(next.place[w].index == s.place[w].index);
      }
      for (Index w = st.num_vertices; w < next.topology.num_vertices; ++w) {
        CHECK(next.topology.is_boundary_vertex(w));
        REQUIRE(next.place[w].kind == SteinerPlace::Kind::Edge);
        CHECK(t.edge_corners[2 * next.place[w].index + 1] == kInvalid);
      }
      check_on_input(v.mesh, t, sums, next);
      // The loops keep their totals: the same multiset, Gauss–Bonnet with the flat new vertices.
      const Target split = steiner_target(next, t, target);
      std::vector<double> a = target.loop_total, b = split.loop_total;
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      CHECK(a == b);
      s = std::move(next);
    }
    const Index bad[] = {s.topology.num_edges};
    CHECK(split_boundary_edges(s, bad).status == Status::InvalidArgument);
  }
}

namespace {

// Counted by the definition, not by find_chords() (checked against it below).
Index count_chords(const Topology& t) {
  Index n = 0;
  for (Index e = 0; e < t.num_edges; ++e) {
    if (t.edge_corners[2 * e + 1] == kInvalid) continue;
    n += t.is_boundary_vertex(t.edge_vertices[2 * e]) && t.is_boundary_vertex(t.edge_vertices[2 * e + 1]) ? 1 : 0;
  }
  return n;
}

// The surface glued to its mirror image along the boundary: a closed surface, or why not.
TopologyResult glued_double(const Mesh& m, const Topology& t) {
  std::vector<Index> mirror(static_cast<std::size_t>(t.num_vertices));
  Index next = t.num_vertices;
  for (Index v = 0; v < t.num_vertices; ++v) mirror[v] = t.is_boundary_vertex(v) ? v : next++;
  std::vector<Index> faces = m.faces;
  for (Index f = 0; f < t.num_faces; ++f)
    faces.insert(faces.end(), {mirror[m.faces[3 * f]], mirror[m.faces[3 * f + 2]], mirror[m.faces[3 * f + 1]]});
  return build_topology(faces, next);
}

}  // namespace

TEST_CASE("steiner: chord splits keep the input surface, leave no chord, and make the double a closed surface") {
  using namespace ricci_shapes;
  // Every interior edge of a one-layer annulus and of a one-row strip is a chord, several to a
  // face (so the splits take rounds); the random surface has a few among many interior edges.
  ValidateOptions vo;
  vo.split_ears = true;
  const Mesh inputs[] = {annulus(1, 12), strip(6, 1, 6.0, 1.0), random_surface(1, 1500).mesh, pretzel(2, 2)};
  for (const Mesh& in : inputs) {
    const ValidateResult v = validate_mesh(in, vo);
    REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
    const Topology& t = v.topology;
    const Index chords = count_chords(t);
    CAPTURE(chords);
    CHECK(static_cast<Index>(find_chords(t).size()) == chords);
    const std::vector<double> sums = angle_sums(v.mesh, t);
    const SteinerMesh s = subdivide_on_faces(v.mesh, t, 0);
    REQUIRE(s.status == Status::Ok);
    Index n = -1;
    const SteinerMesh split = split_chords(s, &n);
    REQUIRE_MESSAGE(split.status == Status::Ok, split.message);
    CHECK(n == chords);  // a split makes no chord, so each chord of the input is split once
    const Topology& st = split.topology;
    CHECK(count_chords(st) == 0);
    CHECK(st.num_vertices == t.num_vertices + n);
    CHECK(st.num_faces == t.num_faces + 2 * n);
    CHECK(st.num_boundary_edges() == t.num_boundary_edges());
    for (Index w = t.num_vertices; w < st.num_vertices; ++w) {
      CHECK_FALSE(st.is_boundary_vertex(w));
      REQUIRE(split.place[w].kind == SteinerPlace::Kind::Edge);
      const Index e = split.place[w].index;
      CHECK(t.edge_corners[2 * e + 1] != kInvalid);  // on an interior input edge …
      CHECK(t.is_boundary_vertex(t.edge_vertices[2 * e]));  // … that was a chord
      CHECK(t.is_boundary_vertex(t.edge_vertices[2 * e + 1]));
    }
    check_on_input(v.mesh, t, sums, split);
    if (!t.is_closed()) {
      const TopologyResult d = glued_double(split.mesh, st);
      REQUIRE_MESSAGE(d.status == Status::Ok, d.message);
      CHECK(d.topology.is_closed());
      CHECK(d.topology.euler_characteristic() == 2 * t.euler_characteristic());
      if (chords > 0) {
        const TopologyResult before = glued_double(v.mesh, t);
        CHECK((before.status != Status::Ok || !before.topology.is_closed()));
      }
    } else {
      CHECK(n == 0);
    }
  }
}

TEST_CASE("steiner: the target carries over: Gauss–Bonnet, loop totals by loop, held boundaries") {
  using namespace ricci_shapes;
  // Three holes of different sizes, so the loops' totals differ (circle: longest +2π, others −2π).
  const Mesh holes = remove_vertex_stars(icosphere(2), {0, 5, 40});
  const ValidateResult v = validate_mesh(holes);
  REQUIRE(v.status == Status::Ok);
  const Topology& t = v.topology;
  REQUIRE(t.num_boundary_loops() == 3);
  for (const BoundaryMode mode : {BoundaryMode::Circle, BoundaryMode::FixedLengths, BoundaryMode::Geodesic}) {
    Target given = uniform_target(t, mode);
    if (mode == BoundaryMode::Circle) given.loop_total = {1.0, 2.0, 3.0};  // tell the loops apart
    const SteinerMesh s = subdivide_on_faces(v.mesh, t, 2);
    REQUIRE(s.status == Status::Ok);
    const Target st = steiner_target(s, t, given);
    CHECK(st.boundary == given.boundary);
    REQUIRE(st.K.size() == static_cast<std::size_t>(s.topology.num_vertices));
    double before = 0, after = 0;
    for (const double k : given.K) before += k;
    for (const double k : st.K) after += k;
    CHECK(after == doctest::Approx(before).epsilon(1e-14));
    for (Index w = t.num_vertices; w < s.topology.num_vertices; ++w) CHECK(st.K[w] == 0);
    // Each loop of the subdivision keeps the total of the input's loop through the same vertices.
    REQUIRE(st.loop_total.size() == given.loop_total.size());
    for (Index i = 0; i < static_cast<Index>(st.loop_total.size()); ++i) {
      const Index w = s.topology.boundary_vertices[s.topology.boundary_offsets[i]];
      Index input_vertex = w;
      for (Index j = s.topology.boundary_offsets[i]; j < s.topology.boundary_offsets[i + 1]; ++j)
        if (s.topology.boundary_vertices[j] < t.num_vertices) input_vertex = s.topology.boundary_vertices[j];
      for (Index l = 0; l < t.num_boundary_loops(); ++l)
        for (Index j = t.boundary_offsets[l]; j < t.boundary_offsets[l + 1]; ++j)
          if (t.boundary_vertices[j] == input_vertex) CHECK(st.loop_total[i] == given.loop_total[l]);
    }
    if (mode == BoundaryMode::FixedLengths) {
      REQUIRE(st.fixed_u.size() == st.K.size());
      for (Index w = 0; w < s.topology.num_vertices; ++w) CHECK(st.fixed_u[w] == (s.topology.is_boundary_vertex(w) ? 1 : 0));
    }
  }
}

TEST_CASE("steiner: levels halve the median jump to the resolution, within the face budget") {
  CHECK(steiner_levels(0.19, 0.05, 3, 891, 1 << 16) == 2);
  CHECK(steiner_levels(0.05, 0.05, 3, 891, 1 << 16) == 0);
  CHECK(steiner_levels(0.051, 0.05, 3, 891, 1 << 16) == 1);
  CHECK(steiner_levels(10.0, 0.05, 3, 891, 1 << 16) == 3);
  CHECK(steiner_levels(10.0, 0.05, 3, 5000, 1 << 16) == 1);   // 20000 faces, not 80000
  CHECK(steiner_levels(10.0, 0.05, 3, 20000, 1 << 16) == 0);  // 80000 > 65536
  CHECK(steiner_levels(10.0, 0.05, 0, 891, 1 << 16) == 0);
  CHECK(steiner_levels(std::nan(""), 0.05, 3, 891, 1 << 16) == 0);
  UniformizeOptions o;
  std::string why;
  CHECK(o.is_valid(&why));
  o.steiner_max_levels = 9;
  CHECK_FALSE(o.is_valid(&why));
  CHECK(why.find("steiner_max_levels") != std::string::npos);
  o = {};
  o.steiner_resolution = 0;
  CHECK_FALSE(o.is_valid(&why));
  o = {};
  o.steiner_max_faces = 0;
  CHECK_FALSE(o.is_valid(&why));
  const ValidateResult v = validate_mesh(ricci_shapes::icosphere(1));
  std::vector<double> u(static_cast<std::size_t>(v.topology.num_vertices), 0.0);
  CHECK(median_edge_jump(v.topology, u) == 0);
  for (Index w = 0; w < v.topology.num_vertices; ++w) u[w] = 0.25 * w;
  CHECK(median_edge_jump(v.topology, u) > 0);
}

TEST_CASE("uniformize: where straight input triangles fold and the factor jumps, Steiner points make the map more conformal") {
  for (const auto& [name, mesh] : hard_cases()) {
    INFO(name);
    ValidateOptions vo;
    vo.split_ears = true;  // as the CLI does for circle and geodesic loops
    const ValidateResult v = validate_mesh(mesh, vo);
    REQUIRE(v.status == Status::Ok);
    const Topology& t = v.topology;
    UniformizeOptions o;
    const UniformizeResult r = uniformize(v.mesh, t, o);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    UniformizeOptions off = o;
    off.steiner_max_levels = 0;
    const UniformizeResult plain = uniformize(v.mesh, t, off);
    REQUIRE_MESSAGE(plain.status == Status::Ok, plain.message);
    MESSAGE(r.brief_report() << "; Steiner levels " << r.steiner.levels << ", median jump " << r.steiner.median_jump
                             << " -> " << r.steiner.refined_median_jump << ", angle distortion "
                             << plain.angles.mean_abs_log << " -> " << r.angles.mean_abs_log);
    CHECK_FALSE(plain.steiner.used);
    CHECK_FALSE(plain.intrinsic.straight_tiles);  // the case the subdivision is for
    REQUIRE(r.steiner.used);
    CHECK(r.steiner.levels >= 1);
    CHECK(r.steiner.median_jump == doctest::Approx(median_edge_jump(t, plain.flow.u)).epsilon(1e-12));
    CHECK(r.steiner.refined_median_jump < r.steiner.median_jump);
    CHECK(r.steiner.vertices_added == r.steiner_mesh.topology.num_vertices - t.num_vertices);
    // Every guarantee on the subdivided surface.
    CHECK(r.flow.max_curvature_error < 1e-12);
    CHECK(r.flow.u.size() == static_cast<std::size_t>(r.steiner_mesh.topology.num_vertices));
    for (Index w = t.num_vertices; w < r.steiner_mesh.topology.num_vertices; ++w)
      if (!r.steiner_mesh.topology.is_boundary_vertex(w)) CHECK(r.flow.K_target[w] == 0);
    CHECK(r.intrinsic.refined);
    // Within 1e-9, or within what the coordinates of the subdivision's smallest pieces resolve
    // (crossings a hair apart where the needles' flips cross the Steiner edges: 1.4e-8 here).
    CHECK(r.layout.max_edge_length_error < std::max(1e-9, r.layout.rounding_floor));
    CHECK(r.layout.flipped_faces == 0);
    CHECK(r.seed_independence_error < 1e-9);
    if (r.has_deck) CHECK(r.deck.relation_error < 1e-9);
    // Back on the user's faces: the common subdivision names them, and covers each exactly.
    const CommonSubdivision& cs = r.refinement;
    std::vector<double> covered(static_cast<std::size_t>(t.num_faces), 0.0);
    for (Index f = 0; f < cs.topology.num_faces; ++f) {
      REQUIRE(cs.face_input[f] >= 0);
      REQUIRE(cs.face_input[f] < t.num_faces);
      covered[cs.face_input[f]] += face_area(cs.mesh, f);
    }
    for (Index f = 0; f < t.num_faces; ++f) CHECK(covered[f] == doctest::Approx(face_area(v.mesh, f)).epsilon(1e-9));
    const InputSurfaceLayout through = input_surface_layout(v.mesh, t, r);
    REQUIRE_MESSAGE(through.status == Status::Ok, through.message);
    CHECK(through.mesh.faces == v.mesh.faces);
    CHECK(r.angles.ratio.size() == static_cast<std::size_t>(3 * t.num_faces));
    // The point of it: a more conformal map of the same surface.
    CHECK(r.angles.mean_abs_log < plain.angles.mean_abs_log);
    // Deterministic.
    const UniformizeResult again = uniformize(v.mesh, t, o);
    CHECK(again.flow.u == r.flow.u);
    CHECK(again.angles.mean_abs_log == r.angles.mean_abs_log);
  }
}

TEST_CASE("uniformize: no Steiner points where the straight input triangles tile, nor on closed H surfaces") {
  std::mt19937_64 rng(3);
  const std::pair<std::string, Mesh> cases[] = {
      {"torus (tiles)", ricci_shapes::torus(24, 12, 2.0, 0.7)},
      {"needles pretzel(2, 2) (H, folds)", ricci_shapes::insert_needles_and_caps(ricci_shapes::pretzel(2, 2), rng, 0.3, 0.02)}};
  for (const auto& [name, mesh] : cases) {
    INFO(name);
    const ValidateResult v = validate_mesh(mesh);
    REQUIRE(v.status == Status::Ok);
    const UniformizeResult r = uniformize(v.mesh, v.topology);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.intrinsic.straight_tiles == (r.geometry != Geometry::Hyperbolic));
    CHECK_FALSE(r.steiner.used);
    CHECK(r.steiner.levels == 0);
    CHECK(r.flow.u.size() == static_cast<std::size_t>(v.topology.num_vertices));
    for (const auto& [stage, seconds] : r.timings) CHECK(stage.rfind("probe_", 0) == std::string::npos);
  }
}
