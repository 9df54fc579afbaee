#!/usr/bin/env python3
"""Checks peeltrim's rendering of OpenSCAD models against OpenSCAD's own CGAL
evaluation (the "real models" bar).

For each model (.scad or .csg): exports the .csg with `openscad` (when given a
.scad), evaluates it with CGAL (`openscad -o truth.stl`), converts the STL to an
OBJ mesh (vertices merged), and renders two scenes with one explicit camera
(OpenSCAD's default view direction, framing the CGAL result):

  A: `[csg] openscad = "model.csg"`       with --algo cst-i (or --algo ALGO;
                                          blister for a model with `%` parts,
                                          which CGAL's result leaves out)
  B: the CGAL mesh as one primitive       with --algo reference

then `peeltrim compare` gives the interior coverage mismatches and the depth
error. Passing: coverage ≤ 0.1% of the interior and depth p99 ≤ 1e-4 of the
model's size. Models with unsupported nodes must fail with the clear error.

Usage: tools/openscad_truth.py [--algo cst-i] [--size 200] [--out out/truth] FILES...
Needs `openscad` (Debian 12: apt-get install openscad) and a built peeltrim
(target/release/peeltrim, or --bin PATH). Writes summary.md and results.json
into --out. Inputs are only read.
"""
import argparse
import json
import math
import os
import subprocess
import sys


def stl_to_obj(stl, obj):
    verts, index, tris = [], {}, []
    with open(stl, "rb") as f:
        data = f.read()
    text = data[:5] == b"solid" and b"facet" in data[:1000]
    if text:
        cur = []
        for line in data.decode("ascii", "replace").splitlines():
            w = line.split()
            if w[:1] == ["vertex"]:
                cur.append(tuple(float(x) for x in w[1:4]))
            elif w[:1] == ["endloop"]:
                tris.append(cur)
                cur = []
    else:
        import struct
        n = struct.unpack_from("<I", data, 80)[0]
        for i in range(n):
            v = struct.unpack_from("<12f", data, 84 + 50 * i)
            tris.append([v[3:6], v[6:9], v[9:12]])
    out = []
    for t in tris:
        ids = []
        for p in t:
            if p not in index:
                index[p] = len(verts)
                verts.append(p)
            ids.append(index[p])
        if len(set(ids)) == 3:
            out.append(ids)
    with open(obj, "w") as f:
        for v in verts:
            f.write("v %r %r %r\n" % v)
        for a, b, c in out:
            f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))
    lo = [min(v[k] for v in verts) for k in range(3)]
    hi = [max(v[k] for v in verts) for k in range(3)]
    c = [(lo[k] + hi[k]) / 2 for k in range(3)]
    r = max(math.dist(v, c) for v in verts)
    return c, r, len(out)


def absolute_files(csg, src_dir):
    """`import`/`surface` paths in the export are relative to the .scad's
    folder; the .csg lives elsewhere, so they are made absolute."""
    import re
    with open(csg) as f:
        text = f.read()

    def fix(m):
        path = m.group(2)
        if not os.path.isabs(path):
            path = os.path.join(src_dir, path)
        return m.group(1) + path.replace("\\", "\\\\").replace('"', '\\"') + '"'

    text = re.sub(r'^(\s*[%#!*]*(?:import|surface)\(file = ")((?:[^"\\]|\\.)*)"', fix, text, flags=re.M)
    with open(csg, "w") as f:
        f.write(text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="+")
    ap.add_argument("--algo", default="cst-i")
    ap.add_argument("--size", type=int, default=200)
    ap.add_argument("--out", default="out/truth")
    ap.add_argument("--bin", default="target/release/peeltrim")
    ap.add_argument("--timeout", type=int, default=120)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for i, src in enumerate(a.files):
        name = "%03d_%s" % (i, os.path.splitext(os.path.basename(src))[0])
        d = os.path.abspath(os.path.join(a.out, name))
        os.makedirs(d, exist_ok=True)
        row = {"model": src}
        rows.append(row)
        csg = os.path.join(d, "model.csg")
        try:
            if src.endswith(".scad"):
                r = subprocess.run(["openscad", "-o", csg, src], capture_output=True, text=True, timeout=a.timeout)
                if r.returncode != 0:
                    row["status"] = "openscad export failed"
                    continue
                absolute_files(csg, os.path.dirname(os.path.abspath(src)))
            else:
                with open(src) as f, open(csg, "w") as g:
                    g.write(f.read())
            # Does peeltrim read it? (unsupported nodes must be a clear error)
            p = subprocess.run([a.bin, "blist", csg], capture_output=True, text=True, timeout=a.timeout)
            if p.returncode != 0:
                err = p.stderr.strip().splitlines()
                row["status"] = "refused"
                row["error"] = err[0] if err else ""
                row["clear"] = ("model.csg:" in p.stderr) and "panicked" not in p.stderr
                continue
            stl = os.path.join(d, "truth.stl")
            r = subprocess.run(["openscad", "-o", stl, csg], capture_output=True, text=True, timeout=a.timeout)
            if r.returncode != 0 or not os.path.exists(stl):
                row["status"] = "no CGAL truth"
                continue
            c, rad, ntri = stl_to_obj(stl, os.path.join(d, "truth.obj"))
            if ntri == 0:
                row["status"] = "empty CGAL result"
                continue
            rx, rz = math.radians(55), math.radians(25)
            dirv = (math.sin(rz) * math.sin(rx), -math.cos(rz) * math.sin(rx), math.cos(rx))
            dist = rad / math.sin(math.radians(22.5) / 2)
            eye = [c[k] + dirv[k] * dist for k in range(3)]
            cam = "[camera]\neye = %r\ntarget = %r\nup = [0.0, 0.0, 1.0]\nfov_y_deg = 22.5\n" % (eye, c)
            rend = "[render]\nwidth = %d\nheight = %d\n" % (a.size, a.size)
            with open(os.path.join(d, "a.toml"), "w") as f:
                f.write(cam + rend + '[csg]\nopenscad = "model.csg"\n')
            with open(os.path.join(d, "b.toml"), "w") as f:
                f.write(cam + rend + '[[primitive]]\nname = "truth"\nshape = "mesh"\npath = "truth.obj"\n[csg]\nexpr = "truth"\n')
            # CGAL's result leaves `%` (background) parts out; `render` draws
            # them see-through with the compositing algorithms (cst-*,
            # kirsch), so such a model is compared as drawn by one that leaves
            # them out (Blister: any tree, exact).
            with open(csg) as f:
                background = any(line.lstrip().startswith("%") for line in f)
            algo = "blister" if background else a.algo
            row["algo"] = algo
            ra = subprocess.run([a.bin, "render", os.path.join(d, "a.toml"), "--algo", algo, "--out", os.path.join(d, "a")],
                                capture_output=True, text=True, timeout=a.timeout * 5)
            if ra.returncode != 0:
                row["status"] = "peeltrim failed"
                row["error"] = ra.stderr.strip().splitlines()[-1:]
                continue
            rb = subprocess.run([a.bin, "render", os.path.join(d, "b.toml"), "--algo", "reference", "--out", os.path.join(d, "b")],
                                capture_output=True, text=True, timeout=a.timeout * 5)
            if rb.returncode != 0:
                row["status"] = "truth mesh unusable"
                row["error"] = rb.stderr.strip().splitlines()[-1:]
                continue
            cmp = subprocess.run([a.bin, "compare", os.path.join(d, "b"), os.path.join(d, "a")], capture_output=True, text=True)
            j = json.loads(cmp.stdout)
            size = 2 * rad
            cov = j.get("coverage_mismatch_interior_frac", j.get("coverage_mismatch_frac"))
            p99 = j.get("depth_abs_err_p99_interior", j.get("depth_abs_err_p99"))
            row.update(coverage=cov, depth_p99_rel=(p99 or 0.0) / size,
                       status="pass" if cov <= 0.001 and (p99 or 0.0) <= 1e-4 * size else "FAIL")
        except subprocess.TimeoutExpired:
            row["status"] = "timeout"
        print("%-50s %s" % (src, row.get("status")), file=sys.stderr)
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump(rows, f, indent=1)
    compared = [r for r in rows if r["status"] in ("pass", "FAIL")]
    passed = [r for r in compared if r["status"] == "pass"]
    refused = [r for r in rows if r["status"] == "refused"]
    lines = ["| model | status | interior coverage mismatch | depth p99 / size |", "|---|---|---|---|"]
    for r in rows:
        lines.append("| %s | %s | %s | %s |" % (
            r["model"], r["status"],
            "%.4f%%" % (100 * r["coverage"]) if "coverage" in r else "",
            "%.2e" % r["depth_p99_rel"] if "depth_p99_rel" in r else r.get("error", "")))
    lines.append("")
    lines.append("compared %d, passed %d (%.0f%%); refused with a clear error %d of %d" % (
        len(compared), len(passed), 100.0 * len(passed) / max(1, len(compared)),
        sum(1 for r in refused if r.get("clear")), len(refused)))
    with open(os.path.join(a.out, "summary.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
