// Infeasible and hostile inputs (issue 8, item 4) through the CLI: target files that violate
// Gauss–Bonnet, positive cone angles or Theorem 4 in `uniformize`; huge vertex indices in target,
// OBJ, OFF and PLY files; files of several GB (sparse) refused by their size before being read;
// unwritable output locations and outputs equal to the input for every command that writes; and
// interruptions while `convert`, `flow`, `cut` and `cover` write. In every case: a non-zero exit
// code, an error naming the file (and the element), the input unchanged and no partial output.
// (The library-level checks of target files are in test_target.cpp, `flow`'s in test_cli_flow.cpp,
// `uniformize`'s interruption in test_cli_uniformize.cpp.)
#include <doctest/doctest.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "ricci/validate.h"
#include "support.h"

using ricci::Status;
using ricci_test::CommandResult;
using ricci_test::run_cli;
using ricci_test::TempDir;
namespace fs = std::filesystem;

namespace {

constexpr double kPi = std::numbers::pi;

/// Names in a folder (hidden ones included), sorted.
std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// A copy of fixtures/NAME in `dir`.
fs::path copy_fixture(const TempDir& dir, const std::string& name) {
  const fs::path p = dir / name;
  ricci_test::write_bytes(p, ricci_test::read_bytes(ricci_test::fixtures_dir() / name));
  return p;
}

/// A sparse file of `bytes` bytes starting with `head` (nothing else is stored on disk).
bool make_sparse(const fs::path& p, const std::string& head, std::uint64_t bytes) {
  ricci_test::write_bytes(p, head);
  return ::truncate(p.c_str(), static_cast<off_t>(bytes)) == 0;
}

std::string number(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

}  // namespace

TEST_CASE("hostile: infeasible target files make uniformize exit 8 naming the vertex, writing nothing") {
  TempDir dir;
  const fs::path mesh = copy_fixture(dir, "genus2.obj");
  const std::string before = ricci_test::read_bytes(mesh);
  const ricci::LoadResult loaded = ricci::load_mesh(mesh.string());
  REQUIRE(loaded.status == Status::Ok);
  const ricci::Topology& t = loaded.validated.topology;
  // χ = −2: Σ K̄ must be −4π; unlisted interior vertices get 0.
  const double valence0 = t.valence(0);
  struct Case {
    const char* what;
    std::string cones;
    const char* mentions;
  };
  // In H, Gauss–Bonnet needs Σ K̄ > 2πχ = −4π (the area is the difference): the other cases sum
  // to −4π + 1 with vertex 1 taking the rest.
  const Case cases[] = {
      {"Gauss-Bonnet violated", "0 -13\n", "Bonnet"},
      {"Gauss-Bonnet with equality", "0 " + number(-4 * kPi) + "\n", "Bonnet"},
      {"cone angle 0 (K = 2pi)", "0 " + number(2 * kPi) + "\n1 " + number(-6 * kPi + 1) + "\n", "vertex 0"},
      {"negative cone angle", "0 7\n1 " + number(-4 * kPi - 7 + 1) + "\n", "vertex 0"},
      // Cone angle (d + 1/2)π at a vertex of valence d exceeds Σ(π − Φ) ≤ dπ over its opposite
      // edges (Theorem 4); vertex 1 takes the rest (a positive cone angle there).
      {"Theorem 4 violated", "0 " + number(2 * kPi - (valence0 + 0.5) * kPi) + "\n1 " +
                                 number(-4 * kPi + 1 - (2 * kPi - (valence0 + 0.5) * kPi)) + "\n",
       "Theorem 4"},
  };
  int k = 0;
  for (const Case& c : cases) {
    CAPTURE(c.what);
    const fs::path cones = dir / ("cones" + std::to_string(k++) + ".txt");
    ricci_test::write_bytes(cones, c.cones);
    const fs::path out = dir / ("out" + std::to_string(k));
    // Theorem 4 bounds circle packing (the paper's scheme); the other checks hold for every scheme.
    const CommandResult r = run_cli({"uniformize", mesh.string(), "--target", "cones=" + cones.string(), "-o",
                                     out.string(), "--no-pictures", "-q", "--scheme", "circle-packing"});
    INFO(r.err);
    CHECK(r.exit_code == 8);
    CHECK(r.err.find("ricci: error: " + mesh.string() + ": target: ") != std::string::npos);
    CHECK(r.err.find(c.mentions) != std::string::npos);
    CHECK(!fs::exists(out));
  }
  CHECK(ricci_test::read_bytes(mesh) == before);
}

TEST_CASE("hostile: huge vertex indices in target, OBJ, OFF and PLY files are named errors") {
  TempDir dir;
  const fs::path mesh = copy_fixture(dir, "genus2.obj");
  for (const char* index : {"99999999999999999999999", "4294967296", "2147483648", "-9223372036854775808"}) {
    CAPTURE(index);
    const fs::path cones = dir / "cones.txt";
    ricci_test::write_bytes(cones, std::string("0 -1\n") + index + " 0.5\n");
    const fs::path out = dir / "out";
    const CommandResult r =
        run_cli({"uniformize", mesh.string(), "--target", "cones=" + cones.string(), "-o", out.string(), "-q"});
    INFO(r.err);
    CHECK(r.exit_code == 4);
    CHECK(r.err.find(cones.string()) != std::string::npos);
    CHECK(r.err.find("line 2") != std::string::npos);
    CHECK(r.err.find("vertices") != std::string::npos);
    CHECK(!fs::exists(out));
  }
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  struct Case {
    const char* name;
    std::string text;
    const char* mentions;
  };
  const Case cases[] = {
      {"a.obj", tri + "f 1 2 99999999999999999999999\n", "line 4"},
      {"b.obj", tri + "f 1 2 2147483648\n", "line 4"},
      {"c.obj", tri + "f 1 2 -9223372036854775808\n", "line 4"},
      {"d.obj", tri + "f 1 2 4294967299\n", "line 4"},
      {"e.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 4294967296\n", "line 6"},
      {"f.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 99999999999999999999999\n", "line 6"},
      {"g.off", "OFF\n99999999999 99999999999 0\n0 0 0\n", "line 2"},
      {"h.off", "OFF\n3 4000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "face"},
      {"i.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2147483647\n",
       "line 13"},
      {"j.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 99999999999999\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n",
       "vertex"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const fs::path p = dir / c.name;
    ricci_test::write_bytes(p, c.text);
    const CommandResult r = run_cli({"info", p.string(), "-q"});
    INFO(r.err);
    CHECK((r.exit_code == 4 || r.exit_code == 3));
    CHECK(r.err.find("ricci: error: " + p.string()) != std::string::npos);
    CHECK(r.err.find(c.mentions) != std::string::npos);
    CHECK(ricci_test::read_bytes(p) == c.text);
  }
}

TEST_CASE("hostile: a file of several GB is refused by its size before it is read") {
  TempDir dir;
  constexpr std::uint64_t kSix = std::uint64_t{6} << 30;
  const fs::path big = dir / "big.obj";
  if (!make_sparse(big, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", kSix)) {
    MESSAGE("cannot make a 6 GiB sparse file here; skipped");
    return;
  }
  // The library: FileTooLarge after one stat(), naming the size and the limit.
  const ricci::ReadResult rr = ricci::read_mesh(big.string());
  CHECK(rr.status == Status::FileTooLarge);
  CHECK(rr.message.find(big.string()) != std::string::npos);
  CHECK(rr.message.find(std::to_string(kSix) + " bytes") != std::string::npos);
  CHECK(rr.message.find("limit of " + std::to_string(std::uint64_t{2} << 30)) != std::string::npos);
  // Every command that reads a mesh: exit 3, the size and the flag that raises the limit.
  const fs::path out = dir / "out";
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"info", big.string()}, {"convert", big.string(), "-o", (dir / "c.off").string()},
        {"flow", big.string(), "-o", (dir / "m.csv").string()}, {"cut", big.string(), "-o", (dir / "cut.obj").string()},
        {"uniformize", big.string(), "-o", out.string()}, {"cover", big.string(), "-o", (dir / "t.svg").string()}}) {
    CAPTURE(args[0]);
    const CommandResult r = run_cli(args);
    INFO(r.err);
    CHECK(r.exit_code == 3);
    CHECK(r.err.find(big.string()) != std::string::npos);
    CHECK(r.err.find(std::to_string(kSix) + " bytes") != std::string::npos);
    CHECK(r.err.find("--max-file-size") != std::string::npos);
  }
  // Target and metric files too (their readers would hold the whole file).
  const fs::path mesh = copy_fixture(dir, "genus2.obj");
  const fs::path cones = dir / "cones.txt";
  REQUIRE(make_sparse(cones, "0 -1\n", kSix));
  const CommandResult rt = run_cli({"uniformize", mesh.string(), "--target", "cones=" + cones.string(), "-o", out.string()});
  INFO(rt.err);
  CHECK(rt.exit_code == 3);
  CHECK(rt.err.find(cones.string() + ": the file has " + std::to_string(kSix) + " bytes") != std::string::npos);
  const fs::path metric = dir / "metric.csv";
  REQUIRE(make_sparse(metric, "vertex,u\n", kSix));
  const CommandResult rm = run_cli({"layout", mesh.string(), "--metric", metric.string(), "-o", out.string()});
  INFO(rm.err);
  CHECK(rm.exit_code == 3);
  CHECK(rm.err.find(metric.string() + ": the file has") != std::string::npos);
  // Nothing was written, and the sparse files are still sparse and unchanged in size.
  CHECK(listing(dir.path()) == std::vector<std::string>{"big.obj", "cones.txt", "genus2.obj", "metric.csv"});
  CHECK(fs::file_size(big) == kSix);
  // The limit is an option: lowered, it refuses a small file; raised, it accepts it; nonsense is
  // a usage error. It may come before or after the subcommand.
  const CommandResult low = run_cli({"info", mesh.string(), "--max-file-size", "1K"});
  CHECK(low.exit_code == 3);
  CHECK(low.err.find("more than the limit of 1024") != std::string::npos);
  CHECK(run_cli({"--max-file-size", "1G", "info", mesh.string()}).exit_code == 0);
  CHECK(run_cli({"info", mesh.string(), "--max-file-size", "12Q"}).exit_code == 2);
  CHECK(run_cli({"info", mesh.string(), "--max-file-size", "99999999999T"}).exit_code == 2);
}

TEST_CASE("hostile: declared counts far beyond the bytes present reserve no memory for them") {
  TempDir dir;
  // 64 MiB of zeros after a header declaring 2·10^9 vertices and faces: the reservation is capped
  // by the bytes present, the parse fails at the first zero byte.
  for (const char* name : {"z.off", "z.ply"}) {
    CAPTURE(name);
    const fs::path p = dir / name;
    const std::string head =
        std::string(name) == "z.off"
            ? "OFF\n2000000000 2000000000 0\n"
            : "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty double x\nproperty double y\n"
              "property double z\nelement face 2000000000\nproperty list uchar int vertex_indices\nend_header\n";
    REQUIRE(make_sparse(p, head, std::uint64_t{64} << 20));
    const ricci::ReadResult r = ricci::read_mesh(p.string());
    INFO(r.message);
    CHECK(r.status != Status::Ok);
    CHECK(r.message.find(p.string()) != std::string::npos);
    CHECK(r.mesh.positions.capacity() < (std::size_t{64} << 20));
  }
}

TEST_CASE("hostile: an unwritable output location exits 6 for every command that writes, creating nothing") {
  TempDir dir;
  const fs::path mesh = copy_fixture(dir, "genus2.obj");
  const fs::path torus = copy_fixture(dir, "torus.obj");
  const fs::path metric = dir / "metric.csv";
  REQUIRE(run_cli({"flow", mesh.string(), "-o", metric.string(), "-q"}).exit_code == 0);
  const fs::path file = dir / "file.txt";
  ricci_test::write_bytes(file, "a regular file\n");
  // A path under a regular file cannot be created even by root.
  const fs::path blocked = file / "sub";
  std::vector<fs::path> places = {blocked};
  if (::geteuid() != 0) {  // a read-only folder stops everyone but root
    const fs::path ro = dir / "read-only";
    fs::create_directory(ro);
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
    places.push_back(ro);
  }
  const std::vector<std::string> before = listing(dir.path());
  for (const fs::path& place : places) {
    CAPTURE(place);
    const std::vector<std::vector<std::string>> runs = {
        {"convert", mesh.string(), "-o", (place / "c.off").string()},
        {"flow", mesh.string(), "-o", (place / "m.csv").string()},
        {"cut", mesh.string(), "-o", (place / "cut.obj").string()},
        {"uniformize", torus.string(), "-o", (place / "out").string(), "--no-pictures"},
        {"layout", mesh.string(), "--metric", metric.string(), "-o", (place / "out").string()},
        {"cover", torus.string(), "-o", (place / "tiles.obj").string()},
    };
    for (const std::vector<std::string>& args : runs) {
      CAPTURE(args[0]);
      const CommandResult r = run_cli(args);
      INFO(r.err);
      CHECK(r.exit_code == 6);
      CHECK(r.err.find("ricci: error: ") != std::string::npos);
      CHECK(r.err.find(place.string()) != std::string::npos);
    }
    if (fs::is_directory(place)) CHECK(listing(place).empty());
  }
  CHECK(listing(dir.path()) == before);
  // `cut` writes two files: when the second cannot be written, the first is not left behind.
  fs::create_directory(dir / "pair.loops.obj");
  const CommandResult pair = run_cli({"cut", mesh.string(), "-o", (dir / "pair.obj").string()});
  INFO(pair.err);
  CHECK(pair.exit_code == 6);
  CHECK(pair.err.find("pair.loops.obj") != std::string::npos);
  CHECK(!fs::exists(dir / "pair.obj"));
  fs::remove(dir / "pair.loops.obj");
  if (::geteuid() != 0) fs::permissions(dir / "read-only", fs::perms::owner_all);
}

TEST_CASE("hostile: an output equal to the input is refused by every command that writes") {
  TempDir dir;
  const fs::path mesh = copy_fixture(dir, "torus.obj");
  const fs::path metric = dir / "metric.csv";
  REQUIRE(run_cli({"flow", mesh.string(), "-o", metric.string(), "-q"}).exit_code == 0);
  const fs::path loops_twin = dir / "twin.loops.obj";  // `cut -o twin.obj` would write it
  ricci_test::write_bytes(loops_twin, ricci_test::read_bytes(mesh));
  const fs::path link = dir / "link.obj";
  fs::create_symlink(mesh.filename(), link);
  const std::string mesh_bytes = ricci_test::read_bytes(mesh);
  const std::string metric_bytes = ricci_test::read_bytes(metric);
  const std::vector<std::string> before = listing(dir.path());
  const std::string same = (dir.path() / "." / "torus.obj").string();
  const std::vector<std::vector<std::string>> runs = {
      {"convert", mesh.string(), "-o", mesh.string()},
      {"convert", mesh.string(), "-o", link.string()},
      {"flow", mesh.string(), "-o", same},
      {"flow", mesh.string(), "-o", metric.string(), "--target", "cones=" + metric.string()},
      {"cut", mesh.string(), "-o", mesh.string()},
      {"cut", link.string(), "-o", same},
      {"cut", loops_twin.string(), "-o", (dir / "twin.obj").string()},
      {"uniformize", mesh.string(), "-o", mesh.string(), "--no-pictures"},
      {"uniformize", mesh.string(), "-o", dir.path().string(), "--no-pictures"},
      {"layout", mesh.string(), "--metric", metric.string(), "-o", mesh.string()},
      {"layout", mesh.string(), "--metric", metric.string(), "-o", metric.string()},
      {"cover", mesh.string(), "-o", mesh.string()},
      {"cover", mesh.string(), "-o", link.string()},
  };
  for (const std::vector<std::string>& args : runs) {
    CAPTURE(args[0]);
    CAPTURE(args[3]);
    const CommandResult r = run_cli(args);
    INFO(r.err);
    CHECK(r.exit_code == 6);
    CHECK(r.err.find("ricci: error: ") != std::string::npos);
    CHECK(ricci_test::read_bytes(mesh) == mesh_bytes);
    CHECK(ricci_test::read_bytes(metric) == metric_bytes);
    CHECK(listing(dir.path()) == before);
  }
  CHECK(fs::is_symlink(link));
}

namespace {

extern "C" char** environ;

struct Interrupted {
  int status = -1;       ///< wait status; -1 when the process could not be started
  bool paused = false;   ///< the signal was sent while the command was about to write
};

/// Runs the CLI with RICCI_WRITE_PAUSE_MS=300, waits for its "pausing before writing" note on
/// stderr (when `at_write`; otherwise signals right away) and sends `sig`.
Interrupted interrupt(const std::vector<std::string>& cli_args, int sig, bool at_write) {
  const std::string cli = RICCI_CLI_PATH;
  std::vector<std::string> args = {cli};
  args.insert(args.end(), cli_args.begin(), cli_args.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_store;
  for (char** e = environ; *e != nullptr; ++e) env_store.emplace_back(*e);
  env_store.emplace_back("RICCI_WRITE_PAUSE_MS=300");
  std::vector<char*> envp;
  for (auto& e : env_store) envp.push_back(e.data());
  envp.push_back(nullptr);
  int err_pipe[2];
  Interrupted out;
  if (::pipe(err_pipe) != 0) return out;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, err_pipe[1], 2);
  posix_spawn_file_actions_addclose(&actions, err_pipe[0]);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, cli.c_str(), &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  ::close(err_pipe[1]);
  if (rc != 0) {
    ::close(err_pipe[0]);
    return out;
  }
  if (at_write) {
    std::string err;
    char buf[4096];
    for (;;) {
      const ssize_t n = ::read(err_pipe[0], buf, sizeof buf);
      if (n <= 0) break;
      err.append(buf, static_cast<std::size_t>(n));
      if (err.find("pausing before writing") != std::string::npos) {
        out.paused = true;
        break;
      }
    }
  }
  ::kill(pid, sig);
  // Drain stderr to its end, so that the command never dies of SIGPIPE instead.
  char sink[4096];
  while (::read(err_pipe[0], sink, sizeof sink) > 0) {
  }
  ::close(err_pipe[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
  }
  out.status = status;
  return out;
}

}  // namespace

TEST_CASE("hostile: SIGINT or SIGTERM while convert, flow, cut or cover write leaves complete outputs or none") {
  TempDir dir;
  const fs::path mesh = copy_fixture(dir, "torus.obj");
  struct Run {
    std::vector<std::string> args;
    std::vector<std::string> outputs;
  };
  const std::vector<Run> runs = {
      {{"convert", mesh.string(), "-o", (dir / "c.off").string()}, {"c.off"}},
      {{"flow", mesh.string(), "-o", (dir / "m.csv").string(), "-q"}, {"m.csv"}},
      {{"cut", mesh.string(), "-o", (dir / "cut.obj").string(), "-q"}, {"cut.obj", "cut.loops.obj"}},
      {{"cover", mesh.string(), "-o", (dir / "tiles.svg").string(), "-q"}, {"tiles.svg"}},
  };
  for (const Run& run : runs) {
    CAPTURE(run.args[0]);
    // The reference outputs of an uninterrupted run.
    REQUIRE(run_cli(run.args).exit_code == 0);
    std::vector<std::string> reference;
    for (const std::string& o : run.outputs) {
      reference.push_back(ricci_test::read_bytes(dir / o));
      fs::remove(dir / o);
    }
    for (int sig : {SIGINT, SIGTERM}) {
      CAPTURE(sig);
      for (bool at_write : {false, true}) {
        CAPTURE(at_write);
        const Interrupted r = interrupt(run.args, sig, at_write);
        REQUIRE(r.status != -1);
        CHECK(WIFSIGNALED(r.status));
        if (WIFSIGNALED(r.status)) CHECK(WTERMSIG(r.status) == sig);
        if (at_write) {
          // Signalled during the pause before writing: the writes complete, then the signal ends
          // the process.
          CHECK(r.paused);
          for (std::size_t i = 0; i < run.outputs.size(); ++i)
            CHECK(ricci_test::read_bytes(dir / run.outputs[i]) == reference[i]);
        }
        // Either every output is complete or none exists; never a temporary file.
        bool all = true, none = true;
        for (std::size_t i = 0; i < run.outputs.size(); ++i) {
          const bool there = fs::exists(dir / run.outputs[i]);
          all = all && there && ricci_test::read_bytes(dir / run.outputs[i]) == reference[i];
          none = none && !there;
        }
        CHECK((all || none));
        for (const std::string& name : listing(dir.path())) CHECK_MESSAGE(name.rfind(".", 0) != 0, name);
        for (const std::string& o : run.outputs) fs::remove(dir / o);
      }
    }
  }
  CHECK(listing(dir.path()) == std::vector<std::string>{"torus.obj"});
}
