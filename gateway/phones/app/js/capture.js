// The capture screen: the rear camera's live view and a shutter, or (no camera access in the browser) the phone's
// own camera through a file input; every photo goes to the phone's queue at once, with its time and wound.
import { closeCamera, hasCamera, openCamera, still } from "./camera.js";
import { localIso } from "./ids.js";
import { keepPhoto, photos, room } from "./photos.js";
import { record } from "./store.js";
import { banner, html, show } from "./view.js";

let stream = null;

export function leaveCapture() {
  closeCamera(stream);
  stream = null;
}

export async function captureScreen(encounterId, woundId, onQueued) {
  const encounter = await record("encounter", encounterId);
  const wound = woundId ? await record("wound", woundId) : null;
  const label = wound ? wound.data.label : "the burn";
  const count = async () => (await photos()).filter((p) => p.encounter_id === encounterId && (p.wound_id || "") === woundId).length;
  const screen = show(
    html`<h1>Photograph ${label}</h1>
      <p class="hint">The burn and the whole printed marker strip in every photo; walk around the burn, 8 or more views.</p>
      <div class="viewfinder"><video id="preview" playsinline muted></video></div>
      <p class="capture-bar"><button type="button" id="shutter" class="shutter" disabled>Take photo</button>
        <span id="taken" role="status" aria-live="polite"></span></p>
      <label class="fallback">Or use the phone's camera app
        <input id="fallback" type="file" accept="image/*" capture="environment" multiple></label>
      <p><a class="button" href="#/encounter/${encounterId}">Done</a></p>`,
  );
  const taken = screen.querySelector("#taken");
  const shutter = screen.querySelector("#shutter");
  const video = screen.querySelector("#preview");
  const keep = async (blob, source, takenAt) => {
    try {
      await keepPhoto(blob, { encounterId, woundId, takenAt, source });
      const space = await room();
      taken.textContent = `${await count()} photos of ${label} on this phone`;
      banner(space.low ? "The phone's storage is running low: upload the photos waiting soon." : "", "warn");
      onQueued?.();
    } catch (error) {
      banner(error.message, "error");
    }
  };
  taken.textContent = `${await count()} photos of ${label} on this phone`;
  if (!encounter) banner("This encounter is not on this phone.", "error");
  screen.querySelector("#fallback").addEventListener("change", async (event) => {
    for (const file of event.target.files) {
      await keep(file, "file", file.lastModified ? localIso(new Date(file.lastModified)) : localIso());
    }
    event.target.value = "";
  });
  if (!hasCamera()) {
    screen.querySelector(".viewfinder").hidden = true;
    shutter.hidden = true;
    return;
  }
  try {
    stream = await openCamera(video);
    shutter.disabled = false;
  } catch (error) {
    banner(`No camera in the app (${error.message}): use the phone's camera app below.`, "warn");
    screen.querySelector(".viewfinder").hidden = true;
    shutter.hidden = true;
    return;
  }
  shutter.addEventListener("click", async () => {
    shutter.disabled = true;
    try {
      const at = localIso();
      await keep(await still(video, stream), "camera", at);
    } finally {
      shutter.disabled = false;
    }
  });
}
