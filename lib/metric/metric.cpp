#include "ricci/metric.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>
#include <cstdint>

#include "model_geometry.h"

namespace ricci {

namespace {

constexpr double kPi = std::numbers::pi;

// σ of the length formula: F(l) = l² (E), sinh²(l/2) (H), sin²(l/2) (S) and the denominators
// D = (1 − σ ε x_i)(1 − σ ε x_j) with σ = 0 (E), +1 (H), −1 (S).
double sigma(Geometry g) { return g == Geometry::Euclidean ? 0.0 : (g == Geometry::Hyperbolic ? 1.0 : -1.0); }

// F(l) and its inverse.
double length_function(Geometry g, double l) {
  switch (g) {
    case Geometry::Euclidean: return l * l;
    case Geometry::Hyperbolic: return std::sinh(l / 2) * std::sinh(l / 2);
    case Geometry::Spherical: return std::sin(l / 2) * std::sin(l / 2);
  }
  return 0;
}

// Length from Q/D; NaN-free: returns -1 when out of range.
double length_from_ratio(Geometry g, double ratio) {
  if (!(ratio > 0) || !std::isfinite(ratio)) return -1;
  switch (g) {
    case Geometry::Euclidean: return std::sqrt(ratio);
    case Geometry::Hyperbolic: return 2 * std::asinh(std::sqrt(ratio));
    case Geometry::Spherical: return ratio < 1 ? 2 * std::asin(std::sqrt(ratio)) : -1;
  }
  return -1;
}

// f of the half-angle formula.
double side_function(Geometry g, double x) {
  switch (g) {
    case Geometry::Euclidean: return x;
    case Geometry::Hyperbolic: return std::sinh(x);
    case Geometry::Spherical: return std::sin(x);
  }
  return x;
}

struct EdgeTerms {
  double ratio;  // Q / D
  double dratio_du[2];  // ∂(Q/D)/∂u_i, ∂(Q/D)/∂u_j
};

EdgeTerms edge_terms(const ConformalStructure& s, double sg, double ui, double uj, double eta) {
  const double eps = s.epsilon;
  const double xi = std::exp(2 * ui), xj = std::exp(2 * uj), xij = std::exp(ui + uj);
  const double q = 2 * eta * xij + eps * xi + eps * xj;
  const double di = 1 - sg * eps * xi, dj = 1 - sg * eps * xj;
  const double d = di * dj;
  EdgeTerms t;
  t.ratio = q / d;
  // ∂Q/∂u_i = 2η e^{u_i+u_j} + 2ε x_i;  ∂D/∂u_i / D = −2σε x_i / (1 − σε x_i).
  t.dratio_du[0] = (2 * eta * xij + 2 * eps * xi) / d + t.ratio * (2 * sg * eps * xi / di);
  t.dratio_du[1] = (2 * eta * xij + 2 * eps * xj) / d + t.ratio * (2 * sg * eps * xj / dj);
  return t;
}

// dF/dl: 2l (E), sinh(l)/2 (H), sin(l)/2 (S).
double length_function_derivative(Geometry g, double l) {
  switch (g) {
    case Geometry::Euclidean: return 2 * l;
    case Geometry::Hyperbolic: return std::sinh(l) / 2;
    case Geometry::Spherical: return std::sin(l) / 2;
  }
  return 0;
}

}  // namespace

/// Angle between sides b and c of a triangle whose third side (opposite the angle) is a, by the
/// half-angle formula; differences clamped at 0 so that rounding never produces NaN.
double detail::angle_from_lengths(Geometry g, double a, double b, double c) {
  const double s = (a + b + c) / 2;
  const double fs = side_function(g, s);
  const double fa = side_function(g, std::max(0.0, s - a));
  const double fb = side_function(g, std::max(0.0, s - b));
  const double fc = side_function(g, std::max(0.0, s - c));
  return 2 * std::atan2(std::sqrt(std::max(0.0, fb * fc)), std::sqrt(std::max(0.0, fs * fa)));
}

std::string_view geometry_name(Geometry g) {
  switch (g) {
    case Geometry::Euclidean: return "euclidean";
    case Geometry::Hyperbolic: return "hyperbolic";
    case Geometry::Spherical: return "spherical";
  }
  return "unknown";
}

std::string_view scheme_name(Scheme s) {
  switch (s) {
    case Scheme::CirclePacking: return "circle-packing";
    case Scheme::InversiveDistance: return "inversive-distance";
    case Scheme::Yamabe: return "yamabe";
  }
  return "unknown";
}

double gauss_bonnet_lambda(Geometry g) { return g == Geometry::Euclidean ? 0.0 : (g == Geometry::Hyperbolic ? -1.0 : 1.0); }

bool InitialMetricOptions::is_valid(std::string* why) const {
  if (!(length_scale >= 0) || !std::isfinite(length_scale)) {
    if (why) *why = "length_scale must be finite and non-negative (0 picks the default)";
    return false;
  }
  if (!(mollify_margin >= 0 && mollify_margin <= 1e-3)) {
    if (why) *why = "mollify_margin must be in [0, 1e-3] (0 turns mollification off)";
    return false;
  }
  return true;
}

std::vector<double> mesh_edge_lengths(const Mesh& mesh, const Topology& topology) {
  std::vector<double> l(static_cast<std::size_t>(topology.num_edges));
#pragma omp parallel for schedule(static) if (topology.num_edges >= 65536)
  for (Index e = 0; e < topology.num_edges; ++e) {
    const double* a = &mesh.positions[3 * static_cast<std::size_t>(topology.edge_vertices[2 * e])];
    const double* b = &mesh.positions[3 * static_cast<std::size_t>(topology.edge_vertices[2 * e + 1])];
    const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    // hypot where the squares would leave the normal range (any scale a double holds); decided
    // before squaring, so that nothing overflows.
    const double m = std::max({std::abs(dx), std::abs(dy), std::abs(dz)});
    l[e] = m < 0x1p-500 || !(m < 0x1p500) ? std::hypot(dx, dy, dz) : std::sqrt(dx * dx + dy * dy + dz * dz);
  }
  return l;
}

Mollification mollify_lengths(const Topology& t, std::span<double> l, double relative_margin) {
  Mollification m;
  if (l.empty() || !(relative_margin > 0)) return m;
  const double n = static_cast<double>(l.size());
  for (const double x : l) m.mean_edge += x / n;  // no overflow of the sum at any scale
  m.delta = relative_margin * m.mean_edge;
  for (Index f = 0; f < t.num_faces; ++f) {
    bool below = false;
    for (int k = 0; k < 3; ++k) {
      const double need = l[t.corner_edge[3 * f + k]] - l[t.corner_edge[3 * f + (k + 1) % 3]] -
                          l[t.corner_edge[3 * f + (k + 2) % 3]] + m.delta;
      if (need > 0) below = true;
      if (need > m.epsilon) {
        m.epsilon = need;
        m.worst_face = f;
      }
    }
    if (below) ++m.faces;
  }
  if (m.epsilon > 0)
    for (double& x : l) x += m.epsilon;
  return m;
}

double unit_power_of_two(double extent) {
  if (!std::isfinite(extent) || !(extent > 0)) return 1;  // isfinite first: no comparison with NaN
  if (extent >= 0x1p-100 && extent <= 0x1p100) return 1;
  int e = 0;
  std::frexp(extent, &e);  // extent = m·2^e, m in [0.5, 1)
  return std::ldexp(1.0, std::min(1 - e, 1023));  // subnormal extents: the largest power of two
}

double euclidean_area_scale(const Topology& t, std::span<const double> l, double target_area) {
  double longest = 0;
  for (const double x : l)
    if (std::isfinite(x)) longest = std::max(longest, x);
  if (!(longest > 0)) return 1;
  int e = 0;
  std::frexp(longest, &e);
  const double p = std::ldexp(1.0, -e);  // l·p ≤ 1: the products below stay in range
  double area = 0;  // of the triangles of lengths l·p
  for (Index f = 0; f < t.num_faces; ++f) {
    // Kahan's stable Heron: sort a ≥ b ≥ c.
    double x[3] = {l[t.corner_edge[3 * f]] * p, l[t.corner_edge[3 * f + 1]] * p, l[t.corner_edge[3 * f + 2]] * p};
    std::sort(x, x + 3, std::greater<>());
    const double q = (x[0] + (x[1] + x[2])) * (x[2] - (x[0] - x[1])) * (x[2] + (x[0] - x[1])) * (x[0] + (x[1] - x[2]));
    area += q > 0 ? 0.25 * std::sqrt(q) : 0;
  }
  return area > 0 ? std::sqrt(target_area / area) * p : 1;
}

InitialMetric initial_metric(const Mesh& mesh, const Topology& t, const InitialMetricOptions& options) {
  InitialMetric r;
  if (std::string why; !options.is_valid(&why)) {
    r.status = Status::InvalidArgument;
    r.message = why;
    return r;
  }
  const Geometry g = options.geometry;
  const Index nv = t.num_vertices, ne = t.num_edges;
  ConformalStructure& s = r.structure;
  s.geometry = g;
  s.scheme = options.scheme;
  s.epsilon = options.scheme == Scheme::Yamabe ? 0.0 : 1.0;

  // 3D lengths and the scale.
  r.l0.resize(static_cast<std::size_t>(ne));
  for (Index e = 0; e < ne; ++e) {
    const double* a = &mesh.positions[3 * static_cast<std::size_t>(t.edge_vertices[2 * e])];
    const double* b = &mesh.positions[3 * static_cast<std::size_t>(t.edge_vertices[2 * e + 1])];
    r.l0[e] = std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  }
  r.mollification = mollify_lengths(t, r.l0, options.mollify_margin);
  double longest = 0;
  for (const double x : r.l0) longest = std::max(longest, x);
  double scale = options.length_scale;
  if (scale == 0) {
    const double chi = static_cast<double>(t.euler_characteristic());
    // H: the area Gauss–Bonnet gives a closed surface (2π|χ|); surfaces with χ ≥ 0 (a disk or an
    // annulus forced into H) get 2π, so that lengths in any unit stay far from sinh² overflow.
    if (g == Geometry::Spherical) scale = euclidean_area_scale(t, r.l0, 4 * kPi);
    else if (g == Geometry::Hyperbolic) scale = euclidean_area_scale(t, r.l0, 2 * kPi * std::max(1.0, -chi));
    else scale = unit_power_of_two(longest);
  }
  // Every scheme on the sphere needs every edge below π, not the euclidean area: where the
  // area-4π scale puts an edge past π (a mesh whose extent is dominated by a few long edges, e.g. a
  // vertex far out, or a long thin surface: random genus-0 draws stretched 30–60:1), the lengths
  // are scaled so that the longest is 0.9 π instead, and the flow (with flips, the intrinsic
  // triangulation's own scaling) does the rest. Circle packing, the fallback where vertex scaling
  // fails, was refused there before ("longer than π after scaling"), hiding the first failure.
  if (g == Geometry::Spherical && options.length_scale == 0) {
    if (longest > 0 && !(longest * scale < kPi)) scale = 0.9 * kPi / longest;
  }
  r.length_scale = scale;
  for (double& x : r.l0) x *= scale;

  auto fail = [&](Status st, std::string msg) {
    r.status = st;
    r.message = std::move(msg);
    r.u.clear();
    r.gamma.clear();
    return r;
  };
  if (g == Geometry::Spherical)
    for (Index e = 0; e < ne; ++e)
      if (!(r.l0[e] < kPi))
        return fail(Status::NumericalFailure, "edge " + std::to_string(e) + " is longer than π after scaling to the unit sphere");
  if (g == Geometry::Hyperbolic)
    for (Index e = 0; e < ne; ++e)
      if (!(r.l0[e] < 700))  // sinh²(l/2) overflows near l = 1419; radii near 700 saturate tanh
        return fail(Status::NumericalFailure, "edge " + std::to_string(e) +
                                                  " is too long for the hyperbolic plane after scaling (length " +
                                                  std::to_string(r.l0[e]) + "); give a smaller length_scale");

  s.eta.resize(static_cast<std::size_t>(ne));
  r.u.assign(static_cast<std::size_t>(nv), 0.0);
  if (options.scheme == Scheme::Yamabe) {
    for (Index e = 0; e < ne; ++e) s.eta[e] = length_function(g, r.l0[e]) / 2;
    r.status = Status::Ok;
    r.message = "ok";
    return r;
  }

  // Radii: per face γ_i = (l_ki + l_ij − l_jk)/2, i.e. half the sum of the two edges at i minus the
  // opposite one; averaged over the faces around each vertex (gathered, deterministic).
  r.gamma.assign(static_cast<std::size_t>(nv), 0.0);
  for (Index v = 0; v < nv; ++v) {
    double sum = 0;
    const Index b = t.vertex_corner_offsets[v], e = t.vertex_corner_offsets[v + 1];
    for (Index i = b; i < e; ++i) {
      const Index c = t.vertex_corners[i];
      sum += (r.l0[t.corner_edge[next_corner(c)]] + r.l0[t.corner_edge[prev_corner(c)]] - r.l0[t.corner_edge[c]]) / 2;
    }
    const double gamma = e > b ? sum / (e - b) : 0;
    if (!(gamma > 0) || !std::isfinite(gamma))
      return fail(Status::DegenerateFace, "vertex " + std::to_string(v) +
                                              " gets a non-positive initial radius (its triangles are degenerate)");
    r.gamma[v] = gamma;
    switch (g) {
      case Geometry::Euclidean: r.u[v] = std::log(gamma); break;
      case Geometry::Hyperbolic:
        if (!(std::tanh(gamma / 2) < 1))
          return fail(Status::NumericalFailure, "vertex " + std::to_string(v) +
                                                    " gets an initial radius too large for the hyperbolic plane");
        r.u[v] = std::log(std::tanh(gamma / 2));
        break;
      case Geometry::Spherical:
        if (!(gamma < kPi)) return fail(Status::NumericalFailure, "vertex " + std::to_string(v) + " radius exceeds π");
        r.u[v] = std::log(std::tan(gamma / 2));
        break;
    }
  }
  // η from the cosine law in its unified form: η = (F(l)·D − ε(x_i + x_j)) / (2 e^{u_i+u_j}).
  const double sg = sigma(g);
  for (Index e = 0; e < ne; ++e) {
    const double ui = r.u[t.edge_vertices[2 * e]], uj = r.u[t.edge_vertices[2 * e + 1]];
    const double xi = std::exp(2 * ui), xj = std::exp(2 * uj);
    const double d = (1 - sg * xi) * (1 - sg * xj);
    double eta = (length_function(g, r.l0[e]) * d - xi - xj) / (2 * std::exp(ui + uj));
    if (options.scheme == Scheme::CirclePacking) {
      if (eta < 0) {
        eta = 0;
        ++r.edges_clamped_high;
      } else if (eta > 1) {
        eta = 1;
        ++r.edges_clamped_low;
      }
    } else if (!(eta > -1)) {
      return fail(Status::DegenerateFace, "edge " + std::to_string(e) + " gets an inversive distance ≤ −1");
    }
    if (!std::isfinite(eta))
      return fail(Status::NumericalFailure, "edge " + std::to_string(e) + " gets a non-finite weight η");
    s.eta[e] = eta;
  }
  if (options.scheme == Scheme::CirclePacking && options.relax_angles) {
    const AngleRelaxation relaxed = relax_intersection_angles(t, s.eta);
    r.cycles_relaxed = relaxed.cycles3 + relaxed.cycles4;
    r.edges_relaxed = relaxed.edges;
  }
  r.status = Status::Ok;
  r.message = "ok";
  return r;
}

AngleRelaxation relax_intersection_angles(const Topology& t, std::span<double> eta) {
  AngleRelaxation r;
  const Index nv = t.num_vertices, ne = t.num_edges;
  if (eta.size() != static_cast<std::size_t>(ne)) return r;
  auto angle = [&](Index e) { return eta[e] >= 0 && eta[e] <= 1 ? std::acos(eta[e]) : -1.0; };
  // Sorted neighbour lists (CSR) with the edge to each neighbour.
  std::vector<Index> offsets(static_cast<std::size_t>(nv) + 1, 0);
  for (Index e = 0; e < ne; ++e) {
    ++offsets[t.edge_vertices[2 * e] + 1];
    ++offsets[t.edge_vertices[2 * e + 1] + 1];
  }
  for (Index v = 0; v < nv; ++v) offsets[v + 1] += offsets[v];
  std::vector<std::pair<Index, Index>> nbr(static_cast<std::size_t>(2 * ne));
  {
    std::vector<Index> fill(offsets.begin(), offsets.end() - 1);
    for (Index e = 0; e < ne; ++e) {
      const Index a = t.edge_vertices[2 * e], b = t.edge_vertices[2 * e + 1];
      nbr[fill[a]++] = {b, e};
      nbr[fill[b]++] = {a, e};
    }
    for (Index v = 0; v < nv; ++v) std::sort(nbr.begin() + offsets[v], nbr.begin() + offsets[v + 1]);
  }
  auto find_edge = [&](Index a, Index b) {
    const auto first = nbr.begin() + offsets[a], last = nbr.begin() + offsets[a + 1];
    const auto it = std::lower_bound(first, last, std::pair<Index, Index>{b, Index{-1}});
    return it != last && it->first == b ? it->second : kInvalid;
  };
  // The vertex opposite edge e in its k-th face (kInvalid on the boundary side).
  auto apex = [&](Index e, int k) {
    const Index c = t.edge_corners[2 * e + k];
    return c == kInvalid ? kInvalid : t.corner_vertex[c];
  };
  std::vector<std::uint8_t> changed(static_cast<std::size_t>(ne), 0);
  auto scale_cycle = [&](const Index* edges, int k, double sum, double goal) {
    const double factor = goal / sum;
    for (int i = 0; i < k; ++i) {
      const double lowered = std::cos(angle(edges[i]) * factor);
      if (lowered != eta[edges[i]]) changed[edges[i]] = 1;
      eta[edges[i]] = lowered;
    }
  };

  // 3-cycles a < b < c that are not faces.
  constexpr double kTrigger3 = 5 * kPi / 6, kGoal3 = 2 * kPi / 3;
  for (Index a = 0; a < nv; ++a) {
    for (Index i = offsets[a]; i < offsets[a + 1]; ++i) {
      const auto [b, eab] = nbr[i];
      if (b <= a) continue;
      for (Index j = i + 1; j < offsets[a + 1]; ++j) {
        const auto [c, eac] = nbr[j];
        const Index ebc = find_edge(b, c);
        if (ebc == kInvalid) continue;
        if (apex(eab, 0) == c || apex(eab, 1) == c) continue;  // the face (a, b, c)
        const Index edges[3] = {eab, ebc, eac};
        double sum = 0;
        bool known = true;
        for (Index e : edges) {
          const double phi = angle(e);
          known = known && phi >= 0;
          sum += phi;
        }
        if (!known || !(sum > kTrigger3)) continue;
        scale_cycle(edges, 3, sum, kGoal3);
        ++r.cycles3;
      }
    }
  }

  // 4-cycles a-b-c-d with a the smallest vertex and b < d, every edge with Φ > π/3 (otherwise
  // the sum cannot exceed the trigger), that are not the outline of two faces.
  constexpr double kTrigger4 = 11 * kPi / 6, kGoal4 = 7 * kPi / 4, kEdgeMin4 = kTrigger4 - 3 * kPi / 2;
  auto steep = [&](Index e) { return angle(e) > kEdgeMin4; };
  for (Index a = 0; a < nv; ++a) {
    for (Index i = offsets[a]; i < offsets[a + 1]; ++i) {
      const auto [b, eab] = nbr[i];
      if (b <= a || !steep(eab)) continue;
      for (Index j = i + 1; j < offsets[a + 1]; ++j) {
        const auto [d, ead] = nbr[j];
        if (d <= a || !steep(ead)) continue;
        for (Index k = offsets[b]; k < offsets[b + 1]; ++k) {
          const auto [c, ebc] = nbr[k];
          if (c <= a || c == d || !steep(ebc)) continue;
          const Index ecd = find_edge(c, d);
          if (ecd == kInvalid || !steep(ecd)) continue;
          const Index eac = find_edge(a, c), ebd = find_edge(b, d);
          auto two_faces = [&](Index diagonal, Index p, Index q) {
            if (diagonal == kInvalid) return false;
            const Index x = apex(diagonal, 0), y = apex(diagonal, 1);
            return (x == p && y == q) || (x == q && y == p);
          };
          if (two_faces(eac, b, d) || two_faces(ebd, a, c)) continue;
          const Index edges[4] = {eab, ebc, ecd, ead};
          double sum = 0;
          for (Index e : edges) sum += angle(e);
          if (!(sum > kTrigger4)) continue;
          scale_cycle(edges, 4, sum, kGoal4);
          ++r.cycles4;
        }
      }
    }
  }
  // Boundary vertices in two faces: their angle is below 2π − (Φ of the two edges opposite them),
  // so Φ = π/2 on both (clamped, as Step 2 gives after an ear split) caps it at π and makes a
  // boundary target K̄ ≤ 0 (inner circle loops, geodesic loops) infeasible. Same trigger and goal
  // as a 3-cycle: the angle may then reach 4π/3.
  for (Index v = 0; v < nv; ++v) {
    if (t.valence(v) != 2 || !t.is_boundary_vertex(v)) continue;
    const Index o = t.vertex_corner_offsets[v];
    const Index edges[2] = {t.corner_edge[t.vertex_corners[o]], t.corner_edge[t.vertex_corners[o + 1]]};
    const double a0 = angle(edges[0]), a1 = angle(edges[1]);
    if (a0 < 0 || a1 < 0 || !(a0 + a1 > kTrigger3)) continue;
    scale_cycle(edges, 2, a0 + a1, kGoal3);
  }
  for (Index e = 0; e < ne; ++e) r.edges += changed[e];
  return r;
}

Index edge_lengths(const Topology& t, const ConformalStructure& s, std::span<const double> u, std::span<double> l) {
  const Index ne = t.num_edges;
  const double sg = sigma(s.geometry);
  Index first_bad = std::numeric_limits<Index>::max();
#pragma omp parallel for schedule(static) reduction(min : first_bad)
  for (Index e = 0; e < ne; ++e) {
    const EdgeTerms et = edge_terms(s, sg, u[t.edge_vertices[2 * e]], u[t.edge_vertices[2 * e + 1]], s.eta[e]);
    const double d0 = 1 - sg * s.epsilon * std::exp(2 * u[t.edge_vertices[2 * e]]);
    const double d1 = 1 - sg * s.epsilon * std::exp(2 * u[t.edge_vertices[2 * e + 1]]);
    const double len = (d0 > 0 && d1 > 0) ? length_from_ratio(s.geometry, et.ratio) : -1;
    l[e] = len > 0 ? len : 0;
    if (!(len > 0)) first_bad = std::min(first_bad, e);
  }
  return first_bad == std::numeric_limits<Index>::max() ? kInvalid : first_bad;
}

AngleReport corner_angles(const Topology& t, Geometry g, std::span<const double> l, std::span<double> theta) {
  const Index nf = t.num_faces;
  Index violations = 0, first = std::numeric_limits<Index>::max();
#pragma omp parallel for schedule(static) reduction(+ : violations) reduction(min : first)
  for (Index f = 0; f < nf; ++f) {
    const double a[3] = {l[t.corner_edge[3 * f]], l[t.corner_edge[3 * f + 1]], l[t.corner_edge[3 * f + 2]]};
    const double s = (a[0] + a[1] + a[2]) / 2;
    const double fs = side_function(g, s);
    double fm[3];
    bool ok = fs > 0 && (g != Geometry::Spherical || s < kPi);
    for (int k = 0; k < 3; ++k) {
      fm[k] = side_function(g, s - a[k]);
      ok = ok && fm[k] > 0;
    }
    if (ok) {
      for (int k = 0; k < 3; ++k)
        theta[3 * f + k] = 2 * std::atan2(std::sqrt(fm[(k + 1) % 3] * fm[(k + 2) % 3]), std::sqrt(fs * fm[k]));
    } else {
      ++violations;
      first = std::min(first, f);
      const int longest = static_cast<int>(std::max_element(a, a + 3) - a);
      for (int k = 0; k < 3; ++k) theta[3 * f + k] = k == longest ? kPi : 0;
    }
  }
  return {violations, violations > 0 ? first : kInvalid};
}

void vertex_curvature(const Topology& t, std::span<const double> theta, std::span<double> K) {
  // The full angle as fl(2π) + its rounding error (π likewise on the boundary): fl(2π) falls
  // 2.4e-16 short of 2π, and a deficit measured from it would leave every vertex of a converged
  // metric that much curved, the same sign everywhere — 4e-11 of holonomy over 160k vertices,
  // 1e-9 of edge-length error where a layout's front closes. fl(2π) − Σθ is exact near a flat
  // vertex (Sterbenz), so the low part is not lost.
  constexpr double kPiLow = 1.2246467991473532e-16;  // π − fl(π)
  const Index nv = t.num_vertices;
#pragma omp parallel for schedule(static)
  for (Index v = 0; v < nv; ++v) {
    double sum = 0;
    for (Index i = t.vertex_corner_offsets[v]; i < t.vertex_corner_offsets[v + 1]; ++i) sum += theta[t.vertex_corners[i]];
    const bool boundary = t.is_boundary_vertex(v);
    K[v] = ((boundary ? kPi : 2 * kPi) - sum) + (boundary ? kPiLow : 2 * kPiLow);
  }
}

void face_areas(const Topology& t, Geometry g, std::span<const double> l, std::span<const double> theta,
                std::span<double> area) {
  const Index nf = t.num_faces;
#pragma omp parallel for schedule(static)
  for (Index f = 0; f < nf; ++f) {
    const double a = l[t.corner_edge[3 * f]], b = l[t.corner_edge[3 * f + 1]], c = l[t.corner_edge[3 * f + 2]];
    if (g == Geometry::Euclidean) {
      area[f] = 0.5 * b * c * std::sin(theta[3 * f]);
      continue;
    }
    // L'Huilier: tan(A/4)² = Π t(·/2) over s, s−a, s−b, s−c with t = tanh (H) or tan (S).
    const double s = (a + b + c) / 2;
    auto tf = [g](double x) { return g == Geometry::Hyperbolic ? std::tanh(x / 2) : std::tan(x / 2); };
    const double p = tf(s) * tf(s - a) * tf(s - b) * tf(s - c);
    area[f] = p > 0 ? 4 * std::atan(std::sqrt(p)) : 0;
  }
}

void angle_derivative_blocks(const Topology& t, const ConformalStructure& s, std::span<const double> u,
                             std::span<const double> l, std::span<const double> theta, std::span<double> blocks) {
  const Index nf = t.num_faces;
  const Geometry g = s.geometry;
  const double sg = sigma(g);
#pragma omp parallel for schedule(static)
  for (Index f = 0; f < nf; ++f) {
    double* B = &blocks[9 * static_cast<std::size_t>(f)];
    double L[3], th[3];
    for (int k = 0; k < 3; ++k) {
      L[k] = l[t.corner_edge[3 * f + k]];
      th[k] = theta[3 * f + k];
    }
    if (!(th[0] > 0 && th[1] > 0 && th[2] > 0 && th[0] < kPi && th[1] < kPi && th[2] < kPi)) {
      for (int i = 0; i < 9; ++i) B[i] = 0;  // degenerate triangle: the extended angles are locally constant
      continue;
    }
    // ∂l_k/∂u_m: edge k (opposite corner k) joins the vertices of corners k+1 and k+2.
    double dl_du[3][3] = {};
    for (int k = 0; k < 3; ++k) {
      const int i = (k + 1) % 3, j = (k + 2) % 3;
      const EdgeTerms et = edge_terms(s, sg, u[t.corner_vertex[3 * f + i]], u[t.corner_vertex[3 * f + j]],
                                      s.eta[t.corner_edge[3 * f + k]]);
      const double dF = length_function_derivative(g, L[k]);
      dl_du[k][i] = et.dratio_du[0] / dF;
      dl_du[k][j] = et.dratio_du[1] / dF;
    }
    // Derivative cosine law: dθ_a = f(l_a)/S · (dl_a − cos θ_c dl_b − cos θ_b dl_c),
    // S = f(l_b) f(l_c) sin θ_a (the same for every corner by the sine law).
    const double S = side_function(g, L[1]) * side_function(g, L[2]) * std::sin(th[0]);
    for (int a = 0; a < 3; ++a) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      const double w = side_function(g, L[a]) / S;
      const double dth_dl[3] = {a == 0 ? w : (b == 0 ? -w * std::cos(th[c]) : -w * std::cos(th[b])),
                                a == 1 ? w : (b == 1 ? -w * std::cos(th[c]) : -w * std::cos(th[b])),
                                a == 2 ? w : (b == 2 ? -w * std::cos(th[c]) : -w * std::cos(th[b]))};
      for (int m = 0; m < 3; ++m) B[3 * a + m] = dth_dl[0] * dl_du[0][m] + dth_dl[1] * dl_du[1][m] + dth_dl[2] * dl_du[2][m];
    }
  }
}

double gauss_bonnet_defect(const Topology& t, Geometry g, std::span<const double> K, std::span<const double> area) {
  double sum_k = 0, sum_a = 0;
  for (Index v = 0; v < t.num_vertices; ++v) sum_k += K[v];
  for (Index f = 0; f < t.num_faces; ++f) sum_a += area[f];
  return sum_k + gauss_bonnet_lambda(g) * sum_a - 2 * kPi * static_cast<double>(t.euler_characteristic());
}

}  // namespace ricci
