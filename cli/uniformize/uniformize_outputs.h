// ricci command-line driver — the outputs of `ricci uniformize` for other tools: the textured
// mesh.glb for graphics viewers, and, when the input was a GIFTI or FreeSurfer surface, the map in
// that family's formats with per-vertex overlays for neuroimaging viewers (Connectome Workbench,
// freeview).
//
// Takes the validated mesh (with its map to the file's vertices), the result, and the surface
// written as mesh.obj; gives named files. Overlays are per vertex of the input file, in its
// order (vertices validation dropped get 0):
//   K                 the input's discrete Gaussian curvature: 2π (π on the boundary) minus the
//                     vertex's corner angles in 3D
//   u                 the flow's u (the scheme's log conformal factor)
//   area_distortion   log of the vertex's share of the layout's area over its share of the
//                     input's area (a third of each incident face; flat triangles of the layout
//                     as drawn: plane, Poincaré disk or unit sphere); 0 = area kept
//   angle_distortion  mean |log θ_input/θ_metric| over the vertex's corners (report.json's
//                     angle_distortion per vertex)
// GIFTI input: sphere.surf.gii (sphere of radius 100, as FreeSurfer's and Workbench's) or
// layout.surf.gii (plane or disk at z = 0, vertices split at the cut), and K.func.gii, u.func.gii,
// area_distortion.func.gii, angle_distortion.func.gii. FreeSurfer input lh.white (any name
// "HEMI.SURF"): lh.sphere (radius 100) or lh.layout, and lh.K, lh.u, lh.area_distortion,
// lh.angle_distortion as curv files.
#pragma once

#include <span>
#include <string>
#include <utility>
#include <vector>

#include "ricci/io.h"
#include "ricci/mesh.h"
#include "ricci/topology.h"
#include "ricci/uniformize.h"

namespace ricci_cli {

/// Per-vertex overlays in the input file's vertex order.
struct VertexOverlays {
  std::vector<double> K, u, area_distortion, angle_distortion;
};

/// `mesh`: the validated mesh; `vertex_to_input`: its vertices' indices in the file (empty when
/// they are the file's); `file_vertices`: the file's vertex count; `surface`/`uv`: the mesh as
/// written (input faces) and its per-corner texture coordinates (E, H) — for the sphere,
/// `sphere` holds the unit-sphere position of every vertex of `mesh`.
VertexOverlays vertex_overlays(const ricci::Mesh& mesh, const ricci::Topology& topology,
                               std::span<const ricci::Index> vertex_to_input,
                               ricci::Index file_vertices, const ricci::UniformizeResult& r,
                               const ricci::Mesh& surface, std::span<const double> uv, std::span<const double> sphere);

/// The files of the input's family (none for other formats): (name, bytes) pairs. `input_path`
/// names the FreeSurfer prefix; `layout` is the sphere (radius 100, file order) when `sphere`,
/// else the layout at z = 0. An empty bytes string means a serialisation failure.
std::vector<std::pair<std::string, std::string>> family_files(ricci::FileFormat input_format, const std::string& input_path,
                                                              const VertexOverlays& overlays, ricci::Index file_faces,
                                                              const ricci::Mesh& layout, bool sphere);

}  // namespace ricci_cli
