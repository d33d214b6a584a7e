#!/usr/bin/env python3
"""Writes the HDRI race scenes (issue 43, part 3) as .glb files into a cache folder.

    make_hdri_assets.py [OUT_DIR] [--shared DIR]     # defaults: ~/.cache/strata/races, ../shared/scenes

Standard library only (the mesh readers of mesh_to_glb.py). The meshes are large (5-8 MB per
file), so the scenes live outside the repository; tools/peers/hdri-races.json names them by
file name under this folder. Every run writes the same bytes, then re-reads each file with
mesh_to_glb.check() (bounds, min/max, indices) and prints its triangle count and sha256.

Scenes (y up, metres-ish; each has one perspective camera, yfov 0.7 rad, aspect 1, for the
races' 128x128 images, a 3/4 view from slightly above that fills most of the frame with the
asset, some floor and some sky):

- armadillo-gold.glb: the Stanford Armadillo (345,944 triangles; scaled to 1.5 tall, standing
  on the floor) in glossy gold: baseColor (1, 0.766, 0.336), metallic 1, roughness 0.25.
- armadillo-plastic.glb: the same mesh, floor and camera in glossy red plastic: baseColor
  (0.8, 0.05, 0.04), metallic 0, roughness 0.3.
- spheres.glb: 20 spheres of Khronos' MetalRoughSpheresNoTextures (10,600 triangles each, their
  own smooth normals and their own materials): its metallic 0 and metallic 1 rows, grey and
  golden, at roughness 1/6 .. 5/6 (its mirror and roughness-1 columns left out), laid out 5 x 4
  on the floor, the metals in the front and back rows.

Every scene has a floor quad y = 0, 30 x 30, baseColor 0.5 grey, metallic 0, roughness 0.5.

Normals: the Armadillo PLY has none; each vertex gets the area-weighted sum of its faces'
normals (the unnormalised cross products, accumulated in float64 in file order, so the output
is deterministic), normalised. The spheres keep the source's NORMAL accessor.
"""
import argparse
import hashlib
import json
import math
import os
import struct
import sys
from array import array

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.dont_write_bytecode = True
sys.path.insert(0, HERE)
import mesh_to_glb  # noqa: E402  (read_ply, finish_mesh, load_gltf, read_accessor, check)
from add_camera import look_at_quaternion  # noqa: E402

YFOV = 0.7
ASPECT = 1.0
FLOOR_HALF = 15.0
FLOOR_MATERIAL = {"name": "floor grey", "pbrMetallicRoughness": {
    "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}}
GOLD = {"name": "glossy gold", "pbrMetallicRoughness": {
    "baseColorFactor": [1.0, 0.766, 0.336, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.25}}
RED_PLASTIC = {"name": "glossy red plastic", "pbrMetallicRoughness": {
    "baseColorFactor": [0.8, 0.05, 0.04, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.3}}
ARMADILLO_HEIGHT = 1.5


class Part:
    """One primitive: float32 positions and normals (flat xyz), uint32 indices, a material."""

    def __init__(self, name, pos, nrm, idx, material):
        self.name, self.pos, self.nrm, self.idx, self.material = name, array("f", pos), array("f", nrm), \
            array("I", idx), material


def floor_part(material_index):
    s = FLOOR_HALF
    pos = [-s, 0.0, -s, -s, 0.0, s, s, 0.0, s, s, 0.0, -s]
    return Part("floor", pos, [0.0, 1.0, 0.0] * 4, [0, 1, 2, 0, 2, 3], material_index)


def signed_volume(pos, idx):
    v = 0.0
    for t in range(0, len(idx), 3):
        a, b, c = 3 * idx[t], 3 * idx[t + 1], 3 * idx[t + 2]
        ax, ay, az = pos[a], pos[a + 1], pos[a + 2]
        bx, by, bz = pos[b], pos[b + 1], pos[b + 2]
        cx, cy, cz = pos[c], pos[c + 1], pos[c + 2]
        v += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    return v / 6.0


def smooth_normals(pos, idx):
    """Area-weighted vertex normals: the sum of the incident faces' cross products, normalised."""
    n = [0.0] * len(pos)
    for t in range(0, len(idx), 3):
        a, b, c = 3 * idx[t], 3 * idx[t + 1], 3 * idx[t + 2]
        ax, ay, az = pos[a], pos[a + 1], pos[a + 2]
        ux, uy, uz = pos[b] - ax, pos[b + 1] - ay, pos[b + 2] - az
        vx, vy, vz = pos[c] - ax, pos[c + 1] - ay, pos[c + 2] - az
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        for k in (a, b, c):
            n[k] += nx
            n[k + 1] += ny
            n[k + 2] += nz
    degenerate = 0
    for k in range(0, len(n), 3):
        length = math.sqrt(n[k] * n[k] + n[k + 1] * n[k + 1] + n[k + 2] * n[k + 2])
        if length > 0:
            n[k], n[k + 1], n[k + 2] = n[k] / length, n[k + 1] / length, n[k + 2] / length
        else:
            n[k], n[k + 1], n[k + 2] = 0.0, 1.0, 0.0
            degenerate += 1
    return n, degenerate


def armadillo(shared):
    """The Armadillo, scaled to ARMADILLO_HEIGHT, centred on x = z = 0, its lowest point on y = 0."""
    path = os.path.join(shared, "stanford_armadillo", "Armadillo.ply")
    pos, idx, stats = mesh_to_glb.read_ply(path)
    pos32, idx, lo, hi = mesh_to_glb.finish_mesh(pos, idx, stats, path)
    s = ARMADILLO_HEIGHT / (hi[1] - lo[1])
    off = [-(lo[0] + hi[0]) / 2, -lo[1], -(lo[2] + hi[2]) / 2]
    p = array("d", pos32)
    for c in range(3):
        p[c::3] = array("d", ((x + off[c]) * s for x in p[c::3]))
    if signed_volume(p, idx) < 0:  # faces wound clockwise seen from outside: turn them
        for t in range(0, len(idx), 3):
            idx[t + 1], idx[t + 2] = idx[t + 2], idx[t + 1]
    nrm, degenerate = smooth_normals(p, idx)
    return p, nrm, idx, degenerate


def sphere_parts(shared, first_material):
    """MetalRoughSpheresNoTextures' spheres (rows metallic 0 and 1, grey and golden, roughness
    columns 1..5), flattened to world space, scaled x1000 (radius 0.35, 1 apart), resting on y = 0.
    Returns (parts, materials)."""
    path = os.path.join(shared, "metal_rough_spheres_no_textures", "MetalRoughSpheresNoTextures.gltf")
    doc, buffers, problems = mesh_to_glb.load_gltf(path)
    if problems:
        raise mesh_to_glb.MeshError(f"{path}: {problems}")
    by_name = {n.get("name"): n for n in doc["nodes"]}
    scale = 1000.0
    rows = ["g_m100%", "m0%", "g_m0%", "m100%"]  # back to front: metals at the back and the front
    cols = ["r16%", "r33%", "r50%", "r66%", "r83%"]
    parts, materials = [], []
    for zi, row in enumerate(rows):
        for xi, col in enumerate(cols):
            node = by_name[f"{row}_{col}"]
            prim = doc["meshes"][node["mesh"]]["primitives"][0]
            src = mesh_to_glb.read_accessor(doc, buffers, prim["attributes"]["POSITION"], problems)
            nrm = mesh_to_glb.read_accessor(doc, buffers, prim["attributes"]["NORMAL"], problems)
            idx = mesh_to_glb.read_accessor(doc, buffers, prim["indices"], problems)
            radius = max(abs(v) for v in src) * scale
            centre = [(xi - 2) * 1.0, radius, (zi - 1.5) * 1.0]
            pos = array("f", src)
            for c in range(3):
                pos[c::3] = array("f", (v * scale + centre[c] for v in src[c::3]))
            mat = dict(doc["materials"][prim["material"]])
            mat["name"] = f"{row}_{col} ({mat['name']})"
            materials.append(mat)
            parts.append(Part(f"{row}_{col}", pos, nrm, idx, first_material + len(materials) - 1))
    if problems:
        raise mesh_to_glb.MeshError(f"{path}: {problems}")
    return parts, materials


def frame_camera(lo, hi, azimuth_deg, elevation_deg, fill, lift=0.0):
    """A camera looking at the box's centre (raised by `lift` x its height) from azimuth (about +Y,
    0 = from +Z) and elevation, at the distance where every corner of the box falls inside `fill`
    of the half field of view (square image). Returns (eye, rotation quaternion)."""
    target = [(a + b) / 2 for a, b in zip(lo, hi)]
    target[1] += lift * (hi[1] - lo[1])
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    back = [math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)]  # from target to eye
    fwd = [-c for c in back]
    right = [fwd[1] * 0 - fwd[2] * 1, fwd[2] * 0 - fwd[0] * 0, fwd[0] * 1 - fwd[1] * 0]  # fwd x up
    rn = math.sqrt(sum(c * c for c in right))
    right = [c / rn for c in right]
    up = [right[1] * fwd[2] - right[2] * fwd[1], right[2] * fwd[0] - right[0] * fwd[2],
          right[0] * fwd[1] - right[1] * fwd[0]]
    t = math.tan(YFOV / 2) * fill
    dist = 0.0
    for cx in (lo[0], hi[0]):
        for cy in (lo[1], hi[1]):
            for cz in (lo[2], hi[2]):
                c = [cx - target[0], cy - target[1], cz - target[2]]
                x = sum(a * b for a, b in zip(c, right))
                y = sum(a * b for a, b in zip(c, up))
                z = sum(a * b for a, b in zip(c, fwd))
                dist = max(dist, abs(x) / (t * ASPECT) - z, abs(y) / t - z)
    eye = [tc + dist * b for tc, b in zip(target, back)]
    eye = [float(struct.unpack("<f", struct.pack("<f", v))[0]) for v in eye]  # float32, as stored
    return eye, look_at_quaternion(eye, target), dist


def write_glb(path, parts, materials, eye, rotation, znear, generator_note):
    blob = bytearray()
    views, accessors, meshes, nodes = [], [], [], []

    def add(data, target, acc):
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        blob.extend(data)
        acc["bufferView"] = len(views) - 1
        accessors.append(acc)
        return len(accessors) - 1

    def le(a):
        if sys.byteorder == "big":
            a = array(a.typecode, a)
            a.byteswap()
        return a.tobytes()

    for part in parts:
        nv = len(part.pos) // 3
        lo = [min(part.pos[c::3]) for c in range(3)]
        hi = [max(part.pos[c::3]) for c in range(3)]
        p = add(le(part.pos), 34962, {"componentType": 5126, "count": nv, "type": "VEC3", "min": lo, "max": hi})
        n = add(le(part.nrm), 34962, {"componentType": 5126, "count": nv, "type": "VEC3"})
        i = add(le(part.idx), 34963, {"componentType": 5125, "count": len(part.idx), "type": "SCALAR"})
        meshes.append({"name": part.name, "primitives": [
            {"attributes": {"POSITION": p, "NORMAL": n}, "indices": i, "material": part.material, "mode": 4}]})
        nodes.append({"name": part.name, "mesh": len(meshes) - 1})
    nodes.append({"name": "race camera", "camera": 0, "translation": eye, "rotation": rotation})
    doc = {
        "asset": {"version": "2.0", "generator": "strata tools/scenes/make_hdri_assets.py (" + generator_note + ")"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [{"name": "race camera", "type": "perspective",
                     "perspective": {"yfov": YFOV, "aspectRatio": ASPECT, "znear": znear}}],
        "buffers": [{"byteLength": len(blob)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(blob)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(struct.pack("<III", mesh_to_glb.GLB_MAGIC, 2, total))
        f.write(struct.pack("<II", len(js), mesh_to_glb.CHUNK_JSON) + js)
        f.write(struct.pack("<II", len(blob), mesh_to_glb.CHUNK_BIN) + bytes(blob))
    os.replace(tmp, path)


def bounds(parts):
    lo = [min(min(p.pos[c::3]) for p in parts) for c in range(3)]
    hi = [max(max(p.pos[c::3]) for p in parts) for c in range(3)]
    return lo, hi


# Camera of each scene: (azimuth, elevation, fill, lift); azimuth 0 looks from +Z.
ARMADILLO_VIEW = (-145.0, 12.0, 0.92, 0.0)
SPHERES_VIEW = (-35.0, 18.0, 1.05, 0.0)


def main():
    mesh_to_glb._check_itemsizes()
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", nargs="?", default=os.path.join(os.path.expanduser("~"), ".cache", "strata", "races"))
    ap.add_argument("--shared", default=os.path.join(os.path.dirname(REPO), "shared", "scenes"),
                    help="the shared scene collection (default ../shared/scenes)")
    args = ap.parse_args()

    written = []
    pos, nrm, idx, degenerate = armadillo(args.shared)
    for name, mat in (("armadillo-gold", GOLD), ("armadillo-plastic", RED_PLASTIC)):
        parts = [Part("armadillo", pos, nrm, idx, 1), floor_part(0)]
        lo, hi = bounds(parts[:1])
        eye, rot, dist = frame_camera(lo, hi, *ARMADILLO_VIEW)
        path = os.path.join(args.out, name + ".glb")
        write_glb(path, parts, [FLOOR_MATERIAL, mat], eye, rot, 0.01, name)
        written.append((path, f"armadillo {len(idx) // 3} triangles ({degenerate} vertices without a normal), "
                              f"{mat['name']}; camera at distance {dist:.3f}"))
    parts, mats = sphere_parts(args.shared, 1)
    lo, hi = bounds(parts)
    eye, rot, dist = frame_camera(lo, hi, *SPHERES_VIEW)
    path = os.path.join(args.out, "spheres.glb")
    write_glb(path, parts + [floor_part(0)], [FLOOR_MATERIAL] + mats, eye, rot, 0.01, "spheres")
    written.append((path, f"{len(parts)} spheres, {sum(len(p.idx) for p in parts) // 3} triangles; camera at "
                          f"distance {dist:.3f}"))

    failed = False
    for path, what in written:
        tris, problems = mesh_to_glb.check(path, verbose=False)
        with open(path, "rb") as f:
            sha = hashlib.sha256(f.read()).hexdigest()
        print(f"{path}: {tris} triangles in the scene ({what}); sha256 {sha[:16]}"
              + ("" if not problems else "; PROBLEMS: " + "; ".join(problems)))
        failed |= bool(problems)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
