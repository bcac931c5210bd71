#!/usr/bin/env bash
# Fetches Debian's source package of Siconos and builds only its C numerics
# (components `externals` and `numerics`) into a cache outside the work tree.
#
#   scripts/build_siconos.sh [PREFIX]
#
# PREFIX defaults to ${COSIM_CACHE:-$HOME/.cache/cosim}/siconos-numerics-4.4.0.
# A finished build leaves PREFIX/.complete; a second call then does nothing.
# apt's own configuration under /etc/apt is never modified: a private deb-src
# list is derived from the machine's `deb` entries in a temporary folder.
set -euo pipefail

version=4.4.0
cache=${COSIM_CACHE:-$HOME/.cache/cosim}
prefix=${1:-$cache/siconos-numerics-$version}

if [[ -f $prefix/.complete ]]; then
  echo "siconos: numerics $version already built in $prefix"
  exit 0
fi

die() { echo "siconos: error: $*" >&2; exit 1; }

work=$cache/siconos-src
mkdir -p "$work"
srcdir=$(find "$work" -maxdepth 1 -type d -name "siconos-$version*" | head -n 1)

if [[ -z $srcdir ]]; then
  echo "siconos: fetching Debian's source package 'siconos' ($version)"
  apt_dir=$(mktemp -d)
  trap 'rm -rf "$apt_dir"' EXIT
  mkdir -p "$apt_dir/sources.list.d" "$apt_dir/lists/partial" "$apt_dir/cache/archives/partial"
  : > "$apt_dir/sources.list"
  found=0
  # deb822 files: turn every `Types: deb` stanza into `Types: deb-src`.
  for f in /etc/apt/sources.list.d/*.sources; do
    [[ -f $f ]] || continue
    sed -E 's/^Types:[[:space:]]*deb([[:space:]]|$)/Types: deb-src\1/' "$f" \
      > "$apt_dir/sources.list.d/$(basename "$f")"
    found=1
  done
  # One-line format: copy `deb` lines as `deb-src`.
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [[ -f $f ]] || continue
    grep -E '^[[:space:]]*deb[[:space:]]' "$f" | sed -E 's/^[[:space:]]*deb[[:space:]]/deb-src /' \
      >> "$apt_dir/sources.list.d/derived.list" && found=1 || true
  done
  [[ $found == 1 ]] || die "no apt sources found under /etc/apt to derive a deb-src entry from.
  Fetch the source package 'siconos' ($version) by hand and unpack it into $work/siconos-$version"
  apt_opts=(-o "Dir::Etc::SourceList=$apt_dir/sources.list"
            -o "Dir::Etc::SourceParts=$apt_dir/sources.list.d"
            -o "Dir::State::Lists=$apt_dir/lists"
            -o "Dir::Cache=$apt_dir/cache")
  command -v dpkg-source >/dev/null || die "dpkg-source is missing: install the Debian package 'dpkg-dev'"
  apt-get "${apt_opts[@]}" -qq update \
    || die "'apt-get update' on the derived deb-src list failed (network or mirror problem).
  Retry, or fetch the source package 'siconos' ($version) by hand into $work"
  (cd "$work" && apt-get "${apt_opts[@]}" -qq source "siconos=$version*") \
    || (cd "$work" && apt-get "${apt_opts[@]}" -qq source siconos) \
    || die "'apt-get source siconos' failed. Fetch the source package by hand into $work"
  srcdir=$(find "$work" -maxdepth 1 -type d -name "siconos-$version*" | head -n 1)
  [[ -n $srcdir ]] || die "the source package unpacked, but no siconos-$version* folder is in $work"
fi

echo "siconos: building numerics from $srcdir into $prefix"
build=$cache/siconos-build
rm -rf "$build"
mkdir -p "$build"
cat > "$build/numerics_only.cmake" <<'OPTS'
set(COMPONENTS externals numerics CACHE INTERNAL "")
option(WITH_PYTHON_WRAPPER "" OFF)
option(WITH_CXX "" OFF)
option(WITH_TESTING "" OFF)
option(WITH_SYSTEM_SUITESPARSE "" ON)
option(BUILD_SHARED_LIBS "" ON)
OPTS
python=/usr/bin/python3
cmake -S "$srcdir" -B "$build" -DUSER_OPTIONS_FILE="$build/numerics_only.cmake" \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$prefix" \
  -DPython3_EXECUTABLE=$python -DPYTHON_EXECUTABLE=$python > "$build/configure.log" 2>&1 \
  || { tail -n 30 "$build/configure.log" >&2; die "configuring Siconos failed (log: $build/configure.log)"; }
cmake --build "$build" -j"$(nproc)" > "$build/build.log" 2>&1 \
  || { tail -n 30 "$build/build.log" >&2; die "building Siconos failed (log: $build/build.log)"; }
cmake --install "$build" > "$build/install.log" 2>&1 \
  || { tail -n 30 "$build/install.log" >&2; die "installing Siconos failed (log: $build/install.log)"; }
# Keep the LCP test problems next to the library: the project's external LCP test suite reads them.
mkdir -p "$prefix/share/lcp_test_data"
cp "$srcdir"/numerics/src/LCP/test/data/*.dat "$prefix/share/lcp_test_data/"
touch "$prefix/.complete"
echo "siconos: done ($prefix)"
