"""ricci batch and ricci summarize: a LocalCluster run with a worker killed mid-run, resume,
failures of every kind recorded, shards, manifests and globs."""

import csv
import os
import signal
import subprocess
import sys
import time

import psutil
import pytest

from conftest import CLI, FIXTURES, GOOD_FIXTURES, SHARED

SMALL_SHARED = ["genus0/brain.obj", "genus0/spot.obj", "genus0/decimated-max.obj", "genus1/kitten-5k.off",
                "genus2/eight.off", "genus2/eight-11k.off", "genus2/skull_low_resolution.obj",
                "genus3plus/3holes.off", "genus3plus/fertility.off"]
BAD = ["three-faces-on-edge.obj", "moebius.obj", "truncated.off", "no-faces.off"]


def batch_cmd(*args):
    return [sys.executable, "-m", "ricci", "batch", *map(str, args)]


def summary(outdir):
    with open(os.path.join(outdir, "summary.csv"), encoding="utf-8") as f:
        return {row["key"]: row for row in csv.DictReader(f)}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """Fixtures and the small shared meshes of genus 0 to 5 (when ../shared is there), linked."""
    root = tmp_path_factory.mktemp("dataset")
    for name in GOOD_FIXTURES:
        os.symlink(FIXTURES / name, root / name)
    if SHARED.is_dir():
        for rel in SMALL_SHARED:
            if (SHARED / rel).exists():
                (root / os.path.dirname(rel)).mkdir(exist_ok=True)
                os.symlink(SHARED / rel, root / rel)
    return root


def _keys(root):
    out = []
    for dirpath, _, files in os.walk(root):
        for f in files:
            out.append(os.path.splitext(os.path.relpath(os.path.join(dirpath, f), root))[0])
    return sorted(out)


def _kill_a_busy_worker(batch, outdir, deadline):
    """SIGKILLs the Dask worker running a mesh once some mesh has finished; returns its pid."""
    while time.monotonic() < deadline and batch.poll() is None:
        done = any(f == "report.json" for _, _, fs in os.walk(outdir) for f in fs)
        if done:
            for p in psutil.Process(batch.pid).children(recursive=True):
                try:
                    if "ricci._one" in " ".join(p.cmdline()):
                        worker = p.parent()
                        if worker.pid != batch.pid:
                            worker.send_signal(signal.SIGKILL)
                            return worker.pid
                except psutil.NoSuchProcess:
                    continue
        time.sleep(0.01)
    return None


def test_batch_on_a_local_cluster_survives_a_killed_worker_and_resumes(dataset, tmp_path):
    outdir = tmp_path / "out"
    batch = subprocess.Popen(batch_cmd(dataset, "-o", outdir, "--workers", "2", "--no-pictures"),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed = _kill_a_busy_worker(batch, outdir, time.monotonic() + 300)
    out, err = batch.communicate(timeout=900)
    assert killed is not None, "no worker was busy while the batch ran: " + err
    rows = summary(outdir) if os.path.isfile(outdir / "summary.csv") else {}
    # On failure, say which mesh ended how (the progress lines alone do not).
    failures = {k: (r["status"], r["message"]) for k, r in rows.items() if r["status"] != "ok"}
    assert batch.returncode == 0, (err, failures)
    keys = _keys(dataset)
    assert sorted(rows) == keys
    for key, row in rows.items():
        assert row["status"] == "ok", (key, row["message"])
        assert os.path.isfile(outdir / key / "mesh.obj") and os.path.isfile(outdir / key / "metric.csv")
        assert float(row["max_curvature_error"]) < 1e-10
    # Gauss–Bonnet per mesh: the genus in the report matches χ.
    for row in rows.values():
        assert int(row["mesh.euler_characteristic"]) == 2 - 2 * int(row["mesh.genus"]) - int(row["mesh.boundary_loops"])
    # Again with --resume: nothing runs, nothing is rewritten.
    stamps = {k: os.stat(outdir / k / "report.json").st_mtime_ns for k in rows}
    again = subprocess.run(batch_cmd(dataset, "-o", outdir, "--workers", "2", "--resume", "--no-pictures"),
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert f"{len(keys)} meshes, {len(keys)} already complete, 0 to run" in again.stderr
    assert stamps == {k: os.stat(outdir / k / "report.json").st_mtime_ns for k in rows}


def test_failures_of_every_kind_are_recorded_and_do_not_stop_the_rest(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    for name in BAD + ["torus.obj", "disk.obj", "genus3.obj"]:
        os.symlink(FIXTURES / ("bad" if name in BAD else "") / name, data / name)
    env = dict(os.environ, RICCI_BATCH_TEST_ABORT="disk.obj", RICCI_BATCH_TEST_HANG="genus3.obj")
    outdir = tmp_path / "out"
    # genus3's process never finishes; every other mesh ends well within the timeout, however
    # loaded the machine.
    r = subprocess.run(batch_cmd(data, "-o", outdir, "--workers", "0", "--timeout", "10", "--no-pictures"),
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 1, r.stderr
    rows = summary(outdir)
    assert rows["three-faces-on-edge"]["status"] == "non_manifold_edge"
    assert rows["moebius"]["status"] == "non_orientable"
    assert rows["truncated"]["status"] == "parse_error"
    assert rows["no-faces"]["status"] == "no_faces"
    assert "three-faces-on-edge.obj" in rows["three-faces-on-edge"]["message"]
    assert rows["disk"]["status"] == "crashed" and "SIGABRT" in rows["disk"]["message"]
    assert rows["genus3"]["status"] == "timeout" and "killed" in rows["genus3"]["message"]
    assert rows["torus"]["status"] == "ok"
    # --resume keeps the failures; --retry-failed runs them again (now without the abort and the hang).
    r = subprocess.run(batch_cmd(data, "-o", outdir, "--workers", "0", "--resume", "--no-pictures"),
                       capture_output=True, text=True, timeout=300)
    assert "7 meshes, 7 already complete, 0 to run" in r.stderr
    r = subprocess.run(batch_cmd(data, "-o", outdir, "--workers", "0", "--resume", "--retry-failed", "--no-pictures"),
                       capture_output=True, text=True, timeout=300)
    rows = summary(outdir)
    assert rows["disk"]["status"] == "ok" and rows["genus3"]["status"] == "ok" and rows["torus"]["status"] == "ok"
    assert rows["moebius"]["status"] == "non_orientable"
    assert not os.path.exists(outdir / "disk" / ".report.json")


def test_shards_split_a_dataset_and_summarize_joins_them(tmp_path):
    outdir = tmp_path / "out"
    for i in range(3):
        r = subprocess.run(batch_cmd(FIXTURES, "-o", outdir, "--shard", f"{i}/3", "--workers", "0", "--no-pictures",
                                     "--seed-checks", "0", "-q"), capture_output=True, text=True, timeout=300)
        assert r.returncode in (0, 1), r.stderr
    os.remove(outdir / "summary.csv")
    r = subprocess.run([CLI, "summarize", str(outdir)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    rows = summary(outdir)
    expected = sorted(os.path.splitext(os.path.relpath(os.path.join(d, f), FIXTURES))[0]
                      for d, _, fs in os.walk(FIXTURES) for f in fs if not f.endswith(".md"))
    assert sorted(rows) == expected
    for name in GOOD_FIXTURES:
        assert rows[os.path.splitext(name)[0]]["status"] == "ok"
    r = subprocess.run(batch_cmd(FIXTURES, "-o", outdir, "--shard", "3/3"), capture_output=True, text=True)
    assert r.returncode != 0 and "--shard 3/3" in r.stderr


def test_manifests_globs_and_the_cli_entry(tmp_path):
    manifest = tmp_path / "list.txt"
    manifest.write_text(f"path\n# two meshes\n{FIXTURES / 'torus.obj'}\n{FIXTURES / 'genus2.obj'}, a note\n")
    outdir = tmp_path / "out"
    r = subprocess.run([CLI, "batch", str(manifest), str(FIXTURES / "disk*.obj"), "-o", str(outdir),
                        "--workers", "0", "--no-pictures", "--seed-checks", "0"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert sorted(summary(outdir)) == ["disk", "genus2", "torus"]
    bad = tmp_path / "bad.txt"
    bad.write_text("missing.obj\n")
    r = subprocess.run(batch_cmd(bad, "-o", tmp_path / "o2"), capture_output=True, text=True)
    assert r.returncode != 0 and "line 1: no such file missing.obj" in r.stderr


def test_batch_on_a_running_scheduler(tmp_path):
    """The cluster path: a scheduler and a worker started apart (as on other machines, here on
    loopback), the batch pointed at the scheduler's address."""
    scheduler_file = tmp_path / "scheduler.json"
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file", str(scheduler_file)], **quiet)]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        import json
        address = json.loads(scheduler_file.read_text())["address"]
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nworkers", "2",
                                       "--nthreads", "1", "--no-dashboard"], **quiet))
        outdir = tmp_path / "out"
        r = subprocess.run(batch_cmd(FIXTURES / "torus.obj", FIXTURES / "genus2.obj", FIXTURES / "icosphere.obj",
                                     "-o", outdir, "--scheduler", address, "--no-pictures"),
                           capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        rows = summary(outdir)
        assert sorted(rows) == ["genus2", "icosphere", "torus"]
        assert all(row["status"] == "ok" for row in rows.values())
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
