#!/usr/bin/env python3
"""SHA-256 of a glTF scene and every file it references (standard library only).

Algorithm (also recorded as `hash_algorithm` in scenes/references/manifest.json):

1. Files: the scene file itself, plus every `buffers[].uri` and `images[].uri` of its JSON
   (for a .glb, of its JSON chunk) that is not a `data:` URI. Each URI is percent-decoded
   and resolved relative to the scene file's directory.
2. Each file's path is written relative to the repository root, with `/` separators and
   no `.` or `..` components (normalised). Duplicates are dropped.
3. The paths are sorted by their UTF-8 bytes (bytewise, ascending).
4. For each file in that order, the line  PATH + "\\0" + lowercase hex SHA-256 of the file's
   bytes + "\\n"  is appended to one byte string (UTF-8).
5. The scene hash is the lowercase hex SHA-256 of that byte string.

    python3 tools/references/scene_hash.py SCENE.gltf [...]   # prints "HASH  SCENE" lines
"""
import hashlib
import json
import os
import posixpath
import struct
import sys
import urllib.parse

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

ALGORITHM = (
    "sha256 over lines PATH + '\\0' + sha256hex(file bytes) + '\\n' (UTF-8), one per file, files "
    "sorted bytewise by PATH; files = the scene file plus every non-'data:' buffers[].uri and "
    "images[].uri of its glTF JSON (GLB: of its JSON chunk), percent-decoded and resolved "
    "relative to the scene file's directory; PATH = the file's path relative to the repository "
    "root, '/'-separated, normalised (no '.' or '..'), duplicates removed; hex digests lowercase. "
    "Implemented by tools/references/scene_hash.py."
)


def gltf_json(path):
    """The glTF document of a .gltf, or of a .glb (its first chunk, JSON)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        clen, ctype = struct.unpack_from("<II", data, 12)
        if ctype != 0x4E4F534A:
            raise ValueError(f"{path}: first GLB chunk is not JSON")
        return json.loads(data[20:20 + clen].decode("utf-8"))
    return json.loads(data.decode("utf-8"))


def scene_files(scene, repo=REPO):
    """Sorted repo-relative POSIX paths of the scene and the files it references."""
    scene = os.path.abspath(scene)
    doc = gltf_json(scene)
    base = os.path.dirname(scene)
    files = {scene}
    for item in doc.get("buffers", []) + doc.get("images", []):
        uri = item.get("uri")
        if uri and not uri.startswith("data:"):
            files.add(os.path.normpath(os.path.join(base, urllib.parse.unquote(uri))))
    rel = set()
    for f in files:
        r = os.path.relpath(f, repo).replace(os.sep, "/")
        r = posixpath.normpath(r)
        if r.startswith("../"):
            raise ValueError(f"{f} is outside the repository {repo}")
        rel.add(r)
    return sorted(rel, key=lambda p: p.encode("utf-8"))


def scene_sha256(scene, repo=REPO):
    lines = bytearray()
    for r in scene_files(scene, repo):
        with open(os.path.join(repo, r), "rb") as f:
            digest = hashlib.sha256(f.read()).hexdigest()
        lines += r.encode("utf-8") + b"\0" + digest.encode("ascii") + b"\n"
    return hashlib.sha256(bytes(lines)).hexdigest()


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    for s in sys.argv[1:]:
        print(f"{scene_sha256(s)}  {s}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
