#!/usr/bin/env bash
# Runs each recording fuzz target for 5 minutes, one at a time (the machine has two cores);
# corpora in a scratch folder seeded from seeds/<target>; log in /tmp/fuzz-<target>.log.
set -u
cd "$(dirname "$0")"
for t in "$@"; do
  mkdir -p /tmp/corpus/$t
  cargo +nightly fuzz run $t /tmp/corpus/$t seeds/$t -- -max_total_time=300 -jobs=1 -rss_limit_mb=2048 > /tmp/fuzz-$t.log 2>&1
  rc=$?; mv -f fuzz-0.log /tmp/fuzz-$t-0.log 2>/dev/null; echo "$t exit $rc" >> /tmp/fuzz-summary.log
done
