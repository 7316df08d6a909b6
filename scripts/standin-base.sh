#!/usr/bin/env bash
# Build a stand-in for the python:3.11-slim base image where registries of container
# images cannot be reached: Debian bookworm (minbase) from the Debian archive plus its
# Python 3.11, with `python` and `pip` on PATH as in the official image.
#   scripts/standin-base.sh [IMAGE_NAME]      (default: localhost/python:3.11-slim)
# Needs root, debootstrap and buildah.
set -euo pipefail
name="${1:-localhost/python:3.11-slim}"
mirror="${DEBIAN_MIRROR:-http://deb.debian.org/debian}"
root="$(mktemp -d)"
trap 'rm -rf "$root"' EXIT
. "$(dirname "$0")/vfs-storage.sh"

debootstrap --variant=minbase --include=python3,python3-pip,python3-venv,ca-certificates \
    bookworm "$root" "$mirror"
# the official image's pip installs into the interpreter; Debian's marks it externally managed
rm -f "$root"/usr/lib/python3.11/EXTERNALLY-MANAGED
ln -sf /usr/bin/python3 "$root"/usr/local/bin/python
ln -sf /usr/bin/pip3 "$root"/usr/local/bin/pip
rm -rf "$root"/var/lib/apt/lists/* "$root"/var/cache/apt/*.bin "$root"/var/cache/apt/archives/*.deb \
    "$root"/usr/share/doc/* "$root"/usr/share/man/* "$root"/usr/share/locale/*

ctr="$(buildah from scratch)"
tar -C "$root" -cf "$root.tar" .
buildah add "$ctr" "$root.tar" /
rm -f "$root.tar"
buildah config --env PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    --env LANG=C.UTF-8 --cmd python3 "$ctr"
buildah commit --format docker "$ctr" "$name"
buildah rm "$ctr"
echo "stand-in base image: $name"
