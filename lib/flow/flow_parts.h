// The parts of the flow's Newton solver (flow.cpp) that each own one concern, with their state:
// which vertices carry conditions and move, and the gauge (VertexClasses); the boundary system's
// restarted GMRES (RestartedGmres); ∂K̄/∂u of targets that follow the lengths
// (LoopTargetDerivative); what each vertex's curvature resolves (CurvatureResolution); the
// circle-domain normalization (CircleDomainModes); and the deterministic parallel sum they share.
//
// Takes: a topology, a structure, a target and the solver's current u and lengths, per call.
// Gives: flags, scratch and small results the solver reads; no part solves the Newton system.
// Internal to the flow stage.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "ricci/flow.h"
#include "ricci/metric.h"
#include "ricci/topology.h"

namespace ricci::detail {

// Sums in fixed chunks, the chunks added in order: the same bits for any thread count.
class ChunkedSum {
 public:
  static constexpr std::int64_t kChunk = 4096;
  explicit ChunkedSum(std::int64_t max_n) : partial_(static_cast<std::size_t>(max_n / kChunk + 1), 0.0) {}

  template <class Term>
  double operator()(std::int64_t n, Term term) {
    const std::int64_t chunks = (n + kChunk - 1) / kChunk;
    double* partial = partial_.data();
#pragma omp parallel for schedule(static) if (chunks > 1)
    for (std::int64_t c = 0; c < chunks; ++c) {
      const std::int64_t end = std::min(n, (c + 1) * kChunk);
      double s = 0;
      for (std::int64_t i = c * kChunk; i < end; ++i) s += term(i);
      partial[c] = s;
    }
    double total = 0;
    for (std::int64_t c = 0; c < chunks; ++c) total += partial[c];
    return total;
  }

 private:
  std::vector<double> partial_;
};

// max |K̄ − K| over the masked vertices; +∞ if any of them is not finite.
double max_error(std::span<const double> K, std::span<const double> K_target,
                 const std::vector<std::uint8_t>& mask);

// Breadth-first graph distances from `source` over the edges of the mesh (−1: unreached).
void graph_distances(const Topology& t, Index source, std::vector<Index>& distance,
                     std::vector<Index>& queue);

constexpr int kGmresRestart = 40;

// Which vertices of a flow problem carry a curvature condition, which of them move in the Newton
// system, and the gauge: a euclidean component without a held u keeps Σu (Newton pins one of its
// vertices); the round sphere (S, closed genus 0, K̄ = 0, Newton) pins three vertices for its
// Möbius gauge (pin_hint when usable, else three vertices about a quarter turn apart). Set once
// per solve by classify().
struct VertexClasses {
  std::vector<std::uint8_t> condition;        // has a curvature condition
  std::vector<std::uint8_t> unknown;          // moves in the Newton system
  std::vector<std::uint8_t> pinned;           // gauge-pinned (a condition vertex that is not an unknown)
  std::vector<Index> vertex_component;        // kInvalid for vertices used by no face
  std::vector<std::uint8_t> gauge_component;  // E: Σu of the component is held
  std::vector<double> component_sum;
  std::vector<Index> component_count;
  bool spherical_gauge = false;
  std::vector<Index> spherical_pins;
  std::array<Index, 3> pin_hint = {kInvalid, kInvalid, kInvalid};

  void classify(const Topology& t, Geometry g, const Target& target, Method method);
  // Removes each euclidean gauge component's mean from a step over its condition vertices.
  void remove_gauge_mean(const Topology& t, std::span<double> step, ChunkedSum& sum);

 private:
  void choose_spherical_gauge(const Topology& t, Index component);
};

// Restarted GMRES (modified Gram–Schmidt, Givens rotations, restart kGmresRestart) for a linear
// system given by its operator apply(x, out), from w = 0; serial and in a fixed order. It keeps its
// workspace between solves: `b` (the right-hand side) in, `w` (the solution) out.
class RestartedGmres {
 public:
  std::vector<double> b, w;
  void resize(std::size_t P) {
    const std::size_t m = kGmresRestart;
    basis_.assign((m + 1) * P, 0.0);
    hessenberg_.assign((m + 1) * m, 0.0);
    cos_.assign(m, 0.0);
    sin_.assign(m, 0.0);
    residual_.assign(m + 1, 0.0);
    y_.assign(m, 0.0);
    b.assign(P, 0.0);
    w.assign(P, 0.0);
    v_.assign(P, 0.0);
  }
  // False when the relative residual is not reached or a value is not finite (the true residual
  // of w decides, within 10× the tolerance).
  template <class Apply>
  bool solve(Apply&& apply, double relative_tolerance, int max_iterations);

 private:
  std::vector<double> basis_, hessenberg_, cos_, sin_, residual_, y_, v_;
};

// ∂K̄/∂u of Circle and LoopTotals targets, whose boundary values follow the lengths (the coupling
// notes in flow.cpp): per boundary position p (the CSR order of Topology::boundary_vertices), ∂l/∂u of
// its outgoing edge at its two ends, taken at a metric by at(); apply() maps a change x of u (#V)
// to the change of K̄ at every position.
class LoopTargetDerivative {
 public:
  void resize(std::size_t positions) {
    dl_du_.assign(2 * positions, 0.0);
    dl_.assign(positions, 0.0);
    arc_.assign(positions, 0.0);
  }
  void at(const Topology& t, const ConformalStructure& s, std::span<const double> u, std::span<const double> lengths);
  void apply(const Topology& t, const Target& target, Geometry g, std::span<const double> lengths,
             std::span<const double> x, std::span<double> dK);
  // The same derivative split (after at()) where every loop edge's length has the same derivative
  // in the u of its two ends (vertex scaling): ∂K̄/∂u = Σ_p w_p (e_p + e_p')(e_p + e_p')ᵀ +
  // Σ_loops a bᵀ, e_p and e_p' the vertices of position p and of the next one on its loop (its
  // outgoing edge); w, a and b per position (a and b zero off their loop). False where the two
  // ends' derivatives differ or a value is not finite.
  bool split(const Topology& t, const Target& target, Geometry g, std::span<const double> lengths,
             std::vector<double>& w, std::vector<double>& a, std::vector<double>& b);

 private:
  InscribedCircle loop_circle(const Topology& t, const Target& target, Geometry g, std::span<const double> lengths,
                              Index loop);
  std::vector<double> dl_du_, dl_;
  std::vector<double> arc_;  // per position: scratch of apply()
  // Per loop, the inscribed circle at the lengths at() was given (radius NaN until apply() first
  // needs it): it depends on the lengths alone, and the boundary system applies this derivative
  // once per boundary position in a step.
  std::vector<InscribedCircle> circle_;
  const double* radius_lengths_ = nullptr;
};

// How finely each vertex's curvature is resolved in double precision (see the design notes at the
// top of flow.cpp): values at the last u whose angle derivative blocks were read, whether some condition
// vertex resolves less than the tolerance (active), and the error judged with it.
struct CurvatureResolution {
  std::vector<double> values;  // #V
  bool active = false;
  bool current = false;  // values are those of the solver's current u
  double largest = 0;    // the largest value above the tolerance, and how many vertices are above it
  Index vertices = 0;

  void update(const Topology& t, const std::vector<double>& blocks, std::span<const double> u,
              const std::vector<std::uint8_t>& condition, double tolerance);
  // max |K̄ − K| over the condition vertices, each scaled by min(1, tolerance / values[v]) when active.
  double judged_error(std::span<const double> K, std::span<const double> target,
                      const std::vector<std::uint8_t>& condition, double tolerance) const;
};

// The circle-domain normalization (see "Circle domains" in flow.cpp; E, genus 0, Circle targets,
// Newton): modes a, b and normalization rows n_c, n_s per vertex (#V, zero off the outer loop),
// their coefficients α, β (current, step, trial), and the workspace of the bordered solve.
struct CircleDomainModes {
  bool active = false;
  std::vector<Index> vertices;  // the outer loop's, in its order
  // Per vertex of the loop (as `vertices`): the modes a, b and the normalization's rows n_c, n_s
  // (all zero off the loop).
  std::vector<double> a, b, norm_c, norm_s;
  double norm_c0 = 0, norm_s0 = 0;  // n·u at the start
  double alpha = 0, beta = 0, d_alpha = 0, d_beta = 0, alpha_trial = 0, beta_trial = 0;
  double largest = 0;  // max over the run of max |α a + β b| / |the effective target without modes|
  int failures = 0;    // steps without the modes (singular 2×2 system)

  // Sets the modes up on the outer loop (the loop of largest positive total) at lengths l and u;
  // active stays false when there is none or a vertex of it has no curvature condition.
  void setup(const Topology& t, const Target& target, std::span<const double> l,
             const std::vector<std::uint8_t>& condition, std::span<const double> u);
  // Mode k (0: a, 1: b) over all vertices, into `full` (#V).
  void scatter(int k, std::span<double> full) const;
  // K_target += α a + β b on the outer loop.
  void add(double alpha_now, double beta_now, std::span<double> K_target) const;
};

template <class Apply>
bool RestartedGmres::solve(Apply&& apply, double relative_tolerance, int max_iterations) {
  const std::size_t P = b.size();
  const std::size_t m = kGmresRestart;
  auto dot = [&](const double* x, const double* y) {
    double s = 0;
    for (std::size_t i = 0; i < P; ++i) s += x[i] * y[i];
    return s;
  };
  std::fill(w.begin(), w.end(), 0.0);
  const double b_norm = std::sqrt(dot(b.data(), b.data()));
  if (!std::isfinite(b_norm)) return false;
  if (b_norm == 0) return true;
  const double target = relative_tolerance * b_norm;
  int iterations = 0;
  while (iterations < max_iterations) {
    // r = b − A w into the first basis vector.
    double* v0 = basis_.data();
    apply(w, {v0, P});
    for (std::size_t i = 0; i < P; ++i) v0[i] = b[i] - v0[i];
    const double beta = std::sqrt(dot(v0, v0));
    if (!std::isfinite(beta)) return false;
    if (beta <= target) break;
    for (std::size_t i = 0; i < P; ++i) v0[i] /= beta;
    std::fill(residual_.begin(), residual_.end(), 0.0);
    residual_[0] = beta;
    std::size_t k = 0;
    double residual = beta;
    for (; k < m && iterations < max_iterations; ++k) {
      ++iterations;
      double* vk = basis_.data() + k * P;
      double* vn = basis_.data() + (k + 1) * P;
      apply({vk, P}, {vn, P});
      double* h = hessenberg_.data() + k * (m + 1);  // column k
      for (std::size_t i = 0; i <= k; ++i) {
        const double* vi = basis_.data() + i * P;
        h[i] = dot(vn, vi);
        for (std::size_t r = 0; r < P; ++r) vn[r] -= h[i] * vi[r];
      }
      h[k + 1] = std::sqrt(dot(vn, vn));
      if (!std::isfinite(h[k + 1])) return false;
      if (h[k + 1] > 0)
        for (std::size_t r = 0; r < P; ++r) vn[r] /= h[k + 1];
      for (std::size_t i = 0; i < k; ++i) {
        const double a = cos_[i] * h[i] + sin_[i] * h[i + 1];
        h[i + 1] = -sin_[i] * h[i] + cos_[i] * h[i + 1];
        h[i] = a;
      }
      const double rho = std::hypot(h[k], h[k + 1]);
      if (!(rho > 0)) return false;
      cos_[k] = h[k] / rho;
      sin_[k] = h[k + 1] / rho;
      h[k] = rho;
      h[k + 1] = 0;
      residual_[k + 1] = -sin_[k] * residual_[k];
      residual_[k] *= cos_[k];
      residual = std::abs(residual_[k + 1]);
      if (residual <= target) {
        ++k;
        break;
      }
    }
    // w += V y with H y = residual (upper triangular, k columns).
    for (std::size_t i = k; i-- > 0;) {
      double x = residual_[i];
      for (std::size_t j = i + 1; j < k; ++j) x -= hessenberg_[j * (m + 1) + i] * y_[j];
      y_[i] = x / hessenberg_[i * (m + 1) + i];
    }
    for (std::size_t i = 0; i < k; ++i) {
      const double* vi = basis_.data() + i * P;
      for (std::size_t r = 0; r < P; ++r) w[r] += y_[i] * vi[r];
    }
    if (residual <= target) break;
  }
  for (double x : w)
    if (!std::isfinite(x)) return false;
  // The true residual decides.
  apply(w, v_);
  double r2 = 0;
  for (std::size_t i = 0; i < P; ++i) r2 += (b[i] - v_[i]) * (b[i] - v_[i]);
  return std::isfinite(r2) && std::sqrt(r2) <= 10 * target;
}

}  // namespace ricci::detail
