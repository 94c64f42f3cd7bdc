// The app's service worker. VERSION and SHELL are written above by the gateway (gateway/phones/app_routes.py).
// It keeps the app's files so the app opens with no connection; the records and photos live in IndexedDB, which an
// update never touches. A new version installs beside the old one, then takes over and the page says so.
const CACHE = `burnedge-app-${VERSION}`;

self.addEventListener("install", (event) => {
  event.waitUntil(
    caches
      .open(CACHE)
      .then((cache) => cache.addAll(SHELL.map((url) => new Request(url, { cache: "no-cache" }))))
      .then(() => self.skipWaiting()),
  );
});

self.addEventListener("activate", (event) => {
  event.waitUntil(
    (async () => {
      for (const key of await caches.keys()) {
        if (key.startsWith("burnedge-app-") && key !== CACHE) await caches.delete(key);
      }
      await self.clients.claim();
    })(),
  );
});

self.addEventListener("fetch", (event) => {
  const url = new URL(event.request.url);
  if (event.request.method !== "GET" || url.origin !== self.location.origin) return;
  const shell = event.request.mode === "navigate" && url.pathname.startsWith("/app") ? "/app/" : url.pathname;
  if (!SHELL.includes(shell)) return; // the API and everything else go to the network as usual
  event.respondWith(
    caches.open(CACHE).then(async (cache) => (await cache.match(shell)) || fetch(event.request)),
  );
});
