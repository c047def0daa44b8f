#!/usr/bin/env bash
# Fetches larger real inputs from Debian packages into data/external/ (not committed).
#
#   bash tools/fetch-data.sh
#
# Source: Debian package `libcgal-demo` (CGAL 5.5), file
# /usr/share/doc/libcgal-dev/data.tar.gz. The package is downloaded and unpacked in a
# temporary folder (no install, no dependencies). Licence: the CGAL data files are
# distributed with CGAL under the terms in Debian's copyright file for the cgal source
# package; they are for local tests and benchmarks and are not redistributed by isokit.
set -euo pipefail
cd "$(dirname "$0")/.."
dest=data/external
mkdir -p "$dest"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
(
  cd "$tmp"
  if ! apt-get download libcgal-demo >/dev/null 2>&1; then
    apt-get update >/dev/null
    apt-get download libcgal-demo >/dev/null
  fi
  dpkg-deb -x libcgal-demo_*.deb x
  tar xzf x/usr/share/doc/libcgal-dev/data.tar.gz \
    data/meshes/bunny00.off data/meshes/armadillo.off data/meshes/elephant.off \
    data/meshes/elephant-with-holes.off data/meshes/fandisk.off data/meshes/knot1.off
)
for f in "$tmp"/data/meshes/*.off; do
  cp "$f" "$dest/"
  echo "fetched $dest/$(basename "$f")"
done
