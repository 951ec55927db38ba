// ricci — canonical generators of a closed hyperbolic surface from the side pairings of any
// fundamental polygon, and the geodesic canonical 4g-gon they span. See deck.h.
//
// Takes: a compact domain (cut_compact(): sides x1 … with partners) and its side pairings
// (fit_domain_pairings(), adjusted to exact vertex cycles, map + map_low in quad).
// Gives: the generators A1 B1 … Ag Bg as exact products of those pairings (canonical_generators())
// and the geodesic polygon with vertices p, A1 p, … (geodesic_polygon()). Nothing here touches the
// mesh: the classification proof's cut-and-paste runs on the polygon's word (a few dozen letters),
// so the cost does not grow with the mesh or, beyond the word's length, with the genus. The
// moves and substitutions are made in quad; the many that are only tried and measured (Schema::
// light(), reduce_generators()) and the search for where a frame goes (displacement_frame(),
// centre_polygon()) run in double-double (moebius_quad.h), a fraction of the cost. Pairings
// closed in quad-double (DeckOptions::wide_pairings) get the words the quad search chose
// evaluated there (evaluate_canonical_words()), and their polygon formed there too.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <new>
#include <numeric>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "moebius_quad.h"
#include "ricci/deck.h"

namespace ricci {

namespace {

using detail::CQ;
using detail::MoebiusQ;
using detail::quad;
using detail::quad_map;
using DD = detail::DoubleDouble;
using cplx = std::complex<double>;

// ---- words in the side pairings ---------------------------------------------------------------

/// A word in the domain's side pairings: +k+1 for pairing k, −(k+1) for its inverse; composition
/// left to right as matrices (the rightmost letter acts first).
using Word = std::vector<int>;

Word inverse(const Word& w) {
  Word out(w.rbegin(), w.rend());
  for (int& x : out) x = -x;
  return out;
}

/// Concatenation, freely reduced at the seams (every input is reduced).
Word concat(std::initializer_list<const Word*> parts) {
  Word out;
  for (const Word* p : parts)
    for (int x : *p) {
      if (!out.empty() && out.back() == -x)
        out.pop_back();
      else
        out.push_back(x);
    }
  return out;
}

// ---- the polygon's word and cut-and-paste ----------------------------------------------------------

/// 2 asinh |b| from |b|² in quad, without leaving double's range: pairings beyond |b| = 1e150 (a
/// displacement above 690, far beyond what a layout resolves) all count as that large.
template <class Q>
double size_of_b(Q b_norm) {
  constexpr double kMaxNorm = 1e300;
  if (detail::qisnan(b_norm) || !(b_norm < Q(kMaxNorm))) return 2 * std::asinh(std::sqrt(kMaxNorm));
  return 2 * std::asinh(std::sqrt(static_cast<double>(b_norm)));
}

/// A polygon with side pairings, read counter-clockwise: side j carries letter[j] with sign[j]
/// (+1: the side labelled x, −1: x^-1). Corner j is where side j starts. element[L] is letter L's
/// pairing (it maps the +1 side onto the −1 side, reversed) as a word in the original pairings.
template <class Q>
struct Schema {
  using CQ = detail::BasicCQ<Q>;
  using MoebiusQ = detail::BasicMoebius<Q>;
  std::vector<int> letter, sign;
  std::vector<Word> element;
  std::vector<MoebiusQ> map;  ///< element[L] evaluated, updated by the same products move by move
  int moves = 0;
  bool words = true;  ///< false: a trial copy (light()) that keeps no words, only letters and maps

  /// A copy for trying moves: the letters, signs and maps, not the words, in double-double (a
  /// trial is only sized; the move chosen is then made again on the schema itself, in its own
  /// precision).
  Schema<detail::DoubleDouble> light() const {
    Schema<detail::DoubleDouble> t;
    t.letter = letter;
    t.sign = sign;
    for (const MoebiusQ& M : map) t.map.push_back(detail::to_dd(M));
    t.moves = moves;
    t.words = false;
    return t;
  }

  int size() const { return static_cast<int>(letter.size()); }
  int at(int j) const { return ((j % size()) + size()) % size(); }
  /// Each letter's +1 and −1 side (−1: none).
  struct Sides {
    std::vector<int> plus, minus;
  };
  Sides sides() const {
    Sides out{std::vector<int>(map.size(), -1), std::vector<int>(map.size(), -1)};
    for (int j = 0; j < size(); ++j) (sign[j] == 1 ? out.plus : out.minus)[letter[j]] = j;
    return out;
  }
  /// Position of letter L's side with sign s.
  int find(int L, int s) const {
    for (int j = 0; j < size(); ++j)
      if (letter[j] == L && sign[j] == s) return j;
    return -1;
  }
  /// Reverses letter L's orientation: its sides swap signs and its pairing is inverted.
  void flip(int L) {
    for (int j = 0; j < size(); ++j)
      if (letter[j] == L) sign[j] = -sign[j];
    if (words) element[L] = inverse(element[L]);
    map[L] = map[L].inverse();
  }

  /// Corner classes (the surface's vertices): the pairing of letter L sends the start of its +1
  /// side to the end of its −1 side, and the end of the +1 side to the start of the −1 side.
  std::vector<int> corner_classes(int* count) const {
    const int n = size();
    std::vector<int> parent(static_cast<std::size_t>(n));
    std::iota(parent.begin(), parent.end(), 0);
    auto root = [&](int x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    for (int p = 0; p < n; ++p) {
      if (sign[p] != 1) continue;
      const int q = find(letter[p], -1);
      parent[root(p)] = root(at(q + 1));
      parent[root(at(p + 1))] = root(q);
    }
    std::vector<int> label(static_cast<std::size_t>(n), -1), out(static_cast<std::size_t>(n));
    *count = 0;
    for (int j = 0; j < n; ++j) {
      const int r = root(j);
      if (label[r] < 0) label[r] = (*count)++;
      out[j] = label[r];
    }
    return out;
  }

  /// Removes an adjacent pair x x^-1 (the corner between them is a vertex of its own, fixed by x,
  /// whose angle is the whole 2π: x is the identity). False when there is none.
  bool cancel_once() {
    const int n = size();
    if (n <= 2) return false;
    for (int j = 0; j < n; ++j) {
      const int k = at(j + 1);
      if (letter[j] != letter[k]) continue;
      const int first = std::min(j, k), second = std::max(j, k);
      letter.erase(letter.begin() + second);
      sign.erase(sign.begin() + second);
      letter.erase(letter.begin() + first);
      sign.erase(sign.begin() + first);
      return true;
    }
    return false;
  }

  /// Per side, whether the cut from corner i to corner j moves it (cut_paste()): the piece with fewer
  /// sides moves, P2 (sides j … i−1) when it has at most half of them (*move_p2), else P1.
  std::vector<char> moved_sides(int i, int j, bool* move_p2) const {
    const int n = size();
    std::vector<char> in_p2(static_cast<std::size_t>(n), 0);
    int p2_sides = 0;
    for (int k = j; k != i; k = at(k + 1)) in_p2[k] = 1, ++p2_sides;
    *move_p2 = p2_sides <= n - p2_sides;
    if (!*move_p2)
      for (char& c : in_p2) c = c ? 0 : 1;
    return in_p2;
  }

  /// Cuts along the diagonal from corner i to corner j (P1: sides i … j−1 and the diagonal y,
  /// P2: sides j … i−1 and y^-1) and glues the two pieces back along letter x, whose sides lie in
  /// different pieces; returns the new letter y. The piece with fewer sides moves (so fewer
  /// pairings change): by g = X^-1 when x's +1 side stays, else X, which lays x's sides onto each
  /// other. A letter with a side in the moved piece follows: both sides moved g L g^-1, only its
  /// −1 side moved g L, only its +1 side moved L g^-1; y's pairing (its +1 side lies in P1) is g
  /// when P2 moves and g^-1 when P1 does.
  int cut_paste(int i, int j, int x) {
    bool move_p2 = false;
    const std::vector<char> moving = moved_sides(i, j, &move_p2);
    auto moved = [&](int k) { return moving[k] != 0; };
    const Sides at_side = sides();
    const int xp = at_side.plus[x], xm = at_side.minus[x];
    const bool plus_stays = !moved(xp);
    Word g, g_inv;
    if (words) {
      g = plus_stays ? inverse(element[x]) : element[x];
      g_inv = inverse(g);
    }
    const MoebiusQ G = plus_stays ? map[x].inverse() : map[x], G_inv = G.inverse();
    for (int L = 0; L < static_cast<int>(map.size()); ++L) {
      if (L == x) continue;
      const int p = at_side.plus[L], m = at_side.minus[L];
      if (p < 0 || m < 0) continue;  // cancelled or never used
      // A trial copy (light(): only sizes are read) keeps the products unnormalised: their
      // determinants stay 1 to quad's rounding, far below the sizes' tie (kSizeTie).
      auto set = [&](const MoebiusQ& M) { map[L] = words ? M.normalized() : M; };
      if (moved(p) && moved(m)) {
        if (words) element[L] = concat({&g, &element[L], &g_inv});
        set(G * map[L] * G_inv);
      } else if (!moved(p) && moved(m)) {
        if (words) element[L] = concat({&g, &element[L]});
        set(G * map[L]);
      } else if (moved(p) && !moved(m)) {
        if (words) element[L] = concat({&element[L], &g_inv});
        set(map[L] * G_inv);
      }
    }
    const int y = static_cast<int>(map.size());
    if (words) {
      element.push_back(move_p2 ? g : g_inv);
      element[x].clear();
    }
    map.push_back(move_p2 ? G : G_inv);
    map[x] = MoebiusQ();
    // The pieces as cyclic side lists (y: +1 in P1, −1 in P2), then the staying piece with x's
    // side replaced by the moved piece's sides after x's other side.
    std::vector<std::pair<int, int>> P1, P2;
    for (int k = i; k != j; k = at(k + 1)) P1.push_back({k, 0});
    P1.push_back({-1, 1});
    for (int k = j; k != i; k = at(k + 1)) P2.push_back({k, 0});
    P2.push_back({-1, -1});
    const std::vector<std::pair<int, int>>& stay = move_p2 ? P1 : P2;
    const std::vector<std::pair<int, int>>& move = move_p2 ? P2 : P1;
    const int in_stay = plus_stays ? xp : xm, in_move = plus_stays ? xm : xp;
    std::size_t at_move = 0;
    while (move[at_move].first != in_move) ++at_move;
    std::vector<int> nl, ns;
    auto put = [&](const std::pair<int, int>& e) {
      nl.push_back(e.first < 0 ? y : letter[e.first]);
      ns.push_back(e.first < 0 ? e.second : sign[e.first]);
    };
    for (const auto& e : stay) {
      if (e.first == in_stay) {
        for (std::size_t k = 1; k < move.size(); ++k) put(move[(at_move + k) % move.size()]);
      } else {
        put(e);
      }
    }
    letter = std::move(nl);
    sign = std::move(ns);
    ++moves;
    return y;
  }

  /// The size the schema would have after cut_paste(i, j, x), without the move: each
  /// letter's pairing as cut_paste() would make it, but only its b entry (the size reads |b|) and
  /// not normalised (the determinant stays 1 to quad's rounding).
  double size_after_cut_paste(int i, int j, int x) const {
    const int n = size();
    bool move_p2 = false;
    const std::vector<char> moving = moved_sides(i, j, &move_p2);
    auto moved = [&](int k) { return moving[k] != 0; };
    const Sides at_side = sides();
    const bool plus_stays = !moved(at_side.plus[x]);
    const MoebiusQ G = plus_stays ? map[x].inverse() : map[x];
    // b of M N = a_M b_N + b_M conj(a_N); of N G^-1 (G^-1 = (conj a_G, −b_G)) = b_N a_G − a_N b_G.
    auto b_times_inverse = [&](const MoebiusQ& N) { return N.b * G.a - N.a * G.b; };
    auto size_of = [](const CQ& b) { return size_of_b(b.norm()); };
    double sum = size_of(G.b);  // the new letter y: G or its inverse, of the same |b|
    for (int q = 0; q < n; ++q) {
      if (sign[q] != 1 || letter[q] == x) continue;
      const int L = letter[q], m = at_side.minus[L];
      const MoebiusQ& M = map[L];
      if (m < 0) sum += size_of(M.b);  // no −1 side: cut_paste() leaves its pairing
      else if (moved(q) && moved(m)) sum += size_of(b_times_inverse(G * M));
      else if (!moved(q) && moved(m)) sum += size_of(G.a * M.b + G.b * M.a.conj());
      else if (moved(q) && !moved(m)) sum += size_of(b_times_inverse(M));
      else sum += size_of(M.b);
    }
    return sum;
  }

  /// Letters of the blocks u v u^-1 v^-1 found by a greedy scan from every rotation (the largest
  /// count), with the rotation that starts at one. Without in_block and start, only the count:
  /// then only the scans from a block's start are made (a scan from elsewhere first skips to the
  /// next block start and then sees what the scan from there sees, or less).
  int commutator_blocks(std::vector<char>* in_block, int* start) const {
    const int n = size();
    const bool count_only = in_block == nullptr;
    // Where a block u v u^-1 v^-1 starts (cyclically), found once; each rotation's scan reads it.
    std::vector<char> block_at(static_cast<std::size_t>(n), 0);
    for (int q = 0; q < n && n >= 4; ++q) {
      const int a = q, b = at(q + 1), c = at(q + 2), d = at(q + 3);
      block_at[q] = letter[a] == letter[c] && letter[b] == letter[d] && letter[a] != letter[b] &&
                    sign[a] == -sign[c] && sign[b] == -sign[d];
    }
    int best = -1;
    for (int r = 0; r < n; ++r) {
      if (count_only && !block_at[r] && best >= 0) continue;
      int count = 0;
      for (int k = 0; k + 4 <= n;) {
        if (block_at[at(r + k)]) {
          ++count;
          k += 4;
        } else {
          ++k;
        }
      }
      if (count > best) {
        best = count;
        if (start) *start = r;
      }
    }
    if (count_only) return best;
    // The marks of the best rotation's scan.
    in_block->assign(static_cast<std::size_t>(n), 0);
    for (int k = 0; k + 4 <= n && best > 0;) {
      const int q = at(*start + k);
      if (block_at[q]) {
        for (int i = 0; i < 4; ++i) (*in_block)[at(q + i)] = 1;
        k += 4;
      } else {
        ++k;
      }
    }
    return best;
  }
};

// A schema's size (Schema::size_after_cut_paste()) is the sum over its letters of how far each
// pairing moves the frame's origin (2 asinh |b|). The compact domain is laid out around that
// origin, so short canonical loops are those that move it little; the greedy choice among moves
// keeps this sum small, which keeps the generators' axes near the domain and their products
// resolvable.

/// Relative difference below which two move sizes count as equal (BestMove).
constexpr double kSizeTie = 1e-9;

/// Entries up to which generators are handled in double-double (centre_polygon(),
/// reduce_generators()): products of up to nine of them and their squared norms stay in double's
/// range.
constexpr double kDoubleDoubleEntries = 1e15;
/// Entries beyond which a word's product, a generator or a polygon's generators are taken as
/// beyond every arithmetic here (quad-double has double's range; double reports them): far past
/// any polygon quad-double verifies (entries e^(r/2) at distance r).
constexpr double kMaxEntries = 1e30;

/// The smallest of the moves offered; sizes within kSizeTie of the best count as equal and the
/// first offered of them is kept. A symmetric surface offers many moves of one size, whose
/// computed sizes differ only by the rounding of the fitted pairings: without the tie the greedy
/// choice, and with it the words and the polygon's reach, would turn on those last bits
/// (fertility.off: perimeter 109.4 or 134.0 depending on the flow's factorization).
struct BestMove {
  int first = -1, second = -1;  ///< the move, as its caller names it
  double size = 0;
  bool found = false;
  void offer(int a, int b, double t_size) {
    if (found && !(t_size < size - kSizeTie * std::abs(size))) return;
    first = a;
    second = b;
    size = t_size;
    found = true;
  }
};

/// One vertex class: a corner of the smallest other class is removed by cutting off the triangle
/// of its two sides b (ending there) and a (leaving it towards another class) and regluing it
/// along b's partner; that merges it with the corner at b's partner. Among the candidate corners
/// the move leaving the shortest words is taken (its size by Schema::size_after_cut_paste(), without
/// making the move). False when no move applies.
bool reduce_classes(Schema<quad>& s) {
  int count = 0;
  std::vector<int> cls = s.corner_classes(&count);
  if (count <= 1) return true;
  std::vector<int> size(static_cast<std::size_t>(count), 0);
  for (int c : cls) ++size[c];
  const int smallest = static_cast<int>(std::min_element(size.begin(), size.end()) - size.begin());
  const int n = s.size();
  BestMove best;
  for (int k = 0; k < n; ++k) {
    if (cls[k] != smallest || cls[s.at(k + 1)] == smallest) continue;
    best.offer(k, -1, s.size_after_cut_paste(s.at(k - 1), s.at(k + 1), s.letter[s.at(k - 1)]));
  }
  if (!best.found) return false;
  const int k = best.first;
  s.cut_paste(s.at(k - 1), s.at(k + 1), s.letter[s.at(k - 1)]);
  return true;
}

/// The same surface's polygon with one vertex class, its sides the dual loops of the domain's
/// shorter pairings, so that no cut-and-paste move is needed to join the corners (each such move
/// multiplies pairings, and a domain with dozens of classes needs ~100 of them: at genus 12 the
/// generators they leave move the domain's centre by up to 70, beyond what 113 bits resolve).
/// Letter L (pairing M_L: its +1 side P onto its −1 side Q) has a dual loop at an interior point
/// p: out through Q into M_L(D), back in through P — the element M_L. The loops meet only at p,
/// in the order of their sides around D. All of them cut the surface into one disk per vertex
/// class, and L separates the classes at the ends of P; so dropping the loops of a spanning tree
/// of that class graph leaves 2g loops whose complement is one disk P', the one-vertex polygon.
/// Its perimeter is twice the kept loops' displacements at p: the tree dropped is the one of the
/// longest pairings (Kruskal, longest first, ties by letter). P' is read by tracing its one face
/// (arrive at p along one end of a loop, leave along the end before it counter-clockwise); its
/// corners are lifts γ_k p with γ_{k+1} = γ_k M_L^±1, and letter L's pairing maps the side
/// crossed forwards (+1, from corner f) onto the one crossed backwards (−1, from corner b):
/// γ_b M_L^-1 γ_f^-1. False, with s unchanged, when s has one class already, or when the trace
/// is not one face of 2·(kept letters) sides or does not close (γ_n the relation: the identity to
/// the rounding of the products, far below kClosure; a wrong reading would miss by O(1)).
bool one_vertex_schema(Schema<quad>& s) {
  constexpr double kClosure = 1e-9;
  const int n = s.size();
  int classes = 0;
  const std::vector<int> cls = s.corner_classes(&classes);
  if (classes <= 1) return false;
  const Schema<quad>::Sides sd = s.sides();
  const int letters = static_cast<int>(s.map.size());
  std::vector<int> order;
  for (int L = 0; L < letters; ++L)
    if (sd.plus[L] >= 0 && sd.minus[L] >= 0) order.push_back(L);
  std::vector<double> length(static_cast<std::size_t>(letters), 0);
  for (int L : order) length[L] = size_of_b(s.map[L].b.norm());
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return length[x] > length[y]; });
  std::vector<int> parent(static_cast<std::size_t>(classes));
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::vector<char> kept(static_cast<std::size_t>(letters), 0);
  for (int L : order) {
    const int P = sd.plus[L], u = root(cls[P]), v = root(cls[s.at(P + 1)]);
    if (u != v) parent[u] = v;  // a tree letter: its loop is dropped
    else kept[L] = 1;
  }
  // The kept loops' ends around p, in the order of their sides; before[j]: the kept end before j.
  std::vector<int> ends;
  for (int j = 0; j < n; ++j)
    if (kept[s.letter[j]]) ends.push_back(j);
  const int m = static_cast<int>(ends.size());
  if (m < 4) return false;
  std::vector<int> before(static_cast<std::size_t>(n), -1);
  for (int k = 0; k < m; ++k) before[ends[(k + 1) % m]] = ends[k];
  // The face: leave along the end at side j, forwards when j is the −1 side (back in through the
  // +1 side), and leave again along the end before the one arrived at.
  std::vector<int> side_letter;
  std::vector<char> forward;
  for (int j = ends[0];;) {
    if (static_cast<int>(side_letter.size()) == m) return false;  // a face longer than all ends
    const int L = s.letter[j];
    side_letter.push_back(L);
    forward.push_back(s.sign[j] == -1);
    j = before[forward.back() ? sd.plus[L] : sd.minus[L]];
    if (j == ends[0]) break;
  }
  if (static_cast<int>(side_letter.size()) != m) return false;  // more than one face: not a disk
  // Corner 0 moved to the corner nearest all others (the least largest distance), so that the
  // products below stay as short as P' allows: a product of maps moving points by d1 and d2
  // keeps about e^-(d1 + d2)/2 of quad's digits.
  {
    std::vector<MoebiusQ> corner(1);
    for (int k = 0; k + 1 < m; ++k)
      corner.push_back((corner.back() * (forward[k] ? s.map[side_letter[k]] : s.map[side_letter[k]].inverse())).normalized());
    int centre = 0;
    double least = INFINITY;
    for (int c = 0; c < m; ++c) {
      const MoebiusQ back = corner[c].inverse();
      double reach = 0;
      for (int k = 0; k < m && reach < least; ++k) reach = std::max(reach, size_of_b((back * corner[k]).b.norm()));
      if (reach < least) least = reach, centre = c;
    }
    std::rotate(side_letter.begin(), side_letter.begin() + centre, side_letter.end());
    std::rotate(forward.begin(), forward.begin() + centre, forward.end());
  }
  std::vector<MoebiusQ> gamma(1);
  std::vector<Word> gamma_word(1);
  std::vector<int> at_forward(static_cast<std::size_t>(letters), -1), at_backward(static_cast<std::size_t>(letters), -1);
  for (int k = 0; k < m; ++k) {
    const int L = side_letter[k];
    (forward[k] ? at_forward : at_backward)[L] = k;
    gamma.push_back((gamma.back() * (forward[k] ? s.map[L] : s.map[L].inverse())).normalized());
    if (s.words) {
      const Word step = forward[k] ? s.element[L] : inverse(s.element[L]);
      gamma_word.push_back(concat({&gamma_word.back(), &step}));
    }
  }
  if (!(gamma.back().distance_to_identity() < kClosure)) return false;
  Schema<quad> t;
  t.words = s.words;
  t.moves = s.moves;
  std::vector<int> renamed(static_cast<std::size_t>(letters), -1);
  for (int k = 0; k < m; ++k) {
    const int L = side_letter[k];
    if (renamed[L] < 0) {
      const int f = at_forward[L], b = at_backward[L];
      if (f < 0 || b < 0) return false;  // a loop crossed twice the same way: not orientable
      renamed[L] = static_cast<int>(t.map.size());
      t.map.push_back((gamma[b] * s.map[L].inverse() * gamma[f].inverse()).normalized());
      if (s.words) {
        const Word inv_l = inverse(s.element[L]), inv_f = inverse(gamma_word[f]);
        t.element.push_back(concat({&gamma_word[b], &inv_l, &inv_f}));
      }
    }
    t.letter.push_back(renamed[L]);
    t.sign.push_back(forward[k] ? 1 : -1);
  }
  int one = 0;
  t.corner_classes(&one);
  if (one != 1) return false;
  s = std::move(t);
  return true;
}

/// One more commutator block: for a linked pair a … b … a^-1 … b^-1 of letters outside the
/// blocks (signs made so by flipping letters), cut from the corner before a to the corner after
/// a^-1 and reglue along b, giving a X U c^-1 Z Y a^-1 c; then cut from the corner after a^-1 to
/// the corner after c^-1 and reglue along a, giving the block c^-1 e c e^-1. Among linked pairs
/// the one leaving the shortest words is taken: each tried on a light() copy, its first move made
/// and its second only sized (Schema::size_after_cut_paste()); the one chosen is made on s. The
/// existing blocks stay whole (the cuts run from corners of letters outside them, and each piece
/// is reglued at such a letter), and in a word where every letter appears twice two windows
/// u v u^-1 v^-1 either coincide or are disjoint, so every pair adds a block; checked on the
/// move made. False when no pair applies or the move added none.
bool add_commutator(Schema<quad>& s) {
  std::vector<char> in_block;
  int start = 0;
  const int blocks = s.commutator_blocks(&in_block, &start);
  const int n = s.size();
  BestMove best;
  const Schema<DD> trial_base = s.light();  // rounded once; each trial copies it
  // Each side's partner (the other side of its letter).
  std::vector<int> other(static_cast<std::size_t>(n), -1), first_side(s.map.size(), -1);
  for (int j = 0; j < n; ++j) {
    int& f = first_side[static_cast<std::size_t>(s.letter[j])];
    if (f < 0) f = j;
    else other[f] = j, other[j] = f;
  }
  // The first move for the pair (ta, tb) on a schema t (a light() trial, or s itself once chosen):
  // the letters a, b flipped to signs +1 and the cut along b; returns a's new letter c.
  auto first_move = [&](auto& t, int ta, int tb) {
    if (t.sign[ta] != 1) t.flip(t.letter[ta]);
    if (t.sign[tb] != 1) t.flip(t.letter[tb]);
    return t.cut_paste(ta, t.at(other[ta] + 1), t.letter[tb]);
  };
  for (int ta = 0; ta < n; ++ta) {
    if (in_block[ta] || other[ta] < 0) continue;
    const int La = s.letter[ta];
    const int span = (other[ta] - ta + n) % n;
    for (int k = 1; k < span; ++k) {
      const int tb = s.at(ta + k);
      if (in_block[tb] || other[tb] < 0) continue;
      if ((other[tb] - ta + n) % n <= span) continue;  // not linked
      Schema<DD> t = trial_base;
      const int c = first_move(t, ta, tb);
      const int qa = t.find(La, -1), qc = t.find(c, -1);
      if (qa < 0 || qc < 0) continue;
      best.offer(ta, tb, t.size_after_cut_paste(t.at(qa + 1), t.at(qc + 1), La));
    }
  }
  if (!best.found) return false;
  const int La = s.letter[best.first];
  const int c = first_move(s, best.first, best.second);
  const int qa = s.find(La, -1), qc = s.find(c, -1);
  if (qa < 0 || qc < 0) return false;
  s.cut_paste(s.at(qa + 1), s.at(qc + 1), La);
  return s.commutator_blocks(nullptr, nullptr) > blocks;
}

template <class Q>
detail::BasicMoebius<Q> displacement_frame(const std::vector<detail::BasicMoebius<Q>>& Y, int max_steps, int* steps);
int reduce_generators(std::vector<detail::MoebiusQ>& gens, std::vector<Word>& words, detail::MoebiusQ& C);




/// A generator from a map in quad or quad-double (detail::set_map()).
template <class Q>
DeckGenerator generator_from(const detail::BasicMoebius<Q>& M, const std::string& name) {
  DeckGenerator G;
  G.name = name;
  G.geometry = Geometry::Hyperbolic;
  detail::set_map(G, M);
  return G;
}


std::string word_text(const Word& w, const std::vector<std::string>& names) {
  std::string out;
  for (int x : w) {
    if (!out.empty()) out += ' ';
    out += names[static_cast<std::size_t>(std::abs(x) - 1)];
    if (x < 0) out += "^-1";
  }
  return out.empty() ? std::string("1") : out;
}

}  // namespace

namespace {

/// One run of the normal form from the domain's schema: the generators a1 b1 … in the pairings'
/// frame and their words, or a status. `recentre`: keep the working frame at the point where the
/// pairings move least (sizes then compare shapes, not where the moved pieces drifted); without
/// it sizes are taken at the origin of the pairings' frame, the domain's centre.
struct NormalForm {
  Status status = Status::NotRun;
  std::string message;
  std::vector<MoebiusQ> gens;  ///< in the pairings' frame
  std::vector<MoebiusQ> work;  ///< the same in the working frame: C gens C^-1
  MoebiusQ frame;              ///< C: the pairings' frame → the working frame
  std::vector<Word> words;
  int moves = 0, handle_moves = 0;
};

/// `one_vertex`: start from one_vertex_schema() (NotRun when it does not apply) rather than
/// joining the domain's corner classes by moves; `reduce`: end with reduce_generators().
NormalForm normal_form(Schema<quad> s, Index genus, bool recentre_moves, bool one_vertex, bool reduce) {
  NormalForm nf;
  if (one_vertex && !one_vertex_schema(s)) return nf;
  auto bad = [&](Status st, const std::string& m) {
    nf.status = st;
    nf.message = "canonical generators: " + m;
    return nf;
  };
  MoebiusQ C;  // pairings' frame → working frame
  auto recentre = [&] {
    if (!recentre_moves) return true;
    // The letters in the word (their maps are the only ones read again), conjugated once.
    std::vector<int> letters;
    std::vector<MoebiusQ> alive;
    for (int j = 0; j < s.size(); ++j)
      if (s.sign[j] == 1) {
        letters.push_back(s.letter[j]);
        alive.push_back(s.map[s.letter[j]]);
      }
    int steps = 0;
    const MoebiusQ T = displacement_frame(alive, 8, &steps);
    if (steps < 0) return false;
    if (steps == 0) return true;
    const MoebiusQ T_inv = T.inverse();
    for (const int L : letters) s.map[L] = (T * s.map[L] * T_inv).normalized();
    C = (T * C).normalized();
    return true;
  };
  // The classification proof on the word: cancel x x^-1, one vertex class, then commutators.
  const int limit = 16 * (s.size() + 4);
  for (int guard = 0;; ++guard) {
    if (guard > limit) return bad(Status::NumericalFailure, "the word did not reach its normal form.");
    if (s.cancel_once()) continue;
    if (!recentre()) return bad(Status::NumericalFailure, "a pairing is not finite.");
    int count = 0;
    s.corner_classes(&count);
    if (count > 1) {
      if (!reduce_classes(s)) return bad(Status::NumericalFailure, "no move joins the polygon's corners.");
      continue;
    }
    std::vector<char> mark;
    int start = 0;
    if (4 * s.commutator_blocks(&mark, &start) == s.size()) {
      std::rotate(s.letter.begin(), s.letter.begin() + start, s.letter.end());
      std::rotate(s.sign.begin(), s.sign.begin() + start, s.sign.end());
      break;
    }
    if (!add_commutator(s)) return bad(Status::NumericalFailure, "no linked pair of letters makes progress.");
  }
  if (s.size() != 4 * static_cast<int>(genus))
    return bad(Status::NumericalFailure, "the normal form has " + std::to_string(s.size()) + " sides, not 4g = " +
                                             std::to_string(4 * genus) + ".");
  // Each block a b a^-1 b^-1 (letters flipped to those signs) gives a_i, b_i; handles reduced in
  // the working frame, then back in the pairings' frame.
  std::vector<MoebiusQ> work;
  for (Index i = 0; i < genus; ++i) {
    const int a = s.letter[static_cast<std::size_t>(4 * i)], b = s.letter[static_cast<std::size_t>(4 * i + 1)];
    if (s.sign[static_cast<std::size_t>(4 * i)] != 1) s.flip(a);
    if (s.sign[static_cast<std::size_t>(4 * i + 1)] != 1) s.flip(b);
    for (const int L : {a, b}) {
      work.push_back(s.map[static_cast<std::size_t>(L)]);
      nf.words.push_back(s.element[static_cast<std::size_t>(L)]);
    }
  }
  if (reduce) nf.handle_moves = reduce_generators(work, nf.words, C);
  for (const MoebiusQ& M : work) nf.gens.push_back((C.inverse() * M * C).normalized());
  nf.work = std::move(work);
  nf.frame = C;
  nf.moves = s.moves;
  nf.status = Status::Ok;
  return nf;
}

}  // namespace

namespace {

/// Generators a1 b1 … of genus g as a DeckResult (names, maps; nothing else set).
template <class Q>
DeckResult trial_deck(Index g, const std::vector<detail::BasicMoebius<Q>>& gens) {
  DeckResult d;
  d.geometry = Geometry::Hyperbolic;
  d.genus = g;
  for (std::size_t j = 0; j < gens.size(); ++j)
    d.generators.push_back(generator_from(gens[j], std::string(j % 2 == 0 ? "a" : "b") + std::to_string(j / 2 + 1)));
  return d;
}

template <class Q>
GeodesicPolygon polygon_from(std::vector<detail::BasicMoebius<Q>> gens, const detail::BasicMoebius<Q>& prior,
                             const DeckResult& canonical);

/// The normal form of the schema's word with the shortest geodesic polygon, or none (last_error
/// then says why the last run failed). Runs in two rounds, each two runs in parallel with sizes
/// at the domain's centre or where the pairings move least (the moves are greedy, so either can
/// end with longer generators). First from the one-vertex polygon of the short pairings' loops
/// (one_vertex_schema()); only when neither gives a fundamental polygon nor a simple one at
/// quad's floor (GeodesicPolygon::at_quad_floor; or the domain has one corner class already),
/// then with the corners joined by moves, whose products grow with the domain's corner classes
/// (a genus-12 grid of holes, 42 classes: 0.1 s and generators beyond 113 bits; the one-vertex
/// runs 0.02 s). The run whose geodesic polygon is a fundamental domain with the smallest
/// perimeter is kept (else the smallest relation error; ties: the earlier run).
std::optional<NormalForm> best_normal_form(const Schema<quad>& s, Index g,
                                                         std::string& last_error) {
  std::optional<NormalForm> best;
  double best_score = 0, best_relation = 0;
  struct Run {
    NormalForm nf;
    double relation = 0, score = 0;
    bool at_floor = false;  ///< its polygon is simple and misses 1e-12 only by quad's floor
  };
  for (const bool one_vertex : {true, false}) {
    Run runs[2];
    int out_of_memory = 0;  // nothing may leave the parallel region: rethrown after it
#pragma omp parallel for schedule(static, 1) reduction(max : out_of_memory)
    for (int k = 0; k < 2; ++k) try {
      Run& run = runs[k];
      // The substitutions shorten the perimeter but do not keep the polygon simple: when the
      // reduced polygon is not a fundamental domain, the same run without them.
      for (const bool reduce : {true, false}) {
        run.nf = normal_form(s, g, k == 1, one_vertex, reduce);
        if (run.nf.status != Status::Ok) break;
        const GeodesicPolygon gp = polygon_from(run.nf.work, run.nf.frame, trial_deck(g, run.nf.work));
        run.relation =
            gp.status == Status::Ok ? gp.deck.relation_error : detail::canonical_relator(run.nf.work).distance_to_identity();
        // A polygon at quad's floor is scored as a fundamental one: the pipeline evaluates its words
        // again in quad-double (evaluate_canonical_words()), where the shortest verifies best.
        const bool fundamental =
            gp.status == Status::Ok && gp.fundamental && (run.relation <= 1e-12 || gp.at_quad_floor);
        run.score = fundamental ? gp.perimeter : std::numeric_limits<double>::infinity();
        run.at_floor = gp.status == Status::Ok && gp.at_quad_floor;
        if (fundamental || run.nf.handle_moves == 0) break;
      }
    } catch (const std::bad_alloc&) {
      out_of_memory = 1;
    }
    if (out_of_memory) throw std::bad_alloc();
    bool floor_reached = false;
    for (Run& run : runs) {
      floor_reached = floor_reached || (run.nf.status == Status::Ok && run.at_floor);
      if (run.nf.status == Status::NotRun) continue;
      if (run.nf.status != Status::Ok) {
        last_error = run.nf.message;
        continue;
      }
      const double score = run.score, relation = run.relation;
      // A later run is kept only when shorter beyond the rounding of the lengths (kSizeTie).
      if (!best || score < best_score * (1 - kSizeTie) ||
          (!std::isfinite(score) && !std::isfinite(best_score) && relation < best_relation)) {
        best = std::move(run.nf);
        best_score = score;
        best_relation = relation;
      }
    }
    // A simple polygon at quad's floor: the corners joined by moves multiply more pairings, and
    // their polygon would have to reach less far to be verified.
    if (best && (std::isfinite(best_score) || floor_reached)) break;
  }
  return best;
}

}  // namespace

namespace {

/// The product of a word's letters (signed 1-based indices into P), or none when an entry passes
/// kMaxEntries on the way (beyond what the arithmetic and the reported doubles carry).
template <class Q>
std::optional<detail::BasicMoebius<Q>> word_product(const std::vector<detail::BasicMoebius<Q>>& P, const Word& w) {
  detail::BasicMoebius<Q> M;
  for (int x : w) {
    M = M * (x > 0 ? P[static_cast<std::size_t>(x - 1)] : P[static_cast<std::size_t>(-x - 1)].inverse());
    if (!detail::entries_below(M, kMaxEntries)) return std::nullopt;
  }
  return M;
}

/// canonical_generators()' failure for generators beyond every arithmetic here.
CanonicalGenerators& beyond(CanonicalGenerators& out) {
  out.beyond_quad = true;
  out.status = out.deck.status = Status::NumericalFailure;
  out.message = out.deck.message = "canonical generators: the relation is not finite.";
  out.deck.generators.clear();
  return out;
}

/// The rest of canonical_generators() (and evaluate_canonical_words()) once the words are known:
/// out's deck (the generators in the pairings' frame), words, working generators (C G C^-1) and
/// relations. `gens`, `work`: the search's own quad products of the words, when they stand;
/// otherwise (null) the words are evaluated in side_maps, in quad-double when every one carries it.
CanonicalGenerators generators_of_words(CanonicalGenerators& out, Index g, std::span<const DeckGenerator> side_maps,
                                        std::span<const DeckGenerator> fitted_maps, const std::vector<Word>& words,
                                        const MoebiusQ& C, const std::vector<MoebiusQ>* gens,
                                        const std::vector<MoebiusQ>* work,
                                        std::chrono::steady_clock::time_point t_start) {
  out.word_letters = words;
  DeckResult& r = out.deck;
  r.geometry = Geometry::Hyperbolic;
  r.genus = g;
  double pairing_residual = 0;
  for (const DeckGenerator& d : side_maps) pairing_residual = std::max(pairing_residual, d.residual_max);
  // Without the search's products: the words evaluated in the pairings (in quad-double when every
  // one carries it), in the pairings' and the working frame.
  const bool wide = gens == nullptr && std::all_of(side_maps.begin(), side_maps.end(), [](const DeckGenerator& d) {
                      return detail::has_wide_map(d);
                    });
  std::vector<detail::MoebiusW> wide_gens, wide_work;
  std::vector<MoebiusQ> quad_gens, quad_work;
  if (gens == nullptr) {
    std::vector<detail::MoebiusW> PW;
    std::vector<MoebiusQ> PQ;
    for (const DeckGenerator& d : side_maps) {
      if (wide) PW.push_back(detail::wide_map(d));
      else PQ.push_back(quad_map(d));
    }
    const detail::MoebiusW CW = detail::to_wide(C), CW_inv = CW.inverse();
    for (const Word& w : words) {
      if (wide) {
        const std::optional<detail::MoebiusW> M = word_product(PW, w);
        if (!M) return beyond(out);
        wide_gens.push_back(M->normalized());
        wide_work.push_back((CW * *M * CW_inv).normalized());
      } else {
        const std::optional<MoebiusQ> M = word_product(PQ, w);
        if (!M) return beyond(out);
        quad_gens.push_back(M->normalized());
        quad_work.push_back((C * *M * C.inverse()).normalized());
      }
    }
    gens = &quad_gens;
    work = &quad_work;
  }
  if (!detail::entries_below(*gens, kMaxEntries) || !detail::entries_below(*work, kMaxEntries) ||
      !detail::entries_below(wide_gens, kMaxEntries) || !detail::entries_below(wide_work, kMaxEntries))
    return beyond(out);
  std::vector<std::string> names;
  for (const DeckGenerator& d : side_maps) names.push_back(d.name);
  for (std::size_t k = 0; k < words.size(); ++k) {
    const std::string name = std::string(k % 2 == 0 ? "a" : "b") + std::to_string(k / 2 + 1);
    r.generators.push_back(wide ? generator_from(wide_gens[k], name) : generator_from((*gens)[k], name));
    r.generators.back().residual_max = pairing_residual;
    out.words.push_back(word_text(words[k], names));
    out.word_lengths.push_back(static_cast<Index>(words[k].size()));
  }
  r.residual_max = pairing_residual;
  r.relator = wide ? detail::canonical_relator(wide_gens).to_double() : detail::canonical_relator(*gens).to_double();
  // At the working frame's origin, where the generators move points least (geodesic_polygon()
  // measures it again at its corner 0); the fitted pairings' words conjugated there too.
  r.relation_error = wide ? detail::canonical_relator(wide_work).distance_to_identity()
                          : detail::canonical_relator(*work).distance_to_identity();
  out.fitted_relation_error = r.relation_error;
  if (!fitted_maps.empty()) {
    std::vector<MoebiusQ> F, fg;
    for (const DeckGenerator& d : fitted_maps) F.push_back(quad_map(d));
    for (const Word& w : words) {
      const std::optional<MoebiusQ> M = word_product(F, w);
      if (!M) break;
      fg.push_back((C * *M * C.inverse()).normalized());
    }
    out.fitted_relation_error = fg.size() == words.size() && detail::entries_below(fg, kMaxEntries)
                                    ? detail::canonical_relator(fg).distance_to_identity()
                                    : std::numeric_limits<double>::infinity();
  }
  out.working = wide ? trial_deck(g, wide_work) : trial_deck(g, *work);
  for (DeckGenerator& G : out.working.generators) G.residual_max = pairing_residual;
  out.working.residual_max = pairing_residual;
  out.working.relation_error = r.relation_error;
  out.working_frame = generator_from(C, "frame");
  if (!std::isfinite(r.relation_error) || !std::isfinite(out.fitted_relation_error)) return beyond(out);
  r.status = Status::Ok;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  char buf[240];
  std::snprintf(buf, sizeof buf,
                "%d canonical generators from %d side pairings (%d cut-and-paste moves on the word, %d handle "
                "substitutions); relation error %.3g",
                static_cast<int>(2 * g), static_cast<int>(side_maps.size()), static_cast<int>(out.moves),
                static_cast<int>(out.handle_moves), r.relation_error);
  r.message = buf;
  out.status = Status::Ok;
  out.message = buf;
  return out;
}

}  // namespace


CanonicalGenerators canonical_generators(const CutResult& domain, std::span<const DeckGenerator> side_maps,
                                         std::span<const DeckGenerator> fitted_maps) {
  const auto t_start = std::chrono::steady_clock::now();
  CanonicalGenerators out;
  auto bad = [&](Status st, const std::string& m) {
    out.status = st;
    out.message = m;
    out.deck.status = st;
    out.deck.message = m;
    out.deck.generators.clear();
    return out;
  };
  if (domain.status != Status::Ok || domain.boundary_loops != 0 || domain.genus < 2)
    return bad(Status::InvalidArgument, "canonical generators need a cut of a closed surface of genus >= 2.");
  const Index letters = domain.num_generators();
  if (static_cast<Index>(side_maps.size()) != letters ||
      (!fitted_maps.empty() && static_cast<Index>(fitted_maps.size()) != letters))
    return bad(Status::InvalidArgument, "canonical generators: expected one side pairing per generator of the cut.");
  Schema<quad> s;
  for (Index L = 0; L < letters; ++L) {
    s.element.push_back({static_cast<int>(L) + 1});
    s.map.push_back(quad_map(side_maps[static_cast<std::size_t>(L)]));
    if (!std::isfinite(static_cast<double>(s.map.back().a.norm() + s.map.back().b.norm())))
      return bad(Status::InvalidArgument, "canonical generators: side pairing " + side_maps[static_cast<std::size_t>(L)].name + " is not finite.");
  }
  std::vector<int> seen(static_cast<std::size_t>(letters), 0);
  for (Index j = 0; j < domain.num_sides(); ++j) {
    const Index L = domain.side_generator[j];
    const int o = domain.side_orientation[j];
    if (domain.side_kind[j] == SideKind::Boundary || L < 0 || L >= letters || (o != 1 && o != -1))
      return bad(Status::InvalidArgument, "canonical generators: side " + std::to_string(j) + " is not paired.");
    seen[static_cast<std::size_t>(L)] += o == 1 ? 1 : 16;
    s.letter.push_back(static_cast<int>(L));
    s.sign.push_back(o);
  }
  for (Index L = 0; L < letters; ++L)
    if (seen[static_cast<std::size_t>(L)] != 17)
      return bad(Status::InvalidArgument, "canonical generators: letter " + std::to_string(L) +
                                              " does not label exactly one side and its inverse.");

  const Index g = domain.genus;
  std::string last_error;
  std::optional<NormalForm> best = best_normal_form(s, g, last_error);
  if (!best) return bad(Status::NumericalFailure, last_error);

  out.moves = best->moves;
  out.handle_moves = best->handle_moves;
  // Pairings given in quad-double (DeckOptions::wide_pairings): the words the search chose (in
  // quad) are evaluated again from them there; otherwise the search's own quad products stand.
  const bool wide = std::all_of(side_maps.begin(), side_maps.end(), [](const DeckGenerator& d) { return detail::has_wide_map(d); });
  return generators_of_words(out, g, side_maps, fitted_maps, best->words, best->frame, wide ? nullptr : &best->gens,
                             wide ? nullptr : &best->work, t_start);
}

CanonicalGenerators evaluate_canonical_words(const CanonicalGenerators& found, std::span<const DeckGenerator> side_maps,
                                             std::span<const DeckGenerator> fitted_maps) {
  const auto t_start = std::chrono::steady_clock::now();
  CanonicalGenerators out;
  const std::size_t n2 = found.word_letters.size();
  bool valid = (found.status == Status::Ok || found.beyond_quad) && n2 >= 4 && n2 % 2 == 0 &&
               (fitted_maps.empty() || fitted_maps.size() == side_maps.size());
  for (const std::vector<int>& w : found.word_letters)
    for (int x : w) valid = valid && x != 0 && static_cast<std::size_t>(std::abs(x)) <= side_maps.size();
  if (!valid) {
    out.status = out.deck.status = Status::InvalidArgument;
    out.message = out.deck.message = "canonical words: expected found canonical generators whose words name the given side pairings.";
    return out;
  }
  out.moves = found.moves;
  out.handle_moves = found.handle_moves;
  return generators_of_words(out, static_cast<Index>(n2 / 2), side_maps, fitted_maps, found.word_letters,
                             quad_map(found.working_frame).normalized(), nullptr, nullptr, t_start);
}

namespace {

/// Perimeter of the polygon with corner 0 at p (|p| < 1), for the side elements Y_k (side k runs
/// from W_k p to W_k Y_k p, so its length is the displacement of Y_k at p): d(p, Y p) = 2 asinh|β|
/// with β = (b + (a − ā) p − b̄ p²)/(1 − |p|²), the b entry of Y in the frame moved to p
/// (displacement_derivatives()); in T, double-double or quad (β cancels when Y nearly fixes p), ∞
/// outside the disk.
/// (1 − |p|²) times the b entry of M in the frame moved to p (z ↦ (z − p)/(1 − p̄ z)):
/// b + (a − ā) p − b̄ p², with p2 = p².
template <class T>
detail::BasicCQ<T> moved_b_scaled(const detail::BasicMoebius<T>& M, detail::BasicCQ<T> p, detail::BasicCQ<T> p2) {
  return M.b + (M.a - M.a.conj()) * p - M.b.conj() * p2;
}

template <class T>
double perimeter_at(const std::vector<detail::BasicMoebius<T>>& Y, detail::BasicCQ<T> p) {
  const T inside = T(1) - p.norm();
  if (!(inside > 0)) return INFINITY;
  const detail::BasicCQ<T> p2 = p * p;
  double sum = 0;
  for (const detail::BasicMoebius<T>& M : Y) {
    const T u = moved_b_scaled(M, p, p2).norm() / (inside * inside);
    if (detail::qisnan(u) || !(u < T(1e300))) return INFINITY;  // beyond double's range
    sum += 2 * std::asinh(std::sqrt(static_cast<double>(u)));
  }
  return sum;
}

/// The gradient and Hessian (hxx, hyy, hxy) of D(p) = Σ_k d(p, Y_k p) at the frame's origin, in
/// closed form. Moving the frame to p (z ↦ (z − p)/(1 − p̄ z)) turns Y = [[a, b], [b̄, ā]] into a
/// map whose b is β(p) = (b + (a − ā) p − b̄ p²)/(1 − |p|²), and d(p, Y p) = 2 asinh|β(p)|. To
/// second order in p, |β|² = |b|² + 2 Re(b̄ c p) + (|c|² + 2|b|²)|p|² − 2 Re(b̄² p²) with
/// c = a − ā, and each term is g(|β|²) with g(u) = 2 asinh √u. The entries are rounded to double
/// (the terms are of the size of the entries: no cancellation). False when an element nearly
/// fixes the origin (|b|² tiny: a side element is hyperbolic and moves every point).
template <class T>
bool displacement_derivatives(const std::vector<detail::BasicMoebius<T>>& Y, double& gx, double& gy, double& hxx,
                              double& hyy, double& hxy) {
  gx = gy = hxx = hyy = hxy = 0;
  for (const detail::BasicMoebius<T>& M : Y) {
    // Entries up to 1e150, so that no product below leaves double's range.
    const T aa = M.a.norm(), bb = M.b.norm();
    if (detail::qisnan(aa) || detail::qisnan(bb) || !(aa < T(1e300)) || !(bb < T(1e300))) return false;
    const cplx a = M.a.to_double(), b = M.b.to_double();
    const double u = std::norm(b);
    if (!(u > 1e-24)) return false;
    const cplx c(0, 2 * a.imag());
    const cplx w = std::conj(b) * c;
    const cplx v = std::conj(b) * std::conj(b);
    const double ux = 2 * w.real(), uy = -2 * w.imag();
    const double diag = 2 * (std::norm(c) + 2 * u);
    const double uxx = diag - 4 * v.real(), uyy = diag + 4 * v.real(), uxy = 4 * v.imag();
    const double r = std::sqrt(u), q = std::sqrt(1 + u);
    const double g1 = 1 / (r * q);                                    // g'(u)
    const double g2 = -0.5 / u / r / q - 0.5 / r / q / (1 + u);       // g''(u)
    gx += g1 * ux;
    gy += g1 * uy;
    hxx += g2 * ux * ux + g1 * uxx;
    hyy += g2 * uy * uy + g1 * uyy;
    hxy += g2 * ux * uy + g1 * uxy;
  }
  return std::isfinite(gx + gy + hxx + hyy + hxy);
}

/// Moves the frame to the point p minimising D(p) = Σ_k d(p, Y_k p) (a convex function: each term
/// is an isometry's displacement): Newton at the frame's origin with D's derivatives in closed form
/// (displacement_derivatives()), each step at most hyperbolic distance 2 and backtracked so D (in
/// T: double-double or quad) does not grow, then the frame moved there (Y conjugated in place,
/// F ← T F), until a step would be below 1e-9. Returns the steps taken, −1 when D is not finite.
template <class T>
int minimise_displacement(std::vector<detail::BasicMoebius<T>>& Y, detail::BasicMoebius<T>& F, int max_steps) {
  using M_T = detail::BasicMoebius<T>;
  using C_T = detail::BasicCQ<T>;
  constexpr double kMaxStep = 0.76;  // tanh(1)
  int steps = 0;
  auto f = [&](double x, double y) { return perimeter_at(Y, C_T{x, y}); };
  double f0 = f(0, 0);  // D at the frame's origin; after a step, the value the search accepted there
  if (!std::isfinite(f0)) return -1;
  for (int it = 0; it < max_steps; ++it) {
    double gx, gy, hxx, hyy, hxy;
    if (!displacement_derivatives(Y, gx, gy, hxx, hyy, hxy)) return -1;
    const double det = hxx * hyy - hxy * hxy;
    cplx step;
    if (hxx > 0 && det > 0) step = cplx(-(hyy * gx - hxy * gy) / det, -(hxx * gy - hxy * gx) / det);
    else step = cplx(-gx, -gy) * 0.1 / std::max(1.0, std::hypot(gx, gy));
    if (std::abs(step) > kMaxStep) step *= kMaxStep / std::abs(step);
    // At the minimum to ~1e-9 (D then moves only at second order): a backtracking search there
    // would halve a step that rounding in D decides.
    if (std::abs(step) < 1e-9) break;
    double t = 1, ft = f(step.real(), step.imag());
    while (t > 1e-6 && !(ft <= f0)) {
      t *= 0.5;
      ft = f(t * step.real(), t * step.imag());
    }
    if (t <= 1e-6) break;
    f0 = ft;
    step *= t;
    ++steps;
    const C_T p(step);
    F = (M_T::to_origin(p) * F).normalized();
    // Y conjugated by T = to_origin(p) in closed form (T's diagonal is real): with r = 1 − |p|²,
    // a' = (a + b p̄ − b̄ p − ā |p|²)/r and b' = (b + (a − ā) p − b̄ p²)/r; normalised once, after
    // the steps.
    const T pp = p.norm(), inv = T(1) / (T(1) - pp);
    const C_T p2 = p * p;
    for (M_T& M : Y) {
      const C_T a = M.a + M.b * p.conj() - M.b.conj() * p - pp * M.a.conj();
      M = M_T(inv * a, inv * moved_b_scaled(M, p, p2));
    }
    if (std::abs(step) < 1e-9) break;
  }
  if (steps > 0)
    for (M_T& M : Y) M = M.normalized();
  return steps;
}

/// The frame of minimise_displacement() for maps given in quad, found in double-double (only
/// where the minimum lies is read: the frame is an exact map in quad, normalised there) and
/// returned as the move T (the identity when no step was taken); −1 in *steps when D is not
/// finite. The callers conjugate their own quad maps by T once.
template <class Q>
detail::BasicMoebius<Q> displacement_frame(const std::vector<detail::BasicMoebius<Q>>& Y, int max_steps, int* steps) {
  // Single maps in double-double: entries up to 1e100 keep their squared norms finite.
  if (!detail::entries_below(Y, 1e100)) {
    *steps = -1;
    return detail::BasicMoebius<Q>();
  }
  std::vector<detail::BasicMoebius<DD>> Yd;
  for (const detail::BasicMoebius<Q>& M : Y) Yd.push_back(detail::to_dd(M));
  detail::BasicMoebius<DD> F;
  *steps = minimise_displacement(Yd, F, max_steps);
  if (*steps <= 0) return detail::BasicMoebius<Q>();
  return detail::from_dd<Q>(F).normalized();
}

/// The polygon's corner maps: corner j is W[j](p), W[0] = identity, with deck.h's convention
/// (block i from u: A^-1 B^-1 A u, B^-1 A u, A u, then [B, A^-1] u).
template <class Q>
std::vector<detail::BasicMoebius<Q>> corner_maps(const std::vector<detail::BasicMoebius<Q>>& gens) {
  using M = detail::BasicMoebius<Q>;
  std::vector<M> W;
  M U;  // block start
  for (std::size_t i = 0; i + 1 < gens.size(); i += 2) {
    const M& A = gens[i];
    const M& B = gens[i + 1];
    W.push_back(U);
    W.push_back((A.inverse() * B.inverse() * A * U).normalized());
    W.push_back((B.inverse() * A * U).normalized());
    W.push_back((A * U).normalized());
    U = (B * A.inverse() * B.inverse() * A * U).normalized();
  }
  W.push_back(U);  // the walk's end: the identity when the relation holds
  return W;
}

/// Substitutions of one pair of adjacent handles (a_i b_i a_{i+1} b_{i+1} = letters 1 2 3 4,
/// negative for inverses: the images of the four, each a word in them) that keep h_{i+1} h_i,
/// h = B A^-1 B^-1 A, letter for letter in the free group — hence the relation, and the corners
/// of every other block: the two swaps (one handle carried across the other, conjugated by that
/// one's commutator) and a twist mixing the handles, with its inverse (found by a search over
/// short substitutions and checked by free reduction; a wrong one would break the relation
/// that every polygon is checked against).
using PairMove = std::array<std::vector<int>, 4>;
const std::array<PairMove, 4> kPairMoves = {{
    {{{3}, {4}, {4, -3, -4, 3, 1, -3, 4, 3, -4}, {4, -3, -4, 3, 2, -3, 4, 3, -4}}},
    {{{-1, 2, 1, -2, 3, 2, -1, -2, 1}, {-1, 2, 1, -2, 4, 2, -1, -2, 1}, {1}, {2}}},
    {{{1, -2, -3, 4, 1}, {1, -2, -3, 4, 2}, {3, -4, 3, 2, -1}, {3, 2, -1}}},
    {{{-4, 3, 2}, {-4, 3, 2, -1, 2}, {3, 1, -2, -3, 4}, {4, 1, -2, -3, 4}}},
}};
/// Per handle (letters 1 2 = a_i b_i): (A, B A^±1) and (B^±1 A, B), which keep [A^-1, B].
const std::array<std::array<std::vector<int>, 2>, 4> kHandleMoves = {{
    {{{1}, {2, 1}}}, {{{1}, {2, -1}}}, {{{2, 1}, {2}}}, {{{-2, 1}, {2}}}}};

/// Conjugates the generators into the frame centred on their geodesic polygon (the corners of
/// the perimeter-minimising corner p, as geodesic_polygon() finds them) and accumulates that move
/// into C; p returns corner 0's point there. There the generators move the polygon's corners by at
/// most its diameter, so products of them keep the most digits. False (nothing changed) when the
/// polygon cannot be found.
bool centre_polygon(std::vector<detail::MoebiusQ>& gens, detail::MoebiusQ& C, detail::CQ& p) {
  // Where the centre lies is found in double-double; the move is then made on gens in quad.
  // Double-double keeps double's range: entries up to 1e15, so that the products of up to nine
  // generators the reduction forms, and their squared norms, stay finite.
  if (!detail::entries_below(gens, kDoubleDoubleEntries)) return false;
  using MD = detail::BasicMoebius<DD>;
  using CD = detail::BasicCQ<DD>;
  std::vector<MD> gd;
  for (const MoebiusQ& M : gens) gd.push_back(detail::to_dd(M));
  const std::vector<MD> W = corner_maps(gd);
  std::vector<MD> Y;
  for (std::size_t k = 0; k + 1 < W.size(); ++k) Y.push_back((W[k].inverse() * W[k + 1]).normalized());
  MD F;
  if (minimise_displacement(Y, F, 200) < 0) return false;
  detail::BasicHyperboloidSum<DD> mass;
  for (std::size_t k = 0; k + 1 < W.size(); ++k) {
    const CD q = (F * W[k] * F.inverse()).apply(CD{0, 0});
    if (detail::qisnan(q.norm()) || !(q.norm() < 1)) return false;
    mass.add(q, 1);
  }
  CD c;
  if (!mass.point(c) || !(c.norm() < 1)) return false;
  const MD to_c = MD::to_origin(c);
  const MD Td = to_c * F;
  const MoebiusQ T = detail::to_quad(Td).normalized(), T_inv = T.inverse();
  for (MoebiusQ& M : gens) M = (T * M * T_inv).normalized();
  C = (T * C).normalized();
  // Corner 0 (F's origin) in the new frame.
  p = detail::to_quad(to_c.apply(CD{0, 0}));
  return true;
}

/// Reduction of canonical generators by substitutions that keep the relation: per handle
/// (kHandleMoves) and per pair of adjacent handles (kPairMoves). The polygon is centred
/// (centre_polygon()), then sweeps over the blocks take, at each handle and each pair, the
/// substitution that shortens the polygon's perimeter most with corner 0 held at p — one changes
/// only the sides of the blocks it touches (the others' corners stay), so only those are
/// measured — until a sweep takes none; then the polygon is centred again (p moves to the new
/// minimiser), until a centring is followed by no substitution (at most 20 centrings, 40 g
/// sweeps each). gens are left in the centred frame (C updated); returns the substitutions made.
int reduce_generators(std::vector<detail::MoebiusQ>& gens, std::vector<Word>& words, detail::MoebiusQ& C) {
  using FastCQ = detail::BasicCQ<DD>;
  using FastMoebius = detail::BasicMoebius<DD>;
  const std::size_t g = gens.size() / 2;
  int made = 0;
  // Substitutions are tried on the generators rounded to double-double (`fast`: a trial is only
  // measured, against gains of 1e-6 of the perimeter), the one chosen is made on gens themselves.
  std::vector<FastMoebius> fast;
  // A block's four sides from its start u; ∞ when a corner lies beyond `reach` from the centre.
  double reach = INFINITY;
  auto block = [&reach](const FastMoebius& A, const FastMoebius& B, const FastCQ& u, FastCQ* next) {
    const FastCQ v1 = (A.inverse() * B.inverse() * A).apply(u), v2 = (B.inverse() * A).apply(u), v3 = A.apply(u);
    const FastCQ v4 = (B * A.inverse() * B.inverse() * A).apply(u);
    if (next) *next = v4;
    for (const FastCQ& v : {v1, v2, v3})
      if (!(detail::hyperbolic_distance_q(v, FastCQ{0, 0}) <= reach)) return static_cast<double>(INFINITY);
    return detail::hyperbolic_distance_q(u, v1) + detail::hyperbolic_distance_q(v1, v2) +
           detail::hyperbolic_distance_q(v2, v3) + detail::hyperbolic_distance_q(v3, v4);
  };
  auto image = [](const auto& maps, const std::vector<int>& w, std::size_t first) {
    using M = std::decay_t<decltype(maps[0])>;
    M out;
    for (int x : w) {
      const M& G = maps[first + static_cast<std::size_t>(std::abs(x) - 1)];
      out = out * (x > 0 ? G : G.inverse());
    }
    return out.normalized();
  };
  auto substitute = [&](const std::vector<const std::vector<int>*>& move, std::size_t first) {
    std::vector<Word> new_words;
    std::vector<MoebiusQ> maps;
    for (const std::vector<int>* w : move) {
      Word out;
      for (int x : *w) {
        const Word& G = words[first + static_cast<std::size_t>(std::abs(x) - 1)];
        const Word step = x > 0 ? G : inverse(G);
        out = concat({&out, &step});
      }
      new_words.push_back(std::move(out));
      maps.push_back(image(gens, *w, first));
    }
    for (std::size_t k = 0; k < maps.size(); ++k) {
      gens[first + k] = maps[k];
      fast[first + k] = detail::to_dd(maps[k]);
      words[first + k] = std::move(new_words[k]);
    }
    ++made;
  };
  CQ p;
  for (int centring = 0; centring < 20; ++centring) {
    if (!centre_polygon(gens, C, p)) return made;
    const int before = made;
    fast.clear();
    for (const MoebiusQ& M : gens) fast.push_back(detail::to_dd(M));
    const std::vector<FastMoebius> W = corner_maps(fast);
    const FastCQ p_fast{detail::to_dd(p.re), detail::to_dd(p.im)};
    std::vector<FastCQ> u;  // block starts: a substitution moves only the start between the blocks it touches
    for (std::size_t i = 0; i <= g; ++i) u.push_back(W[4 * i].apply(p_fast));
    // Substitutions may not move a corner beyond the polygon's reach at this centring: the
    // lengths are measured from the centre, and far corners would both lose their digits
    // (a gain computed there can be rounding) and spread the polygon.
    // (The same corners computed through other products differ by rounding: 1e-6 of slack.)
    reach = 0;
    for (std::size_t k = 0; k + 1 < W.size(); ++k)
      reach = std::max(reach, detail::hyperbolic_distance_q(W[k].apply(p_fast), FastCQ{0, 0}));
    reach += 1e-6;
    double perimeter = 0;
    std::vector<double> len(g);
    for (std::size_t i = 0; i < g; ++i) perimeter += len[i] = block(fast[2 * i], fast[2 * i + 1], u[i], nullptr);
    if (!std::isfinite(perimeter)) break;
    // Gains below 1e-6 of the perimeter are left, and among gains within that of each other the
    // first substitution offered is taken: the polygon's lengths carry the rounding of the flow's
    // solution amplified by e^reach (3e-9 relative at reach 18 between two factorizations of the
    // same system), and a symmetric surface offers substitutions of equal gain; smaller
    // differences would turn on the metric's last bits.
    const double least_gain = 1e-6 * perimeter;
    // A handle's or pair's substitutions are tried again only when what they read changed since
    // they were last tried without gain: the handles' maps (ver) and the block start (u_ver).
    // A handle substitution keeps its commutator, so the next block's start stays.
    std::vector<int> ver(g, 0), u_ver(g + 1, 0);
    std::vector<std::array<int, 2>> tried_handle(g, {-1, -1});
    std::vector<std::array<int, 3>> tried_pair(g, {-1, -1, -1});
    for (std::size_t sweep = 0; sweep < 40 * g; ++sweep) {
      const int at_sweep = made;
      for (std::size_t i = 0; i < g; ++i) {
        double best_gain = least_gain;
        const std::array<int, 2> handle_key{ver[i], u_ver[i]};
        if (tried_handle[i] != handle_key) {
          const std::array<std::vector<int>, 2>* chosen = nullptr;
          for (const auto& m : kHandleMoves) {
            const double gain = len[i] - block(image(fast, m[0], 2 * i), image(fast, m[1], 2 * i), u[i], nullptr);
            if (gain > best_gain + (chosen ? least_gain : 0)) best_gain = gain, chosen = &m;
          }
          if (chosen) {
            len[i] -= best_gain;
            substitute({&(*chosen)[0], &(*chosen)[1]}, 2 * i);
            ++ver[i];
          } else {
            tried_handle[i] = handle_key;
          }
        }
        if (i + 1 == g) continue;
        const std::array<int, 3> pair_key{ver[i], ver[i + 1], u_ver[i]};
        if (tried_pair[i] == pair_key) continue;
        best_gain = least_gain;
        const PairMove* pair = nullptr;
        double len0 = 0, len1 = 0;
        FastCQ start1;  // the second block's start after the chosen substitution (the first's stays)
        for (const PairMove& m : kPairMoves) {
          FastCQ mid;
          const double l0 = block(image(fast, m[0], 2 * i), image(fast, m[1], 2 * i), u[i], &mid),
                       l1 = block(image(fast, m[2], 2 * i), image(fast, m[3], 2 * i), mid, nullptr);
          const double gain = len[i] + len[i + 1] - l0 - l1;
          if (gain > best_gain + (pair ? least_gain : 0))
            best_gain = gain, pair = &m, len0 = l0, len1 = l1, start1 = mid;
        }
        if (pair) {
          len[i] = len0;
          len[i + 1] = len1;
          u[i + 1] = start1;
          substitute({&(*pair)[0], &(*pair)[1], &(*pair)[2], &(*pair)[3]}, 2 * i);
          ++ver[i];
          ++ver[i + 1];
          ++u_ver[i + 1];
        } else {
          tried_pair[i] = pair_key;
        }
      }
      if (made == at_sweep) break;
    }
    if (made == before) break;
  }
  centre_polygon(gens, C, p);
  return made;
}

/// Klein-model point of a disk point (geodesics are straight there).
cplx klein(cplx z) { return 2.0 * z / (1.0 + std::norm(z)); }

double cross(cplx a, cplx b) { return a.real() * b.imag() - a.imag() * b.real(); }

/// Whether the closed segments pq and rs meet (orientation tests; touching counts).
bool segments_meet(cplx p, cplx q, cplx r, cplx s) {
  const double d1 = cross(q - p, r - p), d2 = cross(q - p, s - p), d3 = cross(s - r, p - r), d4 = cross(s - r, q - r);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  auto on = [](cplx a, cplx b, cplx c, double d) {  // c on segment ab, given collinear (d == 0)
    return d == 0 && std::min(a.real(), b.real()) <= c.real() && c.real() <= std::max(a.real(), b.real()) &&
           std::min(a.imag(), b.imag()) <= c.imag() && c.imag() <= std::max(a.imag(), b.imag());
  };
  return on(p, q, r, d1) || on(p, q, s, d2) || on(r, s, p, d3) || on(r, s, q, d4);
}

}  // namespace

namespace {

/// Whether generators were stored in quad-double (detail::set_wide_map()): then their polygon is
/// formed in quad-double too.
bool wide_generators(const DeckResult& d) {
  return std::any_of(d.generators.begin(), d.generators.end(), [](const DeckGenerator& G) { return detail::has_wide_map(G); });
}

template <class Q>
std::vector<detail::BasicMoebius<Q>> maps_of(const DeckResult& d) {
  std::vector<detail::BasicMoebius<Q>> gens;
  for (const DeckGenerator& G : d.generators) {
    if constexpr (std::is_same_v<Q, quad>) gens.push_back(quad_map(G).normalized());
    else gens.push_back(detail::wide_map(G).normalized());
  }
  return gens;
}

}  // namespace

GeodesicPolygon geodesic_polygon(const DeckResult& canonical) {
  if (wide_generators(canonical))
    return polygon_from(maps_of<detail::Wide>(canonical), detail::MoebiusW(), canonical);
  return polygon_from(maps_of<quad>(canonical), MoebiusQ(), canonical);
}

GeodesicPolygon geodesic_polygon(const CanonicalGenerators& cg) {
  if (cg.status != Status::Ok || cg.working.generators.size() != cg.deck.generators.size()) return geodesic_polygon(cg.deck);
  const MoebiusQ prior = quad_map(cg.working_frame).normalized();
  if (wide_generators(cg.working))
    return polygon_from(maps_of<detail::Wide>(cg.working), detail::to_wide(prior), cg.deck);
  return polygon_from(maps_of<quad>(cg.working), prior, cg.deck);
}

namespace {

/// geodesic_polygon() of `gens`, given in the frame `prior` moves the generators' frame to
/// (gens = prior G prior^-1 for canonical's G): the polygon's frame is reported from the
/// generators' frame, its generators are conjugated from `gens` (a short move), and canonical
/// gives their names and residuals.
template <class Q>
GeodesicPolygon polygon_from(std::vector<detail::BasicMoebius<Q>> gens, const detail::BasicMoebius<Q>& prior,
                             const DeckResult& canonical) {
  using MQ = detail::BasicMoebius<Q>;
  using CT = detail::BasicCQ<Q>;
  const auto t_start = std::chrono::steady_clock::now();
  GeodesicPolygon out;
  auto bad = [&](Status st, const std::string& m) {
    out.status = st;
    out.message = m;
    out.vertices.clear();
    return out;
  };
  const std::size_t n2 = canonical.generators.size();
  if (canonical.geometry != Geometry::Hyperbolic || n2 < 4 || n2 % 2 != 0 || gens.size() != n2)
    return bad(Status::InvalidArgument, "the geodesic polygon needs 2g >= 4 hyperbolic generators a1 b1 ...");
  const std::size_t g = n2 / 2;
  // Generators beyond kMaxEntries: their corner products would leave quad-double's (double's)
  // range, and the polygon lies far beyond what either arithmetic verifies.
  if (!detail::entries_below(gens, kMaxEntries) || !detail::entries_below(prior, kMaxEntries)) {
    out.beyond_quad = true;
    return bad(Status::NumericalFailure, "the geodesic polygon's generators lie beyond what " +
                                             std::to_string(detail::bits_of<Q>()) + " bits resolve in the disk.");
  }
  const std::vector<MQ> W = corner_maps(gens);
  const std::size_t n = 4 * g;
  std::vector<MQ> Y;  // side k: W_k^-1 W_{k+1}
  for (std::size_t k = 0; k < n; ++k) Y.push_back((W[k].inverse() * W[k + 1]).normalized());

  // p minimising the perimeter, at the origin of the frame F.
  int steps = 0;
  const MQ F = displacement_frame(Y, 200, &steps);
  if (steps < 0) return bad(Status::NumericalFailure, "the geodesic polygon's perimeter is not finite.");
  out.newton_steps = steps;

  // Corners with p at the origin of F, then the frame centred on them.
  std::vector<CT> corners;
  for (std::size_t k = 0; k < n; ++k) corners.push_back((F * W[k] * F.inverse()).apply(CT{0, 0}));
  const CT end = (F * W[n] * F.inverse()).apply(CT{0, 0});
  // A corner (or, below, the centre) on the unit circle in Q: the polygon reaches beyond what
  // its bits (113 in quad, 212 in quad-double) resolve in the disk.
  auto in_disk = [](const CT& q) { return !detail::qisnan(q.norm()) && q.norm() < 1; };
  auto beyond = [&](const std::string& what) {
    out.beyond_quad = true;
    return bad(Status::NumericalFailure, "the geodesic polygon's " + what + " lies beyond what " +
                                             std::to_string(detail::bits_of<Q>()) + " bits resolve in the disk.");
  };
  for (std::size_t k = 0; k < n; ++k)
    if (!in_disk(corners[k])) return beyond("corner " + std::to_string(k));
  if (!in_disk(end)) return beyond("closing corner");
  out.closure_error = detail::hyperbolic_distance_q(end, CT{0, 0});
  // The centre: the corners' centre of mass on the hyperboloid (symmetric polygons keep their
  // centre exactly).
  detail::BasicHyperboloidSum<Q> mass;
  for (const CT& q : corners) mass.add(q, 1);
  CT c;
  if (!mass.point(c)) return bad(Status::NumericalFailure, "the geodesic polygon's corners have no centre.");
  if (!in_disk(c)) return beyond("centre");
  const MQ C = MQ::to_origin(c);
  const MQ frame = (C * F).normalized();
  out.frame = (frame * prior).normalized().to_double();
  std::vector<CT> v;
  for (const CT& q : corners) v.push_back(C.apply(q));
  for (std::size_t k = 0; k < n; ++k)
    if (!in_disk(v[k])) return beyond("corner " + std::to_string(k));
  for (const CT& q : v) out.vertices.push_back(q.to_double());

  // Generators in the polygon's frame; the relation at corner 0.
  std::vector<MQ> gp;
  out.deck = canonical;
  out.deck.generators.clear();
  for (std::size_t i = 0; i < n2; ++i) {
    gp.push_back((frame * gens[i] * frame.inverse()).normalized());
    DeckGenerator G = generator_from(gp.back(), canonical.generators[i].name);
    G.side = canonical.generators[i].side;
    G.partner = canonical.generators[i].partner;
    G.residual_max = canonical.generators[i].residual_max;
    G.residual_rms = canonical.generators[i].residual_rms;
    G.pairs = canonical.generators[i].pairs;
    out.deck.generators.push_back(G);
  }
  out.deck.relator = detail::canonical_relator(gp).to_double();
  // At corner 0, formed in frames at the corners the relator's letters visit.
  out.deck.relation_error = detail::product_at(detail::canonical_relator_letters(gp), v[0]).distance_to_identity();

  // Sides, angles, reach, simplicity.
  for (std::size_t k = 0; k < n; ++k) {
    const CT& a = v[k];
    const CT& b = v[(k + 1) % n];
    out.side_lengths.push_back(detail::hyperbolic_distance_q(a, b));
    out.perimeter += out.side_lengths.back();
    out.reach = std::max(out.reach, detail::hyperbolic_distance_q(a, CT{0, 0}));
    const MQ Ta = MQ::to_origin(a);
    const cplx next = Ta.apply(v[(k + 1) % n]).to_double(), prev = Ta.apply(v[(k + n - 1) % n]).to_double();
    double angle = std::arg(prev / next);
    if (angle <= 0) angle += 2 * M_PI;
    out.angles.push_back(angle);
    out.angle_sum += angle;
  }
  out.area = (static_cast<double>(n) - 2) * M_PI - out.angle_sum;
  out.simple = true;
  std::vector<cplx> kz;
  for (const cplx& z : out.vertices) kz.push_back(klein(z));
  for (std::size_t i = 0; i < n && out.simple; ++i)
    for (std::size_t j = i + 2; j < n && out.simple; ++j) {
      if (i == 0 && j == n - 1) continue;  // adjacent through corner 0
      if (segments_meet(kz[i], kz[(i + 1) % n], kz[j], kz[(j + 1) % n])) out.simple = false;
    }
  for (std::size_t i = 0; i < n && out.simple; ++i)
    if (kz[i] == kz[(i + 1) % n]) out.simple = false;
  if (!std::isfinite(out.perimeter) || !std::isfinite(out.angle_sum) || !std::isfinite(out.deck.relation_error) ||
      !std::isfinite(out.closure_error))
    return bad(Status::NumericalFailure, "the geodesic polygon has a value that is not finite.");
  out.angle_tolerance = std::max(1e-9, out.deck.relation_error * std::exp(out.reach));
  out.relation_floor = detail::epsilon_of<Q>() * std::exp(2 * out.reach);
  out.arithmetic_bits = detail::bits_of<Q>();
  out.at_quad_floor = out.simple && out.deck.relation_error > 1e-12 && out.deck.relation_error <= 16 * out.relation_floor;
  out.fundamental = out.simple && std::abs(out.angle_sum - 2 * M_PI) <= out.angle_tolerance;
  out.word.clear();
  for (std::size_t i = 1; i <= g; ++i) {
    const std::string k = std::to_string(i);
    out.word += (i > 1 ? " a" : "a") + k + " b" + k + " a" + k + "^-1 b" + k + "^-1";
  }
  out.status = Status::Ok;
  char buf[240];
  std::snprintf(buf, sizeof buf,
                "geodesic %d-gon: perimeter %.6g, angle sum %.15g (2pi %s), reach %.3g, %s, relation error %.3g",
                static_cast<int>(n), out.perimeter, out.angle_sum,
                std::abs(out.angle_sum - 2 * M_PI) <= out.angle_tolerance ? "yes" : "no", out.reach,
                out.simple ? "simple" : "not simple",
                out.deck.relation_error);
  out.message = buf;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return out;
}

}  // namespace

}  // namespace ricci
