#!/usr/bin/env python3
"""Write strata's analytic test scenes and loader fixtures (glTF 2.0).

Standard library only.  Every output is written deterministically (the same
bytes on every run) and is re-read and validated before the script exits.

Usage:
    python3 tools/scenes/make_analytic.py [SCENES_DIR] [--test-data DIR]

SCENES_DIR defaults to <repo>/scenes, --test-data to <repo>/tests/data.

Outputs (conventions are glTF's: right-handed, +Y up, metres, a camera looks
down its local -Z with +Y up, yfov is the vertical field of view in radians,
counter-clockwise triangles are front-facing):

  SCENES_DIR/ao-open-plane.gltf         plane y=0, |x|,|z| <= 1000; AO == 1
  SCENES_DIR/ao-wall.gltf               floor y=0 + wall x=0; AO == 1/2
                                        (bound on the error: see WALL_* below)
  SCENES_DIR/ao-open-plane-offset.gltf  the same scenes under one root node
  SCENES_DIR/ao-wall-offset.gltf        translated by (1e4, 1e4, 1e4)
  TEST_DATA/hierarchy.gltf              node-hierarchy loader fixture
  TEST_DATA/hierarchy.expected.json     its hand-derived world-space triangles
  TEST_DATA/bad/*                       fixtures for loader error handling
"""

import argparse
import base64
import json
import math
import struct
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
GENERATOR = "strata tools/scenes/make_analytic.py"
DATA_URI_PREFIX = "data:application/octet-stream;base64,"

# glTF enums
FLOAT = 5126
UNSIGNED_INT = 5125
ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963
MODE_POINTS = 0
MODE_TRIANGLES = 4
MODE_TRIANGLE_STRIP = 5

COMPONENT_SIZE = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
COMPONENT_FMT = {5120: "b", 5121: "B", 5122: "h", 5123: "H", 5125: "I", 5126: "f"}
TYPE_COUNT = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}

# Shared camera parameters of the AO scenes.
YFOV = 0.5
ASPECT = 1.0
ZNEAR = 0.01
S45 = math.sqrt(0.5)  # sin(45 deg) == cos(45 deg)
# Rotation by -90 deg about +X, [x, y, z, w]: maps local -Z to world -Y (look
# straight down) and local +Y to world -Z (image "up" is world -Z).
LOOK_DOWN = [-S45, 0.0, 0.0, S45]

OFFSET = [10000.0, 10000.0, 10000.0]

# ---------------------------------------------------------------------------
# ao-wall: analytic AO and the bound on its error.
#
# A floor point P = (d, 0, z0) (0 < d) with normal +Y sees the wall x = 0,
# 0 <= y <= H, |z| <= L.  Sample the cosine-weighted hemisphere with Malley's
# method: (dx, dz) uniform in the unit disk, dy = sqrt(1 - dx^2 - dz^2).
# Every direction with dx > 0 is unoccluded: exactly half of the cosine mass.
# A direction with dx < 0 reaches the plane x = 0 at t = d/|dx|, at height
# y = d*dy/|dx| and z = z0 + d*dz/|dx|; it is blocked unless it clears the top
# (y > H) or passes a side edge (|z| > L).  So AO = 1/2 + eps, with
#   eps_top  = fraction with dx<0 and |dx| < (d/H)*dy
#            = k / (2*sqrt(1 + k^2)),  k = d/H            (exact, infinite L)
#   eps_side = fraction with dx<0 and |dx|*(L -/+ z0) < d*|dz| on the +/- side
#            = (atan(d/(L - z0)) + atan(d/(L + z0))) / (2*pi)
#                                                        (two wedges in the disk)
# and max(eps_top, eps_side) <= eps <= eps_top + eps_side.
# The camera at (1, 1, 0) looking down with yfov 0.5 and aspect 1 sees
# x in [1 - tan(0.25), 1 + tan(0.25)] = [0.7447, 1.2553] and |z| <= 0.2553.
# With H = L = 1e5, at the farthest visible point (d = 1.2553, |z0| = 0.2553):
#   eps_top = 6.277e-6, eps_side = 3.996e-6, eps <= 1.0272e-5,
# i.e. AO in [0.5, 0.5 + 1.03e-5]: a relative error of at most 2.06e-5
# (at the nearest visible point, d = 0.7447: eps <= 6.1e-6, relative 1.2e-5).
# The script recomputes these numbers below and asserts them.
# (The floor itself never occludes a floor point: it is coplanar with it.)
# ---------------------------------------------------------------------------
WALL_H = 100000.0
WALL_L = 100000.0
FLOOR_X_MAX = 100000.0


def wall_escape(d, z0, h=WALL_H, half_len=WALL_L):
    """(eps_top, eps_side) for a floor point at distance d from the wall."""
    k = d / h
    top = k / (2.0 * math.sqrt(1.0 + k * k))
    side = (math.atan(d / (half_len - abs(z0))) + math.atan(d / (half_len + abs(z0)))) / (2.0 * math.pi)
    return top, side


# ---------------------------------------------------------------------------
# Small vector / quaternion / 4x4 matrix helpers (row-major M[r][c] in here;
# glTF stores matrices column-major, see to_column_major / from_column_major).
# ---------------------------------------------------------------------------


def vsub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def vcross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def vdot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def vnorm(a):
    n = math.sqrt(vdot(a, a))
    assert n > 0.0, "zero-length vector"
    return [a[0] / n, a[1] / n, a[2] / n]


def vclose(a, b, tol=1e-12):
    return len(a) == len(b) and all(abs(x - y) <= tol for x, y in zip(a, b))


def qrotate(q, v):
    """Rotate v by the unit quaternion q = [x, y, z, w] (v' = q v q*)."""
    u = q[:3]
    w = q[3]
    t = [2.0 * c for c in vcross(u, v)]
    ut = vcross(u, t)
    return [v[i] + w * t[i] + ut[i] for i in range(3)]


def mat_identity():
    return [[1.0 if r == c else 0.0 for c in range(4)] for r in range(4)]


def mat_mul(a, b):
    return [[sum(a[r][k] * b[k][c] for k in range(4)) for c in range(4)] for r in range(4)]


def mat_translation(t):
    m = mat_identity()
    m[0][3], m[1][3], m[2][3] = t
    return m


def mat_scale(s):
    m = mat_identity()
    m[0][0], m[1][1], m[2][2] = s
    return m


def mat_rotation(q):
    x, y, z, w = q
    m = mat_identity()
    m[0][0:3] = [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)]
    m[1][0:3] = [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)]
    m[2][0:3] = [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]
    return m


def to_column_major(m):
    return [m[r][c] for c in range(4) for r in range(4)]


def from_column_major(a):
    assert len(a) == 16
    return [[a[c * 4 + r] for c in range(4)] for r in range(4)]


def mat_point(m, p):
    out = [sum(m[r][k] * p[k] for k in range(3)) + m[r][3] for r in range(4)]
    assert abs(out[3] - 1.0) < 1e-12, "not an affine matrix"
    return out[:3]


def mat_dir(m, v):
    return [sum(m[r][k] * v[k] for k in range(3)) for r in range(3)]


def upper3(m):
    return [row[:3] for row in m[:3]]


def det3(a):
    return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))


def inverse_transpose3(a):
    """(A^-1)^T = cofactor(A) / det(A)."""
    d = det3(a)
    assert abs(d) > 1e-12, "singular transform"
    cof = [[0.0] * 3 for _ in range(3)]
    for r in range(3):
        for c in range(3):
            rr = [i for i in range(3) if i != r]
            cc = [j for j in range(3) if j != c]
            minor = a[rr[0]][cc[0]] * a[rr[1]][cc[1]] - a[rr[0]][cc[1]] * a[rr[1]][cc[0]]
            cof[r][c] = (-1) ** (r + c) * minor
    return [[cof[r][c] / d for c in range(3)] for r in range(3)]


def mat3_vec(a, v):
    return [sum(a[r][k] * v[k] for k in range(3)) for r in range(3)]


def node_local_matrix(node):
    if "matrix" in node:
        assert not any(k in node for k in ("translation", "rotation", "scale")), "matrix and TRS"
        return from_column_major(node["matrix"])
    t = mat_translation(node.get("translation", [0.0, 0.0, 0.0]))
    r = mat_rotation(node.get("rotation", [0.0, 0.0, 0.0, 1.0]))
    s = mat_scale(node.get("scale", [1.0, 1.0, 1.0]))
    return mat_mul(t, mat_mul(r, s))  # glTF: M = T * R * S


def clean(x):
    """Round away double-precision noise (1e-12) and negative zero."""
    r = round(x, 12)
    return 0.0 if r == 0 else r


def cleanv(v):
    return [clean(x) for x in v]


# ---------------------------------------------------------------------------
# glTF writer
# ---------------------------------------------------------------------------


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


class Gltf:
    """Builds one glTF document with a single embedded buffer."""

    def __init__(self):
        self.buffer = bytearray()
        self.buffer_views = []
        self.accessors = []
        self.meshes = []
        self.nodes = []
        self.cameras = []
        self.materials = [{
            "name": "white",
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
        }]
        self.scene_nodes = []
        self.extensions_used = None
        self.extensions_required = None

    def _view(self, data, target):
        while len(self.buffer) % 4:
            self.buffer.append(0)
        offset = len(self.buffer)
        self.buffer.extend(data)
        self.buffer_views.append({
            "buffer": 0,
            "byteOffset": offset,
            "byteLength": len(data),
            "target": target,
        })
        return len(self.buffer_views) - 1

    def vec3(self, values, with_min_max):
        data = b"".join(struct.pack("<3f", *v) for v in values)
        acc = {
            "bufferView": self._view(data, ARRAY_BUFFER),
            "byteOffset": 0,
            "componentType": FLOAT,
            "count": len(values),
            "type": "VEC3",
        }
        if with_min_max:
            stored = [[f32(c) for c in v] for v in values]
            acc["max"] = [max(v[i] for v in stored) for i in range(3)]
            acc["min"] = [min(v[i] for v in stored) for i in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def indices(self, values):
        data = struct.pack("<%dI" % len(values), *values)
        self.accessors.append({
            "bufferView": self._view(data, ELEMENT_ARRAY_BUFFER),
            "byteOffset": 0,
            "componentType": UNSIGNED_INT,
            "count": len(values),
            "type": "SCALAR",
        })
        return len(self.accessors) - 1

    def primitive(self, positions, normals=None, indices=None, mode=MODE_TRIANGLES):
        attrs = {"POSITION": self.vec3(positions, True)}
        if normals is not None:
            assert len(normals) == len(positions)
            attrs["NORMAL"] = self.vec3(normals, False)
        prim = {"attributes": attrs}
        if indices is not None:
            prim["indices"] = self.indices(indices)
        prim["material"] = 0
        prim["mode"] = mode
        return prim

    def mesh(self, name, primitives):
        self.meshes.append({"name": name, "primitives": primitives})
        return len(self.meshes) - 1

    def node(self, node):
        self.nodes.append(node)
        return len(self.nodes) - 1

    def camera(self, name, yfov, aspect, znear):
        self.cameras.append({
            "name": name,
            "type": "perspective",
            "perspective": {"aspectRatio": aspect, "yfov": yfov, "znear": znear},
        })
        return len(self.cameras) - 1

    def padded_buffer(self):
        data = bytes(self.buffer)
        return data + b"\0" * (-len(data) % 4)

    def document(self, buffer_uri="embed"):
        """The JSON document; buffer_uri: "embed", None (GLB) or a file name."""
        data = self.padded_buffer()
        buf = {"byteLength": len(data)}
        if buffer_uri == "embed":
            buf["uri"] = DATA_URI_PREFIX + base64.b64encode(data).decode("ascii")
        elif buffer_uri is not None:
            buf["uri"] = buffer_uri
        doc = {"asset": {"version": "2.0", "generator": GENERATOR}}
        if self.extensions_used is not None:
            doc["extensionsUsed"] = list(self.extensions_used)
        if self.extensions_required is not None:
            doc["extensionsRequired"] = list(self.extensions_required)
        doc["scene"] = 0
        doc["scenes"] = [{"nodes": list(self.scene_nodes)}]
        doc["nodes"] = self.nodes
        doc["cameras"] = self.cameras
        doc["meshes"] = self.meshes
        doc["materials"] = self.materials
        doc["accessors"] = self.accessors
        doc["bufferViews"] = self.buffer_views
        doc["buffers"] = [buf]
        return doc

    def glb(self):
        doc = json.dumps(self.document(buffer_uri=None), separators=(",", ":")).encode("utf-8")
        doc += b" " * (-len(doc) % 4)
        binary = self.padded_buffer()
        total = 12 + 8 + len(doc) + 8 + len(binary)
        return (struct.pack("<4sII", b"glTF", 2, total)
                + struct.pack("<I4s", len(doc), b"JSON") + doc
                + struct.pack("<I4s", len(binary), b"BIN\0") + binary)


WRITTEN = []


def write_bytes(path, data):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    WRITTEN.append(path)


def write_json(path, doc):
    write_bytes(path, (json.dumps(doc, indent=1, sort_keys=False) + "\n").encode("utf-8"))


# ---------------------------------------------------------------------------
# Geometry
# ---------------------------------------------------------------------------


def quad(g, corners, normal):
    """A two-triangle quad; asserts both triangles face `normal` (CCW front)."""
    idx = [0, 1, 2, 0, 2, 3]
    for t in range(2):
        a, b, c = (corners[i] for i in idx[3 * t:3 * t + 3])
        n = vcross(vsub(b, a), vsub(c, a))
        assert vdot(n, normal) > 0 and vclose(vnorm(n), normal), (n, normal)
    return g.primitive(corners, [normal] * 4, idx)


def floor_corners(x0, x1, z0, z1):
    # (v1-v0) x (v2-v0) = (0,0,dz) x (dx,0,dz) = (0, dx*dz, 0): +Y
    return [[x0, 0.0, z0], [x0, 0.0, z1], [x1, 0.0, z1], [x1, 0.0, z0]]


def check_look_down():
    fwd = qrotate(LOOK_DOWN, [0.0, 0.0, -1.0])
    up = qrotate(LOOK_DOWN, [0.0, 1.0, 0.0])
    assert vclose(fwd, [0.0, -1.0, 0.0], 1e-15), fwd
    assert vclose(up, [0.0, 0.0, -1.0], 1e-15), up
    m = mat_rotation(LOOK_DOWN)  # second, independent route
    assert vclose(mat_dir(m, [0.0, 0.0, -1.0]), [0.0, -1.0, 0.0], 1e-15)
    assert vclose(mat_dir(m, [0.0, 1.0, 0.0]), [0.0, 0.0, -1.0], 1e-15)
    assert abs(vdot(LOOK_DOWN[:3], LOOK_DOWN[:3]) + LOOK_DOWN[3] ** 2 - 1.0) < 1e-15


def ao_scene(kind, offset):
    g = Gltf()
    geometry_nodes = []
    if kind == "open-plane":
        prim = quad(g, floor_corners(-1000.0, 1000.0, -1000.0, 1000.0), [0.0, 1.0, 0.0])
        geometry_nodes.append(g.node({"name": "plane", "mesh": g.mesh("plane", [prim])}))
        cam_pos = [0.0, 1.0, 0.0]
    elif kind == "wall":
        floor = quad(g, floor_corners(0.0, FLOOR_X_MAX, -WALL_L, WALL_L), [0.0, 1.0, 0.0])
        # (v1-v0) x (v2-v0) = (0,H,0) x (0,H,2L) = (2HL, 0, 0): +X
        wall = quad(g, [[0.0, 0.0, -WALL_L], [0.0, WALL_H, -WALL_L],
                        [0.0, WALL_H, WALL_L], [0.0, 0.0, WALL_L]], [1.0, 0.0, 0.0])
        geometry_nodes.append(g.node({"name": "floor", "mesh": g.mesh("floor", [floor])}))
        geometry_nodes.append(g.node({"name": "wall", "mesh": g.mesh("wall", [wall])}))
        cam_pos = [1.0, 1.0, 0.0]
    else:
        raise ValueError(kind)
    cam = g.node({"name": "camera", "camera": g.camera("camera", YFOV, ASPECT, ZNEAR),
                  "translation": cam_pos, "rotation": list(LOOK_DOWN)})
    children = geometry_nodes + [cam]
    if offset:
        root = g.node({"name": "offset_root", "children": children, "translation": list(OFFSET)})
        g.scene_nodes = [root]
    else:
        g.scene_nodes = children
    return g


# ---------------------------------------------------------------------------
# hierarchy fixture
# ---------------------------------------------------------------------------

TRI_POS = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
TRI_NRM = [[0.0, 0.0, 1.0]] * 3
STRIP_POS = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]
R_TRS = {
    "translation": [1.0, 2.0, 3.0],
    "rotation": [0.0, S45, 0.0, S45],  # +90 deg about +Y: x -> -z, z -> x
    "scale": [2.0, 2.0, 2.0],
}
A_T = [0.0, 0.0, 1.0]
# B: a scale of (-1, 1, 1) followed by a translation of (0, 5, 0): T * S.
B_ROWS = mat_mul(mat_translation([0.0, 5.0, 0.0]), mat_scale([-1.0, 1.0, 1.0]))
B_MATRIX = to_column_major(B_ROWS)
assert B_MATRIX == [-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0,
                    0.0, 0.0, 1.0, 0.0, 0.0, 5.0, 0.0, 1.0]


def strip_triangles(n):
    """glTF 2.0 spec, 3.7.2.1: p_i = {v_i, v_(i+(1+i%2)), v_(i+(2-i%2))}."""
    return [[i, i + 1 + i % 2, i + 2 - i % 2] for i in range(n - 2)]


def hierarchy_scene():
    g = Gltf()
    tri = g.mesh("triangle", [g.primitive(TRI_POS, TRI_NRM, [0, 1, 2])])
    strip = g.mesh("strip", [g.primitive(STRIP_POS, None, None, MODE_TRIANGLE_STRIP)])
    # node order: 0 R, 1 A, 2 B, 3 C, 4 camera
    g.node(dict([("name", "R"), ("children", [1, 2])] + list(R_TRS.items())))
    g.node({"name": "A", "mesh": tri, "translation": list(A_T)})
    g.node({"name": "B", "mesh": tri, "matrix": list(B_MATRIX)})
    g.node({"name": "C", "mesh": strip})
    g.node({"name": "camera", "camera": g.camera("camera", 0.8, 1.0, 0.01),
            "translation": [1.5, 7.0, 30.0]})
    g.scene_nodes = [0, 3, 4]
    return g


def hierarchy_expected():
    world_r = mat_mul(mat_translation(R_TRS["translation"]),
                      mat_mul(mat_rotation(R_TRS["rotation"]), mat_scale(R_TRS["scale"])))
    world = {
        "A": mat_mul(world_r, mat_translation(A_T)),
        "B": mat_mul(world_r, B_ROWS),
        "C": mat_identity(),
    }
    nodes = {}
    for name in ("A", "B"):
        m = world[name]
        det = det3(upper3(m))
        flip = det < 0
        nmat = inverse_transpose3(upper3(m))
        pos = [mat_point(m, p) for p in TRI_POS]
        nrm = [vnorm(mat3_vec(nmat, n)) for n in TRI_NRM]
        order = [0, 2, 1] if flip else [0, 1, 2]
        tri = [pos[i] for i in order]
        vn = [nrm[i] for i in order]
        gn = vnorm(vcross(vsub(tri[1], tri[0]), vsub(tri[2], tri[0])))
        for n in vn:
            assert vdot(gn, n) > 0.999999, (name, gn, n)  # winding agrees with the normals
        nodes[name] = {
            "node_index": {"A": 1, "B": 2}[name],
            "mesh": 0,
            "world_matrix_column_major": cleanv(to_column_major(m)),
            "determinant": clean(det),
            "winding_flipped": flip,
            "triangles": [[cleanv(p) for p in tri]],
            "vertex_normals": [[cleanv(n) for n in vn]],
            "geometric_normals": [cleanv(gn)],
        }
    tris, gns = [], []
    for t in strip_triangles(len(STRIP_POS)):
        tri = [mat_point(world["C"], STRIP_POS[i]) for i in t]
        tris.append([cleanv(p) for p in tri])
        gns.append(cleanv(vnorm(vcross(vsub(tri[1], tri[0]), vsub(tri[2], tri[0])))))
    nodes["C"] = {
        "node_index": 3,
        "mesh": 1,
        "world_matrix_column_major": cleanv(to_column_major(world["C"])),
        "determinant": 1.0,
        "winding_flipped": False,
        "strip_vertex_indices": strip_triangles(len(STRIP_POS)),
        "triangles": tris,
        "geometric_normals": gns,
        "flat_normals": gns,
    }

    # Hand-derived values (pencil and paper, independent of the helpers above):
    # R maps p to (1,2,3) + Ry90(2p) with Ry90(x,y,z) = (z, y, -x).
    # A: p+(0,0,1) -> (0,0,1),(1,0,1),(0,1,1) -> x2 -> rot -> (2,0,0),(2,0,-2),(2,2,0)
    #    -> +(1,2,3) = (3,2,3),(3,2,1),(3,4,3); normal (0,0,1) -> (1,0,0).
    # B: (-x, y+5, z) -> (0,5,0),(-1,5,0),(0,6,0) -> x2 -> rot -> (0,10,0),(0,10,2),
    #    (0,12,0) -> +(1,2,3) = (1,12,3),(1,12,5),(1,14,3); its unflipped
    #    geometric normal is -X but the vertex normal is (R*S*diag(-1,1,1))^-T (0,0,1)
    #    = +X, so the loader flips to (1,12,3),(1,14,3),(1,12,5), whose normal is +X.
    # C: identity; strip triangles {0,1,2}, {1,3,2}, both with normal +Z.
    hand = {
        "A": ([[[3, 2, 3], [3, 2, 1], [3, 4, 3]]], [[1, 0, 0]] * 3, [[1, 0, 0]]),
        "B": ([[[1, 12, 3], [1, 14, 3], [1, 12, 5]]], [[1, 0, 0]] * 3, [[1, 0, 0]]),
    }
    for name, (tris_h, vn_h, gn_h) in hand.items():
        assert nodes[name]["triangles"] == [[[float(c) for c in p] for p in t] for t in tris_h], name
        assert nodes[name]["vertex_normals"][0] == [[float(c) for c in n] for n in vn_h], name
        assert nodes[name]["geometric_normals"] == [[float(c) for c in n] for n in gn_h], name
    assert nodes["A"]["determinant"] == 8.0 and nodes["B"]["determinant"] == -8.0
    assert nodes["C"]["triangles"] == [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                                       [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]]
    assert nodes["C"]["geometric_normals"] == [[0.0, 0.0, 1.0]] * 2

    note = (
        "Expected world-space output of a glTF loader for hierarchy.gltf, derived by hand "
        "(tools/scenes/make_analytic.py, independent of any renderer code). Scene roots are "
        "R (node 0), C (node 3) and a camera (node 4); R has TRS translation (1,2,3), rotation "
        "+90 deg about +Y, scale 2, and children A (node 1, translation (0,0,1)) and B (node 2, "
        "matrix = translation(0,5,0) * scale(-1,1,1), column-major). A and B share mesh 0, one "
        "indexed triangle (0,0,0),(1,0,0),(0,1,0) with NORMAL (0,0,1). C has mesh 1, a "
        "non-indexed TRIANGLE_STRIP (mode 5) of 4 vertices without normals. World matrix = "
        "parent * T * R * S (or parent * matrix). Emission order is depth-first pre-order over "
        "scene.nodes: A, B, C. B's world transform has a negative determinant (-8), so its "
        "triangle is emitted with the 2nd and 3rd vertex swapped: then the counter-clockwise "
        "geometric normal normalize((v1-v0)x(v2-v0)) equals the transformed vertex normal "
        "normalize(inverse_transpose(upper3x3) * n) = +X. Strip triangles follow the glTF 2.0 "
        "spec rule p_i = {v_i, v_(i+(1+i%2)), v_(i+(2-i%2))}, i.e. {0,1,2} and {1,3,2}; the form "
        "{v_(i+1), v_i, v_(i+2)} = {2,1,3} for odd i is the same triangle rotated cyclically. "
        "Vertex order within A's and B's triangle is exact; a test may accept any cyclic "
        "rotation of a triangle's vertices (that keeps the winding) but never a swap. Values "
        "are rounded to 1e-12; float32 loaders should compare with a tolerance such as 1e-5."
    )
    return {
        "note": note,
        "source": "hierarchy.gltf",
        "emission_order": ["A", "B", "C"],
        "total_triangles": 4,
        "tolerance": 1e-5,
        "nodes": nodes,
    }


# ---------------------------------------------------------------------------
# bad fixtures
# ---------------------------------------------------------------------------


def one_triangle_scene():
    g = Gltf()
    g.node({"name": "triangle", "mesh": g.mesh("triangle", [g.primitive(TRI_POS, TRI_NRM, [0, 1, 2])])})
    g.node({"name": "camera", "camera": g.camera("camera", 0.8, 1.0, 0.01),
            "translation": [0.25, 0.25, 3.0]})
    g.scene_nodes = [0, 1]
    return g


def points_scene():
    g = Gltf()
    g.node({"name": "points", "mesh": g.mesh("points", [g.primitive(TRI_POS, None, None, MODE_POINTS)])})
    g.node({"name": "camera", "camera": g.camera("camera", 0.8, 1.0, 0.01),
            "translation": [0.25, 0.25, 3.0]})
    g.scene_nodes = [0, 1]
    return g


# ---------------------------------------------------------------------------
# Validation (re-reads what was written)
# ---------------------------------------------------------------------------


def decode_buffers(doc, base_dir, allow_missing=False):
    out = []
    for i, buf in enumerate(doc["buffers"]):
        uri = buf.get("uri")
        if uri is None:
            raise AssertionError("buffer %d has no uri (GLB only)" % i)
        if uri.startswith("data:"):
            assert uri.startswith(DATA_URI_PREFIX), uri[:40]
            data = base64.b64decode(uri[len(DATA_URI_PREFIX):], validate=True)
        else:
            path = base_dir / uri
            if allow_missing and not path.exists():
                out.append(None)
                continue
            data = path.read_bytes()
        assert len(data) == buf["byteLength"], (len(data), buf["byteLength"])
        assert buf["byteLength"] % 4 == 0
        out.append(data)
    return out


def read_accessor(doc, buffers, index):
    acc = doc["accessors"][index]
    bv = doc["bufferViews"][acc["bufferView"]]
    ncomp = TYPE_COUNT[acc["type"]]
    csize = COMPONENT_SIZE[acc["componentType"]]
    data = buffers[bv["buffer"]]
    start = bv.get("byteOffset", 0) + acc.get("byteOffset", 0)
    raw = data[start:start + acc["count"] * ncomp * csize]
    vals = struct.unpack("<%d%s" % (acc["count"] * ncomp, COMPONENT_FMT[acc["componentType"]]), raw)
    if ncomp == 1:
        return list(vals)
    return [list(vals[i:i + ncomp]) for i in range(0, len(vals), ncomp)]


def validate_structure(doc, buffers):
    assert doc["asset"]["version"] == "2.0"
    assert doc["asset"]["generator"] == GENERATOR
    for ext in doc.get("extensionsRequired", []):
        assert ext in doc.get("extensionsUsed", []), ext
    blen = [b["byteLength"] for b in doc["buffers"]]
    for i, bv in enumerate(doc["bufferViews"]):
        off = bv.get("byteOffset", 0)
        assert bv["buffer"] < len(blen)
        assert off % 4 == 0, ("bufferView offset not 4-aligned", i)
        assert off + bv["byteLength"] <= blen[bv["buffer"]], ("bufferView overflows buffer", i)
        assert bv.get("target") in (ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER), ("target", i)
        assert "byteStride" not in bv
    for i, acc in enumerate(doc["accessors"]):
        bv = doc["bufferViews"][acc["bufferView"]]
        csize = COMPONENT_SIZE[acc["componentType"]]
        size = csize * TYPE_COUNT[acc["type"]]
        off = acc.get("byteOffset", 0)
        assert acc["count"] >= 1
        assert off + acc["count"] * size <= bv["byteLength"], ("accessor overflows view", i)
        assert (bv.get("byteOffset", 0) + off) % csize == 0, ("accessor misaligned", i)
    seen_parent = {}
    for i, node in enumerate(doc["nodes"]):
        for c in node.get("children", []):
            assert 0 <= c < len(doc["nodes"]) and c != i
            assert c not in seen_parent, ("node with two parents", c)
            seen_parent[c] = i
        if "mesh" in node:
            assert 0 <= node["mesh"] < len(doc["meshes"])
        if "camera" in node:
            assert 0 <= node["camera"] < len(doc["cameras"])
        if "rotation" in node:
            assert abs(sum(c * c for c in node["rotation"]) - 1.0) < 1e-12
        node_local_matrix(node)
    roots = doc["scenes"][doc["scene"]]["nodes"]
    for r in roots:
        assert r not in seen_parent, ("scene root is a child", r)
    assert set(roots) | set(seen_parent) == set(range(len(doc["nodes"]))), "unreachable node"
    for cam in doc["cameras"]:
        p = cam["perspective"]
        assert cam["type"] == "perspective" and 0 < p["yfov"] < math.pi and p["znear"] > 0
    if buffers is None or any(b is None for b in buffers):
        return
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            assert 0 <= prim["material"] < len(doc["materials"])
            pos_acc = doc["accessors"][prim["attributes"]["POSITION"]]
            pos = read_accessor(doc, buffers, prim["attributes"]["POSITION"])
            assert pos_acc["type"] == "VEC3" and pos_acc["componentType"] == FLOAT
            assert pos_acc["min"] == [min(p[i] for p in pos) for i in range(3)], "POSITION min"
            assert pos_acc["max"] == [max(p[i] for p in pos) for i in range(3)], "POSITION max"
            if "indices" in prim:
                idx = read_accessor(doc, buffers, prim["indices"])
                assert doc["accessors"][prim["indices"]]["componentType"] == UNSIGNED_INT
                assert all(0 <= k < len(pos) for k in idx)
            else:
                idx = list(range(len(pos)))
            mode = prim.get("mode", MODE_TRIANGLES)
            if "NORMAL" in prim["attributes"]:
                nrm = read_accessor(doc, buffers, prim["attributes"]["NORMAL"])
                assert len(nrm) == len(pos)
                for n in nrm:
                    assert abs(vdot(n, n) - 1.0) < 1e-6
                if mode == MODE_TRIANGLES:
                    assert len(idx) % 3 == 0
                    for t in range(0, len(idx), 3):
                        a, b, c = (pos[k] for k in idx[t:t + 3])
                        gn = vcross(vsub(b, a), vsub(c, a))
                        for k in idx[t:t + 3]:  # CCW front face agrees with the normals
                            assert vdot(gn, nrm[k]) > 0, "winding disagrees with NORMAL"


def world_triangles(doc, buffers):
    """Reference flattening: [(node name, world triangles, world vertex normals)]."""
    out = []

    def visit(i, parent):
        node = doc["nodes"][i]
        m = mat_mul(parent, node_local_matrix(node))
        if "mesh" in node:
            flip = det3(upper3(m)) < 0
            nmat = inverse_transpose3(upper3(m))
            tris, nrms = [], []
            for prim in doc["meshes"][node["mesh"]]["primitives"]:
                pos = read_accessor(doc, buffers, prim["attributes"]["POSITION"])
                nrm = (read_accessor(doc, buffers, prim["attributes"]["NORMAL"])
                       if "NORMAL" in prim["attributes"] else None)
                idx = (read_accessor(doc, buffers, prim["indices"])
                       if "indices" in prim else list(range(len(pos))))
                mode = prim.get("mode", MODE_TRIANGLES)
                if mode == MODE_TRIANGLES:
                    tri_idx = [idx[t:t + 3] for t in range(0, len(idx) - 2, 3)]
                elif mode == MODE_TRIANGLE_STRIP:
                    tri_idx = [[idx[k] for k in t] for t in strip_triangles(len(idx))]
                else:
                    tri_idx = []
                for t in tri_idx:
                    if flip:
                        t = [t[0], t[2], t[1]]
                    tris.append([mat_point(m, pos[k]) for k in t])
                    if nrm is not None:
                        nrms.append([vnorm(mat3_vec(nmat, nrm[k])) for k in t])
            out.append((node.get("name"), tris, nrms))
        for c in node.get("children", []):
            visit(c, m)

    for r in doc["scenes"][doc["scene"]]["nodes"]:
        visit(r, mat_identity())
    return out


def camera_world(doc):
    def visit(i, parent):
        node = doc["nodes"][i]
        m = mat_mul(parent, node_local_matrix(node))
        if "camera" in node:
            return m
        for c in node.get("children", []):
            r = visit(c, m)
            if r is not None:
                return r
        return None

    for r in doc["scenes"][doc["scene"]]["nodes"]:
        m = visit(r, mat_identity())
        if m is not None:
            return m
    raise AssertionError("no camera node")


def load(path, allow_missing=False):
    doc = json.loads(path.read_text(encoding="utf-8"))
    buffers = decode_buffers(doc, path.parent, allow_missing)
    validate_structure(doc, buffers)
    return doc, buffers


def validate_ao(path, kind, offset):
    doc, buffers = load(path)
    off = OFFSET if offset else [0.0, 0.0, 0.0]
    cam = camera_world(doc)
    cam_pos = [0.0, 1.0, 0.0] if kind == "open-plane" else [1.0, 1.0, 0.0]
    assert vclose(mat_point(cam, [0.0, 0.0, 0.0]), [cam_pos[i] + off[i] for i in range(3)], 1e-9)
    assert vclose(mat_dir(cam, [0.0, 0.0, -1.0]), [0.0, -1.0, 0.0], 1e-15)
    assert vclose(mat_dir(cam, [0.0, 1.0, 0.0]), [0.0, 0.0, -1.0], 1e-15)
    assert vclose(mat_dir(cam, [1.0, 0.0, 0.0]), [1.0, 0.0, 0.0], 1e-15)
    flat = world_triangles(doc, buffers)
    names = sorted(n for n, _, _ in flat)
    assert names == (["plane"] if kind == "open-plane" else ["floor", "wall"]), names
    for name, tris, nrms in flat:
        for tri, ns in zip(tris, nrms):
            gn = vnorm(vcross(vsub(tri[1], tri[0]), vsub(tri[2], tri[0])))
            want = [1.0, 0.0, 0.0] if name == "wall" else [0.0, 1.0, 0.0]
            assert vclose(gn, want, 1e-12) and all(vclose(n, want, 1e-12) for n in ns), name
            for p in tri:
                if name == "wall":
                    assert p[0] == off[0] and off[1] <= p[1] <= off[1] + WALL_H
                else:
                    assert p[1] == off[1]
    # What the camera sees: the floor around (camera x, camera z), 1 m below.
    half = math.tan(YFOV / 2.0)  # aspect 1: same half-extent along x and z
    if kind == "wall":
        d_min, d_max = 1.0 - half, 1.0 + half
        top, side = wall_escape(d_max, half)
        eps_max = top + side
        assert 0.744 < d_min < 0.745 and 1.255 < d_max < 1.256, (d_min, d_max)
        assert abs(top - 6.277e-6) < 1e-9 and abs(side - 3.996e-6) < 1e-9, (top, side)
        assert eps_max < 1.03e-5 and eps_max / 0.5 < 2.06e-5, eps_max
        assert sum(wall_escape(d_min, 0.0)) < 6.2e-6
        return {"visible_distance_to_wall": [d_min, d_max], "ao": 0.5,
                "ao_max_abs_error": eps_max, "ao_max_rel_error": eps_max / 0.5}
    return {"ao": 1.0}


def validate_hierarchy(path, expected_path):
    doc, buffers = load(path)
    expected = json.loads(expected_path.read_text(encoding="utf-8"))
    flat = world_triangles(doc, buffers)
    assert [n for n, _, _ in flat] == expected["emission_order"], [n for n, _, _ in flat]
    assert sum(len(t) for _, t, _ in flat) == expected["total_triangles"]
    for name, tris, nrms in flat:
        exp = expected["nodes"][name]
        assert len(tris) == len(exp["triangles"])
        for got, want in zip(tris, exp["triangles"]):
            for p, q in zip(got, want):
                assert vclose(p, q, 1e-9), (name, got, want)
        if name in ("A", "B"):
            for got, want in zip(nrms, exp["vertex_normals"]):
                for p, q in zip(got, want):
                    assert vclose(p, q, 1e-9), (name, got, want)
        for tri, gn in zip(tris, exp["geometric_normals"]):
            assert vclose(vnorm(vcross(vsub(tri[1], tri[0]), vsub(tri[2], tri[0]))), gn, 1e-9)
    b = expected["nodes"]["B"]
    assert b["winding_flipped"] and b["determinant"] < 0
    for n in b["vertex_normals"][0]:
        assert vdot(b["geometric_normals"][0], n) > 0, "B: flipped winding vs normal"


def validate_glb(data):
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and length == len(data)
    jlen, jtype = struct.unpack_from("<I4s", data, 12)
    assert jtype == b"JSON" and jlen % 4 == 0
    doc = json.loads(data[20:20 + jlen].decode("utf-8"))
    blen, btype = struct.unpack_from("<I4s", data, 20 + jlen)
    assert btype == b"BIN\0" and blen % 4 == 0
    binary = data[28 + jlen:28 + jlen + blen]
    assert 28 + jlen + blen == len(data)
    assert "uri" not in doc["buffers"][0] and doc["buffers"][0]["byteLength"] == blen
    validate_structure(doc, [binary])


# ---------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out_dir", nargs="?", default=str(REPO / "scenes"),
                    help="where the ao-*.gltf scenes go (default: <repo>/scenes)")
    ap.add_argument("--test-data", default=str(REPO / "tests" / "data"),
                    help="where hierarchy.* and bad/ go (default: <repo>/tests/data)")
    args = ap.parse_args()
    scenes = Path(args.out_dir)
    data_dir = Path(args.test_data)

    check_look_down()

    results = {}
    for kind in ("open-plane", "wall"):
        for offset in (False, True):
            name = "ao-%s%s.gltf" % (kind, "-offset" if offset else "")
            path = scenes / name
            write_json(path, ao_scene(kind, offset).document())
            results[name] = validate_ao(path, kind, offset)

    hier = data_dir / "hierarchy.gltf"
    hier_exp = data_dir / "hierarchy.expected.json"
    write_json(hier, hierarchy_scene().document())
    write_json(hier_exp, hierarchy_expected())
    validate_hierarchy(hier, hier_exp)

    bad = data_dir / "bad"
    write_bytes(bad / "not_gltf.gltf", b"hello, this is not a glTF file\n")

    write_json(bad / "no_triangles.gltf", points_scene().document())
    doc, bufs = load(bad / "no_triangles.gltf")
    assert [p["mode"] for m in doc["meshes"] for p in m["primitives"]] == [MODE_POINTS]
    assert sum(len(t) for _, t, _ in world_triangles(doc, bufs)) == 0

    g = one_triangle_scene()
    g.extensions_used = ["EXT_texture_avif"]
    g.extensions_required = ["EXT_texture_avif"]
    write_json(bad / "required_extension.gltf", g.document())
    doc, bufs = load(bad / "required_extension.gltf")
    assert doc["extensionsRequired"] == doc["extensionsUsed"] == ["EXT_texture_avif"]

    full_glb = one_triangle_scene().glb()
    validate_glb(full_glb)
    assert len(full_glb) > 40
    write_bytes(bad / "truncated.glb", full_glb[:40])

    write_json(bad / "missing_buffer.gltf", one_triangle_scene().document(buffer_uri="does-not-exist.bin"))
    doc, bufs = load(bad / "missing_buffer.gltf", allow_missing=True)
    assert bufs == [None] and doc["buffers"][0]["uri"] == "does-not-exist.bin"

    for path in WRITTEN:
        print("%8d  %s" % (path.stat().st_size, path))
    for name, r in results.items():
        print("%-28s %s" % (name, json.dumps(r)))


if __name__ == "__main__":
    main()
