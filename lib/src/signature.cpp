// ricci — conformal shape signatures (see signature.h): the flat torus's reduced modulus and the
// hyperbolic lengths of a fixed list of words, from the deck group of a UniformizeResult.
#include "ricci/signature.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace ricci {

namespace {

constexpr double kTie = 1e-12;

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

void hyperbolic_signature(const DeckResult& deck, ConformalSignature& out) {
  std::vector<std::string> names;
  const auto words = signature_words(deck.genus, &names);
  out.words.clear();
  for (std::size_t w = 0; w < words.size(); ++w) {
    Moebius m;
    double residual = 0;
    for (const auto& [gen, sign] : words[w]) {
      const DeckGenerator& g = deck.generators[static_cast<std::size_t>(gen)];
      m = m * (sign > 0 ? g.map : g.map.inverse());
      residual += g.residual_max;
    }
    out.words.push_back({names[w], m.normalized().translation_length(), 2 * residual});
  }
  out.systole = *std::min_element(out.words.begin(), out.words.end(),
                                  [](const WordLength& x, const WordLength& y) { return x.length < y.length; });
}

}  // namespace

ConformalSignature conformal_signature(const UniformizeResult& r) {
  ConformalSignature out;
  out.status = Status::InvalidArgument;
  if (r.status != Status::Ok) {
    out.message = "the uniformization did not succeed: " + r.message;
    return out;
  }
  if (!r.has_deck || r.deck.status != Status::Ok) {
    out.message = "no deck group: signatures are computed for closed surfaces of genus ≥ 1 so far (genus 0 "
                  "with boundary loops and hyperbolic surfaces with geodesic boundaries are not yet covered)";
    return out;
  }
  out.genus = r.deck.genus;
  const std::size_t expected = 2 * static_cast<std::size_t>(std::max<Index>(out.genus, 0));
  if (out.genus < 1 || r.deck.generators.size() != expected) {
    out.message = "the deck group has " + std::to_string(r.deck.generators.size()) + " generators for genus " +
                  std::to_string(out.genus);
    return out;
  }
  try {
    if (out.genus == 1) {
      if (!torus_signature(r.deck, out)) return out;
    } else {
      hyperbolic_signature(r.deck, out);
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
