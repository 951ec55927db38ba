// The universal cover: group elements as reduced words in the deck generators, deduplicated by
// the image of a reference point; the tiling as a mesh (coincident boundary vertices merged) and
// as SVG. Conventions: ricci/deck.h.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <deque>
#include <map>
#include <string>

#include "ricci/deck.h"

namespace ricci {

using cplx = std::complex<double>;

bool CoverOptions::is_valid(std::string* why) const {
  auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (depth < 0 || depth > 64) return fail("CoverOptions::depth must be in 0..64.");
  if (!(radius > 0) || !(radius <= 1)) return fail("CoverOptions::radius must be in (0, 1].");
  if (!(dedup_tolerance > 0) || !std::isfinite(dedup_tolerance))
    return fail("CoverOptions::dedup_tolerance must be finite and positive.");
  if (max_copies < 1) return fail("CoverOptions::max_copies must be at least 1.");
  return true;
}

namespace {

bool positions_match(const CutResult& cut, std::span<const double> positions) {
  if (positions.size() != static_cast<std::size_t>(cut.num_cut_vertices()) * 2) return false;
  for (double x : positions)
    if (!std::isfinite(x)) return false;
  for (Index v : cut.cut_faces)
    if (v < 0 || v >= cut.num_cut_vertices()) return false;
  for (Index v : cut.side_vertices)
    if (v < 0 || v >= cut.num_cut_vertices()) return false;
  return true;
}

/// Mean of the cut vertices: the reference point (any point works, the group acts freely).
cplx reference_point(std::span<const double> positions) {
  cplx c = 0;
  const std::size_t n = positions.size() / 2;
  for (std::size_t v = 0; v < n; ++v) c += cplx(positions[2 * v], positions[2 * v + 1]);
  return n ? c / double(n) : c;
}

/// "a1^m" in the power notation used for E words ("" for m = 0, "a1" for m = 1).
std::string power(const std::string& name, long m) {
  if (m == 0) return {};
  if (m == 1) return name;
  return name + "^" + std::to_string(m);
}

}  // namespace

CoverResult universal_cover(const CutResult& cut, std::span<const double> positions, const DeckResult& deck,
                            const CoverOptions& options) {
  CoverResult r;
  r.geometry = deck.geometry;
  std::string why;
  if (!options.is_valid(&why)) {
    r.status = Status::InvalidArgument;
    r.message = why;
    return r;
  }
  if (deck.status != Status::Ok || deck.generators.empty()) {
    r.status = Status::InvalidArgument;
    r.message = "the deck transformations are not valid.";
    return r;
  }
  if (!positions_match(cut, positions)) {
    r.status = Status::InvalidArgument;
    r.message = "positions do not match the cut (#cut vertices x 2 finite values).";
    return r;
  }

  if (deck.geometry == Geometry::Euclidean) {
    const auto& ta = deck.generators[0].translation;
    const auto& tb = deck.generators[1].translation;
    const long k = options.depth < 1 ? 1 : options.depth;
    const long h = (k - 1) / 2;
    std::vector<CoverElement> els;
    for (long m = -h; m < k - h; ++m)
      for (long n = -h; n < k - h; ++n) {
        CoverElement e;
        e.length = static_cast<Index>(std::abs(m) + std::abs(n));
        const std::string wa = power(deck.generators[0].name, m), wb = power(deck.generators[1].name, n);
        e.word = wa.empty() ? wb : (wb.empty() ? wa : wa + " " + wb);
        e.translation = {double(m) * ta[0] + double(n) * tb[0], double(m) * ta[1] + double(n) * tb[1]};
        els.push_back(std::move(e));
      }
    std::stable_sort(els.begin(), els.end(), [](const CoverElement& x, const CoverElement& y) { return x.length < y.length; });
    r.words_generated = static_cast<Index>(els.size());
    if (static_cast<Index>(els.size()) > options.max_copies) {
      els.resize(static_cast<std::size_t>(options.max_copies));
      r.truncated = true;
    }
    r.elements = std::move(els);
    r.status = Status::Ok;
    r.message = std::to_string(r.elements.size()) + " translates.";
    return r;
  }

  // H: breadth-first over reduced words, right-multiplying by letters (so a word's successors
  // are the copies adjacent to its own), deduplicated by the image of the reference point.
  const std::size_t ng = deck.generators.size();
  std::vector<Moebius> letter(2 * ng);
  std::vector<std::string> letter_name(2 * ng);
  for (std::size_t i = 0; i < ng; ++i) {
    letter[2 * i] = deck.generators[i].map;
    letter[2 * i + 1] = deck.generators[i].map.inverse();
    letter_name[2 * i] = deck.generators[i].name;
    letter_name[2 * i + 1] = deck.generators[i].name + "^-1";
  }
  const cplx c = reference_point(positions);
  // Found images sorted by real part; a new image is a duplicate when a stored one lies within
  // dedup_tolerance (hyperbolic). Euclidean |Δz| ≤ d/2, so only |ΔRe| ≤ tol/2 needs checking.
  std::multimap<double, std::size_t> seen;
  auto find_dup = [&](cplx p) {
    const double w = options.dedup_tolerance / 2;
    for (auto it = seen.lower_bound(p.real() - w); it != seen.end() && it->first <= p.real() + w; ++it)
      if (hyperbolic_distance(r.elements[it->second].map.apply(c), p) < options.dedup_tolerance) return true;
    return false;
  };
  struct Node {
    std::size_t element;
    int last;  // letter index, -1 for the identity
  };
  std::deque<Node> queue;
  r.elements.push_back(CoverElement{});
  seen.emplace(c.real(), 0);
  queue.push_back({0, -1});
  r.words_generated = 1;
  while (!queue.empty() && !r.truncated) {
    const Node node = queue.front();
    queue.pop_front();
    const CoverElement base = r.elements[node.element];
    if (base.length >= options.depth) continue;
    for (int l = 0; l < static_cast<int>(2 * ng); ++l) {
      if (node.last >= 0 && (l ^ 1) == node.last) continue;  // reduced: no x x^-1
      ++r.words_generated;
      const Moebius M = (base.map * letter[static_cast<std::size_t>(l)]).normalized();
      const cplx p = M.apply(c);
      const double rp = std::abs(p);
      if (!(rp <= options.radius) || !(rp < 1) || !std::isfinite(rp)) continue;
      if (find_dup(p)) continue;
      CoverElement e;
      e.map = M;
      e.length = base.length + 1;
      e.word = base.word.empty() ? letter_name[static_cast<std::size_t>(l)]
                                 : base.word + " " + letter_name[static_cast<std::size_t>(l)];
      r.elements.push_back(std::move(e));
      seen.emplace(p.real(), r.elements.size() - 1);
      queue.push_back({r.elements.size() - 1, l});
      if (static_cast<Index>(r.elements.size()) >= options.max_copies) {
        r.truncated = true;
        break;
      }
    }
  }
  r.status = Status::Ok;
  r.message = std::to_string(r.elements.size()) + " distinct elements from " + std::to_string(r.words_generated) +
              " reduced words" + (r.truncated ? " (truncated at max_copies)." : ".");
  return r;
}

namespace {

/// Position of cut vertex v in the copy of element e.
cplx copy_position(const CoverResult& cover, const CoverElement& e, std::span<const double> positions, Index v) {
  const cplx z(positions[2 * v], positions[2 * v + 1]);
  if (cover.geometry == Geometry::Euclidean) return z + cplx(e.translation[0], e.translation[1]);
  return e.map.apply(z);
}

}  // namespace

Mesh cover_mesh(const CutResult& cut, std::span<const double> positions, const CoverResult& cover,
                double merge_tolerance) {
  Mesh out;
  if (cover.status != Status::Ok || !positions_match(cut, positions) || !(merge_tolerance >= 0)) return out;
  const Index nv = cut.num_cut_vertices();
  std::vector<char> on_boundary(static_cast<std::size_t>(nv), 0);
  for (Index v : cut.side_vertices) on_boundary[v] = 1;
  double tol_e = merge_tolerance;
  if (cover.geometry == Geometry::Euclidean) {
    double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
    for (Index v = 0; v < nv; ++v) {
      xmin = std::min(xmin, positions[2 * v]);
      xmax = std::max(xmax, positions[2 * v]);
      ymin = std::min(ymin, positions[2 * v + 1]);
      ymax = std::max(ymax, positions[2 * v + 1]);
    }
    tol_e = merge_tolerance * std::hypot(xmax - xmin, ymax - ymin);
  }
  const double window = cover.geometry == Geometry::Euclidean ? tol_e : merge_tolerance / 2;
  std::vector<Index> rep;  // copy vertex → output vertex
  rep.reserve(cover.elements.size() * static_cast<std::size_t>(nv));
  std::multimap<double, Index> boundary_seen;  // Re z → output vertex
  for (const CoverElement& e : cover.elements) {
    for (Index v = 0; v < nv; ++v) {
      const cplx z = copy_position(cover, e, positions, v);
      Index found = kInvalid;
      if (on_boundary[v]) {
        for (auto it = boundary_seen.lower_bound(z.real() - window);
             it != boundary_seen.end() && it->first <= z.real() + window && found == kInvalid; ++it) {
          const cplx q(out.positions[3 * it->second], out.positions[3 * it->second + 1]);
          const double d = cover.geometry == Geometry::Euclidean ? std::abs(z - q) : hyperbolic_distance(z, q);
          if (d <= (cover.geometry == Geometry::Euclidean ? tol_e : merge_tolerance)) found = it->second;
        }
      }
      if (found == kInvalid) {
        found = out.num_vertices();
        out.positions.insert(out.positions.end(), {z.real(), z.imag(), 0.0});
        if (on_boundary[v]) boundary_seen.emplace(z.real(), found);
      }
      rep.push_back(found);
    }
  }
  for (std::size_t k = 0; k < cover.elements.size(); ++k)
    for (Index v : cut.cut_faces) out.faces.push_back(rep[k * static_cast<std::size_t>(nv) + static_cast<std::size_t>(v)]);
  return out;
}

namespace {

void put(std::string& s, double x) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, x, std::chars_format::fixed, 6);
  s.append(buf, res.ptr);
}

}  // namespace

std::string cover_svg(const CutResult& cut, std::span<const double> positions, const CoverResult& cover) {
  if (cover.status != Status::Ok || !positions_match(cut, positions)) return {};
  // The polygon boundary: every side without its last vertex (the next side's first).
  std::vector<Index> loop;
  for (Index s = 0; s < cut.num_sides(); ++s)
    for (Index i = cut.side_offsets[s]; i + 1 < cut.side_offsets[s + 1]; ++i) loop.push_back(cut.side_vertices[i]);
  static const char* kPalette[] = {"#f4d35e", "#ee964b", "#f95738", "#0d3b66", "#3f88c5",
                                   "#44bba4", "#a1c181", "#e94f37", "#7d5ba6", "#c3bef0"};
  double xmin = -1.05, xmax = 1.05, ymin = -1.05, ymax = 1.05;
  if (cover.geometry == Geometry::Euclidean) {
    xmin = ymin = 1e300;
    xmax = ymax = -1e300;
    for (const CoverElement& e : cover.elements)
      for (Index v : loop) {
        const cplx z = copy_position(cover, e, positions, v);
        xmin = std::min(xmin, z.real());
        xmax = std::max(xmax, z.real());
        ymin = std::min(ymin, z.imag());
        ymax = std::max(ymax, z.imag());
      }
    if (!(xmax >= xmin)) xmin = xmax = ymin = ymax = 0;
    const double m = 0.02 * std::max({xmax - xmin, ymax - ymin, 1e-9});
    xmin -= m;
    xmax += m;
    ymin -= m;
    ymax += m;
  }
  std::string s;
  s += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"800\" height=\"";
  put(s, 800 * (ymax - ymin) / (xmax - xmin));
  s += "\" viewBox=\"";
  put(s, xmin);
  s += ' ';
  put(s, -ymax);
  s += ' ';
  put(s, xmax - xmin);
  s += ' ';
  put(s, ymax - ymin);
  s += "\">\n<g transform=\"scale(1,-1)\">\n";
  if (cover.geometry == Geometry::Hyperbolic)
    s += "<circle cx=\"0\" cy=\"0\" r=\"1\" fill=\"#ffffff\" stroke=\"#000000\" stroke-width=\"1\" "
         "vector-effect=\"non-scaling-stroke\"/>\n";
  for (const CoverElement& e : cover.elements) {
    s += "<polygon fill=\"";
    s += kPalette[static_cast<std::size_t>(e.length) % (sizeof kPalette / sizeof kPalette[0])];
    s += "\" fill-opacity=\"0.75\" stroke=\"#202020\" stroke-width=\"0.5\" vector-effect=\"non-scaling-stroke\" points=\"";
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const cplx z = copy_position(cover, e, positions, loop[i]);
      if (i) s += ' ';
      put(s, z.real());
      s += ',';
      put(s, z.imag());
    }
    s += "\"><title>";
    s += e.word.empty() ? std::string("1") : e.word;
    s += "</title></polygon>\n";
  }
  s += "</g>\n</svg>\n";
  return s;
}

}  // namespace ricci
