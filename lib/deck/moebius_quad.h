// Quad-precision SU(1,1) maps of the Poincaré disk, for products of side pairings that reach far
// from the origin: a map at hyperbolic distance r from the identity has entries of size e^{r/2},
// so a product resolves the identity only to about ε·e^r. With 113-bit arithmetic (ε ≈ 1e-34)
// that stays below 1e-15 out to r ≈ 44, where a double coordinate of the disk is already 1.
#pragma once

#include <cfloat>
#include <cmath>
#include <complex>
#include <vector>

#include "ricci/deck.h"

namespace ricci::detail {

#if defined(__SIZEOF_FLOAT128__) && (defined(__x86_64__) || defined(__i386__))
using quad = __float128;  // software IEEE binary128 (GCC, Clang on x86)
inline constexpr double kQuadEpsilon = 1.925929944387236e-34;  // 2^-112
#else
using quad = long double;  // IEEE binary128 on aarch64 Linux; extended precision elsewhere
inline constexpr double kQuadEpsilon = static_cast<double>(LDBL_EPSILON);
#endif

/// Square root of x ≥ 0 in quad: Newton's iteration from the double root (each step doubles the
/// correct digits: 53 → 106 → 113+).
inline quad qsqrt(quad x) {
  if (!(x > 0)) return 0;
  quad y = std::sqrt(static_cast<double>(x));
  if (!(y > 0)) return 0;
  for (int k = 0; k < 3; ++k) y = (y + x / y) / 2;
  return y;
}

inline quad qabs(quad x) { return x < 0 ? -x : x; }

/// A complex number in quad.
struct CQ {
  quad re = 0, im = 0;
  CQ() = default;
  CQ(quad r, quad i) : re(r), im(i) {}
  explicit CQ(std::complex<double> z) : re(z.real()), im(z.imag()) {}
  std::complex<double> to_double() const { return {static_cast<double>(re), static_cast<double>(im)}; }
  quad norm() const { return re * re + im * im; }
  CQ conj() const { return {re, -im}; }
};
inline CQ operator+(CQ x, CQ y) { return {x.re + y.re, x.im + y.im}; }
inline CQ operator-(CQ x, CQ y) { return {x.re - y.re, x.im - y.im}; }
inline CQ operator-(CQ x) { return {-x.re, -x.im}; }
inline CQ operator*(CQ x, CQ y) { return {x.re * y.re - x.im * y.im, x.re * y.im + x.im * y.re}; }
inline CQ operator*(quad s, CQ x) { return {s * x.re, s * x.im}; }
inline CQ operator/(CQ x, CQ y) {
  const quad d = y.norm();
  return {(x.re * y.re + x.im * y.im) / d, (x.im * y.re - x.re * y.im) / d};
}

/// z ↦ (a z + b)/(b̄ z + ā) with |a|² − |b|² = 1, in quad.
struct MoebiusQ {
  CQ a{1, 0}, b{0, 0};
  MoebiusQ() = default;
  MoebiusQ(CQ a_, CQ b_) : a(a_), b(b_) {}
  explicit MoebiusQ(const Moebius& m) : a(m.a), b(m.b) {}
  /// The map moving p to the origin (z ↦ (z − p)/(1 − p̄ z), normalised).
  static MoebiusQ to_origin(CQ p) {
    const quad s = qsqrt(1 - p.norm());
    return {CQ{1 / s, 0}, (-1 / s) * p};
  }
  MoebiusQ inverse() const { return {a.conj(), -b}; }
  MoebiusQ operator*(const MoebiusQ& n) const { return {a * n.a + b * n.b.conj(), a * n.b + b * n.a.conj()}; }
  CQ apply(CQ z) const { return (a * z + b) / (b.conj() * z + a.conj()); }
  /// Rescaled to determinant 1 (rounding drift of long products).
  MoebiusQ normalized() const {
    const quad det = a.norm() - b.norm();
    if (!(det > 0)) return *this;
    const quad s = qsqrt(det);
    return {(1 / s) * a, (1 / s) * b};
  }
  /// Rounded entry by entry (no renormalisation in double: far from the origin |a|² − |b|²
  /// cancels there; the rounded map still acts to double precision and keeps its trace).
  Moebius to_double() const { return Moebius{a.to_double(), b.to_double()}; }
  /// Largest entry of M ∓ I, the sign nearer to the identity (PSU(1,1)).
  double distance_to_identity() const {
    const quad bb = qsqrt(b.norm());
    const quad minus = std::max(qsqrt((a - CQ{1, 0}).norm()), bb);
    const quad plus = std::max(qsqrt((a + CQ{1, 0}).norm()), bb);
    return static_cast<double>(std::min(minus, plus));
  }
};

/// Hyperbolic distance between two points of the disk given in quad (∞ outside the disk).
inline double hyperbolic_distance_q(CQ z, CQ w) {
  const quad oz = 1 - z.norm(), ow = 1 - w.norm();
  if (!(oz > 0) || !(ow > 0)) return INFINITY;
  const CQ den = CQ{1, 0} - w.conj() * z;
  const quad dn = den.norm();
  const quad x2 = (z - w).norm() / dn;
  const double x = std::sqrt(static_cast<double>(x2));
  if (x < 0.5) return 2 * std::atanh(static_cast<double>(qsqrt(x2)));
  // 2 artanh x = log((1 + x)² / (1 − x²)), 1 − x² = (1 − |z|²)(1 − |w|²)/|1 − w̄ z|².
  return 2 * std::log1p(x) - std::log(static_cast<double>(oz * ow / dn));
}

/// A weighted sum of points of the disk lifted to the hyperboloid, and its projection back: the
/// hyperboloid combination (the record of a vertex the cut added inside a face) or centre of mass.
struct HyperboloidSum {
  quad t = 0, x = 0, y = 0;
  void add(CQ z, quad weight) {
    const quad o = 1 - z.norm();
    t += weight * (1 + z.norm()) / o;
    x += weight * 2 * z.re / o;
    y += weight * 2 * z.im / o;
  }
  /// The normalised sum in the disk; false when degenerate.
  bool point(CQ& w) const {
    const quad n2 = t * t - x * x - y * y;
    if (!(n2 > 0)) return false;
    const quad den = t + qsqrt(n2);
    w = CQ{x / den, y / den};
    return true;
  }
};

/// A generator's map to quad precision: map + map_low, entry by entry.
inline MoebiusQ quad_map(const DeckGenerator& g) {
  return MoebiusQ(CQ(g.map.a) + CQ(g.map_low.a), CQ(g.map.b) + CQ(g.map_low.b));
}

/// Stores M into g: map rounded entry by entry, map_low what that rounding left out, and the
/// figures read from the map (theta, z0, translation_length).
inline void set_quad_map(DeckGenerator& g, const MoebiusQ& M) {
  g.map = M.to_double();
  g.map_low = MoebiusQ(M.a - CQ(g.map.a), M.b - CQ(g.map.b)).to_double();
  g.theta = g.map.theta();
  g.z0 = g.map.z0();
  g.translation_length = g.map.translation_length();
}

/// C M C^-1 for the product M = M_1 ⋯ M_n of `maps` and C = to_origin(at), formed as the product
/// of the factors C_{i-1} M_i C_i^-1, C_i = to_origin(p_i) at the images p_n = at,
/// p_{i-1} = M_i(p_i) (C_0 = C_n = C). The same map; where M nearly fixes `at` (a vertex cycle, a
/// relator) each factor moves a point near the origin to near the origin and has moderate entries,
/// so the rounding is not multiplied by the size of maps whose axes lie far out (entries e^r)
/// twice over, as forming M first and conjugating it would.
inline MoebiusQ product_at(const std::vector<MoebiusQ>& maps, CQ at) {
  const std::size_t n = maps.size();
  const MoebiusQ C = MoebiusQ::to_origin(at);
  std::vector<MoebiusQ> frame(n + 1, C);
  CQ p = at;
  for (std::size_t i = n; i-- > 1;) {
    p = maps[i].apply(p);
    frame[i] = MoebiusQ::to_origin(p);
  }
  MoebiusQ M;
  for (std::size_t i = 0; i < n; ++i) M = M * (frame[i] * maps[i] * frame[i + 1].inverse());
  return M;
}

/// The letters of the canonical relator [A1^-1, B1] … [Ag^-1, Bg] (product_at()'s maps).
inline std::vector<MoebiusQ> canonical_relator_letters(const std::vector<MoebiusQ>& gens) {
  std::vector<MoebiusQ> out;
  for (std::size_t i = 0; i + 1 < gens.size(); i += 2)
    out.insert(out.end(), {gens[i].inverse(), gens[i + 1], gens[i], gens[i + 1].inverse()});
  return out;
}

/// The canonical relator [A1^-1, B1] … [Ag^-1, Bg] of generators in the order a1 b1 a2 b2 …
/// (deck.h's relation).
inline MoebiusQ canonical_relator(const std::vector<MoebiusQ>& gens) {
  MoebiusQ R;
  for (std::size_t i = 0; i + 1 < gens.size(); i += 2)
    R = R * gens[i].inverse() * gens[i + 1] * gens[i] * gens[i + 1].inverse();
  return R;
}

}  // namespace ricci::detail
