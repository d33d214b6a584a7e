#!/usr/bin/env python3
"""Writes a copy of a glTF file in another folder, optionally with its textures' images
replaced by WebP (EXT_texture_webp) or KTX2 (KHR_texture_basisu) images made by other tools.

The copy references the original's buffers and remaining images by relative URI (rewritten
to stay valid from the copy's folder), so large binaries are not duplicated. Only the JSON is
written here: the new images are made by the reference encoders (cwebp, basisu), see
tools/scenes/make_compressed.sh. Usage:

    gltf_variant.py IN.gltf OUT.gltf                         # a relocated copy
    gltf_variant.py IN.gltf OUT.gltf --images-from DIR       # images: DIR's files of those names
    gltf_variant.py IN.gltf OUT.gltf --extension KHR_texture_basisu \
        --image 0=dir/base.ktx2 --image 1=dir/mr.ktx2 [--fallback] [--glb OUT.glb]

--image I=PATH: texture I's image becomes PATH (relative to OUT's folder); with --fallback the
texture keeps its core `source` (the original image) as the fallback and the extension is
only in extensionsUsed, without it the core `source` is removed and the extension is also in
extensionsRequired. --glb writes a binary glTF instead of OUT.gltf whose new images are
embedded (bufferViews of the binary chunk; the original buffers stay external).
"""
import argparse
import json
import os
import posixpath
import struct

MIME = {".webp": "image/webp", ".ktx2": "image/ktx2"}


def relocate(uri, src_dir, dst_dir):
    if uri.startswith("data:"):
        return uri
    path = os.path.normpath(os.path.join(src_dir, uri))
    return posixpath.join(*os.path.relpath(path, dst_dir).split(os.sep))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--extension", choices=["EXT_texture_webp", "KHR_texture_basisu"])
    ap.add_argument("--image", action="append", default=[], metavar="I=PATH")
    ap.add_argument("--fallback", action="store_true")
    ap.add_argument("--glb", action="store_true", help="write OUT as binary glTF, new images embedded")
    ap.add_argument("--images-from", metavar="DIR",
                    help="point every image URI at the file of the same name in DIR instead")
    args = ap.parse_args()

    with open(args.input) as f:
        doc = json.load(f)
    src_dir = os.path.dirname(os.path.abspath(args.input))
    dst_dir = os.path.dirname(os.path.abspath(args.output))
    for item in doc.get("buffers", []) + doc.get("images", []):
        if "uri" in item:
            item["uri"] = relocate(item["uri"], src_dir, dst_dir)
    if args.images_from:
        for image in doc.get("images", []):
            if "uri" in image:
                name = posixpath.basename(image["uri"])
                image["uri"] = relocate(os.path.abspath(os.path.join(args.images_from, name)), dst_dir, dst_dir)

    blob = bytearray()
    if args.extension:
        for spec in args.image:
            index, path = spec.split("=", 1)
            texture = doc["textures"][int(index)]
            image = {"mimeType": MIME[os.path.splitext(path)[1]]}
            if args.glb:
                with open(os.path.join(dst_dir, path), "rb") as f:
                    data = f.read()
                while len(blob) % 4:
                    blob.append(0)
                doc.setdefault("bufferViews", []).append(
                    {"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)}
                )
                blob.extend(data)
                image["bufferView"] = len(doc["bufferViews"]) - 1
            else:
                image["uri"] = path
            doc["images"].append(image)
            texture.setdefault("extensions", {})[args.extension] = {"source": len(doc["images"]) - 1}
            if not args.fallback:
                del texture["source"]
        used = doc.setdefault("extensionsUsed", [])
        if args.extension not in used:
            used.append(args.extension)
        if not args.fallback:
            required = doc.setdefault("extensionsRequired", [])
            if args.extension not in required:
                required.append(args.extension)
        if not args.fallback:
            # Images no texture uses any more (the replaced originals) are dropped.
            kept = sorted({t["source"] for t in doc["textures"] if "source" in t}
                          | {e["source"] for t in doc["textures"]
                             for e in t.get("extensions", {}).values() if "source" in e})
            new_index = {old: new for new, old in enumerate(kept)}
            doc["images"] = [doc["images"][i] for i in kept]
            for t in doc["textures"]:
                if "source" in t:
                    t["source"] = new_index[t["source"]]
                for e in t.get("extensions", {}).values():
                    if "source" in e:
                        e["source"] = new_index[e["source"]]

    if args.glb:
        # Buffer 0 is the binary chunk; the file's own buffers move up by one (the new
        # images' views, appended last, already name buffer 0).
        n_new = sum(1 for i in doc["images"] if "bufferView" in i)
        old_views = len(doc["bufferViews"]) - n_new
        for k, view in enumerate(doc["bufferViews"]):
            if k < old_views:
                view["buffer"] += 1
        doc["buffers"] = [{"byteLength": len(blob)}] + doc.get("buffers", [])
        while len(blob) % 4:
            blob.append(0)
        text = json.dumps(doc, indent=1).encode()
        while len(text) % 4:
            text += b" "
        total = 12 + 8 + len(text) + 8 + len(blob)
        with open(args.output, "wb") as f:
            f.write(struct.pack("<4sII", b"glTF", 2, total))
            f.write(struct.pack("<I4s", len(text), b"JSON") + text)
            f.write(struct.pack("<I4s", len(blob), b"BIN\0") + bytes(blob))
    else:
        with open(args.output, "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
