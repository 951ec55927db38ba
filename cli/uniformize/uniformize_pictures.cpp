// ricci command-line driver — the pictures of `ricci uniformize` (see uniformize_pictures.h).
#include "uniformize_pictures.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <string>
#include <vector>

#include "pictures.h"
#include "ricci/deck.h"

namespace ricci_cli {

namespace {

using ricci::Geometry;
using ricci::Index;
using cplx = std::complex<double>;
constexpr double kPi = std::numbers::pi;

/// Points along the geodesic from z1 to z2 in the Poincaré disk (the segment from 0 to T(z2) in
/// the frame T moving z1 to 0, mapped back), as x, y pairs appended to `points`.
void geodesic_points(cplx z1, cplx z2, int samples, std::vector<double>& points) {
  const ricci::Moebius T = ricci::Moebius::to_origin(z1), back = T.inverse();
  const cplx w = T.apply(z2);
  for (int k = 0; k <= samples; ++k) {
    const cplx z = back.apply(w * (static_cast<double>(k) / samples));
    points.push_back(z.real());
    points.push_back(z.imag());
  }
}

/// The geodesic canonical 4g-gon (sides a_i, a_i^-1 in one colour, b_i, b_i^-1 in another) over
/// its copies under the deck group: the classic tessellation of the disk, words up to length 3
/// (fewer copies when the group is large), copies whose centre lands within |z| < 0.985.
Picture geodesic_polygon_drawing(const ricci::UniformizeResult& r) {
  const ricci::GeodesicPolygon& gp = r.geodesic_polygon;
  const std::size_t n = gp.vertices.size();
  cplx centre = 0;  // the copies are told apart by where they send the corners' mean
  for (const cplx& z : gp.vertices) centre += z / static_cast<double>(n);
  std::vector<ricci::Moebius> letters;
  for (const ricci::DeckGenerator& G : r.deck.generators) {
    letters.push_back(G.map);
    letters.push_back(G.map.inverse());
  }
  std::vector<ricci::Moebius> copies{ricci::Moebius{}};
  std::vector<cplx> seen{centre};
  std::size_t frontier_begin = 0;
  constexpr std::size_t kMaxCopies = 3000;
  for (int depth = 0; depth < 3 && copies.size() < kMaxCopies; ++depth) {
    const std::size_t frontier_end = copies.size();
    for (std::size_t c = frontier_begin; c < frontier_end && copies.size() < kMaxCopies; ++c)
      for (const ricci::Moebius& L : letters) {
        const ricci::Moebius M = (copies[c] * L).normalized();
        const cplx at = M.apply(centre);
        if (!(std::abs(at) < 0.985)) continue;
        bool known = false;
        for (const cplx& q : seen)
          if (ricci::hyperbolic_distance(q, at) < 1e-6) {
            known = true;
            break;
          }
        if (known) continue;
        copies.push_back(M);
        seen.push_back(at);
      }
    frontier_begin = frontier_end;
  }
  Drawing d;
  d.domain = Domain::Disk;
  d.dims = 2;
  d.edge_colour = 0;
  for (std::size_t c = 1; c < copies.size(); ++c) {
    Polyline pl;
    pl.colour = 0x80707A88;
    pl.width = 0.7;
    for (std::size_t k = 0; k < n; ++k)
      geodesic_points(copies[c].apply(gp.vertices[k]), copies[c].apply(gp.vertices[(k + 1) % n]), 16, pl.points);
    d.lines.push_back(std::move(pl));
  }
  for (std::size_t k = 0; k < n; ++k) {
    Polyline pl;
    const std::size_t block = k / 4, in_block = k % 4;
    pl.colour = palette(static_cast<int>(2 * block + (in_block % 2)));
    pl.width = 2.5;
    geodesic_points(gp.vertices[k], gp.vertices[(k + 1) % n], 48, pl.points);
    d.lines.push_back(std::move(pl));
  }
  d.title = "Canonical polygon " + gp.word + " (geodesic, " + std::to_string(copies.size()) + " copies)";
  return draw(d);
}

/// Sides of a cut as polylines over `positions` (2D), one colour per generator (partners share it).
std::vector<Polyline> side_lines(const ricci::CutResult& cut, std::span<const double> positions, double width) {
  std::vector<Polyline> out;
  for (Index s = 0; s < cut.num_sides(); ++s) {
    Polyline pl;
    const Index gen = cut.side_generator[s];
    pl.colour = gen >= 0 ? palette(static_cast<int>(gen)) : 0xFF333333;
    pl.width = width;
    for (Index i = cut.side_offsets[s]; i < cut.side_offsets[s + 1]; ++i) {
      const Index v = cut.side_vertices[i];
      pl.points.push_back(positions[2 * v]);
      pl.points.push_back(positions[2 * v + 1]);
    }
    out.push_back(std::move(pl));
  }
  return out;
}

Drawing disk_drawing(const ricci::CutResult& cut, const ricci::Topology& disk, std::span<const double> positions,
                     Geometry g, const std::string& title) {
  Drawing d;
  for (Index L = 0; L < disk.num_boundary_loops(); ++L)
    d.outline.emplace_back(disk.boundary_vertices.begin() + disk.boundary_offsets[L],
                           disk.boundary_vertices.begin() + disk.boundary_offsets[L + 1]);
  d.domain = g == Geometry::Hyperbolic ? Domain::Disk : Domain::Plane;
  d.positions.assign(positions.begin(), positions.end());
  d.faces = cut.cut_faces;
  d.edge_colour = cut.cut_faces.size() / 3 > 20000 ? 0 : 0x30304050;
  d.lines = side_lines(cut, positions, 2.5);
  d.title = title;
  return d;
}

/// An atlas (layout.h): the root chart with each face coloured by the chart holding it, then the
/// first few other charts, each in its own coordinates (fitted to the picture).
void atlas_pictures(const ricci::UniformizeResult& r, std::vector<NamedPicture>& out) {
  const ricci::LayoutAtlas& a = r.atlas;
  const std::string n = std::to_string(a.num_charts());
  Drawing d = disk_drawing(r.cut, r.disk, r.layout.positions, r.geometry, "Atlas: " + n + " charts");
  d.face_colours.resize(a.face_chart.size());
  for (std::size_t f = 0; f < a.face_chart.size(); ++f)
    d.face_colours[f] = a.face_chart[f] == 0 ? d.face_colour : palette(static_cast<int>(a.face_chart[f]) - 1);
  // A ring around each chart's origin, since its faces are often too small to see here.
  double extent = 0;
  for (double x : r.layout.positions) extent = std::max(extent, std::abs(x));
  for (Index k = 1; k < a.num_charts(); ++k) {
    const Index v = r.disk.corner_vertex[3 * a.charts[static_cast<std::size_t>(k)].seed_face];
    Polyline ring;
    ring.colour = palette(static_cast<int>(k) - 1);
    ring.width = 2;
    for (int i = 0; i <= 48; ++i) {
      const double t = 2 * kPi * i / 48;
      ring.points.push_back(r.layout.positions[2 * v] + 0.04 * extent * std::cos(t));
      ring.points.push_back(r.layout.positions[2 * v + 1] + 0.04 * extent * std::sin(t));
    }
    d.lines.push_back(std::move(ring));
  }
  const Picture p = draw(d);
  out.push_back({"atlas", "The atlas of charts",
                 "One chart's coordinates could not resolve every face, so the layout is an atlas: the first chart "
                 "(pale) and, coloured, the faces held by the other charts where the first chart puts them, each "
                 "circled since they are often too small to see. Each chart is laid out from its own smallest face; "
                 "mesh.obj groups its faces as chart_K with their own texture coordinates.",
                 p.png, p.svg});
  constexpr Index kShown = 3;
  for (Index k = 1; k < a.num_charts() && k <= kShown; ++k) {
    const ricci::LayoutChart& ch = a.charts[static_cast<std::size_t>(k)];
    Drawing c;
    c.domain = Domain::Plane;
    for (std::size_t f = 0; f < a.face_chart.size(); ++f) {
      if (a.face_chart[f] != k) continue;
      for (int q = 0; q < 3; ++q) {
        c.faces.push_back(static_cast<Index>(c.positions.size() / 2));
        c.positions.push_back(a.corner_positions[6 * f + 2 * q]);
        c.positions.push_back(a.corner_positions[6 * f + 2 * q + 1]);
      }
    }
    c.face_colour = palette(static_cast<int>(k) - 1);
    c.edge_colour = c.faces.size() / 3 > 20000 ? 0 : 0x30304050;
    char err[32];
    std::snprintf(err, sizeof err, "%.2g", ch.max_edge_length_error);
    c.title = "Chart " + std::to_string(k) + " of " + n + ": " + std::to_string(ch.faces) + " faces, edge error " + err;
    const Picture q = draw(c);
    out.push_back({"chart-" + std::to_string(k), "Chart " + std::to_string(k),
                   "The faces of chart " + std::to_string(k) + " in its own coordinates (seed face " +
                       std::to_string(ch.seed_face) + " at the origin), fitted to the picture.",
                   q.png, q.svg});
  }
}

}  // namespace

std::vector<double> corner_uv(const ricci::UniformizeResult& r, const ricci::Mesh& surface) {
  std::vector<double> uv;
  const std::size_t nc = surface.faces.size();
  uv.reserve(2 * nc);
  if (r.has_cut) {
    for (std::size_t c = 0; c < nc; ++c) {
      const Index t = surface.corner_texcoords[c];
      uv.push_back(surface.texcoords[2 * t]);
      uv.push_back(surface.texcoords[2 * t + 1]);
    }
    return uv;
  }
  const std::vector<double>& x = r.layout.positions;
  for (std::size_t f = 0; f < nc / 3; ++f) {
    double lon[3], lat[3];
    for (int k = 0; k < 3; ++k) {
      const Index v = surface.faces[3 * f + k];
      lon[k] = std::atan2(x[3 * v + 1], x[3 * v]);
      lat[k] = std::asin(std::clamp(x[3 * v + 2], -1.0, 1.0));
    }
    for (int k = 1; k < 3; ++k) {
      if (lon[k] - lon[0] > kPi) lon[k] -= 2 * kPi;
      if (lon[k] - lon[0] < -kPi) lon[k] += 2 * kPi;
    }
    for (int k = 0; k < 3; ++k) {
      const double y = std::log(std::tan(kPi / 4 + std::clamp(lat[k], -1.5, 1.5) / 2));
      uv.push_back(lon[k]);
      uv.push_back(y);
    }
  }
  return uv;
}

ConformalDistortion conformal_distortion(std::span<const double> positions, std::span<const Index> faces,
                                         std::span<const double> uv) {
  ConformalDistortion out;
  const std::size_t nf = faces.size() / 3;
  std::vector<double> q;
  q.reserve(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    // The triangle in its own plane (a at 0, b on the x axis) and in the texture plane.
    double P[3][3];
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) P[k][d] = positions[3 * faces[3 * f + k] + d];
    double e1[3], e2[3];
    for (int d = 0; d < 3; ++d) {
      e1[d] = P[1][d] - P[0][d];
      e2[d] = P[2][d] - P[0][d];
    }
    const double l1 = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    if (!(l1 > 0)) continue;
    const double x2 = (e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / l1;
    const double y2 = std::sqrt(std::max(0.0, e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2] - x2 * x2));
    if (!(y2 > 0)) continue;
    const double u0 = uv[6 * f], v0 = uv[6 * f + 1];
    const double du1 = uv[6 * f + 2] - u0, dv1 = uv[6 * f + 3] - v0, du2 = uv[6 * f + 4] - u0, dv2 = uv[6 * f + 5] - v0;
    // Jacobian J with J·(l1, 0) = (du1, dv1) and J·(x2, y2) = (du2, dv2).
    const double a = du1 / l1, c = dv1 / l1;
    const double b = (du2 - a * x2) / y2, d = (dv2 - c * x2) / y2;
    // Singular values of [[a, b], [c, d]].
    const double s1 = std::hypot(a + d, c - b) / 2, s2 = std::hypot(a - d, c + b) / 2;
    const double smax = s1 + s2, smin = std::abs(s1 - s2);
    if (!(smin > 0) || !std::isfinite(smax)) continue;
    q.push_back(smax / smin);
  }
  if (q.empty()) return out;
  out.faces = static_cast<Index>(q.size());
  double sum = 0;
  for (double x : q) sum += x;
  out.mean = sum / static_cast<double>(q.size());
  std::sort(q.begin(), q.end());
  out.median = q[q.size() / 2];
  out.p95 = q[std::min(q.size() - 1, static_cast<std::size_t>(0.95 * static_cast<double>(q.size())))];
  out.max = q.back();
  return out;
}

namespace {

/// The fundamental domain (and, in H, the canonical polygon), or the sphere layout.
void domain_pictures(const ricci::UniformizeResult& r, const ricci::Mesh& surface, std::vector<NamedPicture>& out) {
  const Geometry g = r.geometry;
  const std::string gname(ricci::geometry_name(g));
  if (r.has_cut) {
    const bool compact = r.cut.compact;
    const Drawing d = disk_drawing(r.cut, r.disk, r.layout.positions, g,
                                   compact ? std::string(r.cut.boundary_loops > 0 ? "Compact domain (" : "Compact fundamental domain (") +
                                                 std::to_string(r.cut.num_generators()) + " side pairings)"
                                           : "Fundamental domain: " + r.cut.word);
    const Picture p = draw(d);
    out.push_back({"domain", compact ? "The compact fundamental domain" : "The fundamental domain",
                   compact ? "The layout written to mesh.obj: the surface cut along the branches of a cut graph "
                             "grown from a central face, in the Poincaré disk. Paired sides share a colour."
                           : "The cut surface laid out (" + gname + "); sides that are glued together share a colour.",
                   p.png, p.svg});
    if (r.has_geodesic_polygon && !r.has_polygon) {
      const Picture q = geodesic_polygon_drawing(r);
      out.push_back({"polygon", "The canonical fundamental polygon",
                     "The geodesic 4g-gon of the canonical generators (found from the compact domain's side pairings): "
                     "sides a_i, a_i^-1 share a colour, as do b_i, b_i^-1, and each generator maps a side onto its "
                     "partner. Grey: its copies under the deck group, tiling the Poincaré disk.",
                     q.png, q.svg});
    }
    if (r.has_polygon && compact) {
      // The library gives it centred (DomainDeck::polygon_frame).
      const Picture q =
          draw(disk_drawing(r.polygon_cut, r.polygon_disk, r.polygon.positions, g, "Canonical polygon " + r.polygon_cut.word));
      out.push_back({"polygon", "The canonical fundamental polygon",
                     "Sides a_i, b_i and their partners a_i^-1, b_i^-1 share a colour; each deck generator maps a "
                     "side onto its partner. Laid out through the compact domain's tiles.",
                     q.png, q.svg});
    }
  } else {
    Drawing d;
    d.domain = Domain::SphereFront;
    d.dims = 3;
    d.positions = r.layout.positions;
    d.faces = surface.faces;
    d.edge_colour = surface.faces.size() / 3 > 20000 ? 0 : 0x30304050;
    d.title = "Spherical layout (front hemisphere)";
    const Picture p = draw(d);
    out.push_back({"domain", "The layout on the unit sphere",
                   "The round-sphere metric laid out on the unit sphere (Möbius-centred), seen from +z.", p.png, p.svg});
  }

}

/// The universal cover's tiling, when there is one.
void cover_picture(const ricci::UniformizeResult& r, const ricci::CoverResult* cover, std::vector<NamedPicture>& out) {
  const Geometry g = r.geometry;
  if (cover != nullptr && cover->status == ricci::Status::Ok && r.has_cut) {
    const ricci::Mesh tiling = ricci::cover_mesh(r.cut, r.layout.positions, *cover);
    Drawing d;
    d.domain = g == Geometry::Hyperbolic ? Domain::Disk : Domain::Plane;
    d.dims = 2;
    const std::size_t nv = tiling.positions.size() / 3;
    for (std::size_t v = 0; v < nv; ++v) {
      d.positions.push_back(tiling.positions[3 * v]);
      d.positions.push_back(tiling.positions[3 * v + 1]);
    }
    const std::size_t per_copy = r.cut.cut_faces.size() / 3;
    const bool fill = tiling.faces.size() / 3 <= 400000;
    if (fill) {
      d.faces = tiling.faces;
      d.face_colours.resize(tiling.faces.size() / 3);
      for (std::size_t f = 0; f < d.face_colours.size(); ++f) {
        const std::size_t k = per_copy ? f / per_copy : 0;
        const Index len = k < cover->elements.size() ? cover->elements[k].length : 0;
        // Lighter with word length: the identity copy strongest.
        const std::uint32_t base = palette(static_cast<int>(len));
        const auto mix = [&](int shift) {
          const int c = static_cast<int>((base >> shift) & 0xFF);
          return static_cast<std::uint32_t>(c + (255 - c) * std::min<Index>(len, 4) / 6);
        };
        d.face_colours[f] = 0xFF000000u | (mix(16) << 16) | (mix(8) << 8) | mix(0);
      }
      d.edge_colour = 0;
    }
    // Every copy's boundary.
    for (const ricci::CoverElement& e : cover->elements) {
      Polyline pl;
      pl.colour = 0xC0202830;
      pl.width = e.length == 0 ? 2.0 : 0.8;
      for (Index s = 0; s < r.cut.num_sides(); ++s)
        for (Index i = r.cut.side_offsets[s]; i + 1 < r.cut.side_offsets[s + 1]; ++i) {
          const Index v = r.cut.side_vertices[i];
          cplx z(r.layout.positions[2 * v], r.layout.positions[2 * v + 1]);
          z = g == Geometry::Hyperbolic ? e.map.apply(z) : z + cplx(e.translation[0], e.translation[1]);
          pl.points.push_back(z.real());
          pl.points.push_back(z.imag());
        }
      d.lines.push_back(std::move(pl));
    }
    d.title = "Universal cover: " + std::to_string(cover->elements.size()) + " copies";
    const Picture p = draw(d, 900, 900);
    out.push_back({"cover", "The universal cover",
                   "Copies of the fundamental domain moved by the deck group (reduced words up to the cover depth); "
                   "neighbouring copies meet along whole sides, without gaps or overlaps.",
                   p.png, std::string()});
  }

}

/// The histogram of corner-angle ratios.
void angle_picture(const ricci::UniformizeResult& r, std::vector<NamedPicture>& out) {
  if (!r.angles.ratio.empty()) {
    double lo = 1, hi = 1;
    // The 0.5 % and 99.5 % quantiles (two selections, not a sort).
    std::vector<double> q = r.angles.ratio;
    const std::size_t low = q.size() / 200, high = q.size() - 1 - q.size() / 200;
    std::nth_element(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(high), q.end());
    hi = std::max(1.5, q[high]);
    std::nth_element(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(low), q.begin() + static_cast<std::ptrdiff_t>(high));
    lo = std::min(0.5, q[low]);
    const Picture p = histogram(r.angles.ratio, lo, hi, 60, "Corner angles: input / conformal metric", "angle ratio");
    out.push_back({"angles", "Angle distortion",
                   "Corner angles of the input mesh over those of the computed metric (the mapped angles); 1 is perfect.",
                   p.png, p.svg});
  }

}

/// Newton's convergence by iteration and by time.
void convergence_pictures(const ricci::UniformizeResult& r, std::vector<NamedPicture>& out) {
  if (!r.flow.history.empty()) {
    Chart it, tm;
    it.title = "Newton convergence";
    it.x_label = "iteration";
    it.y_label = "max |target K - K|";
    tm = it;
    tm.x_label = "seconds";
    Series si{"newton", {}, {}, palette(0)}, st{"newton", {}, {}, palette(0)};
    for (const ricci::IterationRecord& h : r.flow.history) {
      si.x.push_back(h.iteration);
      si.y.push_back(h.max_error);
      st.x.push_back(h.seconds);
      st.y.push_back(h.max_error);
    }
    it.series.push_back(si);
    tm.series.push_back(st);
    it.reference_y.push_back({1e-6, "the paper's tolerance 1e-6"});
    tm.reference_y = it.reference_y;
    const Picture a = line_chart(it), b = line_chart(tm);
    out.push_back({"convergence", "Convergence by iteration",
                   "max |target K - K| after each Newton step (logarithmic axis): quadratic convergence shows as a "
                   "steepening drop.",
                   a.png, a.svg});
    out.push_back({"convergence-time", "Convergence by time", "The same against wall-clock seconds.", b.png, b.svg});
  }
}

/// The checkerboard rendering from view k of three (azimuths 30°, 150°, 270°), as PNG.
std::string checker_png(const ricci::Mesh& surface, std::span<const double> uv, Geometry g, int k) {
  CheckerOptions co;
  co.checks_across = g == Geometry::Spherical ? 24 : 20;
  const double az[3] = {30, 150, 270};
  CheckerView view;
  view.azimuth_degrees = az[k];
  view.elevation_degrees = 20;
  return encode_png(render_checkerboard(surface.positions, surface.faces, uv, view, co));
}

}  // namespace

std::vector<NamedPicture> uniformize_pictures(const ricci::UniformizeResult& r, const ricci::Mesh& surface,
                                              const ricci::CoverResult* cover, ConformalDistortion* distortion) {
  const Geometry g = r.geometry;
  const std::vector<double> uv = corner_uv(r, surface);
  if (distortion != nullptr) *distortion = conformal_distortion(surface.positions, surface.faces, uv);
  // Two threads: the checkerboards (software rasterizer, no text) on one, the vector drawings
  // (cairo, with text) and the third checkerboard on the other; gathered in a fixed order.
  std::vector<NamedPicture> drawn, charts;
  std::string png[3];
#pragma omp parallel sections num_threads(2)
  {
#pragma omp section
    {
      png[0] = checker_png(surface, uv, g, 0);
      png[2] = checker_png(surface, uv, g, 2);
    }
#pragma omp section
    {
      domain_pictures(r, surface, drawn);
      cover_picture(r, cover, drawn);
      if (r.has_atlas) atlas_pictures(r, drawn);
      angle_picture(r, charts);
      convergence_pictures(r, charts);
      png[1] = checker_png(surface, uv, g, 1);
    }
  }
  std::vector<NamedPicture> out = std::move(drawn);
  for (int k = 0; k < 3; ++k)
    out.push_back({"checker-" + std::to_string(k + 1), "Checkerboard, view " + std::to_string(k + 1),
                   k == 0 ? std::string("The surface textured by its parameterization (") +
                                (g == Geometry::Spherical ? "Mercator projection of the sphere layout" : "the layout") +
                                "). A conformal map keeps checks square; they only change size."
                          : std::string(),
                   std::move(png[k]), std::string()});
  for (NamedPicture& c : charts) out.push_back(std::move(c));
  return out;
}

}  // namespace ricci_cli
