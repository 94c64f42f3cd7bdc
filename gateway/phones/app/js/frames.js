// A preview frame as grey levels at the gateway's analysis size: { gray, stride, w, h, scale, levels }, where
// `levels` maps a stored level to the gateway's grey level (the camera's video range 16-235 to 0-255), null when
// they are the same. Where the browser has WebCodecs, the camera's own luma plane is copied out of the frame and
// read in place (no colour conversion, no canvas, no copy); elsewhere the frame is drawn on a canvas
// and its grey made from RGB with the gateway's weights (OpenCV's BGR2GRAY). The two differ by a few grey levels on
// strongly coloured pixels (the camera may weigh red, green and blue by BT.709 rather than BT.601); the thresholds
// are set far wider than that, and the gateway's own verdict on the photo replaces this one.
const LUMA_FORMATS = new Set(["I420", "I420A", "I422", "I444", "NV12"]);
const LIMITED_TO_FULL = Uint8Array.from({ length: 256 }, (_, y) => Math.max(0, Math.min(255, Math.round(((y - 16) * 255) / 219))));
let buffer = new Uint8Array(0);

export async function grayFrame(video, width, height, longSide, canvas) {
  const scale = Math.min(1, longSide / Math.max(width, height));
  const w = Math.round(width * scale);
  const h = Math.round(height * scale);
  const luma = await cameraLuma(video);
  if (luma) {
    const { plane, stride, pw, ph, full } = luma;
    const levels = full ? null : LIMITED_TO_FULL;
    if (pw === w && ph === h) return { gray: plane, stride, w, h, scale, levels, source: "luma" };
    return { gray: areaResize(plane, stride, 0, 0, pw, ph, w, h), stride: w, w, h, scale, levels, source: "luma" };
  }
  return { gray: canvasGray(video, w, h, canvas), stride: w, w, h, scale, levels: null, source: "canvas" };
}

async function cameraLuma(video) {
  if (!("VideoFrame" in window)) return null;
  let frame = null;
  try {
    frame = new window.VideoFrame(video);
    if (!LUMA_FORMATS.has(frame.format)) return null;
    const rect = frame.visibleRect;
    const size = frame.allocationSize({ rect });
    if (buffer.length < size) buffer = new Uint8Array(size);
    const [luma] = await frame.copyTo(buffer, { rect });
    const full = frame.colorSpace?.fullRange !== false;
    return { plane: buffer.subarray(luma.offset), stride: luma.stride, pw: rect.width, ph: rect.height, full };
  } catch {
    return null; // a frame the browser cannot copy out (no frame yet, or one held on the GPU): the canvas instead
  } finally {
    frame?.close();
  }
}

// Half the size each way, each pixel the mean of four (INTER_AREA at exactly one half).
export function halfSize(gray, stride, w, h) {
  const dw = w >> 1;
  const dh = h >> 1;
  const out = new Uint8Array(dw * dh);
  for (let y = 0; y < dh; y += 1) {
    for (let x = 0, i = 2 * y * stride, o = y * dw; x < dw; x += 1, i += 2, o += 1) {
      out[o] = (gray[i] + gray[i + 1] + gray[i + stride] + gray[i + stride + 1] + 2) >> 2;
    }
  }
  return { gray: out, w: dw, h: dh };
}

function canvasGray(video, w, h, canvas) {
  canvas.width = w;
  canvas.height = h;
  const context = canvas.getContext("2d", { willReadFrequently: true });
  context.drawImage(video, 0, 0, w, h);
  const rgba = context.getImageData(0, 0, w, h).data;
  const gray = new Uint8Array(w * h);
  for (let i = 0, p = 0; i < gray.length; i += 1, p += 4) {
    gray[i] = Math.round(0.299 * rgba[p] + 0.587 * rgba[p + 1] + 0.114 * rgba[p + 2]);
  }
  return gray;
}

// OpenCV's INTER_AREA for shrinking: every output pixel is the mean of the source area it covers, source pixels cut
// by the boundary counted by the part inside. Separable: rows first, then columns. The source is the rectangle
// (x0, y0, sw, sh) of a plane with the given stride.
export function areaResize(src, stride, x0, y0, sw, sh, dw, dh) {
  const across = areaWeights(sw, dw);
  const down = areaWeights(sh, dh);
  const rows = new Float32Array(sh * dw);
  for (let y = 0; y < sh; y += 1) {
    const line = (y0 + y) * stride + x0;
    for (let x = 0; x < dw; x += 1) {
      const { first, weights } = across[x];
      let sum = 0;
      for (let k = 0; k < weights.length; k += 1) sum += weights[k] * src[line + first + k];
      rows[y * dw + x] = sum;
    }
  }
  const out = new Uint8Array(dw * dh);
  for (let y = 0; y < dh; y += 1) {
    const { first, weights } = down[y];
    for (let x = 0; x < dw; x += 1) {
      let sum = 0;
      for (let k = 0; k < weights.length; k += 1) sum += weights[k] * rows[(first + k) * dw + x];
      out[y * dw + x] = Math.min(255, Math.round(sum));
    }
  }
  return out;
}

function areaWeights(n, m) {
  const step = n / m;
  const out = [];
  for (let i = 0; i < m; i += 1) {
    const start = i * step;
    const end = Math.min(n, start + step);
    const first = Math.floor(start);
    const weights = [];
    for (let j = first; j < end; j += 1) weights.push((Math.min(j + 1, end) - Math.max(j, start)) / step);
    out.push({ first, weights: Float32Array.from(weights) });
  }
  return out;
}
