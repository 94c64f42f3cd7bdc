// Where the phone was when each good photo was taken, from the printed marker's pose (the vendored POSIT solver),
// and the ring of angles around the burn that still lack one. The ring asks for the number of views the gateway
// recommends ([readiness] recommended_views): a reconstruction needs the burn seen from all round.
const STRAIGHT_ON_DEG = 12;

// Distance (mm) and tilt (degrees from straight on) of the camera to the marker, and the direction it looks from
// around the marker (degrees); null when the marker is not in view.
export function pose(marker, frameWidth, frameHeight, sideMm, focal35mm) {
  if (!marker || !window.POS) return null;
  const focal = (focal35mm / 36) * Math.max(frameWidth, frameHeight);
  const corners = marker.corners.map((p) => ({ x: p.x - frameWidth / 2, y: -(p.y - frameHeight / 2) }));
  const found = new window.POS.Posit(sideMm, focal).pose(corners);
  const [r, t] = [found.bestRotation, found.bestTranslation];
  const distance = Math.hypot(t[0], t[1], t[2]);
  const tilt = (Math.acos(Math.min(1, Math.abs(r[2][2]))) * 180) / Math.PI;
  // The camera's position in the marker's own axes: -R^T t.
  const px = -(r[0][0] * t[0] + r[1][0] * t[1] + r[2][0] * t[2]);
  const py = -(r[0][1] * t[0] + r[1][1] * t[1] + r[2][1] * t[2]);
  const azimuth = ((Math.atan2(py, px) * 180) / Math.PI + 360) % 360;
  return { distance_mm: distance, tilt_deg: tilt, azimuth_deg: azimuth };
}

export function sectorOf(view, sectors) {
  if (!view) return null;
  if (view.tilt_deg < STRAIGHT_ON_DEG) return "top";
  return Math.floor(view.azimuth_deg / (360 / sectors)) % sectors;
}

// SVG of the ring: one arc per sector (filled once a good photo was taken from there) and the straight-on centre.
export function ringSvg(filled, sectors, current) {
  const arcs = [];
  for (let i = 0; i < sectors; i += 1) {
    const a0 = ((i * 360) / sectors - 90 + 2) * (Math.PI / 180);
    const a1 = (((i + 1) * 360) / sectors - 90 - 2) * (Math.PI / 180);
    const [x0, y0, x1, y1] = [50 + 40 * Math.cos(a0), 50 + 40 * Math.sin(a0), 50 + 40 * Math.cos(a1), 50 + 40 * Math.sin(a1)];
    const state = filled.has(i) ? "done" : current === i ? "here" : "missing";
    arcs.push(`<path class="arc arc-${state}" d="M ${x0.toFixed(1)} ${y0.toFixed(1)} A 40 40 0 0 1 ${x1.toFixed(1)} ${y1.toFixed(1)}"/>`);
  }
  const top = filled.has("top") ? "done" : current === "top" ? "here" : "missing";
  return `<svg viewBox="0 0 100 100" class="ring" role="img" aria-label="${filled.size} of ${sectors + 1} angles photographed">${arcs.join("")}<circle class="arc-${top}" cx="50" cy="50" r="9"/></svg>`;
}
