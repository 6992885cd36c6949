// @ts-check
// What the page says of a calibration: while it runs, the progress bar's share, the status line
// and the time line (elapsed, and the time left once there is a measure of it) from the worker's
// progress messages; then the status line for the results. Each message names its stage and
// the stages its method goes through (`stages`, the library's plan): the sensors aligned
// globally, the views prepared, JRMPC's or `cad`'s iterations, the frame pairs registered, the
// result made. Each stage has its share of one bar, so the bar moves in every stage.

// Shares of a method's bar by stage, before normalising over the stages it runs. Measured in the
// page on the real rigs (2 workers): on the Livox rig the global stage takes 1.5 s, `views` 15 s,
// its two frame pairs 6 s each; on the twins JRMPC takes about four fifths of what follows
// `views`.
const SHARES = { global: 0.08, views: 0.3, jrmpc: 0.42, cad: 0.42, framePairs: 0.15, finish: 0.05 };

// The stages that are one step (reported as they begin, with no count), and what each does, for
// the status line while it runs.
const STEPS = {
  views: 'levelling the grounds, the bird\'s-eye search and the crop to the ROI',
  finish: 'the plane adjustment and the verdict',
};

// Iterations measured before a time left is given: the first ones carry the setup (the input
// copied, the workers started, the first E-step's caches), so a rate from them overstates the rest
// (28.6 s left at the first iteration of a 2.1 s run). The global stage counts sensors and the
// frame pairs count pairs, each a long job of its own (6 s a pair on the Livox rig): one is a
// measure.
export const MIN_MEASURED = 3;
const MIN_MEASURED_JOBS = 1;
// Before a stage has a measure (and all through a step) the bar creeps towards this share
// of the next mark, with this time constant (s): it shows work going on, and claims nothing.
const CREEP_UNMEASURED = 0.6;
const CREEP_SECONDS = 8;
const creep = (seconds) => CREEP_UNMEASURED * (1 - Math.exp(-seconds / CREEP_SECONDS));

// The time left in a stage from the times of its progress messages: the rate since the stage's
// first message, once MIN_MEASURED iterations (`min`) have run since; null before and at the end.
export class StageClock {
  #first = null;
  #min;

  constructor(min = MIN_MEASURED) {
    this.#min = min;
  }

  // `p`: progress ({iteration, maxIterations}); `now`: seconds on any clock.
  left(p, now) {
    if (!this.#first || p.iteration < this.#first.iteration) this.#first = { iteration: p.iteration, at: now };
    const measured = p.iteration - this.#first.iteration;
    if (measured < this.#min || p.iteration >= p.maxIterations) return null;
    return ((now - this.#first.at) / measured) * (p.maxIterations - p.iteration);
  }
}

// {start, share} of `stage` in a method's bar running `stages`; a stage the plan did not expect
// (the library knows best) takes the rest of the bar from where it stands.
export function shareOf(stages, stage) {
  const total = stages.reduce((sum, s) => sum + SHARES[s], 0);
  const at = stages.indexOf(stage);
  if (at < 0) return null;
  const start = stages.slice(0, at).reduce((sum, s) => sum + SHARES[s], 0) / total;
  return { start, share: SHARES[stage] / total };
}

// {fraction, text} for progress `p` of a method running `stages` (its plan); `left`: seconds
// left in the stage (StageClock), or null; `done`: the share of the stage done (by default
// p.iteration / p.maxIterations; more between the global stage's messages, see RunProgress).
export function describeProgress(stages, p, left = null, done = p.iteration / p.maxIterations) {
  const place = shareOf(stages, p.stage) ?? { start: 0, share: 1 };
  const fraction = place.start + place.share * Math.min(1, done);
  const eta = left !== null && Number.isFinite(left) ? `, about ${left.toFixed(1)} s left` : '';
  if (p.stage === 'global') {
    return { fraction, text: `global alignment: ${p.iteration} of ${p.maxIterations} sensors aligned${eta}` };
  }
  if (p.stage === 'framePairs') return { fraction, text: `frame pair ${p.iteration}/${p.maxIterations}${eta}` };
  if (STEPS[p.stage]) return { fraction, text: STEPS[p.stage] };
  const sigma = `σ ${(p.meanSigma * 100).toFixed(2)} cm`;
  if (p.stage === 'cad') return { fraction, text: `CAD iteration ${p.iteration}/${p.maxIterations}, ${sigma}${eta}` };
  const then = stages.includes('framePairs') ? ', then the frame pairs' : '';
  return { fraction, text: `JRMPC iteration ${p.iteration}/${p.maxIterations}, ${sigma}${eta}${then}` };
}

// One run's progress over its methods (`names`, in order) and their stages (as each message's
// `stages` plans them), on a clock of seconds (`now`). `message(p, now)` takes each progress
// message; `at(now)` says where the run stands at any moment, so the bar, the status line and a
// time line move between messages, and through the steps that send one message: {fraction,
// text, elapsed, left} with `left` the seconds left in the current stage (counted down since it
// was measured) or null.
export class RunProgress {
  #names;
  #started;
  #last = null; // {key, clock, p, at, leftAt: {left, at} | null}

  constructor(names, now) {
    this.#names = names;
    this.#started = now;
  }

  message(p, now) {
    const key = `${p.method}/${p.stage}`;
    if (key !== this.#last?.key) {
      const min = p.stage === 'global' || p.stage === 'framePairs' ? MIN_MEASURED_JOBS : MIN_MEASURED;
      this.#last = { key, clock: new StageClock(min) };
    }
    const last = this.#last;
    const left = last.clock.left(p, now);
    Object.assign(last, { p, at: now, leftAt: left === null ? null : { left, at: now } });
    return this.at(now);
  }

  // Where the run stands at `now`.
  at(now) {
    const elapsed = now - this.#started;
    const last = this.#last;
    // Before the first message (the run's first step begins at once).
    if (!last) return { fraction: 0, text: null, elapsed, left: null };
    const { p } = last;
    const stages = p.stages ?? [];
    const index = Math.max(0, this.#names.indexOf(p.method));
    const label = this.#names.length > 1 ? `${p.method} (${index + 1}/${this.#names.length}): ` : '';
    const of = (fraction) => (index + fraction) / this.#names.length;
    const since = now - last.at;
    const left = last.leftAt && Math.max(0, last.leftAt.left - (now - last.leftAt.at));
    // A step: the bar creeps through its share, and the status says what it does.
    if (STEPS[p.stage]) {
      const { fraction, text } = describeProgress(stages, p, null, creep(since));
      return { fraction: of(fraction), text: label + text, elapsed, left: null };
    }
    // Between messages seconds apart (a sensor aligned, a frame pair), the bar moves by the time
    // measured per step, or by the creep before there is a measure; never to the next mark.
    let done = p.iteration / p.maxIterations;
    if ((p.stage === 'global' || p.stage === 'framePairs') && p.iteration < p.maxIterations) {
      const partial = last.leftAt ? Math.min(0.9, since / (last.leftAt.left / (p.maxIterations - p.iteration))) : creep(since);
      done += partial / p.maxIterations;
    }
    const { fraction, text } = describeProgress(stages, p, null, done);
    return { fraction: of(fraction), text: label + text, elapsed, left };
  }
}

// The time line under the bar: "12.3 s elapsed, about 8 s left in this stage".
export function describeTime({ elapsed, left }) {
  const stage = left !== null && left !== undefined ? `, about ${Math.ceil(left)} s left in this stage` : '';
  return `${elapsed.toFixed(1)} s elapsed${stage}`;
}

// The status line once `results` (one per method run) are in, `seconds` after the click.
/**
 * @param {import('../result').PageResult[]} results @param {number} seconds
 * @param {import('../result').MethodFailure[]} [failures]
 */
export function describeDone(results, seconds, failures = []) {
  const r = results[0];
  const workers = r.workers > 1 ? ` on ${r.workers} workers` : '';
  const on = r.eStepDevice === 'gpu' ? `${workers}, E-step on the GPU (${r.gpu})` : `${workers}${r.exact ? ', exact E-step' : ''}`;
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
