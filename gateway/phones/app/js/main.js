// The app's shell: routes, the round that sends what waits when the gateway is in reach, and the service worker
// that keeps the app on the phone (and says when a new version has come from the gateway).
import { reachable, session } from "./api.js";
import { captureScreen, leaveCapture } from "./capture.js";
import { photos, uploadWaiting } from "./photos.js";
import { encounterScreen, pairScreen, patientScreen, patientsScreen, queueScreen, signInScreen } from "./screens.js";
import { kv } from "./store.js";
import { pull, push, waiting } from "./sync.js";
import { banner } from "./view.js";

const ROUND_EVERY_MS = 15000;
let running = false;

async function route() {
  leaveCapture();
  const hash = window.location.hash || "#/";
  const pairing = hash.match(/^#pair=([A-Za-z0-9-]+)(?:&fp=([0-9A-Fa-f]+))?/);
  if (pairing) return pairScreen(pairing[1], pairing[2] || "");
  if (!(await kv.get("device"))) return pairScreen();
  if (!(await session())) return signInScreen();
  const [, screen, a, b] = hash.split("/");
  if (screen === "patient") return patientScreen(a);
  if (screen === "encounter") return encounterScreen(a);
  if (screen === "capture") return captureScreen(a, b || "", () => round());
  if (screen === "queue") return queueScreen();
  if (screen === "sign-in") return signInScreen();
  return patientsScreen();
}

async function status(inReach) {
  const list = await photos();
  const left = list.filter((p) => p.state !== "stored");
  const changes = await waiting();
  const conflicts = changes.filter((m) => m.state === "conflict").length;
  document.getElementById("link-status").textContent = inReach ? "gateway in reach" : "offline: kept on this phone";
  document.getElementById("link-status").dataset.online = inReach ? "yes" : "no";
  const parts = [];
  if (left.length) parts.push(`${left.length} photos waiting`);
  if (conflicts) parts.push(`${conflicts} to settle`);
  if (changes.length > conflicts) parts.push(`${changes.length - conflicts} changes waiting`);
  document.getElementById("queue-status").innerHTML = parts.length
    ? `<a href="#/queue">${parts.join(", ")}</a>`
    : "nothing waiting";
}

async function round() {
  if (running) return;
  running = true;
  let inReach = false;
  try {
    inReach = await reachable();
    if (inReach) await refreshSettings();
    if (inReach && (await session())) {
      await push();
      await pull();
      await uploadWaiting(() => status(true));
    }
  } catch (error) {
    if (error.status) banner(error.message, "error");
  } finally {
    running = false;
    await status(inReach);
    if (inReach && document.querySelector("[data-state]")) refreshScreen();
  }
}

// The gateway's gate thresholds, readiness rules and marker, kept for the checks offline.
async function refreshSettings() {
  try {
    const response = await fetch("/api/v1/capture/settings", { cache: "no-store" });
    if (response.ok) await kv.set("capture-settings", await response.json());
  } catch {
    // kept from the last time; the capture screen says when there are none yet
  }
}

function refreshScreen() {
  const hash = window.location.hash;
  if (hash.startsWith("#/encounter/") || hash.startsWith("#/queue")) route();
}

async function keepStorage() {
  if (navigator.storage?.persist && !(await navigator.storage.persisted())) await navigator.storage.persist();
}

function serviceWorker() {
  if (!("serviceWorker" in navigator)) return;
  const updated = sessionStorage.getItem("burnedge-updated");
  if (updated) {
    sessionStorage.removeItem("burnedge-updated");
    banner("The app was updated from the gateway. Everything waiting on this phone is still here.", "ok");
  }
  navigator.serviceWorker.register("/app/sw.js", { scope: "/app/" }).then((registration) => {
    setInterval(() => registration.update().catch(() => {}), 30 * 60 * 1000);
  });
  const hadWorker = Boolean(navigator.serviceWorker.controller); // the first install is no update
  let reloading = false;
  navigator.serviceWorker.addEventListener("controllerchange", () => {
    if (reloading || !hadWorker) return;
    reloading = true;
    sessionStorage.setItem("burnedge-updated", "1");
    if (window.location.hash.startsWith("#/capture/")) {
      banner("A new version of the app is ready: it loads when you leave the camera.", "info");
      window.addEventListener("hashchange", () => window.location.reload(), { once: true });
    } else {
      window.location.reload();
    }
  });
}

window.addEventListener("hashchange", route);
window.addEventListener("online", round);
window.addEventListener("burnedge-change", round);
document.addEventListener("visibilitychange", () => document.visibilityState === "visible" && round());
if (!window.isSecureContext) {
  banner(
    "This address is not secure (plain http on the clinic network): the in-app camera, offline use and the photo " +
      "checks need the gateway's https address. Photos can still be taken with the phone's camera app.",
    "warn",
  );
}
serviceWorker();
keepStorage();
route().then(round);
setInterval(round, ROUND_EVERY_MS);
