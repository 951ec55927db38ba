// Tests of signature.h: the SL(2,Z) reduction (lands in the fundamental domain, its matrix is
// unimodular and maps τ to the result, equivalent moduli reduce to the same point), the fixed
// word list, and known answers: the torus of revolution (τ = i·√((R/r)² − 1), converging under
// refinement), invariance under rigid motion, scaling and vertex renumbering; genus-2 lengths.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "ricci/signature.h"
#include "ricci/topology.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "support.h"

namespace {

using ricci::Index;
using ricci::Mesh;
using cplx = std::complex<double>;

cplx mobius(const std::array<long long, 4>& m, cplx t) {
  return (static_cast<double>(m[0]) * t + static_cast<double>(m[1])) / (static_cast<double>(m[2]) * t + static_cast<double>(m[3]));
}

/// A torus of revolution, radii R > r, nu × nv quads split into triangles.
Mesh torus_of_revolution(double R, double r, int nu, int nv) {
  Mesh m;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      m.positions.insert(m.positions.end(), {(R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v)});
    }
  auto id = [&](int i, int j) { return static_cast<Index>(((i + nu) % nu) * nv + (j + nv) % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.faces.insert(m.faces.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.faces.insert(m.faces.end(), {id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

ricci::ConformalSignature signature_of(const Mesh& mesh) {
  const ricci::ValidateResult v = ricci::validate_mesh(mesh);
  REQUIRE_MESSAGE(v.status == ricci::Status::Ok, v.message);
  ricci::UniformizeOptions o;
  o.seed_checks = 0;
  const ricci::UniformizeResult r = ricci::uniformize(v.mesh, v.topology, o);
  REQUIRE_MESSAGE(r.status == ricci::Status::Ok, r.message);
  const ricci::ConformalSignature s = ricci::conformal_signature(r);
  REQUIRE_MESSAGE(s.status == ricci::Status::Ok, s.message);
  return s;
}

Mesh transformed(Mesh m, double scale, double angle, std::uint32_t renumber_seed) {
  const double c = std::cos(angle), s = std::sin(angle);
  for (std::size_t v = 0; v < m.positions.size() / 3; ++v) {
    double* p = &m.positions[3 * v];
    const double x = c * p[0] - s * p[2], z = s * p[0] + c * p[2];
    p[0] = scale * x + 0.25;
    p[1] = scale * p[1] - 1.5;
    p[2] = scale * z + 3;
  }
  if (renumber_seed != 0) {
    const auto nv = static_cast<std::size_t>(m.num_vertices());
    std::vector<Index> perm(nv);
    std::iota(perm.begin(), perm.end(), 0);
    std::mt19937 rng(renumber_seed);
    std::shuffle(perm.begin(), perm.end(), rng);
    std::vector<double> p(m.positions.size());
    for (std::size_t v = 0; v < nv; ++v)
      for (int k = 0; k < 3; ++k) p[3 * static_cast<std::size_t>(perm[v]) + k] = m.positions[3 * v + k];
    m.positions = p;
    for (Index& f : m.faces) f = perm[static_cast<std::size_t>(f)];
  }
  return m;
}

}  // namespace

TEST_CASE("signature: SL(2,Z) reduction lands in the fundamental domain with a unimodular matrix") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> re(-20, 20), lim(-6, 2);
  std::uniform_int_distribution<int> small(-4, 4);
  for (int trial = 0; trial < 2000; ++trial) {
    const cplx tau(re(rng), std::pow(10.0, lim(rng)));
    cplx red;
    std::array<long long, 4> m{};
    REQUIRE(ricci::reduce_modulus(tau, red, m));
    CHECK(m[0] * m[3] - m[1] * m[2] == 1);
    CHECK(red.real() >= -0.5 - 1e-12);
    CHECK(red.real() < 0.5);
    CHECK(std::abs(red) >= 1 - 1e-9);
    const cplx back = mobius(m, tau);
    CHECK(std::abs(back - red) <= 1e-9 * std::max(1.0, std::abs(red)));
    // An SL(2,Z)-equivalent modulus reduces to the same point.
    std::array<long long, 4> g{1, small(rng), 0, 1};
    if (trial % 2 == 0) g = {0, -1, 1, small(rng)};
    cplx red2;
    std::array<long long, 4> m2{};
    REQUIRE(ricci::reduce_modulus(mobius(g, tau), red2, m2));
    if (std::abs(std::abs(red) - 1) > 1e-6 && std::abs(std::abs(red.real()) - 0.5) > 1e-6)
      CHECK(std::abs(red2 - red) <= 1e-8 * std::abs(red));
  }
  cplx red;
  std::array<long long, 4> m{};
  CHECK(!ricci::reduce_modulus(cplx(1, -1), red, m));
  CHECK(!ricci::reduce_modulus(cplx(NAN, 1), red, m));
  // The boundary conventions: Re τ = ½ goes to −½; a point on the unit circle to Re τ ≤ 0.
  REQUIRE(ricci::reduce_modulus(cplx(0.5, 2), red, m));
  CHECK(red.real() == doctest::Approx(-0.5));
  REQUIRE(ricci::reduce_modulus(std::polar(1.0, 1.2), red, m));
  CHECK(red.real() <= 0);
  CHECK(std::abs(red) == doctest::Approx(1));
}

TEST_CASE("signature: the word list depends on the genus only and has one word per class") {
  for (Index g = 1; g <= 4; ++g) {
    std::vector<std::string> names;
    const auto words = ricci::signature_words(g, &names);
    REQUIRE(words.size() == names.size());
    CHECK(std::set<std::string>(names.begin(), names.end()).size() == names.size());
    for (Index k = 0; k < 2 * g; ++k) CHECK(words[static_cast<std::size_t>(k)].size() == 1);
    // Classes under rotation and inversion of two-letter words: no two words in one class.
    std::set<std::vector<int>> seen;
    for (const auto& w : words) {
      if (w.size() != 2) continue;
      const int x = 2 * w[0].first + (w[0].second < 0), y = 2 * w[1].first + (w[1].second < 0);
      CHECK(y != x);
      CHECK(y != (x ^ 1));
      const std::vector<std::vector<int>> cls = {{x, y}, {y, x}, {y ^ 1, x ^ 1}, {x ^ 1, y ^ 1}};
      const std::vector<int> rep = *std::min_element(cls.begin(), cls.end());
      CHECK(seen.insert(rep).second);
    }
    // Every class of two distinct non-inverse letters is present: 4g·(4g−2) ordered pairs.
    const std::size_t ordered = static_cast<std::size_t>(4 * g * (4 * g - 2));
    std::size_t covered = 0;
    for (int x = 0; x < 4 * g; ++x)
      for (int y = 0; y < 4 * g; ++y) {
        if (y == x || y == (x ^ 1)) continue;
        const std::vector<std::vector<int>> cls = {{x, y}, {y, x}, {y ^ 1, x ^ 1}, {x ^ 1, y ^ 1}};
        covered += seen.count(*std::min_element(cls.begin(), cls.end()));
      }
    CHECK(covered == ordered);
  }
}

TEST_CASE("signature: a torus of revolution has tau = i sqrt((R/r)^2 - 1), converging under refinement") {
  for (const double ratio : {3.0, 1.8}) {
    const double exact = std::sqrt(ratio * ratio - 1);
    const double want = std::max(exact, 1 / exact);
    double previous = INFINITY;
    for (const int nv : {12, 24}) {
      const int nu = static_cast<int>(std::lround(nv * ratio));
      const ricci::ConformalSignature s = signature_of(torus_of_revolution(ratio, 1.0, nu, nv));
      REQUIRE(s.has_torus);
      const double err = std::abs(s.torus.tau - cplx(0, want));
      MESSAGE("R/r = " << ratio << ", " << nu << "x" << nv << ": tau = " << s.torus.tau << ", error " << err);
      CHECK(err < 0.02 * want);
      CHECK(err < previous / 3);  // second order: halving h divides the error by about 4
      previous = err;
    }
  }
}

TEST_CASE("signature: invariant under rigid motion, scaling and vertex renumbering") {
  const Mesh torus = torus_of_revolution(2.5, 1.0, 30, 12);
  const ricci::ConformalSignature a = signature_of(torus);
  const ricci::ConformalSignature b = signature_of(transformed(torus, 3.75, 0.7, 0));
  const ricci::ConformalSignature c = signature_of(transformed(torus, 1.0, 0.0, 99));
  CHECK(std::abs(a.torus.tau - b.torus.tau) <= 1e-10);
  CHECK(std::abs(a.torus.tau - c.torus.tau) <= 1e-10);
  MESSAGE("torus: motion+scale " << std::abs(a.torus.tau - b.torus.tau) << ", renumbering " << std::abs(a.torus.tau - c.torus.tau));

  const ricci::ReadResult g2 = ricci::read_mesh((ricci_test::fixtures_dir() / "genus2.obj").string());
  REQUIRE(g2.status == ricci::Status::Ok);
  const ricci::ConformalSignature h = signature_of(g2.mesh);
  REQUIRE(h.words.size() == ricci::signature_words(2).size());
  double shortest = INFINITY;
  for (const ricci::WordLength& w : h.words) {
    CHECK(w.length > 0);
    CHECK(std::isfinite(w.uncertainty));
    shortest = std::min(shortest, w.length);
  }
  CHECK(h.systole.length == shortest);
  const ricci::ConformalSignature h2 = signature_of(transformed(g2.mesh, 0.5, 1.1, 0));
  double worst = 0;
  for (std::size_t k = 0; k < h.words.size(); ++k) worst = std::max(worst, std::abs(h.words[k].length - h2.words[k].length));
  MESSAGE("genus 2: largest change of a word length under motion+scale " << worst);
  CHECK(worst <= 1e-8);
}
