// ricci — conformal shape signatures (see signature.h): takes a UniformizeResult, gives the flat
// torus's reduced modulus, or the hyperbolic lengths of a fixed list of words, the systole among
// the short words and the Fenchel–Nielsen coordinates (signature_fn.cpp), or the boundary parts
// (signature_boundary.cpp), as the topology calls for.
#include "ricci/signature.h"

#include "signature_internal.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <new>
#include <span>
#include <string>
#include <vector>

namespace ricci {

namespace {

constexpr double kTie = 1e-12;
/// The word search visits at most about this many reduced words (signature.h).
constexpr double kWordBudget = 1e6;
/// The spectrum keeps this many distinct lengths; lengths within this relative gap are one.
constexpr std::size_t kSpectrumSize = 32;
constexpr double kSameLength = 1e-9;

/// Letter k of genus g: generator k / 2 (a1 b1 a2 b2 … as 0 1 2 3 …), inverse when k is odd.
/// Letters are ordered a1 a1^-1 b1 b1^-1 a2 … .
int inverse_letter(int k) { return k ^ 1; }

std::string letter_name(int k) {
  const int gen = k / 2;
  std::string s(1, gen % 2 == 0 ? 'a' : 'b');
  s.append(std::to_string(gen / 2 + 1));
  if (k % 2 == 1) s.append("^-1");
  return s;
}

}  // namespace

bool reduce_modulus(std::complex<double> tau, std::complex<double>& reduced, std::array<long long, 4>& m) {
  m = {1, 0, 0, 1};
  if (!std::isfinite(tau.real()) || !std::isfinite(tau.imag()) || !(tau.imag() > 0)) return false;
  std::complex<double> t = tau;
  for (int iter = 0; iter < 10000; ++iter) {
    // Translate into |Re t| ≤ ½: t ↦ t − n, M ↦ T^-n M.
    const double n = std::round(t.real());
    if (std::abs(n) > 1e15) return false;
    const auto k = static_cast<long long>(n);
    t -= n;
    m = {m[0] - k * m[2], m[1] - k * m[3], m[2], m[3]};
    if (std::norm(t) >= 1 - kTie) break;
    // Invert: t ↦ −1/t, M ↦ S M with S = [[0, −1], [1, 0]].
    t = -1.0 / t;
    m = {-m[2], -m[3], m[0], m[1]};
  }
  // Boundary conventions: Re t ∈ [−½, ½), and Re t ≤ 0 on the unit circle.
  if (t.real() >= 0.5 - kTie) {
    t -= 1.0;
    m = {m[0] - m[2], m[1] - m[3], m[2], m[3]};
  }
  if (std::abs(std::norm(t) - 1) <= kTie && t.real() > kTie) {
    t = -1.0 / t;
    m = {-m[2], -m[3], m[0], m[1]};
  }
  reduced = t;
  return true;
}

std::vector<std::vector<std::pair<int, int>>> signature_words(Index genus, std::vector<std::string>* names) {
  std::vector<std::vector<std::pair<int, int>>> words;
  if (names != nullptr) names->clear();
  const int letters = static_cast<int>(4 * std::max<Index>(genus, 0));
  auto add = [&](std::initializer_list<int> ks) {
    std::vector<std::pair<int, int>> w;
    std::string name;
    for (const int k : ks) {
      w.push_back({k / 2, k % 2 == 1 ? -1 : 1});
      if (!name.empty()) name += ' ';
      name += letter_name(k);
    }
    words.push_back(std::move(w));
    if (names != nullptr) names->push_back(std::move(name));
  };
  for (int k = 0; k < letters; k += 2) add({k});
  // Two-letter words x y with y ∉ {x, x^-1}, one per class under rotation (x y ~ y x) and
  // inversion (x y ~ y^-1 x^-1): the pair that is smallest in the letter order.
  for (int x = 0; x < letters; ++x)
    for (int y = 0; y < letters; ++y) {
      if (y == x || y == inverse_letter(x)) continue;
      const std::pair<int, int> self{x, y};
      const std::pair<int, int> others[3] = {{y, x}, {inverse_letter(y), inverse_letter(x)},
                                             {inverse_letter(x), inverse_letter(y)}};
      if (std::all_of(std::begin(others), std::end(others), [&](const auto& o) { return self <= o; })) add({x, y});
    }
  return words;
}

namespace {

bool torus_signature(const DeckResult& deck, ConformalSignature& out) {
  const DeckGenerator& a = deck.generators[0];
  const DeckGenerator& b = deck.generators[1];
  const std::complex<double> wa(a.translation[0], a.translation[1]), wb(b.translation[0], b.translation[1]);
  if (!(std::abs(wa) > 0) || !(std::abs(wb) > 0)) {
    out.status = Status::NumericalFailure;
    out.message = "a deck translation of the torus is zero";
    return false;
  }
  TorusModulus& t = out.torus;
  t.tau_computed = wb / wa;
  if (t.tau_computed.imag() < 0) {
    t.tau_computed = -t.tau_computed;
    t.b_reversed = true;
  }
  if (!reduce_modulus(t.tau_computed, t.tau, t.reduction)) {
    out.status = Status::NumericalFailure;
    out.message = "the torus's translations are parallel (Im τ = 0)";
    return false;
  }
  const double du = (std::abs(t.tau_computed) * a.residual_max + b.residual_max) / std::abs(wa);
  const std::complex<double> denom = static_cast<double>(t.reduction[2]) * t.tau_computed + static_cast<double>(t.reduction[3]);
  t.uncertainty = du / std::norm(denom);
  out.has_torus = true;
  return true;
}

/// Lengths whose rounding bound exceeds this are left out of the spectrum and the systole.
constexpr double kReliable = 1e-9;

/// The longest word length L ≤ 8 whose reduced words, Σ_{l ≤ L} 4g·(4g − 1)^(l−1), stay within
/// the budget (at least 2).
int spectrum_word_length(Index genus) {
  const double letters = 4.0 * static_cast<double>(genus);
  int L = 1;
  double total = letters, layer = letters;
  while (L < 8) {
    layer *= letters - 1;
    if (total + layer > kWordBudget) break;
    total += layer;
    ++L;
  }
  return std::max(L, 2);
}

/// The translation length of a product of a few normalised letters, whose determinant is 1 up to
/// rounding: |Re a|/√det is taken to first order in δ = det − 1, |Re a|·(1 − δ/2), which is exact
/// in quad while |δ| < 1e-17 (the next term, 3δ²/8, is below 2^-113) and needs no square root or
/// division; otherwise translation_length_q(), which normalises.
double product_length(const detail::MoebiusQ& m) {
  using detail::quad;
  const quad delta = m.a.norm() - m.b.norm() - 1;
  if (!(detail::qabs(delta) < static_cast<quad>(1e-17))) return translation_length_q(m);
  const quad re = detail::qabs(m.a.re) * (1 - delta * static_cast<quad>(0.5));
  if (!(static_cast<double>(re) > 1)) return 0;
  // 2·arccosh x = 2·log(x + √(x² − 1)); for x near 1 from the quad difference x − 1.
  const double d = static_cast<double>(re - 1);
  return 2 * std::log1p(d + std::sqrt(d * (d + 2)));
}

/// A map of the disk in double, for screening words before their quad product.
struct MoebiusD {
  std::complex<double> a{1, 0}, b{0, 0};
  MoebiusD operator*(const MoebiusD& n) const {
    return {a * n.a + b * std::conj(n.b), a * n.b + b * std::conj(n.a)};
  }
};

/// The translation length of a product of letters normalised in quad and rounded to double, and a
/// bound on its error: the rounded letters move the product's entries by at most `letters`·2^-53
/// of Π‖letter‖ (`norm_product`), and each product rounds at 2^-53 of that size; the bound takes
/// 8·2^-53 per letter. No normalisation in double (|a|² − |b|² cancels there). The error bound is
/// +∞ where the length is 0 or not finite.
std::pair<double, double> screening_length(const MoebiusD& m, double norm_product, int letters) {
  const double x = std::abs(m.a.real());
  if (!(x > 1) || !std::isfinite(x)) return {0, INFINITY};
  const double d = x - 1;
  const double l = 2 * std::log1p(d + std::sqrt(d * (d + 2)));
  const double dx = letters * 8 * 0x1p-53 * norm_product;
  return {l, 2 * dx / std::sqrt((x - 1) * (x + 1))};
}

/// Every cyclically reduced word of length ≤ max_length that is not a proper power, in depth-first
/// order from one first letter: visit(word, its product in double, Π of its letters' norms).
struct WordWalk {
  const std::vector<MoebiusD>& letter;
  const std::vector<double>& norm;
  int max_length;

  template <class Visit>
  void operator()(int first, Visit&& visit) const {
    const int letters = static_cast<int>(letter.size());
    std::vector<int> word{first};
    std::vector<MoebiusD> prefix{MoebiusD{}, letter[static_cast<std::size_t>(first)]};
    std::vector<double> norm_product{1.0, norm[static_cast<std::size_t>(first)]};
    auto descend = [&](auto&& self) -> void {
      const auto len = static_cast<int>(word.size());
      const bool power = len % 2 == 0 && std::equal(word.begin(), word.begin() + len / 2, word.begin() + len / 2);
      if (word.back() != inverse_letter(word.front()) && !power) visit(word, prefix.back(), norm_product.back());
      if (len == max_length) return;
      for (int k = 0; k < letters; ++k) {
        if (k == inverse_letter(word.back())) continue;
        word.push_back(k);
        prefix.push_back(prefix.back() * letter[static_cast<std::size_t>(k)]);
        norm_product.push_back(norm_product.back() * norm[static_cast<std::size_t>(k)]);
        self(self);
        norm_product.pop_back();
        prefix.pop_back();
        word.pop_back();
      }
    };
    descend(descend);
  }
};

/// Translation lengths past which length_rounding() is not evaluated (its cosh would overflow).
constexpr double kLongest = 1400;

/// A length T below which the reliable words' lengths already give kSpectrumSize entries of the
/// spectrum, from every word's length in double with its error bound (each first letter's words in
/// parallel). Each word that may be reliable (its quad rounding bound at the top of its interval
/// within kReliable) is an interval [l − e, l + e] holding its quad length. Sorted by their lower
/// ends, the intervals fall into clusters, a new one starting where an interval's lower end lies
/// more than kSameLength of its upper end above every upper end before it: the lengths of two
/// clusters are then more than kSameLength apart, so the spectrum takes at least one length from
/// each cluster that holds a word surely reliable (its rounding bound within kReliable at the
/// bottom of its interval). T is the largest upper end of the 1.5·kSpectrumSize-th such cluster,
/// or +∞ when there are fewer; every word whose length may be ≤ T is then taken in quad.
double spectrum_bound(const WordWalk& walk) {
  const int letters = static_cast<int>(walk.letter.size());
  struct Interval {
    double low, high;
    bool sure;
  };
  std::vector<std::vector<Interval>> found(static_cast<std::size_t>(letters));
  int out_of_memory = 0;  // nothing may leave the parallel region: rethrown after it
#pragma omp parallel for schedule(dynamic, 1) reduction(max : out_of_memory)
  for (int first = 0; first < letters; ++first) try {
    std::vector<Interval>& out = found[static_cast<std::size_t>(first)];
    walk(first, [&](const std::vector<int>& word, const MoebiusD& m, double norms) {
      const int len = static_cast<int>(word.size());
      const auto [l, error] = screening_length(m, norms, len);
      if (!(error < l)) {  // unresolved in double (the bound not below the length): anywhere
        out.push_back({0, INFINITY, false});
        return;
      }
      // The quad rounding bound falls as the length grows; past kLongest (where cosh overflows)
      // it is below any tolerance. Never reliable: above kReliable even at the interval's top.
      const double low = l - error, high = l + error;
      if (high < kLongest && !(length_rounding(high, norms, len) <= kReliable)) return;
      out.push_back({low, high, low >= kLongest || length_rounding(low, norms, len) <= kReliable});
    });
  } catch (const std::bad_alloc&) {
    out_of_memory = 1;
  }
  if (out_of_memory) throw std::bad_alloc();
  std::vector<Interval> all;
  for (const std::vector<Interval>& f : found) all.insert(all.end(), f.begin(), f.end());
  found.clear();
  std::sort(all.begin(), all.end(), [](const Interval& x, const Interval& y) { return x.low < y.low; });
  std::size_t clusters = 0;
  double top = -INFINITY;  // the largest upper end so far
  bool sure = false;       // the current cluster holds a surely reliable word
  for (const Interval& i : all) {
    if (i.low - top > kSameLength * i.high) {  // a new cluster: close the current one
      if (sure && ++clusters == kSpectrumSize + kSpectrumSize / 2) return top;
      sure = false;
    }
    top = std::max(top, i.high);
    sure = sure || i.sure;
  }
  return INFINITY;
}

/// The shortest cyclically reduced word of length ≤ max_length in the generators (letters as in
/// signature_words(): k/2 the generator, odd k its inverse), and the kSpectrumSize shortest
/// distinct lengths. The words are searched depth first, each first letter's words on their own
/// (in parallel), and the searches are then merged in the order of their first letters, so the
/// result does not depend on the threads. Two passes: the first takes every word's length in
/// double with an error bound and from them a length T below which the spectrum is complete
/// (spectrum_bound()); the second takes in quad only the words whose length may be ≤ T (a few per
/// thousand), so the result is the one an evaluation of every word in quad gives.
WordLength systole_search(const std::vector<detail::MoebiusQ>& generators, std::span<const double> residuals,
                          int max_length, std::vector<double>& spectrum) {
  const int letters = static_cast<int>(2 * generators.size());
  std::vector<detail::MoebiusQ> letter(static_cast<std::size_t>(letters));
  std::vector<MoebiusD> letter_d(static_cast<std::size_t>(letters));
  std::vector<double> letter_norm(static_cast<std::size_t>(letters));
  for (int k = 0; k < letters; ++k) {
    const detail::MoebiusQ& m = generators[static_cast<std::size_t>(k / 2)];
    const std::size_t i = static_cast<std::size_t>(k);
    letter[i] = (k % 2 == 0 ? m : m.inverse()).normalized();
    letter_d[i] = {letter[i].a.to_double(), letter[i].b.to_double()};
    letter_norm[i] = matrix_norm(letter[i]);
  }
  const WordWalk walk{letter_d, letter_norm, max_length};
  const double T = spectrum_bound(walk);

  // Pass 2: the words whose length may be ≤ T, in quad. The shortest of one search: a shorter
  // length wins; within 1e-9 relative (the same class), the word with fewer letters.
  struct Search {
    WordLength best;
    std::size_t best_letters = 0;
    std::vector<double> lengths;
    Search() { best.length = INFINITY; }
    bool wins(double length, std::size_t count) const {
      const bool tie = std::abs(length - best.length) <= kSameLength * length;
      return (!tie && length < best.length) || (tie && count < best_letters);
    }
    void offer(const WordLength& w, std::size_t count) {
      if (!wins(w.length, count)) return;
      best = w;
      best_letters = count;
    }
  };
  std::vector<Search> searches(static_cast<std::size_t>(letters));
  int out_of_memory = 0;  // nothing may leave the parallel region: rethrown after it
#pragma omp parallel for schedule(dynamic, 1) reduction(max : out_of_memory)
  for (int first = 0; first < letters; ++first) try {
    Search& S = searches[static_cast<std::size_t>(first)];
    walk(first, [&](const std::vector<int>& word, const MoebiusD& md, double norms) {
      const auto [ld, error] = screening_length(md, norms, static_cast<int>(word.size()));
      if (ld - error > T) return;  // longer than T: not in the spectrum (NaN or +∞ bounds stay)
      // Products of normalised letters stay normalised to a few roundings over ≤ 8 letters.
      detail::MoebiusQ m;
      for (const int k : word) m = m * letter[static_cast<std::size_t>(k)];
      const double l = product_length(m);
      // Words whose product the arithmetic cannot resolve to kReliable are left out.
      const double rounding = length_rounding(l, norms, static_cast<int>(word.size()));
      if (!(l > 0 && rounding <= kReliable)) return;
      S.lengths.push_back(l);
      if (!S.wins(l, word.size())) return;  // the word's name is made only for a winner
      WordLength w;
      w.length = l;
      double residual = 0;
      for (const int k : word) {
        if (!w.word.empty()) w.word.push_back(' ');
        w.word.append(letter_name(k));
        residual += residuals.empty() ? 0.0 : residuals[static_cast<std::size_t>(k / 2)];
      }
      w.uncertainty = 2 * residual + rounding;
      S.offer(w, word.size());
    });
  } catch (const std::bad_alloc&) {
    out_of_memory = 1;
  }
  if (out_of_memory) throw std::bad_alloc();
  Search all;
  std::vector<double> lengths;
  for (const Search& S : searches) {
    if (S.best_letters > 0) all.offer(S.best, S.best_letters);
    lengths.insert(lengths.end(), S.lengths.begin(), S.lengths.end());
  }
  const WordLength best = all.best;
  // Distinct lengths (a class met as several words, or equal lengths by symmetry, counts once).
  std::sort(lengths.begin(), lengths.end());
  spectrum.clear();
  for (const double l : lengths) {
    if (!spectrum.empty() && l - spectrum.back() <= kSameLength * l) continue;
    spectrum.push_back(l);
    if (spectrum.size() == kSpectrumSize) break;
  }
  return best;
}

void hyperbolic_signature(const DeckResult& deck, ConformalSignature& out) {
  std::vector<Moebius> gens, low;
  std::vector<double> residuals;
  for (const DeckGenerator& g : deck.generators) {
    gens.push_back(g.map);
    low.push_back(g.map_low);
    residuals.push_back(g.residual_max);
  }
  out = hyperbolic_signature(gens, residuals, low);
}

}  // namespace

ConformalSignature hyperbolic_signature(std::span<const Moebius> generators, std::span<const double> residuals,
                                        std::span<const Moebius> low) {
  ConformalSignature out;
  out.status = Status::InvalidArgument;
  const std::size_t n = generators.size();
  if (n < 4 || n % 2 != 0 || (!residuals.empty() && residuals.size() != n) || (!low.empty() && low.size() != n)) {
    out.message = "a closed surface of genus ≥ 2 has 2g ≥ 4 canonical generators (and one residual and low part "
                  "each, if any); got " + std::to_string(n) + " generators, " + std::to_string(residuals.size()) +
                  " residuals and " + std::to_string(low.size()) + " low parts";
    return out;
  }
  try {
    out.genus = static_cast<Index>(n / 2);
    std::vector<std::string> names;
    const auto words = signature_words(out.genus, &names);
    std::vector<detail::MoebiusQ> q;
    for (std::size_t k = 0; k < n; ++k) q.push_back(quad_generator(generators, low, k));
    for (std::size_t w = 0; w < words.size(); ++w) {
      detail::MoebiusQ m;
      double residual = 0, norms = 1;
      for (const auto& [gen, sign] : words[w]) {
        const detail::MoebiusQ& g = q[static_cast<std::size_t>(gen)];
        m = m * (sign > 0 ? g : g.inverse());
        residual += residuals.empty() ? 0.0 : residuals[static_cast<std::size_t>(gen)];
        norms *= matrix_norm(g);
      }
      const double l = translation_length_q(m);
      out.words.push_back({names[w], l, 2 * residual + length_rounding(l, norms, static_cast<int>(words[w].size()))});
    }
    out.spectrum_word_length = spectrum_word_length(out.genus);
    out.systole = systole_search(q, residuals, out.spectrum_word_length, out.spectrum);
    out.generators.assign(generators.begin(), generators.end());
    out.generator_low.assign(low.begin(), low.end());
    if (out.generator_low.empty()) out.generator_low.assign(n, Moebius{{0, 0}, {0, 0}});
    out.generator_residuals.assign(residuals.begin(), residuals.end());
    if (out.generator_residuals.empty()) out.generator_residuals.assign(n, 0.0);
    out.fenchel_nielsen = fenchel_nielsen(generators, residuals, low);
    if (out.fenchel_nielsen.status != Status::Ok) {
      out.status = out.fenchel_nielsen.status;
      out.message = out.fenchel_nielsen.message;
      return out;
    }
    out.has_fenchel_nielsen = true;
  } catch (const std::exception& e) {
    out.status = Status::OutOfMemory;
    out.message = std::string("signature: ") + e.what();
    return out;
  }
  out.status = Status::Ok;
  out.message = "ok";
  return out;
}

ConformalSignature conformal_signature(const UniformizeResult& r) {
  ConformalSignature out;
  out.status = Status::InvalidArgument;
  if (r.status != Status::Ok) {
    out.message = "the uniformization did not succeed: " + r.message;
    return out;
  }
  const bool closed = r.has_deck && r.deck.status == Status::Ok;
  out.genus = closed ? r.deck.genus : r.cut.genus;
  out.boundary_loops = closed ? 0 : r.cut.boundary_loops;
  try {
    if (closed) {
      const std::size_t expected = 2 * static_cast<std::size_t>(std::max<Index>(out.genus, 0));
      if (out.genus < 1 || r.deck.generators.size() != expected) {
        out.message = "the deck group has " + std::to_string(r.deck.generators.size()) + " generators for genus " +
                      std::to_string(out.genus);
        return out;
      }
      if (out.genus >= 2) {
        hyperbolic_signature(r.deck, out);  // sets the status itself
        return out;
      }
      if (!torus_signature(r.deck, out)) return out;
    } else if (r.has_cut && r.cut.genus == 0 && r.cut.boundary_loops >= 2 && r.geometry == Geometry::Euclidean &&
               r.boundary == BoundaryMode::Circle) {
      if (!circle_domain_signature(r, out)) return out;
    } else if (r.has_cut && r.cut.boundary_loops >= 1 && r.geometry == Geometry::Hyperbolic &&
               r.boundary == BoundaryMode::Geodesic) {
      if (!boundary_geodesic_signature(r, out)) return out;
    } else {
      out.message = "no signature for this surface: signatures are computed for closed surfaces of genus ≥ 1, "
                    "genus-0 surfaces with ≥ 2 boundary loops laid out as circle domains (E, circle "
                    "boundaries), and hyperbolic surfaces with geodesic boundaries; a disk or a sphere has no "
                    "conformal invariant";
      return out;
    }
  } catch (const std::exception& e) {
    out.status = Status::OutOfMemory;
    out.message = std::string("signature: ") + e.what();
    return out;
  }
  out.status = Status::Ok;
  out.message = "ok";
  return out;
}

}  // namespace ricci
