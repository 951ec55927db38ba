// Deck transformations: Möbius algebra of the Poincaré disk, the side-pairing generators of a
// laid-out canonical polygon (E: translations; H: SU(1,1) maps fitted with Ceres) and the
// surface-group relation. Conventions and the relation: ricci/deck.h.
#include "ricci/deck.h"

#include <algorithm>
#include <cfenv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include <ceres/ceres.h>

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

/// An SU(1,1) matrix in long double, for the relation check.
struct MoebiusL {
  using cl = std::complex<long double>;
  cl a{1, 0}, b{0, 0};
  MoebiusL() = default;
  MoebiusL(cl a_, cl b_) : a(a_), b(b_) {}
  explicit MoebiusL(const Moebius& m) : a(m.a), b(m.b) {}
  static MoebiusL to_origin(cplx p) {
    const cl q(p.real(), p.imag());
    const long double s = std::sqrt(1.0L - std::norm(q));
    return {1.0L / s, -q / s};
  }
  MoebiusL inverse() const { return {std::conj(a), -b}; }
  MoebiusL operator*(const MoebiusL& n) const { return {a * n.a + b * std::conj(n.b), a * n.b + b * std::conj(n.a)}; }
  double distance_to_identity() const {
    const long double minus = std::max(std::abs(a - 1.0L), std::abs(b));
    const long double plus = std::max(std::abs(a + 1.0L), std::abs(b));
    return static_cast<double>(std::min(minus, plus));
  }
};

/// A rigid motion z ↦ c z + t (|c| = 1) for the euclidean relation check.
struct Rigid {
  cplx c{1, 0}, t{0, 0};
  cplx apply(cplx z) const { return c * z + t; }
  Rigid inverse() const { return {std::conj(c), -std::conj(c) * t}; }
};
Rigid operator*(const Rigid& m, const Rigid& n) { return {m.c * n.c, m.c * n.t + m.t}; }

DeckResult fail(DeckResult r, Status s, std::string msg) {
  r.status = s;
  r.message = std::move(msg);
  r.generators.clear();
  return r;
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
      // Work in frames centred on the two sides: X = Cp^-1 · M · Cs with Cs, Cp moving the
      // sides' middle vertices to the origin. There the points are far from the unit circle and M
      // has small entries, so residuals are evaluated without cancellation (a layout point at
      // 1 − |z| ≈ 1e-7 mapped by X directly loses ~1e-7 of hyperbolic accuracy; centred, only
      // the resolution of its input coordinates, ≈ 1e-16/(1 − |z|), remains).
      const std::size_t mid = n / 2;
      const Moebius Cs = Moebius::to_origin(e.pairs[mid].z), Cp = Moebius::to_origin(e.pairs[mid].w);
      std::vector<Pair> local(n);
      for (std::size_t k = 0; k < n; ++k) local[k] = {Cs.apply(e.pairs[k].z), Cp.apply(e.pairs[k].w)};
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
        ceres::Solver::Summary summary;
        {
          // Ceres may evaluate trial points that raise floating-point flags; keep the caller's
          // trap settings out of it and restore them afterwards.
          std::fenv_t env;
          std::feholdexcept(&env);
          ceres::Solve(sopts, &problem, &summary);
          std::fesetenv(&env);
        }
        r.ceres_iterations += static_cast<int>(summary.iterations.size());
        // A round that cannot improve (Ceres FAILURE after consecutive invalid steps at the
        // optimum, or a non-finite update) keeps the current map: it is valid, and the residuals
        // below are measured independently of Ceres.
        const bool improved = std::isfinite(delta[0]) && std::isfinite(delta[1]) && std::isfinite(delta[2]) &&
                              delta[1] * delta[1] + delta[2] * delta[2] < 1 &&
                              summary.final_cost <= summary.initial_cost;
        if (!improved) break;
        M = (M * Moebius::from_theta_z0(delta[0], {delta[1], delta[2]})).normalized();
        if (summary.termination_type != ceres::CONVERGENCE) break;
      }
      const Moebius X = (Cp.inverse() * M * Cs).normalized();
      G.map = X;
      G.theta = X.theta();
      G.z0 = X.z0();
      G.translation_length = X.translation_length();
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
      if (!std::isfinite(G.residual_max) || !std::isfinite(G.single_edge_spread))
        return fail(r, Status::NumericalFailure, "generator " + e.name + " maps its side outside the disk.");
    }
    r.residual_max = std::max(r.residual_max, G.residual_max);
    r.single_edge_spread = std::max(r.single_edge_spread, G.single_edge_spread);
    r.generators.push_back(std::move(G));
  }

  // The relation Π [A_i^-1, B_i] = 1.
  if (geometry == Geometry::Hyperbolic) {
    Moebius R;
    for (Index i = 0; i < g; ++i) {
      const Moebius& A = r.generators[2 * i].map;
      const Moebius& B = r.generators[2 * i + 1].map;
      R = R * A.inverse() * B * A * B.inverse();
    }
    r.relator = R;
    // The error is measured on C R C^-1, C moving R's fixed point (corner v0) to the origin, in
    // long double: the partial products then stay among the tiles around the origin and keep
    // small norms (see the header).
    const MoebiusL C = MoebiusL::to_origin(pos(cut.side_vertices[cut.side_offsets[0]]));
    const MoebiusL Ci = C.inverse();
    MoebiusL RL;
    for (Index i = 0; i < g; ++i) {
      const MoebiusL A = C * MoebiusL(r.generators[2 * i].map) * Ci;
      const MoebiusL B = C * MoebiusL(r.generators[2 * i + 1].map) * Ci;
      RL = RL * A.inverse() * B * A * B.inverse();
    }
    r.relation_error = RL.distance_to_identity();
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
    double err = 0;
    for (Index s = 0; s < cut.num_sides(); ++s)
      for (Index i = cut.side_offsets[s]; i < cut.side_offsets[s + 1]; ++i) {
        const cplx z = pos(cut.side_vertices[i]);
        err = std::max(err, std::abs(R.apply(z) - z));
      }
    r.relation_error = err;
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
