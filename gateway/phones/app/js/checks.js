// The gateway's own quality gate (processing/capture/quality.py), run on the phone on every preview frame, with the
// thresholds and guidance the gateway serves (GET /api/v1/capture/settings): grey levels at the gateway's analysis
// size (frames.js), the Laplacian's variance over the central tiles (75th percentile, exactly as the gateway
// computes it), mean grey level and clipping (from every second pixel each way: a statistic, not an edge), and the
// printed marker found by the vendored js-aruco2 detector, with the gateway's own dictionary codes, on a half-size
// copy: first around where it was in the last frame, over the whole frame when it is not there.
// The gateway's verdict on the uploaded photo replaces this one; where they disagree the photo records it.
import { grayFrame, halfSize } from "./frames.js";

const GRID_COLS = 8;
const GRID_ROWS = 6;
const MARKER_HALF_FROM = 800;
/* At half the gateway's analysis size (500 px), a 20 mm marker at arm's length spans about 25 px, 4 px a cell:
   enough to read, and a quarter of the pixels, where the detector's thresholding and contour search cost most. */
const TRACK_MARGIN = 0.75;
/* Around the last marker, this many marker sides each way: a hand's drift between two checks. */

let detector = null;
let last = null; // the marker's corners in the last frame, at the analysis size

function markerDetector(marker) {
  if (!detector && window.AR) {
    window.AR.DICTIONARIES.BURNEDGE = { nBits: marker.bits, tau: marker.max_correction_bits + 1, codeList: marker.codes };
    detector = new window.AR.Detector({ dictionaryName: "BURNEDGE" });
  }
  return detector;
}

const SAME_LEVELS = Uint8Array.from({ length: 256 }, (_, i) => i);

export function figures(frame, quality) {
  const { gray, stride, w, h } = frame;
  const levels = frame.levels || SAME_LEVELS;
  let sum = 0;
  let dark = 0;
  let bright = 0;
  let n = 0;
  for (let y = 0; y < h; y += 2) {
    for (let x = 0, i = y * stride; x < w; x += 2, i += 2) {
      const v = levels[gray[i]];
      sum += v;
      n += 1;
      if (v <= quality.dark_level) dark += 1;
      if (v >= quality.bright_level) bright += 1;
    }
  }
  return {
    local_sharpness: centralSharpness(gray, stride, w, h) * (frame.levels ? (255 / 219) ** 2 : 1),
    mean_intensity: sum / n,
    dark_fraction: dark / n,
    bright_fraction: bright / n,
  };
}

// The Laplacian (OpenCV's 3x3 kernel; the central tiles never reach the border) over the central tiles of an 8 x 6
// grid, each tile's variance, and their 75th percentile (numpy's linear interpolation). On video-range levels the
// variance is scaled to full range (the Laplacian is linear; only rounding differs).
function centralSharpness(gray, stride, w, h) {
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
        for (let x = x0, i = y * stride + x0; x < x1; x += 1, i += 1) {
          const lap = gray[i - 1] + gray[i + 1] + gray[i - stride] + gray[i + stride] - 4 * gray[i];
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

// js-aruco2's Detector.detect, from grey levels we already have (it would make them again from RGBA) and with typed
// buffers (its own are growing arrays); outlines shorter than `minPerimeter` are not looked at.
function detectIn(found, gray, w, h, minPerimeter) {
  const CV = window.CV;
  if (found.thres.data.length !== w * h) {
    found.thres = new CV.Image(w, h, new Uint8Array(w * h));
    found.binary = new Int32Array((w + 2) * (h + 2));
  }
  const grey = new CV.Image(w, h, gray);
  CV.adaptiveThreshold(grey, found.thres, 2, 7);
  let candidates = found.findCandidates(CV.findContours(found.thres, found.binary), minPerimeter, 0.05, 10);
  candidates = found.notTooNear(found.clockwiseCorners(candidates), 10);
  return found.findMarkers(grey, candidates, 49);
}

// The markers in view, their corners and side at full resolution. The search runs on a half-size copy (of a frame
// at least MARKER_HALF_FROM long): around the last marker when there was one, else (or when it has gone from
// there) over the whole frame. A marker under half the gateway's smallest side (`minSidePx`, full resolution) is
// not looked for: its outline is one of thousands the skin's texture makes, and it would be too small anyway.
export function findMarkers(frame, marker, minSidePx = 0) {
  const found = markerDetector(marker);
  if (!found) return [];
  const small = Math.max(frame.w, frame.h) >= MARKER_HALF_FROM ? halfSize(frame.gray, frame.stride, frame.w, frame.h) : frame;
  const k = small.w / frame.w;
  const minPerimeter = Math.max(small.w * 0.01, 4 * (minSidePx / 2) * frame.scale * k);
  const rowLength = small.stride || small.w;
  const search = (x0, y0, w, h) => {
    let gray = small.gray;
    if (w !== small.w || h !== small.h || rowLength !== w) {
      gray = new Uint8Array(w * h);
      for (let y = 0; y < h; y += 1) gray.set(small.gray.subarray((y0 + y) * rowLength + x0, (y0 + y) * rowLength + x0 + w), y * w);
    }
    return detectIn(found, gray, w, h, minPerimeter).map((m) => ({
      id: m.id,
      corners: m.corners.map((p) => ({ x: (x0 + p.x) / k, y: (y0 + p.y) / k })),
    }));
  };
  let markers = [];
  if (last) {
    const xs = last.map((p) => p.x * k);
    const ys = last.map((p) => p.y * k);
    const side = Math.max(Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys));
    const x0 = Math.max(0, Math.floor(Math.min(...xs) - TRACK_MARGIN * side));
    const y0 = Math.max(0, Math.floor(Math.min(...ys) - TRACK_MARGIN * side));
    const x1 = Math.min(small.w, Math.ceil(Math.max(...xs) + TRACK_MARGIN * side));
    const y1 = Math.min(small.h, Math.ceil(Math.max(...ys) + TRACK_MARGIN * side));
    markers = search(x0, y0, x1 - x0, y1 - y0);
  }
  if (!markers.length) markers = search(0, 0, small.w, small.h);
  last = markers.length ? markers[0].corners : null;
  return markers.map((m) => {
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

export async function check(source, width, height, settings, canvas) {
  const t0 = performance.now();
  const frame = await grayFrame(source, width, height, settings.quality.analysis_long_side, canvas);
  const t1 = performance.now();
  const f = figures(frame, settings.quality);
  const t2 = performance.now();
  const markers = findMarkers(frame, settings.marker, settings.quality.min_marker_side_px);
  const t3 = performance.now();
  const reasons = judge(f, markers, width, height, settings.quality);
  return {
    accepted: !reasons.some((r) => settings.rejecting.includes(r)),
    reasons,
    guidance: reasons.map((r) => settings.guidance[r]),
    figures: { ...f, markers },
    ms: t3 - t0,
    phases: { frame: t1 - t0, figures: t2 - t1, marker: t3 - t2 },
    source: frame.source,
  };
}
