// What the page says of a calibration: while it runs, the progress bar's share and the status
// line from the worker's progress messages; then the status line for the results. A calibration
// reports its stages: the sensors aligned globally (`gmm`, `cad`, when the global stage runs),
// JRMPC's iterations (`gmm`, `jrmpc`) or `cad`'s, then the frame pairs registered (`gmm`'s
// refinement, the ICP methods).

// Share of a method's bar for JRMPC when it also registers frame pairs: `gmm` spends about a
// fifth of its time on them (browser bench, both scales).
const JRMPC_SHARE_WITH_PAIRS = 0.8;

// Iterations measured before a time left is given: the first ones carry the setup (the input
// copied, the workers started, the first E-step's caches), so a rate from them overstates the rest
// (28.6 s left at the first iteration of a 2.1 s run).
export const MIN_MEASURED = 3;

// The time left in a stage from the times of its progress messages: the rate since the stage's
// first message, once MIN_MEASURED iterations have run since; null before and at the end.
export class StageClock {
  #first = null;

  // `p`: progress ({iteration, maxIterations}); `now`: seconds on any clock.
  left(p, now) {
    if (!this.#first || p.iteration < this.#first.iteration) this.#first = { iteration: p.iteration, at: now };
    const measured = p.iteration - this.#first.iteration;
    if (measured < MIN_MEASURED || p.iteration >= p.maxIterations) return null;
    return ((now - this.#first.at) / measured) * (p.maxIterations - p.iteration);
  }
}

// {fraction, text} for progress `p` of a method running `stages` ({jrmpc, pairs}, as the
// library's `methods()` lists them); `left`: seconds left in the stage (StageClock), or null.
export function describeProgress(stages, p, left = null) {
  const jrmpcShare = stages.jrmpc ? (stages.pairs ? JRMPC_SHARE_WITH_PAIRS : 1) : 0;
  const done = p.iteration / p.maxIterations;
  const eta = left !== null && Number.isFinite(left) ? `, about ${left.toFixed(1)} s left` : '';
  if (p.stage === 'global') {
    // Before the registration's bar: the bar waits at 0, the line counts the sensors.
    return { fraction: 0, text: `global alignment: ${p.iteration} of ${p.maxIterations} sensors aligned${eta}` };
  }
  if (p.stage === 'framePairs') {
    return { fraction: jrmpcShare + (1 - jrmpcShare) * done, text: `frame pair ${p.iteration}/${p.maxIterations}${eta}` };
  }
  const sigma = `σ ${(p.meanSigma * 100).toFixed(2)} cm`;
  if (p.stage === 'cad') return { fraction: done, text: `CAD iteration ${p.iteration}/${p.maxIterations}, ${sigma}${eta}` };
  const then = jrmpcShare < 1 ? ', then the frame pairs' : '';
  return { fraction: jrmpcShare * done, text: `JRMPC iteration ${p.iteration}/${p.maxIterations}, ${sigma}${eta}${then}` };
}

// The status line once `results` (one per method run) are in, `seconds` after the click.
export function describeDone(results, seconds, failures = []) {
  const r = results[0];
  const workers = r.workers > 1 ? ` on ${r.workers} workers` : '';
  const on = r.estep === 'gpu' ? `${workers}, E-step on the GPU (${r.gpu})` : `${workers}${r.exact ? ', exact E-step' : ''}`;
  if (failures.length) {
    const failed = failures.map((f) => f.method).join(', ');
    return `Done: ${results.length} of ${results.length + failures.length} methods in ${seconds.toFixed(1)} s${on}; ${failed} failed (see Results).`;
  }
  let what;
  if (results.length > 1) what = `${results.length} methods`;
  else if (r.iterations > 0) what = `${r.iterations} iterations${r.converged ? ' (converged)' : ''}`;
  else {
    // An ICP method: no EM, the frame pairs averaged.
    const pairs = r.sensors.filter((s) => s.name !== r.reference).reduce((n, s) => n + s.spread.frames, 0);
    what = `${pairs} frame pair${pairs === 1 ? '' : 's'} registered`;
  }
  return `Done: ${what} in ${seconds.toFixed(1)} s${on}.`;
}
