// ricci — signatures of surfaces with boundary (signature.h): takes a successful
// UniformizeResult with a cut and a layout; gives the normalized circle domain of a genus-0
// surface with n ≥ 2 loops laid out with circle boundaries in E, or the boundary geodesics'
// lengths of a hyperbolic surface with geodesic boundaries.
//
// Circles are fitted to the laid-out input vertices of every loop (algebraic fit, then
// Gauss–Newton on the geometric distance); the normalization is composed of affine maps and the
// inversion w = 1/z, whose action on a circle (c, r) is closed-form: (c̄/(|c|² − r²), r/||c|² − r²|).
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <numeric>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Dense>

#include "signature_internal.h"

namespace ricci {

namespace {

using cplx = std::complex<double>;
constexpr double kTwoPi = 6.283185307179586476925286766559;

struct Circle {
  cplx c;
  double r = 0;
};

Circle affine(const Circle& k, cplx alpha, cplx beta) { return {alpha * k.c + beta, std::abs(alpha) * k.r}; }

/// w = 1/z; the circle must not pass through 0 (|c| ≠ r).
Circle inverted(const Circle& k) {
  const double den = std::norm(k.c) - k.r * k.r;
  return {std::conj(k.c) / den, k.r / std::abs(den)};
}

/// Least-squares circle through points (algebraic fit, refined by Gauss–Newton on |z − c| − r).
/// Returns the largest |dist − r| / r in `residual`.
Circle fit_circle(const std::vector<cplx>& z, double& residual) {
  cplx mean = 0;
  for (const cplx& p : z) mean += p;
  mean /= static_cast<double>(z.size());
  double scale = 0;
  for (const cplx& p : z) scale = std::max(scale, std::abs(p - mean));
  if (!(scale > 0)) scale = 1;
  // |q|² = 2 Re(c̄ q) + k with q the centred, scaled points: linear in (cx, cy, k).
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (const cplx& p : z) {
    const cplx q = (p - mean) / scale;
    const Eigen::Vector3d row(2 * q.real(), 2 * q.imag(), 1);
    M += row * row.transpose();
    rhs += row * std::norm(q);
  }
  const Eigen::Vector3d x = M.ldlt().solve(rhs);
  cplx c(x[0], x[1]);
  double r = std::sqrt(std::max(x[2] + std::norm(c), 0.0));
  for (int it = 0; it < 20; ++it) {
    Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d Jte = Eigen::Vector3d::Zero();
    for (const cplx& p : z) {
      const cplx q = (p - mean) / scale - c;
      const double d = std::abs(q);
      if (!(d > 0)) continue;
      const Eigen::Vector3d J(-q.real() / d, -q.imag() / d, -1);
      JtJ += J * J.transpose();
      Jte += J * (d - r);
    }
    const Eigen::Vector3d step = JtJ.ldlt().solve(-Jte);
    if (!step.allFinite()) break;
    c += cplx(step[0], step[1]);
    r += step[2];
    if (step.norm() < 1e-16) break;
  }
  residual = 0;
  for (const cplx& p : z) residual = std::max(residual, std::abs(std::abs((p - mean) / scale - c) - r) / r);
  return {mean + scale * c, scale * r};
}

/// Inversive distance of two circles bounding a common region: both exterior to each other, or
/// `outer` containing the other.
double inversive_distance(const Circle& a, const Circle& b, bool a_is_outer) {
  const double d2 = std::norm(a.c - b.c);
  return a_is_outer ? (a.r * a.r + b.r * b.r - d2) / (2 * a.r * b.r) : (d2 - a.r * a.r - b.r * b.r) / (2 * a.r * b.r);
}

double separation(double inversive) { return std::acosh(std::max(inversive, 1.0)); }

/// The part of the signature code that reads the cut: per boundary loop (the cut's loop order),
/// its cut vertices, input vertices and 3D length.
struct LoopData {
  std::vector<Index> cut_vertices;   ///< every cut vertex of its Boundary sides (sides concatenated)
  std::vector<std::pair<Index, Index>> edges;  ///< consecutive cut vertices along the sides
  Index smallest_vertex = kInvalid;
  double length_3d = 0;
};

std::vector<LoopData> loop_data(const UniformizeResult& r) {
  const CutResult& cut = r.cut;
  std::vector<LoopData> loops(static_cast<std::size_t>(std::max<Index>(cut.boundary_loops, 0)));
  const std::vector<double>& P = cut.surface_positions;
  for (Index s = 0; s < cut.num_sides(); ++s) {
    if (cut.side_kind[s] != SideKind::Boundary) continue;
    const Index loop = cut.side_boundary_loop[s];
    if (loop < 0 || loop >= static_cast<Index>(loops.size())) continue;
    LoopData& L = loops[static_cast<std::size_t>(loop)];
    for (Index i = cut.side_offsets[s]; i < cut.side_offsets[s + 1]; ++i) {
      const Index cv = cut.side_vertices[i];
      L.cut_vertices.push_back(cv);
      const Index v = cut.cut_to_surface[cv];
      if (v < cut.num_input_vertices && (L.smallest_vertex == kInvalid || v < L.smallest_vertex)) L.smallest_vertex = v;
      if (i + 1 < cut.side_offsets[s + 1]) {
        const Index cw = cut.side_vertices[i + 1];
        L.edges.push_back({cv, cw});
        const Index w = cut.cut_to_surface[cw];
        if (P.size() >= 3 * static_cast<std::size_t>(std::max(v, w) + 1)) {
          const double* x = &P[3 * static_cast<std::size_t>(v)];
          const double* y = &P[3 * static_cast<std::size_t>(w)];
          L.length_3d += std::sqrt((x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) +
                                   (x[2] - y[2]) * (x[2] - y[2])) / r.input_scale;
        }
      }
    }
  }
  return loops;
}

/// The flow's target is the uniformization's: K̄ = 0 at every interior input vertex, and (circle
/// domains) loop totals ±2π with one +2π. Empty string when so (or when no flow ran).
std::string check_uniformizing_target(const UniformizeResult& r, const std::vector<LoopData>& loops, bool circles) {
  const std::vector<double>& Kt = r.flow.K_target;
  if (Kt.empty()) return {};
  std::vector<std::uint8_t> on_boundary(Kt.size(), 0);
  std::vector<double> totals(loops.size(), 0);
  for (std::size_t i = 0; i < loops.size(); ++i) {
    std::vector<Index> vs;
    for (const Index cv : loops[i].cut_vertices) vs.push_back(r.cut.cut_to_surface[cv]);
    std::sort(vs.begin(), vs.end());
    vs.erase(std::unique(vs.begin(), vs.end()), vs.end());
    for (const Index v : vs)
      if (v >= 0 && static_cast<std::size_t>(v) < Kt.size()) {
        on_boundary[static_cast<std::size_t>(v)] = 1;
        totals[i] += Kt[static_cast<std::size_t>(v)];
      }
  }
  for (std::size_t v = 0; v < Kt.size(); ++v)
    if (!on_boundary[v] && !(std::abs(Kt[v]) <= 1e-9))
      return "the target curvature is not the uniformization's (vertex " + std::to_string(v) + " has target " +
             std::to_string(Kt[v]) + ", not 0)";
  if (circles) {
    int positive = 0;
    for (const double t : totals) {
      if (std::abs(t - kTwoPi) <= 1e-7)
        ++positive;
      else if (!(std::abs(t + kTwoPi) <= 1e-7))
        return "a boundary loop's target total curvature is " + std::to_string(t) + ", not ±2π: not a circle domain";
    }
    if (positive != 1) return "not exactly one outer circle (loop total +2π): not a circle domain";
  }
  return {};
}

}  // namespace

bool circle_domain_signature(const UniformizeResult& r, ConformalSignature& out) {
  const std::vector<LoopData> loops = loop_data(r);
  const std::size_t n = loops.size();
  if (const std::string why = check_uniformizing_target(r, loops, true); !why.empty()) {
    out.status = Status::InvalidArgument;
    out.message = why;
    return false;
  }
  if (r.layout.dims != 2 || r.layout.positions.size() != 2 * static_cast<std::size_t>(r.cut.num_cut_vertices())) {
    out.status = Status::InvalidArgument;
    out.message = "the result has no planar layout of the cut";
    return false;
  }
  const double layout_error = std::max(r.layout.max_edge_length_error, 0.0);
  std::vector<Circle> fitted(n);
  std::vector<double> rel(n);
  std::vector<BoundaryCircle> info(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<Index> cvs;
    for (const Index cv : loops[i].cut_vertices)
      if (r.cut.cut_to_surface[cv] < r.cut.num_input_vertices) cvs.push_back(cv);
    std::sort(cvs.begin(), cvs.end());
    cvs.erase(std::unique(cvs.begin(), cvs.end()), cvs.end());
    if (cvs.size() < 3) {
      out.status = Status::InvalidArgument;
      out.message = "boundary loop at vertex " + std::to_string(loops[i].smallest_vertex) +
                    " has fewer than 3 vertices in the layout";
      return false;
    }
    std::vector<cplx> z;
    for (const Index cv : cvs)
      z.emplace_back(r.layout.positions[2 * static_cast<std::size_t>(cv)],
                     r.layout.positions[2 * static_cast<std::size_t>(cv) + 1]);
    double residual = 0;
    fitted[i] = fit_circle(z, residual);
    if (!std::isfinite(fitted[i].r) || !(fitted[i].r > 0) || !std::isfinite(fitted[i].c.real()) ||
        !std::isfinite(fitted[i].c.imag())) {
      out.status = Status::NumericalFailure;
      out.message = "no circle fits boundary loop at vertex " + std::to_string(loops[i].smallest_vertex);
      return false;
    }
    info[i].vertex = loops[i].smallest_vertex;
    info[i].length_3d = loops[i].length_3d;
    info[i].fit_residual = residual;
    rel[i] = residual + layout_error;
  }
  // The layout's outer circle: the largest.
  std::size_t layout_outer = 0;
  for (std::size_t i = 1; i < n; ++i)
    if (fitted[i].r > fitted[layout_outer].r) layout_outer = i;
  auto before = [&](std::size_t i, std::size_t j, double a, double b) {  // a preferred over b, ties by vertex
    if (std::abs(a - b) > 1e-9 * std::max(std::abs(a), std::abs(b))) return a > b;
    return info[i].vertex < info[j].vertex;
  };
  std::size_t outer = 0;
  for (std::size_t i = 1; i < n; ++i)
    if (before(i, outer, info[i].length_3d, info[outer].length_3d)) outer = i;
  // The outer loop to the unit circle, the domain inside it.
  std::vector<Circle> k(n);
  const Circle O = fitted[outer];
  for (std::size_t i = 0; i < n; ++i)
    k[i] = outer == layout_outer ? affine(fitted[i], 1.0 / O.r, -O.c / O.r)
                                 : affine(inverted(affine(fitted[i], 1.0, -O.c)), O.r, 0.0);
  k[outer] = {0.0, 1.0};
  auto sep_to_outer = [&](std::size_t j) { return separation(inversive_distance(k[outer], k[j], true)); };
  std::size_t first = outer == 0 ? 1 : 0;
  for (std::size_t i = 0; i < n; ++i)
    if (i != outer && i != first && before(i, first, -sep_to_outer(i), -sep_to_outer(first))) first = i;
  // The first inner circle concentric: the disk automorphism (z − a)/(1 − āz) with a its limit point.
  {
    const double rho = std::abs(k[first].c), rr = k[first].r;
    if (rho > 1e-300) {
      const double Bq = 1 + rho * rho - rr * rr;
      const double x = 2 * rho / (Bq + std::sqrt(std::max(Bq * Bq - 4 * rho * rho, 0.0)));
      const cplx a = x * k[first].c / rho;
      for (std::size_t i = 0; i < n; ++i) {
        if (i == outer) continue;
        // (z − a)/(1 − āz) = −1/ā + (1 − |a|²)/ā · 1/(1 − āz).
        k[i] = affine(inverted(affine(k[i], -std::conj(a), 1.0)), (1 - std::norm(a)) / std::conj(a), -1.0 / std::conj(a));
      }
    }
  }
  // The other inner circles by decreasing radius; the first of them onto the positive real axis.
  std::vector<std::size_t> order{outer, first};
  for (std::size_t i = 0; i < n; ++i)
    if (i != outer && i != first) order.push_back(i);
  // Exact comparison (a strict weak order): equal radii go to the smaller vertex.
  std::sort(order.begin() + 2, order.end(), [&](std::size_t i, std::size_t j) {
    return k[i].r > k[j].r || (k[i].r == k[j].r && info[i].vertex < info[j].vertex);
  });
  if (n >= 3 && std::abs(k[order[2]].c) > 0) {
    const cplx rot = std::conj(k[order[2]].c) / std::abs(k[order[2]].c);
    for (std::size_t i = 0; i < n; ++i)
      if (i != outer) k[i] = affine(k[i], rot, 0.0);
  }
  CircleDomain& D = out.circle_domain;
  D.circles.clear();
  const double gauge = rel[outer] + rel[first];
  for (const std::size_t i : order) {
    BoundaryCircle b = info[i];
    b.centre = k[i].c;
    b.radius = k[i].r;
    b.uncertainty = k[i].r * rel[i] + gauge;
    D.circles.push_back(b);
  }
  D.separation.assign(n * n, 0);
  D.separation_uncertainty.assign(n * n, 0);
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b) {
      if (a == b) continue;
      const std::size_t i = order[a], j = order[b];
      const double I = i == outer   ? inversive_distance(k[i], k[j], true)
                       : j == outer ? inversive_distance(k[j], k[i], true)
                                    : inversive_distance(k[i], k[j], false);
      D.separation[a * n + b] = separation(I);
      const double slope = I > 1 ? I / std::sqrt((I - 1) * (I + 1)) : INFINITY;
      D.separation_uncertainty[a * n + b] = (rel[i] + rel[j]) * slope;
    }
  if (n == 2) {
    D.annulus_modulus = D.separation[1] / kTwoPi;
    D.annulus_modulus_uncertainty = D.separation_uncertainty[1] / kTwoPi;
  }
  out.has_circle_domain = true;
  return true;
}

bool boundary_geodesic_signature(const UniformizeResult& r, ConformalSignature& out) {
  const std::vector<LoopData> loops = loop_data(r);
  if (const std::string why = check_uniformizing_target(r, loops, false); !why.empty()) {
    out.status = Status::InvalidArgument;
    out.message = why;
    return false;
  }
  const Topology& disk = r.disk;
  if (static_cast<Index>(r.disk_lengths.size()) != disk.num_edges) {
    out.status = Status::InvalidArgument;
    out.message = "the result has no edge lengths of the cut disk";
    return false;
  }
  std::unordered_map<std::uint64_t, Index> boundary_edge;
  auto key = [](Index a, Index b) {
    return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | static_cast<std::uint32_t>(std::max(a, b));
  };
  for (Index e = 0; e < disk.num_edges; ++e)
    if (disk.edge_corners[2 * e + 1] == kInvalid)
      boundary_edge.emplace(key(disk.edge_vertices[2 * e], disk.edge_vertices[2 * e + 1]), e);
  out.boundary_geodesics.clear();
  for (const LoopData& L : loops) {
    BoundaryGeodesic b;
    b.vertex = L.smallest_vertex;
    b.length_3d = L.length_3d;
    for (const auto& [u, v] : L.edges) {
      const auto it = boundary_edge.find(key(u, v));
      if (it == boundary_edge.end()) {
        out.status = Status::NumericalFailure;
        out.message = "boundary loop at vertex " + std::to_string(L.smallest_vertex) + ": a side's edge is not a disk edge";
        return false;
      }
      b.length += r.disk_lengths[static_cast<std::size_t>(it->second)];
    }
    std::vector<Index> vs;
    for (const Index cv : L.cut_vertices) vs.push_back(r.cut.cut_to_surface[cv]);
    std::sort(vs.begin(), vs.end());
    vs.erase(std::unique(vs.begin(), vs.end()), vs.end());
    double residual = 0;
    for (const Index v : vs)
      if (v >= 0 && static_cast<std::size_t>(v) < r.flow.K.size() && r.flow.K.size() == r.flow.K_target.size())
        residual += std::abs(r.flow.K_target[static_cast<std::size_t>(v)] - r.flow.K[static_cast<std::size_t>(v)]);
    b.uncertainty = residual + 4e-16 * b.length * static_cast<double>(L.edges.size());
    out.boundary_geodesics.push_back(b);
  }
  std::sort(out.boundary_geodesics.begin(), out.boundary_geodesics.end(),
            [](const BoundaryGeodesic& x, const BoundaryGeodesic& y) { return x.vertex < y.vertex; });
  return true;
}

}  // namespace ricci
