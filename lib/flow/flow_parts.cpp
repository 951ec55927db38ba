// The solver's parts (flow_parts.h): their methods, and the shared helpers.
#include "flow_parts.h"

#include <cmath>
#include <limits>
#include <numbers>

#include "hessian.h"

namespace ricci::detail {

namespace {
constexpr double kEps = std::numeric_limits<double>::epsilon();
}  // namespace

// max |K̄ − K| over the masked vertices; +∞ if any of them is not finite.
double max_error(std::span<const double> K, std::span<const double> K_target,
                 const std::vector<std::uint8_t>& mask) {
  const auto n = static_cast<Index>(K.size());
  double e = 0;
#pragma omp parallel for schedule(static) if (n >= kParallelMin) reduction(max : e)
  for (Index v = 0; v < n; ++v) {
    if (!mask[v]) continue;
    const double d = std::abs(K_target[v] - K[v]);
    e = std::isfinite(d) ? std::max(e, d) : std::numeric_limits<double>::infinity();
  }
  return e;
}

// Breadth-first graph distances from `source` over the edges of the mesh (−1: unreached).
void graph_distances(const Topology& t, Index source, std::vector<Index>& distance,
                     std::vector<Index>& queue) {
  std::fill(distance.begin(), distance.end(), -1);
  queue.clear();
  distance[source] = 0;
  queue.push_back(source);
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const Index v = queue[head];
    for (Index i = t.vertex_corner_offsets[v]; i < t.vertex_corner_offsets[v + 1]; ++i) {
      const Index c = t.vertex_corners[i];
      for (const Index w : {t.corner_vertex[next_corner(c)], t.corner_vertex[prev_corner(c)]}) {
        if (distance[w] >= 0) continue;
        distance[w] = distance[v] + 1;
        queue.push_back(w);
      }
    }
  }
}

void VertexClasses::classify(const Topology& t, Geometry g, const Target& target, Method method) {
  const Index nv = t.num_vertices, nc = t.num_components;
  condition.assign(static_cast<std::size_t>(nv), 0);
  pinned.assign(static_cast<std::size_t>(nv), 0);
  vertex_component.assign(static_cast<std::size_t>(nv), kInvalid);
  std::vector<std::uint8_t> has_fixed(static_cast<std::size_t>(nc), 0),
      has_boundary(static_cast<std::size_t>(nc), 0);
  std::vector<std::int64_t> chi(static_cast<std::size_t>(nc), 0);
  for (Index v = 0; v < nv; ++v) {
    if (t.valence(v) == 0) continue;
    const Index c = t.face_component[corner_face(t.vertex_corners[t.vertex_corner_offsets[v]])];
    vertex_component[v] = c;
    const bool fixed = !target.fixed_u.empty() && target.fixed_u[v] != 0;
    condition[v] = fixed ? 0 : 1;
    if (fixed) has_fixed[c] = 1;
    if (t.is_boundary_vertex(v)) has_boundary[c] = 1;
    ++chi[c];
  }
  for (Index e = 0; e < t.num_edges; ++e) --chi[t.face_component[corner_face(t.edge_corners[2 * e])]];
  for (Index f = 0; f < t.num_faces; ++f) ++chi[t.face_component[f]];

  gauge_component.assign(static_cast<std::size_t>(nc), 0);
  component_sum.assign(static_cast<std::size_t>(nc), 0.0);
  component_count.assign(static_cast<std::size_t>(nc), 0);
  for (Index v = 0; v < nv; ++v)
    if (condition[v]) ++component_count[vertex_component[v]];

  if (g == Geometry::Euclidean) {
    for (Index c = 0; c < nc; ++c) gauge_component[c] = !has_fixed[c] && component_count[c] > 0;
    if (method == Method::Newton) {
      std::vector<std::uint8_t> done(static_cast<std::size_t>(nc), 0);
      for (Index v = 0; v < nv; ++v) {
        const Index c = vertex_component[v];
        if (!condition[v] || !gauge_component[c] || done[c]) continue;
        pinned[v] = 1;
        done[c] = 1;
      }
    }
  } else if (g == Geometry::Spherical && method == Method::Newton) {
    // The round sphere: closed, genus 0, no held u, K̄ = 0 at every vertex.
    std::vector<std::uint8_t> all_zero(static_cast<std::size_t>(nc), 1);
    for (Index v = 0; v < nv; ++v)
      if (vertex_component[v] != kInvalid && target.K[v] != 0) all_zero[vertex_component[v]] = 0;
    for (Index c = 0; c < nc; ++c)
      if (!has_fixed[c] && !has_boundary[c] && chi[c] == 2 && all_zero[c] && component_count[c] >= 4)
        choose_spherical_gauge(t, c);
  }

  unknown.assign(static_cast<std::size_t>(nv), 0);
  for (Index v = 0; v < nv; ++v) unknown[v] = condition[v] && !pinned[v];
}

void VertexClasses::choose_spherical_gauge(const Topology& t, Index component) {
  const Index nv = t.num_vertices;
  {
    const auto [a, b, c] = pin_hint;
    auto usable = [&](Index v) { return v >= 0 && v < nv && vertex_component[v] == component && condition[v]; };
    if (usable(a) && usable(b) && usable(c) && a != b && b != c && a != c) {
      for (const Index v : pin_hint) {
        pinned[v] = 1;
        spherical_pins.push_back(v);
      }
      spherical_gauge = true;
      return;
    }
  }
  Index v0 = kInvalid;
  for (Index v = 0; v < nv && v0 == kInvalid; ++v)
    if (vertex_component[v] == component) v0 = v;
  std::vector<Index> d0(static_cast<std::size_t>(nv)), d1(static_cast<std::size_t>(nv)), queue;
  graph_distances(t, v0, d0, queue);
  Index diameter = 0;
  for (Index v = 0; v < nv; ++v) diameter = std::max(diameter, d0[v]);
  // A quarter turn on the sphere is about half the graph diameter.
  const double quarter = 0.5 * diameter;
  Index v1 = kInvalid;
  double best = std::numeric_limits<double>::infinity();
  for (Index v = 0; v < nv; ++v) {
    if (d0[v] < 0 || v == v0) continue;
    const double score = std::abs(d0[v] - quarter);
    if (score < best) {
      best = score;
      v1 = v;
    }
  }
  graph_distances(t, v1, d1, queue);
  Index v2 = kInvalid;
  best = std::numeric_limits<double>::infinity();
  for (Index v = 0; v < nv; ++v) {
    if (d0[v] < 0 || v == v0 || v == v1) continue;
    const double score = std::abs(d0[v] - quarter) + std::abs(d1[v] - quarter);
    if (score < best) {
      best = score;
      v2 = v;
    }
  }
  if (v1 == kInvalid || v2 == kInvalid) return;
  for (const Index v : {v0, v1, v2}) {
    pinned[v] = 1;
    spherical_pins.push_back(v);
  }
  spherical_gauge = true;
}

void VertexClasses::remove_gauge_mean(const Topology& t, std::span<double> step, ChunkedSum& sum) {
  const Index nv = t.num_vertices, nc = t.num_components;
  bool any = false;
  for (Index c = 0; c < nc; ++c) {
    any = any || gauge_component[c];
    component_sum[c] = 0;
  }
  if (!any) return;
  if (nc == 1) {
    component_sum[0] = sum(nv, [&](std::int64_t v) { return condition[v] ? step[v] : 0.0; });
  } else {
    for (Index v = 0; v < nv; ++v)
      if (condition[v]) component_sum[vertex_component[v]] += step[v];
  }
  for (Index c = 0; c < nc; ++c)
    component_sum[c] = gauge_component[c] ? component_sum[c] / component_count[c] : 0;
#pragma omp parallel for schedule(static) if (nv >= kParallelMin)
  for (Index v = 0; v < nv; ++v)
    if (condition[v]) step[v] -= component_sum[vertex_component[v]];
}

// ∂l/∂u of each loop's outgoing edges at the current u (the derivative of the unified length
// formula of metric.h: F(l) = Q/D with F = l², sinh²(l/2) or sin²(l/2)).
void LoopTargetDerivative::at(const Topology& t, const ConformalStructure& s, std::span<const double> u,
                              std::span<const double> lengths) {
  circle_.assign(static_cast<std::size_t>(t.num_boundary_loops()),
                 InscribedCircle{std::numeric_limits<double>::quiet_NaN(), -1});
  radius_lengths_ = lengths.data();
  const double sigma =
      s.geometry == Geometry::Euclidean ? 0.0 : (s.geometry == Geometry::Hyperbolic ? 1.0 : -1.0);
  const double eps = s.epsilon;
  const Index positions = t.num_boundary_edges();
  for (Index p = 0; p < positions; ++p) {
    const Index e = t.corner_edge[t.boundary_corners[p]];
    const Index a = t.boundary_vertices[p];
    const Index b = t.edge_vertices[2 * e] == a ? t.edge_vertices[2 * e + 1] : t.edge_vertices[2 * e];
    const double ua = u[a], ub = u[b], eta = s.eta[e], l = lengths[e];
    const double xa = std::exp(2 * ua), xb = std::exp(2 * ub), xab = std::exp(ua + ub);
    const double q = 2 * eta * xab + eps * xa + eps * xb;
    const double da = 1 - sigma * eps * xa, db = 1 - sigma * eps * xb;
    const double ratio = q / (da * db);
    const double dratio_a = (2 * eta * xab + 2 * eps * xa) / (da * db) + ratio * (2 * sigma * eps * xa / da);
    const double dratio_b = (2 * eta * xab + 2 * eps * xb) / (da * db) + ratio * (2 * sigma * eps * xb / db);
    const double dF = s.geometry == Geometry::Euclidean
                          ? 2 * l
                          : (s.geometry == Geometry::Hyperbolic ? std::sinh(l) / 2 : std::sin(l) / 2);
    dl_du_[2 * p] = dratio_a / dF;
    dl_du_[2 * p + 1] = dratio_b / dF;
  }
}

// The loop's inscribed circle (radius 0 when its target is not the inscribed polygon), once per
// lengths at() was given.
InscribedCircle LoopTargetDerivative::loop_circle(const Topology& t, const Target& target, Geometry g,
                                                  std::span<const double> lengths, Index loop) {
  if (!inscribed_circle_loop(target, g, loop)) return {};
  const bool cached = lengths.data() == radius_lengths_ && static_cast<std::size_t>(loop) < circle_.size();
  if (cached && std::isnan(circle_[loop].radius)) circle_[loop] = inscribed_circle(t, loop, lengths);
  return cached ? circle_[loop] : inscribed_circle(t, loop, lengths);
}

// dK[p] = (∂K̄/∂u · x) at the vertex of boundary position p, for x given per vertex (#V).
void LoopTargetDerivative::apply(const Topology& t, const Target& target, Geometry g, std::span<const double> lengths,
                                 std::span<const double> x, std::span<double> dK) {
  for (Index loop = 0; loop < t.num_boundary_loops(); ++loop) {
    const Index begin = t.boundary_offsets[loop], end = t.boundary_offsets[loop + 1];
    double L = 0, dL = 0;
    for (Index p = begin; p < end; ++p) {
      const Index next = p + 1 < end ? p + 1 : begin;
      const double dl = dl_du_[2 * p] * x[t.boundary_vertices[p]] +
                        dl_du_[2 * p + 1] * x[t.boundary_vertices[next]];
      dl_[p] = dl;
      L += lengths[t.corner_edge[t.boundary_corners[p]]];
      dL += dl;
    }
    const double T = target.loop_total[loop];
    const InscribedCircle circle = loop_circle(t, target, g, lengths, loop);
    const double R = circle.radius;
    if (R > 0) {
      // The inscribed polygon: sin(α_j/2) = l_j/2R, so dα_j = (dl_j − l_j·dR/R)/(R·c_j) with
      // c_j = cos(α_j/2) (negative on a major arc), and Σ dα_j = 0 gives dR/R = Σ(dl_j/c_j) / Σ(l_j/c_j).
      double num = 0, den = 0;
      for (Index p = begin; p < end; ++p) {
        const double l = lengths[t.corner_edge[t.boundary_corners[p]]];
        const double c = circle.half_arc_cosine(p - begin, l);
        arc_[p] = c;
        num += dl_[p] / c;
        den += l / c;
      }
      const double dR_over_R = den != 0 && std::isfinite(den) ? num / den : 0.0;
      for (Index p = begin; p < end; ++p) {
        const double l = lengths[t.corner_edge[t.boundary_corners[p]]];
        arc_[p] = (dl_[p] - l * dR_over_R) / (R * arc_[p]);  // dα_p
      }
      const double sign = T > 0 ? 1.0 : -1.0;
      for (Index p = begin; p < end; ++p) {
        const Index before = p > begin ? p - 1 : end - 1;
        dK[p] = sign * 0.5 * (arc_[before] + arc_[p]);
      }
      continue;
    }
    for (Index p = begin; p < end; ++p) {
      const Index before = p > begin ? p - 1 : end - 1;
      const double m = 0.5 * (lengths[t.corner_edge[t.boundary_corners[before]]] +
                              lengths[t.corner_edge[t.boundary_corners[p]]]);
      const double dm = 0.5 * (dl_[before] + dl_[p]);
      dK[p] = T / L * (dm - m * dL / L);
    }
  }
}

// The split of apply()'s derivative. With dl_p = g_p·(x_p + x_p') (g_p the common derivative of
// edge p's length in the u of its ends):
//   inscribed polygon (R > 0): dK_p = (s/2)·(dα_{p−1} + dα_p), dα_j = (dl_j − l_j·ρ)/(R c_j),
//     ρ = Σ_j (dl_j/c_j)/D, D = Σ_j l_j/c_j, s the sign of the total: the loop-local part has
//     w_j = (s/2)·g_j/(R c_j) per edge, and −(s/2)·h_p·ρ, h_p = l_{p−1}/(R c_{p−1}) + l_p/(R c_p),
//     is a_p = −(s/(2D))·h_p times bᵀx, b_q = g_{q−1}/c_{q−1} + g_q/c_q;
//   proportional to length: dK_p = T/L·(½(dl_{p−1} + dl_p) − m_p·dL/L): w_j = T/(2L)·g_j, and
//     a_p = −T·m_p/L², b_q = g_{q−1} + g_q.
bool LoopTargetDerivative::split(const Topology& t, const Target& target, Geometry g, std::span<const double> lengths,
                                 std::vector<double>& w, std::vector<double>& a, std::vector<double>& b) {
  const auto positions = static_cast<std::size_t>(t.num_boundary_edges());
  w.assign(positions, 0.0);
  a.assign(positions, 0.0);
  b.assign(positions, 0.0);
  for (std::size_t p = 0; p < positions; ++p)
    if (!(dl_du_[2 * p] == dl_du_[2 * p + 1]) || !std::isfinite(dl_du_[2 * p])) return false;
  auto edge_length = [&](Index p) { return lengths[t.corner_edge[t.boundary_corners[p]]]; };
  for (Index loop = 0; loop < t.num_boundary_loops(); ++loop) {
    const Index begin = t.boundary_offsets[loop], end = t.boundary_offsets[loop + 1];
    if (end - begin < 3) return false;
    const double T = target.loop_total[loop];
    const InscribedCircle circle = loop_circle(t, target, g, lengths, loop);
    const double R = circle.radius;
    if (R > 0) {
      double D = 0;
      for (Index p = begin; p < end; ++p) {
        arc_[p] = circle.half_arc_cosine(p - begin, edge_length(p));  // c_p
        D += edge_length(p) / arc_[p];
      }
      const double sign = T > 0 ? 1.0 : -1.0;
      for (Index p = begin; p < end; ++p) {
        const Index before = p > begin ? p - 1 : end - 1;
        w[p] = sign * 0.5 * dl_du_[2 * p] / (R * arc_[p]);
        a[p] = -sign / (2 * D) * (edge_length(before) / (R * arc_[before]) + edge_length(p) / (R * arc_[p]));
        b[p] = dl_du_[2 * before] / arc_[before] + dl_du_[2 * p] / arc_[p];
      }
    } else {
      double L = 0;
      for (Index p = begin; p < end; ++p) L += edge_length(p);
      for (Index p = begin; p < end; ++p) {
        const Index before = p > begin ? p - 1 : end - 1;
        w[p] = T / (2 * L) * dl_du_[2 * p];
        a[p] = -T / (L * L) * 0.5 * (edge_length(before) + edge_length(p));
        b[p] = dl_du_[2 * before] + dl_du_[2 * p];
      }
    }
  }
  for (std::size_t p = 0; p < positions; ++p)
    if (!std::isfinite(w[p]) || !std::isfinite(a[p]) || !std::isfinite(b[p])) return false;
  return true;
}

// resolution_v = ε·Σ over the corners at v of Σ_b |∂θ/∂u_b|·(1 + |u_b|), from the derivative
// blocks (of u): the rounding of each length (its log carries ε·(1 + |u|)) seen
// through the angles' sensitivity to it.
void CurvatureResolution::update(const Topology& t, const std::vector<double>& blocks, std::span<const double> u,
                                 const std::vector<std::uint8_t>& condition, double tolerance) {
  const Index nv = t.num_vertices;
  values.resize(static_cast<std::size_t>(nv));
  double most = 0;
  Index count = 0;
#pragma omp parallel for schedule(static) if (nv >= kParallelMin) reduction(max : most) reduction(+ : count)
  for (Index v = 0; v < nv; ++v) {
    double sum = 0;
    for (Index i = t.vertex_corner_offsets[v]; i < t.vertex_corner_offsets[v + 1]; ++i) {
      const Index c = t.vertex_corners[i], f = c / 3;
      const double* row = &blocks[9 * static_cast<std::size_t>(f) + 3 * static_cast<std::size_t>(c - 3 * f)];
      for (int b = 0; b < 3; ++b) sum += std::abs(row[b]) * (1 + std::abs(u[t.corner_vertex[3 * f + b]]));
    }
    values[v] = kEps * sum;
    if (condition[v] && values[v] > tolerance) {
      most = std::max(most, values[v]);
      ++count;
    }
  }
  active = count > 0;
  current = true;
  if (active) {
    largest = most;
    vertices = count;
  }
}

double CurvatureResolution::judged_error(std::span<const double> K, std::span<const double> target,
                                         const std::vector<std::uint8_t>& condition, double tolerance) const {
  if (!active) return max_error(K, target, condition);
  const auto n = static_cast<Index>(K.size());
  double e = 0;
#pragma omp parallel for schedule(static) if (n >= kParallelMin) reduction(max : e)
  for (Index v = 0; v < n; ++v) {
    if (!condition[v]) continue;
    double d = std::abs(target[v] - K[v]);
    if (values[v] > tolerance) d *= tolerance / values[v];
    e = std::isfinite(d) ? std::max(e, d) : std::numeric_limits<double>::infinity();
  }
  return e;
}

void CircleDomainModes::setup(const Topology& t, const Target& target, std::span<const double> l,
                              const std::vector<std::uint8_t>& condition, std::span<const double> u) {
  Index outer = kInvalid;
  for (Index loop = 0; loop < t.num_boundary_loops(); ++loop)
    if (target.loop_total[loop] > 0 && (outer == kInvalid || target.loop_total[loop] > target.loop_total[outer]))
      outer = loop;
  if (outer == kInvalid) return;
  const Index begin = t.boundary_offsets[outer], end = t.boundary_offsets[outer + 1];
  const Index count = end - begin;
  if (count < 4) return;
  a.assign(static_cast<std::size_t>(count), 0.0);
  b.assign(static_cast<std::size_t>(count), 0.0);
  norm_c.assign(static_cast<std::size_t>(count), 0.0);
  norm_s.assign(static_cast<std::size_t>(count), 0.0);
  double L = 0;
  for (Index p = begin; p < end; ++p) L += l[t.corner_edge[t.boundary_corners[p]]];
  if (!(L > 0)) return;
  std::vector<double> theta(static_cast<std::size_t>(count)), w(static_cast<std::size_t>(count));
  double arc = 0;
  for (Index p = begin; p < end; ++p) {
    const double out = l[t.corner_edge[t.boundary_corners[p]]];
    const double in = l[t.corner_edge[t.boundary_corners[p > begin ? p - 1 : end - 1]]];
    theta[p - begin] = 2 * std::numbers::pi * arc / L;
    w[p - begin] = 0.5 * (in + out);
    arc += out;
  }
  double mean_c = 0, mean_s = 0, wc = 0, ws = 0, wsum = 0;
  for (Index i = 0; i < count; ++i) {
    mean_c += std::cos(theta[i]);
    mean_s += std::sin(theta[i]);
    wc += w[i] * std::cos(theta[i]);
    ws += w[i] * std::sin(theta[i]);
    wsum += w[i];
  }
  mean_c /= count;
  mean_s /= count;
  wc /= wsum;
  ws /= wsum;
  for (Index i = 0; i < count; ++i) {
    const Index v = t.boundary_vertices[begin + i];
    if (!condition[v]) return;  // every vertex of a Circle loop has a curvature condition
    vertices.push_back(v);
    a[i] = std::cos(theta[i]) - mean_c;
    b[i] = std::sin(theta[i]) - mean_s;
    norm_c[i] = w[i] * (std::cos(theta[i]) - wc);
    norm_s[i] = w[i] * (std::sin(theta[i]) - ws);
  }
  norm_c0 = norm_s0 = 0;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    norm_c0 += norm_c[i] * u[vertices[i]];
    norm_s0 += norm_s[i] * u[vertices[i]];
  }
  active = true;
}

void CircleDomainModes::scatter(int k, std::span<double> full) const {
  std::fill(full.begin(), full.end(), 0.0);
  const std::vector<double>& mode = k == 0 ? a : b;
  for (std::size_t i = 0; i < vertices.size(); ++i) full[vertices[i]] = mode[i];
}

void CircleDomainModes::add(double alpha_now, double beta_now, std::span<double> K_target) const {
  for (std::size_t i = 0; i < vertices.size(); ++i) K_target[vertices[i]] += alpha_now * a[i] + beta_now * b[i];
}

}  // namespace ricci::detail
