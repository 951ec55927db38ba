// Target curvatures: uniformization targets, per-vertex targets from a file, the boundary modes,
// the effective target for the current lengths, and the feasibility checks run before a flow.
//
// Notation. K̄ the target curvature (target.K), χ = V − E + F, b the number of boundary loops,
// Φ(e) = acos η_e the intersection angle of a circle packing.
//
// Outer loop of a Circle target. uniform_target(), single_vertex_target() and
// read_target_file() decide it from the topology alone, once: the loop with the most vertices
// (ties: the smallest loop index, i.e. the loop with the smallest boundary corner) gets +2π, all
// others −2π. The choice is stored in Target::loop_total, and effective_target() only reads
// loop_total, so it cannot change from one iteration to the next. (Any loop of a genus-0
// surface may be the outer circle of a circle domain — Koebe — so the choice only fixes which
// loop encloses the others in the plane; callers who prefer the longest loop by 3D length
// overwrite loop_total.)
//
// Admissibility (the paper's Theorem 4, Thurston; Chow & Luo 2003). For a weighted closed
// triangulated surface with Φ : E → [0, π/2] and a nonempty vertex set I,
//
//     Σ_{i∈I} K̄_i  >  −Σ_{(e,v)∈Lk(I)} (π − Φ(e)) + 2π χ(F_I),                          (T4)
//
// where F_I is the subcomplex spanned by I (the vertices of I, the edges and faces with all
// vertices in I) and Lk(I) the pairs (e, v) of a face whose vertex v is in I and whose opposite
// edge e has no vertex in I. In E the curvatures realised by circle packings are exactly those
// with Σ K̄ = 2πχ satisfying (T4) for every proper subset I; in H exactly those satisfying (T4)
// for every nonempty I (I = V gives Σ K̄ > 2πχ).
//
// Surfaces with boundary (K = π − Σθ there) are handled by doubling along the boundary: a
// boundary vertex of the double has curvature 2K̄, a symmetric set I ∪ I' spans a complex with
// χ = 2χ(F_I) − χ(F_I ∩ ∂M), and its link is two copies of Lk(I). Halving (T4) for the double:
//
//     Σ_{i∈I} K̄_i  >  −Σ_{Lk(I)} (π − Φ(e)) + 2π χ(F_I) − π χ(F_I ∩ ∂M),                 (T4b)
//
// F_I ∩ ∂M being the boundary vertices of I and the boundary edges joining two of them. (T4b)
// is also the sum of elementary angle bounds, which is why it remains a valid *necessary*
// condition whatever the other vertices do (held u, derived boundary curvatures): per face, the
// angle at a vertex of I is < π − Φ(opposite edge) when that edge avoids I (the limit as the
// vertex's radius → 0, approached monotonically), and the angles at two or three vertices of I
// in one face sum to < π (E: ≤ π − the third angle; H: the angle sum is below π). Writing
// n_int, n_∂ for the interior and boundary vertices of I and F₂ for the faces with at least two
// vertices in I, (T4b) reads
//
//     Σ_{i∈I} K̄_i  >  2π n_int + π n_∂ − π F₂ − Σ_{faces with one vertex v in I} (π − Φ(e_v)),
//
// and for the two families checked here:
//   single vertex v:  K̄_v > 2π − Σ_{corners c at v} (π − Φ(e_c))    (interior)
//                     K̄_v >  π − Σ_{corners c at v} (π − Φ(e_c))    (boundary)
//                     i.e. the cone angle 2π − K̄ (π − K̄) is below Σ (π − Φ) over the edges
//                     opposite v;
//   boundary loop L:  Σ_{i∈L} K̄_i > π n_L − π F₂(L) − Σ_{faces with one vertex in L} (π − Φ(e)),
//                     where Σ K̄ is the loop total for Circle / LoopTotals targets.
// They are applied to circle packing in E and H with every η used in [0, 1] (a loop or vertex
// whose link has an η outside [0, 1] is skipped) and to proper subsets only. In S (triangles
// have angle sums above π) and for inversive distance and Yamabe (no such bound on single
// angles) only the Gauss–Bonnet sign and the positivity of cone angles are checked.
//
// Gauss–Bonnet, Σ K̄ + λ·area = 2πχ with area > 0, with the tolerance τ = 1e-9·(1 + |2πχ|):
// E: |Σ K̄ − 2πχ| ≤ τ; H: Σ K̄ − 2πχ > τ; S: 2πχ − Σ K̄ > τ (an area lost in rounding is no area).
// Cone angles: K̄ < 2π inside, K̄ < π on the boundary, and a loop total below π·(its vertex
// count) (all geometries). A boundary vertex in a single triangle (an ear) has an angle below π,
// so its target must be positive (for a loop total: the total must be). Checks never reject a
// target that some metric realises.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <new>
#include <numbers>
#include <optional>
#include <string>
#include <system_error>

#include "io_internal.h"
#include "ricci/flow.h"

namespace ricci {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2 * std::numbers::pi;

using io_detail::is_finite_bits;

/// A real number for messages: up to 12 significant digits.
std::string fmt(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.12g", x);
  return buf;
}

bool uses_loop_totals(BoundaryMode m) {
  return m == BoundaryMode::Circle || m == BoundaryMode::LoopTotals;
}

Index loop_size(const Topology& t, Index loop) {
  return t.boundary_offsets[loop + 1] - t.boundary_offsets[loop];
}

/// The Circle loop totals: +2π for the loop with the most vertices (ties: the smallest loop
/// index), −2π for every other loop.
std::vector<double> circle_loop_totals(const Topology& t) {
  const Index loops = t.num_boundary_loops();
  std::vector<double> totals(static_cast<std::size_t>(loops), -kTwoPi);
  Index outer = 0;
  for (Index i = 1; i < loops; ++i)
    if (loop_size(t, i) > loop_size(t, outer)) outer = i;
  if (loops > 0) totals[outer] = kTwoPi;
  return totals;
}

/// The part of a target every constructor shares: K̄ = 0, the boundary as `mode` says. Circle
/// and LoopTotals targets get the Circle loop totals, and their boundary vertices store the
/// equal share total/n of their loop (what effective_target() gives for equal lengths), so that
/// Σ target.K matches the Gauss–Bonnet sum; effective_target() replaces these values.
Target base_target(const Topology& t, BoundaryMode mode) {
  Target target;
  target.boundary = mode;
  target.K.assign(static_cast<std::size_t>(t.num_vertices), 0.0);
  if (mode == BoundaryMode::FixedLengths) {
    target.fixed_u.assign(static_cast<std::size_t>(t.num_vertices), 0);
    for (const Index v : t.boundary_vertices) target.fixed_u[v] = 1;
  }
  if (uses_loop_totals(mode)) {
    target.loop_total = circle_loop_totals(t);
    for (Index i = 0; i < t.num_boundary_loops(); ++i) {
      const double share = target.loop_total[i] / loop_size(t, i);
      for (Index j = t.boundary_offsets[i]; j < t.boundary_offsets[i + 1]; ++j)
        target.K[t.boundary_vertices[j]] = share;
    }
  }
  return target;
}

double two_pi_chi(const Topology& t) {
  return kTwoPi * static_cast<double>(t.euler_characteristic());
}

}  // namespace

std::string_view boundary_mode_name(BoundaryMode m) {
  switch (m) {
    case BoundaryMode::Free:
      return "free";
    case BoundaryMode::FixedLengths:
      return "fixed";
    case BoundaryMode::Circle:
      return "circle";
    case BoundaryMode::Geodesic:
      return "geodesic";
    case BoundaryMode::LoopTotals:
      return "loop-totals";
  }
  return "unknown";
}

// Free on a surface with boundary: the boundary vertices share 2πχ equally (interior K̄ = 0), so
// that the euclidean Gauss–Bonnet condition holds. Geodesic: K̄ = 0 everywhere. FixedLengths:
// K̄ = 0 inside, boundary u held. Circle and LoopTotals: the Circle loop totals (see the top).
Target uniform_target(const Topology& t, BoundaryMode mode) {
  Target target = base_target(t, mode);
  if (mode == BoundaryMode::Free && !t.boundary_vertices.empty()) {
    const double share = two_pi_chi(t) / static_cast<double>(t.boundary_vertices.size());
    for (const Index v : t.boundary_vertices) target.K[v] = share;
  }
  return target;
}

// The vertex gets 2πχ minus the loop totals (Circle, LoopTotals) and every other vertex with a
// condition gets 0 (Free and Geodesic boundaries take nothing; a FixedLengths boundary has no
// condition, and a chosen boundary vertex is released from it). A boundary vertex of a Circle or
// LoopTotals target is governed by its loop, so choose an interior vertex there. An out-of-range
// vertex gives an empty K (check_target() then reports InvalidArgument).
Target single_vertex_target(const Topology& t, Index vertex, BoundaryMode mode) {
  Target target = base_target(t, mode);
  if (vertex < 0 || vertex >= t.num_vertices) {
    target.K.clear();
    return target;
  }
  double boundary_takes = 0;
  for (const double total : target.loop_total) boundary_takes += total;
  target.K[vertex] = two_pi_chi(t) - boundary_takes;
  if (mode == BoundaryMode::FixedLengths) target.fixed_u[vertex] = 0;
  return target;
}

Geometry natural_geometry(const Topology& t) {
  if (t.is_closed()) {
    const std::int64_t chi = t.euler_characteristic();
    return chi > 0 ? Geometry::Spherical : (chi == 0 ? Geometry::Euclidean : Geometry::Hyperbolic);
  }
  return t.genus() == 0 ? Geometry::Euclidean : Geometry::Hyperbolic;
}

// S with boundary is not chosen by natural_geometry(); Geodesic is returned for it (feasible for
// a disk: a domain bounded by a great circle has Σ K̄ = 0 < 2π).
BoundaryMode natural_boundary_mode(const Topology& t, Geometry geometry) {
  if (t.is_closed()) return BoundaryMode::Free;
  return geometry == Geometry::Euclidean ? BoundaryMode::Circle : BoundaryMode::Geodesic;
}

std::vector<Index> infeasible_ears(const Topology& t, const Target& target) {
  std::vector<Index> out;
  if (target.K.size() != static_cast<std::size_t>(t.num_vertices)) return out;
  // As in flow.h: Circle and LoopTotals targets derive boundary K̄ from the loop totals.
  const bool derived = target.boundary == BoundaryMode::Circle || target.boundary == BoundaryMode::LoopTotals;
  if (derived && target.loop_total.size() != static_cast<std::size_t>(t.num_boundary_loops())) return out;
  const bool held = target.fixed_u.size() == static_cast<std::size_t>(t.num_vertices);
  for (Index i = 0; i < t.num_boundary_loops(); ++i) {
    for (Index j = t.boundary_offsets[i]; j < t.boundary_offsets[i + 1]; ++j) {
      const Index v = t.boundary_vertices[j];
      if (t.valence(v) != 1 || (held && target.fixed_u[v] != 0)) continue;
      if (derived ? target.loop_total[i] <= 0 : target.K[v] <= 0) out.push_back(v);
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---------------------------------------------------------------------------------------------
// Target files.

namespace {

bool fail_file(TargetFileResult& r, const std::string& path, Status status, const std::string& what) {
  r.status = status;
  r.message = path + ": " + what;
  r.line = -1;
  return false;
}

bool fail_line(TargetFileResult& r, const std::string& path, Status status, std::int64_t line,
               const std::string& what) {
  r.status = status;
  r.message = path + ": line " + std::to_string(line) + ": " + what;
  r.line = line;
  return false;
}

/// Reads a whole regular file of at most max_bytes into `data`; records FileNotFound /
/// FileUnreadable / FileTooLarge otherwise.
bool load_text(const std::string& path, std::string& data, TargetFileResult& r, std::uint64_t max_bytes) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) {
    if (!ec || ec == std::errc::no_such_file_or_directory || ec == std::errc::not_a_directory)
      return fail_file(r, path, Status::FileNotFound, "the target file does not exist");
    return fail_file(r, path, Status::FileUnreadable, "the target file cannot be read: " + ec.message());
  }
  if (fs::is_directory(st))
    return fail_file(r, path, Status::FileUnreadable, "the path is a directory, not a target file");
  if (!fs::is_regular_file(st))
    return fail_file(r, path, Status::FileUnreadable, "the path is not a regular file (a pipe or a device)");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (!ec && size > max_bytes)
    return fail_file(r, path, Status::FileTooLarge,
                     "the target file has " + std::to_string(size) + " bytes, more than the limit of " +
                         std::to_string(max_bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail_file(r, path, Status::FileUnreadable, "the target file cannot be opened");
  data.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (in.bad()) return fail_file(r, path, Status::FileUnreadable, "the target file cannot be read");
  return true;
}

/// A token that looks like an integer (optional sign, digits only), possibly beyond int64.
bool is_integer_like(std::string_view token) {
  if (!token.empty() && (token[0] == '+' || token[0] == '-')) token.remove_prefix(1);
  return !token.empty() &&
         std::all_of(token.begin(), token.end(), [](char c) { return c >= '0' && c <= '9'; });
}

bool parse_target_into(std::string_view data, const std::string& path, const Topology& t, BoundaryMode mode,
                       TargetFileResult& r) {
  Target target = base_target(t, mode);
  const Index nv = t.num_vertices;
  std::vector<std::int64_t> listed_on(static_cast<std::size_t>(nv), -1);
  io_detail::TextCursor cursor(data, 1, /*comments=*/true, /*continuations=*/false);
  cursor.skip_byte_order_mark();
  std::int64_t listed = 0;
  for (;;) {
    const std::string_view index_token = cursor.token();
    if (index_token.empty()) break;
    const std::int64_t line = cursor.line();
    const std::string_view value_token = cursor.token_on_line();
    if (value_token.empty())
      return fail_line(r, path, Status::ParseError, line,
                       "expected `vertex_index curvature`, found only " + io_detail::quote(index_token));
    if (const std::string_view extra = cursor.token_on_line(); !extra.empty())
      return fail_line(r, path, Status::ParseError, line,
                       "expected `vertex_index curvature`, found a third value " + io_detail::quote(extra));

    std::int64_t index = 0;
    if (!io_detail::parse_integer(index_token, index)) {
      if (is_integer_like(index_token))
        return fail_line(r, path, Status::IndexOutOfRange, line,
                         "vertex index " + io_detail::quote(index_token) + " is out of range: the mesh has " +
                             std::to_string(nv) + " vertices");
      return fail_line(r, path, Status::ParseError, line,
                       "the vertex index " + io_detail::quote(index_token) + " is not an integer");
    }
    if (index < 0 || index >= nv)
      return fail_line(r, path, Status::IndexOutOfRange, line,
                       "vertex index " + std::to_string(index) + " is out of range: the mesh has " +
                           std::to_string(nv) + " vertices (valid indices 0 to " + std::to_string(nv - 1) +
                           ")");
    double value = 0;
    switch (io_detail::parse_real(value_token, value)) {
      case io_detail::NumberParse::Ok:
        break;
      case io_detail::NumberParse::Malformed:
        return fail_line(r, path, Status::ParseError, line,
                         "the curvature " + io_detail::quote(value_token) + " of vertex " +
                             std::to_string(index) + " is not a number");
      case io_detail::NumberParse::NonFinite:
        return fail_line(r, path, Status::ParseError, line,
                         "the curvature " + io_detail::quote(value_token) + " of vertex " +
                             std::to_string(index) + " is not a finite number");
    }
    const Index v = static_cast<Index>(index);
    if (listed_on[v] >= 0)
      return fail_line(r, path, Status::ParseError, line,
                       "vertex " + std::to_string(v) + " is listed twice, on line " +
                           std::to_string(listed_on[v]) + " and on line " + std::to_string(line));
    if (uses_loop_totals(mode) && t.is_boundary_vertex(v))
      return fail_line(r, path, Status::ParseError, line,
                       "vertex " + std::to_string(v) + " lies on the boundary, whose curvature the " +
                           std::string(boundary_mode_name(mode)) +
                           " boundary mode derives from the loop totals; list interior vertices only or use "
                           "the free boundary mode");
    listed_on[v] = line;
    ++listed;
    target.K[v] = value;
    // A listed boundary vertex of a FixedLengths target carries its curvature instead of a held u.
    if (mode == BoundaryMode::FixedLengths) target.fixed_u[v] = 0;
  }
  r.status = Status::Ok;
  r.message = path + ": read " + std::to_string(listed) + " target curvature" + (listed == 1 ? "" : "s") +
              " (" + std::to_string(nv - listed) + " of " + std::to_string(nv) +
              " vertices unlisted; boundary mode " + std::string(boundary_mode_name(mode)) + ")";
  r.line = -1;
  r.target = std::move(target);
  return true;
}

}  // namespace

TargetFileResult read_target_file(const std::string& path, const Topology& t, BoundaryMode mode,
                                  std::uint64_t max_bytes) {
  TargetFileResult r;
  try {
    std::string data;
    if (!load_text(path, data, r, max_bytes)) return r;
    parse_target_into(data, path, t, mode, r);
  } catch (const std::bad_alloc&) {
    fail_file(r, path, Status::FileUnreadable, "not enough memory to read the target file");
  } catch (const std::length_error&) {
    fail_file(r, path, Status::FileUnreadable, "the target file is too large to hold in memory");
  }
  return r;
}

TargetFileResult parse_target_text(std::string_view text, const Topology& t, BoundaryMode mode,
                                   const std::string& name) {
  TargetFileResult r;
  try {
    parse_target_into(text, name, t, mode, r);
  } catch (const std::bad_alloc&) {
    fail_file(r, name, Status::FileUnreadable, "not enough memory to read the target curvatures");
  } catch (const std::length_error&) {
    fail_file(r, name, Status::FileUnreadable, "the target curvatures are too large to hold in memory");
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// The effective target.

bool inscribed_circle_loop(const Target& target, Geometry geometry, Index loop) {
  return target.boundary == BoundaryMode::Circle && geometry == Geometry::Euclidean && loop >= 0 &&
         static_cast<std::size_t>(loop) < target.loop_total.size() &&
         std::abs(std::abs(target.loop_total[static_cast<std::size_t>(loop)]) - 2 * kPi) <= 1e-12;
}

// Loops are visited in index order and each loop's length is summed in loop order, so the result
// is deterministic. With inconsistent sizes (which check_target() reports) it writes what it can
// and never reads or writes out of range: K̄ is copied for min(#V, |target.K|, |K_target|)
// vertices, and the loops are spread only when loop_total has one entry per loop and l has #E
// entries. A loop whose length is not a positive finite number gets equal shares.
namespace {

/// Σ 2·arcsin(l_j/2R) − 2π and its derivative in R (R ≥ max l/2).
template <class Side>
std::pair<double, double> arc_excess(Index count, Side side, double R) {
  double f = -2 * kPi, df = 0;
  for (Index j = 0; j < count; ++j) {
    const double x = std::min(side(j) / (2 * R), 1.0);
    const double c = std::sqrt((1 - x) * (1 + x));
    f += 2 * std::asin(x);
    df -= c > 0 ? side(j) / (R * R * c) : INFINITY;
  }
  return {f, df};
}

/// The root of a function f that is positive at lo and negative at hi, from x: Newton while its
/// steps stay inside the bracket (monotone where f is convex or concave on the side x starts
/// from), bisection otherwise, to rounding. fdf(x) gives f and its derivative.
template <class Fdf>
double bracketed_newton(Fdf fdf, double x, double lo, double hi) {
  for (int it = 0; it < 200 && hi - lo > 1e-16 * hi; ++it) {
    const auto [f, df] = fdf(x);
    if (f == 0) return x;
    if (f > 0)
      lo = x;
    else
      hi = x;
    double next = std::isfinite(df) && df < 0 ? x - f / df : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (next == x) break;
    x = next;
  }
  return x;
}

/// The centre inside: the root of Σ 2·arcsin(l_j/2R) = 2π. f decreases in R; f(L/2π) ≥ 0
/// (arcsin x ≥ x) and f(L/4) ≤ 0 (arcsin x ≤ πx/2), so the root lies in [lo, L/4] when f(lo) ≥ 0
/// at lo = max(L/2π, longest/2). Newton from lo (f is convex, so its steps from the left stay
/// left of the root).
template <class Side>
double minor_radius(Index count, Side side, double lo, double hi) {
  return bracketed_newton([&](double R) { return arc_excess(count, side, R); }, lo, lo, hi);
}

/// The centre outside, beyond side m: with φ = arcsin(l_m/2R) ∈ (0, π/2] and r_j = l_j/l_m ≤ 1,
/// F(φ) = Σ_{j≠m} 2·arcsin(r_j sin φ) − 2φ = 0. F(0) = 0 with F'(0) = 2(Σ r_j − 1) > 0 (the
/// polygon inequality), F(π/2) < 0 (the centre is not inside), and F is concave (each
/// arcsin(r sin φ) is, for r ≤ 1), so the positive root is unique and Newton from π/2 approaches
/// it monotonically from the right (bracketed_newton()).
template <class Side>
double major_radius(Index count, Side side, Index m) {
  const double lm = side(m);
  auto F = [&](double phi) {
    const double s = std::sin(phi), c = std::cos(phi);
    double f = -2 * phi, df = -2;
    for (Index j = 0; j < count; ++j) {
      if (j == m) continue;
      const double r = side(j) / lm, x = std::min(r * s, 1.0);
      f += 2 * std::asin(x);
      df += 2 * r * c / std::max(std::sqrt((1 - x) * (1 + x)), 1e-300);
    }
    return std::pair<double, double>{f, df};
  };
  const double phi = bracketed_newton(F, kPi / 2, 0.0, kPi / 2);
  const double s = std::sin(phi);
  return s > 0 && std::isfinite(lm / (2 * s)) ? lm / (2 * s) : 0.0;
}

template <class Side>
InscribedCircle inscribed_circle_of(Index count, Side side) {
  if (count < 3) return {};
  double L = 0, longest = 0;
  Index m = 0;
  for (Index j = 0; j < count; ++j) {
    const double x = side(j);
    if (!(is_finite_bits(x) && x > 0)) return {};
    L += x;
    if (x > longest) {
      longest = x;
      m = j;
    }
  }
  if (!(longest < L - longest) || !std::isfinite(L)) return {};  // no polygon: one side too long
  const double lo = std::max(L / (2 * kPi), 0.5 * longest), hi = std::max(L / 4, lo);
  if (arc_excess(count, side, lo).first >= 0) return {minor_radius(count, side, lo, hi), -1};
  const double R = major_radius(count, side, m);
  return R > 0 ? InscribedCircle{R, m} : InscribedCircle{};
}

}  // namespace

double InscribedCircle::arc(Index j, double l) const {
  const double a = 2 * std::asin(std::min(l / (2 * radius), 1.0));
  return j == major ? 2 * kPi - a : a;
}

double InscribedCircle::half_arc_cosine(Index j, double l) const {
  const double x = std::min(l / (2 * radius), 1.0);
  const double c = std::max(std::sqrt((1 - x) * (1 + x)), 1e-300);
  return j == major ? -c : c;
}

InscribedCircle inscribed_circle(std::span<const double> sides) {
  return inscribed_circle_of(static_cast<Index>(sides.size()), [&](Index j) { return sides[static_cast<std::size_t>(j)]; });
}

InscribedCircle inscribed_circle(const Topology& t, Index loop, std::span<const double> l) {
  if (loop < 0 || loop >= t.num_boundary_loops() || l.size() < static_cast<std::size_t>(t.num_edges)) return {};
  const Index begin = t.boundary_offsets[loop], end = t.boundary_offsets[loop + 1];
  return inscribed_circle_of(end - begin, [&](Index j) { return l[t.corner_edge[t.boundary_corners[begin + j]]]; });
}

double inscribed_radius(std::span<const double> sides) { return inscribed_circle(sides).radius; }

double inscribed_radius(const Topology& t, Index loop, std::span<const double> l) {
  return inscribed_circle(t, loop, l).radius;
}

void effective_target(const Topology& t, const Target& target, std::span<const double> l,
                      std::span<double> K_target, Geometry geometry) {
  const std::size_t n =
      std::min({static_cast<std::size_t>(t.num_vertices), target.K.size(), K_target.size()});
  std::copy_n(target.K.begin(), n, K_target.begin());
  if (!uses_loop_totals(target.boundary)) return;
  const Index loops = t.num_boundary_loops();
  if (target.loop_total.size() != static_cast<std::size_t>(loops)) return;
  if (l.size() < static_cast<std::size_t>(t.num_edges) ||
      K_target.size() < static_cast<std::size_t>(t.num_vertices))
    return;
  for (Index i = 0; i < loops; ++i) {
    const Index begin = t.boundary_offsets[i], end = t.boundary_offsets[i + 1];
    if (end <= begin) continue;
    const double total = target.loop_total[i];
    // Edge j of the loop runs from boundary_vertices[j] to the next vertex of the loop.
    double length = 0;
    for (Index j = begin; j < end; ++j) length += l[t.corner_edge[t.boundary_corners[j]]];
    if (!(is_finite_bits(length) && length > 0)) {
      const double share = total / (end - begin);
      for (Index j = begin; j < end; ++j) K_target[t.boundary_vertices[j]] = share;
      continue;
    }
    double before = l[t.corner_edge[t.boundary_corners[end - 1]]];  // the edge arriving at `begin`
    const InscribedCircle circle = inscribed_circle_loop(target, geometry, i) ? inscribed_circle(t, i, l) : InscribedCircle{};
    if (circle.radius > 0) {
      // The inscribed polygon: turning ±(α_in + α_out)/2, α the sides' central angles.
      const double sign = total > 0 ? 1.0 : -1.0;
      double arc_before = circle.arc(end - 1 - begin, before);
      for (Index j = begin; j < end; ++j) {
        const double arc_after = circle.arc(j - begin, l[t.corner_edge[t.boundary_corners[j]]]);
        K_target[t.boundary_vertices[j]] = sign * 0.5 * (arc_before + arc_after);
        arc_before = arc_after;
      }
      continue;
    }
    for (Index j = begin; j < end; ++j) {
      const double after = l[t.corner_edge[t.boundary_corners[j]]];
      K_target[t.boundary_vertices[j]] = total * (0.5 * (before + after) / length);
      before = after;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Checks.

namespace {

TargetCheck make_check(Status status, std::string message, Element element = Element::None,
                       std::int64_t index = -1) {
  TargetCheck c;
  c.status = status;
  c.message = std::move(message);
  c.element = element;
  c.element_index = index;
  return c;
}

/// π − Φ(e) for a circle-packing weight η_e = cos Φ(e) in [0, 1]; −1 when η_e is outside
/// [0, 1] or not finite (no bound is known then).
double link_term(double eta) {
  if (!is_finite_bits(eta) || eta < 0 || eta > 1) return -1;
  return kPi - std::acos(eta);
}

// ---- check_target(), rule by rule: each returns the first violation, if any ----

// The target as the rules read it: which vertices hold u, which carry a curvature condition.
struct TargetView {
  const Topology& t;
  const ConformalStructure& structure;
  const Target& target;
  bool with_totals = false;  // boundary K̄ derived from loop totals
  bool is_fixed(Index v) const { return !target.fixed_u.empty() && target.fixed_u[v] != 0; }
  // A vertex whose K̄ is a condition read from target.K (not held, not derived from a loop total).
  bool explicit_condition(Index v) const { return !is_fixed(v) && !(with_totals && t.is_boundary_vertex(v)); }
};

// Sizes of K, fixed_u, loop totals and η.
std::optional<TargetCheck> check_sizes(const TargetView& tv) {
  const Topology& t = tv.t;
  const Target& target = tv.target;
  const ConformalStructure& structure = tv.structure;
  const Index nv = t.num_vertices, loops = t.num_boundary_loops();
  const auto nv_size = static_cast<std::size_t>(nv);
  const bool with_totals = tv.with_totals;
  if (target.K.size() != nv_size)
    return make_check(Status::InvalidArgument, "the target has " + std::to_string(target.K.size()) +
                                                   " curvatures, but the mesh has " + std::to_string(nv) +
                                                   " vertices");
  if (!target.fixed_u.empty() && target.fixed_u.size() != nv_size)
    return make_check(Status::InvalidArgument, "the target has " + std::to_string(target.fixed_u.size()) +
                                                   " fixed_u flags, but the mesh has " + std::to_string(nv) +
                                                   " vertices (give one per vertex, or none)");
  if (with_totals && target.loop_total.size() != static_cast<std::size_t>(loops))
    return make_check(Status::InvalidArgument, "the " + std::string(boundary_mode_name(target.boundary)) +
                                                   " boundary mode needs one loop "
                                                   "total per boundary loop: the target has " +
                                                   std::to_string(target.loop_total.size()) +
                                                   ", the mesh has " + std::to_string(loops) + " loops");
  if (structure.eta.size() != static_cast<std::size_t>(t.num_edges))
    return make_check(Status::InvalidArgument,
                      "the conformal structure has " + std::to_string(structure.eta.size()) +
                          " edge weights, but the mesh has " + std::to_string(t.num_edges) + " edges");

  return std::nullopt;
}

// Finite values where they are conditions; any_fixed: some vertex holds its u.
std::optional<TargetCheck> check_values(const TargetView& tv, bool& any_fixed) {
  const Topology& t = tv.t;
  const Target& target = tv.target;
  const Index nv = t.num_vertices, loops = t.num_boundary_loops();
  const bool with_totals = tv.with_totals;
  auto explicit_condition = [&](Index v) { return tv.explicit_condition(v); };
  auto is_fixed = [&](Index v) { return tv.is_fixed(v); };
  any_fixed = false;
  for (Index v = 0; v < nv; ++v) {
    any_fixed = any_fixed || is_fixed(v);
    if (explicit_condition(v) && !is_finite_bits(target.K[v]))
      return make_check(Status::InvalidArgument,
                        "the target curvature of vertex " + std::to_string(v) + " is not a finite number",
                        Element::Vertex, v);
  }
  if (with_totals)
    for (Index i = 0; i < loops; ++i)
      if (!is_finite_bits(target.loop_total[i]))
        return make_check(Status::InvalidArgument, "the total curvature of boundary loop " +
                                                       std::to_string(i) + " is not a finite number");

  return std::nullopt;
}

// Gauss–Bonnet: Σ K̄ + λ·area = 2πχ with area > 0. Loops with a total count by it. (Skipped when
// some vertex holds its u: its curvature is whatever the metric gives.)
std::optional<TargetCheck> check_gauss_bonnet(const TargetView& tv) {
  const Topology& t = tv.t;
  const Target& target = tv.target;
  const Index nv = t.num_vertices;
  const bool with_totals = tv.with_totals;
  const Geometry g = tv.structure.geometry;
  auto explicit_condition = [&](Index v) { return tv.explicit_condition(v); };
  double sum = 0;
  for (Index v = 0; v < nv; ++v)
    if (explicit_condition(v)) sum += target.K[v];
  if (with_totals)
    for (const double total : target.loop_total) sum += total;
  const double expected = two_pi_chi(t);
  const double tolerance = 1e-9 * (1 + std::abs(expected));
  const std::string given = "the target curvatures sum to " + fmt(sum) +
                            (with_totals ? " (boundary loops counted by their totals)" : "");
  const std::string chi =
      "2πχ = " + fmt(expected) + " (χ = " + std::to_string(t.euler_characteristic()) + ")";
  if (g == Geometry::Euclidean && !(std::abs(sum - expected) <= tolerance))
    return make_check(Status::InfeasibleTarget,
                      "Gauss–Bonnet: in euclidean background the target curvatures must sum to " + chi +
                          ", but " + given + " (difference " + fmt(sum - expected) + ")");
  if (g == Geometry::Hyperbolic && !(sum - expected > tolerance))
    return make_check(
        Status::InfeasibleTarget,
        "Gauss–Bonnet: in hyperbolic background the target curvatures must sum to more than " + chi +
            " (the hyperbolic area is their sum minus 2πχ), but " + given);
  if (g == Geometry::Spherical && !(expected - sum > tolerance))
    return make_check(Status::InfeasibleTarget,
                      "Gauss–Bonnet: in spherical background the target curvatures must sum to less than " +
                          chi + " (the spherical area is 2πχ minus their sum), but " + given);
  return std::nullopt;
}

// Positive cone angles (every geometry and scheme), per vertex and per loop with a total.
std::optional<TargetCheck> check_cone_angles(const TargetView& tv) {
  const Topology& t = tv.t;
  const Target& target = tv.target;
  const Index nv = t.num_vertices, loops = t.num_boundary_loops();
  const bool with_totals = tv.with_totals;
  auto explicit_condition = [&](Index v) { return tv.explicit_condition(v); };
  // --- Positive cone angles: 2π − K̄ > 0 inside, π − K̄ > 0 on the boundary (every geometry).
  // Vertices used by no face have no angles and are skipped.
  for (Index v = 0; v < nv; ++v) {
    if (!explicit_condition(v) || t.valence(v) == 0) continue;
    const bool boundary = t.is_boundary_vertex(v);
    const double limit = boundary ? kPi : kTwoPi;
    if (!(target.K[v] < limit))
      return make_check(Status::InfeasibleTarget,
                        "the target curvature " + fmt(target.K[v]) + " of " +
                            (boundary ? "boundary " : "interior ") + "vertex " + std::to_string(v) +
                            " leaves no positive cone angle: it must be below " + (boundary ? "π" : "2π") +
                            " = " + fmt(limit),
                        Element::Vertex, v);
  }
  // A loop with a total: the angles at its n vertices are positive, so its total is below nπ.
  if (with_totals)
    for (Index i = 0; i < loops; ++i)
      if (!(target.loop_total[i] < kPi * loop_size(t, i)))
        return make_check(Status::InfeasibleTarget,
                          "the total curvature " + fmt(target.loop_total[i]) + " of boundary loop " +
                              std::to_string(i) + " leaves no positive angles: with " +
                              std::to_string(loop_size(t, i)) + " vertices it must be below " +
                              fmt(kPi * loop_size(t, i)));

  return std::nullopt;
}

// Ears whose target curvature is ≤ 0.
std::optional<TargetCheck> check_ears(const TargetView& tv) {
  const Topology& t = tv.t;
  const Target& target = tv.target;
  const Index loops = t.num_boundary_loops();
  const bool with_totals = tv.with_totals;
  auto is_fixed = [&](Index v) { return tv.is_fixed(v); };
  // --- Ears: a boundary vertex in a single triangle has an angle below π, so its curvature
  // π − θ is positive whatever the metric (every scheme and geometry).
  for (Index i = 0; i < loops; ++i) {
    for (Index j = t.boundary_offsets[i]; j < t.boundary_offsets[i + 1]; ++j) {
      const Index v = t.boundary_vertices[j];
      if (t.valence(v) != 1 || is_fixed(v)) continue;
      const bool derived = with_totals;
      if (derived ? target.loop_total[i] > 0 : target.K[v] > 0) continue;
      const std::string given =
          derived ? "the " + std::string(boundary_mode_name(target.boundary)) + " target spreads boundary loop " +
                        std::to_string(i) + "'s total " + fmt(target.loop_total[i]) +
                        " by length and so gives it a curvature ≤ 0"
                  : "the target gives it " + fmt(target.K[v]);
      return make_check(Status::InfeasibleTarget,
                        "boundary vertex " + std::to_string(v) + " lies in a single triangle (an ear of boundary loop " +
                            std::to_string(i) + "): its angle is below π, so its curvature π − θ is positive, but " +
                            given + " (split the interior edge opposite it at its midpoint, see split_ears() and "
                            "ValidateOptions::split_ears; remove the ear triangle; or give it a positive target)",
                        Element::Vertex, v);
    }
  }

  return std::nullopt;
}

// Theorem 4 at single vertices: K̄_v above (2π or π) − Σ(π − Φ) over the opposite edges.
std::optional<TargetCheck> check_theorem4_vertices(const TargetView& tv, const std::string& where) {
  const Topology& t = tv.t;
  const Target& target = tv.target;
  const ConformalStructure& structure = tv.structure;
  const Index nv = t.num_vertices;
  auto explicit_condition = [&](Index v) { return tv.explicit_condition(v); };
  for (Index v = 0; v < nv; ++v) {
    if (!explicit_condition(v) || t.valence(v) == 0) continue;
    double link = 0;
    bool known = true;
    for (Index k = t.vertex_corner_offsets[v]; k < t.vertex_corner_offsets[v + 1]; ++k) {
      const double term = link_term(structure.eta[t.corner_edge[t.vertex_corners[k]]]);
      known = known && term >= 0;
      link += term;
    }
    if (!known) continue;
    const bool boundary = t.is_boundary_vertex(v);
    const double full = boundary ? kPi : kTwoPi;
    const double bound = full - link;
    if (!(target.K[v] > bound))
      return make_check(Status::InfeasibleTarget,
                        where + ": the target curvature " + fmt(target.K[v]) + " of " +
                            (boundary ? "boundary " : "interior ") + "vertex " + std::to_string(v) +
                            " is not admissible: it must exceed " + (boundary ? "π" : "2π") +
                            " − Σ(π − Φ) over its " + std::to_string(t.valence(v)) +
                            " opposite edges = " + fmt(bound) + " (the cone angle " +
                            fmt(full - target.K[v]) + " must be below Σ(π − Φ) = " + fmt(link) + ")",
                        Element::Vertex, v);
  }
  return std::nullopt;
}

// Theorem 4 on boundary loops: I = the vertices of one loop, all with a curvature condition, I ≠ V.
std::optional<TargetCheck> check_theorem4_loops(const TargetView& tv, const std::string& where) {
  const Topology& t = tv.t;
  const Target& target = tv.target;
  const ConformalStructure& structure = tv.structure;
  const Index nv = t.num_vertices, loops = t.num_boundary_loops();
  const auto nv_size = static_cast<std::size_t>(nv);
  const bool with_totals = tv.with_totals;
  auto is_fixed = [&](Index v) { return tv.is_fixed(v); };
  std::vector<Index> loop_of(nv_size, kInvalid);
  for (Index i = 0; i < loops; ++i)
    for (Index j = t.boundary_offsets[i]; j < t.boundary_offsets[i + 1]; ++j)
      loop_of[t.boundary_vertices[j]] = i;
  std::vector<double> link(static_cast<std::size_t>(loops), 0.0);
  std::vector<Index> faces_with_two(static_cast<std::size_t>(loops), 0);
  std::vector<std::uint8_t> known(static_cast<std::size_t>(loops), 1);
  for (Index f = 0; f < t.num_faces; ++f) {
    for (Index k = 0; k < 3; ++k) {
      const Index loop = loop_of[t.corner_vertex[3 * f + k]];
      if (loop == kInvalid) continue;
      // Count each (face, loop) once: at the first corner of the face on that loop.
      bool first = true;
      for (Index m = 0; m < k; ++m) first = first && loop_of[t.corner_vertex[3 * f + m]] != loop;
      if (!first) continue;
      Index on_loop = 0;
      for (Index m = 0; m < 3; ++m) on_loop += loop_of[t.corner_vertex[3 * f + m]] == loop ? 1 : 0;
      if (on_loop >= 2) {
        ++faces_with_two[loop];
      } else {
        const double term = link_term(structure.eta[t.corner_edge[3 * f + k]]);
        if (term < 0)
          known[loop] = 0;
        else
          link[loop] += term;
      }
    }
  }
  for (Index i = 0; i < loops; ++i) {
    const Index n = loop_size(t, i);
    if (n >= nv || !known[i]) continue;
    double sum = 0;
    bool all_conditions = true;
    if (with_totals) {
      sum = target.loop_total[i];
    } else {
      for (Index j = t.boundary_offsets[i]; j < t.boundary_offsets[i + 1] && all_conditions; ++j) {
        const Index v = t.boundary_vertices[j];
        all_conditions = !is_fixed(v);
        if (all_conditions) sum += target.K[v];
      }
    }
    if (!all_conditions) continue;
    const double bound = kPi * n - kPi * faces_with_two[i] - link[i];
    if (!(sum > bound))
      return make_check(
          Status::InfeasibleTarget,
          where + ": the total target curvature " + fmt(sum) + " of boundary loop " + std::to_string(i) +
              " (" + std::to_string(n) + " vertices, first " +
              std::to_string(t.boundary_vertices[t.boundary_offsets[i]]) +
              ") is not admissible: it must exceed −Σ_Lk(π − Φ) + 2πχ(F_I) − πχ(F_I ∩ ∂) = " + fmt(bound) +
              " (Σ_Lk(π − Φ) = " + fmt(link[i]) + " over the faces touching the loop at one vertex)");
  }
  return std::nullopt;
}

// Theorem 4 on the level sets of u: the sets a stalled circle-packing solve points at (the radii
// that shrink towards 0 or grow without bound together). Units enter the set whole: a vertex with
// an explicit condition, or (loop totals) a boundary loop with its total; held vertices never.
// (T4b) is kept incrementally as the set grows, per face by the number of its vertices in I.
struct LevelSetScan {
  const TargetView& tv;
  std::vector<std::vector<Index>> units;  // each unit's vertices
  std::vector<double> unit_K;             // its total target curvature
  double worst_slack = 0;                 // Σ K̄ − bound of the worst set (≤ 0: violated)
  Index worst_size = 0, worst_vertex = kInvalid;
  double worst_sum = 0, worst_bound = 0, worst_level = 0;
  bool worst_below = true, found = false;

  // Adds the units in `order` one by one, checking (T4b) after each (E: proper subsets only).
  void scan(const std::vector<Index>& order, std::span<const double> u, bool below) {
    const Topology& t = tv.t;
    std::vector<std::uint8_t> in(static_cast<std::size_t>(t.num_vertices), 0), count(static_cast<std::size_t>(t.num_faces), 0);
    double sum = 0, link = 0;
    Index n_int = 0, n_bd = 0, two = 0, size = 0;
    auto term = [&](Index corner) { return link_term(tv.structure.eta[t.corner_edge[corner]]); };
    for (std::size_t i = 0; i < order.size(); ++i) {
      const Index unit = order[i];
      for (Index v : units[static_cast<std::size_t>(unit)]) {
        in[v] = 1;
        ++size;
        (t.is_boundary_vertex(v) ? n_bd : n_int) += 1;
        for (Index k = t.vertex_corner_offsets[v]; k < t.vertex_corner_offsets[v + 1]; ++k) {
          const Index c = t.vertex_corners[k], f = corner_face(c);
          const std::uint8_t before = count[f]++;
          if (before == 0) {
            link += term(c);
          } else if (before == 1) {
            for (Index m = 3 * f; m < 3 * f + 3; ++m)
              if (m != c && in[t.corner_vertex[m]] && t.corner_vertex[m] != v) link -= term(m);
            ++two;
          }
        }
      }
      sum += unit_K[static_cast<std::size_t>(unit)];
      if (size >= t.num_vertices && tv.structure.geometry == Geometry::Euclidean) break;
      const double bound = kTwoPi * n_int + kPi * n_bd - kPi * two - link;
      const double slack = sum - bound, tol = 1e-9 * (1 + std::abs(bound));
      if (slack <= tol && (!found || slack < worst_slack)) {
        found = true;
        worst_slack = slack;
        worst_size = size;
        worst_sum = sum;
        worst_bound = bound;
        worst_below = below;
        const std::vector<Index>& first = units[static_cast<std::size_t>(order.front())];
        worst_vertex = first.front();
        worst_level = u[units[static_cast<std::size_t>(unit)].front()];
      }
    }
  }
};

}  // namespace

TargetCheck check_theorem4_levels(const Topology& t, const ConformalStructure& structure, const Target& target,
                                  std::span<const double> u) {
  const TargetView tv{t, structure, target, uses_loop_totals(target.boundary)};
  const Geometry g = structure.geometry;
  // Inversive distance with every η in [0, 1] is a circle packing with Φ = arccos η.
  if (structure.scheme == Scheme::Yamabe || g == Geometry::Spherical)
    return make_check(Status::Ok, "no admissibility bound applies");
  if (check_sizes(tv) || u.size() != static_cast<std::size_t>(t.num_vertices))
    return make_check(Status::InvalidArgument, "the sizes of the target or of u do not fit the mesh");
  for (Index e = 0; e < t.num_edges; ++e)
    if (link_term(structure.eta[e]) < 0) return make_check(Status::Ok, "an edge weight is outside [0, 1]: no bound known");
  for (Index v = 0; v < t.num_vertices; ++v)
    if (!std::isfinite(u[v])) return make_check(Status::InvalidArgument, "u is not finite");
  LevelSetScan scan{tv, {}, {}};
  // Units, and each unit's lowest and highest u.
  std::vector<double> low, high;
  for (Index v = 0; v < t.num_vertices; ++v)
    if (tv.explicit_condition(v) && t.valence(v) > 0) {
      scan.units.push_back({v});
      scan.unit_K.push_back(target.K[v]);
    }
  if (tv.with_totals)
    for (Index i = 0; i < t.num_boundary_loops(); ++i) {
      std::vector<Index> loop(t.boundary_vertices.begin() + t.boundary_offsets[i],
                              t.boundary_vertices.begin() + t.boundary_offsets[i + 1]);
      if (std::any_of(loop.begin(), loop.end(), [&](Index v) { return tv.is_fixed(v); })) continue;
      scan.units.push_back(std::move(loop));
      scan.unit_K.push_back(target.loop_total[static_cast<std::size_t>(i)]);
    }
  if (scan.units.empty()) return make_check(Status::Ok, "no vertex carries a curvature condition");
  for (const std::vector<Index>& unit : scan.units) {
    double lo = u[unit.front()], hi = lo;
    for (Index v : unit) {
      lo = std::min(lo, u[v]);
      hi = std::max(hi, u[v]);
    }
    low.push_back(lo);
    high.push_back(hi);
  }
  std::vector<Index> order(scan.units.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<Index>(i);
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return low[a] < low[b]; });
  scan.scan(order, u, true);
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return high[a] > high[b]; });
  scan.scan(order, u, false);
  if (!scan.found) return make_check(Status::Ok, "Theorem 4 holds on every sublevel and superlevel set of u");
  const std::string where = "Theorem 4 (" + std::string(scheme_name(structure.scheme)) + ", " +
                            std::string(geometry_name(g)) + ")";
  return make_check(
      Status::InfeasibleTarget,
      where + " fails on the " + std::to_string(scan.worst_size) + " vertices whose radii " +
          (scan.worst_below ? "shrank" : "grew") + " most (u " + (scan.worst_below ? "≤ " : "≥ ") +
          fmt(scan.worst_level) + ", from vertex " + std::to_string(scan.worst_vertex) +
          "): their total target curvature " + fmt(scan.worst_sum) +
          " must exceed −Σ_Lk(π − Φ) + 2πχ(F_I) − πχ(F_I ∩ ∂) = " + fmt(scan.worst_bound) +
          ", so no circle pattern with these weights reaches the target (a necessary condition, whatever "
          "the solver does); vertex scaling (scheme yamabe, with flips) has no such bound: its conditions are "
          "Gauss–Bonnet and positive cone angles",
      Element::Vertex, scan.worst_vertex);
}

TargetCheck check_target(const Topology& t, const ConformalStructure& structure, const Target& target) {
  const TargetView tv{t, structure, target, uses_loop_totals(target.boundary)};
  if (auto c = check_sizes(tv)) return *c;
  bool any_fixed = false;
  if (auto c = check_values(tv, any_fixed)) return *c;
  if (!any_fixed)
    if (auto c = check_gauss_bonnet(tv)) return *c;
  if (auto c = check_cone_angles(tv)) return *c;
  if (auto c = check_ears(tv)) return *c;
  // Theorem 4 (see the top of this file): circle packing in E and H only.
  const Geometry g = structure.geometry;
  if (structure.scheme != Scheme::CirclePacking || g == Geometry::Spherical) {
    return make_check(Status::Ok, "the target passes the Gauss–Bonnet and cone-angle checks (" +
                                      std::string(scheme_name(structure.scheme)) + ", " +
                                      std::string(geometry_name(g)) + ": no admissibility bound applies)");
  }
  const std::string where = "Theorem 4 (circle packing, " + std::string(geometry_name(g)) + ")";
  if (t.num_vertices >= 2)
    if (auto c = check_theorem4_vertices(tv, where)) return *c;
  if (t.num_boundary_loops() > 0)
    if (auto c = check_theorem4_loops(tv, where)) return *c;
  return make_check(Status::Ok, "the target passes the Gauss–Bonnet, cone-angle and " + where + " checks");
}

}  // namespace ricci
