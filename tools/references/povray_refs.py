#!/usr/bin/env python3
"""glTF 2.0 -> POV-Ray 3.7 conversion: a second, independent reference for strata's `direct`
integrator on scenes lit only by point lights (standard library only; needs `povray` and
`oiiotool` on PATH).

    python3 tools/references/povray_refs.py                 # every job in JOBS, then the manifest
    python3 tools/references/povray_refs.py point-lights    # only these scenes (manifest merged)
    python3 tools/references/povray_refs.py --test DIR      # radiometry / orientation self-tests
    python3 tools/references/povray_refs.py --compare       # compare with the Mitsuba references
    tools/references/make_povray_reference.sh               # --test, then the renders

Writes scenes/references/<scene>.direct.povray.exr (linear Rec.709 RGB, float32, ZIP; the
values are POV-Ray's half-float EXR output widened losslessly) and
scenes/references/povray-manifest.json.

Conversion (strata's contract, scenes/references/README.md):
- camera: the first camera of a depth-first, pre-order walk of the default scene. POV-Ray's
  primary ray is direction + x0*right + y0*up with x0 = (col + 0.5)/W - 0.5 (left -> right)
  and y0 = 0.5 - (row + 0.5)/H (row 0 at the top); these vectors are given EXPLICITLY in
  glTF world coordinates (no look_at, no angle): direction = camera -Z axis, up = camera +Y
  axis x 2 tan(yfov/2), right = camera +X axis x 2 tan(yfov/2) x W/H. The geometry is NOT
  mirrored: POV-Ray's left-handedness only enters through look_at/angle/default vectors,
  none of which is used, so the world stays glTF's right-handed one (checked by --test).
- geometry: every TRIANGLES/STRIP/FAN primitive -> one world-space `mesh2` (node transforms
  applied; NORMAL, when present, -> normal_vectors through the inverse transpose). POV-Ray
  shades both sides of a triangle (strata's diffuse surfaces scatter on both sides).
- material: pigment rgb baseColorFactor, finish { ambient 0 emission 0 diffuse 1
  brilliance 1 specular 0 phong 0 reflection 0 }: radiance = pigment x light x cos(theta).
  Textures, emission, spot lights and a non-black background are refused.
- point light of glTF intensity I = color x intensity: POV-Ray light colour
  C = I / pi / (2 d0^2) with fade_distance d0, fade_power 2, so the light seen at distance d
  is C x 2 / (1 + (d/d0)^2) = (I/pi) / (d^2 + d0^2): the contract's rho/pi I cos/d^2 up to a
  relative error d0^2/(d^2+d0^2) < (d0/d_min)^2, d_min = the smallest light-triangle
  distance in the scene. d0 = D0_FRACTION x d_min, so the error is below D0_FRACTION^2.
- pixels: Antialias on, Sampling_Method 1, Antialias_Threshold 0 (every pixel supersampled),
  Antialias_Depth 9, Jitter off. POV-Ray 3.7 then averages the pixel-centre sample and a 9x9
  grid of sub-pixel centres (a quadrature of the box filter that counts the centre twice: 82
  samples, weights 2/82 at the centre, 1/82 elsewhere).
- global_settings { assumed_gamma 1.0 max_trace_level 1 ambient_light 0 }, no radiosity, no
  photons, hard shadows (no `shadowless`); output +FE (OpenEXR; POV-Ray writes half floats,
  linear, no gamma, no clamping) with File_Gamma 1.0.
"""
import argparse
import base64
import json
import math
import os
import re
import shlex
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import urllib.parse

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import scene_hash  # noqa: E402

OUT_DIR = os.path.join(REPO, "scenes", "references")
MANIFEST = "povray-manifest.json"
# scene name -> (repository-relative glTF path, resolution); the resolution is the Mitsuba
# reference's (tools/references/mitsuba_refs.py SCENES), checked against its EXR by --compare.
SCENES = {
    "point-lights": ("scenes/point-lights.gltf", (192, 144)),
}
JOBS = ["point-lights"]
AA_DEPTH = 9          # POV-Ray 3.7's maximum for Sampling_Method 1
SUPERSAMPLE = 3       # render at 3W x 3H, then average 3x3 blocks (box filter)
D0_FRACTION = 1e-3    # fade_distance = D0_FRACTION x smallest light-triangle distance
THREADS = 1


class ConversionError(Exception):
    pass


# ---------------------------------------------------------------------------------------
# small linear algebra (lists)
# ---------------------------------------------------------------------------------------

def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(len(b))) for j in range(len(b[0]))] for i in range(len(a))]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    return math.sqrt(dot(a, a))


def normalize(a):
    n = norm(a)
    return [c / n for c in a] if n > 0 else [0.0, 0.0, 0.0]


def det3(m):
    return dot(m[0], cross(m[1], m[2]))


def inv3(m):
    d = det3(m)
    if d == 0:
        return None
    c = [cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])]  # rows of adj^T
    return [[c[j][i] / d for j in range(3)] for i in range(3)]


def xform_point(w, p):
    return [w[i][0] * p[0] + w[i][1] * p[1] + w[i][2] * p[2] + w[i][3] for i in range(3)]


def xform_dir(m3, v):
    return [m3[i][0] * v[0] + m3[i][1] * v[1] + m3[i][2] * v[2] for i in range(3)]


def closest_point_triangle(p, a, b, c):
    """Closest point to p on triangle abc (Ericson, Real-Time Collision Detection 5.1.5)."""
    ab, ac, ap = sub(b, a), sub(c, a), sub(p, a)
    d1, d2 = dot(ab, ap), dot(ac, ap)
    if d1 <= 0 and d2 <= 0:
        return a
    bp = sub(p, b)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    if d3 >= 0 and d4 <= d3:
        return b
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        v = d1 / (d1 - d3)
        return [a[i] + v * ab[i] for i in range(3)]
    cp = sub(p, c)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    if d6 >= 0 and d5 <= d6:
        return c
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        w = d2 / (d2 - d6)
        return [a[i] + w * ac[i] for i in range(3)]
    va = d3 * d6 - d5 * d4
    if va <= 0 and (d4 - d3) >= 0 and (d5 - d6) >= 0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return [b[i] + w * (c[i] - b[i]) for i in range(3)]
    denom = 1.0 / (va + vb + vc)
    v, w = vb * denom, vc * denom
    return [a[i] + ab[i] * v + ac[i] * w for i in range(3)]


# ---------------------------------------------------------------------------------------
# glTF reading
# ---------------------------------------------------------------------------------------

COMPONENT = {5120: ("b", 1), 5121: ("B", 1), 5122: ("h", 2), 5123: ("H", 2), 5125: ("I", 4), 5126: ("f", 4)}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength"}


class Gltf:
    def __init__(self, path):
        self.path = os.path.abspath(path)
        self.base = os.path.dirname(self.path)
        with open(self.path, "rb") as f:
            data = f.read()
        self.glb_bin = None
        if data[:4] == b"glTF":
            off, doc = 12, None
            while off < len(data):
                clen, ctype = struct.unpack_from("<II", data, off)
                chunk = data[off + 8: off + 8 + clen]
                if ctype == 0x4E4F534A and doc is None:
                    doc = json.loads(chunk.decode("utf-8"))
                elif ctype == 0x004E4942 and self.glb_bin is None:
                    self.glb_bin = chunk
                off += 8 + clen
            self.doc = doc
        else:
            self.doc = json.loads(data.decode("utf-8"))
        required = set(self.doc.get("extensionsRequired", [])) - SUPPORTED_EXTENSIONS
        if required:
            raise ConversionError(f"{path}: required extensions not supported: {sorted(required)}")
        self._buffers = {}

    def buffer(self, i):
        if i not in self._buffers:
            b = self.doc["buffers"][i]
            if "uri" in b:
                uri = b["uri"]
                if uri.startswith("data:"):
                    head, payload = uri.split(",", 1)
                    data = base64.b64decode(payload) if head.endswith(";base64") else urllib.parse.unquote_to_bytes(payload)
                else:
                    with open(os.path.join(self.base, urllib.parse.unquote(uri)), "rb") as f:
                        data = f.read()
            elif i == 0 and self.glb_bin is not None:
                data = self.glb_bin
            else:
                raise ConversionError(f"buffer {i} has no data")
            if len(data) < b["byteLength"]:
                raise ConversionError(f"buffer {i} is shorter than its byteLength")
            self._buffers[i] = data
        return self._buffers[i]

    def accessor(self, i, as_float=True):
        """List of tuples (one per element)."""
        a = self.doc["accessors"][i]
        if "sparse" in a:
            raise ConversionError(f"accessor {i}: sparse accessors are not supported")
        fmt, size = COMPONENT[a["componentType"]]
        n = NCOMP[a["type"]]
        count = a["count"]
        if "bufferView" not in a:
            vals = [tuple([0] * n)] * count
        else:
            view = self.doc["bufferViews"][a["bufferView"]]
            data = self.buffer(view["buffer"])
            stride = view.get("byteStride") or size * n
            start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
            end = start + stride * (count - 1) + size * n if count else start
            if end > view.get("byteOffset", 0) + view["byteLength"]:
                raise ConversionError(f"accessor {i} runs past its bufferView")
            vals = [struct.unpack_from("<" + fmt * n, data, start + k * stride) for k in range(count)]
        if as_float:
            if a.get("normalized"):
                scale = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}[a["componentType"]]
                vals = [tuple(max(c / scale, -1.0) for c in v) for v in vals]
            else:
                vals = [tuple(float(c) for c in v) for v in vals]
        return vals


def node_local_matrix(node):
    if "matrix" in node:
        m = node["matrix"]  # column-major
        return [[m[c * 4 + r] for c in range(4)] for r in range(4)]
    t = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = node.get("scale", [1, 1, 1])
    r = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return [[r[i][0] * s[0], r[i][1] * s[1], r[i][2] * s[2], t[i]] for i in range(3)] + [[0.0, 0.0, 0.0, 1.0]]


def walk(g):
    """(node_index, node, world_matrix) depth-first, pre-order, over the default scene."""
    doc = g.doc
    scenes = doc.get("scenes", [])
    if not scenes:
        raise ConversionError("no scene")
    identity = [[float(i == j) for j in range(4)] for i in range(4)]

    def visit(i, parent, path):
        if i in path:
            raise ConversionError(f"node {i} is its own ancestor")
        node = doc["nodes"][i]
        world = matmul(parent, node_local_matrix(node))
        yield i, node, world
        for c in node.get("children", []):
            yield from visit(c, world, path + (i,))

    for root in scenes[doc.get("scene", 0)].get("nodes", []):
        yield from visit(root, identity, ())


def triangles(g, prim, nverts):
    mode = prim.get("mode", 4)
    idx = [v[0] for v in g.accessor(prim["indices"], as_float=False)] if "indices" in prim else list(range(nverts))
    if mode == 4:
        tris = [tuple(idx[3 * k: 3 * k + 3]) for k in range(len(idx) // 3)]
    elif mode == 5:
        tris = [(idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]) for i in range(max(len(idx) - 2, 0))]
    elif mode == 6:
        tris = [(idx[i + 1], idx[i + 2], idx[0]) for i in range(max(len(idx) - 2, 0))]
    else:
        return None
    if any(v >= nverts for t in tris for v in t):
        raise ConversionError("index out of range")
    return tris


def convert(path, resolution):
    """Reads glTF `path` into a plain scene description (world space)."""
    g = Gltf(path)
    doc = g.doc
    lights_ext = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    scene = {"meshes": [], "lights": [], "camera": None, "warnings": [], "triangles": 0, "has_normals": []}
    bg = doc.get("extras", {}).get("strata", {}).get("background")
    if bg is not None and any(c > 0 for c in bg):
        raise ConversionError("a non-black background lights the scene in strata/Mitsuba; not converted")
    for ni, node, world in walk(g):
        if "camera" in node and scene["camera"] is None:
            scene["camera"] = (doc["cameras"][node["camera"]], world)
        if "mesh" in node:
            lin = [row[:3] for row in world[:3]]
            inv = inv3(lin)
            nmat = [[inv[j][i] for j in range(3)] for i in range(3)] if inv else None  # inverse transpose
            for pi, prim in enumerate(doc["meshes"][node["mesh"]]["primitives"]):
                attrs = prim["attributes"]
                pos = g.accessor(attrs["POSITION"])
                tris = triangles(g, prim, len(pos))
                if tris is None:
                    scene["warnings"].append(f"node {ni} primitive {pi}: mode {prim.get('mode')} skipped")
                    continue
                if not tris:
                    continue
                mat = doc["materials"][prim["material"]] if "material" in prim else {}
                name = mat.get("name", f"material {prim.get('material')}")
                pbr = mat.get("pbrMetallicRoughness", {})
                if "baseColorTexture" in pbr:
                    raise ConversionError(f"material '{name}': textures are not converted to POV-Ray")
                strength = mat.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
                if any(c * strength > 0 for c in mat.get("emissiveFactor", [0, 0, 0])):
                    raise ConversionError(f"material '{name}': emission is not converted to POV-Ray")
                rho = [float(c) for c in pbr.get("baseColorFactor", [1, 1, 1, 1])[:3]]
                wpos = [xform_point(world, p) for p in pos]
                normals = None
                if "NORMAL" in attrs and nmat is not None:
                    normals = [normalize(xform_dir(nmat, n)) for n in g.accessor(attrs["NORMAL"])]
                    if any(n == [0.0, 0.0, 0.0] for n in normals):
                        normals = None
                        scene["warnings"].append(f"node {ni} primitive {pi}: zero normal, flat shading")
                scene["meshes"].append({"name": f"node {ni} ({node.get('name', '')}) primitive {pi}",
                                        "positions": wpos, "normals": normals, "triangles": tris, "rho": rho})
                scene["triangles"] += len(tris)
                scene["has_normals"].append(normals is not None)
        ext = node.get("extensions", {}).get("KHR_lights_punctual")
        if ext is not None:
            light = lights_ext[ext["light"]]
            if light["type"] != "point":
                raise ConversionError(f"light {ext['light']}: type '{light['type']}' is not converted (point lights only)")
            if light.get("range"):
                scene["warnings"].append(f"light {ext['light']}: range ignored")
            intensity = [c * light.get("intensity", 1.0) for c in light.get("color", [1, 1, 1])]
            scene["lights"].append({"name": light.get("name", f"light {ext['light']}"),
                                    "position": [world[i][3] for i in range(3)], "I": intensity})
    if scene["camera"] is None:
        raise ConversionError(f"{path}: no camera in the default scene")
    cam, world = scene["camera"]
    if cam["type"] != "perspective":
        raise ConversionError("only perspective cameras are supported")
    rot = [row[:3] for row in world[:3]]
    cols = [[rot[i][j] for i in range(3)] for j in range(3)]
    for a in range(3):
        for b in range(3):
            if abs(dot(cols[a], cols[b]) - (a == b)) > 1e-5:
                raise ConversionError("the camera's world transform is not a rotation + translation")
    if det3(rot) < 0:
        raise ConversionError("the camera's world transform is not a rotation + translation")
    w, h = resolution
    t = math.tan(cam["perspective"]["yfov"] / 2)
    scene["pov_camera"] = {
        "location": [world[i][3] for i in range(3)],
        "direction": [-c for c in cols[2]],
        "right": [c * 2 * t * w / h for c in cols[0]],
        "up": [c * 2 * t for c in cols[1]],
    }
    # fade distance: a fraction of the smallest light-triangle distance
    dmin = math.inf
    for L in scene["lights"]:
        for m in scene["meshes"]:
            p = m["positions"]
            for a, b, c in m["triangles"]:
                q = closest_point_triangle(L["position"], p[a], p[b], p[c])
                dmin = min(dmin, norm(sub(q, L["position"])))
    scene["d_min"] = dmin
    return scene


# ---------------------------------------------------------------------------------------
# POV-Ray scene writing and rendering
# ---------------------------------------------------------------------------------------

def f(x):
    return repr(float(x))


def vec(v):
    return "<" + ", ".join(f(c) for c in v) + ">"


FINISH = "finish { ambient 0 emission 0 diffuse 1 brilliance 1 specular 0 phong 0 reflection 0 crand 0 }"


def write_pov(scene, path, d0):
    c = scene["pov_camera"]
    out = ["// Written by tools/references/povray_refs.py from a glTF scene; glTF world coordinates",
           "// (right-handed, +Y up), camera vectors explicit (no look_at / angle).",
           "#version 3.7;",
           "global_settings { assumed_gamma 1.0 max_trace_level 1 ambient_light rgb 0 }",
           "background { rgb 0 }",
           "camera { perspective",
           f"  location {vec(c['location'])}",
           f"  direction {vec(c['direction'])}",
           f"  right {vec(c['right'])}",
           f"  up {vec(c['up'])}",
           "}"]
    for L in scene["lights"]:
        colour = [i / math.pi / (2 * d0 * d0) for i in L["I"]]
        out.append(f"// {L['name']}: I = {L['I']}")
        out.append(f"light_source {{ {vec(L['position'])} color rgb {vec(colour)} fade_distance {f(d0)} fade_power 2 }}")
    for m in scene["meshes"]:
        out.append(f"// {m['name']}")
        out.append("mesh2 {")
        p = m["positions"]
        out.append(f"  vertex_vectors {{ {len(p)},")
        out.append(",\n".join("    " + vec(v) for v in p))
        out.append("  }")
        if m["normals"] is not None:
            out.append(f"  normal_vectors {{ {len(m['normals'])},")
            out.append(",\n".join("    " + vec(v) for v in m["normals"]))
            out.append("  }")
        out.append(f"  face_indices {{ {len(m['triangles'])},")
        out.append(",\n".join(f"    <{a}, {b}, {cc}>" for a, b, cc in m["triangles"]))
        out.append("  }")
        out.append(f"  texture {{ pigment {{ rgb {vec(m['rho'])} }} {FINISH} }}")
        out.append("}")
    with open(path, "w") as fh:
        fh.write("\n".join(out) + "\n")


def ini_options(resolution, aa_depth):
    w, h = resolution
    return [f"Width={w}", f"Height={h}", "Output_File_Type=E", "Output_Alpha=off", "File_Gamma=1.0",
            "Antialias=on", "Sampling_Method=1", "Antialias_Threshold=0.0", f"Antialias_Depth={aa_depth}",
            "Jitter=off", "Quality=9", "Display=off", "Verbose=off", "Pause_When_Done=off",
            f"Work_Threads={THREADS}"]


def povray_version():
    r = subprocess.run(["povray", "--version"], capture_output=True, text=True)
    m = re.search(r"POV-Ray (\S+)", r.stdout + r.stderr)
    deb = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "povray"], capture_output=True, text=True)
    return (m.group(1) if m else "unknown"), (deb.stdout.strip() if deb.returncode == 0 else None)


def render(scene, resolution, out_exr, aa_depth=AA_DEPTH, supersample=SUPERSAMPLE, keep_dir=None):
    """Renders `scene` with POV-Ray into `out_exr` (float32 ZIP EXR): at supersample x the
    resolution (same camera), then box-averaged over supersample x supersample blocks
    (oiiotool --resize:filter=box; equal to the exact block mean within 3e-7 relative).
    Returns (seconds, d0)."""
    d0 = D0_FRACTION * scene["d_min"]
    w, h = resolution
    k = supersample
    work = keep_dir or tempfile.mkdtemp(prefix="strata-povray-")
    os.makedirs(work, exist_ok=True)
    try:
        write_pov(scene, os.path.join(work, "scene.pov"), d0)
        with open(os.path.join(work, "render.ini"), "w") as fh:
            fh.write("\n".join(["Input_File_Name=scene.pov", "Output_File_Name=render.exr"]
                               + ini_options((k * w, k * h), aa_depth)) + "\n")
        t0 = time.time()
        # POV-Ray's I/O restrictions allow writing in the current directory: run it there.
        r = subprocess.run(["povray", "render.ini"], cwd=work, capture_output=True, text=True)
        seconds = time.time() - t0
        if r.returncode != 0 or not os.path.exists(os.path.join(work, "render.exr")):
            raise RuntimeError(f"povray failed ({r.returncode}):\n{r.stderr[-4000:]}")
        with open(os.path.join(work, "povray.log"), "w") as fh:
            fh.write(r.stderr)
        resize = ["--resize:filter=box", f"{w}x{h}"] if k > 1 else []
        subprocess.run(["oiiotool", "--nosoftwareattrib", os.path.join(work, "render.exr"), "--eraseattrib",
                        "ImageDescription", "-d", "float"] + resize + ["--compression", "zip", "-o", out_exr],
                       check=True)
    finally:
        if keep_dir is None:
            shutil.rmtree(work, ignore_errors=True)
    return seconds, d0


# ---------------------------------------------------------------------------------------
# image reading (oiiotool --dumpdata: 9 significant digits, exact for float32)
# ---------------------------------------------------------------------------------------

def _dump(path):
    r = subprocess.run(["oiiotool", "--dumpdata", path], capture_output=True, text=True, check=True)
    return r.stdout.splitlines()


def read_exr(path):
    """(width, height, pixels) with pixels[row][col] = [r, g, b]; row 0 at the top.

    oiiotool --dumpdata prints 9 DECIMALS (not significant digits), which would truncate small
    values such as variances; so the image is first scaled by a power of two (exact in float)
    that brings its maximum near 2^20, dumped, and scaled back."""
    lines = _dump(path)
    vmax = 0.0
    for line in lines[1:]:
        m = re.match(r"\s*Pixel \(\d+, \d+\):\s*(.*)", line)
        if m:
            vmax = max([vmax] + [abs(float(v)) for v in m.group(1).split()])
    scale = 1.0
    if vmax > 0:
        scale = 2.0 ** (20 - math.ceil(math.log2(vmax)))
        with tempfile.TemporaryDirectory(prefix="strata-povray-read-") as tmp:
            scaled = os.path.join(tmp, "scaled.exr")
            subprocess.run(["oiiotool", path, "--mulc", repr(scale), "-d", "float", "-o", scaled], check=True)
            lines = _dump(scaled)
    m = re.search(r":\s+(\d+)\s+x\s+(\d+),\s+(\d+) channel", lines[0])
    w, h, nc = int(m.group(1)), int(m.group(2)), int(m.group(3))
    img = [[None] * w for _ in range(h)]
    for line in lines[1:]:
        m = re.match(r"\s*Pixel \((\d+), (\d+)\):\s*(.*)", line)
        if m:
            vals = [float(v) / scale for v in m.group(3).split()]
            img[int(m.group(2))][int(m.group(1))] = vals[:3]
    if nc < 3 or any(p is None for row in img for p in row):
        raise RuntimeError(f"{path}: could not read every RGB pixel")
    return w, h, img


# ---------------------------------------------------------------------------------------
# comparison with the Mitsuba reference
# ---------------------------------------------------------------------------------------

def compare(pov_path, ref_path, var_path, block=8):
    _, _, P = read_exr(pov_path)
    w, h, M = read_exr(ref_path)
    _, _, V = read_exr(var_path)
    if len(P) != h or len(P[0]) != w:
        raise RuntimeError(f"{pov_path} is {len(P[0])}x{len(P)}, the Mitsuba reference {w}x{h}")
    n = w * h * 3
    mean_p = sum(c for row in P for px in row for c in px) / n
    mean_m = sum(c for row in M for px in row for c in px) / n
    # 8x8 block means, per channel
    rel_blocks = []
    for by in range(0, h - h % block, block):
        for bx in range(0, w - w % block, block):
            for ch in range(3):
                sp = sum(P[y][x][ch] for y in range(by, by + block) for x in range(bx, bx + block))
                sm = sum(M[y][x][ch] for y in range(by, by + block) for x in range(bx, bx + block))
                if sm > 0:
                    rel_blocks.append((sp - sm) / sm)
    # per pixel. "Edge" pixels: the Mitsuba luminance differs by more than 3% from a 4-neighbour
    # (silhouettes, shadow boundaries), where POV-Ray's 82-sample grid quadrature of the box
    # filter has its error; the border rows/columns count as edges.
    def lum_at(img, y, x):
        px = img[y][x]
        return 0.2126 * px[0] + 0.7152 * px[1] + 0.0722 * px[2]

    def is_edge(y, x):
        if y in (0, h - 1) or x in (0, w - 1):
            return True
        c = lum_at(M, y, x)
        return any(abs(lum_at(M, y + dy, x + dx) - c) > 0.03 * c for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1)))

    abs_rel, over5, over5_ch, over5_q, over_abs = [], 0, 0, 0, 0
    edge_n, edge_bad, inner_bad = 0, 0, 0
    zs = []
    for y in range(h):
        for x in range(w):
            bad = bad_q = False
            for ch in range(3):
                d = P[y][x][ch] - M[y][x][ch]
                v = max(V[y][x][ch], 0.0)
                s = math.sqrt(v)
                if M[y][x][ch] > 0:
                    abs_rel.append(abs(d) / M[y][x][ch])
                z = abs(d) / s if s > 0 else (math.inf if d != 0 else 0.0)
                zs.append(z)
                if z > 5:
                    over5_ch += 1
                    bad = True
                # the same with POV-Ray's half-float rounding (uniform, variance ulp^2 / 12) added
                p = abs(P[y][x][ch])
                ulp = 2.0 ** (math.floor(math.log2(p)) - 10) if p >= 2.0 ** -14 else 2.0 ** -24
                if abs(d) > 5 * math.sqrt(v + ulp * ulp / 12):
                    bad_q = True
            over5 += bad
            over5_q += bad_q
            e = is_edge(y, x)
            edge_n += e
            edge_bad += bad_q and e
            inner_bad += bad_q and not e
            if any(abs(P[y][x][ch] - M[y][x][ch]) > 0.02 for ch in range(3)):
                over_abs += 1

    def lum(img, flip_x=False, flip_y=False):
        out = []
        for y in range(h):
            for x in range(w):
                px = img[h - 1 - y if flip_y else y][w - 1 - x if flip_x else x]
                out.append(0.2126 * px[0] + 0.7152 * px[1] + 0.0722 * px[2])
        return out

    def corr(a, b):
        ma, mb = sum(a) / len(a), sum(b) / len(b)
        cov = sum((p - ma) * (q - mb) for p, q in zip(a, b))
        va, vb = sum((p - ma) ** 2 for p in a), sum((q - mb) ** 2 for q in b)
        return cov / math.sqrt(va * vb)

    lp = lum(P)
    abs_rel.sort()
    zs.sort()
    rb = sorted(abs(r) for r in rel_blocks)
    return {
        "image_mean_povray": mean_p,
        "image_mean_mitsuba": mean_m,
        "mean_relative_difference": (mean_p - mean_m) / mean_m,
        "block_size": block,
        "block_mean_relative_difference": {
            "mean_signed": sum(rel_blocks) / len(rel_blocks),
            "mean_abs": sum(rb) / len(rb),
            "median_abs": rb[len(rb) // 2],
            "p99_abs": rb[int(0.99 * (len(rb) - 1))],
            "max_abs": rb[-1],
        },
        "pixel_relative_difference": {"mean_abs": sum(abs_rel) / len(abs_rel), "median_abs": abs_rel[len(abs_rel) // 2],
                                      "p99_abs": abs_rel[int(0.99 * (len(abs_rel) - 1))], "max_abs": abs_rel[-1]},
        "fraction_pixels_over_5_sigma": over5 / (w * h),
        "fraction_pixel_channels_over_5_sigma": over5_ch / n,
        "fraction_pixels_over_5_sigma_incl_half_rounding": over5_q / (w * h),
        "edge_pixels": edge_n,
        "fraction_edge_pixels_over_5_sigma_incl_half_rounding": edge_bad / max(edge_n, 1),
        "fraction_other_pixels_over_5_sigma_incl_half_rounding": inner_bad / max(w * h - edge_n, 1),
        "median_abs_difference_in_sigma": zs[len(zs) // 2],
        "fraction_pixels_abs_difference_over_0.02": over_abs / (w * h),
        "luminance_correlation": corr(lp, lum(M)),
        "luminance_correlation_with_mitsuba_flipped_horizontally": corr(lp, lum(M, flip_x=True)),
        "luminance_correlation_with_mitsuba_flipped_vertically": corr(lp, lum(M, flip_y=True)),
        "note": "sigma = sqrt(Mitsuba .var.exr) per pixel and channel; a pixel is over 5 sigma when any channel is; "
                "'incl_half_rounding' adds POV-Ray's half-float output rounding (ulp^2/12 at the pixel's value; an "
                "upper bound when supersampled) to sigma^2; edge pixels: "
                "Mitsuba luminance differs > 3% from a 4-neighbour, or image border; relative differences are "
                "(povray - mitsuba) / mitsuba",
    }


# ---------------------------------------------------------------------------------------
# self-tests
# ---------------------------------------------------------------------------------------

def test_scene(quads, lights, eye, rot_quat, yfov):
    """A glTF-like plain scene: quads = [(corners (4, CCW), rho)], lights = [(pos, I rgb)]."""
    x, y, z, w = rot_quat
    world = node_local_matrix({"translation": eye, "rotation": rot_quat})
    scene_doc = {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": list(I), "intensity": 1.0} for _, I in lights]}},
        "scene": 0,
        "nodes": [{"camera": 0, "translation": eye, "rotation": [x, y, z, w]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.01}}],
        "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
    }
    blob = bytearray()
    for k, (corners, rho) in enumerate(quads):
        off = len(blob)
        blob += b"".join(struct.pack("<3f", *c) for c in corners) + struct.pack("<6H", 0, 1, 2, 0, 2, 3) + b"\0\0"
        scene_doc["bufferViews"] += [{"buffer": 0, "byteOffset": off, "byteLength": 48},
                                     {"buffer": 0, "byteOffset": off + 48, "byteLength": 12}]
        scene_doc["accessors"] += [{"bufferView": 2 * k, "componentType": 5126, "count": 4, "type": "VEC3"},
                                   {"bufferView": 2 * k + 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]
        scene_doc["materials"].append({"pbrMetallicRoughness": {"baseColorFactor": list(rho) + [1.0]}})
        scene_doc["meshes"].append({"primitives": [{"attributes": {"POSITION": 2 * k}, "indices": 2 * k + 1, "material": k}]})
        scene_doc["nodes"].append({"mesh": k})
    for k, (pos, _) in enumerate(lights):
        scene_doc["nodes"].append({"translation": pos, "extensions": {"KHR_lights_punctual": {"light": k}}})
    scene_doc["scenes"] = [{"nodes": list(range(len(scene_doc["nodes"])))}]
    scene_doc["buffers"] = [{"byteLength": len(blob),
                             "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}]
    return scene_doc, world


def pixel_average(fn, world, yfov, res, row, col, n=32):
    """Mean of fn(hit point on the plane the ray meets) over an n x n grid in pixel (row, col).
    fn(origin, direction) returns the radiance (or None: 0)."""
    w, h = res
    t = math.tan(yfov / 2)
    R = [world[i][0] for i in range(3)]
    U = [world[i][1] for i in range(3)]
    F = [-world[i][2] for i in range(3)]
    eye = [world[i][3] for i in range(3)]
    acc = 0.0
    for j in range(n):
        for i in range(n):
            x0 = (col + (i + 0.5) / n) / w - 0.5
            y0 = 0.5 - (row + (j + 0.5) / n) / h
            d = [F[k] + x0 * 2 * t * w / h * R[k] + y0 * 2 * t * U[k] for k in range(3)]
            v = fn(eye, d)
            acc += v or 0.0
    return acc / (n * n)


def run_tests(out_dir):
    os.makedirs(out_dir, exist_ok=True)
    ok, lines = True, []

    # 1. radiometry: floor y = 0 of albedo 0.5, point light I = 10 at height 2, camera at the
    #    light looking straight down (image up = world -Z).
    rho, I, hgt = 0.5, 10.0, 2.0
    s2 = math.sqrt(0.5)
    quad = ([[-5, 0, 5], [5, 0, 5], [5, 0, -5], [-5, 0, -5]], [rho] * 3)
    yfov, res = 0.5, (33, 33)
    for label, Irgb, k in (("white I=10", [I, I, I], 1),
                           (f"white I=10, supersample {SUPERSAMPLE}", [I, I, I], SUPERSAMPLE),
                           (f"coloured I=1000 x (1, 0.5, 0.25), supersample {SUPERSAMPLE}", [1000.0, 500.0, 250.0],
                            SUPERSAMPLE)):
        doc, world = test_scene([quad], [([0, hgt, 0], Irgb)], [0, hgt, 0], [-s2, 0, 0, s2], yfov)
        gpath = os.path.join(out_dir, "radiometry.gltf")
        with open(gpath, "w") as fh:
            json.dump(doc, fh)
        scene = convert(gpath, res)
        exr = os.path.join(out_dir, f"radiometry-{'white' if Irgb[0] == I else 'coloured'}-ss{k}.exr")
        _, d0 = render(scene, res, exr, supersample=k, keep_dir=os.path.join(out_dir, "radiometry-work"))
        _, _, img = read_exr(exr)

        def radiance_unit(eye, d):  # rho/pi * 1 * cos / dist^2 for unit intensity
            if d[1] >= 0:
                return None
            s = -eye[1] / d[1]
            p = [eye[k] + s * d[k] for k in range(3)]
            v = sub([0, hgt, 0], p)
            dist2 = dot(v, v)
            return rho / math.pi * (v[1] / math.sqrt(dist2)) / dist2

        c = res[0] // 2
        centre = img[c][c]
        expect_point = [rho / math.pi * i / hgt ** 2 for i in Irgb]
        avg_unit = pixel_average(radiance_unit, world, yfov, res, c, c)
        expect_pix = [avg_unit * i for i in Irgb]
        rel_point = max(abs(centre[k] - expect_point[k]) / expect_point[k] for k in range(3))
        rel_pix = max(abs(centre[k] - expect_pix[k]) / expect_pix[k] for k in range(3))
        good = rel_point < 1e-3
        ok &= good
        lines.append(f"{'ok  ' if good else 'FAIL'} radiometry ({label}): centre pixel {[round(v, 6) for v in centre]}, "
                     f"rho/pi I/h^2 = {[round(v, 6) for v in expect_point]} (rel. err {rel_point:.2e}); "
                     f"vs the exact pixel average {[round(v, 6) for v in expect_pix]}: {rel_pix:.2e}; "
                     f"d0 = {d0:.3g} (d_min {scene['d_min']:.3g}, bias < {(d0 / scene['d_min']) ** 2:.1e})")
        worst = 0.0
        for r in range(res[1]):
            for cc in range(res[0]):
                e = pixel_average(radiance_unit, world, yfov, res, r, cc, n=8) * Irgb[0]
                worst = max(worst, abs(img[r][cc][0] - e) / e)
        good = worst < 1e-3
        ok &= good
        lines.append(f"{'ok  ' if good else 'FAIL'} radiometry ({label}): max rel. error of all {res[0] * res[1]} pixels "
                     f"(red) vs the analytic pixel average: {worst:.2e} (POV-Ray's half-float output: <= 4.9e-4)")

    # 2. orientation and pixel alignment: camera at (0, 0, 3) looking down -Z (identity
    #    rotation), |y| <= 1.5 and |x| <= 2 visible at z = 0, 40 x 30 pixels of 0.1 x 0.1.
    #    The only surface is the quad x in [-3, 0], y in [0, 3] (world top-left quadrant),
    #    lit by a light at the camera: rows 0-14 x columns 0-19 must be lit, every other pixel 0;
    #    the lit pixels beside the quad's edges (row 14, column 19) must be fully covered.
    res = (40, 30)
    yfov = 2 * math.atan(0.5)
    quad = ([[-3, 0, 0], [0, 0, 0], [0, 3, 0], [-3, 3, 0]], [1.0, 1.0, 1.0])
    doc, world = test_scene([quad], [([0, 0, 3], [math.pi] * 3)], [0, 0, 3], [0, 0, 0, 1], yfov)
    gpath = os.path.join(out_dir, "orientation.gltf")
    with open(gpath, "w") as fh:
        json.dump(doc, fh)
    scene = convert(gpath, res)
    exr = os.path.join(out_dir, "orientation.exr")
    render(scene, res, exr, keep_dir=os.path.join(out_dir, "orientation-work"))
    _, _, img = read_exr(exr)

    def radiance_o(eye, d):
        s = -eye[2] / d[2]
        p = [eye[k] + s * d[k] for k in range(3)]
        if not (-3 <= p[0] <= 0 and 0 <= p[1] <= 3):
            return None
        v = sub([0, 0, 3], p)
        dist2 = dot(v, v)
        return 1.0 / math.pi * math.pi * (v[2] / math.sqrt(dist2)) / dist2

    lit_ok = all((img[r][c][0] > 0) == (r < 15 and c < 20) for r in range(30) for c in range(40))
    ok &= lit_ok
    lines.append(f"{'ok  ' if lit_ok else 'FAIL'} orientation: lit pixels are exactly rows 0-14 x columns 0-19 "
                 f"(world top-left at the image top-left, row 0 at the top, not mirrored)")
    for (r, c) in ((14, 19), (0, 0), (14, 0), (0, 19)):
        e = pixel_average(radiance_o, world, yfov, res, r, c)
        rel = abs(img[r][c][0] - e) / e
        good = rel < 1e-3
        ok &= good
        lines.append(f"{'ok  ' if good else 'FAIL'} alignment: pixel (row {r}, col {c}) = {img[r][c][0]:.6f}, "
                     f"analytic pixel average {e:.6f} (rel. err {rel:.2e})")
    good = all(img[r][c] == [0.0, 0.0, 0.0] for r, c in ((15, 19), (14, 20), (15, 20)))
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} alignment: pixels (15, 19), (14, 20), (15, 20) beside the quad's edges are 0")
    return ok, lines


# ---------------------------------------------------------------------------------------
# jobs and manifest
# ---------------------------------------------------------------------------------------

def job_paths(name):
    base = os.path.join(OUT_DIR, f"{name}.direct")
    return base + ".povray.exr", base + ".exr", base + ".var.exr"


def run_job(name, aa_depth, supersample, out=None):
    rel, res = SCENES[name]
    scene = convert(os.path.join(REPO, rel), res)
    default_out, ref, var = job_paths(name)
    out = out or default_out
    seconds, d0 = render(scene, res, out, aa_depth, supersample)
    version, deb = povray_version()
    entry = {
        "reference": os.path.relpath(out, REPO),
        "scene": rel,
        "scene_sha256": scene_hash.scene_sha256(os.path.join(REPO, rel)),
        "integrator": "direct",
        "strata_args": ["--integrator", "direct", "--max-depth", "1", "--resolution", f"{res[0]}x{res[1]}"],
        "renderer": "povray",
        "renderer_version": version,
        "debian_package": f"povray {deb}" if deb else None,
        "resolution": [res[0], res[1]],
        "antialiasing": {
            "Antialias": "on", "Sampling_Method": 1, "Antialias_Threshold": 0.0, "Antialias_Depth": aa_depth,
            "Jitter": "off",
            "supersample": supersample,
            "render_resolution": [supersample * res[0], supersample * res[1]],
            "samples_per_pixel": supersample * supersample * (aa_depth * aa_depth + 1),
            "pattern": f"POV-Ray renders {supersample * res[0]}x{supersample * res[1]}; each of those pixels is "
                       f"the mean of its centre and a {aa_depth}x{aa_depth} grid of its sub-pixel centres (POV-Ray 3.7 "
                       f"SupersampleOnePixel: divides by depth^2 + 1, so the centre counts twice); threshold 0 "
                       f"supersamples every pixel; then oiiotool --resize:filter=box averages "
                       f"{supersample}x{supersample} blocks (the exact block mean within 3e-7)",
        },
        "ini_options": ini_options((supersample * res[0], supersample * res[1]), aa_depth),
        "global_settings": "assumed_gamma 1.0 max_trace_level 1 ambient_light rgb 0",
        "finish": FINISH,
        "lights": {
            "count": len(scene["lights"]),
            "fade_power": 2,
            "fade_distance_d0": d0,
            "light_colour": "I / pi / (2 d0^2), I = glTF color x intensity",
            "smallest_light_triangle_distance": scene["d_min"],
            "max_relative_error_from_d0": (d0 / scene["d_min"]) ** 2,
        },
        "triangles": scene["triangles"],
        "normals": "glTF NORMAL -> mesh2 normal_vectors" if all(scene["has_normals"]) else
                   ("none: flat" if not any(scene["has_normals"]) else "mixed"),
        "output": "POV-Ray +FE (half-float OpenEXR, linear, no gamma, no clamping) -> oiiotool -d float "
                  "--resize:filter=box --compression zip (float32)",
        "command": f"tools/references/make_povray_reference.sh {name}",
        "render_seconds": round(seconds, 1),
        "warnings": scene["warnings"],
        "notes": [
            "Direct lighting only: POV-Ray's diffuse finish with point lights and hard shadows, no radiosity, "
            "no reflection: the image is emission (none) + sum over lights of rho/pi I cos / d^2 x visibility, "
            "i.e. strata --integrator direct --max-depth 1 and Mitsuba path max_depth 2.",
            "Camera given by explicit location/direction/right/up in glTF world coordinates (right = camera +X x "
            "2 tan(yfov/2) W/H, up = camera +Y x 2 tan(yfov/2)): no mirroring; checked by povray_refs.py --test.",
            "Noise-free (deterministic grids, jitter off); the error is the grid quadrature of the box filter at "
            "silhouettes and shadow boundaries, POV-Ray's half-float rounding (<= 4.9e-4 relative per POV-Ray "
            "pixel, averaged over the supersample block) and the d0 bias above.",
            "Both sides of each triangle are lit (POV-Ray faces the normal toward the viewer), as in strata and "
            "Mitsuba's twosided diffuse; glTF znear is ignored (no geometry is that close).",
        ],
    }
    if os.path.exists(ref) and os.path.exists(var):
        entry["comparison_with_mitsuba"] = dict(compare(out, ref, var), mitsuba_reference=os.path.relpath(ref, REPO))
    return entry


def update_manifest(entries):
    path = os.path.join(OUT_DIR, MANIFEST)
    old = {}
    if os.path.exists(path):
        with open(path) as fh:
            for e in json.load(fh).get("references", []):
                old[(e["scene"], e["integrator"])] = e
    for e in entries:
        old[(e["scene"], e["integrator"])] = e
    version, deb = povray_version()
    oiio = subprocess.run(["oiiotool", "--version"], capture_output=True, text=True).stdout.strip()
    doc = {
        "description": "Reference images of strata's point-light scenes rendered with POV-Ray 3.7 (a second, "
                       "independent renderer beside the Mitsuba references of manifest.json). Each "
                       "<scene>.direct.povray.exr is linear Rec.709 RGB, float32, ZIP, noise-free. "
                       "Conversion: tools/references/povray_refs.py (module docstring).",
        "hash_algorithm": scene_hash.ALGORITHM,
        "regenerate_all": "tools/references/make_povray_reference.sh",
        "environment": {"povray": version, "debian_package": deb, "oiiotool": oiio, "python": sys.version.split()[0]},
        "references": sorted(old.values(), key=lambda e: e["scene"]),
    }
    with open(path, "w") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("jobs", nargs="*", help=f"scene names (default: all of {JOBS})")
    ap.add_argument("--test", metavar="DIR", help="run the radiometry / orientation self-tests, writing into DIR")
    ap.add_argument("--compare", action="store_true", help="only compare the existing POV-Ray and Mitsuba images")
    ap.add_argument("--aa-depth", type=int, default=AA_DEPTH, help="Antialias_Depth (testing; committed: %(default)s)")
    ap.add_argument("--supersample", type=int, default=SUPERSAMPLE,
                    help="render at this multiple of the resolution, then box-average (committed: %(default)s)")
    ap.add_argument("--out", metavar="DIR", help="write the images here instead (testing: no manifest)")
    ap.add_argument("--keep", metavar="DIR", help="with --pov-only: where to write scene.pov / render.ini")
    ap.add_argument("--pov-only", action="store_true", help="write the .pov / .ini into --keep DIR, do not render")
    args = ap.parse_args()
    for tool in ("povray", "oiiotool"):
        if shutil.which(tool) is None:
            print(f"povray_refs: {tool} not found (Debian: apt-get install povray openimageio-tools)", file=sys.stderr)
            return 1
    if args.test:
        ok, lines = run_tests(args.test)
        print("\n".join(lines))
        print("checks:", "passed" if ok else "FAILED")
        return 0 if ok else 1
    jobs = args.jobs or JOBS
    unknown = [j for j in jobs if j not in SCENES]
    if unknown:
        print(f"unknown scenes {unknown}; known: {sorted(SCENES)}", file=sys.stderr)
        return 2
    if args.pov_only:
        for name in jobs:
            rel, res = SCENES[name]
            scene = convert(os.path.join(REPO, rel), res)
            d = os.path.join(args.keep or ".", name)
            os.makedirs(d, exist_ok=True)
            write_pov(scene, os.path.join(d, "scene.pov"), D0_FRACTION * scene["d_min"])
            with open(os.path.join(d, "render.ini"), "w") as fh:
                fh.write("\n".join(["Input_File_Name=scene.pov", "Output_File_Name=render.exr"]
                                   + ini_options((args.supersample * res[0], args.supersample * res[1]),
                                                 args.aa_depth)) + "\n")
            print(f"wrote {d}/scene.pov and render.ini (run: cd {shlex.quote(d)} && povray render.ini)")
        return 0
    if args.compare:
        for name in jobs:
            out, ref, var = job_paths(name)
            print(name, json.dumps(compare(out, ref, var), indent=1))
        return 0
    entries = []
    if args.out:
        os.makedirs(args.out, exist_ok=True)
    for name in jobs:
        out = os.path.join(args.out, f"{name}.direct.povray.exr") if args.out else None
        e = run_job(name, args.aa_depth, args.supersample, out)
        c = e.get("comparison_with_mitsuba", {})
        print(f"{name}: {e['render_seconds']} s, d0 {e['lights']['fade_distance_d0']:.3g} "
              f"(bias < {e['lights']['max_relative_error_from_d0']:.1e}); vs Mitsuba: mean rel. diff "
              f"{c.get('mean_relative_difference', float('nan')):+.2e}, 8x8 blocks mean |rel| "
              f"{c.get('block_mean_relative_difference', {}).get('mean_abs', float('nan')):.2e}, "
              f">5 sigma {c.get('fraction_pixels_over_5_sigma', float('nan')):.3%}", flush=True)
        entries.append(e)
    if args.aa_depth == AA_DEPTH and args.supersample == SUPERSAMPLE and not args.out:
        update_manifest(entries)
    else:
        print("(--out or non-default settings: manifest not written)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
