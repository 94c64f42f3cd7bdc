// The gateway's own quality gate (processing/capture/quality.py), run on the phone on every preview frame, with the
// thresholds and guidance the gateway serves (GET /api/v1/capture/settings): greyscale at the gateway's analysis
// size, the Laplacian's variance over the central tiles (75th percentile), mean grey level and clipping, and the
// printed marker found with the vendored js-aruco2 detector using the gateway's own dictionary codes. The gateway's
// verdict on the uploaded photo replaces this one; where they disagree the photo records it.
const GRID_COLS = 8;
const GRID_ROWS = 6;

let detector = null;

function markerDetector(marker) {
  if (!detector && window.AR) {
    window.AR.DICTIONARIES.BURNEDGE = { nBits: marker.bits, tau: marker.max_correction_bits + 1, codeList: marker.codes };
    detector = new window.AR.Detector({ dictionaryName: "BURNEDGE" });
  }
  return detector;
}

// Grey levels of the frame at the gateway's analysis size (long side), and the scale to full resolution.
export function analysisFrame(source, width, height, longSide, canvas) {
  const scale = Math.min(1, longSide / Math.max(width, height));
  const w = Math.round(width * scale);
  const h = Math.round(height * scale);
  canvas.width = w;
  canvas.height = h;
  const context = canvas.getContext("2d", { willReadFrequently: true });
  context.imageSmoothingQuality = "high";
  context.drawImage(source, 0, 0, w, h);
  return { image: context.getImageData(0, 0, w, h), w, h, scale };
}

export function figures(frame, quality) {
  const { image, w, h } = frame;
  const rgba = image.data;
  const gray = new Uint8Array(w * h);
  let sum = 0;
  let dark = 0;
  let bright = 0;
  for (let i = 0, p = 0; i < gray.length; i += 1, p += 4) {
    const y = Math.round(0.299 * rgba[p] + 0.587 * rgba[p + 1] + 0.114 * rgba[p + 2]);
    gray[i] = y;
    sum += y;
    if (y <= quality.dark_level) dark += 1;
    if (y >= quality.bright_level) bright += 1;
  }
  return {
    local_sharpness: centralSharpness(gray, w, h),
    mean_intensity: sum / gray.length,
    dark_fraction: dark / gray.length,
    bright_fraction: bright / gray.length,
  };
}

// The Laplacian (OpenCV's 3x3 kernel; the central tiles never reach the border) over the central tiles of an 8 x 6
// grid, each tile's variance, and their 75th percentile (numpy's linear interpolation).
function centralSharpness(gray, w, h) {
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
        for (let x = x0; x < x1; x += 1) {
          const i = y * w + x;
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
  return variances[lo] + (k - lo) * ((variances[Math.min(lo + 1, variances.length - 1)] ?? 0) - variances[lo]);
}

export function findMarkers(frame, marker) {
  const found = markerDetector(marker)?.detect(frame.image) || [];
  return found.map((m) => {
    const corners = m.corners.map((p) => ({ x: p.x / frame.scale, y: p.y / frame.scale }));
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
  const started = performance.now();
  const frame = analysisFrame(source, width, height, settings.quality.analysis_long_side, canvas);
  const f = figures(frame, settings.quality);
  const markers = findMarkers(frame, settings.marker);
  const reasons = judge(f, markers, width, height, settings.quality);
  return {
    accepted: !reasons.some((r) => settings.rejecting.includes(r)),
    reasons,
    guidance: reasons.map((r) => settings.guidance[r]),
    figures: { ...f, markers },
    ms: performance.now() - started,
  };
}
