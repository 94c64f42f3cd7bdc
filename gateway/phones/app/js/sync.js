// Changes made on the phone wait in IndexedDB (in order) and go through the gateway's batched, idempotent push
// when it is in reach; the change feed brings the patients the phone needs, within PATIENT_BOUND.
import { call } from "./api.js";
import { localIso, uuid7 } from "./ids.js";
import { all, keepRecord, kv, put, record, records, recordKey, remove } from "./store.js";

const KEPT = new Set(["patient", "encounter", "wound", "mechanism", "burn_analysis", "consultation"]);
export const PATIENT_BOUND = 300;
// The phone keeps the 300 most recently changed patients (and those with its own changes waiting), with their
// encounters, wounds, mechanism, analyses and advice; older ones are read from the gateway when in reach.

export async function change(kind, id, op, data, baseVersion = null, reason = null) {
  const known = await record(kind, id);
  const mutation = {
    mutation_id: uuid7(),
    kind,
    id,
    op,
    base_version: baseVersion,
    data,
    reason,
    client_time: localIso(),
    state: "queued",
    base_data: op === "update" ? (known?.data ?? null) : null, // what the phone edited: its own changes are the difference
  };
  await put("mutations", mutation);
  await keepRecord(kind, id, data, known ? known.meta : null, true);
  window.dispatchEvent(new Event("burnedge-change")); // the round sends it now if the gateway is in reach
  return mutation;
}

// A change to a record: a change still waiting for that record takes the new data (nothing was sent yet, so there
// is nothing to conflict with); otherwise an update on top of the version the phone holds, or a create.
export async function edit(kind, id, data) {
  const queued = (await waiting()).filter((m) => m.kind === kind && m.id === id && m.state === "queued" && m.op !== "delete");
  if (queued.length) {
    const last = queued[queued.length - 1];
    await put("mutations", { ...last, data, client_time: localIso() });
    const known = await record(kind, id);
    await keepRecord(kind, id, data, known ? known.meta : null, true);
    window.dispatchEvent(new Event("burnedge-change"));
    return last;
  }
  const known = await record(kind, id);
  const version = known?.meta?.version;
  return version ? change(kind, id, "update", data, version) : change(kind, id, "create", data);
}

export async function waiting() {
  return (await all("mutations")).sort((a, b) => a.seq - b.seq);
}

export async function push() {
  const queued = (await waiting()).filter((m) => m.state === "queued");
  if (!queued.length) return null;
  const mutations = queued.map((m) => ({
    mutation_id: m.mutation_id,
    kind: m.kind,
    id: m.id,
    op: m.op,
    base_version: m.base_version,
    data: m.data,
    reason: m.reason,
    client_time: m.client_time,
  }));
  const answer = await call("/api/v1/sync/push", { method: "POST", body: { mutations } });
  for (const [i, result] of answer.results.entries()) {
    const m = queued[i];
    if (result.status === "applied") {
      await remove("mutations", m.seq);
      const later = (await waiting()).some((x) => x.kind === m.kind && x.id === m.id);
      const known = await record(m.kind, m.id);
      const meta = { ...(known?.meta || {}), kind: m.kind, id: m.id, version: result.version };
      await keepRecord(m.kind, m.id, m.data ?? known?.data, meta, later);
    } else {
      await put("mutations", { ...m, state: result.status, error: result.error || "", current: result.current || null });
    }
  }
  return answer;
}

const same = (a, b) => JSON.stringify(a ?? null) === JSON.stringify(b ?? null);

// What a conflict is made of: the fields the phone changed from the version it edited, those of them the gateway
// holds differently, and the fields only the gateway changed (kept whichever the nurse chooses).
export function conflictFields(m) {
  const theirs = m.current?.data || {};
  const mine = m.data || {};
  const base = m.base_data;
  const keys = [...new Set([...Object.keys(theirs), ...Object.keys(mine), ...Object.keys(base || {})])];
  const changedHere = base ? keys.filter((k) => !same(mine[k], base[k])) : keys.filter((k) => k in mine);
  return {
    both: changedHere.filter((k) => !same(mine[k], theirs[k])),
    gatewayOnly: base ? keys.filter((k) => !changedHere.includes(k) && !same(theirs[k], base[k])) : [],
    changedHere,
  };
}

// A conflict is settled by the nurse: take the gateway's version (drop the phone's change), or keep the phone's
// changes, put on top of the gateway's version (what only the gateway changed stays) and pushed again.
export async function settle(seq, keepMine) {
  const m = (await waiting()).find((x) => x.seq === seq);
  if (!m) return;
  if (!keepMine || !m.current) {
    await remove("mutations", seq);
    if (m.current) await keepRecord(m.kind, m.id, m.current.data, m.current.meta, false);
    return;
  }
  const data = { ...m.current.data };
  for (const k of conflictFields(m).changedHere) {
    if (k in m.data) data[k] = m.data[k];
    else delete data[k];
  }
  const base = { base_version: m.current.meta.version, base_data: m.current.data };
  await put("mutations", { ...m, ...base, data, state: "queued", current: null, error: "" });
  await keepRecord(m.kind, m.id, data, m.current.meta, true);
  window.dispatchEvent(new Event("burnedge-change")); // sent again now if the gateway is in reach
}

export async function pull() {
  let cursor = (await kv.get("cursor")) || 0;
  for (let page = 0; page < 1000; page += 1) {
    const answer = await call(`/api/v1/sync/changes?since=${cursor}&limit=500`);
    for (const stored of answer.changes) {
      const kind = stored.meta.kind;
      if (!KEPT.has(kind)) continue;
      const known = await record(kind, stored.meta.id);
      if (known?.pending) continue; // the phone's own change is on its way; a conflict shows when it is pushed
      await keepRecord(kind, stored.meta.id, stored.data, stored.meta, false);
    }
    cursor = answer.next_cursor;
    await kv.set("cursor", cursor);
    if (!answer.has_more) break;
  }
  await prune();
}

async function prune() {
  const patients = await records("patient");
  if (patients.length <= PATIENT_BOUND) return;
  const when = (r) => r.meta?.updated_at || "9999";
  patients.sort((a, b) => when(b).localeCompare(when(a)));
  const dropped = new Set(patients.slice(PATIENT_BOUND).filter((p) => !p.pending).map((p) => p.id));
  const encounters = (await records("encounter")).filter((e) => dropped.has(e.data.patient_id) && !e.pending);
  const gone = new Set(encounters.map((e) => e.id));
  const photos = await all("photos");
  for (const photo of photos) gone.delete(photo.encounter_id); // a photo's encounter stays while the photo waits
  for (const e of encounters) if (!gone.has(e.id)) dropped.delete(e.data.patient_id); // and so does its patient
  for (const kind of ["burn_analysis", "consultation", "mechanism"]) {
    for (const r of await records(kind)) {
      if (gone.has(r.data.encounter_id || r.id)) await remove("records", recordKey(kind, r.id));
    }
  }
  for (const e of encounters) if (gone.has(e.id)) await remove("records", recordKey("encounter", e.id));
  for (const w of await records("wound")) {
    if (dropped.has(w.data.patient_id) && !w.pending) await remove("records", recordKey("wound", w.id));
  }
  for (const id of dropped) await remove("records", recordKey("patient", id));
}
