// ricci (internal) — a sparse symmetric factorization with a fixed pattern, for the Newton steps
// of solve_flow(). Wraps CHOLMOD (64-bit integer interface) so that no other file includes it.
//
// Usage: analyze() once with the pattern of the upper triangle (compressed columns, rows sorted
// within each column); then, every iteration, write the numeric values into values(), call
// factorize() (optionally of A + shift·I) and solve(). The symbolic analysis (fill-reducing
// ordering, elimination tree, supernodes) is computed once and reused by every factorize(). After
// the first factorize() and solve(), further calls reuse every buffer of this object (CHOLMOD
// itself still takes short-lived workspace inside its supernodal factorization).
//
// The factor is LLᵀ, supernodal (dense blocks through the BLAS) for systems of many flops per
// factor nonzero, simplicial (column by column) below (sparse_solver.cpp has the measured
// switch); set_layout() fixes either.
//
// Two kinds: PositiveDefinite (LLᵀ; fails with NotPositiveDefinite when a pivot is not
// positive) and Indefinite, for symmetric matrices with a few negative eigenvalues (the spherical
// Newton matrix has one): LLᵀ of A + Σ ρ_p e_p e_pᵀ with soft pins on 32 … 512 unknowns
// spread over the index range, corrected exactly by the Woodbury formula (a k×k LU solve per
// right-hand side; see sparse_solver.cpp). When even 512 pins do not make the matrix positive
// definite, the solver switches for good to simplicial LDLᵀ without pivoting (for matrices whose
// leading minors are nonzero; NotPositiveDefinite only on a zero or non-finite pivot).
//
// The library never prints: CHOLMOD's own messages are switched off. Not thread-safe; call from
// outside OpenMP regions (CHOLMOD and the BLAS may use threads of their own).
#pragma once

#include <cstdint>
#include <memory>
#include <span>

namespace ricci::detail {

enum class FactorKind { PositiveDefinite, Indefinite };

/// The factor's storage: fixed, or chosen by the analysis from its flops per factor nonzero
/// (Automatic).
enum class FactorLayout { Automatic, Supernodal, Simplicial };

enum class FactorOutcome {
  Ok,
  NotPositiveDefinite,  ///< LLᵀ met a non-positive pivot, or LDLᵀ a zero / non-finite one
  OutOfMemory,
  Failed,  ///< any other CHOLMOD error (invalid input, integer overflow, …)
};

class SymmetricSolver {
 public:
  SymmetricSolver();
  ~SymmetricSolver();
  SymmetricSolver(const SymmetricSolver&) = delete;
  SymmetricSolver& operator=(const SymmetricSolver&) = delete;
  /// Forgets the analysis and factorization (a new analyze() may follow, e.g. for a new pattern);
  /// keeps set_layout()'s choice.
  void reset();

  /// The layout of the next analyze() (Automatic unless set).
  void set_layout(FactorLayout layout);
  /// Whether the analysis chose (or was given) the supernodal layout; false before analyze().
  bool supernodal() const;

  /// Symbolic analysis of the n×n symmetric matrix whose upper triangle has the pattern
  /// col_ptr (n+1) / row (col_ptr[n]) with rows sorted increasingly in each column.
  /// `ordering`: empty (the solver chooses: AMD, or METIS nested dissection when its ordering
  /// saves flops and AMD's factor costs more than a few thousand flops per unknown),
  /// or a fill-reducing permutation to use instead (ordering[k] = the unknown eliminated k-th; n
  /// distinct entries in [0, n), else Failed), e.g. the restriction of another system's
  /// ordering() to the unknowns of this one: the analysis then skips the ordering, which is most
  /// of its cost with METIS.
  FactorOutcome analyze(std::int64_t n, std::span<const std::int64_t> col_ptr,
                        std::span<const std::int64_t> row, FactorKind kind,
                        std::span<const std::int64_t> ordering = {});

  /// The fill-reducing permutation of the analysis (postordered; out[k] = the unknown eliminated
  /// k-th) into out (n entries). False before a successful analyze() or on a size mismatch.
  bool ordering(std::span<std::int64_t> out) const;

  /// The numeric values of the upper triangle, in the order of `row` (write before factorize()).
  std::span<double> values();

  /// Numeric factorization of A + shift·I with the analysis of analyze().
  FactorOutcome factorize(double shift = 0);

  /// Solves (A + shift·I) x = b with the last successful factorization. b and x have n entries
  /// and may not alias. Returns false on a CHOLMOD error or a non-finite result.
  bool solve(std::span<const double> b, std::span<double> x);

  /// Prepares inverse_block() for the unknowns `index` (after analyze(); allocates what
  /// inverse_block() needs). Returns an estimate of the floating-point operations of one
  /// inverse_block(), or a negative value when the factor kind does not support it.
  double prepare_block(std::span<const std::int64_t> index);

  /// out (k×k, row-major, k = the size of prepare_block()'s index) = E_Iᵀ (A + shift·I)⁻¹ E_I for
  /// the last successful factorization, E_I the columns of the identity at those unknowns. With
  /// (A + shift·I) = Pᵀ L Lᵀ P this is ZᵀZ, Z = L⁻¹ P E_I, whose column for unknown i is nonzero
  /// only on the elimination-tree path from i to the root: sparse forward solves along the
  /// supernodes (or columns) of each path (no full solve). With pins (Indefinite), the Woodbury
  /// correction is added. False when unsupported (the LDLᵀ fallback), not prepared, or a value is
  /// not finite.
  bool inverse_block(std::span<double> out);

  /// CHOLMOD's rough reciprocal condition estimate of the last factorization (min/max of the
  /// diagonal of the factor); 0 before any.
  double rcond() const;
  /// Nonzeros of the factor L after the first factorization (0 before).
  double factor_nonzeros() const;
  /// Floating-point operations of one numeric factorization with the last analysis (0 before).
  double factor_flops() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ricci::detail
