// The phone's own storage: IndexedDB, which survives the app being closed and the phone restarting.
// Stores: kv (tokens, cursor, settings), records (what the phone knows of the record), mutations (changes waiting
// for the gateway, in order), photos (pictures and their state), photo_bytes (their bytes until the gateway
// confirmed them), documents (reports kept offline).
const NAME = "burnedge-app";
const VERSION = 1;
let opening = null;

export function database() {
  if (!opening) {
    opening = new Promise((resolve, reject) => {
      const request = indexedDB.open(NAME, VERSION);
      request.onupgradeneeded = () => {
        const db = request.result;
        db.createObjectStore("kv");
        const records = db.createObjectStore("records", { keyPath: "key" });
        records.createIndex("kind", "kind");
        db.createObjectStore("mutations", { keyPath: "seq", autoIncrement: true });
        const photos = db.createObjectStore("photos", { keyPath: "id" });
        photos.createIndex("taken_at", "taken_at");
        db.createObjectStore("photo_bytes", { keyPath: "id" });
        db.createObjectStore("documents", { keyPath: "url" });
      };
      request.onsuccess = () => resolve(request.result);
      request.onerror = () => reject(request.error);
      request.onblocked = () => reject(new Error("the app is open in another tab on an older version: close it"));
    });
  }
  return opening;
}

function done(request) {
  return new Promise((resolve, reject) => {
    request.onsuccess = () => resolve(request.result);
    request.onerror = () => reject(request.error);
  });
}

async function store(name, mode = "readonly") {
  return (await database()).transaction(name, mode).objectStore(name);
}

export async function get(name, key) {
  return done((await store(name)).get(key));
}

// Resolves once the write is on disk (the transaction completed); a full disk rejects with QuotaExceededError.
function committed(s, value) {
  return new Promise((resolve, reject) => {
    s.transaction.oncomplete = () => resolve(value);
    s.transaction.onabort = () => reject(s.transaction.error || new Error("the phone's storage refused the write"));
  });
}

export async function put(name, value, key) {
  const s = await store(name, "readwrite");
  const written = committed(s, value);
  if (key === undefined) s.put(value);
  else s.put(value, key);
  return written;
}

export async function remove(name, key) {
  const s = await store(name, "readwrite");
  const written = committed(s, undefined);
  s.delete(key);
  return written;
}

export async function all(name) {
  return done((await store(name)).getAll());
}

export async function byIndex(name, index, value) {
  return done((await store(name)).index(index).getAll(value));
}

export const kv = {
  get: (key) => get("kv", key),
  set: (key, value) => put("kv", value, key),
  remove: (key) => remove("kv", key),
};

export function recordKey(kind, id) {
  return `${kind}/${id}`;
}

export async function record(kind, id) {
  return get("records", recordKey(kind, id));
}

export async function records(kind) {
  return byIndex("records", "kind", kind);
}

export async function keepRecord(kind, id, data, meta, pending) {
  return put("records", { key: recordKey(kind, id), kind, id, data, meta, pending });
}
