// Quad-precision SU(1,1) maps of the Poincaré disk, for products of side pairings that reach far
// from the origin: a map at hyperbolic distance r from the identity has entries of size e^{r/2},
// so a product resolves the identity only to about ε·e^r. With 113-bit arithmetic (ε ≈ 1e-34)
// that stays below 1e-15 out to r ≈ 44, where a double coordinate of the disk is already 1.
#pragma once

#include <cfloat>
#include <cmath>
#include <complex>
#include <type_traits>
#include <vector>

#include <qd/qd_real.h>

#include "double_double.h"
#include "ricci/deck.h"

namespace ricci::detail {

#if defined(__SIZEOF_FLOAT128__) && (defined(__x86_64__) || defined(__i386__))
using quad = __float128;  // software IEEE binary128 (GCC, Clang on x86)
inline constexpr double kQuadEpsilon = 1.925929944387236e-34;  // 2^-112
#else
using quad = long double;  // IEEE binary128 on aarch64 Linux; extended precision elsewhere
inline constexpr double kQuadEpsilon = static_cast<double>(LDBL_EPSILON);
#endif

/// A double-double h + l (|l| ≤ ulp(h)/2), about 106 bits, in hardware double arithmetic
/// (double_double.h's error-free sums and products, two correction steps per quotient): several
/// times faster than software binary128, for what is only measured — the trial moves and
/// substitutions of canonical_generators(), whose chosen moves are then made in quad. Each
/// operation is exact to about 2^-104 of its result; the range is double's. Needs round-to-nearest
/// and no reassociation (-ffast-math breaks these identities).
struct DoubleDouble {
  double h = 0, l = 0;
  DoubleDouble() = default;
  DoubleDouble(double x) : h(x) {}  // NOLINT: implicit, as for a built-in floating type
  constexpr DoubleDouble(double hi, double lo, int) : h(hi), l(lo) {}
  explicit operator double() const { return h + l; }
};

// The sum with both parts' errors kept (the products and cycles here cancel heavily; the
// layout's dd::Real adds the low parts without them).
inline DoubleDouble operator+(DoubleDouble x, DoubleDouble y) {
  double s, e, t, f;
  dd::two_sum(x.h, y.h, s, e);
  dd::two_sum(x.l, y.l, t, f);
  e += t;
  dd::fast_two_sum(s, e, s, e);
  e += f;
  dd::fast_two_sum(s, e, s, e);
  return {s, e, 0};
}
inline DoubleDouble operator-(DoubleDouble x) { return {-x.h, -x.l, 0}; }
inline DoubleDouble operator-(DoubleDouble x, DoubleDouble y) { return x + -y; }
inline DoubleDouble operator*(DoubleDouble x, DoubleDouble y) {
  double p, e, s;
  dd::two_prod(x.h, y.h, p, e);
  dd::fast_two_sum(p, e + (x.h * y.l + x.l * y.h), s, e);
  return {s, e, 0};
}
inline DoubleDouble operator/(DoubleDouble x, DoubleDouble y) {
  const double q1 = x.h / y.h;
  const DoubleDouble r = x - y * DoubleDouble(q1);
  const double q2 = r.h / y.h;
  const DoubleDouble r2 = r - y * DoubleDouble(q2);
  const double q3 = r2.h / y.h;
  double s, e;
  dd::fast_two_sum(q1, q2, s, e);
  return DoubleDouble{s, e, 0} + DoubleDouble(q3);
}
inline DoubleDouble& operator+=(DoubleDouble& x, DoubleDouble y) { return x = x + y; }
inline DoubleDouble& operator-=(DoubleDouble& x, DoubleDouble y) { return x = x - y; }
inline DoubleDouble& operator*=(DoubleDouble& x, DoubleDouble y) { return x = x * y; }
inline DoubleDouble& operator/=(DoubleDouble& x, DoubleDouble y) { return x = x / y; }
inline bool operator<(DoubleDouble x, DoubleDouble y) { return x.h < y.h || (x.h == y.h && x.l < y.l); }
inline bool operator>(DoubleDouble x, DoubleDouble y) { return y < x; }
inline bool operator<=(DoubleDouble x, DoubleDouble y) { return !(y < x) && x.h == x.h && y.h == y.h; }
inline bool operator>=(DoubleDouble x, DoubleDouble y) { return y <= x; }
inline bool operator==(DoubleDouble x, DoubleDouble y) { return x.h == y.h && x.l == y.l; }
inline bool operator!=(DoubleDouble x, DoubleDouble y) { return !(x == y); }

/// A quad-double (QD's qd_real: four doubles, about 212 bits, double's exponent range), for what
/// quad cannot resolve: the side pairings closed on their vertex cycles, the canonical generators
/// evaluated from their words and their geodesic polygon, where the polygon reaches so far that
/// 113 bits leave the relation above 1e-12 (a row of 20 holes: reach 28, quad floor 3e-10). About
/// three times quad's cost per operation; used only on that retry (uniformize()).
struct Wide {
  qd_real v;
  Wide() : v(0.0) {}
  Wide(double x) : v(x) {}  // NOLINT: implicit, as for a built-in floating type
  Wide(int x) : v(static_cast<double>(x)) {}  // NOLINT
  explicit Wide(const qd_real& x) : v(x) {}
  explicit operator double() const { return v.x[0] + v.x[1]; }
};
inline Wide operator+(const Wide& x, const Wide& y) { return Wide(x.v + y.v); }
inline Wide operator-(const Wide& x) { return Wide(-x.v); }
inline Wide operator-(const Wide& x, const Wide& y) { return Wide(x.v - y.v); }
inline Wide operator*(const Wide& x, const Wide& y) { return Wide(x.v * y.v); }
inline Wide operator/(const Wide& x, const Wide& y) { return Wide(x.v / y.v); }
inline Wide& operator+=(Wide& x, const Wide& y) { return x = x + y; }
inline Wide& operator-=(Wide& x, const Wide& y) { return x = x - y; }
inline Wide& operator*=(Wide& x, const Wide& y) { return x = x * y; }
inline Wide& operator/=(Wide& x, const Wide& y) { return x = x / y; }
inline bool operator<(const Wide& x, const Wide& y) { return x.v < y.v; }
inline bool operator>(const Wide& x, const Wide& y) { return x.v > y.v; }
inline bool operator<=(const Wide& x, const Wide& y) { return x.v <= y.v; }
inline bool operator>=(const Wide& x, const Wide& y) { return x.v >= y.v; }
inline bool operator==(const Wide& x, const Wide& y) { return x.v == y.v; }
inline bool operator!=(const Wide& x, const Wide& y) { return !(x == y); }
inline bool qisnan(const Wide& x) { return x.v.isnan(); }
/// 2^-209: QD's quad-double resolves its values to about this (a few bits below 4 × 53).
inline constexpr double kWideEpsilon = 1.5407439555097887e-63;

/// NaN (or an overflow, whose low part is then NaN).
inline bool qisnan(DoubleDouble x) { return std::isnan(x.h + x.l); }
inline bool qisnan(quad x) { return __builtin_isnan(x); }

/// A quad value as a double-double (rounded to its 106 bits), and back (exactly).
inline DoubleDouble to_dd(quad x) {
  const double h = static_cast<double>(x);
  return {h, static_cast<double>(x - h), 0};
}
inline quad to_quad(DoubleDouble x) { return quad(x.h) + quad(x.l); }
/// A quad value as a quad-double (exactly: 113 bits in three doubles), and back (rounded).
inline Wide to_wide(quad x) {
  const double h = static_cast<double>(x);
  const quad r1 = x - quad(h);
  const double m = static_cast<double>(r1);
  const double l = static_cast<double>(r1 - quad(m));
  return Wide(qd_real(h, m, l, 0.0));
}
inline quad to_quad(const Wide& x) { return quad(x.v.x[0]) + quad(x.v.x[1]) + quad(x.v.x[2]) + quad(x.v.x[3]); }
inline DoubleDouble to_dd(const Wide& x) { return {x.v.x[0], x.v.x[1], 0}; }

/// Square root of x ≥ 0: Newton's iteration from the double root (each step doubles the correct
/// digits: 53 → 106 → 113+).
template <class T>
T qsqrt(T x) {
  if (!(x > 0)) return 0;
  T y = std::sqrt(static_cast<double>(x));
  if (!(y > 0)) return 0;
  for (int k = 0; k < 3; ++k) y = (y + x / y) / 2;
  return y;
}

template <class T>
T qabs(T x) {
  return x < 0 ? -x : x;
}

/// A complex number in quad (T = quad) or double-double.
template <class T>
struct BasicCQ {
  T re = 0, im = 0;
  BasicCQ() = default;
  BasicCQ(T r, T i) : re(r), im(i) {}
  explicit BasicCQ(std::complex<double> z) : re(z.real()), im(z.imag()) {}
  std::complex<double> to_double() const { return {static_cast<double>(re), static_cast<double>(im)}; }
  T norm() const { return re * re + im * im; }
  BasicCQ conj() const { return {re, -im}; }
  friend BasicCQ operator+(BasicCQ x, BasicCQ y) { return {x.re + y.re, x.im + y.im}; }
  friend BasicCQ operator-(BasicCQ x, BasicCQ y) { return {x.re - y.re, x.im - y.im}; }
  friend BasicCQ operator-(BasicCQ x) { return {-x.re, -x.im}; }
  friend BasicCQ operator*(BasicCQ x, BasicCQ y) { return {x.re * y.re - x.im * y.im, x.re * y.im + x.im * y.re}; }
  friend BasicCQ operator*(T s, BasicCQ x) { return {s * x.re, s * x.im}; }
  friend BasicCQ operator/(BasicCQ x, BasicCQ y) {
    const T d = y.norm();
    return {(x.re * y.re + x.im * y.im) / d, (x.im * y.re - x.re * y.im) / d};
  }
};

/// z ↦ (a z + b)/(b̄ z + ā) with |a|² − |b|² = 1, in quad (T = quad) or double-double.
template <class T>
struct BasicMoebius {
  using CQ = BasicCQ<T>;
  CQ a{1, 0}, b{0, 0};
  BasicMoebius() = default;
  BasicMoebius(CQ a_, CQ b_) : a(a_), b(b_) {}
  explicit BasicMoebius(const Moebius& m) : a(m.a), b(m.b) {}
  /// The map moving p to the origin (z ↦ (z − p)/(1 − p̄ z), normalised).
  static BasicMoebius to_origin(CQ p) {
    const T s = qsqrt(T(1) - p.norm());
    return {CQ{T(1) / s, 0}, (T(-1) / s) * p};
  }
  BasicMoebius inverse() const { return {a.conj(), -b}; }
  BasicMoebius operator*(const BasicMoebius& n) const { return {a * n.a + b * n.b.conj(), a * n.b + b * n.a.conj()}; }
  CQ apply(CQ z) const { return (a * z + b) / (b.conj() * z + a.conj()); }
  /// Rescaled to determinant 1 (rounding drift of long products).
  BasicMoebius normalized() const {
    const T det = a.norm() - b.norm();
    if (!(det > 0)) return *this;
    const T s = qsqrt(det);
    return {(T(1) / s) * a, (T(1) / s) * b};
  }
  /// Rounded entry by entry (no renormalisation in double: far from the origin |a|² − |b|²
  /// cancels there; the rounded map still acts to double precision and keeps its trace).
  Moebius to_double() const { return Moebius{a.to_double(), b.to_double()}; }
  /// Largest entry of M ∓ I, the sign nearer to the identity (PSU(1,1)).
  double distance_to_identity() const {
    // Entries beyond 1e150: ∞ without forming their squares (beyond double's range, and
    // quad-double's).
    for (const T* x : {&a.re, &a.im, &b.re, &b.im})
      if (!(qabs(*x) < T(1e150))) return INFINITY;
    const T bb = qsqrt(b.norm());
    const T minus = std::max(qsqrt((a - CQ{1, 0}).norm()), bb);
    const T plus = std::max(qsqrt((a + CQ{1, 0}).norm()), bb);
    return static_cast<double>(std::min(minus, plus));
  }
};

using CQ = BasicCQ<quad>;
using MoebiusQ = BasicMoebius<quad>;

/// Whether every entry of M is below `bound` in magnitude, compared part by part (no product is
/// formed, so nothing overflows; NaN is not below). Double-double and quad-double have double's
/// exponent range: the products and squared norms their code forms stay finite only for maps
/// whose entries are checked so first.
template <class T>
bool entries_below(const BasicMoebius<T>& M, double bound) {
  for (const T* x : {&M.a.re, &M.a.im, &M.b.re, &M.b.im})
    if (!(qabs(*x) < T(bound))) return false;
  return true;
}
template <class T>
bool entries_below(const std::vector<BasicMoebius<T>>& maps, double bound) {
  for (const BasicMoebius<T>& M : maps)
    if (!entries_below(M, bound)) return false;
  return true;
}

/// A map in quad as a double-double one (each entry rounded to 106 bits).
inline BasicMoebius<DoubleDouble> to_dd(const MoebiusQ& m) {
  using C = BasicCQ<DoubleDouble>;
  return {C{to_dd(m.a.re), to_dd(m.a.im)}, C{to_dd(m.b.re), to_dd(m.b.im)}};
}
/// A double-double point or map in quad (exactly; a map is not renormalised).
inline CQ to_quad(const BasicCQ<DoubleDouble>& z) { return {to_quad(z.re), to_quad(z.im)}; }
inline MoebiusQ to_quad(const BasicMoebius<DoubleDouble>& m) { return {to_quad(m.a), to_quad(m.b)}; }

using CW = BasicCQ<Wide>;
using MoebiusW = BasicMoebius<Wide>;

/// Points and maps between quad and quad-double (exactly that way, rounded the other), and
/// quad-double rounded to double-double.
inline CW to_wide(const CQ& z) { return {to_wide(z.re), to_wide(z.im)}; }
inline MoebiusW to_wide(const MoebiusQ& m) { return {to_wide(m.a), to_wide(m.b)}; }
inline CQ to_quad(const CW& z) { return {to_quad(z.re), to_quad(z.im)}; }
inline MoebiusQ to_quad(const MoebiusW& m) { return {to_quad(m.a), to_quad(m.b)}; }
inline const MoebiusQ& to_quad(const MoebiusQ& m) { return m; }
inline BasicMoebius<DoubleDouble> to_dd(const MoebiusW& m) {
  using C = BasicCQ<DoubleDouble>;
  return {C{to_dd(m.a.re), to_dd(m.a.im)}, C{to_dd(m.b.re), to_dd(m.b.im)}};
}
inline Wide to_wide(DoubleDouble x) { return Wide(qd_real(x.h, x.l, 0.0, 0.0)); }
inline MoebiusW to_wide(const BasicMoebius<DoubleDouble>& m) {
  return {CW{to_wide(m.a.re), to_wide(m.a.im)}, CW{to_wide(m.b.re), to_wide(m.b.im)}};
}

/// A quad map or point in the arithmetic T (quad: itself; quad-double: exactly), and a
/// double-double one (exactly); the rounding unit of T and its bits.
template <class T>
BasicMoebius<T> from_quad(const MoebiusQ& m) {
  if constexpr (std::is_same_v<T, quad>) return m;
  else return to_wide(m);
}
template <class T>
BasicCQ<T> from_quad(const CQ& z) {
  if constexpr (std::is_same_v<T, quad>) return z;
  else return to_wide(z);
}
template <class T>
BasicMoebius<T> from_dd(const BasicMoebius<DoubleDouble>& m) {
  if constexpr (std::is_same_v<T, quad>) return to_quad(m);
  else return to_wide(m);
}
template <class T>
BasicCQ<T> from_dd(const BasicCQ<DoubleDouble>& z) {
  if constexpr (std::is_same_v<T, quad>) return to_quad(z);
  else return {to_wide(z.re), to_wide(z.im)};
}
template <class T>
constexpr double epsilon_of() {
  return std::is_same_v<T, quad> ? kQuadEpsilon : kWideEpsilon;
}
template <class T>
constexpr int bits_of() {
  return std::is_same_v<T, quad> ? 113 : 212;
}

/// Hyperbolic distance between two points of the disk given in quad (∞ outside the disk).
template <class T>
double hyperbolic_distance_q(BasicCQ<T> z, BasicCQ<T> w) {
  const T oz = T(1) - z.norm(), ow = T(1) - w.norm();
  if (!(oz > 0) || !(ow > 0)) return INFINITY;
  const BasicCQ<T> den = BasicCQ<T>{1, 0} - w.conj() * z;
  const T dn = den.norm();
  const T x2 = (z - w).norm() / dn;
  const double x = std::sqrt(static_cast<double>(x2));
  if (x < 0.5) return 2 * std::atanh(static_cast<double>(qsqrt(x2)));
  // 2 artanh x = log((1 + x)² / (1 − x²)), 1 − x² = (1 − |z|²)(1 − |w|²)/|1 − w̄ z|².
  return 2 * std::log1p(x) - std::log(static_cast<double>(oz * ow / dn));
}

/// A weighted sum of points of the disk lifted to the hyperboloid, and its projection back: the
/// hyperboloid combination (the record of a vertex the cut added inside a face) or centre of mass.
template <class T>
struct BasicHyperboloidSum {
  T t = 0, x = 0, y = 0;
  void add(BasicCQ<T> z, T weight) {
    const T o = T(1) - z.norm();
    t += weight * (T(1) + z.norm()) / o;
    x += weight * T(2) * z.re / o;
    y += weight * T(2) * z.im / o;
  }
  /// The normalised sum in the disk; false when degenerate.
  bool point(BasicCQ<T>& w) const {
    const T n2 = t * t - x * x - y * y;
    if (!(n2 > 0)) return false;
    const T den = t + qsqrt(n2);
    w = BasicCQ<T>{x / den, y / den};
    return true;
  }
};
using HyperboloidSum = BasicHyperboloidSum<quad>;

/// A generator's map to quad precision: map + map_low (+ map_low2 when it was stored in
/// quad-double), entry by entry.
inline MoebiusQ quad_map(const DeckGenerator& g) {
  return MoebiusQ(CQ(g.map.a) + CQ(g.map_low.a) + CQ(g.map_low2.a), CQ(g.map.b) + CQ(g.map_low.b) + CQ(g.map_low2.b));
}

/// Whether g carries a map stored in quad-double (set_wide_map()).
inline bool has_wide_map(const DeckGenerator& g) {
  return g.map_low2.a != std::complex<double>(0, 0) || g.map_low2.b != std::complex<double>(0, 0) ||
         g.map_low3.a != std::complex<double>(0, 0) || g.map_low3.b != std::complex<double>(0, 0);
}

/// A generator's map in quad-double: its four parts, entry by entry (exact).
inline MoebiusW wide_map(const DeckGenerator& g) {
  auto entry = [](double p0, double p1, double p2, double p3) { return Wide(qd_real(p0, p1, p2, p3)); };
  const Moebius* part[4] = {&g.map, &g.map_low, &g.map_low2, &g.map_low3};
  auto at = [&](int k, int which) {  // which: a.re, a.im, b.re, b.im
    const Moebius& m = *part[k];
    return which == 0 ? m.a.real() : which == 1 ? m.a.imag() : which == 2 ? m.b.real() : m.b.imag();
  };
  Wide e[4];
  for (int w = 0; w < 4; ++w) e[w] = entry(at(0, w), at(1, w), at(2, w), at(3, w));
  return {CW{e[0], e[1]}, CW{e[2], e[3]}};
}

/// The figures read from g's double map (theta, z0, translation_length).
inline void set_map_figures(DeckGenerator& g) {
  g.theta = g.map.theta();
  g.z0 = g.map.z0();
  g.translation_length = g.map.translation_length();
}

/// Stores M into g: map rounded entry by entry, map_low what that rounding left out (map_low2
/// and map_low3 zero), and the figures read from the map.
inline void set_quad_map(DeckGenerator& g, const MoebiusQ& M) {
  g.map = M.to_double();
  g.map_low = MoebiusQ(M.a - CQ(g.map.a), M.b - CQ(g.map.b)).to_double();
  g.map_low2 = g.map_low3 = Moebius{{0, 0}, {0, 0}};
  set_map_figures(g);
}

/// Stores a quad-double M into g: its four parts in map, map_low, map_low2, map_low3.
inline void set_wide_map(DeckGenerator& g, const MoebiusW& M) {
  Moebius* part[4] = {&g.map, &g.map_low, &g.map_low2, &g.map_low3};
  for (int k = 0; k < 4; ++k)
    *part[k] = Moebius{{M.a.re.v.x[k], M.a.im.v.x[k]}, {M.b.re.v.x[k], M.b.im.v.x[k]}};
  set_map_figures(g);
}

/// Stores M (quad or quad-double) into g (set_quad_map(), set_wide_map()).
inline void set_map(DeckGenerator& g, const MoebiusQ& M) { set_quad_map(g, M); }
inline void set_map(DeckGenerator& g, const MoebiusW& M) { set_wide_map(g, M); }

/// The frames C_i = to_origin(p_i) at the images p_n = at, p_{i-1} = M_i(p_i) of `at` along the
/// product M_1 ⋯ M_n of `maps`, with C_0 = C_n = to_origin(at) (product_at()).
template <class T>
std::vector<BasicMoebius<T>> product_frames(const std::vector<BasicMoebius<T>>& maps, BasicCQ<T> at) {
  using M = BasicMoebius<T>;
  const std::size_t n = maps.size();
  std::vector<M> frame(n + 1, M::to_origin(at));
  BasicCQ<T> p = at;
  for (std::size_t i = n; i-- > 1;) {
    p = maps[i].apply(p);
    frame[i] = M::to_origin(p);
  }
  return frame;
}

/// C M C^-1 for the product M = M_1 ⋯ M_n of `maps` and C = to_origin(at), formed as the product
/// of the factors C_{i-1} M_i C_i^-1 (product_frames()). The same map; where M nearly fixes `at`
/// (a vertex cycle, a relator) each factor moves a point near the origin to near the origin and
/// has moderate entries, so the rounding is not multiplied by the size of maps whose axes lie far
/// out (entries e^r) twice over, as forming M first and conjugating it would.
template <class T>
BasicMoebius<T> product_at(const std::vector<BasicMoebius<T>>& maps, BasicCQ<T> at) {
  const std::vector<BasicMoebius<T>> frame = product_frames(maps, at);
  BasicMoebius<T> out;
  for (std::size_t i = 0; i < maps.size(); ++i) out = out * (frame[i] * maps[i] * frame[i + 1].inverse());
  return out;
}

/// The letters of the canonical relator [A1^-1, B1] … [Ag^-1, Bg] (product_at()'s maps).
template <class T>
std::vector<BasicMoebius<T>> canonical_relator_letters(const std::vector<BasicMoebius<T>>& gens) {
  std::vector<BasicMoebius<T>> out;
  for (std::size_t i = 0; i + 1 < gens.size(); i += 2)
    out.insert(out.end(), {gens[i].inverse(), gens[i + 1], gens[i], gens[i + 1].inverse()});
  return out;
}

/// The canonical relator [A1^-1, B1] … [Ag^-1, Bg] of generators in the order a1 b1 a2 b2 …
/// (deck.h's relation).
template <class T>
BasicMoebius<T> canonical_relator(const std::vector<BasicMoebius<T>>& gens) {
  BasicMoebius<T> R;
  for (std::size_t i = 0; i + 1 < gens.size(); i += 2)
    R = R * gens[i].inverse() * gens[i + 1] * gens[i] * gens[i + 1].inverse();
  return R;
}

}  // namespace ricci::detail
