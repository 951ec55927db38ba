// ricci command-line tool — `ricci signature`: load → validate → uniformize (library defaults,
// no seed checks) → conformal_signature(), printed as text or JSON and optionally written as
// signature.json. Also gives the JSON form `ricci uniformize` puts in report.json.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include "commands.h"
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
  char buf[256];
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
  return out;
}

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
  Json words = Json::array();
  for (const ricci::WordLength& w : s.words)
    words.push_back(Json{{"word", w.word}, {"length", number(w.length)}, {"uncertainty", number(w.uncertainty)}});
  j["words"] = words;
  j["systole"] = s.words.empty() ? Json(nullptr)
                                 : Json{{"word", s.systole.word}, {"length", number(s.systole.length)},
                                        {"uncertainty", number(s.systole.uncertainty)}};
  return j;
}

int run_signature(const SignatureCommandOptions& o) {
  const std::string name = o.mesh.empty() ? std::string(embedded_default_name()) : o.mesh;
  if (o.mesh.empty()) print_note(o.quiet, std::string("no MESH given; using the embedded default mesh ") + name);
  if (!o.output.empty() && !o.mesh.empty() && same_file(o.output, o.mesh)) {
    print_error("refusing to write " + o.output + ": it is the input file; nothing was written");
    return finish_stdout(exit_code(Status::OutputIsInput));
  }
  ricci::ValidateOptions vo;
  vo.keep_largest_component = o.largest_component;
  ricci::LoadResult loaded = load_input(o.mesh, vo);
  if (loaded.status != Status::Ok) {
    print_error(loaded.message);
    return finish_stdout(exit_code(loaded.status));
  }
  ricci::UniformizeOptions uo;
  uo.seed_checks = 0;
  const ricci::UniformizeResult r = ricci::uniformize(loaded.validated.mesh, loaded.validated.topology, uo);
  const ricci::ConformalSignature s = ricci::conformal_signature(r);
  if (s.status != Status::Ok) {
    print_error(name + ": " + s.message);
    return finish_stdout(exit_code(r.status != Status::Ok ? r.status : s.status));
  }
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

CLI::App* add_signature_command(CLI::App& app, SignatureCommandOptions& o) {
  CLI::App* cmd = app.add_subcommand(
      "signature",
      "The conformal signature of a closed surface: the flat torus's modulus tau reduced by SL(2,Z) (genus 1), "
      "or the hyperbolic lengths of a fixed list of words in the canonical generators and the systole among "
      "them (genus >= 2), each with an uncertainty.");
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
