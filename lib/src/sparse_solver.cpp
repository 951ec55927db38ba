#include "sparse_solver.h"

#include <cholmod.h>

#include <algorithm>
#include <cfenv>
#include <cmath>
#include <vector>

namespace ricci::detail {

namespace {

constexpr std::int64_t kNestedDissectionThreshold = 20000;

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
  // Indefinite kind by pinned LLᵀ + Woodbury (see sparse_solver.h): the pins, their weights ρ,
  // the k×k capacitance matrix C = R⁻¹ − Eᵀ M⁻¹ E in LU form (row-major, with its row pivots),
  // and dense workspaces for the batched solves M⁻¹E. `simplicial`: given up on pins (LDLᵀ).
  bool simplicial = false;
  std::vector<std::int64_t> pins;
  std::vector<double> pin_weight, pin_saved, capacitance, pin_rhs;
  std::vector<double> Z;  // n×k row-major: L⁻¹ P E (row i holds the k values of unknown i)
  std::vector<std::int64_t> capacitance_pivot;
  cholmod_dense* Bk = nullptr;
  cholmod_dense* Xk = nullptr;
  cholmod_dense* Yk = nullptr;
  cholmod_dense* Ek = nullptr;
  cholmod_dense* Zk = nullptr;
  cholmod_dense* W = nullptr;
  // inverse_block(): per block column c (an unknown in the permuted order), the supernodes on
  // its elimination-tree path (path_super[path_offsets[c] … path_offsets[c+1]), increasing) and
  // the values of L⁻¹ e on their columns (block_values from value_offsets[c], the columns of each
  // path supernode in turn); a dense workspace of n zeros; W = Zᵀ_pins Z_I for the pins.
  std::vector<std::int64_t> block_column, super_parent, column_super, path_offsets, path_super, value_offsets;
  std::vector<double> block_values, block_work, pin_block;
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
    free_batch();
    cholmod_l_finish(&common);
  }

  void free_batch() {
    if (Bk) cholmod_l_free_dense(&Bk, &common);
    if (Xk) cholmod_l_free_dense(&Xk, &common);
    if (Yk) cholmod_l_free_dense(&Yk, &common);
    if (Ek) cholmod_l_free_dense(&Ek, &common);
    if (Zk) cholmod_l_free_dense(&Zk, &common);
    if (W) cholmod_l_free_dense(&W, &common);
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
// With M = Pᵀ L Lᵀ P and Z = L⁻¹ P E (k forward solves per factorization, kept: n×k values),
// C = R⁻¹ − ZᵀZ and A⁻¹ b = Pᵀ L⁻ᵀ (y + Z C⁻¹ Zᵀ y) with y = L⁻¹ P b: one forward and one
// backward solve per right-hand side, as for a positive definite A, plus O(nk) work; C is
// indefinite and solved by LU with partial pivoting. The pins are spread evenly over the unknowns' order; when M is not
// positive definite their number doubles. Failed: out of pins (the caller's factorize() then
// switches to simplicial LDLᵀ).
FactorOutcome SymmetricSolver::Impl::pinned_factorize(double shift) {
  double* x = static_cast<double*>(A->x);
  std::int64_t k = pins.empty() ? std::min(kFirstPins, n) : static_cast<std::int64_t>(pins.size());
  while (true) {
    if (static_cast<std::int64_t>(pins.size()) != k) {
      pins.resize(static_cast<std::size_t>(k));
      for (std::int64_t i = 0; i < k; ++i) pins[i] = ((2 * i + 1) * n) / (2 * k);
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
    if (outcome == FactorOutcome::NotPositiveDefinite && k < std::min(kMaxPins, n)) {
      k = std::min(2 * k, n);
      continue;
    }
    pins.clear();
    std::vector<double>().swap(Z);
    return FactorOutcome::Failed;
  }
}

FactorOutcome SymmetricSolver::Impl::build_capacitance() {
  const auto k = static_cast<std::int64_t>(pins.size());
  // Columns per batched solve: at most about 2M doubles per workspace.
  const std::int64_t batch =
      std::min<std::int64_t>(k, std::clamp<std::int64_t>((std::int64_t{1} << 21) / std::max<std::int64_t>(n, 1), 4, 32));
  if (!Bk || static_cast<std::int64_t>(Bk->ncol) != batch) {
    free_batch();
    Bk = cholmod_l_zeros(static_cast<std::size_t>(n), static_cast<std::size_t>(batch), CHOLMOD_REAL, &common);
    if (!Bk) return status_outcome() == FactorOutcome::Ok ? FactorOutcome::Failed : status_outcome();
  }
  Z.resize(static_cast<std::size_t>(n * k));
  auto* b = static_cast<double*>(Bk->x);
  const auto ld = static_cast<std::int64_t>(Bk->d);
  for (std::int64_t start = 0; start < k; start += batch) {
    const std::int64_t m = std::min(batch, k - start);
    for (std::int64_t c = 0; c < m; ++c) b[c * ld + pins[start + c]] = 1;
    int ok = cholmod_l_solve2(CHOLMOD_P, L, Bk, nullptr, &Xk, nullptr, &Yk, &Ek, &common);
    for (std::int64_t c = 0; c < m; ++c) b[c * ld + pins[start + c]] = 0;
    ok = ok && Xk && cholmod_l_solve2(CHOLMOD_L, L, Xk, nullptr, &Zk, nullptr, &Yk, &Ek, &common);
    if (!ok || !Zk || common.status < CHOLMOD_OK)
      return status_outcome() == FactorOutcome::OutOfMemory ? FactorOutcome::OutOfMemory : FactorOutcome::Failed;
    const auto* z = static_cast<const double*>(Zk->x);
    const auto lz = static_cast<std::int64_t>(Zk->d);
    for (std::int64_t c = 0; c < m; ++c)
      for (std::int64_t i = 0; i < n; ++i) Z[i * k + start + c] = z[c * lz + i];
  }
  // C = R⁻¹ − ZᵀZ, accumulated row by row of Z (lower triangle, then mirrored).
  capacitance.assign(static_cast<std::size_t>(k * k), 0.0);
  for (std::int64_t i = 0; i < n; ++i) {
    const double* zi = Z.data() + i * k;
    for (std::int64_t a = 0; a < k; ++a) {
      const double za = zi[a];
      if (za == 0) continue;
      double* row = capacitance.data() + a * k;
      for (std::int64_t c = 0; c <= a; ++c) row[c] -= za * zi[c];
    }
  }
  for (std::int64_t a = 0; a < k; ++a) {
    capacitance[a * k + a] += 1 / pin_weight[a];
    for (std::int64_t c = 0; c < a; ++c) capacitance[c * k + a] = capacitance[a * k + c];
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
  std::fill(pin_rhs.begin(), pin_rhs.end(), 0.0);
  for (std::int64_t i = 0; i < n; ++i) {
    const double yi = y[i];
    if (yi == 0) continue;
    const double* zi = Z.data() + i * k;
    for (std::int64_t a = 0; a < k; ++a) pin_rhs[a] += zi[a] * yi;
  }
  capacitance_solve(pin_rhs.data());
  for (std::int64_t i = 0; i < n; ++i) {
    const double* zi = Z.data() + i * k;
    double sum = 0;
    for (std::int64_t a = 0; a < k; ++a) sum += zi[a] * pin_rhs[a];
    y[i] += sum;
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

FactorOutcome SymmetricSolver::analyze(std::int64_t n, std::span<const std::int64_t> col_ptr,
                                       std::span<const std::int64_t> row, FactorKind kind) {
  Impl& s = *impl_;
  if (s.analyzed || n < 0 || col_ptr.size() != static_cast<std::size_t>(n) + 1 ||
      row.size() != static_cast<std::size_t>(col_ptr[static_cast<std::size_t>(n)]))
    return FactorOutcome::Failed;
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

  // Ordering: AMD for small systems; nested dissection by METIS for large ones, whose factors of
  // mesh Laplacian-like matrices have markedly less fill (on a 425k-face mesh: a third of the
  // flops of AMD, for a slower analysis that is done once).
  if (n >= kNestedDissectionThreshold) {
    c.nmethods = 1;
    c.method[0].ordering = CHOLMOD_METIS;
  }
  s.kind = kind;
  c.supernodal = CHOLMOD_SUPERNODAL;  // Indefinite: pinned LLᵀ (see Impl::pinned_factorize)
  c.final_asis = 1;  // supernodal stays LLᵀ, simplicial stays LDLᵀ
  c.grow0 = 0;       // no slack for updates/downdates: exact space
  c.grow2 = 0;
  s.L = cholmod_l_analyze(s.A, &c);
  if (!s.L && c.status == CHOLMOD_NOT_INSTALLED) {  // a CHOLMOD built without METIS: AMD alone
    c.nmethods = 0;
    c.status = CHOLMOD_OK;
    s.L = cholmod_l_analyze(s.A, &c);
  }
  if (!s.L) return s.status_outcome() == FactorOutcome::Ok ? FactorOutcome::Failed : s.status_outcome();
  s.B = cholmod_l_zeros(static_cast<std::size_t>(n), 1, CHOLMOD_REAL, &c);
  if (!s.B) return s.status_outcome() == FactorOutcome::Ok ? FactorOutcome::Failed : s.status_outcome();
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
  if (s.kind == FactorKind::Indefinite && !s.simplicial) {
    const FactorOutcome pinned = s.pinned_factorize(shift);
    if (pinned != FactorOutcome::Failed) {
      s.factored = pinned == FactorOutcome::Ok;
      return pinned;
    }
    // Out of pins: simplicial LDLᵀ from here on (a new analysis, once).
    cholmod_common& c = s.common;
    cholmod_l_free_factor(&s.L, &c);
    c.supernodal = CHOLMOD_SIMPLICIAL;
    c.status = CHOLMOD_OK;
    s.L = cholmod_l_analyze(s.A, &c);
    if (!s.L) return s.status_outcome() == FactorOutcome::Ok ? FactorOutcome::Failed : s.status_outcome();
    s.simplicial = true;
    s.free_batch();
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

double SymmetricSolver::prepare_block(std::span<const std::int64_t> index) {
  Impl& s = *impl_;
  s.block_ready = false;
  if (!s.analyzed || s.n == 0 || !s.L || !s.L->is_super) return -1;
  const auto n = s.n;
  for (const std::int64_t i : index)
    if (i < 0 || i >= n) return -1;
  const auto nsuper = static_cast<std::int64_t>(s.L->nsuper);
  const auto* super = static_cast<const SuiteSparse_long*>(s.L->super);
  const auto* pi = static_cast<const SuiteSparse_long*>(s.L->pi);
  const auto* si = static_cast<const SuiteSparse_long*>(s.L->s);
  const auto* perm = static_cast<const SuiteSparse_long*>(s.L->Perm);
  s.column_super.assign(static_cast<std::size_t>(n), -1);
  for (std::int64_t q = 0; q < nsuper; ++q)
    for (std::int64_t j = super[q]; j < super[q + 1]; ++j) s.column_super[j] = q;
  // The supernodal elimination tree: the parent of a supernode holds its first off-diagonal row.
  s.super_parent.assign(static_cast<std::size_t>(nsuper), -1);
  for (std::int64_t q = 0; q < nsuper; ++q) {
    const std::int64_t nscol = super[q + 1] - super[q], nsrow = pi[q + 1] - pi[q];
    if (nsrow > nscol) s.super_parent[q] = s.column_super[si[pi[q] + nscol]];
  }
  // The inverse permutation into block_work (reused as scratch; zero afterwards).
  s.block_work.assign(static_cast<std::size_t>(n), 0.0);
  std::vector<std::int64_t> inverse(static_cast<std::size_t>(n));
  for (std::int64_t k = 0; k < n; ++k) inverse[perm ? perm[k] : k] = k;
  const auto k = static_cast<std::int64_t>(index.size());
  s.block_column.resize(static_cast<std::size_t>(k));
  s.path_offsets.assign(1, 0);
  s.value_offsets.assign(1, 0);
  s.path_super.clear();
  double flops = 0, path_columns = 0;
  for (std::int64_t c = 0; c < k; ++c) {
    const std::int64_t i = inverse[index[c]];
    s.block_column[c] = i;
    std::int64_t values = 0;
    for (std::int64_t q = s.column_super[i]; q >= 0; q = s.super_parent[q]) {
      s.path_super.push_back(q);
      const std::int64_t nscol = super[q + 1] - super[q], nsrow = pi[q + 1] - pi[q];
      values += nscol;
      flops += 2.0 * static_cast<double>(nsrow) * static_cast<double>(nscol);
    }
    path_columns += static_cast<double>(values);
    s.path_offsets.push_back(static_cast<std::int64_t>(s.path_super.size()));
    s.value_offsets.push_back(s.value_offsets.back() + values);
  }
  s.block_values.assign(static_cast<std::size_t>(s.value_offsets.back()), 0.0);
  // The Gram matrix: k²/2 dot products over the paths.
  flops += static_cast<double>(k) * path_columns;
  s.block_ready = true;
  return flops;
}

bool SymmetricSolver::inverse_block(std::span<double> out) {
  Impl& s = *impl_;
  const auto k = static_cast<std::int64_t>(s.block_column.size());
  if (!s.block_ready || !s.factored || s.simplicial || !s.L || !s.L->is_super || !s.L->x ||
      out.size() != static_cast<std::size_t>(k * k))
    return false;
  const auto* super = static_cast<const SuiteSparse_long*>(s.L->super);
  const auto* pi = static_cast<const SuiteSparse_long*>(s.L->pi);
  const auto* px = static_cast<const SuiteSparse_long*>(s.L->px);
  const auto* si = static_cast<const SuiteSparse_long*>(s.L->s);
  const auto* lx = static_cast<const double*>(s.L->x);
  double* work = s.block_work.data();
  // Z: forward solves L z = e_i along each path (the rows outside the path stay zero).
  for (std::int64_t c = 0; c < k; ++c) {
    work[s.block_column[c]] = 1;
    double* z = s.block_values.data() + s.value_offsets[c];
    for (std::int64_t t = s.path_offsets[c]; t < s.path_offsets[c + 1]; ++t) {
      const std::int64_t q = s.path_super[t];
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
    }
  }
  // ZᵀZ: column a scattered into the workspace, dotted with the paths of the columns b ≤ a.
  for (std::int64_t a = 0; a < k; ++a) {
    const double* za = s.block_values.data() + s.value_offsets[a];
    for (std::int64_t t = s.path_offsets[a]; t < s.path_offsets[a + 1]; ++t) {
      const std::int64_t q = s.path_super[t];
      for (std::int64_t j = super[q]; j < super[q + 1]; ++j) work[j] = *za++;
    }
    for (std::int64_t b = 0; b <= a; ++b) {
      const double* zb = s.block_values.data() + s.value_offsets[b];
      double sum = 0;
      for (std::int64_t t = s.path_offsets[b]; t < s.path_offsets[b + 1]; ++t) {
        const std::int64_t q = s.path_super[t];
        for (std::int64_t j = super[q]; j < super[q + 1]; ++j) sum += work[j] * *zb++;
      }
      out[a * k + b] = out[b * k + a] = sum;
    }
    for (std::int64_t t = s.path_offsets[a]; t < s.path_offsets[a + 1]; ++t) {
      const std::int64_t q = s.path_super[t];
      std::fill(work + super[q], work + super[q + 1], 0.0);
    }
  }
  // Pins (Woodbury): + Wᵀ C⁻¹ W with W = Zᵀ_pins Z_I (Z_pins stored row-major, n×kp).
  const auto kp = static_cast<std::int64_t>(s.pins.size());
  if (kp > 0) {
    s.pin_block.assign(static_cast<std::size_t>(2 * kp * k), 0.0);  // W (kp×k), then C⁻¹W
    double* W = s.pin_block.data();
    double* V = W + kp * k;
    for (std::int64_t c = 0; c < k; ++c) {
      const double* z = s.block_values.data() + s.value_offsets[c];
      for (std::int64_t t = s.path_offsets[c]; t < s.path_offsets[c + 1]; ++t) {
        const std::int64_t q = s.path_super[t];
        for (std::int64_t j = super[q]; j < super[q + 1]; ++j) {
          const double zj = *z++;
          if (zj == 0) continue;
          const double* row = s.Z.data() + j * kp;
          for (std::int64_t a = 0; a < kp; ++a) W[a * k + c] += row[a] * zj;
        }
      }
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
        for (std::int64_t p = 0; p < kp; ++p) sum += W[p * k + a] * V[p * k + b];
        out[a * k + b] += sum;
      }
  }
  for (const double v : out)
    if (!std::isfinite(v)) return false;
  return true;
}

double SymmetricSolver::rcond() const {
  return impl_->rcond;
}

double SymmetricSolver::factor_nonzeros() const {
  return impl_->analyzed ? impl_->common.lnz : 0;
}

}  // namespace ricci::detail
