#!/usr/bin/env bash
# tools/ci/embree4-prefix.sh -- assemble an Embree 4 "prefix" for CI without
# building Embree from source (Debian 12 only packages Embree 3.13.5).
#
# Usage: tools/ci/embree4-prefix.sh DEST [--no-smoke] [--force] [--check]
#
#   DEST        where the prefix goes, e.g. "$HOME/.cache/strata/embree4"
#   --no-smoke  do not compile/run the C smoke test after building the prefix
#   --force     rebuild even if DEST already holds a complete prefix
#   --check     on a cache hit, still run the smoke test (default: exit at once)
#
# Result:
#   DEST/include/embree4/rtcore*.h    Embree 4 C headers (see "ABI patch" below)
#   DEST/lib/libembree4-4aef3270.so.4 the wheel's Embree 4.4.0 (SONAME as-is)
#   DEST/lib/libtbb-dcf63f8c.so.12    the wheel's oneTBB 2021.12 (NEEDED by it)
#   DEST/lib/libembree4.so            -> libembree4-4aef3270.so.4 (for -lembree4)
#   DEST/lib/libembree4.so.4          -> libembree4-4aef3270.so.4 (convenience)
#   DEST/VERSION                      one line: header + binary versions
#   DEST/.embree4-prefix.stamp        pinned inputs; used for the cache check
#
# Consumers: compile with -I DEST/include, link with -L DEST/lib -lembree4, run
# with LD_LIBRARY_PATH=DEST/lib (binaries record NEEDED libembree4-4aef3270.so.4;
# that library finds its TBB through its own RPATH $ORIGIN). The script prints
# a ready-to-eval block of exports at the end.
#
# Sources (ordinary clients only: cargo and pip; no URLs):
#   headers: crates.io crate embree4-sys, fetched with `cargo fetch` from a
#            throw-away manifest, then unpacked from the cargo registry cache
#            (the headers live in the crate at lib/embree4/).
#   binary : PyPI wheel embreex (manylinux_2_28, cp311), `pip download`ed
#            (hash-pinned), then unzipped; the libraries are in embreex.libs/.
#
# Why these versions go together
# ------------------------------
# * embreex 4.4.0.post1 is the newest embreex. Its wheel bundles Embree 4.4.0
#   (rtcGetDeviceProperty(VERSION) == 40400, build e794a4799e1e) linked against
#   a bundled oneTBB 2021.12, built with RTC_MAX_INSTANCE_LEVEL_COUNT=1, ray masks
#   and filter functions on, min-width off, and EMBREE_GEOMETRY_INSTANCE_ARRAY on.
# * embree4-sys 0.0.12 is the newest embree4-sys; every embree4-sys release
#   (0.0.1 .. 0.0.12) ships Embree 4.2.0 headers (RTC_VERSION 40200). No 4.3 or
#   4.4 headers can be had through crates.io, PyPI or Debian 12, so the
#   same-minor pairing is impossible; 4.2.0 is the closest.
# * Embree 4.x keeps its C API/ABI backward compatible across minor releases:
#   4.3 and 4.4 only append functions and enum values. Every non-inline function
#   the 4.2.0 headers declare is exported by the 4.4.0 library (checked below).
#   The one exception is build-configuration dependent: since 4.3, with
#   RTC_GEOMETRY_INSTANCE_ARRAY defined, the public structs RTCHit, RTCHit4/8/16
#   (and RTCHitNt), RTCRayQueryContext and RTCPointQueryContext carry an extra
#   instPrimID[RTC_MAX_INSTANCE_LEVEL_COUNT] member. This wheel's library is
#   built that way, so with the unpatched 4.2.0 headers sizeof(RTCRayHit) is 80
#   while rtcIntersect1 writes 84 bytes (instPrimID at offset 80): a 4-byte
#   overrun of every caller's RTCRayHit (verified with a canary).
# * ABI patch: the script therefore defines RTC_GEOMETRY_INSTANCE_ARRAY in
#   rtcore_config.h and adds the instPrimID members exactly as upstream 4.3/4.4
#   headers do (sizeof(RTCRayHit) becomes 96). The smoke test checks with
#   canaries that the library neither writes past RTCRayHit nor reads past
#   RTCRayQueryContext. RTC_VERSION stays 40200: the API surface is 4.2's; the
#   4.3/4.4-only API (instance arrays, rtcForward*Ex, rtcTraversable*, host/device
#   buffers, RTC_FORMAT_QUATERNION_DECOMPOSITION enum value, ...) is not declared.
#   Only the C headers (*.h) are installed; the ISPC headers (*.isph) are not.
# Bumping either pin means re-checking all of the above (and the sha256 pins).
set -Eeuo pipefail

# ---- pins -------------------------------------------------------------------
EMBREE4_SYS_VERSION=0.0.12
EMBREE4_SYS_SHA256=a1c23ca437f91a52068a03088b80395115c87a669874e54120f4552f1bedaf67
HEADER_RTC_VERSION=40200                 # RTC_VERSION in that crate's rtcore_config.h

EMBREEX_VERSION=4.4.0.post1
EMBREEX_PY_VERSION=3.11                  # wheel picked explicitly, whatever python3 is
EMBREEX_ABI=cp311
EMBREEX_PLATFORM=manylinux_2_28_x86_64
EMBREEX_WHEEL_SHA256=2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f
EMBREE_SONAME=libembree4-4aef3270.so.4   # auditwheel-renamed names inside that wheel
TBB_SONAME=libtbb-dcf63f8c.so.12
BINARY_RTC_VERSION=40400                 # rtcGetDeviceProperty(RTC_DEVICE_PROPERTY_VERSION)

ABI_PATCH_REV=1                          # bump when the header patch below changes
HEADERS=(rtcore.h rtcore_buffer.h rtcore_builder.h rtcore_common.h rtcore_config.h
         rtcore_device.h rtcore_geometry.h rtcore_quaternion.h rtcore_ray.h rtcore_scene.h)

STAMP_NAME=.embree4-prefix.stamp
STAMP="embree4-prefix stamp v1
embree4-sys=${EMBREE4_SYS_VERSION} sha256=${EMBREE4_SYS_SHA256} rtc=${HEADER_RTC_VERSION}
embreex=${EMBREEX_VERSION} wheel=${EMBREEX_ABI}-${EMBREEX_PLATFORM} sha256=${EMBREEX_WHEEL_SHA256} rtc=${BINARY_RTC_VERSION}
libs=${EMBREE_SONAME},${TBB_SONAME}
abi-patch=${ABI_PATCH_REV}"

# ---- helpers ----------------------------------------------------------------
PROG=embree4-prefix
log() { printf '[%s] %s\n' "$PROG" "$*"; }
die() { printf '[%s] ERROR: %s\n' "$PROG" "$*" >&2; exit 1; }

CURRENT_STEP="startup"
on_err() {
  local rc=$? line=$1 cmd=${2%%$'\n'*}
  printf '[%s] ERROR: step "%s" failed (exit %s) at line %s: %s\n' \
    "$PROG" "$CURRENT_STEP" "$rc" "$line" "$cmd" >&2
  exit "$rc"
}
trap 'on_err "$LINENO" "$BASH_COMMAND"' ERR

now() { printf '%s' "${EPOCHREALTIME:-$SECONDS}"; }
T_START=$(now)
T_STEP=$T_START
step() {  # step "description": closes the previous step (printing its time), opens a new one
  step_done
  CURRENT_STEP=$1
  T_STEP=$(now)
  log "==> $CURRENT_STEP"
}
step_done() {
  if [[ $CURRENT_STEP != startup ]]; then
    log "    done: $CURRENT_STEP ($(elapsed "$T_STEP")s)"
  fi
}
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.2f", b - a }'; }

usage() { sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; }

# ---- arguments --------------------------------------------------------------
DEST=""
SMOKE=1
FORCE=0
CHECK=0
for arg in "$@"; do
  case $arg in
    --no-smoke) SMOKE=0 ;;
    --force) FORCE=1 ;;
    --check) CHECK=1 ;;
    -h|--help) usage; exit 0 ;;
    -*) usage >&2; die "unknown option: $arg" ;;
    *) [[ -z $DEST ]] || die "more than one DEST given: '$DEST' and '$arg'"; DEST=$arg ;;
  esac
done
[[ -n $DEST ]] || { usage >&2; die "missing DEST argument"; }
DEST=$(realpath -m -- "$DEST")
[[ $DEST != / ]] || die "refusing DEST=/"

print_env() {
  log "consumer environment (eval-able):"
  cat <<EOF
export EMBREE4_PREFIX='$DEST'
export CPATH='$DEST/include'\${CPATH:+:\$CPATH}
export LIBRARY_PATH='$DEST/lib'\${LIBRARY_PATH:+:\$LIBRARY_PATH}
export LD_LIBRARY_PATH='$DEST/lib'\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}
EOF
}

dest_replaceable() {  # only ever replace DEST if it is absent, empty, or made by this script
  [[ ! -e $DEST && ! -L $DEST ]] && return 0
  [[ -d $DEST && ! -L $DEST ]] || return 1
  [[ -z $(ls -A -- "$DEST") || -f $DEST/$STAMP_NAME || -f $DEST/VERSION ]]
}

prefix_complete() {  # prefix_complete DIR: all files present and stamp matches the pins
  local d=$1 h
  [[ -f $d/$STAMP_NAME && "$(cat "$d/$STAMP_NAME")" == "$STAMP" ]] || return 1
  [[ -s $d/VERSION ]] || return 1
  for h in "${HEADERS[@]}"; do [[ -s $d/include/embree4/$h ]] || return 1; done
  [[ -s $d/lib/$EMBREE_SONAME && -s $d/lib/$TBB_SONAME ]] || return 1
  [[ -L $d/lib/libembree4.so && -e $d/lib/libembree4.so ]] || return 1
  return 0
}

# ---- the smoke test (C, Embree 4 API) ------------------------------------------
write_smoke_c() {
  cat >"$1" <<'EOF'
/* Embree 4 smoke test written by tools/ci/embree4-prefix.sh. */
#include <embree4/rtcore.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;
#define CHECK(cond, ...) do { if (!(cond)) { failures++; printf("FAIL: " __VA_ARGS__); printf("\n"); } } while (0)
#define NEAR(a, b) (fabsf((float)(a) - (float)(b)) <= 1e-6f)
#define CANARY 0x5A5A5A5Au      /* after the RTCRayHit */
#define CTX_CANARY 0xC3C3C3C3u  /* after the RTCRayQueryContext */

static void on_error(void* user, enum RTCError code, const char* msg) {
  (void)user;
  failures++;
  printf("FAIL: embree error %d: %s\n", (int)code, msg ? msg : "(null)");
}

static void init_ray(struct RTCRayHit* rh, float ox, float oy, float oz, unsigned int mask) {
  memset(rh, 0, sizeof *rh);
  rh->ray.org_x = ox; rh->ray.org_y = oy; rh->ray.org_z = oz;
  rh->ray.dir_x = 0.f; rh->ray.dir_y = 0.f; rh->ray.dir_z = -1.f;
  rh->ray.tnear = 0.f;
  rh->ray.tfar = INFINITY;
  rh->ray.mask = mask;              /* Embree 4 enables ray masks by default */
  rh->ray.flags = 0;
  rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh->hit.primID = RTC_INVALID_GEOMETRY_ID;
}

static int canary_ok(const unsigned int* c, size_t n, unsigned int value) {
  for (size_t i = 0; i < n; i++) if (c[i] != value) return 0;
  return 1;
}

int main(void) {
  printf("headers : Embree %s (RTC_VERSION %d)", RTC_VERSION_STRING, RTC_VERSION);
#if defined(RTC_GEOMETRY_INSTANCE_ARRAY)
  printf(", RTC_GEOMETRY_INSTANCE_ARRAY");
#endif
  printf(", RTC_MAX_INSTANCE_LEVEL_COUNT=%d, sizeof(RTCRayHit)=%zu\n",
         RTC_MAX_INSTANCE_LEVEL_COUNT, sizeof(struct RTCRayHit));

  RTCDevice device = rtcNewDevice(NULL);
  if (!device) { printf("FAIL: rtcNewDevice returned NULL\n"); return 1; }
  rtcSetDeviceErrorFunction(device, on_error, NULL);
  ssize_t ver = rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION);
  printf("library : Embree %zd.%zd.%zd (RTC_DEVICE_PROPERTY_VERSION = %zd), ray masks %s\n",
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MAJOR),
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MINOR),
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_PATCH), ver,
         rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED) ? "on" : "off");
  CHECK(ver / 10000 == 4, "library major version is %zd, expected 4", ver / 10000);
  CHECK(ver >= RTC_VERSION, "library %zd is older than headers %d", ver, RTC_VERSION);

  /* one triangle (0,0,0) (1,0,0) (0,1,0) */
  RTCScene scene = rtcNewScene(device);
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  float* v = (float*)rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                             3 * sizeof(float), 3);
  unsigned int* idx = (unsigned int*)rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned int), 1);
  if (!v || !idx) { printf("FAIL: rtcSetNewGeometryBuffer returned NULL\n"); return 1; }
  const float tri[9] = { 0.f, 0.f, 0.f,  1.f, 0.f, 0.f,  0.f, 1.f, 0.f };
  memcpy(v, tri, sizeof tri);
  idx[0] = 0; idx[1] = 1; idx[2] = 2;
  rtcCommitGeometry(geom);
  unsigned int geomID = rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);

  /* 1: the requested ray, Embree 4 call form rtcIntersect1(scene, &rayhit, NULL).
        The RTCRayHit is followed by canaries: the library must not write past it. */
  struct { struct RTCRayHit rh; unsigned int canary[16]; } a;
  memset(a.canary, 0x5A, sizeof a.canary);
  init_ray(&a.rh, 0.25f, 0.25f, 1.f, 0xFFFFFFFFu);
  rtcIntersect1(scene, &a.rh, NULL);
  printf("hit     : tfar=%.9g u=%.9g v=%.9g primID=%u geomID=%u instID=%d Ng=(%g,%g,%g)\n",
         a.rh.ray.tfar, a.rh.hit.u, a.rh.hit.v, a.rh.hit.primID, a.rh.hit.geomID,
         (int)a.rh.hit.instID[0], a.rh.hit.Ng_x, a.rh.hit.Ng_y, a.rh.hit.Ng_z);
  CHECK(NEAR(a.rh.ray.tfar, 1.f), "tfar = %.9g, expected 1", a.rh.ray.tfar);
  CHECK(NEAR(a.rh.hit.u, 0.25f), "u = %.9g, expected 0.25", a.rh.hit.u);
  CHECK(NEAR(a.rh.hit.v, 0.25f), "v = %.9g, expected 0.25", a.rh.hit.v);
  CHECK(a.rh.hit.primID == 0, "primID = %u, expected 0", a.rh.hit.primID);
  CHECK(a.rh.hit.geomID == geomID, "geomID = %u, expected %u", a.rh.hit.geomID, geomID);
  CHECK(a.rh.hit.instID[0] == RTC_INVALID_GEOMETRY_ID, "instID[0] = %u, expected invalid", a.rh.hit.instID[0]);
#if defined(RTC_GEOMETRY_INSTANCE_ARRAY)
  CHECK(a.rh.hit.instPrimID[0] == RTC_INVALID_GEOMETRY_ID, "instPrimID[0] = %u, expected invalid",
        a.rh.hit.instPrimID[0]);
#endif
  CHECK(canary_ok(a.canary, 16, CANARY), "library wrote past the end of RTCRayHit (%zu bytes): header/library ABI mismatch",
        sizeof(struct RTCRayHit));

  /* 2: same ray with explicit RTCIntersectArguments and RTCRayQueryContext, the context
        followed by canaries: the library must not read past it (it copies the context's
        instance stack into the hit). */
  struct { struct RTCRayQueryContext ctx; unsigned int canary[16]; } c;
  memset(c.canary, 0xC3, sizeof c.canary);
  rtcInitRayQueryContext(&c.ctx);
  struct RTCIntersectArguments args;
  rtcInitIntersectArguments(&args);
  args.context = &c.ctx;
  init_ray(&a.rh, 0.25f, 0.25f, 1.f, 0xFFFFFFFFu);
  memset(a.canary, 0x5A, sizeof a.canary);
  rtcIntersect1(scene, &a.rh, &args);
  CHECK(a.rh.hit.geomID == geomID && NEAR(a.rh.ray.tfar, 1.f), "hit with explicit arguments missing");
  CHECK(a.rh.hit.instID[0] == RTC_INVALID_GEOMETRY_ID, "instID[0] = 0x%x with explicit context", a.rh.hit.instID[0]);
  {
    const unsigned int* words = (const unsigned int*)&a.rh.hit;
    for (size_t i = 0; i < sizeof(struct RTCHit) / sizeof(unsigned int); i++)
      CHECK(words[i] != CTX_CANARY, "hit word %zu = 0x%x came from past the end of RTCRayQueryContext: ABI mismatch",
            i, words[i]);
  }
  CHECK(canary_ok(a.canary, 16, CANARY), "library wrote past the end of RTCRayHit (explicit arguments)");
  CHECK(canary_ok(c.canary, 16, CTX_CANARY), "library wrote past the end of RTCRayQueryContext");

  /* 3: a ray that misses */
  init_ray(&a.rh, 2.f, 2.f, 1.f, 0xFFFFFFFFu);
  rtcIntersect1(scene, &a.rh, NULL);
  CHECK(a.rh.hit.geomID == RTC_INVALID_GEOMETRY_ID, "ray at (2,2) should miss, got geomID %u", a.rh.hit.geomID);

  /* 4: ray mask 0 must be culled (masks are on in Embree 4) */
  init_ray(&a.rh, 0.25f, 0.25f, 1.f, 0u);
  rtcIntersect1(scene, &a.rh, NULL);
  CHECK(a.rh.hit.geomID == RTC_INVALID_GEOMETRY_ID, "ray with mask 0 should be culled, got geomID %u",
        a.rh.hit.geomID);

  /* 5: occlusion ray: tfar becomes -inf on a hit */
  struct RTCRay ray;
  memset(&ray, 0, sizeof ray);
  ray.org_x = 0.25f; ray.org_y = 0.25f; ray.org_z = 1.f; ray.dir_z = -1.f;
  ray.tnear = 0.f; ray.tfar = INFINITY; ray.mask = 0xFFFFFFFFu;
  rtcOccluded1(scene, &ray, NULL);
  CHECK(isinf(ray.tfar) && ray.tfar < 0, "rtcOccluded1: tfar = %g, expected -inf", ray.tfar);

  enum RTCError err = rtcGetDeviceError(device);
  CHECK(err == RTC_ERROR_NONE, "rtcGetDeviceError = %d", (int)err);
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);

  if (failures) { printf("SMOKE FAILED: %d check(s) failed\n", failures); return 1; }
  printf("SMOKE OK\n");
  return 0;
}
EOF
}

run_smoke() {  # run_smoke PREFIX WORKDIR
  local p=$1 w=$2 cc=${CC:-gcc}
  command -v "$cc" >/dev/null || die "smoke test needs a C compiler ('$cc' not found; set CC or pass --no-smoke)"
  write_smoke_c "$w/embree4-smoke.c"
  log "compile: $cc -I $p/include -L $p/lib -lembree4"
  "$cc" -std=c11 -O2 -Wall -Wextra -I "$p/include" "$w/embree4-smoke.c" -o "$w/embree4-smoke" \
    -L "$p/lib" -lembree4 -lm \
    || die "smoke test failed to compile/link against $p"
  log "smoke binary NEEDED: $(readelf -d "$w/embree4-smoke" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p' | tr '\n' ' ')"
  log "run: LD_LIBRARY_PATH=$p/lib $w/embree4-smoke"
  local out rc=0
  out=$(LD_LIBRARY_PATH="$p/lib" "$w/embree4-smoke" 2>&1) || rc=$?
  printf '%s\n' "$out" | sed 's/^/    | /'
  [[ $rc -eq 0 ]] || return 1
  grep -q '^SMOKE OK$' <<<"$out" || return 1
}

# ---- lock + cache check -----------------------------------------------------
mkdir -p -- "$(dirname -- "$DEST")"
if command -v flock >/dev/null; then
  exec 9>"$DEST.lock"
  flock 9
fi

if [[ $FORCE -eq 0 ]] && prefix_complete "$DEST"; then
  log "cache hit: $DEST already holds a complete prefix ($(elapsed "$T_START")s)"
  log "VERSION: $(cat "$DEST/VERSION")"
  if [[ $CHECK -eq 1 ]]; then
    WORK=$(mktemp -d "${TMPDIR:-/tmp}/embree4-prefix.XXXXXX")
    trap 'rm -rf -- "$WORK"' EXIT
    step "smoke test (--check)"
    run_smoke "$DEST" "$WORK" || die "smoke test FAILED against cached prefix $DEST (re-run with --force)"
    step_done
  fi
  print_env
  exit 0
fi
dest_replaceable || die "$DEST exists and does not look like an embree4 prefix; refusing to replace it"
[[ $FORCE -eq 1 ]] && log "--force: rebuilding $DEST" || log "no complete prefix at $DEST: building it"

# ---- build ------------------------------------------------------------------
step "check tools"
for t in cargo python3 tar readelf sha256sum ldd; do
  command -v "$t" >/dev/null || die "required tool not found: $t"
done
python3 -m pip --version >/dev/null 2>&1 || die "python3 has no pip module (python3 -m pip)"
log "cargo: $(cargo --version); pip: $(python3 -m pip --version | cut -d' ' -f1-2)"

WORK=$(mktemp -d "${TMPDIR:-/tmp}/embree4-prefix.XXXXXX")
STAGE="$DEST.partial.$$"
cleanup() { rm -rf -- "$WORK" "$STAGE"; }
trap cleanup EXIT

step "headers: embree4-sys $EMBREE4_SYS_VERSION from crates.io (cargo)"
CARGO_HOME=${CARGO_HOME:-$HOME/.cargo}
find_crate() {  # prints the cached .crate whose sha256 matches the pin
  local f
  while IFS= read -r f; do
    if [[ $(sha256sum "$f" | cut -d' ' -f1) == "$EMBREE4_SYS_SHA256" ]]; then printf '%s\n' "$f"; return 0; fi
  done < <(find "$CARGO_HOME/registry/cache" -name "embree4-sys-$EMBREE4_SYS_VERSION.crate" 2>/dev/null)
  return 1
}
if CRATE=$(find_crate); then
  log "already in the cargo cache: $CRATE"
else
  mkdir -p "$WORK/cargo-probe/src"
  : >"$WORK/cargo-probe/src/lib.rs"
  cat >"$WORK/cargo-probe/Cargo.toml" <<EOF
[package]
name = "embree4-prefix-probe"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
embree4-sys = "=$EMBREE4_SYS_VERSION"

[workspace]
EOF
  log "cargo fetch (throw-away manifest, nothing is built)"
  if ! cargo fetch --manifest-path "$WORK/cargo-probe/Cargo.toml" --target x86_64-unknown-linux-gnu 2>&1 \
      | sed 's/^/    | /'; then
    die "cargo fetch of embree4-sys $EMBREE4_SYS_VERSION failed"
  fi
  CRATE=$(find_crate) || die "embree4-sys-$EMBREE4_SYS_VERSION.crate with sha256 $EMBREE4_SYS_SHA256 not found under $CARGO_HOME/registry/cache after cargo fetch"
fi
log "crate: $CRATE (sha256 $EMBREE4_SYS_SHA256 OK)"
tar -xzf "$CRATE" -C "$WORK" "embree4-sys-$EMBREE4_SYS_VERSION/lib/embree4" \
  || die "could not unpack lib/embree4 from $CRATE"
HDR_SRC="$WORK/embree4-sys-$EMBREE4_SYS_VERSION/lib/embree4"
for h in "${HEADERS[@]}"; do [[ -s $HDR_SRC/$h ]] || die "header $h missing from the crate (lib/embree4/)"; done
got=$(sed -n 's/^#define RTC_VERSION \([0-9]*\).*/\1/p' "$HDR_SRC/rtcore_config.h")
[[ $got == "$HEADER_RTC_VERSION" ]] || die "crate headers have RTC_VERSION '$got', pinned $HEADER_RTC_VERSION"
HEADER_VERSION_STRING=$(sed -n 's/^#define RTC_VERSION_STRING "\(.*\)".*/\1/p' "$HDR_SRC/rtcore_config.h")
log "headers: Embree $HEADER_VERSION_STRING (RTC_VERSION $got)"

step "binary: embreex $EMBREEX_VERSION wheel from PyPI (pip)"
printf 'embreex==%s --hash=sha256:%s\n' "$EMBREEX_VERSION" "$EMBREEX_WHEEL_SHA256" >"$WORK/requirements.txt"
if ! python3 -m pip download --disable-pip-version-check --no-deps --only-binary=:all: \
    --python-version "$EMBREEX_PY_VERSION" --implementation cp --abi "$EMBREEX_ABI" \
    --platform "$EMBREEX_PLATFORM" -r "$WORK/requirements.txt" -d "$WORK/wheel" 2>&1 | sed 's/^/    | /'; then
  die "pip download of embreex==$EMBREEX_VERSION (sha256 $EMBREEX_WHEEL_SHA256) failed"
fi
shopt -s nullglob
wheels=("$WORK"/wheel/embreex-"$EMBREEX_VERSION"-*.whl)
shopt -u nullglob
[[ ${#wheels[@]} -eq 1 ]] || die "expected exactly one embreex wheel in $WORK/wheel, found ${#wheels[@]}"
WHEEL=${wheels[0]}
[[ $(sha256sum "$WHEEL" | cut -d' ' -f1) == "$EMBREEX_WHEEL_SHA256" ]] || die "sha256 mismatch for $WHEEL"
log "wheel: $(basename "$WHEEL") (sha256 $EMBREEX_WHEEL_SHA256 OK)"
python3 - "$WHEEL" "$WORK/wheel-x" <<'PY'
import sys, zipfile
whl, out = sys.argv[1], sys.argv[2]
with zipfile.ZipFile(whl) as z:
    libs = [n for n in z.namelist() if n.startswith("embreex.libs/") and not n.endswith("/")]
    if not libs:
        sys.exit("no embreex.libs/ folder in the wheel")
    for n in libs:
        z.extract(n, out)
        print("    | extracted", n)
PY
LIB_SRC="$WORK/wheel-x/embreex.libs"
[[ -f $LIB_SRC/$EMBREE_SONAME ]] || die "$EMBREE_SONAME not in the wheel's embreex.libs/ (have: $(ls "$LIB_SRC"))"
[[ -f $LIB_SRC/$TBB_SONAME ]] || die "$TBB_SONAME not in the wheel's embreex.libs/ (have: $(ls "$LIB_SRC"))"

step "inspect the wheel's libraries (readelf -d)"
dyn_field() { readelf -d "$1" | sed -n "s/.*($2).*\[\(.*\)\]/\1/p"; }
for f in "$LIB_SRC"/*; do
  log "$(basename "$f"):"
  readelf -d "$f" | grep -E '\((NEEDED|SONAME|RPATH|RUNPATH)\)' | sed 's/^ *0x[0-9a-f]* */    /'
done
[[ $(dyn_field "$LIB_SRC/$EMBREE_SONAME" SONAME) == "$EMBREE_SONAME" ]] || die "unexpected SONAME of $EMBREE_SONAME"
[[ $(dyn_field "$LIB_SRC/$TBB_SONAME" SONAME) == "$TBB_SONAME" ]] || die "unexpected SONAME of $TBB_SONAME"
dyn_field "$LIB_SRC/$EMBREE_SONAME" NEEDED | grep -qx "$TBB_SONAME" \
  || die "$EMBREE_SONAME does not NEED $TBB_SONAME; layout assumptions are wrong"
log "=> $EMBREE_SONAME NEEDs $TBB_SONAME and finds it via RPATH \$ORIGIN: both must sit in the same directory"

step "assemble prefix in staging dir $STAGE"
rm -rf -- "$STAGE"
mkdir -p "$STAGE/include/embree4" "$STAGE/lib"
for h in "${HEADERS[@]}"; do cp -- "$HDR_SRC/$h" "$STAGE/include/embree4/$h"; done
cp -- "$LIB_SRC/$EMBREE_SONAME" "$LIB_SRC/$TBB_SONAME" "$STAGE/lib/"
chmod 0644 "$STAGE"/include/embree4/*.h
chmod 0755 "$STAGE/lib/$EMBREE_SONAME" "$STAGE/lib/$TBB_SONAME"
ln -s "$EMBREE_SONAME" "$STAGE/lib/libembree4.so"
ln -s "$EMBREE_SONAME" "$STAGE/lib/libembree4.so.4"
log "ldd $EMBREE_SONAME:"
ldd_out=$(LD_LIBRARY_PATH="$STAGE/lib" ldd "$STAGE/lib/$EMBREE_SONAME")
printf '%s\n' "$ldd_out" | sed 's/^/    | /'
! grep -q 'not found' <<<"$ldd_out" || die "unresolved shared-library dependencies (see ldd output above)"
grep -q "$TBB_SONAME => $STAGE/lib/" <<<"$ldd_out" || die "$TBB_SONAME does not resolve to the prefix copy"

step "ABI patch: instPrimID members (RTC_GEOMETRY_INSTANCE_ARRAY) into the 4.2.0 headers"
python3 - "$STAGE/include/embree4" <<'PY'
import pathlib, sys
inc = pathlib.Path(sys.argv[1])
IA = "#if defined(RTC_GEOMETRY_INSTANCE_ARRAY)\n"
END = "#endif\n"

def patch(name, edits):
    p = inc / name
    s = p.read_text()
    for old, new, count in edits:
        n = s.count(old)
        if n != count:
            sys.exit(f"ABI patch: {name}: expected {count} occurrence(s) of {old!r}, found {n}")
        s = s.replace(old, new)
    p.write_text(s)
    print(f"    | patched {name} ({len(edits)} edit(s))")

patch("rtcore_config.h", [(
    "#define RTC_MAX_INSTANCE_LEVEL_COUNT 1\n",
    "#define RTC_MAX_INSTANCE_LEVEL_COUNT 1\n\n"
    "/* Added by strata tools/ci/embree4-prefix.sh: these 4.2.0 headers are paired with an\n"
    "   Embree 4.4.0 library built with EMBREE_GEOMETRY_INSTANCE_ARRAY (as upstream 4.3+ can be),\n"
    "   which adds instPrimID members to RTCHit*, RTCRayQueryContext and RTCPointQueryContext. */\n"
    "#define EMBREE_GEOMETRY_INSTANCE_ARRAY\n"
    "#if defined(EMBREE_GEOMETRY_INSTANCE_ARRAY)\n"
    "  #define RTC_GEOMETRY_INSTANCE_ARRAY\n"
    "#endif\n", 1)])

def member(decl, comment=""):
    return IA + f"  unsigned int instPrimID{decl};{comment}\n" + END

patch("rtcore_ray.h", [
    ("  unsigned int instID[RTC_MAX_INSTANCE_LEVEL_COUNT]; // instance ID\n",
     "  unsigned int instID[RTC_MAX_INSTANCE_LEVEL_COUNT]; // instance ID\n"
     + member("[RTC_MAX_INSTANCE_LEVEL_COUNT]", " // instance primitive ID"), 1),
    *[(f"  unsigned int instID[RTC_MAX_INSTANCE_LEVEL_COUNT][{n}];\n",
       f"  unsigned int instID[RTC_MAX_INSTANCE_LEVEL_COUNT][{n}];\n"
       + member(f"[RTC_MAX_INSTANCE_LEVEL_COUNT][{n}]"), 1) for n in ("4", "8", "16", "N")],
    # C++-only helpers, kept in step with the new member
    ("RTC_FORCEINLINE unsigned int& RTCHitN_instID(RTCHitN* hit, unsigned int N, unsigned int i, unsigned int l) { return ((unsigned*)hit)[7*N+i+N*l]; }\n",
     "RTC_FORCEINLINE unsigned int& RTCHitN_instID(RTCHitN* hit, unsigned int N, unsigned int i, unsigned int l) { return ((unsigned*)hit)[7*N+i+N*l]; }\n"
     + IA + "RTC_FORCEINLINE unsigned int& RTCHitN_instPrimID(RTCHitN* hit, unsigned int N, unsigned int i, unsigned int l) { return ((unsigned*)hit)[7*N + N*RTC_MAX_INSTANCE_LEVEL_COUNT + N*l + i]; }\n" + END, 1),
    ("  for (unsigned int l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; l++)\n    hit.instID[l] = RTCHitN_instID(hitN,N,i,l);\n",
     "  for (unsigned int l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; l++) {\n    hit.instID[l] = RTCHitN_instID(hitN,N,i,l);\n"
     + IA + "    hit.instPrimID[l] = RTCHitN_instPrimID(hitN,N,i,l);\n" + END + "  }\n", 1),
    ("  for (unsigned int l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; l++)\n    RTCHitN_instID(hitN,N,i,l) = hit->instID[l];\n",
     "  for (unsigned int l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; l++) {\n    RTCHitN_instID(hitN,N,i,l) = hit->instID[l];\n"
     + IA + "    RTCHitN_instPrimID(hitN,N,i,l) = hit->instPrimID[l];\n" + END + "  }\n", 1),
    ("  for (unsigned int l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; l++)\n    rh.hit.instID[l] = RTCHitN_instID(hit,N,i,l);\n",
     "  for (unsigned int l = 0; l < RTC_MAX_INSTANCE_LEVEL_COUNT; l++) {\n    rh.hit.instID[l] = RTCHitN_instID(hit,N,i,l);\n"
     + IA + "    rh.hit.instPrimID[l] = RTCHitN_instPrimID(hit,N,i,l);\n" + END + "  }\n", 1),
])

patch("rtcore_common.h", [
    # RTCRayQueryContext
    ("  unsigned int instID[RTC_MAX_INSTANCE_LEVEL_COUNT]; // The current stack of instance ids.\n",
     "  unsigned int instID[RTC_MAX_INSTANCE_LEVEL_COUNT]; // The current stack of instance ids.\n"
     + member("[RTC_MAX_INSTANCE_LEVEL_COUNT]", " // The current stack of instance primitive ids."), 1),
    ("  for (; l < RTC_MAX_INSTANCE_LEVEL_COUNT; ++l)\n    context->instID[l] = RTC_INVALID_GEOMETRY_ID;\n",
     "  for (; l < RTC_MAX_INSTANCE_LEVEL_COUNT; ++l) {\n    context->instID[l] = RTC_INVALID_GEOMETRY_ID;\n"
     + IA + "    context->instPrimID[l] = RTC_INVALID_GEOMETRY_ID;\n" + END + "  }\n", 1),
    # RTCPointQueryContext: instPrimID sits between instID and instStackSize
    ("  unsigned int instID[RTC_MAX_INSTANCE_LEVEL_COUNT];\n\n  // number of instances currently on the stack.\n",
     "  unsigned int instID[RTC_MAX_INSTANCE_LEVEL_COUNT];\n\n"
     + IA + "  // instance prim ids.\n  unsigned int instPrimID[RTC_MAX_INSTANCE_LEVEL_COUNT];\n" + END
     + "\n  // number of instances currently on the stack.\n", 1),
    ("  context->instStackSize = 0;\n  context->instID[0] = RTC_INVALID_GEOMETRY_ID;\n",
     "  context->instStackSize = 0;\n  context->instID[0] = RTC_INVALID_GEOMETRY_ID;\n"
     + IA + "  context->instPrimID[0] = RTC_INVALID_GEOMETRY_ID;\n" + END, 1),
])
PY
if command -v gcc >/dev/null && command -v g++ >/dev/null; then
  for lang in c c++; do
    printf '#include <embree4/rtcore.h>\n' | gcc -x "$lang" -fsyntax-only -I "$STAGE/include" - \
      || die "patched headers do not compile as $lang"
  done
  log "patched headers compile as C and C++"
fi

step "check: every function the headers declare is exported by the library"
CPP_CC=${CC:-gcc}
if command -v "$CPP_CC" >/dev/null; then
  # preprocess as a C consumer would, so SYCL-only declarations (#if EMBREE_SYCL_SUPPORT) drop out
  "$CPP_CC" -E -P -x c -I "$STAGE/include" - <<<'#include <embree4/rtcore.h>' >"$WORK/rtcore.i"
  python3 - "$WORK/rtcore.i" "$STAGE/lib/$EMBREE_SONAME" <<'PY'
import re, subprocess, sys
src, lib = open(sys.argv[1]).read(), sys.argv[2]
declared = set(re.findall(r"\b(rtc\w+)\s*\(", src))
inline = set(re.findall(r"always_inline\)\)[^;{()]*?\b(rtc\w+)\s*\(", src))
out = subprocess.run(["readelf", "--dyn-syms", "-W", lib], check=True, capture_output=True, text=True).stdout
exported = {f[7] for f in (l.split() for l in out.splitlines()) if len(f) >= 8 and f[6] != "UND"}
need = sorted(declared - inline)
if len(need) < 90 or len(inline) < 5:
    sys.exit(f"header parse found only {len(need)} functions / {len(inline)} inline helpers; parser broken?")
missing = [n for n in need if n not in exported]
if missing:
    sys.exit("declared but not exported by the library: " + ", ".join(missing))
print(f"    | all {len(need)} non-inline functions the headers declare are exported "
      f"({len(inline)} inline helpers skipped; the library exports "
      f"{len([e for e in exported if e.startswith('rtc')])} rtc* symbols)")
PY
else
  log "skipped: no C preprocessor ('$CPP_CC' not found)"
fi

step "check: runtime version of the library (python ctypes)"
BINARY_VERSION_STRING=$(python3 - "$STAGE/lib/$EMBREE_SONAME" "$BINARY_RTC_VERSION" <<'PY'
import ctypes, sys
lib = ctypes.CDLL(sys.argv[1])
lib.rtcNewDevice.restype = ctypes.c_void_p
lib.rtcNewDevice.argtypes = [ctypes.c_char_p]
lib.rtcGetDeviceProperty.restype = ctypes.c_ssize_t
lib.rtcGetDeviceProperty.argtypes = [ctypes.c_void_p, ctypes.c_int]
lib.rtcReleaseDevice.argtypes = [ctypes.c_void_p]
dev = lib.rtcNewDevice(None)
if not dev:
    sys.exit("rtcNewDevice failed")
v = lib.rtcGetDeviceProperty(dev, 0)  # RTC_DEVICE_PROPERTY_VERSION
lib.rtcReleaseDevice(dev)
if str(v) != sys.argv[2]:
    sys.exit(f"library reports RTC_DEVICE_PROPERTY_VERSION {v}, pinned {sys.argv[2]}")
print(f"{v // 10000}.{v // 100 % 100}.{v % 100}")
PY
)
log "library: Embree $BINARY_VERSION_STRING (RTC_DEVICE_PROPERTY_VERSION $BINARY_RTC_VERSION)"

step "write VERSION + stamp, publish to $DEST"
printf 'embree4 prefix: headers Embree %s (crates.io embree4-sys %s, lib/embree4, + instPrimID ABI patch rev %s) | binary Embree %s (PyPI embreex %s, %s %s, with %s)\n' \
  "$HEADER_VERSION_STRING" "$EMBREE4_SYS_VERSION" "$ABI_PATCH_REV" "$BINARY_VERSION_STRING" \
  "$EMBREEX_VERSION" "$EMBREEX_ABI-$EMBREEX_PLATFORM" "$EMBREE_SONAME" "$TBB_SONAME" >"$STAGE/VERSION"
printf '%s\n' "$STAMP" >"$STAGE/$STAMP_NAME"
prefix_complete "$STAGE" || die "staged prefix is incomplete (internal error)"
dest_replaceable || die "$DEST exists and does not look like an embree4 prefix; refusing to replace it"
rm -rf -- "$DEST"
mv -- "$STAGE" "$DEST"
log "VERSION: $(cat "$DEST/VERSION")"
( cd "$DEST" && find . -mindepth 1 | LC_ALL=C sort | while IFS= read -r f; do
    if [[ -L $f ]]; then printf '    %s -> %s\n' "$f" "$(readlink "$f")"; else printf '    %s\n' "$f"; fi
  done )

if [[ $SMOKE -eq 1 ]]; then
  step "smoke test against $DEST"
  if ! run_smoke "$DEST" "$WORK"; then
    rm -f -- "$DEST/$STAMP_NAME"   # never leave a prefix that failed its smoke test looking cached
    die "smoke test FAILED against $DEST (stamp removed, so the next run rebuilds)"
  fi
else
  log "smoke test skipped (--no-smoke)"
fi
step_done
log "prefix ready at $DEST; total $(elapsed "$T_START")s"
print_env
