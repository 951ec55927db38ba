// ricci — the whole job: metric, flow, cut, layout, seed check, deck maps, angle distortion.
#include "ricci/uniformize.h"

#include "crowding.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <numbers>
#include <numeric>
#include <omp.h>
#include <optional>
#include <queue>
#include <thread>
#include <utility>

namespace ricci {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxFlipIterations = 60;

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string sci(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

/// Dijkstra distances over the mesh edges with lengths l from `source`.
std::vector<double> distances(const Topology& t, std::span<const Index> faces, std::span<const double> l, Index source) {
  std::vector<double> d(static_cast<std::size_t>(t.num_vertices), kInf);
  using Item = std::pair<double, Index>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> pq;
  d[source] = 0;
  pq.push({0.0, source});
  while (!pq.empty()) {
    const auto [du, u] = pq.top();
    pq.pop();
    if (du > d[u]) continue;
    for (Index k = t.vertex_corner_offsets[u]; k < t.vertex_corner_offsets[u + 1]; ++k) {
      const Index c = t.vertex_corners[k];
      // Both edges of the corner at u: to the next and to the previous corner's vertex.
      const Index cn = next_corner(c), cp = prev_corner(c);
      const std::pair<Index, Index> hops[2] = {{faces[cn], t.corner_edge[cp]}, {faces[cp], t.corner_edge[cn]}};
      for (const auto& [w, e] : hops) {
        const double nd = du + l[e];
        if (nd < d[w]) {
          d[w] = nd;
          pq.push({nd, w});
        }
      }
    }
  }
  return d;
}

/// Base vertices to try (see the header comment): the most central vertex first, then farthest
/// points within the central quarter.
std::vector<Index> base_candidates(const Topology& t, std::span<const Index> faces, std::span<const double> l,
                                   int count) {
  const Index V = t.num_vertices;
  std::vector<Index> out;
  if (V == 0 || count <= 0) return out;
  auto farthest = [&](const std::vector<double>& d) {
    Index best = 0;
    for (Index v = 0; v < V; ++v)
      if (std::isfinite(d[v]) && d[v] > d[best]) best = v;
    return best;
  };
  const Index a = farthest(distances(t, faces, l, 0));
  const std::vector<double> da = distances(t, faces, l, a);
  const Index b = farthest(da);
  const std::vector<double> db = distances(t, faces, l, b);
  std::vector<Index> order;
  for (Index v = 0; v < V; ++v)
    if (!t.is_boundary_vertex(v)) order.push_back(v);
  if (order.empty()) return out;
  auto ecc = [&](Index v) { return std::max(da[v], db[v]); };
  std::stable_sort(order.begin(), order.end(), [&](Index x, Index y) { return ecc(x) < ecc(y); });
  const std::size_t keep = std::max<std::size_t>(1, order.size() / 4);
  order.erase(order.begin() + static_cast<std::ptrdiff_t>(keep), order.end());
  out.push_back(order.front());
  std::vector<double> near = distances(t, faces, l, order.front());
  while (static_cast<int>(out.size()) < count) {
    Index best = kInvalid;
    for (Index v : order)
      if (std::isfinite(near[v]) && near[v] > 0 && (best == kInvalid || near[v] > near[best])) best = v;
    if (best == kInvalid) break;
    out.push_back(best);
    const std::vector<double> d = distances(t, faces, l, best);
    for (Index v = 0; v < V; ++v) near[v] = std::min(near[v], d[v]);
  }
  return out;
}

// The cut disk's connectivity, built once: the cut's own (moved out of it), else the surface's
// when the disk is the surface itself (nothing cut), else built from cut_faces.
TopologyResult take_disk_topology(CutResult& cut, const Topology* surface) {
  TopologyResult out;
  if (is_topology_of(cut.disk_topology, cut.cut_faces, cut.num_cut_vertices())) {
    out.status = Status::Ok;
    out.topology = std::move(cut.disk_topology);
    cut.disk_topology = Topology{};
  } else if (surface != nullptr && is_topology_of(*surface, cut.cut_faces, cut.num_cut_vertices())) {
    out.status = Status::Ok;
    out.topology = *surface;
  } else {
    out = build_topology(cut.cut_faces, cut.num_cut_vertices());
  }
  return out;
}

struct DiskBuild {
  CutResult cut;
  RefinedMetric metric;
  Topology disk;
  std::vector<double> lengths;
  Status status = Status::NotRun;
  std::string message;
  std::string stage;
};

// True when the run has a second thread for work beside its own (FlowOptions::threads 0 or ≥ 2,
// at most available_threads()): the cut beside the flow, the angle distortion beside a cut made
// after it, the seed check beside the canonical polygon's stages.
bool second_thread(const UniformizeOptions& options) {
  const int t = options.flow.threads;
  return (t > 0 ? std::min(t, available_threads()) : available_threads()) >= 2;
}

// The cones of a target K̄: interior vertices (among the first min(#V, K.size())) with K̄ ≠ 0.
std::vector<Index> cone_vertices(const Topology& topology, std::span<const double> K) {
  std::vector<Index> cones;
  for (Index v = 0; v < std::min<Index>(topology.num_vertices, static_cast<Index>(K.size())); ++v)
    if (!topology.is_boundary_vertex(v) && std::abs(K[v]) > 1e-12) cones.push_back(v);
  return cones;
}

// A cut's surface (CutResult::surface_faces, surface_face_to_input, surface_positions) is the
// input's faces and positions with a few faces rewritten and the refined vertices' faces and
// positions appended. Held beside the flow as that difference: what the cut holds there is then
// its disk's faces and their vertices' origins (14 bytes per face) and the refinement's part.
struct SurfaceDiff {
  bool held = false;
  std::vector<Index> rewritten;          // input faces the cut rewrote
  std::vector<Index> rewritten_corners;  // their three vertices each, as the cut has them
  std::vector<Index> appended_faces;  // surface_faces beyond the input's
  std::vector<Index> appended_origin; // surface_face_to_input beyond the input's faces
  std::vector<double> appended_positions;
};

// Moves the cut's surface into `diff` when it has that form (else leaves the cut as it is).
void compact_surface(const Mesh& mesh, const Topology& t, CutResult& c, SurfaceDiff& diff) {
  const std::size_t F = static_cast<std::size_t>(t.num_faces);
  if (c.surface_faces.size() < 3 * F || c.surface_face_to_input.size() < F ||
      c.surface_faces.size() != 3 * c.surface_face_to_input.size() ||
      c.surface_positions.size() < mesh.positions.size() ||
      !std::equal(mesh.positions.begin(), mesh.positions.end(), c.surface_positions.begin()))
    return;
  for (std::size_t f = 0; f < F; ++f)
    if (c.surface_face_to_input[f] != static_cast<Index>(f)) return;
  for (std::size_t f = 0; f < F; ++f)
    if (!std::equal(mesh.faces.begin() + 3 * f, mesh.faces.begin() + 3 * f + 3, c.surface_faces.begin() + 3 * f)) {
      diff.rewritten.push_back(static_cast<Index>(f));
      diff.rewritten_corners.insert(diff.rewritten_corners.end(), c.surface_faces.begin() + 3 * f,
                                    c.surface_faces.begin() + 3 * f + 3);
    }
  diff.appended_faces.assign(c.surface_faces.begin() + 3 * F, c.surface_faces.end());
  diff.appended_origin.assign(c.surface_face_to_input.begin() + F, c.surface_face_to_input.end());
  diff.appended_positions.assign(c.surface_positions.begin() + mesh.positions.size(), c.surface_positions.end());
  for (std::vector<Index>* v : {&c.surface_faces, &c.surface_face_to_input}) std::vector<Index>().swap(*v);
  std::vector<double>().swap(c.surface_positions);
  diff.held = true;
}

// The cut's surface again from the input and `diff` (compact_surface()).
void expand_surface(const Mesh& mesh, const Topology& t, SurfaceDiff& diff, CutResult& c) {
  const std::size_t F = static_cast<std::size_t>(t.num_faces);
  c.surface_faces = mesh.faces;
  for (std::size_t i = 0; i < diff.rewritten.size(); ++i)
    for (std::size_t j = 0; j < 3; ++j)
      c.surface_faces[3 * static_cast<std::size_t>(diff.rewritten[i]) + j] = diff.rewritten_corners[3 * i + j];
  c.surface_faces.insert(c.surface_faces.end(), diff.appended_faces.begin(), diff.appended_faces.end());
  c.surface_face_to_input.resize(F);
  std::iota(c.surface_face_to_input.begin(), c.surface_face_to_input.end(), Index{0});
  c.surface_face_to_input.insert(c.surface_face_to_input.end(), diff.appended_origin.begin(), diff.appended_origin.end());
  c.surface_positions = mesh.positions;
  c.surface_positions.insert(c.surface_positions.end(), diff.appended_positions.begin(), diff.appended_positions.end());
  diff = SurfaceDiff{};
}

// Inputs this large are cut after the flow (UniformizeOptions::cut_beside_flow). Beside it, on two
// threads of one core (the machine of tools/BENCHMARK-pipeline.md), the cut of a 2M-face torus
// took 2-3x its time alone and outlasted the flow's analysis, and its working memory met the
// factor: the peak 2380 → 2616 MB, the job from 3.3 s slower to 6.6 s faster in alternated runs.
constexpr Index kCutBesideMaxFaces = 500000;

// A cut of (mesh, topology) made beside the flow (cut_beside_flow()): cut_surface() reads the
// connectivity and the 3D positions, not the metric, so on a second core it overlaps the flow's
// factorizations (which leave that core idle) and the cut stage only waits for it.
struct CutBeside {
  const Mesh* mesh = nullptr;
  const Topology* topology = nullptr;
  std::optional<CutResult> cut;  // set by the worker; empty when it ran out of memory
  // The disk's central face (the layout's default seed) and the face farthest from it (the first
  // seed check's), found there too (kInvalid: not found).
  Index central = kInvalid, farthest = kInvalid;
  // The cut's surface held as its difference from the input (compact_surface()): take() builds
  // it again.
  SurfaceDiff diff;
  std::jthread worker;           // last: joined before `cut` is destroyed

  // The cut, once the worker is done, when it was made of exactly this mesh and topology; else null.
  CutResult* take(const Mesh& m, const Topology& t) {
    if (worker.joinable()) worker.join();
    if (mesh != &m || topology != &t || !cut) return nullptr;
    if (diff.held) expand_surface(m, t, diff, *cut);
    return &*cut;
  }
};

/// cut → metric on the cut → the disk's connectivity and lengths, for one set of cut options.
/// With `beside`: the cut already made of (mesh, topology) with those options, moved from.
DiskBuild build_disk(const Mesh& mesh, const Topology& topology, Geometry g, std::span<const double> l,
                     const CutOptions& co, CutResult* beside = nullptr) {
  DiskBuild d;
  d.cut = beside != nullptr ? std::move(*beside) : cut_surface(mesh, topology, co);
  if (d.cut.status != Status::Ok) {
    d.status = d.cut.status;
    d.message = d.cut.message;
    d.stage = "cut";
    return d;
  }
  d.metric = refined_edge_lengths(d.cut, topology, g, l);
  d.cut.surface_topology = Topology{};  // d.metric.surface has it
  if (d.metric.status != Status::Ok) {
    d.status = d.metric.status;
    d.message = d.metric.message;
    d.stage = "cut_metric";
    return d;
  }
  TopologyResult disk = take_disk_topology(d.cut, &d.metric.surface);
  if (disk.status != Status::Ok) {
    d.status = Status::NumericalFailure;
    d.message = "the cut disk is not a valid mesh: " + disk.message;
    d.stage = "cut_metric";
    return d;
  }
  d.disk = std::move(disk.topology);
  d.lengths = disk_edge_lengths(d.cut, d.metric.surface, d.metric.l, d.disk);
  d.status = Status::Ok;
  return d;
}

void layout_stages(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                   std::span<const double> metric_l, UniformizeResult& r, Clock::time_point start,
                   const FaceFrames* frames = nullptr, CutBeside* cut_beside = nullptr);

// AngleDistortion of the metric's corner angles tm (#F×3) against the mesh's 3D angles.
AngleDistortion distortion_of_angles(const Mesh& mesh, const Topology& topology, std::span<const double> tm) {
  AngleDistortion a;
  const Index F = topology.num_faces;
  const std::vector<double> l3 = mesh_edge_lengths(mesh, topology);
  std::vector<double> t3(static_cast<std::size_t>(3 * F));
  corner_angles(topology, Geometry::Euclidean, l3, t3);
  a.ratio.resize(static_cast<std::size_t>(3 * F));
  // In fixed chunks of corners, summed in chunk order: the same mean on any thread count.
  constexpr Index kChunk = 16384;
  const Index chunks = (3 * F + kChunk - 1) / kChunk;
  std::vector<double> chunk_sum(static_cast<std::size_t>(chunks), 0.0), chunk_max(chunk_sum.size(), 0.0);
  std::vector<Index> chunk_n(chunk_sum.size(), 0);
#pragma omp parallel for schedule(static) if (chunks >= 4)
  for (Index k = 0; k < chunks; ++k) {
    double sum = 0, max = 0;
    Index n = 0;
    for (Index c = k * kChunk; c < std::min<Index>(3 * F, (k + 1) * kChunk); ++c) {
      const double r = tm[c] > 0 ? t3[c] / tm[c] : kInf;
      a.ratio[c] = r;
      if (!(r > 0) || !std::isfinite(r)) continue;
      const double x = std::abs(std::log(r));
      sum += x;
      ++n;
      max = std::max(max, x);
    }
    chunk_sum[k] = sum, chunk_max[k] = max, chunk_n[k] = n;
  }
  double sum = 0;
  Index n = 0;
  for (Index k = 0; k < chunks; ++k) {
    sum += chunk_sum[k];
    n += chunk_n[k];
    a.max_abs_log = std::max(a.max_abs_log, chunk_max[k]);
  }
  a.mean_abs_log = n > 0 ? sum / n : 0;
  return a;
}

// Angle opposite a boundary edge above which its triangle leans over it (leaning_boundary_edges()).
constexpr double kLeaningAngle = 0.75 * std::numbers::pi;

// The boundary edges of a stopped solve's last iterate (its triangulation `tri`, lengths l) whose
// triangle leans over them: the angle opposite the edge above kLeaningAngle (π where the apex
// reached the chord). Boundary edges never flip, so their indices are the input topology's.
std::vector<Index> leaning_boundary_edges(const IntrinsicTriangulation& tri, std::span<const double> l) {
  const Topology& t = tri.topology;
  std::vector<Index> out;
  if (l.size() != static_cast<std::size_t>(t.num_edges)) return out;
  std::vector<double> theta(static_cast<std::size_t>(t.num_corners()));
  corner_angles(t, tri.geometry, l, theta);
  for (const Index c : t.boundary_corners)
    if (theta[c] > kLeaningAngle) out.push_back(t.corner_edge[c]);
  std::sort(out.begin(), out.end());
  return out;
}

// Vertex scaling with intrinsic flips: the mesh's intrinsic Delaunay triangulation, then the
// solve with Ptolemy flips from u = 0 (r.target, options fo), or from `start` (#V) when given —
// and from 0 after all should that start give no step. True when it converged (r.flow, tri and
// r.intrinsic filled in). False with r.status set when the triangulation could not be made;
// false with r.intrinsic.fallback (and a note in r.flow.notes) when the solve failed, and then in
// `leaning` (loop targets) the boundary edges leaning_boundary_edges() finds and in `last_u` the
// solve's last iterate.
bool flow_with_flips(const Mesh& mesh, const Topology& topology, const FlowOptions& fo, double mollify_margin,
                     UniformizeResult& r, IntrinsicTriangulation& tri, std::vector<Index>* leaning = nullptr,
                     std::span<const double> start = {}, std::vector<double>* last_u = nullptr) {
  r.intrinsic.used = true;
  IntrinsicResult ir = mesh_intrinsic_triangulation(mesh, topology, r.geometry, mollify_margin);
  if (ir.status != Status::Ok) {
    r.status = ir.status;
    r.failed_stage = "initial_metric";
    r.message = "initial_metric: " + ir.message;
    return false;
  }
  r.intrinsic.delaunay_flips = ir.delaunay_flips;
  const std::vector<double> u0(static_cast<std::size_t>(topology.num_vertices), 0.0);
  // Newton with flips converges in a few steps where it converges at all (≤ 12 on every shared
  // mesh): past kMaxFlipIterations the fallback is cheaper than more steps.
  FlowOptions capped = fo;
  capped.max_iterations = std::min(fo.max_iterations, kMaxFlipIterations);
  const bool warm = start.size() == u0.size();
  // Only a warm start keeps the Delaunay triangulation for a second solve from u = 0 (one copy
  // of the triangulation less while the flow peaks: 89 MB at 827k faces).
  if (warm)
    tri = ir.triangulation;
  else
    tri = std::move(ir.triangulation);
  FlowResult f = solve_flow_with_flips(tri, warm ? start : std::span<const double>(u0), r.target, capped);
  if (warm && f.status != Status::Ok && f.iterations == 0) {
    tri = std::move(ir.triangulation);
    f = solve_flow_with_flips(tri, u0, r.target, capped);
  }
  r.intrinsic.flow_flips = f.flips;
  if (f.status == Status::Ok) {
    r.flow = std::move(f);
    return true;
  }
  r.intrinsic.used = false;
  if (leaning && !r.target.loop_total.empty()) *leaning = leaning_boundary_edges(tri, f.l);
  if (last_u) *last_u = f.u;
  r.flow.status = f.status;
  r.flow.notes = f.notes;
  r.intrinsic.fallback = "vertex scaling with intrinsic flips stopped (" + std::string(status_name(f.status)) + ": " +
                         f.message + ")";
  r.flow.notes.push_back(r.intrinsic.fallback + "; the paper's circle packing was solved instead");
  return false;
}

// The double of a bordered surface: the mesh and its mirror image (faces reversed) glued along the
// boundary, boundary vertices shared, the mirror's other vertices appended in order. A boundary
// condition that is local — geodesic or free (K̄ per boundary vertex: 2K̄ in the double, whose
// angle there is twice the surface's) or fixed lengths (u held) — makes its target symmetric, and
// the unique solution of the double is the surface's, mirrored. Vertex scaling with flips needs this
// where triangles lean on the boundary: a boundary edge never flips, so a triangle whose angle
// opposite it grows towards π cannot be mended on the surface, while in the double that edge is
// an ordinary one (the Delaunay condition of the theory with boundary is the double's).
struct DoubledSurface {
  Mesh mesh;
  Topology topology;
  Target target;
  std::vector<Index> mirror;  // #V: each vertex's mirror copy (itself on the boundary)
};

// An interior edge joining two boundary vertices (a chord), or kInvalid: in the double it and its
// mirror copy join the same two vertices, so the glued double is not a surface there.
Index boundary_chord(const Topology& topology) {
  const std::vector<Index> chords = find_chords(topology);  // steiner.h
  return chords.empty() ? kInvalid : chords.front();
}

// Whether the boundary condition of `target` on a bordered surface has a double (above).
bool has_double(const Topology& topology, const Target& target) {
  return !topology.is_closed() && target.loop_total.empty() &&
         (target.boundary == BoundaryMode::Geodesic || target.boundary == BoundaryMode::FixedLengths ||
          target.boundary == BoundaryMode::Free);
}

bool doubled_surface(const Mesh& mesh, const Topology& topology, const Target& target, DoubledSurface& d,
                     std::string& why) {
  if (!has_double(topology, target)) return false;  // no double for this condition (`why` stays empty)
  const Index nv = topology.num_vertices;
  d.mesh = mesh;
  d.mesh.texcoords.clear();
  d.mesh.corner_texcoords.clear();
  d.mirror.resize(static_cast<std::size_t>(nv));
  for (Index v = 0; v < nv; ++v) {
    if (topology.is_boundary_vertex(v)) {
      d.mirror[v] = v;
      continue;
    }
    d.mirror[v] = d.mesh.num_vertices();
    d.mesh.positions.insert(d.mesh.positions.end(), mesh.positions.begin() + 3 * v, mesh.positions.begin() + 3 * v + 3);
  }
  for (Index f = 0; f < topology.num_faces; ++f)
    d.mesh.faces.insert(d.mesh.faces.end(), {d.mirror[mesh.faces[3 * f]], d.mirror[mesh.faces[3 * f + 2]],
                                             d.mirror[mesh.faces[3 * f + 1]]});
  TopologyResult tr = build_topology(d.mesh.faces, d.mesh.num_vertices());
  if (tr.status != Status::Ok || !tr.topology.is_closed()) {
    const Index chord = boundary_chord(topology);
    why = chord != kInvalid ? "the double is not a surface: the interior edge from vertex " +
                                  std::to_string(topology.edge_vertices[2 * chord]) + " to vertex " +
                                  std::to_string(topology.edge_vertices[2 * chord + 1]) +
                                  " joins two boundary vertices, and so would its mirror copy"
                            : "the double is not a closed surface (" + tr.message + ")";
    return false;
  }
  d.topology = std::move(tr.topology);
  const Index nd = d.topology.num_vertices;
  d.target.boundary = BoundaryMode::Free;
  d.target.K.assign(static_cast<std::size_t>(nd), 0.0);
  if (!target.fixed_u.empty()) d.target.fixed_u.assign(static_cast<std::size_t>(nd), 0);
  for (Index v = 0; v < nv; ++v) {
    const bool b = topology.is_boundary_vertex(v);
    d.target.K[v] = b ? 2 * target.K[v] : target.K[v];
    d.target.K[d.mirror[v]] = d.target.K[v];
    if (!target.fixed_u.empty()) d.target.fixed_u[v] = d.target.fixed_u[d.mirror[v]] = target.fixed_u[v];
  }
  return true;
}

// The part of the double's common subdivision that lies in the surface (its input faces come
// first in the double): the surface's vertices keep their indices, the crossings on its input
// edges follow in order; lengths and input edges carried over corner by corner.
CommonSubdivision restrict_to_surface(const CommonSubdivision& cs, const Topology& topology, const DoubledSurface& d) {
  CommonSubdivision out;
  const Index nv = topology.num_vertices, nf = topology.num_faces;
  std::vector<Index> renumber(static_cast<std::size_t>(cs.topology.num_vertices), kInvalid);
  for (Index v = 0; v < nv; ++v) renumber[v] = v;
  Index next = nv;
  std::vector<Index> kept;
  for (Index f = 0; f < cs.topology.num_faces; ++f) {
    if (cs.face_input[f] >= nf) continue;
    kept.push_back(f);
    for (int c = 0; c < 3; ++c) {
      const Index v = cs.mesh.faces[3 * f + c];
      if (renumber[v] == kInvalid) renumber[v] = next++;
    }
  }
  // The double's input edge of each of the surface's edges (corner by corner: faces come first).
  std::vector<Index> edge_of_double(static_cast<std::size_t>(d.topology.num_edges), kInvalid);
  for (Index c = 0; c < 3 * nf; ++c) edge_of_double[d.topology.corner_edge[c]] = topology.corner_edge[c];
  out.mesh.positions.resize(3 * static_cast<std::size_t>(next));
  out.vertex_input_edge.assign(static_cast<std::size_t>(next), kInvalid);
  for (Index v = 0; v < cs.topology.num_vertices; ++v) {
    const Index w = renumber[v];
    if (w == kInvalid) continue;
    for (int k = 0; k < 3; ++k) out.mesh.positions[3 * w + k] = cs.mesh.positions[3 * v + k];
    if (v >= d.topology.num_vertices) {
      const Index e = edge_of_double[cs.vertex_input_edge[v]];
      if (e == kInvalid) {
        out.status = Status::NumericalFailure;
        out.message = "a crossing of the double's common subdivision in the surface lies on the mirror's edge";
        return out;
      }
      out.vertex_input_edge[w] = e;
    }
  }
  // Frames: the double's current triangulation stays the coarse one (the surface's faces are
  // adjacent only where their current faces are).
  out.frames.frame_lengths = cs.frames.frame_lengths;
  out.frames.frame_opposite = cs.frames.frame_opposite;
  for (Index f : kept) {
    for (int c = 0; c < 3; ++c) out.mesh.faces.push_back(renumber[cs.mesh.faces[3 * f + c]]);
    out.face_input.push_back(cs.face_input[f]);
    out.frames.face_frame.push_back(cs.frames.face_frame[f]);
    out.frames.corner_model.insert(out.frames.corner_model.end(), cs.frames.corner_model.begin() + 9 * f,
                                   cs.frames.corner_model.begin() + 9 * (f + 1));
  }
  TopologyResult tr = build_topology(out.mesh.faces, next);
  if (tr.status != Status::Ok) {
    out.status = Status::NumericalFailure;
    out.message = "the surface's part of the double's common subdivision is not a valid mesh: " + tr.message;
    return out;
  }
  out.topology = std::move(tr.topology);
  out.l.assign(static_cast<std::size_t>(out.topology.num_edges), 0.0);
  for (std::size_t i = 0; i < kept.size(); ++i)
    for (int c = 0; c < 3; ++c)
      out.l[out.topology.corner_edge[3 * i + c]] = cs.l[cs.topology.corner_edge[3 * kept[i] + c]];
  out.status = Status::Ok;
  out.message = "ok";
  return out;
}

// Input-edge crossings per face of the double past which flow_on_double() gives up (below).
constexpr std::int64_t kMaxDoubleCrossings = 16;

// Vertex scaling with flips on the double of a bordered surface (doubled_surface()): the
// solution restricted to the surface — u at its vertices, its boundary curvatures halved — and
// the lengths of its edges made straight in that metric; where the straight input triangles of
// the double do not tile it, `refinement` is the surface's part of the double's common
// subdivision (always, with `always_refine`). False when any step fails (the caller falls back as
// before; `why` says which, and stays empty when the boundary condition has no double).
// r.flow, r.intrinsic and the notes are filled in on success.
bool flow_on_double(const Mesh& mesh, const Topology& topology, const FlowOptions& fo, double mollify_margin,
                    bool always_refine, UniformizeResult& r, CommonSubdivision& refinement, std::string& why) {
  DoubledSurface d;
  if (!doubled_surface(mesh, topology, r.target, d, why)) return false;
  IntrinsicResult ir = mesh_intrinsic_triangulation(d.mesh, d.topology, r.geometry, mollify_margin);
  if (ir.status != Status::Ok) {
    why = "its intrinsic triangulation failed (" + ir.message + ")";
    return false;
  }
  IntrinsicTriangulation tri = std::move(ir.triangulation);
  FlowOptions capped = fo;
  capped.max_iterations = std::min(fo.max_iterations, kMaxFlipIterations);
  const std::vector<double> u0(static_cast<std::size_t>(d.topology.num_vertices), 0.0);
  FlowResult f = solve_flow_with_flips(tri, u0, d.target, capped);
  if (f.status != Status::Ok) {
    why = "the flow stopped there (" + std::string(status_name(f.status)) + ": " + f.message + ")";
    return false;
  }
  // The input's edges cross the final triangulation this many times (their normal coordinates):
  // tracing and subdividing cost that much. Past kMaxDoubleCrossings per face of the double the
  // caller's fallback is the better deal (a 7.4k-face surface stretched 54:1, tools/
  // random_surface_sweep's seed 27, grew past 24 GB in the trace and subdivision without it).
  std::int64_t crossings = 0;
  for (const std::int64_t n : tri.normal) crossings += std::max<std::int64_t>(n, 0);
  if (crossings > kMaxDoubleCrossings * static_cast<std::int64_t>(d.topology.num_faces)) {
    why = "its input edges cross the flipped triangulation " + std::to_string(crossings) +
          " times, past the limit of " + std::to_string(kMaxDoubleCrossings) + " per face";
    return false;
  }
  const InputEdgePaths paths = trace_input_edges(tri, d.topology);
  if (paths.status != Status::Ok) {
    why = "tracing its input edges failed (" + paths.message + ")";
    return false;
  }
  const StraightInputMetric straight = straight_input_metric(tri, f.u, d.topology, paths);
  if (straight.status != Status::Ok) {
    why = "straightening its input edges failed (" + straight.message + ")";
    return false;
  }
  if (!straight.tiles() || always_refine) {
    const std::vector<double> t =
        straightest_crossings(tri, paths, straight.crossings, input_edge_crossings(tri, f.u, paths));
    const CommonSubdivision cs = common_subdivision(tri, f.u, d.mesh, d.topology, paths, t);
    if (cs.status != Status::Ok) {
      why = "its common subdivision failed (" + cs.message + ")";
      return false;
    }
    refinement = restrict_to_surface(cs, topology, d);
    if (refinement.status != Status::Ok) {
      why = "restricting its common subdivision to the surface failed (" + refinement.message + ")";
      return false;
    }
  }
  // Back to the surface: its vertices keep their indices in the double, its faces come first.
  const Index nv = topology.num_vertices;
  FlowResult g = f;
  g.u.assign(f.u.begin(), f.u.begin() + nv);
  g.K.assign(f.K.begin(), f.K.begin() + nv);
  g.K_target.assign(f.K_target.begin(), f.K_target.begin() + nv);
  g.max_curvature_error = 0;
  for (Index v = 0; v < nv; ++v) {
    if (topology.is_boundary_vertex(v)) {
      g.K[v] /= 2;
      g.K_target[v] /= 2;
    }
    // A vertex that holds its u (a fixed boundary) has no curvature condition, as in the flow.
    if (!d.target.fixed_u.empty() && d.target.fixed_u[v]) continue;
    g.max_curvature_error = std::max(g.max_curvature_error, std::abs(g.K[v] - g.K_target[v]));
  }
  g.l.assign(static_cast<std::size_t>(topology.num_edges), 0.0);
  for (Index c = 0; c < 3 * topology.num_faces; ++c) g.l[topology.corner_edge[c]] = straight.l[d.topology.corner_edge[c]];
  r.flow = std::move(g);
  r.intrinsic.used = true;
  r.intrinsic.delaunay_flips = ir.delaunay_flips;
  r.intrinsic.flow_flips = f.flips;
  r.intrinsic.crossings = static_cast<Index>(paths.crossed_edge.size());
  r.intrinsic.inconsistent_vertices = straight.inconsistent_vertices;
  r.intrinsic.degenerate_faces = straight.degenerate_faces;
  r.intrinsic.max_angle_sum_error = straight.max_angle_sum_error;
  r.intrinsic.straight_tiles = straight.tiles();
  r.intrinsic.doubled = true;
  r.flow.notes.push_back("vertex scaling with intrinsic flips was solved on the surface's double (" +
                         std::to_string(d.topology.num_faces) + " faces, its mirror glued along the boundary), "
                         "where triangles leaning on the boundary can flip: " + std::to_string(f.iterations) +
                         " Newton steps");
  return true;
}

// Cut weights on the common subdivision: the 3D length, 100 times that off the input's edges (an
// edge of the subdivision lies on an input edge when its ends are two input vertices, two crossings
// of the same input edge, or a crossing and an end of its input edge). With Steiner points (the
// input here is `steiner`'s subdivision of the user's surface), an edge of the subdivision lies on
// a user's edge when it lies on an edge of the subdivided surface and both its ends lie on that
// user's edge (steiner.h: SteinerPlace).
std::vector<double> refinement_cut_weights(const CommonSubdivision& s, const Topology& input,
                                           const SteinerMesh* steiner = nullptr) {
  const Topology& t = s.topology;
  const Index nv = input.num_vertices;
  auto ends_at = [&](Index a, Index v) { return input.edge_vertices[2 * a] == v || input.edge_vertices[2 * a + 1] == v; };
  // The user's vertex or edge a vertex of the subdivision lies on (kind Face: neither).
  auto place = [&](Index v) {
    if (v < nv) return steiner->place[v];
    const Index e = steiner->edge_input[s.vertex_input_edge[v]];
    return e == kInvalid ? SteinerPlace{SteinerPlace::Kind::Face, kInvalid} : SteinerPlace{SteinerPlace::Kind::Edge, e};
  };
  auto on_user_edge = [&](Index a, Index b) {
    const SteinerPlace p = place(a), q = place(b);
    if (p.kind == SteinerPlace::Kind::Face || q.kind == SteinerPlace::Kind::Face) return false;
    if (p.kind == SteinerPlace::Kind::Edge && q.kind == SteinerPlace::Kind::Edge) return p.index == q.index;
    return true;  // a user's vertex and a point on an edge of the subdivided surface from it
  };
  std::vector<double> w(static_cast<std::size_t>(t.num_edges));
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    double d2 = 0;
    for (int k = 0; k < 3; ++k) {
      const double x = s.mesh.positions[3 * a + k] - s.mesh.positions[3 * b + k];
      d2 += x * x;
    }
    bool on_input = true;
    if (a >= nv && b >= nv) on_input = s.vertex_input_edge[a] == s.vertex_input_edge[b];
    else if (a >= nv) on_input = ends_at(s.vertex_input_edge[a], b);
    else if (b >= nv) on_input = ends_at(s.vertex_input_edge[b], a);
    if (on_input && steiner) on_input = on_user_edge(a, b);
    w[e] = std::sqrt(d2) * (on_input ? 1.0 : 100.0);
  }
  return w;
}

// Corner angles of the input's faces in the metric of the common subdivision: each input corner's
// angle is the sum of the angles of the pieces of its face at its vertex.
AngleDistortion refined_angle_distortion(const Mesh& mesh, const Topology& topology, Geometry g,
                                         const CommonSubdivision& s) {
  const Index F = topology.num_faces, nv = topology.num_vertices;
  std::vector<double> tr(static_cast<std::size_t>(3 * s.topology.num_faces)), tm(static_cast<std::size_t>(3 * F), 0.0);
  corner_angles(s.topology, g, s.l, tr);
  for (Index c = 0; c < s.topology.num_corners(); ++c) {
    const Index v = s.topology.corner_vertex[c];
    if (v >= nv) continue;
    const Index f = s.face_input[corner_face(c)];
    for (Index k = 0; k < 3; ++k)
      if (topology.corner_vertex[3 * f + k] == v) tm[3 * f + k] += tr[c];
  }
  return distortion_of_angles(mesh, topology, tm);
}

}  // namespace

bool UniformizeOptions::is_valid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (base_candidates < 1) return fail("base_candidates must be >= 1");
  if (!(polygon_tolerance >= 0) || !std::isfinite(polygon_tolerance))
    return fail("polygon_tolerance must be finite and >= 0");
  if (seed_checks < 0) return fail("seed_checks must be >= 0");
  if (steiner_max_levels < 0 || steiner_max_levels > 8) return fail("steiner_max_levels must be in [0, 8]");
  if (!(steiner_resolution > 0) || !std::isfinite(steiner_resolution))
    return fail("steiner_resolution must be finite and > 0");
  if (steiner_max_faces < 1) return fail("steiner_max_faces must be >= 1");
  if (boundary_split_rounds < 0 || boundary_split_rounds > 16) return fail("boundary_split_rounds must be in [0, 16]");
  if (!(max_layout_error > 0)) return fail("max_layout_error must be > 0");
  std::string w;
  if (!flow.is_valid(&w)) return fail(w);
  if (!cut.is_valid(&w)) return fail(w);
  if (!layout.is_valid(&w)) return fail(w);
  if (!deck.is_valid(&w)) return fail(w);
  if (!atlas.is_valid(&w)) return fail("atlas: " + w);
  return true;
}

std::string UniformizeResult::brief_report() const {
  std::string s = std::string(status_name(status)) + " " + std::string(geometry_name(geometry));
  if (!failed_stage.empty()) s += " (failed at " + failed_stage + ")";
  s += ": " + std::to_string(flow.iterations) + " iterations, max |K̄ − K| " + sci(flow.max_curvature_error);
  if (layout.status == Status::Ok && has_atlas)
    s += ", layout edge error " + sci(atlas.max_edge_length_error) + " in " + std::to_string(atlas.num_charts()) +
         " charts" +
         (atlas.frame_rounding_faces.empty()
              ? std::string()
              : " (" + sci(atlas.max_resolved_error) + " but for " + std::to_string(atlas.frame_rounding_faces.size()) +
                    " needles within their coarse face's rounding)") +
         ", " + std::to_string(atlas.flipped_faces) + " flipped";
  else if (layout.status == Status::Ok)
    s += ", layout edge error " + sci(layout.max_edge_length_error) + ", " + std::to_string(layout.flipped_faces) +
         " flipped";
  if (has_deck && deck.status == Status::Ok) s += ", relation error " + sci(deck.relation_error);
  s += ", " + sci(seconds) + " s";
  return s;
}

AngleDistortion angle_distortion(const Mesh& mesh, const Topology& topology, Geometry g, std::span<const double> l) {
  const Index F = topology.num_faces, E = topology.num_edges;
  if (l.size() != static_cast<std::size_t>(E) || mesh.faces.size() != static_cast<std::size_t>(3 * F) ||
      mesh.positions.size() < static_cast<std::size_t>(3 * topology.num_vertices))
    return {};
  std::vector<double> tm(static_cast<std::size_t>(3 * F));
  corner_angles(topology, g, l, tm);
  return distortion_of_angles(mesh, topology, tm);
}

namespace {

// Times the stages into r.timings and reports each through options.on_stage.
struct StageClock {
  UniformizeResult& r;
  const UniformizeOptions& options;
  Clock::time_point t0 = Clock::now();
  void operator()(const char* name, const std::string& summary) {
    const double s = since(t0);
    r.timings.emplace_back(name, s);
    if (options.on_stage) options.on_stage(StageRecord{name, s, summary});
    t0 = Clock::now();
  }
};

// What metric_stages() leaves for the stages after it.
struct MetricStages {
  bool ok = false;     // the flow converged; false: r.status, failed_stage and message are set
  bool flips = false;  // solved with intrinsic flips: tri, paths and straight are filled in
  IntrinsicTriangulation tri;
  InputEdgePaths paths;
  StraightInputMetric straight;
  // Solved on the surface's double (flow_on_double()): tri and paths are not the surface's, and
  // where its straight triangles do not tile, this is the common subdivision.
  bool doubled = false;
  CommonSubdivision double_refinement;
};

// A bordered surface whose solve with flips stopped (r.intrinsic.fallback says why): its double,
// where boundary edges can flip (flow_on_double()). True with m and r filled in on success; else
// r's fallback and notes say what the double did, for the caller's circle packing.
bool solve_on_double(const Mesh& mesh, const Topology& topology, const FlowOptions& fo, double mollify_margin,
                     bool subdivided, UniformizeResult& r, MetricStages& m, StageClock& stage_done) {
  std::vector<std::string> notes = r.flow.notes;
  const std::string fallback = r.intrinsic.fallback;
  r.intrinsic.fallback.clear();
  std::string double_failure;
  if (flow_on_double(mesh, topology, fo, mollify_margin, subdivided, r, m.double_refinement, double_failure)) {
    notes.pop_back();  // "… circle packing was solved instead"
    notes.push_back(fallback);
    r.flow.notes.insert(r.flow.notes.begin(), notes.begin(), notes.end());
    stage_done("flow", r.flow.brief_report() + ", " + std::to_string(r.intrinsic.flow_flips) + " flips, on the double");
    m.straight.status = Status::Ok;
    m.straight.l = r.flow.l;
    m.straight.max_angle_sum_error = r.intrinsic.max_angle_sum_error;
    m.straight.inconsistent_vertices = r.intrinsic.straight_tiles ? 0 : std::max<Index>(1, r.intrinsic.inconsistent_vertices);
    m.doubled = true;
    m.flips = true;
    m.ok = true;
    return true;
  }
  r.intrinsic.used = false;
  r.intrinsic.fallback = fallback;
  r.flow.notes = notes;
  if (!double_failure.empty()) {
    r.intrinsic.fallback += "; on the surface's double, where boundary edges flip, " + double_failure;
    if (!r.flow.notes.empty()) r.flow.notes.back() = r.intrinsic.fallback + "; the paper's circle packing was solved instead";
  }
  return false;
}

// A failure named in terms a user can act on (status Ok: nothing more specific than the solver's
// own message applies).
struct NamedFailure {
  Status status = Status::Ok;
  std::string message;
};

// Why the circle-domain solve (E, circle boundaries) failed: a circle domain that crowds beyond
// double precision is named as such, not as the solver's symptom (crowding.h: its boundary pieces
// would be too short to lay out anyway), seen from the centre by harmonic measure; otherwise what
// the circles ask, and what else is solved with guarantees.
NamedFailure circle_domain_failure(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                                   const UniformizeResult& r) {
  NamedFailure out;
  const double resolvable = 0x1p-52 / options.max_layout_error;
  const std::string limits = ", and coordinates near the circle resolve arcs of " + sci(resolvable) +
                             " to the layout limit " + sci(options.max_layout_error) +
                             "; long thin parts crowd exponentially (a 100 × 1 strip: e^(−π·50)); --boundary fixed "
                             "needs no circle (the flow stopped: " + r.flow.message + ")";
  const detail::Crowding c = detail::circle_domain_crowding(mesh, topology);
  const double arc = 2 * std::numbers::pi * c.min_measure;  // of the unit circle
  if (c.computed && !(arc > resolvable)) {
    out.status = Status::NumericalFailure;
    out.message = "the circle domain crowds beyond double precision: with vertex " + std::to_string(c.centre) +
                  " (in the middle of the boundary's longest extent) at the centre, " +
                  (c.vertex == c.other ? "the boundary at vertex " + std::to_string(c.vertex)
                                       : "the boundary edge from vertex " + std::to_string(c.vertex) + " to vertex " +
                                             std::to_string(c.other)) +
                  " gets an arc of " + (arc > 0 ? sci(arc) : std::string("below 1e-16")) +
                  " of the unit circle (harmonic measure)" + limits;
    return out;
  }
  if (r.intrinsic.fallback.empty()) return out;
  const Index chord = boundary_chord(topology);
  const std::string alternatives =
      chord == kInvalid || options.split_chords
          ? "--boundary fixed (boundary lengths held) and --boundary free (a given K̄ per boundary vertex) "
            "are fixed targets, solved with flips, on the surface's double where the surface's own solve stops" +
                std::string(chord == kInvalid ? "" : " (its chords split first)")
          : "--boundary fixed and --boundary free are fixed targets solved with flips on the surface's double, "
            "but this surface has none: the interior edge from vertex " +
                std::to_string(topology.edge_vertices[2 * chord]) + " to vertex " +
                std::to_string(topology.edge_vertices[2 * chord + 1]) +
                " joins two boundary vertices (split such edges first, as the default does)";
  out.status = r.flow.status;
  out.message = r.flow.message + "; circle boundaries make each loop's target follow its lengths (the polygon "
                "inscribed in a circle), a problem without the convexity of a fixed target, and neither vertex "
                "scaling with flips (" + r.intrinsic.fallback + ") nor circle packing solved it here; " + alternatives;
  return out;
}

// Steiner levels asked for by a run of uniformize_unit() (it stops after the metric stages).
struct SteinerPlan {
  int levels = 0;
  double median_jump = 0;
  // Boundary splits: asked for with want_leaning; the boundary edges to split when the solve with
  // flips stopped on triangles leaning over them (metric_stages()), the run then failed.
  bool want_leaning = false;
  std::vector<Index> leaning;
  // Chord splits: asked for with want_chords; set when the solve with flips stopped and chords
  // refused its double (metric_stages()), the run then failed.
  bool want_chords = false;
  bool chords = false;
  // Boundary split rounds: the flips solve starts from start_u (#V, when not empty), and where it
  // stopped on leaning triangles its last iterate is put in last_u.
  std::vector<double> start_u;
  std::vector<double> last_u;
};

// The stages initial_metric, target, flow and (with flips) the input's edges traced and made
// straight in the solution's metric, into r (r.flow.l: the input's edges' lengths). The
// `straighten` stage is timed by the caller, which decides what it includes.
// With `plan` and plan->want_leaning: where the solve with flips stops on triangles leaning over
// boundary edges (leaning_boundary_edges()), those edges are put in plan->leaning (its last
// iterate in plan->last_u) and the stages fail at once, without the fallbacks (the caller splits
// them and runs again from there: plan->start_u). With plan->want_chords: where it stops and the
// double is refused by chords (boundary_chord()), plan->chords is set and the stages fail at once
// likewise. With `subdivided` (the run is on a Steiner subdivision), a solve on the double always
// gives its common subdivision.
MetricStages metric_stages(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                           const Target* target, UniformizeResult& r, Clock::time_point start, StageClock& stage_done,
                           SteinerPlan* plan = nullptr, bool subdivided = false) {
  std::vector<Index>* leaning = plan && plan->want_leaning ? &plan->leaning : nullptr;
  bool* chords = plan && plan->want_chords ? &plan->chords : nullptr;
  MetricStages m;
  auto fail = [&](Status s, const std::string& stage, const std::string& message) {
    r.status = s;
    r.failed_stage = stage;
    r.message = stage + ": " + message;
    r.seconds = since(start);
    m.ok = false;
    return std::move(m);
  };
  std::string why;
  if (!options.is_valid(&why)) return fail(Status::InvalidArgument, "options", why);
  if (mesh.faces.size() != static_cast<std::size_t>(3 * topology.num_faces) ||
      mesh.num_vertices() != topology.num_vertices)
    return fail(Status::InvalidArgument, "options", "the mesh does not match its topology");
  if (topology.num_components != 1) return fail(Status::MultipleComponents, "options", "the mesh is not connected");
  stage_done.t0 = Clock::now();

  r.geometry = options.geometry ? *options.geometry : natural_geometry(topology);
  r.boundary = topology.is_closed() ? BoundaryMode::Free
                                    : (options.boundary ? *options.boundary : natural_boundary_mode(topology, r.geometry));
  InitialMetricOptions mo = options.metric;
  mo.geometry = r.geometry;
  r.metric = initial_metric(mesh, topology, mo);
  if (r.metric.status != Status::Ok) return fail(r.metric.status, "initial_metric", r.metric.message);
  stage_done("initial_metric", std::string(geometry_name(r.geometry)) + ", " + std::string(scheme_name(mo.scheme)));

  r.target = target ? *target : uniform_target(topology, r.boundary);
  const TargetCheck check = check_target(topology, r.metric.structure, r.target);
  if (check.status != Status::Ok) return fail(check.status, "target", check.message);
  stage_done("target", "feasible");

  // Polish: up to two more Newton steps once the tolerance is met, kept when they lower the
  // error (layouts close up to the metric's residual curvature, so the last digits matter there).
  FlowOptions fo = options.flow;
  if (options.polish && fo.method == Method::Newton) fo.polish_steps = std::max(fo.polish_steps, 2);
  if (options.intrinsic_flips && mo.scheme == Scheme::Yamabe) {
    bool solved = flow_with_flips(mesh, topology, fo, mo.mollify_margin, r, m.tri, leaning,
                                  plan ? std::span<const double>(plan->start_u) : std::span<const double>(),
                                  leaning ? &plan->last_u : nullptr);
    if (!solved && leaning && !leaning->empty())
      return fail(r.flow.status, "flow", r.intrinsic.fallback + "; " + std::to_string(leaning->size()) +
                                             " boundary edges with triangles leaning over them");
    if (!solved && chords && !r.intrinsic.fallback.empty() && has_double(topology, r.target) &&
        boundary_chord(topology) != kInvalid) {
      *chords = true;
      return fail(r.flow.status, "flow", r.intrinsic.fallback + "; the surface's double is refused by chords");
    }
    if (!solved && !r.intrinsic.fallback.empty() &&
        solve_on_double(mesh, topology, fo, mo.mollify_margin, subdivided, r, m, stage_done))
      return m;
    if (solved) {
      stage_done("flow", r.flow.brief_report() + ", " + std::to_string(r.intrinsic.flow_flips) + " flips");
      m.paths = trace_input_edges(m.tri, topology);
      if (m.paths.status != Status::Ok) return fail(m.paths.status, "straighten", m.paths.message);
      m.straight = straight_input_metric(m.tri, r.flow.u, topology, m.paths);
      if (m.straight.status != Status::Ok) return fail(m.straight.status, "straighten", m.straight.message);
      r.intrinsic.crossings = static_cast<Index>(m.paths.crossed_edge.size());
      r.intrinsic.inconsistent_vertices = m.straight.inconsistent_vertices;
      r.intrinsic.degenerate_faces = m.straight.degenerate_faces;
      r.intrinsic.max_angle_sum_error = m.straight.max_angle_sum_error;
      r.intrinsic.straight_tiles = m.straight.tiles();
      r.flow.l = m.straight.l;
      m.flips = true;
      m.ok = true;
      return m;
    }
    if (r.intrinsic.fallback.empty()) {  // failed before the solve (status set)
      r.seconds = since(start);
      return m;
    }
    // The solve with flips failed: the paper's circle packing instead.
    mo.scheme = Scheme::CirclePacking;
    r.metric = initial_metric(mesh, topology, mo);
    if (r.metric.status != Status::Ok) return fail(r.metric.status, "initial_metric", r.metric.message);
    const TargetCheck again = check_target(topology, r.metric.structure, r.target);
    if (again.status != Status::Ok) return fail(again.status, "target", again.message);
  }
  const std::vector<std::string> notes = std::move(r.flow.notes);
  r.flow = solve_flow(topology, r.metric.structure, r.metric.u, r.target, fo);
  r.flow.notes.insert(r.flow.notes.begin(), notes.begin(), notes.end());
  if (r.flow.status != Status::Ok) {
    if (r.boundary == BoundaryMode::Circle && r.geometry == Geometry::Euclidean) {
      const NamedFailure named = circle_domain_failure(mesh, topology, options, r);
      if (named.status != Status::Ok) return fail(named.status, "flow", named.message);
    }
    if (!r.intrinsic.fallback.empty())
      return fail(r.flow.status, "flow",
                  r.flow.message + "; circle packing was the fallback after " + r.intrinsic.fallback);
    return fail(r.flow.status, "flow", r.flow.message);
  }
  stage_done("flow", r.flow.brief_report());
  m.ok = true;
  return m;
}

}  // namespace

namespace {

// Starts cut_surface() of (mesh, topology) beside the flow (CutBeside) when the layout will take
// exactly that cut: the option on, fewer than kCutBesideMaxFaces faces, two threads available,
// valid options, a connected surface that is not a sphere and not one of those the compact domain
// takes (hyperbolic and not a disk; a target with cones). Run on the input's own faces only (the
// layout stages take it when the straight input triangles tile the surface, or with no flips); a
// common subdivision is cut after the flow. The worker runs its OpenMP loops on one thread: the
// flow's own loops keep both.
void cut_beside_flow(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                     const Target* target, CutBeside& out) {
  if (!options.cut_beside_flow || topology.num_faces >= kCutBesideMaxFaces || !second_thread(options) ||
      !options.is_valid(nullptr) || topology.num_components != 1 ||
      mesh.faces.size() != static_cast<std::size_t>(3 * topology.num_faces) ||
      mesh.num_vertices() != topology.num_vertices)
    return;
  const Geometry g = options.geometry ? *options.geometry : natural_geometry(topology);
  const bool sphere = topology.is_closed() && topology.euler_characteristic() == 2;
  const bool disk = topology.genus() == 0 && topology.num_boundary_loops() == 1;
  if (sphere || (g == Geometry::Hyperbolic && !disk)) return;
  if (target != nullptr && (target->K.size() != static_cast<std::size_t>(topology.num_vertices) ||
                            !cone_vertices(topology, target->K).empty()))
    return;
  out.mesh = &mesh;
  out.topology = &topology;
  out.worker = std::jthread([&out, &options] {
    omp_set_num_threads(1);
    try {
      out.cut = cut_surface(*out.mesh, *out.topology, options.cut);
      // The two connectivities are not held beside the flow, where memory peaks: a surface the
      // cut did not refine is the input's, which refined_edge_lengths() takes then (one it refined
      // is built again there), and the disk's is built again from its faces
      // (take_disk_topology()), each at a small part of the cut's cost.
      CutResult& c = *out.cut;
      c.surface_topology = Topology{};
      if (c.status == Status::Ok && is_topology_of(c.disk_topology, c.cut_faces, c.num_cut_vertices())) {
        out.central = central_face(c.disk_topology);
        if (out.central != kInvalid) out.farthest = farthest_face(c.disk_topology, out.central);
      }
      c.disk_topology = Topology{};
      // Nor a second copy of the input's faces and positions (SurfaceDiff).
      if (c.status == Status::Ok) compact_surface(*out.mesh, *out.topology, c, out.diff);
      for (std::vector<Index>* v : {&c.surface_faces, &c.surface_face_to_input, &c.refined_vertex_face,
                                    &c.refined_vertex_corners, &c.cut_faces, &c.cut_to_surface})
        v->shrink_to_fit();
      c.surface_positions.shrink_to_fit();
      c.refined_vertex_bary.shrink_to_fit();
    } catch (...) {
      out.cut.reset();  // cut again after the flow (out of memory here: it is back by then)
    }
#if defined(__GLIBC__)
    malloc_trim(0);  // the cut's working memory back to the system before the flow's peak
#endif
  });
}


// The whole job on (mesh, topology). With `plan`: when Steiner points apply (the header comment;
// UniformizeOptions::steiner_max_levels), returns right after the metric stages with plan->levels
// set. With `steiner`: (mesh, topology) is that subdivision of the user's surface, and the later
// stages always run on the common subdivision, its cut preferring the user's edges.
UniformizeResult uniformize_unit(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                                 const Target* target, SteinerPlan* plan = nullptr,
                                 const SteinerMesh* steiner = nullptr) {
  const Clock::time_point start = Clock::now();
  CutBeside cut_beside;  // joined on every return
  if (!steiner) cut_beside_flow(mesh, topology, options, target, cut_beside);
  UniformizeResult r;
  StageClock stage_done{r, options};
  MetricStages m = metric_stages(mesh, topology, options, target, r, start, stage_done, plan,
                                 steiner != nullptr && steiner->levels == 0);
  if (!m.ok) return r;
  if (plan && !steiner && m.flips && !m.doubled && !m.straight.tiles() &&
      (r.geometry != Geometry::Hyperbolic || !topology.is_closed()) && options.steiner_max_levels > 0) {
    plan->median_jump = median_edge_jump(topology, r.flow.u);
    plan->levels = steiner_levels(plan->median_jump, options.steiner_resolution, options.steiner_max_levels,
                                  topology.num_faces, options.steiner_max_faces);
    if (plan->levels > 0) {
      r.seconds = since(start);
      return r;
    }
  }
  // On a Steiner subdivision the input's own solve converged (the probe): solving the
  // subdivision's double costs more than the input's run it would replace (the job falls back to
  // that run). Chord splits (levels 0) exist to solve the double.
  if (steiner && m.doubled && steiner->levels > 0) {
    r.status = Status::NumericalFailure;
    r.failed_stage = "straighten";
    r.message = "straighten: the subdivided surface was solved on its double";
    r.seconds = since(start);
    return r;
  }
  if (!m.flips || (m.straight.tiles() && !steiner)) {
    if (m.flips)
      stage_done("straighten", std::to_string(r.intrinsic.crossings) + " crossings; the straight input triangles "
                               "tile the surface (angle sums to " + sci(m.straight.max_angle_sum_error) + ")");
    layout_stages(mesh, topology, options, r.flow.l, r, start, nullptr, &cut_beside);
    return r;
  }
  if (m.doubled) {
    r.refinement = std::move(m.double_refinement);
  } else {
    const std::vector<double> t =
        straightest_crossings(m.tri, m.paths, m.straight.crossings, input_edge_crossings(m.tri, r.flow.u, m.paths));
    r.refinement = common_subdivision(m.tri, r.flow.u, mesh, topology, m.paths, t);
  }
  if (r.refinement.status != Status::Ok) {
    r.status = r.refinement.status;
    r.failed_stage = "straighten";
    r.message = "straighten: " + r.refinement.message;
    r.seconds = since(start);
    return r;
  }
  r.intrinsic.refined = true;
  stage_done("straighten", std::to_string(m.straight.inconsistent_vertices) +
                               " vertices where straight input triangles fold; the common subdivision has " +
                               std::to_string(r.refinement.topology.num_faces) + " faces");
  UniformizeOptions ro = options;
  ro.cut.edge_weights = refinement_cut_weights(r.refinement, topology, steiner);
  layout_stages(r.refinement.mesh, r.refinement.topology, ro, r.refinement.l, r, start, &r.refinement.frames);
  // On a Steiner subdivision the angles are measured on the user's corners (uniformize_subdivided()).
  if (r.status == Status::Ok && !steiner) r.angles = refined_angle_distortion(mesh, topology, r.geometry, r.refinement);
  return r;
}

UniformizeResult conformal_metric_unit(const Mesh& mesh, const Topology& topology,
                                       const UniformizeOptions& options, const Target* target) {
  const Clock::time_point start = Clock::now();
  UniformizeResult r;
  StageClock stage_done{r, options};
  const MetricStages m = metric_stages(mesh, topology, options, target, r, start, stage_done);
  if (!m.ok) return r;
  if (m.flips)
    stage_done("straighten", std::to_string(r.intrinsic.crossings) + " crossings; the straight input triangles " +
                                 (m.straight.tiles() ? "tile the surface" : "fold at " +
                                  std::to_string(m.straight.inconsistent_vertices) + " vertices"));
  r.status = Status::Ok;
  r.message = "ok";
  r.seconds = since(start);
  return r;
}

UniformizeResult lay_out_metric_unit(const Mesh& mesh, const Topology& topology, Geometry geometry,
                                     std::span<const double> lengths, const UniformizeOptions& options) {
  const Clock::time_point start = Clock::now();
  UniformizeResult r;
  r.geometry = geometry;
  r.boundary = BoundaryMode::Free;
  std::string why;
  auto fail = [&](Status s, const std::string& message) {
    r.status = s;
    r.failed_stage = "options";
    r.message = "options: " + message;
    r.seconds = since(start);
    return r;
  };
  if (!options.is_valid(&why)) return fail(Status::InvalidArgument, why);
  if (mesh.faces.size() != static_cast<std::size_t>(3 * topology.num_faces) ||
      mesh.num_vertices() != topology.num_vertices)
    return fail(Status::InvalidArgument, "the mesh does not match its topology");
  if (topology.num_components != 1) return fail(Status::MultipleComponents, "the mesh is not connected");
  if (lengths.size() != static_cast<std::size_t>(topology.num_edges))
    return fail(Status::InvalidArgument, "the metric has " + std::to_string(lengths.size()) +
                                             " lengths but the mesh has " + std::to_string(topology.num_edges) + " edges");
  for (Index e = 0; e < topology.num_edges; ++e)
    if (!(lengths[e] > 0) || !std::isfinite(lengths[e])) {
      r.status = Status::DegenerateFace;
      r.failed_stage = "options";
      r.message = "options: the length of edge " + std::to_string(e) + " is not a positive finite number";
      r.seconds = since(start);
      return r;
    }
  r.flow.l.assign(lengths.begin(), lengths.end());
  r.flow.geometry = geometry;
  r.flow.status = Status::NotRun;
  r.flow.message = "given metric";
  layout_stages(mesh, topology, options, lengths, r, start);
  return r;
}

// The input's positions as the stages read them: times unit_power_of_two() of the bounding box's
// largest side, which is exact, so that every 3D product the stages form (cut weights, corner
// angles, crowding, the common subdivision) stays in range at any scale a double holds. `mesh`
// points at the input itself when the factor is 1.
struct UnitMesh {
  double scale = 1;
  Mesh copy;
  const Mesh* mesh = nullptr;
};

UnitMesh unit_mesh(const Mesh& in) {
  UnitMesh u;
  u.mesh = &in;
  const std::size_t nv = in.positions.size() / 3;
  if (nv == 0) return u;
  double extent = 0, largest = 0;
  for (int k = 0; k < 3; ++k) {
    double lo = in.positions[k], hi = lo;
    for (std::size_t v = 0; v < nv; ++v) {
      lo = std::min(lo, in.positions[3 * v + k]);
      hi = std::max(hi, in.positions[3 * v + k]);
    }
    extent = std::max(extent, hi - lo);
    largest = std::max({largest, std::abs(lo), std::abs(hi)});
  }
  if (!std::isfinite(extent)) extent = largest;  // a side longer than the largest double
  u.scale = unit_power_of_two(extent);
  if (u.scale == 1) return u;
  u.copy = in;
  for (double& x : u.copy.positions) x *= u.scale;
  u.mesh = &u.copy;
  return u;
}

// Back to the input's unit where the result holds 3D positions, and the scale on record.
void record_unit(const UnitMesh& u, UniformizeResult& r) {
  r.input_scale = u.scale;
  if (u.scale == 1) return;
  if (r.metric.status != Status::NotRun) r.metric.length_scale *= u.scale;
  for (double& x : r.refinement.mesh.positions) x /= u.scale;
  for (double& x : r.steiner_mesh.mesh.positions) x /= u.scale;
}

}  // namespace

namespace {

// uniformize_unit() with the fallbacks to circle packing (uniformize()).
UniformizeResult uniformize_with_fallbacks(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                                           const Target* target, SteinerPlan* plan) {
  UniformizeResult r = uniformize_unit(mesh, topology, options, target, plan);
  if (plan && plan->levels > 0) return r;
  // Vertex scaling with flips converged only to the curvature resolution of near-coincident
  // vertices (FlowResult::resolution_vertices), and a stage after the flow could not represent it
  // (a layout closes around such vertices, and its coordinates reproduce their short edges, only to
  // about that resolution; the gate excuses the edges, not a layout that misses elsewhere, nor
  // deck fits through them): circle packing, whose radii do not keep those edges short, instead.
  if (r.status != Status::Ok && r.intrinsic.used && r.flow.status == Status::Ok && r.flow.resolution_vertices > 0 &&
      !(r.flow.max_curvature_error < options.flow.tolerance)) {
    UniformizeOptions packing = options;
    packing.metric.scheme = Scheme::CirclePacking;
    UniformizeResult p = uniformize_unit(mesh, topology, packing, target);
    p.intrinsic.fallback = "vertex scaling with intrinsic flips converged only to the curvature resolution of " +
                           std::to_string(r.flow.resolution_vertices) + " near-coincident vertices (max |K̄ − K| " +
                           sci(r.flow.max_curvature_error) + ", resolution " + sci(r.flow.curvature_resolution) +
                           "), and then failed at " + r.message;
    p.flow.notes.insert(p.flow.notes.begin(), p.intrinsic.fallback + "; the paper's circle packing was solved instead");
    r = std::move(p);
  } else if (r.status != Status::Ok && r.intrinsic.refined && (r.intrinsic.doubled || r.flow.status == Status::Ok)) {
    // Solved with flips (on the surface, or on its double) where the straight input triangles
    // fold: where a stage after the flow fails on that common subdivision — the straighten stage's
    // own limits with hundreds of folds, or slivers of it that no chart resolves (each placed by
    // its coarse face's isometry: a closed genus-12 surface stretched 66:1 whose 2344 faces fold
    // at 691 vertices, slivers missed by 4e-5 in the charts made for them) — circle packing, on
    // the input's own triangles, instead.
    UniformizeOptions packing = options;
    packing.metric.scheme = Scheme::CirclePacking;
    UniformizeResult p = uniformize_unit(mesh, topology, packing, target);
    p.intrinsic.fallback = std::string("vertex scaling with intrinsic flips, solved on the surface") +
                           (r.intrinsic.doubled ? "'s double (" : " (") +
                           std::to_string(r.intrinsic.inconsistent_vertices) +
                           " vertices where its straight input triangles fold), failed at " + r.message;
    p.flow.notes.insert(p.flow.notes.begin(), p.intrinsic.fallback + "; the paper's circle packing was solved instead");
    r = std::move(p);
  }
  return r;
}

// A run r on the subdivision `s` of (mesh, topology) brought back to the user's faces: the
// refinement's faces named by input face, angles on the input's corners, s kept in r. False (r not
// Ok) when the run failed or was not solved with flips through the common subdivision (with
// `any_scheme`: through a subdivision, by any scheme).
bool onto_input(const Mesh& mesh, const Topology& topology, SteinerMesh& s, UniformizeResult& r,
                bool any_scheme = false) {
  if (r.status != Status::Ok) return false;
  if (!r.intrinsic.refined || (!any_scheme && !r.intrinsic.fallback.empty())) {
    r.status = Status::NumericalFailure;
    r.failed_stage = "straighten";
    r.message = "straighten: the subdivided surface was not solved with flips";
    return false;
  }
  for (Index& f : r.refinement.face_input) f = s.face_input[f];
  r.angles = refined_angle_distortion(mesh, topology, r.geometry, r.refinement);
  r.steiner.used = true;
  r.steiner.refined_median_jump = median_edge_jump(s.topology, r.flow.u);
  r.steiner.vertices_added = s.topology.num_vertices - topology.num_vertices;
  r.steiner_mesh = std::move(s);
  return true;
}

// The run on the Steiner subdivision `s` of (mesh, topology), its outputs brought back to the
// user's faces; status not Ok when it failed (the caller keeps the input's own run).
UniformizeResult uniformize_subdivided(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                                       const Target& target, const SteinerPlan& plan, SteinerMesh s) {
  const Target st = steiner_target(s, topology, target);
  UniformizeResult r = uniformize_unit(s.mesh, s.topology, options, &st, nullptr, &s);
  if (!onto_input(mesh, topology, s, r)) return r;
  r.steiner.levels = plan.levels;
  r.steiner.median_jump = plan.median_jump;
  return r;
}

// The start of a boundary split round: `u` (the last iterate on the surface before the split, #V
// of `before`) on the vertices that were there, and on each vertex the split added, between the
// two ends of its boundary edge a and b, the u that keeps that edge's length at u in its two
// halves: ½ l e^((u_a+u_m)/2) + ½ l e^((u_m+u_b)/2) = l e^((u_a+u_b)/2).
std::vector<double> split_start(const SteinerMesh& after, Index before, const std::vector<double>& u) {
  const Topology& t = after.topology;
  std::vector<double> out(static_cast<std::size_t>(t.num_vertices), 0.0);
  if (u.size() != static_cast<std::size_t>(before)) return {};
  std::copy(u.begin(), u.end(), out.begin());
  for (Index L = 0; L < t.num_boundary_loops(); ++L) {
    const Index b0 = t.boundary_offsets[L], n = t.boundary_offsets[L + 1] - b0;
    for (Index i = 0; i < n; ++i) {
      const Index m = t.boundary_vertices[b0 + i];
      if (m < before) continue;
      const Index a = t.boundary_vertices[b0 + (i + n - 1) % n], b = t.boundary_vertices[b0 + (i + 1) % n];
      if (a >= before || b >= before) return {};  // not one split per edge: no start
      const double ha = 0.5 * u[a], hb = 0.5 * u[b];
      out[m] = 2 * (ha + hb + std::log(2.0) - (std::max(ha, hb) + std::log1p(std::exp(-std::abs(ha - hb)))));
    }
  }
  return out;
}

// Boundary splits (the header comment): the edges `leaning` of (mesh, topology) split, the job run
// on the split surface from the stalled solve's last iterate `last_u` (split_start()), and again
// with the edges its own stalled solve names from its own last iterate, up to
// options.boundary_split_rounds rounds; status not Ok when no round succeeded (its message says
// why; the caller runs the input's own job with its fallbacks).
UniformizeResult uniformize_boundary_split(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                                           const Target& target, std::vector<Index> leaning,
                                           std::vector<double> last_u) {
  SteinerMesh s = subdivide_on_faces(mesh, topology, 0);
  UniformizeResult sub;
  Index splits = 0;
  for (int round = 1; round <= options.boundary_split_rounds && s.status == Status::Ok; ++round) {
    Index n = 0;
    SteinerMesh next = split_boundary_edges(s, leaning, &n);
    if (next.status != Status::Ok || n == 0) {
      sub = UniformizeResult{};
      sub.status = next.status == Status::Ok ? Status::NumericalFailure : next.status;
      sub.message = "round " + std::to_string(round) + " split no boundary edge" +
                    (next.status == Status::Ok ? std::string() : ": " + next.message);
      return sub;
    }
    splits += n;
    const Index before = s.topology.num_vertices;
    s = std::move(next);
    const Target st = steiner_target(s, topology, target);
    // Every round stops at the flow when triangles still lean (no fallback run on a surface
    // whose result would be dropped); the last round's edges are then left unsplit.
    SteinerPlan p;
    p.want_leaning = true;
    p.start_u = split_start(s, before, last_u);
    sub = uniformize_unit(s.mesh, s.topology, options, &st, &p, &s);
    if (onto_input(mesh, topology, s, sub)) {
      sub.steiner.boundary_split_rounds = round;
      sub.steiner.boundary_splits = splits;
      sub.flow.notes.push_back(std::to_string(splits) + " boundary edges split at their midpoints in " +
                               std::to_string(round) + (round == 1 ? " round" : " rounds") +
                               ", where triangles leaned over them and vertex scaling with flips stopped");
      return sub;
    }
    if (p.leaning.empty()) return sub;
    leaning = std::move(p.leaning);
    last_u = std::move(p.last_u);
  }
  return sub;
}

// Chord splits (the header comment): the chords of (mesh, topology) split and the job run on the
// split surface; status not Ok when that failed (the caller runs the input's own job).
UniformizeResult uniformize_chord_split(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                                        const Target& target) {
  Index n = 0;
  SteinerMesh s = split_chords(subdivide_on_faces(mesh, topology, 0), &n);
  UniformizeResult sub;
  if (s.status != Status::Ok || n == 0) {
    sub.status = s.status == Status::Ok ? Status::NumericalFailure : s.status;
    sub.message = s.status == Status::Ok ? "no chord was split" : s.message;
    return sub;
  }
  const Target st = steiner_target(s, topology, target);
  sub = uniformize_unit(s.mesh, s.topology, options, &st, nullptr, &s);
  if (sub.status == Status::Ok && !sub.intrinsic.refined) {
    // Solved by a fallback (circle packing) on the split surface's own faces: the split surface
    // is then the subdivision the later stages ran on.
    CommonSubdivision& c = sub.refinement;
    c.mesh = s.mesh;
    c.topology = s.topology;
    c.l = sub.flow.l;
    c.face_input.resize(static_cast<std::size_t>(s.topology.num_faces));
    for (Index f = 0; f < s.topology.num_faces; ++f) c.face_input[f] = f;
    c.vertex_input_edge.assign(static_cast<std::size_t>(s.topology.num_vertices), kInvalid);
    c.status = Status::Ok;
    c.message = "ok";
    sub.intrinsic.refined = true;
  }
  if (!onto_input(mesh, topology, s, sub, true)) return sub;
  sub.steiner.chord_splits = n;
  sub.flow.notes.push_back(std::to_string(n) + (n == 1 ? " chord" : " chords") +
                           " (interior edges joining two boundary vertices) split at their midpoints, so that the "
                           "surface's double is a surface");
  return sub;
}

// The probe's stages first (probe_NAME), then the run's (whose names repeat); seconds from `start`.
void after_probe(UniformizeResult& r, const std::vector<std::pair<std::string, double>>& probe,
                 Clock::time_point start) {
  std::vector<std::pair<std::string, double>> t;
  for (const auto& [name, sec] : probe) t.emplace_back("probe_" + name, sec);
  t.insert(t.end(), r.timings.begin(), r.timings.end());
  r.timings = std::move(t);
  r.seconds = since(start);
}

}  // namespace

UniformizeResult uniformize(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                            const Target* target) {
  const Clock::time_point start = Clock::now();
  const UnitMesh u = unit_mesh(mesh);
  SteinerPlan plan;
  plan.want_leaning = options.boundary_split_rounds > 0;
  plan.want_chords = options.split_chords;
  UniformizeResult r = uniformize_with_fallbacks(*u.mesh, topology, options, target, &plan);
  if (plan.chords) {
    const std::vector<std::pair<std::string, double>> probe = r.timings;
    const std::string stopped = r.message;
    const Target given = target ? *target : uniform_target(topology, r.boundary);
    UniformizeResult sub = uniformize_chord_split(*u.mesh, topology, options, given);
    if (sub.status == Status::Ok) {
      r = std::move(sub);
    } else {
      r = uniformize_with_fallbacks(*u.mesh, topology, options, target, nullptr);
      r.steiner.note = "vertex scaling with flips stopped and chords refused the surface's double (" + stopped +
                       "), and splitting the chords did not solve it (" + sub.message + ")";
      r.flow.notes.push_back(r.steiner.note);
    }
    after_probe(r, probe, start);
  } else if (!plan.leaning.empty()) {
    const std::vector<std::pair<std::string, double>> probe = r.timings;
    const std::string stopped = r.message;
    const Target given = target ? *target : uniform_target(topology, r.boundary);
    UniformizeResult sub = uniformize_boundary_split(*u.mesh, topology, options, given, plan.leaning, plan.last_u);
    if (sub.status == Status::Ok) {
      r = std::move(sub);
    } else {
      r = uniformize_with_fallbacks(*u.mesh, topology, options, target, nullptr);
      r.steiner.note = "vertex scaling with flips stopped on triangles leaning over boundary edges (" + stopped +
                       "), and splitting those edges did not solve it (" + sub.message + ")";
      r.flow.notes.push_back(r.steiner.note);
      // Where the split surface's metric converged and a later stage stopped it while the input's
      // own run stopped at its flow, the split run's failure is what blocks the job: named so.
      const std::string stage = sub.failed_stage;
      if (r.status != Status::Ok && r.failed_stage == "flow" && sub.flow.status == Status::Ok && !stage.empty() &&
          stage != "flow" && sub.message.rfind(stage + ": ", 0) == 0) {
        const std::string own = r.message;
        std::vector<std::string> notes = std::move(r.flow.notes);
        r = std::move(sub);
        r.message = stage + ": with its leaning boundary edges split, vertex scaling with flips converged (" +
                    r.flow.brief_report() + "), and then " + r.message.substr(stage.size() + 2) +
                    "; the input's own run stopped at its flow (" + own + ")";
        r.steiner.note = "the surface's leaning boundary edges were split; the run failed at " + stage;
        notes.insert(notes.end(), r.flow.notes.begin(), r.flow.notes.end());
        r.flow.notes = std::move(notes);
      }
    }
    after_probe(r, probe, start);
  } else if (plan.levels > 0) {
    // Solved on the input to learn its conformal factor; the job itself runs on the subdivision.
    const std::vector<std::pair<std::string, double>> probe = r.timings;
    SteinerMesh s = subdivide_on_faces(*u.mesh, topology, plan.levels);
    const Target given = target ? *target : uniform_target(topology, r.boundary);
    UniformizeResult sub;
    if (s.status == Status::Ok)
      sub = uniformize_subdivided(*u.mesh, topology, options, given, plan, std::move(s));
    else
      sub.message = s.message;
    if (sub.status == Status::Ok) {
      r = std::move(sub);
    } else {
      r = uniformize_with_fallbacks(*u.mesh, topology, options, target, nullptr);
      r.steiner.levels = plan.levels;
      r.steiner.median_jump = plan.median_jump;
      r.steiner.note = "the surface subdivided " + std::to_string(plan.levels) + " times (median |u_i − u_j| " +
                       sci(plan.median_jump) + " over the input's edges) failed (" + sub.message +
                       "); the input's own triangulation is used";
      r.flow.notes.push_back(r.steiner.note);
    }
    after_probe(r, probe, start);
  }
  record_unit(u, r);
  return r;
}

UniformizeResult conformal_metric(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                                  const Target* target) {
  const UnitMesh u = unit_mesh(mesh);
  UniformizeResult r = conformal_metric_unit(*u.mesh, topology, options, target);
  record_unit(u, r);
  return r;
}

UniformizeResult lay_out_metric(const Mesh& mesh, const Topology& topology, Geometry geometry,
                                std::span<const double> lengths, const UniformizeOptions& options) {
  const UnitMesh u = unit_mesh(mesh);
  UniformizeResult r = lay_out_metric_unit(*u.mesh, topology, geometry, lengths, options);
  record_unit(u, r);
  return r;
}

namespace {

// The stages from `cut` on (layout_stages()), sharing the inputs and the result. Each step returns
// false once a stage failed (r.status, failed_stage and message set).
struct SeedCheck;
struct AnglesBeside;

// The frames of a cut disk (its faces are the cut's surface faces, slot by slot) from those of
// the surface it was cut from (`surface`, whose faces `topology` holds): each disk face lies in the
// coarse face of the surface face it refines; a vertex the cut added inside a face or on an edge
// is the combination of the face's corners that refined_edge_lengths() takes (its corners' model
// points, combined and put back on the model). Null when a record names a vertex that is not a
// corner of the face (the layout then develops the faces themselves).
std::shared_ptr<const FaceFrames> disk_frames(const CutResult& cut, const Topology& topology, const FaceFrames& surface,
                                              Geometry g) {
  auto out = std::make_shared<FaceFrames>();
  out->frame_lengths = surface.frame_lengths;
  out->frame_opposite = surface.frame_opposite;
  const Index nf = static_cast<Index>(cut.surface_faces.size() / 3), nin = cut.num_input_vertices;
  if (static_cast<Index>(cut.surface_face_to_input.size()) != nf ||
      surface.corner_model.size() != 9 * static_cast<std::size_t>(topology.num_faces))
    return nullptr;
  out->face_frame.resize(static_cast<std::size_t>(nf));
  out->corner_model.resize(9 * static_cast<std::size_t>(nf));
  for (Index f = 0; f < nf; ++f) {
    const Index s = cut.surface_face_to_input[f];
    out->face_frame[f] = surface.face_frame[s];
    auto model_of = [&](Index v, double* m) {  // v's model point in s's frame; false when v is not on s
      for (int k = 0; k < 3; ++k)
        if (topology.corner_vertex[3 * s + k] == v) {
          std::copy_n(&surface.corner_model[9 * static_cast<std::size_t>(s) + 3 * k], 3, m);
          return true;
        }
      return false;
    };
    for (int k = 0; k < 3; ++k) {
      const Index v = cut.surface_faces[3 * f + k];
      double* m = &out->corner_model[9 * static_cast<std::size_t>(f) + 3 * k];
      if (v < nin) {
        if (!model_of(v, m)) return nullptr;
        continue;
      }
      const std::size_t rec = static_cast<std::size_t>(v - nin);
      double sum[3] = {0, 0, 0};
      for (int j = 0; j < 3; ++j) {
        const double beta = cut.refined_vertex_bary[3 * rec + j];
        if (beta == 0) continue;
        double corner[3];
        if (!model_of(cut.refined_vertex_corners[3 * rec + j], corner)) return nullptr;
        for (int d = 0; d < 3; ++d) sum[d] += beta * corner[d];
      }
      double n = 1;
      if (g == Geometry::Hyperbolic) n = std::sqrt(sum[2] * sum[2] - sum[0] * sum[0] - sum[1] * sum[1]);
      if (g == Geometry::Spherical) n = std::sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
      if (!(n > 0)) return nullptr;
      for (int d = 0; d < 3; ++d) m[d] = sum[d] / n;
    }
  }
  return out;
}

struct LayoutRun {
  const Mesh& mesh;
  const Topology& topology;
  const UniformizeOptions& options;
  std::span<const double> metric_l;
  UniformizeResult& r;
  Clock::time_point start;
  StageClock& stage_done;
  bool sphere = false;     // closed genus 0: laid out on the sphere, uncut
  bool closed_h = false;   // closed genus >= 2 in H: the compact domain and a canonical polygon
  std::vector<Index> cones;  // interior vertices with target K̄ ≠ 0
  SeedCheck* seed_check = nullptr;  // started once the layout passed its gate (options.seed_checks > 0)
  AnglesBeside* angles = nullptr;   // the angle distortion, made beside a cut that runs on one thread
  CutBeside* cut_beside = nullptr;  // a cut of (mesh, topology) made beside the flow, or null
  // When the disk is that cut's: its central face and the face farthest from it (CutBeside).
  Index known_central = kInvalid, known_farthest = kInvalid;
  // A common subdivision's frames (its current faces), and the same for what is laid out (the
  // surface itself, or the cut disk): the layouts develop those coarse faces (FaceFrames).
  const FaceFrames* surface_frames = nullptr;
  std::shared_ptr<const FaceFrames> layout_frames{};
  LayoutOptions layout_options{};  // what the layout itself ran with (start_layout())
  const Topology* laid_out = nullptr;  // the faces the layout developed (the disk, or the sphere)

  bool fail(Status s, const std::string& stage, const std::string& message) {
    r.status = s;
    r.failed_stage = stage;
    r.message = stage + ": " + message;
    r.seconds = since(start);
    return false;
  }
};

// Needles of the common subdivision within their coarse face's rounding (frame_rounding_faces:
// their corners placed as exactly as the coarse face that holds them, whose other pieces are
// resolved) pass when every other face is within the limit. Their 3D area is not the measure here
// (as it is for the one chart's excuse): a piece that is a needle in the metric can span a share
// of its input face in 3D, its corners being crossings placed by metric fractions.
bool needles_excused_in(const LayoutAtlas& atlas, double limit) {
  return atlas.status == Status::Ok && !atlas.frame_rounding_faces.empty() && atlas.max_resolved_error <= limit;
}

// The 3D area of each face of the cut's surface (the disk's faces, slot by slot); empty when the
// cut has no positions.
std::vector<double> cut_face_areas(const CutResult& cut) {
  std::vector<double> area;
  const std::vector<double>& x = cut.surface_positions;
  if (x.empty()) return area;
  const std::size_t nf = cut.surface_faces.size() / 3;
  area.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    const double* p[3];
    for (int k = 0; k < 3; ++k) p[k] = &x[3 * static_cast<std::size_t>(cut.surface_faces[3 * f + k])];
    const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const double w[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    area[f] = 0.5 * std::hypot(u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]);
  }
  return area;
}

// The face farthest from `seed` in steps across edges (breadth-first; the smallest index among the
// farthest), and the seeds of the checks after it: evenly spread over the faces (F/2 for one).
// `farthest`: that face when already known (kInvalid: found here).
std::vector<Index> check_seed_faces(const Topology& t, Index seed, int count, Index farthest = kInvalid) {
  std::vector<Index> seeds;
  if (count <= 0 || seed < 0 || seed >= t.num_faces) return seeds;
  seeds.push_back(farthest != kInvalid ? farthest : farthest_face(t, seed));
  const int spread = count - 1;
  for (int k = 0; k < spread; ++k)
    seeds.push_back(spread == 1 ? t.num_faces / 2
                                : static_cast<Index>((static_cast<std::int64_t>(t.num_faces - 1) * k) / (spread - 1)));
  return seeds;
}

// Seed independence: the layout again from options.seed_checks other seed faces, each compared
// with the layout itself up to the isometries of the geometry (align_layouts()). The layouts are
// normalised alike (E: rigid frame, H: centre of mass, S: Möbius centring, unique up to a
// rotation), so only an isometry separates two correct ones; E's unit box is undone by its scale.
// The first check starts at the face farthest from the layout's seed, where the two propagations
// share the least (the longest paths, laid out in opposite directions); further checks start at
// faces spread over the surface. They start once the layout has passed its gate
// (cut_and_lay_out()), not beside the layout, whose parallel loops then have both cores (beside
// it, the check had made the H layout of a 410k-face genus-2 surface 0.16 → 0.37 s). Before a
// canonical polygon (closed H), with two threads available, they run on a second thread beside
// the polygon and deck stages (serial) and are joined after the angles (finish_seed_check());
// otherwise they run right away on all threads (nothing serial follows to hide them behind).
// The check's layouts are refined only above kCheckRefineAbove (UniformizeOptions::seed_checks).
constexpr double kCheckRefineAbove = 1e-8;
struct SeedCheck {
  std::shared_ptr<const LayoutShapes> shapes;  // the layout's angles and areas: the checks read them
  std::vector<Index> seeds;
  std::vector<Layout> layouts;
  std::exception_ptr error;
  double seconds = 0;     // the checks' own wall time
  bool beside = false;    // laid out on a second thread
  std::function<void()> later;  // not beside: the layouts, made when the check is finished
  std::jthread worker;    // last: joined before the layouts it writes are destroyed
};

// The seeds are found on the worker too (a breadth-first search over the faces for the first).
void start_seed_check(LayoutRun& run, SeedCheck& sc, const Topology& faces, Index seed) {
  const bool sphere = run.sphere;
  const Index farthest = seed == run.known_central ? run.known_farthest : kInvalid;
  auto work = [&run, &sc, &faces, seed, farthest, sphere] {
    const UniformizeResult& res = run.r;
    const auto t0 = Clock::now();
    try {
      sc.seeds = check_seed_faces(faces, seed, run.options.seed_checks, farthest);
      sc.layouts.resize(sc.seeds.size());
      for (std::size_t k = 0; k < sc.seeds.size(); ++k) {
        LayoutOptions o = run.options.layout;
        o.seed_face = sc.seeds[k];
        o.unit_box = false;
        o.refine_above = std::max(o.refine_above, kCheckRefineAbove);
        o.keep_unresolved = run.options.use_atlas && !sphere;
        o.frames = run.layout_frames;
        o.shapes = sc.shapes;
        sc.layouts[k] = sphere ? layout_sphere(run.topology, run.metric_l, o)
                               : layout_disk(res.disk, res.geometry, res.disk_lengths, o);
      }
    } catch (...) {
      sc.error = std::current_exception();
    }
    sc.shapes = nullptr;
    sc.seconds = since(t0);
  };
  sc.beside = second_thread(run.options) && run.closed_h && run.cones.empty();
  if (sc.beside) {
    // One thread of its own, beside the serial polygon and deck stages.
    sc.worker = std::jthread([work] {
      omp_set_num_threads(1);
      work();
    });
  } else {
    sc.later = work;  // on all threads, in finish_seed_check() (its own stage)
  }
}

// The angle distortion (angle_distortion(): the mesh's angles against the metric's, nothing
// laid out) on a second thread beside a cut made after the flow, which runs on one thread
// (cut_compact(), or cut_surface() where it was not made beside the flow; for a disk, whose cut
// is nothing, that means beside its layout), instead of after the layout: genus2-400k's 0.08 s,
// torus-2M's 0.16 s off the job. Joined at the angles stage.
struct AnglesBeside {
  AngleDistortion result;
  std::exception_ptr error;
  std::jthread worker;  // last: joined before `result` is destroyed
};

void start_angles_beside(LayoutRun& run) {
  if (run.angles == nullptr || run.angles->worker.joinable() || !second_thread(run.options)) return;
  AnglesBeside& a = *run.angles;
  a.worker = std::jthread([&a, &run] {
    omp_set_num_threads(1);
    try {
      a.result = angle_distortion(run.mesh, run.topology, run.r.geometry, run.metric_l);
    } catch (...) {
      a.error = std::current_exception();
    }
  });
}

// The options of the layout itself: its seed made explicit (the default central face), so that
// the seed check can start from the face farthest from it.
LayoutOptions start_layout(LayoutRun& run, const Topology& faces) {
  LayoutOptions lo = run.options.layout;
  // With an atlas, vertices beyond one chart's range are left to it (not for the sphere).
  if (run.options.use_atlas && !run.sphere) lo.keep_unresolved = true;
  lo.frames = run.layout_frames;
  if (lo.seed_face < 0) lo.seed_face = run.known_central != kInvalid ? run.known_central : central_face(faces);
  run.layout_options = lo;
  run.laid_out = &faces;
  return lo;
}

/// The accuracy gate on cut_and_lay_out()'s layout, the development through the faces where the
/// frames' misses it, and the atlas of charts where one chart does not resolve every face. False
/// when the layout fails (r.status set).
bool gate_layout(LayoutRun& run) {
  const Topology& topology = run.topology;
  const UniformizeOptions& options = run.options;
  const std::span<const double> metric_l = run.metric_l;
  UniformizeResult& r = run.r;
  StageClock& stage_done = run.stage_done;
  const bool sphere = run.sphere;
  auto fail = [&](Status s, const std::string& stage, const std::string& message) { return run.fail(s, stage, message); };
  // A layout that does not reproduce the metric is no result, except where coordinates cannot
  // resolve an edge and the surface there is negligible: edges above the limit pass when each is
  // within kRoundingAllowance times its own rounding floor and their faces cover at most the
  // limit's fraction of the input's 3D area. That excuses the short
  // edges at near-coincident vertices (and the tiny faces the common subdivision makes there), whose
  // length one layout's coordinates resolve only to about ε·l/s, but not a region that the
  // conformal factor shrinks below what coordinates resolve (a long strip's far end), which is
  // large in 3D. The sphere's positions are Möbius-centred, not isometric: no excuse there.
  auto excuse = [&](const Layout& layout) {
    if (!(layout.max_edge_length_error > options.max_layout_error && std::isfinite(layout.max_edge_length_error) &&
          !sphere))
      return false;
    const std::vector<double> area = cut_face_areas(r.cut);
    const LayoutMisses m = layout_misses(r.disk, r.geometry, r.disk_lengths, layout.positions, area, options.max_layout_error);
    if (!(m.worst_unexplained <= 0 && m.area_fraction <= options.max_layout_error)) return false;
    r.layout_excused = m;
    return true;
  };
  auto misses = [&](const Layout& layout) {
    return layout.max_edge_length_error > options.max_layout_error || !std::isfinite(layout.max_edge_length_error);
  };
  bool excused = excuse(r.layout);
  // The coarse frames carry whatever their triangulation's angle sums miss (a solve that converged
  // only to its curvature resolution at near-coincident vertices): where their layout fails the
  // gate, the development through the faces themselves is tried and kept when it passes.
  if (r.layout.by_frames && !excused && misses(r.layout)) {
    LayoutOptions lo = run.layout_options;
    lo.frames = nullptr;
    Layout faces = sphere ? layout_sphere(topology, metric_l, lo) : layout_disk(r.disk, r.geometry, r.disk_lengths, lo);
    if (faces.status == Status::Ok && (!misses(faces) || excuse(faces))) {
      excused = misses(faces);
      r.layout = std::move(faces);
      stage_done("layout", "through the faces: " + r.layout.brief_report());
    }
  }
  // Faces the root chart's coordinates cannot resolve get charts of their own: where the layout
  // misses the limit; where it passes but flips a face (the metric is converged, so each triangle
  // has positive area and a flipped face is one the coordinates cannot resolve: a sliver far out
  // in the disk); and where it passes but some face misses the charts' own limit
  // (AtlasOptions::limit, 1e-9: a chart's coordinates should resolve every face it holds). In the
  // last two cases the atlas is kept only when it flips no more faces and, for the last, is more
  // accurate than the one chart. A layout the gate excuses (misses within its coordinates'
  // rounding at near-coincident vertices) gets charts too, kept when they pass the limit: a chart
  // around those vertices resolves them (random draw 31: 1.1e-6 excused, 21 charts within 9.8e-10
  // but for 2 needles); otherwise the excused layout stays.
  const bool flips_only = !misses(r.layout) && r.layout.flipped_faces > 0;
  const bool coarse = !misses(r.layout) && !(r.layout.max_edge_length_error <= options.atlas.limit);
  if (options.use_atlas && !sphere && (misses(r.layout) || flips_only || coarse)) {
    // New charts are developed by the coarse frames whenever there are any, also where the root
    // chart is the development through the faces: developed from their lengths, a chart of
    // needles is ill-conditioned (random draw 112: a collar missed by 27.5 of an edge; with frames,
    // 24 charts within 9.9e-10 but for 16 needles; draw 75's atlas, one chart at 6.2e-7 before,
    // 9 charts within 9.7e-10).
    AtlasOptions ao = options.atlas;
    ao.frames = run.layout_frames;
    r.atlas = layout_atlas(r.disk, r.geometry, r.disk_lengths, r.layout.positions, ao);
    const bool better = misses(r.layout) || (r.atlas.flipped_faces <= r.layout.flipped_faces &&
                                             (flips_only ? r.atlas.flipped_faces == 0
                                                         : r.atlas.max_edge_length_error < r.layout.max_edge_length_error));
    const bool needles_excused = needles_excused_in(r.atlas, options.max_layout_error);
    r.has_atlas = r.atlas.status == Status::Ok &&
                  (r.atlas.max_edge_length_error <= options.max_layout_error || needles_excused) && better;
    if (r.has_atlas) r.layout_excused = LayoutMisses{};  // the charts resolve what the gate excused
    stage_done("atlas", r.atlas.message + (!misses(r.layout) && !r.has_atlas ? " (not kept: the one chart is used)" : ""));
  }
  if (!excused && !r.has_atlas && misses(r.layout)) {
    r.layout.status = Status::NumericalFailure;
    return fail(Status::NumericalFailure, "layout",
                      "the layout reproduces the metric only to a relative edge-length error of " +
                          sci(r.layout.max_edge_length_error) + " (edge " + std::to_string(r.layout.worst_edge) +
                          ", limit " + sci(options.max_layout_error) + "); double-precision coordinates resolve " +
                          sci(r.layout.rounding_floor) + " here" +
                          (r.layout.rounding_floor > options.max_layout_error
                               ? ": the metric's conformal factor spans too many orders of magnitude for one chart"
                               : "") +
                          (r.atlas.status != Status::NotRun && r.atlas.status != Status::Ok
                               ? "; an atlas of charts failed too: " + r.atlas.message
                           : r.atlas.status == Status::Ok
                               ? "; an atlas misses the limit too: " + r.atlas.message
                               : ""));
  }

  return true;
}

// Cut (the compact domain, or a cut disk, or none for a sphere) and layout, then the accuracy
// gate: a layout that does not reproduce the metric is no result.
bool cut_and_lay_out(LayoutRun& run) {
  const Mesh& mesh = run.mesh;
  const Topology& topology = run.topology;
  const UniformizeOptions& options = run.options;
  const std::span<const double> metric_l = run.metric_l;
  UniformizeResult& r = run.r;
  StageClock& stage_done = run.stage_done;
  const bool sphere = run.sphere, closed_h = run.closed_h;
  const std::vector<Index>& cones = run.cones;
  auto fail = [&](Status s, const std::string& stage, const std::string& message) { return run.fail(s, stage, message); };
  // Bordered hyperbolic surfaces (all but a disk) are laid out through a compact domain too: their
  // canonical cuts reach as far out in the Poincaré disk as closed ones do. Should the compact
  // cut fail there, the canonical cut below is used instead.
  const bool bordered_h = !topology.is_closed() && r.geometry == Geometry::Hyperbolic &&
                          !(topology.genus() == 0 && topology.num_boundary_loops() == 1);
  // Cone vertices (interior, target K̄ ≠ 0) stay on the compact domain's cut, so that its layout
  // is consistent around them.
  const bool disk_like = sphere || (topology.genus() == 0 && topology.num_boundary_loops() == 1);
  if (!cones.empty() && disk_like)
    return fail(Status::InvalidArgument, "cut",
                      "the target has " + std::to_string(cones.size()) + " cone vertices (the first: vertex " +
                          std::to_string(cones[0]) + ") on a " + (sphere ? "sphere" : "disk") +
                          ", which is laid out uncut: a metric with cones is laid out only on surfaces whose "
                          "fundamental domain can be cut through them (genus >= 1, or several boundary loops)");
  // With cones every surface but a sphere and a disk takes the compact domain, whose cut passes
  // through them.
  CutResult compact_cut;
  if (closed_h || bordered_h || !cones.empty()) {
    start_angles_beside(run);
    compact_cut = cut_compact(mesh, topology, metric_l, -1, cones);
  }
  const bool compact = closed_h || (!cones.empty() && compact_cut.status == Status::Ok) ||
                       (bordered_h && compact_cut.status == Status::Ok);

  // The disk's layout, by the surface's coarse frames carried onto it when there are any.
  auto lay_out_disk = [&]() {
    if (run.surface_frames != nullptr) run.layout_frames = disk_frames(r.cut, topology, *run.surface_frames, r.geometry);
    r.layout = layout_disk(r.disk, r.geometry, r.disk_lengths, start_layout(run, r.disk));
    if (r.layout.status != Status::Ok) return fail(r.layout.status, "layout", r.layout.message);
    stage_done("layout", r.layout.brief_report());
    return true;
  };

  // ---- cut and layout ----
  if (sphere) {
    if (run.surface_frames != nullptr) run.layout_frames = std::make_shared<const FaceFrames>(*run.surface_frames);
    r.layout = layout_sphere(topology, metric_l, start_layout(run, topology));
    if (r.layout.status != Status::Ok) return fail(r.layout.status, "layout", r.layout.message);
    stage_done("layout", r.layout.brief_report());
  } else if (compact) {
    r.has_cut = true;
    DiskBuild d;
    d.cut = std::move(compact_cut);
    if (d.cut.status != Status::Ok) return fail(d.cut.status, "cut", d.cut.message);
    d.metric = refined_edge_lengths(d.cut, topology, r.geometry, metric_l);
    if (d.metric.status != Status::Ok) return fail(d.metric.status, "cut", d.metric.message);
    TopologyResult tr = take_disk_topology(d.cut, nullptr);
    if (tr.status != Status::Ok) return fail(Status::NumericalFailure, "cut", "the domain is not a valid mesh");
    r.cut = std::move(d.cut);
    r.cut_metric = std::move(d.metric);
    r.disk = std::move(tr.topology);
    r.disk_lengths = disk_edge_lengths(r.cut, r.cut_metric.surface, r.cut_metric.l, r.disk);
    stage_done("cut", "compact domain: " + std::to_string(r.cut.num_sides()) + " sides, " +
                          std::to_string(r.cut.num_generators()) + " side pairings");
    if (!lay_out_disk()) return false;
  } else {
    r.has_cut = true;
    CutResult* beside = run.cut_beside != nullptr ? run.cut_beside->take(mesh, topology) : nullptr;
    if (beside == nullptr) start_angles_beside(run);
    DiskBuild d = build_disk(mesh, topology, r.geometry, metric_l, options.cut, beside);
    r.cut = std::move(d.cut);
    r.cut_metric = std::move(d.metric);
    r.disk = std::move(d.disk);
    r.disk_lengths = std::move(d.lengths);
    if (d.status != Status::Ok) return fail(d.status, d.stage, d.message);
    stage_done("cut", r.cut.brief_report() + (beside != nullptr ? " (beside the flow)" : ""));
    if (beside != nullptr) {
      run.known_central = run.cut_beside->central;
      run.known_farthest = run.cut_beside->farthest;
    }
    if (!lay_out_disk()) return false;
  }

  if (!gate_layout(run)) return false;
  // The layout's shapes (corner angles, face areas) go to the seed check, whose layouts of the same
  // lengths read them instead of computing them again; the result does not keep them.
  std::shared_ptr<const LayoutShapes> shapes = std::move(r.layout.shapes);
  const Index seed = run.layout_options.seed_face;
  if (run.seed_check != nullptr && run.laid_out != nullptr && seed >= 0 && seed < run.laid_out->num_faces) {
    run.seed_check->shapes = std::move(shapes);
    start_seed_check(run, *run.seed_check, *run.laid_out, seed);
  }
  return true;
}

bool finish_seed_check(LayoutRun& run, SeedCheck& sc) {
  UniformizeResult& r = run.r;
  if (sc.worker.joinable()) sc.worker.join();
  if (sc.later) sc.later();
  if (sc.error) std::rethrow_exception(sc.error);
  // The layout's own positions, back in its isometric frame (E's unit box is a translation and a
  // uniform scale).
  std::vector<double> own = r.layout.positions;
  if (r.geometry == Geometry::Euclidean && r.layout.scale != 1)
    for (double& x : own) x /= r.layout.scale;
  // The layouts are compared on the vertices both resolve: every edge at the vertex within
  // max_layout_error in each (and, with an atlas, in the first chart's faces: the others are
  // exactly those one chart's coordinates cannot resolve). A propagation from a far seed may reach
  // where its coordinates resolve nothing (the surface's far end in the disk); its positions there
  // are rounding, not a second opinion on the layout.
  const bool sphere = r.geometry == Geometry::Spherical;
  const std::vector<std::uint8_t> own_ok =
      sphere ? std::vector<std::uint8_t>{}
             : resolved_vertices(r.disk, r.geometry, r.disk_lengths, own, run.options.max_layout_error);
  std::vector<std::uint8_t> in_root(static_cast<std::size_t>(r.disk.num_vertices), r.has_atlas ? 0 : 1);
  if (r.has_atlas)
    for (Index f = 0; f < r.disk.num_faces; ++f)
      if (r.atlas.face_chart[f] == 0)
        for (int c = 0; c < 3; ++c) in_root[r.disk.corner_vertex[3 * f + c]] = 1;
  auto restrict = [&](const std::vector<double>& x, const std::vector<std::uint8_t>& keep) {
    std::vector<double> y;
    for (Index v = 0; v < r.disk.num_vertices; ++v)
      if (keep[v]) y.insert(y.end(), {x[2 * v], x[2 * v + 1]});
    return y;
  };
  // In the plane such a layout can span many orders of magnitude, so there the distance is taken
  // relative to the first chart's extent (its largest distance from its points' mean).
  double scale = 1;
  if (r.has_atlas && r.geometry == Geometry::Euclidean) {
    double mx = 0, my = 0, far = 0, n = 0;
    for (Index v = 0; v < r.disk.num_vertices; ++v)
      if (in_root[v]) mx += own[2 * v], my += own[2 * v + 1], n += 1;
    if (n > 0) mx /= n, my /= n;
    for (Index v = 0; v < r.disk.num_vertices; ++v)
      if (in_root[v]) far = std::max(far, std::hypot(own[2 * v] - mx, own[2 * v + 1] - my));
    if (far > 0) scale = far;
  }
  for (std::size_t k = 0; k < sc.seeds.size(); ++k) {
    const Layout& other = sc.layouts[k];
    if (other.status != Status::Ok) return run.fail(other.status, "seed_check", other.message);
    r.seed_faces_checked.push_back(sc.seeds[k]);
    if (sphere) {  // Möbius-centred positions: both resolve the whole sphere or the gate failed
      r.seed_independence_error =
          std::max(r.seed_independence_error, layout_alignment_error(r.geometry, own, other.positions));
      continue;
    }
    std::vector<std::uint8_t> keep =
        resolved_vertices(r.disk, r.geometry, r.disk_lengths, other.positions, run.options.max_layout_error);
    Index compared = 0;
    for (Index v = 0; v < r.disk.num_vertices; ++v) {
      keep[v] = keep[v] && own_ok[v] && in_root[v];
      compared += keep[v];
    }
    r.seed_check_vertices = k == 0 ? compared : std::min(r.seed_check_vertices, compared);
    if (compared < 3) continue;  // nothing both resolve to align on: seed_check_vertices says so
    r.seed_independence_error = std::max(
        r.seed_independence_error, layout_alignment_error(r.geometry, restrict(own, keep), restrict(other.positions, keep)) / scale);
  }
  run.stage_done("seed_check", "max deviation " + sci(r.seed_independence_error) + " over " +
                                   std::to_string(r.seed_faces_checked.size()) + " seeds" +
                                   (sphere ? std::string()
                                           : " on the " + std::to_string(r.seed_check_vertices) + " of " +
                                                 std::to_string(r.disk.num_vertices) + " vertices both resolve") +
                                   ", laid out in " +
                                   sci(sc.seconds) + " s" + (sc.beside ? " beside the polygon and deck stages" : ""));
  return true;
}

// The deck stage's line when the compact domain's side pairings stand as the deck group.
std::string pairings_line(const UniformizeResult& r) {
  return "deck: " + std::to_string(r.domain_maps.size()) + " domain pairings (vertex cycles " + sci(r.domain_cycle_error) +
         ")";
}

// The side pairings of a compact domain's layout, into r.
void take_domain(UniformizeResult& r, const DomainDeck& dd) {
  r.domain_maps = dd.side_maps;
  r.domain_cycle_error = dd.cycle_error;
  r.domain_adjusted_cycle_error = dd.adjusted_cycle_error;
  r.domain_pairing_adjustment = dd.pairing_adjustment;
  r.fitted_relation_error = dd.fitted_relation_error;
  r.tile_consistency = dd.tile_consistency;
}

// The geodesic polygon of generators given in some frame, re-expressed in that frame (vertices
// moved back by its frame, which becomes the identity; the generators are `deck`'s own).
GeodesicPolygon geodesic_in_frame_of(const DeckResult& deck) {
  GeodesicPolygon gp = geodesic_polygon(deck);
  if (gp.status != Status::Ok) return gp;
  const Moebius back = gp.frame.inverse();
  for (std::complex<double>& z : gp.vertices) z = back.apply(z);
  const double relation = gp.deck.relation_error;
  gp.deck = deck;
  gp.deck.relation_error = relation;  // measured at corner 0, in quad
  gp.frame = Moebius{};
  return gp;
}

// Closed genus >= 2 in H, the default: canonical generators from the compact domain's side
// pairings (canonical_generators()) and their geodesic 4g-gon (geodesic_polygon()), kept when
// the polygon is a fundamental domain (simple, angle sum 2π) and the relation holds to 1e-12.
// Where quad cannot hold the polygon — it is simple and misses 1e-12 only by what quad generators
// resolve at its reach, or its generators or corners lie beyond quad's range — the same runs
// again with the pairings closed in quad-double (DeckOptions::wide_pairings: about 212 bits), the
// words the search chose evaluated and the polygon formed there. Otherwise polygon_note says why
// and the caller tries the mesh path (Fallback), unless the domain's pairings themselves failed
// (PairingsFailed: the mesh path needs the same pairings) or quad-double cannot hold the polygon
// either (BeyondQuad: the domain's pairings stand as the deck group; the mesh path's generators
// are products of the same pairings, and its view needs a reach double coordinates resolve).
enum class GeodesicOutcome { Done, Fallback, PairingsFailed, BeyondQuad };

namespace {

// One attempt at the geodesic polygon from fitted pairings: what it gave, and why not when it
// gave none (`beyond`: the arithmetic's range or floor, not the group, stopped it).
struct GeodesicAttempt {
  CanonicalGenerators cg;
  GeodesicPolygon gp;
  bool done = false;
  bool beyond = false;
  std::string note;
};

// `found`: canonical generators whose words are evaluated again in dd's pairings (not searched).
GeodesicAttempt geodesic_attempt(const CutResult& domain, const DomainDeck& dd, int bits,
                                 const CanonicalGenerators* found = nullptr) {
  GeodesicAttempt a;
  const std::string arithmetic = bits > 113 ? "quad-double (" + std::to_string(bits) + "-bit)" : "quad (113-bit)";
  a.cg = found != nullptr ? evaluate_canonical_words(*found, dd.side_maps, dd.fitted_side_maps)
                          : canonical_generators(domain, dd.side_maps, dd.fitted_side_maps);
  if (a.cg.status != Status::Ok) {
    a.beyond = a.cg.beyond_quad;
    a.note = a.beyond ? "no canonical polygon: the canonical generators found reach beyond " + arithmetic + " range (" +
                            a.cg.message + ")"
                      : "no geodesic polygon (" + a.cg.message + ")";
    return a;
  }
  a.gp = geodesic_polygon(a.cg);
  const GeodesicPolygon& gp = a.gp;
  if (gp.status != Status::Ok && gp.beyond_quad) {
    a.beyond = true;
    a.note = "no canonical polygon: " + gp.message.substr(0, gp.message.size() - 1) + " (generators in " + arithmetic +
             " arithmetic)";
    return a;
  }
  if (gp.status == Status::Ok && gp.at_quad_floor) {
    char buf[420];
    std::snprintf(buf, sizeof buf,
                  "no canonical polygon: the geodesic %d-gon of the canonical generators found is simple but reaches "
                  "%.1f from its centre, where generators in %s arithmetic resolve the relation only to about %.2g "
                  "(it holds to %.2g, above 1e-12)",
                  static_cast<int>(gp.vertices.size()), gp.reach, arithmetic.c_str(), gp.relation_floor,
                  gp.deck.relation_error);
    a.beyond = true;
    a.note = buf;
    return a;
  }
  if (gp.status != Status::Ok || !gp.fundamental || !(gp.deck.relation_error <= 1e-12)) {
    a.note = "no geodesic polygon: " + gp.message;
    return a;
  }
  a.done = true;
  return a;
}

}  // namespace

GeodesicOutcome geodesic_canonical_polygon(LayoutRun& run, DomainDeck& pairings_failure) {
  UniformizeResult& r = run.r;
  DomainDeck dd = fit_domain_pairings(r.cut, r.layout.positions, run.options.deck, &run.topology);
  if (dd.status != Status::Ok) {
    pairings_failure = std::move(dd);
    return GeodesicOutcome::PairingsFailed;
  }
  GeodesicAttempt a = geodesic_attempt(r.cut, dd, 113);
  // Quad's range or floor: the pairings closed in quad-double, the same search, its words and
  // polygon evaluated there (the mesh path's polygon, a canonical cut laid out in double, resolves
  // less: on the random surfaces of tools/SWEEP-random-surfaces.md that stopped here it never gave
  // a view, and it cost up to 200 times the flow).
  if (!a.done && a.beyond && run.options.deck.adjust_pairings && !dd.wide) {
    DomainDeck dw = widen_domain_pairings(r.cut, r.layout.positions, dd, run.options.deck, &run.topology);
    if (dw.status == Status::Ok && dw.wide) {
      // The words the quad search chose, when it got that far (its polygon is the shortest that
      // quad could score); else the search again on the closer pairings.
      const bool words = !a.cg.word_letters.empty();
      GeodesicAttempt b = geodesic_attempt(r.cut, dw, 212, words ? &a.cg : nullptr);
      if (b.done || b.beyond) {
        a = std::move(b);
        dd = std::move(dw);
      }
    }
  }
  if (!a.done && a.beyond) {
    // The domain's pairings stand as the deck group, and no mesh path is tried.
    r.polygon_note = a.note + "; the deck group is given by the compact domain's side pairings";
    take_domain(r, dd);
    r.deck = DeckResult{};
    run.stage_done("polygon", r.polygon_note);
    run.stage_done("deck", pairings_line(r));
    return GeodesicOutcome::BeyondQuad;
  }
  if (!a.done) {
    r.polygon_note = a.note;
    return GeodesicOutcome::Fallback;
  }
  CanonicalGenerators& cg = a.cg;
  GeodesicPolygon& gp = a.gp;
  take_domain(r, dd);
  r.fitted_relation_error = cg.fitted_relation_error;
  r.deck = gp.deck;
  r.deck.status = Status::Ok;
  r.deck.message = cg.message;
  r.deck.seconds = cg.deck.seconds + gp.seconds;
  r.canonical_words = std::move(cg.words);
  r.geodesic_polygon = std::move(gp);
  r.has_geodesic_polygon = true;
  r.has_deck = true;
  r.polygon_note.clear();
  run.stage_done("polygon", r.geodesic_polygon.message + (dd.wide ? " (in quad-double: quad's floor at its reach)" : ""));
  run.stage_done("deck", "deck: " + std::to_string(r.deck.generators.size()) + " generators from " +
                             std::to_string(r.domain_maps.size()) + " domain pairings (vertex cycles " +
                             sci(r.domain_cycle_error) + ", adjusted by " + sci(r.domain_pairing_adjustment) +
                             (dd.wide ? ", closed in quad-double to " + sci(dd.wide_cycle_error) : std::string()) +
                             "), " + std::to_string(cg.moves) + " moves on the word, relation error " +
                             sci(r.deck.relation_error));
  return GeodesicOutcome::Done;
}

bool mesh_canonical_polygon(LayoutRun& run);

// Closed genus >= 2 in H with mesh_polygon (or when the geodesic polygon is not a fundamental
// domain): canonical cuts from a few base vertices, each laid out through the compact domain's
// tiles; the one double precision resolves best is kept (then the polygon, its generators and
// deck), else generators without a view, else the domain's side pairings alone. The geodesic
// polygon of the generators found is added when it is a fundamental domain.
bool canonical_polygon(LayoutRun& run) {
  if (!run.options.mesh_polygon) {
    DomainDeck failed;
    const GeodesicOutcome outcome = geodesic_canonical_polygon(run, failed);
    if (outcome == GeodesicOutcome::Done || outcome == GeodesicOutcome::BeyondQuad) return true;
    if (outcome == GeodesicOutcome::PairingsFailed) return run.fail(failed.status, "deck", failed.message);
  }
  const std::string geodesic_note = run.r.polygon_note;
  if (!mesh_canonical_polygon(run)) return false;
  UniformizeResult& r = run.r;
  if (r.has_deck) {
    GeodesicPolygon gp = geodesic_in_frame_of(r.deck);
    if (gp.status == Status::Ok && gp.fundamental) {
      r.geodesic_polygon = std::move(gp);
      r.has_geodesic_polygon = true;
    }
  }
  if (!geodesic_note.empty())
    r.polygon_note = geodesic_note + (r.polygon_note.empty() ? "" : "; " + r.polygon_note);
  return true;
}

// The deck stage's line for canonical generators formed through the domain's pairings.
std::string generators_line(const UniformizeResult& r) {
  return "deck: " + std::to_string(r.deck.generators.size()) + " generators from " +
         std::to_string(r.domain_maps.size()) + " domain pairings (vertex cycles " + sci(r.domain_cycle_error) +
         ", adjusted by " + sci(r.domain_pairing_adjustment) + "), residual max " + sci(r.deck.residual_max) +
         ", relation error " + sci(r.deck.relation_error) + " (" + sci(r.fitted_relation_error) + " as fitted)";
}

// The end of mesh_canonical_polygon(): the polygon found (`found`: r.polygon and r.deck hold the
// best base's), else canonical generators without a view (deck_only), else the compact domain's
// side pairings alone; the polygon note and the stage lines say which.
bool report_mesh_polygon(LayoutRun& run, bool found, std::optional<DomainDeck>& deck_only, CutResult& deck_only_cut,
                         const std::string& last_error) {
  UniformizeResult& r = run.r;
  StageClock& stage_done = run.stage_done;
  if (!found && deck_only) {
    // Canonical generators whose polygon double precision cannot draw.
    r.polygon_note = "no canonical polygon view: " + deck_only->positions_note +
                     "; the canonical generators stand (products of the domain's side pairings, relation in quad)";
    take_domain(r, *deck_only);
    r.deck = std::move(deck_only->deck);
    r.polygon_cut = std::move(deck_only_cut);
    r.has_deck = true;
    stage_done("polygon", r.polygon_note);
    stage_done("deck", generators_line(r));
  } else if (!found) {
    // The layout and the domain's side pairings stand; only the canonical view is missing.
    const std::size_t tried = r.candidates.size();
    const std::string which = tried == 1 ? "the one base vertex tried gave none"
                                         : "none of the " + std::to_string(tried) + " base vertices tried gave one";
    r.polygon_note = "no canonical polygon: " + which + " that double precision can lay out (last: " + last_error +
                     "); the deck group is given by the compact domain's side pairings";
    r.deck = DeckResult{};
    {
      DomainDeck dd = fit_domain_pairings(r.cut, r.layout.positions, run.options.deck, &run.topology);
      if (dd.status != Status::Ok) return run.fail(dd.status, "deck", dd.message);
      take_domain(r, dd);
    }
    stage_done("polygon", r.polygon_note);
    stage_done("deck", pairings_line(r));
  } else {
    r.has_polygon = true;
    r.has_deck = true;
    if (r.polygon.max_edge_length_error > 1e-9) {
      // The view is drawn but coarse: say where its digits went.
      double reach = 0;
      for (std::size_t i = 0; i + 1 < r.polygon.positions.size(); i += 2)
        reach = std::max(reach, std::hypot(r.polygon.positions[i], r.polygon.positions[i + 1]));
      char buf[400];
      std::snprintf(buf, sizeof buf,
                    "the canonical polygon reaches hyperbolic distance %.1f from its centre, where double coordinates "
                    "resolve lengths only to about %.1g: its edge error is %.2g, %d faces flipped (the layout, the "
                    "generators and the relation do not depend on these coordinates)",
                    2 * std::atanh(std::min(reach, 1 - 1e-16)), r.polygon.rounding_floor,
                    r.polygon.max_edge_length_error, static_cast<int>(r.polygon.flipped_faces));
      r.polygon_note = buf;
    }
    stage_done("polygon", "canonical polygon " + r.polygon_cut.word + " (base vertex " +
                              std::to_string(r.polygon_cut.base_vertex) + ", best of " +
                              std::to_string(r.candidates.size()) + "): edge error " +
                              sci(r.polygon.max_edge_length_error) + ", rounding floor " + sci(r.polygon.rounding_floor));
    stage_done("deck", generators_line(r));
  }
  return true;
}

// The most vertices per face a mesh-path canonical cut may add (CutOptions::max_refined_per_face).
// A view double precision lays out comes from short loops: the canonical cuts measured that gave
// one added at most 0.28 per face (eight.off 178 on 634 faces, botijo 21785 on 82332); pretzel(8, 4)'s
// 70268 on 5056 faces reach hyperbolic distance 38.4, beyond double, and a genus-11 common
// subdivision's 1.5M-4.2M on 230k faces leave even quad range, at 30-43 s a cut. Past this bound
// the cut stops, and with it the search for a base (refinement_bound).
constexpr double kMeshPolygonRefinedPerFace = 1;

// The mesh path (see canonical_polygon()).
bool mesh_canonical_polygon(LayoutRun& run) {
  const Mesh& mesh = run.mesh;
  const Topology& topology = run.topology;
  const UniformizeOptions& options = run.options;
  const std::span<const double> metric_l = run.metric_l;
  UniformizeResult& r = run.r;
  std::vector<Index> bases;
  if (options.cut.base_vertex >= 0) bases.push_back(options.cut.base_vertex);
  else bases = base_candidates(topology, mesh.faces, metric_l, options.base_candidates);
  if (bases.empty()) bases.push_back(-1);
  double best_score = kInf;
  // Consecutive bases whose score matched the best one's to 1 %: the polygon's error is then the
  // metric's, not the base's (on fine meshes every base gives the same edge error), and further
  // bases, a cut and a layout each, will not lower it.
  int matching = 0;
  std::string last_error = "no base vertex tried";
  std::optional<DomainDeck> deck_only;
  CutResult deck_only_cut;
  for (Index base : bases) {
    // Three bases none of which could be laid out: the surface's canonical polygons reach beyond
    // double range (long loops); more bases cost a cut each and have not helped in practice.
    if (!std::isfinite(best_score) && r.candidates.size() >= 3) break;
    const Clock::time_point tc = Clock::now();
    BaseCandidate bc;
    bc.base_vertex = base;
    CutOptions co = options.cut;
    co.base_vertex = base;
    co.max_refined_per_face = std::min(co.max_refined_per_face, kMeshPolygonRefinedPerFace);
    CutResult pc = cut_surface(mesh, topology, co);
    auto reject = [&](const std::string& why) {
      last_error = why;
      bc.note = why;
      bc.seconds = since(tc);
      r.candidates.push_back(bc);
    };
    if (pc.status != Status::Ok || !pc.canonical) {
      reject(pc.status != Status::Ok ? pc.message : "the cut is not canonical: " + pc.reason);
      // Loops past the refinement bound: the canonical system crosses the surface that often from
      // any base (measured: all three bases tried on a genus-9 grid), and each try costs seconds.
      if (pc.status == Status::Ok && pc.refinement_bound) break;
      continue;
    }
    bc.base_vertex = pc.base_vertex;
    bc.refined_vertices = pc.num_refined_vertices();
    RefinedMetric pm = refined_edge_lengths(pc, topology, r.geometry, metric_l);
    pc.surface_topology = Topology{};  // pm.surface has it
    if (pm.status != Status::Ok) {
      reject(pm.message);
      continue;
    }
    // The deck first: it reads the canonical disk's connectivity from the cut, then moved out.
    DomainDeck dd = deck_through_domain(pc, r.cut, r.layout.positions, options.deck, &topology);
    if (dd.status != Status::Ok) {
      reject(dd.message);
      continue;
    }
    TopologyResult pt = take_disk_topology(pc, nullptr);
    if (pt.status != Status::Ok) {
      reject("the canonical disk is not a valid mesh");
      continue;
    }
    std::vector<double> pl = disk_edge_lengths(pc, pm.surface, pm.l, pt.topology);
    if (!dd.positions_note.empty()) {
      // Generators without a view of the polygon: kept in case no base gives one, when their
      // relation and residual are within polygon_tolerance. Beyond double range the canonical
      // cut's positions are not those of the loops (pretzel(12, 4): relation 3.6e7, residual
      // 0.55), and such generators are no deck group: the domain's side pairings stand instead.
      bc.relation_error = dd.deck.relation_error;
      const double worst = std::max(dd.deck.relation_error, dd.deck.residual_max);
      if (!(worst <= options.polygon_tolerance)) {
        reject(dd.positions_note + "; its generators are not kept (relation error " + sci(dd.deck.relation_error) +
               ", residual " + sci(dd.deck.residual_max) + ")");
        continue;
      }
      reject(dd.positions_note);
      if (!deck_only || dd.deck.residual_max < deck_only->deck.residual_max) {
        deck_only = std::move(dd);
        deck_only_cut = std::move(pc);
      }
      continue;
    }
    Layout poly = measure_layout(pt.topology, r.geometry, pl, dd.canonical_positions);
    if (poly.status != Status::Ok) {
      reject(poly.message);
      continue;
    }
    bc.relation_error = dd.deck.relation_error;
    bc.rounding_floor = poly.rounding_floor;
    bc.max_edge_length_error = poly.max_edge_length_error;
    reject("");
    const double score = std::max({dd.deck.relation_error, poly.max_edge_length_error, poly.rounding_floor});
    matching = std::isfinite(best_score) && std::abs(score - best_score) <= 0.01 * best_score ? matching + 1 : 0;
    if (score < best_score) {
      best_score = score;
      r.polygon_cut = std::move(pc);
      r.polygon_disk = std::move(pt.topology);
      r.polygon_lengths = std::move(pl);
      r.polygon = std::move(poly);
      take_domain(r, dd);
      r.deck = std::move(dd.deck);
    }
    if (best_score < options.polygon_tolerance || (options.polygon_tolerance > 0 && matching >= 2)) break;
  }
  return report_mesh_polygon(run, std::isfinite(best_score), deck_only, deck_only_cut, last_error);
}

void layout_stages(const Mesh& mesh, const Topology& topology, const UniformizeOptions& options,
                   std::span<const double> metric_l, UniformizeResult& r, Clock::time_point start,
                   const FaceFrames* frames, CutBeside* cut_beside) {
  StageClock stage_done{r, options};
  LayoutRun run{mesh, topology, options, metric_l, r, start, stage_done, false, false, {}};
  run.surface_frames = frames;
  run.cut_beside = cut_beside;
  run.sphere = topology.is_closed() && topology.euler_characteristic() == 2;
  run.closed_h = topology.is_closed() && topology.genus() >= 2 && r.geometry == Geometry::Hyperbolic;
  run.cones = cone_vertices(topology, r.target.K);
  SeedCheck seed_check;  // on a second thread until finish_seed_check() (joined on every return)
  if (options.seed_checks > 0) run.seed_check = &seed_check;
  AnglesBeside angles;  // on a second thread until joined below (and on every return)
  run.angles = &angles;
  if (!cut_and_lay_out(run)) return;

  // ---- the canonical polygon and the deck transformations (closed genus >= 1) ----
  // A metric with cones is no uniformization: its side pairings generate no surface group (the
  // cycle at a cone turns by the cone angle), so there is no deck group, polygon or cover.
  if (!run.cones.empty())
    r.flow.notes.push_back("the target has " + std::to_string(run.cones.size()) +
                           " cone vertices: the compact domain's cut passes through each, and no deck group, canonical "
                           "polygon or cover is made (the metric is not a uniformization)");
  if (run.closed_h && run.cones.empty()) {
    if (!canonical_polygon(run)) return;
  } else if (run.cones.empty() && !run.sphere && topology.is_closed() && topology.genus() == 1 &&
             r.geometry == Geometry::Euclidean && r.cut.canonical) {
    r.has_polygon = true;
    r.polygon_cut = r.cut;
    r.polygon_disk = r.disk;
    r.polygon_lengths = r.disk_lengths;
    r.polygon = r.layout;
    r.has_deck = true;
    r.deck = fit_deck_transformations(r.cut, r.geometry, r.layout.positions, options.deck);
    if (r.deck.status != Status::Ok) return (void)run.fail(r.deck.status, "deck", r.deck.message);
    stage_done("deck", r.deck.brief_report());
  }

  // ---- angle distortion ----
  if (angles.worker.joinable()) {
    angles.worker.join();
    if (angles.error) std::rethrow_exception(angles.error);
    r.angles = std::move(angles.result);
  } else {
    r.angles = angle_distortion(mesh, topology, r.geometry, metric_l);
  }
  stage_done("angles", "mean |log ratio| " + sci(r.angles.mean_abs_log) + ", max " + sci(r.angles.max_abs_log));
  if (run.seed_check != nullptr && !finish_seed_check(run, seed_check)) return;

  r.status = Status::Ok;
  r.message = "ok";
  r.seconds = since(start);
}

}  // namespace

InputSurfaceLayout input_surface_layout(const Mesh& mesh, const Topology& topology, const UniformizeResult& r) {
  InputSurfaceLayout out;
  const CommonSubdivision& s = r.refinement;
  const Index nv = topology.num_vertices, F = topology.num_faces;
  if (!r.intrinsic.refined || r.status != Status::Ok || s.status != Status::Ok || s.topology.num_vertices < nv ||
      mesh.num_vertices() != nv || mesh.num_faces() != F) {
    out.status = Status::InvalidArgument;
    out.message = "the result has no layout of a common subdivision of this mesh";
    return out;
  }
  out.mesh.faces = mesh.faces;
  const std::vector<double>& x = r.layout.positions;
  auto orientation = [&](const double* a, const double* b, const double* c, Index dims) {
    if (dims == 3)
      return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
    double p[3][2];
    const double* q[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      // Klein coordinates in H (geodesics straight there); the plane as it is in E.
      const double w = r.geometry == Geometry::Hyperbolic ? 2 / (1 + q[k][0] * q[k][0] + q[k][1] * q[k][1]) : 1.0;
      p[k][0] = w * q[k][0];
      p[k][1] = w * q[k][1];
    }
    return (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
  };
  auto count = [&](Index f, double o) {
    if (o > 0) return;
    if (out.flipped_faces++ == 0) out.first_flipped_face = f;
  };
  if (!r.has_cut) {
    out.mesh.positions.assign(x.begin(), x.begin() + 3 * nv);
    for (Index f = 0; f < F; ++f)
      count(f, orientation(&x[3 * mesh.faces[3 * f]], &x[3 * mesh.faces[3 * f + 1]], &x[3 * mesh.faces[3 * f + 2]], 3));
  } else {
    // Each input corner takes the cut vertex of its vertex in a piece of its face.
    const CutResult& cut = r.cut;
    std::vector<Index> corner_cut(static_cast<std::size_t>(3 * F), kInvalid), corner_src(corner_cut.size(), kInvalid);
    for (Index c = 0; c < static_cast<Index>(cut.cut_faces.size()); ++c) {
      const Index sv = cut.cut_to_surface[cut.cut_faces[c]];
      if (sv >= nv) continue;
      const Index f = s.face_input[cut.surface_face_to_input[corner_face(c)]];
      for (Index k = 0; k < 3; ++k)
        if (mesh.faces[3 * f + k] == sv && corner_cut[3 * f + k] == kInvalid) {
          corner_cut[3 * f + k] = cut.cut_faces[c];
          corner_src[3 * f + k] = c;
        }
    }
    if (std::find(corner_cut.begin(), corner_cut.end(), kInvalid) != corner_cut.end()) {
      out.status = Status::NumericalFailure;
      out.message = "an input corner has no piece in the common subdivision";
      return out;
    }
    out.mesh.positions = mesh.positions;
    if (r.has_atlas) {
      // Each input face in the chart of the piece holding its corner 0, the other corners carried
      // into it when their pieces lie in other charts; a texture coordinate per corner.
      const LayoutAtlas& a = r.atlas;
      out.face_chart.resize(static_cast<std::size_t>(F));
      out.mesh.texcoords.resize(6 * static_cast<std::size_t>(F));
      out.mesh.corner_texcoords.resize(3 * static_cast<std::size_t>(F));
      for (Index f = 0; f < F; ++f) {
        const Index chart = a.face_chart[corner_face(corner_src[3 * f])];
        out.face_chart[f] = chart;
        for (Index k = 0; k < 3; ++k) {
          const Index c = corner_src[3 * f + k];
          const std::complex<double> z =
              chart_to_chart(a, r.geometry, a.face_chart[corner_face(c)], chart,
                             {a.corner_positions[2 * c], a.corner_positions[2 * c + 1]});
          out.mesh.texcoords[6 * f + 2 * k] = z.real();
          out.mesh.texcoords[6 * f + 2 * k + 1] = z.imag();
          out.mesh.corner_texcoords[3 * f + k] = 3 * f + k;
        }
        count(f, orientation(&out.mesh.texcoords[6 * f], &out.mesh.texcoords[6 * f + 2], &out.mesh.texcoords[6 * f + 4], 2));
      }
    } else {
      out.mesh.texcoords = x;
      out.mesh.corner_texcoords = corner_cut;
      for (Index f = 0; f < F; ++f)
        count(f, orientation(&x[2 * corner_cut[3 * f]], &x[2 * corner_cut[3 * f + 1]], &x[2 * corner_cut[3 * f + 2]], 2));
    }
  }
  out.status = Status::Ok;
  out.message = "ok";
  return out;
}

}  // namespace ricci
