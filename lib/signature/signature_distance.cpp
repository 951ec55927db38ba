// ricci — distances between conformal signatures (signature.h): takes two ConformalSignatures of
// the same kind, gives one number (and its uncertainty) to rank shapes by.
#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>
#include <array>
#include <tuple>
#include <utility>
#include <string>
#include <vector>

#include "ricci/signature.h"

namespace ricci {

namespace {

using cplx = std::complex<double>;

double upper_half_plane_distance(cplx z, cplx w) {
  return 2 * std::asinh(std::abs(z - w) / (2 * std::sqrt(z.imag() * w.imag())));
}

/// Nearest distance from z to the translates w + k.
double nearest_translate(cplx z, cplx w) {
  const double k0 = std::round(z.real() - w.real());
  double best = INFINITY;
  for (double k = k0 - 1; k <= k0 + 1; k += 1) best = std::min(best, upper_half_plane_distance(z, w + k));
  return best;
}

std::string kind_of(const ConformalSignature& s) {
  if (s.has_torus) return "modular";
  if (s.has_circle_domain) return "circle_domain";
  if (!s.boundary_geodesics.empty()) return "boundary_geodesics";
  if (!s.spectrum.empty()) return "length_spectrum";
  return {};
}

/// Largest entry difference of two n×n matrices with rows/columns of b permuted.
double permuted_difference(const std::vector<double>& a, const std::vector<double>& b, const std::vector<std::size_t>& p,
                           std::size_t n) {
  double d = 0;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j) d = std::max(d, std::abs(a[i * n + j] - b[p[i] * n + p[j]]));
  return d;
}

double max_entry(const std::vector<double>& v) {
  double m = 0;
  for (const double x : v)
    if (std::isfinite(x)) m = std::max(m, x);
  return m;
}

constexpr std::size_t kSpectrumCompared = 16;

/// ℓ∞ distance of the spectra's first K values (signature.h).
double spectrum_distance(const std::vector<double>& a, const std::vector<double>& b) {
  const std::size_t K = std::min({a.size(), b.size(), kSpectrumCompared});
  if (K == 0) return INFINITY;
  double d = 0;
  for (std::size_t k = 0; k < K; ++k) d = std::max(d, std::abs(a[k] - b[k]));
  return d;
}

/// Twist difference modulo the period (the mean of the two lengths).
double twist_difference(double ta, double tb, double period) {
  const double d = ta - tb;
  if (!(period > 0)) return d;
  return d - period * std::round(d / period);
}

/// The Fenchel–Nielsen distance minimized over the handle rotations of b (signature.h).
void marked_distance(const ConformalSignature& a, const ConformalSignature& b, SignatureDistance& out) {
  if (!a.has_fenchel_nielsen || b.generators.size() != a.generators.size() || b.generators.size() < 4) return;
  const FenchelNielsen& fa = a.fenchel_nielsen;
  const std::size_t n = b.generators.size(), g = n / 2;
  for (std::size_t rot = 0; rot < g; ++rot) {
    std::vector<Moebius> gens(n), low(n, Moebius{{0, 0}, {0, 0}});
    std::vector<double> res(n, 0);
    for (std::size_t k = 0; k < n; ++k) {
      gens[k] = b.generators[(k + 2 * rot) % n];
      if (b.generator_low.size() == n) low[k] = b.generator_low[(k + 2 * rot) % n];
      if (b.generator_residuals.size() == n) res[k] = b.generator_residuals[(k + 2 * rot) % n];
    }
    const FenchelNielsen fb = fenchel_nielsen(gens, res, low);
    if (fb.status != Status::Ok || fb.lengths.size() != fa.lengths.size()) continue;
    double s = 0, u = 0;
    for (std::size_t i = 0; i < fa.lengths.size(); ++i) {
      const double dl = fa.lengths[i] - fb.lengths[i];
      const double dt = twist_difference(fa.twists[i], fb.twists[i], 0.5 * (fa.lengths[i] + fb.lengths[i]));
      s += dl * dl + dt * dt;
      u += fa.length_uncertainty[i] + fb.length_uncertainty[i] + fa.twist_uncertainty[i] + fb.twist_uncertainty[i];
    }
    if (std::isnan(out.marked_distance) || std::sqrt(s) < out.marked_distance) {
      out.marked_distance = std::sqrt(s);
      out.marked_uncertainty = u;
    }
  }
}

}  // namespace

double modular_distance(cplx tau1, cplx tau2) {
  cplx t1, t2;
  std::array<long long, 4> m1{}, m2{};
  if (!reduce_modulus(tau1, t1, m1) || !reduce_modulus(tau2, t2, m2)) return INFINITY;
  double best = nearest_translate(t1, t2);
  // Cosets with bottom row (c, d), c ≥ 1: Im(γ t2) = Im t2 / |c t2 + d|², and a point lower than
  // Im t1 · e^-best (or higher than Im t1 · e^best) cannot beat `best`.
  for (long long c = 1;; ++c) {
    const double cc = static_cast<double>(c);
    if (t2.imag() / (cc * cc * t2.imag() * t2.imag()) < t1.imag() * std::exp(-best)) break;
    const double centre = -cc * t2.real();
    const double reach = std::sqrt(std::max(t2.imag() * std::exp(best) / t1.imag() - cc * cc * t2.imag() * t2.imag(), 0.0));
    for (long long d = static_cast<long long>(std::floor(centre - reach)); d <= static_cast<long long>(std::ceil(centre + reach)); ++d) {
      if (std::gcd(c, d) != 1) continue;
      // γ0 = [[a, b], [c, d]] with a d − b c = 1 (extended Euclid); other cosets differ by T^k.
      long long x0 = 1, y0 = 0, x1 = 0, y1 = 1, r0 = d, r1 = c;
      while (r1 != 0) {
        const long long q = r0 / r1;
        std::tie(r0, r1) = std::make_pair(r1, r0 - q * r1);
        std::tie(x0, x1) = std::make_pair(x1, x0 - q * x1);
        std::tie(y0, y1) = std::make_pair(y1, y0 - q * y1);
      }
      // x0·d + y0·c = r0 = ±1: a = r0·x0, b = −r0·y0.
      const double a = static_cast<double>(r0 * x0), b = static_cast<double>(-r0 * y0);
      const cplx w = (a * t2 + b) / (cc * t2 + static_cast<double>(d));
      best = std::min(best, nearest_translate(t1, w));
    }
  }
  return best;
}

SignatureDistance signature_distance(const ConformalSignature& a, const ConformalSignature& b) {
  SignatureDistance out;
  out.status = Status::InvalidArgument;
  if (a.status != Status::Ok || b.status != Status::Ok) {
    out.message = "a signature is not valid: " + (a.status != Status::Ok ? a.message : b.message);
    return out;
  }
  const std::string ka = kind_of(a), kb = kind_of(b);
  if (ka.empty() || ka != kb || a.genus != b.genus || a.boundary_loops != b.boundary_loops) {
    out.message = "the two surfaces are not of the same kind: genus " + std::to_string(a.genus) + " with " +
                  std::to_string(a.boundary_loops) + " boundary loops (" + ka + ") against genus " +
                  std::to_string(b.genus) + " with " + std::to_string(b.boundary_loops) + " (" + kb + ")";
    return out;
  }
  out.kind = ka;
  try {
    if (ka == "modular") {
      out.distance = modular_distance(a.torus.tau, b.torus.tau);
      out.uncertainty = a.torus.uncertainty / a.torus.tau.imag() + b.torus.uncertainty / b.torus.tau.imag();
    } else if (ka == "circle_domain") {
      const std::size_t n = a.circle_domain.circles.size();
      if (b.circle_domain.circles.size() != n) {
        out.message = "the circle domains have different numbers of circles";
        return out;
      }
      std::vector<std::size_t> p(n);
      std::iota(p.begin(), p.end(), 0);
      double best = permuted_difference(a.circle_domain.separation, b.circle_domain.separation, p, n);
      if (n <= 8)
        while (std::next_permutation(p.begin(), p.end()))
          best = std::min(best, permuted_difference(a.circle_domain.separation, b.circle_domain.separation, p, n));
      out.distance = best;
      out.uncertainty = max_entry(a.circle_domain.separation_uncertainty) + max_entry(b.circle_domain.separation_uncertainty);
    } else if (ka == "boundary_geodesics") {
      std::vector<double> la, lb;
      double ua = 0, ub = 0;
      for (const BoundaryGeodesic& g : a.boundary_geodesics) {
        la.push_back(g.length);
        ua = std::max(ua, g.uncertainty);
      }
      for (const BoundaryGeodesic& g : b.boundary_geodesics) {
        lb.push_back(g.length);
        ub = std::max(ub, g.uncertainty);
      }
      std::sort(la.begin(), la.end());
      std::sort(lb.begin(), lb.end());
      for (std::size_t i = 0; i < la.size() && i < lb.size(); ++i) out.distance = std::max(out.distance, std::abs(la[i] - lb[i]));
      out.uncertainty = ua + ub;
    } else {
      out.distance = spectrum_distance(a.spectrum, b.spectrum);
      out.uncertainty = 2 * (max_entry(a.generator_residuals) + max_entry(b.generator_residuals)) * 4;
      marked_distance(a, b, out);
    }
  } catch (const std::exception& e) {
    out.status = Status::OutOfMemory;
    out.message = std::string("signature distance: ") + e.what();
    return out;
  }
  out.status = Status::Ok;
  out.message = "ok";
  return out;
}

}  // namespace ricci
