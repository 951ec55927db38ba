// Error-free transformations of IEEE doubles (Knuth's two-sum, Dekker's fast two-sum, the
// fused-multiply-add product), used by deck's double-double arithmetic (moebius_quad.h), and the
// few unevaluated sums hi + lo ("double-double", about 106 bits) that the layout's propagation
// keeps its positions in (layout.cpp, Positions): a vertex placed at
// p + offset keeps the digits of p that double coordinates would round away, so differences of
// neighbouring positions — the directions every later placement turns from — stay exact to the
// rounding of the offsets themselves however far from the origin the faces lie.
//
// Takes and gives plain doubles (and `Real`, such a sum as a value); needs round-to-nearest and no reassociation (-ffast-math breaks
// these identities).
#pragma once

#include <cmath>

namespace ricci::detail::dd {

/// s + e == a + b exactly, s = fl(a + b).
inline void two_sum(double a, double b, double& s, double& e) {
  s = a + b;
  const double bb = s - a;
  e = (a - (s - bb)) + (b - bb);
}

/// As two_sum() for |a| >= |b| (or a == 0).
inline void fast_two_sum(double a, double b, double& s, double& e) {
  s = a + b;
  e = b - (s - a);
}

/// p + e == a·b exactly (barring underflow), p = fl(a·b).
inline void two_prod(double a, double b, double& p, double& e) {
  p = a * b;
  e = std::fma(a, b, -p);
}

/// (ah + al) − (bh + bl) rounded to one double (relative error about 2⁻⁵³ of the difference).
inline double difference(double ah, double al, double bh, double bl) {
  double s, e;
  two_sum(ah, -bh, s, e);
  return s + (e + (al - bl));
}

/// (h, l) = (ah + al) + b, renormalized so that h = fl(h + l).
inline void add(double ah, double al, double b, double& h, double& l) {
  double s, e;
  two_sum(ah, b, s, e);
  fast_two_sum(s, e + al, h, l);
}

/// (h, l) = (ah + al)², to about 2⁻¹⁰⁴ relative.
inline void square(double ah, double al, double& h, double& l) {
  double p, e;
  two_prod(ah, ah, p, e);
  fast_two_sum(p, e + 2 * ah * al, h, l);
}

/// 1 − |z|² for z = (xh + xl) + i(yh + yl) in the unit disk, rounded to one double (relative
/// error about 2⁻⁵³ however near the unit circle z lies).
inline double one_minus_norm(double xh, double xl, double yh, double yl) {
  double x2, x2l, y2, y2l, s, sl, r, rl;
  square(xh, xl, x2, x2l);
  square(yh, yl, y2, y2l);
  two_sum(x2, y2, s, sl);
  sl += x2l + y2l;
  two_sum(1.0, -s, r, rl);
  return r + (rl - sl);
}

/// An unevaluated sum h + l with |l| ≤ ulp(h)/2, and the few operations the disk maps need, each
/// to about 2⁻¹⁰⁴ relative to its result (Dekker; the quotient by one correction step).
struct Real {
  double h = 0, l = 0;
};

inline Real operator+(Real a, Real b) {
  double s, e;
  two_sum(a.h, b.h, s, e);
  Real r;
  fast_two_sum(s, e + (a.l + b.l), r.h, r.l);
  return r;
}
inline Real operator-(Real a) { return {-a.h, -a.l}; }
inline Real operator-(Real a, Real b) { return a + -b; }
inline Real operator*(Real a, Real b) {
  double p, e;
  two_prod(a.h, b.h, p, e);
  Real r;
  fast_two_sum(p, e + (a.h * b.l + a.l * b.h), r.h, r.l);
  return r;
}
inline Real operator/(Real a, Real b) {
  const double q = a.h / b.h;
  const Real rest = a - Real{q, 0} * b;
  Real r;
  fast_two_sum(q, rest.h / b.h, r.h, r.l);
  return r;
}

}  // namespace ricci::detail::dd
