// Layouts: every fixture, uniformized (flow to 1e-12 in its natural geometry), cut and laid out,
// has the metric's edge lengths to < 1e-9 and no flipped face, and layouts from three seeds agree
// after the fitted isometry to < 1e-9; the metric carried to refined surfaces is exact (copied
// edges bit for bit, flat at added vertices, curvature kept at input vertices); normalisations
// hold; alignment recovers known isometries; bad input gives a status naming the element. Shared
// meshes (../shared/meshes, skipped when absent): figures per mesh.
#include <doctest/doctest.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "model_geometry.h"
#include "ricci/cut.h"
#include "ricci/flow.h"
#include "ricci/io.h"
#include "ricci/layout.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

using namespace ricci;
namespace model = ricci::model;
namespace fs = std::filesystem;

namespace {

constexpr double kPi = std::numbers::pi;

struct Uniformized {
  Mesh mesh;
  Topology topo;
  Geometry geometry = Geometry::Euclidean;
  FlowResult flow;
};

Uniformized uniformize(const Mesh& mesh, const Topology& topo, double tol = 1e-12) {
  Uniformized u;
  u.mesh = mesh;
  u.topo = topo;
  u.geometry = natural_geometry(topo);
  InitialMetricOptions o;
  o.geometry = u.geometry;
  const InitialMetric m = initial_metric(mesh, topo, o);
  REQUIRE_MESSAGE(m.status == Status::Ok, m.message);
  const Target target = uniform_target(topo, natural_boundary_mode(topo, u.geometry));
  FlowOptions fo;
  fo.tolerance = tol;
  // Newton steps only: the layouts below are sized on the residuals their path leaves (pretzel(2,
  // 8) ≈ 6e-13, which the patches must reduce); chord steps end elsewhere within the tolerance.
  fo.chord_steps = false;
  u.flow = solve_flow(topo, m.structure, m.u, target, fo);
  return u;
}

/// The disk (cut mesh) of a uniformized surface with its edge lengths.
struct Disk {
  CutResult cut;
  RefinedMetric refined;
  Topology topo;
  std::vector<double> l;
};

Disk cut_disk(const Uniformized& u) {
  Disk d;
  d.cut = cut_surface(u.mesh, u.topo);
  REQUIRE_MESSAGE(d.cut.status == Status::Ok, d.cut.message);
  d.refined = refined_edge_lengths(d.cut, u.topo, u.geometry, u.flow.l);
  REQUIRE_MESSAGE(d.refined.status == Status::Ok, d.refined.message);
  const TopologyResult t = build_topology(d.cut.cut_faces, d.cut.num_cut_vertices());
  REQUIRE(t.status == Status::Ok);
  d.topo = t.topology;
  d.l = disk_edge_lengths(d.cut, d.refined.surface, d.refined.l, d.topo);
  REQUIRE(d.l.size() == static_cast<std::size_t>(d.topo.num_edges));
  return d;
}

/// Layout of a uniformized surface from a seed: the sphere directly, everything else cut open.
Layout lay_out(const Uniformized& u, const Disk* d, Index seed, bool mobius = true,
               std::shared_ptr<const LayoutShapes> shapes = nullptr) {
  LayoutOptions o;
  o.seed_face = seed;
  o.sphere_mobius = mobius;
  o.shapes = std::move(shapes);
  if (d == nullptr) return layout_sphere(u.topo, u.flow.l, o);
  return layout_disk(d->topo, u.geometry, d->l, o);
}

Uniformized load_uniformized(const fs::path& p, double tol = 1e-12) {
  const LoadResult lr = load_mesh(p.string());
  REQUIRE_MESSAGE(lr.status == Status::Ok, lr.message);
  return uniformize(lr.validated.mesh, lr.validated.topology, tol);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Checks a layout of a uniformized surface and its seed independence; returns the worst
/// alignment error over the extra seeds.
double check_surface(const Uniformized& u, const Disk* d, double edge_tol, bool expect_no_flips) {
  const Index nf = d ? d->topo.num_faces : u.topo.num_faces;
  const Layout base = lay_out(u, d, -1, false);
  REQUIRE_MESSAGE(base.status == Status::Ok, base.message);
  // Where double-precision coordinates cannot resolve edge_tol (H: far from the origin), the
  // layout must reach the rounding floor instead (reported by the caller).
  edge_tol = std::max(edge_tol, 8 * base.rounding_floor);
  CHECK(base.max_edge_length_error < edge_tol);
  if (expect_no_flips) CHECK(base.flipped_faces == 0);
  CHECK(base.unplaced_vertices == 0);
  double worst = 0;
  for (Index seed : {Index{0}, nf / 2, nf - 1}) {
    CAPTURE(seed);
    const Layout other = lay_out(u, d, seed, false);
    REQUIRE(other.status == Status::Ok);
    CHECK(other.seed_face == seed);
    CHECK(other.max_edge_length_error < edge_tol);
    const LayoutAlignment a = align_layouts(u.geometry, base.positions, other.positions);
    REQUIRE(a.status == Status::Ok);
    worst = std::max(worst, a.max_deviation);
    if (u.geometry == Geometry::Hyperbolic) CHECK(other.centre_of_mass < 1e-9);
  }
  return worst;
}

}  // namespace

TEST_CASE("layout: every fixture lays out with the metric's edge lengths, no flips, independent of the seed") {
  for (const fs::path& p : ricci_test::mesh_files(ricci_test::fixtures_dir())) {
    INFO(p.filename().string());
    const auto t0 = std::chrono::steady_clock::now();
    const Uniformized u = load_uniformized(p);
    REQUIRE_MESSAGE(u.flow.status == Status::Ok, u.flow.message);
    CHECK(u.flow.max_curvature_error < 1e-12);
    const bool sphere = u.topo.is_closed() && u.topo.euler_characteristic() == 2;
    Disk d;
    if (!sphere) d = cut_disk(u);
    const Disk* dp = sphere ? nullptr : &d;
    const Layout base = lay_out(u, dp, -1);
    REQUIRE(base.status == Status::Ok);
    if (dp != nullptr && base.rounding_floor > 1e-6) {
      // One chart cannot hold it (genus2-finger.obj): every face to 1e-9 in an atlas, none flipped.
      const LayoutAtlas a = layout_atlas(d.topo, u.geometry, d.l, base.positions);
      MESSAGE(p.filename().string() << ": one chart resolves only " << base.rounding_floor << "; " << a.message);
      REQUIRE_MESSAGE(a.status == Status::Ok, a.message);
      CHECK(a.num_charts() >= 2);
      CHECK(a.max_edge_length_error <= 1e-9);
      CHECK(a.flipped_faces == 0);
      continue;
    }
    const double seed_error = check_surface(u, dp, 1e-9, true);
    // The seed-independence error is a distance; what rounding allows is the floor times a length,
    // accumulated over the developments from the other seeds like a random walk (√depth).
    double lmax = 0;
    for (double x : (dp ? d.l : u.flow.l)) lmax = std::max(lmax, x);
    const double seed_tol = std::max(1e-9, 8 * base.rounding_floor * lmax * std::sqrt(static_cast<double>(base.depth)));
    CHECK(seed_error < seed_tol);
    MESSAGE(p.filename().string() << " (" << geometry_name(u.geometry) << "): " << base.brief_report()
                                  << ", rounding floor " << base.rounding_floor << ", seed independence "
                                  << seed_error << ", total " << seconds_since(t0) << " s");
    if (base.rounding_floor > 1e-10)
      MESSAGE(p.filename().string() << ": double-precision Poincaré coordinates cannot resolve 1e-9 here (floor "
                                    << base.rounding_floor << "); checked against 8× the floor");
    CHECK(base.flipped_faces == 0);
    // The shapes it read (corner angles, and areas outside E), given to a layout from another seed
    // of the same lengths, give that layout bit for bit; shapes of another size are not used.
    REQUIRE(base.shapes != nullptr);
    CHECK(base.shapes->corner_angles.size() == static_cast<std::size_t>(3 * (dp ? d.topo : u.topo).num_faces));
    CHECK(base.shapes->face_areas.size() == static_cast<std::size_t>((dp ? d.topo : u.topo).num_faces));
    const Layout fresh = lay_out(u, dp, 0), read = lay_out(u, dp, 0, true, base.shapes);
    REQUIRE(read.status == Status::Ok);
    CHECK(read.positions == fresh.positions);
    CHECK(read.shapes == base.shapes);
    auto short_shapes = std::make_shared<LayoutShapes>(*base.shapes);
    short_shapes->corner_angles.pop_back();
    const Layout ignored = lay_out(u, dp, 0, true, short_shapes);
    CHECK(ignored.positions == fresh.positions);
    CHECK(ignored.shapes != short_shapes);
    auto bent = std::make_shared<LayoutShapes>(*base.shapes);  // read, not recomputed: it shows
    for (double& a : bent->corner_angles) a *= 1 + 1e-6;  // E, H: the development turns by them
    for (std::size_t f = 0; f < bent->face_areas.size(); ++f)  // S: only the centring reads areas
      bent->face_areas[f] *= 1 + 1e-3 * static_cast<double>(f % 7);
    CHECK(lay_out(u, dp, 0, true, bent).positions != fresh.positions);
    if (sphere) {
      // Möbius-centred layouts: centred, still unflipped, and seed independent up to a rotation.
      CHECK(base.centre_of_mass < 1e-12);
      CHECK(base.mobius_length_change >= 0);
      const Layout other = lay_out(u, dp, 0);
      CHECK(layout_alignment_error(u.geometry, base.positions, other.positions) < 1e-9);
    } else if (u.geometry == Geometry::Hyperbolic) {
      CHECK(base.centre_of_mass < 1e-9);
    }
  }
}

TEST_CASE("layout: an unrefined cut carries the input's own connectivity and lengths") {
  // A disk is not cut and a coarse torus's cut adds no vertex: the refined surface is the input,
  // its connectivity copied (not rebuilt) and every length copied bit for bit.
  using namespace ricci_shapes;
  for (const Mesh& m : {disk(6), torus(8, 6, 2.0, 0.7)}) {
    const Topology t = build_topology(m.faces, m.num_vertices()).topology;
    const CutResult cut = cut_surface(m, t);
    REQUIRE(cut.status == Status::Ok);
    if (cut.num_refined_vertices() != 0) continue;
    std::vector<double> l(static_cast<std::size_t>(t.num_edges));
    for (Index e = 0; e < t.num_edges; ++e) l[e] = 1 + 0.01 * (e % 7);
    const RefinedMetric r = refined_edge_lengths(cut, t, Geometry::Euclidean, l);
    REQUIRE(r.status == Status::Ok);
    const Topology rebuilt = build_topology(cut.surface_faces, t.num_vertices).topology;
    CHECK(r.surface.corner_vertex == rebuilt.corner_vertex);
    CHECK(r.surface.opposite == rebuilt.opposite);
    CHECK(r.surface.corner_edge == rebuilt.corner_edge);
    CHECK(r.surface.edge_vertices == rebuilt.edge_vertices);
    CHECK(r.surface.vertex_corners == rebuilt.vertex_corners);
    CHECK(r.surface.boundary_vertices == rebuilt.boundary_vertices);
    CHECK(r.l == l);
  }
}

TEST_CASE("layout: the metric carried to refined surfaces is exact in E, H and S") {
  using namespace ricci_shapes;
  Index refined_meshes = 0;
  for (const Mesh& m : {torus(3, 3, 2.0, 0.8), torus(4, 3, 2.0, 0.7), pretzel(2, 2)}) {
    const TopologyResult tr = build_topology(m.faces, m.num_vertices());
    REQUIRE(tr.status == Status::Ok);
    const Topology& t = tr.topology;
    const CutResult cut = cut_surface(m, t);
    REQUIRE(cut.status == Status::Ok);
    if (cut.num_refined_vertices() == 0) continue;
    ++refined_meshes;
    // Any metric will do: the 3D lengths, scaled so that spherical faces are small enough.
    std::vector<double> l3(static_cast<std::size_t>(t.num_edges));
    for (Index e = 0; e < t.num_edges; ++e) {
      const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
      l3[e] = std::hypot(m.positions[3 * a] - m.positions[3 * b], m.positions[3 * a + 1] - m.positions[3 * b + 1],
                         m.positions[3 * a + 2] - m.positions[3 * b + 2]);
    }
    for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical}) {
      INFO(geometry_name(g));
      std::vector<double> l = l3;
      if (g == Geometry::Spherical)
        for (double& x : l) x *= 0.3;
      const RefinedMetric r = refined_edge_lengths(cut, t, g, l);
      REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
      const Topology& s = r.surface;
      CHECK(r.edges_copied + r.edges_computed == s.num_edges);
      CHECK(r.edges_computed > 0);
      // Input edges keep their lengths bit for bit; split edges add up.
      Index copied = 0;
      for (Index e = 0; e < s.num_edges; ++e) {
        const Index a = s.edge_vertices[2 * e], b = s.edge_vertices[2 * e + 1];
        if (a >= t.num_vertices || b >= t.num_vertices) continue;
        for (Index i = t.vertex_corner_offsets[a]; i < t.vertex_corner_offsets[a + 1]; ++i) {
          const Index c = t.vertex_corners[i];
          if (t.corner_vertex[next_corner(c)] == b) {
            CHECK(r.l[e] == l[t.corner_edge[prev_corner(c)]]);
            ++copied;
          }
        }
      }
      CHECK(copied == r.edges_copied);
      // Angles: flat at every added vertex, the input's angle sums at input vertices.
      std::vector<double> th(static_cast<std::size_t>(s.num_corners())), K(static_cast<std::size_t>(s.num_vertices));
      REQUIRE(corner_angles(s, g, r.l, th).violations == 0);
      vertex_curvature(s, th, K);
      std::vector<double> th0(static_cast<std::size_t>(t.num_corners())), K0(static_cast<std::size_t>(t.num_vertices));
      REQUIRE(corner_angles(t, g, l, th0).violations == 0);
      vertex_curvature(t, th0, K0);
      double flat = 0, kept = 0;
      for (Index v = 0; v < s.num_vertices; ++v) {
        if (v >= t.num_vertices)
          flat = std::max(flat, std::abs(K[v]));
        else
          kept = std::max(kept, std::abs(K[v] - K0[v]));
      }
      CHECK(flat < 1e-12);
      CHECK(kept < 1e-12);
      // Areas add up per input face.
      std::vector<double> A(static_cast<std::size_t>(s.num_faces)), A0(static_cast<std::size_t>(t.num_faces));
      face_areas(s, g, r.l, th, A);
      face_areas(t, g, l, th0, A0);
      std::vector<double> covered(static_cast<std::size_t>(t.num_faces), 0.0);
      for (Index f = 0; f < s.num_faces; ++f) covered[cut.surface_face_to_input[f]] += A[f];
      for (Index f = 0; f < t.num_faces; ++f) CHECK(std::abs(covered[f] - A0[f]) < 1e-12 * std::max(1.0, A0[f]));
      // Disk lengths: each disk edge has the length of the surface edge in the same face slot.
      const TopologyResult dt = build_topology(cut.cut_faces, cut.num_cut_vertices());
      REQUIRE(dt.status == Status::Ok);
      const std::vector<double> ld = disk_edge_lengths(cut, s, r.l, dt.topology);
      REQUIRE(ld.size() == static_cast<std::size_t>(dt.topology.num_edges));
      for (Index c = 0; c < dt.topology.num_corners(); ++c) CHECK(ld[dt.topology.corner_edge[c]] == r.l[s.corner_edge[c]]);
    }
  }
  CHECK(refined_meshes >= 1);
}

TEST_CASE("layout: the uniformized coarse genus-2 surface, refined by its cut, lays out exactly") {
  const Mesh m = ricci_shapes::pretzel(2, 2);
  const TopologyResult tr = build_topology(m.faces, m.num_vertices());
  REQUIRE(tr.status == Status::Ok);
  const Uniformized u = uniformize(m, tr.topology);
  REQUIRE_MESSAGE(u.flow.status == Status::Ok, u.flow.message);
  const Disk d = cut_disk(u);
  CHECK(d.cut.num_refined_vertices() > 0);
  const double seed_error = check_surface(u, &d, 1e-9, true);
  CHECK(seed_error < 1e-9);
}

TEST_CASE("layout: normalisations") {
  const Uniformized u = load_uniformized(ricci_test::fixtures_dir() / "disk.obj");
  const Disk d = cut_disk(u);
  LayoutOptions o;
  o.normalize = true;
  const Layout plain = layout_disk(d.topo, Geometry::Euclidean, d.l, o);
  REQUIRE(plain.status == Status::Ok);
  // E: seed corner 0 at the origin, seed edge on +x.
  const Index s0 = d.topo.corner_vertex[3 * plain.seed_face], s1 = d.topo.corner_vertex[3 * plain.seed_face + 1];
  CHECK(plain.positions[2 * s0] == 0);
  CHECK(plain.positions[2 * s0 + 1] == 0);
  CHECK(plain.positions[2 * s1] > 0);
  CHECK(plain.positions[2 * s1 + 1] == 0);
  o.unit_box = true;
  const Layout box = layout_disk(d.topo, Geometry::Euclidean, d.l, o);
  REQUIRE(box.status == Status::Ok);
  double lo[2] = {1, 1}, hi[2] = {0, 0};
  for (Index v = 0; v < d.topo.num_vertices; ++v)
    for (int k = 0; k < 2; ++k) {
      lo[k] = std::min(lo[k], box.positions[2 * v + k]);
      hi[k] = std::max(hi[k], box.positions[2 * v + k]);
    }
  CHECK(lo[0] == 0);
  CHECK(lo[1] == 0);
  CHECK(std::max(hi[0], hi[1]) == doctest::Approx(1).epsilon(1e-15));
  CHECK(box.max_edge_length_error == plain.max_edge_length_error);
  double plo[2] = {1e300, 1e300};
  for (std::size_t i = 0; i < plain.positions.size(); ++i) plo[i % 2] = std::min(plo[i % 2], plain.positions[i]);
  for (std::size_t i = 0; i < box.positions.size(); ++i)
    CHECK(std::abs(box.positions[i] - (plain.positions[i] - plo[i % 2]) * box.scale) < 1e-14);
  // H: the same disk in the hyperbolic plane with the same lengths scaled down: centred.
  std::vector<double> lh = d.l;
  for (double& x : lh) x *= 0.05;
  const Layout h = layout_disk(d.topo, Geometry::Hyperbolic, lh, o);
  REQUIRE(h.status == Status::Ok);
  CHECK(h.centre_of_mass < 1e-12);
  const Index hv = d.topo.corner_vertex[3 * h.seed_face];
  CHECK(std::abs(h.positions[2 * hv + 1]) < 1e-15);
  CHECK(h.positions[2 * hv] >= 0);
  for (Index v = 0; v < d.topo.num_vertices; ++v) CHECK(std::hypot(h.positions[2 * v], h.positions[2 * v + 1]) < 1);
  // The propagation runs again in the normalised frame (at most 4 times, until the frame moves by
  // less than 1e-6), also from a seed at the disk's edge; without the normalisation it runs once.
  CHECK(h.propagation_passes >= 1);
  CHECK(h.propagation_passes <= 4);
  LayoutOptions off = o;
  off.unit_box = false;
  off.seed_face = h.seed_face == 0 ? d.topo.num_faces - 1 : 0;
  const Layout hf = layout_disk(d.topo, Geometry::Hyperbolic, lh, off);
  REQUIRE(hf.status == Status::Ok);
  CHECK(hf.propagation_passes >= 1);
  CHECK(hf.propagation_passes <= 4);
  CHECK(hf.centre_of_mass < 1e-12);
  off.normalize = false;
  CHECK(layout_disk(d.topo, Geometry::Hyperbolic, lh, off).propagation_passes == 0);
  // S: isometric (rotation only) vs Möbius-centred.
  const Uniformized s = load_uniformized(ricci_test::fixtures_dir() / "icosphere.obj");
  LayoutOptions so;
  so.sphere_mobius = false;
  const Layout iso = layout_sphere(s.topo, s.flow.l, so);
  REQUIRE(iso.status == Status::Ok);
  CHECK(iso.mobius_length_change == 0);
  CHECK(iso.max_edge_length_error < 1e-9);
  const Layout mob = layout_sphere(s.topo, s.flow.l);
  REQUIRE(mob.status == Status::Ok);
  CHECK(mob.centre_of_mass < 1e-12);
  CHECK(mob.normalization_iterations >= 0);
  CHECK(mob.flipped_faces == 0);
  for (Index v = 0; v < s.topo.num_vertices; ++v) {
    const double n = std::hypot(mob.positions[3 * v], mob.positions[3 * v + 1], mob.positions[3 * v + 2]);
    CHECK(std::abs(n - 1) < 1e-14);
  }
  const Index sv = s.topo.corner_vertex[3 * mob.seed_face];
  CHECK(mob.positions[3 * sv + 2] == doctest::Approx(1).epsilon(1e-14));
  // A layout far from centred gets centred: push the isometric one by a Möbius map first.
  MESSAGE("icosphere Möbius centring: " << mob.normalization_iterations << " steps, length change "
                                        << mob.mobius_length_change);
}

TEST_CASE("layout: H develops long edges far out from a seed on the rim to its rounding floor") {
  // A disk realized in the Poincaré disk out to |z| = 0.995 (a flat disk's vertices scaled), its
  // lengths the exact hyperbolic distances of those points, the rim's edges 1.5–2.6 long. Laid
  // out from a face on the rim, the far side lies ~12 units out (1 − |z|² ≈ 2e-5). Faces whose
  // directions were measured from their stored neighbours grew each error by about sinh of the
  // edge length along the rim (0.026 there; from the central face 6e-14); frames carried from
  // the parent faces alone, and the map into the normalised frame in double-double, stay within
  // a few times the rounding floor.
  const Mesh m = ricci_shapes::disk(60);
  const TopologyResult tr = build_topology(m.faces, m.num_vertices());
  REQUIRE(tr.status == Status::Ok);
  const Topology& t = tr.topology;
  std::vector<std::complex<long double>> z(static_cast<std::size_t>(t.num_vertices));
  for (Index v = 0; v < t.num_vertices; ++v) z[v] = {0.995L * m.positions[3 * v], 0.995L * m.positions[3 * v + 1]};
  std::vector<double> l(static_cast<std::size_t>(t.num_edges));
  for (Index e = 0; e < t.num_edges; ++e) {
    const auto a = z[t.edge_vertices[2 * e]], b = z[t.edge_vertices[2 * e + 1]];
    const long double ra = 1 - std::norm(a), rb = 1 - std::norm(b);
    l[e] = static_cast<double>(2 * std::asinh(std::abs(a - b) / std::sqrt(ra * rb)));
  }
  CHECK(*std::max_element(l.begin(), l.end()) > 2.5);
  LayoutOptions o;
  o.patches = 0;
  o.polish_sweeps = 0;
  o.polish_steps = 0;
  const Layout central = layout_disk(t, Geometry::Hyperbolic, l, o);
  o.seed_face = t.num_faces - 1;  // on the outer ring
  const Layout rim = layout_disk(t, Geometry::Hyperbolic, l, o);
  o.normalize = false;  // the development in the rim seed's own frame
  const Layout raw = layout_disk(t, Geometry::Hyperbolic, l, o);
  REQUIRE(central.status == Status::Ok);
  REQUIRE(rim.status == Status::Ok);
  REQUIRE(raw.status == Status::Ok);
  MESSAGE("central seed " << central.max_edge_length_error << " (floor " << central.rounding_floor << "), rim seed "
                          << rim.max_edge_length_error << " (floor " << rim.rounding_floor << "), in its own frame "
                          << raw.max_edge_length_error << " (floor " << raw.rounding_floor << ")");
  CHECK(rim.propagation_passes >= 1);
  CHECK(rim.centre_of_mass < 1e-12);
  CHECK(central.max_edge_length_error < 1e-12);
  CHECK(rim.max_edge_length_error < 1e-11);
  CHECK(raw.max_edge_length_error < 4 * raw.rounding_floor);
}

TEST_CASE("layout: resolved_vertices marks the vertices of edges that miss their length, in E and H") {
  for (const char* name : {"torus.obj", "genus2.obj"}) {
    CAPTURE(name);
    const Uniformized u = load_uniformized(ricci_test::fixtures_dir() / name);
    const Disk d = cut_disk(u);
    const Layout base = lay_out(u, &d, -1, false);
    REQUIRE(base.status == Status::Ok);
    const Index nv = d.topo.num_vertices;
    std::vector<std::uint8_t> ok = resolved_vertices(d.topo, u.geometry, d.l, base.positions, 1e-9);
    REQUIRE(ok.size() == static_cast<std::size_t>(nv));
    CHECK(std::count(ok.begin(), ok.end(), 1) == nv);
    // One vertex moved by a tenth of its shortest edge: it and its neighbours, nothing else.
    const Index w = nv / 3;
    std::vector<double> x = base.positions;
    double shortest = std::numeric_limits<double>::infinity();
    std::vector<std::uint8_t> near(static_cast<std::size_t>(nv), 0);
    near[w] = 1;
    for (Index e = 0; e < d.topo.num_edges; ++e) {
      const Index a = d.topo.edge_vertices[2 * e], b = d.topo.edge_vertices[2 * e + 1];
      if (a != w && b != w) continue;
      near[a] = near[b] = 1;
      shortest = std::min(shortest, std::hypot(x[2 * a] - x[2 * b], x[2 * a + 1] - x[2 * b + 1]));
    }
    x[2 * w] += 0.1 * shortest;
    ok = resolved_vertices(d.topo, u.geometry, d.l, x, 1e-9);
    for (Index v = 0; v < nv; ++v) CHECK(ok[v] == 1 - near[v]);
    // The limit decides: a move of 1e-3 of the shortest edge changes no edge by 1e-1 of its length.
    x = base.positions;
    x[2 * w] += 1e-3 * shortest;
    ok = resolved_vertices(d.topo, u.geometry, d.l, x, 1e-1);
    CHECK(std::count(ok.begin(), ok.end(), 1) == nv);
    // Sizes that do not match: nothing resolved.
    ok = resolved_vertices(d.topo, u.geometry, d.l, std::vector<double>(x.begin(), x.end() - 2), 1e-9);
    CHECK(std::count(ok.begin(), ok.end(), 0) == nv);
  }
}

TEST_CASE("layout: alignment recovers known isometries") {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int trial = 0; trial < 5; ++trial) {
    CAPTURE(trial);
    const Index n = 50;
    // E
    std::vector<double> a(2 * n), b(2 * n);
    for (double& x : a) x = 3 * U(rng);
    const double ang = kPi * U(rng), tx = U(rng), ty = U(rng);
    for (Index v = 0; v < n; ++v) {
      const double x = a[2 * v], y = a[2 * v + 1];
      b[2 * v] = std::cos(ang) * x - std::sin(ang) * y + tx;
      b[2 * v + 1] = std::sin(ang) * x + std::cos(ang) * y + ty;
    }
    LayoutAlignment r = align_layouts(Geometry::Euclidean, a, b);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.max_deviation < 1e-13);
    CHECK(std::abs(std::remainder(r.angle + ang, 2 * kPi)) < 1e-13);
    b[0] += 1e-3;
    CHECK(align_layouts(Geometry::Euclidean, a, b).max_deviation > 1e-4);
    // H
    using Cx = std::complex<double>;
    const Cx z0(0.6 * U(rng), 0.6 * U(rng));
    const Cx rot = std::polar(1.0, kPi * U(rng));
    for (Index v = 0; v < n; ++v) {
      Cx z(0.7 * U(rng), 0.7 * U(rng));
      if (std::abs(z) > 0.9) z *= 0.5;
      a[2 * v] = z.real();
      a[2 * v + 1] = z.imag();
      const Cx w = rot * (z - z0) / (1.0 - std::conj(z0) * z);
      b[2 * v] = w.real();
      b[2 * v + 1] = w.imag();
    }
    // b = M(a): fit takes b onto a, i.e. M⁻¹; applying it to b gives a; check against a fit of the reverse.
    r = align_layouts(Geometry::Hyperbolic, b, a);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.max_deviation < 1e-12);
    CHECK(std::abs(r.translation[0] - z0.real()) < 1e-12);
    CHECK(std::abs(r.translation[1] - z0.imag()) < 1e-12);
    CHECK(std::abs(std::remainder(r.angle - std::arg(rot), 2 * kPi)) < 1e-12);
    // A rotation about the origin: the fitted z0 is rounding (1e-17), and the angle is still the
    // rotation's (it was taken as arg(−M(0)/z0), a ratio of two roundings: an atlas's chart and
    // its parent both holding their collar at the origin were fitted 4.3° apart).
    for (Index v = 0; v < n; ++v) {
      const Cx w = rot * Cx(a[2 * v], a[2 * v + 1]);
      b[2 * v] = w.real();
      b[2 * v + 1] = w.imag();
    }
    r = align_layouts(Geometry::Hyperbolic, b, a);
    REQUIRE(r.status == Status::Ok);
    CHECK(std::hypot(r.translation[0], r.translation[1]) < 1e-15);
    CHECK(std::abs(std::remainder(r.angle - std::arg(rot), 2 * kPi)) < 1e-13);
    // S
    std::vector<double> p(3 * n), q(3 * n);
    for (Index v = 0; v < n; ++v) {
      double x[3] = {U(rng), U(rng), U(rng)};
      const double nn = std::hypot(x[0], x[1], x[2]);
      for (int k = 0; k < 3; ++k) p[3 * v + k] = x[k] / nn;
    }
    const double ax = U(rng), c = std::cos(ax), s = std::sin(ax);
    for (Index v = 0; v < n; ++v) {  // rotation about (0, 0, 1) then swap axes (det −1 · −1 = +1)
      const double x = p[3 * v], y = p[3 * v + 1], z = p[3 * v + 2];
      q[3 * v] = c * x - s * y;
      q[3 * v + 1] = z;
      q[3 * v + 2] = -(s * x + c * y);
    }
    r = align_layouts(Geometry::Spherical, p, q);
    REQUIRE(r.status == Status::Ok);
    CHECK(r.max_deviation < 1e-13);
    double det = 0;
    const double* R = r.rotation;
    det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) + R[2] * (R[3] * R[7] - R[4] * R[6]);
    CHECK(det == doctest::Approx(1).epsilon(1e-13));
  }
}

namespace {

/// Long propagations: E, a fine torus cut open; H, a genus-2 pretzel's compact domain.
struct LongCase {
  std::string name;
  Uniformized u;
  Disk d;
};

std::vector<LongCase> long_propagation_cases() {
  std::vector<LongCase> out;
  for (auto [name, mesh] : {std::pair<std::string, Mesh>{"torus 160x80", ricci_shapes::torus(160, 80, 3.0, 1.0)},
                            std::pair<std::string, Mesh>{"pretzel(2, 8)", ricci_shapes::pretzel(2, 8)}}) {
    INFO(name);
    const TopologyResult tr = build_topology(mesh.faces, mesh.num_vertices());
    REQUIRE(tr.status == Status::Ok);
    LongCase c{name, uniformize(mesh, tr.topology), {}};
    REQUIRE_MESSAGE(c.u.flow.status == Status::Ok, c.u.flow.message);
    if (c.u.geometry == Geometry::Euclidean) {
      c.d = cut_disk(c.u);
    } else {
      c.d.cut = cut_compact(c.u.mesh, c.u.topo, c.u.flow.l);
      REQUIRE_MESSAGE(c.d.cut.status == Status::Ok, c.d.cut.message);
      const TopologyResult dt = build_topology(c.d.cut.cut_faces, c.d.cut.num_cut_vertices());
      REQUIRE(dt.status == Status::Ok);
      c.d.topo = dt.topology;
      c.d.refined = refined_edge_lengths(c.d.cut, c.u.topo, c.u.geometry, c.u.flow.l);
      REQUIRE(c.d.refined.status == Status::Ok);
      c.d.l = disk_edge_lengths(c.d.cut, c.d.refined.surface, c.d.refined.l, c.d.topo);
    }
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace

TEST_CASE("layout: divide and conquer matches the metric, the single propagation and its own seams") {
  for (const LongCase& lc : long_propagation_cases()) {
    const Uniformized& u = lc.u;
    const Disk& d = lc.d;
    const std::string& name = lc.name;
    INFO(name);
    LayoutOptions single;
    single.patches = 0;
    single.polish_sweeps = 0;
    single.polish_steps = 0;  // the patches alone (the global steps are tested in test_layout_polish)
    LayoutOptions split = single;
    split.patches = 12;
    const Layout a = layout_disk(d.topo, u.geometry, d.l, single);
    const Layout b = layout_disk(d.topo, u.geometry, d.l, split);
    REQUIRE(a.status == Status::Ok);
    REQUIRE_MESSAGE(b.status == Status::Ok, b.message);
    CHECK(a.patches == 0);
    CHECK(b.patches == 12);  // kept: not worse than the single propagation
    CHECK(b.patch_fit_iterations > 0);
    CHECK(b.max_edge_length_error <= a.max_edge_length_error);
    // E: far below the 1e-9 bound. H: the single propagation's error grows along its depth
    // (Newton's residual curvature, ≈1e-13 here, amplified by the hyperbolic plane's divergence);
    // patches cut the depth, and the error by a factor of 9 on this domain.
    if (u.geometry == Geometry::Euclidean) CHECK(b.max_edge_length_error < 1e-11);
    else CHECK(b.max_edge_length_error < 0.25 * a.max_edge_length_error);
    CHECK(b.max_edge_length_error < 1e-9);
    CHECK(b.patch_seam_error < 1e-9);
    CHECK(b.flipped_faces == 0);
    CHECK(b.unplaced_vertices == 0);
    CHECK(layout_alignment_error(u.geometry, a.positions, b.positions) < 1e-9);
    if (u.geometry == Geometry::Hyperbolic) CHECK(b.centre_of_mass < 1e-9);
    MESSAGE(name << ": " << d.topo.num_faces << " faces, single propagation " << a.max_edge_length_error
                   << ", 12 patches " << b.max_edge_length_error << " (seams " << b.patch_seam_error << ", "
                   << b.patch_fit_iterations << " Ceres iterations), rounding floor " << b.rounding_floor);
    // More patches than faces: one patch per face at most, still exact.
    if (d.topo.num_faces < 256) {
      LayoutOptions many = single;
      many.patches = 256;
      const Layout m = layout_disk(d.topo, u.geometry, d.l, many);
      REQUIRE(m.status == Status::Ok);
      CHECK(m.max_edge_length_error < 1e-9);
    }
  }
  LayoutOptions bad;
  bad.patches = 257;
  std::string why;
  CHECK_FALSE(bad.is_valid(&why));
  CHECK(why.find("patches") != std::string::npos);
  bad.patches = -2;
  CHECK_FALSE(bad.is_valid(nullptr));
}

TEST_CASE("layout: divide and conquer on the sphere: rotations fitted over the seams, deterministic") {
  // A squashed sphere (20k faces): its spherical metric is far from the input's, and one
  // propagation over it is 20 faces deep and more.
  const Mesh mesh = ricci_shapes::pancake(5, 0.35);
  const TopologyResult tr = build_topology(mesh.faces, mesh.num_vertices());
  REQUIRE(tr.status == Status::Ok);
  const Uniformized u = uniformize(mesh, tr.topology);
  REQUIRE(u.geometry == Geometry::Spherical);
  LayoutOptions single;
  single.patches = 0;
  single.polish_sweeps = 0;
  single.polish_steps = 0;
  single.sphere_mobius = false;  // isometric: the edge error is that of the positions compared
  LayoutOptions split = single;
  split.patches = 12;
  const Layout a = layout_sphere(u.topo, u.flow.l, single);
  REQUIRE(a.status == Status::Ok);
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const Layout one = layout_sphere(u.topo, u.flow.l, split);
  omp_set_num_threads(2);
  const Layout b = layout_sphere(u.topo, u.flow.l, split);
  omp_set_num_threads(saved);
  REQUIRE_MESSAGE(b.status == Status::Ok, b.message);
  CHECK(one.positions == b.positions);  // patches laid out in parallel, gathered in order
  CHECK(a.patches == 0);
  CHECK(b.patches == 12);  // kept: not worse than the single propagation
  CHECK(b.patch_fit_iterations > 0);
  CHECK(b.max_edge_length_error <= a.max_edge_length_error);
  CHECK(b.max_edge_length_error < 1e-11);
  CHECK(b.patch_seam_error < 1e-10);
  CHECK(b.flipped_faces == 0);
  CHECK(b.unplaced_vertices == 0);
  CHECK(layout_alignment_error(Geometry::Spherical, a.positions, b.positions) < 1e-10);
  for (Index v = 0; v < u.topo.num_vertices; ++v)
    CHECK(std::abs(std::hypot(b.positions[3 * v], b.positions[3 * v + 1], b.positions[3 * v + 2]) - 1) < 1e-14);
  MESSAGE("pancake sphere: " << u.topo.num_faces << " faces, single propagation " << a.max_edge_length_error
                             << ", 12 patches " << b.max_edge_length_error << " (seams " << b.patch_seam_error
                             << ", " << b.patch_fit_iterations << " Ceres iterations)");
}

TEST_CASE("layout: refinement only above refine_above, the same on 1 and 2 threads, H breadth-first") {
  for (const LongCase& lc : long_propagation_cases()) {
    const Uniformized& u = lc.u;
    const Disk& d = lc.d;
    const std::string& name = lc.name;
    INFO(lc.name);
    LayoutOptions bare, lax, strict;
    bare.patches = 0;
    bare.polish_sweeps = 0;
    bare.polish_steps = 0;
    lax.refine_above = 1;  // every propagation is within 1 of its floor: nothing runs
    strict.refine_above = 0;
    const Layout b = layout_disk(d.topo, u.geometry, d.l, bare);
    const Layout x = layout_disk(d.topo, u.geometry, d.l, lax);
    REQUIRE(b.status == Status::Ok);
    REQUIRE(x.status == Status::Ok);
    CHECK(x.positions == b.positions);  // bit for bit: the propagation alone
    CHECK(x.patches == 0);
    CHECK(x.polish_sweeps == 0);
    CHECK(x.polish_steps == 0);
    REQUIRE(b.max_error_above_rounding > 0);  // so that the strict layout has something to refine
    CHECK(b.seed_face == central_face(d.topo));  // the default seed, public for the seed check
    const int saved = omp_get_max_threads();
    Layout one, two;
    omp_set_num_threads(1);
    one = layout_disk(d.topo, u.geometry, d.l, strict);
    omp_set_num_threads(2);
    two = layout_disk(d.topo, u.geometry, d.l, strict);
    omp_set_num_threads(saved);
    REQUIRE(one.status == Status::Ok);
    REQUIRE(two.status == Status::Ok);
    CHECK(one.positions == two.positions);  // patches laid out in parallel, gathered in order
    CHECK(one.worst_edge == two.worst_edge);
    const Index nf = d.topo.num_faces;
    const auto automatic = static_cast<int>(std::min<Index>(256, std::max<Index>(std::min<Index>(32, nf / 4000), nf / 10000)));
    // The automatic patches are tried after at most 7 local sweeps and kept when not less accurate
    // (from a swept start they may not be): then the strict layout is no worse than one that keeps
    // them by an explicit count, or within its rounding floor.
    CHECK((one.patches == 0 || one.patches == automatic));
    if (automatic > 1 && one.patches == 0) {
      LayoutOptions forced = strict;
      forced.patches = automatic;
      const Layout p = layout_disk(d.topo, u.geometry, d.l, forced);
      REQUIRE(p.status == Status::Ok);
      CHECK(one.max_edge_length_error <= std::max(p.max_edge_length_error, one.rounding_floor));
      MESSAGE(name << ": strict without the patches " << one.max_edge_length_error << ", with " << automatic
                   << " patches " << p.max_edge_length_error << " (" << p.patches << " kept)");
    }
    CHECK(one.max_edge_length_error <= b.max_edge_length_error);
    if (u.geometry == Geometry::Euclidean) CHECK(one.polish_sweeps == 30);
    // The default: refined exactly when the propagation is more than 1e-10 above its floor.
    const Layout def = layout_disk(d.topo, u.geometry, d.l, LayoutOptions{});
    REQUIRE(def.status == Status::Ok);
    const bool refined = def.patches > 0 || def.polish_sweeps > 0 || def.polish_steps > 0 || def.shape_solve;
    CHECK(refined == (b.max_error_above_rounding > 1e-10));
    if (!refined) CHECK(def.max_error_above_rounding <= 1e-10);
    MESSAGE(name << ": propagation " << b.max_edge_length_error << " (floor " << b.rounding_floor << "), default "
                   << def.max_edge_length_error << std::string(refined ? " refined" : " as propagated") << ", strict "
                   << one.max_edge_length_error);
    // H costs every face 1: the propagation is breadth-first, its depth the seed's dual eccentricity.
    if (u.geometry == Geometry::Hyperbolic) {
      std::vector<Index> dist(static_cast<std::size_t>(d.topo.num_faces), -1), queue{b.seed_face};
      dist[b.seed_face] = 0;
      Index far = 0;
      for (std::size_t h = 0; h < queue.size(); ++h) {
        const Index f = queue[h];
        far = std::max(far, dist[f]);
        for (int k = 0; k < 3; ++k) {
          const Index o = d.topo.opposite[3 * f + k];
          if (o == kInvalid || dist[o / 3] >= 0) continue;
          dist[o / 3] = dist[f] + 1;
          queue.push_back(o / 3);
        }
      }
      CHECK(b.depth == far);
    }
  }
  LayoutOptions bad;
  bad.refine_above = -1;
  std::string why;
  CHECK_FALSE(bad.is_valid(&why));
  CHECK(why.find("refine_above") != std::string::npos);
  bad.refine_above = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(bad.is_valid(nullptr));
}

TEST_CASE("layout: one propagation gives the same positions on 1 and 3 threads in E, H and S") {
  // Large enough that the propagation's buckets (breadth-first levels here) hold more than the
  // 512 faces above which each is developed in parallel: a disk of 153k faces (E; H: the same
  // disk shrunk to radius 0.8 in the Poincaré disk) and an icosphere of 328k faces (S).
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical}) {
    CAPTURE(static_cast<int>(g));
    const Mesh m = g == Geometry::Spherical ? ricci_shapes::icosphere(7) : ricci_shapes::disk(160);
    const TopologyResult tr = build_topology(m.faces, m.num_vertices());
    REQUIRE(tr.status == Status::Ok);
    const Topology& t = tr.topology;
    std::vector<double> l;
    for (Index e = 0; e < t.num_edges; ++e) {
      const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
      const double* p = &m.positions[3 * static_cast<std::size_t>(a)];
      const double* q = &m.positions[3 * static_cast<std::size_t>(b)];
      if (g == Geometry::Euclidean) {
        l.push_back(std::hypot(p[0] - q[0], p[1] - q[1]));
      } else if (g == Geometry::Hyperbolic) {
        l.push_back(model::disk_distance({0.8 * p[0], 0.8 * p[1]}, {0.8 * q[0], 0.8 * q[1]}));
      } else {
        const double np = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        const double nq = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        l.push_back(model::sphere_distance({p[0] / np, p[1] / np, p[2] / np}, {q[0] / nq, q[1] / nq, q[2] / nq}));
      }
    }
    REQUIRE(t.num_faces > 80000);
    LayoutOptions bare;
    bare.patches = 0;
    bare.polish_sweeps = 0;
    bare.polish_steps = 0;
    const int saved = omp_get_max_threads();
    omp_set_num_threads(1);
    const Layout one = g == Geometry::Spherical ? layout_sphere(t, l, bare) : layout_disk(t, g, l, bare);
    omp_set_num_threads(3);
    const Layout three = g == Geometry::Spherical ? layout_sphere(t, l, bare) : layout_disk(t, g, l, bare);
    omp_set_num_threads(saved);
    REQUIRE(one.status == Status::Ok);
    REQUIRE(three.status == Status::Ok);
    CHECK(one.positions == three.positions);
    CHECK(one.depth == three.depth);
    CHECK(one.max_edge_length_error <= 1e-9);
    // Levels of over 450 faces on average; they grow with the distance from the seed, the largest
    // about twice the average on the disk and π/2 times on the sphere.
    CHECK(t.num_faces > 450 * (one.depth + 1));
    MESSAGE("depth " << one.depth << " over " << t.num_faces << " faces, max edge-length error "
                     << one.max_edge_length_error);
  }
}

TEST_CASE("layout: bad input gives a status naming the element, never NaN") {
  const Mesh m = ricci_shapes::disk(4);
  const TopologyResult tr = build_topology(m.faces, m.num_vertices());
  REQUIRE(tr.status == Status::Ok);
  const Topology& t = tr.topology;
  std::vector<double> l(static_cast<std::size_t>(t.num_edges), 0.1);
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical}) {
    INFO(geometry_name(g));
    Layout r = layout_disk(t, g, l);
    REQUIRE(r.status == Status::Ok);
    if (g == Geometry::Euclidean) {  // equilateral and valence 6 inside: flat only in E
      CHECK(r.max_edge_length_error < 1e-12);
      CHECK(r.flipped_faces == 0);
    }
    r = layout_disk(t, g, std::span<const double>(l.data(), l.size() - 1));
    CHECK(r.status == Status::InvalidArgument);
    CHECK(r.positions.empty());
    for (double bad : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
      std::vector<double> lb = l;
      lb[7] = bad;
      r = layout_disk(t, g, lb);
      CHECK(r.status == Status::DegenerateFace);
      CHECK(r.element == Element::Edge);
      CHECK(r.element_index == 7);
      CHECK(r.message.find("edge 7") != std::string::npos);
      CHECK(r.positions.empty());
    }
    std::vector<double> lt = l;
    lt[t.corner_edge[3 * 5]] = 0.25;  // face 5: 0.25 > 0.1 + 0.1
    r = layout_disk(t, g, lt);
    CHECK(r.status == Status::TriangleInequality);
    CHECK(r.element == Element::Face);
    CHECK(r.message.find("face") != std::string::npos);
    CHECK(r.positions.empty());
    LayoutOptions o;
    o.seed_face = t.num_faces;
    CHECK(layout_disk(t, g, l, o).status == Status::InvalidArgument);
    o.seed_face = -2;
    CHECK(layout_disk(t, g, l, o).status == Status::InvalidArgument);
  }
  // Spherical: perimeter ≥ 2π, lengths ≥ π.
  std::vector<double> ls(static_cast<std::size_t>(t.num_edges), 2.2);
  Layout r = layout_disk(t, Geometry::Spherical, ls);
  CHECK(r.status == Status::TriangleInequality);
  ls.assign(ls.size(), 3.2);
  CHECK(layout_disk(t, Geometry::Spherical, ls).status == Status::DegenerateFace);
  // Wrong topology.
  const Mesh tor = ricci_shapes::torus(8, 6, 2.0, 0.7);
  const TopologyResult tt = build_topology(tor.faces, tor.num_vertices());
  REQUIRE(tt.status == Status::Ok);
  const std::vector<double> lt(static_cast<std::size_t>(tt.topology.num_edges), 0.1);
  r = layout_disk(tt.topology, Geometry::Euclidean, lt);
  CHECK(r.status == Status::InvalidArgument);
  CHECK(r.message.find("disk") != std::string::npos);
  CHECK(layout_sphere(tt.topology, lt).status == Status::InvalidArgument);
  CHECK(layout_sphere(t, l).status == Status::InvalidArgument);
  CHECK(layout_disk(Topology{}, Geometry::Euclidean, {}).status == Status::InvalidArgument);
  // Refined lengths: wrong sizes, bad values, a cut that did not run.
  const CutResult cut = cut_surface(tor, tt.topology);
  REQUIRE(cut.status == Status::Ok);
  CHECK(refined_edge_lengths(cut, tt.topology, Geometry::Euclidean, std::vector<double>(3, 1.0)).status ==
        Status::InvalidArgument);
  std::vector<double> lb = lt;
  lb[3] = std::numeric_limits<double>::quiet_NaN();
  const RefinedMetric rb = refined_edge_lengths(cut, tt.topology, Geometry::Euclidean, lb);
  CHECK(rb.status == Status::DegenerateFace);
  CHECK(rb.element_index == 3);
  CHECK(rb.l.empty());
  CHECK(refined_edge_lengths(CutResult{}, tt.topology, Geometry::Euclidean, lt).status == Status::InvalidArgument);
  CHECK(refined_edge_lengths(cut, t, Geometry::Euclidean, l).status == Status::InvalidArgument);
  CHECK(disk_edge_lengths(cut, tt.topology, std::vector<double>(2, 1.0), tt.topology).empty());
  // Alignment: sizes, points outside the model.
  const std::vector<double> p2 = {0.1, 0.2, 0.3, 0.4}, p3 = {0.1, 0.2};
  CHECK(align_layouts(Geometry::Euclidean, p2, p3).status == Status::InvalidArgument);
  CHECK(std::isinf(layout_alignment_error(Geometry::Euclidean, p2, p3)));
  CHECK(align_layouts(Geometry::Hyperbolic, p2, std::vector<double>{0.1, 0.2, 1.3, 0.4}).status ==
        Status::InvalidArgument);
  CHECK(align_layouts(Geometry::Spherical, std::vector<double>{1, 0, 0}, std::vector<double>{2, 0, 0}).status ==
        Status::InvalidArgument);
  CHECK(align_layouts(Geometry::Euclidean, p2, std::vector<double>{0.1, std::nan(""), 0.3, 0.4}).status ==
        Status::InvalidArgument);
}

TEST_CASE("layout: shared real meshes (figures per mesh)") {
  const fs::path root = ricci_test::shared_meshes_dir();
  if (root.empty()) {
    MESSAGE("skipped: ../shared/meshes is absent");
    return;
  }
#ifdef NDEBUG
  const Index max_faces = 20000;  // larger ones (camelhead, rocker-arm, cup) pass too but cost ~10 s
#else
  const Index max_faces = 3000;
#endif
  ricci_test::for_each_shared_mesh({"genus0", "genus1", "genus2", "genus3plus", "boundary"}, [&](const fs::path& p) {
    const LoadResult lr = load_mesh(p.string());
    if (lr.status != Status::Ok || lr.validated.topology.num_faces > max_faces) return;
    const auto t0 = std::chrono::steady_clock::now();
    const Uniformized u = uniformize(lr.validated.mesh, lr.validated.topology);
    if (u.flow.status != Status::Ok && u.flow.status != Status::NotConverged) {
      MESSAGE(p.filename().string() << ": flow " << u.flow.brief_report() << " — no layout");
      return;
    }
    const bool sphere = u.topo.is_closed() && u.topo.euler_characteristic() == 2;
    Disk d;
    if (!sphere) d = cut_disk(u);
    const Disk* dp = sphere ? nullptr : &d;
    const Layout base = lay_out(u, dp, -1, false);
    REQUIRE_MESSAGE(base.status == Status::Ok, base.message);
    const Layout other = lay_out(u, dp, 0, false);
    REQUIRE(other.status == Status::Ok);
    const double seed_error = layout_alignment_error(u.geometry, base.positions, other.positions);
    MESSAGE(p.filename().string() << ": F " << u.topo.num_faces << ", " << geometry_name(u.geometry)
                                  << ", curvature error " << u.flow.max_curvature_error << ", "
                                  << base.brief_report() << ", rounding floor " << base.rounding_floor
                                  << "; seed face 0: edge error "
                                  << other.max_edge_length_error << ", flips " << other.flipped_faces
                                  << "; seed independence " << seed_error << "; total " << seconds_since(t0)
                                  << " s");
    CHECK(base.unplaced_vertices == 0);
    CHECK(base.flipped_faces == 0);
    CHECK(other.flipped_faces == 0);
    // < 1e-9 wherever double-precision coordinates can hold it (see Layout::rounding_floor).
    CHECK(base.max_edge_length_error < std::max(1e-9, 8 * base.rounding_floor));
    CHECK(other.max_edge_length_error < std::max(1e-9, 8 * other.rounding_floor));
  });
}

TEST_CASE("layout: a face flat to the rounding of its lengths is laid out flat, a real violation refused") {
  // A (0,0), B (1,0), C (2,0), D (1,1): faces ABD, BCD and the flat face BAC, whose lengths
  // 1, 1, 2 meet the triangle inequality with equality — a sliver of a common subdivision whose
  // lengths come from crossings can be flat to the last bit. Beyond 4 units in the last place it
  // is a violation.
  const std::vector<Index> faces = {0, 1, 3, 1, 2, 3, 1, 0, 2};
  const TopologyResult tr = build_topology(faces, 4);
  REQUIRE(tr.status == Status::Ok);
  const Topology& t = tr.topology;
  REQUIRE(t.num_boundary_loops() == 1);
  const double xy[4][2] = {{0, 0}, {1, 0}, {2, 0}, {1, 1}};
  std::vector<double> l(static_cast<std::size_t>(t.num_edges));
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index u = t.edge_vertices[2 * e], w = t.edge_vertices[2 * e + 1];
    l[e] = std::hypot(xy[u][0] - xy[w][0], xy[u][1] - xy[w][1]);
  }
  const Layout r = layout_disk(t, Geometry::Euclidean, l);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(r.max_edge_length_error < 1e-14);
  for (double v : r.positions) CHECK(std::isfinite(v));
  // AC longer by 1e-12: the flat face violates the triangle inequality by far more than rounding.
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index u = t.edge_vertices[2 * e], w = t.edge_vertices[2 * e + 1];
    if ((u == 0 && w == 2) || (u == 2 && w == 0)) l[e] = 2 + 1e-12;
  }
  const Layout bad = layout_disk(t, Geometry::Euclidean, l);
  CHECK(bad.status == Status::TriangleInequality);
  CHECK(bad.element == Element::Face);
}

TEST_CASE("model geometry: the hyperbolic distance of close points comes from their spatial parts, not their rounded time coordinates") {
  // Two corners of a sliver of a common subdivision (random sweep draw 34), in their coarse
  // face's model frame near the pole: 1.2e-12 apart, their stored time coordinates one unit in
  // the last place apart while the true difference is about 2.6e-20. The distance from the
  // stored difference was 1.6e-8 of itself off (the reference: the same spatial parts with exact
  // time coordinates; their Poincaré projections with the stored ones, as the layout places them,
  // are within 2.1e-12 of it; the old formula gave 1.2285104951624855e-12).
  const model::P3 p{2.173182196825596e-08, 6.7497698878464093e-09, 1.0000000000000004};
  const model::P3 q{2.1730648744650293e-08, 6.7494054918295069e-09, 1.0000000000000002};
  const double reference = 1.2285105152289828e-12;  // these doubles' spatial parts, exact time coordinates (50 digits)
  const double d = model::distance(Geometry::Hyperbolic, p, q);
  CHECK(std::abs(d - reference) / reference < 1e-14);
  auto disk = [](const model::P3& x) { return std::complex<double>(x[0], x[1]) / (1 + x[2]); };
  const double projected = model::disk_distance(disk(p), disk(q));
  CHECK(std::abs(d - projected) / projected < 1e-11);
  // Far from the pole and far apart the two agree with the Lorentz product too.
  const model::P3 a = model::polar(Geometry::Hyperbolic, 3.0, 0.4), b = model::polar(Geometry::Hyperbolic, 2.5, 1.9);
  const double cosh_d = -model::lorentz(a, b);
  CHECK(model::distance(Geometry::Hyperbolic, a, b) == doctest::Approx(std::acosh(cosh_d)).epsilon(1e-13));
}

TEST_CASE("model geometry: a development step that rounding leaves without a direction says so, never NaN") {
  // A regular step in each geometry: at distance r from p, at the angle asked from the way to q.
  for (Geometry g : {Geometry::Euclidean, Geometry::Hyperbolic, Geometry::Spherical}) {
    CAPTURE(geometry_name(g));
    const model::P3 p = model::polar(g, 0.3, 0.2), q = model::polar(g, 0.7, 1.1);
    model::P3 x{};
    REQUIRE(model::turn_and_walk(g, p, q, 0.9, 0.25, x));
    CHECK(model::distance(g, p, x) == doctest::Approx(0.25).epsilon(1e-13));
    // p and q equal: no direction; the output is left as it was.
    model::P3 kept{7, 7, 7};
    CHECK_FALSE(model::turn_and_walk(g, p, p, 0.9, 0.25, kept));
    CHECK(kept == model::P3{7, 7, 7});
  }
  // Far out on the hyperboloid (30–40 from the pole) two points a hair apart: the tangent's
  // Lorentz norm cancels to zero or below for most pairs (it was a square root of a negative
  // number, straightening an input edge on random draw 32 of the sweep); the others give a finite
  // point on the hyperboloid.
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(0, 1);
  int refused = 0;
  for (int i = 0; i < 500; ++i) {
    const double r = 30 + 10 * uniform(rng), phi = 6.28 * uniform(rng);
    const model::P3 p = model::polar(Geometry::Hyperbolic, r, phi);
    const model::P3 q =
        model::polar(Geometry::Hyperbolic, r + std::pow(10.0, -12 * uniform(rng)), phi + std::pow(10.0, -16 * uniform(rng)));
    model::P3 x{7, 7, 7};
    if (!model::turn_and_walk(Geometry::Hyperbolic, p, q, 1.0, 0.5, x)) {
      ++refused;
      CHECK(x == model::P3{7, 7, 7});
      continue;
    }
    CHECK((std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]) && x[2] >= 1));
  }
  CHECK(refused > 0);
  CHECK(model::within_reach(model::polar(Geometry::Hyperbolic, 300, 0.5)));
  CHECK_FALSE(model::within_reach(model::polar(Geometry::Hyperbolic, 400, 0.5)));
}
