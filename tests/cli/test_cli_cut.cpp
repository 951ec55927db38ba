// Tests of `ricci cut`, run as a separate process: the embedded default, --json keys, the two
// output files, refusal to overwrite the input, bad base vertices and exit codes.
#include <doctest/doctest.h>

#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/topology.h"
#include "support.h"

namespace {

using ricci_test::run_cli;
using ricci_test::TempDir;
using Json = nlohmann::json;

Json parse(const std::string& text) {
  return Json::parse(text, nullptr, /*allow_exceptions=*/false);
}

}  // namespace

TEST_CASE(
    "cli cut: the embedded default mesh gives a canonical genus-2 polygon with the documented JSON keys") {
  const auto r = run_cli({"cut", "--json", "--quiet"});
  CHECK(r.exit_code == 0);
  const Json j = parse(r.out);
  REQUIRE(j.is_object());
  for (const char* key : {"status", "message", "file", "genus", "boundary_loops", "sides", "canonical",
                          "reason", "word", "base_vertex", "generators", "refined_vertices", "moves",
                          "cut_vertices", "cut_faces", "seconds", "output", "loops_output"})
    CHECK_MESSAGE(j.contains(key), key);
  CHECK(j["status"] == "ok");
  CHECK(j["genus"] == 2);
  CHECK(j["boundary_loops"] == 0);
  CHECK(j["sides"] == 8);
  CHECK(j["canonical"] == true);
  CHECK(j["word"] == "a1 b1 a1^-1 b1^-1 a2 b2 a2^-1 b2^-1");
  CHECK(r.err.empty());
  const auto text = run_cli({"cut"});
  CHECK(text.exit_code == 0);
  CHECK(text.out.find("word: a1 b1 a1^-1 b1^-1") != std::string::npos);
  CHECK(text.err.find("embedded default") != std::string::npos);
}

TEST_CASE("cli cut: -o writes the disk and the loops file and never overwrites the input") {
  TempDir tmp;
  const std::string in = (ricci_test::fixtures_dir() / "genus2-1hole.obj").string();
  const std::string out = (tmp / "cut.obj").string();
  const auto r = run_cli({"cut", in, "-o", out, "--json", "-q", "--base-vertex", "5"});
  REQUIRE(r.exit_code == 0);
  const Json j = parse(r.out);
  CHECK(j["genus"] == 2);
  CHECK(j["boundary_loops"] == 1);
  CHECK(j["sides"] == 11);
  CHECK(j["canonical"] == true);
  CHECK(j["word"] == "a1 b1 a1^-1 b1^-1 a2 b2 a2^-1 b2^-1 t1 ∂1 t1^-1");
  CHECK(j["output"] == out);
  const std::string loops = (tmp / "cut.loops.obj").string();
  CHECK(j["loops_output"] == loops);
  // The disk reads back as one disk.
  const ricci::ReadResult disk = ricci::read_mesh(out);
  REQUIRE(disk.status == ricci::Status::Ok);
  const auto t = ricci::build_topology(disk.mesh.faces, disk.mesh.num_vertices());
  REQUIRE(t.status == ricci::Status::Ok);
  CHECK(t.topology.euler_characteristic() == 1);
  CHECK(t.topology.num_boundary_loops() == 1);
  CHECK(disk.mesh.num_vertices() == j["cut_vertices"].get<int>());
  // The loops file: one polyline per side and per generator.
  const std::string text = ricci_test::read_bytes(loops);
  std::istringstream lines(text);
  int l_lines = 0, objects = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("l ", 0) == 0) ++l_lines;
    if (line.rfind("o ", 0) == 0) ++objects;
  }
  CHECK(l_lines == 11 + 4 + 1);
  CHECK(objects == l_lines);
  CHECK(text.find("o loop_a1") != std::string::npos);
  CHECK(text.find("o loop_t1") != std::string::npos);

  // Refusals: the output (or its companion) is the input.
  TempDir tmp2;
  const std::string copy = (tmp2 / "mesh.obj").string();
  ricci_test::write_bytes(copy, ricci_test::read_bytes(in));
  const auto same = run_cli({"cut", copy, "-o", copy});
  CHECK(same.exit_code == 6);
  CHECK(same.err.find("input") != std::string::npos);
  const std::string sneaky = (tmp2 / "mesh.loops.obj").string();
  ricci_test::write_bytes(sneaky, ricci_test::read_bytes(in));
  const auto companion = run_cli({"cut", sneaky, "-o", (tmp2 / "mesh.off").string()});
  CHECK(companion.exit_code == 6);
  CHECK(ricci_test::read_bytes(sneaky) == ricci_test::read_bytes(in));
}

TEST_CASE("cli cut: usage errors and failing inputs have their exit codes") {
  const std::string torus = (ricci_test::fixtures_dir() / "torus.obj").string();
  auto r = run_cli({"cut", torus, "--base-vertex", "100000", "--json"});
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--base-vertex 100000") != std::string::npos);
  CHECK(parse(r.out)["status"] == "invalid_argument");
  r = run_cli({"cut", torus, "--base-vertex", "-3"});
  CHECK(r.exit_code == 2);
  r = run_cli({"cut", torus, "--seed", "abc"});
  CHECK(r.exit_code == 2);
  TempDir tmp;
  r = run_cli({"cut", torus, "-o", (tmp / "cut.txt").string()});
  CHECK(r.exit_code == 2);
  r = run_cli({"cut", (tmp / "missing.obj").string()});
  CHECK(r.exit_code == 3);
  r = run_cli({"cut", torus, "--seed", "3", "--json", "-q"});
  CHECK(r.exit_code == 0);
  CHECK(parse(r.out)["canonical"] == true);
  r = run_cli({"cut", "--help"});
  CHECK(r.exit_code == 0);
  CHECK(r.out.find("--base-vertex") != std::string::npos);
  CHECK(r.out.find("--seed") != std::string::npos);
  // every option states its default
  std::size_t defaults = 0;
  for (std::size_t at = 0; (at = r.out.find("Default", at)) != std::string::npos; ++at) ++defaults;
  CHECK(defaults >= 7);
}
