// Talking to the gateway: the device token (paired once), the session (signed in once per shift), problem+json
// errors as the API reports them, and "not in reach" kept apart from "refused".
import { kv } from "./store.js";

export class NotInReach extends Error {
  constructor() {
    super("the gateway is not in reach: everything waits on this phone");
  }
}

export class Refused extends Error {
  constructor(status, problem) {
    super(problem.detail || problem.title || `refused (${status})`);
    this.status = status;
    this.problem = problem;
  }
}

export async function session() {
  const held = await kv.get("session");
  if (!held) return null;
  return new Date(held.expires_at) > new Date() ? held : null;
}

export async function call(path, { method = "GET", body, headers = {}, signedIn = true } = {}) {
  const sent = { ...headers };
  if (signedIn) {
    const current = await session();
    if (!current) throw new Refused(401, { detail: "sign in again: your session has ended" });
    sent.Authorization = `Bearer ${current.access_token}`;
  }
  let payload = body;
  if (body !== undefined && !(body instanceof Blob)) {
    sent["Content-Type"] = "application/json";
    payload = JSON.stringify(body);
  }
  let response;
  try {
    response = await fetch(path, { method, headers: sent, body: payload, cache: "no-store" });
  } catch {
    throw new NotInReach();
  }
  if (!response.ok) {
    let problem = {};
    try {
      problem = await response.json();
    } catch {
      problem = { detail: `${response.status} ${response.statusText}` };
    }
    if (response.status === 401 && signedIn) await kv.remove("session");
    throw new Refused(response.status, problem);
  }
  return response.status === 204 ? null : response.json();
}

export async function reachable() {
  try {
    const response = await fetch("/health", { cache: "no-store" });
    return response.ok;
  } catch {
    return false;
  }
}

export async function pair(code, fingerprint) {
  const token = await call("/api/v1/auth/pair", {
    method: "POST",
    body: { code: code.trim(), device_fingerprint: fingerprint },
    signedIn: false,
  });
  await kv.set("device", token);
  return token;
}

export async function signIn(username, password) {
  const device = await kv.get("device");
  if (!device) throw new Refused(401, { detail: "pair this phone with the gateway first" });
  const held = await call("/api/v1/auth/login", {
    method: "POST",
    body: { username, password },
    headers: { "X-Device-Token": device.device_token },
    signedIn: false,
  });
  await kv.set("session", held);
  return held;
}

export async function signOut() {
  try {
    await call("/api/v1/auth/logout", { method: "POST" });
  } finally {
    await kv.remove("session");
  }
}
