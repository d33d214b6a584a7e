#!/usr/bin/env python3
"""Edits a camera wrapper .gltf (written by add_camera.py) in place, for reference scenes.

    edit_wrapper.py FILE.gltf [--single-sided-emitters] [--background R,G,B]

--single-sided-emitters  sets `doubleSided: false` on every material that emits (non-zero
                         emissiveFactor), so that it emits from its counter-clockwise (front)
                         face only; the original flag is kept in the material's
                         `extras.strata_original_doubleSided`. Reference renderers refuse
                         double-sided emitters (Mitsuba's area emitter is one-sided).
--background R,G,B       records a constant environment of that linear RGB radiance in the
                         document's `extras.strata.background` (black when absent).

Standard library only; stable output (indent=1).
"""
import argparse
import json


def rgb(text):
    v = [float(x) for x in text.split(",")]
    if len(v) != 3:
        raise argparse.ArgumentTypeError("expected R,G,B")
    return v


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file")
    ap.add_argument("--single-sided-emitters", action="store_true")
    ap.add_argument("--background", type=rgb)
    args = ap.parse_args()

    with open(args.file) as f:
        doc = json.load(f)
    if args.single_sided_emitters:
        for m in doc.get("materials", []):
            if any(c != 0 for c in m.get("emissiveFactor", [0, 0, 0])):
                m.setdefault("extras", {})["strata_original_doubleSided"] = m.get("doubleSided", False)
                m["doubleSided"] = False
    if args.background is not None:
        doc.setdefault("extras", {}).setdefault("strata", {})["background"] = args.background
    with open(args.file, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
