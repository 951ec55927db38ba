// ricci Python module — arrays and options (convert.h).
#include "convert.h"

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <string>

namespace ricci_python {

void raise_error(const char* cls, const std::string& status, const std::string& message, const std::string& stage,
                 py::object result) {
  py::object type = py::module_::import("ricci._errors").attr(cls);
  py::object error = type(status, message, stage.empty() ? py::object(py::none()) : py::object(py::str(stage)), result);
  PyErr_SetObject(type.ptr(), error.ptr());
  throw py::error_already_set();
}

namespace {

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) {
    if (i > 0) s += ", ";
    s += std::to_string(a.shape(i));
  }
  if (a.ndim() == 1) s += ",";
  return s + ")";
}

std::string dtype_text(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

[[noreturn]] void refuse(const std::string& status, const std::string& message) {
  raise_error("InvalidArrayError", status, message);
}

}  // namespace

ricci::ReadResult read_arrays(const py::handle& V_in, const py::handle& F_in, const std::string& name) {
  if (!py::isinstance<py::array>(V_in) && !py::isinstance<py::sequence>(V_in))
    refuse("invalid_argument", name + ": V must be an array of shape (n, 3), not " +
                                   py::str(py::type::of(V_in)).cast<std::string>());
  if (!py::isinstance<py::array>(F_in) && !py::isinstance<py::sequence>(F_in))
    refuse("invalid_argument", name + ": F must be an array of shape (m, 3), not " +
                                   py::str(py::type::of(F_in)).cast<std::string>());
  py::module_ np = py::module_::import("numpy");
  auto as_array = [&](const py::handle& x, const char* what) -> py::array {
    try {
      return np.attr("asarray")(x);
    } catch (py::error_already_set& e) {  // ragged nested lists and the like
      refuse("invalid_argument", name + ": " + what + " is not an array: " + std::string(py::str(e.value())));
    }
  };
  const py::array V = as_array(V_in, "V");
  const py::array F = as_array(F_in, "F");
  const char vk = V.dtype().kind();
  if (vk != 'f' && vk != 'i' && vk != 'u')
    refuse("invalid_argument", name + ": V must hold real numbers (float64), not " + dtype_text(V));
  if (V.ndim() != 2 || V.shape(1) != 3)
    refuse("invalid_argument", name + ": V must have shape (n, 3), not " + shape_text(V));
  const char fk = F.dtype().kind();
  if (fk != 'i' && fk != 'u')
    refuse("invalid_argument", name + ": F must hold integers (int32 or int64), not " + dtype_text(F));
  if (F.ndim() != 2 || F.shape(1) != 3)
    refuse("invalid_argument", name + ": F must have shape (m, 3) (triangles), not " + shape_text(F));
  const py::ssize_t n = V.shape(0), m = F.shape(0);
  constexpr py::ssize_t kMax = std::numeric_limits<ricci::Index>::max() / 3;
  if (n > kMax || m > kMax)
    refuse("invalid_argument", name + ": " + std::to_string(std::max(n, m)) + " rows: more than ricci's 32-bit "
                                      "indices hold (" + std::to_string(kMax) + ")");
  // float64 and int64, C order (a copy only when the caller's arrays are not already so).
  const auto Vd = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(V);
  const auto Fd = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(F);
  if (!Vd || !Fd) throw py::error_already_set();
  ricci::ReadResult r;
  r.mesh.positions.assign(Vd.data(), Vd.data() + 3 * n);
  for (py::ssize_t i = 0; i < 3 * n; ++i)
    if (!std::isfinite(r.mesh.positions[static_cast<std::size_t>(i)]))
      refuse("non_finite_coordinate", name + ": vertex " + std::to_string(i / 3) + " has a non-finite coordinate (" +
                                          std::to_string(r.mesh.positions[static_cast<std::size_t>(i)]) + ")");
  r.mesh.faces.resize(static_cast<std::size_t>(3 * m));
  const std::int64_t* f = Fd.data();
  for (py::ssize_t i = 0; i < 3 * m; ++i) {
    if (f[i] < 0 || f[i] >= n)
      refuse("index_out_of_range", name + ": face " + std::to_string(i / 3) + " names vertex " + std::to_string(f[i]) +
                                       ", outside [0, " + std::to_string(n) + ")");
    r.mesh.faces[static_cast<std::size_t>(i)] = static_cast<ricci::Index>(f[i]);
  }
  r.status = ricci::Status::Ok;
  r.message = name + ": " + std::to_string(n) + " vertices and " + std::to_string(m) + " triangles from arrays";
  r.format = ricci::FileFormat::Auto;
  r.polygons_read = m;
  return r;
}

namespace {

template <class T>
T get(const py::handle& value, const std::string& key, const char* what) {
  try {
    if constexpr (std::is_same_v<T, bool>) {
      if (!py::isinstance<py::bool_>(value)) throw py::cast_error();
    } else if constexpr (std::is_integral_v<T>) {
      if (py::isinstance<py::bool_>(value) || !py::isinstance<py::int_>(value)) {
        // numpy integers pass through __index__.
        if (!py::hasattr(value, "__index__") || py::isinstance<py::float_>(value)) throw py::cast_error();
      }
    } else if constexpr (std::is_floating_point_v<T>) {
      if (py::isinstance<py::bool_>(value) || py::isinstance<py::str>(value)) throw py::cast_error();
    } else {
      if (!py::isinstance<py::str>(value)) throw py::cast_error();
    }
    return value.cast<T>();
  } catch (const py::cast_error&) {
    throw py::type_error("option " + key + " must be " + what + ", not " + py::str(py::type::of(value)).cast<std::string>());
  }
}

using Setter = std::function<void(const py::handle&, const std::string&)>;

void apply(const py::dict& options, const std::map<std::string, Setter>& setters, const char* fn) {
  for (const auto& [k, v] : options) {
    const std::string key = py::str(k).cast<std::string>();
    const auto it = setters.find(key);
    if (it == setters.end()) {
      std::string known;
      for (const auto& [name, s] : setters) known += (known.empty() ? "" : ", ") + name;
      throw py::type_error(std::string(fn) + "() got an unknown option '" + key + "' (known: " + known + ")");
    }
    it->second(v, key);
  }
}

template <class O>
Setter text(std::string O::*field, O& o) {
  return [&o, field](const py::handle& v, const std::string& k) { o.*field = get<std::string>(v, k, "a string"); };
}
template <class O>
Setter real(double O::*field, O& o) {
  return [&o, field](const py::handle& v, const std::string& k) { o.*field = get<double>(v, k, "a number"); };
}
template <class O>
Setter integer(int O::*field, O& o) {
  return [&o, field](const py::handle& v, const std::string& k) {
    const long long x = get<long long>(v, k, "an integer");
    if (x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max())
      throw py::value_error("option " + k + " = " + std::to_string(x) + " is out of range");
    o.*field = static_cast<int>(x);
  };
}
template <class O>
Setter flag(bool O::*field, O& o, bool negate) {
  return [&o, field, negate](const py::handle& v, const std::string& k) { o.*field = get<bool>(v, k, "True or False") != negate; };
}

// The options `flow` and `uniformize` share: the same names on both commands' option structs.
template <class O>
std::map<std::string, Setter> common_setters(O& o) {
  return {
      {"geometry", text(&O::geometry, o)},
      {"scheme", text(&O::scheme, o)},
      {"target", text(&O::target, o)},
      {"boundary", text(&O::boundary, o)},
      {"tol", real(&O::tolerance, o)},
      {"max_iterations", integer(&O::max_iterations, o)},
      {"threads", integer(&O::threads, o)},
      {"flips", flag(&O::no_flips, o, true)},
      {"angle_relax", flag(&O::no_angle_relax, o, true)},
      {"circle_normalization", flag(&O::no_circle_normalization, o, true)},
      {"split_ears", flag(&O::no_split_ears, o, true)},
      {"largest_component", flag(&O::largest_component, o, false)},
  };
}

}  // namespace

void apply_uniformize_options(const py::dict& options, ricci_cli::UniformizeCommandOptions& o) {
  using O = ricci_cli::UniformizeCommandOptions;
  std::map<std::string, Setter> setters = common_setters(o);
  setters.insert({{"base_candidates", integer(&O::base_candidates, o)},
                  {"seed_checks", integer(&O::seed_checks, o)},
                  {"cover_depth", integer(&O::cover_depth, o)},
                  {"cover_faces", integer(&O::cover_faces, o)},
                  {"patches", integer(&O::patches, o)},
                  {"layout_refine_above", real(&O::layout_refine_above, o)},
                  {"unit_box", flag(&O::unit_box, o, false)},
                  {"mesh_polygon", flag(&O::mesh_polygon, o, false)},
                  {"atlas", flag(&O::no_atlas, o, true)},
                  {"steiner_levels", integer(&O::steiner_levels, o)},
                  {"boundary_split_rounds", integer(&O::boundary_split_rounds, o)},
                  {"split_chords", flag(&O::no_split_chords, o, true)}});
  apply(options, setters, "uniformize");
}

void apply_flow_options(const py::dict& options, ricci_cli::FlowCommandOptions& o) {
  using O = ricci_cli::FlowCommandOptions;
  std::map<std::string, Setter> setters = common_setters(o);
  setters.insert({{"method", text(&O::method, o)}, {"step", real(&O::step, o)}});
  apply(options, setters, "flow");
}

py::object json_to_python(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

}  // namespace ricci_python
