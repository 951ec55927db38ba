// ricci command-line driver: `uniformize` (the main job), `layout` (from a stored metric) and
// `cover` (the universal cover tiling). See commands.h and lib/pipeline/include/ricci/uniformize.h.
//
//   load → initial metric → target → flow → cut → layout → seed check → deck maps → outputs
//
// OUTDIR (written only when every stage succeeded; built in a hidden staging directory beside it
// and renamed into place, so a failed or interrupted run leaves no partial OUTDIR; an existing
// OUTDIR is replaced only when it is empty or holds a ricci report.json):
//   mesh.obj         the (refined) surface, input vertices first; per-corner `vt` = the layout
//                    (E: plane, H: Poincaré disk), so seams run exactly along the cut. Closed
//                    genus 0: the input surface without vt (see sphere.obj).
//   sphere.obj       closed genus 0: the same faces with the layout's unit vectors as positions.
//   domain.obj       the cut disk with its layout as positions (x, y, 0), one vertex per cut vertex.
//   metric.csv       as `ricci flow -o`: u, K, K_target per vertex; length per edge (uniformize only).
//   generators.json  closed genus ≥ 1: the deck generators (see generators_json()).
//   cover.svg, cover.obj   closed genus ≥ 1: the universal cover tiling (--cover-depth; cover.obj up
//                          to --cover-faces faces).
//   report.json      the summary (the keys of --json), also printed on stdout with --json.
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <thread>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <future>
#include <fstream>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "commands.h"
#include "flow_setup.h"
#include "ricci/deck.h"
#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "report_html.h"
#include "gltf.h"
#include "huge_pages.h"
#include "uniformize_outputs.h"
#include "uniformize_pictures.h"
#include "uniformize_run.h"

namespace ricci_cli {

namespace {

using Json = nlohmann::ordered_json;
using ricci::Geometry;
using ricci::Index;
using ricci::Status;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

Json real(double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); }

std::string sci(double x, const char* fmt = "%.3g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, x);
  return buf;
}

/// Progress line of a finished stage (summaries that name their stage are printed as they are).
void print_stage(const ricci::StageRecord& s) {
  const bool named = s.summary.rfind(std::string(s.stage) + ":", 0) == 0;
  std::cerr << "ricci: " << (named ? std::string() : std::string(s.stage) + ": ") << s.summary << " (" << sci(s.seconds)
            << " s)\n";
}

/// The group that tiles the universal cover with copies of the layout: the compact domain's side
/// pairings (H: its neighbours across every side are one letter away) or the deck generators.
ricci::DeckResult tiling_group(const ricci::UniformizeResult& r) {
  if (r.domain_maps.empty()) return r.deck;
  ricci::DeckResult d;
  d.status = Status::Ok;
  d.geometry = r.geometry;
  d.genus = r.deck.genus;
  d.generators = r.domain_maps;
  return d;
}

/// Cover options for a layout with `faces` faces: the depth asked for (0: 3 for the torus's
/// 3x3 block, 1 — every neighbour across a side — for the compact domain, 2 otherwise), at most
/// about 3 million faces in all.
ricci::CoverOptions cover_options(const ricci::UniformizeResult& r, std::int64_t depth) {
  ricci::CoverOptions co;
  co.depth = depth > 0 ? depth : (r.geometry == Geometry::Euclidean ? 3 : (r.domain_maps.empty() ? 2 : 1));
  const std::int64_t faces = std::max<std::int64_t>(1, static_cast<std::int64_t>(r.cut.cut_faces.size() / 3));
  co.max_copies = std::max<std::int64_t>(1, std::min<std::int64_t>(20000, 3000000 / faces));
  return co;
}

std::string status_text(Status s) { return s == Status::Ok ? std::string("ok") : std::string(ricci::status_name(s)); }

// ---- output files -------------------------------------------------------------------------------

/// Refuses OUTDIR when it cannot be (re)placed; empty string when fine.
std::string check_output_dir(const fs::path& out, const std::vector<std::string>& protected_paths, Status* status) {
  std::error_code ec;
  *status = Status::WriteFailed;
  if (out.empty()) return "no output directory given";
  if (fs::exists(out, ec)) {
    if (!fs::is_directory(out, ec)) return out.string() + " exists and is not a directory";
    const bool empty = fs::is_empty(out, ec);
    if (!empty && !fs::exists(out / "report.json", ec))
      return out.string() + " is not empty and holds no ricci report.json; refusing to replace it";
  }
  const fs::path parent = fs::absolute(out, ec).parent_path();
  if (!fs::is_directory(parent, ec)) return "cannot create " + out.string() + ": " + parent.string() + " is not a directory";
  if (::access(parent.c_str(), W_OK) != 0) return "cannot create " + out.string() + ": " + parent.string() + " is not writable";
  const fs::path abs_out = fs::weakly_canonical(fs::absolute(out, ec), ec);
  for (const std::string& p : protected_paths) {
    const fs::path ap = fs::weakly_canonical(fs::absolute(p, ec), ec);
    auto it = std::mismatch(abs_out.begin(), abs_out.end(), ap.begin(), ap.end());
    if (it.first == abs_out.end()) {
      *status = Status::OutputIsInput;
      return "refusing to write " + out.string() + ": it contains the input file " + p + "; nothing was written";
    }
  }
  *status = Status::Ok;
  return {};
}

// ---- interruption while writing ------------------------------------------------------------
//
// While OUTDIR is being written, SIGINT, SIGTERM and SIGHUP remove what was staged so far and
// put a replaced OUTDIR back, using only async-signal-safe calls on paths prepared beforehand,
// then end the process with the signal. Before that nothing is on disk; after the final rename
// the result is complete.

constexpr std::size_t kMaxStaged = 64;
char g_files[kMaxStaged][4096];             // staged files, in the order they are created
volatile std::sig_atomic_t g_nfiles = 0;    // files created (or being created) so far
char g_dir[4096];                           // the staging directory
volatile std::sig_atomic_t g_dir_made = 0;  // it exists
char g_old[4096], g_out[4096];              // a replaced OUTDIR moved aside, and where it belongs
volatile std::sig_atomic_t g_old_moved = 0;

extern "C" void on_interrupt(int sig) {
  for (int i = 0; i < g_nfiles; ++i) ::unlink(g_files[i]);
  if (g_dir_made) ::rmdir(g_dir);
  if (g_old_moved) ::rename(g_old, g_out);
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

bool copy_path(char (&dst)[4096], const std::string& src) {
  if (src.size() >= sizeof dst) return false;
  std::memcpy(dst, src.c_str(), src.size() + 1);
  return true;
}

/// Writes the files into a staging directory beside OUTDIR, then renames it into place (see
/// above for interruptions). RICCI_WRITE_PAUSE_MS (a test aid) pauses after every file.
std::string write_output_dir(const fs::path& out, const std::vector<OutFile>& files) {
  // The staging paths live in globals for the signal handler: one directory at a time per process
  // (a driver may call this from several threads).
  static std::mutex writing;
  const std::lock_guard<std::mutex> lock(writing);
  std::error_code ec;
  const fs::path abs = fs::absolute(out, ec);
  const fs::path parent = abs.parent_path();
  const std::string base = abs.filename().string();
  const fs::path staging = parent / ("." + base + ".ricci-tmp-" + std::to_string(::getpid()));
  const fs::path old = parent / ("." + base + ".ricci-old-" + std::to_string(::getpid()));
  if (files.size() > kMaxStaged) return "too many output files";
  for (std::size_t i = 0; i < files.size(); ++i)
    if (!copy_path(g_files[i], (staging / files[i].name).string())) return "output path too long: " + out.string();
  if (!copy_path(g_dir, staging.string()) || !copy_path(g_old, old.string()) || !copy_path(g_out, abs.string()))
    return "output path too long: " + out.string();
  int pause_ms = 0;
  if (const char* p = std::getenv("RICCI_WRITE_PAUSE_MS")) pause_ms = std::max(0, std::min(std::atoi(p), 10000));
  struct Guard {
    void (*prev[3])(int);
    Guard() {
      g_nfiles = 0;
      g_dir_made = 0;
      g_old_moved = 0;
      prev[0] = std::signal(SIGINT, on_interrupt);
      prev[1] = std::signal(SIGTERM, on_interrupt);
      prev[2] = std::signal(SIGHUP, on_interrupt);
    }
    ~Guard() {
      g_nfiles = 0;
      g_dir_made = 0;
      g_old_moved = 0;
      std::signal(SIGINT, prev[0]);
      std::signal(SIGTERM, prev[1]);
      std::signal(SIGHUP, prev[2]);
    }
  } guard;
  fs::remove_all(staging, ec);
  g_dir_made = 1;  // set before creating: rmdir of a directory that is not there is harmless
  if (!fs::create_directory(staging, ec)) return "cannot create " + staging.string() + ": " + ec.message();
  auto abandon = [&](const std::string& m) {
    g_nfiles = 0;
    g_dir_made = 0;
    std::error_code e2;
    fs::remove_all(staging, e2);
    return m;
  };
  for (std::size_t i = 0; i < files.size(); ++i) {
    const OutFile& f = files[i];
    g_nfiles = static_cast<std::sig_atomic_t>(i + 1);  // before the file exists
    std::ofstream os(staging / f.name, std::ios::binary);
    bool made = false;
    try {
      made = f.stream ? f.stream([&os](std::string_view piece) {
        os.write(piece.data(), static_cast<std::streamsize>(piece.size()));
        return static_cast<bool>(os);
      })
                      : static_cast<bool>(os.write(f.data.data(), static_cast<std::streamsize>(f.data.size())));
    } catch (const std::exception&) {
      made = false;  // out of memory while making a streamed file
    }
    os.close();
    if (!made && os) return abandon("could not serialise " + f.name);
    if (!os) return abandon("cannot write " + (out / f.name).string());
    if (pause_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(pause_ms));
  }
  const bool existed = fs::exists(abs, ec);
  if (existed) {
    g_old_moved = 1;  // before the rename: renaming a missing OLD back fails harmlessly
    fs::rename(abs, old, ec);
    if (ec) {
      g_old_moved = 0;
      return abandon("cannot replace " + out.string() + ": " + ec.message());
    }
  }
  fs::rename(staging, abs, ec);
  if (ec) {
    std::error_code e2;
    if (existed) fs::rename(old, abs, e2);
    g_old_moved = 0;
    return abandon("cannot create " + out.string() + ": " + ec.message());
  }
  // OUTDIR is complete: nothing is left to undo.
  g_nfiles = 0;
  g_dir_made = 0;
  g_old_moved = 0;
  if (existed) fs::remove_all(old, ec);
  return {};
}

std::string obj_header(const std::string& what, const std::string& source) {
  return "# ricci: " + what + "\n# input: " + source + "\n";
}

/// A disk with its layout as positions (x, y, 0) (E, H).
std::string disk_obj(const ricci::CutResult& cut, std::span<const double> x, Geometry g, const std::string& what,
                     const std::string& source) {
  std::string s = obj_header(what + ", laid out (" + std::string(ricci::geometry_name(g)) +
                                 (g == Geometry::Hyperbolic ? ", Poincare disk" : "") + "); sides " + cut.word,
                             source);
  for (Index v = 0; v < cut.num_cut_vertices(); ++v) {
    s += "v ";
    append_number(s, x[2 * static_cast<std::size_t>(v)]);
    s += ' ';
    append_number(s, x[2 * static_cast<std::size_t>(v) + 1]);
    s += " 0\n";
  }
  for (std::size_t f = 0; f + 2 < cut.cut_faces.size(); f += 3) {
    s += "f " + std::to_string(cut.cut_faces[f] + 1) + ' ' + std::to_string(cut.cut_faces[f + 1] + 1) + ' ' +
         std::to_string(cut.cut_faces[f + 2] + 1) + '\n';
  }
  return s;
}

// The common subdivision (a refined result) as OBJ: its faces grouped by the input face each lies
// in (`g input_face_F`, 0-based), positions `x` (#V×3) and, when `uv` is not empty, per-corner
// texture coordinates (uv per cut vertex, corner_uv per corner).
std::string refinement_obj(const std::string& what, const std::string& source, std::span<const double> x,
                           std::span<const Index> faces, std::span<const Index> face_input, std::span<const double> uv,
                           std::span<const Index> corner_uv) {
  std::string s = obj_header(what + "; faces grouped by the input face they lie in (g input_face_F, 0-based)", source);
  for (std::size_t v = 0; v + 2 < x.size(); v += 3) {
    s += "v ";
    for (int d = 0; d < 3; ++d) {
      append_number(s, x[v + d]);
      s += d < 2 ? ' ' : '\n';
    }
  }
  for (std::size_t t = 0; t + 1 < uv.size(); t += 2) {
    s += "vt ";
    append_number(s, uv[t]);
    s += ' ';
    append_number(s, uv[t + 1]);
    s += '\n';
  }
  Index group = ricci::kInvalid;
  for (std::size_t f = 0; 3 * f + 2 < faces.size(); ++f) {
    if (face_input[f] != group) {
      group = face_input[f];
      s += "g input_face_" + std::to_string(group) + '\n';
    }
    s += 'f';
    for (int k = 0; k < 3; ++k) {
      s += ' ' + std::to_string(faces[3 * f + k] + 1);
      if (!uv.empty()) s += '/' + std::to_string(corner_uv[3 * f + k] + 1);
    }
    s += '\n';
  }
  return s;
}

Json moebius_json(const ricci::Moebius& m) {
  return Json{{"a", {m.a.real(), m.a.imag()}}, {"b", {m.b.real(), m.b.imag()}}};
}

/// mesh.obj with an atlas: a `g chart_K` line (0-based) before each run of faces in one chart;
/// the faces keep their order. `obj` is serialize_mesh()'s text, one `f` line per face.
std::string obj_with_chart_groups(const std::string& obj, const std::vector<Index>& face_chart) {
  std::string s;
  s.reserve(obj.size() + obj.size() / 16);
  std::size_t face = 0;
  Index group = ricci::kInvalid;
  for (std::size_t at = 0; at < obj.size();) {
    std::size_t end = obj.find('\n', at);
    end = end == std::string::npos ? obj.size() : end + 1;
    if (obj.compare(at, 2, "f ") == 0 && face < face_chart.size()) {
      if (face_chart[face] != group) {
        group = face_chart[face];
        s += "g chart_" + std::to_string(group) + '\n';
      }
      ++face;
    }
    s.append(obj, at, end - at);
    at = end;
  }
  return s;
}

/// The atlas of a layout that one chart could not hold (layout.h): each chart's figures and its
/// maps into its parent and the root chart (H: SU(1,1) matrices, to_root_low the low part of the
/// quad composition; E: angle and translation), and the chart of every face of the cut surface:
/// mesh.obj's, or refinement.obj's for a refined result (mesh.obj's groups name its own faces').
Json atlas_json(const ricci::UniformizeResult& r) {
  const ricci::LayoutAtlas& a = r.atlas;
  Json charts = Json::array();
  for (const ricci::LayoutChart& c : a.charts) {
    Json j{{"parent", c.parent},
           {"depth", c.depth},
           {"seed_face", c.seed_face == ricci::kInvalid ? Json(nullptr) : Json(c.seed_face)},
           {"faces", c.faces},
           {"max_edge_length_error", real(c.max_edge_length_error)},
           {"rounding_floor", real(c.rounding_floor)},
           {"collar_vertices", c.collar_vertices},
           {"transition_error", real(c.transition_error)}};
    if (r.geometry == Geometry::Hyperbolic) {
      j["to_parent"] = moebius_json(c.to_parent);
      j["to_root"] = moebius_json(c.to_root);
      j["to_root_low"] = moebius_json(c.to_root_low);
    } else {
      j["to_parent"] = Json{{"angle", real(c.angle_to_parent)},
                            {"translation", {real(c.translation_to_parent.real()), real(c.translation_to_parent.imag())}}};
      j["to_root"] = Json{{"angle", real(c.angle_to_root)},
                          {"translation", {real(c.translation_to_root.real()), real(c.translation_to_root.imag())}}};
    }
    charts.push_back(std::move(j));
  }
  return Json{{"root_max_edge_length_error", real(r.layout.max_edge_length_error)},
              {"root_rounding_floor", real(r.layout.rounding_floor)},
              {"root_flipped_faces", r.layout.flipped_faces},
              {"max_transition_error", real(a.max_transition_error)},
              {"unresolvable_faces", a.unresolvable_faces},
              {"unresolvable_error", real(a.unresolvable_error)},
              {"frame_rounding_faces", a.frame_rounding_faces.size()},
              {"max_resolved_error", real(a.max_resolved_error)},
              {"charts", std::move(charts)},
              {"face_chart_of", r.intrinsic.refined ? "refinement.obj" : "mesh.obj"},
              {"face_chart", a.face_chart}};
}

Json generators_array(const std::vector<ricci::DeckGenerator>& gens) {
  Json a = Json::array();
  for (const ricci::DeckGenerator& g : gens) {
    Json j;
    j["name"] = g.name;
    j["side"] = g.side;
    j["partner"] = g.partner;
    if (g.geometry == Geometry::Hyperbolic) {
      j["theta"] = real(g.theta);
      j["z0"] = {real(g.z0.real()), real(g.z0.imag())};
      j["matrix"] = moebius_json(g.map);
      j["translation_length"] = real(g.translation_length);
    } else {
      j["translation"] = {real(g.translation[0]), real(g.translation[1])};
      j["rotation"] = real(g.rotation);
      j["translation_length"] = real(std::hypot(g.translation[0], g.translation[1]));
    }
    j["residual_max"] = real(g.residual_max);
    j["residual_rms"] = real(g.residual_rms);
    j["pairs"] = g.pairs;
    j["single_edge_spread"] = real(g.single_edge_spread);
    a.push_back(std::move(j));
  }
  return a;
}

/// The geodesic canonical polygon: its corners (in the generators' frame), sides, angles and the
/// checks that make it a fundamental domain; `words`: each generator in the domain's pairings.
Json geodesic_polygon_json(const ricci::GeodesicPolygon& gp, const std::vector<std::string>& words) {
  Json verts = Json::array();
  for (const std::complex<double>& z : gp.vertices) verts.push_back(Json::array({z.real(), z.imag()}));
  Json c{{"kind", "geodesic"},
         {"word", gp.word},
         {"vertices", std::move(verts)},
         {"side_lengths", gp.side_lengths},
         {"angles", gp.angles},
         {"perimeter", real(gp.perimeter)},
         {"angle_sum", real(gp.angle_sum)},
         {"area", real(gp.area)},
         {"reach", real(gp.reach)},
         {"closure_error", real(gp.closure_error)},
         {"simple", gp.simple},
         {"relation_error", real(gp.deck.relation_error)},
         {"relation_floor", real(gp.relation_floor)},
         {"arithmetic_bits", gp.arithmetic_bits},
         {"seconds", gp.seconds}};
  if (!words.empty()) c["generator_words"] = words;
  return c;
}

std::string generators_json(const ricci::UniformizeResult& r, const std::string& source) {
  Json j;
  j["format"] = "ricci-deck-generators";
  j["version"] = 1;
  j["input"] = source;
  j["geometry"] = std::string(ricci::geometry_name(r.geometry));
  j["genus"] = r.deck.genus;
  const bool geodesic = r.has_geodesic_polygon && !r.has_polygon;
  j["word"] = geodesic ? r.geodesic_polygon.word
                       : (r.has_polygon || (r.has_deck && r.polygon_cut.status == Status::Ok) ? r.polygon_cut.word : r.cut.word);
  j["convention"] =
      r.geometry == Geometry::Hyperbolic
          ? std::string("each generator X maps side X of the polygon onto side X^-1, reversing it; H: z -> e^{i theta}(z - z0)/(1 - "
                        "conj(z0) z) = (a z + b)/(conj(b) z + conj(a)) on the Poincare disk; relation [A1^-1,B1]...[Ag^-1,Bg] = 1; ") +
                (geodesic ? "generators in the frame of the geodesic canonical polygon (report.json's polygon.vertices, the "
                            "polygon centred), each a word in the domain_side_pairings (generator_words), which are in the "
                            "frame of mesh.obj and domain.obj"
                          : "generators in the frame of polygon.obj (the polygon centred), domain_side_pairings in that of "
                            "mesh.obj and domain.obj")
          : "each generator X maps side X of the polygon onto side X^-1: z -> z + translation";
  if (geodesic) j["generator_words"] = r.canonical_words;
  j["relation_error"] = r.has_deck ? real(r.deck.relation_error) : Json(nullptr);
  if (r.has_deck && r.geometry == Geometry::Hyperbolic) j["relator"] = moebius_json(r.deck.relator);
  j["generators"] = generators_array(r.deck.generators);
  if (!r.domain_maps.empty()) {
    j["domain_side_pairings"] = generators_array(r.domain_maps);
    j["domain_cycle_error"] = real(r.domain_cycle_error);
    j["domain_adjusted_cycle_error"] = real(r.domain_adjusted_cycle_error);
    j["domain_pairing_adjustment"] = real(r.domain_pairing_adjustment);
    if (r.has_deck) {
      j["fitted_relation_error"] = real(r.fitted_relation_error);
      j["tile_consistency"] = real(r.tile_consistency);
    }
  }
  return j.dump(2) + '\n';
}

// ---- stored metrics (`ricci layout`) ------------------------------------------------------------

struct StoredMetric {
  Status status = Status::NotRun;
  std::string message;
  std::optional<Geometry> geometry;
  std::vector<double> lengths;
};

/// Reads the edge lengths of a metric file written by `ricci flow -o` (CSV or JSON) and checks
/// that its edges are the mesh's edges.
StoredMetric read_metric(const std::string& path, const ricci::Topology& t) {
  StoredMetric m;
  auto fail = [&](Status s, const std::string& msg) {
    m.status = s;
    m.message = path + ": " + msg;
    m.lengths.clear();
    return m;
  };
  std::error_code ec;
  if (!fs::exists(path, ec)) return fail(Status::FileNotFound, "no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(Status::FileUnreadable, "cannot be read");
  if (std::string too_large = input_too_large(path); !too_large.empty()) {
    m.status = Status::FileTooLarge;
    m.message = std::move(too_large);
    return m;
  }
  const Index E = t.num_edges;
  std::vector<std::array<Index, 2>> ends;
  std::vector<double> len;
  if (has_extension(path, {".json"})) {
    Json j;
    try {
      j = Json::parse(in);
    } catch (const std::exception& e) {
      return fail(Status::ParseError, std::string("not valid JSON: ") + e.what());
    }
    if (j.contains("geometry") && j["geometry"].is_string()) m.geometry = parse_geometry(j["geometry"].get<std::string>());
    if (!j.contains("edges") || !j["edges"].is_object()) return fail(Status::ParseError, "no \"edges\" object");
    const Json& ed = j["edges"];
    for (const char* k : {"v0", "v1", "length"})
      if (!ed.contains(k) || !ed[k].is_array()) return fail(Status::ParseError, std::string("edges has no array \"") + k + "\"");
    const std::size_t n = ed["length"].size();
    if (ed["v0"].size() != n || ed["v1"].size() != n) return fail(Status::ParseError, "edges arrays differ in length");
    for (std::size_t e = 0; e < n; ++e) {
      const Json &a = ed["v0"][e], &b = ed["v1"][e], &l = ed["length"][e];
      if (!a.is_number_integer() || !b.is_number_integer() || !l.is_number())
        return fail(Status::ParseError, "edge " + std::to_string(e) + ": v0, v1 must be integers and length a number");
      ends.push_back({a.get<Index>(), b.get<Index>()});
      len.push_back(l.get<double>());
    }
  } else {
    std::string line;
    std::int64_t lineno = 0;
    bool in_edges = false;
    while (std::getline(in, line)) {
      ++lineno;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.empty()) continue;
      if (line[0] == '#') {
        if (line.rfind("# geometry=", 0) == 0) {
          const std::size_t sp = line.find(' ', 11);
          m.geometry = parse_geometry(line.substr(11, sp == std::string::npos ? std::string::npos : sp - 11));
        }
        if (line.rfind("# edge,", 0) == 0) in_edges = true;
        if (line.rfind("# vertex,", 0) == 0) in_edges = false;
        continue;
      }
      if (!in_edges) continue;
      std::istringstream ss(line);
      std::string f[4];
      for (auto& x : f)
        if (!std::getline(ss, x, ',')) break;
      char* end = nullptr;
      const long long v0 = std::strtoll(f[1].c_str(), &end, 10);
      const bool ok0 = !f[1].empty() && *end == '\0';
      const long long v1 = std::strtoll(f[2].c_str(), &end, 10);
      const bool ok1 = !f[2].empty() && *end == '\0';
      const double l = std::strtod(f[3].c_str(), &end);
      const bool ok2 = !f[3].empty() && *end == '\0';
      if (!ok0 || !ok1 || !ok2)
        return fail(Status::ParseError, "line " + std::to_string(lineno) + ": expected 'edge,v0,v1,length'");
      ends.push_back({static_cast<Index>(v0), static_cast<Index>(v1)});
      len.push_back(l);
      if (static_cast<Index>(len.size()) > E) break;
    }
  }
  if (static_cast<Index>(len.size()) != E)
    return fail(Status::ParseError, "has " + std::to_string(len.size()) + " edges but the mesh has " + std::to_string(E) +
                                        " (a metric of another mesh?)");
  for (Index e = 0; e < E; ++e) {
    if (ends[e][0] != t.edge_vertices[2 * e] || ends[e][1] != t.edge_vertices[2 * e + 1])
      return fail(Status::ParseError, "edge " + std::to_string(e) + " joins " + std::to_string(ends[e][0]) + "-" +
                                          std::to_string(ends[e][1]) + " but the mesh's edge " + std::to_string(e) +
                                          " joins " + std::to_string(t.edge_vertices[2 * e]) + "-" +
                                          std::to_string(t.edge_vertices[2 * e + 1]) + " (a metric of another mesh?)");
    if (!(len[e] > 0) || !std::isfinite(len[e]))
      return fail(Status::DegenerateFace, "the length of edge " + std::to_string(e) + " is not a positive finite number");
  }
  m.lengths = std::move(len);
  m.status = Status::Ok;
  return m;
}

// ---- the report -----------------------------------------------------------------------------

using Run = UniformizeRun;
using Settings = UniformizeSettings;

/// report.json's "layout": the layout's figures (over its charts when it is an atlas).
Json layout_json(const ricci::UniformizeResult& r) {
  const ricci::Layout& L = r.layout;
  Json j = Json{{"domain", r.has_cut ? (r.geometry == Geometry::Hyperbolic ? "poincare-disk" : "plane") : "sphere"},
                {"max_edge_length_error", real(L.max_edge_length_error)},
                {"flipped_faces", L.flipped_faces},
                {"rounding_floor", real(L.rounding_floor)},
                {"max_error_above_rounding", real(std::max(0.0, L.max_error_above_rounding))},
                {"excused_edges", r.layout_excused.edges},
                {"excused_area_fraction", real(r.layout_excused.area_fraction)},
                {"polish_sweeps", L.polish_sweeps},
                {"polish_steps", L.polish_steps},
                {"shape_solve", L.shape_solve},
                {"seed_face", L.seed_face},
                {"depth", L.depth},
                {"patches", L.patches},
                {"patch_seam_error", L.patches > 0 ? real(L.patch_seam_error) : Json(nullptr)},
                {"vertices", static_cast<std::int64_t>(L.positions.size() / std::max(1, L.dims))},
                {"mobius_length_change", r.has_cut ? Json(nullptr) : real(L.mobius_length_change)},
                {"charts", r.has_atlas ? r.atlas.num_charts() : 1},
                {"atlas", r.has_atlas ? atlas_json(r) : Json(nullptr)}};
  if (r.has_atlas) {
    j["max_edge_length_error"] = real(r.atlas.max_edge_length_error);
    j["flipped_faces"] = r.atlas.flipped_faces;
  }
  return j;
}

Json report_json(const Run& run) {
  const ricci::UniformizeResult& r = run.result;
  const bool have = run.have_result;
  Json j;
  j["status"] = status_text(run.status);
  j["message"] = run.message;
  j["failed_stage"] = have && !r.failed_stage.empty() ? Json(r.failed_stage) : Json(nullptr);
  j["input"] = run.file;
  j["embedded_default"] = run.embedded;
  if (run.have_mesh) {
    const Run::Counts& t = run.counts;
    j["mesh"] = Json{{"vertices", t.vertices},     {"edges", t.edges},
                     {"faces", t.faces},           {"boundary_loops", t.boundary_loops},
                     {"euler_characteristic", t.euler_characteristic}, {"genus", t.genus}};
  } else {
    j["mesh"] = nullptr;
  }
  j["geometry"] = have ? Json(std::string(ricci::geometry_name(r.geometry))) : Json(nullptr);
  j["scheme"] = run.from_metric ? Json(nullptr) : Json(run.scheme);
  // Lengths and euclidean layouts are in the input's unit times length_scale (input_scale: the
  // exact power of two applied to positions spanning less than 2^-100 or more than 2^100).
  j["input_scale"] = have ? real(r.input_scale) : Json(nullptr);
  j["length_scale"] = have && r.metric.status == Status::Ok ? real(r.metric.length_scale) : Json(nullptr);
  j["flips"] = have && r.intrinsic.used;
  if (have && r.intrinsic.used) {
    const ricci::IntrinsicSummary& in = r.intrinsic;
    j["intrinsic"] = Json{{"delaunay_flips", in.delaunay_flips},
                          {"flow_flips", in.flow_flips},
                          {"crossings", in.crossings},
                          {"straight_tiles", in.straight_tiles},
                          {"inconsistent_vertices", in.inconsistent_vertices},
                          {"degenerate_faces", in.degenerate_faces},
                          {"max_angle_sum_error", real(in.max_angle_sum_error)},
                          {"refined", in.refined},
                          {"doubled", in.doubled},
                          {"refinement_faces", in.refined ? Json(run.refinement_faces) : Json(nullptr)},
                          {"input_flipped_faces", in.refined ? Json(run.input_flipped_faces) : Json(0)}};
  } else {
    j["intrinsic"] = nullptr;
  }
  if (have && (r.steiner.used || !r.steiner.note.empty())) {
    const ricci::SteinerSummary& st = r.steiner;
    j["steiner"] = Json{{"used", st.used},
                        {"levels", st.levels},
                        {"median_jump", real(st.median_jump)},
                        {"refined_median_jump", st.used ? real(st.refined_median_jump) : Json(nullptr)},
                        {"vertices_added", st.vertices_added},
                        {"boundary_splits", st.boundary_splits},
                        {"boundary_split_rounds", st.boundary_split_rounds},
                        {"chord_splits", st.chord_splits},
                        {"faces", st.used ? Json(r.steiner_mesh.topology.num_faces) : Json(nullptr)},
                        {"note", st.note.empty() ? Json(nullptr) : Json(st.note)}};
  } else {
    j["steiner"] = nullptr;
  }
  j["fallback"] = have && !r.intrinsic.fallback.empty() ? Json(r.intrinsic.fallback) : Json(nullptr);
  j["boundary"] = have && run.have_mesh ? (run.counts.boundary_loops == 0 ? Json("none") : Json(std::string(ricci::boundary_mode_name(r.boundary))))
                                        : Json(nullptr);
  const bool flowed = have && !run.from_metric && r.flow.status != Status::NotRun;
  j["iterations"] = flowed ? Json(r.flow.iterations) : Json(nullptr);
  j["chord_steps"] = flowed ? Json(r.flow.chord_steps) : Json(nullptr);
  j["max_curvature_error"] = flowed ? real(r.flow.max_curvature_error) : Json(nullptr);
  j["curvature_resolution"] = flowed ? real(r.flow.curvature_resolution) : Json(nullptr);
  j["gauss_bonnet_error"] = flowed ? real(r.flow.gauss_bonnet_error) : Json(nullptr);
  const bool laid = have && r.layout.status == Status::Ok;
  j["layout"] = laid ? layout_json(r) : Json(nullptr);
  j["seed_independence_error"] = laid && !r.seed_faces_checked.empty() ? real(r.seed_independence_error) : Json(nullptr);
  j["seed_check_vertices"] = laid && !r.seed_faces_checked.empty() && r.geometry != Geometry::Spherical
                                 ? Json(r.seed_check_vertices)
                                 : Json(nullptr);
  j["seed_faces_checked"] = have ? Json(r.seed_faces_checked) : Json::array();
  auto cut_json = [](const ricci::CutResult& c) {
    return Json{{"genus", c.genus},
                {"boundary_loops", c.boundary_loops},
                {"word", c.word},
                {"canonical", c.canonical},
                {"base_vertex", c.base_vertex},
                {"sides", c.num_sides()},
                {"refined_vertices", c.num_refined_vertices()},
                {"cut_vertices", c.num_cut_vertices()}};
  };
  if (have && r.has_cut && r.cut.status == Status::Ok) {
    Json c = cut_json(r.cut);
    c["kind"] = r.cut.compact ? "compact" : "canonical";
    j["cut"] = std::move(c);
  } else {
    j["cut"] = nullptr;
  }
  if (have && r.has_polygon) {
    Json c = cut_json(r.polygon_cut);
    c["max_edge_length_error"] = real(r.polygon.max_edge_length_error);
    c["rounding_floor"] = real(r.polygon.rounding_floor);
    c["flipped_faces"] = r.polygon.flipped_faces;
    Json cands = Json::array();
    for (const ricci::BaseCandidate& b : r.candidates)
      cands.push_back(Json{{"base_vertex", b.base_vertex},
                           {"refined_vertices", b.refined_vertices},
                           {"relation_error", real(b.relation_error)},
                           {"max_edge_length_error", real(b.max_edge_length_error)},
                           {"rounding_floor", real(b.rounding_floor)},
                           {"seconds", b.seconds},
                           {"note", b.note}});
    c["base_candidates"] = std::move(cands);
    c["kind"] = "mesh";
    if (r.has_geodesic_polygon) c["geodesic"] = geodesic_polygon_json(r.geodesic_polygon, r.canonical_words);
    j["polygon"] = std::move(c);
  } else if (have && r.has_geodesic_polygon) {
    j["polygon"] = geodesic_polygon_json(r.geodesic_polygon, r.canonical_words);
  } else {
    j["polygon"] = nullptr;
  }
  j["generators"] = have && r.has_deck && r.deck.status == Status::Ok ? generators_array(r.deck.generators) : Json::array();
  j["signature"] = run.signature;
  const bool domain = have && !r.domain_maps.empty();
  j["domain_cycle_error"] = domain ? real(r.domain_cycle_error) : Json(nullptr);
  j["domain_adjusted_cycle_error"] = domain ? real(r.domain_adjusted_cycle_error) : Json(nullptr);
  j["domain_pairing_adjustment"] = domain ? real(r.domain_pairing_adjustment) : Json(nullptr);
  j["relation_error"] = have && r.has_deck && r.deck.status == Status::Ok ? real(r.deck.relation_error) : Json(nullptr);
  j["fitted_relation_error"] =
      domain && r.has_deck && r.deck.status == Status::Ok ? real(r.fitted_relation_error) : Json(nullptr);
  j["angle_distortion"] = have && !r.angles.ratio.empty()
                              ? Json{{"mean", real(r.angles.mean_abs_log)}, {"max", real(r.angles.max_abs_log)}}
                              : Json(nullptr);
  j["conformal_distortion"] =
      run.distortion ? Json{{"faces", run.distortion->faces},
                            {"mean", real(run.distortion->mean)},
                            {"median", real(run.distortion->median)},
                            {"p95", real(run.distortion->p95)},
                            {"max", real(run.distortion->max)}}
                     : Json(nullptr);
  Json timings = Json::object();
  timings["load"] = run.load_seconds;
  if (have)
    for (const auto& [name, s] : r.timings) timings[name] = s;
  timings["outputs"] = run.write_seconds;
  if (run.pictures_seconds > 0) timings["pictures"] = run.pictures_seconds;
  j["timings"] = std::move(timings);
  j["total_seconds"] = run.total_seconds;
  j["malloc_huge_pages"] = malloc_huge_pages();
  j["output_dir"] = run.output_dir.empty() ? Json(nullptr) : Json(run.output_dir);
  j["outputs"] = run.outputs;
  Json history = Json::array();
  if (flowed)
    for (const ricci::IterationRecord& h : r.flow.history)
      history.push_back(Json{{"iteration", h.iteration}, {"max_error", real(h.max_error)}, {"seconds", real(h.seconds)}});
  j["history"] = std::move(history);
  j["notes"] = run.notes;
  j["repairs"] = repairs_json(run.repairs);
  return j;
}

int finish(const UniformizeCommandOptions& o, Run& run, Clock::time_point start, std::optional<int> code = std::nullopt) {
  run.total_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (!run.console) return code ? *code : exit_code(run.status);
  if (o.json) {
    std::cout << report_json(run).dump(2) << '\n';
  } else if (run.have_result && run.status == run.result.status) {
    std::cout << run.result.brief_report() << '\n';
  } else if (run.have_result) {
    // The pipeline's result stands, but what came after it (writing OUTDIR) failed: no "ok".
    std::cout << ricci::status_name(run.status) << ": " << run.message << '\n';
  }
  return finish_stdout(code ? *code : exit_code(run.status));
}

void fail(Run& run, Status status, const std::string& message) {
  run.status = status;
  run.message = message;
  if (run.console) print_error(message);
}

// A note recorded once in the report (steps may run again, e.g. the surface for the Python module
// and then for OUTDIR) and printed unless quiet.
void add_note(const UniformizeCommandOptions& o, Run& run, const std::string& note) {
  if (std::find(run.notes.begin(), run.notes.end(), note) != run.notes.end()) return;
  run.notes.push_back(note);
  print_note(o.quiet || !run.console, note);
}

// ---- run_uniformize, stage by stage: each helper returns an exit code when the run ends there ----

int usage_error(const UniformizeCommandOptions& o, Run& run, Clock::time_point start, const std::string& m) {
  fail(run, Status::InvalidArgument, m);
  return finish(o, run, start, kExitUsage);
}

// The options checked and turned into Settings (a usage error otherwise).
std::optional<int> read_settings(const UniformizeCommandOptions& o, Run& run, Clock::time_point start, Settings& st) {
  auto usage = [&](const std::string& m) { return usage_error(o, run, start, m); };
  std::string why;
  ricci::UniformizeOptions& uo = st.uo;
  if (o.geometry != "auto") {
    uo.geometry = parse_geometry(o.geometry);
    if (!uo.geometry) return usage("unknown geometry '" + o.geometry + "'");
  }
  const std::optional<ricci::Scheme> scheme = parse_scheme(o.scheme == "auto" ? std::string("yamabe") : o.scheme);
  if (!scheme) return usage("unknown scheme '" + o.scheme + "'");
  uo.intrinsic_flips = !o.no_flips;
  uo.steiner_max_levels = o.steiner_levels;
  uo.boundary_split_rounds = o.boundary_split_rounds;
  uo.split_chords = !o.no_split_chords;
  const std::optional<TargetSpec> target_spec = parse_target(o.target, &why);
  if (!target_spec) return usage(why);
  const std::optional<BoundarySpec> boundary_spec = parse_boundary(o.boundary, &why);
  if (!boundary_spec) return usage(why);
  st.target = *target_spec;
  st.boundary = *boundary_spec;
  uo.metric.scheme = *scheme;
  uo.metric.relax_angles = !o.no_angle_relax;
  uo.flow.tolerance = o.tolerance;
  if (o.max_iterations > 0) uo.flow.max_iterations = o.max_iterations;
  std::string threads_note;
  uo.flow.threads = usable_threads(o.threads, threads_note);
  if (!threads_note.empty()) {
    run.notes.push_back(threads_note);
    print_note(o.quiet, threads_note);
  }
  uo.flow.normalize_circle_domains = !o.no_circle_normalization;
  uo.base_candidates = o.base_candidates;
  uo.mesh_polygon = o.mesh_polygon;
  uo.use_atlas = !o.no_atlas;
  uo.cut_beside_flow = !o.cut_after_flow;
  uo.seed_checks = o.seed_checks;
  uo.layout.unit_box = o.unit_box;
  uo.layout.patches = o.patches;
  uo.layout.refine_above = o.layout_refine_above;
  if (!uo.is_valid(&why)) return usage(why);
  return std::nullopt;
}

// -o OUTDIR given, and fit to be (re)placed without touching the input files.
std::optional<int> check_outdir(const UniformizeCommandOptions& o, Run& run, Clock::time_point start, const Settings& st) {
  if (o.output.empty()) return usage_error(o, run, start, "-o OUTDIR is required");
  std::vector<std::string> protected_paths;
  if (!run.embedded && !run.preread) protected_paths.push_back(o.mesh);
  if (st.target.kind == TargetSpec::Kind::Cones) protected_paths.push_back(st.target.file);
  if (run.from_metric) protected_paths.push_back(o.metric);
  Status s = Status::Ok;
  const std::string m = check_output_dir(o.output, protected_paths, &s);
  if (s != Status::Ok) {
    fail(run, s, m);
    return finish(o, run, start);
  }
  return std::nullopt;
}

// The input (or the embedded default) loaded and validated into v; its repairs noted.
std::optional<int> load_for_run(const UniformizeCommandOptions& o, const char* cmd, Run& run, Clock::time_point start,
                                ricci::ValidateResult& v) {
  if (run.embedded)
    print_note(o.quiet, std::string("no MESH given; using the embedded default mesh ") + embedded_default_name());
  ricci::ValidateOptions vo;
  vo.keep_largest_component = o.largest_component;
  ricci::LoadResult loaded = run.preread ? ricci::validate_read(*run.preread, run.file, vo)
                                         : load_input(run.embedded ? std::string() : o.mesh, vo);
  run.load_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (loaded.status != Status::Ok) {
    fail(run, loaded.status, loaded.message);
    return finish(o, run, start);
  }
  run.repairs = loaded.repairs;
  for (const ricci::Repair& rep : run.repairs) print_note(o.quiet, rep.message);
  run.input_format = loaded.read.format;
  run.file_vertices = loaded.read.mesh.num_vertices();
  run.file_faces = loaded.read.mesh.num_faces();
  if (loaded.read.welded_vertices > 0)
    print_note(o.quiet, "welded " + std::to_string(loaded.read.welded_vertices) + " STL corners into earlier vertices");
  v = std::move(loaded.validated);
  run.counts.take(v.topology);
  run.have_mesh = true;
  const ricci::Topology& topo = v.topology;
  print_note(o.quiet, std::string(cmd) + ": loaded " + run.file + ": " + std::to_string(topo.num_vertices) +
                          " vertices, " + std::to_string(topo.num_faces) + " faces, genus " + std::to_string(topo.genus()) +
                          ", " + std::to_string(topo.num_boundary_loops()) + " boundary loops (" +
                          sci(run.load_seconds) + " s)");

  return std::nullopt;
}

// `ricci layout`: the stored metric read against the mesh (its ears split as `ricci flow` split
// them, when that is what makes it match), then laid out.
std::optional<int> lay_out_stored_metric(const UniformizeCommandOptions& o, Run& run, Clock::time_point start,
                                         const ricci::UniformizeOptions& uo, ricci::ValidateResult& v) {
  const ricci::Topology& topo = v.topology;
  StoredMetric m = read_metric(o.metric, topo);
  if (m.status != Status::Ok && !topo.is_closed() && !ricci::find_ears(topo).empty()) {
    // A metric from `ricci flow` whose ears were split: try the splits flow makes with the
    // default target (circle, then geodesic boundary), then every ear; keep the one that matches.
    for (int attempt = 0; attempt < 3 && m.status != Status::Ok; ++attempt) {
      ricci::ValidateResult w = v;
      if (attempt < 2) {
        const ricci::BoundaryMode mode = attempt == 0 ? ricci::BoundaryMode::Circle : ricci::BoundaryMode::Geodesic;
        if (!split_infeasible_ears(w, mode, TargetSpec{}, BoundarySpec{}, "auto", "auto").repair) continue;
      } else if (ricci::split_ears(w, ricci::find_ears(w.topology)) != Status::Ok) {
        continue;
      }
      StoredMetric again = read_metric(o.metric, w.topology);
      if (again.status != Status::Ok) continue;
      m = std::move(again);
      v = std::move(w);
      run.repairs.push_back(v.repairs.back());
      print_note(o.quiet, v.repairs.back().message);
      run.counts.take(v.topology);
    }
  }
  if (m.status != Status::Ok) {
    fail(run, m.status, m.message);
    return finish(o, run, start);
  }
  Geometry g = m.geometry ? *m.geometry : ricci::natural_geometry(topo);
  if (uo.geometry && m.geometry && *uo.geometry != *m.geometry)
    return usage_error(o, run, start, "--geometry " + o.geometry + " contradicts the metric file's geometry " +
                 std::string(ricci::geometry_name(*m.geometry)));
  if (uo.geometry) g = *uo.geometry;
  run.result = ricci::lay_out_metric(v.mesh, topo, g, m.lengths, uo);
  return std::nullopt;
}

// `ricci uniformize`: boundary mode and target as for `ricci flow` (prepare_target(): ears the
// target cannot realise split), then the whole pipeline.
std::optional<int> uniformize_with_target(const UniformizeCommandOptions& o, Run& run, Clock::time_point start,
                                          Settings& st, ricci::ValidateResult& v) {
  ricci::UniformizeOptions& uo = st.uo;
  const ricci::Topology& topo = v.topology;
  const Geometry g = uo.geometry ? *uo.geometry : ricci::natural_geometry(topo);
  PreparedTarget prepared = prepare_target(v, g, st.target, st.boundary, o.target, o.boundary, !o.no_split_ears, run.file);
  if (!topo.is_closed()) uo.boundary = prepared.mode;
  for (const std::string& note : prepared.notes) {
    run.notes.push_back(note);
    print_note(o.quiet, note);
  }
  if (prepared.ear_split) {
    run.repairs.push_back(*prepared.ear_split);
    print_note(o.quiet, prepared.ear_split->message);
    run.counts.take(v.topology);
  }
  if (prepared.usage) return usage_error(o, run, start, prepared.message);
  if (prepared.status != Status::Ok) {
    fail(run, prepared.status, prepared.message);
    return finish(o, run, start);
  }
  run.result = ricci::uniformize(v.mesh, topo, uo, &prepared.target);
  return std::nullopt;
}

// Notes on the result (fallback, mollification, the flow's notes, flipped faces, far-out
// coordinates); the run fails here when the result did.
std::optional<int> note_result(const UniformizeCommandOptions& o, Run& run, Clock::time_point start) {
  ricci::UniformizeResult& r = run.result;
  if (!r.intrinsic.fallback.empty()) run.scheme = "circle-packing";
  if (const auto rep = mollification_repair(r.metric.mollification)) {
    run.repairs.push_back(*rep);
    print_note(o.quiet, rep->message);
  }
  for (const std::string& n : r.flow.notes) {
    run.notes.push_back(n);
    print_note(o.quiet, n);
  }
  if (r.status != Status::Ok) {
    fail(run, r.status, run.file + ": " + r.message);
    if (run.console && !o.output.empty()) print_error("no output written to " + o.output);
    return finish(o, run, start);
  }
  const Index flipped = r.has_atlas ? r.atlas.flipped_faces : r.layout.flipped_faces;
  if (flipped > 0) {
    const std::string note = "the layout has " + std::to_string(flipped) + " flipped faces (first: face " +
                             std::to_string(r.has_atlas ? r.atlas.first_flipped_face : r.layout.first_flipped_face) +
                             ")" + (r.has_atlas ? ", each in its own chart" : "");
    run.notes.push_back(note);
    print_note(o.quiet, note);
  }
  if (r.has_atlas) {
    const std::string note =
        "one chart's coordinates resolve the layout only to " + sci(r.layout.max_edge_length_error) +
        " of an edge's length, so it is laid out in " + std::to_string(r.atlas.num_charts()) +
        " charts (a group in mesh.obj and layout.atlas in report.json per chart): every face within " +
        sci(r.atlas.max_edge_length_error) + " in its own chart, transition maps fitted to " +
        sci(r.atlas.max_transition_error) + "; the pictures, domain.obj, cover and deck use the first chart";
    run.notes.push_back(note);
    print_note(o.quiet, note);
  }
  if (r.layout_excused.edges > 0) {
    const std::string note = std::to_string(r.layout_excused.edges) +
                             " edges of the layout miss their length by more than the layout limit, each within " +
                             sci(ricci::kRoundingAllowance) + " times what its coordinates resolve (edges far shorter than their neighbours); their faces "
                             "are " + sci(r.layout_excused.area_fraction) + " of the surface's area";
    run.notes.push_back(note);
    print_note(o.quiet, note);
  }
  if (r.layout.rounding_floor > 1e-9 && !r.has_atlas) {
    const std::string note =
        "double-precision coordinates resolve some edge lengths of the layout only to " + sci(r.layout.rounding_floor) +
        " of their length (layout.rounding_floor): edges far shorter than the other edges of their triangles" +
        (r.geometry == ricci::Geometry::Hyperbolic ? ", or edges far out in the Poincaré disk (where a cut polygon reaches)"
                                                   : "");
    run.notes.push_back(note);
    print_note(o.quiet, note);
  }

  return std::nullopt;
}

// The surface mesh.obj holds and, for a refined result, the input laid out through the subdivision
// (uniformize_surface() in uniformize_run.h).
std::optional<int> output_surface(const UniformizeCommandOptions& o, Run& run, Clock::time_point start,
                                  const ricci::ValidateResult& v, ricci::Mesh& surface, ricci::InputSurfaceLayout& through) {
  const ricci::UniformizeResult& r = run.result;
  const ricci::Topology& topo = v.topology;
  const bool sphere = !r.has_cut;
  if (r.intrinsic.refined) {
    through = ricci::input_surface_layout(v.mesh, topo, r);
    if (through.status != Status::Ok) {
      fail(run, through.status, run.file + ": " + through.message);
      return finish(o, run, start);
    }
    run.input_flipped_faces = through.flipped_faces;
    add_note(o, run, std::to_string(through.flipped_faces) + " of the input's faces, made straight, come out " +
                         "flipped or degenerate" + (through.flipped_faces > 0 ? " (first: face " +
                         std::to_string(through.first_flipped_face) + ")" : std::string()) +
                         "; refinement.obj holds the common subdivision, which maps bijectively");
    run.refinement_faces = sphere ? r.refinement.topology.num_faces : static_cast<Index>(r.cut.surface_faces.size() / 3);
  }
  if (sphere) {
    surface = v.mesh;
    surface.texcoords.clear();
    surface.corner_texcoords.clear();
    run.sphere_positions = r.intrinsic.refined ? through.mesh.positions : r.layout.positions;
  } else {
    // The input's faces with their layout (through the subdivision when refined; per chart with
    // an atlas).
    surface = r.intrinsic.refined ? through.mesh
              : r.has_atlas       ? ricci::surface_with_atlas_uvs(r.cut, r.atlas)
                                  : ricci::surface_with_cut_uvs(r.cut, r.layout.positions);
  }
  return std::nullopt;
}

// A text output made on another thread when there is a second core (else when it is taken): the
// large text files are made beside mesh.glb and the signature (torus-100k: metric.csv 53 ms and
// domain.obj 16 ms beside the glb's 81 ms). The work reads the result and the input only.
std::shared_future<std::string> beside(std::function<std::string()> make) {
  return std::async(ricci::available_threads() >= 2 ? std::launch::async : std::launch::deferred, std::move(make))
      .share();
}

// Every output file but the pictures and the reports, into `files`; `surface` is what mesh.obj
// holds (and the checkerboard renders), `cover` the universal cover when there is one.
std::optional<int> output_files(const UniformizeCommandOptions& o, Run& run, Clock::time_point start, const Settings& st,
                                const ricci::ValidateResult& v, std::vector<OutFile>& files, ricci::Mesh& surface,
                                ricci::CoverResult& cover) {
  const ricci::UniformizeResult& r = run.result;
  const ricci::Topology& topo = v.topology;
  const bool sphere = !r.has_cut;
  ricci::InputSurfaceLayout through;
  if (const auto rc = output_surface(o, run, start, v, surface, through)) return rc;
  // A refined result: the common subdivision itself (refinement.obj), which maps bijectively
  // where straight input faces fold.
  if (r.intrinsic.refined) {
    const ricci::CommonSubdivision& cs = r.refinement;
    if (sphere) {
      files.push_back({"refinement.obj", refinement_obj("the common subdivision of the input and the final intrinsic "
                                                        "triangulation, on the input surface", run.file,
                                                        cs.mesh.positions, cs.mesh.faces, cs.face_input, {}, {})});
      files.push_back({"refinement-sphere.obj",
                       refinement_obj("the common subdivision on the unit sphere", run.file, r.layout.positions,
                                      cs.mesh.faces, cs.face_input, {}, {})});
    } else {
      std::vector<Index> tags(r.cut.surface_face_to_input.size());
      for (std::size_t f = 0; f < tags.size(); ++f) tags[f] = cs.face_input[r.cut.surface_face_to_input[f]];
      const std::vector<double>& sx = r.cut.surface_positions;
      // With an atlas, each piece's texture coordinates are in its own chart.
      const ricci::Mesh charted = r.has_atlas ? ricci::surface_with_atlas_uvs(r.cut, r.atlas) : ricci::Mesh{};
      files.push_back({"refinement.obj",
                       refinement_obj("the common subdivision of the input and the final intrinsic triangulation, with "
                                      "its layout as texture coordinates" +
                                          std::string(r.has_atlas ? " (each piece in its own chart: "
                                                                    "report.json layout.atlas.face_chart)"
                                                                  : ""),
                                      run.file, sx, r.cut.surface_faces, tags,
                                      r.has_atlas ? charted.texcoords : r.layout.positions,
                                      r.has_atlas ? charted.corner_texcoords : r.cut.cut_faces)});
    }
  }
  if (r.has_atlas) {
    files.push_back({"mesh.obj", obj_with_chart_groups(ricci::serialize_mesh(surface, ricci::FileFormat::Obj),
                                                       r.intrinsic.refined ? through.face_chart : r.atlas.face_chart)});
  } else {
    files.push_back({"mesh.obj", {}, [&surface](const ricci::ByteSink& sink) {
                       return ricci::serialize_mesh_to(surface, ricci::FileFormat::Obj, sink);
                     }});
  }
  if (sphere) {
    ricci::Mesh s;
    s.positions = run.sphere_positions;
    s.faces = v.mesh.faces;
    files.push_back({"sphere.obj", ricci::serialize_mesh(s, ricci::FileFormat::Obj)});
  } else {
    files.push_back({"domain.obj", {}, {}, beside([&r, &run] {
                       return disk_obj(r.cut, r.layout.positions, r.geometry,
                                       r.cut.compact ? "the compact fundamental domain" : "the cut disk", run.file);
                     })});
    if (r.has_polygon && !r.domain_maps.empty())
      files.push_back({"polygon.obj", disk_obj(r.polygon_cut, r.polygon.positions, r.geometry,
                                               "the canonical fundamental polygon", run.file)});
  }
  if (!run.from_metric) {
    const MetricHeader header{run.file,
                              std::string(ricci::geometry_name(r.geometry)),
                              run.scheme,
                              topo.is_closed() ? std::string("none") : std::string(ricci::boundary_mode_name(r.boundary)),
                              st.target.kind == TargetSpec::Kind::Uniform ? std::string("uniform") : o.target,
                              "newton",
                              r.intrinsic.used,
                              !r.intrinsic.used || r.intrinsic.straight_tiles};
    files.push_back({"metric.csv", {}, {}, beside([header, &r, &topo, &v] {
                       if (!r.steiner.used) return metric_file_text(header, r.flow, topo, v.vertex_to_input, false);
                       // The subdivided surface's vertices: the input's, then the Steiner vertices (-1).
                       std::vector<Index> to_input(static_cast<std::size_t>(r.steiner_mesh.topology.num_vertices), -1);
                       std::copy(v.vertex_to_input.begin(), v.vertex_to_input.end(), to_input.begin());
                       return metric_file_text(header, r.flow, r.steiner_mesh.topology, to_input, false);
                     })});
  }
  if (!r.polygon_note.empty()) add_note(o, run, r.polygon_note);
  if (r.has_deck || !r.domain_maps.empty()) {
    files.push_back({"generators.json", generators_json(r, run.file)});
    cover = ricci::universal_cover(r.cut, r.layout.positions, tiling_group(r), cover_options(r, o.cover_depth));
    if (cover.status == Status::Ok) {
      files.push_back({"cover.svg", ricci::cover_svg(r.cut, r.layout.positions, cover)});
      // The tiling as one mesh only up to --cover-faces faces (a copy of the domain per element):
      // a genus-5 domain has dozens of neighbours, and their copies would outweigh every other
      // output together.
      const auto copies = static_cast<long long>(cover.elements.size());
      const auto tiling_faces = copies * static_cast<long long>(r.cut.cut_faces.size() / 3);
      if (tiling_faces <= o.cover_faces) {
        // Made as it is written, so the tiling's mesh exists only meanwhile.
        files.push_back({"cover.obj", {}, [&r, &cover](const ricci::ByteSink& sink) {
                           const ricci::Mesh tiling = ricci::cover_mesh(r.cut, r.layout.positions, cover);
                           return tiling.num_faces() > 0 && ricci::serialize_mesh_to(tiling, ricci::FileFormat::Obj, sink);
                         }});
      } else {
        add_note(o, run, "cover.obj not written: the tiling (" + std::to_string(copies) + " copies of the domain) has " +
                             std::to_string(tiling_faces) + " faces, more than --cover-faces " +
                             std::to_string(o.cover_faces) + " (cover.svg draws it; `ricci cover` writes the mesh)");
      }
    } else {
      add_note(o, run, "no cover written: " + cover.message);
    }
  }
  return std::nullopt;
}

// The sphere (radius 100) in the file's vertex order, or the layout at z = 0 split at the cut.
ricci::Mesh family_layout(const Run& run, const ricci::ValidateResult& v, const ricci::Mesh& surface) {
  ricci::Mesh out;
  if (run.sphere_positions.empty()) {
    for (std::size_t t = 0; t < surface.texcoords.size() / 2; ++t)
      out.positions.insert(out.positions.end(), {surface.texcoords[2 * t], surface.texcoords[2 * t + 1], 0.0});
    out.faces = surface.corner_texcoords;
    return out;
  }
  const Index nv = v.mesh.num_vertices();
  bool file_order = v.vertex_to_input.size() == static_cast<std::size_t>(nv);
  for (const Index w : v.vertex_to_input) file_order = file_order && w >= 0 && w < run.file_vertices;
  out.positions.assign(3 * static_cast<std::size_t>(file_order ? run.file_vertices : nv), 0.0);
  for (Index i = 0; i < nv; ++i) {
    const std::size_t w = static_cast<std::size_t>(file_order ? v.vertex_to_input[i] : i);
    for (int k = 0; k < 3; ++k) out.positions[3 * w + k] = 100.0 * run.sphere_positions[3 * static_cast<std::size_t>(i) + k];
  }
  out.faces = v.mesh.faces;
  if (file_order)
    for (Index& f : out.faces) f = v.vertex_to_input[f];
  return out;
}

// mesh.glb, and the files for GIFTI and FreeSurfer users (see uniformize_outputs.h).
void tool_outputs(const UniformizeCommandOptions& o, Run& run, const ricci::ValidateResult& v, const ricci::Mesh& surface,
                  std::vector<OutFile>& files, std::future<ricci::ConformalSignature>& signature) {
  const ricci::UniformizeResult& r = run.result;
  const std::vector<double> uv = corner_uv(r, surface);
  const double repeats = r.geometry == Geometry::Spherical ? 12 : 10;  // half the checks of the pictures
  const GlbResult glb = textured_glb(surface.positions, surface.faces, uv, checker_texture_png(), repeats);
  if (glb.bytes.empty()) {
    add_note(o, run, "no mesh.glb written: " + glb.message);
  } else {
    files.push_back({"mesh.glb", glb.bytes});
  }
  {
    ricci::ConformalSignature sig = signature.get();
    signature_vertices_to_file(sig, v.vertex_to_input);
    if (sig.status == Status::Ok || r.has_deck) run.signature = signature_json(sig);
    if (sig.status == Status::Ok) {
      Json j = run.signature;
      j["input"] = run.file;
      files.push_back({"signature.json", j.dump(2) + '\n'});
    }
  }
  if (run.input_format != ricci::FileFormat::Gifti && run.input_format != ricci::FileFormat::FreeSurfer) return;
  const bool sphere = !run.sphere_positions.empty();
  const VertexOverlays overlays =
      vertex_overlays(v.mesh, v.topology, v.vertex_to_input, run.file_vertices, r, surface,
                      sphere ? std::span<const double>() : std::span<const double>(uv),
                      sphere ? std::span<const double>(run.sphere_positions) : std::span<const double>());
  for (auto& [name, bytes] : family_files(run.input_format, run.file, overlays, run.file_faces,
                                          family_layout(run, v, surface), sphere))
    files.push_back({name, std::move(bytes)});
}

// The pictures, report.json and report.html added to `files`, and OUTDIR written at once.
int write_run(const UniformizeCommandOptions& o, const char* cmd, Run& run, Clock::time_point start,
              std::vector<OutFile>& files, const ricci::Mesh& surface, const ricci::CoverResult& cover) {
  const ricci::UniformizeResult& r = run.result;
  std::vector<ReportImage> images;
  if (!o.no_pictures) {
    const Clock::time_point tp = Clock::now();
    ConformalDistortion qc;
    const std::vector<NamedPicture> pics =
        uniformize_pictures(r, surface, cover.status == Status::Ok ? &cover : nullptr, &qc);
    for (const NamedPicture& p : pics) {
      files.push_back({p.id + ".png", p.png});
      if (!p.svg.empty() && p.id != "cover") files.push_back({p.id + ".svg", p.svg});
      images.push_back({p.id, p.title, p.caption, "image/png", p.png});
    }
    if (qc.faces > 0) run.distortion = qc;
    run.pictures_seconds = std::chrono::duration<double>(Clock::now() - tp).count();
    print_note(o.quiet, std::string(cmd) + ": " + std::to_string(pics.size()) + " pictures (" + sci(run.pictures_seconds) + " s)");
  }
  for (OutFile& f : files)
    if (f.later.valid()) f.data = f.later.get();
  for (const OutFile& f : files)
    if (f.data.empty() && !f.stream) {
      fail(run, Status::WriteFailed, "could not serialise " + f.name + "; nothing was written");
      return finish(o, run, start);
    }
  run.status = Status::Ok;
  run.message = "ok";
  run.output_dir = o.output;
  run.outputs.clear();
  for (const OutFile& f : files) run.outputs.push_back(f.name);
  run.outputs.push_back("report.json");
  if (!o.no_pictures) run.outputs.push_back("report.html");
  run.total_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const Json report = report_json(run);
  files.push_back({"report.json", report.dump(2) + '\n'});
  if (!o.no_pictures) files.push_back({"report.html", report_html(report, images, "ricci uniformize: " + run.file)});
  const Clock::time_point tw = Clock::now();
  const std::string werr = write_output_dir(o.output, files);
  if (!werr.empty()) {
    run.outputs.clear();
    run.output_dir.clear();
    fail(run, Status::WriteFailed, werr + "; nothing was written");
    return finish(o, run, start);
  }
  print_note(o.quiet, std::string(cmd) + ": wrote " + std::to_string(files.size()) + " files to " + o.output + " (" +
                          sci(std::chrono::duration<double>(Clock::now() - tw).count()) + " s)");
  print_note(o.quiet, std::string(cmd) + " done: " + r.brief_report());
  return finish(o, run, start);
}

}  // namespace

void uniformize_begin(const UniformizeCommandOptions& o, UniformizeRun& run) {
  run.embedded = o.mesh.empty() && !run.preread;
  run.file = run.embedded ? std::string(embedded_default_name()) : (run.preread ? run.file : o.mesh);
  run.scheme = o.scheme == "auto" ? "yamabe" : o.scheme;
  run.from_metric = !o.metric.empty();
}

std::optional<int> uniformize_settings(const UniformizeCommandOptions& o, UniformizeRun& run) {
  return read_settings(o, run, run.start, run.settings);
}

std::optional<int> uniformize_check_outdir(const UniformizeCommandOptions& o, UniformizeRun& run) {
  return check_outdir(o, run, run.start, run.settings);
}

std::optional<int> uniformize_load(const UniformizeCommandOptions& o, const char* cmd, UniformizeRun& run) {
  return load_for_run(o, cmd, run, run.start, run.input);
}

std::optional<int> uniformize_compute(const UniformizeCommandOptions& o, UniformizeRun& run) {
  Settings& st = run.settings;
  if (!o.quiet && run.console) {
    st.uo.on_stage = print_stage;
    st.uo.flow.on_iteration = [](const ricci::IterationRecord& rec) {
      std::cerr << "ricci: flow iteration " << rec.iteration << ": max error " << sci(rec.max_error, "%.3e") << ", "
                << sci(rec.seconds) << " s\n";
    };
  }
  if (const auto rc = run.from_metric ? lay_out_stored_metric(o, run, run.start, st.uo, run.input)
                                      : uniformize_with_target(o, run, run.start, st, run.input))
    return rc;
  run.have_result = true;
  if (const auto rc = note_result(o, run, run.start)) return rc;
  run.status = Status::Ok;  // the pipeline succeeded (writing OUTDIR may still fail)
  run.message = "ok";
  return std::nullopt;
}

std::optional<int> uniformize_surface(const UniformizeCommandOptions& o, UniformizeRun& run, ricci::Mesh& surface,
                                      ricci::InputSurfaceLayout& through) {
  return output_surface(o, run, run.start, run.input, surface, through);
}

int uniformize_write(const UniformizeCommandOptions& o, const char* cmd, UniformizeRun& run) {
  const Clock::time_point tw = Clock::now();
  // The conformal signature reads the result alone: with a second core it is computed there while
  // the files are made (a closed genus-5 surface's systole search takes as long as they do).
  const ricci::UniformizeResult& r = run.result;
  std::future<ricci::ConformalSignature> signature =
      std::async(ricci::available_threads() >= 2 ? std::launch::async : std::launch::deferred,
                 [&r] { return ricci::conformal_signature(r); });
  std::vector<OutFile> files;
  ricci::Mesh surface;
  ricci::CoverResult cover;
  if (const auto rc = output_files(o, run, run.start, run.settings, run.input, files, surface, cover)) return *rc;
  tool_outputs(o, run, run.input, surface, files, signature);
  run.write_seconds = std::chrono::duration<double>(Clock::now() - tw).count();
  return write_run(o, cmd, run, run.start, files, surface, cover);
}

nlohmann::ordered_json uniformize_report(const UniformizeRun& run) { return report_json(run); }

int run_uniformize(const UniformizeCommandOptions& o) {
  UniformizeRun run;
  uniformize_begin(o, run);
  const char* cmd = run.from_metric ? "layout" : "uniformize";
  if (const auto rc = uniformize_settings(o, run)) return *rc;
  if (const auto rc = uniformize_check_outdir(o, run)) return *rc;
  if (const auto rc = uniformize_load(o, cmd, run)) return *rc;
  if (const auto rc = uniformize_compute(o, run)) return *rc;
  return uniformize_write(o, cmd, run);
}

int run_cover(const CoverCommandOptions& o) {
  const Clock::time_point start = Clock::now();
  const bool svg = has_extension(o.output, {".svg"});
  if (o.output.empty() || (!svg && !has_extension(o.output, {".obj", ".off", ".ply"}))) {
    print_error("-o must name an .svg (picture) or a mesh file (.obj, .off, .ply) for the tiling");
    return finish_stdout(kExitUsage);
  }
  if (o.depth < 1 || o.depth > 12) {
    print_error("--depth must be between 1 and 12");
    return finish_stdout(kExitUsage);
  }
  if (!o.mesh.empty() && same_file(o.output, o.mesh)) {
    print_error("refusing to write " + o.output + ": it is the input file; nothing was written");
    return finish_stdout(exit_code(Status::OutputIsInput));
  }
  const std::string name = o.mesh.empty() ? std::string(embedded_default_name()) : o.mesh;
  if (o.mesh.empty()) print_note(o.quiet, std::string("no MESH given; using the embedded default mesh ") + name);
  ricci::ValidateOptions vo;
  vo.keep_largest_component = o.largest_component;
  ricci::LoadResult loaded = load_input(o.mesh, vo);
  if (loaded.status != Status::Ok) {
    print_error(loaded.message);
    return finish_stdout(exit_code(loaded.status));
  }
  const ricci::Topology& topo = loaded.validated.topology;
  if (!topo.is_closed() || topo.genus() < 1) {
    print_error(name + ": the universal cover tiling needs a closed surface of genus >= 1 (this one has genus " +
                std::to_string(topo.genus()) + " and " + std::to_string(topo.num_boundary_loops()) + " boundary loops)");
    return finish_stdout(exit_code(Status::InvalidArgument));
  }
  ricci::UniformizeOptions uo;
  uo.seed_checks = 0;
  if (!o.quiet) uo.on_stage = print_stage;
  const ricci::UniformizeResult r = ricci::uniformize(loaded.validated.mesh, topo, uo);
  if (r.status != Status::Ok) {
    print_error(name + ": " + r.message);
    return finish_stdout(exit_code(r.status));
  }
  if (!r.has_deck) {
    print_error(name + ": no deck transformations (the cut is not canonical: " + r.cut.reason + ")");
    return finish_stdout(exit_code(Status::NumericalFailure));
  }
  ricci::CoverOptions co = cover_options(r, o.depth);
  if (o.radius > 0) co.radius = o.radius;
  const ricci::CoverResult cover = ricci::universal_cover(r.cut, r.layout.positions, tiling_group(r), co);
  if (cover.status != Status::Ok) {
    print_error(name + ": " + cover.message);
    return finish_stdout(exit_code(cover.status));
  }
  ricci::WriteResult w;
  if (svg) {
    const std::string data = ricci::cover_svg(r.cut, r.layout.positions, cover);
    const InterruptsDeferred deferred;
    w = ricci::write_file_atomic(o.output, data, {o.mesh});
  } else {
    ricci::WriteOptions wo;
    wo.protected_paths = {o.mesh};
    const ricci::Mesh tiles = ricci::cover_mesh(r.cut, r.layout.positions, cover);
    const InterruptsDeferred deferred;
    w = ricci::write_mesh(o.output, tiles, wo);
  }
  if (w.status != Status::Ok) {
    print_error(w.message);
    return finish_stdout(exit_code(w.status));
  }
  const double secs = std::chrono::duration<double>(Clock::now() - start).count();
  if (o.json) {
    Json j{{"status", "ok"},
           {"input", name},
           {"geometry", std::string(ricci::geometry_name(r.geometry))},
           {"depth", o.depth},
           {"copies", static_cast<std::int64_t>(cover.elements.size())},
           {"words_generated", cover.words_generated},
           {"truncated", cover.truncated},
           {"relation_error", real(r.deck.relation_error)},
           {"output", o.output},
           {"seconds", secs}};
    std::cout << j.dump(2) << '\n';
  } else {
    std::cout << "cover: " << cover.elements.size() << " copies of the fundamental domain (depth " << o.depth << ") written to "
              << o.output << '\n';
  }
  return finish_stdout(kExitOk);
}

CLI::App* add_uniformize_command(CLI::App& app, UniformizeCommandOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "uniformize",
      "The whole job: flow to the uniformization metric (geometry by the topology), cut into a disk "
      "(canonical polygon for closed genus >= 1), lay it out (plane, Poincare disk or sphere), fit the deck "
      "transformations, and write the parameterized mesh, the metric, the generators, the cover and report.json "
      "into OUTDIR. Progress on stderr; a summary line (or --json) on stdout.");
  cmd->add_option("MESH", o.mesh,
                  "Mesh file (.obj, .off, .ply). Default: the embedded genus-2 mesh (" +
                      std::string(embedded_default_name()) + ").");
  cmd->add_option("-o,--output", o.output,
                  "Output directory (created; replaced only if it is empty or holds a previous ricci report.json). "
                  "Written only when every stage succeeded.")
      ->type_name("OUTDIR");
  cmd->add_option("--geometry", o.geometry,
                  "Background geometry: auto (spherical for closed genus 0, euclidean for genus 1 and for genus 0 "
                  "with boundary, hyperbolic otherwise), euclidean, hyperbolic or spherical. Default: auto.")
      ->check(CLI::IsMember({"auto", "euclidean", "hyperbolic", "spherical"}));
  cmd->add_option("--scheme", o.scheme,
                  "Discrete conformal scheme: auto (= yamabe), yamabe (vertex scaling, with intrinsic Delaunay flips "
                  "unless --no-flips), circle-packing (the paper's) or inversive-distance. Default: auto.")
      ->check(CLI::IsMember({"auto", "circle-packing", "inversive-distance", "yamabe"}));
  cmd->add_flag("--no-flips", o.no_flips,
                "Vertex scaling on the input's triangulation as it is, without intrinsic Delaunay flips (stops on "
                "many non-Delaunay meshes; for comparison).");
  cmd->add_option("--steiner-levels", o.steiner_levels,
                  "Vertex scaling with flips (not on closed hyperbolic surfaces): where the input's triangles, made "
                  "straight, would fold and the solution's conformal factor jumps by more than 0.05 across "
                  "the median edge (the map is not resolved by one scale per vertex), subdivide the surface on its "
                  "own faces (every edge split at its midpoint) by the levels that bring it there, at most N and at "
                  "most 65536 faces, and solve again; mesh.obj keeps the input's faces, refinement.obj and metric.csv "
                  "hold the Steiner vertices after the input's. 0: never. Default: 3.")
      ->check(CLI::Range(0, 8));
  cmd->add_option("--boundary-split-rounds", o.boundary_split_rounds,
                  "Vertex scaling with flips on circle or loop-totals boundaries: where the solve stops because "
                  "triangles lean over boundary edges (a boundary edge never flips; its opposite angle reaches pi), "
                  "split those edges at their midpoints (a flat boundary vertex each) and solve again, up to N "
                  "rounds; mesh.obj keeps the input's faces, refinement.obj and metric.csv hold the split vertices "
                  "after the input's. 0: never. Default: 4.")
      ->check(CLI::Range(0, 16));
  cmd->add_flag("--no-split-chords", o.no_split_chords,
                "Geodesic, fixed and free boundaries with vertex scaling and flips: where the solve on the surface "
                "stops and its double (where boundary edges flip) is no surface because interior edges join two "
                "boundary vertices, do not split those chords at their midpoints (a flat interior vertex each) to "
                "solve on the split surface's double; mesh.obj keeps the input's faces either way.");
  cmd->add_option("--target", o.target,
                  "Target curvature: auto (= uniform), uniform, cones=FILE or single-vertex=I (as for `ricci flow`). "
                  "Default: auto.")
      ->check(spec_validator(parse_target, "auto|uniform|cones=FILE|single-vertex=I"));
  cmd->add_option("--boundary", o.boundary,
                  "Boundary condition: auto (circle in euclidean, geodesic in hyperbolic), free, fixed, circle, "
                  "geodesic or loop-totals=T1,T2,... (as for `ricci flow`). Default: auto.")
      ->check(spec_validator(parse_boundary, "auto|free|fixed|circle|geodesic|loop-totals=T1,T2,..."));
  cmd->add_option("--tol", o.tolerance, "Flow: stop when max |target K - K| < TOL (radians). Default: 1e-12.")
      ->check(number_validator(true, false));
  cmd->add_option("--max-iter", o.max_iterations, "Flow: Newton iteration limit. Default: 200.")
      ->check(number_validator(true, true));
  cmd->add_option("--threads", o.threads, "OpenMP threads; 0 uses the OpenMP default. Default: 0.")
      ->check(number_validator(false, true));
  cmd->add_flag("--mesh-polygon", o.mesh_polygon,
                "Closed genus >= 2: the canonical polygon as a canonical cut of the mesh laid out through the compact "
                "domain (polygon.obj; seconds to minutes at genus >= 4) instead of the geodesic 4g-gon of canonical "
                "generators found from the domain's side pairings (milliseconds). Default: off.");
  cmd->add_flag("--no-atlas", o.no_atlas,
                "E and H: lay the surface out in one chart only; where its coordinates cannot resolve every face "
                "(a conformal factor spanning many orders of magnitude, e.g. a long finger) the run fails at the "
                "layout stage instead of writing an atlas of charts (groups chart_K in mesh.obj). Default: off.");
  cmd->add_flag("--cut-after-flow", o.cut_after_flow,
                "Make the cut after the flow instead of on a second thread beside it (genus 1 in E, genus 0 with "
                "several boundary loops, below 500k faces): the run takes the cut's time longer and its peak memory is lower by what "
                "the cut holds during the flow (about 70 bytes per face). Default: off.");
  cmd->add_option("--base-candidates", o.base_candidates,
                  "Closed genus >= 2 with --mesh-polygon: base vertices tried for the canonical polygon; the one whose "
                  "generators and positions double precision resolves best is kept. Default: 8.")
      ->check(number_validator(true, true));
  cmd->add_option("--seed-checks", o.seed_checks,
                  "Layouts from this many other seed faces (the first: the face farthest from the layout's own "
                  "seed) are aligned to the layout (seed_independence_error), once the layout has passed its gate (beside "
                  "the canonical polygon's stages on a closed hyperbolic surface). Default: 1.")
      ->check(number_validator(false, true));
  cmd->add_option("--cover-depth", o.cover_depth,
                  "Closed genus >= 1: word length of the cover tiling written (cover.svg, cover.obj): in the "
                  "side pairings of the compact domain (hyperbolic) or the translations a1, b1 (torus); 0: 1 "
                  "(hyperbolic: every neighbour across a side) or a 3x3 block (torus). Default: 0.")
      ->check(number_validator(false, true));
  cmd->add_option("--cover-faces", o.cover_faces,
                  "Closed genus >= 1: cover.obj (the tiling as one mesh, a copy of the domain per tile) is written "
                  "only when it has at most this many faces; otherwise a note gives its size (cover.svg still draws "
                  "the tiling; `ricci cover` writes the mesh). 0: never. Default: 250000.")
      ->check(number_validator(false, true));
  cmd->add_flag("--unit-box", o.unit_box, "Euclidean: scale the layout into the unit box [0,1]^2. Default: off.");
  cmd->add_option("--patches", o.patches,
                  "Layouts in E, H and S: divide and conquer with this many patches, laid out separately and "
                  "glued by isometries (S: rotations) fitted with Ceres over every shared vertex (kept only "
                  "when not less accurate); 0: one propagation; -1: automatic, min(32, faces/4000) and one per "
                  "10k faces above 320k faces (at most 256), only where one propagation misses its metric by "
                  "more than 1e-10 above its rounding floor. Default: -1.")
      ->check(CLI::Range(-1, 256));
  cmd->add_option("--layout-refine-above", o.layout_refine_above,
                  "Refine the layout (patches, Gauss-Seidel sweeps, global Gauss-Newton steps) only while its "
                  "relative edge-length error exceeds its coordinates' rounding floor by more than this; 0: refine "
                  "every layout down to its rounding floor. Default: 1e-10.")
      ->check(number_validator(false, false));
  cmd->add_flag("--no-pictures", o.no_pictures,
                "Write no pictures and no report.html (only the meshes, metric, generators and report.json). "
                "Default: off.");
  cmd->add_flag("--no-angle-relax", o.no_angle_relax,
                "Circle packing: keep Step 2's intersection angles exactly (see `ricci flow`). Default: off.");
  cmd->add_flag("--no-circle-normalization", o.no_circle_normalization,
                "Circle domains: leave the Moebius gauge free (see `ricci flow`). Default: off.");
  cmd->add_flag("--json", o.json, "Print report.json's content on stdout instead of the summary line. Default: off.");
  cmd->add_flag("-q,--quiet", o.quiet, "Silence progress and notes on stderr; errors are still printed. Default: off.");
  cmd->add_flag("--largest-component", o.largest_component,
                "Keep the largest connected component instead of failing on several. Default: off.");
  cmd->add_flag("--no-split-ears", o.no_split_ears,
                "Keep ears (boundary vertices in a single triangle) whose boundary target is <= 0 (inner circles, "
                "geodesic boundaries) as they are, so the target check fails on them; by default the edge opposite "
                "such an ear is split at its midpoint (a new vertex after the input's, in mesh.obj and metric.csv; "
                "reported in report.json's repairs). Default: off.");
  return cmd;
}

CLI::App* add_layout_command(CLI::App& app, UniformizeCommandOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "layout",
      "Lay out a stored metric (written by `ricci flow -o`): cut, layout, deck transformations and the same "
      "outputs as `ricci uniformize` (without metric.csv) in OUTDIR.");
  cmd->add_option("MESH", o.mesh, "The mesh the metric belongs to (validated the same way). Required.")->required();
  cmd->add_option("--metric", o.metric, "Metric file from `ricci flow -o` (CSV or .json). Required.")
      ->required()
      ->type_name("METRIC");
  cmd->add_option("-o,--output", o.output, "Output directory (as for uniformize). Required.")->required()->type_name("OUTDIR");
  cmd->add_option("--geometry", o.geometry, "Geometry of the lengths: auto (the file's). Default: auto.")
      ->check(CLI::IsMember({"auto", "euclidean", "hyperbolic", "spherical"}));
  cmd->add_flag("--mesh-polygon", o.mesh_polygon, "As for uniformize. Default: off.");
  cmd->add_flag("--no-atlas", o.no_atlas, "As for uniformize. Default: off.");
  cmd->add_option("--base-candidates", o.base_candidates, "As for uniformize. Default: 8.")->check(number_validator(true, true));
  cmd->add_option("--seed-checks", o.seed_checks, "As for uniformize. Default: 1.")->check(number_validator(false, true));
  cmd->add_option("--cover-depth", o.cover_depth, "As for uniformize. Default: 0.")->check(number_validator(false, true));
  cmd->add_option("--cover-faces", o.cover_faces, "As for uniformize. Default: 250000.")
      ->check(number_validator(false, true));
  cmd->add_flag("--unit-box", o.unit_box, "Euclidean: scale the layout into the unit box. Default: off.");
  cmd->add_option("--patches", o.patches, "As for uniformize. Default: -1.")->check(CLI::Range(-1, 256));
  cmd->add_option("--layout-refine-above", o.layout_refine_above, "As for uniformize. Default: 1e-10.")
      ->check(number_validator(false, false));
  cmd->add_flag("--json", o.json, "Print the report on stdout. Default: off.");
  cmd->add_flag("-q,--quiet", o.quiet, "Silence progress and notes on stderr. Default: off.");
  cmd->add_flag("--largest-component", o.largest_component, "Keep the largest connected component. Default: off.");
  return cmd;
}

CLI::App* add_cover_command(CLI::App& app, CoverCommandOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "cover",
      "Uniformize a closed surface of genus >= 1 and write its universal cover tiling: copies of the "
      "fundamental polygon under the deck group's reduced words up to --depth.");
  cmd->add_option("MESH", o.mesh,
                  "Mesh file. Default: the embedded genus-2 mesh (" + std::string(embedded_default_name()) + ").");
  cmd->add_option("-o,--output", o.output, "cover.svg (picture) or a mesh file (.obj, .off, .ply). Required.")
      ->required()
      ->type_name("OUT");
  cmd->add_option("--depth", o.depth,
                  "Hyperbolic: word length in the compact domain's side pairings (1: every neighbour across a "
                  "side); torus: the block of translates is DEPTH x DEPTH. Default: 2.")
      ->check(number_validator(true, true));
  cmd->add_option("--radius", o.radius,
                  "Hyperbolic: keep only copies whose centre lies within |z| <= RADIUS (0: no limit). Default: 0.")
      ->check(number_validator(false, false));
  cmd->add_flag("--json", o.json, "Print a JSON summary on stdout. Default: off.");
  cmd->add_flag("-q,--quiet", o.quiet, "Silence progress on stderr. Default: off.");
  cmd->add_flag("--largest-component", o.largest_component, "Keep the largest connected component. Default: off.");
  return cmd;
}

}  // namespace ricci_cli
