// Photos wait on the phone (IndexedDB) with their capture time and wound until the gateway has confirmed each one
// by its SHA-256; then only their verdict stays. Uploads are tus, resumed, oldest first. Nothing is dropped silently.
import { Refused, session } from "./api.js";
import { localIso, sha256Hex, uuid7 } from "./ids.js";
import { all, get, put, record, remove } from "./store.js";

const HEADROOM = 50 * 1024 * 1024;
const CHUNK = 1024 * 1024;

const EXTENSIONS = { "video/mp4": ".mp4", "video/quicktime": ".mov", "image/png": ".png", "image/heic": ".heic" };
const extension = (type) => EXTENSIONS[type] || ".jpg";

export const mb = (bytes) => `${(bytes / 1024 / 1024).toFixed(bytes < 10 * 1024 * 1024 ? 1 : 0)} MB`;

export async function room(bytes = 0) {
  if (!navigator.storage?.estimate) return { ok: true, low: false, free: null };
  const { usage = 0, quota = 0 } = await navigator.storage.estimate();
  const free = quota - usage;
  return { ok: free > bytes + HEADROOM, low: free < 20 * 4 * 1024 * 1024 + HEADROOM, free };
}

export async function keepPhoto(blob, { encounterId, woundId, takenAt, source, deviceVerdict, sector = null }) {
  const space = await room(blob.size);
  if (!space.ok) {
    throw new Error(
      `the phone's storage is nearly full (${mb(space.free)} left): upload the photos waiting before taking more. ` +
        "This photo was not kept.",
    );
  }
  const id = uuid7();
  const taken = takenAt || localIso();
  const photo = {
    id,
    name: `burn-${taken.slice(0, 19).replace(/[-:]/g, "").replace("T", "-")}-${id.slice(-4)}${extension(blob.type)}`,
    size: blob.size,
    type: blob.type || "image/jpeg",
    sha256: await sha256Hex(blob),
    taken_at: taken,
    encounter_id: encounterId,
    wound_id: woundId || null,
    source,
    device_verdict: deviceVerdict || null,
    sector,
    state: "queued",
    upload_url: null,
    sent: 0,
    asset: null,
    error: "",
  };
  try {
    await put("photo_bytes", { id, blob });
    await put("photos", photo);
  } catch (error) {
    await remove("photo_bytes", id).catch(() => {});
    throw new Error(
      `the phone's storage is full (${error.name || error.message}): upload the photos waiting, or free space ` +
        "on the phone, before taking more. This photo was not kept; the ones before it are.",
    );
  }
  return photo;
}

export async function photos() {
  return (await all("photos")).sort((a, b) => a.taken_at.localeCompare(b.taken_at));
}

export async function forget(id) {
  await remove("photo_bytes", id);
  await remove("photos", id);
}

// Oldest first; a photo waits until its encounter and wound have reached the gateway. Stops at the first photo the
// link could not carry (the next round resumes it); a refusal is kept on the photo with the gateway's reason.
export async function uploadWaiting(onProgress) {
  for (const photo of await photos()) {
    if (photo.state === "stored" || photo.state === "refused") continue;
    const encounter = await record("encounter", photo.encounter_id);
    if (!encounter || encounter.pending) continue;
    const wound = photo.wound_id ? await record("wound", photo.wound_id) : null;
    if (photo.wound_id && (!wound || wound.pending)) continue;
    await uploadOne(photo, onProgress);
  }
}

async function uploadOne(photo, onProgress) {
  const held = await session();
  if (!held) throw new Refused(401, { detail: "sign in again to upload the photos waiting" });
  const bytes = await get("photo_bytes", photo.id);
  if (!bytes) throw new Error(`the bytes of ${photo.name} are missing on this phone`);
  const url = await new Promise((resolve, reject) => {
    const metadata = {
      encounter_id: photo.encounter_id,
      filename: photo.name,
      filetype: photo.type,
      captured_at: photo.taken_at,
    };
    if (photo.sha256) metadata.checksum = `sha256 ${photo.sha256}`;
    if (photo.wound_id) metadata.wound_id = photo.wound_id;
    const upload = new window.tus.Upload(bytes.blob, {
      endpoint: "/api/v1/uploads",
      uploadUrl: photo.upload_url,
      chunkSize: CHUNK,
      retryDelays: [0, 1000, 3000],
      storeFingerprintForResuming: false,
      headers: { Authorization: `Bearer ${held.access_token}` },
      metadata,
      onUploadUrlAvailable: () => put("photos", { ...photo, upload_url: upload.url, state: "uploading" }),
      onProgress: (sent, total) => onProgress?.(photo, sent, total),
      onSuccess: () => resolve(upload.url),
      onError: (error) => reject(error),
    });
    upload.start();
  }).catch(async (error) => {
    const status = error.originalResponse?.getStatus?.() || 0;
    if (status >= 400 && status < 500 && ![401, 409, 423, 429].includes(status)) {
      let detail = "";
      try {
        detail = JSON.parse(error.originalResponse.getBody()).detail;
      } catch {
        detail = error.message;
      }
      await put("photos", { ...(await get("photos", photo.id)), state: "refused", error: detail });
      return null;
    }
    throw error;
  });
  if (url) await confirm(photo, url);
}

async function confirm(photo, url) {
  const held = await session();
  const response = await fetch(`/api/v1/uploads/${url.split("/").pop()}`, {
    headers: { Authorization: `Bearer ${held.access_token}` },
    cache: "no-store",
  });
  const status = await response.json();
  const current = await get("photos", photo.id);
  const same = status.asset && (photo.sha256 ? status.asset.sha256 === photo.sha256 : status.asset.size_bytes === photo.size);
  if (!same) {
    await put("photos", { ...current, state: "queued", upload_url: null, error: "the gateway's copy did not match: sent again" });
    return;
  }
  const verdict = status.asset.verdict;
  const disagrees = Boolean(current.device_verdict && verdict && current.device_verdict.accepted !== verdict.accepted);
  await put("photos", { ...current, state: "stored", asset: { id: status.asset.id, verdict }, disagrees, error: "" });
  await remove("photo_bytes", photo.id); // confirmed by its hash: the phone's copy is no longer needed
}
