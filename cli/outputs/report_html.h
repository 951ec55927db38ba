// ricci command-line tool — the report as one self-contained HTML page: the key numbers of a
// run (status, curvature error, layout checks, timings), the generators table, every picture
// and the whole JSON report, in a file a person can open anywhere (no network, no other files).
//
// Pure functions of their inputs: the page is returned as a string, which callers write
// atomically next to report.json. No printing, no clocks, deterministic.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>
#include <string_view>

namespace ricci_cli {

/// One picture of the report page, embedded in the page as a base64 data: URI.
struct ReportImage {
  /// Short id, used (with characters other than [A-Za-z0-9_-] replaced by '-') as the HTML
  /// element id of the picture's figure, so the page can link to it (e.g. "domain" → #domain).
  /// Ids starting with "report-" are reserved for the page's own sections.
  std::string id;
  std::string title;    ///< heading shown above the picture
  std::string caption;  ///< one or two sentences under it: what to look for
  std::string mime;     ///< "image/png" or "image/svg+xml" (any image type a browser shows)
  std::string data;     ///< the raw bytes: PNG bytes or SVG text
};

/// One self-contained HTML page (no external resources: pictures as base64 data: URIs, inline
/// CSS and script) showing the report's key numbers, the generators table, every picture in
/// order and the whole JSON in a collapsible block.
///
/// `report` is the uniformize command's report object; every key is optional (missing, null or
/// of an unexpected type shows "—"). Keys read: status, message, input, geometry, scheme,
/// iterations, max_curvature_error, layout.{max_edge_length_error, flipped_faces,
/// rounding_floor}, seed_independence_error, angle_distortion.{mean, max}, generators[].{name,
/// residual_max, residual_rms, translation_length}, relation_error, timings (stage → seconds,
/// shown in the object's order), mesh.{vertices, faces, genus, boundary_loops}. Errors are
/// shown in scientific notation with 3 significant digits (3.42e-12), seconds with 3
/// significant digits. Every string from the report, the images and `title` is HTML-escaped.
///
/// The page's script, on window load, counts the <img> elements and those that decoded
/// (complete and naturalWidth > 0) and writes them as <body data-images-total="N"
/// data-images-loaded="M"> and as a visible line, so a headless browser can check the page.
std::string report_html(const nlohmann::json& report, std::span<const ReportImage> images,
                        const std::string& title);

/// The same page from an insertion-ordered report (the CLI's nlohmann::ordered_json), which
/// keeps the timings in the order the stages ran.
std::string report_html(const nlohmann::ordered_json& report, std::span<const ReportImage> images,
                        const std::string& title);

/// Standard base64 (RFC 4648 §4: alphabet A–Z a–z 0–9 + /, '=' padding, no line breaks).
std::string base64_encode(std::string_view bytes);

/// `text` with &, <, >, " and ' replaced by character references, safe inside HTML text and
/// quoted attribute values.
std::string html_escape(std::string_view text);

}  // namespace ricci_cli
