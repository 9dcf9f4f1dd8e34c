#!/usr/bin/env bash
# Install missing Debian packages (idempotent: apt-get runs only if one is missing).
# Without arguments: the run-time libraries the pip wheels load but do not bundle.
# With arguments: exactly those packages (find_python.sh uses this for build deps).
set -euo pipefail

if [ $# -gt 0 ]; then
    pkgs=("$@")
else
    pkgs=(
        # vtk (pyvista) renders offscreen through EGL with Mesa's software driver
        libegl1 libegl-mesa0 libgl1-mesa-dri
        # the gmsh wheel links libGL/libGLU and X/fontconfig libraries dynamically
        libgl1 libglu1-mesa libxrender1 libxcursor1 libxft2 libxinerama1
        # FFCx compiles the generated forms with the C compiler at run time
        gcc libc6-dev
    )
fi

if ! command -v dpkg >/dev/null; then
    echo "system_deps: no dpkg (not Debian/Ubuntu); make sure these are installed: ${pkgs[*]}" >&2
    exit 0
fi

missing=()
for p in "${pkgs[@]}"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "system_deps: installing ${missing[*]}" >&2
sudo=()
if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "system_deps: need root for: ${missing[*]}" >&2; exit 1; }
    sudo=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -q >&2
"${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
