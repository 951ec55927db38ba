"""ricci: conformal maps of triangle meshes by discrete surface Ricci flow.

Arrays in and out, as in libigl's bindings: ``V`` is a float64 array of shape (n, 3), ``F`` an
integer array of shape (m, 3) (int32 or int64) of 0-based vertex indices. Every function that
takes ``V, F`` also takes a file path instead of ``V`` (any format ``ricci`` reads; ``F`` is then
omitted), and ``uniformize()`` with no mesh runs the embedded default (a genus-2 surface), as
``ricci uniformize`` does.

    import ricci
    V, F = ricci.read_mesh("kitten.off")
    r = ricci.uniformize(V, F)            # the whole job: flow, cut, layout, deck group
    r.uv                                  # (m', 3, 2) per-corner texture coordinates of r.surface
    ricci.write_outputs(r, "out")         # the files `ricci uniformize -o out` writes

flow() and uniformize() run the command-line tool's own code with nothing printed, so their
numbers, notes and reports are those of ``ricci flow`` and ``ricci uniformize`` with the same
options (keyword names: the command-line options without dashes, ``tol`` for --tol,
``max_iterations`` for --max-iter, and booleans ``flips``, ``angle_relax``,
``circle_normalization``, ``split_ears`` for the --no-... switches). The GIL is released while
they work; ``progress`` (a callable) receives a dict after every flow iteration (``kind ==
"iteration"``) and pipeline stage (``kind == "stage"``).

Failures raise RicciError (``status``, ``message``, ``stage``, ``result``); arrays that cannot be
a mesh raise InvalidArrayError (also a ValueError); unknown options or values of the wrong type
raise TypeError.
"""

import os as _os

from . import _ricci
from ._errors import InvalidArrayError, RicciError

__version__ = _ricci.__version__
__all__ = ["read_mesh", "info", "flow", "uniformize", "signature", "write_outputs", "FlowResult",
           "UniformizeResult", "RicciError", "InvalidArrayError", "__version__"]


def _mesh_args(V, F, name, allow_default):
    """(V, F, path, name) for the compiled functions: a path (str or os.PathLike) or arrays."""
    if V is None and F is None:
        if not allow_default:
            raise TypeError("a mesh is required: V, F arrays or a file path")
        return None, None, "", name or "genus2.obj"
    if isinstance(V, (str, bytes, _os.PathLike)):
        if F is not None:
            raise TypeError("F must be omitted when the mesh is given as a file path")
        path = _os.fsdecode(V)
        if path == "":
            raise TypeError("empty mesh path")
        return None, None, path, name or path
    if F is None:
        raise TypeError("F is required with V (or give a file path instead of V)")
    return V, F, None, name or "mesh"


class _Result:
    """Attributes of the compiled job, read-only numpy views into its buffers."""

    __slots__ = ("_job",)
    _fields = ()

    def __init__(self, job):
        self._job = job

    def __getattr__(self, key):
        if key in self._fields:
            return getattr(self._job, key)
        raise AttributeError(f"{type(self).__name__} has no attribute {key!r}")

    def __dir__(self):
        return sorted(set(super().__dir__()) | set(self._fields))

    @property
    def ok(self):
        return self._job.status == "ok"

    def __repr__(self):
        return f"<ricci.{type(self).__name__} status={self._job.status!r} message={self._job.message!r}>"


class FlowResult(_Result):
    """What flow() returns.

    status, message    "ok" or the failure's status name, and the message
    u, K, K_target     per vertex of the validated mesh V, F (#V): the conformal factor (the
                       scheme's log radius or log scale), the curvature reached, the target
    edges, edge_lengths  (#E, 2) vertex pairs and the metric's length of each edge
    V, F, vertex_to_input  the validated mesh the numbers refer to, and each of its vertices'
                       index in the input (-1 for vertices added by splitting ears)
    iterations, max_curvature_error, history (a dict per iteration), notes, repairs
    report             the dict `ricci flow --json` prints
    """

    __slots__ = ()
    _fields = ("status", "message", "u", "K", "K_target", "edges", "edge_lengths", "V", "F",
               "vertex_to_input", "iterations", "max_curvature_error", "history", "notes", "repairs",
               "report", "converged")


class UniformizeResult(_Result):
    """What uniformize() returns.

    status, message, failed_stage, geometry ("euclidean", "hyperbolic", "spherical")
    V, F, vertex_to_input   the validated mesh (ears split when the boundary needs it)
    u, K, K_target, edges, edge_lengths   the flow's solution, per vertex / edge of V, F — or of
                       `steiner` when it is not None
    steiner            (positions, faces, face_input) of the surface subdivided on its own faces
                       (Steiner points: V's vertices first, then the new ones; each face's face of F)
                       where the input's faces could not carry the map, else None
    surface            (positions, faces) of mesh.obj: the input's faces, or the surface refined
                       by the cut (input vertices first)
    uv                 (#faces of surface, 3, 2) per-corner layout (plane or Poincare disk);
                       None for a closed genus-0 surface (see `sphere`)
    sphere             (#V, 3) unit-sphere positions (closed genus 0), else None
    layout_positions   (#cut vertices, 2) or (#V, 3): the layout of the cut disk or the sphere (the
                       first chart when the layout is an atlas)
    face_chart         (#faces of surface,) the chart of each face's uv (all 0 with one chart), or
                       None without a cut
    cut                dict: word, canonical, faces of the cut disk, cut_to_surface, sides, ...
    generators         dict of the deck group: names and, in H, "moebius" (k, 2, 2) SU(1,1)
                       matrices and translation lengths, in E "translation" (k, 2) and rotation;
                       None when there is none
    relation_error, timings (seconds per stage), notes, repairs
    report             report.json's content as a dict
    signature()        the conformal signature (signature.json's content)
    """

    __slots__ = ()
    _fields = ("status", "message", "failed_stage", "geometry", "V", "F", "vertex_to_input", "edges",
               "steiner", "u", "K", "K_target", "edge_lengths", "iterations", "surface", "uv", "sphere",
               "face_chart", "layout_positions", "cut", "generators", "relation_error", "timings", "notes",
               "repairs", "report")

    def signature(self):
        """The conformal signature of the surface (the content of signature.json)."""
        return self._job.signature()


def read_mesh(path, *, largest_component=False):
    """(V, F) of a mesh file, as read (polygons fan-triangulated); V float64 (n, 3), F int32 (m, 3).

    Raises RicciError (file_not_found, parse_error, ...) naming the file and line."""
    V, F, meta = _ricci.read_mesh(_os.fsdecode(path), largest_component)
    return V, F


def info(V, F=None, *, name=None, largest_component=False):
    """Counts and topology of a mesh after validation: vertices, edges, faces, boundary_loops,
    euler_characteristic, genus, closed, natural_geometry, repairs."""
    if isinstance(V, (str, bytes, _os.PathLike)):
        V, F = read_mesh(V, largest_component=largest_component)
    V, F, _, name = _mesh_args(V, F, name, False)
    return _ricci.info(V, F, name, largest_component)


def flow(V, F=None, *, name=None, progress=None, **options):
    """The conformal metric alone (`ricci flow`): geometry, scheme, target, boundary, method, tol,
    max_iterations, step, threads, flips, angle_relax, circle_normalization, split_ears,
    largest_component. Returns a FlowResult; raises RicciError when the flow fails (the partial
    result in ``error.result``)."""
    V, F, path, name = _mesh_args(V, F, name, True)
    job = _ricci.flow(V, F, path, name, options, progress)
    result = FlowResult(job)
    if job.status != "ok":
        raise RicciError(job.status, job.message, "flow" if job.have_flow else None, result)
    return result


def uniformize(V=None, F=None, *, name=None, progress=None, **options):
    """The whole job (`ricci uniformize`): geometry, scheme, target, boundary, tol, max_iterations,
    threads, mesh_polygon, atlas, base_candidates, seed_checks, cover_depth, cover_faces, patches, unit_box, flips,
    angle_relax, circle_normalization, split_ears, steiner_levels, boundary_split_rounds, split_chords,
    largest_component. Returns a UniformizeResult; raises
    RicciError naming the stage that failed. With an atlas of charts (``report["layout"]["charts"]``
    > 1), ``uv`` holds each face's corners in its own chart and ``face_chart`` names the chart."""
    V, F, path, name = _mesh_args(V, F, name, True)
    job = _ricci.uniformize(V, F, path, name, options, progress)
    result = UniformizeResult(job)
    if job.status != "ok":
        raise RicciError(job.status, job.message, job.failed_stage or None,
                         result if job.have_result else None)
    return result


def signature(V, F=None, **options):
    """The conformal signature (`ricci signature`) of a mesh (V, F or a path; uniformized with
    ``seed_checks=0`` and the given options) or of a UniformizeResult."""
    if isinstance(V, UniformizeResult):
        return V.signature()
    options.setdefault("seed_checks", 0)
    return uniformize(V, F, **options).signature()


def write_outputs(result, outdir, *, pictures=True):
    """Writes the outputs of `ricci uniformize -o OUTDIR` for a UniformizeResult: mesh.obj,
    metric.csv, report.json, pictures (unless pictures=False), ... all at once (OUTDIR is created,
    or replaced when it holds an earlier ricci report.json). Returns the names written."""
    if not isinstance(result, UniformizeResult):
        raise TypeError("write_outputs() takes the UniformizeResult of ricci.uniformize()")
    result._job.write(_os.fsdecode(outdir), pictures)
    return list(result._job.report["outputs"])
