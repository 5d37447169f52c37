#!/usr/bin/env bash
# A bundle of raytrace for a machine without a Rust toolchain (a farm's nodes, a GPU machine),
# as one tar.xz: the release binary, stripped, in bin/; the denoiser's libraries (Intel Open
# Image Denoise and its TBB) in lib/, where the binary looks for them before anywhere else
# (its folder, lib, ../lib: crates/denoise/src/library.rs); and contrib/gpu-check.sh with the
# scenes it renders (bench/, scenes/), so the device check runs from the unpacked folder.
#
#   contrib/bundle.sh [OUT.tar.xz] [RAYTRACE]
#
# OUT defaults to target/raytrace-VERSION-ARCH-linux.tar.xz; RAYTRACE to
# target/release/raytrace (built first if missing). The libraries come from $OIDN_DIR/lib,
# else the build's .oidn/lib; without them the bundle denoises only where the machine has
# OIDN 2.5 itself (a warning says so). xz takes its settings from XZ_OPT (default: -6, all
# cores). The Vulkan loader and the GPU's driver are the machine's own.
#
# On the other machine:
#   tar -xJf raytrace-VERSION-ARCH-linux.tar.xz
#   raytrace-VERSION-ARCH-linux/bin/raytrace check raytrace-VERSION-ARCH-linux/scenes/quick.toml --device gpu
#   raytrace-VERSION-ARCH-linux/contrib/gpu-check.sh raytrace-VERSION-ARCH-linux/bin/raytrace
set -euo pipefail
cd "$(dirname "$0")/.."

raytrace=${2:-target/release/raytrace}
if [[ ! -x $raytrace ]]; then
    cargo build --release --quiet
fi
version=$("$raytrace" --version | awk '{ print $2 }')
name=raytrace-$version-$(uname -m)-linux
out=${1:-target/$name.tar.xz}
out=$(realpath -m "$out")

staging=$(mktemp -d)
trap 'rm -rf "$staging"' EXIT
root=$staging/$name
mkdir -p "$root/bin" "$root/lib" "$root/contrib" "$root/bench" "$root/scenes"

# The binary without its symbols and line tables (12 MB of 91 here); a copy where there is
# no `strip`.
if command -v strip >/dev/null 2>&1; then
    strip --strip-all -o "$root/bin/raytrace" "$raytrace"
else
    cp "$raytrace" "$root/bin/raytrace"
fi

# The libraries the binary loads when it denoises, their links resolved to files.
libraries=${OIDN_DIR:-.oidn}/lib
copied=0
for library in "$libraries"/libOpenImageDenoise* "$libraries"/libtbb*; do
    [[ -e $library ]] || continue
    cp -L "$library" "$root/lib/"
    copied=$((copied + 1))
done
if [[ $copied -eq 0 ]]; then
    echo "warning: no denoiser libraries in $libraries: the bundle denoises only where the machine has OIDN 2.5" >&2
fi

cp contrib/gpu-check.sh "$root/contrib/"
cp bench/*.toml "$root/bench/"
cp scenes/*.toml "$root/scenes/"

mkdir -p "$(dirname "$out")"
XZ_OPT=${XZ_OPT:--6 -T0} tar -C "$staging" -cJf "$out.partial" "$name"
mv "$out.partial" "$out"
echo "$out: $(du -h "$out" | cut -f1), $name/ with bin/raytrace, $copied libraries in lib/, contrib/gpu-check.sh"
