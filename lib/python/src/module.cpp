// ricci Python module, compiled part (ricci._ricci; the package's public functions are in
// lib/python/ricci/__init__.py, which documents them).
//
// flow() and uniformize() run the command-line tool's own drivers (cli/flow/flow_run.h,
// cli/uniformize/uniformize_run.h) with nothing printed, so a result here has exactly the numbers, notes and
// report of `ricci flow` / `ricci uniformize` on the same mesh and options, and write() writes the
// same OUTDIR. The GIL is released while the library works; a progress callback is called with the
// GIL held after every flow iteration and pipeline stage.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <complex>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "convert.h"
#include "flow_run.h"
#include "ricci/signature.h"
#include "ricci/status.h"
#include "ricci/topology.h"
#include "uniformize_run.h"

namespace py = pybind11;
using namespace pybind11::literals;
using ricci::Status;

namespace ricci_python {
namespace {

/// Forwards progress to a Python callable (GIL taken per call). The first exception it raises is
/// kept, no further call is made, and rethrow() raises it once the run returned.
class Progress {
 public:
  explicit Progress(py::object fn) : fn_(std::move(fn)) {}
  void operator()(py::dict (*make)(const void*), const void* record) {
    if (failed_ || fn_.is_none()) return;
    py::gil_scoped_acquire gil;
    try {
      fn_(make(record));
    } catch (py::error_already_set& e) {
      failed_ = true;
      type_ = e.type();
      value_ = e.value();
      trace_ = e.trace();
    }
  }
  /// With the GIL held.
  void rethrow() {
    if (!failed_) return;
    failed_ = false;
    PyErr_Restore(type_.release().ptr(), value_.release().ptr(), trace_.release().ptr());
    throw py::error_already_set();
  }

 private:
  py::object fn_;
  bool failed_ = false;
  py::object type_, value_, trace_;
};

py::dict iteration_event(const void* p) {
  const auto& r = *static_cast<const ricci::IterationRecord*>(p);
  return py::dict("kind"_a = "iteration", "iteration"_a = r.iteration, "max_error"_a = r.max_error,
                  "energy"_a = r.energy, "step"_a = r.step, "seconds"_a = r.seconds);
}
py::dict stage_event(const void* p) {
  const auto& r = *static_cast<const ricci::StageRecord*>(p);
  return py::dict("kind"_a = "stage", "stage"_a = std::string(r.stage), "seconds"_a = r.seconds,
                  "summary"_a = r.summary);
}

std::string status_text(Status s) { return std::string(ricci::status_name(s)); }

py::list repairs_list(const std::vector<ricci::Repair>& repairs) {
  py::list out;
  for (const ricci::Repair& r : repairs)
    out.append(py::dict("kind"_a = std::string(ricci::repair_name(r.kind)), "count"_a = r.count, "message"_a = r.message));
  return out;
}

// ---- read_mesh, info ---------------------------------------------------------------------------

py::tuple read_mesh_py(const std::string& path, bool largest_component) {
  ricci::ValidateOptions vo;
  vo.keep_largest_component = largest_component;
  ricci::LoadResult r;
  {
    py::gil_scoped_release nogil;
    r = ricci_cli::load_input(path, vo);
  }
  if (r.read.status != Status::Ok) raise_error("RicciError", status_text(r.read.status), r.read.message, "read");
  py::dict meta("format"_a = ricci::format_name(r.read.format), "message"_a = r.read.message,
                "polygons_triangulated"_a = r.read.polygons_triangulated, "status"_a = status_text(r.status),
                "validation"_a = r.message);
  return py::make_tuple(owned(std::move(r.read.mesh.positions), 3), owned(std::move(r.read.mesh.faces), 3), meta);
}

py::dict info_py(const py::handle& V, const py::handle& F, const std::string& name, bool largest_component) {
  const ricci::ReadResult read = read_arrays(V, F, name);
  ricci::ValidateOptions vo;
  vo.keep_largest_component = largest_component;
  ricci::LoadResult r;
  {
    py::gil_scoped_release nogil;
    r = ricci::validate_read(read, name, vo);
  }
  if (r.status != Status::Ok) raise_error("RicciError", status_text(r.status), r.message, "validate");
  const ricci::Topology& t = r.validated.topology;
  return py::dict("vertices"_a = t.num_vertices, "edges"_a = t.num_edges, "faces"_a = t.num_faces,
                  "boundary_loops"_a = t.num_boundary_loops(), "euler_characteristic"_a = t.euler_characteristic(),
                  "genus"_a = t.genus(), "closed"_a = t.is_closed(),
                  "natural_geometry"_a = std::string(ricci::geometry_name(ricci::natural_geometry(t))),
                  "repairs"_a = repairs_list(r.repairs));
}

// ---- flow --------------------------------------------------------------------------------------

struct FlowJob {
  ricci_cli::FlowCommandOptions options;
  ricci::ReadResult pre;
  ricci_cli::FlowReport report;
};

std::shared_ptr<FlowJob> flow_py(const py::handle& V, const py::handle& F, const std::optional<std::string>& path,
                                 const std::string& name, const py::dict& options, py::object progress) {
  auto job = std::make_shared<FlowJob>();
  apply_flow_options(options, job->options);
  job->options.quiet = true;
  job->report.console = false;
  if (!path) {
    job->pre = read_arrays(V, F, name);
    job->report.preread = &job->pre;
    job->report.file = name;
  } else {
    job->options.mesh = *path;
  }
  Progress p(std::move(progress));
  job->report.on_iteration = [&p](const ricci::IterationRecord& r) { p(iteration_event, &r); };
  {
    py::gil_scoped_release nogil;
    ricci_cli::flow_run(job->options, job->report);
    job->report.on_iteration = nullptr;
  }
  p.rethrow();
  return job;
}

// ---- uniformize --------------------------------------------------------------------------------

struct UniformizeJob {
  ricci_cli::UniformizeCommandOptions options;
  ricci::ReadResult pre;
  ricci_cli::UniformizeRun run;
  // The surface mesh.obj holds and its per-corner layout, made on first use.
  bool have_surface = false;
  ricci::Mesh surface;
  ricci::InputSurfaceLayout through;
  std::vector<double> uv;  ///< #F(surface)×3×2
};

std::shared_ptr<UniformizeJob> uniformize_py(const py::handle& V, const py::handle& F,
                                             const std::optional<std::string>& path,
                                             const std::string& name, const py::dict& options, py::object progress) {
  auto job = std::make_shared<UniformizeJob>();
  ricci_cli::UniformizeCommandOptions& o = job->options;
  apply_uniformize_options(options, o);
  o.quiet = true;
  ricci_cli::UniformizeRun& run = job->run;
  run.console = false;
  if (!path) {
    job->pre = read_arrays(V, F, name);
    run.preread = &job->pre;
    run.file = name;
  } else {
    o.mesh = *path;
  }
  ricci_cli::uniformize_begin(o, run);
  Progress p(std::move(progress));
  {
    py::gil_scoped_release nogil;
    if (!ricci_cli::uniformize_settings(o, run)) {
      run.settings.uo.on_stage = [&p](const ricci::StageRecord& r) { p(stage_event, &r); };
      run.settings.uo.flow.on_iteration = [&p](const ricci::IterationRecord& r) { p(iteration_event, &r); };
      if (!ricci_cli::uniformize_load(o, "uniformize", run)) ricci_cli::uniformize_compute(o, run);
      run.settings.uo.on_stage = nullptr;
      run.settings.uo.flow.on_iteration = nullptr;
    }
  }
  p.rethrow();
  return job;
}

void ensure_surface(UniformizeJob& job) {
  if (job.have_surface || job.run.status != Status::Ok) return;
  {
    py::gil_scoped_release nogil;
    ricci_cli::uniformize_surface(job.options, job.run, job.surface, job.through);
  }
  job.have_surface = true;
  const ricci::Mesh& s = job.surface;
  if (s.corner_texcoords.size() != s.faces.size()) return;  // the sphere: no texture coordinates
  job.uv.resize(2 * s.faces.size());
  for (std::size_t c = 0; c < s.faces.size(); ++c) {
    const std::size_t t = static_cast<std::size_t>(s.corner_texcoords[c]);
    job.uv[2 * c] = s.texcoords[2 * t];
    job.uv[2 * c + 1] = s.texcoords[2 * t + 1];
  }
}

py::object generators(const ricci::UniformizeResult& r) {
  if (!r.has_deck || r.deck.status != Status::Ok) return py::none();
  const auto& gens = r.deck.generators;
  py::list names;
  for (const ricci::DeckGenerator& g : gens) names.append(g.name);
  const py::ssize_t k = static_cast<py::ssize_t>(gens.size());
  if (r.geometry == ricci::Geometry::Hyperbolic) {
    // SU(1,1): z ↦ (a z + b) / (b̄ z + ā).
    py::array_t<std::complex<double>> m({k, py::ssize_t{2}, py::ssize_t{2}});
    py::array_t<double> length(k);
    auto mm = m.mutable_unchecked<3>();
    auto ll = length.mutable_unchecked<1>();
    for (py::ssize_t i = 0; i < k; ++i) {
      const ricci::Moebius& g = gens[static_cast<std::size_t>(i)].map;
      mm(i, 0, 0) = g.a;
      mm(i, 0, 1) = g.b;
      mm(i, 1, 0) = std::conj(g.b);
      mm(i, 1, 1) = std::conj(g.a);
      ll(i) = gens[static_cast<std::size_t>(i)].translation_length;
    }
    return py::dict("names"_a = names, "moebius"_a = m, "translation_length"_a = length,
                    "relation_error"_a = r.deck.relation_error);
  }
  py::array_t<double> t({k, py::ssize_t{2}});
  py::array_t<double> rot(k);
  auto tt = t.mutable_unchecked<2>();
  auto rr = rot.mutable_unchecked<1>();
  for (py::ssize_t i = 0; i < k; ++i) {
    const ricci::DeckGenerator& g = gens[static_cast<std::size_t>(i)];
    tt(i, 0) = g.translation[0];
    tt(i, 1) = g.translation[1];
    rr(i) = g.rotation;
  }
  return py::dict("names"_a = names, "translation"_a = t, "rotation"_a = rot, "relation_error"_a = r.deck.relation_error);
}

py::dict cut_dict(const ricci::CutResult& c, const py::handle& owner) {
  py::list labels;
  for (const std::string& s : c.side_label) labels.append(s);
  return py::dict("word"_a = c.word, "canonical"_a = c.canonical, "compact"_a = c.compact,
                  "faces"_a = view(c.cut_faces, 3, owner), "cut_to_surface"_a = view(c.cut_to_surface, 0, owner),
                  "surface_positions"_a = view(c.surface_positions, 3, owner),
                  "surface_faces"_a = view(c.surface_faces, 3, owner),
                  "side_offsets"_a = view(c.side_offsets, 0, owner), "side_vertices"_a = view(c.side_vertices, 0, owner),
                  "side_labels"_a = labels, "base_vertex"_a = c.base_vertex);
}

py::object signature_py(UniformizeJob& job) {
  if (!job.run.have_result || job.run.result.status != Status::Ok)
    raise_error("RicciError", status_text(job.run.status), "no signature: the uniformization did not succeed", "signature");
  ricci::ConformalSignature s;
  {
    py::gil_scoped_release nogil;
    s = ricci::conformal_signature(job.run.result);
  }
  ricci_cli::signature_vertices_to_file(s, job.run.input.vertex_to_input);
  if (s.status != Status::Ok) raise_error("RicciError", status_text(s.status), s.message, "signature");
  return json_to_python(ricci_cli::signature_json(s).dump());
}

void write_py(UniformizeJob& job, const std::string& outdir, bool pictures) {
  if (job.run.status != Status::Ok || !job.run.have_result)
    raise_error("RicciError", status_text(job.run.status), "nothing to write: " + job.run.message, "outputs");
  ricci_cli::UniformizeCommandOptions o = job.options;
  o.output = outdir;
  o.no_pictures = !pictures;
  {
    py::gil_scoped_release nogil;
    if (!ricci_cli::uniformize_check_outdir(o, job.run)) ricci_cli::uniformize_write(o, "uniformize", job.run);
  }
  if (job.run.status != Status::Ok) {
    const std::string status = status_text(job.run.status), message = job.run.message;
    // The pipeline's result still stands: a later write may succeed.
    job.run.status = Status::Ok;
    job.run.message = "ok";
    raise_error("RicciError", status, message, "outputs");
  }
}

}  // namespace
}  // namespace ricci_python

using namespace ricci_python;

PYBIND11_MODULE(_ricci, m) {
  m.doc() = "ricci: discrete surface Ricci flow (compiled part; use the package ricci)";
  m.attr("__version__") = RICCI_VERSION;

  m.def("read_mesh", &read_mesh_py, "path"_a, "largest_component"_a = false);
  m.def("info", &info_py, "V"_a, "F"_a, "name"_a, "largest_component"_a = false);
  py::class_<FlowJob, std::shared_ptr<FlowJob>>(m, "FlowJob")
      .def_property_readonly("status", [](const FlowJob& j) { return status_text(j.report.status); })
      .def_property_readonly("message", [](const FlowJob& j) { return j.report.message; })
      .def_property_readonly("u", [](py::object self) {
        const auto& j = self.cast<const FlowJob&>();
        return view(j.report.flow.u, 0, self);
      })
      .def_property_readonly("K", [](py::object self) { return view(self.cast<const FlowJob&>().report.flow.K, 0, self); })
      .def_property_readonly("K_target",
                             [](py::object self) { return view(self.cast<const FlowJob&>().report.flow.K_target, 0, self); })
      .def_property_readonly("edge_lengths",
                             [](py::object self) { return view(self.cast<const FlowJob&>().report.flow.l, 0, self); })
      .def_property_readonly("edges", [](py::object self) { return view(self.cast<const FlowJob&>().report.input.topology.edge_vertices, 2, self); })
      .def_property_readonly("V", [](py::object self) {
        return view(self.cast<const FlowJob&>().report.input.mesh.positions, 3, self);
      })
      .def_property_readonly("F", [](py::object self) {
        return view(self.cast<const FlowJob&>().report.input.mesh.faces, 3, self);
      })
      .def_property_readonly("vertex_to_input", [](py::object self) {
        return view(self.cast<const FlowJob&>().report.input.vertex_to_input, 0, self);
      })
      .def_property_readonly("iterations", [](const FlowJob& j) { return j.report.flow.iterations; })
      .def_property_readonly("converged", [](const FlowJob& j) { return j.report.status == Status::Ok; })
      .def_property_readonly("have_flow", [](const FlowJob& j) { return j.report.have_flow; })
      .def_property_readonly("max_curvature_error", [](const FlowJob& j) { return j.report.flow.max_curvature_error; })
      .def_property_readonly("history", [](const FlowJob& j) {
        py::list out;
        for (const ricci::IterationRecord& h : j.report.flow.history)
          out.append(py::dict("iteration"_a = h.iteration, "max_error"_a = h.max_error, "energy"_a = h.energy,
                              "step"_a = h.step, "seconds"_a = h.seconds));
        return out;
      })
      .def_property_readonly("notes", [](const FlowJob& j) { return j.report.notes; })
      .def_property_readonly("repairs", [](const FlowJob& j) { return repairs_list(j.report.repairs); })
      .def_property_readonly("report", [](const FlowJob& j) { return json_to_python(ricci_cli::flow_json(j.report).dump()); });

  py::class_<UniformizeJob, std::shared_ptr<UniformizeJob>>(m, "UniformizeJob")
      .def_property_readonly("status", [](const UniformizeJob& j) { return status_text(j.run.status); })
      .def_property_readonly("message", [](const UniformizeJob& j) { return j.run.message; })
      .def_property_readonly("failed_stage", [](const UniformizeJob& j) {
        return j.run.have_result ? j.run.result.failed_stage : std::string();
      })
      .def_property_readonly("have_result", [](const UniformizeJob& j) { return j.run.have_result; })
      .def_property_readonly("geometry", [](const UniformizeJob& j) {
        return std::string(ricci::geometry_name(j.run.result.geometry));
      })
      .def_property_readonly("V", [](py::object self) { return view(self.cast<const UniformizeJob&>().run.input.mesh.positions, 3, self); })
      .def_property_readonly("F", [](py::object self) { return view(self.cast<const UniformizeJob&>().run.input.mesh.faces, 3, self); })
      .def_property_readonly("vertex_to_input", [](py::object self) {
        return view(self.cast<const UniformizeJob&>().run.input.vertex_to_input, 0, self);
      })
      .def_property_readonly("edges", [](py::object self) {
        // The edges edge_lengths belong to: the Steiner subdivision's when it was used.
        const UniformizeJob& j = self.cast<const UniformizeJob&>();
        return view(j.run.result.steiner.used ? j.run.result.steiner_mesh.topology.edge_vertices
                                              : j.run.input.topology.edge_vertices, 2, self);
      })
      .def_property_readonly("steiner", [](py::object self) -> py::object {
        const UniformizeJob& j = self.cast<const UniformizeJob&>();
        if (!j.run.result.steiner.used) return py::none();
        const ricci::Mesh& sub = j.run.result.steiner_mesh.mesh;
        return py::make_tuple(view(sub.positions, 3, self), view(sub.faces, 3, self),
                              view(j.run.result.steiner_mesh.face_input, 0, self));
      })
      .def_property_readonly("u", [](py::object self) { return view(self.cast<const UniformizeJob&>().run.result.flow.u, 0, self); })
      .def_property_readonly("K", [](py::object self) { return view(self.cast<const UniformizeJob&>().run.result.flow.K, 0, self); })
      .def_property_readonly("K_target", [](py::object self) {
        return view(self.cast<const UniformizeJob&>().run.result.flow.K_target, 0, self);
      })
      .def_property_readonly("edge_lengths", [](py::object self) {
        return view(self.cast<const UniformizeJob&>().run.result.flow.l, 0, self);
      })
      .def_property_readonly("iterations", [](const UniformizeJob& j) { return j.run.result.flow.iterations; })
      .def_property_readonly("layout_positions", [](py::object self) {
        const ricci::Layout& L = self.cast<const UniformizeJob&>().run.result.layout;
        return view(L.positions, static_cast<std::size_t>(std::max(1, L.dims)), self);
      })
      .def_property_readonly("cut", [](py::object self) -> py::object {
        const ricci::UniformizeResult& r = self.cast<const UniformizeJob&>().run.result;
        if (!r.has_cut || r.cut.status != Status::Ok) return py::none();
        return cut_dict(r.cut, self);
      })
      .def_property_readonly("surface", [](py::object self) -> py::object {
        UniformizeJob& j = self.cast<UniformizeJob&>();
        ensure_surface(j);
        if (!j.have_surface) return py::none();
        return py::make_tuple(view(j.surface.positions, 3, self), view(j.surface.faces, 3, self));
      })
      .def_property_readonly("uv", [](py::object self) -> py::object {
        UniformizeJob& j = self.cast<UniformizeJob&>();
        ensure_surface(j);
        if (j.uv.empty()) return py::none();
        py::array a = view(j.uv, 2, self);
        return a.attr("reshape")(-1, 3, 2);
      })
      .def_property_readonly("face_chart", [](py::object self) -> py::object {
        UniformizeJob& j = self.cast<UniformizeJob&>();
        ensure_surface(j);
        const ricci::UniformizeResult& r = j.run.result;
        if (j.uv.empty() || !r.has_cut) return py::none();
        if (r.has_atlas && r.intrinsic.refined) return view(j.through.face_chart, 0, self);
        if (!r.has_atlas) {
          py::array_t<ricci::Index> zeros(static_cast<py::ssize_t>(j.surface.faces.size() / 3));
          std::fill(zeros.mutable_data(), zeros.mutable_data() + zeros.size(), ricci::Index{0});
          return zeros;
        }
        return view(r.atlas.face_chart, 0, self);
      })
      .def_property_readonly("sphere", [](py::object self) -> py::object {
        UniformizeJob& j = self.cast<UniformizeJob&>();
        ensure_surface(j);
        if (j.run.sphere_positions.empty()) return py::none();
        return view(j.run.sphere_positions, 3, self);
      })
      .def_property_readonly("generators", [](const UniformizeJob& j) { return generators(j.run.result); })
      .def_property_readonly("relation_error", [](const UniformizeJob& j) -> py::object {
        const ricci::UniformizeResult& r = j.run.result;
        if (!r.has_deck || r.deck.status != Status::Ok) return py::none();
        return py::float_(r.deck.relation_error);
      })
      .def_property_readonly("timings", [](const UniformizeJob& j) {
        py::dict d;
        d["load"] = j.run.load_seconds;
        for (const auto& [name, s] : j.run.result.timings) d[py::str(name)] = s;
        return d;
      })
      .def_property_readonly("notes", [](const UniformizeJob& j) { return j.run.notes; })
      .def_property_readonly("repairs", [](const UniformizeJob& j) { return repairs_list(j.run.repairs); })
      .def_property_readonly("report", [](UniformizeJob& j) {
        j.run.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - j.run.start).count();
        return json_to_python(ricci_cli::uniformize_report(j.run).dump());
      })
      .def("signature", [](UniformizeJob& j) { return signature_py(j); })
      .def("write", &write_py, "outdir"_a, "pictures"_a = true);

  m.def("flow", &flow_py, "V"_a, "F"_a, "path"_a, "name"_a, "options"_a, "progress"_a = py::none());
  m.def("uniformize", &uniformize_py, "V"_a, "F"_a, "path"_a, "name"_a, "options"_a, "progress"_a = py::none());
}
