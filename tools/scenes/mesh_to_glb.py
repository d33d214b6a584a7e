#!/usr/bin/env python3
"""Converts an OBJ or PLY triangle mesh to a binary glTF 2.0 file (.glb) that strata loads.

Usage:

    mesh_to_glb.py INPUT.obj|INPUT.ply OUTPUT.glb [--camera]
    mesh_to_glb.py INPUT.gltf|INPUT.glb          # only reports the triangle count
    mesh_to_glb.py --check FILE.glb              # re-reads and validates a GLB

Standard library only. The output has one mesh with one primitive (TRIANGLES) holding
POSITION (float32 VEC3, with min/max) and uint32 indices, one node, one scene and a
default white material (baseColorFactor 1, metallicFactor 0, roughnessFactor 1). No
normals: strata shades flat.

OBJ: `v x y z` and `f` lines (`v`, `v/vt`, `v//vn`, `v/vt/vn`, negative indices relative
to the vertices read so far); every other statement is ignored. PLY: ascii 1.0,
binary_little_endian 1.0 and binary_big_endian 1.0; the vertex element's x, y, z (any
other properties skipped) and the face element's `vertex_indices` / `vertex_index` list;
other elements are skipped. Polygons are fan-triangulated; faces with fewer than 3
vertices are dropped. Zero-area triangles are kept (strata filters them) and counted.
Vertices that no face uses are dropped (so the bounding box and the camera only see
the mesh).

`--camera` adds a perspective camera (yfov 0.7 rad, aspectRatio 4/3) on the +Z side of
the bounding box's centre, looking down -Z (identity rotation), at the distance where the
box's bounding sphere fits the vertical field of view: radius / sin(yfov / 2).
"""
import argparse
import json
import math
import os
import struct
import sys
import time
from array import array

YFOV = 0.7
ASPECT = 4.0 / 3.0

GLB_MAGIC = 0x46546C67  # "glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942


class MeshError(Exception):
    pass


def _check_itemsizes():
    for code, size in (("b", 1), ("B", 1), ("h", 2), ("H", 2), ("i", 4), ("I", 4), ("f", 4), ("d", 8)):
        if array(code).itemsize != size:
            raise SystemExit(f"array typecode {code!r} is {array(code).itemsize} bytes here, need {size}")


def strided_column(data, start, count, stride, size):
    """Bytes of `count` items of `size` bytes at data[start + k * stride] (C-speed slicing)."""
    if stride == size:
        return data[start:start + count * size]
    out = bytearray(count * size)
    for b in range(size):
        out[b::size] = data[start + b:start + b + (count - 1) * stride + 1:stride] if count else b""
    return out


# --------------------------------------------------------------------------- OBJ


def read_obj(path):
    with open(path, "rb") as f:
        data = f.read()
    if b"\\" in data:  # line continuations
        data = data.replace(b"\\\r\n", b" ").replace(b"\\\n", b" ")
    coords = []  # byte tokens, 3 per vertex
    idx = array("I")
    nv = 0
    stats = {"faces": 0, "dropped_faces": 0, "fan_split": 0}
    append_tri = idx.extend
    for lineno, line in enumerate(data.split(b"\n"), 1):
        if not line:
            continue
        c = line[0]
        if c == 32 or c == 9:
            line = line.lstrip()
            if not line:
                continue
            c = line[0]
        if c == 118:  # 'v'
            if len(line) > 1 and line[1] in (32, 9):
                parts = line.split()
                if len(parts) < 4:
                    raise MeshError(f"{path}:{lineno}: vertex with fewer than 3 coordinates")
                coords += parts[1:4]
                nv += 1
        elif c == 102:  # 'f'
            if len(line) > 1 and line[1] in (32, 9):
                parts = line.split()
                n = len(parts) - 1
                stats["faces"] += 1
                if n < 3:
                    stats["dropped_faces"] += 1
                    continue
                try:
                    if b"/" in line:
                        vs = [int(p.split(b"/", 1)[0]) for p in parts[1:]]
                    else:
                        vs = [int(p) for p in parts[1:]]
                except ValueError:
                    raise MeshError(f"{path}:{lineno}: bad face index in {line.strip()!r}") from None
                for k in range(n):
                    i = vs[k]
                    if i > 0:
                        vs[k] = i - 1
                    elif i < 0:
                        vs[k] = nv + i
                        if vs[k] < 0:
                            raise MeshError(f"{path}:{lineno}: relative index {i} before the first vertex")
                    else:
                        raise MeshError(f"{path}:{lineno}: face index 0 (OBJ indices start at 1)")
                if n == 3:
                    append_tri(vs)
                else:
                    stats["fan_split"] += 1
                    a = vs[0]
                    for k in range(1, n - 1):
                        append_tri((a, vs[k], vs[k + 1]))
    try:
        pos = array("d", map(float, coords))
    except ValueError as e:
        raise MeshError(f"{path}: bad vertex coordinate: {e}") from None
    del coords
    stats["format"] = "OBJ"
    return pos, idx, stats


# --------------------------------------------------------------------------- PLY

PLY_TYPES = {
    "char": "b", "int8": "b", "uchar": "B", "uint8": "B",
    "short": "h", "int16": "h", "ushort": "H", "uint16": "H",
    "int": "i", "int32": "i", "uint": "I", "uint32": "I",
    "float": "f", "float32": "f", "double": "d", "float64": "d",
}


def parse_ply_header(data, path):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshError(f"{path}: not a PLY file (no 'ply' magic or no end_header)")
    nl = data.find(b"\n", end)
    if nl < 0:
        raise MeshError(f"{path}: truncated header")
    body = nl + 1
    fmt = None
    elements = []  # [name, count, [(name, type, count_type or None)]]
    for raw in data[:end].decode("ascii", "replace").splitlines()[1:]:
        t = raw.split()
        if not t or t[0] in ("comment", "obj_info"):
            continue
        if t[0] == "format":
            if len(t) < 3 or t[2] != "1.0" or t[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise MeshError(f"{path}: unsupported PLY format line {raw.strip()!r}")
            fmt = t[1]
        elif t[0] == "element":
            elements.append([t[1], int(t[2]), []])
        elif t[0] == "property":
            if not elements:
                raise MeshError(f"{path}: property before any element")
            try:
                if t[1] == "list":
                    elements[-1][2].append((t[4], PLY_TYPES[t[3]], PLY_TYPES[t[2]]))
                else:
                    elements[-1][2].append((t[2], PLY_TYPES[t[1]], None))
            except (KeyError, IndexError):
                raise MeshError(f"{path}: unsupported property line {raw.strip()!r}") from None
        else:
            raise MeshError(f"{path}: unknown header line {raw.strip()!r}")
    if fmt is None:
        raise MeshError(f"{path}: no format line")
    return fmt, elements, body


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    fmt, elements, off = parse_ply_header(data, path)
    names = [e[0] for e in elements]
    if "vertex" not in names or "face" not in names:
        raise MeshError(f"{path}: needs 'element vertex' and 'element face' (has {names})")
    stats = {"format": "PLY " + fmt, "faces": 0, "dropped_faces": 0, "fan_split": 0, "skipped": []}
    for name, count, props in elements:
        if name == "vertex":
            pn = [p[0] for p in props]
            for c in "xyz":
                if c not in pn:
                    raise MeshError(f"{path}: vertex element has no '{c}' property")
            stats["skipped"] += [f"vertex.{p[0]}" for p in props if p[0] not in ("x", "y", "z")]
        elif name == "face":
            stats["skipped"] += [f"face.{p[0]}" for p in props if p[0] not in ("vertex_indices", "vertex_index")]
        else:
            stats["skipped"].append(f"element {name} ({count})")
    if fmt == "ascii":
        pos, idx = _ply_ascii(data, off, elements, stats, path)
    else:
        pos, idx = _ply_binary(data, off, elements, fmt == "binary_big_endian", stats, path)
    return pos, idx, stats


def _face_list_index(props, path):
    for k, p in enumerate(props):
        if p[0] in ("vertex_indices", "vertex_index"):
            if p[2] is None:
                raise MeshError(f"{path}: face property {p[0]} is not a list")
            if p[1] in "fd":
                raise MeshError(f"{path}: face indices of a floating-point type")
            return k
    raise MeshError(f"{path}: face element has no vertex_indices / vertex_index list")


def _fan(idx, vs, stats):
    n = len(vs)
    stats["faces"] += 1
    if n < 3:
        stats["dropped_faces"] += 1
    elif n == 3:
        idx.extend(vs)
    else:
        stats["fan_split"] += 1
        a = vs[0]
        for k in range(1, n - 1):
            idx.extend((a, vs[k], vs[k + 1]))


def _ply_binary(data, off, elements, big, stats, path):
    e = ">" if big else "<"
    size = {c: struct.calcsize(c) for c in "bBhHiIfd"}
    pos = idx = None
    for name, count, props in elements:
        fixed = all(p[2] is None for p in props)
        if name == "vertex":
            if not fixed:
                raise MeshError(f"{path}: list properties in the vertex element are not supported")
            stride = sum(size[p[1]] for p in props)
            if off + count * stride > len(data):
                raise MeshError(f"{path}: file ends inside the vertex element")
            pos = array("f", bytes(12 * count))
            o = 0
            for pname, t, _ in props:
                if pname in ("x", "y", "z"):
                    col = array(t, strided_column(data, off + o, count, stride, size[t]))
                    if big != (sys.byteorder == "big") and size[t] > 1:
                        col.byteswap()
                    if t != "f":
                        col = array("f", col)
                    pos["xyz".index(pname)::3] = col
                o += size[t]
            off += count * stride
        elif name == "face":
            li = _face_list_index(props, path)
            ct, it = props[li][2], props[li][1]
            pre = sum(size[p[1]] for p in props[:li])
            post_props = props[li + 1:]
            idx = None
            if all(p[2] is None for p in props[:li] + post_props):
                # Fast path: every face a triangle, so every record has the same size.
                stride = pre + size[ct] + 3 * size[it] + sum(size[p[1]] for p in post_props)
                if off + count * stride <= len(data):
                    counts = array(ct, strided_column(data, off + pre, count, stride, size[ct]))
                    if big != (sys.byteorder == "big") and size[ct] > 1:
                        counts.byteswap()
                    # The first record whose count is not 3 is read at its true offset, so
                    # this test is exact.
                    if counts.count(3) == count:
                        raw = array(it, strided_column(data, off + pre + size[ct], count, stride, 3 * size[it]))
                        if big != (sys.byteorder == "big") and size[it] > 1:
                            raw.byteswap()
                        if it != "I":
                            if count and min(raw) < 0:
                                raise MeshError(f"{path}: negative face index")
                            raw = array("I", raw)
                        idx = raw
                        stats["faces"] = count
                        off += count * stride
            if idx is None:  # general path, record by record
                idx = array("I")
                for _ in range(count):
                    vs = None
                    for k, (pname, t, lt) in enumerate(props):
                        if lt is None:
                            off += size[t]
                            continue
                        (n,) = struct.unpack_from(e + lt, data, off)
                        off += size[lt]
                        if k == li:
                            vs = list(struct.unpack_from(f"{e}{n}{t}", data, off))
                        off += n * size[t]
                    if min(vs, default=0) < 0:
                        raise MeshError(f"{path}: negative face index")
                    _fan(idx, vs, stats)
                if off > len(data):
                    raise MeshError(f"{path}: file ends inside the face element")
        else:
            if pos is not None and idx is not None:
                break  # elements after vertex and face are not needed
            if fixed:
                off += count * sum(size[p[1]] for p in props)
            else:
                for _ in range(count):
                    for pname, t, lt in props:
                        if lt is None:
                            off += size[t]
                        else:
                            (n,) = struct.unpack_from(e + lt, data, off)
                            off += size[lt] + n * size[t]
            if off > len(data):
                raise MeshError(f"{path}: file ends inside element {name}")
    pos = array("d", pos)
    return pos, idx


def _ply_ascii(data, off, elements, stats, path):
    tok = data[off:].split()
    p = 0
    pos = idx = None
    for name, count, props in elements:
        fixed = all(q[2] is None for q in props)
        if name == "vertex":
            if not fixed:
                raise MeshError(f"{path}: list properties in the vertex element are not supported")
            np_ = len(props)
            if p + count * np_ > len(tok):
                raise MeshError(f"{path}: file ends inside the vertex element")
            block = tok[p:p + count * np_]
            pos = array("d", bytes(24 * count))
            for k, q in enumerate(props):
                if q[0] in ("x", "y", "z"):
                    pos["xyz".index(q[0])::3] = array("d", map(float, block[k::np_]))
            p += count * np_
        elif name == "face":
            li = _face_list_index(props, path)
            idx = array("I")
            for _ in range(count):
                vs = None
                for k, q in enumerate(props):
                    if q[2] is None:
                        p += 1
                        continue
                    n = int(tok[p])
                    if k == li:
                        vs = [int(x) for x in tok[p + 1:p + 1 + n]]
                        if len(vs) != n:
                            raise MeshError(f"{path}: file ends inside the face element")
                    p += 1 + n
                if min(vs, default=0) < 0:
                    raise MeshError(f"{path}: negative face index")
                _fan(idx, vs, stats)
        else:
            if pos is not None and idx is not None:
                break
            if fixed:
                p += count * len(props)
            else:
                for _ in range(count):
                    for q in props:
                        p += 1 if q[2] is None else 1 + int(tok[p])
    return pos, idx


# --------------------------------------------------------------------------- conversion


def finish_mesh(pos, idx, stats, path):
    """Validates indices, drops unused vertices, converts to float32, returns the GLB inputs."""
    nv = len(pos) // 3
    nt = len(idx) // 3
    if nt == 0:
        raise MeshError(f"{path}: no triangles")
    if max(idx) >= nv:
        raise MeshError(f"{path}: face index {max(idx)} >= vertex count {nv}")
    used = bytearray(nv)
    for i in idx:
        used[i] = 1
    unused = nv - used.count(1)
    stats["input_vertices"] = nv
    stats["unused_vertices"] = unused
    if unused:
        remap = array("I", bytes(4 * nv))
        keep = array("d")
        n = 0
        for v in range(nv):
            if used[v]:
                remap[v] = n
                n += 1
                keep.extend(pos[3 * v:3 * v + 3])
        idx = array("I", [remap[i] for i in idx])
        pos = keep
        nv = n
    pos32 = array("f", pos)
    if not math.isfinite(sum(pos32)):
        raise MeshError(f"{path}: non-finite coordinate (NaN, infinity, or beyond float32 range)")
    lo = [min(pos32[c::3]) for c in range(3)]
    hi = [max(pos32[c::3]) for c in range(3)]

    # Zero-area triangles (in the float32 positions) are kept but counted.
    zero = repeated = 0
    p = pos32
    for t in range(nt):
        a, b, c = idx[3 * t], idx[3 * t + 1], idx[3 * t + 2]
        if a == b or b == c or a == c:
            repeated += 1
            zero += 1
            continue
        a *= 3
        b *= 3
        c *= 3
        ax, ay, az = p[a], p[a + 1], p[a + 2]
        ux, uy, uz = p[b] - ax, p[b + 1] - ay, p[b + 2] - az
        vx, vy, vz = p[c] - ax, p[c + 1] - ay, p[c + 2] - az
        if uy * vz - uz * vy == 0.0 and uz * vx - ux * vz == 0.0 and ux * vy - uy * vx == 0.0:
            zero += 1
    stats["zero_area"] = zero
    stats["repeated_index"] = repeated
    return pos32, idx, lo, hi


def build_glb(pos32, idx, lo, hi, name, camera, view=None):
    nv = len(pos32) // 3
    nbytes_pos = 4 * len(pos32)
    nbytes_idx = 4 * len(idx)
    nodes = [{"name": name, "mesh": 0}]
    doc = {
        "asset": {"version": "2.0", "generator": "strata tools/scenes/mesh_to_glb.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": [{"name": name, "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0, "mode": 4}]}],
        "materials": [{"name": "default white", "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "buffers": [{"byteLength": nbytes_pos + nbytes_idx}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": nbytes_pos, "target": 34962},
            {"buffer": 0, "byteOffset": nbytes_pos, "byteLength": nbytes_idx, "target": 34963},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        ],
    }
    cam = None
    if camera:
        centre = [(a + b) / 2 for a, b in zip(lo, hi)]
        radius = math.sqrt(sum((b - a) ** 2 for a, b in zip(lo, hi))) / 2
        if radius <= 0:
            radius = 1.0
        dist = radius / math.sin(YFOV / 2)
        eye = [centre[0], centre[1], centre[2] + dist]
        rotation = [0.0, 0.0, 0.0, 1.0]
        if view is not None:
            # An explicit viewpoint (--eye/--target), e.g. inside a closed room.
            sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
            from add_camera import look_at_quaternion
            eye, target = view
            rotation = look_at_quaternion(eye, target)
            dist = math.sqrt(sum((a - b) ** 2 for a, b in zip(eye, target)))
        doc["cameras"] = [{"name": "framing camera", "type": "perspective", "perspective": {
            "yfov": YFOV, "aspectRatio": ASPECT, "znear": 0.01 * radius}}]
        nodes.append({"name": "framing camera", "camera": 0, "translation": eye, "rotation": rotation})
        doc["scenes"][0]["nodes"].append(1)
        cam = (eye, dist, radius)
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    pos_le, idx_le = pos32, idx
    if sys.byteorder == "big":
        pos_le, idx_le = array("f", pos32), array("I", idx)
        pos_le.byteswap()
        idx_le.byteswap()
    bin_len = nbytes_pos + nbytes_idx  # both multiples of 4: no padding needed
    total = 12 + 8 + len(js) + 8 + bin_len
    parts = [struct.pack("<III", GLB_MAGIC, 2, total), struct.pack("<II", len(js), CHUNK_JSON), js,
             struct.pack("<II", bin_len, CHUNK_BIN), pos_le.tobytes(), idx_le.tobytes()]
    return parts, total, cam


def convert(args):
    t0 = time.perf_counter()
    ext = os.path.splitext(args.input)[1].lower()
    if ext == ".obj":
        pos, idx, stats = read_obj(args.input)
    elif ext == ".ply":
        pos, idx, stats = read_ply(args.input)
    else:
        raise MeshError(f"{args.input}: unknown extension {ext!r} (expected .obj or .ply)")
    pos32, idx, lo, hi = finish_mesh(pos, idx, stats, args.input)
    name = os.path.splitext(os.path.basename(args.input))[0]
    view = None
    if args.eye or args.target:
        if not (args.eye and args.target):
            raise MeshError("--eye and --target go together")
        view = ([float(v) for v in args.eye.split(",")], [float(v) for v in args.target.split(",")])
    parts, total, cam = build_glb(pos32, idx, lo, hi, name, args.camera or view is not None, view)
    out_dir = os.path.dirname(os.path.abspath(args.output))
    os.makedirs(out_dir, exist_ok=True)
    with open(args.output, "wb") as f:
        for p in parts:
            f.write(p)
    dt = time.perf_counter() - t0
    nt = len(idx) // 3
    extra = []
    if stats["dropped_faces"]:
        extra.append(f"{stats['dropped_faces']} faces with <3 vertices dropped")
    if stats["unused_vertices"]:
        extra.append(f"{stats['unused_vertices']} unused vertices dropped")
    if stats.get("skipped"):
        extra.append("skipped " + ", ".join(stats["skipped"]))
    if cam:
        extra.append("camera at (%.6g, %.6g, %.6g), distance %.6g" % (*cam[0], cam[1]))
    fmt = lambda v: "(" + ", ".join("%.6g" % x for x in v) + ")"
    print(f"{args.input} [{stats['format']}]: {len(pos32) // 3} vertices, {nt} triangles "
          f"({stats['faces']} faces, {stats['fan_split']} fan-split, {stats['zero_area']} zero-area "
          f"of which {stats['repeated_index']} repeat an index), bbox {fmt(lo)}..{fmt(hi)}, "
          f"-> {args.output} {total} bytes, {dt:.2f} s" + ("; " + "; ".join(extra) if extra else ""))


# --------------------------------------------------------------------------- independent reader

COMPONENT = {5120: ("b", 1), 5121: ("B", 1), 5122: ("h", 2), 5123: ("H", 2), 5125: ("I", 4), 5126: ("f", 4)}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def load_gltf(path):
    """Returns (doc, [buffer bytes]) for a .glb or .gltf, checking the GLB container."""
    problems = []
    with open(path, "rb") as f:
        raw = f.read()
    mv = memoryview(raw)
    if raw[:4] == b"glTF":
        if len(raw) < 20:
            raise MeshError(f"{path}: {len(raw)} bytes, too short for a GLB")
        magic, version, length = struct.unpack_from("<III", mv, 0)
        if version != 2:
            problems.append(f"GLB version {version}, not 2")
        if length != len(raw):
            problems.append(f"header length {length} != file size {len(raw)}")
        jlen, jtype = struct.unpack_from("<II", mv, 12)
        if jtype != CHUNK_JSON:
            raise MeshError(f"{path}: first chunk type {jtype:#x} is not JSON")
        if jlen % 4:
            problems.append(f"JSON chunk length {jlen} not a multiple of 4")
        if 20 + jlen > len(raw):
            raise MeshError(f"{path}: JSON chunk runs past the end of the file")
        jbytes = raw[20:20 + jlen]
        if jbytes.rstrip(b" ") != jbytes.rstrip():
            problems.append("JSON chunk padded with something other than spaces")
        doc = json.loads(jbytes.decode("utf-8"))
        bins = []
        o = 20 + jlen
        while o < len(raw):
            if o + 8 > len(raw):
                problems.append("trailing bytes after the last chunk")
                break
            clen, ctype = struct.unpack_from("<II", mv, o)
            if clen % 4:
                problems.append(f"chunk at {o} length {clen} not a multiple of 4")
            if o + 8 + clen > len(raw):
                raise MeshError(f"{path}: chunk at byte {o} runs past the end of the file")
            if ctype == CHUNK_BIN:
                bins.append(raw[o + 8:o + 8 + clen])
            o += 8 + clen
        if len(bins) > 1:
            problems.append(f"{len(bins)} BIN chunks")
        buffers = []
        for k, b in enumerate(doc.get("buffers", [])):
            if "uri" in b:
                buffers.append(_load_uri(path, b["uri"]))
            elif k == 0 and bins:
                blen = b["byteLength"]
                if not (blen <= len(bins[0]) <= blen + 3):
                    problems.append(f"buffer 0 byteLength {blen} vs BIN chunk {len(bins[0])} bytes")
                if any(bins[0][blen:]):
                    problems.append("BIN chunk padding is not zeros")
                buffers.append(bins[0])
            else:
                raise MeshError(f"{path}: buffer {k} has no uri and no BIN chunk")
    else:
        doc = json.loads(raw.decode("utf-8"))
        buffers = [_load_uri(path, b["uri"]) for b in doc.get("buffers", [])]
    for k, b in enumerate(doc.get("buffers", [])):
        if len(buffers[k]) < b["byteLength"]:
            problems.append(f"buffer {k}: {len(buffers[k])} bytes < byteLength {b['byteLength']}")
    return doc, buffers, problems


def _load_uri(path, uri):
    if uri.startswith("data:"):
        import base64
        return base64.b64decode(uri.split(",", 1)[1])
    from urllib.parse import unquote
    with open(os.path.join(os.path.dirname(path), unquote(uri)), "rb") as f:
        return f.read()


def read_accessor(doc, buffers, k, problems):
    """The accessor's components as a flat array (non-sparse), checking bounds and alignment."""
    acc = doc["accessors"][k]
    code, csize = COMPONENT[acc["componentType"]]
    ncomp = NCOMP[acc["type"]]
    count = acc["count"]
    esize = csize * ncomp
    if "bufferView" not in acc:
        return array(code, bytes(count * esize))
    view = doc["bufferViews"][acc["bufferView"]]
    buf = buffers[view["buffer"]]
    vstart = view.get("byteOffset", 0)
    vlen = view["byteLength"]
    if vstart + vlen > doc["buffers"][view["buffer"]]["byteLength"]:
        problems.append(f"bufferView {acc['bufferView']} runs past its buffer")
    stride = view.get("byteStride", esize)
    aoff = acc.get("byteOffset", 0)
    if (vstart + aoff) % csize:
        problems.append(f"accessor {k}: offset {vstart + aoff} not aligned to {csize}")
    need = aoff + (stride * (count - 1) + esize if count else 0)
    if need > vlen:
        problems.append(f"accessor {k}: needs {need} bytes of a {vlen}-byte bufferView")
        raise MeshError(f"accessor {k} out of bounds")
    a = array(code, strided_column(buf, vstart + aoff, count, stride, esize))
    if sys.byteorder == "big":
        a.byteswap()
    if "sparse" in acc:
        problems.append(f"accessor {k}: sparse (not checked)")
    return a


def check(path, verbose=True):
    """Independent GLB/glTF reader: validates and returns (triangles, problems)."""
    doc, buffers, problems = load_gltf(path)
    if doc.get("asset", {}).get("version") != "2.0":
        problems.append(f"asset.version {doc.get('asset', {}).get('version')!r}")
    mesh_tris = []
    for mi, mesh in enumerate(doc.get("meshes", [])):
        tris = 0
        for pi, prim in enumerate(mesh["primitives"]):
            where = f"mesh {mi} primitive {pi}"
            mode = prim.get("mode", 4)
            pa = prim["attributes"].get("POSITION")
            if pa is None:
                problems.append(f"{where}: no POSITION")
                continue
            acc = doc["accessors"][pa]
            if acc["componentType"] != 5126 or acc["type"] != "VEC3":
                problems.append(f"{where}: POSITION is not float32 VEC3")
            pos = read_accessor(doc, buffers, pa, problems)
            nv = acc["count"]
            if nv:
                lo = [min(pos[c::3]) for c in range(3)]
                hi = [max(pos[c::3]) for c in range(3)]
                # Stored min/max must equal the data's (compared as float32).
                f32 = lambda v: struct.unpack("<f", struct.pack("<f", v))[0]
                if "min" not in acc or "max" not in acc:
                    problems.append(f"{where}: POSITION has no min/max")
                elif [f32(v) for v in acc["min"]] != lo or [f32(v) for v in acc["max"]] != hi:
                    problems.append(f"{where}: POSITION min/max {acc['min']}..{acc['max']} != data {lo}..{hi}")
                if not math.isfinite(sum(pos)):
                    problems.append(f"{where}: non-finite positions")
            if "indices" in prim:
                iacc = doc["accessors"][prim["indices"]]
                if iacc["type"] != "SCALAR" or iacc["componentType"] not in (5121, 5123, 5125):
                    problems.append(f"{where}: indices not an unsigned SCALAR")
                ind = read_accessor(doc, buffers, prim["indices"], problems)
                n = len(ind)
                if n and max(ind) >= nv:
                    problems.append(f"{where}: index {max(ind)} >= vertex count {nv}")
                v = doc["bufferViews"][iacc["bufferView"]]
                if "byteStride" in v:
                    problems.append(f"{where}: index bufferView has byteStride")
            else:
                n = nv
            if mode == 4:
                if n % 3:
                    problems.append(f"{where}: {n} indices, not a multiple of 3")
                tris += n // 3
            elif mode in (5, 6):
                tris += max(n - 2, 0)
            if "material" in prim and prim["material"] >= len(doc.get("materials", [])):
                problems.append(f"{where}: material {prim['material']} does not exist")
        mesh_tris.append(tris)
    # Triangles as instanced by the default scene.
    scene_tris = 0
    cams = []
    scenes = doc.get("scenes", [])
    if scenes:
        stack = list(scenes[doc.get("scene", 0)]["nodes"])
        while stack:
            node = doc["nodes"][stack.pop()]
            if "mesh" in node:
                scene_tris += mesh_tris[node["mesh"]]
            if "camera" in node:
                cams.append(node)
            stack += node.get("children", [])
    for node in cams:
        cam = doc["cameras"][node["camera"]]
        if cam["type"] == "perspective":
            p = cam["perspective"]
            if not (p.get("yfov", 0) > 0 and p.get("znear", 0) > 0):
                problems.append(f"camera {node['camera']}: bad yfov/znear")
    if verbose:
        cam_txt = "; ".join(f"camera {n['camera']} at {n.get('translation', [0, 0, 0])} rotation "
                            f"{n.get('rotation', [0, 0, 0, 1])}" for n in cams)
        print(f"{path}: {len(doc.get('meshes', []))} meshes, {sum(mesh_tris)} triangles in meshes, "
              f"{scene_tris} in the default scene, {len(cams)} cameras"
              + (f" ({cam_txt})" if cam_txt else "") + (", OK" if not problems else ""))
        for p in problems:
            print("  PROBLEM: " + p)
    return scene_tris, problems


def main():
    _check_itemsizes()
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input", nargs="?")
    ap.add_argument("output", nargs="?")
    ap.add_argument("--camera", action="store_true", help="add a camera that frames the mesh")
    ap.add_argument("--eye", metavar="X,Y,Z", help="camera position instead of the framing one (with --target)")
    ap.add_argument("--target", metavar="X,Y,Z", help="point the camera looks at (with --eye)")
    ap.add_argument("--check", metavar="FILE.glb", help="validate a GLB (or .gltf) with an independent reader")
    args = ap.parse_args()
    try:
        if args.check:
            _, problems = check(args.check)
            sys.exit(1 if problems else 0)
        if not args.input:
            ap.error("INPUT is required")
        if os.path.splitext(args.input)[1].lower() in (".gltf", ".glb"):
            if args.output:
                ap.error("glTF input is only counted, not converted: give no OUTPUT")
            check(args.input)
            return
        if not args.output:
            ap.error("OUTPUT.glb is required")
        convert(args)
    except MeshError as e:
        sys.exit(f"error: {e}")


if __name__ == "__main__":
    main()
