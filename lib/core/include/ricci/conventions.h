// ricci — conventions shared by every module. Stated once here, asserted in tests/core/test_conventions.cpp.
//
// Meshes are flat, row-major buffers:
//   positions  #V×3 double   positions[3*v + d]
//   faces      #F×3 int32    faces[3*f + k]   (k = 0, 1, 2)
//
// Corners. Corner c = 3f + k is "vertex faces[c] as seen from face f". Within a face the corners
// are cyclic: next(c) and prev(c) are found by arithmetic, no table is stored.
//
// Faces are counter-clockwise: seen from the side the normal points to (right-hand rule), the
// vertices faces[3f], faces[3f+1], faces[3f+2] turn counter-clockwise.
//
// Edges. Per face, edge k is the edge OPPOSITE corner k. It joins vertex(next(c)) and
// vertex(prev(c)) and, in the orientation of face f, runs from vertex(next(c)) to vertex(prev(c)):
//
//                 prev(c)
//                   *
//   opp. next(c):  / \   opp. c:
//   prev(c) -> c  / f \  next(c) -> prev(c)
//                *-----*
//                c     next(c)
//           opp. prev(c): c -> next(c)
//
// Opposite corner. opposite[c] is the corner of the neighbouring face that faces the same edge
// (the edge opposite c), or -1 when that edge is on the boundary. On a consistently oriented
// manifold the neighbour traverses the edge the other way: vertex(next(opposite[c])) ==
// vertex(prev(c)) and vertex(prev(opposite[c])) == vertex(next(c)).
//
// Rotation around a vertex (corner c at vertex v):
//   counter-clockwise neighbour: ccw(c) = next(opposite[next(c)])   (-1 if that edge is boundary)
//   clockwise neighbour:         cw(c)  = prev(opposite[prev(c)])   (-1 if that edge is boundary)
// (ccw(c) lies across the edge v–vertex(prev(c)), cw(c) across the edge v–vertex(next(c)).)
// The fan of a boundary vertex starts at the corner with no clockwise neighbour and ends at the
// corner with no counter-clockwise neighbour. Boundary loops run along the face orientation, so
// the surface lies to the left of a loop (a disk's outer loop is counter-clockwise).
#pragma once

#include <cstdint>

namespace ricci {

/// Index type of vertices, faces, corners and edges. 32 bits: up to 2^31-1 corners (~715M faces).
using Index = std::int32_t;

/// Marks a missing neighbour (boundary) in index arrays.
inline constexpr Index kInvalid = -1;

/// Face of corner c.
constexpr Index corner_face(Index c) { return c / 3; }
/// Position of corner c inside its face (0, 1 or 2).
constexpr Index corner_slot(Index c) { return c % 3; }
/// Corner k of face f.
constexpr Index face_corner(Index f, Index k) { return 3 * f + k; }
/// Next corner inside the face (counter-clockwise).
constexpr Index next_corner(Index c) { return (c % 3 == 2) ? c - 2 : c + 1; }
/// Previous corner inside the face (clockwise).
constexpr Index prev_corner(Index c) { return (c % 3 == 0) ? c + 2 : c - 1; }

}  // namespace ricci
