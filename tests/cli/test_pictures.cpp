// Pictures of the CLI: PNG round trips, the checkerboard rasterizer (checks where the texture
// says, z-buffer occlusion, shading), 2D drawings and charts that are not blank.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "pictures.h"
#include "shapes.h"

using namespace ricci_cli;
using ricci::Index;

namespace {

// Pixels that differ from white.
std::int64_t ink(const Image& image) {
  std::int64_t n = 0;
  for (std::uint32_t p : image.pixels) n += (p & 0x00FFFFFF) != 0x00FFFFFF ? 1 : 0;
  return n;
}

int red(std::uint32_t p) { return static_cast<int>((p >> 16) & 0xFF); }
int blue(std::uint32_t p) { return static_cast<int>(p & 0xFF); }

}  // namespace

TEST_CASE("pictures: PNG encoding round-trips opaque images exactly") {
  std::mt19937_64 rng(5);
  Image image;
  image.width = 37;
  image.height = 23;
  for (int i = 0; i < image.width * image.height; ++i)
    image.pixels.push_back(0xFF000000u | static_cast<std::uint32_t>(rng() & 0xFFFFFF));
  const std::string png = encode_png(image);
  REQUIRE(png.size() > 8);
  CHECK(png.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0);
  const Image back = decode_png(png);
  CHECK(back.width == image.width);
  CHECK(back.height == image.height);
  CHECK(back.pixels == image.pixels);
  CHECK(decode_png("not a png").pixels.empty());
  CHECK(encode_png(Image{}).empty());
}

TEST_CASE("pictures: the checkerboard shows the checks of the texture, nearer faces hide farther ones") {
  // The unit square in the plane z = 0, seen from +z (azimuth 0, elevation 0), uv = xy, 4×4 checks.
  const std::vector<double> positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  const std::vector<Index> faces = {0, 1, 2, 0, 2, 3};
  std::vector<double> uv;
  for (Index c : faces) uv.insert(uv.end(), {positions[3 * c], positions[3 * c + 1]});
  CheckerOptions o;
  o.width = 200;
  o.height = 200;
  o.checks_across = 4;
  o.light = 0xFFFF0000;  // pure red
  o.dark = 0xFF0000FF;   // pure blue
  CheckerView front;
  front.azimuth_degrees = 0;
  front.elevation_degrees = 0;
  CheckerStats stats;
  const Image image = render_checkerboard(positions, faces, uv, front, o, &stats);
  REQUIRE(image.width == 200);
  REQUIRE(image.height == 200);
  // The square fills 90% of the image (5% margins); check (i, j) has its centre at
  // uv ((i + 0.5)/4, (j + 0.5)/4), image x = 10 + 180 u, y = 190 − 180 v (rows grow downwards).
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      const int x = static_cast<int>(10 + 180 * (i + 0.5) / 4), y = static_cast<int>(190 - 180 * (j + 0.5) / 4);
      const std::uint32_t p = image.pixels[static_cast<std::size_t>(y) * 200 + x];
      CAPTURE(i);
      CAPTURE(j);
      if ((i + j) % 2 == 0) {
        CHECK(red(p) > 200);
        CHECK(blue(p) < 30);
      } else {
        CHECK(blue(p) > 200);
        CHECK(red(p) < 30);
      }
    }
  CHECK(stats.covered_pixels > 180 * 180 * 95 / 100);
  CHECK(std::abs(stats.light_pixels - stats.dark_pixels) < stats.covered_pixels / 20);
  CHECK(image.pixels[0] == 0xFFFFFFFF);  // background in the corner

  // A smaller square in front (z = 1, nearer the camera) with a constant light texture hides
  // the middle; seen from behind (azimuth 180) the original square is in front instead.
  std::vector<double> p2 = positions;
  std::vector<Index> f2 = faces;
  for (double t : {0.3, 0.3, 1.0, 0.7, 0.3, 1.0, 0.7, 0.7, 1.0, 0.3, 0.7, 1.0}) p2.push_back(t);
  for (Index c : {4, 5, 6, 4, 6, 7}) f2.push_back(c);
  std::vector<double> uv2 = uv;
  for (int k = 0; k < 6; ++k) uv2.insert(uv2.end(), {0.1, 0.1});
  // uv2's constant square is at (0.1, 0.1): an even (light) check of the 4×4 texture over [0, 1].
  const Image occluded = render_checkerboard(p2, f2, uv2, front, o, nullptr);
  for (int x = 80; x < 120; x += 5) {
    const std::uint32_t p = occluded.pixels[static_cast<std::size_t>(100) * 200 + x];
    CHECK(red(p) > 200);  // the near square, all light
  }
  // Degenerate inputs: no crash, background only.
  CheckerStats none;
  const Image empty = render_checkerboard({}, {}, {}, front, o, &none);
  CHECK(none.covered_pixels == 0);
  CHECK(ink(empty) == 0);
  const std::vector<double> nan_uv(12, std::nan(""));
  const Image grey = render_checkerboard(positions, faces, nan_uv, front, o, &none);
  CHECK(none.covered_pixels > 0);
  CHECK(ink(grey) > 0);
}

TEST_CASE("pictures: drawings and charts give PNG and SVG that are not blank") {
  Drawing d;
  d.domain = Domain::Disk;
  d.positions = {0, 0, 0.5, 0, 0, 0.5};
  d.faces = {0, 1, 2};
  d.lines.push_back({{0, 0, 0.5, 0}, palette(0), 3});
  d.title = "a triangle in the Poincaré disk";
  const Picture p = draw(d, 300, 300);
  const Image image = decode_png(p.png);
  CHECK(image.width == 300);
  CHECK(ink(image) > 1000);
  CHECK(p.svg.find("<svg") != std::string::npos);

  Drawing sphere;
  sphere.domain = Domain::SphereFront;
  sphere.dims = 3;
  sphere.positions = {0, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, -1};
  sphere.faces = {0, 1, 2, 3, 2, 1};  // the second faces away (z < 0 on average)
  const Picture ps = draw(sphere, 200, 200);
  CHECK(ink(decode_png(ps.png)) > 100);

  Chart c;
  c.title = "convergence";
  c.x_label = "iteration";
  c.y_label = "max |K̄ − K|";
  c.series.push_back({"Newton", {1, 2, 3, 4}, {1e-1, 1e-3, 1e-7, 1e-13}, palette(0)});
  c.series.push_back({"with a non-positive value", {1, 2}, {0.0, -1.0}, palette(1)});
  c.reference_y.push_back({1e-10, "tolerance"});
  const Picture chart = line_chart(c, 400, 300);
  CHECK(ink(decode_png(chart.png)) > 1000);
  CHECK(chart.svg.find("<svg") != std::string::npos);

  const std::vector<double> values = {0.9, 1.0, 1.0, 1.1, 1.2, 5.0, std::nan("")};
  const Picture h = histogram(values, 0.5, 1.5, 10, "ratios", "ratio", 400, 300);
  CHECK(ink(decode_png(h.png)) > 1000);
}

TEST_CASE("pictures: one-colour faces are filled through their outline, holes stay empty") {
  // A flat annulus of 2·8·64 = 1024 faces (above the per-face threshold), drawn in the plane with
  // one colour and no edges: filled through the outline loops found from the faces, or through
  // loops given. The hole (|z| < 0.5) stays white; the ring is filled; both agree pixel for pixel.
  const ricci::Mesh m = ricci_shapes::conformal_annulus(0.5, 1.0, 8, 64, true);
  Drawing d;
  d.domain = Domain::Plane;
  for (std::size_t v = 0; v < m.positions.size() / 3; ++v) {
    d.positions.push_back(m.positions[3 * v]);
    d.positions.push_back(m.positions[3 * v + 1]);
  }
  d.faces = m.faces;
  d.edge_colour = 0;
  d.face_colour = 0xFF2060C0;
  const Image found = decode_png(draw(d, 200, 200).png);
  REQUIRE(found.width == 200);
  auto at = [&](const Image& im, int x, int y) { return im.pixels[static_cast<std::size_t>(y) * im.width + x]; };
  // The drawing fits the annulus's box in the 200 × 200 frame, title-less: centre (100, 100).
  CHECK((at(found, 100, 100) & 0x00FFFFFF) == 0x00FFFFFF);  // the hole
  const std::uint32_t ring = at(found, 100, 100 - 60);      // |z| ≈ 0.75
  CHECK(blue(ring) > 150);
  CHECK(red(ring) < 60);
  // The same outline given as loops (outer counter-clockwise, inner clockwise, as the annulus
  // has them): the same pixels.
  Drawing given = d;
  std::vector<Index> outer, inner;
  for (Index k = 0; k < 64; ++k) inner.push_back(k);  // ring 0: |z| = 0.5
  for (Index k = 0; k < 64; ++k) outer.push_back(8 * 64 + k);
  std::reverse(inner.begin(), inner.end());
  given.outline = {outer, inner};
  const Image explicit_loops = decode_png(draw(given, 200, 200).png);
  std::int64_t differ = 0;
  for (std::size_t i = 0; i < found.pixels.size(); ++i) differ += found.pixels[i] != explicit_loops.pixels[i] ? 1 : 0;
  CHECK(differ == 0);
  // The SVG holds the outline, not one path per face: far smaller than the faces' coordinates.
  CHECK(draw(d, 200, 200).svg.size() < 20000);
}
