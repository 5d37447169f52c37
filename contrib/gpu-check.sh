#!/usr/bin/env bash
# The device checks of docs/gpu.md, in two parts.
#
# A clean clip: the books' scene as a 24-frame clip at 1920x1080 (24 fps, a 180-degree
# shutter), rendered to a noise threshold of 2% on the GPU raw, with --denoise and with
# --denoise --temporal, and one frame of it on the CPU with --denoise; prints each frame's
# line and --stats line, then a table of totals per run (wall seconds, render and denoising
# seconds, GPU busy, host ns a sample, MiB read back, peak memory).
#
# Scenes by size, GPU and CPU side by side (issue 39's table): the books' scene
# (bench/bouncing_spheres_seed7.toml) and `raytrace generate --moving 0.5` scenes of 1e5, 1e6
# and 1e7 spheres at 1920x1080, 64 samples (16 for 1e6 and 1e7), and bench/big_points.toml's
# 1e7-point frame at 1920x1080, 16 samples; a row a scene with each device's samples per
# second (of its frame line) and whole-process wall seconds, the GPU's busy share and the
# host's ns a sample. A device that refuses a scene or fails on it has `failed` in its cells,
# and its last lines are printed above.
#
# Then the GPU's start-up: the books' scene at 16x8, 1 sample, with a new pipeline cache
# (cold) and three times after (warm); a row a run with the `gpu:` line's figures (adapter
# and device, pipelines, the part of them waited for, the start-up the run paid, the cache's
# use) and the whole process's wall seconds.
#
#   contrib/gpu-check.sh [RAYTRACE]            # both (many minutes on a real GPU)
#   contrib/gpu-check.sh --quick [RAYTRACE]    # checks the script in seconds: the clip at 80x45,
#                                              # 3 frames, 10%; the scenes at 64x36, 4 or 2
#                                              # samples, spheres and points cut to 1e3 and 2e3
#
# RAYTRACE is the binary to run (default: target/release/raytrace, built first if missing).
# OUT=folder keeps the frames, scenes and logs there (default: a temporary folder, removed
# after). Record its figures in docs/gpu.md and docs/denoising.md with the machine they came
# from.
set -euo pipefail

quick=false
if [[ ${1:-} == --quick ]]; then
    quick=true
    shift
fi
# RAYTRACE and OUT as given, from where the script was called; the rest from the repository's
# root (or an unpacked bundle's, contrib/bundle.sh).
if [[ -n ${1:-} ]]; then
    given=$(realpath -m "$1")
fi
if [[ -n ${OUT:-} ]]; then
    OUT=$(realpath -m "$OUT")
fi
cd "$(dirname "$0")/.."
raytrace=${given:-target/release/raytrace}
if [[ ! -x $raytrace ]]; then
    cargo build --release --quiet
fi
raytrace=$(realpath "$raytrace")
if $quick; then
    width=80 height=45
    frames=3
    threshold=0.1
    # The scenes' table: size, samples (the small scenes', the large ones'), and the counts
    # standing for 1e5, 1e6 and 1e7 spheres and 1e7 points.
    scene_width=64 scene_height=36
    spp_small=4 spp_large=2
    counts=(1000 2000 4000 2000)
else
    width=1920 height=1080
    frames=24
    threshold=0.02
    scene_width=1920 scene_height=1080
    spp_small=64 spp_large=16
    counts=(100000 1000000 10000000 10000000)
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

# Seconds since START (a `date +%s.%N`): a run's whole-process wall time.
seconds_since() {
    awk -v a="$1" -v b="$(date +%s.%N)" 'BEGIN { print b - a }'
}

run() {
    local name=$1
    shift
    local log=$out/$name.log
    local start wall
    start=$(date +%s.%N)
    "$raytrace" render "$clip" --noise-threshold "$threshold" --stats \
        -o "$out/$name/f_####.exr" "$@" >"$log" 2>&1 || {
        cat "$log"
        echo "$name: failed" >&2
        exit 1
    }
    wall=$(seconds_since "$start")
    echo
    echo "== $name: render CLIP (${width}x$height) --noise-threshold $threshold $*"
    grep -E '^(frame [0-9]+|gpu|denoiser)' "$log"
    totals+=("$(awk -v name="$name" -v wall="$wall" '
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

# One device's render of a scene for the scenes' table: the scene, its samples, the device.
# Prints `M_SAMPLES_PER_S WALL_S BUSY NS_A_SAMPLE` ("-" where the device has no such
# figure), or `failed failed - -` after the log's last lines where the render failed.
measure() {
    local scene=$1 spp=$2 device=$3
    local log=$out/$(basename "$scene" .toml)-$device.log
    local start wall
    start=$(date +%s.%N)
    if ! "$raytrace" render "$scene" --device "$device" --width "$scene_width" \
        --height "$scene_height" --samples "$spp" --stats -o "$out/scene.exr" >"$log" 2>&1; then
        tail -n 3 "$log" >&2
        echo "failed failed - -"
        return
    fi
    wall=$(seconds_since "$start")
    awk -v wall="$wall" '
        / stats: / {
            if (match($0, /samples [0-9]+ \([0-9.]+ M\/s\)/)) {
                s = substr($0, RSTART, RLENGTH)
                sub(/.*\(/, "", s)
                sub(/ M\/s\)/, "", s)
            }
            if (match($0, /busy [0-9.]+%/)) busy = substr($0, RSTART + 5, RLENGTH - 5)
            if (match($0, /\([0-9.]+ ns a sample/)) ns = substr($0, RSTART + 1, RLENGTH - 13)
        }
        END { printf "%s %.2f %s %s\n", s, wall, busy ? busy : "-", ns ? ns : "-" }' "$log"
}

# The scenes: the books' (as it is), spheres generated by count, the fountain's points beside
# a copy of bench/big_points.toml.
scenes=$out/scenes
mkdir -p "$scenes"
for n in "${counts[@]:0:3}"; do
    "$raytrace" generate --spheres "$n" --moving 0.5 -o "$scenes/spheres_$n.toml" >/dev/null
done
cp bench/big_points.toml "$scenes/points.toml"
"$raytrace" generate --points "${counts[3]}" --frames 1 -o "$scenes/f_#.ply" >/dev/null

rows=()
row() {
    local name=$1 scene=$2 spp=$3 on_gpu=$4
    local gpu=(- - - -)
    if $on_gpu; then
        read -r -a gpu <<<"$(measure "$scene" "$spp" gpu)"
    fi
    local cpu
    read -r -a cpu <<<"$(measure "$scene" "$spp" cpu)"
    rows+=("| $name | $spp | ${gpu[0]} | ${gpu[1]} | ${cpu[0]} | ${cpu[1]} | ${gpu[2]} | ${gpu[3]} |")
}
row books bench/bouncing_spheres_seed7.toml "$spp_small" true
row "spheres ${counts[0]}" "$scenes/spheres_${counts[0]}.toml" "$spp_small" true
row "spheres ${counts[1]}" "$scenes/spheres_${counts[1]}.toml" "$spp_large" true
row "spheres ${counts[2]}" "$scenes/spheres_${counts[2]}.toml" "$spp_large" true
row "points ${counts[3]}" "$scenes/points.toml" "$spp_large" true

echo
echo "== scenes at ${scene_width}x$scene_height"
echo "| scene | spp | GPU M samples/s | GPU wall s | CPU M samples/s | CPU wall s | GPU busy | host ns a sample |"
echo "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
printf '%s\n' "${rows[@]}"

# The start-up of one run of the books' scene at 16x8 with the pipeline cache in
# $out/pipeline-cache: its name, then `| name | device s | pipelines s | waited s | start-up s |
# cache | wall s |` from its `gpu:` line.
startup() {
    local name=$1 log=$out/startup-$1.log
    local start wall
    start=$(date +%s.%N)
    RAYTRACE_GPU_CACHE=$out/pipeline-cache "$raytrace" render bench/bouncing_spheres_seed7.toml \
        --device gpu --width 16 --height 8 --samples 1 --stats -o "$out/startup.exr" \
        >"$log" 2>&1 || {
        cat "$log"
        echo "start-up $name: failed" >&2
        exit 1
    }
    wall=$(seconds_since "$start")
    awk -v name="$name" -v wall="$wall" '
        /^gpu: / {
            match($0, /start-up [0-9.]+ s/); paid = substr($0, RSTART + 9, RLENGTH - 11)
            match($0, /adapter and device [0-9.]+ s/); dev = substr($0, RSTART + 19, RLENGTH - 21)
            match($0, /pipelines [0-9.]+ s/); pipes = substr($0, RSTART + 10, RLENGTH - 12)
            match($0, /[0-9.]+ s of them waited for/); waited = substr($0, RSTART, RLENGTH - 21)
            match($0, /(cache hit|cold|no cache)\)$/); use = substr($0, RSTART, RLENGTH - 1)
        }
        END { printf "| %s | %s | %s | %s | %s | %s | %.2f |\n", name, dev, pipes, waited, paid, use, wall }' "$log"
}
rm -rf "$out/pipeline-cache"
starts=("$(startup cold)")
for k in 1 2 3; do
    starts+=("$(startup "warm $k")")
done

echo
echo "== start-up: books' scene at 16x8, 1 sample"
echo "| run | adapter and device s | pipelines s | waited for s | start-up s | cache | wall s |"
echo "| --- | ---: | ---: | ---: | ---: | --- | ---: |"
printf '%s\n' "${starts[@]}"
