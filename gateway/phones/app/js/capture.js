// The capture screen: the rear camera's live view with the gateway's checks on every preview frame (sharpness,
// light, the printed marker, its distance and tilt), the ring of angles still missing, and a shutter that takes the
// photo when the checks pass or warns and lets the nurse decide. Without camera access in the browser, the phone's
// own camera app through a file input, judged by the gateway after upload. Every photo is queued at once.
import { closeCamera, hasCamera, openCamera, still } from "./camera.js";
import { check } from "./checks.js";
import { pose, ringSvg, sectorOf } from "./coverage.js";
import { localIso } from "./ids.js";
import { keepPhoto, photos, room } from "./photos.js";
import { kv, record } from "./store.js";
import { banner, html, show } from "./view.js";

const CHECK_EVERY_MS = 100;
/* Each new preview frame is checked, up to ten a second: a hand moves little in a tenth of a second, and checking
   every one of 30 frames a second would only drain the battery and slow the page. */
let stream = null;
let timer = null;

export function leaveCapture() {
  clearTimeout(timer);
  timer = null;
  closeCamera(stream);
  stream = null;
}

function describe(result, view) {
  if (!result) return "";
  const m = result.figures.markers.length ? "marker in view" : "no marker";
  const where = view ? `, ${(view.distance_mm / 10).toFixed(0)} cm away, tilted ${view.tilt_deg.toFixed(0)}°` : "";
  return result.reasons.length ? `${result.guidance.join(" ")} (${m}${where})` : `Ready: sharp, well lit, ${m}${where}.`;
}

export async function captureScreen(encounterId, woundId, onQueued) {
  const settings = await kv.get("capture-settings");
  const encounter = await record("encounter", encounterId);
  const wound = woundId ? await record("wound", woundId) : null;
  const label = wound ? wound.data.label : "the burn";
  const sectors = settings?.readiness.recommended_views ? settings.readiness.recommended_views - 1 : 7;
  const filled = new Set(
    (await photos())
      .filter((p) => p.encounter_id === encounterId && (p.wound_id || "") === woundId && p.sector != null)
      .map((p) => p.sector),
  );
  const count = async () =>
    (await photos()).filter((p) => p.encounter_id === encounterId && (p.wound_id || "") === woundId).length;
  const screen = show(
    html`<h1>Photograph ${label}</h1>
      <p class="hint">The burn and the whole printed marker strip in every photo; walk around the burn.</p>
      <div class="viewfinder"><video id="preview" playsinline muted></video><div id="ring" class="ring-box"></div></div>
      <p id="check" class="check" role="status" aria-live="polite">${settings ? "Checking…" : "The gateway's checks come with its settings: connect once."}</p>
      <div id="warn" class="warn" hidden><p id="warn-text"></p>
        <button type="button" id="take-anyway">Take it anyway</button> <button type="button" id="retake">Try again</button></div>
      <p class="capture-bar"><button type="button" id="shutter" class="shutter" disabled>Take photo</button>
        <span id="taken" role="status" aria-live="polite"></span></p>
      <label class="fallback">Or use the phone's camera app
        <input id="fallback" type="file" accept="image/*" capture="environment" multiple></label>
      <label class="fallback">Or film a short video instead, walking round the burn (10 to 20 s): the gateway
        takes its frames
        <input id="video" type="file" accept="video/*" capture="environment"></label>
      <p><a class="button" href="#/encounter/${encounterId}">Done</a></p>`,
  );
  const $ = (id) => screen.querySelector(`#${id}`);
  const video = $("preview");
  const canvas = document.createElement("canvas");
  let latest = null;
  let view = null;
  const drawRing = () => {
    $("ring").innerHTML = ringSvg(filled, sectors, sectorOf(view, sectors));
  };
  const keep = async (blob, source, takenAt, verdict, where) => {
    try {
      const sector = verdict?.accepted ? sectorOf(where, sectors) : null;
      await keepPhoto(blob, { encounterId, woundId, takenAt, source, deviceVerdict: verdict, sector });
      if (sector != null) filled.add(sector);
      drawRing();
      $("taken").textContent = `${await count()} photos of ${label} on this phone; ${filled.size} of ${sectors + 1} angles`;
      const space = await room();
      banner(space.low ? "The phone's storage is running low: upload the photos waiting soon." : "", "warn");
      onQueued?.();
    } catch (error) {
      banner(error.message, "error");
    }
  };
  $("taken").textContent = `${await count()} photos of ${label} on this phone; ${filled.size} of ${sectors + 1} angles`;
  drawRing();
  if (!encounter) banner("This encounter is not on this phone.", "error");
  $("video").addEventListener("change", async (event) => {
    for (const file of event.target.files) {
      await keep(file, "video", file.lastModified ? localIso(new Date(file.lastModified)) : localIso(), null, null);
    }
    event.target.value = "";
  });
  $("fallback").addEventListener("change", async (event) => {
    for (const file of event.target.files) {
      await keep(file, "file", file.lastModified ? localIso(new Date(file.lastModified)) : localIso(), null, null);
    }
    event.target.value = "";
  });
  const noCamera = (why) => {
    if (why) banner(`No camera in the app (${why}): use the phone's camera app below.`, "warn");
    for (const id of ["shutter", "check"]) $(id).hidden = true;
    screen.querySelector(".viewfinder").hidden = true;
  };
  if (!hasCamera()) return noCamera("");
  try {
    stream = await openCamera(video);
  } catch (error) {
    return noCamera(error.message);
  }
  $("shutter").disabled = false;
  const mine = stream; // a loop of an earlier capture screen stops when its camera has gone
  const loop = async () => {
    if (stream !== mine) return;
    const started = performance.now();
    if (settings && video.videoWidth) {
      latest = await check(video, video.videoWidth, video.videoHeight, settings, canvas);
      if (stream !== mine) return;
      const marker = latest.figures.markers[0];
      view = pose(marker, video.videoWidth, video.videoHeight, settings.marker.side_mm, settings.readiness.default_focal_35mm);
      $("check").textContent = describe(latest, view);
      $("check").dataset.ok = latest.reasons.length ? "no" : "yes";
      $("check").dataset.ms = latest.ms.toFixed(1);
      $("check").dataset.phases = JSON.stringify(latest.phases);
      $("check").dataset.source = latest.source;
      drawRing();
    }
    const onNewFrame = () => (video.requestVideoFrameCallback ? video.requestVideoFrameCallback(() => loop()) : loop());
    timer = setTimeout(onNewFrame, Math.max(0, CHECK_EVERY_MS - (performance.now() - started)));
  };
  loop();
  const take = async (verdict, where) => {
    $("shutter").disabled = true;
    $("warn").hidden = true;
    try {
      await keep(await still(video, stream), "camera", localIso(), verdict, where);
    } finally {
      $("shutter").disabled = false;
    }
  };
  let held = null;
  $("shutter").addEventListener("click", () => {
    const verdict = latest && { accepted: latest.accepted, reasons: latest.reasons, figures: { ...latest.figures } };
    if (!latest || !latest.reasons.length) return take(verdict, view);
    held = { verdict, where: view };
    $("warn-text").textContent = `This photo would be: ${latest.guidance.join(" ")}`;
    $("warn").hidden = false;
  });
  $("take-anyway").addEventListener("click", () => take(held.verdict, held.where));
  $("retake").addEventListener("click", () => {
    $("warn").hidden = true;
  });
}
