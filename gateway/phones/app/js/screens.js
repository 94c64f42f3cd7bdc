// The app's screens: pair, sign in, patients, a patient (encounters, wounds), an encounter (capture per wound,
// photos, analyses), the waiting queue. Everything made here is stored on the phone first.
import { call, NotInReach, pair, session, signIn } from "./api.js";
import { localIso, uuid7 } from "./ids.js";
import { forget, mb, photos } from "./photos.js";
import { get, kv, put, record, records } from "./store.js";
import { change, conflictFields, edit, settle, waiting } from "./sync.js";
import { banner, formData, html, localInput, show, when } from "./view.js";

const go = (hash) => {
  window.location.hash = hash;
};
const name = (p) =>
  [p?.data?.given_name, p?.data?.family_name].filter(Boolean).join(" ") ||
  p?.data?.temporary_label ||
  (p?.data?.medical_record_number ? `Record ${p.data.medical_record_number}` : "(no name)");
const options = (list, selected = "") =>
  list.map((o) => html`<option value="${o.value}" ${o.value === selected ? "selected" : ""}>${o.label}</option>`);
const iso = (local) => (local ? localIso(new Date(local)) : null);

let choices = null;
async function choicesOf() {
  if (!choices) choices = await (await fetch("/app/choices.json")).json();
  return choices;
}

export async function pairScreen(code = "", fingerprint = "") {
  const shown = fingerprint.toUpperCase().match(/../g)?.join(":") || "";
  show(
    html`<h1>Pair this phone</h1>
      <p>The clinic's administrator gives a one-time code (or a QR code that opens this page with it).</p>
      ${shown ? html`<p class="hint">This gateway's certificate begins <code>${shown}</code>: it must match the
        Administration page.</p>` : ""}
      <form id="pair" class="stack">
        <label>Pairing code <input name="code" required autocomplete="one-time-code" value="${code}"></label>
        <button type="submit">Pair</button>
      </form>`,
    {
      "#pair": {
        submit: async (event) => {
          event.preventDefault();
          try {
            await pair(formData(event.target).code, navigator.userAgent.slice(0, 120));
            banner("Paired. Sign in with your own account.", "ok");
            go("#/sign-in");
          } catch (error) {
            banner(error instanceof NotInReach ? "Pairing needs the gateway: join the clinic's Wi-Fi." : error.message, "error");
          }
        },
      },
    },
  );
}

export async function signInScreen() {
  show(
    html`<h1>Sign in</h1>
      <p>Once per shift; the phone stays paired.</p>
      <form id="sign-in" class="stack">
        <label>User name <input name="username" required autocomplete="username" autocapitalize="none"></label>
        <label>Password <input name="password" type="password" required autocomplete="current-password"></label>
        <button type="submit">Sign in</button>
      </form>`,
    {
      "#sign-in": {
        submit: async (event) => {
          event.preventDefault();
          const form = formData(event.target);
          try {
            await signIn(form.username, form.password);
            banner("");
            go("#/");
          } catch (error) {
            banner(error instanceof NotInReach ? "Signing in needs the gateway once per shift." : error.message, "error");
          }
        },
      },
    },
  );
}

export async function patientsScreen(query = "") {
  const all = (await records("patient")).sort((a, b) => name(a).localeCompare(name(b)));
  const found = all.filter((p) => name(p).toLowerCase().includes(query.toLowerCase()));
  show(
    html`<h1>Patients</h1>
      <form id="search" role="search"><input name="q" type="search" placeholder="Find by name" value="${query}"
        aria-label="Find a patient by name"></form>
      <ul class="list">${found.map((p) => html`<li><a href="#/patient/${p.id}">${name(p)}</a>
        <span class="muted">${p.data.date_of_birth || ""}${p.pending ? " · waiting to send" : ""}</span></li>`)}</ul>
      <details ${all.length ? "" : "open"}><summary>New patient</summary>
      <form id="new-patient" class="stack">
        <p class="muted">A name or a record number; for an unknown patient, a temporary label.</p>
        <label>Given name <input name="given_name" autocomplete="off"></label>
        <label>Family name <input name="family_name" autocomplete="off"></label>
        <label>Record number <input name="medical_record_number" autocomplete="off"></label>
        <label>Unknown patient: temporary label <input name="temporary_label" placeholder="e.g. Unknown man, bay 3"></label>
        <p class="error" id="patient-problem" role="alert" hidden></p>
        <label>Date of birth <input name="date_of_birth" type="date"></label>
        <label>Sex <select name="sex">${options((await choicesOf()).sexes, "unknown")}</select></label>
        <label>Weight (kg) <input name="weight_kg" type="number" min="0.3" max="400" step="0.1"></label>
        <button type="submit">Add patient</button>
      </form></details>`,
    {
      "#search": { input: (e) => patientsScreen(e.target.value).then(() => focusSearch()) },
      "#new-patient": {
        submit: async (event) => {
          event.preventDefault();
          const f = formData(event.target);
          const known = ["given_name", "family_name", "medical_record_number", "temporary_label"].filter((k) => f[k]?.trim());
          if (!known.length) {
            const problem = document.getElementById("patient-problem");
            problem.textContent = "Give a name or a record number, or a temporary label for an unknown patient.";
            problem.hidden = false;
            return;
          }
          const id = uuid7();
          const data = { id, given_name: f.given_name || "", family_name: f.family_name || "", sex: f.sex };
          for (const k of ["medical_record_number", "temporary_label"]) if (f[k]?.trim()) data[k] = f[k].trim();
          if (f.date_of_birth) data.date_of_birth = f.date_of_birth;
          if (f.weight_kg) Object.assign(data, { weight_kg: Number(f.weight_kg), weight_source: "estimated" });
          await change("patient", id, "create", data);
          go(`#/patient/${id}`);
        },
      },
    },
  );
}

function focusSearch() {
  const input = document.querySelector("#search input");
  input?.focus();
  input?.setSelectionRange(input.value.length, input.value.length);
}

export async function patientScreen(patientId) {
  const patient = await record("patient", patientId);
  if (!patient) return show(html`<p>This patient is not on this phone. <a href="#/">Patients</a></p>`);
  const encounters = (await records("encounter"))
    .filter((e) => e.data.patient_id === patientId)
    .sort((a, b) => b.data.time_of_arrival.localeCompare(a.data.time_of_arrival));
  const wounds = (await records("wound")).filter((w) => w.data.patient_id === patientId);
  const c = await choicesOf();
  show(
    html`<h1>${name(patient)}</h1>
      <h2>Encounters</h2>
      <ul class="list">${encounters.map((e) => html`<li><a href="#/encounter/${e.id}">${when(e.data.time_of_arrival)}</a>
        <span class="muted">${e.data.mode}${e.pending ? " · waiting to send" : ""}</span></li>`)}</ul>
      <details ${encounters.length ? "" : "open"}><summary>New encounter</summary>
      <form id="new-encounter" class="stack">
        <label>Arrived <input name="time_of_arrival" type="datetime-local" required value="${localInput()}"></label>
        <label>Time of injury <input name="time_of_injury" type="datetime-local"></label>
        <label>Mechanism <select name="mechanism"><option value="">not recorded yet</option>${options(c.mechanisms)}</select></label>
        <label>Kind <select name="mode">${options(c.modes, "emergency")}</select></label>
        <button type="submit">Start encounter</button>
      </form></details>
      <h2>Wounds</h2>
      <ul class="list">${wounds.map((w) => html`<li>${w.data.label} <span class="muted">${w.data.state || "open"}${w.pending ? " · waiting to send" : ""}</span></li>`)}</ul>
      <details ${wounds.length ? "" : "open"}><summary>New wound</summary>
      <form id="new-wound" class="stack">
        <label>Name <input name="label" required placeholder="left forearm" maxlength="80"></label>
        <label>Regions <select name="regions" multiple required size="5">${options(c.regions)}</select></label>
        <label>Side <select name="side"><option value="">—</option>${options(c.sides)}</select></label>
        <label>Cause <select name="cause"><option value="">—</option>${options(c.mechanisms)}</select></label>
        <button type="submit">Add wound</button>
      </form></details>`,
    {
      "#new-encounter": {
        submit: async (event) => {
          event.preventDefault();
          const f = formData(event.target);
          const id = uuid7();
          const data = { id, patient_id: patientId, mode: f.mode, time_of_arrival: iso(f.time_of_arrival) };
          if (f.time_of_injury) data.time_of_injury = iso(f.time_of_injury);
          await change("encounter", id, "create", data);
          if (f.mechanism) await change("mechanism", id, "create", { encounter_id: id, type: f.mechanism });
          go(`#/encounter/${id}`);
        },
      },
      "#new-wound": {
        submit: async (event) => {
          event.preventDefault();
          const f = formData(event.target);
          const id = uuid7();
          const data = { id, patient_id: patientId, label: f.label, regions: [].concat(f.regions) };
          if (f.side) data.side = f.side;
          if (f.cause) data.cause = f.cause;
          await change("wound", id, "create", data);
          patientScreen(patientId);
        },
      },
    },
  );
}

export async function encounterScreen(encounterId) {
  const encounter = await record("encounter", encounterId);
  if (!encounter) return show(html`<p>This encounter is not on this phone. <a href="#/">Patients</a></p>`);
  const patient = await record("patient", encounter.data.patient_id);
  const wounds = (await records("wound")).filter((w) => w.data.patient_id === encounter.data.patient_id);
  const mine = (await photos()).filter((p) => p.encounter_id === encounterId);
  const analyses = (await records("burn_analysis"))
    .filter((a) => a.data.encounter_id === encounterId)
    .sort((a, b) => b.data.completed_at.localeCompare(a.data.completed_at));
  const advice = (await records("consultation")).filter((a) => a.data.encounter_id === encounterId);
  const reportUrl = `/api/v1/encounters/${encounterId}/report.pdf`;
  const kept = await get("documents", reportUrl);
  const targets = wounds.length ? wounds : [{ id: "", data: { label: "the burn" } }];
  const mechanism = await record("mechanism", encounterId);
  const c = await choicesOf();
  const cause = mechanism ? c.mechanisms.find((m) => m.value === mechanism.data.type)?.label : "";
  show(
    html`<h1>${name(patient)}</h1><p class="muted">Encounter ${when(encounter.data.time_of_arrival)}</p>
      <h2>Injury</h2>
      <p id="injury">${encounter.data.time_of_injury ? `Injured ${when(encounter.data.time_of_injury)}` : "Time of injury not recorded"} ·
        ${cause ? `${cause}${mechanism.data.enclosed_space ? ", in an enclosed space" : ""}` : "mechanism not recorded"}
        ${encounter.pending || mechanism?.pending ? html`<span class="muted">· waiting to send</span>` : ""}</p>
      <details><summary>Record or change the injury</summary>
      <form id="injury-form" class="stack">
        <label>Time of injury <input name="time_of_injury" type="datetime-local" value="${encounter.data.time_of_injury ? localInput(new Date(encounter.data.time_of_injury)) : ""}"></label>
        <label>Mechanism <select name="mechanism"><option value="">not recorded yet</option>${options(c.mechanisms, mechanism?.data.type)}</select></label>
        <label class="check-row"><input name="enclosed_space" type="checkbox" ${mechanism?.data.enclosed_space ? "checked" : ""}> In an enclosed space</label>
        <button type="submit">Save the injury</button>
      </form></details>
      ${wounds.length ? "" : html`<p class="hint">Record the wound first on the <a href="#/patient/${encounter.data.patient_id}">patient</a> when the patient has several burns.</p>`}
      <h2>Photograph</h2>
      <ul class="list">${targets.map((w) => html`<li><a class="button" href="#/capture/${encounterId}/${w.id}">Photograph ${w.data.label}</a>
        <span class="muted">${mine.filter((p) => (p.wound_id || "") === w.id).length} photos</span></li>`)}</ul>
      <h2>Photos</h2>${photoList(mine)}
      <h2>Analyses</h2>
      ${targets.map((w) => html`<p><button type="button" data-analyse="${w.id}">Measure ${w.data.label} in 3D</button></p>`)}
      <ul class="list" id="analyses">${analyses.map((a) => html`<li>${when(a.data.completed_at)}: ${figures(a.data)}</li>`)}</ul>
      ${advice.length ? html`<h2>Burn center advice</h2>${advice.map((a) => html`<p><strong>${a.data.note.consultant}</strong>: ${a.data.note.advice}</p>`)}` : ""}
      <h2>Report</h2>
      ${kept ? html`<p><a id="kept-report" href="${URL.createObjectURL(kept.blob)}" download="burn-report-${encounterId.slice(-6)}.pdf">Open the report kept on this phone</a>
        <span class="muted">(as made ${when(kept.fetched_at)})</span></p>` : ""}
      <p><button type="button" id="keep-report">${kept ? "Fetch the report again" : "Keep the report on this phone"}</button></p>`,
    {
      "#injury-form": {
        submit: async (event) => {
          event.preventDefault();
          const f = formData(event.target);
          const injured = iso(f.time_of_injury);
          // the records as they are now (a round may have brought the gateway's fuller version since the screen showed)
          const [nowEncounter, nowMechanism] = [await record("encounter", encounterId), await record("mechanism", encounterId)];
          if ((injured || null) !== (nowEncounter.data.time_of_injury || null)) {
            const data = { ...nowEncounter.data };
            if (injured) data.time_of_injury = injured;
            else delete data.time_of_injury;
            await edit("encounter", encounterId, data);
          }
          const enclosed = Boolean(f.enclosed_space);
          if (f.mechanism && (f.mechanism !== nowMechanism?.data.type || enclosed !== Boolean(nowMechanism?.data.enclosed_space))) {
            const data = { ...(nowMechanism?.data || { encounter_id: encounterId }), type: f.mechanism, enclosed_space: enclosed };
            await edit("mechanism", encounterId, data);
          }
          encounterScreen(encounterId);
        },
      },
      "#keep-report": {
        click: async () => {
          try {
            const held = await session();
            const response = await fetch(reportUrl, { headers: { Authorization: `Bearer ${held?.access_token}` }, cache: "no-store" });
            if (!response.ok) throw new Error((await response.json().catch(() => ({}))).detail || `report refused (${response.status})`);
            await put("documents", { url: reportUrl, blob: await response.blob(), fetched_at: new Date().toISOString() });
            encounterScreen(encounterId);
          } catch (error) {
            banner(error instanceof TypeError ? "The report needs the gateway: it is kept once fetched." : error.message, "error");
          }
        },
      },
      "[data-analyse]": {
        click: async (event) => {
          const woundId = event.target.dataset.analyse;
          try {
            const job = await call(`/api/v1/encounters/${encounterId}/analyses`, {
              method: "POST",
              body: woundId ? { wound_id: woundId } : {},
            });
            banner(`Measurement asked for (${job.state === "queued" ? "waiting its turn" : job.state}): its result comes to this phone when it is done.`, "ok");
          } catch (error) {
            banner(error instanceof NotInReach ? "Measuring needs the gateway: it waits until you are back in reach." : error.message, "error");
          }
        },
      },
    },
  );
}

function figures(analysis) {
  const m = analysis.result?.metrics || {};
  const c = analysis.result?.confidence;
  if (m.area_cm2 == null) return html`no measurement in cm (${analysis.result?.reason || analysis.result?.status})`;
  const scale = analysis.result?.scale?.method === "marker" ? "scale from the printed marker" : "scale from ruler points";
  return html`area ${m.area_cm2.toFixed(1)} cm², perimeter ${m.perimeter_cm?.toFixed(1) ?? "–"} cm,
    confidence ${c?.level || "not stated"} <span class="muted">(${scale}; decision support, not a diagnosis)</span>`;
}

function photoList(list) {
  if (!list.length) return html`<p class="muted">None yet.</p>`;
  return html`<ul class="list photos">${list.map((p) => {
    const verdict = p.asset?.verdict;
    const judged = verdict ? (verdict.accepted ? "usable" : `retake: ${verdict.guidance.join(" ")}`) : "";
    const kind = p.type?.startsWith("video/") ? "video · " : "";
    return html`<li data-photo="${p.id}" data-state="${p.state}">${kind}${when(p.taken_at)} · ${mb(p.size)} ·
      <span class="badge badge-${p.state}">${p.state === "stored" ? "at the gateway" : p.state}</span>
      ${judged ? html`<span class="verdict">${judged}</span>` : ""}${p.error ? html`<span class="error">${p.error}</span>` : ""}</li>`;
  })}</ul>`;
}

const FIELD_WORDS = { type: "kind of injury", time_of_injury: "time of injury", regions: "regions burned" };
const human = (field) => FIELD_WORDS[field] || field.replaceAll("_", " ");
const shown = (value) =>
  value == null || value === ""
    ? "not set"
    : value === true
      ? "yes"
      : value === false
        ? "no"
        : Array.isArray(value)
          ? value.map(shown).join(", ")
          : typeof value === "object"
            ? JSON.stringify(value)
            : String(value).replaceAll("_", " ");

// A change the gateway refused because someone saved that record first: who and when, each field both changed
// (the gateway's value beside the phone's), what only the gateway changed, and the nurse's choice.
function conflictItem(m) {
  const theirs = m.current?.data || {};
  const { both, gatewayOnly } = conflictFields(m);
  const by = m.current ? `${m.current.meta.updated_by}, ${when(m.current.meta.updated_at)}` : "someone else";
  return html`<li class="conflict" data-conflict="${m.seq}"><p><strong>The ${human(m.kind)} was changed at the gateway
      too</strong> <span class="muted">(by ${by})</span></p>
    <table><thead><tr><th></th><th>Gateway</th><th>This phone</th></tr></thead>
      <tbody>${both.map((k) => html`<tr><th>${human(k)}</th><td>${shown(theirs[k])}</td><td>${shown(m.data?.[k])}</td></tr>`)}</tbody></table>
    ${gatewayOnly.length ? html`<p class="muted">Changed only at the gateway, kept either way:
      ${gatewayOnly.map((k) => `${human(k)}: ${shown(theirs[k])}`).join("; ")}.</p>` : ""}
    <button type="button" data-keep-theirs="${m.seq}">Use the gateway's</button>
    <button type="button" data-keep-mine="${m.seq}">Keep mine</button></li>`;
}

export async function queueScreen() {
  const list = await photos();
  const changes = await waiting();
  show(
    html`<h1>Waiting on this phone</h1>
      <h2>Changes</h2>
      <ul class="list">${changes.map((m) => (m.state === "conflict" ? conflictItem(m) : html`<li>${m.op} ${m.kind}
        <span class="muted">${m.state}${m.error ? `: ${m.error}` : ""}</span></li>`))}</ul>
      <h2>Photos</h2>${photoList(list)}
      ${list.some((p) => p.state === "refused") ? html`<p><button type="button" id="forget-refused">Remove the refused photos</button></p>` : ""}`,
    {
      "[data-keep-theirs]": { click: (e) => settle(Number(e.target.dataset.keepTheirs), false).then(queueScreen) },
      "[data-keep-mine]": { click: (e) => settle(Number(e.target.dataset.keepMine), true).then(queueScreen) },
      "#forget-refused": {
        click: async () => {
          for (const p of list.filter((x) => x.state === "refused")) await forget(p.id);
          queueScreen();
        },
      },
    },
  );
}

export async function signedIn() {
  return Boolean((await kv.get("device")) && (await session()));
}
