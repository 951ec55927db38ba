// ricci Python module — numpy arrays in and out, and the option dictionaries of flow() and
// uniformize(). Arrays in are checked here (shape, dtype, finite values, index range) and refused
// with ricci.InvalidArrayError naming the element; arrays out are read-only views of the result's
// own buffers (no copies), kept alive by the result object.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "commands.h"
#include "ricci/io.h"
#include "ricci/mesh.h"

namespace ricci_python {

namespace py = pybind11;

/// Raises ricci.<cls> (ricci/_errors.py) with status, message and stage; `result` is attached to
/// the exception (None when there is none).
[[noreturn]] void raise_error(const char* cls, const std::string& status, const std::string& message,
                              const std::string& stage = std::string(), py::object result = py::none());

/// V (n, 3) real and F (m, 3) integer arrays as a ricci::ReadResult (a triangle soup, status Ok)
/// named `name`. Refuses (InvalidArrayError) wrong shapes or dtypes, non-finite coordinates,
/// indices outside [0, n) and meshes larger than ricci's 32-bit indices hold.
ricci::ReadResult read_arrays(const py::handle& V, const py::handle& F, const std::string& name);

/// A read-only numpy view of `count` rows of `cols` values at `data` (cols 0: a vector), owned by
/// `owner`.
template <class T>
py::array view(const T* data, std::size_t count, std::size_t cols, const py::handle& owner) {
  std::vector<py::ssize_t> shape{static_cast<py::ssize_t>(count)};
  if (cols > 0) shape.push_back(static_cast<py::ssize_t>(cols));
  py::array a = py::array_t<T>(shape, data, owner);
  a.attr("flags").attr("writeable") = false;
  return a;
}
template <class T>
py::array view(const std::vector<T>& v, std::size_t cols, const py::handle& owner) {
  const std::size_t count = cols > 0 ? v.size() / cols : v.size();
  return view(v.data(), count, cols, owner);
}
/// A numpy array that owns `v` (moved in), shaped (size/cols, cols) or (size,) for cols 0.
template <class T>
py::array owned(std::vector<T>&& v, std::size_t cols) {
  auto* heap = new std::vector<T>(std::move(v));
  py::capsule free(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return view(*heap, cols, free);
}

/// The keyword options of ricci.uniformize() onto the command's options (the names in
/// lib/python/ricci/__init__.py); TypeError for an unknown name or a value of the wrong type.
void apply_uniformize_options(const py::dict& options, ricci_cli::UniformizeCommandOptions& o);
/// The same for ricci.flow().
void apply_flow_options(const py::dict& options, ricci_cli::FlowCommandOptions& o);

/// A JSON document (nlohmann) as Python objects (through the json module).
py::object json_to_python(const std::string& text);

}  // namespace ricci_python
