// The internal sparse solver (lib/core/sparse_solver.h), white box: blocks of the inverse taken
// from the factor by sparse forward solves along elimination-tree paths agree with full solves,
// for the positive definite factor and for the pinned (Woodbury) indefinite one, with a shift, in
// the supernodal and the simplicial layout.
#include <doctest/doctest.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "sparse_solver.h"

namespace {

/// Upper triangle (compressed columns) of a 5-point grid operator on an m×m grid: 4 + d (plus a
/// small variation) on the diagonal, −1 to each neighbour; positive definite for d > 0.
struct Grid {
  std::int64_t n = 0;
  std::vector<std::int64_t> col_ptr, row;
  std::vector<double> val;
};

Grid grid(std::int64_t m, double d) {
  Grid g;
  g.n = m * m;
  g.col_ptr.push_back(0);
  for (std::int64_t j = 0; j < g.n; ++j) {
    const std::int64_t x = j % m, y = j / m;
    // rows < j, increasing: (x, y−1) then (x−1, y), then the diagonal
    if (y > 0) {
      g.row.push_back(j - m);
      g.val.push_back(-1);
    }
    if (x > 0) {
      g.row.push_back(j - 1);
      g.val.push_back(-1);
    }
    g.row.push_back(j);
    g.val.push_back(4 + d + 1e-3 * static_cast<double>(j % 7));
    g.col_ptr.push_back(static_cast<std::int64_t>(g.row.size()));
  }
  return g;
}

/// The largest difference between a k×k block of the inverse (row-major, unknowns `index`) and
/// the same entries taken from full solves with the factor at hand.
double difference_to_full_solves(ricci::detail::SymmetricSolver& s, std::int64_t n,
                                 const std::vector<std::int64_t>& index, const std::vector<double>& block) {
  const std::size_t k = index.size();
  std::vector<double> e(static_cast<std::size_t>(n)), x(static_cast<std::size_t>(n));
  double worst = 0;
  for (std::size_t c = 0; c < k; ++c) {
    std::fill(e.begin(), e.end(), 0.0);
    e[static_cast<std::size_t>(index[c])] = 1;
    if (!s.solve(e, x)) return INFINITY;
    for (std::size_t r = 0; r < k; ++r)
      worst = std::max(worst, std::abs(block[r * k + c] - x[static_cast<std::size_t>(index[r])]));
  }
  return worst;
}

}  // namespace

const char* layout_name(ricci::detail::FactorLayout layout) {
  using ricci::detail::FactorLayout;
  return layout == FactorLayout::Supernodal ? "supernodal" : layout == FactorLayout::Simplicial ? "simplicial" : "automatic";
}

constexpr ricci::detail::FactorLayout kLayouts[] = {ricci::detail::FactorLayout::Supernodal,
                                                     ricci::detail::FactorLayout::Simplicial};

TEST_CASE("sparse solver: blocks of the inverse from the factor match full solves") {
  using ricci::detail::FactorKind;
  using ricci::detail::FactorOutcome;
  struct Case {
    const char* name;
    double d, shift;
    FactorKind kind;
  };
  for (const auto layout : kLayouts)
  for (const Case& c : {Case{"positive definite", 0.01, 0.0, FactorKind::PositiveDefinite},
                        Case{"positive definite, shifted", 0.01, 0.5, FactorKind::PositiveDefinite},
                        Case{"pinned (Woodbury)", 0.01, 0.0, FactorKind::Indefinite}}) {
    const std::string name = std::string(c.name) + ", " + layout_name(layout);
    CAPTURE(name);
    const Grid g = grid(60, c.d);
    ricci::detail::SymmetricSolver s;
    s.set_layout(layout);
    REQUIRE(s.analyze(g.n, g.col_ptr, g.row, c.kind) == FactorOutcome::Ok);
    CHECK(s.supernodal() == (layout == ricci::detail::FactorLayout::Supernodal));
    // Unknowns spread over the grid, one of them twice.
    const std::vector<std::int64_t> index = {0, 59, 1234, 1800, 1801, 3599, 2222, 1234};
    const double flops = s.prepare_block(index);
    REQUIRE(flops > 0);
    std::copy(g.val.begin(), g.val.end(), s.values().begin());
    REQUIRE(s.factorize(c.shift) == FactorOutcome::Ok);
    const std::size_t k = index.size();
    std::vector<double> block(k * k, NAN);
    REQUIRE(s.inverse_block(block));
    const double worst = difference_to_full_solves(s, g.n, index, block);
    MESSAGE(name << ": largest difference to full solves " << worst << ", estimated flops " << flops);
    CHECK(worst < 1e-13);
    // Symmetric, with a positive diagonal (the inverse of a positive definite matrix).
    for (std::size_t r = 0; r < k; ++r) {
      CHECK(block[r * k + r] > 0);
      for (std::size_t q = 0; q < k; ++q) CHECK(std::abs(block[r * k + q] - block[q * k + r]) < 1e-15);
    }
  }
}

TEST_CASE("sparse solver: a given ordering is used and gives the same solutions") {
  using ricci::detail::FactorKind;
  using ricci::detail::FactorOutcome;
  for (const auto layout : kLayouts)
  for (const FactorKind kind : {FactorKind::PositiveDefinite, FactorKind::Indefinite}) {
    CAPTURE(layout_name(layout));
    const Grid g = grid(40, 0.01);
    const auto n = static_cast<std::size_t>(g.n);
    ricci::detail::SymmetricSolver chosen, given;
    chosen.set_layout(layout);
    given.set_layout(layout);
    REQUIRE(chosen.analyze(g.n, g.col_ptr, g.row, kind) == FactorOutcome::Ok);
    std::vector<std::int64_t> order(n);
    REQUIRE(chosen.ordering(order));
    std::vector<int> seen(n, 0);
    for (const std::int64_t k : order) {
      REQUIRE(k >= 0);
      REQUIRE(k < g.n);
      ++seen[static_cast<std::size_t>(k)];
    }
    for (const int c : seen) CHECK(c == 1);
    // Not a permutation: refused.
    std::vector<std::int64_t> bad = order;
    bad[0] = bad[1];
    ricci::detail::SymmetricSolver refused;
    CHECK(refused.analyze(g.n, g.col_ptr, g.row, kind, bad) == FactorOutcome::Failed);
    REQUIRE(given.analyze(g.n, g.col_ptr, g.row, kind, order) == FactorOutcome::Ok);
    std::vector<std::int64_t> again(n);
    REQUIRE(given.ordering(again));
    CHECK(again == order);
    CHECK(given.factor_nonzeros() == chosen.factor_nonzeros());
    std::copy(g.val.begin(), g.val.end(), chosen.values().begin());
    std::copy(g.val.begin(), g.val.end(), given.values().begin());
    REQUIRE(chosen.factorize() == FactorOutcome::Ok);
    REQUIRE(given.factorize() == FactorOutcome::Ok);
    std::vector<double> b(n), x1(n), x2(n);
    for (std::size_t i = 0; i < n; ++i) b[i] = std::sin(0.37 * static_cast<double>(i));
    REQUIRE(chosen.solve(b, x1));
    REQUIRE(given.solve(b, x2));
    double worst = 0;
    for (std::size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(x1[i] - x2[i]));
    CHECK(worst < 1e-12);
  }
}

// Both layouts report a non-positive pivot of the positive definite kind (the flow then shifts),
// and factor the indefinite kind; the automatic layout is simplicial on a small grid and the
// solutions of all layouts agree.
TEST_CASE("sparse solver: layouts agree, and both report an indefinite matrix") {
  using ricci::detail::FactorKind;
  using ricci::detail::FactorLayout;
  using ricci::detail::FactorOutcome;
  const Grid g = grid(30, 0.01);
  const auto n = static_cast<std::size_t>(g.n);
  std::vector<double> indefinite = g.val;
  // A negative diagonal entry in the last column (a negative eigenvalue).
  indefinite.back() = -3;
  std::vector<double> b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = std::cos(0.61 * static_cast<double>(i));
  std::vector<std::vector<double>> solutions;
  for (const FactorLayout layout : {FactorLayout::Automatic, FactorLayout::Supernodal, FactorLayout::Simplicial}) {
    CAPTURE(layout_name(layout));
    ricci::detail::SymmetricSolver pd, ind;
    pd.set_layout(layout);
    ind.set_layout(layout);
    REQUIRE(pd.analyze(g.n, g.col_ptr, g.row, FactorKind::PositiveDefinite) == FactorOutcome::Ok);
    REQUIRE(ind.analyze(g.n, g.col_ptr, g.row, FactorKind::Indefinite) == FactorOutcome::Ok);
    if (layout == FactorLayout::Automatic) CHECK(!pd.supernodal());
    std::copy(indefinite.begin(), indefinite.end(), pd.values().begin());
    CHECK(pd.factorize() == FactorOutcome::NotPositiveDefinite);
    // A shift large enough makes it positive definite again.
    CHECK(pd.factorize(8) == FactorOutcome::Ok);
    std::copy(indefinite.begin(), indefinite.end(), ind.values().begin());
    REQUIRE(ind.factorize() == FactorOutcome::Ok);
    std::vector<double> x(n), r(n, 0.0);
    REQUIRE(ind.solve(b, x));
    // Residual of the indefinite system, from the upper triangle.
    for (std::int64_t j = 0; j < g.n; ++j)
      for (std::int64_t k = g.col_ptr[j]; k < g.col_ptr[j + 1]; ++k) {
        const std::int64_t i = g.row[k];
        r[i] += indefinite[k] * x[j];
        if (i != j) r[j] += indefinite[k] * x[i];
      }
    double worst = 0;
    for (std::size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(r[i] - b[i]));
    CHECK(worst < 1e-12);
    solutions.push_back(x);
  }
  for (std::size_t k = 1; k < solutions.size(); ++k)
    for (std::size_t i = 0; i < n; ++i) CHECK(std::abs(solutions[k][i] - solutions[0][i]) < 1e-12);
}

// A block of more than 64 unknowns is made in parallel (rows of ZᵀZ per thread): the same block,
// bit for bit, on 1 and 2 threads, and still that of full solves.
TEST_CASE("sparse solver: a large block of the inverse is the same on 1 and 2 threads") {
  using ricci::detail::FactorKind;
  using ricci::detail::FactorOutcome;
  for (const auto layout : kLayouts) {
    CAPTURE(layout_name(layout));
    const Grid g = grid(60, 0.01);
    ricci::detail::SymmetricSolver s;
    s.set_layout(layout);
    REQUIRE(s.analyze(g.n, g.col_ptr, g.row, FactorKind::PositiveDefinite) == FactorOutcome::Ok);
    std::vector<std::int64_t> index;
    for (std::int64_t i = 0; i < g.n; i += 29) index.push_back(i);
    REQUIRE(index.size() > 64);
    REQUIRE(s.prepare_block(index) > 0);
    std::copy(g.val.begin(), g.val.end(), s.values().begin());
    REQUIRE(s.factorize(0) == FactorOutcome::Ok);
    const std::size_t k = index.size();
    const int saved = omp_get_max_threads();
    std::vector<double> one(k * k, NAN), two(k * k, NAN);
    omp_set_num_threads(1);
    REQUIRE(s.inverse_block(one));
    omp_set_num_threads(2);
    REQUIRE(s.inverse_block(two));
    omp_set_num_threads(saved);
    CHECK(one == two);
    CHECK(difference_to_full_solves(s, g.n, index, two) < 1e-13);
  }
}
