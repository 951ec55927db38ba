// Intrinsic triangulations: Ptolemy flips of a vertex-scaling metric, the Delaunay test and
// flip-to-Delaunay (see ricci/intrinsic.h for the formulas).
//
// Flip of edge e = ij between f0 = (k, i, j) and f1 = (l, j, i), corners c0 at k, c1 at l
// (n = next, p = prev):
//
//            k                          k
//          / c0 \                     / | \ .
//    e_ki /  f0  \ e_jk        e_ki /  |  \ e_jk
//        / n0  p0 \                /   e   \ .
//       i ---e---- j      ->      i  f0 | f1  j
//        \ p1  n1 /                \   |   /
//    e_il \  f1  / e_lj        e_il \  |  / e_lj
//          \ c1 /                     \ | /
//            l                          l   .
//
// The corner slots are kept: f0 becomes (k, i, l) with l in slot p0, f1 becomes (l, j, k) with k in
// slot p1; e is opposite n0 and n1 afterwards, e_il opposite c0 and e_jk opposite c1.
#include "ricci/intrinsic.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <numbers>
#include <string>

#include "hessian.h"
#include "ricci/intrinsic_trace.h"

namespace ricci {

namespace {

using detail::kParallelMin;

// log B of a length in each geometry (log l, log sinh(l/2), log sin(l/2)), NaN when out of range.
double log_chord_of_length(Geometry g, double l) {
  if (!(l > 0) || !std::isfinite(l)) return std::numeric_limits<double>::quiet_NaN();
  const double x = 0.5 * l;
  switch (g) {
    case Geometry::Euclidean:
      return std::log(l);
    case Geometry::Hyperbolic:
      // log sinh x = x − log 2 + log(1 − e^{−2x}), exact where sinh would overflow.
      return x > 20 ? x - std::log(2.0) + std::log1p(-std::exp(-2 * x)) : std::log(std::sinh(x));
    case Geometry::Spherical:
      return l < std::numbers::pi ? std::log(std::sin(x)) : std::numeric_limits<double>::quiet_NaN();
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Largest |log B| stored: 700 (chords a double can hold), so that sums and Ptolemy results stay far
// inside int64 in units of 2⁻⁵⁰.
constexpr double kMaxLogChord = 700;

// Sets the corners of edge e (b = kInvalid for a boundary edge), keeping Topology's rules: an
// interior edge lists its smaller corner first and is oriented as it runs in that corner's face.
void set_edge_corners(IntrinsicTriangulation& tri, Index e, Index a, Index b) {
  Topology& t = tri.topology;
  if (b != kInvalid && b < a) std::swap(a, b);
  t.edge_corners[2 * e] = a;
  t.edge_corners[2 * e + 1] = b;
  t.edge_vertices[2 * e] = t.corner_vertex[next_corner(a)];
  t.edge_vertices[2 * e + 1] = t.corner_vertex[prev_corner(a)];
  if (b == kInvalid) t.boundary_corners[tri.boundary_position[e]] = a;
}

// Records a flip of e into `journal` (when given) before anything of it is written.
void record_flip(const IntrinsicTriangulation& tri, Index e, FlipJournal* journal) {
  if (!journal) return;
  const Topology& t = tri.topology;
  FlipRecord r;
  r.edge = e;
  r.c0 = t.edge_corners[2 * e];
  r.c1 = t.edge_corners[2 * e + 1];
  r.across_jk = t.opposite[next_corner(r.c0)];
  r.across_il = t.opposite[next_corner(r.c1)];
  r.log_chord = tri.log_chord[e];
  r.normal = tri.normal.size() == static_cast<std::size_t>(t.num_edges) ? tri.normal[e] : 0;
  journal->records.push_back(r);
}

// Total area of the spherical triangles with side lengths s·l, or −1 when one of them is not a
// spherical triangle (triangle inequality, perimeter below 2π). L'Huilier's formula. (No NaN: a
// relational comparison with NaN raises FE_INVALID, which the test runner traps.)
double spherical_area(const Topology& t, std::span<const double> l, double s) {
  double total = 0;
  for (Index f = 0; f < t.num_faces; ++f) {
    const double a = s * l[t.corner_edge[3 * f]], b = s * l[t.corner_edge[3 * f + 1]], c = s * l[t.corner_edge[3 * f + 2]];
    const double h = 0.5 * (a + b + c);
    if (!(h - a > 0 && h - b > 0 && h - c > 0 && h < std::numbers::pi)) return -1;
    const double q = std::tan(0.5 * h) * std::tan(0.5 * (h - a)) * std::tan(0.5 * (h - b)) * std::tan(0.5 * (h - c));
    total += 4 * std::atan(std::sqrt(std::max(0.0, q)));
  }
  return total;
}

// The scale s at which the lengths s·l, read as spherical arcs, have total area 4π (from `guess`,
// the euclidean area-4π scale), or 0.9 of the largest admissible scale below it when no admissible
// scale reaches 4π. A round sphere's metric then starts at its solution's scale (and a platonic
// solid's at its solution), which matters for the Möbius gauge that holds three u. The root is
// bracketed and found by the Illinois variant of regula falsi (about ten area sums instead of
// bisection's fifty), halving wherever the upper end is not admissible.
double spherical_scale(const Topology& t, std::span<const double> l, double guess) {
  const double target = 4 * std::numbers::pi;
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();  // upper end not admissible
  double lo = 0, hi = guess, f_lo = -target, f_hi = kNone;
  // Grow hi until it overshoots (area ≥ 4π or inadmissible).
  for (int i = 0; i < 60; ++i) {
    const double a = spherical_area(t, l, hi);
    if (a < 0) break;
    if (a >= target) {
      f_hi = a - target;
      break;
    }
    lo = hi;
    f_lo = a - target;
    hi *= 1.5;
  }
  bool reached = std::isfinite(f_hi);
  int kept = 0;  // which end the last step kept: −1 lo moved, +1 hi moved
  for (int i = 0; i < 100 && hi - lo > 1e-15 * hi; ++i) {
    double mid = 0.5 * (lo + hi);
    if (std::isfinite(f_hi) && f_hi > f_lo) {
      const double x = lo + (hi - lo) * (-f_lo / (f_hi - f_lo));
      if (x > lo && x < hi) mid = x;
    }
    const double a = spherical_area(t, l, mid);
    if (a < 0) {
      hi = mid;
      f_hi = kNone;
      kept = 0;
    } else if (a < target) {
      lo = mid;
      f_lo = a - target;
      if (kept == -1 && std::isfinite(f_hi)) f_hi *= 0.5;  // hi stayed twice: weight it down
      kept = -1;
    } else {
      if (a == target) return mid;
      hi = mid;
      f_hi = a - target;
      reached = true;
      if (kept == 1) f_lo *= 0.5;
      kept = 1;
    }
  }
  return reached || spherical_area(t, l, hi) >= 0 ? lo : 0.9 * lo;
}

}  // namespace

IntrinsicResult make_intrinsic_triangulation(const Topology& topology, Geometry geometry, std::span<const double> l,
                                             bool delaunay) {
  IntrinsicResult r;
  const Index ne = topology.num_edges;
  if (l.size() != static_cast<std::size_t>(ne)) {
    r.status = Status::InvalidArgument;
    r.message = "the metric has " + std::to_string(l.size()) + " edge lengths, but the triangulation has " +
                std::to_string(ne) + " edges";
    return r;
  }
  IntrinsicTriangulation& tri = r.triangulation;
  tri.geometry = geometry;
  tri.log_chord.assign(static_cast<std::size_t>(ne), 0);
  for (Index e = 0; e < ne; ++e) {
    const double x = log_chord_of_length(geometry, l[e]);
    if (!std::isfinite(x) || std::abs(x) > kMaxLogChord) {
      r.status = Status::DegenerateFace;
      r.element_index = e;
      r.message = "edge " + std::to_string(e) + " has length " + std::to_string(l[e]) + ", which is not " +
                  (geometry == Geometry::Spherical ? "in (0, π)" : "a positive finite number") +
                  " (or its chord is beyond e^±700)";
      tri = {};
      return r;
    }
    tri.log_chord[e] = std::llround(x / kLogChordUnit);
  }
  tri.topology = topology;
  tri.normal.assign(static_cast<std::size_t>(ne), -1);
  tri.boundary_position.assign(static_cast<std::size_t>(ne), kInvalid);
  for (Index p = 0; p < topology.num_boundary_edges(); ++p)
    tri.boundary_position[topology.corner_edge[topology.boundary_corners[p]]] = p;
  if (delaunay) {
    DelaunayOptions options;
    options.rule = FlipRule::Geometric;
    options.keep_boundary_fans = true;
    const std::vector<double> zero(static_cast<std::size_t>(topology.num_vertices), 0.0);
    const DelaunayReport report = make_delaunay(tri, zero, options);
    r.delaunay_flips = report.flips;
    r.delaunay_refused = report.refused;
    tri.flips = 0;
  }
  r.status = Status::Ok;
  r.message = "ok";
  return r;
}

IntrinsicResult mesh_intrinsic_triangulation(const Mesh& mesh, const Topology& topology, Geometry geometry,
                                             double mollify_margin) {
  std::vector<double> l = mesh_edge_lengths(mesh, topology);
  const Mollification mollification = mollify_lengths(topology, l, mollify_margin);
  double scale = 1;
  if (geometry == Geometry::Euclidean) {
    double longest = 0;
    for (const double x : l) longest = std::max(longest, x);
    scale = unit_power_of_two(longest);
  } else {
    const double chi = static_cast<double>(topology.euler_characteristic());
    // Heron on the lengths times a power of two that keeps its products in range (exact).
    double longest = 0;
    for (const double x : l) longest = std::max(longest, x);
    int exponent = 0;
    std::frexp(longest, &exponent);
    const double p = std::ldexp(1.0, -exponent);
    double area = 0;
    for (Index f = 0; f < topology.num_faces; ++f) {
      const double a = l[topology.corner_edge[3 * f]] * p, b = l[topology.corner_edge[3 * f + 1]] * p,
                   c = l[topology.corner_edge[3 * f + 2]] * p;
      const double s = 0.5 * (a + b + c);
      area += std::sqrt(std::max(0.0, s * (s - a) * (s - b) * (s - c)));
    }
    // scale = sqrt(target / (area / p²)), with the power of two taken out of the root exactly.
    if (geometry == Geometry::Hyperbolic && chi < 0 && area > 0) scale = std::sqrt(2 * std::numbers::pi * -chi / area) * p;
    if (geometry == Geometry::Spherical && area > 0)
      scale = spherical_scale(topology, l, std::sqrt(4 * std::numbers::pi / area) * p);
  }
  for (double& x : l) x *= scale;
  IntrinsicResult r = make_intrinsic_triangulation(topology, geometry, l, true);
  r.mollification = mollification;
  return r;
}

double vertex_scaling_eta(const IntrinsicTriangulation& tri, Index e) {
  // e^709 is about 8e307: beyond it η = e^{2 log B}/2 leaves double range (Ptolemy flips at a
  // far line-search trial can make such chords); it is then +∞, not an overflow.
  constexpr double kMaxTwiceLogChord = 709;
  const double x = 2 * tri.log_chord_of(e);
  return x <= kMaxTwiceLogChord ? 0.5 * std::exp(x) : std::numeric_limits<double>::infinity();
}

bool vertex_scaling_structure(const IntrinsicTriangulation& tri, ConformalStructure& structure) {
  structure.geometry = tri.geometry;
  structure.scheme = Scheme::Yamabe;
  structure.epsilon = 0;
  const Index ne = tri.topology.num_edges;
  structure.eta.resize(static_cast<std::size_t>(ne));
  int beyond = 0;
#pragma omp parallel for schedule(static) if (ne >= kParallelMin) reduction(max : beyond)
  for (Index e = 0; e < ne; ++e) {
    structure.eta[e] = vertex_scaling_eta(tri, e);
    if (structure.eta[e] == std::numeric_limits<double>::infinity()) beyond = 1;
  }
  return beyond == 0;
}

FlipCheck can_flip(const IntrinsicTriangulation& tri, Index e) {
  const Topology& t = tri.topology;
  const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
  if (c1 == kInvalid) return FlipCheck::Boundary;
  if (corner_face(c0) == corner_face(c1)) return FlipCheck::SameFace;
  return FlipCheck::Ok;
}

namespace {

// The normal coordinate of the new diagonal kl of a flip of e = ij (intrinsic_trace.h): the strands
// of the input's edges through the quadrilateral whose two ends lie on different sides of kl (the
// i side: ki, il, i; the j side: jk, lj, j), or −1 when one of them runs from k to l (then it is
// the only one). Strands are the arcs of f0 and f1 that do not touch ij — the corner arcs at k and
// at l, the arcs from i and from j — and the pairs of arcs glued at the same crossing of ij. Along
// ij from i, f0 has its corner arcs at i (to the i side), its arcs from k, its corner arcs at j (to
// the j side), and f1 the same with l; and the old diagonal, when it was an input edge, crosses kl.
std::int64_t flipped_normal(const IntrinsicTriangulation& tri, Index e) {
  const Topology& t = tri.topology;
  const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
  const CornerArcs k = corner_arcs(tri, c0), l = corner_arcs(tri, c1);
  const CornerArcs i0 = corner_arcs(tri, next_corner(c0)), j0 = corner_arcs(tri, prev_corner(c0));
  const CornerArcs i1 = corner_arcs(tri, prev_corner(c1)), j1 = corner_arcs(tri, next_corner(c1));
  const std::int64_t k_end = i0.around + k.from_vertex, l_end = i1.around + l.from_vertex;
  if (std::min(k_end, l_end) > std::max(i0.around, i1.around)) return -1;  // an arc from k meets one from l
  return k.around + l.around + i0.from_vertex + j0.from_vertex + i1.from_vertex + j1.from_vertex +
         std::max<std::int64_t>(0, i0.around - l_end) + std::max<std::int64_t>(0, i1.around - k_end) +
         (tri.normal[e] == -1 ? 1 : 0);
}

// The connectivity of a flip of e (the new edge keeps index e; its log-chord is set by the caller)
// and its normal coordinate.
void flip_connectivity(IntrinsicTriangulation& tri, Index e) {
  Topology& t = tri.topology;
  const bool normal = tri.normal.size() == static_cast<std::size_t>(t.num_edges);
  const std::int64_t n_new = normal ? flipped_normal(tri, e) : 0;
  const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
  const Index n0 = next_corner(c0), p0 = prev_corner(c0), n1 = next_corner(c1), p1 = prev_corner(c1);
  const Index k = t.corner_vertex[c0], l = t.corner_vertex[c1];
  const Index e_jk = t.corner_edge[n0], e_il = t.corner_edge[n1];
  // The corners across jk and il. When jk and il are one edge (the quadrilateral glued to itself
  // along it), each is the other's: n1 and n0, which become the corners at the new edge, and the
  // edge is then opposite c0 and c1.
  Index across_jk = t.opposite[n0], across_il = t.opposite[n1];
  if (across_jk == n1) across_jk = c0;
  if (across_il == n0) across_il = c1;

  t.corner_vertex[p0] = l;
  t.corner_vertex[p1] = k;
  t.corner_edge[c0] = e_il;
  t.corner_edge[n0] = e;
  t.corner_edge[c1] = e_jk;
  t.corner_edge[n1] = e;
  t.opposite[c0] = across_il;
  if (across_il != kInvalid) t.opposite[across_il] = c0;
  t.opposite[c1] = across_jk;
  if (across_jk != kInvalid) t.opposite[across_jk] = c1;
  t.opposite[n0] = n1;
  t.opposite[n1] = n0;
  set_edge_corners(tri, e, n0, n1);
  set_edge_corners(tri, e_il, c0, across_il);
  set_edge_corners(tri, e_jk, c1, across_jk);
  if (normal) tri.normal[e] = n_new;
  ++tri.flips;
}

// The inverse of flip_connectivity() for the flip `r` recorded, with e's log-chord and normal
// coordinate: the triangles kil and ljk (corners c0, n0, p0 and c1, n1, p1) back to kij and lji.
// The flip left n0 at i and n1 at j, c0 across il and c1 across jk; every entry it wrote is among
// those set here, and edge_corners, edge_vertices and boundary_corners follow from Topology's
// rules (set_edge_corners()), which the triangulation before the flip obeyed too.
void unflip(IntrinsicTriangulation& tri, const FlipRecord& r) {
  Topology& t = tri.topology;
  const Index e = r.edge, c0 = r.c0, c1 = r.c1;
  const Index n0 = next_corner(c0), p0 = prev_corner(c0), n1 = next_corner(c1), p1 = prev_corner(c1);
  const Index e_il = t.corner_edge[c0], e_jk = t.corner_edge[c1];
  t.corner_vertex[p0] = t.corner_vertex[n1];  // j
  t.corner_vertex[p1] = t.corner_vertex[n0];  // i
  t.corner_edge[c0] = e;
  t.corner_edge[c1] = e;
  t.corner_edge[n0] = e_jk;
  t.corner_edge[n1] = e_il;
  t.opposite[c0] = c1;
  t.opposite[c1] = c0;
  t.opposite[n0] = r.across_jk;
  t.opposite[n1] = r.across_il;
  if (r.across_jk != kInvalid) t.opposite[r.across_jk] = n0;
  if (r.across_il != kInvalid) t.opposite[r.across_il] = n1;
  set_edge_corners(tri, e, c0, c1);
  set_edge_corners(tri, e_jk, n0, r.across_jk);
  set_edge_corners(tri, e_il, n1, r.across_il);
  tri.log_chord[e] = r.log_chord;
  if (tri.normal.size() == static_cast<std::size_t>(t.num_edges)) tri.normal[e] = r.normal;
  --tri.flips;
}

// The angle opposite the side of length a in a triangle with sides a, b, c in geometry g (half-angle
// formula, as corner_angles()); −1 when a side is not a length (below) or the triangle inequality
// fails. (Sentinels, not NaN, here and below: a relational comparison with NaN raises FE_INVALID.)
double triangle_angle(Geometry g, double a, double b, double c) {
  if (!(a > 0 && b > 0 && c > 0)) return -1;
  const double s = 0.5 * (a + b + c);
  auto f = [g](double x) {
    return g == Geometry::Euclidean ? x : g == Geometry::Hyperbolic ? std::sinh(x) : std::sin(x);
  };
  const double num = f(s - b) * f(s - c), den = f(s) * f(s - a);
  if (!(s - a > 0 && s - b > 0 && s - c > 0 && num > 0 && den > 0)) return -1;
  return 2 * std::atan(std::sqrt(num / den));
}

// Edge length from log B and the two end values of u; −1 for a spherical chord ≥ 1.
double length_of(Geometry g, double log_chord, double ua, double ub) {
  const double L = std::exp(log_chord + 0.5 * (ua + ub));
  switch (g) {
    case Geometry::Euclidean:
      return L;
    case Geometry::Hyperbolic:
      return 2 * std::asinh(L);
    case Geometry::Spherical:
      return L < 1 ? 2 * std::asin(L) : -1;
  }
  return -1;
}

}  // namespace

void flip_edge(IntrinsicTriangulation& tri, Index e, FlipJournal* journal) {
  const Topology& t = tri.topology;
  const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
  const Index e_ki = t.corner_edge[prev_corner(c0)], e_jk = t.corner_edge[next_corner(c0)];
  const Index e_il = t.corner_edge[next_corner(c1)], e_lj = t.corner_edge[prev_corner(c1)];
  // Ptolemy in fixed point: σ from the two products, symmetric in them, then B_kl = σ − B_ij.
  const std::int64_t a = tri.log_chord[e_il] + tri.log_chord[e_jk];
  const std::int64_t b = tri.log_chord[e_lj] + tri.log_chord[e_ki];
  const std::int64_t hi = std::max(a, b), lo = std::min(a, b);
  const double gap = static_cast<double>(lo - hi) * kLogChordUnit;  // ≤ 0
  const std::int64_t sigma = hi + std::llround(std::log1p(std::exp(gap)) / kLogChordUnit);
  record_flip(tri, e, journal);
  tri.log_chord[e] = sigma - tri.log_chord[e];
  flip_connectivity(tri, e);
}

bool flip_edge_geometric(IntrinsicTriangulation& tri, std::span<const double> u, Index e, FlipJournal* journal) {
  const Topology& t = tri.topology;
  const Geometry g = tri.geometry;
  const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
  const Index n0 = next_corner(c0), p0 = prev_corner(c0), n1 = next_corner(c1), p1 = prev_corner(c1);
  const Index k = t.corner_vertex[c0], i = t.corner_vertex[n0], j = t.corner_vertex[p0], l = t.corner_vertex[c1];
  const double l_ij = length_of(g, tri.log_chord_of(e), u[i], u[j]);
  const double l_ki = length_of(g, tri.log_chord_of(t.corner_edge[p0]), u[k], u[i]);
  const double l_jk = length_of(g, tri.log_chord_of(t.corner_edge[n0]), u[j], u[k]);
  const double l_il = length_of(g, tri.log_chord_of(t.corner_edge[n1]), u[i], u[l]);
  const double l_lj = length_of(g, tri.log_chord_of(t.corner_edge[p1]), u[l], u[j]);
  // The angle of the quadrilateral at i (between ik and il), then the cosine law across it, in
  // the half-chord form: L_kl² = f((a − c)/2)² + h(a) h(c) sin²(θ/2), f = id·2, sinh, sin.
  const double ti = triangle_angle(g, l_jk, l_ij, l_ki), tj = triangle_angle(g, l_ki, l_ij, l_jk);
  const double si = triangle_angle(g, l_lj, l_ij, l_il), sj = triangle_angle(g, l_il, l_ij, l_lj);
  if (ti < 0 || tj < 0 || si < 0 || sj < 0) return false;
  const double theta = ti + si;
  if (!(theta < std::numbers::pi) || !(tj + sj < std::numbers::pi)) return false;
  const double a = l_ki, c = l_il, half = std::sin(0.5 * theta);
  double chord2 = 0;
  switch (g) {
    case Geometry::Euclidean:
      chord2 = (a - c) * (a - c) + 4 * a * c * half * half;
      break;
    case Geometry::Hyperbolic:
      chord2 = std::pow(std::sinh(0.5 * (a - c)), 2) + std::sinh(a) * std::sinh(c) * half * half;
      break;
    case Geometry::Spherical:
      chord2 = std::pow(std::sin(0.5 * (a - c)), 2) + std::sin(a) * std::sin(c) * half * half;
      break;
  }
  if (!(chord2 > 0) || !std::isfinite(chord2)) return false;
  const double log_chord = 0.5 * std::log(chord2) - 0.5 * (u[k] + u[l]);
  if (!(std::abs(log_chord) <= kMaxLogChord)) return false;
  record_flip(tri, e, journal);
  tri.log_chord[e] = std::llround(log_chord / kLogChordUnit);
  flip_connectivity(tri, e);
  return true;
}

double delaunay_margin(const IntrinsicTriangulation& tri, std::span<const double> u, Index e) {
  const Topology& t = tri.topology;
  const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
  if (c1 == kInvalid) return std::numeric_limits<double>::infinity();
  const Index n0 = next_corner(c0), p0 = prev_corner(c0), n1 = next_corner(c1), p1 = prev_corner(c1);
  const double uk = u[t.corner_vertex[c0]], ui = u[t.corner_vertex[n0]], uj = u[t.corner_vertex[p0]],
               ul = u[t.corner_vertex[c1]];
  // log L of the five edges at u: ki, jk, il, lj, ij.
  double y[5] = {tri.log_chord_of(t.corner_edge[p0]) + 0.5 * (uk + ui),
                 tri.log_chord_of(t.corner_edge[n0]) + 0.5 * (uj + uk),
                 tri.log_chord_of(t.corner_edge[n1]) + 0.5 * (ui + ul),
                 tri.log_chord_of(t.corner_edge[p1]) + 0.5 * (ul + uj),
                 tri.log_chord_of(e) + 0.5 * (ui + uj)};
  const double top = *std::max_element(y, y + 5);
  double L[5];
  for (int i = 0; i < 5; ++i) L[i] = std::exp(y[i] - top);
  const double ki = L[0], jk = L[1], il = L[2], lj = L[3], ij = L[4];
  return (il * ki + jk * lj) * (il * jk + ki * lj) - ij * ij * (jk * ki + il * lj);
}

namespace {

// Whether flipping interior edge e leaves one of its ends on the boundary in a single face: both
// faces of e have their other edge at that end on the boundary.
bool makes_ear(const Topology& t, Index e) {
  const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
  const bool first = t.opposite[prev_corner(c0)] == kInvalid && t.opposite[next_corner(c1)] == kInvalid;
  const bool second = t.opposite[next_corner(c0)] == kInvalid && t.opposite[prev_corner(c1)] == kInvalid;
  return first || second;
}

}  // namespace

std::vector<Index> non_delaunay_edges(const IntrinsicTriangulation& tri, std::span<const double> u, double tolerance) {
  const Topology& t = tri.topology;
  const Index ne = t.num_edges, nv = t.num_vertices;
  // Factors e^{u/2} and chords B whose logs exceed kSafeLog are left at 0 (their quadrilaterals take
  // delaunay_margin()): a chord times two factors then stays within e^{±2 kSafeLog}, inside double.
  constexpr double kSafeLog = 300;
  std::vector<double> scale(static_cast<std::size_t>(nv)), chord(static_cast<std::size_t>(ne));
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
  for (Index v = 0; v < nv; ++v) scale[v] = std::abs(0.5 * u[v]) < 0.5 * kSafeLog ? std::exp(0.5 * u[v]) : 0.0;
#pragma omp parallel for schedule(static) if (ne >= kParallelMin)
  for (Index e = 0; e < ne; ++e) {
    const double y = tri.log_chord_of(e);
    chord[e] = std::abs(y) < kSafeLog ? std::exp(y) : 0.0;
  }
  std::vector<std::uint8_t> flagged(static_cast<std::size_t>(ne), 0);
#pragma omp parallel for schedule(static) if (ne >= kParallelMin)
  for (Index e = 0; e < ne; ++e) {
    const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
    if (c1 == kInvalid) continue;
    const Index n0 = next_corner(c0), p0 = prev_corner(c0), n1 = next_corner(c1), p1 = prev_corner(c1);
    const double sk = scale[t.corner_vertex[c0]], si = scale[t.corner_vertex[n0]], sj = scale[t.corner_vertex[p0]],
                 sl = scale[t.corner_vertex[c1]];
    // The chords of ki, jk, il, lj, ij at u, as in delaunay_margin().
    double L[5] = {chord[t.corner_edge[p0]] * sk * si, chord[t.corner_edge[n0]] * sj * sk,
                   chord[t.corner_edge[n1]] * si * sl, chord[t.corner_edge[p1]] * sl * sj, chord[e] * si * sj};
    const double top = *std::max_element(L, L + 5), bottom = *std::min_element(L, L + 5);
    double margin = 0;
    if (bottom > 1e-100 && top < 1e100) {  // a 0 (out of range) fails the first test
      for (double& x : L) x /= top;
      const double ki = L[0], jk = L[1], il = L[2], lj = L[3], ij = L[4];
      margin = (il * ki + jk * lj) * (il * jk + ki * lj) - ij * ij * (jk * ki + il * lj);
    } else {
      margin = delaunay_margin(tri, u, e);
    }
    flagged[e] = margin < -tolerance ? 1 : 0;
  }
  std::vector<Index> out;
  for (Index e = 0; e < ne; ++e)
    if (flagged[e]) out.push_back(e);
  return out;
}

DelaunayReport make_delaunay(IntrinsicTriangulation& tri, std::span<const double> u, const DelaunayOptions& options) {
  const std::vector<Index> suspects = non_delaunay_edges(tri, u, options.tolerance);
  return make_delaunay(tri, u, suspects, options);
}

DelaunayReport make_delaunay(IntrinsicTriangulation& tri, std::span<const double> u, std::span<const Index> suspects,
                             const DelaunayOptions& options) {
  return make_delaunay(tri, u, suspects, options, nullptr);
}

DelaunayReport make_delaunay(IntrinsicTriangulation& tri, std::span<const double> u, std::span<const Index> suspects,
                             const DelaunayOptions& options, FlipJournal* journal) {
  DelaunayReport report;
  Topology& t = tri.topology;
  const Index ne = t.num_edges;
  const std::int64_t max_flips = options.max_flips > 0 ? options.max_flips : 100 * std::int64_t{ne} + 1000;
  const double tol = options.tolerance;
  std::vector<std::uint8_t> queued(static_cast<std::size_t>(ne), 0);
  std::deque<Index> queue;
  for (const Index e : suspects)
    if (e >= 0 && e < ne && !queued[e]) {
      queued[e] = 1;
      queue.push_back(e);
    }
  std::vector<Index> refused;
  while (!queue.empty()) {
    const Index e = queue.front();
    queue.pop_front();
    queued[e] = 0;
    if (!(delaunay_margin(tri, u, e) < -tol)) continue;
    if (report.flips >= max_flips) {
      report.complete = false;
      break;
    }
    if (can_flip(tri, e) != FlipCheck::Ok || (options.keep_boundary_fans && makes_ear(t, e)) ||
        (options.rule == FlipRule::Geometric && !flip_edge_geometric(tri, u, e, journal))) {
      refused.push_back(e);
      continue;
    }
    if (options.rule == FlipRule::Ptolemy) flip_edge(tri, e, journal);
    ++report.flips;
    // The four edges of the quadrilateral may have become non-Delaunay.
    const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
    for (const Index c : {c0, c1})
      for (const Index d : {next_corner(c), prev_corner(c)}) {
        const Index f = t.corner_edge[d];
        if (f != e && !queued[f] && t.edge_corners[2 * f + 1] != kInvalid) {
          queued[f] = 1;
          queue.push_back(f);
        }
      }
  }
  std::sort(refused.begin(), refused.end());
  refused.erase(std::unique(refused.begin(), refused.end()), refused.end());
  for (const Index e : refused)
    if (delaunay_margin(tri, u, e) < -tol) ++report.refused;
  if (report.flips > 0) refresh_vertex_corners(t);
  return report;
}

void FlipJournal::clear(std::size_t keep_bytes) {
  if (records.capacity() * sizeof(FlipRecord) > keep_bytes)
    records = std::vector<FlipRecord>{};
  else
    records.clear();
}

void undo_flips(IntrinsicTriangulation& tri, FlipJournal& journal, std::int64_t keep) {
  const std::int64_t flips = journal.flips();
  keep = std::clamp<std::int64_t>(keep, 0, flips);
  if (keep == flips) return;
  for (std::int64_t k = flips; k-- > keep;) unflip(tri, journal.records[static_cast<std::size_t>(k)]);
  journal.records.resize(static_cast<std::size_t>(keep));
  refresh_vertex_corners(tri.topology);
}

void refresh_vertex_corners(Topology& t) {
  const Index nv = t.num_vertices, nc = t.num_corners();
  t.vertex_corner_offsets.assign(static_cast<std::size_t>(nv) + 1, 0);
  std::vector<Index> start(static_cast<std::size_t>(nv), kInvalid);
  for (Index c = 0; c < nc; ++c) {
    const Index v = t.corner_vertex[c];
    ++t.vertex_corner_offsets[v + 1];
    // The fan's first corner: the one without a clockwise neighbour (boundary), else the smallest.
    if (start[v] == kInvalid || (t.opposite[prev_corner(c)] == kInvalid && t.opposite[prev_corner(start[v])] != kInvalid))
      start[v] = c;
  }
  for (Index v = 0; v < nv; ++v) t.vertex_corner_offsets[v + 1] += t.vertex_corner_offsets[v];
  t.vertex_corners.resize(static_cast<std::size_t>(nc));
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
  for (Index v = 0; v < nv; ++v) {
    if (start[v] == kInvalid) continue;
    Index c = start[v], i = t.vertex_corner_offsets[v];
    const Index end = t.vertex_corner_offsets[v + 1];
    do {
      t.vertex_corners[i++] = c;
      const Index o = t.opposite[next_corner(c)];
      c = o == kInvalid ? kInvalid : next_corner(o);
    } while (c != kInvalid && c != start[v] && i < end);
  }
}

}  // namespace ricci
