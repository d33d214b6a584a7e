#!/usr/bin/env python3
"""glTF 2.0 -> Mitsuba 3 conversion and the Mitsuba reference renders of strata's scenes.

Run through tools/references/make_references.sh (which makes the pinned virtualenv):

    make_references.sh                         # every reference in JOBS, then the manifest
    make_references.sh cornell-box.path ao-wall.ao   # only these (the manifest is merged)
    make_references.sh --materials gltf        # shaded jobs with the glTF BRDF (see "material")
    make_references.sh --manifest tools/peers/hdri-races.json --materials gltf [jobs]
                                               # another job manifest's references, into its out_dir
                                               # (or --out-dir DIR), with a manifest.json there
    python3 mitsuba_refs.py --list             # the job names
    python3 mitsuba_refs.py --check DIR   # orientation (textured quad, camera), radiometry, environment map,
                                          # glass and coat refusals

The conversion is written from the glTF alone (nothing is tuned per scene); the contract it
implements is strata's (see scenes/references/README.md):
- camera: the first camera met in a depth-first, pre-order walk of the default scene (the
  order strata numbers cameras in); Mitsuba `perspective`, fov_axis 'y', fov = yfov in degrees,
  to_world = camera world matrix x diag(-1, 1, -1, 1); the resolution sets the aspect ratio.
- film: hdrfilm, box reconstruction filter, linear RGB float32.
- geometry: every primitive becomes a world-space `mi.Mesh` (node transforms applied, winding
  flipped under a negative determinant, normals by the inverse transpose). Primitives without
  NORMAL and every emissive primitive use face normals (the winding decides the front face).
  Modes TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN; points and lines are skipped (warning).
- material: the base colour is baseColorFactor.rgb x baseColorTexture.rgb (texture decoded from
  sRGB, bilinear, glTF wrap mode, TEXCOORD_0 passed unchanged: Mitsuba 3's bitmap has uv (0, 0)
  at the image's top row like glTF, so NO v flip; checked by --check). COLOR_0 is ignored (as
  strata ignores it). alphaMode is ignored: every surface is opaque, and the manifest row of a
  scene with MASK or BLEND materials asks strata for the same (--no-alpha). What the material becomes depends on --materials:
  - lambertian (the default): twosided(diffuse) with reflectance = the base colour;
    metallic/roughness are ignored.
  - gltf: the `gltf_metal_rough` plugin of gltf_bsdf.py (glTF 2.0 Appendix B, single scattering,
    no energy compensation: strata's GltfBrdf::single_scattering(); two-sided; a mirror below
    alpha = roughness^2 = 1e-3) with base_color = the base colour, metallic = metallicFactor x
    metallicRoughnessTexture.B and roughness = roughnessFactor x metallicRoughnessTexture.G (the
    texture read as linear data, bilinear, same uv and wrap rules; factors default to 1).
    Material extensions that change the BRDF (KHR_materials_ior, _specular, ...) are ignored
    with a warning in the manifest row, which also records the model ("materials").
  - glass (gltf only): a material with KHR_materials_transmission is strata's glass
    (Materials::gltf_bsdf), converted by glass_props() when it is glass alone: transmissionFactor
    1 (untextured) and metallicFactor 0; a mixture with the glTF BRDF, textured roughness, other
    extensions, ior 1 and emission are refused (ConversionError). KHR_materials_ior's ior (1.5
    without) is the index inside; roughness r gives alpha = r^2, smooth below 1e-3; the base
    colour tints transmitted light (specular_transmittance). With KHR_materials_volume and
    thicknessFactor > 0 the surface bounds a volume: smooth -> `dielectric` (int_ior = ior,
    ext_ior = 1; exact Fresnel and the same 1/eta'^2 radiance factor as strata, checked by
    check_glass_bsdf.py); rough -> the `gltf_rough_dielectric` plugin of glass_bsdf.py (Walter et
    al. 2007 with strata's height-correlated G2; Mitsuba's `roughdielectric` has the separable
    G1 G1). attenuationColor c at attenuationDistance d -> an interior `homogeneous` medium,
    albedo 0, sigma_t = -ln(c)/d (sigma_a: strata multiplies each path segment inside by
    exp(-sigma_a t), t its length; Mitsuba's `volpath` attenuates the same segments), and the job
    is rendered with `volpath` instead of `path`. Without a volume: thin-walled, the
    `gltf_thin_dielectric` plugin (strata's ThinDielectric: reflection F D V, transmission that
    lobe mirrored through the plane times (1 - F) tint; smooth: mirror F, straight through
    (1 - F) tint). Mitsuba's own `thindielectric` (R = 2F/(1 + F)) is a different sheet: the
    negative control job thin-glass-thindielectric (CONTROLS) uses it for the smooth sheets.
    Glass scenes take strata --max-depth 16 (PATH_DEPTH; Mitsuba max_depth 17).
  - clear coat (gltf only): a material with KHR_materials_clearcoat is strata's `Layered` coat
    over the glTF BRDF (src/shading/layers.rs, energy compensation off), converted by
    coat_props() when the coat is uniform: clearcoatTexture, clearcoatRoughnessTexture,
    clearcoatNormalTexture, a normalTexture of the base, other extensions and emission are
    refused (ConversionError). It becomes the `gltf_coated` plugin of coat_bsdf.py with the
    material's gltf_metal_rough (as above, textures included) nested as its base, clearcoat =
    clearcoatFactor and clearcoat_roughness = clearcoatRoughnessFactor (both default 0; alpha_c
    = r^2, a mirror below 1e-3): f = c Fc f_coat + (1 - c Fc) f_base with Fc = 0.04 + 0.96 (1 -
    n.wi)^5, Schlick's Fresnel of the coat's index 1.5 at the view angle (KHR_materials_clearcoat,
    "Layering": fresnel_coat uses N.V, not V.H), f_coat = D V of GGX around the vertex normal,
    neither Fresnel-weighted again nor divided by its albedo; check_coat_bsdf.py checks it. A
    coat of weight 0 is no coat (the plain gltf_metal_rough, as strata drops it). The negative
    control jobs (CONTROLS) change the model: coat-f0-0.028 gives every coat f0 0.028 (index
    1.4), coat-additive leaves out the base's weight 1 - c Fc.
  `ao` jobs ignore --materials.
- emission: a one-sided `area` emitter with radiance = emissiveFactor x emissiveTexture x
  KHR_materials_emissive_strength. A doubleSided emissive material is refused unless its
  `extras.strata_reference_single_sided_ok` is true (then only its front face emits).
- KHR_lights_punctual: point -> `point` with intensity = color x intensity; directional ->
  `directional` with irradiance = color x intensity; spot lights are refused.
- background: the document's `extras.strata.background` (linear RGB radiance, black when
  absent) -> a `constant` emitter; camera rays that miss see it.
- environment map (scenes of ENVIRONMENTS; strata --env FILE --env-rotate DEG): an `envmap`
  emitter in place of the background, camera rays that miss see it. strata looks direction d up
  at u = 0.5 + atan2(d.z, d.x)/2pi, v = acos(d.y)/pi (Blender's convention), bilinearly between
  texel centres, u wrapping, v clamped at the poles; the map turned by DEG about +Y. Mitsuba's
  envmap reads u = atan2(x, -z)/2pi in its local frame, so to_world = a turn of 90 + DEG degrees
  about +Y; and it interpolates u between texel centres too but v between rows spread from pole
  to pole (row k at v = k/(H - 1)). The map given to Mitsuba therefore has 2H + 1 rows, row k
  strata's lookup at v = k/2H (the texel rows at odd k, the means of neighbouring rows between,
  the first and last rows repeated at the poles): linear interpolation over those rows is
  strata's lookup exactly. check_environment() (--check) pins this on an asymmetric random map.
- controls: a job of CONTROLS renders a deliberately different model; its manifest row carries
  "control" (what it is), and tests/references.rs only checks that strata fails against it.
- integrators: `ao` = every surface white twosided diffuse (reflectance 1), a constant
  environment of radiance 1, no other emitter, `path` with max_depth 2 and hide_emitters (so
  misses are 0): the image is (1/pi) * integral of V cos over the hemisphere. `direct` = `path`
  with max_depth 2 (strata --max-depth 1) and `path` = max_depth 9 (strata's default 8 bounces),
  both with the real materials, emitters and lights. Russian roulette is effectively off
  (rr_depth 100 > max_depth), so it adds no noise.
- noise: each reference is K independent passes (different seeds, `multijitter` sampler); the
  EXR is their mean and the .var.exr the per-pixel variance of that mean (sample variance
  across passes / K).
- masks: <scene>.mask.exr marks the pixels where the two readings of "the shading normal's
  hemisphere" differ on smooth-shaded meshes (see normals_mask()).
"""
import argparse
import base64
import hashlib
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import time
import urllib.parse

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, HERE)
import scene_hash  # noqa: E402

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

import coat_bsdf  # noqa: E402
import glass_bsdf  # noqa: E402
import gltf_bsdf  # noqa: E402

VARIANT = os.environ.get("STRATA_MITSUBA_VARIANT", "scalar_rgb")
RR_DEPTH = 100
OUT_DIR = os.path.join(REPO, "scenes", "references")

# Scenes: repository-relative path and output resolution (width, height).
SCENES = {
    "ao-open-plane": ("scenes/ao-open-plane.gltf", (64, 64)),
    "ao-wall": ("scenes/ao-wall.gltf", (64, 64)),
    "flight-helmet": ("scenes/flight-helmet.gltf", (192, 144)),
    "cornell-box": ("scenes/cornell-box.gltf", (160, 160)),
    "point-lights": ("scenes/point-lights.gltf", (192, 144)),
    "suzanne": ("scenes/suzanne.gltf", (192, 144)),
    "emissive-strength": ("scenes/emissive-strength.gltf", (256, 128)),
    "sphere-grid": ("scenes/sphere-grid.gltf", (192, 144)),
    "sphere-grid-sky": ("scenes/sphere-grid-sky.gltf", (192, 144)),
    # Lit by an environment map (ENVIRONMENTS) instead of their own background.
    "ao-wall-studio": ("scenes/ao-wall.gltf", (64, 64)),
    "suzanne-studio": ("scenes/suzanne.gltf", (128, 96)),
    # Glass (tools/scenes/make_glass.py): spheres bounding volumes, and thin-walled panels.
    "glass": ("scenes/glass.gltf", (128, 96)),
    "thin-glass": ("scenes/thin-glass.gltf", (128, 96)),
    # A negative control (CONTROLS), not a reference: thin-glass with Mitsuba's thindielectric.
    "thin-glass-thindielectric": ("scenes/thin-glass.gltf", (128, 96)),
    # Clear coats (tools/scenes/make_coat.py), and two negative controls: coats of index 1.4, and
    # coats that do not darken the material below them.
    "coat": ("scenes/coat.gltf", (128, 96)),
    "coat-f0-0.028": ("scenes/coat.gltf", (128, 96)),
    "coat-additive": ("scenes/coat.gltf", (128, 96)),
}
# Scenes lit by an HDR environment map: strata's --env FILE (repository-relative), --env-rotate
# (degrees about +Y). Poly Haven's studio_small_05 (CC0) puts nearly all its light in half of
# the map (u in [0.5, 1]: toward +X and +Z), so a turn of the map changes the image.
STUDIO = "scenes/env/studio_small_05_1k/studio_small_05_1k.hdr"
ENVIRONMENTS = {
    "ao-wall-studio": {"file": STUDIO, "rotate": 30.0},
    "suzanne-studio": {"file": STUDIO, "rotate": 30.0},
}
# strata integrator -> (Mitsuba max_depth, strata --max-depth or None)
INTEGRATORS = {"ao": (2, None), "direct": (2, 1), "path": (9, 8)}
# Scenes whose path jobs need more bounces than strata's default 8: light through a glass
# sphere takes two refractions and, inside, reflections, each a bounce. (strata --max-depth,
# Mitsuba max_depth = that + 1.)
PATH_DEPTH = {"glass": 16, "thin-glass": 16, "thin-glass-thindielectric": 16}
# Negative controls: rendered like references, listed in the manifest with "control" (which
# tests/references.rs uses only to show that its comparison fails), never compared as truth.
CONTROLS = {
    "thin-glass-thindielectric": {
        "thin_model": "mitsuba-thindielectric",
        "description": "NEGATIVE CONTROL, not a reference: scenes/thin-glass.gltf with its smooth sheets converted to "
                       "Mitsuba's thindielectric (R = 2F/(1 + F): the light reflected back and forth inside the "
                       "sheet), a different model from strata's and the extension's (R = F). strata's thin-glass "
                       "render must fail the comparison against it.",
    },
    "coat-f0-0.028": {
        "coat_model": "f0-0.028",
        "description": "NEGATIVE CONTROL, not a reference: scenes/coat.gltf with every clear coat's reflectance at "
                       "normal incidence 0.028 (a coat of index 1.4) instead of the extension's 0.04 (index 1.5), "
                       "through the same gltf_coated plugin. strata's coat render must fail the comparison "
                       "against it.",
    },
    "coat-additive": {
        "coat_model": "additive",
        "description": "NEGATIVE CONTROL, not a reference: scenes/coat.gltf with every clear coat added over its "
                       "base without darkening it (c Fc f_coat + f_base, where the extension and strata weight the "
                       "base by 1 - c Fc), through the same gltf_coated plugin. strata's coat render must fail the "
                       "comparison against it.",
    },
}
# Jobs: (scene, integrator, total spp, passes). Passes use spp/passes samples each.
JOBS = [
    ("ao-open-plane", "ao", 4096, 16),
    ("ao-wall", "ao", 4096, 16),
    ("flight-helmet", "ao", 8192, 32),
    ("cornell-box", "ao", 8192, 32),
    ("point-lights", "ao", 8192, 32),
    ("suzanne", "ao", 8192, 32),
    ("emissive-strength", "ao", 8192, 32),
    ("cornell-box", "direct", 8192, 32),
    ("point-lights", "direct", 8192, 32),
    ("suzanne", "direct", 8192, 32),
    ("emissive-strength", "direct", 8192, 32),
    ("cornell-box", "path", 8192, 32),
    ("point-lights", "path", 8192, 32),
    ("suzanne", "path", 8192, 32),
    ("emissive-strength", "path", 8192, 32),
    # The glossy scene: shaded jobs only, with --materials gltf.
    ("sphere-grid", "direct", 8192, 32),
    ("sphere-grid", "path", 8192, 32),
    # The same spheres and floor under a constant sky (the scene's extras.strata.background):
    # glossy reflections of a constant environment, camera rays that miss see it.
    ("sphere-grid-sky", "path", 8192, 32),
    # Under an HDR environment map (ENVIRONMENTS), --materials gltf: a diffuse floor beside a
    # wall (the wall hides half the map) and the glossy, textured Suzanne.
    ("ao-wall-studio", "path", 8192, 32),
    ("suzanne-studio", "path", 8192, 32),
    # Glass (--materials gltf): smooth, rough and absorbing spheres; thin-walled panels; and the
    # thin panels' negative control (CONTROLS).
    ("glass", "path", 8192, 32),
    ("thin-glass", "path", 8192, 32),
    ("thin-glass-thindielectric", "path", 8192, 32),
    # Clear coats (--materials gltf): smooth, half-weight and rough coats and an uncoated twin;
    # and the coats' negative controls (CONTROLS).
    ("coat", "path", 8192, 32),
    ("coat-f0-0.028", "path", 8192, 32),
    ("coat-additive", "path", 8192, 32),
]
# Material models (--materials): what every glTF material of a shaded job becomes.
MATERIAL_MODELS = {
    "lambertian": "twosided(diffuse), reflectance = base colour; metallic and roughness ignored",
    "gltf": "gltf_metal_rough (tools/references/gltf_bsdf.py): glTF 2.0 Appendix B BRDF, single scattering, "
            "two-sided; base colour, metallic, roughness",
}
# Mitsuba's multi-jittered sampler: each pass is an independent, unbiased stratified estimate
# (seeded differently), so the sample variance across passes stays a valid variance estimate;
# at equal spp it had 8x (AO) to 40x (path) lower variance than `independent` on the Cornell box.
SAMPLER = "multijitter"


class ConversionError(Exception):
    pass


# ---------------------------------------------------------------------------------------
# glTF reading
# ---------------------------------------------------------------------------------------

COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
WRAP = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
SUPPORTED_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_transmission",
                        "KHR_materials_volume", "KHR_materials_ior", "KHR_materials_clearcoat"}


class Gltf:
    def __init__(self, path):
        self.path = os.path.abspath(path)
        self.base = os.path.dirname(self.path)
        with open(self.path, "rb") as f:
            data = f.read()
        self.glb_bin = None
        if data[:4] == b"glTF":
            off = 12
            doc = None
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

    def resolve(self, uri):
        return os.path.normpath(os.path.join(self.base, urllib.parse.unquote(uri)))

    def _uri_bytes(self, uri):
        if uri.startswith("data:"):
            head, payload = uri.split(",", 1)
            if not head.endswith(";base64"):
                return urllib.parse.unquote_to_bytes(payload)
            return base64.b64decode(payload)
        with open(self.resolve(uri), "rb") as f:
            return f.read()

    def buffer(self, i):
        if i not in self._buffers:
            b = self.doc["buffers"][i]
            if "uri" in b:
                data = self._uri_bytes(b["uri"])
            elif i == 0 and self.glb_bin is not None:
                data = self.glb_bin
            else:
                raise ConversionError(f"buffer {i} has no data")
            if len(data) < b["byteLength"]:
                raise ConversionError(f"buffer {i} is shorter than its byteLength")
            self._buffers[i] = data
        return self._buffers[i]

    def _view_array(self, view_index, byte_offset, dtype, ncomp, count):
        view = self.doc["bufferViews"][view_index]
        data = self.buffer(view["buffer"])
        itemsize = np.dtype(dtype).itemsize
        elem = itemsize * ncomp
        stride = view.get("byteStride") or elem
        start = view.get("byteOffset", 0) + byte_offset
        if count == 0:
            return np.zeros((0, ncomp), dtype)
        end = start + stride * (count - 1) + elem
        if end > view.get("byteOffset", 0) + view["byteLength"]:
            raise ConversionError(f"accessor runs past bufferView {view_index}")
        raw = np.frombuffer(data, dtype=np.uint8, count=end - start, offset=start)
        if stride == elem:
            return np.frombuffer(raw.tobytes(), dtype=dtype).reshape(count, ncomp).copy()
        rows = np.lib.stride_tricks.as_strided(raw, shape=(count, elem), strides=(stride, 1))
        return np.frombuffer(rows.copy().tobytes(), dtype=dtype).reshape(count, ncomp)

    def accessor(self, i, as_float=True):
        a = self.doc["accessors"][i]
        dtype = np.dtype(COMPONENT[a["componentType"]]).newbyteorder("<")
        ncomp = NCOMP[a["type"]]
        count = a["count"]
        if "bufferView" in a:
            arr = self._view_array(a["bufferView"], a.get("byteOffset", 0), dtype, ncomp, count)
        else:
            arr = np.zeros((count, ncomp), dtype)
        if "sparse" in a:
            s = a["sparse"]
            idt = np.dtype(COMPONENT[s["indices"]["componentType"]]).newbyteorder("<")
            idx = self._view_array(s["indices"]["bufferView"], s["indices"].get("byteOffset", 0), idt, 1, s["count"])[:, 0]
            val = self._view_array(s["values"]["bufferView"], s["values"].get("byteOffset", 0), dtype, ncomp, s["count"])
            arr = arr.copy()
            arr[idx.astype(np.int64)] = val
        if not as_float:
            return arr
        out = arr.astype(np.float64)
        if a.get("normalized"):
            scale = {np.int8: 127.0, np.uint8: 255.0, np.int16: 32767.0, np.uint16: 65535.0}[COMPONENT[a["componentType"]]]
            out = out / scale
            if a["componentType"] in (5120, 5122):
                out = np.maximum(out, -1.0)
        return out


def node_local_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    t = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    s = node.get("scale", [1, 1, 1])
    r = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    m = np.eye(4)
    m[:3, :3] = r @ np.diag(s)
    m[:3, 3] = t
    return m


def walk(g):
    """Yields (node_index, node, world_matrix) depth-first, pre-order, over the default scene."""
    doc = g.doc
    scenes = doc.get("scenes", [])
    if not scenes:
        raise ConversionError("no scene")
    scene = scenes[doc.get("scene", 0)]

    def visit(i, parent, path):
        if i in path:
            raise ConversionError(f"node {i} is its own ancestor")
        node = doc["nodes"][i]
        world = parent @ node_local_matrix(node)
        yield i, node, world
        for c in node.get("children", []):
            yield from visit(c, world, path + (i,))

    for root in scene.get("nodes", []):
        yield from visit(root, np.eye(4), ())


def triangle_indices(g, prim, vertex_count):
    mode = prim.get("mode", 4)
    if "indices" in prim:
        idx = g.accessor(prim["indices"], as_float=False)[:, 0].astype(np.int64)
    else:
        idx = np.arange(vertex_count, dtype=np.int64)
    if mode == 4:
        n = len(idx) // 3
        tris = idx[: 3 * n].reshape(n, 3)
    elif mode == 5:  # strip: p_i = (v_i, v_{i+(1+i%2)}, v_{i+(2-i%2)})
        n = max(len(idx) - 2, 0)
        i = np.arange(n)
        tris = np.stack([idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]], axis=1)
    elif mode == 6:  # fan: p_i = (v_{i+1}, v_{i+2}, v_0)
        n = max(len(idx) - 2, 0)
        i = np.arange(n)
        tris = np.stack([idx[i + 1], idx[i + 2], np.full(n, idx[0] if len(idx) else 0)], axis=1)
    else:
        return None
    if len(tris) and tris.max() >= vertex_count:
        raise ConversionError("index out of range")
    return tris


# ---------------------------------------------------------------------------------------
# textures
# ---------------------------------------------------------------------------------------

_texture_cache = {}


def load_texture_linear(g, tex_index, srgb=True):
    """(H, W, 3) float32 linear RGB of glTF texture `tex_index`, and its wrap mode. `srgb`: a colour
    texture, decoded from sRGB; else a data texture (metallicRoughnessTexture), its values / 255."""
    tex = g.doc["textures"][tex_index]
    if "source" not in tex:
        raise ConversionError(f"texture {tex_index} has no source")
    img = g.doc["images"][tex["source"]]
    sampler = g.doc.get("samplers", [])[tex["sampler"]] if "sampler" in tex else {}
    ws, wt = sampler.get("wrapS", 10497), sampler.get("wrapT", 10497)
    if ws != wt:
        raise ConversionError(f"texture {tex_index}: wrapS {ws} != wrapT {wt} is not supported by Mitsuba's bitmap")
    key = (g.path, tex["source"], srgb)
    if key not in _texture_cache:
        if "uri" in img:
            data = g._uri_bytes(img["uri"])
        else:
            view = g.doc["bufferViews"][img["bufferView"]]
            buf = g.buffer(view["buffer"])
            data = buf[view.get("byteOffset", 0): view.get("byteOffset", 0) + view["byteLength"]]
        with tempfile.NamedTemporaryFile(suffix=".img") as f:
            f.write(data)
            f.flush()
            bmp = mi.Bitmap(f.name)
        # glTF colour textures are sRGB, data textures linear, whatever the file says; alpha is
        # ignored (opaque).
        bmp.set_srgb_gamma(srgb)
        fmt = bmp.pixel_format()
        if fmt in (mi.Bitmap.PixelFormat.Y, mi.Bitmap.PixelFormat.YA):
            target = mi.Bitmap.PixelFormat.Y
        else:
            target = mi.Bitmap.PixelFormat.RGB
        if fmt in (mi.Bitmap.PixelFormat.YA, mi.Bitmap.PixelFormat.RGBA):
            # Drop alpha by slicing raw channels first, so no (un)premultiplication happens.
            arr = np.array(bmp, copy=True)
            arr = arr[..., :1] if target == mi.Bitmap.PixelFormat.Y else arr[..., :3]
            bmp = mi.Bitmap(np.ascontiguousarray(arr), target)
            bmp.set_srgb_gamma(srgb)
        lin = bmp.convert(target, mi.Struct.Type.Float32, srgb_gamma=False)
        arr = np.array(lin, dtype=np.float32)
        if arr.ndim == 2:
            arr = arr[..., None]
        if arr.shape[2] == 1:
            arr = np.repeat(arr, 3, axis=2)
        _texture_cache[key] = np.ascontiguousarray(arr[..., :3])
    return _texture_cache[key], WRAP[ws]


def texture_dict(arr, wrap):
    return {"type": "bitmap", "data": mi.TensorXf(arr), "raw": True, "filter_type": "bilinear", "wrap_mode": wrap}


def check_texture_info(info, what):
    if info.get("texCoord", 0) != 0:
        raise ConversionError(f"{what}: only TEXCOORD_0 is supported")
    if "KHR_texture_transform" in info.get("extensions", {}):
        raise ConversionError(f"{what}: KHR_texture_transform is not supported by this converter")


# ---------------------------------------------------------------------------------------
# scene conversion
# ---------------------------------------------------------------------------------------

def material_props(g, mat_index, mode, materials="lambertian", warnings=None, glass=None, coat=None):
    """(bsdf dict, emitter dict or None, needs_uv, interior medium dict or None) for a material,
    in mode 'ao' or 'shaded', with the material model `materials` ('lambertian' or 'gltf', see
    MATERIAL_MODELS). `glass`: a dict that collects the conversion of each transmissive
    material (glass_props), with the key "thin_model" (THIN_MODELS) read from it. `coat`: the
    same for clear-coated materials (coat_props), with the key "coat_model" (COAT_MODELS)."""
    white = {"type": "twosided", "material": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}}
    if mode == "ao":
        return white, None, False, None
    mat = g.doc["materials"][mat_index] if mat_index is not None else {}
    name = mat.get("name", f"material {mat_index}")
    pbr = mat.get("pbrMetallicRoughness", {})
    factor = np.array(pbr.get("baseColorFactor", [1, 1, 1, 1])[:3], dtype=np.float32)
    needs_uv = False
    if "baseColorTexture" in pbr:
        info = pbr["baseColorTexture"]
        check_texture_info(info, f"{name} baseColorTexture")
        arr, wrap = load_texture_linear(g, info["index"])
        reflectance = texture_dict(np.ascontiguousarray(arr * factor[None, None, :]), wrap)
        needs_uv = True
    else:
        reflectance = {"type": "rgb", "value": factor.tolist()}
    medium = None
    # A transmissionFactor of 0 without a texture transmits nothing: the glTF BRDF, as in strata.
    transmission = mat.get("extensions", {}).get("KHR_materials_transmission")
    if materials == "gltf" and transmission is not None and (transmission.get("transmissionFactor", 0.0) > 0.0
                                                            or "transmissionTexture" in transmission):
        glass = {} if glass is None else glass
        bsdf, medium, what = glass_props(mat, name, reflectance, glass.get("thin_model", "strata"))
        glass.setdefault("materials", {})[name] = what
    elif materials == "gltf" and "KHR_materials_clearcoat" in mat.get("extensions", {}):
        coat = {} if coat is None else coat
        bsdf, mr_uv, what = coat_props(g, mat, name, reflectance, warnings, coat.get("coat_model", "strata"))
        coat.setdefault("materials", {})[name] = what
        needs_uv |= mr_uv
    elif materials == "gltf":
        bsdf, mr_uv = gltf_bsdf_dict(g, mat, name, reflectance, warnings)
        needs_uv |= mr_uv
    else:
        bsdf = {"type": "twosided", "material": {"type": "diffuse", "reflectance": reflectance}}

    emissive = np.array(mat.get("emissiveFactor", [0, 0, 0]), dtype=np.float32)
    strength = mat.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
    emitter = None
    if np.any(emissive * strength > 0):
        if mat.get("doubleSided", False) and not mat.get("extras", {}).get("strata_reference_single_sided_ok", False):
            raise ConversionError(
                f"material '{name}' is emissive and doubleSided: Mitsuba's area emitter is one-sided, so the "
                "reference would miss the back face's emission. Set doubleSided false in the scene (or, if the "
                "back face cannot matter, extras.strata_reference_single_sided_ok = true).")
        scale = (emissive * strength).astype(np.float32)
        if "emissiveTexture" in mat:
            info = mat["emissiveTexture"]
            check_texture_info(info, f"{name} emissiveTexture")
            arr, wrap = load_texture_linear(g, info["index"])
            radiance = texture_dict(np.ascontiguousarray(arr * scale[None, None, :]), wrap)
            needs_uv = True
        else:
            radiance = {"type": "rgb", "value": scale.tolist()}
        emitter = {"type": "area", "radiance": radiance}
    if medium is not None and emitter is not None:
        raise ConversionError(f"material '{name}': an emissive glass is not supported")
    return bsdf, emitter, needs_uv, medium


# Material extensions that change the glTF BRDF, which the plugin does not model.
GLTF_BRDF_EXTENSIONS_IGNORED = ("KHR_materials_ior", "KHR_materials_specular", "KHR_materials_transmission",
                                "KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_volume",
                                "KHR_materials_iridescence", "KHR_materials_anisotropy", "KHR_materials_unlit",
                                "KHR_materials_pbrSpecularGlossiness", "KHR_materials_dispersion",
                                "KHR_materials_diffuse_transmission")


# How a thin-walled glass (transmission without a volume) is converted (glass_props).
THIN_MODELS = {
    "strata": "gltf_thin_dielectric (tools/references/glass_bsdf.py): strata's ThinDielectric, the extension's "
              "thin-walled model (reflection F D V; transmission the reflection lobe mirrored through the plane "
              "times (1 - F) base colour; smooth: mirror F, straight through (1 - F) base colour)",
    "mitsuba-thindielectric": "NEGATIVE CONTROL: smooth thin-walled glass as Mitsuba's built-in thindielectric, "
                              "which sums the sheet's internal reflections (R = 2F/(1 + F), T = (1 - F)/(1 + F)); "
                              "rough ones as gltf_thin_dielectric",
}
# Extensions a glass material may carry: the ones the conversion reads, and emissive strength
# (a glass must not emit; checked by material_props).
GLASS_EXTENSIONS = {"KHR_materials_transmission", "KHR_materials_volume", "KHR_materials_ior",
                    "KHR_materials_emissive_strength"}


def glass_props(mat, name, base_color, thin_model="strata"):
    """(bsdf dict, interior medium dict or None, description) of a transmissive glTF material
    (KHR_materials_transmission), as strata renders it (Materials::gltf_bsdf,
    src/shading/dielectric.rs). Only glass that strata renders as an interface alone is
    converted: transmissionFactor 1 (no texture) and metallicFactor 0; a mixture of glass and
    the glTF BRDF is refused, as are textured roughness, extensions the conversion does not read
    and ior 1 (an invisible interface).

    - with KHR_materials_volume and thicknessFactor > 0: the boundary of a volume, relative index
      ior entering (ext_ior 1, int_ior ior). Smooth (alpha = roughness^2 < 1e-3): Mitsuba's
      `dielectric` (exact Fresnel; transmission scaled by 1/eta'^2 in radiance mode and by
      specular_transmittance = the base colour, as strata's Dielectric); rough: the
      gltf_rough_dielectric plugin (glass_bsdf.py: Walter et al. 2007 with strata's
      height-correlated G2; Mitsuba's roughdielectric has the separable G1 G1).
      An attenuationColor c < 1 at attenuationDistance d gives an interior `homogeneous` medium
      of sigma_t = sigma_a = -ln(c) / d per channel and albedo 0 (Beer-Lambert, exp(-sigma_a t)
      over the distance t travelled inside: strata multiplies each path segment that ends on
      the inside of the boundary by it; the reference needs `volpath`).
    - without a volume: thin-walled, the gltf_thin_dielectric plugin (strata's ThinDielectric);
      thin_model "mitsuba-thindielectric" (a negative control) puts Mitsuba's `thindielectric`
      in place of the smooth ones."""
    if thin_model not in THIN_MODELS:
        raise ValueError(f"thin_model {thin_model!r} is not one of {sorted(THIN_MODELS)}")
    ext = mat.get("extensions", {})
    pbr = mat.get("pbrMetallicRoughness", {})
    others = sorted(set(ext) - GLASS_EXTENSIONS)
    problems = []
    if others:
        problems.append(f"extensions {others} on a transmissive material are not converted")
    tr = ext["KHR_materials_transmission"]
    if tr.get("transmissionFactor", 0.0) != 1.0 or "transmissionTexture" in tr:
        problems.append(f"transmissionFactor {tr.get('transmissionFactor', 0.0)}"
                        + (" with a transmissionTexture" if "transmissionTexture" in tr else "")
                        + " mixes glass with the glTF BRDF (only transmission 1, untextured, is converted)")
    if pbr.get("metallicFactor", 1.0) != 0.0:
        problems.append(f"metallicFactor {pbr.get('metallicFactor', 1.0)} (glTF's default is 1) mixes glass with "
                        "metal (only metallic 0 is converted)")
    if "metallicRoughnessTexture" in pbr:
        problems.append("a metallicRoughnessTexture (textured metallic and roughness) is not converted")
    ior = float(ext.get("KHR_materials_ior", {}).get("ior", 1.5))
    if not (math.isfinite(ior) and ior > 1.0):
        problems.append(f"ior {ior}: only ior > 1 is converted (strata treats 1 as an invisible interface)")
    if problems:
        raise ConversionError(f"material '{name}': " + "; ".join(problems))
    roughness = min(max(float(pbr.get("roughnessFactor", 1.0)), 0.0), 1.0)
    alpha = roughness * roughness
    smooth = alpha < glass_bsdf.SMOOTH_ALPHA
    vol = ext.get("KHR_materials_volume")
    medium = None
    if vol is not None and float(vol.get("thicknessFactor", 0.0)) > 0.0:
        what = {"kind": "volume boundary", "ior": ior, "roughness": roughness, "alpha": alpha}
        if smooth:
            bsdf = {"type": "dielectric", "int_ior": ior, "ext_ior": 1.0, "specular_transmittance": base_color}
            what["mitsuba"] = "dielectric"
        else:
            glass_bsdf.register()
            bsdf = {"type": glass_bsdf.ROUGH_NAME, "eta": ior, "alpha": alpha, "specular_transmittance": base_color}
            what["mitsuba"] = glass_bsdf.ROUGH_NAME
        colour = np.array(vol.get("attenuationColor", [1.0, 1.0, 1.0]), dtype=np.float64)
        distance = float(vol.get("attenuationDistance", math.inf))
        if np.any(colour <= 0.0) or np.any(colour > 1.0) or not distance > 0.0:
            raise ConversionError(f"material '{name}': attenuationColor {colour.tolist()} must lie in (0, 1] and "
                                  f"attenuationDistance {distance} be positive")
        sigma = -np.log(colour) / distance if math.isfinite(distance) else np.zeros(3)
        if np.any(sigma > 0.0):
            # Mitsuba reads an RGB sigma_t as a reflectance (each channel at most 1): the
            # largest channel goes into `scale`.
            top = float(sigma.max())
            medium = {"type": "homogeneous", "albedo": {"type": "rgb", "value": [0.0, 0.0, 0.0]},
                      "sigma_t": {"type": "rgb", "value": (sigma / top).tolist()}, "scale": top}
            what["medium"] = {"type": "homogeneous", "albedo": 0, "sigma_t": sigma.tolist()}
    else:
        what = {"kind": "thin-walled", "ior": ior, "roughness": roughness, "alpha": alpha}
        if smooth and thin_model == "mitsuba-thindielectric":
            bsdf = {"type": "thindielectric", "int_ior": ior, "ext_ior": 1.0, "specular_transmittance": base_color}
            what["mitsuba"] = "thindielectric (negative control)"
        else:
            glass_bsdf.register()
            bsdf = {"type": glass_bsdf.THIN_NAME, "eta": ior, "alpha": alpha, "specular_transmittance": base_color}
            what["mitsuba"] = glass_bsdf.THIN_NAME
    return bsdf, medium, what


# How a clear coat is converted (coat_props).
COAT_MODELS = {
    "strata": "gltf_coated (tools/references/coat_bsdf.py): KHR_materials_clearcoat's layering as strata's "
              "Layered without energy compensation: c Fc(n.wi) f_coat + (1 - c Fc(n.wi)) f_base, Fc Schlick's "
              "Fresnel of f0 0.04 (index 1.5) at the view angle, f_coat GGX D V of alpha clearcoatRoughness^2 "
              "(a mirror below alpha 1e-3), f_base gltf_metal_rough",
    "f0-0.028": "NEGATIVE CONTROL: gltf_coated with the coat's f0 0.028 (a coat of index 1.4) instead of the "
                "extension's 0.04 (index 1.5)",
    "additive": "NEGATIVE CONTROL: gltf_coated with attenuate_base false: c Fc f_coat + f_base, the coat added "
                "over a base that it does not darken (the factor 1 - c Fc left out)",
}
# Extensions a coated material may carry: the coat, and emissive strength (a coated material
# must not emit; checked by coat_props).
COAT_EXTENSIONS = {"KHR_materials_clearcoat", "KHR_materials_emissive_strength"}


def coat_props(g, mat, name, base_color, warnings, coat_model="strata"):
    """(bsdf dict, needs_uv, description) of a material with KHR_materials_clearcoat, as strata
    renders it (Materials::gltf_bsdf and Layered, src/shading/layers.rs) with energy compensation
    off: the gltf_coated plugin of coat_bsdf.py over the material's glTF BRDF (gltf_bsdf_dict,
    which may be textured). The coat itself must be uniform: clearcoatTexture,
    clearcoatRoughnessTexture and clearcoatNormalTexture are refused, and so is a normalTexture
    of the base (strata keeps the coat on the vertex normal under the base's normal map; the
    conversion has no normal maps), other extensions (they change the base under the coat) and
    emission (the extension darkens emission under the coat; the conversion does not model it).
    clearcoatFactor c (default 0) and clearcoatRoughnessFactor r (default 0) become the plugin's
    clearcoat and clearcoat_roughness (alpha = r^2); a coat of weight 0 is no coat (strata drops
    it), the plain glTF BRDF. Negative controls: coat_model "f0-0.028" gives every coat the
    reflectance of index 1.4, "additive" leaves out the base's weight 1 - c Fc."""
    if coat_model not in COAT_MODELS:
        raise ValueError(f"coat_model {coat_model!r} is not one of {sorted(COAT_MODELS)}")
    ext = mat.get("extensions", {})
    cc = ext["KHR_materials_clearcoat"]
    problems = []
    textures = [t for t in ("clearcoatTexture", "clearcoatRoughnessTexture", "clearcoatNormalTexture") if t in cc]
    if textures:
        problems.append(f"{', '.join(textures)}: only an untextured coat is converted")
    if "normalTexture" in mat:
        problems.append("a normalTexture under a clear coat is not converted (strata keeps the coat on the vertex "
                        "normal; the conversion has no normal maps)")
    others = sorted(set(ext) - COAT_EXTENSIONS)
    if others:
        problems.append(f"extensions {others} beside a clear coat are not converted")
    strength = ext.get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
    if any(float(e) * strength > 0 for e in mat.get("emissiveFactor", [0, 0, 0])):
        problems.append("an emissive coated material is not converted")
    factor = float(cc.get("clearcoatFactor", 0.0))
    roughness = float(cc.get("clearcoatRoughnessFactor", 0.0))
    if not (0.0 <= factor <= 1.0 and 0.0 <= roughness <= 1.0):
        problems.append(f"clearcoatFactor {factor} and clearcoatRoughnessFactor {roughness} must lie in [0, 1]")
    if problems:
        raise ConversionError(f"material '{name}': " + "; ".join(problems))
    base, needs_uv = gltf_bsdf_dict(g, mat, name, base_color, warnings, coated=True)
    if factor == 0.0:
        return base, needs_uv, {"clearcoat": 0.0, "mitsuba": gltf_bsdf.PLUGIN_NAME + " (a coat of weight 0)"}
    coat_bsdf.register()
    bsdf = {"type": coat_bsdf.PLUGIN_NAME, "clearcoat": factor, "clearcoat_roughness": roughness, "base": base}
    what = {"clearcoat": factor, "clearcoat_roughness": roughness, "alpha": roughness * roughness,
            "mitsuba": coat_bsdf.PLUGIN_NAME}
    if coat_model == "f0-0.028":
        bsdf["coat_f0"] = 0.028
        what["coat_f0"] = 0.028
        what["mitsuba"] += " with coat_f0 0.028 (negative control)"
    elif coat_model == "additive":
        bsdf["attenuate_base"] = False
        what["attenuate_base"] = False
        what["mitsuba"] += " with attenuate_base false (negative control)"
    return bsdf, needs_uv, what


def gltf_bsdf_dict(g, mat, name, base_color, warnings, coated=False):
    """The glTF BRDF plugin (gltf_bsdf.py) for material `mat`, and whether it needs TEXCOORD_0.
    metallic = metallicFactor x metallicRoughnessTexture.B, roughness = roughnessFactor x
    metallicRoughnessTexture.G (linear data, glTF's defaults 1 and 1). `coated`: the base of a
    clear coat (coat_props), whose KHR_materials_clearcoat is converted, not ignored."""
    gltf_bsdf.register()
    pbr = mat.get("pbrMetallicRoughness", {})
    metallic = float(pbr.get("metallicFactor", 1.0))
    roughness = float(pbr.get("roughnessFactor", 1.0))
    needs_uv = False
    if "metallicRoughnessTexture" in pbr:
        info = pbr["metallicRoughnessTexture"]
        check_texture_info(info, f"{name} metallicRoughnessTexture")
        arr, wrap = load_texture_linear(g, info["index"], srgb=False)
        metallic = texture_dict(np.ascontiguousarray(arr[..., 2:3] * np.float32(metallic)), wrap)
        roughness = texture_dict(np.ascontiguousarray(arr[..., 1:2] * np.float32(roughness)), wrap)
        needs_uv = True
    for ext in mat.get("extensions", {}):
        msg = f"material '{name}': {ext} ignored (the reference uses the core glTF BRDF)"
        if coated and ext == "KHR_materials_clearcoat":
            continue
        if ext in GLTF_BRDF_EXTENSIONS_IGNORED and warnings is not None and msg not in warnings:
            warnings.append(msg)
    return {"type": gltf_bsdf.PLUGIN_NAME, "base_color": base_color, "metallic": metallic,
            "roughness": roughness}, needs_uv


def make_mesh(name, pos, faces, normals, uvs, bsdf, emitter, interior=None):
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    if emitter is not None:
        props["emitter"] = mi.load_dict(emitter)
    if interior is not None:
        props["interior"] = mi.load_dict(interior)
    mesh = mi.Mesh(name, len(pos), len(faces), props, has_vertex_normals=normals is not None,
                   has_vertex_texcoords=uvs is not None)
    p = mi.traverse(mesh)
    scalar = mi.variant().startswith("scalar")
    f32 = (lambda a: a) if scalar else mi.Float
    u32 = (lambda a: a) if scalar else mi.UInt32
    p["vertex_positions"] = f32(np.ascontiguousarray(pos, dtype=np.float32).ravel())
    p["faces"] = u32(np.ascontiguousarray(faces, dtype=np.uint32).ravel())
    if normals is not None:
        p["vertex_normals"] = f32(np.ascontiguousarray(normals, dtype=np.float32).ravel())
    if uvs is not None:
        p["vertex_texcoords"] = f32(np.ascontiguousarray(uvs, dtype=np.float32).ravel())
    p.update()
    return mesh


def convert(path, mode, resolution, max_depth, materials="lambertian", environment=None, thin_model="strata",
            coat_model="strata"):
    """Mitsuba scene dict for glTF `path`. mode 'ao' or 'shaded'; materials 'lambertian' or 'gltf'
    (MATERIAL_MODELS); environment: an ENVIRONMENTS entry that lights a shaded scene in place of
    its background, or None; thin_model: how thin-walled glass is converted (THIN_MODELS);
    coat_model: how clear coats are converted (COAT_MODELS). Returns (dict, info)."""
    g = Gltf(path)
    doc = g.doc
    scene = {"type": "scene"}
    info = {"triangles": 0, "meshes": 0, "lights": [], "emissive_materials": set(), "warnings": []}
    glass = {"thin_model": thin_model}
    coat = {"coat_model": coat_model}
    media = False
    camera = None
    lights = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    for ni, node, world in walk(g):
        if "camera" in node and camera is None:
            camera = (doc["cameras"][node["camera"]], world)
        if "mesh" in node:
            lin = world[:3, :3]
            det = np.linalg.det(lin)
            normal_m = np.linalg.inv(lin).T if abs(det) > 0 else None
            for pi, prim in enumerate(doc["meshes"][node["mesh"]]["primitives"]):
                attrs = prim["attributes"]
                pos = g.accessor(attrs["POSITION"])
                tris = triangle_indices(g, prim, len(pos))
                if tris is None:
                    info["warnings"].append(f"node {ni} mesh {node['mesh']} primitive {pi}: mode {prim.get('mode')} skipped")
                    continue
                if len(tris) == 0:
                    continue
                if det < 0:
                    tris = tris[:, [0, 2, 1]]
                wpos = pos @ lin.T + world[:3, 3]
                bsdf, emitter, needs_uv, medium = material_props(g, prim.get("material"), mode, materials,
                                                                 info["warnings"], glass, coat)
                media |= medium is not None
                normals = None
                if "NORMAL" in attrs and emitter is None and normal_m is not None:
                    n = g.accessor(attrs["NORMAL"]) @ normal_m.T
                    ln = np.linalg.norm(n, axis=1, keepdims=True)
                    normals = np.where(ln > 0, n / np.maximum(ln, 1e-30), 0.0)
                if emitter is not None:
                    info["emissive_materials"].add(prim.get("material"))
                    if "NORMAL" in attrs:
                        check_flat_normals(g, attrs["NORMAL"], tris, wpos, normal_m, f"node {ni} primitive {pi}")
                uvs = None
                if needs_uv:
                    if "TEXCOORD_0" not in attrs:
                        raise ConversionError(f"node {ni} primitive {pi}: textured material without TEXCOORD_0")
                    # Passed unchanged: Mitsuba 3's bitmap texture puts uv (0, 0) at the image's
                    # first (top) row, as glTF does (verified by --check; flipping v
                    # renders the texture upside down).
                    uvs = g.accessor(attrs["TEXCOORD_0"])[:, :2].copy()
                mesh = make_mesh(f"n{ni}_m{node['mesh']}_p{pi}", wpos, tris, normals, uvs, bsdf, emitter, medium)
                scene[f"mesh_{ni}_{pi}"] = mesh
                info["triangles"] += len(tris)
                info["meshes"] += 1
        light_ext = node.get("extensions", {}).get("KHR_lights_punctual")
        if light_ext is not None and mode != "ao":
            light = lights[light_ext["light"]]
            value = (np.array(light.get("color", [1, 1, 1])) * light.get("intensity", 1.0)).tolist()
            kind = light["type"]
            if kind == "point":
                if light.get("range"):
                    info["warnings"].append(f"light {light_ext['light']}: range ignored")
                scene[f"light_{ni}"] = {"type": "point", "position": world[:3, 3].tolist(),
                                        "intensity": {"type": "rgb", "value": value}}
            elif kind == "directional":
                d = world[:3, :3] @ np.array([0.0, 0.0, -1.0])
                d = d / np.linalg.norm(d)
                scene[f"light_{ni}"] = {"type": "directional", "direction": d.tolist(),
                                        "irradiance": {"type": "rgb", "value": value}}
            else:
                raise ConversionError(f"light {light_ext['light']}: type '{kind}' is not supported "
                                      "(glTF's spot cone falloff differs from Mitsuba's)")
            info["lights"].append(kind)
    if camera is None:
        raise ConversionError(f"{path}: no camera in the default scene")
    cam, world = camera
    if cam["type"] != "perspective":
        raise ConversionError("only perspective cameras are supported")
    rot = world[:3, :3]
    if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-5) or np.linalg.det(rot) < 0:
        raise ConversionError("the camera's world transform is not a rotation + translation")
    to_world = world @ np.diag([-1.0, 1.0, -1.0, 1.0])
    w, h = resolution
    scene["sensor"] = {
        "type": "perspective",
        "fov_axis": "y",
        "fov": math.degrees(cam["perspective"]["yfov"]),
        "near_clip": float(cam["perspective"].get("znear", 0.01)),
        "far_clip": 1e9,
        "to_world": mi.ScalarTransform4f(to_world.tolist()),
        "film": {"type": "hdrfilm", "width": w, "height": h, "rfilter": {"type": "box"},
                 "pixel_format": "rgb", "component_format": "float32"},
        "sampler": {"type": SAMPLER, "sample_count": 1},
    }
    background = doc.get("extras", {}).get("strata", {}).get("background")
    if mode == "ao":
        scene["env"] = {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}
        scene["integrator"] = {"type": "path", "max_depth": 2, "rr_depth": RR_DEPTH, "hide_emitters": True}
        info["background"] = None
    elif environment is not None:
        scene["env"] = envmap_dict(environment)
        scene["integrator"] = {"type": "path", "max_depth": max_depth, "rr_depth": RR_DEPTH, "hide_emitters": False}
        info["background"] = None
    else:
        if background is not None and any(c > 0 for c in background):
            scene["env"] = {"type": "constant", "radiance": {"type": "rgb", "value": [float(c) for c in background]}}
        scene["integrator"] = {"type": "path", "max_depth": max_depth, "rr_depth": RR_DEPTH, "hide_emitters": False}
        info["background"] = [float(c) for c in background] if background is not None else [0.0, 0.0, 0.0]
    if media:
        # The path integrator ignores media: volpath attenuates the segments inside an absorbing
        # glass (albedo 0: a sampled medium interaction ends the path, which averages to
        # exp(-sigma_t t)). Without media it gives the same estimates as path.
        scene["integrator"]["type"] = "volpath"
    info["emissive_materials"] = sorted(info["emissive_materials"])
    if "materials" in glass:
        info["glass"] = {"thin_model": thin_model, "materials": glass["materials"]}
    if "materials" in coat:
        info["coat"] = {"coat_model": coat_model, "description": COAT_MODELS[coat_model],
                        "materials": coat["materials"]}
    return scene, info


def read_environment(path):
    """The map's linear RGB texels (H, W, 3) float32, row 0 the top, as strata reads them: .hdr
    decoded as c * 2^(e - 136) (Mitsuba's Bitmap and the `image` crate agree bit for bit),
    negative and non-finite texels zeroed."""
    texels = np.array(mi.Bitmap(path), dtype=np.float32)[..., :3]
    return np.where(np.isfinite(texels) & (texels > 0), texels, np.float32(0))


def mitsuba_rows(texels):
    """The (2H + 1)-row map whose linear interpolation from pole to pole (Mitsuba's envmap) is
    strata's lookup (bilinear between texel centres, v clamped): row 2j + 1 is texel row j, row
    2j its mean with row j - 1, rows 0 and 2H the first and last texel rows."""
    h = texels.shape[0]
    rows = np.empty((2 * h + 1,) + texels.shape[1:], dtype=np.float32)
    rows[1::2] = texels
    rows[2:-1:2] = 0.5 * (texels[:-1] + texels[1:])
    rows[0], rows[-1] = texels[0], texels[-1]
    return rows


def envmap_to_world(rotate_degrees):
    """Mitsuba's envmap frame for strata's map turned by `rotate_degrees` about +Y (right-handed)."""
    return mi.ScalarTransform4f().rotate([0.0, 1.0, 0.0], 90.0 + rotate_degrees)


def envmap_dict(environment, texels=None):
    """Mitsuba `envmap` emitter equal to strata's --env FILE --env-rotate DEG (see the module
    docstring): FILE is environment["file"] unless `texels` are given."""
    if texels is None:
        texels = read_environment(os.path.join(REPO, environment["file"]))
    bitmap = mi.Bitmap(np.ascontiguousarray(mitsuba_rows(texels)), mi.Bitmap.PixelFormat.RGB)
    return {"type": "envmap", "bitmap": bitmap, "to_world": envmap_to_world(environment.get("rotate", 0.0)),
            "scale": float(environment.get("intensity", 1.0))}


def strata_env_radiance(texels, rotate_degrees, d):
    """strata's EnvMap::radiance written again in numpy (src/shading/envmap.rs): directions d
    (N, 3) -> radiance (N, 3)."""
    h, w = texels.shape[:2]
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    s, c = math.sin(math.radians(rotate_degrees)), math.cos(math.radians(rotate_degrees))
    x = c * d[:, 0] - s * d[:, 2]  # R_y(-rotation) d
    z = s * d[:, 0] + c * d[:, 2]
    u = 0.5 + np.arctan2(z, x) / (2 * math.pi)
    v = np.arccos(np.clip(d[:, 1], -1, 1)) / math.pi
    fx, fy = u * w - 0.5, v * h - 0.5
    x0, y0 = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
    tx, ty = (fx - x0)[:, None], (fy - y0)[:, None]

    def at(i, j):
        return texels[np.clip(j, 0, h - 1), np.mod(i, w)]

    return ((1 - tx) * (1 - ty) * at(x0, y0) + tx * (1 - ty) * at(x0 + 1, y0)
            + (1 - tx) * ty * at(x0, y0 + 1) + tx * ty * at(x0 + 1, y0 + 1))


def check_flat_normals(g, normal_acc, tris, wpos, normal_m, label):
    """Emissive primitives use face normals (winding = front); their normals must agree (up to sign)."""
    n = g.accessor(normal_acc) @ normal_m.T
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    a, b, c = wpos[tris[:, 0]], wpos[tris[:, 1]], wpos[tris[:, 2]]
    fn = np.cross(b - a, c - a)
    ok = np.linalg.norm(fn, axis=1) > 0
    fn = fn[ok] / np.linalg.norm(fn[ok], axis=1, keepdims=True)
    for k in range(3):
        cos = np.abs(np.sum(fn * n[tris[ok, k]], axis=1))
        if np.any(cos < 0.999):
            raise ConversionError(f"{label}: emissive primitive with smooth (non-flat) normals is not supported")


# ---------------------------------------------------------------------------------------
# rendering
# ---------------------------------------------------------------------------------------

def render_passes(scene_dict, spp, passes, seed_base):
    scene = mi.load_dict(scene_dict)
    per = spp // passes
    imgs = []
    for k in range(passes):
        img = mi.render(scene, spp=per, seed=seed_base + k)
        imgs.append(np.array(img, dtype=np.float64))
    stack = np.stack(imgs)  # (K, H, W, 3)
    mean = stack.mean(axis=0)
    var_mean = stack.var(axis=0, ddof=1) / passes
    return mean, var_mean


def normals_mask(scene_dict, resolution, sub=8):
    """Where strata's and Mitsuba's readings of "the shading normal's hemisphere" can differ.

    Per pixel, over sub x sub stratified camera rays (first hits only), returns (H, W, 3):
    R: the fraction of rays whose hit sees the interpolated shading normal n_s and the geometric
       normal n_g on different sides (sign(d.n_s) != sign(d.n_g); silhouettes of smooth-shaded
       meshes). There Mitsuba's twosided BSDF picks the side by n_s, so it shades the hemisphere
       that mostly points into the object, while strata flips n_s to n_g's side of the ray: the
       two differ by up to the whole value. Leave out pixels with R > 0.
    G: the mean over the rays' hits of (1 - |n_s.n_g|)/2, the cosine-weighted fraction of n_s's
       hemisphere that lies below the geometric surface. strata counts those directions as
       occluded; Mitsuba traces them (into the object: usually occluded too, but through thin
       open surfaces they can escape). It bounds the AO difference this causes; zero on flat
       geometry. Compare at very high precision only where G is small.
    B: 0."""
    scene = mi.load_dict(scene_dict)
    sensor = scene.sensors()[0]
    w, h = resolution
    mask = np.zeros((h, w, 3), dtype=np.float32)
    offsets = [(i + 0.5) / sub for i in range(sub)]
    if not mi.variant().startswith("scalar"):
        return normals_mask_jit(scene, sensor, resolution, sub, offsets)
    for y in range(h):
        for x in range(w):
            side = 0
            wedge = 0.0
            for oy in offsets:
                for ox in offsets:
                    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((x + ox) / w, (y + oy) / h), mi.Point2f(0.5, 0.5))
                    si = scene.ray_intersect(ray)
                    if not si.is_valid():
                        continue
                    d = (ray.d[0], ray.d[1], ray.d[2])
                    ng = (si.n[0], si.n[1], si.n[2])
                    ns = (si.sh_frame.n[0], si.sh_frame.n[1], si.sh_frame.n[2])
                    a = d[0] * ng[0] + d[1] * ng[1] + d[2] * ng[2]
                    b = d[0] * ns[0] + d[1] * ns[1] + d[2] * ns[2]
                    if a * b < 0:
                        side += 1
                    c = abs(ng[0] * ns[0] + ng[1] * ns[1] + ng[2] * ns[2])
                    wedge += (1.0 - min(c, 1.0)) / 2
            mask[y, x, 0] = side / (sub * sub)
            mask[y, x, 1] = wedge / (sub * sub)
    return mask


def normals_mask_jit(scene, sensor, resolution, sub, offsets):
    """normals_mask() in a JIT variant: the same rays, traced at once, and the same float64
    arithmetic on their float32 results. Against scalar_rgb (cornell-box, suzanne, flight-helmet
    at 48x36): R identical, G within 6e-6 (the variants round interpolated normals differently)."""
    w, h = resolution
    y, x, oy, ox = np.meshgrid(np.arange(h), np.arange(w), offsets, offsets, indexing="ij")
    u = ((x + ox) / w).astype(np.float32).ravel()
    v = ((y + oy) / h).astype(np.float32).ravel()
    n = len(u)
    ray, _ = sensor.sample_ray(dr.zeros(mi.Float, n), dr.full(mi.Float, 0.5, n), mi.Point2f(u, v),
                               mi.Point2f(dr.full(mi.Float, 0.5, n), dr.full(mi.Float, 0.5, n)))
    si = scene.ray_intersect(ray)
    valid = np.array(si.is_valid())
    d, ng, ns = (np.array(a, dtype=np.float32).T.astype(np.float64) for a in (ray.d, si.n, si.sh_frame.n))
    a = d[:, 0] * ng[:, 0] + d[:, 1] * ng[:, 1] + d[:, 2] * ng[:, 2]
    b = d[:, 0] * ns[:, 0] + d[:, 1] * ns[:, 1] + d[:, 2] * ns[:, 2]
    side = valid & (a * b < 0)
    c = np.abs(ng[:, 0] * ns[:, 0] + ng[:, 1] * ns[:, 1] + ng[:, 2] * ns[:, 2])
    wedge = np.where(valid, (1.0 - np.minimum(c, 1.0)) / 2, 0.0)
    mask = np.zeros((h, w, 3), dtype=np.float32)
    mask[..., 0] = side.reshape(h, w, sub * sub).sum(axis=2) / (sub * sub)
    mask[..., 1] = wedge.reshape(h, w, sub * sub).sum(axis=2) / (sub * sub)
    return mask


FIXED_EXR_DATETIME = b"2000:01:01 00:00:00"


def write_exr(path, arr):
    """Writes an RGB float32 EXR with ZIP compression (Mitsuba writes, oiiotool recompresses).

    The same pixels give the same bytes: oiiotool's Software/ImageHistory attributes are
    turned off, and the DateTime (EXR `capDate`) it always stamps is overwritten in place (same length, so no
    offset moves) with a fixed value."""
    tmp = path + ".tmp.exr"
    mi.Bitmap(np.ascontiguousarray(arr.astype(np.float32)), mi.Bitmap.PixelFormat.RGB).write(tmp)
    subprocess.run(["oiiotool", tmp, "--nosoftwareattrib", "--compression", "zip", "-o", path], check=True)
    os.remove(tmp)
    with open(path, "r+b") as f:
        head = f.read(4096)
        key = b"capDate\0string\0"  # OpenEXR's standard attribute for oiiotool's DateTime
        at = head.find(key)
        if at >= 0:
            n = struct.unpack_from("<i", head, at + len(key))[0]
            if n == len(FIXED_EXR_DATETIME):
                f.seek(at + len(key) + 4)
                f.write(FIXED_EXR_DATETIME)


def error_stats(mean, var_mean):
    se = np.sqrt(np.maximum(var_mean, 0)).mean(axis=2)  # per pixel, averaged over channels
    img_mean = float(mean.mean())
    rel = se / img_mean if img_mean > 0 else se
    value = mean.mean(axis=2)
    lit = value > 1e-3 * max(img_mean, 1e-30)
    own = se[lit] / value[lit]
    return {
        "image_mean": img_mean,
        "mean_standard_error": float(se.mean()),
        "max_standard_error": float(se.max()),
        "mean_relative_standard_error": float(rel.mean()),
        "p99_relative_standard_error": float(np.percentile(rel, 99)),
        "max_relative_standard_error": float(rel.max()),
        "median_standard_error_over_pixel_value": float(np.median(own)) if own.size else 0.0,
        "note": "per-pixel standard error of the reference mean = sqrt(var.exr), averaged over RGB; "
                "*_relative_* = divided by the image mean (over all pixels and channels); the last one "
                "divides by each pixel's own value (pixels above 1e-3 x the image mean)",
    }


def job_name(scene, integrator):
    return f"{scene}.{integrator}"


def depths(scene_name, integrator):
    """(Mitsuba max_depth, strata --max-depth or None) of a job."""
    if integrator == "path" and scene_name in PATH_DEPTH:
        return PATH_DEPTH[scene_name] + 1, PATH_DEPTH[scene_name]
    return INTEGRATORS[integrator]


def job_convert(scene_name, integrator, materials):
    """convert() with a job's settings."""
    rel, res = SCENES[scene_name]
    mdepth, _ = depths(scene_name, integrator)
    thin_model = CONTROLS.get(scene_name, {}).get("thin_model", "strata")
    coat_model = CONTROLS.get(scene_name, {}).get("coat_model", "strata")
    return convert(os.path.join(REPO, rel), "ao" if integrator == "ao" else "shaded", res, mdepth,
                   materials, ENVIRONMENTS.get(scene_name), thin_model, coat_model)


def strata_args(integrator, strata_depth, res, background, materials="lambertian", environment=None):
    """The strata command-line options that match this reference (plus --spp, --seed, -o)."""
    args = ["--integrator", integrator]
    if strata_depth is not None:
        args += ["--max-depth", str(strata_depth)]
    if integrator != "ao":
        # The plugin is the specification's single-scattering model; strata's Lambertian
        # model is its clay override.
        args += {"gltf": ["--energy-compensation", "off"],
                 "lambertian": ["--materials", "lambertian"]}[materials]
    if background is not None and any(c > 0 for c in background):
        args += ["--background", ",".join(f"{c:g}" for c in background)]
    if environment is not None:
        args += ["--env", environment["file"], "--env-rotate", f"{environment.get('rotate', 0.0):g}"]
        if environment.get("intensity", 1.0) != 1.0:
            args += ["--env-intensity", f"{environment['intensity']:g}"]
    return args + ["--resolution", f"{res[0]}x{res[1]}"]


_masks_done = set()


def run_job(scene_name, integrator, spp, passes, seed_base=0, materials="lambertian"):
    rel, res = SCENES[scene_name]
    scene_dict, info = job_convert(scene_name, integrator, materials)
    t0 = time.time()
    mean, var_mean = render_passes(scene_dict, spp, passes, seed_base)
    seconds = time.time() - t0
    base = os.path.join(OUT_DIR, job_name(scene_name, integrator))
    write_exr(base + ".exr", mean)
    write_exr(base + ".var.exr", var_mean)
    if scene_name not in _masks_done:
        # the camera's first hits only: one mask per scene, the same for every integrator
        write_exr(os.path.join(OUT_DIR, scene_name + ".mask.exr"), normals_mask(scene_dict, res))
        _masks_done.add(scene_name)
    # statistics of the float32 values as written (so --rebuild-manifest gives the same numbers)
    mean, var_mean = (a.astype(np.float32).astype(np.float64) for a in (mean, var_mean))
    return manifest_entry(scene_name, integrator, spp, passes, seed_base, scene_dict, info, mean, var_mean, seconds,
                          materials)


def manifest_path(path):
    """A path as a manifest row records it: relative to the repository when inside it (every
    reference of scenes/references/), else absolute (references of a race manifest, in a cache)."""
    path = os.path.abspath(path)
    return os.path.relpath(path, REPO) if os.path.commonpath([path, REPO]) == REPO else path


def scene_sha256(path):
    """The manifest's scene_sha256 (scene_hash.py): file names relative to the repository, or, for
    a scene outside it (a race scene in a cache), relative to the scene's own folder."""
    path = os.path.abspath(path)
    inside = os.path.commonpath([path, REPO]) == REPO
    return scene_hash.scene_sha256(path) if inside else scene_hash.scene_sha256(path, os.path.dirname(path))


# Options of the command that made the references, recorded in each row's "command" (set by
# --manifest and --out-dir; empty for scenes/references/).
COMMAND_OPTIONS = ""


def load_job_manifest(path):
    """Replaces SCENES, ENVIRONMENTS and JOBS by the jobs of a job manifest (e.g.
    tools/peers/hdri-races.json; --manifest), so that its references are made like the others.

    The file: {"description", "scene_dir" (where the scenes are; "~" expanded, relative to the
    repository), "out_dir" (default output folder of the references and their manifest.json),
    "environments": {KEY: {"file": map, relative to the repository}}, "jobs": [{"name", "scene"
    (file under scene_dir), "resolution": [W, H], "integrator", "environment": KEY, "rotate"
    (degrees about +Y), optional "intensity", "spp", "passes"}]}. A job NAME gives the reference
    NAME.INTEGRATOR. Scene and map paths are made absolute, so the rows' strata_args work from
    any folder. Returns the file's content."""
    with open(path) as f:
        spec = json.load(f)

    def absolute(p):
        return os.path.normpath(os.path.join(REPO, os.path.expanduser(p)))

    scene_dir = absolute(spec["scene_dir"])
    envs = {k: absolute(v["file"]) for k, v in spec["environments"].items()}
    SCENES.clear()
    ENVIRONMENTS.clear()
    JOBS[:] = []
    for j in spec["jobs"]:
        name = j["name"]
        if name in SCENES or name in CONTROLS or name in PATH_DEPTH:
            raise ValueError(f"{path}: job name {name!r} used twice or taken by scenes/references")
        SCENES[name] = (os.path.join(scene_dir, j["scene"]), tuple(j["resolution"]))
        env = {"file": envs[j["environment"]], "rotate": float(j["rotate"])}
        if "intensity" in j:
            env["intensity"] = float(j["intensity"])
        ENVIRONMENTS[name] = env
        JOBS.append((name, j.get("integrator", "path"), int(j["spp"]), int(j["passes"])))
    return spec


def manifest_entry(scene_name, integrator, spp, passes, seed_base, scene_dict, info, mean, var_mean, seconds,
                   materials="lambertian"):
    rel, res = SCENES[scene_name]
    mdepth, strata_depth = depths(scene_name, integrator)
    if integrator == "ao":
        materials = "lambertian"  # AO renders every surface white diffuse whatever the model
    base = os.path.join(OUT_DIR, job_name(scene_name, integrator))
    entry = {
        "reference": manifest_path(base + ".exr"),
        "variance": manifest_path(base + ".var.exr"),
        "scene": rel,
        "scene_sha256": scene_sha256(os.path.join(REPO, rel)),
        "integrator": integrator,
        "max_depth": strata_depth,
        "mitsuba_max_depth": mdepth,
        "strata_args": strata_args(integrator, strata_depth, res, info["background"], materials,
                                   None if integrator == "ao" else ENVIRONMENTS.get(scene_name)),
        "renderer": "mitsuba",
        "renderer_version": mi.__version__,
        "variant": mi.variant(),
        "mitsuba_integrator": dict(scene_dict["integrator"]),
        "mitsuba_sampler": SAMPLER,
        "russian_roulette": f"off in effect: rr_depth {RR_DEPTH} > max_depth {mdepth}",
        "spp": spp,
        "passes": passes,
        "spp_per_pass": spp // passes,
        "seeds": f"{seed_base}..{seed_base + passes - 1} (pass k uses seed {seed_base} + k)",
        "resolution": [res[0], res[1]],
        "background": ("ao: constant environment of radiance 1, hidden from camera rays (misses are 0)"
                       if integrator == "ao" else info["background"]),
        "triangles": info["triangles"],
        "lights": info["lights"],
        "command": "tools/references/make_references.sh " + COMMAND_OPTIONS
                   + ("" if materials == "lambertian" else f"--materials {materials} ")
                   + job_name(scene_name, integrator),
        "standard_error": error_stats(mean, var_mean),
        "mask": manifest_path(os.path.join(OUT_DIR, scene_name + ".mask.exr")),
        "mask_stats": mask_stats(os.path.join(OUT_DIR, scene_name + ".mask.exr")),
        "render_seconds": None if seconds is None else round(seconds, 1),
        "warnings": info["warnings"],
    }
    environment = ENVIRONMENTS.get(scene_name)
    if environment is not None and integrator != "ao":
        env_path = os.path.join(REPO, environment["file"])
        with open(env_path, "rb") as f:
            env_sha256 = hashlib.sha256(f.read()).hexdigest()
        entry["background"] = None
        entry["environment"] = {
            "file": environment["file"], "sha256": env_sha256,
            "rotate_degrees": environment.get("rotate", 0.0), "intensity": environment.get("intensity", 1.0),
            "mitsuba": "envmap, to_world = rotate +Y by 90 + rotate_degrees; the map resampled to 2H + 1 rows "
                       "(mitsuba_rows() in tools/references/mitsuba_refs.py), camera rays see it"}
    if has_alpha_modes(os.path.join(REPO, rel)):
        # The conversion renders MASK and BLEND surfaces opaque; so does strata with --no-alpha.
        entry["strata_args"] = entry["strata_args"] + ["--no-alpha"]
    if materials != "lambertian":  # (lambertian rows stay as they were before the option existed)
        entry["materials"] = {"model": materials, "description": MATERIAL_MODELS[materials]}
    if "glass" in info:
        entry["glass"] = info["glass"]
    if "coat" in info:
        entry["coat"] = info["coat"]
    if scene_name in CONTROLS:
        entry["control"] = CONTROLS[scene_name]["description"]
    return entry


def has_alpha_modes(path):
    """True when a material of glTF `path` has alphaMode MASK or BLEND."""
    return any(m.get("alphaMode", "OPAQUE") != "OPAQUE" for m in Gltf(path).doc.get("materials", []))


def mask_stats(path):
    if not os.path.exists(path):
        return None
    m = np.array(mi.Bitmap(path), dtype=np.float64)
    return {"pixels_shading_side_R_gt_0": int((m[..., 0] > 0).sum()),
            "pixels_wedge_G_gt_0.01": int((m[..., 1] > 0.01).sum()),
            "pixels_wedge_G_gt_0.001": int((m[..., 1] > 0.001).sum()),
            "note": "R > 0: leave out (shading normal faces away from the camera where the triangle faces it, "
                    "or the reverse: Mitsuba and strata pick different hemispheres); G: fraction of the shading "
                    "hemisphere below the geometric surface (strata: occluded; Mitsuba: traced), bounds the AO "
                    "difference from that rule. See normals_mask() in tools/references/mitsuba_refs.py."}


def rebuild_entry(scene_name, integrator, spp, passes, old, materials="lambertian"):
    """Manifest entry recomputed from the EXRs on disk (no rendering); keeps the old timing."""
    rel, res = SCENES[scene_name]
    scene_dict, info = job_convert(scene_name, integrator, materials)
    base = os.path.join(OUT_DIR, job_name(scene_name, integrator))
    mean = np.array(mi.Bitmap(base + ".exr"), dtype=np.float64)[..., :3]
    var_mean = np.array(mi.Bitmap(base + ".var.exr"), dtype=np.float64)[..., :3]
    seconds = (old or {}).get("render_seconds")
    if not os.path.exists(os.path.join(OUT_DIR, scene_name + ".mask.exr")):
        write_exr(os.path.join(OUT_DIR, scene_name + ".mask.exr"), normals_mask(scene_dict, res))
    return manifest_entry(scene_name, integrator, spp, passes, 0, scene_dict, info, mean, var_mean, seconds, materials)


MANIFEST_HEADER = {
    "description": "Reference images of strata's scenes rendered with Mitsuba 3. Each <scene>.<integrator>.exr "
                   "is the mean of `passes` independent renders (linear Rec.709 RGB, float32, ZIP); "
                   "<scene>.<integrator>.var.exr is the per-pixel variance of that mean (sample variance across "
                   "passes / passes). Conventions: scenes/references/README.md.",
    "hash_algorithm": scene_hash.ALGORITHM,
    "regenerate_all": "tools/references/make_references.sh",
}


def old_entries():
    path = os.path.join(OUT_DIR, "manifest.json")
    old = {}
    if os.path.exists(path):
        with open(path) as f:
            for e in json.load(f).get("references", []):
                old[os.path.basename(e["reference"])[: -len(".exr")]] = e
    return old


def update_manifest(entries):
    old = old_entries()
    for e in entries:
        old[os.path.basename(e["reference"])[: -len(".exr")]] = e
    order = {job_name(s, i): k for k, (s, i, _, _) in enumerate(JOBS)}
    refs = [old[k] for k in sorted(old, key=lambda k: order.get(k, len(order)))]
    doc = dict(MANIFEST_HEADER)
    doc["environment"] = {"mitsuba": mi.__version__, "drjit": drjit_version(), "numpy": np.__version__,
                          "variant": mi.variant(), "python": sys.version.split()[0]}
    doc["references"] = refs
    with open(os.path.join(OUT_DIR, "manifest.json"), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


def drjit_version():
    import drjit
    return drjit.__version__


# ---------------------------------------------------------------------------------------
# orientation check: textured quad + off-centre marker
# ---------------------------------------------------------------------------------------

def write_png_rgb(path, rows):
    """Minimal 8-bit RGB PNG writer (rows: list of lists of (r, g, b) bytes, top row first)."""
    import zlib
    h, w = len(rows), len(rows[0])
    raw = b"".join(b"\0" + bytes(c for px in row for c in px) for row in rows)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def srgb_to_linear(c):
    c = c / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def check_orientation(out_dir):
    """Renders a quad in the plane z = 0, x, y in [-1, 1], facing a camera at (0, 0, 3) on +Z
    that looks down -Z, with a 4x4 texture of four 2x2 colour blocks (top-left red, top-right
    green, bottom-left blue, bottom-right grey 128) mapped so that glTF uv (0, 0) (the image's
    top-left) is at the quad's top-left corner (-1, +1). An untextured yellow marker square sits
    at x, y in [-1.45, -1.15] x [1.15, 1.45] (world top-left, outside the quad). Lit by a
    constant environment of radiance 1 (each pixel's radiance = its albedo: open planes). The
    image must show the texture upright and the marker at the top-left."""
    os.makedirs(out_dir, exist_ok=True)
    R, G, B, Y = (255, 0, 0), (0, 255, 0), (0, 0, 255), (128, 128, 128)
    rows = [[R, R, G, G], [R, R, G, G], [B, B, Y, Y], [B, B, Y, Y]]
    write_png_rgb(os.path.join(out_dir, "check.png"), rows)
    pos = [[-1, 1, 0], [-1, -1, 0], [1, -1, 0], [1, 1, 0],
           [-1.45, 1.45, 0], [-1.45, 1.15, 0], [-1.15, 1.15, 0], [-1.15, 1.45, 0]]
    nrm = [[0, 0, 1]] * 8
    uv = [[0, 0], [0, 1], [1, 1], [1, 0]] + [[0, 0]] * 4
    idx = [0, 1, 2, 0, 2, 3] * 2
    blob = (b"".join(struct.pack("<3f", *p) for p in pos) + b"".join(struct.pack("<3f", *n) for n in nrm)
            + b"".join(struct.pack("<2f", *t) for t in uv) + struct.pack("<12H", *idx))
    doc = {
        "asset": {"version": "2.0"},
        "extras": {"strata": {"background": [1, 1, 1]}},
        "scene": 0, "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [{"camera": 0, "translation": [0, 0, 3]}, {"mesh": 0}, {"mesh": 1}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 2 * math.atan(1.5 / 3), "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]},
                   {"primitives": [{"attributes": {"POSITION": 4, "NORMAL": 5}, "indices": 6, "material": 1}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
                      {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 0, 1]}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9729, "wrapS": 33071, "wrapT": 33071}],
        "images": [{"uri": "check.png"}],
        "accessors": [
            {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 0, "byteOffset": 192, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 1, "byteOffset": 0, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 0, "byteOffset": 144, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "byteOffset": 12, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 256}, {"buffer": 0, "byteOffset": 256, "byteLength": 24}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    path = os.path.join(out_dir, "check.gltf")
    with open(path, "w") as f:
        json.dump(doc, f)
    res = 60  # the camera sees [-1.5, 1.5]^2: 20 pixels per world unit
    scene_dict, _ = convert(path, "shaded", (res, res), 2)
    mean, var = render_passes(scene_dict, 4096, 4, 0)
    write_exr(os.path.join(out_dir, "check.exr"), mean)

    def px(x, y):  # world (x, y) on the plane -> pixel (row, col), row 0 at the top
        return int((1.5 - y) * 20), int((x + 1.5) * 20)

    g128 = srgb_to_linear(128)
    expect = {"top-left of quad (red)": ((-0.5, 0.5), [1, 0, 0]),
              "top-right of quad (green)": ((0.5, 0.5), [0, 1, 0]),
              "bottom-left of quad (blue)": ((-0.5, -0.5), [0, 0, 1]),
              "bottom-right of quad (grey 128 -> %.4f)" % g128: ((0.5, -0.5), [g128] * 3),
              "marker, world top-left (yellow)": ((-1.3, 1.3), [1, 1, 0]),
              "background, world bottom-right (env 1)": ((1.3, -1.3), [1, 1, 1]),
              "background, world top-right (env 1)": ((1.3, 1.3), [1, 1, 1])}
    ok = True
    lines = []
    for what, ((x, y), rgb) in expect.items():
        r, c = px(x, y)
        got = mean[r, c]
        good = np.allclose(got, rgb, atol=0.02)
        ok &= bool(good)
        lines.append(f"{'ok  ' if good else 'FAIL'} {what}: pixel (row {r}, col {c}) = {np.round(got, 4).tolist()}, expected {np.round(rgb, 4).tolist()}")
    return ok, lines


def check_radiometry(out_dir):
    """A white (albedo 1) plane y = 0 lit by a point light of intensity pi x (1, 0.5, 0.25) at
    (0, 1, 0), seen by a camera at (0, 3, 0) looking straight down (image up = world -Z).
    Analytic radiance at (x, 0, z): (1/pi) * I * cos / d^2 = (1, 0.5, 0.25) * (1 + x^2 + z^2)^(-3/2).
    Two black (base colour 0) emissive quads at y = 0.01, emissiveFactor (0.2, 0.3, 0.4) with
    emissive strength 5: one facing up (front, counter-clockwise, toward the camera: radiance
    (1, 1.5, 2)) and one facing down (the camera sees its back: radiance 0)."""
    os.makedirs(out_dir, exist_ok=True)
    pos = [[-3, 0, 3], [3, 0, 3], [3, 0, -3], [-3, 0, -3],                       # plane, CCW from +Y
           [0.25, 0.01, -0.25], [0.4, 0.01, -0.25], [0.4, 0.01, -0.4], [0.25, 0.01, -0.4],  # up-facing
           [-0.4, 0.01, -0.25], [-0.4, 0.01, -0.4], [-0.25, 0.01, -0.4], [-0.25, 0.01, -0.25]]  # down-facing
    idx = [0, 1, 2, 0, 2, 3] * 3
    blob = b"".join(struct.pack("<3f", *p) for p in pos) + struct.pack("<18H", *idx)
    h = math.sqrt(0.5)
    doc = {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 0.5, 0.25], "intensity": math.pi}]}},
        "scene": 0, "scenes": [{"nodes": [0, 1, 2, 3, 4]}],
        "nodes": [{"camera": 0, "translation": [0, 3, 0], "rotation": [-h, 0, 0, h]}, {"mesh": 0}, {"mesh": 1}, {"mesh": 2},
                  {"translation": [0, 1, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.3, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 3, "material": 0}]},
                   {"primitives": [{"attributes": {"POSITION": 1}, "indices": 3, "material": 1}]},
                   {"primitives": [{"attributes": {"POSITION": 2}, "indices": 3, "material": 1}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1]}},
                      {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [0.2, 0.3, 0.4],
                       "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5}}}],
        "accessors": [
            {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "byteOffset": 0, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 144}, {"buffer": 0, "byteOffset": 144, "byteLength": 36}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    # Two renders: the plane and the light alone (Mitsuba then always picks the point light in
    # its uniform emitter selection, so the image is noise-free), and the full scene for the quads.
    n = 40
    images = []
    for name, nodes in (("radiometry-light", [0, 1, 4]), ("radiometry", [0, 1, 2, 3, 4])):
        doc["scenes"] = [{"nodes": nodes}]
        path = os.path.join(out_dir, name + ".gltf")
        with open(path, "w") as f:
            json.dump(doc, f)
        scene_dict, _ = convert(path, "shaded", (n, n), 2)
        mean, _ = render_passes(scene_dict, 256, 2, 0)
        write_exr(os.path.join(out_dir, name + ".exr"), mean)
        images.append(mean)
    t = math.tan(0.15) * 3
    lines, ok = [], True
    worst = 0.0
    for r in range(n):
        for c in range(n):
            x = ((c + 0.5) / n * 2 - 1) * t
            z = -(1 - (r + 0.5) / n * 2) * t
            e = np.array([1, 0.5, 0.25]) * (1 + x * x + z * z) ** -1.5
            worst = max(worst, float(np.max(np.abs(images[0][r, c] - e) / e)))
    good = worst < 2e-3
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} point light on a white plane: max relative error over {n * n} pixels "
                 f"vs (1/pi) I cos/d^2 = {worst:.2e}")
    mean = images[1]
    for what, (x, z), e in [("front of emissive quad", (0.325, -0.325), [1, 1.5, 2]),
                            ("back of emissive quad", (-0.325, -0.325), [0, 0, 0])]:
        c, r = int((x / t + 1) / 2 * n), int((1 + z / t) / 2 * n)
        good = np.allclose(mean[r, c], e, atol=1e-3)
        ok &= bool(good)
        lines.append(f"{'ok  ' if good else 'FAIL'} {what}: pixel (row {r}, col {c}) = {np.round(mean[r, c], 4).tolist()}, expected {e}")
    return ok, lines


def envmap_eval(emitter_dict, dirs):
    """Mitsuba's radiance of an environment emitter along world directions dirs (N, 3)."""
    emitter = mi.load_dict(emitter_dict)
    if mi.variant().startswith("scalar"):
        out = []
        for d in dirs:
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wi = mi.Vector3f(-d)
            out.append(np.array(emitter.eval(si), dtype=np.float64))
        return np.array(out)
    si = dr.zeros(mi.SurfaceInteraction3f, len(dirs))
    si.wi = mi.Vector3f(*(-dirs.T.astype(np.float32)))
    return np.array(emitter.eval(si), dtype=np.float64).T


def check_environment():
    """The envmap conversion against strata's lookup (strata_env_radiance, the formula of
    src/shading/envmap.rs): a 16 x 8 map of random colours (no symmetry to hide a turn or a
    mirror), 2000 random directions, rotations 0 and 30 degrees: Mitsuba's radiance must equal
    strata's to 1e-4 relative. Negative controls that must differ by more than 1%: to_world
    without the 90-degree turn, the rotation's sign flipped, the map given unresampled, and the
    map upside down."""
    rng = np.random.default_rng(29)
    texels = (rng.random((8, 16, 3)) + 0.05).astype(np.float32)
    dirs = rng.normal(size=(2000, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    lines, ok = [], True

    def error(emitter, rotate):
        want = strata_env_radiance(texels, rotate, dirs)
        return float(np.max(np.abs(envmap_eval(emitter, dirs) - want) / want))

    for rotate in (0.0, 30.0):
        env = {"rotate": rotate}
        e = error(envmap_dict(env, texels), rotate)
        good = e < 1e-4
        ok &= good
        lines.append(f"{'ok  ' if good else 'FAIL'} envmap = strata's lookup, rotation {rotate:g}: "
                     f"max relative difference {e:.1e} over {len(dirs)} directions")
        wrong = {
            "to_world without the 90-degree turn": dict(envmap_dict(env, texels), to_world=mi.ScalarTransform4f().rotate(
                [0.0, 1.0, 0.0], rotate)),
            "map not resampled": dict(envmap_dict(env, texels), bitmap=mi.Bitmap(texels, mi.Bitmap.PixelFormat.RGB)),
            "map upside down": envmap_dict(env, np.ascontiguousarray(texels[::-1])),
        }
        if rotate != 0:
            wrong["rotation sign flipped"] = envmap_dict({"rotate": -rotate}, texels)
        for what, emitter in wrong.items():
            e = error(emitter, rotate)
            good = e > 1e-2
            ok &= good
            lines.append(f"{'ok  ' if good else 'FAIL'} negative control, {what} (rotation {rotate:g}): "
                         f"max relative difference {e:.2f} (must exceed 0.01)")
    return ok, lines


def check_glass_refusals():
    """glass_props() converts glass alone and refuses what it cannot convert exactly: each
    material below must raise ConversionError naming it, and the plain glass must convert."""
    tr = {"KHR_materials_transmission": {"transmissionFactor": 1.0}}
    pbr = {"metallicFactor": 0.0, "roughnessFactor": 0.0}
    refused = {
        "half transmissive": {"pbrMetallicRoughness": pbr,
                              "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.5}}},
        "transmission texture": {"pbrMetallicRoughness": pbr, "extensions": {"KHR_materials_transmission": {
            "transmissionFactor": 1.0, "transmissionTexture": {"index": 0}}}},
        "metallic by default": {"pbrMetallicRoughness": {"roughnessFactor": 0.0}, "extensions": tr},
        "half metal": {"pbrMetallicRoughness": dict(pbr, metallicFactor=0.5), "extensions": tr},
        "textured roughness": {"pbrMetallicRoughness": dict(pbr, metallicRoughnessTexture={"index": 0}),
                               "extensions": tr},
        "ior 1": {"pbrMetallicRoughness": pbr, "extensions": dict(tr, KHR_materials_ior={"ior": 1.0})},
        "clearcoat": {"pbrMetallicRoughness": pbr, "extensions": dict(tr, KHR_materials_clearcoat={})},
        "black attenuation": {"pbrMetallicRoughness": pbr, "extensions": dict(tr, KHR_materials_volume={
            "thicknessFactor": 1.0, "attenuationColor": [0.5, 0.0, 0.5], "attenuationDistance": 1.0})},
    }
    lines, ok = [], True
    white = {"type": "rgb", "value": [1.0, 1.0, 1.0]}
    for name, mat in refused.items():
        try:
            glass_props(mat, name, white)
            good, why = False, "converted"
        except ConversionError as e:
            good, why = f"'{name}'" in str(e), str(e)
        ok &= good
        lines.append(f"{'ok  ' if good else 'FAIL'} glass refused, {name}: {why}")
    try:
        bsdf, medium, _ = glass_props({"pbrMetallicRoughness": pbr, "extensions": dict(tr, KHR_materials_volume={
            "thicknessFactor": 1.0, "attenuationColor": [0.5, 0.25, 1.0], "attenuationDistance": 2.0})}, "glass", white)
        sigma = np.array(medium["sigma_t"]["value"]) * medium["scale"]
        good = bsdf["type"] == "dielectric" and np.allclose(sigma, -np.log([0.5, 0.25, 1.0]) / 2.0)
    except ConversionError as e:
        good = False
        lines.append(str(e))
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} plain absorbing glass converts: dielectric, sigma_t = -ln(c)/d")
    return ok, lines


def check_coat_refusals():
    """coat_props() converts an untextured coat over the glTF BRDF and refuses what it cannot
    convert exactly: each material below must raise ConversionError naming it; the plain coats
    must convert (weight 0: the base alone; the control's f0 on request)."""
    pbr = {"baseColorFactor": [0.7, 0.06, 0.05, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5}
    cc = {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.3}

    def coated(coat=None, **extra):
        m = {"pbrMetallicRoughness": pbr, "extensions": {"KHR_materials_clearcoat": dict(cc, **(coat or {}))}}
        for k, v in extra.items():
            if k == "extensions":
                m["extensions"].update(v)
            else:
                m[k] = v
        return m

    refused = {
        "coat texture": coated({"clearcoatTexture": {"index": 0}}),
        "coat roughness texture": coated({"clearcoatRoughnessTexture": {"index": 0}}),
        "coat normal texture": coated({"clearcoatNormalTexture": {"index": 0}}),
        "base normal map": coated(normalTexture={"index": 0}),
        "coat and ior": coated(extensions={"KHR_materials_ior": {"ior": 1.4}}),
        "coat and sheen": coated(extensions={"KHR_materials_sheen": {"sheenColorFactor": [1, 1, 1]}}),
        "emissive coat": coated(emissiveFactor=[1.0, 0.5, 0.0]),
        "coat weight 2": coated({"clearcoatFactor": 2.0}),
    }
    lines, ok = [], True
    red = {"type": "rgb", "value": [0.7, 0.06, 0.05]}
    gltf_bsdf.register()
    for name, mat in refused.items():
        try:
            coat_props(None, mat, name, red, [])
            good, why = False, "converted"
        except ConversionError as e:
            good, why = f"'{name}'" in str(e), str(e)
        ok &= good
        lines.append(f"{'ok  ' if good else 'FAIL'} coat refused, {name}: {why}")
    try:
        bsdf, _, _ = coat_props(None, coated(), "coat", red, [])
        plain, _, _ = coat_props(None, coated({"clearcoatFactor": 0.0}), "no coat", red, [])
        control, _, _ = coat_props(None, coated(), "control", red, [], "f0-0.028")
        additive, _, _ = coat_props(None, coated(), "additive", red, [], "additive")
        good = (bsdf["type"] == coat_bsdf.PLUGIN_NAME and bsdf["clearcoat"] == 1.0
                and bsdf["clearcoat_roughness"] == 0.3 and "coat_f0" not in bsdf
                and bsdf["base"]["type"] == gltf_bsdf.PLUGIN_NAME and bsdf["base"]["roughness"] == 0.5
                and plain["type"] == gltf_bsdf.PLUGIN_NAME and control["coat_f0"] == 0.028
                and additive["attenuate_base"] is False and "attenuate_base" not in bsdf)
        mi.load_dict(bsdf)
    except ConversionError as e:
        good = False
        lines.append(str(e))
    ok &= good
    lines.append(f"{'ok  ' if good else 'FAIL'} plain coats convert: gltf_coated over gltf_metal_rough; weight 0 the "
                 "base alone; the controls' coat_f0 0.028 and attenuate_base false")
    return ok, lines


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("jobs", nargs="*", help="scene.integrator names (default: all)")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--spp", type=int, help="override the total spp (testing; not for committed references)")
    ap.add_argument("--resolution", metavar="WxH",
                    help="override every job's resolution (testing; not for committed references)")
    ap.add_argument("--out", help="output folder (default scenes/references; the manifest is only written there)")
    ap.add_argument("--manifest", metavar="JOBS.json",
                    help="make the references of this job manifest (e.g. tools/peers/hdri-races.json; see "
                         "load_job_manifest) instead of scenes/references/'s, into --out-dir")
    ap.add_argument("--out-dir", metavar="DIR",
                    help="output folder whose manifest.json is written (merged) like scenes/references/'s "
                         "(default: scenes/references, or with --manifest the file's out_dir); rows name files "
                         "outside the repository by absolute path")
    ap.add_argument("--no-manifest", action="store_true")
    ap.add_argument("--rebuild-manifest", action="store_true",
                    help="recompute the manifest entries of the jobs from the EXRs on disk, without rendering")
    ap.add_argument("--check", metavar="DIR", help="run the orientation and radiometry checks, writing into DIR")
    ap.add_argument("--materials", choices=sorted(MATERIAL_MODELS), default="lambertian",
                    help="material model of the shaded jobs (default lambertian; ao jobs are always white "
                         "diffuse): " + "; ".join(f"{k}: {v}" for k, v in MATERIAL_MODELS.items()))
    args = ap.parse_args()
    global OUT_DIR, COMMAND_OPTIONS, MANIFEST_HEADER
    if args.manifest:
        spec = load_job_manifest(args.manifest)
        COMMAND_OPTIONS = f"--manifest {args.manifest} "
        MANIFEST_HEADER = dict(MANIFEST_HEADER, description=spec["description"] + " " + MANIFEST_HEADER["description"],
                               regenerate_all=f"tools/references/make_references.sh --manifest {args.manifest} "
                                              "--materials gltf")
        if not args.out_dir:
            OUT_DIR = os.path.normpath(os.path.join(REPO, os.path.expanduser(spec["out_dir"])))
    if args.out_dir:
        OUT_DIR = os.path.abspath(os.path.expanduser(args.out_dir))
        COMMAND_OPTIONS += f"--out-dir {args.out_dir} "
    mi.set_variant(VARIANT)
    if args.check:
        ok1, lines1 = check_orientation(args.check)
        ok2, lines2 = check_radiometry(args.check)
        ok3, lines3 = check_environment()
        ok4, lines4 = check_glass_refusals()
        ok5, lines5 = check_coat_refusals()
        print("\n".join(lines1 + lines2 + lines3 + lines4 + lines5))
        ok = ok1 and ok2 and ok3 and ok4 and ok5
        print("checks:", "passed" if ok else "FAILED")
        return 0 if ok else 1
    if args.list:
        for s, i, spp, k in JOBS:
            print(job_name(s, i), spp, k)
        return 0
    if args.out:
        OUT_DIR = os.path.abspath(args.out)
    os.makedirs(OUT_DIR, exist_ok=True)
    wanted = set(args.jobs)
    known = {job_name(s, i) for s, i, _, _ in JOBS}
    if wanted - known:
        print(f"unknown jobs: {sorted(wanted - known)}; known: {sorted(known)}", file=sys.stderr)
        return 2
    if args.materials == "gltf" and mi.variant().startswith("scalar"):
        print("note: in scalar variants Mitsuba calls the glTF BRDF's Python code once per sample (about 50x "
              "slower than twosided(diffuse)); STRATA_MITSUBA_VARIANT=llvm_ad_rgb compiles it once", file=sys.stderr)
    write_manifest = not args.no_manifest and not args.out and not args.spp and not args.resolution
    if args.manifest or args.out_dir:
        # a manifest of its own: every row records its spp and resolution, so an override is
        # written down rather than passed off as the default (--out still writes none)
        write_manifest = not args.no_manifest and not args.out
        if OUT_DIR == os.path.join(REPO, "scenes", "references") and (args.spp or args.resolution):
            write_manifest = False  # never an override into the CI's manifest
    if args.resolution:
        w, h = (int(x) for x in args.resolution.lower().split("x"))
        for name, (rel, _) in SCENES.items():
            SCENES[name] = (rel, (w, h))
    for s, i, spp, k in JOBS:
        if wanted and job_name(s, i) not in wanted:
            continue
        spp = args.spp or spp
        if args.rebuild_manifest:
            entry = rebuild_entry(s, i, spp, k, old_entries().get(job_name(s, i)), args.materials)
        else:
            entry = run_job(s, i, spp, k, materials=args.materials)
        se = entry["standard_error"]
        print(f"{job_name(s, i)}: {entry['render_seconds']} s, mean {se['image_mean']:.4g}, "
              f"rel. s.e. mean {se['mean_relative_standard_error']:.2e} max {se['max_relative_standard_error']:.2e}",
              flush=True)
        if write_manifest:  # after each job, so an interrupted run keeps what it finished
            update_manifest([entry])
    return 0


if __name__ == "__main__":
    sys.exit(main())
