// ricci — the whole job in one call: a validated mesh in, its uniformization out.
//
//   LoadResult in = load_mesh("kitten.obj");
//   UniformizeResult r = uniformize(in.validated.mesh, in.validated.topology);
//   if (r.status == Status::Ok) use(r.layout.positions, r.cut.cut_faces, r.deck.generators);
//
// Stages (each timed in `timings`, reported through `on_stage`):
//   initial_metric  Step 2 of the paper in the chosen geometry (InitialMetricOptions)
//   target          the target curvature (uniform_target() for the boundary mode unless given),
//                   check_target() before any iteration
//   flow            solve_flow() (Newton by default) to FlowOptions::tolerance, then (polish) up
//                   to two more Newton steps kept only when they lower max |K̄ − K|
//                   (FlowOptions::polish_steps, within the same solve) and up to three chord
//                   steps for the residual's smooth part (FlowOptions::smooth_steps). The default scheme is
//                   vertex scaling with intrinsic Delaunay flips (below)
//   straighten      flips only: the solution carried back to the input (below)
//   cut             closed genus ≥ 2 in H: cut_compact(), a compact fundamental domain; otherwise
//                   cut_surface(): the canonical polygon (genus 1), arcs to the holes (genus 0
//                   with several boundary loops, or genus ≥ 1 with boundary), nothing for a disk;
//                   skipped for a closed genus-0 surface, which is laid out on the sphere directly
//   layout          refined_edge_lengths() + layout_disk() (plane / Poincaré disk) or
//                   layout_sphere()
//   atlas           E and H, only when the layout misses max_layout_error where one chart's
//                   coordinates cannot resolve the faces: layout_atlas() (has_atlas), charts of
//                   their own for those faces (the layout then keeps vertices it could not place,
//                   LayoutOptions::keep_unresolved, for the charts to lay out)
//   seed_check      the layout again from `seed_checks` other seed faces (the first: the face
//                   farthest from the layout's seed), aligned to the layout itself by the fitted
//                   isometry (align_layouts()): seed_independence_error. Laid out once the
//                   layout has passed its gate: before a canonical polygon (closed H) on a second
//                   thread beside the polygon and deck stages, otherwise on all threads after the
//                   angles; reported after the angles
//   polygon         closed genus ≥ 2 in H: the compact domain's side pairings (fit_domain_pairings()),
//                   canonical generators as words in them (canonical_generators(): moves on the
//                   domain's word, no cut of the mesh) and their geodesic 4g-gon (geodesic_polygon(),
//                   has_geodesic_polygon), kept when it is a fundamental domain with the relation to
//                   1e-12; where quad cannot resolve it (its range or floor at the polygon's
//                   reach), the pairings closed again and the same words evaluated in
//                   quad-double (widen_domain_pairings(), evaluate_canonical_words()). With
//                   mesh_polygon, or when that fails short of quad-double's range or floor (then
//                   the domain's pairings stand): a canonical cut_surface() laid out
//                   through the compact domain's tiles (deck_through_domain()), best of several base
//                   vertices (below; has_polygon)
//   deck            the deck generators a1 b1 …: E fit_deck_transformations(); H the products of
//                   the domain's (adjusted) side pairings from the polygon stage — also when the
//                   mesh-path polygon lies beyond double range and only its view is missing
//                   (has_deck, not has_polygon); when no canonical generators exist at all, the
//                   pairings alone (fit_domain_pairings())
//   angles          corner angles of the input against those of the metric (angle_distortion);
//                   on a second thread beside a cut that runs on one thread (the compact domain,
//                   or cut_surface() after the flow), joined here
//
// Vertex scaling with intrinsic Delaunay flips (the default: Scheme::Yamabe with
// intrinsic_flips). The mesh's metric is flipped to its intrinsic Delaunay triangulation
// (mesh_intrinsic_triangulation()), the flow runs with Ptolemy flips (solve_flow_with_flips():
// one solution for every admissible target, Newton from any start), and the input's edges are
// traced over the final triangulation (trace_input_edges()). Back to the input's own faces:
//   - when the input edges made straight in the solution's metric tile it
//     (straight_input_metric(), StraightInputMetric::tiles()), every later stage runs on the
//     input's triangulation with those lengths — the same surface, exactly;
//   - otherwise (a straight input triangle would fold) every later stage runs on the exact
//     common subdivision of the two triangulations (common_subdivision(); `refined` is true and
//     `refinement` holds it: cut, layout, polygon and deck refer to its vertices and faces, the
//     input's vertices first). Its cut prefers the pieces of input edges (weights 100× on the
//     other edges), so seams mostly run along input edges. Its layout (and seed check) develops
//     the final intrinsic Delaunay triangulation's faces, in which the subdivision's pieces lie
//     (CommonSubdivision::frames, LayoutOptions::frames): crossings a hair apart on one edge and
//     the slivers between them never place a vertex. Should that layout fail the accuracy gate
//     (a solve converged only to its curvature resolution: the coarse faces carry its residual),
//     the development through the pieces themselves is tried and kept when it passes.
// Steiner points (steiner.h), in E, S and bordered H. Where the straight input triangles fold and the
// solution's conformal factor jumps by more than steiner_resolution (0.05) across the median input
// edge — one scale per vertex does not resolve the map, and the input's faces cannot carry it — the surface is
// subdivided on its own faces by the levels that bring that jump to the resolution (each halves
// it; at most steiner_max_levels, at most steiner_max_faces faces) and the job runs on the
// subdivision with the same target (steiner_target()), always through the common subdivision,
// whose face_input then names the input's faces; `angles` are measured on the input's corners and
// input_surface_layout() gives the input's own faces. The first solve only measured the jump
// (its stages are in `timings` as probe_initial_metric, probe_target, probe_flow). Should the run
// on the subdivision fail, the input's own run is returned and steiner.note says why. Not on
// closed H surfaces: their canonical polygon's search grows faster than the faces on hard
// surfaces (a random closed genus-11 surface of 1772 faces: its polygon stage 0.3 s on the input,
// 29.7 s on the subdivision, 16 times the faces).
// Boundary splits (steiner.h: split_boundary_edges()). A boundary edge never flips, so where a
// circle or loop-totals target (whose loops cannot be doubled: their targets follow the loops'
// lengths) needs a triangle to fold over a boundary edge — its apex pushed past the chord, as on
// a stretched surface whose circle domain spaces its boundary vertices very unevenly — vertex
// scaling with flips stalls with that triangle's angle opposite the boundary edge at π. Such edges
// (angle above 3π/4 at the last iterate) are split at their midpoints, each triangle into two
// (the surface unchanged, a flat boundary vertex more), and the job runs again on the split surface,
// always through the common subdivision as with Steiner points (steiner.boundary_splits,
// steiner.boundary_split_rounds; the split vertices after the input's); up to
// boundary_split_rounds rounds, each splitting the edges its own stalled solve names and solving
// from its last iterate (a split vertex's u keeps its edge's length). Should every round fail, the
// input's own run with its fallbacks is returned and steiner.note says why — unless that run too
// stops at its flow while a round's flow converged and a later stage stopped it: that failure is
// returned then, its message saying so.
// Chord splits (steiner.h: split_chords()). Where the solve with flips on a bordered surface stops
// and its boundary condition has a double (geodesic, fixed lengths, free: doubled_surface() in
// uniformize.cpp) but an interior edge joins two boundary vertices — the double then glues that
// edge and its mirror copy between the same two vertices and is no surface — every such chord is
// split at its midpoint (a flat interior vertex more, the surface unchanged) and the job runs
// again on the split surface, solved on its double through the common subdivision as with
// Steiner points (steiner.chord_splits; the split vertices after the input's). Should that run
// fail, the input's own run with its fallbacks is returned and steiner.note says why.
// Should the solve with flips fail, the paper's circle packing is solved instead and
// `intrinsic.fallback` says why (a note in flow.notes too). Likewise, with uniformize(), when the
// solve converged only to the curvature resolution of near-coincident vertices
// (FlowResult::resolution_vertices) and a later stage failed on it: the whole job is run again
// with circle packing.
//
// Geometry and boundary mode default to the surface's natural ones (natural_geometry():
// S for closed genus 0, E for χ = 0 and for genus 0 with boundary, H for χ < 0;
// natural_boundary_mode(): circles in E, geodesics in H).
//
// Base candidates (closed, H, the mesh path). Poincaré coordinates resolve hyperbolic distance only to about
// 2^-52 / (1 − |z|²), and the relation of generators whose base point lies far from their axes
// loses digits as e^distance. The canonical polygon's shape depends strongly on the base vertex of
// its loops, so up to `base_candidates` base vertices are tried: the most central vertex (least
// max metric distance to the two ends of a double-sweep diameter), then vertices spread over the
// central quarter by farthest-point sampling. The polygon with the smallest max(relation error,
// edge error, rounding floor) is kept (the search stops at the first below `polygon_tolerance`,
// 1e-9, or when two bases in a row match the best one's score to 1 % — the error is then the
// metric's, not the base's — each base costing a cut and a layout of its own, and gives up after
// three bases none of which could be laid out); `candidates` lists every one tried.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ricci/cut.h"
#include "ricci/deck.h"
#include "ricci/flow.h"
#include "ricci/intrinsic_trace.h"
#include "ricci/layout.h"
#include "ricci/mesh.h"
#include "ricci/metric.h"
#include "ricci/status.h"
#include "ricci/steiner.h"
#include "ricci/topology.h"

namespace ricci {

/// What on_stage receives when a stage ends.
struct StageRecord {
  /// "initial_metric", "target", "flow", "straighten" (with intrinsic flips), "cut", "layout",
  /// "atlas" (only when the layout needs charts), "seed_check", "polygon", "deck" or "angles".
  std::string_view stage;
  double seconds = 0;      ///< time the stage took
  std::string summary;     ///< one line: what it found (e.g. the layout's edge error)
};

/// Options of uniformize() and lay_out_metric().
struct UniformizeOptions {
  /// Background geometry; empty: natural_geometry(topology).
  std::optional<Geometry> geometry;
  /// Boundary mode for surfaces with boundary; empty: natural_boundary_mode(topology, geometry).
  std::optional<BoundaryMode> boundary;
  /// Step 2 options (its `geometry` is overwritten by the geometry chosen above). The scheme
  /// defaults to vertex scaling (Scheme::Yamabe), solved with intrinsic flips (below).
  InitialMetricOptions metric = [] {
    InitialMetricOptions m;
    m.scheme = Scheme::Yamabe;
    return m;
  }();
  /// Vertex scaling (Scheme::Yamabe) with intrinsic Delaunay flips (the header comment). Off: the
  /// flow on the input's triangulation as it is (stops on many non-Delaunay meshes).
  bool intrinsic_flips = true;
  /// Steiner points for conformality (steiner.h; the header comment): E, S and bordered H, with vertex scaling
  /// and flips, where the straight input triangles fold and the solution's median |u_i − u_j| over
  /// the input's edges is above `steiner_resolution`: the surface is subdivided on its own faces by the levels that
  /// bring it there (each halves it), at most `steiner_max_levels` and at most
  /// `steiner_max_faces` faces, and solved again. 0 levels: off.
  int steiner_max_levels = 3;
  double steiner_resolution = 0.05;
  std::int64_t steiner_max_faces = std::int64_t{1} << 16;
  /// Boundary splits (the header comment): where vertex scaling with flips stops on a circle or
  /// loop-totals target because triangles lean over boundary edges (their angle opposite a boundary
  /// edge above 3π/4 at the last iterate), those boundary edges are split at their midpoints and
  /// the job runs again on the split surface, up to this many rounds. 0: off.
  int boundary_split_rounds = 4;
  /// Chord splits (the header comment): where the solve with flips stops and the double that
  /// would mend it is refused by chords (interior edges joining two boundary vertices), split them
  /// and run again. False: off.
  bool split_chords = true;
  /// Newton to max |K̄ − K| < 1e-12 by default.
  FlowOptions flow = [] {
    FlowOptions f;
    f.tolerance = 1e-12;
    return f;
  }();
  /// cut_surface() options, also for the canonical polygon of a closed H surface (base_vertex ≥ 0
  /// there replaces the base candidates). Not used by cut_compact().
  CutOptions cut;
  /// After the flow converged, up to two more Newton steps, kept when they lower max |K̄ − K|.
  bool polish = true;
  /// H (closed): the canonical polygon as a canonical cut of the mesh laid out through the
  /// compact domain (the mesh-path view, polygon.obj; best of `base_candidates` base vertices,
  /// each a cut and a layout: seconds to minutes at genus ≥ 4) instead of the default, the
  /// geodesic 4g-gon of canonical generators found from the domain's side pairings alone
  /// (canonical_generators(), geodesic_polygon(): milliseconds at any genus). The default also
  /// falls back to the mesh path when the geodesic polygon is not a fundamental domain, but not
  /// where quad-double cannot hold it (its generators or corners beyond that range, or its
  /// relation at that floor, after quad's): the domain's pairings then stand.
  bool mesh_polygon = false;
  /// H (closed): base vertices tried for the mesh-path canonical polygon (see the header comment).
  int base_candidates = 8;
  /// H (closed): stop trying base vertices at the first canonical polygon whose max(relation
  /// error, edge error, rounding floor) is below this, or once two bases in a row match the best
  /// score to 1 % (0: try them all).
  double polygon_tolerance = 1e-9;
  /// Options of every layout; the seed check runs them with its own seed faces, no unit box and
  /// refine_above at least 1e-8 (see seed_checks).
  LayoutOptions layout;
  /// Extra seed faces whose layouts are compared with the layout itself: the face farthest from
  /// its seed (in steps across edges), then faces spread over the surface (F/2; or 0 … F−1
  /// evenly). They are laid out once the layout has passed its accuracy gate: on a second thread
  /// beside the polygon and deck stages of a closed hyperbolic surface when two threads are
  /// available (FlowOptions::threads 0 or ≥ 2), otherwise on all threads after the angle
  /// distortion (the layout's own loops keep both cores). A check compares positions,
  /// not the edge lengths at the seam where a propagation's front closes (what the refinement
  /// after it mends), so its layouts are refined only above 1e-8: one propagation within 1e-8 of
  /// its metric places every vertex within about 1e-10 of a refined layout (tools/BENCHMARK-perf-notes.md).
  int seed_checks = 1;
  /// Cut beside the flow: where the layout takes cut_surface()'s disk of the input's own faces
  /// (genus 1 in E, genus 0 with several loops), that cut, which reads no metric, is made on a
  /// second thread while the flow runs, when two threads are available and the input has fewer
  /// than 500000 faces: the cut's time comes off the job. What its result holds during the flow
  /// is the disk's faces and their vertices' origins (14 bytes per face) and what the cut added;
  /// larger inputs, whose cut can outlast the flow's analysis and meet its factor, are cut after
  /// the flow. false: always after the flow.
  bool cut_beside_flow = true;
  /// The layout must reproduce the metric to this relative edge-length error, else the run fails
  /// at the layout stage (NumericalFailure, naming the worst edge and the rounding floor) instead
  /// of returning positions that are not the metric's (e.g. a long strip with a free boundary in E,
  /// whose conformal factor spans more orders of magnitude than double precision holds).
  double max_layout_error = 1e-6;
  /// E and H: when the layout misses that limit where its coordinates cannot resolve the faces
  /// (and the miss is not excused as negligible), the faces are laid out in an atlas of charts
  /// (layout_atlas(); has_atlas), each face to `atlas.limit` in its own chart. false: such a
  /// layout fails as before.
  bool use_atlas = true;
  AtlasOptions atlas;  ///< options of layout_atlas()
  DeckOptions deck;  ///< options of the deck and side-pairing fits
  /// Called when each stage ends (the library never prints). Flow iterations: flow.on_iteration.
  std::function<void(const StageRecord&)> on_stage;

  /// True when base_candidates ≥ 1, seed_checks ≥ 0 and flow, cut, layout and deck are valid;
  /// otherwise false, with the reason in *why (when why is not null). `metric` is checked by
  /// initial_metric().
  bool is_valid(std::string* why) const;
};

/// One base vertex tried for the canonical polygon (H, closed).
struct BaseCandidate {
  Index base_vertex = -1;                              ///< the base used by the cut (the one tried if it failed)
  Index refined_vertices = 0;                          ///< vertices the cut added
  double relation_error = INFINITY;                    ///< of its generators (∞: failed)
  double rounding_floor = INFINITY;                    ///< of its polygon's positions
  double max_edge_length_error = INFINITY;             ///< of its polygon's positions
  double seconds = 0;                                  ///< time spent on this candidate
  std::string note;  ///< why it gave no view of the polygon (empty when it gave one)
};

/// Corner angles of a metric compared with the mesh's own 3D angles (angle_distortion()).
struct AngleDistortion {
  /// Per corner of the input (#F×3): θ_input / θ_metric, the 3D corner angle over the angle of
  /// the conformal metric (the mapped angle: layouts are isometric to the metric). 1 is perfect;
  /// +∞ where the metric's angle is 0 (such corners are left out of the two means). Empty when
  /// the sizes do not match.
  std::vector<double> ratio;
  double mean_abs_log = 0;  ///< mean over corners of |log ratio|
  double max_abs_log = 0;   ///< max over corners of |log ratio|
};

/// What the intrinsic flips did (UniformizeResult::intrinsic).
struct IntrinsicSummary {
  bool used = false;                 ///< the flow ran with intrinsic flips
  std::int64_t delaunay_flips = 0;   ///< geometric flips to the input metric's Delaunay triangulation
  std::int64_t flow_flips = 0;       ///< Ptolemy flips during the solve
  Index crossings = 0;               ///< crossings of input edges with the final triangulation's edges
  /// StraightInputMetric's figures: vertices whose straight angle sums differ, degenerate straight
  /// faces, the largest difference.
  Index inconsistent_vertices = 0;
  Index degenerate_faces = 0;
  double max_angle_sum_error = 0;
  /// The input's edges made straight in the solution's metric tile the surface (no common
  /// subdivision needed).
  bool straight_tiles = false;
  bool refined = false;              ///< the later stages ran on the common subdivision
  /// The solve on the surface stopped and was solved on its double instead (a bordered surface
  /// with geodesic, free or fixed-length boundary: the mesh and its mirror glued along the
  /// boundary, where triangles leaning on the boundary can flip), its straight input triangles
  /// tiling it.
  bool doubled = false;
  /// Non-empty when the solve with flips failed, or converged only to its curvature resolution
  /// and a later stage failed on it: why (circle packing was solved instead).
  std::string fallback;
};

/// What the Steiner points did (UniformizeResult::steiner).
struct SteinerSummary {
  bool used = false;           ///< the result is that of the subdivided surface
  int levels = 0;              ///< midpoint subdivisions (0: none)
  double median_jump = 0;      ///< median |u_i − u_j| over the input's edges, solved on the input
  double refined_median_jump = 0;  ///< the same over the subdivided surface's edges, solved there
  Index vertices_added = 0;    ///< Steiner vertices (after the input's)
  /// Boundary splits (UniformizeOptions::boundary_split_rounds): the rounds run and the boundary
  /// edges split in all (each a Steiner vertex on a boundary edge); 0 when none was needed.
  int boundary_split_rounds = 0;
  Index boundary_splits = 0;
  /// Chord splits (UniformizeOptions::split_chords): the chords split (each a Steiner vertex on
  /// an interior edge); 0 when none was needed.
  Index chord_splits = 0;
  /// Why a subdivision that was asked for is not used (its run failed; the input's run is
  /// returned instead); empty otherwise.
  std::string note;
};

/// What uniformize() and lay_out_metric() return: every stage's result.
struct UniformizeResult {
  /// Ok when every stage that applies succeeded. Otherwise the status of the first stage that
  /// failed (`failed_stage` names it; `message` is its message), and the results of the stages
  /// before it stay filled in.
  Status status = Status::NotRun;
  std::string message = "not run";  ///< "<stage>: <the stage's message>" on failure; "ok" on success
  /// "options", "initial_metric", "target", "flow", "cut", "cut_metric", "layout", "seed_check" or
  /// "deck"; empty unless a stage failed.
  std::string failed_stage;

  Geometry geometry = Geometry::Euclidean;  ///< the geometry used
  BoundaryMode boundary = BoundaryMode::Free;  ///< Free for a closed surface
  /// The power of two the input's positions were multiplied by before the stages
  /// (unit_power_of_two() of the bounding box's largest side): 1 unless that side is shorter than
  /// 2^-100 or longer than 2^100. Exact, so the geometry is the input's; the lengths and euclidean
  /// layouts are in the scaled unit (metric.length_scale includes this factor), 3D positions
  /// (refinement.mesh) in the input's.
  double input_scale = 1;

  InitialMetric metric;  ///< initial_metric() (status NotRun for lay_out_metric())
  Target target;         ///< the target curvature the flow ran to (empty for lay_out_metric())
  /// solve_flow() with any kept polish steps (lay_out_metric(): NotRun, l = lengths). With intrinsic
  /// flips: solve_flow_with_flips(), its `l` replaced by the input's edges made straight
  /// (StraightInputMetric::l, #E of the input).
  FlowResult flow;

  /// Cut (not for a closed genus-0 surface: has_cut false). The disk is
  /// build_topology(cut.cut_faces, cut.num_cut_vertices()) with lengths disk_lengths.
  bool has_cut = false;
  CutResult cut;                          ///< cut_surface(), or cut_compact() for closed genus ≥ 2 in H
  RefinedMetric cut_metric;               ///< the metric on cut's refined surface (refined_edge_lengths())
  Topology disk;                          ///< connectivity of the cut disk
  std::vector<double> disk_lengths;       ///< #E(disk): the disk's edge lengths (disk_edge_lengths())
  std::vector<BaseCandidate> candidates;  ///< closed genus ≥ 2 in H: every base vertex tried

  /// The layout: of the disk (positions per cut vertex, dims 2) or, for a closed genus-0
  /// surface, of the surface on the unit sphere (positions per vertex, dims 3).
  Layout layout;
  /// Edges of `layout` above max_layout_error that the accuracy gate excused: each within
  /// kRoundingAllowance times what its coordinates resolve, their faces at most max_layout_error of
  /// the input's 3D area (the short edges at near-coincident vertices). edges = 0 when none.
  LayoutMisses layout_excused;
  /// E and H: the layout needed more than one chart (UniformizeOptions::use_atlas): `atlas` holds
  /// them, every face resolved to AtlasOptions::limit in its own chart. `layout` stays the root
  /// chart (its positions are what the cut, seed check, polygon, deck and cover use).
  bool has_atlas = false;
  LayoutAtlas atlas;
  /// Max over the extra seeds of the deviation from `layout` after alignment (distance of the
  /// geometry; E: before the unit box). 0 when seed_checks is 0. E and H: over the vertices both
  /// layouts resolve (every edge at them within max_layout_error in each; a propagation from a far
  /// seed may reach where its coordinates resolve nothing), with an atlas only those of the first
  /// chart's faces, and in E then relative to that chart's extent (such a plane layout can span
  /// more orders of magnitude than an absolute distance means anything across).
  double seed_independence_error = 0;
  /// E and H: the fewest vertices a seed check compared (of disk.num_vertices); 0 without checks.
  /// Below 3 that check aligned nothing and added nothing to seed_independence_error.
  Index seed_check_vertices = 0;
  std::vector<Index> seed_faces_checked;  ///< the extra seed faces, in the order they were laid out

  /// Closed genus ≥ 1: the canonical polygon a1 b1 a1^-1 b1^-1 … laid out (E: the cut and layout
  /// above; H: a canonical cut_surface() laid out through the compact domain's tiles,
  /// deck_through_domain(), its errors measured by measure_layout()).
  bool has_polygon = false;
  /// Why has_polygon is false for a closed surface of genus ≥ 2, or, with has_polygon, why its
  /// view is coarse (edge error above 1e-9: how far it reaches); empty otherwise.
  std::string polygon_note;
  CutResult polygon_cut;                ///< the canonical cut (E: a copy of cut)
  Topology polygon_disk;                ///< connectivity of its disk
  std::vector<double> polygon_lengths;  ///< #E(polygon_disk): its edge lengths
  Layout polygon;                       ///< its positions and figures (E: a copy of layout)

  /// Closed genus ≥ 2 in H: the geodesic canonical 4g-gon of `deck` (geodesic_polygon()), its
  /// vertices and frame in the frame of `deck`'s generators (frame = identity); with the default
  /// it is the canonical polygon itself, and `canonical_words` hold each generator as a word in
  /// the compact domain's side pairings (`domain_maps`: x1, x2, …).
  bool has_geodesic_polygon = false;
  GeodesicPolygon geodesic_polygon;
  std::vector<std::string> canonical_words;

  /// Deck transformations of the canonical polygon (closed genus ≥ 1), in the frame of `polygon`
  /// (E: that of `layout`; H: DomainDeck::polygon_frame, the polygon centred; with the geodesic
  /// polygon, the frame where it is centred).
  bool has_deck = false;
  DeckResult deck;  ///< valid when has_deck
  /// H: the compact domain's side pairings (Ceres fits), the largest deviation from the identity
  /// of their products around the domain's vertex cycles, and the tile consistency.
  std::vector<DeckGenerator> domain_maps;  ///< H: the side pairings x1, x2, … (DomainDeck::side_maps)
  double domain_cycle_error = 0;           ///< H: DomainDeck::cycle_error (pairings as fitted)
  double domain_adjusted_cycle_error = 0;  ///< H: DomainDeck::adjusted_cycle_error
  double domain_pairing_adjustment = 0;    ///< H: DomainDeck::pairing_adjustment
  double fitted_relation_error = 0;        ///< H with generators: DomainDeck::fitted_relation_error
  double tile_consistency = 0;             ///< H with generators: DomainDeck::tile_consistency

  AngleDistortion angles;  ///< angle_distortion() of the final metric (on the input's corners)

  IntrinsicSummary intrinsic;  ///< the intrinsic flips, when used
  /// Steiner points (UniformizeOptions::steiner_max_levels). When steiner.used, every stage from
  /// initial_metric on ran on `steiner_mesh` (metric, target, flow and intrinsic refer to its
  /// vertices and edges, the input's vertices first), always through the common subdivision,
  /// whose face_input names the input's faces (the user's), and `angles` are on the input's corners.
  SteinerSummary steiner;
  SteinerMesh steiner_mesh;
  /// When intrinsic.refined: the common subdivision the stages from `cut` on ran on.
  CommonSubdivision refinement;

  /// Seconds per stage, in order.
  std::vector<std::pair<std::string, double>> timings;
  double seconds = 0;  ///< wall-clock time of the whole call

  /// One line: status, geometry, iterations, curvature error, layout error, flips, relation.
  std::string brief_report() const;
};

/// Runs the stages at the top of this header on a validated mesh (validate_mesh() / load_mesh()).
/// `target`: the target curvature; nullptr for uniform_target() with the boundary mode.
/// Deterministic for fixed options (OpenMP loops included).
UniformizeResult uniformize(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options = {},
                            const Target* target = nullptr);

/// The stages up to the metric alone: initial_metric, target, flow and, with intrinsic flips,
/// straighten without the common subdivision — what `ricci flow` runs. flow.u, flow.K are per
/// vertex; flow.l are the input's edges' lengths (with flips: made straight in the solution's
/// metric; intrinsic.straight_tiles says whether those straight triangles tile the surface, which
/// a layout of them needs). Status Ok when the flow converged; `cut`, `layout` and later stay
/// empty. Fallback to circle packing as uniformize(). Deterministic for fixed options.
UniformizeResult conformal_metric(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options = {},
                                  const Target* target = nullptr);

/// The stages from `cut` on for a metric given by its edge lengths (#E, in `geometry`; e.g. read
/// back from a file `ricci flow -o` wrote): flow stays empty (status NotRun, l = lengths).
UniformizeResult lay_out_metric(const Mesh& mesh, const Topology& topology, Geometry geometry,
                                std::span<const double> lengths, const UniformizeOptions& options = {});

/// The input's own mesh mapped through a layout of the common subdivision (intrinsic.refined).
struct InputSurfaceLayout {
  /// Ok; InvalidArgument when r has no refined layout or does not match the mesh.
  Status status = Status::NotRun;
  std::string message = "not run";
  /// The input's vertices and faces, in their order. Closed genus 0: positions on the unit sphere
  /// (the layout's), no texture coordinates. Otherwise the input's positions with per-corner
  /// texture coordinates: the layout of the copy of each corner's vertex in that face's pieces
  /// (texcoords are the layout's positions per cut vertex of the subdivision).
  Mesh mesh;
  /// Input faces whose straight triangle through those three points is negatively oriented or
  /// degenerate (E: signed area; H: signed area in Klein coordinates; S: det(x_i, x_j, x_k)),
  /// the smallest of them (kInvalid when none).
  Index flipped_faces = 0;
  Index first_flipped_face = kInvalid;
  /// With an atlas (r.has_atlas): #F, the chart of each input face's texture coordinates (the
  /// chart of the piece holding its corner 0; corners whose pieces lie in other charts are carried
  /// over by chart_to_chart()), and one texture coordinate per corner. Empty otherwise.
  std::vector<Index> face_chart;
};

/// The input mesh laid out through the common subdivision of a refined result (r.intrinsic.refined,
/// r.status Ok): see InputSurfaceLayout. O(#F of the subdivision).
InputSurfaceLayout input_surface_layout(const Mesh& mesh, const Topology& topology, const UniformizeResult& r);

/// Corner-angle distortion of a metric (lengths `l` #E in geometry g) against the mesh's own 3D
/// angles (see AngleDistortion).
AngleDistortion angle_distortion(const Mesh& mesh, const Topology& topology, Geometry g, std::span<const double> l);

}  // namespace ricci
