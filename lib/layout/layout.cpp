// Layouts of discrete metrics in E, H and S; the metric on a cut's refined surface; alignment of
// layouts up to isometries. See layout.h for the algorithms and conventions.
#include "ricci/layout.h"

#include "ceres_quiet.h"
#include "double_double.h"
#include "layout_internal.h"
#include "layout_polish.h"
#include "model_geometry.h"

#include <Eigen/Dense>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <cfenv>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdint>
#include <functional>
#include <cstdio>
#include <limits>
#include <numbers>
#include <numeric>
#include <string>
#include <tuple>
#include <vector>

namespace ricci {

namespace {

using Clock = std::chrono::steady_clock;
using Cx = std::complex<double>;
using V3 = std::array<double, 3>;
constexpr double kPi = std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// E layouts whose propagation misses the metric by more than this (above the rounding floor) are
// also computed from the triangles' shapes by one least-squares solve (LayoutOptions::polish_steps).
constexpr double kShapeLayoutAbove = 1e-8;
// A placement whose vertex has an angle with sine below this costs more in the propagation (see
// run_layout()).
constexpr double kIllPlaced = 1e-4;
// The Gauss–Seidel sweeps of a round move only the vertices within kSweepRings edges of an edge
// whose error, above its floor or in all, exceeds kSweepShare of the largest: a round is kept when
// it lowers the largest error and goes on while it halves it, so edges at a quarter of it matter
// no more (after divide and conquer the error sits along the seams: a few per cent of the
// vertices).
constexpr double kSweepShare = 0.25;
constexpr int kSweepRings = 2;
// A round over those vertices that does not lower the largest error above the floor to this share
// of it, or raises the largest error, is followed by rounds over every vertex: the error is not
// only where the largest errors are.
constexpr double kLocalGain = 0.75;
// With the automatic patch count, at most this many local sweeps (rounds of 1, 2, 4) run before
// the patches are tried (refine_layout()).
constexpr int kSweepsBeforePatches = 7;

std::string num(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

// ---- small vector helpers ------------------------------------------------------------------

V3 sub(const V3& a, const V3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V3 cross(const V3& a, const V3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(const V3& a) { return std::sqrt(dot(a, a)); }
V3 scaled(const V3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
V3 normalized(const V3& a) {
  const double n = norm(a);
  return n > 0 ? scaled(a, 1 / n) : V3{0, 0, 1};
}

/// |z| without hypot's overflow guards (a few times faster); hypot only when the square overflows
/// or underflows.
double euclidean_norm(Cx z) {
  const double n2 = z.real() * z.real() + z.imag() * z.imag();
  return n2 > 1e-300 && n2 < 1e300 ? std::sqrt(n2) : std::abs(z);
}

/// Area of a euclidean triangle with sides a, b, c by Kahan's ordering of Heron's formula (exact
/// to a few ulps however thin the triangle); 0 when rounding leaves the sides degenerate.
double heron_area(double a, double b, double c) {
  if (a < b) std::swap(a, b);
  if (b < c) std::swap(b, c);
  if (a < b) std::swap(a, b);
  const double p = (a + (b + c)) * (c - (a - b)) * (c + (a - b)) * (a + (b - c));
  return p > 0 ? 0.25 * std::sqrt(p) : 0.0;
}

/// f of the half-angle formula: identity (E), sinh (H), sin (S).
double side_function(Geometry g, double x) {
  switch (g) {
    case Geometry::Hyperbolic: return std::sinh(x);
    case Geometry::Spherical: return std::sin(x);
    default: return x;
  }
}

}  // namespace

namespace {

using detail::angle_from_lengths;

using model::disk_distance;    // Poincaré disk; +∞ on or outside the unit circle
using model::sphere_distance;  // great circle of two unit vectors

/// (cos θ, sin θ) of the angle θ opposite side a in the triangle with sides a, b, c (H, S; E
/// places by the cosine law), from the two products of the half-angle formula —
/// sin²(θ/2) ∝ f(σ−b)·f(σ−c), cos²(θ/2) ∝ f(σ)·f(σ−a), σ the half perimeter, f = sinh or sin —
/// without forming θ (angle_from_lengths() takes its arctangent): as exact as θ from the same
/// products, and no arctangent, sine or cosine after them. (1, 0) when both products vanish.
Cx turn_at_first(Geometry g, double a, double b, double c) {
  const double half = (a + b + c) / 2;
  const double sin2 = std::max(0.0, side_function(g, std::max(0.0, half - b)) * side_function(g, std::max(0.0, half - c)));
  const double cos2 = std::max(0.0, side_function(g, half) * side_function(g, std::max(0.0, half - a)));
  const double sum = sin2 + cos2;
  return sum > 0 ? Cx((cos2 - sin2) / sum, 2 * std::sqrt(sin2 * cos2) / sum) : Cx(1, 0);
}

/// a / b for a divisor bounded away from 0 and ∞ (the disk maps' 1 − p̄z with |p|, |z| < 1):
/// the plain formula, without the scaling of the library's complex division.
Cx disk_quotient(Cx a, Cx b) {
  const double n = std::norm(b);
  return {(a.real() * b.real() + a.imag() * b.imag()) / n, (a.imag() * b.real() - a.real() * b.imag()) / n};
}

/// z ↦ (z − p)/(1 − p̄ z), the disk automorphism taking p to 0, and its inverse.
Cx to_origin(Cx p, Cx z) { return disk_quotient(z - p, 1.0 - std::conj(p) * z); }
Cx from_origin(Cx p, Cx z) { return disk_quotient(z + p, 1.0 + std::conj(p) * z); }

/// Hyperboloid point (t, x, y) of a Poincaré disk point.
V3 hyperboloid(Cx z) {
  const double r2 = std::norm(z);
  const double d = (1 - std::abs(z)) * (1 + std::abs(z));
  return {(1 + r2) / d, 2 * z.real() / d, 2 * z.imag() / d};
}

/// Poincaré disk point of a future-timelike vector (t, x, y) (rescaled onto the hyperboloid).
Cx poincare(const V3& X) {
  const double n2 = X[0] * X[0] - X[1] * X[1] - X[2] * X[2];
  const double n = std::sqrt(std::max(n2, 0.0));
  const double t = X[0] + n;
  return t > 0 ? Cx(X[1], X[2]) / t : Cx(0, 0);
}

// ---- positions of one layout ---------------------------------------------------------------

struct Positions {
  Geometry g = Geometry::Euclidean;
  int dims = 2;
  std::vector<double>& x;
  /// The low parts of the coordinates while a propagation keeps them in double-double (x the
  /// high parts, x = fl(x + lo)); null: plain doubles.
  double* lo = nullptr;

  Cx z(Index v) const { return {x[2 * v], x[2 * v + 1]}; }
  void set(Index v, Cx w) {
    x[2 * v] = w.real();
    x[2 * v + 1] = w.imag();
    if (lo != nullptr) lo[2 * v] = lo[2 * v + 1] = 0;
  }
  V3 p(Index v) const { return {x[3 * v], x[3 * v + 1], x[3 * v + 2]}; }
  void set(Index v, const V3& w) {
    for (int d = 0; d < 3; ++d) x[3 * v + d] = w[d];
    if (lo != nullptr) lo[3 * v] = lo[3 * v + 1] = lo[3 * v + 2] = 0;
  }
  /// Coordinate k of v minus that of u: from both parts when they are kept, so exact to the
  /// rounding of the difference itself however far from the origin the two lie.
  double diff(Index v, Index u, int k) const {
    const auto i = static_cast<std::size_t>(dims * v + k), j = static_cast<std::size_t>(dims * u + k);
    return lo != nullptr ? detail::dd::difference(x[i], lo[i], x[j], lo[j]) : x[i] - x[j];
  }
  /// Puts v at u + offset (dims coordinates), keeping u's low parts when they are kept.
  void set_offset(Index v, Index u, const double* offset) {
    for (int k = 0; k < dims; ++k) {
      const auto i = static_cast<std::size_t>(dims * v + k), j = static_cast<std::size_t>(dims * u + k);
      if (lo != nullptr) detail::dd::add(x[j], lo[j], offset[k], x[i], lo[i]);
      else x[i] = x[j] + offset[k];
    }
  }
  /// H: 1 − |z|² of v, from both parts when they are kept.
  double room(Index v) const {
    const std::size_t i = 2 * static_cast<std::size_t>(v);
    return lo != nullptr ? detail::dd::one_minus_norm(x[i], lo[i], x[i + 1], lo[i + 1])
                         : detail::dd::one_minus_norm(x[i], 0, x[i + 1], 0);
  }
  /// H: 1 − āb for a = v and b = v + d (d = b − a from diff()), as (1 − |a|²) − ā·d: the
  /// denominator of the isometry moving a to the origin, at b; b's image there is d over it.
  Cx disk_gap(Index v, Cx d) const { return room(v) - std::conj(z(v)) * d; }
  /// H: the offset from v of the point the isometry moving v to the origin takes to `local`:
  /// from_origin(v, local) − v = local·(1 − |v|²)/(1 + v̄·local).
  Cx disk_offset(Index v, Cx local) const { return disk_quotient(local * room(v), 1.0 + std::conj(z(v)) * local); }
  /// v where u is (both parts).
  void copy(Index v, Index u) {
    for (int k = 0; k < dims; ++k) {
      x[static_cast<std::size_t>(dims * v + k)] = x[static_cast<std::size_t>(dims * u + k)];
      if (lo != nullptr) lo[dims * v + k] = lo[dims * u + k];
    }
  }
  bool finite(Index v) const {
    for (int d = 0; d < dims; ++d)
      if (!std::isfinite(x[dims * v + d])) return false;
    return g != Geometry::Hyperbolic || std::abs(z(v)) < 1;
  }
  double distance(Index a, Index b) const {
    switch (g) {
      case Geometry::Euclidean: return euclidean_norm(z(a) - z(b));
      case Geometry::Hyperbolic: return disk_distance(z(a), z(b));
      default: return sphere_distance(p(a), p(b));
    }
  }
  /// Sign of the orientation of the geodesic triangle (a, b, c).
  double orientation(Index a, Index b, Index c) const {
    if (g == Geometry::Spherical) return dot(p(a), cross(p(b), p(c)));
    Cx A = z(a), B = z(b), Cc = z(c);
    if (g == Geometry::Hyperbolic) {
      auto klein = [](Cx w) { return 2.0 * w / (1.0 + std::norm(w)); };
      A = klein(A);
      B = klein(B);
      Cc = klein(Cc);
    }
    const Cx u = B - A, w = Cc - A;
    return u.real() * w.imag() - u.imag() * w.real();
  }
  /// Places the vertex of corner o of t from the two ends of the edge opposite it (placed
  /// already); returns that vertex.
  Index place_corner(const Topology& t, std::span<const double> l, Index o) {
    const Index v = t.corner_vertex[o];
    place(v, t.corner_vertex[next_corner(o)], t.corner_vertex[prev_corner(o)], l[t.corner_edge[prev_corner(o)]],
          l[t.corner_edge[next_corner(o)]]);
    return v;
  }
  /// Places x so that d(p, x) = rp, d(q, x) = rq, x on the left of p → q. Each geometry forms the
  /// new vertex as p plus an offset computed from q − p (diff()), never from the two positions
  /// themselves: with double-double positions the offset's rounding is the only error a
  /// placement adds, relative to the triangle's own size.
  void place(Index v, Index pv, Index qv, double rp, double rq) {
    switch (g) {
      case Geometry::Euclidean: {
        // In the frame of the placed edge (P at 0, Q on +x at distance s, measured): x = along +
        // i·across, along from the cosine law (absolute error about ε·max length), across = 2·area/s
        // with the area by Kahan's stable Heron formula (relative error about ε), no trigonometry.
        const Cx d(diff(qv, pv, 0), diff(qv, pv, 1));
        const double s = euclidean_norm(d);
        if (!(s > 0) || !std::isfinite(s)) {  // the edge's ends coincide in double: no frame
          set(v, Cx(kNaN, kNaN));
          break;
        }
        const double along = ((rp - rq) * (rp + rq) + s * s) / (2 * s);
        const double across = 2 * heron_area(s, rp, rq) / s;
        const Cx offset = (d / s) * Cx(along, across);
        const double o[2] = {offset.real(), offset.imag()};
        set_offset(v, pv, o);
        break;
      }
      case Geometry::Hyperbolic: {
        // P moved to the origin by the disk isometry, Q to w; geodesics through the origin are
        // diameters and the model is conformal, so the vertex lies at tanh(rp/2)·e^{iθ}·w/|w|, θ the
        // triangle's angle at P. cos θ and sin θ come from the half-angle formula's two products
        // (sin²(θ/2) ∝ sinh(σ−s)·sinh(σ−rp), cos²(θ/2) ∝ sinh σ·sinh(σ−rq), σ the half perimeter)
        // without forming θ: no arctangent, sine or cosine, and θ as exact as the formula's.
        // With d = Q − P: w = d / ((1 − |P|²) − P̄d), and the vertex z = from_origin(P, local) is
        // P + local·(1 − |P|²)/(1 + P̄·local); 1 − |P|² from both parts of P.
        const Cx P = z(pv), d(diff(qv, pv, 0), diff(qv, pv, 1));
        const Cx w = disk_quotient(d, disk_gap(pv, d));
        const double T = std::sqrt(std::norm(w));
        if (T > 0 && T < 1 && rp < 300 && rq < 300 && room(pv) > 0) {
          const Cx local = (std::tanh(rp / 2) / T) * w * turn_at_first(g, rq, 2 * std::atanh(T), rp);
          const Cx offset = disk_offset(pv, local);
          const double o[2] = {offset.real(), offset.imag()};
          set_offset(v, pv, o);
        } else {
          // Ends that coincide or lie a disk apart in double, or lengths beyond the disk's
          // resolution (tanh(rp/2) rounds to 1 from rp ≈ 38): by the angle itself, which stays
          // finite there; the measured layout shows what rounding did.
          const double s = T < 1 ? 2 * std::atanh(T) : kInf;
          const Cx local = std::polar(std::tanh(rp / 2), std::arg(w) + angle_from_lengths(g, rq, std::min(s, 1e300), rp));
          set(v, from_origin(P, local));
        }
        break;
      }
      default: {
        // P, its tangent U towards Q and W = P × U; the vertex is cos rp·P + sin rp·(cos θ U +
        // sin θ W), formed as P + offset and brought back onto the sphere by a factor 1 + k
        // (|P + offset|² = 1 + δ; k = 1/√(1 + δ) − 1 without cancellation).
        const V3 P = p(pv), d{diff(qv, pv, 0), diff(qv, pv, 1), diff(qv, pv, 2)};
        const V3 n = cross(P, d);  // P × Q
        const double s = std::atan2(norm(n), 1 + dot(P, d));
        const V3 U = normalized(cross(n, P));  // tangent at P towards Q
        const V3 W = cross(P, U);
        const Cx turn = turn_at_first(g, rq, s, rp);
        const double c = turn.real(), sn = turn.imag(), h = std::sin(rp / 2), sr = std::sin(rp);
        const double cr1 = -2 * h * h;  // cos rp − 1
        double o[3];
        for (int k = 0; k < 3; ++k) o[k] = cr1 * P[k] + sr * (c * U[k] + sn * W[k]);
        // |P|² − 1 is below 2⁻¹⁰⁰ with both parts kept; with doubles only, P's own rounding.
        const double gap = lo != nullptr ? 0.0 : dot(P, P) - 1;
        const double delta = gap + 2 * (P[0] * o[0] + P[1] * o[1] + P[2] * o[2]) + (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
        const double root = std::sqrt(1 + delta), k1 = -delta / (root * (1 + root));
        for (int k = 0; k < 3; ++k) o[k] = o[k] * (1 + k1) + P[k] * k1;
        set_offset(v, pv, o);
        break;
      }
    }
  }
  /// The seed face: corner 0 at the base point, corner 0 → 1 along +x.
  void place_seed(Index v0, Index v1, Index v2, double l0, double l1, double l2) {
    const double th = angle_from_lengths(g, l0, l1, l2);
    switch (g) {
      case Geometry::Euclidean:
        set(v0, Cx(0, 0));
        set(v1, Cx(l2, 0));
        set(v2, std::polar(l1, th));
        break;
      case Geometry::Hyperbolic:
        set(v0, Cx(0, 0));
        set(v1, Cx(std::tanh(l2 / 2), 0));
        set(v2, std::polar(std::tanh(l1 / 2), th));
        break;
      default:
        set(v0, V3{0, 0, 1});
        set(v1, V3{std::sin(l2), 0, std::cos(l2)});
        set(v2, V3{std::sin(l1) * std::cos(th), std::sin(l1) * std::sin(th), std::cos(l1)});
        break;
    }
  }
};

/// How far rounding the two ends' coordinates to double can move edge (a, b), in the geometry.
double rounding_drift(Geometry g, const Positions& P, Index a, Index b) {
  if (g == Geometry::Spherical) return 2 * 0x1p-53 * std::sqrt(3.0);
  return detail::rounding_drift_planar(g, P.z(a), P.z(b));
}

/// An edge's error above its rounding drift; 0 where rounding cannot place the edge's ends
/// (drift ∞: at or beyond the circle), which have no error above rounding (and ∞ − ∞ would raise
/// FE_INVALID).
double error_above_drift(double err, double drift) { return std::isinf(drift) ? 0.0 : err - drift; }

/// Each edge's relative length error |d − l|/l and its rounding drift over l (measure_edges()).
struct EdgeErrors {
  std::vector<double> err, drift;
  double above(Index e) const { return error_above_drift(err[e], drift[e]); }
};

/// The figures of Layout (max error, worst edge, rounding floor, max error above it) over the
/// edges, `at(e)` giving edge e's error and drift. Parallel; a NaN ranks above every number and
/// ties go to the smaller edge index, so the result does not depend on the threads.
template <class At>
void reduce_edges(Index ne, At&& at, Layout& o) {
  auto rank = [](double x) { return std::isnan(x) ? kInf : x; };
  double worst = 0, floor = 0, above = 0;
  Index worst_edge = kInvalid;
#pragma omp parallel
  {
    double my_worst = 0, my_floor = 0, my_above = 0;
    Index my_edge = kInvalid;
#pragma omp for schedule(static) nowait
    for (Index e = 0; e < ne; ++e) {
      const auto [err, drift] = at(e);
      my_floor = std::max(my_floor, drift);
      const double excess = error_above_drift(err, drift);
      if (rank(excess) > rank(my_above)) my_above = excess;
      if (rank(err) > rank(my_worst)) {
        my_worst = err;
        my_edge = e;
      }
    }
#pragma omp critical(ricci_measure_edges)
    {
      floor = std::max(floor, my_floor);
      if (rank(my_above) > rank(above)) above = my_above;
      if (my_edge != kInvalid && (rank(my_worst) > rank(worst) || (rank(my_worst) == rank(worst) &&
                                                                   (worst_edge == kInvalid || my_edge < worst_edge)))) {
        worst = my_worst;
        worst_edge = my_edge;
      }
    }
  }
  o.max_edge_length_error = worst;
  o.worst_edge = worst_edge;
  o.rounding_floor = floor;
  o.max_error_above_rounding = above;
}

/// Edge e's relative length error and rounding drift over its length in positions P.
std::pair<double, double> edge_error(const Topology& t, Geometry g, std::span<const double> l, const Positions& P,
                                     Index e) {
  const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
  return {std::abs(P.distance(a, b) - l[e]) / l[e], rounding_drift(g, P, a, b) / l[e]};
}

/// Max relative edge-length error, worst edge and rounding floor of positions P (see Layout);
/// with `per_edge`, each edge's figures are kept there too.
void measure_edges(const Topology& t, Geometry g, std::span<const double> l, const Positions& P, Layout& o,
                   EdgeErrors* per_edge = nullptr) {
  const Index ne = t.num_edges;
  if (per_edge == nullptr) {
    reduce_edges(ne, [&](Index e) { return edge_error(t, g, l, P, e); }, o);
    return;
  }
  EdgeErrors& E = *per_edge;
  E.err.resize(static_cast<std::size_t>(ne));
  E.drift.resize(static_cast<std::size_t>(ne));
#pragma omp parallel for schedule(static)
  for (Index e = 0; e < ne; ++e) std::tie(E.err[e], E.drift[e]) = edge_error(t, g, l, P, e);
  reduce_edges(ne, [&](Index e) { return std::pair<double, double>(E.err[e], E.drift[e]); }, o);
}

/// measure_edges() with per_edge = E after only the vertices `moved` moved: their edges are
/// measured again, the others kept.
void remeasure_edges(const Topology& t, Geometry g, std::span<const double> l, const Positions& P,
                     std::span<const Index> moved, EdgeErrors& E, Layout& o) {
  std::vector<std::uint8_t> mark(static_cast<std::size_t>(t.num_edges), 0);
  std::vector<Index> edges;
  for (Index v : moved)
    for (Index i = t.vertex_corner_offsets[v]; i < t.vertex_corner_offsets[v + 1]; ++i) {
      const Index c = t.vertex_corners[i];
      for (Index e : {t.corner_edge[next_corner(c)], t.corner_edge[prev_corner(c)]})
        if (!mark[e]) {
          mark[e] = 1;
          edges.push_back(e);
        }
    }
  const auto n = static_cast<Index>(edges.size());
#pragma omp parallel for schedule(static)
  for (Index k = 0; k < n; ++k) std::tie(E.err[edges[k]], E.drift[edges[k]]) = edge_error(t, g, l, P, edges[k]);
  reduce_edges(t.num_edges, [&](Index e) { return std::pair<double, double>(E.err[e], E.drift[e]); }, o);
}

/// The vertices within `rings` edges of an edge whose error above its rounding floor exceeds
/// `tau`, whose error exceeds `tau_err`, or whose error is NaN, in index order.
std::vector<Index> vertices_near_errors(const Topology& t, const EdgeErrors& E, double tau, double tau_err,
                                        int rings) {
  const Index ne = t.num_edges, nv = t.num_vertices;
  std::vector<std::uint8_t> mark(static_cast<std::size_t>(nv), 0);
  // x above t, a NaN on either side counting as above (tested first: an ordered comparison with
  // a NaN raises FE_INVALID).
  auto exceeds = [](double x, double limit) { return std::isnan(x) || std::isnan(limit) || x > limit; };
  for (Index e = 0; e < ne; ++e)
    if (exceeds(E.above(e), tau) || exceeds(E.err[e], tau_err))
      mark[t.edge_vertices[2 * e]] = mark[t.edge_vertices[2 * e + 1]] = 1;
  for (int r = 1; r <= rings; ++r) {
    const auto level = static_cast<std::uint8_t>(r);
    for (Index e = 0; e < ne; ++e) {
      const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
      if (mark[a] == level && mark[b] == 0) mark[b] = level + 1;
      else if (mark[b] == level && mark[a] == 0) mark[a] = level + 1;
    }
  }
  std::vector<Index> out;
  for (Index v = 0; v < nv; ++v)
    if (mark[v]) out.push_back(v);
  return out;
}

// ---- validation ----------------------------------------------------------------------------

template <class R>
bool check_lengths(const Topology& t, Geometry g, std::span<const double> l, R& r) {
  if (l.size() != static_cast<std::size_t>(t.num_edges)) {
    r.status = Status::InvalidArgument;
    r.message = "expected " + std::to_string(t.num_edges) + " edge lengths, got " + std::to_string(l.size());
    return false;
  }
  for (Index e = 0; e < t.num_edges; ++e) {
    const bool bad = !(std::isfinite(l[e]) && l[e] > 0) || (g == Geometry::Spherical && !(l[e] < kPi));
    if (!bad) continue;
    r.status = Status::DegenerateFace;
    r.element = Element::Edge;
    r.element_index = e;
    r.message = "edge " + std::to_string(e) + " (vertices " + std::to_string(t.edge_vertices[2 * e]) + "–" +
                std::to_string(t.edge_vertices[2 * e + 1]) + ") has length " + num(l[e]) +
                (g == Geometry::Spherical ? ", not in (0, π)" : ", not a positive finite number");
    return false;
  }
  return true;
}

/// A face whose lengths miss the triangle inequality by no more than 4 units in the last place of
/// its longest side: degenerate to rounding (a sliver of a common subdivision whose lengths come
/// from crossings: 7.0e-15, 0.49484433559939217, 0.49484433559939922), laid out flat (angles 0,
/// 0, π, as corner_angles() leaves it).
bool flat_to_rounding(Geometry g, const double a[3]) {
  const double longest = std::max({a[0], a[1], a[2]});
  const double slack = a[0] + a[1] + a[2] - 2 * longest;  // the two short sides minus the long one
  return g != Geometry::Spherical && slack <= 0 && -slack <= 4 * std::numeric_limits<double>::epsilon() * longest;
}

/// Angles and areas; false (with the first face named) on a triangle-inequality violation beyond
/// rounding (flat_to_rounding()).
template <class R>
bool angles_and_areas(const Topology& t, Geometry g, std::span<const double> l, std::vector<double>& theta,
                      std::vector<double>& area, R& r) {
  theta.assign(static_cast<std::size_t>(t.num_corners()), 0.0);
  area.assign(static_cast<std::size_t>(t.num_faces), 0.0);
  AngleReport rep = corner_angles(t, g, l, theta);
  if (rep.violations > 0) {
    // Only faces beyond rounding count.
    rep = AngleReport{0, kInvalid};
    for (Index f = 0; f < t.num_faces; ++f) {
      const double a[3] = {l[t.corner_edge[3 * f]], l[t.corner_edge[3 * f + 1]], l[t.corner_edge[3 * f + 2]]};
      const double s = (a[0] + a[1] + a[2]) / 2;
      bool ok = side_function(g, s) > 0 && (g != Geometry::Spherical || s < kPi);
      for (int k = 0; k < 3; ++k) ok = ok && side_function(g, s - a[k]) > 0;
      if (ok || flat_to_rounding(g, a)) continue;
      if (rep.violations++ == 0) rep.first_violation = f;
    }
  }
  if (rep.violations > 0) {
    const Index f = rep.first_violation;
    r.status = Status::TriangleInequality;
    r.element = Element::Face;
    r.element_index = f;
    r.message = "face " + std::to_string(f) + " (vertices " + std::to_string(t.corner_vertex[3 * f]) + ", " +
                std::to_string(t.corner_vertex[3 * f + 1]) + ", " + std::to_string(t.corner_vertex[3 * f + 2]) +
                ") with lengths " + num(l[t.corner_edge[3 * f]]) + ", " + num(l[t.corner_edge[3 * f + 1]]) + ", " +
                num(l[t.corner_edge[3 * f + 2]]) + " violates the triangle inequality" +
                (g == Geometry::Spherical ? " (or has perimeter ≥ 2π)" : "") + "; " +
                std::to_string(rep.violations) + " faces do";
    return false;
  }
  if (g != Geometry::Euclidean) face_areas(t, g, l, theta, area);  // E: no normalisation weights
  return true;
}

// ---- seed ----------------------------------------------------------------------------------

/// Breadth-first distances over the dual graph from face s; returns the farthest face (smallest
/// index among the farthest).
Index dual_bfs(const Topology& t, Index s, std::vector<Index>& dist) {
  dist.assign(static_cast<std::size_t>(t.num_faces), -1);
  std::vector<Index> queue;
  queue.reserve(static_cast<std::size_t>(t.num_faces));
  dist[s] = 0;
  queue.push_back(s);
  Index far = s;
  for (std::size_t h = 0; h < queue.size(); ++h) {
    const Index f = queue[h];
    if (dist[f] > dist[far] || (dist[f] == dist[far] && f < far)) far = f;
    for (int k = 0; k < 3; ++k) {
      const Index o = t.opposite[3 * f + k];
      if (o == kInvalid || dist[corner_face(o)] >= 0) continue;
      dist[corner_face(o)] = dist[f] + 1;
      queue.push_back(corner_face(o));
    }
  }
  return far;
}

/// A face near the middle of the dual graph's longest paths, by a double sweep: a, the face
/// farthest from face 0, and b, the face farthest from a; then the face whose larger distance to
/// a and b is least (then their sum). Three breadth-first searches.
Index central_face_of(const Topology& t) {
  std::vector<Index> da, db;
  const Index a = dual_bfs(t, 0, db);
  const Index b = dual_bfs(t, a, da);
  dual_bfs(t, b, db);
  Index best = 0;
  auto key = [&](Index f) { return std::pair<Index, Index>(std::max(da[f], db[f]), da[f] + db[f]); };
  for (Index f = 1; f < t.num_faces; ++f)
    if (da[f] >= 0 && key(f) < key(best)) best = f;
  return best;
}

// ---- normalisations ------------------------------------------------------------------------

std::vector<double> vertex_weights(const Topology& t, const std::vector<double>& area) {
  std::vector<double> w(static_cast<std::size_t>(t.num_vertices), 0.0);
#pragma omp parallel for schedule(static)
  for (Index v = 0; v < t.num_vertices; ++v)
    for (Index i = t.vertex_corner_offsets[v]; i < t.vertex_corner_offsets[v + 1]; ++i)
      w[v] += area[corner_face(t.vertex_corners[i])] / 3;
  return w;
}

/// Σ add(acc, i) over i < n, in fixed blocks of indices (the blocks in parallel, then added in
/// order), so that the sum does not depend on the threads. T: Eigen vectors or matrices.
template <class T, class Add>
T block_sum(Index n, Add&& add) {
  constexpr Index kBlock = 4096;
  const Index blocks = (n + kBlock - 1) / kBlock;
  std::vector<T> part(static_cast<std::size_t>(blocks), T::Zero());
#pragma omp parallel for schedule(static)
  for (Index b = 0; b < blocks; ++b) {
    T acc = T::Zero();
    for (Index i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) add(acc, i);
    part[b] = acc;
  }
  T sum = T::Zero();
  for (const T& q : part) sum += q;
  return sum;
}

/// Centre of the hyperboloid centre of mass (Poincaré point) of weighted disk points.
Cx hyperbolic_centre(const Positions& P, Index nv, const std::vector<double>* w) {
  const Eigen::Vector3d C = block_sum<Eigen::Vector3d>(nv, [&](Eigen::Vector3d& acc, Index v) {
    // A position rounded onto the unit circle (or beyond) is no point of the plane: it carries no
    // weight (its hyperboloid point would be infinite).
    if (!(std::abs(P.z(v)) < 1)) return;
    const V3 X = hyperboloid(P.z(v));
    acc += (w ? (*w)[v] : 1.0) * Eigen::Vector3d(X[0], X[1], X[2]);
  });
  return poincare(V3{C[0], C[1], C[2]});
}

/// The disk map z ↦ rot·(z − c)/(1 − c̄ z) that normalises a hyperbolic layout: c the weighted
/// centre of mass (so it goes to the origin), rot the rotation that then puts the seed face's
/// corner 0 (its corner 1 where corner 0 is at the origin) on the positive real axis.
struct DiskMap {
  Cx c{0, 0}, rot{1, 0};
  /// The hyperbolic distance the map moves the centre of mass by.
  double moved() const { return 2 * std::atanh(std::min(std::abs(c), 1 - 1e-16)); }
  /// True when the map moves no point by more than the rounding of its coordinates.
  bool identity() const { return std::abs(c) <= 0x1p-53 && std::abs(rot.imag()) <= 0x1p-53 && rot.real() > 0; }
};

DiskMap normalizing_map(const Topology& t, const Positions& P, const std::vector<double>& w, Index seed) {
  DiskMap m;
  m.c = hyperbolic_centre(P, t.num_vertices, &w);
  Cx ref = to_origin(m.c, P.z(t.corner_vertex[3 * seed]));
  if (std::abs(ref) < 1e-12) ref = to_origin(m.c, P.z(t.corner_vertex[3 * seed + 1]));
  if (std::abs(ref) > 0) m.rot = std::conj(ref) / std::abs(ref);
  return m;
}

/// Moves P by the normalising map in double (nothing when that map is the identity to rounding)
/// and returns the distance the centre of mass moved (0 then); out.centre_of_mass is |z| of the
/// centre of mass afterwards; *map (when not null) is the Lorentz matrix of the map.
double normalize_hyperbolic(const Topology& t, Positions& P, const std::vector<double>& w, Index seed, Layout& out,
                            detail::M3* map = nullptr) {
  const Index nv = t.num_vertices;
  DiskMap m = normalizing_map(t, P, w, seed);
  if (m.identity()) m = DiskMap{};
  double moved = 0;
  if (m.c != Cx(0, 0) || m.rot != Cx(1, 0)) {
    moved = std::max(m.moved(), 0x1p-60);
#pragma omp parallel for schedule(static)
    for (Index v = 0; v < nv; ++v) P.set(v, m.rot * to_origin(m.c, P.z(v)));
  }
  if (map != nullptr) *map = detail::disk_map_matrix(m.c, m.rot);
  out.centre_of_mass = std::abs(hyperbolic_centre(P, nv, &w));
  return moved;
}

void normalize_spherical(const Topology& t, Positions& P, const std::vector<double>& w, Index seed, bool mobius,
                         Layout& out) {
  const Index nv = t.num_vertices;
  double wsum = block_sum<Eigen::Matrix<double, 1, 1>>(nv, [&](auto& acc, Index v) { acc(0) += w[v]; })(0);
  if (!(wsum > 0)) wsum = 1;
  auto centre = [&] {
    const Eigen::Vector3d mu = block_sum<Eigen::Vector3d>(nv, [&](Eigen::Vector3d& acc, Index v) {
      acc += w[v] * Eigen::Vector3d(P.x[3 * v], P.x[3 * v + 1], P.x[3 * v + 2]);
    });
    return scaled(V3{mu[0], mu[1], mu[2]}, 1 / wsum);
  };
  if (mobius) {
    const std::vector<double> before = P.x;
    int it = 0;
    for (; it < 100; ++it) {
      const V3 mu = centre();
      if (norm(mu) < 1e-14) break;
      Eigen::Matrix3d J = block_sum<Eigen::Matrix3d>(nv, [&](Eigen::Matrix3d& acc, Index v) {
        const Eigen::Vector3d x(P.x[3 * v], P.x[3 * v + 1], P.x[3 * v + 2]);
        acc += w[v] * (Eigen::Matrix3d::Identity() - x * x.transpose());
      });
      J *= 2 / wsum;
      const Eigen::Vector3d step = -J.ldlt().solve(Eigen::Vector3d(mu[0], mu[1], mu[2]));
      V3 c{step[0], step[1], step[2]};
      if (!std::isfinite(norm(c))) break;
      if (norm(c) > 0.5) c = scaled(c, 0.5 / norm(c));
      const double c2 = dot(c, c);
#pragma omp parallel for schedule(static)
      for (Index v = 0; v < nv; ++v) {
        V3 x = P.p(v);
        const V3 y{x[0] + c[0], x[1] + c[1], x[2] + c[2]};
        const double d2 = dot(y, y);
        if (!(d2 > 0)) continue;
        for (int d = 0; d < 3; ++d) x[d] = (1 - c2) * y[d] / d2 + c[d];
        P.set(v, normalized(x));
      }
    }
    out.normalization_iterations = it;
    std::vector<double> old = before;
    Positions Q{Geometry::Spherical, 3, old};
    double change = 0;
#pragma omp parallel for schedule(static) reduction(max : change)
    for (Index e = 0; e < t.num_edges; ++e) {
      const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
      const double d0 = Q.distance(a, b), d1 = P.distance(a, b);
      if (d0 > 0) change = std::max(change, std::abs(d1 - d0) / d0);
    }
    out.mobius_length_change = change;
  }
  // Rotation: seed corner 0 → +z, corner 1 into the half-plane y = 0, x > 0.
  const V3 a = P.p(t.corner_vertex[3 * seed]), b = P.p(t.corner_vertex[3 * seed + 1]);
  V3 e1 = sub(b, scaled(a, dot(a, b)));
  if (norm(e1) < 1e-300) e1 = std::abs(a[0]) < 0.9 ? V3{1, 0, 0} : V3{0, 1, 0};
  e1 = normalized(sub(e1, scaled(a, dot(a, e1))));
  const V3 e2 = cross(a, e1);
#pragma omp parallel for schedule(static)
  for (Index v = 0; v < nv; ++v) {
    const V3 x = P.p(v);
    P.set(v, V3{dot(e1, x), dot(e2, x), dot(a, x)});
  }
  out.centre_of_mass = norm(centre());
}

// ---- divide and conquer (E, H) ---------------------------------------------------------------

/// A disk automorphism z ↦ (a z + b)/(b̄ z + ā), |a|² − |b|² = 1 (E: unused).
struct Su11 {
  Cx a{1, 0}, b{0, 0};
  Su11 operator*(const Su11& n) const { return {a * n.a + b * std::conj(n.b), a * n.b + b * std::conj(n.a)}; }
  Cx apply(Cx z) const { return (a * z + b) / (std::conj(b) * z + std::conj(a)); }
  static Su11 to_origin(Cx p) {
    const double s = std::sqrt(1 - std::norm(p));
    return {Cx(1 / s, 0), -p / s};
  }
  static Su11 rotation(double psi) { return {std::polar(1.0, psi / 2), Cx(0, 0)}; }
  Su11 inverse() const { return {std::conj(a), -b}; }
};

/// Complex arithmetic on Ceres jets (std::complex<Jet> is not supported).
template <typename T>
struct Cj {
  T r, i;
};
template <typename T>
Cj<T> operator*(const Cj<T>& x, const Cj<T>& y) {
  return {x.r * y.r - x.i * y.i, x.r * y.i + x.i * y.r};
}
template <typename T>
Cj<T> operator+(const Cj<T>& x, const Cj<T>& y) {
  return {x.r + y.r, x.i + y.i};
}
template <typename T>
Cj<T> operator-(const Cj<T>& x, const Cj<T>& y) {
  return {x.r - y.r, x.i - y.i};
}
template <typename T>
Cj<T> operator/(const Cj<T>& x, const Cj<T>& y) {
  const T d = y.r * y.r + y.i * y.i;
  return {(x.r * y.r + x.i * y.i) / d, (x.i * y.r - x.r * y.i) / d};
}
template <typename T>
Cj<T> cj(Cx z) {
  return {T(z.real()), T(z.imag())};
}

/// The map of one patch into the common frame: T0 ∘ D(δ), D a small isometry near the identity
/// (E: rotation by δ0 and translation L·(δ1, δ2); H: z ↦ e^{iδ0}(z − δ)/(1 − δ̄ z)), T0 the
/// closed-form start (E: rotation rot0 then translation t0; H: the SU(1,1) map m0).
struct PatchMap {
  Geometry g = Geometry::Euclidean;
  Cx rot0{1, 0}, t0{0, 0};
  Su11 m0;
  double scale = 1;

  template <typename T>
  Cj<T> apply(const T* d, Cx x) const {
    const Cj<T> e{cos(d[0]), sin(d[0])};
    if (g == Geometry::Euclidean) {
      const Cj<T> y = e * cj<T>(x) + Cj<T>{T(scale) * d[1], T(scale) * d[2]};
      return cj<T>(rot0) * y + cj<T>(t0);
    }
    const Cj<T> z0{d[1], d[2]};
    const Cj<T> z0c{d[1], -d[2]};
    const Cj<T> one{T(1), T(0)};
    const Cj<T> y = e * (cj<T>(x) - z0) / (one - z0c * cj<T>(x));
    return (cj<T>(m0.a) * y + cj<T>(m0.b)) / (cj<T>(std::conj(m0.b)) * y + cj<T>(std::conj(m0.a)));
  }
  Cx map(const double* d, Cx x) const {
    const Cj<double> w = apply<double>(d, x);
    return {w.r, w.i};
  }
};

/// A vertex shared by two patches: both copies mapped to the common frame must agree.
struct SeamResidual {
  const PatchMap* p;
  const PatchMap* q;
  Cx xp, xq;
  double weight;  // 1/(local edge length · the frame's length scale at the vertex)
  template <typename T>
  bool operator()(const T* dp, const T* dq, T* residual) const {
    const Cj<T> a = p->template apply<T>(dp, xp), b = q->template apply<T>(dq, xq);
    residual[0] = T(weight) * (a.r - b.r);
    residual[1] = T(weight) * (a.i - b.i);
    return true;
  }
};

/// The faces split into patches: seeds by farthest-point sampling over the dual graph (the first
/// is `seed`); owner[f] is the patch of face f, its nearest seed (the first of equals).
struct Patches {
  std::vector<Index> seeds, owner;
};

Patches partition_faces(const Topology& t, Index seed, Index count) {
  const Index nf = t.num_faces;
  Patches out;
  out.seeds = {seed};
  // near[f]: steps from f to the nearest seed (−1: not reached). Each new seed's breadth-first
  // search goes only where it comes strictly nearer: distances to a set of seeds are 1-Lipschitz
  // over the dual graph, so every face on a shortest path to a face that comes nearer comes nearer
  // too, and the pruned search gives the same distances as a full one from every seed.
  std::vector<Index> near, queue;
  dual_bfs(t, seed, near);
  queue.reserve(static_cast<std::size_t>(nf));
  // owner[f]: the seed that last brought f nearer, so the first of its nearest seeds. Each patch
  // is connected: the face f came nearer from holds the same seed (had that face come nearer
  // again later, so would f).
  out.owner.assign(static_cast<std::size_t>(nf), kInvalid);
  for (Index f = 0; f < nf; ++f)
    if (near[f] >= 0) out.owner[f] = 0;
  // level[d]: the faces that came to distance d (in index order at first, then as they came
  // nearer); an entry whose face has come nearer since is stale and dropped when its level is
  // the farthest.
  Index top = 0;
  for (Index f = 0; f < nf; ++f) top = std::max(top, near[f]);
  std::vector<std::vector<Index>> level(static_cast<std::size_t>(top) + 1);
  for (Index f = 0; f < nf; ++f)
    if (near[f] >= 0) level[near[f]].push_back(f);
  while (static_cast<Index>(out.seeds.size()) < count) {
    // The farthest face (the smallest index among the farthest).
    Index best = kInvalid;
    for (; top > 0; --top) {
      std::vector<Index>& at = level[top];
      std::erase_if(at, [&](Index f) { return near[f] != top; });
      if (at.empty()) continue;
      best = *std::min_element(at.begin(), at.end());
      break;
    }
    if (best == kInvalid) break;
    const auto p = static_cast<Index>(out.seeds.size());
    out.seeds.push_back(best);
    near[best] = 0;
    out.owner[best] = p;
    queue.assign({best});
    for (std::size_t h = 0; h < queue.size(); ++h) {
      const Index f = queue[h];
      for (int k = 0; k < 3; ++k) {
        const Index o = t.opposite[3 * f + k];
        if (o == kInvalid) continue;
        const Index nb = corner_face(o);
        if (near[nb] >= 0 && near[nb] <= near[f] + 1) continue;
        near[nb] = near[f] + 1;
        out.owner[nb] = p;
        level[near[nb]].push_back(nb);
        queue.push_back(nb);
      }
    }
  }
  return out;
}

/// One vertex of one patch, in the patch's own frame.
struct PatchCopy {
  Index patch, vertex;
  Cx z;
};

/// The closed-form start of a patch map: the isometry taking the patch's local positions `L` of
/// `touched` onto the current positions `x` (E: Procrustes; H: centroids on the hyperboloid and a
/// rotation).
void start_patch_map(Geometry g, const Positions& L, std::vector<double>& x, std::span<const Index> touched,
                     PatchMap& m) {
  const Positions X{g, 2, x};
  m.g = g;
  double extent = 0;
  if (g == Geometry::Euclidean) {
    Cx ca(0, 0), cb(0, 0);
    for (Index v : touched) {
      ca += X.z(v);
      cb += L.z(v);
    }
    ca /= static_cast<double>(touched.size());
    cb /= static_cast<double>(touched.size());
    Cx acc(0, 0);
    for (Index v : touched) {
      acc += (X.z(v) - ca) * std::conj(L.z(v) - cb);
      extent = std::max(extent, std::abs(L.z(v) - cb));
    }
    m.rot0 = std::abs(acc) > 0 ? acc / std::abs(acc) : Cx(1, 0);
    m.t0 = ca - m.rot0 * cb;
    m.scale = extent > 0 ? extent : 1;
    return;
  }
  // Vertices at or beyond the unit circle (kept aside unplaced, LayoutOptions::keep_unresolved)
  // have no point on the hyperboloid: the fit takes the others, and is the identity without any.
  // |z| as hyperboloid() takes it (|z|² can round below 1 where |z| rounds to 1).
  auto placed = [&](Index v) { return std::abs(X.z(v)) < 1 && std::abs(L.z(v)) < 1; };
  V3 CA{0, 0, 0}, CB{0, 0, 0};
  for (Index v : touched) {
    if (!placed(v)) continue;
    const V3 A = hyperboloid(X.z(v)), B = hyperboloid(L.z(v));
    for (int dd = 0; dd < 3; ++dd) {
      CA[dd] += A[dd];
      CB[dd] += B[dd];
    }
  }
  const Cx ca = poincare(CA), cb = poincare(CB);
  if (!(std::norm(ca) < 1 && std::norm(cb) < 1)) {
    m.m0 = Su11{};
    return;
  }
  Cx acc(0, 0);
  for (Index v : touched)
    if (placed(v)) acc += to_origin(ca, X.z(v)) * std::conj(to_origin(cb, L.z(v)));
  const double psi = std::abs(acc) > 0 ? std::arg(acc) : 0.0;
  m.m0 = Su11::to_origin(ca).inverse() * Su11::rotation(psi) * Su11::to_origin(cb);
}

/// Lays out patch p (seed face s; its faces: owner[f] == p) on its own by propagation into `L`,
/// marking its faces in `visited` and listing its vertices in `touched` (each marked in
/// `placed`). False with `out` set when a vertex leaves the range of double precision.
bool lay_out_patch(const Topology& t, std::span<const double> l, Index p, Index s, std::span<const Index> owner,
                   std::span<std::uint8_t> visited, Positions& L, std::vector<std::uint8_t>& placed,
                   std::vector<Index>& touched, std::vector<Index>& pq, Layout& out) {
  const Index s0 = t.corner_vertex[3 * s], s1 = t.corner_vertex[3 * s + 1], s2 = t.corner_vertex[3 * s + 2];
  L.place_seed(s0, s1, s2, l[t.corner_edge[3 * s]], l[t.corner_edge[3 * s + 1]], l[t.corner_edge[3 * s + 2]]);
  touched.assign({s0, s1, s2});
  placed[s0] = placed[s1] = placed[s2] = 1;
  pq.assign({s});
  visited[s] = 1;
  for (std::size_t h = 0; h < pq.size(); ++h) {
    const Index f = pq[h];
    for (int c = 0; c < 3; ++c) {
      const Index o = t.opposite[3 * f + c];
      if (o == kInvalid || owner[corner_face(o)] != p || visited[corner_face(o)]) continue;
      const Index nb = corner_face(o);
      visited[nb] = 1;
      pq.push_back(nb);
      if (placed[t.corner_vertex[o]]) continue;
      const Index v = L.place_corner(t, l, o);
      placed[v] = 1;
      touched.push_back(v);
      if (!L.finite(v)) {
        out.status = Status::NumericalFailure;
        out.element = Element::Vertex;
        out.element_index = v;
        out.message = "vertex " + std::to_string(v) + " left the range of double precision in the layout of patch " +
                      std::to_string(p);
        return false;
      }
    }
  }
  return true;
}

/// Copies grouped by vertex: copies[order[first[v] … first[v+1])] are vertex v's.
struct CopiesByVertex {
  std::vector<Index> first, order;
};

template <typename Copy>
CopiesByVertex group_copies(const std::vector<Copy>& copies, Index nv) {
  CopiesByVertex out;
  out.first.assign(static_cast<std::size_t>(nv) + 1, 0);
  for (const Copy& c : copies) ++out.first[c.vertex + 1];
  for (Index v = 0; v < nv; ++v) out.first[v + 1] += out.first[v];
  out.order.resize(copies.size());
  std::vector<Index> fill(out.first.begin(), out.first.end() - 1);
  for (Index c = 0; c < static_cast<Index>(copies.size()); ++c) out.order[fill[copies[c].vertex]++] = c;
  return out;
}

/// Mean length of the edges at each vertex.
std::vector<double> mean_edge_at_vertex(const Topology& t, std::span<const double> l) {
  std::vector<double> h(static_cast<std::size_t>(t.num_vertices), 0.0);
  std::vector<int> hn(static_cast<std::size_t>(t.num_vertices), 0);
  for (Index e = 0; e < t.num_edges; ++e)
    for (Index v : {t.edge_vertices[2 * e], t.edge_vertices[2 * e + 1]}) {
      h[v] += l[e];
      ++hn[v];
    }
  for (Index v = 0; v < t.num_vertices; ++v) h[v] /= std::max(1, hn[v]);
  return h;
}

/// Solves a joint fit of patch maps (E, H, S); returns Ceres' iteration count. The closed-form
/// starts leave only a small, nearly linear correction: two or three steps reach the seams'
/// rounding noise, where the cost moves by parts per thousand from step to step.
int solve_patch_fit(ceres::Problem& problem) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = 50;
  so.function_tolerance = 1e-3;
  so.gradient_tolerance = 1e-30;
  so.parameter_tolerance = 1e-20;
  so.logging_type = ceres::SILENT;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  detail::quiet_solve(so, &problem, &summary);
  return static_cast<int>(summary.iterations.size());
}

/// The joint Ceres fit of the patch maps' corrections `delta` over every vertex two patches
/// share (patch `fixed` held), the seam residual being the relative distance of the two copies.
/// Returns Ceres' iteration count, or −1 when there is nothing to fit (one patch, or no seam).
int fit_patch_maps(Geometry g, const std::vector<PatchCopy>& copies, const CopiesByVertex& by,
                   const std::vector<PatchMap>& maps, std::span<const double> h, std::span<const double> x, Index fixed,
                   std::vector<std::array<double, 3>>& delta) {
  ceres::Problem::Options popts;
  ceres::Problem problem(popts);
  Index seams = 0;
  const auto nv = static_cast<Index>(by.first.size()) - 1;
  for (Index v = 0; v < nv; ++v) {
    if (by.first[v + 1] - by.first[v] < 2) continue;
    const PatchCopy& a = copies[by.order[by.first[v]]];
    double frame = 1;
    if (g == Geometry::Hyperbolic) frame = 2 / (1 - std::norm(Cx(x[2 * v], x[2 * v + 1])));
    for (Index j = by.first[v] + 1; j < by.first[v + 1]; ++j) {
      const PatchCopy& b = copies[by.order[j]];
      auto* cost = new ceres::AutoDiffCostFunction<SeamResidual, 2, 3, 3>(
          new SeamResidual{&maps[a.patch], &maps[b.patch], a.z, b.z, frame / h[v]});
      problem.AddResidualBlock(cost, nullptr, delta[a.patch].data(), delta[b.patch].data());
      ++seams;
    }
  }
  if (maps.size() < 2 || seams == 0) return -1;
  if (problem.HasParameterBlock(delta[fixed].data())) problem.SetParameterBlockConstant(delta[fixed].data());
  return solve_patch_fit(problem);
}

/// Each vertex at the mean of its mapped copies (H: on the hyperboloid); returns the seam error,
/// the largest distance of a copy from that mean relative to the vertex's mean edge length.
double average_copies(Geometry g, const std::vector<PatchCopy>& copies, const CopiesByVertex& by,
                      const std::vector<PatchMap>& maps, const std::vector<std::array<double, 3>>& delta,
                      std::span<const double> h, std::vector<double>& x) {
  double seam_error = 0;
  std::vector<Cx> w;
  const auto nv = static_cast<Index>(by.first.size()) - 1;
  for (Index v = 0; v < nv; ++v) {
    const Index n = by.first[v + 1] - by.first[v];
    if (n == 0) continue;
    w.clear();
    for (Index j = by.first[v]; j < by.first[v + 1]; ++j) {
      const PatchCopy& c = copies[by.order[j]];
      w.push_back(maps[c.patch].map(delta[c.patch].data(), c.z));
    }
    Cx mean(0, 0);
    if (g == Geometry::Euclidean) {
      for (const Cx& z : w) mean += z;
      mean /= static_cast<double>(n);
    } else {
      // A copy mapped onto the unit circle or beyond has no hyperboloid point: the mean is that of
      // the others (disk_distance() then puts it infinitely far), or that copy when none is inside.
      V3 S{0, 0, 0};
      bool inside = false;
      for (const Cx& z : w) {
        if (!(std::abs(z) < 1)) continue;
        const V3 X = hyperboloid(z);
        for (int dd = 0; dd < 3; ++dd) S[dd] += X[dd];
        inside = true;
      }
      mean = inside ? poincare(S) : w.front();
    }
    for (const Cx& z : w) {
      const double dist = g == Geometry::Euclidean ? std::abs(z - mean) : disk_distance(z, mean);
      seam_error = std::max(seam_error, h[v] > 0 ? dist / h[v] : dist);
    }
    x[2 * v] = mean.real();
    x[2 * v + 1] = mean.imag();
  }
  return seam_error;
}

/// Lays out every patch of `parts` by its own propagation, in parallel (each thread with its own
/// buffers of `dims` coordinates per vertex), and hands each to `take(p, L, touched)`: patch p's
/// positions and its vertices. False with `out` set when a patch's propagation left double range.
template <typename Take>
bool lay_out_each_patch(const Topology& t, Geometry g, int dims, std::span<const double> l, const Patches& parts,
                        Layout& out, Take&& take) {
  const Index nv = t.num_vertices;
  const Index np = static_cast<Index>(parts.seeds.size());
  std::vector<Layout> failures(static_cast<std::size_t>(np));
  std::vector<std::uint8_t> visited(static_cast<std::size_t>(t.num_faces), 0);
#pragma omp parallel
  {
    std::vector<double> lx(static_cast<std::size_t>(nv) * static_cast<std::size_t>(dims), 0.0);
    std::vector<std::uint8_t> placed(static_cast<std::size_t>(nv), 0);
    std::vector<Index> touched, pq;
    Positions L{g, dims, lx};
#pragma omp for schedule(dynamic, 1)
    for (Index p = 0; p < np; ++p) {
      if (lay_out_patch(t, l, p, parts.seeds[p], parts.owner, visited, L, placed, touched, pq, failures[p]))
        take(p, static_cast<const Positions&>(L), std::span<const Index>(touched));
      for (Index v : touched) placed[v] = 0;
    }
  }
  for (const Layout& f : failures)
    if (f.status == Status::NumericalFailure) {
      out.status = f.status;
      out.element = f.element;
      out.element_index = f.element_index;
      out.message = f.message;
      return false;
    }
  return true;
}

/// Divide and conquer (LayoutOptions::patches): the faces are split into `count` patches
/// (partition_faces()); each patch is laid out on its own by the same propagation from its seed,
/// in a frame of its own (lay_out_patch()); each patch's isometry into the common frame starts
/// from the closed-form fit to the current positions `x` (start_patch_map()) and all of them are
/// then fitted jointly by Ceres over every vertex two patches share, the seed's patch fixed
/// (fit_patch_maps()). Each vertex ends at the mean of its copies (average_copies()). Returns
/// false with `out` set on a failed patch propagation.
bool lay_out_patches(const Topology& t, Geometry g, std::span<const double> l, Index seed, int count,
                     std::vector<double>& x, Layout& out) {
  const Index nv = t.num_vertices, nf = t.num_faces;
  Patches parts = partition_faces(t, seed, std::min<Index>(count, nf));
  const std::vector<Index>& owner = parts.owner;
  const Index np = static_cast<Index>(parts.seeds.size());
  // The patches are laid out in parallel, each in a frame of its own; their copies are gathered in
  // patch order, so the result does not depend on the threads.
  std::vector<std::vector<PatchCopy>> patch_copies(static_cast<std::size_t>(np));
  std::vector<PatchMap> maps(static_cast<std::size_t>(np));
  const bool laid = lay_out_each_patch(t, g, 2, l, parts, out,
                                       [&](Index p, const Positions& L, std::span<const Index> touched) {
                                         start_patch_map(g, L, x, touched, maps[p]);
                                         for (Index v : touched) patch_copies[p].push_back({p, v, L.z(v)});
                                       });
  if (!laid) return false;
  std::vector<PatchCopy> copies;
  for (const std::vector<PatchCopy>& pc : patch_copies) copies.insert(copies.end(), pc.begin(), pc.end());
  const CopiesByVertex by = group_copies(copies, nv);
  const std::vector<double> h = mean_edge_at_vertex(t, l);
  std::vector<std::array<double, 3>> delta(static_cast<std::size_t>(np), std::array<double, 3>{0, 0, 0});
  const int iterations = fit_patch_maps(g, copies, by, maps, h, x, owner[seed], delta);
  if (iterations >= 0) out.patch_fit_iterations = iterations;
  out.patches = static_cast<int>(np);
  out.patch_seam_error = average_copies(g, copies, by, maps, delta, h, x);
  return true;
}

// ---- divide and conquer on the sphere -------------------------------------------------------

/// One vertex of one patch on the sphere: its position in the patch's propagation turned by the
/// patch's starting rotation (so that the fit only corrects it).
struct SphereCopy {
  Index patch, vertex;
  V3 y;
};

/// A vertex two patches share on the sphere: both copies, each turned by its patch's correction
/// (an angle-axis vector), must agree.
struct SphereSeamResidual {
  V3 a, b;
  double weight;  // 1/(the vertex's mean edge length)
  template <typename T>
  bool operator()(const T* da, const T* db, T* residual) const {
    const T ya[3] = {T(a[0]), T(a[1]), T(a[2])}, yb[3] = {T(b[0]), T(b[1]), T(b[2])};
    T pa[3], pb[3];
    ceres::AngleAxisRotatePoint(da, ya, pa);
    ceres::AngleAxisRotatePoint(db, yb, pb);
    for (int k = 0; k < 3; ++k) residual[k] = T(weight) * (pa[k] - pb[k]);
    return true;
  }
};

/// The rotation taking the unit vectors L(v) onto X(v) best in least squares over `touched`
/// (Kabsch: from the SVD of Σ L Xᵀ, a proper rotation).
Eigen::Matrix3d kabsch_rotation(const Positions& L, const Positions& X, std::span<const Index> touched) {
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (Index v : touched) {
    const V3 a = L.p(v), b = X.p(v);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) H(i, j) += a[i] * b[j];
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixV() * D * svd.matrixU().transpose();
}

/// Divide and conquer on the sphere, as lay_out_patches() in the plane and the disk: the patches
/// of partition_faces() each laid out by its own propagation on the unit sphere (in parallel),
/// each turned onto the current positions `x` (3 per vertex) by the best rotation (Kabsch), the
/// rotations then corrected jointly by Ceres over every vertex two patches share (the seed's
/// patch held), and every vertex put at the normalised mean of its copies. The sphere's
/// isometries are its rotations, so the patches fit exactly as they do in E and H.
bool lay_out_sphere_patches(const Topology& t, std::span<const double> l, Index seed, int count,
                            std::vector<double>& x, Layout& out) {
  const Geometry g = Geometry::Spherical;
  const Index nv = t.num_vertices, nf = t.num_faces;
  Patches parts = partition_faces(t, seed, std::min<Index>(count, nf));
  const std::vector<Index>& owner = parts.owner;
  const Index np = static_cast<Index>(parts.seeds.size());
  std::vector<std::vector<SphereCopy>> patch_copies(static_cast<std::size_t>(np));
  const Positions X{g, 3, x};
  const bool laid = lay_out_each_patch(t, g, 3, l, parts, out,
                                       [&](Index p, const Positions& L, std::span<const Index> touched) {
                                         const Eigen::Matrix3d R = kabsch_rotation(L, X, touched);
                                         for (Index v : touched) {
                                           const V3 a = L.p(v);
                                           const Eigen::Vector3d y = R * Eigen::Vector3d(a[0], a[1], a[2]);
                                           patch_copies[p].push_back({p, v, V3{y[0], y[1], y[2]}});
                                         }
                                       });
  if (!laid) return false;
  std::vector<SphereCopy> copies;
  for (const std::vector<SphereCopy>& pc : patch_copies) copies.insert(copies.end(), pc.begin(), pc.end());
  const CopiesByVertex by = group_copies(copies, nv);
  const std::vector<Index>&first = by.first, &order = by.order;
  const std::vector<double> h = mean_edge_at_vertex(t, l);
  std::vector<std::array<double, 3>> delta(static_cast<std::size_t>(np), std::array<double, 3>{0, 0, 0});
  {
    ceres::Problem problem;
    Index seams = 0;
    for (Index v = 0; v < nv; ++v) {
      if (first[v + 1] - first[v] < 2) continue;
      const SphereCopy& a = copies[order[first[v]]];
      for (Index j = first[v] + 1; j < first[v + 1]; ++j) {
        const SphereCopy& b = copies[order[j]];
        auto* cost = new ceres::AutoDiffCostFunction<SphereSeamResidual, 3, 3, 3>(
            new SphereSeamResidual{a.y, b.y, h[v] > 0 ? 1 / h[v] : 1.0});
        problem.AddResidualBlock(cost, nullptr, delta[a.patch].data(), delta[b.patch].data());
        ++seams;
      }
    }
    if (np >= 2 && seams > 0) {
      const Index fixed = owner[seed];
      if (problem.HasParameterBlock(delta[fixed].data())) problem.SetParameterBlockConstant(delta[fixed].data());
      out.patch_fit_iterations = solve_patch_fit(problem);
    }
  }
  // Every vertex at the normalised mean of its turned copies; the seam error as in E and H.
  double seam_error = 0;
  std::vector<V3> w;
  for (Index v = 0; v < nv; ++v) {
    if (first[v + 1] == first[v]) continue;
    w.clear();
    V3 mean{0, 0, 0};
    for (Index j = first[v]; j < first[v + 1]; ++j) {
      const SphereCopy& c = copies[order[j]];
      V3 q;
      ceres::AngleAxisRotatePoint(delta[c.patch].data(), c.y.data(), q.data());
      w.push_back(q);
      for (int d = 0; d < 3; ++d) mean[d] += q[d];
    }
    mean = normalized(mean);
    for (const V3& q : w) {
      const double dist = sphere_distance(q, mean);
      seam_error = std::max(seam_error, h[v] > 0 ? dist / h[v] : dist);
    }
    for (int d = 0; d < 3; ++d) x[3 * static_cast<std::size_t>(v) + d] = mean[d];
  }
  out.patches = static_cast<int>(np);
  out.patch_seam_error = seam_error;
  return true;
}

// ---- the propagation -----------------------------------------------------------------------

// The costs of the propagation's cheapest-first order.
// Each face costs 1 plus how badly it conditions the vertex it places: −log sin of its smallest
// angle (0.14 for an equilateral face, about 14 for an angle of 1e-6). The propagation develops
// the faces cheapest-first from the seed (Dijkstra over the dual graph; breadth-first on
// well-shaped meshes), so a vertex is placed from a sliver only when no better-shaped way of
// similar depth reaches it: the angles a placement turns by are read from lengths, and the
// error of a sliver's angles carries into every vertex placed after it. H keeps every face at
// cost 1 (breadth-first): Poincaré coordinates lose precision as e^r away from the origin, and
// the shortest chains from the central seed matter more there than the faces' shapes.
// In every geometry, placing a vertex whose own angle is tiny costs −log sin of that angle more:
// it lies where two circles meet at that angle, so the errors of the two vertices it is placed
// from grow by 1/sin θ (the far vertex of a needle placed from its short side: by l/s). The same
// needle entered so that it places an end of its short side costs nothing extra (that end is
// placed at distance s along an angle known to about ε·l/s: an error of about ε·l). An angle whose
// sine is above kIllPlaced adds nothing, so well-shaped meshes keep their order.
struct PropagationCosts {
  std::vector<double> entering;  // #F×3: the cost of entering corner_face(o) so that it places the vertex of o
  std::vector<Cx> turns;         // E, H: #F×3, e^{iθ} of each corner
  double most = 1;               // the largest of them

  PropagationCosts(Geometry g, std::span<const double> theta) {
    const Index nf = static_cast<Index>(theta.size() / 3);
    entering.resize(theta.size());
    if (g != Geometry::Spherical) turns.resize(theta.size());
    double top = 1;
#pragma omp parallel for schedule(static) reduction(max : top)
    for (Index f = 0; f < nf; ++f) {
      double sn[3];
      for (int k = 0; k < 3; ++k) {
        if (g == Geometry::Spherical) {
          sn[k] = std::sin(theta[3 * f + k]);
        } else {
          turns[3 * f + k] = std::polar(1.0, theta[3 * f + k]);
          sn[k] = turns[3 * f + k].imag();
        }
      }
      const double smallest = std::min({theta[3 * f], theta[3 * f + 1], theta[3 * f + 2]});
      const double face = g == Geometry::Hyperbolic ? 1.0 : 1 - std::log(std::max(std::sin(smallest), 1e-300));
      for (int k = 0; k < 3; ++k) {
        const double c = face + (sn[k] < kIllPlaced ? -std::log(std::max(sn[k], 1e-300)) : 0.0);
        entering[3 * f + k] = c;
        top = std::max(top, c);
      }
    }
    most = top;
  }
};

/// One face-by-face development of a disk (or a closed genus-0 surface) from a seed face whose
/// vertices are placed already: each face taken places the vertex opposite the edge it was
/// reached across, when that vertex has no position yet.
///
/// The order is cheapest-first by Dial's buckets: every entering cost is at least 1, so a face
/// taken from the bucket of costs [k, k+1) reaches only later buckets, and the costs reached are
/// exactly Dijkstra's; within a bucket faces come out first in first out. With all costs 1 (H)
/// the buckets are the breadth-first levels. The buckets form a ring longer than the largest
/// entering cost, so the work is linear in the faces.
///
/// E and H carry each face's orientation along the tree of faces taken: the direction of its
/// side from corner 0 to corner 1 at corner 0's vertex, a unit complex number, is its parent's
/// turned by the two faces' angles (side directions e^{i(π − θ₁)}, e^{i(π + θ₀)} within a face,
/// reversed across the shared edge) and, in H, by the rotation between the disk isometries that
/// move the two vertices to the origin (transport(): a smooth function of the points); the new
/// vertex is its edge's first end plus the edge's length (H: tanh of half of it, moved there by
/// the isometry) in that direction. Differences of positions never set a direction: placing a
/// vertex from the measured direction of its two placed neighbours (trilateration, S here) turns
/// every later face by their accumulated misplacement over one edge length, an error that grows
/// geometrically with the depth (×10 per ~55 faces on a 425k-face E disk: 1.5e-8 at depth 260),
/// where this one grows only as the rounding of the turns adds up (4e-11 there). The positions
/// are double-double (Positions::lo) while the faces are developed, so far-out neighbours keep
/// their digits.
class Propagation {
 public:
  Propagation(const Topology& t, Geometry g, std::span<const double> l, std::span<const double> theta, Index seed,
              bool keep_going)
      : t_(t), g_(g), l_(l), seed_(seed), keep_going_(keep_going), costs_(g, theta) {
    const auto nv = static_cast<std::size_t>(t.num_vertices), nf = static_cast<std::size_t>(t.num_faces);
    placed_.resize(nv);
    taken_.resize(nf);
    places_.resize(nf);
    restart_.resize(nf);
    order_.reserve(nf);
    depth_.resize(nf);
    reached_.resize(nf);
    via_.resize(nf);
    if (g != Geometry::Spherical) side_.resize(nf);
    if (g == Geometry::Hyperbolic) {
      origin_.resize(nf);
      half_tanh_.resize(l.size());
#pragma omp parallel for schedule(static)
      for (std::size_t e = 0; e < l.size(); ++e) half_tanh_[e] = std::tanh(l[e] / 2);
    }
    buckets_.resize(static_cast<std::size_t>(costs_.most) + 2);
  }

  /// Develops every face reachable from the seed into P; false with `out` naming the vertex when
  /// a position leaves double range. out.depth: the most faces between the seed and a face.
  ///
  /// Two passes: order() takes the faces bucket by bucket as above and decides, without any
  /// geometry, which face places which vertex; then the buckets are developed one after the
  /// other, each bucket's faces in parallel. A face's development reads only its parent's frame
  /// and vertices placed by earlier buckets (every entering cost is at least 1, so a parent lies
  /// in an earlier bucket than its children), and writes only its own frame and the vertex it
  /// places: the result is the sequential one, on any number of threads.
  bool run(Positions& P, Layout& out) {
    const Topology& t = t_;
    // Double-double positions while the faces are developed (the seed's as placed, low parts 0);
    // P keeps the rounded ones.
    low_.assign(P.x.size(), 0.0);
    P.lo = low_.data();
    struct Plain {
      Positions& P;
      ~Plain() { P.lo = nullptr; }
    } plain{P};
    if (g_ != Geometry::Spherical) {
      // The seed's side 0 → 1 at its corner 0 (H: z1 moved by the isometry taking z0 to 0).
      const Index a = t.corner_vertex[3 * seed_], b = t.corner_vertex[3 * seed_ + 1];
      Cx d = P.z(b) - P.z(a);
      if (g_ == Geometry::Hyperbolic) d = disk_quotient(d, P.disk_gap(a, d));
      side_[seed_] = std::abs(d) > 0 ? d / std::abs(d) : Cx(1, 0);
      if (g_ == Geometry::Hyperbolic) origin_[seed_] = Point::at(P, a);
    }
    order(out);
    out.unresolved_vertices = 0;
    const auto levels = static_cast<std::int64_t>(level_start_.size()) - 1;
    for (std::int64_t k = 0; k < levels; ++k) {
      const std::int64_t a = level_start_[k], b = level_start_[k + 1];
      std::int64_t failed = b;  // the first face (in the order) whose vertex left double range
      Index unresolved = 0;
#pragma omp parallel for schedule(static) reduction(min : failed) reduction(+ : unresolved) if (b - a > kParallelLevel)
      for (std::int64_t i = a; i < b; ++i) {
        if (i + static_cast<std::int64_t>(kAhead) < b) prefetch_develop(P, order_[i + kAhead]);
        const Index f = order_[i];
        if (via_[f] == kInvalid) continue;
        const int r = develop(P, f);
        if (r < 0) failed = std::min(failed, i);
        else unresolved += r;
      }
      out.unresolved_vertices += unresolved;
      if (failed < b) return fail(out, via_[order_[failed]]);
      // H frames beyond the disk's resolution restart at corner 0's stored position, read once
      // the bucket has placed its vertices.
      if (g_ != Geometry::Hyperbolic) continue;
      for (std::int64_t i = a; i < b; ++i) {
        const Index f = order_[i];
        if (!restart_[f]) continue;
        origin_[f] = Point::at(P, t.corner_vertex[3 * f]);
        side_[f] = Cx(1, 0);
      }
    }
    return true;
  }

  /// The first pass of run(): the faces in Dial's order (order_, a bucket per level_start_
  /// range), each face's parent corner (via_) and depth, and whether it places the vertex of
  /// that corner (places_: the first face in the order to reach it).
  void order(Layout& out) {
    const Topology& t = t_;
    std::fill(placed_.begin(), placed_.end(), std::uint8_t{0});
    std::fill(taken_.begin(), taken_.end(), std::uint8_t{0});
    std::fill(reached_.begin(), reached_.end(), kInf);
    for (int k = 0; k < 3; ++k) placed_[t.corner_vertex[3 * seed_ + k]] = 1;
    order_.clear();
    level_start_.assign(1, 0);
    depth_[seed_] = 0;
    reached_[seed_] = 0;
    via_[seed_] = kInvalid;
    places_[seed_] = 0;
    restart_[seed_] = 0;
    out.depth = 0;
    const std::size_t ring = buckets_.size();
    for (auto& b : buckets_) b.clear();
    buckets_[0].emplace_back(0.0, seed_);
    std::size_t pending = 1;
    for (std::uint64_t current = 0; pending > 0; ++current) {
      std::vector<std::pair<double, Index>>& bucket = buckets_[current % ring];
      for (std::size_t i = 0; i < bucket.size(); ++i) {
        if (i + 2 * kAhead < bucket.size()) prefetch_face(bucket[i + 2 * kAhead].second);
        if (i + kAhead < bucket.size()) prefetch_around(bucket[i + kAhead].second);
        const auto [cost, f] = bucket[i];
        if (taken_[f] || cost > reached_[f]) continue;
        taken_[f] = 1;
        order_.push_back(f);
        out.depth = std::max(out.depth, depth_[f]);
        if (via_[f] != kInvalid) {
          std::uint8_t& placed = placed_[t.corner_vertex[via_[f]]];
          places_[f] = placed ? 0 : 1;
          placed = 1;
        }
        restart_[f] = 0;
        for (int k = 0; k < 3; ++k) {
          const Index o = t.opposite[3 * f + k];
          if (o == kInvalid) continue;
          const Index nb = corner_face(o);
          const double c = cost + costs_.entering[o];
          if (taken_[nb] || !(c < reached_[nb])) continue;
          reached_[nb] = c;
          via_[nb] = o;
          depth_[nb] = depth_[f] + 1;
          buckets_[static_cast<std::uint64_t>(c) % ring].emplace_back(c, nb);
          ++pending;
        }
      }
      pending -= bucket.size();
      bucket.clear();
      if (static_cast<std::int64_t>(order_.size()) > level_start_.back())
        level_start_.push_back(static_cast<std::int64_t>(order_.size()));
    }
  }

  // Both passes are bound by the latency of their scattered reads (a face's neighbours, their
  // vertices and lengths lie anywhere in the arrays): the order fetches the faces kAhead and
  // 2·kAhead places ahead in the bucket in two steps, first their own corners, then what those
  // index; the development fetches what the face kAhead places ahead reads.
  static constexpr std::size_t kAhead = 8;
  // Buckets of at most this many faces are developed on one thread.
  static constexpr std::int64_t kParallelLevel = 512;
  void prefetch_face(Index f) const {
    __builtin_prefetch(&t_.opposite[3 * f]);
    __builtin_prefetch(&t_.corner_vertex[3 * f]);
    __builtin_prefetch(&via_[f]);
  }
  void prefetch_around(Index f) const {
    for (int k = 0; k < 3; ++k) {
      const Index o = t_.opposite[3 * f + k];
      if (o != kInvalid) {
        __builtin_prefetch(&costs_.entering[o]);
        __builtin_prefetch(&taken_[corner_face(o)]);
        __builtin_prefetch(&reached_[corner_face(o)]);
      }
    }
    const Index o = via_[f];
    if (o != kInvalid) __builtin_prefetch(&placed_[t_.corner_vertex[o]]);
  }
  void prefetch_develop(const Positions& P, Index f) const {
    const Index o = via_[f];
    if (o == kInvalid) return;
    const Index pf = corner_face(t_.opposite[o]);
    if (g_ != Geometry::Spherical) {
      __builtin_prefetch(&costs_.turns[3 * f]);
      __builtin_prefetch(&costs_.turns[3 * pf]);
      __builtin_prefetch(&side_[pf]);
    }
    if (g_ == Geometry::Hyperbolic) __builtin_prefetch(&origin_[pf]);
    for (int k = 0; k < 3; ++k) {
      const Index v = t_.corner_vertex[3 * f + k];
      __builtin_prefetch(&P.x[static_cast<std::size_t>(P.dims) * v]);
      __builtin_prefetch(&low_[static_cast<std::size_t>(P.dims) * v]);
      if (g_ == Geometry::Hyperbolic) __builtin_prefetch(&half_tanh_[t_.corner_edge[3 * f + k]]);
      else __builtin_prefetch(&l_[t_.corner_edge[3 * f + k]]);
    }
  }

  /// H, after run(): moves the positions by the disk map m, in double-double (P keeps the rounded
  /// ones; the low parts stay here).
  void move(Positions& P, const DiskMap& m) {
    using detail::dd::Real;
    const Real cr{m.c.real()}, ci{m.c.imag()}, rr{m.rot.real()}, ri{m.rot.imag()}, one{1};
    std::vector<double>& x = P.x;
#pragma omp parallel for schedule(static)
    for (Index v = 0; v < t_.num_vertices; ++v) {
      const std::size_t i = 2 * static_cast<std::size_t>(v);
      const Real zr{x[i], low_[i]}, zi{x[i + 1], low_[i + 1]};
      const Real nr = zr - cr, ni = zi - ci;                      // z − c
      const Real dr = one - (cr * zr + ci * zi), di = ci * zr - cr * zi;  // 1 − c̄z
      const Real n2 = dr * dr + di * di;
      const Real qr = (nr * dr + ni * di) / n2, qi = (ni * dr - nr * di) / n2;
      const Real wr = rr * qr - ri * qi, wi = rr * qi + ri * qr;
      x[i] = wr.h;
      low_[i] = wr.l;
      x[i + 1] = wi.h;
      low_[i + 1] = wi.l;
    }
  }

  /// Vertices that no face placed (none on a connected mesh).
  Index unplaced() const {
    return static_cast<Index>(std::count(placed_.begin(), placed_.end(), std::uint8_t{0}));
  }

 private:
  /// e^{iθ} of corner c.
  Cx turn(Index c) const { return costs_.turns[c]; }
  /// E: the direction of taken face f's side from corner c to corner c + 1 at corner c's
  /// vertex: side_[f] turned by f's angles.
  Cx side_at(Index f, int c) const {
    const Cx w = side_[f];
    if (c == 0) return w;
    return c == 1 ? -w * std::conj(turn(3 * f + 1)) : -w * turn(3 * f);
  }
  /// Face f, reached across the edge opposite its corner o = via_[f] from face pf (taken before
  /// it, where that edge runs from corner k + 1 at vertex a to k + 2 at b): places the vertex of o
  /// (E: from b along b → a turned by the angle at b; H: develop_frame(); S: from both ends'
  /// positions) and sets side_[f] from the direction of b → a at b, f's side j + 1 → j + 2.
  int develop(Positions& P, Index f) {
    const Index o = via_[f];
    if (g_ == Geometry::Spherical) return places_[f] ? accept(P, o, P.place_corner(t_, l_, o)) : 0;
    if (g_ == Geometry::Hyperbolic) return develop_frame(P, f);
    const Index po = t_.opposite[o], pf = corner_face(po);
    const int k = static_cast<int>(po % 3), j = static_cast<int>(o % 3), c = (j + 1) % 3;
    const Index b = t_.corner_vertex[prev_corner(po)];
    const Cx at_b = -side_at(pf, (k + 1) % 3);
    int unresolved = 0;
    if (places_[f]) {
      const Cx step = at_b * turn(next_corner(o)) * l_[t_.corner_edge[prev_corner(o)]];
      const double offset[2] = {step.real(), step.imag()};
      P.set_offset(t_.corner_vertex[o], b, offset);
      unresolved = accept(P, o, t_.corner_vertex[o]);
      if (unresolved < 0) return unresolved;
    }
    // side_at(f, c) = at_b: undo its turns.
    Cx w = at_b;
    if (c != 0) w = c == 1 ? -at_b * turn(3 * f + 1) : -at_b * std::conj(turn(3 * f));
    const double n = std::abs(w);
    side_[f] = n > 0 && std::isfinite(n) ? w / n : Cx(1, 0);
    return unresolved;
  }
  /// H: a point of the disk in double-double (x = xh + xl, y = yh + yl).
  struct Point {
    double xh = 0, xl = 0, yh = 0, yl = 0;
    static Point at(const Positions& P, Index v) {
      const std::size_t i = 2 * static_cast<std::size_t>(v);
      return {P.x[i], P.lo[i], P.x[i + 1], P.lo[i + 1]};
    }
    /// Stores the point as vertex v's position (both parts).
    void store(Positions& P, Index v) const {
      const std::size_t i = 2 * static_cast<std::size_t>(v);
      P.x[i] = xh;
      P.lo[i] = xl;
      P.x[i + 1] = yh;
      P.lo[i + 1] = yl;
    }
    Cx z() const { return {xh, yh}; }
    bool inside() const {
      return std::isfinite(xh) && std::isfinite(yh) && detail::dd::one_minus_norm(xh, xl, yh, yl) > 0;
    }
  };
  /// H: the point the disk isometry moving p to the origin takes to `local` (p's offset
  /// local·(1 − |p|²)/(1 + p̄·local), added in double-double), and in *turn the rotation
  /// R = conj(1 + p̄·local)/(1 + p̄·local) by which that isometry's frame at the new point turns
  /// against p's: at the new point, the direction back to p is −R·local/|local|. Both depend on
  /// p and the step alone, not on where the new point was stored.
  static Point step(const Point& p, Cx local, Cx* turn) {
    const double room = detail::dd::one_minus_norm(p.xh, p.xl, p.yh, p.yl);
    const Cx q = 1.0 + std::conj(p.z()) * local;
    const Cx offset = disk_quotient(local * room, q);
    Point r;
    detail::dd::add(p.xh, p.xl, offset.real(), r.xh, r.xl);
    detail::dd::add(p.yh, p.yl, offset.imag(), r.yh, r.yl);
    const double n = std::norm(q);
    *turn = n > 0 ? std::conj(q) * std::conj(q) / n : Cx(1, 0);
    return r;
  }
  /// H: face f's corner c (position, and direction of its side c → c + 1 there) from f's frame
  /// (corner 0's position origin_[f] and side_[f]), one step from corner 0 at most.
  std::pair<Point, Cx> corner_frame(Index f, int c) const {
    const Point& p = origin_[f];
    const Cx w = side_[f];
    if (c == 0) return {p, w};
    Cx r;
    if (c == 1) {  // v1 = v0 + along side 0 → 1; at v1, v1 → v2 is v1 → v0 turned by −θ1
      const Point q = step(p, w * half_tanh_[t_.corner_edge[3 * f + 2]], &r);
      return {q, -r * w * std::conj(turn(3 * f + 1))};
    }
    const Cx d = w * turn(3 * f);  // v0 → v2; at v2 the side 2 → 0 points back to v0
    const Point q = step(p, d * half_tanh_[t_.corner_edge[3 * f + 1]], &r);
    return {q, -r * d};
  }
  /// H: face f reached from pf across the edge opposite corner o = via_[f] (in pf from corner
  /// k + 1 at vertex a to k + 2 at b). pf's frame gives b and the direction of b → a there
  /// (b → the third vertex turned by the angle at b); the vertex of o is one step from b, and f's
  /// frame (corner 0) at most one step from b. Frames come from frames alone: a vertex stored by
  /// another branch of the development never turns this one (positions measured from the
  /// stored ends would feed their errors back, growing by about sinh of the edge length per face
  /// along a chain).
  int develop_frame(Positions& P, Index f) {
    const Index o = via_[f];
    const Index po = t_.opposite[o], pf = corner_face(po);
    const int k = static_cast<int>(po % 3), j = static_cast<int>(o % 3), c = (j + 1) % 3;
    const auto [b, from_b] = corner_frame(pf, (k + 2) % 3);
    const Cx at_b = from_b * turn(3 * pf + (k + 2) % 3);  // b → a
    const Index v = t_.corner_vertex[o];
    Cx r;
    int unresolved = 0;
    if (places_[f]) {
      const Point q = step(b, at_b * turn(next_corner(o)) * half_tanh_[t_.corner_edge[prev_corner(o)]], &r);
      if (q.inside()) q.store(P, v);
      else P.x[2 * v] = kNaN;
      unresolved = accept(P, o, v);
      if (unresolved < 0) return unresolved;
    }
    // f's frame from b, its corner c with side c → c + 1 = b → a.
    Point p0 = b;
    Cx w = at_b;
    if (c == 1) {  // v0 is one step from v1 along v1 → v0 = (v1 → v2) turned by θ1
      const Cx d = at_b * turn(3 * f + 1);
      p0 = step(b, d * half_tanh_[t_.corner_edge[3 * f + 2]], &r);
      w = -r * d;
    } else if (c == 2) {  // v0 is one step from v2 along side 2 → 0; v0 → v1 is v0 → v2 turned by −θ0
      p0 = step(b, at_b * half_tanh_[t_.corner_edge[3 * f + 1]], &r);
      w = -r * at_b * std::conj(turn(3 * f));
    }
    const double n = std::abs(w);
    if (!p0.inside() || !(n > 0) || !std::isfinite(n)) {
      // Beyond the disk's resolution (only with keep_going, the vertices there put aside): the
      // frame restarts at corner 0's stored position (run(), once the bucket is placed), so
      // nothing non-finite spreads.
      restart_[f] = 1;
      return unresolved;
    }
    origin_[f] = p0;
    side_[f] = w / n;
    return unresolved;
  }
  /// Checks vertex v, just placed from corner o: 0 when its position is inside double range;
  /// otherwise −1 (the propagation fails, fail()), or with keep_going 1: it is put on the first
  /// end of the edge it was placed from (finite, and its faces measure as missed) and counted.
  int accept(Positions& P, Index o, Index v) {
    if (P.finite(v)) return 0;
    if (!keep_going_) return -1;
    P.copy(v, t_.corner_vertex[next_corner(o)]);
    return 1;
  }
  /// The failure of the vertex of corner o: out names it; false.
  bool fail(Layout& out, Index o) {
    const Index v = t_.corner_vertex[o];
    out.status = Status::NumericalFailure;
    out.element = Element::Vertex;
    out.element_index = v;
    out.message = "vertex " + std::to_string(v) + " left the range of double precision (" +
                  std::string(g_ == Geometry::Hyperbolic ? "at the boundary of the Poincaré disk" : "not finite") +
                  ") at propagation depth " + std::to_string(depth_[corner_face(o)]);
    return false;
  }

  const Topology& t_;
  Geometry g_;
  std::span<const double> l_;
  Index seed_;
  bool keep_going_;
  PropagationCosts costs_;
  std::vector<Cx> side_;  // E, H: each taken face's direction of its side 0 → 1 at corner 0's vertex
  std::vector<Point> origin_;      // H: each taken face's corner 0, as its frame places it
  std::vector<double> half_tanh_;  // H: tanh(l/2) per edge
  std::vector<std::uint8_t> placed_, taken_;
  std::vector<std::uint8_t> places_;   // the face places the vertex of its corner via_[f]
  std::vector<std::uint8_t> restart_;  // H: the face's frame restarts at corner 0's stored position
  std::vector<Index> depth_, via_;  // via_[f]: the corner of f that the face before it placed
  std::vector<double> reached_;
  std::vector<double> low_;  // the low parts of the positions during run()
  std::vector<std::vector<std::pair<double, Index>>> buckets_;
  std::vector<Index> order_;                // the faces in the order taken
  std::vector<std::int64_t> level_start_;  // bucket k is order_[level_start_[k] .. level_start_[k + 1])
};

// ---- refining the propagation's layout -------------------------------------------------------

/// A refinement's result is kept only when neither its max error nor its max error above the
/// edges' rounding floors rose. Where coordinates cannot resolve some edges (a region that the
/// conformal factor shrinks below what doubles hold far from the origin), the max error is their
/// rounding: lowering it by bending the faces the coordinates do resolve is no gain (random draw
/// 73, a circle domain spanning 1e21: patches developed from the needles' own lengths lowered it
/// from 6.6e18 to 2.1e15 while the error above rounding rose from 0.04 to 2e15, and the atlas's
/// charts then missed their collars by 5.4e3 of an edge).
bool not_worse(const Layout& after, const Layout& before) {
  return after.max_edge_length_error <= before.max_edge_length_error &&
         after.max_error_above_rounding <= before.max_error_above_rounding;
}

/// Gauss–Seidel sweeps (detail::polish_by_sweeps) in rounds of 1, 2, 4, … (at most `budget` in
/// all), measured after each round, while the layout is above `refine_above` over its floors;
/// once started, they go on below it while a round still halves the error above the floor
/// (cheap, and a layout nearer its floor gives the deck group more digits). A round that is not
/// not_worse() is undone and ends the sweeps. Each round sweeps only the vertices near its
/// large errors (kSweepShare, kSweepRings) until one of them lowers the largest error above the
/// floor by less than a quarter or is undone (kLocalGain); the rounds
/// after it sweep every vertex, unless `local_only` (then the sweeps end there). `now` and
/// `edge_errors` describe the positions on return. Returns the sweeps kept.
int sweep_in_rounds(const Topology& t, Geometry g, std::span<const double> l, double refine_above, int budget,
                    bool local_only, Positions& P, Layout& now, EdgeErrors& edge_errors) {
  std::vector<double>& x = P.x;
  bool halving = false, local = true;
  int done = 0;
  std::vector<double> kept;
  std::vector<Index> all;
  detail::SweepOrder all_order;  // the colour classes of `all`, made with it
  auto coarse = [&] { return !(now.max_error_above_rounding <= refine_above); };
  for (int round = 1; done < budget && (coarse() || halving) && (local || !local_only); round *= 2) {
    const int n = std::min(round, budget - done);
    const Layout before = now;
    kept = x;
    if (!local && all.empty()) {
      all.resize(static_cast<std::size_t>(t.num_vertices));
      std::iota(all.begin(), all.end(), Index{0});
      all_order = detail::sweep_order(t, all);
    }
    const std::vector<Index> near =
        local ? vertices_near_errors(t, edge_errors, kSweepShare * now.max_error_above_rounding,
                                     kSweepShare * now.max_edge_length_error, kSweepRings)
              : std::vector<Index>{};
    const std::vector<Index>& only = local ? near : all;
    if (only.empty()) break;
    if (local) detail::polish_by_sweeps(t, g, l, x, n, only);
    else detail::polish_by_sweeps(t, g, l, x, n, all_order);
    remeasure_edges(t, g, l, P, only, edge_errors, now);
    if (!not_worse(now, before)) {
      x.swap(kept);
      now = before;
      if (!local) break;
      local = false;  // undone; every vertex from now on (their edges measured again with it)
      continue;
    }
    done += n;
    halving = now.max_error_above_rounding > 0 &&
              now.max_error_above_rounding <= 0.5 * before.max_error_above_rounding;
    if (local && !(now.max_error_above_rounding <= kLocalGain * before.max_error_above_rounding)) local = false;
  }
  return done;
}

/// Divide and conquer (lay_out_patches(), lay_out_sphere_patches()) from the positions of P with
/// `count` patches, kept when not_worse() than `now` (then `now`, `edge_errors` and the
/// patch figures of `out` describe it). True when kept.
bool refine_by_patches(const Topology& t, Geometry g, std::span<const double> l, Index seed, int count, Positions& P,
                       Layout& now, EdgeErrors& edge_errors, Layout& out) {
  std::vector<double>& x = P.x;
  std::vector<double> kept = x;
  Layout trial, after;
  EdgeErrors after_edges;
  const bool laid = g == Geometry::Spherical ? lay_out_sphere_patches(t, l, seed, count, x, trial)
                                             : lay_out_patches(t, g, l, seed, count, x, trial);
  if (laid) measure_edges(t, g, l, P, after, &after_edges);
  if (trial.patches > 0 && std::isfinite(after.max_edge_length_error) && not_worse(after, now)) {
    out.patches = trial.patches;
    out.patch_fit_iterations = trial.patch_fit_iterations;
    out.patch_seam_error = trial.patch_seam_error;
    now = after;
    std::swap(edge_errors, after_edges);
    return true;
  }
  x.swap(kept);
  return false;
}

/// After the propagation, only while the layout misses its metric by more than
/// options.refine_above above the edges' rounding floors (`now` and each edge's figures
/// `edge_errors`, kept up to date until the sweeps end): with the automatic patch count, first
/// the sweeps near the largest errors (at most kSweepsBeforePatches; sweep_in_rounds()); then,
/// still above it, the divide and conquer (E, H, S; automatic patch count, or always with an
/// explicit count ≥ 2; kept when not_worse(); refine_by_patches()); in E, the layout from
/// the triangles' shapes where the error is above kShapeLayoutAbove (needle triangles placed from
/// short bases can grow an error geometrically along a chain), kept when closer and not_worse(); the Gauss–Seidel
/// sweeps (E, H, S; sweep_in_rounds()); global Gauss–Newton steps (E, H, S; layout_polish.h).
/// A layout that one propagation makes accurate (most meshes up to ~10⁵ faces) is left as it
/// is. E then goes back to its rigid frame (seed corner 0 at the origin, corner 1 on +x) when
/// anything moved it. `now` describes the positions on return.
void refine_layout(const Topology& t, Geometry g, std::span<const double> l, std::span<const double> theta,
                   Index seed, const LayoutOptions& options, Positions& P, Layout& now, EdgeErrors& edge_errors,
                   Layout& out) {
  std::vector<double>& x = P.x;
  const Index s0 = t.corner_vertex[3 * seed], s1 = t.corner_vertex[3 * seed + 1];
  auto coarse = [&] { return !(now.max_error_above_rounding <= options.refine_above); };
  bool moved = false;
  // Automatic: min(32, #F/4000) patches, and one per 10k faces above 320k faces, so that the
  // propagation inside a patch stays about as deep as on a mesh of 10k faces (at most 256).
  const Index by_size = std::max<Index>(std::min<Index>(32, t.num_faces / 4000), t.num_faces / 10000);
  const int automatic = coarse() ? static_cast<int>(std::min<Index>(256, by_size)) : 0;
  if (options.patches < 0 && automatic > 1) {
    // Where the propagation misses only near a few seams, the local sweeps bring it under
    // refine_above for a fraction of the patches' cost; the patches run where they do not.
    const int n = sweep_in_rounds(t, g, l, options.refine_above, std::min(kSweepsBeforePatches, options.polish_sweeps),
                                  true, P, now, edge_errors);
    out.polish_sweeps += n;
    moved = moved || n > 0;
  }
  const int patches = options.patches >= 0 ? options.patches : (coarse() ? automatic : 0);
  if (patches > 1 && refine_by_patches(t, g, l, seed, patches, P, now, edge_errors, out)) moved = true;
  const bool steps = options.polish_steps > 0;
  if (g == Geometry::Euclidean && steps && coarse() && now.max_error_above_rounding > kShapeLayoutAbove) {
    std::vector<double> trial = x;
    if (detail::develop_by_shapes(t, l, theta, s0, s1, trial)) {
      Layout shaped;
      EdgeErrors shaped_edges;
      measure_edges(t, g, l, Positions{g, out.dims, trial}, shaped, &shaped_edges);
      if (shaped.max_edge_length_error < now.max_edge_length_error && not_worse(shaped, now)) {
        x.swap(trial);
        out.shape_solve = true;
        now = shaped;
        std::swap(edge_errors, shaped_edges);
        moved = true;
      }
    }
  }
  const int n = sweep_in_rounds(t, g, l, options.refine_above, options.polish_sweeps - out.polish_sweeps, false, P,
                                now, edge_errors);
  out.polish_sweeps += n;
  moved = moved || n > 0;
  if (steps && coarse()) {
    // Kept only when they lower the error above the edges' rounding floors: the steps weigh
    // every edge by 1/l², so edges that the coordinates cannot resolve (a strip's far end, below
    // what doubles hold there) would otherwise trade the resolved positions for their rounding.
    std::vector<double> kept = x;
    const Layout before = now;
    const int taken = detail::polish_globally(t, g, l, x, options.polish_steps).steps;
    measure_edges(t, g, l, P, now);
    if (taken > 0 && now.max_error_above_rounding < before.max_error_above_rounding) {
      out.polish_steps = taken;
      moved = true;
    } else {
      x.swap(kept);
      now = before;
    }
  }
  if (g == Geometry::Euclidean && moved) {
    const Cx o = P.z(s0), d = P.z(s1) - o;
    const Cx rot = std::abs(d) > 0 ? std::conj(d) / std::abs(d) : Cx(1, 0);
    for (Index v = 0; v < t.num_vertices; ++v) P.set(v, (P.z(v) - o) * rot);
    measure_edges(t, g, l, P, now);
  }
}

/// The normalisation of the geometry (layout.h), the unit box, and the flipped faces; the edge
/// error of the final positions (S with Möbius centring: of the isometric positions before it),
/// starting from `now`, the figures of the positions as refined.
void finish_layout(const Topology& t, Geometry g, std::span<const double> l, const std::vector<double>& area,
                   Index seed, const LayoutOptions& options, const Layout& now, Positions& P, Layout& out) {
  std::vector<double>& x = P.x;
  const Index nv = t.num_vertices;
  out.max_edge_length_error = now.max_edge_length_error;
  out.worst_edge = now.worst_edge;
  out.rounding_floor = now.rounding_floor;
  out.max_error_above_rounding = now.max_error_above_rounding;
  if (options.normalize && g != Geometry::Euclidean) {
    const std::vector<double> w = vertex_weights(t, area);
    if (g == Geometry::Hyperbolic) {
      // An isometry: the error is re-measured on the final positions when they moved.
      if (normalize_hyperbolic(t, P, w, seed, out) > 0) measure_edges(t, g, l, P, out);
    } else {
      normalize_spherical(t, P, w, seed, options.sphere_mobius, out);
      if (!options.sphere_mobius) measure_edges(t, g, l, P, out);
    }
  }
  if (g == Geometry::Euclidean && options.unit_box && nv > 0) {
    double lo[2] = {kInf, kInf}, hi[2] = {-kInf, -kInf};
    for (Index v = 0; v < nv; ++v)
      for (int d = 0; d < 2; ++d) {
        lo[d] = std::min(lo[d], x[2 * v + d]);
        hi[d] = std::max(hi[d], x[2 * v + d]);
      }
    const double extent = std::max(hi[0] - lo[0], hi[1] - lo[1]);
    out.scale = extent > 0 ? 1 / extent : 1;
    for (Index v = 0; v < nv; ++v)
      for (int d = 0; d < 2; ++d) x[2 * v + d] = (x[2 * v + d] - lo[d]) * out.scale;
  }
  Index flipped = 0, first = std::numeric_limits<Index>::max();
#pragma omp parallel for schedule(static) reduction(+ : flipped) reduction(min : first)
  for (Index f = 0; f < t.num_faces; ++f) {
    if (P.orientation(t.corner_vertex[3 * f], t.corner_vertex[3 * f + 1], t.corner_vertex[3 * f + 2]) < 0) {
      first = std::min(first, f);
      ++flipped;
    }
  }
  out.flipped_faces = flipped;
  if (flipped > 0) out.first_flipped_face = first;
}

/// The seed and one propagation over the faces (H: its double-double positions moved into the
/// normalised frame); false with `out` naming the vertex that left double range.
bool propagate(const Topology& t, Geometry g, std::span<const double> l, std::span<const double> theta,
               const std::vector<double>& area, Index seed, const LayoutOptions& options, Positions& P, Layout& out) {
  Propagation propagation(t, g, l, theta, seed, options.keep_unresolved);
  const Index s0 = t.corner_vertex[3 * seed], s1 = t.corner_vertex[3 * seed + 1], s2 = t.corner_vertex[3 * seed + 2];
  P.place_seed(s0, s1, s2, l[t.corner_edge[3 * seed]], l[t.corner_edge[3 * seed + 1]], l[t.corner_edge[3 * seed + 2]]);
  if (!propagation.run(P, out)) return false;
  if (g == Geometry::Hyperbolic && options.normalize) {
    // The normalising disk map applied to the positions as developed, in double-double: every
    // vertex then keeps, in the final frame, the digits its placement gave it (Poincaré
    // coordinates lose precision as 1/(1 − |z|²), so a map applied to rounded positions would
    // cost the far ones digits). Once more when the centre of mass moved noticeably.
    const std::vector<double> w = vertex_weights(t, area);
    for (int pass = 0; pass < 4; ++pass) {
      const DiskMap m = normalizing_map(t, P, w, seed);
      if (m.identity()) break;
      propagation.move(P, m);
      ++out.propagation_passes;
      if (m.moved() < 1e-6) break;
    }
  }
  out.unplaced_vertices = propagation.unplaced();
  return true;
}

/// The development by coarse frames (options.frames; layout_frames.cpp), H repeated in the final
/// frame as propagate() does: the seed's coarse face takes the normalising map, composed.
bool develop_by_frames(const Topology& t, Geometry g, const std::vector<double>& area, Index seed,
                       const LayoutOptions& options, Positions& P, Layout& out) {
  const std::string why = detail::check_frames(t, *options.frames);
  if (!why.empty()) {
    out.status = Status::InvalidArgument;
    out.message = why;
    return false;
  }
  detail::FrameDevelopment dev(t, g, *options.frames, seed, options.keep_unresolved);
  detail::M3 seed_map = dev.seed_map();
  if (!dev.run(P.x, seed_map, out)) return false;
  if (g == Geometry::Hyperbolic && options.normalize) {
    const std::vector<double> w = vertex_weights(t, area);
    for (int pass = 0; pass < 4; ++pass) {
      detail::M3 map{};
      const double moved = normalize_hyperbolic(t, P, w, seed, out, &map);
      seed_map = detail::multiply(map, seed_map);
      if (!dev.run(P.x, seed_map, out)) return false;
      ++out.propagation_passes;
      if (moved < 1e-6) break;
    }
  }
  out.unplaced_vertices = dev.unplaced();
  return true;
}

/// Validation, the seed, one propagation or development by frames, the refinement where it is
/// needed, and the finish (normalisation, unit box, flipped faces).
Layout run_layout(const Topology& t, Geometry g, std::span<const double> l, const LayoutOptions& options,
                  Clock::time_point start) {
  Layout out;
  out.geometry = g;
  out.dims = g == Geometry::Spherical ? 3 : 2;
  if (!check_lengths(t, g, l, out)) return out;
  // The shapes: the caller's (another layout of these lengths), else computed.
  const Index nv = t.num_vertices, nf = t.num_faces;
  std::shared_ptr<const LayoutShapes> shapes = options.shapes;
  if (!shapes || shapes->corner_angles.size() != static_cast<std::size_t>(t.num_corners()) ||
      shapes->face_areas.size() != static_cast<std::size_t>(nf)) {
    auto made = std::make_shared<LayoutShapes>();
    if (!angles_and_areas(t, g, l, made->corner_angles, made->face_areas, out)) return out;
    shapes = std::move(made);
  }
  const std::vector<double>& theta = shapes->corner_angles;
  const std::vector<double>& area = shapes->face_areas;
  const Index seed = options.seed_face >= 0 ? options.seed_face : central_face_of(t);
  out.seed_face = seed;
  std::vector<double> x(static_cast<std::size_t>(nv) * out.dims, 0.0);
  if (g == Geometry::Spherical)
    for (Index v = 0; v < nv; ++v) x[3 * v + 2] = 1;
  Positions P{g, out.dims, x};
  if (options.frames) {
    if (!develop_by_frames(t, g, area, seed, options, P, out)) return out;
    out.by_frames = true;
  } else if (!propagate(t, g, l, theta, area, seed, options, P, out)) {
    return out;
  }
  Layout now;
  EdgeErrors edge_errors;
  measure_edges(t, g, l, P, now, &edge_errors);
  // Vertices put aside (keep_unresolved) are no positions to refine: the refinement's global
  // steps would trade the resolved faces for them.
  if (out.unresolved_vertices == 0) refine_layout(t, g, l, theta, seed, options, P, now, edge_errors, out);
  finish_layout(t, g, l, area, seed, options, now, P, out);
  out.positions = std::move(x);
  out.shapes = std::move(shapes);
  out.status = Status::Ok;
  out.message = "laid out " + std::to_string(nf) + " faces in " + std::string(geometry_name(g)) + " geometry";
  out.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

Layout invalid(const std::string& why, Geometry g) {
  Layout out;
  out.geometry = g;
  out.status = Status::InvalidArgument;
  out.message = why;
  return out;
}

std::string shape(const Topology& t) {
  return "χ = " + std::to_string(t.euler_characteristic()) + ", " + std::to_string(t.num_boundary_loops()) +
         " boundary loops, " + std::to_string(t.num_components) + " components";
}

}  // namespace

// ---------------------------------------------------------------------------------------------

bool LayoutOptions::is_valid(std::string* why) const {
  if (patches < -1 || patches > 256) {
    if (why) *why = "patches must be -1 (automatic) or in 0..256, got " + std::to_string(patches);
    return false;
  }
  if (polish_sweeps < 0 || polish_sweeps > 10000) {
    if (why) *why = "polish_sweeps must be in 0..10000, got " + std::to_string(polish_sweeps);
    return false;
  }
  if (polish_steps < 0 || polish_steps > 20) {
    if (why) *why = "polish_steps must be in 0..20, got " + std::to_string(polish_steps);
    return false;
  }
  if (seed_face < -1) {
    if (why) *why = "seed_face must be -1 (automatic) or a face index, got " + std::to_string(seed_face);
    return false;
  }
  if (!(std::isfinite(refine_above) && refine_above >= 0)) {
    if (why) *why = "refine_above must be a finite number >= 0, got " + num(refine_above);
    return false;
  }
  return true;
}

std::string Layout::brief_report() const {
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "layout: %s, %s, seed face %d, depth %d, max edge-length error %.3g, %d flipped faces, %.3f s",
                std::string(status_name(status)).c_str(), std::string(geometry_name(geometry)).c_str(),
                static_cast<int>(seed_face), static_cast<int>(depth), max_edge_length_error,
                static_cast<int>(flipped_faces), seconds);
  return buf;
}

Layout layout_disk(const Topology& disk, Geometry g, std::span<const double> l, const LayoutOptions& options) {
  const Clock::time_point start = Clock::now();
  std::string why;
  if (!options.is_valid(&why)) return invalid(why, g);
  if (disk.num_faces == 0) return invalid("the mesh has no faces", g);
  if (options.seed_face >= disk.num_faces)
    return invalid("seed face " + std::to_string(options.seed_face) + " is out of range (" +
                       std::to_string(disk.num_faces) + " faces)",
                   g);
  if (disk.num_components != 1 || disk.num_boundary_loops() != 1 || disk.euler_characteristic() != 1)
    return invalid("layout_disk needs a topological disk (χ = 1, one boundary loop, connected); got " + shape(disk), g);
  return run_layout(disk, g, l, options, start);
}

Layout layout_sphere(const Topology& surface, std::span<const double> l, const LayoutOptions& options) {
  const Clock::time_point start = Clock::now();
  const Geometry g = Geometry::Spherical;
  std::string why;
  if (!options.is_valid(&why)) return invalid(why, g);
  if (surface.num_faces == 0) return invalid("the mesh has no faces", g);
  if (options.seed_face >= surface.num_faces)
    return invalid("seed face " + std::to_string(options.seed_face) + " is out of range (" +
                       std::to_string(surface.num_faces) + " faces)",
                   g);
  if (surface.num_components != 1 || !surface.is_closed() || surface.euler_characteristic() != 2)
    return invalid("layout_sphere needs a closed genus-0 surface (χ = 2, no boundary, connected); got " + shape(surface),
                   g);
  return run_layout(surface, g, l, options, start);
}

// ---------------------------------------------------------------------------------------------
// The metric on the refined surface.

namespace {

/// The checks of refined_edge_lengths() and its surface's connectivity (the cut's own, or the
/// input's when the cut added nothing: same faces, same corners, copied rather than built
/// again). False with `r` failed.
bool refined_surface(const CutResult& cut, const Topology& input, Geometry g, std::span<const double> input_lengths,
                     RefinedMetric& r) {
  auto fail = [&](Status s, const std::string& m) {
    r.status = s;
    r.message = m;
    r.l.clear();
    return false;
  };
  if (cut.status != Status::Ok) return fail(Status::InvalidArgument, "the cut did not succeed: " + cut.message);
  const Index nin = cut.num_input_vertices, nadd = cut.num_refined_vertices();
  if (nin != input.num_vertices)
    return fail(Status::InvalidArgument, "the cut has " + std::to_string(nin) + " input vertices, the topology " +
                                             std::to_string(input.num_vertices));
  if (cut.refined_vertex_bary.size() != static_cast<std::size_t>(nadd) * 3 ||
      cut.refined_vertex_corners.size() != static_cast<std::size_t>(nadd) * 3 ||
      cut.surface_face_to_input.size() * 3 != cut.surface_faces.size())
    return fail(Status::InvalidArgument, "the cut's refinement records have inconsistent sizes");
  if (!check_lengths(input, g, input_lengths, r)) {
    r.l.clear();
    return false;
  }
  if (is_topology_of(cut.surface_topology, cut.surface_faces, nin + nadd)) {
    r.surface = cut.surface_topology;
  } else if (is_topology_of(input, cut.surface_faces, nin + nadd)) {
    r.surface = input;
  } else {
    TopologyResult st = build_topology(cut.surface_faces, nin + nadd);
    if (st.status != Status::Ok)
      return fail(Status::InvalidArgument, "the cut's refined surface is not a valid mesh: " + st.message);
    r.surface = std::move(st.topology);
  }
  for (Index f : cut.surface_face_to_input)
    if (f < 0 || f >= input.num_faces)
      return fail(Status::InvalidArgument, "the cut names input face " + std::to_string(f) + ", out of range");
  for (Index k = 0; k < nadd; ++k)
    if (cut.refined_vertex_face[k] < 0 || cut.refined_vertex_face[k] >= input.num_faces)
      return fail(Status::InvalidArgument, "added vertex " + std::to_string(nin + k) + " names input face " +
                                               std::to_string(cut.refined_vertex_face[k]) + ", out of range");
  return true;
}

}  // namespace

RefinedMetric refined_edge_lengths(const CutResult& cut, const Topology& input, Geometry g,
                                   std::span<const double> input_lengths) {
  RefinedMetric r;
  auto fail = [&](Status s, const std::string& m) {
    r.status = s;
    r.message = m;
    r.l.clear();
    return r;
  };
  if (!refined_surface(cut, input, g, input_lengths, r)) return r;
  const Index nin = cut.num_input_vertices;
  const Topology& s = r.surface;
  r.l.assign(static_cast<std::size_t>(s.num_edges), 0.0);

  // Per input face: corner frames, computed lazily.
  std::vector<std::uint8_t> have(static_cast<std::size_t>(input.num_faces), 0);
  std::vector<std::array<V3, 3>> frame(static_cast<std::size_t>(input.num_faces));
  auto build_frame = [&](Index O) -> bool {
    if (have[O]) return true;
    const double l0 = input_lengths[input.corner_edge[3 * O]], l1 = input_lengths[input.corner_edge[3 * O + 1]],
                 l2 = input_lengths[input.corner_edge[3 * O + 2]];
    const double sp = (l0 + l1 + l2) / 2;
    bool ok = side_function(g, sp - l0) > 0 && side_function(g, sp - l1) > 0 && side_function(g, sp - l2) > 0;
    if (g == Geometry::Spherical) ok = ok && sp < kPi;
    if (!ok) {
      r.status = Status::TriangleInequality;
      r.element = Element::Face;
      r.element_index = O;
      r.message = "input face " + std::to_string(O) + " with lengths " + num(l0) + ", " + num(l1) + ", " + num(l2) +
                  " violates the triangle inequality" + (g == Geometry::Spherical ? " (or has perimeter ≥ 2π)" : "");
      return false;
    }
    const double th = angle_from_lengths(g, l0, l1, l2);
    std::array<V3, 3>& F = frame[O];
    switch (g) {
      case Geometry::Euclidean:
        F = {V3{1, 0, 0}, V3{1, l2, 0}, V3{1, l1 * std::cos(th), l1 * std::sin(th)}};
        break;
      case Geometry::Hyperbolic:
        F = {V3{1, 0, 0}, V3{std::cosh(l2), std::sinh(l2), 0},
             V3{std::cosh(l1), std::sinh(l1) * std::cos(th), std::sinh(l1) * std::sin(th)}};
        break;
      default:
        F = {V3{0, 0, 1}, V3{std::sin(l2), 0, std::cos(l2)},
             V3{std::sin(l1) * std::cos(th), std::sin(l1) * std::sin(th), std::cos(l1)}};
        break;
    }
    have[O] = 1;
    return true;
  };
  // The point of surface vertex v in the frame of input face O; false if v is not in O.
  auto point = [&](Index v, Index O, V3& X) -> bool {
    X = {0, 0, 0};
    if (v < nin) {
      for (int j = 0; j < 3; ++j)
        if (input.corner_vertex[3 * O + j] == v) {
          X = frame[O][j];
          return true;
        }
      return false;
    }
    const Index k = v - nin;
    for (int i = 0; i < 3; ++i) {
      const double b = cut.refined_vertex_bary[3 * k + i];
      if (b == 0) continue;
      const Index w = cut.refined_vertex_corners[3 * k + i];
      int slot = -1;
      for (int j = 0; j < 3; ++j)
        if (input.corner_vertex[3 * O + j] == w) slot = j;
      if (slot < 0) return false;
      for (int d = 0; d < 3; ++d) X[d] += b * frame[O][slot][d];
    }
    switch (g) {
      case Geometry::Euclidean: X = scaled(X, 1 / X[0]); break;  // Σβ = 1 up to rounding
      case Geometry::Hyperbolic: X = scaled(X, 1 / std::sqrt(X[0] * X[0] - X[1] * X[1] - X[2] * X[2])); break;
      default: X = normalized(X); break;
    }
    return true;
  };

  for (Index e = 0; e < s.num_edges; ++e) {
    const Index a = s.edge_vertices[2 * e], b = s.edge_vertices[2 * e + 1];
    const Index fs = corner_face(s.edge_corners[2 * e]);
    const Index O = cut.surface_face_to_input[fs];
    if (a < nin && b < nin) {
      Index found = kInvalid;
      for (int j = 0; j < 3; ++j) {
        const Index c = 3 * O + j;
        const Index p = input.corner_vertex[next_corner(c)], q = input.corner_vertex[prev_corner(c)];
        if ((p == a && q == b) || (p == b && q == a)) found = input.corner_edge[c];
      }
      if (found != kInvalid) {
        r.l[e] = input_lengths[found];
        ++r.edges_copied;
        continue;
      }
    }
    if (!build_frame(O)) {
      r.l.clear();
      return r;
    }
    V3 A, B;
    if (!point(a, O, A) || !point(b, O, B)) {
      const Index bad = point(a, O, A) ? b : a;
      return fail(Status::NumericalFailure, "surface vertex " + std::to_string(bad) + " of edge " + std::to_string(e) +
                                                " is not expressible in input face " + std::to_string(O) +
                                                " that holds the edge");
    }
    double d = 0;
    switch (g) {
      case Geometry::Euclidean: d = std::hypot(A[1] - B[1], A[2] - B[2]); break;
      case Geometry::Hyperbolic:
        // These frames put the time coordinate first; the model's distance takes it last (and
        // the time difference from the spatial parts, accurate for close points).
        d = model::distance(g, {A[1], A[2], A[0]}, {B[1], B[2], B[0]});
        break;
      default: d = sphere_distance(A, B); break;
    }
    if (!(d > 0) || !std::isfinite(d))
      return fail(Status::NumericalFailure, "sub-edge " + std::to_string(e) + " of input face " + std::to_string(O) +
                                                " has length " + num(d));
    r.l[e] = d;
    ++r.edges_computed;
  }
  r.status = Status::Ok;
  r.message = "lengths of " + std::to_string(s.num_edges) + " edges (" + std::to_string(r.edges_copied) +
              " copied, " + std::to_string(r.edges_computed) + " measured inside input faces)";
  return r;
}

std::vector<double> disk_edge_lengths(const CutResult& cut, const Topology& surface,
                                      std::span<const double> surface_lengths, const Topology& disk) {
  if (surface_lengths.size() != static_cast<std::size_t>(surface.num_edges) ||
      disk.num_faces != surface.num_faces || cut.cut_faces.size() != static_cast<std::size_t>(disk.num_corners()))
    return {};
  std::vector<double> out(static_cast<std::size_t>(disk.num_edges));
  for (Index e = 0; e < disk.num_edges; ++e) out[e] = surface_lengths[surface.corner_edge[disk.edge_corners[2 * e]]];
  return out;
}

// ---------------------------------------------------------------------------------------------
// Alignment.

LayoutAlignment align_layouts(Geometry g, std::span<const double> a, std::span<const double> b) {
  LayoutAlignment r;
  const int dims = g == Geometry::Spherical ? 3 : 2;
  if (a.size() != b.size() || a.empty() || a.size() % dims != 0) {
    r.status = Status::InvalidArgument;
    r.message = "the layouts must have the same non-zero size, a multiple of " + std::to_string(dims) + "; got " +
                std::to_string(a.size()) + " and " + std::to_string(b.size());
    return r;
  }
  const Index n = static_cast<Index>(a.size() / dims);
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!std::isfinite(a[i]) || !std::isfinite(b[i])) {
      r.status = Status::InvalidArgument;
      r.message = "coordinate " + std::to_string(i) + " is not finite";
      return r;
    }
  auto z = [](std::span<const double> x, Index v) { return Cx(x[2 * v], x[2 * v + 1]); };
  auto p = [](std::span<const double> x, Index v) { return V3{x[3 * v], x[3 * v + 1], x[3 * v + 2]}; };
  for (Index v = 0; v < n; ++v) {
    if (g == Geometry::Hyperbolic && !(std::abs(z(a, v)) < 1 && std::abs(z(b, v)) < 1)) {
      r.status = Status::InvalidArgument;
      r.message = "point " + std::to_string(v) + " is not inside the Poincaré disk";
      return r;
    }
    if (g == Geometry::Spherical &&
        !(std::abs(norm(p(a, v)) - 1) < 1e-6 && std::abs(norm(p(b, v)) - 1) < 1e-6)) {
      r.status = Status::InvalidArgument;
      r.message = "point " + std::to_string(v) + " is not a unit vector";
      return r;
    }
  }
  std::vector<double> dev(static_cast<std::size_t>(n));
  if (g == Geometry::Euclidean) {
    Cx ca(0, 0), cb(0, 0);
    for (Index v = 0; v < n; ++v) {
      ca += z(a, v);
      cb += z(b, v);
    }
    ca /= static_cast<double>(n);
    cb /= static_cast<double>(n);
    Cx m(0, 0);
    for (Index v = 0; v < n; ++v) m += (z(a, v) - ca) * std::conj(z(b, v) - cb);
    const Cx rot = std::abs(m) > 0 ? m / std::abs(m) : Cx(1, 0);
    const Cx t = ca - rot * cb;
    r.angle = std::arg(rot);
    r.translation[0] = t.real();
    r.translation[1] = t.imag();
    for (Index v = 0; v < n; ++v) dev[v] = std::abs(z(a, v) - (rot * z(b, v) + t));
  } else if (g == Geometry::Hyperbolic) {
    std::vector<double> aa(a.begin(), a.end()), bb(b.begin(), b.end());
    Positions A{g, 2, aa}, B{g, 2, bb};
    const Cx ca = hyperbolic_centre(A, n, nullptr), cb = hyperbolic_centre(B, n, nullptr);
    Cx m(0, 0);
    for (Index v = 0; v < n; ++v) m += to_origin(ca, z(a, v)) * std::conj(to_origin(cb, z(b, v)));
    const Cx rot = std::abs(m) > 0 ? m / std::abs(m) : Cx(1, 0);
    auto map = [&](Cx w) { return from_origin(ca, rot * to_origin(cb, w)); };
    // As e^{iψ}(z − z0)/(1 − z̄0 z): z0 is the preimage of 0, the angle from the derivative's phase.
    const Cx z0 = from_origin(cb, std::conj(rot) * to_origin(ca, Cx(0, 0)));
    // e^{iψ} from the map at a point w half a unit from z0: map(w) (1 − z̄0 w)/(w − z0). (At the
    // origin, −map(0)/z0, it is the ratio of two numbers as small as z0, each off by the rounding
    // of the points: a chart and its parent both holding the collar at their origins — z0 of
    // 1e-16 — gave an angle 4.3° off.)
    const Cx w = std::abs(z0) > 0 ? -0.5 * z0 / std::abs(z0) : Cx(0.5, 0);
    const double psi = std::arg(map(w) * (1.0 - std::conj(z0) * w) / (w - z0));
    r.angle = psi;
    r.translation[0] = z0.real();
    r.translation[1] = z0.imag();
    for (Index v = 0; v < n; ++v) dev[v] = disk_distance(z(a, v), map(z(b, v)));
  } else {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (Index v = 0; v < n; ++v) {
      const V3 x = p(a, v), y = p(b, v);
      H += Eigen::Vector3d(y[0], y[1], y[2]) * Eigen::Vector3d(x[0], x[1], x[2]).transpose();
    }
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
    const Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.rotation[3 * i + j] = R(i, j);
    for (Index v = 0; v < n; ++v) {
      const V3 y = p(b, v);
      const Eigen::Vector3d Ry = R * Eigen::Vector3d(y[0], y[1], y[2]);
      dev[v] = sphere_distance(p(a, v), V3{Ry[0], Ry[1], Ry[2]});
    }
  }
  double sq = 0;
  for (double d : dev) {
    r.max_deviation = std::max(r.max_deviation, d);
    sq += d * d;
  }
  r.rms_deviation = std::sqrt(sq / n);
  r.status = Status::Ok;
  r.message = "aligned " + std::to_string(n) + " points";
  return r;
}

double layout_alignment_error(Geometry g, std::span<const double> a, std::span<const double> b) {
  const LayoutAlignment r = align_layouts(g, a, b);
  return r.status == Status::Ok ? r.max_deviation : kInf;
}

}  // namespace ricci

namespace ricci {

Index farthest_face(const Topology& t, Index seed) {
  std::vector<Index> dist;
  return dual_bfs(t, seed, dist);
}

Index central_face(const Topology& t) { return t.num_faces > 0 ? central_face_of(t) : kInvalid; }

LayoutMisses layout_misses(const Topology& disk, Geometry g, std::span<const double> l,
                           std::span<const double> positions, std::span<const double> face_area, double limit) {
  LayoutMisses m;
  const int dims = g == Geometry::Spherical ? 3 : 2;
  if (l.size() != static_cast<std::size_t>(disk.num_edges) || face_area.size() != static_cast<std::size_t>(disk.num_faces) ||
      positions.size() != static_cast<std::size_t>(disk.num_vertices) * static_cast<std::size_t>(dims)) {
    m.worst_unexplained = kInf;  // nothing measured: nothing excused
    m.area_fraction = 1;
    return m;
  }
  std::vector<double> x(positions.begin(), positions.end());
  const Positions P{g, dims, x};
  std::vector<std::uint8_t> missed(static_cast<std::size_t>(disk.num_faces), 0);
  for (Index e = 0; e < disk.num_edges; ++e) {
    const Index a = disk.edge_vertices[2 * e], b = disk.edge_vertices[2 * e + 1];
    const double err = std::abs(P.distance(a, b) - l[e]) / l[e];
    if (!(err > limit)) continue;
    ++m.edges;
    const double unexplained = err - kRoundingAllowance * rounding_drift(g, P, a, b) / l[e];
    if (!(unexplained <= m.worst_unexplained)) m.worst_unexplained = unexplained;  // NaN counts as the worst
    for (int k = 0; k < 2; ++k)
      if (const Index c = disk.edge_corners[2 * e + k]; c != kInvalid) missed[c / 3] = 1;
  }
  double total = 0, part = 0;
  for (Index f = 0; f < disk.num_faces; ++f) {
    total += face_area[f];
    if (missed[f]) part += face_area[f];
  }
  m.area_fraction = m.edges == 0 ? 0 : total > 0 ? part / total : 1;
  return m;
}

std::vector<std::uint8_t> resolved_vertices(const Topology& disk, Geometry g, std::span<const double> l,
                                            std::span<const double> positions, double limit) {
  const int dims = g == Geometry::Spherical ? 3 : 2;
  std::vector<std::uint8_t> ok(static_cast<std::size_t>(disk.num_vertices), 0);
  if (l.size() != static_cast<std::size_t>(disk.num_edges) ||
      positions.size() != static_cast<std::size_t>(disk.num_vertices) * static_cast<std::size_t>(dims))
    return ok;
  std::fill(ok.begin(), ok.end(), 1);
  std::vector<double> x(positions.begin(), positions.end());
  const Positions P{g, dims, x};
  // The edges' verdicts in parallel (one byte each), the vertices marked after them in order.
  std::vector<std::uint8_t> edge_ok(static_cast<std::size_t>(disk.num_edges));
#pragma omp parallel for schedule(static)
  for (Index e = 0; e < disk.num_edges; ++e) {
    const Index a = disk.edge_vertices[2 * e], b = disk.edge_vertices[2 * e + 1];
    edge_ok[e] = std::abs(P.distance(a, b) - l[e]) / l[e] <= limit ? 1 : 0;
  }
  for (Index e = 0; e < disk.num_edges; ++e)
    if (!edge_ok[e]) ok[disk.edge_vertices[2 * e]] = ok[disk.edge_vertices[2 * e + 1]] = 0;
  return ok;
}

Layout measure_layout(const Topology& disk, Geometry g, std::span<const double> l, std::span<const double> positions) {
  Layout out;
  out.geometry = g;
  out.dims = g == Geometry::Spherical ? 3 : 2;
  const Index nv = disk.num_vertices;
  if (l.size() != static_cast<std::size_t>(disk.num_edges) ||
      positions.size() != static_cast<std::size_t>(nv) * static_cast<std::size_t>(out.dims)) {
    out.status = Status::InvalidArgument;
    out.message = "measure_layout: sizes do not match the mesh";
    return out;
  }
  out.positions.assign(positions.begin(), positions.end());
  Positions P{g, out.dims, out.positions};
  for (Index v = 0; v < nv; ++v)
    if (!P.finite(v)) {
      out.status = Status::NonFiniteCoordinate;
      out.message = "measure_layout: vertex " + std::to_string(v) + " has no valid position";
      out.element = Element::Vertex;
      out.element_index = v;
      return out;
    }
  measure_edges(disk, g, l, P, out);
  for (Index f = 0; f < disk.num_faces; ++f)
    if (P.orientation(disk.corner_vertex[3 * f], disk.corner_vertex[3 * f + 1], disk.corner_vertex[3 * f + 2]) < 0) {
      if (out.flipped_faces == 0) out.first_flipped_face = f;
      ++out.flipped_faces;
    }
  out.status = Status::Ok;
  out.message = "measured";
  return out;
}

namespace detail {

double rounding_drift_planar(Geometry g, std::complex<double> a, std::complex<double> b) {
  constexpr double u = 0x1p-53;
  if (g == Geometry::Euclidean) return u * std::sqrt(2.0) * (std::abs(a) + std::abs(b));
  const double ra = std::abs(a), rb = std::abs(b), da = (1 - ra) * (1 + ra), db = (1 - rb) * (1 + rb);
  if (!(da > 0 && db > 0)) return std::numeric_limits<double>::infinity();  // at or beyond the circle
  return 2 * u * std::sqrt(2.0) * (1 / da + 1 / db);
}

bool propagate_faces(const Topology& t, Geometry g, std::span<const double> l, Index seed,
                     std::span<const Index> owner, Index label, std::vector<double>& positions,
                     std::vector<Index>& touched, Layout& out) {
  const int dims = g == Geometry::Spherical ? 3 : 2;
  positions.assign(static_cast<std::size_t>(dims) * t.num_vertices, 0.0);
  Positions L{g, dims, positions};
  std::vector<std::uint8_t> visited(static_cast<std::size_t>(t.num_faces), 0), placed(static_cast<std::size_t>(t.num_vertices), 0);
  std::vector<Index> queue;
  return lay_out_patch(t, l, label, seed, owner, visited, L, placed, touched, queue, out);
}

}  // namespace detail

}  // namespace ricci
