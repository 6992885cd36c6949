// What Save PNG draws over the view, in the render worker on a 2D canvas over the WebGL frame: a
// PNG of the points alone says nothing of which colour is which sensor, what a colour scale
// spans, or whether the calibration shown was any good. So: the verdict line across the top (in
// its level's colours), the sensors' legend at the top left (or the colour bar, with its title
// and range, at the bottom right when the points are coloured by a value), and what is shown
// (before or after calibration) at the bottom left.

const LEVEL = {
  good: { fill: '#12281a', stroke: '#2f9e44' },
  check: { fill: '#2b2410', stroke: '#f59f00' },
  failed: { fill: '#2c1215', stroke: '#e03131' },
};
const TEXT = '#dde3ea';
const PANEL = 'rgba(21, 24, 29, 0.88)';

// `overlay`: {verdict: {level, text} | null, legend: [{name, colour (css)}], scale: {title,
// lo, hi, stops: [css colours]} | null, caption}. `scale`: device pixels per CSS pixel.
export function drawOverlay(ctx, width, height, overlay, scale = 1) {
  const px = (n) => Math.round(n * scale);
  ctx.save();
  ctx.textBaseline = 'middle';
  ctx.font = `${px(13)}px system-ui, sans-serif`;
  let top = px(8);
  if (overlay.verdict) {
    const colours = LEVEL[overlay.verdict.level] ?? LEVEL.check;
    const h = px(26);
    ctx.fillStyle = colours.fill;
    ctx.strokeStyle = colours.stroke;
    ctx.lineWidth = px(1);
    ctx.fillRect(px(8), top, width - px(16), h);
    ctx.strokeRect(px(8), top, width - px(16), h);
    ctx.fillStyle = TEXT;
    ctx.font = `bold ${px(13)}px system-ui, sans-serif`;
    ctx.fillText(fit(ctx, overlay.verdict.text, width - px(32)), px(16), top + h / 2);
    ctx.font = `${px(13)}px system-ui, sans-serif`;
    top += h + px(6);
  }
  if (overlay.legend.length) {
    const row = px(18);
    const w = Math.max(...overlay.legend.map((s) => ctx.measureText(s.name).width)) + px(34);
    ctx.fillStyle = PANEL;
    ctx.fillRect(px(8), top, w, row * overlay.legend.length + px(8));
    overlay.legend.forEach((s, i) => {
      const y = top + px(4) + row * i + row / 2;
      ctx.fillStyle = s.colour;
      ctx.beginPath();
      ctx.arc(px(20), y, px(5), 0, 2 * Math.PI);
      ctx.fill();
      ctx.fillStyle = TEXT;
      ctx.fillText(s.name, px(32), y);
    });
  }
  if (overlay.scale) {
    const { title, lo, hi, stops } = overlay.scale;
    const [w, h] = [px(220), px(56)];
    const [x, y] = [width - w - px(8), height - h - px(8)];
    ctx.fillStyle = PANEL;
    ctx.fillRect(x, y, w, h);
    ctx.fillStyle = TEXT;
    ctx.font = `${px(11)}px system-ui, sans-serif`;
    ctx.fillText(fit(ctx, title, w - px(12)), x + px(6), y + px(10));
    const gradient = ctx.createLinearGradient(x + px(6), 0, x + w - px(6), 0);
    stops.forEach((c, i) => gradient.addColorStop(i / Math.max(1, stops.length - 1), c));
    ctx.fillStyle = gradient;
    ctx.fillRect(x + px(6), y + px(20), w - px(12), px(12));
    ctx.fillStyle = TEXT;
    ctx.fillText(lo, x + px(6), y + px(45));
    ctx.textAlign = 'right';
    ctx.fillText(hi, x + w - px(6), y + px(45));
    ctx.textAlign = 'left';
  }
  if (overlay.caption) {
    ctx.font = `${px(12)}px system-ui, sans-serif`;
    const w = ctx.measureText(overlay.caption).width + px(12);
    ctx.fillStyle = PANEL;
    ctx.fillRect(px(8), height - px(30), w, px(22));
    ctx.fillStyle = TEXT;
    ctx.fillText(overlay.caption, px(14), height - px(19));
  }
  ctx.restore();
}

// `text` cut with an ellipsis to `width` pixels.
function fit(ctx, text, width) {
  if (ctx.measureText(text).width <= width) return text;
  let n = text.length;
  while (n > 1 && ctx.measureText(`${text.slice(0, n)}…`).width > width) n--;
  return `${text.slice(0, n)}…`;
}
