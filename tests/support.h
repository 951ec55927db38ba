// Shared helpers for the test suite: where the data is, temporary folders, running the CLI,
// and the invariant checks every topology must pass.
#pragma once

#include <doctest/doctest.h>

#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <random>
#include <string>
#include <vector>

#include "ricci/mesh.h"
#include "ricci/topology.h"

namespace ricci_test {

/// Whether this build runs under AddressSanitizer (GCC defines __SANITIZE_ADDRESS__, clang has
/// __has_feature): the sanitizer build runs some property loops on fewer or smaller draws.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

namespace fs = std::filesystem;

/// The repository's fixtures/ folder.
fs::path fixtures_dir();
/// ../shared/meshes beside the repository (or $RICCI_SHARED_MESHES); empty path when absent.
fs::path shared_meshes_dir();
/// Mesh files (.obj, .off, .ply) directly inside `dir`, sorted by name; empty when `dir` is absent.
std::vector<fs::path> mesh_files(const fs::path& dir);

// Seeded property loops and lists of meshes: each case runs with its seed or file named in the
// messages of any check that fails inside it (doctest INFO), so a failure says which draw it was.

/// body(seed) for seed = first, first + 1, …, last.
template <class Body>
void for_each_seed(std::uint64_t first, std::uint64_t last, Body&& body) {
  for (std::uint64_t seed = first; seed <= last; ++seed) {
    INFO("seed " << seed);
    body(seed);
  }
}
/// body(seed) for each seed listed.
template <class Body>
void for_each_seed(std::initializer_list<std::uint64_t> seeds, Body&& body) {
  for (const std::uint64_t seed : seeds) {
    INFO("seed " << seed);
    body(seed);
  }
}
/// body(path) for every mesh file of fixtures/ (mesh_files()), in name order.
template <class Body>
void for_each_fixture(Body&& body) {
  for (const fs::path& path : mesh_files(fixtures_dir())) {
    INFO("fixture " << path.filename().string());
    body(path);
  }
}
/// body(path) for every mesh file of ../shared/meshes/<folder> for each folder listed, in that
/// order; nothing when the shared meshes are absent.
template <class Body>
void for_each_shared_mesh(std::initializer_list<const char*> folders, Body&& body) {
  const fs::path root = shared_meshes_dir();
  if (root.empty()) return;
  for (const char* folder : folders)
    for (const fs::path& path : mesh_files(root / folder)) {
      INFO("shared mesh " << path.string());
      body(path);
    }
}

/// A fresh, empty temporary folder removed when the object goes out of scope.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

/// Whole content of a file (binary); empty string when it cannot be read.
std::string read_bytes(const fs::path& p);
/// Writes bytes to a file (not atomic; for test inputs only).
void write_bytes(const fs::path& p, const std::string& data);

struct CommandResult {
  int exit_code = -1;
  std::string out;  ///< standard output
  std::string err;  ///< standard error
};
/// Runs the ricci CLI with the given arguments (no shell), capturing stdout and stderr.
CommandResult run_cli(const std::vector<std::string>& args);
/// Runs any program with arguments (no shell), capturing stdout and stderr.
CommandResult run_program(const std::string& program, const std::vector<std::string>& args);

/// A Python interpreter that can import nibabel (/usr/bin/python3, where Debian's python3-nibabel
/// lives, or /usr/local/bin/python3); empty when there is none.
std::string nibabel_python();

/// Checks every invariant of a topology against its faces (see conventions.h and topology.h):
/// opposite corners are involutive and point back across the same edge in the opposite
/// direction; corner→edge and edge→corner/vertex agree; the vertex→corner lists cover every
/// corner once and are ordered counter-clockwise fans; boundary loops are closed, run along the
/// face orientation and cover every boundary edge once; components are edge-connected.
/// Returns an empty string when all hold, else a description of the first violation.
std::string check_topology(const ricci::Topology& topo, const std::vector<ricci::Index>& faces);

/// Every field of two topologies compared exactly (a topology built another way must equal
/// build_topology()'s bit for bit).
bool same_topology(const ricci::Topology& a, const ricci::Topology& b);

}  // namespace ricci_test
