// Pictures: see pictures.h. Raster work is our own (the checkerboard rasterizer); vector
// drawings and charts go through cairo, once onto an image surface (PNG) and once onto an SVG
// surface, from the same drawing code.
#include "pictures.h"

#include <cairo-svg.h>
#include <cairo.h>
#include <fontconfig/fontconfig.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <functional>
#include <mutex>
#include <limits>
#include <numbers>

namespace ricci_cli {

namespace {

constexpr double kPi = std::numbers::pi;

cairo_status_t append_bytes(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

struct ReadState {
  const std::string* bytes;
  std::size_t offset;
};

cairo_status_t read_bytes(void* closure, unsigned char* data, unsigned int length) {
  auto* s = static_cast<ReadState*>(closure);
  if (s->offset + length > s->bytes->size()) return CAIRO_STATUS_READ_ERROR;
  std::memcpy(data, s->bytes->data() + s->offset, length);
  s->offset += length;
  return CAIRO_STATUS_SUCCESS;
}

void set_colour(cairo_t* cr, std::uint32_t argb) {
  const double a = ((argb >> 24) & 0xFF) / 255.0;
  cairo_set_source_rgba(cr, ((argb >> 16) & 0xFF) / 255.0, ((argb >> 8) & 0xFF) / 255.0, (argb & 0xFF) / 255.0, a);
}

// Runs `paint(cr, width, height)` on an image surface and on an SVG surface.
Picture render_both(int width, int height, const std::function<void(cairo_t*, int, int)>& paint) {
  Picture out;
  {
    cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, width, height);
    cairo_t* cr = cairo_create(surface);
    paint(cr, width, height);
    cairo_destroy(cr);
    cairo_surface_flush(surface);
    if (cairo_surface_status(surface) == CAIRO_STATUS_SUCCESS &&
        cairo_surface_write_to_png_stream(surface, append_bytes, &out.png) != CAIRO_STATUS_SUCCESS)
      out.png.clear();
    cairo_surface_destroy(surface);
  }
  {
    cairo_surface_t* surface = cairo_svg_surface_create_for_stream(append_bytes, &out.svg, width, height);
    cairo_t* cr = cairo_create(surface);
    paint(cr, width, height);
    cairo_destroy(cr);
    cairo_surface_finish(surface);
    if (cairo_surface_status(surface) != CAIRO_STATUS_SUCCESS) out.svg.clear();
    cairo_surface_destroy(surface);
  }
  return out;
}

std::string format(const char* f, double x) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, f, x);
  return buffer;
}

// Text loads fontconfig's and cairo's font caches, which live until the process ends. They are
// released at exit, so that leak checkers (LeakSanitizer in the test runs) see a clean process.
void release_font_caches() {
  cairo_debug_reset_static_data();
  FcFini();
}

void draw_text(cairo_t* cr, double x, double y, const std::string& text, double size, bool centred = false,
               std::uint32_t colour = 0xFF202020) {
  static std::once_flag registered;
  std::call_once(registered, [] { std::atexit(release_font_caches); });
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
  set_colour(cr, colour);
  double dx = 0;
  if (centred) {
    cairo_text_extents_t e;
    cairo_text_extents(cr, text.c_str(), &e);
    dx = -e.width / 2 - e.x_bearing;
  }
  cairo_move_to(cr, x + dx, y);
  cairo_show_text(cr, text.c_str());
}

std::uint32_t blend(std::uint32_t colour, double shade) {
  auto channel = [&](int shift) {
    const double c = ((colour >> shift) & 0xFF) * shade;
    return static_cast<std::uint32_t>(std::clamp(c, 0.0, 255.0) + 0.5) << shift;
  };
  return 0xFF000000u | channel(16) | channel(8) | channel(0);
}

}  // namespace

std::uint32_t palette(int index) {
  static const std::uint32_t colours[] = {0xFFD62728, 0xFF1F77B4, 0xFF2CA02C, 0xFFFF7F0E, 0xFF9467BD,
                                          0xFF8C564B, 0xFFE377C2, 0xFF17BECF, 0xFFBCBD22, 0xFF7F7F7F};
  const int n = static_cast<int>(std::size(colours));
  return colours[((index % n) + n) % n];
}

std::string encode_png(const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height))
    return {};
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, image.width, image.height);
  if (cairo_surface_status(surface) != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(surface);
    return {};
  }
  cairo_surface_flush(surface);
  unsigned char* data = cairo_image_surface_get_data(surface);
  const int stride = cairo_image_surface_get_stride(surface);
  for (int y = 0; y < image.height; ++y)
    std::memcpy(data + static_cast<std::size_t>(y) * stride, image.pixels.data() + static_cast<std::size_t>(y) * image.width,
                static_cast<std::size_t>(image.width) * 4);
  cairo_surface_mark_dirty(surface);
  std::string out;
  if (cairo_surface_write_to_png_stream(surface, append_bytes, &out) != CAIRO_STATUS_SUCCESS) out.clear();
  cairo_surface_destroy(surface);
  return out;
}

Image decode_png(const std::string& bytes) {
  Image image;
  ReadState state{&bytes, 0};
  cairo_surface_t* surface = cairo_image_surface_create_from_png_stream(read_bytes, &state);
  if (cairo_surface_status(surface) == CAIRO_STATUS_SUCCESS &&
      (cairo_image_surface_get_format(surface) == CAIRO_FORMAT_ARGB32 ||
       cairo_image_surface_get_format(surface) == CAIRO_FORMAT_RGB24)) {
    cairo_surface_flush(surface);
    image.width = cairo_image_surface_get_width(surface);
    image.height = cairo_image_surface_get_height(surface);
    const int stride = cairo_image_surface_get_stride(surface);
    const unsigned char* data = cairo_image_surface_get_data(surface);
    if (data && image.width > 0 && image.height > 0) {
      image.pixels.resize(static_cast<std::size_t>(image.width) * image.height);
      for (int y = 0; y < image.height; ++y)
        std::memcpy(image.pixels.data() + static_cast<std::size_t>(y) * image.width,
                    data + static_cast<std::size_t>(y) * stride, static_cast<std::size_t>(image.width) * 4);
      if (cairo_image_surface_get_format(surface) == CAIRO_FORMAT_RGB24)
        for (std::uint32_t& p : image.pixels) p |= 0xFF000000u;
    } else {
      image = Image{};
    }
  }
  cairo_surface_destroy(surface);
  return image;
}

// ---------------------------------------------------------------------------------------------
// Checkerboard rasterizer: orthographic camera, z-buffer, per-sample texture lookup, head light.

Image render_checkerboard(std::span<const double> positions, std::span<const ricci::Index> faces,
                          std::span<const double> corner_uv, const CheckerView& view, const CheckerOptions& options,
                          CheckerStats* stats) {
  Image image;
  const int ss = std::clamp(options.supersample, 1, 4);
  const int W = std::max(1, options.width), H = std::max(1, options.height);
  image.width = W;
  image.height = H;
  image.pixels.assign(static_cast<std::size_t>(W) * H, options.background);
  const std::size_t nv = positions.size() / 3, nf = faces.size() / 3;
  if (nv == 0 || nf == 0 || corner_uv.size() != nf * 6) return image;

  // Camera frame: forward d (from the camera towards the scene), right r, up u.
  const double az = view.azimuth_degrees * kPi / 180, el = view.elevation_degrees * kPi / 180;
  const double d[3] = {-std::cos(el) * std::sin(az), -std::sin(el), -std::cos(el) * std::cos(az)};
  const double r[3] = {std::cos(az), 0.0, -std::sin(az)};
  const double u[3] = {r[1] * d[2] - r[2] * d[1], r[2] * d[0] - r[0] * d[2], r[0] * d[1] - r[1] * d[0]};
  std::vector<double> sx(nv), sy(nv), depth(nv);
  double lo_x = std::numeric_limits<double>::infinity(), hi_x = -lo_x, lo_y = lo_x, hi_y = -lo_x;
  for (std::size_t v = 0; v < nv; ++v) {
    const double* p = &positions[3 * v];
    sx[v] = p[0] * r[0] + p[1] * r[1] + p[2] * r[2];
    sy[v] = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
    depth[v] = p[0] * d[0] + p[1] * d[1] + p[2] * d[2];
    if (!std::isfinite(sx[v]) || !std::isfinite(sy[v])) continue;
    lo_x = std::min(lo_x, sx[v]);
    hi_x = std::max(hi_x, sx[v]);
    lo_y = std::min(lo_y, sy[v]);
    hi_y = std::max(hi_y, sy[v]);
  }
  if (!(hi_x >= lo_x) || !(hi_y >= lo_y)) return image;
  const int SW = W * ss, SH = H * ss;
  const double margin = 0.05;
  const double scale = std::min(SW * (1 - 2 * margin) / std::max(hi_x - lo_x, 1e-300),
                                SH * (1 - 2 * margin) / std::max(hi_y - lo_y, 1e-300));
  const double ox = 0.5 * SW - scale * 0.5 * (lo_x + hi_x), oy = 0.5 * SH + scale * 0.5 * (lo_y + hi_y);
  for (std::size_t v = 0; v < nv; ++v) {
    sx[v] = ox + scale * sx[v];
    sy[v] = oy - scale * sy[v];  // image rows grow downwards
  }
  // Texture scale: `checks_across` squares over the longer side of the uv bounding box.
  double ulo = std::numeric_limits<double>::infinity(), uhi = -ulo, vlo = ulo, vhi = -ulo;
  for (std::size_t k = 0; k < nf * 3; ++k) {
    const double a = corner_uv[2 * k], b = corner_uv[2 * k + 1];
    if (!std::isfinite(a) || !std::isfinite(b)) continue;
    ulo = std::min(ulo, a);
    uhi = std::max(uhi, a);
    vlo = std::min(vlo, b);
    vhi = std::max(vhi, b);
  }
  const double span = std::max(uhi - ulo, vhi - vlo);
  const double frequency = span > 0 && options.checks_across > 0 ? options.checks_across / span : 1.0;

  std::vector<double> zbuf(static_cast<std::size_t>(SW) * SH, std::numeric_limits<double>::infinity());
  std::vector<std::uint32_t> colour(static_cast<std::size_t>(SW) * SH, options.background);
  for (std::size_t f = 0; f < nf; ++f) {
    const ricci::Index a = faces[3 * f], b = faces[3 * f + 1], c = faces[3 * f + 2];
    if (a < 0 || b < 0 || c < 0 || static_cast<std::size_t>(std::max({a, b, c})) >= nv) continue;
    // Shading: |n · d| with the face normal in 3D (a head light; both sides lit).
    const double* pa = &positions[3 * a];
    const double* pb = &positions[3 * b];
    const double* pc = &positions[3 * c];
    const double e1[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]};
    const double e2[3] = {pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const double shade = nn > 0 ? 0.35 + 0.65 * std::abs(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / nn : 0.35;
    const double x0 = sx[a], y0 = sy[a], x1 = sx[b], y1 = sy[b], x2 = sx[c], y2 = sy[c];
    const double area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    if (!(std::abs(area) > 0) || !std::isfinite(area)) continue;
    const int min_x = std::max(0, static_cast<int>(std::floor(std::min({x0, x1, x2}))));
    const int max_x = std::min(SW - 1, static_cast<int>(std::ceil(std::max({x0, x1, x2}))));
    const int min_y = std::max(0, static_cast<int>(std::floor(std::min({y0, y1, y2}))));
    const int max_y = std::min(SH - 1, static_cast<int>(std::ceil(std::max({y0, y1, y2}))));
    const double* uv = &corner_uv[6 * f];
    const bool textured = std::isfinite(uv[0] + uv[1] + uv[2] + uv[3] + uv[4] + uv[5]);
    // Barycentric coordinates (w0, w1, w2) of the samples, affine in the sample position: stepped
    // along each row.
    const double inv = 1 / area;
    const double w1_dx = (y2 - y0) * inv, w2_dx = -(y1 - y0) * inv;
    for (int py = min_y; py <= max_y; ++py) {
      const double qx0 = min_x + 0.5, qy = py + 0.5;
      double w1 = ((qx0 - x0) * (y2 - y0) - (x2 - x0) * (qy - y0)) * inv;
      double w2 = ((x1 - x0) * (qy - y0) - (qx0 - x0) * (y1 - y0)) * inv;
      for (int px = min_x; px <= max_x; ++px, w1 += w1_dx, w2 += w2_dx) {
        const double w0 = 1 - w1 - w2;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const double z = w0 * depth[a] + w1 * depth[b] + w2 * depth[c];
        const std::size_t at = static_cast<std::size_t>(py) * SW + px;
        if (!(z < zbuf[at])) continue;
        zbuf[at] = z;
        std::uint32_t base = 0xFF9A9A9A;
        if (textured) {
          const double tu = (w0 * uv[0] + w1 * uv[2] + w2 * uv[4] - ulo) * frequency;
          const double tv = (w0 * uv[1] + w1 * uv[3] + w2 * uv[5] - vlo) * frequency;
          const long long parity = static_cast<long long>(std::floor(tu)) + static_cast<long long>(std::floor(tv));
          base = (parity & 1) ? options.dark : options.light;
        }
        colour[at] = blend(base, shade);
      }
    }
  }
  // Downsample (box filter) and count.
  CheckerStats counted;
  auto channel = [](std::uint32_t p, int shift) { return static_cast<double>((p >> shift) & 0xFF); };
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      double sum[3] = {0, 0, 0};
      int hits = 0;
      for (int j = 0; j < ss; ++j)
        for (int i = 0; i < ss; ++i) {
          const std::size_t at = static_cast<std::size_t>(y * ss + j) * SW + (x * ss + i);
          const std::uint32_t p = colour[at];
          sum[0] += channel(p, 16);
          sum[1] += channel(p, 8);
          sum[2] += channel(p, 0);
          hits += std::isfinite(zbuf[at]) ? 1 : 0;
        }
      const double n = ss * ss;
      const std::uint32_t p = 0xFF000000u | (static_cast<std::uint32_t>(sum[0] / n + 0.5) << 16) |
                              (static_cast<std::uint32_t>(sum[1] / n + 0.5) << 8) |
                              static_cast<std::uint32_t>(sum[2] / n + 0.5);
      image.pixels[static_cast<std::size_t>(y) * W + x] = p;
      if (hits * 2 > ss * ss) {
        ++counted.covered_pixels;
        // Which check colour is the pixel closer to (in hue, ignoring the shading)?
        const double s = std::max({channel(p, 16), channel(p, 8), channel(p, 0), 1.0});
        auto distance = [&](std::uint32_t q) {
          const double t = std::max({channel(q, 16), channel(q, 8), channel(q, 0), 1.0});
          double d2 = 0;
          for (int shift : {16, 8, 0}) {
            const double e = channel(p, shift) / s - channel(q, shift) / t;
            d2 += e * e;
          }
          return d2;
        };
        if (distance(options.light) < distance(options.dark))
          ++counted.light_pixels;
        else
          ++counted.dark_pixels;
      }
    }
  }
  if (stats) *stats = counted;
  return image;
}

// ---------------------------------------------------------------------------------------------
// 2D drawings.

namespace {

/// The outline of a set of consistently oriented triangles (`order` indexes `faces`): the directed
/// edges whose reverse is not an edge of the set, chained into closed loops (at a vertex where
/// several loops touch, any outgoing edge continues the walk: every edge is used once, so the
/// loops still bound the union, and their winding number at a point counts the triangles over it).
std::vector<std::vector<ricci::Index>> outline_loops(std::span<const ricci::Index> faces,
                                                     std::span<const std::size_t> order) {
  std::vector<std::uint64_t> directed;
  directed.reserve(3 * order.size());
  auto key = [](ricci::Index a, ricci::Index b) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
  };
  for (const std::size_t f : order)
    for (int k = 0; k < 3; ++k) directed.push_back(key(faces[3 * f + k], faces[3 * f + (k + 1) % 3]));
  std::sort(directed.begin(), directed.end());
  std::vector<std::pair<ricci::Index, ricci::Index>> border;  // (from, to), sorted by from
  for (const std::uint64_t e : directed) {
    const auto a = static_cast<ricci::Index>(e >> 32), b = static_cast<ricci::Index>(e & 0xFFFFFFFFu);
    if (!std::binary_search(directed.begin(), directed.end(), key(b, a))) border.emplace_back(a, b);
  }
  std::vector<char> used(border.size(), 0);
  auto first_from = [&](ricci::Index a) {
    return static_cast<std::size_t>(std::lower_bound(border.begin(), border.end(), std::make_pair(a, ricci::Index{-1})) -
                                    border.begin());
  };
  std::vector<std::vector<ricci::Index>> loops;
  for (std::size_t s = 0; s < border.size(); ++s) {
    if (used[s]) continue;
    std::vector<ricci::Index> loop;
    std::size_t e = s;
    while (true) {
      used[e] = 1;
      loop.push_back(border[e].first);
      const ricci::Index next = border[e].second;
      std::size_t n = first_from(next);
      while (n < border.size() && border[n].first == next && used[n]) ++n;
      if (n >= border.size() || border[n].first != next) break;  // back at the start (or an open chain)
      e = n;
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

}  // namespace

Picture draw(const Drawing& g, int width, int height) {
  return render_both(width, height, [&](cairo_t* cr, int w, int h) {
    set_colour(cr, 0xFFFFFFFF);
    cairo_paint(cr);
    const int dims = g.dims == 3 ? 3 : 2;
    const std::size_t nv = g.positions.size() / static_cast<std::size_t>(dims);
    // The view box in drawing coordinates.
    double lo_x = -1, hi_x = 1, lo_y = -1, hi_y = 1;
    if (g.domain == Domain::Plane) {
      lo_x = lo_y = std::numeric_limits<double>::infinity();
      hi_x = hi_y = -lo_x;
      auto extend = [&](double x, double y) {
        if (!std::isfinite(x) || !std::isfinite(y)) return;
        lo_x = std::min(lo_x, x);
        hi_x = std::max(hi_x, x);
        lo_y = std::min(lo_y, y);
        hi_y = std::max(hi_y, y);
      };
      for (std::size_t v = 0; v < nv; ++v) extend(g.positions[dims * v], g.positions[dims * v + 1]);
      for (const Polyline& l : g.lines)
        for (std::size_t k = 0; k + 1 < l.points.size(); k += 2) extend(l.points[k], l.points[k + 1]);
      if (!(hi_x >= lo_x)) lo_x = -1, hi_x = 1, lo_y = -1, hi_y = 1;
    }
    const double title_space = g.title.empty() ? 0 : 30;
    const double margin = 20;
    const double sx = (w - 2 * margin) / std::max(hi_x - lo_x, 1e-300);
    const double sy = (h - 2 * margin - title_space) / std::max(hi_y - lo_y, 1e-300);
    const double s = std::min(sx, sy);
    const double cx = 0.5 * w - s * 0.5 * (lo_x + hi_x), cy = title_space + 0.5 * (h - title_space) + s * 0.5 * (lo_y + hi_y);
    auto X = [&](double x) { return cx + s * x; };
    auto Y = [&](double y) { return cy - s * y; };
    if (!g.title.empty()) draw_text(cr, 0.5 * w, 22, g.title, 16, true);
    if (g.domain != Domain::Plane) {
      cairo_new_path(cr);  // the title's text leaves a current point; the circle must not join it
      cairo_arc(cr, X(0), Y(0), s, 0, 2 * kPi);
      set_colour(cr, 0xFFF7F7F7);
      cairo_fill_preserve(cr);
      set_colour(cr, 0xFF404040);
      cairo_set_line_width(cr, 1.5);
      cairo_stroke(cr);
    }
    // Faces (for the sphere: those facing +z, back to front).
    const std::size_t nf = g.faces.size() / 3;
    std::vector<std::size_t> order;
    order.reserve(nf);
    std::vector<double> face_z(nf, 0.0);
    for (std::size_t f = 0; f < nf; ++f) {
      bool ok = true;
      for (int k = 0; k < 3; ++k) ok = ok && g.faces[3 * f + k] >= 0 && static_cast<std::size_t>(g.faces[3 * f + k]) < nv;
      if (!ok) continue;
      if (g.domain == Domain::SphereFront) {
        double z = 0;
        for (int k = 0; k < 3; ++k) z += g.positions[3 * g.faces[3 * f + k] + 2];
        if (z <= 0) continue;
        face_z[f] = z;
      }
      order.push_back(f);
    }
    if (g.domain == Domain::SphereFront)
      std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return face_z[a] < face_z[b]; });
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
    // A closed polygon through vertices, added to the current path.
    auto add_loop = [&](std::span<const ricci::Index> loop) {
      for (std::size_t i = 0; i < loop.size(); ++i) {
        const ricci::Index v = loop[i];
        const double x = X(g.positions[dims * v]), y = Y(g.positions[dims * v + 1]);
        if (i == 0)
          cairo_move_to(cr, x, y);
        else
          cairo_line_to(cr, x, y);
      }
      cairo_close_path(cr);
    };
    // One colour and no edges: the faces are filled at once through the outline of their union
    // (the same pixels, without the seams between anti-aliased triangles, and an SVG whose size
    // does not grow with the faces).
    if (g.edge_colour == 0 && g.face_colours.empty() && order.size() > 64) {
      cairo_new_path(cr);
      const std::vector<std::vector<ricci::Index>> loops = g.outline.empty() ? outline_loops(g.faces, order) : g.outline;
      for (const std::vector<ricci::Index>& loop : loops) add_loop(loop);
      cairo_set_fill_rule(cr, CAIRO_FILL_RULE_WINDING);
      set_colour(cr, g.face_colour);
      cairo_fill(cr);
      order.clear();
    }
    for (const std::size_t f : order) {
      add_loop(std::span<const ricci::Index>(g.faces).subspan(3 * f, 3));
      set_colour(cr, f < g.face_colours.size() ? g.face_colours[f] : g.face_colour);
      if (g.edge_colour != 0) {
        cairo_fill_preserve(cr);
        set_colour(cr, g.edge_colour);
        cairo_set_line_width(cr, 0.4);
        cairo_stroke(cr);
      } else {
        cairo_fill(cr);
      }
    }
    for (const Polyline& l : g.lines) {
      if (l.points.size() < 4) continue;
      cairo_new_path(cr);
      for (std::size_t k = 0; k + 1 < l.points.size(); k += 2) {
        const double x = X(l.points[k]), y = Y(l.points[k + 1]);
        if (!std::isfinite(x) || !std::isfinite(y)) continue;
        if (k == 0)
          cairo_move_to(cr, x, y);
        else
          cairo_line_to(cr, x, y);
      }
      set_colour(cr, l.colour);
      cairo_set_line_width(cr, l.width);
      cairo_stroke(cr);
    }
  });
}

// ---------------------------------------------------------------------------------------------
// Charts.

namespace {

struct Axes {
  double x0, x1, y0, y1;  // data ranges (y in log10 when log)
  double left, right, top, bottom;  // pixel frame
  bool log_y;
  double X(double x) const { return left + (x - x0) / (x1 - x0) * (right - left); }
  double Y(double y) const {
    const double t = log_y ? std::log10(y) : y;
    return bottom - (t - y0) / (y1 - y0) * (bottom - top);
  }
};

void draw_frame(cairo_t* cr, const Axes& a, const std::string& title, const std::string& x_label,
                const std::string& y_label, int w) {
  set_colour(cr, 0xFFFFFFFF);
  cairo_paint(cr);
  draw_text(cr, 0.5 * w, 24, title, 16, true);
  set_colour(cr, 0xFF404040);
  cairo_set_line_width(cr, 1);
  cairo_rectangle(cr, a.left, a.top, a.right - a.left, a.bottom - a.top);
  cairo_stroke(cr);
  // x ticks: about 6 round values.
  const double span = a.x1 - a.x0;
  const double raw = span / 6;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw > 0 ? raw : 1)));
  double step = magnitude;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * magnitude >= raw) {
      step = m * magnitude;
      break;
    }
  for (double x = std::ceil(a.x0 / step) * step; x <= a.x1 + 1e-12 * span; x += step) {
    const double px = a.X(x);
    set_colour(cr, 0xFFE0E0E0);
    cairo_move_to(cr, px, a.top);
    cairo_line_to(cr, px, a.bottom);
    cairo_stroke(cr);
    draw_text(cr, px, a.bottom + 16, format(step >= 1 ? "%.0f" : "%g", x), 11, true);
  }
  // y ticks: decades (log) or about 6 values.
  if (a.log_y) {
    for (int e = static_cast<int>(std::ceil(a.y0)); e <= static_cast<int>(std::floor(a.y1)); ++e) {
      const double py = a.Y(std::pow(10.0, e));
      set_colour(cr, 0xFFE0E0E0);
      cairo_move_to(cr, a.left, py);
      cairo_line_to(cr, a.right, py);
      cairo_stroke(cr);
      draw_text(cr, a.left - 44, py + 4, "1e" + std::to_string(e), 11);
    }
  } else {
    const double ys = (a.y1 - a.y0) / 5;
    for (int k = 0; k <= 5; ++k) {
      const double y = a.y0 + k * ys;
      const double py = a.Y(y);
      set_colour(cr, 0xFFE0E0E0);
      cairo_move_to(cr, a.left, py);
      cairo_line_to(cr, a.right, py);
      cairo_stroke(cr);
      draw_text(cr, a.left - 44, py + 4, format("%.3g", y), 11);
    }
  }
  draw_text(cr, 0.5 * (a.left + a.right), a.bottom + 36, x_label, 12, true);
  cairo_save(cr);
  cairo_translate(cr, 16, 0.5 * (a.top + a.bottom));
  cairo_rotate(cr, -kPi / 2);
  draw_text(cr, 0, 0, y_label, 12, true);
  cairo_restore(cr);
}

}  // namespace

Picture line_chart(const Chart& chart, int width, int height) {
  // Data ranges.
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const Series& s : chart.series)
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]) || (chart.log_y && !(s.y[i] > 0))) continue;
      const double y = chart.log_y ? std::log10(s.y[i]) : s.y[i];
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  for (const auto& [value, label] : chart.reference_y) {
    if (chart.log_y && !(value > 0)) continue;
    const double y = chart.log_y ? std::log10(value) : value;
    y0 = std::min(y0, y);
    y1 = std::max(y1, y);
  }
  if (!(x1 >= x0)) x0 = 0, x1 = 1;
  if (!(y1 >= y0)) y0 = 0, y1 = 1;
  if (x1 == x0) x1 = x0 + 1;
  if (chart.log_y) {
    y0 = std::floor(y0);
    y1 = std::ceil(y1);
  }
  if (y1 == y0) y1 = y0 + 1;
  return render_both(width, height, [&](cairo_t* cr, int w, int h) {
    const Axes a{x0, x1, y0, y1, 70.0, w - 20.0, 40.0, h - 50.0, chart.log_y};
    draw_frame(cr, a, chart.title, chart.x_label, chart.y_label, w);
    for (const auto& [value, label] : chart.reference_y) {
      if (chart.log_y && !(value > 0)) continue;
      const double py = a.Y(value);
      const double dash[] = {5.0, 4.0};
      cairo_set_dash(cr, dash, 2, 0);
      set_colour(cr, 0xFF808080);
      cairo_move_to(cr, a.left, py);
      cairo_line_to(cr, a.right, py);
      cairo_stroke(cr);
      cairo_set_dash(cr, nullptr, 0, 0);
      draw_text(cr, a.right - 4 - 7.0 * static_cast<double>(label.size()), py - 4, label, 11, false, 0xFF606060);
    }
    double legend_y = a.top + 16;
    for (const Series& s : chart.series) {
      cairo_new_path(cr);
      bool started = false;
      for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]) || (chart.log_y && !(s.y[i] > 0))) continue;
        if (!started)
          cairo_move_to(cr, a.X(s.x[i]), a.Y(s.y[i]));
        else
          cairo_line_to(cr, a.X(s.x[i]), a.Y(s.y[i]));
        started = true;
      }
      set_colour(cr, s.colour);
      cairo_set_line_width(cr, 2);
      cairo_stroke(cr);
      for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]) || (chart.log_y && !(s.y[i] > 0))) continue;
        cairo_arc(cr, a.X(s.x[i]), a.Y(s.y[i]), 2.5, 0, 2 * kPi);
        cairo_fill(cr);
      }
      set_colour(cr, s.colour);
      cairo_rectangle(cr, a.right - 170, legend_y - 9, 18, 4);
      cairo_fill(cr);
      draw_text(cr, a.right - 146, legend_y - 3, s.label, 12);
      legend_y += 18;
    }
  });
}

Picture histogram(std::span<const double> values, double lo, double hi, int bins, const std::string& title,
                  const std::string& x_label, int width, int height) {
  bins = std::max(1, bins);
  if (!(hi > lo)) hi = lo + 1;
  std::vector<std::int64_t> counts(static_cast<std::size_t>(bins), 0);
  std::int64_t below = 0, above = 0, total = 0;
  for (const double v : values) {
    if (!std::isfinite(v)) continue;
    ++total;
    int b = static_cast<int>(std::floor((v - lo) / (hi - lo) * bins));
    if (b < 0) {
      ++below;
      b = 0;
    }
    if (b >= bins) {
      if (v > hi) ++above;
      b = bins - 1;
    }
    ++counts[static_cast<std::size_t>(b)];
  }
  const std::int64_t peak = std::max<std::int64_t>(1, *std::max_element(counts.begin(), counts.end()));
  return render_both(width, height, [&](cairo_t* cr, int w, int h) {
    const Axes a{lo, hi, 0.0, static_cast<double>(peak) * 1.05, 70.0, w - 20.0, 40.0, h - 50.0, false};
    std::string full = title + "  (" + std::to_string(total) + " values";
    if (below + above > 0) full += ", " + std::to_string(below + above) + " outside the range, in the end bins";
    full += ")";
    draw_frame(cr, a, full, x_label, "count", w);
    set_colour(cr, 0xFF1F77B4);
    for (int b = 0; b < bins; ++b) {
      const double xa = a.X(lo + (hi - lo) * b / bins), xb = a.X(lo + (hi - lo) * (b + 1) / bins);
      const double yb = a.Y(static_cast<double>(counts[static_cast<std::size_t>(b)]));
      cairo_rectangle(cr, xa + 0.5, yb, std::max(0.5, xb - xa - 1), a.bottom - yb);
    }
    cairo_fill(cr);
  });
}

}  // namespace ricci_cli
