#include "support.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "ricci/conventions.h"

extern char** environ;

namespace ricci_test {

using ricci::Index;
using ricci::kInvalid;
using ricci::next_corner;
using ricci::prev_corner;

fs::path fixtures_dir() { return fs::path(RICCI_SOURCE_DIR) / "fixtures"; }

fs::path shared_meshes_dir() {
  if (const char* env = std::getenv("RICCI_SHARED_MESHES"); env && *env) {
    return fs::is_directory(env) ? fs::path(env) : fs::path();
  }
  const fs::path p = fs::path(RICCI_SOURCE_DIR).parent_path() / "shared" / "meshes";
  return fs::is_directory(p) ? p : fs::path();
}

std::vector<fs::path> mesh_files(const fs::path& dir) {
  std::vector<fs::path> out;
  if (dir.empty() || !fs::is_directory(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const auto ext = e.path().extension().string();
    if (e.is_regular_file() && (ext == ".obj" || ext == ".off" || ext == ".ply")) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  const fs::path base = fs::temp_directory_path();
  for (int attempt = 0;; ++attempt) {
    fs::path p = base / ("ricci-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::error_code ec;
    if (fs::create_directory(p, ec)) {
      path_ = p;
      return;
    }
    if (attempt > 1000) std::abort();
  }
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return {};
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_bytes(const fs::path& p, const std::string& data) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
}

CommandResult run_program(const std::string& program, const std::vector<std::string>& args) {
  CommandResult r;
  TempDir tmp;
  const std::string out_path = (tmp.path() / "stdout").string();
  const std::string err_path = (tmp.path() / "stderr").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<std::string> storage;
  storage.push_back(program);
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : storage) argv.push_back(s.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, program.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    r.err = "could not start " + program;
    return r;
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
  }
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  else if (WIFSIGNALED(status)) r.exit_code = 128 + WTERMSIG(status);
  r.out = read_bytes(out_path);
  r.err = read_bytes(err_path);
  return r;
}

CommandResult run_cli(const std::vector<std::string>& args) { return run_program(RICCI_CLI_PATH, args); }

namespace {
std::string fail(const std::string& what, long long index) {
  return what + " (at " + std::to_string(index) + ")";
}
}  // namespace

std::string check_topology(const ricci::Topology& t, const std::vector<Index>& faces) {
  const Index nc = static_cast<Index>(faces.size());
  if (t.num_faces * 3 != nc) return "num_faces does not match the face buffer";
  if (static_cast<Index>(t.opposite.size()) != nc || static_cast<Index>(t.corner_edge.size()) != nc)
    return "per-corner arrays have the wrong size";
  if (static_cast<Index>(t.edge_vertices.size()) != 2 * t.num_edges ||
      static_cast<Index>(t.edge_corners.size()) != 2 * t.num_edges)
    return "per-edge arrays have the wrong size";
  if (t.corner_vertex != faces) return "corner_vertex is not the face buffer";
  auto vert = [&](Index c) { return faces[c]; };
  // Opposite corners.
  for (Index c = 0; c < nc; ++c) {
    const Index o = t.opposite[c];
    if (o == kInvalid) continue;
    if (o < 0 || o >= nc) return fail("opposite out of range", c);
    if (t.opposite[o] != c) return fail("opposite is not an involution", c);
    if (vert(next_corner(o)) != vert(prev_corner(c)) || vert(prev_corner(o)) != vert(next_corner(c)))
      return fail("opposite corner does not traverse the shared edge in reverse", c);
    if (t.corner_edge[o] != t.corner_edge[c]) return fail("opposite corners on different edges", c);
  }
  // Edges.
  std::vector<int> corner_seen(nc, 0);
  for (Index e = 0; e < t.num_edges; ++e) {
    const Index c0 = t.edge_corners[2 * e], c1 = t.edge_corners[2 * e + 1];
    if (c0 < 0 || c0 >= nc) return fail("edge has no first corner", e);
    if (t.corner_edge[c0] != e) return fail("edge's first corner does not point back", e);
    if (t.edge_vertices[2 * e] != vert(next_corner(c0)) || t.edge_vertices[2 * e + 1] != vert(prev_corner(c0)))
      return fail("edge vertices do not follow the first corner's face", e);
    if (t.opposite[c0] != c1) return fail("edge corners are not opposite", e);
    if (c1 != kInvalid) {
      if (c1 < c0) return fail("interior edge's first corner is not the smaller", e);
      if (t.corner_edge[c1] != e) return fail("edge's second corner does not point back", e);
      ++corner_seen[c1];
    }
    ++corner_seen[c0];
  }
  for (Index c = 0; c < nc; ++c)
    if (corner_seen[c] != 1) return fail("corner listed by a number of edges other than one", c);
  // Vertex fans.
  if (static_cast<Index>(t.vertex_corner_offsets.size()) != t.num_vertices + 1) return "vertex offsets size";
  if (t.vertex_corner_offsets.front() != 0 || t.vertex_corner_offsets.back() != nc) return "vertex offsets ends";
  std::vector<int> in_fan(nc, 0);
  for (Index v = 0; v < t.num_vertices; ++v) {
    const Index b = t.vertex_corner_offsets[v], e = t.vertex_corner_offsets[v + 1];
    if (e < b) return fail("vertex offsets decrease", v);
    if (b == e) continue;
    const bool boundary = t.opposite[prev_corner(t.vertex_corners[b])] == kInvalid;
    if (boundary != t.is_boundary_vertex(v)) return fail("is_boundary_vertex disagrees", v);
    for (Index i = b; i < e; ++i) {
      const Index c = t.vertex_corners[i];
      if (c < 0 || c >= nc || vert(c) != v) return fail("vertex corner list holds another vertex's corner", v);
      ++in_fan[c];
      const Index o = t.opposite[next_corner(c)];
      const Index ccw = o == kInvalid ? kInvalid : next_corner(o);
      if (i + 1 < e) {
        if (ccw != t.vertex_corners[i + 1]) return fail("fan is not in counter-clockwise order", v);
      } else if (boundary) {
        if (ccw != kInvalid) return fail("boundary fan does not end at the boundary", v);
      } else if (ccw != t.vertex_corners[b]) {
        return fail("interior fan does not close", v);
      }
    }
  }
  for (Index c = 0; c < nc; ++c)
    if (in_fan[c] != 1) return fail("corner is not in exactly one vertex fan", c);
  // Boundary loops.
  Index boundary_edges = 0;
  for (Index c = 0; c < nc; ++c) boundary_edges += (t.opposite[c] == kInvalid);
  if (t.num_boundary_edges() != boundary_edges) return "boundary loops do not cover every boundary edge";
  if (static_cast<Index>(t.boundary_vertices.size()) != boundary_edges) return "boundary vertex count";
  std::vector<int> bseen(nc, 0);
  for (Index l = 0; l < t.num_boundary_loops(); ++l) {
    const Index b = t.boundary_offsets[l], e = t.boundary_offsets[l + 1];
    if (e - b < 3) return fail("boundary loop with fewer than three edges", l);
    for (Index i = b; i < e; ++i) {
      const Index c = t.boundary_corners[i];
      if (t.opposite[c] != kInvalid) return fail("boundary corner faces an interior edge", l);
      if (bseen[c]++) return fail("boundary edge listed twice", l);
      if (t.boundary_vertices[i] != vert(next_corner(c))) return fail("boundary vertex is not the edge start", l);
      const Index nxt = (i + 1 < e) ? i + 1 : b;
      if (t.boundary_vertices[nxt] != vert(prev_corner(c))) return fail("boundary loop is not closed/chained", l);
    }
  }
  // Components: every interior edge joins faces of the same component; labels are dense.
  if (static_cast<Index>(t.face_component.size()) != t.num_faces) return "face_component size";
  for (Index c = 0; c < nc; ++c) {
    const Index o = t.opposite[c];
    if (o != kInvalid && t.face_component[c / 3] != t.face_component[o / 3])
      return fail("neighbouring faces in different components", c);
  }
  for (Index f = 0; f < t.num_faces; ++f)
    if (t.face_component[f] < 0 || t.face_component[f] >= t.num_components) return fail("component label", f);
  return {};
}

std::string nibabel_python() {
  for (const char* python : {"/usr/bin/python3", "/usr/local/bin/python3"}) {
    if (run_program(python, {"-c", "import nibabel"}).exit_code == 0) return python;
  }
  return {};
}

bool same_topology(const ricci::Topology& a, const ricci::Topology& b) {
  return a.num_vertices == b.num_vertices && a.num_edges == b.num_edges && a.num_faces == b.num_faces &&
         a.corner_vertex == b.corner_vertex && a.opposite == b.opposite && a.corner_edge == b.corner_edge &&
         a.edge_vertices == b.edge_vertices && a.edge_corners == b.edge_corners &&
         a.vertex_corner_offsets == b.vertex_corner_offsets && a.vertex_corners == b.vertex_corners &&
         a.boundary_offsets == b.boundary_offsets && a.boundary_vertices == b.boundary_vertices &&
         a.boundary_corners == b.boundary_corners && a.face_component == b.face_component &&
         a.num_components == b.num_components;
}

}  // namespace ricci_test
