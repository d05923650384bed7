#!/usr/bin/env bash
# Renders one frame on Kubernetes: applies the shards Job (shards.yaml), waits until it has
# ended — Complete, or Failed when a shard failed for good or the Job's deadline passed, never
# forever — then applies the merge Job (merge.yaml) and waits for it. Run it again to finish a
# frame after a failure: an ended Job is deleted and applied anew, and its pods keep the
# finished shards and resume the stopped ones. See docs/render-farm.md.
set -euo pipefail

here=$(cd -- "$(dirname -- "${BASH_SOURCE[0]}")" && pwd)

usage() {
    cat <<'EOF'
usage: run.sh [--allow-missing] [--timeout SECONDS] [--namespace NS] [SHARDS.yaml [MERGE.yaml]]

  --allow-missing    if shards failed for good, merge what is there (noisier) instead of failing
  --timeout SECONDS  give up waiting for the shards after this long [default: 90000, more than
                     the Job's own activeDeadlineSeconds]
  --namespace NS     the namespace of the Jobs [default: kubectl's current one]
  SHARDS.yaml        the shards Job [default: shards.yaml beside this script]
  MERGE.yaml         the merge Job [default: merge.yaml beside this script]
EOF
}

die() {
    printf 'run.sh: %s\n' "$1" >&2
    exit "${2:-2}"
}
say() { printf '%s %s\n' "$(date -u +%Y-%m-%dT%H:%M:%SZ)" "$*"; }

allow_missing=no timeout=90000 files=() kubectl=(kubectl)
while (($# > 0)); do
    case $1 in
    --allow-missing) allow_missing=yes ;;
    --timeout)
        (($# > 1)) || die "--timeout needs a number of seconds"
        [[ $2 =~ ^[1-9][0-9]*$ ]] || die "--timeout must be a positive number of seconds, got '$2'"
        timeout=$2
        shift
        ;;
    --namespace)
        (($# > 1)) || die "--namespace needs a name"
        kubectl+=(--namespace "$2")
        shift
        ;;
    -h | --help)
        usage
        exit 0
        ;;
    -*) die "unknown option '$1' (see --help)" ;;
    *) files+=("$1") ;;
    esac
    shift
done
((${#files[@]} <= 2)) || die "expected at most two files (SHARDS.yaml MERGE.yaml), got ${#files[@]}"
shards_file=${files[0]:-$here/shards.yaml}
merge_file=${files[1]:-$here/merge.yaml}
for file in "$shards_file" "$merge_file"; do
    [[ -f $file ]] || die "$file: no such file"
done
command -v kubectl >/dev/null || die "kubectl not found"

# What a file says, as the API server reads it.
field() { "${kubectl[@]}" create --dry-run=client -f "$1" -o jsonpath="$2"; }
env_of() { field "$1" "{.spec.template.spec.containers[0].env[?(@.name==\"$2\")].value}"; }

shards_job=$(field "$shards_file" '{.metadata.name}')
merge_job=$(field "$merge_file" '{.metadata.name}')
completions=$(field "$shards_file" '{.spec.completions}')
[[ $(env_of "$shards_file" SHARDS) == "$completions" ]] ||
    die "$shards_file: completions ($completions) and SHARDS ($(env_of "$shards_file" SHARDS)) differ"
for variable in SHARDS FRAME; do
    [[ $(env_of "$merge_file" "$variable") == "$(env_of "$shards_file" "$variable")" ]] ||
        die "$merge_file and $shards_file give different $variable"
done

# The conditions of an existing Job that are true, e.g. "Complete " or "FailureTarget Failed ".
conditions() {
    "${kubectl[@]}" get job "$1" --ignore-not-found \
        -o jsonpath='{range .status.conditions[?(@.status=="True")]}{.type}{" "}{end}'
}
exists() { [[ -n $("${kubectl[@]}" get job "$1" --ignore-not-found -o name) ]]; }

# Waits until Job $1 is Complete or Failed, at most $2 seconds; prints which.
wait_for_end() {
    local job=$1 deadline=$((SECONDS + $2)) state
    while :; do
        state=" $(conditions "$job") "
        if [[ $state == *" Complete "* ]]; then
            echo Complete
            return
        fi
        if [[ $state == *" Failed "* ]]; then
            echo Failed
            return
        fi
        if ((SECONDS >= deadline)); then
            echo TimedOut
            return
        fi
        sleep 10
    done
}

# A Job that has ended is done with: delete it so that applying it again runs it again (its
# partials and checkpoints stay on the volume).
fresh() {
    local job=$1 state
    if exists "$job"; then
        state=" $(conditions "$job") "
        if [[ $state == *" Complete "* || $state == *" Failed "* ]]; then
            say "deleting the ended job/$job to run it again"
            "${kubectl[@]}" delete job "$job" --wait=true >/dev/null
        fi
    fi
}

fresh "$shards_job"
"${kubectl[@]}" apply -f "$shards_file"
say "waiting for job/$shards_job ($completions shards; at most $timeout s)"
result=$(wait_for_end "$shards_job" "$timeout")
case $result in
Complete) say "all $completions shards finished" ;;
TimedOut)
    die "job/$shards_job has not ended after $timeout s; it goes on: run this script again to wait for it" 1
    ;;
Failed)
    failed=$("${kubectl[@]}" get job "$shards_job" -o jsonpath='{.status.failedIndexes}')
    reason=$("${kubectl[@]}" get job "$shards_job" \
        -o jsonpath='{.status.conditions[?(@.type=="Failed")].reason}: {.status.conditions[?(@.type=="Failed")].message}')
    say "job/$shards_job FAILED ($reason); failed shards: ${failed:-none listed}"
    say "their logs: kubectl logs -l job-name=$shards_job --prefix --tail=20"
    if [[ $allow_missing == no ]]; then
        say "not merging an incomplete frame. To finish it, run this script again (finished shards are kept, stopped ones resume), or merge what is there with --allow-missing."
        exit 1
    fi
    ;;
esac

fresh "$merge_job"
"${kubectl[@]}" create --dry-run=client -f "$merge_file" -o yaml |
    "${kubectl[@]}" set env --local -f - "ALLOW_MISSING=$allow_missing" -o yaml |
    "${kubectl[@]}" apply -f -
result=$(wait_for_end "$merge_job" 7200)
"${kubectl[@]}" logs "job/$merge_job" --tail=-1 || true
case $result in
Complete) say "merged: job/$merge_job finished" ;;
*) die "job/$merge_job ended $result; its log is above" 1 ;;
esac
