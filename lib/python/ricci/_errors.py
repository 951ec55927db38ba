"""The exceptions of ricci (raised by the compiled module and by the package)."""


class RicciError(Exception):
    """A run of ricci that did not succeed.

    ``status`` is the library's status name (``"not_converged"``, ``"infeasible_target"``,
    ``"non_manifold_edge"``, ``"file_not_found"``, ...; the same names ``ricci --json`` reports),
    ``message`` its message (naming the file or array, the element and the problem), ``stage`` the
    pipeline stage that failed when one did (``"flow"``, ``"layout"``, ``"outputs"``, ...), and
    ``result`` the partial result when there is one (a FlowResult or UniformizeResult whose
    ``report`` says how far the run came), else None.
    """

    def __init__(self, status, message, stage=None, result=None):
        super().__init__(f"{status}: {message}")
        self.status = status
        self.message = message
        self.stage = stage
        self.result = result


class InvalidArrayError(RicciError, ValueError):
    """Arrays that cannot be a mesh: wrong shape or dtype, a non-finite coordinate, a face index
    outside the vertex range. ``status`` is ``"invalid_argument"``, ``"non_finite_coordinate"`` or
    ``"index_out_of_range"``."""
