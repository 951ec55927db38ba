#!/usr/bin/env python3
"""Writes the seed corpora of the libFuzzer targets into tools/fuzz/corpus/<target>/.

The seeds are the malformed fixtures of fixtures/bad/ (tiny files, one problem each) plus a few
coarse meshes written here in every syntax the readers accept (so that every branch has a seed to
start from): tetrahedron, octahedron, a hexagon disk, an annulus, a 4×3 torus, a cube of quads.
Every file stays far below 20 KB. The corpus is committed; run this only to regenerate it:

    python3 tools/fuzz/make_corpus.py

Fuzzing never writes into these directories (tools/fuzz_smoke.sh fuzzes a copy).
"""
import base64
import math
import os
import shutil
import struct
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CORPUS = os.path.join(ROOT, "tools", "fuzz", "corpus")
BAD = os.path.join(ROOT, "fixtures", "bad")


# ---------------------------------------------------------------------------------------------
# Coarse meshes: (positions, polygons), counter-clockwise, 0-based.

def tetrahedron():
    return [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def octahedron():
    p = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    f = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    return p, f


def disk():
    p = [(0, 0, 0)] + [(math.cos(k * math.pi / 3), math.sin(k * math.pi / 3), 0) for k in range(6)]
    return p, [(0, 1 + k, 1 + (k + 1) % 6) for k in range(6)]


def annulus():
    s = [(1, 0), (0, 1), (-1, 0), (0, -1)]
    p = [(r * x, r * y, 0) for r in (1, 2) for (x, y) in s]
    f = []
    for i in range(4):
        j = (i + 1) % 4
        f += [(i, 4 + i, 4 + j), (i, 4 + j, j)]
    return p, f


def torus(n=4, m=3, R=2.0, r=0.7):
    p = []
    for i in range(n):
        for j in range(m):
            a, b = 2 * math.pi * i / n, 2 * math.pi * j / m
            p.append(((R + r * math.cos(b)) * math.cos(a), (R + r * math.cos(b)) * math.sin(a), r * math.sin(b)))
    f = []
    for i in range(n):
        for j in range(m):
            v = lambda a, b: (a % n) * m + (b % m)
            f += [(v(i, j), v(i + 1, j), v(i + 1, j + 1)), (v(i, j), v(i + 1, j + 1), v(i, j + 1))]
    return p, f


def cube_quads():
    p = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    f = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return p, f


MESHES = {"tetrahedron": tetrahedron(), "octahedron": octahedron(), "disk": disk(), "annulus": annulus(),
          "torus": torus(), "cube-quads": cube_quads()}


def num(x):
    return repr(float(x)) if x != int(x) else str(int(x))


# ---------------------------------------------------------------------------------------------
# Writers, each with its syntax variants.

def obj(mesh, variant="plain"):
    p, f = mesh
    out = ["# seed\n", "o seed\n"] if variant != "plain" else []
    out += ["v %s %s %s\n" % tuple(num(c) for c in v) for v in p]
    if variant == "texcoords":
        out += ["vt %s %s\n" % (num(v[0]), num(v[1])) for v in p]
        out += ["vn 0 0 1\n", "usemtl m\n", "s 1\n"]
        out += ["f " + " ".join("%d/%d/1" % (i + 1, i + 1) for i in poly) + "\n" for poly in f]
    elif variant == "negative":
        n = len(p)
        out += ["f " + " ".join(str(i - n) for i in poly) + "\n" for poly in f]
    elif variant == "crlf":
        out += ["g part\r\n"] + ["f " + " ".join("%d//1" % (i + 1) for i in poly) + "\r\n" for poly in f]
        out = [s.replace("\n", "\r\n") if not s.endswith("\r\n") else s for s in out]
    elif variant == "continued":
        out += ["f " + " \\\n  ".join(str(i + 1) for i in poly) + "\n" for poly in f]
    else:
        out += ["f " + " ".join(str(i + 1) for i in poly) + "\n" for poly in f]
    return "".join(out).encode()


def off(mesh, variant="plain"):
    p, f = mesh
    if variant == "coff":
        head = "# seed\nCOFF\n%d %d 0\n" % (len(p), len(f))
        verts = ["%s %s %s 255 0 0 255\n" % tuple(num(c) for c in v) for v in p]
        faces = ["%d %s 0 0 255\n" % (len(poly), " ".join(map(str, poly))) for poly in f]
    else:
        head = "OFF %d %d 0\n" % (len(p), len(f)) if variant == "inline" else "OFF\n%d %d 0\n" % (len(p), len(f))
        verts = ["%s %s %s\n" % tuple(num(c) for c in v) for v in p]
        faces = ["%d %s\n" % (len(poly), " ".join(map(str, poly))) for poly in f]
    return (head + "".join(verts) + "".join(faces)).encode()


def ply(mesh, encoding, extras=False):
    p, f = mesh
    head = ["ply", "format %s 1.0" % encoding, "comment seed", "element vertex %d" % len(p)]
    head += ["property float x", "property float y", "property float z"]
    if extras:
        head += ["property uchar red"]
    head += ["element face %d" % len(f), "property list uchar int vertex_indices"]
    if extras:
        head += ["element edge 1", "property int vertex1", "property int vertex2"]
    head += ["end_header"]
    out = ("\n".join(head) + "\n").encode()
    if encoding == "ascii":
        body = ["%s %s %s%s\n" % (*(num(c) for c in v), " 7" if extras else "") for v in p]
        body += ["%d %s\n" % (len(poly), " ".join(map(str, poly))) for poly in f]
        if extras:
            body += ["0 1\n"]
        return out + "".join(body).encode()
    e = "<" if encoding == "binary_little_endian" else ">"
    for v in p:
        out += struct.pack(e + "fff", *v) + (b"\x07" if extras else b"")
    for poly in f:
        out += struct.pack(e + "B" + "i" * len(poly), len(poly), *poly)
    if extras:
        out += struct.pack(e + "ii", 0, 1)
    return out


# ---------------------------------------------------------------------------------------------
# fuzz_ply_body: the body under each of the harness's fixed headers (tools/fuzz/fuzz_ply_body.cpp,
# kHeaders), prefixed by [header, #V, #F].

def ply_body(mesh, header):
    p, f = mesh
    prefix = bytes([header, len(p), len(f)])
    if header in (0, 5):  # ascii
        verts = ["%s %s %s%s\n" % (*(num(c) for c in v), " 1 3" if header == 5 else "") for v in p]
        faces = ["%d %s\n" % (len(poly), " ".join(map(str, poly))) for poly in f]
        body = (faces + verts + ["0.5\n"]) if header == 5 else (verts + faces)
        return prefix + "".join(body).encode()
    e = ">" if header in (2, 4) else "<"
    if header in (1, 2):
        vb = b"".join(struct.pack(e + "fff", *v) for v in p)
        fb = b"".join(struct.pack(e + "B" + "i" * len(x), len(x), *x) for x in f)
        return prefix + vb + fb
    if header == 3:
        vb = b"".join(struct.pack(e + "dddBBB", *v, 1, 2, 3) for v in p)
        fb = b"".join(struct.pack(e + "i" + "I" * len(x), len(x), *x) for x in f)
        return prefix + vb + fb + struct.pack(e + "iiii", 0, 1, 1, 2)
    if header == 4:
        vb = b"".join(struct.pack(e + "bHhIBf", 0, int(abs(v[0]) * 10), int(v[1] * 10), int(abs(v[2]) * 10), 1, 0.5)
                      for v in p)
        fb = b"".join(struct.pack(e + "BH" + "h" * len(x) + "f", 9, len(x), *x, 1.0) for x in f)
        return prefix + vb + fb
    if header == 6:
        fb = b"".join(struct.pack(e + "I" + "I" * len(x), len(x), *x) for x in f)
        vb = b"".join(struct.pack(e + "fff", v[2], v[1], v[0]) for v in p)
        return prefix + fb + vb
    raise ValueError(header)


# ---------------------------------------------------------------------------------------------
# fuzz_gifti: GIFTI surfaces and functional files in each encoding, byte order, index order and
# data type, and a few broken ones (needs `import base64` and `import zlib` at the top).

GIFTI_TYPES = {"FLOAT32": "f", "FLOAT64": "d", "INT8": "b", "UINT8": "B", "INT16": "h", "UINT16": "H",
               "INT32": "i", "UINT32": "I", "INT64": "q"}


def gifti_array(intent, dtype, rows, encoding="Base64Binary", big=False, column=False, name=None, gzip_header=False):
    """One DataArray; `rows` is a list of tuples (#N×k) or of numbers (1-D)."""
    two_d = bool(rows) and isinstance(rows[0], tuple)
    cols = len(rows[0]) if two_d else 1
    flat = [x for r in rows for x in r] if two_d else list(rows)
    if column and two_d:
        flat = [rows[i][j] for j in range(cols) for i in range(len(rows))]
    is_float = dtype.startswith("FLOAT")
    if encoding == "ASCII":
        data = "\n" + "\n".join(num(x) if is_float else str(int(x)) for x in flat) + "\n"
    else:
        values = flat if is_float else [int(x) for x in flat]
        raw = struct.pack((">" if big else "<") + GIFTI_TYPES[dtype] * len(values), *values)
        if encoding == "GZipBase64Binary":
            c = zlib.compressobj(6, zlib.DEFLATED, 31 if gzip_header else 15)
            raw = c.compress(raw) + c.flush()
        data = base64.b64encode(raw).decode()
    dims = 'Dimensionality="2" Dim0="%d" Dim1="%d"' % (len(rows), cols) if two_d else \
        'Dimensionality="1" Dim0="%d"' % len(rows)
    meta = "<MetaData/>" if name is None else \
        "<MetaData><MD><Name><![CDATA[Name]]></Name><Value><![CDATA[%s]]></Value></MD></MetaData>" % name
    if intent == "POINTSET":
        meta += ("\n<CoordinateSystemTransformMatrix><DataSpace>NIFTI_XFORM_UNKNOWN</DataSpace>"
                 "<TransformedSpace>NIFTI_XFORM_UNKNOWN</TransformedSpace>"
                 "<MatrixData>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</MatrixData></CoordinateSystemTransformMatrix>")
    return ('<DataArray Intent="NIFTI_INTENT_%s" DataType="NIFTI_TYPE_%s" ArrayIndexingOrder="%s" %s\n'
            ' Encoding="%s" Endian="%s" ExternalFileName="" ExternalFileOffset="">\n%s\n<Data>%s</Data>\n'
            '</DataArray>\n') % (intent, dtype, "ColumnMajorOrder" if column else "RowMajorOrder", dims, encoding,
                                 "BigEndian" if big else "LittleEndian", meta, data)


def gifti(arrays):
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<!DOCTYPE GIFTI SYSTEM "http://www.nitrc.org/frs/download.php/115/gifti.dtd">\n'
            '<GIFTI Version="1.0" NumberOfDataArrays="%d">\n<MetaData/>\n<LabelTable/>\n%s</GIFTI>\n'
            % (len(arrays), "".join(arrays))).encode()


def gifti_surface(mesh, encoding, big=False, column=False, ctype="FLOAT32", itype="INT32", gzip_header=False):
    p, f = mesh
    return gifti([gifti_array("POINTSET", ctype, [tuple(map(float, v)) for v in p], encoding, big, column,
                              gzip_header=gzip_header),
                  gifti_array("TRIANGLE", itype, [tuple(t) for t in f], encoding, big, column,
                              gzip_header=gzip_header)])


def write_gifti_seeds():
    variants = {  # name: (encoding, big, column, coordinate type, index type, gzip header)
        "ascii": ("ASCII", False, False, "FLOAT32", "INT32", False),
        "b64-big-column": ("Base64Binary", True, True, "FLOAT64", "UINT16", False),
        "gz": ("GZipBase64Binary", False, False, "FLOAT32", "INT32", False),
        "gz-gzip-big-column": ("GZipBase64Binary", True, True, "FLOAT32", "UINT8", True),
    }
    for mname in ("tetrahedron", "octahedron", "disk", "torus"):
        for vname, (enc, big, column, ctype, itype, gz) in variants.items():
            if mname in ("disk", "torus") and vname not in ("gz", "ascii"):
                continue
            write("gifti", "%s-%s.surf.gii" % (mname, vname),
                  gifti_surface(MESHES[mname], enc, big, column, ctype, itype, gz))
    p, f = MESHES["octahedron"]
    values = [0.5 * i - 1 for i in range(len(p))]
    write("gifti", "octahedron.func.gii",
          gifti([gifti_array("SHAPE", "FLOAT32", values, "GZipBase64Binary", name="u"),
                 gifti_array("LABEL", "INT32", list(range(len(p))), "ASCII", name="index"),
                 gifti_array("NONE", "INT16", [(i,) for i in range(len(p))], "Base64Binary", True, True)]))
    # Broken: external data, an index out of range, a NaN, a missing triangle array, a huge Dim0.
    tp, tf = MESHES["tetrahedron"]
    good = gifti_surface(MESHES["tetrahedron"], "Base64Binary")
    write("gifti", "bad-external.surf.gii", good.replace(b'Encoding="Base64Binary"', b'Encoding="ExternalFileBinary"', 1))
    write("gifti", "bad-index.surf.gii", gifti_surface((tp, tf[:-1] + [(1, 2, 4)]), "ASCII"))
    write("gifti", "bad-nan.surf.gii", gifti_surface(([(0, 0, float("nan"))] + tp[1:], tf), "GZipBase64Binary"))
    write("gifti", "bad-no-triangles.surf.gii",
          gifti([gifti_array("POINTSET", "FLOAT32", [tuple(map(float, v)) for v in tp], "ASCII")]))
    write("gifti", "bad-huge-dim0.surf.gii", good.replace(b'Dim0="4"', b'Dim0="2000000000"', 1))


# ---------------------------------------------------------------------------------------------
# fuzz_stl and fuzz_freesurfer: triangle meshes as binary and ascii STL, FreeSurfer surfaces and
# curv files, and a few broken ones.

def triangles(mesh):
    p, f = mesh
    for poly in f:
        for k in range(1, len(poly) - 1):
            yield p[poly[0]], p[poly[k]], p[poly[k + 1]]


def stl_binary(mesh, header=b"binary STL seed"):
    tris = list(triangles(mesh))
    out = header.ljust(80, b" ")[:80] + struct.pack("<I", len(tris))
    for a, b, c in tris:
        out += struct.pack("<12fH", 0, 0, 0, *a, *b, *c, 0)
    return out


def stl_ascii(mesh, name="seed"):
    lines = ["solid " + name]
    for a, b, c in triangles(mesh):
        lines += ["facet normal 0 0 0", "  outer loop"]
        lines += ["    vertex %s %s %s" % (num(v[0]), num(v[1]), num(v[2])) for v in (a, b, c)]
        lines += ["  endloop", "endfacet"]
    lines.append("endsolid " + name)
    return ("\n".join(lines) + "\n").encode()


def freesurfer(mesh):
    p, f = mesh
    tris = [(poly[0], poly[k], poly[k + 1]) for poly in f for k in range(1, len(poly) - 1)]
    out = b"\xff\xff\xfe" + b"created by make_corpus\n\n" + struct.pack(">ii", len(p), len(tris))
    out += b"".join(struct.pack(">fff", *v) for v in p)
    return out + b"".join(struct.pack(">iii", *t) for t in tris)


def curv(values, faces):
    return b"\xff\xff\xff" + struct.pack(">iii", len(values), faces, 1) + b"".join(struct.pack(">f", v) for v in values)


def write_stl_freesurfer_seeds():
    for mname in ("tetrahedron", "octahedron", "disk", "torus", "cube-quads"):
        mesh = MESHES[mname]
        write("stl", "%s.stl" % mname, stl_binary(mesh))
        write("stl", "%s-ascii.stl" % mname, stl_ascii(mesh))
        write("freesurfer", "%s.surf" % mname, freesurfer(mesh))
        write("freesurfer", "%s.curv" % mname, curv([0.25 * i for i in range(len(mesh[0]))], len(mesh[1])))
    octa = MESHES["octahedron"]
    write("stl", "solid-header-binary.stl", stl_binary(octa, header=b"solid but binary"))
    write("stl", "two-solids.stl", stl_ascii(octa, "a") + stl_ascii(MESHES["tetrahedron"], "b"))
    write("stl", "bad-truncated.stl", stl_binary(octa)[:-20])
    write("stl", "bad-nan.stl", stl_binary(octa)[:96] + struct.pack("<f", float("nan")) + stl_binary(octa)[100:])
    write("stl", "bad-two-corners.stl", b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                        b"endloop\nendfacet\nendsolid x\n")
    write("freesurfer", "bad-truncated.surf", freesurfer(octa)[:-7])
    write("freesurfer", "bad-index.surf", freesurfer(octa)[:-4] + struct.pack(">i", 99))
    write("freesurfer", "bad-quad-magic.surf", b"\xff\xff\xfd" + freesurfer(octa)[3:])
    write("freesurfer", "bad-values-per-vertex.curv", b"\xff\xff\xff" + struct.pack(">iii", 2, 0, 3) + bytes(24))


# ---------------------------------------------------------------------------------------------

def write(target, name, data):
    assert len(data) < 20000, (target, name, len(data))
    d = os.path.join(CORPUS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as fh:
        fh.write(data)


def main():
    if os.path.isdir(CORPUS):
        shutil.rmtree(CORPUS)
    bad = {name: open(os.path.join(BAD, name), "rb").read() for name in sorted(os.listdir(BAD))
           if name.endswith((".obj", ".off", ".ply"))}
    for name, data in bad.items():
        ext = name.rsplit(".", 1)[1]
        write(ext, "bad-" + name, data)
        write("load", "bad-" + name, bytes([{"obj": 0, "off": 1, "ply": 2}[ext]]) + data)

    for mname, mesh in MESHES.items():
        quads = mname == "cube-quads"
        for variant in ("plain", "texcoords", "negative", "crlf", "continued"):
            if variant != "plain" and mname not in ("tetrahedron", "disk", "cube-quads"):
                continue
            write("obj", "%s-%s.obj" % (mname, variant), obj(mesh, variant))
        for variant in ("plain", "inline", "coff"):
            if variant != "plain" and mname not in ("octahedron", "cube-quads"):
                continue
            write("off", "%s-%s.off" % (mname, variant), off(mesh, variant))
        for enc in ("ascii", "binary_little_endian", "binary_big_endian"):
            write("ply", "%s-%s.ply" % (mname, enc), ply(mesh, enc))
            if mname == "tetrahedron":
                write("ply", "%s-%s-extras.ply" % (mname, enc), ply(mesh, enc, extras=True))
        # load: selector byte (format | options, see fuzz_load.cpp) + file.
        write("load", "%s.obj" % mname, bytes([0x00]) + obj(mesh))
        write("load", "%s-largest-h.off" % mname, bytes([0x01 | 0x04 | 0x10]) + off(mesh))
        write("load", "%s-s.ply" % mname, bytes([0x02 | 0x20]) + ply(mesh, "binary_little_endian"))
        if not quads:
            for header in range(7):
                write("ply_body", "%s-header%d" % (mname, header), ply_body(mesh, header))
            # A raw soup (selector 3): #V, coordinates ×4 as signed bytes, indices.
            p, f = mesh
            soup = bytes([len(p)]) + bytes((int(round(c * 4)) & 0xFF) for v in p for c in v)
            soup += bytes(i for poly in f for i in poly)
            write("load", "%s-soup" % mname, bytes([0x03]) + soup)

    # Targets: selector byte (mesh = b % 3: tetrahedron, disk, annulus; mode = (b / 3) % 5: free,
    # fixed, circle, geodesic, loop-totals) + text.
    texts = {
        "one": b"0 0.5\n",
        "comments": b"# vertex curvature\n\n1 -0.25  # inline\r\n2 +1e-3\n",
        "bom": b"\xef\xbb\xbf0 3.14159\n3 -3.14159\n",
        "duplicate": b"0 1\n0 2\n",
        "beyond": b"99 0\n",
        "huge-index": b"123456789012345678901234567890 0\n",
        "negative": b"-1 0\n",
        "nan": b"0 nan\n",
        "third-value": b"0 1 2\n",
        "alone": b"0\n",
        "exponents": b"1 1e-400\n2 -0.0\n3 1e308\n",
    }
    for tname, text in texts.items():
        for selector in (0, 1, 2, 1 + 3 * 1, 2 + 3 * 2, 1 + 3 * 3, 2 + 3 * 4):
            if tname not in ("one", "comments") and selector not in (1, 2 + 3 * 2):
                continue
            write("target", "%s-%d" % (tname, selector), bytes([selector]) + text)

    write_gifti_seeds()
    write_stl_freesurfer_seeds()


if __name__ == "__main__":
    main()
