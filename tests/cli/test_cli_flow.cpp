// Tests of `ricci flow`, run as a separate process: settings and their defaults, convergence on
// the embedded mesh, the fixtures and (Release builds) the shared real meshes, the metric files,
// and the exit codes of every failure.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/uniformize.h"
#include "ricci/validate.h"
#include "shapes.h"
#include "stress_shapes.h"
#include "support.h"

namespace {

using ricci_test::CommandResult;
using ricci_test::run_cli;
using ricci_test::TempDir;
using ricci_test::fs::path;
using Json = nlohmann::json;

constexpr double kTwoPi = 2 * std::numbers::pi;

Json parse_json(const std::string& text) { return Json::parse(text, nullptr, /*allow_exceptions=*/false); }

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (std::size_t i; (i = s.find(sep, start)) != std::string::npos; start = i + 1) out.push_back(s.substr(start, i - start));
  out.push_back(s.substr(start));
  return out;
}

std::string joined(const std::vector<std::string>& args) {
  std::string s;
  for (const std::string& a : args) s += a + ' ';
  return s;
}

/// The --help entry of an option: the line naming it and its indented continuation lines.
std::string option_help(const std::string& help, const std::string& name) {
  const std::vector<std::string> lines = split_lines(help);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::size_t b = lines[i].find_first_not_of(' ');
    if (b == std::string::npos || lines[i].compare(b, name.size(), name) != 0) continue;
    const std::size_t after = b + name.size();
    if (after < lines[i].size() && lines[i][after] != ' ') continue;
    std::string entry = lines[i];
    for (std::size_t k = i + 1; k < lines.size() && lines[k].rfind("      ", 0) == 0; ++k) entry += ' ' + lines[k];
    return entry;
  }
  return {};
}

/// Runs `ricci flow --json --quiet ARGS…` and returns the result and the parsed summary.
struct FlowRun {
  CommandResult r;
  Json j;
};
FlowRun run_flow(std::vector<std::string> args) {
  args.insert(args.begin(), {"flow", "--json", "--quiet"});
  FlowRun f;
  f.r = run_cli(args);
  f.j = parse_json(f.r.out);
  return f;
}

std::vector<std::string> directory_entries(const path& dir) {
  std::vector<std::string> out;
  for (const auto& e : ricci_test::fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

/// Rows of one CSV section of a metric file: the lines after `header` up to the next comment.
std::vector<std::vector<std::string>> csv_section(const std::string& text, const std::string& header) {
  std::vector<std::vector<std::string>> rows;
  bool inside = false;
  for (const std::string& line : split_lines(text)) {
    if (!line.empty() && line[0] == '#') {
      if (inside) break;
      inside = line == header;
      continue;
    }
    if (inside) rows.push_back(split(line, ','));
  }
  return rows;
}

double number(const std::string& s) {
  std::size_t used = 0;
  const double x = std::stod(s, &used);
  return used == s.size() ? x : std::nan("");
}

/// What `ricci flow` with auto settings must choose for a fixture.
struct Expected {
  const char* file;
  const char* geometry;
  const char* boundary;
};
const Expected kFixtures[] = {
    {"torus.obj", "euclidean", "none"},        {"icosphere.obj", "spherical", "none"},
    {"genus2.obj", "hyperbolic", "none"},      {"genus3.obj", "hyperbolic", "none"},
    {"disk.obj", "euclidean", "circle"},       {"annulus.obj", "euclidean", "circle"},
    {"sphere-3holes.obj", "euclidean", "circle"}, {"genus2-1hole.obj", "hyperbolic", "geodesic"},
};

/// Checks a converged summary: status, error below the tolerance and a consistent history.
/// Returns whether it converged (non-fatal, so sweeps go on to the next mesh).
bool check_converged(const FlowRun& f, double tolerance = 1e-10) {
  INFO(f.r.err);
  CHECK(f.r.exit_code == 0);
  CHECK(f.j.is_object());
  if (!f.j.is_object()) return false;
  CHECK(f.j["status"] == "converged");
  CHECK(f.j["max_curvature_error"].is_number());
  CHECK(f.j["gauss_bonnet_error"].is_number());
  CHECK(f.j["history"].is_array());
  if (f.j["status"] != "converged" || !f.j["max_curvature_error"].is_number() ||
      !f.j["gauss_bonnet_error"].is_number() || !f.j["history"].is_array())
    return false;
  CHECK(f.j["max_curvature_error"].get<double>() < tolerance);
  CHECK(f.j["gauss_bonnet_error"].get<double>() < 1e-6);
  CHECK(f.j["iterations"].get<int>() >= 0);
  if (!f.j["history"].empty()) CHECK(f.j["history"].back()["max_error"].get<double>() < tolerance);
  return f.r.exit_code == 0 && f.j["max_curvature_error"].get<double>() < tolerance;
}

}  // namespace

TEST_CASE("cli flow: --help states every option's default and the flow exit codes") {
  const CommandResult r = run_cli({"flow", "--help"});
  CHECK(r.exit_code == 0);
  INFO(r.out);
  for (const char* name : {"MESH", "--geometry", "--scheme", "--target", "--boundary", "--method", "--tol",
                           "--max-iter", "--step", "--threads", "-o,--output", "--json", "-q,--quiet",
                           "--largest-component"}) {
    CAPTURE(name);
    const std::string entry = option_help(r.out, name);
    REQUIRE(!entry.empty());
    CHECK(entry.find("Default") != std::string::npos);
  }
  CHECK(option_help(r.out, "--tol").find("1e-10") != std::string::npos);
  CHECK(option_help(r.out, "--step").find("0.05") != std::string::npos);
  CHECK(option_help(r.out, "--geometry").find("Default: auto") != std::string::npos);
  CHECK(option_help(r.out, "--scheme").find("Default: auto") != std::string::npos);
  CHECK(option_help(r.out, "--no-flips").find("without intrinsic Delaunay flips") != std::string::npos);
  CHECK(option_help(r.out, "--method").find("Default: newton") != std::string::npos);
  CHECK(option_help(r.out, "-o,--output").find("only when the flow converged") != std::string::npos);
  CHECK(r.out.find("Exit codes") != std::string::npos);
  CHECK(r.out.find("  7  the flow failed") != std::string::npos);
  CHECK(r.out.find("  8  infeasible target") != std::string::npos);
  // The top-level help lists the subcommand.
  CHECK(run_cli({"--help"}).out.find("flow") != std::string::npos);
}

TEST_CASE("cli flow: the embedded default mesh converges in hyperbolic geometry") {
  const FlowRun f = run_flow({});
  check_converged(f);
  const Json& j = f.j;
  for (const char* key : {"status", "message", "file", "geometry", "scheme", "boundary", "target", "method",
                          "iterations", "chord_steps", "max_curvature_error", "gauss_bonnet_error", "seconds", "edges_clamped",
                          "history", "notes", "vertices", "edges", "faces", "genus"}) {
    CAPTURE(key);
    CHECK(j.contains(key));
  }
  CHECK(j["embedded_default"] == true);
  CHECK(j["genus"] == 2);
  CHECK(j["geometry"] == "hyperbolic");
  CHECK(j["scheme"] == "yamabe");
  CHECK(j["flips"] == true);
  CHECK(j["intrinsic"].is_object());
  CHECK(j["boundary"] == "none");
  CHECK(j["target"] == "uniform");
  CHECK(j["method"] == "newton");
  CHECK(j["edges_clamped"].is_null());  // a circle packing figure
  CHECK(run_flow({"--scheme", "circle-packing"}).j["edges_clamped"].is_number_integer());
  CHECK(j["notes"].is_array());
  CHECK(j["output"].is_null());
  CHECK(j["seconds"].get<double>() >= 0);
  REQUIRE(j["history"].is_array());
  REQUIRE(!j["history"].empty());
  for (const Json& h : j["history"]) {
    for (const char* key : {"iteration", "max_error", "energy", "step", "seconds"}) {
      CAPTURE(key);
      CHECK(h.contains(key));
    }
  }
  CHECK(static_cast<int>(j["history"].size()) <= j["iterations"].get<int>() + 1);
  CHECK(f.r.err.empty());  // --quiet

  // Without --quiet: a progress line per iteration on stderr; the text summary on stdout.
  const CommandResult loud = run_cli({"flow"});
  INFO(loud.err);
  CHECK(loud.exit_code == 0);
  CHECK(loud.err.find("ricci: no MESH given") != std::string::npos);
  int progress = 0;
  for (const std::string& line : split_lines(loud.err))
    if (line.rfind("ricci: iteration ", 0) == 0 && line.find("max error") != std::string::npos) ++progress;
  CHECK(progress == static_cast<int>(j["history"].size()));
  CHECK(split_lines(loud.out).size() == 1);
  CHECK(!loud.out.empty());
}

TEST_CASE("cli flow: the fixtures converge with the natural geometry and boundary") {
  for (const Expected& e : kFixtures) {
    CAPTURE(e.file);
    const path mesh = ricci_test::fixtures_dir() / e.file;
    const std::string content = ricci_test::read_bytes(mesh);
    if (content.find("\nf ") == std::string::npos) {
      MESSAGE("fixture " << e.file << " absent (or not generated yet); skipping it");
      continue;
    }
    const FlowRun f = run_flow({mesh.string()});
    check_converged(f);
    CHECK(f.j["geometry"] == e.geometry);
    CHECK(f.j["boundary"] == e.boundary);
    CHECK(f.j["embedded_default"] == false);
  }
}

TEST_CASE("cli flow: -o writes the metric as CSV or JSON with a row per vertex and per edge") {
  TempDir dir;
  const FlowRun counts = run_flow({});
  REQUIRE(counts.j.is_object());
  const std::int64_t V = counts.j["vertices"].get<std::int64_t>(), E = counts.j["edges"].get<std::int64_t>();
  REQUIRE(V > 0);

  const path csv = dir / "metric.csv";
  const FlowRun c = run_flow({"-o", csv.string()});
  check_converged(c);
  CHECK(c.j["output"] == csv.string());
  const std::string text = ricci_test::read_bytes(csv);
  CHECK(text.find("0-based") != std::string::npos);
  const auto vrows = csv_section(text, "# vertex,input_vertex,u,K,K_target");
  const auto erows = csv_section(text, "# edge,v0,v1,length");
  REQUIRE(static_cast<std::int64_t>(vrows.size()) == V);
  REQUIRE(static_cast<std::int64_t>(erows.size()) == E);
  double sum_K = 0;
  for (std::int64_t v = 0; v < V; ++v) {
    CAPTURE(v);
    REQUIRE(vrows[v].size() == 5);
    CHECK(vrows[v][0] == std::to_string(v));
    const double u = number(vrows[v][2]), K = number(vrows[v][3]), Kt = number(vrows[v][4]);
    CHECK(std::isfinite(u));
    CHECK(std::abs(K - Kt) < 1e-10);
    sum_K += K;
  }
  // Closed genus 2 in H: Σ K = 2πχ − λ·area > 2πχ = −4π.
  CHECK(sum_K > -2 * kTwoPi);
  for (std::int64_t e = 0; e < E; ++e) {
    CAPTURE(e);
    REQUIRE(erows[e].size() == 4);
    CHECK(erows[e][0] == std::to_string(e));
    const double v0 = number(erows[e][1]), v1 = number(erows[e][2]), l = number(erows[e][3]);
    CHECK(v0 >= 0);
    CHECK(v0 < V);
    CHECK(v1 >= 0);
    CHECK(v1 < V);
    CHECK(v0 != v1);
    CHECK(l > 0);
  }

  const path json = dir / "metric.json";
  const FlowRun jr = run_flow({"-o", json.string()});
  check_converged(jr);
  const Json m = parse_json(ricci_test::read_bytes(json));
  REQUIRE(m.is_object());
  CHECK(m["format"] == "ricci-flow-metric");
  CHECK(m["num_vertices"] == V);
  CHECK(m["num_edges"] == E);
  CHECK(m["geometry"] == "hyperbolic");
  CHECK(m["vertex_numbering"].get<std::string>().find("0-based") != std::string::npos);
  for (const char* key : {"input_vertex", "u", "K", "K_target"}) {
    CAPTURE(key);
    REQUIRE(m["vertices"][key].is_array());
    CHECK(static_cast<std::int64_t>(m["vertices"][key].size()) == V);
  }
  for (const char* key : {"v0", "v1", "length"}) {
    CAPTURE(key);
    REQUIRE(m["edges"][key].is_array());
    CHECK(static_cast<std::int64_t>(m["edges"][key].size()) == E);
  }
  // Both files hold the same numbers (shortest round-trip decimals in both).
  for (std::int64_t v = 0; v < V; v += 17) {
    CAPTURE(v);
    CHECK(m["vertices"]["u"][v].get<double>() == number(vrows[v][2]));
  }
  for (std::int64_t e = 0; e < E; e += 13) {
    CAPTURE(e);
    CHECK(m["edges"]["length"][e].get<double>() == number(erows[e][3]));
  }

  // Without --quiet the write is announced.
  const CommandResult loud = run_cli({"flow", "-o", (dir / "again.csv").string()});
  CHECK(loud.exit_code == 0);
  CHECK(loud.err.find("ricci: wrote ") != std::string::npos);
}

TEST_CASE("cli flow: one and two threads write identical metrics") {
  TempDir dir;
  const FlowRun a = run_flow({"--threads", "1", "-o", (dir / "a.csv").string()});
  const FlowRun b = run_flow({"--threads", "2", "-o", (dir / "b.csv").string()});
  check_converged(a);
  check_converged(b);
  const std::string ta = ricci_test::read_bytes(dir / "a.csv");
  CHECK(!ta.empty());
  CHECK(ta == ricci_test::read_bytes(dir / "b.csv"));
}

TEST_CASE("cli flow and uniformize: --threads past the processors is clamped with a note") {
  TempDir dir;
  const FlowRun one = run_flow({"--threads", "1", "-o", (dir / "one.csv").string()});
  const FlowRun many = run_flow({"--threads", "1000000", "-o", (dir / "many.csv").string()});
  check_converged(many);
  bool flow_noted = false;  // --quiet: the note is in the summary's notes
  for (const auto& n : many.j["notes"])
    flow_noted = flow_noted || (n.get<std::string>().find("--threads 1000000") != std::string::npos &&
                                n.get<std::string>().find("available to this process") != std::string::npos);
  CHECK(flow_noted);
  CHECK(many.j["threads"].get<int>() >= 1);
  CHECK(many.j["threads"].get<int>() < 1000000);
  CHECK(ricci_test::read_bytes(dir / "one.csv") == ricci_test::read_bytes(dir / "many.csv"));
  const CommandResult u =
      run_cli({"uniformize", "-o", (dir / "out").string(), "--no-pictures", "--json", "-q", "--threads", "1000000"});
  CHECK(u.exit_code == 0);
  const Json j = parse_json(u.out);
  REQUIRE(j.is_object());
  bool noted = false;
  for (const auto& n : j["notes"]) noted = noted || n.get<std::string>().find("available to this process") != std::string::npos;
  CHECK(noted);
}

TEST_CASE("cli flow: an infeasible target exits 8 and writes nothing") {
  TempDir dir;
  const path out = dir / "metric.csv";
  struct Case {
    const char* what;
    const char* cones;
  };
  // The embedded mesh is closed, genus 2, hyperbolic: Σ K̄ must exceed 2πχ = −4π, and every cone
  // angle 2π − K̄ must be positive.
  const Case cases[] = {
      {"Gauss-Bonnet", "# all of it and more at one vertex\n0 -13\n"},
      {"negative cone angle", "0 7\n"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.what);
    const path cones = dir / "cones.txt";
    ricci_test::write_bytes(cones, c.cones);
    const FlowRun f = run_flow({"--target", "cones=" + cones.string(), "-o", out.string()});
    INFO(f.r.err);
    CHECK(f.r.exit_code == 8);
    CHECK(f.r.err.find("ricci: error: ") != std::string::npos);
    REQUIRE(f.j.is_object());
    CHECK(f.j["status"] == "infeasible_target");
    CHECK(f.j["output"].is_null());
    CHECK(!ricci_test::fs::exists(out));
  }
  // The wrong geometry for the topology makes uniformization infeasible too.
  const FlowRun e = run_flow({"--geometry", "euclidean", "-o", out.string()});
  CHECK(e.r.exit_code == 8);
  CHECK(e.j["status"] == "infeasible_target");
  CHECK(e.j["geometry"] == "euclidean");
  CHECK(directory_entries(dir.path()) == std::vector<std::string>{"cones.txt"});
}

TEST_CASE("cli flow: circle domains are Möbius-normalized by default, --no-circle-normalization leaves the gauge free") {
  // A bent disk: its map to the unit disk is far from the identity.
  TempDir dir;
  ricci::Mesh bent = ricci_shapes::disk(20);
  for (std::size_t i = 0; i < bent.positions.size(); i += 3) {
    const double x = bent.positions[i], y = bent.positions[i + 1];
    bent.positions[i + 2] = 0.6 * (x * x - 0.5 * y * y) + 0.3 * x;
  }
  const path input = dir / "bent.obj";
  REQUIRE(ricci::write_mesh(input.string(), bent).status == ricci::Status::Ok);
  auto noted = [](const FlowRun& f) {
    bool found = false;
    for (const auto& note : f.j["notes"]) found = found || note.get<std::string>().find("Möbius normalization") != std::string::npos;
    return found;
  };
  const FlowRun normalized = run_flow({input.string()});
  check_converged(normalized);
  CHECK(normalized.j["boundary"] == "circle");
  CHECK(noted(normalized));
  const FlowRun exact = run_flow({input.string(), "--no-circle-normalization"});
  check_converged(exact);
  CHECK(!noted(exact));
}

TEST_CASE("cli flow: separating cycles get relaxed angles by default, --no-angle-relax keeps Step 2's") {
  // A torus whose split faces are split again has valence-3 vertices in thin, obtuse triangles,
  // where Step 2's angles violate Theorem 4 for uniformization.
  TempDir dir;
  std::mt19937_64 rng(3);
  const ricci::Mesh mesh = ricci_shapes::split_random_faces(
      ricci_shapes::split_random_faces(ricci_shapes::torus(16, 8, 2.0, 0.8), rng, 0.3), rng, 0.3);
  const path input = dir / "torus.obj";
  REQUIRE(ricci::write_mesh(input.string(), mesh).status == ricci::Status::Ok);
  const FlowRun relaxed = run_flow({input.string(), "--scheme", "circle-packing"});
  check_converged(relaxed);
  REQUIRE(relaxed.j["edges_relaxed"].is_number_integer());
  CHECK(relaxed.j["edges_relaxed"].get<int>() > 0);
  CHECK(relaxed.j["cycles_relaxed"].get<int>() > 0);
  bool noted = false;
  for (const auto& note : relaxed.j["notes"]) noted = noted || note.get<std::string>().find("lowered the angles") != std::string::npos;
  CHECK(noted);

  const FlowRun strict = run_flow({input.string(), "--scheme", "circle-packing", "--no-angle-relax"});
  CHECK(strict.r.exit_code == 8);
  CHECK(strict.j["status"] == "infeasible_target");
  CHECK(strict.j["edges_relaxed"] == 0);
  CHECK(strict.r.err.find("Theorem 4") != std::string::npos);
}

TEST_CASE("cli flow: target files that cannot be read exit 3 or 4") {
  TempDir dir;
  const FlowRun missing = run_flow({"--target", "cones=" + (dir / "nope.txt").string()});
  INFO(missing.r.err);
  CHECK(missing.r.exit_code == 3);
  CHECK(missing.r.err.find("nope.txt") != std::string::npos);
  CHECK(missing.j["status"] == "file_not_found");

  ricci_test::write_bytes(dir / "bad.txt", "0 0.5\n1 banana\n");
  const FlowRun bad = run_flow({"--target", "cones=" + (dir / "bad.txt").string()});
  INFO(bad.r.err);
  CHECK(bad.r.exit_code == 4);
  ricci_test::write_bytes(dir / "range.txt", "100000000 0.5\n");
  CHECK(run_flow({"--target", "cones=" + (dir / "range.txt").string()}).r.exit_code == 4);
}

TEST_CASE("cli flow: a flow that does not converge exits 7 and writes nothing") {
  TempDir dir;
  const path out = dir / "metric.json";
  const FlowRun f = run_flow({"--max-iter", "1", "--tol", "1e-14", "-o", out.string()});
  INFO(f.r.err);
  CHECK(f.r.exit_code == 7);
  REQUIRE(f.j.is_object());
  CHECK(f.j["status"] == "not_converged");
  CHECK(f.j["iterations"] == 1);
  CHECK(f.j["output"].is_null());
  CHECK(f.r.err.find("ricci: error: ") != std::string::npos);
  CHECK(directory_entries(dir.path()).empty());
}

TEST_CASE("cli flow: bad arguments are usage errors (exit 2)") {
  TempDir dir;
  const std::vector<std::vector<std::string>> cases = {
      {"flow", "--geometry", "elliptic"},
      {"flow", "--scheme", "ricci"},
      {"flow", "--method", "bfgs"},
      {"flow", "--target", "cones="},
      {"flow", "--target", "single-vertex=x"},
      {"flow", "--target", "single-vertex=-1"},
      {"flow", "--target", "everything"},
      {"flow", "--boundary", "loop-totals=1,x"},
      {"flow", "--boundary", "round"},
      {"flow", "--tol", "-1"},
      {"flow", "--tol", "0"},
      {"flow", "--max-iter", "0"},
      {"flow", "--step", "0"},
      {"flow", "--threads", "-2"},
      {"flow", "--bogus"},
      {"flow", "a.obj", "b.obj"},
      {"flow", "-o"},
  };
  for (const auto& args : cases) {
    CAPTURE(joined(args));
    const CommandResult r = run_cli(args);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("ricci: ") != std::string::npos);
  }
  // Found after parsing, still before any work: a vertex that does not exist, a mesh name as
  // output.
  const FlowRun v = run_flow({"--target", "single-vertex=100000000"});
  CHECK(v.r.exit_code == 2);
  CHECK(v.j["status"] == "invalid_argument");
  const CommandResult o = run_cli({"flow", "-o", (dir / "out.obj").string()});
  CHECK(o.exit_code == 2);
  CHECK(directory_entries(dir.path()).empty());
}

TEST_CASE("cli flow: the output must differ from the input (exit 6)") {
  TempDir dir;
  const path fixture = ricci_test::fixtures_dir() / "genus2.obj";
  const std::string content = ricci_test::read_bytes(fixture);
  const path mesh = dir / "mesh.obj";
  ricci_test::write_bytes(mesh, content);
  ricci_test::write_bytes(dir / "cones.txt", "");
  for (const std::string& out : {mesh.string(), (dir.path() / "." / "mesh.obj").string()}) {
    CAPTURE(out);
    const CommandResult r = run_cli({"flow", mesh.string(), "-o", out});
    INFO(r.err);
    CHECK(r.exit_code == 6);
    CHECK(r.err.find("ricci: error: ") != std::string::npos);
    CHECK(ricci_test::read_bytes(mesh) == content);
  }
  const CommandResult c =
      run_cli({"flow", mesh.string(), "--target", "cones=" + (dir / "cones.txt").string(), "-o",
               (dir / "cones.txt").string()});
  CHECK(c.exit_code == 6);
  CHECK(ricci_test::read_bytes(dir / "cones.txt").empty());
  const CommandResult m = run_cli({"flow", mesh.string(), "-o", (dir / "missing" / "out.csv").string()});
  CHECK(m.exit_code == 6);
  CHECK(directory_entries(dir.path()) == std::vector<std::string>{"cones.txt", "mesh.obj"});
}

TEST_CASE("cli flow: loop totals and single-vertex targets on the disk and annulus fixtures") {
  const path disk = ricci_test::fixtures_dir() / "disk.obj";
  const path annulus = ricci_test::fixtures_dir() / "annulus.obj";
  if (ricci_test::read_bytes(disk).find("\nf ") == std::string::npos ||
      ricci_test::read_bytes(annulus).find("\nf ") == std::string::npos) {
    MESSAGE("disk.obj or annulus.obj fixture absent; skipping");
    return;
  }
  TempDir dir;
  // Gauss–Bonnet on a disk in E: boundary total π leaves π for the interior, all at vertex 0
  // (the disk's centre).
  const path out = dir / "cone.csv";
  const FlowRun cone = run_flow({disk.string(), "--boundary", "loop-totals=pi", "--target", "single-vertex=0", "-o",
                                 out.string()});
  check_converged(cone);
  CHECK(cone.j["boundary"] == "loop-totals");
  REQUIRE(cone.j["loop_totals"].size() == 1);
  CHECK(cone.j["loop_totals"][0].get<double>() == doctest::Approx(std::numbers::pi));
  const auto rows = csv_section(ricci_test::read_bytes(out), "# vertex,input_vertex,u,K,K_target");
  REQUIRE(!rows.empty());
  CHECK(number(rows[0][4]) == doctest::Approx(std::numbers::pi).epsilon(1e-12));
  double sum = 0;
  for (const auto& row : rows) sum += number(row[4]);
  CHECK(sum == doctest::Approx(kTwoPi).epsilon(1e-9));

  // The annulus: totals must add up to 2πχ = 0; given in the loop order of `ricci info`.
  check_converged(run_flow({annulus.string(), "--boundary", "loop-totals=2pi,-2pi"}));
  CHECK(run_flow({annulus.string(), "--boundary", "loop-totals=2pi"}).r.exit_code == 2);
  CHECK(run_flow({annulus.string(), "--boundary", "loop-totals=2pi,-1pi"}).r.exit_code == 8);
  // Dirichlet boundary.
  const FlowRun fixed = run_flow({disk.string(), "--boundary", "fixed"});
  check_converged(fixed);
  CHECK(fixed.j["boundary"] == "fixed");
}

TEST_CASE("cli flow: vertex scaling with intrinsic flips by default, its metric on the input's edges") {
  // Needles and caps make the mesh far from Delaunay; vertex scaling on it as it is stops.
  TempDir dir;
  std::mt19937_64 rng(7);
  const ricci::Mesh mesh = ricci_shapes::insert_needles_and_caps(ricci_shapes::torus(16, 8, 2.0, 0.7), rng, 0.3, 0.02);
  const path input = dir / "needles.obj";
  REQUIRE(ricci::write_mesh(input.string(), mesh).status == ricci::Status::Ok);
  const path out = dir / "metric.json";
  const FlowRun f = run_flow({input.string(), "-o", out.string()});
  check_converged(f, 1e-12);
  CHECK(f.j["scheme"] == "yamabe");
  CHECK(f.j["flips"] == true);
  REQUIRE(f.j["intrinsic"].is_object());
  CHECK(f.j["intrinsic"]["delaunay_flips"].get<std::int64_t>() + f.j["intrinsic"]["flow_flips"].get<std::int64_t>() > 0);
  CHECK(f.j["iterations"].get<int>() <= 12);
  const Json m = parse_json(ricci_test::read_bytes(out));
  REQUIRE(m.is_object());
  CHECK(m["flips"] == true);
  CHECK(m["straight_tiles"] == f.j["intrinsic"]["straight_tiles"]);
  // The same as uniformize's metric.csv, and laid out by `ricci layout` as it is.
  const ricci::ValidateResult v = ricci::validate_mesh(mesh);
  REQUIRE(v.status == ricci::Status::Ok);
  CHECK(m["edges"]["length"].size() == static_cast<std::size_t>(v.topology.num_edges));
  const ricci::UniformizeResult lib = ricci::conformal_metric(v.mesh, v.topology);
  REQUIRE(lib.status == ricci::Status::Ok);
  REQUIRE(m["vertices"]["u"].size() == lib.flow.u.size());
  for (std::size_t i = 0; i < lib.flow.u.size(); ++i) CHECK(m["vertices"]["u"][i].get<double>() == lib.flow.u[i]);
  if (m["straight_tiles"] == true) {
    const CommandResult lay = run_cli({"layout", input.string(), "--metric", out.string(), "-o", (dir / "laid").string(),
                                       "--json", "-q"});
    INFO(lay.err);
    CHECK(lay.exit_code == 0);
    const Json lj = parse_json(lay.out);
    REQUIRE(lj.is_object());
    CHECK(lj["layout"]["flipped_faces"] == 0);
    CHECK(lj["layout"]["max_edge_length_error"].get<double>() < 1e-9);
  }
  // --no-flips: today's vertex scaling on the input's triangulation, reported without flips.
  const FlowRun plain = run_flow({input.string(), "--no-flips"});
  CHECK(plain.j["flips"] == false);
  CHECK(plain.j["status"] != "converged");  // stops on this mesh (line search at the triangle inequality)
  CHECK(plain.j["intrinsic"].is_null());
  MESSAGE("needle torus: flips " << f.j["iterations"] << " Newton steps; --no-flips: " << plain.j["status"] << " after "
                                 << plain.j["iterations"] << " steps");
}

TEST_CASE("cli flow: the other schemes and gradient descent") {
  for (const char* scheme : {"inversive-distance", "yamabe"}) {
    CAPTURE(scheme);
    const FlowRun f = run_flow({"--scheme", scheme});
    check_converged(f);
    CHECK(f.j["scheme"] == scheme);
    CHECK(f.j["edges_clamped"].is_null());
  }
  const FlowRun g = run_flow({"--method", "gradient", "--tol", "1e-6", "--step", "0.05"});
  check_converged(g, 1e-6);
  CHECK(g.j["method"] == "gradient");
  CHECK(g.j["step"] == 0.05);
}

#ifdef NDEBUG
namespace {
/// The geometry and boundary mode the uniformization theorem picks for a topology.
Expected natural_settings(std::int64_t genus, std::int64_t loops) {
  if (loops > 0) return genus == 0 ? Expected{"", "euclidean", "circle"} : Expected{"", "hyperbolic", "geodesic"};
  return genus == 0 ? Expected{"", "spherical", "none"}
                    : (genus == 1 ? Expected{"", "euclidean", "none"} : Expected{"", "hyperbolic", "none"});
}
}  // namespace

TEST_CASE("cli flow: the shared real meshes converge with auto settings or are named infeasible") {
  const path meshes = ricci_test::shared_meshes_dir();
  if (meshes.empty()) {
    MESSAGE("shared meshes folder absent; skipping");
    return;
  }
  // Larger meshes are left to tools/bench_flow.
  constexpr std::int64_t kMaxFaces = 60000;
  int run = 0, hyperbolic = 0;
  std::vector<std::string> failed;
  for (const char* folder : {"genus0", "genus1", "genus2", "genus3plus", "boundary"}) {
    for (const path& file : ricci_test::mesh_files(meshes / folder)) {
      const std::string name = std::string(folder) + "/" + file.filename().string();
      CAPTURE(name);
      const Json info = parse_json(run_cli({"info", "--json", file.string()}).out);
      REQUIRE(info.is_object());
      REQUIRE(info["faces"].is_number());
      if (info["faces"].get<std::int64_t>() > kMaxFaces) {
        MESSAGE(name << ": " << info["faces"].get<std::int64_t>() << " faces, left to the benchmark");
        continue;
      }
      const Expected e = natural_settings(info["genus"].get<std::int64_t>(), info["boundary_loops"].get<std::int64_t>());
      const FlowRun f = run_flow({file.string()});
      REQUIRE(f.j.is_object());
      CHECK(f.j["geometry"] == e.geometry);
      CHECK(f.j["boundary"] == e.boundary);
      if (f.r.exit_code != 8) {
        // Every mesh converges — E and H are convex once the separating 3- and 4-cycles have their
        // angles relaxed and circle domains are Möbius-normalized; S has its safeguards — unless
        // the target is named infeasible before any iteration (exit 8, e.g. an ear on an inner
        // loop).
        check_converged(f);
        hyperbolic += std::string(e.geometry) == "hyperbolic" ? 1 : 0;
      } else if (f.r.exit_code != 0) {
        // An infeasible target (exit 8), with a message, finite numbers and no output — never a
        // crash or a NaN.
        CHECK(f.r.exit_code == 8);
        CHECK(f.j["status"] != "converged");
        CHECK(!f.j.value("message", std::string()).empty());
        if (f.j["max_curvature_error"].is_number()) CHECK(std::isfinite(f.j["max_curvature_error"].get<double>()));
        failed.push_back(name + ": " + f.j.value("status", std::string("?")) + " — " + f.j.value("message", std::string()));
      } else {
        check_converged(f);
      }
      ++run;
    }
  }
  CHECK(run > 0);
  CHECK(hyperbolic > 0);
  std::string summary;
  for (const std::string& f : failed) summary += "\n  " + f;
  MESSAGE("did not converge with auto settings (" << failed.size() << " of " << run << "):" << summary);
}
#endif
