// The whole job as a library call (uniformize.h): every fixture uniformizes with the accuracy the
// stages promise; lay_out_metric() on the flow's own lengths reproduces the layout; stage
// failures name their stage and keep what ran before; angle distortion is measured per corner.
#include <doctest/doctest.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "ricci/cut.h"
#include "ricci/deck.h"
#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

using namespace ricci;
namespace fs = std::filesystem;

TEST_CASE("uniformize: every fixture, stage by stage, with the promised accuracy") {
  ricci_test::for_each_fixture([&](const ricci_test::fs::path& p) {
    const LoadResult lr = load_mesh(p.string());
    REQUIRE(lr.status == Status::Ok);
    const Topology& t = lr.validated.topology;
    std::vector<std::string> stages;
    UniformizeOptions o;
    o.on_stage = [&](const StageRecord& s) {
      stages.emplace_back(s.stage);
      CHECK(s.seconds >= 0);
      CHECK(!s.summary.empty());
    };
    const UniformizeResult r = uniformize(lr.validated.mesh, t, o);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    MESSAGE(p.filename().string() << ": " << r.brief_report() << "; floor " << r.layout.rounding_floor
                                  << ", seed independence " << r.seed_independence_error);
    CHECK(r.geometry == natural_geometry(t));
    CHECK(r.flow.max_curvature_error < 1e-12);
    if (r.has_atlas) {
      // genus2-finger.obj: one chart cannot hold its finger; every face to 1e-9 in its own chart.
      CHECK(r.layout.rounding_floor > 1e-6);
      CHECK(r.atlas.flipped_faces == 0);
      CHECK(r.atlas.max_edge_length_error <= 1e-9);
    } else {
      CHECK(r.layout.flipped_faces == 0);
      CHECK(r.layout.max_edge_length_error < std::max(1e-9, 8 * r.layout.rounding_floor));
    }
    CHECK(r.timings.size() == stages.size());
    const bool sphere = t.is_closed() && t.euler_characteristic() == 2;
    CHECK(r.has_cut == !sphere);
    CHECK(r.layout.dims == (sphere ? 3 : 2));
    if (r.has_cut) {
      CHECK(r.layout.positions.size() == 2 * static_cast<std::size_t>(r.cut.num_cut_vertices()));
      CHECK(r.disk.num_faces == static_cast<Index>(r.cut.cut_faces.size() / 3));
      // The cut's connectivities were handed on (moved), not built again.
      CHECK(ricci_test::same_topology(r.disk, build_topology(r.cut.cut_faces, r.cut.num_cut_vertices()).topology));
      CHECK(r.cut.disk_topology.num_faces == 0);
      CHECK(r.cut.surface_topology.num_faces == 0);
    }
    // Seed independence: the face farthest from the seed, aligned by the fitted isometry.
    CHECK(r.seed_faces_checked.size() == 1);
    CHECK(r.seed_independence_error < 1e-9);
    // On every vertex both layouts resolve: all of them with one chart, the first chart's with an atlas.
    if (r.has_cut && !r.has_atlas) CHECK(r.seed_check_vertices == r.disk.num_vertices);
    if (r.has_atlas) CHECK((r.seed_check_vertices > 0 && r.seed_check_vertices < r.disk.num_vertices));
    // Closed genus >= 1: the canonical polygon and its deck transformations. E: the cut and its
    // layout. H: the layout is the compact domain; the canonical generators are words in its side
    // pairings and the polygon is their geodesic 4g-gon, a fundamental domain.
    const bool closed_handles = t.is_closed() && t.genus() >= 1;
    const bool closed_h = closed_handles && r.geometry == Geometry::Hyperbolic;
    CHECK(r.has_polygon == (closed_handles && !closed_h));
    CHECK(r.has_geodesic_polygon == closed_h);
    CHECK(r.has_deck == closed_handles);
    if (closed_handles) {
      REQUIRE(r.deck.status == Status::Ok);
      CHECK(r.deck.generators.size() == 2 * static_cast<std::size_t>(t.genus()));
      CHECK(r.deck.relation_error < 1e-12);
    }
    if (closed_handles && !closed_h) {
      CHECK(r.polygon_cut.canonical);
      CHECK(r.polygon.flipped_faces == 0);
      CHECK(r.polygon.max_edge_length_error < std::max(1e-9, 8 * r.polygon.rounding_floor));
      CHECK(r.deck.residual_max < std::max(1e-9, 100 * r.polygon.rounding_floor));
      for (const DeckGenerator& G : r.deck.generators) {
        CAPTURE(G.name);
        CHECK(G.single_edge_spread < 1e-9);
      }
    }
    if (closed_h) {
      const GeodesicPolygon& gp = r.geodesic_polygon;
      const double g = static_cast<double>(t.genus());
      CHECK(gp.vertices.size() == 4 * static_cast<std::size_t>(t.genus()));
      CHECK(gp.simple);
      CHECK(gp.angle_sum == doctest::Approx(2 * std::numbers::pi).epsilon(1e-12));
      CHECK(gp.area == doctest::Approx(4 * std::numbers::pi * (g - 1)).epsilon(1e-12));
      CHECK(gp.closure_error < 1e-12);
      CHECK(r.canonical_words.size() == r.deck.generators.size());
      // As fitted, the words carry the fits' residuals δ through their products, which show a
      // change δ of the pairings as about δ·e^{2R} at the polygon's reach R (genus3.obj: δ 1.4e-13,
      // R 8.2, 3.4e-9); adjusted, the relation holds in quad (r.deck.relation_error).
      double fit = 0;
      for (const DeckGenerator& G : r.domain_maps) fit = std::max(fit, G.residual_max);
      CHECK(r.fitted_relation_error < std::max(1e-9, fit * std::exp(2 * gp.reach)));
      CHECK(r.deck.residual_max < 1e-9);
      CHECK(r.domain_pairing_adjustment < 1e-10);
      for (const DeckGenerator& G : r.domain_maps) {
        CAPTURE(G.name);
        CHECK(G.single_edge_spread < 1e-9);
        CHECK(G.residual_max < 1e-10);
      }
      for (const DeckGenerator& G : r.deck.generators) CHECK(G.translation_length > 0.1);
      CHECK(!r.cut.canonical);  // the compact domain
      CHECK(r.domain_maps.size() == static_cast<std::size_t>(r.cut.num_generators()));
      // The pairings are fitted on the first chart, which resolves a finger's vertices only
      // absolutely (to about 1e-16 / (1 − |z|²)), not relative to its tiny edges.
      CHECK(r.domain_cycle_error < (r.has_atlas ? 1e-10 : 1e-12));
      CHECK(r.candidates.empty());  // no base search on the mesh
    } else {
      CHECK(r.candidates.empty());
      CHECK(r.domain_maps.empty());
    }
    // Angle distortion: one ratio per corner, finite, the statistics consistent with them.
    REQUIRE(r.angles.ratio.size() == 3 * static_cast<std::size_t>(t.num_faces));
    double mx = 0;
    for (double x : r.angles.ratio) {
      CHECK(std::isfinite(x));
      CHECK(x > 0);
      mx = std::max(mx, std::abs(std::log(x)));
    }
    CHECK(r.angles.max_abs_log == doctest::Approx(mx));
    CHECK(r.angles.mean_abs_log <= r.angles.max_abs_log);
  });
}

TEST_CASE("uniformize: a stored metric lays out exactly as the flow's own lengths") {
  const LoadResult lr = load_mesh((ricci_test::fixtures_dir() / "genus2.obj").string());
  REQUIRE(lr.status == Status::Ok);
  const Mesh& m = lr.validated.mesh;
  const Topology& t = lr.validated.topology;
  const UniformizeResult a = uniformize(m, t);
  REQUIRE(a.status == Status::Ok);
  const UniformizeResult b = lay_out_metric(m, t, a.geometry, a.flow.l);
  REQUIRE_MESSAGE(b.status == Status::Ok, b.message);
  CHECK(b.flow.status == Status::NotRun);
  CHECK(b.cut.word == a.cut.word);
  CHECK(b.layout.positions == a.layout.positions);  // deterministic: bit for bit
  CHECK(b.deck.relation_error == a.deck.relation_error);
  // Bad lengths are named.
  std::vector<double> l = a.flow.l;
  l[17] = -1;
  const UniformizeResult c = lay_out_metric(m, t, a.geometry, l);
  CHECK(c.status == Status::DegenerateFace);
  CHECK(c.message.find("edge 17") != std::string::npos);
  l.pop_back();
  CHECK(lay_out_metric(m, t, a.geometry, l).status == Status::InvalidArgument);
}

TEST_CASE("uniformize: failures name their stage and keep what ran before") {
  const Mesh mesh = ricci_shapes::torus(16, 8, 1.0, 0.4);
  const ValidateResult v = validate_mesh(mesh);
  REQUIRE(v.status == Status::Ok);
  // A target that violates Gauss-Bonnet (2pi at one vertex of a torus): stopped at `target`.
  Target bad = uniform_target(v.topology);
  bad.K[3] = 2 * std::numbers::pi;
  const UniformizeResult r = uniformize(v.mesh, v.topology, {}, &bad);
  CHECK(r.status == Status::InfeasibleTarget);
  CHECK(r.failed_stage == "target");
  CHECK(r.message.rfind("target: ", 0) == 0);
  CHECK(r.metric.status == Status::Ok);
  CHECK(r.layout.status == Status::NotRun);
  // The flow's iteration limit: stopped at `flow`, with its iterate.
  UniformizeOptions o;
  o.flow.max_iterations = 1;
  const UniformizeResult f = uniformize(v.mesh, v.topology, o);
  CHECK(f.status == Status::NotConverged);
  CHECK(f.failed_stage == "flow");
  CHECK(f.flow.u.size() == static_cast<std::size_t>(v.topology.num_vertices));
  // Bad options.
  o = {};
  o.base_candidates = 0;
  CHECK(uniformize(v.mesh, v.topology, o).status == Status::InvalidArgument);
  o = {};
  o.seed_checks = -1;
  CHECK(uniformize(v.mesh, v.topology, o).status == Status::InvalidArgument);
  o = {};
  o.max_layout_error = 0;
  CHECK(uniformize(v.mesh, v.topology, o).status == Status::InvalidArgument);
}

TEST_CASE("uniformize: a layout that does not reproduce the metric is a failure, not a result") {
  // A 40:1 strip with a free boundary in E: K = 0 inside, so u is harmonic and varies linearly
  // along the strip by about its aspect ratio in each direction of the exponential map; the
  // layout's edges span more orders of magnitude than double precision can hold in one chart.
  const Mesh mesh = ricci_shapes::strip(160, 4, 40.0, 1.0);
  const ValidateResult v = validate_mesh(mesh);
  REQUIRE(v.status == Status::Ok);
  UniformizeOptions o;
  o.boundary = BoundaryMode::Free;
  o.seed_checks = 0;
  // By default the faces one chart cannot resolve get charts of their own (both ends here).
  const UniformizeResult atlas = uniformize(v.mesh, v.topology, o);
  REQUIRE_MESSAGE(atlas.status == Status::Ok, atlas.message);
  CHECK(atlas.has_atlas);
  CHECK(atlas.atlas.num_charts() >= 3);
  CHECK(atlas.layout.max_edge_length_error > o.max_layout_error);
  CHECK(atlas.atlas.max_edge_length_error <= 1e-9);
  // With one chart only, the gate refuses it.
  o.use_atlas = false;
  const UniformizeResult r = uniformize(v.mesh, v.topology, o);
  CHECK(r.flow.status == Status::Ok);  // the flow itself converges
  CHECK(r.status == Status::NumericalFailure);
  CHECK(r.failed_stage == "layout");
  CHECK(r.message.find("edge-length error") != std::string::npos);
  CHECK(r.message.find("(edge ") != std::string::npos);
  MESSAGE(r.message);
  // A limit below any rounding always trips the gate, atlas or not.
  o.use_atlas = true;
  o.max_layout_error = 1e-300;
  const UniformizeResult t = uniformize(v.mesh, v.topology, o);
  CHECK(t.status == Status::NumericalFailure);
  CHECK(t.failed_stage == "layout");
}

TEST_CASE("uniformize: bordered hyperbolic surfaces are laid out through a compact domain") {
  // A genus-2 surface with one hole (the fixture) and a pretzel with two holes punched in it: the
  // cut graph ends on the boundary loops, boundary pieces are unpaired sides, every other side has
  // a partner of the same length, and the layout is exact.
  std::vector<std::pair<std::string, Mesh>> cases;
  {
    const LoadResult lr = load_mesh((ricci_test::fixtures_dir() / "genus2-1hole.obj").string());
    REQUIRE(lr.status == Status::Ok);
    cases.emplace_back("genus2-1hole", lr.validated.mesh);
  }
  const Mesh pretzel = ricci_shapes::pretzel(3, 4);
  cases.emplace_back("pretzel(3) with two holes", ricci_shapes::remove_vertex_stars(pretzel, {5, pretzel.num_vertices() / 2}));
  for (const auto& [name, mesh] : cases) {
    INFO(name);
    const ValidateResult v = validate_mesh(mesh);
    REQUIRE_MESSAGE(v.status == Status::Ok, v.message);
    const Topology& t = v.topology;
    REQUIRE(!t.is_closed());
    const UniformizeResult r = uniformize(v.mesh, t);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.geometry == Geometry::Hyperbolic);
    CHECK(r.cut.compact);
    CHECK(r.cut.boundary_loops == t.num_boundary_loops());
    CHECK(r.layout.max_edge_length_error < 1e-9);
    CHECK(r.layout.flipped_faces == 0);
    CHECK(r.seed_independence_error < 1e-9);
    // Every boundary edge lies on exactly one Boundary side; paired sides match vertex by vertex.
    Index boundary_edges = 0, paired = 0;
    for (Index s = 0; s < r.cut.num_sides(); ++s) {
      const Index n = r.cut.side_offsets[s + 1] - r.cut.side_offsets[s];
      if (r.cut.side_kind[s] == SideKind::Boundary) {
        CHECK(r.cut.side_partner[s] == -1);
        CHECK(r.cut.side_boundary_loop[s] >= 0);
        CHECK(r.cut.side_label[s].rfind("∂", 0) == 0);
        boundary_edges += n - 1;
      } else {
        const Index p = r.cut.side_partner[s];
        REQUIRE(p >= 0);
        CHECK(r.cut.side_partner[p] == s);
        REQUIRE(r.cut.side_offsets[p + 1] - r.cut.side_offsets[p] == n);
        for (Index i = 0; i < n; ++i)
          CHECK(r.cut.cut_to_surface[r.cut.side_vertices[r.cut.side_offsets[s] + i]] ==
                r.cut.cut_to_surface[r.cut.side_vertices[r.cut.side_offsets[p] + n - 1 - i]]);
        ++paired;
      }
    }
    CHECK(boundary_edges == t.boundary_offsets[t.num_boundary_loops()]);
    CHECK(paired % 2 == 0);
    CHECK(paired > 0);
    MESSAGE(name << ": " << r.cut.num_sides() << " sides, layout edge error " << r.layout.max_edge_length_error);
  }
  // A disk needs no cut: cut_compact refuses it.
  const Mesh disk = ricci_shapes::disk(3);
  const ValidateResult dv = validate_mesh(disk);
  REQUIRE(dv.status == Status::Ok);
  const std::vector<double> l(static_cast<std::size_t>(dv.topology.num_edges), 0.1);
  CHECK(cut_compact(dv.mesh, dv.topology, l).status == Status::InvalidArgument);
}

TEST_CASE("uniformize: angle distortion is zero for a metric equal to the mesh's own (E)") {
  const Mesh mesh = ricci_shapes::disk(6);
  const ValidateResult v = validate_mesh(mesh);
  REQUIRE(v.status == Status::Ok);
  const Topology& t = v.topology;
  std::vector<double> l(static_cast<std::size_t>(t.num_edges));
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    double s = 0;
    for (int d = 0; d < 3; ++d) s += std::pow(v.mesh.positions[3 * a + d] - v.mesh.positions[3 * b + d], 2);
    l[e] = std::sqrt(s);
  }
  const AngleDistortion a = angle_distortion(v.mesh, t, Geometry::Euclidean, l);
  CHECK(a.max_abs_log < 1e-12);
  // Doubling one edge changes the angles of its two faces only.
  l[0] *= 1.5;
  const AngleDistortion b = angle_distortion(v.mesh, t, Geometry::Euclidean, l);
  Index changed = 0;
  for (double x : b.ratio) changed += std::abs(std::log(x)) > 1e-12 ? 1 : 0;
  CHECK(changed == (t.edge_corners[1] == kInvalid ? 3 : 6));
  CHECK(b.max_abs_log > 0.1);
}

TEST_CASE("uniformize: genus 4 and 5 through the compact domain, mesh-path canonical polygon") {
  // Generated pretzels with 4 and 5 holes, with mesh_polygon: canonical cuts of the mesh laid out
  // through the compact domain's tiles. The layout (the compact domain) and its side pairings are
  // exact to rounding whatever the canonical polygon looks like. The pairings, moved onto exact
  // vertex cycles by less than their fit residuals, make the canonical relation hold in quad; the
  // same words in the pairings as fitted hold it to the fit's accuracy.
  for (int g : {4, 5}) {
    if (g == 5 && ricci_test::kSanitized) continue;  // the sanitizer build: genus 4 (the same paths)
    CAPTURE(g);
    const ValidateResult v = validate_mesh(ricci_shapes::pretzel(g, 4));
    REQUIRE(v.status == Status::Ok);
    UniformizeOptions o;
    o.mesh_polygon = true;
    const UniformizeResult r = uniformize(v.mesh, v.topology, o);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    CHECK(r.layout.max_edge_length_error < 1e-9);
    CHECK(r.layout.flipped_faces == 0);
    CHECK(r.seed_independence_error < 1e-9);
    CHECK(r.domain_cycle_error < 1e-12);
    CHECK(r.domain_adjusted_cycle_error < 1e-25);
    CHECK(r.domain_pairing_adjustment < 1e-10);
    CHECK(r.domain_pairing_adjustment > 0);
    REQUIRE(r.has_deck);
    CHECK(r.has_polygon);
    CHECK(r.polygon_cut.canonical);
    CHECK(r.deck.generators.size() == 2 * static_cast<std::size_t>(g));
    CHECK(r.deck.relation_error < 1e-9);
    // As fitted, the relation loses what the polygon's reach amplifies (its rounding floor in
    // double measures that reach): below 1e-9 at genus 4, about 2e-7 at genus 5.
    CHECK(r.fitted_relation_error < std::max(1e-9, 10 * r.polygon.rounding_floor));
    if (g == 4) CHECK(r.fitted_relation_error < 1e-9);
    CHECK(r.deck.residual_max < 1e-9);
    CHECK(r.polygon.max_edge_length_error < std::max(1e-9, 8 * r.polygon.rounding_floor));
    CHECK(r.polygon.flipped_faces == 0);
    // A coarse view says how far the polygon reaches (genus 5: 3.6e-8).
    CHECK((r.polygon_note.find("reaches hyperbolic distance") != std::string::npos) ==
          (r.polygon.max_edge_length_error > 1e-9));
    // Every generator is hyperbolic (the group is torsion-free).
    for (const DeckGenerator& G : r.deck.generators) CHECK(G.translation_length > 0.1);
    // The base search went on while no stopping rule held: no score below polygon_tolerance and
    // no two bases in a row matching the best score to 1 % before the last candidate; the best
    // candidate is the one kept.
    REQUIRE(!r.candidates.empty());
    double best = INFINITY, running = INFINITY;
    int matching = 0;
    for (const BaseCandidate& c : r.candidates)
      best = std::min(best, std::max({c.relation_error, c.max_edge_length_error, c.rounding_floor}));
    CHECK(std::max({r.deck.relation_error, r.polygon.max_edge_length_error, r.polygon.rounding_floor}) == best);
    for (std::size_t i = 0; i + 1 < r.candidates.size(); ++i) {
      const BaseCandidate& c = r.candidates[i];
      const double score = std::max({c.relation_error, c.max_edge_length_error, c.rounding_floor});
      if (std::isfinite(score)) {
        matching = std::isfinite(running) && std::abs(score - running) <= 0.01 * running ? matching + 1 : 0;
        running = std::min(running, score);
      }
      CAPTURE(i);
      CHECK(!(running < UniformizeOptions{}.polygon_tolerance));
      CHECK(matching < 2);
    }
    // The geodesic polygon of the mesh path's generators, in their frame.
    REQUIRE(r.has_geodesic_polygon);
    CHECK(r.geodesic_polygon.simple);
    CHECK(r.geodesic_polygon.angle_sum == doctest::Approx(2 * std::numbers::pi).epsilon(1e-12));
    CHECK(r.canonical_words.empty());
    MESSAGE("pretzel(" << g << ", 4), mesh path: " << r.brief_report() << "; canonical polygon edge error "
                       << r.polygon.max_edge_length_error << ", floor " << r.polygon.rounding_floor
                       << ", domain vertex cycles " << r.domain_cycle_error << " (adjusted by "
                       << r.domain_pairing_adjustment << " to " << r.domain_adjusted_cycle_error
                       << "), relation as fitted " << r.fitted_relation_error);
  }
}

TEST_CASE("uniformize: the canonical words and polygon do not depend on the flow's factorization") {
  // The two layouts of Newton's factor round differently, so their solutions differ in the last
  // bits. The compact cut and the greedy moves on its word break ties of equal size by index, so
  // the canonical words, and with them the geodesic polygon, are the same (before those ties were
  // broken by rounding, pretzel(12, 4)'s words under the simplicial layout reached 27.2 and missed
  // the relation; fertility.off's polygon grew from 109.4 to 134.0).
  struct Input {
    std::string name;
    Mesh mesh;
  };
  std::vector<Input> inputs;
  inputs.push_back({"pretzel(12, 4)", ricci_shapes::pretzel(12, 4)});
  inputs.push_back({"pretzel_grid(4, 2, 4)", ricci_shapes::pretzel_grid(4, 2, 4)});
  {
    const LoadResult lr = load_mesh((ricci_test::fixtures_dir() / "genus3.obj").string());
    REQUIRE(lr.status == Status::Ok);
    inputs.push_back({"genus3.obj", lr.validated.mesh});
  }
  for (const Input& in : inputs) {
    CAPTURE(in.name);
    const ValidateResult v = validate_mesh(in.mesh);
    REQUIRE(v.status == Status::Ok);
    std::vector<UniformizeResult> runs;
    for (const Factorization f : {Factorization::Supernodal, Factorization::Simplicial}) {
      UniformizeOptions o;
      o.flow.factorization = f;
      o.seed_checks = 0;
      runs.push_back(uniformize(v.mesh, v.topology, o));
      REQUIRE_MESSAGE(runs.back().status == Status::Ok, runs.back().message);
      REQUIRE(runs.back().has_geodesic_polygon);
    }
    const UniformizeResult& a = runs[0];
    const UniformizeResult& b = runs[1];
    double du = 0;
    for (std::size_t i = 0; i < a.flow.u.size(); ++i) du = std::max(du, std::abs(a.flow.u[i] - b.flow.u[i]));
    CHECK(du < 1e-10);
    CHECK(a.cut.cut_faces == b.cut.cut_faces);
    CHECK(a.canonical_words == b.canonical_words);
    // The same polygon up to the rounding of its far corners: each run's own angle tolerance
    // (max(1e-9, relation error × e^reach); pretzel_grid(4, 2, 4), reach 18.5, moves by 2.8e-9
    // relative between factor layouts whose solutions differ by 3e-15).
    const double tolerance = std::max(a.geodesic_polygon.angle_tolerance, b.geodesic_polygon.angle_tolerance);
    CHECK(a.geodesic_polygon.perimeter == doctest::Approx(b.geodesic_polygon.perimeter).epsilon(tolerance));
    CHECK(a.geodesic_polygon.reach == doctest::Approx(b.geodesic_polygon.reach).epsilon(tolerance));
    MESSAGE(in.name << ": flow solutions apart by " << du << "; perimeters apart by "
                    << std::abs(a.geodesic_polygon.perimeter - b.geodesic_polygon.perimeter) << " (tolerance "
                    << tolerance << " relative); " << b.geodesic_polygon.message);
  }
}

TEST_CASE("uniformize: generators without a polygon view are kept only within the polygon tolerance") {
  // pretzel(12, 4) by the mesh path: every canonical cut reaches beyond double range, and the
  // first base's generators through the domain (its cut vertices' positions past that range)
  // have a relation error of about 5e7. They are not a deck group: the run ends with the compact
  // domain's side pairings, and the base's note says why its generators were dropped.
  if (ricci_test::kSanitized) return;  // 6 s in Release: three canonical cuts of 100k+ vertices
  const ValidateResult v = validate_mesh(ricci_shapes::pretzel(12, 4));
  REQUIRE(v.status == Status::Ok);
  UniformizeOptions o;
  o.mesh_polygon = true;
  const UniformizeResult r = uniformize(v.mesh, v.topology, o);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(!r.has_polygon);
  if (r.has_deck) {
    CHECK(r.deck.relation_error <= o.polygon_tolerance);
    CHECK(r.deck.residual_max <= o.polygon_tolerance);
  } else {
    CHECK(r.domain_maps.size() == static_cast<std::size_t>(r.cut.num_generators()));
    CHECK(r.polygon_note.find("the deck group is given by the compact domain's side pairings") != std::string::npos);
  }
  int dropped = 0;
  for (const BaseCandidate& c : r.candidates) {
    CAPTURE(c.note);
    CHECK(!c.note.empty());
    if (c.note.find("its generators are not kept") != std::string::npos) ++dropped;
  }
  CHECK(dropped >= 1);  // the case this test is about: a base whose generators were dropped
  MESSAGE("pretzel(12, 4), mesh path: " << r.candidates.size() << " bases, " << dropped
                                        << " with generators dropped; " << r.polygon_note);
}

TEST_CASE("uniformize: the geodesic canonical polygon at genus 2 to 20, from the domain's pairings alone") {
  // The default for closed surfaces of genus >= 2: canonical generators as words in the compact
  // domain's side pairings, their geodesic 4g-gon a fundamental domain (simple, angle sum 2π, area
  // 4π(g − 1)), the relation to 1e-12, with no cut of the mesh beyond the compact domain.
  // Holes in a row (pretzel) and, for genus 8, 12 and 20, in 4 × 2, 4 × 3 and 5 × 4 grids (the
  // compact domain of the 4 × 3 grid has 130 sides in 42 corner classes: joining them by moves
  // leaves generators beyond 113 bits, the one-vertex polygon of its shorter pairings does not;
  // the 5 × 4 grid's polygon meets the relation only after the substitutions across handles).
  for (int g : {2, 3, 4, 5, 8, 12, -8, -12, -20}) {
    CAPTURE(g);
    const ValidateResult v = validate_mesh(g > 0    ? ricci_shapes::pretzel(g, 4)
                                           : g == -20 ? ricci_shapes::pretzel_grid(5, 4, 4)
                                                      : ricci_shapes::pretzel_grid(4, g == -8 ? 2 : 3, 4));
    g = std::abs(g);
    REQUIRE(v.status == Status::Ok);
    const UniformizeResult r = uniformize(v.mesh, v.topology);
    REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
    REQUIRE(r.has_deck);
    REQUIRE(r.has_geodesic_polygon);
    CHECK(!r.has_polygon);
    CHECK(r.candidates.empty());
    const GeodesicPolygon& gp = r.geodesic_polygon;
    CHECK(gp.word.rfind("a1 b1 a1^-1 b1^-1", 0) == 0);
    CHECK(gp.vertices.size() == 4 * static_cast<std::size_t>(g));
    CHECK(gp.simple);
    // The walk around 4g corners multiplies generators whose entries grow as e^(reach/2): a
    // relator off the identity by δ moves the corners, and the angles and the closure with them,
    // by up to about δ·e^reach (the 4 × 2 grid: δ 3.4e-15 at reach 18.5, angle sum off by
    // 1.8e-9, closure 5.7e-10). The polygon's own angle_tolerance is that bound.
    CHECK(gp.fundamental);
    CHECK(std::abs(gp.angle_sum - 2 * std::numbers::pi) <= gp.angle_tolerance);
    CHECK(std::abs(gp.area - 4 * std::numbers::pi * (g - 1)) <= gp.angle_tolerance);
    CHECK(gp.closure_error < std::max(1e-10, gp.deck.relation_error * std::exp(gp.reach)));
    CHECK(r.deck.relation_error < 1e-12);
    CHECK(r.canonical_words.size() == 2 * static_cast<std::size_t>(g));
    for (const DeckGenerator& G : r.deck.generators) CHECK(G.translation_length > 0.1);
    // Each corner is the image of corner 0 under the product the side convention gives; every
    // side is mapped onto its partner by its generator (A_i: corner 4i-4 to 4i-1, 4i-3 to 4i-2;
    // B_i: 4i-3 to 4i, 4i-2 to 4i-1), to the rounding of coordinates at the polygon's reach.
    // Checked in double where double coordinates resolve the corners (reach ≤ 15; genus 12's
    // polygon reaches 22, where the relation and the closure above, in quad, speak for it).
    const std::size_t n = gp.vertices.size();
    const double tol = 1e-12 * std::exp(gp.reach);
    for (std::size_t i = 0; i < static_cast<std::size_t>(g) && gp.reach <= 15; ++i) {
      const Moebius& A = r.deck.generators[2 * i].map;
      const Moebius& B = r.deck.generators[2 * i + 1].map;
      auto corner = [&](std::size_t k) { return gp.vertices[k % n]; };
      CHECK(hyperbolic_distance(A.apply(corner(4 * i)), corner(4 * i + 3)) < tol);
      CHECK(hyperbolic_distance(A.apply(corner(4 * i + 1)), corner(4 * i + 2)) < tol);
      CHECK(hyperbolic_distance(B.apply(corner(4 * i + 1)), corner(4 * i + 4)) < tol);
      CHECK(hyperbolic_distance(B.apply(corner(4 * i + 2)), corner(4 * i + 3)) < tol);
    }
    // Each generator is its word in the domain's pairings, moved into the polygon's frame
    // (evaluated in double: checked where the words' products stay within its digits).
    if (g <= 3) {
      for (std::size_t k = 0; k < r.canonical_words.size(); ++k) {
        CAPTURE(r.canonical_words[k]);
        Moebius M;
        std::size_t at = 0;
        const std::string& w = r.canonical_words[k];
        while (at < w.size()) {
          std::size_t end = w.find(' ', at);
          if (end == std::string::npos) end = w.size();
          std::string token = w.substr(at, end - at);
          const bool inv = token.size() > 3 && token.compare(token.size() - 3, 3, "^-1") == 0;
          if (inv) token.resize(token.size() - 3);
          const DeckGenerator* x = nullptr;
          for (const DeckGenerator& d : r.domain_maps)
            if (d.name == token) x = &d;
          REQUIRE_MESSAGE(x != nullptr, token);
          M = M * (inv ? x->map.inverse() : x->map);
          at = end + 1;
        }
        CHECK(moebius_difference(gp.frame * M * gp.frame.inverse(), r.deck.generators[k].map) < 1e-7);
      }
    }
    double seconds = 0;
    for (const auto& [stage, s] : r.timings)
      if (stage == "polygon") seconds = s;
    MESSAGE("genus " << g << ": " << gp.message << ", " << r.canonical_words.size()
                       << " generator words, polygon stage " << seconds << " s");
  }
}

TEST_CASE("uniformize: a row of 20 holes keeps its deck group where its compact domain reaches distance 14, and its canonical polygon") {
  // pretzel(20, 4): one chart lays the compact domain out to 1e-9 but to hyperbolic distance 14
  // from its centre, where a side pairing has entries of size e^14. Rounded to double, those
  // pairings closed the domain's vertex cycles only to 4.3e-5 and the run ended at the deck stage;
  // formed in quad from the fits in frames on their sides (map + map_low), and their cycles
  // evaluated in frames along each cycle, they close to what the layout resolves, and the
  // adjustment closes them to quad rounding.
  const ValidateResult v = validate_mesh(ricci_shapes::pretzel(20, 4));
  REQUIRE(v.status == Status::Ok);
  UniformizeOptions o;
  o.seed_checks = 0;
  const UniformizeResult r = uniformize(v.mesh, v.topology, o);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  double reach = 0;
  for (std::size_t i = 0; i + 1 < r.layout.positions.size(); i += 2)
    reach = std::max(reach, hyperbolic_distance({r.layout.positions[i], r.layout.positions[i + 1]}, {0, 0}));
  MESSAGE("pretzel(20, 4): domain reach " << reach << ", vertex cycles " << r.domain_cycle_error << " (adjusted by "
                                          << r.domain_pairing_adjustment << " to " << r.domain_adjusted_cycle_error
                                          << "); " << (r.has_geodesic_polygon ? r.geodesic_polygon.message : r.polygon_note));
  CHECK(reach > 12);
  CHECK(r.domain_maps.size() == static_cast<std::size_t>(r.cut.num_generators()));
  CHECK(r.domain_cycle_error < 1e-8);
  CHECK(r.domain_pairing_adjustment < 1e-8);
  CHECK(r.domain_adjusted_cycle_error < 1e-20);
  // The geodesic 80-gon of its canonical generators reaches distance 28–30, where generators in
  // quad resolve the relation only to ~2^-112·e^(2·reach) ≈ 1e-10: the pairings are closed again
  // in quad-double and the same words evaluated there, and the polygon is kept, verified to
  // 1e-12, with no mesh path searched.
  REQUIRE(r.has_geodesic_polygon);
  CHECK(r.candidates.empty());
  CHECK(r.polygon_note.empty());
  CHECK(r.geodesic_polygon.fundamental);
  CHECK(r.geodesic_polygon.vertices.size() == 80);
  CHECK(r.geodesic_polygon.reach > 25);
  CHECK(r.geodesic_polygon.arithmetic_bits == 212);
  CHECK(r.geodesic_polygon.relation_floor < 1e-20);
  CHECK(r.deck.relation_error < 1e-20);
  CHECK(r.has_deck);
  CHECK(r.canonical_words.size() == 40);
}

TEST_CASE("uniformize: a metric that is not flat fails the edge gate, and without polish the farthest seed sees it too") {
  // The torus's flat metric with one edge 0.1 % longer: four vertices get curvature. A propagation
  // closes around them with a gap whose place depends on the seed; the polish (sweeps and
  // Gauss–Newton on all positions) then makes the layout a least-squares fit of the lengths, which
  // no longer depends on the seed. What catches the metric is the layout's own edge error (the
  // gate, 1e-6); the seed check sees it only in the raw propagation.
  const LoadResult lr = load_mesh((ricci_test::fixtures_dir() / "torus.obj").string());
  REQUIRE(lr.status == Status::Ok);
  const Topology& t = lr.validated.topology;
  const UniformizeResult flat = uniformize(lr.validated.mesh, t);
  REQUIRE(flat.status == Status::Ok);
  REQUIRE(flat.seed_faces_checked.size() == 1);
  CHECK(flat.seed_faces_checked[0] != flat.layout.seed_face);
  CHECK(flat.seed_independence_error < 1e-12);
  std::vector<double> l = flat.flow.l;
  l[t.num_edges / 2] *= 1.001;
  UniformizeOptions o;
  const UniformizeResult gated = lay_out_metric(lr.validated.mesh, t, Geometry::Euclidean, l, o);
  CHECK(gated.status == Status::NumericalFailure);
  CHECK(gated.failed_stage == "layout");
  o.max_layout_error = 1.0;
  o.flow.threads = 1;
  const UniformizeResult polished = lay_out_metric(lr.validated.mesh, t, Geometry::Euclidean, l, o);
  REQUIRE(polished.status == Status::Ok);
  CHECK(polished.layout.max_edge_length_error > 1e-4);
  CHECK(polished.seed_independence_error < 1e-6);
  o.layout.polish_sweeps = 0;
  o.layout.polish_steps = 0;
  const UniformizeResult one = lay_out_metric(lr.validated.mesh, t, Geometry::Euclidean, l, o);
  REQUIRE(one.status == Status::Ok);
  CHECK(one.seed_independence_error > 1e-4);
  // On two threads (the check's layouts on both): the same numbers.
  o.flow.threads = 2;
  const UniformizeResult two = lay_out_metric(lr.validated.mesh, t, Geometry::Euclidean, l, o);
  REQUIRE(two.status == Status::Ok);
  CHECK(two.seed_independence_error == one.seed_independence_error);
  CHECK(two.seed_faces_checked == one.seed_faces_checked);
  CHECK(two.layout.positions == one.layout.positions);
  // Three checks: the farthest face, then faces spread over the disk.
  o.seed_checks = 3;
  const UniformizeResult three = lay_out_metric(lr.validated.mesh, t, Geometry::Euclidean, l, o);
  REQUIRE(three.seed_faces_checked.size() == 3);
  CHECK(three.seed_faces_checked[0] == one.seed_faces_checked[0]);
  CHECK(three.seed_independence_error >= one.seed_independence_error);
}

TEST_CASE("uniformize: smoothing steps take the residual's sum to its rounding, and one propagation closes") {
  // pretzel(2, 16) (25.6k faces, genus 2, H): the polished solve stops at a max |K̄ − K| of a few
  // ulps whose smooth part still sums to 2.2e-11 over 12.8k vertices, and one propagation of the
  // compact domain then misses its metric by 2.4e-10 where its front closes (above refine_above:
  // patches and sweeps would run). One chord step after the polishing takes the sum to its
  // rounding and the same propagation within 1.3e-12.
  const Mesh mesh = ricci_shapes::pretzel(2, 16);
  const TopologyResult tr = build_topology(mesh.faces, mesh.num_vertices());
  REQUIRE(tr.status == Status::Ok);
  UniformizeOptions o;
  o.seed_checks = 0;
  o.layout.refine_above = 1e300;  // one propagation, no refinement
  auto sum_of = [](const FlowResult& f) {
    long double s = 0;
    for (std::size_t v = 0; v < f.K.size(); ++v) s += static_cast<long double>(f.K[v]) - f.K_target[v];
    return static_cast<double>(std::abs(s));
  };
  auto noted = [](const FlowResult& f) {
    return std::any_of(f.notes.begin(), f.notes.end(), [](const std::string& n) { return n.find("smoothed by") != std::string::npos; });
  };
  const double rounding = std::numeric_limits<double>::epsilon() * 4 * std::numbers::pi *
                          std::sqrt(static_cast<double>(mesh.num_vertices()));
  const UniformizeResult smooth = uniformize(mesh, tr.topology, o);
  o.flow.smooth_steps = 0;
  const UniformizeResult plain = uniformize(mesh, tr.topology, o);
  REQUIRE(smooth.status == Status::Ok);
  REQUIRE(plain.status == Status::Ok);
  INFO("sum " << sum_of(plain.flow) << " → " << sum_of(smooth.flow) << ", one propagation "
              << plain.layout.max_edge_length_error << " → " << smooth.layout.max_edge_length_error);
  CHECK(sum_of(smooth.flow) <= rounding);
  CHECK(sum_of(plain.flow) > 10 * rounding);
  CHECK(noted(smooth.flow));
  CHECK_FALSE(noted(plain.flow));
  CHECK(smooth.flow.max_curvature_error <= 1e-14);
  CHECK(smooth.layout.max_edge_length_error <= 1e-11);
  CHECK(plain.layout.max_edge_length_error > 1e-10);
  // Smoothing is part of the polishing: without it, none.
  o.flow.smooth_steps = 3;
  o.polish = false;
  const UniformizeResult unpolished = uniformize(mesh, tr.topology, o);
  REQUIRE(unpolished.status == Status::Ok);
  CHECK_FALSE(noted(unpolished.flow));
  // And it is validated like every option.
  FlowOptions bad;
  bad.smooth_steps = -1;
  std::string why;
  CHECK_FALSE(bad.is_valid(&why));
  CHECK(why.find("smooth_steps") != std::string::npos);
}

// A circle domain whose boundary system GMRES cannot take to its forcing at the last step goes
// direct: the Gram block of the inverse, its forward solves along elimination-tree paths and the
// dense LU of the 800-position boundary matrix then run in parallel. The whole result must be the
// same bit for bit on 1 and 2 threads.
TEST_CASE("uniformize: a circle domain solved through the split or the direct boundary system is the same on 1 and 2 threads") {
  const Mesh m = ricci_shapes::annulus(20, 400);
  const ValidateResult v = validate_mesh(m);
  REQUIRE(v.status == Status::Ok);
  for (const bool split : {true, false}) {
    CAPTURE(split);
    UniformizeResult r[2];
    for (int threads = 1; threads <= 2; ++threads) {
      UniformizeOptions o;
      o.seed_checks = 0;
      o.flow.threads = threads;
      o.flow.split_loop_coupling = split;
      r[threads - 1] = uniformize(v.mesh, v.topology, o);
      REQUIRE_MESSAGE(r[threads - 1].status == Status::Ok, r[threads - 1].message);
    }
    bool direct = false;
    for (const std::string& note : r[1].flow.notes) direct = direct || note.find("solved directly") != std::string::npos;
    CHECK(direct == !split);
    CHECK(r[0].flow.u == r[1].flow.u);
    CHECK(r[0].flow.l == r[1].flow.l);
    CHECK(r[0].layout.positions == r[1].layout.positions);
  }
}

// A genus-12 grid: the geodesic polygon's generators grow past double range, and the mesh path's
// canonical cut would add hundreds of thousands of vertices. The cut stops at its bound for the
// polygon (1 added vertex per face, and 65536), after one base, and the run ends with the compact
// domain's side pairings as the deck group, saying why.
TEST_CASE("uniformize: where the canonical cut outgrows its bound, the mesh path stops after one cut") {
  // The 4 × 3 grid of holes (genus 12): its canonical cut of the mesh would add more vertices than
  // the bound allows (its geodesic polygon exists: the polygon test above), so with mesh_polygon
  // the first base's cut stops, no other base is tried, and the domain's pairings stand.
  const ValidateResult v = validate_mesh(ricci_shapes::pretzel_grid(4, 3, 4));
  REQUIRE(v.status == Status::Ok);
  UniformizeOptions o;
  o.seed_checks = 0;
  o.mesh_polygon = true;
  const UniformizeResult r = uniformize(v.mesh, v.topology, o);
  REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
  CHECK(!r.has_polygon);
  CHECK(!r.has_geodesic_polygon);
  REQUIRE(r.candidates.size() == 1);
  CHECK(r.candidates[0].note.find("more than 1 vertices per input face") != std::string::npos);
  CHECK(r.polygon_note.find("side pairings") != std::string::npos);
  CHECK(r.domain_maps.size() == static_cast<std::size_t>(r.cut.num_generators()));
}

// With two threads the cut of a surface laid out through cut_surface() (genus 1; genus 0 with
// several loops) is made beside the flow, on a thread of its own; with one, or with
// cut_beside_flow off, it follows the flow. The cut, the disk and the layout must be the same bit
// for bit either way: also the cut's surface, which the worker drops as a copy of the input's
// where the cut added no vertex (as on these two) and the cut stage copies back.
TEST_CASE("uniformize: a cut made beside the flow is the cut made after it") {
  struct Case {
    const char* name;
    Mesh mesh;
  };
  const Case cases[] = {{"torus", ricci_shapes::torus(48, 24, 1.0, 0.4)},
                        {"annulus", ricci_shapes::conformal_annulus(0.3, 0.9, 8, 64)}};
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const ValidateResult v = validate_mesh(c.mesh);
    REQUIRE(v.status == Status::Ok);
    // 1 thread; 2 threads; 2 threads with the option off.
    UniformizeResult r[3];
    std::string cut_line[3];
    for (int run = 0; run < 3; ++run) {
      UniformizeOptions o;
      o.flow.threads = run == 0 ? 1 : 2;
      o.cut_beside_flow = run != 2;
      o.on_stage = [&cut_line, run](const StageRecord& s) {
        if (s.stage == "cut") cut_line[run] = s.summary;
      };
      r[run] = uniformize(v.mesh, v.topology, o);
      REQUIRE_MESSAGE(r[run].status == Status::Ok, r[run].message);
    }
    CHECK(cut_line[0].find("beside the flow") == std::string::npos);
    CHECK(cut_line[1].find("beside the flow") != std::string::npos);
    CHECK(cut_line[2].find("beside the flow") == std::string::npos);
    CHECK(r[0].cut.num_refined_vertices() == 0);
    CHECK(r[0].cut.surface_faces == c.mesh.faces);
    for (int run = 1; run < 3; ++run) {
      CHECK(r[0].cut.surface_faces == r[run].cut.surface_faces);
      CHECK(r[0].cut.surface_face_to_input == r[run].cut.surface_face_to_input);
      CHECK(r[0].cut.surface_positions == r[run].cut.surface_positions);
      CHECK(r[0].cut.refined_vertex_bary == r[run].cut.refined_vertex_bary);
      CHECK(r[0].cut.cut_faces == r[run].cut.cut_faces);
      CHECK(r[0].cut.cut_to_surface == r[run].cut.cut_to_surface);
      CHECK(r[0].cut.side_vertices == r[run].cut.side_vertices);
      CHECK(r[0].cut.word == r[run].cut.word);
      CHECK(r[0].disk.corner_edge == r[run].disk.corner_edge);
      CHECK(r[0].disk_lengths == r[run].disk_lengths);
      CHECK(r[0].layout.positions == r[run].layout.positions);
    }
  }
}

// The compact domain's side pairings are fitted in parallel (one Ceres problem each): the pairings,
// the canonical generators and the polygon must be the same bit for bit on 1 and 2 threads.
TEST_CASE("uniformize: a closed genus-3 surface's pairings and polygon are the same on 1 and 2 threads") {
  const ReadResult read = read_mesh((ricci_test::fixtures_dir() / "genus3.obj").string());
  REQUIRE(read.status == Status::Ok);
  const ValidateResult v = validate_mesh(read.mesh);
  REQUIRE(v.status == Status::Ok);
  const int saved = omp_get_max_threads();
  UniformizeResult r[2];
  for (int threads = 1; threads <= 2; ++threads) {
    omp_set_num_threads(threads);
    UniformizeOptions o;
    o.seed_checks = 0;
    r[threads - 1] = uniformize(v.mesh, v.topology, o);
    REQUIRE_MESSAGE(r[threads - 1].status == Status::Ok, r[threads - 1].message);
  }
  omp_set_num_threads(saved);
  REQUIRE(r[0].domain_maps.size() == r[1].domain_maps.size());
  REQUIRE(r[0].domain_maps.size() >= 6);
  for (std::size_t k = 0; k < r[0].domain_maps.size(); ++k) {
    CHECK(r[0].domain_maps[k].map.a == r[1].domain_maps[k].map.a);
    CHECK(r[0].domain_maps[k].map.b == r[1].domain_maps[k].map.b);
  }
  REQUIRE(r[0].deck.generators.size() == r[1].deck.generators.size());
  for (std::size_t k = 0; k < r[0].deck.generators.size(); ++k) {
    CHECK(r[0].deck.generators[k].map.a == r[1].deck.generators[k].map.a);
    CHECK(r[0].deck.generators[k].map.b == r[1].deck.generators[k].map.b);
  }
  CHECK(r[0].deck.relation_error == r[1].deck.relation_error);
}
