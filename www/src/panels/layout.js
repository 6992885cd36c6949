// The page's layout: the side panel resizable (drag the separator, or arrow keys on it) and
// collapsible (the header's Panel button), its width kept for the next visit; the panels'
// one-line summaries, and folding the setup panels away once there is an answer to read.
const KEY = 'gmmcalib.sideWidth';
const MIN_SIDE = 300;
const MIN_VIEW = 320;
const STEP = 24;

export function initLayout({ main, side, resizer, toggle }) {
  const clamp = (w) => Math.round(Math.max(MIN_SIDE, Math.min(w, window.innerWidth - MIN_VIEW)));
  const setWidth = (w) => {
    const width = clamp(w);
    main.style.setProperty('--side', `${width}px`);
    resizer.setAttribute('aria-valuenow', String(width));
    try {
      localStorage.setItem(KEY, String(width));
    } catch { /* storage refused: the width lasts this visit */ }
  };
  let stored = null;
  try {
    stored = Number(localStorage.getItem(KEY));
  } catch { /* none */ }
  if (stored > 0) setWidth(stored);
  resizer.setAttribute('aria-valuemin', String(MIN_SIDE));
  resizer.addEventListener('pointerdown', (e) => {
    resizer.setPointerCapture(e.pointerId);
    const start = { x: e.clientX, width: side.getBoundingClientRect().width };
    const move = (m) => setWidth(start.width + m.clientX - start.x);
    resizer.addEventListener('pointermove', move);
    resizer.addEventListener('pointerup', () => resizer.removeEventListener('pointermove', move), { once: true });
  });
  resizer.addEventListener('keydown', (e) => {
    const width = side.getBoundingClientRect().width;
    const by = { ArrowLeft: -STEP, ArrowRight: STEP }[e.key];
    if (by) {
      e.preventDefault();
      setWidth(width + by);
    }
  });
  toggle.addEventListener('click', () => {
    const hidden = main.classList.toggle('side-hidden');
    toggle.setAttribute('aria-expanded', String(!hidden));
  });
}

// The inset of the reconstructed target: shown once it has something to show, hidden by its
// close button until the next result.
export function initInset(inset, close) {
  close.addEventListener('click', () => (inset.hidden = true));
  return { show: (on) => (inset.hidden = !on) };
}

// Folds the setup panels (their summaries stay, one line each) so the results are in view.
export function foldSetup(panels, side) {
  for (const panel of panels) panel.open = false;
  side.scrollTop = 0;
}
