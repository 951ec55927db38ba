#include "sparse_solver.h"

#include <cholmod.h>

#include <algorithm>
#include <cfenv>
#include <cmath>
#include <vector>

namespace ricci::detail {

namespace {

// Ordering: AMD first (cheap); METIS nested dissection as well when AMD's factor would cost more
// than this many flops per unknown, and the ordering of fewer flops is kept. On mesh Laplacians
// nested dissection saves 30–70 % of AMD's flops, and more the more AMD fills (flops per unknown:
// face.obj 2 800, 30 % saved; botijo 8 400, 51 %; kitten-106k 10 700, 56 %; kitten-425k 31 000,
// 69 %), while its analysis costs 3–4 µs per unknown, i.e. roughly 8 000 flops at the
// factorization's rate: from about this many flops per unknown it pays for itself within the
// four factorizations of a typical Newton solve.
constexpr double kNestedDissectionFlops = 6000;

// FactorLayout::Automatic: simplicial (column by column, no BLAS) when the factorization's flops
// per factor nonzero are below this, else supernodal (dense blocks through the BLAS); CHOLMOD's
// own switch, whose default of 40 assumes a tuned BLAS. Measured with Debian's ATLAS on 2 cores
// (METIS order, supernodal s / simplicial s): face.obj (75 flops per nonzero) 0.083 / 0.026,
// botijo (119) 0.161 / 0.080, kitten-106k (129) 0.196 / 0.103, face.obj subdivided once (127)
// 0.370 / 0.210, botijo subdivided once (196) 0.696 / 0.763, kitten-425k (217) 0.96 / 1.31.
constexpr double kSupernodalSwitch = 180;

// Indefinite matrices (see sparse_solver.h): soft pins on k spread-out unknowns, k doubling from
// kFirstPins to kMaxPins while the pinned matrix is not positive definite; each pin adds
// kPinWeight × (its diagonal entry) to the diagonal.
constexpr std::int64_t kFirstPins = 32;
constexpr std::int64_t kMaxPins = 512;
constexpr double kPinWeight = 8;

// CHOLMOD detects zero and negative pivots itself and reports them in Common->status; the
// floating-point exceptions it may raise on the way (1/0 of a zero pivot, say) are not the
// caller's business. Hold them for the duration of a call and restore the caller's environment
// (including enabled traps) afterwards.
class FloatingPointHold {
 public:
  FloatingPointHold() { std::feholdexcept(&env_); }
  ~FloatingPointHold() { std::fesetenv(&env_); }
  FloatingPointHold(const FloatingPointHold&) = delete;
  FloatingPointHold& operator=(const FloatingPointHold&) = delete;

 private:
  std::fenv_t env_;
};

}  // namespace

struct SymmetricSolver::Impl {
  cholmod_common common;
  cholmod_sparse* A = nullptr;
  cholmod_factor* L = nullptr;
  cholmod_dense* B = nullptr;
  cholmod_dense* X = nullptr;
  cholmod_dense* Y = nullptr;
  cholmod_dense* E = nullptr;
  std::int64_t n = 0;
  FactorKind kind = FactorKind::PositiveDefinite;
  // Vectors L⁻¹ e_c for a set of columns c of the permuted order, each nonzero only on the
  // elimination-tree path from c to the root: the supernodes of the t-th column's path
  // (super[offsets[t] … offsets[t+1]), increasing) and its values on their columns (values from
  // value_offsets[t], the columns of each path supernode in turn).
  struct Paths {
    std::vector<std::int64_t> column, offsets, super, value_offsets;
    std::vector<double> values;
  };
  // Indefinite kind by pinned LLᵀ + Woodbury (see sparse_solver.h): the pins, their weights ρ,
  // the k×k capacitance matrix C = R⁻¹ − ZᵀZ in LU form (row-major, with its row pivots), and
  // Z = L⁻¹ P E as the paths of the pins. `ldl`: given up on pins (simplicial LDLᵀ).
  FactorLayout layout = FactorLayout::Automatic;
  bool ldl = false;
  std::vector<std::int64_t> pins;
  std::vector<double> pin_weight, pin_saved, capacitance, pin_rhs;
  Paths pin_paths;
  bool pins_changed = false;  // pin_paths are not those of `pins`
  std::vector<std::int64_t> capacitance_pivot;
  cholmod_dense* W = nullptr;
  // The supernodal elimination tree (the parent of each supernode, the supernode of each column)
  // and the inverse permutation, once per analysis (tree_ready); a dense workspace of n zeros.
  // A simplicial LLᵀ factor is read as supernodes of one column each (unit_super: 0, 1, …, n).
  std::vector<std::int64_t> super_parent, column_super, inverse_perm;
  std::vector<SuiteSparse_long> unit_super;
  std::vector<double> block_work;
  bool tree_ready = false;
  // inverse_block(): the paths of the block columns; W = Zᵀ_pins Z_I and C⁻¹W for the pins.
  Paths block_paths;
  std::vector<double> pin_block;
  std::vector<SuiteSparse_long> given;  // the caller's ordering (analyze()), empty when chosen here
  bool block_ready = false;
  bool analyzed = false;
  bool factored = false;
  double rcond = 0;

  Impl() {
    FloatingPointHold hold;
    cholmod_l_start(&common);
    common.print = 0;  // never print
    common.error_handler = nullptr;
  }
  ~Impl() {
    FloatingPointHold hold;
    if (A) cholmod_l_free_sparse(&A, &common);
    if (L) cholmod_l_free_factor(&L, &common);
    if (B) cholmod_l_free_dense(&B, &common);
    if (X) cholmod_l_free_dense(&X, &common);
    if (Y) cholmod_l_free_dense(&Y, &common);
    if (E) cholmod_l_free_dense(&E, &common);
    if (W) cholmod_l_free_dense(&W, &common);
    cholmod_l_finish(&common);
  }

  bool prepare_tree();
  void simplicial_tree();
  // The first column of each supernode (n + 1 entries for a simplicial factor).
  const SuiteSparse_long* supers() const {
    return L->is_super ? static_cast<const SuiteSparse_long*>(L->super) : unit_super.data();
  }
  double build_paths(std::span<const std::int64_t> columns, Paths& p);
  void forward_paths(Paths& p);
  void scatter(const Paths& p, std::int64_t t);
  void unscatter(const Paths& p, std::int64_t t);
  double scattered_dot(const Paths& p, std::int64_t t) const;

  // The symbolic analysis of A with the settings in `common` (and the given ordering, if any).
  cholmod_factor* analyze_pattern() {
    return given.empty() ? cholmod_l_analyze(A, &common) : cholmod_l_analyze_p(A, given.data(), nullptr, 0, &common);
  }

  std::int64_t diagonal_position(std::int64_t j) const { return static_cast<SuiteSparse_long*>(A->p)[j + 1] - 1; }

  FactorOutcome pinned_factorize(double shift);
  FactorOutcome build_capacitance();
  bool pinned_solve(double* x);
  void capacitance_solve(double* r) const;

  FactorOutcome status_outcome() const {
    if (common.status == CHOLMOD_OUT_OF_MEMORY) return FactorOutcome::OutOfMemory;
    if (common.status == CHOLMOD_NOT_POSDEF) return FactorOutcome::NotPositiveDefinite;
    if (common.status < CHOLMOD_OK) return FactorOutcome::Failed;
    return FactorOutcome::Ok;
  }
};

// Indefinite matrices with few negative eigenvalues (the spherical Hessian: one, the scaling
// direction). With E the n×k selection of the pins and R = diag(ρ), M = A + E R Eᵀ is positive
// definite once the pins are dense enough to block the negative directions, and
//     A⁻¹ = M⁻¹ + M⁻¹ E C⁻¹ Eᵀ M⁻¹,   C = R⁻¹ − Eᵀ M⁻¹ E   (Woodbury).
// With M = Pᵀ L Lᵀ P and Z = L⁻¹ P E, C = R⁻¹ − ZᵀZ and A⁻¹ b = Pᵀ L⁻ᵀ (y + Z C⁻¹ Zᵀ y) with
// y = L⁻¹ P b: one forward and one backward solve per right-hand side, as for a positive
// definite A, plus the work of Zᵀy and Z(C⁻¹Zᵀy). Column p of Z is nonzero only on the
// elimination-tree path from the pin to the root, so Z is computed per factorization by sparse
// forward solves along those paths and kept as their values (with nested dissection a path is
// the separators above the pin: O(√n) entries on a mesh, instead of n per column). C is
// indefinite and solved by LU with partial pivoting. The pins are spread evenly over the unknowns'
// order; when M is not positive definite their number doubles, unless the factorization stopped
// at the same column as with half as many. Failed: out of pins, or stuck (the caller's
// factorize() then switches to simplicial LDLᵀ). The factor is supernodal or simplicial LLᵀ.
FactorOutcome SymmetricSolver::Impl::pinned_factorize(double shift) {
  double* x = static_cast<double*>(A->x);
  std::int64_t k = pins.empty() ? std::min(kFirstPins, n) : static_cast<std::int64_t>(pins.size());
  std::int64_t last_stop = -1;  // the column where the last attempt stopped (-1: none)
  while (true) {
    if (static_cast<std::int64_t>(pins.size()) != k) {
      pins.resize(static_cast<std::size_t>(k));
      for (std::int64_t i = 0; i < k; ++i) pins[i] = ((2 * i + 1) * n) / (2 * k);
      pins_changed = true;
    }
    pin_weight.resize(static_cast<std::size_t>(k));
    pin_saved.resize(static_cast<std::size_t>(k));
    for (std::int64_t i = 0; i < k; ++i) {
      const std::int64_t q = diagonal_position(pins[i]);
      pin_saved[i] = x[q];
      const double d = std::abs(x[q]);
      pin_weight[i] = kPinWeight * (std::isfinite(d) && d > 0 ? d : 1.0);
      x[q] += pin_weight[i];
    }
    double beta[2] = {shift, 0};
    common.status = CHOLMOD_OK;
    const int ok = cholmod_l_factorize_p(A, beta, nullptr, 0, L, &common);
    for (std::int64_t i = 0; i < k; ++i) x[diagonal_position(pins[i])] = pin_saved[i];
    FactorOutcome outcome = status_outcome();
    if (outcome == FactorOutcome::Ok && !ok) outcome = FactorOutcome::Failed;
    if (outcome == FactorOutcome::OutOfMemory) return outcome;
    if (outcome == FactorOutcome::Ok) {
      rcond = cholmod_l_rcond(L, &common);
      if (std::isfinite(rcond) && rcond > 0) return build_capacitance();
      outcome = FactorOutcome::NotPositiveDefinite;
    }
    // More pins help when they move the failure; when twice as many stop at the same column, the
    // negative direction there is local and strong (brain-32k: 32 … 512 pins all stop at one
    // column), and LDLᵀ is taken at once.
    const std::int64_t stopped = common.status == CHOLMOD_NOT_POSDEF ? static_cast<std::int64_t>(L->minor) : -1;
    const bool stuck = stopped >= 0 && stopped == last_stop;
    last_stop = stopped;
    if (outcome == FactorOutcome::NotPositiveDefinite && k < std::min(kMaxPins, n) && !stuck) {
      k = std::min(2 * k, n);
      continue;
    }
    pins.clear();
    pin_paths = Paths{};
    return FactorOutcome::Failed;
  }
}

FactorOutcome SymmetricSolver::Impl::build_capacitance() {
  const auto k = static_cast<std::int64_t>(pins.size());
  // Z by sparse forward solves along the pins' elimination-tree paths (their paths are set up
  // when the pins change), then C = R⁻¹ − ZᵀZ over the paths.
  if (!prepare_tree()) return FactorOutcome::Failed;
  if (pins_changed) {
    pins_changed = false;
    std::vector<std::int64_t> columns(static_cast<std::size_t>(k));
    for (std::int64_t a = 0; a < k; ++a) columns[a] = inverse_perm[pins[a]];
    build_paths(columns, pin_paths);
  }
  forward_paths(pin_paths);
  capacitance.resize(static_cast<std::size_t>(k * k));
  for (std::int64_t a = 0; a < k; ++a) {
    scatter(pin_paths, a);
    for (std::int64_t c = 0; c <= a; ++c)
      capacitance[a * k + c] = capacitance[c * k + a] = -scattered_dot(pin_paths, c);
    unscatter(pin_paths, a);
    capacitance[a * k + a] += 1 / pin_weight[a];
  }
  double largest = 0;
  for (const double v : capacitance) largest = std::max(largest, std::abs(v));
  if (!std::isfinite(largest) || largest <= 0) return FactorOutcome::NotPositiveDefinite;
  // LU with partial pivoting, in place.
  capacitance_pivot.resize(static_cast<std::size_t>(k));
  pin_rhs.resize(static_cast<std::size_t>(k));
  for (std::int64_t j = 0; j < k; ++j) {
    std::int64_t p = j;
    for (std::int64_t i = j + 1; i < k; ++i)
      if (std::abs(capacitance[i * k + j]) > std::abs(capacitance[p * k + j])) p = i;
    const double pivot = capacitance[p * k + j];
    if (!(std::abs(pivot) > 1e-15 * largest)) return FactorOutcome::NotPositiveDefinite;
    capacitance_pivot[j] = p;
    if (p != j)
      for (std::int64_t c = 0; c < k; ++c) std::swap(capacitance[j * k + c], capacitance[p * k + c]);
    for (std::int64_t i = j + 1; i < k; ++i) {
      const double f = capacitance[i * k + j] / pivot;
      capacitance[i * k + j] = f;
      if (f != 0)
        for (std::int64_t c = j + 1; c < k; ++c) capacitance[i * k + c] -= f * capacitance[j * k + c];
    }
  }
  return FactorOutcome::Ok;
}

// r ← C⁻¹ r with the LU factors of the capacitance matrix.
void SymmetricSolver::Impl::capacitance_solve(double* r) const {
  const auto k = static_cast<std::int64_t>(pins.size());
  for (std::int64_t j = 0; j < k; ++j) std::swap(r[j], r[capacitance_pivot[j]]);
  for (std::int64_t i = 0; i < k; ++i)
    for (std::int64_t c = 0; c < i; ++c) r[i] -= capacitance[i * k + c] * r[c];
  for (std::int64_t i = k; i-- > 0;) {
    for (std::int64_t c = i + 1; c < k; ++c) r[i] -= capacitance[i * k + c] * r[c];
    r[i] /= capacitance[i * k + i];
  }
}

// A⁻¹ b into out, b in B (see above).
bool SymmetricSolver::Impl::pinned_solve(double* out) {
  const auto k = static_cast<std::int64_t>(pins.size());
  if (!cholmod_l_solve2(CHOLMOD_P, L, B, nullptr, &X, nullptr, &Y, &E, &common) || !X ||
      !cholmod_l_solve2(CHOLMOD_L, L, X, nullptr, &W, nullptr, &Y, &E, &common) || !W ||
      common.status < CHOLMOD_OK)
    return false;
  auto* y = static_cast<double*>(W->x);
  const SuiteSparse_long* super = supers();
  for (std::int64_t a = 0; a < k; ++a) {
    const double* z = pin_paths.values.data() + pin_paths.value_offsets[a];
    double sum = 0;
    for (std::int64_t t = pin_paths.offsets[a]; t < pin_paths.offsets[a + 1]; ++t) {
      const std::int64_t q = pin_paths.super[t];
      for (std::int64_t j = super[q]; j < super[q + 1]; ++j) sum += *z++ * y[j];
    }
    pin_rhs[a] = sum;
  }
  capacitance_solve(pin_rhs.data());
  for (std::int64_t a = 0; a < k; ++a) {
    const double* z = pin_paths.values.data() + pin_paths.value_offsets[a];
    const double w = pin_rhs[a];
    for (std::int64_t t = pin_paths.offsets[a]; t < pin_paths.offsets[a + 1]; ++t) {
      const std::int64_t q = pin_paths.super[t];
      for (std::int64_t j = super[q]; j < super[q + 1]; ++j) y[j] += *z++ * w;
    }
  }
  if (!cholmod_l_solve2(CHOLMOD_Lt, L, W, nullptr, &X, nullptr, &Y, &E, &common) || !X ||
      !cholmod_l_solve2(CHOLMOD_Pt, L, X, nullptr, &B, nullptr, &Y, &E, &common) || !B ||
      common.status < CHOLMOD_OK)
    return false;
  const auto* x = static_cast<const double*>(B->x);
  std::copy(x, x + n, out);
  return true;
}

SymmetricSolver::SymmetricSolver() : impl_(std::make_unique<Impl>()) {}
SymmetricSolver::~SymmetricSolver() = default;
void SymmetricSolver::reset() {
  const FactorLayout layout = impl_->layout;
  impl_ = std::make_unique<Impl>();
  impl_->layout = layout;
}

FactorOutcome SymmetricSolver::analyze(std::int64_t n, std::span<const std::int64_t> col_ptr,
                                       std::span<const std::int64_t> row, FactorKind kind,
                                       std::span<const std::int64_t> ordering) {
  Impl& s = *impl_;
  if (s.analyzed || n < 0 || col_ptr.size() != static_cast<std::size_t>(n) + 1 ||
      row.size() != static_cast<std::size_t>(col_ptr[static_cast<std::size_t>(n)]))
    return FactorOutcome::Failed;
  if (!ordering.empty()) {
    if (ordering.size() != static_cast<std::size_t>(n)) return FactorOutcome::Failed;
    std::vector<std::uint8_t> seen(static_cast<std::size_t>(n), 0);
    for (const std::int64_t k : ordering) {
      if (k < 0 || k >= n || seen[static_cast<std::size_t>(k)]) return FactorOutcome::Failed;
      seen[static_cast<std::size_t>(k)] = 1;
    }
    s.given.assign(ordering.begin(), ordering.end());
  }
  s.n = n;
  s.analyzed = true;
  if (n == 0) return FactorOutcome::Ok;
  FloatingPointHold hold;
  cholmod_common& c = s.common;
  const auto nnz = static_cast<std::size_t>(row.size());
  s.A = cholmod_l_allocate_sparse(static_cast<std::size_t>(n), static_cast<std::size_t>(n), nnz, /*sorted=*/1,
                                  /*packed=*/1, /*stype=*/1, CHOLMOD_REAL, &c);
  if (!s.A) return s.status_outcome() == FactorOutcome::Ok ? FactorOutcome::Failed : s.status_outcome();
  auto* p = static_cast<SuiteSparse_long*>(s.A->p);
  auto* i = static_cast<SuiteSparse_long*>(s.A->i);
  auto* x = static_cast<double*>(s.A->x);
  std::copy(col_ptr.begin(), col_ptr.end(), p);
  std::copy(row.begin(), row.end(), i);
  std::fill(x, x + nnz, 0.0);

  // Ordering (kNestedDissectionFlops): AMD, and METIS nested dissection too when AMD's factor is
  // expensive per unknown; the one of fewer flops is kept. A given ordering is used as is (CHOLMOD
  // still postorders its elimination tree). Layout: set_layout()'s; for Automatic CHOLMOD chooses
  // by the flops per factor nonzero of the ordering it analyses (kSupernodalSwitch).
  // Indefinite: pinned LLᵀ (see Impl::pinned_factorize) in either layout.
  s.kind = kind;
  c.nmethods = 1;
  c.method[0].ordering = s.given.empty() ? CHOLMOD_AMD : CHOLMOD_GIVEN;
  c.supernodal = s.layout == FactorLayout::Supernodal   ? CHOLMOD_SUPERNODAL
                 : s.layout == FactorLayout::Simplicial ? CHOLMOD_SIMPLICIAL
                                                        : CHOLMOD_AUTO;
  c.supernodal_switch = kSupernodalSwitch;
  c.grow0 = 0;  // no slack for updates/downdates: exact space
  c.grow2 = 0;
  s.L = s.analyze_pattern();
  if (s.L && s.given.empty() && c.fl > kNestedDissectionFlops * static_cast<double>(n)) {
    cholmod_factor* amd = s.L;
    const double amd_fl = c.fl, amd_lnz = c.lnz;
    c.method[0].ordering = CHOLMOD_METIS;
    s.L = s.analyze_pattern();
    if (s.L && c.fl < amd_fl) {
      cholmod_l_free_factor(&amd, &c);
    } else {  // METIS gave more flops, ran out of memory or is not installed: AMD's analysis
      if (s.L) cholmod_l_free_factor(&s.L, &c);
      s.L = amd;
      c.fl = amd_fl;
      c.lnz = amd_lnz;
      c.status = CHOLMOD_OK;
    }
  }
  if (!s.L) return s.status_outcome() == FactorOutcome::Ok ? FactorOutcome::Failed : s.status_outcome();
  // Supernodal stays LLᵀ; a simplicial factor is computed as LLᵀ too (LDLᵀ would not report a
  // negative pivot as NotPositiveDefinite, and the paths of inverse_block() read L's columns).
  c.final_asis = s.L->is_super ? 1 : 0;
  c.final_ll = 1;
  c.final_super = 1;
  c.final_pack = 1;
  c.final_monotonic = 1;
  s.B = cholmod_l_zeros(static_cast<std::size_t>(n), 1, CHOLMOD_REAL, &c);
  if (!s.B) return s.status_outcome() == FactorOutcome::Ok ? FactorOutcome::Failed : s.status_outcome();
  // The ordering's workspace (about 8 integers per unknown) is larger than the factorization's,
  // which allocates what it needs.
  cholmod_l_free_work(&c);
  return s.status_outcome();
}

std::span<double> SymmetricSolver::values() {
  Impl& s = *impl_;
  if (!s.A) return {};
  return {static_cast<double*>(s.A->x),
          static_cast<std::size_t>(static_cast<SuiteSparse_long*>(s.A->p)[s.n])};
}

FactorOutcome SymmetricSolver::factorize(double shift) {
  Impl& s = *impl_;
  s.factored = false;
  if (!s.analyzed) return FactorOutcome::Failed;
  if (s.n == 0) {
    s.factored = true;
    s.rcond = 1;
    return FactorOutcome::Ok;
  }
  FloatingPointHold hold;
  if (s.kind == FactorKind::Indefinite && !s.ldl) {
    const FactorOutcome pinned = s.pinned_factorize(shift);
    if (pinned != FactorOutcome::Failed) {
      s.factored = pinned == FactorOutcome::Ok;
      return pinned;
    }
    // Out of pins: simplicial LDLᵀ from here on (a new analysis with the same ordering, once).
    cholmod_common& c = s.common;
    if (s.given.empty() && s.L->Perm) {
      const auto* perm = static_cast<const SuiteSparse_long*>(s.L->Perm);
      s.given.assign(perm, perm + s.n);
    }
    cholmod_l_free_factor(&s.L, &c);
    c.nmethods = 1;
    c.method[0].ordering = s.given.empty() ? CHOLMOD_AMD : CHOLMOD_GIVEN;
    c.supernodal = CHOLMOD_SIMPLICIAL;
    c.final_asis = 1;  // stays LDLᵀ
    c.final_ll = 0;
    c.status = CHOLMOD_OK;
    s.L = s.analyze_pattern();
    if (!s.L) return s.status_outcome() == FactorOutcome::Ok ? FactorOutcome::Failed : s.status_outcome();
    s.ldl = true;
    s.tree_ready = false;
    s.block_ready = false;
  }
  cholmod_common& c = s.common;
  double beta[2] = {shift, 0};
  const int ok = cholmod_l_factorize_p(s.A, beta, nullptr, 0, s.L, &c);
  FactorOutcome outcome = s.status_outcome();
  if (outcome == FactorOutcome::Ok && !ok) outcome = FactorOutcome::Failed;
  if (outcome != FactorOutcome::Ok) return outcome;
  s.rcond = cholmod_l_rcond(s.L, &c);
  // A zero or non-finite diagonal of the factor (possible for LDLᵀ without a NOT_POSDEF report).
  if (!std::isfinite(s.rcond) || s.rcond <= 0) return FactorOutcome::NotPositiveDefinite;
  s.factored = true;
  return FactorOutcome::Ok;
}

bool SymmetricSolver::solve(std::span<const double> b, std::span<double> x) {
  Impl& s = *impl_;
  if (!s.factored || b.size() != static_cast<std::size_t>(s.n) || x.size() != static_cast<std::size_t>(s.n))
    return false;
  if (s.n == 0) return true;
  FloatingPointHold hold;
  std::copy(b.begin(), b.end(), static_cast<double*>(s.B->x));
  if (!s.pins.empty()) {
    if (!s.pinned_solve(x.data())) return false;
  } else {
    const int ok = cholmod_l_solve2(CHOLMOD_A, s.L, s.B, nullptr, &s.X, nullptr, &s.Y, &s.E, &s.common);
    if (!ok || !s.X || s.common.status < CHOLMOD_OK) return false;
    const double* r = static_cast<const double*>(s.X->x);
    std::copy(r, r + s.n, x.begin());
  }
  bool finite = true;
  for (std::int64_t k = 0; k < s.n; ++k) finite = finite && std::isfinite(x[k]);
  return finite;
}

// The supernodal elimination tree (the parent of a supernode holds its first off-diagonal row),
// the supernode of each column and the inverse permutation; once per analysis. A simplicial
// factor's supernodes are its columns (simplicial_tree()).
bool SymmetricSolver::Impl::prepare_tree() {
  if (tree_ready) return true;
  if (!L || ldl) return false;
  const auto* perm = static_cast<const SuiteSparse_long*>(L->Perm);
  inverse_perm.resize(static_cast<std::size_t>(n));
  for (std::int64_t k = 0; k < n; ++k) inverse_perm[perm ? perm[k] : k] = k;
  block_work.assign(static_cast<std::size_t>(n), 0.0);
  tree_ready = true;
  if (!L->is_super) {
    simplicial_tree();
    return true;
  }
  const auto nsuper = static_cast<std::int64_t>(L->nsuper);
  const auto* super = static_cast<const SuiteSparse_long*>(L->super);
  const auto* pi = static_cast<const SuiteSparse_long*>(L->pi);
  const auto* si = static_cast<const SuiteSparse_long*>(L->s);
  column_super.assign(static_cast<std::size_t>(n), -1);
  for (std::int64_t q = 0; q < nsuper; ++q)
    for (std::int64_t j = super[q]; j < super[q + 1]; ++j) column_super[j] = q;
  super_parent.assign(static_cast<std::size_t>(nsuper), -1);
  for (std::int64_t q = 0; q < nsuper; ++q) {
    const std::int64_t nscol = super[q + 1] - super[q], nsrow = pi[q + 1] - pi[q];
    if (nsrow > nscol) super_parent[q] = column_super[si[pi[q] + nscol]];
  }
  return true;
}

// The elimination tree of P A Pᵀ from A's pattern (Liu's algorithm with path compression; the
// symbolic simplicial factor holds no row indices), columns as supernodes of one column.
void SymmetricSolver::Impl::simplicial_tree() {
  const auto* ap = static_cast<const SuiteSparse_long*>(A->p);
  const auto* ai = static_cast<const SuiteSparse_long*>(A->i);
  // For each permuted column, the permuted rows above it (A's upper triangle, either orientation).
  std::vector<std::int64_t> start(static_cast<std::size_t>(n) + 1, 0), above;
  for (std::int64_t c = 0; c < n; ++c)
    for (SuiteSparse_long k = ap[c]; k < ap[c + 1]; ++k)
      if (ai[k] != c) ++start[std::max(inverse_perm[ai[k]], inverse_perm[c]) + 1];
  for (std::int64_t j = 0; j < n; ++j) start[j + 1] += start[j];
  above.resize(static_cast<std::size_t>(start[n]));
  std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
  for (std::int64_t c = 0; c < n; ++c)
    for (SuiteSparse_long k = ap[c]; k < ap[c + 1]; ++k)
      if (ai[k] != c) {
        const std::int64_t a = inverse_perm[ai[k]], b = inverse_perm[c];
        above[fill[std::max(a, b)]++] = std::min(a, b);
      }
  super_parent.assign(static_cast<std::size_t>(n), -1);
  std::vector<std::int64_t> ancestor(static_cast<std::size_t>(n), -1);
  for (std::int64_t j = 0; j < n; ++j)
    for (std::int64_t k = start[j]; k < start[j + 1]; ++k) {
      std::int64_t r = above[k];
      while (ancestor[r] != -1 && ancestor[r] != j) {
        const std::int64_t next = ancestor[r];
        ancestor[r] = j;
        r = next;
      }
      if (ancestor[r] == -1) {
        ancestor[r] = j;
        super_parent[r] = j;
      }
    }
  column_super.resize(static_cast<std::size_t>(n));
  unit_super.resize(static_cast<std::size_t>(n) + 1);
  for (std::int64_t j = 0; j < n; ++j) column_super[j] = j;
  for (std::int64_t j = 0; j <= n; ++j) unit_super[j] = j;
}

// The paths of `columns` (permuted order) into p (values zero); returns the flops of one
// forward_paths() plus the Gram matrix of the paths.
double SymmetricSolver::Impl::build_paths(std::span<const std::int64_t> columns, Paths& p) {
  const SuiteSparse_long* super = supers();
  // Rows of a supernode's block: its pattern (supernodal) or its column count (simplicial).
  const auto* pi = static_cast<const SuiteSparse_long*>(L->pi);
  const auto* count = static_cast<const SuiteSparse_long*>(L->ColCount);
  auto rows = [&](std::int64_t q) -> std::int64_t { return L->is_super ? pi[q + 1] - pi[q] : count[q]; };
  const auto k = static_cast<std::int64_t>(columns.size());
  p.column.assign(columns.begin(), columns.end());
  p.offsets.assign(1, 0);
  p.value_offsets.assign(1, 0);
  p.super.clear();
  double flops = 0, path_columns = 0;
  for (std::int64_t c = 0; c < k; ++c) {
    std::int64_t values = 0;
    for (std::int64_t q = column_super[columns[c]]; q >= 0; q = super_parent[q]) {
      p.super.push_back(q);
      const std::int64_t nscol = super[q + 1] - super[q], nsrow = rows(q);
      values += nscol;
      flops += 2.0 * static_cast<double>(nsrow) * static_cast<double>(nscol);
    }
    path_columns += static_cast<double>(values);
    p.offsets.push_back(static_cast<std::int64_t>(p.super.size()));
    p.value_offsets.push_back(p.value_offsets.back() + values);
  }
  p.values.assign(static_cast<std::size_t>(p.value_offsets.back()), 0.0);
  // The Gram matrix: k²/2 dot products over the paths.
  return flops + static_cast<double>(k) * path_columns;
}

// p.values: the forward solves L z = e_c along each path with the current factor (the rows off
// the path stay zero); block_work is the scratch and is zero again afterwards.
void SymmetricSolver::Impl::forward_paths(Paths& p) {
  const bool super_layout = L->is_super;
  const auto* super = static_cast<const SuiteSparse_long*>(L->super);
  const auto* pi = static_cast<const SuiteSparse_long*>(L->pi);
  const auto* px = static_cast<const SuiteSparse_long*>(L->px);
  const auto* si = static_cast<const SuiteSparse_long*>(L->s);
  const auto* lp = static_cast<const SuiteSparse_long*>(L->p);
  const auto* li = static_cast<const SuiteSparse_long*>(L->i);
  const auto* lnz = static_cast<const SuiteSparse_long*>(L->nz);
  const auto* lx = static_cast<const double*>(L->x);
  // Supernode q: its dense block (columns k1 …, rows pi[q] …), the path's values out to z.
  auto supernode = [&](double* work, std::int64_t q, double*& z) {
    const std::int64_t k1 = super[q], nscol = super[q + 1] - k1, psi = pi[q], nsrow = pi[q + 1] - psi;
    const double* Lq = lx + px[q];
    double* x = work + k1;
    for (std::int64_t j = 0; j < nscol; ++j) {
      const double* col = Lq + j * nsrow;
      const double xj = x[j] / col[j];
      x[j] = xj;
      if (xj == 0) continue;
      for (std::int64_t r = j + 1; r < nscol; ++r) x[r] -= col[r] * xj;
      for (std::int64_t r = nscol; r < nsrow; ++r) work[si[psi + r]] -= col[r] * xj;
    }
    for (std::int64_t j = 0; j < nscol; ++j) {
      *z++ = x[j];
      x[j] = 0;
    }
  };
  // Simplicial column j: its diagonal first, then rows that are all ancestors of j.
  auto column = [&](double* work, std::int64_t j, double*& z) {
    const std::int64_t first = lp[j], end = first + lnz[j];
    const double xj = work[j] / lx[first];
    work[j] = 0;
    *z++ = xj;
    if (xj != 0)
      for (std::int64_t r = first + 1; r < end; ++r) work[li[r]] -= lx[r] * xj;
  };
  // One path per column, each in its own slice of p.values: in parallel for many columns, each
  // thread with its own workspace (zero again after every path), the same values on any number of
  // threads.
  const auto k = static_cast<std::int64_t>(p.column.size());
  auto path = [&](double* work, std::int64_t c) {
    work[p.column[c]] = 1;
    double* z = p.values.data() + p.value_offsets[c];
    for (std::int64_t t = p.offsets[c]; t < p.offsets[c + 1]; ++t) {
      if (super_layout)
        supernode(work, p.super[t], z);
      else
        column(work, p.super[t], z);
    }
  };
  if (k < 64) {
    for (std::int64_t c = 0; c < k; ++c) path(block_work.data(), c);
    return;
  }
#pragma omp parallel
  {
    std::vector<double> work(static_cast<std::size_t>(n), 0.0);
#pragma omp for schedule(dynamic, 8)
    for (std::int64_t c = 0; c < k; ++c) path(work.data(), c);
  }
}

// Path t's values into block_work (scatter) and back to zero (unscatter); the dot product of
// path t with what block_work holds.
void SymmetricSolver::Impl::scatter(const Paths& p, std::int64_t t) {
  const SuiteSparse_long* super = supers();
  const double* z = p.values.data() + p.value_offsets[t];
  for (std::int64_t i = p.offsets[t]; i < p.offsets[t + 1]; ++i) {
    const std::int64_t q = p.super[i];
    for (std::int64_t j = super[q]; j < super[q + 1]; ++j) block_work[j] = *z++;
  }
}

void SymmetricSolver::Impl::unscatter(const Paths& p, std::int64_t t) {
  const SuiteSparse_long* super = supers();
  for (std::int64_t i = p.offsets[t]; i < p.offsets[t + 1]; ++i) {
    const std::int64_t q = p.super[i];
    std::fill(block_work.begin() + super[q], block_work.begin() + super[q + 1], 0.0);
  }
}

double SymmetricSolver::Impl::scattered_dot(const Paths& p, std::int64_t t) const {
  const SuiteSparse_long* super = supers();
  const double* z = p.values.data() + p.value_offsets[t];
  double sum = 0;
  for (std::int64_t i = p.offsets[t]; i < p.offsets[t + 1]; ++i) {
    const std::int64_t q = p.super[i];
    for (std::int64_t j = super[q]; j < super[q + 1]; ++j) sum += block_work[j] * *z++;
  }
  return sum;
}

double SymmetricSolver::prepare_block(std::span<const std::int64_t> index) {
  Impl& s = *impl_;
  s.block_ready = false;
  if (!s.analyzed || s.n == 0 || !s.L || s.ldl) return -1;
  for (const std::int64_t i : index)
    if (i < 0 || i >= s.n) return -1;
  if (!s.prepare_tree()) return -1;
  std::vector<std::int64_t> columns(index.size());
  for (std::size_t c = 0; c < index.size(); ++c) columns[c] = s.inverse_perm[index[c]];
  const double flops = s.build_paths(columns, s.block_paths);
  s.block_ready = true;
  return flops;
}

bool SymmetricSolver::inverse_block(std::span<double> out) {
  Impl& s = *impl_;
  Impl::Paths& p = s.block_paths;
  const auto k = static_cast<std::int64_t>(p.column.size());
  if (!s.block_ready || !s.factored || s.ldl || !s.L || !s.L->is_ll || !s.L->x ||
      out.size() != static_cast<std::size_t>(k * k))
    return false;
  s.forward_paths(p);
  // ZᵀZ: column a scattered into a workspace, dotted with the paths of the columns b ≤ a. Rows in
  // parallel, each thread with its own workspace (zero off the path it holds): every entry is the
  // same sum in the same order on any number of threads.
  const SuiteSparse_long* super = s.supers();
#pragma omp parallel if (k >= 64)
  {
    std::vector<double> work(static_cast<std::size_t>(s.n), 0.0);
#pragma omp for schedule(dynamic, 8)
    for (std::int64_t a = 0; a < k; ++a) {
      const double* za = p.values.data() + p.value_offsets[a];
      for (std::int64_t i = p.offsets[a]; i < p.offsets[a + 1]; ++i)
        for (std::int64_t j = super[p.super[i]]; j < super[p.super[i] + 1]; ++j) work[j] = *za++;
      for (std::int64_t b = 0; b <= a; ++b) {
        const double* zb = p.values.data() + p.value_offsets[b];
        double sum = 0;
        for (std::int64_t i = p.offsets[b]; i < p.offsets[b + 1]; ++i)
          for (std::int64_t j = super[p.super[i]]; j < super[p.super[i] + 1]; ++j) sum += work[j] * *zb++;
        out[a * k + b] = out[b * k + a] = sum;
      }
      for (std::int64_t i = p.offsets[a]; i < p.offsets[a + 1]; ++i)
        std::fill(work.begin() + super[p.super[i]], work.begin() + super[p.super[i] + 1], 0.0);
    }
  }
  // Pins (Woodbury): + Wᵀ C⁻¹ W with W = Zᵀ_pins Z_I.
  const auto kp = static_cast<std::int64_t>(s.pins.size());
  if (kp > 0) {
    s.pin_block.resize(static_cast<std::size_t>(2 * kp * k));  // W (kp×k), then C⁻¹W
    double* W = s.pin_block.data();
    double* V = W + kp * k;
    for (std::int64_t a = 0; a < kp; ++a) {
      s.scatter(s.pin_paths, a);
      for (std::int64_t c = 0; c < k; ++c) W[a * k + c] = s.scattered_dot(p, c);
      s.unscatter(s.pin_paths, a);
    }
    for (std::int64_t c = 0; c < k; ++c) {
      double* r = s.pin_rhs.data();
      for (std::int64_t a = 0; a < kp; ++a) r[a] = W[a * k + c];
      s.capacitance_solve(r);
      for (std::int64_t a = 0; a < kp; ++a) V[a * k + c] = r[a];
    }
    for (std::int64_t a = 0; a < k; ++a)
      for (std::int64_t b = 0; b < k; ++b) {
        double sum = 0;
        for (std::int64_t q = 0; q < kp; ++q) sum += W[q * k + a] * V[q * k + b];
        out[a * k + b] += sum;
      }
  }
  for (const double v : out)
    if (!std::isfinite(v)) return false;
  return true;
}

bool SymmetricSolver::ordering(std::span<std::int64_t> out) const {
  const Impl& s = *impl_;
  if (!s.analyzed || out.size() != static_cast<std::size_t>(s.n)) return false;
  if (s.n == 0) return true;
  if (!s.L) return false;
  const auto* perm = static_cast<const SuiteSparse_long*>(s.L->Perm);
  for (std::int64_t k = 0; k < s.n; ++k) out[static_cast<std::size_t>(k)] = perm ? perm[k] : k;
  return true;
}

void SymmetricSolver::set_layout(FactorLayout layout) {
  impl_->layout = layout;
}

bool SymmetricSolver::supernodal() const {
  return impl_->L && impl_->L->is_super;
}

double SymmetricSolver::rcond() const {
  return impl_->rcond;
}

double SymmetricSolver::factor_nonzeros() const {
  return impl_->analyzed ? impl_->common.lnz : 0;
}

double SymmetricSolver::factor_flops() const {
  return impl_->analyzed ? impl_->common.fl : 0;
}

}  // namespace ricci::detail
