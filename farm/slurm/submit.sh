#!/usr/bin/env bash
# Submits one realcam frame to Slurm as an array job of shards and a merge job that runs once
# every shard has ended. See docs/render-farm.md.
set -euo pipefail

here=$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")" && pwd)

usage() {
    cat <<'EOF'
usage: submit.sh SCENE --shards N --out FRAME.png [farm options] [render options…]

Renders SCENE as N shards (one Slurm array task each, `realcam render --shard I/N`) and
merges them into FRAME.png once every task has ended. Shards stopped by a signal (the time
limit's early signal, scancel --signal=INT, preemption) save a checkpoint, requeue themselves
and resume; a shard that fails for good makes the merge fail with the command that finishes
the frame.

farm options:
  --shards N              number of shards (array tasks), required
  --out FRAME.png         the merged frame, required; partials and checkpoints go beside it
                          (FRAME.shard-I-of-N.exr, FRAME.shard-I-of-N.checkpoint.exr)
  --exr FILE.exr          also write the merged linear film
  --exposure EV           PNG exposure of the merged frame [default: automatic]
  --allow-missing         if shards fail for good, merge what is there (noisier) instead of
                          failing
  --time LIMIT            time limit of one run of a shard (sbatch --time) [default: 01:00:00]
  --stop-before SECONDS   ask realcam to stop this long before the time limit
                          (--signal=INT@SECONDS; Slurm may send it up to 60 s earlier still);
                          it must cover one sample pass and saving the checkpoint [default: 120]
  --cpus-per-task N       cores per shard, also realcam's --threads [default: 4]
  --max-requeues N        give a shard up after it was stopped and requeued N times [default: 50]
  --logs DIR              log folder, created if missing [default: FRAME's folder/logs]
  --sbatch-option OPT     pass OPT to both sbatch calls, e.g. --sbatch-option=--partition=render
                          (repeatable)
  --realcam PATH          the realcam binary the jobs run [default: $REALCAM, else realcam
                          on PATH]
  --continue              keep the frame's finished partials and checkpoints and submit only the
                          shards that have no partial yet (a stopped shard resumes)
  --dry-run               print the sbatch commands instead of running them
  -h, --help              this help

render options: any `realcam render` option except those the farm sets (--shard, --partial,
--checkpoint, --resume, --threads) or that do not fit a shard (--stats, --contact-sheet,
--zoom-sweep, --focus-sweep, --aperture-sweep, --f-number-sweep, several --lens). Give every
shard of a frame the same options.

Jobs run in the directory submit.sh was run from (relative paths in render options are
relative to it), and SCENE, FRAME and the logs are made absolute.
EOF
}

die() {
    printf 'submit.sh: %s\n' "$1" >&2
    printf "run 'submit.sh --help' for the options\n" >&2
    exit 2
}

is_count() { [[ $1 =~ ^[0-9]+$ ]]; }

# "0 1 2 3 5 7 8" → "0-3,5,7-8" (sbatch --array syntax).
array_spec() {
    local runs=() start=$1 prev=$1 index
    shift
    for index in "$@" ""; do
        if [[ -n $index ]] && ((index == prev + 1)); then
            prev=$index
            continue
        fi
        if ((start == prev)); then runs+=("$start"); else runs+=("$start-$prev"); fi
        start=$index prev=$index
    done
    local IFS=,
    printf '%s' "${runs[*]}"
}

# The words as one shell command line: plain words as they are, others quoted.
quoted() {
    local word out=""
    for word in "$@"; do
        if [[ $word =~ ^[A-Za-z0-9_./:=,@%+-]+$ ]]; then
            out+="${out:+ }$word"
        else
            out+="${out:+ }$(printf '%q' "$word")"
        fi
    done
    printf '%s' "$out"
}

(($# > 0)) || die "missing SCENE"
case $1 in
-h | --help)
    usage
    exit 0
    ;;
-*) die "the first argument is the SCENE (a .gltf or .glb file), got the option '$1'" ;;
esac
scene=$1
shift

shards="" out="" exr="" exposure="" allow_missing=no time="" stop_before="" cpus=""
max_requeues=50 logs="" realcam=${REALCAM:-} continue_frame=no dry_run=no
sbatch_options=() render=()
lenses=0
while (($# > 0)); do
    arg=$1
    shift
    name=$arg value="" inline=no
    if [[ $arg == --*=* ]]; then
        name=${arg%%=*} value=${arg#*=} inline=yes
    fi
    case $name in
    --shards | --out | --exr | --exposure | --time | --stop-before | --cpus-per-task | \
        --max-requeues | --logs | --sbatch-option | --realcam)
        if [[ $inline == no ]]; then
            (($# > 0)) || die "$name needs a value"
            value=$1
            shift
        fi
        [[ -n $value ]] || die "$name needs a non-empty value"
        case $name in
        --shards) shards=$value ;;
        --out) out=$value ;;
        --exr) exr=$value ;;
        --exposure) exposure=$value ;;
        --time) time=$value ;;
        --stop-before) stop_before=$value ;;
        --cpus-per-task) cpus=$value ;;
        --max-requeues) max_requeues=$value ;;
        --logs) logs=$value ;;
        --sbatch-option) sbatch_options+=("$value") ;;
        --realcam) realcam=$value ;;
        esac
        ;;
    --allow-missing | --continue | --dry-run)
        [[ $inline == no ]] || die "$name takes no value"
        case $name in
        --allow-missing) allow_missing=yes ;;
        --continue) continue_frame=yes ;;
        --dry-run) dry_run=yes ;;
        esac
        ;;
    -h | --help)
        usage
        exit 0
        ;;
    --shard | --partial | --checkpoint | --resume | --threads)
        die "$name is set by the farm scripts for each shard; leave it out"
        ;;
    --stats | --contact-sheet | --zoom-sweep | --focus-sweep | --aperture-sweep | --f-number-sweep)
        die "$name does not fit a sharded frame; render one frame per submission"
        ;;
    *)
        [[ $name == --lens ]] && lenses=$((lenses + 1))
        render+=("$arg")
        ;;
    esac
done

[[ -n $shards ]] || die "missing --shards N"
[[ $shards =~ ^[1-9][0-9]*$ ]] || die "--shards must be a positive whole number, got '$shards'"
[[ -n $out ]] || die "missing --out FRAME.png"
[[ $out == *.png ]] || die "--out must name a .png file (the merged frame), got '$out'"
[[ -z $exr || $exr == *.exr ]] || die "--exr must name a .exr file, got '$exr'"
[[ -z $stop_before ]] || { is_count "$stop_before" && ((stop_before <= 65535)); } ||
    die "--stop-before must be a whole number of seconds from 0 to 65535, got '$stop_before'"
[[ -z $cpus ]] || [[ $cpus =~ ^[1-9][0-9]*$ ]] || die "--cpus-per-task must be a positive whole number, got '$cpus'"
is_count "$max_requeues" || die "--max-requeues must be a whole number, got '$max_requeues'"
((lenses <= 1)) || die "--lens is given $lenses times: a frame is rendered through one lens"
[[ -f $scene ]] || die "$scene: no such scene file"

if [[ -z $realcam ]]; then
    realcam=$(command -v realcam) || die "realcam is not on PATH; give --realcam PATH or set REALCAM"
fi
[[ -f $realcam && -x $realcam ]] || die "$realcam: not an executable realcam binary"
if [[ $dry_run == no ]]; then
    command -v sbatch >/dev/null || die "sbatch not found: run submit.sh where Slurm's commands are installed"
fi

# Every task records the scene path it was given, and merge refuses partials whose settings
# differ: give all of them one absolute path.
scene=$(realpath -ms -- "$scene")
out=$(realpath -ms -- "$out")
realcam=$(realpath -s -- "$realcam")
[[ -z $exr ]] || exr=$(realpath -ms -- "$exr")
frame_dir=$(dirname -- "$out")
logs=$(realpath -ms -- "${logs:-$frame_dir/logs}")
stem=${out%.png}
name=$(basename -- "$stem")

# Which shards to submit: all of them, or with --continue those without a finished partial.
todo=()
existing=()
for ((index = 0; index < shards; index++)); do
    partial="$stem.shard-$index-of-$shards.exr"
    checkpoint="$stem.shard-$index-of-$shards.checkpoint.exr"
    if [[ -e $partial ]]; then existing+=("$partial"); else todo+=("$index"); fi
    if [[ -e $checkpoint ]]; then existing+=("$checkpoint"); fi
done
if [[ $continue_frame == no && ${#existing[@]} -gt 0 ]]; then
    printf 'submit.sh: %s already has %d partial(s) or checkpoint(s) of %d shards, e.g. %s\n' \
        "$out" "${#existing[@]}" "$shards" "${existing[0]}" >&2
    printf 'pass --continue to keep them (finished shards are kept, stopped ones resume), or delete them to start over\n' >&2
    exit 2
fi

merge_options=()
[[ -z $exr ]] || merge_options+=(--exr "$exr")
[[ -z $exposure ]] || merge_options+=(--exposure "$exposure")

# The command that finishes this frame later: the same submission with --continue, from here.
again=("$here/submit.sh" "$scene" --shards "$shards" --out "$out" "${merge_options[@]}")
[[ $allow_missing == no ]] || again+=(--allow-missing)
[[ -z $time ]] || again+=(--time "$time")
[[ -z $stop_before ]] || again+=(--stop-before "$stop_before")
[[ -z $cpus ]] || again+=(--cpus-per-task "$cpus")
again+=(--max-requeues "$max_requeues" --logs "$logs" --realcam "$realcam")
for option in "${sbatch_options[@]}"; do again+=(--sbatch-option "$option"); done
again+=("${render[@]}" --continue)
continue_command="cd $(printf '%q' "$PWD") && $(quoted "${again[@]}")"

shard_job=(sbatch --parsable --chdir="$PWD" --job-name="$name.shards"
    --output="$logs/$name.shard-%a.log" --open-mode=append --requeue)
[[ -z $time ]] || shard_job+=(--time="$time")
[[ -z $stop_before ]] || shard_job+=(--signal="INT@$stop_before")
[[ -z $cpus ]] || shard_job+=(--cpus-per-task="$cpus")
shard_job+=("${sbatch_options[@]}")
merge_job=(sbatch --parsable --chdir="$PWD" --job-name="$name.merge"
    --output="$logs/$name.merge.log" --open-mode=append --kill-on-invalid-dep=yes
    "${sbatch_options[@]}")
shard_arguments=("$here/shard.sbatch" "$realcam" "$shards" "$out" "$max_requeues" "$scene" "${render[@]}")
merge_arguments=("$here/merge.sbatch" "$realcam" "$shards" "$out" "$logs" "$allow_missing"
    "$continue_command" "${merge_options[@]}")

if ((${#todo[@]} == 0)); then
    array=""
else
    array=$(array_spec "${todo[@]}")
fi

if [[ $dry_run == yes ]]; then
    [[ -z $array ]] || printf '%s\n' "$(quoted "${shard_job[@]}" --array="$array" "${shard_arguments[@]}")"
    printf '%s\n' "$(quoted "${merge_job[@]}" ${array:+--dependency=afterany:ARRAY_JOB} "${merge_arguments[@]}")"
    exit 0
fi

mkdir -p -- "$frame_dir" "$logs"
dependency=()
if [[ -n $array ]]; then
    array_job=$("${shard_job[@]}" --array="$array" "${shard_arguments[@]}")
    array_job=${array_job%%;*}
    dependency=(--dependency="afterany:$array_job")
    printf 'shards: array job %s, tasks %s of 0..%d, logs %s\n' "$array_job" "$array" "$((shards - 1))" "$logs/$name.shard-I.log"
else
    printf 'shards: all %d shards are finished already; submitting only the merge\n' "$shards"
fi
if ! merge_id=$("${merge_job[@]}" "${dependency[@]}" "${merge_arguments[@]}"); then
    if [[ -n $array ]]; then
        scancel "$array_job" || true
        printf 'submit.sh: cannot submit the merge job; cancelled the shards (array job %s)\n' "$array_job" >&2
    fi
    exit 1
fi
merge_id=${merge_id%%;*}
printf 'merge: job %s (starts once every shard task has ended), log %s\n' "$merge_id" "$logs/$name.merge.log"
printf 'frame: %s\n' "$out"
