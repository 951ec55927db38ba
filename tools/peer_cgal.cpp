// peer_cgal — CGAL's conformal parameterizations of a disk-like triangle mesh, timed and measured the
// way ricci reports its own maps: a peer to compare ricci against. Benchmark only: built against
// Debian's CGAL (libcgal-dev, header-only) and Eigen, never linked into the ricci library or CLI,
// and not built unless asked for:
//
//   cmake -S . -B build -DRICCI_PEERS=ON && cmake --build build --target peer_cgal
//   build/tools/peer_cgal [--subdivide K] [--peers lscm,dcm] [--json] MESH.obj|MESH.off
//
// Takes a triangle mesh (OBJ: `v x y z` and `f a b c` lines, faces `a/b/c` style allowed, negative
// indices relative; OFF: header with counts; polygons are split into fans (p0, pk, pk+1) as ricci's
// readers do; vertices no face uses are dropped). --subdivide K splits every triangle into four
// through its edge midpoints, K times, before anything is timed. The mesh must be one connected
// topological disk (one boundary loop, genus 0): anything else is an error (exit 1).
//
// Runs, each timed on its own on the same mesh:
//   lscm  CGAL::Surface_mesh_parameterization::LSCM_parameterizer_3, with its default border: the
//         two vertices Two_vertices_parameterizer_3 fixes. CGAL's default solver: OpenNL's
//         least-squares front end over Eigen::SimplicialLDLT (sparse LDLᵀ Cholesky of the normal
//         equations) — CGAL ignores the solver-traits parameter of LSCM_parameterizer_3.
//   dcm   Discrete_conformal_map_parameterizer_3 (cotangent weights) with the boundary fixed on
//         the unit circle by arc length (Circular_border_arc_length_parameterizer_3). CGAL's
//         default solver: Eigen::BiCGSTAB with an Eigen::IncompleteLUT preconditioner, once for u,
//         once for v.
// Both through CGAL::Surface_mesh_parameterization::parameterize(mesh, parameterizer, bhd, uv)
// with bhd a halfedge of the longest border (Polygon_mesh_processing::longest_border).
//
// Gives, per peer (one line each, or one JSON object with --json):
//   seconds           wall time (std::chrono::steady_clock) of the parameterize() call alone.
//   status            "ok", or "error: " and CGAL's message (or the exception it threw).
//   angle_distortion  over the corners of all faces, |log(θ_uv / θ_3d)|, θ_3d the corner's angle
//                     in the input triangle in 3D, θ_uv the same corner's angle in the plane
//                     (angles as atan2(|cross|, dot)); mean and max over the corners where the
//                     ratio is finite and positive — ricci's figures (AngleDistortion). degenerate:
//                     the other corners, distortion +∞: every corner of a triangle whose uv signed
//                     area is exactly 0 (or not a number), and any corner whose 3D angle is 0.
//   flipped           faces whose uv signed area is < 0. The orientation taken as positive is
//                     that of the whole map: if the sum of the signed areas is negative (the
//                     parameterization came out globally clockwise), every sign is negated once
//                     before counting, so `flipped` counts the faces against the majority.
//   vm_hwm_kb         VmHWM of /proc/self/status after the peer: the process's peak resident
//                     memory so far (cumulative: it includes the mesh and the peers run before).
// Exit status: 0 when every peer succeeded; 1 when the mesh cannot be read or is not a disk, or a
// peer failed (still reported); 2 on a bad command line.
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/Circular_border_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Discrete_conformal_map_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Error_code.h>
#include <CGAL/Surface_mesh_parameterization/LSCM_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iostream>
#include <numeric>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point_2 = Kernel::Point_2;
using Point_3 = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point_3>;
using Vertex = Mesh::Vertex_index;
using Halfedge = Mesh::Halfedge_index;
using UvMap = Mesh::Property_map<Vertex, Point_2>;
namespace SMP = CGAL::Surface_mesh_parameterization;
namespace PMP = CGAL::Polygon_mesh_processing;

// A triangle soup: points and triangles of 0-based point indices.
struct Soup {
  std::vector<std::array<double, 3>> points;
  std::vector<std::array<std::size_t, 3>> triangles;
};

struct Options {
  std::string path;
  int subdivide = 0;
  bool json = false;
  std::vector<std::string> peers{"lscm", "dcm"};
};

// What one peer did (see the header for the definitions).
struct PeerResult {
  std::string name;
  std::string status = "ok";
  double seconds = 0;
  bool measured = false;  // the figures below are filled in (status ok)
  double mean = 0, max = 0;
  std::size_t degenerate = 0, flipped = 0;
  bool clockwise = false;  // the map came out globally clockwise (signs negated for `flipped`)
  long vm_hwm_kb = -1;     // -1: /proc/self/status could not be read
};

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// Appends polygon (0-based indices) split into the fan (p0, pk, pk+1).
void append_fan(const std::vector<std::size_t>& polygon, Soup& soup) {
  for (std::size_t k = 1; k + 1 < polygon.size(); ++k)
    soup.triangles.push_back({polygon[0], polygon[k], polygon[k + 1]});
}

// An OBJ face corner ("7", "7/1", "7//3", "-1/..."): the 0-based vertex index, or an error.
std::string obj_index(const std::string& token, std::size_t vertices_so_far, std::size_t& index) {
  const std::string head = token.substr(0, token.find('/'));
  long long i = 0;
  std::size_t used = 0;
  try {
    i = std::stoll(head, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != head.size() || i == 0) return "face corner '" + token + "' is not a vertex index";
  const long long n = static_cast<long long>(vertices_so_far);
  const long long zero_based = i > 0 ? i - 1 : n + i;
  if (zero_based < 0 || zero_based >= n)
    return "face corner '" + token + "' names a vertex that does not exist (" + std::to_string(n) +
           " so far)";
  index = static_cast<std::size_t>(zero_based);
  return "";
}

// Reads OBJ `v` and `f` lines (everything else ignored). Returns an error message or "".
std::string parse_obj(std::istream& in, Soup& soup) {
  std::string line;
  std::vector<std::size_t> polygon;
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    std::istringstream words(line);
    std::string key;
    if (!(words >> key)) continue;
    const std::string where = "line " + std::to_string(number) + ": ";
    if (key == "v") {
      std::array<double, 3> p{};
      if (!(words >> p[0] >> p[1] >> p[2])) return where + "a vertex needs three coordinates";
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        return where + "a vertex coordinate is not a finite number";
      soup.points.push_back(p);
    } else if (key == "f") {
      polygon.clear();
      for (std::string token; words >> token;) {
        std::size_t index = 0;
        const std::string error = obj_index(token, soup.points.size(), index);
        if (!error.empty()) return where + error;
        polygon.push_back(index);
      }
      if (polygon.size() < 3) return where + "a face needs at least three vertices";
      append_fan(polygon, soup);
    }
  }
  return "";
}

// The next line of an OFF file that is not blank or a comment, as a stream of words.
bool next_off_line(std::istream& in, std::istringstream& words, std::size_t& number) {
  std::string line;
  while (std::getline(in, line)) {
    ++number;
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    words.clear();
    words.str(line);
    return true;
  }
  return false;
}

// Reads an ASCII OFF file: "OFF", the counts V F E, V points, F polygons. Returns an error or "".
std::string parse_off(std::istream& in, Soup& soup) {
  std::istringstream words;
  std::size_t number = 0;
  std::string key;
  if (!next_off_line(in, words, number) || !(words >> key) || key != "OFF")
    return "the first line is not 'OFF' (only ASCII OFF is read)";
  long long v = -1, f = -1;
  if (!(words >> v) && (!next_off_line(in, words, number) || !(words >> v)))
    return "line " + std::to_string(number) + ": no vertex count";
  if (!(words >> f) || v < 0 || f < 0)
    return "line " + std::to_string(number) + ": the counts are not 'vertices faces edges'";
  for (long long i = 0; i < v; ++i) {
    std::array<double, 3> p{};
    if (!next_off_line(in, words, number) || !(words >> p[0] >> p[1] >> p[2]))
      return "line " + std::to_string(number) + ": vertex " + std::to_string(i) + " needs three coordinates";
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      return "line " + std::to_string(number) + ": a vertex coordinate is not a finite number";
    soup.points.push_back(p);
  }
  std::vector<std::size_t> polygon;
  for (long long i = 0; i < f; ++i) {
    long long n = 0;
    if (!next_off_line(in, words, number) || !(words >> n) || n < 3)
      return "line " + std::to_string(number) + ": face " + std::to_string(i) + " needs a size of 3 or more";
    polygon.assign(static_cast<std::size_t>(n), 0);
    for (std::size_t& index : polygon) {
      long long k = -1;
      if (!(words >> k) || k < 0 || k >= v)
        return "line " + std::to_string(number) + ": face " + std::to_string(i) +
               " has an index out of range";
      index = static_cast<std::size_t>(k);
    }
    append_fan(polygon, soup);
  }
  return "";
}

// Reads an OBJ or OFF file by its extension. Returns an error message (without the path) or "".
std::string read_soup(const std::string& path, Soup& soup) {
  const std::string name = lower(path);
  const bool obj = ends_with(name, ".obj"), off = ends_with(name, ".off");
  if (!obj && !off) return "unknown format (expected a .obj or .off file)";
  std::ifstream in(path);
  if (!in) return "cannot open the file";
  const std::string error = obj ? parse_obj(in, soup) : parse_off(in, soup);
  if (!error.empty()) return error;
  if (soup.triangles.empty()) return "the file has no faces";
  return "";
}

// One round of 1→4 midpoint subdivision: each edge gets one new point at its midpoint, each
// triangle (a, b, c) becomes (a, ab, ca), (ab, b, bc), (ca, bc, c) and (ab, bc, ca).
void subdivide(Soup& soup) {
  std::unordered_map<std::uint64_t, std::size_t> midpoints;
  midpoints.reserve(soup.triangles.size() * 2);
  auto midpoint = [&](std::size_t a, std::size_t b) {
    const std::uint64_t key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
    const auto [it, added] = midpoints.try_emplace(key, soup.points.size());
    if (added) {
      const auto& p = soup.points[a];
      const auto& q = soup.points[b];
      soup.points.push_back({(p[0] + q[0]) / 2, (p[1] + q[1]) / 2, (p[2] + q[2]) / 2});
    }
    return it->second;
  };
  std::vector<std::array<std::size_t, 3>> finer;
  finer.reserve(soup.triangles.size() * 4);
  for (const auto& [a, b, c] : soup.triangles) {
    const std::size_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
    finer.push_back({a, ab, ca});
    finer.push_back({ab, b, bc});
    finer.push_back({ca, bc, c});
    finer.push_back({ab, bc, ca});
  }
  soup.triangles = std::move(finer);
}

// Checks that mesh is one connected topological disk: one border loop, Euler characteristic 1.
std::string check_disk(const Mesh& mesh) {
  std::vector<std::size_t> parent(mesh.number_of_vertices());
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  auto root = [&](std::size_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const auto e : mesh.edges()) parent[root(mesh.vertex(e, 0))] = root(mesh.vertex(e, 1));
  std::size_t components = 0;
  for (std::size_t v = 0; v < parent.size(); ++v) components += root(v) == v;
  std::size_t loops = 0;
  std::vector<bool> seen(mesh.number_of_halfedges(), false);
  for (const Halfedge h : mesh.halfedges()) {
    if (!mesh.is_border(h) || seen[h.idx()]) continue;
    ++loops;
    for (Halfedge g = h; !seen[g.idx()]; g = mesh.next(g)) seen[g.idx()] = true;
  }
  const long long euler = static_cast<long long>(mesh.number_of_vertices()) -
                          static_cast<long long>(mesh.number_of_edges()) +
                          static_cast<long long>(mesh.number_of_faces());
  if (components != 1)
    return "not a topological disk: " + std::to_string(components) + " connected components";
  if (loops != 1)
    return "not a topological disk: " + std::to_string(loops) + " boundary loops (needs exactly 1)";
  if (euler != 1)
    return "not a topological disk: Euler characteristic " + std::to_string(euler) +
           " with one boundary loop (genus " + std::to_string((1 - euler) / 2) + ", needs 0)";
  return "";
}

// Builds the Surface_mesh of soup (dropping points no triangle uses) and checks it is a disk.
std::string build_disk_mesh(const Soup& soup, Mesh& mesh) {
  std::vector<bool> used(soup.points.size(), false);
  for (const auto& t : soup.triangles)
    for (const std::size_t v : t) used[v] = true;
  std::vector<Vertex> vertex(soup.points.size());
  for (std::size_t v = 0; v < soup.points.size(); ++v)
    if (used[v])
      vertex[v] = mesh.add_vertex(Point_3(soup.points[v][0], soup.points[v][1], soup.points[v][2]));
  for (std::size_t f = 0; f < soup.triangles.size(); ++f) {
    const auto& [a, b, c] = soup.triangles[f];
    auto triangle = [&] {
      return "triangle " + std::to_string(f) + " (vertices " + std::to_string(a) + ", " + std::to_string(b) +
             ", " + std::to_string(c) + ", 0-based)";
    };
    if (a == b || b == c || c == a) return triangle() + " repeats a vertex";
    if (mesh.add_face(vertex[a], vertex[b], vertex[c]) == Mesh::null_face())
      return triangle() + " cannot be added: the mesh is not an oriented 2-manifold there (an edge in more " +
             "than two faces, neighbours with opposite orientations, or a non-manifold vertex)";
  }
  return check_disk(mesh);
}

// θ_3d / θ_uv figures and flipped faces of the map uv (see the header); fills r.
void measure(const Mesh& mesh, const UvMap& uv, PeerResult& r) {
  std::vector<double> signed_area;
  signed_area.reserve(mesh.number_of_faces());
  double total = 0;
  for (const auto f : mesh.faces()) {
    const Halfedge h = mesh.halfedge(f);
    const Point_2 &a = uv[mesh.target(h)], &b = uv[mesh.target(mesh.next(h))], &c = uv[mesh.source(h)];
    const double s = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    signed_area.push_back(s);
    if (std::isfinite(s)) total += s;
  }
  r.clockwise = total < 0;
  double sum = 0;
  std::size_t n = 0, face = 0;
  for (const auto f : mesh.faces()) {
    const double s = r.clockwise ? -signed_area[face] : signed_area[face];
    ++face;
    r.flipped += s < 0;
    const bool degenerate_uv = !(s != 0 && std::isfinite(s));
    for (const Halfedge h : mesh.halfedges_around_face(mesh.halfedge(f))) {
      // The corner at target(h), between the edges to source(h) and to target(next(h)).
      const Vertex o = mesh.target(h), p = mesh.source(h), q = mesh.target(mesh.next(h));
      const auto e1 = mesh.point(p) - mesh.point(o), e2 = mesh.point(q) - mesh.point(o);
      const double t3 = std::atan2(std::sqrt(CGAL::cross_product(e1, e2).squared_length()), e1 * e2);
      const auto d1 = uv[p] - uv[o], d2 = uv[q] - uv[o];
      const double tuv = std::atan2(std::abs(d1.x() * d2.y() - d1.y() * d2.x()), d1 * d2);
      const double ratio = tuv / t3;
      if (degenerate_uv || !(t3 > 0) || !(ratio > 0) || !std::isfinite(ratio)) {
        ++r.degenerate;
        continue;
      }
      const double x = std::abs(std::log(ratio));
      sum += x;
      ++n;
      r.max = std::max(r.max, x);
    }
  }
  r.mean = n > 0 ? sum / static_cast<double>(n) : 0;
  r.measured = true;
}

// VmHWM of /proc/self/status in kB, or -1.
long vm_hwm_kb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::strtol(line.c_str() + 6, nullptr, 10);
  return -1;
}

// Runs one peer on mesh (its uv map is a temporary property), times it and measures the result.
PeerResult run_peer(Mesh& mesh, const std::string& name, Halfedge border) {
  PeerResult r;
  r.name = name;
  UvMap uv = mesh.add_property_map<Vertex, Point_2>("v:peer_uv", Point_2(0, 0)).first;
  SMP::Error_code code = SMP::OK;
  const auto start = std::chrono::steady_clock::now();
  try {
    if (name == "lscm") {
      code = SMP::parameterize(mesh, SMP::LSCM_parameterizer_3<Mesh>(), border, uv);
    } else {
      using Circle = SMP::Circular_border_arc_length_parameterizer_3<Mesh>;
      code = SMP::parameterize(mesh, SMP::Discrete_conformal_map_parameterizer_3<Mesh, Circle>(), border, uv);
    }
  } catch (const std::exception& e) {
    r.status = std::string("error: CGAL threw: ") + e.what();
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (r.status == "ok" && code != SMP::OK) r.status = std::string("error: ") + SMP::get_error_message(code);
  if (r.status == "ok") measure(mesh, uv, r);
  mesh.remove_property_map(uv);
  r.vm_hwm_kb = vm_hwm_kb();
  return r;
}

// Parses the command line into o. Returns an error message or "".
std::string parse_args(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--json") {
      o.json = true;
    } else if (a == "--subdivide" || a == "--peers") {
      if (i + 1 >= argc) return a + " needs a value";
      const std::string value = argv[++i];
      if (a == "--peers") {
        o.peers.clear();
        std::istringstream list(value);
        for (std::string p; std::getline(list, p, ',');) {
          if (p != "lscm" && p != "dcm") return "unknown peer '" + p + "' (known: lscm, dcm)";
          o.peers.push_back(p);
        }
        if (o.peers.empty()) return "--peers needs at least one of lscm, dcm";
      } else {
        if (value.size() != 1 || value[0] < '0' || value[0] > '6')
          return "--subdivide needs a whole number from 0 to 6, not '" + value + "'";
        o.subdivide = value[0] - '0';
      }
    } else if (a.rfind("--", 0) == 0) {
      return "unknown option '" + a + "'";
    } else if (o.path.empty()) {
      o.path = a;
    } else {
      return "more than one mesh given ('" + o.path + "', '" + a + "')";
    }
  }
  if (o.path.empty()) return "no mesh given";
  return "";
}

// A JSON string literal.
std::string json_string(const std::string& s) {
  std::string q = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      q += '\\';
      q += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\u%04x", static_cast<unsigned>(c));
      q += buffer;
    } else {
      q += c;
    }
  }
  return q + "\"";
}

// A JSON number (null when not finite).
std::string json_number(double x) {
  if (!std::isfinite(x)) return "null";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9g", x);
  return buffer;
}

std::string json_report(const Options& o, const Mesh& mesh, const std::vector<PeerResult>& results) {
  std::string s = "{\"mesh\": " + json_string(o.path) +
                  ", \"faces\": " + std::to_string(mesh.number_of_faces()) +
                  ", \"vertices\": " + std::to_string(mesh.number_of_vertices()) +
                  ", \"subdivide\": " + std::to_string(o.subdivide) + ", \"peers\": [";
  for (std::size_t i = 0; i < results.size(); ++i) {
    const PeerResult& r = results[i];
    s += i ? ", " : "";
    s += "{\"name\": " + json_string(r.name) + ", \"seconds\": " + json_number(r.seconds) +
         ", \"status\": " + json_string(r.status) + ", \"angle_distortion\": ";
    if (r.measured)
      s += "{\"mean\": " + json_number(r.mean) + ", \"max\": " + json_number(r.max) +
           ", \"degenerate\": " + std::to_string(r.degenerate) +
           "}, \"flipped\": " + std::to_string(r.flipped);
    else
      s += "null, \"flipped\": null";
    s += ", \"vm_hwm_kb\": " + (r.vm_hwm_kb >= 0 ? std::to_string(r.vm_hwm_kb) : std::string("null")) + "}";
  }
  return s + "]}";
}

std::string text_line(const PeerResult& r) {
  char buffer[512];
  if (!r.measured) {
    std::snprintf(buffer, sizeof buffer, "%-4s  %.3f s  %s  VmHWM %ld kB", r.name.c_str(), r.seconds,
                  r.status.c_str(), r.vm_hwm_kb);
  } else {
    std::snprintf(buffer, sizeof buffer,
                  "%-4s  %.3f s  ok  angle distortion mean %.6g max %.6g (%zu degenerate corners)  "
                  "%zu flipped faces%s  VmHWM %ld kB",
                  r.name.c_str(), r.seconds, r.mean, r.max, r.degenerate, r.flipped,
                  r.clockwise ? " (map clockwise overall)" : "", r.vm_hwm_kb);
  }
  return buffer;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (const std::string error = parse_args(argc, argv, o); !error.empty()) {
    std::cerr << "peer_cgal: " << error
              << "\nusage: peer_cgal [--subdivide K] [--peers lscm,dcm] [--json] MESH.obj|MESH.off\n";
    return 2;
  }
  Soup soup;
  if (const std::string error = read_soup(o.path, soup); !error.empty()) {
    std::cerr << "peer_cgal: " << o.path << ": " << error << "\n";
    return 1;
  }
  for (int k = 0; k < o.subdivide; ++k) subdivide(soup);
  Mesh mesh;
  if (const std::string error = build_disk_mesh(soup, mesh); !error.empty()) {
    std::cerr << "peer_cgal: " << o.path << ": " << error << "\n";
    return 1;
  }
  soup = Soup();
  const Halfedge border = PMP::longest_border(mesh).first;
  std::vector<PeerResult> results;
  for (const std::string& name : o.peers) results.push_back(run_peer(mesh, name, border));
  if (o.json) {
    std::cout << json_report(o, mesh, results) << "\n";
  } else {
    std::cout << o.path << ": " << mesh.number_of_faces() << " faces, " << mesh.number_of_vertices()
              << " vertices (subdivide " << o.subdivide << ")\n";
    for (const PeerResult& r : results) std::cout << text_line(r) << "\n";
  }
  bool all_ok = true;
  for (const PeerResult& r : results) all_ok = all_ok && r.measured;
  return all_ok ? 0 : 1;
}
