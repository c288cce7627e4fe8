# Sourced by .ci/run and scripts/test: names each step of a run, prints
# when it starts and how long it took, and appends that to a log, so that a
# run's time has a name per step (where the landed CI run and a local run
# part ways, for one).
#
#   step NAME   ends the step before (if any) and starts NAME
#   end_step    ends the current step
#
# ACQ_STEP_LOG, when set, is a tab-separated file that each ended step is
# appended to: date (UTC), commit, step, seconds. .ci/run sets it to
# ci-steps.tsv in the build directory, which CI keeps between its runs.
# ACQ_STEP_PREFIX is put before each step's name (scripts/test under
# .ci/run: "test: ").
acq_step_name=""
acq_step_started=$SECONDS
acq_step_commit="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"

end_step() {
  [ -n "$acq_step_name" ] || return 0
  local took=$((SECONDS - acq_step_started))
  printf '== %s: %d s\n' "$acq_step_name" "$took"
  if [ -n "${ACQ_STEP_LOG:-}" ]; then
    mkdir -p "$(dirname "$ACQ_STEP_LOG")"
    printf '%s\t%s\t%s%s\t%d\n' "$(date -u +%Y-%m-%dT%H:%M:%SZ)" "$acq_step_commit" \
      "${ACQ_STEP_PREFIX:-}" "$acq_step_name" "$took" >>"$ACQ_STEP_LOG"
  fi
  acq_step_name=""
}

step() {
  end_step
  acq_step_name="$*"
  acq_step_started=$SECONDS
  printf '\n== %s (at %d s)\n' "$*" "$SECONDS"
}
