#!/usr/bin/env bash
# Runs each recording fuzz target for 5 minutes, one at a time (the machine has two cores);
# corpora in corpus/<target> (git-ignored) seeded from seeds/<target>; logs in
# artifacts/fuzz-<target>.log.
set -u
cd "$(dirname "$0")"
mkdir -p artifacts
for t in "$@"; do
  mkdir -p corpus/$t
  cargo +nightly fuzz run $t corpus/$t seeds/$t -- -max_total_time=300 -jobs=1 -rss_limit_mb=2048 > artifacts/fuzz-$t.log 2>&1
  rc=$?; mv -f fuzz-0.log artifacts/fuzz-$t-0.log 2>/dev/null; echo "$t exit $rc" >> artifacts/fuzz-summary.log
done
