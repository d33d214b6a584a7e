#!/usr/bin/env bash
# tools/farm/task-index.sh -- prints this task's index in its array job, whichever engine
# started it: Slurm job arrays ($SLURM_ARRAY_TASK_ID), Kubernetes Indexed Jobs
# ($JOB_COMPLETION_INDEX), AWS Batch array jobs ($AWS_BATCH_JOB_ARRAY_INDEX), or
# $STRATA_TASK_INDEX for anything else. Fails, naming them, when none is set.
set -euo pipefail
for v in SLURM_ARRAY_TASK_ID JOB_COMPLETION_INDEX AWS_BATCH_JOB_ARRAY_INDEX STRATA_TASK_INDEX; do
    if [[ -n ${!v:-} ]]; then
        [[ ${!v} =~ ^[0-9]+$ ]] || { echo "task-index: \$$v='${!v}' is not an index" >&2; exit 2; }
        echo "${!v}"
        exit 0
    fi
done
echo "task-index: not in an array job (none of SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX, AWS_BATCH_JOB_ARRAY_INDEX, STRATA_TASK_INDEX is set)" >&2
exit 2
