#!/usr/bin/env python3
"""bench_peers — the whole default `ricci uniformize --no-pictures` job against CGAL's LSCM and
discrete conformal map (tools/peer_cgal) on the same disk meshes, as a Markdown report.

Takes disk-like triangle meshes (OBJ or OFF), each refined K times by 1→4 midpoint subdivision for
every K of --subdivide, and runs, in each of --rounds alternated rounds, three processes one after
another: ricci, peer_cgal --peers lscm, peer_cgal --peers dcm. Gives, per (mesh, K), the best
(least) process wall time of each, ricci's flow stage and other stages, peak RSS of each process
(os.wait4), the mean angle distortion and flipped faces of each map, and ricci's stage timings;
printed to stdout and, with --out, also written to a file (atomically).

    python3 tools/bench_peers.py [--ricci build/ricci] [--peer build/tools/peer_cgal]
        [--mesh ../shared/meshes/boundary/face.obj ...] [--subdivide 0,1,2] [--rounds 3]
        [--peer-max-k N] [--pictures] [--out REPORT.md]

Needs numpy (Debian's python3-numpy), a Release build of ricci, and for the peer columns peer_cgal:
    cmake -S . -B build -DRICCI_PEERS=ON && cmake --build build --target peer_cgal
(without it those columns say "not run"; --peer-max-k N runs the peers only up to K = N). With --pictures, each
round also runs ricci with its pictures, and a last table gives their time and the process's with and without. The subdivided meshes ricci reads are written by this
script into a temporary directory; peer_cgal reads the original file with its own --subdivide K (the
same midpoint rule), and the face and vertex counts of both must agree or the script stops.

A benchmark, never a test: it reports failed runs in its table and does not fail on slow results.
"""
import argparse
import datetime
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_RICCI = os.path.join(ROOT, "build", "ricci")
DEFAULT_PEER = os.path.join(ROOT, "build", "tools", "peer_cgal")
DEFAULT_MESH = os.path.normpath(os.path.join(ROOT, "..", "shared", "meshes", "boundary", "face.obj"))
PEERS = ("lscm", "dcm")
DASH = "—"


# ---------------------------------------------------------------- command line

def parse_args(argv):
    p = argparse.ArgumentParser(description="ricci uniformize vs CGAL LSCM and DCM: a Markdown benchmark report")
    p.add_argument("--ricci", default=DEFAULT_RICCI, help="the ricci CLI (default: build/ricci)")
    p.add_argument("--peer", default=DEFAULT_PEER, help="peer_cgal (default: build/tools/peer_cgal)")
    p.add_argument("--mesh", action="append", help="a disk mesh, OBJ or OFF (repeatable; default: face.obj)")
    p.add_argument("--subdivide", default="0,1,2", type=subdivide_list, help="levels K, comma separated")
    p.add_argument("--rounds", default=3, type=int, help="alternated rounds; the best is kept (default 3)")
    p.add_argument("--peer-max-k", type=int, default=None,
                   help="run the peers only up to this level K (larger K: ricci alone; default: every K)")
    p.add_argument("--pictures", action="store_true",
                   help="also run ricci with its pictures (without --no-pictures) in each round and report their time")
    p.add_argument("--out", help="also write the report to this Markdown file")
    args = p.parse_args(argv)
    args.mesh = args.mesh or [DEFAULT_MESH]
    if args.rounds < 1:
        p.error("--rounds must be at least 1")
    return args


def subdivide_list(text):
    try:
        levels = [int(word) for word in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError("expected whole numbers separated by commas, not %r" % text)
    if any(k < 0 or k > 6 for k in levels):
        raise argparse.ArgumentTypeError("each K must be from 0 to 6 (peer_cgal's range)")
    return levels


# ---------------------------------------------------------------- meshes

def read_mesh(path):
    """(points float64 (n, 3), triangles int64 (m, 3)), polygons as fans, unused vertices dropped."""
    if path.lower().endswith(".obj"):
        points, polygons = read_obj(path)
    elif path.lower().endswith(".off"):
        points, polygons = read_off(path)
    else:
        raise ValueError("unknown format (expected .obj or .off)")
    triangles = [(poly[0], poly[k], poly[k + 1]) for poly in polygons for k in range(1, len(poly) - 1)]
    if not triangles:
        raise ValueError("the file has no faces")
    return compact(np.array(points, dtype=np.float64), np.array(triangles, dtype=np.int64))


def read_obj(path):
    points, polygons = [], []
    with open(path) as f:
        for line in f:
            words = line.split()
            if words and words[0] == "v":
                points.append([float(w) for w in words[1:4]])
            elif words and words[0] == "f":
                polygons.append([obj_index(w, len(points)) for w in words[1:]])
    return points, polygons


def obj_index(token, vertices_so_far):
    i = int(token.split("/")[0])
    index = i - 1 if i > 0 else vertices_so_far + i
    if i == 0 or not 0 <= index < vertices_so_far:
        raise ValueError("face corner %r names no vertex" % token)
    return index


def read_off(path):
    with open(path) as f:
        words = [w for line in f for w in line.split("#")[0].split()]
    if not words or words[0] != "OFF":
        raise ValueError("the first word is not OFF (only ASCII OFF is read)")
    nv, nf, at = int(words[1]), int(words[2]), 4
    points = [[float(w) for w in words[at + 3 * i: at + 3 * i + 3]] for i in range(nv)]
    at += 3 * nv
    polygons = []
    for _ in range(nf):
        n = int(words[at])
        polygons.append([int(w) for w in words[at + 1: at + 1 + n]])
        at += 1 + n
    return points, polygons


def compact(points, triangles):
    used = np.unique(triangles)
    renumber = np.full(len(points), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    return points[used], renumber[triangles]


def subdivide(points, triangles):
    """One 1→4 midpoint split, numbered as peer_cgal does: midpoints in order of first use,
    (a, b, c) → (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)."""
    n, m = len(points), len(triangles)
    a, b, c = triangles.T
    ends = np.stack([np.stack([a, b], 1), np.stack([b, c], 1), np.stack([c, a], 1)], 1).reshape(-1, 2)
    lo, hi = ends.min(1), ends.max(1)
    keys, first, inverse = np.unique(lo * n + hi, return_index=True, return_inverse=True)
    rank = np.empty(len(keys), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(keys))
    middles = np.empty((len(keys), 3))
    middles[rank] = (points[keys // n] + points[keys % n]) / 2
    ab, bc, ca = (n + rank[inverse.reshape(-1)]).reshape(m, 3).T
    finer = np.stack([np.stack(t, 1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))], 1)
    return np.concatenate([points, middles]), finer.reshape(-1, 3)


def write_obj(path, points, triangles):
    with open(path, "w") as f:
        np.savetxt(f, points, fmt="v %.17g %.17g %.17g")
        np.savetxt(f, triangles + 1, fmt="f %d %d %d")


# ---------------------------------------------------------------- processes

def thp_mode():
    """The kernel's transparent huge page mode ("always", "madvise", "never"), or "" when unknown."""
    try:
        with open("/sys/kernel/mm/transparent_hugepage/enabled") as f:
            line = f.read()
    except OSError:
        return ""
    return line[line.find("[") + 1:line.find("]")] if "[" in line and "]" in line else ""


def peer_environment():
    """The peers' environment: glibc's malloc on huge pages as ricci runs (cli/huge_pages.h), so that
    neither side pays 4 kB page faults the other does not."""
    env = dict(os.environ)
    tunables = env.get("GLIBC_TUNABLES", "")
    if thp_mode() == "madvise" and "glibc.malloc.hugetlb" not in tunables and env.get("RICCI_HUGE_PAGES") != "0":
        env["GLIBC_TUNABLES"] = (tunables + ":" if tunables else "") + "glibc.malloc.hugetlb=1"
    return env


def allocator_line():
    env = peer_environment()
    tunables = env.get("GLIBC_TUNABLES", "")
    return "glibc.malloc.hugetlb=1 for every process (ricci sets it itself; the peers get it from this script)" \
        if "glibc.malloc.hugetlb=1" in tunables else "glibc's default (4 kB pages unless the kernel's THP mode is always)"


def run_process(cmd, env=None):
    """Runs cmd to its end: {rc, wall (s, perf_counter around the process), rss_kb (ru_maxrss), out, err}."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        try:
            p = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out, stderr=err, env=env)
        except OSError as e:
            return {"rc": None, "wall": None, "rss_kb": None, "out": "", "err": str(e)}
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - start
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return {"rc": p.returncode, "wall": wall, "rss_kb": usage.ru_maxrss,
                "out": out.read().decode(errors="replace"), "err": err.read().decode(errors="replace")}


def failure(run, detail=None):
    """A failed run's status: detail (the program's own message), else its last line on stderr."""
    if run["rc"] is None:
        return "cannot start: " + run["err"]
    last = detail or (run["err"].strip().splitlines() or [""])[-1]
    return ("exit %d: %s" % (run["rc"], last)).strip()


def parse_json(text):
    try:
        return json.loads(text)
    except ValueError:
        return None


def ricci_cmd(ricci, mesh, outdir, pictures=False):
    return [ricci, "uniformize", mesh, "-o", outdir] + ([] if pictures else ["--no-pictures"]) + ["--json", "-q"]


def ricci_round(ricci, mesh, scratch, pictures=False):
    outdir = tempfile.mkdtemp(prefix="ricci-out-", dir=scratch)
    run = run_process(ricci_cmd(ricci, mesh, outdir, pictures))
    shutil.rmtree(outdir, ignore_errors=True)
    j = parse_json(run["out"])
    r = {"wall": run["wall"], "rss_kb": run["rss_kb"], "ok": run["rc"] == 0 and bool(j) and j.get("status") == "ok"}
    if not r["ok"]:
        r["status"] = failure(run, ricci_failure(j))
        return r
    r.update(status="ok", timings=j.get("timings") or {}, total_seconds=j.get("total_seconds"),
             iterations=j.get("iterations"), distortion=(j.get("angle_distortion") or {}).get("mean"),
             flipped=(j.get("layout") or {}).get("flipped_faces"),
             edge_error=(j.get("layout") or {}).get("max_edge_length_error"))
    return r


def ricci_failure(j):
    if not j:
        return None
    stage = " (stage %s)" % j["failed_stage"] if j.get("failed_stage") else ""
    return "%s: %s%s" % (j.get("status"), j.get("message"), stage)


def peer_cmd(peer, name, mesh, k):
    return [peer, "--peers", name, "--subdivide", str(k), "--json", mesh]


def peer_round(peer, name, mesh, k, counts):
    run = run_process(peer_cmd(peer, name, mesh, k), env=peer_environment())
    j = parse_json(run["out"])
    r = {"wall": run["wall"], "rss_kb": run["rss_kb"], "ok": False}
    if not j or not j.get("peers"):
        r["status"] = failure(run)
        return r
    check_counts(mesh, k, counts, (j.get("faces"), j.get("vertices")))
    result = j["peers"][0]
    r["ok"] = run["rc"] == 0 and result.get("status") == "ok"
    r["status"] = result.get("status") if r["ok"] else failure(run, str(result.get("status")))
    r.update(seconds=result.get("seconds"), distortion=(result.get("angle_distortion") or {}).get("mean"),
             flipped=result.get("flipped"), cgal_version=j.get("cgal_version"))
    return r


def check_counts(mesh, k, ours, theirs):
    if tuple(ours) != tuple(theirs):
        sys.exit("bench_peers: %s subdivided %d times: this script has %d faces, %d vertices but peer_cgal "
                 "reports %s faces, %s vertices; the comparison would not be on the same mesh"
                 % (mesh, k, ours[0], ours[1], theirs[0], theirs[1]))


# ---------------------------------------------------------------- one (mesh, K)

def best(rounds):
    """The round with the least process wall time among the successful ones (else the last round),
    with the failed-round count and, for peers, the least parameterize() time over the rounds."""
    ok = [r for r in rounds if r["ok"]]
    chosen = dict(min(ok, key=lambda r: r["wall"]) if ok else rounds[-1])
    chosen["failed_rounds"] = len(rounds) - len(ok)
    chosen["rounds"] = len(rounds)
    if ok and "seconds" in chosen:
        chosen["seconds"] = min(r["seconds"] for r in ok)
    return chosen


def mesh_for_ricci(path, k, points, triangles, scratch):
    """The file ricci reads for level k (the original for k = 0) and the (faces, vertices) counts."""
    for _ in range(k):
        points, triangles = subdivide(points, triangles)
    if k == 0:
        return path, (len(triangles), len(points))
    stem = os.path.splitext(os.path.basename(path))[0]
    out = os.path.join(scratch, "%s-subdivided-%d.obj" % (stem, k))
    write_obj(out, points, triangles)
    return out, (len(triangles), len(points))


def bench_case(args, path, k, mesh, peer_built, scratch):
    case = {"mesh": os.path.basename(path), "k": k, "faces": None, "ricci": None, "lscm": None, "dcm": None,
            "pictures": None}
    if isinstance(mesh, str):
        case["error"] = "cannot read the mesh: " + mesh
        return case
    ricci_mesh, counts = mesh_for_ricci(path, k, mesh[0], mesh[1], scratch)
    case["faces"] = counts[0]
    runs = {"ricci": [], "lscm": [], "dcm": [], "pictures": []}
    for i in range(args.rounds):
        runs["ricci"].append(ricci_round(args.ricci, ricci_mesh, scratch))
        if args.pictures:
            runs["pictures"].append(ricci_round(args.ricci, ricci_mesh, scratch, pictures=True))
        peers_now = peer_built and (args.peer_max_k is None or k <= args.peer_max_k)
        for name in PEERS if peers_now else ():
            runs[name].append(peer_round(args.peer, name, path, k, counts))
        progress(case, i, args.rounds, runs)
    for name, rounds in runs.items():
        case[name] = best(rounds) if rounds else None
    ok = [r for r in runs["pictures"] if r["ok"] and "pictures" in r["timings"]]
    if ok:
        case["pictures"]["least_pictures"] = min(r["timings"]["pictures"] for r in ok)
    if ricci_mesh != path:
        os.remove(ricci_mesh)
    return case


def progress(case, i, rounds, runs):
    parts = ["%s %s" % (name, "%.2f s" % r[-1]["wall"] if r[-1]["ok"] else "FAILED")
             for name, r in runs.items() if r]
    print("%s K=%d round %d/%d: %s" % (case["mesh"], case["k"], i + 1, rounds, ", ".join(parts)),
          file=sys.stderr, flush=True)


# ---------------------------------------------------------------- report

def num(x, fmt):
    return DASH if x is None else fmt % x


def cell(r, text):
    """text for a successful run; the run's failure (or "not run": not built, or above --peer-max-k)."""
    if r is None:
        return "not run"
    return text if r["ok"] else "failed"


def status_cell(case):
    if case.get("error"):
        return escape(case["error"])
    notes = ["%s: %s (%d of %d rounds failed)" % (name, case[name]["status"], case[name]["failed_rounds"],
                                                   case[name]["rounds"])
             for name in ("ricci",) + PEERS if case[name] and case[name]["failed_rounds"]]
    return escape("; ".join(notes)) or "ok"


def escape(text):
    text = " ".join(str(text).split())
    return (text[:160] + "…" if len(text) > 160 else text).replace("|", "\\|")


def ratio(a, b):
    return DASH if not a or not b or not a["ok"] or not b["ok"] else "%.2f" % (a["wall"] / b["wall"])


def peer_seconds(p):
    return cell(p, "%.3f (%.3f)" % (p["wall"], p["seconds"]) if p and p["ok"] else "")


def megabytes(p):
    return cell(p, num(p["rss_kb"] / 1024 if p and p["rss_kb"] else None, "%.0f"))


def distortion(p):
    return cell(p, num(p.get("distortion") if p else None, "%.4f"))


def main_row(case):
    r, lscm, dcm, faces = case["ricci"], case["lscm"], case["dcm"], case["faces"]
    if r is None:
        return [case["mesh"], str(case["k"]), num(faces, "%d")] + [DASH] * 16 + [status_cell(case)]
    whole, flow = (r["wall"], r["timings"].get("flow")) if r["ok"] else (None, None)
    flips = "/".join(str(p["flipped"]) if p and p["ok"] else DASH for p in (r, lscm, dcm))
    return [case["mesh"], str(case["k"]), num(faces, "%d"),
            cell(r, num(whole, "%.3f")), cell(r, num(flow, "%.3f")),
            num(whole / flow if whole and flow else None, "%.2f"),
            num(whole - flow if whole and flow is not None else None, "%.3f"),
            megabytes(r), cell(r, num(r["rss_kb"] * 1024 / faces if r["rss_kb"] else None, "%.0f")),
            peer_seconds(lscm), peer_seconds(dcm), ratio(r, lscm), ratio(r, dcm), megabytes(lscm), megabytes(dcm),
            distortion(r), distortion(lscm), distortion(dcm), flips, status_cell(case)]


MAIN_HEADER = ["mesh", "K", "faces", "ricci s", "flow s", "whole/flow", "other s", "ricci MB", "ricci B/face",
               "LSCM s (param.)", "DCM s (param.)", "ricci/LSCM", "ricci/DCM", "LSCM MB", "DCM MB",
               "dist. ricci", "dist. LSCM", "dist. DCM", "flipped ricci/LSCM/DCM", "status"]

MAIN_NOTES = """\
- mesh, K: the input file, midpoint-subdivided K times (1→4 triangles each time); faces: its triangles.
- ricci s: wall time of the whole `ricci uniformize` process (time.perf_counter around it), best round.
- flow s: ricci's own `flow` stage timing in that round; whole/flow: ricci s ÷ flow s; other s: ricci s − flow s \
(every other stage, process start and exit).
- ricci MB, LSCM MB, DCM MB: peak resident memory of the process (ru_maxrss from os.wait4), MB = 2^20 bytes; \
ricci B/face: ricci's peak bytes per face.
- LSCM s, DCM s: wall time of the whole peer_cgal process running that one map, best round (it reads and \
subdivides the mesh itself); in parentheses, its parameterize() call alone (least over the rounds).
- ricci/LSCM, ricci/DCM: ricci s ÷ LSCM s and ricci s ÷ DCM s (process wall times); above 1, ricci is slower.
- dist.: mean angle distortion over all corners, |log(θ_uv/θ_3d)| (θ_3d the corner's angle on the mesh, \
θ_uv in the map), as each program reports it.
- flipped: faces of the map with negative signed area (ricci: its layout's flipped faces).
- status: ok, or the failure and the count of failed rounds; "failed" cells had no successful round; \
"not run": no peer_cgal, or K above --peer-max-k."""


def stage_names(cases):
    names = []
    for case in cases:
        r = case["ricci"]
        for name in (r["timings"] if r and r["ok"] else ()):
            if name not in names:
                names.append(name)
    return names


def stage_row(case, names):
    r = case["ricci"]
    if not r or not r["ok"]:
        return [case["mesh"], str(case["k"])] + ["failed" if r else DASH] * (len(names) + 4)
    return ([case["mesh"], str(case["k"])] + [num(r["timings"].get(n), "%.4f") for n in names]
            + [num(r["total_seconds"], "%.4f"), "%.4f" % r["wall"], num(r["iterations"], "%d"),
               num(r["edge_error"], "%.1e")])


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def machine():
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            model = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), model)
    except OSError:
        pass
    return "%s, %d logical CPUs" % (model, os.cpu_count() or 0)


def ricci_commit():
    try:
        out = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
        return out.stdout.strip() or "unknown"
    except OSError:
        return "unknown"


def shown(path):
    full = os.path.abspath(path)
    return os.path.relpath(full, ROOT) if full.startswith(ROOT + os.sep) else full


def header(args, cases, peer_built):
    version = next((c[p]["cgal_version"] for c in cases for p in PEERS if c[p] and c[p].get("cgal_version")), None)
    cgal = " CGAL %s." % version if version else ""
    if peer_built:
        peer_line = "`%s` (NAME: lscm or dcm; MESH: the original file)" % shlex.join(
            peer_cmd(shown(args.peer), "NAME", "MESH", "K"))
    else:
        peer_line = "peer_cgal not built (%s): no peer columns" % shown(args.peer)
    return "\n".join([
        "# ricci uniformize vs CGAL LSCM and DCM",
        "",
        "%s; %s; ricci %s.%s Best of %d alternated rounds (ricci, LSCM, DCM, each its own process)." % (
            machine(), datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            ricci_commit(), cgal, args.rounds),
        "",
        "- report: `python3 tools/bench_peers.py %s`" % shlex.join(sys.argv[1:]),
        "- ricci: `%s` (MESH: the original for K = 0, else a subdivided OBJ this script writes)"
        % shlex.join(ricci_cmd(shown(args.ricci), "MESH", "OUTDIR")),
        "- peers: %s" % peer_line,
        "- allocator: %s; THP mode %s" % (allocator_line(), thp_mode() or "unknown"),
    ])


def pictures_row(case):
    r, p = case["ricci"], case["pictures"]
    with_pictures = p["wall"] if p and p["ok"] else None
    without = r["wall"] if r and r["ok"] else None
    return [case["mesh"], str(case["k"]), num(case["faces"], "%d"), num(p.get("least_pictures") if p else None, "%.3f"),
            cell(p, num(with_pictures, "%.3f")), cell(r, num(without, "%.3f")),
            num(with_pictures - without if with_pictures and without else None, "%.3f")]


def pictures_section(args, cases):
    if not args.pictures:
        return []
    return ["## ricci with its pictures", "",
            "`%s`, one more process per round after the one without pictures." % shlex.join(
                ricci_cmd(shown(args.ricci), "MESH", "OUTDIR", pictures=True)), "",
            table(["mesh", "K", "faces", "pictures s", "process s with pictures", "process s without",
                   "difference s"], [pictures_row(c) for c in cases]), "",
            "pictures s: ricci's own `pictures` timing (drawing and encoding them, before the files are written; the least over the rounds); "
            "process s: the best round's wall time of each process; difference: with − without.", ""]


def report(args, cases, peer_built):
    names = stage_names(cases)
    stage_header = ["mesh", "K"] + names + ["total_seconds", "process s", "iterations", "max edge length error"]
    return "\n".join([
        header(args, cases, peer_built), "",
        table(MAIN_HEADER, [main_row(c) for c in cases]), "", MAIN_NOTES, "",
        "## ricci's stages (seconds, best round)", "",
        table(stage_header, [stage_row(c, names) for c in cases]), "",
        "Each stage column is ricci's own `timings` entry; total_seconds: ricci's own total; process s: the "
        "process wall time; iterations: flow iterations; max edge length error: the layout's "
        "`max_edge_length_error`.", ""] + pictures_section(args, cases))


def write_atomically(path, text):
    folder = os.path.dirname(os.path.abspath(path))
    fd, temp = tempfile.mkstemp(prefix=".bench_peers-", suffix=".md", dir=folder)
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(temp, path)
    except BaseException:
        os.unlink(temp)
        raise


# ---------------------------------------------------------------- main

def load(path):
    try:
        return read_mesh(path)
    except (OSError, ValueError, IndexError) as e:
        return str(e) or type(e).__name__


def main(argv):
    args = parse_args(argv)
    peer_built = os.access(args.peer, os.X_OK)
    cases = []
    with tempfile.TemporaryDirectory(prefix="bench_peers-") as scratch:
        for path in args.mesh:
            mesh = load(path)
            cases += [bench_case(args, path, k, mesh, peer_built, scratch) for k in args.subdivide]
    text = report(args, cases, peer_built)
    if args.out:
        write_atomically(args.out, text)
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
