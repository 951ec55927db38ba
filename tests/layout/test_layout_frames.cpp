// Layouts by coarse frames (layout.h, FaceFrames): a fine triangulation whose faces lie in the
// faces of a coarse one is laid out by developing the coarse faces; the fine triangulation's own
// slivers do not enter.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "layout_internal.h"
#include "ricci/layout.h"
#include "ricci/metric.h"
#include "ricci/topology.h"
#include "shapes.h"

using namespace ricci;

namespace {

using P3 = std::array<double, 3>;

P3 polar(Geometry g, double r, double phi) {
  const double c = std::cos(phi), s = std::sin(phi);
  if (g == Geometry::Euclidean) return {r * c, r * s, 0};
  if (g == Geometry::Hyperbolic) return {std::sinh(r) * c, std::sinh(r) * s, std::cosh(r)};
  return {std::sin(r) * c, std::sin(r) * s, std::cos(r)};
}

double distance(Geometry g, const P3& p, const P3& q) {
  const double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
  if (g == Geometry::Euclidean) return std::hypot(dx, dy);
  if (g == Geometry::Hyperbolic) return 2 * std::asinh(0.5 * std::sqrt(std::max(0.0, dx * dx + dy * dy - dz * dz)));
  return 2 * std::asin(std::min(1.0, 0.5 * std::sqrt(dx * dx + dy * dy + dz * dz)));
}

// β-combination of points, put back on the model.
P3 combine(Geometry g, const P3 (&x)[3], const double (&beta)[3]) {
  P3 p{0, 0, 0};
  for (int k = 0; k < 3; ++k)
    for (int d = 0; d < 3; ++d) p[d] += beta[k] * x[k][d];
  double n = 1;
  if (g == Geometry::Hyperbolic) n = std::sqrt(p[2] * p[2] - p[0] * p[0] - p[1] * p[1]);
  if (g == Geometry::Spherical) n = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  for (double& v : p) v /= n;
  return p;
}

struct Fine {
  Topology topology;
  std::vector<double> l;
  FaceFrames frames;
  Index slivers = 0;  // fine corners with an angle below 1e-4
};

// Every coarse face split at one inner point into three, the point at barycentric `beta` (a hair
// from a side: two of the three pieces are slivers); each piece's frame is its coarse face.
Fine split_faces(const Topology& coarse, Geometry g, const std::vector<double>& lc, const double (&beta)[3]) {
  Fine out;
  std::vector<Index> faces;
  out.frames.frame_opposite = coarse.opposite;
  for (Index f = 0; f < coarse.num_faces; ++f) {
    double L[3];
    for (int k = 0; k < 3; ++k) L[k] = lc[coarse.corner_edge[3 * f + k]];
    for (double x : L) out.frames.frame_lengths.push_back(x);
    // The coarse frame: corner 0 at the pole, corner 1 along +x, corner 2 at corner 0's angle.
    std::vector<double> theta(3);
    const Topology one = build_topology(std::vector<Index>{0, 1, 2}, 3).topology;
    std::vector<double> l1(3);
    for (int k = 0; k < 3; ++k) l1[one.corner_edge[k]] = L[k];
    corner_angles(one, g, l1, theta);
    const P3 x[3] = {polar(g, 0, 0), polar(g, L[2], 0), polar(g, L[1], theta[0])};
    const P3 m = combine(g, x, beta);
    const Index mid = coarse.num_vertices + f;
    for (int k = 0; k < 3; ++k) {
      const Index a = coarse.corner_vertex[3 * f + k], b = coarse.corner_vertex[3 * f + (k + 1) % 3];
      faces.insert(faces.end(), {a, b, mid});
      out.frames.face_frame.push_back(f);
      for (const P3& p : {x[k], x[(k + 1) % 3], m}) out.frames.corner_model.insert(out.frames.corner_model.end(), p.begin(), p.end());
    }
  }
  out.topology = build_topology(faces, coarse.num_vertices + coarse.num_faces).topology;
  out.l.assign(static_cast<std::size_t>(out.topology.num_edges), 0.0);
  for (Index c = 0; c < out.topology.num_corners(); ++c) {
    const Index fine_face = c / 3;
    const double* cm = &out.frames.corner_model[9 * static_cast<std::size_t>(fine_face)];
    const int k = static_cast<int>(c % 3);
    const P3 p{cm[3 * ((k + 1) % 3)], cm[3 * ((k + 1) % 3) + 1], cm[3 * ((k + 1) % 3) + 2]};
    const P3 q{cm[3 * ((k + 2) % 3)], cm[3 * ((k + 2) % 3) + 1], cm[3 * ((k + 2) % 3) + 2]};
    out.l[out.topology.corner_edge[c]] = distance(g, p, q);
  }
  std::vector<double> theta(static_cast<std::size_t>(out.topology.num_corners()));
  corner_angles(out.topology, g, out.l, theta);
  for (double t : theta) out.slivers += t < 1e-4 ? 1 : 0;
  return out;
}

// A metric of the disk's planar positions (z dropped): E their distances; H the same points
// shrunk into the Poincaré disk (radius 0.6), their hyperbolic distances.
std::vector<double> coarse_lengths(const Mesh& m, const Topology& t, Geometry g) {
  std::vector<double> l(static_cast<std::size_t>(t.num_edges));
  double r = 0;
  for (Index v = 0; v < m.num_vertices(); ++v) r = std::max(r, std::hypot(m.positions[3 * v], m.positions[3 * v + 1]));
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    const double ax = m.positions[3 * a], ay = m.positions[3 * a + 1], bx = m.positions[3 * b], by = m.positions[3 * b + 1];
    if (g == Geometry::Euclidean) {
      l[e] = std::hypot(ax - bx, ay - by);
    } else {
      const double s = 0.6 / r, za = s * s * (ax * ax + ay * ay), zb = s * s * (bx * bx + by * by);
      l[e] = 2 * std::asinh(s * std::hypot(ax - bx, ay - by) / std::sqrt((1 - za) * (1 - zb)));
    }
  }
  return l;
}

// ricci_shapes::disk(6) in H (coarse_lengths()), each face split at (0.3, 0.3, 0.4).
Fine split_h_disk() {
  const Mesh m = ricci_shapes::disk(6);
  const Topology coarse = build_topology(m.faces, m.num_vertices()).topology;
  const double beta[3] = {0.3, 0.3, 0.4};
  return split_faces(coarse, Geometry::Hyperbolic, coarse_lengths(m, coarse, Geometry::Hyperbolic), beta);
}

// The isometry taking the origin to tanh(moved / 2) on the real axis (distance `moved`).
detail::M3 away_by(double moved) { return detail::disk_map_matrix({-std::tanh(moved / 2), 0}, 1); }

}  // namespace

TEST_CASE("layout by frames: slivers inside well-shaped coarse faces lay out to rounding in E and H") {
  const Mesh m = ricci_shapes::disk(6);
  const Topology coarse = build_topology(m.faces, m.num_vertices()).topology;
  // The inner point a hair (1e-5 of the face) from side 0–1: one of the three pieces is a sliver
  // with angles near 1e-5 (thinner ones round past the triangle inequality in their lengths).
  const double beta[3] = {0.5 - 0.5e-5, 0.5 - 0.5e-5, 1e-5};
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic}) {  // a disk; S: the sphere below
    INFO(geometry_name(g));
    const Fine fine = split_faces(coarse, g, coarse_lengths(m, coarse, g), beta);
    REQUIRE(fine.topology.euler_characteristic() == 1);
    CHECK(fine.slivers >= coarse.num_faces);
    LayoutOptions o;
    o.frames = std::make_shared<const FaceFrames>(fine.frames);
    o.refine_above = 1e300;  // the development alone, no refinement
    const Layout by_frames = layout_disk(fine.topology, g, fine.l, o);
    REQUIRE_MESSAGE(by_frames.status == Status::Ok, by_frames.message);
    CHECK(by_frames.by_frames);
    CHECK(by_frames.flipped_faces == 0);
    // Every fine edge, the slivers' too, to what its coordinates resolve (rounding floor ≥ ε).
    CHECK(by_frames.max_edge_length_error <= std::max(1e-9, 8 * by_frames.rounding_floor));
    LayoutOptions plain = o;
    plain.frames = nullptr;
    const Layout by_faces = layout_disk(fine.topology, g, fine.l, plain);
    MESSAGE(geometry_name(g) << ": by frames " << by_frames.max_edge_length_error << " (floor " << by_frames.rounding_floor
                             << "), depth " << by_frames.depth << "; through the faces " << by_faces.max_edge_length_error);
    // An atlas over the frames' layout with the ring of vertices around vertex 0 put onto vertex 0
    // (as a layout that keeps unresolved vertices leaves them): its chart, developed by the frames
    // from its smallest face, resolves every face again.
    std::vector<double> x = by_frames.positions;
    const Topology& ft = fine.topology;
    for (Index i = ft.vertex_corner_offsets[0]; i < ft.vertex_corner_offsets[1]; ++i) {
      const Index c = ft.vertex_corners[i];
      for (const Index w : {ft.corner_vertex[next_corner(c)], ft.corner_vertex[prev_corner(c)]}) {
        x[2 * static_cast<std::size_t>(w)] = x[0];
        x[2 * static_cast<std::size_t>(w) + 1] = x[1];
      }
    }
    AtlasOptions ao;
    ao.frames = o.frames;
    const LayoutAtlas a = layout_atlas(ft, g, fine.l, x, ao);
    REQUIRE_MESSAGE(a.status == Status::Ok, a.message);
    CHECK(a.num_charts() >= 2);
    CHECK(a.max_edge_length_error <= ao.limit);
    CHECK(a.flipped_faces == 0);
    ao.frames = std::make_shared<const FaceFrames>();  // frames that do not fit: refused
    CHECK(layout_atlas(ft, g, fine.l, x, ao).status == Status::InvalidArgument);
  }
}

TEST_CASE("layout by frames: a hyperbolic disk developed away from the origin keeps its points on the model") {
  // The development starts with the disk moved 4 and 6 from the origin (its points up to 7.5 out).
  // Its edges stay at the rounding floor of their Poincaré coordinates: the disk map's Lorentz
  // matrix is in closed form (built from frames of points that far out, it was off the Lorentz
  // group by ε·e^{2r}: 3.6e3 × the floor at 6), and Poincaré points are taken as (x, y)/(1 + t)
  // (the hyperboloid's form t² − x² − y² cancels out there).
  const Fine fine = split_h_disk();
  const Index seed = central_face(fine.topology);
  for (const double moved : {4.0, 6.0}) {
    CAPTURE(moved);
    detail::FrameDevelopment dev(fine.topology, Geometry::Hyperbolic, fine.frames, seed, false);
    const detail::M3 away = away_by(moved);
    // The map is a Lorentz transformation to rounding: Mᵀ J M = J.
    const double J[3] = {1, 1, -1};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double s = 0;
        for (int k = 0; k < 3; ++k) s += away[3 * k + i] * J[k] * away[3 * k + j];
        CHECK(std::abs(s - (i == j ? J[i] : 0)) <= 1e-15 * std::cosh(moved) * std::cosh(moved));
      }
    std::vector<double> x(2 * static_cast<std::size_t>(fine.topology.num_vertices));
    Layout out;
    REQUIRE(dev.run(x, detail::multiply(away, dev.seed_map()), out));
    const Layout measured = measure_layout(fine.topology, Geometry::Hyperbolic, fine.l, x);
    REQUIRE(measured.status == Status::Ok);
    double reach = 1;
    for (std::size_t i = 0; i < x.size(); i += 2) reach = std::min(reach, std::hypot(x[i], x[i + 1]));
    MESSAGE("nearest point at " << 2 * std::atanh(reach) << ", edge error " << measured.max_edge_length_error
                                << " (floor " << measured.rounding_floor << ")");
    CHECK(2 * std::atanh(reach) > moved - 1.5);
    CHECK(measured.max_edge_length_error <= 8 * measured.rounding_floor);
  }
}

TEST_CASE("layout by frames: the drift estimate of H maps is 0 in the seed's coarse face and grows as e^r") {
  // Each product of SU(1,1) maps at distance r from the origin adds about ε·e^r to how far a
  // face's map may have moved (FrameDevelopment::drift()); the atlas counts it in each chart's
  // floor and leaves faces whose maps drifted beyond the transitions' limit unresolved.
  const Fine fine = split_h_disk();
  const Index seed = central_face(fine.topology);
  double most[2] = {0, 0};
  int i = 0;
  for (const double moved : {0.0, 6.0}) {
    detail::FrameDevelopment dev(fine.topology, Geometry::Hyperbolic, fine.frames, seed, false);
    std::vector<double> x(2 * static_cast<std::size_t>(fine.topology.num_vertices));
    Layout out;
    REQUIRE(dev.run(x, detail::multiply(away_by(moved), dev.seed_map()), out));
    const std::vector<double>& drift = dev.drift();
    REQUIRE(drift.size() == static_cast<std::size_t>(fine.topology.num_faces));
    for (Index f = 0; f < fine.topology.num_faces; ++f) {
      CHECK(std::isfinite(drift[f]));
      if (fine.frames.face_frame[f] == fine.frames.face_frame[seed]) CHECK(drift[f] == 0);
      most[i] = std::max(most[i], drift[f]);
    }
    ++i;
  }
  MESSAGE("largest drift from the origin " << most[0] << ", moved 6 out " << most[1]);
  CHECK(most[0] > 0);
  CHECK(most[0] < 1e-14);
  CHECK(most[1] > 50 * most[0]);  // e^6 ≈ 403
  CHECK(most[1] < 1e-11);
}

TEST_CASE("layout by frames: a split icosphere on the unit sphere, and frames that do not fit are refused") {
  const Mesh m = ricci_shapes::icosphere(2);
  const Topology coarse = build_topology(m.faces, m.num_vertices()).topology;
  std::vector<double> l = mesh_edge_lengths(m, coarse);
  for (double& x : l) x = 2 * std::asin(0.5 * x);  // chords of the unit sphere → arcs
  const double beta[3] = {0.25, 0.25, 0.5};
  const Fine fine = split_faces(coarse, Geometry::Spherical, l, beta);
  LayoutOptions o;
  o.frames = std::make_shared<const FaceFrames>(fine.frames);
  o.sphere_mobius = false;
  const Layout s = layout_sphere(fine.topology, fine.l, o);
  REQUIRE_MESSAGE(s.status == Status::Ok, s.message);
  CHECK(s.by_frames);
  CHECK(s.max_edge_length_error < 1e-12);
  CHECK(s.flipped_faces == 0);

  FaceFrames bad = fine.frames;
  bad.face_frame.pop_back();
  o.frames = std::make_shared<const FaceFrames>(bad);
  const Layout refused = layout_sphere(fine.topology, fine.l, o);
  CHECK(refused.status == Status::InvalidArgument);
  CHECK(refused.message.find("frames") != std::string::npos);
  bad = fine.frames;
  bad.face_frame[0] = coarse.num_faces;  // no such coarse face
  o.frames = std::make_shared<const FaceFrames>(bad);
  CHECK(layout_sphere(fine.topology, fine.l, o).status == Status::InvalidArgument);
}
