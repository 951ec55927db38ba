#!/usr/bin/env python3
"""The conformal signature of every shared mesh it applies to, and the distances between remeshings
of the same surface and between different surfaces, as Markdown (tools/SIGNATURES.md):

    python3 tools/signature_table.py > tools/SIGNATURES.md

Needs a Release build (build/ricci) and ../shared/meshes (or $RICCI_SHARED_MESHES). A benchmark,
not a test: it prints.
"""
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RICCI = os.path.join(ROOT, "build", "ricci")
MESHES = os.environ.get("RICCI_SHARED_MESHES", os.path.join(ROOT, "..", "shared", "meshes"))
FILES = ["genus1/kitten-5k.off", "genus1/kitten-106k.obj", "genus1/rocker-arm.obj", "genus2/eight.off",
         "genus2/eight-11k.off", "genus2/cup_input_simple_10000.off", "genus2/skull_low_resolution.obj",
         "genus3plus/3holes.off", "genus3plus/fertility.off", "genus3plus/botijo.obj", "boundary/alex-4holes.obj",
         "boundary/head-3holes.off", "boundary/holes-7.off", "boundary/pig-7holes.off", "boundary/stanford-bunny.obj",
         "boundary/eight.hole.off", "boundary/punctured-torus.obj"]
PAIRS = [("kitten-5k.off", "kitten-106k.obj"), ("kitten-5k.off", "rocker-arm.obj"), ("kitten-106k.obj", "rocker-arm.obj"),
         ("eight.off", "eight-11k.off"), ("eight.off", "skull_low_resolution.obj"),
         ("eight-11k.off", "skull_low_resolution.obj"), ("eight.off", "cup_input_simple_10000.off"),
         ("skull_low_resolution.obj", "cup_input_simple_10000.off"), ("holes-7.off", "pig-7holes.off")]


def summary(j):
    if j["torus"]:
        t = j["torus"]
        return "τ = %.6f %+.6fi (± %.1e)" % (t["tau"][0], t["tau"][1], t["uncertainty"])
    if j["fenchel_nielsen"]:
        return "systole %.5f (%s); FN lengths %s; twists %s" % (
            j["systole"]["length"], j["systole"]["word"], " ".join("%.4f" % c["length"] for c in j["fenchel_nielsen"]),
            " ".join("%.4f" % c["twist"] for c in j["fenchel_nielsen"]))
    if j["circle_domain"]:
        d = j["circle_domain"]
        parts = ["r = %.5f at %.4f%+.4fi" % (c["radius"], c["centre"][0], c["centre"][1]) for c in d["circles"][1:]]
        extra = "modulus %.6f; " % d["annulus_modulus"] if d["annulus_modulus"] is not None else ""
        return "circle domain: %s%s" % (extra, "; ".join(parts))
    return "boundary geodesics %s" % " ".join("%.6f" % g["length"] for g in j["boundary_geodesics"])


def main():
    print("# Conformal signatures of the shared meshes\n")
    print("Output of `python3 tools/signature_table.py` (Release build, 2 cores); each signature is")
    print("`ricci signature MESH --json`. The ± figures are the numbers' uncertainty for the discrete metric")
    print("(deck and circle fits); remeshings of one surface differ by the discretization error, which they")
    print("do not include.\n")
    print("| mesh | genus | loops | signature | seconds |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as out:
        for f in FILES:
            name = os.path.basename(f)
            path = os.path.join(out, name + ".json")
            start = time.time()
            r = subprocess.run([RICCI, "signature", os.path.join(MESHES, f), "--json", "-q", "-o", path],
                               capture_output=True, text=True)
            seconds = time.time() - start
            if r.returncode != 0:
                print("| %s | | | failed (exit %d): %s | %.2f |" % (f, r.returncode, r.stderr.strip().replace("|", " "), seconds))
                continue
            j = json.load(open(path))
            print("| %s | %d | %d | %s | %.2f |" % (f, j["genus"], j["boundary_loops"], summary(j), seconds))
        print("\n## Distances (`ricci compare A.json B.json`)\n")
        print("| A | B | kind | distance | marked distance |")
        print("|---|---|---|---|---|")
        for a, b in PAIRS:
            pa, pb = os.path.join(out, a + ".json"), os.path.join(out, b + ".json")
            if not (os.path.exists(pa) and os.path.exists(pb)):
                continue
            r = subprocess.run([RICCI, "compare", pa, pb, "--json"], capture_output=True, text=True)
            if r.returncode != 0:
                print("| %s | %s | failed: %s | | |" % (a, b, r.stderr.strip().replace("|", " ")))
                continue
            j = json.loads(r.stdout)
            m = j["marked_distance"]
            print("| %s | %s | %s | %.5g (± %.1e) | %s |" % (a, b, j["kind"], j["distance"], j["uncertainty"],
                                                          "" if m is None else "%.5g" % m))


if __name__ == "__main__":
    sys.exit(main())
