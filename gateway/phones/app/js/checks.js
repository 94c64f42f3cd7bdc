// The gateway's own quality gate (processing/capture/quality.py), run on the phone on every preview frame, with the
// thresholds and guidance the gateway serves (GET /api/v1/capture/settings): greyscale at the gateway's analysis
// size, the Laplacian's variance over the central tiles (75th percentile, exactly as the gateway computes it), mean
// grey level and clipping (from every second pixel each way: a statistic, not an edge), and the printed marker found
// by the vendored js-aruco2 detector, with the gateway's own dictionary codes, on a smaller copy (MARKER_LONG_SIDE).
// The gateway's verdict on the uploaded photo replaces this one; where they disagree the photo records it.
const GRID_COLS = 8;
const GRID_ROWS = 6;
const MARKER_LONG_SIDE = 640;
/* A 20 mm marker at arm's length spans about 30 px here, 5 px a cell: enough to read, and half the pixels of the
   gateway's analysis size, where the detector's contour search costs most. */

let detector = null;
const markerCanvas = document.createElement("canvas");

function markerDetector(marker) {
  if (!detector && window.AR) {
    window.AR.DICTIONARIES.BURNEDGE = { nBits: marker.bits, tau: marker.max_correction_bits + 1, codeList: marker.codes };
    detector = new window.AR.Detector({ dictionaryName: "BURNEDGE" });
  }
  return detector;
}

function draw(canvas, source, w, h) {
  canvas.width = w;
  canvas.height = h;
  const context = canvas.getContext("2d", { willReadFrequently: true });
  context.drawImage(source, 0, 0, w, h);
  return context.getImageData(0, 0, w, h);
}

// The frame's pixels at the gateway's analysis size (long side), and the scale to full resolution.
export function analysisFrame(source, width, height, longSide, canvas) {
  const scale = Math.min(1, longSide / Math.max(width, height));
  const w = Math.round(width * scale);
  const h = Math.round(height * scale);
  return { image: draw(canvas, source, w, h), canvas, w, h, scale };
}

const luma = (rgba, p) => Math.round(0.299 * rgba[p] + 0.587 * rgba[p + 1] + 0.114 * rgba[p + 2]);

export function figures(frame, quality) {
  const { image, w, h } = frame;
  const rgba = image.data;
  let sum = 0;
  let dark = 0;
  let bright = 0;
  let n = 0;
  for (let y = 0; y < h; y += 2) {
    for (let x = 0, p = y * w * 4; x < w; x += 2, p += 8) {
      const v = luma(rgba, p);
      sum += v;
      n += 1;
      if (v <= quality.dark_level) dark += 1;
      if (v >= quality.bright_level) bright += 1;
    }
  }
  return {
    local_sharpness: centralSharpness(rgba, w, h),
    mean_intensity: sum / n,
    dark_fraction: dark / n,
    bright_fraction: bright / n,
  };
}

// The Laplacian (OpenCV's 3x3 kernel; the central tiles never reach the border) over the central tiles of an 8 x 6
// grid, each tile's variance, and their 75th percentile (numpy's linear interpolation). Grey levels are made only
// for the central rows, the band the Laplacian reads.
function centralSharpness(rgba, w, h) {
  const top = Math.floor(h / GRID_ROWS) - 1;
  const bottom = Math.floor(((GRID_ROWS - 1) * h) / GRID_ROWS) + 1;
  const gray = new Uint8Array(w * (bottom - top));
  for (let y = top, i = 0; y < bottom; y += 1) {
    for (let x = 0, p = y * w * 4; x < w; x += 1, p += 4, i += 1) gray[i] = luma(rgba, p);
  }
  const variances = [];
  for (let r = 1; r < GRID_ROWS - 1; r += 1) {
    for (let c = 1; c < GRID_COLS - 1; c += 1) {
      const y0 = Math.floor((r * h) / GRID_ROWS);
      const y1 = Math.floor(((r + 1) * h) / GRID_ROWS);
      const x0 = Math.floor((c * w) / GRID_COLS);
      const x1 = Math.floor(((c + 1) * w) / GRID_COLS);
      let s = 0;
      let s2 = 0;
      for (let y = y0; y < y1; y += 1) {
        for (let x = x0, i = (y - top) * w + x0; x < x1; x += 1, i += 1) {
          const lap = gray[i - 1] + gray[i + 1] + gray[i - w] + gray[i + w] - 4 * gray[i];
          s += lap;
          s2 += lap * lap;
        }
      }
      const n = (y1 - y0) * (x1 - x0);
      variances.push(s2 / n - (s / n) ** 2);
    }
  }
  variances.sort((a, b) => a - b);
  const k = 0.75 * (variances.length - 1);
  const lo = Math.floor(k);
  return variances[lo] + (k - lo) * (variances[Math.min(lo + 1, variances.length - 1)] - variances[lo]);
}

export function findMarkers(frame, marker) {
  const found = markerDetector(marker);
  if (!found) return [];
  const scale = Math.min(1, MARKER_LONG_SIDE / Math.max(frame.w, frame.h));
  const image = scale < 1 ? draw(markerCanvas, frame.canvas, Math.round(frame.w * scale), Math.round(frame.h * scale)) : frame.image;
  const toFull = frame.scale * (scale < 1 ? scale : 1);
  return found.detect(image).map((m) => {
    const corners = m.corners.map((p) => ({ x: p.x / toFull, y: p.y / toFull }));
    let side = 0;
    for (let i = 0; i < 4; i += 1) {
      const a = corners[i];
      const b = corners[(i + 1) % 4];
      side += Math.hypot(a.x - b.x, a.y - b.y) / 4;
    }
    return { id: m.id, side_px: side, corners };
  });
}

// The same reasons, in the same order, as the gateway's judge().
export function judge(f, markers, width, height, quality) {
  const reasons = [];
  if (Math.max(width, height) < quality.min_width || Math.min(width, height) < quality.min_height) reasons.push("too_small");
  if (f.local_sharpness < quality.min_local_sharpness) reasons.push("blurry");
  if (f.mean_intensity < quality.min_mean_intensity || f.dark_fraction > quality.max_dark_fraction) reasons.push("too_dark");
  if (f.mean_intensity > quality.max_mean_intensity || f.bright_fraction > quality.max_bright_fraction) reasons.push("too_bright");
  if (!markers.length) reasons.push("no_marker");
  else if (Math.max(...markers.map((m) => m.side_px)) < quality.min_marker_side_px) reasons.push("marker_too_small");
  return reasons;
}

export function check(source, width, height, settings, canvas) {
  const t0 = performance.now();
  const frame = analysisFrame(source, width, height, settings.quality.analysis_long_side, canvas);
  const t1 = performance.now();
  const f = figures(frame, settings.quality);
  const t2 = performance.now();
  const markers = findMarkers(frame, settings.marker);
  const t3 = performance.now();
  const reasons = judge(f, markers, width, height, settings.quality);
  return {
    accepted: !reasons.some((r) => settings.rejecting.includes(r)),
    reasons,
    guidance: reasons.map((r) => settings.guidance[r]),
    figures: { ...f, markers },
    ms: t3 - t0,
    phases: { frame: t1 - t0, figures: t2 - t1, marker: t3 - t2 },
  };
}
