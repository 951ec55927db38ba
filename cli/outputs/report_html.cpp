// The report page: see report_html.h. The page is built as one string in reading order:
// header (title, status, message, input), key numbers, the summary table, generators, timings,
// pictures, the whole JSON. Every value goes through cell(), which says "—" for anything
// missing and escapes everything it inserts.
#include "report_html.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

namespace ricci_cli {

std::string base64_encode(std::string_view bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 3 <= bytes.size(); i += 3) {
    const auto b0 = static_cast<unsigned char>(bytes[i]), b1 = static_cast<unsigned char>(bytes[i + 1]),
               b2 = static_cast<unsigned char>(bytes[i + 2]);
    out += kAlphabet[b0 >> 2];
    out += kAlphabet[((b0 & 0x03) << 4) | (b1 >> 4)];
    out += kAlphabet[((b1 & 0x0F) << 2) | (b2 >> 6)];
    out += kAlphabet[b2 & 0x3F];
  }
  const std::size_t rest = bytes.size() - i;
  if (rest == 1) {
    const auto b0 = static_cast<unsigned char>(bytes[i]);
    out += kAlphabet[b0 >> 2];
    out += kAlphabet[(b0 & 0x03) << 4];
    out += "==";
  } else if (rest == 2) {
    const auto b0 = static_cast<unsigned char>(bytes[i]), b1 = static_cast<unsigned char>(bytes[i + 1]);
    out += kAlphabet[b0 >> 2];
    out += kAlphabet[((b0 & 0x03) << 4) | (b1 >> 4)];
    out += kAlphabet[(b1 & 0x0F) << 2];
    out += '=';
  }
  return out;
}

std::string html_escape(std::string_view text) {
  std::string out;
  out.reserve(text.size() + text.size() / 8);
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

namespace {

constexpr const char* kMissing = "—";

/// How a number is shown.
enum class Format {
  Error,    ///< scientific, 3 significant digits: 3.42e-12 (0 as "0")
  Seconds,  ///< 3 significant digits, then " s": 0.0123 s, 12.3 s, 1234 s
  General,  ///< 3 significant digits, scientific only when very small or large
};

std::string chars(double v, std::chars_format how, int precision) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, how, precision);
  return r.ec == std::errc() ? std::string(buf, r.ptr) : std::string("?");
}

std::string format_number(double v, Format format) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+∞" : "−∞";
  std::string s;
  switch (format) {
    case Format::Error:
      s = v == 0 ? "0" : chars(v, std::chars_format::scientific, 2);
      break;
    case Format::Seconds:
      s = std::abs(v) >= 1000 ? chars(v, std::chars_format::fixed, 0)
                              : chars(v, std::chars_format::general, 3);
      return s + " s";
    case Format::General:
      s = chars(v, std::chars_format::general, 3);
      break;
  }
  return s;
}

/// The value at a path of object keys, or nullptr when any step is missing, null or not an object.
template <class Json>
const Json* at(const Json& root, std::initializer_list<const char*> keys) {
  const Json* v = &root;
  for (const char* k : keys) {
    if (!v->is_object()) return nullptr;
    const auto it = v->find(k);
    if (it == v->end()) return nullptr;
    v = &*it;
  }
  return v->is_null() ? nullptr : v;
}

/// Escaped HTML text of a value: "—" when absent, numbers per `format`, strings as they are.
template <class Json>
std::string cell(const Json* v, Format format = Format::General) {
  if (v == nullptr || v->is_null()) return kMissing;
  if (v->is_string()) {
    const auto& s = v->template get_ref<const std::string&>();
    return s.empty() ? std::string(kMissing) : html_escape(s);
  }
  if (v->is_boolean()) return v->template get<bool>() ? "yes" : "no";
  if (v->is_number_unsigned()) return std::to_string(v->template get<std::uint64_t>());
  if (v->is_number_integer()) return std::to_string(v->template get<std::int64_t>());
  if (v->is_number()) return html_escape(format_number(v->template get<double>(), format));
  return html_escape(v->dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

/// The number at `v`, or NaN when it is absent or not a number.
template <class Json>
double number(const Json* v) {
  return v != nullptr && v->is_number() ? v->template get<double>() : std::nan("");
}

/// An element id from a caller's id: [A-Za-z0-9_-] kept, anything else '-'; never empty.
std::string element_id(const std::string& id, std::size_t index) {
  std::string out;
  for (char c : id) {
    const bool keep =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    out += keep ? c : '-';
  }
  return out.empty() ? "image-" + std::to_string(index + 1) : out;
}

constexpr const char* kStyle = R"CSS(
:root { color-scheme: light; }
* { box-sizing: border-box; }
body { margin: 0; background: #f5f6f8; color: #1c2230;
  font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
main { max-width: 1000px; margin: 0 auto; padding: 24px 20px 48px; }
h1 { font-size: 1.6em; margin: 0 0 .4em; overflow-wrap: anywhere; }
h2 { font-size: 1.2em; margin: 1.8em 0 .6em; padding-bottom: .2em; border-bottom: 1px solid #d7dce4; }
h3 { font-size: 1.05em; margin: 0 0 .5em; }
code, pre, td.num {
  font-family: ui-monospace, SFMono-Regular, Menlo, Consolas, "Liberation Mono", monospace; }
code { font-size: .92em; overflow-wrap: anywhere; }
.status-line { display: flex; flex-wrap: wrap; align-items: baseline; gap: .6em; margin: 0 0 .4em; }
.status { display: inline-block; padding: .1em .8em; border-radius: 999px; font-weight: 700; color: #fff; }
.status.ok { background: #1a7f37; }
.status.bad { background: #c62828; }
.message { overflow-wrap: anywhere; }
.meta { margin: .2em 0; color: #4a5263; }
.check { margin: .2em 0; color: #4a5263; }
.check.ok { color: #1a7f37; }
.check.bad { color: #c62828; font-weight: 700; }
.cards { display: grid; grid-template-columns: repeat(auto-fit, minmax(170px, 1fr)); gap: 10px;
  margin-top: 1.2em; }
.card { background: #fff; border: 1px solid #d7dce4; border-radius: 8px; padding: 10px 12px; }
.card .label { font-size: .8em; color: #5a6373; }
.card .value { font-size: 1.3em; font-weight: 600; font-variant-numeric: tabular-nums;
  overflow-wrap: anywhere; }
table { border-collapse: collapse; width: 100%; background: #fff; border: 1px solid #d7dce4; }
th, td { text-align: left; padding: 5px 10px; border-bottom: 1px solid #eceff3; vertical-align: top; }
thead th { background: #eef1f5; font-weight: 600; }
tr.group th { background: #eef1f5; font-size: .85em; text-transform: uppercase; letter-spacing: .04em;
  color: #4a5263; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.summary { width: auto; min-width: min(100%, 560px); }
table.summary th { padding-right: 48px; }
.bad-value { color: #c62828; font-weight: 700; }
.bar { width: 40%; }
.bar span { display: block; height: .8em; margin-top: .35em; background: #7aa2d6; border-radius: 2px; }
.none { color: #5a6373; }
nav.pictures { margin-bottom: 1em; }
nav.pictures a { margin-right: 1em; color: #1f5fae; }
figure { margin: 0 0 24px; background: #fff; border: 1px solid #d7dce4; border-radius: 8px; padding: 14px; }
figure img { display: block; max-width: 100%; height: auto; margin: 0 auto; }
figure img.broken { min-height: 40px; min-width: 120px; outline: 3px solid #c62828; }
figcaption { color: #4a5263; font-size: .92em; margin-top: 8px; }
details { background: #fff; border: 1px solid #d7dce4; border-radius: 8px; padding: 8px 12px; }
summary { cursor: pointer; font-weight: 600; }
pre { overflow: auto; max-height: 640px; font-size: 12px; margin: .6em 0 0; }
)CSS";

// Counts the pictures that decoded once everything has loaded and says so in the DOM.
constexpr const char* kScript = R"JS(
window.addEventListener('load', function () {
  var images = document.images, loaded = 0;
  for (var i = 0; i < images.length; ++i) {
    if (images[i].complete && images[i].naturalWidth > 0) ++loaded;
    else images[i].classList.add('broken');
  }
  document.body.setAttribute('data-images-total', String(images.length));
  document.body.setAttribute('data-images-loaded', String(loaded));
  var line = document.getElementById('report-images-status');
  line.textContent = 'Pictures: ' + loaded + ' of ' + images.length + ' shown' +
      (loaded === images.length ? '.' : ' \u2014 some failed to decode.');
  line.className = loaded === images.length ? 'check ok' : 'check bad';
});
)JS";

/// A row of the summary table: label (trusted HTML), value (already escaped).
void row(std::string& out, const char* label, const std::string& value, bool bad = false) {
  out += "<tr><th scope=\"row\">";
  out += label;
  out += bad ? "</th><td class=\"num bad-value\">" : "</th><td class=\"num\">";
  out += value;
  out += "</td></tr>\n";
}

void group(std::string& out, const char* name) {
  out += "<tr class=\"group\"><th colspan=\"2\">";
  out += name;
  out += "</th></tr>\n";
}

void card(std::string& out, const char* label, const std::string& value, bool bad = false) {
  out += "<div class=\"card\"><div class=\"label\">";
  out += label;
  out += bad ? "</div><div class=\"value bad-value\">" : "</div><div class=\"value\">";
  out += value;
  out += "</div></div>\n";
}

// The page's sections, in order; each appends its HTML to `out`.

// The title, status, message and input.
template <class Json>
void header_section(std::string& out, const Json& report, const std::string& safe_title) {
  const Json* status = at(report, {"status"});
  const bool ok =
      status != nullptr && status->is_string() && status->template get_ref<const std::string&>() == "ok";
  out += "<header id=\"report-header\">\n<h1>" + safe_title + "</h1>\n";
  out += "<p class=\"status-line\"><span class=\"status " + std::string(ok ? "ok" : "bad") +
         "\" id=\"report-status\">" + cell(status) + "</span><span class=\"message\">" +
         cell(at(report, {"message"})) + "</span></p>\n";
  out += "<p class=\"meta\">Input <code>" + cell(at(report, {"input"})) + "</code> · geometry " +
         cell(at(report, {"geometry"})) + " · scheme " + cell(at(report, {"scheme"})) + "</p>\n";
  out +=
      "<p class=\"check\" id=\"report-images-status\">Pictures: not checked (the page&#39;s script did not "
      "run).</p>\n";
  out += "</header>\n";
}

// The run's total time: the report's own "total" stage when it has one, else the sum of the stages.
struct TotalTime {
  double seconds = 0;
  bool known = false;  ///< some stage had a time
  bool own = false;    ///< the report names its total
};
template <class Json>
TotalTime total_time(const Json& report) {
  TotalTime t;
  const Json* timings = at(report, {"timings"});
  const Json* own_total = at(report, {"timings", "total"});
  if (own_total != nullptr && own_total->is_number()) {
    t.seconds = own_total->template get<double>();
    t.known = t.own = true;
  } else if (timings != nullptr && timings->is_object()) {
    for (auto it = timings->begin(); it != timings->end(); ++it)
      if (it->is_number()) {
        t.seconds += it->template get<double>();
        t.known = true;
      }
  }
  return t;
}

// The key numbers as cards, then the summary table.
template <class Json>
void summary_sections(std::string& out, const Json& report, const TotalTime& total) {
  const Json* flipped = at(report, {"layout", "flipped_faces"});
  const bool flipped_bad = flipped != nullptr && flipped->is_number() && flipped->template get<double>() != 0;
  out += "<section class=\"cards\" id=\"report-key-numbers\">\n";
  card(out, "Max curvature error", cell(at(report, {"max_curvature_error"}), Format::Error));
  card(out, "Max edge length error", cell(at(report, {"layout", "max_edge_length_error"}), Format::Error));
  card(out, "Flipped faces", cell(flipped), flipped_bad);
  card(out, "Relation error", cell(at(report, {"relation_error"}), Format::Error));
  card(out, "Total time", total.known ? html_escape(format_number(total.seconds, Format::Seconds)) : kMissing);
  out += "</section>\n";

  // ---- Summary ----
  out += "<section id=\"report-summary\">\n<h2>Summary</h2>\n<table class=\"summary\">\n";
  group(out, "Mesh");
  row(out, "Vertices", cell(at(report, {"mesh", "vertices"})));
  row(out, "Faces", cell(at(report, {"mesh", "faces"})));
  row(out, "Genus", cell(at(report, {"mesh", "genus"})));
  row(out, "Boundary loops", cell(at(report, {"mesh", "boundary_loops"})));
  group(out, "Flow");
  row(out, "Geometry", cell(at(report, {"geometry"})));
  row(out, "Scheme", cell(at(report, {"scheme"})));
  row(out, "Iterations", cell(at(report, {"iterations"})));
  row(out, "Max curvature error", cell(at(report, {"max_curvature_error"}), Format::Error));
  group(out, "Layout");
  row(out, "Max edge length error", cell(at(report, {"layout", "max_edge_length_error"}), Format::Error));
  row(out, "Flipped faces", cell(flipped), flipped_bad);
  row(out, "Rounding floor", cell(at(report, {"layout", "rounding_floor"}), Format::Error));
  row(out, "Seed independence error", cell(at(report, {"seed_independence_error"}), Format::Error));
  row(out, "Angle distortion, mean", cell(at(report, {"angle_distortion", "mean"})));
  row(out, "Angle distortion, max", cell(at(report, {"angle_distortion", "max"})));
  group(out, "Deck group");
  row(out, "Relation error", cell(at(report, {"relation_error"}), Format::Error));
  out += "</table>\n</section>\n";
}

// One row per generator: residuals and translation length.
template <class Json>
void generators_section(std::string& out, const Json& report) {
  out += "<section id=\"report-generators\">\n<h2>Generators</h2>\n";
  const Json* generators = at(report, {"generators"});
  if (generators == nullptr || !generators->is_array()) {
    out += "<p class=\"none\">" + std::string(kMissing) + "</p>\n";
  } else if (generators->empty()) {
    out += "<p class=\"none\">None.</p>\n";
  } else {
    out +=
        "<table>\n<thead><tr><th>Name</th><th class=\"num\">Residual max</th><th class=\"num\">Residual "
        "rms</th>"
        "<th class=\"num\">Translation length</th></tr></thead>\n<tbody>\n";
    for (const Json& g : *generators) {
      out += "<tr><td>" + cell(at(g, {"name"})) + "</td><td class=\"num\">" +
             cell(at(g, {"residual_max"}), Format::Error) + "</td><td class=\"num\">" +
             cell(at(g, {"residual_rms"}), Format::Error) + "</td><td class=\"num\">" +
             cell(at(g, {"translation_length"})) + "</td></tr>\n";
    }
    out += "</tbody>\n</table>\n";
  }
  out += "</section>\n";
}

// One row per stage with a bar relative to the longest, and the total when the report has none.
template <class Json>
void timings_section(std::string& out, const Json& report, const TotalTime& total) {
  const Json* timings = at(report, {"timings"});
  out += "<section id=\"report-timings\">\n<h2>Timings</h2>\n";
  if (timings == nullptr || !timings->is_object() || timings->empty()) {
    out += "<p class=\"none\">" + std::string(kMissing) + "</p>\n";
  } else {
    double longest = 0;
    for (auto it = timings->begin(); it != timings->end(); ++it)
      if (it->is_number() && std::isfinite(it->template get<double>()))
        longest = std::max(longest, it->template get<double>());
    out += "<table>\n<thead><tr><th>Stage</th><th class=\"num\">Time</th><th></th></tr></thead>\n<tbody>\n";
    for (auto it = timings->begin(); it != timings->end(); ++it) {
      const double s = number(&*it);
      const double share = longest > 0 && std::isfinite(s) ? std::clamp(s / longest, 0.0, 1.0) : 0.0;
      out += "<tr><td>" + html_escape(it.key()) + "</td><td class=\"num\">" + cell(&*it, Format::Seconds) +
             "</td><td class=\"bar\"><span style=\"width:" + chars(100 * share, std::chars_format::fixed, 1) +
             "%\"></span></td></tr>\n";
    }
    if (!total.own)
      out += "<tr><th>Total</th><td class=\"num\">" +
             (total.known ? html_escape(format_number(total.seconds, Format::Seconds)) : std::string(kMissing)) +
             "</td><td></td></tr>\n";
    out += "</tbody>\n</table>\n";
  }
  out += "</section>\n";
}

// The pictures, embedded as base64 data, with a navigation bar of unique element ids.
void pictures_section(std::string& out, std::span<const ReportImage> images) {
  out += "<section id=\"report-pictures\">\n<h2>Pictures</h2>\n";
  std::vector<std::string> ids;
  std::set<std::string> used;
  for (std::size_t k = 0; k < images.size(); ++k) {
    std::string id = element_id(images[k].id, k);
    for (int n = 2; used.count(id) != 0 || id.rfind("report-", 0) == 0; ++n)
      id = element_id(images[k].id, k) + "-" + std::to_string(n);
    used.insert(id);
    ids.push_back(id);
  }
  if (images.empty()) {
    out += "<p class=\"none\">" + std::string(kMissing) + "</p>\n";
  } else {
    out += "<nav class=\"pictures\">";
    for (std::size_t k = 0; k < images.size(); ++k)
      out += "<a href=\"#" + ids[k] + "\">" +
             (images[k].title.empty() ? ids[k] : html_escape(images[k].title)) + "</a>";
    out += "</nav>\n";
  }
  for (std::size_t k = 0; k < images.size(); ++k) {
    const ReportImage& im = images[k];
    const std::string image_title = html_escape(im.title);
    out += "<figure id=\"" + ids[k] + "\">\n<h3>" + image_title +
           "</h3>\n<img src=\"data:" + html_escape(im.mime) + ";base64,";
    out += base64_encode(im.data);
    out += "\" alt=\"" + image_title + "\">\n";
    if (!im.caption.empty()) out += "<figcaption>" + html_escape(im.caption) + "</figcaption>\n";
    out += "</figure>\n";
  }
  out += "</section>\n";
}

template <class Json>
std::string page(const Json& report, std::span<const ReportImage> images, const std::string& title) {
  std::string out;
  std::size_t image_bytes = 0;
  for (const ReportImage& im : images) image_bytes += im.data.size();
  out.reserve(16384 + image_bytes / 3 * 4 + 4 * images.size());

  const std::string safe_title = html_escape(title);
  out += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  out += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  out += "<title>" + safe_title + "</title>\n<style>" + kStyle + "</style>\n</head>\n";
  out += "<body data-images-expected=\"" + std::to_string(images.size()) + "\">\n<main>\n";

  header_section(out, report, safe_title);
  const TotalTime total = total_time(report);
  summary_sections(out, report, total);
  generators_section(out, report);
  timings_section(out, report, total);
  pictures_section(out, images);

  // ---- The whole report ----
  out +=
      "<section id=\"report-json\">\n<h2>Report</h2>\n<details>\n<summary>The whole report "
      "(JSON)</summary>\n<pre>";
  out += html_escape(report.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
  out += "</pre>\n</details>\n</section>\n";

  out += "</main>\n<script>";
  out += kScript;
  out += "</script>\n</body>\n</html>\n";
  return out;
}

}  // namespace

std::string report_html(const nlohmann::json& report, std::span<const ReportImage> images,
                        const std::string& title) {
  return page(report, images, title);
}

std::string report_html(const nlohmann::ordered_json& report, std::span<const ReportImage> images,
                        const std::string& title) {
  return page(report, images, title);
}

}  // namespace ricci_cli
