// Points of the three model spaces for developing triangles face by face (internal).
//
// E: the plane z = 0; S: the unit sphere; H: the hyperboloid x² + y² − z² = −1, z > 0. The pole is
// the origin (E) or (0, 0, 1) (S, H); angles turn counter-clockwise seen from +z.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>

#include "ricci/metric.h"

namespace ricci::model {

using P3 = std::array<double, 3>;

inline P3 add(const P3& a, const P3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline P3 sub(const P3& a, const P3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline P3 mul(const P3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline double dot(const P3& a, const P3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double lorentz(const P3& a, const P3& b) { return a[0] * b[0] + a[1] * b[1] - a[2] * b[2]; }
inline P3 cross(const P3& a, const P3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// The model's pole and the point at distance r from it in direction φ (measured from +x).
inline P3 pole(Geometry g) { return g == Geometry::Euclidean ? P3{0, 0, 0} : P3{0, 0, 1}; }
inline P3 polar(Geometry g, double r, double phi) {
  const double c = std::cos(phi), s = std::sin(phi);
  switch (g) {
    case Geometry::Euclidean: return {r * c, r * s, 0};
    case Geometry::Spherical: return {std::sin(r) * c, std::sin(r) * s, std::cos(r)};
    case Geometry::Hyperbolic: return {std::sinh(r) * c, std::sinh(r) * s, std::cosh(r)};
  }
  return {};
}

// Distance of x from the pole.
inline double from_pole(Geometry g, const P3& x) {
  const double rho = std::hypot(x[0], x[1]);
  switch (g) {
    case Geometry::Euclidean: return rho;
    case Geometry::Spherical: return std::atan2(rho, x[2]);
    case Geometry::Hyperbolic: return std::asinh(rho);
  }
  return 0;
}

// The point at distance r from p, at angle `angle` to the left of the geodesic from p to q
// (counter-clockwise seen from outside the sphere / from above the plane and the hyperboloid),
// into `out`. False (out untouched) where rounding leaves no direction from p to q: p and q equal
// in double, or, far out on the hyperboloid, a tangent or a point whose Lorentz norm cancelled to
// zero or below. Precondition: finite p and q (in H, below kModelReach from the pole).
inline bool turn_and_walk(Geometry g, const P3& p, const P3& q, double angle, double r, P3& out) {
  const double c = std::cos(angle), s = std::sin(angle);
  switch (g) {
    case Geometry::Euclidean: {
      P3 d = sub(q, p);
      const double n = std::hypot(d[0], d[1]);
      if (!(n > 0)) return false;
      d = mul(d, 1 / n);
      out = {p[0] + r * (c * d[0] - s * d[1]), p[1] + r * (s * d[0] + c * d[1]), 0};
      return true;
    }
    case Geometry::Spherical: {
      P3 n = cross(p, q);                       // normal of the great circle through p and q
      const double nn = dot(n, n);
      if (!(nn > 0)) return false;
      n = mul(n, 1 / std::sqrt(nn));
      const P3 t = cross(n, p);                 // unit tangent at p towards q
      const P3 left = cross(p, t);              // unit tangent at p, 90° to the left of t
      P3 x = add(mul(p, std::cos(r)), mul(add(mul(t, c), mul(left, s)), std::sin(r)));
      const double xx = dot(x, x);
      if (!(xx > 0)) return false;
      out = mul(x, 1 / std::sqrt(xx));
      return true;
    }
    case Geometry::Hyperbolic: {
      P3 t = add(q, mul(p, lorentz(p, q)));     // q's component tangent at p
      const double tt = lorentz(t, t);
      if (!(tt > 0)) return false;
      t = mul(t, 1 / std::sqrt(tt));
      P3 left = cross(p, t);                    // J (p × t): Lorentz-orthogonal to p and t
      left[2] = -left[2];
      P3 x = add(mul(p, std::cosh(r)), mul(add(mul(t, c), mul(left, s)), std::sinh(r)));
      const double xx = -lorentz(x, x);
      if (!(xx > 0)) return false;
      out = mul(x, 1 / std::sqrt(xx));
      return true;
    }
  }
  return false;
}

// How far from the pole a development may carry points (every coordinate's magnitude; in H about
// e^346, a hyperbolic distance of 347): beyond it products of two coordinates (Lorentz products,
// norms) could overflow.
inline constexpr double kModelReach = 0x1p500;
inline bool within_reach(const P3& x) {
  return std::abs(x[0]) < kModelReach && std::abs(x[1]) < kModelReach && std::abs(x[2]) < kModelReach;
}

// H: z_p − z_q of two hyperboloid points from their spatial parts, (|p|² − |q|²)/(z_p + z_q)
// with z² = 1 + x² + y²: exact to the rounding of the result however close the points are. The
// difference of the stored z coordinates themselves is off by their rounding (2⁻⁵³ z), which for
// points 1e-12 apart near the pole is 1e8 times the true difference (about |x|·|p − q|), and its
// square then moves their distance by 1.6e-8 of itself.
inline double hyperboloid_dz(const P3& p, const P3& q) {
  return ((p[0] - q[0]) * (p[0] + q[0]) + (p[1] - q[1]) * (p[1] + q[1])) / (p[2] + q[2]);
}

// The geodesic distance of two model points (accurate for close points: H from the spatial
// differences and hyperboloid_dz()).
inline double distance(Geometry g, const P3& p, const P3& q) {
  const P3 d = sub(p, q);
  switch (g) {
    case Geometry::Euclidean: return std::hypot(d[0], d[1]);
    case Geometry::Spherical: return std::atan2(std::sqrt(dot(cross(p, q), cross(p, q))), dot(p, q));
    case Geometry::Hyperbolic: {
      const double dz = hyperboloid_dz(p, q);
      return 2 * std::asinh(0.5 * std::sqrt(std::max(0.0, d[0] * d[0] + d[1] * d[1] - dz * dz)));
    }
  }
  return 0;
}

// Great-circle distance of two unit vectors (accurate for close and for nearly antipodal points).
inline double sphere_distance(const P3& x, const P3& y) {
  const P3 c = cross(x, y);
  return std::atan2(std::sqrt(dot(c, c)), dot(x, y));
}

// Hyperbolic distance of two Poincaré-disk points (accurate for close points); +∞ for points on
// or outside the unit circle.
inline double disk_distance(std::complex<double> z, std::complex<double> w) {
  // sinh²(d/2) = |z − w|² / ((1 − |z|²)(1 − |w|²)) from the squared moduli (no hypot), while
  // |z − w|² is a normal number and the points are inside the disk; the moduli otherwise.
  const double nz = std::norm(z), nw = std::norm(w), nd = std::norm(z - w);
  if (nd >= 0x1p-1000 && nz < 1 && nw < 1) return 2 * std::asinh(std::sqrt(nd / ((1 - nz) * (1 - nw))));
  const double az = std::abs(z), aw = std::abs(w);
  const double dz = (1 - az) * (1 + az), dw = (1 - aw) * (1 + aw);
  if (!(dz > 0 && dw > 0)) return std::numeric_limits<double>::infinity();
  return 2 * std::asinh(std::abs(z - w) / std::sqrt(dz * dw));
}

// The disk isometry that takes p to the origin, applied to z.
inline std::complex<double> disk_to_origin(std::complex<double> p, std::complex<double> z) {
  return (z - p) / (1.0 - std::conj(p) * z);
}

// The point a fraction t of the way from p to q along the chord, projected back onto the model.
inline P3 on_chord(Geometry g, const P3& p, const P3& q, double t) {
  P3 x = add(mul(p, 1 - t), mul(q, t));
  switch (g) {
    case Geometry::Euclidean: return x;
    case Geometry::Spherical: return mul(x, 1 / std::sqrt(dot(x, x)));
    case Geometry::Hyperbolic: return mul(x, 1 / std::sqrt(-lorentz(x, x)));
  }
  return x;
}

}  // namespace ricci::model

namespace ricci::detail {

/// Angle between sides b and c of a triangle of geometry g whose third side (opposite the
/// angle) is a (half-angle formula, never NaN for lengths that round past the triangle inequality;
/// metric.cpp).
double angle_from_lengths(Geometry g, double a, double b, double c);

}  // namespace ricci::detail
