#include "ricci/status.h"

namespace ricci {

std::string_view status_name(Status s) {
  switch (s) {
    case Status::Ok: return "ok";
    case Status::NotRun: return "not_run";
    case Status::InvalidArgument: return "invalid_argument";
    case Status::OutOfMemory: return "out_of_memory";
    case Status::FileNotFound: return "file_not_found";
    case Status::FileUnreadable: return "file_unreadable";
    case Status::UnknownFormat: return "unknown_format";
    case Status::ParseError: return "parse_error";
    case Status::FileTooLarge: return "file_too_large";
    case Status::WriteFailed: return "write_failed";
    case Status::OutputIsInput: return "output_is_input";
    case Status::IndexOutOfRange: return "index_out_of_range";
    case Status::NonFiniteCoordinate: return "non_finite_coordinate";
    case Status::NoFaces: return "no_faces";
    case Status::DegenerateFace: return "degenerate_face";
    case Status::DuplicateFace: return "duplicate_face";
    case Status::NonManifoldEdge: return "non_manifold_edge";
    case Status::NonManifoldVertex: return "non_manifold_vertex";
    case Status::InconsistentOrientation: return "inconsistent_orientation";
    case Status::NonOrientable: return "non_orientable";
    case Status::MultipleComponents: return "multiple_components";
    case Status::TriangleInequality: return "triangle_inequality";
    case Status::InfeasibleTarget: return "infeasible_target";
    case Status::NotConverged: return "not_converged";
    case Status::LineSearchFailed: return "line_search_failed";
    case Status::NumericalFailure: return "numerical_failure";
  }
  return "unknown_status";
}

std::string_view element_name(Element e) {
  switch (e) {
    case Element::None: return "none";
    case Element::Vertex: return "vertex";
    case Element::Face: return "face";
    case Element::Edge: return "edge";
    case Element::Corner: return "corner";
    case Element::Line: return "line";
    case Element::Byte: return "byte";
  }
  return "unknown_element";
}

}  // namespace ricci
