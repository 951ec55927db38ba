// ricci — Fenchel–Nielsen coordinates of a closed hyperbolic surface (signature.h): takes the
// canonical generators A1 B1 … Ag Bg as Möbius maps of the disk, gives the lengths and twists of
// the 3g − 3 pants curves the canonical basis defines.
//
// Arithmetic: the generators arrive as double maps plus their low parts (DeckGenerator::map_low)
// and every product, fixed point and cross-ratio is formed in quad (moebius_quad.h): a surface
// whose canonical generators have axes far from the origin has matrix entries of 10⁷ and more,
// and double products of them lose every digit of the traces.
//
// Geometry used: a hyperbolic element's axis runs from its repelling to its attracting fixed point
// (p, q on the unit circle). The map f(z) = (z − p)/(z − q), followed by a unimodular constant,
// sends the disk to a half-plane with the axis on the imaginary axis, so the signed position of a
// point x of the axis is log|x − p| − log|x − q| (hyperbolic distance along it). The common
// perpendicular from that axis to a disjoint geodesic with ends u, v is the circle |w| = √(f(u)f(v))
// there, so its foot sits at ½ Σ_{z∈{u,v}} (log|z − p| − log|z − q|).
#include <algorithm>
#include <cmath>
#include <complex>
#include <string>
#include <vector>

#include "moebius_quad.h"
#include "ricci/signature.h"
#include "signature_internal.h"

namespace ricci {

namespace {

using detail::CQ;
using detail::MoebiusQ;
using detail::quad;

/// An element as a product of generator letters, with the letters' use counts for uncertainties.
struct GroupElement {
  MoebiusQ map;
  std::vector<int> uses;  ///< #generators: how often each generator occurs
  std::string word;

  GroupElement inverse() const {
    GroupElement e{map.inverse(), uses, {}};
    // Reverse the word and invert every letter.
    std::vector<std::string> letters;
    std::size_t start = 0;
    while (start < word.size()) {
      std::size_t end = word.find(' ', start);
      if (end == std::string::npos) end = word.size();
      letters.push_back(word.substr(start, end - start));
      start = end + 1;
    }
    for (auto it = letters.rbegin(); it != letters.rend(); ++it) {
      std::string l = *it;
      const std::size_t hat = l.find("^-1");
      if (hat != std::string::npos)
        l.erase(hat);
      else
        l.append("^-1");
      if (!e.word.empty()) e.word.push_back(' ');
      e.word.append(l);
    }
    return e;
  }
};

GroupElement operator*(const GroupElement& x, const GroupElement& y) {
  GroupElement e{(x.map * y.map).normalized(), x.uses, x.word};
  for (std::size_t k = 0; k < e.uses.size(); ++k) e.uses[k] += y.uses[k];
  if (!e.word.empty() && !y.word.empty()) e.word.push_back(' ');
  e.word.append(y.word);
  return e;
}

/// Repelling and attracting fixed points of a hyperbolic element (false otherwise).
bool axis_of(const MoebiusQ& m0, CQ& p, CQ& q) {
  const MoebiusQ m = m0.normalized();
  const quad re = m.a.re;
  if (!(detail::qabs(re) > 1) || !std::isfinite(static_cast<double>(re)) || !(m.b.norm() > 0)) return false;
  const quad s = detail::qsqrt((detail::qabs(re) - 1) * (detail::qabs(re) + 1));
  const quad sigma = re > 0 ? 1 : -1;
  const CQ ib(0, m.a.im), bc = m.b.conj();
  q = (ib + CQ{sigma * s, 0}) / bc;
  p = (ib - CQ{sigma * s, 0}) / bc;
  q = (1 / detail::qsqrt(q.norm())) * q;
  p = (1 / detail::qsqrt(p.norm())) * p;
  return true;
}

double log_abs(CQ z) { return 0.5 * std::log(static_cast<double>(z.norm())); }

/// Signed position along the axis (p → q) of the foot of the common perpendicular to the geodesic
/// with ends u, v; false when the two geodesics are not disjoint (they cross or share an end).
bool foot_position(CQ p, CQ q, CQ u, CQ v, double& position) {
  const CQ cross = ((u - p) * (v - q)) / ((u - q) * (v - p));
  if (!(cross.re > 0) || !std::isfinite(static_cast<double>(cross.re))) return false;
  position = 0.5 * (log_abs(u - p) - log_abs(u - q) + log_abs(v - p) - log_abs(v - q));
  return std::isfinite(position);
}

/// "a1", "c3", …: a letter and a 1-based index (built by appending: GCC 12's -Wrestrict misfires
/// on "lit" + std::string).
std::string indexed(char letter, std::size_t index) {
  std::string s(1, letter);
  s.append(std::to_string(index));
  return s;
}

struct Curve {
  std::string name;
  GroupElement element;
  GroupElement first_partner;
  GroupElement second_partner;
};

std::vector<Curve> pants_curves(const std::vector<GroupElement>& A, const std::vector<GroupElement>& B) {
  const std::size_t g = A.size();
  std::vector<GroupElement> c(g), d(g + 1);
  for (std::size_t i = 0; i < g; ++i) c[i] = A[i].inverse() * B[i] * A[i] * B[i].inverse();
  d[1] = c[0];
  for (std::size_t k = 2; k <= g; ++k) d[k] = d[k - 1] * c[k - 1];
  std::vector<Curve> curves;
  for (std::size_t i = 0; i < g; ++i)
    curves.push_back({indexed('a', i + 1), A[i], c[i], B[i].inverse() * c[i] * B[i]});
  const std::size_t nc = g == 2 ? 1 : g;
  for (std::size_t i = 0; i < nc; ++i) {
    GroupElement second;
    if (g == 2)
      second = A[1];
    else if (i == 0)
      second = c[1];
    else if (i + 1 <= g - 1)
      second = d[i];
    else
      second = d[g - 2];
    curves.push_back({indexed('c', i + 1), c[i], A[i], second});
  }
  for (std::size_t k = 2; k + 2 <= g; ++k)
    curves.push_back({indexed('d', k), d[k], c[k - 1], c[k]});
  return curves;
}

}  // namespace

FenchelNielsen fenchel_nielsen(std::span<const Moebius> generators, std::span<const double> residuals,
                               std::span<const Moebius> low) {
  FenchelNielsen out;
  out.status = Status::InvalidArgument;
  const std::size_t n = generators.size();
  if (n < 4 || n % 2 != 0) {
    out.message = "Fenchel–Nielsen coordinates need the 2g ≥ 4 canonical generators of a closed surface of genus "
                  "≥ 2; got " + std::to_string(n) + " generators";
    return out;
  }
  if ((!residuals.empty() && residuals.size() != n) || (!low.empty() && low.size() != n)) {
    out.message = "residuals and low parts: expected one per generator (" + std::to_string(n) + "), got " +
                  std::to_string(residuals.size()) + " and " + std::to_string(low.size());
    return out;
  }
  try {
    const std::size_t g = n / 2;
    std::vector<GroupElement> A(g), B(g);
    for (std::size_t i = 0; i < g; ++i) {
      A[i] = {quad_generator(generators, low, 2 * i), std::vector<int>(n, 0), indexed('a', i + 1)};
      A[i].uses[2 * i] = 1;
      B[i] = {quad_generator(generators, low, 2 * i + 1), std::vector<int>(n, 0), indexed('b', i + 1)};
      B[i].uses[2 * i + 1] = 1;
    }
    std::vector<double> norm(n);
    for (std::size_t i = 0; i < g; ++i) {
      norm[2 * i] = matrix_norm(A[i].map);
      norm[2 * i + 1] = matrix_norm(B[i].map);
    }
    // Fits: 2 × the residuals of the letters used; arithmetic: length_rounding() over them.
    auto uncertainty = [&](const std::vector<int>& uses, double length) {
      double u = 0, product = 1;
      int letters = 0;
      for (std::size_t k = 0; k < n; ++k) {
        if (!residuals.empty()) u += uses[k] * residuals[k];
        product *= std::pow(norm[k], uses[k]);
        letters += uses[k];
      }
      return 2 * u + length_rounding(length, product, letters);
    };
    for (const Curve& c : pants_curves(A, B)) {
      CQ p, q, u1, v1, u2, v2;
      if (!axis_of(c.element.map, p, q)) {
        out.message = "curve " + c.name + " (" + c.element.word + ") is not hyperbolic: not a closed surface's group";
        return out;
      }
      double t1 = 0, t2 = 0;
      const bool first = axis_of(c.first_partner.map, u1, v1) && foot_position(p, q, u1, v1, t1);
      const bool second = axis_of(c.second_partner.map, u2, v2) && foot_position(p, q, u2, v2, t2);
      if (!first || !second) {
        out.message = "curve " + c.name + ": the axis of its seam partner " +
                      (first ? c.second_partner.word : c.first_partner.word) + " is not disjoint from its axis: the "
                      "generators are not a closed surface's canonical generators";
        return out;
      }
      std::vector<int> uses = c.element.uses;
      for (std::size_t k = 0; k < n; ++k) uses[k] += c.first_partner.uses[k] + c.second_partner.uses[k];
      out.curves.push_back(c.name);
      out.words.push_back(c.element.word);
      out.lengths.push_back(translation_length_q(c.element.map));
      out.twists.push_back(t2 - t1);
      out.length_uncertainty.push_back(uncertainty(c.element.uses, out.lengths.back()));
      out.twist_uncertainty.push_back(uncertainty(uses, out.lengths.back()));
    }
  } catch (const std::exception& e) {
    out.status = Status::OutOfMemory;
    out.message = std::string("Fenchel–Nielsen coordinates: ") + e.what();
    return out;
  }
  out.status = Status::Ok;
  out.message = "ok";
  return out;
}

MoebiusQ quad_generator(std::span<const Moebius> generators, std::span<const Moebius> low, std::size_t k) {
  MoebiusQ m(generators[k]);
  if (!low.empty()) m = MoebiusQ(m.a + CQ(low[k].a), m.b + CQ(low[k].b));
  return m.normalized();
}

double translation_length_q(const MoebiusQ& m0) {
  const MoebiusQ m = m0.normalized();
  const double re = std::abs(static_cast<double>(m.a.re));
  if (!(re > 1)) return 0;
  // 2·arccosh x = 2·log(x + √(x² − 1)); for x near 1 from the quad difference x − 1.
  const quad x1 = detail::qabs(m.a.re) - 1;
  const double d = static_cast<double>(x1);
  return 2 * std::log1p(d + std::sqrt(d * (d + 2)));
}

double matrix_norm(const MoebiusQ& m) {
  return std::sqrt(static_cast<double>(m.a.norm())) + std::sqrt(static_cast<double>(m.b.norm()));
}

double length_rounding(double length, double norm_product, int letters) {
  const double x = std::cosh(length / 2);
  const double dx = letters * 2.5e-32 * norm_product;
  return x > 1 ? 2 * dx / std::sqrt((x - 1) * (x + 1)) : INFINITY;
}

}  // namespace ricci
