#!/usr/bin/env bash
# The device check of a clean clip: the books' scene as a 24-frame clip at 1920x1080 (24 fps, a
# 180-degree shutter), rendered to a noise threshold of 2% on the GPU raw, with --denoise and
# with --denoise --temporal, and one frame of it on the CPU with --denoise; prints each frame's
# line and --stats line, then a table of totals per run (wall seconds, render and denoising
# seconds, GPU busy, host ns a sample, MiB read back, peak memory).
#
#   contrib/gpu-check.sh [RAYTRACE]            # the clip (minutes on a real GPU)
#   contrib/gpu-check.sh --quick [RAYTRACE]    # 80x45, 3 frames, 10%: checks the script in seconds
#
# RAYTRACE is the binary to run (default: target/release/raytrace, built first if missing).
# OUT=folder keeps the frames and logs there (default: a temporary folder, removed after).
# Record its figures in docs/gpu.md and docs/denoising.md with the machine they came from.
set -euo pipefail
cd "$(dirname "$0")/.."

quick=false
if [[ ${1:-} == --quick ]]; then
    quick=true
    shift
fi
raytrace=${1:-target/release/raytrace}
if [[ ! -x $raytrace ]]; then
    cargo build --release --quiet
fi
raytrace=$(realpath "$raytrace")
if $quick; then
    width=80 height=45
    frames=3
    threshold=0.1
else
    width=1920 height=1080
    frames=24
    threshold=0.02
fi

if [[ -n ${OUT:-} ]]; then
    out=$OUT
    mkdir -p "$out"
else
    out=$(mktemp -d)
    trap 'rm -rf "$out"' EXIT
fi

# The books' scene (scenes/bouncing_spheres.toml, one still over [0, 1] s) as a clip: its
# spheres keep their velocities, the shot is 24 frames a second with the shutter open half of
# each frame, at the size of the check.
clip=$out/clip.toml
sed -e "s/^fps = .*/fps = 24.0/" \
    -e "s/^frames = .*/frames = $frames/" \
    -e "s/^first_frame = .*/first_frame = 1/" \
    -e "s/^width = .*/width = $width/" \
    -e "s/^height = .*/height = $height/" \
    -e "s/^shutter = .*/shutter = 0.020833333333333332/" \
    -e "s|^path = .*|path = \"frames/clip_####.exr\"|" \
    scenes/bouncing_spheres.toml >"$clip"

"$raytrace" check "$clip" --device gpu | grep -E '^(device|memory)'

# One run: its name, then the arguments after `render CLIP`. Prints its lines and keeps its
# totals for the table.
totals=()
run() {
    local name=$1
    shift
    local log=$out/$name.log
    local start end
    start=$(date +%s.%N)
    "$raytrace" render "$clip" --noise-threshold "$threshold" --stats \
        -o "$out/$name/f_####.exr" "$@" >"$log" 2>&1 || {
        cat "$log"
        echo "$name: failed" >&2
        exit 1
    }
    end=$(date +%s.%N)
    echo
    echo "== $name: render CLIP (${width}x$height) --noise-threshold $threshold $*"
    grep -E '^(frame [0-9]+|gpu|denoiser)' "$log"
    totals+=("$(awk -v name="$name" -v wall="$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')" '
        /^frame [0-9]+: / { frames++ }
        / stats: / {
            if (match($0, /render [0-9.]+ s/)) render += substr($0, RSTART + 7, RLENGTH - 9)
            if (match($0, /denoising [0-9.]+ s/)) denoise += substr($0, RSTART + 10, RLENGTH - 12)
            if (match($0, /busy [0-9.]+%/)) { busy += substr($0, RSTART + 5, RLENGTH - 6); n++ }
            if (match($0, /\([0-9.]+ ns a sample/)) { ns += substr($0, RSTART + 1, RLENGTH - 13); nsn++ }
            if (match($0, /read back [0-9.]+ MiB/)) back += substr($0, RSTART + 10, RLENGTH - 14)
            if (match($0, /peak memory [0-9.]+ MiB/)) {
                p = substr($0, RSTART + 12, RLENGTH - 16) + 0
                if (p > peak) peak = p
            }
        }
        END {
            printf "| %s | %d | %.2f | %.2f | %.2f | %.1f%% | %s | %s | %.1f |\n", name, frames,
                wall, render, denoise, n ? busy / n : 0, nsn ? sprintf("%.2f", ns / nsn) : "-",
                back ? sprintf("%.1f", back) : "-", peak
        }' "$log")")
}

run gpu-raw --device gpu
run gpu-denoise --device gpu --denoise
run gpu-temporal --device gpu --denoise --temporal
run cpu-denoise --device cpu --denoise --frames 1

echo
echo "| run | frames | wall s | render s | denoising s | busy (mean) | host ns a sample (mean) | read back MiB | peak MiB |"
echo "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
printf '%s\n' "${totals[@]}"
