// ricci command-line tool — `ricci signature`: load → validate → uniformize (library defaults,
// no seed checks) → conformal_signature(), printed as text or JSON and optionally written as
// signature.json. Also gives the JSON form `ricci uniformize` puts in report.json, reads it back
// (signature_from_json()), and runs `ricci compare A B`: two meshes or signature.json files →
// signature_distance().
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <iostream>
#include <string>

#include "commands.h"
#include "flow_setup.h"
#include "ricci/io.h"
#include "ricci/signature.h"
#include "ricci/uniformize.h"

namespace ricci_cli {

namespace {

using Json = nlohmann::ordered_json;
using ricci::Status;

Json number(double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); }

Json complex_json(std::complex<double> z) { return Json::array({number(z.real()), number(z.imag())}); }

std::string text(const ricci::ConformalSignature& s) {
  char buf[320];
  std::string out;
  if (s.has_torus) {
    const ricci::TorusModulus& t = s.torus;
    std::snprintf(buf, sizeof buf, "tau:            %.12g %+.12gi  (± %.2g)\n", t.tau.real(), t.tau.imag(), t.uncertainty);
    out += buf;
    std::snprintf(buf, sizeof buf, "tau computed:   %.12g %+.12gi%s\n", t.tau_computed.real(), t.tau_computed.imag(),
                  t.b_reversed ? " (b1 reversed)" : "");
    out += buf;
    std::snprintf(buf, sizeof buf, "reduction:      [[%lld, %lld], [%lld, %lld]]\n", t.reduction[0], t.reduction[1],
                  t.reduction[2], t.reduction[3]);
    out += buf;
  }
  for (const ricci::WordLength& w : s.words) {
    std::snprintf(buf, sizeof buf, "length %-14s %.12g  (± %.2g)\n", w.word.c_str(), w.length, w.uncertainty);
    out += buf;
  }
  if (!s.words.empty()) {
    std::snprintf(buf, sizeof buf, "systole:        %.12g (%s)\n", s.systole.length, s.systole.word.c_str());
    out += buf;
  }
  if (s.has_fenchel_nielsen) {
    const ricci::FenchelNielsen& f = s.fenchel_nielsen;
    for (std::size_t i = 0; i < f.curves.size(); ++i) {
      std::snprintf(buf, sizeof buf, "FN %-4s length %.12g (± %.2g)  twist %+.12g (± %.2g)\n", f.curves[i].c_str(),
                    f.lengths[i], f.length_uncertainty[i], f.twists[i], f.twist_uncertainty[i]);
      out += buf;
    }
  }
  if (s.has_circle_domain) {
    const ricci::CircleDomain& d = s.circle_domain;
    for (std::size_t i = 0; i < d.circles.size(); ++i) {
      const ricci::BoundaryCircle& c = d.circles[i];
      std::snprintf(buf, sizeof buf, "circle %zu (loop at vertex %lld, 3D length %.6g): centre %.12g %+.12gi, radius %.12g  (± %.2g)\n",
                    i, static_cast<long long>(c.vertex), c.length_3d, c.centre.real(), c.centre.imag(), c.radius,
                    c.uncertainty);
      out += buf;
    }
    if (d.circles.size() == 2) {
      std::snprintf(buf, sizeof buf, "annulus modulus: %.12g  (± %.2g)\n", d.annulus_modulus, d.annulus_modulus_uncertainty);
      out += buf;
    }
  }
  for (const ricci::BoundaryGeodesic& g : s.boundary_geodesics) {
    std::snprintf(buf, sizeof buf, "boundary geodesic (loop at vertex %lld, 3D length %.6g): %.12g  (± %.2g)\n",
                  static_cast<long long>(g.vertex), g.length_3d, g.length, g.uncertainty);
    out += buf;
  }
  return out;
}

// ---- reading signature.json back -------------------------------------------------------------

/// A finite number, or (uncertainties, which JSON writes as null when infinite) +∞ for null.
double get_number(const Json& j, const char* key, bool null_is_infinite = false) {
  if (!j.is_object() || !j.contains(key)) throw std::runtime_error(std::string("missing \"") + key + "\"");
  const Json& x = j.at(key);
  if (x.is_null() && null_is_infinite) return INFINITY;
  if (!x.is_number()) throw std::runtime_error(std::string("\"") + key + "\" is not a number");
  return x.get<double>();
}

/// A whole number in [0, 10⁹].
ricci::Index get_count(const Json& j, const char* key) {
  if (!j.contains(key) || !j.at(key).is_number_integer()) throw std::runtime_error(std::string("\"") + key + "\" is not a whole number");
  const std::int64_t v = j.at(key).get<std::int64_t>();
  if (v < 0 || v > 1000000000) throw std::runtime_error(std::string("\"") + key + "\" is out of range");
  return static_cast<ricci::Index>(v);
}

std::complex<double> get_complex(const Json& j, const char* key) {
  const Json& x = j.at(key);
  if (!x.is_array() || x.size() != 2 || !x[0].is_number() || !x[1].is_number())
    throw std::runtime_error(std::string("\"") + key + "\" is not a pair of numbers");
  return {x[0].get<double>(), x[1].get<double>()};
}

std::vector<double> get_matrix(const Json& j, const char* key, std::size_t n, bool null_is_infinite = false) {
  const Json& x = j.at(key);
  std::vector<double> out;
  if (!x.is_array() || x.size() != n) throw std::runtime_error(std::string("\"") + key + "\" is not an n×n array");
  for (const Json& row : x) {
    if (!row.is_array() || row.size() != n) throw std::runtime_error(std::string("\"") + key + "\" is not an n×n array");
    for (const Json& v : row) {
      if (v.is_null() && null_is_infinite) {
        out.push_back(INFINITY);
        continue;
      }
      if (!v.is_number()) throw std::runtime_error(std::string("\"") + key + "\" has an entry that is not a number");
      out.push_back(v.get<double>());
    }
  }
  return out;
}

}  // namespace

void signature_vertices_to_file(ricci::ConformalSignature& s, const std::vector<ricci::Index>& vertex_to_input) {
  auto file_vertex = [&](ricci::Index v) {
    return v >= 0 && static_cast<std::size_t>(v) < vertex_to_input.size() ? vertex_to_input[static_cast<std::size_t>(v)] : v;
  };
  for (ricci::BoundaryCircle& c : s.circle_domain.circles) c.vertex = file_vertex(c.vertex);
  for (ricci::BoundaryGeodesic& g : s.boundary_geodesics) g.vertex = file_vertex(g.vertex);
}

ricci::ConformalSignature signature_from_json(const Json& j) {
  ricci::ConformalSignature s;
  if (!j.is_object() || !j.contains("status") || !j.at("status").is_string())
    throw std::runtime_error("not a ricci signature (no \"status\")");
  if (j.at("status").get<std::string>() != "ok") throw std::runtime_error("the signature's status is not ok");
  s.status = Status::Ok;
  s.message = "ok";
  s.genus = get_count(j, "genus");
  s.boundary_loops = j.contains("boundary_loops") ? get_count(j, "boundary_loops") : 0;
  if (j.contains("torus") && !j.at("torus").is_null()) {
    const Json& t = j.at("torus");
    s.has_torus = true;
    s.torus.tau = get_complex(t, "tau");
    s.torus.uncertainty = get_number(t, "uncertainty", true);
    if (!(s.torus.tau.imag() > 0)) throw std::runtime_error("torus.tau is not in the upper half-plane");
  }
  if (j.contains("fenchel_nielsen") && !j.at("fenchel_nielsen").is_null()) {
    s.has_fenchel_nielsen = true;
    s.fenchel_nielsen.status = Status::Ok;
    for (const Json& c : j.at("fenchel_nielsen")) {
      s.fenchel_nielsen.curves.push_back(c.at("curve").get<std::string>());
      s.fenchel_nielsen.lengths.push_back(get_number(c, "length"));
      s.fenchel_nielsen.twists.push_back(get_number(c, "twist"));
      s.fenchel_nielsen.length_uncertainty.push_back(get_number(c, "length_uncertainty", true));
      s.fenchel_nielsen.twist_uncertainty.push_back(get_number(c, "twist_uncertainty", true));
    }
  }
  if (j.contains("spectrum") && j.at("spectrum").is_array())
    for (const Json& l : j.at("spectrum")) {
      if (!l.is_number()) throw std::runtime_error("\"spectrum\" has an entry that is not a number");
      s.spectrum.push_back(l.get<double>());
    }
  if (j.contains("generators") && j.at("generators").is_array())
    for (const Json& g : j.at("generators")) {
      ricci::Moebius m;
      m.a = get_complex(g, "a");
      m.b = get_complex(g, "b");
      if (!std::isfinite(m.a.real()) || !std::isfinite(m.a.imag()) || !std::isfinite(m.b.real()) ||
          !std::isfinite(m.b.imag()))
        throw std::runtime_error("a generator is not finite");
      s.generators.push_back(m);
      ricci::Moebius low{{0, 0}, {0, 0}};
      if (g.contains("a_low")) low.a = get_complex(g, "a_low");
      if (g.contains("b_low")) low.b = get_complex(g, "b_low");
      s.generator_low.push_back(low);
      s.generator_residuals.push_back(get_number(g, "residual_max", true));
    }
  if (j.contains("circle_domain") && !j.at("circle_domain").is_null()) {
    const Json& d = j.at("circle_domain");
    s.has_circle_domain = true;
    for (const Json& c : d.at("circles")) {
      ricci::BoundaryCircle b;
      b.centre = get_complex(c, "centre");
      b.radius = get_number(c, "radius");
      b.uncertainty = get_number(c, "uncertainty", true);
      s.circle_domain.circles.push_back(b);
    }
    const std::size_t n = s.circle_domain.circles.size();
    s.circle_domain.separation = get_matrix(d, "separation", n);
    s.circle_domain.separation_uncertainty = get_matrix(d, "separation_uncertainty", n, true);
  }
  if (j.contains("boundary_geodesics") && j.at("boundary_geodesics").is_array())
    for (const Json& g : j.at("boundary_geodesics")) {
      ricci::BoundaryGeodesic b;
      b.length = get_number(g, "length");
      b.uncertainty = get_number(g, "uncertainty", true);
      s.boundary_geodesics.push_back(b);
    }
  return s;
}

namespace {

}  // namespace

Json signature_json(const ricci::ConformalSignature& s) {
  Json j;
  j["status"] = s.status == Status::Ok ? std::string("ok") : std::string(ricci::status_name(s.status));
  j["message"] = s.message;
  j["genus"] = s.genus;
  if (s.has_torus) {
    const ricci::TorusModulus& t = s.torus;
    j["torus"] = Json{{"tau", complex_json(t.tau)},
                      {"tau_computed", complex_json(t.tau_computed)},
                      {"b_reversed", t.b_reversed},
                      {"reduction", Json::array({t.reduction[0], t.reduction[1], t.reduction[2], t.reduction[3]})},
                      {"uncertainty", number(t.uncertainty)}};
  } else {
    j["torus"] = nullptr;
  }
  j["boundary_loops"] = s.boundary_loops;
  Json words = Json::array();
  for (const ricci::WordLength& w : s.words)
    words.push_back(Json{{"word", w.word}, {"length", number(w.length)}, {"uncertainty", number(w.uncertainty)}});
  j["words"] = words;
  j["systole"] = s.words.empty() ? Json(nullptr)
                                 : Json{{"word", s.systole.word}, {"length", number(s.systole.length)},
                                        {"uncertainty", number(s.systole.uncertainty)}};
  if (!s.spectrum.empty()) {
    Json sp = Json::array();
    for (const double l : s.spectrum) sp.push_back(number(l));
    j["spectrum"] = sp;
    j["spectrum_word_length"] = s.spectrum_word_length;
  } else {
    j["spectrum"] = nullptr;
  }
  if (!s.generators.empty()) {
    Json gens = Json::array();
    for (std::size_t k = 0; k < s.generators.size(); ++k) {
      const ricci::Moebius& m = s.generators[k];
      const ricci::Moebius low = k < s.generator_low.size() ? s.generator_low[k] : ricci::Moebius{{0, 0}, {0, 0}};
      gens.push_back(Json{{"a", complex_json(m.a)},
                          {"b", complex_json(m.b)},
                          {"a_low", complex_json(low.a)},
                          {"b_low", complex_json(low.b)},
                          {"residual_max", k < s.generator_residuals.size() ? number(s.generator_residuals[k]) : Json(nullptr)}});
    }
    j["generators"] = gens;
  } else {
    j["generators"] = nullptr;
  }
  if (s.has_fenchel_nielsen) {
    Json fn = Json::array();
    const ricci::FenchelNielsen& f = s.fenchel_nielsen;
    for (std::size_t i = 0; i < f.curves.size(); ++i)
      fn.push_back(Json{{"curve", f.curves[i]},
                        {"word", f.words[i]},
                        {"length", number(f.lengths[i])},
                        {"twist", number(f.twists[i])},
                        {"length_uncertainty", number(f.length_uncertainty[i])},
                        {"twist_uncertainty", number(f.twist_uncertainty[i])}});
    j["fenchel_nielsen"] = fn;
  } else {
    j["fenchel_nielsen"] = nullptr;
  }
  if (s.has_circle_domain) {
    const ricci::CircleDomain& d = s.circle_domain;
    const std::size_t n = d.circles.size();
    Json circles = Json::array(), sep = Json::array(), unc = Json::array();
    for (const ricci::BoundaryCircle& c : d.circles)
      circles.push_back(Json{{"vertex", c.vertex},
                             {"length_3d", number(c.length_3d)},
                             {"centre", complex_json(c.centre)},
                             {"radius", number(c.radius)},
                             {"fit_residual", number(c.fit_residual)},
                             {"uncertainty", number(c.uncertainty)}});
    for (std::size_t a = 0; a < n; ++a) {
      Json row = Json::array(), urow = Json::array();
      for (std::size_t b = 0; b < n; ++b) {
        row.push_back(number(d.separation[a * n + b]));
        urow.push_back(number(d.separation_uncertainty[a * n + b]));
      }
      sep.push_back(row);
      unc.push_back(urow);
    }
    j["circle_domain"] = Json{{"circles", circles},
                              {"separation", sep},
                              {"separation_uncertainty", unc},
                              {"annulus_modulus", n == 2 ? number(d.annulus_modulus) : Json(nullptr)},
                              {"annulus_modulus_uncertainty", n == 2 ? number(d.annulus_modulus_uncertainty) : Json(nullptr)}};
  } else {
    j["circle_domain"] = nullptr;
  }
  Json geodesics = Json::array();
  for (const ricci::BoundaryGeodesic& g : s.boundary_geodesics)
    geodesics.push_back(Json{{"vertex", g.vertex},
                             {"length_3d", number(g.length_3d)},
                             {"length", number(g.length)},
                             {"uncertainty", number(g.uncertainty)}});
  j["boundary_geodesics"] = geodesics;
  return j;
}

namespace {

/// MESH (or the embedded default when empty) → its signature; on failure prints the error and
/// returns the exit code (0 on success).
int signature_of_mesh(const std::string& mesh, bool largest_component, bool quiet, ricci::ConformalSignature& s) {
  const std::string name = mesh.empty() ? std::string(embedded_default_name()) : mesh;
  ricci::ValidateOptions vo;
  vo.keep_largest_component = largest_component;
  ricci::LoadResult loaded = load_input(mesh, vo);
  if (loaded.status != Status::Ok) {
    print_error(loaded.message);
    return exit_code(loaded.status);
  }
  // The natural boundary mode and uniform target, ears it cannot realise split, as `ricci
  // uniformize` does.
  ricci::ValidateResult& v = loaded.validated;
  PreparedTarget prepared =
      prepare_target(v, ricci::natural_geometry(v.topology), TargetSpec{}, BoundarySpec{}, "", "", true, name);
  if (prepared.status != Status::Ok) {
    print_error(prepared.message);
    return exit_code(prepared.status);
  }
  if (prepared.ear_split) print_note(quiet, prepared.ear_split->message);
  ricci::UniformizeOptions uo;
  uo.seed_checks = 0;
  const ricci::UniformizeResult r = ricci::uniformize(v.mesh, v.topology, uo, &prepared.target);
  s = ricci::conformal_signature(r);
  if (s.status != Status::Ok) {
    print_error(name + ": " + s.message);
    return exit_code(r.status != Status::Ok ? r.status : s.status);
  }
  signature_vertices_to_file(s, loaded.validated.vertex_to_input);
  return 0;
}

/// A signature.json file (by its .json extension) or a mesh → its signature, as signature_of_mesh().
int signature_of_input(const std::string& path, bool largest_component, bool quiet, ricci::ConformalSignature& s) {
  const bool is_json = path.size() >= 5 && path.compare(path.size() - 5, 5, ".json") == 0;
  if (!is_json) return signature_of_mesh(path, largest_component, quiet, s);
  if (const std::string big = input_too_large(path); !big.empty()) {
    print_error(big);
    return exit_code(Status::FileTooLarge);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    print_error(path + ": cannot open the file");
    return exit_code(Status::FileNotFound);
  }
  std::ostringstream text;
  text << in.rdbuf();
  try {
    s = signature_from_json(Json::parse(text.str()));
  } catch (const std::exception& e) {
    std::string message = path;
    message.append(": not a ricci signature.json: ");
    message.append(e.what());
    print_error(message);
    return exit_code(Status::ParseError);
  }
  return 0;
}

}  // namespace

int run_signature(const SignatureCommandOptions& o) {
  const std::string name = o.mesh.empty() ? std::string(embedded_default_name()) : o.mesh;
  if (o.mesh.empty()) print_note(o.quiet, std::string("no MESH given; using the embedded default mesh ") + name);
  if (!o.output.empty() && !o.mesh.empty() && same_file(o.output, o.mesh)) {
    print_error("refusing to write " + o.output + ": it is the input file; nothing was written");
    return finish_stdout(exit_code(Status::OutputIsInput));
  }
  ricci::ConformalSignature s;
  if (const int code = signature_of_mesh(o.mesh, o.largest_component, o.quiet, s); code != 0) return finish_stdout(code);
  Json j = signature_json(s);
  j["input"] = name;
  if (!o.output.empty()) {
    ricci::WriteResult w;
    {
      const InterruptsDeferred deferred;
      w = ricci::write_file_atomic(o.output, j.dump(2) + '\n', {o.mesh});
    }
    if (w.status != Status::Ok) {
      print_error(w.message);
      return finish_stdout(exit_code(w.status));
    }
  }
  if (o.json)
    std::cout << j.dump(2) << '\n';
  else
    std::cout << "file:           " << name << '\n' << "genus:          " << s.genus << '\n' << text(s);
  return finish_stdout(kExitOk);
}

namespace {

Json distance_json(const std::string& second, const ricci::SignatureDistance& d) {
  return Json{{"second", second},
              {"kind", d.kind},
              {"distance", number(d.distance)},
              {"uncertainty", number(d.uncertainty)},
              {"marked_distance", number(d.marked_distance)},
              {"marked_uncertainty", number(d.marked_uncertainty)}};
}

}  // namespace

int run_compare(const CompareCommandOptions& o) {
  ricci::ConformalSignature a;
  if (const int code = signature_of_input(o.first, o.largest_component, o.quiet, a); code != 0) return finish_stdout(code);
  // Every other input against the first; all must be of its kind.
  std::vector<std::pair<std::string, ricci::SignatureDistance>> rows;
  for (const std::string& other : o.others) {
    ricci::ConformalSignature b;
    if (const int code = signature_of_input(other, o.largest_component, o.quiet, b); code != 0) return finish_stdout(code);
    const ricci::SignatureDistance d = ricci::signature_distance(a, b);
    if (d.status != Status::Ok) {
      print_error(o.first + " and " + other + ": " + d.message);
      return finish_stdout(exit_code(d.status));
    }
    rows.emplace_back(other, d);
  }
  if (rows.size() == 1) {
    const ricci::SignatureDistance& d = rows[0].second;
    if (o.json) {
      Json j{{"first", o.first}};
      j.update(distance_json(rows[0].first, d));
      std::cout << j.dump(2) << '\n';
      return finish_stdout(kExitOk);
    }
    char buf[160];
    std::snprintf(buf, sizeof buf, "%.12g  (± %.2g)", d.distance, d.uncertainty);
    std::cout << "first:          " << o.first << '\n'
              << "second:         " << rows[0].first << '\n'
              << "kind:           " << d.kind << '\n'
              << "distance:       " << buf << '\n';
    if (std::isfinite(d.marked_distance)) {
      std::snprintf(buf, sizeof buf, "%.12g  (± %.2g)", d.marked_distance, d.marked_uncertainty);
      std::cout << "marked:         " << buf << " (Fenchel-Nielsen, modulo handle rotations and pants twists)\n";
    }
    return finish_stdout(kExitOk);
  }
  // A ranking: nearest first (ties keep the command line's order).
  std::stable_sort(rows.begin(), rows.end(), [](const auto& x, const auto& y) { return x.second.distance < y.second.distance; });
  if (o.json) {
    Json ranking = Json::array();
    for (const auto& [name, d] : rows) ranking.push_back(distance_json(name, d));
    std::cout << Json{{"first", o.first}, {"ranking", ranking}}.dump(2) << '\n';
    return finish_stdout(kExitOk);
  }
  std::cout << "first:          " << o.first << "\nkind:           " << rows[0].second.kind << '\n';
  for (std::size_t k = 0; k < rows.size(); ++k) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "%3zu  %.12g  (± %.2g)  ", k + 1, rows[k].second.distance, rows[k].second.uncertainty);
    std::cout << buf << rows[k].first << '\n';
  }
  return finish_stdout(kExitOk);
}

CLI::App* add_compare_command(CLI::App& app, CompareCommandOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "compare",
      "The distance between the conformal signatures of surfaces of the same kind (A against each B; several B are "
      "ranked, nearest first): the modular distance of "
      "the two tau (genus 1), the largest difference of the circle domains' separations over relabellings of the "
      "loops (genus 0 with >= 2 loops), of the sorted boundary geodesics' lengths (hyperbolic with boundary), or "
      "the largest difference of the length spectra's first 16 values (genus >= 2), with the Fenchel-Nielsen "
      "distance modulo handle rotations and pants twists as the marked distance.");
  cmd->add_option("A", o.first, "A mesh file, or a signature.json written by `ricci signature -o` or `ricci uniformize`.")
      ->required();
  cmd->add_option("B", o.others,
                  "One or more meshes or signature.json files of A's kind. With one: its distance to A; with several: "
                  "all of them ranked by their distance to A, nearest first.")
      ->required();
  cmd->add_flag("--json", o.json, "Print one JSON object on stdout instead of text. Default: off.");
  cmd->add_flag("--largest-component", o.largest_component,
                "Keep the largest connected component of a mesh instead of failing on several. Default: off.");
  cmd->add_flag("-q,--quiet", o.quiet, "Silence notes on stderr; errors are still printed. Default: off.");
  return cmd;
}

CLI::App* add_signature_command(CLI::App& app, SignatureCommandOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "signature",
      "The conformal signature of a surface, each number with an uncertainty: the flat torus's modulus tau "
      "reduced by SL(2,Z) (genus 1); the hyperbolic lengths of a fixed list of words in the canonical generators, "
      "the length spectrum and systole among all words up to a genus-dependent length (6 at genus 2) and "
      "Fenchel-Nielsen coordinates (closed genus >= 2); the "
      "normalized circle domain and its separations (genus 0 with >= 2 boundary loops); the boundary geodesics' "
      "lengths (hyperbolic surfaces with boundary).");
  cmd->add_option("MESH", o.mesh,
                  "Mesh file (any format `ricci info` reads). Default: the embedded genus-2 mesh (" +
                      std::string(embedded_default_name()) + ").");
  cmd->add_option("-o,--output", o.output, "Also write the JSON to this file (atomically). Default: none.");
  cmd->add_flag("--json", o.json, "Print one JSON object on stdout instead of text. Default: off.");
  cmd->add_flag("--largest-component", o.largest_component,
                "Keep the largest connected component instead of failing on several. Default: off.");
  cmd->add_flag("-q,--quiet", o.quiet, "Silence notes on stderr; errors are still printed. Default: off.");
  return cmd;
}

}  // namespace ricci_cli
