"""The Python module against the command-line tool and against bad input."""

import os
import threading
import time

import numpy as np
import pytest

import ricci
from conftest import FIXTURES, GOOD_FIXTURES, SHARED, read_metric_csv, read_obj_uv, run_cli


@pytest.mark.parametrize("name", GOOD_FIXTURES)
def test_uniformize_matches_the_cli_bitwise(name, cli, tmp_path):
    path = FIXTURES / name
    run_cli("uniformize", path, "-o", tmp_path / "cli", "--no-pictures", "-q")
    u_cli, l_cli = read_metric_csv(tmp_path / "cli" / "metric.csv")
    V, F = ricci.read_mesh(path)
    r = ricci.uniformize(V, F)
    assert r.status == "ok"
    # u per validated vertex and the metric's edge lengths: the same doubles.
    assert r.u.tolist() == u_cli
    assert r.edge_lengths.tolist() == l_cli
    if r.uv is None:  # closed genus 0: the sphere
        sphere = [tuple(map(float, l.split()[1:4])) for l in open(tmp_path / "cli" / "sphere.obj") if l.startswith("v ")]
        assert [tuple(p) for p in r.sphere.tolist()] == sphere
    else:
        assert [tuple(c) for c in r.uv.reshape(-1, 2).tolist()] == read_obj_uv(tmp_path / "cli" / "mesh.obj")
    # The same files, and mesh.obj byte for byte, from write_outputs() of a run on the file.
    rp = ricci.uniformize(str(path))
    written = ricci.write_outputs(rp, tmp_path / "py", pictures=False)
    assert sorted(written) == sorted(os.listdir(tmp_path / "cli"))
    for f in ("mesh.obj", "metric.csv"):
        assert (tmp_path / "py" / f).read_bytes() == (tmp_path / "cli" / f).read_bytes(), f


@pytest.mark.parametrize("scheme", ["yamabe", "circle-packing", "inversive-distance"])
def test_flow_matches_the_cli_bitwise(scheme, cli, tmp_path):
    path = FIXTURES / "genus2.obj"
    run_cli("flow", path, "--scheme", scheme, "-o", tmp_path / "m.csv", "-q")
    u_cli, l_cli = read_metric_csv(tmp_path / "m.csv")
    V, F = ricci.read_mesh(path)
    f = ricci.flow(V, F, scheme=scheme)
    assert f.converged and f.status == "ok"
    assert f.u.tolist() == u_cli
    assert f.edge_lengths.tolist() == l_cli
    assert f.edges.shape == (len(l_cli), 2)
    assert f.iterations == len(f.history) and f.max_curvature_error < 1e-10
    assert f.report["status"] == "converged"


def test_results_are_read_only_views_and_consistent():
    r = ricci.uniformize(FIXTURES / "torus.obj", seed_checks=0)
    assert r.V.dtype == np.float64 and r.V.shape[1] == 3 and r.F.shape[1] == 3
    assert not r.u.flags.writeable
    with pytest.raises(ValueError):
        r.u[0] = 1.0
    # Gauss–Bonnet on the flow's own numbers: Σ K = 2πχ for the torus (χ = 0), K = K̄ to 1e-12.
    assert abs(r.K.sum()) < 1e-10
    assert np.max(np.abs(r.K - r.K_target)) < 1e-12
    assert r.generators["names"] == ["a1", "b1"] and r.generators["translation"].shape == (2, 2)
    assert r.relation_error < 1e-9
    assert set(r.timings) >= {"load", "flow", "cut", "layout"}
    assert r.report["mesh"]["genus"] == 1 and r.report["status"] == "ok"
    sv, sf = r.surface
    assert r.uv.shape == (sf.shape[0], 3, 2)


def test_hyperbolic_generators_are_su11():
    r = ricci.uniformize(FIXTURES / "genus2.obj", seed_checks=0)
    g = r.generators
    assert g["names"] == ["a1", "b1", "a2", "b2"]
    m = g["moebius"]
    det = m[:, 0, 0] * m[:, 1, 1] - m[:, 0, 1] * m[:, 1, 0]
    assert np.allclose(det, 1.0, atol=1e-9)
    # The relation of the deck group (deck.h): [A1^-1, B1][A2^-1, B2] = ±identity, [x, y] = x y x^-1 y^-1;
    # the other order is not the identity.
    inv = np.linalg.inv
    a1, b1, a2, b2 = m
    p = inv(a1) @ b1 @ a1 @ inv(b1) @ inv(a2) @ b2 @ a2 @ inv(b2)
    assert min(np.abs(p - np.eye(2)).max(), np.abs(p + np.eye(2)).max()) < 1e-6
    q = a1 @ b1 @ inv(a1) @ inv(b1) @ a2 @ b2 @ inv(a2) @ inv(b2)
    assert min(np.abs(q - np.eye(2)).max(), np.abs(q + np.eye(2)).max()) > 1e-3
    sig = ricci.signature(r)
    assert sig["genus"] == 2 and sig["systole"]["length"] > 0
    assert ricci.signature(FIXTURES / "genus2.obj")["systole"] == sig["systole"]


def test_info_matches_the_cli(cli):
    import json
    V, F = ricci.read_mesh(FIXTURES / "sphere-3holes.obj")
    info = ricci.info(V, F)
    j = json.loads(run_cli("info", FIXTURES / "sphere-3holes.obj", "--json").stdout)
    assert info["genus"] == j["genus"] and info["boundary_loops"] == j["boundary_loops"]
    assert info["euler_characteristic"] == j["euler_characteristic"] and info["faces"] == j["faces"]


# ---- refusals ----------------------------------------------------------------------------------

def _tetra():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int64)
    return V, F


@pytest.mark.parametrize("fn", [ricci.uniformize, ricci.flow, ricci.info])
def test_bad_arrays_are_refused(fn):
    V, F = _tetra()
    cases = [
        (V[:, :2], F, "invalid_argument", "shape (n, 3)"),
        (V, F[:, :2], "invalid_argument", "shape (m, 3)"),
        (V, F.astype(np.float64), "invalid_argument", "integers"),
        (V.astype(str), F, "invalid_argument", "real numbers"),
        (np.where(np.arange(12).reshape(4, 3) == 4, np.nan, V), F, "non_finite_coordinate", "vertex 1"),
        (np.where(np.arange(12).reshape(4, 3) == 0, np.inf, V), F, "non_finite_coordinate", "vertex 0"),
        (V, np.where(np.arange(12).reshape(4, 3) == 7, 4, F), "index_out_of_range", "face 2"),
        (V, np.where(np.arange(12).reshape(4, 3) == 0, -1, F), "index_out_of_range", "face 0"),
        (V, np.array([[0, 1, 2**40]]), "index_out_of_range", "face 0"),
        ([[0, 0, 0], [1, 0]], F, "invalid_argument", "V is not an array"),
        (V.astype(complex), F, "invalid_argument", "real numbers"),
        (V, F > 1, "invalid_argument", "integers"),
        (V, F.astype(object), "invalid_argument", "integers"),
        (np.zeros((0, 3)), np.zeros((0, 3), dtype=int), None, None),
    ]
    for v, f, status, words in cases:
        if status is None:  # well-formed but empty: the library's own refusal
            with pytest.raises(ricci.RicciError) as e:
                fn(v, f)
            assert e.value.status == "no_faces", e.value.message
            continue
        with pytest.raises(ricci.InvalidArrayError) as e:
            fn(v, f)
        assert e.value.status == status and words in e.value.message, (status, e.value.message)
        assert isinstance(e.value, ValueError)


def test_int32_and_lists_are_accepted():
    V, F = _tetra()
    a = ricci.info(V, F.astype(np.int32))
    b = ricci.info(V.tolist(), F.tolist())
    assert a == b and a["genus"] == 0 and a["closed"]


def test_library_failures_carry_their_status(tmp_path):
    with pytest.raises(ricci.RicciError) as e:
        ricci.uniformize(FIXTURES / "bad" / "three-faces-on-edge.obj")
    assert e.value.status == "non_manifold_edge" and "three-faces-on-edge.obj" in e.value.message
    with pytest.raises(ricci.RicciError) as e:
        ricci.read_mesh(tmp_path / "missing.obj")
    assert e.value.status == "file_not_found"
    with pytest.raises(ricci.RicciError) as e:
        ricci.flow(FIXTURES / "genus2.obj", max_iterations=1)
    assert e.value.status == "not_converged" and e.value.stage == "flow"
    assert e.value.result is not None and e.value.result.iterations == 1 and len(e.value.result.u) > 0
    with pytest.raises(ricci.RicciError) as e:
        ricci.uniformize(FIXTURES / "genus2.obj", geometry="euclidean")
    assert e.value.status == "infeasible_target" and e.value.stage == "target"
    partial = e.value.result  # the stages before the target: a validated mesh, no flow
    assert partial is not None and len(partial.V) == 798 and len(partial.u) == 0 and partial.uv is None
    assert partial.report["status"] == "infeasible_target"
    with pytest.raises(ricci.RicciError) as e:
        ricci.uniformize(FIXTURES / "genus2.obj", geometry="plane")
    assert e.value.status == "invalid_argument" and "unknown geometry" in e.value.message
    with pytest.raises(ricci.RicciError) as e:
        ricci.uniformize(FIXTURES / "torus.obj", tol=-1.0)
    assert e.value.status == "invalid_argument"
    with pytest.raises(ricci.RicciError) as e:
        ricci.uniformize(FIXTURES / "torus.obj", threads=-3)
    assert e.value.status == "invalid_argument"


def test_layout_refine_above_reaches_the_layout():
    # 0 refines every layout to its rounding floor: never less accurate than the default.
    default = ricci.uniformize(FIXTURES / "torus.obj", seed_checks=0)
    strict = ricci.uniformize(FIXTURES / "torus.obj", seed_checks=0, layout_refine_above=0.0)
    assert default.report["layout"]["polish_sweeps"] == 0
    assert strict.report["layout"]["max_edge_length_error"] <= default.report["layout"]["max_edge_length_error"]
    with pytest.raises(TypeError, match="layout_refine_above"):
        ricci.uniformize(FIXTURES / "torus.obj", layout_refine_above="small")


def test_bad_options_are_type_errors():
    with pytest.raises(TypeError, match="unknown option 'tolerance'"):
        ricci.uniformize(FIXTURES / "torus.obj", tolerance=1e-9)
    with pytest.raises(TypeError, match="option tol must be a number"):
        ricci.flow(FIXTURES / "torus.obj", tol="small")
    with pytest.raises(TypeError, match="option flips must be True or False"):
        ricci.uniformize(FIXTURES / "torus.obj", flips=1)
    with pytest.raises(TypeError):
        ricci.uniformize(FIXTURES / "torus.obj", np.zeros((3, 3)))
    with pytest.raises(TypeError, match="write_outputs"):
        ricci.write_outputs(ricci.flow(FIXTURES / "torus.obj"), "x")


def test_write_outputs_refuses_a_foreign_folder(tmp_path):
    r = ricci.uniformize(FIXTURES / "torus.obj", seed_checks=0)
    (tmp_path / "theirs").mkdir()
    (tmp_path / "theirs" / "notes.txt").write_text("keep me")
    with pytest.raises(ricci.RicciError) as e:
        ricci.write_outputs(r, tmp_path / "theirs")
    assert e.value.status == "write_failed" and e.value.stage == "outputs"
    assert (tmp_path / "theirs" / "notes.txt").read_text() == "keep me"
    # The result still stands: it can be written elsewhere, twice.
    assert "report.json" in ricci.write_outputs(r, tmp_path / "ok", pictures=False)
    assert "report.json" in ricci.write_outputs(r, tmp_path / "ok", pictures=False)


# ---- threads and progress ------------------------------------------------------------------------

def test_the_gil_is_released_during_the_solve():
    V, F = ricci.read_mesh(FIXTURES / "genus3.obj")
    ticks = 0
    done = threading.Event()
    results = []

    def work():
        # The mesh-path canonical polygon (a few cuts of the mesh), three times over, makes the
        # work long enough to count (about 0.07 s each here).
        for _ in range(3):
            results.append(ricci.uniformize(V, F, seed_checks=3, mesh_polygon=True))
        done.set()

    t = threading.Thread(target=work)
    start = time.monotonic()
    t.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.002)
    t.join()
    elapsed = time.monotonic() - start
    assert [r.status for r in results] == ["ok"] * 3
    # With the GIL held for the whole run this loop would tick at most once per solve (between
    # them); released, it ticks every 2 ms.
    assert ticks >= 10, (elapsed, ticks)


def test_progress_reaches_python_and_its_errors_come_back():
    events = []
    ricci.uniformize(FIXTURES / "genus2.obj", progress=events.append, seed_checks=0)
    iterations = [e for e in events if e["kind"] == "iteration"]
    stages = [e["stage"] for e in events if e["kind"] == "stage"]
    assert [e["iteration"] for e in iterations] == list(range(1, len(iterations) + 1))
    assert stages[:3] == ["initial_metric", "target", "flow"] and "layout" in stages
    calls = []

    def fail(event):
        calls.append(event)
        raise KeyError("stop")

    with pytest.raises(KeyError, match="stop"):
        ricci.flow(FIXTURES / "genus2.obj", progress=fail)
    assert len(calls) == 1


def test_embedded_default_and_paths():
    r = ricci.uniformize(seed_checks=0)
    assert r.report["embedded_default"] and r.report["mesh"]["genus"] == 2
    V, F = ricci.read_mesh(str(FIXTURES / "genus2.obj"))
    assert np.array_equal(r.V, V)


def test_atlas_face_chart_matches_the_report():
    # genus2-finger.obj: its finger needs a chart of its own; uv holds each face in its chart.
    r = ricci.uniformize(str(FIXTURES / "genus2-finger.obj"), seed_checks=0)
    layout = r.report["layout"]
    assert layout["charts"] >= 2
    assert layout["max_edge_length_error"] <= 1e-9
    assert r.face_chart.tolist() == layout["atlas"]["face_chart"]
    assert sorted(set(r.face_chart.tolist())) == list(range(layout["charts"]))
    assert r.uv.shape == (len(r.face_chart), 3, 2)
    assert np.isfinite(r.uv).all()
    # One chart only: the layout stage refuses it, naming the stage.
    with pytest.raises(ricci.RicciError) as e:
        ricci.uniformize(str(FIXTURES / "genus2-finger.obj"), seed_checks=0, atlas=False)
    assert "layout" in str(e.value)
    assert (ricci.uniformize(str(FIXTURES / "genus2.obj"), seed_checks=0).face_chart == 0).all()


def test_steiner_subdivision_is_exposed_with_its_own_edges():
    pig = SHARED / "boundary" / "pig-7holes.off"
    if not pig.exists():
        pytest.skip("the shared meshes are absent")
    r = ricci.uniformize(str(pig), seed_checks=0)
    st = r.report["steiner"]
    assert st["used"] and st["levels"] >= 1
    positions, faces, face_input = r.steiner
    n = len(r.V)
    assert np.array_equal(positions[:n], r.V)  # the input's vertices first
    assert len(positions) == n + st["vertices_added"] and len(faces) == st["faces"]
    assert len(r.u) == len(positions) and len(r.edge_lengths) == len(r.edges)
    assert face_input.min() >= 0 and face_input.max() < len(r.F)
    assert r.report["angle_distortion"]["mean"] <= 0.06
    off = ricci.uniformize(str(pig), seed_checks=0, steiner_levels=0)
    assert off.steiner is None and off.report["steiner"] is None
    assert len(off.u) == n and len(off.edges) == len(off.edge_lengths)
    assert off.report["angle_distortion"]["mean"] > r.report["angle_distortion"]["mean"]
