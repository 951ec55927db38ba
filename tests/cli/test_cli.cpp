// Tests of the ricci command-line tool, run as a separate process (exit codes, stdout, stderr).
#include <doctest/doctest.h>

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "support.h"

namespace {

using ricci_test::CommandResult;
using ricci_test::run_cli;
using ricci_test::TempDir;
using ricci_test::fs::path;
using Json = nlohmann::json;

// A closed tetrahedron (genus 0), consistently oriented, with coordinates that are not exact
// binary fractions so that round trips exercise the number formatting.
const char* const kTetrahedronObj =
    "# tetrahedron\n"
    "v 0.1 0 0\n"
    "v 1 0.3333333333333333 0\n"
    "v 0 1 0.2\n"
    "v 0.25 0.125 1.7\n"
    "f 1 3 2\n"
    "f 1 2 4\n"
    "f 1 4 3\n"
    "f 2 3 4\n";

// Three triangles on the edge 1-2: a non-manifold edge.
const char* const kNonManifoldObj =
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 0 1 0\n"
    "v 0 -1 0\n"
    "v 0 0 1\n"
    "f 1 2 3\n"
    "f 2 1 4\n"
    "f 1 2 5\n";

// Keys `info --json` always prints.
const char* const kInfoKeys[] = {"status",
                                 "message",
                                 "file",
                                 "format",
                                 "vertices",
                                 "vertices_listed",
                                 "edges",
                                 "faces",
                                 "boundary_loops",
                                 "boundary_loop_sizes",
                                 "euler_characteristic",
                                 "genus",
                                 "components",
                                 "orientable",
                                 "manifold",
                                 "non_manifold_edges",
                                 "non_manifold_vertices",
                                 "inconsistent_edges",
                                 "min_angle_deg",
                                 "max_angle_deg",
                                 "obtuse_fraction",
                                 "repairs"};
// Keys that describe the mesh, null when the file could not be read.
const char* const kMeshKeys[] = {"vertices",
                                 "vertices_listed",
                                 "edges",
                                 "faces",
                                 "boundary_loops",
                                 "boundary_loop_sizes",
                                 "euler_characteristic",
                                 "genus",
                                 "components",
                                 "orientable",
                                 "manifold",
                                 "non_manifold_edges",
                                 "non_manifold_vertices",
                                 "inconsistent_edges",
                                 "min_angle_deg",
                                 "max_angle_deg",
                                 "obtuse_fraction"};

Json parse_json(const std::string& text) {
  return Json::parse(text, nullptr, /*allow_exceptions=*/false);
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

/// The help entry of option `name`: the line starting with it (after indentation) and the deeper
/// indented lines that continue its description; "" if there is none.
std::string help_entry(const std::string& help, const std::string& name) {
  const std::vector<std::string> lines = lines_of(help);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string t = trim(lines[i]);
    if (t.rfind(name, 0) != 0 || (t.size() > name.size() && t[name.size()] != ' ')) continue;
    std::string entry = t;
    for (std::size_t k = i + 1; k < lines.size() && lines[k].rfind("      ", 0) == 0; ++k) {
      entry += ' ';
      entry += trim(lines[k]);
    }
    return entry;
  }
  return {};
}

std::vector<std::string> directory_entries(const path& dir) {
  std::vector<std::string> out;
  for (const auto& e : ricci_test::fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  return out;
}

// One row of the table in shared/meshes/README.md.
struct TableRow {
  std::string v, f, b, chi, genus;
};

/// Leading integer of a table cell ("34834 (+1113 unref.)" → 34834); false if there is none.
bool leading_int(const std::string& cell, std::int64_t* out) {
  try {
    std::size_t used = 0;
    *out = std::stoll(cell, &used);
    return used > 0;
  } catch (...) {
    return false;
  }
}

/// file (relative to the meshes folder) → row, from the table with columns
/// file|source|licence|V|F|b|χ|genus|…
std::map<std::string, TableRow> read_mesh_table(const path& meshes) {
  std::map<std::string, TableRow> rows;
  for (const std::string& line : lines_of(ricci_test::read_bytes(meshes / "README.md"))) {
    if (line.rfind("| `", 0) != 0) continue;
    std::vector<std::string> cells;
    std::size_t start = 1;
    for (std::size_t bar; (bar = line.find('|', start)) != std::string::npos; start = bar + 1)
      cells.push_back(trim(line.substr(start, bar - start)));
    if (cells.size() < 9) continue;  // another table (mesh quality)
    std::string file = cells[0];
    if (file.size() >= 2 && file.front() == '`' && file.back() == '`') file = file.substr(1, file.size() - 2);
    rows[file] = TableRow{cells[3], cells[4], cells[5], cells[6], cells[7]};
  }
  return rows;
}

/// Compares `info --json` output with a README row: V (and unreferenced), F, b, χ, genus.
void check_against_table(const Json& j, const TableRow& row) {
  std::int64_t v = 0, f = 0, b = 0, chi = 0, genus = 0;
  REQUIRE(leading_int(row.v, &v));
  CHECK(j["vertices"] == v);
  if (const auto plus = row.v.find("(+"); plus != std::string::npos) {
    std::int64_t unref = 0;
    REQUIRE(leading_int(row.v.substr(plus + 2), &unref));
    CHECK(j["vertices_listed"] == v + unref);
  } else {
    CHECK(j["vertices_listed"] == v);
  }
  // F counts polygons; compare only for files made of triangles.
  if (row.f.find("gons") == std::string::npos && leading_int(row.f, &f)) CHECK(j["faces"] == f);
  REQUIRE(leading_int(row.b, &b));
  REQUIRE(leading_int(row.chi, &chi));
  REQUIRE(leading_int(row.genus, &genus));
  CHECK(j["boundary_loops"] == b);
  CHECK(j["euler_characteristic"] == chi);
  CHECK(j["genus"] == genus);
  CHECK(j["components"] == 1);
  CHECK(j["manifold"] == true);
  CHECK(j["orientable"] == true);
  REQUIRE(j["boundary_loop_sizes"].is_array());
  CHECK(static_cast<std::int64_t>(j["boundary_loop_sizes"].size()) == b);
}

}  // namespace

TEST_CASE("cli: --help and --version") {
  const CommandResult help = run_cli({"--help"});
  CHECK(help.exit_code == 0);
  CHECK(help.out.find("info") != std::string::npos);
  CHECK(help.out.find("convert") != std::string::npos);
  CHECK(help.out.find("Exit codes") != std::string::npos);
  for (const char* code : {"0 ", "1 ", "2 ", "3 ", "4 ", "5 ", "6 "}) {
    CAPTURE(code);
    CHECK(help.out.find(std::string("  ") + code) != std::string::npos);
  }

  const CommandResult version = run_cli({"--version"});
  CHECK(version.exit_code == 0);
  CHECK(version.out == "ricci 0.1.0\n");
}

TEST_CASE("cli: every subcommand's --help exits 0 and states each option's default") {
  const std::map<std::string, std::vector<std::string>> options = {
      {"info", {"MESH", "--json", "--largest-component", "--no-repair-orientation", "-q,--quiet"}},
      {"convert", {"IN", "-o,--output", "--validate", "--largest-component", "--format", "-q,--quiet"}},
  };
  for (const auto& [command, names] : options) {
    CAPTURE(command);
    const CommandResult r = run_cli({command, "--help"});
    CHECK(r.exit_code == 0);
    CHECK(r.out.find("Exit codes") != std::string::npos);
    for (const std::string& name : names) {
      CAPTURE(name);
      const std::string line = help_entry(r.out, name);
      INFO(r.out);
      REQUIRE(!line.empty());
      const bool states_default =
          line.find("Default") != std::string::npos || line.find("Required") != std::string::npos;
      CHECK(states_default);
    }
  }
}

TEST_CASE("cli: bad arguments are usage errors (exit 2)") {
  const std::vector<std::vector<std::string>> cases = {
      {"info", "--bogus"},
      {"--bogus"},
      {},
      {"frobnicate"},
      {"info", "a.obj", "b.obj"},
      {"convert", "a.obj"},
      {"convert", "a.obj", "-o", "b.obj", "--format", "3ds"},
      {"convert", "a.obj", "-o", "b.obj", "--largest-component"},
  };
  for (const auto& args : cases) {
    std::string joined;
    for (const auto& a : args) joined += a + " ";
    CAPTURE(joined);
    const CommandResult r = run_cli(args);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("ricci: ") != std::string::npos);
    CHECK(r.err.find("Run with --help for more information.") != std::string::npos);
  }
  const CommandResult bogus = run_cli({"info", "--bogus"});
  CHECK(bogus.err.find("--bogus") != std::string::npos);

  // An output path whose format cannot be told is a usage error, found before reading anything.
  TempDir dir;
  ricci_test::write_bytes(dir / "tet.obj", kTetrahedronObj);
  const CommandResult r = run_cli({"convert", (dir / "tet.obj").string(), "-o", (dir / "tet.txt").string()});
  CHECK(r.exit_code == 2);
  CHECK(!ricci_test::fs::exists(dir / "tet.txt"));
}

TEST_CASE("cli: a missing input file exits 3 and names the file") {
  TempDir dir;
  const std::string missing = (dir / "no-such-mesh.obj").string();
  for (const bool json : {false, true}) {
    CAPTURE(json);
    std::vector<std::string> args = {"info", missing};
    if (json) args.push_back("--json");
    const CommandResult r = run_cli(args);
    INFO(r.err);
    CHECK(r.exit_code == 3);
    CHECK(r.err.find("ricci: error: ") != std::string::npos);
    CHECK(r.err.find("no-such-mesh.obj") != std::string::npos);
    if (json) {
      const Json j = parse_json(r.out);
      REQUIRE(j.is_object());
      CHECK(j["status"] == "file_not_found");
      for (const char* key : kMeshKeys) {
        CAPTURE(key);
        REQUIRE(j.contains(key));
        CHECK(j[key].is_null());
      }
      CHECK(j["repairs"].is_array());
    } else {
      CHECK(r.out.find("error: ") != std::string::npos);
    }
  }
  const CommandResult c = run_cli({"convert", missing, "-o", (dir / "out.obj").string()});
  CHECK(c.exit_code == 3);
  CHECK(c.err.find("no-such-mesh.obj") != std::string::npos);
  CHECK(directory_entries(dir.path()).empty());
}

TEST_CASE("cli: malformed file content exits 4 with the line number") {
  TempDir dir;
  const path garbage = dir / "garbage.obj";
  ricci_test::write_bytes(garbage, "v 0 0 0\nv 1 0 0\nv 0 banana 0\nf 1 2 3\n");
  const CommandResult r = run_cli({"info", garbage.string()});
  INFO(r.err);
  CHECK(r.exit_code == 4);
  CHECK(r.err.find("garbage.obj") != std::string::npos);
  CHECK(r.err.find("line 3") != std::string::npos);
  CHECK(r.out.find("line 3") != std::string::npos);

  const CommandResult j = run_cli({"info", "--json", garbage.string()});
  CHECK(j.exit_code == 4);
  const Json parsed = parse_json(j.out);
  REQUIRE(parsed.is_object());
  CHECK(parsed["status"] == "parse_error");
  CHECK(parsed["line"] == 3);
}

TEST_CASE("cli: a non-manifold mesh exits 5 and still reports its diagnostics") {
  TempDir dir;
  const path mesh = dir / "fin.obj";
  ricci_test::write_bytes(mesh, kNonManifoldObj);
  const CommandResult text = run_cli({"info", mesh.string()});
  INFO(text.out);
  INFO(text.err);
  CHECK(text.exit_code == 5);
  CHECK(text.err.find("ricci: error: ") != std::string::npos);
  CHECK(text.out.find("non-manifold edges:") != std::string::npos);
  CHECK(text.out.find("n/a (not manifold)") != std::string::npos);
  CHECK(lines_of(text.out).back().rfind("error: ", 0) == 0);

  const CommandResult r = run_cli({"info", "--json", mesh.string()});
  CHECK(r.exit_code == 5);
  const Json j = parse_json(r.out);
  REQUIRE(j.is_object());
  CHECK(j["status"] == "non_manifold_edge");
  CHECK(j["faces"] == 3);
  CHECK(j["vertices"] == 5);
  CHECK(j["non_manifold_edges"] == 1);
  CHECK(j["manifold"] == false);
  CHECK(j["genus"].is_null());
  CHECK(j["boundary_loop_sizes"].is_null());

  const CommandResult c = run_cli({"convert", mesh.string(), "-o", (dir / "out.off").string(), "--validate"});
  CHECK(c.exit_code == 5);
  CHECK(!ricci_test::fs::exists(dir / "out.off"));
}

TEST_CASE("cli: info without a mesh describes the embedded default (genus 2)") {
  const CommandResult text = run_cli({"info"});
  {
    INFO(text.out);
    INFO(text.err);
    CHECK(text.exit_code == 0);
    CHECK(text.out.find("embedded default") != std::string::npos);
    CHECK(text.err.find("embedded default") != std::string::npos);
    CHECK(text.out.find("status: ok") != std::string::npos);
  }

  const CommandResult quiet = run_cli({"info", "--quiet"});
  CHECK(quiet.exit_code == text.exit_code);
  if (quiet.exit_code == 0) CHECK(quiet.err.empty());

  const CommandResult r = run_cli({"info", "--json"});
  INFO(r.err);
  CHECK(r.exit_code == 0);
  const Json j = parse_json(r.out);
  REQUIRE(j.is_object());
  CHECK(j["embedded_default"] == true);
  CHECK(j["file"] == "genus2.obj");
  CHECK(j["status"] == "ok");
  CHECK(j["genus"] == 2);
  CHECK(j["euler_characteristic"] == -2);
  CHECK(j["boundary_loops"] == 0);
  CHECK(j["components"] == 1);
}

TEST_CASE("cli: info --json prints every key and parses") {
  TempDir dir;
  const path mesh = dir / "tet.obj";
  ricci_test::write_bytes(mesh, kTetrahedronObj);
  const CommandResult r = run_cli({"info", "--json", mesh.string()});
  INFO(r.out);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  const Json j = parse_json(r.out);
  REQUIRE(j.is_object());
  for (const char* key : kInfoKeys) {
    CAPTURE(key);
    CHECK(j.contains(key));
  }
  CHECK(j["status"] == "ok");
  CHECK(j["file"] == mesh.string());
  CHECK(j["format"] == "obj");
  CHECK(j["vertices"] == 4);
  CHECK(j["vertices_listed"] == 4);
  CHECK(j["edges"] == 6);
  CHECK(j["faces"] == 4);
  CHECK(j["boundary_loops"] == 0);
  CHECK(j["boundary_loop_sizes"] == Json::array());
  CHECK(j["euler_characteristic"] == 2);
  CHECK(j["genus"] == 0);
  CHECK(j["components"] == 1);
  CHECK(j["orientable"] == true);
  CHECK(j["manifold"] == true);
  CHECK(j["non_manifold_edges"] == 0);
  CHECK(j["non_manifold_vertices"] == 0);
  CHECK(j["inconsistent_edges"] == 0);
  REQUIRE(j["min_angle_deg"].is_number());
  REQUIRE(j["max_angle_deg"].is_number());
  CHECK(j["min_angle_deg"].get<double>() > 0);
  CHECK(j["min_angle_deg"].get<double>() <= j["max_angle_deg"].get<double>());
  CHECK(j["max_angle_deg"].get<double>() < 180);
  CHECK(j["obtuse_fraction"].get<double>() >= 0);
  CHECK(j["obtuse_fraction"].get<double>() <= 1);
  CHECK(j["repairs"] == Json::array());

  // The human form carries the same facts and ends with the status line.
  const CommandResult text = run_cli({"info", mesh.string()});
  CHECK(text.exit_code == 0);
  CHECK(text.out.find("genus:") != std::string::npos);
  CHECK(lines_of(text.out).back() == "status: ok");
}

TEST_CASE("cli: info on the shared meshes matches the README table") {
  const path meshes = ricci_test::shared_meshes_dir();
  if (meshes.empty()) {
    MESSAGE("shared meshes folder absent; skipping");
    return;
  }
  // A check of the table's figures, run in Release; the sanitizer build fuzzes the readers and maps
  // the shared files up to 30k faces (tools/sanitize_meshes.sh).
  if (ricci_test::kSanitized) {
    MESSAGE("sanitizer build: skipped (run in Release)");
    return;
  }
  const std::map<std::string, TableRow> table = read_mesh_table(meshes);
  REQUIRE(!table.empty());
  int checked = 0;
  for (const char* folder : {"genus0", "genus1", "genus2", "genus3plus", "boundary"}) {
    for (const path& file : ricci_test::mesh_files(meshes / folder)) {
      const std::string name = std::string(folder) + "/" + file.filename().string();
      CAPTURE(name);
      const auto row = table.find(name);
      REQUIRE_MESSAGE(row != table.end(), "no README row for " << name);
      const CommandResult r = run_cli({"info", "--json", file.string()});
      INFO(r.err);
      CHECK(r.exit_code == 0);
      const Json j = parse_json(r.out);
      REQUIRE(j.is_object());
      CHECK(j["status"] == "ok");
      check_against_table(j, row->second);
      ++checked;
    }
  }
  CHECK(checked > 0);
}

TEST_CASE("cli: info on the shared bad meshes exits 5 or repairs them, never crashes") {
  const path meshes = ricci_test::shared_meshes_dir();
  if (meshes.empty()) {
    MESSAGE("shared meshes folder absent; skipping");
    return;
  }
  const std::map<std::string, TableRow> table = read_mesh_table(meshes);
  // Orientable files whose stored orientation is inconsistent: validation flips faces.
  const std::set<std::string> repairable = {"blobby-shuffled.off", "inverted_triangles.obj",
                                            "lionstatue-4-flipped-edges.obj"};
  const std::vector<path> files = ricci_test::mesh_files(meshes / "bad");
  CHECK(!files.empty());
  for (const path& file : files) {
    const std::string name = file.filename().string();
    CAPTURE(name);
    const CommandResult r = run_cli({"info", "--json", file.string()});
    INFO(r.err);
    CHECK(r.exit_code < 128);
    const Json j = parse_json(r.out);
    REQUIRE(j.is_object());
    if (repairable.count(name)) {
      CHECK(r.exit_code == 0);
      CHECK(j["status"] == "ok");
      REQUIRE(j["repairs"].is_array());
      bool flipped = false;
      for (const Json& rep : j["repairs"]) flipped = flipped || rep["kind"] == "faces_flipped";
      CHECK(flipped);
      CHECK(j["inconsistent_edges"] == 0);
      CHECK(j["inconsistent_edges_input"].get<std::int64_t>() > 0);
      if (const auto row = table.find("bad/" + name); row != table.end()) check_against_table(j, row->second);
      // Refusing to repair makes the same file an error.
      const CommandResult strict = run_cli({"info", "--no-repair-orientation", file.string()});
      CHECK(strict.exit_code == 5);
    } else {
      CHECK(r.exit_code == 5);
      CHECK(j["status"] != "ok");
      CHECK(j["faces"].is_number());
      CHECK(j["genus"].is_null() == j["genus_undefined_reason"].is_string());
    }
    const CommandResult text = run_cli({"info", file.string()});
    CHECK(text.exit_code == r.exit_code);
  }
}

TEST_CASE("cli: info --largest-component keeps the largest component") {
  const path meshes = ricci_test::shared_meshes_dir();
  if (meshes.empty() || !ricci_test::fs::exists(meshes / "bad" / "kitten-plus-4-tets.obj")) {
    MESSAGE("shared meshes folder absent; skipping");
    return;
  }
  const path file = meshes / "bad" / "kitten-plus-4-tets.obj";
  CHECK(run_cli({"info", file.string()}).exit_code == 5);
  const CommandResult r = run_cli({"info", "--json", "--largest-component", file.string()});
  INFO(r.err);
  CHECK(r.exit_code == 0);
  const Json j = parse_json(r.out);
  REQUIRE(j.is_object());
  CHECK(j["components"] == 1);
  CHECK(j["genus"] == 1);
  CHECK(j["euler_characteristic"] == 0);
  bool dropped = false;
  for (const Json& rep : j["repairs"])
    dropped = dropped || (rep["kind"] == "components_dropped" && rep["count"] == 4);
  CHECK(dropped);
}

TEST_CASE("cli: convert round trip through every format") {
  TempDir dir;
  ricci_test::write_bytes(dir / "tet.obj", kTetrahedronObj);
  auto convert = [&](const std::string& in, const std::string& out, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"convert", (dir / in).string(), "-o", (dir / out).string(), "--quiet"};
    args.insert(args.end(), extra.begin(), extra.end());
    const CommandResult r = run_cli(args);
    INFO(in << " -> " << out << ": " << r.err);
    CHECK(r.exit_code == 0);
    CHECK(r.err.empty());
  };
  convert("tet.obj", "a.obj");
  convert("a.obj", "b.ply");
  convert("b.ply", "c.off", {"--validate"});
  convert("c.off", "d.ply", {"--format", "ply-ascii"});
  convert("d.ply", "e.obj");
  CHECK(ricci_test::read_bytes(dir / "d.ply").rfind("ply\nformat ascii", 0) == 0);
  CHECK(ricci_test::read_bytes(dir / "b.ply").find("binary_little_endian") != std::string::npos);
  CHECK(!ricci_test::read_bytes(dir / "a.obj").empty());
  CHECK(ricci_test::read_bytes(dir / "a.obj") == ricci_test::read_bytes(dir / "e.obj"));
  for (const char* name : {"a.obj", "b.ply", "c.off", "d.ply", "e.obj"}) {
    CAPTURE(name);
    const Json j = parse_json(run_cli({"info", "--json", (dir / name).string()}).out);
    REQUIRE(j.is_object());
    CHECK(j["vertices"] == 4);
    CHECK(j["faces"] == 4);
    CHECK(j["genus"] == 0);
  }
  // Without --quiet, convert says what it wrote.
  const CommandResult loud = run_cli({"convert", (dir / "tet.obj").string(), "-o", (dir / "f.off").string()});
  CHECK(loud.exit_code == 0);
  CHECK(loud.err.find("ricci: wrote") != std::string::npos);

  // --validate applies the repairs: the bunny loses its unreferenced vertices.
  const path meshes = ricci_test::shared_meshes_dir();
  const path bunny = meshes.empty() ? path() : meshes / "boundary" / "stanford-bunny.obj";
  if (bunny.empty() || !ricci_test::fs::exists(bunny)) {
    MESSAGE("shared meshes folder absent; skipping the bunny round trip");
    return;
  }
  const CommandResult v =
      run_cli({"convert", bunny.string(), "-o", (dir / "bunny.ply").string(), "--validate"});
  CHECK(v.exit_code == 0);
  CHECK(v.err.find("1113") != std::string::npos);
  const Json j = parse_json(run_cli({"info", "--json", (dir / "bunny.ply").string()}).out);
  REQUIRE(j.is_object());
  CHECK(j["vertices"] == 34834);
  CHECK(j["vertices_listed"] == 34834);
  CHECK(j["boundary_loops"] == 5);
}

TEST_CASE("cli: convert refuses to overwrite its input (exit 6)") {
  TempDir dir;
  const path mesh = dir / "tet.obj";
  ricci_test::write_bytes(mesh, kTetrahedronObj);
  for (const std::string& out : {mesh.string(), (dir.path() / "." / "tet.obj").string()}) {
    CAPTURE(out);
    for (const bool validate : {false, true}) {
      std::vector<std::string> args = {"convert", mesh.string(), "-o", out};
      if (validate) args.push_back("--validate");
      const CommandResult r = run_cli(args);
      INFO(r.err);
      CHECK(r.exit_code == 6);
      CHECK(r.err.find("ricci: error: ") != std::string::npos);
      CHECK(ricci_test::read_bytes(mesh) == kTetrahedronObj);
      CHECK(directory_entries(dir.path()) == std::vector<std::string>{"tet.obj"});
    }
  }
}

TEST_CASE("cli: convert into a missing folder exits 6 and creates nothing") {
  TempDir dir;
  const path mesh = dir / "tet.obj";
  ricci_test::write_bytes(mesh, kTetrahedronObj);
  const CommandResult r = run_cli({"convert", mesh.string(), "-o", (dir / "missing" / "out.obj").string()});
  INFO(r.err);
  CHECK(r.exit_code == 6);
  CHECK(r.err.find("ricci: error: ") != std::string::npos);
  CHECK(!ricci_test::fs::exists(dir / "missing"));
  CHECK(directory_entries(dir.path()) == std::vector<std::string>{"tet.obj"});
}
