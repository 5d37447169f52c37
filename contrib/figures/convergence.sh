#!/usr/bin/env bash
# Regenerates every figure, image and CSV file of docs/convergence.md and of the convergence
# part of docs/performance.md ("Time to a given error, measured by converge"), and prints the
# docs' tables made from them (data/convergence_tables.md in the output folder).
#
#   contrib/figures/convergence.sh            # the docs' figures, into docs/ (take a quiet machine)
#   contrib/figures/convergence.sh --quick    # every command at reduced size, into target/figures-quick
#
# The full run takes about two hours on a quiet 2-core machine (2 threads): per scene two 4096-
# sample references and the measured renders to 256 samples, 3 seeds each, timed by the
# median of up to 7 alternated renders; then the books' scene to 1% error raw, adaptive and
# denoised. --quick renders quarter-size frames (160x90) with 512-sample references, measures
# to 64 samples with 2 seeds and checks the commands in a few minutes; its figures are not
# the docs'. OUT=folder puts either elsewhere.
set -euo pipefail
cd "$(dirname "$0")/../.."

quick=false
if [[ ${1:-} == --quick ]]; then
    quick=true
fi
if $quick; then
    out=${OUT:-target/figures-quick}
    size=(--width 160 --height 90)
    reference_samples=512
    max_samples=64
    seeds=2
    denoised_max=64
    thresholds=0.1,0.05
    time_limits=(1 1)
else
    out=${OUT:-docs}
    size=()
    reference_samples=4096
    max_samples=256
    seeds=3
    denoised_max=1024
    thresholds=0.05,0.02,0.01
    time_limits=(4 2)
fi
data=$out/data
images=$out/images
references=target/figures-references$($quick && echo -quick || true)
mkdir -p "$data" "$images" "$references"

cargo build --release --quiet
cargo build --release --quiet --example equal_time_crops
bin=target/release/raytrace
crops=target/release/examples/equal_time_crops
threads=(--threads 2)

started=$(date +%s)
log() { echo "[$(($(date +%s) - started)) s] $*" >&2; }

# 1. Each shipped scene's error against time, both samplers (docs/convergence.md, Results).
for scene in bouncing_spheres defocus orbits propeller quick turntable; do
    log "converge $scene"
    plot=()
    case $scene in
        bouncing_spheres | defocus) plot=(--plot "$images/convergence_$scene.png") ;;
    esac
    "$bin" converge "scenes/$scene.toml" "${threads[@]}" "${size[@]}" \
        --reference-samples "$reference_samples" --max-samples "$max_samples" --seeds "$seeds" \
        --write-reference "$references/${scene}_a.exr" "$references/${scene}_b.exr" \
        --csv "$data/convergence_$scene.csv" "${plot[@]}" >"$data/convergence_$scene.txt"
done

# 2. The books' scene to 1% error: uniform and adaptive, raw and denoised, the default
#    sampler, against the references of step 1 (docs/performance.md, docs/convergence.md).
log "converge bouncing_spheres: time to error"
"$bin" converge scenes/bouncing_spheres.toml "${threads[@]}" "${size[@]}" --sampler sobol \
    --denoise --thresholds "$thresholds" --max-samples "$denoised_max" --seeds "$seeds" \
    --reference "$references/bouncing_spheres_a.exr" "$references/bouncing_spheres_b.exr" \
    --csv "$data/time_to_error_bouncing_spheres.csv" \
    --plot "$images/convergence_time_to_error_bouncing_spheres.png" \
    >"$data/time_to_error_bouncing_spheres.txt"

# 3. Equal-time crops: both samplers under the same --time-limit, cropped beside the
#    reference (docs/convergence.md, Equal time, side by side).
k=0
for scene in bouncing_spheres defocus; do
    limit=${time_limits[$k]}
    k=$((k + 1))
    case $scene in
        bouncing_spheres) region=(80 90 120 100 3) ;;
        *) region=(55 20 120 100 3) ;;
    esac
    $quick && region=(20 20 60 50 3)
    for sampler in independent sobol; do
        log "render $scene --sampler $sampler --time-limit $limit"
        "$bin" render "scenes/$scene.toml" "${threads[@]}" "${size[@]}" -q --sampler "$sampler" \
            --time-limit "$limit" -o "$references/${scene}_equal_time_$sampler.exr"
    done
    "$crops" "$images/equal_time_$scene.png" "${region[@]}" "$references/${scene}_a.exr" \
        "$references/${scene}_equal_time_independent.exr" \
        "$references/${scene}_equal_time_sobol.exr" >"$data/equal_time_$scene.txt"
done

# 4. The docs' tables, from the CSV files.
log "tables"
{
    echo "### independent MSE / sobol MSE at equal samples, and the MSE slopes"
    echo
    counts=$(printf '%s\n' 1 4 16 64 "$max_samples" | awk '!seen[$0]++' | paste -sd ' ')
    echo "| scene | $(echo "$counts" | sed 's/ / | /g; s/^1 |/1 spp |/') | MSE slope, independent / sobol | FLIP at $max_samples, independent / sobol |"
    echo "| --- |$(for _ in $counts; do printf ' ---: |'; done) ---: | ---: |"
    for scene in bouncing_spheres defocus orbits propeller quick turntable; do
        csv=$data/convergence_$scene.csv
        slopes=$(grep -E '^(independent|sobol): MSE slope' "$data/convergence_$scene.txt" |
            sed -E 's/.*MSE slope ([-0-9.]+) against samples.*/\1/' | paste -sd '/' | sed 's#/# / #')
        awk -F, -v scene="$scene" -v slopes="$slopes" -v max="$max_samples" -v list="$counts" '
            NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
            $col["finish"] == "raw" && $col["sampling"] == "uniform" {
                mse[$col["sampler"], $col["samples"] + 0] = $col["mse"]
                flip[$col["sampler"], $col["samples"] + 0] = $col["flip"]
            }
            END {
                line = "| " scene
                n = split(list, counts, " ")
                for (k = 1; k <= n; k++) {
                    c = counts[k]
                    line = line sprintf(" | %.2f", mse["independent", c] / mse["sobol", c])
                }
                line = line " | " slopes sprintf(" | %.4f / %.4f |", flip["independent", max], flip["sobol", max])
                print line
            }' "$csv"
    done
    echo
    echo "### estimate / true relative error"
    echo
    from16=$(awk -v max="$max_samples" 'BEGIN { for (n = 16; n <= max; n *= 2) printf "%d ", n }')
    echo "| scene | sampler | $(echo "$from16" | sed 's/ $//; s/ / | /g; s/^16/16 spp/') |"
    echo "| --- | --- |$(for _ in $from16; do printf ' ---: |'; done)"
    for scene in bouncing_spheres defocus orbits propeller quick turntable; do
        awk -F, -v scene="$scene" '
            NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
            $col["finish"] == "raw" && $col["sampling"] == "uniform" && $col["samples"] + 0 >= 16 {
                s = $col["sampler"]
                row[s] = row[s] sprintf(" | %.2f", sqrt($col["estimated_rel_mse"] / $col["rel_mse"]))
            }
            END { for (s in row) print "| " scene " | " s row[s] " |" }' "$data/convergence_$scene.csv" | sort
    done
    echo
    echo "### time to a relative error, bouncing_spheres"
    echo
    echo '```'
    sed -n '/^time to a relative error/,/^CSV written/p' "$data/time_to_error_bouncing_spheres.txt" |
        grep -v '^CSV written'
    echo '```'
    echo
    echo "### equal time (MSE against reference A, whole image and crop)"
    echo
    for scene in bouncing_spheres defocus; do
        echo "$scene: $(sed 's#.*/##' "$data/equal_time_$scene.txt" | paste -sd ';')"
    done
} >"$data/convergence_tables.md"
log "done: $data/convergence_tables.md"
