#!/usr/bin/env bash
# Fetches larger real inputs from Debian packages into data/external/ (not committed).
#
#   bash tools/fetch-data.sh
#
# Sources (each package is downloaded and unpacked in a temporary folder: no install, no
# dependencies):
# - `libcgal-demo` (CGAL 5.5), file /usr/share/doc/libcgal-dev/data.tar.gz: six meshes
#   (data/meshes/*.off) and two images, `skull_2.9.inr` (a CT skull, smoothed, 64^3 float)
#   and `liver.inr.gz` (a segmented abdominal CT, 438 x 353 x 165, 8-bit). Licence: the CGAL
#   data files are distributed with CGAL under the terms in Debian's copyright file for the
#   cgal source package.
# - `mricron-data` (MRIcron 1.2), /usr/share/mricron/templates/ch2bet.nii.gz: the Colin27
#   T1-weighted MRI of a brain, skull stripped (181 x 217 x 181, 1 mm). Licence: BSD-3-clause
#   (Debian's copyright file for mricron).
# They are for local tests and benchmarks and are not redistributed by isokit.
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
    data/meshes/elephant-with-holes.off data/meshes/fandisk.off data/meshes/knot1.off \
    data/images/skull_2.9.inr data/images/liver.inr.gz
  apt-get download mricron-data >/dev/null 2>&1
  dpkg-deb -x mricron-data_*.deb m
)
for f in "$tmp"/data/meshes/*.off; do
  cp "$f" "$dest/"
  echo "fetched $dest/$(basename "$f")"
done
for f in "$tmp"/data/images/skull_2.9.inr "$tmp"/data/images/liver.inr.gz \
  "$tmp"/m/usr/share/mricron/templates/ch2bet.nii.gz; do
  cp "$f" "$dest/"
  echo "fetched $dest/$(basename "$f")"
done
