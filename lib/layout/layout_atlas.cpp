// The atlas of charts (layout.h, "An atlas of charts"): takes a disk, its edge lengths and one
// layout of it (E or H); gives charts, each face's corners in its own chart, and the transition
// maps between charts (H composed in quad). Calls the layout's propagation (layout_internal.h).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include "layout_internal.h"
#include "model_geometry.h"
#include "moebius_quad.h"
#include "ricci/layout.h"

namespace ricci {

namespace {

using Cx = std::complex<double>;

std::string sci(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", x);
  return b;
}

double planar_distance(Geometry g, Cx a, Cx b) {
  return g == Geometry::Hyperbolic ? model::disk_distance(a, b) : std::abs(a - b);
}

/// The atlas while it is built.
struct AtlasBuild {
  const Topology& t;
  Geometry g;
  std::span<const double> l;
  const AtlasOptions& options;
  LayoutAtlas& out;
  std::vector<double> face_error;  ///< #F: max relative edge error of the face in its chart
  std::vector<double> face_floor;  ///< #F: its rounding floor there (rounding_drift() / length)
  std::span<const double> root_positions;  ///< #V×2: the root layout's (layout_atlas()'s input)
  std::vector<Index> owner;        ///< scratch labels for a chart's propagation (-1 elsewhere)
  /// #F: the face stays unresolved in the chart made for its own group (laid out from that
  /// group's smallest face, near its origin) and no further chart resolves it better, so it starts
  /// no group of its own (see LayoutAtlas::unresolvable_faces); a deferred() face is not settled.
  std::vector<std::uint8_t> settled;
  /// #F: the face was missed, beyond rounding, by the chart made for its group although that
  /// chart was not seeded at it. A development from a seed elsewhere reaches such a face along
  /// two branches that close around the vertices between them, each turning the far branch by
  /// its angle-sum residual (H: times sinh of its distance): a large group's chart can miss a face
  /// where its branches meet although the lengths close. Once per face, it is not settled but
  /// starts a group of that chart, whose own chart is made from that group's smallest face; a
  /// face missed again there is settled (unresolvable, or lengths that are not one metric).
  std::vector<std::uint8_t> retried;
  bool retry(Index f, Index seed) {
    if (f == seed || retried[f] || rounding_only(f)) return false;
    retried[f] = 1;
    return true;
  }
  /// #F: the face's floor when it was last deferred() into a nested group (+∞: never). A nested
  /// chart is laid out again from a face across from its collar when its seed is far from it, so
  /// it need not lie around the faces it was made for: a face deferred again at the same floor
  /// would start the same group in a chart of the same seed, nesting without end. A face is
  /// deferred again only where its floor fell kNestGain times since; otherwise it is settled
  /// (unresolvable).
  std::vector<double> deferred_at;
  bool defer(Index f) {
    if (!deferred(f) || !(face_floor[f] * kNestGain <= deferred_at[f])) return false;
    deferred_at[f] = face_floor[f];
    return true;
  }
  /// #F, with coarse frames: the rounding of the face's own coarse face, relative to the face's
  /// shortest edge — 2^-53 × the coarse face's longest side l / that edge (in H 2^-53 sinh l: its
  /// model triangle's coordinates grow with the distance from the pole). Every chart places the
  /// face's corners by that face's one isometry, so even the chart made for it resolves the face
  /// only to about that (a needle of the common subdivision, an edge 1e-11 of its coarse face:
  /// about 1e-5); an error within it there is rounding, not lengths that are not one metric.
  std::vector<double> frame_floor;
  /// Errors within this many times the frame floor are that rounding (rounding_only()).
  static constexpr double kFrameAllowance = 64;
  bool rounding_only(Index f) const {
    return !frame_floor.empty() && face_error[f] <= kFrameAllowance * frame_floor[f];
  }
  /// The least rounding floor any chart can give the face: its frame floor with coarse frames,
  /// else 2^-53 × its longest edge / its shortest (the face laid out at a chart's origin).
  double best_floor(Index f) const {
    if (!frame_floor.empty()) return frame_floor[f];
    return 0x1p-53 * longest(f) / shortest(f);
  }
  /// A face left unresolved in the chart made for its group, but only by that chart's floor
  /// where it lies (within kFrameAllowance of face_floor) while a chart around it would resolve
  /// it kNestGain times better: it is not settled there but starts a group of that chart, whose
  /// own chart is made around it (a needle at |z| = 0.98 of a chart seeded elsewhere in its
  /// group).
  static constexpr double kNestGain = 4;
  bool deferred(Index f) const {
    return face_error[f] <= kFrameAllowance * face_floor[f] && face_floor[f] > kNestGain * best_floor(f);
  }

  Cx corner(Index f, int c) const { return {out.corner_positions[6 * f + 2 * c], out.corner_positions[6 * f + 2 * c + 1]}; }

  /// How far rounding can move the distance of a and b: as Layout::rounding_floor's, but with
  /// each coordinate's own magnitude (doubles resolve a point near a chart's origin relative to
  /// its distance from it).
  double rounding_drift(Cx a, Cx b) const {
    constexpr double u = 0x1p-53;
    if (g == Geometry::Euclidean) return u * std::sqrt(2.0) * (std::abs(a) + std::abs(b));
    const double ra = std::abs(a), rb = std::abs(b), da = (1 - ra) * (1 + ra), db = (1 - rb) * (1 + rb);
    if (!(da > 0 && db > 0)) return std::numeric_limits<double>::infinity();
    return 2 * u * std::sqrt(2.0) * (ra / da + rb / db);
  }

  /// Why a chart misses by `miss` (of an edge of length `unit`) near vertex p, as far as the
  /// lengths tell. They close around each interior vertex v of the disk only to its angle-sum
  /// residual δ_v (|2π − Σθ|; the target is flat inside the disk: cones lie on its boundary), so
  /// two developments that pass v on either side differ by a turn δ_v about it: at p, by
  /// δ_v·sinh(d(p, v)) in H, δ_v·d(p, v) in E. Their sum over the vertices, with distances in the
  /// root layout, bounds what the residuals can do there. Only on failure (one pass over the faces).
  std::string miss_reason(double miss, Index p, double unit) const {
    std::vector<double> theta(static_cast<std::size_t>(t.num_corners()));
    std::vector<double> K(static_cast<std::size_t>(t.num_vertices));
    corner_angles(t, g, l, theta);
    vertex_curvature(t, theta, K);  // 2π − Σθ at interior vertices
    auto z = [&](Index v) { return Cx(root_positions[2 * v], root_positions[2 * v + 1]); };
    // No operation here may overflow or meet NaN (the sanitized tests trap them): a residual that
    // is not finite, or a vertex beyond the root layout's range, leaves the reach unknown (∞).
    constexpr double kInf = std::numeric_limits<double>::infinity();
    double delta = 0, reach = 0;
    Index at = kInvalid;
    for (Index v = 0; v < t.num_vertices; ++v) {
      if (t.valence(v) == 0 || t.is_boundary_vertex(v)) continue;
      const double r = std::abs(K[v]);
      if (!std::isfinite(r)) {
        reach = kInf;
        continue;
      }
      if (r > delta) delta = r, at = v;
      if (r == 0 || reach == kInf) continue;
      const double d = planar_distance(g, z(p), z(v));
      reach = std::isfinite(d) && d < 700 ? reach + r * (g == Geometry::Hyperbolic ? std::sinh(d) : d) : kInf;
    }
    if (reach < kInf) reach = unit > 1e-200 ? reach / unit : kInf;  // the sum stays below ~1e41
    if (at == kInvalid) return ": the lengths are not one metric there";
    const std::string residual = "the lengths close around the disk's vertices only to " + sci(delta) +
                                 " (the angle sum at vertex " + std::to_string(at) + " misses 2π by that)";
    if (!std::isfinite(reach))
      return ": " + residual + "; how far such residuals turn the developments there is beyond the root layout's "
             "coordinates";
    if (miss <= reach)
      return ": " + residual + ", and such residuals turn the developments there apart by up to " + sci(reach) +
             " of an edge: the lengths are not flat closely enough for this reach";
    return ": more than the lengths' angle-sum residuals account for there (up to " + sci(delta) + " at vertex " +
           std::to_string(at) + ", " + sci(reach) + " of an edge at most): the lengths are not one metric there";
  }

  /// The face's max relative edge error in its chart's coordinates, and its rounding floor.
  /// The longest and the shortest edge of face f.
  double longest(Index f) const {
    return std::max({l[t.corner_edge[3 * f]], l[t.corner_edge[3 * f + 1]], l[t.corner_edge[3 * f + 2]]});
  }
  double shortest(Index f) const {
    return std::min({l[t.corner_edge[3 * f]], l[t.corner_edge[3 * f + 1]], l[t.corner_edge[3 * f + 2]]});
  }

  void measure_face(Index f, double& err, double& floor) const {
    err = floor = 0;
    for (int c = 0; c < 3; ++c) {
      const Cx a = corner(f, (c + 1) % 3), b = corner(f, (c + 2) % 3);
      const double le = l[t.corner_edge[3 * f + c]];
      const double e = std::abs(planar_distance(g, a, b) - le) / le;
      err = std::isnan(e) || std::isnan(err) ? NAN : std::max(err, e);
      floor = std::max(floor, rounding_drift(a, b) / le);
    }
  }

  bool fail(Element e, Index i, const std::string& message) {
    out.status = Status::NumericalFailure;
    out.element = e;
    out.element_index = i;
    out.message = message;
    return false;
  }

  /// A face its chart does not resolve: an edge misses the limit.
  bool unresolved(Index f) const { return !(face_error[f] <= options.limit); }
  /// A face near the limit: its coordinates resolve it to less than kMargin times the limit. A
  /// group of unresolved faces takes the near ones connected to it too, so that the collar of its
  /// chart lies where the parent's positions are good to well below the limit (the transition map
  /// is fitted there).
  static constexpr double kMargin = 1e-2;
  bool near_limit(Index f) const {
    return unresolved(f) || !(face_floor[f] <= std::max(kMargin * options.limit, kFrameAllowance * best_floor(f)));
  }
  /// A face of a chart whose corners can hold a collar there: not near_limit(), or, with frames,
  /// a needle within its coarse face's rounding (rounding_only()) placed to kMargin × limit of its
  /// coarse face's shortest side — the scale the collar is fitted and measured at with frames
  /// (collar_points()), where a region of needles has no other faces.
  bool collar_ok(Index f) const {
    if (!near_limit(f) || (any_resolved_collar && !unresolved(f))) return true;
    if (frame_floor.empty() || !rounding_only(f)) return false;
    const FaceFrames& fr = *options.frames;
    const std::size_t cf = 3 * static_cast<std::size_t>(fr.face_frame[f]);
    const double coarse = std::min({fr.frame_lengths[cf], fr.frame_lengths[cf + 1], fr.frame_lengths[cf + 2]});
    const double own = shortest(f);
    return face_floor[f] * own <= kMargin * options.limit * coarse && face_error[f] * own <= kMargin * options.limit * coarse;
  }

  /// Groups of chart k's faces for new charts: each unresolved face with the faces near the limit
  /// connected to it across edges (in face order).
  std::vector<std::vector<Index>> unresolved_groups(Index k) const {
    std::vector<std::vector<Index>> groups;
    std::vector<std::uint8_t> seen(static_cast<std::size_t>(t.num_faces), 0);
    for (Index f0 = 0; f0 < t.num_faces; ++f0) {
      if (seen[f0] || out.face_chart[f0] != k || !unresolved(f0) || settled[f0]) continue;
      std::vector<Index> group{f0};
      seen[f0] = 1;
      for (std::size_t h = 0; h < group.size(); ++h) {
        for (int c = 0; c < 3; ++c) {
          const Index o = t.opposite[3 * group[h] + c];
          if (o == kInvalid) continue;
          const Index nb = corner_face(o);
          if (seen[nb] || out.face_chart[nb] != k || !near_limit(nb)) continue;
          seen[nb] = 1;
          group.push_back(nb);
        }
      }
      groups.push_back(std::move(group));
    }
    return groups;
  }

  /// A group of chart k (unresolved_groups()) in pieces that each reach at most kGroupReach from
  /// their first face, made from the group's rim inwards. A chart holds its collar only near its
  /// origin (kCollarReach) and the collar runs round the whole group, so a long group — a strip of
  /// needles between two input edges that rounding does not separate, running across many coarse
  /// faces — leaves the collar where the chart cannot fit it even laid out from it (make_chart()
  /// then reports it too_long). Distances
  /// run along the faces (a step counts the longest edge of the face it leaves) from the faces next
  /// to chart k's good ones; pieces start at the nearest face not yet taken and take the faces
  /// within reach of it, so each lies next to the rim or to pieces made before it, whose charts
  /// then hold its collar (collar_and_parent(); chart_groups() tries a piece again once they do).
  static constexpr double kGroupReach = 2;
  /// `local`: scratch, #F entries of kInvalid (sized on first use, left so).
  std::vector<std::vector<Index>> split_by_reach(const std::vector<Index>& group, Index k,
                                                 std::vector<Index>& local) const {
    const std::size_t n = group.size();
    if (local.empty()) local.assign(static_cast<std::size_t>(t.num_faces), kInvalid);
    for (std::size_t i = 0; i < n; ++i) local[group[i]] = static_cast<Index>(i);
    // Distances from the rim (Dijkstra; a component with no rim starts from its first face).
    constexpr double kInf = std::numeric_limits<double>::infinity();
    std::vector<double> dist(n, kInf);
    std::vector<std::pair<double, Index>> heap;
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) {
        const Index o = t.opposite[3 * group[i] + c];
        if (o != kInvalid && local[corner_face(o)] == kInvalid && out.face_chart[corner_face(o)] == k &&
            collar_ok(corner_face(o)) && dist[i] > 0) {
          dist[i] = 0;
          heap.push_back({0.0, static_cast<Index>(i)});
        }
      }
    if (heap.empty()) {
      dist[0] = 0;
      heap.push_back({0.0, 0});
    }
    auto later = [](const std::pair<double, Index>& a, const std::pair<double, Index>& b) { return a > b; };
    std::make_heap(heap.begin(), heap.end(), later);
    while (!heap.empty()) {
      std::pop_heap(heap.begin(), heap.end(), later);
      const auto [d, i] = heap.back();
      heap.pop_back();
      if (d > dist[i]) continue;
      const double step = d + longest(group[i]);
      for (int c = 0; c < 3; ++c) {
        const Index o = t.opposite[3 * group[i] + c];
        if (o == kInvalid) continue;
        const Index j = local[corner_face(o)];
        if (j == kInvalid || !(step < dist[j])) continue;
        dist[j] = step;
        heap.push_back({step, j});
        std::push_heap(heap.begin(), heap.end(), later);
      }
    }
    std::vector<Index> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<Index>(i);
    std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return dist[a] < dist[b]; });
    // Pieces, nearest first.
    std::vector<std::vector<Index>> pieces;
    std::vector<std::uint8_t> taken(n, 0);
    std::vector<double> reach(n, 0.0);
    for (const Index s0 : order) {
      if (taken[s0]) continue;
      std::vector<Index> piece{s0};
      taken[s0] = 1;
      reach[s0] = 0;
      for (std::size_t h = 0; h < piece.size(); ++h) {
        const Index i = piece[h];
        const double step = reach[i] + longest(group[i]);
        if (h > 0 && step > kGroupReach) continue;
        for (int c = 0; c < 3; ++c) {
          const Index o = t.opposite[3 * group[i] + c];
          if (o == kInvalid) continue;
          const Index j = local[corner_face(o)];
          if (j == kInvalid || taken[j]) continue;
          taken[j] = 1;
          reach[j] = step;
          piece.push_back(j);
        }
      }
      std::vector<Index> faces(piece.size());
      for (std::size_t h = 0; h < piece.size(); ++h) faces[h] = group[piece[h]];
      // A piece of faces near the limit only (none unresolved and unsettled) needs no chart.
      if (std::any_of(faces.begin(), faces.end(), [&](Index f) { return unresolved(f) && !settled[f]; }))
        pieces.push_back(std::move(faces));
    }
    for (const Index f : group) local[f] = kInvalid;
    return pieces;
  }

  /// The collar: faces of chart k resolved there, within collar_rings rings of the group.
  std::vector<Index> collar(const std::vector<Index>& group, Index k, Index label) {
    std::vector<Index> ring = group, faces;
    for (int r = 0; r < options.collar_rings; ++r) {
      std::vector<Index> next;
      for (Index f : ring) {
        for (int c = 0; c < 3; ++c) {
          const Index o = t.opposite[3 * f + c];
          if (o == kInvalid) continue;
          const Index nb = corner_face(o);
          if (owner[nb] == label || out.face_chart[nb] != k || !collar_ok(nb)) continue;
          owner[nb] = label;
          next.push_back(nb);
        }
      }
      faces.insert(faces.end(), next.begin(), next.end());
      ring = std::move(next);
    }
    return faces;
  }

  /// The collar in the group's chart `home`; where that chart resolves none of the faces around
  /// the group (a nested group at the rim of the chart made for its parent group), in the chart
  /// holding most of the group's neighbours that has a collar there, which becomes the parent.
  /// Empty when no chart has one.
  std::vector<Index> collar_and_parent(const std::vector<Index>& group, Index home, Index label, Index& parent) {
    parent = home;
    std::vector<Index> ring = collar(group, home, label);
    if (!ring.empty()) return ring;
    std::vector<Index> around;
    for (Index f : group)
      for (int cc = 0; cc < 3; ++cc) {
        const Index o = t.opposite[3 * f + cc];
        if (o == kInvalid) continue;
        const Index j = out.face_chart[corner_face(o)];
        if (owner[corner_face(o)] != label && j != home) around.push_back(j);
      }
    std::sort(around.begin(), around.end());
    std::vector<std::pair<Index, Index>> counts;  // (−count, chart)
    for (std::size_t i = 0; i < around.size();) {
      std::size_t e = i;
      while (e < around.size() && around[e] == around[i]) ++e;
      counts.push_back({-static_cast<Index>(e - i), around[i]});
      i = e;
    }
    std::sort(counts.begin(), counts.end());
    for (const auto& [neg, j] : counts) {
      ring = collar(group, j, label);
      if (!ring.empty()) {
        parent = j;
        break;
      }
    }
    return ring;
  }

  /// The chart's map into the root: the parent's composed with its own transition.
  void compose_to_root(LayoutChart& ch) const {
    const LayoutChart& p = out.charts[static_cast<std::size_t>(ch.parent)];
    if (g == Geometry::Hyperbolic) {
      using detail::CQ;
      using detail::MoebiusQ;
      const MoebiusQ root(CQ(p.to_root.a) + CQ(p.to_root_low.a), CQ(p.to_root.b) + CQ(p.to_root_low.b));
      const MoebiusQ m = (root * MoebiusQ(ch.to_parent)).normalized();
      ch.to_root = m.to_double();
      ch.to_root_low = Moebius{(m.a - CQ(ch.to_root.a)).to_double(), (m.b - CQ(ch.to_root.b)).to_double()};
    } else {
      const Cx rot = std::polar(1.0, p.angle_to_root);
      ch.angle_to_root = std::remainder(p.angle_to_root + ch.angle_to_parent, 2 * std::numbers::pi);
      ch.translation_to_root = rot * ch.translation_to_parent + p.translation_to_root;
    }
  }

  /// Fit points: each collar vertex once (`verts`), with its parent and its own position (x), and
  /// the shortest collar edge at it — with frames, the shortest side of the coarse faces at it:
  /// both charts put every point of a coarse face by that face's one isometry, so their rounding
  /// moves the coarse face rigidly, at its own scale, however short the fine edges inside it.
  void collar_points(const std::vector<Index>& ring, const std::vector<double>& x, std::vector<Index>& verts,
                     std::vector<double>& parent_pts, std::vector<double>& own_pts, std::vector<double>& scale) const {
    verts.clear();
    parent_pts.clear();
    own_pts.clear();
    scale.clear();
    std::vector<Index> index_of(static_cast<std::size_t>(t.num_vertices), kInvalid);
    const FaceFrames* fr = options.frames.get();
    for (Index f : ring) {
      const std::size_t cf = fr ? 3 * static_cast<std::size_t>(fr->face_frame[f]) : 0;
      for (int cc = 0; cc < 3; ++cc) {
        const Index v = t.corner_vertex[3 * f + cc];
        const double le =
            fr ? std::min({fr->frame_lengths[cf], fr->frame_lengths[cf + 1], fr->frame_lengths[cf + 2]})
               : std::min(l[t.corner_edge[3 * f + (cc + 1) % 3]], l[t.corner_edge[3 * f + (cc + 2) % 3]]);
        if (index_of[v] == kInvalid) {
          index_of[v] = static_cast<Index>(scale.size());
          verts.push_back(v);
          const Cx p = corner(f, cc);
          parent_pts.insert(parent_pts.end(), {p.real(), p.imag()});
          own_pts.insert(own_pts.end(), {x[2 * v], x[2 * v + 1]});
          scale.push_back(le);
        } else {
          scale[index_of[v]] = std::min(scale[index_of[v]], le);
        }
      }
    }
  }

  /// How far rounding can move the chart's own collar points, relative to their scale (the largest
  /// over the collar): their coordinates' rounding and, with frames in H, the drift of the maps
  /// that placed them (`drift` per vertex; empty otherwise). Points as collar_points() lists them.
  double collar_floor(const std::vector<Index>& verts, const std::vector<double>& drift,
                      const std::vector<double>& own_pts, const std::vector<double>& scale) const {
    double most = 0;
    for (std::size_t i = 0; i < scale.size(); ++i) {
      const Cx p{own_pts[2 * i], own_pts[2 * i + 1]};
      const double moved = drift.empty() ? 0.0 : drift[static_cast<std::size_t>(verts[i])];
      most = std::max(most, (rounding_drift(p, p) / 2 + moved) / scale[i]);
    }
    return most;
  }

  /// H: the farthest of the chart's own collar points from its origin (hyperbolic distance); E: 0
  /// (a residual δ turns a loop's far side by δ times its distance only, not sinh of it).
  static constexpr double kCollarReach = 4;
  double collar_reach(const std::vector<double>& own_pts) const {
    if (g != Geometry::Hyperbolic) return 0;
    double most = 0;
    for (std::size_t i = 0; i < own_pts.size(); i += 2) most = std::max(most, std::hypot(own_pts[i], own_pts[i + 1]));
    return most < 1 ? 2 * std::atanh(most) : std::numeric_limits<double>::infinity();
  }

  /// The smallest (least longest edge) of the group's faces across an edge from a face of its
  /// collar `ring`; kInvalid when none.
  Index seed_at_collar(const std::vector<Index>& group, std::vector<Index> ring) const {
    std::sort(ring.begin(), ring.end());
    Index best = kInvalid;
    double best_len = 0;
    for (Index f : group) {
      bool at = false;
      for (int c = 0; c < 3 && !at; ++c) {
        const Index o = t.opposite[3 * f + c];
        at = o != kInvalid && std::binary_search(ring.begin(), ring.end(), corner_face(o));
      }
      if (!at) continue;
      const double len = longest(f);
      if (best == kInvalid || len < best_len) {
        best = f;
        best_len = len;
      }
    }
    return best;
  }

  /// Set by make_chart() when no chart had a collar for the group (it made none).
  bool no_collar = false;
  /// Set by make_chart() (it made no chart) when the group's collar lies beyond kCollarReach of
  /// the chart even laid out from the collar, while `splittable` (H, a group not split before).
  bool too_long = false, splittable = false;
  /// Collars may take any resolved face, near the limit or not (chart_groups()' last round).
  bool any_resolved_collar = false;
  /// The groups of chart k, each made a chart of; a group too long for one chart is cut into
  /// pieces (split_by_reach()), made charts of in turn; a group no chart has a collar for is tried
  /// again after the others (its neighbours may have moved into their own charts by then), until
  /// a round makes no chart; then once more with collars of any resolved faces (whose positions
  /// may hold only to the limit: the transition check still bounds the fit). Faces of a group
  /// still without a collar stay where they are, unresolvable. False when make_chart() failed.
  bool chart_groups(Index k) {
    struct Group {
      std::vector<Index> faces;
      bool piece = false;
    };
    std::vector<Group> pending;
    for (std::vector<Index>& faces : unresolved_groups(k)) pending.push_back({std::move(faces), false});
    std::vector<Index> slot;  // split_by_reach()'s scratch
    int stage = 0;  // 0: as made; 1: the groups left taken whole again; 2: collars of any resolved faces
    while (!pending.empty()) {
      std::vector<Group> later;
      std::size_t made = 0;
      for (std::size_t i = 0; i < pending.size(); ++i) {
        no_collar = too_long = false;
        splittable = g == Geometry::Hyperbolic && !pending[i].piece;
        if (!make_chart(pending[i].faces, k)) {
          any_resolved_collar = false;
          return false;
        }
        if (too_long) {
          for (std::vector<Index>& faces : split_by_reach(pending[i].faces, k, slot))
            pending.push_back({std::move(faces), true});
        } else if (no_collar) {
          later.push_back(std::move(pending[i]));
        } else {
          ++made;
        }
      }
      if (made > 0) {
        pending = std::move(later);
      } else if (stage == 0 && std::any_of(later.begin(), later.end(), [](const Group& q) { return q.piece; })) {
        // Pieces no chart has a collar for (their neighbours near the limit needed no chart of
        // their own): the groups left, whole, not cut again.
        stage = 1;
        pending.clear();
        for (std::vector<Index>& faces : unresolved_groups(k)) pending.push_back({std::move(faces), true});
      } else if (stage < 2) {
        stage = 2;
        any_resolved_collar = true;
        pending = std::move(later);
      } else {
        for (const Group& group : later)
          for (Index f : group.faces)
            if (unresolved(f)) settled[f] = 1;
        break;
      }
    }
    any_resolved_collar = false;
    return true;
  }

  /// Makes a chart of `group` (faces of chart k): lays it out with its collar, fits the
  /// transition, moves the group's faces into it.
  bool make_chart(const std::vector<Index>& group, Index home) {
    const Index c = out.num_charts();
    LayoutChart ch;
    // The smallest face (least longest edge) is the new origin; in a group of a chart made for a
    // group before, the smallest of its unresolved faces not settled (the deferred() faces it is
    // made for, not the faces near them that chart resolves).
    const bool nested = home != 0;
    ch.seed_face = group[0];
    for (Index f : group)
      if (!settled[f] && (!nested || unresolved(f)) && longest(f) < longest(ch.seed_face)) ch.seed_face = f;
    for (Index f : group) owner[f] = c;
    Index parent = home;
    const std::vector<Index> ring = collar_and_parent(group, home, c, parent);
    if (ring.empty()) {
      // No chart resolves the faces around the group (yet: a piece of a long group whose
      // neighbouring pieces have no chart so far); the caller tries again after the others.
      for (Index f : group) owner[f] = -1;
      no_collar = true;
      return true;
    }
    const Index k = parent;
    ch.parent = k;
    // Nested below the group's own chart too (the depth bound ends a chain of nested groups).
    ch.depth = std::max(out.charts[static_cast<std::size_t>(k)].depth, out.charts[static_cast<std::size_t>(home)].depth) + 1;
    if (ch.depth > options.max_depth) {
      for (Index f : group) owner[f] = -1;
      for (Index f : ring) owner[f] = -1;
      return fail(Element::Face, group[0], "charts nest deeper than " + std::to_string(options.max_depth) +
                                               " around face " + std::to_string(group[0]));
    }
    // The transition is fitted on the collar, so the chart must hold its collar well within its
    // resolution, and near its origin. Around the group's smallest face it may not when the group
    // is large (a long thin part whose far end is exponentially small): the collar then lies where
    // the chart's coordinates or maps have few digits left, or beyond double range; and in H the
    // development reaches the collar's points along long paths that enclose vertices, each of
    // which turns the far side of such a loop by its curvature residual δ times sinh of its
    // distance (1e-13 at 19 units from the collar missed it by 9e-8). Such a chart starts again at
    // the collar, from the smallest of the group's faces across an edge from it, and leaves the
    // far end to charts nested in it.
    std::vector<double> x, drift, parent_pts, own_pts, scale;
    std::vector<Index> verts;
    Layout pl;
    bool ok = false;
    for (int attempt = 0;; ++attempt) {
      std::vector<Index> touched;
      pl = Layout{};
      ok = options.frames
               ? detail::propagate_faces_by_frames(t, g, *options.frames, ch.seed_face, owner, c, x, touched, drift, pl)
               : detail::propagate_faces(t, g, l, ch.seed_face, owner, c, x, touched, pl);
      if (ok) collar_points(ring, x, verts, parent_pts, own_pts, scale);
      const bool near = ok && collar_reach(own_pts) <= kCollarReach;
      if (attempt > 0 || (near && collar_floor(verts, drift, own_pts, scale) <= kMargin * options.max_transition_error)) {
        too_long = ok && !near && splittable;
        break;
      }
      const Index s = seed_at_collar(group, ring);
      if (s == kInvalid || s == ch.seed_face) {
        too_long = ok && !near && splittable;
        break;
      }
      ch.seed_face = s;
    }
    for (Index f : group) owner[f] = -1;
    for (Index f : ring) owner[f] = -1;
    if (too_long) return true;
    if (!ok) return fail(pl.element, pl.element_index, pl.message);
    const LayoutAlignment fit = align_layouts(g, parent_pts, own_pts);
    if (fit.status != Status::Ok)
      return fail(Element::Face, ch.seed_face, "the chart around face " + std::to_string(ch.seed_face) +
                                                   " could not be fitted to chart " + std::to_string(k) + ": " + fit.message);
    ch.collar_vertices = static_cast<Index>(scale.size());
    if (g == Geometry::Hyperbolic) {
      ch.to_parent = Moebius::from_theta_z0(fit.angle, {fit.translation[0], fit.translation[1]});
    } else {
      ch.angle_to_parent = fit.angle;
      ch.translation_to_parent = {fit.translation[0], fit.translation[1]};
    }
    auto to_parent = [&](Cx z) {
      return g == Geometry::Hyperbolic ? ch.to_parent.apply(z) : std::polar(1.0, ch.angle_to_parent) * z + ch.translation_to_parent;
    };
    for (std::size_t i = 0; i < scale.size(); ++i) {
      const double d = planar_distance(g, {parent_pts[2 * i], parent_pts[2 * i + 1]}, to_parent({own_pts[2 * i], own_pts[2 * i + 1]}));
      ch.transition_error = std::max(ch.transition_error, d / scale[i]);
    }
    if (!(ch.transition_error <= options.max_transition_error) && any_resolved_collar) {
      no_collar = true;  // a collar near the limit that does not hold the fit: none after all
      return true;
    }
    if (!(ch.transition_error <= options.max_transition_error)) {
      double unit = 0;  // the collar's mean edge length
      for (double s : scale) unit += s / static_cast<double>(scale.size());
      return fail(Element::Face, ch.seed_face,
                  "the chart around face " + std::to_string(ch.seed_face) + " misses chart " + std::to_string(k) +
                      " on their common collar by " + sci(ch.transition_error) + " of an edge's length (limit " +
                      sci(options.max_transition_error) + ")" +
                      miss_reason(ch.transition_error, t.corner_vertex[3 * ch.seed_face], unit));
    }
    compose_to_root(ch);
    // The group's faces move into the new chart; a face settled before (unresolvable in the chart
    // made for it, and pulled into this group as a neighbour near the limit) only where this
    // chart places it better.
    Index resolved = 0;
    for (Index f : group) {
      const Index old_chart = out.face_chart[f];
      const double old_error = face_error[f], old_floor = face_floor[f];
      double old_corners[6];
      std::copy_n(&out.corner_positions[6 * static_cast<std::size_t>(f)], 6, old_corners);
      out.face_chart[f] = c;
      for (int cc = 0; cc < 3; ++cc) {
        const Index v = t.corner_vertex[3 * f + cc];
        out.corner_positions[6 * f + 2 * cc] = x[2 * v];
        out.corner_positions[6 * f + 2 * cc + 1] = x[2 * v + 1];
      }
      measure_face(f, face_error[f], face_floor[f]);
      // With frames in H, the drift of the maps that placed its corners adds to its floor.
      if (!drift.empty())
        for (int cc = 0; cc < 3; ++cc) {
          const double moved = drift[t.corner_vertex[3 * f + (cc + 1) % 3]] + drift[t.corner_vertex[3 * f + (cc + 2) % 3]];
          face_floor[f] = std::max(face_floor[f], moved / l[t.corner_edge[3 * f + cc]]);
        }
      if (settled[f] && !(face_error[f] < old_error)) {
        out.face_chart[f] = old_chart;
        std::copy_n(old_corners, 6, &out.corner_positions[6 * static_cast<std::size_t>(f)]);
        face_error[f] = old_error;
        face_floor[f] = old_floor;
        continue;
      }
      if (!unresolved(f)) ++resolved;
      else if ((f == ch.seed_face || !defer(f)) && !retry(f, ch.seed_face)) settled[f] = 1;
    }
    // A face its own chart misses by more than a collar may and by more than kFrameAllowance times
    // the chart's floor there: not rounding, the lengths do not close. (A miss within that floor,
    // which no nested chart would resolve kNestGain times better, leaves the face unresolvable.)
    for (Index f : group)
      if (!(face_error[f] <= options.max_transition_error) && !rounding_only(f) && settled[f] &&
          !(face_error[f] <= kFrameAllowance * face_floor[f])) {
        return fail(Element::Face, f, "face " + std::to_string(f) + " misses its lengths by " + sci(face_error[f]) +
                                          " even in the chart around face " + std::to_string(ch.seed_face) +
                                          " made for it (" + std::to_string(resolved) + " of its group's " +
                                          std::to_string(group.size()) + " faces resolved; limit " +
                                          sci(options.max_transition_error) + ")" +
                                          miss_reason(face_error[f], t.corner_vertex[3 * f], shortest(f)));
      }
    out.charts.push_back(ch);
    return true;
  }

  /// Sign of the face's orientation in its chart (H: in Klein coordinates, where geodesics are
  /// straight).
  double orientation(Index f) const {
    Cx p[3];
    for (int c = 0; c < 3; ++c) {
      p[c] = corner(f, c);
      if (g == Geometry::Hyperbolic) p[c] *= 2 / (1 + std::norm(p[c]));
    }
    const Cx u = p[1] - p[0], w = p[2] - p[0];
    return u.real() * w.imag() - u.imag() * w.real();
  }

  /// Every chart's figures from its faces (face_error and face_floor are each face's in its chart).
  void summarise() {
    for (LayoutChart& ch : out.charts) {
      ch.faces = 0;
      ch.max_edge_length_error = ch.rounding_floor = 0;
      ch.worst_face = kInvalid;
    }
    for (Index f = 0; f < t.num_faces; ++f) {
      LayoutChart& ch = out.charts[static_cast<std::size_t>(out.face_chart[f])];
      const double err = face_error[f], floor = face_floor[f];
      const bool needle = unresolved(f) && rounding_only(f);  // orientation within rounding
      if (!needle && !(orientation(f) > 0) && out.flipped_faces++ == 0) out.first_flipped_face = f;
      if (unresolved(f)) {
        ++out.unresolvable_faces;
        out.unresolvable_error = std::isnan(err) ? err : std::max(out.unresolvable_error, err);
      }
      if (needle) {
        out.frame_rounding_faces.push_back(f);
      } else {
        out.max_resolved_error = std::isnan(err) ? err : std::max(out.max_resolved_error, err);
      }
      ++ch.faces;
      ch.rounding_floor = std::max(ch.rounding_floor, floor);
      if (ch.worst_face == kInvalid || err > ch.max_edge_length_error) {
        ch.max_edge_length_error = err;
        ch.worst_face = f;
      }
    }
    for (const LayoutChart& ch : out.charts) {
      out.max_edge_length_error = std::max(out.max_edge_length_error, ch.max_edge_length_error);
      out.max_transition_error = std::max(out.max_transition_error, ch.transition_error);
    }
  }
};

}  // namespace

bool AtlasOptions::is_valid(std::string* why) const {
  std::string w;
  if (!(std::isfinite(limit) && limit > 0)) w = "limit must be a finite number > 0";
  else if (collar_rings < 1 || collar_rings > 16) w = "collar_rings must be in 1..16";
  else if (max_depth < 1 || max_depth > 65536) w = "max_depth must be in 1..65536";
  else if (!(std::isfinite(max_transition_error) && max_transition_error > 0))
    w = "max_transition_error must be a finite number > 0";
  if (why != nullptr) *why = w;
  return w.empty();
}

LayoutAtlas layout_atlas(const Topology& disk, Geometry g, std::span<const double> l, std::span<const double> positions,
                         const AtlasOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  LayoutAtlas out;
  std::string why;
  if (!options.is_valid(&why) || g == Geometry::Spherical || l.size() != static_cast<std::size_t>(disk.num_edges) ||
      positions.size() != 2 * static_cast<std::size_t>(disk.num_vertices)) {
    out.status = Status::InvalidArgument;
    out.message = !why.empty() ? "options: " + why
                  : g == Geometry::Spherical ? std::string("an atlas is made in E and H only")
                                             : "sizes: #E lengths and #V×2 positions are required";
    return out;
  }
  if (options.frames) {
    if (const std::string w = detail::check_frames(disk, *options.frames); !w.empty()) {
      out.status = Status::InvalidArgument;
      out.message = w;
      return out;
    }
  }
  const Index nf = disk.num_faces;
  out.face_chart.assign(static_cast<std::size_t>(nf), 0);
  out.corner_positions.resize(6 * static_cast<std::size_t>(nf));
  for (Index f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) {
      const Index v = disk.corner_vertex[3 * f + c];
      out.corner_positions[6 * f + 2 * c] = positions[2 * v];
      out.corner_positions[6 * f + 2 * c + 1] = positions[2 * v + 1];
    }
  LayoutChart root;
  out.charts.push_back(root);
  AtlasBuild b{disk, g, l, options, out, std::vector<double>(static_cast<std::size_t>(nf)),
               std::vector<double>(static_cast<std::size_t>(nf)), positions,
               std::vector<Index>(static_cast<std::size_t>(nf), -1),
               std::vector<std::uint8_t>(static_cast<std::size_t>(nf), 0),
               std::vector<std::uint8_t>(static_cast<std::size_t>(nf), 0),
               std::vector<double>(static_cast<std::size_t>(nf), std::numeric_limits<double>::infinity()), {}};
  if (options.frames && options.frames->face_frame.size() == static_cast<std::size_t>(nf)) {
    const FaceFrames& fr = *options.frames;
    b.frame_floor.assign(static_cast<std::size_t>(nf), 0.0);
    for (Index f = 0; f < nf; ++f) {
      const std::size_t cf = 3 * static_cast<std::size_t>(fr.face_frame[f]);
      const double longest = std::max({fr.frame_lengths[cf], fr.frame_lengths[cf + 1], fr.frame_lengths[cf + 2]});
      const double coarse = g == Geometry::Hyperbolic ? std::sinh(longest) : longest;
      const double own = std::min({l[disk.corner_edge[3 * f]], l[disk.corner_edge[3 * f + 1]], l[disk.corner_edge[3 * f + 2]]});
      b.frame_floor[f] = own > 0 ? 0x1p-53 * coarse / own : std::numeric_limits<double>::infinity();
    }
  }
#pragma omp parallel for schedule(static)
  for (Index f = 0; f < nf; ++f) b.measure_face(f, b.face_error[f], b.face_floor[f]);
  for (Index k = 0; k < out.num_charts(); ++k) {
    if (!b.chart_groups(k)) {
      out.charts.clear();
      out.face_chart.clear();
      out.corner_positions.clear();
      return out;
    }
  }
  b.summarise();
  out.status = Status::Ok;
  out.message = std::to_string(out.num_charts()) + (out.num_charts() == 1 ? " chart" : " charts") +
                ", max edge-length error " + sci(out.max_edge_length_error) + ", transitions to " +
                sci(out.max_transition_error) +
                (out.unresolvable_faces > 0 ? "; " + std::to_string(out.unresolvable_faces) +
                                                  " faces no chart resolves to " + sci(options.limit) + " (worst " +
                                                  sci(out.unresolvable_error) + " in the chart made for them)"
                                            : "") +
                (!out.frame_rounding_faces.empty()
                     ? ", " + std::to_string(out.frame_rounding_faces.size()) +
                           " of them within the rounding of their coarse face (faces elsewhere to " +
                           sci(out.max_resolved_error) + ")"
                     : "");
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

std::complex<double> chart_to_chart(const LayoutAtlas& atlas, Geometry g, Index from, Index to, std::complex<double> z) {
  if (from < 0 || to < 0 || from >= atlas.num_charts() || to >= atlas.num_charts())
    return {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  if (from == to) return z;
  const LayoutChart& a = atlas.charts[static_cast<std::size_t>(from)];
  const LayoutChart& b = atlas.charts[static_cast<std::size_t>(to)];
  if (g == Geometry::Hyperbolic) {
    using detail::CQ;
    using detail::MoebiusQ;
    const MoebiusQ A(CQ(a.to_root.a) + CQ(a.to_root_low.a), CQ(a.to_root.b) + CQ(a.to_root_low.b));
    const MoebiusQ B(CQ(b.to_root.a) + CQ(b.to_root_low.a), CQ(b.to_root.b) + CQ(b.to_root_low.b));
    return (B.inverse() * A).normalized().apply(CQ(z)).to_double();
  }
  // z_root = e^{iα} z + t for each chart: z_to = e^{−iβ}(e^{iα} z + t_a − t_b).
  return std::polar(1.0, -b.angle_to_root) *
         (std::polar(1.0, a.angle_to_root) * z + (a.translation_to_root - b.translation_to_root));
}

Mesh surface_with_atlas_uvs(const CutResult& cut, const LayoutAtlas& atlas) {
  Mesh m;
  const std::size_t corners = cut.cut_faces.size();
  if (atlas.status != Status::Ok || atlas.face_chart.size() * 3 != corners || atlas.corner_positions.size() != 2 * corners ||
      cut.surface_faces.size() != corners)
    return m;
  m.positions = cut.surface_positions;
  m.faces = cut.surface_faces;
  m.corner_texcoords.resize(corners);
  // One texture coordinate per (cut vertex, chart), numbered in the order of first use.
  const std::int64_t charts = atlas.num_charts();
  std::vector<std::pair<std::int64_t, Index>> key(corners);
  for (std::size_t c = 0; c < corners; ++c)
    key[c] = {static_cast<std::int64_t>(cut.cut_faces[c]) * charts + atlas.face_chart[c / 3], static_cast<Index>(c)};
  std::sort(key.begin(), key.end());
  std::vector<Index> first_corner;  // per distinct key, its smallest corner
  std::vector<Index> key_of(corners);
  for (std::size_t k = 0; k < corners; ++k) {
    if (k == 0 || key[k].first != key[k - 1].first) first_corner.push_back(key[k].second);
    key_of[key[k].second] = static_cast<Index>(first_corner.size() - 1);
  }
  std::vector<Index> order(first_corner.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<Index>(i);
  std::sort(order.begin(), order.end(), [&](Index a, Index b) { return first_corner[a] < first_corner[b]; });
  std::vector<Index> number(first_corner.size());
  m.texcoords.resize(2 * first_corner.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    number[order[i]] = static_cast<Index>(i);
    const Index c = first_corner[order[i]];
    m.texcoords[2 * i] = atlas.corner_positions[2 * c];
    m.texcoords[2 * i + 1] = atlas.corner_positions[2 * c + 1];
  }
  for (std::size_t c = 0; c < corners; ++c) m.corner_texcoords[c] = number[key_of[c]];
  return m;
}

}  // namespace ricci
