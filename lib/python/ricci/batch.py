"""ricci batch and ricci summarize: uniformize whole datasets.

    ricci batch INPUT [INPUT ...] -o OUTDIR [--workers N] [--scheduler ADDRESS] [--shard I/N]
                [--timeout S] [--resume] [--retry-failed] [uniformize options]
    ricci summarize OUTDIR

INPUT is a directory (every mesh file below it), a glob pattern, a manifest (a text file with one
mesh path per line, relative to the manifest; '#' comments) or a mesh file. Each mesh gets its own
folder OUTDIR/KEY, KEY being its path relative to the input without the extension, holding what
`ricci uniformize -o OUTDIR/KEY` writes, report.json included. A mesh that fails gets a report.json
with its status and message (and the partial report when the pipeline started); a mesh that runs
past --timeout is killed and recorded with status "timeout", one whose process dies with status
"crashed". Neither stops the rest.

Every mesh runs in a process of its own (started by a Dask task, or directly with --workers 0), so
a crash or a timeout costs only that mesh, and a Dask worker that is killed loses no finished
result: each result is on disk, complete, the moment its task ends, and the scheduler runs the
lost task again elsewhere. --resume skips meshes whose report.json is complete (an "ok" report
whose outputs all exist, or a failure report unless --retry-failed).

Dask: a LocalCluster of --workers processes (default: the number of cores, at most the number of
meshes) unless --scheduler names a running scheduler (tcp://host:8786), whose workers must import
the same ricci package and see INPUT and OUTDIR at the same paths. --shard I/N (0 <= I < N) keeps
every N-th mesh starting at the I-th in sorted order, so N independent jobs (a Slurm array, GNU
parallel) split a dataset; --workers 0 runs without Dask, one mesh after another.

At the end (and with `ricci summarize OUTDIR`) OUTDIR/summary.csv gets one row per report.json:
its key, then every scalar of the report (nested keys joined by '.').
"""

import argparse
import csv
import glob
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time

MESH_EXTENSIONS = (".obj", ".off", ".ply", ".stl", ".gii")
OVERLAY_SUFFIXES = (".func.gii", ".shape.gii", ".label.gii", ".time.gii")
FREESURFER_MAGIC = b"\xff\xff\xfe"
FAILED = "failed"  # statuses other than "ok" come from the library, or are "timeout" / "crashed"


# ---- inputs ----------------------------------------------------------------------------------

def _is_mesh_file(path):
    low = path.lower()
    if low.endswith(OVERLAY_SUFFIXES):
        return False
    if low.endswith(MESH_EXTENSIONS):
        return True
    if os.path.splitext(low)[1] in (".txt", ".csv", ".json", ".lst", ".md", ".png", ".svg", ".html"):
        return False
    try:  # FreeSurfer surfaces have no extension ("lh.white"): recognised by their magic number
        with open(path, "rb") as f:
            return f.read(3) == FREESURFER_MAGIC
    except OSError:
        return False


def _key(rel):
    root, ext = os.path.splitext(rel)
    if ext.lower() == ".gii" and root.lower().endswith(".surf"):
        root = root[:-5]
    return root.replace(os.sep, "/")


def _walk(directory, exclude):
    out = []
    for dirpath, dirnames, filenames in os.walk(directory):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith(".")
                             and os.path.realpath(os.path.join(dirpath, d)) != exclude)
        for name in sorted(filenames):
            p = os.path.join(dirpath, name)
            if _is_mesh_file(p):
                out.append((p, _key(os.path.relpath(p, directory))))
    return out


def _manifest(path):
    base = os.path.dirname(os.path.abspath(path))
    out = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            entry = line.split("#", 1)[0].strip().split(",", 1)[0].strip()
            if not entry or (number == 1 and entry.lower() == "path"):
                continue
            p = entry if os.path.isabs(entry) else os.path.join(base, entry)
            if not os.path.isfile(p):
                raise SystemExit(f"ricci batch: {path}: line {number}: no such file {entry}")
            out.append((p, _key(entry if not os.path.isabs(entry) else os.path.basename(entry))))
    return out


def find_meshes(inputs, outdir):
    """[(path, key)] for the inputs, sorted by key; keys made unique."""
    exclude = os.path.realpath(outdir)
    found = []
    for item in inputs:
        if any(c in item for c in "*?["):
            matches = sorted(p for p in glob.glob(item, recursive=True) if os.path.isfile(p) and _is_mesh_file(p))
            if not matches:
                raise SystemExit(f"ricci batch: {item}: no mesh file matches")
            prefix = item.split("*")[0].split("?")[0].split("[")[0]
            base = prefix if prefix.endswith(os.sep) else os.path.dirname(prefix)
            found += [(p, _key(os.path.relpath(p, base or "."))) for p in matches]
        elif os.path.isdir(item):
            found += _walk(item, exclude)
        elif os.path.isfile(item):
            if _is_mesh_file(item):
                found.append((item, _key(os.path.basename(item))))
            else:
                found += _manifest(item)
        else:
            raise SystemExit(f"ricci batch: {item}: no such file or directory")
    seen, out = {}, []
    for path, key in found:
        k = key
        if k in seen:
            k = f"{key}_{os.path.splitext(path)[1].lstrip('.').lower() or 'mesh'}"
            n = 2
            while k in seen:
                k, n = f"{key}_{n}", n + 1
        seen[k] = path
        out.append((path, k))
    return sorted(out, key=lambda pk: pk[1])


def shard(meshes, spec):
    """Every N-th mesh from the I-th, for spec "I/N"."""
    try:
        i, n = (int(x) for x in spec.split("/"))
    except ValueError:
        raise SystemExit(f"ricci batch: --shard {spec}: expected I/N with integers 0 <= I < N")
    if n < 1 or not 0 <= i < n:
        raise SystemExit(f"ricci batch: --shard {spec}: expected 0 <= I < N")
    return meshes[i::n]


# ---- one mesh ----------------------------------------------------------------------------------

def read_report(folder):
    try:
        with open(os.path.join(folder, "report.json"), encoding="utf-8") as f:
            report = json.load(f)
    except (OSError, ValueError):
        return None
    return report if isinstance(report, dict) and "status" in report else None


def is_complete(folder, retry_failed):
    report = read_report(folder)
    if report is None:
        return False
    if report["status"] != "ok":
        return not retry_failed
    return all(os.path.isfile(os.path.join(folder, name)) for name in report.get("outputs", []))


def write_failure(folder, report):
    """report.json alone in `folder` (an earlier ricci folder there is replaced), atomically."""
    if os.path.isdir(folder) and (os.listdir(folder) == [] or os.path.isfile(os.path.join(folder, "report.json"))):
        shutil.rmtree(folder)
    os.makedirs(folder, exist_ok=True)
    tmp = os.path.join(folder, f".report.json.{os.getpid()}")
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(report, f, indent=2)
        f.write("\n")
    os.replace(tmp, os.path.join(folder, "report.json"))


def _die_with_parent():
    # The mesh's process ends with the task's process (a killed Dask worker leaves no orphan
    # writing into OUTDIR while the task runs again elsewhere).
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


RUN_MARK = ".ricci-batch-run"  # in a mesh's folder: the batch run that wrote it


def run_one(path, folder, options, timeout=None, threads=None, run_id=None):
    """Uniformizes one mesh in a child process into `folder`; returns {status, message, seconds}.
    With `run_id`, a folder this very batch run already completed is not written again: Dask runs a
    task again when the worker holding its finished result dies, and the rewrite would race with
    the summary reading that folder."""
    start = time.monotonic()
    if run_id is not None:
        try:
            with open(os.path.join(folder, RUN_MARK), encoding="utf-8") as f:
                done = f.read() == run_id
        except OSError:
            done = False
        report = read_report(folder) if done else None
        if report is not None:
            return {"status": report["status"], "message": report.get("message", ""), "seconds": 0.0}
    result = _run_one(path, folder, options, timeout, threads, start)
    if run_id is not None and read_report(folder) is not None:
        with open(os.path.join(folder, RUN_MARK), "w", encoding="utf-8") as f:
            f.write(run_id)
    return result


def _run_one(path, folder, options, timeout, threads, start):
    os.makedirs(os.path.dirname(folder) or ".", exist_ok=True)  # KEY may have folders (genus1/kitten)
    # What a process killed while writing this folder left beside it (its staging directory, or the
    # earlier folder it had moved aside): the run below writes the folder afresh.
    base = os.path.basename(folder)
    for left in glob.glob(os.path.join(glob.escape(os.path.dirname(folder) or "."), f".{glob.escape(base)}.ricci-*-*")):
        shutil.rmtree(left, ignore_errors=True)
    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ)
    env["PYTHONPATH"] = package_parent + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    if threads:
        env["OMP_NUM_THREADS"] = str(threads)
    cmd = [sys.executable, "-m", "ricci._one", path, folder, json.dumps(options)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            preexec_fn=_die_with_parent)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        # SIGTERM first: caught while OUTDIR is being written, it removes what was staged.
        proc.terminate()
        try:
            proc.communicate(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
        seconds = time.monotonic() - start
        message = f"{path}: no result within {timeout:g} s; the process was killed"
        write_failure(folder, {"status": "timeout", "message": message, "input": path, "batch_seconds": seconds})
        return {"status": "timeout", "message": message, "seconds": seconds}
    seconds = time.monotonic() - start
    if proc.returncode < 0 or (proc.returncode != 0 and read_report(folder) is None):
        how = (f"signal {-proc.returncode} ({signal.Signals(-proc.returncode).name})"
               if proc.returncode < 0 else f"exit code {proc.returncode}")
        tail = err.decode("utf-8", "replace").strip().splitlines()[-1:] or [""]
        message = f"{path}: the process ended with {how}" + (f": {tail[0]}" if tail[0] else "")
        write_failure(folder, {"status": "crashed", "message": message, "input": path, "batch_seconds": seconds})
        return {"status": "crashed", "message": message, "seconds": seconds}
    report = read_report(folder) or {}
    return {"status": report.get("status", FAILED), "message": report.get("message", ""), "seconds": seconds}


# ---- summary -------------------------------------------------------------------------------------

FIRST_COLUMNS = ["key", "input", "status", "message", "failed_stage"]


def _flatten(prefix, value, row):
    if isinstance(value, dict):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else k, v, row)
    elif value is None or isinstance(value, (str, int, float, bool)):
        row[prefix] = "" if value is None else value


def summarize(outdir):
    """Writes OUTDIR/summary.csv (one row per report.json below OUTDIR); returns (path, rows)."""
    rows = []
    for dirpath, dirnames, filenames in os.walk(outdir):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        if "report.json" in filenames and os.path.abspath(dirpath) != os.path.abspath(outdir):
            report = read_report(dirpath)
            if report is None:
                continue
            row = {"key": os.path.relpath(dirpath, outdir).replace(os.sep, "/")}
            _flatten("", report, row)
            rows.append(row)
    rows.sort(key=lambda r: r["key"])
    columns = [c for c in FIRST_COLUMNS if any(c in r for r in rows)]
    columns += sorted({k for r in rows for k in r} - set(columns))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, restval="", lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    path = os.path.join(outdir, "summary.csv")
    tmp = path + f".{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(buffer.getvalue())
    os.replace(tmp, path)
    return path, len(rows)


# ---- progress ------------------------------------------------------------------------------------

class Progress:
    """A progress line on stderr: a bar on a terminal, one line per finished mesh otherwise."""

    def __init__(self, total, quiet):
        self.total, self.done, self.failed, self.quiet = total, 0, 0, quiet
        self.start = time.monotonic()
        self.tty = sys.stderr.isatty()

    def update(self, key, result):
        self.done += 1
        self.failed += result["status"] != "ok"
        if self.quiet:
            return
        elapsed = time.monotonic() - self.start
        if self.tty:
            width = 30
            filled = width * self.done // max(1, self.total)
            sys.stderr.write(f"\rricci batch [{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total}"
                             f" ({self.failed} failed) {elapsed:.0f} s ")
            if self.done == self.total:
                sys.stderr.write("\n")
        else:
            sys.stderr.write(f"ricci batch: {self.done}/{self.total} {key}: {result['status']} "
                             f"({result['seconds']:.2f} s)\n")
        sys.stderr.flush()


# ---- the command ---------------------------------------------------------------------------------

def _parser():
    p = argparse.ArgumentParser(prog="ricci batch", description="Uniformize every mesh of a dataset (see `pydoc ricci.batch`).")
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="directory, glob pattern, manifest or mesh file")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR")
    p.add_argument("--workers", type=int, default=None, help="LocalCluster processes (default: cores); 0: no Dask")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--shard", default=None, metavar="I/N", help="every N-th mesh from the I-th (0-based)")
    p.add_argument("--timeout", type=float, default=None, metavar="S", help="seconds per mesh before it is killed")
    p.add_argument("--resume", action="store_true", help="skip meshes whose report.json is complete")
    p.add_argument("--retry-failed", action="store_true", help="with --resume: run failed meshes again")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    u = p.add_argument_group("options of ricci uniformize")
    u.add_argument("--geometry")
    u.add_argument("--scheme")
    u.add_argument("--target")
    u.add_argument("--boundary")
    u.add_argument("--tol", type=float)
    u.add_argument("--max-iter", dest="max_iterations", type=int)
    u.add_argument("--threads", type=int, help="OpenMP threads per mesh (default: cores / workers)")
    u.add_argument("--mesh-polygon", action="store_true", default=None)
    u.add_argument("--no-atlas", dest="atlas", action="store_false", default=None)
    u.add_argument("--base-candidates", type=int)
    u.add_argument("--seed-checks", type=int)
    u.add_argument("--cover-depth", type=int)
    u.add_argument("--cover-faces", type=int)
    u.add_argument("--patches", type=int)
    u.add_argument("--unit-box", action="store_true", default=None)
    u.add_argument("--no-flips", dest="flips", action="store_false", default=None)
    u.add_argument("--no-angle-relax", dest="angle_relax", action="store_false", default=None)
    u.add_argument("--no-circle-normalization", dest="circle_normalization", action="store_false", default=None)
    u.add_argument("--no-split-ears", dest="split_ears", action="store_false", default=None)
    u.add_argument("--largest-component", action="store_true", default=None)
    u.add_argument("--no-pictures", dest="pictures", action="store_false", default=None)
    return p


UNIFORMIZE_KEYS = ("geometry", "scheme", "target", "boundary", "tol", "max_iterations", "threads", "mesh_polygon",
                   "atlas", "base_candidates",
                   "seed_checks", "cover_depth", "cover_faces", "patches", "unit_box", "flips", "angle_relax",
                   "circle_normalization", "split_ears", "largest_component", "pictures")


def batch(args):
    outdir = args.output
    if args.timeout is not None and not args.timeout > 0:
        raise SystemExit("ricci batch: --timeout must be a positive number of seconds")
    if args.workers is not None and args.workers < 0:
        raise SystemExit("ricci batch: --workers must be 0 or more")
    if args.scheduler and args.workers == 0:
        raise SystemExit("ricci batch: --scheduler and --workers 0 contradict each other")
    meshes = find_meshes(args.inputs, outdir)
    if args.shard:
        meshes = shard(meshes, args.shard)
    os.makedirs(outdir, exist_ok=True)
    options = {k: getattr(args, k) for k in UNIFORMIZE_KEYS if getattr(args, k) is not None}
    threads = options.get("threads")
    todo = [(p, k) for p, k in meshes
            if not (args.resume and is_complete(os.path.join(outdir, k), args.retry_failed))]
    skipped = len(meshes) - len(todo)
    if not args.quiet:
        sys.stderr.write(f"ricci batch: {len(meshes)} meshes, {skipped} already complete, {len(todo)} to run\n")
    progress = Progress(len(todo), args.quiet)
    results = {}
    cores = os.cpu_count() or 1
    if args.workers == 0 or not todo:
        for path, key in todo:
            results[key] = run_one(path, os.path.join(outdir, key), options, args.timeout, threads)
            progress.update(key, results[key])
    else:
        from dask.distributed import Client, LocalCluster, as_completed
        cluster = None
        if args.scheduler:
            client = Client(args.scheduler)
        else:
            workers = args.workers or max(1, min(cores, len(todo)))
            threads = threads or max(1, cores // workers)
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=40)
            client = Client(cluster)
        try:
            run_id = f"{os.getpid()}-{time.time_ns()}"
            futures = {client.submit(run_one, path, os.path.join(os.path.abspath(outdir), key), options,
                                     args.timeout, threads, run_id, pure=False, key=f"ricci-{i}"): (path, key)
                       for i, (path, key) in enumerate(todo)}
            for future in as_completed(futures):
                path, key = futures.pop(future)
                try:
                    result = future.result()
                except Exception as e:  # the task itself failed: e.g. KilledWorker after repeated losses
                    message = f"{path}: the task failed: {type(e).__name__}: {e}"
                    write_failure(os.path.join(outdir, key), {"status": "crashed", "message": message, "input": path})
                    result = {"status": "crashed", "message": message, "seconds": 0.0}
                # Forget the task at once: a finished task whose (small) result lived on a worker
                # that dies later would otherwise run again and rewrite its folder.
                future.release()
                results[key] = result
                progress.update(key, result)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    path, rows = summarize(outdir)
    failed = sum(r["status"] != "ok" for r in results.values())
    if not args.quiet:
        sys.stderr.write(f"ricci batch: {len(results)} run, {failed} failed, {skipped} skipped; {path} ({rows} rows)\n")
    return 0 if failed == 0 else 1


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "summarize":
        p = argparse.ArgumentParser(prog="ricci summarize", description="OUTDIR/summary.csv from the report.json files below OUTDIR.")
        p.add_argument("outdir", metavar="OUTDIR")
        a = p.parse_args(argv[1:])
        if not os.path.isdir(a.outdir):
            sys.stderr.write(f"ricci summarize: {a.outdir}: no such directory\n")
            return 2
        path, rows = summarize(a.outdir)
        print(f"{path}: {rows} rows")
        return 0
    if argv and argv[0] == "batch":
        argv = argv[1:]
    return batch(_parser().parse_args(argv))
