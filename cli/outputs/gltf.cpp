// ricci command-line tool — binary glTF output (see gltf.h).
#include "gltf.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <vector>

#include "pictures.h"

namespace ricci_cli {

namespace {

using ricci::Index;

/// The mesh split at its seams: one output vertex per distinct (vertex, texture coordinate).
struct SplitMesh {
  std::vector<float> positions, normals, uv;
  std::vector<std::uint32_t> indices;
};

/// Area-weighted vertex normals of the input (unit length; +z where they vanish).
std::vector<double> vertex_normals(std::span<const double> x, std::span<const Index> faces) {
  std::vector<double> n(x.size(), 0.0);
  for (std::size_t f = 0; f < faces.size() / 3; ++f) {
    const double* a = &x[3 * static_cast<std::size_t>(faces[3 * f])];
    const double* b = &x[3 * static_cast<std::size_t>(faces[3 * f + 1])];
    const double* c = &x[3 * static_cast<std::size_t>(faces[3 * f + 2])];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double w[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 3; ++i) n[3 * static_cast<std::size_t>(faces[3 * f + k]) + i] += w[i];
  }
  for (std::size_t v = 0; v < n.size() / 3; ++v) {
    double* p = &n[3 * v];
    const double s = std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2])});
    if (!(s > 0) || !std::isfinite(s)) {
      p[0] = p[1] = 0;
      p[2] = 1;
      continue;
    }
    const double q[3] = {p[0] / s, p[1] / s, p[2] / s};
    const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    for (int i = 0; i < 3; ++i) p[i] = q[i] / len;
  }
  return n;
}

SplitMesh split_at_seams(std::span<const double> x, std::span<const Index> faces, std::span<const double> uv,
                         double repeats) {
  // Texture coordinates scaled to `repeats` texture periods across the longer side.
  double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
  for (std::size_t c = 0; c < faces.size(); ++c)
    for (int i = 0; i < 2; ++i) {
      lo[i] = std::min(lo[i], uv[2 * c + i]);
      hi[i] = std::max(hi[i], uv[2 * c + i]);
    }
  const double extent = std::max(hi[0] - lo[0], hi[1] - lo[1]);
  const double scale = extent > 0 ? repeats / extent : 1.0;
  const std::vector<double> normals = vertex_normals(x, faces);
  SplitMesh out;
  std::vector<std::vector<std::uint32_t>> copies(x.size() / 3);  // output vertices of each input vertex
  out.indices.reserve(faces.size());
  for (std::size_t c = 0; c < faces.size(); ++c) {
    const auto v = static_cast<std::size_t>(faces[c]);
    const float s = static_cast<float>((uv[2 * c] - lo[0]) * scale);
    const float t = static_cast<float>((uv[2 * c + 1] - lo[1]) * scale);
    std::uint32_t found = std::numeric_limits<std::uint32_t>::max();
    for (const std::uint32_t w : copies[v]) {
      if (out.uv[2 * w] == s && out.uv[2 * w + 1] == t) {
        found = w;
        break;
      }
    }
    if (found == std::numeric_limits<std::uint32_t>::max()) {
      found = static_cast<std::uint32_t>(out.positions.size() / 3);
      copies[v].push_back(found);
      for (int i = 0; i < 3; ++i) {
        out.positions.push_back(static_cast<float>(x[3 * v + i]));
        out.normals.push_back(static_cast<float>(normals[3 * v + i]));
      }
      out.uv.push_back(s);
      out.uv.push_back(t);
    }
    out.indices.push_back(found);
  }
  return out;
}

/// Appends `data` to the buffer (4-byte aligned) and adds a buffer view of it; returns its index.
template <class T>
int add_view(tinygltf::Model& m, const std::vector<T>& data, int target) {
  std::vector<unsigned char>& buf = m.buffers[0].data;
  while (buf.size() % 4 != 0) buf.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buf.size();
  view.byteLength = data.size() * sizeof(T);
  view.target = target;
  const auto* p = reinterpret_cast<const unsigned char*>(data.data());
  buf.insert(buf.end(), p, p + view.byteLength);
  m.bufferViews.push_back(view);
  return static_cast<int>(m.bufferViews.size() - 1);
}

int add_accessor(tinygltf::Model& m, int view, int component, int type, std::size_t count) {
  tinygltf::Accessor a;
  a.bufferView = view;
  a.componentType = component;
  a.type = type;
  a.count = count;
  m.accessors.push_back(a);
  return static_cast<int>(m.accessors.size() - 1);
}

}  // namespace

GlbResult textured_glb(std::span<const double> positions, std::span<const Index> faces,
                       std::span<const double> corner_uv, const std::string& png, double repeats) {
  GlbResult r;
  if (corner_uv.size() != 2 * faces.size() || faces.empty() || png.empty()) {
    r.message = "no texture coordinates for the faces";
    return r;
  }
  constexpr double kMax = std::numeric_limits<float>::max();
  for (const double v : positions) {
    if (!(std::abs(v) <= kMax)) {
      r.message = "a coordinate is beyond single precision, which glTF stores";
      return r;
    }
  }
  for (const double v : corner_uv) {
    if (!std::isfinite(v)) {
      r.message = "a texture coordinate is not finite";
      return r;
    }
  }
  const SplitMesh s = split_at_seams(positions, faces, corner_uv, repeats);
  tinygltf::Model m;
  m.asset.version = "2.0";
  m.asset.generator = "ricci";
  m.buffers.resize(1);
  const int vp = add_view(m, s.positions, TINYGLTF_TARGET_ARRAY_BUFFER);
  const int vn = add_view(m, s.normals, TINYGLTF_TARGET_ARRAY_BUFFER);
  const int vt = add_view(m, s.uv, TINYGLTF_TARGET_ARRAY_BUFFER);
  const int vi = add_view(m, s.indices, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  const std::vector<unsigned char> image(png.begin(), png.end());
  const int vimg = add_view(m, image, 0);
  m.bufferViews[static_cast<std::size_t>(vimg)].target = 0;
  const std::size_t nv = s.positions.size() / 3;
  const int ap = add_accessor(m, vp, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  std::vector<double> mn(3, INFINITY), mx(3, -INFINITY);
  for (std::size_t v = 0; v < nv; ++v)
    for (std::size_t i = 0; i < 3; ++i) {
      mn[i] = std::min<double>(mn[i], s.positions[3 * v + i]);
      mx[i] = std::max<double>(mx[i], s.positions[3 * v + i]);
    }
  m.accessors[static_cast<std::size_t>(ap)].minValues = mn;
  m.accessors[static_cast<std::size_t>(ap)].maxValues = mx;
  const int an = add_accessor(m, vn, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  const int at = add_accessor(m, vt, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
  const int ai = add_accessor(m, vi, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, s.indices.size());

  tinygltf::Image img;
  img.bufferView = vimg;
  img.mimeType = "image/png";
  m.images.push_back(img);
  tinygltf::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_NEAREST;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
  sampler.wrapS = TINYGLTF_TEXTURE_WRAP_REPEAT;
  sampler.wrapT = TINYGLTF_TEXTURE_WRAP_REPEAT;
  m.samplers.push_back(sampler);
  tinygltf::Texture tex;
  tex.source = 0;
  tex.sampler = 0;
  m.textures.push_back(tex);
  tinygltf::Material mat;
  mat.name = "checkerboard";
  mat.doubleSided = true;
  mat.pbrMetallicRoughness.baseColorTexture.index = 0;
  mat.pbrMetallicRoughness.metallicFactor = 0.0;
  mat.pbrMetallicRoughness.roughnessFactor = 1.0;
  m.materials.push_back(mat);

  tinygltf::Primitive prim;
  prim.attributes["POSITION"] = ap;
  prim.attributes["NORMAL"] = an;
  prim.attributes["TEXCOORD_0"] = at;
  prim.indices = ai;
  prim.material = 0;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  tinygltf::Mesh mesh;
  mesh.name = "surface";
  mesh.primitives.push_back(prim);
  m.meshes.push_back(mesh);
  tinygltf::Node node;
  node.mesh = 0;
  m.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  m.scenes.push_back(scene);
  m.defaultScene = 0;

  std::ostringstream os;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&m, os, false, true)) {
    r.message = "tinygltf could not write the scene";
    return r;
  }
  r.bytes = os.str();
  r.vertices = static_cast<std::int64_t>(nv);
  return r;
}

std::string checker_texture_png(int pixels) {
  const CheckerOptions colours;
  Image img;
  img.width = img.height = pixels;
  img.pixels.resize(static_cast<std::size_t>(pixels) * static_cast<std::size_t>(pixels));
  for (int y = 0; y < pixels; ++y)
    for (int x = 0; x < pixels; ++x) {
      const bool odd = ((2 * x / pixels) + (2 * y / pixels)) % 2 == 1;
      img.pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(pixels) + static_cast<std::size_t>(x)] =
          odd ? colours.dark : colours.light;
    }
  return encode_png(img);
}

}  // namespace ricci_cli
