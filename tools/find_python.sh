#!/usr/bin/env bash
# Print the path of a CPython >= 3.12 with working ssl, ctypes and venv (logs go to stderr).
# Order: $DD_PYTHON, python3.13/python3.12 on PATH, pyenv installs, our cached build,
# else build CPython 3.13.5 from the Debian orig tarball into the per-user cache.
# DD_FORCE_BUILD_PYTHON=1 skips the search (uses or creates the cached build).
set -euo pipefail

VERSION=3.13.5
SHA256=93e583f243454e6e9e4588ca2c2662206ad961659863277afcdb96801647d640
POOL_PATH=pool/main/p/python3.13/python3.13_${VERSION}.orig.tar.xz
CACHE_ROOT=${XDG_CACHE_HOME:-$HOME/.cache}/dd_contact
PREFIX=$CACHE_ROOT/cpython-$VERSION
MARKER=$PREFIX/.dd_contact_complete  # written last: a prefix without it is a broken build
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

TMP=""
trap '[ -z "$TMP" ] || rm -rf "$TMP"' EXIT

log() { echo "find_python: $*" >&2; }

# Print the interpreter's real path if it is usable (resolves pyenv shims and symlinks).
check() {
    "$1" -c 'import sys, sysconfig, ssl, ctypes, venv, ensurepip
assert sys.implementation.name == "cpython" and sys.version_info >= (3, 12)
assert not sysconfig.get_config_var("Py_GIL_DISABLED")  # no wheels for free-threaded builds
print(sys.executable)' 2>/dev/null
}

# The main Debian archive from the apt sources (not -security); DD_DEBIAN_MIRROR overrides.
debian_mirror() {
    if [ -n "${DD_DEBIAN_MIRROR:-}" ]; then echo "${DD_DEBIAN_MIRROR%/}"; return; fi
    local uris
    uris=$({
        cat /etc/apt/sources.list.d/*.sources 2>/dev/null |
            sed -n 's/^URIs:[[:space:]]*//p' | tr ' ' '\n'
        sed -n 's/^deb[[:space:]]\+\(\[[^]]*\][[:space:]]\+\)\?\([^[:space:]]\+\).*/\2/p' \
            /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null
    } | sed 's:/*$::' | grep -E '^(https?|ftp)://' | grep -v security || true)
    grep -m1 '/debian$' <<<"$uris" || head -n1 <<<"$uris"
}

download() {
    if command -v curl >/dev/null; then curl -fsSL -o "$2" "$1"; else wget -q -O "$2" "$1"; fi
}

build() {
    local deps=(build-essential libssl-dev zlib1g-dev libbz2-dev libffi-dev liblzma-dev
        libsqlite3-dev libreadline-dev uuid-dev libncurses-dev xz-utils)
    command -v curl >/dev/null || command -v wget >/dev/null || deps+=(curl ca-certificates)
    "$HERE/system_deps.sh" "${deps[@]}"

    local mirror url
    mirror=$(debian_mirror) || true
    [ -n "$mirror" ] || { log "no Debian mirror in apt sources (set DD_DEBIAN_MIRROR)"; exit 1; }
    url=$mirror/$POOL_PATH
    TMP=$(mktemp -d)

    log "downloading $url"
    download "$url" "$TMP/src.tar.xz"
    if ! echo "$SHA256  $TMP/src.tar.xz" | sha256sum -c --status; then
        log "SHA256 MISMATCH for $url: expected $SHA256"
        log "got $(sha256sum "$TMP/src.tar.xz")"
        exit 1
    fi
    tar -xJf "$TMP/src.tar.xz" -C "$TMP"

    # rpath must be the final prefix, so install there directly; the marker makes it valid.
    rm -rf "$PREFIX"
    local logfile=$CACHE_ROOT/build-cpython-$VERSION.log
    log "building CPython $VERSION into $PREFIX (~3 min; log: $logfile)"
    if ! (cd "$TMP/Python-$VERSION" &&
        ./configure --enable-shared --disable-test-modules --prefix="$PREFIX" \
            LDFLAGS="-Wl,-rpath,$PREFIX/lib" &&
        make -j"$(nproc)" && make install) >"$logfile" 2>&1; then
        tail -n 40 "$logfile" >&2
        log "build failed, see $logfile"
        exit 1
    fi
    check "$PREFIX/bin/python3.13" >/dev/null || { log "built python is not usable"; exit 1; }
    touch "$MARKER"
}

# The cached build, building it first if needed (under a lock against concurrent runs).
cached_build() {
    mkdir -p "$CACHE_ROOT"
    exec 9>"$CACHE_ROOT/cpython-$VERSION.lock"
    flock 9
    # rebuild a cached interpreter that stopped working (e.g. system libraries changed)
    { [ -e "$MARKER" ] && check "$PREFIX/bin/python3.13" >/dev/null; } || build
    check "$PREFIX/bin/python3.13"
}

if [ -n "${DD_PYTHON:-}" ]; then
    check "$DD_PYTHON" || { log "DD_PYTHON=$DD_PYTHON is not a usable CPython >= 3.12"; exit 1; }
    exit 0
fi

if [ "${DD_FORCE_BUILD_PYTHON:-0}" != 1 ]; then
    # newest pyenv install first
    mapfile -t pyenv_pys < <(printf '%s\n' "$HOME"/.pyenv/versions/3.1[2-9]*/bin/python3 | sort -rV)
    for py in python3.13 python3.12 "${pyenv_pys[@]}"; do
        command -v "$py" >/dev/null 2>&1 || continue
        if check "$py"; then exit 0; fi
        log "skipping $(command -v "$py") (not a usable CPython >= 3.12)"
    done
    [ -e "$MARKER" ] && check "$PREFIX/bin/python3.13" && exit 0
fi

cached_build
