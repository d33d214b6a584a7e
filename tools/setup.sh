#!/usr/bin/env bash
# Installs what strata needs to build and test on Debian 12 (or Ubuntu/Debian 13):
# Embree (headers and library), Draco's decoder (libdraco-dev: KHR_draco_mesh_compression),
# libclang for bindgen, pkg-config, and OpenImageIO's
# command-line tools (idiff, oiiotool) used by the image tests, and DejaVu Sans for the
# labels of the convergence tool's plots. Idempotent: packages that
# are already installed are not touched, and apt is not called at all when none is missing.
set -euo pipefail

packages=(libembree-dev libdraco-dev libclang-dev pkg-config openimageio-tools fonts-dejavu-core)

if ! command -v dpkg >/dev/null 2>&1; then
    echo "setup: not a Debian-based system; install Embree 4 (or 3.13), Draco, libclang, pkg-config and" >&2
    echo "       OpenImageIO's tools with your package manager (Homebrew: embree draco llvm pkg-config openimageio)." >&2
    exit 1
fi

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]})); then
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
    echo "setup: installing ${missing[*]}" >&2
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
    echo "setup: system packages already installed (${packages[*]})" >&2
fi

# Open Image Denoise for --denoise (Debian 12 packages none): the libraries of PyPI's pyoidn
# wheel, fetched once into ~/.cache/strata/oidn-2.5.1, where strata loads them from at run
# time. Set STRATA_NO_OIDN=1 to skip it.
if [ -z "${STRATA_NO_OIDN:-}" ]; then
    if ! command -v pip3 >/dev/null 2>&1 && ! python3 -m pip --version >/dev/null 2>&1; then
        echo "setup: no pip: skipping Open Image Denoise (--denoise); apt-get install python3-pip to have it" >&2
    elif oidn=$("$(dirname "$0")/oidn-prefix.sh"); then
        echo "setup: Open Image Denoise in $oidn, where render --denoise finds it" >&2
    else
        echo "setup: warning: could not fetch Open Image Denoise; strata builds and renders, and --denoise says how to get it" >&2
    fi
fi

if ! command -v cargo >/dev/null 2>&1; then
    echo "setup: cargo not found: install a Rust toolchain (rustup), Rust 1.87 or newer" >&2
    exit 1
fi
