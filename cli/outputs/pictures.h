// ricci command-line tool — pictures a person can judge at a glance: a checkerboard-textured
// rendering of the mesh (a small z-buffer software rasterizer), 2D drawings of layouts and
// tilings (plane, Poincaré disk with its unit circle, sphere seen orthographically), a histogram
// and a convergence plot with a logarithmic axis.
//
// Everything renders into memory: PNG bytes (cairo's PNG encoder) and, for vector drawings, SVG
// text (cairo's SVG surface), which callers write atomically. Pure functions of their inputs;
// no printing; deterministic (no threads, no clocks).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ricci/conventions.h"

namespace ricci_cli {

/// A raster image: width × height pixels, 0xAARRGGBB each (premultiplied alpha, as cairo's
/// CAIRO_FORMAT_ARGB32), rows top to bottom.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint32_t> pixels;
};

/// PNG bytes of an image; empty when encoding fails.
std::string encode_png(const Image& image);
/// Decodes PNG bytes (for tests and checks); an empty image when they are not a PNG.
Image decode_png(const std::string& bytes);

/// A picture in both forms: PNG bytes and SVG text (empty SVG for raster-only pictures).
struct Picture {
  std::string png;
  std::string svg;
};

// ---- Checkerboard rendering ---------------------------------------------------------------

struct CheckerView {
  double azimuth_degrees = 30;    ///< rotation of the camera about the vertical (y) axis
  double elevation_degrees = 20;  ///< camera height angle above the horizontal plane
};

struct CheckerOptions {
  int width = 640;
  int height = 480;
  /// Checks per unit of texture coordinate (the texture is rescaled so that its bounding box is
  /// `checks` squares across its longer side when `checks_across` > 0).
  double checks_across = 16;
  int supersample = 2;  ///< anti-aliasing: render s×s samples per pixel and average
  std::uint32_t background = 0xFFFFFFFF;
  std::uint32_t light = 0xFFF2C14E;  ///< colour of the even checks
  std::uint32_t dark = 0xFF2E4A7A;   ///< colour of the odd checks
};

struct CheckerStats {
  std::int64_t covered_pixels = 0;  ///< pixels showing the mesh
  std::int64_t light_pixels = 0;    ///< of those, closer to the light check colour
  std::int64_t dark_pixels = 0;     ///< of those, closer to the dark check colour
};

/// Renders faces (#F×3 vertex indices into positions #V×3) with per-corner texture coordinates
/// (#F×3×2, the layout) as checks, shaded by a head light, orthographic projection from `view`,
/// fitted to the image. Faces whose texture coordinates are not finite are drawn grey.
Image render_checkerboard(std::span<const double> positions, std::span<const ricci::Index> faces,
                          std::span<const double> corner_uv, const CheckerView& view, const CheckerOptions& options,
                          CheckerStats* stats = nullptr);

// ---- 2D drawings --------------------------------------------------------------------------

/// What a drawing of a layout shows. Points are xy pairs.
struct Polyline {
  std::vector<double> points;    ///< #points×2
  std::uint32_t colour = 0xFF000000;
  double width = 1.5;            ///< in pixels
};

enum class Domain : int {
  Plane = 0,    ///< fit the drawing's bounding box
  Disk,         ///< the unit disk (Poincaré model): the unit circle is drawn and framed
  SphereFront,  ///< unit-sphere points (xyz) seen orthographically from +z: the disk outline is drawn
};

struct Drawing {
  Domain domain = Domain::Plane;
  /// Positions: xy per vertex (Plane, Disk) or xyz on the unit sphere (SphereFront).
  std::vector<double> positions;
  int dims = 2;
  std::vector<ricci::Index> faces;        ///< #F×3, filled with face_colour (or per-face colours)
  std::vector<std::uint32_t> face_colours;  ///< optional #F (ARGB), else face_colour for all
  std::uint32_t face_colour = 0xFFDCE6F2;
  std::uint32_t edge_colour = 0x40304050;  ///< thin mesh edges (0: none)
  std::vector<Polyline> lines;             ///< drawn on top (sides, generators, outlines)
  /// Optional: the closed loops of vertices bounding the faces' union (e.g. a disk's boundary
  /// loop). With one face colour and no edges the faces are filled at once through this outline,
  /// computed from the faces when empty.
  std::vector<std::vector<ricci::Index>> outline;
  std::string title;
};

/// Renders a drawing to PNG (width × height) and SVG.
Picture draw(const Drawing& drawing, int width = 800, int height = 800);

// ---- Charts -------------------------------------------------------------------------------

struct Series {
  std::string label;
  std::vector<double> x, y;  ///< y > 0 for a logarithmic axis (other points are skipped)
  std::uint32_t colour = 0xFF1F77B4;
};

struct Chart {
  std::string title, x_label, y_label;
  bool log_y = true;
  std::vector<Series> series;
  /// Horizontal reference lines (e.g. the tolerance), drawn dashed.
  std::vector<std::pair<double, std::string>> reference_y;
};

/// A line chart (points joined, markers at the points) with a legend.
Picture line_chart(const Chart& chart, int width = 800, int height = 500);

/// A histogram of values over [lo, hi] with `bins` bins (values outside are counted in the end
/// bins and said in the subtitle).
Picture histogram(std::span<const double> values, double lo, double hi, int bins, const std::string& title,
                  const std::string& x_label, int width = 800, int height = 500);

/// A distinct colour per index (generator pairs, series), fully opaque.
std::uint32_t palette(int index);

}  // namespace ricci_cli
