// Polishing developed layouts: Gauss–Seidel sweeps (E, S) and global Gauss–Newton steps (E, H, S).
// See layout_polish.h.
#include "layout_polish.h"

#include <Eigen/SparseCore>

#include <algorithm>
#include <bit>
#include <cmath>
#include <complex>
#include <cstdint>

#include "model_geometry.h"
#include "sparse_solver.h"

namespace ricci::detail {

namespace {

using Cx = std::complex<double>;
using model::cross;
using model::disk_distance;
using model::dot;
using model::P3;
using model::sphere_distance;

double norm(const P3& a) { return std::sqrt(dot(a, a)); }
P3 normalized(const P3& a) {
  const double n = norm(a);
  return n > 0 ? model::mul(a, 1 / n) : P3{0, 0, 1};
}
P3 point(const std::vector<double>& x, Index v) { return {x[3 * v], x[3 * v + 1], x[3 * v + 2]}; }

/// A unit tangent basis (e1, e2) at the unit vector X, with e1 × e2 = X.
void tangent_basis(const P3& X, P3& e1, P3& e2) {
  e1 = normalized(cross(X, std::abs(X[0]) < 0.9 ? P3{1, 0, 0} : P3{0, 1, 0}));
  e2 = cross(X, e1);
}

/// Moves the unit vector X by a·e1 + b·e2 in its tangent plane, then back onto the sphere.
P3 move_on_sphere(const P3& X, const P3& e1, const P3& e2, double a, double b) {
  return normalized(P3{X[0] + a * e1[0] + b * e2[0], X[1] + a * e1[1] + b * e2[1], X[2] + a * e1[2] + b * e2[2]});
}

/// The unit tangent at X pointing away from Y (the gradient of the great-circle distance d(X, Y)
/// with respect to X); false when X and Y coincide or are antipodal.
bool away_from(const P3& X, const P3& Y, P3& u) {
  const double c = dot(X, Y);
  u = P3{c * X[0] - Y[0], c * X[1] - Y[1], c * X[2] - Y[2]};
  const double n = norm(u);
  if (!(n > 0)) return false;
  u = model::mul(u, 1 / n);
  return true;
}

/// ∂d(z, w)/∂z in the Poincaré disk, as a plane vector: the conformal factor 2/(1 − |z|²) times the
/// unit vector at z pointing away from w along the geodesic. The isometry taking z to the origin
/// has a positive real derivative at z, so that direction is minus the direction of w's image.
void disk_gradient(Cx z, Cx w, double& gx, double& gy) {
  const Cx t = model::disk_to_origin(z, w);
  const double n = std::abs(t), az = std::abs(z);
  if (!(az < 1)) {  // z rounded onto the circle: no finite gradient (|z|² may still be below 1)
    gx = gy = 0;
    return;
  }
  const double lambda = 2 / ((1 - az) * (1 + az));
  gx = n > 0 ? -lambda * t.real() / n : 0;
  gy = n > 0 ? -lambda * t.imag() / n : 0;
}

/// Point v of a Poincaré layout.
Cx disk_point(const std::vector<double>& x, Index v) { return {x[2 * v], x[2 * v + 1]}; }

double max_relative_error(const Topology& t, Geometry g, std::span<const double> l, const std::vector<double>& x) {
  double worst = 0;
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
    const double d = g == Geometry::Spherical    ? sphere_distance(point(x, a), point(x, b))
                     : g == Geometry::Hyperbolic ? disk_distance(disk_point(x, a), disk_point(x, b))
                                                 : std::hypot(x[2 * a] - x[2 * b], x[2 * a + 1] - x[2 * b + 1]);
    const double err = std::abs(d - l[e]) / l[e];
    if (!(err <= worst)) worst = err;  // NaN propagates as the worst
  }
  return worst;
}

/// One Gauss–Newton step in two dimensions on Σ w (r + u·δ)² (r a residual, u the unit direction
/// along which it grows): δ = −H⁻¹ g. False when H is (nearly) singular.
struct GaussNewton2 {
  double g0 = 0, g1 = 0, h00 = 0, h01 = 0, h11 = 0;
  void add(double w, double r, double ux, double uy) {
    g0 += w * r * ux;
    g1 += w * r * uy;
    h00 += w * ux * ux;
    h01 += w * ux * uy;
    h11 += w * uy * uy;
  }
  bool step(double& a, double& b) const {
    const double det = h00 * h11 - h01 * h01;
    if (!(det > 1e-12 * (h00 + h11) * (h00 + h11))) return false;
    a = -(h11 * g0 - h01 * g1) / det;
    b = -(h00 * g1 - h01 * g0) / det;
    return true;
  }
};

/// f(j, e) for every edge e of vertex v once, j its other end: the edge to vertex(next(c)) of each
/// corner, and for a boundary vertex also the edge to vertex(prev(c)) of its last
/// (counter-clockwise) corner.
template <class F>
void for_each_incident_edge(const Topology& t, Index v, F&& f) {
  const Index k0 = t.vertex_corner_offsets[v], k1 = t.vertex_corner_offsets[v + 1];
  for (Index k = k0; k < k1; ++k) {
    const Index c = t.vertex_corners[k];
    f(t.corner_vertex[next_corner(c)], t.corner_edge[prev_corner(c)]);
  }
  if (k1 > k0 && t.is_boundary_vertex(v)) {
    const Index c = t.vertex_corners[k1 - 1];
    f(t.corner_vertex[prev_corner(c)], t.corner_edge[next_corner(c)]);
  }
}


/// One Gauss–Newton step of vertex v over its incident edges, the other ends held (H: a step that
/// would leave the unit disk is not taken).
void sweep_vertex(const Topology& t, Geometry g, std::span<const double> l, std::vector<double>& x, Index v) {
  GaussNewton2 gn;
  double a = 0, b = 0;
  if (g == Geometry::Hyperbolic) {
    // In the Poincaré disk: ∂d/∂z is disk_gradient(), the step stays inside the disk.
    const Cx z = disk_point(x, v);
    for_each_incident_edge(t, v, [&](Index j, Index e) {
      const Cx w = disk_point(x, j);
      const double d = disk_distance(z, w);
      double gx = 0, gy = 0;
      if (!(d > 0) || !std::isfinite(d)) return;
      disk_gradient(z, w, gx, gy);
      gn.add(1 / (l[e] * l[e]), d - l[e], gx, gy);
    });
    if (!gn.step(a, b)) return;
    const Cx moved = z + Cx(a, b);
    if (!(std::abs(moved) < 1)) return;
    x[2 * v] = moved.real();
    x[2 * v + 1] = moved.imag();
    return;
  }
  if (g == Geometry::Euclidean) {
    for_each_incident_edge(t, v, [&](Index j, Index e) {
      const double dx = x[2 * v] - x[2 * j], dy = x[2 * v + 1] - x[2 * j + 1];
      const double d = std::hypot(dx, dy);
      if (d > 0) gn.add(1 / (l[e] * l[e]), d - l[e], dx / d, dy / d);
    });
    if (!gn.step(a, b)) return;
    x[2 * v] += a;
    x[2 * v + 1] += b;
    return;
  }
  const P3 X = point(x, v);
  P3 e1, e2, u;
  tangent_basis(X, e1, e2);
  for_each_incident_edge(t, v, [&](Index j, Index e) {
    const P3 Y = point(x, j);
    if (away_from(X, Y, u)) gn.add(1 / (l[e] * l[e]), sphere_distance(X, Y) - l[e], dot(u, e1), dot(u, e2));
  });
  if (!gn.step(a, b)) return;
  const P3 Z = move_on_sphere(X, e1, e2, a, b);
  for (int d = 0; d < 3; ++d) x[3 * v + d] = Z[d];
}

}  // namespace

// Colour classes of at most this many vertices are swept on one thread.
constexpr Index kParallelClass = 4096;

SweepOrder sweep_order(const Topology& t, std::span<const Index> only) {
  const Index n = only.empty() ? t.num_vertices : static_cast<Index>(only.size());
  // Greedy colouring in the given order: each vertex takes the smallest colour none of its
  // neighbours among the swept vertices has taken yet (colour −2: not swept; −1: not yet coloured).
  std::vector<int> colour(static_cast<std::size_t>(t.num_vertices), only.empty() ? -1 : -2);
  if (!only.empty())
    for (Index v : only) colour[v] = -1;
  std::vector<Index> count;
  std::uint64_t used = 0;  // bit c: colour c seen at a neighbour (colours past 63 by a scan)
  std::vector<std::uint8_t> seen;
  for (Index i = 0; i < n; ++i) {
    const Index v = only.empty() ? i : only[i];
    used = 0;
    int most = -1;
    for_each_incident_edge(t, v, [&](Index j, Index) {
      const int c = colour[j];
      if (c < 0) return;
      most = std::max(most, c);
      if (c < 64) used |= std::uint64_t{1} << c;
    });
    int c = 0;
    if (~used != 0 && most < 64) {
      c = std::countr_one(used);
    } else {  // a vertex of very high degree: the colours of its neighbours listed
      seen.assign(static_cast<std::size_t>(most) + 2, 0);
      for_each_incident_edge(t, v, [&](Index j, Index) {
        if (colour[j] >= 0) seen[static_cast<std::size_t>(colour[j])] = 1;
      });
      while (seen[static_cast<std::size_t>(c)]) ++c;
    }
    colour[v] = c;
    if (static_cast<std::size_t>(c) >= count.size()) count.resize(static_cast<std::size_t>(c) + 1, 0);
    ++count[static_cast<std::size_t>(c)];
  }
  SweepOrder order;
  order.class_start.assign(count.size() + 1, 0);
  for (std::size_t c = 0; c < count.size(); ++c) order.class_start[c + 1] = order.class_start[c] + count[c];
  order.vertices.resize(static_cast<std::size_t>(n));
  std::vector<Index> fill(order.class_start.begin(), order.class_start.end() - 1);
  for (Index i = 0; i < n; ++i) {
    const Index v = only.empty() ? i : only[i];
    order.vertices[static_cast<std::size_t>(fill[static_cast<std::size_t>(colour[v])]++)] = v;
  }
  return order;
}

// Each vertex takes one Gauss–Newton step on Σ_j ((d(x, x_j) − l_j)/l_j)² over its incident
// edges — E in the plane; H in the Poincaré disk; S in its tangent plane, then back onto the
// sphere — class by class of sweep_order(): no two vertices of a class share an edge, so a
// class's steps read only positions no other step of it writes, and run in parallel with the
// same result on any number of threads.
void polish_by_sweeps(const Topology& t, Geometry g, std::span<const double> l, std::vector<double>& x,
                      int sweeps, std::span<const Index> only) {
  if (sweeps > 0) polish_by_sweeps(t, g, l, x, sweeps, sweep_order(t, only));
}

void polish_by_sweeps(const Topology& t, Geometry g, std::span<const double> l, std::vector<double>& x,
                      int sweeps, const SweepOrder& order) {
  const std::size_t classes = order.class_start.size() - 1;
  for (int sweep = 0; sweep < sweeps; ++sweep)
    for (std::size_t c = 0; c < classes; ++c) {
      const Index a = order.class_start[c], b = order.class_start[c + 1];
#pragma omp parallel for schedule(static) if (b - a > kParallelClass)
      for (Index i = a; i < b; ++i) sweep_vertex(t, g, l, x, order.vertices[static_cast<std::size_t>(i)]);
    }
}

// Two unknowns per vertex (E: dx, dy; S: the coordinates of the move in the vertex's tangent
// basis). Row e of J holds ∂r_e/∂(unknowns of its two ends), r_e = (d_e − l_e)/l_e. The rigid
// motions (E: two translations and a rotation; S: three rotations) leave every r_e unchanged, so
// JᵀJ is singular along them: three unknowns are held fixed (both of one vertex, and the one of a
// neighbour that the rotation about the first moves most), which leaves JᵀJ positive definite on
// an infinitesimally rigid triangulation (every triangulated disk or sphere with non-degenerate
// faces, as the propagation shows: each vertex is added with two independent edges).
GlobalPolish polish_globally(const Topology& t, Geometry g, std::span<const double> l, std::vector<double>& x,
                             int max_steps) {
  GlobalPolish out;
  out.error_before = out.error_after = max_relative_error(t, g, l, x);
  const Index nv = t.num_vertices, ne = t.num_edges;
  if (max_steps <= 0 || ne == 0 || !std::isfinite(out.error_before) || out.error_before == 0) return out;
  const bool sphere = g == Geometry::Spherical;
  const std::int64_t n = 2 * static_cast<std::int64_t>(nv);

  // The gauge: vertex p fixed, and one coordinate of its neighbour q.
  const Index p = t.edge_vertices[0], q = t.edge_vertices[1];
  std::vector<std::uint8_t> fixed(static_cast<std::size_t>(n), 0);
  fixed[2 * p] = fixed[2 * p + 1] = 1;
  if (g == Geometry::Euclidean) {
    const double dx = x[2 * q] - x[2 * p], dy = x[2 * q + 1] - x[2 * p + 1];
    fixed[2 * q + (std::abs(dx) >= std::abs(dy) ? 1 : 0)] = 1;  // a rotation about p moves q across p → q
  } else if (g == Geometry::Hyperbolic) {
    double dx = 0, dy = 0;  // the geodesic direction at q (away from p); a rotation about p moves q across it
    disk_gradient(disk_point(x, q), disk_point(x, p), dx, dy);
    fixed[2 * q + (std::abs(dx) >= std::abs(dy) ? 1 : 0)] = 1;
  } else {
    P3 e1, e2;
    tangent_basis(point(x, q), e1, e2);
    const P3 r = cross(point(x, p), point(x, q));  // how a rotation about p moves q
    fixed[2 * q + (std::abs(dot(r, e1)) >= std::abs(dot(r, e2)) ? 0 : 1)] = 1;
  }

  using Sparse = Eigen::SparseMatrix<double, Eigen::ColMajor, std::int64_t>;
  std::vector<Eigen::Triplet<double, std::int64_t>> entries;
  entries.reserve(static_cast<std::size_t>(ne) * 10 + static_cast<std::size_t>(n));
  std::vector<P3> basis(sphere ? 2 * static_cast<std::size_t>(nv) : 0);
  std::vector<double> rhs(static_cast<std::size_t>(n)), step(static_cast<std::size_t>(n));
  SymmetricSolver solver;
  Sparse A(n, n);

  for (int it = 0; it < max_steps; ++it) {
    // Normal equations JᵀJ δ = −Jᵀr, fixed unknowns as identity rows. JᵀJ is assembled and
    // factorized at the first step only: the later steps move the positions by about the error
    // (≪ the edge lengths), so the first factor still solves them to a contraction well below
    // one (a simplified Gauss–Newton / chord iteration), at the cost of a right-hand side each.
    entries.clear();
    std::fill(rhs.begin(), rhs.end(), 0.0);
    if (sphere)
      for (Index v = 0; v < nv; ++v) tangent_basis(point(x, v), basis[2 * v], basis[2 * v + 1]);
    for (Index e = 0; e < ne; ++e) {
      const Index ends[2] = {t.edge_vertices[2 * e], t.edge_vertices[2 * e + 1]};
      double d = 0, grad[2][2] = {};  // ∂d/∂(unknowns of each end)
      if (g == Geometry::Euclidean) {
        const double dx = x[2 * ends[0]] - x[2 * ends[1]], dy = x[2 * ends[0] + 1] - x[2 * ends[1] + 1];
        d = std::hypot(dx, dy);
        if (!(d > 0)) continue;
        grad[0][0] = dx / d, grad[0][1] = dy / d, grad[1][0] = -dx / d, grad[1][1] = -dy / d;
      } else if (g == Geometry::Hyperbolic) {
        const Cx za = disk_point(x, ends[0]), zb = disk_point(x, ends[1]);
        d = disk_distance(za, zb);
        if (!(d > 0) || !std::isfinite(d)) continue;
        disk_gradient(za, zb, grad[0][0], grad[0][1]);
        disk_gradient(zb, za, grad[1][0], grad[1][1]);
      } else {
        const P3 X = point(x, ends[0]), Y = point(x, ends[1]);
        P3 ux, uy;
        if (!away_from(X, Y, ux) || !away_from(Y, X, uy)) continue;
        d = sphere_distance(X, Y);
        grad[0][0] = dot(ux, basis[2 * ends[0]]), grad[0][1] = dot(ux, basis[2 * ends[0] + 1]);
        grad[1][0] = dot(uy, basis[2 * ends[1]]), grad[1][1] = dot(uy, basis[2 * ends[1] + 1]);
      }
      const double r = (d - l[e]) / l[e];
      double J[4];
      std::int64_t col[4];
      for (int s = 0; s < 2; ++s)
        for (int k = 0; k < 2; ++k) {
          col[2 * s + k] = 2 * static_cast<std::int64_t>(ends[s]) + k;
          J[2 * s + k] = fixed[col[2 * s + k]] ? 0.0 : grad[s][k] / l[e];
        }
      for (int i = 0; i < 4; ++i) {
        rhs[col[i]] -= J[i] * r;
        for (int j = 0; j < 4; ++j)
          if (it == 0 && col[i] <= col[j]) entries.emplace_back(col[i], col[j], J[i] * J[j]);
      }
    }
    if (it == 0) {
      for (std::int64_t i = 0; i < n; ++i)
        if (fixed[i]) entries.emplace_back(i, i, 1.0);
      A.setFromTriplets(entries.begin(), entries.end());  // sums duplicates, rows sorted per column
      A.makeCompressed();
      const std::span<const std::int64_t> cp(A.outerIndexPtr(), static_cast<std::size_t>(n) + 1);
      const std::span<const std::int64_t> rows(A.innerIndexPtr(), static_cast<std::size_t>(A.nonZeros()));
      if (solver.analyze(n, cp, rows, FactorKind::PositiveDefinite) != FactorOutcome::Ok) {
        out.factorized = false;
        return out;
      }
      std::copy(A.valuePtr(), A.valuePtr() + A.nonZeros(), solver.values().begin());
      if (solver.factorize() != FactorOutcome::Ok) {
        out.factorized = false;
        return out;
      }
    }
    if (!solver.solve(rhs, step)) break;
    std::vector<double> trial = x;
    for (Index v = 0; v < nv; ++v) {
      if (step[2 * v] == 0 && step[2 * v + 1] == 0) continue;  // the fixed vertex stays bit for bit
      if (!sphere) {
        trial[2 * v] += step[2 * v];
        trial[2 * v + 1] += step[2 * v + 1];
        continue;
      }
      const P3 Z = move_on_sphere(point(x, v), basis[2 * v], basis[2 * v + 1], step[2 * v], step[2 * v + 1]);
      for (int d = 0; d < 3; ++d) trial[3 * v + d] = Z[d];
    }
    const double err = max_relative_error(t, g, l, trial);
    if (!(err < out.error_after)) break;
    const bool enough = !(err < 0.1 * out.error_after);
    x.swap(trial);
    out.error_after = err;
    ++out.steps;
    if (enough) break;
  }
  return out;
}

bool develop_by_shapes(const Topology& t, std::span<const double> l, std::span<const double> theta, Index s0,
                       Index s1, std::vector<double>& x) {
  const Index nv = t.num_vertices, nf = t.num_faces;
  const std::int64_t n = 2 * static_cast<std::int64_t>(nv);
  const Index s01 = t.edge_between(s0, s1);
  if (s01 == kInvalid) return false;
  // Fixed unknowns and their values.
  std::vector<double> fixed_value(static_cast<std::size_t>(n), 0.0);
  std::vector<std::uint8_t> fixed(static_cast<std::size_t>(n), 0);
  fixed[2 * s0] = fixed[2 * s0 + 1] = fixed[2 * s1] = fixed[2 * s1 + 1] = 1;
  fixed_value[2 * s1] = l[s01];
  for (Index v = 0; v < nv; ++v)
    if (t.vertex_corner_offsets[v] == t.vertex_corner_offsets[v + 1]) fixed[2 * v] = fixed[2 * v + 1] = 1;

  using Sparse = Eigen::SparseMatrix<double, Eigen::ColMajor, std::int64_t>;
  std::vector<Eigen::Triplet<double, std::int64_t>> entries;
  entries.reserve(static_cast<std::size_t>(nf) * 3 * 21 + static_cast<std::size_t>(n));
  std::vector<double> rhs(static_cast<std::size_t>(n), 0.0);
  for (Index f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      const Index ci = 3 * f + k, cj = next_corner(ci), ck = prev_corner(ci);
      const Index vi = t.corner_vertex[ci], vj = t.corner_vertex[cj], vk = t.corner_vertex[ck];
      const double lij = l[t.corner_edge[ck]], lik = l[t.corner_edge[cj]];
      const double ratio = lik / lij, a = ratio * std::cos(theta[ci]), b = ratio * std::sin(theta[ci]);
      const double w = 1 / (lij * lij);
      // r = z_k − (1 − c) z_i − c z_j with c = a + ib; a complex coefficient α = p + iq acts on
      // (x, y) as Re: (p, −q), Im: (q, p).
      const Index vs[3] = {vk, vi, vj};
      const double ps[3] = {1, -(1 - a), -a}, qs[3] = {0, b, -b};
      for (int part = 0; part < 2; ++part) {  // real and imaginary rows
        double row[6];
        std::int64_t col[6];
        for (int m = 0; m < 3; ++m) {
          col[2 * m] = 2 * static_cast<std::int64_t>(vs[m]);
          col[2 * m + 1] = col[2 * m] + 1;
          row[2 * m] = part == 0 ? ps[m] : qs[m];
          row[2 * m + 1] = part == 0 ? -qs[m] : ps[m];
        }
        double known = 0;  // the fixed unknowns' part of the row
        for (int m = 0; m < 6; ++m)
          if (fixed[col[m]]) known += row[m] * fixed_value[col[m]];
        for (int m = 0; m < 6; ++m) {
          if (fixed[col[m]]) continue;
          rhs[col[m]] -= w * row[m] * known;
          for (int q = 0; q < 6; ++q)
            if (!fixed[col[q]] && col[m] <= col[q]) entries.emplace_back(col[m], col[q], w * row[m] * row[q]);
        }
      }
    }
  }
  for (std::int64_t i = 0; i < n; ++i)
    if (fixed[i]) {
      entries.emplace_back(i, i, 1.0);
      rhs[i] = fixed_value[i];
    }
  Sparse A(n, n);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  SymmetricSolver solver;
  const std::span<const std::int64_t> cp(A.outerIndexPtr(), static_cast<std::size_t>(n) + 1);
  const std::span<const std::int64_t> rows(A.innerIndexPtr(), static_cast<std::size_t>(A.nonZeros()));
  if (solver.analyze(n, cp, rows, FactorKind::PositiveDefinite) != FactorOutcome::Ok) return false;
  std::copy(A.valuePtr(), A.valuePtr() + A.nonZeros(), solver.values().begin());
  std::vector<double> z(static_cast<std::size_t>(n));
  if (solver.factorize() != FactorOutcome::Ok || !solver.solve(rhs, z)) return false;
  // Vertices used by no face keep their place.
  for (Index v = 0; v < nv; ++v)
    if (t.vertex_corner_offsets[v] < t.vertex_corner_offsets[v + 1]) {
      x[2 * v] = z[2 * v];
      x[2 * v + 1] = z[2 * v + 1];
    }
  return true;
}

}  // namespace ricci::detail
