// Deck transformations: Möbius algebra of the Poincaré disk, the side-pairing generators of a
// laid-out canonical polygon (E: translations; H: SU(1,1) maps fitted with Ceres) and the
// surface-group relation. Conventions and the relation: ricci/deck.h.
#include "ricci/deck.h"

#include "ceres_quiet.h"

#include <algorithm>
#include <array>
#include <cfenv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <utility>

#include <ceres/ceres.h>
#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "moebius_quad.h"

namespace ricci {

using cplx = std::complex<double>;

// ---- Möbius ---------------------------------------------------------------------------------

Moebius Moebius::from_theta_z0(double theta, cplx z0) {
  const double r = std::abs(z0);
  const double s = std::sqrt((1 - r) * (1 + r));
  const cplx e = std::polar(1.0, theta / 2);
  return {e / s, -e * z0 / s};
}

Moebius Moebius::rotation(double theta) { return {std::polar(1.0, theta / 2), 0.0}; }

Moebius Moebius::translation_real(double d) { return {std::cosh(d / 2), std::sinh(d / 2)}; }

Moebius Moebius::to_origin(cplx p) { return from_theta_z0(0, p); }

cplx Moebius::apply(cplx z) const { return (a * z + b) / (std::conj(b) * z + std::conj(a)); }

double Moebius::one_minus_abs2_of_image(cplx z, double one_minus_abs2_z) const {
  return one_minus_abs2_z / std::norm(std::conj(b) * z + std::conj(a));
}

Moebius Moebius::normalized() const {
  const double det = std::norm(a) - std::norm(b);
  if (!(det > 0)) return *this;
  const double s = std::sqrt(det);
  return {a / s, b / s};
}

double Moebius::theta() const {
  double t = 2 * std::arg(a);  // (−2π, 2π]
  if (t > M_PI) t -= 2 * M_PI;
  if (t <= -M_PI) t += 2 * M_PI;
  return t;
}

cplx Moebius::z0() const { return -b / a; }

double Moebius::translation_length() const {
  const double x = std::abs(a.real());
  return x <= 1 ? 0.0 : 2 * std::acosh(x);
}

Moebius operator*(const Moebius& m, const Moebius& n) {
  // [[a, b], [b̄, ā]] · [[c, d], [d̄, c̄]] = [[ac + b d̄, ad + b c̄], …]
  return {m.a * n.a + m.b * std::conj(n.b), m.a * n.b + m.b * std::conj(n.a)};
}

double moebius_difference(const Moebius& m, const Moebius& n) {
  const double minus = std::max(std::abs(m.a - n.a), std::abs(m.b - n.b));
  const double plus = std::max(std::abs(m.a + n.a), std::abs(m.b + n.b));
  return std::min(minus, plus);
}

double distance_to_identity(const Moebius& m) { return moebius_difference(m, Moebius{}); }

namespace {

double one_minus_abs2(cplx z) {
  const double r = std::abs(z);
  return (1 - r) * (1 + r);
}

}  // namespace

double hyperbolic_distance(cplx z, cplx w) {
  const double oz = one_minus_abs2(z), ow = one_minus_abs2(w);
  if (!(oz > 0) || !(ow > 0)) return std::numeric_limits<double>::infinity();
  const cplx den = 1.0 - std::conj(w) * z;
  const double x = std::abs(z - w) / std::abs(den);
  if (x < 0.5) return 2 * std::atanh(x);
  // 2 artanh x = log((1 + x)² / (1 − x²)) with 1 − x² from the exact identity.
  const double one_minus_x2 = oz * ow / std::norm(den);
  return 2 * std::log1p(x) - std::log(one_minus_x2);
}

Moebius moebius_from_two_points(cplx z1, cplx z2, cplx w1, cplx w2) {
  const Moebius pz = Moebius::to_origin(z1), pw = Moebius::to_origin(w1);
  const cplx z2p = pz.apply(z2), w2p = pw.apply(w2);
  if (std::abs(z2p) == 0 || std::abs(w2p) == 0) return pw.inverse() * pz;
  const double psi = std::arg(w2p) - std::arg(z2p);
  return (pw.inverse() * Moebius::rotation(psi) * pz).normalized();
}

// ---- options and reports ------------------------------------------------------------------

bool DeckOptions::is_valid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (max_iterations < 1) return fail("DeckOptions::max_iterations must be at least 1.");
  if (!(function_tolerance >= 0) || !(gradient_tolerance >= 0) || !(parameter_tolerance >= 0))
    return fail("DeckOptions tolerances must be finite and non-negative.");
  if (!std::isfinite(function_tolerance) || !std::isfinite(gradient_tolerance) ||
      !std::isfinite(parameter_tolerance))
    return fail("DeckOptions tolerances must be finite and non-negative.");
  if (rounds < 1 || rounds > 10) return fail("DeckOptions::rounds must be in 1..10.");
  if (!(max_pairing_adjustment > 0)) return fail("DeckOptions::max_pairing_adjustment must be > 0.");
  return true;
}

std::string DeckResult::brief_report() const {
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "deck: %s, %s, genus %d, %d generators, residual max %.3g, single-edge spread %.3g, "
                "relation error %.3g, %d Ceres iterations, %.3f s",
                status == Status::Ok ? "ok" : std::string(status_name(status)).c_str(),
                std::string(geometry_name(geometry)).c_str(), static_cast<int>(genus),
                static_cast<int>(generators.size()), residual_max, single_edge_spread, relation_error,
                ceres_iterations, seconds);
  return buf;
}

// ---- the fit --------------------------------------------------------------------------------

namespace {

/// Residual of one vertex pair for M = M0 · N(δ), δ = (θ, x0, y0), N(δ) = e^{iθ}(z − z₀)/(1 − z̄₀z):
/// the vector (d/x)·u with u = (M(z) − w)/(1 − w̄ M(z)), x = |u|, d = 2 artanh x, so its length is
/// the hyperbolic distance d(M(z), w) and it is smooth at u = 0.
struct PairResidual {
  cplx m0a, m0b, z, w;
  double oz, ow;  // 1 − |z|², 1 − |w|²

  template <typename T>
  bool operator()(const T* const delta, T* residual) const {
    const T th = delta[0], x0 = delta[1], y0 = delta[2];
    const T s2 = T(1) - x0 * x0 - y0 * y0;
    if (!(s2 > T(0))) return false;
    const T s = sqrt(s2);
    const T er = cos(th / T(2)) / s, ei = sin(th / T(2)) / s;
    // N: a = e/s, b = −e z0/s.
    const T na_r = er, na_i = ei;
    const T nb_r = -(er * x0 - ei * y0), nb_i = -(er * y0 + ei * x0);
    // M = M0 · N: a = m0a na + m0b conj(nb), b = m0a nb + m0b conj(na).
    const double A = m0a.real(), Ai = m0a.imag(), B = m0b.real(), Bi = m0b.imag();
    const T ma_r = A * na_r - Ai * na_i + B * nb_r + Bi * nb_i;
    const T ma_i = A * na_i + Ai * na_r + Bi * nb_r - B * nb_i;
    const T mb_r = A * nb_r - Ai * nb_i + B * na_r + Bi * na_i;
    const T mb_i = A * nb_i + Ai * nb_r + Bi * na_r - B * na_i;
    // M(z) = (a z + b)/(b̄ z + ā).
    const double zr = z.real(), zi = z.imag();
    const T num_r = ma_r * zr - ma_i * zi + mb_r, num_i = ma_r * zi + ma_i * zr + mb_i;
    const T den_r = mb_r * zr + mb_i * zi + ma_r, den_i = mb_r * zi - mb_i * zr - ma_i;
    const T dd = den_r * den_r + den_i * den_i;
    const T p_r = (num_r * den_r + num_i * den_i) / dd, p_i = (num_i * den_r - num_r * den_i) / dd;
    const T op = T(oz) / dd;  // 1 − |M(z)|²
    // u = (p − w)/(1 − w̄ p).
    const double wr = w.real(), wi = w.imag();
    const T n_r = p_r - wr, n_i = p_i - wi;
    const T q_r = T(1) - (wr * p_r + wi * p_i), q_i = -(wr * p_i - wi * p_r);
    const T qq = q_r * q_r + q_i * q_i;
    const T u_r = (n_r * q_r + n_i * q_i) / qq, u_i = (n_i * q_r - n_r * q_i) / qq;
    const T x2 = u_r * u_r + u_i * u_i;
    T scale;
    if (x2 < T(1e-3)) {
      // d/x = 2 artanh(x)/x = 2 Σ x^{2k}/(2k+1), to x^12 (error < 1e-21).
      scale = T(2) * (T(1) + x2 * (T(1.0 / 3) + x2 * (T(1.0 / 5) + x2 * (T(1.0 / 7) +
                      x2 * (T(1.0 / 9) + x2 * (T(1.0 / 11) + x2 * T(1.0 / 13)))))));
    } else {
      const T x = sqrt(x2);
      const T one_minus_x2 = op * T(ow) / qq;
      scale = (T(2) * log(T(1) + x) - log(one_minus_x2)) / x;
    }
    residual[0] = scale * u_r;
    residual[1] = scale * u_i;
    return true;
  }
};

struct Pair {
  cplx z, w;
};

struct SidePairs {
  std::string name;
  Index side = -1, partner = -1;
  std::vector<Pair> pairs;
};

using detail::CQ;
using detail::MoebiusQ;

/// A rigid motion z ↦ c z + t (|c| = 1) for the euclidean relation check.
struct Rigid {
  cplx c{1, 0}, t{0, 0};
  cplx apply(cplx z) const { return c * z + t; }
  Rigid inverse() const { return {std::conj(c), -std::conj(c) * t}; }
};
Rigid operator*(const Rigid& m, const Rigid& n) { return {m.c * n.c, m.c * n.t + m.t}; }

/// Ends a fit once a step, taken or tried, is below the rounding of the parameters (θ and z0 of a
/// map near the identity in frames centred on the sides, where a change of 2^-50 moves the side's
/// points by a few units in their last place). The tolerances alone never end it there: the cost
/// is then rounding noise, steps are accepted and rejected at random, and the trust region shrinks
/// to its minimum over ~40 more iterations (113 fits of a genus-20 surface: 9.4k iterations, 4.5 of
/// them useful per fit).
class StopAtRounding : public ceres::IterationCallback {
 public:
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    constexpr double kRoundingStep = 0x1p-50;
    return s.iteration > 0 && s.step_norm <= kRoundingStep ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }
};

/// Fits the Möbius map X taking z to w over all pairs (H): the two-point start from the end
/// pairs, then Levenberg–Marquardt rounds in frames centred on the two sides; fills the map,
/// residuals and single-edge spread of G. False when the result is not finite.
bool fit_hyperbolic(const std::vector<Pair>& pairs, const DeckOptions& options, DeckGenerator& G,
                    int& ceres_iterations) {
  const std::size_t n = pairs.size();
  // Work in frames centred on the two sides: X = Cp^-1 · M · Cs with Cs, Cp moving the
  // sides' middle vertices to the origin. There the points are far from the unit circle and M
  // has small entries, so residuals are evaluated without cancellation (a layout point at
  // 1 − |z| ≈ 1e-7 mapped by X directly loses ~1e-7 of hyperbolic accuracy; centred, only
  // the resolution of its input coordinates, ≈ 1e-16/(1 − |z|), remains).
  const std::size_t mid = n / 2;
  const Moebius Cs = Moebius::to_origin(pairs[mid].z), Cp = Moebius::to_origin(pairs[mid].w);
  std::vector<Pair> local(n);
  for (std::size_t k = 0; k < n; ++k) local[k] = {Cs.apply(pairs[k].z), Cp.apply(pairs[k].w)};
  // Closed-form start from the side's end vertices (farthest apart), then Ceres.
  Moebius M = moebius_from_two_points(local.front().z, local.back().z, local.front().w, local.back().w);
  double sum0 = 0;
  for (const Pair& p : local) {
    const double d = hyperbolic_distance(M.apply(p.z), p.w);
    G.initial_residual_max = std::max(G.initial_residual_max, d);
    sum0 += d * d;
  }
  G.initial_residual_rms = std::sqrt(sum0 / double(n));
  for (int round = 0; round < options.rounds; ++round) {
    double delta[3] = {0, 0, 0};
    ceres::Problem::Options popts;
    ceres::Problem problem(popts);
    for (const Pair& p : local) {
      auto* cost = new ceres::AutoDiffCostFunction<PairResidual, 2, 3>(
          new PairResidual{M.a, M.b, p.z, p.w, one_minus_abs2(p.z), one_minus_abs2(p.w)});
      problem.AddResidualBlock(cost, nullptr, delta);
    }
    ceres::Solver::Options sopts;
    sopts.linear_solver_type = ceres::DENSE_QR;
    sopts.minimizer_type = ceres::TRUST_REGION;
    sopts.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    sopts.max_num_iterations = options.max_iterations;
    sopts.function_tolerance = options.function_tolerance;
    sopts.gradient_tolerance = options.gradient_tolerance;
    sopts.parameter_tolerance = options.parameter_tolerance;
    sopts.logging_type = ceres::SILENT;
    sopts.minimizer_progress_to_stdout = false;
    sopts.num_threads = 1;
    StopAtRounding at_rounding;
    sopts.callbacks.push_back(&at_rounding);
    ceres::Solver::Summary summary;
    detail::quiet_solve(sopts, &problem, &summary);
    ceres_iterations += static_cast<int>(summary.iterations.size());
    // A round that cannot improve (Ceres FAILURE after consecutive invalid steps at the
    // optimum, or a non-finite update) keeps the current map: it is valid, and the residuals
    // below are measured independently of Ceres.
    const bool improved = std::isfinite(delta[0]) && std::isfinite(delta[1]) && std::isfinite(delta[2]) &&
                          delta[1] * delta[1] + delta[2] * delta[2] < 1 &&
                          summary.final_cost <= summary.initial_cost;
    if (!improved) break;
    M = (M * Moebius::from_theta_z0(delta[0], {delta[1], delta[2]})).normalized();
    if (summary.termination_type != ceres::CONVERGENCE && summary.termination_type != ceres::USER_SUCCESS) break;
  }
  // X = Cp^-1 · M · Cs, the product taken in quad of the very maps the local points came from,
  // kept as map + map_low. Cs and Cp have entries of size e^{r/2} for sides at distance r from
  // the origin, so X rounded to double misplaces the side's own points by about ε·e^{2r} (sides
  // at r ≈ 14: 1e-4, where the fit is good to 1e-10).
  detail::set_quad_map(G, (MoebiusQ(Cp).inverse() * MoebiusQ(M) * MoebiusQ(Cs)).normalized());
  double sum2 = 0;
  for (const Pair& p : local) {
    const double d = hyperbolic_distance(M.apply(p.z), p.w);
    G.residual_max = std::max(G.residual_max, d);
    sum2 += d * d;
  }
  G.residual_rms = std::sqrt(sum2 / double(n));
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const Moebius E = moebius_from_two_points(local[k].z, local[k + 1].z, local[k].w, local[k + 1].w);
    for (const Pair& p : local)
      G.single_edge_spread = std::max(G.single_edge_spread, hyperbolic_distance(E.apply(p.z), M.apply(p.z)));
  }
  return std::isfinite(G.residual_max) && std::isfinite(G.single_edge_spread);
}

DeckResult fail(DeckResult r, Status s, std::string msg) {
  r.status = s;
  r.message = std::move(msg);
  r.generators.clear();
  return r;
}

/// The relator R = [A_1^-1, B_1] … [A_g^-1, B_g] of `gens` (quad, order a1 b1 a2 b2 …): its
/// double value and the distance to the identity of C R C^-1, C the map moving the polygon corner
/// v0 to the origin, formed in frames at the corners its letters visit (detail::product_at():
/// neither the generators nor R conjugated whole, which would multiply their rounding by |C|²).
double relation_of(const std::vector<MoebiusQ>& gens, CQ v0, Moebius* relator) {
  if (relator) *relator = detail::canonical_relator(gens).to_double();
  return detail::product_at(detail::canonical_relator_letters(gens), v0).distance_to_identity();
}

/// Finds the side labelled `name` and its partner labelled name^-1 in a canonical cut.
bool find_side_pair(const CutResult& cut, const std::string& name, Index* side, Index* partner) {
  *side = *partner = kInvalid;
  for (Index s = 0; s < cut.num_sides(); ++s)
    if (cut.side_label[s] == name) *side = s;
  if (*side == kInvalid) return false;
  *partner = cut.side_partner[*side];
  return *partner >= 0 && *partner < cut.num_sides() && cut.side_label[*partner] == name + "^-1";
}

/// Checks the side structure of the cut; empty string when usable.
std::string check_cut(const CutResult& cut) {
  if (cut.status != Status::Ok) return "the cut is not valid (status " + std::string(status_name(cut.status)) + ").";
  if (!cut.canonical) return "the cut is not canonical (" + cut.reason + ").";
  if (cut.boundary_loops != 0) return "deck transformations are computed for closed surfaces only.";
  if (cut.genus < 1) return "a genus-0 surface has no deck transformations.";
  const Index ns = cut.num_sides();
  if (ns != 4 * cut.genus || cut.side_offsets.size() != static_cast<std::size_t>(ns) + 1 ||
      cut.side_label.size() != static_cast<std::size_t>(ns) || cut.side_partner.size() != static_cast<std::size_t>(ns))
    return "the cut's side arrays do not describe 4g sides.";
  if (cut.side_offsets[0] != 0 || cut.side_offsets[ns] != static_cast<Index>(cut.side_vertices.size()))
    return "the cut's side offsets do not cover side_vertices.";
  const Index nv = cut.num_cut_vertices();
  for (Index s = 0; s < ns; ++s) {
    if (cut.side_offsets[s + 1] - cut.side_offsets[s] < 2) return "side " + std::to_string(s) + " has fewer than 2 vertices.";
    const Index p = cut.side_partner[s];
    if (p < 0 || p >= ns || cut.side_partner[p] != s) return "side " + std::to_string(s) + " has no valid partner.";
    if (cut.side_offsets[p + 1] - cut.side_offsets[p] != cut.side_offsets[s + 1] - cut.side_offsets[s])
      return "sides " + std::to_string(s) + " and " + std::to_string(p) + " have different vertex counts.";
  }
  for (Index v : cut.side_vertices)
    if (v < 0 || v >= nv) return "a side vertex is out of range of the cut vertices.";
  return {};
}

}  // namespace

DeckResult fit_deck_transformations(const CutResult& cut, Geometry geometry, std::span<const double> positions,
                                    const DeckOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  DeckResult r;
  r.geometry = geometry;
  r.genus = cut.genus;
  std::string why;
  if (!options.is_valid(&why)) return fail(r, Status::InvalidArgument, why);
  why = check_cut(cut);
  if (!why.empty()) return fail(r, Status::InvalidArgument, why);
  const Index g = cut.genus;
  if (geometry == Geometry::Spherical) return fail(r, Status::InvalidArgument, "spherical layouts have no deck group.");
  if (geometry == Geometry::Euclidean && g != 1)
    return fail(r, Status::InvalidArgument, "euclidean deck transformations need genus 1 (genus " + std::to_string(g) + ").");
  if (geometry == Geometry::Hyperbolic && g < 2)
    return fail(r, Status::InvalidArgument, "hyperbolic deck transformations need genus >= 2 (genus " + std::to_string(g) + ").");
  const Index nv = cut.num_cut_vertices();
  if (positions.size() != static_cast<std::size_t>(nv) * 2)
    return fail(r, Status::InvalidArgument,
                "positions has " + std::to_string(positions.size()) + " values, expected #cut vertices x 2 = " +
                    std::to_string(static_cast<std::size_t>(nv) * 2) + ".");
  for (Index v = 0; v < nv; ++v) {
    const double x = positions[2 * v], y = positions[2 * v + 1];
    if (!std::isfinite(x) || !std::isfinite(y))
      return fail(r, Status::NonFiniteCoordinate, "cut vertex " + std::to_string(v) + " has a non-finite position.");
    if (geometry == Geometry::Hyperbolic && !(one_minus_abs2({x, y}) > 0))
      return fail(r, Status::InvalidArgument, "cut vertex " + std::to_string(v) + " lies on or outside the unit circle.");
  }
  auto pos = [&](Index v) { return cplx(positions[2 * v], positions[2 * v + 1]); };

  // The side pairs in canonical order a1 b1 a2 b2 ….
  std::vector<SidePairs> sp;
  for (Index k = 1; k <= g; ++k)
    for (const char* letter : {"a", "b"}) {
      SidePairs e;
      e.name = letter + std::to_string(k);
      if (!find_side_pair(cut, e.name, &e.side, &e.partner))
        return fail(r, Status::InvalidArgument, "the cut has no sides " + e.name + " and " + e.name + "^-1.");
      const Index b0 = cut.side_offsets[e.side], bp = cut.side_offsets[e.partner];
      const Index n = cut.side_offsets[e.side + 1] - b0;
      for (Index i = 0; i < n; ++i)
        e.pairs.push_back({pos(cut.side_vertices[b0 + i]), pos(cut.side_vertices[bp + n - 1 - i])});
      if (std::abs(e.pairs.front().z - e.pairs.back().z) == 0 || std::abs(e.pairs.front().w - e.pairs.back().w) == 0)
        return fail(r, Status::NumericalFailure, "side " + e.name + " or its partner has coincident end vertices.");
      sp.push_back(std::move(e));
    }

  for (const SidePairs& e : sp) {
    DeckGenerator G;
    G.name = e.name;
    G.side = e.side;
    G.partner = e.partner;
    G.geometry = geometry;
    G.pairs = static_cast<Index>(e.pairs.size());
    const std::size_t n = e.pairs.size();
    if (geometry == Geometry::Euclidean) {
      cplx t = 0, zc = 0, wc = 0;
      for (const Pair& p : e.pairs) {
        t += p.w - p.z;
        zc += p.z;
        wc += p.w;
      }
      t /= double(n);
      zc /= double(n);
      wc /= double(n);
      cplx cross = 0;
      for (const Pair& p : e.pairs) cross += (p.w - wc) * std::conj(p.z - zc);
      G.rotation = std::abs(cross) > 0 ? std::arg(cross) : 0.0;
      G.translation = {t.real(), t.imag()};
      double sum2 = 0;
      for (const Pair& p : e.pairs) {
        const double d = std::abs(p.z + t - p.w);
        G.residual_max = std::max(G.residual_max, d);
        sum2 += d * d;
      }
      G.residual_rms = std::sqrt(sum2 / double(n));
      const cplx t0 = e.pairs.front().w - e.pairs.front().z;
      double sum0 = 0;
      for (const Pair& p : e.pairs) {
        const double d = std::abs(p.z + t0 - p.w);
        G.initial_residual_max = std::max(G.initial_residual_max, d);
        sum0 += d * d;
      }
      G.initial_residual_rms = std::sqrt(sum0 / double(n));
      for (std::size_t k = 0; k + 1 < n; ++k) {
        const cplx te = (e.pairs[k].w - e.pairs[k].z + e.pairs[k + 1].w - e.pairs[k + 1].z) / 2.0;
        G.single_edge_spread = std::max(G.single_edge_spread, std::abs(te - t));
      }
    } else {
      if (!fit_hyperbolic(e.pairs, options, G, r.ceres_iterations))
        return fail(r, Status::NumericalFailure, "generator " + e.name + " maps its side outside the disk.");
    }
    r.residual_max = std::max(r.residual_max, G.residual_max);
    r.single_edge_spread = std::max(r.single_edge_spread, G.single_edge_spread);
    r.generators.push_back(std::move(G));
  }

  // The relation Π [A_i^-1, B_i] = 1.
  if (geometry == Geometry::Hyperbolic) {
    std::vector<MoebiusQ> gens;
    for (const DeckGenerator& G : r.generators) gens.push_back(detail::quad_map(G));
    r.relation_error = relation_of(gens, CQ(pos(cut.side_vertices[cut.side_offsets[0]])), &r.relator);
  } else {
    // Rigid motions (Procrustes) so that a rotation in the layout shows up in the relation.
    std::vector<Rigid> rig;
    for (std::size_t i = 0; i < sp.size(); ++i) {
      cplx zc = 0, wc = 0;
      for (const Pair& p : sp[i].pairs) {
        zc += p.z;
        wc += p.w;
      }
      zc /= double(sp[i].pairs.size());
      wc /= double(sp[i].pairs.size());
      const cplx c = std::polar(1.0, r.generators[i].rotation);
      rig.push_back({c, wc - c * zc});
    }
    Rigid R;
    for (Index i = 0; i < g; ++i) {
      const Rigid& A = rig[2 * i];
      const Rigid& B = rig[2 * i + 1];
      R = R * A.inverse() * B * A * B.inverse();
    }
    // Relative to the longest translation, so that the figure does not depend on the units.
    double err = 0, scale = 0;
    for (Index s = 0; s < cut.num_sides(); ++s)
      for (Index i = cut.side_offsets[s]; i < cut.side_offsets[s + 1]; ++i) {
        const cplx z = pos(cut.side_vertices[i]);
        err = std::max(err, std::abs(R.apply(z) - z));
      }
    for (const Rigid& m : rig) scale = std::max(scale, std::abs(m.t));
    r.relation_error = scale > 0 ? err / scale : err;
  }
  if (!std::isfinite(r.relation_error)) return fail(r, Status::NumericalFailure, "the relation check is not finite.");
  r.status = Status::Ok;
  char buf[160];
  std::snprintf(buf, sizeof buf, "%d generators fitted; residual max %.3g, relation error %.3g.",
                static_cast<int>(r.generators.size()), r.residual_max, r.relation_error);
  r.message = buf;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return r;
}

}  // namespace ricci

// ---- through a compact domain ---------------------------------------------------------------

namespace ricci {

namespace {

using detail::HyperboloidSum;
using detail::quad;

std::uint64_t dkey(Index u, Index v) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(u)) << 32) | static_cast<std::uint32_t>(v);
}

/// A letter of a word in the domain's side pairings: pairing k (k < 0: none), or its inverse.
struct Letter {
  Index k = -1;
  bool inverse = false;
};

template <class T>
detail::BasicMoebius<T> letter_map(const std::vector<detail::BasicMoebius<T>>& P, Letter l) {
  if (l.k < 0) return detail::BasicMoebius<T>();
  return l.inverse ? P[static_cast<std::size_t>(l.k)].inverse() : P[static_cast<std::size_t>(l.k)];
}

/// A vertex cycle of the domain: the pairings crossed around one vertex of its cut graph (freely
/// reduced, not empty) and that vertex's position in the domain layout (the product fixes it).
struct Cycle {
  std::vector<Letter> word;
  CQ at;
  /// The frames of detail::product_at() at the vertex's images along the word under the pairings
  /// as fitted (set_frames()); frames[0] = frames[n] = to_origin(at). Any frames give the same
  /// product; these keep its factors moderate for every pairing near the fitted ones, so they are
  /// made once and serve the adjustment's every evaluation.
  std::vector<MoebiusQ> frames, frames_inv;
  void set_frames(const std::vector<MoebiusQ>& P);
};

void Cycle::set_frames(const std::vector<MoebiusQ>& P) {
  std::vector<MoebiusQ> maps;
  for (const Letter& l : word) maps.push_back(letter_map(P, l));
  frames = detail::product_frames(maps, at);
  frames_inv.clear();
  for (const MoebiusQ& F : frames) frames_inv.push_back(F.inverse());
}

/// The product of a cycle's letters conjugated to its vertex, formed in its frames (as
/// detail::product_at(): each factor moves a point near the origin to near the origin), in quad or
/// quad-double (the quad frames taken exactly).
template <class T>
detail::BasicMoebius<T> cycle_product(const std::vector<detail::BasicMoebius<T>>& P, const Cycle& c) {
  detail::BasicMoebius<T> M;
  for (std::size_t i = 0; i < c.word.size(); ++i)
    M = M * (detail::from_quad<T>(c.frames[i]) * letter_map(P, c.word[i]) * detail::from_quad<T>(c.frames_inv[i + 1]));
  return M;
}

/// The product of a cycle conjugated to the origin (cycle_product()); it is ±I exactly when
/// (Im a, Re b, Im b) of ±M, the sign making Re a positive, vanishes (det = 1). Writes those
/// three numbers.
template <class T>
void cycle_residual(const std::vector<detail::BasicMoebius<T>>& P, const Cycle& c, double* out) {
  const detail::BasicMoebius<T> M = cycle_product(P, c);
  const T s = M.a.re < 0 ? -1 : 1;
  out[0] = static_cast<double>(s * M.a.im);
  out[1] = static_cast<double>(s * M.b.re);
  out[2] = static_cast<double>(s * M.b.im);
}

/// How much of a cycle residual the pairings' own quad entries leave: a pairing between sides at
/// distance r from the origin has entries of size e^r, rounded to 2^-112 of that, and a factor of
/// cycle_product() multiplies that rounding by e^r again; so 2^-112 × Σ (|a|² + |b|²) over a
/// cycle's letters, the largest over the cycles (~1e-33 for domains near the origin, ~1e-22 for
/// sides at r ≈ 14).
double cycle_rounding(const std::vector<MoebiusQ>& P, const std::vector<Cycle>& cycles) {
  double floor = 0;
  for (const Cycle& c : cycles) {
    quad sum = 0;
    for (const Letter& l : c.word) {
      const MoebiusQ& X = P[static_cast<std::size_t>(l.k)];
      sum += X.a.norm() + X.b.norm();
    }
    floor = std::max(floor, detail::kQuadEpsilon * static_cast<double>(sum));
  }
  return floor;
}

/// The pairings X_k · C_k⁻¹ E(ξ_k) C_k, E(ξ) = [[1 + iξ0, ξ1 + iξ2], conj] normalised and C_k the
/// disk map taking pairing k's side centre to the origin: ξ_k moves the side's points by about
/// |ξ_k| whatever their distance from the origin (E(ξ) alone moves a point at distance r by about
/// |ξ|·cosh r, so a minimum-norm ξ would let the sides far out in the disk move the most).
template <class T>
detail::BasicMoebius<T> perturbed_pairing(const detail::BasicMoebius<T>& X, const T* xi, const MoebiusQ& CQuad) {
  using M = detail::BasicMoebius<T>;
  using C2 = detail::BasicCQ<T>;
  const M C = detail::from_quad<T>(CQuad);
  const M E = M(C2{1, xi[0]}, C2{xi[1], xi[2]}).normalized();
  return (X * (C.inverse() * E * C)).normalized();
}

template <class T>
std::vector<detail::BasicMoebius<T>> perturbed(const std::vector<detail::BasicMoebius<T>>& X, const std::vector<T>& xi,
                                               const std::vector<MoebiusQ>& C) {
  std::vector<detail::BasicMoebius<T>> Y(X.size());
  for (std::size_t k = 0; k < X.size(); ++k) Y[k] = perturbed_pairing(X[k], &xi[3 * k], C[k]);
  return Y;
}

/// The Jacobian of the cycle residuals (cycle_residual(), 3 rows per cycle) with respect to the
/// perturbations ξ of perturbed_pairing() at ξ = 0 (3 columns per pairing), in closed form and in
/// double. Each factor Φ_i = F_i L_i F_{i+1}^-1 of cycle_product() fixes the origin (a rotation), so
/// prefix and suffix products are exact to double's rounding; varying pairing k = X C^-1 E(ξ) C
/// gives dΦ_i = Φ_i · Ad(F_{i+1} C^-1)(D) for the letter X and −Ad(F_i C^-1)(D) · Φ_i for X^-1,
/// D the tangent of E(ξ) at 0 (i, 1, i on the entries a, b, b). Those conjugations move D by the
/// distance from the cycle's vertex to the side centre, at most a side's length, so the entries
/// keep their relative accuracy (a perturbation along a far side's own axis is not amplified).
Eigen::SparseMatrix<double> cycle_jacobian(const std::vector<MoebiusQ>& X, const std::vector<Cycle>& cycles,
                                           const std::vector<MoebiusQ>& C) {
  using MD = detail::BasicMoebius<double>;
  using CD = detail::BasicCQ<double>;
  auto to_d = [](const MoebiusQ& M) { return MD(CD(M.a.to_double()), CD(M.b.to_double())); };
  const std::array<MD, 3> D = {MD(CD{0, 1}, CD{0, 0}), MD(CD{0, 0}, CD{1, 0}), MD(CD{0, 0}, CD{0, 1})};
  std::vector<Eigen::Triplet<double>> entries;  // repeated letters of a cycle: summed
  for (std::size_t c = 0; c < cycles.size(); ++c) {
    const Cycle& cyc = cycles[c];
    const std::size_t n = cyc.word.size();
    std::vector<MD> phi(n), prefix(n + 1), suffix(n + 1);
    for (std::size_t i = 0; i < n; ++i) phi[i] = to_d(cyc.frames[i] * letter_map(X, cyc.word[i]) * cyc.frames_inv[i + 1]);
    for (std::size_t i = 0; i < n; ++i) prefix[i + 1] = prefix[i] * phi[i];
    for (std::size_t i = n; i-- > 0;) suffix[i] = phi[i] * suffix[i + 1];
    const double s = prefix[n].a.re < 0 ? -1 : 1;
    for (std::size_t i = 0; i < n; ++i) {
      const Letter& l = cyc.word[i];
      const std::size_t k = static_cast<std::size_t>(l.k);
      const MD T = to_d(l.inverse ? cyc.frames[i] * C[k].inverse() : cyc.frames[i + 1] * C[k].inverse());
      const MD T_inv = T.inverse();
      for (int t = 0; t < 3; ++t) {
        const MD ad = T * D[static_cast<std::size_t>(t)] * T_inv;
        MD d_phi = l.inverse ? ad * phi[i] : phi[i] * ad;
        if (l.inverse) d_phi = MD(-1.0 * d_phi.a, -1.0 * d_phi.b);
        const MD dM = prefix[i] * d_phi * suffix[i + 1];
        const Eigen::Index row = 3 * static_cast<Eigen::Index>(c), col = 3 * static_cast<Eigen::Index>(k) + t;
        entries.emplace_back(row, col, s * dM.a.im);
        entries.emplace_back(row + 1, col, s * dM.b.re);
        entries.emplace_back(row + 2, col, s * dM.b.im);
      }
    }
  }
  Eigen::SparseMatrix<double> J(3 * static_cast<Eigen::Index>(cycles.size()), 3 * static_cast<Eigen::Index>(X.size()));
  J.setFromTriplets(entries.begin(), entries.end());
  return J;
}

/// Moves the fitted pairings X to nearby ones whose vertex cycles are exactly ±I (to the rounding
/// of T: quad, or quad-double from pairings closed in quad): Gauss–Newton on the cycle equations
/// over Y_k = X_k · E(ξ_k), each step the minimum-norm solution of the linearised equations
/// (cycle_jacobian() at ξ = 0, exact to double's rounding; the correction is of the size of the
/// residuals, so each step gains about as many digits as that Jacobian has). Returns the largest
/// cycle residual left.
template <class T>
double adjust_pairings(std::vector<detail::BasicMoebius<T>>& X, const std::vector<Cycle>& cycles,
                       const std::vector<MoebiusQ>& C) {
  const Eigen::Index m = static_cast<Eigen::Index>(X.size()), nr = 3 * static_cast<Eigen::Index>(cycles.size());
  if (m == 0 || nr == 0) return 0;
  auto residual = [&](const std::vector<detail::BasicMoebius<T>>& Y, Eigen::VectorXd& r) {
    r.resize(nr);
    for (std::size_t c = 0; c < cycles.size(); ++c) cycle_residual(Y, cycles[c], r.data() + 3 * c);
  };
  std::vector<T> xi(static_cast<std::size_t>(3 * m), 0);
  // The minimum-norm step J^T (J J^T)^-1 (−r): J J^T is sparse (cycles sharing a pairing) and
  // singular where the cycle equations are dependent (their product is the identity as a word),
  // so it is factored with a shift of 1e-15 of its largest entry, which leaves the step in J's row
  // space and changes it by that relative amount (the next step removes it).
  std::vector<MoebiusQ> XQ;
  for (const detail::BasicMoebius<T>& M : X) XQ.push_back(detail::to_quad(M));
  const Eigen::SparseMatrix<double> J = cycle_jacobian(XQ, cycles, C);
  Eigen::SparseMatrix<double> A = J * J.transpose();
  double largest = 0;
  for (Eigen::Index i = 0; i < A.rows(); ++i) largest = std::max(largest, A.coeff(i, i));
  Eigen::SparseMatrix<double> shift(A.rows(), A.cols());
  shift.setIdentity();
  A += (1e-15 * largest) * shift;
  const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(A);
  Eigen::VectorXd r;
  std::vector<T> best = xi;
  residual(X, r);
  double best_err = r.lpNorm<Eigen::Infinity>();
  // Not factorable (a non-finite Jacobian): the pairings stay as fitted, judged by their cycles.
  if (llt.info() != Eigen::Success || !(largest > 0) || !std::isfinite(largest)) return best_err;
  for (int it = 0; it < 8 && best_err > 0; ++it) {
    const Eigen::VectorXd delta = J.transpose() * llt.solve(-r);
    if (!delta.allFinite()) break;
    for (Eigen::Index j = 0; j < 3 * m; ++j) xi[static_cast<std::size_t>(j)] += delta[j];
    residual(perturbed(X, xi, C), r);
    const double err = r.lpNorm<Eigen::Infinity>();
    if (!(err < 0.5 * best_err)) break;
    best_err = err;
    best = xi;
  }
  X = perturbed(X, best, C);
  return best_err;
}

/// The centre of the smallest hyperbolic disk holding the points (approximately: Bădoiu–Clarkson
/// steps towards the farthest point, 1/(k+1) of the way at step k, in double; the points, already
/// centred on their centre of mass, need only be resolved coarsely for this).
cplx minimax_centre(const std::vector<CQ>& pts) {
  // At most ~16k points (a stride through the cut vertices, whose neighbours lie within one edge).
  const std::size_t stride = std::max<std::size_t>(1, pts.size() / 16384);
  std::vector<cplx> z;
  for (std::size_t i = 0; i < pts.size(); i += stride) z.push_back(pts[i].to_double());
  cplx c = 0;
  for (int k = 1; k <= 400; ++k) {
    const Moebius T = Moebius::to_origin(c);
    double far = 0;
    cplx q_far = 0;
    for (const cplx& p : z) {
      const cplx q = T.apply(p);
      const double d = std::norm(q);
      if (d > far) {
        far = d;
        q_far = q;
      }
    }
    if (!(far > 0) || !(far < 1)) break;
    const double r = std::sqrt(far), dist = 2 * std::atanh(r);
    const cplx step = std::tanh(dist / (2.0 * (k + 1))) * q_far / r;
    const cplx next = T.inverse().apply(step);
    if (!std::isfinite(next.real()) || !std::isfinite(next.imag()) || !(std::norm(next) < 1)) break;
    c = next;
  }
  return c;
}

}  // namespace

namespace {

/// deck_through_domain() with the canonical cut optional: without it, only the domain's side
/// pairings and the vertex-cycle check (fit_domain_pairings()). One method per step, in the order
/// run() calls them; each returns false after fail() has recorded why.
class DomainDeckRun {
 public:
  DomainDeckRun(const CutResult* canonical, const CutResult& domain, std::span<const double> dpos,
                const DeckOptions& options, const Topology* surface, const DomainDeck* given = nullptr)
      : canonical_in_(canonical), domain_(domain), in_(domain.surface_faces), dpos_(dpos), options_(options),
        surface_(surface), given_(given) {}

  DomainDeck run() {
    t_start_ = std::chrono::steady_clock::now();
    r_.geometry = Geometry::Hyperbolic;
    r_.genus = domain_.genus;
    if (!check_domain() || !fit_side_pairings()) return std::move(out_);
    index_boundary();
    if (!find_vertex_cycles() || !adjust_to_cycles()) return std::move(out_);
    if (canonical_in_ == nullptr) return pairings_only();
    // Each step stops the chain on failure; out_ then carries its status and message.
    if (check_canonical() && build_tiles() && canonical_positions() && polygon_frame() && canonical_generators())
      relation();
    return std::move(out_);
  }

 private:
  struct Word {
    Index Fs, Fp;
    Letter N;
  };

  const CutResult* canonical_in_;
  const CutResult& domain_;
  const std::vector<Index>& in_;  // the domain's input faces (surface_faces)
  std::span<const double> dpos_;
  const DeckOptions& options_;
  const Topology* surface_;  // the input surface's topology, when the caller has it
  const DomainDeck* given_;  // pairings already fitted (widen_domain_pairings()): not fitted again
  std::chrono::steady_clock::time_point t_start_;
  DomainDeck out_;
  DeckResult& r_ = out_.deck;
  Index nin_ = 0, Fin_ = 0;
  std::vector<MoebiusQ> X_;                   // the domain's side pairings (adjusted when asked)
  std::vector<MoebiusQ> fitted_;              // the same as fitted, before any adjustment
  std::vector<std::vector<Pair>> side_pairs_;  // per pairing: the vertex pairs it was fitted on
  std::unordered_map<std::uint64_t, std::pair<Index, int>> boundary_;  // directed edge → (pairing, orientation)
  std::vector<std::uint8_t> on_side_;  // per cut vertex: on some side (only edges between two such are looked up)
  std::vector<Cycle> cycles_;
  // The canonical disk, its breadth-first tiles and positions.
  const Topology* T_ = nullptr;  // the canonical disk's connectivity: the cut's, or built_disk_
  Topology built_disk_;
  std::vector<Index> parent_, queue_;
  std::vector<Letter> via_;
  std::vector<MoebiusQ> h_;
  std::vector<CQ> pos_;
  MoebiusQ frame_;
  std::vector<Word> words_;
  std::vector<MoebiusQ> XQ_;

  bool fail(Status s, const std::string& m) {
    out_.status = s;
    out_.message = m;
    r_.status = s;
    r_.message = m;
    r_.generators.clear();
    out_.side_maps.clear();
    out_.canonical_positions.clear();
    return false;
  }
  cplx dz(Index v) const { return cplx(dpos_[2 * v], dpos_[2 * v + 1]); }

  /// The options, the domain (an unrefined cut of genus ≥ 2) and its positions inside the disk.
  bool check_domain() {
    std::string why;
    if (!options_.is_valid(&why)) return fail(Status::InvalidArgument, why);
    if (domain_.genus < 2) return fail(Status::InvalidArgument, "the compact-domain construction is for genus >= 2.");
    if (domain_.status != Status::Ok || domain_.num_refined_vertices() != 0 ||
        domain_.cut_faces.size() != domain_.surface_faces.size())
      return fail(Status::InvalidArgument, "the domain is not an unrefined cut of the surface.");
    nin_ = domain_.num_input_vertices;
    Fin_ = static_cast<Index>(domain_.surface_faces.size() / 3);
    const Index nd = domain_.num_cut_vertices();
    if (dpos_.size() != 2 * static_cast<std::size_t>(nd))
      return fail(Status::InvalidArgument, "domain positions: expected #domain cut vertices x 2 values.");
    for (Index v = 0; v < nd; ++v) {
      const cplx z = dz(v);
      if (!std::isfinite(z.real()) || !std::isfinite(z.imag()) || !(one_minus_abs2(z) > 0))
        return fail(Status::InvalidArgument, "domain cut vertex " + std::to_string(v) + " is not inside the unit disk.");
    }
    return true;
  }

  /// 1. Side pairings of the domain, fitted over all vertex pairs of each branch.
  bool fit_side_pairings() {
    X_.resize(static_cast<std::size_t>(domain_.num_generators()));
    side_pairs_.resize(X_.size());
    out_.side_maps.resize(X_.size());
    std::vector<Index> sides;  // one side of each pairing, in side order
    for (Index s = 0; s < domain_.num_sides(); ++s) {
      if (domain_.side_orientation[s] != 1) continue;
      const Index k = domain_.side_generator[s], p = domain_.side_partner[s];
      if (k < 0 || k >= static_cast<Index>(X_.size()) || p < 0)
        return fail(Status::InvalidArgument, "a domain side has no pairing.");
      const Index b0 = domain_.side_offsets[s], bp = domain_.side_offsets[p], n = domain_.side_offsets[s + 1] - b0;
      std::vector<Pair>& pairs = side_pairs_[k];
      for (Index i = 0; i < n; ++i)
        pairs.push_back({dz(domain_.side_vertices[b0 + i]), dz(domain_.side_vertices[bp + n - 1 - i])});
      sides.push_back(s);
    }
    if (given_ != nullptr) return take_given();
    // The pairings are fitted independently (each its own Ceres problem), in parallel; the results
    // are taken in side order, so the first failure named is the one a serial loop would name.
    const auto m = static_cast<std::int64_t>(sides.size());
    std::vector<DeckGenerator> fitted(static_cast<std::size_t>(m));
    std::vector<int> iterations(static_cast<std::size_t>(m), 0);
    std::vector<std::uint8_t> ok(static_cast<std::size_t>(m), 0);
    int out_of_memory = 0;  // nothing may leave the parallel region: rethrown after it
#pragma omp parallel for schedule(dynamic, 1) reduction(max : out_of_memory) if (m >= 4)
    for (std::int64_t j = 0; j < m; ++j) try {
      const Index s = sides[static_cast<std::size_t>(j)];
      DeckGenerator& G = fitted[static_cast<std::size_t>(j)];
      G.name = domain_.side_label[s];
      G.side = s;
      G.partner = domain_.side_partner[s];
      G.pairs = domain_.side_offsets[s + 1] - domain_.side_offsets[s];
      ok[static_cast<std::size_t>(j)] = fit_hyperbolic(side_pairs_[static_cast<std::size_t>(domain_.side_generator[s])],
                                                       options_, G, iterations[static_cast<std::size_t>(j)]);
    } catch (const std::bad_alloc&) {
      out_of_memory = 1;
    }
    if (out_of_memory) throw std::bad_alloc();
    for (std::int64_t j = 0; j < m; ++j) {
      DeckGenerator& G = fitted[static_cast<std::size_t>(j)];
      r_.ceres_iterations += iterations[static_cast<std::size_t>(j)];
      if (!ok[static_cast<std::size_t>(j)])
        return fail(Status::NumericalFailure, "domain side pairing " + G.name + " maps its side outside the disk.");
      const Index k = domain_.side_generator[sides[static_cast<std::size_t>(j)]];
      X_[k] = detail::quad_map(G);
      out_.side_maps[k] = std::move(G);
    }
    return true;
  }

  /// The pairings of given_ instead of fits: its side maps (adjusted or not) stand as X_; its maps
  /// as fitted, when it kept them, are what adjust_to_cycles() measures the adjustment from.
  bool take_given() {
    const DomainDeck& g = *given_;
    if (g.status != Status::Ok || g.side_maps.size() != X_.size() ||
        (!g.fitted_side_maps.empty() && g.fitted_side_maps.size() != X_.size()))
      return fail(Status::InvalidArgument, "the given pairings are not one per generator of the domain.");
    out_.side_maps = g.side_maps;
    for (std::size_t k = 0; k < X_.size(); ++k) X_[k] = detail::quad_map(g.side_maps[k]);
    return true;
  }

  /// 2. Directed boundary edges of the domain → (pairing, orientation).
  void index_boundary() {
    on_side_.assign(static_cast<std::size_t>(domain_.num_cut_vertices()), 0);
    for (Index s = 0; s < domain_.num_sides(); ++s)
      for (Index i = domain_.side_offsets[s]; i + 1 < domain_.side_offsets[s + 1]; ++i) {
        const Index a = domain_.side_vertices[i], b = domain_.side_vertices[i + 1];
        boundary_[dkey(a, b)] = {domain_.side_generator[s], domain_.side_orientation[s]};
        for (Index x : {a, b})
          if (x >= 0 && x < static_cast<Index>(on_side_.size())) on_side_[x] = 1;
      }
  }
  /// The letter crossed over the edge opposite corner k of input face O (none when the domain does
  /// not cut it): X^-1 when the face lies on side x, X on side x^-1.
  Letter crossing(Index O, int k) const {
    const Index c = 3 * O + k;
    const Index a = domain_.cut_faces[next_corner(c)], b = domain_.cut_faces[prev_corner(c)];
    // An edge with an end off every side is no side's (most edges: no hashing for them).
    if (a >= 0 && a < static_cast<Index>(on_side_.size()) && b >= 0 && b < static_cast<Index>(on_side_.size()) &&
        (!on_side_[a] || !on_side_[b]))
      return Letter{};
    const auto it = boundary_.find(dkey(a, b));
    if (it == boundary_.end()) return Letter{};
    return Letter{it->second.first, it->second.second == 1};
  }
  /// The corner of input face O1 opposite its edge shared with O2 that holds surface vertices a, b
  /// (input vertices or points added on that edge).
  int shared_corner(Index O1, Index O2, Index a, Index b) const {
    int best = -1;
    for (int k = 0; k < 3; ++k) {
      const Index A = in_[3 * O1 + (k + 1) % 3], B = in_[3 * O1 + (k + 2) % 3];
      bool in2 = false, in2b = false;
      for (int j = 0; j < 3; ++j) {
        in2 |= in_[3 * O2 + j] == A;
        in2b |= in_[3 * O2 + j] == B;
      }
      if (!in2 || !in2b) continue;
      const bool ends_ok = (a >= nin_ || a == A || a == B) && (b >= nin_ || b == A || b == B);
      if (ends_ok) return k;
      if (best < 0) best = k;
    }
    return best;
  }

  /// Vertex cycles of the domain: the crossings around every input vertex compose to ±I. Their
  /// words, freely reduced (a vertex inside a branch crosses it there and back: empty), and the
  /// largest residual of the fitted pairings on them.
  bool find_vertex_cycles() {
    TopologyResult it;
    const bool given = surface_ != nullptr && is_topology_of(*surface_, in_, nin_);
    if (!given) {
      it = build_topology(in_, nin_);
      if (it.status != Status::Ok) return fail(Status::InvalidArgument, "the domain's input faces are not a valid mesh.");
    }
    const Topology& I = given ? *surface_ : it.topology;
    for (Index v = 0; v < nin_; ++v) {
      const Index k0 = I.vertex_corner_offsets[v], k1 = I.vertex_corner_offsets[v + 1];
      if (k0 == k1) continue;
      Cycle cyc;
      bool closed = true;
      for (Index k = k0; k < k1; ++k) {
        const Index c = I.vertex_corners[k];
        // ccw neighbour: across the edge v–vertex(prev(c)), opposite corner next(c).
        const Index nc = next_corner(c);
        if (I.opposite[nc] == kInvalid) {
          closed = false;
          break;
        }
        const Letter l = crossing(corner_face(c), static_cast<int>(nc % 3));
        if (l.k < 0) continue;
        if (!cyc.word.empty() && cyc.word.back().k == l.k && cyc.word.back().inverse != l.inverse)
          cyc.word.pop_back();
        else
          cyc.word.push_back(l);
      }
      // Cyclically reduced (a conjugate: still ±I exactly when the cycle is).
      while (cyc.word.size() >= 2 && cyc.word.front().k == cyc.word.back().k &&
             cyc.word.front().inverse != cyc.word.back().inverse) {
        cyc.word.pop_back();
        cyc.word.erase(cyc.word.begin());
      }
      if (!closed || cyc.word.empty()) continue;
      cyc.at = CQ(dz(domain_.cut_faces[I.vertex_corners[k0]]));
      cyc.set_frames(X_);
      cycles_.push_back(std::move(cyc));
    }
    double res[3];
    for (const Cycle& c : cycles_) {
      cycle_residual(X_, c, res);
      out_.cycle_error = std::max({out_.cycle_error, std::abs(res[0]), std::abs(res[1]), std::abs(res[2])});
    }
    return true;
  }

  /// With options.adjust_pairings: the pairings closest to the fitted ones whose vertex cycles
  /// are exact (adjust_pairings()), their residuals on the domain's sides, and a refusal when they
  /// had to move a side vertex further than options.max_pairing_adjustment.
  bool adjust_to_cycles() {
    fitted_ = X_;
    out_.adjusted_cycle_error = out_.cycle_error;
    if (!options_.adjust_pairings || cycles_.empty()) return true;
    out_.fitted_side_maps = out_.side_maps;
    if (given_ != nullptr && !given_->fitted_side_maps.empty()) {
      out_.fitted_side_maps = given_->fitted_side_maps;
      for (std::size_t k = 0; k < X_.size(); ++k) fitted_[k] = detail::quad_map(given_->fitted_side_maps[k]);
      out_.cycle_error = given_->cycle_error;
    }
    // Each pairing's side centre: its middle fitted point.
    std::vector<MoebiusQ> centres(X_.size());
    for (std::size_t k = 0; k < X_.size(); ++k)
      if (!side_pairs_[k].empty()) centres[k] = MoebiusQ::to_origin(CQ(side_pairs_[k][side_pairs_[k].size() / 2].z));
    // Given pairings closed in quad already (widen_domain_pairings()): not closed again there; the
    // quad figures stay theirs.
    const bool closed_before = given_ != nullptr && !given_->fitted_side_maps.empty();
    out_.adjusted_cycle_error = closed_before ? given_->adjusted_cycle_error : adjust_pairings(X_, cycles_, centres);
    // The adjusted maps replace the fitted ones; their residuals on the domain's sides.
    for (std::size_t k = 0; k < X_.size(); ++k) {
      DeckGenerator& G = out_.side_maps[k];
      detail::set_quad_map(G, X_[k]);
      G.residual_max = 0;
      double sum2 = 0;
      for (const Pair& p : side_pairs_[k]) {
        const double d = detail::hyperbolic_distance_q(X_[k].apply(CQ(p.z)), CQ(p.w));
        const double moved = detail::hyperbolic_distance_q(X_[k].apply(CQ(p.z)), fitted_[k].apply(CQ(p.z)));
        G.residual_max = std::max(G.residual_max, d);
        out_.pairing_adjustment = std::max(out_.pairing_adjustment, moved);
        sum2 += d * d;
      }
      G.residual_rms = side_pairs_[k].empty() ? 0 : std::sqrt(sum2 / double(side_pairs_[k].size()));
      if (!std::isfinite(G.residual_max) || !std::isfinite(out_.pairing_adjustment))
        return fail(Status::NumericalFailure, "the adjusted side pairing " + G.name + " is not finite.");
    }
    // Closed to quad precision: within 1e14 ε (the cycles near the origin) or within 64 times
    // what the pairings' rounded entries leave (domains reaching far into the disk).
    out_.cycle_rounding = closed_before ? given_->cycle_rounding : cycle_rounding(X_, cycles_);
    const double closed = std::max(1e14 * detail::kQuadEpsilon, 64 * out_.cycle_rounding);
    if (!(out_.pairing_adjustment <= options_.max_pairing_adjustment) || !(out_.adjusted_cycle_error < closed)) {
      char buf[360];
      std::snprintf(buf, sizeof buf,
                    "the domain's side pairings are not those of a surface group: their vertex cycles miss the "
                    "identity by %.3g, and pairings closing them (to %.3g, quad rounding %.3g there) move a side "
                    "vertex by %.3g (limit %.3g); the domain layout is not consistent.",
                    out_.cycle_error, out_.adjusted_cycle_error, out_.cycle_rounding, out_.pairing_adjustment,
                    options_.max_pairing_adjustment);
      return fail(Status::NumericalFailure, buf);
    }
    if (options_.wide_pairings) {
      std::vector<detail::MoebiusW> XW;
      for (const MoebiusQ& M : X_) XW.push_back(detail::to_wide(M));
      out_.wide_cycle_error = adjust_pairings(XW, cycles_, centres);
      if (!std::isfinite(out_.wide_cycle_error))
        return fail(Status::NumericalFailure, "the side pairings closed in quad-double are not finite.");
      for (std::size_t k = 0; k < X_.size(); ++k) detail::set_wide_map(out_.side_maps[k], XW[k]);
      out_.wide = true;
    }
    return true;
  }

  /// The result of fit_domain_pairings(): the pairings and their cycle check, no generators.
  DomainDeck pairings_only() {
    out_.status = Status::Ok;
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "%d side pairings fitted; vertex cycles within %.3g of the identity (%.3g after an adjustment of "
                  "%.3g).",
                  static_cast<int>(out_.side_maps.size()), out_.cycle_error, out_.adjusted_cycle_error,
                  out_.pairing_adjustment);
    out_.message = buf;
    r_.status = Status::NotRun;
    r_.message = "no canonical cut given";
    out_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start_).count();
    return std::move(out_);
  }

  /// The canonical cut: valid, of the same surface, naming only input faces the domain has.
  bool check_canonical() {
    const CutResult& canonical = *canonical_in_;
    r_.genus = canonical.genus;
    const std::string why = check_cut(canonical);
    if (!why.empty()) return fail(Status::InvalidArgument, why);
    if (canonical.genus != domain_.genus || canonical.num_input_vertices != nin_)
      return fail(Status::InvalidArgument, "the domain is not a cut of the canonical cut's surface.");
    for (Index o : canonical.surface_face_to_input)
      if (o < 0 || o >= Fin_) return fail(Status::InvalidArgument, "the canonical cut names an input face the domain lacks.");
    return true;
  }

  /// 3. Tiles of the canonical disk's faces, breadth first: each face records the face it was
  /// reached from and the letter crossed, so the tiles can be formed for any set of pairings.
  bool build_tiles() {
    const CutResult& canonical = *canonical_in_;
    // The cut's own disk connectivity when it kept it (cut_surface() does), else built here.
    if (is_topology_of(canonical.disk_topology, canonical.cut_faces, canonical.num_cut_vertices())) {
      T_ = &canonical.disk_topology;
    } else {
      TopologyResult ct = build_topology(canonical.cut_faces, canonical.num_cut_vertices());
      if (ct.status != Status::Ok) return fail(Status::InvalidArgument, "the canonical disk is not a valid mesh.");
      built_disk_ = std::move(ct.topology);
      T_ = &built_disk_;
    }
    const Index Fc = T_->num_faces;
    parent_.assign(static_cast<std::size_t>(Fc), kInvalid);
    via_.assign(static_cast<std::size_t>(Fc), Letter{});
    std::vector<Index> depth(static_cast<std::size_t>(Fc), kInvalid);
    queue_ = {0};
    depth[0] = 0;
    for (std::size_t qi = 0; qi < queue_.size(); ++qi) {
      const Index F1 = queue_[qi], O1 = canonical.surface_face_to_input[F1];
      for (int j = 0; j < 3; ++j) {
        const Index c = 3 * F1 + j, o = T_->opposite[c];
        if (o == kInvalid) continue;
        const Index F2 = corner_face(o);
        if (depth[F2] != kInvalid) continue;
        const Index O2 = canonical.surface_face_to_input[F2];
        if (O1 != O2) {
          const int k = shared_corner(O1, O2, canonical.surface_faces[next_corner(c)], canonical.surface_faces[prev_corner(c)]);
          if (k < 0)
            return fail(Status::NumericalFailure, "canonical faces " + std::to_string(F1) + " and " + std::to_string(F2) +
                                                      " lie in input faces that share no edge.");
          via_[F2] = crossing(O1, k);
        }
        parent_[F2] = F1;
        depth[F2] = depth[F1] + 1;
        out_.tile_depth = std::max(out_.tile_depth, depth[F2]);
        queue_.push_back(F2);
      }
    }
    if (static_cast<Index>(queue_.size()) != Fc) return fail(Status::InvalidArgument, "the canonical disk is not connected.");
    return true;
  }
  /// Every face's tile for the pairings P, in breadth-first order.
  std::vector<MoebiusQ> tiles(const std::vector<MoebiusQ>& P) const {
    std::vector<MoebiusQ> h(static_cast<std::size_t>(T_->num_faces));
    for (std::size_t qi = 1; qi < queue_.size(); ++qi) {
      const Index F = queue_[qi];
      h[F] = via_[F].k < 0 ? h[parent_[F]] : h[parent_[F]] * letter_map(P, via_[F]);
    }
    return h;
  }
  /// The tile of one face: the letters along its breadth-first path, from face 0.
  MoebiusQ tile_of(const std::vector<MoebiusQ>& P, Index F) const {
    std::vector<Letter> path;
    for (; F != 0 && F != kInvalid; F = parent_[F])
      if (via_[F].k >= 0) path.push_back(via_[F]);
    MoebiusQ t;
    for (auto it = path.rbegin(); it != path.rend(); ++it) t = t * letter_map(P, *it);
    return t;
  }

  /// 4. The domain position of surface vertex x seen from input face O.
  int corner_of(Index O, Index v) const {
    for (int k = 0; k < 3; ++k)
      if (in_[3 * O + k] == v) return k;
    return -1;
  }
  bool local(Index O, Index x, CQ& w) const {
    const CutResult& canonical = *canonical_in_;
    if (x < nin_) {
      const int k = corner_of(O, x);
      if (k < 0) return false;
      w = CQ(dz(domain_.cut_faces[3 * O + k]));
      return true;
    }
    const Index rec = x - nin_;
    if (rec >= canonical.num_refined_vertices()) return false;
    HyperboloidSum sum;
    for (int k = 0; k < 3; ++k) {
      const double beta = canonical.refined_vertex_bary[3 * rec + k];
      if (beta == 0) continue;
      const int kk = corner_of(O, canonical.refined_vertex_corners[3 * rec + k]);
      if (kk < 0) return false;
      sum.add(CQ(dz(domain_.cut_faces[3 * O + kk])), beta);
    }
    return sum.point(w);
  }

  /// 5. Canonical positions (quad), each cut vertex from every face that holds it.
  bool canonical_positions() {
    const CutResult& canonical = *canonical_in_;
    h_ = tiles(X_);
    const Index nc = canonical.num_cut_vertices();
    pos_.assign(static_cast<std::size_t>(nc), CQ{});
    std::vector<char> have(static_cast<std::size_t>(nc), 0);
    for (Index F = 0; F < T_->num_faces; ++F) {
      const Index O = canonical.surface_face_to_input[F];
      for (int j = 0; j < 3; ++j) {
        const Index cv = canonical.cut_faces[3 * F + j], x = canonical.surface_faces[3 * F + j];
        CQ w;
        if (!local(O, x, w))
          return fail(Status::NumericalFailure,
                      "surface vertex " + std::to_string(x) + " is not in its input face " + std::to_string(O) + ".");
        const CQ z = h_[F].apply(w);
        // A tile beyond quad range: fail at once rather than after every face.
        if (!(1 - z.norm() > 0) || !std::isfinite(static_cast<double>(z.norm())))
          return fail(Status::NumericalFailure, "canonical cut vertex " + std::to_string(cv) + " is not in the disk.");
        if (!have[cv]) {
          pos_[cv] = z;
          have[cv] = 1;
        } else {
          out_.tile_consistency = std::max(out_.tile_consistency, detail::hyperbolic_distance_q(pos_[cv], z));
        }
      }
    }
    // Every placed position was checked inside the disk as it was computed; what is left is a
    // vertex no face placed.
    for (Index v = 0; v < nc; ++v)
      if (!have[v])
        return fail(Status::NumericalFailure, "canonical cut vertex " + std::to_string(v) + " is not in the disk.");
    if (!std::isfinite(out_.tile_consistency)) return fail(Status::NumericalFailure, "the canonical tiles are not finite.");
    return true;
  }

  /// The polygon's own frame: its hyperboloid centre of mass, then (PolygonCentre::Minimax) the
  /// centre of its smallest enclosing disk, moved to the origin. The polygon can lie far from the
  /// domain (tiles at distance r have entries ~e^{r/2}), so the generators are formed from the
  /// products frame·h_F, which are moderate near the polygon, never by conjugating a far-out
  /// product (that would multiply its rounding by e^r). Then the positions in double, when every
  /// vertex is resolved (otherwise the generators stand without the view).
  bool polygon_frame() {
    HyperboloidSum sum;
    for (const CQ& z : pos_) sum.add(z, 1);
    CQ centre;
    if (!sum.point(centre)) return fail(Status::NumericalFailure, "the canonical polygon has no centre of mass.");
    frame_ = MoebiusQ::to_origin(centre);
    for (CQ& z : pos_) z = frame_.apply(z);
    if (options_.polygon_centre == PolygonCentre::Minimax) {
      const cplx c = minimax_centre(pos_);
      const MoebiusQ M = MoebiusQ::to_origin(CQ(c));
      frame_ = M * frame_;
      for (CQ& z : pos_) z = M.apply(z);
    }
    out_.polygon_frame = frame_.to_double();
    const Index nc = static_cast<Index>(pos_.size());
    out_.canonical_positions.resize(2 * static_cast<std::size_t>(nc));
    for (Index v = 0; v < nc && out_.positions_note.empty(); ++v) {
      const cplx z = pos_[v].to_double();
      if (!(one_minus_abs2(z) > 0)) {
        char buf[240];
        std::snprintf(buf, sizeof buf,
                      "canonical cut vertex %d lies at hyperbolic distance %.1f from the origin, beyond the range of "
                      "double coordinates in the Poincaré disk (about 38)",
                      static_cast<int>(v), detail::hyperbolic_distance_q(pos_[v], CQ{0, 0}));
        out_.positions_note = buf;
      }
      out_.canonical_positions[2 * v] = z.real();
      out_.canonical_positions[2 * v + 1] = z.imag();
    }
    if (!out_.positions_note.empty()) out_.canonical_positions.clear();
    return true;
  }

  /// 6. The canonical generators X = h_{F_p} · N^-1 · h_{F_s}^-1 (in the polygon's frame), with
  /// their residuals on the canonical positions.
  bool canonical_generators() {
    const CutResult& canonical = *canonical_in_;
    std::unordered_map<std::uint64_t, Index> face_of;  // directed cut-vertex edge → canonical face
    for (Index F = 0; F < T_->num_faces; ++F)
      for (int j = 0; j < 3; ++j)
        face_of[dkey(canonical.cut_faces[3 * F + (j + 1) % 3], canonical.cut_faces[3 * F + (j + 2) % 3])] = 3 * F + j;
    for (Index i = 1; i <= canonical.genus; ++i)
      for (const char* letter : {"a", "b"}) {
        DeckGenerator G;
        G.name = letter + std::to_string(i);
        G.geometry = Geometry::Hyperbolic;
        if (!find_side_pair(canonical, G.name, &G.side, &G.partner))
          return fail(Status::InvalidArgument, "the cut has no sides " + G.name + " and " + G.name + "^-1.");
        const Index bs = canonical.side_offsets[G.side], bp = canonical.side_offsets[G.partner];
        const Index n = canonical.side_offsets[G.side + 1] - bs;
        const Index s0 = canonical.side_vertices[bs], s1 = canonical.side_vertices[bs + 1];
        const Index p0 = canonical.side_vertices[bp + n - 2], p1 = canonical.side_vertices[bp + n - 1];
        const auto fs = face_of.find(dkey(s0, s1)), fp = face_of.find(dkey(p0, p1));
        if (fs == face_of.end() || fp == face_of.end())
          return fail(Status::InvalidArgument, "side " + G.name + " is not on the disk boundary.");
        const Index Fs = corner_face(fs->second), Fp = corner_face(fp->second);
        const Index Os = canonical.surface_face_to_input[Fs], Op = canonical.surface_face_to_input[Fp];
        Letter N;
        if (Os != Op) {
          const int k = shared_corner(Os, Op, canonical.cut_to_surface[s0], canonical.cut_to_surface[s1]);
          if (k < 0) return fail(Status::NumericalFailure, "the faces on either side of " + G.name + " share no input edge.");
          N = crossing(Os, k);
        }
        words_.push_back({Fs, Fp, N});
        const MoebiusQ Xg = (frame_ * h_[Fp]) * letter_map(X_, N).inverse() * (frame_ * h_[Fs]).inverse();
        XQ_.push_back(Xg);
        detail::set_quad_map(G, Xg);
        G.pairs = n;
        if (!generator_residuals(Xg, bs, bp, n, G)) return false;
        r_.residual_max = std::max(r_.residual_max, G.residual_max);
        r_.single_edge_spread = std::max(r_.single_edge_spread, G.single_edge_spread);
        r_.generators.push_back(std::move(G));
      }
    return true;
  }
  /// Residuals of generator Xg on the canonical positions of its n side pairs (sides starting at
  /// bs and bp in side_vertices), in quad, in frames centred on the two sides; the spread of the
  /// maps fitted to single edges.
  bool generator_residuals(const MoebiusQ& Xg, Index bs, Index bp, Index n, DeckGenerator& G) {
    const CutResult& canonical = *canonical_in_;
    const Index mid = n / 2;
    const MoebiusQ Cs = MoebiusQ::to_origin(pos_[canonical.side_vertices[bs + mid]]);
    const MoebiusQ Cp = MoebiusQ::to_origin(pos_[canonical.side_vertices[bp + n - 1 - mid]]);
    const MoebiusQ MQ = Cp * Xg * Cs.inverse();
    const Moebius M = MQ.to_double();
    std::vector<Pair> loc;
    double sum2 = 0;
    for (Index k = 0; k < n; ++k) {
      const CQ zq = Cs.apply(pos_[canonical.side_vertices[bs + k]]);
      const CQ wq = Cp.apply(pos_[canonical.side_vertices[bp + n - 1 - k]]);
      const double d = detail::hyperbolic_distance_q(MQ.apply(zq), wq);
      G.residual_max = std::max(G.residual_max, d);
      sum2 += d * d;
      loc.push_back({zq.to_double(), wq.to_double()});
    }
    G.residual_rms = std::sqrt(sum2 / double(n));
    G.initial_residual_max = G.residual_max;
    G.initial_residual_rms = G.residual_rms;
    for (std::size_t k = 0; k + 1 < loc.size(); ++k) {
      const Moebius E = moebius_from_two_points(loc[k].z, loc[k + 1].z, loc[k].w, loc[k + 1].w);
      for (const Pair& q : loc) G.single_edge_spread = std::max(G.single_edge_spread, hyperbolic_distance(E.apply(q.z), M.apply(q.z)));
    }
    if (!std::isfinite(G.residual_max) || !std::isfinite(G.single_edge_spread))
      return fail(Status::NumericalFailure, "generator " + G.name + " is not finite.");
    return true;
  }

  /// 7. The relation, conjugated to the corner v0, in quad: of the generators (from the adjusted
  /// pairings) and of the same words in the pairings as fitted.
  bool relation() {
    const CutResult& canonical = *canonical_in_;
    const CQ v0 = pos_[canonical.side_vertices[canonical.side_offsets[0]]];
    r_.relation_error = relation_of(XQ_, v0, &r_.relator);
    if (options_.adjust_pairings && !cycles_.empty()) {
      std::vector<MoebiusQ> XF;
      for (const Word& w : words_)
        XF.push_back((frame_ * tile_of(fitted_, w.Fp)) * letter_map(fitted_, w.N).inverse() *
                     (frame_ * tile_of(fitted_, w.Fs)).inverse());
      out_.fitted_relation_error = relation_of(XF, v0, nullptr);
    } else {
      out_.fitted_relation_error = r_.relation_error;
    }
    if (!std::isfinite(r_.relation_error) || !std::isfinite(out_.fitted_relation_error))
      return fail(Status::NumericalFailure, "the relation check is not finite.");
    r_.status = Status::Ok;
    char buf[240];
    std::snprintf(buf, sizeof buf,
                  "%d generators through %d domain pairings; residual max %.3g, relation error %.3g (%.3g with the "
                  "pairings as fitted).",
                  static_cast<int>(r_.generators.size()), static_cast<int>(out_.side_maps.size()), r_.residual_max,
                  r_.relation_error, out_.fitted_relation_error);
    r_.message = buf;
    r_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start_).count();
    out_.status = Status::Ok;
    out_.message = r_.message;
    out_.seconds = r_.seconds;
    return true;
  }
};


}  // namespace

DomainDeck deck_through_domain(const CutResult& canonical, const CutResult& domain, std::span<const double> dpos,
                               const DeckOptions& options, const Topology* surface) {
  return DomainDeckRun(&canonical, domain, dpos, options, surface).run();
}

DomainDeck fit_domain_pairings(const CutResult& domain, std::span<const double> dpos, const DeckOptions& options,
                               const Topology* surface) {
  return DomainDeckRun(nullptr, domain, dpos, options, surface).run();
}

DomainDeck widen_domain_pairings(const CutResult& domain, std::span<const double> dpos, const DomainDeck& pairings,
                                 const DeckOptions& options, const Topology* surface) {
  DeckOptions wide = options;
  wide.wide_pairings = true;
  wide.adjust_pairings = true;
  DomainDeck out = DomainDeckRun(nullptr, domain, dpos, wide, surface, &pairings).run();
  if (out.status == Status::Ok) out.fitted_relation_error = pairings.fitted_relation_error;
  return out;
}

}  // namespace ricci
