// What the main view shows, measured on its pixels (a screenshot of the canvas): where the
// points coloured by sensor lie, so a test can say the data fill and centre the view.
const PALETTE = [[0xff, 0x6b, 0x6b], [0x4d, 0xab, 0xf7], [0x69, 0xdb, 0x7c], [0xff, 0xd4, 0x3b], [0xda, 0x77, 0xf2], [0xff, 0x92, 0x2b], [0x38, 0xd9, 0xa9], [0xf7, 0x83, 0xac]];

// {count, spread: [x, y] (the 5th-95th percentile's extent as a share of the view's width and
// height), centre: [x, y] (the median, as a share)} of the pixels showing a sensor's points.
export async function dataPixels(page) {
  const box = await page.locator('#view').boundingBox();
  const png = await page.screenshot({ clip: box });
  return page.evaluate(async ([data, palette]) => {
    const bitmap = await createImageBitmap(new Blob([Uint8Array.from(atob(data), (c) => c.charCodeAt(0))], { type: 'image/png' }));
    const ctx = new OffscreenCanvas(bitmap.width, bitmap.height).getContext('2d');
    ctx.drawImage(bitmap, 0, 0);
    const { data: px, width, height } = ctx.getImageData(0, 0, bitmap.width, bitmap.height);
    const xs = [], ys = [];
    for (let y = 0; y < height; y += 2) {
      for (let x = 0; x < width; x += 2) {
        const i = 4 * (y * width + x);
        if (palette.some(([r, g, b]) => Math.abs(px[i] - r) + Math.abs(px[i + 1] - g) + Math.abs(px[i + 2] - b) < 30)) xs.push(x / width), ys.push(y / height);
      }
    }
    const q = (v, f) => v.sort((a, b) => a - b)[Math.floor(f * (v.length - 1))];
    if (!xs.length) return { count: 0 };
    return { count: xs.length, spread: [q(xs, 0.95) - q(xs, 0.05), q(ys, 0.95) - q(ys, 0.05)], centre: [q(xs, 0.5), q(ys, 0.5)] };
  }, [png.toString('base64'), PALETTE]);
}

// Waits until the view has drawn another frame after `act()`, then settles.
export async function afterFrame(page, act) {
  const n = await page.locator('#view').evaluate((v) => Number(v.dataset.frames ?? 0));
  await act();
  await page.waitForFunction((k) => Number(document.querySelector('#view').dataset.frames) > k, n);
  await page.waitForTimeout(300);
}
