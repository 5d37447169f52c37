#!/usr/bin/env bash
# compare_builds.sh OLD_BINARY NEW_BINARY [FOLDER]
#
# Renders every shipped scene with each binary, with a set of options that reaches every path
# of a frame (plain, PNG, all passes, noise threshold, denoised, denoised under a threshold,
# --temporal from the start and from a later chunk, the GPU where one is found (lavapipe
# counts), one thread, a larger size), runs `check`, `generate`, `converge`, `converge
# --flicker` and `clip` and a few bad inputs, and compares what the two wrote: every frame
# and clip byte for byte, every printed line with its timings (seconds, rates) left out.
# A change that must keep frames byte-identical (a refactoring) passes with "0 differ".
#
# Run from anywhere; it reads the scenes in the repository's `scenes/`. The point caches the
# fountain and LAMMPS scenes read are made first where missing, with NEW_BINARY's `generate`
# and with `lmp` (Debian: lammps); without `lmp` the LAMMPS scene is left out, and said so.
# Outputs go to FOLDER (a temporary folder if not given): old/ and new/. `check` prints the
# memory a render needs, which a change to what a room counts moves: those figures are counted
# apart from the differences. Prints each file that differs; exits 1 if any does.
set -euo pipefail

if [[ $# -lt 2 ]]; then
    echo "usage: $0 OLD_BINARY NEW_BINARY [FOLDER]" >&2
    exit 2
fi
OLD=$(realpath "$1")
NEW=$(realpath "$2")
OUT=$(realpath -m "${3:-$(mktemp -d)}")
ROOT=$(realpath "$(dirname "$0")/..")
cd "$ROOT"

mkdir -p scenes/caches
if ! compgen -G 'scenes/caches/fountain_*.ply' >/dev/null; then
    "$NEW" generate -o 'scenes/caches/fountain_####.ply' --frames 48 --points 4000
fi
scenes=(scenes/*.toml)
if [[ ! -f scenes/caches/lammps_gas.lammpstrj ]]; then
    if command -v lmp >/dev/null; then
        lmp -in examples/lammps/gas.in -log none -screen none
    else
        echo "no lmp: scenes/lammps_gas.toml left out"
        scenes=("${scenes[@]/scenes\/lammps_gas.toml/}")
    fi
fi

# render_all BINARY FOLDER: every run, its standard output and error and status kept.
render_all() {
    local bin=$1 out=$2
    mkdir -p "$out"
    run() {
        local name=$1
        shift
        "$bin" "$@" >"$out/$name.stdout" 2>"$out/$name.stderr" && echo "rc=0" >>"$out/$name.stdout" ||
            echo "rc=$?" >>"$out/$name.stdout"
    }
    local size="--width 96 --height 54" all=alpha,depth,normal,albedo,motion,variance
    for s in "${scenes[@]}"; do
        [[ -n $s ]] || continue
        local n
        n=$(basename "$s" .toml)
        run "$n.plain" render "$s" $size --samples 8 --output "$out/$n/plain_####.exr" --quiet --threads 2
        run "$n.png" render "$s" $size --samples 8 --output "$out/$n/png_####.png" --quiet
        run "$n.passes" render "$s" $size --samples 4 --passes $all --output "$out/$n/passes_####.exr" --quiet
        run "$n.thresh" render "$s" $size --noise-threshold 0.05 --max-samples 64 --passes samples \
            --output "$out/$n/thresh_####.exr" --quiet
        run "$n.dn" render "$s" $size --samples 16 --denoise --output "$out/$n/dn_####.exr" --quiet \
            --chunk-size 3 --chunk 0
        run "$n.dnth" render "$s" $size --denoise --noise-threshold 0.04 --max-samples 128 \
            --output "$out/$n/dnth_####.exr" --quiet --chunk-size 2 --chunk 0
        run "$n.temporal" render "$s" $size --samples 8 --denoise --temporal \
            --output "$out/$n/temp_####.exr" --quiet --chunk-size 4 --chunk 0
        run "$n.temporalchunk" render "$s" $size --samples 8 --denoise --temporal \
            --output "$out/$n/tempc_####.exr" --quiet --chunk-size 2 --chunk 1
        run "$n.gpu" render "$s" $size --samples 8 --device gpu --output "$out/$n/gpu_####.exr" --quiet \
            --chunk-size 2 --chunk 0
        run "$n.gputh" render "$s" $size --device gpu --noise-threshold 0.05 --max-samples 64 --passes $all \
            --output "$out/$n/gputh_####.exr" --quiet --chunk-size 2 --chunk 0
        run "$n.gpudn" render "$s" $size --samples 8 --device gpu --denoise --temporal \
            --output "$out/$n/gpudn_####.exr" --quiet --chunk-size 3 --chunk 0
        run "$n.big" render "$s" --width 200 --height 113 --samples 16 --denoise --passes $all \
            --output "$out/$n/big_####.exr" --quiet --chunk-size 1 --chunk 0
        run "$n.t1" render "$s" $size --samples 8 --threads 1 --output "$out/$n/plain_####.exr" --quiet \
            --chunk-size 2 --chunk 0
        run "$n.check" check "$s"
        run "$n.checkgpu" check "$s" --device gpu --chunk-size 5
    done
    run help --help
    for c in render check clip converge generate preview; do run "help_$c" "$c" --help; done
    run gen generate --spheres 50 --moving 0.5 --seed 3 --frames 4 -o "$out/gen.toml"
    run genply generate --points 300 --frames 3 -o "$out/genply/f_####.ply"
    run conv converge scenes/quick.toml --width 32 --height 18 --max-samples 16 --reference-samples 64 \
        --repeats 1 --csv "$out/conv.csv"
    run flick converge scenes/quick.toml --flicker 1-3 --width 32 --height 18 --max-samples 8 \
        --reference-samples 32
    run bad1 render /nonexistent.toml
    run bad2 render scenes/quick.toml --frames 99
    run clipgif clip scenes/quick.toml "$out/clip.gif" --input "$out/quick/png_####.png"
}

render_all "$OLD" "$OUT/old"
render_all "$NEW" "$OUT/new"

# A printed line without its timings: seconds, rates, converge's timed columns (its table's
# seconds and efficiency, its slopes against seconds, its equal-time ratios) and flicker's
# seconds (the last column of its table's rows), converge's note on times that ran backwards,
# and check's memory figures.
untimed() {
    sed -E "s#$2#OUT#g; s#[0-9.]+(e[-+]?[0-9]+)? s\b#T s#g; s#[0-9.]+ M samples/s#R M samples/s#g" "$1" |
        awk '$1 == "independent" || $1 == "sobol" { $3 = $4 = $5 = $NF = "T" }
             $1 == "raw" || $1 == "denoised" { $NF = "T" } { print }' |
        sed -E 's#-?[0-9.]+ against seconds#T against seconds#g
                s#= [0-9.]+ at T s \(median [0-9.]+ over [0-9]+ times#= T at T s (median T over N times#
                /ran backwards against their neighbours/d
                s#memory:? about [0-9.]+ [KMG]iB#memory about M#g'
}
# converge's CSVs without their timed columns.
untimed_csv() {
    python3 - "$1" <<'EOF'
import csv, sys
timed = {"seconds", "wall_seconds", "wall_seconds_spread", "cpu_seconds", "cpu_seconds_spread",
         "efficiency", "efficiency_spread", "seconds_spread", "time_ratio", "error_ratio"}
rows = list(csv.DictReader(open(sys.argv[1])))
for r in rows:
    print(",".join(v for k, v in r.items() if k not in timed))
EOF
}

cd "$OUT/old"
files=0 differ=0 memory=0
while IFS= read -r f; do
    files=$((files + 1))
    if [[ ! -f "$OUT/new/$f" ]]; then
        echo "missing in new: $f"
        differ=$((differ + 1))
        continue
    fi
    case "$f" in
    *.check.stdout | *.checkgpu.stdout)
        if ! cmp -s <(untimed "$f" "$OUT/old") <(untimed "$OUT/new/$f" "$OUT/new"); then
            echo "differs: $f"
            differ=$((differ + 1))
        elif ! cmp -s "$f" "$OUT/new/$f"; then
            memory=$((memory + 1))
        fi
        ;;
    *.csv)
        if ! cmp -s <(untimed_csv "$f") <(untimed_csv "$OUT/new/$f"); then
            echo "differs: $f"
            differ=$((differ + 1))
        fi
        ;;
    *.stdout | *.stderr | *.toml)
        if ! cmp -s <(untimed "$f" "$OUT/old") <(untimed "$OUT/new/$f" "$OUT/new"); then
            echo "differs: $f"
            differ=$((differ + 1))
        fi
        ;;
    *)
        if ! cmp -s "$f" "$OUT/new/$f"; then
            echo "differs: $f"
            differ=$((differ + 1))
        fi
        ;;
    esac
done < <(find . -type f | sed 's#^\./##' | sort)
echo "$files files compared in $OUT: $differ differ ($memory check outputs differ only in their memory line)"
[[ $differ -eq 0 ]]
