// Tests of the CLI with the formats users keep meshes in: `ricci uniformize` on STL, FreeSurfer and
// GIFTI inputs gives the same map as from OBJ and writes the family's files (sphere or layout,
// per-vertex overlays) and mesh.glb; mesh.glb is checked by two readers that are not its writer
// (a GLB parser written here in Python's standard library, and tinygltf's loader); `ricci
// convert` handles every pair of formats; `ricci info` reports format details.
#include <tiny_gltf.h>

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ricci/io.h"
#include "support.h"

namespace {

using ricci::FileFormat;
using ricci::Status;
using ricci_test::run_cli;
using ricci_test::TempDir;
namespace fs = std::filesystem;
using Json = nlohmann::json;

Json read_json(const fs::path& p) {
  return Json::parse(ricci_test::read_bytes(p));
}

/// Checks a .glb with Python's standard library only: the container (magic, version, length,
/// JSON and BIN chunks), every accessor inside its buffer view and the buffer, POSITION's min/max
/// against the data, indices below the vertex count, TEXCOORD_0 finite, the image a PNG.
constexpr const char* kGlbCheck = R"(
import json, struct, sys, math
data = open(sys.argv[1], 'rb').read()
magic, version, length = struct.unpack_from('<4sII', data, 0)
assert magic == b'glTF' and version == 2 and length == len(data), 'header'
jlen, jtype = struct.unpack_from('<II', data, 12)
assert jtype == 0x4E4F534A, 'json chunk'
doc = json.loads(data[20:20 + jlen])
off = 20 + jlen
blen, btype = struct.unpack_from('<II', data, off)
assert btype == 0x004E4942, 'bin chunk'
bin = data[off + 8: off + 8 + blen]
assert doc['asset']['version'] == '2.0'
assert doc['buffers'][0]['byteLength'] <= blen
sizes = {5126: 4, 5125: 4, 5123: 2, 5121: 1}
comps = {'SCALAR': 1, 'VEC2': 2, 'VEC3': 3}
def read(acc):
    a = doc['accessors'][acc]; v = doc['bufferViews'][a['bufferView']]
    n = a['count'] * comps[a['type']]; w = sizes[a['componentType']]
    start = v.get('byteOffset', 0) + a.get('byteOffset', 0)
    assert start + n * w <= v.get('byteOffset', 0) + v['byteLength'] <= doc['buffers'][0]['byteLength'], 'bounds'
    fmt = {5126: 'f', 5125: 'I', 5123: 'H', 5121: 'B'}[a['componentType']]
    return a, struct.unpack_from('<%d%s' % (n, fmt), bin, start)
prim = doc['meshes'][0]['primitives'][0]
pa, pos = read(prim['attributes']['POSITION'])
for i in range(3):
    col = pos[i::3]
    assert abs(min(col) - pa['min'][i]) == 0 and abs(max(col) - pa['max'][i]) == 0, 'min/max'
ta, uv = read(prim['attributes']['TEXCOORD_0'])
assert ta['count'] == pa['count'] and all(math.isfinite(x) for x in uv), 'uv'
ia, idx = read(prim['indices'])
assert len(idx) % 3 == 0 and max(idx) < pa['count'], 'indices'
tex = doc['materials'][prim['material']]['pbrMetallicRoughness']['baseColorTexture']['index']
img = doc['images'][doc['textures'][tex]['source']]
v = doc['bufferViews'][img['bufferView']]
assert img['mimeType'] == 'image/png' and bin[v.get('byteOffset', 0):v.get('byteOffset', 0) + 8] == b'\x89PNG\r\n\x1a\n', 'png'
print(pa['count'], len(idx) // 3)
)";

/// Loads a .glb with tinygltf (images not decoded) and returns its triangle count, -1 on failure.
long long tinygltf_triangles(const fs::path& p, std::string& err) {
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                           void*) { return true; },
                        nullptr);
  std::string warn;
  if (!loader.LoadBinaryFromFile(&model, &err, &warn, p.string())) return -1;
  if (model.meshes.size() != 1 || model.meshes[0].primitives.size() != 1) return -1;
  const tinygltf::Primitive& prim = model.meshes[0].primitives[0];
  if (prim.attributes.count("TEXCOORD_0") == 0 || prim.indices < 0) return -1;
  return static_cast<long long>(model.accessors[static_cast<std::size_t>(prim.indices)].count / 3);
}

}  // namespace

TEST_CASE("cli formats: mesh.glb passes two independent readers") {
  TempDir dir;
  const std::string torus = (ricci_test::fixtures_dir() / "torus.obj").string();
  REQUIRE(run_cli({"uniformize", torus, "-o", (dir / "t").string(), "-q", "--no-pictures"}).exit_code == 0);
  REQUIRE(run_cli({"uniformize", (ricci_test::fixtures_dir() / "icosphere.obj").string(), "-o", (dir / "s").string(),
                   "-q", "--no-pictures"})
              .exit_code == 0);
  for (const char* sub : {"t", "s"}) {
    const fs::path glb = dir / sub / "mesh.glb";
    REQUIRE(fs::exists(glb));
    std::string err;
    const long long triangles = tinygltf_triangles(glb, err);
    const ricci::ReadResult obj = ricci::read_mesh((dir / sub / "mesh.obj").string());
    REQUIRE(obj.status == Status::Ok);
    CHECK_MESSAGE(triangles == obj.mesh.num_faces(), err);
    ricci_test::write_bytes(dir / "check.py", kGlbCheck);
    const auto py = ricci_test::run_program("/usr/bin/python3", {(dir / "check.py").string(), glb.string()});
    CHECK_MESSAGE(py.exit_code == 0, py.err);
    CHECK(py.out.find(std::to_string(obj.mesh.num_faces())) != std::string::npos);
  }
}

TEST_CASE("cli formats: STL and FreeSurfer inputs map as their OBJ does and write the family's files") {
  TempDir dir;
  const std::string torus = (ricci_test::fixtures_dir() / "torus.obj").string();
  const std::string sphere = (ricci_test::fixtures_dir() / "icosphere.obj").string();
  // OBJ → STL (binary and ascii) and FreeSurfer; the fixtures' coordinates are rounded to float
  // there, so the reference runs on the converted OBJ of the same floats.
  for (const auto& [source, name, format] : {std::tuple{torus, "t.stl", "stl"}, std::tuple{torus, "ta.stl", "stl-ascii"},
                                              std::tuple{sphere, "lh.white", "freesurfer"}}) {
    const auto c = run_cli({"convert", source, "-o", (dir / name).string(), "--format", format, "-q"});
    REQUIRE_MESSAGE(c.exit_code == 0, c.err);
    const std::string back = (dir / (std::string(name) + ".obj")).string();
    REQUIRE(run_cli({"convert", (dir / name).string(), "-o", back, "-q"}).exit_code == 0);
    REQUIRE(run_cli({"uniformize", (dir / name).string(), "-o", (dir / (std::string(name) + ".out")).string(), "-q",
                     "--no-pictures"})
                .exit_code == 0);
    REQUIRE(run_cli({"uniformize", back, "-o", (dir / (std::string(name) + ".ref")).string(), "-q", "--no-pictures"})
                .exit_code == 0);
    const Json a = read_json(dir / (std::string(name) + ".out") / "report.json");
    const Json b = read_json(dir / (std::string(name) + ".ref") / "report.json");
    CHECK(a["angle_distortion"]["mean"] == b["angle_distortion"]["mean"]);
    CHECK(a["mesh"] == b["mesh"]);
    CHECK(ricci_test::read_bytes(dir / (std::string(name) + ".out") / "mesh.obj").size() ==
          ricci_test::read_bytes(dir / (std::string(name) + ".ref") / "mesh.obj").size());
  }
  // FreeSurfer family: lh.sphere of radius 100 and four curv overlays over the file's vertices.
  const fs::path out = dir / "lh.white.out";
  const ricci::ReadResult lh = ricci::read_mesh((out / "lh.sphere").string());
  REQUIRE_MESSAGE(lh.status == Status::Ok, lh.message);
  CHECK(lh.format == FileFormat::FreeSurfer);
  const ricci::ReadResult white = ricci::read_mesh((dir / "lh.white").string());
  CHECK(lh.mesh.faces == white.mesh.faces);
  for (std::size_t v = 0; v < lh.mesh.positions.size() / 3; ++v) {
    const double* p = &lh.mesh.positions[3 * v];
    CHECK(std::abs(std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 100) < 1e-4);
  }
  double k_sum = 0;
  for (const char* overlay : {"K", "u", "area_distortion", "angle_distortion"}) {
    const ricci::OverlayReadResult o = ricci::read_overlay((out / (std::string("lh.") + overlay)).string());
    REQUIRE_MESSAGE(o.status == Status::Ok, o.message);
    REQUIRE(o.arrays.size() == 1);
    CHECK(o.arrays[0].size() == white.mesh.positions.size() / 3);
    CHECK(o.num_faces == white.mesh.num_faces());
    if (std::string(overlay) == "K")
      for (const double k : o.arrays[0]) k_sum += k;
  }
  CHECK(std::abs(k_sum - 4 * M_PI) < 1e-4);  // Gauss–Bonnet of the input (float32 values)
  // STL: no family files besides mesh.glb.
  CHECK(fs::exists(dir / "t.stl.out" / "mesh.glb"));
  CHECK(!fs::exists(dir / "t.stl.out" / "sphere.surf.gii"));
}

TEST_CASE("cli formats: convert handles every pair of formats and info reports their details") {
  TempDir dir;
  const std::string src = (ricci_test::fixtures_dir() / "icosphere.obj").string();
  const std::vector<std::pair<std::string, std::string>> formats = {
      {"a.obj", "obj"},       {"a.off", "off"},  {"a.ply", "ply"},       {"b.ply", "ply-ascii"},
      {"a.stl", "stl"},       {"b.stl", "stl-ascii"}, {"a.gii", "gifti"}, {"lh.a", "freesurfer"}};
  // A float copy of the fixture, so that every format holds it exactly.
  REQUIRE(run_cli({"convert", src, "-o", (dir / "f.stl").string(), "-q"}).exit_code == 0);
  REQUIRE(run_cli({"convert", (dir / "f.stl").string(), "-o", (dir / "f.obj").string(), "-q"}).exit_code == 0);
  const ricci::ReadResult ref = ricci::read_mesh((dir / "f.obj").string());
  REQUIRE(ref.status == Status::Ok);
  for (const auto& [from, from_format] : formats) {
    const std::string in = (dir / ("from-" + from)).string();
    REQUIRE(run_cli({"convert", (dir / "f.obj").string(), "-o", in, "--format", from_format, "-q"}).exit_code == 0);
    for (const auto& [to, to_format] : formats) {
      const std::string target = (dir / ("to-" + to)).string();
      const auto c = run_cli({"convert", in, "-o", target, "--format", to_format, "-q"});
      const std::string label = from_format + " -> " + to_format;
      REQUIRE_MESSAGE(c.exit_code == 0, (label + ": " + c.err));
      const ricci::ReadResult r = ricci::read_mesh(target);
      REQUIRE_MESSAGE(r.status == Status::Ok, r.message);
      CHECK_MESSAGE(r.mesh.faces == ref.mesh.faces, label);
      CHECK_MESSAGE(r.mesh.positions == ref.mesh.positions, label);
    }
  }
  const auto info = run_cli({"info", (dir / "from-a.stl").string(), "--json"});
  REQUIRE(info.exit_code == 0);
  const Json j = Json::parse(info.out);
  CHECK(j["format"] == "stl-binary");
  CHECK(j["welded_vertices"].get<long long>() == 3 * ref.mesh.num_faces() - ref.mesh.num_vertices());
  CHECK(j["format_details"].get<std::string>().find("binary STL") == 0);
  const auto gii = run_cli({"info", (dir / "from-a.gii").string()});
  CHECK(gii.out.find("format details:") != std::string::npos);
  CHECK(gii.out.find("GZipBase64Binary") != std::string::npos);
}

TEST_CASE("cli formats: --weld-tolerance is validated and used") {
  TempDir dir;
  REQUIRE(run_cli({"convert", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o", (dir / "t.stl").string(), "-q"})
              .exit_code == 0);
  CHECK(run_cli({"info", (dir / "t.stl").string(), "--weld-tolerance", "-1"}).exit_code == 2);
  const auto a = run_cli({"info", (dir / "t.stl").string(), "--weld-tolerance", "1e-9", "--json"});
  REQUIRE(a.exit_code == 0);
  CHECK(Json::parse(a.out)["genus"] == 1);
  // A tolerance larger than the edges welds the torus into something invalid: named, exit 5.
  const auto b = run_cli({"info", (dir / "t.stl").string(), "--weld-tolerance", "10"});
  CHECK(b.exit_code == 5);
  CHECK(b.err.find("t.stl") != std::string::npos);
}

TEST_CASE("cli formats: the shared brain maps to the same sphere from GIFTI, FreeSurfer and OFF") {
  const fs::path shared = ricci_test::shared_meshes_dir();
  const fs::path off = shared / "genus0" / "brain-conte69-32k-lh.off";
  if (shared.empty() || !fs::exists(off)) {
    MESSAGE("../shared/meshes absent: skipped");
    return;
  }
  // Three maps of 65k faces, run in Release; the sanitizer build fuzzes these three readers.
  if (ricci_test::kSanitized) {
    MESSAGE("sanitizer build: skipped (run in Release)");
    return;
  }
  TempDir dir;
  const std::string gii = (dir / "lh.surf.gii").string();
  REQUIRE(run_cli({"convert", off.string(), "-o", gii, "-q"}).exit_code == 0);
  REQUIRE(run_cli({"convert", gii, "-o", (dir / "lh.white").string(), "--format", "freesurfer", "-q"}).exit_code == 0);
  const std::vector<std::string> args = {"-q", "--no-pictures", "--seed-checks", "0"};
  auto uniformize = [&](const std::string& in, const std::string& out) {
    std::vector<std::string> a = {"uniformize", in, "-o", (dir / out).string()};
    a.insert(a.end(), args.begin(), args.end());
    const auto r = run_cli(a);
    REQUIRE_MESSAGE(r.exit_code == 0, r.err);
    return read_json(dir / out / "report.json");
  };
  const Json from_off = uniformize(off.string(), "off");
  const Json from_gii = uniformize(gii, "gii");
  const Json from_fs = uniformize((dir / "lh.white").string(), "fs");
  // GIFTI and FreeSurfer hold the same float32 coordinates: the same map, bit for bit.
  CHECK(ricci_test::read_bytes(dir / "gii" / "sphere.obj") == ricci_test::read_bytes(dir / "fs" / "sphere.obj"));
  CHECK(from_gii["angle_distortion"] == from_fs["angle_distortion"]);
  // The OFF's coordinates are those floats printed to 9 digits (4.9e-7 apart): the same map to
  // that order.
  CHECK(from_off["mesh"] == from_gii["mesh"]);
  CHECK(std::abs(from_off["angle_distortion"]["mean"].get<double>() - from_gii["angle_distortion"]["mean"].get<double>()) < 1e-6);
  const ricci::ReadResult a = ricci::read_mesh((dir / "off" / "sphere.obj").string());
  const ricci::ReadResult b = ricci::read_mesh((dir / "gii" / "sphere.obj").string());
  REQUIRE(a.mesh.positions.size() == b.mesh.positions.size());
  double worst = 0;
  for (std::size_t i = 0; i < a.mesh.positions.size(); ++i) worst = std::max(worst, std::abs(a.mesh.positions[i] - b.mesh.positions[i]));
  CHECK(worst < 1e-4);
  MESSAGE("sphere positions from OFF and GIFTI differ by at most " << worst);
  // The family's files: sphere.surf.gii over the file's vertices, radius 100, and the overlays.
  const ricci::ReadResult sphere = ricci::read_mesh((dir / "gii" / "sphere.surf.gii").string());
  REQUIRE_MESSAGE(sphere.status == Status::Ok, sphere.message);
  CHECK(sphere.mesh.num_vertices() == 32492);
  CHECK(sphere.mesh.num_faces() == 64980);
  for (const char* overlay : {"K", "u", "area_distortion", "angle_distortion"}) {
    const ricci::OverlayReadResult o = ricci::read_overlay((dir / "gii" / (std::string(overlay) + ".func.gii")).string());
    REQUIRE_MESSAGE(o.status == Status::Ok, o.message);
    CHECK(o.arrays.at(0).size() == 32492);
    CHECK(o.names.at(0) == overlay);
  }
}

TEST_CASE("cli signature: torus and genus 2 give their numbers, other topologies a named refusal") {
  TempDir dir;
  const auto t = run_cli({"signature", (ricci_test::fixtures_dir() / "torus.obj").string(), "--json", "-q", "-o",
                          (dir / "sig.json").string()});
  REQUIRE_MESSAGE(t.exit_code == 0, t.err);
  const Json j = Json::parse(t.out);
  CHECK(j["status"] == "ok");
  CHECK(j["genus"] == 1);
  CHECK(j["torus"]["tau"][1].get<double>() >= std::sqrt(3.0) / 2);
  CHECK(std::abs(j["torus"]["tau"][0].get<double>()) <= 0.5);
  CHECK(read_json(dir / "sig.json")["torus"] == j["torus"]);
  const auto g = run_cli({"signature", "-q"});  // the embedded genus-2 mesh
  REQUIRE_MESSAGE(g.exit_code == 0, g.err);
  CHECK(g.out.find("systole:") != std::string::npos);
  CHECK(g.out.find("length a1 ") != std::string::npos);
  const auto d = run_cli({"signature", (ricci_test::fixtures_dir() / "disk.obj").string(), "-q"});
  CHECK(d.exit_code != 0);
  CHECK(d.err.find("disk.obj") != std::string::npos);
  CHECK(d.err.find("no signature for this surface") != std::string::npos);
  // ricci uniformize writes the same signature into report.json and signature.json.
  REQUIRE(run_cli({"uniformize", (ricci_test::fixtures_dir() / "torus.obj").string(), "-o", (dir / "u").string(), "-q",
                   "--no-pictures"})
              .exit_code == 0);
  CHECK(read_json(dir / "u" / "report.json")["signature"]["torus"]["tau"].is_array());
  CHECK(fs::exists(dir / "u" / "signature.json"));
  // A genus-0 surface with three loops: its circle domain.
  const auto c = run_cli({"signature", (ricci_test::fixtures_dir() / "sphere-3holes.obj").string(), "--json", "-q"});
  REQUIRE_MESSAGE(c.exit_code == 0, c.err);
  const Json cj = Json::parse(c.out);
  REQUIRE(cj["circle_domain"]["circles"].size() == 3);
  CHECK(cj["circle_domain"]["circles"][0]["radius"] == 1.0);
  CHECK(cj["circle_domain"]["separation"].size() == 3);
  CHECK(cj["boundary_loops"] == 3);
}

TEST_CASE("cli compare: meshes and signature files, same kinds only, malformed files named") {
  TempDir dir;
  const std::string torus = (ricci_test::fixtures_dir() / "torus.obj").string();
  REQUIRE(run_cli({"signature", torus, "-q", "-o", (dir / "t.json").string()}).exit_code == 0);
  // A mesh against its own signature file: distance 0.
  const auto same = run_cli({"compare", torus, (dir / "t.json").string(), "--json", "-q"});
  REQUIRE_MESSAGE(same.exit_code == 0, same.err);
  const Json j = Json::parse(same.out);
  CHECK(j["kind"] == "modular");
  CHECK(j["distance"].get<double>() <= 1e-12);
  // Genus 2 against itself: the length spectrum and the marked distance.
  REQUIRE(run_cli({"signature", "-q", "-o", (dir / "g.json").string()}).exit_code == 0);
  const auto g = run_cli({"compare", (dir / "g.json").string(), (dir / "g.json").string(), "--json"});
  REQUIRE_MESSAGE(g.exit_code == 0, g.err);
  const Json gj = Json::parse(g.out);
  CHECK(gj["kind"] == "length_spectrum");
  CHECK(gj["distance"] == 0.0);
  CHECK(gj["marked_distance"].get<double>() <= 1e-12);
  const auto text = run_cli({"compare", (dir / "g.json").string(), (dir / "g.json").string()});
  CHECK(text.out.find("marked:") != std::string::npos);
  // Several: ranked by distance to the first, nearest first (the torus itself, then a bumpier one).
  const std::string bumpy = (dir / "bumpy.obj").string();
  {
    ricci::ReadResult m = ricci::read_mesh(torus);
    REQUIRE(m.status == ricci::Status::Ok);
    for (std::size_t k = 0; k + 2 < m.mesh.positions.size(); k += 3) m.mesh.positions[k + 2] *= 1.7;
    REQUIRE(ricci::write_mesh(bumpy, m.mesh).status == ricci::Status::Ok);
  }
  const auto ranked = run_cli({"compare", torus, bumpy, (dir / "t.json").string(), "--json", "-q"});
  REQUIRE_MESSAGE(ranked.exit_code == 0, ranked.err);
  const Json rj = Json::parse(ranked.out);
  REQUIRE(rj["ranking"].size() == 2);
  CHECK(rj["ranking"][0]["second"] == (dir / "t.json").string());
  CHECK(rj["ranking"][1]["second"] == bumpy);
  CHECK(rj["ranking"][1]["distance"].get<double>() > 1e-3);
  const auto ranked_text = run_cli({"compare", torus, bumpy, (dir / "t.json").string(), "-q"});
  CHECK(ranked_text.out.find("  1  ") != std::string::npos);
  // Different kinds: refused naming both, exit 2 (invalid argument).
  const auto mixed = run_cli({"compare", (dir / "t.json").string(), (dir / "g.json").string()});
  CHECK(mixed.exit_code != 0);
  CHECK(mixed.err.find("not of the same kind") != std::string::npos);
  CHECK(mixed.err.find("t.json") != std::string::npos);
  // A malformed or foreign JSON file: named, non-zero, no crash.
  for (const char* bad : {"{", "[1, 2]", "{\"status\": \"ok\", \"genus\": 1, \"torus\": {\"tau\": [0, -1], \"uncertainty\": 0}}",
                          "{\"status\": \"ok\"}", "{\"status\": \"ok\", \"genus\": 1e300}",
                          "{\"status\": \"ok\", \"genus\": 0, \"boundary_loops\": 2, \"circle_domain\": {\"circles\": [1, 2]}}"}) {
    std::ofstream(dir / "bad.json") << bad;
    const auto r = run_cli({"compare", (dir / "bad.json").string(), (dir / "t.json").string()});
    CHECK(r.exit_code != 0);
    CHECK_MESSAGE(r.err.find("bad.json") != std::string::npos, r.err);
  }
  const auto missing = run_cli({"compare", (dir / "none.json").string(), (dir / "t.json").string()});
  CHECK(missing.exit_code != 0);
  CHECK(missing.err.find("none.json") != std::string::npos);
}
