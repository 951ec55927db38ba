// ricci — status codes shared by every module.
//
// Every driver returns a result struct whose `status` starts as Status::NotRun. Only Status::Ok
// means the outputs of that result are valid; for every other value they are unspecified (and
// usually empty). `message` is a full sentence naming the file, the element and the problem.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace ricci {

/// Outcome of a driver, stored in the `status` field of every result struct. Only Ok means the
/// outputs are valid; the value names the first problem found. status_name() gives its JSON name.
enum class Status : int {
  Ok = 0,                   ///< success: the outputs of the result are valid
  NotRun,                   ///< the driver has not been run
  InvalidArgument,          ///< an option or argument is out of its documented range
  OutOfMemory,              ///< an allocation failed; nothing was returned
  // Files.
  FileNotFound,             ///< the input path does not exist
  FileUnreadable,           ///< the input exists but cannot be read (permissions, a directory…)
  UnknownFormat,            ///< the file extension / header names no supported format
  ParseError,               ///< malformed content; `line` (text) or byte offset says where
  FileTooLarge,             ///< over ReadOptions::max_file_bytes, or counts beyond 32-bit indices
  WriteFailed,              ///< the output could not be written; nothing was left behind
  OutputIsInput,            ///< refused: the output path is the input (or another protected) file
  // Mesh content.
  IndexOutOfRange,          ///< a face refers to a vertex that does not exist
  NonFiniteCoordinate,      ///< a vertex coordinate is NaN or infinite
  NoFaces,                  ///< the mesh has no faces
  DegenerateFace,           ///< a face repeats a vertex or has zero area
  DuplicateFace,            ///< two faces use the same three vertices
  NonManifoldEdge,          ///< an edge is shared by more than two faces
  NonManifoldVertex,        ///< the faces around a vertex form more than one fan (pinched)
  InconsistentOrientation,  ///< neighbouring faces traverse their shared edge the same way
  NonOrientable,            ///< no choice of face orientations is consistent (Möbius, Klein…)
  MultipleComponents,       ///< the mesh has several connected components
  // Metrics and flows.
  TriangleInequality,       ///< a triangle's lengths violate the triangle inequality
  InfeasibleTarget,         ///< the target curvature violates Gauss–Bonnet or admissibility
  NotConverged,             ///< the iteration limit was reached before the tolerance
  LineSearchFailed,         ///< no step along the search direction decreased the energy
  NumericalFailure,         ///< a factorization failed or a value left its valid range
};

/// Stable snake_case name of a status ("non_manifold_edge"), used in JSON reports.
std::string_view status_name(Status s);

/// Kind of element an error refers to, stored next to a 0-based `element_index` in result
/// structs. None: no single element (then element_index is -1); Vertex, Face, Edge, Corner: a mesh
/// element in the numbering stated by the result (corner c = 3f + k). Line and Byte name a position
/// in a file; the readers report that position in ReadResult::line instead and set `element` to the
/// mesh element (or None).
enum class Element : int { None = 0, Vertex, Face, Edge, Corner, Line, Byte };

/// Stable name of an element kind ("vertex", "face", …).
std::string_view element_name(Element e);

}  // namespace ricci
