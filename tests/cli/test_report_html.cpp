// The report page: base64, escaping, "—" for what is missing, pictures as data URIs; and the
// page opened in headless Chromium: every picture decodes (the page's own load check says so in
// the DOM), a screenshot is not blank, and a corrupt picture is caught.
#include <doctest/doctest.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "pictures.h"
#include "report_html.h"
#include "support.h"

using namespace ricci_cli;
using ricci_test::fs::path;

namespace {

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

/// A report with every key the page reads.
nlohmann::ordered_json full_report() {
  nlohmann::ordered_json r;
  r["status"] = "ok";
  r["message"] = "converged in 7 Newton steps";
  r["input"] = "meshes/genus2.obj";
  r["geometry"] = "hyperbolic";
  r["scheme"] = "tangential";
  r["iterations"] = 7;
  r["max_curvature_error"] = 3.4217e-12;
  r["layout"] = {{"max_edge_length_error", 1.25e-13}, {"flipped_faces", 0}, {"rounding_floor", 2.2e-16}};
  r["seed_independence_error"] = 4.5e-14;
  r["angle_distortion"] = {{"mean", 0.1234}, {"max", 0.56789}};
  r["generators"] = nlohmann::ordered_json::array();
  for (int k = 0; k < 4; ++k)
    r["generators"].push_back({{"name", "a" + std::to_string(k + 1)},
                               {"residual_max", 1e-12 * (k + 1)},
                               {"residual_rms", 3e-13 * (k + 1)},
                               {"translation_length", 1.5 + k}});
  r["relation_error"] = 8.88e-15;
  r["timings"] = {{"read", 0.012345}, {"flow", 12.345}, {"layout", 0.5}};
  r["mesh"] = {{"vertices", 1234}, {"faces", 2460}, {"genus", 2}, {"boundary_loops", 0}};
  return r;
}

/// Real pictures of the kinds the uniformize command writes: a chart, a histogram and a
/// drawing as PNG, and the drawing's SVG.
std::vector<ReportImage> real_images() {
  Chart c;
  c.title = "convergence";
  c.x_label = "iteration";
  c.y_label = "max |K̄ − K|";
  c.series.push_back({"Newton", {1, 2, 3, 4, 5}, {1e-1, 1e-3, 1e-6, 1e-10, 1e-13}, palette(0)});
  c.reference_y.push_back({1e-10, "tolerance"});
  const Picture chart = line_chart(c, 600, 360);

  std::vector<double> values;
  for (int i = 0; i < 400; ++i) values.push_back(1.0 + 0.2 * std::sin(0.37 * i) * std::cos(0.11 * i));
  const Picture hist = histogram(values, 0.7, 1.3, 24, "edge length ratios", "ratio", 600, 360);

  Drawing d;
  d.domain = Domain::Disk;
  d.positions = {0, 0, 0.6, 0, 0, 0.6, -0.6, 0, 0, -0.6};
  d.faces = {0, 1, 2, 0, 2, 3, 0, 3, 4};
  d.face_colours = {palette(0), palette(1), palette(2)};
  d.lines.push_back({{0.6, 0, 0, 0.6, -0.6, 0}, palette(3), 3});
  d.title = "fundamental domain";
  const Picture drawing = draw(d, 500, 500);

  return {
      {"convergence", "Convergence", "The curvature error falls below the tolerance.", "image/png",
       chart.png},
      {"ratios", "Edge length ratios", "Ratios near 1 mean little distortion.", "image/png", hist.png},
      {"domain", "Fundamental domain", "The domain in the Poincaré disk.", "image/png", drawing.png},
      {"domain-svg", "Fundamental domain (SVG)", "The same drawing as vector graphics.", "image/svg+xml",
       drawing.svg},
  };
}

// ---- Headless Chromium ----------------------------------------------------------------------

/// The first executable called `name` on $PATH; empty when there is none.
std::string find_on_path(const std::string& name) {
  const char* env = std::getenv("PATH");
  const std::string dirs = env != nullptr ? env : "/usr/bin:/bin";
  std::size_t start = 0;
  while (start <= dirs.size()) {
    const std::size_t end = std::min(dirs.find(':', start), dirs.size());
    const path candidate = path(dirs.substr(start, end - start)) / name;
    std::error_code ec;
    if (end > start && std::filesystem::is_regular_file(candidate, ec) &&
        ::access(candidate.c_str(), X_OK) == 0)
      return candidate.string();
    start = end + 1;
  }
  return {};
}

/// A file:// URL of an absolute path (bytes outside the unreserved set percent-encoded).
std::string file_url(const path& p) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string url = "file://";
  for (unsigned char c : std::filesystem::absolute(p).string()) {
    const bool keep = std::isalnum(c) != 0 || c == '/' || c == '-' || c == '_' || c == '.' || c == '~';
    if (keep)
      url += static_cast<char>(c);
    else
      url += {'%', kHex[c >> 4], kHex[c & 15]};
  }
  return url;
}

struct Browser {
  std::string chromium;  ///< path of the chromium binary; empty when the test should stop
  std::string timeout;   ///< path of coreutils' timeout
};

/// Chromium and timeout, or a failure saying how to install them (a message and empty paths
/// when RICCI_SKIP_BROWSER=1).
Browser find_browser() {
  Browser b{find_on_path("chromium"), find_on_path("timeout")};
  if (!b.chromium.empty() && !b.timeout.empty()) return b;
  const char* skip = std::getenv("RICCI_SKIP_BROWSER");
  if (skip != nullptr && std::string(skip) == "1") {
    MESSAGE("chromium (or timeout) not found; browser test skipped because RICCI_SKIP_BROWSER=1");
  } else {
    FAIL_CHECK(
        "chromium (or coreutils' timeout) not found on PATH: run tools/setup.sh to install it "
        "(or set RICCI_SKIP_BROWSER=1 to skip the browser tests)");
  }
  return {};
}

/// Runs headless Chromium on a page with the given action flags, in a fresh profile, killed
/// after 60 s (exit code 124 then).
ricci_test::CommandResult run_chromium(const Browser& b, const path& page,
                                       const std::vector<std::string>& action) {
  ricci_test::TempDir profile;
  std::vector<std::string> args = {"--kill-after=5",
                                   "60",
                                   b.chromium,
                                   "--headless",
                                   "--no-sandbox",
                                   "--disable-gpu",
                                   "--no-first-run",
                                   "--disable-background-networking",
                                   "--user-data-dir=" + profile.path().string()};
  args.insert(args.end(), action.begin(), action.end());
  args.push_back(file_url(page));
  return ricci_test::run_program(b.timeout, args);
}

/// The value of `data-images-<what>="N"` in a DOM dump; -1 when absent.
int images_attribute(const std::string& dom, const std::string& what) {
  const std::string key = "data-images-" + what + "=\"";
  const std::size_t at = dom.find(key);
  if (at == std::string::npos) return -1;
  const std::size_t begin = at + key.size(), end = dom.find('"', begin);
  if (end == std::string::npos || end == begin || end - begin > 6) return -1;
  int n = 0;
  for (std::size_t i = begin; i < end; ++i) {
    if (!std::isdigit(static_cast<unsigned char>(dom[i]))) return -1;
    n = 10 * n + (dom[i] - '0');
  }
  return n;
}

/// The last part of a program's standard error, for failure messages.
std::string tail(const std::string& s) {
  return s.size() > 1500 ? s.substr(s.size() - 1500) : s;
}

}  // namespace

TEST_CASE("report_html: base64 matches the RFC 4648 test vectors") {
  CHECK(base64_encode("") == "");
  CHECK(base64_encode("f") == "Zg==");
  CHECK(base64_encode("fo") == "Zm8=");
  CHECK(base64_encode("foo") == "Zm9v");
  CHECK(base64_encode("foob") == "Zm9vYg==");
  CHECK(base64_encode("fooba") == "Zm9vYmE=");
  CHECK(base64_encode("foobar") == "Zm9vYmFy");
  CHECK(base64_encode(std::string("\x00\xff\xfe", 3)) == "AP/+");
  CHECK(base64_encode(std::string("\xfb\xef\xbe", 3)) == "++++");
}

TEST_CASE("report_html: every string is escaped, no live markup comes from the report") {
  CHECK(html_escape("a<b>&\"c'") == "a&lt;b&gt;&amp;&quot;c&#39;");
  nlohmann::json r;
  r["status"] = "<b>failed</b>";
  r["message"] = "<script>alert(1)</script>";
  r["input"] = "\"><img src=x onerror=alert(2)>";
  r["generators"] = {{{"name", "<script>g</script>"}, {"residual_max", 1e-3}}};
  r["timings"] = {{"<i>stage</i>", 1.0}};
  const std::vector<ReportImage> images = {{"\"><script>", "<script>t</script>",
                                            "caption <script>c</script> & more", "image/png\"><script>",
                                            "xyz"}};
  const std::string html = report_html(r, images, "title <script>x</script> 'q'");
  CHECK(count(html, "<script") == 1);  // the page's own load check only
  CHECK(count(html, "<img") == 1);     // the one picture
  CHECK(count(html, "<b>") == 0);
  CHECK(count(html, "<i>") == 0);
  CHECK(html.find("&lt;script&gt;alert(1)&lt;/script&gt;") != std::string::npos);
  CHECK(html.find("&quot;&gt;&lt;img src=x onerror=alert(2)&gt;") != std::string::npos);
  CHECK(html.find("<title>title &lt;script&gt;x&lt;/script&gt; &#39;q&#39;</title>") != std::string::npos);
  CHECK(html.find("caption &lt;script&gt;c&lt;/script&gt; &amp; more") != std::string::npos);
  CHECK(html.find("class=\"status bad\"") != std::string::npos);  // not "ok": red
  // The id becomes a plain element id.
  CHECK(html.find("<figure id=\"---script-\">") != std::string::npos);
}

TEST_CASE("report_html: missing keys show a dash, numbers are formatted") {
  for (const nlohmann::json& r : {nlohmann::json::object(), nlohmann::json(), nlohmann::json::array()}) {
    const std::string html = report_html(r, {}, "empty");
    CHECK(html.find("Iterations</th><td class=\"num\">—</td>") != std::string::npos);
    CHECK(html.find("Max curvature error</th><td class=\"num\">—</td>") != std::string::npos);
    CHECK(html.find("Flipped faces</th><td class=\"num\">—</td>") != std::string::npos);
    CHECK(html.find("class=\"status bad\" id=\"report-status\">—</span>") != std::string::npos);
    CHECK(count(html, "—") >= 20);
  }
  // Present but null or of the wrong type: a dash too, never an exception.
  nlohmann::json odd = {{"iterations", nullptr}, {"layout", 3},     {"generators", "none"},
                        {"timings", {1, 2}},     {"mesh", nullptr}, {"generators", {{{"name", nullptr}}}}};
  std::string html;
  CHECK_NOTHROW(html = report_html(odd, {}, "odd"));
  CHECK(html.find("Iterations</th><td class=\"num\">—</td>") != std::string::npos);
  CHECK(html.find("Vertices</th><td class=\"num\">—</td>") != std::string::npos);

  const nlohmann::ordered_json full = full_report();
  html = report_html(full, {}, "full");
  CHECK(html.find("class=\"status ok\"") != std::string::npos);
  CHECK(html.find("Max curvature error</th><td class=\"num\">3.42e-12</td>") != std::string::npos);
  CHECK(html.find("Rounding floor</th><td class=\"num\">2.20e-16</td>") != std::string::npos);
  CHECK(html.find("Angle distortion, max</th><td class=\"num\">0.568</td>") != std::string::npos);
  CHECK(html.find("Iterations</th><td class=\"num\">7</td>") != std::string::npos);
  CHECK(html.find("Vertices</th><td class=\"num\">1234</td>") != std::string::npos);
  CHECK(html.find(">0.0123 s<") != std::string::npos);
  CHECK(html.find(">12.3 s<") != std::string::npos);
  CHECK(html.find(">12.9 s<") != std::string::npos);  // the total
  CHECK(html.find("<td>a4</td><td class=\"num\">4.00e-12</td><td class=\"num\">1.20e-12</td><td "
                  "class=\"num\">4.5</td>") != std::string::npos);
  // The timings keep the order the stages ran in (ordered_json), not alphabetical order.
  CHECK(html.find("<td>read</td>") < html.find("<td>flow</td>"));
  CHECK(html.find("<td>flow</td>") < html.find("<td>layout</td>"));
  // The whole JSON, escaped, in a collapsible block.
  CHECK(html.find("<details>") != std::string::npos);
  CHECK(html.find("&quot;relation_error&quot;: 8.88e-15") != std::string::npos);
  // A plain nlohmann::json report gives the same summary.
  const std::string plain = report_html(nlohmann::json(full), {}, "full");
  CHECK(plain.find("Max curvature error</th><td class=\"num\">3.42e-12</td>") != std::string::npos);
}

TEST_CASE("report_html: every picture is embedded as a data URI") {
  const std::vector<ReportImage> images = real_images();
  const std::string html = report_html(full_report(), images, "pictures");
  CHECK(count(html, "<img ") == images.size());
  CHECK(html.find("data-images-expected=\"4\"") != std::string::npos);
  for (const ReportImage& im : images) {
    INFO(im.id);
    REQUIRE(!im.data.empty());
    CHECK(html.find("<figure id=\"" + im.id + "\">") != std::string::npos);
    CHECK(html.find("src=\"data:" + im.mime + ";base64," + base64_encode(im.data) + "\"") !=
          std::string::npos);
    CHECK(html.find(im.caption) != std::string::npos);
  }
  // Nothing is fetched from elsewhere.
  CHECK(html.find("http://") == std::string::npos);
  CHECK(html.find("https://") == std::string::npos);
  CHECK(html.find("<link") == std::string::npos);
  CHECK(html.find("src=\"data:") != std::string::npos);
  CHECK(count(html, "src=\"") == images.size());
}

TEST_CASE("report_html: headless Chromium shows every picture and a page that is not blank") {
  const Browser browser = find_browser();
  if (browser.chromium.empty()) return;
  const std::vector<ReportImage> images = real_images();
  ricci_test::TempDir dir;
  const path page = dir / "report.html";
  ricci_test::write_bytes(page, report_html(full_report(), images, "ricci uniformize: genus2.obj"));

  // The page's own check, run on window load, in the DOM Chromium dumps after the load event.
  const ricci_test::CommandResult dom = run_chromium(browser, page, {"--dump-dom"});
  INFO("chromium stderr: ", tail(dom.err));
  REQUIRE(dom.exit_code == 0);
  CHECK(images_attribute(dom.out, "total") == static_cast<int>(images.size()));
  CHECK(images_attribute(dom.out, "loaded") == static_cast<int>(images.size()));
  CHECK(dom.out.find("Pictures: 4 of 4 shown.") != std::string::npos);

  // A screenshot of the top of the page: the right size, and something drawn on it.
  const path shot = dir / "screenshot.png";
  const ricci_test::CommandResult s =
      run_chromium(browser, page, {"--screenshot=" + shot.string(), "--window-size=1000,1400"});
  INFO("chromium stderr: ", tail(s.err));
  REQUIRE(s.exit_code == 0);
  const Image image = decode_png(ricci_test::read_bytes(shot));
  REQUIRE(image.width == 1000);
  REQUIRE(image.height == 1400);
  std::map<std::uint32_t, std::int64_t> histogram_of_colours;
  for (std::uint32_t p : image.pixels) ++histogram_of_colours[p];
  std::uint32_t background = 0;
  std::int64_t most = 0;
  for (const auto& [colour, n] : histogram_of_colours)
    if (n > most) most = n, background = colour;
  auto channel = [](std::uint32_t p, int shift) { return static_cast<int>((p >> shift) & 0xFF); };
  std::int64_t ink = 0;
  for (std::uint32_t p : image.pixels) {
    int diff = 0;
    for (int shift : {0, 8, 16}) diff += std::abs(channel(p, shift) - channel(background, shift));
    ink += diff > 60 ? 1 : 0;
  }
  const double ink_fraction = static_cast<double>(ink) / static_cast<double>(image.pixels.size());
  CAPTURE(ink_fraction);
  CAPTURE(histogram_of_colours.size());
  // The top of this page measures about 4% ink and 1500 colours; a page with one word on it
  // 0.02% and 160 colours (anti-aliased text), a white page 0% and 1.
  CHECK(ink_fraction > 0.02);
  CHECK(histogram_of_colours.size() > 500);
}

TEST_CASE("report_html: headless Chromium catches a corrupt picture (the check can fail)") {
  const Browser browser = find_browser();
  if (browser.chromium.empty()) return;
  std::vector<ReportImage> images = real_images();
  images.resize(2);
  images[1].data = "\x89PNG\r\n\x1a\n but not a PNG after all";
  ricci_test::TempDir dir;
  const path page = dir / "report.html";
  ricci_test::write_bytes(page, report_html(full_report(), images, "a corrupt picture"));
  const ricci_test::CommandResult dom = run_chromium(browser, page, {"--dump-dom"});
  INFO("chromium stderr: ", tail(dom.err));
  REQUIRE(dom.exit_code == 0);
  CHECK(images_attribute(dom.out, "total") == 2);
  CHECK(images_attribute(dom.out, "loaded") == 1);
  CHECK(dom.out.find("Pictures: 1 of 2 shown") != std::string::npos);
}

TEST_CASE("report_html: the report of `ricci uniformize` on the embedded default opens with every picture") {
  const Browser browser = find_browser();
  if (browser.chromium.empty()) return;
  ricci_test::TempDir dir;
  const path out = dir / "out";
  const auto run = ricci_test::run_cli({"uniformize", "-o", out.string(), "-q"});
  REQUIRE(run.exit_code == 0);
  const path page = out / "report.html";
  const std::string html = ricci_test::read_bytes(page);
  const int images = static_cast<int>(count(html, "<img "));
  CHECK(images >= 9);  // domain, polygon, cover, three checkerboards, angles, two convergence plots
  const ricci_test::CommandResult dom = run_chromium(browser, page, {"--dump-dom"});
  INFO("chromium stderr: ", tail(dom.err));
  REQUIRE(dom.exit_code == 0);
  CHECK(images_attribute(dom.out, "total") == images);
  CHECK(images_attribute(dom.out, "loaded") == images);
  const path shot = dir / "screenshot.png";
  const ricci_test::CommandResult s =
      run_chromium(browser, page, {"--screenshot=" + shot.string(), "--window-size=1000,1400"});
  REQUIRE(s.exit_code == 0);
  const Image image = decode_png(ricci_test::read_bytes(shot));
  REQUIRE(image.width == 1000);
  std::map<std::uint32_t, std::int64_t> colours;
  for (std::uint32_t p : image.pixels) ++colours[p];
  CHECK(colours.size() > 500);
}
